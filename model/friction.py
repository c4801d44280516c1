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

import numpy as np

from trebuchet.model.scene import Engine

__all__ = ["has_friction", "sliding_sign", "friction_couples", "friction_generalised_forces",
           "loss_powers", "friction_start", "friction_newton_step", "friction_newton_margin",
           "friction_first_steps", "friction_solve", "FRICTION_NEWTON_STEPS",
           "FRICTION_NEWTON_EPS"]


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


# ---------------------------------------------------------------------------------------------
# The load magnitudes under the couples: Newton's method on the affine pieces of
# dynamics.friction_pieces (p[0], p[1] the couples' factors, p[2:6] the frictionless loads, N,
# p[6:14] their slopes in the magnitudes)

#: The most Newton steps :func:`friction_solve` takes (it stops before where the steps have
#: converged to round-off: two for the sample engines; the third is below round-off for couples
#: of up to a tenth of what the bearings' loads could turn; tests/test_friction.py measures it).
FRICTION_NEWTON_STEPS = 3
#: The relative round-off Newton's steps converge to (2⁻⁵², float64's epsilon).
FRICTION_NEWTON_EPS = 2.0 ** -52


def friction_start(p: tuple, lib: ModuleType = np) -> tuple[Any, Any]:
    """Newton's start: the frictionless load magnitudes ``|F_R₀|``, ``|F_H₀|`` (N) of the
    pieces ``p`` of ``dynamics.friction_pieces``."""
    return lib.sqrt(p[2] * p[2] + p[3] * p[3]), lib.sqrt(p[4] * p[4] + p[5] * p[5])


def friction_newton_step(p: tuple, n_R: Any, n_H: Any, lib: ModuleType = np
                         ) -> tuple[Any, Any]:
    """One Newton step on ``n = (|F_R(n)|, |F_H(n)|)`` (N) with the pieces ``p`` of
    ``dynamics.friction_pieces``: residual ``f = (|F_R(n)| − n_R, |F_H(n)| − n_H)``, Jacobian
    ``∂|F|/∂n = F̂·∂F/∂n − I``. Each row of the system is multiplied by its ``|F|`` (the same
    step, one division instead of three: ``|F| f = F·F − |F| n``, ``|F| ∂|F|/∂n = F·∂F/∂n −
    |F| I``)."""
    Rx, Ry = p[2] + p[6] * n_R + p[8] * n_H, p[3] + p[7] * n_R + p[9] * n_H
    Hx, Hy = p[4] + p[10] * n_R + p[12] * n_H, p[5] + p[11] * n_R + p[13] * n_H
    RR, HH = Rx * Rx + Ry * Ry, Hx * Hx + Hy * Hy
    abs_R, abs_H = lib.sqrt(RR), lib.sqrt(HH)
    f_R, f_H = RR - abs_R * n_R, HH - abs_H * n_H
    J11 = Rx * p[6] + Ry * p[7] - abs_R
    J12 = Rx * p[8] + Ry * p[9]
    J21 = Hx * p[10] + Hy * p[11]
    J22 = Hx * p[12] + Hy * p[13] - abs_H
    det = J11 * J22 - J12 * J21
    return n_R - (f_R * J22 - f_H * J12) / det, n_H - (J11 * f_H - J21 * f_R) / det


def friction_newton_margin(step: Any, previous: Any, n: Any) -> Any:
    """≤ 0 where a Newton step ``step`` (N) on a load magnitude ``n`` (N) has converged to
    round-off: the step itself below ``ε n`` (``ε = 2⁻⁵²``), or the next one Newton's quadratic
    convergence predicts, ``step³ / previous²`` (``previous`` the step before, N; 0 for the
    first), below it: ``step⁶ − ε² n² (previous² + step²)²``, N⁶ (squares: no absolute value
    or division; a step of 0 or NaN answers as it should)."""
    s2 = step * step
    both = previous * previous + s2
    return s2 * s2 * s2 - FRICTION_NEWTON_EPS * FRICTION_NEWTON_EPS * n * n * both * both


def friction_first_steps(p: tuple, lib: ModuleType = np) -> tuple[Any, Any, Any, Any, Any, Any]:
    """Newton's first two steps (:func:`friction_newton_step`) from the frictionless
    magnitudes (:func:`friction_start`) with the pieces ``p`` of ``dynamics.friction_pieces``: the
    magnitudes ``n_R``, ``n_H`` after them and the second step ``d_R``, ``d_H`` (N), and the
    margins of its convergence (:func:`friction_newton_margin`, ≤ 0: converged)."""
    o_R, o_H = friction_start(p, lib)
    a_R, a_H = friction_newton_step(p, o_R, o_H, lib)
    n_R, n_H = friction_newton_step(p, a_R, a_H, lib)
    d_R, d_H = n_R - a_R, n_H - a_H
    return (n_R, n_H, d_R, d_H, friction_newton_margin(d_R, a_R - o_R, n_R),
            friction_newton_margin(d_H, a_H - o_H, n_H))


def friction_solve(p: tuple, lib: ModuleType = np) -> tuple[Any, Any]:
    """The load magnitudes ``n_R = |F_R|``, ``n_H = |F_H|`` (N) under the couples they cause,
    from the pieces ``p`` of ``dynamics.friction_pieces``: Newton's first two steps
    (:func:`friction_first_steps`), then more until :func:`friction_newton_margin` says both
    have converged to round-off, at most :data:`FRICTION_NEWTON_STEPS` in all. On arrays the
    steps go on until every element has converged. The C (``fmu/c/treb_shot.c``) runs the
    same steps: the first two generated with the pieces, the others one by one."""
    n_R, n_H, d_R, d_H, m_R, m_H = friction_first_steps(p, lib)
    for _ in range(FRICTION_NEWTON_STEPS - 2):
        if np.all((m_R <= 0.0) & (m_H <= 0.0)):
            break
        o_R, o_H, s_R, s_H = n_R, n_H, d_R, d_H
        n_R, n_H = friction_newton_step(p, o_R, o_H, lib)
        d_R, d_H = n_R - o_R, n_H - o_H
        m_R, m_H = friction_newton_margin(d_R, s_R, n_R), friction_newton_margin(d_H, s_H, n_H)
    return n_R, n_H
