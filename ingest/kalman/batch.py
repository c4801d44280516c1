"""Kalman filter, Rauch–Tung–Striebel smoother and jump scores for many series at once.

The filter is the one of filterpy's ``KalmanFilter.batch_filter`` (predict, then
update, every step) and ``rts_smoother``, written for a scalar measurement of the
first state component and batched over ``B`` series that share the time steps (several
angles, several candidate process noises). Every pass over the frames is compiled
(numba): the filter (:mod:`.kernel`) and the backward recursions, the means-only refilter,
the error covariance and the model's draws (:mod:`.passes`), each a loop over the frames
holding one step's ``k × k`` matrices, so that time and memory grow linearly with the log
and no ``(n, B, k, k)`` array of a whole noise grid is built. Their numpy forms are kept in
:mod:`.reference` (``numpy_passes()`` switches every function here to them; tests compare
both). docs/background.md ("Differentiating video angles"): filterpy runs about 30k
samples/s; both agree to round-off (``tests/test_smooth_kalman.py`` checks it against
filterpy).

State of one series: ``[angle, rate, acceleration]`` (``k = 3``, constant
acceleration, white jerk) or ``[angle, rate, acceleration, jerk]`` (``k = 4``,
constant jerk, white snap). Units are whatever the caller uses; the smoother in
:mod:`trebuchet.ingest.smoothing.smooth` works in frames (time divided by the median frame
interval) and measurement-noise units (R = 1), which keeps the covariances well
conditioned.

Series and their data: ``src`` (B,) maps series ``b`` to the row ``src[b]`` of the
measurements ``z``, ``valid`` (and, for the likelihood, ``weight``) it reads, and of a
``shape`` (A, n) of the process noise (``λ_b shape[src[b], i]`` at step ``i``): a grid of
noise candidates shares one copy of each angle's data.

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

import numpy as np

from trebuchet.ingest.kalman import reference
from trebuchet.ingest.kalman.kernel import filter_steps, noisy_steps
from trebuchet.ingest.kalman.passes import (
    error_cov_pass,
    kick_responses,
    quad_pass,
    refilter_pass,
    simulate_chunk,
    smoother_pass,
    states_pass,
    sums_pass,
)
from trebuchet.ingest.kalman.steps import (
    FilterResult,
    LoglikSums,
    SmootherResult,
    StepModel,
    matrix_root,
    polynomial_transition,
    white_noise_covariance,
)

__all__ = ["polynomial_transition", "white_noise_covariance", "StepModel", "FilterResult",
           "SmootherResult", "LoglikSums", "batch_kalman_filter", "filter_loglik",
           "backward_smoother", "smoothed_states", "backward_sums", "refiltered",
           "resmoothed", "residual_innovations", "residual_quadratics", "simulated_model_runs",
           "error_covariance"]

#: Rows of the model's draws made at once (:func:`simulated_model_runs`).
DRAW_CHUNK = 512


def _f(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def _series(src: np.ndarray | None, B: int) -> np.ndarray:
    return np.arange(B, dtype=np.int64) if src is None else np.ascontiguousarray(src, np.int64)


def _noise_spec(lam: np.ndarray, src: np.ndarray, shape: np.ndarray | None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``lam`` (B,) or (B, n), and ``shape`` (A, n) with series ``b`` on row ``src[b]``, as
    the kernel's factor (B,), rows (S, n or 1) and row index (B,) (exact: a factor 1.0)."""
    lam = np.asarray(lam, dtype=float)
    B = src.size
    if shape is not None:
        return _f(lam), _f(shape), src
    if lam.ndim == 2:
        return np.ones(B), _f(lam), np.arange(B, dtype=np.int64)
    return _f(lam), np.ones((1, 1)), np.zeros(B, dtype=np.int64)


def _expanded(z: np.ndarray, valid: np.ndarray, lam: np.ndarray, src: np.ndarray | None,
              shape: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The measurements, mask and process noise one row per series (the numpy forms')."""
    lam = np.asarray(lam, dtype=float)
    if shape is not None:
        shape = np.asarray(shape, float)
        lam = lam[:, None] * (shape if src is None else shape[src])
    if src is None:
        return z, valid, lam
    return np.asarray(z)[src], np.asarray(valid)[src], lam


def _run_filter(z, valid, steps, lam, kick, r2, x0, P0, src, shape, store, hist,
                weight):  # noqa: ANN001, ANN202
    """The compiled filter; returns (x_end, P_end, S, nu, xp, Pp, gain, sums)."""
    n, k = steps.n, steps.k
    x = np.array(x0, dtype=np.float64, order="C")
    P = np.array(P0, dtype=np.float64, order="C")
    B = x.shape[0]
    src = _series(src, B)
    lam_v, rows, rows_src = _noise_spec(lam, src, shape)
    kick = _f(np.broadcast_to(np.asarray(kick, float), (B,)))
    r2 = _f(np.broadcast_to(np.asarray(r2, float), (B,)))
    F, Q0, G = _f(steps.F), _f(steps.Q0), _f(steps.G)
    has_noise = noisy_steps(Q0, G, lam_v, rows, rows_src, kick)
    moves = ~np.all(F == np.eye(k), axis=(1, 2))
    first = reference._rest_steps(steps, has_noise, x, P.reshape(B, k * k))
    S = np.empty((n, B)) if hist else np.empty((0, 0))
    nu = np.empty((n, B)) if hist else np.empty((0, 0))
    sums = np.zeros((B, 3)) if weight is not None else np.zeros((0, 3))
    w = _f(weight) if weight is not None else np.zeros((0, 0))
    xp = np.empty((n, B, k)) if store else np.empty((0, 0, 0))
    Pp = np.empty((n, B, k, k)) if store else np.empty((0, 0, 0, 0))
    gain = np.empty((n, B, k)) if store else np.empty((0, 0, 0))
    filter_steps(int(first), F, Q0, G, moves, has_noise, lam_v, rows, rows_src, kick, src,
                 np.ascontiguousarray(valid, dtype=np.bool_), _f(z), r2, x, P, bool(hist),
                 S, nu, w, sums, bool(store), xp, Pp, gain)
    return x, P, S, nu, xp, Pp, gain, sums


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
    *,
    src: np.ndarray | None = None,
    shape: np.ndarray | None = None,
) -> FilterResult:
    """Kalman filter (predict then update each step) for ``B`` scalar series at once.

    Parameters
    ----------
    z : (B, n) measurements of the first state (or (A, n) with ``src``); values where
        ``valid`` is False are ignored.
    valid : (B, n) bool (or (A, n) with ``src``), False for a gap (predict through, no update).
    steps : per-step matrices, see :class:`StepModel`.
    lam : (B,) process-noise density, or (B, n) one per series and step (piecewise noise).
    kick, r2 : (B,) kick variance, measurement variance.
    x0, P0 : (B, k), (B, k, k) prior at frame 0, before the step-0 prediction.
    store : keep the histories needed by :func:`backward_smoother`.
    src : (B,) the row of ``z``, ``valid`` (and ``shape``) of each series (default: its own).
    shape : (A, n) the process noise per step relative to ``lam`` (B,): series ``b`` has
        ``lam[b] shape[src[b], i]`` at step ``i``.

    A leading rest (only the first state uncertain, nothing moving it) is a running mean;
    the update is the simple form ``P = Pp - K H Pp`` (filterpy: Joseph form, equal in
    exact arithmetic; they differ by round-off, ~1e-9 of the largest variance near a kick).
    """
    if reference.active():
        zz, vv, ll = _expanded(z, valid, lam, src, shape)
        return reference.batch_kalman_filter(zz, vv, steps, ll, kick, r2, x0, P0, store)
    x, P, S, nu, xp, Pp, gain, _ = _run_filter(z, valid, steps, lam, kick, r2, x0, P0, src,
                                               shape, store, True, None)
    if not store:
        return FilterResult(S, nu, x_end=x, P_end=P)
    return FilterResult(S, nu, xp, Pp, gain, x, P)


def filter_loglik(
    z: np.ndarray,
    valid: np.ndarray,
    weight: np.ndarray,
    steps: StepModel,
    lam: np.ndarray,
    kick: np.ndarray,
    r2: np.ndarray,
    x0: np.ndarray,
    P0: np.ndarray,
    *,
    src: np.ndarray | None = None,
    shape: np.ndarray | None = None,
) -> LoglikSums:
    """The sums of :meth:`FilterResult.loglik_sums` (``weight`` (A, n) by ``src`` like
    ``z``, 0 at gaps) and the filter's end state, without its histories: the filter of
    :func:`batch_kalman_filter` for a noise search over a grid (memory per series, not per
    series and step)."""
    if reference.active():
        zz, vv, ll = _expanded(z, valid, lam, src, shape)
        filt = reference.batch_kalman_filter(zz, vv, steps, ll, kick, r2, x0, P0)
        w = np.asarray(weight) if src is None else np.asarray(weight)[src]
        return LoglikSums(*filt.loglik_sums(w), filt.x_end, filt.P_end)
    x, P, *_, sums = _run_filter(z, valid, steps, lam, kick, r2, x0, P0, src, shape, False,
                                 False, weight)
    return LoglikSums(sums[:, 0].copy(), sums[:, 1].copy(), sums[:, 2].copy(), x, P)


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
    if reference.active():
        return reference.backward_smoother(steps, filt, valid)
    n, B, k = filt.xp.shape
    xs, rs = np.empty((n, B, k)), np.empty((n, B, k))
    Ps, Ns = np.empty((n, B, k, k)), np.empty((n, B, k, k))
    smoother_pass(_f(steps.F), _f(filt.gain), _f(filt.S), _f(filt.nu), _f(filt.xp),
                  _f(filt.Pp), np.ascontiguousarray(valid, np.bool_), _series(None, B), xs,
                  Ps, rs, Ns)
    return SmootherResult(xs, Ps, rs, Ns)


def smoothed_states(steps: StepModel, filt: FilterResult, valid: np.ndarray) -> np.ndarray:
    """Smoothed states ``x^s`` (n, B, k) only: the ``r`` half of :func:`backward_smoother`
    (``r_{i-1} = Hᵀ ν_i / S_i + L_iᵀ r_i``, ``x^s_i = xp_i + Pp_i r_{i-1}``), without the
    covariances, at a fraction of its cost."""
    if reference.active():
        return reference.smoothed_states(steps, filt, valid)
    n, B, k = filt.xp.shape
    xs = np.empty((n, B, k))
    states_pass(_f(steps.F), _f(filt.gain), _f(filt.S), _f(filt.Pp), _f(filt.nu),
                _f(filt.xp), np.ascontiguousarray(valid, np.bool_), _series(None, B), xs)
    return xs


def backward_sums(steps: StepModel, filt: FilterResult, valid: np.ndarray) -> np.ndarray:
    """The backward sums ``r`` (n, B, k) of :func:`backward_smoother` only."""
    if reference.active():
        return reference.backward_sums(steps, filt, valid)
    n, B, k = filt.xp.shape
    rs = np.empty((n, B, k))
    sums_pass(_f(steps.F), _f(filt.gain), _f(filt.S), _f(filt.nu),
              np.ascontiguousarray(valid, np.bool_), _series(None, B), rs)
    return rs


def refiltered(steps: StepModel, filt: FilterResult, z: np.ndarray, valid: np.ndarray,
               x0: np.ndarray) -> FilterResult:
    """``filt`` with its means re-run on other measurements ``z`` (B, n): the gains, the
    covariances and the innovation variances of a linear Kalman filter do not depend on
    the data, so the filter of ``z`` keeps them and only the means (``xp``, ``nu``,
    ``x_end``) change. ``valid`` must be the mask ``filt`` ran with (its gains are zero at
    the gaps); ``x0`` (B, k) the prior mean. For :func:`smoothed_states` of ``z``."""
    if reference.active():
        return reference.refiltered(steps, filt, z, valid, x0)
    n, B, k = filt.xp.shape
    x = np.array(x0, dtype=np.float64, order="C")
    nu, xp = np.empty((n, B)), np.empty((n, B, k))
    refilter_pass(_f(steps.F), _f(filt.gain), np.ascontiguousarray(valid, np.bool_),
                  _series(None, B), _f(z), x, nu, xp)
    return FilterResult(filt.S, nu, xp, filt.Pp, filt.gain, x, filt.P_end)


def _refilter_of(steps: StepModel, filt: FilterResult, z: np.ndarray, valid: np.ndarray,
                 x0: np.ndarray, src: np.ndarray, kx: int) -> tuple[np.ndarray, np.ndarray]:
    """The innovations (n, B) and the first ``kx`` predicted states (n, B, kx) of the
    filter of ``filt.series(src)`` run on ``z`` (B, n); ``valid`` (A, n) by ``src``."""
    n, B = steps.n, src.size
    nu, xp = np.empty((n, B)), np.empty((n, B, kx))
    refilter_pass(_f(steps.F), _f(filt.gain), np.ascontiguousarray(valid, np.bool_), src,
                  _f(z), np.array(x0, dtype=np.float64, order="C"), nu, xp)
    return nu, xp


def resmoothed(steps: StepModel, filt: FilterResult, z: np.ndarray, valid: np.ndarray,
               x0: np.ndarray, src: np.ndarray | None = None, states: int | None = None
               ) -> np.ndarray:
    """The smoothed states (n, B, ``states`` of k) of other measurements ``z`` (B, n) by
    the smoother of ``filt``'s series ``src[b]`` (its gains), from the prior mean ``x0``
    (B, k): ``smoothed_states(steps, refiltered(steps, filt.series(src), z, valid[src],
    x0), valid[src])``, with ``valid`` (A, n) the mask ``filt`` ran with, without copying
    the gains and covariances per series."""
    k = steps.k
    B = np.asarray(z).shape[0]
    src = _series(src, B)
    kx = k if states is None else int(states)
    if reference.active():
        one = filt.series(src)
        ok = np.asarray(valid)[src]
        return reference.smoothed_states(steps, reference.refiltered(steps, one, z, ok, x0),
                                         ok)[:, :, :kx]
    nu, xp = _refilter_of(steps, filt, z, valid, x0, src, kx)
    # xs = xp + Pp r written over xp (each element read once, before it is written)
    states_pass(_f(steps.F), _f(filt.gain), _f(filt.S), _f(filt.Pp), nu, xp,
                np.ascontiguousarray(valid, np.bool_), src, xp)
    return xp


def residual_innovations(steps: StepModel, filt: FilterResult, z: np.ndarray,
                         valid: np.ndarray, src: np.ndarray) -> FilterResult:
    """The innovations of the filter of ``filt``'s series ``src[b]`` (its gains) run on
    ``z`` (B, n) from a zero prior mean (``valid`` (A, n) by ``src``), for
    :func:`residual_quadratics` (``z`` is not needed after it)."""
    k = steps.k
    src = _series(src, np.asarray(z).shape[0])
    if reference.active():
        one = reference.refiltered(steps, filt.series(src), z, np.asarray(valid)[src],
                                   np.zeros((src.size, k)))
        return FilterResult(one.S, one.nu, xp=one.xp, Pp=one.Pp, gain=one.gain)
    nu, _ = _refilter_of(steps, filt, z, valid, np.zeros((src.size, k)), src, 0)
    return FilterResult(filt.S, nu)


def residual_quadratics(steps: StepModel, filt: FilterResult, innovations: FilterResult,
                        valid: np.ndarray, src: np.ndarray, pairs: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray]:
    """``ρᵀ Q0 ρ`` (n, B) of the backward sums ``ρ`` of the smoother of ``filt``'s series
    ``src[b]`` of the ``innovations`` :func:`residual_innovations` gave (``valid`` (A, n) by
    ``src``), and ``(ρ_a + ρ_b)ᵀ Q0 (ρ_a + ρ_b)`` (n, P) for each row ``(a, b)`` of
    ``pairs`` (P, 2)."""
    n = steps.n
    src = _series(src, innovations.nu.shape[1])
    pairs = np.ascontiguousarray(pairs, dtype=np.int64).reshape(-1, 2)
    if reference.active():
        rho = reference.backward_sums(steps, innovations, np.asarray(valid)[src])
        both = rho[:, pairs[:, 0]] + rho[:, pairs[:, 1]]
        return (np.einsum("nai,nij,naj->na", rho, steps.Q0, rho, optimize=True),
                np.einsum("nai,nij,naj->na", both, steps.Q0, both, optimize=True))
    nu = innovations.nu
    quad, pair_quad = np.empty((n, src.size)), np.empty((n, pairs.shape[0]))
    quad_pass(_f(steps.F), _f(filt.gain), _f(filt.S), nu, np.ascontiguousarray(valid, np.bool_),
              src, _f(steps.Q0), pairs, quad, pair_quad)
    return quad, pair_quad


def simulated_model_runs(steps: StepModel, noise: np.ndarray, kick: np.ndarray,
                         r2: np.ndarray, prior: np.ndarray, rng: np.random.Generator,
                         src: np.ndarray | None = None, out: np.ndarray | None = None
                         ) -> np.ndarray:
    """Measurements (B, n) drawn from the state-space model itself: the first state of
    ``x_i = F_i x_{i-1} + w_i``, ``w_i ~ N(0, noise[b] Q0_i + kick[b] G_i)`` (``noise``
    (B, n), or (S, n) with series ``b`` on row ``src[b]``; ``kick`` (B,)), ``x_0 ~ N(0,
    prior[b])`` (B, k, k), plus white measurement noise of variance ``r2`` (B,) (0: none).

    The draws are those of one ``rng.standard_normal`` call each for the start (B, k), the
    steps (n, B, k), the kicks (events, B, k) and the measurements (B, n), in that order;
    the steps' are made :data:`DRAW_CHUNK` rows at a time, so no (n, B, k) array is held,
    and the runs made without the kicks, whose responses (the model is linear) are added
    once their draws come. ``out``: a C-ordered (B, n) array to write the draws into
    (returned)."""
    noise = np.asarray(noise, float)
    if reference.active():
        z = reference.simulated_model_runs(steps, noise if src is None else noise[src], kick,
                                           r2, prior, rng)
        if out is None:
            return z
        out[...] = z
        return out
    n, k = steps.n, steps.k
    B = np.asarray(kick).size
    src = _series(src, B)
    q_root = _f(matrix_root(steps.Q0))
    events = np.flatnonzero(np.any(steps.G != 0.0, axis=(1, 2))).astype(np.int64)
    g_root = _f(matrix_root(steps.G[events]))
    x = np.einsum("bij,bj->bi", matrix_root(np.asarray(prior, float)), rng.standard_normal((B, k)))
    x = np.array(x, dtype=np.float64, order="C")
    sd = _f(np.sqrt(noise))
    kick_sd = _f(np.sqrt(np.asarray(kick, float)))
    z = np.empty((B, n)) if out is None else out
    F = _f(steps.F)
    none = np.zeros(0, dtype=np.int64)
    for lo in range(0, n, DRAW_CHUNK):
        normals = rng.standard_normal((min(DRAW_CHUNK, n - lo), B, k))
        simulate_chunk(lo, F, q_root, g_root, none, sd, src, kick_sd, normals,
                       np.zeros((0, B, k)), x, z)
    kick_responses(F, g_root, events, kick_sd, rng.standard_normal((events.size, B, k)), z)
    r_sd = np.sqrt(np.asarray(r2, float))
    rows = max(1, DRAW_CHUNK // max(n, 1))  # the (B, n) draws a few series at a time
    for lo in range(0, B, rows):
        hi = min(lo + rows, B)
        z[lo:hi] += r_sd[lo:hi, None] * rng.standard_normal((hi - lo, n))
    return z


def error_covariance(steps: StepModel, filt: FilterResult, sm: SmootherResult,
                     valid: np.ndarray, r2: np.ndarray, lam: np.ndarray, kick: np.ndarray,
                     prior: np.ndarray, parts: bool = False):
    """Covariance (n, B, k, k) of the smoothed states' error ``x − x̂`` when the smoother
    of ``filt``/``sm`` (its gains, from its own model) runs on data whose true process
    noise is ``lam[b] Q0 + kick[b] G`` per step and series (``lam``, ``kick`` (B,)), with
    measurement variance ``r2`` (B,) and prior covariance ``prior`` (B, k, k) at frame 0.

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
    lam = np.broadcast_to(np.asarray(lam, float), (B,))
    kick = np.broadcast_to(np.asarray(kick, float), (B,))
    if reference.active():
        noise = (lam[None, :, None, None] * steps.Q0[:, None]
                 + kick[None, :, None, None] * steps.G[:, None])
        return reference.error_covariance(steps, filt, sm, valid, r2, noise, prior, parts)
    err = np.empty((n, B, k, k))
    covr = np.empty((n, B, k, k)) if parts else np.empty((0, 0, 0, 0))
    error_cov_pass(_f(steps.F), _f(steps.Q0), _f(steps.G), _f(filt.gain), _f(filt.S),
                   _f(filt.Pp), _f(sm.N), np.ascontiguousarray(valid, np.bool_),
                   _series(None, B), _f(np.broadcast_to(np.asarray(r2, float), (B,))), _f(lam),
                   _f(kick), _f(prior), err, covr)
    return (err, covr) if parts else err
