"""Lift-off from the stone's own track: where it leaves the trough.

In phase I the stone slides along the trough (the scene's ground level, ``y = 0`` in the
engine's plane; a straight line in any image of it, lines staying lines under a camera's
perspective). At lift-off the trough's normal force reaches zero; the stone's vertical
acceleration, zero in the trough, then grows from zero, so its height above the trough
rises like ``c (t − t_l)³`` (checked on the simulation: ``y / (t − t_l)³`` stays within
20 % of its value over the first 80 ms, 17 m/s³ for the paper's engine, 27 for the
backyard one, 36 for the small fast one).

:func:`stone_lift_off` fits every tracked stone position from the trigger to a window's
end at once: its distance from a straight line (``a + b s``, ``s`` along the line; the
trough as the camera draws it) plus ``c (t − t_l)³₊`` with ``c ≥ 0``, by least squares for
each candidate ``t_l`` on a frame grid and then at a tenth of a frame
(:func:`~.detection.refined_profile`); the noise scale is profiled out. The profile's
mean and spread are the estimate. A cubic departure is slow: 1 cm in 80 ms on the paper's
engine (a quarter of a pixel at the tilted sample's 26 px/m), so this source is coarse
where the stone is small in the image, and sharp where it is large. It sees the lift-off
directly, where the normal force's zero moves with every angle's common offset (a camera's
roll: on tilted video the normal force put lift-off 4.7 frames late), so it checks the
normal force's lift-off (:func:`~.lift_off.lift_off_choice`): where they disagree, the
lift-off's sd covers both. On the video bench it came 1.6–4 frames early where the normal
force was within half a frame, so it is a check, not a second estimate to average.

Positions in any length unit (y up); times in the log's time (s).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trebuchet.ingest.events.detection import refined_profile

__all__ = ["TroughDeparture", "StoneLiftOff", "stone_lift_off", "departure_sse"]


@dataclass(frozen=True)
class TroughDeparture:
    """Settings of :func:`stone_lift_off`: ``window_s``, the fit's window reaches this far
    (s) past the latest candidate; ``min_frames``: fewest tracked positions in the trough
    and after the departure each; ``subframe_steps``, ``profile_drop``,
    ``max_fine_candidates``: the profile's refinement; ``min_log_ratio``: the
    log-likelihood the departure must gain over none in the window;
    ``systematic_noise``: the sd's floor is the time the fitted cubic takes to rise by
    this many residual sd (a camera model off by a few mm across the trough, as on the
    demo video, moves the departure by more than the profile's spread: there the profile
    said 0.9 frame where the stone was 3.3 frames early; with the floor 5.6 frames; on
    simulated tracks with 0.3 px white noise the errors are within 2.6, 8 and 0.8 frames
    at 240 fps on the paper's, backyard and small fast engines, the floor 7–10 frames, so
    this source counts where the normal force's zero is itself uncertain)."""

    window_s: float = 0.12
    min_frames: int = 6
    subframe_steps: int = 10
    profile_drop: float = 12.0
    max_fine_candidates: int = 80
    min_log_ratio: float = 6.0
    systematic_noise: float = 0.25


@dataclass(frozen=True)
class StoneLiftOff:
    """Result of :func:`stone_lift_off`: ``time`` (s, log time; None: no departure seen in
    the window) and its ``sd`` (s, the profile's spread); ``log_ratio``: the
    log-likelihood the departure gains over none; ``noise``: the residuals' sd (the
    positions' unit)."""

    time: float | None
    sd: float
    log_ratio: float
    noise: float


def _frame_axes(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Coordinates (s, h) of positions ``xy`` (n, 2) along and across their first stretch's
    direction (the trough as drawn): the principal axis of the first third of them."""
    first = xy[: max(3, xy.shape[0] // 3)]
    centred = first - first.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    along = vt[0] if abs(vt[0][0]) >= abs(vt[0][1]) else vt[1]
    if along[0] < 0:
        along = -along
    across = np.array([-along[1], along[0]])
    rel = xy - xy[0]
    return rel @ along, rel @ across


def _departure_fit(t: np.ndarray, s: np.ndarray, h: np.ndarray, t_l: float,
                   q: np.ndarray, h_res: np.ndarray) -> tuple[float, float]:
    """SSE and the cubic's coefficient ``c₃`` (the positions' unit per s³) of the model of
    :func:`departure_sse` for one candidate ``t_l`` (s); ``q``: orthonormal columns of the
    line (1, s), ``h_res``: ``h`` less its projection on them."""
    u = np.maximum(t - t_l, 0.0)
    sse0 = float(h_res @ h_res)
    if not (u > 0).any():
        return sse0, 0.0
    scale = float(u.max())
    cols = np.stack([(u / scale) ** 3, (u / scale) ** 4], axis=1)
    cols = cols - q @ (q.T @ cols)
    coef, *_ = np.linalg.lstsq(cols, h_res, rcond=None)
    if coef[0] < 0:  # the stone rises: c₃ ≥ 0, the quartic alone
        col = cols[:, 1]
        norm = float(col @ col)
        coef = np.array([0.0, float(col @ h_res) / norm if norm > 0 else 0.0])
    r = h_res - cols @ coef
    return min(float(r @ r), sse0), float(coef[0]) / scale**3


def _line(s: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    q, _ = np.linalg.qr(np.stack([np.ones_like(s), s], axis=1))
    return q, h - q @ (q.T @ h)


def departure_sse(t: np.ndarray, s: np.ndarray, h: np.ndarray,
                  candidates: np.ndarray) -> np.ndarray:
    """Sum of squared residuals (C,) of ``h = a + b s + c₃ u³ + c₄ u⁴``, ``u = (t − t_l)₊``
    (``c₃ ≥ 0``: the stone rises), for each candidate lift-off ``t_l`` (s) in
    ``candidates``: ``t`` (n,) s, ``s``, ``h`` (n,) the positions along and across the
    trough. The quartic term takes up the growth of the vertical acceleration's rate away
    from the lift-off (the cubic alone pulled the estimate 4–8 frames late on the small
    engines)."""
    q, h_res = _line(s, h)
    return np.array([_departure_fit(t, s, h, float(c), q, h_res)[0] for c in candidates])


def stone_lift_off(t: np.ndarray, stone: np.ndarray, trigger: float, latest: float,
                   frame: float, settings: TroughDeparture = TroughDeparture()
                   ) -> StoneLiftOff | None:
    """Lift-off (s, log time) from the stone's positions ``stone`` (n, 2, y up, NaN = not
    tracked) at times ``t`` (n,): candidates from the ``trigger`` (s) to ``latest`` (s),
    the fit's window from the trigger to ``latest`` + ``window_s``; see the module doc.
    None when too few positions are tracked there."""
    t = np.asarray(t, dtype=float)
    stone = np.asarray(stone, dtype=float)
    end = latest + settings.window_s
    rows = np.isfinite(stone).all(axis=1) & (t >= trigger) & (t <= end)
    if rows.sum() < 3 * settings.min_frames:
        return None
    tw, xy = t[rows], stone[rows]
    s, h = _frame_axes(xy)
    first = max(trigger + settings.min_frames * frame, float(tw[settings.min_frames - 1]))
    last = min(latest, float(tw[-settings.min_frames]))
    if last <= first:
        return None
    coarse = np.arange(first, last + 0.5 * frame, frame)
    sse = departure_sse(tw, s, h, coarse)
    n = tw.size

    def loglik(times: np.ndarray) -> np.ndarray:
        return -0.5 * n * np.log(np.maximum(departure_sse(tw, s, h, times), 1e-300))

    ll = -0.5 * n * np.log(np.maximum(sse, 1e-300))
    none = -0.5 * n * np.log(max(float(departure_sse(tw, s, h, np.array([end + frame]))[0]),
                                 1e-300))
    noise = float(np.sqrt(sse.min() / max(n - 3, 1)))
    log_ratio = float(ll.max() - none)
    if log_ratio < settings.min_log_ratio:
        return StoneLiftOff(None, float("nan"), log_ratio, noise)
    when, spread, _ = refined_profile(loglik, coarse, ll, frame, settings.profile_drop,
                                      settings.subframe_steps, settings.max_fine_candidates)
    _, c3 = _departure_fit(tw, s, h, when, *_line(s, h))
    rise = settings.systematic_noise * noise
    floor = (rise / c3) ** (1.0 / 3.0) if c3 > 0 else float("inf")
    return StoneLiftOff(when, float(np.hypot(spread, floor)), log_ratio, noise)
