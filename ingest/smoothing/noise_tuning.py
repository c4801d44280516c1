"""Process and measurement noise of the angle smoother by maximum likelihood.

For a candidate ratio ``λ = q / r²`` the Kalman filter's innovations ``ν`` and their
variances ``S`` give the log-likelihood ``-½ Σ (log 2π S + ν²/S)``. Scaling all noise by
``ρ`` scales ``S`` by ``ρ``, so the measurement noise can be profiled out:
``ρ̂ = Σ (ν²/S) / N`` (Harvey 1989, *Forecasting, structural time series models and the
Kalman filter*, §3.4; the kicks at events are kept fixed, a small approximation).
All candidates and angles run in one batched filter that keeps only the likelihood's sums
(:func:`~trebuchet.ingest.kalman.batch.filter_loglik`; the smoother of a chosen candidate
is run again on its own, :func:`grid_filter`); the maximum on a grid of
``log10 λ`` is refined by a parabola through the three best points.

docs/background.md ("Differentiating video angles"): the maximum-likelihood ``q`` with the cutoff
then lowered by 0.8 came within 2 % of the best ``q`` chosen knowing the truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trebuchet.ingest.kalman.batch import (
    FilterResult,
    StepModel,
    batch_kalman_filter,
    filter_loglik,
)


@dataclass(frozen=True)
class NoiseSearch:
    """Grid of :func:`maximum_likelihood_noise`.

    ``log10_step``: spacing of the ``log10 λ`` grid. ``min_cutoff_hz``: the slowest
    smoother considered (its bandwidth, about ``λ^(1/(2k))`` rad per frame).
    ``cutoff_factor``: the bandwidth used for the output relative to the
    maximum-likelihood one (``λ`` times ``cutoff_factor^(2k)``); 1 keeps the ML value.
    ``piece_decades``: half-width (decades of ``λ``) of the grid of :func:`piecewise_noise`
    around the single-``λ`` maximum; ``piece_prior_decades``: sd (decades) of the
    log-normal prior that keeps a piece's ``λ`` near that maximum (a short piece's
    likelihood is flat toward small ``λ``); ``piece_cutoff_factor``: as ``cutoff_factor``,
    for the pieces.
    """

    log10_step: float = 0.5
    min_cutoff_hz: float = 0.3
    cutoff_factor: float = 0.8
    piece_decades: float = 3.0
    piece_prior_decades: float = 1.0
    piece_cutoff_factor: float = 0.8


@dataclass(frozen=True)
class NoiseEstimate:
    """Result for one angle; smoother units (time in frames of ``tau`` s).

    ``lam_ml``: maximum-likelihood ``q/r²``; ``lam``: the one to use (after
    ``cutoff_factor``); ``r2``: measurement variance (rad²); ``loglik``: the maximum
    log-likelihood (without the excluded first innovations); ``at_edge``: the maximum
    lies on the edge of the grid.
    """

    lam_ml: float
    lam: float
    r2: float
    loglik: float
    at_edge: bool


def lambda_grid(k: int, tau: float, duration: float, settings: NoiseSearch) -> np.ndarray:
    """Candidate ``λ`` (smoother units) from the slowest cutoff to the Nyquist frequency.

    The smoother's bandwidth is roughly ``λ^(1/(2k))`` rad per frame, so
    ``λ = (2π f_c τ)^(2k)``: from ``f_c = max(min_cutoff_hz, 1/duration)`` to π/τ rad/s,
    widened by two grid steps at each end.
    """
    fc = max(settings.min_cutoff_hz, 1.0 / max(duration, tau))
    lo = 2 * k * np.log10(2 * np.pi * fc * tau) - 2 * settings.log10_step
    hi = 2 * k * np.log10(np.pi) + 2 * settings.log10_step
    m = int(np.ceil((hi - lo) / settings.log10_step)) + 1
    return 10.0 ** (lo + settings.log10_step * np.arange(m))


def _parabola_peak(x: np.ndarray, y: np.ndarray, j: int) -> tuple[float, float]:
    """Vertex of the parabola through (x, y)[j-1:j+2] (x equally spaced); (x, y) at j on edges."""
    if j <= 0 or j >= len(x) - 1:
        return float(x[j]), float(y[j])
    y0, y1, y2 = y[j - 1], y[j], y[j + 1]
    den = y0 - 2 * y1 + y2
    if not (np.isfinite(y0) and np.isfinite(y2) and den < 0):
        return float(x[j]), float(y1)
    h = x[1] - x[0]
    s = 0.5 * (y0 - y2) / den
    return float(x[j] + s * h), float(y1 - 0.25 * (y0 - y2) * s)


def maximum_likelihood_noise(
    z: np.ndarray,
    valid: np.ndarray,
    lik_weight: np.ndarray,
    steps: StepModel,
    grid: np.ndarray,
    r2_ref: np.ndarray,
    kick: np.ndarray,
    x0: np.ndarray,
    P0: np.ndarray,
    r2_given: np.ndarray,
    q_given: np.ndarray,
    settings: NoiseSearch = NoiseSearch(),
    shape: np.ndarray | None = None,
) -> list[NoiseEstimate]:
    """Maximum-likelihood ``λ = q/r²`` and ``r²`` for each of ``A`` angles.

    ``z``, ``valid``, ``lik_weight`` (A, n); ``grid`` candidate ``λ``; ``r2_ref`` (A,) the
    reference measurement variance the filter runs with (a rough estimate, or the given
    one); ``kick`` (A,) event kick variances; ``x0``, ``P0`` (A, k), (A, k, k) priors;
    ``r2_given``/``q_given`` (A,) NaN where free (``q`` in smoother units). With both free
    ``r²`` is profiled out; with ``r`` given ``λ`` is searched with ``r`` fixed; with ``q``
    given the grid runs over ``r² = q/λ``. ``shape`` (A, n): the process noise of each
    step relative to ``λ`` (default 1 everywhere; :func:`jerk_noise_shape`), so that
    ``λ`` is then the scale of that profile. The filter of angle ``a`` at ``grid[j]``
    (run with ``r2_ref``) is :func:`grid_filter` ``(…, grid[j] * r2_ref[a], …)``.
    """
    A = z.shape[0]
    m = grid.size
    k = steps.k
    rep = np.repeat(np.arange(A), m)
    sums = filter_loglik(z, valid, lik_weight, steps, np.tile(grid, A) * r2_ref[rep],
                         kick[rep], r2_ref[rep], x0[rep], P0[rep], src=rep, shape=shape)
    log_s = sums.log_s.reshape(A, m)
    nu2_s = sums.nu2_s.reshape(A, m)
    cnt = sums.count.reshape(A, m)
    out = []
    x = np.log10(grid)
    for a in range(A):
        N = cnt[a, 0]
        if np.isfinite(r2_given[a]):
            rho = np.full(m, r2_given[a] / r2_ref[a])
        elif np.isfinite(q_given[a]):
            rho = q_given[a] / (grid * r2_ref[a])
        else:
            rho = nu2_s[a] / N
        rho = np.where(np.isfinite(rho) & (rho > 0), rho, np.nan)
        with np.errstate(invalid="ignore"):
            ll = -0.5 * (N * np.log(2 * np.pi * rho) + log_s[a] + nu2_s[a] / rho)
        ll = np.where(np.isfinite(ll), ll, -np.inf)
        j = int(np.argmax(ll))
        x_best, ll_best = _parabola_peak(x, ll, j)
        lrho = np.log(np.where(np.isfinite(rho), rho, 1.0) * r2_ref[a])
        r2 = float(np.exp(np.interp(x_best, x, lrho))) if m > 1 else float(np.exp(lrho[0]))
        if np.isfinite(r2_given[a]):
            r2 = float(r2_given[a])
        lam_ml = 10.0**x_best
        if np.isfinite(q_given[a]):
            r2 = float(q_given[a] / lam_ml)
        lam_use = lam_ml * settings.cutoff_factor ** (2 * k)
        if np.isfinite(q_given[a]):
            lam_use = lam_ml
        out.append(NoiseEstimate(lam_ml, lam_use, r2, ll_best, j in (0, m - 1)))
    return out


def grid_filter(z: np.ndarray, valid: np.ndarray, steps: StepModel, lam: np.ndarray,
                r2: np.ndarray, kick: np.ndarray, x0: np.ndarray, P0: np.ndarray,
                shape: np.ndarray | None = None) -> FilterResult:
    """The filter of candidates chosen from a search of :func:`maximum_likelihood_noise`
    with the histories a smoother needs, one per angle of ``z`` (A, n): ``lam`` (A,) each
    one's ``q/r²`` times the variance ``r2`` (A,) it ran with (the search's
    ``grid[j] * r2_ref[a]``, the same product: the same filter to the last bit), its
    ``shape`` (A, n) if any; ``kick``, ``x0``, ``P0`` per angle."""
    return batch_kalman_filter(z, valid, steps, lam, kick, r2, x0, P0, store=True, shape=shape)


@dataclass(frozen=True)
class PiecewiseNoise:
    """Result of :func:`piecewise_noise` for ``A`` angles and ``P`` pieces (smoother units).

    ``lam_ml`` (A, P) maximum-likelihood ``q/r²`` per piece, ``lam`` (A, P) the ones to use
    (after ``cutoff_factor``), ``loglik`` (A,) the summed maximum log-likelihoods,
    ``at_edge`` (A, P) maxima on the edge of the local grid.
    """

    lam_ml: np.ndarray
    lam: np.ndarray
    loglik: np.ndarray
    at_edge: np.ndarray


def piecewise_noise(
    z: np.ndarray,
    valid: np.ndarray,
    lik_weight: np.ndarray,
    steps: StepModel,
    bounds: np.ndarray,
    lam_start: np.ndarray,
    r2: np.ndarray,
    kick: np.ndarray,
    x0: np.ndarray,
    P0: np.ndarray,
    settings: NoiseSearch = NoiseSearch(),
    max_decades: np.ndarray | None = None,
) -> PiecewiseNoise:
    """``λ = q/r²`` chosen piece by piece: the process noise may differ between stretches
    of the log (the trough, the swing, the flight after release), ``r²`` stays fixed.

    ``bounds`` (P+1,) frame indices ``0 = b0 < b1 < … < bP = n``; piece ``p`` holds the
    steps ``b_p .. b_{p+1}-1``. Going forward, each piece's ``λ`` maximises the likelihood
    of that piece's innovations with the earlier pieces at their chosen ``λ`` (a sequential,
    causal maximum: the filter before a piece does not depend on its ``λ``). The grid runs
    ``±settings.piece_decades`` around ``lam_start`` (A,) (the single-``λ`` maximum); one
    batched pass per piece, so the whole search costs one pass over the log. The state
    carried into the next piece is that of the best grid point; the value used is the
    parabola through the three best. ``r2`` (A,) measurement variance; ``kick``, ``x0``,
    ``P0`` as for :func:`maximum_likelihood_noise`. ``max_decades`` (P,): per piece, the
    highest ``λ`` allowed, in decades above ``lam_start`` (``inf``: the grid's end).
    """
    A = z.shape[0]
    k = steps.k
    half = int(np.ceil(settings.piece_decades / settings.log10_step))
    offsets = settings.log10_step * np.arange(-half, half + 1)
    m = offsets.size
    rep = np.repeat(np.arange(A), m)
    lam_grid = np.repeat(np.asarray(lam_start, float), m) * np.tile(10.0**offsets, A)
    x = np.asarray(x0, float)[rep]
    P = np.asarray(P0, float)[rep]
    P_count = len(bounds) - 1
    lam_ml = np.empty((A, P_count))
    ll_sum = np.zeros(A)
    edge = np.zeros((A, P_count), bool)
    for p in range(P_count):
        lo, hi = int(bounds[p]), int(bounds[p + 1])
        filt = filter_loglik(z[:, lo:hi], valid[:, lo:hi], lik_weight[:, lo:hi],
                             steps.stretch(lo, hi), lam_grid * r2[rep], kick[rep], r2[rep], x,
                             P, src=rep)
        ll = -0.5 * (filt.log_s + filt.nu2_s).reshape(A, m)
        ll = ll - 0.5 * (offsets / settings.piece_prior_decades) ** 2
        if max_decades is not None:
            ll = np.where(offsets > max_decades[p] + 1e-9, -np.inf, ll)
        ll = np.where(np.isfinite(ll), ll, -np.inf)
        best = np.argmax(ll, axis=1)
        for a in range(A):
            xb, lb = _parabola_peak(offsets, ll[a], int(best[a]))
            lam_ml[a, p] = lam_start[a] * 10.0**xb
            ll_sum[a] += lb
            edge[a, p] = best[a] in (0, m - 1)
        pick = np.arange(A) * m + best
        x = np.repeat(filt.x_end[pick], m, axis=0)
        P = np.repeat(filt.P_end[pick], m, axis=0)
    lam_use = lam_ml * settings.piece_cutoff_factor ** (2 * k)
    return PiecewiseNoise(lam_ml, lam_use, ll_sum, edge)


def windowed_noise(est: np.ndarray, weight: np.ndarray, half_width: np.ndarray,
                   floor: np.ndarray, linear: bool = False) -> np.ndarray:
    """Local process noise (B, n): the per-step estimates ``est`` (B, n) averaged with
    weights ``weight`` (B, n) over a Gaussian window of sd ``half_width`` (B,) steps, and
    not below ``floor`` (B,). Where the window holds no weight, the floor. With ``linear``
    a local-linear fit instead of the local mean (Fan & Gijbels 1996, §3.2.5: the same in
    the interior of evenly weighted steps, but free of the one-sided window's bias at a
    track's ends and at gaps: a trend rising to the end is followed, not averaged down);
    where the window cannot fix a slope (one weighted step), the local mean."""
    B, n = est.shape
    out = np.empty_like(est)
    for b in range(B):
        h = max(float(half_width[b]), 1.0)
        span = min(int(np.ceil(4 * h)), (n - 1) // 2)
        kern = np.exp(-0.5 * (np.arange(-span, span + 1) / h) ** 2)
        num = np.convolve(est[b] * weight[b], kern, mode="same")
        den = np.convolve(weight[b], kern, mode="same")
        with np.errstate(invalid="ignore", divide="ignore"):
            local = np.where(den > 1e-9, num / den, floor[b])
        if linear:
            off = np.arange(-span, span + 1, dtype=float)
            k1, k2 = -off * kern, off**2 * kern
            s1 = np.convolve(weight[b], k1, mode="same")
            s2 = np.convolve(weight[b], k2, mode="same")
            t1 = np.convolve(est[b] * weight[b], k1, mode="same")
            det = den * s2 - s1**2
            with np.errstate(invalid="ignore", divide="ignore"):
                lin = (s2 * num - s1 * t1) / det
            ok = (den > 1e-9) & (det > 1e-9 * np.maximum(den * s2, 1e-300)) & np.isfinite(lin)
            local = np.where(ok, lin, local)
        out[b] = np.maximum(local, floor[b])
    return out


def jerk_noise_shape(acc: np.ndarray, ts: np.ndarray, weight: np.ndarray,
                     half_width: np.ndarray, floor: float, linear: bool = False) -> np.ndarray:
    """Relative process noise per angle and step (A, n), mean 1 over the weighted steps.

    The white-jerk model's density ``q`` is the variance rate of the jerk; where the motion
    is slow (the trough) its jerk is near zero, in the swing it is large. The local
    ``q`` is taken proportional to the squared jerk ``(Δa/Δt)²`` of a first smoothed
    acceleration ``acc`` (A, n) (smoother units; ``ts`` (n,) frame times; for the
    constant-jerk model too: its squared snap gave larger errors and narrower bands on
    ``bench/ingest_trade.py``), averaged over a
    Gaussian window of sd ``half_width`` (A,) steps (:func:`windowed_noise`) over the steps
    with ``weight`` (A, n) > 0 (steps with process noise and no event kick, inside the
    angle's track: outside it the smoother extrapolates with no jerk at all), and not
    below ``floor`` times its mean; ``linear``: the window's local-linear fit
    (:func:`windowed_noise`). The scale is left to maximum likelihood
    (:func:`maximum_likelihood_noise` with ``shape``).
    """
    A, n = acc.shape
    dt = np.diff(ts)
    jerk2 = np.zeros((A, n))
    jerk2[:, 1:] = (np.diff(acc, axis=1) / np.maximum(dt, 1e-12)) ** 2
    local = windowed_noise(jerk2, weight, half_width, np.zeros(A), linear)
    w = weight + 1e-300
    level = np.array([np.average(local[a], weights=w[a]) for a in range(A)])
    level = np.where(level > 0, level, 1.0)
    return np.maximum(local / level[:, None], floor)


def track_end_common_noise(shape: np.ndarray, weight: np.ndarray, ends: np.ndarray,
                           last: int, span: np.ndarray) -> np.ndarray:
    """Local noise shapes (B, n) of angles of one mechanism with, at the end of a track that
    stops while others go on, the angles' common shape where it is larger.

    An angle's own first smoothing cannot show a change of its jerk in the last frames of
    its track: there it is a one-sided estimate that lags, and nothing after the end pulls
    it along (the sling's track ends at the release, just as the sling whips round). The
    angles are degrees of freedom of one mechanism, coupled through its mass matrix, so a
    fast change shows in the jerk of the angles whose tracks go on. Over the last ``span``
    (B,) steps up to ``ends`` (B,) (an angle's last valid step), for a track ending at
    least three steps before ``last`` (the last valid step of any angle), the shape is the
    larger of its own and the mean of all angles' shapes that have ``weight`` > 0 at that
    step (each of mean 1 over its own weighted steps, as :func:`jerk_noise_shape` gives
    them). Other tracks and steps are unchanged."""
    B, n = shape.shape
    out = shape.copy()
    if B < 2:
        return out
    on = weight > 0
    count = on.sum(axis=0)
    common = np.where(count > 0, (shape * on).sum(axis=0) / np.maximum(count, 1), 0.0)
    for b in range(B):
        end = int(ends[b])
        if last - end < 3 or not span[b] > 0:
            continue
        lo = max(int(np.floor(end - span[b])), 0)
        out[b, lo:end + 1] = np.maximum(out[b, lo:end + 1], common[lo:end + 1])
    return out
