"""A sweep's journal: its rows appended to a side file as they finish, for ``--resume``.

The sweep's table is written whole at the end (atomically); until then every finished row is
appended to the journal, flushed at once, so that a killed run (``kill -9``, a power cut of the
process, Ctrl-C) keeps what it finished. The file::

    # trebuchet sweep journal 1 <sha256 of the scene, grid, outputs and options>
    design,engine.M,status,error,range,...
    0,12000.0,ok,,391.24...,...

Floats are written with ``repr`` (they read back to the same bits); a last line cut short by
the kill is dropped on reading. :func:`open_journal` refuses a journal of another sweep (its
digest differs) and an existing journal unless asked to resume it.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from trebuchet.core.errors import TrebuchetInputError

__all__ = ["Journal", "open_journal", "sweep_digest", "journal_path"]

_MAGIC = "# trebuchet sweep journal 1 "


def journal_path(output: str | Path) -> Path:
    """The journal beside a sweep's output: ``OUTPUT.partial``."""
    output = Path(output)
    return output.with_name(output.name + ".partial")


def sweep_digest(scene: Mapping[str, Any], grid: Mapping[str, Sequence[Any]],
                 outputs: Sequence[str], options: Any, budget: Any = None) -> str:
    """A digest of what makes a sweep's rows: the base scene's dict, the grid, the outputs and
    the simulation options (the budget is left out: it decides nothing of a row that ran)."""
    del budget
    text = json.dumps({"scene": scene, "grid": {k: [repr(v) for v in vals]
                                                for k, vals in grid.items()},
                       "outputs": list(outputs), "options": asdict(options)},
                      sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return repr(value)
    return str(value)


def _parse(column: str, text: str, words: frozenset[str]) -> Any:
    """A cell back to its value: ``design`` an int, ``status``/``error`` and word-valued grid
    cells text, every other cell a float."""
    if column == "design":
        return int(text)
    if column in ("status", "error") or column in words:
        return text
    try:
        return float(text)
    except ValueError:
        return text  # a word in a word-valued grid column (engine.counterweight)


class Journal:
    """An open journal: :meth:`append` rows, :meth:`close`, :meth:`discard` once the table is
    written."""

    def __init__(self, path: Path, columns: Sequence[str], fh: io.TextIOBase) -> None:
        self.path, self.columns, self._fh = path, list(columns), fh
        self._writer = csv.writer(fh, lineterminator="\n")

    def append(self, rows: Sequence[Mapping[str, Any]]) -> None:
        """Write rows and flush them to the file system at once."""
        for row in rows:
            self._writer.writerow([_cell(row.get(c, math.nan)) for c in self.columns])
        self._fh.flush()

    def close(self) -> None:
        self._fh.close()

    def discard(self) -> None:
        """Close and remove the journal (its rows are in the table now)."""
        self.close()
        self.path.unlink(missing_ok=True)


def open_journal(path: str | Path, digest: str, columns: Sequence[str], resume: bool,
                 words: frozenset[str] = frozenset()) -> tuple[Journal, list[dict[str, Any]]]:
    """Open the journal at ``path`` for appending, with the rows it already holds (when
    ``resume``). A fresh journal is created (``resume`` without one starts afresh); an existing
    one without ``resume``, or one of another sweep, is refused in one line."""
    path = Path(path)
    if path.exists() and not path.is_file():
        raise TrebuchetInputError(f"{path}: the sweep's journal would go here, but this is not "
                                  "a regular file")
    if path.is_file() and not resume:
        raise TrebuchetInputError(f"{path}: an unfinished sweep's rows are here; give --resume "
                                  "to continue it, or delete the file to start again")
    rows: list[dict[str, Any]] = []
    if path.is_file():
        rows = _read(path, digest, columns, words)
        fh = open(path, "r+", encoding="utf-8", newline="")  # noqa: SIM115 - kept open
        fh.seek(0, os.SEEK_END)
        return Journal(path, columns, fh), rows
    try:
        fh = open(path, "x", encoding="utf-8", newline="")  # noqa: SIM115 - kept open
    except OSError as exc:
        raise TrebuchetInputError(f"{path}: cannot write the sweep's journal here: "
                                  f"{exc.strerror or exc}") from None
    fh.write(_MAGIC + digest + "\n")
    csv.writer(fh, lineterminator="\n").writerow(columns)
    fh.flush()
    return Journal(path, columns, fh), rows


def _read(path: Path, digest: str, columns: Sequence[str],
          words: frozenset[str]) -> list[dict[str, Any]]:
    """The complete rows of a journal; its cut-short last line (a killed write) is removed
    from the file."""
    try:
        raw = path.read_bytes()
        text = raw.decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise TrebuchetInputError(f"{path}: cannot read the sweep's journal: {exc}") from None
    head, _, body = text.partition("\n")
    if not head.startswith(_MAGIC):
        raise TrebuchetInputError(f"{path}: not a journal of trebuchet sweep; delete it or "
                                  "give another output")
    if head[len(_MAGIC):].strip() != digest:
        raise TrebuchetInputError(f"{path}: the rows of another sweep (another scene, grid, "
                                  "outputs or accuracy); give that sweep's arguments with "
                                  "--resume, or delete the file")
    complete = body[:body.rfind("\n") + 1] if "\n" in body else ""
    if len(complete) != len(body):  # the last line was cut by the kill: drop it
        with open(path, "r+b") as fh:
            fh.truncate(len(raw) - len(body.encode()) + len(complete.encode()))
    lines = list(csv.reader(io.StringIO(complete)))
    if not lines or lines[0] != list(columns):
        raise TrebuchetInputError(f"{path}: its columns are not this sweep's; delete it")
    out = []
    for n, cells in enumerate(lines[1:], start=3):
        if len(cells) != len(columns):
            raise TrebuchetInputError(f"{path}: line {n} has {len(cells)} cells, not "
                                      f"{len(columns)}; delete the file to start again")
        try:
            out.append({c: _parse(c, v, words) for c, v in zip(columns, cells, strict=True)})
        except ValueError:
            raise TrebuchetInputError(f"{path}: line {n}: not a row of this sweep; delete "
                                      "the file to start again") from None
    return out
