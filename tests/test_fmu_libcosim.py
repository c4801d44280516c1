"""The FMU in libcosim (the Open Simulation Platform's co-simulation library, through
libcosimpy, which loads FMUs with its own FMI Library): 1 ms steps equal the in-process
simulator, without friction and with the paper's bearings (issue 22)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from trebuchet.fmu.crosscheck import reference
from trebuchet.fmu.interface import OUTPUT_NAMES, PARAMETERS

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="the build needs gcc")
libcosimpy = pytest.importorskip("libcosimpy")
REL = 1e-8
#: data_samples/horsdal_friction.toml's bearings (the same as tests/test_fmu.py's FRICTION).
FRICTION = {"friction.pivot_mu": 0.15, "friction.pivot_radius": 0.1, "friction.hinge_mu": 0.15,
            "friction.hinge_radius": 0.06}


@pytest.mark.parametrize("changed", [{}, FRICTION], ids=["frictionless", "friction"])
def test_libcosim_runs_the_fmu_as_the_simulator(fmu_path, changed):
    from fmpy import read_model_description
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.ERROR)
    vr = {v.name: v.valueReference for v in read_model_description(str(fmu_path)).modelVariables}
    execution = CosimExecution.from_step_size(step_size=1_000_000)  # ns: 1 ms
    index = execution.add_local_slave(
        local_slave=CosimLocalSlave(fmu_path=str(fmu_path), instance_name="trebuchet"))
    for name, value in changed.items():
        assert execution.real_initial_value(index, vr[name], value)
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer=observer)
    reals = [vr[n] for n in OUTPUT_NAMES[1:]]
    rows, phases = [], []
    for _ in range(1500):
        assert execution.step()
        rows.append(observer.last_real_values(index, reals))
        phases.append(observer.last_integer_values(index, [vr["phase"]])[0])
    status = execution.status()
    assert status.error_code == 0 and status.current_time == 1_500_000_000
    values = {p.name: p.start for p in PARAMETERS} | changed
    ref = reference(1e-3 * np.arange(1, 1501), values, t_stop=1.5)
    if changed:  # friction takes heat from the shot: the FMU's outputs say so
        assert ref["E_loss_pivot"].iloc[-1] > 1e3 and ref["E_loss_hinge"].iloc[-1] > 1e3
    np.testing.assert_array_equal(phases, ref["phase"].to_numpy())
    got = np.array(rows)
    for j, name in enumerate(OUTPUT_NAMES[1:]):
        want = ref[name].to_numpy()
        err = np.max(np.abs(got[:, j] - want))
        assert err <= REL * np.max(np.abs(want)), f"{name} off by {err:g}"
