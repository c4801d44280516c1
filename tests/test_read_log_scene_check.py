"""The scene check of the units read_log decided, and the log options of the command line
(issue 14)."""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import trebuchet
from tests.exports import read_export
from tests.exports.shot import scene
from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.cli import add_log_arguments, log_options
from trebuchet.ingest.logs.scene_check import scene_check


def test_the_scene_check_finds_the_shot_and_names_a_wrong_factor(exports):
    sc = scene()
    for name in ("generic_deg.csv", "tracker_protractor_rad.txt", "kinovea_us.csv",
                 "sleap_untracked.analysis.csv"):
        found = scene_check(read_export(exports, name), sc)
        assert 0.8 < found.sweep_deg / found.sweep_sim_deg < 1.25, name
        assert 0.8 < found.time_s / found.time_sim_s < 1.25, name
        assert "the log's swing is the scene's" in found.note
    df = read_export(exports, "generic_deg.csv")
    ms = df.copy()
    ms["t"] *= 1000.0
    with pytest.raises(TrebuchetInputError, match=r"generic_deg\.csv: .*time.*ms read as s"):
        scene_check(ms, sc)
    s = df.copy()
    s["t"] /= 1000.0
    with pytest.raises(TrebuchetInputError, match="time.*s read as ms"):
        scene_check(s, sc)
    deg = df.copy()
    deg["theta"] = np.radians(deg["theta"])
    with pytest.raises(TrebuchetInputError, match="sweep.*rad read as degrees"):
        scene_check(deg, sc)
    frames = read_export(exports, "dlc_single.csv")
    frames["t"] *= 120.0
    with pytest.raises(TrebuchetInputError, match="frame numbers read as s"):
        scene_check(frames, sc)


def test_the_log_options_of_the_command_line():
    p = argparse.ArgumentParser()
    add_log_arguments(p)
    args = p.parse_args(["log.csv", "--scene", "s.toml"])
    assert log_options(args) == {"fps": None, "columns": None, "points": None}
    args = p.parse_args(["log.csv", "--scene", "s.toml", "--time-unit", "ms", "--angle-unit",
                         "rad", "--min-likelihood", "0.8", "--individual", "ind2",
                         "--calibration", "cam.toml"])
    assert log_options(args) == {"fps": None, "columns": None, "points": None,
                                 "time_unit": "ms", "angle_unit": "rad", "min_likelihood": 0.8,
                                 "individual": "ind2", "calibration": "cam.toml"}
    with pytest.raises(TrebuchetInputError, match="--min-likelihood 1.5"):
        log_options(p.parse_args(["log.csv", "--scene", "s.toml", "--min-likelihood", "1.5"]))
    with pytest.raises(SystemExit):
        p.parse_args(["log.csv", "--scene", "s.toml", "--time-unit", "min"])


def test_a_log_without_the_start_or_the_fastest_point(exports):
    sc = scene()
    df = read_export(exports, "generic_deg.csv")
    moved = np.abs(df["theta"] - df["theta"].iloc[0]) > np.radians(10)
    late = df[moved.to_numpy()].reset_index(drop=True)  # starts mid-swing
    found = scene_check(late, sc)
    assert not found.checked and "does not start at rest" in found.note
    fastest = int(np.argmax(np.abs(np.gradient(df["theta"], df["t"]))))
    early = df.iloc[:fastest - 20].reset_index(drop=True)  # ends before the fastest point
    found = scene_check(early, sc)
    assert found.checked and 0.8 < found.time_s / found.time_sim_s < 1.25
    still = df.iloc[:30].reset_index(drop=True)
    assert not scene_check(still, sc).checked


def test_the_samples_swing_is_their_scenes_despite_noise_and_mislocated_points():
    """Kinovea's whole ms and 0.01 m, DeepLabCut's points mislocated by 10-40 px with
    likelihood above the default cut: the beam's fastest point is the beam's, not a spike."""
    samples = Path(__file__).parents[1] / "data_samples"
    dlc = {"pivot": "axle", "spigot": "arm_tip", "hinge": "hinge", "counterweight": "weight",
           "projectile": "stone"}
    kin = {"pivot": "Beam/axle", "spigot": "Beam/tip", "hinge": "Beam/hinge",
           "counterweight": "Weight/centre", "projectile": "Stone/centre"}
    for name, kwargs in (("horsdal_dlc.csv", {"fps": 120, "points": dlc}),
                         ("horsdal_kinovea.csv", {"fps": 240, "points": kin})):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            log = trebuchet.read_log(samples / name, **kwargs)
        found = scene_check(log, samples / "horsdal_large.toml")
        assert 0.8 < found.sweep_deg / found.sweep_sim_deg < 1.25, name
        assert 0.8 < found.time_s / found.time_sim_s < 1.25, name


# on the command line the hints name options, not Python keywords (issue 17: errors.Option,
# and the CLI's rewriting of messages not yet built with it)
@pytest.mark.parametrize("name, args, words", [
    ("kinovea_frames_origin.csv", [], ("kinovea_frames_origin.csv, column 'Time'", "--fps")),
    ("sleap_two_tracks.analysis.csv", ["--fps", "120"], ("track_0", "track_1")),
    ("kinovea_hundredth_min.csv", ["--fps", "240"], ("column 'Time'", "--time-unit")),
])
def test_a_file_the_reader_refuses_is_one_line_and_status_2(exports, tmp_path, capsys, name,
                                                            args, words):
    from trebuchet.cli import main

    folder, _ = exports
    scene_file = Path(__file__).parents[1] / "data_samples" / "horsdal_large.toml"
    status = main(["forces", str(folder / name), "--scene", str(scene_file),
                   "-o", str(tmp_path / "loads.csv"), *args])
    err = capsys.readouterr().err.strip()
    assert status == 2 and len(err.splitlines()) == 1, err
    for word in words:
        assert word in err
    assert not (tmp_path / "loads.csv").exists()


def test_a_log_cut_mid_swing_whose_last_frames_lag_is_checked_to_its_end():
    """The stress grid (issue 26): at 60 fps the spigot's track of the small fast engine
    degraded and was lost mid-swing, its last frames lagging by up to 6°: the beam's speed
    peaked 4 frames before the log's end, that was taken for the fastest point, and the
    right scene was refused (sweep 53° against 113°)."""
    sc = trebuchet.Scene.from_toml(Path(__file__).parents[1] / "data_samples"
                                   / "small_fast.toml")
    t = np.arange(0.0, 0.37, 1 / 60)
    sim = trebuchet.simulate(sc, t_eval=t)
    theta = sim["theta"].to_numpy(dtype=float).copy()
    theta[-5:] += np.radians([0.8, 0.7, -0.3, -2.1, -6.0])  # the marker slips (the cell's)
    rest = np.arange(0.0, 0.3, 1 / 60)
    log = pd.DataFrame({"t": np.r_[rest, 0.3 + t], "theta": np.r_[np.full(rest.size, theta[0]),
                                                                 theta]})
    for a in ("psi", "phi"):
        log[a] = np.r_[np.full(rest.size, sim[a].iloc[0]), sim[a].to_numpy(dtype=float)]
    found = scene_check(log, sc)
    assert found.checked and 0.5 <= found.sweep_deg / found.sweep_sim_deg <= 2.0
