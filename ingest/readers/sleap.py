"""SLEAP analysis exports: the HDF5 (File > Export Analysis HDF5, ``sleap-convert --format
analysis``) and the CSV (File > Export Analysis CSV).

Layouts, as SLEAP writes them (talmolab/sleap, ``sleap/info/write_tracking_h5.py``;
see docs/formats.md)::

    HDF5 (h5py order; SLEAP transposes every array for MATLAB)
      tracks           (tracks, 2, nodes, frames)  x, y in px, NaN where not predicted
      track_occupancy  (frames, tracks)
      point_scores     (tracks, nodes, frames)
      node_names       (nodes,)  byte strings
      track_names      (tracks,) byte strings; empty when the project has no tracks

    CSV
      track,frame_idx,instance.score,<node>.x,<node>.y,<node>.score,...
      track_0,0,4.02,959.7,777.2,0.86,...       <- frames without an instance are absent

* the frame index is the time base: ``t = frame / fps`` (``fps`` is required);
* the track is chosen by ``individual`` (the only one by default; several without a choice
  is an error listing them); an empty track name means an untracked project;
* pixels with y down: flipped to y up; a point whose score is below ``min_likelihood``
  becomes a gap (reported). User-labelled points have no score and are kept.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from trebuchet.errors import TrebuchetInputError
from trebuchet.ingest.readers.keypoints import choose_individual, keypoint_source
from trebuchet.ingest.readers.source import LogSource
from trebuchet.ingest.readers.table import check_row_lengths, numeric_column, table_lines

HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
REQUIRED = ("tracks", "node_names")


def is_hdf5(path: str | Path) -> bool:
    """Whether the file starts with the HDF5 signature."""
    try:
        with open(path, "rb") as f:
            return f.read(8) == HDF5_SIGNATURE
    except OSError:
        return False


def _h5py():
    try:
        import h5py
    except ImportError:
        raise TrebuchetInputError(
            "reading an HDF5 file needs the package h5py (pip install h5py)"
        ) from None
    return h5py


def looks_like_sleap_h5(path: str | Path) -> bool:
    """An HDF5 file with SLEAP's ``tracks`` and ``node_names`` datasets."""
    if not is_hdf5(path):
        return False
    try:
        import h5py
    except ImportError:
        return False
    with h5py.File(path, "r") as f:
        return all(k in f for k in REQUIRED)


def _names(dataset) -> list[str]:
    """Byte or text strings of a 1-D dataset (empty, or float, when SLEAP had none)."""
    if dataset.shape == (0,) or dataset.dtype.kind not in "SOU":
        return []
    return [v.decode() if isinstance(v, bytes) else str(v) for v in dataset[()]]


def read_sleap_h5(path: str | Path, fps: float | None, min_likelihood: float,
                  individual: str | None = None) -> LogSource:
    """Read a SLEAP analysis HDF5 (see the module doc). ``path`` is opened here; errors
    leave its name to the caller, as the text readers do. Rows are numbered frame + 1."""
    h5py = _h5py()
    with h5py.File(path, "r") as f:
        missing = [k for k in REQUIRED if k not in f]
        if missing:
            raise TrebuchetInputError(
                f"a SLEAP analysis file needs the datasets {', '.join(REQUIRED)} "
                f"(missing: {', '.join(missing)})")
        tracks = np.asarray(f["tracks"][()], dtype=float).T     # frames, nodes, 2, tracks
        scores = (np.asarray(f["point_scores"][()], dtype=float).T
                  if "point_scores" in f else None)              # frames, nodes, tracks
        nodes = _names(f["node_names"])
        names = _names(f["track_names"]) if "track_names" in f else []
    if tracks.ndim != 4 or tracks.shape[2] != 2 or tracks.shape[1] != len(nodes):
        raise TrebuchetInputError(
            f"dataset 'tracks' has shape {tracks.T.shape}, expected (tracks, 2, "
            f"{len(nodes)} nodes, frames) as SLEAP writes it")
    n_frames, _, _, n_tracks = tracks.shape
    labels = names if names else [""] * n_tracks
    if len(labels) != n_tracks:
        raise TrebuchetInputError(
            f"{len(names)} track names for {n_tracks} tracks in 'tracks'")
    chosen = choose_individual(names, individual, "track")
    k = labels.index(chosen) if chosen else 0
    present = ~np.isnan(tracks[:, :, :, k]).all(axis=(1, 2))
    frames = np.nonzero(present)[0]
    if frames.size == 0:
        raise TrebuchetInputError(f"track {chosen or 0!r} has no predicted frame")
    parts = {}
    for j, node in enumerate(nodes):
        score = scores[frames, j, k] if scores is not None else None
        parts[node] = (tracks[frames, j, 0, k], tracks[frames, j, 1, k], score)
    return keypoint_source("sleap", frames, frames + 1, parts, fps, min_likelihood,
                           time_label="frame index", score_name="score")


def looks_like_sleap_csv(numbered: list[tuple[int, str]]) -> bool:
    """A header starting ``track,frame_idx`` with ``<node>.x`` columns."""
    if not numbered:
        return False
    cells = [c.strip() for c in numbered[0][1].split(",")]
    return cells[:2] == ["track", "frame_idx"] and any(c.endswith(".x") for c in cells)


def read_sleap_csv(numbered: list[tuple[int, str]], fps: float | None,
                   min_likelihood: float, individual: str | None = None) -> LogSource:
    """Read a SLEAP analysis CSV (see the module doc)."""
    header, *data = table_lines(numbered, ",")
    if not data:
        raise TrebuchetInputError("only a header row, no instance")
    cols = header.cells
    check_row_lengths(data, len(cols))
    track_cells = [line.cells[0].strip() if line.cells else "" for line in data]
    names = list(dict.fromkeys(c for c in track_cells if c))
    chosen = choose_individual(names, individual, "track")
    mine = [line for line, c in zip(data, track_cells, strict=True) if c == (chosen or "")]
    if not mine:
        raise TrebuchetInputError(f"no row of track {chosen!r}")
    rows = np.array([line.number for line in mine])
    frames = numeric_column(mine, 1, "frame_idx")
    index = {c: i for i, c in enumerate(cols)}
    parts = {}
    for c in cols:
        if not c.endswith(".x"):
            continue
        node = c[:-2]
        if f"{node}.y" not in index:
            raise TrebuchetInputError.at(f"column '{c}'", f"no '{node}.y' beside it")
        x = numeric_column(mine, index[c], c)
        y = numeric_column(mine, index[f"{node}.y"], f"{node}.y")
        score = (numeric_column(mine, index[f"{node}.score"], f"{node}.score")
                 if f"{node}.score" in index else None)
        parts[node] = (x, y, score)
    return keypoint_source("sleap", frames, rows, parts, fps, min_likelihood,
                           time_label="frame_idx", score_name="score")
