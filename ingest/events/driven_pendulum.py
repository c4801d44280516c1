"""An angle carried on past the end of its track by a pendulum the smoothed beam drives.

The sling (:mod:`.sling_continuation`) and the hinged counterweight
(:mod:`trebuchet.ingest.smoothing.counterweight_continuation`) each swing as a pendulum
hung from a point of the beam: given θ(t), θ̇(t), θ̈(t), the angle follows from its state at
one instant. :func:`driven_pendulum` integrates such an equation from the angle's last
smoothed state, with the smoothed beam as the driver (θ, θ̇, θ̈ linear between the rows,
at most one frame apart, where the smoother's own model is locally cubic), and its
covariance over an ensemble of :data:`DRAWS` starting states drawn from the smoother's
covariance there; each member's θ̈ may be shifted by its own multiple (standard normal) of
θ̈'s sd.

It goes only as far as it is used: up to a time ``until`` its caller gives, and never past
a gap in the beam's rows longer than :data:`MAX_GAP_FRAMES` frames (the driver between two
rows is a straight line, which stands for the beam only over a frame or so; a log whose
last time is 1e9 s would have the pendulum swing for 1e9 s). A continuation stopped at a
gap says so (:attr:`PendulumRun.gap`).
"""

from __future__ import annotations

from bisect import bisect_right
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from trebuchet.ingest.events.pendulum_kernel import KINDS, integrate
from trebuchet.ingest.kalman import reference
from trebuchet.model import dynamics as dyn

__all__ = ["DRAWS", "MAX_GAP_FRAMES", "FORMULAS", "PendulumRun", "driven_pendulum"]

#: Starting states drawn for the sd (a fixed seed: the same log gives the same sd).
DRAWS = 24

#: The pendulum is not carried across a step between the beam's rows longer than this many
#: frames (the median frame interval).
MAX_GAP_FRAMES = 10.0


#: The pendulums hung from the beam, each the model's own formula (rad/s², numpy-broadcasting):
#: the sling from the spigot (phase II), the hinged counterweight from the hinge.
FORMULAS: dict[str, Callable[..., Any]] = {
    "sling": dyn.sling_pendulum_phi_dd, "counterweight": dyn.counterweight_pendulum_psi_dd}

@dataclass(frozen=True, eq=False)
class PendulumRun:
    """The angle (rad), its rate (rad/s) and acceleration (rad/s²) on the rows ``rows``
    after the track's last row ``start``, each (k,), and their covariance ``cov``
    (k, 3, 3) over the ensemble; ``gap``: the time (s) of the beam's last row before a
    gap the run stopped at (None: none)."""

    rows: np.ndarray
    angle: np.ndarray
    rate: np.ndarray
    acc: np.ndarray
    cov: np.ndarray
    start: int
    gap: float | None = None


def _reach(t: np.ndarray, rows: np.ndarray, last: int, until: float | None
           ) -> tuple[np.ndarray, float | None]:
    """The rows (indexes of ``t``, after ``last``) the run covers: up to the time ``until``
    (s; None: all), and before the first step between consecutive rows (from ``last`` on)
    longer than :data:`MAX_GAP_FRAMES` frames; and the time of the row before that gap."""
    if until is not None:
        rows = rows[t[rows] <= until]
    if rows.size == 0:
        return rows, None
    frame = float(np.median(np.diff(t))) if t.size > 1 else np.inf
    steps = np.diff(t[np.r_[last, rows]])
    wide = np.flatnonzero(~(steps <= MAX_GAP_FRAMES * frame))
    if wide.size == 0:
        return rows, None
    cut = int(wide[0])
    return rows[:cut], float(t[last] if cut == 0 else t[rows[cut - 1]])


class _Driver:
    """θ, θ̇, θ̈ and θ̈'s sd of the beam at a time, linear between its rows: the same
    arithmetic as ``np.interp`` (slope ``(y[j+1] − y[j]) / (x[j+1] − x[j])``, then
    ``slope (s − x[j]) + y[j]``; the end values outside), in plain floats, four at once."""

    def __init__(self, x: np.ndarray, ys: tuple[np.ndarray, ...]) -> None:
        self.x = x.tolist()
        self.ys = [y.tolist() for y in ys]
        with np.errstate(invalid="ignore", divide="ignore"):
            self.slopes = [(np.diff(y) / np.diff(x)).tolist() for y in ys]

    def __call__(self, s: float) -> list[float]:
        x = self.x
        j = bisect_right(x, s) - 1
        if j < 0:
            return [y[0] for y in self.ys]
        if j >= len(x) - 1 or s == x[j]:
            return [y[j] for y in self.ys]
        out = []
        for y, slope in zip(self.ys, self.slopes, strict=True):
            v = slope[j] * (s - x[j]) + y[j]
            if v != v:  # NaN one way: np.interp tries the other end, then the equal values
                v = slope[j] * (s - x[j + 1]) + y[j + 1]
                if v != v and y[j] == y[j + 1]:
                    v = y[j]
            out.append(v)
        return out


def _numpy_rate(pendulum: str, x: np.ndarray, ys: np.ndarray, shift: np.ndarray,
                engine: Any, g: float) -> Callable[[float, np.ndarray], np.ndarray]:
    """``rate(s, y)`` of the ensemble for ``solve_ivp`` in numpy (the compiled integration's
    reference, :mod:`.pendulum_kernel`): the members' angles then their rates in ``y``; the
    beam's drivers ``ys`` (4, k: θ, θ̇, θ̈, θ̈'s sd) at the times ``x`` (k,); each member's θ̈
    shifted by ``shift`` times θ̈'s sd."""
    m = shift.size
    drive = _Driver(x, tuple(ys))
    formula = FORMULAS[pendulum]

    def rate(s: float, y: np.ndarray) -> np.ndarray:
        th, th_d, th_dd, th_dd_sd = drive(s)
        return np.concatenate([y[m:], formula(th, th_d, th_dd + shift * th_dd_sd, y[:m],
                                              engine, g)])
    return rate


def driven_pendulum(t: np.ndarray, theta: np.ndarray, theta_d: np.ndarray,
                    theta_dd: np.ndarray, last: int, state: np.ndarray, cov: np.ndarray,
                    pendulum: str, engine: Any, g: float, *,
                    theta_dd_sd: np.ndarray | None = None, seed: int = 20261125,
                    until: float | None = None, spread: bool = True) -> PendulumRun:
    """The angle from row ``last`` on over the later rows where the beam (``t`` s,
    ``theta`` rad, ``theta_d`` rad/s, ``theta_dd`` rad/s², and ``theta_dd_sd`` if given)
    is known, up to the time ``until`` (s; None: the log's end) and not across a gap of the
    beam's rows (module doc), by the ``pendulum``'s formula (:data:`FORMULAS`, "sling" or
    "counterweight") for the ``engine`` (its lengths, m) and gravity ``g`` (m/s²), from
    ``state`` (angle, rate) at ``last`` with ``cov`` (3, 3) its smoothed covariance of
    (angle, rate, acceleration) there. With ``theta_dd_sd`` each member's θ̈ is shifted by
    a drawn multiple of it. Integrated compiled (:mod:`.pendulum_kernel`; within
    :func:`~trebuchet.ingest.kalman.reference.numpy_passes` by scipy's ``solve_ivp`` with a
    numpy right-hand side). ``spread=False``: the
    smoothed start alone, no ensemble, the covariance NaN (where only the angle is used:
    the ensemble's wider members set the integrator's steps, twice to four times as many)."""
    formula = FORMULAS[pendulum]
    usable = np.isfinite(theta) & np.isfinite(theta_d) & np.isfinite(theta_dd)
    shifted = theta_dd_sd is not None
    sd = np.zeros(t.size) if theta_dd_sd is None else np.asarray(theta_dd_sd, dtype=float)
    if shifted:
        usable &= np.isfinite(sd)
    rows = np.arange(last + 1, t.size)
    rows, gap = _reach(t, rows[usable[rows]], last, until)
    if rows.size == 0:
        empty = np.zeros(0)
        return PendulumRun(rows, empty, empty, empty, np.zeros((0, 3, 3)), last, gap)
    x, ys = t[usable], np.stack([v[usable] for v in (theta, theta_d, theta_dd, sd)])
    c2 = np.nan_to_num(np.asarray(cov, dtype=float)[:2, :2])
    rng = np.random.default_rng(seed)
    draws = (rng.multivariate_normal(state, 0.5 * (c2 + c2.T), size=DRAWS, method="eigh")
             if spread else np.zeros((0, 2)))
    y0 = np.vstack([state, draws])  # (1 + DRAWS, 2): the smoothed start first
    m = y0.shape[0]
    # θ̈'s error, in its sd, per member (none for the smoothed start)
    shift = np.r_[0.0, rng.standard_normal(DRAWS)] if shifted and spread else np.zeros(m)

    span, start = (t[last], t[rows[-1]]), y0.T.ravel()
    if reference.active():
        sol = solve_ivp(_numpy_rate(pendulum, x, ys, shift, engine, g), span, start,
                        t_eval=t[rows], method="DOP853", rtol=1e-9, atol=1e-12)
        y = np.full((2 * m, rows.size), np.nan)
        y[:, : sol.y.shape[1]] = sol.y
    else:
        params = [engine.L1, engine.L2, engine.L3, engine.L4, g]
        y, _ = integrate(KINDS.index(pendulum), x, ys, shift, np.array(params, dtype=float),
                         *span, start, t[rows], 1e-9, 1e-12)
    angle, angle_d = y[:m], y[m:]  # (members, k)
    acc = formula(theta[rows], theta_d[rows], theta_dd[rows] + shift[:, None] * sd[rows],
                  angle, engine, g)
    runs = np.stack([angle, angle_d, acc], axis=1)  # (members, 3, k)
    mean, ens = runs[0], runs[1:]
    if not spread:
        return PendulumRun(rows, mean[0], mean[1], mean[2], np.full((rows.size, 3, 3), np.nan),
                           last, gap)
    dev = ens - ens.mean(axis=0)
    out = np.einsum("dik,djk->kij", dev, dev) / (DRAWS - 1)
    return PendulumRun(rows, mean[0], mean[1], mean[2], out, last, gap)
