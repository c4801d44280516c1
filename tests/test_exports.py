"""Every export fixture of :mod:`tests.exports` read through ``trebuchet.read_log`` and
compared with its truth (issue 14).

Each file is written at test time, in the layout its tool writes (see the writer modules
and docs/formats.md), from the simulated shot of the paper's engine. A case reads one file
the way a user would (``fps``, ``points`` or ``columns``, as the file cannot say them), and
the ambiguous ones both ways: the unit or the individual stated by keyword, and inferred
from the file. Cases that fail today because their reader or keyword does not exist yet
are strict xfails: each flips to a failure (to be unmarked) the day it passes.
"""

from __future__ import annotations

import inspect
import warnings
from dataclasses import dataclass, field

import numpy as np
import pytest

import trebuchet
from tests.exports import write_all
from tests.exports.truth import Truth
from trebuchet.errors import TrebuchetInputError

ANGLES = ("theta", "psi", "phi")

# Why a case fails today (the reader or the keyword it needs does not exist yet).
NO_KEYWORD = "read_log has no time_unit / angle_unit / individual keyword yet"
NO_H5 = "no HDF5 reader yet (DeepLabCut .h5, SLEAP analysis HDF5)"
NO_SLEAP_CSV = "no SLEAP analysis CSV reader yet"
NO_ANIPOSE = "no anipose 3-D reader yet (plane fit, vertical from the engine)"
KINOVEA_MS = ("Kinovea's unit-less Time is read as whole milliseconds only (other time codes "
              "refused or misread)")
KINOVEA_Y = ("Kinovea's fractional ms are refused, and its image-space export (pixels, y "
             "down, no header sign of it) is read as y up: the engine comes out mirrored (the "
             "counterweight hanging above its hinge)")
TRACKER_DEG = "Tracker θ without a unit is always read as degrees (radian preference misread)"
GENERIC_RAD = "a generic angle column without a unit is read as rad (degrees refused)"
GENERIC_S = "a generic time column without a unit is read as s"
REPEATS = "runs of more than two identical rows (up-converted video) are kept"
MIN_LIKELIHOOD = "min_likelihood defaults to 0.9, the issue asks 0.6"


@dataclass
class Case:
    """One way of reading one fixture."""

    file: str
    how: str                                     # short id: "user", "keyword", "inferred"
    kwargs: dict = field(default_factory=dict)   # added to the truth's own ``read``
    refused: tuple[str, ...] | None = None       # expect TrebuchetInputError naming these
    drop: tuple[str, ...] = ()                   # keys of the truth's ``read`` not given
    xfail: str | None = None

    @property
    def id(self) -> str:
        return f"{self.file}-{self.how}"


CASES = [
    # DeepLabCut
    Case("dlc_single.csv", "user"),
    Case("dlc_single.csv", "min_likelihood", {"min_likelihood": 0.6}),
    Case("dlc_single.h5", "user", xfail=NO_H5),
    Case("dlc_multi.csv", "individual", xfail=NO_KEYWORD),
    Case("dlc_multi.csv", "no-individual", drop=("individual",), refused=("ind1", "ind2")),
    Case("dlc_multi_el.h5", "individual", xfail=NO_H5),
    Case("dlc_multi_el.h5", "no-individual", drop=("individual",), refused=("ind1", "ind2"),
         xfail=NO_H5),
    Case("dlc_multi_one.h5", "only-individual", xfail=NO_H5),
    Case("phone_upconverted_dlc.csv", "user", xfail=REPEATS),
    # SLEAP
    Case("sleap_two_tracks.analysis.h5", "individual", xfail=NO_H5),
    Case("sleap_two_tracks.analysis.h5", "no-individual", drop=("individual",),
         refused=("track_0", "track_1"), xfail=NO_H5),
    Case("sleap_two_tracks.analysis.csv", "individual", xfail=NO_SLEAP_CSV),
    Case("sleap_two_tracks.analysis.csv", "no-individual", drop=("individual",),
         refused=("track_0", "track_1"), xfail=NO_SLEAP_CSV),
    Case("sleap_untracked.analysis.h5", "user", xfail=NO_H5),
    Case("sleap_untracked.analysis.csv", "user", xfail=NO_SLEAP_CSV),
    # anipose
    Case("anipose_pose3d.csv", "user", xfail=NO_ANIPOSE),
    # Kinovea: every time code, stated by keyword and inferred from the frame pattern
    Case("kinovea_2024_classic_s.csv", "keyword", {"time_unit": "s"}, xfail=NO_KEYWORD),
    Case("kinovea_2024_classic_s.csv", "inferred", xfail=KINOVEA_MS),
    Case("kinovea_2025_classic_s_fr.csv", "keyword", {"time_unit": "s"}, xfail=NO_KEYWORD),
    Case("kinovea_2025_classic_s_fr.csv", "inferred", xfail=KINOVEA_MS),
    Case("kinovea_ms_fraction_de.csv", "keyword", {"time_unit": "ms"}, xfail=NO_KEYWORD),
    Case("kinovea_ms_fraction_de.csv", "inferred", xfail=KINOVEA_MS),
    Case("kinovea_us.csv", "keyword", {"time_unit": "us"}, xfail=NO_KEYWORD),
    Case("kinovea_us.csv", "inferred", xfail=KINOVEA_MS),
    Case("kinovea_frames_origin.csv", "keyword", {"time_unit": "frames"}, xfail=NO_KEYWORD),
    Case("kinovea_frames_origin.csv", "inferred", xfail=KINOVEA_MS),
    Case("kinovea_frames_comma.csv", "keyword", {"time_unit": "frames"}, xfail=NO_KEYWORD),
    Case("kinovea_frames_comma.csv", "inferred", xfail=KINOVEA_MS),
    Case("kinovea_image_space_px.csv", "keyword", {"time_unit": "ms"}, xfail=NO_KEYWORD),
    Case("kinovea_image_space_px.csv", "inferred", xfail=KINOVEA_Y),
    Case("kinovea_hundredth_min.csv", "refused", refused=("Time",)),
    # Tracker
    Case("tracker_protractor_deg.txt", "user"),
    Case("tracker_protractor_deg.txt", "keyword", {"angle_unit": "deg"}, xfail=NO_KEYWORD),
    Case("tracker_protractor_rad.txt", "keyword", {"angle_unit": "rad"}, xfail=NO_KEYWORD),
    Case("tracker_protractor_rad.txt", "inferred", xfail=TRACKER_DEG),
    Case("tracker_protractor_deg_comma.txt", "user"),
    Case("tracker_pointmass.txt", "user"),
    # plain CSV
    Case("generic_deg.csv", "user"),
    Case("generic_nounit_deg.csv", "keyword", {"angle_unit": "deg"}, xfail=NO_KEYWORD),
    Case("generic_nounit_deg.csv", "inferred", xfail=GENERIC_RAD),
    Case("generic_time_ms.csv", "keyword", {"time_unit": "ms"}, xfail=NO_KEYWORD),
    Case("generic_time_ms.csv", "inferred", xfail=GENERIC_S),
    Case("phone_upconverted_generic.csv", "user", xfail=REPEATS),
]


@pytest.fixture(scope="module")
def exports(tmp_path_factory):
    folder = tmp_path_factory.mktemp("exports")
    return folder, write_all(folder)


def _read(folder, truth: Truth, case: Case):
    kwargs = {k: v for k, v in truth.read.items() if k not in case.drop} | case.kwargs
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return trebuchet.read_log(folder / truth.name, **kwargs)


def check(df, truth: Truth) -> None:
    """The rows, times and angles of ``df`` are the truth's (to its tolerances)."""
    assert len(df) == len(truth.t), (
        f"{truth.name}: {len(df)} rows read, {len(truth.t)} distinct images with an angle")
    t = df["t"].to_numpy()
    worst = float(np.max(np.abs(t - truth.t)))
    assert worst <= truth.t_tol, f"{truth.name}: time off by up to {worst:.3g} s"
    for a in ANGLES:
        got = df[a].to_numpy()
        want = truth.angles[a]
        gaps = np.isnan(want)
        assert np.array_equal(np.isnan(got), gaps), (
            f"{truth.name}, {a}: gaps at rows {np.nonzero(np.isnan(got) != gaps)[0][:10]} "
            "differ from the truth's")
        err = float(np.max(np.abs(got[~gaps] - want[~gaps])))
        assert err <= truth.angle_tol, f"{truth.name}, {a}: off by up to {err:.3g} rad"


def _params() -> list:
    return [pytest.param(case, id=case.id,
                         marks=[pytest.mark.xfail(strict=True, reason=case.xfail)]
                         if case.xfail else [])
            for case in CASES]


@pytest.mark.parametrize("case", _params())
def test_export(exports, case: Case) -> None:
    folder, truths = exports
    if case.file not in truths and case.file.endswith(".h5"):
        pytest.skip("h5py and tables (PyTables) are needed to write the HDF5 fixtures")
    truth = truths[case.file]
    if case.refused is not None:
        with pytest.raises(TrebuchetInputError) as err:
            _read(folder, truth, case)
        for word in case.refused:
            assert word in str(err.value), f"the refusal should name {word!r}: {err.value}"
        return
    check(_read(folder, truth, case), truth)


def test_every_fixture_has_a_case(exports) -> None:
    _, truths = exports
    cases = {c.file for c in CASES}
    assert set(truths) <= cases
    assert {c for c in cases if not c.endswith(".h5")} <= set(truths)


@pytest.mark.xfail(strict=True, reason=MIN_LIKELIHOOD)
def test_min_likelihood_default_is_deeplabcuts() -> None:
    """Below 0.6 (DeepLabCut's own plotting cut-off, ``pcutoff``) a position is a gap."""
    default = inspect.signature(trebuchet.read_log).parameters["min_likelihood"].default
    assert default == 0.6


def test_low_likelihood_gaps_are_reported(exports) -> None:
    folder, truths = exports
    truth = truths["dlc_single.csv"]
    df = _read(folder, truth, Case("dlc_single.csv", "report"))
    assert any("likelihood" in note for note in df.attrs["repairs"])


@pytest.mark.xfail(strict=True, reason=REPEATS)
@pytest.mark.parametrize("name", ["phone_upconverted_dlc.csv", "phone_upconverted_generic.csv"])
def test_upconverted_rate_is_noted(exports, name: str) -> None:
    """The repeated images are reported with the effective frame rate (60 fps)."""
    folder, truths = exports
    truth = truths[name]
    df = _read(folder, truth, Case(name, "note"))
    assert any("60" in note and "repeat" in note for note in df.attrs["repairs"])
