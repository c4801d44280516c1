"""A point log's angles with the user's camera file and the engine's geometry together.

A camera file (OpenCV's camera matrix and distortion) fixes the lens, and
:func:`~trebuchet.ingest.logs.read_log.read_log` has already taken the lens out of the
tracked pixels; it does not fix where the engine's plane stands before the camera. With the
scene known, :func:`posed_log` finds that too, from the engine's own geometry
(:func:`~trebuchet.ingest.geometry.plane_pose.plane_from_engine`: the ties L1, L2, L3,
L4 kept at their lengths and the beam straight fix the plane's tilt, the counterweight
hanging plumb at rest its roll), takes every tracked point to the plane and takes the
angles from two points each as ``read_log`` does
(:func:`~trebuchet.ingest.geometry.points.point_angles`): they keep their frame-by-frame
noise, which the smoother expects, and lose most of the tilt's error.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.ingest.calibrated_angles import point_tracks
from trebuchet.ingest.geometry.plane_pose import plane_from_engine
from trebuchet.ingest.geometry.points import point_angles
from trebuchet.ingest.geometry.shot_frames import rest_frames
from trebuchet.ingest.geometry.user_calibration import UserCalibration
from trebuchet.model.scene import Scene

__all__ = ["posed_log"]


def posed_log(log: pd.DataFrame, scene: Scene, calibration: UserCalibration
              ) -> tuple[pd.DataFrame, tuple[str, ...]]:
    """``log`` (read with ``calibration``, a camera file alone: lens-free pixels) with
    ``theta``, ``psi``, ``phi`` (rad) from its points taken to the engine's plane by the
    pose the engine's geometry gives, and the note saying what was found. Unchanged (no
    note) for known points (they fix the plane already) or a log without the pivot and
    spigot. The log's gaps stay gaps (φ cut where the stone flies)."""
    tracks = point_tracks(log)
    if (calibration.fixes_plane or calibration.lens is None or tracks is None
            or not {"pivot", "spigot"} <= set(tracks)):
        return log, ()
    phi = log["phi"].to_numpy(dtype=float)
    pose = plane_from_engine(tracks, calibration.lens, scene.engine,
                             in_sling=np.isfinite(phi), at_rest=rest_frames(tracks["spigot"]))
    angles = point_angles({role: tuple(pose.to_plane(xy).T) for role, xy in tracks.items()})
    out = log.copy()
    out.attrs = dict(log.attrs)
    for name, values in angles.items():
        had = np.isfinite(log[name].to_numpy(dtype=float))
        out[name] = np.where(had, values, np.nan)
    roll = (f"roll {np.degrees(pose.roll):.2f}° from the counterweight hanging plumb on "
            f"{pose.plumb_frames} rest frames" if pose.plumb_frames else
            "roll not fixed (no plumb counterweight at rest)")
    note = (f"the engine's plane before the camera of {Path(calibration.source).name} found "
            f"from the engine's geometry: turned {np.degrees(pose.pitch):.1f}° (pitch) and "
            f"{np.degrees(pose.yaw):.1f}° (yaw) from facing it, {roll}, "
            f"{pose.scale * pose.focal:.1f} px/m; its ties misfit {100 * pose.misfit:.2f} % "
            "rms; the angles are the points' on that plane (this pose's own uncertainty is "
            "not in the bands)")
    return out, (note,)
