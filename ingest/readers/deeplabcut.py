"""DeepLabCut CSV (``analyze_videos(..., save_as_csv=True)``).

Layout::

    scorer,DLC_resnet50_trebuchetMay1shuffle1_100000,DLC_resnet50_...,...
    bodyparts,pivot,pivot,pivot,spigot,spigot,spigot,...
    coords,x,y,likelihood,x,y,likelihood,...
    0,512.3,280.1,0.999,901.7,610.2,0.98,...

* multi-animal files have an ``individuals`` row before ``bodyparts``; their points are
  named ``<individual>/<bodypart>`` (or ``<bodypart>`` alone when unique);
* the first column is the frame index; there is no time: ``fps`` is required and
  ``t = frame / fps``;
* image coordinates in pixels with y pointing **down**: y is negated here so that the
  positions (and ``attrs["points"]``) have y up;
* positions with a likelihood below ``min_likelihood`` become gaps (reported).
"""

from __future__ import annotations

import numpy as np

from trebuchet.errors import TrebuchetInputError
from trebuchet.ingest.readers.mapping import Candidate, role_default
from trebuchet.ingest.readers.source import LogSource
from trebuchet.ingest.readers.table import (
    Line,
    check_row_lengths,
    format_rows,
    numeric_column,
    table_lines,
)
from trebuchet.ingest.readers.timebase import frames_to_time


def looks_like_deeplabcut(numbered: list[tuple[int, str]]) -> bool:
    """The first cell of the first line is ``scorer`` and a ``coords`` row follows."""
    if len(numbered) < 3:
        return bool(numbered) and numbered[0][1].lower().startswith("scorer,")
    first = [line.split(",", 1)[0].strip().lower() for _, line in numbered[:4]]
    return first[0] == "scorer" and "coords" in first


def read_deeplabcut(
    numbered: list[tuple[int, str]], fps: float | None, min_likelihood: float
) -> LogSource:
    """Read a DeepLabCut CSV (see the module doc)."""
    lines = table_lines(numbered, ",")
    kinds = [line.cells[0].lower() if line.cells else "" for line in lines[:4]]
    if "coords" not in kinds:
        raise TrebuchetInputError(
            "a DeepLabCut file needs the header rows scorer, bodyparts and coords"
        )
    n_header = kinds.index("coords") + 1
    header = {kinds[k]: lines[k].cells for k in range(n_header)}
    if "bodyparts" not in header:
        raise TrebuchetInputError("DeepLabCut header without a 'bodyparts' row")
    coords_line = lines[n_header - 1]
    data = lines[n_header:]
    if not data:
        raise TrebuchetInputError(
            f"only header rows (up to row {coords_line.number}), no data rows"
        )
    n_columns = len(coords_line.cells)
    check_row_lengths(data, n_columns)
    rows = np.array([line.number for line in data])
    frame_raw = numeric_column(data, 0, "frame index")
    t, frame = frames_to_time(frame_raw, rows, fps, "frame index")
    parts: dict[str, dict[str, int]] = {}
    for i in range(1, n_columns):
        part = _cell(header["bodyparts"], i)
        if "individuals" in header and _cell(header["individuals"], i):
            part = f"{_cell(header['individuals'], i)}/{part}"
        parts.setdefault(part, {})[coords_line.cells[i].lower()] = i
    bare = [p.rsplit("/", 1)[-1] for p in parts]
    tracks = []
    for name, cols in parts.items():
        if "x" not in cols or "y" not in cols:
            raise TrebuchetInputError.at(
                f"row {coords_line.number}", f"bodypart '{name}' lacks an x or y column"
            )
        short = name.rsplit("/", 1)[-1]
        aliases = {name} | ({short} if bare.count(short) == 1 else set())
        tracks.append(
            Candidate(
                label=name,
                aliases=frozenset(aliases),
                default=role_default(short) if bare.count(short) == 1 else None,
                data=_point_getter(data, cols, name, min_likelihood),
            )
        )
    return LogSource(
        fmt="deeplabcut",
        t=t,
        rows=rows,
        time_label="frame index",
        point_tracks=tracks,
        frame=frame,
        fps=fps,
    )


def _cell(cells: list[str], i: int) -> str:
    """Cell ``i`` of a header row, empty if the row is short."""
    return cells[i] if i < len(cells) else ""


def _point_getter(
    data: list[Line], cols: dict[str, int], name: str, min_likelihood: float
):
    """A function returning (x, -y_image, note) of one bodypart, low likelihood as NaN."""

    def get() -> tuple[np.ndarray, np.ndarray, str | None]:
        x = numeric_column(data, cols["x"], f"{name}/x")
        y = -numeric_column(data, cols["y"], f"{name}/y")
        note = None
        if "likelihood" in cols:
            p = numeric_column(data, cols["likelihood"], f"{name}/likelihood")
            low = (p < min_likelihood) & np.isfinite(x) & np.isfinite(y)
            if low.any():
                x = np.where(low, np.nan, x)
                y = np.where(low, np.nan, y)
                rows = [line.number for line, bad in zip(data, low, strict=True) if bad]
                note = (
                    f"{int(low.sum())} positions of '{name}' with likelihood below "
                    f"{min_likelihood:g} treated as gaps ({format_rows(rows)})"
                )
        return x, y, note

    return get
