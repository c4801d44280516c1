"""Friction in the bearings (issue 22): what it costs in time and what it takes from a shot.

For the paper's engine (``data_samples/horsdal_friction.toml``: μ 0.15 on a 0.10 m shaft and a
0.06 m pin) and the small fast engine (``data_samples/small_fast.toml``: μ 0.3 on a 12.5 mm
shaft and a 10 mm pin), each with and without its ``[friction]``:

* the CPU time of one ``simulate`` at its defaults (the generated C's DOP853, rtol 1e-10,
  1 ms outputs) and with ``method="numba-DOP853"`` (the fallback without a C compiler), the
  least of ``REPEATS`` interleaved batches of ten (CPU time, not wall: the machines this runs
  on are shared), and the friction run's ratio to the frictionless one of the same path
  timed in the same run;
* the right-hand-side evaluations and accepted steps (the couples' sign turns over 1e-3 rad/s
  of sliding rate: each standstill of a joint costs small steps);
* the heat made by the release (J and % of ΔU, pivot and hinge), the energy drift of
  mechanical energy plus losses, and the range in vacuum.
"""

from __future__ import annotations

import dataclasses
import os
import time
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.model.scene import Scene
from trebuchet.model.simulate import integrate, simulate

ROOT = Path(__file__).resolve().parents[1]
SCENES = {"paper": ROOT / "data_samples" / "horsdal_friction.toml",
          "small fast": ROOT / "data_samples" / "small_fast.toml"}
REPEATS = int(os.environ.get("BENCH_REPEATS", "10"))


def _without_friction(scene: Scene) -> Scene:
    return dataclasses.replace(scene, engine=dataclasses.replace(scene.engine, friction=None))


#: The paths of ``simulate``: its default (the generated C) and the numba kernels.
METHODS = {"C": "DOP853", "numba": "numba-DOP853"}


def _timed(runs: list[tuple[Scene, str]]) -> list[float]:
    """CPU seconds of one ``simulate`` of each (scene, method): the least of the interleaved
    batches."""
    times: list[list[float]] = [[] for _ in runs]
    for s, method in runs:
        simulate(s, method=method)
    for _ in range(REPEATS):
        for k, (s, method) in enumerate(runs):
            t0 = time.process_time()
            for _ in range(10):
                simulate(s, method=method)
            times[k].append((time.process_time() - t0) / 10)
    return [float(np.min(t)) for t in times]


def _row(name: str, path: str, scene: Scene, seconds: float, base: float) -> dict:
    run = simulate(scene, method=METHODS[path])
    traj = integrate(scene, method=METHODS[path])
    steps = sum(p.sol.t_steps.size for p in traj.phases)
    release = run.attrs["events"]["release"]
    at = run[run.t <= release].iloc[-1]
    pivot = float(at.get("E_loss_pivot", 0.0))
    hinge = float(at.get("E_loss_hinge", 0.0))
    return {"engine": name, "path": path, "friction": "yes" if scene.friction else "no",
            "simulate (ms CPU)": 1e3 * seconds, "ratio to frictionless": seconds / base,
            "evaluations": traj.nfev, "steps": steps,
            "heat by release, pivot (J)": pivot, "hinge (J)": hinge,
            "share of dU (%)": 100.0 * (pivot + hinge) / scene.delta_U,
            "energy drift (of dU)": run.attrs["diagnostics"]["energy_drift_rel"],
            "range (m)": run.attrs["flight"]["range"]}


def run(out_dir: Path) -> pd.DataFrame:
    rows = []
    for name, path in SCENES.items():
        with_fr = Scene.from_toml(path)
        plain = _without_friction(with_fr)
        runs = [(s, m) for m in METHODS.values() for s in (plain, with_fr)]
        times = dict(zip(((s.friction is not None, m) for s, m in runs), _timed(runs),
                         strict=True))
        for label, method in METHODS.items():
            base = times[False, method]
            rows.append(_row(name, label, plain, base, base))
            rows.append(_row(name, label, with_fr, times[True, method], base))
    table = pd.DataFrame(rows)
    table.attrs["notes"] = [
        f"{REPEATS} interleaved batches of 10 runs per scene after a warm-up; the least CPU "
        "time per run; the ratio is to the same engine without its [friction], timed in the "
        "same run, on the same path (C: simulate's default, the generated C; numba: "
        "method='numba-DOP853').",
        "Target (issue 22): a shot with friction at most 2 x the frictionless one.",
    ]
    return table
