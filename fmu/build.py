"""Build ``Trebuchet.fmu``: the native FMU, compiled C, model exchange and co-simulation.

:func:`build_fmu` writes the C sources (:func:`trebuchet.fmu.csources.write_sources`: the
formulas generated from the model's Python, the integrator and FMI glue), compiles them for
linux64 with gcc and, where ``x86_64-w64-mingw32-gcc`` is installed, for win64, and zips
``modelDescription.xml`` (:mod:`trebuchet.fmu.model_description`), the binaries and
``sources/`` (every C file, the FMI headers of the version and ``buildDescription.xml``), so
that any importer can compile it elsewhere. The FMI headers are fmpy's (its ``c-code``
folder), found at build time.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.core.output import atomic_path
from trebuchet.fmu.csources import C_SOURCES, write_sources
from trebuchet.fmu.model_description import MODEL_NAME, model_description

__all__ = ["build_fmu", "fmi_headers", "compile_binary", "MODEL_NAME", "CFLAGS"]

CFLAGS = ("-O2", "-std=c99", "-Wall", "-Wextra", "-Wno-unused-parameter")
_HEADERS = {2: ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h"),
            3: ("fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h")}
#: Platform folder (FMI 2, FMI 3), compiler, shared-library suffix and extra flags of each
#: binary built.
PLATFORMS = ((("linux64", "x86_64-linux"), "gcc", ".so", ("-fPIC",)),
             (("win64", "x86_64-windows"), "x86_64-w64-mingw32-gcc", ".dll", ("-static",)))


def fmi_headers(fmi: int) -> list[Path]:
    """The FMI ``fmi`` (2 or 3) headers shipped with fmpy."""
    import fmpy

    folder = Path(fmpy.__file__).with_name("c-code")
    return [folder / name for name in _HEADERS[fmi]]


def compile_binary(sources: Path, fmi: int, out: Path, compiler: str = "gcc",
                   extra: tuple[str, ...] = ("-fPIC",)) -> Path:
    """Compile the FMU's shared library from the folder ``sources`` to ``out``."""
    files = [str(sources / name) for name in (*C_SOURCES, f"fmi{fmi}.c")]
    cmd = [compiler, *CFLAGS, *extra, "-shared", "-I", str(sources), *files, "-o", str(out),
           "-lm"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"{compiler} failed:\n{proc.stderr}")
    return out


def _build_description(fmi: int) -> bytes:
    root = ET.Element("fmiBuildDescription", fmiVersion="3.0")
    config = ET.SubElement(root, "BuildConfiguration", modelIdentifier=MODEL_NAME)
    files = ET.SubElement(config, "SourceFileSet", language="C99")
    for name in (*C_SOURCES, f"fmi{fmi}.c"):
        ET.SubElement(files, "SourceFile", name=name)
    ET.SubElement(config, "Library", name="m")
    ET.indent(root, space="  ")
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True)


def build_fmu(target: str | Path, fmi: int = 2) -> Path:
    """Build the FMU of FMI version ``fmi`` (2 or 3) at ``target`` (written whole or not at
    all); returns its path. Needs gcc."""
    if fmi not in (2, 3):
        raise TrebuchetInputError(f"--fmi {fmi}: must be 2 or 3")
    if shutil.which("gcc") is None:
        raise TrebuchetInputError("trebuchet fmu build needs gcc (the C compiler) on PATH")
    target = Path(target)
    with tempfile.TemporaryDirectory(prefix="trebuchet_fmu_") as tmp:
        root = Path(tmp)
        src = root / "sources"
        guid, _ = write_sources(src)
        for header in fmi_headers(fmi):
            shutil.copy2(header, src / header.name)
        for name in ("fmi2.c", "fmi3.c"):
            if name != f"fmi{fmi}.c":
                (src / name).unlink()
        (src / "buildDescription.xml").write_bytes(_build_description(fmi))
        binaries = []
        for platforms, compiler, suffix, extra in PLATFORMS:
            if shutil.which(compiler) is None:
                continue
            out = root / "binaries" / platforms[fmi - 2] / f"{MODEL_NAME}{suffix}"
            out.parent.mkdir(parents=True)
            binaries.append(compile_binary(src, fmi, out, compiler, extra))
        md = model_description(guid, fmi, (*C_SOURCES, f"fmi{fmi}.c"))
        with atomic_path(target) as out, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("modelDescription.xml", md)
            for path in sorted([*binaries, *src.iterdir()]):
                z.write(path, path.relative_to(root).as_posix())
    return target
