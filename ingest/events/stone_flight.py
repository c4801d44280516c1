"""The release from the tracked stone: on its sling's circle before, in free flight after.

At the release the stone and the sling's end share position and velocity; afterwards the
stone flies on a parabola under gravity alone while the sling's end goes its own way. Its
distance from the spigot minus L4 then grows only like ½·a_rel·(t − t_r)² (a_rel = T/m,
the sling's pull per mass just before), so a threshold on that distance
(:mod:`~trebuchet.ingest.geometry.sling_circle`) waits 20–30 ms at the paper engine's pixel
scale, and a tracker often loses the flying stone before then. Here every tracked
position around the end of the stone's track is fitted at once by a change-point model
(positions in the log's own length unit, y up, times in s):

- the spigot ``S(t)``: a cubic in ``τ = t − t_r`` plus ``½ Δa τ₊²`` per coordinate (its
  acceleration jumps at the release, phase II → III);
- before ``t_r`` the stone on its sling's circle, ``X = S + R(τ) (cos φ, sin φ)``, with
  ``φ(τ)`` a cubic and ``R(τ) = R₀ + R₁ τ`` (a slow drift absorbs a camera's
  foreshortening across the sweep);
- after ``t_r`` a ballistic parabola ``X = X(t_r) + V(t_r) τ + ½ g τ²`` with the scene's
  ``g`` (in the log's length unit, ``g_image``) whose position and velocity at ``t_r`` are
  those of the circle: no free parameter of its own, so the flight's first frames pin
  ``t_r``.

The misfit of each candidate ``t_r`` (a Cauchy loss, so a tracker's wrong match on the last
frames does not count) gives a profile likelihood, the noise scale profiled out from the
residuals of the best candidate; it is evaluated on a frame grid and then at a tenth of a
frame (:func:`~trebuchet.ingest.events.detection.refined_profile`), whose mean and spread
are the estimate. Against "no release in the window" (every frame on the circle) the
release must gain ``min_log_ratio``; else the stone was not seen in flight.

Measured on the video bench's cells (``bench/video_accuracy.py``: paper and backyard
engines; base, tilt 5/10/15°, roll 1°, 120 fps, the issue's scenario; seeds 0, 1; 28
logs): every release seen in flight, within 0.71 frame of the truth (RMS 0.32, mean
+0.23, growing with the camera's tilt), where the profile's own spread is 0.001–0.1
frame: the tracker's errors are not white noise (the template's offset drifts as the
sling line leaves the stone). The spread also
leaves out the error of the spigot's own fit, whose velocity at ``t_r`` carries the
flight: with 0.2 px of white noise on every point and 6 frames of flight the estimates
scatter by 0.37 frame where the profile says 0.15 (0.15 and 0.15 with an exact spigot;
no noise: within 0.03 frame). So the sd a caller states needs a floor
(:mod:`.release_sources` adds half a frame). The windows are set in time (a cubic sling
angle over 0.1 s): at 60 fps they hold too few frames and the fit declines (None); with
windows of 12 + 8 frames there it took the misfit of a cubic over a third of the backyard
engine's swing for a flight, 2 frames early.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.events.detection import refined_profile
from trebuchet.model.scene import Scene

__all__ = ["StoneFlightFit", "StoneRelease", "stone_release", "release_misfit", "cauchy_loss",
           "cauchy_least_squares", "points_stone_release"]


@dataclass(frozen=True)
class StoneFlightFit:
    """Settings of :func:`stone_release`.

    ``max_flight_s``: candidates reach this far (s, at least ``min_flight_frames``
    frames) back from the end of the search (the release is sought in the last frames of
    the stone's sling track); ``pre_window_s``: the circle's part of the fit reaches this
    far (s, at least ``min_pre_frames`` frames) before the earliest candidate;
    ``phi_degree``: degree of the sling angle's polynomial; ``outlier_scale``: the Cauchy
    loss's scale in residual sd;
    ``start_scale_m``: the first pass's loss scale (m on the engine, converted by the
    log's scale); ``subframe_steps``, ``profile_drop``, ``max_fine_candidates``: the
    profile's refinement (:func:`~.detection.refined_profile`); ``min_log_ratio``: the
    log-likelihood a release must gain over none in the window.
    """

    max_flight_s: float = 0.05
    min_flight_frames: int = 3
    pre_window_s: float = 0.05
    min_pre_frames: int = 8
    phi_degree: int = 3
    outlier_scale: float = 3.0
    start_scale_m: float = 0.01
    subframe_steps: int = 10
    profile_drop: float = 12.0
    max_fine_candidates: int = 80
    min_log_ratio: float = 6.0

    def __post_init__(self) -> None:
        if (not self.max_flight_s > 0 or self.min_flight_frames < 2
                or self.min_pre_frames < self.phi_degree + 3
                or not self.pre_window_s > 0 or not self.outlier_scale > 0
                or not self.start_scale_m > 0 or self.subframe_steps < 1):
            raise TrebuchetInputError(
                "StoneFlightFit: max_flight_s must be positive, min_flight_frames ≥ 2, "
                "min_pre_frames > phi_degree + 2, pre_window_s, outlier_scale and "
                "start_scale_m positive and subframe_steps ≥ 1")


@dataclass(frozen=True)
class StoneRelease:
    """Result of :func:`stone_release`: ``time`` (s, log time; None: the stone was not seen
    to leave its circle in the window) and its ``sd`` (s, the profile's spread: see the
    module doc for its floor); ``noise``: the
    residuals' robust sd (the log's length unit); ``log_ratio``: the log-likelihood the
    release gains over none in the window; ``flight_frames``: frames with the stone tracked
    after the release; ``last_on_circle``: time (s) of the last tracked stone position of
    the window (with ``time`` None, the release comes after it); ``how``: a phrase."""

    time: float | None
    sd: float
    noise: float
    log_ratio: float
    flight_frames: int
    last_on_circle: float
    how: str


def _spigot_basis(tau: np.ndarray) -> np.ndarray:
    """Columns of the spigot's path: 1, τ, τ², τ³ and τ₊² (its acceleration's jump)."""
    return np.stack([np.ones_like(tau), tau, tau**2, tau**3, np.maximum(tau, 0.0) ** 2], 1)


def release_misfit(t: np.ndarray, spigot: np.ndarray, stone: np.ndarray, g_image: np.ndarray,
                   t_r: float, loss_scale: float, degree: int = 3,
                   start: np.ndarray | None = None) -> tuple[float, np.ndarray, np.ndarray]:
    """The change-point model of the module doc fitted for a release at ``t_r`` (s).

    ``t`` (n,) s; ``spigot``, ``stone`` (n, 2) positions (NaN = not tracked); ``g_image``
    (2,) gravity's acceleration in the positions' unit per s²; ``loss_scale``: the Cauchy
    loss's scale (the positions' unit); ``start``: parameters to start from (φ's
    coefficients, R₀, R₁). Returns the loss (``Σ s² log(1 + r²/s²)``, the positions' unit
    squared), the residuals (m,) and the parameters.
    """
    tau = np.asarray(t, dtype=float) - t_r
    basis = _spigot_basis(tau)
    ok_s = np.isfinite(spigot).all(axis=1)
    coef, *_ = np.linalg.lstsq(basis[ok_s], spigot[ok_s], rcond=None)
    s_fit = basis @ coef
    s0, s1 = coef[0], coef[1]  # spigot position and velocity at t_r
    ok = np.isfinite(stone).all(axis=1)
    before, after = ok & (tau <= 0.0), ok & (tau > 0.0)
    tb, ta = tau[before], tau[after]
    powers = np.stack([tb**j for j in range(degree + 1)])
    if start is None:
        d = stone[before] - s_fit[before]
        angle = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
        start = np.concatenate([np.polyfit(tb, angle, degree)[::-1],
                                [float(np.median(np.hypot(d[:, 0], d[:, 1]))), 0.0]])

    n_par = degree + 3

    def parts(p: np.ndarray) -> tuple:
        c, r0, r1 = p[:degree + 1], p[degree + 1], p[degree + 2]
        phi = c @ powers
        radial = np.stack([np.cos(phi), np.sin(phi)], axis=1)
        u = np.array([np.cos(c[0]), np.sin(c[0])])
        u_perp = np.array([-u[1], u[0]])
        return c, r0, r1, radial, u, u_perp

    def residuals(p: np.ndarray) -> np.ndarray:
        c, r0, r1, radial, u, u_perp = parts(p)
        on_circle = s_fit[before] + (r0 + r1 * tb)[:, None] * radial
        x_r = s0 + r0 * u
        v_r = s1 + r0 * c[1] * u_perp + r1 * u
        flying = x_r + np.outer(ta, v_r) + 0.5 * np.outer(ta**2, g_image)
        return np.concatenate([(stone[before] - on_circle).ravel(),
                               (stone[after] - flying).ravel()])

    def jacobian(p: np.ndarray) -> np.ndarray:
        c, r0, r1, radial, u, u_perp = parts(p)
        jb = np.zeros((tb.size, 2, n_par))
        tangent = (r0 + r1 * tb)[:, None] * np.stack([-radial[:, 1], radial[:, 0]], axis=1)
        jb[:, :, :degree + 1] = tangent[:, :, None] * powers.T[:, None, :]
        jb[:, :, degree + 1] = radial
        jb[:, :, degree + 2] = tb[:, None] * radial
        ja = np.zeros((ta.size, 2, n_par))
        ja[:, :, 0] = r0 * u_perp + np.outer(ta, r1 * u_perp - r0 * c[1] * u)
        if degree >= 1:
            ja[:, :, 1] = np.outer(ta, r0 * u_perp)
        ja[:, :, degree + 1] = u + np.outer(ta, c[1] * u_perp)
        ja[:, :, degree + 2] = np.outer(ta, u)
        return -np.concatenate([jb.reshape(-1, n_par), ja.reshape(-1, n_par)])

    params, res = cauchy_least_squares(residuals, jacobian, np.asarray(start, dtype=float),
                                       loss_scale)
    return cauchy_loss(res, loss_scale), res, params


def cauchy_loss(residuals: np.ndarray, scale: float) -> float:
    """``Σ s² log(1 + r²/s²)`` (units of the residuals squared): about ``Σ r²`` for
    residuals well inside ``scale``, growing only logarithmically beyond it."""
    return float(scale**2 * np.sum(np.log1p((residuals / scale) ** 2)))


def cauchy_least_squares(residuals, jacobian, start: np.ndarray, scale: float,
                         max_iterations: int = 20, tolerance: float = 1e-7
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Minimise :func:`cauchy_loss` of ``residuals(p)`` by iteratively reweighted
    Gauss–Newton (weights ``1 / (1 + r²/s²)``, a majoriser of the loss, each step halved
    until the loss falls). Returns the parameters and their residuals. Much faster than
    ``scipy.optimize.least_squares(loss="cauchy")`` on these few-parameter fits, which a
    profile over candidate times repeats a hundred times."""
    p = start.copy()
    r = residuals(p)
    loss = cauchy_loss(r, scale)
    for _ in range(max_iterations):
        w = 1.0 / (1.0 + (r / scale) ** 2)
        jac = jacobian(p)
        jw = jac * w[:, None]
        normal = jac.T @ jw
        normal[np.diag_indices_from(normal)] *= 1.0 + 1e-9
        try:
            step = -np.linalg.solve(normal, jw.T @ r)
        except np.linalg.LinAlgError:
            break
        for _ in range(20):
            trial = p + step
            r_trial = residuals(trial)
            loss_trial = cauchy_loss(r_trial, scale)
            if loss_trial <= loss:
                break
            step = 0.5 * step
        else:
            break
        p, r, done = trial, r_trial, loss - loss_trial <= tolerance * max(loss, 1e-300)
        loss = loss_trial
        if done:
            break
    return p, r


def stone_release(t: np.ndarray, spigot: np.ndarray, stone: np.ndarray, g_image: np.ndarray,
                  scale: float, until: float,
                  settings: StoneFlightFit = StoneFlightFit()) -> StoneRelease | None:
    """The release (s, log time) from the stone's positions around the end of its sling
    track; see the module doc.

    ``t`` (n,) s increasing; ``spigot``, ``stone`` (n, 2) positions in the log's length
    unit, y up (NaN = not tracked); ``g_image`` (2,) gravity's acceleration in that unit
    per s² (``(0, −g·scale)`` for an image whose axes are the engine's); ``scale``: the
    log's length unit per m (to set the first loss scale); ``until`` (s): the end of the
    search (the sling track's last frame, or where the stone is seen far off its circle):
    candidates lie within ``max_flight_s`` before it, the fit's data reach as far after
    it. None when too few positions are tracked there.
    """
    t = np.asarray(t, dtype=float)
    spigot, stone = np.asarray(spigot, dtype=float), np.asarray(stone, dtype=float)
    if t.size < 3:
        return None
    dt = float(np.median(np.diff(t)))
    k = max(settings.min_flight_frames, int(round(settings.max_flight_s / dt)))
    pre = max(settings.min_pre_frames, int(round(settings.pre_window_s / dt)))
    tracked = np.isfinite(stone).all(axis=1) & np.isfinite(spigot).all(axis=1)
    rows = tracked & (t >= until - (k + pre + 0.5) * dt) & (t <= until + (k + 0.5) * dt)
    if rows.sum() < pre + settings.phi_degree + 3:
        return None
    tw, sw, xw = t[rows], spigot[rows], stone[rows]
    last = float(tw[-1])
    first_candidate = max(until - k * dt, float(tw[settings.min_pre_frames - 1]))
    if first_candidate >= last:
        return None
    coarse = np.arange(first_candidate, last + 0.5 * dt, dt)
    coarse = np.append(coarse, last + 0.5 * dt)  # the last: no release in the window
    degree = settings.phi_degree

    def losses(times: np.ndarray, loss_scale: float) -> np.ndarray:
        out, start = np.empty(times.size), None
        for i, tr in enumerate(times):
            out[i], _, start = release_misfit(tw, sw, xw, g_image, float(tr), loss_scale,
                                              degree, start)
        return out

    loss_scale = settings.start_scale_m * scale
    noise = loss_scale
    for _ in range(2):  # the loss scale from the residuals of the best candidate
        cost = losses(coarse, loss_scale)
        best = float(coarse[int(np.argmin(cost))])
        _, res, _ = release_misfit(tw, sw, xw, g_image, best, loss_scale, degree)
        noise = max(1.4826 * float(np.median(np.abs(res))), 1e-9 * scale)
        loss_scale = settings.outlier_scale * noise
    coarse_ll = -0.5 * cost / noise**2

    def loglik(times: np.ndarray) -> np.ndarray:
        return -0.5 * losses(times, loss_scale) / noise**2

    when, spread, best_ll = refined_profile(loglik, coarse[:-1], coarse_ll[:-1], dt,
                                            settings.profile_drop, settings.subframe_steps,
                                            settings.max_fine_candidates)
    log_ratio = float(max(best_ll, coarse_ll[:-1].max()) - coarse_ll[-1])
    flight = int(np.sum(tw > when))
    if log_ratio < settings.min_log_ratio or flight < 1:
        return StoneRelease(None, float("nan"), noise, log_ratio, 0, last,
                            "the stone stays on its sling's circle to the end of its track")
    return StoneRelease(when, spread, noise, log_ratio, flight, last,
                        f"the tracked stone leaves its sling's circle for free flight "
                        f"({flight} frames of flight fitted)")


def points_stone_release(points: Mapping[str, np.ndarray], scene: Scene, until: float,
                         settings: StoneFlightFit = StoneFlightFit()) -> StoneRelease | None:
    """:func:`stone_release` on a point log's positions (``read_log``'s
    ``ReadLog.points``: ``t`` s and ``<role>_x``, ``<role>_y`` in the file's length unit,
    y up): the scale (unit per m) from the spigot's distance to the pivot (the beam's
    L1), gravity ``(0, −g·scale)``. None without a tracked pivot, spigot and projectile."""
    needed = [f"{r}_{a}" for r in ("pivot", "spigot", "projectile") for a in ("x", "y")]
    if points is None or "t" not in points or any(k not in points for k in needed):
        return None
    xy = {r: np.stack([np.asarray(points[f"{r}_x"], dtype=float),
                       np.asarray(points[f"{r}_y"], dtype=float)], axis=1)
          for r in ("pivot", "spigot", "projectile")}
    with np.errstate(invalid="ignore"):
        beam = np.hypot(*(xy["spigot"] - np.nanmedian(xy["pivot"], axis=0)).T)
    if not np.isfinite(beam).any():
        return None
    scale = float(np.nanmedian(beam)) / scene.engine.L1
    if not scale > 0:
        return None
    g_image = np.array([0.0, -scene.g * scale])
    return stone_release(np.asarray(points["t"], dtype=float), xy["spigot"], xy["projectile"],
                         g_image, scale, until, settings)
