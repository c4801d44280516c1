"""Accuracy, band coverage and speed of ``trebuchet.ingest.reconstruct`` on simulated logs.

Two engines (the paper's, and a small one with L3 = 0.5 m whose accelerations swing fast),
frame rates 60–1000 fps, angle noise 0.1–2° (and the 0.3° of the issue's target), and the
small fast engine of issue 23 (``data_samples/small_fast.toml``) with and without its
bearings' friction at 120–480 fps and 0.1–1.0°, six seeds per cell, 2 % dropped frames, 0.3
s at rest before the trigger, the sling's track ending at the release. The truth is the
simulation at the same frame times (:mod:`trebuchet.ingest.synthetic.simulated_log`). Both
force forms (projected, direct) run on the same smoothed angles. Per run and form, over the
frames of the shot (after the trigger; for |F_S| only up to the release, while the sling
holds the projectile: after it load and truth are both exactly 0 and would count as covered
by any band):

- ``<Q>_rms``: RMS error of |F_R|, |F_H|, |F_S| and the torque, % of the true peak;
- ``<Q>_peak``: error of the peak value, % of the true peak;
- ``<Q>_cover``: % of frames whose truth lies within the ±2 sd band;
- event errors in frames (trigger, lift-off, release);
- ``seconds``: wall time of the whole reconstruction (smoothing and noise tuning
  included) with the default form.

``run(out_dir)`` writes ``ingest_accuracy_runs.csv`` (every run) and
``ingest_accuracy.csv`` / ``ingest_accuracy.md`` (mean over seeds) and returns the summary;
``python bench/ingest_accuracy.py [out_dir] [--model M] [--ml-q] [--seeds 6-11]`` prints
it; ``--model`` runs the smoother's model ``M`` ("ca" default, "cj", "select", "average"),
``--ml-q`` its maximum-likelihood ``q`` (``NoiseSearch.cutoff_factor = 1``) instead of the
default's, ``--seeds`` another seed set (``6-11`` or ``6,7,8``: a check that a change is
not tuned to the default seeds' noise).
"""

from __future__ import annotations

import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.ingest.reconstruct import (
    ReconstructOptions,
    loads_from_smoothed,
    reconstruct,
    sling_track_end,
)
from trebuchet.ingest.smoothing.noise_tuning import NoiseSearch
from trebuchet.ingest.smoothing.smooth import SmoothSettings, smooth
from trebuchet.ingest.synthetic.simulated_log import SMALL_ENGINE, simulated_log
from trebuchet.model.scene import Scene

ROOT = Path(__file__).resolve().parents[1]
FRAME_RATES = (60, 120, 240, 1000)
NOISE_DEG = (0.1, 0.3, 0.5, 1.0, 2.0)
#: Six seeds per cell: a cell's coverage is a statistic of a few hundred strongly correlated
#: frames (at 60 fps one frame of one seed is 0.65 % of two seeds' frames), so with two
#: seeds a cell at 99.35 % was one missed frame from inside.
SEEDS = (0, 1, 2, 3, 4, 5)
QUANTITIES = {"F_R_abs": "FR", "F_H_abs": "FH", "F_S_abs": "FS", "torque": "torque"}
#: Loads scored only while the sling holds the projectile (phases 1–2): after the release
#: |F_S| and its truth are both exactly 0, frames that would count as inside any band.
HELD_ONLY = ("F_S_abs",)
#: The issue's band target: ±2 sd coverage (%) inside this range in every cell and load.
COVER_RANGE = (85.0, 99.0)
#: Targets of the issue on the paper's engine: (fps, noise °) -> max RMS and peak error, %.
TARGETS = {(240, 0.3): 5.0, (120, 0.5): 8.0, (60, 1.0): 8.0}


def engines() -> dict[str, Scene]:
    return {"paper": Scene.from_toml(ROOT / "data_samples" / "horsdal_large.toml"),
            "small": Scene.from_dict(SMALL_ENGINE, source="small")}


def small_fast_engines() -> dict[str, Scene]:
    """The small fast backyard engine of issue 23 (``data_samples/small_fast.toml``: its |F_R|
    peak is 23 ms wide, the worst case found) without and with its bearings' friction."""
    fast = Scene.from_toml(ROOT / "data_samples" / "small_fast.toml")
    return {"small_fast": replace(fast, engine=replace(fast.engine, friction=None)),
            "small_fast_friction": fast}


#: The small fast engines' grid (issue 23: noise 0.1–1.0°, 120–480 fps); their rows are the
#: smoother's (``loads_from_smoothed``), the fitted engine's are ``bench/identify_accuracy.py``'s.
SMALL_FAST_GRID = ((120, 240, 480), (0.1, 0.3, 0.5, 1.0))


def scores(res: pd.DataFrame, truth: pd.DataFrame) -> dict[str, float]:
    """Errors (% of the true peak) and ±2 sd coverage (%) over the shot's frames (for
    ``HELD_ONLY`` loads over the frames before the release)."""
    out: dict[str, float] = {}
    phase = truth["phase"].to_numpy()
    moving = phase > 0
    held = moving & (phase <= 2)
    for col, short in QUANTITIES.items():
        est, true = res[col].to_numpy(), truth[col].to_numpy()
        sd = res[col + "_sd"].to_numpy()
        frames = held if col in HELD_ONLY else moving
        ok = frames & np.isfinite(est) & np.isfinite(true)
        peak = np.max(np.abs(true[frames]))
        err = est[ok] - true[ok]
        out[f"{short}_rms"] = 100 * float(np.sqrt(np.mean(err**2)) / peak)
        out[f"{short}_peak"] = 100 * float(abs(np.max(np.abs(est[ok])) - peak) / peak)
        out[f"{short}_cover"] = 100 * float(np.mean(np.abs(err) <= 2 * sd[ok]))
    out["valid_frames"] = 100 * float(np.mean(np.isfinite(res["F_R_abs"].to_numpy()[moving])))
    return out


def smoother_options(model: str = "ca", ml_q: bool = False) -> ReconstructOptions:
    """Reconstruct options of a bench variant: the smoother's ``model`` and, with ``ml_q``,
    its maximum-likelihood process noise (``cutoff_factor = 1``); else the defaults; the
    smoother's loads (``method="smooth"``: this bench measures the smoother)."""
    st = SmoothSettings(noise=NoiseSearch(cutoff_factor=1.0)) if ml_q else None
    return ReconstructOptions(model=model, smooth=st, method="smooth")


def one_run(engine: str, fps: int, noise: float, seed: int, model: str = "ca",
            ml_q: bool = False) -> list[dict]:
    """Both forms on one simulated log; the time is the default pipeline's (or that of
    :func:`smoother_options` ``(model, ml_q)``)."""
    opts = smoother_options(model, ml_q)
    scene = (engines() | small_fast_engines())[engine]
    log, truth = simulated_log(scene, fps, noise, seed=seed, drop_fraction=0.02)
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t0 = time.perf_counter()
        end = sling_track_end(log)  # as reconstruct() does
        est = smooth(log, model=opts.model, events=None if end is None else {"release": end[0]},
                     settings=opts.smooth)
        smoothed = time.perf_counter() - t0
        for form in ("projected", "direct"):
            t1 = time.perf_counter()
            res = loads_from_smoothed(est, scene, options=ReconstructOptions(form=form),
                                      release_sd=None if end is None else end[1])
            seconds = smoothed + time.perf_counter() - t1
            true_ev, ev = truth.attrs["events"], res.attrs["events"]
            row = {"engine": engine, "fps": fps, "noise_deg": noise, "seed": seed,
                   "form": form, **scores(res, truth), "seconds": seconds}
            for key in ("trigger", "lift_off", "release"):
                found = ev.get(key)
                row[f"{key}_err_frames"] = (np.nan if found is None or key not in true_ev
                                            else (found - true_ev[key]) * fps)
            row["advisories"] = len(res.attrs["reconstruction"].advisories)
            rows.append(row)
    return rows


def speed_2s_1000fps(repeats: int = 7, options: ReconstructOptions | None = None) -> float:
    """Best wall time (s) of ``reconstruct`` (read from a table, smoothing, tuning, both
    event searches, loads and their sd) on a 2 s log at 1000 fps of the paper's engine."""
    scene = engines()["paper"]
    rest = 0.3
    log, _ = simulated_log(scene, 1000, 0.5, rest=rest, after_release=2.0 - rest - 0.997,
                           seed=0)
    return best_reconstruct_time(log, scene, repeats, options)


def best_reconstruct_time(log: pd.DataFrame, scene: Scene, repeats: int = 7,
                          options: ReconstructOptions | None = None) -> float:
    """Best wall time (s) of ``repeats`` calls of ``reconstruct(log, scene)``."""
    best = np.inf
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for _ in range(repeats):
            t0 = time.perf_counter()
            reconstruct(log, scene, options=options)
            best = min(best, time.perf_counter() - t0)
    return float(best)


def coverage_cells(table: pd.DataFrame, form: str = "projected") -> dict[str, int]:
    """Cells × loads of ``form`` in ``table`` (the summary) whose coverage lies inside
    :data:`COVER_RANGE`, below it (bands too narrow) and above it (too wide)."""
    cover = table.loc[table["form"] == form, [f"{q}_cover" for q in QUANTITIES.values()]]
    values = cover.to_numpy().ravel()
    lo, hi = COVER_RANGE
    return {"inside": int(np.sum((values >= lo) & (values <= hi))),
            "too narrow": int(np.sum(values < lo)), "too wide": int(np.sum(values > hi))}


def summary(runs: pd.DataFrame) -> pd.DataFrame:
    """Mean over seeds per engine, frame rate, noise and form (rounded)."""
    keys = ["engine", "fps", "noise_deg", "form"]
    cols = [c for c in runs.columns if c not in keys and c != "seed"]
    table = runs.groupby(keys, sort=False)[cols].mean().reset_index()
    return table.round(2)


def run(out_dir: str | Path | None = None, workers: int = 2, model: str = "ca",
        ml_q: bool = False, seeds: tuple[int, ...] = SEEDS) -> pd.DataFrame:
    """The summary table (see the module doc); writes the CSVs and Markdown to ``out_dir``.
    ``model``, ``ml_q``: the smoother variant (:func:`smoother_options`); ``seeds``: the
    seeds of every cell."""
    cells = [(e, f, n, s, model, ml_q) for e in engines() for f in FRAME_RATES
             for n in NOISE_DEG for s in seeds]
    cells += [(e, f, n, s, model, ml_q) for e in small_fast_engines()
              for f in SMALL_FAST_GRID[0] for n in SMALL_FAST_GRID[1] for s in seeds]
    # timed first: right after the pool has kept both cores busy it read 0.1-0.2 s slower
    speed = speed_2s_1000fps(options=smoother_options(model, ml_q))
    speed_default = speed_2s_1000fps()  # reconstruct's default: the fitted engine's loads
    t0 = time.perf_counter()
    if workers > 1:
        with ProcessPoolExecutor(workers) as pool:
            parts = list(pool.map(one_run, *zip(*cells, strict=True)))
    else:
        parts = [one_run(*c) for c in cells]
    runs = pd.DataFrame([r for p in parts for r in p])
    table = summary(runs)
    seed_note = "" if tuple(seeds) == SEEDS else f", seeds {', '.join(map(str, seeds))}"
    notes = [f"{len(cells)} simulated logs ({len(seeds)} seeds per cell{seed_note}), "
             f"{time.perf_counter() - t0:.0f} s with {workers} worker(s)",
             f"2 s log at 1000 fps, three angles, reconstruct() end to end: {speed:.2f} s with "
             f"the smoother (method smooth), {speed_default:.2f} s by default (the fitted "
             "engine's loads, issue 23)",
             "errors and peaks in % of the true peak; cover: % of shot frames with the "
             "truth inside ±2 sd; seconds: smoothing + tuning + loads of one form",
             "|F_S| (FS_*) is scored only while the sling holds the projectile (phases 1–2); "
             "until this note it also counted the frames after the release, where load and "
             "truth are both 0 (23–29 % of the shot's frames, all counted inside the band)"]
    if model != "ca" or ml_q:
        notes.insert(0, f"smoother variant: model {model!r}"
                     + (", maximum-likelihood q (cutoff_factor 1)" if ml_q else ""))
    counts = coverage_cells(table[table["engine"].isin(list(engines()))])
    notes.append(f"projected form, cells × loads with coverage in {COVER_RANGE[0]:g}–"
                 f"{COVER_RANGE[1]:g} %: {counts['inside']} of {sum(counts.values())} "
                 f"({counts['too narrow']} too narrow, {counts['too wide']} too wide)")
    fast = coverage_cells(table[~table["engine"].isin(list(engines()))])
    notes.append(f"the small fast engines (issue 23; the smoother), cells × loads with coverage "
                 f"in range: {fast['inside']} of {sum(fast.values())} ({fast['too narrow']} too "
                 f"narrow, {fast['too wide']} too wide); the fitted engine's loads on them: "
                 "bench identify_accuracy")
    for (fps, noise), limit in TARGETS.items():
        sel = table[(table.engine == "paper") & (table.fps == fps)
                    & (table.noise_deg == noise) & (table.form == "projected")]
        if len(sel):
            r = sel.iloc[0]
            notes.append(f"target paper {fps} fps {noise}°: |F_R| RMS {r.FR_rms:.1f} %, peak "
                         f"{r.FR_peak:.1f} % (limit {limit:g} %)")
    table.attrs["notes"] = notes
    if out_dir is not None:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        runs.to_csv(out / "ingest_accuracy_runs.csv", index=False)
        table.to_csv(out / "ingest_accuracy.csv", index=False)
        (out / "ingest_accuracy.md").write_text(markdown(table))
    return table


def markdown(table: pd.DataFrame) -> str:
    """The summary as a Markdown table with its notes."""
    lines = ["ingest_accuracy: reconstruct() on simulated logs", ""]
    lines += [f"- {n}" for n in table.attrs.get("notes", [])]
    cols = [c for c in table.columns]
    lines += ["", "| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for row in table.itertuples(index=False):
        lines.append("| " + " | ".join(f"{v:.3g}" if isinstance(v, float) else str(v)
                                       for v in row) + " |")
    return "\n".join(lines) + "\n"


def seed_list(text: str) -> tuple[int, ...]:
    """``"6-11"`` or ``"6,7,8"`` as a tuple of seeds."""
    if "-" in text:
        lo, hi = text.split("-")
        return tuple(range(int(lo), int(hi) + 1))
    return tuple(int(v) for v in text.split(","))


if __name__ == "__main__":
    args = sys.argv[1:]
    if "-h" in args or "--help" in args:
        print(__doc__)
        sys.exit(0)
    variant: dict = {"model": "ca", "ml_q": False}
    if "--seeds" in args:
        i = args.index("--seeds")
        variant["seeds"] = seed_list(args[i + 1])
        del args[i:i + 2]
    if "--ml-q" in args:
        args.remove("--ml-q")
        variant["ml_q"] = True
    if "--model" in args:
        i = args.index("--model")
        variant["model"] = args[i + 1]
        del args[i:i + 2]
    result = run(args[0] if args else None, **variant)
    print(markdown(result))
