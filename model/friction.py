"""Coulomb friction in the bearings: the couples, their generalised forces and the heat.

The paper: "Heat is generated here due to sliding friction at rates proportional to the
appropriate reaction forces and sliding speeds"; the losses that matter are at the beam's
shaft (the pivot) and the counterweight's hinge pin. A shaft of radius ``r`` turning in its
bearing with coefficient ``μ`` under a load ``|F|`` feels a couple ``μ r |F|`` against its
sliding rate ``w``:

* pivot: ``τ_P = μ_P r_P |F_R| s(θ̇)``, with F_R the bearing reaction (paper, eq. (14));
* hinge: ``τ_H = μ_H r_H |F_H| s(ψ̇ − θ̇)``, with F_H the hinge force (paper, eq. (11)), the
  arm turning at ψ̇ − θ̇ relative to the beam;

with ``s(w) = tanh(w / smoothing_rate)`` for the sign. The couple ``−τ_P`` acts on the beam,
``−τ_H`` on the counterweight's arm and ``+τ_H`` on the beam, so the generalised forces of
the Lagrange equations (virtual work ``Q_θ δθ + Q_ψ δψ``) are

    Q_θ = −τ_P + τ_H,        Q_ψ = −τ_H,

and the heat they make, ``−(Q_θ θ̇ + Q_ψ ψ̇)``, is the sum of the two loss powers
``P_P = τ_P θ̇ ≥ 0`` and ``P_H = τ_H (ψ̇ − θ̇) ≥ 0``. Couples are pure torques: they change no
force balance (F_H = M a_M + M g e_y and F_R = F_CM + F_H + F_S stand as they are), only the
accelerations, and with them every force.

Every function runs on floats (``lib=math``, compiled by numba), numpy arrays and sympy
symbols. ``e`` is an :class:`~trebuchet.model.scene.Engine` or anything with its attributes
``pivot_friction`` (``μ_P r_P``, m), ``hinge_friction`` (``μ_H r_H``, m) and ``friction_rate``
(rad/s). Couples in N m, powers in W.
"""

from __future__ import annotations

import math
from types import ModuleType
from typing import Any

from trebuchet.model.scene import Engine

__all__ = ["has_friction", "sliding_sign", "friction_couples", "friction_generalised_forces",
           "loss_powers"]


def has_friction(e: Engine) -> bool:
    """True when a bearing of ``e`` has friction (``μ r > 0`` at pivot or hinge)."""
    return e.pivot_friction != 0.0 or e.hinge_friction != 0.0


def sliding_sign(w: Any, rate: float, lib: ModuleType = math) -> Any:
    """``s(w) = tanh(w / rate)``: the sign of a sliding rate ``w`` (rad/s), smoothed over
    ``rate`` (rad/s) so that the couple turns continuously through standstill."""
    return lib.tanh(w / rate)


def friction_couples(F_R_abs: Any, F_H_abs: Any, theta_d: Any, psi_d: Any, e: Engine,
                     lib: ModuleType = math) -> tuple[Any, Any]:
    """``τ_P = μ_P r_P |F_R| s(θ̇)`` and ``τ_H = μ_H r_H |F_H| s(ψ̇ − θ̇)``, N m: the friction
    couples of pivot and hinge, signed as the sliding rates they oppose. ``F_R_abs``,
    ``F_H_abs``: the magnitudes of bearing reaction and hinge force, N."""
    rate = e.friction_rate
    return (e.pivot_friction * F_R_abs * sliding_sign(theta_d, rate, lib),
            e.hinge_friction * F_H_abs * sliding_sign(psi_d - theta_d, rate, lib))


def friction_generalised_forces(tau_P: Any, tau_H: Any) -> tuple[Any, Any]:
    """``Q_θ = −τ_P + τ_H`` and ``Q_ψ = −τ_H``, N m: the couples' generalised forces in the
    Lagrange equations of θ and ψ (``−τ_P`` and ``+τ_H`` turn the beam, ``−τ_H`` the arm)."""
    return tau_H - tau_P, -tau_H


def loss_powers(tau_P: Any, tau_H: Any, theta_d: Any, psi_d: Any) -> tuple[Any, Any]:
    """``P_P = τ_P θ̇`` and ``P_H = τ_H (ψ̇ − θ̇)``, W: the heat made at pivot and hinge, never
    negative; their sum is ``−(Q_θ θ̇ + Q_ψ ψ̇)``, the mechanical power friction takes."""
    return tau_P * theta_d, tau_H * (psi_d - theta_d)
