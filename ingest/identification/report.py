"""An identification in words and files: the one sentence, the printed summary table, and the
fitted scene as a scene file with each fitted value's sd in a comment.

The scene file is a valid scene (:func:`fitted_scene_text` checks it by reading it back):
``trebuchet simulate``, ``sweep``, the FMU and every other command take it as they take the
scene it was fitted from. Keys the given scene left to their defaults stay so where the fit
did not move them (``I`` of a uniform beam whose mass was not fitted, ``H`` with the spigot on
the ground at the start).
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

import pandas as pd

from trebuchet.ingest.identification.parameters import follows_default_H, follows_default_I
from trebuchet.ingest.identification.result import Identification
from trebuchet.model.scene import Scene

__all__ = ["summary_text", "fitted_scene_text", "write_fitted_scene", "table_for_csv"]


def _number(value: float, sd: float = math.nan) -> str:
    """A value with as many digits as its sd asks (two significant digits of the sd, at
    least four of the value)."""
    if not math.isfinite(value):
        return ""
    if math.isfinite(sd) and sd > 0:
        digits = max(0, 1 - math.floor(math.log10(sd)))
        if abs(value) >= 1e-4 and digits <= 12:
            return f"{value:.{digits}f}"
    return f"{value:.4g}"


def summary_text(ident: Identification, *, log: str = "log", output: str | None = None,
                 table: str | None = None) -> str:
    """The summary ``trebuchet identify`` prints: the log and scene, the table in the scene's
    units, the residual check, the bearings' heat and the sentence."""
    lines = [f"log: {log}; scene: {Path(ident.given.source).name}",
             f"  {'parameter':28s}{'scene':>12s}{'fitted':>14s}{'sd':>11s}  unit"]
    for row in ident.table.itertuples(index=False):
        tag = "" if row.kind == "free" else f"  ({row.kind})"
        lines.append(f"  {row.parameter:28s}{_number(row.scene_value, row.sd):>12s}"
                     f"{_number(row.value, row.sd):>14s}{row.sd:>11.2g}  {row.unit}{tag}")
    lines.append(ident.check.describe())
    if ident.loss is not None:
        loss = ident.loss
        lines.append(f"bearings' heat by the release: {loss.joules:.4g} J (sd {loss.sd:.2g}; "
                     f"pivot {loss.pivot:.3g} J, hinge {loss.hinge:.3g} J), "
                     f"{100 * loss.fraction:.2f} % of ΔU (sd {100 * loss.fraction_sd:.2f})")
    lines.append(ident.sentence)
    for path in (output, table):
        if path:
            lines.append(f"-> {path}")
    return "\n".join(lines)


# --------------------------------------------------------------------------- the scene file


def _toml_value(value: Any, sd: float = math.nan) -> str:
    """A TOML value; a fitted number with three significant digits of its ``sd``."""
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    value = float(value)
    if math.isfinite(sd) and sd > 0:
        value = round(value, max(0, 2 - math.floor(math.log10(sd))))
    return repr(value) if not value.is_integer() else f"{value:.1f}"


def _comments(ident: Identification) -> dict[tuple[str, str], tuple[str, float]]:
    """``(section, key)`` -> the comment of each fitted value (its sd and the scene's) and the
    sd."""
    out = {}
    for row in ident.table.itertuples(index=False):
        section, _, key = row.parameter.partition(".")
        if not key:
            continue
        how = {"free": "fitted", "nuisance": "fitted (the log's)",
               "derived": "where the log puts the release"}[row.kind]
        scene = "" if not math.isfinite(row.scene_value) else \
            f"; the scene's {_number(row.scene_value)}"
        unit = "" if row.unit == "1" else f" {row.unit}"
        out[(section, key)] = (f"{how}: sd {row.sd:.2g}{unit}{scene}", float(row.sd))
    return out


def _fitted_dict(ident: Identification) -> dict[str, dict[str, Any]]:
    """The fitted scene's dict, with ``I`` and ``H`` left to their defaults where they
    follow them and the fit did not move them."""
    fitted, given = ident.scene, ident.given
    data = fitted.to_dict()
    eng = data["engine"]
    if "engine.I" not in ident.free and follows_default_I(fitted) and follows_default_I(given):
        eng.pop("I", None)
    if "engine.H" not in ident.free and follows_default_H(given) and follows_default_H(fitted):
        eng.pop("H", None)
    for key in ("L1", "L2", "L_CM", "L3", "L4", "m_b", "M", "m"):  # untouched: as written
        if key in eng and f"engine.{key}" not in ident.free:
            eng[key] = getattr(given.engine, key)
    return data


def fitted_scene_text(ident: Identification, *, log: str = "log") -> str:
    """The fitted scene as a scene file (module doc), checked by reading it back."""
    data = _fitted_dict(ident)
    comments = _comments(ident)
    head = [f"# Fitted by trebuchet identify to {log} from {Path(ident.given.source).name}.",
            f"# {ident.check.describe()}",
            f"# {ident.sentence}"]
    head += [f"# warning: {w}" for w in ident.warnings]
    lines = [h.replace("\n", " ") for h in head]
    for section, values in data.items():
        lines += ["", f"[{section}]"]
        for key, value in values.items():
            note, sd = comments.get((section, key), (None, math.nan))
            text = f"{key} = {_toml_value(value, sd)}"
            lines.append(text + (f"  # {note}" if note else ""))
    text = "\n".join(lines) + "\n"
    Scene.from_dict(tomllib.loads(text), source="the fitted scene")  # valid, or a bug here
    return text


def write_fitted_scene(ident: Identification, target: str | Path, *, log: str = "log",
                       inputs: list[str | Path | None] | None = None) -> None:
    """Write :func:`fitted_scene_text` to ``target`` whole or not at all, never over one of
    the command's ``inputs`` (:func:`trebuchet.core.output.atomic_path`)."""
    from trebuchet.core.output import atomic_path

    text = fitted_scene_text(ident, log=log)
    with atomic_path(target, inputs=inputs or ()) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")


def table_for_csv(ident: Identification) -> pd.DataFrame:
    """The table as ``--table`` writes it (the columns of :data:`~.result.TABLE_COLUMNS`)."""
    return ident.table.copy()
