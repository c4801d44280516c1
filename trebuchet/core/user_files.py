"""Reading a file the user names (a log, a scene, a calibration): a regular file, bounded.

A path may name a FIFO (reading it waits for a writer that never comes), a device
(``/dev/zero`` and ``/dev/urandom`` never end), a folder, or a file far larger than what it
claims to be (a 5 GB sparse file). :func:`read_user_file` opens without blocking, refuses
anything but a regular file and reads at most the bound its caller gives (what such a file
can mean), in one line naming what is wrong; the caller puts the file's name in front.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Mapping
from pathlib import Path

from trebuchet.core.errors import TrebuchetInputError

__all__ = ["read_user_file", "size_text"]

_KINDS = ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"),
          (stat.S_ISDIR, "a folder"))


def size_text(n: int) -> str:
    """``n`` bytes in words: ``"64 MiB"``, ``"5 GiB"``, ``"812 bytes"``."""
    for shift, unit in ((30, "GiB"), (20, "MiB"), (10, "KiB")):
        if n >= 1 << shift:
            return f"{n / (1 << shift):.3g} {unit}"
    return f"{n} bytes"


def read_user_file(path: str | Path, what: str, limit: int,
                   larger: Mapping[bytes, int] | None = None) -> bytes:
    """The bytes of the regular file ``path``, at most ``limit`` of them (``larger``: a
    higher limit for files starting with one of its byte strings, e.g. HDF5's signature).

    :class:`TrebuchetInputError` (without the file's name) for a missing file, one that is
    no regular file (FIFO, device, socket, folder), one that cannot be read, and one larger
    than its limit. ``what`` names the file's role in the message ("log", "scene file").
    """
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0) | getattr(
        os, "O_BINARY", 0)
    try:
        fd = os.open(os.fspath(path), flags)
    except FileNotFoundError:
        raise TrebuchetInputError("no such file") from None
    except IsADirectoryError:
        raise TrebuchetInputError(f"is a folder, not a {what}") from None
    except OSError as exc:
        raise TrebuchetInputError(f"cannot be read ({exc.strerror or exc})") from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            kind = next((text for test, text in _KINDS if test(mode)), "no regular file")
            raise TrebuchetInputError(f"is {kind}, not a {what}: a {what} is read from a "
                                      "regular file")
        size = os.fstat(fd).st_size
        head = _read(fd, 16)
        bound = next((n for sig, n in (larger or {}).items() if head.startswith(sig)), limit)
        if size > bound:
            raise TrebuchetInputError(f"is {size_text(size)}, more than the {size_text(bound)}"
                                      f" a {what} can mean")
        chunks, total = [head], len(head)
        while True:
            chunk = _read(fd, min(1 << 20, bound + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > bound:
                raise TrebuchetInputError(f"holds more than the {size_text(bound)} a {what} "
                                          "can mean")
        return b"".join(chunks)
    finally:
        os.close(fd)


def _read(fd: int, n: int) -> bytes:
    try:
        return os.read(fd, n)
    except BlockingIOError:  # a regular file never blocks; anything else is refused above
        return b""
    except OSError as exc:
        raise TrebuchetInputError(f"cannot be read ({exc.strerror or exc})") from None
