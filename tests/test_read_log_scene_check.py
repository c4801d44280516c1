"""The scene check of the units read_log decided, and the log options of the command line
(issue 14)."""

from __future__ import annotations

import argparse
import warnings

import numpy as np
import pytest

import trebuchet
from tests.exports import write_all
from tests.exports.shot import scene
from trebuchet.errors import TrebuchetInputError
from trebuchet.ingest.cli import add_log_arguments, log_options
from trebuchet.ingest.logs.scene_check import scene_check


@pytest.fixture(scope="module")
def exports(tmp_path_factory):
    folder = tmp_path_factory.mktemp("exports")
    return folder, write_all(folder)


def _read(exports, name, **kwargs):
    folder, truths = exports
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return trebuchet.read_log(folder / name, **(truths[name].read | kwargs))


def test_the_scene_check_finds_the_shot_and_names_a_wrong_factor(exports):
    sc = scene()
    for name in ("generic_deg.csv", "tracker_protractor_rad.txt", "kinovea_us.csv",
                 "sleap_untracked.analysis.csv"):
        found = scene_check(_read(exports, name), sc)
        assert 0.8 < found.sweep_deg / found.sweep_sim_deg < 1.25, name
        assert 0.8 < found.time_s / found.time_sim_s < 1.25, name
        assert "the log's swing is the scene's" in found.note
    df = _read(exports, "generic_deg.csv")
    ms = df.copy()
    ms["t"] *= 1000.0
    with pytest.raises(TrebuchetInputError, match=r"generic_deg\.csv: .*time.*ms read as s"):
        scene_check(ms, sc)
    deg = df.copy()
    deg["theta"] = np.radians(deg["theta"])
    with pytest.raises(TrebuchetInputError, match="sweep.*rad read as degrees"):
        scene_check(deg, sc)
    frames = _read(exports, "dlc_single.csv")
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
