"""Accuracy and speed of ``trebuchet.ingest.smoothing.smooth.smooth`` on synthetic shots.

For frame rates 60–1000 fps and noise 0.1–2°, on the synthetic angles of
:mod:`trebuchet.ingest.synthetic.shaped_log` (rest, acceleration jump at the trigger and at the
release, 3 % dropped frames): RMS errors of angle, rate and acceleration relative to
their peaks during the shot, the fraction of moving frames whose truth lies within ±2 sd
(band coverage, ~95 % if the sd are honest), the recovered noise sd, the trigger error
in frames, and the wall time (tuning included). ``run(out_dir)`` writes
``smooth_accuracy.csv`` there and returns the table; ``python bench/smooth_accuracy.py``
prints it.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.ingest.smoothing.smooth import ANGLES, smooth
from trebuchet.ingest.synthetic.shaped_log import synthetic_log

FRAME_RATES = (60, 120, 240, 1000)
NOISE_DEG = (0.1, 0.5, 2.0)
TRIGGER = 0.3
RELEASE = 1.3


def accuracy_row(
    fps: float, noise_deg: float, seed: int = 0, model: str = "ca", **smooth_kw
) -> dict[str, float]:
    """Errors of one smoothed synthetic log (see module doc); keys are column names."""
    log, truth = synthetic_log(fps, noise_deg, drop_fraction=0.03, seed=seed,
                               trigger=TRIGGER, release=RELEASE)
    t0 = time.perf_counter()
    est = smooth(log, model=model, **smooth_kw)
    seconds = time.perf_counter() - t0
    moving = (truth["t"] > TRIGGER).to_numpy()
    row: dict[str, float] = {"fps": fps, "noise_deg": noise_deg, "seed": seed,
                             "model": model, "seconds": seconds}
    for a in ANGLES:
        for suf, label in (("", "x"), ("_d", "d"), ("_dd", "dd")):
            err = (est[a + suf] - truth[a + suf]).to_numpy()
            sd = est[a + suf + "_sd"].to_numpy()
            ok = np.isfinite(err) & moving
            peak = np.abs(truth[a + suf].to_numpy()[moving]).max()
            if suf == "":
                peak = np.ptp(truth[a].to_numpy())
            row[f"{a}_{label}_rms_rel"] = float(np.sqrt(np.mean(err[ok] ** 2)) / peak)
            row[f"{a}_{label}_cover2sd"] = float(np.mean(np.abs(err[ok]) <= 2 * sd[ok]))
        row[f"{a}_r_sd_ratio"] = est.attrs["smoothing"].noise[a]["r_sd"] / np.deg2rad(noise_deg)
    trig = est.attrs["events"]["trigger"]
    row["trigger_err_frames"] = np.nan if trig is None else (trig - TRIGGER) * fps
    rel = est.attrs["events"]["release"]
    row["release_err_frames"] = np.nan if rel is None else (rel - RELEASE) * fps
    return row


def run(out_dir: str | Path | None = None, seeds: int = 2) -> pd.DataFrame:
    """Table of :func:`accuracy_row` over frame rates, noise levels and seeds.

    Writes ``<out_dir>/smooth_accuracy.csv`` when ``out_dir`` is given.
    """
    rows = [
        accuracy_row(fps, nd, seed)
        for fps in FRAME_RATES
        for nd in NOISE_DEG
        for seed in range(seeds)
    ]
    table = pd.DataFrame(rows)
    if out_dir is not None:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        table.to_csv(out / "smooth_accuracy.csv", index=False)
    return table


def summary(table: pd.DataFrame) -> pd.DataFrame:
    """Mean over seeds and angles of the relative RMS and coverage, per fps and noise."""
    cols = {}
    for label in ("x", "d", "dd"):
        cols[f"rms_{label}_%"] = table[[f"{a}_{label}_rms_rel" for a in ANGLES]].mean(axis=1) * 100
        cols[f"cover_{label}"] = table[[f"{a}_{label}_cover2sd" for a in ANGLES]].mean(axis=1)
    cols["r_sd_ratio"] = table[[f"{a}_r_sd_ratio" for a in ANGLES]].mean(axis=1)
    df = pd.concat([table[["fps", "noise_deg", "trigger_err_frames", "seconds"]],
                    pd.DataFrame(cols)], axis=1)
    return df.groupby(["fps", "noise_deg"]).mean().round(3)


if __name__ == "__main__":
    pd.set_option("display.width", 200)
    print(summary(run()).to_string())
