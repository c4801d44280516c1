"""Find the trigger and the release of a shot in video-tracked angles.

- Trigger: the first motion after rest. The angles are at rest, then the acceleration
  jumps from zero (the rate stays continuous and keeps its sign for a while). Fitted by
  least squares of ``z = c`` before ``t0`` and a departure whose rate is ``u`` times a
  non-negative linear function (``u = t - t0``) after it, on every moving angle, each
  angle's noise variance profiled out; the likelihood is profiled over ``t0`` on a frame
  grid and then at a tenth of a frame, and its normalised profile gives the estimate (its
  mean) and its sd. An unconstrained cubic let noise at rest pass for a dip before the
  rise: 10–30 frames early in some logs at 0.3–2° noise.
- Release: the acceleration of the angles jumps (the sling tension vanishes), and the
  sling's track often ends. Found as the largest likelihood-ratio statistic of a jump in
  acceleration, from the backward smoothing recursion (de Jong 1989; Durbin & Koopman
  2012 §7.5: auxiliary residuals / intervention tests), see
  :func:`~trebuchet.ingest.kalman.batch.backward_smoother`.

Lift-off needs forces and is found elsewhere. All times in the log's own time (s).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from trebuchet.ingest.kalman.batch import polynomial_transition


@dataclass(frozen=True)
class TriggerSearch:
    """Settings of :func:`detect_trigger`.

    ``noise_multiple``: the fit window ends where an angle has left its rest value by this
    many noise sd, but at least ``min_excursion_fraction`` and at most
    ``max_excursion_fraction`` of its whole excursion and never less than
    ``min_noise_multiple`` sd, for ``persist_samples`` valid samples in a row.
    ``min_rest_frames``: fewer rest
    frames than this before the fitted onset means the log starts in motion (no trigger).
    ``coarse_candidates``: onsets tried on the first, frame-spaced pass; the second pass
    covers every onset within ``profile_drop`` log-likelihood units of the best at
    ``1/subframe_steps`` of a frame (coarser if that takes more than
    ``max_fine_candidates``).
    """

    noise_multiple: float = 50.0
    min_noise_multiple: float = 6.0
    persist_samples: int = 5
    min_excursion_fraction: float = 0.01
    max_excursion_fraction: float = 0.2
    min_signal_to_noise: float = 20.0
    min_rest_frames: int = 3
    subframe_steps: int = 10
    coarse_candidates: int = 80
    max_fine_candidates: int = 160
    profile_drop: float = 12.0


@dataclass(frozen=True)
class ReleaseSearch:
    """Settings of :func:`release_statistic` and :func:`detect_release`.

    ``threshold``: the χ² (summed over the angles) a jump must reach to count as the
    release when nothing else says where it is (chance maxima over a 2000-frame log with
    no jump stayed at or below 11 in trials). ``guard_frames``: frames after the trigger
    and before the end that are not searched. ``subframe_positions``: positions tried
    between two frames. ``track_end_window``: frames before the end of the sling track
    searched (without threshold) when the track ends before the others.
    """

    threshold: float = 25.0
    guard_frames: int = 3
    subframe_positions: int = 4
    track_end_window: int = 6


def robust_noise_sd(t: np.ndarray, z: np.ndarray) -> float:
    """Measurement-noise sd (units of ``z``) from the median absolute deviation of the
    residuals of linear interpolation between neighbouring valid samples.

    Robust to the smooth motion only where it is slow compared with the noise; used for
    scaling and the trigger fit, not as the final noise (that comes from the likelihood).
    NaN if fewer than 5 valid samples.
    """
    ok = np.isfinite(z)
    tv, zv = t[ok], z[ok]
    if zv.size < 5:
        return float("nan")
    h1 = tv[1:-1] - tv[:-2]
    h2 = tv[2:] - tv[1:-1]
    w = h2 / (h1 + h2)
    e = zv[1:-1] - (w * zv[:-2] + (1.0 - w) * zv[2:])
    e = e / np.sqrt(1.0 + w**2 + (1.0 - w) ** 2)
    mad = np.median(np.abs(e - np.median(e)))
    return float(1.4826 * mad)


def _onset_sse(t: np.ndarray, z: np.ndarray, t0: np.ndarray) -> np.ndarray:
    """Residual sum of squares (units of ``z``²) of the fit of a rest then a monotone
    departure, for each candidate onset ``t0`` (C,); ``t`` (m,) s, ``z`` (m,) with NaN gaps.

    Model: ``c`` before ``t0``; after it, ``c + s f(u)``, ``u = t - t0``, with the rate
    ``f'(u) = u (p + (q - p) u / U)`` (acceleration ``p`` at the onset, rate
    ``q U`` at the window's end ``U``) and ``p, q ≥ 0``: the acceleration jumps at the
    onset, the rate is continuous and keeps its sign ``s`` (the direction in which the
    angle has left rest at the end of the window) over the window. Least squares with
    the two bounds, exactly, by the best feasible solution over the active sets.
    """
    ok = np.isfinite(z)
    tv = t[ok]
    y = z[ok] - np.median(z[ok][:5])
    y = y * (1.0 if y[-1] >= 0 else -1.0)
    scale = max(tv[-1] - tv[0], 1e-12)
    u = np.maximum(tv[None, :] - t0[:, None], 0.0) / scale  # (C, m)
    span = np.maximum((tv[-1] - t0) / scale, 1e-9)[:, None]
    h2 = u**3 / (3.0 * span)
    h1 = u**2 / 2.0 - h2
    cols = (np.ones_like(u), h1, h2)
    XtX = np.empty((t0.size, 3, 3))
    for i in range(3):
        for j in range(i, 3):
            XtX[:, i, j] = XtX[:, j, i] = y.size if i == j == 0 else np.einsum(
                "cm,cm->c", cols[i], cols[j])
    Xty = np.stack([np.full(t0.size, y.sum()), h1 @ y, h2 @ y], axis=-1)
    yy = float(y @ y)
    best = np.full(t0.size, yy - y.sum() ** 2 / y.size)  # constant only
    for idx in (np.array([0, 1, 2]), np.array([0, 1]), np.array([0, 2])):
        G = XtX[:, idx[:, None], idx[None, :]]
        g = Xty[:, idx]
        G = G + 1e-12 * np.trace(G, axis1=1, axis2=2)[:, None, None] * np.eye(idx.size)
        beta = np.linalg.solve(G, g[..., None])[..., 0]
        sse = yy - np.einsum("ci,ci->c", beta, g)
        feasible = np.all(beta[:, 1:] >= 0.0, axis=1)
        best = np.where(feasible & (sse < best), sse, best)
    return np.maximum(best, 1e-300)


def _fit_windows(Z: np.ndarray, sd: np.ndarray, settings: TriggerSearch
                 ) -> tuple[list[int], list[int]]:
    """The angles that move clearly and, for each, the last frame of its onset fit window
    (see :class:`TriggerSearch`)."""
    ends, use = [], []
    for a, z in enumerate(Z):
        ok = np.flatnonzero(np.isfinite(z))
        if ok.size < 8 or not np.isfinite(sd[a]) or sd[a] <= 0:
            continue
        start = np.median(z[ok[:5]])
        dev = np.abs(z[ok] - start)
        excursion = dev.max()
        if excursion < settings.min_signal_to_noise * sd[a]:
            continue
        level = np.clip(
            settings.noise_multiple * sd[a],
            settings.min_excursion_fraction * excursion,
            settings.max_excursion_fraction * excursion,
        )
        level = max(level, settings.min_noise_multiple * sd[a])
        # first sample from which the angle stays beyond the level for a few samples
        above = dev > level
        m = min(settings.persist_samples, above.size)
        persistent = np.lib.stride_tricks.sliding_window_view(above, m).all(axis=1)
        if not persistent.any():
            continue
        ends.append(int(ok[np.argmax(persistent)]))
        use.append(a)
    return use, ends


def trigger_estimate(
    t: np.ndarray,
    Z: np.ndarray,
    sd: np.ndarray,
    settings: TriggerSearch = TriggerSearch(),
) -> tuple[float, float] | None:
    """Time (s, the log's time) at which the angles leave rest and its sd (s), or None.

    Each moving angle is fitted, over its own window from the first frame to where it has
    clearly left rest, by a constant before the onset ``t0`` and the constant plus
    ``Σ_{p=2..degree} b_p (t - t0)^p / p!`` after it (rate continuous, acceleration
    jumping at ``t0``). With each angle's noise variance profiled out the log-likelihood
    is ``ℓ(t0) = -Σ_angles (m_a/2) log SSE_a(t0)``; it is evaluated on a frame grid and
    then at ``1/subframe_steps`` of a frame over every onset within ``profile_drop`` of the
    maximum. The estimate is the mean of ``exp ℓ`` (a flat prior on ``t0``) over that
    grid, the sd its spread: wide where the first motion is buried in the noise.

    ``t`` (n,) increasing, ``Z`` (A, n) angles (rad) with NaN gaps, ``sd`` (A,) a rough
    noise sd (rad) that sets the window, e.g. from :func:`robust_noise_sd`. None when no
    angle moves clearly (excursion below ``min_signal_to_noise`` sd) or the log starts in
    motion (fewer than ``min_rest_frames`` frames before the onset).
    """
    use, ends = _fit_windows(Z, sd, settings)
    if not use:
        return None
    end = int(max(ends))
    if end < settings.min_rest_frames:
        return None
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    first_valid = min(int(np.flatnonzero(np.isfinite(Z[a]))[0]) for a in use)
    lo_t = t[first_valid] - settings.min_rest_frames * dt  # a log in motion peaks here
    hi_t = t[end]
    if hi_t <= lo_t:
        return None

    def loglik(t0: np.ndarray) -> np.ndarray:
        total = np.zeros(t0.size)
        for a, e in zip(use, ends, strict=True):
            z = Z[a, : e + 1]
            m = int(np.isfinite(z).sum())
            total -= 0.5 * m * np.log(_onset_sse(t[: e + 1], z, t0))
        return total

    frames = int(np.ceil((hi_t - lo_t) / dt))
    stride = max(1, frames // settings.coarse_candidates)
    coarse = np.linspace(lo_t, hi_t, frames // stride + 1)
    mean, spread, _ = refined_profile(loglik, coarse, loglik(coarse), dt,
                                      settings.profile_drop, settings.subframe_steps,
                                      settings.max_fine_candidates)
    if mean - t[first_valid] < (settings.min_rest_frames - 0.5) * dt:
        return None
    return mean, spread


def refined_profile(loglik: Callable[[np.ndarray], np.ndarray], coarse: np.ndarray,
                    coarse_loglik: np.ndarray, dt: float, drop: float, subframe_steps: int,
                    max_fine: int) -> tuple[float, float, float]:
    """Time (s) of an event from its profile log-likelihood, its sd (s), and the largest
    log-likelihood on the fine grid.

    ``loglik`` maps candidate times (s) to log-likelihoods, already evaluated on the
    ``coarse`` grid (``coarse_loglik``); every candidate within ``drop`` of the best, and
    one coarse step either side, is evaluated again every ``dt / subframe_steps`` s
    (coarser if that takes more than ``max_fine`` candidates). The estimate is the mean
    of ``exp(loglik)`` over that grid (a flat prior), the sd its spread with the grid's
    own ``step² / 12``.
    """
    keep = np.flatnonzero(coarse_loglik >= coarse_loglik.max() - drop)
    lo = coarse[max(keep[0] - 1, 0)]
    hi = coarse[min(keep[-1] + 1, coarse.size - 1)]
    step = max(dt / subframe_steps, (hi - lo) / max_fine)
    fine = np.arange(lo, hi + 0.5 * step, step)
    ll = loglik(fine)
    w = np.exp(ll - ll.max())
    w /= w.sum()
    mean = float(w @ fine)
    return mean, float(np.sqrt(w @ (fine - mean) ** 2 + step**2 / 12.0)), float(ll.max())


def detect_trigger(
    t: np.ndarray,
    Z: np.ndarray,
    sd: np.ndarray,
    settings: TriggerSearch = TriggerSearch(),
) -> float | None:
    """The time (s) of :func:`trigger_estimate`, or None."""
    found = trigger_estimate(t, Z, sd, settings)
    return None if found is None else found[0]


def jump_direction(k: int, delta: np.ndarray) -> np.ndarray:
    """State change at a frame caused by a unit jump in acceleration ``delta`` earlier.

    ``F(delta) e_acc = [delta²/2, delta, 1, 0…]``; ``delta`` in the smoother's time unit,
    any shape; returns shape ``delta.shape + (k,)``.
    """
    F = polynomial_transition(k, np.ravel(delta))
    return F[:, :, 2].reshape(np.shape(delta) + (k,))


def release_statistic(
    ts: np.ndarray,
    r: np.ndarray,
    N: np.ndarray,
    positions: int = 4,
) -> tuple[np.ndarray, np.ndarray]:
    """Likelihood-ratio statistic of a jump in acceleration before each frame.

    ``ts`` (n,) frame times in the smoother's unit, ``r`` (n, A, k) and ``N`` (n, A, k, k)
    from :func:`~trebuchet.ingest.kalman.batch.backward_smoother` (one series per angle).
    For frame ``i`` and a jump at ``t_i - δ``, ``δ`` = 0, 1/m, … of the frame interval,
    the statistic is ``Σ_angles (d·r)² / dᵀNd``. Returns the best statistic per frame
    (n,) and the jump time (n,) for it (smoother's unit); frame 0 gets 0.
    """
    n, A, k = r.shape
    dt = np.diff(ts, prepend=ts[0])
    frac = np.arange(positions) / positions
    delta = dt[:, None] * frac[None, :]  # (n, m)
    d = jump_direction(k, delta)  # (n, m, k)
    score = np.einsum("nmk,nak->nma", d, r)
    info = np.einsum("nmk,nakl,nml->nma", d, N, d)
    chi2 = np.where(info > 1e-300, score**2 / np.where(info > 1e-300, info, 1.0), 0.0)
    total = chi2.sum(axis=2)  # (n, m)
    best = np.argmax(total, axis=1)
    stat = total[np.arange(n), best]
    stat[0] = 0.0
    when = ts - delta[np.arange(n), best]
    return stat, when


def detect_release(
    ts: np.ndarray,
    stat: np.ndarray,
    when: np.ndarray,
    trigger_index: int,
    sling_end_index: int | None,
    settings: ReleaseSearch = ReleaseSearch(),
) -> tuple[float | None, str]:
    """Release time (smoother's unit) from :func:`release_statistic`, and how it was found.

    ``trigger_index``: first frame after the trigger (0 without one). ``sling_end_index``:
    last valid frame of the sling angle when its track ends while the others go on, else
    None. With a track end the best jump within ``track_end_window`` frames before it
    (or just after the last sling frame if none stands out) is the release; otherwise the
    best jump over the shot if its statistic passes ``threshold``, else None.
    """
    n = ts.size
    g = settings.guard_frames
    if sling_end_index is not None:
        lo = max(trigger_index + g, sling_end_index - settings.track_end_window + 1)
        hi = min(sling_end_index + 2, n)
        if hi > lo:
            i = lo + int(np.argmax(stat[lo:hi]))
            if stat[i] >= 0.25 * settings.threshold:
                how = f"jump in acceleration at the end of the sling track (χ² {stat[i]:.0f})"
                return float(when[i]), how
        nxt = min(sling_end_index + 1, n - 1)
        return float(0.5 * (ts[sling_end_index] + ts[nxt])), "end of the sling track"
    lo, hi = trigger_index + g, n - g
    if hi <= lo:
        return None, "log too short after the trigger to look for a release"
    i = lo + int(np.argmax(stat[lo:hi]))
    if stat[i] < settings.threshold:
        return None, f"no jump in acceleration stands out (largest χ² {stat[i]:.0f})"
    return float(when[i]), f"jump in acceleration (χ² {stat[i]:.0f})"
