"""The band around the smoothed angles: the measurement noise's exact error covariance, the
share of the model's process noise the data show (a method-of-moments α shrunk toward the
smoothing residual's, :func:`shrunk_alpha`), and the smoothing's bias.
"""

from __future__ import annotations

import numpy as np

from trebuchet.ingest.kalman.batch import (
    FilterResult,
    SmootherResult,
    StepModel,
    error_covariance,
    residual_innovations,
    residual_quadratics,
    resmoothed,
    simulated_model_runs,
)
from trebuchet.ingest.kalman.kernel import compiled
from trebuchet.ingest.smoothing.problem import (
    SmoothingProblem,
    TuningState,
)

__all__ = ["residual_moments", "shrunk_alpha", "calibrated_band", "bias_band",
           "gaussian_window"]


#: Beyond this many steps of the kernel's half-width the window is a product of Fourier
#: transforms (its time then does not grow with the width).
FFT_RADIUS = 48


def gaussian_window(x: np.ndarray, sigma: float) -> np.ndarray:
    """``scipy.ndimage.gaussian_filter1d(x, sigma, axis=0, mode="constant")``: its kernel
    ``exp(−j²/2σ²)`` normalised, to ``int(4σ + 0.5)`` steps, zeros outside ``x``. Up to
    :data:`FFT_RADIUS` steps to the last bit (each output the centre term, then the
    symmetric pairs from the farthest in, as scipy's C loop adds them; compiled with the
    outputs in the inner loop); wider, through the FFT (to round-off, about 1e-16 of the
    largest value; exactly 0 where the kernel sees only zeros, as there): the bands'
    windows are a few of the smoother's time constants, 30–100 frames at 1000 fps and
    wider on a long quiet log, where the direct sum cost 2.6 s of a 60 s log."""
    sd = float(sigma)
    radius = int(4.0 * sd + 0.5)
    at = np.arange(-radius, radius + 1)
    w = np.exp(-0.5 / (sd * sd) * at**2)
    w = w / w.sum()
    flat = np.ascontiguousarray(np.asarray(x, dtype=float).reshape(len(x), -1))
    if radius <= FFT_RADIUS or not np.isfinite(flat).all():
        out = np.empty_like(flat)
        _symmetric_window(flat, np.ascontiguousarray(w[::-1]), out)
        return out.reshape(np.shape(x))
    from scipy.fft import irfft, next_fast_len, rfft

    n = flat.shape[0]
    size = next_fast_len(n + 2 * radius, real=True)
    out = irfft(rfft(flat, size, axis=0) * rfft(w, size)[:, None], size, axis=0)
    out = out[radius:radius + n]
    # exactly 0 where the window holds no nonzero input
    seen = np.concatenate([[0], np.cumsum(np.any(flat != 0.0, axis=1))])
    lo = np.clip(np.arange(n) - radius, 0, n)
    hi = np.clip(np.arange(n) + radius + 1, 0, n)
    out[seen[hi] == seen[lo]] = 0.0
    return np.ascontiguousarray(out).reshape(np.shape(x))


def _symmetric_window(x, w, out):  # noqa: ANN001, ANN201 - numba
    """``out[i] = x[i] w₀ + Σ_{d=r…1} (x[i−d] + x[i+d]) w_d`` along axis 0, zeros outside."""
    n, c = x.shape
    r = w.shape[0] // 2
    pad = np.zeros((n + 2 * r, c))
    pad[r:r + n] = x
    for i in range(n):
        for q in range(c):
            out[i, q] = x[i, q] * w[r]
    for d in range(r, 0, -1):
        wd = w[r + d]
        for i in range(n):
            for q in range(c):
                out[i, q] += (pad[i + r - d, q] + pad[i + r + d, q]) * wd


_symmetric_window = compiled(_symmetric_window)


def residual_moments(steps: StepModel, filt: FilterResult, Z: np.ndarray, valid: np.ndarray,
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
    # the draws' process noise: none for the first half, the model's for the second
    noise = np.vstack([np.zeros((1, n)), lam * r2[:, None]])
    kicks = np.where(drawn < half, kick[many], 0.0)
    meas = np.where(drawn < half, r2[many], 0.0)
    # the data's residual (rows 0 … A−1) and the draws' (below) in one batch
    res = np.empty((A + 2 * half, n))
    res[:A] = np.where(valid, Z - fitted, 0.0)
    z = simulated_model_runs(steps, noise, kicks, meas, prior[many] * (meas > 0)[:, None, None],
                             rng, src=np.where(drawn < half, 0, 1 + many), out=res[A:])
    z[~valid[many]] = 0.0
    zero = np.zeros((2 * half, steps.k))
    z -= resmoothed(steps, filt, z, valid, zero, src=many, states=1)[:, :, 0].T
    # ρ's quadratic forms, and those of the sum of each noise draw and its process-noise
    # draw (ρ is linear in the data)
    everyone = np.concatenate([np.arange(A), many])
    pairs = np.stack([A + np.arange(half), A + half + np.arange(half)], axis=1)
    innovations = residual_innovations(steps, filt, res, valid, everyone)
    del res, z
    quad, pair_quad = residual_quadratics(steps, filt, innovations, valid, everyone, pairs)
    del innovations
    lam_t = lam.T[:, None, :]  # (n, 1, A): the draws' series are (draw, angle)
    null = (quad[:, A:A + half].reshape(n, draws, A) * lam_t).mean(axis=1)
    slope = (quad[:, A + half:].reshape(n, draws, A) * lam_t).mean(axis=1)
    alt = pair_quad.reshape(n, draws, A) * lam_t
    return quad[:, :A] * lam.T, null, slope, alt


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


def calibrated_band(p: SmoothingProblem, fit: TuningState, xs: np.ndarray, Ps: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray]:
    """The band's covariance and its process-noise share α (A, n): the measurement noise's
    exact error covariance ``E0`` (``band_variance="noise"``), or ``E0 + α (P − E0)`` with α
    the share of the model's white noise the data show near each frame
    (``"calibrated"``; see :class:`SmoothSettings`)."""
    settings, steps, k, A, n, valid = p.settings, fit.steps, p.k, p.A, p.n, p.valid
    est, lam_use, sm, kick = fit.est, fit.lam_use, fit.sm, p.kick
    band_scale = np.ones((A, n))
    used = fit.filt if fit.filt.S.shape[1] == A else fit.filt.series(np.arange(A))
    own = SmootherResult(sm.x[:, :A], sm.P[:, :A], sm.r[:, :A], sm.N[:, :A])
    E0, R0 = error_covariance(steps, used, own, valid, np.array([e.r2 for e in est]),
                              np.zeros(A), kick, p.P0, parts=True)
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
    del lam_q, R0
    shrink = settings.band_alpha_from == "shrunk"
    if shrink:
        seen_r, base_r, slope_r, alt = residual_moments(
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
        num = gaussian_window(seen[:, a] - base[:, a], width)
        den = gaussian_window(slope[:, a], width)
        with np.errstate(invalid="ignore", divide="ignore"):
            alpha[a] = np.where(den > 0, np.maximum(num, 0.0) / den, 1.0)
        if shrink:
            # the residual's α and its sampling variance at α = 1 (the
            # windowed statistic's scatter over the draws of noise plus process)
            num = gaussian_window(seen_r[:, a] - base_r[:, a], width)
            den = gaussian_window(slope_r[:, a], width)
            sd = gaussian_window(alt[:, :, a], width).std(axis=1, ddof=1)
            good = (den > 0) & (sd > 0)
            with np.errstate(invalid="ignore", divide="ignore"):
                a_res[a] = np.where(good, num / den, 0.0)
                v_res[a] = np.where(good, (sd / den) ** 2, np.inf)
            ok = np.flatnonzero(valid[a])
            frames[a, ok[0]:ok[-1] + 1] = steps.Q0[ok[0]:ok[-1] + 1, 0, 0] > 0
    alpha = np.clip(alpha, 0.0, 1.0)
    if shrink:
        alpha = np.clip(shrunk_alpha(alpha, a_res, v_res, frames), 0.0, 1.0)
    band = Ps - E0  # E0 + α (P − E0), in one array
    band *= alpha.T[:, :, None, None]
    band += E0
    return band, alpha


def bias_band(p: SmoothingProblem, fit: TuningState, xs: np.ndarray, Ps: np.ndarray) -> np.ndarray:
    """``Ps`` plus ``b bᵀ``, the smoothing's bias ``b`` from the same smoother run again on
    its own output, ``bias_iterations`` terms of its series."""
    steps, valid = fit.steps, p.valid
    used = fit.filt if fit.filt.S.shape[1] == p.A else fit.filt.series(np.arange(p.A))

    def again(series: np.ndarray, prior: np.ndarray) -> np.ndarray:
        return resmoothed(steps, used, series, valid, prior)

    bias = again(xs[:, :, 0].T, p.x0) - xs
    step_bias = bias
    for _ in range(p.settings.bias_iterations - 1):
        # the next term of the bias's series: with x̂ = M x, (M − I) x =
        # Σ_j (I − M)^j (M − I) x̂, each term the last one less its own smoothing
        step_bias = step_bias - again(step_bias[:, :, 0].T, np.zeros_like(p.x0))
        bias = bias + step_bias
    return Ps + bias[..., :, None] * bias[..., None, :]
