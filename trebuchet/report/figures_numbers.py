"""The key numbers that go with the figures: events, peaks with their times, the flight.

Each function takes a frame of the contract's columns (simulated or measured) and returns
a small DataFrame for a report. Values come from the frame's columns and ``attrs``; nothing
is recomputed. Peaks are taken from the trigger to release, in the paper's units (m·g,
M·g, kN m, kW, kJ) with the SI value beside them.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from trebuchet.model.scene import Scene
from trebuchet.model.timeline import shot_events, shot_time, shot_window
from trebuchet.report.figures_draw import event_values

__all__ = ["event_table", "peak_table", "flight_table"]


def event_table(frame: pd.DataFrame) -> pd.DataFrame:
    """Columns ``event``, ``t_ms`` (after the trigger): lift-off and release as known."""
    ev = shot_events(frame)
    return pd.DataFrame({"event": list(ev), "t_ms": [1e3 * v for v in ev.values()]})


def _row(quantity: str, value_si: float, scale: float, unit: str, si_unit: str,
         t: float) -> dict[str, object]:
    return {"quantity": quantity, "value": value_si / scale, "unit": unit,
            "t_ms": 1e3 * t, "value_SI": value_si, "SI_unit": si_unit}


def peak_table(frame: pd.DataFrame, scene: Scene) -> pd.DataFrame:
    """Peaks (with their times) and values at release of the quantities the paper quotes.

    Columns: ``quantity``, ``value`` (in ``unit``: m·g, M·g, kN m, kW, kJ, %), ``t_ms``
    (time after the trigger), ``value_SI`` (N, N m, W, J), ``SI_unit``. A quantity whose
    column the frame lacks is left out.
    """
    e = scene.engine
    mg, Mg = e.m * scene.g, e.M * scene.g
    win = shot_window(frame)
    t = shot_time(win)
    rows: list[dict[str, object]] = []

    def extreme(col: str, label: str, scale: float, unit: str, si: str, how: str = "max",
                absolute: bool = False) -> None:
        if col not in win.columns or len(win) == 0:
            return
        y = win[col].to_numpy(dtype=float)
        y = np.abs(y) if absolute else y
        if not np.isfinite(y).any():
            return
        i = int(np.nanargmax(y) if how == "max" else np.nanargmin(y))
        rows.append(_row(label, float(y[i]), scale, unit, si, float(t[i])))

    def at_release(col: str, label: str, scale: float, unit: str, si: str) -> None:
        if col not in frame.columns:
            return
        hit = event_values(frame, col).get("release")
        if hit is not None:
            rows.append(_row(label, hit[1], scale, unit, si, hit[0]))

    at_release("F_S_abs", "sling tension F_S at release", mg, "m·g", "N")
    extreme("F_S_abs", "greatest sling tension F_S", mg, "m·g", "N")
    extreme("F_S_perp", "greatest F_S across the beam", mg, "m·g", "N")
    extreme("F_H_abs", "greatest hinge force |F_H|", Mg, "M·g", "N")
    extreme("F_R_abs", "greatest pivot reaction |F_R|", Mg, "M·g", "N")
    extreme("F_R_perp", "greatest bending load |F_R⊥|", Mg, "M·g", "N", absolute=True)
    extreme("F_R_x", "greatest F_R,x (away from target)", Mg, "M·g", "N")
    extreme("F_R_x", "least F_R,x (toward target)", Mg, "M·g", "N", how="min")
    extreme("torque", "greatest torque N", 1e3, "kN m", "N m")
    extreme("torque", "least torque N", 1e3, "kN m", "N m", how="min")
    extreme("P_m", "greatest power on projectile P_m", 1e3, "kW", "W")
    extreme("P_M", "least power on counterweight P_M", 1e3, "kW", "W", how="min")
    extreme("E_beam", "greatest beam energy E_beam", 1e3, "kJ", "J")
    at_release("E_m", "projectile energy E_m at release", 1e3, "kJ", "J")
    at_release("E_loss_pivot", "heat made at the pivot E_loss_pivot by release", 1e3, "kJ",
               "J")
    at_release("E_loss_hinge", "heat made at the hinge E_loss_hinge by release", 1e3, "kJ",
               "J")
    delta_u = scene.delta_U
    shares = ("greatest beam energy E_beam", "projectile energy E_m at release",
              "heat made at the pivot E_loss_pivot by release",
              "heat made at the hinge E_loss_hinge by release")
    if delta_u:
        for r in list(rows):
            if r["quantity"] in shares:
                rows.append({"quantity": f"{r['quantity']} / ΔU",
                             "value": 100.0 * float(r["value_SI"]) / delta_u, "unit": "%",
                             "t_ms": r["t_ms"], "value_SI": float(r["value_SI"]) / delta_u,
                             "SI_unit": "1"})
    return pd.DataFrame(rows, columns=["quantity", "value", "unit", "t_ms", "value_SI",
                                       "SI_unit"])


def flight_table(frame: pd.DataFrame) -> pd.DataFrame:
    """The release state and flight of ``attrs["flight"]`` (simulated runs), with units:
    columns ``quantity``, ``value``, ``unit``. Empty when the frame has no flight."""
    fl = frame.attrs.get("flight") or {}
    spec = [("release_height", "release height", 1.0, "m"),
            ("release_x", "release behind the pivot (+x)", 1.0, "m"),
            ("release_speed", "release speed", 1.0, "m/s"),
            ("release_angle", "release angle above horizontal", math.pi / 180, "deg"),
            ("range", "range from the pivot (vacuum)", 1.0, "m"),
            ("apex_height", "apex height", 1.0, "m"),
            ("time_of_flight", "time of flight", 1.0, "s"),
            ("impact_speed", "impact speed", 1.0, "m/s")]
    rows = [{"quantity": label, "value": float(fl[key]) / scale, "unit": unit}
            for key, label, scale, unit in spec if key in fl]
    return pd.DataFrame(rows, columns=["quantity", "value", "unit"])
