"""The angles a fit takes from a log, and the frames between which the log puts the release.

A log of angles is taken as it is read; a log of tracked points gets its angles as
``reconstruct`` gets them (:func:`~trebuchet.ingest.calibrated_angles.calibrated_log`: the
engine calibrates the image, the default; or a user's camera file posed on the engine,
:func:`~trebuchet.ingest.user_calibrated.posed_log`), so that ``identify`` and ``forces``
fit and smooth the same angles.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.core.errors import TrebuchetDataWarning, TrebuchetInputError, warn_at_caller
from trebuchet.ingest.calibrated_angles import calibrated_log
from trebuchet.ingest.geometry.user_calibration import read_calibration
from trebuchet.ingest.logs.result import read_log_info
from trebuchet.ingest.user_calibrated import posed_log
from trebuchet.model.scene import Scene

__all__ = ["angle_log", "release_bracket", "TRACK_END_FRAMES"]

#: The sling's track must end this many frames before the beam's and the counterweight's for
#: its end to bound the release (as ``reconstruct``'s ``sling_track_end``).
TRACK_END_FRAMES = 3


def angle_log(log: str | Path | pd.DataFrame, scene: Scene, *, fps: float | None = None,
              columns: Mapping[str, str] | None = None,
              points: Mapping[str, str] | None = None,
              calibration: str | Path | None = None, image_calibration: str = "engine",
              read_options: Mapping[str, object] | None = None
              ) -> tuple[pd.DataFrame, str, tuple[float, float] | None]:
    """The log's table of angles (``t`` s, ``theta``, ``psi``, ``phi`` rad), its source's name
    and, for a point log whose stone was seen leaving its sling's circle, that time and its sd
    (s)."""
    user = read_calibration(calibration) if calibration is not None else None
    if isinstance(log, pd.DataFrame):
        if points is not None or user is not None:
            raise TrebuchetInputError("identify: points= and calibration= need a log file of "
                                      "point positions, not a table of angles")
        frame = log.rename(columns=dict(columns)) if columns else log.copy()
        if "t" not in frame.columns and "frame" in frame.columns and fps:
            frame.insert(0, "t", frame["frame"].to_numpy(dtype=float) / float(fps))
        return frame, "log", None
    if not isinstance(log, str | Path):
        raise TrebuchetInputError("identify: expected a log file path or a DataFrame, got "
                                  f"{type(log).__name__}")
    from trebuchet.ingest.logs.read_log import read_log

    options = {k: v for k, v in (read_options or {}).items() if v is not None}
    frame = read_log(log, fps=fps, columns=columns, points=points, calibration=user, **options)
    info = read_log_info(frame)
    source = str(log) if info is None else info.source
    if user is not None and image_calibration != "engine":
        frame, _ = posed_log(frame, scene, user)
    if image_calibration == "engine":
        in_pixels = False if user is not None and user.fixes_plane else None
        calibrated = calibrated_log(frame, scene, in_pixels=in_pixels)
        if calibrated is not None:
            frame = calibrated.log
            for note in calibrated.warnings:
                warn_at_caller(f"{Path(source).name}: {note}", TrebuchetDataWarning)
    leaves = None if info is None else info.leaves_sling
    return frame, source, leaves


def release_bracket(t: np.ndarray, z: np.ndarray) -> tuple[float, float] | None:
    """The frames (s) between which the sling's track ends while the beam's and the
    counterweight's go on for :data:`TRACK_END_FRAMES` frames more: the release lies
    between them (where a tracked stone is seen leaving its sling's circle, ``read_log`` cut
    the track there). None where the sling's track goes on to the end, or is not tracked."""
    ok = [np.flatnonzero(np.isfinite(za)) for za in z]
    if ok[2].size == 0 or (ok[0].size == 0 and ok[1].size == 0):
        return None
    last = int(ok[2][-1])
    others = max(int(o[-1]) for o in ok[:2] if o.size)
    if others - last < TRACK_END_FRAMES or last + 1 >= t.size:
        return None
    return float(t[last]), float(t[last + 1])
