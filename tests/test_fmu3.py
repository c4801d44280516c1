"""The native FMU as FMI 3.0 (``trebuchet fmu build --fmi 3``): valid, co-simulation and model
exchange equal to the in-process simulator, bad parameters are fmi3Error, FMU state works."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tests.test_fmu import hold_couples_to_own_state
from trebuchet.fmu.crosscheck import reference
from trebuchet.fmu.interface import OUTPUT_NAMES, PARAMETERS

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="the build needs gcc")
REL, REL_ME = 1e-8, 1e-6


@pytest.fixture(scope="module")
def fmu3(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("fmu3") / "Trebuchet.fmu"
    proc = subprocess.run([sys.executable, "-m", "trebuchet.cli", "fmu", "build", "--fmi", "3",
                           "-o", str(path)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return path


def _assert_equal(result, ref: pd.DataFrame, rel: float) -> None:
    np.testing.assert_array_equal(np.asarray(result["phase"]), ref["phase"].to_numpy())
    for name in OUTPUT_NAMES[1:]:
        want = ref[name].to_numpy(dtype=float)
        err = np.max(np.abs(np.asarray(result[name], dtype=float) - want))
        assert err <= rel * np.max(np.abs(want)), f"{name} off by {err:g}"


def test_fmi3_model_description(fmu3):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(fmu3)) == []
    md = read_model_description(str(fmu3))
    assert md.fmiVersion == "3.0" and md.coSimulation and md.modelExchange
    by_name = {v.name: v for v in md.modelVariables}
    assert by_name["engine.counterweight"].type == "Enumeration"
    assert by_name["theta"].type == "Float64" and by_name["theta"].displayUnit == "deg"
    assert len(md.eventIndicators) == 3 and len(md.derivatives) == 8


@pytest.mark.parametrize("step", [1e-3, 1e-2])
def test_fmi3_cosimulation_equals_in_process(fmu3, step):
    from fmpy import simulate_fmu

    result = simulate_fmu(str(fmu3), stop_time=1.5, output_interval=step,
                          fmi_type="CoSimulation")
    assert result["time"][-1] == pytest.approx(1.5)
    _assert_equal(result, reference(result["time"], t_stop=1.5), REL)


FRICTION = {"friction.pivot_mu": 0.15, "friction.pivot_radius": 0.1, "friction.hinge_mu": 0.15,
            "friction.hinge_radius": 0.06}


@pytest.mark.parametrize("changes", [{}, FRICTION], ids=["frictionless", "friction"])
def test_fmi3_model_exchange_equals_in_process(fmu3, changes):
    from fmpy import simulate_fmu

    result = simulate_fmu(str(fmu3), stop_time=1.5, output_interval=1e-3,
                          fmi_type="ModelExchange", solver="CVode", record_events=False,
                          start_values=changes)
    keep = np.abs(result["time"] - 0.997) > 1e-9  # the release by time: right vs left limit
    frame = pd.DataFrame({n: result[n] for n in result.dtype.names})[keep]
    values = {**{p.name: p.start for p in PARAMETERS}, **changes}
    ref = reference(frame["time"].to_numpy(), values, t_stop=1.5)
    frame = frame.reset_index(drop=True)
    if changes:
        hold_couples_to_own_state(frame, ref, values)
    _assert_equal(frame, ref, REL_ME)


def test_fmi3_cosimulation_with_friction_equals_in_process(fmu3):
    from fmpy import simulate_fmu

    result = simulate_fmu(str(fmu3), stop_time=1.5, output_interval=1e-3,
                          fmi_type="CoSimulation", start_values=FRICTION)
    values = {**{p.name: p.start for p in PARAMETERS}, **FRICTION}
    _assert_equal(result, reference(result["time"], values, t_stop=1.5), REL)


def test_fmi3_bad_parameter_error_and_state(fmu3):
    from fmpy import extract, read_model_description
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi3 import FMU3Slave

    md = read_model_description(str(fmu3))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    folder = extract(str(fmu3))
    log: list[tuple[int, str]] = []

    def logger(env, status, category, message):  # noqa: ANN001, ANN202
        log.append((status, message.decode()))

    try:
        slave = FMU3Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier="Trebuchet",
                          instanceName="t")
        slave.instantiate(loggingOn=True, logMessage=logger)
        slave.setFloat64([vr["engine.L4"]], [0.0])
        slave.enterInitializationMode(startTime=0.0)
        with pytest.raises(FMICallException) as err:
            slave.exitInitializationMode()
        assert err.value.status == 3
        assert any(s == 3 and "[engine] L4" in m for s, m in log), log
        slave.freeInstance()

        slave = FMU3Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier="Trebuchet",
                          instanceName="t")
        slave.instantiate(logMessage=logger)
        slave.enterInitializationMode(startTime=0.0)
        slave.exitInitializationMode()
        outputs = [vr[n] for n in OUTPUT_NAMES[1:]]

        def run(t0: float, n: int) -> np.ndarray:
            rows = []
            for k in range(n):
                slave.doStep(t0 + k * 1e-3, 1e-3)
                rows.append(slave.getFloat64(outputs))
            return np.array(rows)

        run(0.0, 500)
        state = slave.getFMUState()
        blob = slave.serializeFMUState(state)
        first = run(0.5, 500)
        slave.setFMUState(state)
        np.testing.assert_array_equal(run(0.5, 500), first)
        slave.setFMUState(slave.deserializeFMUState(blob))
        np.testing.assert_array_equal(run(0.5, 500), first)
        slave.terminate()
        slave.freeInstance()
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def test_fmi3_directional_derivatives(fmu3):
    """Model exchange: d(outputs)/d(states) against central differences of the outputs."""
    import ctypes

    from fmpy import extract, read_model_description
    from fmpy.fmi3 import FMU3Model

    md = read_model_description(str(fmu3))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    folder = extract(str(fmu3))
    try:
        fmu = FMU3Model(guid=md.guid, unzipDirectory=folder, modelIdentifier="Trebuchet",
                        instanceName="jac")
        fmu.instantiate()
        fmu.enterInitializationMode(startTime=0.0)
        fmu.exitInitializationMode()
        fmu.updateDiscreteStates()
        fmu.enterContinuousTimeMode()
        outputs = [vr[n] for n in OUTPUT_NAMES[1:]]
        x = np.array([-0.6, -1.2, 0.0, 2.0, -3.0, 0.0, 0.0, 0.0])
        states = ("theta", "psi", "phi", "theta_d", "psi_d", "phi_d", "E_loss_pivot",
                  "E_loss_hinge")
        n = len(states)
        for name in ("theta", "psi", "theta_d", "psi_d"):  # phi, phi_d: the trough's constraint
            k = states.index(name)
            fmu.setContinuousStates((ctypes.c_double * n)(*x), n)
            exact = np.array(fmu.getDirectionalDerivative(outputs, [vr[name]], [1.0]))
            h = 1e-5 * max(1.0, abs(x[k]))
            rows = []
            for sign in (1.0, -1.0):
                fmu.setContinuousStates((ctypes.c_double * n)(*(x + sign * h * np.eye(n)[k])), n)
                rows.append(np.array(fmu.getFloat64(outputs)))
            diff = (rows[0] - rows[1]) / (2.0 * h)
            assert np.max(np.abs(exact - diff)) <= 1e-6 * max(1.0, np.max(np.abs(diff))), name
        fmu.terminate()
        fmu.freeInstance()
    finally:
        shutil.rmtree(folder, ignore_errors=True)
