"""A log file as a table of text cells, each data row with its line number in the file.

Reading is shared by every log format: the text is decoded, split into lines, the
delimiter is found, and cells are split with quotes respected. Numbers are converted
only for the columns a format needs, so that text in an unused column is no error,
while text in a used one is reported with file, line and column.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from trebuchet.errors import TrebuchetInputError

#: Cells read as "no value": an empty cell or an explicit not-a-number.
MISSING_TOKENS = frozenset({"", "nan", "-nan", "na", "n/a", "null", "none"})

#: Delimiters tried, in order of preference.
DELIMITERS = ("\t", ";", ",")


@dataclass(frozen=True)
class Line:
    """One line of the file: its 1-based line number and its cells (stripped)."""

    number: int
    cells: list[str]


def read_text(path: str | Path) -> str:
    """Return the text of a log file.

    UTF-8 (with or without BOM) and UTF-16 with BOM are read; anything else falls back
    to Windows-1252. A missing, unreadable, empty or binary file is a
    :class:`TrebuchetInputError` naming the file.
    """
    p = Path(path)
    if not p.exists():
        raise TrebuchetInputError("no such file")
    if p.is_dir():
        raise TrebuchetInputError("is a folder, not a log file")
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise TrebuchetInputError(f"cannot be read ({exc.strerror})") from None
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        text = raw.decode("utf-16")
    elif b"\x00" in raw[:4096]:
        raise TrebuchetInputError("is not a text (CSV) file")
    else:
        try:
            text = raw.decode("utf-8-sig")
        except UnicodeDecodeError:
            text = raw.decode("cp1252", errors="replace")
    if not text.strip():
        raise TrebuchetInputError("the file is empty")
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
    """Split one line into stripped cells (double quotes respected; ``" "`` = any whitespace)."""
    if delimiter == " ":
        return line.split()
    return [c.strip() for c in next(csv.reader([line], delimiter=delimiter))]


def table_lines(numbered: list[tuple[int, str]], delimiter: str) -> list[Line]:
    """Split numbered lines into :class:`Line` objects."""
    return [Line(n, split_cells(text, delimiter)) for n, text in numbered]


def parse_number(cell: str) -> float | None:
    """Return the number in ``cell``; NaN for a missing cell; None if it is not a number.

    A decimal comma (``1,25`` or Java's ``1,25E-3``) is accepted: a comma can only be
    inside a cell when the delimiter is not a comma or the cell is quoted.
    """
    s = cell.strip().strip('"').strip()
    if s.lower() in MISSING_TOKENS:
        return math.nan
    if "," in s and "." not in s and s.count(",") == 1:
        s = s.replace(",", ".")
    s = s.replace("\u2212", "-")  # a typographic minus sign
    try:
        value = float(s)
    except ValueError:
        return None
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
            raise TrebuchetInputError.at(
                f"row {line.number}, column '{name}'", f"{cell!r} is not a number"
            )
        out[k] = value
    return out


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
