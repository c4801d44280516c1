"""The in-process engine's formulas (``treb_rows.c``, ``treb_rows.h``; not in the FMU).

Every column of ``simulate``'s table for each phase, counterweight, friction and dry fire
(:data:`ENGINE_FORMULAS`), the same for the columns of a design's peak search
(:data:`PEAK_ROW_NAMES`), and the height of the counterweight's centre: the model's Python,
as :class:`~trebuchet.fmu.codegen.Formula` entries that :func:`~trebuchet.fmu.codegen.
generate_c` prints to C, as it does the FMU's (:data:`~trebuchet.fmu.codegen.FORMULAS`).
:func:`generate_rows_header` writes their declarations and the index of each row column.
``fmu/engine_build.py`` writes and compiles them. Units are those of the model: m, kg, rad,
rad/s, rad/s², N, N m, W, J.
"""

from __future__ import annotations

import math
from typing import Any

from trebuchet.fmu.codegen import (
    ANGLE_NAMES,
    COUPLES,
    LOST,
    PARAMETER_NAMES,
    REST,
    STATES,
    Build,
    Formula,
    phase_outputs,
)
from trebuchet.model import forces as frc
from trebuchet.model import kinematics as kin

__all__ = ["ENGINE_FORMULAS", "ROW_NAMES", "PEAK_ROW_NAMES", "generate_rows_header"]

#: The rows of the in-process engine: ``simulate``'s columns after ``t`` and ``phase`` (the
#: angles, φ NaN after release; every column of :func:`forces.row_loads`, direct form; the
#: energies lost by friction, J, 0 without), then the height of the counterweight's centre
#: ``y_M`` (m, for the figures of a design; not a column of the table).
ROW_NAMES = (*ANGLE_NAMES, *frc.ROW_COLUMNS, "E_loss_pivot", "E_loss_hinge", "y_M")


def _counterweight_height(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> list[Any]:
    return [kin.counterweight_position_xy(lib.cos(x["th"]), lib.sin(x["th"]), lib.cos(x["ps"]),
                                          lib.sin(x["ps"]), e, H)[1]]


#: The columns of :data:`ROW_NAMES` a design's peak search takes (``fmu/c/treb_peaks.c``,
#: ``model/summary_kernel.py``'s extrema): the loads, the energies and the counterweight's
#: height. Their formulas alone cost about half of a whole row.
PEAK_ROW_NAMES = ("F_S_abs", "F_H_abs", "F_R_abs", "F_R_perp", "torque", "sling_tension",
                  "E_m", "E_M", "E_beam", "E_loss_pivot", "E_loss_hinge", "y_M")


def _rows(phase: int, friction: bool, names: tuple[str, ...] = ROW_NAMES,
          expand: bool = False) -> Build:
    """The columns ``names`` of :data:`ROW_NAMES`; ``expand``: on symbols, the sines and
    cosines of sums of angles expanded (sympy's ``expand_trig``), so that the C takes the
    sine and cosine of each angle once (3 ``sincos`` where 5 were; the same numbers to
    rounding)."""
    outputs = phase_outputs(phase, friction, ROW_NAMES[:-1])
    where = [ROW_NAMES.index(n) for n in names]

    def build(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> list[Any]:
        row = [*outputs(e, g, H, x, lib), *_counterweight_height(e, g, H, x, lib)]
        if expand and lib is not math:
            import sympy as sp

            return [sp.expand_trig(sp.sympify(row[i])) for i in where]
        return [row[i] for i in where]
    return build


def _engine_formulas() -> tuple[Formula, ...]:
    """The in-process engine's formulas (``treb_rows.c``; not in the FMU): every row column of
    each phase, counterweight, friction and dry fire, the same for the columns of the peak
    search (:data:`PEAK_ROW_NAMES`), and the counterweight's height."""
    out: list[Formula] = []
    for fixed in (False, True):
        cw = "fixed" if fixed else "hinged"
        for friction in (False, True):
            tail, extra = ("_friction", (*LOST, *COUPLES)) if friction else ("", ())
            for phase, dry in ((1, False), (2, False), (3, False), (3, True)):
                name = f"{phase}_{cw}{'_dry' if dry else ''}{tail}"
                what = f"phase {phase}{' (dry fire)' if dry else ''}"
                for suffix, names, doc in (
                        ("", ROW_NAMES, "every column of simulate's rows"),
                        ("_peak", PEAK_ROW_NAMES, "the columns of the peak search")):
                    # sines of sums expanded: the peak search's, and every friction row's
                    expand = bool(suffix) or friction
                    out.append(Formula(f"rows{name}{suffix}", f"{what}: {doc} (dynamics + "
                                       "forces.row_loads)", (*STATES[phase], *extra, *REST),
                                       names, _rows(phase, friction, names, expand),
                                       fixed, dry=dry, friction=friction))
    out.append(Formula("counterweight_height", "kinematics.counterweight_position_xy: the "
                       "height of the counterweight's centre (m)", ("th", "ps"), ("y_M",),
                       _counterweight_height))
    return tuple(out)


ENGINE_FORMULAS: tuple[Formula, ...] = _engine_formulas()


def generate_rows_header() -> str:
    """``treb_rows.h``: the in-process engine's formulas (:data:`ENGINE_FORMULAS`) and the
    index of each row column (:data:`ROW_NAMES`)."""
    # the banner names codegen, whose generate_c prints these functions
    lines = ["/* Generated by trebuchet.fmu.codegen from the model's Python: do not edit. */",
             "#ifndef TREB_ROWS_H", "#define TREB_ROWS_H", "",
             f"#define TREB_N_ROWS {len(ROW_NAMES)}",
             f'#define TREB_ROW_NAMES "{" ".join(ROW_NAMES)}"',
             f'#define TREB_PARAMETER_NAMES "{" ".join(PARAMETER_NAMES)}"']
    lines += [f"#define TREB_ROW_{n} {i}" for i, n in enumerate(ROW_NAMES)]
    lines += [f"#define TREB_N_PEAK_ROWS {len(PEAK_ROW_NAMES)}"]
    lines += [f"#define TREB_PEAK_ROW_{n} {i}" for i, n in enumerate(PEAK_ROW_NAMES)]
    lines += [f"void treb_{f.name}(const double *q, const double *x, double *out);"
              for f in ENGINE_FORMULAS]
    lines += ["", "#endif", ""]
    return "\n".join(lines)
