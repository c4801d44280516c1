"""The ``trebuchet`` command line.

Each room of the package registers its own sub-commands (``register(sub)`` in
``trebuchet.model.cli``, ``trebuchet.ingest.cli``, ``trebuchet.fmu.cli``). A
user's mistake ends with status 2 and one line on stderr that names the file,
row or key; no traceback, no partial output.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import warnings
from collections.abc import Sequence
from typing import NoReturn

from trebuchet.errors import TrebuchetInputError, command_line

ROOMS = (
    "trebuchet.model.cli",
    "trebuchet.report.report_cli",
    "trebuchet.model.sweep_cli",
    "trebuchet.ingest.cli",
    "trebuchet.report.compare_cli",
    "trebuchet.fmu.cli",
)


class _Parser(argparse.ArgumentParser):
    """argparse, with a mistake on the command line reported in one line (and status 2), as
    every other user's mistake is; ``--help`` shows the usage."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="trebuchet",
        description="Internal forces of the swinging-counterweight trebuchet (Horsdal).")
    from trebuchet.version import __version__

    parser.add_argument("--version", action="version", version=f"trebuchet {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in ROOMS:
        try:
            room = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name != name:
                raise
            continue
        room.register(sub)
    return parser


def _format_warning(message, category, filename, lineno, line=None) -> str:
    return f"trebuchet: warning: {message}\n"


def _quiet_stdout() -> None:
    """The reader of our output has gone (``trebuchet paper | head``): send what is left of
    stdout nowhere, so that neither we nor the interpreter's final flush report it."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    warnings.formatwarning = _format_warning
    try:
        with command_line():  # hints name --options, not Python keywords (errors.Option)
            status = int(args.run(args) or 0)
        sys.stdout.flush()
        return status
    except BrokenPipeError:
        _quiet_stdout()
        return 141  # as a shell reports a command ended by SIGPIPE; no message
    except TrebuchetInputError as exc:
        print(f"trebuchet: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # a file the user named cannot be read or written
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"trebuchet: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("trebuchet: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
