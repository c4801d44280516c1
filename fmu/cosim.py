"""Co-simulation of a shot: the in-process simulator answering communication steps.

The FMU's slave holds a :class:`Run` and calls these pure functions; nothing here is a copy of
the model. A run is the :func:`~trebuchet.model.simulate.integrate` trajectory of the scene
(dense output, events located to solver accuracy), so lift-off and release inside a
communication step are exact, and the outputs at any time are
:func:`~trebuchet.model.loads.loads` of :meth:`Trajectory.angles` at that time: the same rows
as ``simulate(scene, t_eval=..., after_release=after_release_for(t_stop))``.

A rising release command at communication time ``t_c`` before the trajectory's release
re-integrates the shot with ``scene.with_release(time=t_c, velocity_angle=<the scene's>)``.
Times are s after the trigger.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from trebuchet.fmu.interface import OUTPUTS
from trebuchet.model.loads import loads
from trebuchet.model.scene import Scene
from trebuchet.model.simulate import DEFAULT_AFTER_RELEASE, Trajectory, integrate

__all__ = ["Run", "Window", "after_release_for", "start_run", "command_release", "covering",
           "outputs", "window", "lookup", "OUTPUT_NAMES", "WINDOW_STEPS", "MATCH_ULPS"]

OUTPUT_NAMES: tuple[str, ...] = tuple(v.name for v in OUTPUTS)
WINDOW_STEPS = 256  # communication points evaluated at once (one call of the simulator's loads)
MATCH_ULPS = 8  # a precomputed time this close (in units in the last place) answers a request
_SLING = ("phi", "phi_d", "phi_dd")


@dataclass(frozen=True)
class Run:
    """A co-simulated shot: the scene in force (with a commanded release, if any), its
    trajectory, the phase III length it was integrated with (s; None: the simulator's
    default) and the accepted command time (s) or None."""

    scene: Scene
    trajectory: Trajectory
    after_release: float | None
    commanded_at: float | None = None


def after_release_for(t_stop: float | None) -> float | None:
    """Seconds of phase III the FMU integrates: enough to reach ``t_stop`` (s) whatever the
    release time, at least the simulator's default; None (the simulator's default) for an
    open end."""
    if t_stop is None or not math.isfinite(t_stop):
        return None
    return max(DEFAULT_AFTER_RELEASE, float(t_stop))


def start_run(scene: Scene, t_stop: float | None = None) -> Run:
    """Integrate ``scene`` for a co-simulation that ends at ``t_stop`` (s, None: open).

    Raises :class:`~trebuchet.errors.TrebuchetInputError` for a shot the simulator refuses.
    """
    after = after_release_for(t_stop)
    return Run(scene, integrate(scene, after_release=after), after)


def command_release(run: Run, t_c: float) -> tuple[Run, str | None]:
    """Apply a release command that rose at communication time ``t_c`` (s).

    Returns the run to continue with and, when the command has no effect, the reason (for
    the FMU's log): before lift-off the projectile lies in the trough, after release it has
    already gone.
    """
    ev = run.trajectory.events
    if "release" not in ev:
        return run, f"release command at t = {t_c:.9g} s ignored: a dry fire has no projectile"
    if t_c <= ev.get("lift_off", 0.0):
        return run, (f"release command at t = {t_c:.9g} s ignored: the projectile lies in the "
                     f"trough until lift-off at {ev['lift_off']:.9g} s")
    if t_c >= ev["release"]:
        return run, (f"release command at t = {t_c:.9g} s ignored: the projectile was "
                     f"released at {ev['release']:.9g} s")
    scene = run.scene.with_release(time=t_c, velocity_angle=run.scene.release.velocity_angle)
    traj = integrate(scene, after_release=run.after_release)
    return replace(run, scene=scene, trajectory=traj, commanded_at=t_c), None


def covering(run: Run, t: float) -> Run:
    """The run, re-integrated with a longer phase III if ``t`` (s) lies past its end."""
    traj = run.trajectory
    if t <= traj.t_end:
        return run
    flight_start = traj.events.get("release", 0.0)
    after = max(traj.t_end - flight_start, DEFAULT_AFTER_RELEASE)
    while flight_start + after < t:
        after *= 2.0
    return replace(run, trajectory=integrate(run.scene, after_release=after),
                   after_release=after)


def outputs(run: Run, t: float | np.ndarray) -> pd.DataFrame:
    """The FMU's outputs (:data:`OUTPUT_NAMES`) at times ``t`` (s), one row per time.

    The sling angles, undefined once the projectile has left, are 0 in phase 3.
    """
    times = np.atleast_1d(np.asarray(t, dtype=float))
    traj = run.trajectory
    rows = loads(traj.angles(times), run.scene, release_state=traj.release_state)
    out = rows.loc[:, list(OUTPUT_NAMES)].copy()
    free = out["phase"].to_numpy() == 3
    for name in _SLING:
        out.loc[free, name] = 0.0
    return out


@dataclass(frozen=True)
class Window:
    """Outputs precomputed at the communication points a master stepping by ``h`` will ask
    for next: ``times`` (s) and ``values`` (one row per time, columns :data:`OUTPUT_NAMES`)."""

    times: np.ndarray
    values: np.ndarray


def window(run: Run, t: float, h: float, n: int = WINDOW_STEPS) -> Window:
    """Outputs at ``t + k h`` (s; ``k = 0 .. n-1``, none past the trajectory's end): the
    communication points a master stepping by ``h`` asks for next. The first row is exactly
    at ``t``."""
    t_end = run.trajectory.t_end
    grid = t + h * np.arange(n) if h > 0.0 else np.array([t])
    grid = grid[(grid <= t_end) | (np.arange(grid.size) == 0)]
    return Window(grid, outputs(run, grid).to_numpy(dtype=float))


def lookup(run: Run, win: Window | None, t: float) -> np.ndarray | None:
    """The precomputed output row for a request at ``t`` (s), or None.

    A row answers if its time equals ``t`` to :data:`MATCH_ULPS` units in the last place
    (masters compute ``t0 + n h`` or ``t + h``; the two differ by rounding only) and no event
    (lift-off, release) lies between the two times, so the phase is the one at ``t``.
    """
    if win is None or win.times.size == 0:
        return None
    i = int(np.searchsorted(win.times, t))
    for j in (i - 1, i):
        if 0 <= j < win.times.size:
            tj = float(win.times[j])
            if tj == t:
                return win.values[j]
            if abs(tj - t) <= MATCH_ULPS * np.spacing(max(abs(t), abs(tj))):
                lo, hi = min(t, tj), max(t, tj)
                events = (run.trajectory.events.get(k) for k in ("lift_off", "release"))
                if not any(e is not None and lo <= e <= hi for e in events):
                    return win.values[j]
    return None
