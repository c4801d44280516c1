"""Pose-estimation output as point candidates: what the DeepLabCut (.h5), SLEAP and anipose
readers share once their file is parsed into arrays.

* :func:`choose_individual`: the animal (DeepLabCut's individual, SLEAP's track) whose
  points are the engine's: the one asked for, else the only one, else an error listing
  them;
* :func:`keypoint_source`: a :class:`~.source.LogSource` of point candidates from frame
  numbers and per-point ``x``, ``y`` and score arrays; image coordinates (y down) are
  flipped to y up; a score below ``min_likelihood`` makes the position a gap, reported.
  Files without text rows (HDF5) number their rows by frame (row = frame index + 1).
"""

from __future__ import annotations

import numpy as np

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.readers.mapping import Candidate, role_default
from trebuchet.ingest.readers.source import LogSource
from trebuchet.ingest.readers.table import format_rows
from trebuchet.ingest.readers.timebase import frames_to_time


def choose_individual(names: list[str], individual: str | None,
                      what: str = "individual", keyword: str = "individual") -> str | None:
    """The chosen name among ``names`` (None when the file has none)."""
    listed = ", ".join(repr(n) for n in names) or "none"
    if individual is not None:
        if individual not in names:
            raise TrebuchetInputError(
                f"no {what} {individual!r} in this file ({what}s: {listed})")
        return individual
    if not names:
        return None
    if len(names) == 1:
        return names[0]
    raise TrebuchetInputError(
        f"{len(names)} {what}s in this file ({listed}); say which one is the engine, "
        f"e.g. {keyword}={names[0]!r}")


def keypoint_source(
    fmt: str,
    frames: np.ndarray,
    rows: np.ndarray,
    parts: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray | None]],
    fps: float | None,
    min_likelihood: float,
    *,
    time_label: str = "frame index",
    y_down: bool = True,
    score_name: str = "likelihood",
    repairs: list[str] | None = None,
) -> LogSource:
    """Point candidates named by the keys of ``parts`` (``"<individual>/<part>"`` or
    ``"<part>"``; each also found by its bare part name when that is unique)."""
    t, frame = frames_to_time(np.asarray(frames, dtype=float), rows, fps, time_label)
    bare = [name.rsplit("/", 1)[-1] for name in parts]
    tracks = []
    for name, (x, y, score) in parts.items():
        short = name.rsplit("/", 1)[-1]
        unique = bare.count(short) == 1
        tracks.append(Candidate(
            label=name,
            aliases=frozenset({name} | ({short} if unique else set())),
            default=role_default(short) if unique else None,
            data=_getter(name, rows, np.asarray(x, dtype=float), np.asarray(y, dtype=float),
                         None if score is None else np.asarray(score, dtype=float),
                         min_likelihood, y_down, score_name),
        ))
    return LogSource(fmt=fmt, t=t, rows=np.asarray(rows), time_label=time_label,
                     point_tracks=tracks, frame=frame, fps=fps, repairs=list(repairs or []))


def _getter(name: str, rows: np.ndarray, x: np.ndarray, y: np.ndarray,
            score: np.ndarray | None, min_likelihood: float, y_down: bool, score_name: str):
    """A function returning (x, y up, note) of one point, low scores as NaN."""

    def get() -> tuple[np.ndarray, np.ndarray, str | None]:
        xs, ys = x.copy(), (-y if y_down else y.copy())
        note = None
        if score is not None:
            with np.errstate(invalid="ignore"):
                low = (score < min_likelihood) & np.isfinite(xs) & np.isfinite(ys)
            if low.any():
                xs[low] = np.nan
                ys[low] = np.nan
                note = (f"{int(low.sum())} positions of '{name}' with {score_name} below "
                        f"{min_likelihood:g} treated as gaps ({format_rows(rows[low])})")
        return xs, ys, note

    return get
