"""The projectile's flight after release, in vacuum.

Origin on the ground under the pivot; the projectile is thrown toward −x, so
the range counts along −x. Positions in m, speeds in m/s, times in s, angles
in rad.
"""

from __future__ import annotations

import math

__all__ = ["vacuum_flight"]


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
    speed = math.hypot(vx, vy)
    if y < 0.0:
        raise ValueError(f"release below ground (y = {y:.4g} m)")
    t_f = (vy + math.sqrt(vy * vy + 2.0 * g * y)) / g
    x_impact = x + vx * t_f
    vy_impact = vy - g * t_f
    apex = y + (vy * vy / (2.0 * g) if vy > 0.0 else 0.0)
    return {
        "release_time": release["t"],
        "release_x": x,
        "release_height": y,
        "release_speed": speed,
        "release_angle": math.atan2(vy, -vx),
        "time_of_flight": t_f,
        "range": -x_impact,
        "range_from_release": x - x_impact,
        "apex_height": apex,
        "impact_speed": math.hypot(vx, vy_impact),
        "impact_angle": math.atan2(-vy_impact, abs(vx)),
    }
