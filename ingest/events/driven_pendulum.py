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
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

__all__ = ["DRAWS", "PendulumRun", "driven_pendulum"]

#: Starting states drawn for the sd (a fixed seed: the same log gives the same sd).
DRAWS = 24


@dataclass(frozen=True, eq=False)
class PendulumRun:
    """The angle (rad), its rate (rad/s) and acceleration (rad/s²) on the rows ``rows``
    after the track's last row ``start``, each (k,), and their covariance ``cov``
    (k, 3, 3) over the ensemble."""

    rows: np.ndarray
    angle: np.ndarray
    rate: np.ndarray
    acc: np.ndarray
    cov: np.ndarray
    start: int


def driven_pendulum(t: np.ndarray, theta: np.ndarray, theta_d: np.ndarray,
                    theta_dd: np.ndarray, last: int, state: np.ndarray, cov: np.ndarray,
                    angle_dd: Callable[..., np.ndarray], *,
                    theta_dd_sd: np.ndarray | None = None, seed: int = 20261125
                    ) -> PendulumRun:
    """The angle from row ``last`` on over the later rows where the beam (``t`` s,
    ``theta`` rad, ``theta_d`` rad/s, ``theta_dd`` rad/s², and ``theta_dd_sd`` if given)
    is known, by ``angle_dd(θ, θ̇, θ̈, angle)`` (rad/s², numpy-broadcasting), from
    ``state`` (angle, rate) at ``last`` with ``cov`` (3, 3) its smoothed covariance of
    (angle, rate, acceleration) there. With ``theta_dd_sd`` each member's θ̈ is shifted by
    a drawn multiple of it."""
    usable = np.isfinite(theta) & np.isfinite(theta_d) & np.isfinite(theta_dd)
    shifted = theta_dd_sd is not None
    sd = np.zeros(t.size) if theta_dd_sd is None else np.asarray(theta_dd_sd, dtype=float)
    if shifted:
        usable &= np.isfinite(sd)
    rows = np.arange(last + 1, t.size)
    rows = rows[usable[rows]]
    if rows.size == 0:
        empty = np.zeros(0)
        return PendulumRun(rows, empty, empty, empty, np.zeros((0, 3, 3)), last)
    tu, thu, thdu, thddu, sdu = (v[usable] for v in (t, theta, theta_d, theta_dd, sd))
    c2 = np.nan_to_num(np.asarray(cov, dtype=float)[:2, :2])
    rng = np.random.default_rng(seed)
    draws = rng.multivariate_normal(state, 0.5 * (c2 + c2.T), size=DRAWS, method="eigh")
    y0 = np.vstack([state, draws])  # (1 + DRAWS, 2): the smoothed start first
    m = y0.shape[0]
    # θ̈'s error, in its sd, per member (none for the smoothed start)
    shift = np.r_[0.0, rng.standard_normal(DRAWS)] if shifted else np.zeros(m)

    def rate(s: float, y: np.ndarray) -> np.ndarray:
        """(angle, rate) of every member, stacked: the rate and the pendulum's acceleration."""
        th, th_d, th_dd, th_dd_sd = (float(np.interp(s, tu, v))
                                     for v in (thu, thdu, thddu, sdu))
        return np.concatenate([y[m:], angle_dd(th, th_d, th_dd + shift * th_dd_sd, y[:m])])

    sol = solve_ivp(rate, (t[last], t[rows[-1]]), y0.T.ravel(), t_eval=t[rows],
                    method="DOP853", rtol=1e-9, atol=1e-12)
    y = np.full((2 * m, rows.size), np.nan)
    y[:, : sol.y.shape[1]] = sol.y
    angle, angle_d = y[:m], y[m:]  # (members, k)
    acc = angle_dd(theta[rows], theta_d[rows], theta_dd[rows] + shift[:, None] * sd[rows],
                   angle)
    runs = np.stack([angle, angle_d, acc], axis=1)  # (members, 3, k)
    mean, ens = runs[0], runs[1:]
    dev = ens - ens.mean(axis=0)
    out = np.einsum("dik,djk->kij", dev, dev) / (DRAWS - 1)
    return PendulumRun(rows, mean[0], mean[1], mean[2], out, last)
