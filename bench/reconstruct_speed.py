"""Speed and memory of ``reconstruct`` against the log's length, and against one filterpy RTS pass.

Logs of the paper's engine at 1000 fps (0.5° noise, 0.3 s at rest before the trigger, the
sling's track ending at the release, the rest of the log the beam swinging on), 2, 5, 20
and 60 s long. Per length, timed in one run and interleaved (each repeat times every line
once, so that the load of a shared machine falls on all alike; the best of the repeats):

- ``reconstruct``: :func:`trebuchet.ingest.reconstruct.reconstruct` end to end from the
  table (smoothing and its noise search, the band calibration, the release check with the
  sling carried on by its pendulum, lift-off, every load and its sd), default preset;
- ``fast``: the same with ``preset="fast"`` (``ReconstructOptions``);
- ``filterpy``: the baseline, one plain filterpy pass: per angle a ``KalmanFilter`` of the
  same motion model (constant acceleration, white jerk, the exact discretised noise of
  each frame's own interval, ``Fs``/``Qs`` per step as for an uneven log),
  ``batch_filter`` then ``rts_smoother``, over the three angles; ``filterpy_one_F`` the
  same with one ``F`` and ``Q`` for every frame (right for this log, which drops none).

Columns: seconds and µs per row of each, their ratios to filterpy, and ``KiB_per_row``: the
peak RSS growth of one ``reconstruct`` call in a fresh process (after a warm-up on a short
log, which compiles the kernels; :func:`memory_probe`) divided by the log's rows. ``python -m bench
reconstruct_speed``; ``BENCH_REPEATS`` (default 3) repeats, ``BENCH_LENGTHS`` (default
"2,5,20,60") the lengths in s.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
FPS = 1000.0
NOISE_DEG = 0.5
REST = 0.3
RELEASE = 0.997  # s after the trigger, the paper engine's
REPEATS = int(os.environ.get("BENCH_REPEATS", "3"))
LENGTHS = tuple(float(v) for v in os.environ.get("BENCH_LENGTHS", "2,5,20,60").split(","))
#: The issue's targets: reconstruct of the 2 s log within this × filterpy, µs per row at
#: 20 s within this × that at 2 s, at most this many KiB of memory per row.
TARGET_RATIO, TARGET_GROWTH, TARGET_KIB = 0.7, 1.3, 4.0


def shot_log(seconds: float) -> pd.DataFrame:
    """The log of ``seconds`` s (module doc)."""
    from bench.ingest_accuracy import engines
    from trebuchet.ingest.synthetic.simulated_log import simulated_log

    log, _ = simulated_log(engines()["paper"], FPS, NOISE_DEG, rest=REST,
                           after_release=seconds - REST - RELEASE, seed=0)
    return log


def filterpy_pass(log: pd.DataFrame, q: float = 1e3, per_frame: bool = True) -> None:
    """The baseline: filterpy's ``batch_filter`` and ``rts_smoother`` of a constant-
    acceleration model (white jerk of density ``q`` rad²/s⁵, the measurement noise's
    variance) with each frame's own F and Q (``per_frame``; else one F and Q of the median
    frame interval, as for a log without dropped frames), over theta, psi and phi."""
    from filterpy.kalman import KalmanFilter

    from trebuchet.ingest.kalman.batch import polynomial_transition, white_noise_covariance

    t = log["t"].to_numpy(dtype=float)
    dt = np.diff(t, prepend=t[0] - np.median(np.diff(t)))
    if not per_frame:
        dt = np.full(1, np.median(np.diff(t)))
    Fs = list(polynomial_transition(3, dt)) if per_frame else None
    Qs = list(q * white_noise_covariance(3, dt)) if per_frame else None
    r2 = np.radians(NOISE_DEG) ** 2
    for angle in ("theta", "psi", "phi"):
        z = log[angle].to_numpy(dtype=float)
        ok = np.isfinite(z)
        kf = KalmanFilter(dim_x=3, dim_z=1)
        if not per_frame:
            kf.F = polynomial_transition(3, dt)[0]
            kf.Q = q * white_noise_covariance(3, dt)[0]
        kf.x = np.array([[z[ok][0]], [0.0], [0.0]])
        kf.P = np.diag([1e-2, 1.0, 1e2])
        kf.H = np.eye(1, 3)
        kf.R = np.array([[r2]])
        zs = [np.array([[v]]) if good else None for v, good in zip(z, ok, strict=True)]
        x, P, _, _ = kf.batch_filter(zs, Fs=Fs, Qs=Qs)
        kf.rts_smoother(x, P, Fs=Fs, Qs=Qs)


def _reconstruct(log: pd.DataFrame, preset: str = "default") -> pd.DataFrame:
    from bench.ingest_accuracy import engines
    from trebuchet.ingest.reconstruct import ReconstructOptions, reconstruct

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return reconstruct(log, engines()["paper"], options=ReconstructOptions(preset=preset))


def _status_kib(key: str) -> float:
    """``VmRSS`` (resident now) or ``VmHWM`` (its peak) of this process, KiB."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return float(line.split()[1])
    raise RuntimeError(f"no {key} in /proc/self/status")


def memory_probe(seconds: float) -> dict[str, float]:
    """In this (fresh) process: the peak RSS growth (KiB) of one ``reconstruct`` of the
    ``seconds`` s log, after a warm-up on a 0.7 s log at 240 fps: the resident memory's
    high-water mark (``VmHWM``, reset just before the call through ``/proc/self/clear_refs``)
    less the resident memory then. (``getrusage``'s ``ru_maxrss`` would not do: a process
    started by a large one inherits its peak.)"""
    from bench.ingest_accuracy import engines
    from trebuchet.ingest.synthetic.simulated_log import simulated_log

    small, _ = simulated_log(engines()["paper"], 240.0, NOISE_DEG, rest=REST, seed=1)
    _reconstruct(small)
    log = shot_log(seconds)
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")  # reset the high-water mark to the resident memory now
    except OSError:
        pass
    before = _status_kib("VmRSS")
    _reconstruct(log)
    return {"rows": len(log), "growth_kib": _status_kib("VmHWM") - before}


def _memory(seconds: float) -> dict[str, float]:
    code = (f"import json; from bench.reconstruct_speed import memory_probe; "
            f"print(json.dumps(memory_probe({seconds!r})))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                         text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _best_times(log: pd.DataFrame, repeats: int) -> dict[str, float]:
    """Best wall time (s) of each line over ``repeats`` interleaved repeats."""
    lines = {"reconstruct": lambda: _reconstruct(log), "fast": lambda: _reconstruct(log, "fast"),
             "filterpy": lambda: filterpy_pass(log),
             "filterpy_one_F": lambda: filterpy_pass(log, per_frame=False)}
    best = dict.fromkeys(lines, np.inf)
    for _ in range(repeats):
        for name, call in lines.items():
            t0 = time.perf_counter()
            call()
            best[name] = min(best[name], time.perf_counter() - t0)
    return best


def run(out_dir: str | Path | None = None) -> pd.DataFrame:
    """The table of the module doc."""
    _reconstruct(shot_log(2.0).iloc[:600])  # warm-up: kernels compiled or loaded
    filterpy_pass(shot_log(2.0).iloc[:100])
    rows = []
    for seconds in LENGTHS:
        log = shot_log(seconds)
        n = len(log)
        best = _best_times(log, REPEATS if seconds <= 20 else max(1, REPEATS - 1))
        mem = _memory(seconds)
        rows.append({
            "seconds_of_log": seconds, "rows": n,
            "reconstruct_s": best["reconstruct"], "fast_s": best["fast"],
            "filterpy_s": best["filterpy"],
            "reconstruct_us_per_row": 1e6 * best["reconstruct"] / n,
            "fast_us_per_row": 1e6 * best["fast"] / n,
            "filterpy_us_per_row": 1e6 * best["filterpy"] / n,
            "reconstruct_over_filterpy": best["reconstruct"] / best["filterpy"],
            "fast_over_filterpy": best["fast"] / best["filterpy"],
            "reconstruct_over_filterpy_one_F": best["reconstruct"] / best["filterpy_one_F"],
            "KiB_per_row": mem["growth_kib"] / mem["rows"],
        })
        print(f"  {seconds:g} s: {rows[-1]}", flush=True)
    table = pd.DataFrame(rows)
    table.attrs["notes"] = _notes(table)
    return table


def _notes(table: pd.DataFrame) -> list[str]:
    """The targets, met or not, and the machine."""
    by = table.set_index("seconds_of_log")
    notes = [f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
             f"load average {os.getloadavg()[0]:.1f} at the end; times are the best of "
             f"{REPEATS} interleaved repeats (60 s: {max(1, REPEATS - 1)}), ratios within one run"]
    if 2.0 in by.index:
        r = by.loc[2.0, "reconstruct_over_filterpy"]
        notes.append(f"2 s log: reconstruct {r:.2f} x filterpy (target {TARGET_RATIO}), "
                     f"preset fast {by.loc[2.0, 'fast_over_filterpy']:.2f} x; "
                     f"{by.loc[2.0, 'reconstruct_over_filterpy_one_F']:.2f} x a filterpy pass "
                     "with one F and Q for all frames (no per-frame lists)")
    if 2.0 in by.index and 20.0 in by.index:
        g = by.loc[20.0, "reconstruct_us_per_row"] / by.loc[2.0, "reconstruct_us_per_row"]
        notes.append(f"µs per row at 20 s: {g:.2f} x that at 2 s (target {TARGET_GROWTH})")
    notes.append(f"memory: at most {table['KiB_per_row'].max():.2f} KiB per row "
                 f"(target {TARGET_KIB}): peak RSS growth of one call in a fresh process / rows")
    return notes


if __name__ == "__main__":
    out = run()
    for line in out.attrs["notes"]:
        print(line)
    print(out.to_string(index=False))
