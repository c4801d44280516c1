"""The scene against the log: is the engine of the scene file the engine filmed?

:func:`~trebuchet.ingest.logs.scene_check.scene_check` catches a wrong unit (a factor of 57,
1000 or the frame rate). A wrong engine passes it: the backyard sample read with the
paper's scene swings in 0.56 s against the scene's 0.72 s, starts 5° off the scene's
start pose, and its loads come out with the paper's masses (a 590 kN m torque peak for a
100 kg engine). :func:`scene_match` compares the smoothed log with the scene's simulation
on what the camera cannot change:

- the **start pose**: the beam's angle at rest against the scene's start angle, less the
  counterweight's tilt from plumb (a camera's roll turns every angle alike; the hanging
  counterweight is plumb whatever the engine);
- the **swing time**: the time the beam takes from 20° to 70° past its rest angle (the
  trigger's detection, a frame or two, drops out of a difference of times);
- the **peak rate**: the beam's fastest angular rate before the release.

On the shipped samples with their own scenes (7 logs: angle logs, Tracker, Kinovea,
DeepLabCut and both tracked videos) the swing times agree within 1.4 %, the peak rates
within 2 % and the start angles within 0.1°; the backyard log with the paper's scene:
0.79×, 1.62× and 5.1°. Beyond :data:`WARN_RATIO` (or :data:`POSE_DEG`) the scene and
the mismatch are named in a warning; beyond :data:`REFUSE_RATIO` the loads would be
another engine's and :func:`reconstruct` refuses (``ReconstructOptions.scene_mismatch``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from trebuchet.model.scene import Scene
from trebuchet.model.simulate import simulate

__all__ = ["SceneMatch", "scene_match", "WARN_RATIO", "REFUSE_RATIO", "POSE_DEG",
           "PAST_REST_DEG"]

#: A swing time or peak rate off by more than this factor (either way) warns...
WARN_RATIO = 1.07
#: ...and by more than this one is another engine's: refused.
REFUSE_RATIO = 1.33
#: The start angle off by more than this (°, beyond the camera's roll) warns.
POSE_DEG = 2.0
#: The beam is timed and its rate read where it passes these angles (°) past its rest
#: angle: the swing time is the time from the first to the last.
PAST_REST_DEG = (20.0, 45.0, 70.0)


@dataclass(frozen=True)
class SceneMatch:
    """The log against the scene: ``swing_ratio`` (the log's time from 20° to 70° past
    rest over the scene's; NaN where the log does not show it), ``rate_ratio`` (the log's
    peak beam rate over the scene's), ``pose_deg`` (the log's start angle less the
    scene's, beyond the camera's roll; NaN without a rest), ``roll_deg`` (the
    counterweight's tilt from plumb at rest); ``mismatch``: the sentence naming what
    differs (None: nothing beyond the bounds); ``refused``: the mismatch is beyond
    :data:`REFUSE_RATIO`."""

    swing_ratio: float
    rate_ratio: float
    pose_deg: float
    roll_deg: float
    mismatch: str | None
    refused: bool


def _crossings(t: np.ndarray, theta_deg: np.ndarray, rate: np.ndarray, rest: float
               ) -> tuple[np.ndarray, np.ndarray]:
    """Times (s) and rates (rad/s) at which the beam first passes each of
    :data:`PAST_REST_DEG` past ``rest`` (°), interpolated between samples (NaN where it
    does not)."""
    rise = theta_deg - rest
    times, rates = [], []
    for level in PAST_REST_DEG:
        k = np.flatnonzero(rise >= level)
        if k.size == 0 or k[0] == 0 or not np.isfinite(rise[k[0] - 1]):
            times.append(np.nan)
            rates.append(np.nan)
            continue
        i = int(k[0])
        f = (level - rise[i - 1]) / (rise[i] - rise[i - 1])
        times.append(t[i - 1] + f * (t[i] - t[i - 1]))
        rates.append(rate[i - 1] + f * (rate[i] - rate[i - 1]))
    return np.array(times), np.array(rates)


def _ratio_text(what: str, got: float, want: float, unit: str, ratio: float) -> str:
    return f"{what} {got:.3g}{unit} (the scene's {want:.3g}{unit}, {ratio:.2f}×)"


def scene_match(est: pd.DataFrame, scene: Scene, trigger: float | None,
                release: float | None = None) -> SceneMatch:
    """The smoothed log ``est`` (``t`` s, ``theta``, ``theta_d``, ``psi``; rad, rad/s)
    against the simulation of ``scene``; ``trigger`` (s, log time; None: the log starts
    in motion, nothing is compared) marks the rest before the swing. The rates are read
    where the beam passes 20°, 45° and 70° past rest, on its way up (not up to a release,
    which a tracker may put anywhere), and the worst of them counts; the swing time is the
    time between the first and the last of those. See the module doc. ``release`` is
    not used (kept for the callers' symmetry)."""
    nan = float("nan")
    if trigger is None:
        return SceneMatch(nan, nan, nan, nan, None, False)
    t = est["t"].to_numpy(dtype=float)
    theta = np.degrees(est["theta"].to_numpy(dtype=float))
    rate = est["theta_d"].to_numpy(dtype=float)
    sim = simulate(scene, dt=1e-3)
    held = sim["phase"].to_numpy() <= 2
    t_sim = sim["t"].to_numpy(dtype=float)[held]
    theta_sim = np.degrees(sim["theta"].to_numpy(dtype=float))[held]
    at_sim = _crossings(t_sim, theta_sim, sim["theta_d"].to_numpy(dtype=float)[held],
                        float(theta_sim[0]))
    at_rest = t <= trigger
    rest = float(np.nanmedian(theta[at_rest])) if np.isfinite(theta[at_rest]).any() else nan
    if not np.isfinite(rest):
        return SceneMatch(nan, nan, nan, nan, None, False)
    psi = np.degrees(est["psi"].to_numpy(dtype=float))[at_rest]
    roll = float(np.nanmedian(psi) - math.degrees(scene.start.psi)) \
        if np.isfinite(psi).any() else 0.0
    pose = rest - math.degrees(scene.start.theta) - roll
    after = t > trigger
    at_log = _crossings(t[after], theta[after], rate[after], rest)
    with np.errstate(invalid="ignore", divide="ignore"):
        rate_ratios = at_log[1] / at_sim[1]
        swing_ratio = float((at_log[0][-1] - at_log[0][0]) / (at_sim[0][-1] - at_sim[0][0]))
    finite = rate_ratios[np.isfinite(rate_ratios) & (rate_ratios > 0)]
    rate_ratio = float(finite[np.argmax(np.maximum(finite, 1 / finite))]) if finite.size \
        else nan
    parts = []
    offs = []
    k = int(np.argmax(np.where(np.isfinite(rate_ratios) & (rate_ratios > 0),
                               np.maximum(rate_ratios, 1 / rate_ratios), 0.0)))
    for what, ratio, got, want, unit in (
            (f"swings from {PAST_REST_DEG[0]:g}° to {PAST_REST_DEG[-1]:g}° past rest in",
             swing_ratio, at_log[0][-1] - at_log[0][0], at_sim[0][-1] - at_sim[0][0], " s"),
            (f"passes {PAST_REST_DEG[k]:g}° past rest at", rate_ratio, at_log[1][k],
             at_sim[1][k], " rad/s")):
        if np.isfinite(ratio) and ratio > 0:
            off = max(ratio, 1.0 / ratio)
            offs.append(off)
            if off > WARN_RATIO:
                parts.append(_ratio_text(what, got, want, unit, ratio))
    if abs(pose) > POSE_DEG:
        parts.append(f"starts with its beam at {math.degrees(scene.start.theta) + pose:.1f}° "
                     f"(the scene's {math.degrees(scene.start.theta):.1f}°, beyond the "
                     f"camera's roll of {roll:.1f}° that the hanging counterweight shows)")
    mismatch = None
    if parts:
        mismatch = (f"the log is not the engine of {scene.source}: it "
                    + "; it ".join(parts) + "; is the scene the engine filmed?")
    refused = len(offs) == 2 and min(offs) > REFUSE_RATIO ** 0.5 and max(offs) > REFUSE_RATIO
    return SceneMatch(swing_ratio, rate_ratio, pose, roll, mismatch, refused)
