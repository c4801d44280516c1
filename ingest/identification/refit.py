"""The diagnosis' refit from the fit that failed its check, its work reused.

Where a fit fails its residual check the diagnosis fits the log again with the bearings'
friction free (:mod:`.diagnosis`). That refit frees every entry of the first fit and more, and
starts where the first one ended: the new keys where the first fit's engine has them (no
friction: the same engine), so that the first fit's Jacobian stands for its own entries. Then:

1. Gauss–Newton steps that take only the new keys' columns afresh (forward differences, the
   fit's step, at each step's point), until the residuals pass the check
   (:data:`FROZEN_STEPS` at most);
2. the whole Jacobian taken afresh once at that point, and Gauss–Newton steps with it, each
   kept where it lowers the χ² sum and still passes, until a step lowers it by less than
   :data:`SETTLED_CHI2` (:data:`REFINING_STEPS` at most): the first steps' Jacobian is the
   frictionless engine's for the old entries, so their point lies off the optimum along the
   valley of M, I and the coefficients (the bearings' share of ΔU 0.2–0.5 %-points low on
   the small fast engine's 2 s logs).

Measured on the small fast engine's logs with its friction fitted by a scene without (18 logs,
120–480 fps, 0.1–1°): the bearings' share of ΔU within 0.04 %-points of the full refit's (it is
printed to 0.1), a third of its integrations (median; 19–25 against 47–92); one log at 0.1°
whose first steps did not pass was fitted in full.

Where the first steps never pass (a wrong engine, which friction does not explain) or a step
is no engine, :func:`extended_fit` gives None and the caller fits from the scene's own start
(:func:`~.fit.fit_shot`), as every refit did before.
"""

from __future__ import annotations

import numpy as np

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.identification.fit import DIFF_STEP, ShotFit, assessed, shot_fit
from trebuchet.ingest.identification.parameters import scene_value
from trebuchet.ingest.identification.shot_model import ShotModel

__all__ = ["extended_fit", "FROZEN_STEPS", "REFINING_STEPS", "SETTLED_CHI2"]

#: Steps with only the new keys' columns afresh before the caller fits on its own.
FROZEN_STEPS = 3
#: Steps with the Jacobian taken afresh once the check passes.
REFINING_STEPS = 3
#: A refining step that lowers the χ² sum by less than this ends the refit (a tenth of what
#: one sd of one fitted entry is worth).
SETTLED_CHI2 = 0.1


def _scale(model: ShotModel, i: int) -> float:
    """The scale of entry ``i`` of ``model``'s vector (a key's; 1 for a nuisance)."""
    return model.keys[i].scale if i < len(model.keys) else 1.0


def _start(model: ShotModel, first: ShotFit) -> tuple[np.ndarray, np.ndarray, list[int]] | None:
    """``model``'s vector at ``first``'s engine, the Jacobian with ``first``'s columns for its
    own entries, and the new entries' indices; None where a new entry is a nuisance (no start
    for it) or the residuals differ in length."""
    if first.jacobian is None or model.residual_count != first.jacobian.shape[0]:
        return None
    names = first.model.names
    new = [i for i, name in enumerate(model.names) if name not in names]
    if any(i >= len(model.keys) for i in new):
        return None
    x = np.empty(len(model.names))
    J = np.empty((first.jacobian.shape[0], x.size))
    for i, name in enumerate(model.names):
        if i in new:
            x[i] = scene_value(first.scene, name) / model.keys[i].scale
            continue
        j = names.index(name)
        x[i] = first.x[j] * _scale(first.model, j) / _scale(model, i)
        J[:, i] = first.jacobian[:, j] * (_scale(model, i) / _scale(first.model, j))
    return x, J, new


def _columns(model: ShotModel, x: np.ndarray, r: np.ndarray, J: np.ndarray,
             which: list[int] | range) -> None:
    """The columns ``which`` of ``J`` by forward differences at ``x`` (``r`` its residual)."""
    for i in which:
        h = DIFF_STEP * max(1.0, abs(x[i]))
        moved = x.copy()
        moved[i] += h
        J[:, i] = (model.residual(moved) - r) / h


def extended_fit(model: ShotModel, first: ShotFit) -> ShotFit | None:
    """``model``, the log of ``first`` (a fit that failed its check) with more scene keys
    free, fitted from ``first``'s solution (module doc); None where its first steps do not
    pass the check: the caller then fits ``model`` from its own start."""
    start = _start(model, first)
    if start is None:
        return None
    x, J, new = start
    lo, hi = model.bounds(x)
    try:
        r = model.residual(x)
        nfev, done = 1, None
        for _ in range(FROZEN_STEPS):
            _columns(model, x, r, J, new)
            x = np.clip(x + np.linalg.lstsq(J, -r, rcond=None)[0], lo, hi)
            r = model.residual(x)
            nfev += len(new) + 1
            done = assessed(model, x, r)
            if done[3].passed:
                break
        if done is None or not done[3].passed:
            return None
        _columns(model, x, r, J, range(x.size))
        nfev += x.size
        for _ in range(REFINING_STEPS):
            trial = np.clip(x + np.linalg.lstsq(J, -r, rcond=None)[0], lo, hi)
            r_trial = model.residual(trial)
            nfev += 1
            drop = float(r @ r - r_trial @ r_trial)
            if drop <= 0.0:
                break
            trial_done = assessed(model, trial, r_trial)
            if not trial_done[3].passed:
                break
            x, r, done = trial, r_trial, trial_done
            if drop < SETTLED_CHI2:
                break
        return shot_fit(model, x, r, J, nfev, done)
    except TrebuchetInputError:
        return None
