"""The counterweight's angle where its track is lost: the engine's own pendulum, driven by
the beam.

The hinged counterweight swings as a pendulum of length L3 hung from the hinge
(:func:`~trebuchet.model.dynamics.counterweight_pendulum_psi_dd`, the second row of the
paper's eq. (A.1)): given the beam's motion θ(t), θ̇(t), θ̈(t), ψ follows from its state at
one instant, in every phase and whatever the projectile does; the masses do not enter.
Where the counterweight's track ends while the beam's goes on (a frame member in front of
it for the rest of the shot, a template that slid off its marker and was flagged), ψ is
carried on from its last smoothed state by integrating that equation with the smoothed
beam as the driver. Its sd comes from an ensemble of starting states drawn from the
smoother's covariance there, each member driven by the smoothed θ̈ shifted by its own
multiple (drawn, standard normal) of θ̈'s sd: θ̈'s error enters ψ̈ scaled by L2/L3, near
1 on a small engine, and without it the stated sd held the drift only to 2-3 sd.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp

from trebuchet.ingest.smoothing.result import smoothing_of, with_smoothing
from trebuchet.model.dynamics import counterweight_pendulum_psi_dd
from trebuchet.model.scene import Scene

__all__ = ["CounterweightContinuation", "continued_counterweight",
           "with_continued_counterweight", "MIN_FRAMES_LOST"]

#: Starting states drawn for the sd (a fixed seed: the same log gives the same sd).
DRAWS = 24
#: The counterweight's track must end at least this many frames before the beam's.
MIN_FRAMES_LOST = 3


@dataclass(frozen=True, eq=False)
class CounterweightContinuation:
    """ψ (rad), ψ̇ (rad/s), ψ̈ (rad/s²) on the rows ``rows`` after the track's last row
    ``start``, each (k,), and their covariance ``cov`` (k, 3, 3) over the ensemble of
    starting states."""

    rows: np.ndarray
    psi: np.ndarray
    psi_d: np.ndarray
    psi_dd: np.ndarray
    cov: np.ndarray
    start: int


def continued_counterweight(est: dict[str, np.ndarray], scene: Scene, last: int,
                            cov_psi: np.ndarray, seed: int = 20261125
                            ) -> CounterweightContinuation:
    """ψ carried on from row ``last`` (the counterweight track's last valid row) over the
    rows after it where the smoothed beam is known (``est``: ``t`` s, ``theta`` rad,
    ``theta_d`` rad/s, ``theta_dd`` and its sd ``theta_dd_sd`` rad/s², ``psi`` and ``psi_d``
    at row ``last``) by the
    counterweight's pendulum equation; ``cov_psi`` (3, 3): the smoother's covariance of
    (ψ, ψ̇, ψ̈) at that row (SI). The mean is the integration from the smoothed state, the
    covariance that of ``DRAWS`` integrations from states drawn with it."""
    e, g = scene.engine, scene.g
    t = np.asarray(est["t"], dtype=float)
    theta, theta_d, theta_dd, theta_dd_sd = (np.asarray(est[c], dtype=float) for c in
                                             ("theta", "theta_d", "theta_dd", "theta_dd_sd"))
    usable = (np.isfinite(theta) & np.isfinite(theta_d) & np.isfinite(theta_dd)
              & np.isfinite(theta_dd_sd))
    rows = np.arange(last + 1, t.size)
    rows = rows[usable[rows]]
    if rows.size == 0:
        empty = np.zeros(0)
        return CounterweightContinuation(rows, empty, empty, empty, np.zeros((0, 3, 3)), last)
    tu, thu, thdu, thddu, sdu = (v[usable] for v in (t, theta, theta_d, theta_dd,
                                                    theta_dd_sd))
    start = np.array([float(est["psi"][last]), float(est["psi_d"][last])])
    c2 = np.nan_to_num(np.asarray(cov_psi, dtype=float)[:2, :2])
    rng = np.random.default_rng(seed)
    draws = rng.multivariate_normal(start, 0.5 * (c2 + c2.T), size=DRAWS, method="eigh")
    y0 = np.vstack([start, draws])  # (1 + DRAWS, 2): the smoothed start first
    m = y0.shape[0]
    shift = np.r_[0.0, rng.standard_normal(DRAWS)]  # θ̈'s error, in its sd, per member

    def rate(s: float, y: np.ndarray) -> np.ndarray:
        """(ψ, ψ̇) of every member, stacked: ψ̇ and the pendulum's ψ̈ (the beam's θ, θ̇, θ̈
        linear between the rows, at most a frame apart)."""
        th, th_d, th_dd, sd = (float(np.interp(s, tu, v)) for v in (thu, thdu, thddu, sdu))
        return np.concatenate([y[m:], counterweight_pendulum_psi_dd(
            th, th_d, th_dd + shift * sd, y[:m], e, g, np)])

    sol = solve_ivp(rate, (t[last], t[rows[-1]]), y0.T.ravel(), t_eval=t[rows],
                    method="DOP853", rtol=1e-9, atol=1e-12)
    y = np.full((2 * m, rows.size), np.nan)
    y[:, : sol.y.shape[1]] = sol.y
    psi, psi_d = y[:m], y[m:]
    acc = counterweight_pendulum_psi_dd(
        theta[rows], theta_d[rows], theta_dd[rows] + shift[:, None] * theta_dd_sd[rows], psi,
        e, g, np)
    runs = np.stack([psi, psi_d, acc], axis=1)  # (members, 3, k)
    mean, ens = runs[0], runs[1:]
    dev = ens - ens.mean(axis=0)
    cov = np.einsum("dik,djk->kij", dev, dev) / (DRAWS - 1)
    return CounterweightContinuation(rows, mean[0], mean[1], mean[2], cov, last)


def with_continued_counterweight(est: pd.DataFrame, scene: Scene, psi_log: np.ndarray
                                 ) -> pd.DataFrame:
    """``est`` (a smoother's output, one row per log row) with ψ, ψ̇, ψ̈, their sd and
    the smoothing's ``cov["psi"]`` filled after the last row where the log has ψ (``psi_log``,
    rad, NaN in gaps), when the smoothed beam goes on at least :data:`MIN_FRAMES_LOST`
    rows longer, by the counterweight's pendulum (module doc), and a note saying so;
    ``est`` itself otherwise (no ψ at all, a counterweight fixed to the beam)."""
    psi_log = np.asarray(psi_log, dtype=float)
    have = np.flatnonzero(np.isfinite(psi_log))
    theta = est["theta"].to_numpy(dtype=float)
    beam = np.flatnonzero(np.isfinite(theta))
    if (scene.engine.fixed_counterweight or have.size == 0 or beam.size == 0
            or len(psi_log) != len(est) or beam[-1] - have[-1] < MIN_FRAMES_LOST):
        return est
    last = int(have[-1])
    fit = smoothing_of(est)
    cov = dict(fit.cov)
    cont = continued_counterweight(
        {c: est[c].to_numpy(dtype=float) for c in ("t", "theta", "theta_d", "theta_dd",
                                                   "theta_dd_sd", "psi", "psi_d")},
        scene, last, np.asarray(cov["psi"][last])[:3, :3])
    rows = cont.rows[np.isfinite(cont.psi)]
    if rows.size == 0:
        return est
    keep = np.isin(cont.rows, rows)
    out = est.copy()
    psi_cov = np.array(cov["psi"], dtype=float, copy=True)
    psi_cov[rows] = 0.0
    psi_cov[rows, :3, :3] = cont.cov[keep]
    cov["psi"] = psi_cov
    for j, (suffix, values) in enumerate((("", cont.psi), ("_d", cont.psi_d),
                                          ("_dd", cont.psi_dd))):
        out.loc[out.index[rows], "psi" + suffix] = values[keep]
        out.loc[out.index[rows], "psi" + suffix + "_sd"] = np.sqrt(cont.cov[keep, j, j])
    t = est["t"].to_numpy(dtype=float)
    note = (f"the counterweight's track ends at {t[last]:.4f} s while the beam's goes on to "
            f"{t[rows[-1]]:.4f} s: psi is carried on by the counterweight's pendulum driven "
            "by the smoothed beam (sd at the end "
            f"{np.degrees(np.sqrt(cont.cov[keep][-1, 0, 0])):.2g} deg)")
    return with_smoothing(out, fit.replace(cov=cov).noted(note))
