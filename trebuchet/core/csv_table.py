"""CSV files of the package's tables: pandas' ``to_csv`` text, about four times faster.

``DataFrame.to_csv`` formats every float through numpy's ``astype(str)`` (about 1.5 µs a
value) and hands the rows to the ``csv`` module; for the 105 columns of ``trebuchet forces``
that is most of the time the command spends after the reconstruction. :func:`csv_text`
writes the same bytes from Python's own float ``repr`` (the shortest string that reads back
to the same number, which is what numpy prints too), one ``%`` format per row:

* float64 columns: ``repr`` of each value, ``inf``/``-inf`` as they are, NaN as an empty
  cell (pandas' ``na_rep``); every digit that tells the double apart is kept, as pandas
  keeps it;
* integer and boolean columns: ``str`` (``3``, ``True``);
* text (object or string columns): the value, quoted as the ``csv`` module quotes (a cell
  holding a comma, a quote or a line break), missing values empty;
* the header: the names, quoted alike; with ``units``, ``name (unit)`` for the names that
  have one (:func:`trebuchet.model.units.column_unit`).

No index column, lines ending in ``os.linesep``, as ``to_csv(index=False)``. A table with
anything else (other dtypes, names that are not strings or repeat) is written by pandas
itself, so the bytes are pandas' in every case (``tests/test_csv_table.py``).
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.core.output import atomic_path

__all__ = ["csv_text", "write_table"]


class _Blank:
    """Formats as an empty cell under ``%r``: stands in for NaN in a float column."""

    __slots__ = ()

    def __repr__(self) -> str:
        return ""


_BLANK = _Blank()


def _quoted(text: str) -> str:
    """``text`` as one cell of the ``csv`` module's writer (pandas' quoting, QUOTE_MINIMAL)."""
    if not text:
        return text
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator=os.linesep).writerow([text])
    return buffer.getvalue()[:-len(os.linesep)]


def _text_cells(column: pd.Series) -> list[str]:
    """Cells of a text column: missing values empty, the others as ``str``, quoted."""
    missing = column.isna().to_numpy()
    seen: dict[object, str] = {}
    out = []
    for value, gap in zip(column.to_numpy(dtype=object).tolist(), missing.tolist(),
                          strict=True):
        if gap:
            out.append("")
            continue
        cell = seen.get(value)
        if cell is None:
            cell = seen[value] = _quoted(str(value))
        out.append(cell)
    return out


def _cells(column: pd.Series) -> tuple[str, list] | None:
    """The ``%`` format and the values of one column, or None where pandas must write it."""
    dtype = column.dtype
    if dtype == np.float64:
        values = column.to_numpy()
        cells = values.tolist()
        for i in np.flatnonzero(np.isnan(values)).tolist():
            cells[i] = _BLANK
        return "%r", cells
    if isinstance(dtype, np.dtype) and dtype.kind in "iub":
        return "%s", column.to_numpy().tolist()
    if (isinstance(dtype, np.dtype) and dtype.kind == "O") or isinstance(dtype, pd.StringDtype):
        values = column.to_numpy(dtype=object)
        if all(isinstance(v, str) for v in values[~column.isna().to_numpy()].tolist()):
            return "%s", _text_cells(column)
    return None


def _header_cells(names: list, units: Mapping[str, str] | None) -> list:
    """The header's names, ``name (unit)`` where ``units`` gives one (not for "1")."""
    units = units or {}
    return [f"{n} ({units[n]})" if units.get(n) not in (None, "", "1") else n for n in names]


def csv_text(frame: pd.DataFrame, units: Mapping[str, str] | None = None) -> str:
    """The CSV text of ``frame`` (no index): the bytes ``frame.to_csv(index=False)`` writes,
    with ``units`` (``{column: unit}``) written into the header as ``name (unit)``."""
    names = list(frame.columns)
    columns = None
    if (names and all(isinstance(n, str) for n in names) and len(set(names)) == len(names)
            and not isinstance(frame.columns, pd.MultiIndex) and len(names) > 1):
        columns = [_cells(frame.iloc[:, j]) for j in range(len(names))]
    if columns is None or any(c is None for c in columns):
        if units:
            frame = frame.set_axis(_header_cells(names, units), axis=1)
        return frame.to_csv(index=False)
    header = ",".join(_quoted(c) for c in _header_cells(names, units))
    line = ",".join(fmt for fmt, _ in columns)
    rows = [line % row for row in zip(*(c for _, c in columns), strict=True)]
    return os.linesep.join([header, *rows, ""])


def write_table(frame: pd.DataFrame, target: str | Path, *,
                units: Mapping[str, str] | None = None,
                inputs: Iterable[str | Path | None] = ()) -> None:
    """Write ``frame`` as CSV (:func:`csv_text`) to ``target``, whole or not at all
    (:func:`trebuchet.core.output.atomic_path`, which refuses a target among the command's
    ``inputs``); ``units``: ``{column: unit}`` for the header."""
    text = csv_text(frame, units)
    with (atomic_path(target, inputs=inputs) as tmp,
          open(tmp, "w", encoding="utf-8", newline="") as f):
        f.write(text)
