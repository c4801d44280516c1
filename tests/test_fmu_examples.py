"""The FMU's examples (fmu/examples) and its cross-check layout, run as a user runs them: each
against the in-process simulator."""

from __future__ import annotations

import shutil
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from tests.test_fmu import EXAMPLES, REL, assert_outputs_equal
from trebuchet.fmu.crosscheck import reference

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="the build needs gcc")


def test_example_csv_input_drives_the_release(fmu_path, tmp_path):
    out = tmp_path / "release.csv"
    proc = subprocess.run([sys.executable, str(EXAMPLES / "release_by_csv.py"), str(fmu_path),
                           str(out), "0.85"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    result = pd.read_csv(out)
    assert result["time"].iloc[-1] == pytest.approx(1.5)
    released = result["time"][result["phase"] == 3].iloc[0]
    assert released == pytest.approx(0.851)  # command seen at 0.85, released there
    ref = reference(result["time"].to_numpy(), command_time=0.85, t_stop=1.5)
    assert ref.loc[ref["phase"] == 3, "time"].iloc[0] == pytest.approx(0.851)
    assert_outputs_equal(result, ref, "CSV input")


def test_example_speed_controller_loop(fmu_path, tmp_path):
    out = tmp_path / "controller.csv"
    target = 50.0
    proc = subprocess.run([sys.executable, str(EXAMPLES / "speed_controller.py"),
                           str(fmu_path), str(out), str(target)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    rows = pd.read_csv(out)
    first = rows.index[rows["release_command"] == 1][0]
    t_c = rows["time"][first]
    assert rows["speed"][first] >= target > rows["speed"][first - 1]
    assert (rows["phase"][:first + 1] < 3).all() and (rows["phase"][first + 1:] == 3).all()
    ref = reference(rows["time"].to_numpy(), command_time=float(t_c), t_stop=1.5)
    speed = np.hypot(ref["vx_m"], ref["vy_m"]).to_numpy()
    np.testing.assert_array_equal(rows["phase"], ref["phase"])
    assert np.max(np.abs(rows["speed"] - speed)) <= REL * speed.max()


def test_crosscheck_layout_verifies(fmu_path, tmp_path):
    out = tmp_path / "xc"
    proc = subprocess.run([sys.executable, "-m", "trebuchet.cli", "fmu", "crosscheck",
                           str(fmu_path), "-o", str(out)], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    (folder,) = out.glob("fmus/2.0/cs/*/trebuchet/*/Trebuchet")
    from fmpy import simulate_fmu
    from fmpy.cross_check.validate_vendor_repo import validate_test_fmu
    from fmpy.util import read_csv, read_ref_opt_file

    assert validate_test_fmu(str(folder)) == []
    opt = read_ref_opt_file(str(folder / "Trebuchet_ref.opt"))
    result = simulate_fmu(str(folder / "Trebuchet.fmu"), start_time=opt["StartTime"],
                          stop_time=opt["StopTime"], output_interval=opt["StepSize"],
                          relative_tolerance=opt["RelTol"], fmi_type="CoSimulation",
                          input=read_csv(str(folder / "Trebuchet_in.csv")))
    ref = pd.read_csv(folder / "Trebuchet_ref.csv")
    assert len(result) == len(ref) == 1501
    assert (ref["phase"] == 3).idxmax() == 901  # the input's command at 0.9 s released
    assert_outputs_equal(result, ref, "cross-check")


def test_crosscheck_of_a_missing_fmu_is_a_user_error(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "trebuchet.cli", "fmu", "crosscheck",
                           str(tmp_path / "none.fmu"), "-o", str(tmp_path / "xc")],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert "none.fmu: FMU not found" in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "xc").exists()
