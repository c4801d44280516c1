"""Accuracy of ``trebuchet.reconstruct`` on tracked video of simulated shots (issue 15).

Each log is made by :func:`bench.video.shot.tracked_shot`: a simulated shot rendered at
640×480 through a pinhole camera with pose (tilt, roll) and radial distortion ``k1``,
motion blur from the shutter, lens blur (0.8 px), sensor noise (2 grey levels), the near
frame's legs and brace in front of the engine; markers tracked by masked template matching
from clicks on the first frame only (0.25 px sd); written as DeepLabCut (likelihood = match
score) or Kinovea CSV and read back by ``trebuchet.reconstruct`` with default settings.
Two engines: the paper's (``horsdal_large.toml``, a tripod 40 m away) and the backyard one
(``backyard.toml``, a phone 6.6 m away), each zoomed so that its swing fills 85 % of the
frame. The default grid changes one thing at a time from a base (no tilt, roll or
distortion, 240 fps, 1/1000 s, frame members in front, DeepLabCut, fixed template), adds a
Kinovea export with the time column of Kinovea's default time code (seconds, rounded to
the ms), and the issue's scenario (10° tilt, 0.3° roll, k1 −0.03, 120 fps, 1/250 s) with a
fixed and an adaptive template; ``--full`` runs the factorial grid of tilts 0–15°, rolls
0–1°, k1 0 to −0.08, 60–240 fps and three shutters.

Columns (mean over seeds): angle RMS errors of the read log (°); |F_R| RMS and peak error
and |F_S| RMS in phase II (% of the true peak); release and lift-off errors (frames,
detected − true); % of frames with the truth inside ±2 sd for F_R_x, F_R_y (shot), F_S_x,
F_S_y (phases 1–2); the tracker's median error (px), % of point-frames lost (likelihood
< 0.9) and % kept but > 3 px off (``wrong``); seconds to render + track and to
reconstruct; ``misses``: the issue's targets missed (FR: |F_R| RMS ≤ 3 %, peak within 5 %;
FS: |F_S| RMS ≤ 10 %; release: within 2 frames at 240 fps, 3 at 120; lift: within 2
frames; cover: every band 85–99 %).

``python -m bench video_accuracy`` (default grid, into ``bench/results``) or
``python bench/video_accuracy.py [out_dir] [--full] [--seeds 0,1] [--workers 2] [--runs
FILE]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
import time
import warnings
import zlib
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

import trebuchet as tb

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.video.camera import project  # noqa: E402
from bench.video.metrics import (  # noqa: E402
    COVERED,
    angle_errors,
    event_scores,
    shot_scores,
    tracking_scores,
)
from bench.video.render import frame_members, stone_post  # noqa: E402
from bench.video.shot import Pose, tracked_shot  # noqa: E402
from bench.video.track import TrackerSettings  # noqa: E402
from bench.video.truth import engine_points  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
#: engine -> (scene file, camera distance in m)
ENGINES = {"paper": ("horsdal_large.toml", 40.0), "backyard": ("backyard.toml", 6.6),
           "small fast": ("small_fast.toml", 5.0)}
#: The engines of the default grid (the small fast one is in bench/video_stress.py's).
DEFAULT_ENGINES = ("paper", "backyard")
SEEDS = (0, 1)
#: Trackers: a fixed template, an adaptive one (Kinovea-like: it follows motion blur and can
#: slide onto an occluder), and Kinovea's default left unedited (re-cuts its template on
#: a weak match and never lets go: behind a frame member it takes the member and sticks).
TRACKERS = {"fixed": TrackerSettings(), "adaptive": TrackerSettings(update_rate=0.3),
            "kinovea": TrackerSettings(recut_score=0.8, lost_score=0.5, recut_lost=True)}
FULL_TILTS = (0.0, 5.0, 10.0, 15.0)
FULL_ROLLS = (0.0, 0.3, 1.0)
FULL_K1 = (0.0, -0.03, -0.08)
FULL_FPS = (60.0, 120.0, 240.0)
#: shutters of the full grid: fixed exposures (s), and "open" (1/fps)
FULL_SHUTTERS = (1 / 1000, 1 / 250, None)


@dataclass(frozen=True)
class Cell:
    """One configuration of the grid (angles in °, fps in 1/s, shutter in s); ``post``: a
    post in front where the stone passes mid-swing (:func:`~bench.video.render.stone_post`)."""

    engine: str
    change: str
    tilt: float = 0.0
    roll: float = 0.0
    k1: float = 0.0
    fps: float = 240.0
    shutter: float = 1 / 1000
    occluders: bool = True
    fmt: str = "deeplabcut"
    tracker: str = "fixed"
    post: bool = False


def default_cells() -> list[Cell]:
    """The base of each engine, one change at a time from it, and the issue's scenario."""
    cells = []
    for engine in DEFAULT_ENGINES:
        base = Cell(engine, "base")
        variants = [base]
        variants += [dataclasses.replace(base, change=f"tilt {v:g}°", tilt=v) for v in (5, 10, 15)]
        variants += [dataclasses.replace(base, change=f"roll {v:g}°", roll=v) for v in (0.3, 1.0)]
        variants += [dataclasses.replace(base, change=f"k1 {v:g}", k1=v) for v in (-0.03, -0.08)]
        variants += [dataclasses.replace(base, change=f"{v:g} fps", fps=v) for v in (60, 120)]
        variants += [dataclasses.replace(base, change="shutter 1/250 s", shutter=1 / 250),
                     dataclasses.replace(base, change="shutter open", shutter=1 / 240),
                     dataclasses.replace(base, change="no frame members", occluders=False),
                     dataclasses.replace(base, change="Kinovea export", fmt="kinovea"),
                     dataclasses.replace(base, change="Kinovea export, time in s",
                                         fmt="kinovea-classic")]
        issue = dataclasses.replace(base, change="issue scenario", tilt=10.0, roll=0.3,
                                    k1=-0.03, fps=120.0, shutter=1 / 250)
        variants += [issue, dataclasses.replace(issue, change="issue scenario, adaptive",
                                                tracker="adaptive")]
        cells += variants
    return cells


def full_cells() -> list[Cell]:
    """The factorial grid of tilts, rolls, k1, frame rates and shutters, both engines."""
    cells = []
    for engine in DEFAULT_ENGINES:
        for tilt in FULL_TILTS:
            for roll in FULL_ROLLS:
                for k1 in FULL_K1:
                    for fps in FULL_FPS:
                        for shutter in FULL_SHUTTERS:
                            cells.append(Cell(engine, "grid", tilt, roll, k1, fps,
                                              shutter if shutter else 1 / fps))
    return cells


def scene_of(engine: str) -> tb.Scene:
    return tb.Scene.from_toml(ROOT / "data_samples" / ENGINES[engine][0])


def run_one(cell: Cell, seed: int, folder: str) -> dict:
    """Render, track, export, reconstruct and score one log; an exception becomes ``error``."""
    out: dict = dataclasses.asdict(cell) | {"seed": seed}
    cv2.setNumThreads(1)  # one process per core: no thread pools competing inside it
    try:
        scene = scene_of(cell.engine)
        pose = Pose(ENGINES[cell.engine][1], cell.tilt, cell.roll, cell.k1)
        members = (frame_members(scene) if cell.occluders else ()) + (
            (stone_post(scene, 0.5),) if cell.post else ())
        shot = tracked_shot(scene, pose, cell.fps, cell.shutter, members or False, seed,
                            out_dir=folder, fmt=cell.fmt, tracker=TRACKERS[cell.tracker],
                            name=f"{cell.engine}_{zlib.crc32(repr(cell).encode()):08x}_{seed}")
        truth = shot.truth
        true_px = project(shot.camera, engine_points(scene, truth))
        out |= tracking_scores(shot.positions, shot.scores, true_px, truth["phase"].to_numpy())
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            log = tb.read_log(shot.path, **shot.read)
        with warnings.catch_warnings(record=True) as said:
            warnings.simplefilter("always")
            start = time.perf_counter()
            result = tb.reconstruct(shot.path, scene, **shot.read)
            seconds = time.perf_counter() - start
        out |= angle_errors(log, truth, cell.fps) | shot_scores(result, truth, cell.fps)
        out |= event_scores(result, truth, cell.fps, [str(w.message) for w in said])
        out |= {"video_s": shot.seconds, "reconstruct_s": seconds, "error": ""}
    except Exception as exc:  # a failure is a result of the bench, not its end
        out["error"] = f"{type(exc).__name__}: {exc}"[:300]
        print(f"{cell.engine}, {cell.change}, seed {seed}: {out['error']}", file=sys.stderr)
    return out


def target_checks(row: pd.Series) -> dict[str, bool]:
    """The issue's targets for a (seed-averaged) row: met or not (release: only at 120 and 240
    fps, where the issue sets a limit)."""
    limit = {240.0: 2.0, 120.0: 3.0}.get(float(row["fps"]))
    return {
        "FR": bool(row["FR_rms"] <= 3.0 and abs(row["FR_peak"]) <= 5.0),
        "FS": bool(row["FS_rms"] <= 10.0),
        "release": limit is None or bool(abs(row["release_err_frames"]) <= limit),
        "lift": bool(abs(row["lift_off_err_frames"]) <= 2.0),
        "cover": all(85.0 <= row[f"{c}_cover"] <= 99.0 for c in COVERED),
    }


def misses(row: pd.Series) -> str:
    """The issue's targets a row misses, as short names ("-" for none)."""
    return " ".join(k for k, ok in target_checks(row).items() if not ok) or "-"


KEYS = ["engine", "change", "tilt", "roll", "k1", "fps", "shutter", "occluders", "fmt",
        "tracker"]


def summary(runs: pd.DataFrame) -> pd.DataFrame:
    """Mean over seeds of each cell (failed runs left out, counted in ``failed``)."""
    ok = runs[runs["error"] == ""]
    values = [c for c in runs.columns if c not in KEYS + ["seed", "error"]]
    table = ok.groupby(KEYS, sort=False)[values].mean().reset_index()
    failed = runs.assign(bad=runs["error"] != "").groupby(KEYS, sort=False)["bad"].sum()
    table = table.merge(failed.rename("failed").reset_index(), on=KEYS, how="right")
    table["shutter"] = [f"1/{1 / s:.0f}" for s in table["shutter"]]
    table["misses"] = [misses(r) for _, r in table.iterrows()]
    return table


def run(out_dir: Path, cells: list[Cell] | None = None, seeds: tuple[int, ...] = SEEDS,
        workers: int = 2, runs_csv: Path | None = None) -> pd.DataFrame:
    """Run the grid; write ``video_accuracy.csv`` (and every run to ``runs_csv`` if given);
    return the summary (``attrs["notes"]`` for the Markdown table)."""
    cells = default_cells() if cells is None else cells
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="video_bench_") as folder:
        jobs = [(c, s, folder) for c in cells for s in seeds]
        if workers > 1:
            with ProcessPoolExecutor(workers) as pool:
                rows = list(pool.map(run_one, *zip(*jobs, strict=True)))
        else:
            rows = [run_one(*j) for j in jobs]
    runs = pd.DataFrame(rows)
    if runs_csv is not None:
        runs.to_csv(runs_csv, index=False)
    table = summary(runs)
    table.to_csv(out_dir / "video_accuracy.csv", index=False)
    events = [c for c in table.columns if c.split("_")[-1] in ("err", "sd", "warned", "ok")]
    shown = table.drop(columns=["occluders", "fmt", "tracker", "post", *events])
    ok = table[table["misses"] == "-"]
    met = pd.DataFrame([target_checks(r) for _, r in table.iterrows()]).sum()
    notes = [
        f"{len(runs)} logs ({len(cells)} cells × {len(seeds)} seeds), "
        f"{time.perf_counter() - start:.0f} s with {workers} worker(s); "
        f"{int((runs['error'] != '').sum())} failed",
        "change: what differs from the engine's base (no tilt, roll or k1; 240 fps; "
        "1/1000 s; frame members in front; DeepLabCut; fixed template)",
        f"cells meeting every target of the issue: {len(ok)} of {len(table)}; each target: "
        + ", ".join(f"{k} {int(v)}" for k, v in met.items()),
        "times (video_s: render + track; reconstruct_s) are wall times on 2 shared cores with "
        "other jobs running: compare them within one run only",
        "reconstruct with its default settings (today's code): the engine calibrates the "
        "image itself (no camera file), the release from the tracked stone's flight and the "
        "engine's equations, systematic angle sd in the bands",
    ]
    for (engine, change), errors in runs[runs["error"] != ""].groupby(
            ["engine", "change"], sort=False)["error"]:
        notes.append(f"failed: {engine}, {change}: {errors.iloc[0]}")
    shown.attrs["notes"] = notes
    return shown


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out_dir", nargs="?", type=Path, default=ROOT / "bench" / "results")
    ap.add_argument("--full", action="store_true", help="the factorial grid (long)")
    ap.add_argument("--seeds", default=",".join(map(str, SEEDS)))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--runs", type=Path, help="also write every run (not averaged) here")
    args = ap.parse_args(argv)
    seeds = tuple(int(s) for s in args.seeds.split(","))
    args.out_dir.mkdir(parents=True, exist_ok=True)
    table = run(args.out_dir, full_cells() if args.full else None, seeds, args.workers,
                args.runs)
    for n in table.attrs["notes"]:
        print(f"- {n}")
    with pd.option_context("display.width", 250, "display.max_columns", 40):
        print(table.to_string(index=False))
    return 0


if __name__ == "__main__":
    np.seterr(all="ignore")
    sys.exit(main())
