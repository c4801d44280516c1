"""smooth(): accuracy, honest bands, events, noise tuning, gaps, overrides, bad input."""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from trebuchet.core.errors import TrebuchetDataWarning, TrebuchetInputError
from trebuchet.ingest.smoothing.smooth import ANGLES, smooth
from trebuchet.ingest.synthetic.shaped_log import SHAPES, synthetic_log

TRIGGER, RELEASE = 0.3, 1.3


def _errors(est: pd.DataFrame, truth: pd.DataFrame, name: str):
    """Relative RMS error (to the peak) and ±2 sd coverage over the moving frames."""
    moving = (truth["t"] > TRIGGER).to_numpy()
    err = (est[name] - truth[name]).to_numpy()
    sd = est[name + "_sd"].to_numpy()
    ok = np.isfinite(err) & moving
    peak = np.abs(truth[name].to_numpy()[moving]).max()
    return np.sqrt(np.mean(err[ok] ** 2)) / peak, np.mean(np.abs(err[ok]) <= 2 * sd[ok])


@pytest.fixture(scope="module")
def shot240():
    log, truth = synthetic_log(240, 0.5, drop_fraction=0.03, seed=3)
    return log, truth, smooth(log)


def test_columns_rows_and_attrs(shot240):
    log, _, est = shot240
    assert list(est.index) == list(log.index)
    np.testing.assert_array_equal(est["t"], log["t"])
    for a in ANGLES:
        for suf in ("", "_d", "_dd"):
            assert a + suf in est and a + suf + "_sd" in est
        assert est.attrs["smoothing"].cov[a].shape == (len(log), 3, 3)
        noise = est.attrs["smoothing"].noise[a]
        assert noise["q"] > 0 and noise["r_sd"] > 0
    assert set(est.attrs["events"]) >= {"trigger", "release"}
    assert est.attrs["smoothing"].model == "ca"
    assert np.isfinite(est.attrs["smoothing"].loglik)
    var = np.diagonal(est.attrs["smoothing"].cov["theta"], axis1=1, axis2=2)
    np.testing.assert_allclose(np.sqrt(var[:, 2]), est["theta_dd_sd"], rtol=1e-12)


def test_derivative_accuracy_and_honest_bands(shot240):
    _, truth, est = shot240
    for a in ANGLES:
        rms_d, cov_d = _errors(est, truth, a + "_d")
        rms_dd, cov_dd = _errors(est, truth, a + "_dd")
        assert rms_d < 0.02, (a, rms_d)
        assert rms_dd < 0.10, (a, rms_dd)
        # truth inside ±2 sd for most frames, but the band is not padded either
        assert 0.85 <= cov_d <= 0.998, (a, cov_d)
        assert 0.85 <= cov_dd <= 0.998, (a, cov_dd)


@pytest.mark.parametrize("fps,noise", [(60, 2.0), (1000, 0.1)])
def test_accuracy_at_extreme_rates(fps, noise):
    log, truth = synthetic_log(fps, noise, drop_fraction=0.03, seed=5)
    est = smooth(log)
    for a in ANGLES:
        rms_dd, cov_dd = _errors(est, truth, a + "_dd")
        assert rms_dd < 0.15, (a, rms_dd)
        assert cov_dd >= 0.85, (a, cov_dd)
        assert _errors(est, truth, a + "_d")[0] < 0.04


@pytest.mark.parametrize("fps,noise", [(240, 0.5), (1000, 0.1), (60, 0.5)])
def test_trigger_found_within_two_frames(fps, noise):
    log, _ = synthetic_log(fps, noise, seed=7, trigger=0.2137)
    est = smooth(log)
    assert abs(est.attrs["events"]["trigger"] - 0.2137) * fps <= 2.0
    assert est.attrs["smoothing"].event_sources["trigger"] == "detected"


def test_rest_before_trigger_is_exact(shot240):
    _, _, est = shot240
    before = est["t"] < est.attrs["events"]["trigger"]
    assert np.all(est.loc[before, "theta_d"] == 0) and np.all(est.loc[before, "psi_dd"] == 0)


@pytest.mark.parametrize("noise", [0.1, 2.0])
def test_noise_sd_recovered(noise):
    log, _ = synthetic_log(120, noise, seed=11)
    est = smooth(log)
    for a in ANGLES:
        ratio = est.attrs["smoothing"].noise[a]["r_sd"] / np.deg2rad(noise)
        assert 0.8 < ratio < 1.2, (a, ratio)


def test_log_starting_in_motion_has_no_trigger():
    log, truth = synthetic_log(240, 0.5, seed=2, trigger=-0.2)
    est = smooth(log)
    assert est.attrs["events"]["trigger"] is None
    rms_dd, _ = _errors(est, truth, "psi_dd")
    assert rms_dd < 0.15


def test_gaps_are_predicted_through_with_wider_bands():
    log, truth = synthetic_log(240, 0.5, drop_fraction=0.1, seed=4)
    gap = (log["t"] > 0.8) & (log["t"] < 0.88)
    log.loc[gap, list(ANGLES)] = np.nan
    est = smooth(log)
    inside = est.loc[gap]
    assert inside[list(ANGLES)].notna().all().all()
    assert inside["theta_sd"].max() > 1.3 * est.loc[~gap & (log["t"] > 0.4), "theta_sd"].mean()
    err = (inside["theta_d"] - truth.loc[gap, "theta_d"]).abs()
    assert (err <= 3 * inside["theta_d_sd"]).mean() > 0.9


def test_sling_track_end_gives_release_and_no_extrapolation():
    log, _ = synthetic_log(240, 0.3, seed=6)
    after = log["t"] > RELEASE + 0.5 / 240
    log.loc[after, "phi"] = np.nan
    est = smooth(log)
    rel = est.attrs["events"]["release"]
    assert rel is not None and abs(rel - RELEASE) * 240 <= 6
    assert est.loc[after, ["phi", "phi_d", "phi_dd", "phi_dd_sd"]].isna().all().all()
    assert est.loc[after, "theta_dd"].notna().all()
    notes = est.attrs["smoothing"].notes
    assert any("phi" in note and "not extrapolated" in note for note in notes)
    assert np.isnan(est.attrs["smoothing"].cov["phi"][after.to_numpy()]).all()


def test_large_jump_in_acceleration_is_found_as_release():
    shapes = {k: replace(v, jump=8 * v.jump) for k, v in SHAPES.items()}
    log, _ = synthetic_log(240, 0.3, seed=8, shapes=shapes, release=1.1)
    est = smooth(log)
    rel = est.attrs["events"]["release"]
    assert rel is not None and abs(rel - 1.1) * 240 <= 2


def test_no_release_reported_without_one():
    log, _ = synthetic_log(240, 0.5, seed=9, release=None)
    assert smooth(log).attrs["events"]["release"] is None


def test_overrides_are_respected():
    log, _ = synthetic_log(120, 0.5, seed=10)
    est = smooth(log, q=50.0, r={"theta": 0.01}, events={"trigger": 0.31, "release": None})
    assert est.attrs["events"] == {"trigger": 0.31, "release": None}
    assert est.attrs["smoothing"].event_sources["trigger"] == "given"
    for a in ANGLES:
        assert est.attrs["smoothing"].noise[a]["q"] == pytest.approx(50.0, rel=1e-12)
    assert est.attrs["smoothing"].noise["theta"]["r_sd"] == pytest.approx(0.01, rel=1e-12)
    assert est.attrs["smoothing"].noise["theta"]["source"] == "given"
    assert est.attrs["smoothing"].noise["psi"]["source"] == "maximum likelihood"
    before = est["t"] <= 0.31
    assert np.all(est.loc[before, "phi_d"] == 0)


def test_untracked_angle_gives_nan_columns():
    log, _ = synthetic_log(120, 0.5, seed=12)
    log["phi"] = np.nan
    with pytest.warns(TrebuchetDataWarning, match="phi is not tracked"):
        est = smooth(log)
    assert est[["phi", "phi_d_sd"]].isna().all().all()
    assert est["theta_dd"].notna().all()
    assert "phi" not in est.attrs["smoothing"].noise


def test_filterpy_backend_agrees():
    log, _ = synthetic_log(60, 0.5, seed=13, duration=1.2)
    a = smooth(log)
    b = smooth(log, backend="filterpy")
    for col in ("theta", "psi_d", "phi_dd"):
        scale = np.abs(a[col]).max()
        assert np.abs(a[col] - b[col]).max() <= 1e-9 * scale
        np.testing.assert_allclose(a[col + "_sd"], b[col + "_sd"], rtol=1e-6, atol=1e-9 * scale)


def test_constant_jerk_model():
    log, truth = synthetic_log(240, 0.5, seed=14)
    est = smooth(log, model="cj")
    assert est.attrs["smoothing"].cov["theta"].shape[1:] == (4, 4)
    assert _errors(est, truth, "psi_dd")[0] < 0.10


def test_wrapped_angle_is_unwrapped_with_warning():
    log, truth = synthetic_log(120, 0.1, seed=15)
    log["phi"] = np.angle(np.exp(1j * log["phi"]))  # into (-π, π]
    with pytest.warns(TrebuchetDataWarning, match="phi"):
        est = smooth(log)
    assert _errors(est, truth, "phi_d")[0] < 0.03


def test_two_seconds_at_1000fps():
    """A long log runs through (its time is measured in bench/ingest_accuracy.py, not
    asserted here)."""
    log, truth = synthetic_log(1000, 0.5, seed=16)
    est = smooth(log)
    assert len(est) == len(log) >= 2000
    assert _errors(est, truth, "theta_d")[0] < 0.05


@pytest.mark.parametrize(
    "mutate,match",
    [
        (lambda d: d.iloc[:5], "5 rows"),
        (lambda d: d.drop(columns="psi"), "'psi'"),
        (lambda d: d.assign(t=d["t"].where(d.index != 7, 0.0)), r"'t', row 7"),
        (lambda d: d.assign(theta=d["theta"].where(d.index != 4, np.inf)), "'theta', row 4"),
        (lambda d: d.assign(phi=np.where(d.index < 3, 0.1, np.nan)), "'phi' has 3 valid"),
    ],
)
def test_bad_input_names_column_and_row(mutate, match):
    log, _ = synthetic_log(60, 0.5, seed=17, duration=0.6)
    with pytest.raises(TrebuchetInputError, match=match):
        smooth(mutate(log))


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"model": "cv"}, "model"),
        ({"q": -1.0}, "positive"),
        ({"events": {"trigger": 99.0}}, "outside"),
        ({"events": {"launch": 0.2}}, "unknown event"),
        ({"events": {"trigger": 0.4, "release": 0.3}}, "not after"),
    ],
)
def test_bad_arguments(kwargs, match):
    log, _ = synthetic_log(60, 0.5, seed=18, duration=0.6)
    with pytest.raises(TrebuchetInputError, match=match):
        smooth(log, **kwargs)


def test_no_runtime_warnings():
    log, _ = synthetic_log(1000, 2.0, seed=19, drop_fraction=0.05)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        smooth(log, model="cj")


def test_piece_before_the_release_is_bounded_by_the_whole_log():
    """The last third of the swing alone takes about 3× the whole log's q (measured on the
    paper's engine at 240 fps, 0.3°); with pieces on it is bounded by it, the others are
    free."""
    from pathlib import Path

    from trebuchet.ingest.smoothing.smooth import SmoothSettings
    from trebuchet.ingest.synthetic.simulated_log import simulated_log
    from trebuchet.model.scene import Scene

    scene = Scene.from_toml(Path(__file__).resolve().parents[1] / "data_samples"
                            / "horsdal_large.toml")
    log, truth = simulated_log(scene, 240, 0.3, seed=11, drop_fraction=0.02, t0=5.0)
    release = truth.attrs["events"]["release"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bounded = smooth(log, settings=SmoothSettings(shot_pieces=3))
        free = smooth(log, settings=SmoothSettings(shot_pieces=3,
                                                   release_piece_max_decades=np.inf))
    for name in ANGLES:
        noise = bounded.attrs["smoothing"].noise[name]
        pieces = noise["pieces"]
        assert len(pieces) == 4  # three in the shot, the flight
        last = [p for p in pieces if p["t_start"] < release <= p["t_end"] + 1 / 240]
        assert len(last) == 1 and last[0]["q"] <= noise["q"] * (1 + 1e-9)
        assert pieces[0]["q"] < noise["q"]  # the trough: far below
        unbounded = free.attrs["smoothing"].noise[name]
        assert max(p["q"] for p in unbounded["pieces"]) > 2 * unbounded["q"]
