"""Shared fixtures: the paper's engine and a small backyard engine."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from trebuchet.model.scene import Scene

ROOT = Path(__file__).resolve().parents[1]
HORSDAL = ROOT / "data_samples" / "horsdal_large.toml"

BACKYARD = {
    "engine": {"L1": 2.0, "L2": 0.5, "L_CM": 0.6, "L3": 0.6, "L4": 1.8, "m_b": 15.0,
               "M": 100.0, "m": 1.0},
    "start": {"theta_deg": -45.0, "psi_deg": -90.0,
              "phi_deg": -180.0},
    "release": {"velocity_angle_deg": 45.0},
    "environment": {"g": 9.81},
}


@pytest.fixture(scope="session")
def horsdal() -> Scene:
    return Scene.from_toml(HORSDAL)


@pytest.fixture(scope="session")
def backyard() -> Scene:
    return Scene.from_dict(BACKYARD, source="backyard")


def deg(x: float) -> float:
    return math.degrees(x)
