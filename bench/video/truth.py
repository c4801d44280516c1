"""The simulated shot a video films: frame times, the truth table, and point positions.

The video starts ``rest`` s before the trigger (the engine at rest at its start pose) and
ends ``after`` s after the release. Frame ``k`` is exposed from ``k/fps − shutter/2`` to
``k/fps + shutter/2`` (log time, s): the frame's time is the middle of its exposure, so a
marker blurred by the shutter is centred on the truth at the frame's time (to the
curvature of its path).

The truth table is :func:`trebuchet.simulate` at the frame times (s after the trigger),
with the rest rows before the trigger: the start pose, no motion, phase 0, and the static
loads of the first phase (:func:`trebuchet.forces`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

import trebuchet as tb
from trebuchet.ingest.synthetic.simulated_log import shot_truth
from trebuchet.model.kinematics import counterweight_position, hinge_position, spigot_position

__all__ = ["Filming", "POINTS", "shot_events", "frame_times", "truth_table", "engine_points",
           "exposure_times", "exposed_points"]

#: The tracked points, in the order of every (…, 5, 2) position array.
POINTS = ("pivot", "spigot", "hinge", "counterweight", "projectile")



@dataclass(frozen=True)
class Filming:
    """When the camera runs: ``fps`` (1/s), ``shutter`` (exposure, s, at most 1/fps), ``rest``
    (s filmed before the trigger) and ``after`` (s filmed after the release)."""

    fps: float
    shutter: float
    rest: float = 0.3
    after: float = 0.3

    def __post_init__(self) -> None:
        if not 0.0 < self.shutter <= 1.0 / self.fps + 1e-12:
            raise ValueError(f"shutter {self.shutter:g} s must lie in (0, 1/fps]")


def shot_events(scene: tb.Scene) -> dict[str, float]:
    """Lift-off and release (s after the trigger) of a scene's shot."""
    return dict(tb.simulate(scene, t_eval=[0.0]).attrs["events"])


def frame_times(scene: tb.Scene, filming: Filming) -> np.ndarray:
    """Log times (s) of the frames: ``k / fps`` from the first frame (the trigger at
    ``filming.rest``) to ``filming.after`` s after the release."""
    release = shot_events(scene)["release"]
    n = int(math.floor((filming.rest + release + filming.after) * filming.fps + 1e-9)) + 1
    return np.arange(n) / filming.fps


def truth_table(scene: tb.Scene, t: np.ndarray, trigger: float, after: float) -> pd.DataFrame:
    """Every column of :func:`trebuchet.simulate` at log times ``t`` (s) for a trigger at
    ``trigger`` (s), plus ``t_shot`` (s after the trigger); rest rows before the trigger
    (phase 0, no motion, static loads). ``attrs["events"]``: trigger, lift-off, release in
    log time (s)."""
    return shot_truth(scene, t, trigger, after)


def engine_points(scene: tb.Scene, table: pd.DataFrame) -> np.ndarray:
    """World positions (m, x right, y up) of :data:`POINTS` in the rows of a simulated table
    (``theta``, ``psi``, ``x_m``, ``y_m``), shape (n, 5, 2): the projectile at ``x_m, y_m``
    (in the trough, the sling, and in flight after the release)."""
    e, H = scene.engine, scene.start.H
    th, ps = table["theta"].to_numpy(), table["psi"].to_numpy()
    n = th.size
    pivot = np.array([np.zeros(n), np.full(n, H)])
    parts = [pivot, spigot_position(th, e, H), hinge_position(th, e, H),
             counterweight_position(th, ps, e, H),
             np.array([table["x_m"].to_numpy(), table["y_m"].to_numpy()])]
    return np.stack(parts, axis=1).transpose(2, 1, 0)


def exposure_times(t: np.ndarray, shutter: float, n_sub: int) -> np.ndarray:
    """Sub-frame times (s), shape (n_frames, n_sub): the midpoints of ``n_sub`` equal slices of
    each frame's exposure."""
    offsets = (np.arange(n_sub) + 0.5) / n_sub * shutter - shutter / 2.0
    return np.asarray(t, dtype=float)[:, None] + offsets[None, :]


def exposed_points(scene: tb.Scene, t: np.ndarray, trigger: float, shutter: float,
                   n_sub: int, after: float) -> np.ndarray:
    """World positions (m) of :data:`POINTS` at the sub-frame times of every frame, shape
    (n_frames, n_sub, 5, 2); before the trigger the start pose."""
    sub = exposure_times(t, shutter, n_sub)
    run = tb.simulate(scene, t_eval=np.clip(sub.ravel() - trigger, 0.0, None),
                      after_release=after + shutter)
    return engine_points(scene, run).reshape(sub.shape + (len(POINTS), 2))
