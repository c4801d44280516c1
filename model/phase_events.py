"""The events that end a phase of a shot, as functions of time and state that cross zero.

Each is a pure function of the time ``t`` (s), the phase's state ``y`` (θ, ψ[, φ], θ̇, ψ̇[, φ̇];
rad and rad/s), the engine ``e``, gravity ``g`` (m/s²), the pivot height ``H`` (m) and one
parameter ``par``. They are written on floats with :mod:`math` so that the pure-Python
integrators and the compiled one (:mod:`trebuchet.model.shot_kernel`) evaluate the same code;
:func:`event_value` picks one by its kind. ``DIRECTION`` gives the sign of the crossing that
counts (+1 rising through zero, −1 falling); every event here ends its phase.
"""

from __future__ import annotations

import math
from typing import Any

from trebuchet.model import dynamics as dyn
from trebuchet.model.kinematics import projectile_position_xy, projectile_velocity_xy
from trebuchet.model.scene import Engine

__all__ = [
    "LIFT_OFF", "SLING_UPRIGHT", "GROUND", "RELEASE_TIME", "RELEASE_ANGLE", "DIRECTION",
    "lift_off_margin", "sling_upright_margin", "projectile_height", "time_to_release",
    "climb_margin", "event_value", "trough_margin",
]

LIFT_OFF, SLING_UPRIGHT, GROUND, RELEASE_TIME, RELEASE_ANGLE = 0, 1, 2, 3, 4
#: Direction of the crossing that counts, by kind.
DIRECTION = {LIFT_OFF: -1.0, SLING_UPRIGHT: 1.0, GROUND: -1.0, RELEASE_TIME: 1.0,
             RELEASE_ANGLE: 1.0}


def lift_off_margin(y: Any, e: Engine, g: float, H: float) -> float:
    """Phase I: the trough's normal force over the projectile's weight, ``F_N/(m g)``
    (dimensionless; paper, eq. (16) with ``F_N = m g − F_S·e_y``); lift-off where it falls
    through 0."""
    return trough_margin(dyn.phase_motion(1, y, e, g, H, math), e, g)


def trough_margin(m: Any, e: Engine, g: float) -> float:
    """``F_N/(m g)`` of :func:`lift_off_margin` from the motion ``m`` of
    :func:`dynamics.phase_motion` in phase I (the FMU's C passes the motion under its own
    solve of the friction couples)."""
    th, ph, th_d, th_dd = m[0], m[2], m[3], m[6]
    f, gg = dyn.trough_f_g(th, ph, e, math)
    return 1.0 - e.L1 * (f * th_dd + gg * th_d * th_d) * math.tan(ph) / g


def sling_upright_margin(y: Any, e: Engine, H: float) -> float:
    """Phase I: ``sin φ − 0.999`` on the trough constraint (dimensionless); rising through 0
    the sling stands vertical over a projectile still in the trough (the counterweight cannot
    lift it)."""
    return (H + e.L1 * math.sin(y[0])) / e.L4 - 0.999


def projectile_height(y: Any, e: Engine, H: float) -> float:
    """Phase II: height of the projectile in the sling, m, plus a hair (1e-9 of L1 + L4) so
    that lift-off from the trough at height 0 is not taken for a strike; falling through 0
    it strikes the ground."""
    height = projectile_position_xy(math.cos(y[0]), math.sin(y[0]), math.cos(y[2]),
                                    math.sin(y[2]), e, H)[1]
    return height + 1e-9 * (e.L1 + e.L4)


def time_to_release(t: float, t_release: float) -> float:
    """Phase II: ``t − t_release``, s; release by time where it rises through 0."""
    return t - t_release


def climb_margin(y: Any, e: Engine, angle: float) -> float:
    """Phase II: ``|v| sin(α − β)``, m/s, where β is the projectile's climb toward −x and α
    the release angle (rad); release where it rises through 0 (β = α)."""
    th, ph, th_d, ph_d = y[0], y[2], y[3], y[5]
    vx, vy = projectile_velocity_xy(math.cos(th), math.sin(th), th_d, math.cos(ph),
                                    math.sin(ph), ph_d, e)
    return math.sin(angle) * (-vx) - math.cos(angle) * vy


def event_value(kind: int, t: float, y: Any, e: Engine, g: float, H: float,
                par: float) -> float:
    """The event function of ``kind`` (one of the constants above) at ``(t, y)``; ``par`` is
    the release time (s) or the release angle (rad) where the kind needs one."""
    if kind == LIFT_OFF:
        return lift_off_margin(y, e, g, H)
    if kind == SLING_UPRIGHT:
        return sling_upright_margin(y, e, H)
    if kind == GROUND:
        return projectile_height(y, e, H)
    if kind == RELEASE_TIME:
        return time_to_release(t, par)
    return climb_margin(y, e, par)
