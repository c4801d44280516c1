"""Mutations of the text logs of the fuzz corpus (:mod:`._fuzz_cases`): encodings, cells
that are no numbers or no engine's, a cell off by 30° or 90°, a jumping point, cut, repeated
and swapped rows, long cells and headers, escape sequences in a name, shifted times."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from bench._fuzz_cases import Base, Case, rng_for

# --------------------------------------------------------------------------- text logs

def _delimiter(line: str) -> str:
    for d in ("\t", ";", ","):
        if d in line:
            return d
    return " "


def _number(cell: str) -> float | None:
    s = cell.strip().strip('"').replace(",", ".")
    try:
        return float(s)
    except ValueError:
        return None


def _data_lines(lines: list[str], base: Base) -> list[int]:
    """Indexes of the data lines (the time column, or the first, holds a number)."""
    col = base.time_col if base.time_col is not None else 0
    if base.key.startswith("anipose"):
        col = None
    out = []
    for i, line in enumerate(lines):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        cells = line.rstrip("\r\n").split(_delimiter(line))
        probe = cells[-1] if col is None else (cells[col] if col < len(cells) else "")
        if _number(probe) is not None and i > 0:
            out.append(i)
    return out


def _format_like(old: str, value: float) -> str:
    """``value`` written as the cell ``old`` is (quotes, decimal comma, decimals)."""
    raw = old.strip().strip('"')
    decimals = len(raw.split(".")[-1]) if "." in raw else (
        len(raw.split(",")[-1]) if "," in raw and "E" not in raw.upper() else 6)
    text = f"{value:.{min(decimals, 9)}f}"
    if "," in raw:
        text = text.replace(".", ",")
    return f'"{text}"' if old.strip().startswith('"') else text


def _set_cell(line: str, col: int, new: str) -> str:
    end = line[len(line.rstrip("\r\n")):]
    d = _delimiter(line)
    cells = line.rstrip("\r\n").split(d)
    if col < len(cells):
        cells[col] = new
    return d.join(cells) + end


def _cell(line: str, col: int) -> str:
    cells = line.rstrip("\r\n").split(_delimiter(line))
    return cells[col] if col < len(cells) else ""


@dataclass
class _Mutator:
    """A text log's lines and the cases made from them: :meth:`add` one, :meth:`pick` a data
    row (with a number in column ``col``), :meth:`with_cell` the text with one cell changed."""

    base: Base
    lines: list[str]
    data: list[int]
    rng: np.random.Generator
    out: list[Case] = field(default_factory=list)

    def add(self, mutation: str, expect: str, content: bytes | str,
            rows: tuple[int, ...] = ()) -> None:
        body = content.encode("utf-8") if isinstance(content, str) else content
        self.out.append(Case(f"log/{self.base.key}/{mutation}", self.base, mutation, expect,
                             body, rows=rows, suffix=self.base.path.suffix))

    def pick(self, col: int | None) -> int:
        data = self.data
        middle = data[len(data) // 5: 4 * len(data) // 5]
        for _ in range(200):
            i = int(self.rng.choice(middle))
            if col is None or _number(_cell(self.lines[i], col)) is not None:
                return i
        return int(middle[0])

    def with_cell(self, i: int, col: int, new: str) -> str:
        lines = self.lines
        return "".join(lines[:i] + [_set_cell(lines[i], col, new)] + lines[i + 1:])


def text_cases(base: Base, seed: int) -> list[Case]:
    """Mutations of a text log."""
    raw = base.path.read_bytes()
    text = raw.decode("utf-8-sig", errors="replace")
    lines = text.splitlines(keepends=True)
    m = _Mutator(base, lines, _data_lines(lines, base), rng_for(seed, base.key))
    joined = "".join
    m.add("crlf", "same", joined(ln.rstrip("\r\n") + "\r\n" for ln in lines))
    m.add("utf8_bom", "same", b"\xef\xbb\xbf" + text.encode("utf-8"))
    m.add("utf16_bom", "same", "\ufeff".encode("utf-16-le") + text.encode("utf-16-le"))
    m.add("utf16_odd_bytes", "flag", "\ufeff".encode("utf-16-le") + text.encode("utf-16-le")
          + b"x")
    m.add("blank_lines", "same", text + "\n\n\n")
    if base.value_col is not None:
        _cell_cases(m, base.value_col)
    _header_cases(m)
    if m.data:
        _row_cases(m)
    m.add("empty", "flag", b"")
    m.add("binary", "flag", bytes(m.rng.integers(0, 256, 4096, dtype=np.uint8)))
    return m.out


def _cell_cases(m: _Mutator, vcol: int) -> None:
    """A value cell that is no number, too long, written in other digits, or off the shot."""
    for mutation, new in (("cell_text", "abc"), ("cell_inf", "inf"),
                          ("cell_1e400", "1e400"), ("cell_1e300", "1e300"),
                          ("cell_long", "9" * 140_000)):
        i = m.pick(vcol)
        m.add(mutation, "flag", m.with_cell(i, vcol, new), (i + 1,))
    for mutation, fn in (("cell_underscore", lambda s: re.sub(r"(\d)(\d)", r"\1_\2", s,
                                                              count=1)),
                         ("cell_arabic_digits", lambda s: s.translate(
                             str.maketrans("0123456789", "٠١٢٣٤٥٦٧٨٩"))),
                         ("cell_fullwidth_digits", lambda s: s.translate(
                             str.maketrans("0123456789", "０１２３４５６７８９")))):
        for _ in range(50):
            i = m.pick(vcol)
            old = _cell(m.lines[i], vcol)
            new = fn(old)
            if new != old:
                break
        m.add(mutation, "refuse", m.with_cell(i, vcol, new), (i + 1,))
    if m.base.angle_unit:
        for step in (30.0, 90.0):
            i = m.pick(vcol)
            old = _cell(m.lines[i], vcol)
            shift = step if m.base.angle_unit == "deg" else math.radians(step)
            m.add(f"angle_outlier_{step:g}deg", "flag",
                  m.with_cell(i, vcol, _format_like(old, _number(old) + shift)), (i + 1,))
    else:
        i = m.pick(vcol)
        old = _number(_cell(m.lines[i], vcol))
        new = _format_like(_cell(m.lines[i], vcol), old + 0.25 * _spread(m))
        m.add("point_jump", "flag", m.with_cell(i, vcol, new), (i + 1,))


def _spread(m: _Mutator) -> float:
    """A quarter of the picture's scale: the largest range of any column but the time's."""
    lines, data = m.lines, m.data
    spread = 0.0
    for col in range(len(lines[data[0]].split(_delimiter(lines[data[0]])))):
        if col == m.base.time_col:
            continue
        vals = [v for k in data if (v := _number(_cell(lines[k], col))) is not None
                and math.isfinite(v)]
        if vals:
            spread = max(spread, max(vals) - min(vals))
    return spread


def _header_cases(m: _Mutator) -> None:
    """Escape sequences in a column's name, and a header cell over 131,072 characters."""
    lines, joined = m.lines, "".join
    header = m.data[0] - 1 if m.data else 0
    if header < 0 or not m.data:
        return
    h = lines[header]
    d = _delimiter(h)
    cells = h.rstrip("\r\n").split(d)
    vcol = m.base.value_col
    j = vcol if vcol is not None and vcol < len(cells) else 0
    cells_c = list(cells)
    cells_c[j] = cells_c[j][:1] + "\x1b[2J\x1b]0;pwned\x07" + cells_c[j][1:]
    m.add("header_control_bytes", "any", joined(lines[:header] + [d.join(cells_c) + "\n"]
                                                + lines[header + 1:]), (header + 1,))
    cells_l = list(cells) + ["x" * 140_000]
    m.add("header_long", "flag", joined(lines[:header] + [d.join(cells_l) + "\n"]
                                        + lines[header + 1:]), (header + 1,))


def _row_cases(m: _Mutator) -> None:
    """A row cut, deleted, repeated, swapped, short or long; garbage; shifted times."""
    lines, data, joined = m.lines, m.data, "".join
    i = m.pick(None)
    m.add("nul_byte", "flag", joined(lines[:i]) + lines[i][:3] + "\x00" + lines[i][3:]
          + joined(lines[i + 1:]), (i + 1,))
    cut = len(joined(lines[:i])) + len(lines[i]) // 2
    m.add("truncated", "flag", joined(lines)[:cut], (i + 1,))
    m.add("row_deleted", "flag", joined(lines[:i] + lines[i + 1:]), (i, i + 1))
    m.add("row_duplicated", "flag", joined(lines[:i + 1] + [lines[i]] + lines[i + 1:]),
          (i + 1, i + 2))
    m.add("rows_swapped", "flag", joined(lines[:i] + [lines[i + 1], lines[i]]
                                         + lines[i + 2:]), (i + 1, i + 2))
    d = _delimiter(lines[i])
    m.add("row_short", "flag", joined(lines[:i] + [lines[i].rstrip("\r\n").rsplit(d, 1)[0]
                                                   + "\n"] + lines[i + 1:]), (i + 1,))
    m.add("row_extra_cell", "flag", joined(lines[:i] + [lines[i].rstrip("\r\n") + d + "7"
                                                        + "\n"] + lines[i + 1:]), (i + 1,))
    m.add("garbage_line", "flag", joined(lines[:i] + ["%&/(garbage)=?\n"] + lines[i:]),
          (i + 1,))
    m.add("only_header", "flag", joined(lines[:data[0]]))
    tc = m.base.time_col
    if tc is None:
        return
    shifted = list(lines)
    for k in data:
        v = _number(_cell(lines[k], tc))
        if v is not None:
            shifted[k] = _set_cell(lines[k], tc, _format_like(_cell(lines[k], tc), v + 1e15))
    m.add("time_offset_1e15", "refuse", joined(shifted))
    last = data[-1]
    v = _number(_cell(lines[last], tc))
    m.add("last_time_1e9", "flag", m.with_cell(last, tc, _format_like(_cell(lines[last], tc),
                                                                      v + 1e9)), (last + 1,))
