"""Errors and warnings that reach the user.

A :class:`TrebuchetInputError` is a user's mistake (a bad scene key, a bad log
row, a non-physical request). Its message names the file, row or key and what
is wrong; the command line prints it as one line and exits with status 2.

**Hints in the words of the interface called.** A message that tells the user what to
give names the setting with an :class:`Option`: formatted into the message, it reads
``--fps 240`` while a command of the ``trebuchet`` command line runs (:func:`command_line`,
entered by ``trebuchet.cli.main``) and ``fps=240`` for a Python caller::

    raise TrebuchetInputError(f"{path}: frame numbers and no time column; give "
                              f"{Option('fps', 240)}")
    # trebuchet forces ...  -> "... give --fps 240"
    # tb.read_log(...)      -> "... give fps=240"

The form is decided when the message is built (inside the command), so a message that is
caught and wrapped in another keeps it.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import os
import shlex
import sys
import unicodedata
import warnings
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["TrebuchetInputError", "TrebuchetDataWarning", "ModelValidityWarning", "Option",
           "check_choice", "command_line", "cli_command", "on_command_line", "warn_at_caller",
           "printable"]

_INTERFACE: contextvars.ContextVar[str] = contextvars.ContextVar("trebuchet_interface",
                                                                 default="python")


@contextlib.contextmanager
def command_line() -> Iterator[None]:
    """Within this block messages name settings as command-line options (``--fps 240``)."""
    token = _INTERFACE.set("cli")
    try:
        yield
    finally:
        _INTERFACE.reset(token)


def cli_command(run: Callable[..., int]) -> Callable[..., int]:
    """Decorate a sub-command's ``run(args)``: it speaks the command line's words however it
    is called (``trebuchet.cli.main`` or a test calling ``args.run(args)``)."""
    @functools.wraps(run)
    def wrapped(*args: Any, **kwargs: Any) -> int:
        with command_line():
            return run(*args, **kwargs)
    return wrapped


def on_command_line() -> bool:
    """True while a command of the ``trebuchet`` command line runs (:func:`command_line`)."""
    return _INTERFACE.get() == "cli"


_NOTHING = object()


@dataclass(frozen=True)
class Option:
    """A setting named in a message, in the form of the interface called (module doc).

    ``keyword``: the Python keyword (``fps``, ``columns``, ``time_unit``); ``value``: an
    example or the value at fault (omitted: the name alone); ``flag``: the command-line
    option (default ``--`` + the keyword with ``-`` for ``_``). A mapping value (``columns``,
    ``points``) is one repeated flag per item on the command line, ``NAME=VALUE`` each::

        Option("columns", {"x (deg)": "theta"}, flag="--column")
        # Python: columns={'x (deg)': 'theta'}   CLI: --column 'x (deg)=theta'

    ``Option.column(name, angle)`` and ``Option.point(role, name)`` build those two.
    """

    keyword: str
    value: object = _NOTHING
    flag: str | None = None

    @classmethod
    def column(cls, name: str, angle: str) -> Option:
        """``columns={name: angle}`` / ``--column name=angle``."""
        return cls("columns", {name: angle}, flag="--column")

    @classmethod
    def point(cls, role: str, name: str) -> Option:
        """``points={role: name}`` / ``--point role=name``."""
        return cls("points", {role: name}, flag="--point")

    @property
    def cli_flag(self) -> str:
        return self.flag or "--" + self.keyword.replace("_", "-")

    def python(self) -> str:
        """``keyword=value`` (``repr`` of the value), or the keyword alone."""
        if self.value is _NOTHING:
            return self.keyword
        value = self.value
        if isinstance(value, float) and value.is_integer() and abs(value) < 1e15:
            value = int(value)  # fps=240, not fps=240.0
        return f"{self.keyword}={value!r}"

    def cli(self) -> str:
        """``--flag value`` (quoted for a shell where needed), or the flag alone."""
        if self.value is _NOTHING:
            return self.cli_flag
        if isinstance(self.value, Mapping):
            return " ".join(f"{self.cli_flag} {shlex.quote(f'{k}={v}')}"
                            for k, v in self.value.items())
        if isinstance(self.value, bool):
            return self.cli_flag
        if isinstance(self.value, float):
            return f"{self.cli_flag} {self.value:g}"
        return f"{self.cli_flag} {shlex.quote(str(self.value))}"

    def __str__(self) -> str:
        return self.cli() if on_command_line() else self.python()

    def __format__(self, spec: str) -> str:
        return format(str(self), spec)


class TrebuchetInputError(ValueError):
    """Bad input from the user: the message names file, row or key and the problem.

    Code that reads a file raises it with the place inside the file (:meth:`at`: ``"row 12,
    column 'theta'"``) and without the file's name; the one function that opened the file
    adds the name once (:meth:`in_file`): ``"shot.csv, row 12, column 'theta': ..."``.
    """

    def __init__(self, message: str, *, where: str | None = None) -> None:
        message = printable(message)
        where = None if where is None else printable(where)
        self.message, self.where = message, where
        super().__init__(f"{where}: {message}" if where else message)

    @classmethod
    def at(cls, where: str, message: str) -> TrebuchetInputError:
        """The error ``message`` at ``where`` (a row, column, key or point of the input)."""
        return cls(message, where=where)

    def in_file(self, name: object) -> TrebuchetInputError:
        """This error with the file's ``name`` in front of its place."""
        where = f"{name}, {self.where}" if self.where else str(name)
        return type(self)(self.message, where=where)


def check_choice(owner: str, name: str, value: object, options: tuple) -> None:
    """Refuse ``value`` of the setting ``name`` unless it is one of ``options``: the message
    names ``owner`` (the function or settings class), the setting (an :class:`Option`: the
    flag on the command line) and the choices."""
    if value not in options:
        raise TrebuchetInputError(f"{owner}: {Option(name)} must be one of {tuple(options)}, "
                                  f"not {value!r}")


#: The folders of the package's sources (this file is trebuchet/core/errors.py).
_PACKAGE_DIRS = tuple(
    os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))) + os.sep + d
    for d in ("trebuchet", "model", "ingest", "fmu", "data_samples"))


def printable(text: str) -> str:
    """``text`` with every control character (C0, DEL, C1: ESC, BEL, newline, ...) and every
    invisible format character (bidirectional overrides, zero-width marks) written as an
    escape (``\\x1b``, ``\\u202e``): a name read from a user's file cannot clear, recolour
    or retitle the terminal a message is printed on, nor split the message's one line."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() or c == " " or unicodedata.category(c) not in
                   ("Cc", "Cf", "Zl", "Zp") else repr(c)[1:-1] for c in text)


def warn_at_caller(message: str | Warning, category: type[Warning] = UserWarning) -> None:
    """``warnings.warn`` pointing at the first line outside this package (the user's call),
    however deep inside the package it is issued (Python 3.12's ``skip_file_prefixes``);
    control characters in a text message are escaped (:func:`printable`)."""
    if isinstance(message, str):
        message = printable(message)
    frame, level = sys._getframe(1), 2
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(
            _PACKAGE_DIRS):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, category, stacklevel=level)


class TrebuchetDataWarning(UserWarning):
    """A repair made to user data (dropped duplicate frame, filled gap, unwrapped angle)."""


class ModelValidityWarning(UserWarning):
    """The model left its range of validity (slack sling, unresolved acceleration)."""
