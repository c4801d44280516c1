"""Kalman filter, Rauch–Tung–Striebel smoother and jump scores for many series at once.

The filter is the one of filterpy's ``KalmanFilter.batch_filter`` (predict, then
update, every step) and ``rts_smoother``, written for a scalar measurement of the
first state component and batched in numpy over ``B`` series that share the time
steps (several angles, several candidate process noises). The filter's loop over the
frames is compiled (:mod:`.kernel`); the backward passes are Python loops over
the ``n`` time steps, each step a handful of numpy operations on ``(B, k, k)`` arrays,
so their cost hardly grows with ``B``. docs/background.md ("Differentiating video angles"): filterpy
runs about 30k samples/s; both agree to round-off (``tests/test_smooth_kalman.py``
checks it against filterpy).

State of one series: ``[angle, rate, acceleration]`` (``k = 3``, constant
acceleration, white jerk) or ``[angle, rate, acceleration, jerk]`` (``k = 4``,
constant jerk, white snap). Units are whatever the caller uses; the smoother in
:mod:`trebuchet.ingest.smoothing.smooth` works in frames (time divided by the median frame
interval) and measurement-noise units (R = 1), which keeps the covariances well
conditioned.

References
----------
- R. E. Kalman (1960), A new approach to linear filtering and prediction problems.
- H. E. Rauch, F. Tung, C. T. Striebel (1965), Maximum likelihood estimates of linear
  dynamic systems, AIAA J. 3(8) — the RTS smoother.
- P. de Jong (1989), Smoothing and interpolation with the state-space model, JASA 84;
  J. Durbin, S. J. Koopman (2012), Time Series Analysis by State Space Methods, 2nd ed.,
  §4.4 and §7.5 — the backward recursion ``r, N`` used for the jump (intervention) scores.
- R. Labbe, filterpy 2.0.0, ``Q_continuous_white_noise`` (the discretised process noise).
"""

from __future__ import annotations

from dataclasses import dataclass
from math import factorial

import numpy as np

from trebuchet.ingest.kalman.kernel import filter_steps


def polynomial_transition(k: int, dt: np.ndarray) -> np.ndarray:
    """Transition matrices ``F(dt)`` of a ``k``-state polynomial (Taylor) model.

    ``F[i, j] = dt**(j - i) / (j - i)!`` for ``j >= i``. ``dt`` in the caller's time
    unit, shape ``(n,)``; returns ``(n, k, k)``.
    """
    dt = np.asarray(dt, dtype=float)
    F = np.zeros(dt.shape + (k, k))
    for i in range(k):
        for j in range(i, k):
            F[..., i, j] = dt ** (j - i) / factorial(j - i)
    return F


def white_noise_covariance(k: int, dt: np.ndarray) -> np.ndarray:
    """Exact discretised covariance of white noise (unit spectral density) on the last state.

    Identical to filterpy's ``Q_continuous_white_noise(k, dt, 1.0)`` (k = 2, 3, 4), for an
    array of ``dt``: ``Q[i, j] = dt**(2k-1-i-j) / ((k-1-i)! (k-1-j)! (2k-1-i-j))``.
    Returns ``(n, k, k)``; multiply by the spectral density ``q`` (rad²/s⁵ for k = 3).
    """
    dt = np.asarray(dt, dtype=float)
    Q = np.empty(dt.shape + (k, k))
    for i in range(k):
        for j in range(k):
            a, b = k - 1 - i, k - 1 - j
            p = a + b + 1
            Q[..., i, j] = dt**p / (factorial(a) * factorial(b) * p)
    return Q


@dataclass(frozen=True)
class StepModel:
    """Per-step matrices shared by all series of a batch (``n`` steps, ``k`` states).

    Step ``i`` predicts from the time of frame ``i-1`` to frame ``i`` (step 0 is the prior
    at frame 0: ``F[0] = I``, ``Q0[0] = 0``). Process noise of series ``b`` at step ``i`` is
    ``lam[b] * Q0[i] + kick[b] * G[i]``: ``Q0`` the unit white-noise covariance (zero
    at rest), ``G`` the unit covariance of a jump (a "kick") in acceleration at an event
    between the frames, carried to frame ``i``.
    """

    F: np.ndarray  # (n, k, k)
    Q0: np.ndarray  # (n, k, k)
    G: np.ndarray  # (n, k, k)

    @property
    def n(self) -> int:
        return self.F.shape[0]

    @property
    def k(self) -> int:
        return self.F.shape[-1]

    def stretch(self, lo: int, hi: int) -> StepModel:
        """Steps ``lo .. hi-1`` (to run the filter on from the filtered state at ``lo-1``)."""
        return StepModel(self.F[lo:hi], self.Q0[lo:hi], self.G[lo:hi])


@dataclass(frozen=True)
class FilterResult:
    """Output of :func:`batch_kalman_filter`, histories indexed ``[step, series, ...]``.

    ``S`` the innovation variance and ``nu`` the innovation (0 at gaps) at every step;
    with ``store=True`` also ``xp``/``Pp`` (state and covariance after the prediction)
    and ``gain`` (Kalman gain, zero at gaps), which :func:`backward_smoother` needs.
    ``x_end``/``P_end``: the filtered state (B, k) and covariance (B, k, k) after the last
    step, to continue the filter on a following stretch of steps.
    """

    S: np.ndarray
    nu: np.ndarray
    xp: np.ndarray | None = None
    Pp: np.ndarray | None = None
    gain: np.ndarray | None = None
    x_end: np.ndarray | None = None
    P_end: np.ndarray | None = None

    def series(self, index: np.ndarray) -> FilterResult:
        """The result for the series ``index`` only (e.g. one grid point per angle)."""
        def pick(a: np.ndarray | None, axis: int) -> np.ndarray | None:
            return None if a is None else np.take(a, index, axis=axis)

        return FilterResult(pick(self.S, 1), pick(self.nu, 1), pick(self.xp, 1),
                            pick(self.Pp, 1), pick(self.gain, 1), pick(self.x_end, 0),
                            pick(self.P_end, 0))

    def loglik_sums(self, weight: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``Σ w log S``, ``Σ w ν²/S`` and ``Σ w`` per series; ``weight`` (B, n), 0 at gaps."""
        w = np.asarray(weight, float).T
        ok = self.S > 0.0  # lost positive definiteness (round-off at extreme λ): NaN sums
        log_s = np.log(np.where(ok, self.S, 1.0)) + np.where(ok, 0.0, np.nan)
        return (
            (w * log_s).sum(axis=0),
            (w * self.nu**2 / self.S).sum(axis=0),
            w.sum(axis=0),
        )


def _rest_steps(steps: StepModel, has_noise: list[bool], x: np.ndarray, P: np.ndarray) -> int:
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


def batch_kalman_filter(
    z: np.ndarray,
    valid: np.ndarray,
    steps: StepModel,
    lam: np.ndarray,
    kick: np.ndarray,
    r2: np.ndarray,
    x0: np.ndarray,
    P0: np.ndarray,
    store: bool = False,
) -> FilterResult:
    """Kalman filter (predict then update each step) for ``B`` scalar series at once.

    Parameters
    ----------
    z : (B, n) measurements of the first state; values where ``valid`` is False are ignored.
    valid : (B, n) bool, False for a gap (predict through, no update).
    steps : per-step matrices, see :class:`StepModel`.
    lam : (B,) process-noise density, or (B, n) one per series and step (piecewise noise).
    kick, r2 : (B,) kick variance, measurement variance.
    x0, P0 : (B, k), (B, k, k) prior at frame 0, before the step-0 prediction.
    store : keep the histories needed by :func:`backward_smoother`.

    The steps after a leading rest run compiled (:func:`.kernel.filter_steps`). The
    update is the simple form ``P = Pp - K H Pp`` (filterpy: Joseph form, equal in exact
    arithmetic; they differ by round-off, ~1e-9 of the largest variance near a kick).
    """
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
    # process noise of every step and series at once: lam Q0 + kick G, (n, B, kk)
    lam_steps = lam.T if per_step else np.broadcast_to(lam_c.T, (n, B))
    noise = lam_steps[:, :, None] * Q0[:, None, :] + kick_c.T[:, :, None] * G[:, None, :]
    has_noise = np.any(noise != 0.0, axis=(1, 2)).tolist()
    moves = (~np.all(steps.F == np.eye(k), axis=(1, 2))).tolist()
    zz_t = np.array(zz.T, order="C")
    valid_t = np.ascontiguousarray(valid.T).astype(float)

    x = np.array(x0, dtype=float)
    P = np.array(P0, dtype=float).reshape(B, kk)
    S_hist = np.empty((n, B))
    nu_hist = np.zeros((n, B))
    if store:
        xps = np.empty((n, B, k))
        Pps = np.empty((n, B, k, k))
    first = _rest_steps(steps, has_noise, x, P)
    if first:
        # a leading rest: only the first state is uncertain and nothing moves it, so the
        # filter is a running weighted mean, done for all those steps at once
        p0, m0 = P[:, 0], x[:, 0]
        v = valid_t[:first]
        count = np.cumsum(v, axis=0) - v  # valid frames before each step
        total = np.cumsum(v * zz_t[:first], axis=0) - v * zz_t[:first]
        p_pred = 1.0 / (1.0 / p0 + count / r2)
        x_pred = p_pred * (m0 / p0 + total / r2)
        S_hist[:first] = p_pred + r2
        nu_hist[:first] = v * (zz_t[:first] - x_pred)
        if store:
            xps[:first] = 0.0
            xps[:first, :, 0] = x_pred
            Pps[:first] = 0.0
            Pps[:first, :, 0, 0] = p_pred
        last = first - 1
        p_end = 1.0 / (1.0 / p_pred[last] + v[last] / r2)
        x = np.zeros_like(x)
        x[:, 0] = p_end * (x_pred[last] / p_pred[last] + v[last] * zz_t[last] / r2)
        P = np.zeros_like(P)
        P[:, 0] = p_end
    P3 = np.ascontiguousarray(P.reshape(B, k, k))
    # every input a fresh, writable C-ordered copy (one compiled signature); x, P3 and the
    # histories are written in place
    x = np.array(x, dtype=float, order="C")
    filter_steps(int(first), np.array(steps.F, dtype=float, order="C"),
                 np.array(noise.reshape(n, B, k, k), order="C"),
                 np.array(moves, dtype=bool), np.array(has_noise, dtype=bool),
                 np.array(valid.T, dtype=bool, order="C"),
                 zz_t, np.array(r2, dtype=float),
                 x, P3, S_hist, nu_hist, bool(store),
                 xps if store else np.empty((1, 1, 1)),
                 Pps if store else np.empty((1, 1, 1, 1)))
    end = {"x_end": x, "P_end": P3}
    if not store:
        return FilterResult(S_hist, nu_hist, **end)
    gains = Pps[:, :, 0, :] * (valid_t / S_hist)[:, :, None]  # zero at gaps
    return FilterResult(S_hist, nu_hist, xps, Pps, gains, **end)


@dataclass(frozen=True)
class SmootherResult:
    """Output of :func:`backward_smoother`, indexed ``[step, series, ...]``.

    ``x``, ``P``: smoothed state and covariance. ``r``, ``N``: for a jump ``d·Δ`` added to
    the state at step ``i`` (between frames ``i-1`` and ``i``, ``d`` in the state at frame
    ``i``) the score is ``d·r[i]`` and the information ``dᵀ N[i] d``: the maximum-
    likelihood jump is ``Δ = d·r / dᵀNd``, and ``(d·r)² / dᵀNd`` the likelihood-ratio
    statistic (χ², 1 degree of freedom per series, when there is no jump).
    """

    x: np.ndarray
    P: np.ndarray
    r: np.ndarray
    N: np.ndarray


def backward_smoother(steps: StepModel, filt: FilterResult, valid: np.ndarray) -> SmootherResult:
    """Fixed-interval smoother in the Bryson–Frazier form, with jump scores.

    Backward recursion (Durbin & Koopman 2012, §4.4, their ``r_{t-1}, N_{t-1}``; de Jong
    1989): ``r_{i-1} = Hᵀ ν_i / S_i + L_iᵀ r_i``, ``N_{i-1} = Hᵀ H / S_i + L_iᵀ N_i L_i``
    with ``L_i = F_{i+1} (I - K_i H)``; then ``x^s_i = xp_i + Pp_i r_{i-1}`` and
    ``P^s_i = Pp_i - Pp_i N_{i-1} Pp_i``. Equal to the Rauch–Tung–Striebel smoother
    (filterpy's ``rts_smoother``; tests compare them) but with no matrix inverse, so the
    singular covariances at rest need no special care, and the same ``r, N`` give the
    jump statistics used to find the release.
    """
    n, B, k = filt.xp.shape
    kk = k * k
    valid = np.asarray(valid, dtype=bool)
    # L_i = F_{i+1} (I - K_i e1ᵀ) = F_{i+1} - (F_{i+1} K_i) e1ᵀ for all steps at once, and
    # LL_i = L_i ⊗ L_i: vec(L_iᵀ N L_i) = vec(N) @ LL_i (row-major vec)
    F_next = steps.F[1:]
    L = np.repeat(F_next[:, None], B, axis=1)
    L[..., 0] -= np.einsum("nij,nbj->nbi", F_next, filt.gain[:-1])
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
    """Smoothed states ``x^s`` (n, B, k) only: the ``r`` half of :func:`backward_smoother`
    (``r_{i-1} = Hᵀ ν_i / S_i + L_iᵀ r_i``, ``x^s_i = xp_i + Pp_i r_{i-1}``), without the
    covariances, at a fraction of its cost."""
    return filt.xp + np.einsum("nbij,nbj->nbi", filt.Pp, backward_sums(steps, filt, valid))


def backward_sums(steps: StepModel, filt: FilterResult, valid: np.ndarray) -> np.ndarray:
    """The backward sums ``r`` (n, B, k) of :func:`backward_smoother` only."""
    n, B, k = filt.xp.shape
    valid = np.asarray(valid, dtype=bool)
    F_next = steps.F[1:]
    L = np.repeat(F_next[:, None], B, axis=1)
    L[..., 0] -= np.einsum("nij,nbj->nbi", F_next, filt.gain[:-1])
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
    """Measurements (B, n) drawn from the state-space model itself: the first state of
    ``x_i = F_i x_{i-1} + w_i``, ``w_i ~ N(0, noise[b] Q0_i + kick[b] G_i)`` (``noise``
    (B, n), ``kick`` (B,)), ``x_0 ~ N(0, prior[b])`` (B, k, k), plus white measurement
    noise of variance ``r2`` (B,) (0: none)."""
    n, k = steps.n, steps.k
    B = noise.shape[0]

    def root(C: np.ndarray) -> np.ndarray:
        w, v = np.linalg.eigh(C)
        return v * np.sqrt(np.clip(w, 0.0, None))[..., None, :]

    q_root = root(steps.Q0)  # (n, k, k)
    g_root = root(steps.G)  # nonzero at the events only
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
    """``filt`` with its means re-run on other measurements ``z`` (B, n): the gains, the
    covariances and the innovation variances of a linear Kalman filter do not depend on
    the data, so the filter of ``z`` keeps them and only the means (``xp``, ``nu``,
    ``x_end``) change. ``valid`` must be the mask ``filt`` ran with (its gains are zero at
    the gaps); ``x0`` (B, k) the prior mean. For :func:`smoothed_states` of ``z``."""
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
    """Covariance (n, B, k, k) of the smoothed states' error ``x − x̂`` when the smoother
    of ``filt``/``sm`` (its gains, from its own model) runs on data whose true process
    noise is ``noise`` (n, B, k, k) per step and series, with measurement variance ``r2``
    (B,) and prior covariance ``prior`` (B, k, k) at frame 0.

    With the prediction error ``e_i = x_i − xp_i`` (``e_{i+1} = L_i e_i − F_{i+1} K_i v_i
    + w_{i+1}``, ``Π_{i+1} = L_i Π_i L_iᵀ + r F K Kᵀ Fᵀ + W_{i+1}``) the backward sum
    splits as ``r_{i-1} = N_{i-1} e_i + η``, ``η`` independent of ``e_i`` with
    ``U_{i-1} = c cᵀ r + L_iᵀ N_i W_{i+1} N_i L_i + L_iᵀ U_i L_i``, ``c = e1/S_i −
    L_iᵀ N_i F_{i+1} K_i``; the smoothed error ``(I − Pp N) e − Pp η`` has covariance
    ``(I − Pp N) Π (I − Pp N)ᵀ + Pp U Pp``. With the smoother's own process noise this is
    its ``P`` (tests check it); with none (and the same kicks), the error of noise alone.
    ``parts``: also the covariance (n, B, k, k) of the backward sums ``r`` (the
    smoother's ``r``), ``N Π N + U``.
    """
    n, B, k = filt.xp.shape
    kk = k * k
    valid = np.asarray(valid, bool)
    r2 = np.asarray(r2, float)
    F_next = steps.F[1:]
    L = np.repeat(F_next[:, None], B, axis=1)
    L[..., 0] -= np.einsum("nij,nbj->nbi", F_next, filt.gain[:-1])
    LL = np.einsum("nbpi,nbqj->nbpqij", L, L).reshape(n - 1, B, kk, kk)
    LLT = np.swapaxes(LL, 2, 3)
    FK = np.einsum("nij,nbj->nbi", F_next, filt.gain[:-1])  # (n-1, B, k)
    # forward: Π
    drive_f = (r2[None, :, None, None] * FK[..., :, None] * FK[..., None, :]
               + noise[1:]).reshape(n - 1, B, kk)
    Pi = np.empty((n, B, kk))
    p = np.asarray(prior, float).reshape(B, kk)
    Pi[0] = p
    for i in range(n - 1):
        p = (p[:, None, :] @ LLT[i])[:, 0] + drive_f[i]
        Pi[i + 1] = p
    # backward: U
    N = sm.N
    inv_S = np.where(valid.T, 1.0 / filt.S, 0.0)  # (n, B)
    NL = N[1:] @ L  # N_{i+1} L_i
    c = -np.einsum("nbji,nbj->nbi", L, np.einsum("nbij,nbj->nbi", N[1:], FK))
    c = np.concatenate([c, np.zeros((1, B, k))])
    c[..., 0] += inv_S
    NW = NL  # L_iᵀ N_{i+1} W_{i+1} N_{i+1} L_i
    wterm = np.swapaxes(NW, 2, 3) @ noise[1:] @ NW
    drive_b = r2[None, :, None, None] * c[..., :, None] * c[..., None, :]
    drive_b[:-1] += wterm
    U = _accumulate_backward(drive_b.reshape(n, B, kk), LL)
    Pp = filt.Pp
    M = np.eye(k) - Pp @ N
    Pi = Pi.reshape(n, B, k, k)
    U = U.reshape(n, B, k, k)
    err = M @ Pi @ np.swapaxes(M, 2, 3) + Pp @ U @ Pp
    if parts:
        return err, N @ Pi @ N + U
    return err


def _accumulate_backward(drive: np.ndarray, LL: np.ndarray) -> np.ndarray:
    """``U_i = drive_i + U_{i+1} LL_i`` from the last step back (rows (B, k²) per step): the
    backward sums of the smoother's error recursions."""
    n = drive.shape[0]
    U = np.empty_like(drive)
    u = drive[n - 1].copy()
    U[n - 1] = u
    for i in range(n - 2, -1, -1):
        u = (u[:, None, :] @ LL[i])[:, 0] + drive[i]
        U[i] = u
    return U
