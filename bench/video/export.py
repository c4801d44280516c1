"""Tracked points written as the tools write them: DeepLabCut CSV and Kinovea trajectory CSV.

DeepLabCut (``analyze_videos(..., save_as_csv=True)``: its pandas table of MultiIndex columns
written by ``DataFrame.to_csv``): three header rows ``scorer`` / ``bodyparts`` / ``coords``
(``x, y, likelihood`` per bodypart), then one row per frame led by the frame index; image
pixels with y down; NaN as an empty cell; full float precision.

Kinovea (the trajectory CSV export, ``ExporterCSVTrajectory`` of Kinovea.ScreenManager):
one header row ``"Time","<object>/<point>/X","<object>/<point>/Y",…``, every cell quoted,
an empty cell (no quotes) for a missing value, ``,`` between cells with a decimal point
(English locale), CRLF line ends; numbers are 32-bit floats written by .NET Framework's
``float.ToString`` (7 significant digits); coordinates calibrated by a line of known length
(m per px) with the origin on a chosen pixel and y up, the axes the image's own (a tilted
or rolled camera is not corrected). The time column follows the user's time-code
preference (``Metadata.GetNumericalTime``), see :data:`KINOVEA_TIMES`; the header says
``Time`` whatever the unit.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

__all__ = ["DLC_SCORER", "KINOVEA_TIMES", "write_deeplabcut", "write_kinovea",
           "kinovea_coordinates", "kinovea_time"]

#: Kinovea's time column by time-code preference: "ms" whole milliseconds (the kinematics
#: dialogs' export, the layout trebuchet's reader documents), "classic" seconds rounded to
#: the millisecond (Kinovea's default time code), "milliseconds" unrounded milliseconds,
#: "frames" frame numbers.
KINOVEA_TIMES = ("ms", "classic", "milliseconds", "frames")

#: The scorer name DeepLabCut writes (network, project date, shuffle, training iterations).
DLC_SCORER = "DLC_resnet50_trebuchetVideoNov25shuffle1_100000"


def _number(v: float) -> str:
    """A float as pandas writes it (``repr``), empty for NaN."""
    return "" if not np.isfinite(v) else repr(float(v))


def write_deeplabcut(path: str | Path, names: Sequence[str], xy: np.ndarray,
                     likelihood: np.ndarray, scorer: str = DLC_SCORER) -> Path:
    """Write a DeepLabCut CSV of bodyparts ``names`` at pixels ``xy`` ((n, k, 2), y down)
    with ``likelihood`` ((n, k), 0–1); frame indices 0 … n − 1."""
    path = Path(path)
    k = len(names)
    lines = [",".join(["scorer"] + [scorer] * (3 * k)),
             ",".join(["bodyparts"] + [n for n in names for _ in range(3)]),
             ",".join(["coords"] + ["x", "y", "likelihood"] * k)]
    p = np.clip(np.nan_to_num(likelihood, nan=0.0), 0.0, 1.0)
    for i in range(xy.shape[0]):
        cells = [str(i)]
        for j in range(k):
            cells += [_number(xy[i, j, 0]), _number(xy[i, j, 1]), _number(p[i, j])]
        lines.append(",".join(cells))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def kinovea_coordinates(xy: np.ndarray, origin: np.ndarray, m_per_px: float) -> np.ndarray:
    """Kinovea's calibrated coordinates (m, y up) of pixels ``xy`` (y down) for a line
    calibration of ``m_per_px`` and the origin at pixel ``origin``."""
    d = (np.asarray(xy, dtype=float) - np.asarray(origin, dtype=float)) * m_per_px
    return np.stack([d[..., 0], -d[..., 1]], axis=-1)


def _kinovea_cell(v: float) -> str:
    """A quoted 32-bit float as .NET Framework writes it (7 significant digits), or an empty
    cell for NaN."""
    return "" if not np.isfinite(v) else f'"{float(np.float32(v)):.7G}"'


def kinovea_time(t: np.ndarray, fps: float, time_format: str = "ms") -> np.ndarray:
    """Kinovea's time column (see :data:`KINOVEA_TIMES`) for frame times ``t`` (s)."""
    frames = np.round(np.asarray(t, dtype=float) * fps)
    ms = frames * 1000.0 / fps
    if time_format == "ms":
        return np.round(ms)
    if time_format == "classic":
        return np.round(ms) / 1000.0
    if time_format == "milliseconds":
        return ms
    if time_format == "frames":
        return frames
    raise ValueError(f"time_format must be one of {KINOVEA_TIMES}, not {time_format!r}")


def write_kinovea(path: str | Path, names: Sequence[str], t: np.ndarray, coords: np.ndarray,
                  fps: float, time_format: str = "ms") -> Path:
    """Write a Kinovea trajectory CSV of points ``names`` (``object/point``) at frame times
    ``t`` (s from the first frame, written as ``time_format`` says) and calibrated
    coordinates ``coords`` ((n, k, 2), m, y up; NaN: not tracked in that frame)."""
    path = Path(path)
    header = ['"Time"'] + [f'"{n}/{axis}"' for n in names for axis in ("X", "Y")]
    lines = [",".join(header)]
    times = kinovea_time(t, fps, time_format)
    for i, ti in enumerate(times):
        cells = [_kinovea_cell(ti)]
        for j in range(len(names)):
            cells += [_kinovea_cell(coords[i, j, 0]), _kinovea_cell(coords[i, j, 1])]
        lines.append(",".join(cells))
    with open(path, "w", encoding="utf-8", newline="\r\n") as f:
        f.write("\n".join(lines) + "\n")
    return path
