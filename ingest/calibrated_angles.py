"""A point log's angles through the image the engine calibrates itself (issue 15).

:func:`~trebuchet.ingest.logs.read_log.read_log` turns tracked points into angles by atan2 of
two points, which is right only for a camera square to the engine's plane with a perfect
lens. With the scene known, :func:`calibrated_log` fits the camera (tilt, roll, lens
distortion, scale) and every frame's angles to all the tracked points at once
(:func:`~trebuchet.ingest.geometry.calibration.calibrate`), flags points that break the
engine's geometry (stuck on an occluder, jumped), and hands the smoother the fitted angles.
The calibration's own uncertainty, common to every frame, is returned for the bands.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from trebuchet.ingest.geometry.calibration import Calibration, calibrate
from trebuchet.model.scene import Scene

__all__ = ["CalibratedLog", "calibrated_log", "point_tracks", "widened_by_calibration"]

ROLES = ("pivot", "spigot", "hinge", "counterweight", "projectile")


@dataclass(frozen=True, eq=False)
class CalibratedLog:
    """The log with the calibrated angles (rad; φ left out where read_log cut it, the stone
    in flight), the calibration itself, the angle sd the calibration carries into every
    frame alike (rad per angle and frame, for the bands), the notes for the result (the
    camera found, what was fitted, the points left out) and the warnings (points that break
    the engine's geometry, named with their frames)."""

    log: pd.DataFrame
    calibration: Calibration
    common_sd: dict[str, np.ndarray]
    notes: tuple[str, ...]
    warnings: tuple[str, ...]


def point_tracks(log: pd.DataFrame) -> dict[str, np.ndarray] | None:
    """The tracked points of a point log (``attrs["points"]`` of ``read_log``) as
    ``{role: (n, 2)}`` in the file's unit, y up; None for a log of angles."""
    points = log.attrs.get("points")
    if not points:
        return None
    out = {}
    for role in ROLES:
        if f"{role}_x" in points:
            out[role] = np.column_stack([np.asarray(points[f"{role}_x"], dtype=float),
                                         np.asarray(points[f"{role}_y"], dtype=float)])
    return out or None


#: Tracking noise (file units per coordinate) taken for pixels: the calibration's priors on
#: marker offsets and lens distortion are in pixels of a tracker's noise (about 1 px).
PIXEL_NOISE = (0.1, 10.0)


def tracking_noise(tracks: dict[str, np.ndarray]) -> float:
    """Robust sd per coordinate (file units) of the tracked positions' scatter: the pivot's
    about its median (it does not move), else the spigot's second differences (/√6)."""
    pivot = tracks.get("pivot")
    if pivot is not None and np.isfinite(pivot).all(axis=1).sum() >= 10:
        ok = pivot[np.isfinite(pivot).all(axis=1)]
        dev = np.abs(ok - np.median(ok, axis=0))
        return max(float(np.median(dev)) / 0.6745, 1e-12)
    xy = tracks.get("spigot", tracks.get("hinge"))
    d2 = np.diff(xy, n=2, axis=0)
    d2 = np.abs(d2[np.isfinite(d2).all(axis=1)])
    return max(float(np.median(d2)) / 0.6745 / np.sqrt(6.0), 1e-12) if d2.size else 1.0


def calibrated_log(log: pd.DataFrame, scene: Scene) -> CalibratedLog | None:
    """``log`` with ``theta``, ``psi``, ``phi`` from the calibration of its tracked points
    against ``scene``, or None where the log holds no points (or too few to fit). The
    projectile after it leaves the sling is fitted on the scene's vacuum parabola; φ stays
    NaN where ``read_log`` found the stone in flight."""
    tracks = point_tracks(log)
    if tracks is None or not ({"spigot", "hinge"} & set(tracks)):
        return None
    t = log["t"].to_numpy(dtype=float)
    vacuum = scene.flight.model == "vacuum"
    unit = tracking_noise(tracks)
    rescaled = not (PIXEL_NOISE[0] <= unit <= PIXEL_NOISE[1])
    if rescaled:  # world units (m, cm): the priors speak of pixels of the tracker's noise
        tracks = {role: xy / unit for role, xy in tracks.items()}
    cal = calibrate(tracks, scene.engine, H=scene.start.H, g=scene.g if vacuum else None,
                    t=t, trough=scene.projectile == "trough")
    out = log.copy()
    out.attrs = dict(log.attrs)
    for name in ("theta", "psi", "phi"):
        fitted = np.asarray(getattr(cal, name), dtype=float)
        had = np.isfinite(log[name].to_numpy(dtype=float))
        # keep the log's gaps where it had no angle (phi cut at the stone's flight)
        out[name] = np.where(had | (name != "phi"), fitted, np.nan)
    common = {name: np.nan_to_num(np.asarray(getattr(cal, f"{name}_sd_calibration"),
                                             dtype=float))
              for name in ("theta", "psi", "phi")}
    flagged = tuple(f.note for f in cal.flagged)
    scaled = (f"(the points, in the file's unit with a tracking noise of {unit:.3g}, were "
              f"fitted in units of that noise: px above means that unit / {unit:.3g})",
              ) if rescaled else ()
    notes = (cal.summary(), *scaled, *cal.notes, *flagged)
    return CalibratedLog(out, cal, common, notes, flagged)


def widened_by_calibration(est: pd.DataFrame, common_sd: dict[str, np.ndarray]
                           ) -> pd.DataFrame:
    """The smoother's output ``est`` with each angle's sd (and the angle's variance in
    ``attrs["cov"]``) widened by the calibration's sd ``common_sd`` (rad), in quadrature: the
    camera's uncertainty moves every frame's angle alike, so it is a bias of the whole log
    that the smoother cannot see in the scatter."""
    out = est.copy()
    out.attrs = dict(est.attrs)
    cov = dict(est.attrs["cov"])
    for name, sd in common_sd.items():
        if name not in cov or not np.any(sd > 0):
            continue
        out[name + "_sd"] = np.sqrt(est[name + "_sd"].to_numpy(dtype=float) ** 2 + sd**2)
        c = np.array(cov[name], dtype=float, copy=True)
        c[:, 0, 0] += sd**2
        cov[name] = c
    out.attrs["cov"] = cov
    return out
