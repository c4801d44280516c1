"""The FMU in a host no one here wrote for Python: a small C program that loads it with dlopen
(fmu/host/fmi2_host.c), compiled here. Its results equal the in-process simulator."""

from __future__ import annotations

import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from trebuchet.fmu.c_host import compile_host, run_host
from trebuchet.fmu.crosscheck import reference
from trebuchet.fmu.interface import OUTPUT_NAMES

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")
REL = 1e-8


@pytest.fixture(scope="module")
def host(tmp_path_factory) -> Path:
    return compile_host(tmp_path_factory.mktemp("host") / "fmi2_host")


def _assert_equal(table: dict[str, np.ndarray], ref: pd.DataFrame) -> None:
    np.testing.assert_array_equal(table["phase"], ref["phase"].to_numpy())
    for name in OUTPUT_NAMES[1:]:
        want = ref[name].to_numpy(dtype=float)
        err = np.max(np.abs(table[name] - want))
        assert err <= REL * np.max(np.abs(want)), f"{name} off by {err:g}"


@pytest.mark.parametrize("command_time", [None, 0.85])
def test_c_host_runs_the_fmu_as_the_simulator(host, fmu_path, tmp_path, command_time):
    run = run_host(host, fmu_path, tmp_path, stop=1.5, step=1e-3, command_time=command_time)
    assert run.returncode == 0 and run.status <= 1, run.message
    assert run.table["time"][-1] == pytest.approx(1.5) and len(run.table["time"]) == 1501
    ref = reference(run.table["time"], command_time=command_time, t_stop=1.5)
    _assert_equal(run.table, ref)
    if command_time is not None:
        assert run.table["time"][np.argmax(run.table["phase"] == 3)] == pytest.approx(0.851)


def test_c_host_gets_an_error_naming_the_bad_parameter(host, fmu_path, tmp_path):
    run = run_host(host, fmu_path, tmp_path, values={"engine.M": -1.0})
    assert run.returncode == 1 and run.status == 3  # fmi2Error
    assert run.message.startswith("FMU parameters: [engine] M: = -1: must be a positive mass")


def test_the_library_needs_no_python(fmu_path, tmp_path):
    if shutil.which("readelf") is None:
        pytest.skip("needs readelf")
    with zipfile.ZipFile(fmu_path) as z:
        z.extract("binaries/linux64/Trebuchet.so", tmp_path)
    lib = tmp_path / "binaries" / "linux64" / "Trebuchet.so"
    dynamic = subprocess.run(["readelf", "-d", "--dyn-syms", str(lib)], capture_output=True,
                             text=True, check=True).stdout
    needed = [line for line in dynamic.splitlines() if "(NEEDED)" in line]
    assert needed and not any("python" in line.lower() for line in needed), needed
    assert "_Py" not in dynamic


def test_sources_compile_elsewhere_into_the_same_fmu(host, fmu_path, tmp_path):
    """An importer compiles ``sources/`` with its own compiler command (here plain ``cc``
    without the build's flags) and gets the same results."""
    with zipfile.ZipFile(fmu_path) as z:
        z.extractall(tmp_path / "unzipped")
    sources = sorted(str(p) for p in (tmp_path / "unzipped" / "sources").glob("*.c"))
    rebuilt = tmp_path / "Trebuchet.so"
    subprocess.run(["cc", "-shared", "-fPIC", "-O1", *sources, "-o", str(rebuilt), "-lm"],
                   check=True, capture_output=True)
    repacked = tmp_path / "Rebuilt.fmu"
    with zipfile.ZipFile(fmu_path) as zin, zipfile.ZipFile(repacked, "w") as zout:
        for item in zin.infolist():
            data = (rebuilt.read_bytes() if item.filename == "binaries/linux64/Trebuchet.so"
                    else zin.read(item))
            zout.writestr(item, data)
    run = run_host(host, repacked, tmp_path / "run", stop=1.5, step=1e-3)
    assert run.returncode == 0, run.message
    _assert_equal(run.table, reference(run.table["time"], t_stop=1.5))
