"""A log file as a table of text cells, each data row with its line number in the file.

Reading is shared by every log format: the text is decoded, split into lines, the
delimiter is found, and cells are split with quotes respected. Numbers are converted
only for the columns a format needs, so that text in an unused column is no error,
while text in a used one is reported with file, line and column.
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.core.user_files import read_user_file
from trebuchet.ingest.readers.limits import MAX_CELL_CHARS, MAX_ROWS, MAX_TEXT_BYTES

#: Cells read as "no value": an empty cell or an explicit not-a-number.
MISSING_TOKENS = frozenset({"", "nan", "-nan", "na", "n/a", "null", "none"})

#: A number as CSV tools read it: ASCII digits, one decimal point, an exponent.
DECIMAL = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")

#: Delimiters tried, in order of preference.
DELIMITERS = ("\t", ";", ",")


@dataclass(frozen=True)
class Line:
    """One line of the file: its 1-based line number and its cells (stripped)."""

    number: int
    cells: list[str]


def read_text(path: str | Path) -> str:
    """Return the text of a log file (a regular file of at most :data:`.limits.MAX_TEXT_BYTES`,
    see :func:`trebuchet.core.user_files.read_user_file`), decoded by :func:`decode_text`. A
    missing, unreadable, special, oversized, empty or binary file is a
    :class:`TrebuchetInputError` without the file's name (the caller adds it)."""
    return decode_text(read_user_file(path, "log", MAX_TEXT_BYTES))


def decode_text(raw: bytes) -> str:
    """The text of a log file's bytes.

    UTF-8 (with or without BOM) and UTF-16 with BOM are read; anything else falls back
    to Windows-1252. Binary content, UTF-16 that does not decode (an odd number of bytes:
    a cut file), an empty file and more than :data:`.limits.MAX_ROWS` lines are a
    :class:`TrebuchetInputError`.
    """
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        try:
            text = raw.decode("utf-16")
        except UnicodeDecodeError as exc:
            odd = " (an odd number of bytes: the file is cut?)" if len(raw) % 2 else ""
            raise TrebuchetInputError(
                f"starts as UTF-16 text (byte-order mark) but byte {exc.start} does not "
                f"decode{odd}") from None
        text = text.lstrip("\ufeff")
        if "\x00" in text[:4096]:
            raise TrebuchetInputError("is not a text (CSV) file")
    elif b"\x00" in raw[:4096]:
        raise TrebuchetInputError("is not a text (CSV) file")
    else:
        try:
            text = raw.decode("utf-8-sig")
        except UnicodeDecodeError:
            text = raw.decode("cp1252", errors="replace")
    if not text.strip():
        raise TrebuchetInputError("the file is empty")
    lines = text.count("\n") + 1
    if lines > MAX_ROWS + 100:
        raise TrebuchetInputError(f"{lines:,} lines, more than the {MAX_ROWS:,} frames a log "
                                  "can hold")
    return text


def split_lines(text: str) -> list[tuple[int, str]]:
    """Return the non-blank lines of ``text`` with their 1-based line numbers."""
    return [(i + 1, line) for i, line in enumerate(text.splitlines()) if line.strip()]


def sniff_delimiter(header: str) -> str:
    """Return the delimiter of a header line: tab, then ``;``, then ``,``, else whitespace.

    Outside quotes only: a Kinovea header ``"Time","A/p/X"`` is comma separated even
    though its cells may hold other characters. Returns ``" "`` for whitespace.
    """
    outside = _outside_quotes(header)
    for d in DELIMITERS:
        if d in outside:
            return d
    return " "


def _outside_quotes(line: str) -> str:
    """The characters of ``line`` not inside double quotes."""
    out, inside = [], False
    for ch in line:
        if ch == '"':
            inside = not inside
        elif not inside:
            out.append(ch)
    return "".join(out)


def split_cells(line: str, delimiter: str) -> list[str]:
    """Split one line into stripped cells (double quotes respected; ``" "`` = any whitespace).

    A cell longer than :data:`.limits.MAX_CELL_CHARS` (no number or name is) is a
    :class:`TrebuchetInputError` (without the row: :func:`table_lines` adds it)."""
    if delimiter == " ":
        cells = line.split()
    else:
        try:
            cells = [c.strip() for c in next(csv.reader([line], delimiter=delimiter))]
        except (csv.Error, StopIteration) as exc:
            raise TrebuchetInputError(_cell_error(line, exc)) from None
    if any(len(c) > MAX_CELL_CHARS for c in cells):
        raise TrebuchetInputError(_cell_error(line, None))
    return cells


def _cell_error(line: str, exc: Exception | None) -> str:
    if exc is None or "field larger" in str(exc):
        return (f"a cell of more than {MAX_CELL_CHARS:,} characters, which no number or name "
                "of a log is")
    return f"cannot be split into cells ({exc})"


def table_lines(numbered: list[tuple[int, str]], delimiter: str) -> list[Line]:
    """Split numbered lines into :class:`Line` objects; a line that cannot be split is a
    :class:`TrebuchetInputError` naming its row."""
    out = []
    for n, text in numbered:
        try:
            out.append(Line(n, split_cells(text, delimiter)))
        except TrebuchetInputError as exc:
            raise TrebuchetInputError.at(f"row {n}", exc.message) from None
    return out


def parse_number(cell: str) -> float | None:
    """Return the number in ``cell``; NaN for a missing cell; None if it is not a number.

    A decimal comma (``1,25`` or Java's ``1,25E-3``) is accepted: a comma can only be
    inside a cell when the delimiter is not a comma or the cell is quoted. Only ASCII
    decimals are numbers, as CSV tools read them (:data:`DECIMAL`): ``5_0.1`` and digits of
    other scripts are text, refused where the column is used.
    """
    s = cell.strip().strip('"').strip()
    if s.lower() in MISSING_TOKENS:
        return math.nan
    if "," in s and "." not in s and s.count(",") == 1:
        s = s.replace(",", ".")
    s = s.replace("\u2212", "-")  # a typographic minus sign
    if not DECIMAL.fullmatch(s):  # float() would take '5_0.1', Arabic-Indic or wide digits
        return None
    value = float(s)
    if math.isinf(value):
        return None
    return value


def numeric_column(
    lines: list[Line], index: int, name: str
) -> np.ndarray:
    """Return column ``index`` of the data ``lines`` as float64, NaN where empty.

    Text in a cell (or an infinite value) is a :class:`TrebuchetInputError` naming the
    file, the line number in the file and the column ``name``.
    """
    out = np.empty(len(lines))
    for k, line in enumerate(lines):
        cell = line.cells[index] if index < len(line.cells) else ""
        value = parse_number(cell)
        if value is None:
            hint = ("" if cell.isascii() and "_" not in cell else " (only ASCII digits, a "
                    "decimal point or comma and an exponent make a number)")
            raise TrebuchetInputError.at(
                f"row {line.number}, column '{name}'", f"{cell!r} is not a number{hint}"
            )
        out[k] = value
    return out


def point_getter(lines: list[Line], ix: int, iy: int, x_name: str, y_name: str
                 ) -> Callable[[], tuple[np.ndarray, np.ndarray, None]]:
    """A function returning ``(x, y, None)`` of a point track: columns ``ix`` and ``iy`` of
    the data ``lines`` (:func:`numeric_column`, named ``x_name``, ``y_name`` in messages;
    the file's length unit, y up), read only when called."""

    def get() -> tuple[np.ndarray, np.ndarray, None]:
        return numeric_column(lines, ix, x_name), numeric_column(lines, iy, y_name), None

    return get


def check_row_lengths(lines: list[Line], n_columns: int) -> None:
    """Error for a data row with more non-empty cells than the header has columns."""
    for line in lines:
        extra = [c for c in line.cells[n_columns:] if c]
        if extra:
            raise TrebuchetInputError.at(
                f"row {line.number}", f"{len(line.cells)} cells, but the header has "
                f"{n_columns} column{'' if n_columns == 1 else 's'} (extra value {extra[0]!r})"
            )


def header_and_rows(numbered: list[tuple[int, str]],
                    delimiter: str) -> tuple[Line, list[Line]]:
    """The header line and the data lines of a one-header table, every data line as long as
    the header; an error naming the file when there is no data row."""
    header_line, *data = table_lines(numbered, delimiter)
    if not data:
        raise TrebuchetInputError(
            f"only a header row (row {header_line.number}), no data rows"
        )
    check_row_lengths(data, len(header_line.cells))
    return header_line, data


def format_rows(rows: np.ndarray | list[int], limit: int = 8) -> str:
    """``[3, 4, 5, 9]`` -> ``"rows 3-5, 9"``; long lists end in ``", ... (N in all)"``."""
    rows = [int(r) for r in rows]
    if not rows:
        return "no rows"
    spans: list[tuple[int, int]] = []
    for r in rows:
        if spans and r == spans[-1][1] + 1:
            spans[-1] = (spans[-1][0], r)
        else:
            spans.append((r, r))
    parts = [f"{a}" if a == b else f"{a}-{b}" for a, b in spans[:limit]]
    more = f", ... ({len(rows)} rows in all)" if len(spans) > limit else ""
    word = "row" if len(rows) == 1 else "rows"
    return f"{word} {', '.join(parts)}{more}"
