"""The smoother's passes after the filter, compiled (numba) like the filter's
(:mod:`.kernel`): the backward recursion of the Rauch–Tung–Striebel smoother in the
Bryson–Frazier form, the means-only filter on other data (the gains do not depend on the
data), the smoother's error covariance under another process noise, and draws of the
state-space model.

Each loops over the frames with the series inside and keeps only a step's ``k × k``
matrices (``L = F (I − K H)`` is built where it is used: no ``(n, B, k², k²)`` Kronecker
products); series ``b`` reads its gains, covariances and validity from the stored series
``src[b]`` (many draws share one smoother's gains without copies). The formulas and their
numpy forms: :mod:`.batch` (public functions) and :mod:`.reference` (the numpy forms, kept to
check these against). Arguments are C-ordered float64 arrays (bool masks, int64 indexes).
"""

from __future__ import annotations

import numpy as np

from trebuchet.ingest.kalman.kernel import compiled

__all__ = ["smoother_pass", "sums_pass", "refilter_pass", "states_pass", "quad_pass",
           "error_cov_pass", "simulate_chunk", "kick_responses"]


def _transfer(F, i, gain, s, L):  # noqa: ANN001, ANN201 - numba
    """``L = F[i+1] − (F[i+1] K) e1ᵀ`` (k, k) into ``L``, ``K = gain[i, s]``."""
    k = L.shape[0]
    for p in range(k):
        acc = 0.0
        for j in range(k):
            acc += F[i + 1, p, j] * gain[i, s, j]
        for q in range(k):
            L[p, q] = F[i + 1, p, q]
        L[p, 0] -= acc


def _back_r(F, gain, i, s, r, b, tmp):  # noqa: ANN001, ANN201 - numba
    """``r[b] ← r[b] L`` (a row vector) with ``L = F[i+1] − (F[i+1] K) e1ᵀ``,
    ``K = gain[i, s]``: ``r F[i+1]``, less ``r·(F[i+1] K)`` in its first element."""
    k = tmp.shape[0]
    for q in range(k):
        acc = 0.0
        for p in range(k):
            acc += r[b, p] * F[i + 1, p, q]
        tmp[q] = acc
    corr = 0.0
    for p in range(k):
        fk = 0.0
        for j in range(k):
            fk += F[i + 1, p, j] * gain[i, s, j]
        corr += r[b, p] * fk
    tmp[0] -= corr
    for q in range(k):
        r[b, q] = tmp[q]


def _sandwich(L, N, b, T):  # noqa: ANN001, ANN201 - numba
    """``N[b] ← Lᵀ N[b] L`` (k, k); ``T`` scratch."""
    k = L.shape[0]
    for p in range(k):
        for q in range(k):
            acc = 0.0
            for u in range(k):
                acc += N[b, p, u] * L[u, q]
            T[p, q] = acc
    for p in range(k):
        for q in range(k):
            acc = 0.0
            for u in range(k):
                acc += L[u, p] * T[u, q]
            N[b, p, q] = acc


def _smoother_pass(F, gain, S, nu, xp, Pp, valid, src, xs, Ps, rs, Ns
                   ):  # noqa: ANN001, ANN201 - numba
    """Backward recursion ``r_{i-1} = e1 ν_i/S_i + L_iᵀ r_i``, ``N_{i-1} = e1 e1ᵀ/S_i +
    L_iᵀ N_i L_i`` (zero terms at gaps), ``x^s = xp + Pp r``, ``P^s = Pp − Pp N Pp``; writes
    ``xs``, ``rs`` (n, B, k), ``Ps``, ``Ns`` (n, B, k, k)."""
    n, B, k = xp.shape
    r = np.zeros((B, k))
    N = np.zeros((B, k, k))
    L = np.empty((k, k))
    T = np.empty((k, k))
    tmp = np.empty(k)
    for i in range(n - 1, -1, -1):
        for b in range(B):
            s = src[b]
            if i < n - 1:
                _transfer(F, i, gain, s, L)
                _back_r(F, gain, i, s, r, b, tmp)
                _sandwich(L, N, b, T)
            inv = 1.0 / S[i, s] if valid[s, i] else 0.0
            r[b, 0] += nu[i, b] * inv
            N[b, 0, 0] += inv
            for a in range(k):
                rs[i, b, a] = r[b, a]
                acc = 0.0
                for c in range(k):
                    Ns[i, b, a, c] = N[b, a, c]
                    acc += Pp[i, s, a, c] * r[b, c]
                xs[i, b, a] = xp[i, b, a] + acc
            for a in range(k):
                for c in range(k):
                    acc = 0.0
                    for u in range(k):
                        acc += Pp[i, s, a, u] * N[b, u, c]
                    T[a, c] = acc
            for a in range(k):
                for c in range(k):
                    acc = 0.0
                    for u in range(k):
                        acc += T[a, u] * Pp[i, s, u, c]
                    Ps[i, b, a, c] = Pp[i, s, a, c] - acc


def _sums_pass(F, gain, S, nu, valid, src, rs):  # noqa: ANN001, ANN201 - numba
    """The backward sums ``r`` only (n, B, k) into ``rs``."""
    n, B, k = rs.shape
    r = np.zeros((B, k))
    tmp = np.empty(k)
    for i in range(n - 1, -1, -1):
        for b in range(B):
            s = src[b]
            if i < n - 1:
                _back_r(F, gain, i, s, r, b, tmp)
            inv = 1.0 / S[i, s] if valid[s, i] else 0.0
            r[b, 0] += nu[i, b] * inv
            for a in range(k):
                rs[i, b, a] = r[b, a]


def _refilter_pass(F, gain, valid, src, z, x, nu, xp):  # noqa: ANN001, ANN201 - numba
    """The filter's means on measurements ``z`` (B, n) with the stored gains of series
    ``src[b]``: ``x = F x``, ``ν = (z − x₀)`` where valid (else 0), ``x += K ν``; writes
    ``nu`` (n, B) and the first ``xp.shape[2]`` predicted states into ``xp`` (n, B, ·);
    ``x`` (B, k) the prior mean, updated to the end."""
    n, B = nu.shape
    k = x.shape[1]
    kx = xp.shape[2]
    xn = np.empty(k)
    for i in range(n):
        for b in range(B):
            s = src[b]
            for a in range(k):
                acc = 0.0
                for m in range(k):
                    acc += x[b, m] * F[i, a, m]
                xn[a] = acc
            for a in range(kx):
                xp[i, b, a] = xn[a]
            ok = valid[s, i]
            v = ((z[b, i] if ok else 0.0) - xn[0]) * (1.0 if ok else 0.0)
            nu[i, b] = v
            for a in range(k):
                x[b, a] = xn[a] + gain[i, s, a] * v


def _states_pass(F, gain, S, Pp, nu, xp, valid, src, xs):  # noqa: ANN001, ANN201 - numba
    """Smoothed states only: the ``r`` recursion and ``x^s = xp + Pp r``, the first
    ``xs.shape[2]`` states (n, B, ·) from the predicted ones ``xp``."""
    n, B, kx = xs.shape
    k = F.shape[1]
    r = np.zeros((B, k))
    tmp = np.empty(k)
    for i in range(n - 1, -1, -1):
        for b in range(B):
            s = src[b]
            if i < n - 1:
                _back_r(F, gain, i, s, r, b, tmp)
            inv = 1.0 / S[i, s] if valid[s, i] else 0.0
            r[b, 0] += nu[i, b] * inv
            for a in range(kx):
                acc = 0.0
                for c in range(k):
                    acc += Pp[i, s, a, c] * r[b, c]
                xs[i, b, a] = xp[i, b, a] + acc


def _quad_pass(F, gain, S, nu, valid, src, Q0, pairs, quad, pair_quad
               ):  # noqa: ANN001, ANN201 - numba
    """The backward sums' quadratic forms ``rᵀ Q0 r`` per step and series (n, B) into
    ``quad``, and of the sums of two series ``(r_a + r_b)ᵀ Q0 (r_a + r_b)`` for each row
    ``(a, b)`` of ``pairs`` (P, 2) into ``pair_quad`` (n, P)."""
    n, B = quad.shape
    k = F.shape[1]
    r = np.zeros((B, k))
    tmp = np.empty(k)
    for i in range(n - 1, -1, -1):
        for b in range(B):
            s = src[b]
            if i < n - 1:
                _back_r(F, gain, i, s, r, b, tmp)
            inv = 1.0 / S[i, s] if valid[s, i] else 0.0
            r[b, 0] += nu[i, b] * inv
            out = 0.0
            for a in range(k):
                acc = 0.0
                for c in range(k):
                    acc += Q0[i, a, c] * r[b, c]
                out += r[b, a] * acc
            quad[i, b] = out
        for j in range(pairs.shape[0]):
            b1, b2 = pairs[j, 0], pairs[j, 1]
            out = 0.0
            for a in range(k):
                acc = 0.0
                for c in range(k):
                    acc += Q0[i, a, c] * (r[b1, c] + r[b2, c])
                out += (r[b1, a] + r[b2, a]) * acc
            pair_quad[i, j] = out


def _error_cov_pass(F, Q0, G, gain, S, Pp, N, valid, src, r2, lam, kick, prior, err, covr
                    ):  # noqa: ANN001, ANN201 - numba
    """:func:`~trebuchet.ingest.kalman.batch.error_covariance`: the prediction error's
    covariance forward, ``Π_{i+1} = L_i Π_i L_iᵀ + r2 (F K)(F K)ᵀ + W_{i+1}`` (``W =
    lam Q0 + kick G``, the true process noise), then backward ``U_i = L_iᵀ U_{i+1} L_i +
    r2 c cᵀ + (N_{i+1} L_i)ᵀ W_{i+1} (N_{i+1} L_i)``, ``c = e1/S_i − L_iᵀ N_{i+1} F K_i``,
    and ``err = (I − Pp N) Π (I − Pp N)ᵀ + Pp U Pp``, ``covr = N Π N + U`` (if
    ``covr`` has rows) into (n, B, k, k)."""
    n, B, k = err.shape[0], err.shape[1], err.shape[2]
    parts = covr.shape[0] > 0
    Pi = np.empty((n, B, k, k))
    L = np.empty((k, k))
    T = np.empty((k, k))
    T2 = np.empty((k, k))
    W = np.empty((1, k, k))
    U = np.zeros((B, k, k))
    fk = np.empty(k)
    c = np.empty(k)
    Nfk = np.empty(k)
    for b in range(B):
        for a in range(k):
            for q in range(k):
                Pi[0, b, a, q] = prior[b, a, q]
    for i in range(n - 1):
        for b in range(B):
            s = src[b]
            _transfer(F, i, gain, s, L)
            _gain_forward(F, i, gain, s, fk)
            for a in range(k):  # T = L Π
                for q in range(k):
                    acc = 0.0
                    for u in range(k):
                        acc += L[a, u] * Pi[i, b, u, q]
                    T[a, q] = acc
            for a in range(k):
                for q in range(k):
                    acc = 0.0
                    for u in range(k):
                        acc += T[a, u] * L[q, u]
                    Pi[i + 1, b, a, q] = acc + (r2[b] * fk[a] * fk[q]
                                                + (lam[b] * Q0[i + 1, a, q]
                                                   + kick[b] * G[i + 1, a, q]))
    for i in range(n - 1, -1, -1):
        for b in range(B):
            s = src[b]
            for a in range(k):
                c[a] = 0.0
            if i < n - 1:
                _transfer(F, i, gain, s, L)
                _gain_forward(F, i, gain, s, fk)
                for a in range(k):  # N_{i+1} F K
                    acc = 0.0
                    for u in range(k):
                        acc += N[i + 1, b, a, u] * fk[u]
                    Nfk[a] = acc
                for a in range(k):
                    acc = 0.0
                    for u in range(k):
                        acc += L[u, a] * Nfk[u]
                    c[a] = -acc
                for a in range(k):  # T = N_{i+1} L
                    for q in range(k):
                        acc = 0.0
                        for u in range(k):
                            acc += N[i + 1, b, a, u] * L[u, q]
                        T[a, q] = acc
                for a in range(k):
                    for q in range(k):
                        W[0, a, q] = lam[b] * Q0[i + 1, a, q] + kick[b] * G[i + 1, a, q]
                _sandwich(L, U, b, T2)  # U ← Lᵀ U L
                _sandwich(T, W, 0, T2)  # W ← (N L)ᵀ W (N L)
            if valid[s, i]:
                c[0] += 1.0 / S[i, s]
            for a in range(k):
                for q in range(k):
                    drive = r2[b] * c[a] * c[q]
                    if i < n - 1:
                        drive += W[0, a, q]
                    U[b, a, q] += drive
            _error_at(i, b, s, Pp, N, Pi, U, err, covr, parts, T, T2)


def _gain_forward(F, i, gain, s, fk):  # noqa: ANN001, ANN201 - numba
    """``F[i+1] K`` (k,) into ``fk``, ``K = gain[i, s]``."""
    k = fk.shape[0]
    for p in range(k):
        acc = 0.0
        for j in range(k):
            acc += F[i + 1, p, j] * gain[i, s, j]
        fk[p] = acc


def _error_at(i, b, s, Pp, N, Pi, U, err, covr, parts, T, T2):  # noqa: ANN001, ANN201
    """``err[i, b] = M Π Mᵀ + Pp U[b] Pp`` with ``M = I − Pp N``, and ``covr[i, b] = N Π N +
    U[b]``."""
    k = T.shape[0]
    for a in range(k):  # T = M
        for q in range(k):
            acc = 0.0
            for u in range(k):
                acc += Pp[i, s, a, u] * N[i, b, u, q]
            T[a, q] = (1.0 if a == q else 0.0) - acc
    for a in range(k):  # T2 = M Π
        for q in range(k):
            acc = 0.0
            for u in range(k):
                acc += T[a, u] * Pi[i, b, u, q]
            T2[a, q] = acc
    for a in range(k):
        for q in range(k):
            acc = 0.0
            for u in range(k):
                acc += T2[a, u] * T[q, u]
            err[i, b, a, q] = acc
    for a in range(k):  # T = Pp U
        for q in range(k):
            acc = 0.0
            for u in range(k):
                acc += Pp[i, s, a, u] * U[b, u, q]
            T[a, q] = acc
    for a in range(k):
        for q in range(k):
            acc = 0.0
            for u in range(k):
                acc += T[a, u] * Pp[i, s, u, q]
            err[i, b, a, q] += acc
    if not parts:
        return
    for a in range(k):  # T = N Π
        for q in range(k):
            acc = 0.0
            for u in range(k):
                acc += N[i, b, a, u] * Pi[i, b, u, q]
            T[a, q] = acc
    for a in range(k):
        for q in range(k):
            acc = 0.0
            for u in range(k):
                acc += T[a, u] * N[i, b, u, q]
            covr[i, b, a, q] = acc + U[b, a, q]


def _simulate_chunk(lo, F, q_root, g_root, events, noise_sd, src, kick_sd, normals,
                    ev_normals, x, z):  # noqa: ANN001, ANN201 - numba
    """Rows ``lo .. lo + len(normals) − 1`` of draws of the model: ``x_i = F_i x_{i−1} +
    w_i``, ``w_i = noise_sd[src[b], i] q_root[i] ε_i`` plus, at the steps ``events[e]``,
    ``kick_sd[b] g_root[e] η_e`` (``normals`` (c, B, k) the ε of these rows, ``ev_normals``
    (E, B, k)); ``z[b, i] = x₀``; ``x`` (B, k) carried from chunk to chunk."""
    rows, B, k = normals.shape
    w = np.empty(k)
    xn = np.empty(k)
    for j in range(rows):
        i = lo + j
        for b in range(B):
            for a in range(k):
                acc = 0.0
                for m in range(k):
                    acc += q_root[i, a, m] * normals[j, b, m]
                w[a] = noise_sd[src[b], i] * acc
            for e in range(events.shape[0]):
                if events[e] == i:
                    for a in range(k):
                        acc = 0.0
                        for m in range(k):
                            acc += g_root[e, a, m] * ev_normals[e, b, m]
                        w[a] += kick_sd[b] * acc
            for a in range(k):
                acc = 0.0
                for m in range(k):
                    acc += x[b, m] * F[i, a, m]
                xn[a] = acc + w[a]
            for a in range(k):
                x[b, a] = xn[a]
            z[b, i] = xn[0]


def _kick_responses(F, g_root, events, kick_sd, ev_normals, z):  # noqa: ANN001, ANN201
    """Add to the draws ``z`` (B, n) the response to each event's kick: ``y_e = kick_sd[b]
    g_root[e] η_e``, ``y_i = F_i y_{i−1}`` after it, ``z[b, i] += y_i[0]`` (the model is
    linear: the draws made without the kicks plus these are the draws with them)."""
    B, n = z.shape
    k = F.shape[1]
    y = np.empty(k)
    yn = np.empty(k)
    for e in range(events.shape[0]):
        for b in range(B):
            for a in range(k):
                acc = 0.0
                for m in range(k):
                    acc += g_root[e, a, m] * ev_normals[e, b, m]
                y[a] = kick_sd[b] * acc
            z[b, events[e]] += y[0]
            for i in range(events[e] + 1, n):
                for a in range(k):
                    acc = 0.0
                    for m in range(k):
                        acc += y[m] * F[i, a, m]
                    yn[a] = acc
                for a in range(k):
                    y[a] = yn[a]
                z[b, i] += y[0]


_transfer = compiled(_transfer, inline=True)
_back_r = compiled(_back_r, inline=True)
_sandwich = compiled(_sandwich, inline=True)
_gain_forward = compiled(_gain_forward, inline=True)
_error_at = compiled(_error_at, inline=True)
smoother_pass = compiled(_smoother_pass)
sums_pass = compiled(_sums_pass)
refilter_pass = compiled(_refilter_pass)
states_pass = compiled(_states_pass)
quad_pass = compiled(_quad_pass)
error_cov_pass = compiled(_error_cov_pass)
simulate_chunk = compiled(_simulate_chunk)
kick_responses = compiled(_kick_responses)
