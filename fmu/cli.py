"""Sub-commands of the FMU: ``trebuchet fmu build`` and ``trebuchet fmu crosscheck``.

Light to import (docs/architecture.md, "Adding a sub-command"): sympy, the code generator and
fmpy load when a command runs."""

from __future__ import annotations

import argparse


def register(sub: argparse._SubParsersAction) -> None:
    fmu = sub.add_parser("fmu", help="build the FMU and its cross-check files",
                         description="The trebuchet as a native FMI 2.0 or 3.0 FMU "
                         "(co-simulation and model exchange).")
    commands = fmu.add_subparsers(dest="fmu_command", required=True, metavar="COMMAND")

    p = commands.add_parser("build", help="build Trebuchet.fmu",
                            description="Build the native FMU: C generated from the model's "
                            "formulas and compiled (gcc; win64 too where "
                            "x86_64-w64-mingw32-gcc is installed), co-simulation and model "
                            "exchange in one file. The host needs nothing but the FMU.")
    p.add_argument("-o", "--output", default="Trebuchet.fmu", help="FMU file to write "
                   "(default Trebuchet.fmu)")
    p.add_argument("--fmi", type=int, choices=(2, 3), default=2, help="FMI version "
                   "(default 2)")
    p.set_defaults(run=_build)

    p = commands.add_parser("crosscheck", help="write the FMI cross-check layout for an FMU",
                            description="Write fmus/2.0/cs/<platform>/trebuchet/<version>/"
                            "Trebuchet/ with the FMU, the in-process reference result, the "
                            "input and the options file.")
    p.add_argument("fmu", help="the FMU (from 'trebuchet fmu build')")
    p.add_argument("-o", "--output", required=True, help="directory to write")
    p.set_defaults(run=_crosscheck)


def _build(args: argparse.Namespace) -> int:
    from trebuchet.core.output import check_target
    from trebuchet.fmu.build import build_fmu, fmi_headers
    from trebuchet.fmu.csources import GLUE_DIR, GLUE_FILES

    check_target(args.output,  # not over a file the build reads
                 inputs=[*fmi_headers(args.fmi), *(GLUE_DIR / name for name in GLUE_FILES)])
    path = build_fmu(args.output, fmi=args.fmi)
    print(f"FMI {args.fmi}.0 FMU (co-simulation and model exchange) -> {path}")
    return 0


def _crosscheck(args: argparse.Namespace) -> int:
    from trebuchet.core.output import check_target
    from trebuchet.fmu.crosscheck import write_crosscheck

    check_target(args.output, folder=True, inputs=[args.fmu])
    folder = write_crosscheck(args.fmu, args.output)
    print(f"cross-check files -> {folder}")
    return 0
