"""HDF5 logs (DeepLabCut's .h5, SLEAP's analysis .h5): opened with h5py from their bytes.

The file is read once, as a bounded regular file (:func:`trebuchet.core.user_files.read_user_file`:
no FIFO, no device, at most :data:`.limits.MAX_HDF5_BYTES`), and h5py opens those bytes:
what is checked is what is read. h5py reads numbers and strings and never unpickles
anything; a corrupt file's errors inside :func:`open_hdf5` become one-line refusals.
"""

from __future__ import annotations

import contextlib
import io
from collections.abc import Iterator
from pathlib import Path

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.core.user_files import read_user_file
from trebuchet.ingest.readers.limits import MAX_HDF5_BYTES, MAX_TEXT_BYTES

HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: What h5py (and numpy on its arrays) raise for a file that is not the HDF5 it claims to be.
H5_ERRORS = (OSError, ValueError, KeyError, TypeError, IndexError, RuntimeError,
             AttributeError, LookupError)


def log_bytes(source: str | Path | bytes) -> bytes:
    """The bytes of a log file (``source`` itself when given as bytes): a regular file of at
    most :data:`.limits.MAX_TEXT_BYTES`, or :data:`.limits.MAX_HDF5_BYTES` for HDF5."""
    if isinstance(source, bytes):
        return source
    return read_user_file(source, "log", MAX_TEXT_BYTES, {HDF5_SIGNATURE: MAX_HDF5_BYTES})


def is_hdf5(source: str | Path | bytes) -> bool:
    """Whether the file (or bytes) starts with the HDF5 signature; False for anything that
    cannot be read as a regular file."""
    if isinstance(source, bytes):
        return source.startswith(HDF5_SIGNATURE)
    try:
        return log_bytes(source).startswith(HDF5_SIGNATURE)
    except TrebuchetInputError:
        return False


def _h5py():
    try:
        import h5py
    except ImportError:
        raise TrebuchetInputError(
            "reading an HDF5 file needs the package h5py (pip install h5py)"
        ) from None
    return h5py


@contextlib.contextmanager
def open_hdf5(source: str | Path | bytes) -> Iterator:
    """The h5py file of ``source`` (a path or the file's bytes), read only; h5py's errors
    inside the block become a :class:`TrebuchetInputError` (without the file's name)."""
    h5py = _h5py()
    data = log_bytes(source)
    try:
        f = h5py.File(io.BytesIO(data), "r")
    except H5_ERRORS as exc:
        raise TrebuchetInputError(f"is not a text (CSV) file, and starts like an HDF5 file "
                                  f"that cannot be opened as one ({type(exc).__name__}: "
                                  f"{str(exc)[:200]})") from None
    try:
        yield f
    except TrebuchetInputError:
        raise
    except H5_ERRORS as exc:
        raise TrebuchetInputError(f"a corrupt HDF5 file ({type(exc).__name__}: "
                                  f"{str(exc)[:200]})") from None
    finally:
        f.close()
