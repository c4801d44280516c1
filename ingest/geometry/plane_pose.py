"""Where the engine's plane stands before a camera of known lens, from the engine's own
geometry (:func:`plane_from_engine`): the turn of the camera that keeps the engine's ties at
their lengths and its beam straight, and the roll that makes the counterweight hang plumb at
rest. Used with a camera file of :mod:`.user_calibration`, which fixes the lens only.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from scipy.optimize import least_squares

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model.scene import Engine

from .camera import rotation_from_angles


class Lens(Protocol):
    """What the fit needs of :class:`.user_calibration.Lens`: the camera matrix K (px) and
    the focal length (px) of the lens-free pixels."""

    matrix: np.ndarray

    @property
    def focal(self) -> float: ...

__all__ = ["PlanePose", "plane_from_engine", "rectified", "TIES"]


#: The engine's ties whose lengths the rectified image must keep: (point, point, length).
TIES = (("pivot", "spigot", "L1"), ("pivot", "hinge", "L2"), ("hinge", "counterweight", "L3"),
        ("spigot", "projectile", "L4"))
#: Soft-L1 scale of the ties' relative misfit (a tie 0.3 % off counts fully; tracker
#: outliers beyond it less and less).
TIE_SCALE = 3e-3
#: Starting pitches and yaws (rad) of the fit (the best of the nine is kept).
POSE_STARTS = (-0.2, 0.0, 0.2)


@dataclass(frozen=True)
class PlanePose:
    """Where the engine's plane stands before a camera of known lens: the virtual turn of
    the camera that faces it, ``pitch`` and ``yaw`` (rad), the ``roll`` (rad) that then makes
    the counterweight hang plumb at rest, ``scale`` (rectified units per m: px per m / focal),
    ``focal`` (px) and principal point ``centre`` (px, y up) of the lens-free pixels, and
    ``misfit`` (rms relative misfit of the engine's ties, dimensionless); ``plumb_frames``
    the rest frames the roll came from (0: the roll is not fixed)."""

    pitch: float
    yaw: float
    roll: float
    scale: float
    focal: float
    centre: tuple[float, float]
    misfit: float
    plumb_frames: int

    def to_plane(self, xy_up: np.ndarray) -> np.ndarray:
        """Lens-free pixels (…, 2, y up) to the engine's plane (m, y up, origin at the
        principal point's ray)."""
        q = rectified(xy_up, self.focal, self.centre, self.pitch, self.yaw) / self.scale
        c, s = np.cos(-self.roll), np.sin(-self.roll)
        return np.stack([c * q[..., 0] - s * q[..., 1], s * q[..., 0] + c * q[..., 1]], -1)


def rectified(xy_up: np.ndarray, focal: float, centre: tuple[float, float], pitch: float,
              yaw: float) -> np.ndarray:
    """Lens-free pixels (…, 2, y up) as a camera turned by ``pitch`` and ``yaw`` (rad, about
    its own x and y axes, :func:`.camera.rotation_from_angles` without roll) would see them:
    the ray ``((u − c)/f, 1)`` turned, then divided by its depth (dimensionless)."""
    R = rotation_from_angles(pitch, yaw, 0.0) @ np.diag([1.0, -1.0, -1.0])  # R_x R_y
    xy = (np.asarray(xy_up, dtype=float) - np.asarray(centre)) / focal
    ray = np.concatenate([xy, np.ones(xy.shape[:-1] + (1,))], axis=-1) @ R.T
    return ray[..., :2] / ray[..., 2:3]


def _tie_misfits(tracks: Mapping[str, np.ndarray], in_sling: np.ndarray, engine: Engine,
                 focal: float, centre: tuple[float, float], x: np.ndarray) -> np.ndarray:
    """Relative misfits of every tie (its rectified length over its length in m, over the
    scale, minus 1) and the beam's bend (sine of the angle between pivot − hinge and
    spigot − pivot), all frames, NaN left out."""
    pitch, yaw, scale = x
    q = {k: rectified(v, focal, centre, pitch, yaw) for k, v in tracks.items()}
    out = []
    for a, b, length in TIES:
        if a in q and b in q:
            d = np.hypot(*(q[b] - q[a]).T) / (getattr(engine, length) * scale) - 1.0
            out.append(d[in_sling] if b == "projectile" else d)
    if {"pivot", "spigot", "hinge"} <= set(q):
        u, w = q["spigot"] - q["pivot"], q["pivot"] - q["hinge"]
        out.append((u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0])
                   / (np.hypot(*u.T) * np.hypot(*w.T)))
    r = np.concatenate(out)
    return r[np.isfinite(r)]


def plane_from_engine(tracks: Mapping[str, np.ndarray], lens: Lens, engine: Engine,
                      in_sling: np.ndarray, at_rest: np.ndarray) -> PlanePose:
    """The plane's pose before a camera of known ``lens`` from the engine's own geometry.

    ``tracks`` {role: (n, 2)} lens-free px, y up (:meth:`Lens.undistort`); ``in_sling`` (n,)
    the frames whose projectile hangs L4 from the spigot; ``at_rest`` (n,) frames before the
    shot. With the focal length known, a turn of the camera (pitch, yaw) that faces the
    plane leaves a similar image of it: the fit (soft-L1 least squares from nine starts)
    finds the turn and the scale that keep the engine's ties at their lengths (L1 pivot to
    spigot, L2 pivot to hinge, L3 hinge to counterweight, L4 spigot to projectile in the
    sling) and its beam straight. The roll then makes the counterweight hang plumb at rest
    (ψ = −90°; not for a rigid counterweight, ``plumb_frames`` 0)."""
    K = lens.matrix
    focal, centre = lens.focal, (float(K[0, 2]), float(-K[1, 2]))
    if not {"pivot", "spigot"} <= set(tracks):
        raise TrebuchetInputError("the plane's pose from the engine needs the pivot and the "
                                  f"spigot tracked; points: {sorted(tracks)}")
    q0 = rectified(tracks["spigot"], focal, centre, 0.0, 0.0) - rectified(
        tracks["pivot"], focal, centre, 0.0, 0.0)
    s0 = float(np.nanmedian(np.hypot(*q0.T))) / engine.L1
    best = None
    for p0 in POSE_STARTS:
        for y0 in POSE_STARTS:
            sol = least_squares(lambda x: _tie_misfits(tracks, in_sling, engine, focal, centre,
                                                       x), [p0, y0, s0], loss="soft_l1",
                                f_scale=TIE_SCALE, x_scale=[0.1, 0.1, s0])
            if best is None or sol.cost < best.cost:
                best = sol
    pitch, yaw, scale = (float(v) for v in best.x)
    misfit = float(np.sqrt(np.mean(best.fun ** 2)))
    roll, plumb = 0.0, 0
    if engine.counterweight_offset is None and {"hinge", "counterweight"} <= set(tracks):
        q = {k: rectified(tracks[k], focal, centre, pitch, yaw) for k in ("hinge",
                                                                        "counterweight")}
        d = q["counterweight"] - q["hinge"]
        hang = np.arctan2(d[:, 1], d[:, 0])[at_rest]
        hang = hang[np.isfinite(hang)]
        if hang.size:
            roll, plumb = float(np.median(hang)) + np.pi / 2, int(hang.size)
    return PlanePose(pitch, yaw, roll, scale, focal, centre, misfit, plumb)
