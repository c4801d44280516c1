"""read_log on bad logs: a TrebuchetInputError naming the file, the row or column, the problem."""

from __future__ import annotations

import random
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from trebuchet.core.errors import TrebuchetDataWarning, TrebuchetInputError
from trebuchet.ingest.logs.read_log import MIN_FRAMES, read_log

LOGS = Path(__file__).parent / "fixtures" / "logs"
HEADER = "t (s),theta (deg),psi (deg),phi (deg)"


def good_rows(n: int = 12) -> list[str]:
    """n rows of a moving engine, 100 fps, degrees."""
    return [f"{k / 100:.2f},{-50 + k:.1f},{-90 + 2 * k:.1f},{-180 + 3 * k:.1f}" for k in range(n)]


def write(tmp_path: Path, text: str, name: str = "shot.csv") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def error_of(path: Path, **kwargs) -> str:
    with pytest.raises(TrebuchetInputError) as err:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TrebuchetDataWarning)
            read_log(path, **kwargs)
    return str(err.value)


def test_missing_file(tmp_path):
    msg = error_of(tmp_path / "nowhere.csv")
    assert "nowhere.csv" in msg and "no such file" in msg


def test_empty_file(tmp_path):
    msg = error_of(write(tmp_path, "\n  \n"))
    assert "shot.csv" in msg and "empty" in msg


def test_header_only(tmp_path):
    msg = error_of(write(tmp_path, HEADER + "\n"))
    assert "shot.csv" in msg and "row 1" in msg and "no data" in msg


def test_missing_angle_column_lists_columns_and_suggests_columns(tmp_path):
    rows = [r.rsplit(",", 1)[0] + ",7" for r in good_rows()]
    msg = error_of(write(tmp_path, "t (s),theta (deg),psi (deg),sling (deg)\n" + "\n".join(rows)))
    assert "shot.csv" in msg and "phi" in msg
    assert "'sling (deg)'" in msg and "columns=" in msg


def test_text_in_a_numeric_cell_names_row_and_column(tmp_path):
    rows = good_rows()
    rows[4] = "0.04,-46.0,oops,-168.0"
    msg = error_of(write(tmp_path, HEADER + "\n" + "\n".join(rows)))
    # the header is line 1, so the fifth data row is line 6 of the file
    assert "shot.csv, row 6, column 'psi (deg)'" in msg and "'oops' is not a number" in msg


def test_the_file_is_named_once_in_front_of_the_place(tmp_path):
    """Readers raise with the place in the file; read_log adds the file's name once."""
    rows = good_rows()
    rows[4] = "0.04,-46.0,oops,-168.0"
    with pytest.raises(TrebuchetInputError) as err:
        read_log(write(tmp_path, HEADER + "\n" + "\n".join(rows), name="s.csv"))
    assert str(err.value).count("s.csv") == 1
    assert err.value.where.endswith("/s.csv, row 6, column 'psi (deg)'")
    assert err.value.message == "'oops' is not a number"


def test_text_in_an_unused_column_is_no_error(tmp_path):
    rows = [r + ",ok" for r in good_rows()]
    df = read_log(write(tmp_path, HEADER + ",comment\n" + "\n".join(rows)))
    assert len(df) == 12


def test_decreasing_time_is_an_error_naming_the_row(tmp_path):
    rows = good_rows()
    rows[7], rows[8] = rows[8], rows[7]
    msg = error_of(write(tmp_path, HEADER + "\n" + "\n".join(rows)))
    assert "shot.csv, row 10, column 't (s)'" in msg and "decreases" in msg


def test_empty_time_cell_names_the_row(tmp_path):
    rows = good_rows()
    rows[2] = "," + rows[2].split(",", 1)[1]
    msg = error_of(write(tmp_path, HEADER + "\n" + "\n".join(rows)))
    assert "shot.csv, row 4" in msg and "time is empty" in msg


def test_all_empty_angle_column(tmp_path):
    rows = [r.rsplit(",", 1)[0] + "," for r in good_rows()]
    msg = error_of(write(tmp_path, HEADER + "\n" + "\n".join(rows)))
    assert "shot.csv, column 'phi (deg)'" in msg and "no value" in msg


def test_too_few_frames_says_how_many_are_needed(tmp_path):
    msg = error_of(write(tmp_path, HEADER + "\n" + "\n".join(good_rows(MIN_FRAMES - 1))))
    assert "shot.csv" in msg and f"only {MIN_FRAMES - 1} frames" in msg
    assert f"at least {MIN_FRAMES}" in msg


def test_too_few_complete_frames_counts_rows_with_all_three_angles(tmp_path):
    rows = good_rows(14)
    for k in range(0, 14, 3):  # 5 rows lose psi: 9 complete frames remain
        cells = rows[k].split(",")
        cells[2] = ""
        rows[k] = ",".join(cells)
    msg = error_of(write(tmp_path, HEADER + "\n" + "\n".join(rows)))
    assert "only 9 frames with all three angles" in msg


@pytest.mark.parametrize(
    ("header", "column"),
    [
        ("t (fortnights),theta,psi,phi", "t (fortnights)"),
        ("t,theta (grad),psi,phi", "theta (grad)"),
    ],
)
def test_unknown_unit_names_the_column(tmp_path, header, column):
    msg = error_of(write(tmp_path, header + "\n" + "\n".join(good_rows())))
    assert f"shot.csv, column '{column}'" in msg and "unknown" in msg and "unit" in msg


def test_frame_column_without_fps(tmp_path):
    rows = [f"{k}," + r.split(",", 1)[1] for k, r in enumerate(good_rows())]
    msg = error_of(write(tmp_path, "frame,theta (deg),psi (deg),phi (deg)\n" + "\n".join(rows)))
    assert "shot.csv" in msg and "'frame'" in msg and "fps=" in msg


def test_frame_number_with_a_fraction(tmp_path):
    rows = [f"{k}," + r.split(",", 1)[1] for k, r in enumerate(good_rows())]
    rows[3] = "3.5," + rows[3].split(",", 1)[1]
    msg = error_of(write(tmp_path, "frame,theta,psi,phi\n" + "\n".join(rows)), fps=100)
    assert "shot.csv, row 5, column 'frame'" in msg and "not whole" in msg


@pytest.mark.parametrize("fps", [0, -240, float("nan"), "fast"])
def test_bad_fps(tmp_path, fps):
    msg = error_of(write(tmp_path, HEADER + "\n" + "\n".join(good_rows())), fps=fps)
    assert "shot.csv" in msg and "fps" in msg


def test_two_names_mapped_to_one_angle_is_ambiguous(tmp_path):
    p = write(tmp_path, "t,a (rad),b (rad),psi,phi\n" + "\n".join(
        f"{k / 100},{k},{k},{k},{k}" for k in range(12)))
    msg = error_of(p, columns={"a": "theta", "b": "theta"})
    assert "shot.csv" in msg and "ambiguous" in msg and "'a'" in msg and "'b'" in msg


def test_two_columns_named_after_one_angle_is_ambiguous(tmp_path):
    p = write(tmp_path, "t,theta (deg),theta (rad),psi,phi\n" + "\n".join(
        f"{k / 100},{k},{k},{k},{k}" for k in range(12)))
    msg = error_of(p)
    assert "ambiguous" in msg and "'theta (deg)'" in msg and "'theta (rad)'" in msg
    assert "columns=" in msg


def test_a_tracker_column_name_shared_by_tracks_is_ambiguous():
    msg = error_of(LOGS / "tracker_multi_tab.txt", columns={"θ": "theta"})
    assert "tracker_multi_tab.txt" in msg and "ambiguous" in msg and "'beam/θ'" in msg


def test_unknown_name_in_columns_lists_the_columns(tmp_path):
    msg = error_of(write(tmp_path, HEADER + "\n" + "\n".join(good_rows())),
                   columns={"beam": "theta"})
    assert "no column named 'beam'" in msg and "'theta (deg)'" in msg


def test_columns_target_must_be_an_angle(tmp_path):
    msg = error_of(write(tmp_path, HEADER + "\n" + "\n".join(good_rows())),
                   columns={"theta (deg)": "beta"})
    assert "shot.csv" in msg and "'beta'" in msg and "theta, psi, phi" in msg


def test_points_on_a_file_of_angles(tmp_path):
    msg = error_of(write(tmp_path, HEADER + "\n" + "\n".join(good_rows())),
                   points={"pivot": "axle"})
    assert "shot.csv" in msg and "points=" in msg and "no points" in msg


def test_row_with_more_cells_than_the_header(tmp_path):
    rows = good_rows()
    rows[5] += ",12.5"
    msg = error_of(write(tmp_path, HEADER + "\n" + "\n".join(rows)))
    assert "shot.csv, row 7" in msg and "header has 4 columns" in msg


def test_binary_file(tmp_path):
    p = tmp_path / "shot.h5"
    p.write_bytes(b"\x89HDF\r\n\x1a\n\x00\x00\x00\x00" * 10)
    msg = error_of(p)
    assert "shot.h5" in msg and "not a text" in msg


def test_no_time_column(tmp_path):
    msg = error_of(write(tmp_path, "theta,psi,phi\n" + "\n".join("1,2,3" for _ in range(12))))
    assert "shot.csv" in msg and "no time column" in msg and "'theta'" in msg


def test_deeplabcut_bad_cell_names_row_and_column(tmp_path):
    text = (LOGS / "deeplabcut.csv").read_text().splitlines()
    cells = text[6].split(",")
    cells[3] = "high"
    text[6] = ",".join(cells)
    msg = error_of(write(tmp_path, "\n".join(text) + "\n", "dlc.csv"), fps=240)
    assert "dlc.csv, row 7, column 'pivot/likelihood'" in msg


def test_mangled_fixtures_give_a_table_or_our_error_and_nothing_else(tmp_path):
    """Cut, blank or scribble over fixture lines at random: no pandas or numpy traceback."""
    rng = random.Random(7)
    sources = sorted(LOGS.glob("*.*"))
    sources = [s for s in sources if s.suffix != ".md"]
    kwargs = {
        "deeplabcut.csv": {"fps": 240},
        "kinovea_semicolon.csv": {"points": {"pivot": "axle", "spigot": "tip",
                                             "counterweight": "Weight", "projectile": "Stone"}},
        "tracker_multi_tab.txt": {"columns": {"beam": "theta", "arm": "psi", "sling": "phi"}},
    }
    outcomes = {"table": 0, "error": 0}
    for i in range(150):
        src = rng.choice(sources)
        lines = src.read_text().splitlines()
        for _ in range(rng.randint(1, 3)):
            k = rng.randrange(len(lines))
            action = rng.choice(["cut", "blank", "scribble", "drop", "swap"])
            if action == "cut":
                lines[k] = lines[k][: rng.randrange(len(lines[k]) + 1)]
            elif action == "blank":
                lines[k] = ""
            elif action == "scribble":
                pos = rng.randrange(len(lines[k]) + 1)
                lines[k] = lines[k][:pos] + rng.choice(["x", ";", ",", "\t", '"', "1e999"]) + \
                    lines[k][pos:]
            elif action == "drop" and len(lines) > 1:
                del lines[k]
            elif action == "swap" and k + 1 < len(lines):
                lines[k], lines[k + 1] = lines[k + 1], lines[k]
        p = tmp_path / f"m{i}_{src.name}"
        p.write_text("\n".join(lines) + "\n")
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", TrebuchetDataWarning)
                df = read_log(p, **kwargs.get(src.name, {}))
        except TrebuchetInputError as exc:
            assert p.name in str(exc)
            outcomes["error"] += 1
        else:
            assert isinstance(df, pd.DataFrame) and list(df.columns) == ["t", "theta", "psi", "phi"]
            assert np.all(np.diff(df["t"]) > 0)
            outcomes["table"] += 1
    assert outcomes["table"] > 20 and outcomes["error"] > 20, outcomes


def test_angles_without_unit_are_read_in_the_unit_their_values_tell(tmp_path):
    """Degree values reach beyond two turns in rad; radian values within ±π sweep too little
    in degrees for a shot. Each inference is said (a warned repair and a decision)."""
    text = "t,theta,psi,phi\n" + "\n".join(good_rows()) + "\n"
    with pytest.warns(TrebuchetDataWarning, match="angle unit of 'theta', 'psi', 'phi': deg"):
        df = read_log(write(tmp_path, text))
    np.testing.assert_allclose(df["theta"], np.radians(-50 + np.arange(12)), atol=1e-12)
    assert any("deg (inferred" in d for d in df.attrs["log"].decisions)
    radians = "t,theta,psi,phi\n" + "\n".join(
        f"{k / 100:.2f},{np.radians(-50 + k):.5f},{np.radians(-90 + 2 * k):.5f},"
        f"{np.radians(-180 + 3 * k):.5f}" for k in range(12)) + "\n"
    with pytest.warns(TrebuchetDataWarning, match="phi': rad"):
        assert len(read_log(write(tmp_path, radians, "rad.csv"))) == 12
    assert len(read_log(write(tmp_path, radians, "rad.csv"), angle_unit="rad")) == 12


def test_angles_without_unit_that_no_unit_makes_a_shot_are_refused(tmp_path):
    """A sweep of 10: more than a turn in rad, 10° in degrees (a shot sweeps 100-200°)."""
    text = "t,theta,psi,phi\n" + "\n".join(
        f"{k / 100:.2f},{-5 + k:.1f},{-9 + k:.1f},{-3 + k * 0.1:.1f}" for k in range(11)) + "\n"
    msg = error_of(write(tmp_path, text))
    assert "shot.csv, column 'theta'" in msg and "angle_unit=" in msg and "'theta (deg)'" in msg
    assert len(read_log(write(tmp_path, text), angle_unit="deg")) == 11


def test_times_in_ms_under_a_seconds_header_are_refused(tmp_path):
    rows = [f"{k * 10},{-50 + k:.1f},{-90 + 2 * k:.1f},{-180 + 3 * k:.1f}" for k in range(12)]
    msg = error_of(write(tmp_path, HEADER + "\n" + "\n".join(rows) + "\n"))
    assert "column 't (s)'" in msg and "0.1 fps" in msg and "(ms)" in msg


def test_a_frame_rate_the_times_contradict_is_refused(tmp_path):
    path = write(tmp_path, HEADER + "\n" + "\n".join(good_rows()) + "\n")
    msg = error_of(path, fps=10)
    assert "fps=10" in msg and "100 per s" in msg
    assert len(read_log(path, fps=100)) == 12  # the rate the times have: fine


def test_columns_on_a_file_of_points_point_to_points(tmp_path):
    dlc = Path(__file__).parents[1] / "data_samples" / "horsdal_dlc.csv"
    msg = error_of(dlc, fps=120, columns={"axle": "theta"})
    assert "'axle'" in msg and "point positions" in msg and "points=" in msg


def test_a_column_that_is_no_angle_is_reported_not_dropped_silently(tmp_path):
    rows = [r + ",first try" for r in good_rows()]
    path = write(tmp_path, HEADER + ",note\n" + "\n".join(rows) + "\n")
    with pytest.warns(TrebuchetDataWarning, match="'note' not used"):
        log = read_log(path)
    assert any("'note' not used" in r for r in log.attrs["log"].repairs)


def test_an_absurd_value_under_a_stated_unit_names_its_row_not_the_header(tmp_path):
    rows = good_rows()
    rows[5] = "0.05,1e308,-80.0,-165.0"
    msg = error_of(write(tmp_path, HEADER + "\n" + "\n".join(rows)))
    assert "row 7, column 'theta (deg)'" in msg and "corrupt or misplaced" in msg
    assert "say so in its header" not in msg


def test_a_missing_angle_hint_speaks_the_callers_words(tmp_path):
    """Python callers are told the keyword, command-line users the flag."""
    from trebuchet.core.errors import command_line

    rows = [r.rsplit(",", 1)[0] + ",7" for r in good_rows()]
    path = write(tmp_path, "t (s),theta (deg),psi (deg),sling (deg)\n" + "\n".join(rows))
    assert "columns={" in error_of(path)
    with command_line():
        cli = error_of(path)
    assert "--column '<column in the file>=phi'" in cli and "columns=" not in cli
