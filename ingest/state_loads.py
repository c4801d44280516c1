"""Loads of a log's rows from a state of its angles: the rows' phases, the loads with the rows
at rest and the trough's constraint handled, and the variance an event time's sd adds.

Shared by the two ways ``reconstruct`` takes the loads: from the smoothed angles
(:mod:`~trebuchet.ingest.loads_table`) and from the fitted engine
(:mod:`~trebuchet.ingest.identification.fitted_loads`). Units: SI.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
import pandas as pd
from scipy.special import ndtr

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model import dynamics as dyn
from trebuchet.model.frames import frame
from trebuchet.model.loads import load_columns
from trebuchet.model.scene import Scene

__all__ = ["shot_phases", "evaluate_loads", "evaluate_load_columns", "flight_carry",
           "event_variance", "DERIVATIVE_COLUMNS", "CUMULATIVE_COLUMNS"]

DERIVATIVE_COLUMNS = [a + s for a in ("theta", "psi", "phi") for s in ("_d", "_dd")]
#: The loads that are no function of their row alone: the bearings' heat (J), the integral of
#: their power (``P_loss_*``, W) over the rows from the first
#: (:func:`~trebuchet.model.loads.cumulative_energy`); a propagation by chunks of rows takes
#: them on the whole log.
CUMULATIVE_COLUMNS = {"E_loss_pivot": "P_loss_pivot", "E_loss_hinge": "P_loss_hinge"}


def shot_phases(t: np.ndarray, scene: Scene, trigger: float | None, lift_off: float | None,
                release: float | None) -> np.ndarray:
    """Phase of each row (int): 0 at rest (``t ≤ trigger``), then the scene's phases: 1 in
    the trough until ``lift_off``, 2 in the sling until ``release``, 3 after (times in s,
    the log's time; None = no such event in the log)."""
    t = np.asarray(t, dtype=float)
    first = scene.phases[0]
    phase = np.full(t.size, first, dtype=np.int64)
    if first == 1 and lift_off is not None:
        phase[t > lift_off] = 2
    if first != 3 and release is not None:
        phase[t > release] = 3
    if trigger is not None:
        phase[t <= trigger] = 0
    return phase


def evaluate_load_columns(state: Mapping[str, np.ndarray] | pd.DataFrame, phase: np.ndarray,
                          scene: Scene, form: str, trough: str) -> dict[str, np.ndarray]:
    """The columns of ``loads`` (pandas-free: :func:`~trebuchet.model.loads.load_columns`)
    on ``state`` (a frame, or a mapping of numpy columns with ``columns`` as
    :class:`~trebuchet.ingest.uncertainty.Columns` has) with rest rows (phase 0) as the
    scene's first phase at zero rates and accelerations, and, for ``trough="constraint"``, φ
    and its derivatives from θ in the trough; ``phase`` is the rows' own (with its 0s)."""
    cols = {c: np.asarray(state[c], dtype=float) for c in state.columns}
    rest = phase == 0
    first = scene.phases[0]
    run_phase = np.where(rest, first, phase)
    if rest.any():
        for col in DERIVATIVE_COLUMNS:
            cols[col] = np.where(rest, 0.0, cols[col])
    if trough == "constraint" and first == 1:
        sel = run_phase == 1
        if sel.any():
            e, H = scene.engine, scene.start.H
            th, th_d, th_dd = (cols[c][sel] for c in ("theta", "theta_d", "theta_dd"))
            with np.errstate(invalid="ignore", divide="ignore"):
                ph = dyn.trough_sling_angle(th, e, H)
                ph_d = dyn.trough_phi_d(th, ph, th_d, e)
                ph_dd = dyn.trough_phi_dd(th, ph, th_d, ph_d, th_dd, e)
            for col, v in (("phi", ph), ("phi_d", ph_d), ("phi_dd", ph_dd)):
                values = cols[col].copy()
                values[sel] = v
                cols[col] = values
    cols["phase"] = run_phase
    try:
        out = load_columns(cols, scene, form=form)
    except ValueError as exc:  # phase-3 rows without a sling row before them
        raise TrebuchetInputError(f"reconstruct: {exc}") from None
    out["phase"] = phase
    return out


def evaluate_loads(state: pd.DataFrame, phase: np.ndarray, scene: Scene, form: str,
                   trough: str) -> pd.DataFrame:
    """:func:`evaluate_load_columns` as a frame on ``state``'s index."""
    return frame(evaluate_load_columns(state, phase, scene, form, trough), index=state.index)


def flight_carry(phase: np.ndarray) -> Callable[[int, int], list[int]]:
    """``carry`` of a propagation by chunks of rows
    (:func:`~trebuchet.ingest.uncertainty.propagate`): rows in flight (phase 3) need the last
    row in the sling (the flight starts from its state) in their chunk."""
    held = np.flatnonzero(phase != 3)
    last = int(held[-1]) if held.size else -1

    def carry(lo: int, hi: int) -> list[int]:
        return [last] if 0 <= last < lo and bool(np.any(phase[lo:hi] == 3)) else []

    return carry


def event_variance(t: np.ndarray, event: float | None, sd: float, values: np.ndarray,
                   out: np.ndarray | None = None) -> np.ndarray:
    """Variance (n, m) from the chance that a row lies on the other side of an event whose
    time (s) has sd ``sd`` (s): ``P(other side) × (load across the event − load)²``, the
    load across the event taken from the nearest row on the other side. ``out``: added to
    it (and returned) instead of a new array; only the rows within 6 sd of the event are
    touched."""
    var = np.zeros_like(values) if out is None else out
    if event is None or not sd > 0:
        return var
    after = t > event
    if after.all() or not after.any():
        return var
    i_before = int(np.flatnonzero(~after)[-1])
    i_after = int(np.flatnonzero(after)[0])
    near = np.flatnonzero(np.abs(t - event) < 6.0 * sd)
    p_after = ndtr((t[near] - event) / sd)
    p_other = np.where(after[near], 1.0 - p_after, p_after)
    other = np.where(after[near, None], values[i_before][None, :], values[i_after][None, :])
    diff = np.nan_to_num(other - values[near])
    var[near] += p_other[:, None] * diff ** 2
    return var
