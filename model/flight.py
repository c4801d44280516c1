"""The projectile's flight after release: in vacuum (the paper) or with quadratic air drag.

Origin on the ground under the pivot; the projectile is thrown toward −x, so
the range counts along −x. Positions in m, speeds in m/s, times in s, angles
in rad.
"""

from __future__ import annotations

import math

import numpy as np

from trebuchet.model.scene import Flight

__all__ = ["vacuum_flight", "drag_flight", "flight_summary", "projectile_in_flight",
           "drag_constant"]


def drag_constant(flight: Flight, m: float) -> float:
    """``k = ρ C_d A / (2 m)`` of the drag deceleration ``a = −k |v| v``, 1/m
    (sphere of the flight's diameter, projectile mass ``m`` in kg)."""
    area = math.pi * flight.diameter ** 2 / 4.0
    return flight.air_density * flight.drag_coefficient * area / (2.0 * m)


def _release_summary(release: dict[str, float]) -> dict[str, float]:
    return {
        "release_time": release["t"],
        "release_x": release["x"],
        "release_height": release["y"],
        "release_speed": math.hypot(release["vx"], release["vy"]),
        "release_angle": math.atan2(release["vy"], -release["vx"]),
    }


def vacuum_flight(release: dict[str, float], g: float) -> dict[str, float]:
    """Range, apex, time of flight and impact of a ballistic flight from the release state.

    Parameters
    ----------
    release : dict
        ``t`` (s), ``x``, ``y`` (m), ``vx``, ``vy`` (m/s) at release.
    g : float
        Gravity, m/s².

    Returns
    -------
    dict with ``release_time`` (s), ``release_x``, ``release_height`` (m),
    ``release_speed`` (m/s), ``release_angle`` (rad above horizontal, toward −x),
    ``time_of_flight`` (s to the ground), ``range`` (m from the pivot, along −x),
    ``range_from_release`` (m), ``apex_height`` (m), ``impact_speed`` (m/s),
    ``impact_angle`` (rad below horizontal).
    """
    x, y, vx, vy = release["x"], release["y"], release["vx"], release["vy"]
    if y < 0.0:
        raise ValueError(f"release below ground (y = {y:.4g} m)")
    t_f = (vy + math.sqrt(vy * vy + 2.0 * g * y)) / g
    x_impact = x + vx * t_f
    vy_impact = vy - g * t_f
    apex = y + (vy * vy / (2.0 * g) if vy > 0.0 else 0.0)
    return {
        **_release_summary(release),
        "time_of_flight": float(t_f),
        "range": float(-x_impact),
        "range_from_release": float(x - x_impact),
        "apex_height": float(apex),
        "impact_speed": math.hypot(vx, vy_impact),
        "impact_angle": math.atan2(-vy_impact, abs(vx)),
    }


def _drag_rhs(k: float, g: float):
    def rhs(t: float, s: np.ndarray) -> list[float]:
        vx, vy = s[2], s[3]
        speed = math.hypot(vx, vy)
        return [vx, vy, -k * speed * vx, -g - k * speed * vy]

    return rhs


def _solve_drag(release: dict[str, float], g: float, k: float, t_max: float):
    def ground(t: float, s: np.ndarray) -> float:
        return s[1]

    ground.terminal = True  # type: ignore[attr-defined]
    ground.direction = -1.0  # type: ignore[attr-defined]
    y0 = [release["x"], release["y"], release["vx"], release["vy"]]
    from scipy.integrate import solve_ivp  # only drag needs it (import costs ~0.5 s)

    return solve_ivp(_drag_rhs(k, g), (release["t"], release["t"] + t_max), y0, method="DOP853",
                     rtol=1e-10, atol=1e-9, dense_output=True, events=ground)


def drag_flight(release: dict[str, float], g: float, flight: Flight, m: float) -> dict[str, float]:
    """As :func:`vacuum_flight`, for quadratic drag ``a = −k |v| v − g e_y`` (``k`` from
    :func:`drag_constant`), integrated to the ground."""
    k = drag_constant(flight, m)
    t_guess = 2.0 * vacuum_flight(release, g)["time_of_flight"] + 1.0
    sol = _solve_drag(release, g, k, t_guess)
    t_hit = float(sol.t_events[0][0])
    x, y, vx, vy = sol.y_events[0][0]
    ts = np.linspace(release["t"], t_hit, 2001)
    heights = sol.sol(ts)[1]
    return {
        **_release_summary(release),
        "time_of_flight": t_hit - release["t"],
        "range": float(-x),
        "range_from_release": float(release["x"] - x),
        "apex_height": float(max(heights.max(), release["y"])),
        "impact_speed": math.hypot(vx, vy),
        "impact_angle": math.atan2(-vy, abs(vx)),
    }


def flight_summary(release: dict[str, float], g: float, flight: Flight,
                   m: float) -> dict[str, float]:
    """The flight of the scene's model: vacuum or drag."""
    if flight.model == "drag":
        return {**drag_flight(release, g, flight, m), "model": "drag"}
    return {**vacuum_flight(release, g), "model": "vacuum"}


def projectile_in_flight(release: dict[str, float], t: np.ndarray, g: float, flight: Flight,
                         m: float) -> tuple[np.ndarray, np.ndarray]:
    """Projectile position (m) and velocity (m/s) at times ``t`` (s) after release, shapes
    (2, n). In vacuum the parabola; with drag the integrated trajectory (continued below ground
    level if asked, as the engine's phase III may outlast the flight)."""
    tau = t - release["t"]
    if flight.model == "drag" and t.size:
        k = drag_constant(flight, m)
        y0 = [release["x"], release["y"], release["vx"], release["vy"]]
        t_end = float(t.max())
        if t_end <= release["t"]:
            s = np.repeat(np.array(y0)[:, None], t.size, axis=1)
        else:
            from scipy.integrate import solve_ivp

            sol = solve_ivp(_drag_rhs(k, g), (release["t"], t_end), y0, method="DOP853",
                            rtol=1e-10, atol=1e-9, dense_output=True)
            s = sol.sol(t)
        return s[:2], s[2:]
    r = np.array([release["x"] + release["vx"] * tau,
                  release["y"] + release["vy"] * tau - 0.5 * g * tau * tau])
    v = np.array([np.full_like(tau, release["vx"]), release["vy"] - g * tau])
    return r, v
