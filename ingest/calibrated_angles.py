"""A point log's angles through the image the engine calibrates itself (issue 15).

:func:`~trebuchet.ingest.logs.read_log.read_log` turns tracked points into angles by atan2 of
two points, which is right only for a camera square to the engine's plane with a perfect
lens. With the scene known, :func:`calibrated_log` fits the camera (tilt, roll, lens
distortion, scale, each marker's offset) and every frame's angles to all the tracked points
at once (:func:`~trebuchet.ingest.geometry.calibration.calibrate`), flags points that break
the engine's geometry (stuck on an occluder, jumped), and hands the smoother the angles of
the points taken to the engine's plane through the camera found (:func:`mapped_angles`).
The calibration's own uncertainty, common to every frame, is returned for the bands.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from trebuchet.ingest.geometry.beam_hinge import beam_hinge
from trebuchet.ingest.geometry.calibration import Calibration, calibrate
from trebuchet.ingest.geometry.points import point_angles
from trebuchet.ingest.logs.read_log import PIXEL_FORMATS  # image pixels: the priors' unit
from trebuchet.ingest.logs.result import read_log_info
from trebuchet.ingest.smoothing.result import smoothing_of, with_smoothing
from trebuchet.model.scene import Scene

__all__ = ["CalibratedLog", "calibrated_log", "mapped_angles", "plane_points", "point_tracks",
           "widened_by_calibration", "pixel_factor", "beam_length"]

ROLES = ("pivot", "spigot", "hinge", "counterweight", "projectile")


@dataclass(frozen=True, eq=False)
class CalibratedLog:
    """The log with the calibrated angles (rad; φ left out where read_log cut it, the stone
    in flight), the calibration itself, the angle sd the calibration carries into every
    frame alike (rad per angle and frame, for the bands), the notes for the result (the
    camera found, what was fitted, the points left out) and the warnings (points that break
    the engine's geometry, named with their frames) and the points in the engine's plane
    (``t`` and ``<role>_x``, ``<role>_y``, :func:`plane_points`; None where the calibration
    was refused)."""

    log: pd.DataFrame
    calibration: Calibration
    common_sd: dict[str, np.ndarray]
    notes: tuple[str, ...]
    warnings: tuple[str, ...]
    plane: pd.DataFrame | None = None


def point_tracks(log: pd.DataFrame) -> dict[str, np.ndarray] | None:
    """The tracked points of a point log (``ReadLog.points`` of ``read_log``'s
    ``attrs["log"]``) as ``{role: (n, 2)}`` in the file's unit, y up; None for a log of
    angles."""
    info = read_log_info(log)
    points = None if info is None else info.points
    if not points:
        return None
    out = {}
    for role in ROLES:
        if f"{role}_x" in points:
            out[role] = np.column_stack([np.asarray(points[f"{role}_x"], dtype=float),
                                         np.asarray(points[f"{role}_y"], dtype=float)])
    return out or None


#: A beam shorter than this many file units is not in pixels (a file in m or cm)...
PIXEL_BEAM = 50.0
#: ...and is fitted in pseudo-pixels that put the long arm L1 at this many: a camera
#: framing the engine puts it at a few hundred pixels.
PSEUDO_PIXEL_BEAM = 500.0


def beam_length(tracks: dict[str, np.ndarray]) -> float:
    """The median pivot-to-spigot distance of the tracks (file units; NaN if not tracked)."""
    if "pivot" not in tracks or "spigot" not in tracks:
        return float("nan")
    d = np.hypot(*(tracks["spigot"] - tracks["pivot"]).T)
    return float(np.nanmedian(d)) if np.isfinite(d).any() else float("nan")


def pixel_factor(tracks: dict[str, np.ndarray], fmt: str | None) -> float:
    """The factor that takes the file's unit to (pseudo-)pixels: 1 for image formats and for
    beams of at least :data:`PIXEL_BEAM` units, else the one that makes the beam
    :data:`PSEUDO_PIXEL_BEAM` long."""
    beam = beam_length(tracks)
    if fmt in PIXEL_FORMATS or not np.isfinite(beam) or beam >= PIXEL_BEAM:
        return 1.0
    return PSEUDO_PIXEL_BEAM / beam


def calibrated_log(log: pd.DataFrame, scene: Scene, *, in_pixels: bool | None = None
                   ) -> CalibratedLog | None:
    """``log`` with ``theta``, ``psi``, ``phi`` from the calibration of its tracked points
    against ``scene``, or None where the log holds no points (or too few to fit). The
    projectile after it leaves the sling is fitted on the scene's vacuum parabola; φ stays
    NaN where ``read_log`` found the stone in flight. ``in_pixels``: whether the points are
    image pixels (None: from the log's format; False for points a user's calibration took
    to the plane in m)."""
    tracks = point_tracks(log)
    if tracks is None or not ({"spigot", "hinge"} & set(tracks)):
        return None
    t = log["t"].to_numpy(dtype=float)
    vacuum = scene.flight.model == "vacuum"
    factor = pixel_factor(tracks, read_log_info(log).format if in_pixels is not False else None)
    if factor != 1.0:  # world units (m, cm): the priors speak of pixels
        tracks = {role: xy * factor for role, xy in tracks.items()}
    cal = calibrate(tracks, scene.engine, H=scene.start.H, g=scene.g if vacuum else None,
                    t=t, trough=scene.projectile == "trough")
    out = log.copy()
    plane = plane_points(tracks, cal)
    angles = point_angles({role: (p[:, 0], p[:, 1]) for role, p in plane.items()})
    for name in ("theta", "psi", "phi"):
        had = log[name].to_numpy(dtype=float)
        z = np.asarray(angles.get(name, np.full(len(log), np.nan)), dtype=float)
        z = z + 2.0 * np.pi * np.round((had - z) / (2.0 * np.pi))  # the log's branch
        # the log's gaps stay (points read_log left out, phi cut at the stone's flight)
        out[name] = np.where(np.isfinite(had), z, np.nan)
    common = {name: np.nan_to_num(np.asarray(getattr(cal, f"{name}_sd_calibration"),
                                             dtype=float))
              for name in ("theta", "psi", "phi")}
    flagged = tuple(f.note for f in cal.flagged)
    scaled = (f"(the points, in the file's length unit, were fitted scaled by {factor:.4g} "
              "to pseudo-pixels: px above means that unit / "
              f"{factor:.4g})",) if factor != 1.0 else ()
    notes = (cal.summary(), *scaled, *(n for n in cal.notes if n not in flagged), *flagged)
    apart = disagreement_deg(log, out)
    if apart > MAX_DISAGREEMENT_DEG:
        refused = (f"the engine's self-calibration of the image was not used: the camera it "
                   f"found ({cal.summary()}) puts the angles a median {apart:.1f}° from the "
                   f"image's own (more than {MAX_DISAGREEMENT_DEG:g}°), a fit caught in a "
                   "wrong camera; the angles are the image's, as read")
        zero = {name: np.zeros(len(log)) for name in common}
        return CalibratedLog(log.copy(), cal, zero, (refused,), (refused,))
    points = pd.DataFrame({"t": t} | {f"{role}_{c}": xy[:, j] for role, xy in plane.items()
                                      for j, c in enumerate("xy")})
    return CalibratedLog(out, cal, common, notes, flagged, points)


#: Self-calibrated angles further than this (°, median over the frames, the worst of θ,
#: ψ, φ) from the image's own are refused: a camera tilted by up to 15° and rolled by 1°
#: moves them by at most 1.5° (the video bench), a fit caught in a wrong camera (a
#: 40° roll on the backyard engine filmed at 10° tilt) by tens of degrees.
MAX_DISAGREEMENT_DEG = 5.0


def disagreement_deg(log: pd.DataFrame, calibrated: pd.DataFrame) -> float:
    """The largest over θ, ψ, φ of the median |calibrated − read| angle (°)."""
    worst = 0.0
    for name in ("theta", "psi", "phi"):
        d = calibrated[name].to_numpy(dtype=float) - log[name].to_numpy(dtype=float)
        d = np.abs(np.angle(np.exp(1j * d)))
        if np.isfinite(d).any():
            worst = max(worst, float(np.degrees(np.nanmedian(d))))
    return worst


def plane_points(tracks: dict[str, np.ndarray], cal: Calibration) -> dict[str, np.ndarray]:
    """Each tracked point (n, 2) in the engine's plane through the camera found: its marker
    offset (px) taken off, the lens undone and the projective map inverted
    (``Camera.unproject``); NaN where missing or flagged; the hinge, where pivot and spigot
    are tracked, taken from the beam through them as ``read_log`` takes it."""
    camera = cal.camera
    plane = {}
    for role, xy in tracks.items():
        xy = np.array(xy, dtype=float, copy=True)
        gap = cal.gaps.get(role)
        if gap is not None:
            xy[np.asarray(gap, bool)] = np.nan
        plane[role] = camera.unproject(xy - cal.offsets.get(role, 0.0))
    if all(r in plane for r in ("pivot", "spigot", "hinge")):  # the hinge as read_log takes it
        beam = beam_hinge(plane["pivot"], plane["spigot"], plane["hinge"])
        if beam is not None:
            plane["hinge"] = beam.xy
    return plane


def mapped_angles(tracks: dict[str, np.ndarray], cal: Calibration) -> dict[str, np.ndarray]:
    """θ, ψ, φ (rad, the paper's branch; NaN where a point is missing or flagged) by the
    same pairs of points as ``read_log`` takes (:data:`.geometry.points.NEEDS`) from the
    points in the engine's plane (:func:`plane_points`).

    Not the calibration's own per-frame angles (``cal.theta`` …, a constrained fit of every
    point of the frame): where its constraints switch (the stone leaving the trough) or
    the set of tracked points changes, that fit steps by the points' small misfits, and
    the smoother reads the step as an acceleration. Measured on rendered and tracked shots
    (240 fps, frame members in front): the paper engine, 10° tilt, |F_R| RMS error 37 % of
    its peak with the fit's angles, 3.3 % with these (3.3 % raw, θ RMS 0.42° raw, 0.20°
    both); the backyard engine, 10° tilt, 19 % against 0.8 % (1.4 % raw)."""
    plane = plane_points(tracks, cal)
    return point_angles({role: (p[:, 0], p[:, 1]) for role, p in plane.items()})


def widened_by_calibration(est: pd.DataFrame, common_sd: dict[str, np.ndarray]
                           ) -> pd.DataFrame:
    """The smoother's output ``est`` with each angle's sd (and the angle's variance in
    the smoothing's ``cov``) widened by the calibration's sd ``common_sd`` (rad), in quadrature: the
    camera's uncertainty moves every frame's angle alike, so it is a bias of the whole log
    that the smoother cannot see in the scatter."""
    out = est.copy()
    fit = smoothing_of(est)
    cov = dict(fit.cov)
    for name, sd in common_sd.items():
        if name not in cov or not np.any(sd > 0):
            continue
        out[name + "_sd"] = np.sqrt(est[name + "_sd"].to_numpy(dtype=float) ** 2 + sd**2)
        c = np.array(cov[name], dtype=float, copy=True)
        c[:, 0, 0] += sd**2
        cov[name] = c
    return with_smoothing(out, fit.replace(cov=cov))
