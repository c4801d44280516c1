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

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from trebuchet.ingest.kalman import reference
from trebuchet.ingest.kalman.kernel import compiled

__all__ = ["Propagation", "Columns", "propagate", "STATE_SUFFIXES", "BAND_SD", "CHUNK_ROWS",
           "chunk_rows"]

STATE_SUFFIXES = ("", "_d", "_dd")

#: A measured quantity's band is its mean ± BAND_SD standard deviations (figures, comparison).
BAND_SD = 2.0

#: Rows a table's propagation evaluates at a time at least (``propagate(chunk=…)``, see
#: :func:`chunk_rows`): its 19 evaluations of some 40 loads then hold about 2 MB.
CHUNK_ROWS = 256


def chunk_rows(n: int) -> int:
    """Rows to evaluate at a time on a table of ``n`` rows: :data:`CHUNK_ROWS`, or a 64th
    of the table if that is more (fewer calls on a long log; the evaluations then hold
    about 0.14 KiB a row of the table)."""
    return max(CHUNK_ROWS, n // 64)


class Columns(dict):
    """A table as numpy columns (a dict) with its rows' positions as ``index`` and its
    column names as ``columns``: what :func:`propagate` hands ``evaluate`` with
    ``columns=True``, read as a DataFrame is (``t["theta"]``, ``t.columns``, ``t.index``)
    without building one per evaluation."""

    def __init__(self, data: Mapping[str, np.ndarray], index: np.ndarray) -> None:
        super().__init__(data)
        self.index = index

    @property
    def columns(self) -> list[str]:
        return list(self)

    def __len__(self) -> int:
        return len(self.index)


@dataclass(frozen=True)
class Propagation:
    """Result of :func:`propagate` for the columns ``names`` (arrays of shape (n, m)).

    ``value``: the loads at the smoothed state; ``sd``: √(linear + second-order variance
    + bias²); ``by_order``: (5, n, m') linear variance split by ``i + j`` (angle 0, rate 1,
    acceleration 2 for each of the pair) of the columns ``order_names`` (all ``names``
    unless :func:`propagate` was asked for fewer; None: all)."""

    names: list[str]
    value: np.ndarray
    sd: np.ndarray
    by_order: np.ndarray
    order_names: list[str] | None = None

    def orders(self, name: str) -> np.ndarray:
        """The (5, n) variance by order of the column ``name``."""
        kept = self.names if self.order_names is None else self.order_names
        return self.by_order[:, :, kept.index(name)]


def _numeric(result: pd.DataFrame | Mapping[str, np.ndarray], names: list[str]) -> np.ndarray:
    """The columns ``names`` of an evaluation (a frame, or a mapping of columns) as (n, m)."""
    if isinstance(result, pd.DataFrame):
        return result[names].to_numpy(dtype=float)
    return np.stack([np.asarray(result[c], dtype=float) for c in names], axis=1)


def _shifts(state: pd.DataFrame, h: dict[str, np.ndarray], order: int
            ) -> list[tuple[str, int, np.ndarray]]:
    """(angle, state index, shifted column) of every evaluation after the unshifted one:
    ``+h`` (and ``−h`` for ``order`` 2) per angle and suffix with any positive ``h``."""
    out = []
    for angle, hh in h.items():
        for i, suffix in enumerate(STATE_SUFFIXES):
            if not np.any(hh[:, i] > 0):
                continue
            x = np.asarray(state[angle + suffix], dtype=float)
            out.append((angle, i, x + hh[:, i]))
            if order == 2:
                out.append((angle, i, x - hh[:, i]))
    return out


def propagate(evaluate: Callable[[pd.DataFrame], pd.DataFrame], state: pd.DataFrame,
              cov: dict[str, np.ndarray], names: list[str] | None = None,
              order: int = 2, stacked: bool = False, *, chunk: int | None = None,
              carry: Callable[[int, int], np.ndarray] | None = None,
              order_names: list[str] | None = None, columns: bool = False) -> Propagation:
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
    the bands: see ``SmoothSettings``).

    ``chunk``: rows evaluated at a time (None: all at once), so that the 2·9 + 1
    evaluations hold memory for that many rows only; each row's results are those of the
    whole (the sums are row by row). ``evaluate`` then gets frames of those rows, indexed by
    their positions in ``state``; ``carry(lo, hi)``: the positions (before ``lo``) of rows
    the rows ``lo … hi−1`` depend on (the projectile in flight on the last row in the
    sling), evaluated with them and dropped. ``order_names``: the columns whose
    ``by_order`` is kept (None: all). ``columns``: ``evaluate`` gets a :class:`Columns`
    (numpy columns and the rows' positions) instead of a DataFrame and may return one, or
    any mapping of columns (no DataFrame per evaluation)."""
    if order not in (1, 2):
        raise ValueError(f"propagate: order must be 1 or 2, not {order!r}")
    covs = {a: np.asarray(C, dtype=float) for a, C in cov.items()}
    n = len(state)
    if columns:
        state = Columns({c: np.asarray(state[c]) for c in state.columns}, np.arange(n))
    if chunk is None or n <= chunk:
        return _kept(_propagated(evaluate, state, covs, names, order, stacked), order_names)
    value = sd = lin = None
    for lo in range(0, n, chunk):
        hi = min(lo + chunk, n)
        extra = np.asarray(carry(lo, hi) if carry is not None else [], dtype=np.int64)
        rows = np.r_[extra, np.arange(lo, hi)]
        rows_of = (Columns({c: v[rows] for c, v in state.items()}, rows) if columns
                   else state.iloc[rows])
        part = _kept(_propagated(evaluate, rows_of, {a: C[rows] for a, C in covs.items()},
                                 names, order, stacked), order_names)
        if value is None:
            names = part.names
            value, sd = np.empty((n, len(names))), np.empty((n, len(names)))
            lin = np.empty((5, n, part.by_order.shape[2]))
        value[lo:hi], sd[lo:hi] = part.value[extra.size:], part.sd[extra.size:]
        lin[:, lo:hi] = part.by_order[:, extra.size:]
    return Propagation(names=names, value=value, sd=sd, by_order=lin,
                       order_names=part.order_names)


def _kept(prop: Propagation, order_names: list[str] | None) -> Propagation:
    """``prop`` with ``by_order`` for the columns ``order_names`` only (None: all)."""
    if order_names is None:
        return prop
    kept = [c for c in order_names if c in prop.names]
    return Propagation(prop.names, prop.value, prop.sd,
                       prop.by_order[:, :, [prop.names.index(c) for c in kept]], kept)


def _propagated(evaluate: Callable[[pd.DataFrame], pd.DataFrame], state: pd.DataFrame,
                covs: dict[str, np.ndarray], names: list[str] | None, order: int,
                stacked: bool) -> Propagation:
    """:func:`propagate` on all rows of ``state`` at once."""
    h = {a: np.sqrt(np.clip(np.nan_to_num(np.diagonal(C, axis1=1, axis2=2)), 0.0, None))
         for a, C in covs.items()}
    shifts = _shifts(state, h, order)
    columns = {c: np.asarray(state[c]) for c in state.columns}
    n = len(state)
    table = Columns if isinstance(state, Columns) else pd.DataFrame
    if stacked:
        big = {c: np.concatenate([v] + [x if c == a + STATE_SUFFIXES[i] else v
                                        for a, i, x in shifts])
               for c, v in columns.items()}
        result = evaluate(Columns(big, np.arange(n * (len(shifts) + 1))) if table is Columns
                          else pd.DataFrame(big))
        if names is None:
            names = _load_names(result, state)
        values = _numeric(result, names)
        outputs = values.reshape(len(shifts) + 1, n, len(names))
    else:
        base = evaluate(state)
        if names is None:
            names = _load_names(base, state)
        outputs = np.empty((len(shifts) + 1, n, len(names)))
        outputs[0] = _numeric(base, names)
        del base
        for s, (a, i, x) in enumerate(shifts):
            shifted = columns | {a + STATE_SUFFIXES[i]: x}
            frame = (Columns(shifted, state.index) if table is Columns
                     else pd.DataFrame(shifted, index=state.index, copy=False))
            outputs[s + 1] = _numeric(evaluate(frame), names)
    step = 2 if order == 2 else 1
    at = {(a, i): 1 + step * j for j, (a, i) in enumerate(dict.fromkeys(
        (a, i) for a, i, _ in shifts))}
    where = np.array([[at.get((a, i), -1) for i in range(3)] for a in covs],
                     dtype=np.int64).reshape(len(covs), 3)
    cov = np.stack([covs[a] for a in covs]) if covs else np.zeros((0, n, 3, 3))
    sd_h = np.stack([h[a] for a in covs]) if covs else np.zeros((0, n, 3))
    if reference.active():
        sd, lin = _variance_numpy(outputs, where, cov, sd_h, order)
    else:
        sd = np.empty((n, len(names)))
        lin = np.empty((5, n, len(names)))
        _variance(outputs, where, _f(cov), _f(sd_h), order, sd, lin)
    return Propagation(names=names, value=outputs[0].copy(), sd=sd, by_order=lin)


def _variance_numpy(outputs: np.ndarray, where: np.ndarray, cov: np.ndarray, h: np.ndarray,
                    order: int) -> tuple[np.ndarray, np.ndarray]:
    """The sd (n, m) and the linear variance by order (5, n, m) from the evaluations
    ``outputs`` (S, n, m; the unshifted first, the +h one of angle ``a``'s state ``i`` at
    ``where[a, i]`` (−1: none), its −h one next to it), each angle's covariance ``cov``
    (A, n, 3, 3) and sds ``h`` (A, n, 3): the module doc's sums, in numpy (the numpy form
    of the compiled :func:`_variance`, which runs the same operations element by element)."""
    L0 = outputs[0]
    _, n, m = outputs.shape
    lin = np.zeros((5, n, m))
    second = np.zeros((n, m))
    bias = np.zeros((n, m))
    for C, hh, at in zip(cov, h, where, strict=True):
        with np.errstate(invalid="ignore", divide="ignore"):
            R = C / (hh[:, :, None] * hh[:, None, :])
        R = np.where(np.isfinite(R), R, 0.0)
        a = np.zeros((3, n, m))
        b = np.zeros((3, n, m))
        for i in range(3):
            if at[i] < 0:
                continue
            Lp = outputs[at[i]]
            if order == 1:
                a[i] = np.nan_to_num(Lp - L0)
                continue
            Lm = outputs[at[i] + 1]
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
    return np.where(np.isfinite(L0), sd, np.nan), lin


def _finite(x: float) -> float:
    """``np.nan_to_num`` of one number: NaN 0, ±inf the largest finite float."""
    if x != x:
        return 0.0
    if x == np.inf:
        return 1.7976931348623157e308
    if x == -np.inf:
        return -1.7976931348623157e308
    return x


def _variance_kernel(outputs, where, cov, h, order, sd, lin):  # noqa: ANN001, ANN201
    """:func:`_variance_numpy` element by element (compiled; writes ``sd``, ``lin``): the
    same operations on each row and load in the same order, without its (n, m) arrays."""
    S, n, m = outputs.shape
    A = cov.shape[0]
    R = np.empty((A, 3, 3))
    a = np.empty(3)
    b = np.empty(3)
    acc = np.empty(5)
    for row in range(n):
        for g in range(A):
            for i in range(3):
                for j in range(3):
                    v = cov[g, row, i, j] / (h[g, row, i] * h[g, row, j])
                    R[g, i, j] = v if np.isfinite(v) else 0.0
        for col in range(m):
            L0 = outputs[0, row, col]
            for q in range(5):
                acc[q] = 0.0
            second = 0.0
            bias = 0.0
            for g in range(A):
                for i in range(3):
                    s = where[g, i]
                    a[i] = 0.0
                    b[i] = 0.0
                    if s < 0:
                        continue
                    Lp = outputs[s, row, col]
                    if order == 1:
                        a[i] = _finite(Lp - L0)
                        continue
                    Lm = outputs[s + 1, row, col]
                    a[i] = _finite(0.5 * (Lp - Lm))
                    b[i] = _finite(Lp + Lm - 2.0 * L0)
                for i in range(3):
                    r = R[g, i, i]
                    acc[2 * i] += a[i] * a[i] * r
                    if order == 2:
                        second += 0.5 * r * (b[i] * b[i])
                        bias += 0.5 * b[i]
                    for j in range(i + 1, 3):
                        r = R[g, i, j]
                        acc[i + j] += 2.0 * r * (a[i] * a[j])
                        if order == 2:
                            second += (r * r) * (b[i] * b[j])
            total = acc[0]
            for q in range(5):
                lin[q, row, col] = acc[q]
                if q > 0:
                    total += acc[q]
            var = total + second + bias * bias
            if not np.isfinite(L0):
                sd[row, col] = np.nan
            elif var > 0.0 or var != var:
                sd[row, col] = np.sqrt(var)
            else:
                sd[row, col] = 0.0


def _f(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


_finite = compiled(_finite)
_variance = compiled(_variance_kernel)


def _load_names(result: pd.DataFrame | Mapping[str, np.ndarray], state: pd.DataFrame
                ) -> list[str]:
    """Every float column of ``result`` (a frame or a mapping of columns) that ``state``
    does not hold."""
    return [c for c in result if c not in state.columns
            and np.asarray(result[c]).dtype.kind == "f"]
