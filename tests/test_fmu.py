"""The co-simulation FMU: built once per session, run by fmpy in subprocesses, compared with the
in-process simulator at the same times."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from trebuchet.errors import TrebuchetInputError
from trebuchet.fmu import cosim
from trebuchet.fmu.crosscheck import reference
from trebuchet.fmu.interface import (
    OUTPUTS,
    PARAMETERS,
    VARIABLES,
    parameters_from_scene,
    scene_from_parameters,
)
from trebuchet.model.forces import LOAD_COLUMNS

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "fmu" / "examples"
REL = 1e-8  # the bound, relative to each output's peak over the run
STEPS = {1e-4: 1.1, 1e-3: 1.5, 3e-3: 1.5, 1e-2: 1.5}  # communication step (s): stop time (s)


def run_python(code: str, *args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh interpreter (the FMU's library lives and dies there)."""
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code), *args],
                          capture_output=True, text=True, timeout=timeout, cwd=ROOT)


@pytest.fixture(scope="session")
def fmu_path(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("fmu") / "Trebuchet.fmu"
    proc = subprocess.run([sys.executable, "-m", "trebuchet.cli", "fmu", "build", "-o",
                           str(path)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert path.is_file()
    return path


def assert_outputs_equal(result, ref: pd.DataFrame, label: str) -> None:
    """Same phase at every time; every output within REL of its peak magnitude."""
    np.testing.assert_allclose(result["time"], ref["time"], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(np.asarray(result["phase"]), ref["phase"].to_numpy(),
                                  err_msg=label)
    for name in cosim.OUTPUT_NAMES:
        got, want = np.asarray(result[name], dtype=float), ref[name].to_numpy(dtype=float)
        scale = np.max(np.abs(want))
        assert np.all(np.isfinite(got)), f"{label}: {name} not finite"
        err = np.max(np.abs(got - want))
        assert err <= REL * scale + 1e-300, f"{label}: {name} off by {err:g} (peak {scale:g})"


# --------------------------------------------------------------------------- in-process parts

def test_fmu_package_imports_cheaply():
    proc = run_python("""
        import sys, trebuchet.fmu
        print(sorted(m for m in ("pythonfmu", "fmpy") if m in sys.modules))
    """)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"


def test_every_scene_key_is_a_parameter():
    from trebuchet.model import scene as scene_module

    names = {p.name for p in PARAMETERS}
    rad_aliases = {"theta", "psi", "phi", "velocity_angle"}  # the FMU takes the *_deg keys
    for section, keys in scene_module.SCENE_KEYS.items():
        for key in keys - rad_aliases:
            assert f"{section}.{key}" in names, f"[{section}] {key} has no FMU parameter"


def test_parameters_have_units_starts_and_ranges():
    for p in PARAMETERS:
        assert p.start is not None, p.name
        if p.type == "Real":
            assert p.min is not None and p.max is not None, p.name
            assert p.min <= p.start <= p.max, p.name
            assert p.unit is not None or p.name == "flight.drag_coefficient", p.name
    # the start values are the paper's engine, a scene the simulator accepts
    scene = scene_from_parameters({p.name: p.start for p in PARAMETERS})
    assert scene.engine.M == 19100.0 and scene.release.time == 0.997 and scene.g == 9.82


def test_outputs_cover_the_contract_columns():
    names = [v.name for v in OUTPUTS]
    angles = [f"{a}{s}" for s in ("", "_d", "_dd") for a in ("theta", "psi", "phi")]
    for column in ["phase", *angles, *LOAD_COLUMNS]:
        assert column in names
    assert len(set(v.name for v in VARIABLES)) == len(VARIABLES)


def test_scene_round_trip_and_scene_messages(horsdal):
    values = parameters_from_scene(horsdal)
    again = scene_from_parameters(values)
    assert again.engine == horsdal.engine and again.release == horsdal.release
    assert math.isclose(again.start.phi, horsdal.start.phi, rel_tol=1e-15)
    with pytest.raises(TrebuchetInputError, match=r"\[engine\] m: .*positive mass"):
        scene_from_parameters({**values, "engine.m": -1.0})
    with pytest.raises(TrebuchetInputError, match=r"\[start\] phi_deg"):
        scene_from_parameters({**values, "start.phi_deg": -170.0})
    with pytest.raises(TrebuchetInputError, match=r"\[release\]"):
        scene_from_parameters({**values, "release.time": 0.0})


def test_both_release_rules_release_at_the_first(horsdal):
    values = parameters_from_scene(horsdal)
    both = scene_from_parameters({**values, "release.velocity_angle_deg": 30.0})
    assert both.release.time == 0.997 and math.isclose(both.release.velocity_angle,
                                                       math.radians(30.0))
    angle_only = scene_from_parameters({**values, "release.time": 0.0,
                                        "release.velocity_angle_deg": 30.0})
    t_both = cosim.start_run(both).trajectory.events["release"]
    t_angle = cosim.start_run(angle_only).trajectory.events["release"]
    assert t_both == pytest.approx(min(0.997, t_angle), abs=1e-12)


def test_release_command_before_lift_off_or_after_release_is_ignored(horsdal):
    run = cosim.start_run(horsdal, 1.5)
    for t_c in (0.1, 1.2):
        same, why = cosim.command_release(run, t_c)
        assert same is run and "ignored" in why
    released, why = cosim.command_release(run, 0.7)
    assert why is None and released.trajectory.events["release"] == pytest.approx(0.7, abs=1e-12)


def test_window_never_answers_across_an_event(horsdal):
    run = cosim.start_run(horsdal, 1.5)
    t_lift = run.trajectory.events["lift_off"]
    below = np.nextafter(t_lift, 0.0)
    win = cosim.window(run, below, 1e-3)
    np.testing.assert_array_equal(cosim.lookup(run, win, below), win.values[0])
    assert cosim.lookup(run, win, np.nextafter(t_lift, 1.0)) is None  # other side of lift-off
    assert cosim.lookup(run, win, below + 5e-4) is None  # not a communication point
    row = cosim.lookup(run, win, below + 1e-3 * 7 * (1 + 1e-16))
    assert row is not None and row[0] == 2.0


# --------------------------------------------------------------------------- the FMU itself

def test_model_description_is_valid(fmu_path):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(fmu_path)) == []
    md = read_model_description(str(fmu_path), validate=True)
    by_name = {v.name: v for v in md.modelVariables}
    for p in PARAMETERS:
        v = by_name[p.name]
        assert v.causality == "parameter" and v.start is not None
        if p.type == "Real":
            assert v.unit == p.unit and float(v.min) == p.min and float(v.max) == p.max
    assert by_name["release_command"].causality == "input"
    assert by_name["release_command"].type == "Boolean"
    outputs = [v for v in md.modelVariables if v.causality == "output"]
    assert [v.name for v in outputs] == list(cosim.OUTPUT_NAMES)
    assert {u.variable.name for u in md.initialUnknowns} == set(cosim.OUTPUT_NAMES)
    assert by_name["F_R_x"].unit == "N" and by_name["torque"].unit == "N.m"


_STEP_RUNS = """
    import json, os, sys
    import numpy as np
    from fmpy import simulate_fmu
    fmu, out, steps = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
    arrays = {}
    for step, stop in steps:
        r = simulate_fmu(fmu, stop_time=stop, output_interval=step)
        for name in r.dtype.names:
            arrays[f"{step!r}/{name}"] = r[name]
    np.savez(out, **arrays)
    sys.stdout.flush()
    os._exit(0)
"""


@pytest.fixture(scope="module")
def step_runs(fmu_path, tmp_path_factory) -> dict[float, dict[str, np.ndarray]]:
    out = tmp_path_factory.mktemp("steps") / "runs.npz"
    proc = run_python(_STEP_RUNS, str(fmu_path), str(out), json.dumps(list(STEPS.items())))
    assert proc.returncode == 0, proc.stderr
    data = np.load(out)
    runs: dict[float, dict[str, np.ndarray]] = {}
    for key in data.files:
        step, name = key.split("/", 1)
        runs.setdefault(float(step), {})[name] = data[key]
    return runs


@pytest.mark.parametrize("step", sorted(STEPS))
def test_cosimulation_equals_in_process(step_runs, step):
    result = step_runs[step]
    stop = STEPS[step]
    assert result["time"][-1] == pytest.approx(stop, abs=1e-9)  # fmpy truncates on discard
    assert len(result["time"]) == round(stop / step) + 1
    ref = reference(result["time"], t_stop=stop)
    assert_outputs_equal(result, ref, f"step {step:g} s")


def test_lift_off_and_release_fall_inside_steps(step_runs, horsdal):
    events = cosim.start_run(horsdal, 1.5).trajectory.events
    for step in (3e-3, 1e-2):
        t, phase = step_runs[step]["time"], step_runs[step]["phase"]
        for event, before, after in (("lift_off", 1, 2), ("release", 2, 3)):
            k = np.searchsorted(t, events[event])
            assert t[k - 1] < events[event] < t[k]  # strictly inside a step
            assert phase[k - 1] == before and phase[k] == after


def test_bad_parameter_is_an_error_and_the_host_survives(fmu_path):
    proc = run_python("""
        import json, os, sys
        from fmpy import simulate_fmu
        report = []
        for bad in ({"engine.m": -1.0}, {"start.phi_deg": -170.0}, {}):
            log = []
            def logger(component, instance, status, category, message):
                log.append([status, message.decode()])
            try:
                r = simulate_fmu(sys.argv[1], stop_time=1.2, output_interval=1e-2,
                                 start_values=bad, logger=logger, debug_logging=True)
                report.append({"ok": float(r["time"][-1]), "last_phase": int(r["phase"][-1])})
            except Exception as exc:
                report.append({"error": str(exc), "log": log})
        print(json.dumps(report))
        sys.stdout.flush()
        os._exit(0)
    """, str(fmu_path))
    assert proc.returncode == 0, proc.stderr
    mass, pose, good = json.loads(proc.stdout.strip().splitlines()[-1])
    for case, key in ((mass, "[engine] m"), (pose, "[start] phi_deg")):
        assert "fmi2ExitInitializationMode failed" in case["error"]
        assert "error" in case["error"] or "fatal" in case["error"]
        assert any(status >= 3 and key in message for status, message in case["log"]), case
    assert good == {"ok": pytest.approx(1.2), "last_phase": 3}  # instantiated again, ran


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
    from fmpy.cross_check.validate_vendor_repo import validate_test_fmu

    assert validate_test_fmu(str(folder)) == []
    proc = run_python("""
        import os, sys
        from fmpy import simulate_fmu
        from fmpy.util import read_csv, read_ref_opt_file, write_csv
        d = sys.argv[1]
        opt = read_ref_opt_file(os.path.join(d, "Trebuchet_ref.opt"))
        r = simulate_fmu(os.path.join(d, "Trebuchet.fmu"), start_time=opt["StartTime"],
                         stop_time=opt["StopTime"], output_interval=opt["StepSize"],
                         relative_tolerance=opt["RelTol"],
                         input=read_csv(os.path.join(d, "Trebuchet_in.csv")))
        write_csv(sys.argv[2], r)
        sys.stdout.flush()
        os._exit(0)
    """, str(folder), str(tmp_path / "out.csv"))
    assert proc.returncode == 0, proc.stderr
    result = pd.read_csv(tmp_path / "out.csv")
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
