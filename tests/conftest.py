"""Shared fixtures: the paper's engine and a small backyard engine."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import pytest

from trebuchet.model.scene import Scene

ROOT = Path(__file__).resolve().parents[1]
HORSDAL = ROOT / "data_samples" / "horsdal_large.toml"

#: The backyard engine of data_samples/backyard.toml (written by data_samples/make_samples.py).
BACKYARD = tomllib.loads((ROOT / "data_samples" / "backyard.toml").read_text(encoding="utf-8"))


@pytest.fixture(scope="session")
def horsdal() -> Scene:
    return Scene.from_toml(HORSDAL)


@pytest.fixture(scope="session")
def backyard() -> Scene:
    return Scene.from_dict(BACKYARD, source="backyard")


def deg(x: float) -> float:
    return math.degrees(x)


@pytest.fixture(scope="session")
def fmu_path(tmp_path_factory) -> Path:
    """``trebuchet fmu build`` (FMI 2.0) once for the whole session: the FMU tests in fmpy,
    libcosim and the C host share it (a build compiles the generated C, about 20 s)."""
    import subprocess
    import sys

    path = tmp_path_factory.mktemp("fmu") / "Trebuchet.fmu"
    proc = subprocess.run([sys.executable, "-m", "trebuchet.cli", "fmu", "build", "-o",
                           str(path)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert path.is_file()
    return path


@pytest.fixture(scope="session")
def exports(tmp_path_factory):
    """Every tracker-export fixture of tests/exports, written once for the session:
    ``(folder, {file name: truth})``."""
    from tests.exports import write_all

    folder = tmp_path_factory.mktemp("exports")
    return folder, write_all(folder)

