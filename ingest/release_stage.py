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

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.errors import ModelValidityWarning, warn_at_caller
from trebuchet.ingest.events.release_model import (
    ModelRelease,
    ReleaseFit,
    release_choice,
    release_from_model,
    scene_doubt,
)
from trebuchet.ingest.events.release_sources import TrackEndRelease, release_at_track_end
from trebuchet.ingest.events.sling_continuation import continued_sling
from trebuchet.ingest.events.stone_flight import points_stone_release
from trebuchet.ingest.logs.result import read_log_info
from trebuchet.ingest.reconstruct_options import (
    ReconstructOptions,
    checking_settings,
    smoother_settings,
)
from trebuchet.ingest.smoothing.result import smoothing_of, with_angle_rows, with_smoothing
from trebuchet.ingest.smoothing.smooth import ANGLES, smooth
from trebuchet.model.scene import Scene

__all__ = ["sling_track_end", "smooth_again", "model_release", "with_continued_sling",
           "release_by_the_equations", "lost_or_released", "smoothed_with_release",
           "log_source", "Noise", "SmoothedShot"]

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
    after the sling track's last row ``last`` (up to the time ``until``, s; all rows if
    None) by the sling's pendulum driven by the smoothed beam
    (:mod:`.events.sling_continuation`)."""
    cont = continued_sling({c: est[c].to_numpy(dtype=float) for c in
                            ("t", "theta", "theta_d", "theta_dd", "phi", "phi_d")},
                           scene, last, smoothing_of(est).cov["phi"][last][:3, :3])
    keep = np.ones(cont.rows.size, bool) if until is None else (
        est["t"].to_numpy(dtype=float)[cont.rows] <= until)
    return with_angle_rows(est, "phi", cont.rows[keep],
                           (cont.phi[keep], cont.phi_d[keep], cont.phi_dd[keep]),
                           cont.cov[keep])


def release_by_the_equations(log: pd.DataFrame, angles_log: np.ndarray, est: pd.DataFrame,
                             scene: Scene, options: ReconstructOptions,
                             smooth_events: dict[str, float | None],
                             q: Noise, r: Noise
                             ) -> tuple[pd.DataFrame, float | None]:
    """The smoothed log and the release's sd (s; None = the default) after checking the
    release of ``est`` (smoothed with :func:`checking_settings`) against the engine's
    equations (:mod:`.events.release_model`); where the model's release is used the log is
    smoothed again with it given (the noise search's result of ``est`` standing in for
    a new one: same log, only the release moves), its source says so and a note tells
    both times; else it is smoothed again with the smoother's own release given.
    A model that fits neither phase warns (ModelValidityWarning), and so do angles that
    fit it near the release worse than their noise allows (:func:`.scene_doubt`; the
    model's release is still used). ``angles_log`` (3, n): the log's θ, ψ, φ (rad) as
    :func:`~.smooth.validated_log` gave them."""
    settings = options.release_model
    found = smoothing_of(est).events
    fitted = model_release(angles_log, est, scene, settings)
    t = est["t"].to_numpy(dtype=float)
    sd_free = options.event_sd_frames * float(np.median(np.diff(t)))
    use, sentence = release_choice(fitted, found.get("release"), settings)
    name = Path(log_source(log)).name
    if sentence is not None and not use:
        warn_at_caller(f"{name}: {sentence}", ModelValidityWarning)
    doubt = scene_doubt(fitted, settings)
    if doubt is not None:
        warn_at_caller(f"{name}: {doubt}", ModelValidityWarning)
    if not use:
        # the smoother's own release stands: the log smoothed again with it given
        est = smooth_again(log, est, options, smooth_events, q, r, found.get("release"))
        est = with_smoothing(est, smoothing_of(est).noted(doubt, sentence))
        if sentence is not None:
            return est, None
        # agreed: the smoother's time stands, with the wider of the two sds
        return est, (None if fitted.time is None or found.get("release") is None
                     else max(sd_free, fitted.sd))
    notes = smoothing_of(est).notes
    est = smooth_again(log, est, options, smooth_events, q, r, fitted.time)
    again = smoothing_of(est)
    again = again.replace(notes=notes).noted(*again.notes, sentence, doubt)
    return with_smoothing(est, again.with_source("release", fitted.how)), fitted.sd


def lost_or_released(log: pd.DataFrame, angles_log: np.ndarray, est: pd.DataFrame,
                     scene: Scene, options: ReconstructOptions,
                     smooth_events: dict[str, float | None],
                     q: Noise, r: Noise,
                     track_end: tuple[float, float]) -> tuple[pd.DataFrame, float]:
    """The smoothed log and the release's sd (s) where the sling's track ends while θ and ψ
    go on: a release only if the engine or the stone agrees
    (:func:`.events.release_sources.release_at_track_end`). The sources: the engine's
    equations on θ and ψ (:func:`model_release`, φ carried on past the track by the
    sling's pendulum) and, for a point log, the tracked stone leaving its sling's circle
    (:func:`.events.stone_flight.points_stone_release`). A track lost before the release
    (the equations put it well after the track's end): the log is smoothed again with the
    equations' release, φ carried on up to it (phase II keeps its sling loads), and a note
    says so. A release before the track's end (the stone tracked in flight): smoothed
    again with it, φ left out after it (a flying stone's direction is no sling angle).
    Else the track's end stands (``est`` as it is). Sources that disagree warn
    (ModelValidityWarning), naming the one taken."""
    settings = options.release_model
    phi = est["phi"].to_numpy(dtype=float)
    last = int(np.flatnonzero(np.isfinite(phi))[-1])
    t = est["t"].to_numpy(dtype=float)
    fitted = model_release(angles_log, with_continued_sling(est, scene, last), scene,
                            settings)
    info = read_log_info(log)
    stone = (None if info is None or info.points is None
             else points_stone_release(info.points, scene, float(t[last])))
    choice = release_at_track_end(track_end, float(t[last]), float(t[last + 1]),
                                  float(np.median(np.diff(t))), stone, fitted,
                                  TrackEndRelease(max_misfit=settings.max_misfit))
    if choice.warning is not None:
        warn_at_caller(f"{Path(log_source(log)).name}: {choice.warning}", ModelValidityWarning)
    if choice.kind == "track end" and choice.time == track_end[0]:
        return with_smoothing(est, smoothing_of(est).noted(choice.note, choice.warning)), \
            choice.sd
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
        return with_smoothing(again, fit), choice.sd
    cut = log.copy()
    cut.loc[cut["t"].to_numpy(dtype=float) > choice.time, "phi"] = np.nan
    again = smooth_again(cut, est, options, smooth_events, q, r, choice.time)
    fit = smoothing_of(again).with_source("release", choice.source).noted(choice.note,
                                                                          choice.warning)
    return with_smoothing(again, fit), choice.sd


def log_source(log: pd.DataFrame) -> str:
    """The log's file as ``read_log`` was given it, else ``"log"``."""
    info = read_log_info(log)
    return "log" if info is None else info.source


@dataclass(frozen=True, eq=False)
class SmoothedShot:
    """The release stage's result: ``est``, the log smoothed with its release (and the
    smoothing's sources and notes saying where it came from), and ``release_sd``, the
    release's sd (s; None: the default, ``ReconstructOptions.event_sd_frames``)."""

    est: pd.DataFrame
    release_sd: float | None


def smoothed_with_release(log: pd.DataFrame, angles_log: np.ndarray, scene: Scene,
                          options: ReconstructOptions, given: Mapping[str, float | None],
                          q: Noise, r: Noise) -> SmoothedShot:
    """``log`` smoothed with the release its sources agree on (module doc); ``angles_log``
    (3, n): its θ, ψ, φ (rad) as :func:`~.smooth.validated_log` gave them; ``given``: the
    events the caller gave (checked), of which the trigger and the release go to the
    smoother."""
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
        if confirm and not seen_leaving:  # a stone seen in flight was released; a track
            # that just ends may have been lost
            est, release_sd = lost_or_released(log, angles_log, est, scene, options,
                                               smooth_events, q, r, track_end)
    elif check:
        est, release_sd = release_by_the_equations(log, angles_log, est, scene, options,
                                                   smooth_events, q, r)
    elif unchecked:
        est = with_smoothing(est, smoothing_of(est).noted(
            "the release was not checked against the engine's equations "
            f"({' and '.join(untracked)} not tracked); it comes from the jump search alone"))
    return SmoothedShot(est, release_sd)
