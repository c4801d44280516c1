"""The ``trebuchet`` command line.

Each room of the package registers its own sub-commands (``register(sub)`` in
``trebuchet.model.cli``, ``trebuchet.ingest.cli``, ``trebuchet.fmu.cli``). A
user's mistake ends with status 2 and one line on stderr that names the file,
row or key; no traceback, no partial output.

The parser is built from light modules only: a room's ``cli`` module imports nothing heavy at
its top (no numpy, pandas, scipy, numba), and its commands import the room's machinery when
they run, so that ``trebuchet --help`` and every usage error answer at once
(docs/architecture.md, "Adding a sub-command"; ``tests/test_cli_startup.py`` checks it).

Ctrl-C, at any moment (the heavy modules still importing included), prints one line,
``trebuchet: interrupted``, and ends with status 130 and no traceback; a half-written output is
removed as after any other failure (:mod:`trebuchet.core.output`).
"""

from __future__ import annotations

import argparse
import ast
import importlib
import os
import re
import shlex
import sys
import warnings
from collections.abc import Sequence
from typing import NoReturn

from trebuchet.core.errors import Option, TrebuchetInputError, command_line
from trebuchet.core.interrupts import (
    INTERRUPTED,
    MESSAGE,
    catch_interrupts,
    end_quietly,
    restore,
)

if __name__ == "__main__":  # python -m trebuchet.cli (the console script: trebuchet/__init__)
    catch_interrupts()  # before main() is entered: an interrupt while it imports is quiet too

ROOMS = (
    "trebuchet.model.cli",
    "trebuchet.report.report_cli",
    "trebuchet.model.sweep_cli",
    "trebuchet.model.design_cli",
    "trebuchet.ingest.cli",
    "trebuchet.ingest.identify_cli",
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
    from trebuchet.core.version import __version__

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


_KEYWORD = re.compile(r"\b([a-z][a-z_]*)=(\{|'[^']*'|\"[^\"]*\"|[-+0-9.eE]+|[A-Za-z_]\w*"
                      r"|(?=[\s),;]|$))")


def _balanced(text: str, start: int) -> int:
    """End (exclusive) of the ``{...}`` that opens at ``text[start]``, or -1."""
    depth, quote = 0, ""
    for i in range(start, len(text)):
        c = text[i]
        if quote:
            quote = "" if c == quote else quote
        elif c in "'\"":
            quote = c
        elif c == "{":
            depth += 1
        elif c == "}":
            depth -= 1
            if depth == 0:
                return i + 1
    return -1


def cli_words(message: str, flags: set[str]) -> str:
    """``message`` with the Python keywords it names as settings (``fps=240``,
    ``columns={'beam': 'theta'}``) written as the command's options (``--fps 240``,
    ``--column beam=theta``), for messages not yet built with :class:`Option`; a keyword is
    rewritten only where the command has its option (``flags``: ``--fps``, ``--column``, ...)."""
    plural = {"columns": "--column", "points": "--point"}
    out, pos = [], 0
    for match in _KEYWORD.finditer(message):
        keyword, value = match.group(1), match.group(2)
        flag = plural.get(keyword, "--" + keyword.replace("_", "-"))
        if flag not in flags or match.start() < pos:
            continue
        end = match.end()
        if value == "":  # "pass fps= to ...": the option alone
            text = flag
        elif value == "{":
            end = _balanced(message, match.start(2))
            if end < 0:
                continue
            try:
                mapping = ast.literal_eval(message[match.start(2):end])
            except (ValueError, SyntaxError):
                continue
            if not isinstance(mapping, dict):
                continue
            text = Option(keyword, mapping, flag=flag).cli()
        else:
            try:
                literal = ast.literal_eval(value)
            except (ValueError, SyntaxError):
                literal = value
            text = f"{flag} {shlex.quote(str(literal))}"
        out.append(message[pos:match.start()])
        out.append(text)
        pos = end
    out.append(message[pos:])
    return "".join(out)


def _flags(parser: argparse.ArgumentParser, argv: Sequence[str] | None) -> set[str]:
    """The option strings of the sub-command that runs."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            args = list(sys.argv[1:] if argv is None else argv)
            for word in args:
                if word in action.choices:
                    return {flag for a in action.choices[word]._actions
                            for flag in a.option_strings}
    return set()


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
    """Run ``trebuchet ARGS`` (``argv``; default ``sys.argv[1:]``) and return its status.
    Ctrl-C is caught while it runs (module doc); called with ``argv`` (a test, a program),
    the caller's SIGINT handler is put back on return."""
    previous = catch_interrupts()
    try:
        return _main(argv)
    except KeyboardInterrupt:  # raised by code, or where the handler could not be set
        print(MESSAGE, file=sys.stderr)
        return INTERRUPTED
    finally:
        if argv is None:  # the command itself: quiet through the interpreter's shut-down too
            end_quietly()
        else:
            restore(previous)


def _main(argv: Sequence[str] | None) -> int:
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
        print(f"trebuchet: error: {cli_words(str(exc), _flags(parser, argv))}",
              file=sys.stderr)
        return 2
    except OSError as exc:  # a file the user named cannot be read or written
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"trebuchet: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
