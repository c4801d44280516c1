"""The simulator's settings as the command line names them: tolerances, output step, phase III.

Light on purpose (no numpy, nothing of the model): ``trebuchet``'s parser is built from these
(``simulate``, ``sweep``, ``report``) without importing the simulator, so that ``trebuchet
--help`` and every usage error answer at once. :mod:`trebuchet.model.simulate` and
:mod:`trebuchet.model.sweep` take them from here.
"""

from __future__ import annotations

import argparse

__all__ = ["DEFAULT_RTOL", "ACCURACY", "DEFAULT_AFTER_RELEASE", "MAX_DT", "output_step",
           "accuracy_option"]

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
