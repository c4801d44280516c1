"""The camera: how a point of the engine's plane lands on the image, and back.

The engine moves in one vertical plane. Its coordinates are the paper's: x to the right,
y up, origin on the ground under the pivot, metres. The image's pixel coordinates are
those the log readers deliver: x along a row (px), y **up** (the image row negated, px;
see :mod:`trebuchet.ingest.formats_deeplabcut`).

A pinhole camera maps the plane to the image by a homography ``Hm`` (3×3, plane metres to
undistorted pixels), and its lens bends every pixel radially about the distortion centre
``c`` (OpenCV's model, radial terms only)::

    ũ = Hm [x, y, 1]ᵀ,   u = ũ₁₂ / ũ₃                        (pinhole)
    ρ = |u − c| / R                                          (radius, R px: the focal length)
    d = c + (u − c) (1 + k1 ρ² + k2 ρ⁴)                      (radial distortion)

:func:`project` is the plane to pixels, :func:`unproject` pixels to the plane. A user's own
calibration gives a camera through :func:`camera_from_points` (four or more known plane
points) or :func:`intrinsics_from_opencv` (an OpenCV camera matrix and distortion);
:func:`camera_from_pose` builds one from a pose (tests, synthetic logs), and
:func:`camera_pose` reads tilt, roll, focal length and scale back out of a camera.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trebuchet.core.errors import TrebuchetInputError

__all__ = ["Camera", "Intrinsics", "CameraPose", "apply_homography", "distort", "undistort",
           "project", "unproject", "homography_from_points", "camera_from_points",
           "intrinsics_from_opencv", "camera_from_pose", "camera_pose", "rotation_from_angles"]

#: Flip of the image's y axis: OpenCV rows point down, the readers' y up.
FLIP_Y = np.diag([1.0, -1.0, 1.0])


@dataclass(frozen=True)
class Intrinsics:
    """What a lens calibration knows: distortion centre ``centre`` (px, y up), the radius
    ``radius`` (px) that normalises the distortion (the focal length), ``k1``, ``k2``.
    ``focal`` (px) when known (an OpenCV matrix), else None."""

    centre: tuple[float, float]
    radius: float
    k1: float = 0.0
    k2: float = 0.0
    focal: float | None = None


@dataclass(frozen=True)
class Camera:
    """Plane (m) to image (px, y up): homography ``Hm`` (3×3) then radial distortion
    ``k1``, ``k2`` about ``centre`` (px) with radius ``radius`` (px)."""

    Hm: np.ndarray
    k1: float = 0.0
    k2: float = 0.0
    centre: tuple[float, float] = (0.0, 0.0)
    radius: float = 1000.0

    def project(self, xy: np.ndarray) -> np.ndarray:
        """Pixels (…, 2) of plane points ``xy`` (…, 2) m."""
        return project(self, xy)

    def unproject(self, uv: np.ndarray) -> np.ndarray:
        """Plane points (…, 2) m of pixels ``uv`` (…, 2)."""
        return unproject(self, uv)


@dataclass(frozen=True)
class CameraPose:
    """A camera read as a pose (rad, px): ``tilt`` the angle between the optical axis and
    the plane's normal, split into ``pitch`` (positive: the camera looks down on the engine)
    and ``yaw`` (about the vertical); ``roll`` of the image about the optical axis (the
    plane's horizontal against the image rows); ``px_per_m`` the scale at the pivot;
    ``focal`` (px), None where the image shows no perspective to find it from (then
    pitch = yaw = tilt = 0: a fronto-parallel camera)."""

    tilt: float
    pitch: float
    yaw: float
    roll: float
    px_per_m: float
    focal: float | None


def apply_homography(Hm: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """``Hm [x, y, 1]ᵀ`` dehomogenised: points (…, 2) to points (…, 2)."""
    x, y = xy[..., 0], xy[..., 1]
    w = Hm[2, 0] * x + Hm[2, 1] * y + Hm[2, 2]                   # ũ₃
    u = (Hm[0, 0] * x + Hm[0, 1] * y + Hm[0, 2]) / w             # ũ₁ / ũ₃
    v = (Hm[1, 0] * x + Hm[1, 1] * y + Hm[1, 2]) / w             # ũ₂ / ũ₃
    return np.stack([u, v], axis=-1)


def distort(uv: np.ndarray, k1: float, k2: float, centre: tuple[float, float],
            radius: float) -> np.ndarray:
    """``d = c + (u − c)(1 + k1 ρ² + k2 ρ⁴)``, ``ρ = |u − c| / R``: px (…, 2) to px (…, 2)."""
    if k1 == 0.0 and k2 == 0.0:
        return uv
    rel = (uv - np.asarray(centre)) / radius                     # (u − c) / R
    rho2 = rel[..., 0] ** 2 + rel[..., 1] ** 2                   # ρ²
    gain = 1.0 + rho2 * (k1 + k2 * rho2)                         # 1 + k1 ρ² + k2 ρ⁴
    return np.asarray(centre) + rel * (radius * gain)[..., None]


def undistort(uv: np.ndarray, k1: float, k2: float, centre: tuple[float, float],
              radius: float, iterations: int = 8) -> np.ndarray:
    """Inverse of :func:`distort`: solve ``ρ_u (1 + k1 ρ_u² + k2 ρ_u⁴) = ρ_d`` for each
    pixel's undistorted radius by Newton's method (px (…, 2) to px (…, 2))."""
    if k1 == 0.0 and k2 == 0.0:
        return uv
    rel = (uv - np.asarray(centre)) / radius
    rd = np.hypot(rel[..., 0], rel[..., 1])                      # ρ_d
    ru = rd.copy()
    for _ in range(iterations):
        r2 = ru * ru
        f = ru * (1.0 + r2 * (k1 + k2 * r2)) - rd                # ρ(1 + k1ρ² + k2ρ⁴) − ρ_d
        df = 1.0 + r2 * (3.0 * k1 + 5.0 * k2 * r2)               # d/dρ
        ru = ru - f / df
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(rd > 0, ru / np.where(rd > 0, rd, 1.0), 1.0)
    return np.asarray(centre) + rel * (radius * scale)[..., None]


def project(camera: Camera, xy: np.ndarray) -> np.ndarray:
    """Pixels (…, 2, y up) of plane points ``xy`` (…, 2) m: homography then distortion."""
    xy = np.asarray(xy, dtype=float)
    return distort(apply_homography(camera.Hm, xy), camera.k1, camera.k2, camera.centre,
                   camera.radius)


def unproject(camera: Camera, uv: np.ndarray) -> np.ndarray:
    """Plane points (…, 2) m of pixels ``uv`` (…, 2, y up): undistortion then ``Hm⁻¹``."""
    uv = np.asarray(uv, dtype=float)
    u = undistort(uv, camera.k1, camera.k2, camera.centre, camera.radius)
    return apply_homography(np.linalg.inv(camera.Hm), u)


def _normalising(points: np.ndarray) -> np.ndarray:
    """Similarity taking points (n, 2) to centroid 0 and mean distance √2 (Hartley)."""
    mean = points.mean(axis=0)
    spread = np.mean(np.hypot(*(points - mean).T))
    s = np.sqrt(2.0) / spread if spread > 0 else 1.0
    return np.array([[s, 0.0, -s * mean[0]], [0.0, s, -s * mean[1]], [0.0, 0.0, 1.0]])


def homography_from_points(plane: np.ndarray, image: np.ndarray) -> np.ndarray:
    """Homography ``Hm`` (plane m to px) through n ≥ 4 point pairs: the normalised direct
    linear transform (Hartley & Zisserman, Algorithm 4.2), least squares for n > 4.

    ``plane`` (n, 2) m, ``image`` (n, 2) px (undistorted). Refused when fewer than four
    pairs are finite or three of the plane points are (nearly) on one line.
    """
    plane = np.asarray(plane, dtype=float)
    image = np.asarray(image, dtype=float)
    if plane.shape != image.shape or plane.ndim != 2 or plane.shape[1] != 2:
        raise TrebuchetInputError(f"calibration points: plane {plane.shape} and image "
                                  f"{image.shape} must both be (n, 2)")
    ok = np.isfinite(plane).all(axis=1) & np.isfinite(image).all(axis=1)
    if ok.sum() < 4:
        raise TrebuchetInputError(f"calibration points: {int(ok.sum())} complete pairs; a "
                                  "homography needs four or more known plane points")
    P, Q = plane[ok], image[ok]
    Tp, Tq = _normalising(P), _normalising(Q)
    p = P @ Tp[:2, :2].T + Tp[:2, 2]
    q = Q @ Tq[:2, :2].T + Tq[:2, 2]
    n = p.shape[0]
    A = np.zeros((2 * n, 9))
    A[0::2, 0:2], A[0::2, 2] = p, 1.0                            # x' row: h1·p − u h3·p = 0
    A[0::2, 6:8], A[0::2, 8] = -q[:, :1] * p, -q[:, 0]
    A[1::2, 3:5], A[1::2, 5] = p, 1.0                            # y' row: h2·p − v h3·p = 0
    A[1::2, 6:8], A[1::2, 8] = -q[:, 1:] * p, -q[:, 1]
    _, sv, vt = np.linalg.svd(A)
    if sv[-2] < 1e-9 * sv[0]:
        raise TrebuchetInputError("calibration points: the plane points do not fix a "
                                  "homography (three or more on one line?)")
    Hn = vt[-1].reshape(3, 3)
    Hm = np.linalg.inv(Tq) @ Hn @ Tp                             # undo the normalisations
    return Hm / Hm[2, 2]


def camera_from_points(plane: np.ndarray, image: np.ndarray,
                       intrinsics: Intrinsics | None = None) -> Camera:
    """A user's own calibration: four or more points of the engine's plane ``plane`` (n, 2)
    m (paper's axes: origin on the ground under the pivot, y up) seen at ``image`` (n, 2)
    px (y up). With ``intrinsics`` (a lens calibration) the pixels are undistorted first."""
    image = np.asarray(image, dtype=float)
    if intrinsics is None:
        return Camera(homography_from_points(plane, image))
    i = intrinsics
    flat = undistort(image, i.k1, i.k2, i.centre, i.radius)
    return Camera(homography_from_points(plane, flat), i.k1, i.k2, i.centre, i.radius)


def intrinsics_from_opencv(matrix: np.ndarray, distortion: np.ndarray | None = None,
                           ) -> Intrinsics:
    """Lens of an OpenCV calibration: camera matrix ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]``
    (px, rows down) and distortion ``(k1, k2[, p1, p2[, k3 …]])``. The readers' y is the row
    negated, so the centre is ``(cx, −cy)``. Refused where this model cannot follow it:
    pixels far from square (fx ≠ fy by more than 1 %), tangential terms or k3 that matter."""
    K = np.asarray(matrix, dtype=float)
    if K.shape != (3, 3) or not np.isfinite(K).all():
        raise TrebuchetInputError(f"camera matrix: must be 3×3 and finite, got {K.shape}")
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    if not (fx > 0 and fy > 0) or abs(fx - fy) > 0.01 * fx:
        raise TrebuchetInputError(f"camera matrix: fx = {fx:g}, fy = {fy:g} px; this camera "
                                  "model needs square pixels (fx = fy within 1 %)")
    d = np.zeros(5) if distortion is None else np.ravel(np.asarray(distortion, dtype=float))
    if d.size < 2 or not np.isfinite(d).all():
        raise TrebuchetInputError("camera distortion: give (k1, k2[, p1, p2[, k3]]), finite")
    rest = np.abs(d[2:])
    if rest.size and rest.max() > 1e-4:
        raise TrebuchetInputError(f"camera distortion: tangential or higher terms "
                                  f"{d[2:].tolist()} are not modelled (only k1, k2)")
    f = 0.5 * (fx + fy)
    return Intrinsics(centre=(float(cx), float(-cy)), radius=float(f), k1=float(d[0]),
                      k2=float(d[1]), focal=float(f))


def rotation_from_angles(pitch: float, yaw: float, roll: float) -> np.ndarray:
    """World (plane x, y up, z toward the camera) to OpenCV camera axes (x right, y down,
    z forward): ``R = R_z(roll) R_x(pitch) R_y(yaw) diag(1, −1, −1)``."""
    cp, sp, cy, sy, cr, sr = (np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw),
                              np.cos(roll), np.sin(roll))
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cp, -sp], [0.0, sp, cp]])
    Ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    Rz = np.array([[cr, -sr, 0.0], [sr, cr, 0.0], [0.0, 0.0, 1.0]])
    return Rz @ Rx @ Ry @ np.diag([1.0, -1.0, -1.0])


def camera_from_pose(focal: float, image_size: tuple[float, float], distance: float,
                     aim: tuple[float, float], pitch: float = 0.0, yaw: float = 0.0,
                     roll: float = 0.0, k1: float = 0.0, k2: float = 0.0) -> Camera:
    """A pinhole camera ``distance`` m from the plane point ``aim`` (m), looking at it with
    ``pitch``, ``yaw``, ``roll`` (rad, see :class:`CameraPose`), focal length ``focal`` px,
    principal point at the centre of an image of ``image_size`` (width, height) px, and
    radial distortion ``k1``, ``k2`` normalised by the focal length (OpenCV's)."""
    R = rotation_from_angles(pitch, yaw, roll)
    A = np.array([aim[0], aim[1], 0.0])
    C = A - distance * R.T @ np.array([0.0, 0.0, 1.0])          # camera centre behind the aim
    t = -R @ C                                                  # X_c = R X + t
    K = np.array([[focal, 0.0, image_size[0] / 2], [0.0, focal, image_size[1] / 2],
                  [0.0, 0.0, 1.0]])
    Hm = FLIP_Y @ K @ np.column_stack([R[:, 0], R[:, 1], t])    # y-up px of (x, y, 0)
    return Camera(Hm / Hm[2, 2], k1, k2, (image_size[0] / 2, -image_size[1] / 2), focal)


def focal_from_homography(Hm: np.ndarray, centre: tuple[float, float]) -> float | None:
    """Focal length (px) that makes ``K⁻¹ Hm``'s first two columns orthogonal and of equal
    length (Zhang's two constraints, square pixels, principal point ``centre``), least
    squares in ``1/f²``; None where the homography shows no perspective to find it from."""
    h = FLIP_Y @ Hm
    cx, cy = centre[0], -centre[1]
    a = h[0] - cx * h[2]                                         # f·(row 1 of [r1 r2 t]) λ
    b = h[1] - cy * h[2]
    g = h[2]
    # orthogonality: (a1 a2 + b1 b2)/f² + g1 g2 = 0; equal norms: (a1²+b1²−a2²−b2²)/f² + g1²−g2²
    A = np.array([a[0] * a[1] + b[0] * b[1], a[0] ** 2 + b[0] ** 2 - a[1] ** 2 - b[1] ** 2])
    B = np.array([g[0] * g[1], g[0] ** 2 - g[1] ** 2])
    den = float(A @ A)
    if den == 0.0:
        return None
    u = -float(A @ B) / den                                       # 1/f²
    scale = np.hypot(a[0], b[0]) / np.hypot(g[0], g[1]) if np.hypot(g[0], g[1]) > 0 else np.inf
    if not u > 0 or not np.isfinite(scale):
        return None
    f = 1.0 / np.sqrt(u)
    if f > 1e3 * scale:  # perspective below any measurable level: f unbounded
        return None
    return float(f)


def camera_pose(camera: Camera, focal: float | None = None,
                centre: tuple[float, float] | None = None, pivot: tuple[float, float]
                = (0.0, 0.0)) -> CameraPose:
    """Tilt, roll, scale and focal length of ``camera`` (see :class:`CameraPose`).

    ``focal`` px when known (else found from the homography with the principal point
    ``centre``, px y up, default the distortion centre); ``pivot`` the plane point (m) where
    the scale is measured.
    """
    Hm = camera.Hm
    c = camera.centre if centre is None else centre
    x0 = np.array(pivot, dtype=float)
    eps = 1e-3
    J = np.column_stack([(apply_homography(Hm, x0 + [eps, 0]) - apply_homography(Hm, x0)) / eps,
                         (apply_homography(Hm, x0 + [0, eps]) - apply_homography(Hm, x0)) / eps])
    px_per_m = float(np.sqrt(abs(np.linalg.det(J))))
    f = focal if focal is not None else focal_from_homography(Hm, c)
    if f is None:
        roll = -float(np.arctan2(J[1, 0], J[0, 0]))              # the plane's x in the image
        return CameraPose(0.0, 0.0, 0.0, roll, px_per_m, None)
    Kinv = np.array([[1 / f, 0.0, -c[0] / f], [0.0, 1 / f, -c[1] / f], [0.0, 0.0, 1.0]])
    M = FLIP_Y @ Kinv @ Hm                                        # λ [r1 r2 t] (OpenCV axes)
    lam = 0.5 * (np.linalg.norm(M[:, 0]) + np.linalg.norm(M[:, 1]))
    M = M / lam * np.sign(M[2, 2])                                # t_z > 0: plane in front
    r1, r2 = M[:, 0], M[:, 1]
    R = np.column_stack([r1, r2, np.cross(r1, r2)])
    U, _, Vt = np.linalg.svd(R)                                   # nearest rotation
    R = U @ Vt
    Q = R @ np.diag([1.0, -1.0, -1.0])                            # R_z(roll) R_x(pitch) R_y(yaw)
    pitch = float(np.arcsin(np.clip(Q[2, 1], -1, 1)))
    yaw = float(np.arctan2(-Q[2, 0], Q[2, 2]))
    roll = float(np.arctan2(-Q[0, 1], Q[1, 1]))
    tilt = float(np.arccos(np.clip(abs(R[2, 2]), -1, 1)))         # optical axis vs normal
    return CameraPose(tilt, pitch, yaw, roll, px_per_m, float(f))
