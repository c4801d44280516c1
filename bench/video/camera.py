"""A pinhole camera with pose and radial distortion, filming the engine's plane from the side.

World axes are the model's (:mod:`trebuchet.model.kinematics`): origin on the ground under
the pivot, x right, y up, plus z out of the engine's plane toward the camera. The camera
looks at an aim point from ``distance`` m, pitched up by ``tilt_deg`` (it stands lower than
the aim point, as a tripod does) and rolled by ``roll_deg`` about its optical axis. Image
pixels: u right, v down, the centre of the first pixel at (0, 0).

Distortion is OpenCV's radial model on normalised coordinates,
``x_d = x (1 + k1 r² + k2 r⁴)``; ``k1 < 0`` is barrel distortion. :func:`undistort_pixels`
inverts it (the same result as ``cv2.undistortPoints`` with ``P = K``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Camera", "camera_matrix", "rotation", "centre", "project", "distort_normalized",
           "undistort_normalized", "undistort_pixels", "camera_framing"]


@dataclass(frozen=True)
class Camera:
    """Pose and intrinsics of a camera.

    ``aim``: world point (x, y, z in m) on the optical axis; ``distance``: m from the camera
    centre to ``aim``; ``tilt_deg``: pitch up (°); ``roll_deg``: roll about the optical axis
    (°; positive makes the world's horizontal rise to the right in the image);
    ``focal_px``: focal length (px); ``size``: image (width, height) in px; ``k1``, ``k2``:
    radial distortion; the principal point is the image centre.
    """

    aim: tuple[float, float, float]
    distance: float
    tilt_deg: float = 0.0
    roll_deg: float = 0.0
    focal_px: float = 800.0
    size: tuple[int, int] = (640, 480)
    k1: float = 0.0
    k2: float = 0.0

    @property
    def principal(self) -> tuple[float, float]:
        """Principal point (px): the image centre."""
        return ((self.size[0] - 1) / 2.0, (self.size[1] - 1) / 2.0)


def camera_matrix(cam: Camera) -> np.ndarray:
    """The 3×3 intrinsic matrix K (px)."""
    cx, cy = cam.principal
    return np.array([[cam.focal_px, 0.0, cx], [0.0, cam.focal_px, cy], [0.0, 0.0, 1.0]])


def rotation(cam: Camera) -> np.ndarray:
    """World-to-camera rotation (rows: the camera's right, down and forward axes in world
    coordinates)."""
    t, r = np.deg2rad(cam.tilt_deg), np.deg2rad(cam.roll_deg)
    forward = np.array([0.0, np.sin(t), -np.cos(t)])
    right = np.array([1.0, 0.0, 0.0])
    down = np.cross(forward, right)
    c, s = np.cos(r), np.sin(r)
    right, down = c * right + s * down, -s * right + c * down
    return np.array([right, down, forward])


def centre(cam: Camera) -> np.ndarray:
    """Camera centre in world coordinates (m)."""
    return np.asarray(cam.aim, dtype=float) - cam.distance * rotation(cam)[2]


def distort_normalized(xy: np.ndarray, k1: float, k2: float = 0.0) -> np.ndarray:
    """Radial distortion of normalised image coordinates ``xy`` (..., 2)."""
    r2 = np.sum(xy * xy, axis=-1, keepdims=True)
    return xy * (1.0 + k1 * r2 + k2 * r2 * r2)


def undistort_normalized(xy_d: np.ndarray, k1: float, k2: float = 0.0,
                         iterations: int = 20) -> np.ndarray:
    """Inverse of :func:`distort_normalized` by fixed-point iteration (as OpenCV does)."""
    xy = np.array(xy_d, dtype=float)
    for _ in range(iterations):
        r2 = np.sum(xy * xy, axis=-1, keepdims=True)
        xy = xy_d / (1.0 + k1 * r2 + k2 * r2 * r2)
    return xy


def project(cam: Camera, points: np.ndarray) -> np.ndarray:
    """Pixels (u, v) of world points ``points`` (..., 3) in m, or (..., 2) on the plane
    z = 0; shape (..., 2). Points behind the camera give NaN."""
    p = np.asarray(points, dtype=float)
    if p.shape[-1] == 2:
        p = np.concatenate([p, np.zeros(p.shape[:-1] + (1,))], axis=-1)
    q = (p - centre(cam)) @ rotation(cam).T
    z = q[..., 2:3]
    with np.errstate(invalid="ignore", divide="ignore"):
        xy = np.where(z > 0, q[..., :2] / z, np.nan)
    xy = distort_normalized(xy, cam.k1, cam.k2)
    cx, cy = cam.principal
    return xy * cam.focal_px + np.array([cx, cy])


def undistort_pixels(cam: Camera, uv: np.ndarray) -> np.ndarray:
    """Pixels (..., 2) with the lens distortion removed (the pinhole camera's pixels)."""
    c = np.array(cam.principal)
    xy = undistort_normalized((np.asarray(uv, dtype=float) - c) / cam.focal_px, cam.k1, cam.k2)
    return xy * cam.focal_px + c


def camera_framing(box: tuple[float, float, float, float], distance: float, *,
                   tilt_deg: float = 0.0, roll_deg: float = 0.0, k1: float = 0.0,
                   size: tuple[int, int] = (640, 480), fill: float = 0.85) -> Camera:
    """A camera ``distance`` m from the centre of the world box ``(x0, y0, x1, y1)`` (m, on
    the plane z = 0), pitched and rolled as given, whose focal length (px) makes the box
    fill ``fill`` of the image's width or height (whichever binds), as a user zooms to
    frame the swing."""
    x0, y0, x1, y1 = box
    aim = ((x0 + x1) / 2.0, (y0 + y1) / 2.0, 0.0)
    unit = Camera(aim=aim, distance=distance, tilt_deg=tilt_deg, roll_deg=roll_deg,
                  focal_px=1.0, size=size, k1=0.0)
    corners = np.array([[x0, y0], [x1, y0], [x0, y1], [x1, y1]])
    xy = project(unit, corners) - np.array(unit.principal)  # normalised offsets, focal 1
    half = np.max(np.abs(xy), axis=0)
    focal = fill * min(size[0] / 2.0 / half[0], size[1] / 2.0 / half[1])
    # barrel distortion pulls the corners in: the same focal length still frames the box
    return Camera(aim=aim, distance=distance, tilt_deg=tilt_deg, roll_deg=roll_deg,
                  focal_px=float(focal), size=size, k1=k1)
