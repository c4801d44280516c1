"""Issue 17: compare takes every option of forces; hints in the words of the interface called;
the small ones (report folder named *.html, --dt, --accuracy in both commands, a closed pipe,
dir(tb), warnings at the caller's line, the sweep's progress and units)."""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
import warnings

import pytest

import trebuchet as tb
from trebuchet.cli import build_parser, cli_words, main
from trebuchet.core.errors import Option, TrebuchetInputError, command_line, warn_at_caller
from trebuchet.model import sweep as sweep_module

from .conftest import HORSDAL, ROOT

SAMPLES = ROOT / "data_samples"


def _options(command: str) -> dict[str, argparse.Action]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {flag: action for action in sub.choices[command]._actions
            for flag in action.option_strings}


# --- compare takes every option forces takes, same names and meanings

def test_compare_takes_every_option_of_forces_with_the_same_meaning():
    forces, compare = _options("forces"), _options("compare")
    # what is written differs: a CSV file there (--units: its header), a folder here; and
    # --quiet quiets each command's own lines (the summary there, progress lines here)
    own = ("-o", "--output", "-h", "--help", "--units", "--quiet")
    missing = sorted(set(forces) - set(compare) - set(own))
    assert missing == [], missing
    assert "--quiet" in compare
    for flag, action in forces.items():
        if flag in own:
            continue
        other = compare[flag]
        assert (other.dest, other.choices, other.type, other.metavar, other.help) == (
            action.dest, action.choices, action.type, action.metavar, action.help), flag
    for flag in ("--trigger", "--lift-off", "--release", "--form", "--trough", "--fps",
                 "--column", "--point", "--min-likelihood"):
        assert flag in compare


def test_compare_parses_event_times_and_form_like_forces():
    args = build_parser().parse_args(
        ["compare", "log.csv", "--scene", "s.toml", "-o", "rep", "--trigger", "1.0",
         "--lift-off", "1.34", "--release", "none", "--form", "direct",
         "--release-rule", "log"])
    from trebuchet.ingest.cli import reconstruct_options

    with command_line():
        options = reconstruct_options(args)
    assert options["events"] == {"trigger": 1.0, "lift_off": 1.34, "release": None}
    assert options["form"] == "direct" and args.release_rule == "log"


def test_the_old_release_words_still_choose_the_rule_with_a_note(tmp_path, capsys):
    from trebuchet.report.compare_cli import _release_rule

    args = build_parser().parse_args(["compare", "l.csv", "--scene", "s", "-o", "r",
                                      "--release", "scene"])
    assert _release_rule(args) == "scene" and args.release is None
    assert "--release-rule scene" in capsys.readouterr().err
    args = build_parser().parse_args(["compare", "l.csv", "--scene", "s", "-o", "r",
                                      "--release", "log", "--release-rule", "scene"])
    with pytest.raises(TrebuchetInputError, match="--release-rule"):
        _release_rule(args)


def test_a_bad_event_time_in_compare_names_its_option(tmp_path, capsys):
    code = main(["compare", str(SAMPLES / "horsdal_240fps.csv"), "--scene", str(HORSDAL),
                 "-o", str(tmp_path / "rep"), "--trigger", "soon"])
    assert code == 2
    assert "--trigger 'soon'" in capsys.readouterr().err
    assert not (tmp_path / "rep").exists()


# --- hints in the words of the interface called

def test_option_reads_as_a_flag_on_the_command_line_and_a_keyword_in_python():
    fps, column, point = Option("fps", 240), Option.column("x (deg)", "theta"), \
        Option.point("pivot", "axle")
    assert f"{fps}, {column}, {point}" == \
        "fps=240, columns={'x (deg)': 'theta'}, points={'pivot': 'axle'}"
    with command_line():
        assert f"{fps}, {column}, {point}" == \
            "--fps 240, --column 'x (deg)=theta', --point pivot=axle"
        assert str(Option("time_unit", "ms")) == "--time-unit ms"
    assert str(Option("min_likelihood")) == "min_likelihood"


def test_the_command_line_rewrites_keyword_hints_of_unconverted_messages():
    flags = {"--fps", "--column", "--point"}
    text = ("name it with columns={'<column in the file>': 'theta'}; or fps=240, "
            "points={'pivot': 'axle', 'spigot': 'tip'}; time_unit='ms' stays; pass fps= to "
            "use it")
    assert cli_words(text, flags) == (
        "name it with --column '<column in the file>=theta'; or --fps 240, "
        "--point pivot=axle --point spigot=tip; time_unit='ms' stays; pass --fps to use it")


@pytest.mark.parametrize("sample, flag", [("horsdal_tracker.txt", "--column"),
                                          ("horsdal_kinovea.csv", "--point"),
                                          ("horsdal_dlc.csv", "--fps")])
def test_plain_forces_on_the_shipped_samples_hints_with_options(tmp_path, capsys, sample,
                                                                flag):
    code = main(["forces", str(SAMPLES / sample), "--scene", str(HORSDAL), "-o",
                 str(tmp_path / "x.csv")])
    err = capsys.readouterr().err
    assert code == 2 and flag in err, err
    assert "columns=" not in err and "points=" not in err and "fps=" not in err, err


def test_python_callers_keep_keywords():
    with pytest.raises(TrebuchetInputError, match=r"columns=\{"):
        tb.read_log(SAMPLES / "horsdal_tracker.txt")


def test_the_shipped_samples_read_with_the_readme_options(tmp_path, capsys):
    """data_samples/README.md gives each sample's command line; the point files read."""
    readme = (SAMPLES / "README.md").read_text(encoding="utf-8")
    for flag in ("--column beam=theta", "--fps 240 --point pivot=axle", "--fps 120"):
        assert flag in readme
    code = main(["forces", str(SAMPLES / "horsdal_tracker.txt"), "--scene", str(HORSDAL),
                 "-o", str(tmp_path / "t.csv"), "--column", "beam=theta", "--column",
                 "arm=psi", "--column", "sling=phi"])
    assert code == 0, capsys.readouterr().err


def test_report_dt_names_the_option_in_each_interface(tmp_path, horsdal):
    from trebuchet.report.report_cli import report_scene

    with pytest.raises(TrebuchetInputError, match=r"^dt=0\.5"):
        report_scene(horsdal, tmp_path / "r", dt=0.5)
    with command_line(), pytest.raises(TrebuchetInputError, match=r"^--dt 0\.5"):
        report_scene(horsdal, tmp_path / "r", dt=0.5)


# --- the small ones

def test_a_report_folder_named_like_a_page_is_refused(tmp_path, capsys):
    out = tmp_path / "out" / "rep.html"
    assert main(["report", str(HORSDAL), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "rep.html" in err and "folder" in err and str(tmp_path / "out" / "rep") in err
    assert not out.exists()


@pytest.mark.parametrize("dt", ["1e308", "0", "-1", "nan"])
def test_simulate_refuses_an_output_step_that_misses_the_shot(tmp_path, capsys, dt):
    with pytest.raises(SystemExit) as info:
        main(["simulate", str(HORSDAL), "-o", str(tmp_path / "r.csv"), "--dt", dt])
    assert info.value.code == 2
    assert "--dt" in capsys.readouterr().err
    assert not (tmp_path / "r.csv").exists()


def test_accuracy_is_spelt_the_same_in_simulate_and_sweep():
    for command in ("simulate", "sweep"):
        flags = _options(command)
        assert "--accuracy" in flags and "--rtol" in flags, command
        assert flags["--accuracy"] is flags["--rtol"]
    args = build_parser().parse_args(["sweep", str(HORSDAL), "--grid", "engine.M=1e4",
                                      "-o", "x.csv", "--accuracy", "fast"])
    assert args.rtol == "fast"


def test_sweep_chunks_are_small_enough_for_the_bar_to_move():
    assert sweep_module._chunk_size(20_000, 2) <= 64
    assert sweep_module._chunk_size(8, 2) == 1


def test_sweep_gives_the_release_angle_in_degrees_too(horsdal):
    table = sweep_module.sweep(horsdal, {"release.velocity_angle_deg": [40.0]}, workers=1,
                               progress=False)
    row = table.iloc[0]
    assert row["release_angle_deg"] == pytest.approx(math.degrees(row["release_angle"]))
    assert row["release_angle_deg"] == pytest.approx(40.0, abs=0.5)


def test_a_closed_pipe_ends_quietly():
    code = ("import sys; sys.argv = ['trebuchet', 'paper']; from trebuchet.cli import main; "
            "sys.exit(main())")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    proc.stdout.readline()
    proc.stdout.close()  # as `| head -1` does
    err = proc.stderr.read().decode()
    proc.wait(timeout=60)
    assert "Broken pipe" not in err and "Traceback" not in err, err


def test_dir_shows_the_lazy_functions():
    for name in ("read_log", "smooth", "reconstruct", "compare", "simulate", "Scene"):
        assert name in dir(tb)


def test_warnings_point_at_the_callers_line():
    def deep():
        warn_at_caller("x", UserWarning)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        deep()
    assert caught[0].filename == __file__


def test_the_license_is_an_spdx_string_setuptools_does_not_warn_about():
    import tomllib

    data = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    assert data["project"]["license"] == "MIT"
    assert any(r.startswith("setuptools>=77") for r in data["build-system"]["requires"])


def test_read_log_options_reach_the_reader_in_forces(tmp_path, capsys):
    """--time-unit, --angle-unit, ... are read_log's: the log is read with them first."""
    code = main(["forces", str(SAMPLES / "horsdal_240fps.csv"), "--scene", str(HORSDAL),
                 "-o", str(tmp_path / "x.csv"), "--time-unit", "s", "--angle-unit", "deg"])
    assert code == 0, capsys.readouterr().err
