"""A shot's time axis and events on a frame of the interface's columns.

A *frame* is a DataFrame of the interface's columns (docs/interface.md): a simulated run (``t``
is the time after the trigger) or a measured one (``t`` is the log's own time, ``t_shot`` the
time after the trigger). Its ``attrs["events"]`` holds the trigger, lift-off and release.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

__all__ = ["EVENT_NAMES", "shot_time", "shot_events", "shot_window"]

EVENT_NAMES = ("lift_off", "release")


def shot_time(frame: pd.DataFrame) -> np.ndarray:
    """Time after the trigger, s: ``t_shot`` for a measured log, else ``t`` shifted by the
    ``trigger`` event when the frame's ``attrs["events"]`` holds one, else ``t``."""
    if "t_shot" in frame.columns:
        return frame["t_shot"].to_numpy(dtype=float)
    t = frame["t"].to_numpy(dtype=float)
    trigger = (frame.attrs.get("events") or {}).get("trigger")
    return t - trigger if trigger is not None else t


def shot_events(frame: pd.DataFrame) -> dict[str, float]:
    """Lift-off and release in time after the trigger, s (only the events the frame knows)."""
    events = frame.attrs.get("events") or {}
    trigger = events.get("trigger")
    shift = trigger if trigger is not None and "t" in frame.columns else 0.0
    out: dict[str, float] = {}
    for name in EVENT_NAMES:
        value = events.get(name)
        if value is not None and math.isfinite(value):
            out[name] = float(value) - shift
    return out


def shot_window(frame: pd.DataFrame, until: str = "release") -> pd.DataFrame:
    """Rows from the trigger (time 0) up to the event ``until`` inclusive (all rows after the
    trigger when the frame does not know that event)."""
    t = shot_time(frame)
    keep = t >= 0.0
    end = shot_events(frame).get(until)
    if end is not None:
        keep &= t <= end * (1 + 1e-12)
    out = frame.loc[keep]
    out.attrs = dict(frame.attrs)
    return out
