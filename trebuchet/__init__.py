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
    fitted = tb.identify("shot.csv", scene)   # the engine fitted to its shot

Units are SI throughout: m, kg, s, rad, N, N m, W, J.

Each name loads on first use: ``import trebuchet`` itself imports neither numpy nor scipy, so
that the ``trebuchet`` command (``trebuchet --help``, a usage error) answers at once; the model
(numpy, pandas, numba) loads with the first ``tb.Scene`` or ``tb.simulate``, the ingest path
(filterpy, scipy) with the first ``tb.read_log``, ``tb.smooth``, ``tb.reconstruct`` or
``tb.compare`` or ``tb.identify``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from trebuchet.core import interrupts

if interrupts.started_as_command():  # the ``trebuchet`` command: Ctrl-C quiet from here on
    interrupts.catch_interrupts()

from trebuchet.core.errors import ModelValidityWarning, TrebuchetDataWarning, TrebuchetInputError
from trebuchet.core.version import __version__

if TYPE_CHECKING:
    from trebuchet.ingest.compare import compare
    from trebuchet.ingest.identification.identify import identify
    from trebuchet.ingest.logs.read_log import read_log
    from trebuchet.ingest.reconstruct import reconstruct
    from trebuchet.ingest.smoothing.smooth import smooth
    from trebuchet.model.loads import loads as forces
    from trebuchet.model.scene import Engine, Release, Scene, Start
    from trebuchet.model.simulate import simulate

__all__ = [
    "Scene", "Engine", "Start", "Release", "simulate", "forces", "read_log", "smooth",
    "reconstruct", "compare", "identify", "design", "TrebuchetInputError",
    "TrebuchetDataWarning", "ModelValidityWarning", "__version__",
]

_LAZY = {
    "Scene": ("trebuchet.model.scene", "Scene"),
    "Engine": ("trebuchet.model.scene", "Engine"),
    "Start": ("trebuchet.model.scene", "Start"),
    "Release": ("trebuchet.model.scene", "Release"),
    "simulate": ("trebuchet.model.simulate", "simulate"),
    "forces": ("trebuchet.model.loads", "loads"),
    "read_log": ("trebuchet.ingest.logs.read_log", "read_log"),
    "smooth": ("trebuchet.ingest.smoothing.smooth", "smooth"),
    "reconstruct": ("trebuchet.ingest.reconstruct", "reconstruct"),
    "compare": ("trebuchet.ingest.compare", "compare"),
    "design": ("trebuchet.model.design", "design"),
    "identify": ("trebuchet.ingest.identification.identify", "identify"),
}


def __dir__() -> list[str]:
    """Everything the package offers, the lazily loaded ingest functions included."""
    return sorted(set(globals()) | set(_LAZY))


def __getattr__(name: str) -> Any:
    """Each public name loads on first use (module doc), and is kept for the next."""
    if name in _LAZY:
        import importlib

        module, attr = _LAZY[name]
        value = getattr(importlib.import_module(module), attr)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'trebuchet' has no attribute {name!r}")
