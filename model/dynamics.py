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

Friction in the bearings (:mod:`trebuchet.model.friction`) enters as the generalised forces
``Q_θ``, ``Q_ψ`` of its couples; the couples follow the loads on the bearings, which follow
the accelerations, so :func:`friction_forces` solves for them (Newton's method on the two
load magnitudes; the accelerations are affine in the couples). An engine without friction
takes none of that path: its numbers are those of the frictionless equations, bit for bit.

Angles in rad, rates in rad/s, accelerations in rad/s², lengths in m, masses in
kg, ``g`` in m/s², generalised forces in N m.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

import numpy as np

from trebuchet.model.forces import joint_forces_xy
from trebuchet.model.friction import (
    FRICTION_NEWTON_EPS,
    FRICTION_NEWTON_STEPS,
    friction_couples,
    friction_first_steps,
    friction_generalised_forces,
    friction_newton_margin,
    friction_newton_step,
    friction_solve,
    friction_start,
    has_friction,
    loss_powers,
)
from trebuchet.model.kinematics import trough_f_g, trough_phi_d, trough_phi_dd, trough_sling_angle
from trebuchet.model.scene import Engine

__all__ = [
    "trough_sling_angle",
    "trough_f_g",
    "beam_and_counterweight",
    "trough_phi_d",
    "trough_phi_dd",
    "phase_accelerations",
    "couple_response",
    "trough_inertia",
    "sling_inertia",
    "friction_forces",
    "friction_pieces",
    "friction_newton_step",
    "friction_newton_margin",
    "friction_solve",
    "friction_first_steps",
    "motion_of_pieces",
    "friction_derivative",
    "friction_start",
    "friction_result",
    "phase_motion",
    "motion_under",
    "state_derivative_under",
    "accelerations_phase1",
    "accelerations_phase2",
    "accelerations_phase3",
    "sling_pendulum_phi_dd",
    "counterweight_pendulum_psi_dd",
    "state_rates_phase1",
    "state_rates_phase2",
    "state_rates_phase3",
    "phase_state",
    "state_derivative",
    "energy_scale",
    "FRICTION_NEWTON_STEPS",
    "FRICTION_NEWTON_EPS",
]


def beam_and_counterweight(theta: Any, psi: Any, theta_d: Any, psi_d: Any, q_proj: Any,
                           i_proj: Any, e: Engine, g: float, lib: ModuleType = np,
                           Q_th: Any = 0.0, Q_ps: Any = 0.0) -> tuple[Any, Any]:
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

    ``Q_th``, ``Q_ps`` (N m): generalised forces of friction couples on θ and ψ. The
    counterweight's equation then reads ``M L3² ψ̈ = M L3 (L2 (cos(θ−ψ) θ̈ − sin(θ−ψ) θ̇²) −
    g cos ψ) + Q_ψ``, and eliminating it adds ``Q_θ + (L2 cos(θ−ψ)/L3) Q_ψ`` to the beam's
    ``Σ Q`` (derived with sympy in tests/test_friction_derivation.py). A fixed counterweight
    turns with the beam: ``Q_θ + Q_ψ``.
    """
    cos_th = lib.cos(theta)
    q = q_proj - e.m_b * e.L_CM * g * cos_th
    i = i_proj + e.I
    if e.fixed_counterweight:
        rho2 = e.L2 * e.L2 + e.L3 * e.L3 - 2.0 * e.L2 * e.L3 * lib.cos(e.counterweight_offset)
        theta_dd = (q + e.M * g * (e.L2 * cos_th - e.L3 * lib.cos(psi)) + Q_th + Q_ps) / (
            i + e.M * rho2)
        return theta_dd, theta_dd
    s, c = lib.sin(theta - psi), lib.cos(theta - psi)
    cos_ps = lib.cos(psi)
    w2 = theta_d * theta_d
    q = q + e.M * e.L2 * (e.L3 * psi_d * psi_d * s - c * (e.L2 * w2 * s + g * cos_ps)
                          + g * cos_th)
    theta_dd = (q + Q_th + (e.L2 * c / e.L3) * Q_ps) / (i + e.M * e.L2 * e.L2 * s * s)
    return theta_dd, (_pendulum(e.L2, e.L3, s, c, cos_ps, theta_d, theta_dd, g)
                      + Q_ps / (e.M * e.L3 * e.L3))


def counterweight_pendulum_psi_dd(theta: Any, theta_d: Any, theta_dd: Any, psi: Any, e: Engine,
                                  g: float, lib: ModuleType = np) -> Any:
    """The hinged counterweight as a pendulum of length L3 hung from the moving hinge,
    ``ψ̈ = (L2 (cos(θ−ψ) θ̈ − sin(θ−ψ) θ̇²) − g cos ψ)/L3`` (rad/s²; the second row of the
    paper's eq. (A.1)), for any motion of the beam and in every phase."""
    s, c = lib.sin(theta - psi), lib.cos(theta - psi)
    return _pendulum(e.L2, e.L3, s, c, lib.cos(psi), theta_d, theta_dd, g)


def _pendulum(arm: Any, length: Any, s: Any, c: Any, cos_a: Any, theta_d: Any, theta_dd: Any,
              g: float) -> Any:
    """A pendulum of ``length`` (m) at angle ``a`` hung from the beam's point ``arm`` (m) from
    the pivot, toward the counterweight: ``ä = (arm (cos(θ−a) θ̈ − sin(θ−a) θ̇²) − g cos a) /
    length`` (``s``, ``c``: sin and cos of θ − a). The counterweight's arm (L2, L3) as
    written; the sling (spigot at −L1 on this side, L4) with ``arm = −L1``."""
    return (arm * (c * theta_dd - s * (theta_d * theta_d)) - g * cos_a) / length


def trough_inertia(f: Any, e: Engine) -> Any:
    """``m L1² f²``, kg m²: the projectile's share of the beam's inertia in the trough (the
    paper's eq. (A.1); ``f`` of :func:`trough_f_g`)."""
    return e.m * e.L1 * e.L1 * f * f


def sling_inertia(s: Any, e: Engine) -> Any:
    """``m L1² sin²(θ−φ)``, kg m²: the projectile's share of the beam's inertia in the sling
    (``s = sin(θ−φ)``)."""
    return e.m * e.L1 * e.L1 * s * s


def accelerations_phase1(theta: Any, psi: Any, theta_d: Any, psi_d: Any, e: Engine, g: float,
                         H: float, lib: ModuleType = np, Q_th: Any = 0.0,
                         Q_ps: Any = 0.0) -> tuple[Any, Any, Any, Any, Any]:
    """Phase I (projectile dragged in the trough): returns φ, φ̇, θ̈, ψ̈, φ̈.

    The paper's eq. (A.1): the projectile's share is ``I = m L1² f²`` and
    ``Q = −m L1² f g θ̇²``; φ follows θ on the trough constraint. ``Q_th``, ``Q_ps``: friction's
    generalised forces (N m, :func:`beam_and_counterweight`).
    """
    phi = trough_sling_angle(theta, e, H, lib)
    phi_d = trough_phi_d(theta, phi, theta_d, e, lib)
    f, gg = trough_f_g(theta, phi, e, lib)
    mL1L1 = e.m * e.L1 * e.L1
    theta_dd, psi_dd = beam_and_counterweight(theta, psi, theta_d, psi_d,
                                              -mL1L1 * f * gg * theta_d * theta_d,
                                              trough_inertia(f, e), e, g, lib, Q_th, Q_ps)
    phi_dd = trough_phi_dd(theta, phi, theta_d, phi_d, theta_dd, e, lib)
    return phi, phi_d, theta_dd, psi_dd, phi_dd


def accelerations_phase2(theta: Any, psi: Any, phi: Any, theta_d: Any, psi_d: Any, phi_d: Any,
                         e: Engine, g: float, lib: ModuleType = np, Q_th: Any = 0.0,
                         Q_ps: Any = 0.0) -> tuple[Any, Any, Any]:
    """Phase II (projectile in the sling): returns θ̈, ψ̈, φ̈ from the three Lagrange equations.

    The sling's equation eliminated, the projectile adds ``Q = −m L1 (L4 φ̇² sin(θ−φ) +
    g cos θ + cos(θ−φ)(L1 θ̇² sin(θ−φ) − g cos φ))`` and ``I = m L1² sin²(θ−φ)``, and swings
    as a pendulum of length L4 hung from the spigot,
    ``φ̈ = (L1 (sin(θ−φ) θ̇² − cos(θ−φ) θ̈) − g cos φ)/L4``. ``Q_th``, ``Q_ps``: friction's
    generalised forces (N m).
    """
    s, c = lib.sin(theta - phi), lib.cos(theta - phi)
    cos_ph = lib.cos(phi)
    w2 = theta_d * theta_d
    q_p = -e.m * e.L1 * (e.L4 * phi_d * phi_d * s + g * lib.cos(theta)
                         + c * (e.L1 * w2 * s - g * cos_ph))
    theta_dd, psi_dd = beam_and_counterweight(theta, psi, theta_d, psi_d, q_p,
                                              sling_inertia(s, e), e, g, lib, Q_th, Q_ps)
    phi_dd = _pendulum(-e.L1, e.L4, s, c, cos_ph, theta_d, theta_dd, g)
    return theta_dd, psi_dd, phi_dd


def sling_pendulum_phi_dd(theta: Any, theta_d: Any, theta_dd: Any, phi: Any, e: Engine,
                          g: float, lib: ModuleType = np) -> Any:
    """Phase II: the sling as a pendulum of length L4 hung from the moving spigot,
    ``φ̈ = (L1 (sin(θ−φ) θ̇² − cos(θ−φ) θ̈) − g cos φ)/L4`` (rad/s²; the paper's sling
    equation), for any motion of the beam."""
    s, c = lib.sin(theta - phi), lib.cos(theta - phi)
    return _pendulum(-e.L1, e.L4, s, c, lib.cos(phi), theta_d, theta_dd, g)


def accelerations_phase3(theta: Any, psi: Any, theta_d: Any, psi_d: Any, e: Engine, g: float,
                         lib: ModuleType = np, Q_th: Any = 0.0,
                         Q_ps: Any = 0.0) -> tuple[Any, Any]:
    """Phase III (projectile released, or a dry fire): θ̈, ψ̈ of beam and counterweight alone
    (``Q_th``, ``Q_ps``: friction's generalised forces, N m)."""
    return beam_and_counterweight(theta, psi, theta_d, psi_d, 0.0, 0.0, e, g, lib, Q_th, Q_ps)


def phase_accelerations(kind: int, th: Any, ps: Any, ph: Any, th_d: Any, ps_d: Any, ph_d: Any,
                        e: Engine, g: float, H: float, lib: ModuleType = np, Q_th: Any = 0.0,
                        Q_ps: Any = 0.0) -> tuple[Any, Any, Any, Any, Any]:
    """φ, φ̇ (rad, rad/s), θ̈, ψ̈, φ̈ (rad/s²) of phase ``kind`` under friction's generalised
    forces ``Q_th``, ``Q_ps`` (N m): in the trough φ and φ̇ follow θ (the ones given are not
    used), in the sling they are the ones given, after release they are NaN."""
    if kind == 1:
        return accelerations_phase1(th, ps, th_d, ps_d, e, g, H, lib, Q_th, Q_ps)
    if kind == 2:
        th_dd, ps_dd, ph_dd = accelerations_phase2(th, ps, ph, th_d, ps_d, ph_d, e, g, lib, Q_th,
                                                   Q_ps)
        return ph, ph_d, th_dd, ps_dd, ph_dd
    th_dd, ps_dd = accelerations_phase3(th, ps, th_d, ps_d, e, g, lib, Q_th, Q_ps)
    nan = th * lib.nan
    return nan, nan, th_dd, ps_dd, nan


def couple_response(kind: int, th: Any, ps: Any, ph: Any, e: Engine, H: float,
                    lib: ModuleType = np) -> tuple[Any, Any, Any, Any, Any, Any]:
    """θ̈, ψ̈, φ̈ (rad/s²) per N m of ``Q_θ``, then per N m of ``Q_ψ``, in the pose ``th, ps,
    ph`` of phase ``kind`` (φ the trough's in phase I, unused in III): the mass matrix alone,
    from the equations of :func:`beam_and_counterweight` at rest without gravity; φ follows θ
    through the trough's constraint (:func:`trough_phi_dd`) or the sling's pendulum
    (:func:`sling_pendulum_phi_dd`). The accelerations are affine in the generalised forces,
    so these are exact slopes."""
    z = 0.0 * th
    if kind == 1:
        i_proj = trough_inertia(trough_f_g(th, ph, e, lib)[0], e)
        follow = trough_phi_dd(th, ph, z, z, 1.0, e, lib)
    elif kind == 2:
        i_proj = sling_inertia(lib.sin(th - ph), e)
        follow = sling_pendulum_phi_dd(th, z, 1.0, ph, e, 0.0, lib)
    else:
        i_proj, follow = z, z
    th_t, ps_t = beam_and_counterweight(th, ps, z, z, z, i_proj, e, 0.0, lib, 1.0, 0.0)
    th_p, ps_p = beam_and_counterweight(th, ps, z, z, z, i_proj, e, 0.0, lib, 0.0, 1.0)
    return th_t, ps_t, follow * th_t, th_p, ps_p, follow * th_p


def friction_pieces(kind: int, th: Any, ps: Any, ph: Any, th_d: Any, ps_d: Any, ph_d: Any,
                    e: Engine, g: float, H: float, lib: ModuleType = np) -> tuple:
    """What the couples of the bearings' friction depend on, in phase ``kind`` at the given
    angles (rad) and rates (rad/s), 25 numbers: ``a_P = μ_P r_P s(θ̇)``, ``a_H = μ_H r_H
    s(ψ̇ − θ̇)`` (m); the frictionless loads ``F_R₀``, ``F_H₀`` (N) and their slopes in the load
    magnitudes ``n = (|F_R|, |F_H|)``: ``∂F_R/∂n_R``, ``∂F_R/∂n_H``, ``∂F_H/∂n_R``,
    ``∂F_H/∂n_H`` (dimensionless); then the frictionless motion (φ, φ̇, θ̈, ψ̈, φ̈) and the
    accelerations' slopes in ``Q_θ``, ``Q_ψ`` (:func:`couple_response`). Loads are affine in
    the accelerations and these in the couples' generalised forces ``Q_θ = −a_P n_R + a_H
    n_H``, ``Q_ψ = −a_H n_H``, so ``F(n) = F₀ + n_R ∂F/∂n_R + n_H ∂F/∂n_H`` exactly."""
    a_P, a_H = friction_couples(1.0, 1.0, th_d, ps_d, e, lib)
    motion = phase_accelerations(kind, th, ps, ph, th_d, ps_d, ph_d, e, g, H, lib)
    ph0, ph_d0, th_dd, ps_dd, ph_dd = motion
    R0, H0 = joint_forces_xy(kind, th, th_d, th_dd, ps, ps_d, ps_dd, ph0, ph_d0, ph_dd, e, g,
                             lib)
    r = couple_response(kind, th, ps, ph0, e, H, lib)
    z = 0.0 * th
    Rt, Ht = joint_forces_xy(kind, th, z, r[0], ps, z, r[1], ph0, z, r[2], e, 0.0, lib)
    Rp, Hp = joint_forces_xy(kind, th, z, r[3], ps, z, r[4], ph0, z, r[5], e, 0.0, lib)
    # ∂F/∂n_R = −a_P ∂F/∂Q_θ;  ∂F/∂n_H = a_H (∂F/∂Q_θ − ∂F/∂Q_ψ)
    return (a_P, a_H, R0[0], R0[1], H0[0], H0[1],
            -a_P * Rt[0], -a_P * Rt[1], a_H * (Rt[0] - Rp[0]), a_H * (Rt[1] - Rp[1]),
            -a_P * Ht[0], -a_P * Ht[1], a_H * (Ht[0] - Hp[0]), a_H * (Ht[1] - Hp[1]),
            *motion, *r)


def friction_forces(kind: int, th: Any, ps: Any, ph: Any, th_d: Any, ps_d: Any, ph_d: Any,
                    e: Engine, g: float, H: float, lib: ModuleType = np
                    ) -> tuple[Any, Any, Any, Any]:
    """``Q_θ``, ``Q_ψ`` (generalised forces) and ``τ_P``, ``τ_H`` (the couples), N m, of the
    bearings' friction in phase ``kind`` at the given angles and rates.

    The couples are ``τ_P = a_P |F_R|``, ``τ_H = a_H |F_H|``, and the loads follow the
    accelerations the couples cause: ``n = (|F_R(n)|, |F_H(n)|)`` is solved by
    Newton's method (:func:`friction_solve`) from the frictionless magnitudes, on the exact
    affine loads of :func:`friction_pieces`. The same code runs on floats and arrays, and the
    FMU's C runs the same steps on functions generated from these."""
    p = friction_pieces(kind, th, ps, ph, th_d, ps_d, ph_d, e, g, H, lib)
    n_R, n_H = friction_solve(p, lib)
    return friction_result(p, n_R, n_H)


def friction_result(p: tuple, n_R: Any, n_H: Any) -> tuple[Any, Any, Any, Any]:
    """``Q_θ``, ``Q_ψ``, ``τ_P``, ``τ_H`` (N m) of the load magnitudes ``n_R``, ``n_H`` (N):
    ``τ_P = a_P n_R``, ``τ_H = a_H n_H`` with ``a_P``, ``a_H`` the first two pieces."""
    tau_P, tau_H = p[0] * n_R, p[1] * n_H
    Q_th, Q_ps = friction_generalised_forces(tau_P, tau_H)
    return Q_th, Q_ps, tau_P, tau_H


def _state_angles(kind: int, y: Any, lib: ModuleType) -> tuple[Any, Any, Any, Any, Any, Any]:
    """θ, ψ, φ, θ̇, ψ̇, φ̇ from the state of phase ``kind`` (φ, φ̇ NaN where the state holds
    none: the trough's follow from θ)."""
    if kind == 2:
        return y[0], y[1], y[2], y[3], y[4], y[5]
    nan = y[0] * lib.nan
    return y[0], y[1], nan, y[2], y[3], nan


def energy_scale(e: Engine, g: float) -> float:
    """``(M L2 − m_b L_CM) g``, J: the engine's scale of energy and of torque (N m), the unit in
    which the integrators carry the friction's lost energy."""
    return (e.M * e.L2 - e.m_b * e.L_CM) * g


def phase_motion(kind: int, y: Any, e: Engine, g: float, H: float, lib: ModuleType = np
                 ) -> tuple[Any, Any, Any, Any, Any, Any, Any, Any, Any, Any, Any]:
    """θ, ψ, φ (rad), θ̇, ψ̇, φ̇ (rad/s), θ̈, ψ̈, φ̈ (rad/s²) and the loss powers of pivot and
    hinge ``P_P``, ``P_H`` (W, :func:`~trebuchet.model.friction.loss_powers`) from the state
    ``y`` of phase ``kind`` (I: ``(θ, ψ, θ̇, ψ̇)`` with φ from the trough; II: ``(θ, ψ, φ, θ̇,
    ψ̇, φ̇)``; III: ``(θ, ψ, θ̇, ψ̇)``, φ and its derivatives NaN; anything after those, such
    as the integrators' lost energies, is ignored): the one dispatch from a phase to its
    accelerations, with the bearings' friction (:func:`friction_forces`) where the engine has
    it, for floats (compiled) and arrays alike."""
    if has_friction(e):
        return _friction_motion(kind, y, e, g, H, lib)
    return motion_under(kind, y, e, g, H, 0.0, 0.0, lib)


def _friction_motion(kind: int, y: Any, e: Engine, g: float, H: float, lib: ModuleType
                     ) -> tuple[Any, Any, Any, Any, Any, Any, Any, Any, Any, Any, Any]:
    """:func:`phase_motion` with the bearings' friction: the couples solved on the pieces of
    :func:`friction_pieces` (:func:`friction_solve`), then :func:`motion_of_pieces`."""
    th, ps, ph, th_d, ps_d, ph_d = _state_angles(kind, y, lib)
    p = friction_pieces(kind, th, ps, ph, th_d, ps_d, ph_d, e, g, H, lib)
    n_R, n_H = friction_solve(p, lib)
    return motion_of_pieces(th, ps, th_d, ps_d, p, n_R, n_H)


def motion_of_pieces(th: Any, ps: Any, th_d: Any, ps_d: Any, p: tuple, n_R: Any, n_H: Any
                     ) -> tuple[Any, Any, Any, Any, Any, Any, Any, Any, Any, Any, Any]:
    """:func:`phase_motion` (θ, ψ, φ in rad, their rates in rad/s and accelerations in rad/s²,
    the loss powers ``P_P``, ``P_H`` in W) from the angles and rates of beam and counterweight,
    the pieces ``p`` of :func:`friction_pieces` and the load magnitudes ``n_R``, ``n_H`` (N)
    that the couples follow: the frictionless accelerations plus the couples' generalised forces
    times their slopes (equal to :func:`motion_under` of those forces to round-off, without
    evaluating the equations again); φ, φ̇ are the pieces' (the trough's in phase I)."""
    Q_th, Q_ps, tau_P, tau_H = friction_result(p, n_R, n_H)
    th_dd = p[16] + Q_th * p[19] + Q_ps * p[22]
    ps_dd = p[17] + Q_th * p[20] + Q_ps * p[23]
    ph_dd = p[18] + Q_th * p[21] + Q_ps * p[24]
    P_P, P_H = loss_powers(tau_P, tau_H, th_d, ps_d)
    return th, ps, p[14], th_d, ps_d, p[15], th_dd, ps_dd, ph_dd, P_P, P_H


def motion_under(kind: int, y: Any, e: Engine, g: float, H: float, Q_th: Any, Q_ps: Any,
                 lib: ModuleType = np
                 ) -> tuple[Any, Any, Any, Any, Any, Any, Any, Any, Any, Any, Any]:
    """:func:`phase_motion` under given generalised forces of friction ``Q_th``, ``Q_ps`` (N m):
    the couples are ``τ_H = −Q_ψ``, ``τ_P = −Q_θ − Q_ψ`` and the loss powers ``τ_P θ̇``,
    ``τ_H (ψ̇ − θ̇)``."""
    th, ps, ph, th_d, ps_d, ph_d = _state_angles(kind, y, lib)
    ph, ph_d, th_dd, ps_dd, ph_dd = phase_accelerations(kind, th, ps, ph, th_d, ps_d, ph_d, e, g,
                                                        H, lib, Q_th, Q_ps)
    tau_H = -Q_ps
    P_P, P_H = loss_powers(tau_H - Q_th, tau_H, th_d, ps_d)
    return th, ps, ph, th_d, ps_d, ph_d, th_dd, ps_dd, ph_dd, P_P, P_H


def phase_state(kind: int, y: Any, e: Engine, g: float, H: float, lib: ModuleType = np
                ) -> tuple[Any, Any, Any, Any, Any, Any, Any, Any, Any]:
    """θ, ψ, φ (rad), θ̇, ψ̇, φ̇ (rad/s), θ̈, ψ̈, φ̈ (rad/s²) from the state ``y`` of phase
    ``kind``: the first nine of :func:`phase_motion`."""
    m = phase_motion(kind, y, e, g, H, lib)
    return m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7], m[8]


def state_rates_phase1(y: Any, e: Engine, g: float, H: float,
                       lib: ModuleType = np) -> tuple[Any, Any, Any, Any]:
    """Time derivative of the phase-I state ``y = (θ, ψ, θ̇, ψ̇)``: ``(θ̇, ψ̇, θ̈, ψ̈)``."""
    m = phase_motion(1, y, e, g, H, lib)
    return y[2], y[3], m[6], m[7]


def state_rates_phase2(y: Any, e: Engine, g: float,
                       lib: ModuleType = np) -> tuple[Any, Any, Any, Any, Any, Any]:
    """Time derivative of the phase-II state ``y = (θ, ψ, φ, θ̇, ψ̇, φ̇)``:
    ``(θ̇, ψ̇, φ̇, θ̈, ψ̈, φ̈)``."""
    m = phase_motion(2, y, e, g, 0.0, lib)
    return y[3], y[4], y[5], m[6], m[7], m[8]


def state_rates_phase3(y: Any, e: Engine, g: float,
                       lib: ModuleType = np) -> tuple[Any, Any, Any, Any]:
    """Time derivative of the phase-III state ``y = (θ, ψ, θ̇, ψ̇)``: ``(θ̇, ψ̇, θ̈, ψ̈)``."""
    m = phase_motion(3, y, e, g, 0.0, lib)
    return y[2], y[3], m[6], m[7]


def state_derivative(kind: int, y: Any, e: Engine, g: float, H: float, lib: ModuleType = np
                     ) -> tuple[Any, Any, Any, Any, Any, Any, Any, Any]:
    """Time derivative of the state ``y`` of phase ``kind`` as the integrators carry it, padded
    to eight entries: phase II ``(θ̇, ψ̇, φ̇, θ̈, ψ̈, φ̈, ė_P, ė_H)``, phases I and III ``(θ̇, ψ̇,
    θ̈, ψ̈, ė_P, ė_H, 0, 0)``; the first ``len(y)`` are the state's. ``e_P``, ``e_H`` are the
    energies lost at pivot and hinge in units of :func:`energy_scale` (states only where the
    engine has friction: ``ė = P_loss / scale``)."""
    return _derivative(kind, y, phase_motion(kind, y, e, g, H, lib), e, g)


def state_derivative_under(kind: int, y: Any, e: Engine, g: float, H: float, Q_th: Any,
                           Q_ps: Any, lib: ModuleType = np
                           ) -> tuple[Any, Any, Any, Any, Any, Any, Any, Any]:
    """:func:`state_derivative` under given generalised forces of friction (N m)."""
    return _derivative(kind, y, motion_under(kind, y, e, g, H, Q_th, Q_ps, lib), e, g)


def friction_derivative(kind: int, y: Any, p: tuple, n_R: Any, n_H: Any, e: Engine,
                        g: float) -> tuple[Any, Any, Any, Any, Any, Any, Any, Any]:
    """:func:`state_derivative` of an engine with friction from the pieces ``p`` of
    :func:`friction_pieces` at the state ``y`` and the solved load magnitudes ``n_R``,
    ``n_H`` (N, :func:`friction_solve`): :func:`motion_of_pieces`, no equation evaluated
    again (the C glue's right-hand side, generated from this)."""
    if kind == 2:
        th, ps, th_d, ps_d = y[0], y[1], y[3], y[4]
    else:
        th, ps, th_d, ps_d = y[0], y[1], y[2], y[3]
    return _derivative(kind, y, motion_of_pieces(th, ps, th_d, ps_d, p, n_R, n_H), e, g)


def _derivative(kind: int, y: Any, m: tuple, e: Engine, g: float) -> tuple:
    scale = energy_scale(e, g)
    loss_P, loss_H = m[9] / scale, m[10] / scale
    if kind == 2:
        return y[3], y[4], y[5], m[6], m[7], m[8], loss_P, loss_H
    zero = 0.0 * m[6]
    return y[2], y[3], m[6], m[7], loss_P, loss_H, zero, zero
