"""Systematic angle errors a log shows against the engine's own geometry.

A tracked angle's error is not only the white noise the smoother models: a tilted or
rolled camera, lens distortion and a marker clicked off its point bias every angle by
0.1–3° (bench/video_accuracy.py: θ at rest 0.06° off on a fronto-parallel camera, 1.1°
with 1° of roll; ψ of the plumb counterweight 0.4° off on the fronto-parallel camera, 2–3.7°
under a 15° tilt), slowly varying with the pose. The smoother averages white noise away,
so its sd of an angle is a few thousandths of a degree and the loads that depend on the
angles themselves (the weights' components: F_R_x through ψ, F_S_y through θ) get bands
that hold the truth 5–60 % of the time. Two things every log with a rest and a scene shows
measure that error without the truth:

- **the rest pose**: before the trigger the engine stands in the scene's start pose (the
  counterweight hangs plumb at ψ = −90°, the beam on its stop at θ₀, the sling at φ₀);
  the median of each angle over the rest rows less that angle is its offset there. Its
  square, less the median's own sampling variance (``π/2 · s² / n`` for ``n`` rows of
  robust sd ``s``), is an unbiased estimate of the squared bias.
- **the segment lengths** (point logs): the beam's arm pivot→spigot (θ), the counterweight's
  arm hinge→counterweight (ψ) and the sling spigot→projectile while it holds the stone (φ)
  have constant lengths. An in-plane linear distortion ``s (I + E)`` (``E`` symmetric,
  traceless, the anisotropic part a pitched camera's foreshortening makes) changes the
  relative length of a segment at angle ``a`` by ``e cos 2(a − a_E)`` and its angle by
  ``−e sin 2(a − a_E)``, and a marker offset ``δ`` fixed in the image changes them by
  ``δ/L cos(a − a_δ)`` and ``δ/L sin(a − a_δ)``: the same amplitude, a quarter period
  apart. So the sd (over the rows) of the segment's relative length, less its median and
  median-filtered over 9 frames against the tracking's white noise, measures the sd of
  the angle's varying error (in rad). A perspective's depth scale (far parts smaller) also
  changes the lengths without turning the angles: the measure errs on the wide side.

The systematic sd of angle ``a`` is ``√(max(b² − var_b, 0) + m²)`` (``b`` the rest offset,
``m`` the length misfit), added to the angle's variance on every row of the smoothed log.
Its rate gets the misfit's own rate where it exceeds the tracking's white noise
(:func:`misfit_rate_sd`: the camera's error moving with the pose, a marker dragged off
its point by a frame member passing in front of it), and its acceleration the excess
power of the misfit's second derivative over the whole track (:func:`misfit_acceleration_sd`:
template matching errs alike on neighbouring frames, which the smoother takes for motion
and its residuals do not show). Measured on bench/video_accuracy.py (20 cells, 2 seeds):
the ±2 sd bands of F_R_x, F_R_y, F_S_x, F_S_y pooled over the paper engine's logs held
the truth 34, 66, 74, 59 % of the time before, 96, 90, 96, 95 % with these terms; white
angle noise (no points, rest pose exact) is left as it was. Units: radians (and rad/s,
rad/s²) throughout.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.ndimage import uniform_filter1d
from scipy.signal import savgol_coeffs, savgol_filter

from trebuchet.ingest.calibrated_angles import widened_by_calibration
from trebuchet.ingest.logs.result import read_log_info
from trebuchet.ingest.smoothing.result import smoothing_of, with_smoothing
from trebuchet.model.scene import Scene

__all__ = ["SystematicAngles", "rest_pose_offsets", "segment_length_misfit",
           "systematic_angles", "with_systematic_angles", "systematic_note", "misfit_rate_sd",
           "misfit_acceleration_sd",
           "relative_length_misfit", "SEGMENTS", "MEDIAN_FRAMES", "RATE_FRAMES"]

ANGLES = ("theta", "psi", "phi")
#: The points whose distance is the constant length of each angle's segment.
SEGMENTS: dict[str, tuple[str, str]] = {"theta": ("pivot", "spigot"),
                                        "psi": ("hinge", "counterweight"),
                                        "phi": ("spigot", "projectile")}
#: Frames of the running median that keeps the slow part of a segment's length misfit.
MEDIAN_FRAMES = 9
#: Frames of the Savitzky–Golay filter (quadratic) that differentiates a length misfit,
#: and of the running mean of its square.
RATE_FRAMES = 15
#: Fewest rest rows (and rows of a segment) that give an estimate.
MIN_ROWS = 5


@dataclass(frozen=True)
class SystematicAngles:
    """Per angle (rad): ``rest_offset`` (median at rest less the scene's start angle; NaN
    without rest rows), ``rest_offset_sd`` (that median's sampling sd), ``length_misfit``
    (sd of the segment's slow relative length error; NaN without points), ``sd``, the
    systematic sd added to the angle, and ``rate_sd`` (rad/s, one per row of the log),
    that added to its rate (:func:`misfit_rate_sd`)."""

    rest_offset: dict[str, float] = field(default_factory=dict)
    rest_offset_sd: dict[str, float] = field(default_factory=dict)
    length_misfit: dict[str, float] = field(default_factory=dict)
    sd: dict[str, float] = field(default_factory=dict)
    rate_sd: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    acc_sd: dict[str, float] = field(default_factory=dict)


def start_angles(scene: Scene) -> dict[str, float]:
    """The scene's start pose (rad): the angles the engine rests in before the trigger."""
    return {"theta": scene.start.theta, "psi": scene.start.psi, "phi": scene.start.phi}


def rest_pose_offsets(t: np.ndarray, angles: dict[str, np.ndarray], trigger: float | None,
                      scene: Scene) -> tuple[dict[str, float], dict[str, float]]:
    """Each angle's offset (rad) at rest from the scene's start pose, and the sd (rad) of
    that median: ``1.2533 · s / √n`` with ``s`` the angle's robust sd (1.4826 MAD) over
    the ``n`` rows before ``trigger`` (s). NaN for an angle with fewer than ``MIN_ROWS``
    rest rows, or without a trigger."""
    start = start_angles(scene)
    offset: dict[str, float] = {}
    offset_sd: dict[str, float] = {}
    for name in ANGLES:
        z = np.asarray(angles[name], float)
        rest = z[(t < trigger) & np.isfinite(z)] if trigger is not None else z[:0]
        if rest.size < MIN_ROWS:
            offset[name], offset_sd[name] = float("nan"), float("nan")
            continue
        med = float(np.median(rest))
        # the start angle on the branch of the log's value (angles are unwrapped)
        a0 = start[name] + 2 * np.pi * np.round((med - start[name]) / (2 * np.pi))
        offset[name] = med - a0
        s = 1.4826 * float(np.median(np.abs(rest - med)))
        offset_sd[name] = 1.2533 * s / np.sqrt(rest.size)
    return offset, offset_sd


def relative_length_misfit(points: pd.DataFrame, rows: dict[str, np.ndarray]
                           ) -> dict[str, np.ndarray]:
    """Per angle (one per row): its segment's length over ``rows[angle]`` (bool) relative
    to its median, less 1 (NaN elsewhere, and for every row where a point is missing or
    fewer than ``MIN_ROWS`` rows have both points)."""
    out: dict[str, np.ndarray] = {}
    n = len(points)
    for name, (p, q) in SEGMENTS.items():
        cols = [p + "_x", p + "_y", q + "_x", q + "_y"]
        if any(c not in points for c in cols):
            out[name] = np.full(n, np.nan)
            continue
        length = np.hypot(points[q + "_x"].to_numpy(float) - points[p + "_x"].to_numpy(float),
                          points[q + "_y"].to_numpy(float) - points[p + "_y"].to_numpy(float))
        length = np.where(rows[name], length, np.nan)
        if np.sum(np.isfinite(length)) < MIN_ROWS:
            out[name] = np.full(n, np.nan)
            continue
        out[name] = length / np.nanmedian(length) - 1.0
    return out


def white_variance(rel: np.ndarray) -> float:
    """The white (frame-to-frame independent) variance of a series ``rel`` (NaN = not
    seen): half the robust variance (1.4826 MAD, squared) of its differences between
    consecutive present values; 0 with fewer than ``MIN_ROWS`` values."""
    ok = np.isfinite(rel)
    if ok.sum() < MIN_ROWS:
        return 0.0
    steps = np.diff(rel[ok])
    return (1.4826 * float(np.median(np.abs(steps - np.median(steps))))) ** 2 / 2.0


def segment_length_misfit(rel: np.ndarray) -> float:
    """The sd (rad) of the slow part of a relative length misfit ``rel`` (one per row,
    NaN = not seen): running-median filtered over ``MEDIAN_FRAMES`` frames, its variance
    less what the tracking's white noise leaves in such a median (``π / (2 n)`` of the
    white variance, :func:`white_variance`, for ``n`` frames); the sd of the angle's
    varying systematic error (the module doc). NaN with fewer than ``MIN_ROWS`` values."""
    if np.sum(np.isfinite(rel)) < MIN_ROWS:
        return float("nan")
    slow = pd.Series(rel).rolling(MEDIAN_FRAMES, center=True, min_periods=3).median()
    var = float(np.nanvar(slow.to_numpy())) - np.pi / (2 * MEDIAN_FRAMES) * white_variance(rel)
    return float(np.sqrt(max(var, 0.0)))


def misfit_rate_sd(t: np.ndarray, rel: np.ndarray, order: int = 1) -> np.ndarray:
    """The rate (rad/s, one per row; ``order`` 2: the acceleration, rad/s²) of an angle's
    varying systematic error, from its segment's relative length misfit ``rel`` (NaN
    where the segment is not seen) on the rows' times ``t`` (s). The angle's error moves
    as its segment's length does (the module doc), whether from the camera (``2 e ȧ``)
    or a marker dragged off its point for a few frames by something passing in front of
    it. The misfit's derivative of that order (a quadratic Savitzky–Golay filter of
    ``RATE_FRAMES`` frames through the gaps, linearly filled) is squared and averaged
    over ``RATE_FRAMES`` frames; the tracking's white noise (variance ``w``,
    :func:`white_variance`) puts ``w Σ c²`` into that mean (``c`` the filter's
    coefficients) and makes it scatter by ``√(2 Σ_k (W − |k|) γ_k²) / W`` (``γ_k =
    w Σ_i c_i c_{i+k}`` the filtered noise's autocovariance, ``W`` frames). What exceeds
    the noise's share by more than twice that scatter counts (its root is returned);
    elsewhere 0: a clipped estimate of a zero would otherwise leave half the noise's
    scatter as a bias. 0 outside the segment's rows."""
    ok = np.isfinite(rel)
    out = np.zeros(rel.size)
    if ok.sum() < max(RATE_FRAMES, MIN_ROWS) or t.size < RATE_FRAMES:
        return out
    idx = np.arange(rel.size)
    filled = np.interp(idx, idx[ok], rel[ok])
    dt = float(np.median(np.diff(t)))
    slope = savgol_filter(filled, RATE_FRAMES, 2, deriv=order, delta=dt)
    c = savgol_coeffs(RATE_FRAMES, 2, deriv=order, delta=dt)
    w = white_variance(rel)
    gamma = w * np.correlate(c, c, mode="full")  # lags −(F−1) … F−1
    lags = np.arange(-(c.size - 1), c.size)
    near = np.abs(lags) < RATE_FRAMES
    scatter = np.sqrt(2.0 * np.sum((RATE_FRAMES - np.abs(lags[near])) * gamma[near] ** 2)) \
        / RATE_FRAMES
    excess = uniform_filter1d(slope**2, RATE_FRAMES, mode="nearest") - w * float(np.sum(c * c))
    inside = np.zeros(rel.size, bool)
    inside[idx[ok][0]:idx[ok][-1] + 1] = True
    seen = inside & (excess > 2.0 * scatter)
    return np.where(seen, np.sqrt(np.clip(excess, 0.0, None)), 0.0)


def misfit_acceleration_sd(t: np.ndarray, rel: np.ndarray) -> float:
    """The acceleration (rad/s²) of an angle's error that the tracking's correlated noise
    makes, one sd over the whole track, from its segment's relative length misfit
    ``rel`` (NaN where not seen) on the rows' times ``t`` (s). Template matching errs
    alike on neighbouring frames (on the video bench the error's lag-1 autocorrelation is
    0.5–0.9 after a 31-frame high-pass, against 0 for white noise); the smoother follows
    such an error as motion, so its residuals do not show it (their lag-1
    autocorrelation is −0.3–0.2) and its sd of the accelerations counts only the white
    part. The misfit shows it: the mean square of its second derivative (the quadratic
    Savitzky–Golay filter of ``RATE_FRAMES`` frames) over the track exceeds what white
    noise of the misfit's white variance ``w`` (:func:`white_variance`) puts there,
    ``w Σ c²``. The excess counts only beyond twice its sd under white noise (the mean's
    scatter, as in :func:`misfit_rate_sd`, and ``w``'s own: a robust variance from ``m``
    differences has a relative sd of about ``2.3 / √m``); 0 otherwise. One value for
    the whole track: a frame-by-frame estimate is dominated by the noise it is to exceed."""
    ok = np.isfinite(rel)
    if ok.sum() < 3 * RATE_FRAMES or t.size < RATE_FRAMES:
        return 0.0
    idx = np.arange(rel.size)
    inside = slice(idx[ok][0], idx[ok][-1] + 1)
    filled = np.interp(idx, idx[ok], rel[ok])[inside]
    dt = float(np.median(np.diff(t)))
    curvature = savgol_filter(filled, RATE_FRAMES, 2, deriv=2, delta=dt)
    c = savgol_coeffs(RATE_FRAMES, 2, deriv=2, delta=dt)
    w = white_variance(rel)
    n = filled.size
    gamma = w * np.correlate(c, c, mode="full")
    lags = np.abs(np.arange(-(c.size - 1), c.size))
    scatter = np.sqrt(2.0 * np.sum((n - lags) * gamma**2)) / n
    white = w * float(np.sum(c * c))
    excess = float(np.mean(curvature**2)) - white
    doubt = np.hypot(scatter, white * 2.3 / np.sqrt(ok.sum() - 1))
    return float(np.sqrt(excess)) if excess > 2.0 * doubt else 0.0


def systematic_angles(log: pd.DataFrame, scene: Scene, trigger: float | None,
                      release: float | None, lengths: bool = True,
                      points: pd.DataFrame | None = None) -> SystematicAngles:
    """The systematic sd of each angle of ``log`` (``t`` s; θ, ψ, φ rad; the points of a
    point log in its ``read_log`` info) from its rest pose before ``trigger`` and, for a
    point log with ``lengths``, its segments' lengths (the sling's up to ``release``; s,
    log time). ``points`` (``t``, ``<role>_x``, ``<role>_y``) stand in for the file's: the
    points in the engine's plane the angles of a calibrated image come from
    (:func:`~.calibrated_angles.plane_points`), whose lengths measure what the camera
    found leaves; ``lengths=False`` measures no lengths."""
    t = log["t"].to_numpy(float)
    angles = {a: log[a].to_numpy(float) for a in ANGLES}
    offset, offset_sd = rest_pose_offsets(t, angles, trigger, scene)
    info = read_log_info(log)
    misfit = {a: float("nan") for a in ANGLES}
    rate_sd = {a: np.zeros(t.size) for a in ANGLES}
    acc_sd = {a: 0.0 for a in ANGLES}
    if points is None and info is not None and info.points is not None:
        points = pd.DataFrame(dict(info.points))
    if lengths and points is not None:
        if len(points) == len(log):
            held = t < release if release is not None else np.ones(t.size, bool)
            every = np.ones(t.size, bool)
            rel = relative_length_misfit(points, {"theta": every, "psi": every, "phi": held})
            misfit = {a: segment_length_misfit(r) for a, r in rel.items()}
            rate_sd = {a: misfit_rate_sd(t, r) for a, r in rel.items()}
            acc_sd = {a: misfit_acceleration_sd(t, r) for a, r in rel.items()}
    sd = {}
    for a in ANGLES:
        bias2 = max(offset[a] ** 2 - offset_sd[a] ** 2, 0.0) if np.isfinite(offset[a]) else 0.0
        m2 = misfit[a] ** 2 if np.isfinite(misfit[a]) else 0.0
        sd[a] = float(np.sqrt(bias2 + m2))
    return SystematicAngles(offset, offset_sd, misfit, sd, rate_sd, acc_sd)


def with_systematic_angles(est: pd.DataFrame, found: SystematicAngles) -> pd.DataFrame:
    """A copy of the smoothed log ``est`` (:func:`~.smoothing.smooth.smooth`'s output)
    whose angles carry the systematic sd ``found.sd`` too, their rates ``found.rate_sd``
    and their accelerations ``found.acc_sd``: added in quadrature to ``X_sd``,
    ``X_d_sd``, ``X_dd_sd`` and to the diagonal of the smoothing's covariance on every
    row; a note (:func:`systematic_note`) says so."""
    n = len(est)
    out = widened_by_calibration(est, {a: np.full(n, s) for a, s in found.sd.items()})
    fit = smoothing_of(out)
    cov = dict(fit.cov)
    for a, rate_sd in found.rate_sd.items():
        if a not in cov or not np.any(rate_sd > 0):
            continue
        c = np.array(cov[a], dtype=float, copy=True)
        c[:, 1, 1] += rate_sd**2
        cov[a] = c
        out[a + "_d_sd"] = np.sqrt(est[a + "_d_sd"].to_numpy(float) ** 2 + rate_sd**2)
    for a, acc_sd in found.acc_sd.items():
        if a not in cov or not acc_sd > 0:
            continue
        c = np.array(cov[a], dtype=float, copy=True)
        c[:, 2, 2] += acc_sd**2
        cov[a] = c
        out[a + "_dd_sd"] = np.sqrt(est[a + "_dd_sd"].to_numpy(float) ** 2 + acc_sd**2)
    return with_smoothing(out, fit.replace(cov=cov).noted(systematic_note(found)))


def systematic_note(found: SystematicAngles) -> str | None:
    """A sentence stating the angles' systematic sd (°) and whence; None if all are 0."""
    if not any(v > 0 for v in found.sd.values()):
        return None
    parts = ", ".join(f"{a} {np.degrees(v):.2g}°" for a, v in found.sd.items() if v > 0)
    return (f"the angles carry a systematic sd ({parts}) measured from the rest pose against "
            "the scene's start pose and, for tracked points, the segments' length misfit; "
            "the loads' bands include it")
