"""Drawing primitives shared by the figures: the shot's time axis, lines for predicted
curves, ±2 sd bands for measured ones, and the full points at lift-off and release.

A *frame* is a DataFrame of the contract's columns: a simulated run (``t`` is the time
after the trigger) or a measured one (``t`` is the log's own time, ``t_shot`` the time
after the trigger, and every quantity ``X`` has its standard deviation in ``X_sd``).
Nothing here computes physics: every value drawn is a column of the frame, scaled to the
paper's units (forces over m·g or M·g, ms, kN m, kW, kJ).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from trebuchet.ingest.uncertainty import BAND_SD
from trebuchet.model.timeline import shot_events, shot_time

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = [
    "event_values",
    "draw_curve",
    "mark_events",
    "label_time_axis",
    "legend",
]

def event_values(frame: pd.DataFrame, column: str | Callable[[pd.DataFrame], np.ndarray]
                 ) -> dict[str, tuple[float, float]]:
    """``{event: (time s, value)}`` of a column (or of a function of the frame) at lift-off
    and release, interpolated between rows. An event up to one row step beyond the first or
    last finite row (a measured log's release between two frames, after the window's last
    frame) takes that row's value."""
    t = shot_time(frame)
    y = _values(frame, column)
    ok = np.isfinite(y)
    out: dict[str, tuple[float, float]] = {}
    if not ok.any():
        return out
    ts, ys = t[ok], y[ok]
    step = float(np.median(np.diff(ts))) if ts.size > 1 else 0.0
    for name, te in shot_events(frame).items():
        if ts[0] - step <= te <= ts[-1] + step:
            out[name] = (te, float(np.interp(te, ts, ys)))
    return out


def _values(frame: pd.DataFrame, column: str | Callable[[pd.DataFrame], np.ndarray]
            ) -> np.ndarray:
    if callable(column):
        return np.asarray(column(frame), dtype=float)
    return frame[column].to_numpy(dtype=float)


def draw_curve(ax: Axes, frame: pd.DataFrame, column: str, *, scale: float, color: str,
               label: str, measured: bool, absolute: bool = False) -> None:
    """One quantity against time in ms: a line for a predicted frame, the mean and a
    ±2 sd band for a measured one (a line alone when the frame has no ``column_sd``).

    ``scale`` divides the column (m·g, M·g, 1e3 for kN m, kW, kJ); ``absolute`` draws the
    magnitude of a signed component.
    """
    t_ms = shot_time(frame) * 1e3
    y = frame[column].to_numpy(dtype=float)
    if absolute:
        y = np.abs(y)
    y = y / scale
    if not measured:
        ax.plot(t_ms, y, color=color, lw=1.6, label=f"{label} predicted")
        return
    sd_col = f"{column}_sd"
    if sd_col in frame.columns:
        sd = frame[sd_col].to_numpy(dtype=float) / scale
        band_label = f"{label} measured ±{BAND_SD:g} sd"
        ax.fill_between(t_ms, y - BAND_SD * sd, y + BAND_SD * sd, color=color, alpha=0.25,
                        lw=0, label=band_label)
        # the dashed mean joins the band's legend entry (legend())
        ax.plot(t_ms, y, color=color, lw=0.8, ls="--", gid=band_label)
    else:
        ax.plot(t_ms, y, color=color, lw=1.0, ls="--", label=f"{label} measured (no sd)")


def mark_events(ax: Axes, frame: pd.DataFrame, column: str, *, scale: float, color: str,
                absolute: bool = False) -> None:
    """Full points on a time curve at lift-off and release (the paper's convention)."""
    def fn(f: pd.DataFrame) -> np.ndarray:
        y = f[column].to_numpy(dtype=float)
        return np.abs(y) if absolute else y

    for te, value in event_values(frame, fn).values():
        ax.plot(te * 1e3, value / scale, "o", ms=5, mfc=color, mec="black", mew=0.6,
                zorder=5)


def legend(ax: Axes, **kwargs) -> None:
    """The axes' legend, a measured band's entry drawn with its dashed mean line on it (the
    line carries the band's label as its ``gid``), each label once."""
    from matplotlib.legend_handler import HandlerTuple

    handles, labels = ax.get_legend_handles_labels()
    lines = {line.get_gid(): line for line in ax.get_lines() if line.get_gid()}
    seen: dict[str, object] = {}
    for handle, label in zip(handles, labels, strict=True):
        if label not in seen:
            seen[label] = (handle, lines[label]) if label in lines else handle
    ax.legend(list(seen.values()), list(seen), handler_map={tuple: HandlerTuple(ndivide=1)},
              fontsize="small", **kwargs)


def label_time_axis(ax: Axes) -> None:
    """x label for time after the trigger, in ms."""
    ax.set_xlabel("time after trigger t (ms)")
