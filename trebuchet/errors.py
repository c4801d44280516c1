"""Errors and warnings that reach the user.

A :class:`TrebuchetInputError` is a user's mistake (a bad scene key, a bad log
row, a non-physical request). Its message names the file, row or key and what
is wrong; the command line prints it as one line and exits with status 2.
"""

from __future__ import annotations


class TrebuchetInputError(ValueError):
    """Bad input from the user: the message names file, row or key and the problem."""


class TrebuchetDataWarning(UserWarning):
    """A repair made to user data (dropped duplicate frame, filled gap, unwrapped angle)."""


class ModelValidityWarning(UserWarning):
    """The model left its range of validity (slack sling, unresolved acceleration)."""
