"""The CSV writer (trebuchet/core/csv_table.py) writes pandas' bytes, and units on request."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from trebuchet.cli import main
from trebuchet.core.csv_table import csv_text, write_table
from trebuchet.model.simulate import simulate
from trebuchet.model.sweep import STATUS_REFUSED, SUMMARY_COLUMNS, SimulationOptions, sweep
from trebuchet.model.sweep_cli import sweep_units
from trebuchet.model.units import column_unit

from .conftest import HORSDAL, ROOT

SAMPLE = ROOT / "data_samples" / "horsdal_240fps.csv"


@pytest.fixture(scope="module")
def sample_loads():
    """The loads of the shipped sample log, as ``trebuchet forces`` writes them."""
    from trebuchet.ingest.reconstruct import reconstruct

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return reconstruct(SAMPLE, HORSDAL)


def test_the_sample_loads_are_written_as_pandas_writes_them(sample_loads):
    assert sample_loads.isna().any().any()  # NaN cells (phi after release, sd at rest)
    assert sample_loads["phase"].dtype.kind == "i"
    assert csv_text(sample_loads) == sample_loads.to_csv(index=False)


def test_a_simulated_shot_and_a_dry_fire_are_written_as_pandas_writes_them(horsdal):
    from trebuchet.model.scene import Scene

    data = horsdal.to_dict()
    data.pop("release")
    dry = Scene.from_dict({**data, "start": {**data["start"], "projectile": "none"}})
    for run in (simulate(horsdal), simulate(dry, after_release=0.2)):
        assert csv_text(run) == run.to_csv(index=False)


def test_a_sweep_with_words_and_refusals_is_written_as_pandas_writes_them(horsdal):
    table = sweep(horsdal, {"engine.M": (19100.0, -5.0)}, workers=1, progress=False,
                  options=SimulationOptions(rtol="fast", dt=0.01))
    assert (table["status"] == STATUS_REFUSED).any() and table["error"].str.len().max() > 0
    assert csv_text(table) == table.to_csv(index=False)


def test_every_kind_of_cell_is_written_as_pandas_writes_it():
    rng = np.random.default_rng(3)
    n = 4000
    x = rng.standard_normal(n) * 10.0 ** rng.integers(-320, 300, n)
    x[::7] = np.round(x[::7] * 1e-3)
    x[::11] = np.nan
    x[:12] = [np.inf, -np.inf, -0.0, 0.0, 1e16, 1e15, 9999999999999998.0, 1e-5, 1e-4,
              5e-324, 1.7976931348623157e308, 0.1 + 0.2]
    words = ["x", "a,b", 'say "hi"', "two\nlines", "cr\rhere", "", None, "  padded ", "ünï"]
    frame = pd.DataFrame({
        "value": x, "n": np.arange(n) - 7, "u8": (np.arange(n) % 200).astype(np.uint8),
        "ok": np.arange(n) % 3 == 0, "word": [words[i % len(words)] for i in range(n)],
        "object word": pd.Series([words[i % len(words)] for i in range(n)], dtype=object),
        'a "quoted", name': -x})
    assert csv_text(frame) == frame.to_csv(index=False)


@pytest.mark.parametrize("frame", [
    pd.DataFrame({"only": [1.5, np.nan, 2.0]}),  # a lone empty cell is quoted
    pd.DataFrame({"f32": np.array([0.1, 1 / 3], dtype=np.float32), "b": [1.0, 2.0]}),
    pd.DataFrame({"n": pd.array([1, None], dtype="Int64"), "b": [1.0, 2.0]}),
    pd.DataFrame({"when": pd.to_datetime(["2024-01-01", "2024-01-02"]), "b": [1.0, 2.0]}),
    pd.DataFrame([[1.0, 2.0]], columns=["same", "same"]),
    pd.DataFrame({"mixed": [1, "a"], "b": [1.0, 2.0]}),
])
def test_what_the_fast_path_does_not_take_is_pandas_own(frame):
    assert csv_text(frame) == frame.to_csv(index=False)


def test_write_table_writes_the_file_whole(sample_loads, tmp_path):
    target = tmp_path / "loads.csv"
    write_table(sample_loads, target)
    sample_loads.to_csv(tmp_path / "pandas.csv", index=False)
    assert target.read_bytes() == (tmp_path / "pandas.csv").read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["loads.csv", "pandas.csv"]


# --------------------------------------------------------------------------- units


def test_every_column_of_the_loads_has_its_unit(sample_loads):
    bare = [c for c in sample_loads.columns if column_unit(c) is None]
    assert bare == ["phase"]
    assert column_unit("t") == column_unit("t_shot") == "s"
    assert column_unit("theta_dd_sd") == "rad/s^2" and column_unit("psi_d") == "rad/s"
    assert column_unit("F_R_perp_sd") == column_unit("sling_tension") == "N"
    assert column_unit("torque_spigot") == "N m" and column_unit("P_beam") == "W"
    assert column_unit("E_m") == "J" and column_unit("vy_m") == "m/s"
    assert column_unit("x_m") == "m" and column_unit("phi") == "rad"


def test_the_sweep_units_are_the_summary_s_own(horsdal):
    units = sweep_units(["design", "engine.M", "release.velocity_angle_deg", "status", "error",
                         *SUMMARY_COLUMNS])
    assert units["engine.M"] == "kg" and units["release.velocity_angle_deg"] == "deg"
    assert units["release_angle_deg"] == "deg" and units["torque_peak"] == "N m"
    assert "energy_share" not in units and "status" not in units and "design" not in units
    for name in SUMMARY_COLUMNS:  # where the name alone tells the unit, it tells the same
        if column_unit(name) is not None:
            assert column_unit(name) == units[name], name


def test_simulate_writes_units_into_the_header_on_request(tmp_path, capsys):
    bare, with_units = tmp_path / "bare.csv", tmp_path / "units.csv"
    assert main(["simulate", str(HORSDAL), "-o", str(bare), "--dt", "0.01"]) == 0
    assert main(["simulate", str(HORSDAL), "-o", str(with_units), "--dt", "0.01",
                 "--units"]) == 0
    plain, named = pd.read_csv(bare), pd.read_csv(with_units)
    assert list(plain.columns)[:4] == ["t", "phase", "theta", "psi"]
    assert list(named.columns)[:4] == ["t (s)", "phase", "theta (rad)", "psi (rad)"]
    assert "F_R_x (N)" in named.columns and "torque (N m)" in named.columns
    np.testing.assert_array_equal(named.to_numpy(), plain.to_numpy())
