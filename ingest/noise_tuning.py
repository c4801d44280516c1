"""Process and measurement noise of the angle smoother by maximum likelihood.

For a candidate ratio ``λ = q / r²`` the Kalman filter's innovations ``ν`` and their
variances ``S`` give the log-likelihood ``-½ Σ (log 2π S + ν²/S)``. Scaling all noise by
``ρ`` scales ``S`` by ``ρ``, so the measurement noise can be profiled out:
``ρ̂ = Σ (ν²/S) / N`` (Harvey 1989, *Forecasting, structural time series models and the
Kalman filter*, §3.4; the kicks at events are kept fixed, a small approximation).
All candidates and angles run in one batched filter
(:func:`~trebuchet.ingest.kalman_batch.batch_kalman_filter`); the maximum on a grid of
``log10 λ`` is refined by a parabola through the three best points.

NOTES ("Differentiating video angles"): the maximum-likelihood ``q`` with the cutoff
then lowered by 0.8 came within 2 % of the best ``q`` chosen knowing the truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .kalman_batch import StepModel, batch_kalman_filter


@dataclass(frozen=True)
class NoiseSearch:
    """Grid of :func:`maximum_likelihood_noise`.

    ``log10_step``: spacing of the ``log10 λ`` grid. ``min_cutoff_hz``: the slowest
    smoother considered (its bandwidth, about ``λ^(1/(2k))`` rad per frame).
    ``cutoff_factor``: the bandwidth used for the output relative to the
    maximum-likelihood one (``λ`` times ``cutoff_factor^(2k)``); 1 keeps the ML value.
    """

    log10_step: float = 0.5
    min_cutoff_hz: float = 0.3
    cutoff_factor: float = 0.8


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
) -> list[NoiseEstimate]:
    """Maximum-likelihood ``λ = q/r²`` and ``r²`` for each of ``A`` angles.

    ``z``, ``valid``, ``lik_weight`` (A, n); ``grid`` candidate ``λ``; ``r2_ref`` (A,) the
    reference measurement variance the filter runs with (a rough estimate, or the given
    one); ``kick`` (A,) event kick variances; ``x0``, ``P0`` (A, k), (A, k, k) priors;
    ``r2_given``/``q_given`` (A,) NaN where free (``q`` in smoother units). With both free
    ``r²`` is profiled out; with ``r`` given ``λ`` is searched with ``r`` fixed; with ``q``
    given the grid runs over ``r² = q/λ``.
    """
    A = z.shape[0]
    m = grid.size
    k = steps.k
    rep = np.repeat(np.arange(A), m)
    lam = np.tile(grid, A)
    filt = batch_kalman_filter(
        z[rep],
        valid[rep],
        steps,
        lam * r2_ref[rep],
        kick[rep],
        r2_ref[rep],
        x0[rep],
        P0[rep],
    )
    log_s, nu2_s, cnt = filt.loglik_sums(lik_weight[rep])
    log_s = log_s.reshape(A, m)
    nu2_s = nu2_s.reshape(A, m)
    cnt = cnt.reshape(A, m)
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
