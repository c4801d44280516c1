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
    if k == 3:
        _filter3(first, F, Q0, G, moves, has_noise, lam, shape, shape_src, kick, src, valid,
                 z, r2, x, P, hist, S_hist, nu_hist, weight, sums, store, xps, Pps, gains)
        return
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


def _filter3(first, F, Q0, G, moves, has_noise, lam, shape, shape_src, kick, src, valid, z,
             r2, x, P, hist, S_hist, nu_hist, weight, sums, store, xps, Pps, gains
             ):  # noqa: ANN001, ANN201, C901 - numba
    """:func:`_filter_steps` for ``k = 3`` (the constant-acceleration model), steps ``first``
    on: each series' state and covariance in scalars through all its steps (four times
    faster), every product summed in the same order from 0.0 as the general loop (the
    same results to the last bit)."""
    n = F.shape[0]
    has_sums = sums.shape[0] > 0
    per_step = shape.shape[1] > 1
    for b in range(x.shape[0]):
        s = src[b]
        x0, x1, x2 = x[b, 0], x[b, 1], x[b, 2]
        p00, p01, p02 = P[b, 0, 0], P[b, 0, 1], P[b, 0, 2]
        p10, p11, p12 = P[b, 1, 0], P[b, 1, 1], P[b, 1, 2]
        p20, p21, p22 = P[b, 2, 0], P[b, 2, 1], P[b, 2, 2]
        lb, kv, rb, row = lam[b], kick[b], r2[b], shape_src[b]
        for i in range(first, n):
            if moves[i]:
                f00, f01, f02 = F[i, 0, 0], F[i, 0, 1], F[i, 0, 2]
                f10, f11, f12 = F[i, 1, 0], F[i, 1, 1], F[i, 1, 2]
                f20, f21, f22 = F[i, 2, 0], F[i, 2, 1], F[i, 2, 2]
                x0, x1, x2 = (0.0 + f00 * x0 + f01 * x1 + f02 * x2,
                              0.0 + f10 * x0 + f11 * x1 + f12 * x2,
                              0.0 + f20 * x0 + f21 * x1 + f22 * x2)
                t00 = 0.0 + f00 * p00 + f01 * p10 + f02 * p20
                t01 = 0.0 + f00 * p01 + f01 * p11 + f02 * p21
                t02 = 0.0 + f00 * p02 + f01 * p12 + f02 * p22
                t10 = 0.0 + f10 * p00 + f11 * p10 + f12 * p20
                t11 = 0.0 + f10 * p01 + f11 * p11 + f12 * p21
                t12 = 0.0 + f10 * p02 + f11 * p12 + f12 * p22
                t20 = 0.0 + f20 * p00 + f21 * p10 + f22 * p20
                t21 = 0.0 + f20 * p01 + f21 * p11 + f22 * p21
                t22 = 0.0 + f20 * p02 + f21 * p12 + f22 * p22
                p00 = 0.0 + t00 * f00 + t01 * f01 + t02 * f02
                p01 = 0.0 + t00 * f10 + t01 * f11 + t02 * f12
                p02 = 0.0 + t00 * f20 + t01 * f21 + t02 * f22
                p10 = 0.0 + t10 * f00 + t11 * f01 + t12 * f02
                p11 = 0.0 + t10 * f10 + t11 * f11 + t12 * f12
                p12 = 0.0 + t10 * f20 + t11 * f21 + t12 * f22
                p20 = 0.0 + t20 * f00 + t21 * f01 + t22 * f02
                p21 = 0.0 + t20 * f10 + t21 * f11 + t22 * f12
                p22 = 0.0 + t20 * f20 + t21 * f21 + t22 * f22
            if has_noise[i]:
                lv = lb * shape[row, i if per_step else 0]
                p00 += lv * Q0[i, 0, 0] + kv * G[i, 0, 0]
                p01 += lv * Q0[i, 0, 1] + kv * G[i, 0, 1]
                p02 += lv * Q0[i, 0, 2] + kv * G[i, 0, 2]
                p10 += lv * Q0[i, 1, 0] + kv * G[i, 1, 0]
                p11 += lv * Q0[i, 1, 1] + kv * G[i, 1, 1]
                p12 += lv * Q0[i, 1, 2] + kv * G[i, 1, 2]
                p20 += lv * Q0[i, 2, 0] + kv * G[i, 2, 0]
                p21 += lv * Q0[i, 2, 1] + kv * G[i, 2, 1]
                p22 += lv * Q0[i, 2, 2] + kv * G[i, 2, 2]
            S = p00 + rb
            ok = valid[s, i]
            nu = 0.0
            if store:
                xps[i, b, 0], xps[i, b, 1], xps[i, b, 2] = x0, x1, x2
                Pps[i, b, 0, 0], Pps[i, b, 0, 1], Pps[i, b, 0, 2] = p00, p01, p02
                Pps[i, b, 1, 0], Pps[i, b, 1, 1], Pps[i, b, 1, 2] = p10, p11, p12
                Pps[i, b, 2, 0], Pps[i, b, 2, 1], Pps[i, b, 2, 2] = p20, p21, p22
                vs = (1.0 if ok else 0.0) / S
                gains[i, b, 0], gains[i, b, 1], gains[i, b, 2] = p00 * vs, p01 * vs, p02 * vs
            if ok:
                nu = z[s, i] - x0
                r0, r1, r2_ = p00, p01, p02
                g0, g1, g2 = r0 / S, r1 / S, r2_ / S
                x0 += g0 * nu
                x1 += g1 * nu
                x2 += g2 * nu
                p00 -= g0 * r0
                p01 -= g0 * r1
                p02 -= g0 * r2_
                p10 -= g1 * r0
                p11 -= g1 * r1
                p12 -= g1 * r2_
                p20 -= g2 * r0
                p21 -= g2 * r1
                p22 -= g2 * r2_
            if hist:
                S_hist[i, b] = S
                nu_hist[i, b] = nu
            if has_sums:
                _add_loglik(weight[s, i], S, nu, sums, b)
        x[b, 0], x[b, 1], x[b, 2] = x0, x1, x2
        P[b, 0, 0], P[b, 0, 1], P[b, 0, 2] = p00, p01, p02
        P[b, 1, 0], P[b, 1, 1], P[b, 1, 2] = p10, p11, p12
        P[b, 2, 0], P[b, 2, 1], P[b, 2, 2] = p20, p21, p22


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
_filter3 = compiled(_filter3)
filter_steps = compiled(_filter_steps)
noisy_steps = compiled(_noisy_steps)
