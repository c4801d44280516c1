"""``tb.design`` and ``trebuchet design``: the problem's checks, a search that beats a grid
and meets its limits when checked, the refusal of limits no design meets, BEST.toml read back
as the same scene, and the command line's outputs and errors."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

import trebuchet as tb
from trebuchet import cli
from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model import design as design_module
from trebuchet.model.design import design
from trebuchet.model.design_output import pareto_front, scene_toml, summary_table
from trebuchet.model.design_problem import make_problem, parse_limit, parse_vary
from trebuchet.model.design_search import SearchOptions
from trebuchet.model.scene import Scene
from trebuchet.model.shot_summary import shot_figures
from trebuchet.model.sweep import sweep

from .conftest import BACKYARD

SMALL = SearchOptions(popsize=6, generations=8)
#: The backyard engine, its sling free (1.0-2.5 m) and its release climb (30-50 deg): the
#: sling's peak pull limited to 25 m g.
VARY = {"engine.L4": (1.0, 2.5), "release.velocity_angle_deg": (30.0, 50.0)}


@pytest.fixture(scope="module")
def base(backyard) -> Scene:
    return backyard.with_release(velocity_angle=math.radians(40.0))


@pytest.fixture(scope="module")
def limit(base) -> str:
    return f"F_S_peak <= {25 * base.engine.m * base.g}"


@pytest.fixture(scope="module")
def result(base, limit):
    return design(base, VARY, maximize="range", limits=[limit], seed=3, workers=1,
                  search_options=SMALL)


# --------------------------------------------------------------------------- the problem


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"vary": {"engine.Mass": (1, 2)}, "maximize": "range"}, "--vary 'engine.Mass'"),
    ({"vary": {"engine.L4": (3, 1)}, "maximize": "range"}, "wrong way round"),
    ({"vary": {"engine.L4": (2, 2)}, "maximize": "range"}, "lower bound must lie below"),
    ({"vary": {"engine.L4": (1, 2)}, "maximize": "reach"}, "--maximize: 'reach'"),
    ({"vary": {"engine.L4": (1, 2)}, "minimize": "F_R"}, "--minimize: 'F_R'"),
    ({"vary": {"engine.L4": (1, 2)}}, "exactly one of --maximize"),
    ({"vary": {"engine.L4": (1, 2)}, "maximize": "range", "minimize": "F_R_peak"},
     "exactly one"),
    ({"vary": {"engine.counterweight": (1, 2)}, "maximize": "range"}, "takes a word"),
    ({"vary": {"release.time": (1, 2), "release.velocity_angle_deg": (30, 40)},
      "maximize": "range"}, "one release rule"),
    ({"vary": {}, "maximize": "range"}, "at least one scene key"),
    ({"vary": {"engine.L4": (1, 2)}, "maximize": "range", "limits": ["F_R_peak < 3"]},
     "FIGURE<=VALUE"),
    ({"vary": {"engine.L4": (1, 2)}, "maximize": "range", "limits": ["F_Rx<=3"]},
     "'F_Rx' is not a figure"),
    ({"vary": {"engine.L4": (1, 2)}, "maximize": "range", "limits": ["range>=nan"]},
     "FIGURE<=VALUE"),
])
def test_bad_problem_refused_naming_it(base, kwargs, match):
    with pytest.raises(TrebuchetInputError, match=match):
        make_problem(base, **kwargs)


def test_parse():
    assert parse_vary("engine.L4=3:8") == ("engine.L4", (3.0, 8.0))
    lim = parse_limit(" cw_clearance >= 1.0 ")
    assert (lim.figure, lim.op, lim.value) == ("cw_clearance", ">=", 1.0)
    assert lim.margin(1.25) == 0.25 and parse_limit("F_R_peak<=4.5e5").margin(5e5) == -5e4
    for bad in ("engine.L4=3", "engine.L4=3:8:2", "engine.L4=a:8", "engine.L4"):
        with pytest.raises(TrebuchetInputError, match="--vary"):
            parse_vary(bad)


# --------------------------------------------------------------------------- the search


def test_best_meets_the_limit_and_beats_a_grid(result, base, limit):
    lim = parse_limit(limit)
    assert all(c.met for c in result.limits)
    again = shot_figures(result.scene)
    assert again.F_S_peak <= lim.value and again.status == "ok"
    assert again.range == pytest.approx(result.value, rel=1e-12)
    grid = sweep(base, {"engine.L4": np.linspace(1.0, 2.5, 16),
                        "release.velocity_angle_deg": np.linspace(30, 50, 11)},
                 workers=1, progress=False)
    ok = grid[(grid["status"] == "ok") & (grid["F_S_peak"] <= lim.value)]
    assert result.value >= ok["range"].max()
    assert result.binding.limit == lim and result.binding.relative < 1e-4


def test_history_and_start(result, base):
    h = result.history
    assert len(h) == result.evaluations and set(h["stage"]) == {"search", "polish"}
    assert h["feasible"].any() and (h["range"][h["feasible"]] <= result.value + 1e-9).all()
    assert result.start_params["engine.L4"] == base.engine.L4
    assert result.start_figures["range"] == shot_figures(base).range
    same = np.ones(len(h), dtype=bool)
    for k, v in result.params.items():
        same &= h[k].to_numpy() == v
    assert same.sum() == 1 and h["range"][same].iloc[0] == result.value


def test_seed_repeats_the_search(result, base, limit):
    again = design(base, VARY, maximize="range", limits=[limit], seed=3, workers=2,
                   search_options=SMALL)
    assert again.params == result.params
    np.testing.assert_array_equal(again.history["range"], result.history["range"])


def test_minimize_within_a_lower_limit(base):
    """The least peak bearing load that still throws 60 m: no design of a grid does better."""
    res = design(base, VARY, minimize="F_R_peak", limits=["range >= 60"], seed=1, workers=1,
                 search_options=SMALL)
    assert res.sense == "minimize" and res.figures["range"] >= 60.0
    grid = sweep(base, {"engine.L4": np.linspace(1.0, 2.5, 16),
                        "release.velocity_angle_deg": np.linspace(30, 50, 11)},
                 workers=1, progress=False)
    ok = grid[(grid["status"] == "ok") & (grid["range"] >= 60.0)]
    assert res.value <= ok["F_R_peak"].min()


def test_limits_no_design_meets_name_the_closest(base):
    with pytest.raises(TrebuchetInputError,
                       match=r"no design between the bounds meets F_S_peak <= 100 N: the "
                             r"closest of \d+ came to [0-9.]+ \([0-9.e+]+ over"):
        design(base, VARY, maximize="range", limits=["F_S_peak<=100", "range>=1"],
               workers=1, seed=1, search_options=SearchOptions(popsize=4, generations=3))


def test_limits_met_apart_but_not_together(base):
    with pytest.raises(TrebuchetInputError, match="meets every limit at once: the closest"):
        design(base, VARY, maximize="range", limits=["range>=85", "F_S_peak<=200"],
               workers=1, seed=1, search_options=SearchOptions(popsize=5, generations=6))


def test_a_best_that_fails_its_check_is_not_reported(base, limit, monkeypatch):
    """Where simulate's table of the search's best breaks the limit, the next design that
    passes is reported instead."""
    real, first = design_module.summarize, []

    def summarize(run, scene):
        out = real(run, scene)
        if not first:
            first.append(scene)
            out["F_S_peak"] = 1e9
        return out

    monkeypatch.setattr(design_module, "summarize", summarize)
    res = design(base, VARY, maximize="range", limits=[limit], seed=3, workers=1,
                 search_options=SMALL)
    assert first and res.scene != first[0] and all(c.met for c in res.limits)


def test_tb_design_is_public():
    assert tb.design is design


# --------------------------------------------------------------------------- outputs


@pytest.mark.parametrize("data", [
    BACKYARD,
    {**BACKYARD, "flight": {"model": "drag", "diameter": 0.1}},
    {**BACKYARD, "engine": {**BACKYARD["engine"], "I": 9.0, "counterweight": "fixed"}},
])
def test_scene_toml_reads_back(data):
    scene = Scene.from_dict(data)
    text = scene_toml(scene, ["a comment", "another"])
    assert text.startswith("# a comment\n# another\n")
    back = Scene.from_dict(tomllib.loads(text))
    assert back.to_dict().keys() == scene.to_dict().keys()
    for section, keys in scene.to_dict().items():
        for k, v in keys.items():
            if isinstance(v, float):
                assert back.to_dict()[section][k] == pytest.approx(v, rel=1e-14, abs=1e-14)
            else:
                assert back.to_dict()[section][k] == v


def test_pareto_front():
    x = np.array([1.0, 2.0, 3.0, 1.5, 2.5])
    y = np.array([1.0, 3.0, 4.0, 0.5, 2.0])
    assert list(pareto_front(x, y, x_smaller=True, y_larger=True)) == [0, 1, 2]


def test_summary_table(result):
    text = summary_table(result)
    assert "engine.L4" in text and "range (m)" in text and "F_S_peak (N)" in text
    assert text.splitlines()[0].split() == ["start", "best"]


# --------------------------------------------------------------------------- command line

ARGS = ["--vary", "engine.L4=1:2.5", "--vary", "release.velocity_angle_deg=30:50",
        "--maximize", "range", "--seed", "3", "--workers", "1", "--generations", "8",
        "--popsize", "6", "--quiet"]


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory, base):
    path = tmp_path_factory.mktemp("design") / "backyard40.toml"
    path.write_text(scene_toml(base))
    return path


def test_cli_writes_best_and_plot(scene_file, tmp_path, capsys, base, result, limit):
    best, plot = tmp_path / "best.toml", tmp_path / "trade.png"
    status = cli.main(["design", str(scene_file), "-o", str(best), *ARGS, "--limit",
                       limit.replace(" ", ""), "--plot", str(plot)])
    out = capsys.readouterr().out
    assert status == 0
    assert "start" in out and "best" in out and "range (m)" in out
    text = best.read_text()
    assert "# Objective: maximize range" in text and "<- binding" in text
    assert "margin" in text
    back = Scene.from_toml(best)
    assert back.engine.L4 == pytest.approx(result.scene.engine.L4, rel=1e-12)
    assert shot_figures(back).range == pytest.approx(result.value, rel=1e-9)
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(("extra", "match"), [
    (["--vary", "engine.Mass=1:2"], "engine.Mass"),
    (["--vary", "engine.m_b=5:1"], "wrong way round"),
    (["--limit", "F_S_peak=<3"], "FIGURE<=VALUE"),
    (["--limit", "F_S_peak<=1"], "came to"),
    (["--vary", "engine.L4=2:3"], "given twice"),
])
def test_cli_bad_input_exits_2_writing_nothing(scene_file, tmp_path, capsys, extra, match):
    best = tmp_path / "best.toml"
    status = cli.main(["design", str(scene_file), "-o", str(best), *ARGS,
                       "--generations", "2", "--popsize", "3", *extra])
    err = capsys.readouterr().err
    assert status == 2 and match in err and err.count("\n") == 1
    assert "Traceback" not in err and list(tmp_path.iterdir()) == []


def test_cli_objective_required(scene_file, tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["design", str(scene_file), "-o", str(tmp_path / "b.toml"), "--vary",
                  "engine.L4=1:2"])
    assert exc.value.code == 2 and "--maximize" in capsys.readouterr().err


def test_design_on_dask_equals_local(base, limit, result):
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        on_dask = design(base, VARY, maximize="range", limits=[limit], seed=3,
                         executor=client, search_options=SMALL)
    assert on_dask.params == result.params and on_dask.value == result.value
