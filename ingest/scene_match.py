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
           "SPAN_DEG"]

#: A swing time or peak rate off by more than this factor (either way) warns...
WARN_RATIO = 1.07
#: ...and by more than this one is another engine's: refused.
REFUSE_RATIO = 1.33
#: The start angle off by more than this (°, beyond the camera's roll) warns.
POSE_DEG = 2.0
#: The stretch of the swing timed: from the first to the second angle (°) past rest.
SPAN_DEG = (20.0, 70.0)


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


def _span(t: np.ndarray, theta_deg: np.ndarray, rest: float) -> float:
    """Time (s) from the first sample :data:`SPAN_DEG`\\[0] past ``rest`` to the first
    :data:`SPAN_DEG`\\[1] past it (NaN if not both reached)."""
    rise = theta_deg - rest
    a = np.flatnonzero(rise >= SPAN_DEG[0])
    b = np.flatnonzero(rise >= SPAN_DEG[1])
    return float(t[b[0]] - t[a[0]]) if a.size and b.size else float("nan")


def _ratio_text(what: str, got: float, want: float, unit: str, ratio: float) -> str:
    return f"{what} {got:.3g}{unit} (the scene's {want:.3g}{unit}, {ratio:.2f}×)"


def scene_match(est: pd.DataFrame, scene: Scene, trigger: float | None,
                release: float | None) -> SceneMatch:
    """The smoothed log ``est`` (``t`` s, ``theta``, ``theta_d``, ``psi``; rad, rad/s)
    against the simulation of ``scene``; ``trigger``, ``release`` (s, log time; None:
    not found) bound the swing. See the module doc."""
    t = est["t"].to_numpy(dtype=float)
    theta = np.degrees(est["theta"].to_numpy(dtype=float))
    rate = est["theta_d"].to_numpy(dtype=float)
    sim = simulate(scene, dt=1e-3)
    held = sim["phase"].to_numpy() <= 2
    t_sim = sim["t"].to_numpy(dtype=float)[held]
    theta_sim = np.degrees(sim["theta"].to_numpy(dtype=float))[held]
    rate_sim = float(np.max(sim["theta_d"].to_numpy(dtype=float)[held]))
    lo = -math.inf if trigger is None else trigger
    hi = math.inf if release is None else release
    swing = (t > lo) & (t <= hi) & np.isfinite(rate)
    rate_ratio = float(np.max(rate[swing]) / rate_sim) if swing.any() else float("nan")
    pose = roll = swing_ratio = float("nan")
    if trigger is not None:
        at_rest = t <= trigger
        rest = float(np.nanmedian(theta[at_rest])) if at_rest.any() else float("nan")
        if np.isfinite(rest):
            psi = np.degrees(est["psi"].to_numpy(dtype=float))[at_rest]
            roll = float(np.nanmedian(psi) - math.degrees(scene.start.psi)) \
                if np.isfinite(psi).any() else 0.0
            pose = rest - math.degrees(scene.start.theta) - roll
            span = _span(t[swing], theta[swing], rest)
            span_sim = _span(t_sim, theta_sim, float(theta_sim[0]))
            swing_ratio = span / span_sim if span_sim > 0 else float("nan")
    parts = []
    worst = 1.0
    for what, ratio, got, want, unit in (
            ("swings from 20° to 70° past rest in", swing_ratio,
             swing_ratio * _span(t_sim, theta_sim, float(theta_sim[0])),
             _span(t_sim, theta_sim, float(theta_sim[0])), " s"),
            ("turns its beam at up to", rate_ratio, rate_ratio * rate_sim, rate_sim, " rad/s")):
        if np.isfinite(ratio) and ratio > 0:
            off = max(ratio, 1.0 / ratio)
            worst = max(worst, off)
            if off > WARN_RATIO:
                parts.append(_ratio_text(what, got, want, unit, ratio))
    if np.isfinite(pose) and abs(pose) > POSE_DEG:
        parts.append(f"starts with its beam at {math.degrees(scene.start.theta) + pose:.1f}° "
                     f"(the scene's {math.degrees(scene.start.theta):.1f}°, beyond the "
                     f"camera's roll of {roll:.1f}° that the hanging counterweight shows)")
    mismatch = None
    if parts:
        mismatch = (f"the log is not the engine of {scene.source}: it "
                    + "; it ".join(parts) + "; is the scene the engine filmed?")
    return SceneMatch(swing_ratio, rate_ratio, pose, roll, mismatch, worst > REFUSE_RATIO)
