"""The figures of one shot without its table: release, range, peak loads, clearance.

:func:`shot_figures` is the summary-only path of sweeps and of the optimiser
(:mod:`trebuchet.model.design`), with no DataFrame and no table of rows. Where the C engine
runs, the shot, its events and the search of its peaks over the continuous shot are one call
of the generated C (:func:`~trebuchet.model.c_peaks.design_peaks`; :func:`designs_figures` and
:func:`designs_values` take many designs a call); elsewhere (no compiler, or a shot the C
refuses) it integrates the shot with :func:`~trebuchet.model.simulate.integrate` and the
numba kernel of :mod:`trebuchet.model.summary_kernel` searches the integrator's own steps,
the same search. The peaks are then the extrema over the continuous shot, located on the
dense output to ~1e-6 s. Given an output step ``dt`` it instead evaluates every load on the
rows of :func:`~trebuchet.model.simulate.simulate`'s table (the same functions, the same
times) and takes their extrema, as a table of that step would show them.

Windows: the peaks cover the shot from the trigger to ``after_release`` s past the release
(0.5 s by default, as ``simulate``); the counterweight's clearance covers it to
:data:`CLEARANCE_WINDOW` s past the release, whatever ``after_release`` (a dry fire: the
whole simulated swing).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from trebuchet.model import c_engine
from trebuchet.model import kinematics as kin
from trebuchet.model.c_peaks import DESIGN_NAMES, design_peaks
from trebuchet.model.c_summary import summary_and_times
from trebuchet.model.flight import flight_summary
from trebuchet.model.forces import projectile_energy, rest_energies
from trebuchet.model.kernel_phase import KernelSolution
from trebuchet.model.loads import load_columns
from trebuchet.model.scene import Scene
from trebuchet.model.shot_kernel import jit_engine
from trebuchet.model.simulate import (
    DEFAULT_AFTER_RELEASE,
    DEFAULT_DRY_FIRE,
    LOST_COLUMNS,
    Trajectory,
    default_times,
    engine_energy,
    integrate,
    resolve_rtol,
)
from trebuchet.model.summary_kernel import EXTREMA, reduce_phases

__all__ = ["FIGURES", "CLEARANCE_WINDOW", "ShotFigures", "shot_figures", "designs_figures",
           "designs_values", "throw_status",
           "STATUS_OK", "STATUS_BACKWARD", "STATUS_GROUND"]

#: s past the release over which ``cw_clearance`` is taken.
CLEARANCE_WINDOW = 0.5

#: The figures of a shot, with their units (SI). Peaks are maxima of the magnitude over the
#: shot, trigger to ``after_release`` s past the release.
FIGURES: dict[str, str] = {
    "lift_off": "s, lift-off of the projectile from the trough",
    "release_time": "s, release after the trigger",
    "release_speed": "m/s, projectile speed at release",
    "release_angle": "rad, projectile velocity above horizontal at release",
    "release_angle_deg": "°, the same in degrees (as the scene file's _deg keys)",
    "release_height": "m, projectile height at release",
    "range": "m, range in vacuum from the pivot",
    "F_S_peak": "N, peak |F_S| (sling on projectile)",
    "F_H_peak": "N, peak |F_H| (beam on counterweight at the hinge)",
    "F_R_peak": "N, peak |F_R| (bearing reaction at the pivot)",
    "F_R_perp_peak": "N, peak |F_R_perp| (reaction across the beam: bending)",
    "torque_peak": "N m, peak |torque| on the beam about the pivot",
    "sling_tension_min": "N, least sling tension while held (negative: slack, model invalid)",
    "energy_share": "1, projectile's mechanical energy at release over ΔU",
    "energy_drift_rel": "1, max |E_m + E_M + E_beam| over ΔU (solver accuracy)",
    "cw_clearance": "m, lowest height of the counterweight's centre above the ground, "
                    f"trigger to {CLEARANCE_WINDOW:g} s past the release",
    "E_loss_release": "J, heat made by friction in the bearings (pivot and hinge) by the "
                      "release",
    "loss_share": "%, the same over ΔU",
}

STATUS_OK, STATUS_BACKWARD, STATUS_GROUND = "ok", "backward", "ground"

#: The kernel's extremum behind each peak figure, and its sign.
_FROM_EXTREMA = {"F_S_peak": ("F_S_abs", 1.0), "F_H_peak": ("F_H_abs", 1.0),
                 "F_R_peak": ("F_R_abs", 1.0), "F_R_perp_peak": ("F_R_perp_abs", 1.0),
                 "torque_peak": ("torque_abs", 1.0), "sling_tension_min": ("-sling_tension", -1.0),
                 "cw_clearance": ("-y_M", -1.0)}


@dataclass(frozen=True)
class ShotFigures:
    """The :data:`FIGURES` of one shot (SI units, NaN where the shot has no such thing: a dry
    fire has no release) and ``times``, the time (s) at which each extremum
    (``*_peak``, ``sling_tension_min``, ``cw_clearance``) was found."""

    lift_off: float
    release_time: float
    release_speed: float
    release_angle: float
    release_angle_deg: float
    release_height: float
    range: float
    F_S_peak: float
    F_H_peak: float
    F_R_peak: float
    F_R_perp_peak: float
    torque_peak: float
    sling_tension_min: float
    energy_share: float
    energy_drift_rel: float
    cw_clearance: float
    E_loss_release: float = 0.0
    loss_share: float = 0.0
    times: Mapping[str, float] = field(default_factory=dict, compare=False)

    def as_dict(self) -> dict[str, float]:
        """The figures as ``{name: value}`` in the order of :data:`FIGURES`."""
        values = vars(self)
        return {k: float(values[k]) for k in FIGURES}

    @property
    def status(self) -> str:
        """:func:`throw_status` of this shot."""
        return throw_status(self.release_angle, self.range)


def throw_status(release_angle: float, range_: float) -> str:
    """How the projectile leaves: ``"backward"`` when it lands behind the pivot (``range_`` <
    0 m) or leaves climbing backward (``release_angle`` beyond 90°, rad); ``"ground"`` when it
    is thrown downward, into the ground (``release_angle`` below 0); else ``"ok"`` (a dry fire,
    with NaN for both, is ``"ok"``)."""
    if range_ < 0.0:
        return STATUS_BACKWARD
    if release_angle < 0.0:
        return STATUS_GROUND
    if release_angle > 0.5 * math.pi:
        return STATUS_BACKWARD
    return STATUS_OK


def _windows(scene: Scene, after_release: float | None) -> tuple[float, float]:
    """s past the release over which the peaks are taken, and s of phase III integrated (at
    least :data:`CLEARANCE_WINDOW`); a dry fire: its whole shot, both."""
    if scene.projectile == "none":
        after = DEFAULT_DRY_FIRE if after_release is None else after_release
        return after, after
    after = DEFAULT_AFTER_RELEASE if after_release is None else after_release
    return after, max(after, CLEARANCE_WINDOW)


def shot_figures(scene: Scene, *, rtol: float | str = "default",
                 after_release: float | None = None, dt: float | None = None) -> ShotFigures:
    """The figures of a shot of ``scene``, without a table.

    Parameters
    ----------
    scene : Scene
    rtol : float or str
        Integrator tolerance or a preset of ``simulate.ACCURACY`` (as :func:`simulate`).
    after_release : float, optional
        s of phase III over which the peaks are taken (default 0.5 s; a dry fire 1.5 s).
        Phase III is integrated at least :data:`CLEARANCE_WINDOW` s for ``cw_clearance``.
    dt : float, optional
        None (default): extrema over the continuous shot, reduced on the dense output.
        A step in s: extrema over the rows of ``simulate(scene, dt=dt)``'s table.

    Raises TrebuchetInputError where :func:`simulate` would (a design the model refuses).
    """
    rtol = resolve_rtol(rtol)
    if c_engine.available(quiet=True):
        if dt is not None:  # the table's rows, reduced in C
            figures, times = summary_and_times(scene, rtol=rtol, dt=dt,
                                               after_release=after_release)
            return ShotFigures(**figures, times=times)
        figures = designs_figures([scene], rtol=rtol, after_release=after_release)[0]
        if figures is not None:
            return figures
    after, integrate_after = _windows(scene, after_release)  # the C refused (numba words it)
    traj = integrate(scene, rtol=rtol, after_release=integrate_after)
    t_rel = traj.events.get("release")
    t_hi = traj.t_end if t_rel is None else t_rel + after
    t_clear = traj.t_end if t_rel is None else t_rel + CLEARANCE_WINDOW
    rest = rest_energies(scene)
    em_release = 0.0
    if traj.release_state is not None:
        rs = traj.release_state
        em_release = projectile_energy((rs["vx"], rs["vy"]), rs["y"], scene.engine,
                                       scene.g) - rest[0]
    if dt is None and all(isinstance(p.sol, KernelSolution | c_engine.CPhase)
                          for p in traj.phases):  # the steps, of the numba kernel or the C
        values, times = reduce_phases(list(traj.phases), jit_engine(scene.engine), scene.g,
                                      scene.start.H, rest, em_release, t_hi, t_clear)
    else:
        extrema = _extrema_on_rows(traj, t_hi, t_clear, dt or 1e-3)
        values, times = zip(*(extrema[name] for name in EXTREMA), strict=True)
    figures, times = _figure_values(
        scene, traj.events.get("lift_off", math.nan), math.nan if t_rel is None else t_rel,
        traj.release_state, em_release, math.nan if t_rel is None else _lost_by(traj, t_rel),
        values, times)
    return ShotFigures(**figures, times=times)


def designs_figures(scenes: Sequence[Scene], *, rtol: float | str = "default",
                    after_release: float | None = None) -> list[ShotFigures | None]:
    """The figures of each scene's shot over the continuous shot, as :func:`shot_figures`,
    all in one call of the C engine (:func:`~trebuchet.model.c_peaks.design_peaks`); None
    for a scene the C refuses (:func:`shot_figures` words the refusal). Raises
    EngineUnavailable without the C."""
    return [None if found is None else ShotFigures(**found[0], times=found[1])
            for found in designs_values(scenes, rtol=rtol, after_release=after_release)]


def designs_values(scenes: Sequence[Scene], *, rtol: float | str = "default",
                   after_release: float | None = None
                   ) -> list[tuple[dict[str, float], dict[str, float]] | None]:
    """:func:`designs_figures` as ``(figures, times)`` dicts (:meth:`ShotFigures.as_dict`
    and :attr:`ShotFigures.times`): a sweep's rows, without an object a design."""
    rtol = resolve_rtol(rtol)
    windows = [_windows(sc, after_release) for sc in scenes]
    out, status = design_peaks(scenes, rtol, [w[0] for w in windows],
                               [w[1] for w in windows], CLEARANCE_WINDOW)
    found: list[tuple[dict[str, float], dict[str, float]] | None] = []
    for sc, row, refused in zip(scenes, out.tolist(), status.tolist(), strict=True):
        if refused:
            found.append(None)
            continue
        t_rel = row[_T_RELEASE]
        rs = None if math.isnan(t_rel) else dict(zip(_RELEASE_KEYS, row[_RELEASE], strict=True))
        found.append(_figure_values(sc, row[_T_LIFT], t_rel, rs, row[_E_M_RELEASE],
                                    row[_LOSS_RELEASE], row[:_N_EXTREMA],
                                    row[_N_EXTREMA:_TIMES]))
    return found


_N_EXTREMA, _TIMES = len(EXTREMA), 2 * len(EXTREMA)
_T_LIFT, _T_RELEASE, _E_M_RELEASE, _LOSS_RELEASE = (
    DESIGN_NAMES.index(k) for k in ("t_lift", "t_release", "E_m_release", "loss_release"))
_RELEASE = slice(DESIGN_NAMES.index("release_t"), DESIGN_NAMES.index("release_vy") + 1)
_RELEASE_KEYS = ("t", "x", "y", "vx", "vy")
#: Each peak figure, the index of its extremum in EXTREMA, and its sign.
_PEAKS = tuple((name, EXTREMA.index(key), sign) for name, (key, sign) in _FROM_EXTREMA.items())
_DRIFT = EXTREMA.index("energy_sum_abs")
_NO_FLIGHT = dict.fromkeys(("release_speed", "release_angle", "release_angle_deg",
                            "release_height", "range"), math.nan)


def _figure_values(scene: Scene, t_lift: float, t_rel: float, release_state: dict | None,
                   em_release: float, lost: float, values: Sequence[float],
                   times: Sequence[float]) -> tuple[dict[str, float], dict[str, float]]:
    """The :data:`FIGURES` (in order) and the time of each extremum, from the events (s, NaN:
    none), the projectile's state at release (None: a dry fire), its energy over rest then
    and the friction's heat by then (J), and the
    :data:`~trebuchet.model.summary_kernel.EXTREMA` with their times (s)."""
    nan, delta_u = math.nan, scene.delta_U
    out = {"lift_off": t_lift, "release_time": t_rel}
    if release_state is None:
        out.update(_NO_FLIGHT)
    else:
        fl = flight_summary(release_state, scene.g, scene.flight, scene.engine.m)
        out.update(release_speed=fl["release_speed"], release_angle=fl["release_angle"],
                   release_angle_deg=math.degrees(fl["release_angle"]),
                   release_height=fl["release_height"], range=fl["range"])
    for name, i, sign in _PEAKS:
        v = sign * values[i]
        out[name] = v if math.isfinite(v) else nan
    out["energy_share"] = nan if release_state is None else em_release / delta_u
    out["energy_drift_rel"] = values[_DRIFT] / delta_u
    out["cw_clearance"] = out.pop("cw_clearance")  # the order of FIGURES
    out["E_loss_release"], out["loss_share"] = lost, 100.0 * lost / delta_u
    return out, {name: float(times[i]) for name, i, _ in _PEAKS}


def _lost_by(traj: Trajectory, t: float) -> float:
    """Heat made by friction at pivot and hinge from the trigger to ``t`` (s), J: the
    integrated lost energies (0 without friction)."""
    cols = traj.angle_columns(np.array([t]), lost=True)
    return float(cols.get("E_loss_pivot", [0.0])[0] + cols.get("E_loss_hinge", [0.0])[0])


def _extrema_on_rows(traj: Trajectory, t_hi: float, t_clear: float,
                     dt: float) -> dict[str, tuple[float, float]]:
    """The :data:`~trebuchet.model.summary_kernel.EXTREMA` and their times over the rows
    ``simulate`` would tabulate at step ``dt`` (s) up to ``t_hi``, the clearance up to
    ``t_clear``: the loads of every row by :func:`load_columns`, as ``simulate``."""
    scene = traj.scene
    times = default_times(traj, dt)
    times = np.unique(np.append(times[times <= t_hi], t_hi))
    angles = traj.angle_columns(times, lost=True)  # the integrated heat, as simulate's
    lost = {name: angles.pop(name) for name in LOST_COLUMNS if name in angles}
    cols = load_columns(angles, scene, release_state=traj.release_state, lost=lost or None)
    e, H = scene.engine, scene.start.H
    th, ps = cols["theta"], cols["psi"]
    y_M = kin.counterweight_position_xy(np.cos(th), np.sin(th), np.cos(ps), np.sin(ps), e, H)[1]
    t = cols["t"]
    if t_clear > t_hi:  # the clearance's window runs on past the peaks' rows
        extra = default_times(traj, dt)
        extra = extra[(extra > t_hi) & (extra <= t_clear)]
        if extra.size:
            more = traj.angle_columns(np.append(extra, t_clear))
            y_more = kin.counterweight_position_xy(
                np.cos(more["theta"]), np.sin(more["theta"]), np.cos(more["psi"]),
                np.sin(more["psi"]), e, H)[1]
            t, y_M = np.append(t, more["t"]), np.append(y_M, y_more)
    held = cols["phase"] <= 2
    quantities = {
        "F_S_abs": (cols["t"], cols["F_S_abs"]), "F_H_abs": (cols["t"], cols["F_H_abs"]),
        "F_R_abs": (cols["t"], cols["F_R_abs"]),
        "F_R_perp_abs": (cols["t"], np.abs(cols["F_R_perp"])),
        "torque_abs": (cols["t"], np.abs(cols["torque"])),
        "-sling_tension": (cols["t"][held], -cols["sling_tension"][held]),
        "-y_M": (t[t <= t_clear], -y_M[t <= t_clear]),
        "energy_sum_abs": (cols["t"], np.abs(engine_energy(cols, traj))),
    }
    out = {}
    for name, (tt, v) in quantities.items():
        if v.size == 0:
            out[name] = (-math.inf, math.nan)
            continue
        i = int(np.argmax(v))
        out[name] = (float(v[i]), float(tt[i]))
    return out
