"""Find the trigger and the release of a shot in video-tracked angles.

- Trigger: the first motion after rest. The angles are at rest, then the acceleration
  jumps from zero (the rate stays continuous). Fitted by least squares of
  ``z = z0`` before ``t0`` and ``z0 + a u²/2 + j u³/6`` (``u = t - t0``) after it, over
  the start of the motion, jointly for all tracked angles (each weighted by its noise),
  profiled over ``t0`` on a frame grid, then to a tenth of a frame.
- Release: the acceleration of the angles jumps (the sling tension vanishes), and the
  sling's track often ends. Found as the largest likelihood-ratio statistic of a jump in
  acceleration, from the backward smoothing recursion (de Jong 1989; Durbin & Koopman
  2012 §7.5: auxiliary residuals / intervention tests), see
  :func:`~trebuchet.ingest.kalman_batch.backward_smoother`.

Lift-off needs forces and is found elsewhere. All times in the log's own time (s).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .kalman_batch import polynomial_transition


@dataclass(frozen=True)
class TriggerSearch:
    """Settings of :func:`detect_trigger`.

    ``noise_multiple``: the fit window ends where an angle has left its rest value by this
    many noise sd, but at least ``min_excursion_fraction`` and at most
    ``max_excursion_fraction`` of its whole excursion and never less than
    ``min_noise_multiple`` sd, for ``persist_samples`` valid samples in a row.
    ``min_rest_frames``: fewer rest
    frames than this before the fitted onset means the log starts in motion (no trigger).
    """

    noise_multiple: float = 50.0
    min_noise_multiple: float = 6.0
    persist_samples: int = 5
    min_excursion_fraction: float = 0.01
    max_excursion_fraction: float = 0.2
    min_signal_to_noise: float = 20.0
    min_rest_frames: int = 3
    subframe_steps: int = 10


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


def _onset_sse(
    t: np.ndarray, Z: np.ndarray, weights: np.ndarray, t0: np.ndarray
) -> np.ndarray:
    """Weighted residual sum of squares of the rest-then-cubic fit for each onset ``t0``.

    ``Z`` (A, m) with NaN gaps, ``weights`` (A,) = 1/sd², ``t0`` (C,). Returns (C,).
    """
    total = np.zeros(t0.size)
    u = np.maximum(t[None, :] - t0[:, None], 0.0)  # (C, m)
    X = np.stack([np.ones_like(u), u**2 / 2.0, u**3 / 6.0], axis=-1)  # (C, m, 3)
    for z, wgt in zip(Z, weights, strict=True):
        ok = np.isfinite(z)
        Xa = X[:, ok, :]
        y = z[ok] - np.median(z[ok][:5])
        XtX = np.einsum("cmi,cmj->cij", Xa, Xa)
        Xty = np.einsum("cmi,m->ci", Xa, y)
        XtX = XtX + 1e-12 * np.trace(XtX, axis1=1, axis2=2)[:, None, None] * np.eye(3)
        beta = np.linalg.solve(XtX, Xty[..., None])[..., 0]
        sse = y @ y - np.einsum("ci,ci->c", beta, Xty)
        total += wgt * sse
    return total


def detect_trigger(
    t: np.ndarray,
    Z: np.ndarray,
    sd: np.ndarray,
    settings: TriggerSearch = TriggerSearch(),
) -> float | None:
    """Time (s, the log's time) at which the angles leave rest, or None.

    ``t`` (n,) increasing, ``Z`` (A, n) angles (rad) with NaN gaps, ``sd`` (A,) their noise
    sd (rad), e.g. from :func:`robust_noise_sd`. None when no angle moves clearly
    (excursion below ``min_signal_to_noise`` sd) or the log starts in motion (fewer than
    ``min_rest_frames`` frames before the fitted onset). The onset is resolved to
    ``1/subframe_steps`` of a frame; its accuracy is about a frame at 0.1–2° noise.
    """
    n = t.size
    ends = []
    use = []
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
        ends.append(ok[np.argmax(persistent)])
        use.append(a)
    if not use:
        return None
    end = int(max(ends))
    if end < settings.min_rest_frames:
        return None
    tw = t[: end + 1]
    wgt = 1.0 / np.asarray(sd)[use] ** 2

    def sse(t0: np.ndarray) -> np.ndarray:
        total = np.zeros(t0.size)
        for a, e, w in zip(use, ends, wgt, strict=True):
            total += _onset_sse(t[: e + 1], Z[a : a + 1, : e + 1], np.array([w]), t0)
        return total

    stride = max(1, (tw.size - 1) // 100)  # at most ~100 coarse candidates
    coarse_idx = np.arange(0, tw.size - 1, stride)
    best = int(coarse_idx[np.argmin(sse(tw[coarse_idx]))])
    dt = np.median(np.diff(t)) if n > 1 else 1.0
    lo = tw[max(best - stride, 0)]
    hi = tw[min(best + stride, tw.size - 1)]
    fine = np.linspace(lo, hi, int(2 * stride * settings.subframe_steps) + 1)
    sse_f = sse(fine)
    t0 = float(fine[np.argmin(sse_f)])
    first_valid = min(np.flatnonzero(np.isfinite(z))[0] for z in Z[use])
    if t0 - t[first_valid] < (settings.min_rest_frames - 0.5) * dt:
        return None
    return t0


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
    from :func:`~trebuchet.ingest.kalman_batch.backward_smoother` (one series per angle).
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
