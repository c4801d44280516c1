"""Kinovea trajectory CSV (kinematics dialogs' export, or File > Export > CSV).

Layout::

    "Time";"Beam/pivot/X";"Beam/pivot/Y";"Beam/spigot/X";"Beam/spigot/Y"
    "0";"0,512";"1,204";"6,90";"-3,95"
    "4";"0,512";"1,204";;

* every cell quoted; empty cells (no quotes) for missing positions;
* separator ``;`` when the decimal mark is a comma (older versions: ``,`` with quoted
  decimal-comma numbers, both read);
* ``Time``: Kinovea writes it without a unit, in the unit of the user's time-code
  preference: s (ClassicTime, the default; whole ms up to 2025.1), ms (the kinematics
  dialogs of 0.8-0.9: whole ms; the Milliseconds preference: fractional), µs or frame
  numbers. ``time_unit=`` states it; else it is decided from the frame pattern
  (:mod:`.time_units`) and the decision reported. A unit in the header (``Time (s)``) is
  used. Kinovea can set a time origin anywhere: times may be negative;
* whole-millisecond times are replaced by exact frame times: ``round(t fps) / fps`` when
  ``fps`` is given, else a frame grid fitted to the times (kept only if it reproduces
  every time within 0.5 ms); other times go on the grid k/fps when ``fps`` is given and
  they lie within 0.001 frame of it (single precision);
* coordinates: world space (calibrated, y up) or image space (pixels, y down), which the
  header does not tell: :func:`read_log` tells them from the engine at rest;
* points are ``<object>/<point>`` and can be named that way, by ``<point>`` alone when
  unique, or by ``<object>`` when the object has a single point; coordinates are
  Kinovea's calibrated ones, y up.
"""

from __future__ import annotations

import re

import numpy as np

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.readers.mapping import Candidate, role_default
from trebuchet.ingest.readers.source import LogSource
from trebuchet.ingest.readers.table import (
    header_and_rows,
    numeric_column,
    point_getter,
    sniff_delimiter,
    table_lines,
)
from trebuchet.ingest.readers.time_units import decide_time_unit, stated_time_unit
from trebuchet.ingest.readers.timebase import check_time, snap_rounded_times
from trebuchet.ingest.readers.units import split_unit, time_factor

_COORD = re.compile(r"^(?P<point>.+)/(?P<axis>[XYxy])$")


def looks_like_kinovea(numbered: list[tuple[int, str]]) -> bool:
    """A header whose first cell is ``Time`` and with ``.../X`` or ``.../Y`` cells."""
    if not numbered:
        return False
    line = numbered[0][1]
    cells = table_lines([numbered[0]], sniff_delimiter(line))[0].cells
    if not cells or split_unit(cells[0])[0].lower() != "time":
        return False
    return any(_COORD.match(c) for c in cells[1:])


def read_kinovea(numbered: list[tuple[int, str]], fps: float | None,
                 time_unit: str | None = None) -> LogSource:
    """Read a Kinovea trajectory CSV (see the module doc)."""
    delimiter = sniff_delimiter(numbered[0][1])
    header_line, data = header_and_rows(numbered, delimiter)
    header = header_line.cells
    rows = np.array([line.number for line in data])
    raw = numeric_column(data, 0, header[0])
    check_time(raw, rows, header[0])
    _, unit = split_unit(header[0])
    frame = None
    if unit is None:
        t, frame, unit, decision = decide_time_unit(raw, rows, header[0], fps, time_unit,
                                                    "Kinovea")
    else:
        t = raw * time_factor(header[0], unit, default=1e-3)
        decision = stated_time_unit(header[0], unit, time_unit)
    repairs: list[str] = []
    ms = t * 1e3
    if frame is None and (np.abs(ms - np.round(ms)) < 1e-6).all():
        # whole ms (the kinematics dialogs, ClassicTime up to 2025.1); a fitted frame rate
        # is only reported in the note, never taken as the file's fps
        t, _, note = snap_rounded_times(t, rows, fps, step=1e-3)
        if note:
            repairs.append(note)
    elif frame is None and fps is not None:
        t = _on_frame_grid(t, fps)
    pairs = _point_columns(header)
    objects: dict[str, int] = {}
    for name in pairs:
        obj = name.split("/")[0]
        objects[obj] = objects.get(obj, 0) + 1
    point_names = [name.split("/", 1)[1] if "/" in name else name for name in pairs]
    tracks = []
    for name, (ix, iy) in pairs.items():
        obj, _, point = name.partition("/")
        aliases = {name}
        if point and point_names.count(point) == 1:
            aliases.add(point)
        if objects[obj] == 1:
            aliases.add(obj)
        default = role_default(point) if point else None
        if default is None and objects[obj] == 1:
            default = role_default(obj)
        tracks.append(
            Candidate(
                label=name,
                aliases=frozenset(aliases),
                default=default,
                data=point_getter(data, ix, iy, f"{name}/X", f"{name}/Y"),
            )
        )
    return LogSource(
        fmt="kinovea",
        t=t,
        rows=rows,
        time_label=header[0],
        point_tracks=tracks,
        frame=frame,
        fps=fps,
        repairs=repairs,
        decisions=[decision],
        y_down=None,
    )


def _on_frame_grid(t: np.ndarray, fps: float) -> np.ndarray:
    """Kinovea's times (frames from the time origin times the frame interval, written in
    single precision with 7 digits) put back on the frame grid k/fps when each lies within
    0.001 of a frame from it; else as written."""
    k = np.round(t * fps)
    if (np.abs(t * fps - k) <= 1e-3).all():
        return k / fps
    return t


def _point_columns(header: list[str]) -> dict[str, tuple[int, int]]:
    """``{"object/point": (x column, y column)}``; error for an X without its Y."""
    xs: dict[str, int] = {}
    ys: dict[str, int] = {}
    for i, cell in enumerate(header[1:], start=1):
        m = _COORD.match(cell)
        if m:
            (xs if m.group("axis") in "Xx" else ys)[m.group("point")] = i
    pairs = {}
    for name, ix in xs.items():
        if name not in ys:
            raise TrebuchetInputError(f"column '{name}/X' has no '{name}/Y'")
        pairs[name] = (ix, ys[name])
    return pairs
