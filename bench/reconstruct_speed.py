"""Speed and memory of ``reconstruct`` against the log's length, and against one filterpy RTS pass.

Logs of the paper's engine at 1000 fps (0.5° noise, 0.3 s at rest before the trigger, the
sling's track ending at the release, the rest of the log the beam swinging on), 2, 5, 20
and 60 s long. Per length, timed in one run and interleaved (each repeat times every line
once, so that the load of a shared machine falls on all alike; the best of the repeats):

- ``smooth``: :func:`trebuchet.ingest.reconstruct.reconstruct` end to end from the table
  with ``method="smooth"`` (smoothing and its noise search, the band calibration, the
  release check with the sling carried on by its pendulum, lift-off, every load and its sd),
  default preset;
- ``fast``: the same with ``preset="fast"`` (``ReconstructOptions``);
- ``fit``: ``reconstruct``'s default for a log of angles (issue 23): the engine fitted to the
  log, the loads of the fitted engine with the smoothed residual and their bands;
- ``filterpy``: the baseline, one plain filterpy pass: per angle a ``KalmanFilter`` of the
  same motion model (constant acceleration, white jerk, the exact discretised noise of
  each frame's own interval, ``Fs``/``Qs`` per step as for an uneven log),
  ``batch_filter`` then ``rts_smoother``, over the three angles; ``filterpy_one_F`` the
  same with one ``F`` and ``Q`` for every frame (right for this log, which drops none).

Columns: seconds and µs per row of each, their ratios to filterpy, and ``smooth_KiB_per_row``
/ ``fit_KiB_per_row``: the peak RSS growth of one ``reconstruct`` call in a fresh process
(after a warm-up on a short log, which compiles the kernels; :func:`memory_probe`) divided by
the log's rows.

Where the fit fails its residual check (issue 25: no slower than the smoother alone), the
notes give, timed in the same run: the CPU of ``reconstruct``'s default against
``method="smooth"`` on a 1.5 s log at 240 fps of the small fast engine with its bearings'
friction, reconstructed with a scene without it (the fit fails, the diagnosis fits again with
friction free, the smoother's loads are kept), interleaved in this process; and the whole
``trebuchet forces`` process on that log, the default against ``--method smooth``, each
``BENCH_PROCESS_RUNS`` (default 7) times in turn, CPU of each child from the operating system
(``os.wait4``), the median of the pairs' ratios.

``python -m bench reconstruct_speed``; ``BENCH_REPEATS`` (default 3) repeats, ``BENCH_LENGTHS``
(default "2,5,20,60") the lengths in s.
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


def _reconstruct(log: pd.DataFrame, preset: str = "default", method: str | None = "smooth"
                 ) -> pd.DataFrame:
    from bench.ingest_accuracy import engines
    from trebuchet.ingest.reconstruct import ReconstructOptions, reconstruct

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return reconstruct(log, engines()["paper"],
                           options=ReconstructOptions(preset=preset, method=method))


def _status_kib(key: str) -> float:
    """``VmRSS`` (resident now) or ``VmHWM`` (its peak) of this process, KiB."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return float(line.split()[1])
    raise RuntimeError(f"no {key} in /proc/self/status")


def memory_probe(seconds: float, method: str | None = "smooth") -> dict[str, float]:
    """In this (fresh) process: the peak RSS growth (KiB) of one ``reconstruct`` of the
    ``seconds`` s log by ``method``, after a warm-up on a 0.7 s log at 240 fps: the resident
    memory's
    high-water mark (``VmHWM``, reset just before the call through ``/proc/self/clear_refs``)
    less the resident memory then. (``getrusage``'s ``ru_maxrss`` would not do: a process
    started by a large one inherits its peak.)"""
    from bench.ingest_accuracy import engines
    from trebuchet.ingest.synthetic.simulated_log import simulated_log

    small, _ = simulated_log(engines()["paper"], 240.0, NOISE_DEG, rest=REST, seed=1)
    _reconstruct(small, method=method)
    log = shot_log(seconds)
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")  # reset the high-water mark to the resident memory now
    except OSError:
        pass
    before = _status_kib("VmRSS")
    _reconstruct(log, method=method)
    return {"rows": len(log), "growth_kib": _status_kib("VmHWM") - before}


def _memory(seconds: float, method: str | None) -> dict[str, float]:
    code = (f"import json; from bench.reconstruct_speed import memory_probe; "
            f"print(json.dumps(memory_probe({seconds!r}, {method!r})))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                         text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _best_times(log: pd.DataFrame, repeats: int) -> dict[str, float]:
    """Best wall time (s) of each line over ``repeats`` interleaved repeats."""
    lines = {"smooth": lambda: _reconstruct(log), "fast": lambda: _reconstruct(log, "fast"),
             "fit": lambda: _reconstruct(log, method=None),
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
    # Warm-up: kernels compiled or loaded. The whole shot, its release included: a log cut
    # before the release leaves the release check's kernels to the first timed call.
    warm = shot_log(2.0)
    _reconstruct(warm)
    _reconstruct(warm, method=None)
    filterpy_pass(shot_log(2.0).iloc[:100])
    rows = []
    for seconds in LENGTHS:
        log = shot_log(seconds)
        n = len(log)
        best = _best_times(log, REPEATS if seconds <= 20 else max(1, REPEATS - 1))
        row: dict[str, float] = {"seconds_of_log": seconds, "rows": n}
        for line in ("smooth", "fast", "fit", "filterpy"):
            row[f"{line}_s"] = best[line]
        for line in ("smooth", "fast", "fit", "filterpy"):
            row[f"{line}_us_per_row"] = 1e6 * best[line] / n
        for line in ("smooth", "fast", "fit"):
            row[f"{line}_over_filterpy"] = best[line] / best["filterpy"]
        row["smooth_over_filterpy_one_F"] = best["smooth"] / best["filterpy_one_F"]
        for method, name in (("smooth", "smooth"), (None, "fit")):
            mem = _memory(seconds, method)
            row[f"{name}_KiB_per_row"] = mem["growth_kib"] / mem["rows"]
        rows.append(row)
        print(f"  {seconds:g} s: {rows[-1]}", flush=True)
    table = pd.DataFrame(rows)
    table.attrs["notes"] = _notes(table, failing_fit())
    return table


def _notes(table: pd.DataFrame, failing: dict[str, float]) -> list[str]:
    """The targets, met or not, and the machine."""
    by = table.set_index("seconds_of_log")
    notes = [f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
             f"load average {os.getloadavg()[0]:.1f} at the end; times are the best of "
             f"{REPEATS} interleaved repeats (60 s: {max(1, REPEATS - 1)}), ratios within one run"]
    if 2.0 in by.index:
        notes.append(f"2 s log: smoother {by.loc[2.0, 'smooth_over_filterpy']:.2f} x filterpy "
                     f"(target {TARGET_RATIO}), preset fast {by.loc[2.0, 'fast_over_filterpy']:.2f}"
                     f" x, the default (fitted engine) {by.loc[2.0, 'fit_over_filterpy']:.2f} x; "
                     f"smoother {by.loc[2.0, 'smooth_over_filterpy_one_F']:.2f} x a filterpy pass "
                     "with one F and Q for all frames (no per-frame lists)")
    if 2.0 in by.index and 20.0 in by.index:
        g = {m: by.loc[20.0, f"{m}_us_per_row"] / by.loc[2.0, f"{m}_us_per_row"]
             for m in ("smooth", "fit")}
        notes.append(f"µs per row at 20 s over that at 2 s (target {TARGET_GROWTH}): smoother "
                     f"{g['smooth']:.2f} x, the default (fitted engine) {g['fit']:.2f} x")
    notes.append(f"memory (target {TARGET_KIB} KiB a row; peak RSS growth of one call in a "
                 f"fresh process / rows): smoother at most {table['smooth_KiB_per_row'].max():.2f}"
                 f", the default (fitted engine) at most {table['fit_KiB_per_row'].max():.2f}")
    notes.append(
        f"a fit that fails its check ({failing['rows']:.0f} rows; the smoother's loads kept "
        f"after the diagnosis' refit): reconstruct {failing['fit_cpu_s']:.3f} s CPU against "
        f"{failing['smooth_cpu_s']:.3f} s with method smooth ({failing['in_process']:.2f} x, "
        f"medians of {failing['runs']:.0f} interleaved); the whole trebuchet forces process "
        f"{failing['process']:.3f} x its --method smooth (median of {failing['pairs']:.0f} "
        f"pairs' CPU ratios, {failing['process_lo']:.2f}–{failing['process_hi']:.2f})")
    return notes


# --------------------------------------------------------------------------- a failing fit


def failing_log() -> tuple[pd.DataFrame, object]:
    """The small fast engine with its bearings' friction, 1.5 s at 240 fps, 0.5°, and the
    scene without that friction (the fit fails its check: the issue's danger)."""
    from bench.identify_accuracy import _log, engines

    scenes = engines()
    log, _ = _log(scenes["small_fast_friction"], 240, NOISE_DEG, 0, after_release=0.71)
    return log, scenes["small_fast"]


def _child_cpu(args: list[str]) -> float:
    """CPU seconds (user + system) of one child process running ``args``."""
    proc = subprocess.Popen(args, cwd=ROOT, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode:
        raise RuntimeError(f"{' '.join(args)} exited with {proc.returncode}")
    return usage.ru_utime + usage.ru_stime


def failing_fit(runs: int = 7) -> dict[str, float]:
    """The module doc's figures for a fit that fails its check."""
    import tempfile

    from trebuchet.ingest.reconstruct import reconstruct

    log, scene = failing_log()
    times: dict[str, list[float]] = {"fit": [], "smooth": []}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert reconstruct(log, scene).attrs["reconstruction"].method == "smooth"
        for _ in range(runs):
            for key, method in (("fit", None), ("smooth", "smooth")):
                t0 = time.process_time()
                reconstruct(log, scene, method=method)
                times[key].append(time.process_time() - t0)
    out = {"rows": len(log), "runs": runs, **{f"{k}_cpu_s": float(np.median(v))
                                              for k, v in times.items()}}
    out["in_process"] = out["fit_cpu_s"] / out["smooth_cpu_s"]
    pairs = int(os.environ.get("BENCH_PROCESS_RUNS", "7"))
    with tempfile.TemporaryDirectory() as tmp:
        csv, toml = Path(tmp) / "log.csv", Path(tmp) / "scene.toml"
        log[["t", "theta", "psi", "phi"]].to_csv(csv, index=False)
        sample = (ROOT / "data_samples" / "small_fast.toml").read_text()
        toml.write_text(sample[:sample.index("[friction]")])  # the scene without friction
        base = [sys.executable, "-m", "trebuchet.cli", "forces", str(csv), "--scene",
                str(toml), "--angle-unit", "rad", "--quiet", "-o", str(Path(tmp) / "o.csv")]
        _child_cpu(base)  # warm-up
        ratios = [_child_cpu(base) / _child_cpu([*base, "--method", "smooth"])
                  for _ in range(pairs)]
    out.update(pairs=pairs, process=float(np.median(ratios)), process_lo=min(ratios),
               process_hi=max(ratios))
    return out


if __name__ == "__main__":
    out = run()
    for line in out.attrs["notes"]:
        print(line)
    print(out.to_string(index=False))
