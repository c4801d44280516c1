"""``compare --fit``: the scene as given and as fitted to the shot, side by side, and which of
its parameters carry the difference.

The engine fitted to the log (:func:`~trebuchet.ingest.identification.identify.identify`: the
one ``reconstruct`` fitted for the loads, or a fit of its own where the loads are the
smoother's) is simulated at the log's frames as the given scene is, and compared with the same
measured loads and the same chance levels (those of the measured loads' error; the fitted
engine differs from the given one only in its parameters). A freed key differs from the scene's
where the fitted value lies more than :data:`DIFFERS_SD` of its sd away; the sentence names
those, by how much, and how the verdicts change. By default (``fit=None``) the fitted scene is
shown where the given one differs from the measurement in some quantity.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from trebuchet.ingest.compare import CompareOptions, compare_measured
from trebuchet.ingest.compare_chance import with_chance
from trebuchet.ingest.identification.identify import identify
from trebuchet.ingest.identification.result import Identification
from trebuchet.ingest.reconstruction import reconstruction_of
from trebuchet.model.scene import Scene
from trebuchet.report.verdict import DISPLAY

__all__ = ["FittedComparison", "fitted_comparison", "DIFFERS_SD", "IDENTIFY_KEYWORDS"]

#: A fitted key this many sd from the scene's value carries a difference.
DIFFERS_SD = 2.0
#: The options of ``compare`` that ``identify`` takes too.
IDENTIFY_KEYWORDS = ("fps", "columns", "points", "events", "image_calibration",
                     "min_likelihood", "time_unit", "angle_unit", "individual", "calibration")


@dataclass(frozen=True)
class FittedComparison:
    """The scene as fitted beside the scene as given: the ``identification``, the fitted
    scene's ``metrics`` and ``predicted`` frame (as ``compare`` gives them for the given
    scene), ``side_by_side`` (per quantity: outside fraction and verdict of each), ``keys``
    (per freed key: the scene's value, the fitted one, its sd, the difference in sd) and the
    ``sentence`` of the verdict."""

    identification: Identification
    metrics: pd.DataFrame
    predicted: pd.DataFrame
    side_by_side: pd.DataFrame
    keys: pd.DataFrame
    sentence: str


def _identification(measured: pd.DataFrame, log: Any, scene: Scene,
                    options: Mapping[str, Any]) -> Identification:
    """The identification ``reconstruct`` made for the loads, else one of the log."""
    done = reconstruction_of(measured).identification
    if done is not None:
        return done
    return identify(log, scene, **{k: v for k, v in options.items()
                                   if k in IDENTIFY_KEYWORDS and v is not None})


def _key_table(ident: Identification) -> pd.DataFrame:
    free = ident.table[ident.table["kind"] == "free"]
    rows = []
    for r in free.itertuples(index=False):
        off = (r.value - r.scene_value) / r.sd if r.sd > 0 else math.inf
        rows.append({"parameter": r.parameter, "scene": r.scene_value, "fitted": r.value,
                     "sd": r.sd, "unit": r.unit,
                     "fitted / scene": r.value / r.scene_value if r.scene_value else math.nan,
                     "difference (sd)": off})
    return pd.DataFrame(rows)


def _side_by_side(given: pd.DataFrame, fitted: pd.DataFrame) -> pd.DataFrame:
    out = pd.DataFrame({"quantity": [DISPLAY.get(q, (q, ""))[0] for q in given["quantity"]]})
    for label, table in (("as given", given), ("as fitted", fitted)):
        out[f"outside ±2 sd, {label} (%)"] = 100 * table["outside_band_fraction"].to_numpy()
        if "verdict" in table:
            out[f"verdict, {label}"] = table["verdict"].to_numpy()
    return out


def _sentence(ident: Identification, keys: pd.DataFrame, given: pd.DataFrame,
              fitted: pd.DataFrame) -> str:
    parts = []
    for r in keys.to_dict("records"):
        if not abs(r["difference (sd)"]) > DIFFERS_SD:
            continue
        short = r["parameter"].partition(".")[2]
        how = (f"{r['fitted'] / r['scene']:.2f} × the scene's"
               if r["scene"] and not r["parameter"].endswith("_mu")
               else f"{r['fitted']:.3g} against {r['scene']:.3g}")
        parts.append(f"{short} ({how}, {abs(r['difference (sd)']):.1f} sd)")
    if parts:
        text = "the shot differs from the scene in " + ", ".join(parts)
    else:
        text = (f"no fitted key differs from the scene's by more than {DIFFERS_SD:g} sd "
                f"({', '.join(keys['parameter'])} fitted)")
    if ident.loss is not None:
        text += (f"; friction takes {100 * ident.loss.fraction:.1f} % (sd "
                 f"{100 * ident.loss.fraction_sd:.1f}) of ΔU by the release")
    if "verdict" in given and "verdict" in fitted:
        n = len(given)
        agree = [int((t["verdict"] == "agrees").sum()) for t in (given, fitted)]
        text += (f"; as fitted, the model agrees within chance in {agree[1]} of {n} quantities "
                 f"(as given: {agree[0]})")
    if not ident.passed:
        text += ("; but the fitted engine does not explain the shot either (its residual "
                 "check fails: " + (ident.warnings[0] if ident.warnings else "see the "
                                    "warnings") + ")")
    return text


def fitted_comparison(measured: pd.DataFrame, given: pd.DataFrame, scene: Scene,
                      options: CompareOptions, log: str | Path | pd.DataFrame,
                      log_options: Mapping[str, Any] | None = None, *,
                      fit: bool | None = None) -> FittedComparison | None:
    """The scene as fitted beside ``given`` (the given scene's metrics, from ``compare``):
    always for ``fit=True``, never for ``False``, and for ``None`` (the default) where the
    given scene differs from the measurement in some quantity. ``log`` and ``log_options``
    (``compare``'s) identify the engine where ``measured`` holds no identification."""
    if fit is False:
        return None
    differs = "verdict" in given and (given["verdict"] == "differs").any()
    if fit is None and not differs:
        return None
    ident = _identification(measured, log, scene, log_options or {})
    table, predicted = compare_measured(measured, ident.scene, options)
    if "chance_limit" in given:
        attrs = dict(table.attrs)
        chance = given[["quantity", *[c for c in ("chance_fraction", "chance_limit",
                                                  "chance_limit_all", "effective_samples")
                                      if c in given]]]
        table = with_chance(table, chance, measured, predicted, options.band_sd)
        table.attrs.update(attrs)
    keys = _key_table(ident)
    return FittedComparison(identification=ident, metrics=table, predicted=predicted,
                            side_by_side=_side_by_side(given, table), keys=keys,
                            sentence=_sentence(ident, keys, given, table))

