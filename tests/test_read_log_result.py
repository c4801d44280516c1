"""read_log's typed result (``attrs["log"]``, a ReadLog) and the decisions it records
(issues 13 and 14)."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pandas as pd
import pytest

import trebuchet
from tests.exports import read_export
from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.logs.result import ReadLog, read_log_info


def test_the_result_is_one_read_log_shared_by_derived_tables(exports):
    df = read_export(exports, "kinovea_2024_classic_s.csv")
    info = df.attrs["log"]
    assert isinstance(info, ReadLog) and read_log_info(df) is info
    assert info.format == "kinovea" and info.source.endswith("kinovea_2024_classic_s.csv")
    assert info.fps == 240.0 and info.point_names["pivot"] == "Axle/0"
    assert set(info.points) >= {"t", "pivot_x", "pivot_y"} and len(info.points["t"]) == len(df)
    with pytest.raises(ValueError):
        info.points["t"][0] = 1.0          # read-only arrays
    with pytest.raises(AttributeError):
        info.fps = 120.0                   # frozen
    # pandas deep-copies attrs on every operation: the ReadLog is shared, not copied
    assert copy.deepcopy(info) is info and df[df["t"] > 0].attrs["log"] is info
    both = pd.concat([df, df.copy()])
    assert both.attrs["log"] is info
    back = pickle.loads(pickle.dumps(info))
    assert back.columns == info.columns and np.array_equal(back.points["t"], info.points["t"])
    assert set(df.attrs) == {"log"}  # one typed value, not a bag of keys
    assert read_log_info(pd.DataFrame({"t": [0.0]})) is None


@pytest.mark.parametrize("name, kwargs, words", [
    ("kinovea_2024_classic_s.csv", {}, ("time unit of 'Time': s (inferred", "fps=240",
                                        "y axis: up")),
    ("kinovea_frames_comma.csv", {"time_unit": "frames"}, ("frames (time_unit='frames')",)),
    ("kinovea_image_space_px.csv", {}, ("ms (inferred", "y axis: down, image space")),
    ("tracker_protractor_rad.txt", {}, ("rad (inferred", "Tracker writes its time in s",
                                        "time unit confirmed: the rate column beside 'beam/θ'")),
    ("tracker_protractor_deg.txt", {"angle_unit": "deg"}, ("deg (angle_unit='deg')",)),
    ("generic_deg.csv", {}, ("stated in the header", "angle units stated")),
    ("dlc_single.csv", {}, ("frame numbers", "y axis: down")),
])
def test_every_unit_decision_is_recorded(exports, name, kwargs, words):
    info = read_export(exports, name, **kwargs).attrs["log"]
    text = " | ".join(info.decisions)
    for word in words:
        assert word in text, text
    inferred = [d for d in info.decisions if "(inferred" in d]
    assert all(d in info.repairs for d in inferred)  # an inference is warned and summarised


def test_unknown_units_and_calibration_are_refused(exports):
    folder, _ = exports
    path = folder / "generic_deg.csv"
    with pytest.raises(TrebuchetInputError, match="time_unit='min'"):
        trebuchet.read_log(path, time_unit="min")
    with pytest.raises(TrebuchetInputError, match="angle_unit='grad'"):
        trebuchet.read_log(path, angle_unit="grad")
    with pytest.raises(TrebuchetInputError, match=r"cam\.toml: cannot be read"):
        trebuchet.read_log(path, calibration="cam.toml")   # no such file
    with pytest.raises(TrebuchetInputError, match=r"generic_deg\.csv.*says 's'"):
        trebuchet.read_log(path, time_unit="ms")  # the header states s
    with pytest.raises(TrebuchetInputError, match="individual='ind1'.*no individuals"):
        trebuchet.read_log(path, individual="ind1")


def test_a_frame_index_file_takes_no_other_time_unit(exports):
    with pytest.raises(TrebuchetInputError, match=r"dlc_single\.csv: time_unit='ms'"):
        read_export(exports, "dlc_single.csv", time_unit="ms")


def test_the_refusals_of_an_hdf5_reader_reach_the_user_as_they_are(exports):
    folder, truths = exports
    name = "sleap_two_tracks.analysis.h5"
    if name not in truths:
        pytest.skip("h5py and tables (PyTables) are needed to write the HDF5 fixtures")
    with pytest.raises(TrebuchetInputError) as err:
        trebuchet.read_log(folder / name, fps=120.0)
    assert str(err.value).startswith(f"{folder / name}: 2 tracks in this file")
