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
ends, and phase II its sling loads up to the release the equations find. It goes as far as
that: to a release already found, or, for the check, to :func:`release_horizon` (the beam's
first turn after the track's end, and at least twice the time from the trigger to it),
not to the end of the log (each second of a continuation costs about as much as smoothing
ten: a 60 s log at 1000 fps spent 25 pendulums' 58 s of swinging to check a release it
then placed where the track ended).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trebuchet.ingest.events.driven_pendulum import driven_pendulum
from trebuchet.model.scene import Scene

__all__ = ["SlingContinuation", "continued_sling", "release_horizon", "HORIZON_FRAMES"]

#: The shortest continuation the release check gets (frames after the track's end).
HORIZON_FRAMES = 20


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
    gap: float | None = None


def release_horizon(t: np.ndarray, theta_d: np.ndarray, last: int,
                    trigger: float | None) -> float:
    """How far (log time, s) the release check needs φ carried on past the sling track's
    last row ``last``: to the release, which comes before the beam's first turn after it
    (θ̇, rad/s, changing sign: a sling that still held its stone then throws it nowhere)
    or, on an engine whose beam turns earlier, within twice the time from the trigger
    (s; None: the log's first row) to the track's end; at least :data:`HORIZON_FRAMES`
    frames. Where the beam has not turned by then, twice that time."""
    start = t[0] if trigger is None else trigger
    frame = float(np.median(np.diff(t)))
    span = max(2.0 * (t[last] - start), HORIZON_FRAMES * frame)
    rate = theta_d[last:]
    ok = np.isfinite(rate) & (rate != 0.0)
    if not ok.any():
        return float(t[last] + span)
    sign = np.sign(rate[ok][0])
    turned = np.flatnonzero(ok & (np.sign(rate) != sign))
    turn = t[last + turned[0]] if turned.size else -np.inf
    return float(max(turn, t[last] + span))


def continued_sling(est: dict[str, np.ndarray], scene: Scene, last: int,
                    cov_phi: np.ndarray, seed: int = 20261125, until: float | None = None,
                    spread: bool = True) -> SlingContinuation:
    """φ carried on from row ``last`` (the sling track's last valid row) up to the time
    ``until`` (s; None: the end of ``est``) over the rows of ``est`` (a smoother's output:
    ``t`` s, ``theta`` rad, ``theta_d`` rad/s, ``theta_dd`` rad/s², ``phi``, ``phi_d`` at
    row ``last``) by the sling's pendulum equation driven by the smoothed beam
    (:func:`.driven_pendulum.driven_pendulum`: not across a gap of the beam's rows, ``gap``
    then the time it stopped at); ``cov_phi`` (3, 3): the smoother's covariance of (φ, φ̇,
    φ̈) at that row (SI). ``spread=False``: φ alone, its covariance NaN (the release check
    uses φ and φ̇ only)."""
    t, theta, theta_d, theta_dd = (np.asarray(est[c], dtype=float)
                                   for c in ("t", "theta", "theta_d", "theta_dd"))
    run = driven_pendulum(
        t, theta, theta_d, theta_dd, last,
        np.array([float(est["phi"][last]), float(est["phi_d"][last])]), cov_phi,
        "sling", scene.engine, scene.g, seed=seed, until=until, spread=spread)
    return SlingContinuation(run.rows, run.angle, run.rate, run.acc, run.cov, run.start,
                             run.gap)
