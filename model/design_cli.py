"""Sub-command ``trebuchet design``: the best design under limits, written as a scene file.

    trebuchet design SCENE.toml -o BEST.toml --vary engine.L4=3:8 --vary engine.L3=1:4 \\
        --vary release.velocity_angle_deg=25:55 --maximize range \\
        --limit 'F_R_peak<=468905' --limit 'F_S_peak<=54010' --limit 'cw_clearance>=1' \\
        [--workers N] [--scheduler ADDRESS] [--seed N] [--plot trade.png]

Prints a table of the start against the best; BEST.toml is a valid scene whose comment block
gives the objective and each limit with its margin. A mistake (an unknown key or figure,
bounds the wrong way round, a limit that does not parse, limits no design meets): exit 2, one
line, nothing written.

Light to import (docs/architecture.md, "Adding a sub-command"): the search loads when the
command runs.
"""

from __future__ import annotations

import argparse
import time

from trebuchet.core.errors import TrebuchetInputError, cli_command
from trebuchet.model.settings import (
    ACCURACY,
    DESIGN_GENERATIONS,
    DESIGN_POPSIZE,
    accuracy_option,
    add_budget_options,
)

__all__ = ["register"]


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text}: must be at least 1")
    return value


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "design", help="the best design under limits on its loads (an optimiser, not a grid)",
        description="Vary scene keys between bounds to maximise or minimise one figure of the "
                    "sweep table while every --limit holds: differential evolution with the "
                    "limits as constraints, then a local polish; the best design is verified "
                    "by simulating it again at the default accuracy and written as a scene "
                    "file with its objective and margins in a comment block.")
    p.add_argument("scene", help="the start scene (TOML)")
    p.add_argument("-o", "--output", required=True, help="the best design, a scene file (TOML)")
    p.add_argument("--vary", action="append", required=True, metavar="KEY=LO:HI",
                   help="a scene key section.key (units of the scene file) and its bounds, "
                        "e.g. engine.L4=3:8; repeat for more keys")
    goal = p.add_mutually_exclusive_group(required=True)
    goal.add_argument("--maximize", metavar="FIGURE",
                      help="a figure of the sweep table (range, F_R_peak, ..., cw_clearance)")
    goal.add_argument("--minimize", metavar="FIGURE", help="as --maximize, the other way")
    p.add_argument("--limit", action="append", default=[], metavar="FIGURE<=VALUE",
                   help="FIGURE<=VALUE or FIGURE>=VALUE in SI units, e.g. F_R_peak<=468905 or "
                        "cw_clearance>=1.0; repeat for more")
    p.add_argument("--workers", type=int, default=None,
                   help="local processes (default: this process where the generated C runs "
                        "the designs many a call, else one per core; 1 runs in this process)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run the designs on a Dask cluster at ADDRESS (tcp://host:port)")
    p.add_argument("--seed", type=int, default=None, help="makes the search repeatable")
    p.add_argument("--plot", default=None, metavar="FILE.png",
                   help="draw the trade: the objective against the binding limit, with the "
                        "Pareto front of the designs tried, the start and the best")
    p.add_argument("--accuracy", "--rtol", dest="rtol", type=accuracy_option, default="default",
                   help="solver tolerance of the search: fast, default, precise or a number "
                        f"(default {ACCURACY['default']:g}); the best is verified at default")
    p.add_argument("--generations", type=_count, default=DESIGN_GENERATIONS,
                   help=f"generations of evolution at most (default {DESIGN_GENERATIONS})")
    p.add_argument("--popsize", type=_count, default=DESIGN_POPSIZE,
                   help=f"designs per varied key in a generation (default {DESIGN_POPSIZE})")
    add_budget_options(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=_design)


@cli_command
def _design(args: argparse.Namespace) -> int:
    from trebuchet.core.output import check_target
    from trebuchet.model.design import design
    from trebuchet.model.design_output import plot_trade, summary_table, write_best
    from trebuchet.model.design_problem import parse_vary
    from trebuchet.model.design_search import SearchOptions
    from trebuchet.model.sweep import Budget, SimulationOptions
    from trebuchet.model.sweep_design import check_workers, keyed_arguments

    vary = keyed_arguments(args.vary, parse_vary, "--vary")
    check_workers(args.workers)
    out = check_target(args.output, inputs=[args.scene])
    plot = check_target(args.plot, inputs=[args.scene]) if args.plot else None
    if plot is not None and plot == out:
        raise TrebuchetInputError(f"--plot {args.plot}: is the -o output too; give another "
                                  "name")
    t0 = time.perf_counter()
    result = design(args.scene, vary, maximize=args.maximize, minimize=args.minimize,
                    limits=args.limit, seed=args.seed, workers=args.workers,
                    executor=args.scheduler, progress=not args.quiet,
                    options=SimulationOptions(rtol=args.rtol),
                    budget=Budget(seconds=args.time_budget, memory=args.memory_budget),
                    search_options=SearchOptions(popsize=args.popsize,
                                                 generations=args.generations))
    seconds = time.perf_counter() - t0
    write_best(result, args.output, args.scene, inputs=[args.scene])
    if plot is not None:
        plot_trade(result, args.plot, inputs=[args.scene, args.output])
    print(summary_table(result))
    print(f"{result.evaluations} designs in {seconds:.1f} s; best -> {out}"
          + (f", trade -> {plot}" if plot else ""))
    return 0
