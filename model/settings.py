"""The simulator's settings as the command line names them: tolerances, output step, phase III.

Light on purpose (no numpy, nothing of the model): ``trebuchet``'s parser is built from these
(``simulate``, ``sweep``, ``report``) without importing the simulator, so that ``trebuchet
--help`` and every usage error answer at once. :mod:`trebuchet.model.simulate` and
:mod:`trebuchet.model.sweep` take them from here.
"""

from __future__ import annotations

import argparse

__all__ = ["DEFAULT_RTOL", "ACCURACY", "DEFAULT_AFTER_RELEASE", "MAX_DT", "output_step",
           "accuracy_option", "TIME_BUDGET", "MEMORY_BUDGET", "DESIGN_POPSIZE",
           "DESIGN_GENERATIONS", "memory_size", "positive_seconds", "add_budget_options"]

DEFAULT_RTOL = 1e-10
ACCURACY = {"fast": 1e-6, "default": DEFAULT_RTOL, "precise": 1e-12}  # named tolerances
DEFAULT_AFTER_RELEASE = 0.5  # s of phase III simulated by default
MAX_DT = 0.1  # s: a coarser output step misses the shot's events and peaks


# --------------------------------------------------------------------------- command-line values
# (shared by ``simulate`` and ``sweep``: one spelling, one check)


def output_step(text: str) -> float:
    """``--dt``: an output step in s, in (0, 0.1] (``simulate``, ``sweep``, ``report``)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: not a number of seconds") from None
    if not 0.0 < value <= MAX_DT:
        raise argparse.ArgumentTypeError(f"{text}: the output step must lie in (0, {MAX_DT:g}] "
                                         "s (a shot lasts about a second)")
    return value


def accuracy_option(text: str) -> float | str:
    """``--accuracy`` (also spelt ``--rtol``): a preset or a relative tolerance in (0, 1e-2)."""
    if text in ACCURACY:
        return text
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: give " + ", ".join(ACCURACY)
                                         + " or a tolerance such as 1e-8") from None
    if not 0.0 < value < 1e-2:
        raise argparse.ArgumentTypeError(f"{text}: a tolerance must lie between 0 and 1e-2")
    return value


# --------------------------------------------------------------------------- sweeps and designs
# (``sweep`` and ``design``: model/sweep_design.py and model/design_search.py take them here)

TIME_BUDGET = 60.0  # s one design may run in a worker process before it is stopped
MEMORY_BUDGET = 2 * 2**30  # bytes a worker may grow by running one design
DESIGN_POPSIZE = 8  # designs per varied key in a generation of the design search
DESIGN_GENERATIONS = 20  # generations of evolution at most
_SIZE_UNITS = {"": 1, "K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}


def memory_size(text: str) -> int:
    """``--memory-budget``: bytes from ``2G``, ``500M``, ``1.5G`` or a plain number of bytes."""
    import re

    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([KMGT]?)i?B?\s*", text,
                     re.IGNORECASE)
    if not m:
        raise argparse.ArgumentTypeError(f"{text!r}: give a size such as 2G, 500M or 1.5G")
    return int(float(m.group(1)) * _SIZE_UNITS[m.group(2).upper()])


def positive_seconds(text: str) -> float:
    """A positive, finite number of seconds (``--time-budget``)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: not a number of seconds") from None
    if not 0.0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"{text}: must be a positive number of seconds")
    return value


def add_budget_options(p: argparse.ArgumentParser) -> None:
    """``--time-budget`` and ``--memory-budget`` (``sweep`` and ``design``)."""
    p.add_argument("--time-budget", type=positive_seconds, default=TIME_BUDGET, metavar="S",
                   help="wall time one design may take in a worker process before it is "
                        f"stopped and marked over_budget (default {TIME_BUDGET:g} s)")
    p.add_argument("--memory-budget", type=memory_size, default=MEMORY_BUDGET,
                   metavar="SIZE", help="memory a worker may grow by running one design "
                                        f"(default {MEMORY_BUDGET / 2**30:g}G)")
