"""The generated C in process (issue 25): one shot, one with friction, a design's figures, a sweep.

Every line is timed in one run: ``REPEATS`` rounds after a warm-up, each calling every case
five times back to back (the plain baseline once), so that the load of a shared machine falls
on all alike; the median counts (and the best of each, which the machine's other sessions
disturb least), and each target is a ratio of two lines of the same run:

* ``simulate`` of the paper's engine (``data_samples/horsdal_large.toml``, 1499 rows, 53
  columns) in the generated C (the default) and with the numba kernels (the default before);
* **the generated C alone**: the shot (``CShot.start``) and the same 53 columns at the same
  1499 times (``CShot.rows``): two ctypes calls, no DataFrame, what ``simulate`` wraps;
* the **plain** ``solve_ivp`` implementation of ``bench/model_speed.py`` (a numpy mass matrix
  in the right-hand side, the forces at the same times): the issue's baseline;
* the paper's engine **with friction** (``data_samples/horsdal_friction.toml``), C and numba;
* a **design's figures** without a table: on the table's rows reduced in C
  (``c_summary.shot_summary``, ``sweep --dt``), as continuous peaks on the C's steps
  (``shot_summary.shot_figures``, the sweep's default), and from ``simulate``'s table with the
  numba kernels (``sweep.summarize(simulate(...))``, as sweeps made them before issue 24);
* a **sweep** of 10,000 designs (100 release angles × 100 counterweights) on the cores this
  process may use, timed once (wall).

The notes give each target of the issue with its figure; they and the largest difference
between the C and the numba kernels' tables (scenes of tests/test_c_engine.py) say whether
the results changed.
"""

from __future__ import annotations

import os
import platform
import resource
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from bench.model_speed import plain_shot
from trebuchet.core.errors import ModelValidityWarning
from trebuchet.model import c_engine
from trebuchet.model.c_summary import shot_summary
from trebuchet.model.scene import Scene
from trebuchet.model.shot_summary import shot_figures
from trebuchet.model.simulate import default_times, integrate, simulate
from trebuchet.model.sweep import default_workers, design_scene, summarize, sweep

ROOT = Path(__file__).resolve().parents[1]
PAPER = ROOT / "data_samples" / "horsdal_large.toml"
FRICTION = ROOT / "data_samples" / "horsdal_friction.toml"
REPEATS = int(os.environ.get("BENCH_REPEATS", "20"))
BLOCK = 5  # calls of a case back to back in each round (the plain baseline: one)
SWEEP_SIDE = int(os.environ.get("BENCH_ENGINE_SWEEP_SIDE", "100"))  # designs: its square
WARMUP = 3
DESIGN = {"release.velocity_angle_deg": 45.0, "engine.M": 20000.0}


def _cases(paper: Scene, friction: Scene, design: Scene) -> dict[str, object]:
    times = default_times(integrate(paper))
    names = c_engine.table_names(False)

    def c_alone() -> None:
        c_engine.CShot.start(paper, 1e-10, 0.5).rows(times, names)

    return {
        "plain solve_ivp implementation (baseline)": lambda: plain_shot(paper),
        "simulate (default: the generated C)": lambda: simulate(paper),
        "the generated C alone (shot + 53 columns at 1499 times)": c_alone,
        "simulate with method='numba-DOP853' (the default before)": lambda: simulate(
            paper, method="numba-DOP853"),
        "simulate, with friction (C)": lambda: simulate(friction),
        "simulate, with friction (numba-DOP853)": lambda: simulate(friction,
                                                                   method="numba-DOP853"),
        "a design's figures: shot_summary (C, no table)": lambda: shot_summary(design),
        "a design's figures: shot_figures (the sweep's default: the C's steps, continuous "
        "peaks)": lambda: shot_figures(design),
        "a design's figures from the table: summarize(simulate(numba-DOP853))": lambda: summarize(
            simulate(design, method="numba-DOP853"), design),
    }


def _time(cases: dict[str, object], repeats: int) -> dict[str, list[float]]:
    """ms of each call: ``repeats`` rounds, each calling every case :data:`BLOCK` times back to
    back (a loop of shots, as a sweep or a study runs them; the rounds spread the load of a
    shared machine over all cases alike)."""
    for fn in cases.values():
        for _ in range(WARMUP):
            fn()
    out: dict[str, list[float]] = {k: [] for k in cases}
    for _ in range(repeats):
        for name, fn in cases.items():
            for _ in range(BLOCK if "plain" not in name else 1):
                t0 = time.perf_counter()
                fn()
                out[name].append(1e3 * (time.perf_counter() - t0))
    return out


def _cpu_s() -> float:
    """CPU seconds of this process and of its finished children (the sweep's workers)."""
    me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(
        resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def _largest_difference() -> float:
    """Largest |C − numba| over each column's peak, on the scenes of tests/test_c_engine.py
    without friction."""
    from tests.test_c_engine import SCENES
    from tests.test_variants import scene_with

    worst = 0.0
    for changes in SCENES.values():
        scene = scene_with(**changes)
        a, b = simulate(scene), simulate(scene, method="numba-DOP853")
        for k in a.columns:
            x, y = a[k].to_numpy(dtype=float), b[k].to_numpy(dtype=float)
            ok = ~np.isnan(y)
            if ok.any():
                worst = max(worst, float(np.max(np.abs(x[ok] - y[ok])))
                            / max(float(np.max(np.abs(y[ok]))), 1.0))
    return worst


def run(out_dir: str | Path | None = None, repeats: int = REPEATS) -> pd.DataFrame:
    warnings.simplefilter("ignore", ModelValidityWarning)
    paper, friction = Scene.from_toml(PAPER), Scene.from_toml(FRICTION)
    design = design_scene(paper, DESIGN)
    times = _time(_cases(paper, friction, design), repeats)
    med = {k: float(np.median(v)) for k, v in times.items()}
    best = [float(np.min(v)) for v in times.values()]
    names = list(med)
    plain, sim, alone, numba, fr_c, fr_numba, fig, fig_cont, fig_before = (med[k]
                                                                            for k in names)
    rows = [{"case": k, "median_ms": med[k], "p25_ms": float(np.percentile(v, 25)),
             "p75_ms": float(np.percentile(v, 75)), "min_ms": float(np.min(v)),
             "ratio_to_plain": med[k] / plain, "ratio_to_simulate": med[k] / sim}
            for k, v in times.items()]
    grid = {"release.velocity_angle_deg": list(np.linspace(25.0, 70.0, SWEEP_SIDE)),
            "engine.M": list(np.linspace(8000.0, 40000.0, SWEEP_SIDE))}
    workers = default_workers()
    cpu0 = _cpu_s()
    t0 = time.perf_counter()
    table = sweep(paper, grid, workers=workers, progress=False)
    wall = time.perf_counter() - t0
    cpu = _cpu_s() - cpu0
    n = SWEEP_SIDE * SWEEP_SIDE
    rows.append({"case": f"sweep of {n:,} designs, {workers} workers (wall, once)",
                 "median_ms": 1e3 * wall, "p25_ms": np.nan, "p75_ms": np.nan, "min_ms": np.nan,
                 "ratio_to_plain": np.nan, "ratio_to_simulate": np.nan})
    rows.append({"case": "  the same, CPU of a design (all processes)",
                 "median_ms": 1e3 * cpu / n, "p25_ms": np.nan, "p75_ms": np.nan,
                 "min_ms": np.nan, "ratio_to_plain": np.nan,
                 "ratio_to_simulate": 1e3 * cpu / n / sim})
    out = pd.DataFrame(rows)
    diff = _largest_difference()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    out.attrs["notes"] = [
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, load "
        f"average {load:.2f} at the end; Python {platform.python_version()}; {repeats} "
        f"rounds of {BLOCK} calls back to back, medians",
        f"one shot within 0.04 × plain (before 0.10 in the issue): {sim / plain:.4f} × plain "
        f"(numba-DOP853, the default before, in this run: {numba / plain:.4f})",
        f"one shot within 2 × the generated C in process (before 6 ×): {sim / alone:.2f} × "
        f"(numba-DOP853: {numba / alone:.2f} ×); best of each: {best[1] / best[2]:.2f} ×",
        f"with friction ≤ 2 × the frictionless shot: C {fr_c / sim:.2f} ×, numba-DOP853 "
        f"{fr_numba / numba:.2f} ×; best of each: C {best[4] / best[1]:.2f} ×, numba "
        f"{best[5] / best[3]:.2f} ×; the friction shot in C is {fr_numba / fr_c:.1f} × faster "
        "than with numba",
        f"a sweep design within 0.25 × one simulate() call (before about 2 ×): shot_summary "
        f"{fig / sim:.2f} × simulate in C ({fig / numba:.2f} × simulate with numba-DOP853), "
        f"shot_figures {fig_cont / sim:.2f} × ({fig_cont / numba:.2f} ×); best of each: "
        f"{best[6] / best[1]:.2f} ×, {best[7] / best[1]:.2f} ×; the figures from simulate's "
        f"table: {fig_before / numba:.2f} × numba's simulate",
        f"10,000 designs in a few seconds on 2 cores: {n:,} designs in {wall:.1f} s on "
        f"{workers} workers ({n / wall:,.0f} designs/s; "
        f"{int((table['status'] != 'ok').sum())} not ok); {1e3 * cpu / n:.2f} ms of CPU a "
        f"design in all processes: 10,000 designs in {1e4 * cpu / n / 2:.1f} s on 2 free cores",
        f"no result changes beyond rounding: the largest difference of a column between the C "
        f"and numba-DOP853, over its peak, on 7 scenes without friction: {diff:.1e}",
    ]
    if out_dir is not None:
        Path(out_dir).mkdir(parents=True, exist_ok=True)
        out.to_csv(Path(out_dir) / "engine_speed.csv", index=False)
    return out


if __name__ == "__main__":  # pragma: no cover
    res = run()
    print("\n".join(res.attrs["notes"]))
    print(res.to_string(index=False))
