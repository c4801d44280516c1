"""The release stage of :func:`~trebuchet.ingest.reconstruct.reconstruct`: the log smoothed
with the release its sources agree on.

Where the log shows no given release, the release comes from (:func:`smoothed_with_release`):

- the end of the sling's track (:func:`sling_track_end`), checked by the engine's equations
  and the tracked stone's flight (:func:`lost_or_released`: a track lost before the
  release is carried on by the sling's pendulum, :func:`with_continued_sling`);
- else the smoother's jump search, checked by the engine's equations
  (:func:`release_by_the_equations`);
- else (θ or ψ not tracked) the jump search alone.

Where a source moves the release, the log is smoothed again with it given
(:func:`smooth_again`). Times in the log's time (s).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.core.errors import ModelValidityWarning, warn_at_caller
from trebuchet.ingest.events.release_model import (
    ModelRelease,
    ReleaseFit,
    release_from_model,
    scene_doubt,
)
from trebuchet.ingest.events.release_sources import (
    MIN_FLIGHT_FRAMES,
    ReleaseChoice,
    SceneTiming,
    TrackEnd,
    TrackEndRelease,
    covering_sd,
    release_at_track_end,
    release_without_track_end,
)
from trebuchet.ingest.events.sling_continuation import continued_sling, release_horizon
from trebuchet.ingest.events.stone_flight import StoneRelease, points_stone_release
from trebuchet.ingest.logs.result import read_log_info
from trebuchet.ingest.reconstruct_options import (
    ReconstructOptions,
    checking_settings,
    smoother_settings,
)
from trebuchet.ingest.smoothing.result import smoothing_of, with_angle_rows, with_smoothing
from trebuchet.ingest.smoothing.smooth import ANGLES, smooth
from trebuchet.model.scene import Scene
from trebuchet.model.simulate import simulate

__all__ = ["sling_track_end", "smooth_again", "model_release", "with_continued_sling",
           "release_by_the_equations", "lost_or_released", "smoothed_with_release",
           "log_source", "Noise", "SmoothedShot", "scene_timing"]

#: The smoother's process and measurement noise as ``reconstruct`` takes them (rad, per
#: angle or one number; None: maximum likelihood).
Noise = float | Mapping[str, float] | None


def sling_track_end(log: pd.DataFrame, min_frames: int = 3) -> tuple[float, float] | None:
    """Release time (s) and its sd (s) when the sling angle's track ends at least
    ``min_frames`` frames before the others': midway between its last frame and the next,
    sd = that gap / √12 (uniform); or, where ``read_log`` cut the track where a tracked
    stone leaves its sling's circle (``ReadLog.leaves_sling``), that fitted time and its
    sd. None otherwise."""
    t = log["t"].to_numpy(dtype=float)
    ok = {a: np.flatnonzero(np.isfinite(log[a].to_numpy(dtype=float))) for a in ANGLES}
    if any(v.size == 0 for v in ok.values()):
        return None
    last = int(ok["phi"][-1])
    others = max(int(ok["theta"][-1]), int(ok["psi"][-1]))
    if others - last < min_frames or last + 1 >= t.size:
        return None
    info = read_log_info(log)
    leaves = None if info is None else info.leaves_sling
    if leaves is not None and t[last] <= leaves[0] < t[last + 1]:
        return float(leaves[0]), float(leaves[1])
    gap = t[last + 1] - t[last]
    return float(t[last] + 0.5 * gap), float(gap / np.sqrt(12.0))


def smooth_again(log: pd.DataFrame, est: pd.DataFrame, options: ReconstructOptions,
                 smooth_events: dict[str, float | None],
                 q: Noise, r: Noise,
                 release: float | None) -> pd.DataFrame:
    """``log`` smoothed with the full settings, ``release`` (s, log time; None = none)
    given, and what the checking smoothing ``est`` found standing in for a new search:
    its trigger (the same detection on the same log; its source and sd are kept) and its
    noise (``smooth(tuned=…)``; local noise refits its scale)."""
    before = smoothing_of(est)
    again = smooth(log, model=options.model, q=q, r=r,
                   events={"trigger": before.events.get("trigger"), **smooth_events,
                           "release": release},
                   settings=smoother_settings(options), tuned=before.noise)
    fit = smoothing_of(again)
    kept = {}
    for key in ("event_sources", "event_sd"):
        new = {k: v for k, v in getattr(fit, key).items() if k != "trigger"}
        if "trigger" in getattr(before, key):
            new["trigger"] = getattr(before, key)["trigger"]
        kept[key] = new
    fit = fit.replace(**kept).with_source("release", before.event_sources.get("release"))
    return with_smoothing(again, fit)


def model_release(angles_log: np.ndarray, est: pd.DataFrame, scene: Scene,
                  settings: ReleaseFit) -> ModelRelease:
    """:func:`.events.release_model.release_from_model` on the log's raw θ and ψ (rad,
    unwrapped as the smoother does; ``angles_log`` (3, n) as ``validated_log`` gave them)
    and the smoothed ``est``, with the smoother's noise sd and trigger."""
    fit = smoothing_of(est)
    noise = fit.noise  # theta and psi are tracked (reconstruct checks)
    angles = {}
    for a in ("theta", "psi"):
        z = angles_log[ANGLES.index(a)].copy()
        ok = np.isfinite(z)
        z[ok] = np.unwrap(z[ok])  # as the smoother does
        angles[a] = z
    return release_from_model(angles, est, scene, fit.events.get("trigger"),
                              {a: noise[a]["r_sd"] for a in ("theta", "psi")}, settings)


def with_continued_sling(est: pd.DataFrame, scene: Scene, last: int,
                         until: float | None = None) -> pd.DataFrame:
    """``est`` with φ, φ̇, φ̈ and their sd (and the smoothing's ``cov["phi"]``) filled on the rows
    after the sling track's last row ``last`` (up to the time ``until``, s; if None as far
    as the release check needs, :func:`.events.sling_continuation.release_horizon`, and
    φ, φ̇, φ̈ without their sd: the check does not use it) by the sling's pendulum driven
    by the smoothed beam (:mod:`.events.sling_continuation`)."""
    cols = {c: est[c].to_numpy(dtype=float) for c in
            ("t", "theta", "theta_d", "theta_dd", "phi", "phi_d")}
    check = until is None  # for the release check: φ and φ̇ only (its sd NaN)
    if check:
        until = release_horizon(cols["t"], cols["theta_d"], last,
                                smoothing_of(est).events.get("trigger"))
    cont = continued_sling(cols, scene, last, smoothing_of(est).cov["phi"][last][:3, :3],
                           until=until, spread=not check)
    return with_angle_rows(est, "phi", cont.rows, (cont.phi, cont.phi_d, cont.phi_dd), cont.cov)


def scene_timing(scene: Scene, trigger: float | None, trigger_sd: float = 0.0
                 ) -> SceneTiming:
    """The scene's own release in the log's time: ``trigger`` (s, its sd ``trigger_sd``)
    plus the simulated time from trigger to release
    (:class:`~.events.release_sources.SceneTiming`)."""
    if trigger is None:
        return SceneTiming(None)
    span = float(simulate(scene, t_eval=[0.0]).attrs["events"]["release"])
    return SceneTiming(trigger + span, span, float(np.nan_to_num(trigger_sd)))


def _warned(log: pd.DataFrame, *sentences: str | None) -> None:
    name = Path(log_source(log)).name
    for sentence in sentences:
        if sentence is not None:
            warn_at_caller(f"{name}: {sentence}", ModelValidityWarning)


def release_by_the_equations(log: pd.DataFrame, angles_log: np.ndarray, est: pd.DataFrame,
                             scene: Scene, options: ReconstructOptions,
                             smooth_events: dict[str, float | None],
                             q: Noise, r: Noise) -> SmoothedShot:
    """The log smoothed with its release where the sling's track goes on past it: the
    release of ``est`` (smoothed with :func:`checking_settings`, its jump search) checked
    against the engine's equations (:mod:`.events.release_model`) by
    :func:`~.events.release_sources.release_without_track_end`; the log is smoothed again
    with the release taken given (the noise search's result of ``est`` standing in for a
    new one: same log, only the release moves), its source and a note saying where it
    came from. A release no source confirms, and angles that fit the equations near the
    release worse than their noise allows (:func:`.scene_doubt`), warn
    (ModelValidityWarning). ``angles_log`` (3, n): the log's θ, ψ, φ (rad) as
    :func:`~.smooth.validated_log` gave them."""
    settings = options.release_model
    found = smoothing_of(est).events
    fitted = model_release(angles_log, est, scene, settings)
    t = est["t"].to_numpy(dtype=float)
    frame = float(np.median(np.diff(t)))
    choice = release_without_track_end(
        fitted, found.get("release"), options.event_sd_frames * frame, frame,
        scene_timing(scene, found.get("trigger"),
                     smoothing_of(est).event_sd.get("trigger", 0.0)),
        TrackEndRelease(max_misfit=settings.max_misfit))
    doubt = scene_doubt(fitted, settings)
    _warned(log, choice.warning, doubt)
    release = None if not np.isfinite(choice.time) else choice.time
    notes = smoothing_of(est).notes
    again = smooth_again(log, est, options, smooth_events, q, r, release)
    fit = smoothing_of(again)
    fit = fit.replace(notes=notes).noted(*fit.notes, choice.note, choice.warning, doubt)
    if choice.kind == "equations":
        fit = fit.with_source("release", choice.source)
    sd = None if release is None else choice.sd
    return SmoothedShot(with_smoothing(again, fit), sd, choice)


def lost_or_released(log: pd.DataFrame, angles_log: np.ndarray, est: pd.DataFrame,
                     scene: Scene, options: ReconstructOptions,
                     smooth_events: dict[str, float | None], q: Noise, r: Noise,
                     track_end: tuple[float, float],
                     plane: pd.DataFrame | None = None) -> SmoothedShot:
    """The log smoothed with its release where the sling's track ends while θ and ψ go on:
    a release only if the engine or the stone agrees
    (:func:`.events.release_sources.release_at_track_end`). The sources: the engine's
    equations on θ and ψ (:func:`model_release`, φ carried on past the track by the
    sling's pendulum) and, for a point log, the tracked stone leaving its sling's circle
    (:func:`.events.stone_flight.points_stone_release`, in the engine's plane where the
    engine calibrated the image: ``plane``, m; else in the file's unit), unless the stone's
    track ends where the tracker stood still (``ReadLog.held``). A track lost before the
    release (the equations put it well after the track's end): the log is smoothed again
    with the equations' release, φ carried on up to it (phase II keeps its sling loads),
    and a note says so. A release before the track's end (the stone tracked in flight):
    smoothed again with it, φ left out after it (a flying stone's direction is no sling
    angle). Else the track's end stands (``est`` as it is). Sources that disagree, and a
    track's end no source confirms, warn (ModelValidityWarning)."""
    settings = options.release_model
    phi = est["phi"].to_numpy(dtype=float)
    last = int(np.flatnonzero(np.isfinite(phi))[-1])
    t = est["t"].to_numpy(dtype=float)
    fitted = model_release(angles_log, with_continued_sling(est, scene, last), scene,
                           settings)
    info = read_log_info(log)
    points = plane if plane is not None else None if info is None else info.points
    stone = (None if points is None
             else points_stone_release(points, scene, float(t[last])))
    if (stone is None or stone.time is None) and info is not None \
            and info.leaves_sling is not None and info.leaves_sling[0] == track_end[0]:
        stone = _seen_leaving(info, track_end)
    end = TrackEnd(track_end[0], track_end[1], float(t[last]), float(t[last + 1]),
                   float(np.median(np.diff(t))), stone_held=_stone_held(info, float(t[last]),
                                                                        float(t[last + 1])))
    choice = release_at_track_end(end, stone, fitted,
                                  scene_timing(scene, smoothing_of(est).events.get("trigger"),
                                               smoothing_of(est).event_sd.get("trigger", 0.0)),
                                  TrackEndRelease(max_misfit=settings.max_misfit))
    if choice.kind == "lost":
        choice = _lost_spread(choice, angles_log, est, scene, settings, last, end.frame)
    _warned(log, choice.warning)
    if choice.kind == "track end" and choice.time == track_end[0]:
        fit = smoothing_of(est).noted(choice.note, choice.warning)
        return SmoothedShot(with_smoothing(est, fit), choice.sd, choice)
    if choice.kind == "lost":
        t_last = float(t[last])
        again = smooth_again(log, est, options, smooth_events, q, r, choice.time)
        again = with_continued_sling(again, scene, last, until=choice.time)
        gap = choice.time - track_end[0]
        fit = smoothing_of(again).with_source("release", choice.source).noted(
            f"the sling's track ends at {t_last:.4f} s, but θ and ψ follow the engine in the "
            f"sling until {choice.time:.4f} s (sd {1e3 * choice.sd:.1f} ms, "
            f"{1e3 * gap:.0f} ms later): the track was lost, not released; φ is carried on "
            "by the sling's pendulum up to the release", choice.note, choice.warning)
        return SmoothedShot(with_smoothing(again, fit), choice.sd, choice)
    cut = log.copy()
    cut.loc[cut["t"].to_numpy(dtype=float) > choice.time, "phi"] = np.nan
    again = smooth_again(cut, est, options, smooth_events, q, r, choice.time)
    fit = smoothing_of(again).with_source("release", choice.source).noted(choice.note,
                                                                          choice.warning)
    return SmoothedShot(with_smoothing(again, fit), choice.sd, choice)


def _seen_leaving(info, track_end: tuple[float, float]) -> StoneRelease:
    """The stone seen leaving its sling's circle where ``read_log`` cut φ
    (``ReadLog.leaves_sling``: its time and sd, s) as a stone source of the arbitration;
    its frames of flight are the stone's tracked positions after the cut."""
    if info.points is None or "projectile_x" not in info.points:
        flight = MIN_FLIGHT_FRAMES  # read_log cut φ where the stone had left by frames
    else:
        t = np.asarray(info.points["t"], dtype=float)
        x = np.asarray(info.points["projectile_x"], dtype=float)
        flight = int((np.isfinite(x) & (t > track_end[0])).sum())
    return StoneRelease(float(track_end[0]), float(track_end[1]), float("nan"), float("inf"),
                        flight, float(track_end[0]), "the tracked stone leaves its sling's circle")


#: s: a lost track's release is sought again with the sling's track cut this much earlier
#: (:func:`_lost_spread`).
LOST_TRIM_S = 0.05


def _lost_spread(choice: ReleaseChoice, angles_log: np.ndarray, est: pd.DataFrame,
                 scene: Scene, settings: ReleaseFit, last: int, frame: float
                 ) -> ReleaseChoice:
    """A lost track's release (``choice``, from the engine's equations with φ carried on
    by the sling's pendulum from the track's last row ``last``) with its sd widened by how
    far the equations move it when the pendulum starts :data:`LOST_TRIM_S` s earlier
    (:func:`~.events.release_sources.covering_sd`): the last frames of a track that is
    being lost (a template sliding onto a frame member before it sticks there) may be off
    the stone, and the carried-on φ with them (a stuck stone on the backyard engine: the
    release 3 frames late with an sd of 0.9 frame). Where the widened sd exceeds a frame,
    a warning says the release is uncertain."""
    trim = max(3, int(round(LOST_TRIM_S / frame)))
    first = int(np.flatnonzero(np.isfinite(est["phi"].to_numpy(dtype=float)))[0])
    if last - trim <= first:
        return choice
    again = model_release(angles_log, with_continued_sling(est, scene, last - trim), scene,
                          settings)
    if again.time is None or not again.misfit <= settings.max_misfit:
        return choice
    sd = covering_sd(choice.sd, again.time - choice.time)
    if sd <= frame:
        return dataclasses.replace(choice, sd=sd)
    return dataclasses.replace(choice, sd=sd, warning=(
        f"the release is uncertain: the sling's track was lost and the engine's equations put "
        f"the release at {choice.time:.4f} s, or at {again.time:.4f} s with the track cut "
        f"{1e3 * trim * frame:.0f} ms earlier; it is taken with sd {1e3 * sd:.1f} ms "
        f"({sd / frame:.1f} frames)"))


def _stone_held(info, last: float, following: float) -> bool:
    """Whether ``read_log`` left the stone's positions out as stuck (``ReadLog.held``) from
    the sling track's end on: a run of the projectile that starts after the track's last
    frame ``last`` (s) and no later than the frame after it, ``following`` (s), allowing a
    few frames the stuck check trims at the run's start."""
    if info is None:
        return False
    slack = 5.0 * (following - last)
    return any(role == "projectile" and last < first <= following + slack
               for role, first, _ in getattr(info, "held", ()))


def log_source(log: pd.DataFrame) -> str:
    """The log's file as ``read_log`` was given it, else ``"log"``."""
    info = read_log_info(log)
    return "log" if info is None else info.source


@dataclass(frozen=True, eq=False)
class SmoothedShot:
    """The release stage's result: ``est``, the log smoothed with its release (and the
    smoothing's sources and notes saying where it came from), ``release_sd``, the
    release's sd (s; None: the default, ``ReconstructOptions.event_sd_frames``), and
    ``choice``, the decision that placed it (None: given, seen leaving by ``read_log``, or
    from the jump search alone)."""

    est: pd.DataFrame
    release_sd: float | None
    choice: ReleaseChoice | None = None


def smoothed_with_release(log: pd.DataFrame, angles_log: np.ndarray, scene: Scene,
                          options: ReconstructOptions, given: Mapping[str, float | None],
                          q: Noise, r: Noise, plane: pd.DataFrame | None = None
                          ) -> SmoothedShot:
    """``log`` smoothed with the release its sources agree on (module doc); ``angles_log``
    (3, n): its θ, ψ, φ (rad) as :func:`~.smooth.validated_log` gave them; ``given``: the
    events the caller gave (checked), of which the trigger and the release go to the
    smoother; ``plane``: the tracked points in the engine's plane (m), where the engine
    calibrated the image (the stone's flight is fitted there)."""
    smooth_events = {k: v for k, v in given.items() if k in ("trigger", "release")}
    track_end = None
    if ("release" not in given and options.release_at_track_end
            and scene.projectile != "none"):
        track_end = sling_track_end(log)
        if track_end is not None:
            smooth_events["release"] = track_end[0]
    check = (track_end is None and "release" not in given and scene.projectile != "none"
             and options.release_model is not None)
    untracked = [a for a, z in zip(ANGLES, angles_log, strict=True)
                 if a != "phi" and not np.isfinite(z).any()]
    confirm = (track_end is not None and options.release_model is not None and not untracked
               and "release" not in given)
    unchecked = check and bool(untracked)
    check = check and not untracked
    settings = smoother_settings(options)
    est = smooth(log, model=options.model, q=q, r=r, events=smooth_events or None,
                 settings=checking_settings(settings) if check else settings)
    release_sd = None
    if track_end is not None:
        info = read_log_info(log)
        leaves = None if info is None else info.leaves_sling
        seen_leaving = leaves is not None and leaves[0] == track_end[0]
        est = with_smoothing(est, smoothing_of(est).with_source(
            "release", "the tracked stone leaves its sling's circle" if seen_leaving
            else "end of the sling track"))
        release_sd = track_end[1]
        if confirm:  # a track that just ends may have been lost; a stone seen leaving its
            # circle is checked against the equations and the stone's flight fit
            return lost_or_released(log, angles_log, est, scene, options, smooth_events,
                                    q, r, track_end, plane)
    elif check:
        return release_by_the_equations(log, angles_log, est, scene, options,
                                        smooth_events, q, r)
    elif unchecked:
        est = with_smoothing(est, smoothing_of(est).noted(
            "the release was not checked against the engine's equations "
            f"({' and '.join(untracked)} not tracked); it comes from the jump search alone"))
    return SmoothedShot(est, release_sd)
