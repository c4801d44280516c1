"""trebuchet compare: the report directory (index.html, metrics.csv with the contract's columns,
figures), progress lines, and all or nothing: a failure midway leaves no report behind."""

from __future__ import annotations

import argparse

import matplotlib

matplotlib.use("Agg")

import pandas as pd  # noqa: E402
import pytest  # noqa: E402

import trebuchet.report.figures as figures_module
from tests.conftest import HORSDAL, ROOT  # noqa: E402
from trebuchet import cli  # noqa: E402
from trebuchet.core.errors import TrebuchetInputError  # noqa: E402
from trebuchet.core.output import OUTPUT_MARKER  # noqa: E402
from trebuchet.ingest.cli import log_options  # noqa: E402
from trebuchet.ingest.compare import CONTRACT_COLUMNS, QUANTITIES  # noqa: E402
from trebuchet.report import compare_cli
from trebuchet.report.figures import FIGURES  # noqa: E402

DEMO_LOG = ROOT / "data_samples" / "horsdal_240fps.csv"
# the sample's gaps and resolution advisory: they go to the report, checked there
pytestmark = [pytest.mark.filterwarnings("ignore::trebuchet.core.errors.TrebuchetDataWarning"),
              pytest.mark.filterwarnings("ignore::trebuchet.core.errors.ModelValidityWarning")]


@pytest.fixture
def run(monkeypatch):
    """``trebuchet ...`` through cli.main with the compare room registered (the lead adds it to
    ROOMS; until then this parser stands in)."""
    def build() -> argparse.ArgumentParser:
        parser = argparse.ArgumentParser(prog="trebuchet")
        compare_cli.register(parser.add_subparsers(dest="command", required=True))
        return parser

    monkeypatch.setattr(cli, "build_parser", build)
    return lambda *argv: cli.main([str(a) for a in argv])


def leftovers(parent):
    return sorted(p.name for p in parent.iterdir() if p.name.startswith("."))


def test_compare_writes_a_complete_report(run, tmp_path, capsys):
    out = tmp_path / "report"
    assert run("compare", DEMO_LOG, "--scene", HORSDAL, "-o", out) == 0
    captured = capsys.readouterr()
    assert str(out / "index.html") in captured.out
    for step in ("reconstructing", "simulating", "drawing tension.png"):
        assert step in captured.err
    table = pd.read_csv(out / "metrics.csv")
    assert list(table.columns[:6]) == CONTRACT_COLUMNS
    assert list(table["quantity"]) == [q.column for q in QUANTITIES]
    assert table[CONTRACT_COLUMNS[1:]].notna().all().all()
    assert set(pd.read_csv(out / "events.csv")["event"]) == {"start", "lift_off", "release"}
    html = (out / "index.html").read_text(encoding="utf-8")
    for name in FIGURES:
        assert (out / f"{name}.png").stat().st_size > 1000
        assert f'src="{name}.png"' in html
    assert "Advisories" in html and "left as gaps" in html  # the log's repairs
    assert "metrics" in html and "F_R_perp" in html and "release" in html
    assert "{" not in html.split("<body>")[1]  # no unformatted placeholders
    assert leftovers(tmp_path) == []


def test_a_failure_midway_leaves_no_report_and_keeps_an_old_one(run, tmp_path, monkeypatch):
    def broken(predicted, measured, scene):
        raise RuntimeError("figure broke")

    figures = dict(list(FIGURES.items())[:1]) | {"broken": broken}
    monkeypatch.setattr(figures_module, "FIGURES", figures)
    fresh = tmp_path / "fresh"
    with pytest.raises(RuntimeError, match="figure broke"):
        compare_cli.compare_report(DEMO_LOG, HORSDAL, fresh, progress=None)
    assert not fresh.exists()
    old = tmp_path / "old"
    old.mkdir()
    (old / "index.html").write_text("the old report")
    (old / OUTPUT_MARKER).write_text('{"written_by": "trebuchet", "files": ["index.html"]}')
    with pytest.raises(RuntimeError):
        run("compare", DEMO_LOG, "--scene", HORSDAL, "-o", old, "--quiet")
    assert (old / "index.html").read_text() == "the old report"
    assert sorted(p.name for p in old.iterdir()) == [OUTPUT_MARKER, "index.html"]
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("extra, expected", [
    (["--column", "beam=rho"], "--column 'beam=rho': 'rho' is not one of theta, psi, phi"),
    (["--point", "tip"], "--point 'tip': expected ROLE=NAME with ROLE one of pivot, spigot, hinge"),
    (["--fps", "-5"], "--fps -5: must be a positive frame rate"),
])
def test_bad_arguments_exit_2_with_one_line(run, tmp_path, capsys, extra, expected):
    out = tmp_path / "report"
    assert run("compare", DEMO_LOG, "--scene", HORSDAL, "-o", out, *extra) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and expected in err[0], err
    assert not out.exists()


def test_bad_scene_and_missing_log_exit_2_naming_the_file(run, tmp_path, capsys):
    scene = tmp_path / "bad.toml"
    scene.write_text(HORSDAL.read_text().replace("m_b = 622.0", "m_b = -622.0"))
    out = tmp_path / "report"
    assert run("compare", DEMO_LOG, "--scene", scene, "-o", out) == 2
    err = capsys.readouterr().err.strip()
    assert "bad.toml" in err and "m_b" in err and "\n" not in err
    assert run("compare", tmp_path / "nope.csv", "--scene", HORSDAL, "-o", out, "--quiet") == 2
    err = capsys.readouterr().err.strip()
    assert "nope.csv" in err and "Traceback" not in err
    assert not out.exists()


def test_log_options_are_those_of_forces():
    """compare takes the same log arguments as forces (docs/interface.md), parsed by the same
    code."""
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers()
    compare_cli.register(sub)
    args = parser.parse_args(["compare", "log.csv", "--scene", "s.toml", "-o", "out",
                              "--column", "a=b=theta", "--column", "arm=psi",
                              "--point", "pivot=Beam/axle", "--fps", "240"])
    assert log_options(args) == {"fps": 240.0, "columns": {"a=b": "theta", "arm": "psi"},
                                 "points": {"pivot": "Beam/axle"}}
    bad = parser.parse_args(["compare", "log.csv", "--scene", "s.toml", "-o", "out",
                             "--point", "=axle"])
    with pytest.raises(TrebuchetInputError, match="--point '=axle'"):
        log_options(bad)
