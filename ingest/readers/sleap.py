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

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.readers.hdf5 import is_hdf5, open_hdf5
from trebuchet.ingest.readers.keypoints import choose_individual, keypoint_source
from trebuchet.ingest.readers.limits import MAX_DATASET_BYTES, MAX_ROWS
from trebuchet.ingest.readers.source import LogSource
from trebuchet.ingest.readers.table import check_row_lengths, numeric_column, table_lines

REQUIRED = ("tracks", "node_names")


def looks_like_sleap_h5(source: str | Path | bytes) -> bool:
    """An HDF5 file with SLEAP's ``tracks`` and ``node_names`` datasets."""
    if not is_hdf5(source):
        return False
    with open_hdf5(source) as f:
        return all(k in f for k in REQUIRED)


def _names(f, key: str) -> list[str]:
    """Byte or text strings of a 1-D dataset (empty, or float, when SLEAP had none)."""
    ds = f[key]
    if not hasattr(ds, "dtype") or ds.ndim != 1 or ds.shape == (0,) or (
            ds.dtype.kind not in "SOU"):
        return []
    if ds.shape[0] > 100_000:
        raise TrebuchetInputError.at(f"dataset '{key}'", f"{ds.shape[0]} names: no SLEAP "
                                     "project has as many")
    return [v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v)
            for v in ds[()]]


def _numbers(f, key: str, ndim: int, layout: str) -> np.ndarray:
    """A numeric dataset of ``ndim`` dimensions (``layout`` names them), checked for its
    type and size before it is read."""
    ds = f[key]
    if not hasattr(ds, "dtype") or ds.dtype.kind not in "fiu":
        kind = getattr(getattr(ds, "dtype", None), "name", "a group")
        raise TrebuchetInputError.at(f"dataset '{key}'", f"holds {kind} values, not numbers "
                                     f"({layout})")
    if ds.ndim != ndim:
        raise TrebuchetInputError.at(f"dataset '{key}'", f"has shape {ds.shape}, expected "
                                     f"{layout} as SLEAP writes it")
    size = float(np.prod(ds.shape, dtype=float)) * 8
    if size > MAX_DATASET_BYTES:
        raise TrebuchetInputError.at(f"dataset '{key}'", f"has shape {ds.shape}: "
                                     f"{size / 2**20:.4g} MiB, more than the "
                                     f"{MAX_DATASET_BYTES >> 20} MiB a log can mean")
    return np.asarray(ds[()], dtype=float)


def read_sleap_h5(source: str | Path | bytes, fps: float | None, min_likelihood: float,
                  individual: str | None = None) -> LogSource:
    """Read a SLEAP analysis HDF5 (see the module doc) from its path or bytes; errors leave
    the file's name to the caller, as the text readers do. Rows are numbered frame + 1."""
    with open_hdf5(source) as f:
        missing = [k for k in REQUIRED if k not in f]
        if missing:
            raise TrebuchetInputError(
                f"a SLEAP analysis file needs the datasets {', '.join(REQUIRED)} "
                f"(missing: {', '.join(missing)})")
        layout = "(tracks, 2, nodes, frames)"
        tracks = _numbers(f, "tracks", 4, layout)
        scores = (_numbers(f, "point_scores", 3, "(tracks, nodes, frames)")
                  if "point_scores" in f else None)
        nodes = _names(f, "node_names")
        names = _names(f, "track_names") if "track_names" in f else []
    if tracks.shape[1] != 2 or tracks.shape[2] != len(nodes):
        raise TrebuchetInputError.at(
            "dataset 'tracks'", f"has shape {tracks.shape}, expected (tracks, 2, "
            f"{len(nodes)} nodes, frames) as SLEAP writes it")
    if scores is not None and scores.shape != (tracks.shape[0], tracks.shape[2],
                                               tracks.shape[3]):
        raise TrebuchetInputError.at(
            "dataset 'point_scores'", f"has shape {scores.shape}, not (tracks, nodes, frames) "
            f"= {(tracks.shape[0], tracks.shape[2], tracks.shape[3])} of 'tracks'")
    tracks = tracks.T                                            # frames, nodes, 2, tracks
    scores = None if scores is None else scores.T                # frames, nodes, tracks
    n_frames, _, _, n_tracks = tracks.shape
    if n_frames > MAX_ROWS:
        raise TrebuchetInputError.at("dataset 'tracks'", f"{n_frames} frames, more than the "
                                     f"{MAX_ROWS:,} a log can hold")
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
