"""Compiled integration of one phase of a shot: DOP853 and the equations of motion in numba.

The pure-Python DOP853 of :mod:`trebuchet.model.integrator` spends ~5 µs of interpreter time
per right-hand-side call; a shot needs ~600 of them. Here the same method (the same tableau,
error norm, step-size control, first step and dense output, so the two take the same steps
up to rounding) runs compiled, calling the formulas of :mod:`trebuchet.model.dynamics` and
:mod:`trebuchet.model.phase_events` themselves: numba compiles those modules' functions
unchanged (``lib=math``), so no formula is written twice.

* :func:`_integrate` integrates one phase (1 trough, 2 sling, 3 released) until its end or the
  first event that ends it: the steps and their interpolation coefficients (every step's,
  computed in the loop: three more right-hand-side calls a step);
* :func:`_columns` evaluates angles, rates and accelerations at many times at once (the dense
  output and the equations of motion, compiled).

:mod:`trebuchet.model.kernel_phase` is their Python face (``solve_phase``,
``KernelSolution``).

Compiled code is cached on disk (numba ``cache=True``); a digest of the source files it is
built from is kept beside the cache, and a cache built from other sources is discarded on
import, since numba itself only watches the file of the cached function. The first call in a fresh
environment compiles for a few seconds.
"""

from __future__ import annotations

import math
import sys
import types
from collections import namedtuple
from pathlib import Path

import numba
import numpy as np
from numba.extending import register_jitable

from trebuchet.model import dynamics as dyn
from trebuchet.model import forces as fo
from trebuchet.model import friction as fr
from trebuchet.model import kinematics as kin
from trebuchet.model import phase_events as pev
from trebuchet.model.dop853_tableau import DOP853 as _dop
from trebuchet.model.integrator import DENSE_ORDER, ERROR_ORDER, _crossed, next_step_size
from trebuchet.model.numba_cache import discard_stale_cache
from trebuchet.model.scene import Engine

__all__ = ["JitEngine", "jit_engine", "STATE_SIZE", "FORMULA_MODULES", "say_compiling",
           "INTERPOLATOR_COEFFICIENTS"]

#: The modules whose functions compiled code calls unchanged (``lib=math``).
FORMULA_MODULES = (kin, fr, fo, dyn, pev)
for _module in FORMULA_MODULES:
    for _f in list(vars(_module).values()):
        if isinstance(_f, types.FunctionType) and _f.__module__ == _module.__name__:
            register_jitable(_f)
for _f in (_crossed, next_step_size):  # shared with the pure-Python integrator
    register_jitable(_f)

#: The engine as numba sees it: Engine's fields, ``counterweight_offset`` NaN when hinged, and
#: the bearings' friction ``μ r`` (m) at pivot and hinge with its smoothing rate (rad/s).
JitEngine = namedtuple("JitEngine", "L1 L2 L_CM L3 L4 m_b M m I counterweight_offset "
                                    "fixed_counterweight pivot_friction hinge_friction "
                                    "friction_rate")

#: State size of each phase: (θ, ψ, θ̇, ψ̇), (θ, ψ, φ, θ̇, ψ̇, φ̇), (θ, ψ, θ̇, ψ̇); an engine with
#: friction carries two more, the energies lost at pivot and hinge (:func:`dyn.state_derivative`).
STATE_SIZE = {1: 4, 2: 6, 3: 4}

_NS, _NX, _NP = _dop.N_STAGES, _dop.N_STAGES_EXTENDED, _dop.INTERPOLATOR_POWER
_A = np.ascontiguousarray(_dop.A[:_NX, :_NX], dtype=np.float64)
_B = np.ascontiguousarray(_dop.B, dtype=np.float64)
_E3 = np.ascontiguousarray(_dop.E3, dtype=np.float64)
_E5 = np.ascontiguousarray(_dop.E5, dtype=np.float64)
_D = np.ascontiguousarray(_dop.D[:_NP - 3, :_NX], dtype=np.float64)
assert DENSE_ORDER == _NP  # noqa: S101 - the interpolant below has 7 coefficients
#: Coefficients of a step's interpolating polynomial (DOP853's dense output).
INTERPOLATOR_COEFFICIENTS = _NP


def jit_engine(e: Engine) -> JitEngine:
    """The engine's parameters as a :data:`JitEngine`."""
    offset = e.counterweight_offset
    return JitEngine(e.L1, e.L2, e.L_CM, e.L3, e.L4, e.m_b, e.M, e.m, e.I,
                     math.nan if offset is None else float(offset), e.fixed_counterweight,
                     float(e.pivot_friction), float(e.hinge_friction), float(e.friction_rate))


# ---------------------------------------------------------------------------------------------
# Compiled pieces

@numba.njit(cache=True)
def _rate(kind, y, e, g, H, out):  # noqa: ANN001, ANN202 - numba
    """``out = y'`` of phase ``kind`` (:func:`dynamics.state_derivative`)."""
    d = dyn.state_derivative(kind, y, e, g, H, math)
    for i in range(y.shape[0]):
        out[i] = d[i]


@numba.njit(cache=True)
def _event(kind, t, y, e, g, H, par):  # noqa: ANN001, ANN202
    """:func:`phase_events.event_value`, compiled once for every caller."""
    return pev.event_value(kind, t, y, e, g, H, par)


@numba.njit(cache=True)
def _stage(y, h, K, s, out):  # noqa: ANN001, ANN202
    """``out = y + h Σ_{j<s} a_sj K_j``."""
    for i in range(y.shape[0]):
        acc = 0.0
        for j in range(s):
            acc += _A[s, j] * K[j, i]
        out[i] = y[i] + h * acc


@numba.njit(cache=True)
def _step(kind, e, g, H, h, y, K, rtol, atol, y_new, tmp):  # noqa: ANN001, ANN202
    """One DOP853 step from ``y`` with ``K[0] = f(y)``: fills ``K[1..12]`` (``K[12] = f(y_new)``)
    and ``y_new``; returns the error norm of scipy's DOP853 (accept below 1)."""
    n = y.shape[0]
    for s in range(1, _NS):
        _stage(y, h, K, s, tmp)
        _rate(kind, tmp, e, g, H, K[s])
    for i in range(n):
        acc = 0.0
        for j in range(_NS):
            acc += _B[j] * K[j, i]
        y_new[i] = y[i] + h * acc
    _rate(kind, y_new, e, g, H, K[_NS])
    s5 = 0.0
    s3 = 0.0
    for i in range(n):
        d = atol[i] + rtol * max(abs(y[i]), abs(y_new[i]))
        e5 = 0.0
        e3 = 0.0
        for j in range(_NS + 1):
            e5 += _E5[j] * K[j, i]
            e3 += _E3[j] * K[j, i]
        e5 /= d
        e3 /= d
        s5 += e5 * e5
        s3 += e3 * e3
    if s5 == 0.0 and s3 == 0.0:
        return 0.0
    return abs(h) * s5 / math.sqrt((s5 + 0.01 * s3) * n)


@numba.njit(cache=True)
def _dense(kind, e, g, H, h, y, y_new, K, tmp, F):  # noqa: ANN001, ANN202
    """The seven interpolation coefficients ``F`` of an accepted step (three more stages)."""
    for s in range(_NS + 1, _NX):
        _stage(y, h, K, s, tmp)
        _rate(kind, tmp, e, g, H, K[s])
    for i in range(y.shape[0]):
        dy = y_new[i] - y[i]
        F[0, i] = dy
        F[1, i] = h * K[0, i] - dy
        F[2, i] = 2.0 * dy - h * (K[_NS, i] + K[0, i])
        for p in range(_NP - 3):
            acc = 0.0
            for j in range(_NX):
                acc += _D[p, j] * K[j, i]
            F[3 + p, i] = h * acc


@numba.njit(cache=True)
def _interp(x, y0, F, out):  # noqa: ANN001, ANN202
    """The step's polynomial at ``x = (t − t_step)/h`` (Horner in x and 1 − x, as DOP853)."""
    u = 1.0 - x
    for i in range(y0.shape[0]):
        v = F[_NP - 1, i] * x
        for p in range(_NP - 2, -1, -1):
            v += F[p, i]
            v *= u if p % 2 else x
        out[i] = v + y0[i]


@numba.njit(cache=True)
def _interp_point(x, y0, F):  # noqa: ANN001, ANN202
    out = np.empty(y0.shape[0])
    _interp(x, y0, F, out)
    return out


@numba.njit(cache=True)
def _event_at(kind, t, t0, h, y0, F, e, g, H, par):  # noqa: ANN001, ANN202
    """An event function on a step's polynomial at time ``t``."""
    return _event(kind, t, _interp_point((t - t0) / h, y0, F), e, g, H, par)


_XTOL = 4.0 * np.finfo(float).eps


@numba.njit(cache=True)
def _brent(kind, xa, xb, fa, fb, t0, h, y0, F, e, g, H, par):  # noqa: ANN001, ANN202
    """Root of the event in ``[xa, xb]`` (``fa``, ``fb`` of opposite signs) by Brent's method,
    step for step as scipy's ``brentq`` (its ``brentq.c``) with ``xtol = rtol = 4 eps``."""
    xpre, xcur, fpre, fcur = xa, xb, fa, fb
    xblk = fblk = spre = scur = 0.0
    for _ in range(100):
        if fpre != 0.0 and fcur != 0.0 and (fpre < 0.0) != (fcur < 0.0):
            xblk, fblk = xpre, fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (_XTOL + _XTOL * abs(xcur)) / 2.0
        sbis = (xblk - xcur) / 2.0
        if fcur == 0.0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2.0 * abs(stry) < min(abs(spre), 3.0 * abs(sbis) - delta):
                spre, scur = scur, stry
            else:
                spre = scur = sbis
        else:
            spre = scur = sbis
        xpre, fpre = xcur, fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0.0 else -delta
        fcur = _event_at(kind, xcur, t0, h, y0, F, e, g, H, par)
    return xcur


@numba.njit(cache=True)
def _locate(kind, t0, h, y0, F, g0, g1, e, g, H, par):  # noqa: ANN001, ANN202
    """Root of an event that changed sign over one step, on the step's polynomial (as
    :func:`trebuchet.model.integrator._locate`)."""
    t1 = t0 + h
    if g0 == 0.0:
        return t0
    if g1 == 0.0:
        return t1
    ga = _event_at(kind, t0, t0, h, y0, F, e, g, H, par)
    gb = _event_at(kind, t1, t0, h, y0, F, e, g, H, par)
    if ga == 0.0:
        return t0
    if gb == 0.0 or (ga > 0.0) == (gb > 0.0):
        return t1 if abs(gb) <= abs(ga) else t0
    return _brent(kind, t0, t1, ga, gb, t0, h, y0, F, e, g, H, par)


@numba.njit(cache=True)
def _initial_step(kind, e, g, H, t0, y0, f0, t_bound, rtol, atol):  # noqa: ANN001, ANN202
    """Hairer's starting step, as scipy's ``select_initial_step``; one right-hand-side call."""
    n = y0.shape[0]
    span = abs(t_bound - t0)
    if span == 0.0:
        return 0.0
    d0 = 0.0
    d1 = 0.0
    for i in range(n):
        sc = atol[i] + abs(y0[i]) * rtol
        d0 += (y0[i] / sc) ** 2
        d1 += (f0[i] / sc) ** 2
    d0 = math.sqrt(d0 / n)
    d1 = math.sqrt(d1 / n)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, span)
    y1 = y0 + h0 * f0
    f1 = np.empty(n)
    _rate(kind, y1, e, g, H, f1)
    d2 = 0.0
    for i in range(n):
        sc = atol[i] + abs(y0[i]) * rtol
        d2 += ((f1[i] - f0[i]) / sc) ** 2
    d2 = math.sqrt(d2 / n) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (ERROR_ORDER + 1))
    return min(100.0 * h0, h1, span)


@numba.njit(cache=True)
def _grown(a, cap):  # noqa: ANN001, ANN202
    """``a`` copied into a longer array of ``cap`` rows (the rest uninitialised)."""
    out = np.empty((cap, *a.shape[1:]))
    out[:a.shape[0]] = a
    return out


@numba.njit(cache=True)
def _integrate(kind, e, g, H, t0, t1, y0, rtol, atol, first_step, ev_kind, ev_dir,
               ev_par):  # noqa: ANN001, ANN202
    """DOP853 from ``t0`` to ``t1`` or to the end of the first step in which an event
    crosses zero. Returns the steps (start times, sizes, start states, coefficients), the
    final time and state, status (0 end, 1 event, −1 step too small), evaluations, rejected
    steps and the index of the event that ended the phase (−1 if none), located to ~1e-15 s
    on the last step's polynomial."""
    n = y0.shape[0]
    cap = 64
    T = np.empty(cap)
    Hs = np.empty(cap)
    Y = np.empty((cap, n))
    Fs = np.empty((cap, _NP, n))
    K = np.empty((_NX, n))
    tmp = np.empty(n)
    y = y0.copy()
    y_new = np.empty(n)
    f = np.empty(n)
    _rate(kind, y, e, g, H, f)
    nfev = 1
    nev = ev_kind.shape[0]
    g_old = np.empty(nev)
    g_new = np.empty(nev)
    crossed = np.zeros(nev, dtype=np.bool_)
    for j in range(nev):
        g_old[j] = _event(ev_kind[j], t0, y, e, g, H, ev_par[j])
    if first_step > 0.0:
        h_abs = min(first_step, t1 - t0)
    else:
        h_abs = _initial_step(kind, e, g, H, t0, y, f, t1, rtol, atol)
        nfev += 1
    t = t0
    n_steps = 0
    n_rej = 0
    status = 0
    while t < t1:
        min_step = 10.0 * (np.nextafter(t, np.inf) - t)
        if h_abs < min_step:
            h_abs = min_step
        rejected = False
        h = 0.0
        while True:
            if not h_abs >= min_step:  # also a NaN step from a NaN right-hand side
                status = -1
                break
            t_new = t + h_abs
            if t_new > t1:
                t_new = t1
            h = t_new - t
            h_abs = h
            K[0] = f
            err = _step(kind, e, g, H, h, y, K, rtol, atol, y_new, tmp)
            nfev += _NS
            h_abs = next_step_size(h_abs, err, rejected)
            if err < 1.0:
                break
            n_rej += 1
            rejected = True
        if status < 0:
            break
        if n_steps == cap:
            cap *= 2
            T, Hs, Y, Fs = _grown(T, cap), _grown(Hs, cap), _grown(Y, cap), _grown(Fs, cap)
        T[n_steps] = t
        Hs[n_steps] = h
        Y[n_steps] = y
        _dense(kind, e, g, H, h, y, y_new, K, tmp, Fs[n_steps])
        nfev += 3
        n_steps += 1
        hit = False
        for j in range(nev):
            g_new[j] = _event(ev_kind[j], t_new, y_new, e, g, H, ev_par[j])
            crossed[j] = _crossed(g_old[j], g_new[j], ev_dir[j])
            hit = hit or crossed[j]
        t = t_new
        y[:] = y_new
        f[:] = K[_NS]
        if hit:
            status = 1
            break
        g_old[:] = g_new
    which = -1
    if status == 1:  # the first of the events that crossed in the last step ends the phase
        k = n_steps - 1
        for j in range(nev):
            if crossed[j]:
                te = _locate(ev_kind[j], T[k], Hs[k], Y[k], Fs[k], g_old[j], g_new[j], e, g, H,
                             ev_par[j])
                if which < 0 or te < t:
                    t, which = te, j
        _interp((t - T[k]) / Hs[k], Y[k], Fs[k], y)
    return (T[:n_steps].copy(), Hs[:n_steps].copy(), Y[:n_steps].copy(), Fs[:n_steps].copy(),
            t, y, status, nfev, n_rej, which)


@numba.njit(cache=True)
def _state_at(ts, Y, Hs, Fs, t, y):  # noqa: ANN001, ANN202
    """The state at time ``t`` into ``y``: step ``k`` spans ``(ts[k], ts[k+1]]`` (a time on a
    step boundary takes the step that ends there, as scipy's OdeSolution)."""
    k = min(max(np.searchsorted(ts, t) - 1, 0), Hs.shape[0] - 1)
    _interp((t - ts[k]) / Hs[k], Y[k], Fs[k], y)


@numba.njit(cache=True)
def _columns(kind, e, g, H, ts, Y, Hs, Fs, t, out):  # noqa: ANN001, ANN202
    """Rows θ, ψ, φ, θ̇, ψ̇, φ̇, θ̈, ψ̈, φ̈ of ``out`` at times ``t`` (φ NaN in phase 3); where
    ``out`` has more rows, the states after the phase's angles and rates (the lost energies
    of friction) follow."""
    y = np.empty(Y.shape[1])
    extra = out.shape[0] - 9
    first = y.shape[0] - extra
    for m in range(t.shape[0]):
        _state_at(ts, Y, Hs, Fs, t[m], y)
        th, ps, ph, th_d, ps_d, ph_d, th_dd, ps_dd, ph_dd = dyn.phase_state(kind, y, e, g, H,
                                                                             math)
        out[0, m], out[1, m], out[2, m] = th, ps, ph
        out[3, m], out[4, m], out[5, m] = th_d, ps_d, ph_d
        out[6, m], out[7, m], out[8, m] = th_dd, ps_dd, ph_dd
        for j in range(extra):
            out[9 + j, m] = y[first + j]


@numba.njit(cache=True)
def _states(ts, Y, Hs, Fs, t, out):  # noqa: ANN001, ANN202
    """The state at times ``t`` into the columns of ``out`` (n, m)."""
    y = np.empty(Y.shape[1])
    for m in range(t.shape[0]):
        _state_at(ts, Y, Hs, Fs, t[m], y)
        out[:, m] = y


_COMPILED = (_rate, _event, _grown, _stage, _step, _dense, _interp, _interp_point, _event_at,
             _brent, _locate, _initial_step, _integrate, _state_at, _columns, _states)
_SOURCES = (*(Path(m.__file__) for m in FORMULA_MODULES), Path(_crossed.__code__.co_filename),
            Path(__file__))


def _discard_stale_cache() -> bool:
    """:func:`discard_stale_cache` of this module's compiled functions."""
    return discard_stale_cache(_COMPILED, _SOURCES, "trebuchet_shot_kernel")


_cold = _discard_stale_cache()


def say_compiling() -> None:
    """One line on stderr before the first compilation of a fresh installation (~15 s)."""
    global _cold
    if _cold:
        _cold = False
        print("trebuchet: compiling the simulator (once per installation, about 15 s)...",
              file=sys.stderr, flush=True)
