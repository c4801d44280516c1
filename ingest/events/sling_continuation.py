"""The sling angle where its track is lost: the engine's own pendulum, driven by the beam.

In phase II the projectile swings as a pendulum of length L4 hung from the spigot
(:func:`~trebuchet.model.dynamics.sling_pendulum_phi_dd`): given the beam's motion θ(t),
θ̇(t), θ̈(t), the sling angle follows from its state at one instant. Where the stone's
track ends while the beam's and the arm's go on (motion blur, the stone leaving the
picture), φ is carried on from its last smoothed state by integrating that equation with
the smoothed beam as the driver, as if the stone were still in the sling. Its sd comes
from an ensemble of starting states drawn from the smoother's covariance there; the beam's
own uncertainty and the scene's are not in it (both are small against the start's on the
logs measured: the spread grows as the pendulum's sensitivity to its start).

This gives the release check (:mod:`.release_model`) a phase-II prediction after the track
ends, and phase II its sling loads up to the release the equations find.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from trebuchet.model.dynamics import sling_pendulum_phi_dd
from trebuchet.model.scene import Scene

__all__ = ["SlingContinuation", "continued_sling"]

#: Starting states drawn for the sd (a fixed seed: the same log gives the same sd).
DRAWS = 24


@dataclass(frozen=True, eq=False)
class SlingContinuation:
    """φ (rad), φ̇ (rad/s), φ̈ (rad/s²) on the rows ``rows`` of the smoothed log after the
    track's last frame, each (k,), and their covariance ``cov`` (k, 3, 3) over the ensemble
    of starting states; ``start``: the row the integration starts from."""

    rows: np.ndarray
    phi: np.ndarray
    phi_d: np.ndarray
    phi_dd: np.ndarray
    cov: np.ndarray
    start: int


def _driver(t: np.ndarray, theta: np.ndarray, theta_d: np.ndarray, theta_dd: np.ndarray):
    """θ, θ̇, θ̈ at any time between the rows: θ̈ linear between rows, θ̇ and θ from the
    smoother's values at the rows by the same linear interpolation (the rows are at most
    one frame apart, where the smoother's own model is locally cubic)."""
    def at(s: float) -> tuple[float, float, float]:
        return (float(np.interp(s, t, theta)), float(np.interp(s, t, theta_d)),
                float(np.interp(s, t, theta_dd)))
    return at


def continued_sling(est: dict[str, np.ndarray], scene: Scene, last: int,
                    cov_phi: np.ndarray, seed: int = 20261125) -> SlingContinuation:
    """φ carried on from row ``last`` (the sling track's last valid row) to the end of
    ``est`` (a smoother's output: ``t`` s, ``theta`` rad, ``theta_d`` rad/s, ``theta_dd``
    rad/s², ``phi``, ``phi_d`` at row ``last``) by the sling's pendulum equation driven by
    the smoothed beam; ``cov_phi`` (3, 3): the smoother's covariance of (φ, φ̇, φ̈) at that
    row (SI). The mean is the integration from the smoothed state, the covariance that of
    ``DRAWS`` integrations from states drawn with it."""
    e, g = scene.engine, scene.g
    t = np.asarray(est["t"], dtype=float)
    theta, theta_d, theta_dd = (np.asarray(est[c], dtype=float)
                                for c in ("theta", "theta_d", "theta_dd"))
    rows = np.arange(last + 1, t.size)
    usable = np.isfinite(theta) & np.isfinite(theta_d) & np.isfinite(theta_dd)
    rows = rows[usable[rows]]
    if rows.size == 0:
        empty = np.zeros(0)
        return SlingContinuation(rows, empty, empty, empty, np.zeros((0, 3, 3)), last)
    at = _driver(t[usable], theta[usable], theta_d[usable], theta_dd[usable])

    start = np.array([float(est["phi"][last]), float(est["phi_d"][last])])
    c2 = np.nan_to_num(np.asarray(cov_phi, dtype=float)[:2, :2])
    rng = np.random.default_rng(seed)
    draws = rng.multivariate_normal(start, 0.5 * (c2 + c2.T), size=DRAWS, method="eigh")
    y0 = np.vstack([start, draws])  # (1 + DRAWS, 2): the smoothed start first
    m = y0.shape[0]

    def rate(s: float, y: np.ndarray) -> np.ndarray:
        """(φ, φ̇) of every member, stacked: φ̇ and the pendulum's φ̈."""
        th, th_d, th_dd = at(s)
        return np.concatenate([y[m:], sling_pendulum_phi_dd(th, th_d, th_dd, y[:m], e, g, np)])

    sol = solve_ivp(rate, (t[last], t[rows[-1]]), y0.T.ravel(), t_eval=t[rows],
                    method="DOP853", rtol=1e-9, atol=1e-12)
    y = np.full((2 * m, rows.size), np.nan)
    y[:, : sol.y.shape[1]] = sol.y
    phi, phi_d = y[:m], y[m:]  # (members, k)
    acc = sling_pendulum_phi_dd(theta[rows], theta_d[rows], theta_dd[rows], phi, e, g, np)
    runs = np.stack([phi, phi_d, acc], axis=1)  # (members, 3, k)
    mean, ens = runs[0], runs[1:]
    dev = ens - ens.mean(axis=0)
    cov = np.einsum("dik,djk->kij", dev, dev) / (DRAWS - 1)
    return SlingContinuation(rows, mean[0], mean[1], mean[2], cov, last)
