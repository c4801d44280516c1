"""The peaks of a shot reduced in compiled code, on the integrator's dense output: no table.

A sweep or an optimiser wants a handful of figures per design (the peak forces, the least
sling tension, the counterweight's lowest point), not a table of 1500 rows. Here one compiled
call walks the steps of every phase of a :class:`~trebuchet.model.simulate.Trajectory` (the
DOP853 steps and interpolation coefficients of :mod:`trebuchet.model.shot_kernel`), samples
each step at :data:`SAMPLES_PER_STEP` points, evaluates the loads there with the model's own
compiled formulas (:func:`trebuchet.model.dynamics.phase_state`,
:func:`trebuchet.model.forces.row_loads`,
:func:`trebuchet.model.kinematics.counterweight_position_xy`; nothing is written twice) and
keeps, for each figure, the best sample. Every local best of the samples within
:data:`CANDIDATE_SHARE` of the best is then located on the dense output: :data:`GOLDEN_STEPS`
steps of golden-section search shrink its bracket (two sample spacings, ~20 ms) to ~0.5 ms,
and :data:`PARABOLA_STEPS` steps of parabolic interpolation find the extremum in it (on the
paper's engine the peaks then agree with a 1 µs table around them to all 15 digits).

The figures are therefore the extrema over the continuous shot, not over a table's rows: a
row maximum at a 1 ms step lies below them by up to ~1e-5 of the peak.

Where the C engine runs, the same search runs in C on the C's steps, in the same call as the
shot (``fmu/c/treb_peaks.c``, :mod:`trebuchet.model.c_peaks`, with the settings of this
module): this kernel is the path without a compiler, and for a shot the C refuses where the
numba integrator does not.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numba
import numpy as np

from trebuchet.model import dynamics as dyn
from trebuchet.model import forces as fo
from trebuchet.model import kinematics as kin
from trebuchet.model import (
    loads_kernel,  # noqa: F401 - registers row_loads for numba
    shot_kernel,
)
from trebuchet.model.numba_cache import discard_stale_cache
from trebuchet.model.shot_kernel import _interp

__all__ = ["EXTREMA", "reduce_phases", "SAMPLES_PER_STEP", "GOLDEN_STEPS", "PARABOLA_STEPS",
           "CANDIDATE_SHARE"]

#: The extrema the kernel reduces, in its output order; each is a maximum of the quantity
#: named (a minimum is the maximum of its negative).
EXTREMA = ("F_S_abs", "F_H_abs", "F_R_abs", "F_R_perp_abs", "torque_abs", "-sling_tension",
           "-y_M", "energy_sum_abs")
_N = len(EXTREMA)
_HELD_ONLY = 5  # -sling_tension: phases 1 and 2 only
_CLEARANCE = 6  # -y_M: up to t_clear only
_NO_REFINE = 7  # the energy sum: a diagnostic, its largest sample

SAMPLES_PER_STEP = 2
GOLDEN_STEPS = 6
PARABOLA_STEPS = 3
CANDIDATE_SHARE = 0.02

_I_FS, _I_FH, _I_FR = (fo.ROW_COLUMNS.index(c) for c in ("F_S_abs", "F_H_abs", "F_R_abs"))
_I_PERP, _I_TQ = fo.ROW_COLUMNS.index("F_R_perp"), fo.ROW_COLUMNS.index("torque")
_I_TENSION = fo.ROW_COLUMNS.index("sling_tension")
_I_EM, _I_EMM, _I_EB = (fo.ROW_COLUMNS.index(c) for c in ("E_m", "E_M", "E_beam"))
_GOLD = (math.sqrt(5.0) - 1.0) / 2.0


@numba.njit(cache=True)
def _values(kind, y, n, e, g, H, rest, em_release, out):  # noqa: ANN001, ANN202 - numba
    """The :data:`EXTREMA` quantities at one state ``y`` (its first ``n`` entries) of phase
    ``kind`` into ``out``; the state's last two entries, where it has more than the angles
    and rates, are the energies lost to friction in units of ``dynamics.energy_scale``."""
    th, ps, ph, th_d, ps_d, ph_d, th_dd, ps_dd, ph_dd = dyn.phase_state(kind, y, e, g, H, math)
    row = fo.row_loads(kind, th, th_d, th_dd, ps, ps_d, ps_dd, ph, ph_d, ph_dd, e, g, H, False,
                       rest)
    out[0] = row[_I_FS]
    out[1] = row[_I_FH]
    out[2] = row[_I_FR]
    out[3] = abs(row[_I_PERP])
    out[4] = abs(row[_I_TQ])
    out[5] = -row[_I_TENSION] if kind <= 2 else -math.inf
    out[6] = -kin.counterweight_position_xy(math.cos(th), math.sin(th), math.cos(ps),
                                            math.sin(ps), e, H)[1]
    e_m = row[_I_EM] if kind <= 2 else em_release
    lost = 0.0
    if n > (6 if kind == 2 else 4):
        lost = (y[n - 2] + y[n - 1]) * dyn.energy_scale(e, g)
    out[7] = abs(e_m + row[_I_EMM] + row[_I_EB] + lost)


@numba.njit(cache=True)
def _state(T, Hs, Y, Fs, k0, k1, n, t, y):  # noqa: ANN001, ANN202
    """The state of the phase whose steps are ``k0 .. k1-1`` at time ``t`` into ``y[:n]``; a
    time on a step boundary takes the step that ends there (as the simulator's tables)."""
    k = k0
    while k + 1 < k1 and T[k + 1] < t:
        k += 1
    _interp((t - T[k]) / Hs[k], Y[k, :n], Fs[k, :, :n], y[:n])


@numba.njit(cache=True)
def _at(j, kind, T, Hs, Y, Fs, k0, k1, n, t, e, g, H, rest, em, y, v):  # noqa: ANN001, ANN202
    """Quantity ``j`` of :data:`EXTREMA` at time ``t`` of a phase."""
    _state(T, Hs, Y, Fs, k0, k1, n, t, y)
    _values(kind, y, n, e, g, H, rest, em, v)
    return v[j]


@numba.njit(cache=True)
def _vertex(x1, x2, x3, f1, f2, f3):  # noqa: ANN001, ANN202
    """The abscissa of the vertex of the parabola through three points (NaN if flat)."""
    p = (x2 - x1) * (f2 - f3)
    q = (x2 - x3) * (f2 - f1)
    den = p - q
    if den == 0.0:
        return math.nan
    return x2 - 0.5 * ((x2 - x1) * p - (x2 - x3) * q) / den


@numba.njit(cache=True)
def _locate_max(j, kind, T, Hs, Y, Fs, k0, k1, n, a, b, e, g, H, rest, em, y, v):  # noqa: ANN001
    """Largest value of quantity ``j`` on ``[a, b]``: :data:`GOLDEN_STEPS` steps of
    golden-section search, then :data:`PARABOLA_STEPS` steps of successive parabolic
    interpolation through the best point and its neighbours. Returns ``(value, time)`` of the
    best point evaluated (the ends included)."""
    fa = _at(j, kind, T, Hs, Y, Fs, k0, k1, n, a, e, g, H, rest, em, y, v)
    fb = _at(j, kind, T, Hs, Y, Fs, k0, k1, n, b, e, g, H, rest, em, y, v)
    c, d = b - _GOLD * (b - a), a + _GOLD * (b - a)
    fc = _at(j, kind, T, Hs, Y, Fs, k0, k1, n, c, e, g, H, rest, em, y, v)
    fd = _at(j, kind, T, Hs, Y, Fs, k0, k1, n, d, e, g, H, rest, em, y, v)
    for _ in range(GOLDEN_STEPS):
        if fc >= fd:
            b, fb, d, fd = d, fd, c, fc
            c = b - _GOLD * (b - a)
            fc = _at(j, kind, T, Hs, Y, Fs, k0, k1, n, c, e, g, H, rest, em, y, v)
        else:
            a, fa, c, fc = c, fc, d, fd
            d = a + _GOLD * (b - a)
            fd = _at(j, kind, T, Hs, Y, Fs, k0, k1, n, d, e, g, H, rest, em, y, v)
    xs = np.array([a, c, d, b, 0.0, 0.0])
    fs = np.array([fa, fc, fd, fb, -math.inf, -math.inf])
    m = 4
    for _ in range(PARABOLA_STEPS):
        order = np.argsort(xs[:m])
        xs[:m], fs[:m] = xs[:m][order], fs[:m][order]
        i = int(np.argmax(fs[:m]))
        if i == 0 or i == m - 1:  # the largest at an end of the bracket: nothing to fit
            break
        x = _vertex(xs[i - 1], xs[i], xs[i + 1], fs[i - 1], fs[i], fs[i + 1])
        if not xs[i - 1] < x < xs[i + 1]:
            break
        xs[m], fs[m] = x, _at(j, kind, T, Hs, Y, Fs, k0, k1, n, x, e, g, H, rest, em, y, v)
        m += 1
    i = int(np.argmax(fs[:m]))
    return fs[i], xs[i]


@numba.njit(cache=True)
def _add(m, t, p, kind, y, n, e, g, H, rest, em, ts, ph, vals):  # noqa: ANN001, ANN202
    _values(kind, y, n, e, g, H, rest, em, vals[m])
    ts[m], ph[m] = t, p
    return m + 1


@numba.njit(cache=True)
def _samples(kinds, k0s, k1s, t_starts, t_ends, sizes, T, Hs, Y, Fs, t_hi, t_clear, e, g, H,
             rest, em):  # noqa: ANN001, ANN202
    """Every phase's steps sampled at :data:`SAMPLES_PER_STEP` points, with the ends of the
    windows (``t_hi``, ``t_clear``) and of the phase among them, up to the later window's end:
    the times (in order within each phase), their phase and the :data:`EXTREMA` there."""
    t_stop = max(t_hi, t_clear)
    total = (Hs.shape[0] + 1) * SAMPLES_PER_STEP + 4 * kinds.shape[0]
    ts = np.empty(total)
    ph = np.empty(total, dtype=np.int64)
    vals = np.empty((total, _N))
    y = np.empty(Y.shape[1])
    m = 0
    for p in range(kinds.shape[0]):
        n, kind, t0 = sizes[p], kinds[p], t_starts[p]
        t_last = min(t_ends[p], t_stop)
        if t_last < t0:
            continue
        special = np.array([t_hi, t_clear, t_last])
        special.sort()
        q, first = 0, m
        for k in range(k0s[p], k1s[p]):
            for s in range(SAMPLES_PER_STEP):
                t = T[k] + Hs[k] * s / SAMPLES_PER_STEP
                if t > t_last:
                    break
                while q < 3 and special[q] < t:
                    if special[q] >= t0 and (m == first or special[q] > ts[m - 1]):
                        _state(T, Hs, Y, Fs, k0s[p], k1s[p], n, special[q], y)
                        m = _add(m, special[q], p, kind, y, n, e, g, H, rest, em, ts, ph, vals)
                    q += 1
                if m > first and t <= ts[m - 1]:
                    continue
                _interp((t - T[k]) / Hs[k], Y[k, :n], Fs[k, :, :n], y[:n])
                m = _add(m, t, p, kind, y, n, e, g, H, rest, em, ts, ph, vals)
        for r in range(q, 3):
            if t0 <= special[r] <= t_last and (m == first or special[r] > ts[m - 1]):
                _state(T, Hs, Y, Fs, k0s[p], k1s[p], n, special[r], y)
                m = _add(m, special[r], p, kind, y, n, e, g, H, rest, em, ts, ph, vals)
    return ts[:m], ph[:m], vals[:m]


@numba.njit(cache=True)
def _reduce(kinds, k0s, k1s, t_starts, t_ends, sizes, T, Hs, Y, Fs, t_hi, t_clear, e, g, H,
            rest, em, out_v, out_t):  # noqa: ANN001, ANN202
    """The :data:`EXTREMA` (``out_v``) and their times (``out_t``): the best sample of each
    within its window, then every local best of the samples near it located on the dense
    output (module doc)."""
    ts, ph, vals = _samples(kinds, k0s, k1s, t_starts, t_ends, sizes, T, Hs, Y, Fs, t_hi,
                            t_clear, e, g, H, rest, em)
    y = np.empty(Y.shape[1])
    v = np.empty(_N)
    last = ts.shape[0] - 1
    for j in range(_N):
        w = t_clear if j == _CLEARANCE else t_hi
        best = -math.inf
        for i in range(ts.shape[0]):
            if ts[i] <= w and vals[i, j] > best:
                best, out_t[j] = vals[i, j], ts[i]
        out_v[j] = best
        if j == _NO_REFINE or not math.isfinite(best):
            continue
        floor = best - CANDIDATE_SHARE * abs(best)
        for i in range(ts.shape[0]):
            p = ph[i]
            if ts[i] > w or vals[i, j] < floor:
                continue
            left = i - 1 if i > 0 and ph[i - 1] == p else i
            right = i + 1 if i < last and ph[i + 1] == p and ts[i + 1] <= w else i
            if left == right or vals[left, j] > vals[i, j] or vals[right, j] > vals[i, j]:
                continue
            found, at = _locate_max(j, kinds[p], T, Hs, Y, Fs, k0s[p], k1s[p], sizes[p],
                                    ts[left], ts[right], e, g, H, rest, em, y, v)
            if found > out_v[j]:
                out_v[j], out_t[j] = found, at


_SOURCES = tuple(Path(m.__file__) for m in (*shot_kernel.FORMULA_MODULES, shot_kernel)) + (
    Path(__file__),)
_COMPILED = (_values, _state, _at, _vertex, _locate_max, _add, _samples, _reduce)
_cold = discard_stale_cache(_COMPILED, _SOURCES, "trebuchet_summary_kernel")


def reduce_phases(phases: list, engine: tuple, g: float, H: float,
                  rest: tuple[float, float, float], em_release: float, t_hi: float,
                  t_clear: float) -> tuple[np.ndarray, np.ndarray]:
    """The :data:`EXTREMA` of a shot and their times (s) over ``[0, t_hi]`` (the clearance over
    ``[0, t_clear]``), from its phases as solved by :func:`kernel_phase.solve_phase` (each a
    :class:`~trebuchet.model.kernel_phase.KernelSolution` with ``kind``, the steps and the
    phase's start ``t0`` and end ``t1``, as :class:`~trebuchet.model.simulate.PhaseSolution`
    holds them). ``engine``: the :data:`~trebuchet.model.shot_kernel.JitEngine`; ``rest``: the
    rest energies (J); ``em_release``: the projectile's energy at release over rest (J), which
    the energy sum takes after release. Values and times are NaN where no sample lies."""
    global _cold
    if _cold:
        _cold = False
        print("trebuchet: compiling the sweep's peak search (once per installation, about 10 s)"
              "...", file=sys.stderr, flush=True)
    width = max(p.sol.y_end.size for p in phases)
    n_steps = [max(p.sol.t_steps.size, 1) for p in phases]
    total = sum(n_steps)
    T, Hs = np.empty(total), np.empty(total)
    Y, Fs = np.zeros((total, width)), np.zeros((total, 7, width))
    k0s, k1s = np.empty(len(phases), np.int64), np.empty(len(phases), np.int64)
    k = 0
    for i, p in enumerate(phases):
        s, n = p.sol, p.sol.y_end.size
        k0s[i], k1s[i] = k, k + n_steps[i]
        if s.t_steps.size:  # a phase of zero length holds its one state
            T[k:k1s[i]], Hs[k:k1s[i]] = s.t_steps, s.h
            Y[k:k1s[i], :n], Fs[k:k1s[i], :, :n] = s.y_steps, s.coef
        else:
            T[k], Hs[k], Y[k, :n] = s.t_end, 1.0, s.y_end
        k = k1s[i]
    out_v, out_t = np.full(_N, np.nan), np.full(_N, np.nan)
    _reduce(np.array([p.sol.kind for p in phases], np.int64), k0s, k1s,
            np.array([p.t0 for p in phases]), np.array([p.t1 for p in phases]),
            np.array([p.sol.y_end.size for p in phases], np.int64), T, Hs, Y, Fs,
            float(t_hi), float(t_clear), engine, float(g), float(H),
            tuple(float(r) for r in rest), float(em_release), out_v, out_t)
    return out_v, out_t
