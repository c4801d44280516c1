"""Errors and warnings that reach the user.

A :class:`TrebuchetInputError` is a user's mistake (a bad scene key, a bad log
row, a non-physical request). Its message names the file, row or key and what
is wrong; the command line prints it as one line and exits with status 2.
"""

from __future__ import annotations


class TrebuchetInputError(ValueError):
    """Bad input from the user: the message names file, row or key and the problem.

    Code that reads a file raises it with the place inside the file (:meth:`at`: ``"row 12,
    column 'theta'"``) and without the file's name; the one function that opened the file
    adds the name once (:meth:`in_file`): ``"shot.csv, row 12, column 'theta': ..."``.
    """

    def __init__(self, message: str, *, where: str | None = None) -> None:
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
    names ``owner`` (the function or settings class), the setting and the choices."""
    if value not in options:
        raise TrebuchetInputError(f"{owner}: {name} must be one of {tuple(options)}, "
                                  f"not {value!r}")


class TrebuchetDataWarning(UserWarning):
    """A repair made to user data (dropped duplicate frame, filled gap, unwrapped angle)."""


class ModelValidityWarning(UserWarning):
    """The model left its range of validity (slack sling, unresolved acceleration)."""
