"""Lift-off from the data: where the reconstructed trough normal force reaches zero.

In phase I the projectile is dragged in the trough; the trough pushes up with
``F_N = m g − F_S·e_y`` (N, :func:`trebuchet.model.forces.trough_normal_force`). Lift-off
is its first zero after the trigger (docs/background.md: the accelerations are continuous there, so
the loads are too). Times in the log's time (s).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trebuchet.ingest.events.release_sources import covering_sd, scene_covering_sd

__all__ = ["lift_off_time", "lift_off_sd", "rest_offset", "offset_widened_sd",
           "LiftOffChoice", "lift_off_choice", "gap_widened_sd", "timing_widened_sd",
           "GAP_WINDOW_S"]


def lift_off_time(t: np.ndarray, normal_force: np.ndarray, trigger: float | None,
                  release: float | None, hold_s: float = 0.02) -> float | None:
    """Log time (s) where ``normal_force`` (N, phase-I formula on every row) first falls
    through zero after ``trigger`` and stays at or below zero for ``hold_s`` s (at least
    three frames), linearly interpolated between frames; None if it never does before
    ``release``."""
    t = np.asarray(t, dtype=float)
    fn = np.asarray(normal_force, dtype=float)
    lo = t[0] - 1.0 if trigger is None else trigger
    hi = t[-1] + 1.0 if release is None else release
    inside = np.flatnonzero((t > lo) & (t <= hi) & np.isfinite(fn))
    if inside.size < 2:
        return None
    dt = float(np.median(np.diff(t)))
    hold = max(3, int(np.ceil(hold_s / dt)))
    below = fn[inside] <= 0.0
    for k in np.flatnonzero(below):
        if k == 0:
            continue
        run = below[k:k + hold]
        if run.all() and (k + hold <= below.size or t[inside[-1]] >= hi - dt):
            i0, i1 = inside[k - 1], inside[k]
            f0, f1 = fn[i0], fn[i1]
            frac = f0 / (f0 - f1) if f0 != f1 else 0.0
            return float(t[i0] + frac * (t[i1] - t[i0]))
    return None


def lift_off_sd(t: np.ndarray, normal_force: np.ndarray, normal_force_sd: np.ndarray,
                lift_off: float) -> float:
    """sd (s) of the lift-off time: the normal force's sd (N) at the crossing divided by
    its rate of fall (N/s), from the frames on either side of it."""
    t = np.asarray(t, dtype=float)
    i = int(np.clip(np.searchsorted(t, lift_off), 1, t.size - 1))
    slope = (normal_force[i] - normal_force[i - 1]) / (t[i] - t[i - 1])
    sd = 0.5 * (normal_force_sd[i] + normal_force_sd[i - 1])
    if not (np.isfinite(slope) and np.isfinite(sd)) or slope == 0.0:
        return float("nan")
    return float(abs(sd / slope))


def rest_offset(t: np.ndarray, theta: np.ndarray, trigger: float | None,
                start_theta: float, min_rows: int = 3) -> float:
    """The beam's angle at rest in the log minus the scene's start angle (rad): the median
    of ``theta`` (rad) on the rows at or before ``trigger`` (s) less ``start_theta``
    (rad). A camera's roll (or its tilt, or a marker clicked off the beam's line) adds
    about this much to every angle the log reads; NaN without ``min_rows`` rest rows."""
    if trigger is None:
        return float("nan")
    rest = (np.asarray(t, dtype=float) <= trigger) & np.isfinite(theta)
    if rest.sum() < min_rows:
        return float("nan")
    return float(np.median(np.asarray(theta, dtype=float)[rest]) - start_theta)


def offset_widened_sd(sd: float, lift_off: float, shifted: float | None) -> float:
    """The lift-off's sd (s) widened by the shift of the lift-off (s) found with every
    angle moved by the log's :func:`rest_offset` (``shifted``, s; None: none found, then
    ``sd`` stands): the normal force's zero moves with the angles' common offset, which
    the smoother's sd does not hold (on the video bench a 1° camera roll moved lift-off
    by 2–3 frames where its sd said 0.4)."""
    if shifted is None or not np.isfinite(shifted):
        return sd
    return float(np.hypot(sd, shifted - lift_off)) if np.isfinite(sd) else abs(shifted - lift_off)


@dataclass(frozen=True)
class LiftOffChoice:
    """The lift-off taken: ``time`` (s, log time) and ``sd`` (s), ``source`` (a phrase),
    ``note`` (a sentence, or None) and ``warning`` (a sentence to warn, or None: the
    normal force's zero and the stone's departure from the trough disagree)."""

    time: float
    sd: float
    source: str
    note: str | None = None
    warning: str | None = None


def lift_off_choice(force: float, force_sd: float, stone: float | None, stone_sd: float,
                    agreement_sd: float = 2.0) -> LiftOffChoice:
    """Lift-off from the normal force's zero (``force``, ``force_sd``, s), checked by the
    stone's departure from the trough (``stone``, ``stone_sd``, s; None: not seen,
    :mod:`.trough_departure`): the normal force's time stands; where the two disagree
    beyond ``agreement_sd`` sd of their difference its sd widens to cover the stone's
    (the release's rule, :func:`~.release_sources.covering_sd`) and a warning says so.
    Not their mean: on the video bench the stone's departure came 1.6–4 frames early
    where the normal force was within half a frame (a cubic rise out of the trough is slow,
    and a camera model a few mm off across the trough shifts it), and averaging the two
    where a gap had widened the force's sd moved lift-off 2.6 frames early."""
    source = "trough normal force reaches zero"
    if stone is None or not (np.isfinite(stone_sd) and stone_sd > 0):
        return LiftOffChoice(force, force_sd, source)
    sd = force_sd if np.isfinite(force_sd) and force_sd > 0 else 0.0
    both = float(np.hypot(sd, stone_sd))
    said = (f"the trough's normal force reaches zero at {force:.4f} s (sd {1e3 * sd:.1f} ms), "
            f"the stone leaves the trough at {stone:.4f} s (sd {1e3 * stone_sd:.1f} ms)")
    source = "trough normal force reaches zero, checked by the stone leaving the trough"
    if abs(force - stone) <= agreement_sd * both:
        return LiftOffChoice(force, force_sd, source, f"lift-off at {force:.4f} s: {said}")
    wide = covering_sd(sd, stone - force)
    return LiftOffChoice(force, wide, source, None,
                         f"the lift-off sources disagree: {said}, "
                         f"{abs(force - stone) / both:.1f} sd apart; lift-off is taken at "
                         f"{force:.4f} s with sd {1e3 * wide:.1f} ms to cover both (the angles' "
                         "common offset, a camera's roll, moves the normal force's zero)")

#: s: an angle the normal force needs that is not tracked within this of the lift-off
#: widens its sd (:func:`gap_widened_sd`).
GAP_WINDOW_S = 0.05


def gap_widened_sd(t: np.ndarray, tracked: np.ndarray, lift_off: float, sd: float
                   ) -> tuple[float, str | None]:
    """The lift-off's sd (s) widened where an angle it rests on is not tracked near it:
    ``tracked`` (k, n) bool per angle and row (θ and ψ: the normal force is the phase-I
    formula on them); each untracked run of rows that reaches from :data:`GAP_WINDOW_S`
    before ``lift_off`` (s) to two frames after it adds its span / √12 in quadrature (the
    lift-off could lie anywhere the data do not show; a gap that starts after the
    crossing moved nothing: on the video bench's Kinovea exports the counterweight's gaps
    from 27 ms after lift-off on had widened its sd to 60-200 ms and let the stone's
    coarser departure pull it 3-4 frames early). A stress-grid log whose counterweight's
    track was dropped from 60 ms before lift-off on put it 9.8 frames late with an sd of 0.3
    frame. Returns the sd and a sentence (None: nothing widened)."""
    t = np.asarray(t, dtype=float)
    frame = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    # a gap that starts after the crossing (and its first frames below zero) moves nothing
    near = (t >= lift_off - GAP_WINDOW_S) & (t <= lift_off + 2.0 * frame)
    extra, spans = 0.0, []
    for row in np.asarray(tracked, bool):
        missing = ~row
        if not (missing & near).any():
            continue
        idx = np.flatnonzero(missing)
        cuts = np.flatnonzero(np.diff(idx) > 1)
        for a, b in zip(np.r_[idx[0], idx[cuts + 1]], np.r_[idx[cuts], idx[-1]], strict=True):
            if near[a:b + 1].any():
                lo, hi = t[max(a - 1, 0)], t[min(b + 1, t.size - 1)]
                extra = max(extra, (hi - lo) / np.sqrt(12.0))
                spans.append((float(t[a]), float(t[b])))
    if extra == 0.0:
        return sd, None
    wide = float(np.hypot(sd if np.isfinite(sd) else 0.0, extra))
    runs = ", ".join(f"{a:.4f}–{b:.4f} s" for a, b in spans[:3])
    return wide, (f"the angles the trough's normal force rests on are not tracked near the "
                  f"lift-off ({runs}): its sd is widened to {1e3 * wide:.1f} ms")


def timing_widened_sd(lift_off: float, sd: float, scene_lift_off: float | None,
                      span: float, frame: float = 0.0, trigger_sd: float = 0.0
                      ) -> tuple[float, str | None]:
    """The lift-off's sd (s) widened to cover the scene's own lift-off (``scene_lift_off``,
    s, log time: the trigger, sd ``trigger_sd`` s, plus the simulated time to lift-off
    ``span``; None: unknown) where the two disagree
    (:func:`~.release_sources.scene_covering_sd`, as
    :func:`~.release_sources.timing_checked` does for a release; ``frame``, s); a sentence
    (None: as it is). Neither the stone's departure (its sd 13–17 frames where the stone
    is small in the image) nor the normal force's own sd sees a zero moved by the tracked
    angles' systematic errors: on the stress grid it lay 2–9 frames off with an sd under a
    frame, unwarned, where the scene's own lift-off was within 2."""
    if scene_lift_off is None or not np.isfinite(span) or span <= 0:
        return sd, None
    gap = scene_lift_off - lift_off
    wide = scene_covering_sd(lift_off, sd, scene_lift_off, span, frame, trigger_sd)
    if wide is None:
        return sd, None
    return wide, (f"the lift-off at {lift_off:.4f} s lies {1e3 * abs(gap):.0f} ms from the "
                  f"scene's own {scene_lift_off:.4f} s: it is taken with sd "
                  f"{1e3 * wide:.1f} ms to cover both")
