"""The generic angle log: a CSV with a time column and angle columns.

Layout::

    # optional comment lines
    t (s),theta (deg),psi (deg),phi (deg)
    0.000,-50.0,-90.0,-180.0

* time: ``t`` or ``time`` (unit written: ``t (ms)``, ``time [s]``; without one, stated
  by ``time_unit=`` or decided from the frame pattern, see :mod:`.time_units`), or
  ``frame`` (frame numbers, needs ``fps``; ``t = frame / fps``). With both, the time
  column is used and the frame numbers are kept in the result's ``frame``.
* angles: ``theta``, ``psi``, ``phi`` (or ``θ``, ``ψ``, ``φ``), case-insensitive, unit in
  parentheses or brackets. An angle column without a unit is in the unit of
  ``angle_unit=``, else decided from the values by :func:`read_log` (the beam's sweep,
  see :func:`.units.decide_angle_unit`), the decision reported.
* delimiter: comma, semicolon or tab (decimal comma allowed with the latter two).
"""

from __future__ import annotations

import numpy as np

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.readers.mapping import Candidate, angle_default
from trebuchet.ingest.readers.source import LogSource
from trebuchet.ingest.readers.table import (
    Line,
    header_and_rows,
    numeric_column,
    sniff_delimiter,
)
from trebuchet.ingest.readers.time_units import decide_time_unit, stated_time_unit
from trebuchet.ingest.readers.timebase import check_time, frames_to_time
from trebuchet.ingest.readers.units import angle_factor, split_unit, time_factor

TIME_NAMES = frozenset({"t", "time"})
FRAME_NAMES = frozenset({"frame", "frames", "frame number", "frame_number"})


def read_generic(numbered: list[tuple[int, str]], fps: float | None,
                 time_unit: str | None = None) -> LogSource:
    """Read a generic angle log from its numbered non-blank lines (see the module doc)."""
    numbered = [(n, s) for n, s in numbered if not s.lstrip().startswith("#")]
    if not numbered:
        raise TrebuchetInputError("no header row (only comment lines)")
    delimiter = sniff_delimiter(numbered[0][1])
    header_line, data = header_and_rows(numbered, delimiter)
    header = header_line.cells
    names = [split_unit(h) for h in header]
    time_cols = [i for i, (n, _) in enumerate(names) if n.lower() in TIME_NAMES]
    frame_cols = [i for i, (n, _) in enumerate(names) if n.lower() in FRAME_NAMES]
    for cols, what in ((time_cols, "time"), (frame_cols, "frame")):
        if len(cols) > 1:
            raise TrebuchetInputError(
                f"several {what} columns ({', '.join(repr(header[i]) for i in cols)})"
            )
    rows = np.array([line.number for line in data])
    frame = None
    decisions = []
    if frame_cols:
        i = frame_cols[0]
        raw = numeric_column(data, i, header[i])
        if not time_cols:
            t, frame = frames_to_time(raw, rows, fps, header[i])
            time_label = header[i]
            decisions.append(f"time: frame numbers of '{header[i]}' / fps")
        elif np.isfinite(raw).all() and (raw == np.round(raw)).all():
            frame = raw.astype(np.int64)
    if time_cols:
        i = time_cols[0]
        time_label = header[i]
        raw = numeric_column(data, i, header[i])
        if names[i][1] is None:
            check_time(raw, rows, header[i])
            t, counted, _, decision = decide_time_unit(raw, rows, header[i], fps, time_unit,
                                                       "CSV")
            if counted is not None:
                frame = counted
        else:
            t = raw * time_factor(header[i], names[i][1], default=1.0)
            decision = stated_time_unit(header[i], names[i][1], time_unit)
        decisions.append(decision)
    elif not frame_cols:
        raise TrebuchetInputError(
            f"no time column: expected 't', 'time' or 'frame' "
            f"(columns found: {', '.join(repr(h) for h in header)})"
        )
    used = set(time_cols) | set(frame_cols)
    candidates = [
        Candidate(
            label=header[i],
            aliases=frozenset({header[i], names[i][0]}),
            default=angle_default(names[i][0]),
            data=_angle_getter(data, i, header[i], names[i][1]),
        )
        for i in range(len(header))
        if i not in used and header[i]
    ]
    unitless = frozenset(header[i] for i in range(len(header))
                         if i not in used and header[i] and names[i][1] is None)
    return LogSource(
        fmt="generic",
        t=t,
        rows=rows,
        time_label=time_label,
        angle_columns=candidates,
        frame=frame,
        fps=fps,
        unitless=unitless,
        decisions=decisions,
    )


def _angle_getter(data: list[Line], index: int, header: str, unit: str | None):
    """A function returning column ``index`` in rad (unit from the header), or as written
    when the header has no unit (read_log decides it)."""

    def get() -> np.ndarray:
        factor = angle_factor(header, unit, default=1.0)
        return numeric_column(data, index, header) * factor

    return get
