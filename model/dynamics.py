"""Equations of motion: the angular accelerations of each phase, from the Lagrangian.

The Lagrange equations of the paper (its appendix for phase I) are solved in
closed form. Eliminating the counterweight's and the sling's equations leaves
one equation for the beam,

    θ̈ = Σ Q_k / Σ I_k,

a sum over the parts of the engine of a generalised force ``Q_k`` (N m) and an
effective moment of inertia ``I_k`` (kg m²): the beam itself, the hinged
counterweight (a pendulum driven by the hinge) and the projectile (dragged in
the trough in phase I, swinging in the sling in phase II, gone in phase III).
The counterweight's and sling's accelerations then follow from their own
pendulum equations. Every function works on floats (``lib=math``, for the
integrator) and on numpy arrays (``lib=numpy``, the default, for outputs).

Angles in rad, rates in rad/s, accelerations in rad/s², lengths in m, masses in
kg, ``g`` in m/s².
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

import numpy as np

from .scene import Engine

__all__ = [
    "trough_sling_angle",
    "trough_f_g",
    "counterweight_psi_dd",
    "sling_phi_dd",
    "trough_phi_d",
    "trough_phi_dd",
    "accelerations_phase1",
    "accelerations_phase2",
    "accelerations_phase3",
]


def trough_sling_angle(theta: Any, e: Engine, H: float, lib: ModuleType = np) -> Any:
    """Sling angle φ in the trough from the constraint ``H + L1 sin θ + L4 sin φ = 0``
    (paper, eq. for phase I), on the branch under the beam (cos φ < 0), rad."""
    return -lib.pi + lib.asin((H + e.L1 * lib.sin(theta)) / e.L4)


def trough_f_g(theta: Any, phi: Any, e: Engine, lib: ModuleType = np) -> tuple[Any, Any]:
    """The paper's ``f(θ)`` and ``g(θ)`` of phase I (dimensionless):
    ``a_m = L1 (f θ̈ + g θ̇²) e_x``."""
    cos_phi = lib.cos(phi)
    f = -lib.sin(theta - phi) / cos_phi
    c = lib.cos(theta)
    g = -(e.L1 / e.L4) * c * c / (cos_phi * cos_phi * cos_phi) - lib.cos(theta - phi) / cos_phi
    return f, g


def trough_phi_d(theta: Any, phi: Any, theta_d: Any, e: Engine, lib: ModuleType = np) -> Any:
    """φ̇ in the trough from ``L1 cos θ θ̇ + L4 cos φ φ̇ = 0``, rad/s."""
    return -e.L1 * lib.cos(theta) * theta_d / (e.L4 * lib.cos(phi))


def trough_phi_dd(theta: Any, phi: Any, theta_d: Any, phi_d: Any, theta_dd: Any, e: Engine,
                  lib: ModuleType = np) -> Any:
    """φ̈ in the trough, the time derivative of the velocity constraint, rad/s²."""
    return (e.L4 * lib.sin(phi) * phi_d * phi_d
            - e.L1 * (lib.cos(theta) * theta_dd - lib.sin(theta) * theta_d * theta_d)) / (
        e.L4 * lib.cos(phi))


def counterweight_psi_dd(theta: Any, psi: Any, theta_d: Any, theta_dd: Any, e: Engine, g: float,
                         lib: ModuleType = np) -> Any:
    """ψ̈ of the hinged counterweight, a pendulum of length L3 hung from the moving hinge,
    rad/s² (second row of the paper's eq. (A.1), divided by M L3²); θ̈ for a counterweight
    fixed to the beam."""
    if e.counterweight_offset is not None:
        return theta_dd
    s, c = lib.sin(theta - psi), lib.cos(theta - psi)
    return (e.L2 * (c * theta_dd - s * theta_d * theta_d) - g * lib.cos(psi)) / e.L3


def sling_phi_dd(theta: Any, phi: Any, theta_d: Any, theta_dd: Any, e: Engine, g: float,
                 lib: ModuleType = np) -> Any:
    """φ̈ of the projectile in the sling, a pendulum of length L4 hung from the spigot, rad/s²."""
    s, c = lib.sin(theta - phi), lib.cos(theta - phi)
    return (e.L1 * (s * theta_d * theta_d - c * theta_dd) - g * lib.cos(phi)) / e.L4


def _counterweight_share(theta: Any, psi: Any, theta_d: Any, psi_d: Any, e: Engine, g: float,
                         lib: ModuleType) -> tuple[Any, Any]:
    """Generalised force (N m) and effective inertia (kg m²) of the counterweight on the beam:
    for the hinged one once its own equation is eliminated; for one fixed to the beam at
    ``ψ = θ + offset``, gravity's torque ``M g (L2 cos θ − L3 cos ψ)`` and ``M ρ²`` with
    ``ρ² = L2² + L3² − 2 L2 L3 cos(offset)``."""
    if e.counterweight_offset is not None:
        rho2 = e.L2 * e.L2 + e.L3 * e.L3 - 2.0 * e.L2 * e.L3 * lib.cos(e.counterweight_offset)
        return e.M * g * (e.L2 * lib.cos(theta) - e.L3 * lib.cos(psi)), e.M * rho2
    s, c = lib.sin(theta - psi), lib.cos(theta - psi)
    swing = e.L2 * theta_d * theta_d * s + g * lib.cos(psi)
    q = e.M * e.L2 * (e.L3 * psi_d * psi_d * s - c * swing + g * lib.cos(theta))
    return q, e.M * e.L2 * e.L2 * s * s


def _beam_share(theta: Any, e: Engine, g: float, lib: ModuleType) -> tuple[Any, Any]:
    """Generalised force (gravity on the beam's centre of mass, N m) and inertia of the beam."""
    return -e.m_b * e.L_CM * g * lib.cos(theta), e.I


def accelerations_phase1(theta: Any, psi: Any, theta_d: Any, psi_d: Any, e: Engine, g: float,
                         H: float, lib: ModuleType = np) -> tuple[Any, Any, Any, Any, Any]:
    """Phase I (projectile dragged in the trough): returns φ, φ̇, θ̈, ψ̈, φ̈.

    The paper's eq. (A.1) with the projectile's share ``I = m L1² f²`` and
    ``Q = −m L1² f g θ̇²``.
    """
    phi = trough_sling_angle(theta, e, H, lib)
    phi_d = trough_phi_d(theta, phi, theta_d, e, lib)
    f, gg = trough_f_g(theta, phi, e, lib)
    q_cw, i_cw = _counterweight_share(theta, psi, theta_d, psi_d, e, g, lib)
    q_b, i_b = _beam_share(theta, e, g, lib)
    q_p = -e.m * e.L1 * e.L1 * f * gg * theta_d * theta_d
    i_p = e.m * e.L1 * e.L1 * f * f
    theta_dd = (q_cw + q_b + q_p) / (i_cw + i_b + i_p)
    psi_dd = counterweight_psi_dd(theta, psi, theta_d, theta_dd, e, g, lib)
    phi_dd = trough_phi_dd(theta, phi, theta_d, phi_d, theta_dd, e, lib)
    return phi, phi_d, theta_dd, psi_dd, phi_dd


def accelerations_phase2(theta: Any, psi: Any, phi: Any, theta_d: Any, psi_d: Any, phi_d: Any,
                         e: Engine, g: float, lib: ModuleType = np) -> tuple[Any, Any, Any]:
    """Phase II (projectile in the sling): returns θ̈, ψ̈, φ̈ from the three Lagrange equations."""
    s, c = lib.sin(theta - phi), lib.cos(theta - phi)
    q_cw, i_cw = _counterweight_share(theta, psi, theta_d, psi_d, e, g, lib)
    q_b, i_b = _beam_share(theta, e, g, lib)
    q_p = -e.m * e.L1 * (e.L4 * phi_d * phi_d * s + g * lib.cos(theta)
                         + c * (e.L1 * theta_d * theta_d * s - g * lib.cos(phi)))
    i_p = e.m * e.L1 * e.L1 * s * s
    theta_dd = (q_cw + q_b + q_p) / (i_cw + i_b + i_p)
    psi_dd = counterweight_psi_dd(theta, psi, theta_d, theta_dd, e, g, lib)
    phi_dd = sling_phi_dd(theta, phi, theta_d, theta_dd, e, g, lib)
    return theta_dd, psi_dd, phi_dd


def accelerations_phase3(theta: Any, psi: Any, theta_d: Any, psi_d: Any, e: Engine, g: float,
                         lib: ModuleType = np) -> tuple[Any, Any]:
    """Phase III (projectile released): returns θ̈, ψ̈ of beam and counterweight alone."""
    q_cw, i_cw = _counterweight_share(theta, psi, theta_d, psi_d, e, g, lib)
    q_b, i_b = _beam_share(theta, e, g, lib)
    theta_dd = (q_cw + q_b) / (i_cw + i_b)
    return theta_dd, counterweight_psi_dd(theta, psi, theta_d, theta_dd, e, g, lib)
