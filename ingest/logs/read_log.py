"""Read an angle or point log (generic CSV or a tracking tool's export) into the paper's
angles.

:func:`read_log` recognises the format from the file's content (never its extension;
docs/formats.md lists every tool and layout):

* ``"sleap"``: SLEAP's analysis HDF5 or CSV, see :mod:`..readers.sleap`;
* ``"deeplabcut"``: a DeepLabCut CSV or .h5, see :mod:`..readers.deeplabcut`;
* ``"anipose"``: anipose's 3-D CSV, see :mod:`..readers.anipose`;
* ``"tracker"``: an export of Tracker (physlets.org/tracker), see :mod:`..readers.tracker`;
* ``"kinovea"``: a Kinovea trajectory CSV, see :mod:`..readers.kinovea`;
* ``"generic"``: anything else, see :mod:`..readers.generic`.

Units the file does not state are decided (``time_unit=``, ``angle_unit=``, else from the
frame steps and the values, see :mod:`..readers.time_units` and :mod:`.units`), each
decision a sentence; :func:`.scene_check.scene_check` checks them against the scene.
Then every log gets the same checks and repairs, in this order: the time must not
decrease (error naming the row); rows without any angle are dropped; rows repeating the
time of the row before are merged; absent frames and empty cells are reported (and left
as gaps: no row is invented, no value interpolated); repeated frames (an up-converted
video's runs of one image) are dropped; each angle is unwrapped. Every repair (and every
inferred unit) is listed in the result's ``repairs`` (``attrs["log"]``, a
:class:`.result.ReadLog`) and warned about as a
:class:`~trebuchet.core.errors.TrebuchetDataWarning`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.core.errors import (
    Option,
    TrebuchetDataWarning,
    TrebuchetInputError,
    printable,
    warn_at_caller,
)
from trebuchet.ingest.geometry.user_calibration import (
    RESIDUAL_WARN_PX,
    UserCalibration,
    read_calibration,
)
from trebuchet.ingest.logs.from_points import (  # noqa: F401 (PIXEL_FORMATS: calibrated_angles reads it here)
    PIXEL_FORMATS,
    from_points,
    left_out_reason,
)
from trebuchet.ingest.logs.outliers import drop_single_frame_outliers
from trebuchet.ingest.logs.repairs import (
    drop_repeated_frames,
    drop_rows_without_angles,
    merge_duplicate_times,
    report_gaps,
    unwrap_angles,
)
from trebuchet.ingest.logs.result import ReadLog
from trebuchet.ingest.logs.units import angle_units, rate_check
from trebuchet.ingest.readers.anipose import looks_like_anipose, read_anipose
from trebuchet.ingest.readers.deeplabcut import (
    looks_like_deeplabcut,
    read_deeplabcut,
    read_deeplabcut_h5,
)
from trebuchet.ingest.readers.generic import read_generic
from trebuchet.ingest.readers.hdf5 import is_hdf5, log_bytes
from trebuchet.ingest.readers.kinovea import looks_like_kinovea, read_kinovea
from trebuchet.ingest.readers.mapping import ANGLES, check_mapping, missing_angle_error, resolve
from trebuchet.ingest.readers.sleap import (
    looks_like_sleap_csv,
    looks_like_sleap_h5,
    read_sleap_csv,
    read_sleap_h5,
)
from trebuchet.ingest.readers.source import LogSource, ParsedLog
from trebuchet.ingest.readers.table import decode_text, split_lines
from trebuchet.ingest.readers.time_units import check_time_unit
from trebuchet.ingest.readers.timebase import (
    check_fps,
    check_frame_rate,
    check_time,
    decimal_rounding,
    snap_rounded_times,
)
from trebuchet.ingest.readers.tracker import looks_like_tracker, read_tracker
from trebuchet.ingest.readers.units import check_angle_unit

#: Fewest frames with all three angles that a log must have.
MIN_FRAMES = 10
#: rad: an angle further from zero than two turns is no shot's (degrees read as rad, most likely).
MAX_ANGLE = 4.0 * math.pi

#: Default likelihood (DeepLabCut) or score (SLEAP) below which a position is a gap:
#: DeepLabCut's own ``pcutoff``.
MIN_LIKELIHOOD = 0.6
#: Formats whose time is a frame index (``t = frame / fps``).
FRAME_INDEXED = ("deeplabcut", "sleap", "anipose")


def read_log(
    path: str | Path,
    fps: float | None = None,
    columns: Mapping[str, str] | None = None,
    points: Mapping[str, str] | None = None,
    *,
    time_unit: str | None = None,
    angle_unit: str | None = None,
    min_likelihood: float = MIN_LIKELIHOOD,
    individual: str | None = None,
    calibration: str | Path | UserCalibration | None = None,
) -> pd.DataFrame:
    """Read an angle log; return columns ``t`` (s), ``theta``, ``psi``, ``phi`` (rad).

    Parameters
    ----------
    path:
        The log file. Its format is recognised from its content (docs/formats.md lists
        every tool and layout): DeepLabCut (CSV, .h5), SLEAP (analysis HDF5 and CSV),
        anipose (3-D CSV), Kinovea, Tracker, or a generic CSV.
    fps:
        Frame rate (1/s) for files with frame numbers and no time column (generic
        ``frame`` column, DeepLabCut, SLEAP, anipose, Kinovea's Frames time code). For
        times rounded to whole milliseconds (Kinovea) or written with too few decimals
        (Tracker's 0.1 ms) it gives the exact frame times; without it they go on a fitted
        frame grid (a repair note says so). It also decides a time column's unit.
    columns:
        ``{"<column or track name in the file>": "theta" | "psi" | "phi"}`` for files whose
        names are not the angles' own. Unmapped angles still use columns named after them.
    points:
        ``{"pivot" | "spigot" | "hinge" | "counterweight" | "projectile": "<point name>"}``
        for files of point positions (Kinovea, DeepLabCut, SLEAP, anipose, Tracker point
        masses); parts not given are found by their own name. theta needs pivot and
        spigot, psi hinge and counterweight, phi spigot and projectile.
    time_unit:
        ``"s"``, ``"ms"``, ``"us"`` or ``"frames"``: the unit of a time column whose header
        states none (Kinovea's ``Time``, a generic ``t``). Without it the unit is decided
        from the frame pattern (the steps against a film's frame rate and ``fps``), or the
        file is refused naming the likely unit.
    angle_unit:
        ``"deg"`` or ``"rad"``: the unit of angle columns whose header states none
        (Tracker's θ, in the unit of its preference; a generic ``theta``). Without it the
        unit is decided from the beam's sweep, or the file is refused.
    min_likelihood:
        DeepLabCut's likelihood or SLEAP's score below which a position becomes a gap
        (reported); default 0.6, DeepLabCut's own ``pcutoff``.
    individual:
        The individual (DeepLabCut multi-animal) or track (SLEAP) that is the engine;
        needed when the file has several.
    calibration:
        The user's own calibration of the camera, for files of tracked points in image
        pixels (DeepLabCut, SLEAP): a file of four or more known points of the engine's
        plane (CSV or TOML; the positions are then in m on that plane) or an OpenCV camera
        file (YAML, XML, JSON; the positions are then the lens-free pixels), see
        :mod:`trebuchet.ingest.geometry.user_calibration` and docs/formats.md. A decision
        sentence says what it fixed.

    Returns
    -------
    pandas.DataFrame
        ``t`` in s (the log's own time: ``frame / fps`` for frame numbers), the angles in
        rad, unwrapped, float64, sorted by ``t``; NaN where an angle is missing.
        ``attrs["log"]`` is a :class:`~trebuchet.ingest.logs.result.ReadLog`: the source,
        format, repairs, decisions (how each unit was decided), columns, fps, frame
        numbers, the points of a point file, and when a tracked projectile leaves its
        sling's circle; it is the only key in ``attrs``.

    Raises
    ------
    TrebuchetInputError
        On a user's mistake; the message names the file, the row (1-based line number in
        the file) or column, and what is wrong.
    """
    time_unit = check_time_unit(time_unit)
    angle_unit = check_angle_unit(angle_unit)
    if calibration is not None and not isinstance(calibration, UserCalibration):
        calibration = read_calibration(calibration)
    try:
        log, repairs = _read(path, fps, columns, points, min_likelihood, individual,
                             time_unit, angle_unit, calibration)
    except TrebuchetInputError as exc:  # the file's name, once, in front of the place
        raise exc.in_file(path) from None
    if calibration is not None and (calibration.residual_px or 0.0) > RESIDUAL_WARN_PX:
        warn_at_caller(f"{Path(calibration.source).name}: the known points miss their "
                      f"homography by {calibration.residual_px:.2f} px rms (more than "
                      f"{RESIDUAL_WARN_PX:g} px): a mistyped point, or a lens that bends (give "
                      "its camera matrix and distortion in the same file)",
                      TrebuchetDataWarning)
    return _frame(path, log, repairs)


def _read(path: str | Path, fps: float | None, columns: Mapping[str, str] | None,
          points: Mapping[str, str] | None, min_likelihood: float, individual: str | None,
          time_unit: str | None, angle_unit: str | None,
          calibration: UserCalibration | None = None) -> tuple[ParsedLog, list[str]]:
    """:func:`read_log` up to the result table: the log and its repair notes. Errors name the
    place in the file but not the file."""
    fps = check_fps(fps)
    mapping = check_mapping(columns, ANGLES, "columns")
    check_mapping(points, ("pivot", "spigot", "hinge", "counterweight", "projectile"),
                  "points")
    if not (isinstance(min_likelihood, int | float) and 0 <= min_likelihood <= 1):
        raise TrebuchetInputError(f"min_likelihood={min_likelihood!r} must be in [0, 1]")
    if individual is not None and not isinstance(individual, str):
        raise TrebuchetInputError(f"individual={individual!r} must be a name (str)")
    source = _read_source(path, fps, float(min_likelihood), individual, points, time_unit)
    check_time(source.t, source.rows, source.time_label)
    check_frame_rate(source.t, source.time_label, fps)
    _snap_decimal_times(source, fps)
    log = _choose_angles(source, mapping, points, angle_unit, calibration)
    for angle in ANGLES:
        values = log.angles[angle]
        if np.isnan(values).all():
            raise TrebuchetInputError.at(
                f"column '{log.labels[angle]}'",
                f"no value at all (for {angle}){left_out_reason(log, angle)}")
        largest = float(np.nanmax(np.abs(values)))
        if largest > MAX_ANGLE:
            label = log.labels[angle]
            if re.search(r"[(\[]\s*(deg|rad)", label, re.IGNORECASE) or angle_unit:
                k = int(np.nanargmax(np.abs(values)))  # the unit is stated: a bad cell
                raise TrebuchetInputError.at(
                    f"row {log.rows[k]}, column '{label}'", f"{angle} = {largest:.4g} rad, "
                    "more than two turns from zero, which no shot turns: a corrupt or "
                    "misplaced value?")
            raise TrebuchetInputError.at(
                f"column '{label}'", f"{angle} reaches {largest:.4g} rad, more "
                "than two turns from zero, which no shot turns; if the column holds degrees, "
                f"say so in its header, e.g. '{angle} (deg)', or with "
                f"{Option('angle_unit', 'deg')}"
            )
    repairs = [d for d in log.decisions if "(inferred" in d] + list(log.repairs)
    for step in (drop_rows_without_angles, merge_duplicate_times):
        note = step(log)
        if note:
            repairs.append(note)
    repairs += report_gaps(log)
    note = drop_repeated_frames(log)
    if note:
        repairs.append(note)
    unwrapped = unwrap_angles(log)
    repairs += drop_single_frame_outliers(log) + unwrapped
    complete = int(np.isfinite(np.column_stack([log.angles[a] for a in ANGLES])).all(1).sum())
    if complete < MIN_FRAMES:
        raise TrebuchetInputError(
            f"only {complete} frames with all three angles; at least {MIN_FRAMES} "
            f"are needed"
        )
    return log, repairs


def _read_source(path: str | Path, fps: float | None, min_likelihood: float,
                 individual: str | None, points: Mapping[str, str] | None,
                 time_unit: str | None) -> LogSource:
    """Recognise the format from the content and read the file (once: a regular file of
    bounded size, :func:`.hdf5.log_bytes`)."""
    raw = log_bytes(path)
    if is_hdf5(raw):
        if looks_like_sleap_h5(raw):
            source = read_sleap_h5(raw, fps, min_likelihood, individual)
        else:
            source = read_deeplabcut_h5(raw, fps, min_likelihood, individual)
        return _frame_indexed(source, fps, time_unit)
    text = decode_text(raw)
    numbered = split_lines(text)
    if looks_like_deeplabcut(numbered):
        source = read_deeplabcut(numbered, fps, min_likelihood, individual)
    elif looks_like_sleap_csv(numbered):
        source = read_sleap_csv(numbered, fps, min_likelihood, individual)
    elif looks_like_anipose(numbered):
        source = read_anipose(numbered, fps, points)
    else:
        source = None
    cut = _cut_last_row(text, numbered)
    if source is not None:
        source.repairs.extend(cut)
        return _frame_indexed(source, fps, time_unit)
    if individual is not None:
        raise TrebuchetInputError(
            f"individual={individual!r} is for DeepLabCut multi-animal and SLEAP files; "
            "this file has no individuals")
    if looks_like_tracker(numbered):
        source = read_tracker(numbered, fps, time_unit)
    elif looks_like_kinovea(numbered):
        source = read_kinovea(numbered, fps, time_unit)
    else:
        source = read_generic(numbered, fps, time_unit)
    source.repairs.extend(cut)
    return source


def _cut_last_row(text: str, numbered: list[tuple[int, str]]) -> list[str]:
    """A note when the file ends without a line end inside a row shorter than the one
    before (fewer delimiters): an export or copy cut short, its last row partial."""
    if len(numbered) < 2 or text.endswith(("\n", "\r")):
        return []
    (_, before), (number, last) = numbered[-2], numbered[-1]
    delimiter = max(",;\t", key=before.count)
    if last.count(delimiter) >= before.count(delimiter):
        return []
    return [f"the file ends inside row {number}, which has fewer cells than the row before "
            "and no line end: the file is cut (an interrupted export or copy?); its cells "
            "missing are gaps"]


def _frame_indexed(source: LogSource, fps: float | None, time_unit: str | None) -> LogSource:
    """The decisions of a pose file (frame index, image or 3-D coordinates)."""
    if time_unit not in (None, "frames"):
        raise TrebuchetInputError(
            f"time_unit={time_unit!r}, but this {source.fmt} file counts frames "
            f"('{source.time_label}'); leave time_unit out and pass fps=")
    source.decisions.append(f"time: frame numbers ('{source.time_label}') / fps={fps!r}")
    if source.fmt == "anipose":
        source.decisions.append("y axis: up from the counterweight hanging at rest (anipose's "
                                "3-D points taken into the engine's plane)")
    else:
        source.decisions.append(f"y axis: down ({source.fmt} writes image coordinates), "
                                "turned up")
    return source


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
    angle_unit: str | None = None,
    calibration: UserCalibration | None = None,
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
        return from_points(source, points, calibration)
    if calibration is not None:
        raise TrebuchetInputError(
            f"calibration= is for files of tracked points in image pixels; this {source.fmt} "
            "file holds angles")
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
    labels = {a: chosen[a].label for a in ANGLES}
    raw = {a: np.asarray(chosen[a].data(), dtype=float) for a in ANGLES}
    angles, decided, factors = angle_units(raw, labels, source.unitless, angle_unit)
    decisions = list(source.decisions) + decided
    confirmed = rate_check(source.t, angles, labels, source.rates, factors)
    if confirmed:
        decisions.append(confirmed)
    if unused and source.fmt == "generic":  # nothing is dropped unsaid (a tracking tool's
        # export holds rates and accelerations beside each angle: those are not news)
        repairs.append(f"column(s) {', '.join(repr(u) for u in unused)} not used (no angle "
                       "of the shot; map one with columns= if it is)")
    return source.parsed(angles, labels, repairs, decisions)


def _has_default_angles(source: LogSource) -> bool:
    """Whether any angle column is named after an angle."""
    return any(c.default in ANGLES for c in source.angle_columns)


def _frame(path: str | Path, log: ParsedLog, repairs: list[str]) -> pd.DataFrame:
    """The result table with its :class:`ReadLog`; warns once per repair."""
    df = pd.DataFrame(
        {"t": np.asarray(log.t, dtype=np.float64)}
        | {a: np.asarray(log.angles[a], dtype=np.float64) for a in ANGLES}
    )
    repairs = [printable(r) for r in repairs]  # names from the file reach the terminal
    info = ReadLog(
        source=str(path),
        format=log.fmt,
        repairs=tuple(repairs),
        decisions=tuple(printable(d) for d in log.decisions),
        columns=dict(log.labels),
        fps=None if log.fps is None else float(log.fps),
        frame=log.frame,
        points=None if log.points is None else {"t": df["t"].to_numpy()} | log.points,
        point_names=None if log.points is None else dict(log.point_names or {}),
        leaves_sling=log.leaves_sling,
        lines=log.rows,
        held=log.held,
    )
    df.attrs["log"] = info
    name = Path(path).name
    for note in repairs:
        warn_at_caller(f"{name}: {note}", TrebuchetDataWarning)
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
