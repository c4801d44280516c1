"""The image calibrated by the engine itself (ingest.geometry): camera model, the fit's
Jacobian, recovery of angles and camera from simulated shots filmed by known cameras."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize._numdiff import approx_derivative

import trebuchet.ingest.geometry.calibration as cal_mod
from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.geometry import plane_map
from trebuchet.ingest.geometry.calibration import angles_from_calibration, calibrate
from trebuchet.ingest.geometry.camera import (
    apply_homography,
    camera_from_points,
    camera_from_pose,
    camera_pose,
    homography_from_points,
    intrinsics_from_opencv,
)
from trebuchet.ingest.synthetic.filmed_points import film, simulated_plane_track

SIZE = (1920, 1080)
OFFSETS = {"spigot": (0.4, -0.3), "hinge": (-0.5, 0.2), "counterweight": (0.3, 0.6),
           "projectile": (-0.2, -0.4)}


def tilted_camera() -> object:
    """Pitch 10°, roll 0.3°, k1 = −0.03, 40 m from the paper's engine."""
    return camera_from_pose(2500.0, SIZE, 40.0, (0.0, 6.0), pitch=np.radians(10.0),
                            roll=np.radians(0.3), k1=-0.03)


def fronto_camera() -> object:
    return camera_from_pose(2500.0, SIZE, 40.0, (0.0, 6.0))


@pytest.fixture(scope="module")
def shot(horsdal):
    return simulated_plane_track(horsdal, 240.0, rest=0.2)


def rms_deg(est: np.ndarray, true: np.ndarray) -> float:
    d = np.angle(np.exp(1j * (est - true)))
    return float(np.degrees(np.sqrt(np.mean(d[np.isfinite(d)] ** 2))))


def raw_angles(pts: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Today's reader: atan2 of two points in pixels."""
    def direction(a, b):
        d = pts[b] - pts[a]
        return np.arctan2(d[:, 1], d[:, 0])
    return {"theta": direction("pivot", "spigot"), "psi": direction("hinge", "counterweight"),
            "phi": direction("spigot", "projectile")}


# ---------------------------------------------------------------- camera model

def test_project_unproject_round_trip_with_distortion():
    cam = tilted_camera()
    xy = np.random.default_rng(0).uniform(-10, 15, (200, 2))
    assert np.abs(cam.unproject(cam.project(xy)) - xy).max() < 1e-9


def test_pose_read_back_from_a_camera():
    cam = camera_from_pose(2500.0, SIZE, 40.0, (0.0, 6.0), pitch=np.radians(10.0),
                           yaw=np.radians(3.0), roll=np.radians(0.3))
    pose = camera_pose(cam, pivot=(0.0, 6.0))
    assert np.degrees([pose.pitch, pose.yaw, pose.roll]) == pytest.approx([10, 3, 0.3],
                                                                          abs=1e-9)
    assert pose.focal == pytest.approx(2500.0, rel=1e-9)
    flat = camera_pose(camera_from_pose(2500.0, SIZE, 40.0, (0.0, 6.0), roll=0.01))
    assert flat.focal is None and flat.tilt == 0.0 and flat.roll == pytest.approx(0.01)


def test_homography_from_four_points_and_refusals():
    cam = tilted_camera()
    plane = np.array([[0.0, 0.0], [5.0, 0.0], [5.0, 8.0], [-3.0, 6.0]])
    Hm = homography_from_points(plane, apply_homography(cam.Hm, plane))
    assert np.abs(Hm - cam.Hm).max() < 1e-9 * np.abs(cam.Hm).max()
    with pytest.raises(TrebuchetInputError, match="four or more"):
        homography_from_points(plane[:3], plane[:3])
    with pytest.raises(TrebuchetInputError, match="one line"):
        line = np.column_stack([np.arange(5.0), np.arange(5.0)])
        homography_from_points(line, line)


def test_opencv_intrinsics_flip_the_rows_and_refuse_tangential_terms():
    K = [[2500.0, 0, 960.0], [0, 2500.0, 540.0], [0, 0, 1]]
    lens = intrinsics_from_opencv(K, [-0.03, 0.01, 0, 0, 0])
    assert lens.centre == (960.0, -540.0) and lens.k1 == -0.03 and lens.focal == 2500.0
    with pytest.raises(TrebuchetInputError, match="tangential"):
        intrinsics_from_opencv(K, [-0.03, 0.01, 0.002, 0, 0])


def test_image_jacobian_matches_finite_differences():
    cam = np.array([900.0, -600.0, 400.0, 0.01, 0.02, -0.01, 0.03, -0.05, -0.02, 0.01])
    X = np.random.default_rng(1).uniform(-1.5, 1.5, (7, 2))
    centre, radius = np.array([960.0, -540.0]), 1920.0
    d_plane, d_cam = plane_map.image_jacobian(cam, X, centre, radius)
    for i in range(7):
        num = approx_derivative(lambda z, i=i: plane_map.image_of(cam, z, centre, radius),
                                X[i], method="3-point")
        assert np.abs(d_plane[i] - num).max() < 1e-6 * np.abs(num).max()
        numc = approx_derivative(lambda c, i=i: plane_map.image_of(c, X[i], centre, radius), cam,
                                 method="3-point")
        assert np.abs(d_cam[i] - numc).max() < 1e-5 * np.abs(numc).max()


def test_fit_jacobian_matches_finite_differences(backyard, monkeypatch):
    """The whole problem's analytic sparse Jacobian, with the parabola in flight, against
    finite differences over its sparsity."""
    track = simulated_plane_track(backyard, 60.0, rest=0.2, after_release=0.3)
    cam = camera_from_pose(2500.0, SIZE, 25.0, (0.0, 4.0), pitch=np.radians(5.0), k1=-0.03)
    pts = film(track, cam, SIZE, 0.3, np.random.default_rng(2))
    checked = []
    solve = cal_mod._solve

    def check(pb, x0, *args):
        x = x0 + np.random.default_rng(0).normal(0.0, 1e-3, x0.size)
        Ja = pb.jacobian(x).toarray()
        Jn = approx_derivative(pb.residuals, x, method="3-point",
                               sparsity=pb.sparsity()).toarray()
        scale = np.abs(Jn).max(axis=0) + 1e-12
        checked.append((float((np.abs(Ja - Jn).max(axis=0) / scale).max()), pb.flight.any()))
        return solve(pb, x0, *args)

    monkeypatch.setattr(cal_mod, "_solve", check)
    calibrate(pts, backyard.engine, H=backyard.start.H, g=backyard.g, t=track.t,
              image_size=SIZE, in_sling=track.in_sling)
    assert checked and max(e for e, _ in checked) < 1e-6
    assert any(f for _, f in checked)  # the parabola was part of it


# ---------------------------------------------------------------- recovery

def test_exact_pixels_give_the_camera_and_angles(horsdal, shot):
    cam = tilted_camera()
    pts = film(shot, cam, SIZE, 0.0, np.random.default_rng(0))
    c = calibrate(pts, horsdal.engine, H=horsdal.start.H, image_size=SIZE, noise_px=0.1,
                  at_rest=shot.at_rest, in_trough=shot.in_trough,
                  levels=("projective+k1",))
    ok = shot.in_sling  # the prototype's figure: 0.002° (the k1 prior pulls a little)
    assert rms_deg(c.theta, shot.theta) < 2e-3
    assert rms_deg(c.psi, shot.psi) < 2e-3
    assert rms_deg(c.phi[ok], shot.phi[ok]) < 2e-3
    assert np.degrees(c.pose.pitch) == pytest.approx(10.0, abs=2e-2)
    assert np.degrees(c.pose.roll) == pytest.approx(0.3, abs=2e-3)
    assert c.k1_focal == pytest.approx(-0.03, abs=1e-4)
    assert not c.flagged


def test_tilted_camera_recovered_from_noisy_offset_tracks(horsdal, shot):
    cam = tilted_camera()
    pts = film(shot, cam, SIZE, 0.5, np.random.default_rng(1), OFFSETS)
    c = calibrate(pts, horsdal.engine, H=horsdal.start.H, image_size=SIZE)
    raw = raw_angles(pts)
    ok = shot.in_sling
    fit = {"theta": rms_deg(c.theta, shot.theta), "psi": rms_deg(c.psi, shot.psi),
           "phi": rms_deg(c.phi[ok], shot.phi[ok])}
    before = {"theta": rms_deg(raw["theta"], shot.theta), "psi": rms_deg(raw["psi"], shot.psi),
              "phi": rms_deg(raw["phi"][ok], shot.phi[ok])}
    assert fit["theta"] < 0.15 < before["theta"]       # measured 0.08 against 0.50
    assert fit["phi"] < 0.15 < before["phi"]           # 0.09 against 1.14
    assert fit["psi"] < 0.25 < before["psi"]           # 0.18 against 0.39
    assert c.level.startswith("projective")
    assert np.degrees(c.pose.tilt) == pytest.approx(10.0, abs=1.0)
    assert np.degrees(c.pose.roll) == pytest.approx(0.3, abs=0.15)
    assert c.pose.px_per_m == pytest.approx(camera_pose(cam, pivot=(0, horsdal.start.H))
                                            .px_per_m, rel=0.01)
    assert c.noise_px == pytest.approx(0.5, rel=0.3)
    # the bands: own sd near the scatter of the errors
    err = np.degrees(np.angle(np.exp(1j * (c.theta - shot.theta))))
    assert np.degrees(np.nanmedian(c.theta_sd)) == pytest.approx(np.std(err), rel=0.5)
    assert np.all(c.theta_sd_calibration > 0)
    assert "tilt 10." in c.summary() and "roll 0." in c.summary()


def test_fronto_parallel_camera_no_worse_than_atan2_of_the_pixels(horsdal, shot):
    pts = film(shot, fronto_camera(), SIZE, 0.5, np.random.default_rng(1), OFFSETS)
    c = calibrate(pts, horsdal.engine, H=horsdal.start.H, image_size=SIZE)
    raw = raw_angles(pts)
    ok = shot.in_sling
    assert c.level in ("level", "similarity")
    assert rms_deg(c.theta, shot.theta) <= rms_deg(raw["theta"], shot.theta)
    assert rms_deg(c.psi, shot.psi) <= rms_deg(raw["psi"], shot.psi)
    assert rms_deg(c.phi[ok], shot.phi[ok]) <= rms_deg(raw["phi"][ok], shot.phi[ok])


def test_stuck_track_is_flagged_and_left_out(horsdal, shot):
    pts = film(shot, tilted_camera(), SIZE, 0.5, np.random.default_rng(3), OFFSETS)
    a, b = 150, 210
    cw = pts["counterweight"].copy()
    cw[a:b] = cw[a] + np.random.default_rng(4).normal(0.0, 0.5, (b - a, 2))
    pts["counterweight"] = cw
    c = calibrate(pts, horsdal.engine, H=horsdal.start.H, image_size=SIZE)
    stuck = [f for f in c.flagged if f.point == "counterweight"]
    assert len(stuck) == 1 and stuck[0].kind == "stuck"
    assert stuck[0].first <= a + 3 and b - 1 <= stuck[0].last <= b + 1
    assert "counterweight" in stuck[0].note and "stuck" in stuck[0].note
    assert c.gaps["counterweight"][a + 3:b].all()
    assert not [f for f in c.flagged if f.point != "counterweight"]
    assert rms_deg(c.theta, shot.theta) < 0.15


def test_missing_points_degrade_gracefully(horsdal, shot):
    pts = film(shot, tilted_camera(), SIZE, 0.5, np.random.default_rng(5),
               points=("pivot", "spigot", "projectile"))
    c = calibrate(pts, horsdal.engine, H=horsdal.start.H, image_size=SIZE,
                  at_rest=shot.at_rest)
    assert np.isnan(c.psi).all()
    assert any(s.startswith("counterweight") is False and "psi: 0 frames" in s
               for s in c.fitted)
    raw = raw_angles(pts | {"hinge": pts["spigot"], "counterweight": pts["spigot"]})
    assert rms_deg(c.theta, shot.theta) < rms_deg(raw["theta"], shot.theta)


def test_users_own_calibration_from_known_points(horsdal, shot):
    cam = tilted_camera()
    lens = intrinsics_from_opencv([[2500.0, 0, 960.0], [0, 2500.0, 540.0], [0, 0, 1]],
                                  [-0.03, 0.0])
    plane = np.array([[-4.0, 0.0], [4.0, 0.0], [4.0, 10.0], [-4.0, 10.0], [0.0, 5.0]])
    mine = camera_from_points(plane, cam.project(plane), lens)
    pts = film(shot, cam, SIZE, 0.5, np.random.default_rng(6))
    c = angles_from_calibration(pts, mine, horsdal.engine, H=horsdal.start.H)
    ok = shot.in_sling
    assert c.level == "given"
    assert rms_deg(c.theta, shot.theta) < 0.1
    assert rms_deg(c.phi[ok], shot.phi[ok]) < 0.12


def test_bad_points_are_refused(horsdal):
    with pytest.raises(TrebuchetInputError, match="spigot or the hinge"):
        calibrate({"pivot": np.zeros((10, 2))}, horsdal.engine, H=5.0)
    with pytest.raises(TrebuchetInputError, match="unknown points"):
        calibrate({"beam": np.zeros((10, 2))}, horsdal.engine, H=5.0)


def test_block_normal_equations_match_the_sparse_jacobian(backyard, monkeypatch):
    """The block solver's U, W, V and gradient equal those of the sparse Jacobian."""
    track = simulated_plane_track(backyard, 60.0, rest=0.2, after_release=0.3)
    cam = camera_from_pose(2500.0, SIZE, 25.0, (0.0, 4.0), pitch=np.radians(5.0), k1=-0.03)
    pts = film(track, cam, SIZE, 0.3, np.random.default_rng(2))
    checked = []
    solve = cal_mod._solve

    def check(pb, x0, *args):
        rb = pb.row_blocks(x0)
        r = pb.residuals(x0)
        w = np.random.default_rng(1).uniform(0.5, 1.0, r.size)
        U, W, V, gg, ga = rb.normal(w, r)
        J = np.diag(w) @ rb.matrix().toarray()
        JtJ, g = J.T @ J, J.T @ (w * r)
        ng, n = pb.n_global, pb.n
        assert np.allclose(U, JtJ[:ng, :ng]) and np.allclose(gg, g[:ng])
        assert np.allclose(W, JtJ[:ng, ng:].reshape(ng, n, 3).transpose(1, 0, 2))
        blocks = [JtJ[ng + 3 * f:ng + 3 * f + 3, ng + 3 * f:ng + 3 * f + 3] for f in range(n)]
        assert np.allclose(V, np.array(blocks)) and np.allclose(ga.ravel(), g[ng:])
        checked.append(True)
        return solve(pb, x0, *args)

    monkeypatch.setattr(cal_mod, "_solve", check)
    calibrate(pts, backyard.engine, H=backyard.start.H, g=backyard.g, t=track.t,
              image_size=SIZE, in_sling=track.in_sling)
    assert checked


def test_block_solver_agrees_with_scipy_least_squares(horsdal):
    track = simulated_plane_track(horsdal, 60.0, rest=0.3)
    pts = film(track, tilted_camera(), SIZE, 0.5, np.random.default_rng(7), OFFSETS)
    common = dict(H=horsdal.start.H, image_size=SIZE, at_rest=track.at_rest,
                  in_trough=track.in_trough, levels=("projective",), noise_px=0.5)
    fast = calibrate(pts, horsdal.engine, **common)
    ref = calibrate(pts, horsdal.engine, solver="scipy", **common)
    assert fast.cost == pytest.approx(ref.cost, rel=1e-4)
    for a in ("theta", "psi", "phi"):
        diff = np.degrees(np.nanmax(np.abs(getattr(fast, a) - getattr(ref, a))))
        assert diff < 1e-3


def test_fixed_counterweight_engine(backyard):
    """A counterweight rigid on the beam: ψ = θ + offset, no plumb; the angles still come."""
    data = {"engine": {"L1": 2.0, "L2": 0.5, "L_CM": 0.6, "L3": 0.6, "L4": 1.8, "m_b": 15.0,
                       "M": 100.0, "m": 1.0, "counterweight": "fixed"},
            "start": {"theta_deg": -45.0, "psi_deg": -90.0, "phi_deg": -180.0},
            "release": {"velocity_angle_deg": 45.0}, "environment": {"g": 9.81}}
    scene = type(backyard).from_dict(data, source="fixed")
    track = simulated_plane_track(scene, 240.0, rest=0.2)
    cam = camera_from_pose(2500.0, SIZE, 12.0, (0.0, 1.8), pitch=np.radians(10.0))
    pts = film(track, cam, SIZE, 0.5, np.random.default_rng(8))
    c = calibrate(pts, scene.engine, H=scene.start.H, image_size=SIZE)
    raw = raw_angles(pts)
    assert c.at_rest.any() and "plumb counterweight at rest: 0 frames" in c.fitted
    assert rms_deg(c.theta, track.theta) < rms_deg(raw["theta"], track.theta) / 2
    assert rms_deg(c.psi, track.psi) < rms_deg(raw["psi"], track.psi) / 2


def test_tracker_confidence_weights_silence_a_bad_stretch(horsdal, shot):
    pts = film(shot, tilted_camera(), SIZE, 0.5, np.random.default_rng(9))
    bad = slice(200, 230)
    pts["spigot"][bad] += 40.0                         # a swapped stretch the tracker doubted
    weights = {"spigot": np.ones(shot.t.size)}
    weights["spigot"][bad] = 0.0
    c = calibrate(pts, horsdal.engine, H=horsdal.start.H, image_size=SIZE, weights=weights)
    assert not c.flagged
    assert np.isnan(c.residuals["spigot"][bad]).all()
    assert rms_deg(c.theta, shot.theta) < 0.15


def test_users_lens_calibration_fixes_the_distortion(horsdal, shot):
    """An OpenCV camera matrix and distortion: the lens is held, the plane's map fitted."""
    lens = intrinsics_from_opencv([[2500.0, 0, 960.0], [0, 2500.0, 540.0], [0, 0, 1]],
                                  [-0.03, 0.0])
    pts = film(shot, tilted_camera(), SIZE, 0.5, np.random.default_rng(10), OFFSETS)
    c = calibrate(pts, horsdal.engine, H=horsdal.start.H, camera=lens)
    assert c.level == "projective" and c.parameters["k1"] == pytest.approx(-0.03)
    assert c.k1_focal == pytest.approx(-0.03)
    assert np.degrees(c.pose.pitch) == pytest.approx(10.0, abs=0.5)
    assert rms_deg(c.theta, shot.theta) < 0.15


def test_swapped_and_jumped_points_are_named(horsdal, shot):
    """Spigot and projectile swapped for six frames, the counterweight jumping for three:
    each wrong point is named with its frames, and only it."""
    pts = film(shot, tilted_camera(), SIZE, 0.5, np.random.default_rng(3))
    good = {k: v.copy() for k, v in pts.items()}
    pts["spigot"][250:256], pts["projectile"][250:256] = (good["projectile"][250:256],
                                                          good["spigot"][250:256])
    pts["counterweight"][100:103] += [15.0, -10.0]
    c = calibrate(pts, horsdal.engine, H=horsdal.start.H, image_size=SIZE)
    runs = sorted((f.point, f.first, f.last, f.kind) for f in c.flagged)
    assert runs == [("counterweight", 100, 102, "outlier"), ("projectile", 250, 255, "outlier"),
                    ("spigot", 250, 255, "outlier")]
    assert rms_deg(c.theta, shot.theta) < 0.15
