"""Loads of a log's rows from a state of its angles: the rows' phases, the loads with the rows
at rest and the trough's constraint handled, and the variance an event time's sd adds.

Shared by the two ways ``reconstruct`` takes the loads: from the smoothed angles
(:mod:`~trebuchet.ingest.reconstruct`, whose private ``shot_phases``, ``_evaluate`` and
``_event_variance`` these are, written once more here while that module is being reorganised:
it can import them from here) and from the fitted engine
(:mod:`~trebuchet.ingest.identification.fitted_loads`). Units: SI.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.special import ndtr

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model import dynamics as dyn
from trebuchet.model.loads import loads
from trebuchet.model.scene import Scene

__all__ = ["shot_phases", "evaluate_loads", "event_variance", "DERIVATIVE_COLUMNS"]

DERIVATIVE_COLUMNS = [a + s for a in ("theta", "psi", "phi") for s in ("_d", "_dd")]


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


def evaluate_loads(state: pd.DataFrame, phase: np.ndarray, scene: Scene, form: str,
                   trough: str) -> pd.DataFrame:
    """``loads`` on ``state`` with rest rows (phase 0) as the scene's first phase at zero
    rates and accelerations, and, for ``trough="constraint"``, φ and its derivatives from θ
    in the trough."""
    cols = {c: state[c].to_numpy(dtype=float) for c in state.columns}
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
    frame = pd.DataFrame(cols, index=state.index, copy=False)
    try:
        out = loads(frame, scene, form=form)
    except ValueError as exc:  # phase-3 rows without a sling row before them
        raise TrebuchetInputError(f"reconstruct: {exc}") from None
    out["phase"] = phase
    return out


def event_variance(t: np.ndarray, event: float | None, sd: float,
                   values: np.ndarray) -> np.ndarray:
    """Variance (n, m) from the chance that a row lies on the other side of an event whose
    time (s) has sd ``sd`` (s): ``P(other side) × (load across the event − load)²``, the
    load across the event taken from the nearest row on the other side."""
    var = np.zeros_like(values)
    if event is None or not sd > 0:
        return var
    after = t > event
    if after.all() or not after.any():
        return var
    i_before = int(np.flatnonzero(~after)[-1])
    i_after = int(np.flatnonzero(after)[0])
    near = np.abs(t - event) < 6.0 * sd
    p_after = ndtr((t - event) / sd)
    p_other = np.where(after, 1.0 - p_after, p_after)
    other = np.where(after[:, None], values[i_before][None, :], values[i_after][None, :])
    diff = np.nan_to_num(other - values)
    var[near] = p_other[near, None] * diff[near] ** 2
    return var
