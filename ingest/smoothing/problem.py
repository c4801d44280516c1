"""The fixed parts of one smoothing: the tracked angles in the smoother's units, the event
step model (rest, kicks at trigger and release), the pieces of the shot and the priors;
and the state a tuning hands to the next stage.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trebuchet.ingest.kalman.batch import (
    FilterResult,
    SmootherResult,
    StepModel,
    polynomial_transition,
    white_noise_covariance,
)
from trebuchet.ingest.smoothing.noise_tuning import (
    NoiseEstimate,
)
from trebuchet.ingest.smoothing.settings import (
    SmoothSettings,
)

__all__ = ["SmoothingProblem", "TuningState", "event_step_model", "piece_bounds", "priors"]


@dataclass(frozen=True, eq=False)
class SmoothingProblem:
    """What every stage of one smoothing shares: the tracked angles ``Z`` (A, n; rad) on the
    frames ``ts`` (time in frames of ``tau`` s from the first row), where they are measured
    (``valid``) and count in the likelihood (``weight``), the priors ``x0``, ``P0`` at the
    first frame, the event kicks' variance ``kick`` (smoother units), the given process
    noise (``q_given``, smoother units; NaN: to fit) and measurement variance
    (``r2_given``, rad²; NaN: to fit), the reference variance ``r2_ref`` (rad²) and the
    single-λ search grid."""

    t: np.ndarray
    ts: np.ndarray
    tau: float
    k: int
    tracked: list[str]
    Z: np.ndarray
    valid: np.ndarray
    weight: np.ndarray
    x0: np.ndarray
    P0: np.ndarray
    kick: np.ndarray
    q_given: np.ndarray
    r2_given: np.ndarray
    r2_ref: np.ndarray
    grid: np.ndarray
    jerk_time: float
    trig_s: float | None
    settings: SmoothSettings

    @property
    def A(self) -> int:
        return self.Z.shape[0]

    @property
    def n(self) -> int:
        return self.Z.shape[1]

    @property
    def free(self) -> list[int]:
        """The angles whose process noise is fitted (``q`` not given)."""
        return [a for a in range(self.A) if not np.isfinite(self.q_given[a])]

    @property
    def shaped(self) -> bool:
        """Whether the process noise's shape is local (fitted frame by frame)."""
        s = self.settings
        return s.local_noise and s.shot_pieces < 1 and bool(self.free)

    def release_index(self, rel_s: float | None) -> int | None:
        """The first frame after a release at ``rel_s`` (frames), None without one."""
        return None if rel_s is None else int(np.searchsorted(self.ts, rel_s, side="right"))


@dataclass(frozen=True, eq=False)
class TuningState:
    """A tuning's state: the step model of the events (release at ``rel_s`` frames, first
    frame of the shot ``start``), the noise estimates, λ per angle and frame (to use, and
    the maximum-likelihood one), the pieces' bounds, and the last filter and smoother."""

    steps: StepModel
    start: int
    rel_s: float | None
    est: list[NoiseEstimate]
    lam_use: np.ndarray
    lam_ml: np.ndarray
    bounds: np.ndarray
    filt: FilterResult | None = None
    sm: SmootherResult | None = None


def event_step_model(
    ts: np.ndarray,
    k: int,
    trigger: float | None,
    release: float | None,
    jerk_kick_time: float,
) -> tuple[StepModel, int]:
    """Per-frame transition, process noise and event kicks (smoother time unit).

    Rest (no process noise) up to ``trigger``; at ``trigger`` and ``release`` (between
    frames) a unit kick in acceleration (and jerk, sd ``1/jerk_kick_time`` per unit, for
    ``k = 4``) carried to the next frame by ``F(δ)``, and the white noise split at the
    event, ``F(δ) W(δ_before) F(δ)ᵀ + W(δ)``. Returns the model and the first frame index
    after the trigger (0 without a trigger).
    """
    n = ts.size
    dt = np.diff(ts, prepend=ts[0])
    F = polynomial_transition(k, dt)
    F[0] = np.eye(k)
    Q0 = white_noise_covariance(k, dt)
    Q0[0] = 0.0
    G = np.zeros_like(F)
    kick = np.zeros((k, k))
    kick[2, 2] = 1.0
    if k == 4:
        kick[3, 3] = 1.0 / jerk_kick_time**2
    start = 0
    if trigger is not None:
        i = int(np.searchsorted(ts, trigger, side="right"))
        start = i
        Q0[:i] = 0.0
        if 0 < i < n:
            delta = ts[i] - trigger
            Fd = polynomial_transition(k, np.array([delta]))[0]
            Q0[i] = white_noise_covariance(k, np.array([delta]))[0]
            G[i] += Fd @ kick @ Fd.T
    if release is not None:
        j = int(np.searchsorted(ts, release, side="right"))
        if 0 < j < n:
            delta = ts[j] - release
            before = release - ts[j - 1]
            Fd = polynomial_transition(k, np.array([delta]))[0]
            W = white_noise_covariance(k, np.array([delta, before]))
            Q0[j] = W[0] + (Fd @ W[1] @ Fd.T if j > start else 0.0)
            G[j] += Fd @ kick @ Fd.T
    return StepModel(F, Q0, G), start


def piece_bounds(n: int, start: int, release_index: int | None, pieces: int,
                 min_frames: int) -> np.ndarray:
    """Frame bounds ``0 = b0 < … < bP = n`` of the stretches with their own process noise:
    the rest and the first part of the shot, up to ``pieces`` equal parts of the shot
    (``start`` to ``release_index``, each at least ``min_frames`` frames), the flight after
    the release (if at least ``min_frames`` frames, else joined to the shot)."""
    end = n if release_index is None else int(release_index)
    shot = end - start
    count = int(np.clip(shot // max(min_frames, 1), 1, max(pieces, 1)))
    inner = start + np.round(shot * np.arange(1, count) / count).astype(int)
    bounds = [0, *inner.tolist()]
    if end < n and n - end >= min_frames and end > bounds[-1]:
        bounds.append(end)
    bounds.append(n)
    return np.unique(np.asarray(bounds, dtype=int))


def priors(
    Z: np.ndarray, sd: np.ndarray, k: int, rest: bool, acc_sd: np.ndarray, rate_sd: np.ndarray,
    jerk_sd: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Prior state and covariance at frame 0, and likelihood weights (first innovations out)."""
    A, n = Z.shape
    x0 = np.zeros((A, k))
    P0 = np.zeros((A, k, k))
    weight = np.isfinite(Z).astype(float)
    for a in range(A):
        ok = np.flatnonzero(np.isfinite(Z[a]))
        x0[a, 0] = Z[a, ok[0]]
        P0[a, 0, 0] = 100.0 * sd[a] ** 2
        n_diffuse = 1
        if not rest:
            P0[a, 1, 1] = rate_sd[a] ** 2
            P0[a, 2, 2] = acc_sd[a] ** 2
            if k == 4:
                P0[a, 3, 3] = jerk_sd[a] ** 2
            n_diffuse = k
        weight[a, ok[:n_diffuse]] = 0.0
    return x0, P0, weight
