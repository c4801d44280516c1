"""Speed of the native FMU, in a C host and in fmpy, against the same run in-process.

A 1.5 s shot of the paper's engine at 1 ms communication steps (1500 ``fmi2DoStep`` calls,
every output read at every step):

* **C host** (``fmu/host/fmi2_host.c``, dlopen, no Python): the whole run from
  ``fmi2Instantiate`` to ``fmi2FreeInstance``, and the mean cost of one step (``fmi2DoStep``
  and ``fmi2GetReal`` / ``fmi2GetInteger`` of every output);
* **fmpy, a loop** of ``FMU2Slave.doStep`` and ``getReal`` / ``getInteger`` of every output
  (the FMU unzipped and loaded once): whole run from instantiate to free, and per step; once
  with fmpy's list API, once with its ``fmi2GetReal`` on ctypes arrays built before the loop
  (what a host that reads the same outputs every step does);
* **fmpy simulate_fmu**: the whole call (unzip, load, instantiate, 1500 steps, recording);
* **in-process** ``simulate`` of the same scene at the same 1501 times.

The best of ``repeats`` runs counts; the fmpy loops' cost of a step is the best mean over a
block of 100 steps (the machine is shared). ``run(out_dir)`` writes ``fmu_speed.csv`` and returns
the table (targets of issue 16 in its last column); ``python bench/fmu_speed.py`` prints it.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.fmu.build import build_fmu
from trebuchet.fmu.c_host import compile_host, run_host
from trebuchet.fmu.crosscheck import after_release_for
from trebuchet.fmu.interface import OUTPUT_NAMES, PARAMETERS, scene_from_parameters
from trebuchet.model.simulate import simulate

STOP = 1.5  # s
STEP = 1e-3  # s
N_STEPS = round(STOP / STEP)
BLOCK = 100  # steps timed together in the fmpy loops; the best block gives the step's cost


def _fmpy_loop(fmu: Path, repeats: int, prebuilt: bool) -> tuple[float, float]:
    """Best whole run (s) and the cost of a step (s; the best mean over a block of
    :data:`BLOCK` steps, as ``timeit`` takes the best, so that other processes on a shared
    machine do not count) of a plain fmpy loop: ``getReal`` with a list of value references,
    or (``prebuilt``) fmpy's ``fmi2GetReal`` on ctypes arrays built once."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave, fmi2Integer, fmi2Real, fmi2ValueReference

    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    reals = [vr[n] for n in OUTPUT_NAMES[1:]]
    phase = [vr["phase"]]
    real_refs = (fmi2ValueReference * len(reals))(*reals)
    real_values = (fmi2Real * len(reals))()
    phase_ref, phase_value = (fmi2ValueReference * 1)(*phase), (fmi2Integer * 1)()
    folder = extract(str(fmu))
    best_run = best_step = np.inf
    try:
        for _ in range(repeats):
            t0 = time.perf_counter()
            slave = FMU2Slave(guid=md.guid, unzipDirectory=folder,
                              modelIdentifier=md.coSimulation.modelIdentifier,
                              instanceName="bench")
            slave.instantiate()
            slave.setupExperiment(startTime=0.0, stopTime=STOP)
            slave.enterInitializationMode()
            slave.exitInitializationMode()
            slave.getReal(reals)
            for block in range(0, N_STEPS, BLOCK):
                b0 = time.perf_counter()
                if prebuilt:
                    for k in range(block, block + BLOCK):
                        slave.doStep(k * STEP, STEP)
                        slave.fmi2GetReal(slave.component, real_refs, len(reals), real_values)
                        slave.fmi2GetInteger(slave.component, phase_ref, 1, phase_value)
                else:
                    for k in range(block, block + BLOCK):
                        slave.doStep(k * STEP, STEP)
                        slave.getReal(reals)
                        slave.getInteger(phase)
                best_step = min(best_step, (time.perf_counter() - b0) / BLOCK)
            slave.terminate()
            slave.freeInstance()
            t3 = time.perf_counter()
            best_run = min(best_run, t3 - t0)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return best_run, best_step


def _simulate_fmu_seconds(fmu: Path, repeats: int) -> float:
    from fmpy import simulate_fmu

    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        r = simulate_fmu(str(fmu), stop_time=STOP, output_interval=STEP,
                         fmi_type="CoSimulation")
        best = min(best, time.perf_counter() - t0)
        if abs(r["time"][-1] - STOP) > 1e-9:
            raise RuntimeError("truncated run")
    return best


def _in_process_seconds(repeats: int) -> float:
    scene = scene_from_parameters({p.name: p.start for p in PARAMETERS})
    times = STEP * np.arange(N_STEPS + 1)
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        simulate(scene, t_eval=times, after_release=after_release_for(STOP))
        best = min(best, time.perf_counter() - t0)
    return best


def run(out_dir: str | Path | None = None, repeats: int = 20) -> pd.DataFrame:
    """Whole-run and per-step wall times (s, µs) of each case, their ratio to the in-process
    run, and the issue's targets."""
    with tempfile.TemporaryDirectory(prefix="fmu_speed_") as tmp:
        tmp_path = Path(tmp)
        fmu = build_fmu(tmp_path / "Trebuchet.fmu")
        host = compile_host(tmp_path / "fmi2_host")
        c_run = run_host(host, fmu, tmp_path / "host", stop=STOP, step=STEP, repeats=repeats,
                         table=False)
        if c_run.returncode != 0:
            raise RuntimeError(f"C host failed: {c_run.message}")
        loop_run, loop_step = _fmpy_loop(fmu, repeats, prebuilt=False)
        fast_run, fast_step = _fmpy_loop(fmu, repeats, prebuilt=True)
        sim_fmu = _simulate_fmu_seconds(fmu, max(3, repeats // 5))
    inproc = _in_process_seconds(repeats)
    rows = [
        ("in-process simulate", inproc, np.nan, ""),
        ("C host (dlopen), whole run", c_run.run_us * 1e-6, c_run.step_us,
         "run <= 2 ms, step <= 2 us"),
        ("fmpy FMU2Slave loop (getReal), whole run", loop_run, loop_step * 1e6,
         "step <= 10 us"),
        ("fmpy FMU2Slave loop (fmi2GetReal, arrays built once), whole run", fast_run,
         fast_step * 1e6, "step <= 10 us"),
        ("fmpy simulate_fmu", sim_fmu, np.nan, ""),
    ]
    table = pd.DataFrame([{"case": c, "steps": N_STEPS, "seconds": s, "us_per_step": u,
                           "ratio_to_in_process": s / inproc, "target": t}
                          for c, s, u, t in rows])
    table.attrs["notes"] = [
        f"1.5 s shot of the paper's engine at 1 ms steps ({N_STEPS} steps, all "
        f"{len(OUTPUT_NAMES)} outputs read each step); best of {repeats} runs",
        "us_per_step: fmi2DoStep plus reading every output; C host: mean over the best run; "
        f"fmpy loops: best mean over a block of {BLOCK} steps",
    ]
    if out_dir is not None:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        table.to_csv(out / "fmu_speed.csv", index=False)
    return table


if __name__ == "__main__":
    print(run().to_string(index=False))
