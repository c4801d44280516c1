"""The image calibrated by the engine itself (issue 15).

A point log gives, frame by frame, the pixels of the pivot, spigot, hinge, counterweight
and projectile. :func:`calibrate` fits, in one robust least squares over the whole log
(soft-L1 loss, analytic sparse Jacobian; the frames' angles eliminated by the Schur
complement, :mod:`.block_least_squares`, or ``scipy.optimize.least_squares``), the map
from the engine's plane to the image together with every frame's angles θ, ψ, φ and a
constant pixel offset of each marker. The scene makes it well posed:

* the pivot is fixed; spigot, pivot and hinge lie on one straight beam at L1 and L2; the
  counterweight is L3 from the hinge; the projectile L4 from the spigot while in the sling
  (:mod:`.engine_points`), on a parabola with the scene's g in flight;
* the vertical: at rest the counterweight hangs plumb (``L3 cos ψ = 0``); in the trough the
  projectile lies on its level (``H + L1 sin θ + L4 sin φ = 0``); in flight it falls
  along −y;
* the start: the ellipse the spigot traces about the pivot (:mod:`.conic_start`).

The map from the plane to the image and its levels are in :mod:`.plane_map`; the
residuals, their Jacobian and the starting values in :mod:`.calibration_problem`; which
frames are at rest, in the trough, in the sling, in :mod:`.shot_frames`.

Perspective and distortion are kept only where the data show them: the levels of
:data:`LEVELS` are fitted on a subsample of the frames and the one with the least
Bayesian information criterion ``2 cost + k ln N`` of the whole log (cost from residuals
in units of the noise, the subsample's scaled up to the log's N coordinates: more frames
show finer effects) is fitted on all frames. Marker offsets have a Gaussian prior
(``offset_prior_px``): without them a constant sub-pixel click error turns into a false
tilt. k1 and k2 have a prior that bounds the distortion at the edge of the data
(``distortion_prior_px``).

Outliers and stuck tracks (:mod:`.track_flags`) become gaps and the fit is repeated
without them. Each frame's angles get their sd from the fit's Gauss–Newton covariance:
``*_sd`` the frame's own (random) part, ``*_sd_calibration`` the part the camera and the
marker offsets carry into every frame alike (their Schur complement), both rad.
"""

from __future__ import annotations

import time
from collections.abc import Mapping

import numpy as np
from scipy.optimize import least_squares

from trebuchet.core.errors import TrebuchetInputError, check_choice
from trebuchet.model.scene import Engine

from .block_least_squares import block_least_squares
from .calibration_problem import (
    CalibrationProblem,
    noise_sd,
    start_angles,
    start_flight,
)
from .calibration_result import Calibration, LevelFit, calibration_result
from .camera import Camera, Intrinsics, apply_homography, undistort
from .conic_start import circle_homography
from .engine_points import POINTS
from .plane_map import (
    ALL_LEVELS,
    CAMERA_PARAMETERS,
    FREE_PARAMETERS,
    LEVELS,
    normalised_homography,
    parameters_of,
)
from .shot_frames import circle_centre, frame_roles, trough_frames
from .track_flags import FlaggedTrack, flag_tracks, outlier_limit

__all__ = ["LEVELS", "ALL_LEVELS", "CAMERA_PARAMETERS", "LevelFit", "Calibration", "calibrate",
           "angles_from_calibration"]


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


def _solve(pb: CalibrationProblem, x0: np.ndarray, solver: str = "blocks",
           ftol: float | None = None, max_iter: int = 100):
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
    given = camera if isinstance(camera, Camera) else None
    lens = camera if isinstance(camera, Intrinsics) else None
    centre, radius, k_sd = _distortion_frame(obs, given or lens, image_size,
                                             distortion_prior_px, notes)
    pivot_img = _pivot_pixel(obs, notes)
    roles = frame_roles(obs, n, engine.counterweight_offset is None, pivot_img, g=g, t=t,
                        at_rest=at_rest, in_trough=in_trough, in_sling=in_sling, trough=trough)
    O, use, wt = _observations(obs, w, roles.sling | roles.flight)
    # --- the start: the spigot's ellipse about the pivot (or the user's camera)
    cam0 = _start_camera(obs, use, engine, H, given, lens, centre, radius, pivot_img, notes)
    if levels[-1] in FREE_PARAMETERS:
        cam0[FREE_PARAMETERS[levels[-1]]:8] = 0.0
    vertical = bool(roles.plumb.any() or roles.trough.any() or roles.flight.any())
    if not vertical:
        notes.append("no rest, trough or flight frames: the image's vertical is taken as "
                     "the engine's")
    if given is not None:
        levels = ("given",)
    elif lens is not None:
        levels = tuple(dict.fromkeys(lv.split("+")[0] for lv in levels))  # lens fixed
    L = engine.L1
    pb = CalibrationProblem(
        obs=O, use=use, wt=wt / (noise_px or 1.0),
        lengths=(1.0, engine.L2 / L, engine.L3 / L, engine.L4 / L), h=H / L, centre=centre,
        radius=radius, rest=roles.plumb & use[3], trough=roles.trough, sling=roles.sling,
        flight=roles.flight, tau=roles.tau, g=(g or 0.0) / L, cam0=cam0,
        free=_free_of(levels[-1], vertical),
        offset_points=tuple(p for p in range(1, 5) if use[p].any()),
        sigma=noise_px or 1.0, offset_sd=offset_prior_px, k_sd=k_sd,
        gauge_px=float(cam0[2]), fixed_psi=engine.counterweight_offset)
    pb.ang0 = start_angles(pb, cam0)
    # --- the camera's level, on a subsample; then the trough's frames with that camera
    fits, cam, off, fl = _choose_level(pb, levels, vertical, lens is not None, noise_px is None,
                                       selection_frames, solver)
    best = _pick_level(fits)
    rest = roles.rest
    if trough and in_trough is None and "projectile" in obs and rest.any():
        pb.trough = _trough_with(pb, cam, rest)
    # --- all frames at the chosen level; outliers out, refit
    pb.free, pb.cam0 = _free_of(best.level, vertical), cam
    pb.ang0 = start_angles(pb, cam)
    final = _solve(pb, _x_of(pb, cam, off, fl, pb.ang0), solver)
    final, sigma, flagged, gaps = _flag_and_refit(pb, final, [k for k in POINTS if k in obs],
                                                  noise_px, flag_threshold, solver)
    return calibration_result(pb, final, sigma, engine, H, lens, best, fits, obs, rest,
                              flagged, gaps, notes, start)


def _distortion_frame(obs: dict[str, np.ndarray], camera: Camera | Intrinsics | None,
                      image_size: tuple[float, float] | None, prior_px: float,
                      notes: list[str]) -> tuple[np.ndarray, float, tuple[float, float]]:
    """Distortion centre (px), radius R (px) and the prior sd of k1 and k2 (a displacement
    of ``prior_px`` at the data's furthest radius ρ_max: ``prior_px / (R ρ_max³)``, ``…⁵``).
    From the user's camera or lens, else the picture (centre, R its width), else the
    tracked points' box (a note says so)."""
    pts = np.concatenate([v[np.isfinite(v).all(axis=1)] for v in obs.values()])
    if pts.shape[0] == 0:
        raise TrebuchetInputError("calibrate: no tracked position at all")
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    if camera is not None:
        centre, radius = np.array(camera.centre, float), float(camera.radius)
    elif image_size is not None:
        centre, radius = np.array([image_size[0] / 2, -image_size[1] / 2]), float(image_size[0])
    else:
        centre, radius = 0.5 * (lo + hi), float(np.hypot(*(hi - lo)))
        notes.append("no image size: distortion about the centre of the tracked points")
    rho_max = max(float(np.max(np.hypot(*(pts - centre).T))) / radius, 1e-3)
    return centre, radius, (prior_px / (radius * rho_max ** 3), prior_px / (radius * rho_max ** 5))


def _pivot_pixel(obs: dict[str, np.ndarray], notes: list[str]) -> np.ndarray:
    """The pivot's pixel: the median of its track, or the centre of the spigot's (or
    hinge's) circle when it is not tracked (a note says so)."""
    if "pivot" in obs and np.isfinite(obs["pivot"]).any():
        return np.nanmedian(obs["pivot"], axis=0)
    notes.append("the pivot is not tracked: its pixel starts at the centre of the spigot's "
                 "(or hinge's) circle")
    return circle_centre(obs["spigot" if "spigot" in obs else "hinge"])


def _observations(obs: dict[str, np.ndarray], w: dict[str, np.ndarray],
                  stone: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pixels (5, n, 2) (0 where not used), which are used (5, n) and their weights
    √confidence (5, n); the projectile only on the frames ``stone`` (sling or flight)."""
    n = next(iter(obs.values())).shape[0]
    O, use, wt = np.zeros((5, n, 2)), np.zeros((5, n), bool), np.zeros((5, n))
    for p, name in enumerate(POINTS):
        if name in obs:
            ok = np.isfinite(obs[name]).all(axis=1) & (w[name] > 0)
            if name == "projectile":
                ok &= stone
            O[p] = np.where(ok[:, None], obs[name], 0.0)
            use[p], wt[p] = ok, np.sqrt(w[name])
    return O, use, wt


def _start_camera(obs: dict[str, np.ndarray], use: np.ndarray, engine: Engine, H: float,
                  given: Camera | None, lens: Intrinsics | None, centre: np.ndarray,
                  radius: float, pivot: np.ndarray, notes: list[str]) -> np.ndarray:
    """Starting camera parameters: the user's camera, else the ellipse of the spigot (or
    hinge) about the pivot (:mod:`.conic_start`), else a fronto-parallel camera with the
    arc's median radius as its scale (a note says so)."""
    L = engine.L1
    if given is not None:
        N = np.array([[1 / L, 0.0, 0.0], [0.0, 1 / L, -H / L], [0.0, 0.0, 1.0]])
        cam0 = parameters_of(given.Hm @ np.linalg.inv(N))     # back to X̃ units
        cam0[8:] = given.k1, given.k2
        return cam0
    arc_name, arc_len = ("spigot", 1.0) if "spigot" in obs else ("hinge", engine.L2 / L)
    k1k2 = (lens.k1, lens.k2) if lens else (0.0, 0.0)
    arc = undistort(obs[arc_name][use[POINTS.index(arc_name)]], *k1k2, tuple(centre), radius)
    Hc = circle_homography(arc, pivot)
    cam0 = np.zeros(10)
    if Hc is not None:
        cam0 = parameters_of(Hc @ np.diag([1 / arc_len, 1 / arc_len, 1.0]))
    if Hc is None or np.hypot(cam0[6], cam0[7]) > 0.5 or abs(cam0[4]) > 0.3:
        s0 = float(np.median(np.hypot(*(arc - pivot).T))) / arc_len
        cam0 = np.array([pivot[0], pivot[1], s0, 0, 0, 0, 0, 0, 0, 0])
        notes.append("the spigot's track gives no ellipse about the pivot: started from a "
                     "fronto-parallel camera")
    cam0[8:] = k1k2
    return cam0


def _free_of(level: str, vertical: bool) -> np.ndarray:
    """Indices of the camera parameters a level frees (the turn only with a vertical)."""
    if level == "given":
        return np.zeros(0, int)
    return np.array([i for i in range(FREE_PARAMETERS[level]) if vertical or i != 3], int)


def _x_of(pb: CalibrationProblem, cam: np.ndarray, off: np.ndarray, fl: np.ndarray,
          ang: np.ndarray) -> np.ndarray:
    """The unknowns' vector of ``pb`` (free camera, offsets, flight, angles)."""
    nf = 4 if pb.flight.any() else 0
    if nf and fl.size == 0:
        fl = start_flight(pb, cam)
    return np.concatenate([cam[pb.free], off[list(pb.offset_points)].ravel(), fl[:nf],
                           ang.ravel()])


def _with_sigma(pb: CalibrationProblem, sigma: float) -> None:
    """Put the residuals of ``pb`` in units of the noise sd ``sigma`` (px)."""
    sigma = max(sigma, 1e-3)
    pb.wt = pb.wt * pb.sigma / sigma
    pb.sigma = sigma


def _choose_level(pb: CalibrationProblem, levels: tuple[str, ...], vertical: bool,
                  lens: bool, estimate_noise: bool, selection_frames: int, solver: str
                  ) -> tuple[list[LevelFit], np.ndarray, np.ndarray, np.ndarray]:
    """Fit the levels, simplest first, on at most ``selection_frames`` frames (the richest
    first, for the noise sd when ``estimate_noise``; ``pb`` gets it too); stop after two
    richer levels no better. Returns the fits and the best one's camera, offsets, flight."""
    n = pb.n
    sub = pb.subset(np.arange(0, n, max(1, int(np.ceil(n / selection_frames)))))
    sub.free = _free_of(levels[-1], vertical)
    cam0 = pb.cam0
    top = _solve(sub, _x_of(sub, cam0, np.zeros((5, 2)), np.zeros(0), sub.ang0), solver,
                 SELECTION_FTOL)
    if estimate_noise:
        sigma = noise_sd(sub, top.x)
        _with_sigma(sub, sigma)
        _with_sigma(pb, sigma)
    top_cam, top_off, top_fl, _ = sub.split(top.x)
    n_obs = 2 * int(pb.use.sum())                                # the whole log's N
    per_log = n_obs / (2.0 * max(int(sub.use.sum()), 1))        # its cost per subsample cost
    fits: list[LevelFit] = []
    sols: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    worse = 0
    for level in levels:
        sub.free = _free_of(level, vertical)
        cam = top_cam.copy()
        if level in FREE_PARAMETERS:                             # the rest held at zero
            cam[FREE_PARAMETERS[level]:] = 0.0
            cam[8:] = cam0[8:] if lens else cam[8:]
        sub.cam0 = cam
        if level == levels[-1]:
            x0 = top.x
        else:
            sub.ang0 = start_angles(sub, cam)
            x0 = _x_of(sub, cam, top_off, top_fl, sub.ang0)
        fit = _solve(sub, x0, solver, SELECTION_FTOL, SELECTION_ITERATIONS)
        sols[level] = (fit.x, cam)
        fits.append(LevelFit(level, float(fit.cost), int(sub.free.size),
                             2.0 * per_log * float(fit.cost) + sub.free.size * np.log(n_obs)))
        worse = worse + 1 if fits[-1].bic > _pick_level(fits).bic else 0
        if worse == 2:                                           # two richer models no better
            break
    best = _pick_level(fits)
    sub.free, sub.cam0 = _free_of(best.level, vertical), sols[best.level][1]
    cam, off, fl, _ = sub.split(sols[best.level][0])
    return fits, cam, off, fl


def _trough_with(pb: CalibrationProblem, cam: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """The trough's frames from the projectile's height in the plane (its pixels taken
    back with the camera ``cam``): to the onset of its rise above 5 sd of its rest
    height (at least 3 noise sd)."""
    Hinv = np.linalg.inv(normalised_homography(cam))
    px = undistort(np.where(pb.use[4][:, None], pb.obs[4], np.nan), cam[8], cam[9],
                   tuple(pb.centre), pb.radius)
    y = apply_homography(Hinv, px)[:, 1] + pb.h                  # units of L1, trough at 0
    y_rest = y[rest & np.isfinite(y)]
    level = float(np.median(y_rest)) if y_rest.size else 0.0
    sd = 1.4826 * float(np.median(np.abs(y_rest - level))) if y_rest.size else 0.0
    floor = pb.sigma / cam[2]                                    # one noise sd, units of L1
    return trough_frames(y - level, rest, max(5.0 * sd, 3.0 * floor))


def _flag_and_refit(pb: CalibrationProblem, final, names: list[str], noise_px: float | None,
                    flag_threshold: float, solver: str):
    """Up to :data:`FLAG_ROUNDS` rounds: flag the points to blame (:func:`_culprits`,
    :func:`.track_flags.flag_tracks`), take them out, refit. Returns the fit, the noise sd
    (px), the flagged runs and the gaps per point."""
    sigma = noise_px if noise_px is not None else noise_sd(pb, final.x)
    n = pb.n
    flagged: tuple[FlaggedTrack, ...] = ()
    gaps = {name: np.zeros(n, bool) for name in names}
    for _ in range(FLAG_ROUNDS):
        U = pb.predicted(final.x)
        index = {name: POINTS.index(name) for name in names}
        observed = {k: np.where(pb.use[p][:, None], pb.obs[p], np.nan) for k, p in index.items()}
        predicted = {k: U[p] for k, p in index.items()}
        culprits = _culprits(pb, final.x, outlier_limit(sigma, flag_threshold), solver)
        found, new = flag_tracks(observed, predicted, sigma, threshold=flag_threshold,
                                 culprits={k: culprits[p] for k, p in index.items()})
        if not found:
            break
        flagged += found
        for k, p in index.items():
            pb.use[p] &= ~new[k]
            gaps[k] |= new[k]
        if noise_px is None:
            _with_sigma(pb, sigma)
        final = _solve(pb, final.x, solver)
        if noise_px is None:
            sigma = noise_sd(pb, final.x)
    if noise_px is None:
        sigma = noise_sd(pb, final.x)
    return final, sigma, flagged, gaps


def _culprits(pb: CalibrationProblem, x: np.ndarray, limit: float, solver: str) -> np.ndarray:
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


def angles_from_calibration(points: Mapping[str, np.ndarray], calibration: Calibration | Camera,
                            engine: Engine, *, H: float, **options) -> Calibration:
    """Each frame's angles from all its tracked points with a known camera (one found by
    :func:`calibrate`, or a user's :class:`~.camera.Camera`): the same constrained fit
    with the camera held, the marker offsets and angles fitted. ``options`` as for
    :func:`calibrate`."""
    camera = calibration.camera if isinstance(calibration, Calibration) else calibration
    return calibrate(points, engine, H=H, camera=camera, **options)
