"""Angles, their rates and accelerations, with standard deviations, from a noisy log.

``smooth(log)`` runs, per angle, a Kalman filter and Rauch–Tung–Striebel smoother
(Rauch, Tung & Striebel 1965) of a constant-acceleration model (white jerk; ``model="cj"``:
constant jerk, white snap) with the exact discretised process noise for each frame's own
time step (filterpy's ``Q_continuous_white_noise``), and:

- the angles rest before the trigger (no process noise, zero rate and acceleration) and
  the acceleration may jump at the trigger and at the release (a wide "kick" in the
  acceleration at the event's time, between frames);
- the process noise ``q`` is the maximum of the innovation likelihood with the
  measurement noise ``r`` profiled out (:mod:`~trebuchet.ingest.smoothing.noise_tuning`), either
  may be given instead; by default ``q`` then varies frame by frame with the squared jerk
  of that first smoothing (slow trough, fast swing), its scale again by maximum
  likelihood (``SmoothSettings.local_noise``);
- the standard deviations include the smoothing's bias, estimated by smoothing the
  smoothed angle once more and that residual once more (``SmoothSettings.bias_band``,
  ``bias_iterations``), and the posterior's process-noise share only as far as the data
  show that much process noise (``SmoothSettings.band_variance``);
- trigger and release are found in the data (:mod:`~trebuchet.ingest.events.detection`) unless
  given;
- gaps (NaN) are predicted through; outside an angle's track (before its first or after
  its last valid frame) the outputs are NaN, not extrapolated (``attrs["notes"]`` says so).

The numerics are the batched numpy filter of :mod:`~trebuchet.ingest.kalman.batch`
(about 30× faster than filterpy, equal to round-off; ``backend="filterpy"`` runs the final
pass through filterpy's ``KalmanFilter.batch_filter`` and ``rts_smoother`` instead).
Measured accuracy and speed: ``bench/smooth_accuracy.py``; docs/background.md,
"Differentiating video angles (filterpy 2.0.0)".
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
from scipy.ndimage import gaussian_filter1d

from trebuchet.errors import TrebuchetDataWarning, TrebuchetInputError
from trebuchet.ingest.events.detection import (
    detect_release,
    release_statistic,
    robust_noise_sd,
    trigger_estimate,
)
from trebuchet.ingest.kalman.batch import (
    FilterResult,
    SmootherResult,
    StepModel,
    backward_smoother,
    backward_sums,
    batch_kalman_filter,
    error_covariance,
    polynomial_transition,
    refiltered,
    simulated_model_runs,
    smoothed_states,
    white_noise_covariance,
)
from trebuchet.ingest.smoothing.inputs import (
    checked_events,
    log_name,
    per_angle,
    unwrapped_angles,
    validated_log,
)
from trebuchet.ingest.smoothing.model_choice import COMBINATIONS, combined_smoothing, jump_profile
from trebuchet.ingest.smoothing.noise_tuning import (
    NoiseEstimate,
    jerk_noise_shape,
    lambda_grid,
    maximum_likelihood_noise,
    piecewise_noise,
    track_end_common_noise,
)
from trebuchet.ingest.smoothing.settings import (
    ANGLES,
    BAND_ALPHA_FROM,
    BAND_VARIANCES,
    MODEL_STATES,
    SUFFIXES,
    SmoothSettings,
)

__all__ = ["smooth", "SmoothSettings", "ANGLES", "SUFFIXES", "MODEL_STATES", "BAND_VARIANCES",
           "BAND_ALPHA_FROM", "validated_log", "checked_events", "event_step_model",
           "piece_bounds", "shrunk_alpha"]

# ----------------------------------------------------------------------------- model


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


def _priors(
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


# ----------------------------------------------------------------------------- main


def _residual_moments(steps: StepModel, filt: FilterResult, Z: np.ndarray, valid: np.ndarray,
                      fitted: np.ndarray, lam: np.ndarray, r2: np.ndarray, kick: np.ndarray,
                      prior: np.ndarray, draws: int
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``SmoothSettings.band_alpha_from = "shrunk"``: per frame and angle (n, A) the
    statistic ``ρᵀ λQ ρ`` of the backward sums ``ρ`` of the smoothing residual
    ``z − x̂`` (the same gains run on it), its expectations under the measurement noise
    and the event kicks alone and under the model's white process noise alone, by
    ``draws`` simulated runs of the model each (fixed seed), and (n, draws, A) its
    values on the sums of one run of each, data with ``α = 1``."""
    n, A = Z.shape[1], Z.shape[0]
    rng = np.random.default_rng(20261124)
    half = A * draws
    many = np.tile(np.arange(A), 2 * draws)
    drawn = np.arange(2 * half)
    noise = np.where((drawn >= half)[:, None], (lam * r2[:, None])[many], 0.0)
    kicks = np.where(drawn < half, kick[many], 0.0)
    meas = np.where(drawn < half, r2[many], 0.0)
    z = simulated_model_runs(steps, noise, kicks, meas, prior[many] * (meas > 0)[:, None, None],
                             rng)
    ok = valid[many]
    z = np.where(ok, z, 0.0)
    fits = filt.series(many)
    zero = np.zeros((2 * half, steps.k))
    fit = smoothed_states(steps, refiltered(steps, fits, z, ok, zero), ok)[:, :, 0].T
    # the data's residual and the draws' in one batch
    everyone = np.concatenate([np.arange(A), many])
    res = np.concatenate([np.where(valid, Z - fitted, 0.0), z - fit])
    ok = valid[everyone]
    rho = backward_sums(steps, refiltered(steps, filt.series(everyone), res, ok,
                                          np.zeros((A + 2 * half, steps.k))), ok)
    stat = np.einsum("nai,nij,naj->na", rho, steps.Q0, rho, optimize=True) * lam[everyone].T
    null = stat[:, A:A + half].reshape(n, draws, A).mean(axis=1)
    slope = stat[:, A + half:].reshape(n, draws, A).mean(axis=1)
    both = rho[:, A:A + half] + rho[:, A + half:]  # ρ is linear in the data
    alt = np.einsum("nai,nij,naj->na", both, steps.Q0, both, optimize=True) * lam[many[:half]].T
    return stat[:, :A], null, slope, alt.reshape(n, draws, A)


def _earlier_estimate(noise: Mapping[str, float], tau: float, k: int) -> NoiseEstimate:
    """A :class:`NoiseEstimate` (smoother units, frames of ``tau`` s, ``k`` states) from
    one angle's entry of an earlier smoothing's ``attrs["noise"]`` (SI: ``q``, ``q_ml``
    rad²/s^(2k−1), ``r_sd`` rad)."""
    r2 = float(noise["r_sd"]) ** 2
    unit = tau ** (2 * k - 1) / r2
    return NoiseEstimate(float(noise["q_ml"]) * unit, float(noise["q"]) * unit, r2,
                         float(noise.get("loglik", np.nan)), bool(noise.get("at_grid_edge")))


def shrunk_alpha(prior: np.ndarray, estimate: np.ndarray, variance: np.ndarray,
                 frames: np.ndarray) -> np.ndarray:
    """Empirical-Bayes shrinkage of the frames' ``estimate`` (any shape) toward ``prior``:
    with ``estimate ~ N(α, variance)`` and ``α ~ N(prior, τ²)`` the posterior mean
    ``prior + τ² / (τ² + variance) · (estimate − prior)``, ``τ²`` by DerSimonian and
    Laird's moment estimator over the ``frames`` (bool mask): ``Σ w (estimate − prior)²``
    has the expectation ``N + τ² Σ w`` (``w = 1 / variance``; ``N`` frames, 0 if
    negative). ``variance = inf``: the prior."""
    w = np.where(frames, 1.0 / variance, 0.0)
    d2 = np.where(frames, (estimate - prior) ** 2, 0.0)
    total = float(np.sum(w))
    tau2 = max((float(np.sum(w * d2)) - int(np.sum(frames & (w > 0)))) / total, 0.0) \
        if total > 0 else 0.0
    with np.errstate(invalid="ignore"):
        weight = np.where(np.isfinite(variance), tau2 / (tau2 + variance), 0.0)
    return prior + np.nan_to_num(weight) * (estimate - prior)


def smooth(
    log: pd.DataFrame,
    *,
    model: str = "ca",
    q: float | Mapping[str, float] | None = None,
    r: float | Mapping[str, float] | None = None,
    events: Mapping[str, float | None] | None = None,
    backend: str = "numpy",
    settings: SmoothSettings | None = None,
    tuned: Mapping[str, Mapping[str, float]] | None = None,
) -> pd.DataFrame:
    """Smoothed angles (rad), rates (rad/s), accelerations (rad/s²) and their sd.

    Parameters
    ----------
    log : DataFrame with ``t`` (s, strictly increasing) and ``theta``, ``psi``, ``phi``
        (rad; NaN = gap; an all-NaN column = angle not tracked).
    model : ``"ca"`` constant acceleration (white jerk) or ``"cj"`` constant jerk;
        ``"select"`` / ``"average"``: both, per angle the one of larger likelihood or
        their likelihood-weighted mixture (:mod:`~trebuchet.ingest.smoothing.model_choice`; the
        ``cj`` run takes the events the ``ca`` run found; about twice the time).
    q : process-noise spectral density (rad²/s⁵ for ``ca``, rad²/s⁷ for ``cj``), a number
        or ``{angle: number}``; default: maximum likelihood.
    r : measurement-noise sd (rad), number or per angle; default: maximum likelihood.
    events : ``{"trigger": t, "release": t}`` in the log's time (s); a key present
        overrides detection (``None``: no such event), an absent key is detected. Given
        times must lie inside the log and be ordered trigger < lift_off < release
        (``lift_off`` is only checked and passed on); the refusal names the log's file
        (``log.attrs["source"]``) and the event.
    backend : ``"numpy"`` (batched, default) or ``"filterpy"`` (final pass via filterpy).
    settings : :class:`SmoothSettings`.
    tuned : ``attrs["noise"]`` of an earlier smoothing of the same log with other events
        (``reconstruct`` smooths again where the engine's equations move the release):
        its ``q`` and ``q_ml`` (rad²/s⁵ or rad²/s⁷) and ``r_sd`` (rad) per angle stand in
        for the single-``q`` noise search. Used only with local noise
        (``SmoothSettings.local_noise``), whose scale is then fitted again by maximum
        likelihood on the new events, and only where neither ``q`` nor ``r`` is given
        and every tracked angle has its entry (and not for ``"select"``/``"average"``);
        else the search runs as usual.

    Returns
    -------
    DataFrame with the log's rows and ``t``, and for each angle ``X`` in theta, psi, phi:
    ``X``, ``X_d``, ``X_dd`` and ``X_sd``, ``X_d_sd``, ``X_dd_sd``. ``attrs``:
    ``events`` ({"trigger", "release"}: log time or None), ``event_sources``,
    ``event_sd`` ({"trigger": sd (s) of a detected or given trigger}), ``noise``
    ({angle: {"q", "r_sd", "q_ml", "loglik", "jump_gain", "jump_count", "source",
    "at_grid_edge", "pieces", "q_frames"}}; ``jump_gain``: what profiling over the event
    jumps adds to ``loglik``, ``jump_count`` their effective number,
    :func:`~trebuchet.ingest.smoothing.model_choice.jump_profile`; with local noise ``q`` is the
    density where the shape is at its mean and ``q_frames`` (n,) the one used at each
    frame), ``cov``
    ({angle: (n, k, k) smoothed covariance of [angle, rate, acceleration(, jerk)] in SI,
    with the bias term of ``SmoothSettings.bias_band``, NaN outside the track}),
    ``model``, ``loglik`` (sum over angles), ``notes``.

    Raises
    ------
    TrebuchetInputError : missing column, too few frames, time not increasing, bad
        ``q``/``r``/``events``; the message names the column and row.
    """
    settings = settings or SmoothSettings()
    if model in COMBINATIONS:
        if q is not None:
            raise TrebuchetInputError(f"smooth: model {model!r} compares fitted models; "
                                      "q (whose units depend on the model) cannot be given")
        first = smooth(log, model="ca", r=r, events=events, backend=backend, settings=settings)
        found = first.attrs["events"]
        second = smooth(log, model="cj", r=r, backend=backend, settings=settings,
                        events={"trigger": found["trigger"], "release": found["release"]})
        return combined_smoothing({"ca": first, "cj": second}, ANGLES, SUFFIXES, model)
    if model not in MODEL_STATES:
        raise TrebuchetInputError(f"smooth: model must be 'ca', 'cj', 'select' or 'average', "
                                  f"not {model!r}")
    if backend not in ("numpy", "filterpy"):
        raise TrebuchetInputError(f"smooth: backend must be 'numpy' or 'filterpy', not {backend!r}")
    k = MODEL_STATES[model]
    t, Z_all = validated_log(log, settings.min_frames)
    Z_all = unwrapped_angles(Z_all)
    tracked = [a for i, a in enumerate(ANGLES) if np.isfinite(Z_all[i]).any()]
    Z = Z_all[[ANGLES.index(a) for a in tracked]]
    q_in = per_angle(q, "q", tracked)
    r_in = per_angle(r, "r", tracked)
    given = checked_events(events, t, log_name(log))
    notes = _untracked_notes(tracked, log_name(log))

    sd = _initial_noise_sd(t, Z, [r_in[a] for a in tracked])
    trigger, events_found = _trigger(t, Z, sd, given, settings)
    p = _problem(t, Z, tracked, sd, trigger, k, q_in, r_in, settings)
    release = given.get("release")
    fit, nearest = _first_tuning(p, given, release, tuned)
    fit, nearest, release, how = _release_scan(p, fit, nearest, given, release)
    events_found["sources"]["release"] = how
    if p.shaped:
        fit = _shaped_noise(p, fit, nearest, scan="release" not in given,
                            released=fit.rel_s is not None)

    xs, Ps = fit.sm.x[:, :p.A], fit.sm.P[:, :p.A]
    jump_gain, jump_count = jump_profile(fit.steps.G, p.kick, fit.sm.r[:, :p.A],
                                         fit.sm.N[:, :p.A])
    if backend == "filterpy":
        xs, Ps = _filterpy_pass(p, fit)
    band_scale = np.ones((p.A, p.n))
    if settings.band_variance != "posterior":
        Ps, band_scale = _band(p, fit, xs, Ps)
    if settings.bias_band:
        Ps = _bias_band(p, fit, xs, Ps)
    out, noise, cov, loglik = _assembled(log, p, fit, xs, Ps, band_scale, jump_gain,
                                         jump_count, notes)
    out.attrs["events"] = {"trigger": trigger, "release": release}
    if "lift_off" in given:
        out.attrs["events"]["lift_off"] = given["lift_off"]
    out.attrs["event_sources"] = events_found["sources"]
    out.attrs["event_sd"] = events_found["sd"]
    out.attrs["noise"] = noise
    out.attrs["cov"] = cov
    out.attrs["model"] = model
    out.attrs["loglik"] = loglik
    out.attrs["notes"] = notes
    return out


# ----------------------------------------------------------------------------- stages


@dataclass(frozen=True, eq=False)
class _Problem:
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
class _Fit:
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


def _untracked_notes(tracked: list[str], name: str) -> list[str]:
    """A note (and a warning) for each angle without any value."""
    notes: list[str] = []
    for a in ANGLES:
        if a not in tracked:
            notes.append(f"{a}: not tracked (all NaN); its columns are NaN")
            warnings.warn(TrebuchetDataWarning(
                f"{name}: {a} is not tracked (no value at all): its rate, "
                "acceleration and every load that needs it are NaN"), stacklevel=3)
    return notes


def _initial_noise_sd(t: np.ndarray, Z: np.ndarray, r_given: list[float]) -> np.ndarray:
    """Measurement noise sd per angle (rad) before any smoothing: the robust estimate of
    :func:`~trebuchet.ingest.events.detection.robust_noise_sd`, 1e-3 of the angle's range
    where it fails, or the given ``r``."""
    sd = np.array([robust_noise_sd(t, z) for z in Z])
    sd = np.where(np.isfinite(sd) & (sd > 0), sd, np.nan)
    fallback = 1e-3 * np.array([np.nanmax(z) - np.nanmin(z) for z in Z])
    sd = np.where(np.isfinite(sd), sd, np.maximum(fallback, 1e-9))
    for a, r_a in enumerate(r_given):
        if np.isfinite(r_a):
            sd[a] = r_a
    return sd


def _trigger(t: np.ndarray, Z: np.ndarray, sd: np.ndarray, given: Mapping[str, float | None],
             settings: SmoothSettings) -> tuple[float | None, dict]:
    """The trigger (log time, s; None without rest at the start) and ``{"sources": {...},
    "sd": {...}}`` for the events: given, or the onset fit of
    :func:`~trebuchet.ingest.events.detection.trigger_estimate` with its sd (s)."""
    sources: dict[str, str] = {}
    event_sd: dict[str, float] = {}
    if "trigger" in given:
        trigger = given["trigger"]
        sources["trigger"] = "given"
        event_sd["trigger"] = 0.0
    else:
        found_trigger = trigger_estimate(t, Z, sd, settings.trigger)
        trigger = None if found_trigger is None else found_trigger[0]
        if found_trigger is not None:
            event_sd["trigger"] = found_trigger[1]
        sources["trigger"] = "detected" if trigger is not None else "no rest found at the start"
    return trigger, {"sources": sources, "sd": event_sd}


def _problem(t: np.ndarray, Z: np.ndarray, tracked: list[str], sd: np.ndarray,
             trigger: float | None, k: int, q_in: Mapping[str, float],
             r_in: Mapping[str, float], settings: SmoothSettings) -> _Problem:
    """The smoothing's fixed parts: time in frames, the scales of the event kicks and the
    diffuse priors (from each angle's excursion over the shot's duration), the given noise."""
    tau = float(np.median(np.diff(t)))
    ts = (t - t[0]) / tau
    rest = trigger is not None
    excursion = np.array([np.nanmax(z) - np.nanmin(z) for z in Z])
    excursion = np.maximum(excursion, 10 * sd)
    duration = max(t[-1] - (trigger if trigger is not None else t[0]), 2 * tau)
    acc_sd = settings.kick_scale * excursion / duration**2 * tau**2
    rate_sd = 10.0 * excursion / duration * tau
    jerk_time = settings.jerk_kick_time / tau
    jerk_sd = acc_sd / jerk_time
    x0, P0, weight = _priors(Z, sd, k, rest, acc_sd, rate_sd, jerk_sd)
    return _Problem(
        t=t, ts=ts, tau=tau, k=k, tracked=tracked, Z=Z, valid=np.isfinite(Z), weight=weight,
        x0=x0, P0=P0, kick=acc_sd**2,
        q_given=np.array([q_in[a] for a in tracked]) * tau ** (2 * k - 1),
        r2_given=np.array([r_in[a] ** 2 for a in tracked]), r2_ref=sd**2,
        grid=lambda_grid(k, tau, t[-1] - t[0], settings.noise), jerk_time=jerk_time,
        trig_s=None if trigger is None else (trigger - t[0]) / tau, settings=settings)


def _tune(p: _Problem, steps: StepModel, grid: np.ndarray, store: bool = False
          ) -> tuple[list[NoiseEstimate], FilterResult | None]:
    """Estimates per angle and, with ``store``, the grid filter's result for the
    free angles (``q`` not given) at the grid point nearest each one's maximum (None
    if one of them was not searched)."""
    A, free = p.A, p.free
    need = [a for a in range(A) if not (np.isfinite(p.q_given[a]) and np.isfinite(p.r2_given[a]))]
    est: list[NoiseEstimate | None] = [None] * A
    for a in range(A):
        if a not in need:
            lam = p.q_given[a] / p.r2_given[a]
            est[a] = NoiseEstimate(lam, lam, float(p.r2_given[a]), np.nan, False)
    nearest = None
    if need:
        found, filt = maximum_likelihood_noise(
            p.Z[need], p.valid[need], p.weight[need], steps, grid, p.r2_ref[need],
            p.kick[need], p.x0[need], p.P0[need], p.r2_given[need], p.q_given[need],
            p.settings.noise, store=store,
        )
        for a, e in zip(need, found, strict=True):
            est[a] = e
        if store and all(a in need for a in free):
            nearest = filt.series(np.array([
                need.index(a) * grid.size
                + int(np.argmin(np.abs(np.log(grid / est[a].lam_ml)))) for a in free]))
    return est, nearest  # type: ignore[return-value]


def _tune_pieces(p: _Problem, steps: StepModel, est: list[NoiseEstimate], start: int,
                 rel_index: int | None, pieces: bool = True
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """λ per angle and frame (A, n) to use and the maximum-likelihood one, and the
    bounds; one λ per angle where ``q`` is given or pieces are off."""
    A, n, settings = p.A, p.n, p.settings
    lam_use = np.array([[e.lam] for e in est]) * np.ones((A, n))
    lam_ml = np.array([[e.lam_ml] for e in est]) * np.ones((A, n))
    free = p.free
    bounds = piece_bounds(n, start, rel_index, settings.shot_pieces,
                          settings.piece_min_frames)
    if not pieces or settings.shot_pieces < 1 or not free or bounds.size <= 2:
        return lam_use, lam_ml, np.array([0, n])
    cap = np.full(bounds.size - 1, np.inf)
    if rel_index is not None:
        cap[bounds[1:] == int(rel_index)] = settings.release_piece_max_decades
    found = piecewise_noise(
        p.Z[free], p.valid[free], p.weight[free], steps, bounds,
        np.array([est[a].lam_ml for a in free]), np.array([est[a].r2 for a in free]),
        p.kick[free], p.x0[free], p.P0[free], settings.noise, cap,
    )
    piece = np.repeat(np.arange(bounds.size - 1), np.diff(bounds))
    lam_use[free] = found.lam[:, piece]
    lam_ml[free] = found.lam_ml[:, piece]
    return lam_use, lam_ml, bounds


def _final_pass(p: _Problem, fit: _Fit, scan: bool = True) -> _Fit:
    """Smoother with the chosen q (series 0..A-1) and, for the release scan, the
    maximum-likelihood q (A..2A-1): one batched pass costs about the same as one."""
    steps, est, A = fit.steps, fit.est, p.A
    if not scan:
        filt = batch_kalman_filter(
            p.Z, p.valid, steps, fit.lam_use * np.array([e.r2 for e in est])[:, None], p.kick,
            np.array([e.r2 for e in est]), p.x0, p.P0, store=True)
        return replace(fit, filt=filt, sm=backward_smoother(steps, filt, p.valid))
    lam = np.concatenate([fit.lam_use, fit.lam_ml])
    r2 = np.tile([e.r2 for e in est], 2)
    two = np.r_[np.arange(A), np.arange(A)]
    filt = batch_kalman_filter(
        p.Z[two], p.valid[two], steps, lam * r2[:, None], p.kick[two], r2, p.x0[two],
        p.P0[two], store=True,
    )
    return replace(fit, filt=filt, sm=backward_smoother(steps, filt, p.valid[two]))


def _first_tuning(p: _Problem, given: Mapping[str, float | None], release: float | None,
                  tuned: Mapping[str, Mapping[str, float]] | None
                  ) -> tuple[_Fit, FilterResult | None]:
    """The noise search on the events known so far (a given release, or none yet): one λ
    per angle while the release is still to be scanned for, pieces after it; an earlier
    smoothing's noise (``tuned``) stands in for the search where local noise will refine
    it. Returns the fit (smoothed unless local noise follows on known events) and the
    grid filter nearest each angle's maximum, for the local noise's shape."""
    rel_s = None if release is None else (release - p.t[0]) / p.tau
    steps, start = event_step_model(p.ts, p.k, p.trig_s, rel_s, p.jerk_time)
    scan = "release" not in given  # one q per angle for the release scan, pieces after it
    # local noise: its shape comes from a smoother at the grid point nearest the
    # maximum-likelihood q of the last tuning (which must have run on the final steps)
    earlier = (p.shaped and tuned is not None and len(p.free) == p.A
               and not np.isfinite(p.r2_given).any() and all(a in tuned for a in p.tracked))
    if earlier:  # the local noise's shape then comes from a smoother at this q_ml
        est, nearest = [_earlier_estimate(tuned[a], p.tau, p.k) for a in p.tracked], None
    else:
        est, nearest = _tune(p, steps, p.grid, store=p.shaped and not scan)
    lam_use, lam_ml, bounds = _tune_pieces(p, steps, est, start, p.release_index(rel_s),
                                           pieces=not scan)
    fit = _Fit(steps, start, rel_s, est, lam_use, lam_ml, bounds)
    if scan or not p.shaped:
        fit = _final_pass(p, fit, scan)
    return fit, nearest


def _release_scan(p: _Problem, fit: _Fit, nearest: FilterResult | None,
                  given: Mapping[str, float | None], release: float | None
                  ) -> tuple[_Fit, FilterResult | None, float | None, str]:
    """The release: given, or found by the jump search on the maximum-likelihood series of
    the first tuning (:func:`~trebuchet.ingest.events.detection.detect_release`), then the
    noise tuned again (locally around the first maximum) on the new events. Returns the
    fit, the grid filter for the local noise's shape, the release (log time, s) and how it
    was found."""
    settings, A, t, tau = p.settings, p.A, p.t, p.tau
    if "release" in given:
        return fit, nearest, release, "given" if release is not None else "given as none"
    sm, valid, tracked = fit.sm, p.valid, p.tracked
    stat, when = release_statistic(
        p.ts, sm.r[:, A:], sm.N[:, A:], settings.release.subframe_positions
    )
    sling_end = None
    if "phi" in tracked:
        last = {a: np.flatnonzero(valid[i])[-1] for i, a in enumerate(tracked)}
        others = [last[a] for a in tracked if a != "phi"]
        if others and max(others) - last["phi"] >= 3:
            sling_end = int(last["phi"])
    rel_s, how = detect_release(p.ts, stat, when, fit.start, sling_end, settings.release)
    if rel_s is not None:
        release = float(t[0] + rel_s * tau)
        steps, start = event_step_model(p.ts, p.k, p.trig_s, rel_s, p.jerk_time)
        est, nearest = fit.est, None
        if settings.retune_after_release:
            ml = np.array([e.lam_ml for e in est])
            step = settings.noise.log10_step / 2
            local = 10.0 ** (np.log10(np.median(ml)) + step * np.arange(-6, 7))
            local = np.unique(np.concatenate([local, p.grid]))
            local = local[(local > ml.min() / 30) & (local < ml.max() * 30)]
            est, nearest = _tune(p, steps, 10.0 ** np.linspace(
                np.log10(local.min()), np.log10(local.max()),
                int(round(np.log10(local.max() / local.min()) / step)) + 1), store=p.shaped)
        lam_use, lam_ml, bounds = _tune_pieces(p, steps, est, start, p.release_index(rel_s))
        fit = replace(fit, steps=steps, start=start, rel_s=rel_s, est=est, lam_use=lam_use,
                      lam_ml=lam_ml, bounds=bounds)
        if not p.shaped:
            fit = _final_pass(p, fit, scan=False)
    elif settings.shot_pieces >= 1:
        lam_use, lam_ml, bounds = _tune_pieces(p, fit.steps, fit.est, fit.start, None)
        fit = replace(fit, lam_use=lam_use, lam_ml=lam_ml, bounds=bounds)
        if not p.shaped:
            fit = _final_pass(p, fit, scan=False)
    return fit, nearest, release, how


def _shaped_noise(p: _Problem, fit: _Fit, nearest: FilterResult | None, scan: bool,
                  released: bool) -> _Fit:
    """The local noise on the final events: its shape from the acceleration of a smoother
    near the maximum-likelihood λ (the grid filter kept by the tuning, the release scan's
    own series where no release was found, or a pass at λ_ml), its scale fitted
    (:func:`_local_noise`), then the final pass."""
    free, A = p.free, p.A
    if nearest is not None:
        acc = smoothed_states(fit.steps, nearest, p.valid[free])[:, :, 2].T
    elif scan and not released:  # no release found: the scan's ML series, same steps
        acc = fit.sm.x[:, [A + a for a in free], 2].T
    else:
        r2f = np.array([fit.est[a].r2 for a in free])
        nearest = batch_kalman_filter(p.Z[free], p.valid[free], fit.steps,
                                      fit.lam_ml[free] * r2f[:, None], p.kick[free], r2f,
                                      p.x0[free], p.P0[free], store=True)
        acc = smoothed_states(fit.steps, nearest, p.valid[free])[:, :, 2].T
    fit = _local_noise(p, fit, acc)
    if len(free) < A:
        fit = _final_pass(p, fit, scan=False)
    return fit


def _local_noise(p: _Problem, fit: _Fit, acc: np.ndarray) -> _Fit:
    """λ per angle and frame (to use, maximum likelihood), the estimates and the
    smoother of the free angles with the λ to use: the shape of
    :func:`~trebuchet.ingest.smoothing.noise_tuning.jerk_noise_shape` from ``acc``
    (len(free), n), the acceleration (for ``cj`` too) of a smoother at about the
    maximum-likelihood λ ``fit.lam_ml`` (A, n); its scale per angle by maximum likelihood
    (``r`` kept), with ``cutoff_factor`` applied to that scale as to a single λ. The scale
    grid's step divides the cutoff's shift, so the filter of the grid point that shift
    below the maximum is the one to use: one batched pass fits the scale and filters."""
    steps, settings, k, n, A, valid = fit.steps, p.settings, p.k, p.n, p.A, p.valid
    free, est, lam_ml = p.free, fit.est, fit.lam_ml
    noisy = np.any(steps.Q0 != 0.0, axis=(1, 2)) & ~np.any(steps.G != 0.0, axis=(1, 2))
    w = np.zeros((len(free), n))
    for j, a in enumerate(free):
        ok = np.flatnonzero(valid[a])
        w[j, ok[0]:ok[-1] + 1] = noisy[ok[0]:ok[-1] + 1]
    ref = np.array([np.exp(np.average(np.log(lam_ml[a]), weights=w[j] + 1e-300))
                    for j, a in enumerate(free)])
    half = settings.local_window * ref ** (-1.0 / (2 * k))
    shape = jerk_noise_shape(acc, p.ts, w, half, settings.local_floor, settings.local_linear)
    ends = np.array([np.flatnonzero(valid[a])[-1] for a in range(A)])
    shape = track_end_common_noise(shape, w, ends[free], int(ends.max()),
                                   settings.local_end_common * half)
    shape = shape * ref[:, None]
    cut = -2 * k * np.log10(settings.noise.cutoff_factor)
    shift = int(np.ceil(cut / (settings.noise.log10_step / 2) - 1e-9)) if cut > 0 else 0
    step = cut / shift if shift else settings.noise.log10_step / 2
    half = int(np.ceil(settings.local_scale_decades / step))
    offsets = step * np.arange(-half - shift, half + 1)
    r2 = np.array([est[a].r2 for a in free])
    found, filt = maximum_likelihood_noise(
        p.Z[free], valid[free], p.weight[free], steps, 10.0**offsets, r2, p.kick[free],
        p.x0[free], p.P0[free], r2, np.full(len(free), np.nan), settings.noise, shape=shape,
        store=True)
    est = list(est)
    lam_use = np.array([[e.lam] for e in est]) * np.ones((A, n))
    lam_ml = lam_ml.copy()
    pick = []
    for j, (e, a) in enumerate(zip(found, free, strict=True)):
        top = int(np.clip(np.round((np.log10(e.lam_ml) - offsets[0]) / step), 0,
                          offsets.size - 1))
        use = max(top - shift, 0)
        pick.append(j * offsets.size + use)
        est[a] = NoiseEstimate(e.lam_ml * ref[j], 10.0 ** offsets[use] * ref[j], e.r2,
                               e.loglik, e.at_edge or top - shift < 0)
        lam_ml[a] = e.lam_ml * shape[j]
        lam_use[a] = 10.0 ** offsets[use] * shape[j]
    picked = filt.series(np.array(pick))
    return replace(fit, est=est, lam_use=lam_use, lam_ml=lam_ml, filt=picked,
                   sm=backward_smoother(steps, picked, valid[free]))


def _filterpy_pass(p: _Problem, fit: _Fit) -> tuple[np.ndarray, np.ndarray]:
    """``backend="filterpy"``: the final pass through filterpy's filter and smoother,
    angle by angle (states and covariances as the numpy pass gives them)."""
    from trebuchet.ingest.kalman.filterpy_reference import filterpy_filter_smoother

    A = p.A
    xs = np.empty_like(fit.sm.x[:, :A])
    Ps = np.empty_like(fit.sm.P[:, :A])
    for a, e in enumerate(fit.est):
        res = filterpy_filter_smoother(
            p.Z[a], p.valid[a], fit.steps, fit.lam_use[a] * e.r2, p.kick[a], e.r2, p.x0[a],
            p.P0[a]
        )
        xs[:, a] = res["xs"]
        Ps[:, a] = res["Ps"]
    return xs, Ps


def _band(p: _Problem, fit: _Fit, xs: np.ndarray, Ps: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray]:
    """The band's covariance and its process-noise share α (A, n): the measurement noise's
    exact error covariance ``E0`` (``band_variance="noise"``), or ``E0 + α (P − E0)`` with α
    the share of the model's white noise the data show near each frame
    (``"calibrated"``; see :class:`SmoothSettings`)."""
    settings, steps, k, A, n, valid = p.settings, fit.steps, p.k, p.A, p.n, p.valid
    est, lam_use, sm, kick = fit.est, fit.lam_use, fit.sm, p.kick
    band_scale = np.ones((A, n))
    used = fit.filt.series(np.arange(A))
    own = SmootherResult(sm.x[:, :A], sm.P[:, :A], sm.r[:, :A], sm.N[:, :A])
    true_noise = kick[None, :, None, None] * steps.G[:, None]
    E0, R0 = error_covariance(steps, used, own, valid, np.array([e.r2 for e in est]),
                              true_noise, p.P0, parts=True)
    if settings.band_variance == "noise":
        return E0, band_scale
    # how much of the white noise the data show, frame by frame: the backward
    # sums r have E[r rᵀ] = R0 + α (N − R0) when the true process noise is α
    # times the model's; a method-of-moments α over a Gaussian window
    lam_q = lam_use[:, :, None, None] * steps.Q0[None]  # (A, n, k, k)
    lam_q = np.swapaxes(lam_q, 0, 1)  # (n, A, k, k)
    rr = sm.r[:, :A]
    seen = np.einsum("nai,naij,naj->na", rr, lam_q, rr)
    base = np.einsum("naij,naji->na", lam_q, R0)
    slope = np.einsum("naij,naji->na", lam_q, sm.N[:, :A] - R0)
    shrink = settings.band_alpha_from == "shrunk"
    if shrink:
        seen_r, base_r, slope_r, alt = _residual_moments(
            steps, used, p.Z, valid, xs[:, :, 0].T, lam_use,
            np.array([e.r2 for e in est]), kick, p.P0, settings.band_draws)
    alpha = np.ones((A, n))
    a_res = np.zeros((A, n))
    v_res = np.full((A, n), np.inf)
    noisy = np.flatnonzero(steps.Q0[:, 0, 0] > 0)
    frames = np.zeros((A, n), bool)
    for a in range(A):
        tc = np.exp(np.mean(np.log(lam_use[a, noisy]))) ** (-1.0 / (2 * k))
        width = settings.band_window * tc
        num = gaussian_filter1d(seen[:, a] - base[:, a], width, mode="constant")
        den = gaussian_filter1d(slope[:, a], width, mode="constant")
        with np.errstate(invalid="ignore", divide="ignore"):
            alpha[a] = np.where(den > 0, np.maximum(num, 0.0) / den, 1.0)
        if shrink:
            # the residual's α and its sampling variance at α = 1 (the
            # windowed statistic's scatter over the draws of noise plus process)
            num = gaussian_filter1d(seen_r[:, a] - base_r[:, a], width, mode="constant")
            den = gaussian_filter1d(slope_r[:, a], width, mode="constant")
            sd = gaussian_filter1d(alt[:, :, a], width, axis=0,
                                   mode="constant").std(axis=1, ddof=1)
            good = (den > 0) & (sd > 0)
            with np.errstate(invalid="ignore", divide="ignore"):
                a_res[a] = np.where(good, num / den, 0.0)
                v_res[a] = np.where(good, (sd / den) ** 2, np.inf)
            ok = np.flatnonzero(valid[a])
            frames[a, ok[0]:ok[-1] + 1] = steps.Q0[ok[0]:ok[-1] + 1, 0, 0] > 0
    alpha = np.clip(alpha, 0.0, 1.0)
    if shrink:
        alpha = np.clip(shrunk_alpha(alpha, a_res, v_res, frames), 0.0, 1.0)
    return E0 + alpha.T[:, :, None, None] * (Ps - E0), alpha


def _bias_band(p: _Problem, fit: _Fit, xs: np.ndarray, Ps: np.ndarray) -> np.ndarray:
    """``Ps`` plus ``b bᵀ``, the smoothing's bias ``b`` from the same smoother run again on
    its own output, ``bias_iterations`` terms of its series."""
    steps, valid = fit.steps, p.valid
    used = fit.filt.series(np.arange(p.A))

    def again(series: np.ndarray, prior: np.ndarray) -> np.ndarray:
        return smoothed_states(steps, refiltered(steps, used, series, valid, prior), valid)

    bias = again(xs[:, :, 0].T, p.x0) - xs
    step_bias = bias
    for _ in range(p.settings.bias_iterations - 1):
        # the next term of the bias's series: with x̂ = M x, (M − I) x =
        # Σ_j (I − M)^j (M − I) x̂, each term the last one less its own smoothing
        step_bias = step_bias - again(step_bias[:, :, 0].T, np.zeros_like(p.x0))
        bias = bias + step_bias
    return Ps + bias[..., :, None] * bias[..., None, :]


def _assembled(log: pd.DataFrame, p: _Problem, fit: _Fit, xs: np.ndarray, Ps: np.ndarray,
               band_scale: np.ndarray, jump_gain: np.ndarray, jump_count: np.ndarray,
               notes: list[str]) -> tuple[pd.DataFrame, dict, dict, float]:
    """The result table in SI (columns ``X``, ``X_d``, ``X_dd`` and their ``_sd``; NaN
    outside each track), and per angle its noise fit and covariance, and the summed
    log-likelihood; appends to ``notes``."""
    t, tau, k, n, tracked = p.t, p.tau, p.k, p.n, p.tracked
    est, lam_use, bounds = fit.est, fit.lam_use, fit.bounds
    shaped, free = p.shaped, p.free
    # back to SI
    scale = tau ** -np.arange(k)
    xs = xs * scale
    Ps = Ps * scale[:, None] * scale[None, :]
    out = pd.DataFrame({"t": t}, index=log.index)
    cov = {}
    noise = {}
    loglik = 0.0
    for name in ANGLES:
        cols = {}
        if name in tracked:
            a = tracked.index(name)
            ok = np.flatnonzero(p.valid[a])
            inside = np.zeros(n, bool)
            inside[ok[0] : ok[-1] + 1] = True
            if ok[-1] < n - 1:
                notes.append(
                    f"{name}: track ends at t = {t[ok[-1]]:g} s; "
                    "later rows are NaN (not extrapolated)"
                )
            if ok[0] > 0:
                notes.append(f"{name}: track starts at t = {t[ok[0]]:g} s; earlier rows are NaN")
            var = np.diagonal(Ps[:, a], axis1=1, axis2=2)
            for j, suf in enumerate(SUFFIXES):
                cols[name + suf] = np.where(inside, xs[:, a, j], np.nan)
                sd_j = np.sqrt(np.maximum(var[:, j], 0.0))
                cols[name + suf + "_sd"] = np.where(inside, sd_j, np.nan)
            c = Ps[:, a].copy()
            c[~inside] = np.nan
            cov[name] = c
            e = est[a]
            q_si = e.lam * e.r2 / tau ** (2 * k - 1)
            noise[name] = {
                "q": q_si,
                "r_sd": float(np.sqrt(e.r2)),
                "q_ml": e.lam_ml * e.r2 / tau ** (2 * k - 1),
                "loglik": e.loglik,
                "jump_gain": float(jump_gain[a]),
                "jump_count": float(jump_count[a]),
                "source": "given" if np.isfinite(p.q_given[a]) and np.isfinite(p.r2_given[a])
                else "maximum likelihood",
                "at_grid_edge": e.at_edge,
                "pieces": [] if shaped and a in free else [
                    {"t_start": float(t[lo]), "t_end": float(t[hi - 1]),
                     "q": float(lam_use[a, lo] * e.r2 / tau ** (2 * k - 1))}
                    for lo, hi in zip(bounds[:-1], bounds[1:], strict=True)
                ],
                "q_frames": lam_use[a] * e.r2 / tau ** (2 * k - 1),
                "band_scale": band_scale[a],
            }
            if e.at_edge:
                notes.append(f"{name}: the likelihood maximum lies on the edge of the q grid")
            if np.isfinite(e.loglik):
                loglik += e.loglik
        else:
            for suf in SUFFIXES:
                cols[name + suf] = np.full(n, np.nan)
                cols[name + suf + "_sd"] = np.full(n, np.nan)
        for key, v in cols.items():
            out[key] = v
    order = ["t"] + [a + s for a in ANGLES for s in SUFFIXES] + [
        a + s + "_sd" for a in ANGLES for s in SUFFIXES
    ]
    extra = [c for c in out.columns if c not in order]
    out = out[order + extra]
    return out, noise, cov, loglik
