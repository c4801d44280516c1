"""Read an angle log (generic CSV or a tracking tool's export) into the paper's angles.

:func:`read_log` recognises the format from the file's content (never its extension):

* ``"tracker"``: an export of Tracker (physlets.org/tracker), see :mod:`.formats_tracker`;
* ``"kinovea"``: a Kinovea trajectory CSV, see :mod:`.formats_kinovea`;
* ``"deeplabcut"``: a DeepLabCut CSV, see :mod:`.formats_deeplabcut`;
* ``"generic"``: anything else, see :mod:`.formats_generic`.

Then every log gets the same checks and repairs, in this order: the time must not
decrease (error naming the row); rows without any angle are dropped; rows repeating the
time of the row before are merged; absent frames and empty cells are reported (and left
as gaps: no row is invented, no value interpolated); repeated frames are dropped;
each angle is unwrapped. Every repair is listed in ``attrs["repairs"]`` and warned
about as a :class:`~trebuchet.errors.TrebuchetDataWarning`.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.errors import TrebuchetDataWarning, TrebuchetInputError
from trebuchet.ingest.geometry.points import NEEDS, point_angles, resolve_points
from trebuchet.ingest.geometry.sling_circle import leaving_time, sling_ratio
from trebuchet.ingest.logs.repairs import (
    drop_repeated_frames,
    drop_rows_without_angles,
    merge_duplicate_times,
    report_gaps,
    unwrap_angles,
)
from trebuchet.ingest.readers.deeplabcut import looks_like_deeplabcut, read_deeplabcut
from trebuchet.ingest.readers.generic import read_generic
from trebuchet.ingest.readers.kinovea import looks_like_kinovea, read_kinovea
from trebuchet.ingest.readers.mapping import ANGLES, check_mapping, missing_angle_error, resolve
from trebuchet.ingest.readers.source import LogSource, ParsedLog
from trebuchet.ingest.readers.table import read_text, split_lines
from trebuchet.ingest.readers.timebase import (
    check_fps,
    check_frame_rate,
    check_time,
    decimal_rounding,
    snap_rounded_times,
)
from trebuchet.ingest.readers.tracker import looks_like_tracker, read_tracker

#: Fewest frames with all three angles that a log must have.
MIN_FRAMES = 10
#: rad: an angle further from zero than two turns is no shot's (degrees read as rad, most likely).
MAX_ANGLE = 4.0 * math.pi

#: Default likelihood below which a DeepLabCut position is treated as missing.
MIN_LIKELIHOOD = 0.9


def read_log(
    path: str | Path,
    fps: float | None = None,
    columns: Mapping[str, str] | None = None,
    points: Mapping[str, str] | None = None,
    *,
    min_likelihood: float = MIN_LIKELIHOOD,
) -> pd.DataFrame:
    """Read an angle log; return columns ``t`` (s), ``theta``, ``psi``, ``phi`` (rad).

    Parameters
    ----------
    path:
        The log file. Its format is recognised from its content.
    fps:
        Frame rate (1/s) for files with frame numbers and no time column (generic
        ``frame`` column, DeepLabCut). For times rounded to whole milliseconds
        (Kinovea) or written with too few decimals (Tracker's 0.1 ms) it gives the exact
        frame times; without it they go on a fitted frame grid (a repair note says so).
    columns:
        ``{"<column or track name in the file>": "theta" | "psi" | "phi"}`` for files whose
        names are not the angles' own. Unmapped angles still use columns named after them.
    points:
        ``{"pivot" | "spigot" | "hinge" | "counterweight" | "projectile": "<point name>"}``
        for files of point positions (Kinovea, DeepLabCut, Tracker point masses); parts
        not given are found by their own name. theta needs pivot and spigot, psi hinge
        and counterweight, phi spigot and projectile.
    min_likelihood:
        DeepLabCut only: positions with a lower likelihood become gaps (default 0.9,
        stricter than DeepLabCut's own plotting cut-off of 0.6: second derivatives
        suffer more from a wrong point than from a missing one).

    Returns
    -------
    pandas.DataFrame
        ``t`` in s (the log's own time: ``frame / fps`` for frame numbers), the angles in
        rad, unwrapped, float64, sorted by ``t``; NaN where an angle is missing. ``attrs``:
        ``source`` (the path), ``format``, ``repairs`` (list of sentences), ``columns``
        (which column or points gave each angle), ``fps`` (if known), ``frame`` (list
        of frame numbers per row, if the file has them), and for point files ``points``
        (dict of lists: ``t``, ``<part>_x``, ``<part>_y`` in the file's unit, y up; one
        call to ``pandas.DataFrame`` away from a table) and ``point_names``; and
        ``leaves_sling`` (``{"t", "sd"}`` in s) when a tracked projectile leaves its
        sling's circle (phi is blanked from there, a repair). Only plain Python values,
        so that ``pandas.concat`` of logs keeps working.

    Raises
    ------
    TrebuchetInputError
        On a user's mistake; the message names the file, the row (1-based line number in
        the file) or column, and what is wrong.
    """
    try:
        log, repairs = _read(path, fps, columns, points, min_likelihood)
    except TrebuchetInputError as exc:  # the file's name, once, in front of the place
        raise exc.in_file(path) from None
    return _frame(path, log, repairs)


def _read(path: str | Path, fps: float | None, columns: Mapping[str, str] | None,
          points: Mapping[str, str] | None, min_likelihood: float
          ) -> tuple[ParsedLog, list[str]]:
    """:func:`read_log` up to the result table: the log and its repair notes. Errors name the
    place in the file but not the file."""
    fps = check_fps(fps)
    mapping = check_mapping(columns, ANGLES, "columns")
    check_mapping(points, ("pivot", "spigot", "hinge", "counterweight", "projectile"),
                  "points")
    if not (isinstance(min_likelihood, int | float) and 0 <= min_likelihood <= 1):
        raise TrebuchetInputError(f"min_likelihood={min_likelihood!r} must be in [0, 1]")
    numbered = split_lines(read_text(path))
    source = _read_source(numbered, fps, float(min_likelihood))
    check_time(source.t, source.rows, source.time_label)
    check_frame_rate(source.t, source.time_label, fps)
    _snap_decimal_times(source, fps)
    log = _choose_angles(source, mapping, points)
    for angle in ANGLES:
        values = log.angles[angle]
        if np.isnan(values).all():
            raise TrebuchetInputError.at(
                f"column '{log.labels[angle]}'", f"no value at all (for {angle})"
            )
        largest = float(np.nanmax(np.abs(values)))
        if largest > MAX_ANGLE:
            raise TrebuchetInputError.at(
                f"column '{log.labels[angle]}'", f"{angle} reaches {largest:.4g} rad, more "
                "than two turns from zero, which no shot turns; if the column holds degrees, "
                f"say so in its header, e.g. '{angle} (deg)'"
            )
    repairs = list(log.repairs)
    for step in (drop_rows_without_angles, merge_duplicate_times):
        note = step(log)
        if note:
            repairs.append(note)
    repairs += report_gaps(log)
    note = drop_repeated_frames(log)
    if note:
        repairs.append(note)
    complete = int(np.isfinite(np.column_stack([log.angles[a] for a in ANGLES])).all(1).sum())
    if complete < MIN_FRAMES:
        raise TrebuchetInputError(
            f"only {complete} frames with all three angles; at least {MIN_FRAMES} "
            f"are needed"
        )
    repairs += unwrap_angles(log)
    return log, repairs


def _read_source(
    numbered: list[tuple[int, str]], fps: float | None, min_likelihood: float
) -> LogSource:
    """Recognise the format from the content and read the file."""
    if looks_like_deeplabcut(numbered):
        return read_deeplabcut(numbered, fps, min_likelihood)
    if looks_like_tracker(numbered):
        return read_tracker(numbered, fps)
    if looks_like_kinovea(numbered):
        return read_kinovea(numbered, fps)
    return read_generic(numbered, fps)


def _snap_decimal_times(source: LogSource, fps: float | None) -> None:
    """Times written with too few decimals (Tracker's 4) go back on the frame grid of
    ``fps`` (1/s) if given, else on a fitted one, with a repair note; Kinovea's whole
    milliseconds are handled by its reader."""
    if source.frame is not None or source.fmt == "kinovea":
        return
    step = decimal_rounding(source.t)
    if step is None:
        return
    t, _, note = snap_rounded_times(source.t, source.rows, fps, step, anchored=False)
    source.t = t
    if note:
        source.repairs.append(note)


def _choose_angles(
    source: LogSource,
    mapping: dict[str, str],
    points: Mapping[str, str] | None,
) -> ParsedLog:
    """Pick the angle columns (or compute the angles from points) of ``source``."""
    use_points = points is not None or (
        not mapping and source.point_tracks and not _has_default_angles(source)
    )
    if use_points:
        if not source.point_tracks:
            raise TrebuchetInputError(
                f"points= is for files of point positions; this {source.fmt} file "
                f"holds no points (columns found: "
                f"{', '.join(repr(c.label) for c in source.angle_columns) or 'none'})"
            )
        if mapping:
            raise TrebuchetInputError(
                "give either columns= (angle columns) or points= (point positions), "
                "not both"
            )
        return _from_points(source, points)
    chosen = resolve(source.angle_columns, mapping, ANGLES, "columns", "column")
    for angle in ANGLES:
        if angle not in chosen:
            if source.point_tracks and not source.angle_columns:
                raise TrebuchetInputError(
                    f"this {source.fmt} file holds point positions, not angles; "
                    f"use points= instead of columns="
                )
            raise missing_angle_error(angle, source.angle_columns)
    used = {chosen[a].label for a in ANGLES}
    unused = [c.label for c in source.angle_columns if c.label not in used]
    repairs = list(source.repairs)
    if unused and source.fmt == "generic":  # nothing is dropped unsaid (a tracking tool's
        # export holds rates and accelerations beside each angle: those are not news)
        repairs.append(f"column(s) {', '.join(repr(u) for u in unused)} not used (no angle "
                       "of the shot; map one with columns= if it is)")
    return ParsedLog(
        fmt=source.fmt,
        t=source.t,
        rows=source.rows,
        angles={a: np.asarray(chosen[a].data(), dtype=float) for a in ANGLES},
        labels={a: chosen[a].label for a in ANGLES},
        frame=source.frame,
        fps=source.fps,
        repairs=repairs,
    )


def _has_default_angles(source: LogSource) -> bool:
    """Whether any angle column is named after an angle."""
    return any(c.default in ANGLES for c in source.angle_columns)


def _from_points(
    source: LogSource, points: Mapping[str, str] | None
) -> ParsedLog:
    """The angles from the point positions named by ``points`` (see :mod:`.angles_from_points`)."""
    chosen = resolve_points(source.point_tracks, dict(points) if points else None)
    repairs = list(source.repairs)
    positions: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for role, cand in chosen.items():
        x, y, note = cand.data()
        if np.isnan(x).all() or np.isnan(y).all():
            raise TrebuchetInputError.at(
                f"point '{cand.label}' ({role})", "no position at all"
            )
        positions[role] = (np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        if note:
            repairs.append(note)
    angles = point_angles(positions)
    leaves, note = _cut_flight_from_sling(source, positions, angles)
    if note:
        repairs.append(note)
    labels = {}
    for angle, pairs in NEEDS.items():
        for a, b in pairs:
            if a in positions and b in positions:
                labels[angle] = f"{chosen[a].label} -> {chosen[b].label}"
                break
    flat = {}
    for role, (x, y) in positions.items():
        flat[f"{role}_x"] = x
        flat[f"{role}_y"] = y
    return ParsedLog(
        fmt=source.fmt,
        t=source.t,
        rows=source.rows,
        angles=angles,
        labels=labels,
        frame=source.frame,
        fps=source.fps,
        points=flat,
        point_names={role: cand.label for role, cand in chosen.items()},
        repairs=repairs,
        leaves_sling=leaves,
    )


def _cut_flight_from_sling(source: LogSource, positions: dict[str, tuple[np.ndarray, np.ndarray]],
                           angles: dict[str, np.ndarray]
                           ) -> tuple[tuple[float, float] | None, str | None]:
    """Blank phi where the tracked projectile has left its sling's circle (in flight after
    the release, see :mod:`.sling_circle`); return (that time and its sd in s, the repair
    note), or (None, None)."""
    if not all(r in positions for r in ("pivot", "spigot", "projectile")):
        return None, None
    ratio = sling_ratio(positions["pivot"], positions["spigot"], positions["projectile"])
    found = leaving_time(source.t, ratio)
    if found is None:
        return None, None
    first = int(np.searchsorted(source.t, found[0], side="right"))
    cut = np.isfinite(angles["phi"]) & (np.arange(ratio.size) >= first)
    angles["phi"][cut] = np.nan
    level = float(np.nanmedian(ratio))
    far = float(np.nanmax(ratio[first:])) / level
    return found, (f"the projectile leaves its sling's circle at t = {found[0]:.6g} ± "
            f"{found[1]:.2g} s, before row {source.rows[first]}, and ends {far:.3g}× the "
            f"sling's length from the spigot: the stone is in flight, so phi (spigot -> "
            f"projectile) is no sling angle there; its {int(cut.sum())} values from that row "
            "on are left out (the release lies before it)")


def _frame(path: str | Path, log: ParsedLog, repairs: list[str]) -> pd.DataFrame:
    """The result table with its attrs; warns once per repair."""
    df = pd.DataFrame(
        {"t": np.asarray(log.t, dtype=np.float64)}
        | {a: np.asarray(log.angles[a], dtype=np.float64) for a in ANGLES}
    )
    attrs: dict = {
        "source": str(path),
        "format": log.fmt,
        "repairs": repairs,
        "columns": dict(log.labels),
    }
    if log.fps is not None:
        attrs["fps"] = float(log.fps)
    if log.frame is not None:
        attrs["frame"] = [int(f) for f in log.frame]
    if log.points is not None:
        attrs["points"] = {"t": df["t"].tolist()} | {
            k: [float(v) for v in arr] for k, arr in log.points.items()
        }
        attrs["point_names"] = dict(log.point_names or {})
    if log.leaves_sling is not None:
        attrs["leaves_sling"] = {"t": log.leaves_sling[0], "sd": log.leaves_sling[1]}
    df.attrs.update(attrs)
    name = Path(path).name
    for note in repairs:
        warnings.warn(f"{name}: {note}", TrebuchetDataWarning, stacklevel=3)
    return df


def write_log(df: pd.DataFrame, path: str | Path, unit: str = "deg") -> Path:
    """Write ``t`` and the angles of ``df`` (rad) as a generic log; return the path.

    Header ``t (s),theta (deg),psi (deg),phi (deg)`` (or ``(rad)`` with ``unit="rad"``);
    missing angles are written as empty cells; numbers with 17 significant digits so
    that :func:`read_log` gives back the same values (to rounding of the unit change).
    """
    if unit not in ("deg", "rad"):
        raise TrebuchetInputError(f"write_log: unit={unit!r} must be 'deg' or 'rad'")
    missing = [c for c in ("t", *ANGLES) if c not in df.columns]
    if missing:
        raise TrebuchetInputError(f"write_log: the table has no column {', '.join(missing)}")
    factor = 180.0 / math.pi if unit == "deg" else 1.0
    lines = [f"t (s),theta ({unit}),psi ({unit}),phi ({unit})"]
    t = df["t"].to_numpy(dtype=float)
    values = df[list(ANGLES)].to_numpy(dtype=float) * factor
    for ti, row in zip(t, values, strict=True):
        cells = [repr(float(ti))] + ["" if math.isnan(v) else repr(float(v)) for v in row]
        lines.append(",".join(cells))
    p = Path(path)
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return p
