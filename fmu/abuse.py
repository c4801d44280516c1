"""Run the FMU abuse host (``fmu/host/fmu_abuse.c``) on a corpus and count what went wrong.

:func:`build_abuse` writes the FMU's C sources, compiles its FMI 2.0 and FMI 3.0 libraries and
the host, with AddressSanitizer and UndefinedBehaviorSanitizer (``sanitize=True``, the bench)
or plainly (the tests' quick sample); :func:`run_abuse` runs a corpus
(:mod:`trebuchet.fmu.abuse_corpus`) through them, each case in a child process with a time
limit, and returns an :class:`AbuseRun`: calls made, crashes, hangs, sanitizer reports, values
returned non-finite with OK, calls that went on where FMI requires a refusal, and errors
returned without a logged message, in total and by family.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import zipfile
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from trebuchet.fmu.build import CFLAGS, fmi_headers
from trebuchet.fmu.csources import C_SOURCES, GLUE_DIR, write_sources

__all__ = ["ABUSE_SOURCE", "AbuseBuild", "CaseResult", "AbuseRun", "build_abuse", "run_abuse",
           "SANITIZE_FLAGS"]

ABUSE_SOURCE = Path(__file__).with_name("host") / "fmu_abuse.c"
#: Flags of the sanitizer build: every report ends the case (no recovery), frames kept.
SANITIZE_FLAGS = ("-fsanitize=address,undefined", "-fno-sanitize-recover=all",
                  "-fno-omit-frame-pointer", "-g", "-O1")
#: Sanitizer options of the host's run: leaks reported, reports to the case's stderr.
SANITIZER_ENV = {"ASAN_OPTIONS": "detect_leaks=1:abort_on_error=0:allocator_may_return_null=1"
                                 ":handle_abort=1:symbolize=1",
                 "UBSAN_OPTIONS": "print_stacktrace=1:halt_on_error=1"}
_FIELDS = ("calls", "nan_ok", "after_error", "silent_error")


@dataclass(frozen=True)
class AbuseBuild:
    """The compiled host and the FMU's libraries, and the FMU's instantiation token."""

    host: Path
    lib2: Path
    lib3: Path
    token: str
    sanitized: bool


@dataclass(frozen=True)
class CaseResult:
    """One case: ``result`` ok, crash, hang or sanitizer; the counts of :data:`_FIELDS`; the
    last call made and the first line of a report (for a case that was not ok)."""

    name: str
    result: str
    calls: int
    nan_ok: int
    after_error: int
    silent_error: int
    ms: float
    last: str = ""
    detail: str = ""
    log: tuple[str, ...] = ()

    @property
    def family(self) -> str:
        """The case's family: its name up to the first ``-`` (``state-12`` -> ``state``)."""
        return self.name.split("-")[0]


@dataclass(frozen=True)
class AbuseRun:
    """Every case of a run, and the seconds it took."""

    cases: tuple[CaseResult, ...]
    seconds: float

    def count(self, what: str, cases: Iterable[CaseResult] | None = None) -> int:
        """Cases with result ``what`` (crash, hang, sanitizer, ok), or the sum of a count of
        :data:`_FIELDS` (calls, nan_ok, after_error, silent_error)."""
        cases = self.cases if cases is None else list(cases)
        if what in _FIELDS:
            return sum(getattr(c, what) for c in cases)
        return sum(1 for c in cases if c.result == what)

    def failures(self) -> list[CaseResult]:
        """Cases that crashed, hung, made a sanitizer report, or counted a wrong result."""
        return [c for c in self.cases if c.result != "ok" or c.nan_ok or c.after_error
                or c.silent_error]


def _compile_all(commands: list[list[str]]) -> None:
    """Run the compiler commands side by side; raise with the first one's errors."""
    procs = [subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for cmd in commands]
    for cmd, proc in zip(commands, procs, strict=True):
        _, err = proc.communicate()
        if proc.returncode != 0:
            raise RuntimeError(f"{cmd[0]} failed:\n{err}")


def _sources(folder: Path, fmu: Path | None, glue: Path | None) -> tuple[Path, str]:
    """The FMU's C sources in ``folder/sources`` (from ``fmu``'s ``sources/`` or written
    anew; the FMI layer missing from an FMU and ``glue``'s files copied in) and the token."""
    src = folder / "sources"
    if fmu is None:
        write_sources(src)
    else:
        with zipfile.ZipFile(fmu) as z:
            for name in z.namelist():
                if name.startswith("sources/") and not name.endswith("/"):
                    src.mkdir(parents=True, exist_ok=True)
                    (src / Path(name).name).write_bytes(z.read(name))
        for name in ("fmi2.c", "fmi3.c"):
            if not (src / name).exists():
                shutil.copy2(GLUE_DIR / name, src / name)
    for path in glue.iterdir() if glue is not None else ():
        (src / path.name).write_bytes(path.read_bytes())
    token = re.search(r'#define TREB_GUID "([^"]+)"', (src / "treb_variables.h").read_text())
    return src, token[1]


def build_abuse(folder: Path, sanitize: bool = True, fmu: Path | None = None,
                glue: Path | None = None, sanitize_formulas: bool = True) -> AbuseBuild:
    """Compile the FMU's FMI 2.0 and 3.0 libraries and the abuse host into ``folder`` (gcc).

    The sources are ``fmu``'s (an FMU built by :func:`~trebuchet.fmu.build.build_fmu`: no
    second code generation) or written anew; ``glue`` is another folder of the hand-written
    C, to measure an older version. The generated formulas are compiled once for both, with
    the sanitizers unless ``sanitize_formulas`` is False (straight-line arithmetic on fixed
    arrays; instrumenting them is most of the compile's time)."""
    folder.mkdir(parents=True, exist_ok=True)
    src, token = _sources(folder, fmu, glue)
    include = fmi_headers(2)[0].parent
    common = [*CFLAGS, "-fPIC", "-I", str(src), "-I", str(include)]
    flags = [*common, *(SANITIZE_FLAGS if sanitize else ())]
    formulas = folder / "treb_formulas.o"
    _compile_all([["gcc", *(flags if sanitize_formulas else common), "-c",
                   str(src / "treb_formulas.c"), "-o", str(formulas)]])
    units = ([p.name for p in sorted(glue.glob("treb_*.c"))] if glue is not None
             else [name for name in C_SOURCES if name != "treb_formulas.c"])
    glue_files = [str(src / name) for name in units]
    libs = [folder / f"Trebuchet{fmi}.so" for fmi in (2, 3)]
    host = folder / "fmu_abuse"
    _compile_all([*(["gcc", *flags, "-shared", str(formulas), *glue_files,
                     str(src / f"fmi{fmi}.c"), "-o", str(lib), "-lm"]
                    for fmi, lib in zip((2, 3), libs, strict=True)),
                  ["gcc", *flags, str(ABUSE_SOURCE), "-o", str(host), "-ldl", "-lm"]])
    return AbuseBuild(host, libs[0], libs[1], token, sanitize)


_CASE = re.compile(r"^CASE (?P<name>\S+) result=(?P<result>\w+) calls=(?P<calls>\d+) "
                   r"nan_ok=(?P<nan_ok>\d+) after_error=(?P<after_error>\d+) "
                   r"silent_error=(?P<silent_error>\d+) ms=(?P<ms>[\d.]+)"
                   r'(?: last=(?P<last>\S*) detail="(?P<detail>.*)")?$')


def run_abuse(build: AbuseBuild, corpus: Path, timeout: float = 10.0,
              log: bool = False) -> AbuseRun:
    """Run every case of ``corpus`` in the host; a case running longer than ``timeout`` s is
    a hang. ``log``: keep every message the FMU logged, as "STATUS text" (status 0 OK to
    4 Fatal), in each case's ``log``."""
    import time

    env = {**os.environ, **(SANITIZER_ENV if build.sanitized else {})}
    if log:
        env["ABUSE_VERBOSE"] = "1"
    t0 = time.perf_counter()
    proc = subprocess.run([str(build.host), str(build.lib2), str(build.lib3), build.token,
                           str(corpus), str(max(1, round(timeout)))], capture_output=True,
                          text=True, env=env)
    seconds = time.perf_counter() - t0
    if proc.returncode != 0 or "TOTAL" not in proc.stdout:
        raise RuntimeError(f"the abuse host failed ({proc.returncode}): {proc.stderr[-2000:]}")
    cases, messages = [], []
    for line in proc.stdout.splitlines():
        if line.startswith("  LOG "):
            messages.append(line[6:])
            continue
        m = _CASE.match(line)
        if m:
            cases.append(CaseResult(m["name"], m["result"], int(m["calls"]), int(m["nan_ok"]),
                                    int(m["after_error"]), int(m["silent_error"]),
                                    float(m["ms"]), m["last"] or "", m["detail"] or "",
                                    tuple(messages)))
            messages = []
    return AbuseRun(tuple(cases), seconds)
