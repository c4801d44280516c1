"""The measured swing against the scene's: a check of the units :func:`read_log` decided.

``read_log`` decides a unit the file does not state from the file alone (the frame pattern,
the values); a factor of 57 (degrees read as rad), 1000 (ms read as s) or the frame rate
(frame numbers read as s) that slipped through shows against the engine filmed: its beam
sweeps through a known angle in a known time. :func:`scene_check` compares the log's beam
with the simulation of the scene over the same stretch of the shot, which needs no event
the log does not show by itself:

* from the beam's **departure** (the first time θ lies :data:`DEPARTURE_DEG` from its rest
  value, the median of the first frames) to its **fastest point** (the largest dθ/dt);
* the **sweep**: θ at the fastest point minus θ at rest, in degrees;
* the **time** from the departure to the fastest point, in s.

Each must lie within a broad band of the simulation's (:data:`BAND`: a different engine or
release gives tens of per cent, a wrong unit a factor of 57, 1000 or the frame rate).
Outside the band it is an error naming the likely factor; inside, a :class:`SceneCheck`
with both and a sentence for the notes. A log that ends before the beam's fastest point
is compared with the simulation over as long a stretch after the departure; a log that
does not start at rest (θ drifting by more than :data:`REST_SHARE` of its sweep over its
first :data:`REST_TIME` s) or whose beam never departs is not checked (a
:class:`SceneCheck` with ``checked=False`` saying why).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.ndimage import median_filter
from scipy.signal import savgol_filter

from trebuchet.core.errors import Option, TrebuchetInputError
from trebuchet.ingest.logs.result import read_log_info
from trebuchet.model.scene import Scene, as_scene
from trebuchet.model.simulate import simulate

#: deg: θ's distance from its rest value that marks the beam's departure.
DEPARTURE_DEG = 2.0
#: The start of a log taken as the engine at rest: this many s, at least so many frames.
REST_TIME = 0.1
REST_FRAMES = 10
#: Largest drift of θ over those frames, as a share of its whole sweep, for a rest.
REST_SHARE = 0.01
#: Broad band of the ratio measured / simulated, for the sweep and for the time.
BAND = (0.5, 2.0)
#: Frames of the running median that takes out single mislocated points.
OUTLIER_FRAMES = 5
#: s: the span of the local fit that gives the log's dθ/dt.
RATE_WINDOW = 0.05
#: s: the simulation's output step.
SIM_STEP = 1e-4


@dataclass(frozen=True)
class SceneCheck:
    """The log's beam against the scene's simulation: sweep (deg) from rest to the fastest
    point, time (s) from departure to the fastest point; ``note`` says it in a sentence.
    ``checked`` is False (and the numbers NaN) when the log does not show that stretch
    (it starts after the departure, or the beam never leaves rest): nothing was checked."""

    checked: bool
    sweep_deg: float
    sweep_sim_deg: float
    time_s: float
    time_sim_s: float
    note: str


def scene_check(log: pd.DataFrame, scene: Scene | str, *, band: tuple[float, float] = BAND
                ) -> SceneCheck:
    """Compare the beam of ``log`` (``read_log``'s table: ``t`` in s, ``theta`` in rad) with
    the simulation of ``scene``; an error when sweep or time lies outside ``band``."""
    scene = as_scene(scene, "scene_check")
    name = _name(log)
    t = log["t"].to_numpy(dtype=float)
    theta = log["theta"].to_numpy(dtype=float)
    ok = np.isfinite(t) & np.isfinite(theta)
    t, theta = t[ok], theta[ok]
    why = _not_at_rest(t, theta)
    if why:
        nan = float("nan")
        return SceneCheck(False, nan, nan, nan, nan, f"the swing was not checked against the "
                          f"scene: {why}")
    rest = float(np.median(theta[:_rest_window(t)]))
    measured = _stretch(t, theta, rest)
    sim = simulate(scene, dt=SIM_STEP)
    t_sim = sim["t"].to_numpy(dtype=float)
    theta_sim = sim["theta"].to_numpy(dtype=float)
    rate_sim = sim["theta_d"].to_numpy(dtype=float)
    if measured[2]:  # the log ends before its fastest point: the simulation too
        departure = _departure(t_sim, theta_sim, float(theta_sim[0]))
        keep = t_sim <= departure + (t[-1] - _departure(t, theta, rest))
        t_sim, theta_sim, rate_sim = t_sim[keep], theta_sim[keep], rate_sim[keep]
    simulated = _stretch(t_sim, theta_sim, float(theta_sim[0]), rate=rate_sim)
    sweep, duration, _ = measured
    sweep_sim, duration_sim, _ = simulated
    low, high = band
    for what, got, want, unit, factors, option in (
            ("sweep from rest", sweep, sweep_sim, "°",
             {180 / math.pi: ("degrees read as rad", "deg"),
              math.pi / 180: ("rad read as degrees", "rad")}, "angle_unit"),
            ("time from its departure", duration, duration_sim, " s", _time_factors(log),
             "time_unit")):
        ratio = got / want if want > 0 else math.inf
        if low <= ratio <= high:
            continue
        likely = [why for f, why in factors.items() if 0.7 <= ratio / f <= 1.4]
        hint = (f": {likely[0][0]}? State the unit: {Option(option, likely[0][1])}" if likely else
                "; is the scene the engine filmed, and the log's unit right?")
        raise TrebuchetInputError(
            f"{name}: the beam's {what} to its fastest point is "
            f"{got:.4g}{unit}, the scene's {want:.4g}{unit} ({ratio:.3g}×, outside "
            f"{low:g}-{high:g}×){hint}")
    note = (f"the log's swing is the scene's: the beam sweeps {sweep:.4g}° (scene "
            f"{sweep_sim:.4g}°) from rest to its fastest point, {duration:.4g} s (scene "
            f"{duration_sim:.4g} s) after leaving rest by {DEPARTURE_DEG:g}°")
    sling = _sling_in_the_trough(log, scene, rest, band)
    if sling:
        note += f"; {sling}"
    return SceneCheck(True, sweep, sweep_sim, duration, duration_sim, note)


#: The stretch of the beam's rise over which the projectile is dragged along the trough:
#: the spigot risen by these shares of L1 from rest (before any engine's lift-off).
TROUGH_RISE = (0.05, 0.3)
#: Fewest frames of that stretch for the sling's length to be measured.
TROUGH_FRAMES = 5


def _sling_in_the_trough(log: pd.DataFrame, scene: Scene, rest: float,
                         band: tuple[float, float]) -> str | None:
    """The sling's length the log shows while the projectile is dragged along the trough,
    against the scene's L4 (an error outside ``band``); None when the log does not show it.

    In the trough the projectile lies at height 0, so the spigot's height (the scene's H
    and L1, the log's θ) equals ``−L4 sin φ`` (the log's φ): over the first rise of the
    beam (:data:`TROUGH_RISE`) the least-squares ``L4 = −Σ h sin φ / Σ sin² φ``. A scene
    whose sling cannot reach the trough from there (a 1 mm sling on a shot with a 5.5 m
    one) is no engine of this log: its loads would be missing (NaN) while in the trough."""
    if scene.projectile != "trough":
        return None
    e, s = scene.engine, scene.start
    t = log["t"].to_numpy(dtype=float)
    theta = log["theta"].to_numpy(dtype=float)
    phi = log["phi"].to_numpy(dtype=float)
    rise = e.L1 * (np.sin(theta) - math.sin(rest))
    h = s.H + e.L1 * math.sin(s.theta) + rise     # the spigot's height, rest as the scene's
    low, high = (f * e.L1 for f in TROUGH_RISE)
    first = np.flatnonzero(rise > high)
    end = first[0] if first.size else t.size
    use = np.isfinite(h) & np.isfinite(phi) & (rise >= low) & (np.arange(t.size) < end)
    if use.sum() < TROUGH_FRAMES:
        return None
    sin_phi = np.sin(phi[use])
    length = float(-np.sum(h[use] * sin_phi) / np.sum(sin_phi * sin_phi))
    ratio = length / e.L4
    rows = read_log_info(log).lines if read_log_info(log) is not None else None
    where = (f"rows {rows[use][0]}-{rows[use][-1]}" if rows is not None and len(rows) == t.size
             else f"t = {t[use][0]:.4g}-{t[use][-1]:.4g} s")
    if not band[0] <= ratio <= band[1]:
        raise TrebuchetInputError(
            f"{_name(log)}: the scene's [engine] L4 = {e.L4:g} m is not this log's sling: "
            f"while the beam first rises ({where}) its θ and φ drag the projectile along the "
            f"trough as a sling of {length:.3g} m does ({ratio:.3g}× L4, outside "
            f"{band[0]:g}-{band[1]:g}×, with the scene's H and L1); is the scene the engine "
            "filmed?")
    return (f"in the trough the sling drags the projectile as one of {length:.3g} m does "
            f"(scene L4 = {e.L4:g} m)")


def _rest_window(t: np.ndarray) -> int:
    """Frames taken as the engine at rest: the first :data:`REST_TIME` s, at least
    :data:`REST_FRAMES` and at most a tenth of the log (a time 1000 times too short)."""
    return max(REST_FRAMES, min(int(np.searchsorted(t, t[0] + REST_TIME)), t.size // 10))


def _not_at_rest(t: np.ndarray, theta: np.ndarray) -> str | None:
    """Why the log shows no departure from rest (None when it does): θ drifts over the
    first frames (the mean of their second half against their first) by more than
    :data:`REST_SHARE` of its whole sweep, or never leaves rest."""
    n = _rest_window(t)
    if theta.size < 2 * n:
        return f"fewer than {2 * n} frames with theta"
    first = theta[:n]
    drift = abs(float(np.mean(first[n // 2:]) - np.mean(first[:n // 2])))
    if drift > REST_SHARE * float(np.ptp(theta)):
        return (f"the log does not start at rest (theta drifts by {math.degrees(drift):.3g}° "
                f"over its first {t[n - 1] - t[0]:.3g} s)")
    rest = float(np.median(first))
    if not (np.abs(theta - rest) > math.radians(DEPARTURE_DEG)).any():
        return f"the beam never leaves its rest pose by {DEPARTURE_DEG:g}°"
    return None


def _name(log: pd.DataFrame) -> str:
    info = read_log_info(log)
    return Path(info.source).name if info is not None else "log"


def _time_factors(log: pd.DataFrame) -> dict[float, tuple[str, str]]:
    """Factor by which a wrong time unit stretches the swing: (what happened, the unit)."""
    out = {1000.0: ("ms read as s", "ms"), 1e-3: ("s read as ms", "s"),
           1e6: ("µs read as s", "us")}
    info = read_log_info(log)
    if info is not None and info.fps:
        out[float(info.fps)] = ("frame numbers read as s", "frames")
        out[1.0 / float(info.fps)] = ("s read as frame numbers", "s")
    return out


def _departure(t: np.ndarray, theta: np.ndarray, rest: float) -> float:
    """The time θ first lies :data:`DEPARTURE_DEG` from ``rest`` (linear between frames)."""
    target = math.radians(DEPARTURE_DEG)
    k = int(np.argmax(np.abs(theta - rest) > target))
    if k == 0:
        return float(t[0])
    a, b = abs(theta[k - 1] - rest), abs(theta[k] - rest)
    return float(t[k - 1] + (t[k] - t[k - 1]) * (target - a) / (b - a) if b > a else t[k])


def _stretch(t: np.ndarray, theta: np.ndarray, rest: float, rate: np.ndarray | None = None
             ) -> tuple[float, float, bool]:
    """(sweep in deg from ``rest`` to the fastest point, time in s from the departure to it,
    whether the fastest point is the log's end); dθ/dt from a local fit to ``theta``
    (after a running median over :data:`OUTLIER_FRAMES` frames, against a mislocated
    point) unless ``rate`` gives it. A fastest point within the two filters' half-widths
    of the last frame cannot be told from the end (a stress-grid log whose spigot was lost
    mid-swing at 60 fps peaked 4 frames before its end, lagging the truth by 6°: its
    sweep was compared with the whole swing's and the scene refused)."""
    edge = 1
    if rate is None:
        theta = median_filter(theta, size=OUTLIER_FRAMES, mode="nearest")
        rate = _rate(theta, t)
        edge = OUTLIER_FRAMES // 2 + _rate_width(t, theta.size) // 2
    departure = _departure(t, theta, rest)
    fastest = int(np.argmax(np.where(t >= departure, np.abs(rate), -np.inf)))
    return (math.degrees(abs(theta[fastest] - rest)), float(t[fastest] - departure),
            fastest >= t.size - 1 - edge)


def _rate(theta: np.ndarray, t: np.ndarray) -> np.ndarray:
    """dθ/dt from a Savitzky-Golay fit (quadratic over ~:data:`RATE_WINDOW` s, at most a
    fifth of the log): the beam's speed peaks over a tenth of a second, the noise's over a
    frame."""
    width = _rate_width(t, theta.size)
    if width > theta.size:
        return np.gradient(theta, t)
    return savgol_filter(theta, width, 2, deriv=1, delta=period_of(t))


def period_of(t: np.ndarray) -> float:
    """The frame interval (s): the median positive step of ``t`` (1 where there is none)."""
    steps = np.diff(t)
    return float(np.median(steps[steps > 0])) if (steps > 0).any() else 1.0


def _rate_width(t: np.ndarray, n: int) -> int:
    """Frames (odd, at least 5) of :func:`_rate`'s fit: ~:data:`RATE_WINDOW` s, at most a
    fifth of the ``n`` frames."""
    width = min(int(round(RATE_WINDOW / period_of(t))), n // 5)
    return max(5, width) | 1
