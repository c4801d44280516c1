"""Where the five tracked points of the engine are, in its plane, for given angles.

The points and the paper's conventions (:mod:`trebuchet.model.kinematics`; m, rad, x to the
right, y up, origin on the ground under the pivot, e_a = (cos a, sin a))::

    pivot          r_P = H e_y
    spigot         r_S = H e_y + L1 e_θ
    hinge          r_H = H e_y − L2 e_θ
    counterweight  r_M = H e_y − L2 e_θ + L3 e_ψ
    projectile     r_m = H e_y + L1 e_θ + L4 e_φ      (in the trough or the sling)
"""

from __future__ import annotations

import numpy as np

from trebuchet.model.kinematics import (
    counterweight_position,
    hinge_position,
    projectile_position,
    spigot_position,
)
from trebuchet.model.scene import Engine

__all__ = ["POINTS", "plane_points"]

#: The tracked points, in the order used everywhere in this package.
POINTS = ("pivot", "spigot", "hinge", "counterweight", "projectile")


def plane_points(theta: np.ndarray, psi: np.ndarray, phi: np.ndarray, engine: Engine,
                 H: float) -> dict[str, np.ndarray]:
    """Positions (n, 2) m of the five points for angles ``theta``, ``psi``, ``phi`` (n,) rad."""
    theta = np.asarray(theta, dtype=float)
    pivot = np.zeros((2, theta.size))
    pivot[1] = H
    return {
        "pivot": pivot.T,
        "spigot": spigot_position(theta, engine, H).T,
        "hinge": hinge_position(theta, engine, H).T,
        "counterweight": counterweight_position(theta, np.asarray(psi, float), engine, H).T,
        "projectile": projectile_position(theta, np.asarray(phi, float), engine, H).T,
    }
