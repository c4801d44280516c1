"""Speed of :func:`trebuchet.model.sweep.sweep`: 1000 designs of the paper's engine.

The grid: 20 release velocity angles (25°–70°) × 50 counterweight masses (8–40 t), every
design simulated at simulate's defaults (DOP853, rtol 1e-10, outputs every 1 ms) and
summarised (events, release, range, peak loads, energy share and drift). The same sweep runs
in this process (``workers=1``) and on local process pools of 2, 4, ... up to the cores this
process may use; one row per run with the wall time, designs per second, the speed-up over
the serial run and the number of designs refused (each with its reason in the table, none
dropped). The parallel tables must equal the serial one row for row; the benchmark checks it.

``run(out_dir)`` writes ``sweep_speed.csv`` there and returns the table;
``python bench/sweep_speed.py`` prints it. ``BENCH_SWEEP_ANGLES`` and ``BENCH_SWEEP_MASSES``
shrink the grid for a quick look.
"""

from __future__ import annotations

import os
import platform
import time
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.model.scene import Scene
from trebuchet.model.sweep import default_workers, sweep

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "data_samples" / "horsdal_large.toml"
ANGLES = int(os.environ.get("BENCH_SWEEP_ANGLES", "20"))
MASSES = int(os.environ.get("BENCH_SWEEP_MASSES", "50"))


def grid() -> dict[str, list[float]]:
    """Release angles (deg) × counterweight masses (kg)."""
    return {"release.velocity_angle_deg": list(np.linspace(25.0, 70.0, ANGLES)),
            "engine.M": list(np.linspace(8000.0, 40000.0, MASSES))}


def worker_counts(cores: int) -> list[int]:
    """1, then doubling, then the core count."""
    counts = [1]
    while counts[-1] * 2 < cores:
        counts.append(counts[-1] * 2)
    if cores > 1:
        counts.append(cores)
    return counts


def run(out_dir: str | Path | None = None) -> pd.DataFrame:
    base = Scene.from_toml(SCENE)
    g = grid()
    n = len(g["release.velocity_angle_deg"]) * len(g["engine.M"])
    cores = default_workers()
    rows, reference, serial_s = [], None, None
    for workers in worker_counts(cores):
        t0 = time.perf_counter()
        table = sweep(base, g, workers=workers, progress=False)
        seconds = time.perf_counter() - t0
        if reference is None:
            reference, serial_s = table, seconds
        else:
            pd.testing.assert_frame_equal(table, reference)
        rows.append({
            "designs": n, "workers": workers, "wall_s": seconds, "designs_per_s": n / seconds,
            "ms_per_design": 1e3 * seconds / n, "speedup": serial_s / seconds,
            "efficiency": serial_s / seconds / workers,
            "refused": int((table["status"] == "refused").sum()),
            "failed": int((table["status"] == "failed").sum()),
            "max_energy_drift_rel": float(table["energy_drift_rel"].max()),
        })
    out = pd.DataFrame(rows)
    out.attrs["notes"] = [
        f"grid: {len(g['release.velocity_angle_deg'])} release angles 25–70° × "
        f"{len(g['engine.M'])} counterweights 8–40 t on the paper's engine = {n} designs",
        f"machine: {platform.processor() or platform.machine()}, {cores} usable cores, "
        f"Python {platform.python_version()}",
        "parallel tables equal the serial one row for row (checked)",
    ]
    if out_dir is not None:
        Path(out_dir).mkdir(parents=True, exist_ok=True)
        out.to_csv(Path(out_dir) / "sweep_speed.csv", index=False)
    return out


if __name__ == "__main__":
    table = run()
    print("\n".join(table.attrs["notes"]))
    print(table.to_string(index=False))
