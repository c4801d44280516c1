"""Runaway sizes (issue 21): an output step or a phase III beyond what a shot can mean is
refused at once, in one line naming the option, instead of filling the memory (``--dt 1e-9``
asked for 11 GiB) or never ending (``--after-release inf``)."""

from __future__ import annotations

import time

import numpy as np
import pytest

import trebuchet as tb
from trebuchet.cli import main
from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model import output_size as size
from trebuchet.model import simulate as sim
from trebuchet.model.shot_checks import checked_times

from .conftest import HORSDAL


@pytest.mark.parametrize("kwargs, words", [
    ({"dt": 1e-9}, ["dt=1e-09", "at least 1e-06 s"]),
    ({"dt": 1e-7}, ["dt=1e-07"]),
    ({"after_release": 1e6}, ["after_release=1000000", "60 s"]),
    ({"after_release": float("inf")}, ["after_release=inf"]),
    ({"after_release": float("nan")}, ["after_release=nan"]),
    ({"after_release": -1.0}, ["after_release=-1"]),
    ({"dt": 2e-6, "after_release": 60.0}, ["dt=2e-06", "30,000,001 output rows",
                                            "after_release"]),
])
def test_runaway_sizes_are_refused_before_the_run(horsdal, monkeypatch, kwargs, words):
    def never(*args, **kw):
        raise AssertionError("integrated although the options were out of bounds")

    monkeypatch.setattr(sim, "_solve", never)
    with pytest.raises(TrebuchetInputError) as caught:
        tb.simulate(horsdal, **kwargs)
    for word in words:
        assert word in str(caught.value), (word, str(caught.value))


def test_rows_over_the_whole_shot_are_counted_once_it_is_known(horsdal):
    """``dt = 1e-6`` passes the first check (0.5 s of phase III) but not the shot's 1.5 s."""
    t0 = time.perf_counter()
    rows = r"dt=1e-06 s: 1,49\d,\d{3} output rows"
    with pytest.raises(TrebuchetInputError, match=rows) as caught:
        tb.simulate(horsdal, dt=1e-6)
    assert "1,000,000" in str(caught.value) and "after_release" not in str(caught.value)
    assert time.perf_counter() - t0 < 5.0


def test_the_bounds_themselves():
    size.check_output_size(size.MIN_DT, span=0.5)  # 500,001 rows
    size.check_output_size(1e-3, size.MAX_AFTER_RELEASE)
    with pytest.raises(TrebuchetInputError, match="step of at least 1.1e-06 s"):
        size.check_output_size(1e-6, span=1.0)  # 1,000,001 rows
    with pytest.raises(TrebuchetInputError, match="t_eval holds 1,000,001 times"):
        checked_times(np.zeros(size.MAX_ROWS + 1))


@pytest.mark.parametrize("argv, flag", [
    (["simulate", HORSDAL, "-o", "{out}", "--dt", "1e-9"], "--dt 1e-09"),
    (["simulate", HORSDAL, "-o", "{out}", "--after-release", "1e6"], "--after-release 1e+06"),
    (["simulate", HORSDAL, "-o", "{out}", "--after-release", "inf"], "--after-release inf"),
    (["report", HORSDAL, "-o", "{out}", "--dt", "1e-9", "--quiet"], "--dt 1e-09"),
    (["sweep", HORSDAL, "--grid", "engine.M=19100", "-o", "{out}", "--after-release", "inf",
      "--quiet"], "--after-release inf"),
])
def test_the_command_line_names_the_option(tmp_path, capsys, argv, flag):
    out = tmp_path / "out"
    t0 = time.perf_counter()
    code = main([str(a).format(out=out) for a in argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and flag in err[0], err
    assert time.perf_counter() - t0 < 10.0
    assert list(tmp_path.iterdir()) == []
