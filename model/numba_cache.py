"""numba's cache, kept honest: a compiled function is cached against its own file only, but
the formulas it calls live in other files. :func:`discard_stale_cache` keeps a digest of all
of them beside the cache and empties it when any changed (used by every compiled kernel)."""

from __future__ import annotations

import hashlib
from pathlib import Path

__all__ = ["discard_stale_cache"]


def discard_stale_cache(compiled: tuple, sources: tuple[Path, ...], name: str) -> bool:
    """Numba re-validates a cached function against its own file only; the formulas it calls
    live in other files. Keep a digest of all ``sources`` beside the cache (in a file named
    after ``name``) and empty the cache index of every function of ``compiled`` when it
    differs. True when the compiled code must be built (again)."""
    try:
        cache_dir = Path(compiled[0]._cache._cache_path)  # numba's cache locator
    except AttributeError:  # pragma: no cover - caching off or numba internals moved
        return True
    digest = hashlib.sha256(b"".join(p.read_bytes() for p in sources)).hexdigest()
    stamp = cache_dir / f"{name}.sources"
    try:
        if stamp.is_file() and stamp.read_text() == digest:
            return False
        for fn in compiled:
            fn._cache.flush()
        cache_dir.mkdir(parents=True, exist_ok=True)
        stamp.write_text(digest)
    except OSError:  # pragma: no cover - a read-only cache: numba falls back or recompiles
        pass
    return True
