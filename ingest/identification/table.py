"""A fit's vector in the scene file's words: the table of fitted values with their sd, the
covariance in the table's units, and quantities of the fitted engine with their sd.

The fitted vector ``x`` (:mod:`.shot_model`) maps linearly onto the table's rows: a freed key is
``x · scale`` (its unit), the trigger is ``x`` (s, log time), a start angle ``x`` in degrees,
and the release ``release.time`` is the fitted release minus the trigger (s after the trigger,
the scene file's meaning). The covariance follows as ``A C Aᵀ``.

Quantities of the fitted engine that are no entry of ``x`` (the release's climb angle, the
heat of the bearings by the release, the release where the scene's rule puts it) take their sd
from their gradient by forward differences, ``g C gᵀ``: one integration per entry of ``x``.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from trebuchet.ingest.identification.fit import ShotFit
from trebuchet.ingest.identification.result import TABLE_COLUMNS, LossEnergy
from trebuchet.model.simulate import Trajectory

__all__ = ["fit_table", "ShotQuantities", "shot_quantities", "ROW_NAMES"]

#: Table row of each nuisance of the fitted vector, with its unit.
ROW_NAMES = {"trigger": ("trigger", "s"), "theta0": ("start.theta_deg", "°"),
             "psi0": ("start.psi_deg", "°"), "phi0": ("start.phi_deg", "°"),
             "release": ("release.time", "s")}


def _transform(fit: ShotFit) -> tuple[np.ndarray, np.ndarray]:
    """``(A, b)``: the table's free and nuisance rows are ``A x + b``."""
    model = fit.model
    names = model.names
    n = len(names)
    A = np.zeros((n, n))
    b = np.zeros(n)
    for i, name in enumerate(names):
        if i < len(model.keys):
            A[i, i] = model.keys[i].scale
        elif name in ("theta0", "psi0", "phi0"):
            A[i, i] = math.degrees(1.0)
        elif name == "release":
            A[i, i] = 1.0
            if "trigger" in names:
                A[i, names.index("trigger")] = -1.0
            else:
                b[i] = -float(model.trigger)
        else:
            A[i, i] = 1.0
    return A, b


def _scene_row_value(fit: ShotFit, name: str) -> float:
    s = fit.model.scene
    return {"trigger": math.nan, "theta0": math.degrees(s.start.theta),
            "psi0": math.degrees(s.start.psi), "phi0": math.degrees(s.start.phi),
            "release": s.release.time if s.release.time is not None else math.nan}[name]


def fit_table(fit: ShotFit) -> tuple[pd.DataFrame, tuple[str, ...], np.ndarray]:
    """The table of the fitted keys and nuisances (:data:`~.result.TABLE_COLUMNS`), their
    names and covariance in the table's units."""
    A, b = _transform(fit)
    values = A @ fit.x + b
    cov = A @ fit.covariance @ A.T
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    rows = []
    model = fit.model
    for i, name in enumerate(model.names):
        if i < len(model.keys):
            key = model.keys[i]
            rows.append((key.name, key.scene_value, values[i], sd[i], key.unit, "free"))
        else:
            row, unit = ROW_NAMES[name]
            rows.append((row, _scene_row_value(fit, name), values[i], sd[i], unit, "nuisance"))
    table = pd.DataFrame(rows, columns=TABLE_COLUMNS)
    return table, tuple(table["parameter"]), cov


# --------------------------------------------------------------------------- derived


class ShotQuantities:
    """Quantities of one trajectory started at ``t0`` (s, log time): ``release`` (s, log
    time; NaN where it is not released), ``climb_deg`` (the projectile's climb at release
    toward −x, the scene's release angle, °),
    ``loss_pivot``, ``loss_hinge`` (J lost by the release, or by the trajectory's end where
    it is not released), ``delta_U`` (J, the scene's available energy) and ``lift_off`` (s, log
    time; NaN where the scene has no trough)."""

    NAMES = ("release", "climb_deg", "loss_pivot", "loss_hinge", "delta_U", "lift_off")

    def __init__(self, traj: Trajectory, t0: float) -> None:
        rel = traj.events.get("release")
        self.values = np.full(len(self.NAMES), math.nan)
        at = traj.t_end if rel is None else float(rel)
        if rel is not None and traj.release_state is not None:
            rs = traj.release_state
            self.values[0] = t0 + float(rel)
            self.values[1] = math.degrees(math.atan2(rs["vy"], -rs["vx"]))  # toward −x
        pivot, hinge = traj.lost_energies(np.array([at]))
        self.values[2], self.values[3] = float(pivot[0]), float(hinge[0])
        self.values[4] = traj.scene.delta_U
        lift = traj.events.get("lift_off")
        if lift is not None:
            self.values[5] = t0 + float(lift)


def shot_quantities(fit: ShotFit) -> tuple[np.ndarray, np.ndarray]:
    """Values of :class:`ShotQuantities` ``NAMES`` of the fitted trajectory and their
    covariance (forward differences of the vector, module doc)."""
    base = ShotQuantities(fit.trajectory, fit.trigger).values
    G = np.zeros((fit.x.size, base.size))
    for i, (h, traj, t0) in enumerate(fit.steps):
        G[i] = np.nan if traj is None else (ShotQuantities(traj, t0).values - base) / h
    G = np.where(np.isfinite(G), G, 0.0)
    return base, G.T @ fit.covariance @ G


def loss_energy(values: np.ndarray, cov: np.ndarray) -> LossEnergy:
    """The bearings' heat by the release (:class:`~.result.LossEnergy`) from
    :func:`shot_quantities`."""
    names = ShotQuantities.NAMES
    ip, ih, iu = (names.index(k) for k in ("loss_pivot", "loss_hinge", "delta_U"))
    total = values[ip] + values[ih]
    g_total = np.zeros(values.size)
    g_total[[ip, ih]] = 1.0
    var_total = float(g_total @ cov @ g_total)
    frac = total / values[iu]
    g_frac = g_total / values[iu]
    g_frac[iu] = -total / values[iu] ** 2
    var_frac = float(g_frac @ cov @ g_frac)
    return LossEnergy(joules=float(total), sd=math.sqrt(max(var_total, 0.0)),
                      fraction=float(frac), fraction_sd=math.sqrt(max(var_frac, 0.0)),
                      pivot=float(values[ip]), hinge=float(values[ih]))
