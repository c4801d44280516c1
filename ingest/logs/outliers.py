"""Single frames that no smooth motion reaches: a mistyped or misplaced angle.

An angle of the engine moves smoothly from frame to frame: between two frames a frame
period apart it changes by its rate times the period, and its rate changes by its
acceleration. A value that sits far off the curve its neighbours define (a cell typed 90°
off, a tracker's wrong match on one frame) is no measurement of the shot: absorbed by the
smoother, one such cell raised the noise estimate from 0.31° to 5° and moved the peak
loads by 6 %.

The test, per angle, over its present values (:func:`single_frame_outliers`):

* each value is predicted from its present neighbours, two on either side, by the cubic
  through them (Lagrange, at the frames' times; the nearest neighbour on a side counts
  within :data:`REACH` frame periods, the next within 1.5 times that: one absent frame is
  bridged), by a lower polynomial where a side has one, and at a track's ends by the line
  through two on one side (:func:`misses`). Each miss is divided by its prediction's noise
  gain ``√(1 + Σ w²)`` (1.39 for the cubic): for smooth motion it is then the noise, plus
  the fourth derivative's h⁴/6, far below a degree at the frame rates of a film;
* the noise sd is robust (1.4826 × the median |miss|): the larger of the whole angle's and
  of the :data:`WINDOW` frames around (where fast motion or blur makes every miss
  larger), never below :data:`FLOOR`;
* a value that misses by more than :data:`THRESHOLD` such sds is a single-frame outlier
  when, left out, its neighbours agree with each other (each within half the threshold),
  and when no neighbour, left out instead, explains the disagreement as well: a step, a
  real kink of the motion or a run of bad frames moves its neighbours too, and is left
  alone.

Candidates are taken largest first, each judged on the values left. Each outlier becomes a
gap (NaN), reported with its row, its miss and the noise.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from trebuchet.ingest.readers.source import ParsedLog
from trebuchet.ingest.readers.table import format_rows

#: Misses (in robust sds of the noise) beyond which a value is an outlier.
THRESHOLD = 8.0
#: Frames around a value whose misses give the local noise.
WINDOW = 21
#: Frame periods within which a value's neighbours predict it (two frame periods for the
#: nearest on a side, three for the next: one absent frame bridged).
REACH = 2.0
#: rad: the least noise sd assumed (1e-7 rad, 6e-6°: below the rounding of any log; a log
#: without noise, every miss exactly zero, would otherwise make any rounding an outlier).
FLOOR = 1e-7
#: At most this share of an angle's values is taken out (more is no single-frame fault).
MAX_SHARE = 0.05


def misses(t: np.ndarray, values: np.ndarray, period: float | None = None, *,
           per_noise: bool = True) -> np.ndarray:
    """Each value's miss from the curve of its neighbours: the value minus the polynomial
    through its present neighbours (up to two on either side, the nearest within
    :data:`REACH` frame periods, the next within 1.5 times that; at the ends of a track the
    line through two on one side), divided by ``√(1 + Σ w²)`` (``w`` the polynomial's
    weights: the miss's sd for unit noise) when ``per_noise``. rad; NaN where missing or
    without neighbours. ``period`` in s, by default the median step of the present values."""
    ok = np.flatnonzero(np.isfinite(values))
    out = np.full(values.shape, np.nan)
    if ok.size < 3:
        return out
    tv, av = t[ok], values[ok]
    if period is None:
        steps = np.diff(tv)
        period = float(np.median(steps[steps > 0])) if (steps > 0).any() else 0.0
    if not period > 0.0:
        return out
    n = ok.size
    j = np.arange(n)

    def near(offset: int) -> np.ndarray:
        k = np.clip(j + offset, 0, n - 1)
        return (j + offset >= 0) & (j + offset < n) & (
            np.abs(tv[k] - tv) <= (1.0 + 0.5 * (abs(offset) - 1)) * REACH * period)

    left = near(-1).astype(int) + (near(-1) & near(-2))
    right = near(1).astype(int) + (near(1) & near(2))
    lo = np.where(right > 0, left, np.where(left == 2, 2, -1))
    hi = np.where(left > 0, right, np.where(right == 2, 2, -1))
    for a, b in ((2, 2), (1, 2), (2, 1), (1, 1), (0, 2), (2, 0)):
        pick = j[(lo == a) & (hi == b)]
        if not pick.size:
            continue
        nodes = np.stack([pick + d for d in (*range(-a, 0), *range(1, b + 1))])
        tt, x = tv[nodes], tv[pick]
        weights = np.ones_like(tt)
        with np.errstate(divide="ignore", invalid="ignore"):
            for p in range(len(nodes)):
                for q in range(len(nodes)):
                    if p != q:
                        weights[p] *= (x - tt[q]) / (tt[p] - tt[q])
            miss = av[pick] - np.sum(weights * av[nodes], axis=0)
            if per_noise:
                miss = miss / np.sqrt(1.0 + np.sum(weights * weights, axis=0))
        out[ok[pick]] = miss
    return out


def _scale(miss: np.ndarray) -> np.ndarray:
    """The noise sd around each frame: the larger of the global and the local robust sd
    of the misses (1.4826 × median |miss|, the median of the misses being about zero)."""
    absolute = np.abs(miss)
    overall = max(1.4826 * float(np.nanmedian(absolute)), FLOOR)
    local = 1.4826 * pd.Series(absolute).rolling(WINDOW, center=True, min_periods=7
                                                  ).median().to_numpy()
    return np.fmax(overall, local)


def single_frame_outliers(t: np.ndarray, values: np.ndarray
                          ) -> tuple[list[tuple[int, float]], float]:
    """The values no smooth motion reaches (module doc) as (index, miss from the curve of
    the neighbours in rad), and the angle's noise sd (rad) they were measured against."""
    values = np.array(values, dtype=float)
    present = np.isfinite(values)
    steps = np.diff(t[present])
    if present.sum() < 9 or not (steps > 0).any():
        return [], math.nan
    period = float(np.median(steps[steps > 0]))
    miss = misses(t, values, period)
    if not np.isfinite(miss).any():
        return [], math.nan
    scale = _scale(miss)
    noise = float(np.nanmedian(scale))
    with np.errstate(invalid="ignore", divide="ignore"):
        z = np.abs(miss) / scale
    candidates = np.flatnonzero(z > THRESHOLD)
    candidates = candidates[np.argsort(-z[candidates])]
    found: list[tuple[int, float]] = []
    for k in candidates[: max(1, int(MAX_SHARE * present.sum()))]:
        ok = np.flatnonzero(np.isfinite(values))
        at = int(np.searchsorted(ok, k))
        if at >= ok.size or ok[at] != k:
            continue
        lo, hi = ok[max(0, at - 6)], ok[min(ok.size - 1, at + 6)] + 1
        window, times, sd = values[lo:hi], t[lo:hi], scale[lo:hi]
        here = k - lo
        if not abs(misses(times, window, period)[here]) > THRESHOLD * sd[here]:
            continue
        beside = _neighbours(window, here)
        if not _explains(times, window, sd, here, period) or any(
                _explains(times, window, sd, int(j), period, here) for j in beside
                if abs(int(j) - here) <= 2):
            continue  # its neighbours disagree too (a step, a kink), or one of them
            # explains the disagreement as well as it does
        found.append((k, float(misses(times, window, period, per_noise=False)[here])))
        values[k] = np.nan
    return sorted(found), noise


def _neighbours(values: np.ndarray, k: int) -> np.ndarray:
    """The indexes of the two present values on either side of index ``k``."""
    ok = np.flatnonzero(np.isfinite(values))
    ok = ok[ok != k]
    at = int(np.searchsorted(ok, k))
    return ok[max(0, at - 2):at + 2]


def _explains(t: np.ndarray, values: np.ndarray, sd: np.ndarray, k: int, period: float,
              must: int | None = None) -> bool:
    """Whether, with value ``k`` left out, its neighbours lie on one smooth curve (each
    misses it by at most half the threshold, in noise sds ``sd``; the value ``must`` among
    them measurably so)."""
    trial = values.copy()
    trial[k] = np.nan
    near = _neighbours(trial, k)
    again = np.abs(misses(t, trial, period)[near]) / sd[near]
    if must is not None and not (must in near and np.isfinite(again[near == must]).all()):
        return False
    return bool(near.size) and bool(np.all(~(again > THRESHOLD / 2)))


def drop_single_frame_outliers(log: ParsedLog) -> list[str]:
    """Make every single-frame outlier of each angle a gap (in place); one sentence per
    angle that had any."""
    out = []
    for a in ("theta", "psi", "phi"):
        found, noise = single_frame_outliers(log.t, log.angles[a])
        if not found:
            continue
        rows = [k for k, _ in found]
        values = log.angles[a].copy()
        values[rows] = np.nan
        log.angles[a] = values
        worst = max(abs(m) for _, m in found)
        out.append(
            f"{a} ({log.labels.get(a, a)}) jumps off the motion its neighbouring frames "
            f"define in {format_rows(log.rows[rows])} (by up to {math.degrees(worst):.3g}°, "
            f"the noise being about {math.degrees(noise):.2g}°): no smooth motion of the "
            "engine reaches such a frame (a mistyped or misplaced value?); left out as a gap")
    return out
