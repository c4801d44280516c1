"""Forces before and at the trigger: the paper's Sections 5 and 9, in closed form.

Before the trigger (t = 0−) the engine is held at rest by a locking force,
(a) perpendicular to the beam at the spigot or (b) horizontal through the
sling. At t = 0+ the angular accelerations jump from zero to the values of
eq. (22), which the equations of motion give without solving them. Forces in
N, accelerations in rad/s², torques in N m; vectors as ``(x, y)`` tuples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from trebuchet.model.scene import Scene

__all__ = [
    "StaticForces",
    "InitialState",
    "static_forces",
    "initial_accelerations",
    "initial_state",
    "heavy_counterweight_limits",
]

Vec = tuple[float, float]


@dataclass(frozen=True)
class StaticForces:
    """Forces on the beam at rest before the trigger (t = 0−), N.

    ``F_L`` the locking force vector, ``F_R`` the bearing reaction, ``F_H`` hinge,
    ``F_CM`` centre of mass, ``F_S`` sling (zero for locking a).
    """

    locking: str
    F_L: Vec
    F_R: Vec
    F_H: Vec
    F_CM: Vec
    F_S: Vec


@dataclass(frozen=True)
class InitialState:
    """Accelerations (rad/s², m/s²), forces (N) and torque (N m) just after the trigger, t = 0+
    (paper, eqs. (22)–(28)). ``N_counterweight`` is the hinge's share of the torque,
    ``L2 F_H·e_θ⊥`` (70 kN m for Table 1)."""

    theta_dd: float
    psi_dd: float
    phi_dd: float
    a_m: Vec
    a_M: Vec
    F_m: Vec
    F_M: Vec
    F_S: Vec
    F_CM: Vec
    F_H: Vec
    F_R: Vec
    N: float
    N_counterweight: float


def static_forces(scene: Scene, locking: Literal["a", "b"] = "a") -> StaticForces:
    """Static forces before the trigger (paper, Section 5).

    ``locking="a"``: ``F_L = −F_L e_θ⊥`` at the spigot, ``F_L = (M L2 − m_b L_CM) g cos θ_i / L1``.
    ``locking="b"``: horizontal through the sling, ``F_L = (M L2 − m_b L_CM) g cos θ_i /
    (L1 sin θ_i)``; the paper's ``F_b = −F_L e_x + (M + m_b) g e_y``.
    """
    e, g, th = scene.engine, scene.g, scene.start.theta
    moment = e.first_moment * g * math.cos(th)
    F_H = (0.0, e.M * g)
    F_CM = (0.0, e.m_b * g)
    if locking == "a":
        F_L = moment / e.L1
        F_Lv = (F_L * math.sin(th), -F_L * math.cos(th))  # −F_L e_θ⊥
        F_R = (-F_L * math.sin(th), (e.M + e.m_b) * g + F_L * math.cos(th))
        return StaticForces("a", F_Lv, F_R, F_H, F_CM, (0.0, 0.0))
    if locking == "b":
        F_L = moment / (e.L1 * math.sin(th))
        F_R = (-F_L, (e.M + e.m_b) * g)
        # The sling pulls the spigot horizontally: the force on the beam is −F_S = (F_L, 0).
        return StaticForces("b", (F_L, 0.0), F_R, F_H, F_CM, (-F_L, 0.0))
    raise ValueError(f"locking must be 'a' or 'b', got {locking!r}")


def initial_accelerations(scene: Scene) -> tuple[float, float, float]:
    """θ̈_i, ψ̈_i, φ̈_i at t = 0+ (paper, eq. (22)), rad/s², for a start at rest with the
    projectile in the trough.

    ``θ̈_i = (M L2 − m_b L_CM) g cos θ_i / (m L1² sin² θ_i + M L2² cos² θ_i + I)`` holds for a
    hanging counterweight (ψ_i = −π/2) and a flat sling (φ_i = −π); for other start poses the
    general equations of motion are used.
    """
    from trebuchet.model.dynamics import accelerations_phase1

    e, g, s = scene.engine, scene.g, scene.start
    if math.isclose(s.psi, -math.pi / 2, abs_tol=1e-12) and math.isclose(
            math.cos(s.phi), -1.0, abs_tol=1e-12):
        th = s.theta
        theta_dd = e.first_moment * g * math.cos(th) / (
            e.m * e.L1 ** 2 * math.sin(th) ** 2 + e.M * e.L2 ** 2 * math.cos(th) ** 2 + e.I)
        return theta_dd, -e.L2 / e.L3 * math.sin(th) * theta_dd, e.L1 / e.L4 * math.cos(
            th) * theta_dd
    _, _, theta_dd, psi_dd, phi_dd = accelerations_phase1(s.theta, s.psi, 0.0, 0.0, e, g, s.H,
                                                          math)
    return theta_dd, psi_dd, phi_dd


def initial_state(scene: Scene) -> InitialState:
    """Accelerations, forces and torque at t = 0+ in the paper's closed forms (eqs. (23)–(28))."""
    e, g, th = scene.engine, scene.g, scene.start.theta
    theta_dd, psi_dd, phi_dd = initial_accelerations(scene)
    s, c = math.sin(th), math.cos(th)
    a_m = (-e.L1 * s * theta_dd, 0.0)
    a_M = (0.0, -e.L2 * c * theta_dd)
    F_S = (e.m * a_m[0], 0.0)
    F_CM = (-e.m_b * e.L_CM * s * theta_dd, e.m_b * (g + e.L_CM * c * theta_dd))
    F_H = (0.0, e.M * (g - e.L2 * c * theta_dd))
    F_R = (-(e.m * e.L1 + e.m_b * e.L_CM) * s * theta_dd,
           (e.M + e.m_b) * g - e.first_moment * c * theta_dd)
    N = e.first_moment * g * c - (e.m * e.L1 ** 2 * s * s + e.M * e.L2 ** 2 * c * c) * theta_dd
    return InitialState(
        theta_dd=theta_dd, psi_dd=psi_dd, phi_dd=phi_dd, a_m=a_m, a_M=a_M,
        F_m=F_S, F_M=(0.0, e.M * a_M[1]), F_S=F_S, F_CM=F_CM, F_H=F_H, F_R=F_R, N=N,
        N_counterweight=e.L2 * F_H[1] * c,
    )


def heavy_counterweight_limits(scene: Scene) -> dict[str, float]:
    """Limits of the initial accelerations as M → ∞ (paper, after eq. (22) and eqs. (23)–(24)):
    ``θ̈_i → g/(L2 cos θ_i)``, ``ψ̈_i → −tan θ_i g/L3``, ``φ̈_i → (L1/L4)(g/L2)`` (rad/s²),
    ``a_m → −tan θ_i (L1/L2) g`` and ``a_M → −g`` (m/s²)."""
    e, g, th = scene.engine, scene.g, scene.start.theta
    return {
        "theta_dd": g / (e.L2 * math.cos(th)),
        "psi_dd": -math.tan(th) * g / e.L3,
        "phi_dd": e.L1 / e.L4 * g / e.L2,
        "a_m_x": -math.tan(th) * e.L1 / e.L2 * g,
        "a_M_y": -g,
    }
