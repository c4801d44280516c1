"""Issue 26's smaller items on the command line: messages that name the right option once,
in good grammar, and say what they mean."""

from __future__ import annotations

import argparse

import pandas as pd
import pytest

import trebuchet as tb
from tests.exports import read_export
from tests.exports.shot import scene as export_scene
from trebuchet.cli import main
from trebuchet.core.errors import TrebuchetInputError, command_line
from trebuchet.ingest.cli import add_log_arguments, log_options
from trebuchet.ingest.compare import CHANCE_COLUMNS, METRIC_COLUMNS, QUANTITIES
from trebuchet.ingest.logs.scene_check import scene_check
from trebuchet.ingest.readers.table import Line, check_row_lengths
from trebuchet.model.scene import Scene
from trebuchet.report.compare_cli import _verdict_line
from trebuchet.report.verdict import verdict_html, verdict_table

from .conftest import HORSDAL, ROOT


def test_a_wrong_time_unit_names_its_option_once(exports):
    ms = read_export(exports, "generic_deg.csv")
    ms["t"] *= 1000.0
    with command_line(), pytest.raises(TrebuchetInputError) as cli:
        scene_check(ms, export_scene())
    with pytest.raises(TrebuchetInputError) as python:
        scene_check(ms, export_scene())
    assert str(cli.value).count("--time-unit") == 1 and "--angle-unit" not in str(cli.value)
    assert "ms read as s? State the unit: --time-unit ms" in str(cli.value)
    assert "State the unit: time_unit='ms'" in str(python.value)
    rad = read_export(exports, "generic_deg.csv")
    rad["theta"] = rad["theta"].map(lambda a: a * 3.141592653589793 / 180.0)
    with command_line(), pytest.raises(TrebuchetInputError, match="--angle-unit rad$"):
        scene_check(rad, export_scene())


def test_an_impossible_frame_rate_blames_fps_not_the_header(tmp_path, capsys):
    parser = argparse.ArgumentParser()
    add_log_arguments(parser)
    args = parser.parse_args(["log.csv", "--scene", "s.toml", "--fps", "1e9"])
    with pytest.raises(TrebuchetInputError, match=r"^--fps 1e\+09: no film of a shot has"):
        log_options(args)
    code = main(["forces", str(ROOT / "data_samples" / "video_paper_dlc.csv"), "--scene",
                 str(ROOT / "data_samples" / "video_paper.toml"), "--fps", "1e9", "-o",
                 str(tmp_path / "loads.csv")])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("trebuchet: error: --fps 1e+09:") and "header" not in err
    with pytest.raises(TrebuchetInputError, match="fps=2: no film of a shot has 2 frames"):
        tb.read_log(ROOT / "data_samples" / "video_paper_dlc.csv", fps=2)


def test_one_column_is_singular():
    with pytest.raises(TrebuchetInputError, match="but the header has 1 column "):
        check_row_lengths([Line(2, ["0.0", "1.0"])], 1)
    with pytest.raises(TrebuchetInputError, match="but the header has 2 columns "):
        check_row_lengths([Line(2, ["0.0", "1.0", "2.0"])], 2)


def test_simulate_takes_a_scene_file_as_reconstruct_does():
    by_path = tb.simulate(str(HORSDAL))
    pd.testing.assert_frame_equal(by_path, tb.simulate(Scene.from_toml(HORSDAL)))
    angles = by_path[["t", "phase", "theta", "theta_d", "theta_dd", "psi", "psi_d", "psi_dd",
                      "phi", "phi_d", "phi_dd"]]
    pd.testing.assert_frame_equal(tb.forces(angles, HORSDAL),
                                  tb.forces(angles, Scene.from_toml(HORSDAL)))
    with pytest.raises(TrebuchetInputError, match="simulate: expected a Scene or a scene"):
        tb.simulate(3)


def _metrics(verdicts: list[str]) -> pd.DataFrame:
    """A metrics table of the ten quantities with the verdicts given (numbers made up)."""
    rows = []
    for q, verdict in zip(QUANTITIES, verdicts, strict=True):
        row = dict.fromkeys(METRIC_COLUMNS + CHANCE_COLUMNS, 0.1)
        row.update(quantity=q.column, label=q.label, unit=q.unit, measured_peak=5e5,
                   measured_peak_sd=2e4, predicted_peak=4.6e5, verdict=verdict,
                   within_chance=verdict == "agrees", chance_fraction=0.05,
                   chance_limit=0.1, chance_limit_all=0.2, effective_samples=20.0)
        rows.append(row)
    return pd.DataFrame(rows)


@pytest.mark.parametrize("verdicts, says, never", [
    (["differs"] * 10, "differ in all 10 quantities", "other"),
    (["differs"] * 9 + ["agrees"], "differ in 9 of 10 quantities", "others"),
    (["differs"] * 2 + ["agrees"] * 8, "; the others agree.", "the other agrees"),
])
def test_the_verdict_counts_what_it_says(horsdal, verdicts, says, never):
    table = _metrics(verdicts)
    head = verdict_html(table, horsdal).split("</strong>")[0]
    assert says in head and never not in head, head
    if verdicts.count("agrees") == 1:
        assert "; the other agrees." in head
    line = _verdict_line(table)
    assert ("in all 10 quantities" in line) == (verdicts.count("differs") == 10), line


def test_forces_in_weights_read_as_weights_with_kn_beside(horsdal):
    short, _ = verdict_table(_metrics(["agrees"] * 10), horsdal)
    by = dict(zip(short["quantity"], short["peak predicted"], strict=True))
    hinge = next(v for k, v in by.items() if k.startswith("|F_H|"))
    assert "M·g (460\u00a0kN)" in hinge and "M g" not in " ".join(short.to_numpy().ravel())
