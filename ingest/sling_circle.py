"""Does a tracked projectile stay on its sling's circle? Where it leaves, it is released.

While the projectile hangs in the taut sling (trough and swing, phases I–II) its distance
from the spigot is the sling's length L4, and the spigot's distance from the pivot is the
beam's L1: the ratio ``ρ = |projectile − spigot| / |spigot − pivot|`` is the constant
L4/L1, in any length unit (pixels included). After the release the stone flies off and ρ
grows without bound. A point tracker that keeps following the stone then gives a "sling
angle" spigot → stone that is no sling angle at all; the rows from the first one off the
circle are the released rows (the issue's "leaves the sling geometry").

The level and the noise of ρ come from the log itself, not from the scene, so a sling that
is slack at rest (ρ below its taut value) or a scene whose lengths are a little off does
not matter: only the final excursion of ρ far above its typical value is looked at.

Where the stone leaves, the sling's pull on it stops: ρ's rate is continuous (zero) and
its acceleration jumps from zero to about T/(m L1). That is the shape of the trigger's
first motion after rest, so the time is fitted by the same profile likelihood
(:func:`~trebuchet.ingest.events.trigger_estimate`), which finds it to about a frame;
the first row clearly off the circle comes 2–50 frames later (60–1000 fps, 0.5–3 px noise
on a paper-sized engine filmed at 40 px/m).
"""

from __future__ import annotations

import numpy as np

from .events import robust_noise_sd, trigger_estimate

__all__ = ["sling_ratio", "first_row_off_circle", "leaving_time"]


def sling_ratio(pivot: tuple[np.ndarray, np.ndarray], spigot: tuple[np.ndarray, np.ndarray],
                projectile: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """``|projectile − spigot| / |spigot − pivot|`` per row (dimensionless; NaN where a point
    is missing or the spigot sits on the pivot). Positions ``(x, y)`` in one length unit."""
    with np.errstate(invalid="ignore", divide="ignore"):
        sling = np.hypot(projectile[0] - spigot[0], projectile[1] - spigot[1])
        beam = np.hypot(spigot[0] - pivot[0], spigot[1] - pivot[1])
        return np.where(beam > 0, sling / np.where(beam > 0, beam, 1.0), np.nan)


def first_row_off_circle(ratio: np.ndarray, away: float = 1.05, noise_multiple: float = 4.0,
                         min_rows: int = 8, end_rows: int = 3) -> int | None:
    """First row of the final stretch on which the projectile is off its sling's circle.

    Only when the track ends off the circle (the median of its last ``end_rows`` present
    ratios above ``away`` × the median of all present ratios, and above it by
    ``noise_multiple`` noise sd: the stone in flight): walking back from
    there, the stretch ends at the last row whose ratio lies within ``noise_multiple``
    noise sd of that median (the sd from the median absolute difference of successive
    ratios, which the smooth rise in flight barely touches). None when the track does
    not end in flight, or with fewer than ``min_rows`` present ratios.
    """
    ok = np.flatnonzero(np.isfinite(ratio))
    if ok.size < min_rows:
        return None
    values = ratio[ok]
    level = float(np.median(values))
    sd = 1.4826 * float(np.median(np.abs(np.diff(values) - np.median(np.diff(values))))) \
        / np.sqrt(2.0)
    end = float(np.median(values[-end_rows:]))
    if not level > 0 or end <= max(away * level, level + noise_multiple * sd):
        return None
    near = np.flatnonzero(values <= level + noise_multiple * sd)
    if near.size == 0:
        return None
    last_near = int(near[-1])
    return int(ok[last_near + 1])


def leaving_time(t: np.ndarray, ratio: np.ndarray, lead: float = 0.15,
                 min_lead_rows: int = 20) -> tuple[float, float] | None:
    """When (s) the projectile leaves its sling's circle, and the sd (s) of that time.

    ``t`` (n,) s increasing, ``ratio`` (n,) from :func:`sling_ratio`. Only when the track
    ends in flight (:func:`first_row_off_circle`); the onset of ρ's final rise is fitted on
    the rows from ``lead`` s (at least ``min_lead_rows`` rows) before the first row off
    the circle to the end. None otherwise, or when no onset can be fitted.
    """
    first = first_row_off_circle(ratio)
    if first is None:
        return None
    dt = float(np.median(np.diff(t)))
    lo = max(0, first - max(min_lead_rows, int(round(lead / dt))))
    sub_t, sub = t[lo:], ratio[lo:]
    sd = robust_noise_sd(sub_t, sub)
    found = trigger_estimate(sub_t, sub[None, :], np.array([sd]))
    if found is None:
        return float(0.5 * (t[first - 1] + t[first])) if first > 0 else float(t[0]), dt
    return found
