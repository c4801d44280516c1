"""Sub-command ``trebuchet sweep``: simulate a grid of designs and write one row per design.

    trebuchet sweep SCENE.toml --grid release.velocity_angle_deg=30:60:7 \\
        --grid engine.M=10000,19100,30000 -o sweep.csv [--workers N] [--scheduler ADDRESS]

``--grid KEY=VALUES`` names a scene key as ``section.key`` (units of the scene file) and its
values as a comma list (``10000,19100,30000``) or ``start:stop:count`` (``count`` evenly spaced
values, both ends included). The table is written whole at the end; meanwhile each finished
row goes to ``OUTPUT.partial``, which a killed run leaves behind and ``--resume`` continues.

Light to import (docs/architecture.md, "Adding a sub-command"): the sweep loads when the
command runs.
"""

from __future__ import annotations

import argparse
import time
from collections import Counter

from trebuchet.core.errors import cli_command
from trebuchet.model.settings import ACCURACY, accuracy_option, add_budget_options, output_step
from trebuchet.model.units import UNITS_HELP

__all__ = ["register", "sweep_units"]


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "sweep", help="simulate a grid of designs and tabulate release, range and peak loads",
        description="Simulate every combination of the --grid values on SCENE and write one "
                    "row per design: the parameters, status and error (the reason a design "
                    "was refused, failed or throws backward or into the ground), release, "
                    "range in vacuum, peak forces and torque, counterweight clearance (SI). "
                    "Finished rows go to OUTPUT.partial as they come; --resume continues a "
                    "killed run from it.")
    p.add_argument("scene", help="base scene file (TOML)")
    p.add_argument("--units", action="store_true", help=UNITS_HELP)
    p.add_argument("--grid", action="append", required=True, metavar="KEY=VALUES",
                   help="scene key section.key and its values: a,b,c or start:stop:count "
                        "(both ends included), e.g. engine.M=10000,19100 or "
                        "release.velocity_angle_deg=30:60:7; repeat for more keys")
    p.add_argument("-o", "--output", required=True, help="CSV file to write")
    p.add_argument("--workers", type=int, default=None,
                   help="local processes (default: one per core; 1 runs in this process, "
                        "without the budgets)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on a Dask cluster at ADDRESS (tcp://host:port; needs dask)")
    p.add_argument("--dt", type=output_step, default=None,
                   help="take the peaks over the rows of a table at this step in s, up to 0.1 "
                        "(default: over the continuous shot, faster)")
    p.add_argument("--accuracy", "--rtol", dest="rtol", type=accuracy_option, default="default",
                   help="fast, default, precise, or a relative tolerance such as 1e-8 "
                        f"(default: default = {ACCURACY['default']:g}); as for simulate")
    p.add_argument("--after-release", type=float, default=None,
                   help="s of phase III the peaks cover (default: simulate's 0.5)")
    add_budget_options(p)
    p.add_argument("--resume", action="store_true",
                   help="continue the killed sweep whose rows OUTPUT.partial holds")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=_sweep)


@cli_command
def _sweep(args: argparse.Namespace) -> int:
    from trebuchet.core.csv_table import write_table
    from trebuchet.core.output import check_target
    from trebuchet.model.design_sizing import read_scene
    from trebuchet.model.sweep import Budget, SimulationOptions, parse_grid_option, sweep
    from trebuchet.model.sweep_design import check_workers, keyed_arguments
    from trebuchet.model.sweep_journal import journal_path

    grid = keyed_arguments(args.grid, parse_grid_option, "--grid")
    check_workers(args.workers)
    SimulationOptions(rtol=args.rtol, dt=args.dt, after_release=args.after_release).check()
    out = check_target(args.output, inputs=[args.scene])
    journal = journal_path(out)
    base, sizing = read_scene(args.scene)  # its [sizing] rules, if any
    options = SimulationOptions(rtol=args.rtol, dt=args.dt, after_release=args.after_release,
                                sizing=sizing)
    t0 = time.perf_counter()
    # interrupted or killed, the rows finished so far stay in the journal for --resume
    table = sweep(base, grid, executor=args.scheduler, workers=args.workers,
                  progress=not args.quiet, options=options,
                  budget=Budget(seconds=args.time_budget, memory=args.memory_budget),
                  journal=journal, resume=args.resume)
    seconds = time.perf_counter() - t0
    write_table(table, args.output, inputs=[args.scene],
                units=sweep_units(list(table.columns)) if args.units else None)
    journal.unlink(missing_ok=True)
    counts = Counter(table["status"])
    ok = counts.pop("ok", 0)
    others = ", ".join(f"{n} {status}" for status, n in sorted(counts.items()))
    print(f"{len(table)} designs in {seconds:.1f} s: {ok} ok"
          + (f", {others} (reason in column 'error')" if others else "")
          + f" -> {args.output}")
    return 0


def sweep_units(columns: list[str]) -> dict[str, str]:
    """The unit of each column of a sweep's table: the scene keys' and the model's
    (:func:`~trebuchet.model.units.column_unit`), the summary's as
    :data:`~trebuchet.model.sweep.SUMMARY_COLUMNS` states them ("1": none)."""
    from trebuchet.model.sweep import SUMMARY_COLUMNS
    from trebuchet.model.units import column_units

    units = column_units(columns)
    for name, text in SUMMARY_COLUMNS.items():
        unit = text.split(",", 1)[0].strip()
        if name in columns and unit != "1":
            units[name] = {"°": "deg"}.get(unit, unit)
    return units
