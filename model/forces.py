"""Internal forces, torque, rates of work and energies (the paper's Sections 6–8).

Every force is a sum of terms mass × length × rotated generalised
acceleration, ``M_a L_a R_a A_a``, plus a constant gravity term, exactly as
in the paper. Each formula is written once, as a ``*_xy`` function of
rotated accelerations ``R_a A_a``, cosines, sines and rates that returns the
force's ``(x, y)`` components in N: it runs on floats, compiled with numba one
row at a time (:mod:`trebuchet.model.loads_kernel`, the path of every load
column), and on numpy arrays over time. The functions named without ``_xy``
take :class:`~trebuchet.model.kinematics.Angle` objects and return arrays of
shape ``(2, n)``; :func:`row_loads` composes the formulas into the columns of
the interface (docs/interface.md) for one row; :func:`trebuchet.model.loads.loads` does it for
a whole table. The simulator, the ingest path and the FMU all call that.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any

import numpy as np

from trebuchet.model import kinematics as kin
from trebuchet.model.friction import friction_couples, friction_generalised_forces, loss_powers
from trebuchet.model.kinematics import Angle, trough_f_g
from trebuchet.model.scene import Engine, Scene

__all__ = [
    "centre_of_mass_force",
    "centre_of_mass_force_xy",
    "hinge_force",
    "hinge_force_xy",
    "hinge_force_along_arm",
    "hinge_force_along_arm_xy",
    "sling_force_in_sling",
    "sling_force_in_sling_xy",
    "sling_force_along_sling",
    "sling_force_along_sling_xy",
    "sling_force_in_trough",
    "sling_force_in_trough_xy",
    "pivot_reaction",
    "pivot_reaction_xy",
    "torque_contributions",
    "torque_contributions_xy",
    "trough_normal_force",
    "projectile_energy",
    "energies",
    "energies_xy",
    "joint_forces_xy",
    "hinge_force_with_pin_friction_xy",
    "row_loads",
    "LOAD_COLUMNS",
    "ROW_COLUMNS",
    "FRICTION_COLUMNS",
]


#: The input columns of :func:`loads`: each angle, its rate and its acceleration.
ANGLE_COLUMNS = (("theta", "theta_d", "theta_dd"), ("psi", "psi_d", "psi_dd"),
                 ("phi", "phi_d", "phi_dd"))

LOAD_COLUMNS = [
    "F_S_x", "F_S_y", "F_H_x", "F_H_y", "F_CM_x", "F_CM_y", "F_R_x", "F_R_y", "torque",
    "P_m", "P_M", "P_beam", "E_m", "E_M", "E_beam", "x_m", "y_m", "vx_m", "vy_m",
]

#: Every column :func:`row_loads` returns, in its order: the contract's, then the extras.
ROW_COLUMNS = (*LOAD_COLUMNS, "F_N", "F_M_x", "F_M_y", "F_m_x", "F_m_y", "sling_tension",
               "torque_hinge", "torque_cm", "torque_spigot",
               "F_S_par", "F_S_perp", "F_H_par", "F_H_perp", "F_CM_par", "F_CM_perp",
               "F_R_par", "F_R_perp",
               "F_S_abs", "F_H_abs", "F_CM_abs", "F_R_abs", "F_M_abs", "F_m_abs",
               "torque_friction", "P_loss_pivot", "P_loss_hinge")

#: The columns of :data:`ROW_COLUMNS` that only an engine with friction has (zero without).
FRICTION_COLUMNS = ("torque_friction", "P_loss_pivot", "P_loss_hinge")


# ---------------------------------------------------------------------------------------------
# The formulas, on components: floats (compiled, a row at a time) or arrays (over time)

def _along(F: Any, cos_a: Any, sin_a: Any) -> Any:
    """``F·e_a``: the component of ``F`` along ``e_a = (cos a, sin a)``."""
    return F[0] * cos_a + F[1] * sin_a


def _across(F: Any, cos_a: Any, sin_a: Any) -> Any:
    """``F·e_a⊥``: the component of ``F`` along ``e_a⊥ = (−sin a, cos a)``."""
    return F[1] * cos_a - F[0] * sin_a


def centre_of_mass_force_xy(RA_th: Any, e: Engine, g: float) -> tuple[Any, Any]:
    """``F_CM = m_b L_CM R_θ A_θ + m_b g e_y`` (paper, eq. (10)), N: the force the rest of the
    beam exerts on its centre-of-mass particle. ``RA_th``: ``R_θ A_θ`` (rad/s²)."""
    k = e.m_b * e.L_CM
    return k * RA_th[0], k * RA_th[1] + e.m_b * g


def hinge_force_xy(RA_th: Any, RA_ps: Any, e: Engine, g: float) -> tuple[Any, Any]:
    """``F_H = −M L2 R_θ A_θ + M L3 R_ψ A_ψ + M g e_y`` (paper, eq. (11)), N: force from the
    beam on the counterweight at the hinge."""
    a, b = -e.M * e.L2, e.M * e.L3
    return a * RA_th[0] + b * RA_ps[0], a * RA_th[1] + b * RA_ps[1] + e.M * g


def hinge_force_along_arm_xy(RA_th: Any, cos_ps: Any, sin_ps: Any, psi_d: Any, e: Engine,
                             g: float) -> tuple[Any, Any]:
    """``(F_H·e_ψ) e_ψ``, N: eq. (11) projected on the counterweight arm, where the paper shows
    ``F_H ∥ e_ψ``. The projection holds no ψ̈ (``e_ψ·R_ψ A_ψ = −ψ̇²``), so it is the robust form
    for measured angles."""
    along = (-e.M * e.L2 * _along(RA_th, cos_ps, sin_ps) - e.M * e.L3 * psi_d * psi_d
             + e.M * g * sin_ps)
    return along * cos_ps, along * sin_ps


def hinge_force_with_pin_friction_xy(RA_th: Any, cos_ps: Any, sin_ps: Any, theta_d: Any,
                                     psi_d: Any, e: Engine, g: float,
                                     lib: Any = np) -> tuple[Any, Any]:
    """F_H, N, free of ψ̈ where the hinge pin has friction: the arm is massless, so the pin's
    couple ``−τ_H`` on it balances the moment of F_H about the hinge, ``L3 F_H·e_ψ⊥ = −τ_H``
    with ``τ_H = μ_H r_H |F_H| s(ψ̇ − θ̇)``. With ``k = μ_H r_H s(ψ̇ − θ̇)/L3`` and the
    component along the arm ``F_∥`` of :func:`hinge_force_along_arm_xy`:
    ``|F_H| = |F_∥| / √(1 − k²)`` and ``F_H·e_ψ⊥ = −k |F_H|``. Equal to eq. (11) on an exact
    motion (a test says so)."""
    k = friction_couples(0.0, 1.0, theta_d, psi_d, e, lib)[1] / e.L3
    F_par = hinge_force_along_arm_xy(RA_th, cos_ps, sin_ps, psi_d, e, g)
    along = _along(F_par, cos_ps, sin_ps)
    across = -k * lib.sqrt(along * along / (1.0 - k * k))
    return F_par[0] - across * sin_ps, F_par[1] + across * cos_ps


def sling_force_in_sling_xy(RA_th: Any, RA_ph: Any, e: Engine, g: float) -> tuple[Any, Any]:
    """``F_S = m L1 R_θ A_θ + m L4 R_φ A_φ + m g e_y`` (paper, eq. (13)), N: sling tension on the
    projectile in phase II."""
    a, b = e.m * e.L1, e.m * e.L4
    return a * RA_th[0] + b * RA_ph[0], a * RA_th[1] + b * RA_ph[1] + e.m * g


def sling_force_along_sling_xy(RA_th: Any, cos_ph: Any, sin_ph: Any, phi_d: Any, e: Engine,
                               g: float) -> tuple[Any, Any]:
    """``(F_S·e_φ) e_φ``, N: eq. (13) projected on the sling (``F_S ∥ e_φ``); holds no φ̈."""
    along = (e.m * e.L1 * _along(RA_th, cos_ph, sin_ph) - e.m * e.L4 * phi_d * phi_d
             + e.m * g * sin_ph)
    return along * cos_ph, along * sin_ph


def sling_force_in_trough_xy(theta: Any, theta_d: Any, theta_dd: Any, phi: Any, e: Engine,
                             lib: Any = np) -> tuple[Any, Any]:
    """``F_S = m L1 (f θ̈ + g θ̇²)(e_x + tan φ e_y)`` (paper, eq. (16)), N: sling tension on the
    projectile dragged in the trough (phase I). ``lib``: ``math`` on floats, numpy on arrays."""
    f, gg = trough_f_g(theta, phi, e, lib)
    F_x = e.m * e.L1 * (f * theta_dd + gg * theta_d * theta_d)
    return F_x, F_x * lib.tan(phi)


def trough_normal_force(F_S_y: Any, e: Engine, g: float) -> Any:
    """Normal force of the trough on the projectile, ``F_N = m g − F_S·e_y``, N (phase I).
    Lift-off where it reaches zero."""
    return e.m * g - F_S_y


def pivot_reaction_xy(F_H: Any, F_CM: Any, F_S: Any) -> tuple[Any, Any]:
    """``F_R = F_H + F_CM + F_S`` (paper, eq. (14)), N: bearing reaction on the beam at P."""
    return F_H[0] + F_CM[0] + F_S[0], F_H[1] + F_CM[1] + F_S[1]


def joint_forces_xy(phase: int, th: Any, th_d: Any, th_dd: Any, ps: Any, ps_d: Any,
                    ps_dd: Any, ph: Any, ph_d: Any, ph_dd: Any, e: Engine, g: float,
                    lib: Any = math) -> tuple[tuple[Any, Any], tuple[Any, Any]]:
    """The bearing reaction F_R (eq. (14)) and the hinge force F_H (eq. (11)), N, in their
    direct forms, from the angles (rad), rates (rad/s) and accelerations (rad/s²) of
    ``phase`` (the sling's F_S of eq. (16) in the trough, (13) in the sling, none after
    release): the loads on the bearings, which friction follows."""
    c_th, s_th = lib.cos(th), lib.sin(th)
    RA_th = kin.rotated_acceleration_xy(c_th, s_th, th_d, th_dd)
    F_H = hinge_force_xy(RA_th, kin.rotated_acceleration_xy(lib.cos(ps), lib.sin(ps), ps_d,
                                                            ps_dd), e, g)
    if phase == 1:
        F_S = sling_force_in_trough_xy(th, th_d, th_dd, ph, e, lib)
    elif phase == 2:
        F_S = sling_force_in_sling_xy(RA_th, kin.rotated_acceleration_xy(
            lib.cos(ph), lib.sin(ph), ph_d, ph_dd), e, g)
    else:
        F_S = (0.0 * th, 0.0 * th)
    return pivot_reaction_xy(F_H, centre_of_mass_force_xy(RA_th, e, g), F_S), F_H


def torque_contributions_xy(cos_th: Any, sin_th: Any, cos_ps: Any, sin_ps: Any, F_H: Any,
                            F_S: Any, e: Engine, g: float) -> tuple[Any, Any, Any]:
    """The three terms of the torque on the beam about the pivot (paper, eq. (19)), N m:
    hinge ``L2 F_H·e_θ⊥``, centre of mass ``−L_CM m_b g e_y·e_θ⊥``, spigot ``−L1 F_S·e_θ⊥``.

    A counterweight fixed rigidly to the beam pushes along no arm: its force acts at the
    counterweight, and the hinge term gains ``−L3 F_H·e_ψ⊥`` (zero for the hinged one, where
    ``F_H ∥ e_ψ``)."""
    hinge = e.L2 * _across(F_H, cos_th, sin_th)
    if e.fixed_counterweight:
        hinge = hinge - e.L3 * _across(F_H, cos_ps, sin_ps)
    return hinge, -e.L_CM * e.m_b * g * cos_th, -e.L1 * _across(F_S, cos_th, sin_th)


def projectile_energy(v_m: Any, y_m: Any, e: Engine, g: float) -> Any:
    """``½ m |v_m|² + m g y_m``, J: the projectile's mechanical energy (potential zero on the
    ground)."""
    return 0.5 * e.m * (v_m[0] * v_m[0] + v_m[1] * v_m[1]) + e.m * g * y_m


def energies_xy(cos_th: Any, sin_th: Any, theta_d: Any, cos_ps: Any, sin_ps: Any, psi_d: Any,
                v_m: Any, y_m: Any, e: Engine, g: float, H: float) -> tuple[Any, Any, Any]:
    """Mechanical energy (kinetic + potential, potential zero on the ground) of the projectile,
    counterweight and beam, J (paper, Section 4)."""
    r_M = kin.counterweight_position_xy(cos_th, sin_th, cos_ps, sin_ps, e, H)
    v_M = kin.counterweight_velocity_xy(cos_th, sin_th, theta_d, cos_ps, sin_ps, psi_d, e)
    E_M = 0.5 * e.M * (v_M[0] * v_M[0] + v_M[1] * v_M[1]) + e.M * g * r_M[1]
    E_b = 0.5 * e.I * theta_d * theta_d + e.m_b * g * (H + e.L_CM * sin_th)
    return projectile_energy(v_m, y_m, e, g), E_M, E_b


# ---------------------------------------------------------------------------------------------
# The same formulas on angles over time: arrays of shape (2, n)

def centre_of_mass_force(theta: Angle, e: Engine, g: float) -> np.ndarray:
    """:func:`centre_of_mass_force_xy` (paper, eq. (10)) over time, N, shape (2, n)."""
    return np.array(centre_of_mass_force_xy(theta.RA, e, g))


def hinge_force(theta: Angle, psi: Angle, e: Engine, g: float) -> np.ndarray:
    """:func:`hinge_force_xy` (paper, eq. (11)) over time, N, shape (2, n)."""
    return np.array(hinge_force_xy(theta.RA, psi.RA, e, g))


def hinge_force_along_arm(theta: Angle, psi: Angle, e: Engine, g: float) -> np.ndarray:
    """:func:`hinge_force_along_arm_xy` over time, N, shape (2, n)."""
    return np.array(hinge_force_along_arm_xy(theta.RA, psi.cos, psi.sin, psi.rate, e, g))


def sling_force_in_sling(theta: Angle, phi: Angle, e: Engine, g: float) -> np.ndarray:
    """:func:`sling_force_in_sling_xy` (paper, eq. (13)) over time, N, shape (2, n)."""
    return np.array(sling_force_in_sling_xy(theta.RA, phi.RA, e, g))


def sling_force_along_sling(theta: Angle, phi: Angle, e: Engine, g: float) -> np.ndarray:
    """:func:`sling_force_along_sling_xy` over time, N, shape (2, n)."""
    return np.array(sling_force_along_sling_xy(theta.RA, phi.cos, phi.sin, phi.rate, e, g))


def sling_force_in_trough(theta: Angle, phi: Angle, e: Engine) -> np.ndarray:
    """:func:`sling_force_in_trough_xy` (paper, eq. (16)) over time, N, shape (2, n)."""
    return np.array(sling_force_in_trough_xy(theta.value, theta.rate, theta.acc, phi.value, e))


def pivot_reaction(F_H: np.ndarray, F_CM: np.ndarray, F_S: np.ndarray) -> np.ndarray:
    """:func:`pivot_reaction_xy` (paper, eq. (14)) over time, N, shape (2, n)."""
    return np.array(pivot_reaction_xy(F_H, F_CM, F_S))


def torque_contributions(theta: Angle, psi: Angle, F_H: np.ndarray, F_S: np.ndarray,
                         e: Engine, g: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`torque_contributions_xy` (paper, eq. (19)) over time, N m."""
    return torque_contributions_xy(theta.cos, theta.sin, psi.cos, psi.sin, F_H, F_S, e, g)


def energies(theta: Angle, psi: Angle, v_m: np.ndarray, y_m, e: Engine, g: float,
             H: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`energies_xy` over time: projectile, counterweight and beam, J."""
    return energies_xy(theta.cos, theta.sin, theta.rate, psi.cos, psi.sin, psi.rate, v_m, y_m,
                       e, g, H)


@lru_cache(maxsize=256)
def rest_energies(scene: Scene) -> tuple[float, float, float]:
    """:func:`energies` of projectile, counterweight and beam at rest before the trigger, J:
    the zero of the energies :func:`loads` reports (the projectile lies on the ground in the
    trough, or hangs in the sling where the scene starts it there)."""
    e, g, H, rest, zero = scene.engine, scene.g, scene.start.H, scene.start, np.zeros(1)
    rest_th = kin.Angle(np.array([rest.theta]), zero, zero)
    rest_ps = kin.Angle(np.array([rest.psi]), zero, zero)
    y_rest = (kin.projectile_position(rest_th, np.array([rest.phi]), e, H)[1]
              if scene.projectile == "sling" else zero)
    E_m, E_M, E_b = energies(rest_th, rest_ps, np.zeros((2, 1)), y_rest, e, g, H)
    return float(E_m[0]), float(E_M[0]), float(E_b[0])


# ---------------------------------------------------------------------------------------------
# One row of every load column

def row_loads(phase: int, th: float, th_d: float, th_dd: float, ps: float, ps_d: float,
              ps_dd: float, ph: float, ph_d: float, ph_dd: float, e: Engine, g: float,
              H: float, projected: bool, rest: tuple[float, float, float]) -> tuple:
    """Every column of :data:`ROW_COLUMNS` for one instant, from the angles (rad), rates
    (rad/s) and accelerations (rad/s²) in ``phase`` (1 trough, 2 sling, 3 released; the sling's
    angle is ignored in phase 3). ``projected``: F_H along the counterweight arm and F_S along
    the sling (:func:`loads`' ``form``). ``rest``: the energies at rest (J), the zero of the
    energy columns. After release the projectile's columns (``x_m … vy_m``, ``E_m``) are NaN:
    its flight is not a function of the angles (:func:`load_columns` fills them in)."""
    held = phase == 1 or phase == 2
    if not held:
        ph = ph_d = ph_dd = 0.0
    c_th, s_th = math.cos(th), math.sin(th)
    c_ps, s_ps = math.cos(ps), math.sin(ps)
    c_ph, s_ph = math.cos(ph), math.sin(ph)
    RA_th = kin.rotated_acceleration_xy(c_th, s_th, th_d, th_dd)
    F_CM = centre_of_mass_force_xy(RA_th, e, g)
    if projected and not e.fixed_counterweight and e.hinge_friction != 0.0:
        F_H = hinge_force_with_pin_friction_xy(RA_th, c_ps, s_ps, th_d, ps_d, e, g, math)
    elif projected and not e.fixed_counterweight:
        F_H = hinge_force_along_arm_xy(RA_th, c_ps, s_ps, ps_d, e, g)
    else:
        F_H = hinge_force_xy(RA_th, kin.rotated_acceleration_xy(c_ps, s_ps, ps_d, ps_dd), e, g)
    F_N = 0.0
    if phase == 1:
        F_S = sling_force_in_trough_xy(th, th_d, th_dd, ph, e, math)
        F_N = trough_normal_force(F_S[1], e, g)
    elif phase == 2 and projected:
        F_S = sling_force_along_sling_xy(RA_th, c_ph, s_ph, ph_d, e, g)
    elif phase == 2:
        F_S = sling_force_in_sling_xy(RA_th, kin.rotated_acceleration_xy(c_ph, s_ph, ph_d,
                                                                         ph_dd), e, g)
    else:
        F_S = (0.0, 0.0)
    F_R = pivot_reaction_xy(F_H, F_CM, F_S)
    F_R_abs = math.sqrt(F_R[0] * F_R[0] + F_R[1] * F_R[1])
    F_H_abs = math.sqrt(F_H[0] * F_H[0] + F_H[1] * F_H[1])
    t_hinge, t_cm, t_spigot = torque_contributions_xy(c_th, s_th, c_ps, s_ps, F_H, F_S, e, g)
    torque = t_hinge + t_cm + t_spigot
    t_friction = P_pivot = P_hinge = 0.0
    if e.pivot_friction != 0.0 or e.hinge_friction != 0.0:
        tau_P, tau_H = friction_couples(F_R_abs, F_H_abs, th_d, ps_d, e, math)
        t_friction = friction_generalised_forces(tau_P, tau_H)[0]
        P_pivot, P_hinge = loss_powers(tau_P, tau_H, th_d, ps_d)
        torque = torque + t_friction

    v_M = kin.counterweight_velocity_xy(c_th, s_th, th_d, c_ps, s_ps, ps_d, e)
    v_CM = kin.centre_of_mass_velocity_xy(c_th, s_th, th_d, e)
    r_m = kin.projectile_position_xy(c_th, s_th, c_ph, s_ph, e, H)
    v_m = kin.projectile_velocity_xy(c_th, s_th, th_d, c_ph, s_ph, ph_d, e)
    E_m, E_M, E_b = energies_xy(c_th, s_th, th_d, c_ps, s_ps, ps_d, v_m, r_m[1], e, g, H)
    P_m = _along(F_S, v_m[0], v_m[1]) if held else 0.0
    if e.m == 0.0:  # dry fire: there is no projectile
        r_m, v_m, E_m = (math.nan, math.nan), (math.nan, math.nan), rest[0]
    elif not held:  # in flight: filled in from the release state
        r_m, v_m, E_m = (math.nan, math.nan), (math.nan, math.nan), math.nan
    F_M = (F_H[0], F_H[1] - e.M * g)
    F_m = (F_S[0], F_S[1] - e.m * g + F_N)
    tension = -_along(F_S, c_ph, s_ph) if held else 0.0
    return (F_S[0], F_S[1], F_H[0], F_H[1], F_CM[0], F_CM[1], F_R[0], F_R[1], torque,
            P_m, _along(F_H, v_M[0], v_M[1]), torque * th_d + e.m_b * g * v_CM[1],
            E_m - rest[0], E_M - rest[1], E_b - rest[2], r_m[0], r_m[1], v_m[0], v_m[1],
            F_N, F_M[0], F_M[1], F_m[0], F_m[1], tension, t_hinge, t_cm, t_spigot,
            _along(F_S, c_th, s_th), _across(F_S, c_th, s_th),
            _along(F_H, c_th, s_th), _across(F_H, c_th, s_th),
            _along(F_CM, c_th, s_th), _across(F_CM, c_th, s_th),
            _along(F_R, c_th, s_th), _across(F_R, c_th, s_th),
            math.sqrt(F_S[0] * F_S[0] + F_S[1] * F_S[1]), F_H_abs,
            math.sqrt(F_CM[0] * F_CM[0] + F_CM[1] * F_CM[1]), F_R_abs,
            math.sqrt(F_M[0] * F_M[0] + F_M[1] * F_M[1]),
            math.sqrt(F_m[0] * F_m[0] + F_m[1] * F_m[1]), t_friction, P_pivot, P_hinge)
