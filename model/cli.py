"""Sub-commands of the model: ``simulate`` and ``paper``.

Light to import (docs/architecture.md, "Adding a sub-command"): :func:`register` builds the
parsers from :mod:`trebuchet.model.settings`; the simulator loads when a command runs.
"""

from __future__ import annotations

import argparse
import sys

from trebuchet.core.errors import cli_command
from trebuchet.model.output_size import MAX_AFTER_RELEASE
from trebuchet.model.settings import (
    DEFAULT_AFTER_RELEASE,
    DEFAULT_RTOL,
    accuracy_option,
    output_step,
)
from trebuchet.model.units import UNITS_HELP


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("simulate", help="simulate a shot and write every force to CSV",
                       description="Simulate a shot of SCENE and write the contract's columns.")
    p.add_argument("scene", help="scene file (TOML)")
    p.add_argument("--units", action="store_true", help=UNITS_HELP)
    p.add_argument("-o", "--output", required=True, help="CSV file to write")
    p.add_argument("--dt", type=output_step, default=1e-3,
                   help="output step in s, 1e-6 to 0.1, at most 1,000,000 rows "
                   "(default 0.001)")
    p.add_argument("--accuracy", "--rtol", dest="accuracy", default="default", type=accuracy_option,
                   help="fast, default, precise, or a relative tolerance such as 1e-8 "
                   f"(default: {DEFAULT_RTOL:g})")
    p.add_argument("--after-release", type=float, default=DEFAULT_AFTER_RELEASE,
                   help=f"s of phase III to simulate, 0 to {MAX_AFTER_RELEASE:g} "
                   f"(default {DEFAULT_AFTER_RELEASE:g})")
    p.set_defaults(run=_simulate)

    p = sub.add_parser("paper", help="compare the model with every number the paper quotes",
                       description="Print the table quantity | paper | computed | difference.")
    p.add_argument("--scene", help="scene file (default: the paper's Table 1 engine)")
    p.add_argument("--markdown", action="store_true", help="print a Markdown table")
    p.add_argument("-o", "--output", help="also write the table as CSV")
    p.set_defaults(run=_paper)


@cli_command
def _simulate(args: argparse.Namespace) -> int:
    from trebuchet.core.csv_table import write_table
    from trebuchet.core.output import check_target
    from trebuchet.model.scene import Scene
    from trebuchet.model.simulate import simulate
    from trebuchet.model.units import column_units

    check_target(args.output, inputs=[args.scene])
    scene = Scene.from_toml(args.scene)
    run = simulate(scene, rtol=args.accuracy, after_release=args.after_release, dt=args.dt)
    write_table(run, args.output, inputs=[args.scene],
                units=column_units(list(run.columns)) if args.units else None)
    print(simulation_summary(run) + f"; {len(run)} rows -> {args.output}")
    return 0


def simulation_summary(run) -> str:
    """One line: the events the shot went through and the flight's range (s, m)."""
    ev, fl = run.attrs["events"], run.attrs["flight"]
    parts = [f"{name.replace('_', '-')} {ev[name]:.4f} s" for name in ("lift_off", "release")
             if name in ev]
    if fl is not None:
        parts.append(f"range ({fl.get('model', 'vacuum')}) {fl['range']:.1f} m")
    else:
        parts.append(f"dry fire, {ev['end']:.4f} s simulated")
    return ", ".join(parts)


def format_paper_table(table, markdown: bool = False) -> str:
    """The comparison table as aligned text or Markdown."""
    rows = [("quantity", "unit", "paper", "computed", "difference", "", "note")]
    for r in table.itertuples():
        rows.append((f"{r.section}: {r.quantity}", r.unit, f"{r.paper:.6g}", f"{r.computed:.4g}",
                     f"{r.difference:+.3g}", "" if r.agrees else "differs", r.note))
    if markdown:
        lines = ["| " + " | ".join(rows[0]) + " |", "|" + "---|" * len(rows[0])]
        lines += ["| " + " | ".join(c.replace("|", "\\|") for c in r) + " |" for r in rows[1:]]
        return "\n".join(lines)
    widths = [max(len(r[i]) for r in rows) for i in range(6)]
    return "\n".join("  ".join(c.ljust(w) for c, w in zip(r[:6], widths, strict=True))
                     + (f"  {r[6]}" if r[6] else "") for r in rows)


@cli_command
def _paper(args: argparse.Namespace) -> int:
    from trebuchet.core.csv_table import write_table
    from trebuchet.core.output import check_target
    from trebuchet.model.paper import horsdal_scene_path, paper_comparison
    from trebuchet.model.scene import Scene

    if args.output:
        check_target(args.output, inputs=[args.scene])
    scene = Scene.from_toml(args.scene) if args.scene else None
    table = paper_comparison(scene)
    if scene is not None and scene.engine != Scene.from_toml(horsdal_scene_path()).engine:
        print(f"trebuchet: note: {args.scene} is not the engine of the paper's Table 1; its "
              "numbers are set beside the paper's all the same", file=sys.stderr)
    print(format_paper_table(table, markdown=args.markdown))
    if args.output:
        write_table(table, args.output, inputs=[args.scene])
    return 0
