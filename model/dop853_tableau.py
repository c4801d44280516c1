"""The DOP853 tableau: scipy's own coefficient table, read without importing scipy.integrate.

The integrators of :mod:`trebuchet.model.integrator` and :mod:`trebuchet.model.shot_kernel`
take the stages, weights, error estimators and dense-output coefficients of Dormand and
Prince's 8(5,3) pair from ``scipy/integrate/_ivp/dop853_coefficients.py`` (Hairer, Nørsett
and Wanner, "Solving Ordinary Differential Equations I", 2nd ed., Sec. II.10), so that they
take the same steps as :class:`scipy.integrate.DOP853`. That file needs numpy only, but
importing it as ``scipy.integrate._ivp.dop853_coefficients`` runs ``scipy.integrate``'s
``__init__`` first: about 0.25 s of imports (scipy.special, scipy.sparse, scipy.optimize,
...) that the simulator never uses. :data:`DOP853` is that same file executed on its own
(or the module itself, where scipy.integrate is imported already); the numbers are scipy's,
nothing is retyped.

``DOP853.N_STAGES`` (12), ``N_STAGES_EXTENDED`` (16), ``INTERPOLATOR_POWER`` (7), and the
arrays ``A``, ``B``, ``C``, ``E3``, ``E5``, ``D`` (dimensionless).
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

__all__ = ["DOP853"]

_SCIPY_NAME = "scipy.integrate._ivp.dop853_coefficients"


def _tableau() -> ModuleType:
    """scipy's ``dop853_coefficients`` module, executed from its file without its package."""
    if _SCIPY_NAME in sys.modules:
        return sys.modules[_SCIPY_NAME]
    spec = importlib.util.find_spec("scipy")  # finds the package; does not import it
    if spec is None or not spec.submodule_search_locations:
        raise ModuleNotFoundError("scipy is not installed", name="scipy")
    path = (Path(next(iter(spec.submodule_search_locations))) / "integrate" / "_ivp"
            / "dop853_coefficients.py")
    file_spec = importlib.util.spec_from_file_location("trebuchet_dop853_coefficients", path)
    if file_spec is None or file_spec.loader is None:  # pragma: no cover - a broken scipy
        raise ModuleNotFoundError(f"{path}: scipy's DOP853 table is missing", name="scipy")
    module = importlib.util.module_from_spec(file_spec)
    file_spec.loader.exec_module(module)
    return module


DOP853 = _tableau()
