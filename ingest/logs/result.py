"""What :func:`~trebuchet.ingest.logs.read_log.read_log` knows about the log it read, as one
typed value: ``df.attrs["log"]``, a :class:`ReadLog`.

Pandas deep-copies ``attrs`` on every operation (``df.copy()``, ``df[mask]``, ...):
:class:`ReadLog` is frozen and returns itself from ``copy.deepcopy``, so the copy is free
and every table derived from the log shares it. It compares by identity (``eq=False``):
``pandas.concat`` keeps attrs only when every input's are equal, and two logs read from
the same file are then still equal (the same object) after any derivation.

It is the only key ``read_log`` writes in ``attrs`` (the separate keys of earlier
releases, ``attrs["source"]``, ``["format"]``, ``["repairs"]``, ... are gone): read
``attrs["log"]``, or :func:`read_log_info` for a table that may not come from
``read_log``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np
import pandas as pd


@dataclass(frozen=True, eq=False)
class ReadLog:
    """How a log file was read.

    Attributes
    ----------
    source:
        The path as given to ``read_log`` (``str``).
    format:
        ``"generic"``, ``"tracker"``, ``"kinovea"``, ``"deeplabcut"``, ``"sleap"`` or
        ``"anipose"``.
    repairs:
        Sentences: what was changed or left out, each warned as a ``TrebuchetDataWarning``
        (inferred units are among them).
    decisions:
        Sentences: how each unit was decided (time; angles or the y axis), stated in the
        header, by keyword, or inferred and from what evidence.
    columns:
        Which column (or pair of points, ``"a -> b"``) gave each angle.
    fps:
        The frame rate given (1/s), or None.
    frame:
        Frame numbers of the rows (int64, read-only) when the file has them, else None.
    points:
        For point files: ``t`` and ``<role>_x``, ``<role>_y`` (read-only float arrays, one
        per row, in the file's length unit, y up); None otherwise. ``pandas.DataFrame(
        dict(log.points))`` is the table.
    point_names:
        For point files: the file's point that gave each role.
    leaves_sling:
        ``(t, sd)`` in s when a tracked projectile leaves its sling's circle, else None.
    lines:
        The file's line number (1-based) of each row (int64, read-only): messages about
        rows name these, the numbers a user sees in an editor.
    held:
        ``(role, first, last)`` (s) of each run of positions left out because the tracker
        stood still on something while the engine moved (a tracker stuck on a frame
        member): the stone's track ends there, not at its release.
    """

    source: str
    format: str
    repairs: tuple[str, ...] = ()
    decisions: tuple[str, ...] = ()
    columns: Any = field(default_factory=dict)
    fps: float | None = None
    frame: np.ndarray | None = field(default=None, repr=False)
    points: Any = field(default=None, repr=False)
    point_names: Any = None
    leaves_sling: tuple[float, float] | None = None
    lines: np.ndarray | None = field(default=None, repr=False)
    held: tuple[tuple[str, float, float], ...] = ()

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "repairs", tuple(self.repairs))
        set_(self, "decisions", tuple(self.decisions))
        set_(self, "held", tuple(tuple(h) for h in self.held))
        set_(self, "columns", MappingProxyType(dict(self.columns)))
        if self.frame is not None:
            set_(self, "frame", _frozen(np.asarray(self.frame, dtype=np.int64)))
        if self.lines is not None:
            set_(self, "lines", _frozen(np.asarray(self.lines, dtype=np.int64)))
        if self.points is not None:
            set_(self, "points", MappingProxyType(
                {k: _frozen(np.asarray(v, dtype=float)) for k, v in self.points.items()}))
        if self.point_names is not None:
            set_(self, "point_names", MappingProxyType(dict(self.point_names)))

    def __deepcopy__(self, memo: dict) -> ReadLog:
        return self

    def __copy__(self) -> ReadLog:
        return self

    def __reduce__(self):
        """Pickled as its plain fields (mapping proxies do not pickle)."""
        return (_rebuild, (self.source, self.format, self.repairs, self.decisions,
                           dict(self.columns), self.fps, self.frame,
                           None if self.points is None else dict(self.points),
                           None if self.point_names is None else dict(self.point_names),
                           self.leaves_sling, self.lines, self.held))


def _frozen(a: np.ndarray) -> np.ndarray:
    a = a.copy()
    a.flags.writeable = False
    return a


def _rebuild(*fields) -> ReadLog:
    return ReadLog(*fields)


def read_log_info(df: pd.DataFrame) -> ReadLog | None:
    """``df.attrs["log"]`` when ``df`` comes from ``read_log`` (or a table derived from it),
    else None."""
    info = df.attrs.get("log") if isinstance(df, pd.DataFrame) else None
    return info if isinstance(info, ReadLog) else None
