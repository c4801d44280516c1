"""The batched numpy Kalman filter / smoother against filterpy 2.0.0 (the reference)."""

from __future__ import annotations

import numpy as np
import pytest

from trebuchet.ingest.kalman_batch import (
    StepModel,
    backward_smoother,
    batch_kalman_filter,
    polynomial_transition,
    white_noise_covariance,
)
from trebuchet.ingest.kalman_filterpy import filterpy_filter_smoother


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
