"""Tuning the smoother's noise: the single-λ search, pieces of the shot, the release scan
and the local (frame-by-frame) noise, each stage a function of the
:class:`~trebuchet.ingest.smoothing.problem.SmoothingProblem` and the last
:class:`~trebuchet.ingest.smoothing.problem.TuningState`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from trebuchet.ingest.events.detection import (
    detect_release,
    release_statistic,
)
from trebuchet.ingest.kalman.batch import (
    FilterResult,
    StepModel,
    backward_smoother,
    batch_kalman_filter,
    smoothed_states,
)
from trebuchet.ingest.smoothing.noise_tuning import (
    NoiseEstimate,
    grid_filter,
    jerk_noise_shape,
    maximum_likelihood_noise,
    piecewise_noise,
    track_end_common_noise,
)
from trebuchet.ingest.smoothing.problem import (
    SmoothingProblem,
    TuningState,
    event_step_model,
    piece_bounds,
)

__all__ = ["tune", "tune_pieces", "final_pass", "first_tuning", "release_scan", "shaped_noise",
           "local_noise", "earlier_estimate"]


def tune(p: SmoothingProblem, steps: StepModel, grid: np.ndarray, store: bool = False
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
        found = maximum_likelihood_noise(
            p.Z[need], p.valid[need], p.weight[need], steps, grid, p.r2_ref[need],
            p.kick[need], p.x0[need], p.P0[need], p.r2_given[need], p.q_given[need],
            p.settings.noise,
        )
        for a, e in zip(need, found, strict=True):
            est[a] = e
        if store and all(a in need for a in free):
            near = np.array([grid[int(np.argmin(np.abs(np.log(grid / est[a].lam_ml))))]
                             for a in free])
            nearest = grid_filter(p.Z[free], p.valid[free], steps, near * p.r2_ref[free],
                                  p.r2_ref[free], p.kick[free], p.x0[free], p.P0[free])
    return est, nearest  # type: ignore[return-value]


def tune_pieces(p: SmoothingProblem, steps: StepModel, est: list[NoiseEstimate], start: int,
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


def final_pass(p: SmoothingProblem, fit: TuningState, scan: bool = True) -> TuningState:
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


def first_tuning(p: SmoothingProblem, given: Mapping[str, float | None], release: float | None,
                  tuned: Mapping[str, Mapping[str, float]] | None
                  ) -> tuple[TuningState, FilterResult | None]:
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
        est, nearest = [earlier_estimate(tuned[a], p.tau, p.k) for a in p.tracked], None
    else:
        est, nearest = tune(p, steps, p.grid, store=p.shaped and not scan)
    lam_use, lam_ml, bounds = tune_pieces(p, steps, est, start, p.release_index(rel_s),
                                           pieces=not scan)
    fit = TuningState(steps, start, rel_s, est, lam_use, lam_ml, bounds)
    if scan or not p.shaped:
        fit = final_pass(p, fit, scan)
    return fit, nearest


def release_scan(p: SmoothingProblem, fit: TuningState, nearest: FilterResult | None,
                  given: Mapping[str, float | None], release: float | None
                  ) -> tuple[TuningState, FilterResult | None, float | None, str]:
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
            est, nearest = tune(p, steps, 10.0 ** np.linspace(
                np.log10(local.min()), np.log10(local.max()),
                int(round(np.log10(local.max() / local.min()) / step)) + 1), store=p.shaped)
        lam_use, lam_ml, bounds = tune_pieces(p, steps, est, start, p.release_index(rel_s))
        fit = replace(fit, steps=steps, start=start, rel_s=rel_s, est=est, lam_use=lam_use,
                      lam_ml=lam_ml, bounds=bounds)
        if not p.shaped:
            fit = final_pass(p, fit, scan=False)
    elif settings.shot_pieces >= 1:
        lam_use, lam_ml, bounds = tune_pieces(p, fit.steps, fit.est, fit.start, None)
        fit = replace(fit, lam_use=lam_use, lam_ml=lam_ml, bounds=bounds)
        if not p.shaped:
            fit = final_pass(p, fit, scan=False)
    return fit, nearest, release, how


def shaped_noise(p: SmoothingProblem, fit: TuningState, nearest: FilterResult | None, scan: bool,
                  released: bool) -> TuningState:
    """The local noise on the final events: its shape from the acceleration of a smoother
    near the maximum-likelihood λ (the grid filter kept by the tuning, the release scan's
    own series where no release was found, or a pass at λ_ml), its scale fitted
    (:func:`local_noise`), then the final pass."""
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
    fit = local_noise(p, fit, acc)
    if len(free) < A:
        fit = final_pass(p, fit, scan=False)
    return fit


def local_noise(p: SmoothingProblem, fit: TuningState, acc: np.ndarray) -> TuningState:
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
    scales = 10.0**offsets
    found = maximum_likelihood_noise(
        p.Z[free], valid[free], p.weight[free], steps, scales, r2, p.kick[free],
        p.x0[free], p.P0[free], r2, np.full(len(free), np.nan), settings.noise, shape=shape)
    est = list(est)
    lam_use = np.array([[e.lam] for e in est]) * np.ones((A, n))
    lam_ml = lam_ml.copy()
    pick = []
    for j, (e, a) in enumerate(zip(found, free, strict=True)):
        top = int(np.clip(np.round((np.log10(e.lam_ml) - offsets[0]) / step), 0,
                          offsets.size - 1))
        use = max(top - shift, 0)
        pick.append(use)
        est[a] = NoiseEstimate(e.lam_ml * ref[j], 10.0 ** offsets[use] * ref[j], e.r2,
                               e.loglik, e.at_edge or top - shift < 0)
        lam_ml[a] = e.lam_ml * shape[j]
        lam_use[a] = 10.0 ** offsets[use] * shape[j]
    picked = grid_filter(p.Z[free], valid[free], steps, scales[pick] * r2, r2, p.kick[free],
                         p.x0[free], p.P0[free], shape=shape)
    return replace(fit, est=est, lam_use=lam_use, lam_ml=lam_ml, filt=picked,
                   sm=backward_smoother(steps, picked, valid[free]))


def earlier_estimate(noise: Mapping[str, float], tau: float, k: int) -> NoiseEstimate:
    """A :class:`NoiseEstimate` (smoother units, frames of ``tau`` s, ``k`` states) from
    one angle's entry of an earlier smoothing's ``noise`` (SI: ``q``, ``q_ml``
    rad²/s^(2k−1), ``r_sd`` rad)."""
    r2 = float(noise["r_sd"]) ** 2
    unit = tau ** (2 * k - 1) / r2
    return NoiseEstimate(float(noise["q_ml"]) * unit, float(noise["q"]) * unit, r2,
                         float(noise.get("loglik", np.nan)), bool(noise.get("at_grid_edge")))
