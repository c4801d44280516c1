"""DeepLabCut output: the CSV (``analyze_videos(..., save_as_csv=True)``) and the .h5.

Layout::

    scorer,DLC_resnet50_trebuchetMay1shuffle1_100000,DLC_resnet50_...,...
    bodyparts,pivot,pivot,pivot,spigot,spigot,spigot,...
    coords,x,y,likelihood,x,y,likelihood,...
    0,512.3,280.1,0.999,901.7,610.2,0.98,...

* multi-animal files have an ``individuals`` row before ``bodyparts``: the engine is the
  individual named by ``individual`` (the only one by default; several without a choice is
  an error listing them); the unique bodyparts of the individual ``single`` go with it.
  Points are named ``<individual>/<bodypart>`` (or ``<bodypart>`` alone when unique);
* the .h5 is a pandas HDF file (PyTables; key ``df_with_missing``, or ``tracks`` for
  stitched multi-animal tracks; "table" or "fixed" format) holding the same table: columns
  ``scorer / [individuals /] bodyparts / coords``, index the frame number; it is read with
  h5py, nothing unpickled (:mod:`.pandas_hdf`: a file with pickled objects is refused);
  its rows are numbered frame + 1 in messages;
* the first column is the frame index; there is no time: ``fps`` is required and
  ``t = frame / fps``;
* image coordinates in pixels with y pointing **down**: y is negated here so that the
  positions (and the result's ``points``) have y up;
* positions with a likelihood below ``min_likelihood`` become gaps (reported).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.readers.hdf5 import open_hdf5
from trebuchet.ingest.readers.keypoints import choose_individual, keypoint_source
from trebuchet.ingest.readers.mapping import Candidate, role_default
from trebuchet.ingest.readers.pandas_hdf import frame_keys, read_frame
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
    numbered: list[tuple[int, str]], fps: float | None, min_likelihood: float,
    individual: str | None = None,
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
    keep = None
    if "individuals" in header:
        cells = [_cell(header["individuals"], i) for i in range(1, n_columns)]
        found = list(dict.fromkeys(c for c in cells if c and c != UNIQUE))
        keep = {choose_individual(found, individual), UNIQUE, ""}
    elif individual is not None:
        raise TrebuchetInputError(
            f"individual={individual!r}, but this is a single-animal DeepLabCut file")
    parts: dict[str, dict[str, int]] = {}
    for i in range(1, n_columns):
        part = _cell(header["bodyparts"], i)
        if keep is not None:
            who = _cell(header["individuals"], i)
            if who not in keep:
                continue
            if who:
                part = f"{who}/{part}"
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


#: The individual under which multi-animal files keep their unique bodyparts.
UNIQUE = "single"
#: HDF keys DeepLabCut writes: analyses, and stitched multi-animal tracks.
H5_KEYS = ("df_with_missing", "tracks")


def read_deeplabcut_h5(source: str | Path | bytes, fps: float | None, min_likelihood: float,
                       individual: str | None = None) -> LogSource:
    """Read a DeepLabCut .h5 (pandas' HDF5 table, see the module doc) from its path or bytes,
    with h5py: nothing in the file is unpickled (:mod:`.pandas_hdf`). Errors leave the file's
    name to the caller, as the text readers do."""
    with open_hdf5(source) as f:
        keys = frame_keys(f)
        key = next((k for k in H5_KEYS if k in keys), keys[0] if len(keys) == 1 else None)
        if key is None:
            raise TrebuchetInputError(
                f"no DeepLabCut table in this HDF5 file (tables: {', '.join(keys) or 'none'};"
                f" expected {' or '.join(H5_KEYS)})")
        table = read_frame(f, key)
    names = table.names
    if "bodyparts" not in names or "coords" not in names:
        raise TrebuchetInputError.at(
            f"key '{key}'", "no DeepLabCut table (column levels: "
            f"{', '.join(str(n) for n in names) or 'none'}; expected scorer, bodyparts, coords)")
    chosen = None
    if "individuals" in names:
        who = names.index("individuals")
        found = list(dict.fromkeys(c[who] for c in table.columns if c[who] != UNIQUE))
        chosen = choose_individual(found, individual)
    elif individual is not None:
        raise TrebuchetInputError(
            f"individual={individual!r}, but this is a single-animal DeepLabCut file")
    seen: dict[str, dict[str, np.ndarray]] = {}
    for col in table.columns:
        level = dict(zip(names, col, strict=True))
        who = level.get("individuals")
        if who is not None and who not in (chosen, UNIQUE):
            continue
        name = f"{who}/{level['bodyparts']}" if who else str(level["bodyparts"])
        coord = str(level["coords"]).lower()
        if coord in ("x", "y", "likelihood") and col not in table.values:
            raise TrebuchetInputError.at(f"key '{key}'", f"column {'/'.join(col)} holds no "
                                         "numbers")
        if col in table.values:
            seen.setdefault(name, {})[coord] = table.values[col]
    parts: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray | None]] = {}
    for name, coords in seen.items():
        if "x" not in coords or "y" not in coords:
            raise TrebuchetInputError(f"bodypart '{name}' lacks an x or y column")
        parts[name] = (coords["x"], coords["y"], coords.get("likelihood"))
    frames = np.asarray(table.index, dtype=float) if table.index.dtype.kind in "fiu" else None
    if frames is None:
        raise TrebuchetInputError.at(f"key '{key}'", "its index is not frame numbers "
                                     f"({table.index.dtype})")
    return keypoint_source("deeplabcut", frames, np.arange(len(frames)) + 1, parts, fps,
                           min_likelihood)


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
