"""Loads of the fitted engine against the smoother's, and the identification, on simulated logs.

Issue 23. Engines: the small fast backyard engine (``data_samples/small_fast.toml``: its |F_R|
peak is 23 ms wide) with its bearings' friction ("small_fast_friction", 8.7 % of ΔU lost by the
release) and without ("small_fast"), and the paper's engine ("paper"); white angle noise
0.1–1.0°, 120–480 fps; each log starts at a random phase of its frames (0.3 s at rest plus a
random fraction of a frame), so that trigger and release fall anywhere between two frames.
Each log is reconstructed twice from the same scene it was simulated from: ``method="fit"``
(the default: the engine fitted to the log, its loads where the fit passes its residual
check, else the smoother's) and ``method="smooth"``. Per method and cell, over the frames of
the shot (|F_S| while held):

- ``FR_peak_med``, ``FR_peak_p10``, ``FR_peak_p90``: |F_R|'s peak error (estimated peak /
  true peak − 1, %), median and 10th / 90th percentiles over the logs;
- ``FR_rms``: |F_R|'s RMS error, % of its true peak (median over the logs);
- ``FR_cover``: % of frames with the truth inside ±2 sd, pooled over the logs;
  ``FR_cover_peak``: % of logs whose ±2 sd band holds the truth at the true peak's frame;
- the same ``cover`` pooled for |F_H|, |F_S| and the torque (``FH_cover``, ``FS_cover``,
  ``torque_cover``);
- ``fit_used``: % of logs whose loads came from the fitted engine (the fit passed its check);
- ``peak_advised``: % of logs whose reconstruction warned that |F_R|'s or |F_H|'s peak is
  too short for the smoother (``ingest/advisory.py``, ``peak_width_advisories``);
- ``cpu_s``: median CPU seconds of one ``reconstruct`` (process time, this worker).

``identify_scenarios`` (``bench/results/identify_scenarios.csv``): the issue's identification
target (0.3°, 240 fps, the small fast engine with its friction and a counterweight 6 % heavier
than its scene, whose coefficients are half the engine's), the same log fitted with only M
free (scene with half the friction, and scene without friction: must warn), and scenes 10 %
off in M or 20 % off in I (frictionless).

``run(out_dir)`` writes ``identify_accuracy.csv`` / ``.md``, ``identify_accuracy_runs.csv``
(every log), ``identify_scenarios.csv`` and ``identify_speed.csv`` (identify on a 1.5 s log at
240 fps, CPU s; reconstruct's default against ``method="smooth"``, the smoother of today's
``forces``, in one run) and returns the summary.
"""

from __future__ import annotations

import math
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.core.errors import ModelValidityWarning
from trebuchet.ingest.identification.identify import identify
from trebuchet.ingest.reconstruct import reconstruct
from trebuchet.ingest.synthetic.simulated_log import simulated_log
from trebuchet.model.scene import Scene

ROOT = Path(__file__).resolve().parents[1]
FRAME_RATES = (120, 240, 480)
NOISE_DEG = (0.1, 0.3, 0.5, 1.0)
SEEDS = {"small_fast": 20, "small_fast_friction": 20, "paper": 8}
QUANTITIES = {"F_R_abs": "FR", "F_H_abs": "FH", "F_S_abs": "FS", "torque": "torque"}
METHODS = ("fit", "smooth")
#: The issue's load target: (engine, fps, noise) -> (peak %, RMS % of peak, cover range %).
TARGET = (("small_fast_friction", 240, 0.5), ("small_fast", 240, 0.5))


def engines() -> dict[str, Scene]:
    fast = Scene.from_toml(ROOT / "data_samples" / "small_fast.toml")
    return {"small_fast": replace(fast, engine=replace(fast.engine, friction=None)),
            "small_fast_friction": fast,
            "paper": Scene.from_toml(ROOT / "data_samples" / "horsdal_large.toml")}


def _log(scene: Scene, fps: float, noise: float, seed: int, after_release: float = 0.3):
    """A simulated log starting at a random phase of its frames."""
    phase = np.random.default_rng(10_000 + seed).uniform()
    return simulated_log(scene, fps, noise, seed=seed, rest=0.3 + phase / fps,
                         after_release=after_release)


def scores(res: pd.DataFrame, truth: pd.DataFrame) -> dict[str, float]:
    """Peak, RMS and cover of each load (module doc)."""
    out: dict[str, float] = {}
    phase = truth["phase"].to_numpy()
    moving = phase > 0
    for col, short in QUANTITIES.items():
        frames = moving & (phase <= 2) if col == "F_S_abs" else moving
        est, true = res[col].to_numpy(), truth[col].to_numpy()
        sd = res[col + "_sd"].to_numpy()
        ok = frames & np.isfinite(est) & np.isfinite(sd)
        peak = float(np.max(np.abs(true[frames])))
        k = int(np.argmax(np.where(frames, np.abs(true), -1.0)))
        out[f"{short}_peak"] = 100 * (float(np.max(np.abs(est[ok]))) / peak - 1)
        out[f"{short}_rms"] = 100 * float(np.sqrt(np.mean((est[ok] - true[ok]) ** 2))) / peak
        out[f"{short}_in"] = float(np.sum(np.abs(est[ok] - true[ok]) <= 2 * sd[ok]))
        out[f"{short}_n"] = float(ok.sum())
        out[f"{short}_peak_in"] = float(abs(est[k] - true[k]) <= 2 * sd[k])
    return out


def one_log(engine: str, fps: int, noise: float, seed: int) -> list[dict]:
    """Both methods on one log (module doc)."""
    scene = engines()[engine]
    log, truth = _log(scene, fps, noise, seed)
    rows = []
    for method in METHODS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t0 = time.process_time()
            res = reconstruct(log, scene, method=method)
            cpu = time.process_time() - t0
        done = res.attrs["reconstruction"]
        ident = done.identification
        row = {"engine": engine, "fps": fps, "noise_deg": noise, "seed": seed,
               "method": method, "fit_used": float(done.method == "fit"), "cpu_s": cpu,
               "peak_advised": float(any("wide at half height" in a.message
                                         for a in done.advisories)),
               **scores(res, truth)}
        if ident is not None:
            row |= {"lag1_max": max(ident.check.lag1.values()),
                    "chi2_max": max(ident.check.chi2.values()),
                    "M_err": 100 * (ident.value("engine.M") / scene.engine.M - 1),
                    "I_err": 100 * (ident.value("engine.I") / scene.engine.I - 1)}
        rows.append(row)
    return rows


def summary(runs: pd.DataFrame) -> pd.DataFrame:
    """Per engine, frame rate, noise and method (module doc)."""
    out = []
    for key, g in runs.groupby(["engine", "fps", "noise_deg", "method"], sort=False):
        row = dict(zip(["engine", "fps", "noise_deg", "method"], key, strict=True))
        peak = g["FR_peak"].to_numpy()
        row |= {"logs": len(g), "FR_peak_med": np.median(peak),
                "FR_peak_p10": np.percentile(peak, 10), "FR_peak_p90": np.percentile(peak, 90),
                "FR_rms": float(np.median(g["FR_rms"])),
                "FR_cover": 100 * g["FR_in"].sum() / g["FR_n"].sum(),
                "FR_cover_peak": 100 * float(g["FR_peak_in"].mean())}
        for short in ("FH", "FS", "torque"):
            row[f"{short}_cover"] = 100 * g[f"{short}_in"].sum() / g[f"{short}_n"].sum()
        row |= {"fit_used": 100 * float(g["fit_used"].mean()),
                "peak_advised": 100 * float(g["peak_advised"].mean()),
                "cpu_s": float(np.median(g["cpu_s"]))}
        out.append(row)
    return pd.DataFrame(out).round(2)


# --------------------------------------------------------------------------- identification


def _scenario_scenes() -> dict[str, tuple[Scene, Scene, list[str] | None]]:
    """name -> (truth, scene given, free keys)."""
    fast = engines()["small_fast_friction"]
    dry = engines()["small_fast"]
    heavier = replace(fast, engine=replace(fast.engine, M=106.0))
    half = replace(fast, engine=replace(fast.engine, friction=replace(
        fast.friction, pivot_mu=0.15, hinge_mu=0.15)))
    return {
        "friction, M +6 % (target)": (heavier, half, None),
        "the same, only M free, scene half the friction": (heavier, half, ["engine.M"]),
        "the same, only M free, scene without friction": (heavier, dry, ["engine.M"]),
        "frictionless, scene M 10 % light": (replace(dry, engine=replace(dry.engine, M=110.0)),
                                             dry, None),
        "frictionless, scene I 20 % light": (replace(dry, engine=replace(
            dry.engine, I=1.2 * dry.engine.I)), dry, None),
    }


def one_identification(name: str, seed: int, fps: int = 240, noise: float = 0.3) -> dict:
    truth, given, free = _scenario_scenes()[name]
    log, run = _log(truth, fps, noise, seed)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        t0 = time.process_time()
        found = identify(log, given, free)
        cpu = time.process_time() - t0
    row = {"scenario": name, "seed": seed, "passed": found.passed, "cpu_s": cpu,
           "warned": any(issubclass(w.category, ModelValidityWarning)
                         and "does not explain" in str(w.message) for w in caught)}
    values = {"engine.M": truth.engine.M, "engine.I": truth.engine.I}
    if truth.friction is not None:
        values |= {"friction.pivot_mu": truth.friction.pivot_mu,
                   "friction.hinge_mu": truth.friction.hinge_mu}
    z = []
    for key, value in values.items():
        if key in found.free:
            row[f"{key}_err"] = 100 * (found.value(key) / value - 1)
            z.append(abs(found.value(key) - value) / found.sd(key))
    row["max_z"] = max(z) if z else math.nan
    if found.loss is not None and truth.friction is not None:
        rel = run.attrs["events"]["release"]
        lost = run.loc[run["t"] <= rel, ["E_loss_pivot", "E_loss_hinge"]].sum(axis=1).max()
        row["loss_err"] = 100 * (found.loss.joules / lost - 1)
        row["loss_z"] = abs(found.loss.joules - lost) / found.loss.sd
    return row


def scenario_summary(rows: pd.DataFrame) -> pd.DataFrame:
    out = []
    for name, g in rows.groupby("scenario", sort=False):
        row = {"scenario": name, "logs": len(g), "passed_pct": 100 * g["passed"].mean(),
               "warned_pct": 100 * g["warned"].mean()}
        for col in ("engine.M_err", "engine.I_err", "loss_err"):
            if col in g and g[col].notna().any():
                v = g[col].dropna()
                row[f"{col}_med"] = float(np.median(v))
                row[f"{col}_worst"] = float(v.iloc[np.argmax(np.abs(v.to_numpy()))])
        if "engine.M_err" in g:
            row["M_within_1.5_pct"] = 100 * float((g["engine.M_err"].abs() <= 1.5).mean())
        row["within_3sd_pct"] = 100 * float((g["max_z"] <= 3).mean())
        row["cpu_s"] = float(np.median(g["cpu_s"]))
        out.append(row)
    return pd.DataFrame(out).round(2)


# --------------------------------------------------------------------------- speed


def speed(repeats: int = 5) -> pd.DataFrame:
    """identify on a 1.5 s log at 240 fps (CPU s), and reconstruct's default against
    ``method="smooth"`` on the same logs, interleaved in one run (CPU s; ratio)."""
    scenes = engines()
    fast = scenes["small_fast_friction"]
    rows = []
    for name, scene, fps, after in (("small_fast_friction", fast, 240, 0.71),
                                    ("small_fast", scenes["small_fast"], 240, 0.71),
                                    ("paper", scenes["paper"], 240, 0.4),
                                    ("paper", scenes["paper"], 1000, 0.4)):
        log, _ = _log(scene, fps, 0.5, 0, after_release=after)
        span = float(log["t"].iloc[-1] - log["t"].iloc[0])
        times = {"identify": [], "reconstruct fit": [], "reconstruct smooth": []}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            reconstruct(log, scene)  # warm
            for _ in range(repeats):
                for key, call, method in (("identify", identify, None),
                                          ("reconstruct fit", reconstruct, None),
                                          ("reconstruct smooth", reconstruct, "smooth")):
                    extra = {} if method is None else {"method": method}
                    t0 = time.process_time()
                    call(log, scene, **extra)
                    times[key].append(time.process_time() - t0)
        med = {k: float(np.median(v)) for k, v in times.items()}
        rows.append({"engine": name, "fps": fps, "log_s": round(span, 2), "frames": len(log),
                     "identify_cpu_s": med["identify"], "fit_cpu_s": med["reconstruct fit"],
                     "smooth_cpu_s": med["reconstruct smooth"],
                     "fit_over_smooth": med["reconstruct fit"] / med["reconstruct smooth"]})
    return pd.DataFrame(rows).round(3)


def run(out_dir: str | Path | None = None, workers: int = 2) -> pd.DataFrame:
    """The summary table (module doc); writes the CSVs and Markdown to ``out_dir``."""
    cells = [(e, f, n, s) for e, seeds in SEEDS.items() for f in FRAME_RATES for n in NOISE_DEG
             for s in range(seeds)]
    scenario_cells = [(name, s) for name in _scenario_scenes() for s in range(30)]
    t0 = time.perf_counter()
    speeds = speed()  # first: the pool would keep both cores busy
    with ProcessPoolExecutor(workers) as pool:
        parts = list(pool.map(one_log, *zip(*cells, strict=True), chunksize=4))
        ident = list(pool.map(one_identification, *zip(*scenario_cells, strict=True),
                              chunksize=4))
    runs = pd.DataFrame([r for p in parts for r in p])
    table = summary(runs)
    scen = scenario_summary(pd.DataFrame(ident))
    notes = [f"{len(cells)} simulated logs, both methods, and {len(scenario_cells)} "
             f"identifications, {time.perf_counter() - t0:.0f} s with {workers} workers",
             "peaks, RMS in % of the true peak; cover: % of the shot's frames with the truth "
             "inside ±2 sd, pooled; cover_peak: % of logs holding the truth at its peak"]
    for engine, fps, noise in TARGET:
        for method in METHODS:
            r = table[(table.engine == engine) & (table.fps == fps) & (table.noise_deg == noise)
                      & (table.method == method)]
            if len(r):
                r = r.iloc[0]
                notes.append(f"target {engine} {fps} fps {noise}°, {method}: |F_R| peak "
                             f"{r.FR_peak_med:+.1f} % "
                             f"({r.FR_peak_p10:+.1f}..{r.FR_peak_p90:+.1f}), "
                             f"RMS {r.FR_rms:.2f} %, cover {r.FR_cover:.1f} % pooled, "
                             f"{r.FR_cover_peak:.0f} % at the peak (limits 3 %, 1.5 %, 85–99 %)")
    for r in speeds.itertuples(index=False):
        notes.append(f"speed {r.engine} {r.fps} fps, {r.log_s} s log: identify "
                     f"{r.identify_cpu_s:.2f} s CPU; reconstruct fit {r.fit_cpu_s:.2f} s against "
                     f"smooth {r.smooth_cpu_s:.2f} s ({r.fit_over_smooth:.2f} ×)")
    for r in scen.to_dict("records"):
        notes.append("identification: " + ", ".join(
            f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in r.items()))
    table.attrs["notes"] = notes
    if out_dir is not None:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        runs.to_csv(out / "identify_accuracy_runs.csv", index=False)
        pd.DataFrame(ident).to_csv(out / "identify_scenarios_runs.csv", index=False)
        scen.to_csv(out / "identify_scenarios.csv", index=False)
        speeds.to_csv(out / "identify_speed.csv", index=False)
        write_tables(out, scen, speeds)
        table.to_csv(out / "identify_accuracy.csv", index=False)
    return table


def write_tables(out: Path, scenarios: pd.DataFrame, speeds: pd.DataFrame) -> None:
    """``identify_scenarios.md`` and ``identify_speed.md`` (docs/benchmarks.md's blocks)."""
    from bench.__main__ import markdown

    (out / "identify_scenarios.md").write_text(markdown(
        scenarios, "Identification on the small fast engine, 0.3° at 240 fps, 30 logs a row "
        "(bench identify_accuracy).", ["errors in % of the truth (median, and the worst log); "
                                       "within_3sd: % of logs whose every fitted key lies "
                                       "within 3 sd of the truth; warned: % of logs warned "
                                       "that the fit does not explain the shot"]),
        encoding="utf-8")
    (out / "identify_speed.md").write_text(markdown(
        speeds, "CPU seconds of identify and of reconstruct's two methods on the same logs, "
        "interleaved in one run (bench identify_accuracy).",
        ["median of 5 runs each; fit_over_smooth: reconstruct's default over "
         "method='smooth' (the smoother of today's forces)"]), encoding="utf-8")


if __name__ == "__main__":
    import sys

    result = run(sys.argv[1] if len(sys.argv) > 1 else None)
    print("\n".join(result.attrs["notes"]))
    print(result.to_string(index=False))
