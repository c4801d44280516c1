"""trebuchet: internal forces of the swinging-counterweight trebuchet.

After E. Horsdal, "The swinging counterweight trebuchet: on internal forces".
The public API (docs/interface.md)::

    import trebuchet as tb
    scene = tb.Scene.from_toml("data_samples/horsdal_large.toml")
    run = tb.simulate(scene)              # DataFrame of every force, torque, power, energy
    loads = tb.forces(angles, scene)      # the same formulas on any angles
    log = tb.read_log("shot.csv")         # t, theta, psi, phi in rad
    est = tb.smooth(log)                  # derivatives with *_sd
    measured = tb.reconstruct("shot.csv", scene)

Units are SI throughout: m, kg, s, rad, N, N m, W, J.
"""

from __future__ import annotations

from typing import Any

from trebuchet.errors import ModelValidityWarning, TrebuchetDataWarning, TrebuchetInputError
from trebuchet.model.loads import loads as forces
from trebuchet.model.scene import Engine, Release, Scene, Start
from trebuchet.model.simulate import simulate
from trebuchet.version import __version__

__all__ = [
    "Scene", "Engine", "Start", "Release", "simulate", "forces", "read_log", "smooth",
    "reconstruct", "compare", "TrebuchetInputError", "TrebuchetDataWarning", "ModelValidityWarning",
    "__version__", "design",
]

_LAZY = {
    "read_log": ("trebuchet.ingest.logs.read_log", "read_log"),
    "smooth": ("trebuchet.ingest.smoothing.smooth", "smooth"),
    "reconstruct": ("trebuchet.ingest.reconstruct", "reconstruct"),
    "compare": ("trebuchet.ingest.compare", "compare"),
    "design": ("trebuchet.model.design", "design"),
}


def __dir__() -> list[str]:
    """Everything the package offers, the lazily loaded ingest functions included."""
    return sorted(set(globals()) | set(_LAZY))


def __getattr__(name: str) -> Any:
    """The ingest path loads on first use (filterpy takes about a second to import)."""
    if name in _LAZY:
        import importlib

        module, attr = _LAZY[name]
        return getattr(importlib.import_module(module), attr)
    raise AttributeError(f"module 'trebuchet' has no attribute {name!r}")
