"""The counterweight's angle where its track is lost: the engine's own pendulum, driven by
the beam.

The hinged counterweight swings as a pendulum of length L3 hung from the hinge
(:func:`~trebuchet.model.dynamics.counterweight_pendulum_psi_dd`, the second row of the
paper's eq. (A.1)): given the beam's motion θ(t), θ̇(t), θ̈(t), ψ follows from its state at
one instant, in every phase and whatever the projectile does; the masses do not enter.
Where the counterweight's track ends while the beam's goes on (a frame member in front of
it for the rest of the shot, a template that slid off its marker and was flagged), ψ is
carried on from its state at the track's end (below) by integrating that equation with the
smoothed beam as the driver. Its sd comes from an ensemble of starting states drawn from
that state's covariance, each member driven by the smoothed θ̈ shifted by its own
multiple (drawn, standard normal) of θ̈'s sd: θ̈'s error enters ψ̈ scaled by L2/L3, near
1 on a small engine, and without it the stated sd held the drift only to 2-3 sd.

The starting state (:func:`fitted_start`) is the pendulum fitted to the track's own points
over its last :data:`START_WINDOW` × √(L3/g) (the pendulum's own time) and after its last
gap (points before a gap are the marker before the tracker lost it: a template dragged
towards what then hid it), not the smoother's state at the last row: at the end of a track
the smoother's rate rests on the last two or three points alone, and a marker being hidden
as the track ends drags its template towards what hides it (issue 26's backyard engine at
15° tilt: the last points 0.5–0.9 px off, the smoothed ψ̇ 68 °/s off, ψ 10° off 40 frames
later). The pendulum ties the window's points together by the engine's own equation, so two
points cannot set the rate. The fit's covariance is White's sandwich with each point's
variance its leverage-corrected squared residual (HC3, MacKinnon & White 1985), never under
the points' noise (the smoother's ``r_sd``): a dragged point at the window's end, where the
start is read, widens it most; it is scaled by (1 + ρ)/(1 − ρ) for the residuals' lag-1
correlation ρ (points that err together are worth fewer), and the smoother's covariance at
the last row is added to it: an error shared by the whole window is what the fit cannot
see, and the smoother's end state's spread is what the continuation carried before.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd

from trebuchet.ingest.events.driven_pendulum import MAX_GAP_FRAMES, driven_pendulum
from trebuchet.ingest.smoothing.result import smoothing_of, with_angle_rows, with_smoothing
from trebuchet.model.scene import Scene

__all__ = ["CounterweightContinuation", "PendulumStart", "continued_counterweight",
           "fitted_start", "with_continued_counterweight", "MIN_FRAMES_LOST",
           "START_WINDOW", "MIN_START_POINTS"]

#: The counterweight's track must end at least this many frames before the beam's.
MIN_FRAMES_LOST = 3

#: The starting state is fitted over the track's points in the last this much of the
#: counterweight pendulum's own time √(L3/g) (0.05 s on the backyard engine, 0.10 s on
#: the paper's): short against the swing, so that θ̈'s error barely moves the window's ψ.
START_WINDOW = 0.2

#: With fewer points than this in the window the start is the smoother's last state.
MIN_START_POINTS = 5

#: Finite-difference steps of the fit's Jacobian (rad, rad/s), and its Gauss-Newton passes.
_STEPS = (1e-5, 1e-4)
_PASSES = 4


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


@dataclass(frozen=True, eq=False)
class PendulumStart:
    """The counterweight's state ``state`` (ψ rad, ψ̇ rad/s) at the track's last row
    ``last``, fitted over the track's rows ``rows`` (:func:`fitted_start`), its covariance
    ``cov`` (2, 2) and ``scale``, the points' mean variance in the fit over their noise's
    (module doc: HC3 and (1 + ρ)/(1 − ρ), at least 1)."""

    state: np.ndarray
    cov: np.ndarray
    rows: np.ndarray
    last: int
    scale: float


def _window_model(est: dict[str, np.ndarray], scene: Scene, rows: np.ndarray, last: int
                  ) -> Callable[[np.ndarray], np.ndarray]:
    """ψ on ``rows`` then (ψ, ψ̇) at ``last`` of the counterweight's pendulum started at
    ``rows[0]`` in the state ``p`` (ψ rad, ψ̇ rad/s), driven by the smoothed beam."""
    t = est["t"]
    first = int(rows[0])

    def model(p: np.ndarray) -> np.ndarray:
        run = driven_pendulum(t, est["theta"], est["theta_d"], est["theta_dd"], first, p,
                              np.zeros((3, 3)), "counterweight", scene.engine, scene.g,
                              until=float(t[last]), spread=False)
        angle = np.full(t.size, np.nan)
        rate = np.full(t.size, np.nan)
        angle[first], rate[first] = p
        angle[run.rows], rate[run.rows] = run.angle, run.rate
        return np.r_[angle[rows], angle[last], rate[last]]
    return model


def fitted_start(est: dict[str, np.ndarray], psi_log: np.ndarray, scene: Scene, last: int,
                 r_sd: float, cov_last: np.ndarray) -> PendulumStart | None:
    """The counterweight's (ψ, ψ̇) at ``last`` (the track's last row) from its pendulum
    fitted by least squares to the log's ψ (``psi_log``, rad) over the track's rows within
    :data:`START_WINDOW` × √(L3/g) s before it and after its last gap (module doc), driven
    by the smoothed beam (``est``: ``t`` s, ``theta`` rad, ``theta_d`` rad/s, ``theta_dd``
    rad/s², ``psi``, ``psi_d`` the smoothed ψ for the first guess); ``r_sd`` (rad): the
    points' noise; ``cov_last`` (2, 2): the smoother's covariance of (ψ, ψ̇) at ``last``,
    added to the fit's. None with fewer than :data:`MIN_START_POINTS` points or where the
    pendulum does not reach ``last``."""
    t = est["t"]
    span = START_WINDOW * np.sqrt(scene.engine.L3 / scene.g)
    rows = np.flatnonzero(np.isfinite(psi_log) & (t >= t[last] - span) & (t <= t[last]))
    gaps = np.flatnonzero(np.diff(rows) > 1)
    rows = rows[gaps[-1] + 1:] if gaps.size else rows  # after the track's last gap
    if rows.size < MIN_START_POINTS or not (r_sd > 0):
        return None
    model = _window_model(est, scene, rows, last)
    p = np.array([est["psi"][rows[0]], est["psi_d"][rows[0]]], dtype=float)
    steps = np.diag(_STEPS)
    for _ in range(_PASSES):
        f0 = model(p)
        jac = np.column_stack([(model(p + d) - f0) / d[i] for i, d in enumerate(steps)])
        if not (np.isfinite(f0).all() and np.isfinite(jac).all()):
            return None
        step = np.linalg.lstsq(jac[:-2], psi_log[rows] - f0[:-2], rcond=None)[0]
        p = p + step
        if np.all(np.abs(step) < 1e-3 * np.array(_STEPS)):
            break
    f0 = model(p)
    res = psi_log[rows] - f0[:-2]
    a = jac[:-2]
    inv = np.linalg.inv(a.T @ a)
    lever = np.clip(np.einsum("ij,jk,ik->i", a, inv, a), 0.0, 0.99)
    e2 = np.maximum(res**2 / (1.0 - lever) ** 2, r_sd**2)  # HC3, never under the noise
    ss = float(res @ res)
    rho = float(np.clip(res[1:] @ res[:-1] / ss, 0.0, 0.95)) if ss > 0 else 0.0
    corr = (1 + rho) / (1 - rho)
    fit_cov = inv @ (a.T * e2) @ a @ inv * corr
    scale = float(np.mean(e2)) / r_sd**2 * corr
    phi = jac[-2:]  # d(ψ, ψ̇ at last) / d(start)
    cov = phi @ fit_cov @ phi.T + np.nan_to_num(np.asarray(cov_last, dtype=float))
    return PendulumStart(f0[-2:], 0.5 * (cov + cov.T), rows, last, scale)


def continued_counterweight(est: dict[str, np.ndarray], scene: Scene, last: int,
                            cov_psi: np.ndarray, seed: int = 20261125
                            ) -> CounterweightContinuation:
    """ψ carried on from row ``last`` (the counterweight track's last valid row) over the
    rows after it where the smoothed beam is known (``est``: ``t`` s, ``theta`` rad,
    ``theta_d`` rad/s, ``theta_dd`` and its sd ``theta_dd_sd`` rad/s², ``psi`` and ``psi_d``
    at row ``last``) by the counterweight's pendulum equation, each member of the ensemble
    driven by θ̈ shifted by a drawn multiple of its sd
    (:func:`~trebuchet.ingest.events.driven_pendulum.driven_pendulum`); ``cov_psi``
    (3, 3): the covariance of (ψ, ψ̇, ψ̈) at that row (SI; the smoother's, or the fitted
    start's, :func:`fitted_start`, in its first two rows and columns)."""
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
    cols = {c: est[c].to_numpy(dtype=float) for c in ("t", "theta", "theta_d", "theta_dd",
                                                      "theta_dd_sd", "psi", "psi_d")}
    fit = smoothing_of(est)
    cov_last = np.array(np.asarray(fit.cov["psi"][last])[:3, :3], dtype=float)
    r_sd = float(fit.noise.get("psi", {}).get("r_sd", np.nan))
    start = fitted_start(cols, psi_log, scene, last, r_sd, cov_last[:2, :2])
    if start is not None:  # the window's pendulum for the smoother's end state
        cols["psi"], cols["psi_d"] = cols["psi"].copy(), cols["psi_d"].copy()
        cols["psi"][last], cols["psi_d"][last] = start.state
        cov_last[:2, :2] = start.cov
    cont = continued_counterweight(cols, scene, last, cov_last)
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
    if start is not None:
        note += (f", started from the pendulum fitted to the track's last {start.rows.size} "
                 f"points (their noise x{np.sqrt(start.scale):.2g} from the residuals)")
    if cont.gap is not None:
        note += (f", not across the gap in the log's rows after {cont.gap:.4f} s (longer than "
                 f"{MAX_GAP_FRAMES:g} frames): psi is NaN from there on")
    return with_smoothing(out, smoothing_of(out).noted(note))
