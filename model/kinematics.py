"""Kinematics of the paper's Section 3: unit vectors, the rotated generalised
accelerations ``R_a A_a``, and positions, velocities and accelerations of the
projectile, counterweight and beam centre of mass.

Each quantity is written once, as a function of the angles' cosines, sines,
rates and accelerations that returns its ``(x, y)`` components: the same
function runs on floats (compiled with numba in
:mod:`trebuchet.model.loads_kernel`, one row at a time) and on numpy arrays
over time. The functions named without ``_xy`` take angles (arrays or
:class:`Angle`) and return numpy arrays of shape ``(2, n)`` (x row, y row).

The origin lies on the ground under the pivot, x to the right, y up; with θ
increasing the projectile is thrown toward −x. Angles in rad, lengths in m,
velocities in m/s, accelerations in m/s².
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from types import ModuleType
from typing import Any

import numpy as np

from trebuchet.model.scene import Engine

__all__ = [
    "Angle",
    "unit",
    "unit_perp",
    "rotated_acceleration",
    "rotated_acceleration_xy",
    "dot",
    "spigot_position",
    "hinge_position",
    "projectile_position",
    "projectile_position_xy",
    "projectile_velocity",
    "projectile_velocity_xy",
    "counterweight_position",
    "counterweight_position_xy",
    "counterweight_velocity",
    "counterweight_velocity_xy",
    "centre_of_mass_velocity",
    "centre_of_mass_velocity_xy",
    "trough_sling_angle",
    "trough_f_g",
    "trough_phi_d",
    "trough_phi_dd",
]



@dataclass(frozen=True, eq=False)
class Angle:
    """One of the paper's angles over time: ``value`` (rad), ``rate`` (rad/s), ``acc``
    (rad/s²), arrays of one length. Its unit vectors and rotated generalised acceleration are
    computed once, on first use, and shared by every formula that needs them."""

    value: np.ndarray
    rate: np.ndarray
    acc: np.ndarray

    @cached_property
    def cos(self) -> np.ndarray:
        return np.cos(self.value)

    @cached_property
    def sin(self) -> np.ndarray:
        return np.sin(self.value)

    @cached_property
    def unit(self) -> np.ndarray:
        """``e_a = (cos a, sin a)``, shape (2, n)."""
        return np.array([self.cos, self.sin])

    @cached_property
    def perp(self) -> np.ndarray:
        """``e_a⊥ = (−sin a, cos a)``, shape (2, n)."""
        return np.array([-self.sin, self.cos])

    @cached_property
    def RA(self) -> np.ndarray:
        """``R_a A_a = ä e_a⊥ − ȧ² e_a`` (the paper's eq. (9)), rad/s² per unit length."""
        return np.array(rotated_acceleration_xy(self.cos, self.sin, self.rate, self.acc))


def _cos_sin(a: Any) -> tuple[Any, Any]:
    """Cosine and sine of an angle given as an :class:`Angle` or as values (rad)."""
    if isinstance(a, Angle):
        return a.cos, a.sin
    return np.cos(a), np.sin(a)


def unit(a: np.ndarray | Angle) -> np.ndarray:
    """``e_a = (cos a, sin a)``, shape (2, n)."""
    if isinstance(a, Angle):
        return a.unit
    return np.array([np.cos(a), np.sin(a)])


def unit_perp(a: np.ndarray | Angle) -> np.ndarray:
    """``e_a⊥ = (−sin a, cos a)``, shape (2, n)."""
    if isinstance(a, Angle):
        return a.perp
    return np.array([-np.sin(a), np.cos(a)])


def rotated_acceleration_xy(cos_a: Any, sin_a: Any, rate: Any, acc: Any) -> tuple[Any, Any]:
    """``R_a A_a = ä e_a⊥ − ȧ² e_a`` (the paper's eq. (9)) as its components, rad/s² per unit
    length, from ``cos a``, ``sin a``, ``ȧ`` (rad/s) and ``ä`` (rad/s²)."""
    w2 = rate * rate
    return -cos_a * w2 - sin_a * acc, -sin_a * w2 + cos_a * acc


def rotated_acceleration(a: np.ndarray, a_d: np.ndarray, a_dd: np.ndarray) -> np.ndarray:
    """``R_a A_a = ä e_a⊥ − ȧ² e_a`` (the paper's eq. (9)), rad/s² per unit length, shape (2, n).

    Multiplied by a length it is the acceleration of a point at that distance
    along ``e_a`` from a fixed point.
    """
    return Angle(a, a_d, a_dd).RA


def dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Row-wise scalar product of two (2, n) vector arrays."""
    return u[0] * v[0] + u[1] * v[1]


def spigot_position(theta: np.ndarray, e: Engine, H: float) -> np.ndarray:
    """``r_S = H e_y + L1 e_θ``, m: where the sling hangs from the beam."""
    r = e.L1 * unit(theta)
    r[1] += H
    return r


def hinge_position(theta: np.ndarray, e: Engine, H: float) -> np.ndarray:
    """``r_H = H e_y − L2 e_θ``, m: where the counterweight hangs from the beam."""
    r = -e.L2 * unit(theta)
    r[1] += H
    return r


def projectile_position_xy(cos_th: Any, sin_th: Any, cos_ph: Any, sin_ph: Any, e: Engine,
                           H: float) -> tuple[Any, Any]:
    """``r_m = H e_y + L1 e_θ + L4 e_φ`` (paper, eq. (1)), m, as its components."""
    return e.L1 * cos_th + e.L4 * cos_ph, H + e.L1 * sin_th + e.L4 * sin_ph


def projectile_position(theta: np.ndarray | Angle, phi: np.ndarray | Angle, e: Engine,
                        H: float) -> np.ndarray:
    """``r_m = H e_y + L1 e_θ + L4 e_φ`` (paper, eq. (1)), m, shape (2, n)."""
    return np.array(projectile_position_xy(*_cos_sin(theta), *_cos_sin(phi), e, H))


def projectile_velocity_xy(cos_th: Any, sin_th: Any, theta_d: Any, cos_ph: Any, sin_ph: Any,
                           phi_d: Any, e: Engine) -> tuple[Any, Any]:
    """``v_m = L1 θ̇ e_θ⊥ + L4 φ̇ e_φ⊥`` (paper, eq. (7); eq. (4) in the trough), m/s, as its
    components."""
    a, b = e.L1 * theta_d, e.L4 * phi_d
    return -a * sin_th - b * sin_ph, a * cos_th + b * cos_ph


def projectile_velocity(theta: np.ndarray | Angle, phi: np.ndarray | Angle, theta_d: np.ndarray,
                        phi_d: np.ndarray, e: Engine) -> np.ndarray:
    """``v_m = L1 θ̇ e_θ⊥ + L4 φ̇ e_φ⊥`` (paper, eq. (7); eq. (4) in the trough), m/s."""
    ct, st = _cos_sin(theta)
    cp, sp = _cos_sin(phi)
    return np.array(projectile_velocity_xy(ct, st, theta_d, cp, sp, phi_d, e))


def counterweight_position_xy(cos_th: Any, sin_th: Any, cos_ps: Any, sin_ps: Any, e: Engine,
                              H: float) -> tuple[Any, Any]:
    """``r_M = H e_y − L2 e_θ + L3 e_ψ``, m, as its components."""
    return -e.L2 * cos_th + e.L3 * cos_ps, H - e.L2 * sin_th + e.L3 * sin_ps


def counterweight_position(theta: np.ndarray | Angle, psi: np.ndarray | Angle, e: Engine,
                           H: float) -> np.ndarray:
    """``r_M = H e_y − L2 e_θ + L3 e_ψ``, m, shape (2, n)."""
    return np.array(counterweight_position_xy(*_cos_sin(theta), *_cos_sin(psi), e, H))


def counterweight_velocity_xy(cos_th: Any, sin_th: Any, theta_d: Any, cos_ps: Any, sin_ps: Any,
                              psi_d: Any, e: Engine) -> tuple[Any, Any]:
    """``v_M = −L2 θ̇ e_θ⊥ + L3 ψ̇ e_ψ⊥``, m/s, as its components."""
    a, b = -e.L2 * theta_d, e.L3 * psi_d
    return -a * sin_th - b * sin_ps, a * cos_th + b * cos_ps


def counterweight_velocity(theta: np.ndarray | Angle, psi: np.ndarray | Angle,
                           theta_d: np.ndarray, psi_d: np.ndarray, e: Engine) -> np.ndarray:
    """``v_M = −L2 θ̇ e_θ⊥ + L3 ψ̇ e_ψ⊥``, m/s, shape (2, n)."""
    ct, st = _cos_sin(theta)
    cp, sp = _cos_sin(psi)
    return np.array(counterweight_velocity_xy(ct, st, theta_d, cp, sp, psi_d, e))


def centre_of_mass_velocity_xy(cos_th: Any, sin_th: Any, theta_d: Any,
                               e: Engine) -> tuple[Any, Any]:
    """``v_CM = L_CM θ̇ e_θ⊥``, m/s, as its components."""
    a = e.L_CM * theta_d
    return -a * sin_th, a * cos_th


def centre_of_mass_velocity(theta: np.ndarray | Angle, theta_d: np.ndarray,
                            e: Engine) -> np.ndarray:
    """``v_CM = L_CM θ̇ e_θ⊥``, m/s, shape (2, n)."""
    return np.array(centre_of_mass_velocity_xy(*_cos_sin(theta), theta_d, e))


# ---------------------------------------------------------------------------------------------
# The trough constraint of phase I (the projectile on the ground, the sling taut)

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
