"""Sub-command ``trebuchet identify LOG --scene SCENE -o FITTED.toml``: the engine of a filmed
shot, fitted by its own equations of motion (:mod:`trebuchet.ingest.identification`).

Light to import (docs/architecture.md, "Adding a sub-command"): the parser is built from
:mod:`trebuchet.ingest.cli`'s argument helpers and the standard library; numpy, scipy and the
fit load when ``identify`` runs.
"""

from __future__ import annotations

import argparse
import sys
import warnings

from trebuchet.core.errors import cli_command
from trebuchet.ingest.cli import (
    add_event_arguments,
    add_image_calibration_argument,
    add_log_arguments,
    event_options,
    log_options,
)

__all__ = ["register"]


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``identify LOG --scene SCENE -o FITTED.toml [--free KEY ...] [--table T.csv]``
    with every log option of ``forces``."""
    p = sub.add_parser(
        "identify", help="fit the engine's equations of motion to a filmed shot: its "
                         "counterweight, beam inertia and bearings' friction",
        description="Fit the scene's engine to the log's angles (least squares on the "
                    "equations of motion; trigger, start pose and release fitted too) and "
                    "write the fitted scene, with each fitted value's sd in a comment. "
                    "Default free keys: engine.M, engine.I and the friction coefficients "
                    "whose radii the scene gives. One mass must stay the scene's: gravity "
                    "scales every mass alike.")
    add_log_arguments(p)
    add_image_calibration_argument(p)
    add_event_arguments(p)
    p.add_argument("-o", "--output", required=True, metavar="FITTED.toml",
                   help="the fitted scene to write (a scene file)")
    p.add_argument("--free", action="append", default=None, metavar="KEY",
                   help="a scene key to fit, as section.key (engine.M, engine.I, "
                        "friction.pivot_mu, engine.L3, ...); repeatable; replaces the default "
                        "set")
    p.add_argument("--table", metavar="T.csv",
                   help="also write the table of fitted values (parameter, scene_value, value, "
                        "sd, unit, kind) as CSV")
    p.add_argument("--quiet", action="store_true",
                   help="no summary on stdout (warnings still go to stderr)")
    p.set_defaults(run=_identify)


@cli_command
def _identify(args: argparse.Namespace) -> int:
    from pathlib import Path

    from trebuchet.core.csv_table import write_table
    from trebuchet.core.output import check_target
    from trebuchet.ingest.identification.identify import identify
    from trebuchet.ingest.identification.report import (
        summary_text,
        table_for_csv,
        write_fitted_scene,
    )

    inputs = [args.log, args.scene, args.calibration]
    check_target(args.output, inputs=inputs)
    if args.table:
        check_target(args.table, inputs=inputs)
    options = log_options(args)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = identify(args.log, args.scene, args.free, events=event_options(args),
                          image_calibration=args.image_calibration, **options)
    name = Path(args.log).name
    write_fitted_scene(result, args.output, log=name, inputs=inputs)
    if args.table:
        write_table(table_for_csv(result), args.table, inputs=inputs)
    if not args.quiet:
        print(summary_text(result, log=name, output=args.output, table=args.table))
    for w in caught:
        print(f"trebuchet: warning: {w.message}", file=sys.stderr)
    return 0
