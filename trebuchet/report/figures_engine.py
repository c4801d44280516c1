"""Stick drawings of the engine at one instant (the paper's figure of configurations).

The pose comes from a frame's angles (``theta``, ``psi``, ``phi``, rad) and the
projectile's position (``x_m``, ``y_m``, m); the points of the beam follow from the
scene's lengths with the unit vectors of :mod:`trebuchet.model.kinematics`. Origin on
the ground under the pivot, lengths in m.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from matplotlib.axes import Axes

from trebuchet.model import kinematics as kin
from trebuchet.model.scene import Scene
from trebuchet.model.timeline import shot_events, shot_time, shot_window

__all__ = ["engine_points", "greatest_bending_time", "draw_engine"]


def engine_points(frame: pd.DataFrame, t: float, scene: Scene) -> dict[str, np.ndarray]:
    """Positions (m) of pivot, hinge, spigot, counterweight and projectile at time ``t``
    (s after the trigger), interpolated between the frame's rows; each a (2,) array.
    The projectile is NaN where the frame has no position for it."""
    e, H = scene.engine, scene.start.H
    ts = shot_time(frame)
    at = {}
    for col in ("theta", "psi", "phi", "x_m", "y_m"):
        y = frame[col].to_numpy(dtype=float)
        ok = np.isfinite(y)
        at[col] = float(np.interp(t, ts[ok], y[ok])) if ok.any() else math.nan
    pivot = np.array([0.0, H])
    hinge = kin.hinge_position(np.array(at["theta"]), e, H)
    spigot = kin.spigot_position(np.array(at["theta"]), e, H)
    weight = kin.counterweight_position(np.array(at["theta"]), np.array(at["psi"]), e, H)
    return {"pivot": pivot, "hinge": hinge, "spigot": spigot, "counterweight": weight,
            "projectile": np.array([at["x_m"], at["y_m"]])}


def greatest_bending_time(frame: pd.DataFrame) -> tuple[float, float]:
    """Time (s after the trigger) and value (N) of the greatest bending load
    ``|F_R·e_θ⊥|`` up to release."""
    win = shot_window(frame)
    load = win["F_R_perp"].abs().to_numpy(dtype=float)
    if not np.isfinite(load).any():
        raise ValueError("the frame has no finite F_R_perp up to release")
    i = int(np.nanargmax(load))
    return float(shot_time(win)[i]), float(load[i])


def draw_engine(ax: Axes, frame: pd.DataFrame, t: float, scene: Scene, *, measured: bool,
                label: str) -> None:
    """Draw the engine's pose at ``t`` (s after the trigger): trestle, beam, counterweight arm
    and weight, sling and projectile, and the projectile's path up to ``t`` (dotted).
    Predicted poses are drawn in colour, measured ones in grey dashes."""
    p = engine_points(frame, t, scene)
    ls = "--" if measured else "-"
    beam_c, arm_c, sling_c = ("0.45", "0.45", "0.45") if measured else ("#8c564b", "#1f77b4",
                                                                      "#2ca02c")
    # trestle: two legs from the ground to the pivot
    legs = 0.35 * p["pivot"][1]
    ax.plot([-legs, 0, legs], [0, p["pivot"][1], 0], color="0.6", lw=1.5, ls=ls)
    ax.plot(*np.column_stack([p["hinge"], p["spigot"]]), color=beam_c, lw=3.5, ls=ls,
            label=f"{label}: beam")
    ax.plot(*np.column_stack([p["hinge"], p["counterweight"]]), color=arm_c, lw=2, ls=ls)
    ax.plot(*p["counterweight"], "s", ms=14, mfc="none" if measured else arm_c, mec=arm_c)
    ax.plot(*p["pivot"], "o", ms=6, color="black")
    # the projectile's path up to t; the sling while it holds the projectile
    ts = shot_time(frame)
    upto = (ts >= 0) & (ts <= t)
    ax.plot(frame["x_m"].to_numpy()[upto], frame["y_m"].to_numpy()[upto], ":", color=sling_c,
            lw=1)
    if np.isfinite(p["projectile"]).all():
        release = shot_events(frame).get("release")
        if release is None or t <= release * (1 + 1e-12):
            ax.plot(*np.column_stack([p["spigot"], p["projectile"]]), color=sling_c, lw=1,
                    ls=ls)
        ax.plot(*p["projectile"], "o", ms=6, color=sling_c)
