"""Does a tracked projectile stay on its sling's circle? Where it leaves, it is released.

While the projectile hangs in the taut sling (trough and swing, phases I–II) its distance
from the spigot is the sling's length L4, and the spigot's distance from the pivot is the
beam's L1: the ratio ``ρ = |projectile − spigot| / |spigot − pivot|`` is the constant
L4/L1, in any length unit (pixels included). After the release the stone flies off and ρ
grows without bound. A point tracker that keeps following the stone then gives a "sling
angle" spigot → stone that is no sling angle at all; the rows from the first one off the
circle are the released rows (the issue's "leaves the sling geometry").

The level and the noise of ρ come from the log itself, not from the scene, so a scene
whose lengths are a little off does not matter, and each ratio is compared with the
level of the rows just before it, so a sling slack at rest (ρ below its taut value) is
no flight; only a final, sustained rise far above that level is looked at.

Where the stone leaves, the sling's pull on it stops: ρ's rate is continuous (zero) and
its acceleration jumps from zero to about T/(m L1). That is the shape of the trigger's
first motion after rest, so the time is fitted by the same profile likelihood
(:func:`~trebuchet.ingest.events.detection.trigger_estimate`), which finds it to about a frame;
the first row clearly off the circle comes 2–50 frames later (60–1000 fps, 0.5–3 px noise
on a paper-sized engine filmed at 40 px/m).
"""

from __future__ import annotations

import numpy as np

from trebuchet.ingest.events.detection import robust_noise_sd, trigger_estimate

__all__ = ["sling_ratio", "first_row_off_circle", "leaving_time"]


def sling_ratio(pivot: tuple[np.ndarray, np.ndarray], spigot: tuple[np.ndarray, np.ndarray],
                projectile: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """``|projectile − spigot| / |spigot − pivot|`` per row (dimensionless; NaN where a point
    is missing or the spigot sits on the pivot). Positions ``(x, y)`` in one length unit."""
    with np.errstate(invalid="ignore", divide="ignore"):
        sling = np.hypot(projectile[0] - spigot[0], projectile[1] - spigot[1])
        beam = np.hypot(spigot[0] - pivot[0], spigot[1] - pivot[1])
        return np.where(beam > 0, sling / np.where(beam > 0, beam, 1.0), np.nan)


def _noise_sd(values: np.ndarray) -> float:
    """Noise sd of a series from the median absolute deviation of its successive
    differences (which a smooth rise barely touches)."""
    d = np.diff(values)
    return 1.4826 * float(np.median(np.abs(d - np.median(d)))) / np.sqrt(2.0)


def _trailing_level(values: np.ndarray, rows: int) -> np.ndarray:
    """Median of the ``rows`` values before each one (NaN for the first ``rows``)."""
    level = np.full(values.size, np.nan)
    if values.size > rows:
        windows = np.lib.stride_tricks.sliding_window_view(values[:-1], rows)
        level[rows:] = np.median(windows, axis=1)
    return level


def first_row_off_circle(ratio: np.ndarray, away: float = 1.05, noise_multiple: float = 4.0,
                         level_rows: int = 10, min_flight_rows: int = 5,
                         end_rows: int = 3) -> int | None:
    """First row of the final stretch on which the projectile is off its sling's circle.

    Each present ratio is compared with the median of the ``level_rows`` present ones
    before it (the circle's level there: a slack sling at rest, lower, has left that
    window by the end of the swing); walking back from the end of the track, the
    stretch starts after the last ratio within ``noise_multiple`` noise sd of its level.
    It counts as a flight only with at least ``min_flight_rows`` rows, nearly all
    (80 %) above the level at its start by ``noise_multiple`` sd, and the median of its
    last ``end_rows`` ratios above ``away`` × that level (the stone far off the circle,
    not a tracker's glitch on the last frames). None otherwise.
    """
    ok = np.flatnonzero(np.isfinite(ratio))
    if ok.size < level_rows + min_flight_rows:
        return None
    values = ratio[ok]
    sd = _noise_sd(values)
    level = _trailing_level(values, level_rows)
    near = ~(values > level + noise_multiple * sd)  # the first rows (no level) count as near
    first = int(np.flatnonzero(near)[-1]) + 1
    if values.size - first < min_flight_rows:
        return None
    base = float(level[first])
    flight = values[first:]
    if (not base > 0 or float(np.median(flight[-end_rows:])) <= away * base
            or np.mean(flight > base + noise_multiple * sd) < 0.8):
        return None
    return int(ok[first])


def leaving_time(t: np.ndarray, ratio: np.ndarray, lead: float = 0.3,
                 min_lead_rows: int = 20, level_time: float = 0.03
                 ) -> tuple[float, float] | None:
    """When (s) the projectile leaves its sling's circle, and the sd (s) of that time.

    ``t`` (n,) s increasing, ``ratio`` (n,) from :func:`sling_ratio`. Only when the track
    ends in flight (:func:`first_row_off_circle`, each row's level from the rows of the
    ``level_time`` s before it, at least 10); the onset of ρ's final rise is fitted on the
    rows from ``lead`` s (at least ``min_lead_rows`` rows) before the first row off the
    circle, or from the last slack row (below the circle) after that, to the end. None
    otherwise, or when no onset can be fitted (then nothing is cut: the release is left to
    the other searches).
    """
    dt = float(np.median(np.diff(t)))
    first = first_row_off_circle(ratio, level_rows=max(10, int(round(level_time / dt))))
    if first is None:
        return None
    lo = max(0, first - max(min_lead_rows, int(round(lead / dt))))
    # the fit's rest is the taut sling: start after any slack row (below the circle)
    before = ratio[lo:first]
    ok = np.isfinite(before)
    if ok.sum() > 2:
        taut = float(np.median(before[ok]))
        slack = np.flatnonzero(ok & (before < taut - 4.0 * _noise_sd(before[ok])))
        if slack.size:
            lo += int(slack[-1]) + 1
    sub_t, sub = t[lo:], ratio[lo:]
    sd = robust_noise_sd(sub_t, sub)
    found = trigger_estimate(sub_t, sub[None, :], np.array([sd]))
    return found
