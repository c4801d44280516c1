"""A lean explicit Runge–Kutta integrator for small non-stiff systems, in pure Python.

The simulator's default is the compiled twin of this code (:mod:`trebuchet.model.shot_kernel`,
the same method and the same steps); this one integrates any Python right-hand side, is
``simulate(method="python-DOP853")``, and is the reference the compiled one is tested
against.

The method is DOP853, the explicit 8(5,3) pair of Dormand and Prince with the
7th-order continuous extension of Hairer, Nørsett and Wanner ("Solving Ordinary
Differential Equations I", 2nd ed., Sec. II.10; the Fortran code DOP853). Its
coefficient tables are read as data from ``scipy.integrate._ivp.dop853_coefficients``
(:mod:`trebuchet.model.dop853_tableau`, without importing scipy.integrate) and the error
norm, step-size control and first-step choice follow :class:`scipy.integrate.DOP853`, so
the two take the same steps up to rounding.

What differs is the cost per step. ``solve_ivp`` spends ~50 µs of numpy overhead
per step on a 4–6 component state; here one step is straight-line Python on float
locals, generated once per state dimension (:func:`_kernels`), so a step costs
little more than its twelve right-hand-side calls. Further:

* the right-hand side ``fun(t, y)`` gets ``y`` as a **list of floats** and returns a
  sequence of ``n`` floats (write it with :mod:`math`); pass ``array_state=True`` for
  a ``fun`` that wants a numpy array;
* events are evaluated only at step ends; a step where one changes sign is
  interpolated and the root found by Brent's method on the dense output to
  ~1e-15 s (``scipy.optimize.brentq``);
* dense output is built lazily: the three extra stages and the seven interpolation
  coefficients of a step are computed the first time an output time falls in it
  (:class:`DenseSolution`), and evaluation at many times is vectorised with numpy.

:func:`solve` returns an :class:`RKResult` with the fields of ``solve_ivp``'s result
that the simulator uses: ``t, y, sol, t_events, y_events, status, message, nfev``.
Only forward integration (``t1 > t0``) is supported.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from trebuchet.model.dop853_kernels import N_STAGES as _NS
from trebuchet.model.dop853_kernels import DenseSolution
from trebuchet.model.dop853_kernels import kernels as _kernels

__all__ = ["solve", "RKResult", "DenseSolution", "ORDER", "DENSE_ORDER"]

ORDER = 8  # order of the propagated solution
DENSE_ORDER = 7  # order of the continuous extension
ERROR_ORDER = 7  # order of the embedded error estimate (as scipy counts it)

SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0
_ERROR_EXPONENT = -1.0 / (ERROR_ORDER + 1)


MESSAGES = {
    0: "The solver successfully reached the end of the integration interval.",
    1: "A termination event occurred.",
    -1: "Required step size is less than spacing between numbers.",
}


# ---------------------------------------------------------------------------------------------
# The result

@dataclass
class RKResult:
    """What ``solve_ivp`` returns, for the fields used here."""

    t: np.ndarray
    y: np.ndarray
    sol: DenseSolution | None
    t_events: list[np.ndarray] | None
    y_events: list[np.ndarray] | None
    status: int
    message: str
    nfev: int
    n_accepted: int = 0
    n_rejected: int = 0
    njev: int = 0
    nlu: int = 0
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def success(self) -> bool:
        return self.status >= 0


# ---------------------------------------------------------------------------------------------
# Events

def _event_props(ev: Callable) -> tuple[float, int]:
    direction = float(getattr(ev, "direction", 0.0))
    terminal = getattr(ev, "terminal", False)
    if terminal is True:
        max_count = 1
    elif terminal is False or terminal is None:
        max_count = 0  # never terminates
    else:
        max_count = int(terminal)
        if max_count < 1:
            raise ValueError("an event's terminal must be a bool or a positive int")
    return direction, max_count


def _crossed(g_old: float, g_new: float, direction: float) -> bool:
    """scipy's rule: up if g_old <= 0 <= g_new, down if g_old >= 0 >= g_new."""
    up = g_old <= 0.0 <= g_new
    down = g_old >= 0.0 >= g_new
    if direction > 0:
        return up
    if direction < 0:
        return down
    return up or down


def _locate(ev: Callable, interp: Callable, t0: float, h: float, y0: list[float], F: list[float],
            g0: float, g1: float) -> float:
    """Root of ``ev(t, y(t))`` on one step, by Brent's method on the step's polynomial."""
    def g(s: float) -> float:
        return ev(s, interp((s - t0) / h, y0, F))

    t1 = t0 + h
    if g0 == 0.0:
        return t0
    if g1 == 0.0:
        return t1
    ga, gb = g(t0), g(t1)  # the interpolant's own end values (rounding may differ)
    if ga == 0.0:
        return t0
    if gb == 0.0 or (ga > 0.0) == (gb > 0.0):
        return t1 if abs(gb) <= abs(ga) else t0
    from scipy.optimize import brentq  # here only: scipy.optimize costs ~0.1 s to import

    return brentq(g, t0, t1, xtol=4 * np.finfo(float).eps, rtol=4 * np.finfo(float).eps)


# ---------------------------------------------------------------------------------------------
# The driver

def next_step_size(h_abs: float, err: float, rejected: bool) -> float:
    """Step-size control of DOP853 as scipy's: the next |h| (s) after a step of ``h_abs`` whose
    error norm is ``err`` (accepted below 1). After an accepted step it grows at most tenfold,
    not at all right after a rejection; a rejected step shrinks at most fivefold, and by five
    when the error is not a number (NaN from the right-hand side). Written on floats only, so
    that the compiled integrator (:mod:`trebuchet.model.shot_kernel`) runs this same code."""
    if err < 1.0:
        factor = MAX_FACTOR if err == 0.0 else min(MAX_FACTOR, SAFETY * err ** _ERROR_EXPONENT)
        if rejected and factor > 1.0:
            factor = 1.0
        return h_abs * factor
    if err == err:
        return h_abs * max(MIN_FACTOR, SAFETY * err ** _ERROR_EXPONENT)
    return h_abs * MIN_FACTOR


def _initial_step(fun: Callable, t0: float, y0: list[float], f0: Sequence[float],
                  t_bound: float, rtol: float, atol: list[float]) -> float:
    """Hairer's starting step (as scipy's ``select_initial_step``); one right-hand-side call."""
    n = len(y0)
    span = abs(t_bound - t0)
    if span == 0.0:
        return 0.0
    sc = [a + abs(v) * rtol for a, v in zip(atol, y0, strict=True)]
    d0 = math.sqrt(sum((v / s) ** 2 for v, s in zip(y0, sc, strict=True)) / n)
    d1 = math.sqrt(sum((v / s) ** 2 for v, s in zip(f0, sc, strict=True)) / n)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, span)
    f1 = fun(t0 + h0, [v + h0 * d for v, d in zip(y0, f0, strict=True)])
    d2 = math.sqrt(sum(((b - a) / s) ** 2 for a, b, s in zip(f0, f1, sc, strict=True)) / n) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (ERROR_ORDER + 1))
    return min(100 * h0, h1, span)


def _checked_start(t_span: tuple[float, float], y0: Sequence[float], rtol: float,
                   atol: float | Sequence[float], max_step: float
                   ) -> tuple[float, float, list[float], list[float]]:
    """``t0``, ``t1``, the state as a list and ``atol`` per component, checked (ValueError)."""
    t0, t_bound = float(t_span[0]), float(t_span[1])
    if not t_bound >= t0:
        raise ValueError("only forward integration is supported: t_span[1] must be >= t_span[0]")
    if not (math.isfinite(t0) and math.isfinite(t_bound)):
        raise ValueError("t_span must be finite")
    y = [float(v) for v in np.asarray(y0, dtype=float).reshape(-1)]
    n = len(y)
    if n == 0:
        raise ValueError("y0 must hold at least one component")
    if not rtol > 0:
        raise ValueError("rtol must be positive")
    atol_l = [float(a) for a in np.broadcast_to(np.asarray(atol, dtype=float), (n,))]
    if min(atol_l) < 0:
        raise ValueError("atol must not be negative")
    if max_step <= 0:
        raise ValueError("max_step must be positive")
    return t0, t_bound, y, atol_l


def _on_lists(fun: Callable, events: Sequence[Callable] | None
              ) -> tuple[Callable, list[Callable]]:
    """``fun`` and the events of an array-state problem, taking lists as the driver does."""
    def listed(t: float, yy: list[float]) -> Sequence[float]:
        return np.asarray(fun(t, np.asarray(yy)), dtype=float).tolist()

    def wrapped(ev: Callable) -> Callable:
        def g(t: float, yy: list[float]) -> float:
            return ev(t, np.asarray(yy))
        return g
    return listed, [wrapped(ev) for ev in (events or [])]


@dataclass
class _Steps:
    """The accepted steps of a run (private to :func:`solve`, filled as it goes): their
    starts, sizes, states before and after, stages, the dense coefficients built so far,
    the output points and the counters."""

    ts_old: list[float] = field(default_factory=list)
    hs: list[float] = field(default_factory=list)
    ys_old: list[list[float]] = field(default_factory=list)
    ys_new: list[list[float]] = field(default_factory=list)
    Ks: list[tuple] = field(default_factory=list)
    coef: dict[int, tuple] = field(default_factory=dict)
    t_out: list[float] = field(default_factory=list)
    y_out: list[list[float]] = field(default_factory=list)
    nfev: int = 0
    n_rej: int = 0

    def keep(self, t: float, h: float, y: list[float], y_new: list[float], K: tuple) -> int:
        """Record an accepted step; its index."""
        self.ts_old.append(t)
        self.hs.append(h)
        self.ys_old.append(y)
        self.ys_new.append(y_new)
        self.Ks.append(K)
        return len(self.ts_old) - 1


def _accepted_step(step: Callable, fun: Callable, t: float, y: list[float], f: list[float],
                   h_abs: float, t_bound: float, rtol: float, atol: list[float],
                   max_step: float, steps: _Steps) -> tuple | None:
    """One accepted step from ``t``: ``(t_new, h, y_new, f_new, K, next |h|)``, shrinking
    and retrying rejected ones (counted in ``steps``); None where the step size falls below
    the floating-point floor (also a NaN step from a NaN right-hand side)."""
    min_step = 10.0 * (math.nextafter(t, math.inf) - t)
    if h_abs > max_step:
        h_abs = max_step
    elif h_abs < min_step:
        h_abs = min_step
    rejected = False
    while True:
        if not h_abs >= min_step:
            return None
        t_new = t + h_abs
        if t_new > t_bound:
            t_new = t_bound
        h = t_new - t
        y_new, f_new, err, K = step(fun, t, h, y, f, rtol, atol)
        steps.nfev += _NS
        h_abs = next_step_size(h, err, rejected)
        if err < 1.0:
            return t_new, h, y_new, f_new, K, h_abs
        steps.n_rej += 1
        rejected = True


@dataclass
class _Events:
    """The run's events and what they found (private to :func:`solve`)."""

    events: list[Callable]
    props: list[tuple[float, int]]
    g_old: list[float]
    counts: list[int]
    t_events: list[list[float]]
    y_events: list[list[list[float]]]

    @classmethod
    def start(cls, events: list[Callable], t0: float, y0: list[float]) -> _Events:
        return cls(events, [_event_props(ev) for ev in events],
                   [float(ev(t0, y0)) for ev in events], [0] * len(events),
                   [[] for _ in events], [[] for _ in events])

    def after_step(self, fun: Callable, dense: Callable, interp: Callable, steps: _Steps,
                   i_step: int, t: float, h: float, y: list[float], t_new: float,
                   y_new: list[float]) -> tuple[float, list[float]] | None:
        """Locate the events crossed in step ``i_step`` (``t`` to ``t_new``); the time and
        state where a terminal one ends the run, else None."""
        g_new = [float(ev(t_new, y_new)) for ev in self.events]
        active = [j for j, (dr, _) in enumerate(self.props)
                  if _crossed(self.g_old[j], g_new[j], dr)]
        self.g_old, g_old = g_new, self.g_old
        if not active:
            return None
        F = steps.coef.get(i_step)
        if F is None:
            F = dense(fun, t, h, y, y_new, steps.Ks[i_step])
            steps.coef[i_step] = F
            steps.nfev += 3
        hits = sorted((_locate(self.events[j], interp, t, h, y, list(F), g_old[j],
                               g_new[j]), j) for j in active)
        for te, j in hits:
            self.counts[j] += 1
            self.t_events[j].append(te)
            self.y_events[j].append(interp((te - t) / h, y, F))
            if self.props[j][1] and self.counts[j] >= self.props[j][1]:
                return te, interp((te - t) / h, y, F)
        return None


def solve(fun: Callable[[float, list[float]], Sequence[float]], t_span: tuple[float, float],
          y0: Sequence[float], *, rtol: float = 1e-3, atol: float | Sequence[float] = 1e-6,
          events: Sequence[Callable] | None = None, dense_output: bool = True,
          max_step: float = math.inf, first_step: float | None = None,
          array_state: bool = False, vectorized_fun: Callable | None = None) -> RKResult:
    """Integrate ``y' = fun(t, y)`` from ``t_span[0]`` to ``t_span[1]`` with DOP853.

    Parameters
    ----------
    fun : callable
        ``fun(t, y) -> sequence of n floats``; ``y`` is a list of floats (a numpy array with
        ``array_state=True``).
    t_span : (t0, t1)
        The interval, ``t1 >= t0``.
    y0 : sequence of n floats
    rtol, atol : float, and float or sequence of n floats
        Local error per step below ``atol + rtol |y|`` in scipy's DOP853 norm.
    events : callables ``g(t, y) -> float``, optional
        As in ``solve_ivp``: attributes ``terminal`` (bool, or a count of occurrences that
        ends the run) and ``direction`` (+1: g rising through 0, -1: falling, 0: both).
        Roots are located on the dense output by Brent's method.
    dense_output : bool
        Keep the continuous solution in ``result.sol`` (lazy; see :class:`DenseSolution`).
    max_step, first_step : float, optional
        Bounds on the step size; the first step is chosen as scipy does by default.
    array_state : bool
        Hand ``fun`` and the events a numpy array instead of a list (slower).
    vectorized_fun : callable, optional
        The same right-hand side on arrays, ``vectorized_fun(t (m,), y (n, m)) -> (n, m)``:
        the dense output then builds the coefficients of many steps in one numpy pass instead
        of three Python calls of ``fun`` per step.
    """
    t0, t_bound, y, atol_l = _checked_start(t_span, y0, rtol, atol, max_step)
    n = len(y)
    if array_state:
        fun, events = _on_lists(fun, events)
    step, dense, interp = _kernels(n)
    f = list(fun(t0, y))
    if len(f) != n:
        raise ValueError(f"fun returned {len(f)} values for a state of {n}")
    steps = _Steps(t_out=[t0], y_out=[y], nfev=1)
    found = _Events.start(list(events or []), t0, y)
    if first_step is None:
        h_abs = _initial_step(fun, t0, y, f, t_bound, rtol, atol_l)
        steps.nfev += 1
    elif not first_step > 0:
        raise ValueError("first_step must be positive")
    else:
        h_abs = min(float(first_step), t_bound - t0)
    t, status = t0, 0
    while t < t_bound:
        done = _accepted_step(step, fun, t, y, f, h_abs, t_bound, rtol, atol_l, max_step,
                              steps)
        if done is None:
            status = -1
            break
        t_new, h, y_new, f_new, K, h_abs = done
        i_step = steps.keep(t, h, y, y_new, K)
        stop = found.after_step(fun, dense, interp, steps, i_step, t, h, y, t_new, y_new) \
            if found.events else None
        if stop is not None:
            status = 1
            t = stop[0]
            steps.t_out.append(t)
            steps.y_out.append(stop[1])
            break
        t, y, f = t_new, y_new, f_new
        steps.t_out.append(t)
        steps.y_out.append(y)
    return _result(steps, found, n, t, status, fun, dense_output, vectorized_fun)


def _result(steps: _Steps, found: _Events, n: int, t_end: float, status: int, fun: Callable,
            dense_output: bool, vectorized_fun: Callable | None) -> RKResult:
    """The :class:`RKResult` of a run."""
    sol = None
    if dense_output:
        sol = DenseSolution(fun, n, steps.ts_old, steps.hs, steps.ys_old, steps.ys_new,
                            steps.Ks, t_end=t_end, coef=steps.coef,
                            vectorized_fun=vectorized_fun)
    events = found.events
    return RKResult(
        t=np.asarray(steps.t_out, dtype=float),
        y=np.asarray(steps.y_out, dtype=float).T.reshape(n, len(steps.t_out)),
        sol=sol,
        t_events=[np.asarray(v, dtype=float) for v in found.t_events] if events else None,
        y_events=[np.asarray(v, dtype=float).reshape(len(v), n) for v in found.y_events]
        if events else None,
        status=status, message=MESSAGES[status], nfev=steps.nfev,
        n_accepted=len(steps.ts_old), n_rejected=steps.n_rej,
    )
