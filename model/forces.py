"""Internal forces, torque, rates of work and energies (the paper's Sections 6–8).

Every force is a sum of terms mass × length × rotated generalised
acceleration, ``M_a L_a R_a A_a``, plus a constant gravity term, exactly as
in the paper. The functions are pure and vectorised: angles (rad), rates
(rad/s) and accelerations (rad/s²) are arrays over time, vectors come back as
arrays of shape ``(2, n)`` in N. The simulator, the ingest path and the FMU
all call these functions; :func:`loads` composes them into the columns of
CONTRACT.md.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Literal

import numpy as np
import pandas as pd

from trebuchet.errors import TrebuchetInputError

from . import kinematics as kin
from .dynamics import trough_f_g
from .flight import projectile_in_flight
from .frames import frame
from .kinematics import Angle
from .scene import Engine, Scene

__all__ = [
    "centre_of_mass_force",
    "hinge_force",
    "hinge_force_along_arm",
    "sling_force_in_sling",
    "sling_force_along_sling",
    "sling_force_in_trough",
    "pivot_reaction",
    "torque_contributions",
    "trough_normal_force",
    "energies",
    "loads",
    "LOAD_COLUMNS",
]

E_Y = np.array([[0.0], [1.0]])

#: The input columns of :func:`loads`: each angle, its rate and its acceleration.
ANGLE_COLUMNS = (("theta", "theta_d", "theta_dd"), ("psi", "psi_d", "psi_dd"),
                 ("phi", "phi_d", "phi_dd"))

LOAD_COLUMNS = [
    "F_S_x", "F_S_y", "F_H_x", "F_H_y", "F_CM_x", "F_CM_y", "F_R_x", "F_R_y", "torque",
    "P_m", "P_M", "P_beam", "E_m", "E_M", "E_beam", "x_m", "y_m", "vx_m", "vy_m",
]


def centre_of_mass_force(theta: Angle, e: Engine, g: float) -> np.ndarray:
    """``F_CM = m_b L_CM R_θ A_θ + m_b g e_y`` (paper, eq. (10)), N: the force the rest of the
    beam exerts on its centre-of-mass particle."""
    return e.m_b * e.L_CM * theta.RA + e.m_b * g * E_Y


def hinge_force(theta: Angle, psi: Angle, e: Engine, g: float) -> np.ndarray:
    """``F_H = −M L2 R_θ A_θ + M L3 R_ψ A_ψ + M g e_y`` (paper, eq. (11)), N: force from the
    beam on the counterweight at the hinge."""
    return -e.M * e.L2 * theta.RA + e.M * e.L3 * psi.RA + e.M * g * E_Y


def hinge_force_along_arm(theta: Angle, psi: Angle, e: Engine, g: float) -> np.ndarray:
    """``(F_H·e_ψ) e_ψ``, N: eq. (11) projected on the counterweight arm, where the paper shows
    ``F_H ∥ e_ψ``. The projection holds no ψ̈ (``e_ψ·R_ψ A_ψ = −ψ̇²``), so it is the robust form
    for measured angles."""
    along = (-e.M * e.L2 * kin.dot(psi.unit, theta.RA) - e.M * e.L3 * psi.rate * psi.rate
             + e.M * g * psi.sin)
    return along * psi.unit


def sling_force_in_sling(theta: Angle, phi: Angle, e: Engine, g: float) -> np.ndarray:
    """``F_S = m L1 R_θ A_θ + m L4 R_φ A_φ + m g e_y`` (paper, eq. (13)), N: sling tension on the
    projectile in phase II."""
    return e.m * e.L1 * theta.RA + e.m * e.L4 * phi.RA + e.m * g * E_Y


def sling_force_along_sling(theta: Angle, phi: Angle, e: Engine, g: float) -> np.ndarray:
    """``(F_S·e_φ) e_φ``, N: eq. (13) projected on the sling (``F_S ∥ e_φ``); holds no φ̈."""
    along = (e.m * e.L1 * kin.dot(phi.unit, theta.RA) - e.m * e.L4 * phi.rate * phi.rate
             + e.m * g * phi.sin)
    return along * phi.unit


def sling_force_in_trough(theta: Angle, phi: Angle, e: Engine) -> np.ndarray:
    """``F_S = m L1 (f θ̈ + g θ̇²)(e_x + tan φ e_y)`` (paper, eq. (16)), N: sling tension on the
    projectile dragged in the trough (phase I)."""
    f, gg = trough_f_g(theta.value, phi.value, e)
    a_x = e.L1 * (f * theta.acc + gg * theta.rate * theta.rate)
    return e.m * a_x * np.array([np.ones_like(a_x), phi.sin / phi.cos])


def trough_normal_force(F_S_y, e: Engine, g: float):
    """Normal force of the trough on the projectile, ``F_N = m g − F_S·e_y``, N (phase I).
    Lift-off where it reaches zero."""
    return e.m * g - F_S_y


def pivot_reaction(F_H: np.ndarray, F_CM: np.ndarray, F_S: np.ndarray) -> np.ndarray:
    """``F_R = F_H + F_CM + F_S`` (paper, eq. (14)), N: bearing reaction on the beam at P."""
    return F_H + F_CM + F_S


def torque_contributions(theta: Angle, psi: Angle, F_H: np.ndarray, F_S: np.ndarray,
                         e: Engine, g: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The three terms of the torque on the beam about the pivot (paper, eq. (19)), N m:
    hinge ``L2 F_H·e_θ⊥``, centre of mass ``−L_CM m_b g e_y·e_θ⊥``, spigot ``−L1 F_S·e_θ⊥``.

    A counterweight fixed rigidly to the beam pushes along no arm: its force acts at the
    counterweight, and the hinge term gains ``−L3 F_H·e_ψ⊥`` (zero for the hinged one, where
    ``F_H ∥ e_ψ``)."""
    hinge = e.L2 * kin.dot(F_H, theta.perp)
    if e.fixed_counterweight:
        hinge = hinge - e.L3 * kin.dot(F_H, psi.perp)
    return hinge, -e.L_CM * e.m_b * g * theta.cos, -e.L1 * kin.dot(F_S, theta.perp)


def energies(theta: Angle, psi: Angle, v_m: np.ndarray, y_m, e: Engine, g: float,
             H: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mechanical energy (kinetic + potential, potential zero on the ground) of the projectile,
    counterweight and beam, J (paper, Section 4)."""
    r_M = kin.counterweight_position(theta, psi, e, H)
    v_M = kin.counterweight_velocity(theta, psi, theta.rate, psi.rate, e)
    E_m = 0.5 * e.m * kin.dot(v_m, v_m) + e.m * g * y_m
    E_M = 0.5 * e.M * kin.dot(v_M, v_M) + e.M * g * r_M[1]
    E_b = 0.5 * e.I * theta.rate * theta.rate + e.m_b * g * (H + e.L_CM * theta.sin)
    return E_m, E_M, E_b


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


def loads(angles: pd.DataFrame, scene: Scene, *, form: Literal["direct", "projected"] = "direct",
          release_state: dict[str, float] | None = None) -> pd.DataFrame:
    """Every force, torque, power and energy of the contract from angles and their derivatives.

    Parameters
    ----------
    angles : DataFrame
        Columns ``t`` (s), ``phase`` (1 trough, 2 sling, 3 released), ``theta psi phi`` (rad),
        ``*_d`` (rad/s) and ``*_dd`` (rad/s²). ``phi`` and its derivatives are ignored in
        phase 3.
    scene : Scene
        The engine, gravity, and the rest pose that energies are counted from.
    form : "direct" or "projected"
        ``direct``: the paper's eqs. (11) and (13). ``projected``: F_H on the counterweight arm
        and F_S on the sling, free of ψ̈ and φ̈ (robust on noisy measured angles).
    release_state : dict, optional
        Projectile ``t, x, y, vx, vy`` at release (s, m, m/s) for the ballistic phase 3. By
        default the state of the last phase-2 row.

    Returns
    -------
    DataFrame with the input columns, the contract's load columns (N, N m, W, J, m, m/s) and
    extras: ``F_N`` (trough normal force), ``F_M_*`` and ``F_m_*`` (total force on
    counterweight and projectile), ``sling_tension`` (negative means slack), ``*_par`` and
    ``*_perp`` (components along and across the beam) and ``torque_hinge``, ``torque_cm``,
    ``torque_spigot``, and magnitudes ``*_abs``.
    """
    if form not in ("direct", "projected"):
        raise ValueError(f"form must be 'direct' or 'projected', got {form!r}")
    _check_angles(angles)
    given = _columns_of(angles)
    return frame(load_columns(given, scene, form=form, release_state=release_state),
                 index=angles.index)


def load_columns(given: dict[str, np.ndarray], scene: Scene, *,
                 form: Literal["direct", "projected"] = "direct",
                 release_state: dict[str, float] | None = None) -> dict[str, np.ndarray]:
    """:func:`loads` on a dict of checked columns (numpy arrays of one length): the input
    columns followed by every load column, as a dict. The simulator's path, free of pandas."""
    e, g, H = scene.engine, scene.g, scene.start.H
    phase = given["phase"]
    _check_phase(phase)
    in_trough, in_sling, free = phase == 1, phase == 2, phase == 3
    held = in_trough | in_sling
    th = kin.Angle(*(given[k].astype(float, copy=False) for k in ANGLE_COLUMNS[0]))
    ps = kin.Angle(*(given[k].astype(float, copy=False) for k in ANGLE_COLUMNS[1]))
    ph = kin.Angle(*(np.where(held, given[k], 0.0) for k in ANGLE_COLUMNS[2]))
    with np.errstate(all="ignore"):
        F_CM = centre_of_mass_force(th, e, g)
        if form == "direct" or e.fixed_counterweight:
            F_H = hinge_force(th, ps, e, g)
        else:
            F_H = hinge_force_along_arm(th, ps, e, g)
        F_S = np.zeros((2, len(phase)))
        if in_sling.any():
            sling = sling_force_in_sling if form == "direct" else sling_force_along_sling
            F_S = np.where(in_sling, sling(th, ph, e, g), F_S)
        if in_trough.any():
            F_S = np.where(in_trough, sling_force_in_trough(th, ph, e), F_S)
        F_R = pivot_reaction(F_H, F_CM, F_S)
        t_hinge, t_cm, t_spigot = torque_contributions(th, ps, F_H, F_S, e, g)
        N = t_hinge + t_cm + t_spigot

        r_m = kin.projectile_position(th, ph, e, H)
        v_m = kin.projectile_velocity(th, ph, th.rate, ph.rate, e)
    if free.any() and e.m > 0.0:
        r_m, v_m = _in_flight(given["t"], r_m, v_m, held, free, scene, release_state)
    elif e.m == 0.0:  # dry fire: there is no projectile to place
        r_m, v_m = np.full_like(r_m, np.nan), np.full_like(v_m, np.nan)

    v_M = kin.counterweight_velocity(th, ps, th.rate, ps.rate, e)
    v_CM = kin.centre_of_mass_velocity(th, th.rate, e)
    P_m = np.where(free, 0.0, kin.dot(F_S, v_m))
    P_M = kin.dot(F_H, v_M)
    P_beam = N * th.rate + e.m_b * g * v_CM[1]
    E_m, E_M, E_b = energies(th, ps, v_m, r_m[1], e, g, H)
    if e.m == 0.0:
        E_m = np.zeros_like(E_M)
    E_m0, E_M0, E_b0 = rest_energies(scene)

    F_N = np.where(in_trough, trough_normal_force(F_S[1], e, g), 0.0)
    e_th, e_perp, e_phi = th.unit, th.perp, ph.unit
    out = {
        "F_S_x": F_S[0], "F_S_y": F_S[1], "F_H_x": F_H[0], "F_H_y": F_H[1],
        "F_CM_x": F_CM[0], "F_CM_y": F_CM[1], "F_R_x": F_R[0], "F_R_y": F_R[1],
        "torque": N, "P_m": P_m, "P_M": P_M, "P_beam": P_beam,
        "E_m": E_m - E_m0, "E_M": E_M - E_M0, "E_beam": E_b - E_b0,
        "x_m": r_m[0], "y_m": r_m[1], "vx_m": v_m[0], "vy_m": v_m[1],
        "F_N": F_N,
        "F_M_x": F_H[0], "F_M_y": F_H[1] - e.M * g,
        "F_m_x": F_S[0], "F_m_y": F_S[1] - e.m * g + F_N,
        "sling_tension": np.where(held, -kin.dot(F_S, e_phi), 0.0),
        "torque_hinge": t_hinge, "torque_cm": t_cm, "torque_spigot": t_spigot,
    }
    for name, F in (("F_S", F_S), ("F_H", F_H), ("F_CM", F_CM), ("F_R", F_R)):
        out[f"{name}_par"] = kin.dot(F, e_th)
        out[f"{name}_perp"] = kin.dot(F, e_perp)
    for name in ("F_S", "F_H", "F_CM", "F_R", "F_M", "F_m"):
        x, y = out[f"{name}_x"], out[f"{name}_y"]
        out[f"{name}_abs"] = np.sqrt(x * x + y * y)  # np.hypot is 5x slower; no overflow here
    return {**given, **out}


def _columns_of(angles: pd.DataFrame) -> dict[str, np.ndarray]:
    """The columns of a frame as numpy arrays: one copy of the whole frame as floats, and each
    column of another dtype on its own (``df[name]`` costs ~25 µs a column in pandas 3)."""
    names = list(angles.columns)
    try:
        values = angles.to_numpy(dtype=float).T.copy()
    except (TypeError, ValueError):  # a column that is not numeric: leave it as it is
        return {c: angles[c].to_numpy() for c in names}
    return {c: values[j] if d == np.float64 else angles[c].to_numpy()
            for j, (c, d) in enumerate(zip(names, angles.dtypes, strict=True))}


def _check_angles(angles: pd.DataFrame) -> None:
    """The input :func:`loads` needs, with an error that names what is missing."""
    need = ("t", "phase", *(c for cols in ANGLE_COLUMNS for c in cols))
    missing = [c for c in need if c not in angles.columns]
    if missing:
        raise TrebuchetInputError("forces: the angles lack the column(s) " + ", ".join(missing)
                                  + " (needed: " + " ".join(need) + ")")


def _check_phase(phase: np.ndarray) -> None:
    """Every row is in phase 1 (trough), 2 (sling) or 3 (released)."""
    bad = ~((phase == 1) | (phase == 2) | (phase == 3))
    if bad.any():
        rows = np.flatnonzero(bad)
        raise TrebuchetInputError(f"forces: phase must be 1 (trough), 2 (sling) or 3 (released); "
                                  f"row {rows[0]} has {phase[rows[0]]} ({rows.size} rows in all)")


def _in_flight(t: np.ndarray, r_m: np.ndarray, v_m: np.ndarray, held: np.ndarray,
               free: np.ndarray, scene: Scene, release_state: dict[str, float] | None
               ) -> tuple[np.ndarray, np.ndarray]:
    """Projectile position and velocity after release, from the release state (by default the
    last row still held in the sling) along the scene's flight model."""
    t = np.asarray(t, dtype=float)
    if release_state is None:
        before = np.flatnonzero(held)
        if before.size == 0:
            raise ValueError("phase-3 rows need a release_state or a phase-2 row before them")
        i = before[-1]
        release_state = {"t": t[i], "x": r_m[0, i], "y": r_m[1, i], "vx": v_m[0, i],
                         "vy": v_m[1, i]}
    r_m, v_m = r_m.copy(), v_m.copy()
    r_m[:, free], v_m[:, free] = projectile_in_flight(release_state, t[free], scene.g,
                                                      scene.flight, scene.engine.m)
    return r_m, v_m
