"""The self-calibration wired into the ingest path (ingest/calibrated_angles.py): a point log
filmed by a tilted camera with a real lens gets the engine's own calibration, and its bands
widen by what the calibration does not know."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from trebuchet.ingest.calibrated_angles import (
    beam_length,
    calibrated_log,
    disagreement_deg,
    pixel_factor,
    point_tracks,
    widened_by_calibration,
)
from trebuchet.ingest.geometry.camera import camera_from_pose
from trebuchet.ingest.logs.result import ReadLog
from trebuchet.ingest.reconstruction import reconstruction_of
from trebuchet.ingest.smoothing.result import Smoothing, smoothing_of, with_smoothing
from trebuchet.ingest.synthetic.filmed_points import film, simulated_plane_track

SIZE = (1920, 1080)


def _point_log(track, pts):
    """A log as read_log gives it for a point file: atan2 angles, the points in attrs."""
    def direction(a, b):
        d = pts[b] - pts[a]
        return np.arctan2(d[:, 1], d[:, 0])
    phi = np.unwrap(direction("spigot", "projectile"))
    phi -= 2 * np.pi * np.round((phi[0] + np.pi) / (2 * np.pi))
    log = pd.DataFrame({"t": track.t, "theta": direction("pivot", "spigot"),
                        "psi": direction("hinge", "counterweight"), "phi": phi})
    log.attrs["log"] = ReadLog(source="tilted.csv", format="deeplabcut", points={
        "t": track.t} | {f"{r}_{c}": pts[r][:, j] for r in pts for j, c in enumerate("xy")})
    return log


@pytest.fixture(scope="module")
def tilted(horsdal):
    track = simulated_plane_track(horsdal, 120.0, rest=0.2)
    cam = camera_from_pose(2500.0, SIZE, 40.0, (0.0, 6.0), pitch=np.radians(10.0),
                           roll=np.radians(0.3), k1=-0.03)
    pts = film(track, cam, SIZE, 0.5, np.random.default_rng(3))
    return track, _point_log(track, pts)


def _rms_deg(a, b):
    d = np.angle(np.exp(1j * (a - b)))
    return float(np.degrees(np.sqrt(np.nanmean(d**2))))


def _systematic_deg(a, b, frames=9):
    """RMS (°) of the error's running mean over ``frames``: what the camera's geometry
    adds, with the pixel noise (the smoother's business) averaged out."""
    d = np.angle(np.exp(1j * (a - b)))
    ok = np.isfinite(d)
    kernel = np.ones(frames)
    mean = np.convolve(np.where(ok, d, 0.0), kernel, "same") / np.maximum(
        np.convolve(ok.astype(float), kernel, "same"), 1.0)
    return float(np.degrees(np.sqrt(np.mean(mean[ok] ** 2))))


def test_the_tilted_camera_is_calibrated_away(horsdal, tilted):
    track, log = tilted
    out = calibrated_log(log, horsdal)
    assert out is not None
    for name in ("theta", "psi", "phi"):
        true = getattr(track, name)
        raw, fit = log[name].to_numpy(), out.log[name].to_numpy()
        # measured: θ 0.45° -> 0.12°, ψ 0.27° -> 0.07°, φ 0.96° -> 0.10°
        assert _systematic_deg(fit, true) < 0.4 * _systematic_deg(raw, true), name
        assert _rms_deg(fit, true) < _rms_deg(raw, true), name
    assert any("calibrated by the engine" in n for n in out.notes)
    assert all(np.isfinite(sd).all() and (sd >= 0).all() for sd in out.common_sd.values())


def test_a_hidden_marker_changes_no_other_angle(horsdal, tilted):
    """The hinge hidden for six frames: ψ is a gap there and θ (pivot -> spigot, through the
    camera) stays what it is with the hinge in view, to the camera's refit (measured
    0.0045°), instead of being refitted from whichever points the frame has."""
    track, log = tilted
    full = calibrated_log(log, horsdal)
    points = {k: np.array(v, dtype=float, copy=True) for k, v in log.attrs["log"].points.items()}
    hidden = slice(60, 66)
    points["hinge_x"][hidden] = np.nan
    points["hinge_y"][hidden] = np.nan
    gappy = log.copy()
    gappy.loc[gappy.index[hidden], "psi"] = np.nan
    gappy.attrs["log"] = ReadLog(source="hidden.csv", format="deeplabcut", points=points)
    out = calibrated_log(gappy, horsdal)
    moved = np.degrees(np.abs(out.log["theta"].to_numpy() - full.log["theta"].to_numpy()))
    assert moved.max() < 0.02
    assert np.isnan(out.log["psi"].to_numpy()[hidden]).all()
    assert np.isfinite(out.log["psi"].to_numpy()[70:80]).all()


def test_a_calibration_caught_in_a_wrong_camera_is_refused_with_a_warning(
        horsdal, tilted, monkeypatch):
    """A fit whose camera turns the image by 40° (as one caught in a wrong minimum did on the
    backyard engine at 10° tilt) puts the angles far from the image's own: the log keeps
    the image's angles, no calibration sd, and a warning says why."""
    import dataclasses

    import trebuchet.ingest.calibrated_angles as module

    real = module.calibrate

    def rolled(*args, **kwargs):
        cal = real(*args, **kwargs)
        wrong = camera_from_pose(2500.0, SIZE, 40.0, (0.0, 6.0), pitch=np.radians(10.0),
                                 roll=np.radians(40.0))
        return dataclasses.replace(cal, camera=wrong)

    monkeypatch.setattr(module, "calibrate", rolled)
    _, log = tilted
    out = calibrated_log(log, horsdal)
    np.testing.assert_array_equal(out.log[["theta", "psi", "phi"]].to_numpy(),
                                  log[["theta", "psi", "phi"]].to_numpy())
    assert all((sd == 0).all() for sd in out.common_sd.values())
    assert len(out.warnings) == 1 and "was not used" in out.warnings[0]
    assert disagreement_deg(log, out.log) == 0.0


def test_a_log_of_angles_is_left_alone(horsdal, tilted):
    _, log = tilted
    plain = log.copy()
    plain.attrs = {}
    assert point_tracks(plain) is None and calibrated_log(plain, horsdal) is None


def test_points_in_metres_are_fitted_in_pseudo_pixels(tilted):
    """Pixels stay pixels; a file in metres (beam a few units long) is scaled to put the
    beam at 500 pseudo-pixels, so that the calibration's pixel priors mean the same."""
    _, log = tilted
    tracks = point_tracks(log)
    beam = beam_length(tracks)
    assert 200 < beam < 600  # 6.48 m filmed from 40 m with a 2500 px focal length
    assert pixel_factor(tracks, "deeplabcut") == 1.0 == pixel_factor(tracks, "kinovea")
    metres = {r: xy / 40.0 for r, xy in tracks.items()}
    assert pixel_factor(metres, "kinovea") == pytest.approx(500.0 / beam_length(metres))
    assert pixel_factor(metres, "deeplabcut") == 1.0


def test_the_calibration_widens_the_angle_bands_in_quadrature():
    n = 5
    est = pd.DataFrame({"theta": np.zeros(n), "theta_sd": np.full(n, 3e-3)})
    with_smoothing(est, Smoothing(events={}, cov={
        "theta": np.tile(np.diag([9e-6, 1.0, 1.0]), (n, 1, 1))}))
    out = widened_by_calibration(est, {"theta": np.full(n, 4e-3)})
    assert np.allclose(out["theta_sd"], 5e-3)
    assert np.allclose(smoothing_of(out).cov["theta"][:, 0, 0], 25e-6)
    assert np.allclose(smoothing_of(est).cov["theta"][:, 0, 0], 9e-6)  # input untouched


def test_reconstruct_takes_the_calibrated_angles_unless_told_not_to(horsdal, tilted):
    import warnings

    from trebuchet.ingest.reconstruct import ReconstructOptions, reconstruct

    track, log = tilted
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plain = reconstruct(log, horsdal, options=ReconstructOptions(image_calibration="none"))
        fitted = reconstruct(log, horsdal)
    assert any("calibrated by the engine" in n for n in reconstruction_of(fitted).notes)
    assert not any("calibrated by the engine" in n for n in reconstruction_of(plain).notes)
    ok = np.isfinite(fitted["theta"]) & np.isfinite(plain["theta"])
    t = log["t"].to_numpy()[ok]
    truth = np.interp(t, track.t, track.theta)
    assert _rms_deg(fitted["theta"].to_numpy()[ok], truth) < _rms_deg(
        plain["theta"].to_numpy()[ok], truth)
