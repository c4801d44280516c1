"""Design an engine under limits on its loads: the paper's optimisation as a function.

The paper's engine "is optimized to throw 100 kg stones a distance of 450 m in vacuum" by a
procedure that "limits internal forces" (Horsdal, Section 1). :func:`design` does that for
any scene: it varies the scene keys it is given between their bounds, maximises (or
minimises) one figure of the sweep table and keeps every limit::

    import trebuchet as tb
    result = tb.design("paper_40deg.toml",
                       vary={"engine.L4": (3, 8), "engine.L3": (1, 4),
                             "release.velocity_angle_deg": (25, 55)},
                       maximize="range",
                       limits=["F_R_peak <= 468905", "F_S_peak <= 54010",
                               "cw_clearance >= 1.0"], seed=1)
    result.scene, result.figures["range"], result.limits, result.history

The search (:mod:`trebuchet.model.design_search`): differential evolution with the limits as
constraints, then SLSQP, every design on the sweep's summary-only path, in local worker
processes or on a Dask cluster as a sweep. The best design is then **verified**: simulated
again at the default accuracy, both on the summary path and as ``simulate``'s table; a design
that breaks a limit in either is never reported (the next best is tried). Limits no design
between the bounds meets are refused, naming the limit that came closest and by how much.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Any

import pandas as pd
from tqdm.auto import tqdm

from trebuchet.core.errors import ModelValidityWarning, TrebuchetInputError
from trebuchet.model.design_problem import Limit, make_problem
from trebuchet.model.design_search import Evaluator, SearchOptions, search
from trebuchet.model.design_sizing import Sizing, read_scene, sized
from trebuchet.model.scene import Scene, as_scene
from trebuchet.model.shot_summary import FIGURES, shot_figures
from trebuchet.model.simulate import simulate
from trebuchet.model.sweep import (
    MAX_DESIGNS,
    Budget,
    DesignRunner,
    SimulationOptions,
    design_scene,
    evaluate_design,
    summarize,
)
from trebuchet.model.sweep_design import batched

__all__ = ["design", "DesignResult", "LimitCheck", "figure_unit"]

_VERIFY_TRIES = 10


def figure_unit(figure: str) -> str:
    """The SI unit of a figure of :data:`FIGURES` (``"N"``, ``"m"``, ``"1"``, ...)."""
    return FIGURES[figure].split(",")[0]


@dataclass(frozen=True)
class LimitCheck:
    """A limit on the best design: its ``value`` (the stricter of the summary path and the
    re-simulated table) and ``margin`` (how far inside, in the figure's unit; ≥ 0: met)."""

    limit: Limit
    value: float
    margin: float

    @property
    def relative(self) -> float:
        """The margin over the limit's value (1e-2 is 1 %)."""
        return self.margin / self.limit.scale

    @property
    def met(self) -> bool:
        return self.margin >= 0.0


@dataclass(frozen=True)
class DesignResult:
    """The best design a search found and verified.

    ``scene``: the best design; ``params``: its values of the varied keys; ``figures``: its
    figures (SI, the sweep table's columns, summary path at the default accuracy);
    ``table_figures``: the same from ``simulate``'s table (rows every 1 ms), the check;
    ``limits``: every limit with its margin; ``start_params``, ``start_figures``,
    ``start_status``: the scene the search started from; ``history``: every design the search
    ran (stage ``search`` or ``polish``, generation, keys, status, figures, ``feasible``);
    ``seed``: the search's seed; ``sizing``: the sizing rules that set the best design's
    shaft radii (:mod:`trebuchet.model.design_sizing`)."""

    scene: Scene
    params: dict[str, float]
    objective: str
    sense: str
    figures: dict[str, float]
    table_figures: dict[str, float]
    limits: tuple[LimitCheck, ...]
    start_params: dict[str, float]
    start_figures: dict[str, float]
    start_status: str
    history: pd.DataFrame
    seed: int | None
    sizing: Sizing = Sizing()

    @property
    def value(self) -> float:
        """The objective's value at the best design (SI)."""
        return self.figures[self.objective]

    @property
    def evaluations(self) -> int:
        """Designs simulated by the search (each once)."""
        return len(self.history)

    @property
    def binding(self) -> LimitCheck | None:
        """The limit with the least relative margin (the one that holds the design back)."""
        return min(self.limits, key=lambda c: c.relative) if self.limits else None


def design(scene: Scene | str | Path, vary: Mapping[str, Any], maximize: str | None = None,
           minimize: str | None = None, limits: Sequence[str | Limit] = (), *,
           seed: int | None = None, workers: int | None = None, executor: Any = None,
           progress: bool = False, options: SimulationOptions | None = None,
           budget: Budget | None = None, search_options: SearchOptions | None = None,
           sizing: Sizing | None = None) -> DesignResult:
    """The design that maximises (or minimises) a figure within the limits.

    Parameters
    ----------
    scene : Scene or path
        The start: every key not varied keeps its value. A scene file may hold a ``[sizing]``
        section (:mod:`trebuchet.model.design_sizing`).
    vary : mapping of "section.key" to (lo, hi) or "lo:hi"
        The keys to vary (units of the scene file) and their bounds.
    maximize, minimize : str
        Exactly one: a figure of the sweep table (``range``, ``F_R_peak``, ..., or
        ``cw_clearance``).
    limits : sequence of "FIGURE<=VALUE" / "FIGURE>=VALUE" or Limit
        What every design must meet, SI units.
    seed : int, optional
        Makes the search repeatable.
    workers, executor :
        Where designs run, as :func:`trebuchet.model.sweep.sweep`, but for the default: in
        this process wherever the generated C runs designs many a call (no sizing rules, no
        output step). A search's batches are small (a generation of a few dozen designs, a
        polish step of a few), and worker processes' round trips and start-up cost more
        than they save there (docs/benchmarks.md, "Design under limits"); a design then has
        no time or memory budget. Give ``workers`` to run them in worker processes.
    progress : bool
        A progress bar on stderr.
    options, budget :
        How each design is simulated and what it may cost, as for a sweep.
    search_options : SearchOptions
        Population, generations, polish.
    sizing : Sizing, optional
        Shafts sized from their peak loads (default: the scene file's ``[sizing]``, if any).

    Returns
    -------
    DesignResult. Raises TrebuchetInputError for an unknown key or figure, bounds the wrong
    way round, a limit that does not parse, and limits no design between the bounds meets.
    """
    if isinstance(scene, str | Path):
        base, from_file = read_scene(scene)
        sizing = from_file if sizing is None else sizing
    else:
        base = as_scene(scene, "design")
    options = options or SimulationOptions()
    if sizing is not None:
        options = replace(options, sizing=sizing)
    problem = make_problem(base, vary, maximize, minimize, limits)
    clash = [k for k in options.sized_keys if k in problem.keys]
    if clash:
        raise TrebuchetInputError(f"--vary {clash[0]}: a [sizing] rule sets it from each "
                                  "design's peak load; vary something else")
    budget = budget or Budget()
    options.check()
    budget.check()
    opts = search_options or SearchOptions()
    opts = replace(opts, seed=seed if seed is not None else opts.seed)
    budget_designs = opts.popsize * len(problem.variables) * (opts.generations + 1)
    if not (opts.popsize >= 1 and opts.generations >= 1 and budget_designs <= MAX_DESIGNS):
        raise TrebuchetInputError(f"design: --popsize {opts.popsize} x {len(problem.variables)}"
                                  f" keys x --generations {opts.generations}: at most "
                                  f"{MAX_DESIGNS:,} designs, each at least 1")
    start = evaluate_design(base, (-1, {}), options=options)
    start_figures = {k: start[k] for k in FIGURES}
    scale = abs(start_figures[problem.objective])
    scale = scale if math.isfinite(scale) and scale > 0 else 1.0
    start_params = problem.start_params()
    start_u = problem.unit(start_params)
    total = opts.popsize * len(problem.variables) * (opts.generations + 1) + 8 * len(
        problem.variables) * (opts.polish_steps // 4 if opts.polish else 0)
    if workers is None and executor is None and batched(options):
        workers = 1  # small batches: the C runs them here, many a call (``workers`` doc)
    with DesignRunner(base, executor=executor, workers=workers, options=options,
                      budget=budget) as runner, \
            tqdm(total=total, disable=not progress, unit="design", desc="design") as bar:
        ev = Evaluator(problem, lambda items: [r for b in runner.run(items) for r in b],
                       on_batch=lambda _, n: bar.update(n))
        ranked = search(ev, opts, start_u if all(map(math.isfinite, start_u)) else None,
                        scale)
        bar.update(max(0, bar.total - bar.n))
    history = _history(ev)
    if not ranked:
        raise _no_design(ev)
    index, best, figures, table = _verified(ev, ranked, options)
    row = ev.history[index]
    params = {k: row[k] for k in problem.keys}
    checks = tuple(_check(lim, figures, table) for lim in problem.limits)
    return DesignResult(
        scene=replace(best, source=f"{base.source} (designed)"), params=params,
        objective=problem.objective, sense="maximize" if problem.sense > 0 else "minimize",
        figures=figures, table_figures=table, limits=checks, start_params=start_params,
        start_figures=start_figures, start_status=start["status"], history=history,
        seed=opts.seed, sizing=options.sizing)


def _check(limit: Limit, figures: Mapping[str, float], table: Mapping[str, float]
           ) -> LimitCheck:
    """The limit on the stricter of the two sets of figures."""
    value = min((figures[limit.figure], table[limit.figure]),
                key=lambda v: limit.margin(v) if math.isfinite(v) else -math.inf)
    return LimitCheck(limit, value, limit.margin(value))


def _verified(ev: Evaluator, ranked: list[int], options: SimulationOptions
              ) -> tuple[int, Scene, dict[str, float], dict[str, float]]:
    """The first design of ``ranked`` that meets every limit when simulated again at the
    default accuracy, on the summary path and as simulate's table."""
    problem = ev.problem
    for index in ranked[:_VERIFY_TRIES]:
        params = {k: ev.history[index][k] for k in problem.keys}
        scene, figures = sized(design_scene(problem.base, params), options.sizing,
                               partial(shot_figures, after_release=options.after_release))
        with warnings.catch_warnings():  # a slack sling is in the figures already
            warnings.simplefilter("ignore", ModelValidityWarning)
            table = summarize(simulate(scene, after_release=options.after_release), scene)
        checks = [_check(lim, figures.as_dict(), table) for lim in problem.limits]
        if figures.status == "ok" and all(c.met for c in checks):
            return index, scene, figures.as_dict(), table
    raise TrebuchetInputError(
        f"design: the {min(len(ranked), _VERIFY_TRIES)} best designs of the search break a "
        "limit when simulated again at the default accuracy; search at --accuracy default")


def _history(ev: Evaluator) -> pd.DataFrame:
    keys = list(ev.problem.keys)
    cols = ["design", "stage", "generation", *keys, "status", "error", "feasible",
            *FIGURES]
    rows = [{**r, "feasible": ev.feasible(r)} for r in ev.history]
    return pd.DataFrame(rows, columns=cols)


def _no_design(ev: Evaluator) -> TrebuchetInputError:
    """The refusal when no design meets every limit: the limit that came closest, and by how
    much."""
    problem, rows = ev.problem, [r for r in ev.history if r["status"] == "ok"]
    if not rows:
        bad = ev.history[0] if ev.history else {"error": "no design ran"}
        return TrebuchetInputError(
            f"design: no design between the bounds throws forward ({len(ev.history)} tried; "
            f"every one refused, failed or threw backward or into the ground, e.g. "
            f"{bad['error']})")
    best = {lim: max(rows, key=lambda r, lim=lim: _finite_margin(lim, r)) for lim in
            problem.limits}
    never = [lim for lim in problem.limits if _finite_margin(lim, best[lim]) < 0]
    if never:
        lim = min(never, key=lambda x: -_finite_margin(x, best[x]) / x.scale)
        value = best[lim][lim.figure]
        short = -lim.margin(value)
        more = (f"; {len(never) - 1} more limit(s) no design meets: "
                + ", ".join(x.text for x in never if x is not lim)) if len(never) > 1 else ""
        return TrebuchetInputError(
            f"design: no design between the bounds meets {lim.text} {figure_unit(lim.figure)}:"
            f" the closest of {len(ev.history)} came to {value:.6g} "
            f"({short:.3g} {'over' if lim.op == '<=' else 'under'}, "
            f"{100 * short / lim.scale:.3g} %){more}")
    closest = min(rows, key=lambda r: sum(max(0.0, -_finite_margin(x, r) / x.scale)
                                          for x in problem.limits))
    broken = [x for x in problem.limits if _finite_margin(x, closest) < 0]
    worst = max(broken, key=lambda x: -_finite_margin(x, closest) / x.scale)
    at = ", ".join(f"{k} = {closest[k]:.6g}" for k in problem.keys)
    short = -worst.margin(closest[worst.figure])
    return TrebuchetInputError(
        f"design: no design between the bounds meets every limit at once: the closest "
        f"({at}) breaks {worst.text} {figure_unit(worst.figure)} by {short:.3g} "
        f"({100 * short / worst.scale:.3g} %)")


def _finite_margin(limit: Limit, row: Mapping[str, Any]) -> float:
    m = limit.margin(row[limit.figure])
    return m if math.isfinite(m) else -math.inf
