"""The image calibrated by the engine itself (issue 15).

A point log gives, frame by frame, the pixels of the pivot, spigot, hinge, counterweight
and projectile. :func:`calibrate` fits, in one robust least squares over the whole log
(soft-L1 loss, analytic sparse Jacobian; the frames' angles eliminated by the Schur
complement, :mod:`.block_least_squares`, or ``scipy.optimize.least_squares``), the map from the
engine's plane to the image together with every frame's angles θ, ψ, φ and a constant
pixel offset of each marker. The scene makes it well posed:

* the pivot is fixed; spigot, pivot and hinge lie on one straight beam at L1 and L2; the
  counterweight is L3 from the hinge; the projectile L4 from the spigot while in the sling
  (:mod:`.engine_points`), on a parabola with the scene's g in flight;
* the vertical: at rest the counterweight hangs plumb (``L3 cos ψ = 0``); in the trough the
  projectile lies on its level (``H + L1 sin θ + L4 sin φ = 0``); in flight it falls
  along −y;
* the start: the ellipse the spigot traces about the pivot (:mod:`.conic_start`).

The map (:class:`CameraModel`), from plane coordinates ``X̃ = (r − r_P)/L1`` (pivot at
the origin, units of the beam's long arm) to pixels::

    w = 1 + p1 x̃ + p2 ỹ                                      projective part (tilt)
    a = [[1 + α, β], [β, 1 − α]] X̃ / w                         affine part (aspect, shear)
    u = t + s R(turn) a                                       similarity (vertical, scale)
    d = c + (u − c)(1 + k1 ρ² + k2 ρ⁴),  ρ = |u − c|/R        radial distortion

Perspective and distortion are kept only where the data show them: the levels of
:data:`LEVELS` are fitted on a subsample of the frames and the one with the least
Bayesian information criterion ``2 cost + k ln N`` of the whole log (cost from residuals
in units of the noise, the subsample's scaled up to the log's N coordinates: more frames
show finer effects) is fitted on all frames. Marker offsets have a Gaussian prior
(``offset_prior_px``):
without them a constant sub-pixel click error turns into a false tilt. k1 and k2 have a
prior that bounds the distortion at the edge of the data (``distortion_prior_px``).

Outliers and stuck tracks (:mod:`.track_flags`) become gaps and the fit is repeated
without them. Each frame's angles get their sd from the fit's Gauss–Newton covariance:
``*_sd`` the frame's own (random) part, ``*_sd_calibration`` the part the camera and the
marker offsets carry into every frame alike (their Schur complement), both rad.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.optimize import least_squares

from trebuchet.errors import TrebuchetInputError, check_choice
from trebuchet.model.scene import Engine

from .block_least_squares import RowBlocks, block_least_squares, normal_blocks
from .camera import Camera, CameraPose, Intrinsics, apply_homography, camera_pose, undistort
from .conic_start import circle_homography
from .engine_points import POINTS
from .track_flags import RAYLEIGH_MEDIAN, FlaggedTrack, flag_tracks, outlier_limit

__all__ = ["LEVELS", "ALL_LEVELS", "CAMERA_PARAMETERS", "LevelFit", "Calibration", "calibrate",
           "angles_from_calibration"]

#: Camera models, from the simplest up: "level" a fronto-parallel camera with a perfect lens
#: whose rows are horizontal (today's atan2 of the pixels); "similarity" the same turned
#: about its optical axis; "affine" adds aspect and shear; "projective" the tilt; then k1, k2.
ALL_LEVELS = ("level", "similarity", "affine", "projective", "projective+k1",
              "projective+k1+k2")
#: The levels chosen from by default. Perspective comes with k1 (held by its prior): the
#: pixels' cost hardly tells k1 (weakly identified) but the vertical found depends on it;
#: measured on the paper's engine filmed tilted with k1 = −0.03, the plain projective map
#: left θ biased by up to 3 of its calibration sd on 2000 frames, with k1 under 1.7.
LEVELS = ("level", "similarity", "affine", "projective+k1", "projective+k1+k2")
#: The camera's parameters: translation (px), scale (px per L1), turn (rad), α, β, p1, p2
#: (per L1), k1, k2 (per radius R).
CAMERA_PARAMETERS = ("tx", "ty", "scale", "turn", "alpha", "beta", "p1", "p2", "k1", "k2")
_FREE = {"level": 3, "similarity": 4, "affine": 6, "projective": 8, "projective+k1": 9,
         "projective+k1+k2": 10}
#: Branch of each angle's first value: [-π, π) for θ and ψ, [-3π/2, π/2) for φ (the
#: sling starts near −180°), as in :mod:`trebuchet.ingest.angles_from_points`.
BRANCH_START = (-np.pi, -np.pi, -1.5 * np.pi)
ANGLES = ("theta", "psi", "phi")
_WEAK = 1e-3  # weight of the prior that keeps an angle without data at its start (1/rad)


@dataclass(frozen=True)
class LevelFit:
    """One camera model fitted on the selection frames: its robust ``cost`` (residuals in
    noise units), number of camera parameters ``k``, ``bic`` = 2 cost + k ln N for the
    whole log (its N coordinates; the subsample's cost scaled up to them)."""

    level: str
    cost: float
    k: int
    bic: float


@dataclass(frozen=True)
class Calibration:
    """What :func:`calibrate` found.

    Camera: ``camera`` (project / unproject), ``pose`` (tilt, roll, px per m, focal),
    ``level`` (the model chosen, one of :data:`ALL_LEVELS` or "given"), ``parameters`` and
    ``parameters_sd`` (of :data:`CAMERA_PARAMETERS`; sd 0 where fixed), ``k1_focal`` (k1
    normalised by the focal length, OpenCV's, when the focal length is known or found),
    ``levels`` (each candidate's fit). Markers: ``offsets`` and ``offsets_sd`` (2,) px.
    Angles: ``theta``, ``psi``, ``phi`` (n,) rad on the paper's branch, NaN where the
    points do not give them; ``*_sd`` their random sd, ``*_sd_calibration`` the sd that
    the camera's and offsets' uncertainty carries into them (common to all frames).
    Quality: ``residuals`` (n, 2) px per point (tracked minus fitted, NaN where not used),
    ``noise_px`` (robust sd per coordinate), ``flagged`` runs and ``gaps`` (n,) masks of
    outliers and stuck tracks, ``at_rest``, ``in_trough``, ``in_sling`` (n,) the frames
    each constraint was applied to, ``fitted`` (what was fitted, in words), ``notes``.
    Solver: ``cost``, ``nfev``, ``success``, ``message``, ``seconds``.
    """

    camera: Camera
    pose: CameraPose
    level: str
    parameters: dict[str, float]
    parameters_sd: dict[str, float]
    k1_focal: float | None
    levels: tuple[LevelFit, ...]
    offsets: dict[str, np.ndarray]
    offsets_sd: dict[str, np.ndarray]
    theta: np.ndarray
    psi: np.ndarray
    phi: np.ndarray
    theta_sd: np.ndarray
    psi_sd: np.ndarray
    phi_sd: np.ndarray
    theta_sd_calibration: np.ndarray
    psi_sd_calibration: np.ndarray
    phi_sd_calibration: np.ndarray
    residuals: dict[str, np.ndarray]
    noise_px: float
    flagged: tuple[FlaggedTrack, ...]
    gaps: dict[str, np.ndarray]
    at_rest: np.ndarray
    in_trough: np.ndarray
    in_sling: np.ndarray
    fitted: tuple[str, ...]
    notes: tuple[str, ...]
    cost: float
    nfev: int
    success: bool
    message: str
    seconds: float

    def angles(self) -> dict[str, np.ndarray]:
        """``{"theta": …, "psi": …, "phi": …}`` rad."""
        return {"theta": self.theta, "psi": self.psi, "phi": self.phi}


# ---------------------------------------------------------------- the map plane → image

def image_of(cam: np.ndarray, X: np.ndarray, centre: np.ndarray, radius: float) -> np.ndarray:
    """Pixels (…, 2) of plane points ``X`` (…, 2) in units of L1 about the pivot, for the
    camera parameters ``cam`` (:data:`CAMERA_PARAMETERS`); see the module doc."""
    tx, ty, s, turn, al, be, p1, p2, k1, k2 = cam
    x, y = X[..., 0], X[..., 1]
    w = 1.0 + p1 * x + p2 * y                                    # projective part
    xp, yp = x / w, y / w
    ax = (1.0 + al) * xp + be * yp                               # affine part
    ay = be * xp + (1.0 - al) * yp
    c, sn = s * np.cos(turn), s * np.sin(turn)
    u = tx + c * ax - sn * ay                                    # u = t + s R(turn) a
    v = ty + sn * ax + c * ay
    if k1 != 0.0 or k2 != 0.0:
        du, dv = (u - centre[0]) / radius, (v - centre[1]) / radius
        rho2 = du * du + dv * dv                                 # ρ²
        gain = rho2 * (k1 + k2 * rho2)                           # k1 ρ² + k2 ρ⁴
        u = u + (u - centre[0]) * gain
        v = v + (v - centre[1]) * gain
    return np.stack([u, v], axis=-1)


def image_jacobian(cam: np.ndarray, X: np.ndarray, centre: np.ndarray, radius: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Derivatives of :func:`image_of`: ``∂u/∂X̃`` (…, 2, 2) and ``∂u/∂cam`` (…, 2, 10), by
    the chain rule through its four steps."""
    tx, ty, s, turn, al, be, p1, p2, k1, k2 = cam
    x, y = X[..., 0], X[..., 1]
    w = 1.0 + p1 * x + p2 * y
    xp, yp = x / w, y / w
    ax = (1.0 + al) * xp + be * yp
    ay = be * xp + (1.0 - al) * yp
    c, sn = np.cos(turn), np.sin(turn)
    ex, ey = c * ax - sn * ay, sn * ax + c * ay                  # R(turn) a = (u0 − t) / s
    e_x, e_y = tx + s * ex - centre[0], ty + s * ey - centre[1]  # u0 − c
    rho2 = (e_x * e_x + e_y * e_y) / radius ** 2
    gain = rho2 * (k1 + k2 * rho2)                               # g = k1 ρ² + k2 ρ⁴
    dg = 2.0 * (k1 + 2.0 * k2 * rho2) / radius ** 2              # ∂g/∂(u0 − c) = dg (u0 − c)
    shape = x.shape
    Dd = np.empty(shape + (2, 2))                                # ∂u/∂u0 = (1 + g) I + dg e eᵀ
    Dd[..., 0, 0] = 1.0 + gain + dg * e_x * e_x
    Dd[..., 0, 1] = Dd[..., 1, 0] = dg * e_x * e_y
    Dd[..., 1, 1] = 1.0 + gain + dg * e_y * e_y
    Rs = s * np.array([[c, -sn], [sn, c]])                       # ∂u0/∂a
    A = np.array([[1.0 + al, be], [be, 1.0 - al]])               # ∂a/∂q
    Dq = np.empty(shape + (2, 2))                                # ∂q/∂X̃ = (I − q pᵀ) / w
    Dq[..., 0, 0] = (1.0 - xp * p1) / w
    Dq[..., 0, 1] = -xp * p2 / w
    Dq[..., 1, 0] = -yp * p1 / w
    Dq[..., 1, 1] = (1.0 - yp * p2) / w
    DdRs = Dd @ Rs
    DdRsA = DdRs @ A
    d_plane = DdRsA @ Dq
    d_cam = np.empty(shape + (2, 10))
    d_cam[..., :, 0] = Dd[..., :, 0]                             # t
    d_cam[..., :, 1] = Dd[..., :, 1]
    d_cam[..., 0, 2] = Dd[..., 0, 0] * ex + Dd[..., 0, 1] * ey   # s: ∂u0/∂s = R a
    d_cam[..., 1, 2] = Dd[..., 1, 0] * ex + Dd[..., 1, 1] * ey
    d_cam[..., 0, 3] = s * (-Dd[..., 0, 0] * ey + Dd[..., 0, 1] * ex)   # turn: s R⊥ a
    d_cam[..., 1, 3] = s * (-Dd[..., 1, 0] * ey + Dd[..., 1, 1] * ex)
    d_cam[..., :, 4] = DdRs[..., :, 0] * xp[..., None] - DdRs[..., :, 1] * yp[..., None]  # α
    d_cam[..., :, 5] = DdRs[..., :, 0] * yp[..., None] + DdRs[..., :, 1] * xp[..., None]  # β
    qx = -(DdRsA[..., :, 0] * xp[..., None] + DdRsA[..., :, 1] * yp[..., None])  # ∂q/∂p = −q X̃/w
    d_cam[..., :, 6] = qx * (x / w)[..., None]
    d_cam[..., :, 7] = qx * (y / w)[..., None]
    d_cam[..., 0, 8], d_cam[..., 1, 8] = e_x * rho2, e_y * rho2  # ∂u/∂k1 = (u0 − c) ρ²
    d_cam[..., 0, 9], d_cam[..., 1, 9] = e_x * rho2 ** 2, e_y * rho2 ** 2
    return d_plane, d_cam


def _normalised_homography(cam: np.ndarray) -> np.ndarray:
    """``[[s R(turn) A + t pᵀ, t], [pᵀ, 1]]``: the pinhole part of ``cam`` on X̃ (units of
    L1), since ``u = t + s R A X̃ / w`` is ``((s R A + t pᵀ) X̃ + t) / w``."""
    tx, ty, s, turn, al, be, p1, p2 = cam[:8]
    R = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    A = np.array([[1.0 + al, be], [be, 1.0 - al]])
    Hn = np.eye(3)
    Hn[:2, :2] = s * R @ A + np.outer([tx, ty], [p1, p2])
    Hn[:2, 2] = tx, ty
    Hn[2, :2] = p1, p2
    return Hn


def _parameters_of(Hn: np.ndarray) -> np.ndarray:
    """Inverse of :func:`_normalised_homography` (k1 = k2 = 0): ``Hn = [[M, t], [pᵀ, 1]]``
    with ``M − t pᵀ = s R A``, split by the polar decomposition ``s R A = R (s A)``."""
    Hn = Hn / Hn[2, 2]
    t, p = Hn[:2, 2], Hn[2, :2]
    M = Hn[:2, :2] - np.outer(t, p)                              # s R A
    U, S, Vt = np.linalg.svd(M)
    R = U @ Vt                                                   # rotation part
    if np.linalg.det(R) < 0:
        raise TrebuchetInputError("calibration: the image is a mirror image of the engine's "
                                  "plane (is y pointing down?)")
    sA = R.T @ M                                                 # s A, symmetric
    s = 0.5 * np.trace(sA)
    al, be = 0.5 * (sA[0, 0] - sA[1, 1]) / s, 0.5 * (sA[0, 1] + sA[1, 0]) / s
    return np.array([t[0], t[1], s, np.arctan2(R[1, 0], R[0, 0]), al, be, p[0], p[1], 0, 0])


def camera_of(cam: np.ndarray, engine: Engine, H: float, centre: np.ndarray,
              radius: float) -> Camera:
    """The :class:`~.camera.Camera` (plane m → px) of the parameters ``cam``:
    ``Hm = Hn N`` with ``N`` taking metres to X̃ = (r − (0, H)) / L1."""
    L = engine.L1
    N = np.array([[1 / L, 0.0, 0.0], [0.0, 1 / L, -H / L], [0.0, 0.0, 1.0]])
    Hm = _normalised_homography(cam) @ N
    return Camera(Hm / Hm[2, 2], float(cam[8]), float(cam[9]),
                  (float(centre[0]), float(centre[1])), float(radius))


# ---------------------------------------------------------------- the problem

@dataclass
class _Problem:
    """The least-squares problem on a set of frames (internal)."""

    obs: np.ndarray            # (5, n, 2) px, 0 where not used
    use: np.ndarray            # (5, n) bool: position used
    wt: np.ndarray             # (5, n) residual weight: √confidence / σ
    lengths: tuple[float, float, float, float]   # L1, L2, L3, L4 / L1
    h: float                   # H / L1
    centre: np.ndarray
    radius: float
    rest: np.ndarray           # (n,) bool: counterweight plumb
    trough: np.ndarray         # (n,) bool: projectile on the trough's level
    sling: np.ndarray          # (n,) bool: projectile in the sling or trough
    flight: np.ndarray         # (n,) bool: projectile on the parabola
    tau: np.ndarray            # (n,) s since the first flight frame
    g: float                   # g / L1, 1/s²
    cam0: np.ndarray           # (10,) camera parameters (the fixed ones stay)
    free: np.ndarray           # indices of the free camera parameters
    offset_points: tuple[int, ...]   # points (indices into POINTS) with an offset
    sigma: float               # px
    offset_sd: float           # px
    k_sd: tuple[float, float]  # prior sd of k1, k2
    gauge_px: float            # px per L1 for the plumb and trough residuals
    fixed_psi: float | None    # ψ − θ of a counterweight fixed on the beam
    ang0: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    @property
    def n(self) -> int:
        return self.obs.shape[1]

    @property
    def n_global(self) -> int:
        return self.free.size + 2 * len(self.offset_points) + (4 if self.flight.any() else 0)

    def split(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Camera (10,), offsets (5, 2), flight (4,), angles (n, 3) of the vector ``x``."""
        cam = self.cam0.copy()
        nc = self.free.size
        cam[self.free] = x[:nc]
        off = np.zeros((5, 2))
        no = len(self.offset_points)
        off[list(self.offset_points)] = x[nc:nc + 2 * no].reshape(no, 2)
        nf = 4 if self.flight.any() else 0
        fl = x[nc + 2 * no:nc + 2 * no + nf]
        return cam, off, fl, x[self.n_global:].reshape(self.n, 3)

    def plane(self, ang: np.ndarray, fl: np.ndarray) -> np.ndarray:
        """The five points (5, n, 2) in units of L1 about the pivot (:mod:`.engine_points`)."""
        l1, l2, l3, l4 = self.lengths
        th, ps, ph = ang[:, 0], ang[:, 1], ang[:, 2]
        if self.fixed_psi is not None:
            ps = th + self.fixed_psi                             # ψ = θ + offset (rigid)
        eth = np.stack([np.cos(th), np.sin(th)], axis=-1)
        X = np.zeros((5, self.n, 2))
        X[1] = l1 * eth                                          # r_S − r_P = L1 e_θ
        X[2] = -l2 * eth                                         # r_H − r_P = −L2 e_θ
        X[3] = X[2] + l3 * np.stack([np.cos(ps), np.sin(ps)], axis=-1)   # + L3 e_ψ
        X[4] = X[1] + l4 * np.stack([np.cos(ph), np.sin(ph)], axis=-1)   # r_m − r_P
        if fl.size:
            tau = self.tau[self.flight]
            X[4, self.flight, 0] = fl[0] + fl[2] * tau            # x = x0 + vx τ
            X[4, self.flight, 1] = fl[1] + fl[3] * tau - 0.5 * self.g * tau ** 2  # − g τ²/2
        return X

    def predicted(self, x: np.ndarray) -> np.ndarray:
        """Pixels (5, n, 2) where the tracker should see each point, offsets included."""
        cam, off, fl, ang = self.split(x)
        return image_of(cam, self.plane(ang, fl), self.centre, self.radius) + off[:, None, :]

    def residuals(self, x: np.ndarray) -> np.ndarray:
        cam, off, fl, ang = self.split(x)
        U = image_of(cam, self.plane(ang, fl), self.centre, self.radius) + off[:, None, :]
        r_pts = ((U - self.obs) * self.wt[..., None])[self.use]             # tracked − fitted
        l1, l2, l3, l4 = self.lengths
        th, ps, ph = ang[:, 0], ang[:, 1], ang[:, 2]
        k = self.gauge_px / self.sigma
        r_plumb = k * l3 * np.cos(ps[self.rest])                          # L3 cos ψ = 0
        r_trough = k * (self.h + l1 * np.sin(th[self.trough])
                        + l4 * np.sin(ph[self.trough]))                   # y_m = 0
        r_off = off[list(self.offset_points)].ravel() / self.offset_sd
        r_k = [cam[8 + i] / self.k_sd[i] for i in range(2) if 8 + i in self.free]
        r_weak = _WEAK * (ang - self.ang0).ravel()
        return np.concatenate([r_pts.ravel(), r_plumb, r_trough, r_off, r_k, r_weak])

    def sparsity(self) -> sp.csr_matrix:
        """Which residual depends on which parameter: each frame's angles touch only that
        frame's rows; camera parameters touch every point row."""
        n, nc, ng = self.n, self.free.size, self.n_global
        no = len(self.offset_points)
        rows, cols = [], []
        p_idx, f_idx = np.nonzero(self.use)
        m = p_idx.size
        r0 = np.repeat(np.arange(m) * 2, 1)
        for d in (0, 1):                                         # both coordinates of a point
            r = r0 + d
            rows.append(np.repeat(r, nc))
            cols.append(np.tile(np.arange(nc), m))
            for j, p in enumerate(self.offset_points):
                sel = p_idx == p
                rows.append(r[sel])
                cols.append(np.full(sel.sum(), nc + 2 * j + d))
            theta_rows = p_idx > 0
            flying = (p_idx == 4) & self.flight[f_idx]
            theta_rows &= ~flying
            rows.append(r[theta_rows])
            cols.append(ng + 3 * f_idx[theta_rows])
            psi = (p_idx == 3) & (self.fixed_psi is None)
            rows.append(r[psi])
            cols.append(ng + 3 * f_idx[psi] + 1)
            phi = (p_idx == 4) & ~flying
            rows.append(r[phi])
            cols.append(ng + 3 * f_idx[phi] + 2)
            if self.flight.any():
                for q in range(4):
                    rows.append(r[flying])
                    cols.append(np.full(flying.sum(), nc + 2 * no + q))
        row = 2 * m
        rest = np.flatnonzero(self.rest)
        rows.append(row + np.arange(rest.size))
        cols.append(ng + 3 * rest + 1)
        row += rest.size
        trough = np.flatnonzero(self.trough)
        for j in (0, 2):
            rows.append(row + np.arange(trough.size))
            cols.append(ng + 3 * trough + j)
        row += trough.size
        rows.append(row + np.arange(2 * no))
        cols.append(nc + np.arange(2 * no))
        row += 2 * no
        for i in range(2):
            if 8 + i in self.free:
                rows.append(np.array([row]))
                cols.append(np.array([int(np.flatnonzero(self.free == 8 + i)[0])]))
                row += 1
        rows.append(row + np.arange(3 * n))
        cols.append(ng + np.arange(3 * n))
        row += 3 * n
        R, C = np.concatenate(rows), np.concatenate(cols)
        return sp.csr_matrix((np.ones(R.size), (R, C)), shape=(row, ng + 3 * n))

    def row_blocks(self, x: np.ndarray) -> RowBlocks:
        """The residuals' Jacobian, analytic, as its blocks (:class:`.RowBlocks`; rows as in
        :meth:`residuals`): the point rows with every global column, each frame's angles
        touching only its own rows."""
        cam, off, fl, ang = self.split(x)
        nc, ng = self.free.size, self.n_global
        no = len(self.offset_points)
        l1, l2, l3, l4 = self.lengths
        th, ps, ph = ang[:, 0], ang[:, 1], ang[:, 2]
        if self.fixed_psi is not None:
            ps = th + self.fixed_psi
        X = self.plane(ang, fl)
        p_idx, f_idx = np.nonzero(self.use)
        m = p_idx.size
        d_plane, d_cam = image_jacobian(cam, X[p_idx, f_idx], self.centre, self.radius)
        wt = self.wt[p_idx, f_idx][:, None]
        d_plane = d_plane * wt[..., None]                       # (m, 2, 2)
        Jg = np.zeros((m, 2, ng))
        Jg[:, :, :nc] = d_cam[..., self.free] * wt[..., None]   # camera
        for j, p in enumerate(self.offset_points):              # offsets: ∂u/∂δ = I
            sel = p_idx == p
            Jg[sel, 0, nc + 2 * j] = wt[sel, 0]
            Jg[sel, 1, nc + 2 * j + 1] = wt[sel, 0]
        flying = (p_idx == 4) & self.flight[f_idx]
        if self.flight.any():                                   # x0, y0, vx, vy
            tau = self.tau[f_idx[flying]][:, None]
            dp = d_plane[flying]
            Jg[flying, :, nc + 2 * no] = dp[:, :, 0]
            Jg[flying, :, nc + 2 * no + 1] = dp[:, :, 1]
            Jg[flying, :, nc + 2 * no + 2] = dp[:, :, 0] * tau
            Jg[flying, :, nc + 2 * no + 3] = dp[:, :, 1] * tau
        et = np.column_stack([-np.sin(th), np.cos(th)])[f_idx]  # ∂e_θ/∂θ = e_θ⊥
        ep = np.column_stack([-np.sin(ps), np.cos(ps)])[f_idx]
        eph = np.column_stack([-np.sin(ph), np.cos(ph)])[f_idx]
        lever = np.where((p_idx == 1) | (p_idx == 4), l1, -l2)[:, None]
        dth = lever * et                                        # ∂X̃/∂θ: L1 e_θ⊥ or −L2 e_θ⊥
        if self.fixed_psi is not None:
            dth = dth + np.where(p_idx == 3, l3, 0.0)[:, None] * ep
        dth = np.where(((p_idx > 0) & ~flying)[:, None], dth, 0.0)
        dps = np.where(((p_idx == 3) & (self.fixed_psi is None))[:, None], l3 * ep, 0.0)
        dph = np.where(((p_idx == 4) & ~flying)[:, None], l4 * eph, 0.0)   # L4 e_φ⊥
        Ja = d_plane @ np.stack([dth, dps, dph], axis=-1)       # ∂u/∂X̃ ∂X̃/∂(θ, ψ, φ)
        k = self.gauge_px / self.sigma
        rest, tr = np.flatnonzero(self.rest), np.flatnonzero(self.trough)
        Ba = np.zeros((rest.size + tr.size, 3))
        Ba[:rest.size, 1] = -k * l3 * np.sin(ps[rest])          # ∂(L3 cos ψ)/∂ψ
        Ba[rest.size:, 0] = k * l1 * np.cos(th[tr])             # ∂y_m/∂θ
        Ba[rest.size:, 2] = k * l4 * np.cos(ph[tr])             # ∂y_m/∂φ
        prior_cols = [nc + np.arange(2 * no)]
        prior_vals = [np.full(2 * no, 1.0 / self.offset_sd)]
        for i in range(2):
            if 8 + i in self.free:
                prior_cols.append(np.flatnonzero(self.free == 8 + i))
                prior_vals.append(np.array([1.0 / self.k_sd[i]]))
        return RowBlocks(Jg.reshape(2 * m, ng), Ja.reshape(2 * m, 3), np.repeat(f_idx, 2),
                         Ba, np.concatenate([rest, tr]), np.concatenate(prior_cols),
                         np.concatenate(prior_vals), _WEAK, ng, self.n)

    def jacobian(self, x: np.ndarray) -> sp.csr_matrix:
        """The residuals' Jacobian as a sparse matrix (for ``least_squares``)."""
        return self.row_blocks(x).matrix()

    def subset(self, frames: np.ndarray) -> _Problem:
        """The same problem on the frames ``frames`` (indices)."""
        f = frames
        out = _Problem(**{k: getattr(self, k) for k in self.__dataclass_fields__})
        out.obs, out.use, out.wt = self.obs[:, f], self.use[:, f], self.wt[:, f]
        out.rest, out.trough, out.sling = self.rest[f], self.trough[f], self.sling[f]
        out.flight, out.tau, out.ang0 = self.flight[f], self.tau[f], self.ang0[f]
        return out


#: The robust loss's scale, in noise sd: residuals beyond it count less and less.
F_SCALE = 3.0
SOLVERS = ("blocks", "scipy")
#: Relative drop of the cost that ends the fits that choose the camera's level (their
#: costs differ by tens to thousands of noise units).
SELECTION_FTOL = 1e-6
#: ... and the fit of all frames (a drop of 1e-7 of a cost of 10⁴ noise units moves no
#: angle by a thousandth of its sd).
FINAL_FTOL = 1e-7
#: Rounds of flagging outliers and refitting (each takes the worst point of a frame).
FLAG_ROUNDS = 3
#: Iterations of each level's fit in the choice: enough for the models that fit (they
#: converge in 5–10); the others' costs are far off anyway.
SELECTION_ITERATIONS = 10


def _solve(pb: _Problem, x0: np.ndarray, solver: str = "blocks", ftol: float | None = None,
           max_iter: int = 100):
    """One robust least squares (soft-L1, scale :data:`F_SCALE` noise sd) with the analytic
    sparse Jacobian: "blocks" by :func:`.block_least_squares.block_least_squares` (the
    frames' angle blocks eliminated by the Schur complement, time linear in the frames),
    "scipy" by ``scipy.optimize.least_squares`` (trf, lsmr; the reference, ~20× slower)."""
    ftol = FINAL_FTOL if ftol is None else ftol
    if solver == "blocks":
        return block_least_squares(pb.residuals, pb.row_blocks, x0, pb.n_global, 3,
                                   f_scale=F_SCALE, max_iter=max_iter, ftol=ftol)
    return least_squares(pb.residuals, x0, jac=pb.jacobian, loss="soft_l1",
                         f_scale=F_SCALE, x_scale="jac", method="trf", tr_solver="lsmr",
                         max_nfev=max_iter, xtol=1e-10, ftol=ftol)


# ---------------------------------------------------------------- starting values

def _branch(values: np.ndarray, low: float) -> np.ndarray:
    """Unwrap ``values`` (rad) over the finite ones; shift into [low, low + 2π) at the first."""
    out = values.copy()
    ok = np.isfinite(values)
    if ok.any():
        u = np.unwrap(values[ok])
        out[ok] = u - 2 * np.pi * np.floor((u[0] - low) / (2 * np.pi))
    return out


def _fill(values: np.ndarray) -> np.ndarray:
    """NaN filled by linear interpolation over the frames (0 where nothing is known)."""
    ok = np.isfinite(values)
    if not ok.any():
        return np.zeros_like(values)
    idx = np.arange(values.size)
    return np.interp(idx, idx[ok], values[ok])


def _start_angles(pb: _Problem, cam: np.ndarray) -> np.ndarray:
    """Each frame's angles from its pixels taken back to the plane with the camera ``cam``
    (atan2 of two points, as the uncalibrated reader does), gaps interpolated."""
    Hinv = np.linalg.inv(_normalised_homography(cam))
    X = np.full(pb.obs.shape, np.nan)
    for p in range(5):
        u = undistort(pb.obs[p], cam[8], cam[9], tuple(pb.centre), pb.radius)
        X[p] = np.where(pb.use[p][:, None], apply_homography(Hinv, u), np.nan)
    l1, l2, l3, l4 = pb.lengths
    th = np.arctan2(X[1, :, 1], X[1, :, 0])                      # pivot → spigot
    from_hinge = np.arctan2(-X[2, :, 1], -X[2, :, 0])            # hinge → pivot
    th = _fill(_branch(np.where(np.isfinite(th), th, from_hinge), BRANCH_START[0]))
    eth = np.stack([np.cos(th), np.sin(th)], axis=-1)
    cw = X[3] + l2 * eth                                         # r_M − r_H
    ps = _fill(_branch(np.arctan2(cw[:, 1], cw[:, 0]), BRANCH_START[1]))
    st = X[4] - l1 * eth                                         # r_m − r_S
    ph = np.arctan2(st[:, 1], st[:, 0])
    ph = np.where(pb.sling, ph, np.nan)
    in_trough = pb.trough & ~np.isfinite(ph)                     # φ from the level alone
    s = np.clip(-(pb.h + l1 * np.sin(th)) / l4, -1, 1)
    ph = np.where(in_trough, -np.pi - np.arcsin(s), ph)          # sin φ = −(H + L1 sin θ)/L4
    ph = _fill(_branch(ph, BRANCH_START[2]))
    return np.column_stack([th, ps, ph])


def _start_flight(pb: _Problem, cam: np.ndarray) -> np.ndarray:
    """x0, y0, vx, vy (units of L1, s) of the parabola through the flight pixels."""
    Hinv = np.linalg.inv(_normalised_homography(cam))
    sel = pb.flight & pb.use[4]
    X = apply_homography(Hinv, undistort(pb.obs[4, sel], cam[8], cam[9], tuple(pb.centre),
                                         pb.radius))
    tau = pb.tau[sel]
    A = np.column_stack([np.ones_like(tau), tau])
    cx = np.linalg.lstsq(A, X[:, 0], rcond=None)[0]              # x = x0 + vx τ
    cy = np.linalg.lstsq(A, X[:, 1] + 0.5 * pb.g * tau ** 2, rcond=None)[0]  # y + gτ²/2
    return np.array([cx[0], cy[0], cx[1], cy[1]])


def _onset(d: np.ndarray, low: float, power: float) -> int:
    """Frame where a departure ``d`` (n,) from rest starts, for a departure growing like
    ``(t − t0)^power``: from the first frames ``a`` and ``b`` (three in a row) above ``low``
    and ``4 low``, ``t0 = (4^(1/power) a − b) / (4^(1/power) − 1)`` (earlier when it grows
    more slowly than that: on the safe side). ``d.size`` when it never departs."""
    def first_above(level: float) -> int | None:
        up = np.nan_to_num(d, nan=0.0) > level
        run = up[:-2] & up[1:-1] & up[2:]
        return int(np.flatnonzero(run)[0]) if run.any() else None

    a, b = first_above(low), first_above(4.0 * low)
    if a is None:
        return d.size
    if b is None:
        return a
    q = 4.0 ** (1.0 / power)
    return max(int(np.floor((q * a - b) / (q - 1.0))), 0)


def _rest_frames(track: np.ndarray, frames: int = 5, z: float = 6.0) -> np.ndarray:
    """Frames before the engine first moves: ``track`` (n, 2) px of a moving point departs
    from its first ``frames`` positions by more than ``z`` noise sd (noise from the
    frame-to-frame steps there); the onset of that departure (quadratic: the beam's
    acceleration jumps at the trigger) ends the rest."""
    n = track.shape[0]
    ok = np.isfinite(track).all(axis=1)
    head = np.flatnonzero(ok)[:4 * frames]
    if head.size < 2 * frames:
        return np.zeros(n, bool)
    steps = np.hypot(*np.diff(track[head], axis=0).T)
    noise = max(float(np.median(steps)) / RAYLEIGH_MEDIAN / np.sqrt(2.0), 0.05)
    centre = np.median(track[head[:frames]], axis=0)
    first = _onset(np.hypot(*(track - centre).T), max(z * noise, 1.0), 2.0)
    rest = np.zeros(n, bool)
    rest[:max(first - 1, 0)] = True
    rest &= ok
    return rest if rest.sum() >= frames else np.zeros(n, bool)


def _circle_centre(track: np.ndarray) -> np.ndarray:
    """Centre (2,) px of the circle through a track (n, 2): linear least squares of
    ``x² + y² + D x + E y + F = 0`` (Kåsa), centre ``(−D/2, −E/2)``."""
    q = track[np.isfinite(track).all(axis=1)]
    A = np.column_stack([q[:, 0], q[:, 1], np.ones(len(q))])
    D, E, _ = np.linalg.lstsq(A, -(q[:, 0] ** 2 + q[:, 1] ** 2), rcond=None)[0]
    return np.array([-D / 2, -E / 2])


def _sling_frames(obs: dict[str, np.ndarray], pivot: np.ndarray) -> np.ndarray:
    """Frames before the projectile flies off its sling's circle: the ratio
    |projectile − spigot| / |spigot − pivot| (pixels) rises for good above 1.1 × its
    median over the first half of the track."""
    n = obs["projectile"].shape[0]
    if "spigot" not in obs:
        return np.ones(n, bool)
    sling = np.hypot(*(obs["projectile"] - obs["spigot"]).T)
    beam = np.hypot(*(obs["spigot"] - pivot).T)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = sling / beam
    ok = np.flatnonzero(np.isfinite(ratio))
    if ok.size < 10:
        return np.ones(n, bool)
    level = float(np.median(ratio[ok[:ok.size // 2]]))
    near = ok[ratio[ok] <= 1.1 * level]
    last = near[-1] if near.size else -1
    out = np.ones(n, bool)
    if ok[-1] - last >= 5:                                       # a sustained final rise
        out[last + 1:] = False
    return out


def _trough_frames(y: np.ndarray, rest: np.ndarray, tol: float) -> np.ndarray:
    """Frames from the start on which the projectile's height ``y`` (units of L1, trough at
    0) stays on the trough's level: until the onset of its rise above ``tol`` (cubic: at
    lift-off the trough's push falls to zero continuously)."""
    first = _onset(y, tol, 3.0)
    out = np.zeros(y.size, bool)
    out[:max(first - 1, 0)] = True
    return out & (np.isfinite(y) | rest)


# ---------------------------------------------------------------- the fit

def _prepare_points(points: Mapping[str, np.ndarray], weights: Mapping[str, np.ndarray] | None
                    ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], int]:
    """Points (n, 2) float with NaN gaps and weights (n,) in [0, 1], checked."""
    unknown = set(points) - set(POINTS)
    if unknown:
        raise TrebuchetInputError(f"calibrate: unknown points {sorted(unknown)}; the points "
                                  f"are {POINTS}")
    obs = {k: np.asarray(v, dtype=float) for k, v in points.items() if v is not None}
    sizes = {v.shape for v in obs.values()}
    if len(sizes) != 1 or len(next(iter(sizes))) != 2 or next(iter(sizes))[1] != 2:
        raise TrebuchetInputError(f"calibrate: every point must be an (n, 2) array of pixels "
                                  f"of one length n, got {[v.shape for v in obs.values()]}")
    n = next(iter(sizes))[0]
    if "spigot" not in obs and "hinge" not in obs:
        raise TrebuchetInputError("calibrate: the beam's angle needs the spigot or the hinge "
                                  f"tracked; points given: {sorted(obs)}")
    w = {}
    for k in obs:
        wk = np.ones(n) if weights is None or k not in weights else np.asarray(weights[k], float)
        w[k] = np.clip(np.nan_to_num(wk, nan=0.0), 0.0, 1.0)
    return obs, w, n


def _pick_level(fits: list[LevelFit]) -> LevelFit:
    """The fit with the least BIC."""
    return min(fits, key=lambda f: f.bic)


def calibrate(points: Mapping[str, np.ndarray], engine: Engine, *, H: float,
              g: float | None = None, t: np.ndarray | None = None,
              weights: Mapping[str, np.ndarray] | None = None,
              at_rest: np.ndarray | None = None, in_trough: np.ndarray | None = None,
              in_sling: np.ndarray | None = None, trough: bool = True,
              camera: Camera | Intrinsics | None = None,
              image_size: tuple[float, float] | None = None,
              noise_px: float | None = None, offset_prior_px: float = 0.5,
              distortion_prior_px: float = 5.0, levels: tuple[str, ...] = LEVELS,
              selection_frames: int = 300, flag_threshold: float = 6.0,
              solver: str = "blocks") -> Calibration:
    """Fit the camera and every frame's angles to a point log (see the module doc).

    Parameters
    ----------
    points : {"pivot" | "spigot" | "hinge" | "counterweight" | "projectile": (n, 2) px}
        Pixel tracks, x along the rows, y up (the readers' convention: the image row
        negated), NaN in gaps. Any subset holding the spigot or the hinge.
    engine, H : the scene's engine (lengths m) and pivot height H (m above the trough).
    g : m/s², with ``t`` (n,) s: the projectile after leaving the sling is fitted on a
        vacuum parabola (leave None for a scene with drag).
    weights : tracker confidences (n,) in [0, 1] per point; residuals are weighted by them.
    at_rest, in_trough, in_sling : (n,) bool, optional: frames at rest (counterweight
        plumb), with the projectile in the trough (on its level), in the sling or trough
        (L4 from the spigot). Found from the tracks when not given (``trough``: False
        for a scene whose projectile does not start in the trough).
    camera : a user's own calibration: a :class:`~.camera.Camera` (fixed; only the angles
        and marker offsets are fitted) or :class:`~.camera.Intrinsics` (lens fixed; the
        plane's map fitted, without distortion levels).
    image_size : (width, height) px: puts the distortion centre (and principal point) at
        the picture's centre and normalises distortion by the width.
    noise_px : tracker noise sd per coordinate (px); estimated from the fit when None.
    offset_prior_px : prior sd of each marker's constant offset (px).
    distortion_prior_px : prior sd of k1's (and k2's) displacement at the data's edge (px).
    levels : camera models to choose from (:data:`LEVELS`, any of :data:`ALL_LEVELS`).
    selection_frames : at most this many frames (evenly spread) for choosing the level.
    flag_threshold : residual (noise sd) beyond which a position is an outlier.
    solver : "blocks" (Schur complement, fast) or "scipy" (``least_squares``, reference).
    """
    start = time.perf_counter()
    check_choice("calibrate", "solver", solver, SOLVERS)
    for level in levels:
        check_choice("calibrate", "levels", level, ALL_LEVELS)
    obs, w, n = _prepare_points(points, weights)
    notes: list[str] = []
    all_pts = np.concatenate([v[np.isfinite(v).all(axis=1)] for v in obs.values()])
    if all_pts.shape[0] == 0:
        raise TrebuchetInputError("calibrate: no tracked position at all")
    lo, hi = all_pts.min(axis=0), all_pts.max(axis=0)
    given = camera if isinstance(camera, Camera) else None
    lens = camera if isinstance(camera, Intrinsics) else None
    if given is not None:
        centre, radius = np.array(given.centre, float), given.radius
    elif lens is not None:
        centre, radius = np.array(lens.centre, float), lens.radius
    elif image_size is not None:
        centre, radius = np.array([image_size[0] / 2, -image_size[1] / 2]), float(image_size[0])
    else:
        centre, radius = 0.5 * (lo + hi), float(np.hypot(*(hi - lo)))
        notes.append("no image size: distortion about the centre of the tracked points")
    rho_max = max(float(np.max(np.hypot(*(all_pts - centre).T))) / radius, 1e-3)
    k_sd = (distortion_prior_px / (radius * rho_max ** 3),
            distortion_prior_px / (radius * rho_max ** 5))

    pivot_img = (np.nanmedian(obs["pivot"], axis=0) if "pivot" in obs
                 and np.isfinite(obs["pivot"]).any() else None)
    if pivot_img is None:                                        # the spigot's circle's centre
        pivot_img = _circle_centre(obs["spigot" if "spigot" in obs else "hinge"])
        notes.append("the pivot is not tracked: its pixel starts at the centre of the "
                     "spigot's (or hinge's) circle")
    # --- which frames get which constraint
    moving = next(obs[k] for k in ("spigot", "projectile", "counterweight", "hinge")
                  if k in obs)
    rest = (np.asarray(at_rest, bool) if at_rest is not None else _rest_frames(moving))
    if "projectile" in obs:
        sling = (np.asarray(in_sling, bool) if in_sling is not None else
                 _sling_frames(obs, pivot_img))
    else:
        sling = np.ones(n, bool)
    flight = ~sling & (g is not None) & (t is not None)
    if "projectile" in obs and flight.any() and np.isfinite(obs["projectile"][flight]).all(
            axis=1).sum() < 5:
        flight[:] = False
    tau = np.zeros(n)
    if flight.any():
        tt = np.asarray(t, float)
        tau = tt - tt[np.flatnonzero(flight)[0]]
    trough_mask = (np.asarray(in_trough, bool) if in_trough is not None
                   else (rest.copy() if trough and "projectile" in obs else np.zeros(n, bool)))
    fixed_psi = engine.counterweight_offset
    plumb = rest if fixed_psi is None else np.zeros(n, bool)  # a rigid one does not hang

    # --- the problem's arrays
    O = np.zeros((5, n, 2))
    use = np.zeros((5, n), bool)
    wt = np.zeros((5, n))
    for p, name in enumerate(POINTS):
        if name in obs:
            ok = np.isfinite(obs[name]).all(axis=1) & (w[name] > 0)
            if name == "projectile":
                ok &= sling | flight
            O[p] = np.where(ok[:, None], obs[name], 0.0)
            use[p], wt[p] = ok, np.sqrt(w[name])
    L = engine.L1
    # --- the start: the spigot's ellipse about the pivot
    cam0 = np.zeros(10)
    if given is not None:
        N = np.array([[1 / L, 0.0, 0.0], [0.0, 1 / L, -H / L], [0.0, 0.0, 1.0]])
        cam0 = _parameters_of(given.Hm @ np.linalg.inv(N))
        cam0[8:] = given.k1, given.k2
    else:
        arc_name, arc_len = ("spigot", 1.0) if "spigot" in obs else ("hinge", engine.L2 / L)
        arc = obs[arc_name][use[POINTS.index(arc_name)]]
        k1k2 = (lens.k1, lens.k2) if lens else (0.0, 0.0)
        arc = undistort(arc, *k1k2, tuple(centre), radius)
        pc = pivot_img
        Hc = circle_homography(arc, pc)
        if Hc is not None:
            cam0 = _parameters_of(Hc @ np.diag([1 / arc_len, 1 / arc_len, 1.0]))
        if Hc is None or np.hypot(cam0[6], cam0[7]) > 0.5 or abs(cam0[4]) > 0.3:
            s0 = float(np.median(np.hypot(*(arc - pc).T))) / arc_len
            cam0 = np.array([pc[0], pc[1], s0, 0, 0, 0, 0, 0, 0, 0])
            notes.append("the spigot's track gives no ellipse about the pivot: started from "
                         "a fronto-parallel camera")
        cam0[8:] = k1k2
    if levels[-1] in _FREE:
        cam0[_FREE[levels[-1]]:8] = 0.0
    vertical = plumb.any() or trough_mask.any() or flight.any()
    if not vertical:
        notes.append("no rest, trough or flight frames: the image's vertical is taken as "
                     "the engine's")
    if given is not None:
        levels = ("given",)
    elif lens is not None:
        levels = tuple(dict.fromkeys(lv.split("+")[0] for lv in levels))  # lens fixed

    def free_of(level: str) -> np.ndarray:
        if level == "given":
            return np.zeros(0, int)
        idx = list(range(_FREE[level]))
        if not vertical and 3 in idx:
            idx.remove(3)
        return np.array(idx, int)

    offset_points = tuple(p for p in range(1, 5) if use[p].any())
    pb = _Problem(obs=O, use=use, wt=wt / (noise_px or 1.0),
                  lengths=(1.0, engine.L2 / L, engine.L3 / L, engine.L4 / L), h=H / L,
                  centre=centre, radius=radius, rest=plumb & use[3],
                  trough=trough_mask, sling=sling, flight=flight, tau=tau,
                  g=(g or 0.0) / L, cam0=cam0, free=free_of(levels[-1]),
                  offset_points=offset_points, sigma=noise_px or 1.0,
                  offset_sd=offset_prior_px, k_sd=k_sd, gauge_px=float(cam0[2]),
                  fixed_psi=fixed_psi)
    pb.ang0 = _start_angles(pb, cam0)

    def x_of(p: _Problem, cam: np.ndarray, off: np.ndarray, fl: np.ndarray,
             ang: np.ndarray) -> np.ndarray:
        nf = 4 if p.flight.any() else 0
        if nf and fl.size == 0:
            fl = _start_flight(p, cam)
        return np.concatenate([cam[p.free], off[list(p.offset_points)].ravel(), fl[:nf],
                               ang.ravel()])

    def with_sigma(p: _Problem, sigma: float) -> None:
        p.wt = p.wt * p.sigma / sigma
        p.sigma = sigma

    # --- choose the level on a subsample of frames
    step = max(1, int(np.ceil(n / selection_frames)))
    sub = pb.subset(np.arange(0, n, step))
    fits: list[LevelFit] = []
    sols: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    sub.free = free_of(levels[-1])
    res = _solve(sub, x_of(sub, cam0, np.zeros((5, 2)), np.zeros(0), sub.ang0), solver,
                 SELECTION_FTOL)
    if noise_px is None:
        sigma = _noise_sd(sub, res.x)
        with_sigma(sub, max(sigma, 1e-3))
        with_sigma(pb, max(sigma, 1e-3))
    top_cam, top_off, top_fl, _ = sub.split(res.x)
    n_obs = 2 * int(pb.use.sum())                                # the whole log's N
    per_log = n_obs / (2.0 * max(int(sub.use.sum()), 1))        # its cost per subsample cost
    worse = 0
    for level in levels:                                         # from the simplest up
        sub.free = free_of(level)
        cam = top_cam.copy()
        if level in _FREE:                                       # the rest held at zero
            cam[_FREE[level]:] = 0.0
            cam[8:] = cam0[8:] if lens is not None else cam[8:]
        sub.cam0 = cam
        if level == levels[-1]:
            x0 = res.x
        else:
            sub.ang0 = _start_angles(sub, cam)
            x0 = x_of(sub, cam, top_off, top_fl, sub.ang0)
        fit = _solve(sub, x0, solver, SELECTION_FTOL, SELECTION_ITERATIONS)
        sols[level] = (fit.x, cam)
        fits.append(LevelFit(level, float(fit.cost), int(sub.free.size),
                             2.0 * per_log * float(fit.cost)
                             + sub.free.size * np.log(n_obs)))
        worse = worse + 1 if fits[-1].bic > _pick_level(fits).bic else 0
        if worse == 2:                                           # two richer models no better
            break
    best = _pick_level(fits)
    sub.free, sub.cam0 = free_of(best.level), sols[best.level][1]
    cam_best, off_best, fl_best, _ = sub.split(sols[best.level][0])

    # --- the projectile's trough frames, from its height with the chosen camera
    if trough and in_trough is None and "projectile" in obs and rest.any():
        Hinv = np.linalg.inv(_normalised_homography(cam_best))
        y = apply_homography(Hinv, undistort(np.where(use[4][:, None], O[4], np.nan),
                                             cam_best[8], cam_best[9], tuple(centre),
                                             radius))[:, 1] + pb.h
        y_rest = y[rest & np.isfinite(y)]
        sd = 1.4826 * float(np.median(np.abs(y_rest - np.median(y_rest)))) if y_rest.size else 0
        floor = pb.sigma / cam_best[2]                           # one noise sd, units of L1
        pb.trough = _trough_frames(y - (np.median(y_rest) if y_rest.size else 0.0), rest,
                                   max(5.0 * sd, 3.0 * floor))
    # --- all frames at the chosen level
    pb.free, pb.cam0 = free_of(best.level), cam_best
    pb.ang0 = _start_angles(pb, cam_best)
    final = _solve(pb, x_of(pb, cam_best, off_best, fl_best, pb.ang0), solver)
    sigma = noise_px if noise_px is not None else _noise_sd(pb, final.x)
    flagged: tuple[FlaggedTrack, ...] = ()
    gaps = {name: np.zeros(n, bool) for name in POINTS if name in obs}
    for _ in range(FLAG_ROUNDS):          # the worst point of a frame first, then look again
        U = pb.predicted(final.x)
        observed = {name: np.where(pb.use[p][:, None], pb.obs[p], np.nan)
                    for p, name in enumerate(POINTS) if name in obs}
        predicted = {name: U[p] for p, name in enumerate(POINTS) if name in obs}
        culprits = _culprits(pb, final.x, outlier_limit(sigma, flag_threshold), solver)
        found, new = flag_tracks(observed, predicted, sigma, threshold=flag_threshold,
                                 culprits={name: culprits[p] for p, name in enumerate(POINTS)
                                           if name in obs})
        if not found:
            break
        flagged += found
        for p, name in enumerate(POINTS):
            if name in new:
                pb.use[p] &= ~new[name]
                gaps[name] |= new[name]
        if noise_px is None:
            with_sigma(pb, max(sigma, 1e-3))
        final = _solve(pb, final.x, solver)
        if noise_px is None:
            sigma = _noise_sd(pb, final.x)
    U = pb.predicted(final.x)
    cam, off, fl, ang = pb.split(final.x)
    if noise_px is None:
        sigma = _noise_sd(pb, final.x)
    # --- uncertainty: Gauss–Newton covariance, split by the Schur complement
    blocks = (final.normal if hasattr(final, "normal") else
              normal_blocks(final.jac, pb.n_global, n, 3))
    sd_frame, sd_cal, sd_global = _angle_sd(blocks, sigma / pb.sigma)
    has = _angle_has_data(pb)
    if fixed_psi is not None:                                    # ψ = θ + offset (rigid)
        ang[:, 1] = ang[:, 0] + fixed_psi
        sd_frame[:, 1], sd_cal[:, 1] = sd_frame[:, 0], sd_cal[:, 0]
    for j in range(3):
        ang[:, j] = _branch(np.where(has[:, j], ang[:, j], np.nan), BRANCH_START[j])
    sd_frame = np.where(has, sd_frame, np.nan)
    sd_cal = np.where(has, sd_cal, np.nan)
    cam_sd = np.zeros(10)
    cam_sd[pb.free] = sd_global[:pb.free.size]
    no = len(pb.offset_points)
    off_sd = np.zeros((5, 2))
    off_sd[list(pb.offset_points)] = sd_global[pb.free.size:pb.free.size + 2 * no].reshape(
        no, 2)
    camera_found = camera_of(cam, engine, H, centre, radius)
    focal = (lens.focal if lens is not None else None)
    pose = camera_pose(camera_found, focal=focal, centre=tuple(centre), pivot=(0.0, H))
    k1_focal = (float(cam[8]) * (pose.focal / radius) ** 2 if pose.focal is not None
                else None)
    residuals = {name: np.where(pb.use[p][:, None], pb.obs[p] - U[p], np.nan)
                 for p, name in enumerate(POINTS) if name in obs}
    fitted = [f"camera: {best.level}" + (" (tilt and distortion fixed by the user's lens)"
                                         if lens is not None else "")]
    fitted += [f"{name}: {int(pb.use[p].sum())} positions" for p, name in enumerate(POINTS)
               if name in obs]
    fitted += [f"{ANGLES[j]}: {int(has[:, j].sum())} frames" for j in range(3)]
    fitted += [f"plumb counterweight at rest: {int(pb.rest.sum())} frames",
               f"projectile on the trough's level: {int(pb.trough.sum())} frames",
               f"projectile on its parabola: {int((pb.flight & pb.use[4]).sum())} frames"]
    return Calibration(
        camera=camera_found, pose=pose, level=best.level,
        parameters=dict(zip(CAMERA_PARAMETERS, cam.tolist(), strict=True)),
        parameters_sd=dict(zip(CAMERA_PARAMETERS, cam_sd.tolist(), strict=True)),
        k1_focal=k1_focal, levels=tuple(fits),
        offsets={name: off[p] for p, name in enumerate(POINTS) if name in obs},
        offsets_sd={name: off_sd[p] for p, name in enumerate(POINTS) if name in obs},
        theta=ang[:, 0], psi=ang[:, 1], phi=ang[:, 2],
        theta_sd=sd_frame[:, 0], psi_sd=sd_frame[:, 1], phi_sd=sd_frame[:, 2],
        theta_sd_calibration=sd_cal[:, 0], psi_sd_calibration=sd_cal[:, 1],
        phi_sd_calibration=sd_cal[:, 2],
        residuals=residuals, noise_px=float(sigma), flagged=flagged,
        gaps={k: v for k, v in gaps.items()}, at_rest=rest.copy(),
        in_trough=pb.trough.copy(), in_sling=sling.copy(), fitted=tuple(fitted),
        notes=tuple(notes) + tuple(f.note for f in flagged), cost=float(final.cost),
        nfev=int(final.nfev), success=bool(final.success), message=str(final.message),
        seconds=time.perf_counter() - start)


def _culprits(pb: _Problem, x: np.ndarray, limit: float, solver: str) -> np.ndarray:
    """(5, n) bool: in each frame with a residual beyond ``limit`` px, the point whose
    leaving out lets the others fit best (the frame's angles refitted with the camera,
    offsets and flight held): one wrong point drags the fitted frame and its neighbours'
    residuals with it, so the largest residual need not be the wrong point's."""
    U = pb.predicted(x)
    dist = np.where(pb.use, np.hypot(*(U - pb.obs).transpose(2, 0, 1)), 0.0)   # (5, n) px
    out = np.zeros(pb.use.shape, bool)
    out[4] = (dist[4] > limit) & pb.flight                       # a stone off its parabola
    dist[4] = np.where(pb.flight, 0.0, dist[4])
    frames = np.flatnonzero((dist > limit).any(axis=0))
    if frames.size == 0:
        return out
    cam, off, fl, ang = pb.split(x)
    sub = pb.subset(frames)
    sub.obs = sub.obs - off[:, None, :]                          # offsets held
    sub.offset_points, sub.free, sub.cam0 = (), np.zeros(0, int), cam
    sub.flight = np.zeros(frames.size, bool)                     # the parabola held: leave
    sub.use[4] &= pb.sling[frames]                               # flying stones out
    worst_left = np.full((5, frames.size), np.inf)
    for p in range(5):
        here = sub.use[p].copy()
        if not here.any():
            continue
        trial = sub.subset(np.arange(frames.size))
        trial.use = sub.use.copy()
        trial.use[p] = False
        sol = _solve(trial, ang[frames].ravel(), solver)
        V = trial.predicted(sol.x)
        left = np.where(trial.use, np.hypot(*(V - trial.obs).transpose(2, 0, 1)), 0.0)
        worst_left[p] = np.where(here, left.max(axis=0), np.inf)
    blame = np.argmin(worst_left, axis=0)                        # the best point to leave out
    out[blame, frames] = True
    return out & pb.use


def _noise_sd(pb: _Problem, x: np.ndarray) -> float:
    """The tracker's noise sd per coordinate (px), robustly from the fit's residuals: the
    median residual distance over the Rayleigh median √(2 ln 2), scaled up by
    √(N / (N − p)) for the p parameters fitted to the N coordinates (each frame's angles
    take up part of its noise)."""
    r = (pb.predicted(x) - pb.obs)[pb.use]
    n_obs = r.size
    n_par = pb.n_global + int(_angle_has_data(pb).sum())
    raw = float(np.median(np.hypot(r[:, 0], r[:, 1]))) / RAYLEIGH_MEDIAN
    return max(raw * np.sqrt(n_obs / max(n_obs - n_par, 1)), 1e-3)


def _angle_has_data(pb: _Problem) -> np.ndarray:
    """(n, 3) bool: the frame's θ, ψ, φ are fixed by some residual other than the weak
    prior."""
    th = pb.use[1] | pb.use[2]
    ps = pb.use[3] & th if pb.fixed_psi is None else th
    ph = ((pb.use[4] & ~pb.flight) | pb.trough) & th
    return np.column_stack([th, ps, ph])


def _angle_sd(blocks: tuple[np.ndarray, np.ndarray, np.ndarray], rescale: float
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sd (n, 3) of each frame's angles (its own part and the part the global parameters
    carry), and of the global parameters (ng,), from the normal blocks ``U``, ``W``, ``V``
    of ``JᵀJ`` (residuals in noise units, times ``rescale``): ``C_g = (U − W V⁻¹ Wᵀ)⁻¹``,
    ``C_f = V_f⁻¹ + V_f⁻¹ W_fᵀ C_g W_f V_f⁻¹``."""
    U, W, V = blocks
    ng = U.shape[0]
    Vinv = np.linalg.inv(V)                                       # V_f⁻¹
    WV = W @ Vinv                                                 # W_f V_f⁻¹ (n, ng, 3)
    S = U - np.einsum("fgj,fhj->gh", WV, W)                       # Schur complement
    Cg = np.linalg.pinv(S) if ng else np.zeros((0, 0))
    cal = np.einsum("fgi,gh,fhi->fi", WV, Cg, WV)                 # diag of V⁻¹WᵀC_gWV⁻¹
    own = np.einsum("fii->fi", Vinv)
    r2 = rescale * rescale
    return (np.sqrt(np.maximum(own, 0) * r2), np.sqrt(np.maximum(cal, 0) * r2),
            np.sqrt(np.maximum(np.diag(Cg), 0) * r2))


def angles_from_calibration(points: Mapping[str, np.ndarray], calibration: Calibration | Camera,
                            engine: Engine, *, H: float, **options) -> Calibration:
    """Each frame's angles from all its tracked points with a known camera (one found by
    :func:`calibrate`, or a user's :class:`~.camera.Camera`): the same constrained fit
    with the camera held, the marker offsets and angles fitted. ``options`` as for
    :func:`calibrate`."""
    camera = calibration.camera if isinstance(calibration, Calibration) else calibration
    return calibrate(points, engine, H=H, camera=camera, **options)
