"""The ``trebuchet report`` command: the paper's figures and key numbers for a simulated
scene, as ``DIR/index.html`` with one PNG per figure, written whole or not at all.

Light to import (docs/architecture.md, "Adding a sub-command"): the model and the figures load
when the command runs or :func:`report_scene` is called."""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from trebuchet.core.errors import Option, TrebuchetInputError, cli_command, warn_at_caller

if TYPE_CHECKING:
    from trebuchet.model.scene import Scene

__all__ = ["register", "report_scene", "CAPTIONS"]

CAPTIONS = {
    "tension": "Sling tension F_S and its component across the beam F_S⊥, in units of the "
               "projectile's weight m·g (paper: Fig. Tension).",
    "reactions": "a) hinge force |F_H|, b) pivot reaction |F_R|, c) its horizontal component, "
                 "in units of the counterweight's weight M·g (paper: Fig. Reaction).",
    "bending": "Forces across the beam: a) the bending load |F_R⊥|, b) its parts from hinge, "
               "centre of mass and sling, c) their shares (paper: Fig. PerpReac).",
    "loci": "Loci of F_R, F_M (M·g) and of F_m, F_S (m·g) (paper: Fig. ForceLocus).",
    "torque": "Torque on the beam: contributions of hinge, gravity at the centre of mass and "
              "spigot, and the total N, kN m (paper: Fig. Torque).",
    "configurations": "The engine at the greatest bending load and at release "
                      "(paper: Fig. Configurations).",
    "energy": "Rates of work (kW) and mechanical energy gained (kJ) by counterweight, beam "
              "and projectile (paper: Figs. Power and Power_Beam).",
}


def _stderr(message: str) -> None:
    print(f"trebuchet report: {message}", file=sys.stderr, flush=True)


def report_scene(scene: Scene, out_dir: str | Path, *, dt: float = 1e-3,
                 progress: Callable[[str], None] | None = None) -> Path:
    """Simulate ``scene`` and write its report to ``out_dir`` (index.html, one PNG per figure
    of :data:`trebuchet.report.figures.FIGURES`, ``peaks.csv``); ``dt`` is the output step, s.
    Warnings of the model (slack sling, ...) are shown in the report as advisories and
    passed on."""
    from trebuchet.model.simulate import simulate
    from trebuchet.report.figures_numbers import event_table, flight_table, peak_table
    from trebuchet.report.page import write_report

    if not 0.0 < dt <= 0.1:
        raise TrebuchetInputError(f"{Option('dt', dt)}: the output step must lie in "
                                  "(0, 0.1] s")
    say = progress or (lambda message: None)
    say(f"simulating {scene.source}")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run = simulate(scene, dt=dt)
    for w in caught:
        warn_at_caller(w.message, w.category)
    advisories = [str(w.message) for w in caught]
    if "sling_tension" in run.columns and (run.loc[run["phase"] == 2, "sling_tension"] < 0).any():
        advisories.append("the sling tension goes negative in the sling phase: a real sling "
                          "would go slack there, and the forces after that are not physical")
    diag = run.attrs.get("diagnostics") or {}
    tables = {"events": event_table(run), "peaks": peak_table(run, scene),
              "flight": flight_table(run)}
    from trebuchet.report.figures import FIGURES  # matplotlib loads only when a report is drawn

    figures = {name: (lambda make=make: make(run, None, scene)) for name, make in FIGURES.items()}
    intro = (f"Simulated shot of {scene.source}: {len(run)} rows every {dt * 1e3:g} ms, "
             f"solver {diag.get('method', '?')} at rtol {diag.get('rtol', float('nan')):g}, "
             f"relative energy drift {diag.get('energy_drift_rel', float('nan')):.2g}. "
             "Times after the trigger; forces over the projectile's weight m·g "
             f"({scene.engine.m * scene.g / 1e3:.4g} kN) or the counterweight's weight M·g "
             f"({scene.engine.M * scene.g / 1e3:.4g} kN).")
    return write_report(out_dir, figures, tables, advisories,
                        title=f"trebuchet report: {Path(scene.source).name}",
                        captions=CAPTIONS, intro=intro, csv_tables=["peaks"], progress=say,
                        inputs=[scene.source])


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``report SCENE -o DIR [--dt S] [--quiet]``."""
    p = sub.add_parser("report", help="figures and key numbers of a simulated shot as HTML",
                       description="Simulate SCENE and write DIR/index.html with the paper's "
                                   "figures (PNG) and the key numbers: events, peaks with "
                                   "times, flight. The directory is written whole or not at "
                                   "all.")
    p.add_argument("scene", help="scene file (TOML)")
    p.add_argument("-o", "--output", required=True, help="report directory to write")
    p.add_argument("--dt", type=float, default=1e-3,
                   help="output step in s, 1e-6 to 0.1 (default 0.001)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.set_defaults(run=_report)


@cli_command
def _report(args: argparse.Namespace) -> int:
    from trebuchet.core.output import check_target
    from trebuchet.model.scene import Scene

    start = time.monotonic()
    check_target(args.output, folder=True, inputs=[args.scene])
    scene = Scene.from_toml(args.scene)
    out = report_scene(scene, args.output, dt=args.dt,
                       progress=None if args.quiet else _stderr)
    print(f"report of {args.scene} -> {out / 'index.html'} "
          f"({time.monotonic() - start:.1f} s)")
    return 0
