"""The calibration's start: the ellipse the spigot traces about the pivot.

In the engine's plane the spigot runs on a circle of radius L1 about the pivot. A pinhole
camera images that circle as a conic ``C`` (``x̃ᵀ C x̃ = 0``, x̃ homogeneous pixels) and
the pivot as a point ``p`` inside it. The polar of a circle's centre is the line at
infinity, and poles and polars survive a homography, so the image of the plane's line at
infinity is ``l = C p`` (Hartley & Zisserman, Section 2.8.1): it fixes the projective part
of the map. Sending ``l`` back to infinity leaves an ellipse centred on the pivot, an
affine image of the circle, and the symmetric map taking the unit circle to that ellipse
is the rest (up to a rotation about the pivot, which the vertical fixes later).

:func:`circle_homography` returns that map from the plane in units of the circle's
radius (origin at its centre) to pixels; None where the points do not trace an ellipse
around the pivot (too short an arc, a track that is not an arc at all).
"""

from __future__ import annotations

import numpy as np

__all__ = ["fit_conic", "circle_homography"]


def fit_conic(points: np.ndarray) -> np.ndarray:
    """Algebraic least-squares conic ``a x² + b xy + c y² + d x + e y + f = 0`` through
    ``points`` (m, 2), as its symmetric 3×3 matrix (smallest singular vector of the design
    matrix ``[x², xy, y², x, y, 1]``; points should be centred and scaled to about 1)."""
    x, y = points[:, 0], points[:, 1]
    D = np.column_stack([x * x, x * y, y * y, x, y, np.ones_like(x)])
    _, _, vt = np.linalg.svd(D, full_matrices=False)
    a, b, c, d, e, f = vt[-1]
    return np.array([[a, b / 2, d / 2], [b / 2, c, e / 2], [d / 2, e / 2, f]])


def circle_homography(arc: np.ndarray, centre: np.ndarray) -> np.ndarray | None:
    """Homography (3×3) from the plane in units of the circle's radius, origin at its
    centre, to pixels, from the pixels ``arc`` (m, 2) of points on the circle and the pixel
    ``centre`` (2,) of its centre. None where no ellipse around ``centre`` fits."""
    arc = arc[np.isfinite(arc).all(axis=1)]
    if arc.shape[0] < 6:
        return None
    spread = float(np.median(np.hypot(*(arc - centre).T)))
    if not spread > 0:
        return None
    T = np.array([[1 / spread, 0, -centre[0] / spread], [0, 1 / spread, -centre[1] / spread],
                  [0, 0, 1.0]])                                  # pixels → centred, unit size
    q = (arc - centre) / spread
    C = fit_conic(q)
    l = C @ np.array([0.0, 0.0, 1.0])                            # polar of the centre: l = C p
    if not abs(l[2]) > 0:
        return None
    Hp = np.array([[1.0, 0, 0], [0, 1.0, 0], l / l[2]])          # sends l to infinity, p fixed
    Hp_inv = np.linalg.inv(Hp)
    Ca = Hp_inv.T @ C @ Hp_inv                                   # the conic after Hp
    M, F = Ca[:2, :2], Ca[2, 2]
    if abs(Ca[0, 2]) + abs(Ca[1, 2]) > 1e-6 * np.abs(Ca).max():
        return None
    w, V = np.linalg.eigh(-M / F)                                # ellipse xᵀ (−M/F) x = 1
    if not (w > 0).all():
        return None
    G = V @ np.diag(1.0 / np.sqrt(w)) @ V.T                      # unit circle → ellipse
    Hc = Hp_inv @ np.block([[G, np.zeros((2, 1))], [np.zeros((1, 2)), np.ones((1, 1))]])
    Hm = np.linalg.inv(T) @ Hc                                   # back to pixels
    return Hm / Hm[2, 2]
