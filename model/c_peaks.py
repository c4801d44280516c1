"""The figures of many designs over their continuous shots, in the generated C, one call for all.

:func:`design_peaks` hands the numbers of any number of scenes to the C engine
(:mod:`trebuchet.model.c_engine`) in one call (``fmu/c/treb_peaks.c``): for each it integrates
the shot and runs the peak search of :mod:`trebuchet.model.summary_kernel` on the C's own
steps (its settings passed from there: every step sampled, every local best near the best
located on the dense output), with the loads of the generated row formulas; it also returns
the events, the projectile's state and energy at release and the heat of the bearings'
friction by then. No Python per step, per row or per design inside the call: the sweep's and
the optimiser's way to a design's figures (:func:`trebuchet.model.shot_summary.shot_figures`
turns a row of it into :class:`~trebuchet.model.shot_summary.ShotFigures`).

The energies at rest (the zero of the energy columns) are the C's generated
``treb_rest_energies`` (from ``forces.energies_xy``, as ``forces.rest_energies``), so that
no design pays numpy's cost for three numbers.
"""

from __future__ import annotations

import ctypes
from collections.abc import Sequence

import numpy as np

from trebuchet.model import c_engine
from trebuchet.model.scene import Scene
from trebuchet.model.summary_kernel import (
    CANDIDATE_SHARE,
    EXTREMA,
    GOLDEN_STEPS,
    PARABOLA_STEPS,
    SAMPLES_PER_STEP,
)

__all__ = ["DESIGN_NAMES", "design_peaks", "REFUSED"]

#: The numbers of a design, in the C's order (treb_peaks.h, TREB_DESIGN_*): each of
#: summary_kernel's :data:`~trebuchet.model.summary_kernel.EXTREMA` (-inf where no sample
#: lies), the time of each (s; NaN there), lift-off and release (s; NaN: none), the
#: projectile's ``t, x, y, vx, vy`` at release (s, m, m/s), its energy over rest at release
#: (J; 0 in a dry fire), the friction's heat by the release (J; 0 without friction) and the
#: end of phase III (s).
DESIGN_NAMES = (*EXTREMA, *(f"t:{name}" for name in EXTREMA), "t_lift", "t_release",
                "release_t", "release_x", "release_y", "release_vx", "release_vy",
                "E_m_release", "loss_release", "t_end")
#: The status of a design the C refuses (the caller words the refusal).
REFUSED = -1

_SEARCH = np.array([SAMPLES_PER_STEP, GOLDEN_STEPS, PARABOLA_STEPS, CANDIDATE_SHARE], float)
_N = len(DESIGN_NAMES)


def _library() -> ctypes.CDLL:
    lib = c_engine.library()
    if not hasattr(lib, "_designs_declared"):
        p, d, i = ctypes.c_void_p, ctypes.c_double, ctypes.c_int
        fn = lib.treb_engine_designs
        fn.restype, fn.argtypes = i, [ctypes.c_long, p, p, p, p, d, p, p, p]
        names = lib.treb_engine_design_names
        names.restype, names.argtypes = ctypes.c_char_p, []
        if tuple(names().decode().split()) != DESIGN_NAMES:
            raise c_engine.EngineUnavailable("the C engine's design figures differ from the "
                                             "model's")
        lib._designs_declared = True
    return lib


def design_peaks(scenes: Sequence[Scene], rtol: float, after: Sequence[float],
                 integrate_after: Sequence[float], clear_window: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The :data:`DESIGN_NAMES` of each scene's shot, one row a scene, and its status (0, or
    :data:`REFUSED` where the C refuses the shot).

    Parameters
    ----------
    scenes : sequence of Scene
    rtol : float
        Integrator tolerance (atol = rtol/100), as ``simulate``'s.
    after : sequence of float
        s past each release over which the extrema are taken (a dry fire: its whole shot).
    integrate_after : sequence of float
        s of phase III each shot is integrated for (a dry fire: its whole shot).
    clear_window : float
        s past the release over which the counterweight's lowest point is taken.

    Raises EngineUnavailable without the C, MemoryError where it runs out of memory.
    """
    lib = _library()
    n = len(scenes)
    numbers = [c_engine.scene_numbers(sc, rtol, a, rest=False)
               for sc, a in zip(scenes, integrate_after, strict=True)]
    q = np.array([v[0] for v in numbers], dtype=float)
    flags = np.array([v[1] for v in numbers], dtype=np.intc)
    par = np.array([v[2] for v in numbers], dtype=float)
    after = np.array(after, dtype=float)
    out = np.empty((n, _N))
    status = np.zeros(n, dtype=np.intc)
    if lib.treb_engine_designs(n, q.ctypes.data, flags.ctypes.data, par.ctypes.data,
                               after.ctypes.data, float(clear_window), _SEARCH.ctypes.data,
                               out.ctypes.data, status.ctypes.data) == -2:
        raise MemoryError("the C engine ran out of memory")
    return out, status
