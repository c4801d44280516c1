"""Ctrl-C on the ``trebuchet`` command: one line, status 130, no traceback, at any moment.

Python answers SIGINT with a ``KeyboardInterrupt`` traceback wherever it lands: in the first
second of a command that is mostly the import of numpy, pandas, scipy and numba, and a
traceback from inside an import says nothing to a user. The command (``trebuchet.cli.main``)
installs :func:`catch_interrupts` instead: the first Ctrl-C prints ``trebuchet: interrupted``
on stderr and unwinds with ``SystemExit(130)`` (status 128 + SIGINT, as a shell reports a
command it stopped), so the ``finally`` blocks of :mod:`trebuchet.core.output` remove a
half-written output; a second Ctrl-C ends the process at once.

So that an interrupt while the package itself is still importing is quiet too, ``import
trebuchet`` installs the handler when, and only when, the process is the ``trebuchet``
command (:func:`started_as_command`); a program or a notebook that imports the package keeps
its own Ctrl-C. An interrupt that lands inside an import ends the process at once, after the
line (:func:`_importing` says why). This module imports nothing but the standard library's
``os``, ``signal`` and ``sys``.
"""

from __future__ import annotations

import os
import signal
import sys
from collections.abc import Callable
from typing import Any

__all__ = ["INTERRUPTED", "MESSAGE", "catch_interrupts", "end_quietly", "restore",
           "say_interrupted", "started_as_command"]

INTERRUPTED = 130  # status after Ctrl-C: 128 + SIGINT, as a shell reports it
MESSAGE = "trebuchet: interrupted"

_state = {"owner": os.getpid(), "said": False}


def _interrupted(signum: int, frame: Any) -> None:
    """First SIGINT: say so, then unwind with status 130; a second one ends at once."""
    if os.getpid() != _state["owner"]:  # a worker forked from the command (a sweep's pool):
        return                          # the command decides, and stops the pool
    signal.signal(signal.SIGINT, _end_now)
    _close_progress_bars()
    say_interrupted()
    if _importing(frame):  # a module half initialised cannot unwind cleanly: end here
        os._exit(INTERRUPTED)
    raise SystemExit(INTERRUPTED)


def _importing(frame: Any) -> bool:
    """The interrupt landed while a module was being imported. Unwinding from there is not
    safe: a compiled module's initialisation (scipy's HiGHS wrapper, for one) turns the
    ``SystemExit`` into ``ImportError: initialization failed`` with a traceback, and a
    ``try: import ... except ImportError`` in a library would swallow it and go on. Nothing
    is written while the command imports (outputs are written whole at its end, and a
    temporary file a killed run leaves is removed by the next: :mod:`trebuchet.core.output`)."""
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib"):
            return True
        frame = frame.f_back
    return False


def _end_now(signum: int, frame: Any) -> None:
    """SIGINT while unwinding after the first one, or after the command is done."""
    if os.getpid() == _state["owner"]:
        say_interrupted()
        os._exit(INTERRUPTED)


def _close_progress_bars() -> None:
    """Take a sweep's tqdm bar off the screen, so that the message is the one line left (the
    bar is closed again, to no effect, as the command unwinds)."""
    tqdm = sys.modules.get("tqdm.std")
    for bar in list(getattr(getattr(tqdm, "tqdm", None), "_instances", ())):
        try:
            bar.leave = False
            bar.close()
        except Exception:  # noqa: BLE001 - a bar that cannot close stays; the message follows
            pass


def say_interrupted() -> None:
    """:data:`MESSAGE` on stderr, once per process; a raw write, since the handler may run
    in the middle of a print to stderr (a progress line)."""
    if _state["said"]:
        return
    _state["said"] = True
    try:
        os.write(sys.stderr.fileno(), (MESSAGE + "\n").encode())
    except (OSError, ValueError, AttributeError):  # no stderr (closed, replaced)
        pass


def _install(handler: Callable[[int, Any], None] | Any) -> Any:
    try:
        return signal.signal(signal.SIGINT, handler)
    except (ValueError, OSError, TypeError):  # not the main thread: Python's own handling
        return None


def catch_interrupts() -> Any:
    """Handle Ctrl-C as the module doc says, from now on in this process; returns the handler
    it replaces (None where none can be set: not the main thread), for :func:`restore`."""
    _state["owner"] = os.getpid()
    return _install(_interrupted)


def end_quietly() -> None:
    """After the command: a Ctrl-C while the interpreter shuts down ends it at once, quietly
    but for the one line."""
    _install(_end_now)


def restore(previous: Any) -> None:
    """Put back the handler :func:`catch_interrupts` replaced (a test or a program that called
    ``trebuchet.cli.main``)."""
    if previous is not None:
        _install(previous)
        _state["said"] = False


def started_as_command() -> bool:
    """This process is the ``trebuchet`` command (its console script), not a program that
    imports the package. (``python -m trebuchet.cli`` installs the handler in that module.)"""
    main = sys.modules.get("__main__")
    name = os.path.basename(getattr(main, "__file__", None) or "")
    return name in ("trebuchet", "trebuchet.exe", "trebuchet-script.py")
