"""The ``trebuchet compare`` command: a filmed shot against the model of its scene, as
``DIR/index.html`` with the paper's figures (measured ±2 sd bands, predicted lines), the
metrics and events as tables and CSV files, and the advisories; written whole or not at all.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path

import pandas as pd

from trebuchet.errors import TrebuchetInputError
from trebuchet.ingest.cli import add_log_arguments, log_options
from trebuchet.ingest.compare import (
    ALIGN_MODES,
    RELEASE_MODES,
    CompareOptions,
    compare,
    event_table,
)
from trebuchet.model.scene import Scene
from trebuchet.output import check_target
from trebuchet.report.page import write_report
from trebuchet.report.report_cli import CAPTIONS

__all__ = ["register", "compare_report", "ANGLE_MISFIT_ADVISORY"]

ANGLE_MISFIT_ADVISORY = 4.0  # sd² per row: above this the angles themselves disagree


def _stderr(message: str) -> None:
    print(f"trebuchet compare: {message}", file=sys.stderr, flush=True)


def _advisories(caught: list[warnings.WarningMessage], predicted: pd.DataFrame) -> list[str]:
    """The warnings of reconstruct and simulate (passed on to the caller too), and whether
    the model's angles fit the measured ones at all."""
    for w in caught:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    out = [str(w.message) for w in caught]
    chi2 = predicted.attrs.get("angle_chi2", math.nan)
    if chi2 > ANGLE_MISFIT_ADVISORY:
        out.append(f"the model's θ and ψ differ from the measured ones by {math.sqrt(chi2):.3g} "
                   "sd (root mean square) from trigger to release: this scene does not move "
                   "like the filmed engine (check its masses, lengths and start pose); the "
                   "load differences below follow from that")
    return out


def compare_report(log: str | Path | pd.DataFrame, scene: Scene | str | Path,
                   out_dir: str | Path, *, options: CompareOptions | None = None,
                   progress: Callable[[str], None] | None = None,
                   **reconstruct_options) -> tuple[Path, pd.DataFrame]:
    """Compare a log with ``scene`` (:func:`~trebuchet.ingest.compare.compare`) and write
    ``out_dir``: ``index.html``, ``metrics.csv`` (the contract's columns first),
    ``events.csv`` and one PNG per figure of :data:`trebuchet.report.figures.FIGURES`.
    Atomic: after an error there is no report (an older one at ``out_dir`` stays).
    Returns the report's path and the metrics."""
    scene = scene if isinstance(scene, Scene) else Scene.from_toml(scene)
    options = options or CompareOptions()
    say = progress or (lambda message: None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table, measured, predicted = compare(log, scene, options=options, progress=say,
                                             **reconstruct_options)
    advisories = _advisories(caught, predicted)
    events = event_table(measured, predicted)
    notes = " ".join(str(n).rstrip(".") + "." for n in measured.attrs.get("notes", []))
    name = Path(str(measured.attrs.get("source", log))).name
    intro = (f"Log {name} ({len(measured)} frames at {measured.attrs.get('fps', math.nan):.4g} "
             f"fps, loads reconstructed in the {measured.attrs.get('form', '?')} form) against "
             f"the model of {Path(scene.source).name}. Alignment: "
             f"{predicted.attrs['alignment']}. Release: {predicted.attrs['release_rule']}. "
             f"Times are s after the log's detected trigger; metrics in SI units (N, N m, W, "
             f"J, s); measured curves are ±{options.band_sd:g} sd bands, predicted curves "
             "lines. Quantities held by the sling (F_S, P_m, E_m) are compared from trigger "
             f"to release, the others as long as both frames go. {notes}").strip()
    from trebuchet.report.figures import FIGURES  # matplotlib loads only to draw

    figures = {key: (lambda make=make: make(predicted, measured, scene))
               for key, make in FIGURES.items()}
    out = write_report(out_dir, figures, {"metrics": table, "events": events}, advisories,
                       title=f"trebuchet compare: {name} against {Path(scene.source).name}",
                       captions=CAPTIONS, intro=intro, csv_tables=["metrics", "events"],
                       progress=say)
    return out, table


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``compare LOG --scene SCENE -o DIR [--fps N] [--column NAME=theta ...]
    [--point pivot=NAME ...] [--release auto|log|scene] [--align fit|trigger] [--quiet]``."""
    p = sub.add_parser(
        "compare", help="a filmed shot against the model: metrics, figures, HTML report",
        description="Reconstruct the loads of LOG, simulate SCENE aligned to the log and "
                    "write DIR/index.html with the figures, DIR/metrics.csv (peaks, RMS "
                    "differences, peak timing, fraction outside the measured ±2 sd band) "
                    "and DIR/events.csv. The directory is written whole or not at all.")
    add_log_arguments(p)
    p.add_argument("-o", "--output", required=True, help="report directory to write")
    p.add_argument("--release", choices=RELEASE_MODES, default="auto",
                   help="auto (default): a scene's release time is replaced by the log's "
                        "release, a velocity-angle rule is kept; log: always the log's; "
                        "scene: always the scene's rule")
    p.add_argument("--align", choices=ALIGN_MODES, default="fit",
                   help="fit (default): the model's start fitted to the measured angles; "
                        "trigger: the model starts at the log's detected trigger")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.set_defaults(run=_compare)


def _summary(table: pd.DataFrame) -> Mapping[str, float]:
    return {"worst_rms_rel": float(table["rms_difference_rel"].max()),
            "worst_outside": float(table["outside_band_fraction"].max())}


def _compare(args: argparse.Namespace) -> int:
    start = time.monotonic()
    # what can be checked before the progress lines start: the report folder, the log, the scene
    check_target(args.output, folder=True)
    if not Path(args.log).is_file():
        raise TrebuchetInputError(f"{args.log}: no such file")
    reconstruct_options = log_options(args)
    scene = Scene.from_toml(args.scene)
    options = CompareOptions(release=args.release, align=args.align)
    out, table = compare_report(args.log, scene, args.output, options=options,
                                progress=None if args.quiet else _stderr,
                                **reconstruct_options)
    s = _summary(table)
    print(f"compare {args.log} against {args.scene} -> {out / 'index.html'} "
          f"(RMS differences up to {100 * s['worst_rms_rel']:.3g} % of the measured peaks, "
          f"up to {100 * s['worst_outside']:.3g} % of the shot outside "
          f"±{options.band_sd:g} sd; "
          f"{time.monotonic() - start:.1f} s)")
    return 0
