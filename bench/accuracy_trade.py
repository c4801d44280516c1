"""Speed against accuracy of the simulator, for every accuracy preset and solver.

Each setting is timed and its error in lift-off time, release speed, peak sling tension and
peak pivot reaction measured against a very tight reference run (compiled DOP853 at rtol 1e-13).

``python -m bench accuracy_trade`` writes ``accuracy_trade.md``/``.csv`` and
``accuracy_trade.png`` (error against time per shot: settings up and to the right of another
are never worth it).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.model.paper import horsdal_scene_path
from trebuchet.model.scene import Scene
from trebuchet.model.simulate import ACCURACY, simulate

SETTINGS = [
    *[(f"preset {name}", "DOP853", name) for name in ACCURACY],
    ("compiled DOP853", "DOP853", 1e-8),
    ("python DOP853", "python-DOP853", 1e-10),
    ("scipy DOP853", "scipy-DOP853", 1e-10),
    ("scipy DOP853", "scipy-DOP853", 1e-6),
    ("scipy RK45", "RK45", 1e-10),
    ("scipy RK45", "RK45", 1e-6),
    ("scipy LSODA", "LSODA", 1e-10),
    ("scipy Radau", "Radau", 1e-10),
    ("scipy Radau", "Radau", 1e-6),
]


def _summary(run: pd.DataFrame) -> dict[str, float]:
    held = run[run["phase"] <= 2]
    return {
        "lift_off": run.attrs["events"]["lift_off"],
        "release_speed": run.attrs["flight"]["release_speed"],
        "peak_F_S": float(held["F_S_abs"].max()),
        "peak_F_R": float(held["F_R_abs"].max()),
        "energy_drift_rel": run.attrs["diagnostics"]["energy_drift_rel"],
        "nfev": run.attrs["diagnostics"]["nfev"],
    }


def _time(scene: Scene, method: str, rtol: float | str, repeats: int) -> float:
    simulate(scene, method=method, rtol=rtol)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        simulate(scene, method=method, rtol=rtol)
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def run(out_dir: str | Path, repeats: int = 15) -> pd.DataFrame:
    """Measure every setting on the paper's engine; write the table and the plot."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    scene = Scene.from_toml(horsdal_scene_path())
    ref = _summary(simulate(scene, rtol=1e-13))
    rows = []
    for label, method, rtol in SETTINGS:
        got = _summary(simulate(scene, method=method, rtol=rtol))
        rtol_value = ACCURACY.get(rtol, rtol) if isinstance(rtol, str) else rtol
        rows.append({
            "setting": label, "method": method, "rtol": rtol_value,
            "ms_per_shot": 1e3 * _time(scene, method, rtol, repeats),
            "nfev": got["nfev"],
            "lift_off_error_s": abs(got["lift_off"] - ref["lift_off"]),
            "release_speed_error_rel": abs(got["release_speed"] / ref["release_speed"] - 1),
            "peak_F_S_error_rel": abs(got["peak_F_S"] / ref["peak_F_S"] - 1),
            "peak_F_R_error_rel": abs(got["peak_F_R"] / ref["peak_F_R"] - 1),
            "energy_drift_rel": got["energy_drift_rel"],
        })
        print(f"  {label:18s} rtol {rtol_value:7.0e}: {rows[-1]['ms_per_shot']:7.2f} ms")
    table = pd.DataFrame(rows)
    table.attrs["notes"] = [
        "reference: compiled DOP853 at rtol 1e-13; errors are relative (lift-off: absolute, s)",
        "ms_per_shot: median of repeated simulate(scene) calls with all forces on the 1 ms grid",
        "plot: accuracy_trade.png (settings up and to the right of another are never worth it)",
    ]
    _plot(table, out_dir / "accuracy_trade.png")
    return table


def _plot(table: pd.DataFrame, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5), layout="constrained")
    error = table[["release_speed_error_rel", "peak_F_S_error_rel", "peak_F_R_error_rel"]].max(
        axis=1).clip(lower=1e-16)
    for method, group in table.groupby("method"):
        ax.loglog(group["ms_per_shot"], error[group.index], "o-", label=method)
        for i in group.index:
            ax.annotate(f"{table.rtol[i]:.0e}", (table.ms_per_shot[i], error[i]), fontsize=7,
                        xytext=(4, 3), textcoords="offset points")
    ax.set_xlabel("time per shot with all forces (ms)")
    ax.set_ylabel("largest relative error\n(release speed, peak F_S, peak F_R)")
    ax.set_title("Speed against accuracy, the paper's engine (labels: rtol)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.savefig(path, dpi=120)
    plt.close(fig)


