"""Every export fixture of :mod:`tests.exports` read through ``trebuchet.read_log`` and
compared with its truth (issue 14).

Each file is written at test time, in the layout its tool writes (see the writer modules
and docs/formats.md), from the simulated shot of the paper's engine. A case reads one file
the way a user would (``fps``, ``points`` or ``columns``, as the file cannot say them), and
the ambiguous ones both ways: the unit or the individual stated by keyword, and inferred
from the file. A case that cannot pass yet is a strict xfail naming the missing piece
(``Case.xfail``): it flips to a failure (to be unmarked) the day it passes.
"""

from __future__ import annotations

import inspect
import warnings
from dataclasses import dataclass, field

import numpy as np
import pytest

import trebuchet
from tests.exports.shot import BEAM_ROWS, BEAM_TOL
from tests.exports.truth import Truth
from trebuchet.core.errors import TrebuchetInputError

ANGLES = ("theta", "psi", "phi")

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
    Case("dlc_single.h5", "user"),
    Case("dlc_multi.csv", "individual"),
    Case("dlc_multi.csv", "no-individual", drop=("individual",), refused=("ind1", "ind2")),
    Case("dlc_multi_el.h5", "individual"),
    Case("dlc_multi_el.h5", "no-individual", drop=("individual",), refused=("ind1", "ind2")),
    Case("dlc_multi_one.h5", "only-individual"),
    Case("phone_upconverted_dlc.csv", "user"),
    # SLEAP
    Case("sleap_two_tracks.analysis.h5", "individual"),
    Case("sleap_two_tracks.analysis.h5", "no-individual", drop=("individual",),
         refused=("track_0", "track_1")),
    Case("sleap_two_tracks.analysis.csv", "individual"),
    Case("sleap_two_tracks.analysis.csv", "no-individual", drop=("individual",),
         refused=("track_0", "track_1")),
    Case("sleap_untracked.analysis.h5", "user"),
    Case("sleap_untracked.analysis.csv", "user"),
    # anipose
    Case("anipose_pose3d.csv", "user"),
    # Kinovea: every time code, stated by keyword and inferred from the frame pattern
    Case("kinovea_2024_classic_s.csv", "keyword", {"time_unit": "s"}),
    Case("kinovea_2024_classic_s.csv", "inferred"),
    Case("kinovea_2025_classic_s_fr.csv", "keyword", {"time_unit": "s"}),
    Case("kinovea_2025_classic_s_fr.csv", "inferred"),
    Case("kinovea_ms_fraction_de.csv", "keyword", {"time_unit": "ms"}),
    Case("kinovea_ms_fraction_de.csv", "inferred"),
    Case("kinovea_us.csv", "keyword", {"time_unit": "us"}),
    Case("kinovea_us.csv", "inferred"),
    Case("kinovea_frames_origin.csv", "keyword", {"time_unit": "frames"}),
    Case("kinovea_frames_origin.csv", "inferred"),
    Case("kinovea_frames_origin.csv", "no-fps", drop=("fps",), refused=("fps",)),
    Case("kinovea_frames_comma.csv", "keyword", {"time_unit": "frames"}),
    Case("kinovea_frames_comma.csv", "inferred"),
    Case("kinovea_image_space_px.csv", "keyword", {"time_unit": "ms"}),
    Case("kinovea_image_space_px.csv", "inferred"),
    Case("kinovea_hundredth_min.csv", "refused", refused=("Time",)),
    # Tracker
    Case("tracker_protractor_deg.txt", "user"),
    Case("tracker_protractor_deg.txt", "keyword", {"angle_unit": "deg"}),
    Case("tracker_protractor_rad.txt", "keyword", {"angle_unit": "rad"}),
    Case("tracker_protractor_rad.txt", "inferred"),
    Case("tracker_protractor_deg_comma.txt", "user"),
    Case("tracker_pointmass.txt", "user"),
    # plain CSV
    Case("generic_deg.csv", "user"),
    Case("generic_nounit_deg.csv", "keyword", {"angle_unit": "deg"}),
    Case("generic_nounit_deg.csv", "inferred"),
    Case("generic_time_ms.csv", "keyword", {"time_unit": "ms"}),
    Case("generic_time_ms.csv", "inferred"),
    Case("phone_upconverted_generic.csv", "user"),
]


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
        beam = np.zeros(len(want), dtype=bool)
        if a == "psi" and BEAM_ROWS in truth.angles:
            beam = truth.angles[BEAM_ROWS] > 0
        exact = ~gaps & ~beam
        err = float(np.max(np.abs(got[exact] - want[exact])))
        assert err <= truth.angle_tol, f"{truth.name}, {a}: off by up to {err:.3g} rad"
        if np.any(beam):  # psi from the beam's hinge where the tracker lost the hinge
            err = float(np.max(np.abs(got[beam] - want[beam])))
            assert err <= BEAM_TOL, f"{truth.name}, psi from the beam off by up to {err:.3g} rad"


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


def test_min_likelihood_default_is_deeplabcuts() -> None:
    """Below 0.6 (DeepLabCut's own plotting cut-off, ``pcutoff``) a position is a gap."""
    default = inspect.signature(trebuchet.read_log).parameters["min_likelihood"].default
    assert default == 0.6


def test_low_likelihood_gaps_are_reported(exports) -> None:
    folder, truths = exports
    truth = truths["dlc_single.csv"]
    df = _read(folder, truth, Case("dlc_single.csv", "report"))
    assert any("likelihood" in note for note in df.attrs["log"].repairs)


@pytest.mark.parametrize("name", ["phone_upconverted_dlc.csv", "phone_upconverted_generic.csv"])
def test_upconverted_rate_is_noted(exports, name: str) -> None:
    """The repeated images are reported with the effective frame rate (60 fps)."""
    folder, truths = exports
    truth = truths[name]
    df = _read(folder, truth, Case(name, "note"))
    assert any("60" in note and "repeat" in note for note in df.attrs["log"].repairs)


# ---------------------------------------------------------------- the readers, one by one
# Phase 2 of issue 14: readers for the layouts above, tested on the fixtures before
# read_log dispatches to them (each case flips its read_log case above once wired).


def _numbered(path):
    from trebuchet.ingest.readers.table import read_text, split_lines

    return split_lines(read_text(path))


def _read_sleap_h5(path, truth, individual):
    from trebuchet.ingest.readers.sleap import looks_like_sleap_h5, read_sleap_h5

    assert looks_like_sleap_h5(path)
    return read_sleap_h5(path, truth.read["fps"], truth.min_likelihood, individual)


def _read_sleap_csv(path, truth, individual):
    from trebuchet.ingest.readers.sleap import looks_like_sleap_csv, read_sleap_csv

    numbered = _numbered(path)
    assert looks_like_sleap_csv(numbered)
    return read_sleap_csv(numbered, truth.read["fps"], truth.min_likelihood, individual)


def _read_dlc_h5(path, truth, individual):
    from trebuchet.ingest.readers.deeplabcut import read_deeplabcut_h5

    return read_deeplabcut_h5(path, truth.read["fps"], truth.min_likelihood, individual)


def _read_dlc_csv(path, truth, individual):
    from trebuchet.ingest.readers.deeplabcut import read_deeplabcut

    return read_deeplabcut(_numbered(path), truth.read["fps"], truth.min_likelihood,
                           individual)


def _read_anipose(path, truth, individual):
    from trebuchet.ingest.readers.anipose import looks_like_anipose, read_anipose

    numbered = _numbered(path)
    assert looks_like_anipose(numbered)
    return read_anipose(numbered, truth.read["fps"], truth.read["points"])


READERS = {
    "sleap_two_tracks.analysis.h5": _read_sleap_h5,
    "sleap_untracked.analysis.h5": _read_sleap_h5,
    "sleap_two_tracks.analysis.csv": _read_sleap_csv,
    "sleap_untracked.analysis.csv": _read_sleap_csv,
    "dlc_single.h5": _read_dlc_h5,
    "dlc_multi_el.h5": _read_dlc_h5,
    "dlc_multi_one.h5": _read_dlc_h5,
    "dlc_multi.csv": _read_dlc_csv,
    "anipose_pose3d.csv": _read_anipose,
}


def _source_angles(path, source, points):
    """(t, angles) of a reader's LogSource as read_log computes them from the points, rows
    without any angle left out."""
    from trebuchet.ingest.geometry.points import point_angles, resolve_points

    chosen = resolve_points(source.point_tracks, dict(points))
    angles = point_angles({r: c.data()[:2] for r, c in chosen.items()})
    keep = np.zeros(len(source.t), dtype=bool)
    for a in ANGLES:
        keep |= np.isfinite(angles[a])
    return source.t[keep], {a: angles[a][keep] for a in ANGLES}


@pytest.mark.parametrize("name", sorted(READERS))
def test_reader(exports, name: str) -> None:
    folder, truths = exports
    if name not in truths:
        pytest.skip("h5py and tables (PyTables) are needed to write the HDF5 fixtures")
    truth = truths[name]
    path = folder / name
    source = READERS[name](path, truth, truth.read.get("individual"))
    t, angles = _source_angles(path, source, truth.read["points"])
    assert len(t) == len(truth.t)
    assert np.max(np.abs(t - truth.t)) <= truth.t_tol
    for a in ANGLES:
        want = truth.angles[a]
        if a == "psi" and BEAM_ROWS in truth.angles:  # read_log fills these from the beam
            want = np.where(truth.angles[BEAM_ROWS] > 0, np.nan, want)
        assert np.array_equal(np.isnan(angles[a]), np.isnan(want)), a
        ok = np.isfinite(want)
        err = np.max(np.abs(angles[a][ok] - want[ok]))
        assert err <= truth.angle_tol, f"{name}, {a}: off by {err:.3g} rad"


@pytest.mark.parametrize("name", [n for n in sorted(READERS)
                                  if n.startswith(("sleap_two", "dlc_multi."))
                                  or n == "dlc_multi_el.h5"])
def test_reader_refuses_without_individual(exports, name: str) -> None:
    folder, truths = exports
    if name not in truths:
        pytest.skip("h5py and tables (PyTables) are needed to write the HDF5 fixtures")
    truth = truths[name]
    with pytest.raises(TrebuchetInputError) as err:
        READERS[name](folder / name, truth, None)
    for who in truth.individuals:
        assert repr(who) in str(err.value)


@pytest.mark.parametrize("name, individual, words", [
    ("sleap_two_tracks.analysis.csv", "track_7", ("track_7", "'track_0'", "'track_1'")),
    ("dlc_multi.csv", "ind3", ("ind3", "'ind1'", "'ind2'")),
])
def test_reader_names_an_unknown_individual(exports, name, individual, words) -> None:
    folder, truths = exports
    with pytest.raises(TrebuchetInputError) as err:
        READERS[name](folder / name, truths[name], individual)
    for word in words:
        assert word in str(err.value)


def test_single_animal_file_refuses_an_individual(exports) -> None:
    from trebuchet.ingest.readers.deeplabcut import read_deeplabcut

    folder, truths = exports
    path = folder / "dlc_single.csv"
    with pytest.raises(TrebuchetInputError, match="single-animal"):
        read_deeplabcut(_numbered(path), 120.0, 0.6, "ind1")


def test_anipose_needs_the_four_engine_points(exports) -> None:
    from trebuchet.ingest.readers.anipose import read_anipose

    folder, _ = exports
    path = folder / "anipose_pose3d.csv"
    with pytest.raises(TrebuchetInputError, match="hinge") as err:
        read_anipose(_numbered(path), 100.0, {"pivot": "axle", "spigot": "arm_tip"})
    assert "weight" in str(err.value)     # the joints are listed


def test_anipose_refuses_points_off_any_plane(exports, tmp_path) -> None:
    from trebuchet.ingest.readers.anipose import read_anipose

    folder, truths = exports
    text = (folder / "anipose_pose3d.csv").read_text().splitlines()
    header = text[0].split(",")
    z = header.index("stone_z")
    rng = np.random.default_rng(1)
    rows = []
    for line in text[1:]:
        cells = line.split(",")
        if cells[z]:
            cells[z] = repr(float(cells[z]) + rng.normal(0, 3000.0))
        rows.append(",".join(cells))
    path = tmp_path / "bent.csv"
    path.write_text("\n".join([text[0], *rows]) + "\n")
    with pytest.raises(TrebuchetInputError, match="plane"):
        read_anipose(_numbered(path), 100.0, truths["anipose_pose3d.csv"].read["points"])
