"""Fast assembly of wide DataFrames from columns of equal length.

``pd.DataFrame(dict_of_arrays)`` sanitises every column on its own (~10–30 µs each) before
stacking them into blocks; for the ~60 columns of :func:`trebuchet.model.loads.loads` that
is most of two milliseconds. :func:`frame` stacks the float64 columns into one block itself
and hands the blocks to pandas' low-level constructor
(``pandas.api.internals.create_dataframe_from_blocks``, pandas >= 3.0): the same frame
(columns, order, dtypes, values, index) in about a tenth of the time. Anything unusual
(other dtypes than numbers and booleans, unequal lengths, an older pandas) goes through
``pd.DataFrame`` unchanged.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import lru_cache

import numpy as np
import pandas as pd

try:  # pandas >= 3.0
    from pandas.api.internals import create_dataframe_from_blocks as _from_blocks
except ImportError:  # pragma: no cover - older pandas
    _from_blocks = None

__all__ = ["frame", "block_frame"]


@lru_cache(maxsize=64)
def _columns(names: tuple[str, ...]) -> pd.Index:
    """The column index pandas would build from these keys (cached: the same few sets of
    names come back on every call, and an Index is immutable)."""
    return pd.Index(list(names))


def frame(columns: Mapping[str, np.ndarray], index: pd.Index | None = None) -> pd.DataFrame:
    """``pd.DataFrame(columns, index=index)`` for one-dimensional numpy columns of one length,
    built with every float64 column in a single block."""
    names = tuple(columns)
    arrays = [columns[k] for k in names]
    n = len(arrays[0]) if arrays else 0
    if (_from_blocks is None or not names or len(set(names)) != len(names)
            or not all(isinstance(k, str) for k in names)
            or not all(type(a) is np.ndarray and a.ndim == 1 and len(a) == n
                       and a.dtype.kind in "biuf" for a in arrays)
            or (index is not None and len(index) != n)):
        return pd.DataFrame(dict(columns), index=index)
    float_pos = [i for i, a in enumerate(arrays) if a.dtype == np.float64]
    block = np.empty((len(float_pos), n))
    for j, i in enumerate(float_pos):
        block[j] = arrays[i]
    blocks = [(block, np.asarray(float_pos, dtype=np.intp))] if float_pos else []
    blocks += [(arrays[i].reshape(1, n).copy(), np.asarray([i], dtype=np.intp))
               for i, a in enumerate(arrays) if a.dtype != np.float64]
    return _from_blocks(blocks, index=pd.RangeIndex(n) if index is None else index,
                        columns=_columns(names))


def block_frame(names: tuple[str, ...], block: np.ndarray,
                others: Mapping[int, np.ndarray]) -> pd.DataFrame:
    """A DataFrame of the columns ``names`` on a RangeIndex: the float64 columns are the rows of
    ``block`` (C order, one row per column, in the order of ``names``) and ``others`` the
    columns of other dtypes, by position in ``names``. ``block`` is not copied where pandas
    allows it (pandas >= 3.0)."""
    n = block.shape[1]
    float_pos = np.asarray([i for i in range(len(names)) if i not in others], dtype=np.intp)
    if _from_blocks is None:  # pragma: no cover - older pandas
        cols = dict(zip((names[i] for i in float_pos), block, strict=True))
        cols.update({names[i]: v for i, v in others.items()})
        return pd.DataFrame({k: cols[k] for k in names})
    blocks = [(block, float_pos)]
    blocks += [(np.asarray(v).reshape(1, n), np.asarray([i], dtype=np.intp))
               for i, v in others.items()]
    return _from_blocks(blocks, index=pd.RangeIndex(n), columns=_columns(tuple(names)))
