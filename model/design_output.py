"""What ``trebuchet design`` writes: the best design as a scene file with a comment block,
a short table of the start against the best, and the trade as a figure.

The scene file is TOML written here (no writer among the dependencies): the sections and keys
of ``Scene.to_dict``, numbers as Python's shortest round-trip ``repr``, words as TOML basic
strings, the moment of inertia ``I`` and the pivot height ``H`` left out where they are the
defaults the reader computes (so that the file reads back to the same scene, and they follow
the lengths when a user edits them). ``Scene.from_toml`` reads it back.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from trebuchet.core.output import atomic_path
from trebuchet.model.design import DesignResult, figure_unit
from trebuchet.model.scene import Scene, default_moment_of_inertia

__all__ = ["scene_toml", "comment_block", "summary_table", "write_best", "plot_trade",
           "pareto_front"]


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        value = float(value)
        if not math.isfinite(value):
            raise ValueError(f"{value}: a scene holds finite numbers only")
        return repr(value)
    return json.dumps(str(value), ensure_ascii=False)  # a TOML basic string


def scene_toml(scene: Scene, comments: Sequence[str] = ()) -> str:
    """The scene as the text of a scene file, after ``comments`` (one ``#`` line each)."""
    data = scene.to_dict()
    e, s = scene.engine, scene.start
    eng = data.get("engine", {})
    if "I" in eng and math.isclose(e.I, default_moment_of_inertia(e.m_b, e.L1, e.L2),
                                   rel_tol=1e-12):
        del eng["I"]
    if "H" in eng and math.isclose(s.H, -e.L1 * math.sin(s.theta), rel_tol=1e-12):
        del eng["H"]
    lines = [f"# {c}".rstrip() for c in comments]
    for section, keys in data.items():
        if not keys:
            continue
        lines += ["", f"[{section}]"]
        lines += [f"{k} = {_toml_value(v)}" for k, v in keys.items()]
    return "\n".join(lines).lstrip("\n") + "\n"


def _number(value: float, unit: str = "") -> str:
    if not math.isfinite(value):
        return "–"
    text = f"{value:.6g}"
    return f"{text} {unit}".rstrip() if unit and unit != "1" else text


def comment_block(result: DesignResult, source: str) -> list[str]:
    """The comment lines of BEST.toml: objective, each limit and its margin, the keys."""
    obj, unit = result.objective, figure_unit(result.objective)
    start = result.start_figures[obj]
    change = (f", {100 * (result.value - start) / abs(start):+.3g} %"
              if math.isfinite(start) and start else "")
    lines = [f"Designed by trebuchet design from {source}"
             + (f" (seed {result.seed}" if result.seed is not None else " (no seed")
             + f", {result.evaluations} designs simulated).",
             f"Objective: {result.sense} {obj} = {_number(result.value, unit)} "
             f"(start {_number(start, unit)}{change}).",
             "Limits, each with its margin (how far inside it the design stays):"]
    binding = result.binding
    for c in result.limits:
        u = figure_unit(c.limit.figure)
        lines.append(f"  {c.limit.text} {u}: {c.value:.9g} {u}, margin "
                     f"{_number(c.margin, u)} ({100 * c.relative:.3g} %)"
                     + ("  <- binding" if c is binding else ""))
    if not result.limits:
        lines.append("  (none)")
    lines.append("Varied: " + "; ".join(
        f"{k} = {result.params[k]:.6g}" for k in result.params) + ".")
    friction = result.scene.to_dict().get("friction", {})
    for key, figure, tau in result.sizing.rules:
        stress = key.replace("radius", "shear_stress")
        lines.append(f"Sized: friction.{key} = {friction[key]:.6g} m = sqrt({figure} / (2 pi "
                     f"tau)), {figure} = {result.figures[figure]:.6g} N, tau = {tau:g} Pa "
                     f"([sizing] {stress} = {tau!r}; put it back in the scene to design on).")
    lines.append("Verified by simulating it again at the default accuracy (the summary path "
                 "and simulate's table).")
    return lines


def write_best(result: DesignResult, target: str | Path, source: str, *,
               inputs: Sequence[str | Path] = ()) -> None:
    """BEST.toml, whole or not at all (never over one of the command's ``inputs``)."""
    text = scene_toml(result.scene, comment_block(result, source))
    with atomic_path(target, inputs=inputs) as tmp:
        tmp.write_text(text, encoding="utf-8")


def summary_table(result: DesignResult) -> str:
    """Start against best: the varied keys, the objective and every limited figure."""
    rows: list[tuple[str, str, str, str]] = []
    for k, v in result.params.items():
        rows.append((k, _number(result.start_params.get(k, math.nan)), _number(v), ""))
    obj, unit = result.objective, figure_unit(result.objective)
    rows.append((f"{obj} ({unit})", _number(result.start_figures[obj]),
                 _number(result.value), result.sense))
    for c in result.limits:
        f = c.limit.figure
        rows.append((f"{f} ({figure_unit(f)})", _number(result.start_figures[f]),
                     _number(c.value), f"{c.limit.op} {c.limit.value:.6g}, margin "
                                       f"{100 * c.relative:.3g} %"))
    head = ("", "start", "best", "")
    widths = [max(len(r[i]) for r in [head, *rows]) for i in range(4)]
    fmt = "{:<%d}  {:>%d}  {:>%d}  {:<%d}" % tuple(widths)  # noqa: UP031 - widths
    return "\n".join(fmt.format(*r).rstrip() for r in [head, *rows])


def pareto_front(x: np.ndarray, y: np.ndarray, x_smaller: bool, y_larger: bool) -> np.ndarray:
    """Indices of the points no other point beats in both ``x`` (smaller better if
    ``x_smaller``) and ``y`` (larger better if ``y_larger``), sorted by ``x``."""
    sx = np.where(x_smaller, x, -x)
    sy = np.where(y_larger, y, -y)
    order = np.lexsort((-sy, sx))
    front, best = [], -math.inf
    for i in order:
        if sy[i] > best:
            front.append(i)
            best = sy[i]
    return np.array(sorted(front, key=lambda i: x[i]), dtype=int)


def _zoom(ax: Any, x: np.ndarray, y: np.ndarray, xs: Sequence[float],
          ys: Sequence[float]) -> None:
    """Limits that show the bulk of the designs (2nd to 98th percentile) and the marks."""
    if x.size < 10:
        return
    for data, marks, setter in ((x, xs, ax.set_xlim), (y, ys, ax.set_ylim)):
        ok = [v for v in marks if math.isfinite(v)]
        lo = min(np.percentile(data, 2), *ok)
        hi = max(np.percentile(data, 98), *ok)
        pad = 0.05 * (hi - lo) or 1.0
        setter(lo - pad, hi + pad)


def plot_trade(result: DesignResult, target: str | Path, *,
               inputs: Sequence[str | Path] = ()) -> None:
    """The objective against the binding limit's figure over every design the search ran
    that meets the other limits, its Pareto front, the limit, the start and the best."""
    from matplotlib.figure import Figure

    h: pd.DataFrame = result.history[result.history["status"] == "ok"]
    obj = result.objective
    binding = result.binding
    fig = Figure(figsize=(7.0, 4.8), layout="constrained")
    ax = fig.add_subplot()
    if binding is None:  # nothing to trade against: the objective over the search
        ax.plot(np.arange(len(h)), h[obj], ".", color="0.6", label="designs tried")
        ax.set_xlabel("design (order of the search)")
    else:
        lim = binding.limit
        others = [c.limit for c in result.limits if c is not binding]
        keep = np.ones(len(h), dtype=bool)
        for o in others:
            keep &= (h[o.figure] <= o.value) if o.op == "<=" else (h[o.figure] >= o.value)
        x, y = h[lim.figure].to_numpy(), h[obj].to_numpy()
        ax.plot(x[~keep], y[~keep], ".", color="0.85", label="break another limit")
        ax.plot(x[keep], y[keep], ".", color="0.55", label="meet the other limits")
        if keep.sum() > 1:
            front = pareto_front(x[keep], y[keep], lim.op == "<=", result.sense == "maximize")
            ax.plot(x[keep][front], y[keep][front], "-", color="C0", label="Pareto front")
        ax.axvline(lim.value, color="C3", ls="--", lw=1, label=f"limit {lim.text}")
        ax.plot([result.start_figures[lim.figure]], [result.start_figures[obj]], "o",
                color="k", ms=8, label="start")
        ax.plot([binding.value], [result.value], "*", color="C3", ms=14, label="best")
        ax.set_xlabel(f"{lim.figure} ({figure_unit(lim.figure)})")
        _zoom(ax, x[keep], y[keep], [lim.value, binding.value, result.start_figures[lim.figure]],
              [result.value, result.start_figures[obj]])
    ax.set_ylabel(f"{obj} ({figure_unit(obj)})")
    ax.set_title(f"{result.sense} {obj}: the trade against the binding limit", fontsize=10)
    ax.legend(fontsize=8, loc="best")
    with atomic_path(target, inputs=inputs) as tmp:
        fig.savefig(tmp, dpi=120, format="png")

