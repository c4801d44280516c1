"""Release found where the sling's track goes on past it: jump search against equations.

The jump search alone against the default check with the engine's equations
(``trebuchet.ingest.events.release_model``), through ``reconstruct``.

Two engines (the paper's and the small one of ``ingest_accuracy``), two kinds of sling
track after the release (``pendulum``: the empty sling swinging on the spigot; ``stone``:
a tracker following the stone, the direction spigot -> stone), frame rates 60–1000 fps,
angle noise 0.1–2°, two seeds, 2 % dropped frames
(:func:`trebuchet.ingest.synthetic.simulated_log.continued_sling_log`). Per cell (mean of the seeds'
absolute values):

- ``jump_err`` / ``err``: release error in frames, the jump search alone
  (``ReconstructOptions(release_model=None)``) / the default (NaN where none was found;
  ``jump_none``: logs without a release);
- ``err_sd``: the default's error in units of its reported sd (mean |z|);
- ``jump_FS`` / ``FS``: error of the peak sling tension |F_S|, % of the true peak;
- ``seconds``: wall time of the smoother's ``reconstruct`` with the check;
- ``fit_err``, ``fit_FS``, ``fit_used``: the same for ``reconstruct``'s default since issue 23
  (the loads and events of the engine fitted to the log where the fit passes its residual
  check; with the sling's track going on, the release is the scene's rule on the fitted
  engine), and the % of logs whose loads came from the fit. The two columns before are the
  smoother's (``method="smooth"``), whose release these cells measure.

``run(out_dir)`` writes ``release_accuracy_runs.csv`` (every log) and returns the table
(``python -m bench release_accuracy`` writes ``release_accuracy.md``/``.csv``).
"""

from __future__ import annotations

import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd

from bench.ingest_accuracy import best_reconstruct_time, engines
from trebuchet.ingest.reconstruct import ReconstructOptions, reconstruct
from trebuchet.ingest.synthetic.simulated_log import continued_sling_log

KINDS = ("pendulum", "stone")
FRAME_RATES = (60, 120, 240, 1000)
NOISE_DEG = (0.1, 0.5, 2.0)
SEEDS = (0, 1)


def one_log(engine: str, kind: str, fps: int, noise: float, seed: int) -> dict:
    """Both runs on one simulated log whose sling track goes on past the release."""
    scene = engines()[engine]
    log, truth = continued_sling_log(scene, fps, noise, kind, seed=seed, drop_fraction=0.02)
    true_release = truth.attrs["events"]["release"]
    peak = float(truth["F_S_abs"].max())
    row: dict = {"engine": engine, "kind": kind, "fps": fps, "noise_deg": noise, "seed": seed}
    for label, options in (("jump_", ReconstructOptions(release_model=None, method="smooth")),
                           ("", ReconstructOptions(method="smooth")),
                           ("fit_", ReconstructOptions())):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t0 = time.perf_counter()
            res = reconstruct(log, scene, options=options)
            seconds = time.perf_counter() - t0
        found = res.attrs["events"]["release"]
        err = np.nan if found is None else (found - true_release) * fps
        row[label + "err"] = err
        row[label + "FS"] = 100.0 * (float(res["F_S_abs"].max()) / peak - 1.0)
        if label == "fit_":
            row["fit_used"] = float(res.attrs["reconstruction"].method == "fit")
        if label == "":
            sd = res.attrs["reconstruction"].event_sd["release"] * fps
            row["z"] = err / sd if sd > 0 else np.nan
            row["seconds"] = seconds
            row["source"] = res.attrs["reconstruction"].event_sources["release"]
    return row


def speed_2s_1000fps(repeats: int = 5) -> float:
    """Best wall time (s) of ``reconstruct`` on a 2 s log at 1000 fps of the paper's engine
    whose sling track goes on past the release (the check and its second smoothing)."""
    scene = engines()["paper"]
    release = 0.997  # the paper engine's, s after the trigger
    log, _ = continued_sling_log(scene, 1000, 0.5, "pendulum", seed=0, rest=0.3,
                                 after_release=2.0 - 0.3 - release)
    return best_reconstruct_time(log, scene, repeats)


def run(out_dir: str | Path | None = None, workers: int = 2) -> pd.DataFrame:
    """The per-cell table (see the module doc); the runs go to ``out_dir``."""
    cells = [(e, k, f, n, s) for e in engines() for k in KINDS for f in FRAME_RATES
             for n in NOISE_DEG for s in SEEDS]
    speed = speed_2s_1000fps()
    t0 = time.perf_counter()
    with ProcessPoolExecutor(workers) as pool:
        runs = pd.DataFrame(list(pool.map(one_log, *zip(*cells, strict=True))))
    elapsed = time.perf_counter() - t0
    if out_dir is not None:
        Path(out_dir).mkdir(parents=True, exist_ok=True)
        runs.to_csv(Path(out_dir) / "release_accuracy_runs.csv", index=False)
    keys = ["engine", "kind", "fps", "noise_deg"]
    absolute = runs.assign(**{c: runs[c].abs() for c in ("jump_err", "err", "z", "jump_FS",
                                                         "FS", "fit_err", "fit_FS")})
    table = absolute.groupby(keys, sort=False).agg(
        jump_none=("jump_err", lambda v: int(v.isna().sum())), jump_err=("jump_err", "mean"),
        err=("err", "mean"), err_sd=("z", "mean"), jump_FS=("jump_FS", "mean"),
        FS=("FS", "mean"), seconds=("seconds", "mean"), fit_err=("fit_err", "mean"),
        fit_FS=("fit_FS", "mean"), fit_used=("fit_used", "mean")).reset_index().round(2)
    table["fit_used"] = (100 * table["fit_used"]).round(0)
    err, jump = runs["err"].abs(), runs["jump_err"].abs()
    table.attrs["notes"] = [
        f"{len(runs)} simulated logs ({len(SEEDS)} seeds per cell), {elapsed:.0f} s with "
        f"{workers} workers",
        f"jump search alone: no release on {int(jump.isna().sum())} logs; on the others "
        f"|error| median {jump.median():.2f}, 90 % {jump.quantile(0.9):.1f}, worst "
        f"{jump.max():.0f} frames; peak |F_S| error median {runs['jump_FS'].abs().median():.1f} "
        f"%, 90 % {runs['jump_FS'].abs().quantile(0.9):.0f} %",
        f"with the engine's equations (default): no release on {int(err.isna().sum())} logs; "
        f"|error| median {err.median():.2f}, 90 % {err.quantile(0.9):.1f}, worst "
        f"{err.max():.0f} frames; truth within ±2 sd on "
        f"{100 * np.mean(runs['z'].abs() <= 2):.0f} % of logs; peak |F_S| error median "
        f"{runs['FS'].abs().median():.1f} %, 90 % {runs['FS'].abs().quantile(0.9):.0f} %",
        f"2 s log at 1000 fps whose sling track goes on, reconstruct() end to end: "
        f"{speed:.2f} s (target 0.5 s)",
        f"reconstruct's default (issue 23): loads of the fitted engine on "
        f"{100 * runs['fit_used'].mean():.0f} % of logs; |release error| median "
        f"{runs['fit_err'].abs().median():.2f}, 90 % {runs['fit_err'].abs().quantile(0.9):.1f} "
        f"frames; peak |F_S| error median {runs['fit_FS'].abs().median():.1f} %, 90 % "
        f"{runs['fit_FS'].abs().quantile(0.9):.0f} %",
    ]
    return table
