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
integrator) and on numpy arrays (``lib=numpy``, the default, for outputs), and
compiles unchanged with numba (:mod:`trebuchet.model.shot_kernel`); ``e`` is an
:class:`~trebuchet.model.scene.Engine` or anything with its attributes.

Angles in rad, rates in rad/s, accelerations in rad/s², lengths in m, masses in
kg, ``g`` in m/s².
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

import numpy as np

from trebuchet.model.scene import Engine

__all__ = [
    "trough_sling_angle",
    "trough_f_g",
    "beam_and_counterweight",
    "trough_phi_d",
    "trough_phi_dd",
    "accelerations_phase1",
    "accelerations_phase2",
    "accelerations_phase3",
    "sling_pendulum_phi_dd",
    "counterweight_pendulum_psi_dd",
    "state_rates_phase1",
    "state_rates_phase2",
    "state_rates_phase3",
    "phase_state",
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


def beam_and_counterweight(theta: Any, psi: Any, theta_d: Any, psi_d: Any, q_proj: Any,
                           i_proj: Any, e: Engine, g: float,
                           lib: ModuleType = np) -> tuple[Any, Any]:
    """θ̈ and ψ̈ (rad/s²) given the projectile's share of the beam's equation.

    ``θ̈ = Σ Q / Σ I`` over the beam (gravity on its centre of mass, inertia I), the
    counterweight and the projectile (``q_proj`` in N m, ``i_proj`` in kg m², zero once
    released). The hinged counterweight's own equation (second row of the paper's eq. (A.1))
    is eliminated: it adds ``Q = M L2 (L3 ψ̇² sin(θ−ψ) − cos(θ−ψ)(L2 θ̇² sin(θ−ψ) + g cos ψ)
    + g cos θ)`` and ``I = M L2² sin²(θ−ψ)``, and then swings as a pendulum of length L3 hung
    from the moving hinge, ``ψ̈ = (L2 (cos(θ−ψ) θ̈ − sin(θ−ψ) θ̇²) − g cos ψ)/L3``. A
    counterweight fixed to the beam at ``ψ = θ + offset`` adds gravity's torque
    ``M g (L2 cos θ − L3 cos ψ)`` and ``M ρ²``, ``ρ² = L2² + L3² − 2 L2 L3 cos(offset)``, and
    turns with the beam (ψ̈ = θ̈).
    """
    cos_th = lib.cos(theta)
    q = q_proj - e.m_b * e.L_CM * g * cos_th
    i = i_proj + e.I
    if e.fixed_counterweight:
        rho2 = e.L2 * e.L2 + e.L3 * e.L3 - 2.0 * e.L2 * e.L3 * lib.cos(e.counterweight_offset)
        theta_dd = (q + e.M * g * (e.L2 * cos_th - e.L3 * lib.cos(psi))) / (i + e.M * rho2)
        return theta_dd, theta_dd
    s, c = lib.sin(theta - psi), lib.cos(theta - psi)
    cos_ps = lib.cos(psi)
    w2 = theta_d * theta_d
    q = q + e.M * e.L2 * (e.L3 * psi_d * psi_d * s - c * (e.L2 * w2 * s + g * cos_ps)
                          + g * cos_th)
    theta_dd = q / (i + e.M * e.L2 * e.L2 * s * s)
    return theta_dd, counterweight_pendulum_psi_dd(theta, theta_d, theta_dd, psi, e, g, lib)


def counterweight_pendulum_psi_dd(theta: Any, theta_d: Any, theta_dd: Any, psi: Any, e: Engine,
                                  g: float, lib: ModuleType = np) -> Any:
    """The hinged counterweight as a pendulum of length L3 hung from the moving hinge,
    ``ψ̈ = (L2 (cos(θ−ψ) θ̈ − sin(θ−ψ) θ̇²) − g cos ψ)/L3`` (rad/s²; the second row of the
    paper's eq. (A.1)), for any motion of the beam and in every phase."""
    s, c = lib.sin(theta - psi), lib.cos(theta - psi)
    return (e.L2 * (c * theta_dd - s * (theta_d * theta_d)) - g * lib.cos(psi)) / e.L3


def accelerations_phase1(theta: Any, psi: Any, theta_d: Any, psi_d: Any, e: Engine, g: float,
                         H: float, lib: ModuleType = np) -> tuple[Any, Any, Any, Any, Any]:
    """Phase I (projectile dragged in the trough): returns φ, φ̇, θ̈, ψ̈, φ̈.

    The paper's eq. (A.1): the projectile's share is ``I = m L1² f²`` and
    ``Q = −m L1² f g θ̇²``; φ follows θ on the trough constraint.
    """
    phi = trough_sling_angle(theta, e, H, lib)
    phi_d = trough_phi_d(theta, phi, theta_d, e, lib)
    f, gg = trough_f_g(theta, phi, e, lib)
    mL1L1 = e.m * e.L1 * e.L1
    theta_dd, psi_dd = beam_and_counterweight(theta, psi, theta_d, psi_d,
                                              -mL1L1 * f * gg * theta_d * theta_d, mL1L1 * f * f,
                                              e, g, lib)
    phi_dd = trough_phi_dd(theta, phi, theta_d, phi_d, theta_dd, e, lib)
    return phi, phi_d, theta_dd, psi_dd, phi_dd


def accelerations_phase2(theta: Any, psi: Any, phi: Any, theta_d: Any, psi_d: Any, phi_d: Any,
                         e: Engine, g: float, lib: ModuleType = np) -> tuple[Any, Any, Any]:
    """Phase II (projectile in the sling): returns θ̈, ψ̈, φ̈ from the three Lagrange equations.

    The sling's equation eliminated, the projectile adds ``Q = −m L1 (L4 φ̇² sin(θ−φ) +
    g cos θ + cos(θ−φ)(L1 θ̇² sin(θ−φ) − g cos φ))`` and ``I = m L1² sin²(θ−φ)``, and swings
    as a pendulum of length L4 hung from the spigot,
    ``φ̈ = (L1 (sin(θ−φ) θ̇² − cos(θ−φ) θ̈) − g cos φ)/L4``.
    """
    s, c = lib.sin(theta - phi), lib.cos(theta - phi)
    cos_ph = lib.cos(phi)
    w2 = theta_d * theta_d
    q_p = -e.m * e.L1 * (e.L4 * phi_d * phi_d * s + g * lib.cos(theta)
                         + c * (e.L1 * w2 * s - g * cos_ph))
    theta_dd, psi_dd = beam_and_counterweight(theta, psi, theta_d, psi_d, q_p,
                                              e.m * e.L1 * e.L1 * s * s, e, g, lib)
    phi_dd = sling_pendulum_phi_dd(theta, theta_d, theta_dd, phi, e, g, lib)
    return theta_dd, psi_dd, phi_dd


def sling_pendulum_phi_dd(theta: Any, theta_d: Any, theta_dd: Any, phi: Any, e: Engine,
                          g: float, lib: ModuleType = np) -> Any:
    """Phase II: the sling as a pendulum of length L4 hung from the moving spigot,
    ``φ̈ = (L1 (sin(θ−φ) θ̇² − cos(θ−φ) θ̈) − g cos φ)/L4`` (rad/s²; the paper's sling
    equation), for any motion of the beam."""
    s, c = lib.sin(theta - phi), lib.cos(theta - phi)
    return (e.L1 * (s * (theta_d * theta_d) - c * theta_dd) - g * lib.cos(phi)) / e.L4


def accelerations_phase3(theta: Any, psi: Any, theta_d: Any, psi_d: Any, e: Engine, g: float,
                         lib: ModuleType = np) -> tuple[Any, Any]:
    """Phase III (projectile released, or a dry fire): θ̈, ψ̈ of beam and counterweight alone."""
    return beam_and_counterweight(theta, psi, theta_d, psi_d, 0.0, 0.0, e, g, lib)


def state_rates_phase1(y: Any, e: Engine, g: float, H: float,
                       lib: ModuleType = np) -> tuple[Any, Any, Any, Any]:
    """Time derivative of the phase-I state ``y = (θ, ψ, θ̇, ψ̇)``: ``(θ̇, ψ̇, θ̈, ψ̈)``."""
    _, _, th_dd, ps_dd, _ = accelerations_phase1(y[0], y[1], y[2], y[3], e, g, H, lib)
    return y[2], y[3], th_dd, ps_dd


def state_rates_phase2(y: Any, e: Engine, g: float,
                       lib: ModuleType = np) -> tuple[Any, Any, Any, Any, Any, Any]:
    """Time derivative of the phase-II state ``y = (θ, ψ, φ, θ̇, ψ̇, φ̇)``:
    ``(θ̇, ψ̇, φ̇, θ̈, ψ̈, φ̈)``."""
    th_dd, ps_dd, ph_dd = accelerations_phase2(y[0], y[1], y[2], y[3], y[4], y[5], e, g, lib)
    return y[3], y[4], y[5], th_dd, ps_dd, ph_dd


def state_rates_phase3(y: Any, e: Engine, g: float,
                       lib: ModuleType = np) -> tuple[Any, Any, Any, Any]:
    """Time derivative of the phase-III state ``y = (θ, ψ, θ̇, ψ̇)``: ``(θ̇, ψ̇, θ̈, ψ̈)``."""
    th_dd, ps_dd = accelerations_phase3(y[0], y[1], y[2], y[3], e, g, lib)
    return y[2], y[3], th_dd, ps_dd


def phase_state(kind: int, y: Any, e: Engine, g: float, H: float, lib: ModuleType = np
                ) -> tuple[Any, Any, Any, Any, Any, Any, Any, Any, Any]:
    """θ, ψ, φ (rad), θ̇, ψ̇, φ̇ (rad/s), θ̈, ψ̈, φ̈ (rad/s²) from the state ``y`` of phase
    ``kind`` (I: ``(θ, ψ, θ̇, ψ̇)`` with φ from the trough; II: ``(θ, ψ, φ, θ̇, ψ̇, φ̇)``;
    III: ``(θ, ψ, θ̇, ψ̇)``, φ and its derivatives NaN): the one dispatch from a phase to its
    accelerations, for floats (compiled) and arrays alike."""
    if kind == 1:
        th, ps, th_d, ps_d = y[0], y[1], y[2], y[3]
        ph, ph_d, th_dd, ps_dd, ph_dd = accelerations_phase1(th, ps, th_d, ps_d, e, g, H, lib)
    elif kind == 2:
        th, ps, ph, th_d, ps_d, ph_d = y[0], y[1], y[2], y[3], y[4], y[5]
        th_dd, ps_dd, ph_dd = accelerations_phase2(th, ps, ph, th_d, ps_d, ph_d, e, g, lib)
    else:
        th, ps, th_d, ps_d = y[0], y[1], y[2], y[3]
        th_dd, ps_dd = accelerations_phase3(th, ps, th_d, ps_d, e, g, lib)
        ph = ph_d = ph_dd = th * lib.nan
    return th, ps, ph, th_d, ps_d, ph_d, th_dd, ps_dd, ph_dd
