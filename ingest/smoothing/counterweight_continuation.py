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

from trebuchet.ingest.events.driven_pendulum import MAX_GAP_FRAMES, driven_pendulum
from trebuchet.ingest.smoothing.result import smoothing_of, with_angle_rows, with_smoothing
from trebuchet.model.scene import Scene

__all__ = ["CounterweightContinuation", "continued_counterweight",
           "with_continued_counterweight", "MIN_FRAMES_LOST"]

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
    gap: float | None = None


def continued_counterweight(est: dict[str, np.ndarray], scene: Scene, last: int,
                            cov_psi: np.ndarray, seed: int = 20261125
                            ) -> CounterweightContinuation:
    """ψ carried on from row ``last`` (the counterweight track's last valid row) over the
    rows after it where the smoothed beam is known (``est``: ``t`` s, ``theta`` rad,
    ``theta_d`` rad/s, ``theta_dd`` and its sd ``theta_dd_sd`` rad/s², ``psi`` and ``psi_d``
    at row ``last``) by the counterweight's pendulum equation, each member of the ensemble
    driven by θ̈ shifted by a drawn multiple of its sd
    (:func:`~trebuchet.ingest.events.driven_pendulum.driven_pendulum`); ``cov_psi``
    (3, 3): the smoother's covariance of (ψ, ψ̇, ψ̈) at that row (SI)."""
    t, theta, theta_d, theta_dd, theta_dd_sd = (
        np.asarray(est[c], dtype=float)
        for c in ("t", "theta", "theta_d", "theta_dd", "theta_dd_sd"))
    run = driven_pendulum(
        t, theta, theta_d, theta_dd, last,
        np.array([float(est["psi"][last]), float(est["psi_d"][last])]), cov_psi,
        "counterweight", scene.engine, scene.g, theta_dd_sd=theta_dd_sd, seed=seed)
    return CounterweightContinuation(run.rows, run.angle, run.rate, run.acc, run.cov,
                                     run.start, run.gap)


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
    cont = continued_counterweight(
        {c: est[c].to_numpy(dtype=float) for c in ("t", "theta", "theta_d", "theta_dd",
                                                   "theta_dd_sd", "psi", "psi_d")},
        scene, last, np.asarray(smoothing_of(est).cov["psi"][last])[:3, :3])
    rows = cont.rows[np.isfinite(cont.psi)]
    if rows.size == 0:
        return est
    keep = np.isin(cont.rows, rows)
    out = with_angle_rows(est, "psi", rows, (cont.psi[keep], cont.psi_d[keep],
                                             cont.psi_dd[keep]), cont.cov[keep])
    t = est["t"].to_numpy(dtype=float)
    note = (f"the counterweight's track ends at {t[last]:.4f} s while the beam's goes on to "
            f"{t[rows[-1]]:.4f} s: psi is carried on by the counterweight's pendulum driven "
            "by the smoothed beam (sd at the end "
            f"{np.degrees(np.sqrt(cont.cov[keep][-1, 0, 0])):.2g} deg)")
    if cont.gap is not None:
        note += (f", not across the gap in the log's rows after {cont.gap:.4f} s (longer than "
                 f"{MAX_GAP_FRAMES:g} frames): psi is NaN from there on")
    return with_smoothing(out, smoothing_of(out).noted(note))
