"""What a simulated shot is checked for before it is returned (:func:`~trebuchet.model.simulate.
simulate`): output times that can mean something, no NaN or infinity where a quantity exists,
and the intervals where the rigid sling would have to push. Times in s."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model.output_size import MAX_ROWS
from trebuchet.model.scene import Scene

__all__ = ["checked_times", "slack_intervals", "refuse_non_finite", "stiffness_advice"]


def checked_times(t_eval: Sequence[float] | np.ndarray) -> np.ndarray:
    """``t_eval`` as a one-dimensional array of finite floats (s), or a refusal saying why."""
    try:
        t = np.asarray(t_eval, dtype=float)
    except (TypeError, ValueError):
        raise TrebuchetInputError("t_eval must hold numbers (s after the trigger)") from None
    if t.ndim != 1:
        raise TrebuchetInputError(f"t_eval must be one-dimensional, got shape {t.shape}")
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise TrebuchetInputError(f"t_eval[{bad[0]}] = {t[bad[0]]}: times must be finite "
                                  f"({bad.size} are not)")
    if t.size > MAX_ROWS:
        raise TrebuchetInputError(f"t_eval holds {t.size:,} times: at most {MAX_ROWS:,} output "
                                  "rows in one run")
    return t


def slack_intervals(run: Mapping[str, Any]) -> list[tuple[float, float]]:
    """Intervals (s) where the sling holding the projectile would have to push
    (``sling_tension < 0``): the rigid-sling model is not valid there. ``run``: the loads, a
    DataFrame or a dict of columns."""
    slack = (np.asarray(run["phase"]) <= 2) & (np.asarray(run["sling_tension"]) < 0.0)
    t = np.asarray(run["t"])
    edges = np.flatnonzero(np.diff(np.concatenate([[0], slack.astype(np.int8), [0]])))
    return [(float(t[a]), float(t[b - 1])) for a, b in zip(edges[::2], edges[1::2], strict=True)]


# Columns that are undefined by design: the sling after release, the projectile of a dry fire.
_UNDEFINED_AFTER_RELEASE = ("phi", "phi_d", "phi_dd")
_UNDEFINED_DRY_FIRE = ("x_m", "y_m", "vx_m", "vy_m")


def refuse_non_finite(cols: Mapping[str, np.ndarray], scene: Scene) -> None:
    """Output holds no NaN or infinity except where a quantity does not exist (the sling's
    angle after release, the projectile of a dry fire); anything else is refused."""
    phase3 = cols["phase"] == 3
    dry = scene.engine.m == 0.0
    skip = _UNDEFINED_AFTER_RELEASE + (_UNDEFINED_DRY_FIRE if dry else ())
    total = np.zeros(phase3.shape)  # NaN and ±inf survive a sum: one pass over the columns
    for name, v in cols.items():
        if v.dtype.kind == "f" and name not in skip:
            total += v
    for name in _UNDEFINED_AFTER_RELEASE:
        total += np.where(phase3, 0.0, cols[name])
    if np.isfinite(total).all():
        return
    for name, v in cols.items():
        if v.dtype.kind != "f" or (dry and name in _UNDEFINED_DRY_FIRE):
            continue
        bad = ~np.isfinite(v)
        if name in _UNDEFINED_AFTER_RELEASE:
            bad &= ~phase3
        if bad.any():
            t_bad = float(cols["t"][np.flatnonzero(bad)[0]])
            raise TrebuchetInputError(
                f"{scene.source}: the model breaks down at t = {t_bad:.4g} s ({name} is not "
                "finite); the scene is outside what the equations of motion can describe")


def stiffness_advice(scene: Scene, nfev: int) -> list[str]:
    """What the user can do about a costly or stiff scene (``nfev``: the right-hand sides the
    shot took)."""
    advice = []
    e = scene.engine
    if nfev > 5000 and not e.fixed_counterweight and e.L3 < 0.05 * e.L1:
        advice.append(
            f"L3 = {e.L3:g} m makes the counterweight's swing stiff ({nfev} evaluations); "
            "if it barely swings, model it fixed to the beam ([engine] counterweight = "
            "\"fixed\"), or use method=\"Radau\"")
    return advice
