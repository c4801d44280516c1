"""Choosing or averaging the smoother's models per angle by their likelihood.

:func:`~trebuchet.ingest.smoothing.smooth.smooth` offers two state-space models of an angle:
constant acceleration (``"ca"``, white jerk) and constant jerk (``"cj"``, white snap). Each has one
process-noise density (its shape frame by frame from the local jerk, its scale by maximum
likelihood) and one measurement noise, so with equal parameter counts their maximised
innovation log-likelihoods ``ℓ_ca``, ``ℓ_cj`` compare directly (Akaike 1974), up to the jumps at the
events: both models let the acceleration jump at the trigger and the release, ``cj`` its
jerk as well, each a wide Gaussian "kick" of variance ``κ``, whose marginal likelihood
falls as ``−½ log κ`` per jump, an arbitrary amount (a decade of the jerk kick's sd moved
``ℓ_cj − ℓ_ca`` by 4.6 nats, as much as the models differ). So the jumps are taken as
parameters: ``ℓ`` profiled over them (:func:`jump_profile`, exact for the linear Gaussian
model) and AIC's penalty of one per jump the data determine (its effective count, between
0 for a jump after the track's end and 1). The criterion is ``ℓ_prof − p_eff``; from it,
per angle:

- ``select``: the model with the larger ``ℓ``;
- ``average``: Bayesian model averaging (Hoeting, Madigan, Raftery & Volinsky 1999) with
  equal prior weights: ``w_m = exp(ℓ_m) / Σ exp(ℓ)``, the mixture's mean
  ``x̄ = Σ w_m x_m`` and covariance ``P̄ = Σ w_m (P_m + (x_m − x̄)(x_m − x̄)ᵀ)``
  (the spread between the models widens the band where they disagree).

Only the angle, its rate and acceleration (the first three states, the ones the loads use)
are combined; the covariance is 3×3 for every angle.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from trebuchet.ingest.smoothing.result import smoothing_of, with_smoothing

COMBINATIONS: tuple[str, ...] = ("select", "average")


def likelihood_weights(loglik: Sequence[float], how: str) -> np.ndarray:
    """Weights of the models with maximised log-likelihoods ``loglik`` (nats).

    ``how="select"``: 1 for the largest (the first on a tie), 0 for the others;
    ``"average"``: ``exp(ℓ_m − max ℓ)`` normalised (Akaike weights). A non-finite ``ℓ``
    gets weight 0; all non-finite: all weight on the first.
    """
    ll = np.asarray(loglik, dtype=float)
    w = np.zeros(ll.size)
    ok = np.isfinite(ll)
    if not ok.any():
        w[0] = 1.0
        return w
    if how == "select":
        w[int(np.argmax(np.where(ok, ll, -np.inf)))] = 1.0
        return w
    if how != "average":
        raise ValueError(f"how must be one of {COMBINATIONS}, not {how!r}")
    w[ok] = np.exp(ll[ok] - ll[ok].max())
    return w / w.sum()


def jump_profile(G: np.ndarray, kick: np.ndarray, r: np.ndarray, N: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Log-likelihood gain (nats) of profiling over the event jumps, and their effective count.

    ``G`` (n, k, k): unit covariance of the jump at each step (zero where none), ``kick``
    (A,) its variance ``κ`` per series, ``r`` (n, A, k) and ``N`` (n, A, k, k) the
    smoother's backward quantities (:class:`~trebuchet.ingest.kalman.batch.SmootherResult`).
    With ``G = D Dᵀ`` (``m`` columns) the jump is ``D β``, ``β ~ N(0, κ I)``; with
    ``M = Dᵀ N D`` the posterior covariance of ``β`` is ``V = κ I − κ² M`` and its data
    information ``J = V⁻¹ − I/κ``. For a linear Gaussian model the marginal and the
    profile likelihood over ``β`` differ exactly by
    ``ℓ_prof − ℓ_marg = ½ log det(I + κ J) + ½ β̂ᵀ (κ I + J⁻¹)⁻¹ β̂``, which is
    ``½ (m log κ − log det V) + ½ rᵀD M⁺ Dᵀr`` (as ``(κ I + J⁻¹)⁻¹ = M`` and
    ``β̂ = M⁻¹ Dᵀr``; the last term is the jump's likelihood-ratio statistic); the
    effective number of parameters (Hastie & Tibshirani 1990) is ``tr(κ J (I + κ J)⁻¹) = tr(κ M)``.
    Returns both summed over the jumps, (A,) each.
    """
    A = kick.size
    gain = np.zeros(A)
    count = np.zeros(A)
    for i in np.flatnonzero(np.any(G != 0.0, axis=(1, 2))):
        w, U = np.linalg.eigh(G[i])
        keep = w > 1e-12 * w.max()
        D = U[:, keep] * np.sqrt(w[keep])
        m = D.shape[1]
        for a in range(A):
            kap = float(kick[a])
            M = D.T @ N[i, a] @ D
            V = kap * np.eye(m) - kap**2 * M
            sign, logdet = np.linalg.slogdet(V)
            if sign <= 0 or not np.all(np.isfinite(M)):
                continue
            u = D.T @ r[i, a]
            gain[a] += 0.5 * (m * np.log(kap) - logdet + float(u @ np.linalg.pinv(M) @ u))
            count[a] += kap * float(np.trace(M))
    return gain, count


def mixture_moments(means: Sequence[np.ndarray], covs: Sequence[np.ndarray],
                    weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean (n, d) and covariance (n, d, d) of the mixture of Gaussians with ``means``
    (each (n, d)), ``covs`` (each (n, d, d)) and ``weights`` (summing to 1):
    ``x̄ = Σ w x``, ``P̄ = Σ w (P + (x − x̄)(x − x̄)ᵀ)``. Models of weight 0 are left out
    (their NaN, e.g. outside a track, do not spread)."""
    use = [i for i, w in enumerate(weights) if w > 0]
    mean = sum(weights[i] * means[i] for i in use)
    cov = sum(weights[i] * (covs[i] + np.einsum("ni,nj->nij", means[i] - mean,
                                                 means[i] - mean)) for i in use)
    return mean, cov


def criterion(noise: Mapping[str, float]) -> float:
    """``ℓ_prof − p_eff`` of one angle's ``noise`` entry (of the
    :class:`~trebuchet.ingest.smoothing.result.Smoothing` of
    :func:`~trebuchet.ingest.smoothing.smooth.smooth`): the maximised log-likelihood with the event
    jumps profiled out, less their effective count (AIC / 2, up to the sign)."""
    return float(noise["loglik"] + noise.get("jump_gain", 0.0) - noise.get("jump_count", 0.0))


def combined_smoothing(ests: Mapping[str, pd.DataFrame], angles: Sequence[str],
                       suffixes: Sequence[str], how: str) -> pd.DataFrame:
    """The output of :func:`~trebuchet.ingest.smoothing.smooth.smooth` combined per angle from the
    runs ``ests`` (model name -> its output, same log and events) by the criterion
    ``noise[angle]["loglik"] + ["jump_gain"] − ["jump_count"]`` (the jumps
    profiled out, AIC's penalty for them; see the module doc).

    Columns ``X``, ``X_d``, ``X_dd`` and their ``_sd`` are the mixture's; its
    ``Smoothing`` is the first run's with ``cov`` the mixture's 3×3, ``noise`` per angle that of the
    heaviest model (with its ``"model"``), ``model_weights`` ({angle: {model: w}}),
    ``model`` = ``how`` and ``loglik`` the sum over angles of the mixture's criterion
    ``log Σ_m exp(c_m) / M`` (``select``: of the chosen model's).
    """
    names = list(ests)
    fits = {m: smoothing_of(e) for m, e in ests.items()}
    first = ests[names[0]]
    out = first.copy()
    cov: dict[str, np.ndarray] = {}
    noise: dict[str, dict] = {}
    weights: dict[str, dict[str, float]] = {}
    total = 0.0
    for angle in angles:
        if angle not in fits[names[0]].cov:
            continue
        ll = [criterion(fits[m].noise[angle]) for m in names]
        w = likelihood_weights(ll, how)
        means = [np.stack([ests[m][angle + s].to_numpy(dtype=float) for s in suffixes], 1)
                 for m in names]
        covs = [np.asarray(fits[m].cov[angle], float)[:, :3, :3] for m in names]
        mean, P = mixture_moments(means, covs, w)
        for j, s in enumerate(suffixes):
            out[angle + s] = mean[:, j]
            out[angle + s + "_sd"] = np.sqrt(np.maximum(np.diagonal(P, axis1=1, axis2=2)[:, j],
                                                        0.0))
        cov[angle] = P
        best = names[int(np.argmax(w))]
        noise[angle] = {**fits[best].noise[angle], "model": best}
        weights[angle] = {m: float(wm) for m, wm in zip(names, w, strict=True)}
        finite = np.asarray(ll, float)[np.isfinite(ll)]
        if finite.size:
            top = finite.max()
            total += (float(ll[int(np.argmax(w))]) if how == "select"
                      else float(top + np.log(np.mean(np.exp(finite - top)))))
    return with_smoothing(out, fits[names[0]].replace(
        cov=cov, noise=noise, model_weights=weights, model=how, loglik=total))
