"""Errors and warnings that reach the user.

A :class:`TrebuchetInputError` is a user's mistake (a bad scene key, a bad log
row, a non-physical request). Its message names the file, row or key and what
is wrong; the command line prints it as one line and exits with status 2.
"""

from __future__ import annotations


class TrebuchetInputError(ValueError):
    """Bad input from the user: the message names file, row or key and the problem."""


def check_choice(owner: str, name: str, value: object, options: tuple) -> None:
    """Refuse ``value`` of the setting ``name`` unless it is one of ``options``: the message
    names ``owner`` (the function or settings class), the setting and the choices."""
    if value not in options:
        raise TrebuchetInputError(f"{owner}: {name} must be one of {tuple(options)}, "
                                  f"not {value!r}")


class TrebuchetDataWarning(UserWarning):
    """A repair made to user data (dropped duplicate frame, filled gap, unwrapped angle)."""


class ModelValidityWarning(UserWarning):
    """The model left its range of validity (slack sling, unresolved acceleration)."""
