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
with both and a sentence for the notes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.errors import TrebuchetInputError
from trebuchet.ingest.logs.result import read_log_info
from trebuchet.model.scene import Scene, as_scene
from trebuchet.model.simulate import simulate

#: deg: θ's distance from its rest value that marks the beam's departure.
DEPARTURE_DEG = 2.0
#: Frames at the start of a log taken as the engine at rest (at most).
REST_FRAMES = 10
#: Broad band of the ratio measured / simulated, for the sweep and for the time.
BAND = (0.5, 2.0)
#: s: the simulation's output step.
SIM_STEP = 1e-4


@dataclass(frozen=True)
class SceneCheck:
    """The log's beam against the scene's simulation: sweep (deg) from rest to the fastest
    point, time (s) from departure to the fastest point; ``note`` says it in a sentence."""

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
    measured = _stretch(t[ok], theta[ok])
    if measured is None:
        raise TrebuchetInputError(
            f"{name}: the beam does not leave its rest pose by {DEPARTURE_DEG:g}° and reach a "
            "fastest point in the log; nothing to check against the scene")
    sim = simulate(scene, dt=SIM_STEP)
    simulated = _stretch(sim["t"].to_numpy(dtype=float), sim["theta"].to_numpy(dtype=float),
                         rest=float(sim["theta"].iloc[0]),
                         rate=sim["theta_d"].to_numpy(dtype=float))
    if simulated is None:
        raise TrebuchetInputError(f"{name}: the scene's beam does not swing")
    sweep, duration = measured
    sweep_sim, duration_sim = simulated
    low, high = band
    for what, got, want, unit, factors in (
            ("sweep from rest", sweep, sweep_sim, "°", {180 / math.pi: "degrees read as rad",
                                               math.pi / 180: "rad read as degrees"}),
            ("time from its departure", duration, duration_sim, " s", _time_factors(log))):
        ratio = got / want
        if low <= ratio <= high:
            continue
        likely = [why for f, why in factors.items() if 0.7 <= ratio / f <= 1.4]
        hint = (f": {likely[0]}? State the unit (time_unit= or angle_unit=, "
                "--time-unit or --angle-unit)" if likely else
                "; is the scene the engine filmed, and the log's unit right?")
        raise TrebuchetInputError(
            f"{name}: the beam's {what} to its fastest point is "
            f"{got:.4g}{unit}, the scene's {want:.4g}{unit} ({ratio:.3g}×, outside "
            f"{low:g}-{high:g}×){hint}")
    note = (f"the log's swing is the scene's: the beam sweeps {sweep:.4g}° (scene "
            f"{sweep_sim:.4g}°) from rest to its fastest point, {duration:.4g} s (scene "
            f"{duration_sim:.4g} s) after leaving rest by {DEPARTURE_DEG:g}°")
    return SceneCheck(sweep, sweep_sim, duration, duration_sim, note)


def _name(log: pd.DataFrame) -> str:
    info = read_log_info(log)
    return Path(info.source).name if info is not None else "log"


def _time_factors(log: pd.DataFrame) -> dict[float, str]:
    out = {1000.0: "ms read as s", 1e-3: "s read as ms", 1e6: "µs read as s"}
    info = read_log_info(log)
    if info is not None and info.fps:
        out[float(info.fps)] = "frame numbers read as s"
        out[1.0 / float(info.fps)] = "s read as frame numbers"
    return out


def _stretch(t: np.ndarray, theta: np.ndarray, rest: float | None = None,
             rate: np.ndarray | None = None) -> tuple[float, float] | None:
    """(sweep in deg from rest to the fastest point, time in s from the departure to it);
    dθ/dt from ``theta`` lightly smoothed unless ``rate`` gives it."""
    if t.size < 5:
        return None
    if rest is None:
        rest = float(np.median(theta[:REST_FRAMES]))
    gone = np.nonzero(np.abs(theta - rest) > math.radians(DEPARTURE_DEG))[0]
    if not gone.size or gone[0] == 0:
        return None
    k = int(gone[0])
    # the departure between the two frames around it, linearly
    a, b = abs(theta[k - 1] - rest), abs(theta[k] - rest)
    target = math.radians(DEPARTURE_DEG)
    t_dep = t[k - 1] + (t[k] - t[k - 1]) * (target - a) / (b - a) if b > a else t[k]
    if rate is None:
        rate = np.gradient(_smoothed(theta, t), t)
    after = np.arange(t.size) >= k
    if not after.any():
        return None
    fastest = int(np.argmax(np.where(after, np.abs(rate), -np.inf)))
    if fastest <= k - 1 or fastest >= t.size - 1:
        return None
    return (math.degrees(abs(theta[fastest] - rest)), float(t[fastest] - t_dep))


def _smoothed(theta: np.ndarray, t: np.ndarray) -> np.ndarray:
    """θ lightly smoothed (a running mean over ~10 ms) so that its derivative's peak is the
    beam's, not the noise's."""
    steps = np.diff(t)
    period = float(np.median(steps[steps > 0])) if (steps > 0).any() else 1.0
    width = max(1, int(round(0.01 / period)))
    if width < 3:
        return theta
    kernel = np.ones(width) / width
    padded = np.pad(theta, (width // 2, width - 1 - width // 2), mode="edge")
    return np.convolve(padded, kernel, mode="valid")
