"""The driven pendulums' integration compiled: ``scipy.integrate.solve_ivp(method="DOP853",
t_eval=…)`` step for step, with the right-hand side of :mod:`.driven_pendulum` inside.

The beam drives a pendulum through θ, θ̇, θ̈ linear between its rows, so DOP853 at rtol 1e-9
takes about a step a row and twelve right-hand sides a step (3000 for 0.7 s at 1000 fps),
where ``solve_ivp``'s numpy overhead (some 30 µs a right-hand side) was most of a
reconstruction's time. This is the same method in one compiled loop: scipy's tableau
(``scipy.integrate._ivp.dop853_coefficients``), its first-step choice, error norm (the
5th- and 3rd-order estimates), step-size control (safety 0.9, factors 0.2–10, no growth
right after a rejection) and dense output (three more stages, seven coefficients) at the
output times. It takes the same steps as scipy up to the rounding of its sums (numpy sums
``K·a`` through BLAS), so the results agree to well inside the tolerance
(``tests/test_continuation_bounds.py`` compares them); ``numpy_passes()`` runs scipy.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numba
import numpy as np
from scipy.integrate._ivp import dop853_coefficients as _dop

from trebuchet.ingest.kalman.kernel import compiled
from trebuchet.model import dynamics as dyn
from trebuchet.model.numba_cache import discard_stale_cache

__all__ = ["integrate", "TABLEAU", "Lengths", "KINDS"]

#: The pendulums' formulas by index: 0 the sling's, 1 the hinged counterweight's.
KINDS = ("sling", "counterweight")

_NS = _dop.N_STAGES  # 12
_NX = _dop.N_STAGES_EXTENDED  # 16
_NP = _dop.INTERPOLATOR_POWER  # 7

#: DOP853's coefficients as scipy has them: A (16, 16), B (12,), C (16,), E3, E5 (13,), D (4, 16).
TABLEAU = tuple(np.ascontiguousarray(a, dtype=np.float64) for a in (
    _dop.A, _dop.B, _dop.C, _dop.E3, _dop.E5, _dop.D))


class Lengths(NamedTuple):
    """An engine's lengths (m), as the compiled pendulum formulas read them (``e.L1`` …)."""

    L1: float
    L2: float
    L3: float
    L4: float


# the model's own formulas compiled by numba (their source, not a copy), not cached on their
# own: they are compiled into the cached functions below, whose cache is emptied when
# model/dynamics.py changes (:func:`~trebuchet.model.numba_cache.discard_stale_cache`)
_sling_dd = numba.njit(error_model="numpy")(dyn.sling_pendulum_phi_dd)
_counterweight_dd = numba.njit(error_model="numpy")(dyn.counterweight_pendulum_psi_dd)


def _rhs(kind, s, y, x, ys, slopes, shift, params, out):  # noqa: ANN001, ANN201 - numba
    """The ensemble's derivative at time ``s`` into ``out``: ``y`` the members' angles then
    their rates; the beam's θ, θ̇, θ̈ and θ̈'s sd (``ys`` (4, k) at the times ``x``, with
    ``slopes`` their differences over the intervals) linear between the rows as
    ``np.interp`` has them; each member's θ̈ shifted by ``shift`` times θ̈'s sd; ``kind`` 0
    the sling, 1 the counterweight; ``params`` L1, L2, L3, L4 (m), g (m/s²)."""
    m = shift.shape[0]
    n = x.shape[0]
    j = np.searchsorted(x, s, side="right") - 1
    th, th_d, th_dd, sd = 0.0, 0.0, 0.0, 0.0
    for q in range(4):
        if j < 0 or j >= n - 1 or s == x[j]:
            v = ys[q, 0 if j < 0 else j]
        else:
            v = slopes[q, j] * (s - x[j]) + ys[q, j]
            if v != v:  # NaN one way: np.interp tries the other end, then the equal values
                v = slopes[q, j] * (s - x[j + 1]) + ys[q, j + 1]
                if v != v and ys[q, j] == ys[q, j + 1]:
                    v = ys[q, j]
        if q == 0:
            th = v
        elif q == 1:
            th_d = v
        elif q == 2:
            th_dd = v
        else:
            sd = v
    for i in range(m):
        out[i] = y[m + i]
    e = Lengths(params[0], params[1], params[2], params[3])
    drive = th_dd + shift * sd
    if kind == 0:
        out[m:] = _sling_dd(th, th_d, drive, y[:m], e, params[4])
    else:
        out[m:] = _counterweight_dd(th, th_d, drive, y[:m], e, params[4])



def _stage_input(y, K, a, s, h, out):  # noqa: ANN001, ANN201 - numba
    """``out = y + (Σ_{i<s} a[i] K[i]) h``."""
    for j in range(y.shape[0]):
        acc = 0.0
        for i in range(s):
            acc += K[i, j] * a[i]
        out[j] = y[j] + acc * h


def _step(kind, x, ys, slopes, shift, params, t, y, f, h, K, A, B, C, y_new, tmp
          ):  # noqa: ANN001, ANN201 - numba
    """One DOP853 step from ``(t, y)`` (``f`` its derivative) of size ``h``: ``y_new`` and
    the stages ``K`` (13, n), ``K[12]`` the derivative at the step's end."""
    n = y.shape[0]
    for j in range(n):
        K[0, j] = f[j]
    for s in range(1, _NS):
        _stage_input(y, K, A[s], s, h, tmp)
        _rhs(kind, t + C[s] * h, tmp, x, ys, slopes, shift, params, K[s])
    for j in range(n):
        acc = 0.0
        for i in range(_NS):
            acc += K[i, j] * B[i]
        y_new[j] = y[j] + h * acc
    _rhs(kind, t + h, y_new, x, ys, slopes, shift, params, K[_NS])


def _error_norm(K, h, E3, E5, scale):  # noqa: ANN001, ANN201 - numba
    """scipy's ``DOP853._estimate_error_norm``."""
    n = scale.shape[0]
    e5 = 0.0
    e3 = 0.0
    for j in range(n):
        a5 = 0.0
        a3 = 0.0
        for i in range(_NS + 1):
            a5 += K[i, j] * E5[i]
            a3 += K[i, j] * E3[i]
        a5 /= scale[j]
        a3 /= scale[j]
        e5 += a5 * a5
        e3 += a3 * a3
    n5 = np.sqrt(e5)
    n3 = np.sqrt(e3)
    e5 = n5 * n5
    e3 = n3 * n3
    if e5 == 0.0 and e3 == 0.0:
        return 0.0
    return abs(h) * e5 / np.sqrt((e5 + 0.01 * e3) * n)


def _dense_out(kind, x, ys, slopes, shift, params, t_old, h, y_old, y, f, K, A, C, D, tmp, F,
               ts, lo, hi, out):  # noqa: ANN001, ANN201 - numba
    """The dense output of the last step at ``ts[lo:hi]`` into the columns ``lo:hi`` of
    ``out`` (n, m): the three extra stages, then scipy's ``Dop853DenseOutput``."""
    n = y.shape[0]
    for s in range(_NS + 1, _NX):
        _stage_input(y_old, K, A[s], s, h, tmp)
        _rhs(kind, t_old + C[s] * h, tmp, x, ys, slopes, shift, params, K[s])
    for j in range(n):
        d = y[j] - y_old[j]
        F[0, j] = d
        F[1, j] = h * K[0, j] - d
        F[2, j] = 2.0 * d - h * (f[j] + K[0, j])
        for r in range(_NP - 3):
            acc = 0.0
            for i in range(_NX):
                acc += D[r, i] * K[i, j]
            F[3 + r, j] = h * acc
    for q in range(lo, hi):
        x = (ts[q] - t_old) / h
        for j in range(n):
            v = 0.0
            for i in range(_NP):
                v += F[_NP - 1 - i, j]
                v *= x if i % 2 == 0 else 1.0 - x
            out[j, q] = v + y_old[j]


def _initial_step(kind, x, ys, slopes, shift, params, t0, y0, f0, t_bound, rtol, atol, tmp,
                  f1):  # noqa: ANN001, ANN201 - numba
    """scipy's ``select_initial_step`` for order 7 (forward, no maximum step)."""
    n = y0.shape[0]
    interval = abs(t_bound - t0)
    if interval == 0.0:
        return 0.0
    d0 = 0.0
    d1 = 0.0
    for j in range(n):
        sc = atol + abs(y0[j]) * rtol
        d0 += (y0[j] / sc) ** 2
        d1 += (f0[j] / sc) ** 2
    d0 = np.sqrt(d0) / np.sqrt(n)
    d1 = np.sqrt(d1) / np.sqrt(n)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, interval)
    for j in range(n):
        tmp[j] = y0[j] + h0 * f0[j]
    _rhs(kind, t0 + h0, tmp, x, ys, slopes, shift, params, f1)
    d2 = 0.0
    for j in range(n):
        sc = atol + abs(y0[j]) * rtol
        d2 += ((f1[j] - f0[j]) / sc) ** 2
    d2 = np.sqrt(d2) / np.sqrt(n) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    return min(100.0 * h0, h1, interval)


def _integrate(kind, x, ys, slopes, shift, params, t0, t_bound, y0, ts, rtol, atol, A, B, C,
               E3, E5, D, out):  # noqa: ANN001, ANN201 - numba
    """``solve_ivp`` of :func:`_rhs` over ``(t0, t_bound)`` from ``y0`` with ``t_eval=ts`` and
    ``method="DOP853"`` into ``out`` (n, len(ts)); returns the number of output times
    reached (all, unless a step fell below scipy's smallest)."""
    n = y0.shape[0]
    m = ts.shape[0]
    y = y0.copy()
    f = np.empty(n)
    _rhs(kind, t0, y, x, ys, slopes, shift, params, f)
    K = np.empty((_NX, n))
    F = np.empty((_NP, n))
    tmp = np.empty(n)
    y_new = np.empty(n)
    scale = np.empty(n)
    h_abs = _initial_step(kind, x, ys, slopes, shift, params, t0, y, f, t_bound, rtol, atol,
                          tmp, y_new)
    t = t0
    done = 0
    while t != t_bound:
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        if h_abs < min_step:
            h_abs = min_step
        rejected = False
        while True:
            if h_abs < min_step:
                return done
            t_new = t + h_abs
            if t_new - t_bound > 0.0:
                t_new = t_bound
            h = t_new - t
            h_abs = abs(h)
            _step(kind, x, ys, slopes, shift, params, t, y, f, h, K, A, B, C, y_new, tmp)
            for j in range(n):
                scale[j] = atol + max(abs(y[j]), abs(y_new[j])) * rtol
            err = _error_norm(K, h, E3, E5, scale)
            if err < 1.0:
                factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / 8.0))
                if rejected:
                    factor = min(1.0, factor)
                h_abs *= factor
                break
            h_abs *= max(0.2, 0.9 * err ** (-1.0 / 8.0))
            rejected = True
        f_new = K[_NS].copy()
        hi = np.searchsorted(ts, t_new, side="right")
        if hi > done:
            y_old = y.copy()
            _dense_out(kind, x, ys, slopes, shift, params, t, h, y_old, y_new, f_new, K, A, C,
                       D, tmp, F, ts, done, hi, out)
            done = hi
        t = t_new
        for j in range(n):
            y[j] = y_new[j]
            f[j] = f_new[j]
    return m if done >= m else done


_rhs = compiled(_rhs)
_stage_input = compiled(_stage_input, inline=True)
_step = compiled(_step)
_error_norm = compiled(_error_norm)
_dense_out = compiled(_dense_out)
_initial_step = compiled(_initial_step)
_integrate = compiled(_integrate)
discard_stale_cache((_integrate, _rhs, _stage_input, _step, _error_norm, _dense_out,
                     _initial_step), (Path(dyn.__file__), Path(__file__)),
                    "trebuchet_pendulum_kernel")


def integrate(kind: int, x: np.ndarray, ys: np.ndarray, shift: np.ndarray, params: np.ndarray,
              t0: float, t_bound: float, y0: np.ndarray, ts: np.ndarray, rtol: float,
              atol: float) -> tuple[np.ndarray, int]:
    """The ensemble's states (n, len(ts)) at the output times ``ts`` (increasing, within
    ``(t0, t_bound]``) from ``y0`` at ``t0`` (the arguments of :func:`_rhs`), and how many
    of them were reached."""
    x, ys, shift, params = (np.ascontiguousarray(v, dtype=np.float64)
                            for v in (x, ys, shift, params))
    with np.errstate(invalid="ignore", divide="ignore"):
        slopes = np.ascontiguousarray(np.diff(ys, axis=1) / np.diff(x))
    out = np.full((y0.size, ts.size), np.nan)
    reached = _integrate(int(kind), x, ys, slopes, shift, params, float(t0), float(t_bound),
                         np.ascontiguousarray(y0, dtype=np.float64),
                         np.ascontiguousarray(ts, dtype=np.float64), float(rtol), float(atol),
                         *TABLEAU, out)
    return out, int(reached)
