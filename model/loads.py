"""Every load column of a whole table: :func:`~trebuchet.model.forces.row_loads` on each row
(compiled, :mod:`trebuchet.model.loads_kernel`), then the projectile in flight after release.

:func:`loads` is the public entry (``trebuchet.forces``); :func:`load_columns` is the
simulator's pandas-free path. The simulator, the ingest path and the FMU all call these.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model.flight import projectile_in_flight
from trebuchet.model.forces import (
    ANGLE_COLUMNS,
    FRICTION_COLUMNS,
    ROW_COLUMNS,
    projectile_energy,
    rest_energies,
)
from trebuchet.model.frames import frame
from trebuchet.model.friction import has_friction
from trebuchet.model.loads_kernel import load_block
from trebuchet.model.scene import Scene, as_scene

__all__ = ["loads", "load_columns"]



def loads(angles: pd.DataFrame, scene: Scene | str | Path, *,
          form: Literal["direct", "projected"] = "direct",
          release_state: dict[str, float] | None = None) -> pd.DataFrame:
    """Every force, torque, power and energy of the contract from angles and their derivatives.

    Parameters
    ----------
    angles : DataFrame
        Columns ``t`` (s), ``phase`` (1 trough, 2 sling, 3 released), ``theta psi phi`` (rad),
        ``*_d`` (rad/s) and ``*_dd`` (rad/s²). ``phi`` and its derivatives are ignored in
        phase 3.
    scene : Scene, or the path of a scene file (TOML)
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
    scene = as_scene(scene, "forces")
    _check_angles(angles)
    given = _columns_of(angles)
    return frame(load_columns(given, scene, form=form, release_state=release_state),
                 index=angles.index)


def load_columns(given: dict[str, np.ndarray], scene: Scene, *,
                 form: Literal["direct", "projected"] = "direct",
                 release_state: dict[str, float] | None = None,
                 lost: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """:func:`loads` on a dict of checked columns (numpy arrays of one length): the input
    columns followed by every load column, as a dict. The simulator's path, free of pandas:
    :func:`row_loads` on every row, compiled (:mod:`trebuchet.model.loads_kernel`), then the
    projectile in flight after release. ``lost``: ``E_loss_pivot``, ``E_loss_hinge`` (J) as
    the simulator integrated them, instead of the trapezoidal sums over the rows."""
    e, g = scene.engine, scene.g
    phase = given["phase"]
    free = phase == 3
    held = (phase == 1) | (phase == 2)
    _check_phase(phase, held | free)
    block = load_block(given, scene, form == "projected", rest_energies(scene))
    out = dict(zip(ROW_COLUMNS, block, strict=True))
    if has_friction(e):
        t = np.asarray(given["t"], dtype=float)
        for joint in ("pivot", "hinge"):
            name = f"E_loss_{joint}"
            out[name] = lost[name] if lost else cumulative_energy(t, out[f"P_loss_{joint}"])
    else:
        for name in FRICTION_COLUMNS:
            del out[name]
    if e.m > 0.0 and free.any():
        r_m, v_m = _in_flight(given["t"], out, held, free, scene, release_state)
        for name, v in zip(("x_m", "y_m", "vx_m", "vy_m"), (*r_m, *v_m), strict=True):
            out[name][free] = v
        out["E_m"][free] = projectile_energy(v_m, r_m[1], e, g) - rest_energies(scene)[0]
    return {**given, **out}


def cumulative_energy(t: np.ndarray, power: np.ndarray) -> np.ndarray:
    """``∫ P dt`` from the first row, J, by the trapezoidal rule over the rows' times ``t`` (s)
    (the simulator replaces it with the integrated value)."""
    steps = 0.5 * (power[1:] + power[:-1]) * np.diff(t)
    return np.concatenate([[0.0], np.cumsum(steps)]) if t.size else np.zeros(0)


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


def _check_phase(phase: np.ndarray, known: np.ndarray) -> None:
    """Every row is in phase 1 (trough), 2 (sling) or 3 (released): ``known`` marks those."""
    if not known.all():
        rows = np.flatnonzero(~known)
        raise TrebuchetInputError(f"forces: phase must be 1 (trough), 2 (sling) or 3 (released); "
                                  f"row {rows[0]} has {phase[rows[0]]} ({rows.size} rows in all)")


def _in_flight(t: np.ndarray, out: dict[str, np.ndarray], held: np.ndarray, free: np.ndarray,
               scene: Scene, release_state: dict[str, float] | None
               ) -> tuple[np.ndarray, np.ndarray]:
    """Projectile position (m) and velocity (m/s) on the rows after release, shapes (2, k), from
    the release state (by default the last row still held in the sling) along the scene's
    flight model."""
    t = np.asarray(t, dtype=float)
    if release_state is None:
        before = np.flatnonzero(held)
        if before.size == 0:
            raise ValueError("phase-3 rows need a release_state or a phase-2 row before them")
        i = before[-1]
        release_state = {"t": t[i], **{k: out[f"{k}_m"][i] for k in ("x", "y", "vx", "vy")}}
    return projectile_in_flight(release_state, t[free], scene.g, scene.flight, scene.engine.m)
