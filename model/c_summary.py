"""The figures of a design without its table, reduced in the generated C: sweeps and the optimiser.

:func:`shot_summary` integrates the shot in the C engine (:mod:`trebuchet.model.c_engine`) and
reduces every figure of ``sweep.summarize`` in C over the rows ``simulate`` would tabulate at
the same output step (the same times, the same generated formulas): no DataFrame, no table,
and the same numbers as ``summarize(simulate(scene))`` to rounding. It adds the counterweight's
clearance (``cw_clearance``: the lowest height of its centre above the ground from the trigger
to :data:`CLEARANCE_WINDOW` s past the release, on the rows at the same step) and the heat the
bearings' friction has made by the release (``E_loss_release``, J, and ``loss_share``, % of ΔU;
0 without friction): the figures of ``shot_summary.FIGURES``, whose ``shot_figures`` takes
them from here when asked for an output step.

A design the model refuses raises the :class:`~trebuchet.core.errors.TrebuchetInputError` that
``simulate`` raises (the numba kernel words it, as ``simulate`` does); without a C compiler
:class:`~trebuchet.model.c_engine.EngineUnavailable` is raised (the caller's own path, such as
``sweep.summarize(simulate(...))``, gives the same figures).
"""

from __future__ import annotations

import math

from trebuchet.model import c_engine
from trebuchet.model.flight import flight_summary
from trebuchet.model.output_size import check_output_size
from trebuchet.model.scene import Scene
from trebuchet.model.settings import DEFAULT_AFTER_RELEASE
from trebuchet.model.simulate import DEFAULT_DRY_FIRE, integrate, resolve_rtol, simulate

__all__ = ["SUMMARY_KEYS", "EXTREMA", "CLEARANCE_WINDOW", "shot_summary", "summary_and_times"]

#: s past the release over which ``cw_clearance`` is taken (a dry fire: the whole swing).
CLEARANCE_WINDOW = 0.5

#: The keys of :func:`shot_summary`, in order: the figures of
#: ``shot_summary.FIGURES`` (their units there), the sweep's ``SUMMARY_COLUMNS``.
SUMMARY_KEYS = ("lift_off", "release_time", "release_speed", "release_angle",
                "release_angle_deg", "release_height", "range", "F_S_peak", "F_H_peak",
                "F_R_peak", "F_R_perp_peak", "torque_peak", "sling_tension_min", "energy_share",
                "energy_drift_rel", "cw_clearance", "E_loss_release", "loss_share")

#: The keys of :func:`shot_summary` that are extrema of the rows, with a time.
EXTREMA = ("F_S_peak", "F_H_peak", "F_R_peak", "F_R_perp_peak", "torque_peak",
           "sling_tension_min", "cw_clearance")


def shot_summary(scene: Scene, *, rtol: float | str = "default", dt: float = 1e-3,
                 after_release: float | None = None) -> dict[str, float]:
    """The :data:`SUMMARY_KEYS` of a shot of ``scene`` (SI units; NaN where the shot has no
    such thing: a dry fire has no release, a shot from the sling no lift-off); see
    :func:`summary_and_times`."""
    return summary_and_times(scene, rtol=rtol, dt=dt, after_release=after_release)[0]


def summary_and_times(scene: Scene, *, rtol: float | str = "default", dt: float = 1e-3,
                      after_release: float | None = None
                      ) -> tuple[dict[str, float], dict[str, float]]:
    """The :data:`SUMMARY_KEYS` of a shot of ``scene`` and the time (s) of each extremum of
    :data:`EXTREMA` (the first row that holds it; NaN where there is none).

    Parameters
    ----------
    scene : Scene
    rtol : float or str
        Integrator tolerance or a preset of ``simulate.ACCURACY``, as :func:`simulate`.
    dt : float
        Output step (s) of the rows the peaks are taken over, as ``simulate``'s ``dt``.
    after_release : float, optional
        s of phase III the peaks cover (default 0.5 s; a dry fire 1.5 s), as ``simulate``.

    Raises TrebuchetInputError where ``simulate`` would, EngineUnavailable without the C.
    """
    rtol = resolve_rtol(rtol)
    dry = scene.projectile == "none"
    after = after_release if after_release is not None else (
        DEFAULT_DRY_FIRE if dry else DEFAULT_AFTER_RELEASE)
    check_output_size(dt, after)
    c_engine.library()  # EngineUnavailable without a compiler: the caller's own path then
    shot = c_engine.CShot.start(scene, rtol, after)
    if shot is None:  # refused: the numba kernel words the refusal, as simulate does
        integrate(scene, rtol=rtol, method="numba-DOP853", after_release=after)
        raise RuntimeError(f"{scene.source}: the C engine refused the shot "
                           f"({shot_refusal(scene, rtol, after)}) where the numba kernel did not")
    t_clear = shot.t_end if dry else shot.t_release + CLEARANCE_WINDOW
    fig, when, finite = shot.figures(dt, t_clear)
    if not finite:  # simulate names the column and the time
        simulate(scene, rtol=rtol, dt=dt, after_release=after, method="c-DOP853")
        raise RuntimeError(f"{scene.source}: a row of the shot is not finite where simulate's "
                           "table found none")
    delta_u = scene.delta_U
    rs = shot.release_state
    fl = flight_summary(rs, scene.g, scene.flight, scene.engine.m) if rs else None
    nan = math.nan
    return {
        "lift_off": shot.t_lift, "release_time": shot.t_release,
        "release_speed": fl["release_speed"] if fl else nan,
        "release_angle": fl["release_angle"] if fl else nan,
        "release_angle_deg": math.degrees(fl["release_angle"]) if fl else nan,
        "release_height": fl["release_height"] if fl else nan,
        "range": fl["range"] if fl else nan,
        **{k: fig[k] for k in ("F_S_peak", "F_H_peak", "F_R_peak", "F_R_perp_peak",
                               "torque_peak", "sling_tension_min")},
        "energy_share": fig["E_m_release"] / delta_u,
        "energy_drift_rel": fig["energy_drift"] / delta_u,
        "cw_clearance": fig["cw_clearance"],
        "E_loss_release": fig["loss_at_release"],
        "loss_share": 100.0 * fig["loss_at_release"] / delta_u,
    }, {k: when[k] for k in EXTREMA}


def shot_refusal(scene: Scene, rtol: float, after_release: float) -> str:
    """The C engine's own reason for refusing the shot (its words, not ``simulate``'s)."""
    return c_engine.CShot(scene, rtol, after_release).refusal
