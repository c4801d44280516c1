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
