"""Standard deviations of every load from the smoother's covariance of the angles.

Each load ``L`` is a function of nine smoothed quantities per row: three angles, their
rates and accelerations. The smoother gives, per row and angle, the 3×3 covariance ``C``
of (angle, rate, acceleration); the angles are smoothed independently, so the 9×9
covariance is block-diagonal. With ``h_i = √C_ii`` per row, central differences
``L(x ± h_i e_i)`` over all rows at once (18 calls of the vectorised load function) give,
in units of one sd, the slope ``a_i = (L₊ − L₋)/2`` and the curvature
``b_i = L₊ + L₋ − 2 L₀``. With the correlation ``R`` of each block:

- linear variance ``Σ aᵢ aⱼ Rᵢⱼ`` (first-order propagation);
- second-order variance ``½ Σ bᵢ bⱼ Rᵢⱼ²`` (exact for a diagonal Hessian: ψ̇², |F|);
- bias ``½ Σ bᵢ``: the load of the smoothed state is off the mean of the load by this
  much; it goes into the sd so that the ±2 sd band holds the truth (an MSE, not a
  posterior variance).

``variance_by_order`` splits the linear variance by the derivative orders of the pair
(``i + j`` = 0 … 4) for :mod:`~trebuchet.ingest.advisory`. Units: those of the load.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd

__all__ = ["Propagation", "propagate", "STATE_SUFFIXES"]

STATE_SUFFIXES = ("", "_d", "_dd")


@dataclass(frozen=True)
class Propagation:
    """Result of :func:`propagate` for the columns ``names`` (arrays of shape (n, m)).

    ``value``: the loads at the smoothed state; ``sd``: √(linear + second-order variance
    + bias²); ``by_order``: (5, n, m) linear variance split by ``i + j`` (angle 0, rate 1,
    acceleration 2 for each of the pair)."""

    names: list[str]
    value: np.ndarray
    sd: np.ndarray
    by_order: np.ndarray


def _numeric(frame: pd.DataFrame, names: list[str]) -> np.ndarray:
    return frame[names].to_numpy(dtype=float)


def propagate(evaluate: Callable[[pd.DataFrame], pd.DataFrame], state: pd.DataFrame,
              cov: dict[str, np.ndarray], names: list[str] | None = None,
              order: int = 2) -> Propagation:
    """Propagate the per-angle covariance ``cov`` ({angle: (n, 3, 3)}, SI; NaN = unknown)
    through ``evaluate`` (a vectorised function of a frame with ``<angle><suffix>``
    columns, returning loads) at ``state``. ``names``: output columns to propagate
    (default: every float column ``evaluate`` returns that ``state`` does not hold).
    ``order``: 2 (central differences, linear + second-order variance + bias, 18 calls)
    or 1 (forward differences, linear variance only, 9 calls: about half the time)."""
    if order not in (1, 2):
        raise ValueError(f"propagate: order must be 1 or 2, not {order!r}")
    base = evaluate(state)
    if names is None:
        names = [c for c in base.columns
                 if c not in state.columns and base[c].dtype.kind == "f"]
    L0 = _numeric(base, names)
    columns = {c: state[c].to_numpy() for c in state.columns}

    def shifted(col: str, x: np.ndarray) -> pd.DataFrame:
        return pd.DataFrame(columns | {col: x}, index=state.index, copy=False)

    n, m = L0.shape
    lin = np.zeros((5, n, m))
    second = np.zeros((n, m))
    bias = np.zeros((n, m))
    for angle, C in cov.items():
        C = np.asarray(C, dtype=float)
        h = np.sqrt(np.clip(np.nan_to_num(np.diagonal(C, axis1=1, axis2=2)), 0.0, None))
        with np.errstate(invalid="ignore", divide="ignore"):
            R = C / (h[:, :, None] * h[:, None, :])
        R = np.where(np.isfinite(R), R, 0.0)
        a = np.zeros((3, n, m))
        b = np.zeros((3, n, m))
        for i, suffix in enumerate(STATE_SUFFIXES):
            col = angle + suffix
            if not np.any(h[:, i] > 0):
                continue
            x = state[col].to_numpy(dtype=float)
            Lp = _numeric(evaluate(shifted(col, x + h[:, i])), names)
            if order == 1:
                a[i] = np.nan_to_num(Lp - L0)
                continue
            Lm = _numeric(evaluate(shifted(col, x - h[:, i])), names)
            a[i] = np.nan_to_num(0.5 * (Lp - Lm))
            b[i] = np.nan_to_num(Lp + Lm - 2.0 * L0)
        for i in range(3):
            for j in range(3):
                r = R[:, i, j][:, None]
                lin[i + j] += a[i] * a[j] * r
                second += 0.5 * b[i] * b[j] * r * r
            bias += 0.5 * b[i]
    var = lin.sum(axis=0) + second + bias * bias
    sd = np.sqrt(np.clip(var, 0.0, None))
    sd = np.where(np.isfinite(L0), sd, np.nan)
    return Propagation(names=names, value=L0, sd=sd, by_order=lin)
