"""Start-up of the command line, and the CSV writer: ratios to baselines timed in the same run.

* ``trebuchet --help`` and a usage error (``trebuchet forces`` without its arguments), each
  as a whole process, against ``python -c pass`` (the target of issue 25: within 4 x);
* a small ``trebuchet forces`` run (the shipped sample ``horsdal_240fps.csv``, 332 rows) as a
  whole process, and the same command run again inside this process once its modules are
  loaded and its kernels compiled: the difference is the start-up (imports, numba's cache
  loading), given as its share of the whole;
* writing the loads of a 2 s log at 1000 fps (2000 rows, 105 columns) as CSV: pandas'
  ``to_csv`` (what the command used), :func:`trebuchet.core.csv_table.write_table` (what it
  uses now: the same bytes, checked) and ``np.savetxt`` at 17 digits (not the same text: the
  issue's yardstick), each also as a share of the ``reconstruct`` call that made the table.

The processes and the writers are timed in turns (A B C A B C ...), so that the load of a
shared machine falls on all alike; the table gives medians and the ratio to each line's
baseline. ``BENCH_CLI_REPEATS`` (default 15) sets the repeats of the short lines.
"""

from __future__ import annotations

import io
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.cli import main
from trebuchet.core.csv_table import csv_text, write_table
from trebuchet.ingest.reconstruct import reconstruct
from trebuchet.ingest.synthetic.simulated_log import simulated_log
from trebuchet.model.scene import Scene

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "data_samples" / "horsdal_large.toml"
SAMPLE = ROOT / "data_samples" / "horsdal_240fps.csv"
REPEATS = int(os.environ.get("BENCH_CLI_REPEATS", "15"))
FORCES_REPEATS = max(3, REPEATS // 3)
COMMAND = Path(sys.executable).with_name("trebuchet")


def _process_seconds(argv: list[str]) -> float:
    """Wall time of one whole process (its output thrown away)."""
    t0 = time.perf_counter()
    subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    return time.perf_counter() - t0


def _in_turns(cases: dict[str, object], repeats: int) -> dict[str, list[float]]:
    """Each case (a command line, or a callable timed in this process) ``repeats`` times, in
    turns, after one warm-up round."""
    times: dict[str, list[float]] = {name: [] for name in cases}
    for k in range(repeats + 1):
        for name, case in cases.items():
            if callable(case):
                t0 = time.perf_counter()
                case()
                seconds = time.perf_counter() - t0
            else:
                seconds = _process_seconds(case)
            if k:
                times[name].append(seconds)
    return times


def _quiet_forces(argv: list[str]) -> None:
    with warnings.catch_warnings(), open(os.devnull, "w") as sink:
        warnings.simplefilter("ignore")
        stdout, stderr = sys.stdout, sys.stderr
        sys.stdout = sys.stderr = sink
        try:
            main(argv)
        finally:
            sys.stdout, sys.stderr = stdout, stderr


def _row(case: str, times: list[float], baseline: str, base_times: list[float] | None,
         ) -> dict[str, object]:
    ratio = (statistics.median(a / b for a, b in zip(times, base_times, strict=True))
             if base_times is not None else 1.0)
    return {"case": case, "median_s": statistics.median(times), "min_s": min(times),
            "ratio": ratio, "baseline": baseline, "repeats": len(times)}


def _start_up(folder: Path) -> tuple[list[dict], list[str]]:
    python = [sys.executable, "-c", "pass"]
    short = _in_turns({"python": python, "help": [str(COMMAND), "--help"],
                       "usage": [str(COMMAND), "forces"]}, REPEATS)
    argv = ["forces", str(SAMPLE), "--scene", str(SCENE), "-o", str(folder / "loads.csv")]
    long = _in_turns({"python": python, "whole": [str(COMMAND), *argv],
                      "warm": lambda: _quiet_forces(argv)}, FORCES_REPEATS)
    whole, warm = statistics.median(long["whole"]), statistics.median(long["warm"])
    rows = [
        _row("python -c pass", short["python"], "", None),
        _row("trebuchet --help", short["help"], "python -c pass", short["python"]),
        _row("trebuchet forces (usage error: no arguments)", short["usage"], "python -c pass",
             short["python"]),
        _row(f"trebuchet forces {SAMPLE.name} (332 rows), whole process", long["whole"],
             "python -c pass", long["python"]),
        _row("the same forces run in a warm process (no start-up)", long["warm"],
             "whole process", long["whole"]),
    ]
    notes = [f"trebuchet --help: {rows[1]['ratio']:.2f} x python -c pass (target <= 4 x); "
             f"a usage error {rows[2]['ratio']:.2f} x",
             f"a small forces run: {whole:.2f} s, of which {100 * (whole - warm) / whole:.0f} % "
             f"start-up (imports and numba's cache: the whole process less the same run in a "
             f"warm one, {warm:.2f} s)"]
    return rows, notes


def _loads_table() -> tuple[pd.DataFrame, float]:
    """The loads of a 2 s log at 1000 fps (synthetic, 0.5 s at rest and after release), and
    the seconds ``reconstruct`` took to make them."""
    scene = Scene.from_toml(SCENE)
    log, _ = simulated_log(scene, 1000.0, 0.1, rest=0.5, after_release=0.5, seed=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reconstruct(log, scene)  # compile and load what it needs
        t0 = time.perf_counter()
        loads = reconstruct(log, scene)
        return loads, time.perf_counter() - t0


def _csv(folder: Path) -> tuple[list[dict], list[str]]:
    loads, reconstruct_s = _loads_table()
    same = csv_text(loads) == loads.to_csv(index=False)
    block = loads.to_numpy(dtype=float)

    def savetxt() -> None:
        buffer = io.StringIO()
        np.savetxt(buffer, block, fmt="%.17g", delimiter=",")
        (folder / "savetxt.csv").write_text(buffer.getvalue())

    times = _in_turns({
        "pandas": lambda: loads.to_csv(folder / "pandas.csv", index=False),
        "ours": lambda: write_table(loads, folder / "ours.csv"),
        "savetxt": savetxt}, REPEATS)
    n, k = loads.shape
    rows = [
        _row(f"pandas to_csv, {n} x {k} loads", times["pandas"], "", None),
        _row("csv_table.write_table (the same bytes)", times["ours"], "pandas to_csv",
             times["pandas"]),
        _row("np.savetxt %.17g (not the same text)", times["savetxt"], "pandas to_csv",
             times["pandas"]),
        {"case": "reconstruct of that log", "median_s": reconstruct_s, "min_s": reconstruct_s,
         "ratio": float("nan"), "baseline": "", "repeats": 1},
    ]
    pandas_s, ours_s = statistics.median(times["pandas"]), statistics.median(times["ours"])
    notes = [f"writing the loads of a 2 s log at 1000 fps ({n} rows, {k} columns): to_csv "
             f"{pandas_s:.3f} s = {100 * pandas_s / reconstruct_s:.0f} % on top of "
             f"reconstruct, write_table {ours_s:.3f} s = {100 * ours_s / reconstruct_s:.0f} % "
             f"({pandas_s / ours_s:.1f} x faster); output byte-identical to to_csv: {same}"]
    return rows, notes


def run(out_dir: str | Path | None = None) -> pd.DataFrame:
    if not COMMAND.exists():
        raise SystemExit(f"no {COMMAND}: install the package (make install) first")
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        rows, notes = _start_up(folder)
        csv_rows, csv_notes = _csv(folder)
    table = pd.DataFrame(rows + csv_rows)
    table.attrs["notes"] = [
        f"machine: {platform.machine()}, {os.cpu_count()} cores, load average {load:.2f} at "
        f"the start; Python {platform.python_version()}, pandas {pd.__version__}",
        *notes, *csv_notes]
    return table


if __name__ == "__main__":
    with pd.option_context("display.width", 200):
        print(run().to_string(index=False))
