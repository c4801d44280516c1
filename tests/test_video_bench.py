"""Smoke tests of the video bench (bench/video): camera model, exporters, tracker, one shot."""

from __future__ import annotations

import warnings

import cv2
import numpy as np
import pytest

import trebuchet as tb
from bench.video.camera import (
    Camera,
    camera_framing,
    camera_matrix,
    centre,
    project,
    rotation,
    undistort_pixels,
)
from bench.video.export import (
    kinovea_coordinates,
    kinovea_time,
    write_deeplabcut,
    write_kinovea,
)
from bench.video.shot import KINOVEA_NAMES, Pose, tracked_shot
from bench.video.track import TrackerSettings, track_points
from bench.video.truth import POINTS, Filming, engine_points, frame_times, truth_table

TILTED = Camera(aim=(3.0, 6.0, 0.0), distance=40.0, tilt_deg=10.0, roll_deg=0.3,
                focal_px=1000.0, k1=-0.03)


def _world_points(n: int = 50, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-6, 12, n), rng.uniform(0, 14, n), rng.uniform(-1, 1, n)])


def test_projection_matches_opencv():
    p = _world_points()
    rvec, _ = cv2.Rodrigues(rotation(TILTED))
    tvec = -rotation(TILTED) @ centre(TILTED)
    expected, _ = cv2.projectPoints(p, rvec, tvec, camera_matrix(TILTED),
                                    np.array([TILTED.k1, TILTED.k2, 0.0, 0.0]))
    np.testing.assert_allclose(project(TILTED, p), expected[:, 0, :], atol=1e-6)


def test_undistortion_inverts_distortion():
    p = _world_points()
    pinhole = Camera(**{**TILTED.__dict__, "k1": 0.0})
    uv = project(TILTED, p)
    np.testing.assert_allclose(undistort_pixels(TILTED, uv), project(pinhole, p), atol=1e-6)
    by_cv2 = cv2.undistortPoints(uv[:, None, :], camera_matrix(TILTED),
                                 np.array([TILTED.k1, 0.0, 0.0, 0.0]), P=camera_matrix(TILTED))
    np.testing.assert_allclose(by_cv2[:, 0, :], project(pinhole, p), atol=1e-3)


def test_roll_and_tilt_move_the_image_as_documented():
    level = Camera(aim=(0.0, 5.0, 0.0), distance=20.0, focal_px=500.0)
    rolled = Camera(aim=(0.0, 5.0, 0.0), distance=20.0, roll_deg=1.0, focal_px=500.0)
    a, b = project(level, np.array([[-5.0, 5.0], [5.0, 5.0]]))
    assert a[1] == pytest.approx(b[1])  # level: the horizontal stays horizontal
    a, b = project(rolled, np.array([[-5.0, 5.0], [5.0, 5.0]]))
    assert b[1] < a[1]  # positive roll: the horizontal rises to the right (v is down)
    tilted = Camera(aim=(0.0, 5.0, 0.0), distance=20.0, tilt_deg=10.0, focal_px=500.0)
    assert centre(tilted)[1] < 5.0  # pitched up: the camera stands below its aim


def test_framing_puts_the_box_inside_the_image():
    cam = camera_framing((-2.0, 0.0, 9.0, 15.0), 40.0, tilt_deg=15.0, roll_deg=1.0, k1=-0.08)
    corners = np.array([[-2.0, 0.0], [9.0, 0.0], [-2.0, 15.0], [9.0, 15.0]])
    uv = project(cam, corners)
    assert (uv >= 0).all() and (uv[:, 0] < 640).all() and (uv[:, 1] < 480).all()


@pytest.fixture(scope="module")
def backyard_truth():
    scene = tb.Scene.from_toml("data_samples/backyard.toml")
    filming = Filming(fps=120.0, shutter=1 / 1000)
    t = frame_times(scene, filming)
    truth = truth_table(scene, t, filming.rest, filming.after)
    return scene, truth, engine_points(scene, truth)


def _read(path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return tb.read_log(path, **kw)


def test_deeplabcut_export_is_read_back(tmp_path, backyard_truth):
    scene, truth, points = backyard_truth
    cam = camera_framing((-4.0, 0.0, 4.0, 5.0), 6.6)
    uv = project(cam, points)
    likelihood = np.full(uv.shape[:2], 0.99)
    path = write_deeplabcut(tmp_path / "shot.csv", POINTS, uv, likelihood)
    lines = path.read_text().splitlines()
    assert [ln.split(",")[0] for ln in lines[:4]] == ["scorer", "bodyparts", "coords", "0"]
    assert lines[2].split(",")[1:4] == ["x", "y", "likelihood"]
    log = _read(path, fps=120.0)
    assert log.attrs["log"].format == "deeplabcut"
    assert log.attrs["log"].point_names == {p: p for p in POINTS}  # found by their own names
    np.testing.assert_allclose(log["t"], truth["t"], atol=1e-9)
    held = truth["phase"].to_numpy() <= 2
    for a in ("theta", "psi"):
        np.testing.assert_allclose(log[a], truth[a], atol=1e-9)
    np.testing.assert_allclose(log["phi"][held], truth["phi"][held], atol=1e-9)


def test_kinovea_export_is_read_back(tmp_path, backyard_truth):
    scene, truth, points = backyard_truth
    cam = camera_framing((-4.0, 0.0, 4.0, 5.0), 6.6)
    uv = project(cam, points)
    coords = kinovea_coordinates(uv, uv[0, 0], 0.01)
    path = write_kinovea(tmp_path / "shot.csv", KINOVEA_NAMES, truth["t"].to_numpy(), coords,
                         120.0)
    raw = path.read_bytes()
    assert raw.startswith(b'"Time","Beam/pivot/X","Beam/pivot/Y"') and b"\r\n" in raw
    points_map = dict(zip(POINTS, KINOVEA_NAMES, strict=True))
    log = _read(path, fps=120.0, points=points_map)
    assert log.attrs["log"].format == "kinovea"
    assert log.attrs["log"].point_names == points_map
    np.testing.assert_allclose(log["t"], truth["t"], atol=1e-9)
    for a in ("theta", "psi"):  # 7 significant digits: about 1e-7 of the coordinates
        np.testing.assert_allclose(log[a], truth[a], atol=1e-5)


def test_kinovea_time_columns_follow_the_time_code():
    t = np.arange(4) / 120.0
    assert list(kinovea_time(t, 120.0, "ms")) == [0.0, 8.0, 17.0, 25.0]
    assert list(kinovea_time(t, 120.0, "classic")) == [0.0, 0.008, 0.017, 0.025]
    assert kinovea_time(t, 120.0, "milliseconds")[1] == pytest.approx(1000 / 120)
    assert list(kinovea_time(t, 120.0, "frames")) == [0.0, 1.0, 2.0, 3.0]


def _moving_disk(n: int, start: tuple[float, float], step: tuple[float, float]):
    for k in range(n):
        img = np.full((120, 160), 120, np.uint8)
        c = (round((start[0] + k * step[0]) * 16), round((start[1] + k * step[1]) * 16))
        cv2.circle(img, c, 6 * 16, 20, -1, cv2.LINE_AA, 4)
        cv2.circle(img, c, 4 * 16, 240, -1, cv2.LINE_AA, 4)
        yield cv2.GaussianBlur(img, (0, 0), 0.8)  # the lens


def test_tracker_follows_a_marker_from_one_click():
    frames = list(_moving_disk(30, (20.0, 30.0), (3.3, 1.7)))
    xy, score = track_points(frames, np.array([[20.0, 30.0]]), 4.0, TrackerSettings())
    truth = np.array([[20.0 + 3.3 * k, 30.0 + 1.7 * k] for k in range(30)])
    assert np.abs(xy[:, 0] - truth).max() < 0.3
    assert score.min() > 0.9


def test_tracked_shot_end_to_end(tmp_path):
    scene = tb.Scene.from_toml("data_samples/backyard.toml")
    shot = tracked_shot(scene, Pose(6.6, tilt_deg=5.0, roll_deg=0.3, k1=-0.03, size=(320, 240)),
                        60.0, 1 / 250, True, 3, out_dir=tmp_path, name="small")
    assert shot.path == tmp_path / "small.csv" and shot.path.exists()
    assert len(shot.truth) == shot.positions.shape[0] == shot.scores.shape[0]
    log = _read(shot.path, **shot.read)
    assert log.attrs["log"].format == "deeplabcut" and len(log) > 20
    assert np.nanmax(np.abs(np.rad2deg(log["theta"] - shot.truth["theta"].to_numpy()[:len(log)]))
                     ) < 5.0


def test_shipped_video_sample_reads_with_its_scene():
    log = _read("data_samples/video_tilted_dlc.csv", fps=120.0)
    assert log.attrs["log"].format == "deeplabcut"
    assert log.attrs["log"].point_names == {p: p for p in POINTS}
    assert log["t"].iloc[0] == 0.0 and log.attrs["log"].frame[-1] == 263
    scene = tb.Scene.from_toml("data_samples/video_tilted.toml")
    assert scene == tb.Scene.from_toml("data_samples/horsdal_large.toml")
