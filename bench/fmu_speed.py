"""Speed of the co-simulation FMU against the same run in-process.

A 1.5 s shot of the paper's engine at 1 ms communication steps (1500 doStep calls, every
output read at every step) through fmpy's ``simulate_fmu``, against ``simulate`` of the same
scene at the same 1501 times in-process. The FMU runs in a subprocess (pythonfmu's library
is loaded there and dies with it); its time is measured inside that process, from
``simulate_fmu`` call to return (unzip, load, instantiate, initialise, 1500 steps). The best
of ``repeats`` runs counts. ``run(out_dir)`` writes ``fmu_speed.csv`` and returns the table;
``python bench/fmu_speed.py`` prints it.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.fmu.build import build_fmu
from trebuchet.fmu.cosim import after_release_for
from trebuchet.fmu.interface import PARAMETERS, scene_from_parameters
from trebuchet.model.simulate import simulate

STOP = 1.5  # s
STEP = 1e-3  # s

_COSIM = """
    import json, os, sys, time
    from fmpy import simulate_fmu
    fmu, stop, step, repeats = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4])
    seconds = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        r = simulate_fmu(fmu, stop_time=stop, output_interval=step)
        seconds.append(time.perf_counter() - t0)
        assert abs(r["time"][-1] - stop) < 1e-9, "truncated run"
    print(json.dumps({"seconds": seconds, "rows": int(len(r))}))
    sys.stdout.flush()
    os._exit(0)  # pythonfmu 0.7.0 can corrupt the heap at interpreter exit
"""


def _cosim_seconds(fmu: Path, repeats: int) -> tuple[float, int]:
    proc = subprocess.run([sys.executable, "-c", textwrap.dedent(_COSIM), str(fmu), repr(STOP),
                           repr(STEP), str(repeats)], capture_output=True, text=True,
                          timeout=600, check=True)
    report = json.loads(proc.stdout.strip().splitlines()[-1])
    return min(report["seconds"]), report["rows"]


def _in_process_seconds(repeats: int) -> tuple[float, int]:
    scene = scene_from_parameters({p.name: p.start for p in PARAMETERS})
    times = STEP * np.arange(round(STOP / STEP) + 1)
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        run = simulate(scene, t_eval=times, after_release=after_release_for(STOP))
        best = min(best, time.perf_counter() - t0)
    return best, len(run)


def run(out_dir: str | Path | None = None, repeats: int = 3) -> pd.DataFrame:
    """Wall time (s) of the co-simulation and of the in-process run, and their ratio."""
    with tempfile.TemporaryDirectory(prefix="fmu_speed_") as tmp:
        fmu = build_fmu(Path(tmp) / "Trebuchet.fmu")
        cosim_s, cosim_rows = _cosim_seconds(fmu, repeats)
    inproc_s, inproc_rows = _in_process_seconds(repeats)
    table = pd.DataFrame([
        {"case": "in-process simulate", "steps": inproc_rows - 1, "seconds": inproc_s,
         "ms_per_step": 1e3 * inproc_s / (inproc_rows - 1), "ratio_to_in_process": 1.0},
        {"case": "FMU via fmpy simulate_fmu", "steps": cosim_rows - 1, "seconds": cosim_s,
         "ms_per_step": 1e3 * cosim_s / (cosim_rows - 1),
         "ratio_to_in_process": cosim_s / inproc_s},
    ])
    if out_dir is not None:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        table.to_csv(out / "fmu_speed.csv", index=False)
    return table


if __name__ == "__main__":
    print(run().to_string(index=False))
