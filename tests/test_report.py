"""The HTML report: written whole or not at all; the ``report`` command via register()."""

from __future__ import annotations

import argparse

import matplotlib

matplotlib.use("Agg")

import pandas as pd  # noqa: E402
import pytest  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

import trebuchet.report.figures as figures_module
from trebuchet.core.errors import TrebuchetInputError  # noqa: E402
from trebuchet.core.output import OUTPUT_MARKER  # noqa: E402
from trebuchet.report import page as report_mod  # noqa: E402
from trebuchet.report import report_cli  # noqa: E402
from trebuchet.report.figures import FIGURES  # noqa: E402
from trebuchet.report.page import write_report  # noqa: E402

from .conftest import HORSDAL  # noqa: E402

PNG = b"\x89PNG\r\n\x1a\n"


def small_figure(label: str = "x") -> Figure:
    fig = Figure(figsize=(2, 1.5))
    ax = fig.subplots()
    ax.plot([0, 1], [0, 1])
    ax.set_xlabel(f"{label} (ms)")
    return fig


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="trebuchet")
    report_cli.register(p.add_subparsers(dest="command", required=True))
    return p


def test_write_report_writes_pngs_tables_and_escaped_html(tmp_path):
    out = tmp_path / "rep"
    table = pd.DataFrame({"quantity": ["a<b"], "value": [1.23456789]})
    said = []
    write_report(out, {"one": small_figure(), "two": small_figure}, {"metrics": table},
                 ["sling <slack>"], title="T & <t>", captions={"one": "first"},
                 csv_tables=["metrics"], progress=said.append)
    assert sorted(p.name for p in out.iterdir()) == [OUTPUT_MARKER, "index.html", "metrics.csv",
                                                    "one.png", "two.png"]
    assert (out / "one.png").read_bytes()[:8] == PNG
    assert (out / "two.png").read_bytes()[:8] == PNG
    text = (out / "index.html").read_text(encoding="utf-8")
    assert '<img src="one.png"' in text and '<img src="two.png"' in text
    assert "T &amp; &lt;t&gt;" in text and "sling &lt;slack&gt;" in text
    assert "a&lt;b" in text and "1.235" in text and "first" in text
    assert pd.read_csv(out / "metrics.csv").equals(table)
    assert len(said) == 2
    assert not [p for p in tmp_path.iterdir() if p.name != "rep"]  # no temporary left


def test_a_figure_failing_midway_leaves_no_report_and_keeps_the_old_one(tmp_path):
    out = tmp_path / "rep"

    def broken() -> Figure:
        raise RuntimeError("drawing failed")

    with pytest.raises(RuntimeError):
        write_report(out, {"one": small_figure(), "two": broken}, {}, [], title="t")
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []
    write_report(out, {"one": small_figure()}, {}, [], title="old")
    with pytest.raises(RuntimeError):
        write_report(out, {"one": small_figure(), "two": broken}, {}, [], title="new")
    assert sorted(p.name for p in out.iterdir()) == [OUTPUT_MARKER, "index.html", "one.png"]
    assert "old" in (out / "index.html").read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


def test_bad_names_are_refused_before_writing(tmp_path):
    with pytest.raises(ValueError):
        write_report(tmp_path / "rep", {"../x": small_figure()}, {}, [])
    with pytest.raises(ValueError):
        write_report(tmp_path / "rep", {}, {}, [], csv_tables=["metrics"])
    assert not (tmp_path / "rep").exists()


def test_report_command_writes_index_and_every_figure(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(report_mod, "FIGURE_DPI", 40)  # faster; layout is the same
    out = tmp_path / "report"
    args = parser().parse_args(["report", str(HORSDAL), "-o", str(out), "--dt", "0.002"])
    assert args.run(args) == 0
    names = sorted(p.name for p in out.iterdir())
    assert names == sorted([OUTPUT_MARKER, "index.html", "peaks.csv",
                           *(f"{n}.png" for n in FIGURES)])
    for n in FIGURES:
        assert (out / f"{n}.png").read_bytes()[:8] == PNG
    html = (out / "index.html").read_text(encoding="utf-8")
    for heading in ("events", "peaks", "flight"):
        assert f"<h2>{heading}</h2>" in html
    assert "lift_off" in html and "greatest bending load" in html and "release speed" in html
    peaks = pd.read_csv(out / "peaks.csv").set_index("quantity")
    assert peaks.loc["greatest bending load |F_R⊥|", "value"] == pytest.approx(1.6, abs=0.03)
    err = capsys.readouterr().err
    assert "simulating" in err and "drawing tension.png" in err


def test_report_with_a_failing_figure_leaves_nothing(tmp_path, monkeypatch, horsdal):
    def broken(predicted, measured, scene):
        raise RuntimeError("figure failed")

    monkeypatch.setattr(figures_module, "FIGURES", {"tension": FIGURES["tension"],
                                                "broken": broken})
    with pytest.raises(RuntimeError):
        report_cli.report_scene(horsdal, tmp_path / "report", dt=0.005)
    assert list(tmp_path.iterdir()) == []


def test_bad_scene_is_an_input_error_and_writes_nothing(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(HORSDAL.read_text().replace("L1 = 6.48", "L1 = -6.48"))
    out = tmp_path / "report"
    args = parser().parse_args(["report", str(bad), "-o", str(out)])
    with pytest.raises(TrebuchetInputError, match="L1"):
        args.run(args)
    args = parser().parse_args(["report", str(tmp_path / "missing.toml"), "-o", str(out)])
    with pytest.raises(TrebuchetInputError, match="missing.toml"):
        args.run(args)
    args = parser().parse_args(["report", str(HORSDAL), "-o", str(out), "--dt", "0"])
    with pytest.raises(TrebuchetInputError, match="--dt"):
        args.run(args)
    assert not out.exists()
