"""The paper's angles of a log of tracked points (Kinovea, DeepLabCut, SLEAP, anipose,
Tracker point masses), as :func:`~.read_log.read_log` takes them: the points named by
``points=`` (or found by their names), a user's calibration applied to image pixels, a
tracker stuck on an occluder or off the engine's geometry left out as gaps, the hinge
checked on the beam through pivot and spigot, the angles from the positions
(:mod:`..geometry.points`) and φ blanked once the tracked stone has left its sling's circle.
Every change is a repair sentence.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.geometry.beam_hinge import beam_hinge, hinge_note
from trebuchet.ingest.geometry.points import NEEDS, point_angles, resolve_points
from trebuchet.ingest.geometry.sling_circle import leaving_time, sling_ratio
from trebuchet.ingest.geometry.stuck_points import off_engine, stuck_runs
from trebuchet.ingest.geometry.user_calibration import UserCalibration
from trebuchet.ingest.logs.units import y_axis
from trebuchet.ingest.readers.limits import MAX_COORDINATE
from trebuchet.ingest.readers.source import LogSource, ParsedLog
from trebuchet.ingest.readers.table import format_rows

#: The point each point's tie runs to (for the note on positions off the engine).
TIED = {"spigot": "pivot", "hinge": "beam", "counterweight": "hinge", "projectile": "spigot"}


#: Formats whose points are image pixels: a user's calibration applies to them.
PIXEL_FORMATS = ("deeplabcut", "sleap")


def from_points(
    source: LogSource, points: Mapping[str, str] | None,
    calibration: UserCalibration | None = None,
) -> ParsedLog:
    """The angles from the point positions named by ``points`` (see :mod:`.angles_from_points`)."""
    chosen = resolve_points(source.point_tracks, dict(points) if points else None)
    repairs = list(source.repairs)
    decisions = list(source.decisions)
    positions: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for role, cand in chosen.items():
        x, y, note = cand.data()
        if np.isnan(x).all() or np.isnan(y).all():
            raise TrebuchetInputError.at(
                f"point '{cand.label}' ({role})", "no position at all"
            )
        _check_positions(x, y, source.rows, cand.label)
        positions[role] = (np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        if note:
            repairs.append(note)
    if source.y_down is None:
        down, decision = y_axis(positions)
        decisions.append(decision)
        if down:
            positions = {r: (x, -y) for r, (x, y) in positions.items()}
    if calibration is not None:
        if source.fmt not in PIXEL_FORMATS:
            raise TrebuchetInputError(
                f"calibration= is for points in image pixels (DeepLabCut, SLEAP); this "
                f"{source.fmt} file's positions are not known to be pixels")
        positions = {r: tuple(calibration.to_plane(np.column_stack(xy)).T)
                     for r, xy in positions.items()}
        decisions.append(calibration.describe())
    held = []
    for run in stuck_runs(positions):  # a tracker held on an occluder: gaps, named
        held.append((run.point, float(source.t[run.first]), float(source.t[run.last])))
        x, y = (v.copy() for v in positions[run.point])
        x[run.first:run.last + 1] = np.nan
        y[run.first:run.last + 1] = np.nan
        positions[run.point] = (x, y)
        t0, t1 = source.t[run.first], source.t[run.last]
        repairs.append(
            f"{run.point} ('{chosen[run.point].label}') stands still (within {run.spread:.3g}) "
            f"in rows {source.rows[run.first]}-{source.rows[run.last]} (t = {t0:.6g}-{t1:.6g} "
            f"s) while the {run.reference} moves {run.moved:.3g}: the tracker is stuck "
            "(on an occluder?); those positions are left out as gaps")
    jumps: dict[str, list[int]] = {}
    for off in off_engine(positions):  # a few frames off the engine's geometry: gaps, named
        x, y = (v.copy() for v in positions[off.point])
        x[off.first:off.last + 1] = np.nan
        y[off.first:off.last + 1] = np.nan
        positions[off.point] = (x, y)
        jumps.setdefault(off.point, []).extend(range(off.first, off.last + 1))
    for role, frames in jumps.items():
        repairs.append(
            f"{role} ('{chosen[role].label}') lies off the engine's geometry (its distance or "
            f"line to the {TIED[role]} breaks) in {format_rows(source.rows[frames])}: a "
            "tracker's wrong match; those positions are left out as gaps")
    hinge = _hinge_of_the_beam(positions, source, chosen, repairs)
    angles = point_angles(positions if hinge is None else positions | {"hinge": hinge})
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
    return source.parsed(angles, labels, repairs, decisions, points=flat,
                         point_names={role: cand.label for role, cand in chosen.items()},
                         leaves_sling=leaves, held=tuple(held))


def _check_positions(x: np.ndarray, y: np.ndarray, rows: np.ndarray, label: str) -> None:
    """Refuse an infinite coordinate, or one beyond :data:`MAX_COORDINATE` (a corrupt cell:
    no image or survey of an engine reaches it), naming the row and the point."""
    with np.errstate(invalid="ignore"):
        bad = (np.abs(np.asarray(x, float)) > MAX_COORDINATE) | (
            np.abs(np.asarray(y, float)) > MAX_COORDINATE)
    if bad.any():
        k = int(np.argmax(bad))
        raise TrebuchetInputError.at(
            f"row {rows[k]}, point '{label}'", f"position ({x[k]:.4g}, {y[k]:.4g}) lies "
            f"beyond {MAX_COORDINATE:.0e} in any unit: no image or survey of an engine "
            "reaches it (a corrupt value?)")


def _hinge_of_the_beam(positions: dict[str, tuple[np.ndarray, np.ndarray]], source: LogSource,
                       chosen: Mapping, repairs: list[str]) -> tuple[np.ndarray, np.ndarray] | None:
    """The hinge (x, y) for psi: the tracked one, filled and checked by the beam through pivot
    and spigot (:mod:`.beam_hinge`; a note in ``repairs``), or None to keep it as tracked."""
    if not all(r in positions for r in ("pivot", "spigot", "hinge")):
        return None
    fit = beam_hinge(*(np.column_stack(positions[r]) for r in ("pivot", "spigot", "hinge")))
    note = None if fit is None else hinge_note(fit, source.rows, chosen["hinge"].label)
    if note is None:
        return None
    repairs.append(note)
    return fit.xy[:, 0], fit.xy[:, 1]


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




def left_out_reason(log: ParsedLog, angle: str) -> str:
    """Why ``angle`` of a point log has no value at all where its points are in the file:
    the points whose positions :func:`from_points` left out (stuck on an occluder, off the
    engine's geometry) named, as a clause to append to the refusal ("" where none was).
    On the stress grid an adaptive template slid 5–12 px off the paper engine's hinge; its
    positions were all left out and the refusal named only ψ's column, which holds values."""
    names = log.point_names or {}
    ends = log.labels.get(angle, "").split(" -> ")
    dropped = [role for role, name in names.items() if name in ends and any(
        s.startswith(f"{role} ('") and ("stands still" in s or "off the engine's geometry" in s)
        for s in log.repairs)]
    if not dropped:
        return ""
    which = " and ".join(f"'{names[r]}'" for r in dropped)
    return (f": the file's positions of {which} were left out where the tracker stood still "
            "while the engine moved or left the engine's geometry (a tracker's wrong match), "
            f"which leaves no row with {angle}; retrack {which}")
