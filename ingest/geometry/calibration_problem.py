"""The calibration's least-squares problem: residuals, their Jacobian, starting values.

The unknowns are the free camera parameters (:mod:`.plane_map`), a constant pixel offset
per marker (all but the pivot's), the projectile's parabola in flight (x0, y0, vx, vy) and
every frame's θ, ψ, φ. The residuals, in this order, each in units of the noise sd:

* every tracked coordinate, tracked minus fitted (the points of :mod:`.engine_points`),
  weighted by √confidence;
* at rest ``L3 cos ψ`` (plumb), in the trough ``H + L1 sin θ + L4 sin φ`` (level), both
  as pixels at the starting scale;
* the priors: marker offsets, k1 and k2; and a weak one (:data:`WEAK`) keeping an angle
  without data at its start.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from .block_least_squares import RowBlocks
from .camera import apply_homography, undistort
from .plane_map import image_jacobian, image_of, normalised_homography
from .track_flags import RAYLEIGH_MEDIAN

__all__ = ["BRANCH_START", "ANGLES", "WEAK", "CalibrationProblem", "branch", "start_angles",
           "start_flight", "angles_with_data", "noise_sd"]

#: Branch of each angle's first value: [-π, π) for θ and ψ, [-3π/2, π/2) for φ (the
#: sling starts near −180°), as in :mod:`trebuchet.ingest.angles_from_points`.
BRANCH_START = (-np.pi, -np.pi, -1.5 * np.pi)
ANGLES = ("theta", "psi", "phi")
WEAK = 1e-3  # weight of the prior that keeps an angle without data at its start (1/rad)


@dataclass
class CalibrationProblem:
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
        r_weak = WEAK * (ang - self.ang0).ravel()
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
                         np.concatenate(prior_vals), WEAK, ng, self.n)

    def jacobian(self, x: np.ndarray) -> sp.csr_matrix:
        """The residuals' Jacobian as a sparse matrix (for ``least_squares``)."""
        return self.row_blocks(x).matrix()

    def subset(self, frames: np.ndarray) -> CalibrationProblem:
        """The same problem on the frames ``frames`` (indices)."""
        f = frames
        out = CalibrationProblem(**{k: getattr(self, k) for k in self.__dataclass_fields__})
        out.obs, out.use, out.wt = self.obs[:, f], self.use[:, f], self.wt[:, f]
        out.rest, out.trough, out.sling = self.rest[f], self.trough[f], self.sling[f]
        out.flight, out.tau, out.ang0 = self.flight[f], self.tau[f], self.ang0[f]
        return out



def branch(values: np.ndarray, low: float) -> np.ndarray:
    """Unwrap ``values`` (rad) over the finite ones; shift into [low, low + 2π) at the first."""
    out = values.copy()
    ok = np.isfinite(values)
    if ok.any():
        u = np.unwrap(values[ok])
        out[ok] = u - 2 * np.pi * np.floor((u[0] - low) / (2 * np.pi))
    return out


def fill(values: np.ndarray) -> np.ndarray:
    """NaN filled by linear interpolation over the frames (0 where nothing is known)."""
    ok = np.isfinite(values)
    if not ok.any():
        return np.zeros_like(values)
    idx = np.arange(values.size)
    return np.interp(idx, idx[ok], values[ok])


def start_angles(pb: CalibrationProblem, cam: np.ndarray) -> np.ndarray:
    """Each frame's angles from its pixels taken back to the plane with the camera ``cam``
    (atan2 of two points, as the uncalibrated reader does), gaps interpolated."""
    Hinv = np.linalg.inv(normalised_homography(cam))
    X = np.full(pb.obs.shape, np.nan)
    for p in range(5):
        u = undistort(pb.obs[p], cam[8], cam[9], tuple(pb.centre), pb.radius)
        X[p] = np.where(pb.use[p][:, None], apply_homography(Hinv, u), np.nan)
    l1, l2, l3, l4 = pb.lengths
    th = np.arctan2(X[1, :, 1], X[1, :, 0])                      # pivot → spigot
    from_hinge = np.arctan2(-X[2, :, 1], -X[2, :, 0])            # hinge → pivot
    th = fill(branch(np.where(np.isfinite(th), th, from_hinge), BRANCH_START[0]))
    eth = np.stack([np.cos(th), np.sin(th)], axis=-1)
    cw = X[3] + l2 * eth                                         # r_M − r_H
    ps = fill(branch(np.arctan2(cw[:, 1], cw[:, 0]), BRANCH_START[1]))
    st = X[4] - l1 * eth                                         # r_m − r_S
    ph = np.arctan2(st[:, 1], st[:, 0])
    ph = np.where(pb.sling, ph, np.nan)
    in_trough = pb.trough & ~np.isfinite(ph)                     # φ from the level alone
    s = np.clip(-(pb.h + l1 * np.sin(th)) / l4, -1, 1)
    ph = np.where(in_trough, -np.pi - np.arcsin(s), ph)          # sin φ = −(H + L1 sin θ)/L4
    ph = fill(branch(ph, BRANCH_START[2]))
    return np.column_stack([th, ps, ph])


def start_flight(pb: CalibrationProblem, cam: np.ndarray) -> np.ndarray:
    """x0, y0, vx, vy (units of L1, s) of the parabola through the flight pixels."""
    Hinv = np.linalg.inv(normalised_homography(cam))
    sel = pb.flight & pb.use[4]
    X = apply_homography(Hinv, undistort(pb.obs[4, sel], cam[8], cam[9], tuple(pb.centre),
                                         pb.radius))
    tau = pb.tau[sel]
    A = np.column_stack([np.ones_like(tau), tau])
    cx = np.linalg.lstsq(A, X[:, 0], rcond=None)[0]              # x = x0 + vx τ
    cy = np.linalg.lstsq(A, X[:, 1] + 0.5 * pb.g * tau ** 2, rcond=None)[0]  # y + gτ²/2
    return np.array([cx[0], cy[0], cx[1], cy[1]])


def noise_sd(pb: CalibrationProblem, x: np.ndarray) -> float:
    """The tracker's noise sd per coordinate (px), robustly from the fit's residuals: the
    median residual distance over the Rayleigh median √(2 ln 2), scaled up by
    √(N / (N − p)) for the p parameters fitted to the N coordinates (each frame's angles
    take up part of its noise)."""
    r = (pb.predicted(x) - pb.obs)[pb.use]
    n_obs = r.size
    n_par = pb.n_global + int(angles_with_data(pb).sum())
    raw = float(np.median(np.hypot(r[:, 0], r[:, 1]))) / RAYLEIGH_MEDIAN
    return max(raw * np.sqrt(n_obs / max(n_obs - n_par, 1)), 1e-3)


def angles_with_data(pb: CalibrationProblem) -> np.ndarray:
    """(n, 3) bool: the frame's θ, ψ, φ are fixed by some residual other than the weak
    prior."""
    th = pb.use[1] | pb.use[2]
    ps = pb.use[3] & th if pb.fixed_psi is None else th
    ph = ((pb.use[4] & ~pb.flight) | pb.trough) & th
    return np.column_stack([th, ps, ph])
