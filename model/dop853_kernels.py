"""The generated kernels of the pure-Python DOP853 (:mod:`trebuchet.model.integrator`) and
its lazy dense output.

One step, the dense coefficients of a step and a one-point interpolation are written as
straight-line Python over float locals for a given state dimension ``n`` (:func:`kernels`,
compiled once per ``n``), so a step costs little more than its twelve right-hand-side
calls; :class:`DenseSolution` builds a step's three extra stages and seven interpolation
coefficients the first time an output time falls in it. Coefficients from
:mod:`trebuchet.model.dop853_tableau` (Hairer, Nørsett and Wanner, "Solving Ordinary
Differential Equations I", 2nd ed., Sec. II.10).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache
from typing import Any

import numpy as np

from trebuchet.model.dop853_tableau import DOP853 as _dop

__all__ = ["kernels", "DenseSolution", "N_STAGES"]

_NS = _dop.N_STAGES  # 12 stages per step; K[12] holds f(t+h, y_new) (first same as last)
N_STAGES = _NS
_NX = _dop.N_STAGES_EXTENDED  # 16: three extra stages for the dense output
_NP = _dop.INTERPOLATOR_POWER  # 7 interpolation coefficients per component


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
def kernels(n: int) -> tuple[Callable, Callable, Callable]:
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
            dense = kernels(self.n)[1]
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
        return kernels(self.n)[2]((t - self.t_old[i]) / self.h[i], self.y_old[i].tolist(), F)
