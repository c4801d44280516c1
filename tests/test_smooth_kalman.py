"""The batched numpy Kalman filter / smoother against filterpy 2.0.0 (the reference)."""

from __future__ import annotations

import numpy as np
import pytest

from trebuchet.ingest.kalman.batch import (
    StepModel,
    backward_smoother,
    backward_sums,
    batch_kalman_filter,
    error_covariance,
    polynomial_transition,
    refiltered,
    simulated_model_runs,
    smoothed_states,
    white_noise_covariance,
)
from trebuchet.ingest.kalman.filterpy_reference import filterpy_filter_smoother


@pytest.mark.parametrize("k", [2, 3, 4])
def test_white_noise_covariance_is_filterpys(k):
    from filterpy.common import Q_continuous_white_noise

    dt = np.array([0.001, 0.3, 1.0, 1.7])
    Q = white_noise_covariance(k, dt)
    for i, h in enumerate(dt):
        np.testing.assert_allclose(Q[i], Q_continuous_white_noise(k, h, 1.0), rtol=1e-14)


def _case(k: int, seed: int = 0, n: int = 300):
    """Variable steps, rest then a kick in acceleration, gaps: one series."""
    rng = np.random.default_rng(seed)
    ts = np.cumsum(rng.uniform(0.7, 1.3, n))
    ts -= ts[0]
    dt = np.diff(ts, prepend=ts[0])
    F = polynomial_transition(k, dt)
    F[0] = np.eye(k)
    Q0 = white_noise_covariance(k, dt)
    Q0[0] = 0.0
    G = np.zeros_like(F)
    i = 80
    Q0[:i] = 0.0
    e = np.zeros(k)
    e[2] = 1.0
    G[i] = np.outer(F[i] @ e, F[i] @ e)
    s = np.maximum(ts - ts[i - 1] - 0.4, 0.0)
    z = 2e-3 * s**3 + 0.02 * s**2 + rng.normal(0.0, 1.0, n)
    valid = rng.random(n) > 0.1
    valid[0] = True
    x0 = np.zeros(k)
    x0[0] = z[0]
    P0 = np.zeros((k, k))
    P0[0, 0] = 100.0
    return StepModel(F, Q0, G), z, valid, x0, P0


@pytest.mark.parametrize("k", [3, 4])
def test_batched_filter_and_smoother_equal_filterpy(k):
    steps, z, valid, x0, P0 = _case(k)
    lam, kick = 1e-3, 0.5
    ref = filterpy_filter_smoother(z, valid, steps, lam, kick, 1.0, x0, P0)
    filt = batch_kalman_filter(
        z[None], valid[None], steps, np.array([lam]), np.array([kick]), np.array([1.0]),
        x0[None], P0[None], store=True,
    )
    sm = backward_smoother(steps, filt, valid[None])
    for j in range(k):
        scale = np.abs(ref["xs"][:, j]).max()
        tol = 1e-10 if j < 3 else 1e-9  # the jerk of "cj" is the worst conditioned
        assert np.abs(sm.x[:, 0, j] - ref["xs"][:, j]).max() <= tol * scale
        assert np.abs(filt.xp[:, 0, j] - ref["xp"][:, j]).max() <= tol * np.abs(
            ref["xp"][:, j]
        ).max()
        # covariances: filterpy's Joseph-form update vs the simple form differ by round-off
        pscale = np.abs(ref["Ps"][:, j, j]).max()
        assert np.abs(sm.P[:, 0, j, j] - ref["Ps"][:, j, j]).max() <= 1e-8 * pscale
    log_s, nu2_s, _ = filt.loglik_sums(valid[None])
    np.testing.assert_allclose(log_s + nu2_s, np.nansum(ref["loglik_terms"]), rtol=1e-10)


def test_batch_equals_separate_runs():
    steps, z, valid, x0, P0 = _case(3, seed=1)
    lams = np.array([1e-6, 1e-3, 1.0])
    B = lams.size
    many = batch_kalman_filter(
        np.tile(z, (B, 1)), np.tile(valid, (B, 1)), steps, lams, np.full(B, 0.5), np.ones(B),
        np.tile(x0, (B, 1)), np.tile(P0, (B, 1, 1)),
    )
    for b, lam in enumerate(lams):
        one = batch_kalman_filter(
            z[None], valid[None], steps, lams[b : b + 1], np.array([0.5]), np.ones(1),
            x0[None], P0[None],
        )
        # BLAS may pick other kernels for other batch sizes: round-off only
        np.testing.assert_allclose(many.S[:, b], one.S[:, 0], rtol=1e-9)
        np.testing.assert_allclose(many.nu[:, b], one.nu[:, 0], rtol=1e-9, atol=1e-9)
        assert lam == lams[b]


@pytest.mark.parametrize("k", [3, 4])
def test_error_covariance_under_the_smoothers_own_model_is_its_posterior(k):
    """Data from the smoother's own model: the error covariance of its gains is its P."""
    steps, z, valid, x0, P0 = _case(k)
    lam, kick, r2 = np.array([1e-3, 3e-2]), np.array([0.5, 2.0]), np.array([1.0, 0.3])
    zz, vv = np.vstack([z, z]), np.vstack([valid, valid])
    x0s, P0s = np.stack([x0, x0]), np.stack([P0, P0])
    filt = batch_kalman_filter(zz, vv, steps, lam, kick, r2, x0s, P0s, store=True)
    sm = backward_smoother(steps, filt, vv)
    err, cov_r = error_covariance(steps, filt, sm, vv, r2, lam, kick, P0s, parts=True)
    for got, want in ((err, sm.P), (cov_r, sm.N)):
        # each element against its two sds (the filter's simple-form update leaves
        # round-off of about 1e-5 of the larger ones near the jerk kick, k = 4)
        d = np.sqrt(np.abs(np.diagonal(want, axis1=2, axis2=3)))
        dd = d[..., :, None] * d[..., None, :]
        assert np.max(np.abs(got - want) - 1e-5 * dd) <= 1e-12 * np.abs(want).max()


def test_error_covariance_of_noise_alone_matches_simulation():
    """Truth without process noise (a kick at the event only), the gains of a smoother
    that expects plenty: the formula's error covariance against 4000 simulated runs,
    far below the smoother's own P in the acceleration."""
    k = 3
    steps, _, valid, x0, P0 = _case(k, n=200)
    lam, kick, r2 = np.array([5e-3]), np.array([0.5]), np.array([1.0])
    rng = np.random.default_rng(7)
    runs = 4000
    # truth: rest, then at the kick an acceleration jump of sd √kick, carried exactly
    x = np.zeros((runs, k))
    x[:, 0] = rng.normal(0.0, np.sqrt(P0[0, 0]), runs)
    truth = np.empty((steps.n, runs, k))
    for i in range(steps.n):
        x = x @ steps.F[i].T
        if np.any(steps.G[i]):
            w = np.linalg.cholesky(kick[0] * steps.G[i] + 1e-300 * np.eye(k))
            x = x + rng.normal(size=(runs, k)) @ w.T
        truth[i] = x
    z = truth[:, :, 0].T + rng.normal(0.0, np.sqrt(r2[0]), (runs, steps.n))
    ok = np.broadcast_to(valid, (1, steps.n))
    filt = batch_kalman_filter(z[:1], ok, steps, lam, kick, r2, x0[None], P0[None], store=True)
    sm = backward_smoother(steps, filt, ok)
    many = refiltered(steps, filt.series(np.zeros(runs, int)), z, np.broadcast_to(valid, z.shape),
                      np.broadcast_to(x0, (runs, k)))
    xs = smoothed_states(steps, many, np.broadcast_to(valid, z.shape))
    err = truth - xs
    seen = np.einsum("nbi,nbj->nij", err, err) / runs
    want = error_covariance(steps, filt, sm, ok, r2, np.zeros(1), kick, P0[None])[:, 0]
    for j in range(k):
        rel = seen[100:, j, j] / want[100:, j, j]
        assert np.all(np.abs(rel - 1.0) < 0.12), (j, rel.min(), rel.max())
    assert np.all(want[100:, 2, 2] < 0.5 * sm.P[100:, 0, 2, 2])


def test_backward_sums_are_the_smoothers():
    steps, z, valid, x0, P0 = _case(3)
    filt = batch_kalman_filter(z[None], valid[None], steps, np.array([1e-3]), np.array([0.5]),
                               np.array([1.0]), x0[None], P0[None], store=True)
    sm = backward_smoother(steps, filt, valid[None])
    np.testing.assert_allclose(backward_sums(steps, filt, valid[None]), sm.r, rtol=1e-12,
                               atol=1e-15)


def test_simulated_model_runs_have_the_models_covariance():
    """Draws of the state-space model: the variance of the measured component at every
    frame against the exact propagation ``P_i = F P Fᵀ + λ Q0_i + kick G_i`` (+ r2)."""
    k = 3
    steps, _, _, _, P0 = _case(k, n=200)
    runs = 4000
    lam, kick, r2 = 2e-3, 0.5, 0.3
    z = simulated_model_runs(steps, np.full((runs, steps.n), lam), np.full(runs, kick),
                             np.full(runs, r2), np.broadcast_to(P0, (runs, k, k)),
                             np.random.default_rng(3))
    P = P0.copy()
    want = np.empty(steps.n)
    for i in range(steps.n):
        P = steps.F[i] @ P @ steps.F[i].T + lam * steps.Q0[i] + kick * steps.G[i]
        want[i] = P[0, 0] + r2
    rel = z.var(axis=0) / want
    assert np.all(np.abs(rel - 1.0) < 0.1), (rel.min(), rel.max())
    assert np.all(np.abs(z.mean(axis=0)) < 4 * np.sqrt(want / runs))
    quiet = simulated_model_runs(steps, np.zeros((2, steps.n)), np.zeros(2), np.zeros(2),
                                 np.zeros((2, k, k)), np.random.default_rng(3))
    assert np.all(quiet == 0.0)
