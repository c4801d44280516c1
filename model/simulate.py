"""Simulate a shot: phase I (trough), phase II (sling), phase III (released).

:func:`simulate` is the one entry point. It integrates the equations of motion
of :mod:`trebuchet.model.dynamics` phase by phase, locates lift-off (the
trough's normal force reaches zero) and release (a time, or the projectile's
velocity climbing at a given angle) as events to solver accuracy, and
computes every load with :func:`trebuchet.model.loads.loads` on the
requested output times. The result is a DataFrame whose ``attrs`` carry the
events, the flight in vacuum and the solver's diagnostics.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pandas as pd

from trebuchet.core.errors import ModelValidityWarning, TrebuchetInputError, warn_at_caller
from trebuchet.model import c_engine
from trebuchet.model import dynamics as dyn
from trebuchet.model import kinematics as kin
from trebuchet.model import phase_events as pev
from trebuchet.model.flight import flight_summary
from trebuchet.model.frames import block_frame, frame
from trebuchet.model.friction import has_friction
from trebuchet.model.loads import load_columns
from trebuchet.model.output_size import check_output_size
from trebuchet.model.scene import Scene, as_scene
from trebuchet.model.settings import ACCURACY, DEFAULT_AFTER_RELEASE, DEFAULT_RTOL
from trebuchet.model.shot_checks import (
    checked_times,
    refuse_non_finite,
    slack_intervals,
    stiffness_advice,
)

__all__ = ["simulate", "Trajectory", "integrate", "resolve_rtol", "DEFAULT_RTOL", "ACCURACY"]

DEFAULT_DRY_FIRE = 1.5  # s simulated by default for a dry fire (phase III from the start)
MAX_SHOT = 60.0  # s: a shot still in the trough or sling by then is refused
#: Angles, rates and accelerations, in the row order of :meth:`Trajectory.angle_columns`.
STATE_COLUMNS = ("theta", "psi", "phi", "theta_d", "psi_d", "phi_d", "theta_dd", "psi_dd",
                 "phi_dd")
#: The energies lost to friction, integrated with the motion where the engine has friction.
LOST_COLUMNS = ("E_loss_pivot", "E_loss_hinge")


@dataclass(frozen=True)
class PhaseSolution:
    """One phase: its interval (s), its dense solution and solver counters."""

    phase: int
    t0: float
    t1: float
    sol: Any  # dense solution: callable at times, returns the state
    nfev: int
    last_step: float | None = None


@dataclass(frozen=True)
class Trajectory:
    """The integrated motion of a shot: its phases, events and release state."""

    scene: Scene
    phases: tuple[PhaseSolution, ...]
    events: dict[str, float]
    release_state: dict[str, float] | None
    rtol: float
    method: str
    shot: Any = None  # the C engine's shot (c_engine.CShot) where it integrated

    @property
    def t_end(self) -> float:
        return self.phases[-1].t1

    @property
    def nfev(self) -> int:
        return sum(p.nfev for p in self.phases)

    @property
    def engine(self) -> str:
        """What integrated the shot: ``"c"``, ``"numba"``, ``"python"`` or ``"scipy"``."""
        if self.shot is not None:
            return "c"
        if self.method in ("DOP853", "c-DOP853", "numba-DOP853"):
            return "numba"
        return "python" if self.method == "python-DOP853" else "scipy"

    @property
    def friction(self) -> bool:
        """True when the engine has friction: every phase's state then ends with the energies
        lost at pivot and hinge (in units of :func:`dynamics.energy_scale`)."""
        return has_friction(self.scene.engine)

    def lost_energies(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``E_loss_pivot``, ``E_loss_hinge`` (J, since the trigger) at times ``t`` (s), from the
        integrated states (zero without friction)."""
        cols = self.angle_columns(np.asarray(t, dtype=float), lost=True)
        zero = np.zeros(cols["t"].size)
        return cols.get("E_loss_pivot", zero), cols.get("E_loss_hinge", zero)

    def angles(self, t: np.ndarray) -> pd.DataFrame:
        """Angles, rates and accelerations at times ``t`` (s). At an event time the row takes
        the phase that ends there (left limit); ``t = 0`` is 0+ (the shot has started)."""
        return frame(self.angle_columns(t))

    def angle_columns(self, t: np.ndarray, lost: bool = False) -> dict[str, np.ndarray]:
        """:meth:`angles` as a dict of columns ``t, phase, theta … phi_dd``; with ``lost`` and
        an engine with friction, ``E_loss_pivot`` and ``E_loss_hinge`` (J, since the trigger,
        from the integrated states) too."""
        t = np.asarray(t, dtype=float)
        if t.ndim != 1:
            raise ValueError("t_eval must be one-dimensional")
        if t.size and (t.min() < 0.0 or t.max() > self.t_end * (1 + 1e-12)):
            raise TrebuchetInputError(f"t_eval must lie within [0, {self.t_end:.6g}] s (the "
                                      "simulated shot); ask for a longer phase III with "
                                      "after_release=")
        n = t.size
        names = STATE_COLUMNS + (LOST_COLUMNS if lost and self.friction else ())
        block = np.full((len(names), n), np.nan)
        phase = np.zeros(n, dtype=np.int64)
        # phase k takes (t1 of phase k-1, t1 of phase k]; the first also t <= its t1
        which = np.minimum(np.searchsorted([p.t1 for p in self.phases], t, side="left"),
                           len(self.phases) - 1)
        for k, p in enumerate(self.phases):
            sel = np.flatnonzero(which == k)
            if not sel.size:
                continue
            if sel[-1] - sel[0] + 1 == sel.size:  # sorted times: a slice, no gather
                sel = slice(int(sel[0]), int(sel[-1]) + 1)
            phase[sel] = p.phase
            block[:, sel] = self._phase_columns(p, t[sel], len(names))
        if len(names) > len(STATE_COLUMNS):
            block[len(STATE_COLUMNS):] *= dyn.energy_scale(self.scene.engine, self.scene.g)
        return {"t": t, "phase": phase, **dict(zip(names, block, strict=True))}

    def _phase_columns(self, p: PhaseSolution, t: np.ndarray, rows: int) -> np.ndarray:
        """The first ``rows`` of :data:`STATE_COLUMNS` and the lost energies' states of one
        phase at times ``t`` inside it."""
        if hasattr(p.sol, "columns"):  # the compiled integrator evaluates them itself
            out = np.empty((rows, t.size))
            p.sol.columns(t, out)
            return out
        e, g, H = self.scene.engine, self.scene.g, self.scene.start.H
        y = p.sol(t)
        extra = [y[-k] for k in range(rows - len(STATE_COLUMNS), 0, -1)]
        return np.array([*dyn.phase_state(p.phase, y, e, g, H), *extra])


def _rhs(scene: Scene, kind: int, lib: ModuleType = math) -> Callable:
    """Right-hand side of phase ``kind`` for the pure-Python integrators: on lists of floats with
    ``lib=math`` (the steps), on arrays of shape (n, m) with ``lib=numpy`` (dense output)."""
    e, g, H = scene.engine, scene.g, scene.start.H

    def rhs(t: Any, y: Sequence[Any]) -> Any:
        return _pack(lib, dyn.state_derivative(kind, y, e, g, H, lib)[:len(y)])
    return rhs


def _pack(lib: ModuleType, parts: tuple[Any, ...]) -> Any:
    """A derivative as the integrator's step wants it (a list) or as an (n, m) array."""
    return list(parts) if lib is math else np.array(parts)


def _event(scene: Scene, kind: int, par: float) -> Callable:
    """An event of :mod:`~trebuchet.model.phase_events` as ``solve_ivp`` wants it: ``g(t, y)``
    with ``terminal`` and ``direction``."""
    e, g, H = scene.engine, scene.g, scene.start.H

    def fun(t: float, y: Sequence[float]) -> float:
        return pev.event_value(kind, t, y, e, g, H, par)

    fun.terminal = True  # type: ignore[attr-defined]
    fun.direction = pev.DIRECTION[kind]  # type: ignore[attr-defined]
    return fun


#: Integrators of :func:`simulate`'s ``method``: DOP853 in the generated C (default; the numba
#: kernel where no C compiler is), in C or numba by name, in pure Python, or any ``solve_ivp``
#: method prefixed ``scipy-`` (a bare scipy name also works).
METHODS = ("DOP853", "c-DOP853", "numba-DOP853", "python-DOP853", "scipy-DOP853", "scipy-RK45",
           "scipy-Radau", "scipy-LSODA", "scipy-BDF", "scipy-RK23")


def _solve(scene: Scene, kind: int, t0: float, t1: float, y0: Sequence[float],
           events: list[tuple[int, float]], rtol: float, method: str,
           first_step: float | None = None) -> Any:
    """Integrate phase ``kind`` (1 trough, 2 sling, 3 released) from ``t0`` to ``t1`` (s) or to
    the first of ``events`` (kinds of :mod:`~trebuchet.model.phase_events` with their
    parameter). DOP853 (default): compiled (:mod:`trebuchet.model.shot_kernel`);
    ``"python-DOP853"``: the same steps in pure Python (:mod:`trebuchet.model.integrator`);
    ``"scipy-DOP853"`` or any other ``solve_ivp`` method name: ``scipy.integrate.solve_ivp``.

    ``first_step`` (s) carries the step size across a phase change: the automatic first-step
    guess can overshoot after lift-off or release, and DOP853's error estimate does not always
    catch it on a first step (energy errors of 1e-7 of ΔU were seen)."""
    if first_step is not None:
        first_step = min(first_step, t1 - t0)
    if method in ("DOP853", "c-DOP853", "numba-DOP853"):  # where the C did not run: numba
        from trebuchet.model.kernel_phase import solve_phase

        return solve_phase(kind, scene.engine, scene.g, scene.start.H, t0, t1,
                           np.asarray(y0, dtype=float), rtol, first_step, tuple(events))
    ev = [_event(scene, k, par) for k, par in events]
    if method == "python-DOP853":
        from trebuchet.model.integrator import solve

        return solve(_rhs(scene, kind), (t0, t1), y0, rtol=rtol, atol=rtol * 1e-2,
                     dense_output=True, events=ev, first_step=first_step,
                     vectorized_fun=_rhs(scene, kind, np))
    from scipy.integrate import solve_ivp  # imported when used: it costs ~0.5 s

    return solve_ivp(_rhs(scene, kind), (t0, t1), y0, method=method.removeprefix("scipy-"),
                     rtol=rtol, atol=rtol * 1e-2, dense_output=True, events=ev or None,
                     first_step=first_step)


def _last_full_step(sol: Any) -> float | None:
    """The last step (s) a phase took before an event cut it short, to start the next with."""
    t = np.asarray(sol.t)
    return float(t[-2] - t[-3]) if t.size >= 3 else None


def resolve_rtol(rtol: float | str) -> float:
    """A relative tolerance from a preset name of :data:`ACCURACY` or a number in (0, 1e-2)."""
    if isinstance(rtol, str):
        if rtol not in ACCURACY:
            raise TrebuchetInputError(f"accuracy {rtol!r}: must be one of "
                                      + ", ".join(ACCURACY) + " or a tolerance")
        return ACCURACY[rtol]
    if not 0.0 < rtol < 1e-2:
        raise TrebuchetInputError(f"rtol = {rtol:g}: must lie between 0 and 1e-2")
    return float(rtol)


def integrate(scene: Scene, *, rtol: float | str = "default", method: str = "DOP853",
              after_release: float | None = None) -> Trajectory:
    """Integrate the phases of a shot that the scene calls for; see :func:`simulate`."""
    rtol = resolve_rtol(rtol)
    if after_release is None:
        after_release = DEFAULT_DRY_FIRE if scene.projectile == "none" else DEFAULT_AFTER_RELEASE
    check_output_size(after_release=after_release)
    if method in ("DOP853", "c-DOP853") and (traj := _integrate_c(scene, rtol, after_release,
                                                                 method)):
        return traj
    e, g, H, s = scene.engine, scene.g, scene.start.H, scene.start
    phases: list[PhaseSolution] = []
    events: dict[str, float] = {}
    t0, beam = 0.0, [s.theta, s.psi, 0.0, 0.0]  # θ, ψ, θ̇, ψ̇
    sling = [s.phi, 0.0]  # φ, φ̇
    lost = [0.0, 0.0] if has_friction(e) else []  # energies lost at pivot and hinge
    release_state = None
    if 1 in scene.phases:
        t0, beam, lost = _phase_trough(scene, beam, lost, rtol, method, phases, events)
        th, ps, th_d, ps_d = beam
        ph, ph_d, _, _, _ = dyn.accelerations_phase1(th, ps, th_d, ps_d, e, g, H, math)
        sling = [ph, ph_d]
    if 2 in scene.phases:
        t0, beam, sling, lost = _phase_sling(scene, t0, beam, sling, lost, rtol, method, phases,
                                             events)
        th, ps, th_d, ps_d = beam
        ph, ph_d = sling
        c_th, s_th, c_ph, s_ph = math.cos(th), math.sin(th), math.cos(ph), math.sin(ph)
        x, y = kin.projectile_position_xy(c_th, s_th, c_ph, s_ph, e, H)
        vx, vy = kin.projectile_velocity_xy(c_th, s_th, th_d, c_ph, s_ph, ph_d, e)
        release_state = {"t": t0, "x": x, "y": y, "vx": vx, "vy": vy}
    # Phase III: beam and counterweight swing on; the projectile flies (or there is none).
    t_end = t0 + after_release
    if after_release > 0.0 or not phases:
        sol = _solve(scene, 3, t0, t_end, beam + lost, [], rtol, method,
                     phases[-1].last_step if phases else None)
        _check(sol, scene, "phase III")
        phases.append(PhaseSolution(3, t0, t_end, sol.sol, sol.nfev))
    events["end"] = t_end
    return Trajectory(scene=scene, phases=tuple(phases), events=events,
                      release_state=release_state, rtol=rtol, method=method)


def _integrate_c(scene: Scene, rtol: float, after_release: float,
                 method: str) -> Trajectory | None:
    """The shot by the generated C (:mod:`~trebuchet.model.c_engine`); None where it cannot run
    here (``"DOP853"``: the numba kernel runs) or refuses the shot (the numba kernel words it)."""
    if method == "c-DOP853":
        c_engine.require(method)
    elif not c_engine.available():
        return None
    shot = c_engine.CShot.start(scene, rtol, after_release)
    if shot is None:
        return None
    n = len(shot.kinds) - (after_release == 0.0 and len(shot.kinds) > 1)  # no phase III
    phases = tuple(PhaseSolution(shot.kinds[k], shot.t0[k], shot.t1[k], c_engine.CPhase(shot, k),
                                 shot.nfev[k]) for k in range(n))
    return Trajectory(scene, phases, {**shot.events, "end": phases[-1].t1}, shot.release_state,
                      rtol, method, shot)


def _phase_trough(scene: Scene, beam: list[float], lost: list[float], rtol: float, method: str,
                  phases: list[PhaseSolution], events: dict[str, float]
                  ) -> tuple[float, list[float], list[float]]:
    """Phase I, beam and counterweight with the projectile on the trough constraint, up to
    lift-off. Returns the lift-off time and the beam state and lost energies there."""
    e, rel = scene.engine, scene.release
    t_rel = rel.time if rel.time is not None else math.inf
    ev = [(pev.LIFT_OFF, 0.0), (pev.SLING_UPRIGHT, 0.0)]
    sol = _solve(scene, 1, 0.0, MAX_SHOT, beam + lost, ev, rtol, method)
    _check(sol, scene, "phase I")
    if sol.status != 1:
        raise TrebuchetInputError(
            f"{scene.source}: [engine] the projectile did not lift off within {MAX_SHOT:g} s: "
            f"the counterweight (M = {e.M:g} kg, L2 = {e.L2:g} m) cannot swing the beam "
            f"(I = {e.I:g} kg m², m_b = {e.m_b:g} kg) and the projectile (m = {e.m:g} kg) "
            "fast enough; a heavier counterweight, a lighter beam or projectile would")
    if sol.t_events[1].size:
        raise TrebuchetInputError(
            f"{scene.source}: [engine] M = {e.M:g} kg: the counterweight cannot lift the "
            f"projectile: at t = {sol.t_events[1][0]:.4g} s the sling stands vertical over a "
            "projectile still in the trough; use a heavier counterweight, a lighter projectile "
            "or a longer sling")
    t_lift = float(sol.t_events[0][0])
    if t_lift >= t_rel:
        raise TrebuchetInputError(f"{scene.source}: [release] time = {t_rel:g} s comes before "
                                  f"lift-off at {t_lift:.4g} s: the projectile is still in the "
                                  "trough")
    events["lift_off"] = t_lift
    phases.append(PhaseSolution(1, 0.0, t_lift, sol.sol, sol.nfev, _last_full_step(sol)))
    y = [float(v) for v in sol.y_events[0][0]]
    return t_lift, y[:4], y[4:]


def _phase_sling(scene: Scene, t0: float, beam: list[float], sling: list[float],
                 lost: list[float], rtol: float, method: str, phases: list[PhaseSolution],
                 events: dict[str, float]
                 ) -> tuple[float, list[float], list[float], list[float]]:
    """Phase II, the projectile in the sling, up to release. Returns the release time and the
    beam and sling states and lost energies there."""
    rel = scene.release
    t_rel = rel.time if rel.time is not None else math.inf
    if t_rel <= t0:
        raise TrebuchetInputError(f"{scene.source}: [release] time = {t_rel:g} s: must come "
                                  f"after the start of phase II at {t0:.4g} s")
    ev = [(pev.GROUND, 0.0)]
    if rel.time is not None:
        ev.append((pev.RELEASE_TIME, rel.time))
    if rel.velocity_angle is not None:
        ev.append((pev.RELEASE_ANGLE, rel.velocity_angle))
    t_stop = min(t_rel, MAX_SHOT) if rel.velocity_angle is None else MAX_SHOT
    th, ps, th_d, ps_d = beam
    ph, ph_d = sling
    sol = _solve(scene, 2, t0, t_stop, [th, ps, ph, th_d, ps_d, ph_d, *lost], ev, rtol, method,
                 phases[-1].last_step if phases else None)
    _check(sol, scene, "phase II")
    hits = [(te[0], ye[0], k) for k, (te, ye) in enumerate(zip(sol.t_events, sol.y_events,
                                                                strict=True)) if te.size]
    if hits and min(hits, key=lambda h: h[0])[2] == 0:
        t_hit = min(hits, key=lambda h: h[0])[0]
        rule = (f"time = {rel.time:g} s" if rel.time is not None else
                f"velocity_angle_deg = {math.degrees(rel.velocity_angle):g}")
        raise TrebuchetInputError(
            f"{scene.source}: [release] {rule}: the projectile strikes the ground at "
            f"t = {t_hit:.4g} s while still in the sling; release it earlier, use a shorter "
            "sling or raise the pivot")
    if hits:
        t_release, y_release, _ = min(hits, key=lambda h: h[0])
    elif rel.velocity_angle is None:  # released by time exactly at the end of the interval
        t_release, y_release = sol.t[-1], sol.y[:, -1]
    else:
        raise TrebuchetInputError(
            f"{scene.source}: [release] velocity_angle_deg = "
            f"{math.degrees(rel.velocity_angle):g}: the projectile never climbs at that angle "
            f"within {MAX_SHOT:g} s")
    t_release = float(t_release)
    events["release"] = t_release
    phases.append(PhaseSolution(2, t0, t_release, sol.sol, sol.nfev, _last_full_step(sol)))
    th, ps, ph, th_d, ps_d, ph_d, *lost = (float(v) for v in y_release)
    return t_release, [th, ps, th_d, ps_d], [ph, ph_d], lost


def _check(sol: Any, scene: Scene, what: str) -> None:
    if sol.status < 0:
        raise TrebuchetInputError(f"{scene.source}: the integration of {what} failed: "
                                  f"{sol.message}")


def default_times(traj: Trajectory, dt: float = 1e-3) -> np.ndarray:
    """A uniform grid of step ``dt`` (s) over the shot, with lift-off and release added."""
    grid = np.arange(0.0, traj.t_end + 0.5 * dt, dt)
    grid = grid[grid <= traj.t_end]
    extra = list(traj.events.values())
    return np.unique(np.concatenate([grid, extra]))


def engine_energy(run: Mapping[str, Any], traj: Trajectory) -> np.ndarray:
    """Mechanical energy gained by the engine since rest plus the heat its bearings made, J:
    ``E_m + E_M + E_beam + E_loss_pivot + E_loss_hinge``, with the projectile's energy frozen at
    its release value once it flies (drag may take it after that). Zero for an exact
    solution: the drift of the integrator."""
    E_m = np.asarray(run["E_m"])
    if traj.release_state is not None:
        rs, e, s = traj.release_state, traj.scene.engine, traj.scene
        y_rest = 0.0
        if s.projectile == "sling":
            y_rest = kin.projectile_position_xy(
                math.cos(s.start.theta), math.sin(s.start.theta), math.cos(s.start.phi),
                math.sin(s.start.phi), e, s.start.H)[1]
        at_release = 0.5 * e.m * (rs["vx"] ** 2 + rs["vy"] ** 2) + e.m * s.g * (rs["y"] - y_rest)
        E_m = np.where(np.asarray(run["phase"]) == 3, at_release, E_m)
    total = E_m + np.asarray(run["E_M"]) + np.asarray(run["E_beam"])
    if "E_loss_pivot" in run:
        total = total + np.asarray(run["E_loss_pivot"]) + np.asarray(run["E_loss_hinge"])
    return total


def simulate(scene: Scene | str | Path,
             t_eval: Sequence[float] | np.ndarray | None = None, *,
             rtol: float | str = "default", method: str = "DOP853",
             after_release: float | None = None, dt: float = 1e-3) -> pd.DataFrame:
    """Simulate a shot and compute every force, torque, power and energy of the paper.

    Parameters
    ----------
    scene : Scene, or the path of a scene file (TOML)
        Engine, start pose, release rule, gravity.
    t_eval : array of s, optional
        Output times after the trigger. Default: every ``dt`` s, plus lift-off, release and the
        end. At an event time a row holds the phase that ends there.
    rtol : float or str
        Relative tolerance of the integrator (absolute tolerance ``rtol/100``), or a preset of
        :data:`ACCURACY`: ``"fast"`` (1e-6), ``"default"`` (1e-10: energy conserved to 1e-9 of
        ΔU), ``"precise"`` (1e-12). ``make bench`` measures what each costs and buys.
    method : str
        ``"DOP853"`` (default): Dormand–Prince 8(5,3) in the C that ``trebuchet fmu build``
        generates from the model's formulas, run in process (:mod:`trebuchet.model.c_engine`;
        built at install, ``make install``); where no C compiler is, the same method compiled
        with numba. ``"c-DOP853"``, ``"numba-DOP853"``: one of those by name (the same steps,
        equal to rounding). ``"python-DOP853"``: the same steps in pure Python.
        ``"scipy-<name>"`` or a bare ``solve_ivp`` method name (``"RK45"``, ``"Radau"``, …):
        ``scipy.integrate.solve_ivp``.
    after_release : float, optional
        Seconds of phase III (beam and counterweight after release) to simulate; default 0.5 s,
        or 1.5 s for a dry fire (which is phase III from the start).
    dt : float
        Output step of the default grid, s.

    Returns
    -------
    DataFrame with the columns of docs/interface.md (and the extras of
    :func:`trebuchet.model.loads.loads`). ``attrs["events"]`` holds ``lift_off``,
    ``release`` and ``end`` (s; lift-off and release only where the scene has them);
    ``attrs["flight"]`` the flight (vacuum or drag, None for a dry fire);
    ``attrs["diagnostics"]`` the solver, tolerance, number of evaluations and energy drift.
    """
    scene = as_scene(scene, "simulate")
    rtol = resolve_rtol(rtol)
    times = None if t_eval is None else checked_times(t_eval)
    if times is None:
        check_output_size(dt, after_release)
    traj = integrate(scene, rtol=rtol, method=method, after_release=after_release)
    if times is None:
        check_output_size(dt, span=traj.t_end)
    times = default_times(traj, dt) if times is None else times
    table = None if traj.shot is None else traj.shot.table(times)  # the C: every column
    if table is None:
        angles = traj.angle_columns(times, lost=True)
        lost = {name: angles.pop(name) for name in LOST_COLUMNS if name in angles}
        cols = load_columns(angles, scene, release_state=traj.release_state, lost=lost or None)
    else:
        cols = table.columns
    if table is None or not table.finite:
        refuse_non_finite(cols, scene)
    drift = float(np.max(np.abs(engine_energy(cols, traj)))) if times.size else 0.0
    delta_u = scene.delta_U
    slack = slack_intervals(cols)
    run = frame(cols) if table is None else block_frame(table.names, table.block,
                                                        {1: table.phase})
    run.attrs["events"] = dict(traj.events)
    run.attrs["flight"] = (None if traj.release_state is None else flight_summary(
        traj.release_state, scene.g, scene.flight, scene.engine.m))
    run.attrs["diagnostics"] = {
        "method": method, "engine": traj.engine, "rtol": rtol, "nfev": traj.nfev,
        "energy_drift": drift, "energy_drift_rel": drift / delta_u, "delta_U": delta_u,
        "slack": slack, "advice": stiffness_advice(scene, traj.nfev),
    }
    for a, b in run.attrs["diagnostics"]["slack"]:
        warn_at_caller(ModelValidityWarning(
            f"{scene.source}: the sling goes slack (tension below zero) from t = {a:.4g} s to "
            f"{b:.4g} s: a rigid sling cannot push, so the loads there are fiction"))
    return run
