"""Sweeps: grid syntax, designs built from the base scene, executors giving identical rows,
refused designs kept with their reason, and the ``trebuchet sweep`` command."""

from __future__ import annotations

import argparse
import math
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pandas as pd
import pytest

from trebuchet import cli
from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model import sweep_cli
from trebuchet.model.scene import Scene
from trebuchet.model.simulate import simulate
from trebuchet.model.sweep import (
    SUMMARY_COLUMNS,
    SimulationOptions,
    check_grid,
    design_scene,
    grid_designs,
    parse_grid_option,
    parse_grid_values,
    sweep,
)

from .conftest import BACKYARD, HORSDAL

FAST = SimulationOptions(dt=5e-3, after_release=0.2)
GRID_2X2 = {"release.velocity_angle_deg": [35.0, 50.0], "engine.M": [12000.0, 25000.0]}


@pytest.fixture(scope="module")
def angle_base(horsdal) -> Scene:
    return horsdal.with_release(velocity_angle=math.radians(40.0))


@pytest.fixture(scope="module")
def serial_2x2(angle_base) -> pd.DataFrame:
    return sweep(angle_base, GRID_2X2, workers=1, progress=False, options=FAST)


# --------------------------------------------------------------------------- grid syntax


def test_range_includes_both_ends():
    assert parse_grid_values("30:60:7") == pytest.approx((30, 35, 40, 45, 50, 55, 60), abs=1e-12)
    assert parse_grid_values("-85:-15:3") == pytest.approx((-85, -50, -15))
    assert parse_grid_values("2.5:9:1") == (2.5,)


def test_comma_list_and_single_value():
    assert parse_grid_values("10000, 19100,3e4") == (10000.0, 19100.0, 30000.0)
    assert parse_grid_values("0.997") == (0.997,)


@pytest.mark.parametrize("text", ["", "1:2", "1:2:3:4", "1:2:x", "1:2:0", "1:2:2.5", "a,b",
                                  "1,,2", "nan", "1:inf:3"])
def test_bad_values_refused_naming_the_option(text):
    with pytest.raises(TrebuchetInputError, match="--grid engine.M"):
        parse_grid_values(text, where="--grid engine.M")


def test_grid_option():
    assert parse_grid_option("engine.M=1,2") == ("engine.M", (1.0, 2.0))
    with pytest.raises(TrebuchetInputError, match="KEY=VALUES"):
        parse_grid_option("engine.M")


@pytest.mark.parametrize("key", ["engine.Mass", "engin.M", "M", "engine.", "start.theta_rad"])
def test_bad_key_named(key):
    with pytest.raises(TrebuchetInputError, match=f"grid key '{key}'"):
        check_grid({key: [1.0]})


def test_conflicting_release_rules_refused():
    with pytest.raises(TrebuchetInputError, match="one release rule"):
        check_grid({"release.time": [1.0], "release.velocity_angle_deg": [40.0]})
    with pytest.raises(TrebuchetInputError, match="same angle"):
        check_grid({"start.theta": [-0.5], "start.theta_deg": [-30.0]})


def test_cartesian_product_first_key_slowest():
    designs = grid_designs({"a.x": (1.0, 2.0), "b.y": (3.0, 4.0, 5.0)})
    assert len(designs) == 6
    assert [(d["a.x"], d["b.y"]) for d in designs[:4]] == [(1, 3), (1, 4), (1, 5), (2, 3)]


# --------------------------------------------------------------------------- designs


def test_empty_design_is_the_base(horsdal, backyard):
    assert design_scene(horsdal, {}) == horsdal
    assert design_scene(backyard, {}) == backyard


def test_design_keeps_spigot_on_ground_and_projectile_in_trough(horsdal):
    scene = design_scene(horsdal, {"start.theta_deg": -30.0, "engine.L1": 7.5, "engine.m_b": 700})
    e, s = scene.engine, scene.start
    assert s.theta == pytest.approx(math.radians(-30.0), abs=1e-15)
    assert s.H + e.L1 * math.sin(s.theta) == pytest.approx(0.0, abs=1e-12)
    assert s.H + e.L1 * math.sin(s.theta) + e.L4 * math.sin(s.phi) == pytest.approx(0, abs=1e-12)
    assert e.I == pytest.approx(700 * (7.5**2 - 7.5 * 0.86 + 0.86**2) / 3, rel=1e-12)


def test_design_keeps_explicit_moment_and_height():
    data = {**BACKYARD, "engine": {**BACKYARD["engine"], "I": 9.0, "H": 2.0}}
    data["start"] = {"theta_deg": -45.0, "psi_deg": -90.0,
                     "phi_deg": math.degrees(-math.pi + math.asin((2.0 - 2 * 0.5**0.5) / 1.8))}
    base = Scene.from_dict(data)
    scene = design_scene(base, {"engine.m_b": 30.0, "engine.L4": 2.2})
    assert scene.engine.I == 9.0 and scene.start.H == 2.0
    spigot = scene.start.H + scene.engine.L1 * math.sin(scene.start.theta)
    assert spigot + 2.2 * math.sin(scene.start.phi) == pytest.approx(0.0, abs=1e-12)


def test_release_rule_replaced(horsdal):
    scene = design_scene(horsdal, {"release.velocity_angle_deg": 35.0})
    assert scene.release.time is None
    assert scene.release.velocity_angle == pytest.approx(math.radians(35.0))


# --------------------------------------------------------------------------- sweeps


def test_rows_match_direct_simulation(serial_2x2, angle_base):
    """Row 3 (50°, 25000 kg) equals a simulation of the scene written out by hand."""
    assert list(serial_2x2["design"]) == [0, 1, 2, 3]
    assert (serial_2x2["status"] == "ok").all() and (serial_2x2["error"] == "").all()
    row = serial_2x2.iloc[3]
    assert (row["release.velocity_angle_deg"], row["engine.M"]) == (50.0, 25000.0)
    data = angle_base.to_dict()
    data["engine"]["M"] = 25000.0
    data["release"] = {"velocity_angle_deg": 50.0}
    run = simulate(Scene.from_dict(data), dt=FAST.dt, after_release=FAST.after_release)
    assert row["release_angle"] == pytest.approx(math.radians(50.0), abs=1e-8)
    assert row["range"] == run.attrs["flight"]["range"]
    assert row["lift_off"] == run.attrs["events"]["lift_off"]
    assert row["F_R_peak"] == run["F_R_abs"].max()
    assert row["torque_peak"] == run["torque"].abs().max()
    assert 0.0 < row["energy_share"] < 1.0
    assert row["energy_drift_rel"] < 1e-8


def test_heavier_counterweight_throws_faster(serial_2x2):
    for _, pair in serial_2x2.groupby("release.velocity_angle_deg"):
        light, heavy = pair.sort_values("engine.M")["release_speed"]
        assert heavy > light


def test_two_processes_give_identical_rows(serial_2x2, angle_base):
    parallel = sweep(angle_base, GRID_2X2, workers=2, progress=False, options=FAST)
    pd.testing.assert_frame_equal(parallel, serial_2x2)


def test_given_executor_gives_identical_rows(serial_2x2, angle_base):
    with ThreadPoolExecutor(2) as pool:
        threaded = sweep(angle_base, GRID_2X2, executor=pool, progress=False, options=FAST)
    pd.testing.assert_frame_equal(threaded, serial_2x2)


def test_refused_designs_kept_with_reason(horsdal):
    table = sweep(horsdal, {"engine.M": [100.0, 19100.0], "release.time": [0.2, 0.997]},
                  workers=1, progress=False, options=FAST)
    assert len(table) == 4
    by = {(r["engine.M"], r["release.time"]): r for _, r in table.iterrows()}
    light = by[(100.0, 0.997)]
    assert light["status"] == "refused" and "[engine] M" in light["error"]
    early = by[(19100.0, 0.2)]
    assert early["status"] == "refused" and "before lift-off" in early["error"]
    assert early["error"].startswith("design 2:")
    assert np.isnan(early[list(SUMMARY_COLUMNS)].to_numpy(dtype=float)).all()
    good = by[(19100.0, 0.997)]
    assert good["status"] == "ok" and good["release_time"] == 0.997


def test_output_selection(horsdal):
    table = sweep(horsdal, {"engine.m": [90.0]}, outputs=["range"], workers=1, progress=False,
                  options=FAST)
    assert list(table.columns) == ["design", "engine.m", "status", "error", "range"]
    with pytest.raises(TrebuchetInputError, match="'reach'"):
        sweep(horsdal, {"engine.m": [90.0]}, outputs=["reach"], progress=False)


@pytest.mark.parametrize("options", [SimulationOptions(rtol=1.0), SimulationOptions(rtol="sloppy"),
                                     SimulationOptions(dt=0.0),
                                     SimulationOptions(after_release=-1.0)])
def test_bad_options_refused_before_any_design(horsdal, options):
    with pytest.raises(TrebuchetInputError):
        sweep(horsdal, {"engine.m": [90.0]}, workers=1, progress=False, options=options)


def test_word_valued_key(horsdal):
    table = sweep(horsdal, {"engine.counterweight": ["hinged", "swinging"]}, workers=1,
                  progress=False, options=FAST)
    assert table["status"].iloc[0] == "ok"
    assert table["status"].iloc[1] == "refused" and "counterweight" in table["error"].iloc[1]


def test_dask_cluster_gives_identical_rows(serial_2x2, angle_base):
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            on_client = sweep(angle_base, GRID_2X2, executor=client, progress=False,
                              options=FAST)
        by_address = sweep(angle_base, GRID_2X2, executor=cluster.scheduler_address,
                           progress=False, options=FAST)
    pd.testing.assert_frame_equal(on_client, serial_2x2)
    pd.testing.assert_frame_equal(by_address, serial_2x2)


# --------------------------------------------------------------------------- command line


@pytest.fixture
def main(monkeypatch):
    """``trebuchet`` with the sweep room registered (until cli.ROOMS lists it)."""
    if "trebuchet.model.sweep_cli" not in cli.ROOMS:
        monkeypatch.setattr(cli, "ROOMS", (*cli.ROOMS, "trebuchet.model.sweep_cli"))
    return cli.main


def test_register_adds_sweep():
    parser = argparse.ArgumentParser()
    sweep_cli.register(parser.add_subparsers())
    args = parser.parse_args(["sweep", "s.toml", "--grid", "engine.M=1,2", "--grid",
                              "release.time=1:2:3", "-o", "x.csv", "--workers", "3"])
    assert args.grid == ["engine.M=1,2", "release.time=1:2:3"] and args.workers == 3
    assert args.run is sweep_cli._sweep


def test_cli_bad_key_exits_2_naming_it(main, tmp_path, capsys):
    out = tmp_path / "sweep.csv"
    status = main(["sweep", str(HORSDAL), "--grid", "engine.Mass=1,2", "-o", str(out)])
    err = capsys.readouterr().err
    assert status == 2
    assert err.count("\n") == 1 and "engine.Mass" in err and "Traceback" not in err
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_cli_bad_values_exit_2(main, tmp_path, capsys):
    status = main(["sweep", str(HORSDAL), "--grid", "engine.M=1:2", "-o", str(tmp_path / "s")])
    assert status == 2 and "--grid engine.M" in capsys.readouterr().err


def test_cli_writes_table(main, tmp_path, capsys):
    out = tmp_path / "sweep.csv"
    status = main(["sweep", str(HORSDAL), "--grid", "engine.M=100,19100", "--grid",
                   "release.velocity_angle_deg=35:45:2", "-o", str(out), "--workers", "1",
                   "--dt", "0.005", "--rtol", "fast", "--quiet"])
    assert status == 0
    table = pd.read_csv(out, keep_default_na=False, na_values=[""])
    assert len(table) == 4
    assert list(table["status"]) == ["refused", "refused", "ok", "ok"]
    assert table["release_angle"].iloc[2:].to_numpy() == pytest.approx(np.radians([35, 45]))
    assert "4 designs" in capsys.readouterr().out


def test_dask_not_imported_unless_asked():
    import subprocess
    import sys

    code = ("import sys, trebuchet.model.sweep, trebuchet.model.sweep_cli; "
            "assert not any(m.split('.')[0] in ('dask', 'distributed') for m in sys.modules)")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_scheduler_without_dask_is_a_clear_error(horsdal, monkeypatch):
    monkeypatch.setitem(__import__("sys").modules, "dask.distributed", None)
    with pytest.raises(TrebuchetInputError, match="needs dask"):
        sweep(horsdal, {"engine.m": [90.0]}, executor="tcp://127.0.0.1:1", progress=False)


def test_grid_too_large_refused():
    with pytest.raises(TrebuchetInputError, match="count must lie between 1 and 1,000,000"):
        parse_grid_values("1:2:100000000", where="--grid engine.M")
    with pytest.raises(TrebuchetInputError, match="split it into several sweeps"):
        grid_designs({"a.x": range(1000), "b.y": range(1001)})
