"""Typed results between the stages: ``read_log`` -> ``attrs["log"]`` (ReadLog), ``smooth``
-> ``attrs["smoothing"]`` (Smoothing), ``reconstruct`` -> ``attrs["reconstruction"]``
(Reconstruction), each beside the interface's ``attrs["events"]`` and nothing else."""

from __future__ import annotations

import copy
import pickle
import warnings

import numpy as np
import pandas as pd
import pytest

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.advisory import Advisory
from trebuchet.ingest.logs.read_log import read_log
from trebuchet.ingest.logs.result import ReadLog
from trebuchet.ingest.reconstruct import reconstruct
from trebuchet.ingest.reconstruction import Reconstruction, reconstruction_of
from trebuchet.ingest.smoothing.result import Smoothing, smoothing_of
from trebuchet.ingest.smoothing.smooth import smooth
from trebuchet.ingest.synthetic.simulated_log import simulated_log


@pytest.fixture(scope="module")
def shot(horsdal, tmp_path_factory):
    """A simulated 120 fps log written as a plain CSV, read back, smoothed, reconstructed."""
    log, _ = simulated_log(horsdal, 120, 0.3, seed=4)
    path = tmp_path_factory.mktemp("stage") / "shot.csv"
    log.to_csv(path, index=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        read = read_log(path)
        est = smooth(read)
        res = reconstruct(path, horsdal)
    return read, est, res


def test_each_stage_carries_one_typed_object_beside_the_events(shot):
    read, est, res = shot
    assert set(read.attrs) == {"log"} and isinstance(read.attrs["log"], ReadLog)
    assert set(est.attrs) == {"events", "smoothing"}
    assert isinstance(smoothing_of(est), Smoothing)
    assert set(res.attrs) == {"events", "reconstruction", "log"}
    done = reconstruction_of(res)
    assert isinstance(done, Reconstruction) and res.attrs["log"].source.endswith("shot.csv")
    # the interface's plain dict says what the typed object says
    assert est.attrs["events"] == dict(smoothing_of(est).events)
    assert res.attrs["events"] == dict(done.events)
    assert set(done.events) == {"trigger", "lift_off", "release"}
    assert all(isinstance(a, Advisory) for a in done.advisories)
    assert set(done.noise) == {"theta", "psi", "phi"} and done.noise["theta"]["r_sd"] > 0


def test_the_objects_are_frozen_and_shared_by_derived_tables(shot):
    _, est, res = shot
    fit, done = smoothing_of(est), reconstruction_of(res)
    with pytest.raises(AttributeError):
        fit.model = "cj"
    with pytest.raises(TypeError):
        fit.noise["theta"] = {}
    with pytest.raises(TypeError):
        done.event_sd["release"] = 0.0
    with pytest.raises(ValueError):
        fit.cov["theta"][0, 0, 0] = 1.0          # read-only arrays
    assert copy.deepcopy(fit) is fit and est[est["t"] > 0].attrs["smoothing"] is fit
    assert pd.concat([res, res.copy()]).attrs["reconstruction"] is done


def test_the_objects_pickle_with_their_values(shot):
    _, est, res = shot
    fit, done = smoothing_of(est), reconstruction_of(res)
    back = pickle.loads(pickle.dumps(fit))
    assert back.events == fit.events and back.notes == fit.notes
    np.testing.assert_array_equal(back.cov["psi"], fit.cov["psi"])
    again = pickle.loads(pickle.dumps(done))
    assert again.events == done.events and again.advisories == done.advisories


def test_a_new_note_or_source_makes_a_new_object(shot):
    _, est, _ = shot
    fit = smoothing_of(est)
    noted = fit.noted("a remark", None, "a remark")
    assert noted is not fit and noted.notes == (*fit.notes, "a remark")
    assert noted.noted("a remark") is noted           # repeats are left out
    named = fit.with_source("release", "given")
    assert named.event_sources["release"] == "given" and fit.event_sources != named.event_sources


def test_a_table_from_elsewhere_is_refused_by_name():
    with pytest.raises(TrebuchetInputError, match="trebuchet.smooth"):
        smoothing_of(pd.DataFrame({"t": [0.0]}))
    with pytest.raises(TrebuchetInputError, match="trebuchet.reconstruct"):
        reconstruction_of(pd.DataFrame({"t": [0.0]}))


def test_the_command_line_turns_the_self_calibration_off_by_name():
    import argparse

    from trebuchet.ingest.cli import add_reconstruct_arguments, reconstruct_options

    p = argparse.ArgumentParser()
    add_reconstruct_arguments(p)
    args = p.parse_args(["shot.csv", "--scene", "s.toml", "--image-calibration", "none"])
    assert reconstruct_options(args)["image_calibration"] == "none"
    assert reconstruct_options(p.parse_args(["shot.csv", "--scene", "s.toml"]))[
        "image_calibration"] is None
    with pytest.raises(SystemExit):
        p.parse_args(["shot.csv", "--scene", "s.toml", "--image-calibration", "auto"])


def test_warnings_point_at_the_users_line_not_into_the_package():
    """A repair warned while ``reconstruct`` reads a file, and the validity warnings of the
    reconstruction, are reported at the caller's line (``errors.warn_at_caller``)."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[1] / "data_samples"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        reconstruct(root / "video_paper_dlc.csv", root / "video_paper.toml", fps=240)
    assert caught
    assert {Path(w.filename).resolve() for w in caught} == {Path(__file__).resolve()}
