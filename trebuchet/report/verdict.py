"""The compare report's first screen: a verdict per quantity and tables in the figures' units.

The metrics (:func:`trebuchet.ingest.compare.metrics`, SI, fractions) are shown as people
read the figures: forces in m·g (the sling) or M·g (beam and counterweight), torque in
kN m, power in kW, energy in kJ, times in ms after the log's trigger, fractions in %.
The verdict says for each quantity whether the prediction leaves the measured ±2 sd band
no more often than chance allows (``chance_limit``; see
:func:`trebuchet.ingest.compare.chance_levels`) and, where it leaves it more often, when
and by how much.
"""

from __future__ import annotations

import html
import math

import pandas as pd

from trebuchet.model.scene import Scene
from trebuchet.report.page import table_html

__all__ = ["DISPLAY", "display_scale", "verdict_html", "verdict_table", "details_table",
           "events_table"]

#: quantity: (short name for the tables, unit kind)
DISPLAY: dict[str, tuple[str, str]] = {
    "F_S_abs": ("|F_S| sling force", "mg"),
    "F_H_abs": ("|F_H| hinge force", "Mg"),
    "F_R_abs": ("|F_R| pivot reaction", "Mg"),
    "F_R_x": ("F_R,x horizontal, at the pivot", "Mg"),
    "F_R_perp": ("F_R⊥ across the beam", "Mg"),
    "torque": ("torque on the beam", "kN m"),
    "P_m": ("P_m power to the projectile", "kW"),
    "E_m": ("E_m energy of the projectile", "kJ"),
    "E_M": ("E_M energy of the counterweight", "kJ"),
    "E_beam": ("E_beam energy of the beam", "kJ"),
}


def display_scale(quantity: str, scene: Scene) -> tuple[float, str]:
    """``(divisor, unit)`` that turns the SI value of ``quantity`` into the figures' unit."""
    kind = DISPLAY.get(quantity, (quantity, ""))[1]
    e = scene.engine
    return {"mg": (e.m * scene.g, "m·g"), "Mg": (e.M * scene.g, "M·g"),
            "kN m": (1e3, "kN m"), "kW": (1e3, "kW"), "kJ": (1e3, "kJ")}.get(kind, (1.0, ""))


def _kn(value_si: float, unit: str) -> str:
    """`` (497 kN)`` beside a force in m·g or M·g (which could be read as megagrams)."""
    if unit not in ("m·g", "M·g") or value_si is None or not math.isfinite(value_si):
        return ""
    return f" ({_num(value_si / 1e3)}\u00a0kN)"  # no break inside "(480 kN)"


def _num(value: float, digits: int = 3) -> str:
    if value is None or not math.isfinite(value):
        return "–"
    return f"{value:.{digits}g}"


def _pct(value: float) -> str:
    """A fraction in %: one decimal (13.1 % and 12.7 % must not both read 13 %), 0 as 0."""
    if value is None or not math.isfinite(value):
        return "–"
    return "0 %" if value == 0 else f"{100 * value:.1f} %"


#: Outside fraction of a correct model for Gaussian errors and a ±2 sd band (2 Φ(−2)).
NOMINAL = math.erfc(2.0 / math.sqrt(2.0))
#: A chance fraction this many times the nominal one: the band understates the error.
NARROW = 3.0


def _stretch(row: pd.Series, release_ms: float | None) -> str:
    start, end = 1e3 * row["outside_start"], 1e3 * row["outside_end"]
    worst = row["outside_worst_sd"]
    side = "above" if worst > 0 else "below"
    when = f"{start:.0f}–{end:.0f} ms"
    if release_ms is not None and start > release_ms:
        when += " (after release, beyond the time figures, which stop there)"
    return f"predicted {side} the band at {when}, by up to {abs(worst):.1f} sd"


def _where(row: pd.Series, release_ms: float | None) -> str:
    """"agrees", "borderline" or "differs", and where and how the prediction leaves the band;
    a band that even a correct model leaves far more often than nominal is said to be
    narrow."""
    if not math.isfinite(row.get("chance_limit", math.nan)):
        return "no verdict (chance not estimated)"
    verdict = row.get("verdict") or ("agrees" if row["within_chance"] else "differs")
    if verdict == "agrees":
        text = "agrees"
        if math.isfinite(row.get("outside_start", math.nan)):
            when = _stretch(row, release_ms).split(" at ", 1)[1]
            text += f" (outside mostly at {when})"
        if row["chance_fraction"] > NARROW * NOMINAL:
            text += (f"; but the band is narrow: even a correct model leaves it on "
                     f"{_pct(row['chance_fraction'])} of the rows")
        return text
    if verdict == "borderline":
        limit = row.get("chance_limit_all", math.nan)
        return (f"borderline: {_stretch(row, release_ms)}; more often than chance allows for "
                f"one quantity, not for all ten at once (≤ {_pct(limit)})")
    return f"differs: {_stretch(row, release_ms)}"


def verdict_table(table: pd.DataFrame, scene: Scene, release_ms: float | None = None
                  ) -> tuple[pd.DataFrame, list[str]]:
    """The short table of the first screen (one row per quantity: peaks in the figures'
    units, outside fraction, what chance allows, verdict) and the rows' classes."""
    rows, classes = [], []
    for _, r in table.iterrows():
        scale, unit = display_scale(r["quantity"], scene)
        name = DISPLAY.get(r["quantity"], (r["label"], ""))[0]
        rows.append({
            "quantity": name,
            "peak measured ± sd": (f"{_num(r['measured_peak'] / scale)} ± "
                                   f"{_num(r['measured_peak_sd'] / scale, 2)} {unit}"
                                   + _kn(r["measured_peak"], unit)),
            "peak predicted": (f"{_num(r['predicted_peak'] / scale)} {unit}"
                               + _kn(r["predicted_peak"], unit)),
            "outside ±2 sd": _pct(r["outside_band_fraction"]),
            "chance allows": ("≤ " + _pct(r["chance_limit"])
                              if math.isfinite(r.get("chance_limit", math.nan)) else "–"),
            "verdict": _where(r, release_ms),
        })
        verdict = r.get("verdict") or ("agrees" if r.get("within_chance", True) else "differs")
        classes.append({"differs": "differ", "borderline": "borderline"}.get(verdict, ""))
    return pd.DataFrame(rows), classes


def verdict_html(table: pd.DataFrame, scene: Scene, *, release_ms: float | None = None,
                 level: float = 0.95) -> str:
    """The verdict block: a sentence a reader can act on, what chance allows and why, and
    the short table (escaped)."""
    esc = html.escape
    have = table["chance_limit"].notna() if "chance_limit" in table else None
    short, classes = verdict_table(table, scene, release_ms)
    if have is None or not have.any():
        head = ("No verdict: what chance allows was not estimated (chance_runs = 0). The "
                "table gives the fraction of the shot outside the measured ±2 sd band.")
        css = ""
    else:
        verdicts = (table["verdict"] if "verdict" in table else
                    table["within_chance"].map({True: "agrees", False: "differs"}))
        differ = [DISPLAY.get(q, (q, ""))[0] for q in table.loc[verdicts == "differs",
                                                               "quantity"]]
        border = [DISPLAY.get(q, (q, ""))[0] for q in table.loc[verdicts == "borderline",
                                                               "quantity"]]
        n = len(table)
        others = n - len(differ) - len(border)
        if not differ:
            head = ("Model and measurement agree: "
                    + (f"every one of the {n} quantities stays within the measured ±2 sd band "
                       "as often as chance allows." if not border else
                       f"no quantity leaves the measured ±2 sd band more often than chance "
                       f"allows for {n} quantities at once; {', '.join(border)} "
                       f"{'is' if len(border) == 1 else 'are'} borderline (more often than "
                       "for a single quantity), where the table says."))
            css = "agree"
        else:
            head = ("Model and measurement differ in "
                    + (f"all {n}" if len(differ) == n else f"{len(differ)} of {n}")
                    + f" quantities ({', '.join(differ)}): the prediction leaves the measured "
                    "±2 sd band more often than chance allows, where the table says"
                    + (f"; {', '.join(border)} borderline" if border else "")
                    + {0: ".", 1: "; the other agrees."}.get(others, "; the others agree."))
            css = "differ"
    n_eff = table["effective_samples"] if "effective_samples" in table else None
    span = (f"{n_eff.min():.0f} to {n_eff.max():.0f}" if n_eff is not None
            and n_eff.notna().any() else "–")
    why = ("Even a perfect model leaves the band on about 5 % of the rows, and because "
           "neighbouring frames of a smoothed log share their errors, one shot holds only "
           f"{span} independent samples per quantity, so the outside fraction of one shot "
           f"varies widely: \u201cchance allows\u201d is its {100 * level:.0f} % limit, "
           "found by reconstructing logs simulated from the model with this log's noise. "
           "Ten quantities are compared, so one of them above its limit now and then is "
           "chance too: a quantity differs when it is above the limit for all ten at once "
           f"({100 - (100 - 100 * level) / len(table):.1f} %), and is borderline between "
           "the two.")
    return (f'<div class="verdict {css}" id="verdict"><p><strong>{esc(head)}</strong></p>'
            + table_html(short, css_class="main", stack=True, row_classes=classes)
            + f'<p class="small">{esc(why)}</p></div>')


def details_table(table: pd.DataFrame, scene: Scene) -> pd.DataFrame:
    """Every metric in the figures' units (times ms after the log's trigger, fractions %)."""
    rows = []
    for _, r in table.iterrows():
        scale, unit = display_scale(r["quantity"], scene)
        rows.append({
            "quantity": r["quantity"], "unit": unit,
            "measured peak": r["measured_peak"] / scale,
            "sd": r["measured_peak_sd"] / scale,
            "at (ms)": 1e3 * r["measured_peak_time"],
            "predicted peak": r["predicted_peak"] / scale,
            "at (ms) ": 1e3 * r["predicted_peak_time"],
            "peak difference (sd)": r["peak_difference_in_sd"],
            "RMS difference": r["rms_difference"] / scale,
            "RMS / peak (%)": 100 * r["rms_difference_rel"],
            "outside ±2 sd (%)": 100 * r["outside_band_fraction"],
            "chance: mean (%)": 100 * r.get("chance_fraction", math.nan),
            "chance: limit (%)": 100 * r.get("chance_limit", math.nan),
            "chance: limit, all ten (%)": 100 * r.get("chance_limit_all", math.nan),
            "independent samples": r.get("effective_samples", math.nan),
            "rows": int(r["rows"]),
            "from (ms)": 1e3 * r["window_start"], "to (ms)": 1e3 * r["window_end"],
        })
    return pd.DataFrame(rows)


def events_table(events: pd.DataFrame) -> pd.DataFrame:
    """The events in ms after the log's detected trigger."""
    names = {"start": "start of motion", "lift_off": "lift-off", "release": "release"}
    return pd.DataFrame({
        "event": [names.get(e, e) for e in events["event"]],
        "measured (ms)": 1e3 * events["measured"],
        "sd (ms)": 1e3 * events["measured_sd"],
        "predicted (ms)": 1e3 * events["predicted"],
        "predicted − measured (ms)": 1e3 * events["difference"],
    })
