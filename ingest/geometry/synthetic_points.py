"""Synthetic point logs: a simulated shot filmed by a known camera (tests and benches).

:func:`simulated_plane_track` runs the simulator and gives the five points in the engine's
plane (m) frame by frame, with a stretch at rest before the trigger; :func:`film` projects
them through a :class:`~.camera.Camera` and adds what trackers add: random pixel noise,
a constant sub-pixel offset per marker, points outside the picture lost.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from trebuchet.model.scene import Scene
from trebuchet.model.simulate import simulate

from .camera import Camera
from .engine_points import POINTS, plane_points

__all__ = ["PlaneTrack", "simulated_plane_track", "film"]


@dataclass(frozen=True)
class PlaneTrack:
    """A simulated shot frame by frame: ``t`` (n,) s after the trigger, true angles
    ``theta``, ``psi``, ``phi`` (n,) rad (φ NaN after the release), the points (n, 2) m in
    the plane (``points``; the projectile in flight too), ``at_rest`` before the trigger,
    ``in_trough`` (phase I and rest, for a scene starting in the trough), ``in_sling``
    (before the release)."""

    t: np.ndarray
    theta: np.ndarray
    psi: np.ndarray
    phi: np.ndarray
    points: dict[str, np.ndarray]
    at_rest: np.ndarray
    in_trough: np.ndarray
    in_sling: np.ndarray


def simulated_plane_track(scene: Scene, fps: float, rest: float = 0.2,
                          after_release: float = 0.25) -> PlaneTrack:
    """The shot of ``scene`` at ``fps`` frames/s, with ``rest`` s at rest before the
    trigger and ``after_release`` s after the release."""
    run0 = simulate(scene, t_eval=[0.0], after_release=after_release + 0.05)
    end = run0.attrs["events"]["release"] + after_release
    t_move = np.arange(0.0, end, 1.0 / fps)
    run = simulate(scene, t_eval=t_move, after_release=after_release + 0.05)
    n_rest = int(round(rest * fps))
    t = np.concatenate([-np.arange(n_rest, 0, -1) / fps, t_move])
    s = scene.start

    def with_rest(column: str, value: float) -> np.ndarray:
        return np.concatenate([np.full(n_rest, value), run[column].to_numpy()])

    theta, psi, phi = with_rest("theta", s.theta), with_rest("psi", s.psi), with_rest("phi",
                                                                                      s.phi)
    phase = np.concatenate([np.ones(n_rest, int), run["phase"].to_numpy()])
    pts = plane_points(theta, psi, np.nan_to_num(phi), scene.engine, s.H)
    x0, y0 = pts["projectile"][n_rest, 0], pts["projectile"][n_rest, 1]
    pts["projectile"] = np.column_stack([with_rest("x_m", x0), with_rest("y_m", y0)])
    at_rest = t < 0
    in_trough = (phase == 1) if scene.projectile == "trough" else np.zeros(t.size, bool)
    return PlaneTrack(t, theta, psi, phi, pts, at_rest, in_trough, phase < 3)


def film(track: PlaneTrack, camera: Camera, image_size: tuple[float, float],
         noise_px: float, rng: np.random.Generator,
         offsets_px: Mapping[str, tuple[float, float]] | None = None,
         points: tuple[str, ...] = POINTS) -> dict[str, np.ndarray]:
    """Pixel tracks (n, 2; x along the rows, y up = −row) of ``points`` of ``track`` seen
    by ``camera``: Gaussian noise of sd ``noise_px`` per coordinate, plus the constant
    ``offsets_px`` of each marker; NaN where the point is outside the picture of
    ``image_size`` (width, height) px."""
    out = {}
    for name in points:
        uv = camera.project(track.points[name])
        uv = uv + rng.normal(0.0, noise_px, uv.shape)
        if offsets_px and name in offsets_px:
            uv = uv + np.asarray(offsets_px[name], dtype=float)
        inside = ((uv[:, 0] >= 0) & (uv[:, 0] <= image_size[0]) & (uv[:, 1] <= 0)
                  & (uv[:, 1] >= -image_size[1]))
        out[name] = np.where(inside[:, None], uv, np.nan)
    return out
