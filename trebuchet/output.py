"""Writing outputs whole or not at all.

A command that fails midway must leave no partial file or report behind: every
output is written under a temporary name beside its target and renamed into
place only when complete. A target that cannot be written (no such folder, no
permission, a folder where a file is asked for or the other way round) is a
user's mistake, refused with a :class:`~trebuchet.errors.TrebuchetInputError`
that names it; a folder is replaced only where it holds a previous report (or
nothing), never a user's other files. Outputs get the permissions of the
user's umask, as a plain ``open`` would give them.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pandas as pd

from trebuchet.errors import TrebuchetInputError

__all__ = ["atomic_path", "atomic_dir", "write_csv", "check_target", "OUTPUT_MARKER"]

#: An empty file in every folder this package writes: such a folder may be replaced by the
#: next run. (A folder with an ``index.html`` is a report of an earlier version: also ours.)
OUTPUT_MARKER = ".trebuchet-output"


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _refuse(target: Path, exc: OSError) -> TrebuchetInputError:
    return TrebuchetInputError(f"{target}: cannot write here: {exc.strerror or exc}")


def _parent(target: Path) -> None:
    """Create the folder that will hold ``target``, or refuse with the reason."""
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise _refuse(target, exc) from None


def check_target(target: str | Path, folder: bool = False) -> Path:
    """Refuse, before any work, a target that cannot take the output: a folder where a file
    is to be written, a file where a folder is, or a folder that holds a user's other files
    (``folder=True``: a report folder, which the next run replaces whole)."""
    target = Path(target)
    if not folder and target.is_dir():
        raise TrebuchetInputError(f"{target}: is a folder; give a file name to write")
    if folder and target.exists() and not target.is_dir():
        raise TrebuchetInputError(f"{target}: is a file; give a folder name for the report")
    if folder and not target.is_dir() and target.suffix.lower() in (".html", ".htm"):
        raise TrebuchetInputError(f"{target}: a report is a folder (index.html, the figures "
                                  "and CSV files), not one page; give a folder name such as "
                                  f"{target.with_suffix('')}")
    if folder and target.is_dir() and any(target.iterdir()) and not (
            (target / OUTPUT_MARKER).is_file() or (target / "index.html").is_file()):
        raise TrebuchetInputError(f"{target}: the folder holds other files and no earlier "
                                  "output of trebuchet; give a new or empty folder")
    _probe(target)
    return target


def _probe(target: Path) -> None:
    """Refuse a target whose nearest existing folder takes no new file (no permission, a
    read-only or virtual file system): a temporary file is made there and removed."""
    folder = target.parent.absolute()
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if not folder.is_dir():
        raise TrebuchetInputError(f"{target}: {folder} is a file, not a folder")
    try:
        fd, probe = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".probe", dir=folder)
    except OSError as exc:
        raise _refuse(target, exc) from None
    os.close(fd)
    os.unlink(probe)


@contextlib.contextmanager
def atomic_path(target: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``target``; on success rename it to ``target``."""
    target = check_target(target)
    _parent(target)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    except OSError as exc:
        raise _refuse(target, exc) from None
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        try:
            os.chmod(tmp_path, 0o666 & ~_umask())
            os.replace(tmp_path, target)
        except OSError as exc:
            raise _refuse(target, exc) from None
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


@contextlib.contextmanager
def atomic_dir(target: str | Path) -> Iterator[Path]:
    """Yield a temporary directory beside ``target``; on success it replaces ``target``, which
    must not exist, be empty, or hold an earlier output of this package
    (:func:`check_target`)."""
    target = check_target(target, folder=True)
    _parent(target)
    try:
        tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp",
                                    dir=target.parent))
    except OSError as exc:
        raise _refuse(target, exc) from None
    try:
        yield tmp
        try:
            (tmp / OUTPUT_MARKER).touch()
            os.chmod(tmp, 0o777 & ~_umask())
            if target.exists():
                old = target.with_name(f".{target.name}.old")
                shutil.rmtree(old, ignore_errors=True)
                os.replace(target, old)
                os.replace(tmp, target)
                shutil.rmtree(old, ignore_errors=True)
            else:
                os.replace(tmp, target)
        except OSError as exc:
            raise _refuse(target, exc) from None
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


def write_csv(frame: pd.DataFrame, target: str | Path) -> None:
    """Write a DataFrame as CSV (no index), atomically."""
    with atomic_path(target) as tmp:
        frame.to_csv(tmp, index=False)
