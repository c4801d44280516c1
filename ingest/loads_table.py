"""The loads table of a smoothed log: phases, loads with their sd, lift-off, checks.

:func:`loads_from_smoothed` takes the output of
:func:`~trebuchet.ingest.smoothing.smooth.smooth` (the angles, rates and accelerations with
their covariance, the events the smoothing found or was given) to the frame of
:func:`~trebuchet.ingest.reconstruct.reconstruct`: the phase of each row
(:func:`~.state_loads.shot_phases`), every load of :func:`trebuchet.model.loads.loads` on it
(:func:`~.state_loads.evaluate_load_columns`) and its sd (:mod:`.uncertainty`, plus the
chance that a row next to an event lies in the other phase,
:func:`~.state_loads.event_variance`), lift-off where the trough's
normal force reaches zero (:func:`detect_lift_off`), the resolution advisory and the
geometry findings. Units: SI.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from trebuchet.ingest.advisory import (
    ADVISED,
    peak_width_advisories,
    resolution_advisories,
    smoother_bandwidth,
)
from trebuchet.ingest.events.lift_off import (
    gap_widened_sd,
    lift_off_choice,
    lift_off_sd,
    lift_off_time,
    offset_widened_sd,
    rest_offset,
    timing_widened_sd,
)
from trebuchet.ingest.events.trough_departure import StoneLiftOff
from trebuchet.ingest.reconstruct_options import ReconstructOptions, propagation_order
from trebuchet.ingest.reconstruction import Reconstruction
from trebuchet.ingest.scene_fit import geometry_findings
from trebuchet.ingest.smoothing.result import smoothing_of
from trebuchet.ingest.smoothing.smooth import ANGLES, SUFFIXES
from trebuchet.ingest.state_loads import (
    evaluate_load_columns,
    event_variance,
    flight_carry,
    shot_phases,
)
from trebuchet.ingest.uncertainty import chunk_rows, propagate
from trebuchet.model.scene import Scene
from trebuchet.model.simulate import simulate

__all__ = ["STATE_COLUMNS", "state_frame", "detect_lift_off", "loads_from_smoothed",
           "ShotEvents", "shot_events"]

STATE_COLUMNS = [a + s for a in ANGLES for s in SUFFIXES]


def state_frame(est: pd.DataFrame) -> pd.DataFrame:
    """A plain frame (no attrs: pandas copies attrs on every operation) of t and the nine
    smoothed quantities."""
    cols = {"t": est["t"].to_numpy(dtype=float)}
    cols |= {c: est[c].to_numpy(dtype=float) for c in STATE_COLUMNS}
    return pd.DataFrame(cols)


def _release_within_sling_track(t: np.ndarray, phi: np.ndarray, release: float) -> float:
    """A detected release (s) before the first row after the sling track's end (that row
    has no sling angle, so it is released); one at or after that row goes halfway from the
    track's last frame to it. A release inside the last interval (the fitted time a
    tracked stone leaves its sling's circle) stands."""
    ok = np.flatnonzero(np.isfinite(phi))
    if ok.size == 0 or ok[-1] >= t.size - 1:
        return release
    last = int(ok[-1])
    if release < t[last + 1]:
        return release
    return float(0.5 * (t[last] + t[last + 1]))


# ----------------------------------------------------------------------------- main


def detect_lift_off(state: pd.DataFrame, cov: dict[str, np.ndarray], scene: Scene,
                     trigger: float | None, release: float | None,
                     options: ReconstructOptions) -> tuple[float | None, float]:
    """Lift-off (s, log time) and its sd (s) from the phase-I normal force on every row;
    the sd widened by the shift the angles' common offset at rest (the log's θ at rest
    against the scene's start θ: a camera's roll) makes (:func:`.events.lift_off.
    offset_widened_sd`)."""
    t = state["t"].to_numpy()
    trial = shot_phases(t, scene, trigger, None, None)
    trial[trial == 3] = 1
    fn = evaluate_load_columns(state, trial, scene, options.form, options.trough)["F_N"]
    when = lift_off_time(t, fn, trigger, release)
    if when is None:
        return None, float("nan")
    i = int(np.clip(np.searchsorted(t, when), 1, t.size - 1))
    rows = np.arange(max(i - 1, 0), min(i + 1, t.size))
    sub = state.iloc[rows].reset_index(drop=True)
    sub_cov = {a: c[rows] for a, c in cov.items()}
    # the trial phases have no phase 3, so the rows are independent: one stacked call
    prop = propagate(lambda s: evaluate_load_columns(s, np.resize(trial[rows], len(s)), scene,
                                                     options.form, options.trough),
                     sub, sub_cov, ["F_N"], order=propagation_order(options), stacked=True)
    sd = lift_off_sd(t[rows], prop.value[:, 0], prop.sd[:, 0], when)
    offset = rest_offset(t, state["theta"].to_numpy(), trigger, scene.start.theta)
    if np.isfinite(offset) and offset != 0.0:  # the angles' common offset moves F_N's zero
        shifted = state.assign(theta=state["theta"].to_numpy() - offset)
        fn_shifted = evaluate_load_columns(shifted, trial, scene, options.form,
                                           options.trough)["F_N"]
        sd = offset_widened_sd(sd, when, lift_off_time(t, fn_shifted, trigger, release))
    return when, sd


@dataclass(frozen=True)
class ShotEvents:
    """The events of a smoothed log as the loads table uses them: ``times`` (trigger,
    lift-off, release; s, log time, or None), their ``sd`` (s; 0 given, NaN not sought),
    ``sources`` (phrases), and the ``notes`` and ``warnings`` (sentences) their
    decisions gave."""

    times: dict[str, float | None]
    sd: dict[str, float]
    sources: dict[str, str]
    notes: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()


def _lift_off(state: pd.DataFrame, cov: dict[str, np.ndarray], scene: Scene,
              given: Mapping[str, float | None], trigger: float | None,
              release: float | None, options: ReconstructOptions,
              stone_lift: StoneLiftOff | None, tracked: np.ndarray | None,
              trigger_sd: float = 0.0) -> tuple[float | None, float, str, tuple, tuple]:
    """Lift-off (s or None), its sd (s), source, notes and warnings: given, or the normal
    force's zero, its sd widened where θ or ψ is not tracked near it
    (:func:`~.events.lift_off.gap_widened_sd`), weighed with the stone's departure from
    the trough (:func:`~.events.lift_off.lift_off_choice`), and widened where it lies far
    from the scene's own lift-off (:func:`~.events.lift_off.timing_widened_sd`)."""
    if scene.projectile != "trough":
        return None, float("nan"), f"no trough (projectile {scene.projectile!r})", (), ()
    if "lift_off" in given:
        lift = given["lift_off"]
        return lift, 0.0, "given" if lift is not None else "given as none", (), ()
    lift, sd = detect_lift_off(state, cov, scene, trigger, release, options)
    if lift is None:
        return None, sd, "the normal force never reaches zero before release", (), ()
    notes: list[str] = []
    warned: list[str] = []
    if tracked is not None:
        sd, said = gap_widened_sd(state["t"].to_numpy(dtype=float), tracked[:2], lift, sd)
        notes += [said] if said else []
    source = "trough normal force reaches zero"
    if stone_lift is not None and stone_lift.time is not None:
        choice = lift_off_choice(lift, sd, stone_lift.time, stone_lift.sd)
        lift, sd, source = choice.time, choice.sd, choice.source
        notes += [n for n in (choice.note, choice.warning) if n is not None]
        warned += [] if choice.warning is None else [choice.warning]
    if trigger is not None:
        span = simulate(scene, t_eval=[0.0]).attrs["events"].get("lift_off")
        if span is not None:
            frame = float(np.median(np.diff(state["t"].to_numpy(dtype=float))))
            sd, said = timing_widened_sd(lift, sd, trigger + span, span, frame,
                                         float(np.nan_to_num(trigger_sd)))
            notes += [said] if said else []
            warned += [said] if said else []
    return lift, sd, source, tuple(notes), tuple(warned)


def shot_events(est: pd.DataFrame, state: pd.DataFrame, cov: dict[str, np.ndarray],
                scene: Scene, given: Mapping[str, float | None], options: ReconstructOptions,
                release_sd: float | None, stone_lift: StoneLiftOff | None,
                tracked: np.ndarray | None = None) -> ShotEvents:
    """The trigger and release of the smoothing (or ``given``), a release moved inside the
    sling's track (:func:`_release_within_sling_track`), their sd, and lift-off
    (:func:`_lift_off`); see :func:`loads_from_smoothed`."""
    t = est["t"].to_numpy(dtype=float)
    fit = smoothing_of(est)
    found = dict(fit.events)
    sources = dict(fit.event_sources)
    trigger = given["trigger"] if "trigger" in given else found.get("trigger")
    release = given["release"] if "release" in given else found.get("release")
    if scene.projectile == "none":
        release = None
    elif release is not None and "release" not in given and release_sd is None:
        # the smoother's own search (a source's release stands: the sling's track may
        # have a gap just before it)
        release = _release_within_sling_track(t, est["phi"].to_numpy(dtype=float), release)
    sd_event = options.event_sd_frames * float(np.median(np.diff(t)))
    sd = {"trigger": 0.0 if "trigger" in given or trigger is None
          else fit.event_sd.get("trigger", sd_event),
          "release": 0.0 if "release" in given or release is None
          else (sd_event if release_sd is None else release_sd)}
    lift, sd["lift_off"], sources["lift_off"], notes, warned = _lift_off(
        state, cov, scene, given, trigger, release, options, stone_lift, tracked,
        sd["trigger"])
    return ShotEvents({"trigger": trigger, "lift_off": lift, "release": release}, sd, sources,
                      notes, warned)


def _table(est: pd.DataFrame, state: pd.DataFrame, t: np.ndarray, trigger: float | None,
           phase: np.ndarray, names: list[str], values: np.ndarray, sd: np.ndarray
           ) -> pd.DataFrame:
    """The frame of :func:`loads_from_smoothed`: ``t``, ``t_shot``, ``phase``, the smoothed
    angles, the loads ``names`` (``values`` (n, m)) and every column's sd."""
    out: dict[str, np.ndarray] = {"t": t, "t_shot": t - (trigger if trigger is not None
                                                         else t[0]), "phase": phase}
    for c in STATE_COLUMNS:  # the smoothed angles (phase-I loads may use φ from θ)
        out[c] = state[c].to_numpy()
    for j, c in enumerate(names):
        out[c] = values[:, j]
    for c in STATE_COLUMNS:
        out[c + "_sd"] = est[c + "_sd"].to_numpy(dtype=float)
    for j, c in enumerate(names):
        out[c + "_sd"] = sd[:, j]
    return pd.DataFrame(out, index=est.index)


def loads_from_smoothed(est: pd.DataFrame, scene: Scene, *,
                        events: Mapping[str, float | None] | None = None,
                        options: ReconstructOptions | None = None,
                        release_sd: float | None = None,
                        lines: np.ndarray | None = None,
                        stone_lift: StoneLiftOff | None = None,
                        tracked: np.ndarray | None = None) -> pd.DataFrame:
    """Every load and its sd from the output of :func:`~trebuchet.ingest.smoothing.smooth.smooth`.

    ``lines``: the file's line number of each row (``read_log``'s ``ReadLog.lines``); the
    advisories and validity findings then name rows by them, as the reader's notes do.

    ``events``: given event times (s, log time; None = no such event) overriding those in
    the smoothing's and the lift-off detection; ``release_sd`` (s): sd of the
    release time in ``est`` if known (default ``event_sd_frames`` frames);
    ``stone_lift``: the stone's departure from the trough
    (:func:`~.events.trough_departure.stone_lift_off`), weighed with the normal force's
    zero (:func:`~.events.lift_off.lift_off_choice`); ``tracked`` (3, n) bool: which of θ,
    ψ, φ the log tracked on each row (an untracked one near lift-off widens its sd).
    Returns the frame of :func:`reconstruct` (without the log's own attrs).
    """
    options = options or ReconstructOptions()
    t = est["t"].to_numpy(dtype=float)
    state = state_frame(est)
    fit = smoothing_of(est)
    cov = {a: np.asarray(c, dtype=float)[:, :3, :3] for a, c in fit.cov.items()}
    ev = shot_events(est, state, cov, scene, dict(events or {}), options, release_sd,
                     stone_lift, tracked)
    trigger, release = ev.times["trigger"], ev.times["release"]
    phase = shot_phases(t, scene, trigger, ev.times["lift_off"], release)
    prop = propagate(lambda s: evaluate_load_columns(s, phase[np.asarray(s.index)], scene,
                                                     options.form, options.trough),
                     state, cov, order=propagation_order(options), chunk=chunk_rows(len(state)),
                     carry=flight_carry(phase), order_names=list(ADVISED), columns=True)
    ev_var = event_variance(t, trigger, ev.sd["trigger"], prop.value)
    event_variance(t, release, ev.sd["release"], prop.value, out=ev_var)
    sd = prop.sd  # √(sd² + the events' variance), in place (a 60 s log: 20 MB an array)
    np.sqrt(np.add(np.square(sd, out=sd), ev_var, out=sd), out=sd)
    fps = 1.0 / float(np.median(np.diff(t)))
    noise_deg = float(np.degrees(np.median([v["r_sd"] for v in fit.noise.values()]))) \
        if fit.noise else float("nan")
    col = {c: j for j, c in enumerate(prop.names)}
    advice = resolution_advisories(
        t, phase > 0, {c: prop.value[:, j] for c, j in col.items()},
        {c: sd[:, j] for c, j in col.items()}, {c: prop.orders(c) for c in prop.order_names},
        {c: ev_var[:, j] for c, j in col.items()}, fps, noise_deg,
        options.resolution_fraction, lines=lines)
    advice += peak_width_advisories(t, phase > 0, {c: prop.value[:, j] for c, j in col.items()},
                                    smoother_bandwidth(fit.noise, t), fps, noise_deg, lines=lines)
    del ev_var
    result = _table(est, state, t, trigger, phase, prop.names, prop.value, sd)
    del prop, sd
    notes = list(fit.notes) + list(ev.notes)
    if trigger is None:
        notes.append("no rest found at the start: t_shot counts from the first frame")
    validity = geometry_findings(t, phase, result["theta"].to_numpy(), result["psi"].to_numpy(),
                                 result["phi"].to_numpy(), scene,
                                 tension=result["sling_tension"].to_numpy(),
                                 tension_sd=result["sling_tension_sd"].to_numpy(), lines=lines)
    result.attrs["events"] = dict(ev.times)
    result.attrs["reconstruction"] = Reconstruction(
        events=ev.times, event_sd=ev.sd, event_sources=ev.sources, noise=fit.noise,
        form=options.form, trough=options.trough, model=fit.model, preset=options.preset,
        fps=fps, advisories=advice, validity=validity, notes=notes,
        event_warnings=ev.warnings)
    return result
