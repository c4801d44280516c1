"""Scene files: the contract's keys, validation that names the key, and the CLI's handling."""

from __future__ import annotations

import copy
import math
import subprocess
import sys

import pytest

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model.scene import Scene, default_moment_of_inertia

from .conftest import BACKYARD, HORSDAL


def test_horsdal_scene_is_table_1(horsdal):
    e = horsdal.engine
    assert (e.L1, e.L2, e.L_CM, e.L3, e.L4, e.m_b, e.M, e.m) == (
        6.48, 0.86, 2.81, 2.45, 5.55, 622.0, 19100.0, 100.0)
    assert e.I == pytest.approx(7704, abs=0.5)
    assert horsdal.g == 9.82
    assert horsdal.start.theta == pytest.approx(math.radians(-50))
    assert horsdal.start.H == pytest.approx(-6.48 * math.sin(math.radians(-50)))
    assert horsdal.release.time == 0.997 and horsdal.release.velocity_angle is None


def test_round_trip_through_dict(horsdal):
    again = Scene.from_dict(horsdal.to_dict())
    assert again == horsdal


def _bad(mutate, expect: str):
    data = copy.deepcopy(BACKYARD)
    mutate(data)
    with pytest.raises(TrebuchetInputError) as info:
        Scene.from_dict(data, source="yard.toml")
    message = str(info.value)
    assert message.startswith("yard.toml: ")
    assert expect in message, message
    return message


@pytest.mark.parametrize("key", ["L1", "L2", "L3", "L4", "m_b", "M", "m"])
def test_nonpositive_values_name_the_key(key):
    _bad(lambda d: d["engine"].__setitem__(key, -1.0), f"[engine] {key}")
    _bad(lambda d: d["engine"].__setitem__(key, 0.0), f"[engine] {key}")


@pytest.mark.parametrize("key", ["L1", "M", "m"])
def test_missing_key_is_named(key):
    msg = _bad(lambda d: d["engine"].pop(key), f"[engine] {key}")
    assert "missing" in msg


def test_unknown_key_and_section():
    assert "unknown key" in _bad(lambda d: d["engine"].__setitem__("L5", 1.0), "[engine] L5")
    assert "unknown section" in _bad(lambda d: d.__setitem__("wind", {}), "[wind]")


def test_text_where_a_number_belongs():
    _bad(lambda d: d["engine"].__setitem__("L1", "two"), "[engine] L1")
    _bad(lambda d: d["engine"].__setitem__("M", True), "[engine] M")


def test_centre_of_mass_off_the_beam():
    _bad(lambda d: d["engine"].__setitem__("L_CM", 2.5), "[engine] L_CM")
    _bad(lambda d: d["engine"].__setitem__("L_CM", -0.6), "[engine] L_CM")


def test_sling_cannot_reach_the_trough():
    _bad(lambda d: d["engine"].__setitem__("H", 4.0), "[engine] L4")


def test_start_pose_puts_projectile_below_ground_or_off_the_trough():
    msg = _bad(lambda d: d["start"].__setitem__("phi_deg", -150.0), "[start] phi_deg")
    assert "below ground" in msg and "phi_deg = -180" in msg
    _bad(lambda d: d["start"].__setitem__("theta_deg", 10.0), "[start] theta_deg")
    _bad(lambda d: (d["engine"].__setitem__("H", 1.0)), "[start] theta_deg")


@pytest.mark.parametrize("angle", [0.0, 90.0, -10.0, 120.0])
def test_release_angle_outside_0_90(angle):
    _bad(lambda d: d["release"].__setitem__("velocity_angle_deg", angle),
         "[release] velocity_angle_deg")


def test_release_needs_exactly_one_rule():
    _bad(lambda d: d["release"].__setitem__("time", 1.0), "[release]")
    _bad(lambda d: d["release"].clear(), "[release]")


def test_counterweight_too_light_for_the_beam():
    _bad(lambda d: d["engine"].__setitem__("M", 10.0), "[engine] M")


def test_default_moment_of_inertia_matches_table_1():
    assert default_moment_of_inertia(622.0, 6.48, 0.86) == pytest.approx(7704, abs=0.5)


def test_bad_toml_and_missing_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[engine\nL1 = 1")
    with pytest.raises(TrebuchetInputError, match="bad.toml: not valid TOML"):
        Scene.from_toml(bad)
    with pytest.raises(TrebuchetInputError, match="nothere.toml: scene file not found"):
        Scene.from_toml(tmp_path / "nothere.toml")


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "trebuchet.cli", *args], capture_output=True,
                          text=True, timeout=120)


def test_cli_simulate_writes_the_contract_columns(tmp_path):
    out = tmp_path / "run.csv"
    res = _cli("simulate", str(HORSDAL), "-o", str(out))
    assert res.returncode == 0, res.stderr
    header = out.read_text().splitlines()[0].split(",")
    for col in ("t", "phase", "theta", "psi", "phi", "theta_d", "psi_d", "phi_d", "theta_dd",
                "psi_dd", "phi_dd", "F_S_x", "F_S_y", "F_H_x", "F_H_y", "F_CM_x", "F_CM_y",
                "F_R_x", "F_R_y", "torque", "P_m", "P_M", "P_beam", "E_m", "E_M", "E_beam",
                "x_m", "y_m", "vx_m", "vy_m"):
        assert col in header


def test_cli_bad_scene_exits_2_with_one_line_and_no_output(tmp_path):
    scene = tmp_path / "neg.toml"
    scene.write_text(HORSDAL.read_text().replace("L3 = 2.45", "L3 = -2.45"))
    out = tmp_path / "run.csv"
    res = _cli("simulate", str(scene), "-o", str(out))
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "neg.toml" in lines[0] and "[engine] L3" in lines[0]
    assert "Traceback" not in res.stderr
    assert not out.exists()
    assert list(tmp_path.iterdir()) == [scene]


def test_cli_paper_prints_the_table():
    res = _cli("paper")
    assert res.returncode == 0, res.stderr
    assert "θ̈ at 0+" in res.stdout and "lift-off" in res.stdout and "differs" in res.stdout


# --- errors name the key the user wrote, and the one that is wrong (issue 17)

def _scene_with(tmp_path, section: str, old: str, new: str):
    text = HORSDAL.read_text(encoding="utf-8")
    assert old in text
    path = tmp_path / "s.toml"
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    return path


def test_a_huge_beam_mass_blames_m_b_not_M(tmp_path):
    path = _scene_with(tmp_path, "engine", "m_b = 622.0", "m_b = 1e308")
    with pytest.raises(TrebuchetInputError, match=r"\[engine\] m_b: = 1e\+308 kg"):
        Scene.from_toml(path)


def test_radians_typed_under_theta_deg_blame_theta_and_say_so(tmp_path):
    path = _scene_with(tmp_path, "start", "theta_deg = -50.0", "theta_deg = -0.87")
    with pytest.raises(TrebuchetInputError, match=r"\[start\] theta_deg: = -0\.87°.*"
                                                  r"did you mean theta = -0\.87 rad") as info:
        Scene.from_toml(path)
    assert "psi" not in str(info.value)


def test_degrees_under_the_radian_key_report_that_key(tmp_path):
    path = _scene_with(tmp_path, "start", "theta_deg = -50.0", "theta = -50")
    with pytest.raises(TrebuchetInputError, match=r"\[start\] theta: = -50 rad .*write "
                                                  r"theta_deg = -50") as info:
        Scene.from_toml(path)
    assert "theta_deg:" not in str(info.value) and "2864" not in str(info.value)


def test_a_counterweight_below_ground_blames_what_sets_the_pivots_height(tmp_path):
    path = _scene_with(tmp_path, "engine", "L1 = 6.48", "L1 = 6.48\nH = 1.0")
    text = path.read_text(encoding="utf-8").replace("theta_deg = -50.0", "theta_deg = -5.0")
    path.write_text(text, encoding="utf-8")
    with pytest.raises(TrebuchetInputError, match=r"\[engine\] H: = 1 m: the pivot is too low"):
        Scene.from_toml(path)
