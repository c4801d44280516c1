"""The compiled integration of one phase as Python sees it (:mod:`trebuchet.model.shot_kernel`).

* :func:`solve_phase` integrates one phase (1 trough, 2 sling, 3 released) until its end or the
  first event that ends it, and returns a :class:`KernelSolution`: the steps and their
  interpolation coefficients;
* :meth:`KernelSolution.columns` evaluates angles, rates and accelerations at many times at
  once (the dense output and the equations of motion, compiled).

Units: s, rad, rad/s, rad/s² (and J in units of ``dynamics.energy_scale`` for the lost
energies of friction).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trebuchet.model import phase_events as pev
from trebuchet.model.scene import Engine
from trebuchet.model.shot_kernel import (
    INTERPOLATOR_COEFFICIENTS,
    JitEngine,
    _columns,
    _integrate,
    _states,
    jit_engine,
    say_compiling,
)

__all__ = ["KernelSolution", "solve_phase"]

@dataclass(frozen=True, eq=False)
class KernelSolution:
    """One integrated phase: steps starting at ``t_steps`` (s) of size ``h`` from states
    ``y_steps`` with interpolation coefficients ``coef`` (steps × 7 × n), ending at ``t_end``.
    Callable like scipy's ``OdeSolution``; fields of ``solve_ivp``'s result for the events."""

    kind: int
    engine: JitEngine
    g: float
    H: float
    t_steps: np.ndarray
    h: np.ndarray
    y_steps: np.ndarray
    coef: np.ndarray
    t_end: float
    y_end: np.ndarray
    status: int
    nfev: int
    n_rejected: int
    t_events: list[np.ndarray]
    y_events: list[np.ndarray]

    @property
    def sol(self) -> KernelSolution:
        return self

    @property
    def message(self) -> str:
        return {0: "The solver successfully reached the end of the integration interval.",
                1: "A termination event occurred.",
                -1: "Required step size is less than spacing between numbers."}[self.status]

    @property
    def t(self) -> np.ndarray:
        """Step ends, as ``solve_ivp``'s ``t`` (the first is the start)."""
        return np.append(self.t_steps, self.t_end) if self.t_steps.size else np.array(
            [self.t_end])

    @property
    def y(self) -> np.ndarray:
        """States at :attr:`t`, shape (n, steps + 1)."""
        return np.column_stack([*self.y_steps, self.y_end]) if self.t_steps.size else (
            self.y_end[:, None])

    def _grid(self) -> np.ndarray:
        return np.append(self.t_steps, self.t_end)

    def __call__(self, t: np.ndarray | float) -> np.ndarray:
        tt = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.empty((self.y_end.size, tt.size))
        if self.t_steps.size == 0:
            out[:] = self.y_end[:, None]
        else:
            _states(self._grid(), self.y_steps, self.h, self.coef, tt, out)
        return out[:, 0] if np.ndim(t) == 0 else out

    def columns(self, t: np.ndarray, out: np.ndarray) -> None:
        """Angles, rates and accelerations (rows θ, ψ, φ, θ̇, ψ̇, φ̇, θ̈, ψ̈, φ̈; rad, rad/s,
        rad/s²) at times ``t`` (s) into ``out`` (9 × len(t); with more rows, the states after
        the angles and rates follow: the lost energies of friction)."""
        if self.t_steps.size == 0:  # a phase of zero length: the one state it holds
            ts, Y = np.array([self.t_end, self.t_end + 1.0]), self.y_end[None, :]
            coef, h = np.zeros((1, INTERPOLATOR_COEFFICIENTS, self.y_end.size)), np.ones(1)
        else:
            ts, Y, coef, h = self._grid(), self.y_steps, self.coef, self.h
        _columns(self.kind, self.engine, self.g, self.H, ts, Y, h, coef,
                 np.ascontiguousarray(t, dtype=float), out)


def solve_phase(kind: int, engine: Engine, g: float, H: float, t0: float, t1: float,
                y0: np.ndarray, rtol: float, first_step: float | None = None,
                events: tuple[tuple[int, float], ...] = ()) -> KernelSolution:
    """Integrate phase ``kind`` (1, 2, 3) from ``t0`` to ``t1`` (s) with DOP853 at ``rtol``
    (``atol = rtol/100``), stopping at the first of ``events`` (pairs of a kind of
    :mod:`~trebuchet.model.phase_events` and its parameter) located to ~1e-15 s by Brent's
    method on the step's polynomial."""
    say_compiling()
    e = jit_engine(engine)
    y0 = np.ascontiguousarray(y0, dtype=float)
    n = y0.size
    kinds = np.array([k for k, _ in events], dtype=np.int64)
    pars = np.array([p for _, p in events], dtype=float)
    dirs = np.array([pev.DIRECTION[k] for k, _ in events], dtype=float)
    atol = np.full(n, rtol * 1e-2)
    (T, Hs, Y, Fs, t_end, y_end, status, nfev, n_rej,
     which) = _integrate(kind, e, float(g), float(H), float(t0), float(t1), y0, float(rtol),
                         atol, float(first_step or 0.0), kinds, dirs, pars)
    t_events = [np.empty(0) for _ in events]
    y_events = [np.empty((0, n)) for _ in events]
    if which >= 0:
        t_events[which] = np.array([t_end])
        y_events[which] = y_end[None, :].copy()
    return KernelSolution(kind, e, float(g), float(H), T, Hs, Y, Fs, float(t_end),
                          np.asarray(y_end, dtype=float), int(status), int(nfev), int(n_rej),
                          t_events, y_events)
