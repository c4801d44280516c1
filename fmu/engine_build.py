"""Build the in-process engine: the FMU's C, generated from the model's formulas, as a library.

The simulator runs its shots in the same C as the FMU (:mod:`trebuchet.model.c_engine` loads
it with ctypes): :func:`write_engine_sources` writes the FMU's sources
(:func:`trebuchet.fmu.csources.write_sources`: ``treb_formulas.c`` generated from the model's
Python, the DOP853 glue ``treb_shot.c``) and the engine's own, ``treb_rows.c`` (every column of
``simulate``'s table, generated from ``forces.row_loads`` by
:data:`trebuchet.fmu.engine_formulas.ENGINE_FORMULAS`) and ``treb_batch.c`` (the hand-written
loop over output times and the figures of a design on a table's rows) and ``treb_peaks.c`` (a
design's figures over the continuous shot, one call for many designs); :func:`build_engine` compiles
them with gcc into one shared library. ``python -m trebuchet.fmu.engine_build OUT`` does both
(the simulator runs it in a subprocess when its library is missing or stale, as numba
compiles on first use).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from trebuchet.fmu import codegen, engine_formulas
from trebuchet.fmu.build import CFLAGS
from trebuchet.fmu.csources import GLUE_DIR, write_sources

__all__ = ["ENGINE_GLUE", "ENGINE_SOURCES", "ENGINE_CFLAGS", "write_engine_sources", "build_engine",
           "main"]

#: The engine's hand-written files beside the FMU's (``fmu/c/``).
ENGINE_GLUE = ("treb_batch.h", "treb_batch.c", "treb_peaks.h", "treb_peaks.c")
#: The translation units of the engine's library.
ENGINE_SOURCES = ("treb_formulas.c", "treb_rows.c", "treb_shot.c", "treb_batch.c",
                  "treb_peaks.c")
#: The FMU's flags, at -O3 and with sqrt inlined (no errno): the same numbers bit for bit
#: (ISO C99 contracts no multiply-add; nothing is reassociated), ~10 % faster.
ENGINE_CFLAGS = ("-O3", "-fno-math-errno", *(f for f in CFLAGS if f != "-O2"))


def write_engine_sources(folder: Path) -> list[Path]:
    """Write every C source of the engine into ``folder``; returns the files written."""
    _, written = write_sources(folder)
    files = {"treb_rows.c": codegen.generate_c(engine_formulas.ENGINE_FORMULAS, "treb_rows.h"),
             "treb_rows.h": engine_formulas.generate_rows_header()}
    for name, text in files.items():
        (folder / name).write_text(text)
        written.append(folder / name)
    for name in ENGINE_GLUE:
        written.append(Path(shutil.copy2(GLUE_DIR / name, folder / name)))
    return written


def build_engine(out: Path, compiler: str = "gcc") -> Path:
    """Generate the engine's sources and compile them into the shared library ``out``
    (replaced whole: it is written beside and renamed). Raises RuntimeError with the
    compiler's message if the compiler is missing or fails."""
    if shutil.which(compiler) is None:
        raise RuntimeError(f"no C compiler: {compiler} is not on PATH")
    out = Path(out)
    with tempfile.TemporaryDirectory(prefix="trebuchet_engine_") as tmp:
        src = Path(tmp)
        write_engine_sources(src)
        lib = src / out.name
        cmd = [compiler, *ENGINE_CFLAGS, "-fPIC", "-shared", "-I", str(src),
               *(str(src / name) for name in ENGINE_SOURCES), "-o", str(lib), "-lm"]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"{compiler} failed:\n{proc.stderr}")
        out.parent.mkdir(parents=True, exist_ok=True)
        staged = out.with_name(out.name + ".part")
        shutil.copyfile(lib, staged)
        staged.replace(out)
    return out


def main(argv: list[str] | None = None) -> int:
    """``python -m trebuchet.fmu.engine_build OUT``: build the library ``OUT``; exit 1 with the
    reason on stderr if it cannot be built."""
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print("usage: python -m trebuchet.fmu.engine_build LIBRARY", file=sys.stderr)
        return 2
    try:
        build_engine(Path(args[0]))
    except (RuntimeError, OSError) as exc:
        print(str(exc), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
