"""`trebuchet forces`: output file, summary, overrides, and one-line errors with status 2."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from trebuchet.cli import main
from trebuchet.ingest.cli import parse_pairs
from trebuchet.ingest.logs.read_log import write_log
from trebuchet.ingest.synthetic.simulated_log import simulated_log

from .conftest import HORSDAL


@pytest.fixture(scope="module")
def shot_file(tmp_path_factory, horsdal):
    log, truth = simulated_log(horsdal, 120, 0.5, seed=21, drop_fraction=0.02)
    path = tmp_path_factory.mktemp("forces") / "shot.csv"
    renamed = log.rename(columns={"theta": "beam", "psi": "arm", "phi": "sling"})
    lines = write_log(log, path).read_text().splitlines()
    lines[0] = "t (s),beam (deg),arm (deg),sling (deg)"
    path.write_text("\n".join(lines) + "\n")
    return path, renamed, truth


def test_forces_writes_loads_and_a_summary(shot_file, tmp_path, capsys):
    path, _, truth = shot_file
    out = tmp_path / "loads.csv"
    code = main(["forces", str(path), "--scene", str(HORSDAL), "-o", str(out),
                 "--column", "beam=theta", "--column", "arm=psi", "--column", "sling=phi"])
    assert code == 0
    captured = capsys.readouterr()
    text = captured.out
    for word in ("angle noise", "trigger", "lift-off", "release", "repairs", "|F_R|", "|F_H|",
                 "|F_S|", "torque", "±"):
        assert word in text, word
    # the log's repairs are warnings on stderr, as compare gives them, not results on stdout
    assert "missing on" not in text and "trebuchet: warning:" not in text
    assert "trebuchet: warning:" in captured.err and "missing on" in captured.err
    loads = pd.read_csv(out)
    assert len(loads) == len(truth)
    for col in ("t", "t_shot", "phase", "F_R_x", "F_R_x_sd", "torque_sd", "P_M_sd"):
        assert col in loads.columns
    np.testing.assert_allclose(loads["t"], truth["t"], rtol=0, atol=1e-12)


def test_quiet_forces_prints_no_summary_and_units_go_into_the_header(shot_file, tmp_path,
                                                                     capsys):
    path, _, truth = shot_file
    out = tmp_path / "loads.csv"
    code = main(["forces", str(path), "--scene", str(HORSDAL), "-o", str(out), "--quiet",
                 "--units", "--column", "beam=theta", "--column", "arm=psi", "--column",
                 "sling=phi"])
    captured = capsys.readouterr()
    assert code == 0 and captured.out == ""
    assert "trebuchet: warning:" in captured.err and "missing on" in captured.err
    loads = pd.read_csv(out)
    assert list(loads.columns[:4]) == ["t (s)", "t_shot (s)", "phase", "theta (rad)"]
    assert "F_R_x_sd (N)" in loads.columns and "torque (N m)" in loads.columns
    assert len(loads) == len(truth)


def test_given_events_are_used(shot_file, tmp_path, capsys):
    path, _, truth = shot_file
    ev = truth.attrs["events"]
    out = tmp_path / "loads.csv"
    code = main(["forces", str(path), "--scene", str(HORSDAL), "-o", str(out),
                 "--column", "beam=theta", "--column", "arm=psi", "--column", "sling=phi",
                 "--trigger", str(ev["trigger"]), "--release", str(ev["release"]),
                 "--lift-off", "none", "--form", "direct"])
    assert code == 0
    text = capsys.readouterr().out
    assert "(given)" in text and "given as none" in text and "formulas: direct" in text
    phase = pd.read_csv(out)["phase"].to_numpy()
    assert 2 not in phase  # no lift-off: the projectile stays in the trough until release


def test_a_log_starting_mid_swing_says_where_t_shot_counts_from(shot_file, tmp_path, capsys):
    _, renamed, truth = shot_file
    late = renamed[renamed["t"] > truth.attrs["events"]["trigger"] + 0.3]
    path = tmp_path / "late.csv"
    write_log(late.rename(columns={"beam": "theta", "arm": "psi", "sling": "phi"}), path)
    out = tmp_path / "loads.csv"
    assert main(["forces", str(path), "--scene", str(HORSDAL), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "notes:" in text and "t_shot counts from the first frame" in text
    assert pd.read_csv(out)["t_shot"].iloc[0] == 0.0


@pytest.mark.parametrize("extra, message", [
    (["--column", "beam=omega"], "'omega' is not one of theta, psi, phi"),
    (["--column", "beam"], "expected NAME=ANGLE"),
    (["--point", "wheel=x"], "'wheel' is not one of"),
    (["--release", "soon"], "--release 'soon': not a time"),
    (["--fps", "-3"], "--fps -3: must be a positive frame rate"),
])
def test_bad_options_exit_2_with_one_line(shot_file, tmp_path, capsys, extra, message):
    path, _, _ = shot_file
    out = tmp_path / "loads.csv"
    code = main(["forces", str(path), "--scene", str(HORSDAL), "-o", str(out), *extra])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not out.exists()


def test_missing_files_exit_2(shot_file, tmp_path, capsys):
    path, _, _ = shot_file
    out = tmp_path / "loads.csv"
    assert main(["forces", str(path), "--scene", str(tmp_path / "no.toml"), "-o", str(out)]) == 2
    assert "no.toml" in capsys.readouterr().err
    assert main(["forces", str(tmp_path / "none.csv"), "--scene", str(HORSDAL),
                 "-o", str(out)]) == 2
    assert "none.csv" in capsys.readouterr().err
    assert not out.exists()


def test_parse_pairs():
    assert parse_pairs(["a=b=theta"], "--column", ("theta",), "right") == {"a=b": "theta"}
    assert parse_pairs(["pivot=Beam/axle"], "--point", ("pivot",), "left") == {
        "pivot": "Beam/axle"}
    assert parse_pairs([], "--column", ("theta",), "right") is None
