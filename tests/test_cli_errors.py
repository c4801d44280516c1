"""A user's mistake on the command line: status 2, one line on stderr naming what is wrong, no
traceback, no output file; and the outputs a user gets are ordinary files."""

from __future__ import annotations

import dataclasses
import os
import stat
import tomllib

import numpy as np
import pytest

import trebuchet as tb
from trebuchet.cli import main
from trebuchet.core.errors import TrebuchetInputError
from trebuchet.core.output import OUTPUT_MARKER

from .conftest import HORSDAL


def _toml(data: dict) -> str:
    """A scene dict as TOML (numbers and strings only)."""
    lines = []
    for section, keys in data.items():
        lines.append(f"[{section}]")
        lines += [f"{k} = {v!r}" if isinstance(v, str) else f"{k} = {v}" for k, v in
                  keys.items()]
    return "\n".join(lines).replace("'", '"') + "\n"


def _scene_file(tmp_path, name: str, **changes) -> str:
    data = tomllib.loads(HORSDAL.read_text(encoding="utf-8"))
    for section, keys in changes.items():
        if keys is None:
            data.pop(section)
            continue
        for key, value in keys.items():
            if value is None:
                data[section].pop(key)
            else:
                data[section][key] = value
    path = tmp_path / name
    path.write_text(_toml(data), encoding="utf-8")
    return str(path)


def _refused(capsys, argv: list[str], *words: str) -> str:
    try:
        code = main(argv)
    except SystemExit as stop:  # argparse ends the program itself
        code = stop.code
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "Traceback" not in err[0]
    for w in words:
        assert w in err[0], (w, err[0])
    return err[0]


def test_output_that_cannot_be_written_is_refused_in_one_line(tmp_path, capsys):
    folder = tmp_path / "a_folder"
    folder.mkdir()
    _refused(capsys, ["simulate", str(HORSDAL), "-o", str(folder)], str(folder), "folder")
    a_file = tmp_path / "a_file"
    a_file.write_text("keep\n")
    _refused(capsys, ["simulate", str(HORSDAL), "-o", str(a_file / "run.csv")], str(a_file))
    _refused(capsys, ["paper", "-o", str(folder)], "folder")
    assert list(folder.iterdir()) == [] and a_file.read_text() == "keep\n"


def test_a_report_never_replaces_a_file_or_someone_elses_folder(tmp_path, capsys):
    a_file = tmp_path / "notes.txt"
    a_file.write_text("keep\n")
    _refused(capsys, ["report", str(HORSDAL), "-o", str(a_file), "--quiet"], "is a file")
    assert a_file.read_text() == "keep\n"
    theirs = tmp_path / "photos"
    theirs.mkdir()
    (theirs / "shot.jpg").write_bytes(b"\xff\xd8")
    _refused(capsys, ["report", str(HORSDAL), "-o", str(theirs), "--quiet"], "other files")
    assert [p.name for p in theirs.iterdir()] == ["shot.jpg"]


def test_a_report_folder_replaces_the_previous_report(tmp_path, capsys, monkeypatch):
    from trebuchet.report import page as report_mod
    monkeypatch.setattr(report_mod, "FIGURE_DPI", 30)
    out = tmp_path / "rep"
    for _ in range(2):
        assert main(["report", str(HORSDAL), "-o", str(out), "--quiet", "--dt", "0.005"]) == 0
    assert (out / OUTPUT_MARKER).is_file() and (out / "index.html").is_file()


def test_outputs_follow_the_umask(tmp_path, capsys):
    old = os.umask(0o022)
    try:
        out = tmp_path / "run.csv"
        assert main(["simulate", str(HORSDAL), "-o", str(out), "--dt", "0.01"]) == 0
    finally:
        os.umask(old)
    assert stat.S_IMODE(out.stat().st_mode) == 0o644


@pytest.mark.parametrize("dt", ["0", "-1", "nan"])
def test_a_bad_output_step_is_refused(tmp_path, capsys, dt):
    out = tmp_path / "run.csv"
    _refused(capsys, ["simulate", str(HORSDAL), "-o", str(out), f"--dt={dt}"], "dt")
    assert not out.exists()


def test_a_mistyped_command_line_is_one_line(capsys):
    line = _refused(capsys, ["simulate", str(HORSDAL)], "-o")
    assert line.startswith("trebuchet simulate: error:")
    _refused(capsys, ["simulate", str(HORSDAL), "-o", "x.csv", "--accuracy", "bogus"], "bogus")


@pytest.mark.parametrize("start, expect", [
    ({"projectile": "sling", "phi_deg": -90.0}, "release"),
    ({"projectile": "none", "phi_deg": None}, "dry fire"),
])
def test_simulate_summarises_scenes_without_a_trough(tmp_path, capsys, start, expect):
    changes = {"start": start, "engine": {"H": 12.0}}
    if start["projectile"] == "none":
        changes = {"start": start, "engine": {"m": None, "L4": None}, "release": None}
    scene = _scene_file(tmp_path, "variant.toml", **changes)
    out = tmp_path / "run.csv"
    assert main(["simulate", scene, "-o", str(out), "--dt", "0.01"]) == 0
    said = capsys.readouterr().out
    assert expect in said and "lift-off" not in said
    assert out.is_file()


def test_the_paper_table_needs_a_shot_from_the_trough(tmp_path, capsys):
    dry = _scene_file(tmp_path, "dry.toml", start={"projectile": "none", "phi_deg": None},
                      engine={"m": None, "L4": None}, release=None)
    _refused(capsys, ["paper", "--scene", dry], "dry.toml", "projectile")


def test_bad_output_times_are_refused(horsdal):
    with pytest.raises(TrebuchetInputError, match=r"t_eval\[1\] = nan"):
        tb.simulate(horsdal, t_eval=[0.1, np.nan])
    with pytest.raises(TrebuchetInputError, match="numbers"):
        tb.simulate(horsdal, t_eval=["a", "b"])


def test_an_engine_refuses_impossible_values_however_it_is_built(horsdal):
    with pytest.raises(TrebuchetInputError, match="M = -5"):
        dataclasses.replace(horsdal.engine, M=-5.0)
    with pytest.raises(TrebuchetInputError, match="L_CM"):
        dataclasses.replace(horsdal.engine, L_CM=100.0)


def test_a_bad_report_folder_is_refused_before_the_work_starts(tmp_path, capsys):
    """No progress line comes before the refusal: the target is checked first."""
    a_file = tmp_path / "a_file"
    a_file.write_text("keep\n")
    _refused(capsys, ["report", str(HORSDAL), "-o", str(a_file / "rep")], str(a_file))


def test_compare_and_forces_refuse_before_their_progress_lines(tmp_path, capsys):
    missing = tmp_path / "shot.csv"
    _refused(capsys, ["compare", str(missing), "--scene", str(HORSDAL), "-o",
                      str(tmp_path / "rep")], str(missing), "no such file")
    log = HORSDAL.parent / "horsdal_240fps.csv"
    _refused(capsys, ["forces", str(log), "--scene", str(HORSDAL), "-o", str(tmp_path)],
             "folder")


def test_compare_refuses_a_bad_log_before_its_progress_lines(tmp_path, capsys):
    lines = (HORSDAL.parent / "horsdal_240fps.csv").read_text(encoding="utf-8").splitlines()
    cells = lines[20].split(",")
    cells[1] = "abc"
    lines[20] = ",".join(cells)
    bad = tmp_path / "shot.csv"
    bad.write_text("\n".join(lines) + "\n", encoding="utf-8")
    _refused(capsys, ["compare", str(bad), "--scene", str(HORSDAL), "-o", str(tmp_path / "r")],
             "shot.csv", "row", "'abc'")
