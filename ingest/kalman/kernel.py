"""The Kalman filter's loop over the frames, compiled (numba).

:func:`~trebuchet.ingest.kalman.batch.batch_kalman_filter` runs many scalar series at once;
in numpy each frame costs a dozen small array operations whose overhead, on a 2 s log at
1000 fps, was about half of a reconstruction's time. Here the same predict-then-update
steps run as one compiled loop over frames and series (a few k × k products per step,
k = 3 or 4), the process noise of each step built where it is added (``λ Q0 + κ G``: no
array of it per step and series), the measurements of each series read from the row of
its angle (a grid of noise candidates shares one copy of the data) and, for a noise search,
the log-likelihood's sums accumulated on the way (no histories kept).

The compiled code is cached beside this file (or in numba's user cache); numba rebuilds it
when this file changes (it calls nothing from other files). Where no cache folder can be
written (a read-only installation and home), it is compiled anew in each process (about
2 s; set ``NUMBA_CACHE_DIR`` to a writable folder to keep it).
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["filter_steps", "noisy_steps", "compiled"]


def compiled(function, inline: bool = False):  # noqa: ANN001, ANN201 - numba
    """``function`` compiled with an on-disk cache, or without one where numba finds no
    writable cache folder; ``inline``: compiled into each compiled caller (a small helper
    of an inner loop: a call costs more than its few products)."""
    options = {"error_model": "numpy", **({"inline": "always"} if inline else {})}
    try:
        return numba.njit(cache=True, **options)(function)
    except RuntimeError:  # "cannot cache function ...: no locator available"
        return numba.njit(**options)(function)


def _rest_steps(first, src, valid, z, r2, x, P, S_hist, nu_hist, hist, weight, has_sums,
                sums, store, xps, Pps, gains):  # noqa: ANN001, ANN201 - numba
    """Steps ``0 .. first - 1``, a rest (only the first state uncertain and nothing moves
    it): the running weighted mean of the measurements, as the numpy form
    ``count = cumsum(v) − v``, ``p = 1/(1/p0 + count/r2)``, ``x = p (m0/p0 + total/r2)``
    (the same operations in the same order); ``x``, ``P`` then hold the state after it."""
    B, k = x.shape
    for b in range(B):
        s = src[b]
        p0 = P[b, 0, 0]
        m0 = x[b, 0]
        rb = r2[b]
        c_v = 0.0
        c_vz = 0.0
        p_pred = 0.0
        x_pred = 0.0
        v = 0.0
        zz = 0.0
        for i in range(first):
            v = 1.0 if valid[s, i] else 0.0
            zz = z[s, i] if valid[s, i] else 0.0
            vz = v * zz
            c_v = c_v + v
            c_vz = c_vz + vz
            count = c_v - v
            total = c_vz - vz
            p_pred = 1.0 / (1.0 / p0 + count / rb)
            x_pred = p_pred * (m0 / p0 + total / rb)
            S = p_pred + rb
            nu = v * (zz - x_pred)
            if hist:
                S_hist[i, b] = S
                nu_hist[i, b] = nu
            if has_sums:
                _add_loglik(weight[s, i], S, nu, sums, b)
            if store:
                for a in range(k):
                    xps[i, b, a] = 0.0
                    gains[i, b, a] = 0.0
                    for c in range(k):
                        Pps[i, b, a, c] = 0.0
                xps[i, b, 0] = x_pred
                Pps[i, b, 0, 0] = p_pred
                gains[i, b, 0] = p_pred * (v / S)
        p_end = 1.0 / (1.0 / p_pred + v / rb)
        for a in range(k):
            x[b, a] = 0.0
            for c in range(k):
                P[b, a, c] = 0.0
        x[b, 0] = p_end * (x_pred / p_pred + v * zz / rb)
        P[b, 0, 0] = p_end


def _add_loglik(w, S, nu, sums, b):  # noqa: ANN001, ANN201 - numba
    """``Σ w log S``, ``Σ w ν²/S``, ``Σ w`` of series ``b`` (NaN where ``S ≤ 0``)."""
    log_s = np.log(S) if S > 0.0 else np.nan
    sums[b, 0] += w * log_s
    sums[b, 1] += w * (nu * nu) / S
    sums[b, 2] += w


def _filter_steps(first, F, Q0, G, moves, has_noise, lam, shape, shape_src, kick, src, valid,
                  z, r2, x, P, hist, S_hist, nu_hist, weight, sums, store, xps, Pps, gains
                  ):  # noqa: ANN001, ANN201 - numba
    """The filter over all ``n`` steps, in place; steps ``0 .. first - 1`` are a rest
    (:func:`_rest_steps`).

    ``F``, ``Q0``, ``G`` (n, k, k) transitions, unit white noise and unit kick;
    ``moves``, ``has_noise`` (n,) bool: ``F`` is not the identity, the process noise is not
    zero; series ``b`` reads its measurements ``z`` (A, n) where ``valid`` (A, n) from row
    ``src[b]``, its process noise is ``lam[b] shape[shape_src[b], i] Q0[i] + kick[b] G[i]``
    (``shape`` (S, n), or (S, 1) for one λ for all steps), its measurement variance
    ``r2[b]``; ``x`` (B, k), ``P`` (B, k, k) the prior at frame 0 before the step-0
    prediction, updated to the end. Each step: ``x = F x``, ``P = F P Fᵀ + noise`` (where
    they apply), then with a measurement ``S = P₀₀ + r2``, ``K = P[:, 0] / S``, ``x += K ν``,
    ``P -= K P[0, :]`` (the simple form). ``hist``: writes ``S_hist``, ``nu_hist`` (n, B)
    (ν = 0 at a gap); ``sums`` (B, 3) not empty: accumulates ``Σ w log S``, ``Σ w ν²/S``,
    ``Σ w`` with ``w = weight[src[b], i]``; ``store``: the predicted ``xps`` (n, B, k),
    ``Pps`` (n, B, k, k) and the gains ``Pp[0, :] (v/S)`` (n, B, k), zero at gaps.
    """
    n = F.shape[0]
    B, k = x.shape
    has_sums = sums.shape[0] > 0
    per_step = shape.shape[1] > 1
    if first > 0:
        _rest_steps(first, src, valid, z, r2, x, P, S_hist, nu_hist, hist, weight, has_sums,
                    sums, store, xps, Pps, gains)
    xn = np.empty(k)
    T = np.empty((k, k))
    row = np.empty(k)
    for i in range(first, n):
        for b in range(B):
            s = src[b]
            if moves[i]:
                for a in range(k):
                    acc = 0.0
                    for m in range(k):
                        acc += F[i, a, m] * x[b, m]
                    xn[a] = acc
                for a in range(k):
                    x[b, a] = xn[a]
                for a in range(k):
                    for c in range(k):
                        acc = 0.0
                        for m in range(k):
                            acc += F[i, a, m] * P[b, m, c]
                        T[a, c] = acc
                for a in range(k):
                    for c in range(k):
                        acc = 0.0
                        for m in range(k):
                            acc += T[a, m] * F[i, c, m]
                        P[b, a, c] = acc
            if has_noise[i]:
                lv = lam[b] * shape[shape_src[b], i if per_step else 0]
                kv = kick[b]
                for a in range(k):
                    for c in range(k):
                        P[b, a, c] += lv * Q0[i, a, c] + kv * G[i, a, c]
            S = P[b, 0, 0] + r2[b]
            ok = valid[s, i]
            nu = 0.0
            if store:
                for a in range(k):
                    xps[i, b, a] = x[b, a]
                    for c in range(k):
                        Pps[i, b, a, c] = P[b, a, c]
                vs = (1.0 if ok else 0.0) / S
                for a in range(k):
                    gains[i, b, a] = P[b, 0, a] * vs
            if ok:
                nu = z[s, i] - x[b, 0]
                for c in range(k):
                    row[c] = P[b, 0, c]
                for a in range(k):
                    gain = row[a] / S
                    x[b, a] += gain * nu
                    for c in range(k):
                        P[b, a, c] -= gain * row[c]
            if hist:
                S_hist[i, b] = S
                nu_hist[i, b] = nu
            if has_sums:
                _add_loglik(weight[s, i], S, nu, sums, b)


def _noisy_steps(Q0, G, lam, shape, shape_src, kick):  # noqa: ANN001, ANN201 - numba
    """(n,) bool: the process noise ``lam[b] shape[shape_src[b], i] Q0[i] + kick[b] G[i]``
    (as :func:`_filter_steps` builds it) is not zero for some series at step ``i``."""
    n, k = Q0.shape[0], Q0.shape[1]
    B = lam.shape[0]
    per_step = shape.shape[1] > 1
    out = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        for b in range(B):
            lv = lam[b] * shape[shape_src[b], i if per_step else 0]
            kv = kick[b]
            for a in range(k):
                for c in range(k):
                    if lv * Q0[i, a, c] + kv * G[i, a, c] != 0.0:
                        out[i] = True
                        break
                if out[i]:
                    break
            if out[i]:
                break
    return out


_add_loglik = compiled(_add_loglik, inline=True)
_rest_steps = compiled(_rest_steps)
filter_steps = compiled(_filter_steps)
noisy_steps = compiled(_noisy_steps)
