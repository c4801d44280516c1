"""The native FMU: its interface, and its runs in fmpy (co-simulation and model exchange)
compared with the in-process simulator at the same times. Built once per session."""

from __future__ import annotations

import ctypes
import math
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.fmu.crosscheck import reference
from trebuchet.fmu.interface import (
    OUTPUT_NAMES,
    OUTPUTS,
    PARAMETERS,
    VARIABLES,
    parameters_from_scene,
    scene_from_parameters,
)
from trebuchet.model.forces import LOAD_COLUMNS
from trebuchet.model.friction import friction_couples
from trebuchet.model.simulate import simulate

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="the build needs gcc")

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "fmu" / "examples"
REL = 1e-8  # the bound for co-simulation, relative to each output's peak over the run
REL_ME = 1e-6  # model exchange under fmpy's CVode (the FMU's default tolerance, 1e-10)
STEPS = {1e-4: 1.1, 1e-3: 1.5, 3e-3: 1.5, 1e-2: 1.5}  # communication step (s): stop time (s)


def run_python(code: str, *args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh interpreter."""
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code), *args],
                          capture_output=True, text=True, timeout=timeout, cwd=ROOT)


def assert_outputs_equal(result, ref: pd.DataFrame, label: str, rel: float = REL) -> None:
    """Same phase at every time; every output within ``rel`` of its peak magnitude."""
    np.testing.assert_allclose(result["time"], ref["time"], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(np.asarray(result["phase"]), ref["phase"].to_numpy(),
                                  err_msg=label)
    for name in OUTPUT_NAMES:
        got, want = np.asarray(result[name], dtype=float), ref[name].to_numpy(dtype=float)
        scale = np.max(np.abs(want))
        assert np.all(np.isfinite(got)), f"{label}: {name} not finite"
        err = np.max(np.abs(got - want))
        assert err <= rel * scale + 1e-300, f"{label}: {name} off by {err:g} (peak {scale:g})"


#: data_samples/horsdal_friction.toml's bearings.
FRICTION = {"friction.pivot_mu": 0.15, "friction.pivot_radius": 0.1, "friction.hinge_mu": 0.15,
            "friction.hinge_radius": 0.06}
#: data_samples/small_fast.toml: the small fast engine with friction (released at a 40° climb).
SMALL_FAST = {"engine.L1": 1.5, "engine.L2": 0.4, "engine.L_CM": 0.55, "engine.L3": 0.5,
              "engine.L4": 1.4, "engine.m_b": 4.0, "engine.M": 100.0, "engine.m": 0.5,
              "start.theta_deg": -45.0, "release.time": 0.0, "release.velocity_angle_deg": 40.0,
              "environment.g": 9.81, "friction.pivot_mu": 0.3, "friction.pivot_radius": 0.0125,
              "friction.hinge_mu": 0.3, "friction.hinge_radius": 0.010}


def hold_couples_to_own_state(result: pd.DataFrame, ref: pd.DataFrame,
                              values: dict[str, float]) -> None:
    """The friction couples turn over 1e-3 rad/s of θ̇ (tanh): where the beam turns back
    (t = 1.364 s) CVode's 1e-8 in θ̇ moves them by 1e-5 of their peak. Hold ``torque_friction``
    to the couples of the FMU's own rates and loads instead (and take it as the reference)."""
    scene = scene_from_parameters(values)
    tau_P, tau_H = friction_couples(np.hypot(result.F_R_x, result.F_R_y),
                                    np.hypot(result.F_H_x, result.F_H_y), result.theta_d,
                                    result.psi_d, scene.engine, np)
    np.testing.assert_allclose(result.torque_friction, tau_H - tau_P, rtol=1e-12,
                               atol=1e-9 * np.abs(ref.torque_friction).max())
    ref["torque_friction"] = result["torque_friction"].to_numpy()


def start_values(**changes: float) -> dict[str, float]:
    """The parameters' start values (the paper's engine) with ``changes`` (``engine__M`` for
    ``engine.M``)."""
    values = {p.name: p.start for p in PARAMETERS}
    values.update({k.replace("__", "."): v for k, v in changes.items()})
    return values


class Slave:
    """The FMU instantiated for co-simulation by fmpy, with the log it wrote."""

    def __init__(self, fmu: Path, unzipped: str) -> None:
        from fmpy import fmi2 as f2
        from fmpy import read_model_description

        self.md = read_model_description(str(fmu))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.log: list[tuple[int, str]] = []

        def logger(component, instance, status, category, message):  # noqa: ANN001, ANN202
            self.log.append((status, message.decode()))

        self.callbacks = f2.fmi2CallbackFunctions()
        self.callbacks.logger = f2.fmi2CallbackLoggerTYPE(logger)
        self.callbacks.allocateMemory = f2.fmi2CallbackAllocateMemoryTYPE(f2.calloc)
        self.callbacks.freeMemory = f2.fmi2CallbackFreeMemoryTYPE(f2.free)
        self.fmu = f2.FMU2Slave(guid=self.md.guid, unzipDirectory=unzipped,
                                modelIdentifier=self.md.coSimulation.modelIdentifier,
                                instanceName="test")
        self.fmu.instantiate(loggingOn=True, callbacks=self.callbacks)

    def set(self, values: dict[str, float]) -> None:
        by_type = {v.name: v.type for v in self.md.modelVariables}
        for name, value in values.items():
            if by_type[name] == "Enumeration":
                self.fmu.setInteger([self.vr[name]], [int(value)])
            else:
                self.fmu.setReal([self.vr[name]], [float(value)])

    def outputs(self) -> np.ndarray:
        phase = self.fmu.getInteger([self.vr["phase"]])
        return np.array([*phase, *self.fmu.getReal([self.vr[n] for n in OUTPUT_NAMES[1:]])])


@pytest.fixture()
def unzipped(fmu_path):
    from fmpy import extract

    folder = extract(str(fmu_path))
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


# --------------------------------------------------------------------------- the interface

def test_fmu_package_imports_cheaply():
    proc = run_python("""
        import sys, trebuchet.fmu
        print(sorted(m for m in ("sympy", "fmpy") if m in sys.modules))
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


def test_parameters_have_units_starts_ranges_and_choices():
    for p in PARAMETERS:
        assert p.start is not None, p.name
        if p.type == "Real":
            assert p.min is not None and p.max is not None, p.name
            assert p.min <= p.start <= p.max, p.name
            dimensionless = ("flight.drag_coefficient", "friction.pivot_mu", "friction.hinge_mu")
            assert p.unit is not None or p.name in dimensionless, p.name
        else:
            assert p.type == "Enumeration" and p.start in p.choices, p.name
    scene = scene_from_parameters({p.name: p.start for p in PARAMETERS})
    assert scene.engine.M == 19100.0 and scene.release.time == 0.997 and scene.g == 9.82
    fixed = scene_from_parameters({**start_values(engine__L3=0.5, start__psi_deg=130.0),
                                   "engine.counterweight": 2})  # FMI value of "fixed"
    assert fixed.engine.fixed_counterweight


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


def test_model_description(fmu_path):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(fmu_path)) == []
    md = read_model_description(str(fmu_path), validate=True)
    assert md.coSimulation is not None and md.modelExchange is not None
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    assert md.modelExchange.providesDirectionalDerivative
    assert md.numberOfEventIndicators == 3
    by_name = {v.name: v for v in md.modelVariables}
    for p in PARAMETERS:
        v = by_name[p.name]
        assert v.causality == "parameter" and v.start is not None
        if p.type == "Real":
            assert v.unit == p.unit and float(v.min) == p.min and float(v.max) == p.max
        else:
            assert v.type == "Enumeration"
            assert [item.name for item in v.declaredType.items] == list(p.choices)
    assert by_name["release_command"].causality == "input"
    assert by_name["release_command"].type == "Boolean"
    outputs = [v for v in md.modelVariables if v.causality == "output"]
    assert [v.name for v in outputs] == list(OUTPUT_NAMES)
    assert {u.variable.name for u in md.initialUnknowns} == set(OUTPUT_NAMES)
    assert by_name["F_R_x"].unit == "N" and by_name["torque"].unit == "N.m"
    assert by_name["theta"].unit == "rad" and by_name["theta"].displayUnit == "deg"
    states = [d.variable.derivative.name for d in md.derivatives]
    assert states == ["theta", "psi", "phi", "theta_d", "psi_d", "phi_d", "E_loss_pivot",
                      "E_loss_hinge"]
    assert set(md.buildConfigurations[0].sourceFileSets[0].sourceFiles) >= {
        "treb_formulas.c", "fmi2.c"}


def test_fmu_holds_binaries_and_sources(fmu_path):
    import zipfile

    names = set(zipfile.ZipFile(fmu_path).namelist())
    assert "binaries/linux64/Trebuchet.so" in names
    assert {"sources/buildDescription.xml", "sources/treb_formulas.c", "sources/fmi2.c",
            "sources/fmi2Functions.h"} <= names
    assert not any("python" in n.lower() for n in names)
    if shutil.which("x86_64-w64-mingw32-gcc"):  # the build cross-compiles where it can
        assert "binaries/win64/Trebuchet.dll" in names


# --------------------------------------------------------------------------- runs in fmpy

@pytest.fixture(scope="module")
def step_runs(fmu_path) -> dict[float, np.ndarray]:
    from fmpy import simulate_fmu

    return {step: simulate_fmu(str(fmu_path), stop_time=stop, output_interval=step,
                               fmi_type="CoSimulation") for step, stop in STEPS.items()}


@pytest.mark.parametrize("step", sorted(STEPS))
def test_cosimulation_equals_in_process(step_runs, step):
    result = step_runs[step]
    stop = STEPS[step]
    assert result["time"][-1] == pytest.approx(stop, abs=1e-9)  # fmpy truncates on discard
    assert len(result["time"]) == round(stop / step) + 1
    ref = reference(result["time"], t_stop=stop)
    assert_outputs_equal(result, ref, f"step {step:g} s")


def test_lift_off_and_release_fall_inside_steps(step_runs, horsdal):
    events = simulate(horsdal, t_eval=[0.0]).attrs["events"]
    for step in (3e-3, 1e-2):
        t, phase = step_runs[step]["time"], step_runs[step]["phase"]
        for event, before, after in (("lift_off", 1, 2), ("release", 2, 3)):
            k = np.searchsorted(t, events[event])
            assert t[k - 1] < events[event] < t[k]  # strictly inside a step
            assert phase[k - 1] == before and phase[k] == after


@pytest.mark.parametrize("changes", [
    {"engine.counterweight": 2, "engine.L3": 0.5, "start.psi_deg": 130.0},
    {"release.time": 0.0, "release.velocity_angle_deg": 40.0},
    {"release.velocity_angle_deg": 30.0},  # both rules: the first reached releases
    {"start.projectile": 2, "engine.H": 12.0, "start.phi_deg": -90.0},
    {"start.projectile": 3, "release.time": 0.0},
    {"flight.model": 2, "flight.diameter": 0.3},
    FRICTION,
    SMALL_FAST,
    {**FRICTION, "engine.counterweight": 2, "engine.L3": 0.5, "start.psi_deg": 130.0},
    {**FRICTION, "start.projectile": 3, "release.time": 0.0},
], ids=["fixed", "angle", "both", "sling", "dry", "drag", "friction", "small-friction",
        "fixed-friction", "dry-friction"])
def test_cosimulation_of_variants_equals_in_process(fmu_path, changes):
    from fmpy import simulate_fmu

    values = {**start_values(), **changes}
    result = simulate_fmu(str(fmu_path), stop_time=1.5, output_interval=1e-3,
                          fmi_type="CoSimulation", start_values=changes)
    dry = values["start.projectile"] == 3
    rel, rtol = REL, "default"
    if dry and "friction.pivot_mu" in changes:
        # the beam swings for 1.5 s and the hinge sticks (|psi_d - theta_d| ~ 1e-5 rad/s, in
        # the couples' tanh over 1e-3 rad/s): the friction torque there is 2e6 N m per rad/s of
        # the integrated rate, and the shots at rtol 1e-10 hold it to the solver's accuracy
        # only (numba's 1.2e-8 of its peak, the C's 4e-8, against the shot at rtol 1e-13):
        # the FMU against the Python's shot at 1e-13, to 1e-7 of each output's peak
        rel, rtol = 1e-7, 1e-13
    ref = reference(result["time"], values, t_stop=1.5, rtol=rtol)
    if dry:  # no projectile: its position, velocity and energy are not defined
        for name in ("x_m", "y_m", "vx_m", "vy_m"):
            assert np.isnan(result[name]).all() and ref[name].isna().all()
            result[name] = 0.0
            ref[name] = 0.0
    assert_outputs_equal(result, ref, str(changes), rel=rel)


@pytest.mark.parametrize("changes", [{}, FRICTION], ids=["frictionless", "friction"])
def test_model_exchange_under_cvode_equals_in_process(fmu_path, changes):
    from fmpy import simulate_fmu

    result = simulate_fmu(str(fmu_path), stop_time=1.5, output_interval=1e-3,
                          fmi_type="ModelExchange", solver="CVode", record_events=False,
                          start_values=changes)
    assert result["time"][-1] == pytest.approx(1.5)
    ref = reference(result["time"], {**start_values(), **changes}, t_stop=1.5)
    # The release by time (0.997 s) falls on an output point: fmpy records the state after
    # the event there, the simulator the phase that ends there. Compare every other point.
    keep = np.abs(result["time"] - 0.997) > 1e-9
    assert keep.sum() == len(keep) - 1 and result["phase"][~keep][0] == 3
    ref = ref[keep].reset_index(drop=True)
    result = pd.DataFrame({n: result[n] for n in result.dtype.names})[keep]
    if changes:
        hold_couples_to_own_state(result, ref, {**start_values(), **changes})
    assert_outputs_equal(result.reset_index(drop=True), ref, "model exchange", rel=REL_ME)


def test_model_exchange_release_command_input(fmu_path):
    from fmpy import simulate_fmu

    command = np.array([(0.0, False), (0.85, True), (1.5, True)],
                       dtype=[("time", float), ("release_command", bool)])
    result = simulate_fmu(str(fmu_path), stop_time=1.5, output_interval=1e-3,
                          fmi_type="ModelExchange", input=command, record_events=False)
    ref = reference(result["time"], command_time=0.85, t_stop=1.5)
    keep = np.abs(result["time"] - 0.85) > 1e-9  # the event's own point: right vs left limit
    assert result["phase"][~keep][0] == 3 and ref["phase"][~keep].iloc[0] == 2
    frame = pd.DataFrame({n: result[n] for n in result.dtype.names})[keep]
    assert_outputs_equal(frame.reset_index(drop=True), ref[keep].reset_index(drop=True),
                         "model exchange, release command", rel=REL_ME)


@pytest.mark.parametrize("changes, x", [
    ({}, [-0.6, -1.2, 0.0, 2.0, -3.0, 0.0, 0.0, 0.0]),  # trough: phi follows the constraint
    ({"start.projectile": 2, "engine.H": 12.0, "start.phi_deg": -90.0},
     [-0.4, -1.0, -1.9, 2.5, -1.0, 4.0, 0.0, 0.0]),  # in the sling
    ({"start.projectile": 3, "release.time": 0.0}, [0.3, -0.5, 0.0, 3.0, 2.0, 0.0, 0.0, 0.0]),
    (FRICTION, [-0.6, -1.2, 0.0, 2.0, -3.0, 0.0, 900.0, 400.0]),  # lost energies: states
    ({**FRICTION, "start.projectile": 2, "engine.H": 12.0, "start.phi_deg": -90.0},
     [-0.4, -1.0, -1.9, 2.5, -1.0, 4.0, 900.0, 400.0]),
], ids=["trough", "sling", "dry", "trough-friction", "sling-friction"])
def test_directional_derivatives_equal_differences_of_the_outputs(fmu_path, unzipped, changes,
                                                                  x):
    """Model exchange: d(outputs)/d(states) from the generated Jacobians against central
    differences of the FMU's own outputs (bound: the difference's error, 1e-6 of the peak)."""
    from fmpy import read_model_description
    from fmpy.fmi2 import FMU2Model

    md = read_model_description(str(fmu_path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    types = {v.name: v.type for v in md.modelVariables}
    fmu = FMU2Model(guid=md.guid, unzipDirectory=unzipped,
                    modelIdentifier=md.modelExchange.modelIdentifier, instanceName="jac")
    fmu.instantiate()
    for name, value in changes.items():
        if types[name] == "Enumeration":
            fmu.setInteger([vr[name]], [value])
        else:
            fmu.setReal([vr[name]], [value])
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    fmu.newDiscreteStates()
    fmu.enterContinuousTimeMode()
    fmu.setTime(0.1)
    outputs = [vr[n] for n in OUTPUT_NAMES[1:]]
    states = [vr[n] for n in ("theta", "psi", "phi", "theta_d", "psi_d", "phi_d",
                              "E_loss_pivot", "E_loss_hinge")]
    x = np.array(x)
    n = len(states)
    for k, state in enumerate(states):
        fmu.setContinuousStates((ctypes.c_double * n)(*x), n)
        exact = np.array(fmu.getDirectionalDerivative(outputs, [state], [1.0]))
        h = 1e-5 * max(1.0, abs(x[k]))
        rows = []
        for sign in (1.0, -1.0):
            fmu.setContinuousStates((ctypes.c_double * n)(*(x + sign * h * np.eye(n)[k])), n)
            rows.append(np.array(fmu.getReal(outputs)))
        diff = (rows[0] - rows[1]) / (2.0 * h)
        finite = np.isfinite(diff)
        assert np.isfinite(exact).all()
        scale = max(1.0, float(np.max(np.abs(diff[finite]))))
        assert np.max(np.abs(exact[finite] - diff[finite])) <= 1e-6 * scale, state
    fmu.terminate()
    fmu.freeInstance()


def test_model_exchange_refuses_a_release_time_before_lift_off(fmu_path):
    from fmpy import simulate_fmu
    from fmpy.fmi1 import FMICallException

    log: list[tuple[int, str]] = []

    def logger(component, instance, status, category, message):  # noqa: ANN001, ANN202
        log.append((status, message.decode()))

    with pytest.raises(FMICallException) as err:
        simulate_fmu(str(fmu_path), stop_time=1.5, fmi_type="ModelExchange",
                     start_values={"release.time": 0.2}, logger=logger)
    assert err.value.status == 3
    assert any(s == 3 and "[release] time = 0.2 s comes before lift-off" in m for s, m in log)


def test_bad_parameter_is_an_error_naming_the_key_and_instantiates_again(fmu_path, unzipped):
    from fmpy.fmi1 import FMICallException

    for changes, key in (({"engine.M": -1.0}, "[engine] M"), ({"engine.L4": 0.0}, "[engine] L4"),
                         ({"start.phi_deg": -170.0}, "[start] phi_deg"),
                         ({"release.time": 0.0}, "[release]"),
                         ({"release.time": 0.2}, "[release] time = 0.2 s comes before")):
        slave = Slave(fmu_path, unzipped)
        slave.set(changes)
        slave.fmu.setupExperiment(startTime=0.0)
        slave.fmu.enterInitializationMode()
        with pytest.raises(FMICallException) as err:
            slave.fmu.exitInitializationMode()
        assert err.value.status == 3  # fmi2Error, not fmi2Fatal
        assert any(status == 3 and key in message for status, message in slave.log), slave.log
        slave.fmu.freeInstance()
    slave = Slave(fmu_path, unzipped)  # the same library, instantiated again
    slave.fmu.setupExperiment(startTime=0.0)
    slave.fmu.enterInitializationMode()
    slave.fmu.exitInitializationMode()
    slave.fmu.doStep(0.0, 1.2)
    assert slave.outputs()[0] == 3
    slave.fmu.terminate()
    slave.fmu.freeInstance()


def test_fmu_state_get_set_and_serialise_replay_the_run(fmu_path, unzipped):
    slave = Slave(fmu_path, unzipped)
    fmu = slave.fmu
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    h, t = 1e-3, 0.0
    for _ in range(300):
        fmu.doStep(t, h)
        t += h
    saved_at = t
    state = fmu.getFMUState()
    blob = fmu.serializeFMUState(state)

    def run_on(t0: float, command_at: float) -> np.ndarray:
        rows, t = [], t0
        for k in range(900):
            fmu.setBoolean([slave.vr["release_command"]], [t >= command_at])
            fmu.doStep(t, h)
            t = saved_at + (k + 1) * h
            rows.append(slave.outputs())
        return np.array(rows)

    first = run_on(saved_at, 0.8)
    fmu.setFMUState(state)
    again = run_on(saved_at, 0.8)
    np.testing.assert_array_equal(again, first)
    restored = fmu.deserializeFMUState(blob)
    fmu.setFMUState(restored)
    np.testing.assert_array_equal(run_on(saved_at, 0.8), first)
    fmu.setFMUState(state)
    later = run_on(saved_at, 0.9)  # another command time from the same state
    released = saved_at + h * (1 + np.argmax(later[:, 0] == 3))
    assert released == pytest.approx(0.9 + h, abs=1e-9)
    assert not np.array_equal(later, first)
    fmu.freeFMUState(state)
    fmu.freeFMUState(restored)
    fmu.terminate()
    fmu.freeInstance()
