"""The time axis of a log: from frame numbers, its order, and times rounded to milliseconds."""

from __future__ import annotations

import math

import numpy as np

from trebuchet.core.errors import Option, TrebuchetInputError


def check_fps(fps: float | None) -> float | None:
    """Return ``fps`` (frames per second) as a float; error unless None or a frame rate a film
    of a shot can have (:data:`FRAME_RATE_RANGE`), naming ``fps`` (``--fps``)."""
    if fps is None:
        return None
    try:
        value = float(fps)
    except (TypeError, ValueError):
        raise TrebuchetInputError(f"{Option('fps', fps)}: not a number") from None
    if not math.isfinite(value) or value <= 0:
        raise TrebuchetInputError(f"{Option('fps', value)}: must be a positive frame rate (1/s)")
    low, high = FRAME_RATE_RANGE
    if not low <= value <= high:
        raise TrebuchetInputError(f"{Option('fps', value)}: no film of a shot has {value:g} "
                                  f"frames per s; give the video's frame rate ({low:g} to "
                                  f"{high:g} per s)")
    return value


def frames_to_time(
    frame: np.ndarray, rows: np.ndarray, fps: float | None, label: str
) -> tuple[np.ndarray, np.ndarray]:
    """Return (t in s, frame as int64) from frame numbers and the frame rate ``fps`` (1/s).

    ``t = frame / fps``, so the log's time is zero at frame 0 of the video. Errors: no fps,
    an empty or non-integer frame number (naming its row).
    """
    if fps is None:
        raise TrebuchetInputError(
            f"column '{label}' holds frame numbers and the file has no time column; "
            f"pass the frame rate, e.g. fps=240"
        )
    bad = ~np.isfinite(frame)
    if bad.any():
        k = int(np.argmax(bad))
        raise TrebuchetInputError.at(f"row {rows[k]}, column '{label}'", "frame number is empty")
    far = np.abs(frame) >= MAX_FRAME
    if far.any():
        k = int(np.argmax(far))
        raise TrebuchetInputError.at(
            f"row {rows[k]}, column '{label}'", f"frame number {frame[k]:.6g} is no frame of "
            f"a video (at most {MAX_FRAME:,}: over 8 months at 100 fps)")
    frac = np.abs(frame - np.round(frame))
    if (frac > 1e-9).any():
        k = int(np.argmax(frac > 1e-9))
        raise TrebuchetInputError.at(
            f"row {rows[k]}, column '{label}'", f"frame number {frame[k]:g} is not whole"
        )
    frame_int = np.round(frame).astype(np.int64)
    return frame_int / fps, frame_int


def check_time(t: np.ndarray, rows: np.ndarray, label: str) -> None:
    """Error for an empty time cell, a time earlier than the row before (naming the row), and
    times too large for their steps (:func:`check_precision`)."""
    bad = ~np.isfinite(t)
    if bad.any():
        k = int(np.argmax(bad))
        raise TrebuchetInputError.at(f"row {rows[k]}, column '{label}'", "the time is empty")
    check_precision(t, label)
    back = np.diff(t) < 0
    if back.any():
        k = int(np.argmax(back)) + 1
        raise TrebuchetInputError.at(
            f"row {rows[k]}, column '{label}'", f"time decreases "
            f"({t[k]:.6g} s after {t[k - 1]:.6g} s on row {rows[k - 1]}); "
            f"a log must be in the order of its frames"
        )


#: Frame numbers a video can have (exclusive): 2³¹.
MAX_FRAME = 2**31
#: Largest share of a frame step that float64's spacing at the log's times may reach.
TIME_RESOLUTION = 1e-3


def check_precision(t: np.ndarray, label: str) -> None:
    """Error for times so large that float64 no longer resolves their frames: the spacing
    of doubles near the largest |t| (s) beyond :data:`TIME_RESOLUTION` of the median step
    (times offset by 1e15 s are 0.125 s apart at best: the frames of a shot merge)."""
    if t.size < 2:
        return
    largest = float(np.max(np.abs(t)))
    resolution = float(np.spacing(largest))
    steps = np.diff(t)
    steps = steps[steps > 0]
    step = float(np.median(steps)) if steps.size else 0.0
    if resolution > TIME_RESOLUTION * step:
        raise TrebuchetInputError.at(
            f"column '{label}'", f"times near {largest:.6g} s keep a resolution of only "
            f"{resolution:.3g} s in 64-bit numbers, "
            + (f"more than a thousandth of the step between rows ({step:.3g} s)"
               if resolution < step else "which merges rows" if step > 0 else
               "and every row has the same time")
            + ": the column has lost its precision; subtract an offset (e.g. the first "
            "time) before writing it")


#: Frame rates (1/s) a filmed shot can have; outside them the time unit is wrong.
FRAME_RATE_RANGE = (5.0, 1e5)


def check_frame_rate(t: np.ndarray, label: str, fps: float | None) -> None:
    """Error for times whose frame rate no film of a shot has (a time column in ms under an
    ``s`` header, or the other way round), and for a given ``fps`` that the log's own times
    contradict by more than 5 %. ``t`` in s, sorted."""
    steps = np.diff(t[np.isfinite(t)])
    steps = steps[steps > 0]
    if not steps.size:
        return
    rate = 1.0 / float(np.median(steps))
    low, high = FRAME_RATE_RANGE
    if not low <= rate <= high:
        hint = "ms" if rate < low else "s"
        raise TrebuchetInputError.at(
            f"column '{label}'", f"the frames lie {1.0 / rate:.3g} s apart ({rate:.3g} "
            f"fps), which no film of a shot has; if the times are in {hint}, say so in the "
            f"header, e.g. '{label.split('(')[0].split('[')[0].strip() or 't'} ({hint})'")
    if fps is None:
        return
    # times rounded coarser than the frames (60 fps to 0.01 s: steps 0.01, 0.02) move the
    # median step; the mean of the steps near it does not
    near = steps[np.abs(steps * rate - 1.0) <= 0.5]
    mean_rate = 1.0 / float(np.mean(near))
    if min(abs(rate / fps - 1.0), abs(mean_rate / fps - 1.0)) > 0.05:
        raise TrebuchetInputError(
            f"fps={fps:g} disagrees with the log's times in column '{label}', whose "
            f"frames come {rate:.4g} per s; correct fps or leave it out")


def decimal_rounding(t: np.ndarray, period_fraction: float = 1e-3) -> float | None:
    """The step (s) the times were rounded to when it blurs the frame period, else None.

    Times written with a few decimals (Tracker's 0.0083/0.0084 s at 120 fps) are whole
    multiples of a power of ten; when that step exceeds ``period_fraction`` of the median
    frame period and the single-frame steps differ, the rounding shows in the frame rate
    (120.5 fps from the median step); a step shorter than 0.75 of the median is proof
    of rounding too (60 fps written to 0.01 s: steps of 0.01 and 0.02 s). Times on an
    exact grid (0.01 s at 100 fps) and times whose rounding is finer than
    ``period_fraction`` of the period (6 decimals at up to 1000 fps) give None.
    """
    tv = t[np.isfinite(t)]
    dt = np.diff(tv)
    dt = dt[dt > 0]
    if tv.size < 3 or not dt.size:
        return None
    period = float(np.median(dt))
    single = dt[np.abs(dt / period - 1.0) < 0.5]
    if np.ptp(single) <= 1e-9 * period and not (dt < 0.75 * period).any():
        return None
    for decimals in range(6):
        step = 10.0**-decimals
        if np.abs(tv / step - np.round(tv / step)).max() < 1e-6:
            return step if step > period_fraction * period else None
    return None


def snap_rounded_times(
    t: np.ndarray, rows: np.ndarray, fps: float | None, step: float,
    anchored: bool = True,
) -> tuple[np.ndarray, float | None, str | None]:
    """Replace times rounded to ``step`` seconds (e.g. Kinovea's whole ms) by frame times.

    With ``fps`` known, each time becomes ``round(t * fps) / fps`` (``anchored``: times
    counted from the video's frame 0, as Kinovea's) or, not anchored, the frame times
    ``c + k / fps`` with ``k = round((t - t[0]) fps)`` and ``c`` fitted (a log whose
    time starts anywhere); a time further than ``step / 2`` (anchored) or ``0.6 step``
    from its frame is an error naming the row (the frame rate does not fit).
    Without ``fps`` the frame period is fitted by least squares over the frame indices
    implied by the steps; the fit is used only if it reproduces every time within
    ``0.6 step`` (rounding's half step and the fit's own small offset). Returns (times
    in s, frame rate used or fitted or None, repair text or None).
    Times that already lie on the frame grid are returned unchanged with no repair.
    """
    tol = step / 2 + 1e-9
    if len(t) < 2:
        return t, fps, None
    if fps is not None:
        if anchored:
            snapped = np.round(t * fps) / fps
        else:
            k = np.round((t - t[0]) * fps)
            snapped = float(np.mean(t - k / fps)) + k / fps
            tol = 0.6 * step
        off = np.abs(snapped - t)
        if (off > tol).any():
            k = int(np.argmax(off > tol))
            raise TrebuchetInputError.at(
                f"row {rows[k]}", f"time {t[k]:.6g} s is {off[k] * 1e3:.2f} ms from the "
                f"nearest frame at fps={fps:g}; is the frame rate right?"
            )
        how = (f"the frame times k/fps at fps={fps:g}" if anchored
               else f"a frame grid at fps={fps:g}")
        fitted = fps
    else:
        dt = np.diff(t)
        positive = dt[dt > 0]
        if len(positive) == 0:
            return t, None, None
        period = float(np.median(positive))
        coarse = (t, None, (
            f"times are rounded to {step * 1e3:g} ms, too coarse for the frame period "
            f"of about {float(np.mean(positive)) * 1e3:.3g} ms; they are used as written: "
            "pass fps= to recover exact frame times"))
        if period <= 2 * step * (1 + 1e-9):
            return coarse
        for _ in range(3):
            steps = np.round(dt / period)
            if (steps < 1).any():
                return coarse
            period = float(dt.sum() / steps.sum())
        k = np.concatenate([[0.0], np.cumsum(steps)])
        slope, intercept = np.polyfit(k, t, 1)
        snapped = intercept + slope * k
        # rounding moves a time by up to step/2 from its frame; the fitted grid itself sits
        # a little off the true one (least squares, not the minimax line): 0.6 step allows it
        if np.abs(snapped - t).max() > 0.6 * step:
            return t, None, None
        fitted = 1.0 / slope
        how = f"a fitted frame grid at {fitted:.6g} fps (pass fps= to use the exact rate)"
    change = np.abs(snapped - t).max()
    if change <= 1e-12:
        return t, fitted, None
    return snapped, fitted, (
        f"times rounded to {step * 1e3:g} ms replaced by {how}; largest change "
        f"{change * 1e3:.3g} ms"
    )
