"""anipose 3-D output (``anipose triangulate``: ``pose-3d/<video>.csv``).

Layout, as anipose writes it (lambdaloop/anipose, ``anipose/triangulate.py``; see
docs/formats.md)::

    axle_x,axle_y,axle_z,axle_error,axle_ncams,axle_score,arm_tip_x,...,M_00,...,center_2,fnum
    1978.06,-3345.27,12043.57,2.12,3.0,0.958,-2763.59,...,1.0,...,0.0,0

* ``<joint>_x/_y/_z`` in the calibration's unit (usually mm) in the first camera's frame
  (or rotated by ``M`` and centred on ``center`` when the anipose config sets axes); NaN
  where fewer than two cameras saw the joint; ``_error``, ``_ncams``, ``_score`` are not
  used (anipose has already dropped the points below its own score threshold);
* ``fnum`` is the frame number: ``t = fnum / fps`` (``fps`` is required);
* the engine moves in one plane: the plane is fitted to every present point (least
  squares), and the paper's axes in it are taken from the engine itself: **up** is
  opposite to the counterweight hanging below its hinge in the first frames (the engine
  at rest), **x** points from the pivot toward the spigot's side at rest (the paper's
  start pose has θ in (-90°, 90°)). Those four points are found by their names or by
  ``points=``; both the fit and the rest pose are reported (a repair note), and a plane
  the points leave by more than :data:`MAX_OUT_OF_PLANE` of its size is an error.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.readers.keypoints import keypoint_source
from trebuchet.ingest.readers.limits import MAX_COORDINATE
from trebuchet.ingest.readers.mapping import ROLES, Candidate, check_mapping, resolve, role_default
from trebuchet.ingest.readers.source import LogSource
from trebuchet.ingest.readers.table import header_and_rows, numeric_column

#: Frames at the start of the log taken as the engine at rest (at most).
REST_FRAMES = 10
#: Largest rms distance of the points from their plane, as a fraction of the plane's size.
MAX_OUT_OF_PLANE = 0.05
AXES = ("x", "y", "z")


def looks_like_anipose(numbered: list[tuple[int, str]]) -> bool:
    """A comma header with ``fnum`` and ``<joint>_x``, ``_y``, ``_z`` columns."""
    if not numbered:
        return False
    cells = [c.strip() for c in numbered[0][1].split(",")]
    return "fnum" in cells and any(c.endswith("_z") and c[:-2] + "_x" in cells for c in cells)


def read_anipose(numbered: list[tuple[int, str]], fps: float | None,
                 points: Mapping[str, str] | None = None) -> LogSource:
    """Read an anipose 3-D CSV into in-plane positions (see the module doc)."""
    header, data = header_and_rows(numbered, ",")
    cols = {c.strip(): i for i, c in enumerate(header.cells)}
    if "fnum" not in cols:
        raise TrebuchetInputError("an anipose 3-D file needs the column 'fnum'")
    joints = [c[:-2] for c in cols if c.endswith("_x")
              and all(f"{c[:-2]}_{a}" in cols for a in AXES)]
    if not joints:
        raise TrebuchetInputError("no <joint>_x, _y, _z columns")
    rows = np.array([line.number for line in data])
    frames = numeric_column(data, cols["fnum"], "fnum")
    xyz = {j: np.column_stack([numeric_column(data, cols[f"{j}_{a}"], f"{j}_{a}")
                               for a in AXES]) for j in joints}
    for j, p in xyz.items():
        with np.errstate(invalid="ignore"):
            far = np.abs(p) > MAX_COORDINATE
        if far.any():
            k, a = (int(v[0]) for v in np.nonzero(far))
            raise TrebuchetInputError.at(
                f"row {rows[k]}, column '{j}_{AXES[a]}'", f"{p[k, a]:.4g} lies beyond "
                f"{MAX_COORDINATE:.0e} in any unit: no survey of an engine reaches it (a "
                "corrupt value?)")
    origin, normal, spread, rms = _plane(xyz)
    roles = _roles(joints, points)
    up, right, rest = _axes(xyz, roles, normal)
    parts = {}
    for j in joints:
        d = xyz[j] - origin
        parts[j] = (d @ right, d @ up, None)
    note = (f"anipose 3-D points taken into the engine's plane (fitted to every point; rms "
            f"distance from it {rms:.3g}, {rms / spread:.2%} of its size), up opposite to "
            f"'{roles['counterweight']}' hanging below '{roles['hinge']}' and x toward "
            f"'{roles['spigot']}' from '{roles['pivot']}' over the first {rest} frames (the "
            "engine at rest)")
    return keypoint_source("anipose", frames, rows, parts, fps, 0.0, time_label="fnum",
                           y_down=False, repairs=[note])


def _plane(xyz: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Centroid, unit normal, size (rms distance from the centroid) and rms out-of-plane
    distance of every present point."""
    pts = np.concatenate([p[np.isfinite(p).all(axis=1)] for p in xyz.values()])
    if len(pts) < 3:
        raise TrebuchetInputError("fewer than 3 present 3-D points")
    origin = pts.mean(axis=0)
    _, sv, vt = np.linalg.svd(pts - origin, full_matrices=False)
    spread = float(np.sqrt((sv[0] ** 2 + sv[1] ** 2) / len(pts)))
    rms = float(sv[2] / np.sqrt(len(pts)))
    if spread == 0 or rms > MAX_OUT_OF_PLANE * spread:
        raise TrebuchetInputError(
            f"the points do not lie in one plane (rms distance {rms:.3g} from the "
            f"best one, {rms / spread if spread else np.inf:.1%} of its size); the engine's "
            "motion must be planar")
    return origin, vt[2], spread, rms


def _roles(joints: list[str], points: Mapping[str, str] | None) -> dict[str, str]:
    """Joint name of pivot, spigot, hinge and counterweight (``points=`` or the names)."""
    cands = [Candidate(label=j, aliases=frozenset({j}), default=role_default(j)) for j in joints]
    chosen = resolve(cands, check_mapping(points, ROLES, "points"), ROLES, "points", "point")
    missing = [r for r in ("pivot", "spigot", "hinge", "counterweight") if r not in chosen]
    if missing:
        raise TrebuchetInputError(
            f"the engine's vertical and side come from its pivot, spigot, hinge and "
            f"counterweight at rest; no point for {', '.join(missing)} (joints: "
            f"{', '.join(joints)}); name them with points=")
    return {r: c.label for r, c in chosen.items()}


def _axes(xyz: dict[str, np.ndarray], roles: dict[str, str], normal: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray, int]:
    """Up and right unit vectors in the plane, from the first frames (the engine at rest)."""
    hang = xyz[roles["counterweight"]] - xyz[roles["hinge"]]
    arm = xyz[roles["spigot"]] - xyz[roles["pivot"]]
    both = np.nonzero(np.isfinite(hang).all(axis=1) & np.isfinite(arm).all(axis=1))[0]
    if both.size == 0:
        raise TrebuchetInputError(
            "no frame with the pivot, spigot, hinge and counterweight all present")
    first = both[:REST_FRAMES]
    down = hang[first].mean(axis=0)
    down = down - normal * (down @ normal)
    if np.linalg.norm(down) == 0:
        raise TrebuchetInputError("the counterweight does not hang from its hinge")
    up = -down / np.linalg.norm(down)
    right = np.cross(up, normal)
    if arm[first].mean(axis=0) @ right < 0:
        right = -right
    return up, right, int(first.size)
