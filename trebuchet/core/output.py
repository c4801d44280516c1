"""Writing outputs whole or not at all, and never over anything that is not ours.

A command that fails midway must leave no partial file or report behind: every
output is written under a hidden temporary name beside its target and renamed
into place only when complete. What an output may replace (docs/outputs.md):

- a file output: nothing, or a regular file the user may write (not a folder, a
  FIFO, a device or a socket; not a read-only file; not one of the command's own
  inputs, however it is spelt: through a symbolic or hard link or ``../``). A
  symbolic link is followed: the file it points to is replaced, the link stays;
- a folder output (a report): nothing, an empty folder, or a folder this package
  wrote, which holds the marker file :data:`OUTPUT_MARKER` listing every file
  written there, and nothing else. A folder with anything more (a user's
  ``thesis.tex`` put in beside the report) or an input of the command inside is
  refused. The new folder is swapped in atomically (Linux ``renameat2``) and the
  old one removed.

A target that cannot be written (no such folder, no permission, a full disk) is
a user's mistake, refused with a :class:`~trebuchet.core.errors.TrebuchetInputError`
that names it. Each temporary carries a signed name
(``.NAME.<token><signature>.trebuchet-tmp``) and a lock while its run is alive;
the next write into the same folder removes the temporaries that a killed run
left there: only those whose name is signed, that belong to this user and whose
lock is free. Outputs get the permissions of the user's umask, as a plain
``open`` would give them.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import hashlib
import json
import os
import re
import secrets
import shutil
import stat
import sys
import time
from collections.abc import Iterable, Iterator
from pathlib import Path

import pandas as pd

from trebuchet.core.errors import TrebuchetInputError

try:
    import fcntl
except ImportError:  # not POSIX: no locks, so no temporary is ever provably stale
    fcntl = None  # type: ignore[assignment]

__all__ = ["atomic_path", "atomic_dir", "write_csv", "check_target", "OUTPUT_MARKER",
           "remove_stale_temporaries"]

#: The file in every folder this package writes: JSON ``{"written_by": "trebuchet",
#: "files": [...]}`` with the relative path of every file written there. Such a folder, holding
#: those files and nothing else, may be replaced by the next run. (An empty marker, from
#: versions before the list, stands for a report's flat ``index.html``, PNG and CSV files.)
OUTPUT_MARKER = ".trebuchet-output"

_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"), (stat.S_ISLNK, "a symbolic link"))
_TEMP = re.compile(r"\.(?P<token>[0-9a-f]{8})(?P<sig>[0-9a-f]{8})\.trebuchet-(?:tmp|probe)\Z")
_WRITE_ERRORS = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS, errno.EIO)
_STALE_WITHOUT_LOCK = 60.0  # s: a temporary folder not yet holding its lock file is stale later


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _refuse(target: Path, exc: OSError) -> TrebuchetInputError:
    return TrebuchetInputError(f"{target}: cannot write here: {exc.strerror or exc}")


def _kind(mode: int) -> str:
    """What a file of this mode is, for a message: "a FIFO (named pipe)", "a folder", ..."""
    return next((name for test, name in _KINDS if test(mode)), "a file")


def _real(shown: Path) -> Path:
    """``shown`` absolute, with every symbolic link followed (the link's target is written)."""
    try:
        return Path(os.path.realpath(shown, strict=False))
    except (OSError, RuntimeError) as exc:
        raise TrebuchetInputError(f"{shown}: cannot follow its links: {exc}") from None


def _stat(path: Path, shown: Path, follow: bool = True) -> os.stat_result | None:
    try:
        return os.stat(path, follow_symlinks=follow)
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise _refuse(shown, exc) from None


# --------------------------------------------------------------------------- temporaries


def _signature(token: str) -> str:
    return hashlib.sha256(f"trebuchet-output:{token}".encode()).hexdigest()[:8]


def _temp_name(name: str, kind: str = "tmp") -> str:
    token = secrets.token_hex(4)
    return f".{name[:100]}.{token}{_signature(token)}.trebuchet-{kind}"


def _is_our_temp(name: str) -> bool:
    match = _TEMP.search(name)
    return (name.startswith(".") and match is not None
            and match["sig"] == _signature(match["token"]))


def _lock(fd: int) -> bool:
    """Take the lock on ``fd`` without waiting; False if a live run holds it."""
    if fcntl is None:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return False
    return True


def _new_temp_file(folder: Path, name: str, shown: Path, kind: str = "tmp") -> tuple[int, Path]:
    """A new empty file (mode 0600) with a signed name in ``folder``, locked while the
    returned descriptor is open."""
    for _ in range(100):
        path = folder / _temp_name(name, kind)
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0)
                         | getattr(os, "O_CLOEXEC", 0), 0o600)
        except FileExistsError:
            continue
        except OSError as exc:
            raise _refuse(shown, exc) from None
        _lock(fd)
        return fd, path
    raise TrebuchetInputError(f"{shown}: cannot make a temporary file in {folder}")


def _new_temp_dir(folder: Path, name: str, shown: Path) -> tuple[int, Path]:
    """A new folder (mode 0700) with a signed name in ``folder`` and its marker file inside,
    locked while the returned descriptor is open."""
    for _ in range(100):
        path = folder / _temp_name(name)
        try:
            path.mkdir(mode=0o700)
        except FileExistsError:
            continue
        except OSError as exc:
            raise _refuse(shown, exc) from None
        try:
            fd = os.open(path / OUTPUT_MARKER, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o666)
        except OSError as exc:
            shutil.rmtree(path, ignore_errors=True)
            raise _refuse(shown, exc) from None
        _lock(fd)
        return fd, path
    raise TrebuchetInputError(f"{shown}: cannot make a temporary folder in {folder}")


def remove_stale_temporaries(folder: str | Path) -> list[Path]:
    """Remove from ``folder`` the temporaries that killed runs of this package left there, and
    nothing else: an entry is removed only if its name carries the package's signature, it
    belongs to this user, it is a regular file or a folder, and no live run holds its lock (a
    folder's lock is on its marker; a folder that has none yet is left for a minute). Returns
    the paths removed."""
    removed: list[Path] = []
    if fcntl is None:
        return removed
    try:
        with os.scandir(folder) as found:
            entries = [e for e in found if _is_our_temp(e.name)]
    except OSError:
        return removed
    for entry in entries:
        path = Path(entry.path)
        try:
            st = entry.stat(follow_symlinks=False)
        except OSError:
            continue
        if st.st_uid != os.geteuid() or not (stat.S_ISREG(st.st_mode) or
                                             stat.S_ISDIR(st.st_mode)):
            continue
        lock = path if stat.S_ISREG(st.st_mode) else path / OUTPUT_MARKER
        try:
            fd = os.open(lock, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
        except FileNotFoundError:
            if stat.S_ISDIR(st.st_mode) and time.time() - st.st_mtime > _STALE_WITHOUT_LOCK:
                shutil.rmtree(path, ignore_errors=True)
                removed.append(path)
            continue
        except OSError:
            continue
        try:
            if _lock(fd) and os.fstat(fd).st_ino == os.stat(lock, follow_symlinks=False).st_ino:
                if stat.S_ISDIR(st.st_mode):
                    shutil.rmtree(path, ignore_errors=True)
                else:
                    path.unlink(missing_ok=True)
                removed.append(path)
        except OSError:
            pass
        finally:
            os.close(fd)
    return removed


# --------------------------------------------------------------------------- what is ours


def _owned_predicate(folder: Path):
    """From ``folder``'s marker: a test of a relative path (``a/b.csv``; a folder ends in
    ``/``) for "written by this package", or None where the folder holds no valid marker."""
    marker = folder / OUTPUT_MARKER
    try:
        st = os.stat(marker, follow_symlinks=False)
        if not stat.S_ISREG(st.st_mode) or st.st_size > 1 << 20:
            return None
        text = marker.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return None
    if not text.strip():  # the empty marker of earlier versions: a flat report
        return lambda rel: "/" not in rel and (rel == "index.html"
                                               or rel.endswith((".png", ".csv")))
    try:
        data = json.loads(text)
        files = {str(f) for f in data["files"]} if data.get("written_by") == "trebuchet" \
            else None
    except (ValueError, TypeError, KeyError, AttributeError):
        return None
    if files is None:
        return None
    folders = {p.as_posix() + "/" for f in files for p in Path(f).parents if p != Path(".")}
    return lambda rel: rel in files or rel in folders


def _foreign_entries(folder: Path) -> list[str] | None:
    """The entries of ``folder`` (relative paths) that this package did not write; None where
    the folder holds no valid marker (then everything in it is foreign)."""
    owned = _owned_predicate(folder)
    if owned is None:
        return None
    foreign = []
    for root, dirs, files in os.walk(folder):
        rel_root = Path(root).relative_to(folder)
        for name in sorted(dirs + files):
            rel = (rel_root / name).as_posix()
            st = os.stat(Path(root) / name, follow_symlinks=False)
            if rel == OUTPUT_MARKER:
                continue
            if stat.S_ISDIR(st.st_mode):
                ok = owned(rel + "/")
            else:  # a link, FIFO, ... is never ours, even under one of our names
                ok = stat.S_ISREG(st.st_mode) and owned(rel)
            if not ok:
                foreign.append(rel)
        dirs[:] = [d for d in dirs if (rel_root / d).as_posix() not in foreign]
    return foreign


def _check_folder_is_ours(real: Path, shown: Path) -> None:
    """Refuse a non-empty folder that is not wholly an earlier output of this package."""
    try:
        if not any(real.iterdir()):
            return
        foreign = _foreign_entries(real)
    except OSError as exc:
        raise _refuse(shown, exc) from None
    if foreign is None:
        raise TrebuchetInputError(f"{shown}: the folder holds other files and no earlier "
                                  "output of trebuchet; give a new or empty folder")
    if foreign:
        more = f" and {len(foreign) - 1} more" if len(foreign) > 1 else ""
        raise TrebuchetInputError(f"{shown}: the folder holds other files than the earlier "
                                  f"output of trebuchet ({foreign[0]}{more}), which writing "
                                  "there would delete; move them or give a new or empty folder")


def _check_inputs(shown: Path, real: Path, st: os.stat_result | None, folder: bool,
                  inputs: Iterable[str | Path | None]) -> None:
    """Refuse an output that is one of the command's inputs, or a folder holding one."""
    for given in inputs:
        if given is None or str(given) == "":
            continue
        try:
            ist = os.stat(given)
        except OSError:
            continue  # the command reports an input that cannot be read
        if folder:
            inside = _real(Path(given))
            if inside == real or real in inside.parents:
                raise TrebuchetInputError(f"{shown}: holds {given}, an input of this command, "
                                          "and writing the output replaces the folder whole; "
                                          "give another folder")
        elif st is not None and (ist.st_dev, ist.st_ino) == (st.st_dev, st.st_ino):
            raise TrebuchetInputError(f"{shown}: is {given}, an input of this command; give "
                                      "another file name for the output")


def check_target(target: str | Path, folder: bool = False, *,
                 inputs: Iterable[str | Path | None] = ()) -> Path:
    """Refuse, before any work, a target that cannot take the output (module doc): a folder,
    FIFO, device or read-only file where a file is to be written; a file where a folder is; a
    folder that holds a user's other files (``folder=True``: a report folder, which the next
    run replaces whole); one of ``inputs`` (the files the command reads). Removes the stale
    temporaries of killed runs beside it. Returns the path that will be written (absolute,
    symbolic links followed)."""
    shown = Path(target)
    real = _real(shown)
    if real.parent == real:
        raise TrebuchetInputError(f"{shown}: is the root folder; give a file or folder name")
    remove_stale_temporaries(real.parent)
    st = _stat(real, shown)
    if folder and st is not None and not stat.S_ISDIR(st.st_mode):
        what = "a file" if stat.S_ISREG(st.st_mode) else _kind(st.st_mode)
        raise TrebuchetInputError(f"{shown}: is {what}; give a folder name for the report")
    if folder and st is None and shown.suffix.lower() in (".html", ".htm"):
        raise TrebuchetInputError(f"{shown}: a report is a folder (index.html, the figures "
                                  "and CSV files), not one page; give a folder name such as "
                                  f"{shown.with_suffix('')}")
    if not folder and st is not None:
        if stat.S_ISDIR(st.st_mode):
            raise TrebuchetInputError(f"{shown}: is a folder; give a file name to write")
        if not stat.S_ISREG(st.st_mode):
            raise TrebuchetInputError(f"{shown}: is {_kind(st.st_mode)}, not a regular file; "
                                      "trebuchet writes only regular files: give a file name")
        if not st.st_mode & 0o222 or not os.access(real, os.W_OK):
            raise TrebuchetInputError(f"{shown}: is read-only; make it writable or give "
                                      "another file name")
    _check_inputs(shown, real, st, folder, inputs)
    if folder and st is not None:
        _check_folder_is_ours(real, shown)
    _probe(real, shown)
    return real


def _probe(real: Path, shown: Path) -> None:
    """Refuse a target whose nearest existing folder takes no new file (no permission, a
    read-only or virtual file system, a full disk): a temporary file is made there and
    removed."""
    folder = real.parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    if not folder.is_dir():
        raise TrebuchetInputError(f"{shown}: {folder} is a file, not a folder")
    fd, probe = _new_temp_file(folder, real.name, shown, kind="probe")
    os.close(fd)
    probe.unlink(missing_ok=True)


def _parent(real: Path, shown: Path) -> None:
    """Create the folder that will hold ``real``, or refuse with the reason."""
    try:
        real.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise _refuse(shown, exc) from None


def _write_error(shown: Path, tmp: Path, exc: OSError) -> BaseException:
    """An error met while writing the temporary, naming the user's target (a full disk says
    "No space left on device" and nothing of which file); other errors pass unchanged."""
    name = str(exc.filename or "")
    if exc.errno in _WRITE_ERRORS or (name and name.startswith(str(tmp))):
        return TrebuchetInputError(f"{shown}: cannot write: {exc.strerror or exc}")
    return exc


# --------------------------------------------------------------------------- writers


@contextlib.contextmanager
def atomic_path(target: str | Path, *, inputs: Iterable[str | Path | None] = ()
                ) -> Iterator[Path]:
    """Yield a temporary path beside ``target``; on success rename it to ``target``
    (:func:`check_target` first, with the command's ``inputs``)."""
    shown = Path(target)
    real = check_target(shown, inputs=inputs)
    _parent(real, shown)
    fd, tmp = _new_temp_file(real.parent, real.name, shown)
    try:
        try:
            yield tmp
        except OSError as exc:
            raise _write_error(shown, tmp, exc) from None
        check_target(shown, inputs=inputs)  # what may have appeared there meanwhile
        try:
            os.chmod(tmp, 0o666 & ~_umask())
            os.replace(tmp, real)
        except OSError as exc:
            raise _refuse(shown, exc) from None
    finally:
        os.close(fd)
        if os.path.lexists(tmp):
            tmp.unlink()


def _exchange(a: Path, b: Path) -> bool:
    """Swap ``a`` and ``b`` in one step (Linux ``renameat2(RENAME_EXCHANGE)``); False where
    the system or file system cannot."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        renameat2 = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return False
    at_fdcwd, rename_exchange = -100, 2
    renameat2.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                          ctypes.c_uint]
    if renameat2(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def _manifest(tmp: Path) -> str:
    files = sorted(p.relative_to(tmp).as_posix() for p in tmp.rglob("*")
                   if p.is_file() and not p.is_symlink() and p.name != OUTPUT_MARKER)
    return json.dumps({"written_by": "trebuchet", "files": files}, indent=1) + "\n"


def _put_in_place(tmp: Path, real: Path, shown: Path) -> None:
    """Move the finished folder ``tmp`` to ``real``; an earlier output there (checked again
    now: it may have changed during the work) is swapped out into ``tmp``."""
    if _stat(real, shown, follow=False) is None:
        os.rename(tmp, real)
        return
    check_target(shown, folder=True)
    if _exchange(tmp, real):
        return
    old = real.parent / _temp_name(real.name)
    os.rename(real, old)
    os.rename(tmp, real)
    os.rename(old, tmp)


@contextlib.contextmanager
def atomic_dir(target: str | Path, *, inputs: Iterable[str | Path | None] = ()
               ) -> Iterator[Path]:
    """Yield a temporary directory beside ``target``; on success it replaces ``target``, which
    must not exist, be empty, or hold an earlier output of this package and nothing else
    (:func:`check_target`, with the command's ``inputs``). The marker written into it lists
    every file."""
    shown = Path(target)
    real = check_target(shown, folder=True, inputs=inputs)
    _parent(real, shown)
    fd, tmp = _new_temp_dir(real.parent, real.name, shown)
    try:
        try:
            yield tmp
        except OSError as exc:
            raise _write_error(shown, tmp, exc) from None
        try:
            (tmp / OUTPUT_MARKER).write_text(_manifest(tmp), encoding="utf-8")
            os.chmod(tmp / OUTPUT_MARKER, 0o666 & ~_umask())
            os.chmod(tmp, 0o777 & ~_umask())
            _put_in_place(tmp, real, shown)
        except OSError as exc:
            raise _refuse(shown, exc) from None
    finally:
        os.close(fd)
        if os.path.lexists(tmp):
            shutil.rmtree(tmp, ignore_errors=True)


def write_csv(frame: pd.DataFrame, target: str | Path, *,
              inputs: Iterable[str | Path | None] = ()) -> None:
    """Write a DataFrame as CSV (no index), atomically (:func:`atomic_path`)."""
    with atomic_path(target, inputs=inputs) as tmp:
        frame.to_csv(tmp, index=False)
