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

__all__ = ["Propagation", "propagate", "STATE_SUFFIXES", "BAND_SD"]

STATE_SUFFIXES = ("", "_d", "_dd")

#: A measured quantity's band is its mean ± BAND_SD standard deviations (figures, comparison).
BAND_SD = 2.0


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


def _shifts(state: pd.DataFrame, h: dict[str, np.ndarray], order: int
            ) -> list[tuple[str, int, np.ndarray]]:
    """(angle, state index, shifted column) of every evaluation after the unshifted one:
    ``+h`` (and ``−h`` for ``order`` 2) per angle and suffix with any positive ``h``."""
    out = []
    for angle, hh in h.items():
        for i, suffix in enumerate(STATE_SUFFIXES):
            if not np.any(hh[:, i] > 0):
                continue
            x = state[angle + suffix].to_numpy(dtype=float)
            out.append((angle, i, x + hh[:, i]))
            if order == 2:
                out.append((angle, i, x - hh[:, i]))
    return out


def propagate(evaluate: Callable[[pd.DataFrame], pd.DataFrame], state: pd.DataFrame,
              cov: dict[str, np.ndarray], names: list[str] | None = None,
              order: int = 2, stacked: bool = False) -> Propagation:
    """Propagate the per-angle covariance ``cov`` ({angle: (n, 3, 3)}, SI; NaN = unknown)
    through ``evaluate`` (a vectorised function of a frame with ``<angle><suffix>``
    columns, returning loads) at ``state``. ``names``: output columns to propagate
    (default: every float column ``evaluate`` returns that ``state`` does not hold).
    ``order``: 2 (central differences, linear + second-order variance + bias, 18 calls)
    or 1 (forward differences, linear variance only, 9 calls: about half the time).
    ``stacked``: one call of ``evaluate`` on the unshifted and all shifted states one
    below the other instead of one call each: only for an ``evaluate`` whose rows do not
    depend on each other (it gets a frame that many times longer); far faster on a few
    rows, where each call's fixed cost dominates. The angles' errors are independent (their
    cross-covariances through the shared process noise were measured and did not improve
    the bands: see ``SmoothSettings``)."""
    if order not in (1, 2):
        raise ValueError(f"propagate: order must be 1 or 2, not {order!r}")
    covs = {a: np.asarray(C, dtype=float) for a, C in cov.items()}
    h = {a: np.sqrt(np.clip(np.nan_to_num(np.diagonal(C, axis1=1, axis2=2)), 0.0, None))
         for a, C in covs.items()}
    shifts = _shifts(state, h, order)
    columns = {c: state[c].to_numpy() for c in state.columns}
    n = len(state)
    if stacked:
        big = {c: np.concatenate([v] + [x if c == a + STATE_SUFFIXES[i] else v
                                        for a, i, x in shifts])
               for c, v in columns.items()}
        result = evaluate(pd.DataFrame(big))
        if names is None:
            names = _load_names(result, state)
        values = _numeric(result, names)
        outputs = [values[b * n:(b + 1) * n] for b in range(len(shifts) + 1)]
    else:
        base = evaluate(state)
        if names is None:
            names = _load_names(base, state)
        outputs = [_numeric(base, names)]
        for a, i, x in shifts:
            frame = pd.DataFrame(columns | {a + STATE_SUFFIXES[i]: x}, index=state.index,
                                 copy=False)
            outputs.append(_numeric(evaluate(frame), names))
    L0 = outputs[0]
    m = L0.shape[1]
    lin = np.zeros((5, n, m))
    second = np.zeros((n, m))
    bias = np.zeros((n, m))
    step = 2 if order == 2 else 1
    at = {(a, i): 1 + step * j for j, (a, i) in enumerate(dict.fromkeys(
        (a, i) for a, i, _ in shifts))}
    for angle, C in covs.items():
        hh = h[angle]
        with np.errstate(invalid="ignore", divide="ignore"):
            R = C / (hh[:, :, None] * hh[:, None, :])
        R = np.where(np.isfinite(R), R, 0.0)
        a = np.zeros((3, n, m))
        b = np.zeros((3, n, m))
        for i in range(3):
            if (angle, i) not in at:
                continue
            Lp = outputs[at[angle, i]]
            if order == 1:
                a[i] = np.nan_to_num(Lp - L0)
                continue
            Lm = outputs[at[angle, i] + 1]
            a[i] = np.nan_to_num(0.5 * (Lp - Lm))
            b[i] = np.nan_to_num(Lp + Lm - 2.0 * L0)
        for i in range(3):  # the symmetric pairs once, doubled; R_ii is 1 (or 0)
            r = R[:, i, i][:, None]
            lin[2 * i] += a[i] * a[i] * r
            if order == 2:
                second += 0.5 * r * (b[i] * b[i])
                bias += 0.5 * b[i]
            for j in range(i + 1, 3):
                r = R[:, i, j][:, None]
                lin[i + j] += 2.0 * r * (a[i] * a[j])
                if order == 2:
                    second += (r * r) * (b[i] * b[j])
    var = lin.sum(axis=0) + second + bias * bias
    sd = np.sqrt(np.clip(var, 0.0, None))
    sd = np.where(np.isfinite(L0), sd, np.nan)
    return Propagation(names=names, value=L0, sd=sd, by_order=lin)


def _load_names(result: pd.DataFrame, state: pd.DataFrame) -> list[str]:
    """Every float column of ``result`` that ``state`` does not hold."""
    return [c for c in result.columns if c not in state.columns and result[c].dtype.kind == "f"]
