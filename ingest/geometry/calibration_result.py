"""What :func:`~.calibration.calibrate` returns: the camera models tried (:class:`LevelFit`)
and the :class:`Calibration` of the final fit, with each frame's angles and their sd by the
Schur complement of the fit's normal equations (:func:`angle_sd`)."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from trebuchet.model.scene import Engine

from .block_least_squares import normal_blocks
from .calibration_problem import (
    ANGLES,
    BRANCH_START,
    CalibrationProblem,
    angles_with_data,
    branch,
)
from .camera import Camera, CameraPose, Intrinsics, camera_pose
from .engine_points import POINTS
from .plane_map import CAMERA_PARAMETERS, camera_of
from .track_flags import FlaggedTrack

__all__ = ["LevelFit", "Calibration", "calibration_result", "angle_sd"]


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

    def summary(self) -> str:
        """The camera found and the fit's quality in one sentence (for a log's notes)."""
        p = self.pose
        tilt = (f"tilt {np.degrees(p.tilt):.1f}° (pitch {np.degrees(p.pitch):.1f}°, yaw "
                f"{np.degrees(p.yaw):.1f}°), focal {p.focal:.0f} px" if p.focal is not None
                else "no tilt")
        k1 = (f", k1 {self.k1_focal:.3f} per focal length" if self.k1_focal is not None
              and self.parameters_sd["k1"] > 0 else "")
        sd = {a: np.degrees(np.nanmedian(getattr(self, f"{a}_sd_calibration")))
              for a in ANGLES}
        return (f"camera calibrated by the engine ({self.level}): {tilt}, roll "
                f"{np.degrees(p.roll) + 0.0:.2f}°{k1}, {p.px_per_m:.1f} px/m at the pivot; "
                f"tracking noise {self.noise_px:.2f} px; calibration sd θ {sd['theta']:.3f}°, "
                f"ψ {sd['psi']:.3f}°, φ {sd['phi']:.3f}°; {len(self.flagged)} stretches of "
                f"points left out")


def calibration_result(pb: CalibrationProblem, final, sigma: float, engine: Engine, H: float,
            lens: Intrinsics | None, best: LevelFit, fits: list[LevelFit],
            obs: dict[str, np.ndarray], rest: np.ndarray, flagged: tuple[FlaggedTrack, ...],
            gaps: dict[str, np.ndarray], notes: list[str], start: float) -> Calibration:
    """The :class:`Calibration` of the final fit: angles on the paper's branch (NaN without
    data), their sd by the Schur complement, the camera and its pose, the residuals."""
    n = pb.n
    cam, off, fl, ang = pb.split(final.x)
    U = pb.predicted(final.x)
    blocks = (final.normal if hasattr(final, "normal") else
              normal_blocks(final.jac, pb.n_global, n, 3))
    sd_frame, sd_cal, sd_global = angle_sd(blocks, sigma / pb.sigma)
    has = angles_with_data(pb)
    if pb.fixed_psi is not None:                                 # ψ = θ + offset (rigid)
        ang[:, 1] = ang[:, 0] + pb.fixed_psi
        sd_frame[:, 1], sd_cal[:, 1] = sd_frame[:, 0], sd_cal[:, 0]
    for j in range(3):
        ang[:, j] = branch(np.where(has[:, j], ang[:, j], np.nan), BRANCH_START[j])
    sd_frame = np.where(has, sd_frame, np.nan)
    sd_cal = np.where(has, sd_cal, np.nan)
    nc, no = pb.free.size, len(pb.offset_points)
    cam_sd = np.zeros(10)
    cam_sd[pb.free] = sd_global[:nc]
    off_sd = np.zeros((5, 2))
    off_sd[list(pb.offset_points)] = sd_global[nc:nc + 2 * no].reshape(no, 2)
    camera_found = camera_of(cam, engine, H, pb.centre, pb.radius)
    pose = camera_pose(camera_found, focal=lens.focal if lens is not None else None,
                       centre=tuple(pb.centre), pivot=(0.0, H))
    k1_focal = (float(cam[8]) * (pose.focal / pb.radius) ** 2 if pose.focal is not None
                else None)                                       # k1 per focal length
    named = [(p, k) for p, k in enumerate(POINTS) if k in obs]
    fitted = [f"camera: {best.level}" + (" (distortion fixed by the user's lens)"
                                         if lens is not None else "")]
    fitted += [f"{k}: {int(pb.use[p].sum())} positions" for p, k in named]
    fitted += [f"{ANGLES[j]}: {int(has[:, j].sum())} frames" for j in range(3)]
    fitted += [f"plumb counterweight at rest: {int(pb.rest.sum())} frames",
               f"projectile on the trough's level: {int(pb.trough.sum())} frames",
               f"projectile on its parabola: {int((pb.flight & pb.use[4]).sum())} frames"]
    return Calibration(
        camera=camera_found, pose=pose, level=best.level,
        parameters=dict(zip(CAMERA_PARAMETERS, cam.tolist(), strict=True)),
        parameters_sd=dict(zip(CAMERA_PARAMETERS, cam_sd.tolist(), strict=True)),
        k1_focal=k1_focal, levels=tuple(fits),
        offsets={k: off[p] for p, k in named}, offsets_sd={k: off_sd[p] for p, k in named},
        theta=ang[:, 0], psi=ang[:, 1], phi=ang[:, 2],
        theta_sd=sd_frame[:, 0], psi_sd=sd_frame[:, 1], phi_sd=sd_frame[:, 2],
        theta_sd_calibration=sd_cal[:, 0], psi_sd_calibration=sd_cal[:, 1],
        phi_sd_calibration=sd_cal[:, 2],
        residuals={k: np.where(pb.use[p][:, None], pb.obs[p] - U[p], np.nan) for p, k in named},
        noise_px=float(sigma), flagged=flagged, gaps=gaps, at_rest=rest.copy(),
        in_trough=pb.trough.copy(), in_sling=pb.sling.copy(), fitted=tuple(fitted),
        notes=tuple(notes) + tuple(f.note for f in flagged), cost=float(final.cost),
        nfev=int(final.nfev), success=bool(final.success), message=str(final.message),
        seconds=time.perf_counter() - start)


def angle_sd(blocks: tuple[np.ndarray, np.ndarray, np.ndarray], rescale: float
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
