"""The ``trebuchet compare`` command: a filmed shot against the model of its scene, as
``DIR/index.html`` with the paper's figures (measured ±2 sd bands, predicted lines), the
metrics and events as tables and CSV files, and the advisories; written whole or not at all.

Light to import (docs/architecture.md, "Adding a sub-command"): the comparison, the model and
the figures load when the command runs or :func:`compare_report` is called.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from trebuchet.core.errors import TrebuchetInputError, cli_command, warn_at_caller
from trebuchet.ingest.cli import add_reconstruct_arguments, reconstruct_options
from trebuchet.ingest.settings import ALIGN_MODES, CHANCE_RUNS, RELEASE_MODES
from trebuchet.report.report_cli import CAPTIONS

if TYPE_CHECKING:
    import pandas as pd

    from trebuchet.ingest.compare import CompareOptions
    from trebuchet.model.scene import Scene

__all__ = ["register", "compare_report", "fitted_html", "ANGLE_MISFIT_ADVISORY"]

ANGLE_MISFIT_ADVISORY = 4.0  # sd² per row: above this the angles themselves disagree


def _stderr(message: str) -> None:
    print(f"trebuchet compare: {message}", file=sys.stderr, flush=True)


def _advisories(caught: list[warnings.WarningMessage], predicted: pd.DataFrame) -> list[str]:
    """The warnings of reconstruct and simulate (passed on to the caller too, at the
    caller's line), and whether the model's angles fit the measured ones at all."""
    for w in caught:
        warn_at_caller(w.message, w.category)
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
                   progress: Callable[[str], None] | None = None, fit: bool | None = None,
                   **reconstruct_options) -> tuple[Path, pd.DataFrame]:
    """Compare a log with ``scene`` (:func:`~trebuchet.ingest.compare.compare`) and write
    ``out_dir``: ``index.html`` (the verdict and a short table first, then the figures, then
    every metric and the events under "Details"), ``metrics.csv`` (the contract's columns
    first, SI), ``events.csv`` and one PNG per figure of
    :data:`trebuchet.report.figures.FIGURES`. Atomic: after an error there is no report (an
    older one at ``out_dir`` stays). Returns the report's path and the metrics. ``fit``: the
    scene as fitted to the shot beside the scene as given (:mod:`.fitted_compare`): True
    always, False never, None (default) where the given scene differs; its sentence leads,
    ``fitted_metrics.csv`` and ``fitted_keys.csv`` join the files and ``metrics.attrs``
    holds it as ``"fitted"``."""
    from trebuchet.ingest.compare import CompareOptions, compare, event_table
    from trebuchet.ingest.logs.result import read_log_info
    from trebuchet.ingest.reconstruction import reconstruction_of
    from trebuchet.model.scene import Scene
    from trebuchet.report.page import write_report
    from trebuchet.report.verdict import details_table, events_table, verdict_html

    scene = scene if isinstance(scene, Scene) else Scene.from_toml(scene)
    options = options or CompareOptions()
    say = progress or (lambda message: None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table, measured, predicted = compare(log, scene, options=options, progress=say,
                                             **reconstruct_options)
    advisories = _advisories(caught, predicted)
    fitted = _fitted(measured, table, scene, options, log, reconstruct_options, fit, say)
    events = event_table(measured, predicted)
    done = reconstruction_of(measured)
    notes = " ".join(str(n).rstrip(".") + "." for n in done.notes)
    info = read_log_info(measured)
    name = Path(info.source).name if info is not None else "(a table given in Python)"
    lag_ms = 1e3 * float(predicted.attrs.get("lag", 0.0))
    intro = (f"How this was compared: log {name} ({len(measured)} frames at "
             f"{done.fps:.4g} fps, loads reconstructed in the "
             f"{done.form} form) against the model of "
             f"{Path(scene.source).name}. Every time on this page is in ms after the log's "
             f"detected trigger; the model starts {lag_ms:+.1f} ms from it. Alignment: "
             f"{predicted.attrs['alignment']}. Release: {predicted.attrs['release_rule']}. "
             f"Measured curves are ±{options.band_sd:g} sd bands, predicted curves lines. "
             "Quantities held by the sling (F_S, P_m, E_m) are compared from trigger to "
             f"release, the others as long as both go on. {notes}").strip()
    release = [m for e, m in zip(events["event"], events["measured"], strict=True)
               if e == "release" and math.isfinite(m)]
    lead = verdict_html(table, scene, release_ms=1e3 * release[0] if release else None,
                        level=options.chance_level)
    details, files = {}, {"metrics.csv": table, "events.csv": events}
    if fitted is not None:
        lead = fitted_html(fitted) + lead
        details["The scene as given and as fitted to the shot"] = fitted.keys
        files |= {"fitted_metrics.csv": fitted.metrics, "fitted_keys.csv": fitted.keys}
        table.attrs["fitted"] = fitted
    from trebuchet.report.figures import FIGURES  # matplotlib loads only to draw

    figures = {key: (lambda make=make: make(predicted, measured, scene))
               for key, make in FIGURES.items()}
    out = write_report(out_dir, figures, {}, advisories,
                       title=f"Measured against predicted: {name}, {Path(scene.source).name}",
                       captions=CAPTIONS, intro=intro, progress=say, lead_html=lead,
                       details={"All metrics (units of the figures; SI in metrics.csv)":
                                details_table(table, scene),
                                "Events (ms after the log's trigger)": events_table(events),
                                **details},
                       files=files,
                       inputs=[log if isinstance(log, str | Path) else None, scene.source,
                               reconstruct_options.get("calibration")])
    return out, table


def _fitted(measured: pd.DataFrame, table: pd.DataFrame, scene: Scene,
            options: CompareOptions, log: str | Path | pd.DataFrame,
            reconstruct_options: Mapping[str, object], fit: bool | None,
            say: Callable[[str], None]):
    """The scene as fitted beside the scene as given (:mod:`.fitted_compare`), or None; its
    warnings pass to the caller."""
    from trebuchet.report.fitted_compare import fitted_comparison

    differs = "verdict" in table and bool((table["verdict"] == "differs").any())
    if fit is False or (fit is None and not differs):
        return None
    say("comparing the scene as fitted to the log")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        found = fitted_comparison(measured, table, scene, options, log, reconstruct_options,
                                  fit=fit)
    for w in caught:
        warn_at_caller(w.message, w.category)
    return found


def fitted_html(fitted) -> str:
    """The lead paragraph of the scene as fitted: its sentence and the side-by-side table."""
    import html

    from trebuchet.report.page import table_html

    return (f'<div class="verdict" id="fitted"><p><strong>{html.escape(fitted.sentence)}'
            "</strong></p>" + table_html(fitted.side_by_side, css_class="main", stack=True)
            + "</div>")


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``compare LOG --scene SCENE -o DIR`` with every option of ``forces`` (the same
    names and meanings: ``--fps``, ``--column``, ``--point``, ``--form``, ``--trough``,
    ``--trigger``, ``--lift-off``, ``--release``) and its own ``--release-rule``,
    ``--align``, ``--quiet``."""
    p = sub.add_parser(
        "compare", help="a filmed shot against the model: verdict, metrics, figures, HTML",
        description="Reconstruct the loads of LOG (as forces does, with the same options), "
                    "simulate SCENE aligned to the log and write DIR/index.html: a verdict "
                    "per quantity (does the prediction stay within the measured ±2 sd band "
                    "as often as chance allows?), the figures, DIR/metrics.csv and "
                    "DIR/events.csv. The directory is written whole or not at all.")
    add_reconstruct_arguments(p)
    p.add_argument("-o", "--output", required=True, help="report directory to write")
    p.add_argument("--release-rule", choices=RELEASE_MODES, default=None,
                   help="the model's release: auto (default): a scene's release time is "
                        "replaced by the log's release, a velocity-angle rule is kept; log: "
                        "always the log's; scene: always the scene's rule")
    p.add_argument("--align", choices=ALIGN_MODES, default="fit",
                   help="fit (default): the model's start fitted to the measured angles; "
                        "trigger: the model starts at the log's detected trigger")
    p.add_argument("--chance-runs", type=int, default=CHANCE_RUNS,
                   metavar="N", help="simulated logs that estimate what chance allows "
                   f"(default {CHANCE_RUNS}; 0: no verdict)")
    p.add_argument("--fit", action="store_true", default=None,
                   help="also show the scene as fitted to the shot (trebuchet identify) beside "
                        "the scene as given, and which parameters carry the difference "
                        "(default: where the given scene differs)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.set_defaults(run=_compare)


def _summary(table: pd.DataFrame) -> Mapping[str, float]:
    return {"worst_rms_rel": float(table["rms_difference_rel"].max()),
            "worst_outside": float(table["outside_band_fraction"].max())}


def _release_rule(args: argparse.Namespace) -> str:
    """``--release-rule``; the words auto, log and scene given to ``--release`` (its meaning
    before ``compare`` took the options of ``forces``) still choose the rule, with a note."""
    if args.release is not None and args.release.strip().lower() in RELEASE_MODES:
        word = args.release.strip().lower()
        if args.release_rule is not None and args.release_rule != word:
            raise TrebuchetInputError(f"--release {word} and --release-rule "
                                      f"{args.release_rule}: give the rule once, as "
                                      "--release-rule")
        print(f"trebuchet compare: note: --release {word} is now written --release-rule "
              f"{word}; --release takes the release time (s), as for forces",
              file=sys.stderr)
        args.release = None
        return word
    return args.release_rule or "auto"


@cli_command
def _compare(args: argparse.Namespace) -> int:
    from trebuchet.core.output import check_target
    from trebuchet.ingest.compare import CompareOptions
    from trebuchet.model.scene import Scene

    start = time.monotonic()
    # what can be checked before the progress lines start: the report folder, the log, the scene
    rule = _release_rule(args)
    check_target(args.output, folder=True, inputs=[args.log, args.scene, args.calibration])
    if not Path(args.log).is_file():
        raise TrebuchetInputError(f"{args.log}: no such file")
    if not 0 <= args.chance_runs <= 1000:
        raise TrebuchetInputError(f"--chance-runs {args.chance_runs}: give 0 to 1000")
    options = reconstruct_options(args)
    scene = Scene.from_toml(args.scene)
    compare_options = CompareOptions(release=rule, align=args.align,
                                     chance_runs=args.chance_runs)
    out, table = compare_report(args.log, scene, args.output, options=compare_options,
                                progress=None if args.quiet else _stderr, fit=args.fit,
                                **options)
    fitted = table.attrs.get("fitted")
    also = f"; {fitted.sentence}" if fitted is not None else ""
    print(f"compare {args.log} against {args.scene} -> {out / 'index.html'}: "
          f"{_verdict_line(table)}{also} ({time.monotonic() - start:.1f} s)")
    return 0


def _verdict_line(table: pd.DataFrame) -> str:
    """The verdict in one line, for the terminal."""
    s = _summary(table)
    worst = (f"RMS differences up to {100 * s['worst_rms_rel']:.3g} % of the measured peaks, "
             f"up to {100 * s['worst_outside']:.3g} % of the shot outside ±2 sd")
    if "within_chance" not in table or table["chance_limit"].isna().all():
        return worst
    differ = table.loc[table["verdict"] == "differs", "quantity"].tolist()
    border = table.loc[table["verdict"] == "borderline", "quantity"].tolist()
    also = f"; borderline: {', '.join(border)}" if border else ""
    if not differ:
        return (f"model and measurement agree within chance on all {len(table)} quantities"
                f"{' (' + also[2:] + ')' if also else ''}; " + worst)
    many = f"all {len(table)}" if len(differ) == len(table) else f"{len(differ)} of {len(table)}"
    return (f"model and measurement differ beyond chance in {many} quantities "
            f"({', '.join(differ)}{also}); " + worst)
