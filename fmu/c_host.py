"""The small C host of ``fmu/host/fmi2_host.c``: compile it, and run an FMU in it.

The host loads the FMU's linux64 library with ``dlopen`` in a process that has no Python,
runs a co-simulation at fixed steps and reports its timings (see the C file). The tests
check its results against the in-process simulator; the bench reads its timings.
"""

from __future__ import annotations

import subprocess
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from trebuchet.fmu.build import fmi_headers

__all__ = ["HOST_SOURCE", "HostRun", "compile_host", "run_host"]

HOST_SOURCE = Path(__file__).with_name("host") / "fmi2_host.c"


@dataclass(frozen=True)
class HostRun:
    """One run of the host: its status line's fields, the exit code and the output table
    (``time``, ``phase`` and the outputs by name; None without an output file)."""

    returncode: int
    status: int
    message: str
    run_us: float | None
    step_us: float | None
    table: dict[str, np.ndarray] | None


def compile_host(out: Path) -> Path:
    """Compile the host to the executable ``out`` (gcc, the FMI 2.0 headers of fmpy)."""
    include = fmi_headers(2)[0].parent
    subprocess.run(["gcc", "-O2", "-std=c99", "-Wall", "-Wextra", "-I", str(include),
                    str(HOST_SOURCE), "-o", str(out), "-ldl"], check=True, capture_output=True)
    return out


def _status_fields(line: str) -> dict[str, str]:
    fields: dict[str, str] = {}
    message, _, rest = line.partition(" message=")
    fields["status"] = message.removeprefix("status=")
    text, *numbers = rest.split(" run_us=")
    fields["message"] = text
    if numbers:
        run_us, _, step_us = numbers[0].partition(" step_us=")
        fields["run_us"], fields["step_us"] = run_us, step_us
    return fields


def run_host(host: Path, fmu: Path, workdir: Path, stop: float = 1.5, step: float = 1e-3,
             command_time: float | None = None, repeats: int = 1,
             values: dict[str, float | int] | None = None, table: bool = True) -> HostRun:
    """Unzip ``fmu`` into ``workdir`` and run it in the C host for ``stop`` s at ``step`` s,
    the release command rising at ``command_time`` (s), parameters ``values`` by name."""
    from fmpy import read_model_description

    md = read_model_description(str(fmu))
    by_name = {v.name: v for v in md.modelVariables}
    outputs = [v for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    refs = [v.valueReference for v in outputs]
    if refs != list(range(refs[0], refs[0] + len(refs))):
        raise ValueError("the host reads the Real outputs as one run of value references")
    with zipfile.ZipFile(fmu) as z:
        z.extractall(workdir)
    library = workdir / "binaries" / "linux64" / f"{md.coSimulation.modelIdentifier}.so"
    csv = workdir / "host_out.csv"
    sets = [f"{by_name[k].valueReference}={'i' if by_name[k].type == 'Enumeration' else ''}{v}"
            for k, v in (values or {}).items()]
    args = [str(host), str(library), md.guid, repr(stop), repr(step),
            str(by_name["phase"].valueReference), str(refs[0]), str(len(refs)),
            str(by_name["release_command"].valueReference),
            repr(-1.0 if command_time is None else command_time),
            str(csv) if table else "-", str(repeats), *sets]
    proc = subprocess.run(args, capture_output=True, text=True, timeout=600)
    last = proc.stdout.strip().splitlines()[-1] if proc.stdout.strip() else "status=-1 message="
    fields = _status_fields(last)
    data = None
    if proc.returncode == 0 and table:
        raw = np.loadtxt(csv, delimiter=",", ndmin=2)
        data = {"time": raw[:, 0], "phase": raw[:, 1].astype(int),
                **{v.name: raw[:, 2 + j] for j, v in enumerate(outputs)}}
    return HostRun(proc.returncode, int(fields["status"]), fields["message"],
                   float(fields["run_us"]) if "run_us" in fields else None,
                   float(fields["step_us"]) if "step_us" in fields else None, data)
