"""Ingest: smoother model, noise tuning and presets against force error, band coverage and time.

On the paper's engine at 240 fps / 0.3° and 120 fps / 1° (simulated logs, 2 % dropped
frames, two seeds), ``reconstruct`` runs with:

- the presets ``fast``, ``default``, ``precise`` (:class:`ReconstructOptions`);
- the constant-jerk smoother (``model="cj"``) instead of constant acceleration;
- at the maximum-likelihood ``q`` (``NoiseSearch.cutoff_factor = 1``): ``"cj"`` and the
  per-angle choice of the likelier model (``model="select"``,
  :mod:`~trebuchet.ingest.smoothing.model_choice`);
- the process noise ``q`` fixed at 10× and 0.1× the maximum-likelihood one of the default
  run (per angle; the measurement noise fixed at its estimate), i.e. the tuning skipped and
  off by a decade either way;
- ``fit``: ``reconstruct``'s default since issue 23, the loads of the engine fitted to the
  log (the others are the smoother's, ``method="smooth"``).

Columns: RMS error of |F_R| and torque (% of the true peak), ±2 sd coverage (% of the shot's
frames), and the wall time of ``reconstruct`` (s, best of the two seeds' runs, tuning
included). ``run(out_dir)`` writes ``ingest_trade.md``/``.csv``/``.png`` (error against
time).
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from bench.ingest_accuracy import engines, scores
from trebuchet.ingest.reconstruct import ReconstructOptions, reconstruct
from trebuchet.ingest.smoothing.noise_tuning import NoiseSearch
from trebuchet.ingest.smoothing.smooth import SmoothSettings
from trebuchet.ingest.synthetic.simulated_log import simulated_log

ROOT_RESULTS = Path(__file__).resolve().parent / "results"
CELLS = ((240, 0.3), (120, 1.0))
SEEDS = (0, 1)
SETTINGS = ("fast", "default", "precise", "cj", "cj ML q", "select ML q", "q x10", "q x0.1",
            "fit")


def _one(log: pd.DataFrame, truth: pd.DataFrame, setting: str, ml: dict) -> dict:
    scene = engines()["paper"]
    kw: dict = {"method": "smooth"}
    if setting == "fit":
        kw["method"] = "fit"
    elif setting in ("fast", "default", "precise"):
        kw["options"] = ReconstructOptions(preset=setting)
    elif setting == "cj":
        kw["options"] = ReconstructOptions(model="cj")
    elif setting.endswith("ML q"):
        kw["options"] = ReconstructOptions(
            model=setting.split()[0], smooth=SmoothSettings(noise=NoiseSearch(cutoff_factor=1.0)))
    else:
        factor = 10.0 if setting == "q x10" else 0.1
        kw["q"] = {a: factor * v["q"] for a, v in ml.items()}
        kw["r"] = {a: v["r_sd"] for a, v in ml.items()}
    t0 = time.perf_counter()
    res = reconstruct(log, scene, **kw)
    seconds = time.perf_counter() - t0
    sc = scores(res, truth)
    return {"FR_rms": sc["FR_rms"], "torque_rms": sc["torque_rms"],
            "FR_cover": sc["FR_cover"], "torque_cover": sc["torque_cover"],
            "seconds": seconds}


def run(out_dir: str | Path | None = None) -> pd.DataFrame:
    """The trade table (see the module doc); writes its files to ``out_dir``."""
    scene = engines()["paper"]
    rows = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for fps, noise in CELLS:
            for seed in SEEDS:
                log, truth = simulated_log(scene, fps, noise, seed=seed, drop_fraction=0.02)
                ml = reconstruct(log, scene, method="smooth").attrs[  # warm-up and the ML q
                    "reconstruction"].noise
                for setting in SETTINGS:
                    rows.append({"fps": fps, "noise_deg": noise, "setting": setting,
                                 "seed": seed, **_one(log, truth, setting, ml)})
    runs = pd.DataFrame(rows)
    table = (runs.groupby(["fps", "noise_deg", "setting"], sort=False)
             .agg(FR_rms=("FR_rms", "mean"), torque_rms=("torque_rms", "mean"),
                  FR_cover=("FR_cover", "mean"), torque_cover=("torque_cover", "mean"),
                  seconds=("seconds", "min"))
             .reset_index().round(3))
    table.attrs["notes"] = [
        "paper engine, simulated logs, 2 seeds; errors % of the true peak, cover % of the "
        "shot's frames inside ±2 sd, seconds: best reconstruct() wall time",
        "q x10 / q x0.1: q fixed at 10x / 0.1x the maximum-likelihood q (no tuning)",
        "cj / select ML q: the maximum-likelihood q (cutoff_factor 1); select: per angle "
        "the likelier of ca and cj (event jumps profiled out, AIC)",
    ]
    if out_dir is not None:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        table.to_csv(out / "ingest_trade.csv", index=False)
        (out / "ingest_trade.md").write_text(markdown(table))
        _plot(table, out / "ingest_trade.png")
    return table


def markdown(table: pd.DataFrame) -> str:
    """The trade table as Markdown with its notes."""
    lines = ["Ingest: smoother model, noise tuning and presets against force error, band "
             "coverage and time.", ""]
    lines += [f"- {n}" for n in table.attrs.get("notes", [])]
    cols = list(table.columns)
    lines += ["", "| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for row in table.itertuples(index=False):
        lines.append("| " + " | ".join(f"{v:.4g}" if isinstance(v, float) else str(v)
                                       for v in row) + " |")
    return "\n".join(lines) + "\n"


def _plot(table: pd.DataFrame, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(CELLS), figsize=(10, 4), squeeze=False)
    for ax, (fps, noise) in zip(axes[0], CELLS, strict=True):
        sel = table[(table.fps == fps) & (table.noise_deg == noise)]
        for _, r in sel.iterrows():
            ax.plot(r.seconds, r.FR_rms, "o")
            ax.annotate(r.setting, (r.seconds, r.FR_rms), fontsize=8,
                        xytext=(3, 3), textcoords="offset points")
        ax.set_xlabel("reconstruct wall time (s)")
        ax.set_ylabel("|F_R| RMS error (% of peak)")
        ax.set_title(f"paper engine, {fps} fps, {noise}°")
        ax.set_ylim(bottom=0.0, top=float(np.nanmax(sel.FR_rms)) * 1.2)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    print(markdown(run(ROOT_RESULTS if "--write" in sys.argv else None)))
