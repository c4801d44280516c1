"""Simulate a shot: phase I (trough), phase II (sling), phase III (released).

:func:`simulate` is the one entry point. It integrates the equations of motion
of :mod:`trebuchet.model.dynamics` phase by phase, locates lift-off (the
trough's normal force reaches zero) and release (a time, or the projectile's
velocity climbing at a given angle) as events to solver accuracy, and
computes every load with :func:`trebuchet.model.forces.loads` on the
requested output times. The result is a DataFrame whose ``attrs`` carry the
events, the flight in vacuum and the solver's diagnostics.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import ModuleType
from typing import Any

import numpy as np
import pandas as pd

from trebuchet.errors import ModelValidityWarning, TrebuchetInputError

from . import dynamics as dyn
from .flight import flight_summary
from .forces import loads
from .scene import Scene

__all__ = ["simulate", "Trajectory", "integrate", "resolve_rtol", "DEFAULT_RTOL", "ACCURACY"]

DEFAULT_RTOL = 1e-10
ACCURACY = {"fast": 1e-6, "default": DEFAULT_RTOL, "precise": 1e-12}  # named tolerances
DEFAULT_AFTER_RELEASE = 0.5  # s of phase III simulated by default
DEFAULT_DRY_FIRE = 1.5  # s simulated by default for a dry fire (phase III from the start)
MAX_SHOT = 60.0  # s: a shot still in the trough or sling by then is refused


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

    @property
    def t_end(self) -> float:
        return self.phases[-1].t1

    @property
    def nfev(self) -> int:
        return sum(p.nfev for p in self.phases)

    def angles(self, t: np.ndarray) -> pd.DataFrame:
        """Angles, rates and accelerations at times ``t`` (s). At an event time the row takes
        the phase that ends there (left limit); ``t = 0`` is 0+ (the shot has started)."""
        t = np.asarray(t, dtype=float)
        if t.ndim != 1:
            raise ValueError("t_eval must be one-dimensional")
        if t.size and (t.min() < 0.0 or t.max() > self.t_end * (1 + 1e-12)):
            raise TrebuchetInputError(f"t_eval must lie within [0, {self.t_end:.6g}] s (the "
                                      "simulated shot); ask for a longer phase III with "
                                      "after_release=")
        from .frames import frame

        e, g, H = self.scene.engine, self.scene.g, self.scene.start.H
        names = ("theta", "psi", "phi", "theta_d", "psi_d", "phi_d", "theta_dd", "psi_dd",
                 "phi_dd")
        n = t.size
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
            y = p.sol(t[sel])
            if p.phase == 1:
                th, ps, th_d, ps_d = y
                ph, ph_d, th_dd, ps_dd, ph_dd = dyn.accelerations_phase1(th, ps, th_d, ps_d, e,
                                                                         g, H)
            elif p.phase == 2:
                th, ps, ph, th_d, ps_d, ph_d = y
                th_dd, ps_dd, ph_dd = dyn.accelerations_phase2(th, ps, ph, th_d, ps_d, ph_d, e, g)
            else:
                th, ps, th_d, ps_d = y
                th_dd, ps_dd = dyn.accelerations_phase3(th, ps, th_d, ps_d, e, g)
                ph = ph_d = ph_dd = np.nan
            for row, v in enumerate((th, ps, ph, th_d, ps_d, ph_d, th_dd, ps_dd, ph_dd)):
                block[row, sel] = v
        return frame({"t": t, "phase": phase, **dict(zip(names, block, strict=True))})


def _rhs_phase1(scene: Scene, lib: ModuleType = math) -> Callable:
    """Phase I right-hand side for state (θ, ψ, θ̇, ψ̇): on lists of floats with ``lib=math``
    (the integrator's steps), on arrays of shape (4, m) with ``lib=numpy`` (dense output)."""
    e, g, H = scene.engine, scene.g, scene.start.H

    def rhs(t: Any, y: Sequence[Any]) -> Any:
        th, ps, th_d, ps_d = y
        _, _, th_dd, ps_dd, _ = dyn.accelerations_phase1(th, ps, th_d, ps_d, e, g, H, lib)
        return _pack(lib, th_d, ps_d, th_dd, ps_dd)

    return rhs


def _rhs_phase2(scene: Scene, lib: ModuleType = math) -> Callable:
    """Phase II right-hand side for state (θ, ψ, φ, θ̇, ψ̇, φ̇); see :func:`_rhs_phase1`."""
    e, g = scene.engine, scene.g

    def rhs(t: Any, y: Sequence[Any]) -> Any:
        th, ps, ph, th_d, ps_d, ph_d = y
        th_dd, ps_dd, ph_dd = dyn.accelerations_phase2(th, ps, ph, th_d, ps_d, ph_d, e, g, lib)
        return _pack(lib, th_d, ps_d, ph_d, th_dd, ps_dd, ph_dd)

    return rhs


def _rhs_phase3(scene: Scene, lib: ModuleType = math) -> Callable:
    """Phase III right-hand side for state (θ, ψ, θ̇, ψ̇); see :func:`_rhs_phase1`."""
    e, g = scene.engine, scene.g

    def rhs(t: Any, y: Sequence[Any]) -> Any:
        th, ps, th_d, ps_d = y
        th_dd, ps_dd = dyn.accelerations_phase3(th, ps, th_d, ps_d, e, g, lib)
        return _pack(lib, th_d, ps_d, th_dd, ps_dd)

    return rhs


def _pack(lib: ModuleType, *parts: Any) -> Any:
    """A derivative as the integrator's step wants it (a list) or as an (n, m) array."""
    return list(parts) if lib is math else np.array(parts)


def _event(fun: Callable[[float, Any], float], direction: float) -> Callable:
    fun.terminal = True  # type: ignore[attr-defined]
    fun.direction = direction  # type: ignore[attr-defined]
    return fun


def _lift_off_event(scene: Scene) -> Callable:
    """Normal force of the trough over the projectile's weight, ``F_N/(m g)``; lift-off at 0."""
    e, g, H = scene.engine, scene.g, scene.start.H

    def normal_force(t: float, y: Sequence[float]) -> float:
        th, ps, th_d, ps_d = y
        ph, _, th_dd, _, _ = dyn.accelerations_phase1(th, ps, th_d, ps_d, e, g, H, math)
        f, gg = dyn.trough_f_g(th, ph, e, math)
        return 1.0 - e.L1 * (f * th_dd + gg * th_d * th_d) * math.tan(ph) / g

    return _event(normal_force, -1.0)


def _sling_upright_event(scene: Scene) -> Callable:
    """The sling stands vertical over a projectile still in the trough (cos φ → 0): the
    counterweight cannot lift the projectile."""
    e, H = scene.engine, scene.start.H

    def upright(t: float, y: Sequence[float]) -> float:
        return (H + e.L1 * math.sin(y[0])) / e.L4 - 0.999

    return _event(upright, 1.0)


def _ground_event(scene: Scene) -> Callable:
    """Height of the projectile in the sling, m (a hair below ground counts as the ground, so
    that lift-off from the trough at y = 0 is not taken for a strike)."""
    e, H = scene.engine, scene.start.H
    margin = 1e-9 * (e.L1 + e.L4)

    def height(t: float, y: Sequence[float]) -> float:
        return H + e.L1 * math.sin(y[0]) + e.L4 * math.sin(y[2]) + margin

    return _event(height, -1.0)


def _time_event(t_release: float) -> Callable:
    return _event(lambda t, y: t - t_release, 1.0)


def _velocity_angle_event(scene: Scene, angle: float) -> Callable:
    """``|v| sin(α − β)`` where β is the projectile's climb toward −x; zero when β = α."""
    e = scene.engine
    sa, ca = math.sin(angle), math.cos(angle)

    def climb(t: float, y: Sequence[float]) -> float:
        th, _, ph, th_d, _, ph_d = y
        vx = -e.L1 * th_d * math.sin(th) - e.L4 * ph_d * math.sin(ph)
        vy = e.L1 * th_d * math.cos(th) + e.L4 * ph_d * math.cos(ph)
        return sa * (-vx) - ca * vy

    return _event(climb, 1.0)


def _solve(rhs: tuple[Callable, Callable], t0: float, t1: float, y0: Sequence[float],
           events: list[Callable], rtol: float, method: str,
           first_step: float | None = None) -> Any:
    """``rhs`` is the right-hand side on floats and on arrays (for the dense output of all
    steps at once). DOP853 (default): the lean integrator of
    :mod:`trebuchet.model.integrator`, the same method as scipy's at a fraction of the
    overhead; ``"scipy-DOP853"`` or any other
    ``solve_ivp`` method name: ``scipy.integrate.solve_ivp``.

    ``first_step`` (s) carries the step size across a phase change: the automatic first-step
    guess can overshoot after lift-off or release, and DOP853's error estimate does not always
    catch it on a first step (energy errors of 1e-7 of ΔU were seen)."""
    if first_step is not None:
        first_step = min(first_step, t1 - t0)
    rhs, rhs_arrays = rhs
    if method == "DOP853":
        from .integrator import solve

        return solve(rhs, (t0, t1), y0, rtol=rtol, atol=rtol * 1e-2, dense_output=True,
                     events=events, first_step=first_step, vectorized_fun=rhs_arrays)
    from scipy.integrate import solve_ivp  # imported when used: it costs ~0.5 s

    return solve_ivp(rhs, (t0, t1), y0, method=method.removeprefix("scipy-"), rtol=rtol,
                     atol=rtol * 1e-2, dense_output=True, events=events or None,
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
    if not after_release >= 0.0:
        raise TrebuchetInputError(f"after_release = {after_release:g} s: must not be negative")
    e, g, H, s = scene.engine, scene.g, scene.start.H, scene.start
    phases: list[PhaseSolution] = []
    events: dict[str, float] = {}
    t0, beam = 0.0, [s.theta, s.psi, 0.0, 0.0]  # θ, ψ, θ̇, ψ̇
    sling = [s.phi, 0.0]  # φ, φ̇
    release_state = None
    if 1 in scene.phases:
        t0, beam = _phase_trough(scene, beam, rtol, method, phases, events)
        th, ps, th_d, ps_d = beam
        ph, ph_d, _, _, _ = dyn.accelerations_phase1(th, ps, th_d, ps_d, e, g, H, math)
        sling = [ph, ph_d]
    if 2 in scene.phases:
        t0, beam, sling = _phase_sling(scene, t0, beam, sling, rtol, method, phases, events)
        th, ps, th_d, ps_d = beam
        ph, ph_d = sling
        release_state = {
            "t": t0,
            "x": e.L1 * math.cos(th) + e.L4 * math.cos(ph),
            "y": H + e.L1 * math.sin(th) + e.L4 * math.sin(ph),
            "vx": -e.L1 * th_d * math.sin(th) - e.L4 * ph_d * math.sin(ph),
            "vy": e.L1 * th_d * math.cos(th) + e.L4 * ph_d * math.cos(ph),
        }
    # Phase III: beam and counterweight swing on; the projectile flies (or there is none).
    t_end = t0 + after_release
    if after_release > 0.0 or not phases:
        sol = _solve((_rhs_phase3(scene), _rhs_phase3(scene, np)), t0, t_end, beam, [], rtol,
                     method,
                     phases[-1].last_step if phases else None)
        _check(sol, scene, "phase III")
        phases.append(PhaseSolution(3, t0, t_end, sol.sol, sol.nfev))
    events["end"] = t_end
    return Trajectory(scene=scene, phases=tuple(phases), events=events,
                      release_state=release_state, rtol=rtol, method=method)


def _phase_trough(scene: Scene, beam: list[float], rtol: float, method: str,
                  phases: list[PhaseSolution], events: dict[str, float]
                  ) -> tuple[float, list[float]]:
    """Phase I, beam and counterweight with the projectile on the trough constraint, up to
    lift-off. Returns the lift-off time and the beam state there."""
    e, rel = scene.engine, scene.release
    t_rel = rel.time if rel.time is not None else math.inf
    ev = [_lift_off_event(scene), _sling_upright_event(scene)]
    sol = _solve((_rhs_phase1(scene), _rhs_phase1(scene, np)), 0.0, MAX_SHOT, beam, ev, rtol,
                 method)
    _check(sol, scene, "phase I")
    if sol.status != 1:
        raise TrebuchetInputError(f"{scene.source}: the projectile did not lift off within "
                                  f"{MAX_SHOT:g} s")
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
    return t_lift, list(sol.y_events[0][0])


def _phase_sling(scene: Scene, t0: float, beam: list[float], sling: list[float], rtol: float,
                 method: str, phases: list[PhaseSolution], events: dict[str, float]
                 ) -> tuple[float, list[float], list[float]]:
    """Phase II, the projectile in the sling, up to release. Returns the release time and the
    beam and sling states there."""
    rel = scene.release
    t_rel = rel.time if rel.time is not None else math.inf
    if t_rel <= t0:
        raise TrebuchetInputError(f"{scene.source}: [release] time = {t_rel:g} s: must come "
                                  f"after the start of phase II at {t0:.4g} s")
    ev = [_ground_event(scene)]
    if rel.time is not None:
        ev.append(_time_event(rel.time))
    if rel.velocity_angle is not None:
        ev.append(_velocity_angle_event(scene, rel.velocity_angle))
    t_stop = min(t_rel, MAX_SHOT) if rel.velocity_angle is None else MAX_SHOT
    th, ps, th_d, ps_d = beam
    ph, ph_d = sling
    sol = _solve((_rhs_phase2(scene), _rhs_phase2(scene, np)), t0, t_stop,
                 [th, ps, ph, th_d, ps_d, ph_d], ev, rtol,
                 method, phases[-1].last_step if phases else None)
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
    th, ps, ph, th_d, ps_d, ph_d = (float(v) for v in y_release)
    return t_release, [th, ps, th_d, ps_d], [ph, ph_d]


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


def engine_energy(run: pd.DataFrame, traj: Trajectory) -> np.ndarray:
    """Mechanical energy gained by the engine since rest, J: ``E_m + E_M + E_beam``, with the
    projectile's energy frozen at its release value once it flies (drag may take it after
    that). Zero for an exact solution: the drift of the integrator."""
    E_m = run["E_m"].to_numpy()
    if traj.release_state is not None:
        rs, e, s = traj.release_state, traj.scene.engine, traj.scene
        y_rest = 0.0
        if s.projectile == "sling":
            y_rest = s.start.H + e.L1 * math.sin(s.start.theta) + e.L4 * math.sin(s.start.phi)
        at_release = 0.5 * e.m * (rs["vx"] ** 2 + rs["vy"] ** 2) + e.m * s.g * (rs["y"] - y_rest)
        E_m = np.where(run["phase"].to_numpy() == 3, at_release, E_m)
    return E_m + run["E_M"].to_numpy() + run["E_beam"].to_numpy()


def simulate(scene: Scene, t_eval: Sequence[float] | np.ndarray | None = None, *,
             rtol: float | str = "default", method: str = "DOP853",
             after_release: float | None = None, dt: float = 1e-3) -> pd.DataFrame:
    """Simulate a shot and compute every force, torque, power and energy of the paper.

    Parameters
    ----------
    scene : Scene
        Engine, start pose, release rule, gravity.
    t_eval : array of s, optional
        Output times after the trigger. Default: every ``dt`` s, plus lift-off, release and the
        end. At an event time a row holds the phase that ends there.
    rtol : float or str
        Relative tolerance of the integrator (absolute tolerance ``rtol/100``), or a preset of
        :data:`ACCURACY`: ``"fast"`` (1e-6), ``"default"`` (1e-10: energy conserved to 1e-9 of
        ΔU), ``"precise"`` (1e-12). ``make bench`` measures what each costs and buys.
    method : str
        A ``scipy.integrate.solve_ivp`` method; DOP853 (default) suits this non-stiff system.
    after_release : float, optional
        Seconds of phase III (beam and counterweight after release) to simulate; default 0.5 s,
        or 1.5 s for a dry fire (which is phase III from the start).
    dt : float
        Output step of the default grid, s.

    Returns
    -------
    DataFrame with the columns of CONTRACT.md (and the extras of
    :func:`trebuchet.model.forces.loads`). ``attrs["events"]`` holds ``lift_off``,
    ``release`` and ``end`` (s; lift-off and release only where the scene has them);
    ``attrs["flight"]`` the flight (vacuum or drag, None for a dry fire);
    ``attrs["diagnostics"]`` the solver, tolerance, number of evaluations and energy drift.
    """
    rtol = resolve_rtol(rtol)
    traj = integrate(scene, rtol=rtol, method=method, after_release=after_release)
    times = default_times(traj, dt) if t_eval is None else np.asarray(t_eval, dtype=float)
    run = loads(traj.angles(times), scene, release_state=traj.release_state)
    _refuse_non_finite(run, scene)  # before attrs: pandas copies attrs on every column read
    drift = float(np.max(np.abs(engine_energy(run, traj)))) if len(run) else 0.0
    delta_u = scene.delta_U
    slack = slack_intervals(run)
    run.attrs["events"] = dict(traj.events)
    run.attrs["flight"] = (None if traj.release_state is None else flight_summary(
        traj.release_state, scene.g, scene.flight, scene.engine.m))
    run.attrs["diagnostics"] = {
        "method": method, "rtol": rtol, "nfev": traj.nfev,
        "energy_drift": drift, "energy_drift_rel": drift / delta_u, "delta_U": delta_u,
        "slack": slack, "advice": _advice(scene, traj),
    }
    for a, b in run.attrs["diagnostics"]["slack"]:
        warnings.warn(ModelValidityWarning(
            f"{scene.source}: the sling goes slack (tension below zero) from t = {a:.4g} s to "
            f"{b:.4g} s: a rigid sling cannot push, so the loads there are fiction"),
            stacklevel=2)
    return run


def slack_intervals(run: pd.DataFrame) -> list[tuple[float, float]]:
    """Intervals (s) where the sling holding the projectile would have to push
    (``sling_tension < 0``): the rigid-sling model is not valid there."""
    slack = (run["phase"].to_numpy() <= 2) & (run["sling_tension"].to_numpy() < 0.0)
    t = run["t"].to_numpy()
    edges = np.flatnonzero(np.diff(np.concatenate([[0], slack.astype(np.int8), [0]])))
    return [(float(t[a]), float(t[b - 1])) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def _advice(scene: Scene, traj: Trajectory) -> list[str]:
    """What the user can do about a costly or stiff scene."""
    advice = []
    e = scene.engine
    if traj.nfev > 5000 and not e.fixed_counterweight and e.L3 < 0.05 * e.L1:
        advice.append(
            f"L3 = {e.L3:g} m makes the counterweight's swing stiff ({traj.nfev} evaluations); "
            "if it barely swings, model it fixed to the beam ([engine] counterweight = "
            "\"fixed\"), or use method=\"Radau\"")
    return advice


# Columns that are undefined by design: the sling after release, the projectile of a dry fire.
_UNDEFINED_AFTER_RELEASE = ("phi", "phi_d", "phi_dd")
_UNDEFINED_DRY_FIRE = ("x_m", "y_m", "vx_m", "vy_m")


def _refuse_non_finite(run: pd.DataFrame, scene: Scene) -> None:
    """Output holds no NaN or infinity except where a quantity does not exist (the sling's
    angle after release, the projectile of a dry fire); anything else is refused."""
    floats = run.select_dtypes("float")
    bad = ~np.isfinite(floats.to_numpy())
    names = list(floats.columns)
    phase3 = run["phase"].to_numpy() == 3
    for name in _UNDEFINED_AFTER_RELEASE:
        if name in names:
            bad[phase3, names.index(name)] = False
    if scene.engine.m == 0.0:
        for name in _UNDEFINED_DRY_FIRE:
            if name in names:
                bad[:, names.index(name)] = False
    if bad.any():
        row, col = np.argwhere(bad)[0]
        t_bad = float(run["t"].to_numpy()[row])
        raise TrebuchetInputError(
            f"{scene.source}: the model breaks down at t = {t_bad:.4g} s ({names[col]} is not "
            "finite); the scene is outside what the equations of motion can describe")
