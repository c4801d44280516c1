"""Exports of Tracker (Open Source Physics, physlets.org/tracker): File > Export > Data.

Layout, as Tracker writes it (tab by default; comma, semicolon or space possible)::

    #multi:                         <- only when several tracks are exported
    <tab>beam<tab><tab>arm<tab>     <- track names, each above its first column
    t<tab>θ<tab>ω<tab>θ<tab>        <- column names, with a trailing delimiter
    0,000E0<tab>-5,0E1<tab>...      <- numbers; decimal comma in some locales

* time: the first column, ``t`` in s (or ``frame`` numbers, which need ``fps``);
* angles: Tracker's angle columns (``θ``, ``θv``, ..., ``ω``, ``α``) are written in
  degrees (Tracker's default) or radians (its preference) under the same names; read_log
  takes ``angle_unit=`` or decides from the values, and checks the time against the
  track's ω (dθ/dt in the same unit). Other columns (data tracks) need a unit in the
  header to be used as angles;
* a column is named ``<track>/<column>`` (e.g. ``beam/θ``); a track's name alone means
  its ``θ`` column (``columns={"beam": "theta", "arm": "psi", "sling": "phi"}``). A
  track named ``theta``, ``psi`` or ``phi`` (or ``θ``, ``ψ``, ``φ``) needs no mapping;
* point masses (tracks with ``x`` and ``y``, y up) can give the angles with ``points=``;
* missing frames are empty cells; rows with only a time (Tracker writes one for every
  video frame even with a step size above 1) are dropped by the common repairs.
"""

from __future__ import annotations

import numpy as np

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.readers.mapping import Candidate, angle_default, role_default
from trebuchet.ingest.readers.source import LogSource
from trebuchet.ingest.readers.table import (
    Line,
    check_row_lengths,
    numeric_column,
    point_getter,
    split_cells,
    table_lines,
)
from trebuchet.ingest.readers.time_units import decide_time_unit, stated_time_unit
from trebuchet.ingest.readers.timebase import frames_to_time
from trebuchet.ingest.readers.units import ANGLE_UNITS, angle_factor, split_unit, time_factor

TIME_HEADERS = ("t", "frame")
#: Tracker's angle columns: angle, angular velocity and acceleration, all written in the
#: angle-unit preference (degrees or radians) under the same names.
ANGLE_SIGNS = ("θ", "ω", "α")


def _delimiter(header: str) -> str:
    """Tracker ends its header row with the delimiter; fall back to the usual order."""
    for d in ("\t", ";", ",", " "):
        if header.endswith(d):
            return d
    for d in ("\t", ";", ","):
        if d in header:
            return d
    return " "


def _split(line: str, delimiter: str, number: int | None = None) -> list[str]:
    """Cells of a Tracker line (row ``number`` in errors); for a space delimiter, every
    space separates (keeps columns)."""
    if delimiter == " ":
        return [c.strip() for c in line.split(" ")]
    try:
        return split_cells(line, delimiter)
    except TrebuchetInputError as exc:
        raise TrebuchetInputError.at(f"row {number}", exc.message) from None


def looks_like_tracker(numbered: list[tuple[int, str]]) -> bool:
    """``#multi:`` first, or a name row and then a header ``t``/``frame`` + delimiter."""
    if not numbered:
        return False
    if numbered[0][1].strip().startswith("#multi:"):
        return True
    if len(numbered) < 2:
        return False
    header = numbered[1][1].rstrip("\r\n")
    d = _delimiter(header)
    if not header.endswith(d):
        return False
    first = split_unit(_split(header, d, numbered[1][0])[0])[0]
    names = [c for c in _split(numbered[0][1], d, numbered[0][0]) if c]
    return first in TIME_HEADERS and len(names) >= 1


def read_tracker(numbered: list[tuple[int, str]], fps: float | None,
                time_unit: str | None = None) -> LogSource:
    """Read a Tracker export (see the module doc)."""
    lines = list(numbered)
    if lines[0][1].strip().startswith("#multi:"):
        lines = lines[1:]
    if len(lines) < 2:
        raise TrebuchetInputError("a Tracker export needs a track-name row and a header")
    (name_no, name_text), (header_no, header_text) = lines[0], lines[1]
    d = _delimiter(header_text.rstrip("\r\n"))
    names = _split(name_text, d, name_no)
    header = _split(header_text, d, header_no)
    while header and not header[-1]:
        header.pop()
    if not header or split_unit(header[0])[0] not in TIME_HEADERS:
        raise TrebuchetInputError.at(
            f"row {header_no}", f"a Tracker header starts with 't' or 'frame', "
            f"found {header[0] if header else ''!r}"
        )
    data = [Line(n, _split(text, d)) for n, text in lines[2:]] if d == " " else table_lines(
        lines[2:], d
    )
    if not data:
        raise TrebuchetInputError(f"only header rows (up to row {header_no}), no data")
    check_row_lengths(data, len(header))
    rows = np.array([line.number for line in data])
    raw_time = numeric_column(data, 0, header[0])
    frame = None
    time_name, unit_written = split_unit(header[0])
    if time_name == "frame":
        t, frame = frames_to_time(raw_time, rows, fps, header[0])
        decision = f"time: frame numbers of '{header[0]}' / fps"
    elif unit_written is not None:
        t = raw_time * time_factor(header[0], unit_written, default=1.0)
        decision = stated_time_unit(header[0], unit_written, time_unit)
    elif time_unit is not None:
        t, frame, _, decision = decide_time_unit(raw_time, rows, header[0], fps, time_unit,
                                                 "Tracker")
    else:
        t = raw_time
        decision = f"time unit of '{header[0]}': s (Tracker writes its time in s)"
    tracks = _track_spans(names, len(header))
    angle_columns: list[Candidate] = []
    point_tracks: list[Candidate] = []
    unitless: set[str] = set()
    rates: dict = {}
    for track, cols in tracks:
        theta_cols = [i for i in cols if split_unit(header[i])[0] == "θ"]
        by_name = {split_unit(header[i])[0]: i for i in cols}
        for i in cols:
            base, unit = split_unit(header[i])
            label = f"{track}/{header[i]}" if track else header[i]
            aliases = {label, header[i], base, f"{track}/{base}"}
            if track and (i in theta_cols[:1] or len(cols) == 1):
                aliases.add(track)
            default = angle_default(base) if base != "θ" else None
            if track and i in theta_cols[:1] and default is None:
                default = angle_default(track)
            angle_columns.append(
                Candidate(
                    label=label,
                    aliases=frozenset(aliases),
                    default=default,
                    data=_angle_getter(data, i, label, base, unit),
                )
            )
            if unit is None and base.startswith(ANGLE_SIGNS):
                unitless.add(label)
            if base == "θ" and "ω" in by_name and split_unit(header[by_name["ω"]])[1] is None:
                rates[label] = _raw_getter(data, by_name["ω"], f"{track}/ω" if track else "ω")
        if "x" in by_name and "y" in by_name and track:
            point_tracks.append(
                Candidate(
                    label=track,
                    aliases=frozenset({track}),
                    default=role_default(track),
                    data=point_getter(data, by_name["x"], by_name["y"], f"{track}/x",
                                      f"{track}/y"),
                )
            )
    return LogSource(
        fmt="tracker",
        t=t,
        rows=rows,
        time_label=header[0],
        angle_columns=angle_columns,
        point_tracks=point_tracks,
        frame=frame,
        fps=fps,
        unitless=frozenset(unitless),
        rates=rates,
        decisions=[decision],
    )


def _track_spans(names: list[str], n_columns: int) -> list[tuple[str, list[int]]]:
    """Columns (after the time column) of each track, from the positions of the names."""
    starts = [(i, n) for i, n in enumerate(names[:n_columns]) if n]
    if not starts:
        return [("", list(range(1, n_columns)))]
    spans = []
    for k, (i, n) in enumerate(starts):
        end = starts[k + 1][0] if k + 1 < len(starts) else n_columns
        cols = [c for c in range(max(i, 1), end)]
        if cols:
            spans.append((n, cols))
    return spans


def _angle_getter(
    data: list[Line], index: int, label: str, base: str, unit: str | None
):
    """A function returning a Tracker column in rad, or as written for Tracker's own angle
    columns (θ..., ω, α) without a unit (read_log decides it: degrees or radians by the
    preference, under the same names)."""

    def get() -> np.ndarray:
        if unit is None and not base.startswith(ANGLE_SIGNS):
            raise TrebuchetInputError.at(
                f"column '{label}'", f"no unit; write it into the header, e.g. "
                f"'{base} (deg)' (known: {', '.join(sorted(ANGLE_UNITS))})"
            )
        factor = angle_factor(label, unit, default=1.0)
        return numeric_column(data, index, label) * factor

    return get


def _raw_getter(data: list[Line], index: int, label: str):
    """A function returning a column as written."""
    return lambda: numeric_column(data, index, label)
