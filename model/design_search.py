"""The search of :func:`trebuchet.model.design.design`: differential evolution with the limits
as constraints, then a local polish.

* **Global**: scipy's :func:`~scipy.optimize.differential_evolution` on the unit cube of the
  varied keys, the limits as a :class:`~scipy.optimize.NonlinearConstraint` (Lampinen's rule:
  a design that meets every limit beats one that does not; among those that do not, the
  smaller total violation wins), vectorised with deferred updating, so that each generation
  is one batch of designs for the worker processes or the Dask cluster. Seeded: the same
  ``seed`` gives the same designs.
* **Local**: SLSQP from the best design that meets every limit, the constraints kept
  :attr:`SearchOptions.safety` (relative) inside each limit, gradients by forward
  differences whose ``N + 1`` designs go out as one batch. The optimum of a design under
  limits usually lies on one of them; SLSQP lands on it where evolution only comes near.

Why not pymoo: its genetic algorithms handle constraints the same way, a single objective
gains nothing from its Pareto machinery, and scipy is already a dependency; the trade the
``--plot`` draws is read off the search's history instead.

The figures of every design come from the sweep's summary-only path
(:class:`~trebuchet.model.sweep.DesignRunner`), each design simulated once (a cache by its
coordinates); every design, its stage and its generation stay in the history.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import NonlinearConstraint, differential_evolution, minimize

from trebuchet.model.design_problem import Problem
from trebuchet.model.settings import DESIGN_GENERATIONS, DESIGN_POPSIZE

__all__ = ["SearchOptions", "Evaluator", "search", "STATUS_MARGIN"]

#: The relative margin of every limit of a design that gave no figures (refused, failed).
_NO_FIGURES = -10.0
#: The margin of the "status" constraint: a design must throw forward (status ok).
STATUS_MARGIN = 1.0
_STEP = 1e-6  # forward-difference step of the polish, in the unit cube


@dataclass(frozen=True)
class SearchOptions:
    """``popsize`` designs per varied key in each generation, at most ``generations``
    generations of evolution (fewer when its population has converged to ``tol``), then the
    local ``polish`` (at most ``polish_steps`` SLSQP iterations); ``seed`` makes it
    repeatable; ``safety``: the relative margin the polish keeps inside each limit (the
    solver's own accuracy is ~1e-9, so that an independent simulation meets the limits too)."""

    popsize: int = DESIGN_POPSIZE
    generations: int = DESIGN_GENERATIONS
    tol: float = 0.0
    polish: bool = True
    polish_steps: int = 60
    seed: int | None = None
    safety: float = 1e-6


@dataclass
class Evaluator:
    """The figures of designs given by their coordinates in the unit cube: each design run
    once (``run_batch`` takes ``(index, params)`` pairs and returns their rows), every one kept
    in ``history`` with the search's ``stage`` and ``generation`` at the time."""

    problem: Problem
    run_batch: Callable[[list[tuple[int, dict[str, float]]]], list[dict[str, Any]]]
    on_batch: Callable[[Evaluator, int], None] | None = None
    history: list[dict[str, Any]] = field(default_factory=list)
    units: list[np.ndarray] = field(default_factory=list)
    stage: str = "search"
    generation: int = 0
    _cache: dict[bytes, int] = field(default_factory=dict)

    def rows(self, U: np.ndarray) -> list[dict[str, Any]]:
        """The rows of the designs at the rows of ``U`` (S × N), new ones run as one batch."""
        U = np.atleast_2d(np.asarray(U, dtype=float))
        keys = [u.tobytes() for u in U]
        todo: dict[bytes, tuple[int, dict[str, float]]] = {}
        at: dict[bytes, np.ndarray] = {}
        for key, u in zip(keys, U, strict=True):
            if key not in self._cache and key not in todo:
                todo[key] = (len(self.history) + len(todo), self.problem.params(u))
                at[key] = u.copy()
        if todo:
            rows = {r["design"]: r for r in self.run_batch(list(todo.values()))}
            for key, (index, _) in todo.items():
                self._cache[key] = index
                self.history.append({**rows[index], "stage": self.stage,
                                     "generation": self.generation})
                self.units.append(at[key])
            if self.on_batch:
                self.on_batch(self, len(todo))
        return [self.history[self._cache[k]] for k in keys]

    def margins(self, row: dict[str, Any]) -> np.ndarray:
        """The relative margin of each limit (its value's unit: 1e-2 is 1 %) and of the
        status (+1 ok, −1 not): every one ≥ 0 for a design that meets the limits."""
        limits = self.problem.limits
        if row["status"] in ("refused", "failed", "over_budget"):
            return np.array([*[_NO_FIGURES] * len(limits), -STATUS_MARGIN])
        m = [lim.margin(row[lim.figure]) / lim.scale for lim in limits]
        m = [x if math.isfinite(x) else _NO_FIGURES for x in m]
        return np.array([*m, STATUS_MARGIN if row["status"] == "ok" else -STATUS_MARGIN])

    def energy(self, row: dict[str, Any], scale: float) -> float:
        """The value the search minimises: the objective, signed and scaled (a design with no
        such figure: a large number)."""
        value = row.get(self.problem.objective, math.nan)
        if not math.isfinite(value) or row["status"] != "ok":
            return 1e3
        return -self.problem.sense * value / scale

    def feasible(self, row: dict[str, Any], safety: float = 0.0) -> bool:
        m = self.margins(row)
        return bool(m[-1] > 0 and np.all(m[:-1] >= safety))


def _seed_keyword(seed: int | None) -> dict[str, Any]:
    """scipy >= 1.15 names the seed ``rng``; older releases ``seed``."""
    params = inspect.signature(differential_evolution).parameters
    return {"rng": seed} if "rng" in params else {"seed": seed}


def _evolve(ev: Evaluator, opts: SearchOptions, x0: np.ndarray | None, scale: float) -> None:
    """Differential evolution over the unit cube; every design lands in ``ev.history``."""
    n = len(ev.problem.variables)

    def energies(U: np.ndarray) -> np.ndarray:
        return np.array([ev.energy(r, scale) for r in ev.rows(np.reshape(U, (n, -1)).T)])

    def constraints(U: np.ndarray) -> np.ndarray:
        ev.generation += 1
        return np.stack([ev.margins(r) for r in ev.rows(np.reshape(U, (n, -1)).T)], axis=1)

    differential_evolution(
        energies, [(0.0, 1.0)] * n, maxiter=opts.generations, popsize=opts.popsize,
        tol=opts.tol, polish=False, updating="deferred", vectorized=True, x0=x0,
        constraints=NonlinearConstraint(constraints, 0.0, np.inf),
        **_seed_keyword(opts.seed))


def _polish(ev: Evaluator, u0: np.ndarray, opts: SearchOptions, scale: float) -> None:
    """SLSQP from ``u0`` with forward-difference gradients (one batch of designs each)."""
    ev.stage = "polish"
    n = u0.size

    def points(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        steps = np.where(u + _STEP <= 1.0, _STEP, -_STEP)
        return np.vstack([u, u + np.diag(steps)]), steps

    def fun(u: np.ndarray) -> float:
        return ev.energy(ev.rows(u[None])[0], scale)

    def jac(u: np.ndarray) -> np.ndarray:
        P, steps = points(np.asarray(u, dtype=float))
        e = [ev.energy(r, scale) for r in ev.rows(P)]
        return (np.array(e[1:]) - e[0]) / steps

    def cons(u: np.ndarray) -> np.ndarray:
        return ev.margins(ev.rows(u[None])[0]) - opts.safety

    def cons_jac(u: np.ndarray) -> np.ndarray:
        P, steps = points(np.asarray(u, dtype=float))
        m = np.array([ev.margins(r) for r in ev.rows(P)])
        return ((m[1:] - m[0]) / steps[:, None]).T

    minimize(fun, u0, jac=jac, bounds=[(0.0, 1.0)] * n, method="SLSQP",
             constraints=[{"type": "ineq", "fun": cons, "jac": cons_jac}],
             options={"maxiter": opts.polish_steps, "ftol": 1e-12})


def search(ev: Evaluator, opts: SearchOptions, start: np.ndarray | None,
           scale: float) -> list[int]:
    """Run the search; return the indices in ``ev.history`` of the designs that meet every
    limit with the polish's safety margin (half of it for round-off), best first."""
    inside = start is not None and bool(np.all((start >= 0.0) & (start <= 1.0)))
    _evolve(ev, opts, start if inside else None, scale)
    best = _ranked(ev, scale, 0.0)
    if opts.polish and best:
        _polish(ev, ev.units[best[0]], opts, scale)
    return _ranked(ev, scale, 0.5 * opts.safety)


def _ranked(ev: Evaluator, scale: float, safety: float) -> list[int]:
    ok = [i for i, r in enumerate(ev.history) if ev.feasible(r, safety)]
    return sorted(ok, key=lambda i: ev.energy(ev.history[i], scale))
