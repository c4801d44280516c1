"""The numpy forms of the filter's and the smoother's passes, kept to check the compiled ones
(:mod:`.kernel`, :mod:`.passes`) against, and the switch that makes :mod:`.batch` run them.

These are the passes as they were before they were compiled: a Python loop over the steps,
each step a few numpy operations on all series at once, and the backward recursions through
the Kronecker products ``L ⊗ L`` (``(n, B, k², k²)``) held for the whole log. Within
:func:`numpy_passes` every function of :mod:`.batch` runs its numpy form
(``tests/test_kalman_passes.py`` compares the two on the shipped samples end to end).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

import numpy as np

from trebuchet.ingest.kalman.steps import FilterResult, SmootherResult, StepModel, matrix_root

__all__ = ["numpy_passes", "active", "batch_kalman_filter", "backward_smoother",
           "backward_sums", "smoothed_states", "refiltered", "error_covariance",
           "simulated_model_runs"]

_ACTIVE: ContextVar[bool] = ContextVar("trebuchet_numpy_passes", default=False)


@contextmanager
def numpy_passes() -> Iterator[None]:
    """Within this block the functions of :mod:`.batch` run their numpy forms (this
    module), in this thread or task only."""
    token = _ACTIVE.set(True)
    try:
        yield
    finally:
        _ACTIVE.reset(token)


def active() -> bool:
    """Whether :func:`numpy_passes` is on."""
    return _ACTIVE.get()


def _rest_steps(steps: StepModel, has_noise: np.ndarray, x: np.ndarray, P: np.ndarray) -> int:
    """Number of leading steps with no process noise and no kick while only the first
    state is uncertain and set (``x0`` and ``P0`` zero elsewhere, ``P0[0, 0] > 0``) and
    every transition keeps the first state as it is (``F e1 = e1``): a rest before the
    trigger, where the filter is a running mean."""
    k = steps.k
    P00 = P[:, 0]
    rest_x = np.all(x[:, 1:] == 0.0) if k > 1 else True
    rest_P = np.all(P[:, 1:] == 0.0) and np.all(P00 > 0.0)
    if not (rest_x and rest_P):
        return 0
    e1 = np.zeros(k)
    e1[0] = 1.0
    keeps = np.all(steps.F[:, :, 0] == e1, axis=1)
    quiet = keeps & ~np.asarray(has_noise, bool)
    stop = np.flatnonzero(~quiet)
    return int(stop[0]) if stop.size else steps.n


def _sum_over(k: int, term) -> np.ndarray:  # noqa: ANN001
    """``Σ_m term(m)`` for m = 0 … k−1, added in that order from 0 (the compiled filter's
    order: its products then agree to the last bit)."""
    acc = 0.0
    for m in range(k):
        acc = acc + term(m)
    return acc


def batch_kalman_filter(z: np.ndarray, valid: np.ndarray, steps: StepModel, lam: np.ndarray,
                        kick: np.ndarray, r2: np.ndarray, x0: np.ndarray, P0: np.ndarray,
                        store: bool = False) -> FilterResult:
    """:func:`.batch.batch_kalman_filter` in numpy: the process noise of every step and
    series built at once (n, B, k, k), the leading rest as a running mean, then a loop over
    the steps (each matrix product a sum in the compiled filter's order)."""
    B, n = z.shape
    k = steps.k
    kk = k * k
    valid = np.asarray(valid, dtype=bool)
    zz = np.where(valid, z, 0.0)
    r2 = np.broadcast_to(np.asarray(r2, float), (B,))
    lam = np.asarray(lam, float)
    per_step = lam.ndim == 2
    lam_c = lam if per_step else lam[:, None]
    kick_c = np.asarray(kick, float)[:, None]
    Q0 = steps.Q0.reshape(n, kk)
    G = steps.G.reshape(n, kk)
    lam_steps = lam.T if per_step else np.broadcast_to(lam_c.T, (n, B))
    noise = (lam_steps[:, :, None] * Q0[:, None, :]
             + kick_c.T[:, :, None] * G[:, None, :]).reshape(n, B, k, k)
    has_noise = np.any(noise != 0.0, axis=(2, 3))
    moves = ~np.all(steps.F == np.eye(k), axis=(1, 2))
    zz_t = np.array(zz.T, order="C")
    valid_t = np.ascontiguousarray(valid.T).astype(float)
    x = np.array(x0, dtype=float)
    P = np.array(P0, dtype=float)
    S_hist = np.empty((n, B))
    nu_hist = np.zeros((n, B))
    xps = np.empty((n, B, k))
    Pps = np.empty((n, B, k, k))
    first = _rest_steps(steps, np.any(has_noise, axis=1), x, P.reshape(B, kk))
    if first:
        p0, m0 = P[:, 0, 0], x[:, 0]
        v = valid_t[:first]
        count = np.cumsum(v, axis=0) - v
        total = np.cumsum(v * zz_t[:first], axis=0) - v * zz_t[:first]
        p_pred = 1.0 / (1.0 / p0 + count / r2)
        x_pred = p_pred * (m0 / p0 + total / r2)
        S_hist[:first] = p_pred + r2
        nu_hist[:first] = v * (zz_t[:first] - x_pred)
        xps[:first] = 0.0
        xps[:first, :, 0] = x_pred
        Pps[:first] = 0.0
        Pps[:first, :, 0, 0] = p_pred
        last = first - 1
        p_end = 1.0 / (1.0 / p_pred[last] + v[last] / r2)
        x = np.zeros_like(x)
        x[:, 0] = p_end * (x_pred[last] / p_pred[last] + v[last] * zz_t[last] / r2)
        P = np.zeros_like(P)
        P[:, 0, 0] = p_end
    for i in range(first, n):
        if moves[i]:
            F = steps.F[i]
            x = _sum_over(k, lambda m, F=F, x=x: F[None, :, m] * x[:, m, None])
            T = _sum_over(k, lambda m, F=F, P=P: F[None, :, m, None] * P[:, None, m, :])
            P = _sum_over(k, lambda m, F=F, T=T: T[:, :, m, None] * F[None, None, :, m])
        if has_noise[i].any():
            P = P + noise[i]
        S = P[:, 0, 0] + r2
        S_hist[i] = S
        xps[i] = x
        Pps[i] = P
        ok = valid[:, i]
        nu = np.where(ok, zz_t[i] - x[:, 0], 0.0)
        gain = P[:, 0, :] / S[:, None]
        x = x + np.where(ok[:, None], gain * nu[:, None], 0.0)
        P = P - np.where(ok[:, None, None], gain[:, :, None] * P[:, None, 0, :], 0.0)
        nu_hist[i] = nu
    end = {"x_end": x, "P_end": P}
    if not store:
        return FilterResult(S_hist, nu_hist, **end)
    gains = Pps[:, :, 0, :] * (valid_t / S_hist)[:, :, None]
    return FilterResult(S_hist, nu_hist, xps, Pps, gains, **end)


def _transfer(steps: StepModel, filt: FilterResult) -> np.ndarray:
    """``L_i = F_{i+1} (I − K_i e1ᵀ)`` for all steps, (n − 1, B, k, k)."""
    B = filt.xp.shape[1]
    F_next = steps.F[1:]
    L = np.repeat(F_next[:, None], B, axis=1)
    L[..., 0] -= np.einsum("nij,nbj->nbi", F_next, filt.gain[:-1])
    return L


def backward_smoother(steps: StepModel, filt: FilterResult, valid: np.ndarray) -> SmootherResult:
    """:func:`.batch.backward_smoother` in numpy, ``N`` through ``L ⊗ L``."""
    n, B, k = filt.xp.shape
    kk = k * k
    valid = np.asarray(valid, dtype=bool)
    L = _transfer(steps, filt)
    LL = np.einsum("nbpi,nbqj->nbpqij", L, L).reshape(n - 1, B, kk, kk)
    r = np.zeros((B, 1, k))
    N = np.zeros((B, 1, kk))
    rs = np.empty((n, B, k))
    Ns = np.empty((n, B, kk))
    inv_S = np.where(valid.T, 1.0 / filt.S, 0.0)
    nu_S = filt.nu * inv_S
    for i in range(n - 1, -1, -1):
        if i < n - 1:
            r = r @ L[i]
            N = N @ LL[i]
        r[:, 0, 0] += nu_S[i]
        N[:, 0, 0] += inv_S[i]
        rs[i] = r[:, 0]
        Ns[i] = N[:, 0]
    Ns = Ns.reshape(n, B, k, k)
    Pp = filt.Pp
    xs = filt.xp + np.einsum("nbij,nbj->nbi", Pp, rs)
    Ps = Pp - Pp @ Ns @ Pp
    return SmootherResult(xs, Ps, rs, Ns)


def smoothed_states(steps: StepModel, filt: FilterResult, valid: np.ndarray) -> np.ndarray:
    """:func:`.batch.smoothed_states` in numpy."""
    return filt.xp + np.einsum("nbij,nbj->nbi", filt.Pp, backward_sums(steps, filt, valid))


def backward_sums(steps: StepModel, filt: FilterResult, valid: np.ndarray) -> np.ndarray:
    """:func:`.batch.backward_sums` in numpy."""
    n, B, k = filt.xp.shape
    valid = np.asarray(valid, dtype=bool)
    L = _transfer(steps, filt)
    nu_S = np.where(valid.T, filt.nu / filt.S, 0.0)
    r = np.zeros((B, 1, k))
    rs = np.empty((n, B, k))
    for i in range(n - 1, -1, -1):
        if i < n - 1:
            r = r @ L[i]
        r[:, 0, 0] += nu_S[i]
        rs[i] = r[:, 0]
    return rs


def simulated_model_runs(steps: StepModel, noise: np.ndarray, kick: np.ndarray,
                         r2: np.ndarray, prior: np.ndarray, rng: np.random.Generator
                         ) -> np.ndarray:
    """:func:`.batch.simulated_model_runs` in numpy (all the draws at once)."""
    n, k = steps.n, steps.k
    B = noise.shape[0]

    root = matrix_root
    q_root = root(steps.Q0)
    g_root = root(steps.G)
    x = np.einsum("bij,bj->bi", root(np.asarray(prior, float)), rng.standard_normal((B, k)))
    FT = np.ascontiguousarray(np.swapaxes(steps.F, 1, 2))
    w = (np.sqrt(np.asarray(noise, float).T)[:, :, None]
         * np.einsum("nij,nbj->nbi", q_root, rng.standard_normal((n, B, k))))
    events = np.flatnonzero(np.any(steps.G != 0.0, axis=(1, 2)))
    w[events] += (np.sqrt(np.asarray(kick, float))[None, :, None]
                  * np.einsum("nij,nbj->nbi", g_root[events],
                              rng.standard_normal((events.size, B, k))))
    z = np.empty((B, n))
    for i in range(n):
        x = x @ FT[i] + w[i]
        z[:, i] = x[:, 0]
    return z + np.sqrt(np.asarray(r2, float))[:, None] * rng.standard_normal((B, n))


def refiltered(steps: StepModel, filt: FilterResult, z: np.ndarray, valid: np.ndarray,
               x0: np.ndarray) -> FilterResult:
    """:func:`.batch.refiltered` in numpy."""
    n, B, k = filt.xp.shape
    FT = np.ascontiguousarray(np.swapaxes(steps.F, 1, 2))
    ok = np.asarray(valid, bool).T
    zz = np.where(ok, np.asarray(z, float).T, 0.0)
    gain = filt.gain
    x = np.array(x0, dtype=float)
    xp = np.empty((n, B, k))
    nu = np.zeros((n, B))
    for i in range(n):
        x = x @ FT[i]
        xp[i] = x
        v = (zz[i] - x[:, 0]) * ok[i]
        nu[i] = v
        x = x + gain[i] * v[:, None]
    return FilterResult(filt.S, nu, xp, filt.Pp, gain, x, filt.P_end)


def error_covariance(steps: StepModel, filt: FilterResult, sm: SmootherResult,
                     valid: np.ndarray, r2: np.ndarray, noise: np.ndarray,
                     prior: np.ndarray, parts: bool = False):
    """:func:`.batch.error_covariance` in numpy; ``noise`` (n, B, k, k) the true process
    noise per step and series."""
    n, B, k = filt.xp.shape
    kk = k * k
    valid = np.asarray(valid, bool)
    r2 = np.asarray(r2, float)
    F_next = steps.F[1:]
    L = _transfer(steps, filt)
    LL = np.einsum("nbpi,nbqj->nbpqij", L, L).reshape(n - 1, B, kk, kk)
    LLT = np.swapaxes(LL, 2, 3)
    FK = np.einsum("nij,nbj->nbi", F_next, filt.gain[:-1])
    drive_f = (r2[None, :, None, None] * FK[..., :, None] * FK[..., None, :]
               + noise[1:]).reshape(n - 1, B, kk)
    Pi = np.empty((n, B, kk))
    p = np.asarray(prior, float).reshape(B, kk)
    Pi[0] = p
    for i in range(n - 1):
        p = (p[:, None, :] @ LLT[i])[:, 0] + drive_f[i]
        Pi[i + 1] = p
    N = sm.N
    inv_S = np.where(valid.T, 1.0 / filt.S, 0.0)
    NL = N[1:] @ L
    c = -np.einsum("nbji,nbj->nbi", L, np.einsum("nbij,nbj->nbi", N[1:], FK))
    c = np.concatenate([c, np.zeros((1, B, k))])
    c[..., 0] += inv_S
    wterm = np.swapaxes(NL, 2, 3) @ noise[1:] @ NL
    drive_b = r2[None, :, None, None] * c[..., :, None] * c[..., None, :]
    drive_b[:-1] += wterm
    drive_b = drive_b.reshape(n, B, kk)
    U = np.empty_like(drive_b)
    u = drive_b[n - 1].copy()
    U[n - 1] = u
    for i in range(n - 2, -1, -1):
        u = (u[:, None, :] @ LL[i])[:, 0] + drive_b[i]
        U[i] = u
    Pp = filt.Pp
    M = np.eye(k) - Pp @ N
    Pi = Pi.reshape(n, B, k, k)
    U = U.reshape(n, B, k, k)
    err = M @ Pi @ np.swapaxes(M, 2, 3) + Pp @ U @ Pp
    if parts:
        return err, N @ Pi @ N + U
    return err
