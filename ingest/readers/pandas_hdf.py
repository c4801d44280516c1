"""pandas' HDF5 tables (``DataFrame.to_hdf``) read with h5py, nothing unpickled.

pandas reads these files through PyTables, which unpickles attributes and object columns:
a file can make that run any code. Here the layout is read with h5py (which never
unpickles): the numbers from their numeric datasets, the column names from string datasets
or, where PyTables pickled them (the "table" format's ``non_index_axes``, ``info``,
``values_block_<k>_kind``), by :func:`.pickle_literals.literal`, which refuses any pickle
that is more than plain names. A block of pickled objects (a column of mixed types in the
"fixed" format: ``CLASS = VLARRAY``, ``PSEUDOATOM = object``) is refused unread.

The two layouts (pandas.io.pytables; the group of key ``k`` is ``/k``):

* **table** (``pandas_type = frame_table``): a compound dataset ``table`` with the field
  ``index`` and one field ``values_block_<k>`` (rows × columns) per dtype block; attributes
  ``non_index_axes`` (``[(1, [columns])]``), ``values_cols``, ``info`` (the column levels'
  names) on the group, ``values_block_<k>_kind`` (the block's columns) on ``table``;
* **fixed** (``pandas_type = frame``): datasets ``axis0`` (columns) and ``axis1`` (index),
  or, for a MultiIndex, ``axis0_level<i>`` (names, attribute ``name``) and
  ``axis0_label<i>`` (codes); per block ``block<k>_items`` (its columns, same scheme) and
  ``block<k>_values`` (stored transposed: rows × columns when ``transposed`` is set).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.readers.limits import MAX_DATASET_BYTES, MAX_ROWS
from trebuchet.ingest.readers.pickle_literals import literal


@dataclass(frozen=True)
class Frame:
    """A pandas DataFrame as read: ``index`` (rows,) as stored, ``columns`` one tuple of
    strings per column (one string each for flat columns), ``names`` the column levels'
    names (None where unnamed), ``values`` {column: (rows,) float64} of the numeric
    columns."""

    index: np.ndarray
    columns: list[tuple[str, ...]]
    names: list[str | None]
    values: dict[tuple[str, ...], np.ndarray]


def frame_keys(f) -> list[str]:
    """The keys (group paths without the leading ``/``) of the pandas tables in the open
    h5py file ``f``, found up to three groups deep."""
    found: list[str] = []

    def walk(group, depth: int) -> None:
        for name in list(group.keys())[:1000]:
            node = group.get(name, getlink=False)
            if not hasattr(node, "keys"):
                continue
            if "pandas_type" in node.attrs:
                found.append(node.name.lstrip("/"))
            elif depth < 3:
                walk(node, depth + 1)

    walk(f, 0)
    return found


def read_frame(f, key: str) -> Frame:
    """The table of ``key`` in the open h5py file ``f`` (see the module doc)."""
    group = f[key]
    kind = _text(group.attrs.get("pandas_type"))
    if kind == "frame_table":
        return _table(group, key)
    if kind == "frame":
        return _fixed(group, key)
    raise TrebuchetInputError.at(f"key '{key}'", f"a pandas {kind or 'object'} is not a "
                                 "table of frames (pandas_type frame_table or frame)")


def _text(value) -> str:
    if isinstance(value, bytes | np.bytes_):
        return bytes(value).decode("utf-8", errors="replace")
    return "" if value is None else str(value)


def _attr(node, name: str, where: str) -> object:
    """A pickled attribute's plain value (None when absent)."""
    if name not in node.attrs:
        return None
    raw = node.attrs[name]
    if not isinstance(raw, bytes | np.bytes_):
        return raw.item() if isinstance(raw, np.generic) else raw
    return literal(bytes(raw), f"{where}, attribute '{name}'")


def _dataset(node, name: str, where: str) -> np.ndarray:
    """A numeric or string dataset's values, refused when it holds pickled objects or more
    than :data:`MAX_DATASET_BYTES`."""
    if name not in node:
        raise TrebuchetInputError.at(where, f"no dataset '{name}'")
    ds = node[name]
    if not hasattr(ds, "dtype"):
        raise TrebuchetInputError.at(f"{where}/{name}", "a group where a dataset belongs")
    import h5py

    if (_text(ds.attrs.get("PSEUDOATOM")) == "object" or _text(ds.attrs.get("CLASS"))
            == "VLARRAY" or (ds.dtype.kind == "O" and h5py.check_string_dtype(ds.dtype)
                             is None)):
        raise TrebuchetInputError.at(
            f"{where}/{name}", "holds pickled Python objects (a column of mixed types): not "
            "read, since unpickling them would run code from the file; save the table "
            "without that column")
    size = int(np.prod(ds.shape, dtype=float)) * ds.dtype.itemsize if ds.shape else 0
    if size > MAX_DATASET_BYTES:
        raise TrebuchetInputError.at(
            f"{where}/{name}", f"shape {ds.shape}: {size / 2**20:.4g} MiB, more than the "
            f"{MAX_DATASET_BYTES >> 20} MiB a log's table can mean")
    return ds[()]


def _strings(values, where: str) -> list[str]:
    if not isinstance(values, list | tuple):
        raise TrebuchetInputError.at(where, f"expected a list of names, not {type(values)}")
    return [v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v) for v in values]


def _column(value, where: str) -> tuple[str, ...]:
    if isinstance(value, tuple):
        return tuple(_strings(value, where))
    return tuple(_strings([value], where))


def _table(group, key: str) -> Frame:
    where = f"key '{key}'"
    if "table" not in group:
        raise TrebuchetInputError.at(where, "no dataset 'table'")
    table_ds = group["table"]
    axes = _attr(group, "non_index_axes", where)
    if not (isinstance(axes, list) and len(axes) == 1 and isinstance(axes[0], tuple)
            and len(axes[0]) == 2 and isinstance(axes[0][1], list)):
        raise TrebuchetInputError.at(where, "attribute 'non_index_axes' is not [(1, "
                                     "[columns])] as pandas writes it")
    columns = [_column(c, where) for c in axes[0][1]]
    blocks = _strings(_attr(group, "values_cols", where) or [], where)
    table = _dataset(group, "table", where)
    fields = table.dtype.names or ()
    if "index" not in fields:
        raise TrebuchetInputError.at(f"{where}/table", "no field 'index'")
    values: dict[tuple[str, ...], np.ndarray] = {}
    for block in blocks:
        kind = _attr(table_ds, f"{block}_kind", f"{where}/table")
        if block not in fields or not isinstance(kind, list):
            raise TrebuchetInputError.at(f"{where}/table", f"block '{block}' without its "
                                         "values or its columns")
        data = np.asarray(table[block])
        data = data.reshape(len(table), -1)
        if data.shape[1] != len(kind):
            raise TrebuchetInputError.at(f"{where}/table", f"block '{block}' has "
                                         f"{data.shape[1]} columns for {len(kind)} names")
        if data.dtype.kind in "fiub":
            for j, col in enumerate(kind):
                values[_column(col, where)] = data[:, j].astype(float)
    info = _attr(group, "info", where)
    names = info.get(1, {}).get("names") if isinstance(info, dict) and isinstance(
        info.get(1), dict) else None
    return _frame(np.asarray(table["index"]), columns, names, values, where)


def _axis(group, prefix: str, where: str) -> tuple[list[tuple[str, ...]], list[str | None]]:
    """The labels of ``axis0`` or ``block<k>_items`` (regular or MultiIndex) and the levels'
    names."""
    if _text(group.attrs.get(f"{prefix}_variety")) != "multi":
        labels = _dataset(group, prefix, where)
        name = _text(group[prefix].attrs.get("name")) if prefix in group else ""
        return ([(_text(v) if isinstance(v, bytes | np.bytes_) else str(v),)
                 for v in np.ravel(labels)], [None if name in ("", "N.") else name])
    n = group.attrs.get(f"{prefix}_nlevels")
    if not isinstance(n, int | np.integer) or not 1 <= int(n) <= 16:
        raise TrebuchetInputError.at(where, f"attribute '{prefix}_nlevels' = {n!r} is no "
                                     "number of levels")
    levels, codes, names = [], [], []
    for i in range(int(n)):
        level = _dataset(group, f"{prefix}_level{i}", where)
        levels.append([_text(v) if isinstance(v, bytes | np.bytes_) else str(v)
                       for v in np.ravel(level)])
        codes.append(np.ravel(_dataset(group, f"{prefix}_label{i}", where)).astype(np.int64))
        name = _text(group[f"{prefix}_level{i}"].attrs.get("name"))
        names.append(None if name in ("", "N.") else name)
    if len({c.size for c in codes}) != 1:
        raise TrebuchetInputError.at(where, f"the levels of '{prefix}' have codes of "
                                     "different lengths")
    columns = []
    for k in range(codes[0].size):
        parts = []
        for level, code in zip(levels, codes, strict=True):
            c = int(code[k])
            if not -1 <= c < len(level):
                raise TrebuchetInputError.at(where, f"'{prefix}' code {c} is outside its "
                                             f"level of {len(level)} names")
            parts.append("" if c < 0 else level[c])
        columns.append(tuple(parts))
    return columns, names


def _fixed(group, key: str) -> Frame:
    where = f"key '{key}'"
    if _text(group.attrs.get("axis1_variety")) == "multi":
        raise TrebuchetInputError.at(where, "an index of several levels is not frame numbers")
    columns, names = _axis(group, "axis0", where)
    index = np.ravel(_dataset(group, "axis1", where))
    nblocks = group.attrs.get("nblocks")
    if not isinstance(nblocks, int | np.integer) or not 0 <= int(nblocks) <= 1000:
        raise TrebuchetInputError.at(where, f"attribute 'nblocks' = {nblocks!r} is no count "
                                     "of blocks")
    values: dict[tuple[str, ...], np.ndarray] = {}
    for k in range(int(nblocks)):
        items, _ = _axis(group, f"block{k}_items", where)
        data = _dataset(group, f"block{k}_values", where)
        if data.ndim != 2:
            raise TrebuchetInputError.at(f"{where}/block{k}_values", f"{data.ndim} dimensions,"
                                         " not rows × columns")
        if not group[f"block{k}_values"].attrs.get("transposed", False):
            data = data.T
        if data.shape != (index.size, len(items)):
            raise TrebuchetInputError.at(f"{where}/block{k}_values", f"shape {data.shape}, "
                                         f"not {index.size} rows × {len(items)} columns")
        if data.dtype.kind in "fiub":
            for j, col in enumerate(items):
                values[col] = data[:, j].astype(float)
    return _frame(index, columns, names, values, where)


def _frame(index: np.ndarray, columns: list[tuple[str, ...]], names, values, where: str
           ) -> Frame:
    if index.ndim != 1:
        raise TrebuchetInputError.at(where, "the index is not one column")
    if index.size > MAX_ROWS:
        raise TrebuchetInputError.at(where, f"{index.size} rows, more than the {MAX_ROWS:,} "
                                     "frames a log can hold")
    width = max((len(c) for c in columns), default=0)
    if names is None or len(names) != width:
        names = [None] * width
    for col, v in values.items():
        if v.shape != index.shape:
            raise TrebuchetInputError.at(where, f"column {col} has {v.size} values for "
                                         f"{index.size} rows")
    return Frame(index, columns, [None if n is None else str(n) for n in names], values)
