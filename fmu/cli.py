"""Sub-commands of the FMU: ``trebuchet fmu build`` and ``trebuchet fmu crosscheck``."""

from __future__ import annotations

import argparse

from trebuchet.output import check_target


def register(sub: argparse._SubParsersAction) -> None:
    fmu = sub.add_parser("fmu", help="build the co-simulation FMU and its cross-check files",
                         description="The trebuchet as an FMI 2.0 co-simulation FMU.")
    commands = fmu.add_subparsers(dest="fmu_command", required=True, metavar="COMMAND")

    p = commands.add_parser("build", help="build Trebuchet.fmu",
                            description="Build the FMI 2.0 co-simulation FMU (the in-process "
                            "simulator behind pythonfmu). The host needs Python with this "
                            "package installed.")
    p.add_argument("-o", "--output", default="Trebuchet.fmu", help="FMU file to write "
                   "(default Trebuchet.fmu)")
    p.set_defaults(run=_build)

    p = commands.add_parser("crosscheck", help="write the FMI cross-check layout for an FMU",
                            description="Write fmus/2.0/cs/<platform>/trebuchet/<version>/"
                            "Trebuchet/ with the FMU, the in-process reference result, the "
                            "input and the options file.")
    p.add_argument("fmu", help="the FMU (from 'trebuchet fmu build')")
    p.add_argument("-o", "--output", required=True, help="directory to write")
    p.set_defaults(run=_crosscheck)


def _build(args: argparse.Namespace) -> int:
    from trebuchet.fmu.build import build_fmu

    check_target(args.output)
    path = build_fmu(args.output)
    print(f"FMI 2.0 co-simulation FMU -> {path}")
    return 0


def _crosscheck(args: argparse.Namespace) -> int:
    from trebuchet.fmu.crosscheck import write_crosscheck

    check_target(args.output, folder=True)
    folder = write_crosscheck(args.fmu, args.output)
    print(f"cross-check files -> {folder}")
    return 0
