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
from functools import cache
from typing import Any

import numpy as np

from trebuchet.model.dop853_tableau import DOP853 as _dop

__all__ = ["solve", "RKResult", "DenseSolution", "ORDER", "DENSE_ORDER"]

ORDER = 8  # order of the propagated solution
DENSE_ORDER = 7  # order of the continuous extension
ERROR_ORDER = 7  # order of the embedded error estimate (as scipy counts it)

SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0
_ERROR_EXPONENT = -1.0 / (ERROR_ORDER + 1)

_NS = _dop.N_STAGES  # 12 stages per step; K[12] holds f(t+h, y_new) (first same as last)
_NX = _dop.N_STAGES_EXTENDED  # 16: three extra stages for the dense output
_NP = _dop.INTERPOLATOR_POWER  # 7 interpolation coefficients per component

MESSAGES = {
    0: "The solver successfully reached the end of the integration interval.",
    1: "A termination event occurred.",
    -1: "Required step size is less than spacing between numbers.",
}


# ---------------------------------------------------------------------------------------------
# Code generation: one step, the dense coefficients of a step, and a one-point interpolation,
# as straight-line Python over float locals for a given state dimension n.

def _lin(terms: list[tuple[float, str]]) -> str:
    """``c1*x1 + c2*x2 + ...`` skipping zero coefficients (``0.0`` if none)."""
    parts = [f"{float(c)!r}*{x}" for c, x in terms if c != 0.0]
    return " + ".join(parts) if parts else "0.0"


def _step_source(n: int) -> str:
    A, B, C, E3, E5 = _dop.A, _dop.B, _dop.C, _dop.E3, _dop.E5
    r = range(n)
    k = [[f"k{s}_{i}" for i in r] for s in range(_NX)]
    lines = ["def step(fun, t, h, y, f, rtol, atol):"]
    lines.append(f"    {', '.join(f'y_{i}' for i in r)}, = y")
    lines.append(f"    {', '.join(k[0])}, = f")
    lines.append(f"    {', '.join(f'a_{i}' for i in r)}, = atol")
    for s in range(1, _NS):
        args = ", ".join(f"y_{i} + h*({_lin([(A[s, j], k[j][i]) for j in range(s)])})"
                         for i in r)
        lines.append(f"    {', '.join(k[s])}, = fun(t + {float(C[s])!r}*h, [{args}])")
    for i in r:
        lines.append(f"    u_{i} = y_{i} + h*({_lin([(B[j], k[j][i]) for j in range(_NS)])})")
    lines.append(f"    yn = [{', '.join(f'u_{i}' for i in r)}]")
    lines.append("    fn = fun(t + h, yn)")
    lines.append(f"    {', '.join(k[_NS])}, = fn")
    lines.append("    s5 = 0.0")
    lines.append("    s3 = 0.0")
    for i in r:
        lines.append(f"    d = a_{i} + rtol*max(abs(y_{i}), abs(u_{i}))")
        lines.append(f"    e = ({_lin([(E5[j], k[j][i]) for j in range(_NS + 1)])})/d")
        lines.append("    s5 += e*e")
        lines.append(f"    e = ({_lin([(E3[j], k[j][i]) for j in range(_NS + 1)])})/d")
        lines.append("    s3 += e*e")
    lines.append("    if s5 == 0.0 and s3 == 0.0:")
    lines.append("        err = 0.0")
    lines.append("    else:")
    lines.append(f"        err = abs(h)*s5/sqrt((s5 + 0.01*s3)*{n})")
    flat = ", ".join(k[s][i] for s in range(_NS + 1) for i in r)
    lines.append(f"    return yn, fn, err, ({flat},)")
    return "\n".join(lines) + "\n"


def _dense_source(n: int) -> str:
    A, C, D = _dop.A, _dop.C, _dop.D
    r = range(n)
    k = [[f"k{s}_{i}" for i in r] for s in range(_NX)]
    lines = ["def dense(fun, t, h, y, yn, K):"]
    lines.append(f"    {', '.join(f'y_{i}' for i in r)}, = y")
    lines.append(f"    {', '.join(f'u_{i}' for i in r)}, = yn")
    lines.append(f"    {', '.join(k[s][i] for s in range(_NS + 1) for i in r)}, = K")
    for s in range(_NS + 1, _NX):
        args = ", ".join(f"y_{i} + h*({_lin([(A[s, j], k[j][i]) for j in range(s)])})"
                         for i in r)
        lines.append(f"    {', '.join(k[s])}, = fun(t + {float(C[s])!r}*h, [{args}])")
    rows: list[str] = []
    for i in r:
        lines.append(f"    dy_{i} = u_{i} - y_{i}")
    rows.append(", ".join(f"dy_{i}" for i in r))
    rows.append(", ".join(f"h*{k[0][i]} - dy_{i}" for i in r))
    rows.append(", ".join(f"2.0*dy_{i} - h*({k[_NS][i]} + {k[0][i]})" for i in r))
    for p in range(_NP - 3):
        rows.append(", ".join(f"h*({_lin([(D[p, j], k[j][i]) for j in range(_NX)])})"
                              for i in r))
    lines.append(f"    return ({', '.join(rows)},)")
    return "\n".join(lines) + "\n"


def _interp_source(n: int) -> str:
    """``y(x)`` on one step from its coefficients ``F`` (flat, row-major 7×n), as a list."""
    comps = []
    for i in range(n):
        F = [f"F[{p * n + i}]" for p in range(_NP)]
        expr = F[6]
        for p in range(5, -1, -1):  # Horner in alternating x and (1 - x), as DOP853's CONTD8
            expr = f"{F[p]} + {'x' if p % 2 else 'u'}*({expr})"
        comps.append(f"y0[{i}] + x*({expr})")
    return ("def interp(x, y0, F):\n    u = 1.0 - x\n"
            f"    return [{', '.join(comps)}]\n")


@cache
def _kernels(n: int) -> tuple[Callable, Callable, Callable]:
    """The generated ``step``, ``dense`` and ``interp`` functions for dimension ``n``."""
    ns: dict[str, Any] = {"sqrt": math.sqrt}
    for src in (_step_source(n), _dense_source(n), _interp_source(n)):
        exec(compile(src, f"<dop853 kernel n={n}>", "exec"), ns)  # noqa: S102 - generated here
    return ns["step"], ns["dense"], ns["interp"]


# ---------------------------------------------------------------------------------------------
# Dense output

class DenseSolution:
    """The continuous solution over the accepted steps, callable like scipy's ``OdeSolution``:
    ``sol(t)`` gives shape ``(n,)`` for a scalar ``t`` and ``(n, m)`` for ``m`` times. Times
    outside ``[t_min, t_max]`` are extrapolated with the first or last step's polynomial.

    A step's interpolation coefficients are computed (three more right-hand-side calls) the
    first time a time in it is asked for; ``nfev`` counts those calls."""

    def __init__(self, fun: Callable, n: int, t_old: list[float], h: list[float],
                 y_old: list[list[float]], y_new: list[list[float]], K: list[tuple],
                 t_end: float, coef: dict[int, tuple] | None = None,
                 vectorized_fun: Callable | None = None):
        self._fun, self.n = fun, n
        self._vfun = vectorized_fun
        self._K, self._y_new = K, y_new
        self.t_old = np.asarray(t_old, dtype=float)
        self.h = np.asarray(h, dtype=float)
        self.y_old = np.asarray(y_old, dtype=float).reshape(len(t_old), n)
        self.t_min = float(t_old[0]) if t_old else float(t_end)
        self.t_max = float(t_end)
        self.ts = np.append(self.t_old, self.t_max)
        self._F = np.zeros((len(t_old), _NP, n))
        self._have = np.zeros(len(t_old), dtype=bool)
        self.nfev = 0
        for i, F in (coef or {}).items():
            self._F[i] = np.reshape(F, (_NP, n))
            self._have[i] = True

    @property
    def n_steps(self) -> int:
        return len(self.t_old)

    def __getstate__(self) -> dict[str, Any]:
        """Pickling builds every step's coefficients and leaves ``fun`` (often a closure)
        behind, as scipy's OdeSolution carries arrays only."""
        self.coefficients()
        state = dict(self.__dict__)
        state["_fun"] = None
        state["_K"] = None
        return state

    def coefficients(self, steps: np.ndarray | None = None) -> np.ndarray:
        """Interpolation coefficients ``(n_steps, 7, n)``, computing those of ``steps`` (all
        by default) if not yet done."""
        idx = np.arange(self.n_steps) if steps is None else np.asarray(steps)
        missing = np.unique(idx[~self._have[idx]]) if idx.size else idx
        if missing.size > 1 and self._vfun is not None:
            self._F[missing] = self._dense_all(missing)
        elif missing.size:
            dense = _kernels(self.n)[1]
            fun, t_old, h, y_old = self._fun, self.t_old, self.h, self.y_old
            rows = [dense(fun, float(t_old[i]), float(h[i]), y_old[i].tolist(),
                          self._y_new[i], self._K[i]) for i in missing.tolist()]
            self._F[missing] = np.reshape(rows, (missing.size, _NP, self.n))
        self._have[missing] = True
        self.nfev += 3 * missing.size
        return self._F

    def _dense_all(self, steps: np.ndarray) -> np.ndarray:
        """The coefficients of many steps at once: the three extra stages of every step in one
        call each of the vectorised right-hand side ``vfun(t (m,), y (n, m)) -> (n, m)``."""
        m, n = steps.size, self.n
        K = np.empty((m, _NX, n))
        K[:, :_NS + 1] = np.reshape([self._K[i] for i in steps.tolist()], (m, _NS + 1, n))
        h, t0, y0 = self.h[steps], self.t_old[steps], self.y_old[steps]
        for s in range(_NS + 1, _NX):
            dy = h[:, None] * np.einsum("msn,s->mn", K[:, :s], _dop.A[s, :s])
            K[:, s] = np.asarray(self._vfun(t0 + _dop.C[s] * h, (y0 + dy).T)).T
        delta = np.asarray([self._y_new[i] for i in steps.tolist()]) - y0
        F = np.empty((m, _NP, n))
        F[:, 0] = delta
        F[:, 1] = h[:, None] * K[:, 0] - delta
        F[:, 2] = 2.0 * delta - h[:, None] * (K[:, _NS] + K[:, 0])
        F[:, 3:] = h[:, None, None] * np.einsum("pk,mkn->mpn", _dop.D, K)
        return F

    def step_index(self, t: np.ndarray) -> np.ndarray:
        """Index of the step each time falls in (a time on a step boundary takes the step that
        ends there, as scipy's OdeSolution does)."""
        idx = np.searchsorted(self.ts, t, side="left") - 1
        return np.clip(idx, 0, self.n_steps - 1)

    def __call__(self, t: Any) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        if self.n_steps == 0:
            y = np.asarray(self._y_new[0] if self._y_new else [], dtype=float)
            return np.repeat(y[:, None], t.size, axis=1).reshape((self.n, *t.shape))
        scalar = t.ndim == 0
        tt = t.reshape(-1)
        idx = self.step_index(tt)
        F = self.coefficients(idx)[idx]  # (m, 7, n)
        x = ((tt - self.t_old[idx]) / self.h[idx])[:, None]
        u = 1.0 - x
        y = F[:, 6] * x
        for p in range(5, -1, -1):
            y += F[:, p]
            y *= u if p % 2 else x
        y += self.y_old[idx]
        return y[0] if scalar else y.T

    def at(self, t: float) -> list[float]:
        """The state at one time as a list of floats (no numpy; for event functions)."""
        i = int(self.step_index(np.asarray([t]))[0])
        F = self.coefficients(np.asarray([i]))[i].ravel().tolist()
        return _kernels(self.n)[2]((t - self.t_old[i]) / self.h[i], self.y_old[i].tolist(), F)


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
    if array_state:
        user_fun = fun

        def fun(t: float, yy: list[float]) -> Sequence[float]:  # noqa: F811
            return np.asarray(user_fun(t, np.asarray(yy)), dtype=float).tolist()

        def _wrap_event(ev: Callable) -> Callable:
            def g(t: float, yy: list[float]) -> float:
                return ev(t, np.asarray(yy))
            return g
        events = [_wrap_event(ev) for ev in (events or [])]

    step, dense, interp = _kernels(n)
    events = list(events or [])
    props = [_event_props(ev) for ev in events]
    counts = [0] * len(events)
    t_events: list[list[float]] = [[] for _ in events]
    y_events: list[list[list[float]]] = [[] for _ in events]

    f = list(fun(t0, y))
    if len(f) != n:
        raise ValueError(f"fun returned {len(f)} values for a state of {n}")
    nfev = 1
    g_old = [float(ev(t0, y)) for ev in events]

    ts_old: list[float] = []
    hs: list[float] = []
    ys_old: list[list[float]] = []
    ys_new: list[list[float]] = []
    Ks: list[tuple] = []
    coef: dict[int, tuple] = {}
    t_out, y_out = [t0], [y]
    n_rej = 0
    status = 0

    if first_step is None:
        h_abs = _initial_step(fun, t0, y, f, t_bound, rtol, atol_l)
        nfev += 1
    else:
        if not first_step > 0:
            raise ValueError("first_step must be positive")
        h_abs = min(float(first_step), t_bound - t0)
    t = t0
    nextafter = math.nextafter
    while t < t_bound:
        min_step = 10.0 * (nextafter(t, math.inf) - t)
        if h_abs > max_step:
            h_abs = max_step
        elif h_abs < min_step:
            h_abs = min_step
        rejected = False
        while True:
            if not h_abs >= min_step:  # also a NaN step from a NaN right-hand side
                status = -1
                break
            t_new = t + h_abs
            if t_new > t_bound:
                t_new = t_bound
            h = t_new - t
            h_abs = h
            y_new, f_new, err, K = step(fun, t, h, y, f, rtol, atol_l)
            nfev += _NS
            h_abs = next_step_size(h_abs, err, rejected)
            if err < 1.0:
                break
            n_rej += 1
            rejected = True
        if status < 0:
            break
        i_step = len(ts_old)
        ts_old.append(t)
        hs.append(h)
        ys_old.append(y)
        ys_new.append(y_new)
        Ks.append(K)

        if events:
            g_new = [float(ev(t_new, y_new)) for ev in events]
            active = [j for j, (dr, _) in enumerate(props)
                      if _crossed(g_old[j], g_new[j], dr)]
            if active:
                F = coef.get(i_step)
                if F is None:
                    F = dense(fun, t, h, y, y_new, K)
                    coef[i_step] = F
                    nfev += 3
                hits = sorted((_locate(events[j], interp, t, h, y, list(F), g_old[j],
                                       g_new[j]), j) for j in active)
                stop_at = None
                for te, j in hits:
                    counts[j] += 1
                    t_events[j].append(te)
                    y_events[j].append(interp((te - t) / h, y, F))
                    if props[j][1] and counts[j] >= props[j][1]:
                        stop_at = te
                        break
                if stop_at is not None:
                    status = 1
                    y_stop = interp((stop_at - t) / h, y, F)
                    t_out.append(stop_at)
                    y_out.append(y_stop)
                    t = stop_at
                    break
            g_old = g_new
        t, y, f = t_new, y_new, f_new
        t_out.append(t)
        y_out.append(y)

    sol = None
    if dense_output:
        sol = DenseSolution(fun, n, ts_old, hs, ys_old, ys_new, Ks, t_end=t, coef=coef,
                            vectorized_fun=vectorized_fun)
    return RKResult(
        t=np.asarray(t_out, dtype=float),
        y=np.asarray(y_out, dtype=float).T.reshape(n, len(t_out)),
        sol=sol,
        t_events=[np.asarray(v, dtype=float) for v in t_events] if events else None,
        y_events=[np.asarray(v, dtype=float).reshape(len(v), n) for v in y_events]
        if events else None,
        status=status, message=MESSAGES[status], nfev=nfev,
        n_accepted=len(ts_old), n_rejected=n_rej,
    )
