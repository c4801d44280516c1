"""Every load column of a table, compiled: :func:`trebuchet.model.forces.row_loads` on each row.

numpy spends ~1 µs of overhead on each of the ~300 array operations the ~40 load columns take;
on a shot's 1500 rows that was most of :func:`~trebuchet.model.simulate.simulate`'s time.
Here numba compiles the force formulas of :mod:`trebuchet.model.forces` and
:mod:`trebuchet.model.kinematics` themselves (registered by
:mod:`trebuchet.model.shot_kernel`) (their ``*_xy`` functions and
:func:`~trebuchet.model.forces.row_loads`, unchanged) into one loop over the rows that writes a
block of float64 columns, so no formula is written twice.

As for :mod:`trebuchet.model.shot_kernel`, the compiled code is cached on disk and discarded
when any of the files it is built from changes.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numba
import numpy as np

from trebuchet.model import forces as fo
from trebuchet.model.numba_cache import discard_stale_cache
from trebuchet.model.scene import Scene
from trebuchet.model.shot_kernel import FORMULA_MODULES, jit_engine

__all__ = ["load_block"]

_N_COLUMNS = len(fo.ROW_COLUMNS)


@numba.njit(cache=True, error_model="numpy")
def _load_rows(phase, th, th_d, th_dd, ps, ps_d, ps_dd, ph, ph_d, ph_dd, e, g, H, projected,
               rest, out):  # noqa: ANN001, ANN202 - numba
    """Row ``i`` of every input into column ``i`` of ``out`` (``len(ROW_COLUMNS)`` × n)."""
    for i in range(phase.shape[0]):
        row = fo.row_loads(phase[i], th[i], th_d[i], th_dd[i], ps[i], ps_d[i], ps_dd[i], ph[i],
                           ph_d[i], ph_dd[i], e, g, H, projected, rest)
        for j in range(_N_COLUMNS):
            out[j, i] = row[j]


_SOURCES = tuple(Path(m.__file__) for m in FORMULA_MODULES) + (Path(__file__),)
_cold = discard_stale_cache((_load_rows,), _SOURCES, "trebuchet_loads_kernel")


def load_block(given: dict[str, np.ndarray], scene: Scene, projected: bool,
               rest: tuple[float, float, float]) -> np.ndarray:
    """:func:`~trebuchet.model.forces.row_loads` on every row of the columns ``given``
    (``phase`` and the nine angle columns of :data:`~trebuchet.model.forces.ANGLE_COLUMNS`),
    as a C-ordered block of shape ``(len(ROW_COLUMNS), n)``: one row per column."""
    global _cold
    if _cold:  # the first call of a fresh installation compiles (~5 s): say so
        _cold = False
        print("trebuchet: compiling the load formulas (once per installation, about 5 s)...",
              file=sys.stderr, flush=True)
    phase = np.ascontiguousarray(given["phase"], dtype=np.int64)
    angles = [np.ascontiguousarray(given[c], dtype=np.float64)
              for cols in fo.ANGLE_COLUMNS for c in cols]
    out = np.empty((_N_COLUMNS, phase.size))
    _load_rows(phase, *angles, jit_engine(scene.engine), float(scene.g),
               float(scene.start.H), bool(projected), tuple(float(r) for r in rest), out)
    return out
