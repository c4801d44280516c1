"""C for the native FMU, generated from the simulator's own Python formulas.

No equation of motion, event function or load is typed in C. Each :class:`Formula` below
names the model functions it calls (:mod:`trebuchet.model.dynamics`,
:mod:`~trebuchet.model.phase_events`, :mod:`~trebuchet.model.forces`,
:mod:`~trebuchet.model.kinematics`, :mod:`~trebuchet.model.flight`); :func:`generate_c` runs
them on sympy symbols, eliminates common subexpressions (``sympy.cse``) and prints C99 with
sympy's C printer. The same ``build`` callables run on floats with :mod:`math` in the test
that compares the compiled C with the Python on random states (``tests/test_fmu_codegen.py``).

Functions written on floats with :mod:`math` by name (``row_loads``, the event functions, the
drag flight) are traced through a copy that sees ``math`` bound to sympy (:func:`traced`);
the module itself is not touched.

The in-process engine's formulas (``treb_rows.c``: every column of ``simulate``'s rows) are
tabled in :mod:`trebuchet.fmu.engine_formulas` on the pieces named here; this module holds
the generator and the FMU's formulas (``treb_formulas.c``).

Every generated function has one signature, ``void treb_<name>(const double *q, const
double *x, double *out)``: ``q`` the engine's parameters in the order of
:data:`PARAMETER_NAMES`, ``x`` the inputs of the formula (:attr:`Formula.inputs`), ``out``
its results (:attr:`Formula.outputs`). Units are those of the model: m, kg, kg m², rad,
rad/s, rad/s², s, N, N m, W, J.
"""

from __future__ import annotations

import math
import types
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cache
from types import SimpleNamespace
from typing import Any

import numpy as np

from trebuchet.fmu.c_printer import c_printer
from trebuchet.fmu.interface import OUTPUT_NAMES
from trebuchet.model import dynamics as dyn
from trebuchet.model import flight as flt
from trebuchet.model import forces as frc
from trebuchet.model import kinematics as kin
from trebuchet.model import phase_events as pev
from trebuchet.model.scene import default_moment_of_inertia

__all__ = ["Formula", "FORMULAS", "PARAMETER_NAMES", "ANGLE_NAMES", "LOAD_OUTPUTS",
           "STATES", "REST", "LOST", "COUPLES", "Build", "phase_outputs",
           "generate_c", "generate_header", "engine_namespace", "traced", "sympy_math"]

#: The engine's parameters, in the order of the generated functions' ``q`` array: lengths (m),
#: masses (kg), I (kg m²), the fixed counterweight's offset ψ − θ (rad), g (m/s²), H (m), and
#: the bearings' friction: ``μ r`` at pivot and hinge (m) and the sign's smoothing rate (rad/s).
PARAMETER_NAMES = ("L1", "L2", "L_CM", "L3", "L4", "m_b", "M", "m", "I", "offset", "g", "H",
                   "pivot_friction", "hinge_friction", "friction_rate")
#: Angle outputs of every phase, in order (the sling's are 0 after release).
ANGLE_NAMES = ("theta", "psi", "phi", "theta_d", "psi_d", "phi_d", "theta_dd", "psi_dd",
               "phi_dd")
#: Load outputs (the FMU's outputs after phase and angles), columns of ``row_loads``.
LOAD_OUTPUTS = tuple(n for n in OUTPUT_NAMES if n != "phase" and n not in ANGLE_NAMES)
#: The inputs of each phase's state: the angles (rad) and their rates (rad/s).
STATES = {1: ("th", "ps", "th_d", "ps_d"), 2: ("th", "ps", "ph", "th_d", "ps_d", "ph_d"),
          3: ("th", "ps", "th_d", "ps_d")}
#: The energies at rest (J) that the outputs' energies are counted from.
REST = ("rest_m", "rest_M", "rest_beam")
#: With friction: the lost energies (states, in units of ``dynamics.energy_scale``) and the
#: couples' generalised forces (N m, solved by the C glue with the generated Newton steps).
LOST = ("e_P", "e_H")
COUPLES = ("Q_th", "Q_ps")
#: The pieces of ``dynamics.friction_pieces`` (Newton's steps take the first 14: the couples'
#: factors and the loads' affine pieces; the rates all 25).
PIECES = tuple(f"p{i}" for i in range(25))
_LOADS = PIECES[:14]
_NEWTON = ("n_R", "n_H")
#: The convergence of a Newton step: the magnitudes before it and the step before (N); the
#: margins and the step (N).
_MARGIN_IN = (*_NEWTON, "o_R", "o_H", "s_R", "s_H")
_MARGIN_OUT = ("m_R", "m_H", "d_R", "d_H")
_FIRST_STEPS = (*_NEWTON, "d_R", "d_H", "m_R", "m_H")


@cache
def sympy_math() -> SimpleNamespace:
    """The names of :mod:`math` the model uses, as sympy functions."""
    import sympy as sp

    return SimpleNamespace(sin=sp.sin, cos=sp.cos, tan=sp.tan, tanh=sp.tanh, asin=sp.asin,
                           sqrt=sp.sqrt,
                           pi=sp.pi, nan=sp.nan, hypot=lambda a, b: sp.sqrt(a * a + b * b))


def traced(f: Callable, lib: Any) -> Callable:
    """``f`` itself for ``lib is math``; else a copy of ``f`` whose global ``math`` is ``lib``,
    and whose module's other functions (that it may call by name) are such copies too. The
    module is not changed."""
    if lib is math:
        return f
    names = {**f.__globals__, "math": lib}
    for key, value in f.__globals__.items():
        if isinstance(value, types.FunctionType) and value.__module__ == f.__module__:
            names[key] = types.FunctionType(value.__code__, names, value.__name__,
                                            value.__defaults__, value.__closure__)
    return types.FunctionType(f.__code__, names, f.__name__, f.__defaults__, f.__closure__)


def engine_namespace(q: Sequence[Any], fixed: bool, friction: bool = False) -> SimpleNamespace:
    """An engine-like object (the attributes of :class:`~trebuchet.model.scene.Engine`) from
    the parameter values ``q`` (:data:`PARAMETER_NAMES`); without ``friction`` the bearings'
    are 0, so the formulas are the frictionless ones."""
    v = dict(zip(PARAMETER_NAMES, q, strict=True))
    return SimpleNamespace(L1=v["L1"], L2=v["L2"], L_CM=v["L_CM"], L3=v["L3"], L4=v["L4"],
                           m_b=v["m_b"], M=v["M"], m=v["m"], I=v["I"],
                           counterweight_offset=v["offset"] if fixed else None,
                           fixed_counterweight=fixed,
                           pivot_friction=v["pivot_friction"] if friction else 0.0,
                           hinge_friction=v["hinge_friction"] if friction else 0.0,
                           friction_rate=v["friction_rate"])


#: How closely a generated Jacobian matches the central difference (relative to its peak).
JACOBIAN_TOLERANCE = 1e-6

Build = Callable[[SimpleNamespace, Any, Any, dict[str, Any], Any], Sequence[Any]]


@dataclass(frozen=True)
class Formula:
    """One generated C function: its name, what it is, its inputs ``x`` and outputs ``out``
    (names), and ``build(e, g, H, x, lib)``, the model's Python giving the outputs (``lib``
    :mod:`math` on floats, :func:`sympy_math` on symbols). ``fixed``: the counterweight rigid
    on the beam (None: the formula does not depend on it). ``dry``: no projectile (m = 0).
    ``tolerance``: how closely the compiled C matches ``build`` on floats, relative to each
    output's peak: rounding for the formulas, the central difference's own error for the
    Jacobians (whose ``build`` on floats differentiates numerically)."""

    name: str
    doc: str
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    build: Build
    fixed: bool | None = None
    dry: bool = False
    tolerance: float = 1e-12
    friction: bool = False


def _motion(phase: int, x: dict[str, Any], e: Any, g: Any, H: Any, lib: Any,
            friction: bool) -> tuple:
    """:func:`dynamics.phase_motion` of ``phase`` from its state (with friction: under the
    couples' generalised forces ``Q_th``, ``Q_ps`` of the inputs); φ 0 in III."""
    y = [x[n] for n in STATES[phase]]
    if friction:
        m = list(dyn.motion_under(phase, y, e, g, H, x["Q_th"], x["Q_ps"], lib))
    else:
        m = list(dyn.phase_motion(phase, y, e, g, H, lib))
    if phase == 3:
        m[2] = m[5] = m[8] = 0.0
    return tuple(m)


def phase_outputs(phase: int, friction: bool = False,
                  names: tuple[str, ...] | None = None) -> Build:
    """The FMU's outputs of ``phase`` (φ 0 after release); with ``names``, those columns of
    :data:`~trebuchet.fmu.engine_formulas.ROW_NAMES` (φ NaN after release, as ``simulate``'s
    table)."""
    def build(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> list[Any]:
        th, ps, ph, th_d, ps_d, ph_d, th_dd, ps_dd, ph_dd = _motion(phase, x, e, g, H, lib,
                                                                    friction)[:9]
        row = traced(frc.row_loads, lib)(phase, th, th_d, th_dd, ps, ps_d, ps_dd, ph, ph_d,
                                         ph_dd, e, g, H, False, tuple(x[r] for r in REST))
        cols = dict(zip(frc.ROW_COLUMNS, row, strict=True))
        scale = dyn.energy_scale(e, g)
        cols["E_loss_pivot"] = x["e_P"] * scale if friction else 0.0
        cols["E_loss_hinge"] = x["e_H"] * scale if friction else 0.0
        angles = [th, ps, ph, th_d, ps_d, ph_d, th_dd, ps_dd, ph_dd]
        if names is None:
            return [*angles, *(cols[n] for n in LOAD_OUTPUTS)]
        if phase == 3:  # no sling after release: NaN, as in simulate's table
            angles[2] = angles[5] = angles[8] = lib.nan
        cols.update(zip(ANGLE_NAMES, angles, strict=True))
        return [cols[n] for n in names]
    return build


#: How closely the generated first Newton steps match the Python's: the second step (N) is a
#: difference of magnitudes 1e4 to 1e5 times its size (sympy writes it as a quotient, the
#: Python subtracts), so its rounding is that of the magnitudes, ~1e-16 of 1e6 N.
FIRST_STEPS_TOLERANCE = 1e-9

#: Relative step of the central differences that check the generated Jacobians.
FD_STEP = 1e-5


def _jacobian(phase: int) -> Build:
    """d(outputs)/d(state) of ``phase``, row-major (output by output): sympy's derivative of
    the outputs on symbols; a central difference of the same Python on floats."""
    outputs = phase_outputs(phase)
    states = STATES[phase]

    def build(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> list[Any]:
        if lib is math:
            columns = []
            for n in states:
                h = FD_STEP * max(1.0, abs(x[n]))
                up = outputs(e, g, H, {**x, n: x[n] + h}, lib)
                down = outputs(e, g, H, {**x, n: x[n] - h}, lib)
                columns.append([(a - b) / (2.0 * h) for a, b in zip(up, down, strict=True)])
            return [columns[j][i] for i in range(len(columns[0])) for j in range(len(states))]
        import sympy as sp

        values = [sp.sympify(v) for v in outputs(e, g, H, x, lib)]
        return [sp.nan if v is sp.nan else sp.diff(v, x[n]) for v in values for n in states]
    return build


def _rates(phase: int) -> Build:
    def build(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> tuple:
        y = [x[n] for n in STATES[phase]]
        if phase == 1:
            return dyn.state_rates_phase1(y, e, g, H, lib)
        if phase == 2:
            return dyn.state_rates_phase2(y, e, g, lib)
        return dyn.state_rates_phase3(y, e, g, lib)
    return build


def _state(x: dict[str, Any], phase: int) -> list[Any]:
    """The phase's state from the inputs (zeros where a formula takes none, as the time
    rule)."""
    return [x.get(n, 0.0) for n in STATES[phase]]


def _vacuum_flight(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> list[Any]:
    release = {k: x[f"r_{k}"] for k in ("t", "x", "y", "vx", "vy")}
    t = np.array([x["t"]], dtype=object if lib is not math else float)
    r, v = flt.projectile_in_flight(release, t, g, flt.Flight(), e.m)
    E = frc.projectile_energy((v[0][0], v[1][0]), r[1][0], e, g) - x["rest_m"]
    return [r[0][0], r[1][0], v[0][0], v[1][0], E]


def _drag_rates(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> list[Any]:
    rhs = traced(flt._drag_rhs, lib)(x["k"], g)
    return list(rhs(0.0, [x["x"], x["y"], x["vx"], x["vy"]]))


def _drag_constant(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> list[Any]:
    f = SimpleNamespace(diameter=x["diameter"], drag_coefficient=x["drag_coefficient"],
                        air_density=x["air_density"])
    return [traced(flt.drag_constant, lib)(f, e.m)]


def _flight_energy(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> list[Any]:
    return [frc.projectile_energy((x["vx"], x["vy"]), x["y"], e, g) - x["rest_m"]]


def _rest_energies(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> tuple:
    c_th, s_th = lib.cos(x["th"]), lib.sin(x["th"])
    c_ps, s_ps = lib.cos(x["ps"]), lib.sin(x["ps"])
    return frc.energies_xy(c_th, s_th, 0.0, c_ps, s_ps, 0.0, (0.0, 0.0), x["y_m"], e, g, H)


def _projectile(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> list[Any]:
    c_th, s_th = lib.cos(x["th"]), lib.sin(x["th"])
    c_ph, s_ph = lib.cos(x["ph"]), lib.sin(x["ph"])
    r = kin.projectile_position_xy(c_th, s_th, c_ph, s_ph, e, H)
    v = kin.projectile_velocity_xy(c_th, s_th, x["th_d"], c_ph, s_ph, x["ph_d"], e)
    return [*r, *v]


def _pieces(phase: int) -> Build:
    """:func:`dynamics.friction_pieces` of ``phase``."""
    def build(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> list[Any]:
        y = [x[n] for n in STATES[phase]]
        th, ps, ph, th_d, ps_d, ph_d = (y[0], y[1], y[2], y[3], y[4], y[5]) if phase == 2 else (
            y[0], y[1], 0.0, y[2], y[3], 0.0)
        p = dyn.friction_pieces(phase, th, ps, ph, th_d, ps_d, ph_d, e, g, H, lib)
        return list(p[:len(PIECES)])
    return build


def _first_steps(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> tuple:
    return dyn.friction_first_steps(tuple(x[n] for n in _LOADS), lib)


def _newton(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> tuple:
    return dyn.friction_newton_step(tuple(x[n] for n in _LOADS), x["n_R"], x["n_H"], lib)


def _newton_margins(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> tuple:
    """The margins of a step of ``dynamics.friction_solve`` from ``o`` to ``n``
    (``dynamics.friction_newton_margin``) and the step."""
    d_R, d_H = x["n_R"] - x["o_R"], x["n_H"] - x["o_H"]
    return (dyn.friction_newton_margin(d_R, x["s_R"], x["n_R"]),
            dyn.friction_newton_margin(d_H, x["s_H"], x["n_H"]), d_R, d_H)


def _friction_rates(phase: int) -> Build:
    """``dynamics.friction_derivative`` of ``phase`` from the state, the pieces and the solved
    load magnitudes."""
    def build(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> tuple:
        y = [x[n] for n in (*STATES[phase], *LOST)]
        p = tuple(x[n] for n in PIECES)
        return dyn.friction_derivative(phase, y, p, x["n_R"], x["n_H"], e, g)[:len(y)]
    return build


def _couples(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> list[Any]:
    p = tuple(x.get(n, 0.0) for n in PIECES)
    return list(dyn.friction_result(p, x["n_R"], x["n_H"])[:2])


def _lift_off_under(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> list[Any]:
    y = [x[n] for n in STATES[1]]
    m = dyn.motion_under(1, y, e, g, H, x["Q_th"], x["Q_ps"], lib)
    return [traced(pev.trough_margin, lib)(m, e, g)]


def _event(kind: int, phase: int) -> Build:
    def build(e: Any, g: Any, H: Any, x: dict[str, Any], lib: Any) -> list[Any]:
        value = traced(pev.event_value, lib)(kind, x.get("t", 0.0), _state(x, phase), e, g, H,
                                             x.get("par", 0.0))
        return [value]
    return build


def _all_formulas() -> tuple[Formula, ...]:
    out: list[Formula] = []
    angles_loads = (*ANGLE_NAMES, *LOAD_OUTPUTS)
    for fixed in (False, True):
        cw = "fixed" if fixed else "hinged"
        for phase in (1, 2, 3):
            out.append(Formula(f"rates{phase}_{cw}", f"phase {phase} state derivative "
                               "(dynamics.state_rates_phase*)", STATES[phase],
                               tuple(f"d_{n}" for n in STATES[phase]), _rates(phase), fixed))
            out.append(Formula(f"outputs{phase}_{cw}", f"phase {phase} angles, rates, "
                               "accelerations and loads (dynamics + forces.row_loads)",
                               (*STATES[phase], *REST), angles_loads, phase_outputs(phase), fixed))
        out.append(Formula(f"outputs3_{cw}_dry", "dry fire (no projectile): angles and loads",
                           (*STATES[3], *REST), angles_loads, phase_outputs(3), fixed, dry=True))
        for phase in (1, 2, 3):
            out.append(Formula(f"jacobian{phase}_{cw}", f"phase {phase}: d(outputs)/d(state), "
                               "row-major", (*STATES[phase], *REST),
                               tuple(f"d{o}/d{n}" for o in angles_loads for n in STATES[phase]),
                               _jacobian(phase), fixed, tolerance=JACOBIAN_TOLERANCE))
        out.append(Formula(f"lift_off_{cw}", "phase_events.lift_off_margin: F_N / (m g)",
                           STATES[1], ("margin",), _event(pev.LIFT_OFF, 1), fixed))
        out += _friction_formulas(fixed, angles_loads)
    out += [
        Formula("friction_first_steps", "dynamics.friction_first_steps: Newton's first two "
                "steps on the bearings' load magnitudes (N), the second step and its margins",
                _LOADS, _FIRST_STEPS, _first_steps, friction=True,
                tolerance=FIRST_STEPS_TOLERANCE),
        Formula("friction_newton", "dynamics.friction_newton_step: one Newton step on the "
                "bearings' load magnitudes (N)", (*_LOADS, *_NEWTON), _NEWTON, _newton,
                friction=True),
        Formula("friction_newton_margins", "dynamics.friction_newton_margin of both loads "
                "(<= 0: converged to round-off) and the step (N)", _MARGIN_IN, _MARGIN_OUT,
                _newton_margins, friction=True),
        Formula("friction_couples", "dynamics.friction_result: Q_th, Q_ps (N m)",
                ("p0", "p1", *_NEWTON), COUPLES, _couples),
        Formula("sling_upright", "phase_events.sling_upright_margin", STATES[1], ("margin",),
                _event(pev.SLING_UPRIGHT, 1)),
        Formula("ground", "phase_events.projectile_height (m)", STATES[2], ("height",),
                _event(pev.GROUND, 2)),
        Formula("release_time", "phase_events.time_to_release (s)", ("t", "par"), ("dt",),
                _event(pev.RELEASE_TIME, 2)),
        Formula("climb", "phase_events.climb_margin (m/s); par: release angle (rad)",
                (*STATES[2], "par"), ("margin",), _event(pev.RELEASE_ANGLE, 2)),
        Formula("projectile", "kinematics.projectile_position_xy, projectile_velocity_xy",
                ("th", "ph", "th_d", "ph_d"), ("x", "y", "vx", "vy"), _projectile),
        Formula("vacuum_flight", "flight.projectile_in_flight (vacuum) and its energy",
                ("t", "r_t", "r_x", "r_y", "r_vx", "r_vy", "rest_m"),
                ("x", "y", "vx", "vy", "E_m"), _vacuum_flight),
        Formula("drag_rates", "flight._drag_rhs: (x, y, vx, vy)'", ("k", "x", "y", "vx", "vy"),
                ("d_x", "d_y", "d_vx", "d_vy"), _drag_rates),
        Formula("drag_constant", "flight.drag_constant (1/m)",
                ("diameter", "drag_coefficient", "air_density"), ("k",), _drag_constant),
        Formula("flight_energy", "forces.projectile_energy less its rest value (J)",
                ("vx", "vy", "y", "rest_m"), ("E_m",), _flight_energy),
        Formula("rest_energies", "forces.energies_xy at rest (J)", ("th", "ps", "y_m"),
                REST, _rest_energies),
        Formula("energy_scale", "dynamics.energy_scale (J): the unit of the lost energies' states",
                (), ("scale",), lambda e, g, H, x, lib: [dyn.energy_scale(e, g)]),
        Formula("default_inertia", "scene.default_moment_of_inertia (kg m2)", (), ("I",),
                lambda e, g, H, x, lib: [default_moment_of_inertia(e.m_b, e.L1, e.L2)]),
    ]
    return tuple(out)


def _friction_formulas(fixed: bool, angles_loads: tuple[str, ...]) -> list[Formula]:
    """The formulas of an engine with friction in its bearings: the couples' pieces, and the
    state's rates from the pieces and the solved loads, the outputs and lift-off under the
    couples' generalised forces (the C glue solves those with the generated Newton steps, as
    :func:`dynamics.friction_solve` does)."""
    cw = "fixed" if fixed else "hinged"
    out = []
    for phase in (1, 2, 3):
        out.append(Formula(f"friction_pieces{phase}_{cw}", f"phase {phase}: "
                           "dynamics.friction_pieces", STATES[phase], PIECES, _pieces(phase),
                           fixed, friction=True))
        out.append(Formula(f"rates{phase}_{cw}_friction", f"phase {phase} state derivative "
                           "with friction (dynamics.friction_derivative)",
                           (*STATES[phase], *LOST, *PIECES, *_NEWTON),
                           tuple(f"d_{n}" for n in (*STATES[phase], *LOST)),
                           _friction_rates(phase), fixed, friction=True))
        out.append(Formula(f"outputs{phase}_{cw}_friction", f"phase {phase} angles, rates, "
                           "accelerations and loads with friction",
                           (*STATES[phase], *LOST, *COUPLES, *REST), angles_loads,
                           phase_outputs(phase, True), fixed, friction=True))
    out.append(Formula(f"outputs3_{cw}_dry_friction", "dry fire with friction: angles and loads",
                       (*STATES[3], *LOST, *COUPLES, *REST), angles_loads, phase_outputs(3, True),
                       fixed, dry=True, friction=True))
    out.append(Formula(f"lift_off_{cw}_friction", "phase_events.trough_margin under the "
                       "couples", (*STATES[1], *COUPLES), ("margin",), _lift_off_under, fixed,
                       friction=True))
    return out


FORMULAS: tuple[Formula, ...] = _all_formulas()


def _function_c(f: Formula) -> str:
    import sympy as sp

    q = [sp.Symbol(f"p_{n}", real=True) for n in PARAMETER_NAMES]
    if f.dry:
        q[PARAMETER_NAMES.index("m")] = sp.Float(0.0)
    x = {n: sp.Symbol(f"x_{n}", real=True) for n in f.inputs}
    e = engine_namespace(q, bool(f.fixed), f.friction)
    g, H = q[PARAMETER_NAMES.index("g")], q[PARAMETER_NAMES.index("H")]
    exprs = [sp.sympify(v) for v in f.build(e, g, H, x, sympy_math())]
    if len(exprs) != len(f.outputs):
        raise ValueError(f"{f.name}: {len(exprs)} results for {len(f.outputs)} outputs")
    temps, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("t"))
    pr = c_printer(products=f.friction)
    used = set().union(*(ex.free_symbols for ex in [*reduced, *(v for _, v in temps)]))
    lines = [f"/* {f.doc}. x: {' '.join(f.inputs) or '-'}; out: {' '.join(f.outputs)} */",
             f"void treb_{f.name}(const double *q, const double *x, double *out)", "{"]
    lines += [f"    const double {s} = q[{i}];" for i, s in enumerate(q)
              if isinstance(s, sp.Symbol) and s in used]
    lines += [f"    const double {s} = x[{i}];" for i, s in enumerate(x.values()) if s in used]
    lines += ["    (void)q; (void)x;"]
    lines += [f"    const double {s} = {pr.doprint(v)};" for s, v in temps]
    lines += [f"    out[{i}] = {pr.doprint(v)};  /* {n} */"
              for i, (n, v) in enumerate(zip(f.outputs, reduced, strict=True))]
    return "\n".join([*lines, "}", ""])


def generate_header() -> str:
    """``treb_formulas.h``: the generated functions' declarations and index constants."""
    lines = ["/* Generated by trebuchet.fmu.codegen from the model's Python: do not edit. */",
             "#ifndef TREB_FORMULAS_H", "#define TREB_FORMULAS_H", ""]
    lines += [f"#define TREB_Q_{n} {i}" for i, n in enumerate(PARAMETER_NAMES)]
    lines += [f"#define TREB_NQ {len(PARAMETER_NAMES)}",
              f"#define TREB_FRICTION_NEWTON_STEPS {dyn.FRICTION_NEWTON_STEPS}",
              f"#define TREB_N_PIECES {len(PIECES)}",
              f"#define TREB_N_LOADS {len(_LOADS)}",
              f"#define TREB_N_FIRST_STEPS {len(_FIRST_STEPS)}",
              f"#define TREB_N_OUTPUTS {len(ANGLE_NAMES) + len(LOAD_OUTPUTS)}", ""]
    lines += [f"#define TREB_OUT_{n} {i}" for i, n in enumerate((*ANGLE_NAMES, *LOAD_OUTPUTS))]
    lines += [""]
    lines += [f"void treb_{f.name}(const double *q, const double *x, double *out);"
              for f in FORMULAS]
    lines += ["", "#endif", ""]
    return "\n".join(lines)


def generate_c(formulas: tuple[Formula, ...] = FORMULAS, header: str = "treb_formulas.h") -> str:
    """``treb_formulas.c``: every :data:`FORMULAS` entry as C99 (or ``formulas`` with their
    ``header``)."""
    head = ["/* Generated by trebuchet.fmu.codegen from the model's Python (sympy, cse): "
            "do not edit. */", "#include <math.h>", f'#include "{header}"',
            "#ifndef M_PI", "#define M_PI 3.14159265358979323846", "#endif",
            "#ifndef NAN", "#define NAN (0.0 / 0.0)", "#endif", ""]
    return "\n".join(head) + "\n".join(_function_c(f) for f in formulas)
