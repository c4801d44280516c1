"""Kinematics of the paper's Section 3: unit vectors, the rotated generalised
accelerations ``R_a A_a``, and positions, velocities and accelerations of the
projectile, counterweight and beam centre of mass.

Vectors are numpy arrays of shape ``(2, n)`` (x row, y row), vectorised over
time. The origin lies on the ground under the pivot, x to the right, y up;
with θ increasing the projectile is thrown toward −x. Angles in rad, lengths
in m, velocities in m/s, accelerations in m/s².
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .scene import Engine

__all__ = [
    "Angle",
    "unit",
    "unit_perp",
    "rotated_acceleration",
    "dot",
    "spigot_position",
    "hinge_position",
    "projectile_position",
    "projectile_velocity",
    "counterweight_position",
    "counterweight_velocity",
    "centre_of_mass_velocity",
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
        w2 = self.rate * self.rate
        return np.array([-self.cos * w2 - self.sin * self.acc,
                         -self.sin * w2 + self.cos * self.acc])


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


def projectile_position(theta: np.ndarray, phi: np.ndarray, e: Engine, H: float) -> np.ndarray:
    """``r_m = H e_y + L1 e_θ + L4 e_φ`` (paper, eq. (1)), m."""
    r = e.L1 * unit(theta) + e.L4 * unit(phi)
    r[1] += H
    return r


def projectile_velocity(theta: np.ndarray, phi: np.ndarray, theta_d: np.ndarray,
                        phi_d: np.ndarray, e: Engine) -> np.ndarray:
    """``v_m = L1 θ̇ e_θ⊥ + L4 φ̇ e_φ⊥`` (paper, eq. (7); eq. (4) in the trough), m/s."""
    return e.L1 * theta_d * unit_perp(theta) + e.L4 * phi_d * unit_perp(phi)


def counterweight_position(theta: np.ndarray, psi: np.ndarray, e: Engine, H: float) -> np.ndarray:
    """``r_M = H e_y − L2 e_θ + L3 e_ψ``, m."""
    r = -e.L2 * unit(theta) + e.L3 * unit(psi)
    r[1] += H
    return r


def counterweight_velocity(theta: np.ndarray, psi: np.ndarray, theta_d: np.ndarray,
                           psi_d: np.ndarray, e: Engine) -> np.ndarray:
    """``v_M = −L2 θ̇ e_θ⊥ + L3 ψ̇ e_ψ⊥``, m/s."""
    return -e.L2 * theta_d * unit_perp(theta) + e.L3 * psi_d * unit_perp(psi)


def centre_of_mass_velocity(theta: np.ndarray, theta_d: np.ndarray, e: Engine) -> np.ndarray:
    """``v_CM = L_CM θ̇ e_θ⊥``, m/s."""
    return e.L_CM * theta_d * unit_perp(theta)
