"""Sub-command ``trebuchet sweep``: simulate a grid of designs and write one row per design.

    trebuchet sweep SCENE.toml --grid release.velocity_angle_deg=30:60:7 \\
        --grid engine.M=10000,19100,30000 -o sweep.csv [--workers N] [--scheduler ADDRESS]

``--grid KEY=VALUES`` names a scene key as ``section.key`` (units of the scene file) and its
values as a comma list (``10000,19100,30000``) or ``start:stop:count`` (``count`` evenly spaced
values, both ends included). The table is written whole or not at all.

Light to import (docs/architecture.md, "Adding a sub-command"): the sweep loads when the
command runs.
"""

from __future__ import annotations

import argparse
import time

from trebuchet.errors import TrebuchetInputError, cli_command
from trebuchet.model.settings import ACCURACY, accuracy_option, output_step
from trebuchet.model.units import UNITS_HELP


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "sweep", help="simulate a grid of designs and tabulate release, range and peak loads",
        description="Simulate every combination of the --grid values on SCENE and write one "
                    "row per design: the parameters, status and error (the reason a design "
                    "was refused), release, range in vacuum, peak forces and torque (SI).")
    p.add_argument("scene", help="base scene file (TOML)")
    p.add_argument("--units", action="store_true", help=UNITS_HELP)
    p.add_argument("--grid", action="append", required=True, metavar="KEY=VALUES",
                   help="scene key section.key and its values: a,b,c or start:stop:count "
                        "(both ends included), e.g. engine.M=10000,19100 or "
                        "release.velocity_angle_deg=30:60:7; repeat for more keys")
    p.add_argument("-o", "--output", required=True, help="CSV file to write")
    p.add_argument("--workers", type=int, default=None,
                   help="local processes (default: one per core; 1 runs in this process)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on a Dask cluster at ADDRESS (tcp://host:port; needs dask)")
    p.add_argument("--dt", type=output_step, default=1e-3,
                   help="output step in s, up to 0.1 (default 0.001)")
    p.add_argument("--accuracy", "--rtol", dest="rtol", type=accuracy_option, default="default",
                   help="fast, default, precise, or a relative tolerance such as 1e-8 "
                        f"(default: default = {ACCURACY['default']:g}); as for simulate")
    p.add_argument("--after-release", type=float, default=None,
                   help="s of phase III to simulate (default: simulate's)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=_sweep)


@cli_command
def _sweep(args: argparse.Namespace) -> int:
    from trebuchet.csv_table import write_table
    from trebuchet.model.scene import Scene
    from trebuchet.model.sweep import STATUS_OK, SimulationOptions, parse_grid_option, sweep
    from trebuchet.output import check_target

    grid: dict[str, tuple[float, ...]] = {}
    for text in args.grid:
        key, values = parse_grid_option(text)
        if key in grid:
            raise TrebuchetInputError(f"--grid {key}: given twice")
        grid[key] = values
    if args.workers is not None and args.workers < 1:
        raise TrebuchetInputError(f"--workers {args.workers}: must be at least 1")
    options = SimulationOptions(rtol=args.rtol, dt=args.dt, after_release=args.after_release)
    options.check()
    check_target(args.output, inputs=[args.scene])
    base = Scene.from_toml(args.scene)
    t0 = time.perf_counter()
    table = sweep(base, grid, executor=args.scheduler, workers=args.workers,
                  progress=not args.quiet, options=options)
    seconds = time.perf_counter() - t0
    write_table(table, args.output, inputs=[args.scene],
                units=sweep_units(list(table.columns)) if args.units else None)
    ok = int((table["status"] == STATUS_OK).sum())
    print(f"{len(table)} designs in {seconds:.1f} s: {ok} ok, {len(table) - ok} refused or "
          f"failed (reason in column 'error') -> {args.output}")
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
