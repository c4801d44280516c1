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
  its last valid frame) the outputs are NaN, not extrapolated (the notes of
  ``attrs["smoothing"]`` say so).

The numerics are the batched numpy filter of :mod:`~trebuchet.ingest.kalman.batch`
(about 30× faster than filterpy, equal to round-off; ``backend="filterpy"`` runs the final
pass through filterpy's ``KalmanFilter.batch_filter`` and ``rts_smoother`` instead).
Measured accuracy and speed: ``bench/smooth_accuracy.py``; docs/background.md,
"Differentiating video angles (filterpy 2.0.0)".

The stages, in the order :func:`smooth` runs them: the initial noise (:func:`_initial_noise_sd`),
the trigger (:func:`_trigger`), the fixed parts (:func:`_problem`,
:class:`~trebuchet.ingest.smoothing.problem.SmoothingProblem`), the tuning and release scan
(:mod:`~trebuchet.ingest.smoothing.tuning`), the band calibration and bias
(:mod:`~trebuchet.ingest.smoothing.band`), the assembly (:func:`_assembled`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from trebuchet.core.errors import TrebuchetDataWarning, TrebuchetInputError, warn_at_caller
from trebuchet.ingest.events.detection import robust_noise_sd, trigger_estimate
from trebuchet.ingest.smoothing.band import bias_band, calibrated_band, shrunk_alpha
from trebuchet.ingest.smoothing.inputs import (
    checked_events,
    log_name,
    per_angle,
    unwrapped_angles,
    validated_log,
)
from trebuchet.ingest.smoothing.model_choice import COMBINATIONS, combined_smoothing, jump_profile
from trebuchet.ingest.smoothing.noise_tuning import lambda_grid
from trebuchet.ingest.smoothing.problem import (
    SmoothingProblem,
    TuningState,
    event_step_model,
    piece_bounds,
    priors,
)
from trebuchet.ingest.smoothing.result import Smoothing, smoothing_of, with_smoothing
from trebuchet.ingest.smoothing.settings import (
    ANGLES,
    BAND_ALPHA_FROM,
    BAND_VARIANCES,
    MODEL_STATES,
    SUFFIXES,
    SmoothSettings,
)
from trebuchet.ingest.smoothing.tuning import first_tuning, release_scan, shaped_noise

__all__ = ["smooth", "SmoothSettings", "ANGLES", "SUFFIXES", "MODEL_STATES", "BAND_VARIANCES",
           "BAND_ALPHA_FROM", "validated_log", "checked_events", "event_step_model",
           "piece_bounds", "shrunk_alpha"]


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
        (``read_log``'s ``attrs["log"].source``) and the event.
    backend : ``"numpy"`` (batched, default) or ``"filterpy"`` (final pass via filterpy).
    settings : :class:`SmoothSettings`.
    tuned : the ``noise`` of an earlier smoothing of the same log with other events
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
    ``X``, ``X_d``, ``X_dd`` and ``X_sd``, ``X_d_sd``, ``X_dd_sd``.
    ``attrs["smoothing"]``: a :class:`~trebuchet.ingest.smoothing.result.Smoothing` (the
    events, their sd and sources, each angle's noise fit and covariance, the model, the
    log-likelihood, notes); ``attrs["events"]``: its events as a plain dict (trigger,
    release: log time, s, or None).

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
        found = smoothing_of(first).events
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
    fit, release, events_found["sources"]["release"] = _tuned_noise(p, given, tuned)
    xs, Ps, band_scale, jump_gain, jump_count = _final_states(p, fit, backend, settings)
    out, noise, cov, loglik = _assembled(log, p, fit, xs, Ps, band_scale, jump_gain,
                                         jump_count, notes)
    found = {"trigger": trigger, "release": release}
    if "lift_off" in given:
        found["lift_off"] = given["lift_off"]
    return with_smoothing(out, Smoothing(
        events=found, event_sd=events_found["sd"], event_sources=events_found["sources"],
        noise=noise, cov=cov, model=model, loglik=loglik, notes=notes))


def _untracked_notes(tracked: list[str], name: str) -> list[str]:
    """A note (and a warning) for each angle without any value."""
    notes: list[str] = []
    for a in ANGLES:
        if a not in tracked:
            notes.append(f"{a}: not tracked (all NaN); its columns are NaN")
            warn_at_caller(TrebuchetDataWarning(
                f"{name}: {a} is not tracked (no value at all): its rate, "
                "acceleration and every load that needs it are NaN"))
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
             r_in: Mapping[str, float], settings: SmoothSettings) -> SmoothingProblem:
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
    x0, P0, weight = priors(Z, sd, k, rest, acc_sd, rate_sd, jerk_sd)
    return SmoothingProblem(
        t=t, ts=ts, tau=tau, k=k, tracked=tracked, Z=Z, valid=np.isfinite(Z), weight=weight,
        x0=x0, P0=P0, kick=acc_sd**2,
        q_given=np.array([q_in[a] for a in tracked]) * tau ** (2 * k - 1),
        r2_given=np.array([r_in[a] ** 2 for a in tracked]), r2_ref=sd**2,
        grid=lambda_grid(k, tau, t[-1] - t[0], settings.noise), jerk_time=jerk_time,
        trig_s=None if trigger is None else (trigger - t[0]) / tau, settings=settings)


def _tuned_noise(p: SmoothingProblem, given: Mapping[str, float | None],
                 tuned: Mapping[str, Mapping[str, float]] | None
                 ) -> tuple[TuningState, float | None, str]:
    """The noise fit of the smoothing and its release: the first tuning
    (:func:`first_tuning`, or ``tuned``'s noise), the release scanned (given, or the
    search of :func:`release_scan`: log time, s, or None) with how it was found (a
    phrase), then, for local noise (``p.shaped``), the noise's shape fitted
    (:func:`shaped_noise`); the fit in the problem's units (frames)."""
    release = given.get("release")
    fit, nearest = first_tuning(p, given, release, tuned)
    fit, nearest, release, how = release_scan(p, fit, nearest, given, release)
    if p.shaped:
        fit = shaped_noise(p, fit, nearest, scan="release" not in given,
                            released=fit.rel_s is not None)
    return fit, release, how


def _final_states(p: SmoothingProblem, fit: TuningState, backend: str,
                  settings: SmoothSettings) -> tuple[np.ndarray, ...]:
    """The final pass: the smoothed states ``xs`` (n, A, k) and their covariances ``Ps``
    (n, A, k, k; rad and per-frame rates, as the fit's), through filterpy for
    ``backend="filterpy"``, the band's variance calibrated (``band_scale`` (A, n), 1 for
    ``band_variance="posterior"``) and widened by the bias band (``settings.bias_band``),
    and each angle's jump profile (``jump_gain``, ``jump_count``:
    :func:`jump_profile`)."""
    xs, Ps = fit.sm.x[:, :p.A], fit.sm.P[:, :p.A]
    jump_gain, jump_count = jump_profile(fit.steps.G, p.kick, fit.sm.r[:, :p.A],
                                         fit.sm.N[:, :p.A])
    if backend == "filterpy":
        xs, Ps = _filterpy_pass(p, fit)
    band_scale = np.ones((p.A, p.n))
    if settings.band_variance != "posterior":
        Ps, band_scale = calibrated_band(p, fit, xs, Ps)
    if settings.bias_band:
        Ps = bias_band(p, fit, xs, Ps)
    return xs, Ps, band_scale, jump_gain, jump_count


def _filterpy_pass(p: SmoothingProblem, fit: TuningState) -> tuple[np.ndarray, np.ndarray]:
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


def _assembled(log: pd.DataFrame, p: SmoothingProblem, fit: TuningState, xs: np.ndarray,
               Ps: np.ndarray, band_scale: np.ndarray, jump_gain: np.ndarray,
               jump_count: np.ndarray,
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
