"""The compiled passes of the smoother and the load propagation against their numpy forms
(``ingest/kalman/reference.py``, switched on by ``numpy_passes()``): pass by pass on random
series, and end to end on shipped samples (issue 25: no result changes beyond round-off)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.ndimage import gaussian_filter1d

import trebuchet.ingest.loads_table as loads_table_module
from tests.test_smooth_kalman import _case
from trebuchet.ingest.kalman import batch
from trebuchet.ingest.kalman.reference import numpy_passes
from trebuchet.ingest.kalman.steps import matrix_root
from trebuchet.ingest.reconstruct import reconstruct
from trebuchet.ingest.smoothing.band import FFT_RADIUS, gaussian_window
from trebuchet.ingest.uncertainty import propagate

SAMPLES = Path(__file__).resolve().parents[1] / "data_samples"


def _passes(k: int) -> dict[str, np.ndarray]:
    """Every pass of :mod:`trebuchet.ingest.kalman.batch` on three series of one random
    case (variable steps, a rest, a kick, gaps), in whatever form is switched on."""
    steps, z, valid, x0, P0 = _case(k, n=300)
    lam, kick = np.array([1e-4, 1e-3, 3e-2]), np.array([0.5, 0.5, 2.0])
    r2 = np.array([1.0, 1.0, 0.3])
    zz, vv = np.vstack([z] * 3), np.vstack([valid] * 3)
    x0s, P0s = np.stack([x0] * 3), np.stack([P0] * 3)
    f = batch.batch_kalman_filter(zz, vv, steps, lam, kick, r2, x0s, P0s, store=True)
    sm = batch.backward_smoother(steps, f, vv)
    ll = batch.filter_loglik(z[None], valid[None], valid[None].astype(float), steps, lam, kick,
                             r2, x0s, P0s, src=np.zeros(3, int))
    err, cov_r = batch.error_covariance(steps, f, sm, vv, r2, lam, kick, P0s, parts=True)
    src = np.array([0, 1, 1, 2])
    other = np.random.default_rng(3).normal(size=(4, steps.n))
    innovations = batch.residual_innovations(steps, f, other, vv, src)
    quad, pair = batch.residual_quadratics(steps, f, innovations, vv, src, np.array([[0, 1]]))
    draws = batch.simulated_model_runs(
        steps, np.vstack([np.zeros(steps.n), np.full(steps.n, 1e-3)]), np.array([0.5, 0.5, 0.0]),
        np.array([1.0, 0.0, 1.0]), P0s, np.random.default_rng(5), src=np.array([0, 1, 1]))
    return {"S": f.S, "nu": f.nu, "xp": f.xp, "Pp": f.Pp, "gain": f.gain, "x_end": f.x_end,
            "P_end": f.P_end, "log_s": ll.log_s, "nu2_s": ll.nu2_s, "x": sm.x, "P": sm.P,
            "r": sm.r, "N": sm.N, "states": batch.smoothed_states(steps, f, vv),
            "sums": batch.backward_sums(steps, f, vv),
            "refiltered": batch.refiltered(steps, f, 0.5 * zz, vv, x0s).xp,
            "resmoothed": batch.resmoothed(steps, f, other, vv, np.zeros((4, k)), src=src),
            "err": err, "cov_r": cov_r, "quad": quad, "pair": pair, "draws": draws}


@pytest.mark.parametrize("k", [3, 4])
def test_compiled_passes_equal_their_numpy_forms(k):
    compiled = _passes(k)
    with numpy_passes():
        numpy = _passes(k)
    # the filter sums in the same order in both forms: the same to the last bit
    for name in ("S", "nu", "xp", "Pp", "gain", "x_end", "P_end", "log_s", "nu2_s"):
        np.testing.assert_array_equal(compiled[name], numpy[name], err_msg=name)
    # the backward passes (BLAS and einsum in numpy): round-off of the largest element
    for name, got in compiled.items():
        want = numpy[name]
        scale = np.max(np.abs(want))
        assert np.max(np.abs(got - want)) <= 1e-10 * scale, name


def test_gaussian_window_is_scipys():
    """To the last bit up to FFT_RADIUS steps of the kernel (direct sums in scipy's order),
    to round-off beyond (the FFT), with the same exact zeros where the kernel sees only
    zeros."""
    rng = np.random.default_rng(0)
    for shape, sigma in (((500,), 11.7), ((400, 8), 10.2), ((300,), 0.7), ((50,), 30.0),
                         ((3000,), 37.3), ((2000, 8), 90.0)):
        x = rng.standard_normal(shape) * 10 ** rng.uniform(-5, 5, shape)
        x[:40] = 0.0
        x[-400:] = 0.0
        got = gaussian_window(x, sigma)
        want = gaussian_filter1d(x, sigma, axis=0, mode="constant")
        if int(4 * sigma + 0.5) <= FFT_RADIUS:
            np.testing.assert_array_equal(got, want)
        else:
            assert np.max(np.abs(got - want)) <= 1e-14 * np.max(np.abs(want))
            np.testing.assert_array_equal(got == 0.0, want == 0.0)


def test_matrix_root_does_not_flip_with_the_last_bit():
    """A rank-one kick covariance d dᵀ (the release's on video_paper_dlc.csv): LAPACK's
    eigenvector flipped sign for a release 4e-16 s later, and with it every draw's kick."""
    d = np.array([0.40311659, 0.89790488, 1.0])
    G = np.outer(d, d)
    roots = [matrix_root(G * (1.0 + e)) for e in (0.0, 2e-16, 4e-16, -2e-16, 1e-13)]
    for root in roots:
        np.testing.assert_allclose(root @ root.T, G, atol=1e-12)
        np.testing.assert_allclose(root, roots[0], atol=1e-7)
    assert roots[0][:, -1] @ d > 0  # the largest component positive
    stack = np.stack([G, 2.0 * G, G])  # a stack: each distinct matrix once, the same roots
    np.testing.assert_array_equal(matrix_root(stack)[2], matrix_root(stack)[0])


def test_compiled_propagation_equals_its_numpy_form_and_chunks_change_nothing():
    rng = np.random.default_rng(4)
    n = 70
    state = pd.DataFrame({c: rng.normal(size=n) for c in
                          ("theta", "theta_d", "theta_dd", "psi", "psi_d", "psi_dd")})
    cov = {}
    for a in ("theta", "psi"):
        m = rng.normal(size=(n, 3, 3))
        cov[a] = m @ np.swapaxes(m, 1, 2) * 0.01
    cov["psi"][5] = np.nan  # unknown on a row: its sd NaN, no error

    def loads(s):
        th, ps = np.asarray(s["theta"]), np.asarray(s["psi_d"])
        return pd.DataFrame({"y": np.sin(th) * ps**2 + np.asarray(s["theta_dd"]),
                             "w": np.hypot(th, np.asarray(s["psi_dd"])), "big": np.exp(50 * th)})

    for order in (1, 2):
        whole = propagate(loads, state, cov, order=order)
        with numpy_passes():
            numpy = propagate(loads, state, cov, order=order)
        chunked = propagate(loads, state, cov, order=order, chunk=16, columns=True)
        for other in (numpy, chunked):
            for field in ("value", "sd", "by_order"):
                np.testing.assert_array_equal(getattr(whole, field), getattr(other, field))


def _quiet_reconstruct(path: Path, scene: str, **kwargs) -> pd.DataFrame:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return reconstruct(path, SAMPLES / scene, **{"method": "smooth", **kwargs})


@pytest.mark.parametrize("sample, scene, kwargs", [
    ("horsdal_240fps.csv", "horsdal_large.toml", {}),
    ("backyard_240fps.csv", "backyard.toml", {}),
    ("horsdal_tracker.txt", "horsdal_large.toml",
     {"columns": {"beam": "theta", "arm": "psi", "sling": "phi"}}),
    ("horsdal_dlc.csv", "horsdal_large.toml",
     {"fps": 120, "min_likelihood": 0.9, "points": {
         "pivot": "axle", "spigot": "arm_tip", "hinge": "hinge", "counterweight": "weight",
         "projectile": "stone"}}),
])
def test_reconstruct_of_a_shipped_sample_equals_its_numpy_passes(sample, scene, kwargs):
    """The compiled passes against the numpy forms (the previous code path, bit for bit on
    these samples) end to end: every column and event. Values agree to 1e-9 of each
    column's peak (measured: 4e-10 at most); the sds to 1e-7 (measured: 3.4e-8 at most), at
    the rows next to an event's kick, where the smoothed covariance ``Pp − Pp N Pp`` is
    about 1e-8 of its two terms and the two forms round them differently."""
    fast = _quiet_reconstruct(SAMPLES / sample, scene, **kwargs)
    with numpy_passes():
        slow = _quiet_reconstruct(SAMPLES / sample, scene, **kwargs)
    assert list(fast.columns) == list(slow.columns)
    for c in fast.columns:
        a, b = fast[c].to_numpy(dtype=float), slow[c].to_numpy(dtype=float)
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b), err_msg=c)
        ok = ~np.isnan(b)
        if not ok.any():
            continue
        tol = 1e-7 if c.endswith("_sd") else 1e-9
        assert np.max(np.abs(a[ok] - b[ok])) <= tol * max(np.max(np.abs(b[ok])), 1e-300), c
    for key, when in slow.attrs["events"].items():
        got = fast.attrs["events"][key]
        assert (got is None) == (when is None)
        assert when is None or abs(got - when) <= 1e-9
    assert fast.attrs["reconstruction"].notes == slow.attrs["reconstruction"].notes


def test_chunked_load_propagation_changes_no_row(monkeypatch):
    """Evaluated a few rows at a time, the rows in flight with the last row in the sling:
    the loads and their sd of the whole table to the last bit."""
    whole = _quiet_reconstruct(SAMPLES / "horsdal_240fps.csv", "horsdal_large.toml")
    monkeypatch.setattr(loads_table_module, "chunk_rows", lambda n: 37)
    chunked = _quiet_reconstruct(SAMPLES / "horsdal_240fps.csv", "horsdal_large.toml")
    assert (whole["phase"] == 3).sum() > 37  # flight rows in chunks without the release row
    for c in whole.columns:
        np.testing.assert_array_equal(whole[c].to_numpy(), chunked[c].to_numpy(), err_msg=c)


def _peak_kib_a_row(scene, seconds: float, method: str | None) -> float:
    """Peak of the allocations (tracemalloc sees numpy's) during one ``reconstruct`` of a
    ``seconds`` s log of ``scene`` at 1000 fps, KiB per row, after a first call on a short
    one (the kernels compiled or loaded)."""
    import tracemalloc

    from trebuchet.ingest.synthetic.simulated_log import simulated_log

    log, _ = simulated_log(scene, 1000, 0.5, rest=0.3, after_release=seconds - 0.3 - 0.997)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reconstruct(log.iloc[:800], scene, method=method)
        tracemalloc.start()
        try:
            done = reconstruct(log, scene, method=method)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
    assert done.attrs["reconstruction"].method == (method or "fit")
    return peak / len(log) / 1024


def test_reconstruct_holds_less_than_4_kib_a_row(horsdal):
    """Issue 25: at most 4 KiB of memory a row (36 KiB before: the noise search's and the
    band's (n, B, k, k) arrays, 19 load evaluations of the whole log held at once), on a 4 s
    log at 1000 fps."""
    kib = _peak_kib_a_row(horsdal, 4.0, "smooth")  # the smoother's passes
    assert kib < 4, kib


@pytest.mark.parametrize("seconds", [4.0, 20.0])
def test_fitted_loads_hold_less_than_4_kib_a_row(horsdal, seconds):
    """Issues 23 and 25: the default method, the loads of the fitted engine, in the same
    4 KiB a row (9.6 KiB before on the 4 s log: the gradients of every load by each fitted
    entry, p × m numbers a row, and the residual's propagation held for the whole log)."""
    kib = _peak_kib_a_row(horsdal, seconds, None)
    assert kib < 4, kib
