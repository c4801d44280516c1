"""Internal forces from a video log: read, smooth, apply the model's force functions.

``reconstruct(log, scene)`` = :func:`~trebuchet.ingest.logs.read_log.read_log` +
:func:`~trebuchet.ingest.smoothing.smooth.smooth` + :func:`trebuchet.model.loads.loads` on the
smoothed state, with

- **events** in the log's time: the trigger and release from the smoother, lift-off where
  the reconstructed trough normal force reaches zero (:mod:`.events.lift_off`); each may be
  given instead (``events={"trigger": s, "lift_off": s, "release": s}``, None = no such
  event);
- **phases**: 0 at rest before the trigger (an extension of the contract: the static
  loads with the beam held by the trigger, whose own force is not modelled, so
  ``torque`` there is the torque the trigger holds), 1 trough, 2 sling, 3 released;
- **forms**: ``"projected"`` (default) takes F_H along the counterweight arm and F_S along
  the sling, free of ψ̈ and φ̈; ``"direct"`` the paper's eqs. (11), (13). In phase I the
  sling angle is by default taken from θ through the trough constraint
  (``trough="constraint"``; ``"measured"`` uses the smoothed φ);
- **uncertainty**: every load's sd from the smoother's full per-angle covariance
  (:mod:`.uncertainty`), plus, on the frames next to a detected trigger or release, the
  chance that the frame lies in the other phase (the trigger's sd from its likelihood
  profile, the release's ``event_sd_frames`` frames or the track-end gap / √12);
- **checks**: angles that leave the scene's geometry and a slack sling
  (:mod:`.scene_fit`), and the resolution advisory (:mod:`.advisory`), both as
  :class:`~trebuchet.core.errors.ModelValidityWarning` and in ``attrs``.

Measured accuracy of both forms and the bands' coverage: ``bench/ingest_accuracy.py``.
Units: SI (s, rad, rad/s, rad/s², N, N m, W, J, m, m/s).

The pipeline (:func:`reconstruct`), each stage a function of its inputs:

1. :func:`read_stage`: the log read and checked against the scene (its swing), posed by
   the user's calibration, and its angles taken through the camera the engine calibrates
   (:mod:`.calibrated_angles`);
2. :func:`check_shot` (a log with no shot is refused); :func:`fitted_stage` (issue 23: the
   loads of the scene's engine fitted to a log of angles, where the fit passes its check,
   end here); else
   :func:`~.release_stage.smoothed_with_release`: the log smoothed with the release its
   sources agree on (the sling track's end, the tracked stone's flight, the engine's
   equations, the smoother's jump search), a given release before the trigger refused
   (:func:`check_given_release`), and the log's swing checked against the scene's
   (:func:`matched_scene`);
3. :func:`refined_estimate`: the notes of the first stages, the calibration's sd in the
   bands, the counterweight carried on past a lost track, the angles' systematic sd;
4. :func:`loads_stage` (:func:`~.loads_table.loads_from_smoothed`): phases, lift-off
   (the normal force's zero, checked by the stone's departure from the trough,
   :func:`stone_departure`), loads and their sd;
5. :func:`warn_checks`: the geometry findings and the resolution advisory warned.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.core.errors import (
    ModelValidityWarning,
    TrebuchetDataWarning,
    TrebuchetInputError,
    on_command_line,
    warn_at_caller,
)
from trebuchet.ingest.calibrated_angles import (
    CalibratedLog,
    calibrated_log,
    widened_by_calibration,
)
from trebuchet.ingest.events.trough_departure import (
    StoneLiftOff,
    TroughDeparture,
    stone_lift_off,
)
from trebuchet.ingest.geometry.user_calibration import UserCalibration, read_calibration
from trebuchet.ingest.identification.fitted_loads import fitted_reconstruction
from trebuchet.ingest.loads_table import STATE_COLUMNS, loads_from_smoothed
from trebuchet.ingest.logs.read_log import MIN_LIKELIHOOD
from trebuchet.ingest.logs.result import read_log_info
from trebuchet.ingest.logs.scene_check import SceneCheck, scene_check
from trebuchet.ingest.reconstruct_options import (
    FORMS,
    PRESETS,
    ReconstructOptions,
    checking_settings,
    propagation_order,
    smoother_settings,
)
from trebuchet.ingest.reconstruction import Reconstruction, reconstruction_of
from trebuchet.ingest.release_stage import (
    Noise,
    SmoothedShot,
    log_source,
    sling_track_end,
    smoothed_with_release,
)
from trebuchet.ingest.scene_fit import warn_findings
from trebuchet.ingest.scene_match import scene_match
from trebuchet.ingest.smoothing.counterweight_continuation import with_continued_counterweight
from trebuchet.ingest.smoothing.inputs import event_named
from trebuchet.ingest.smoothing.result import smoothing_of, with_smoothing
from trebuchet.ingest.smoothing.smooth import ANGLES, checked_events, validated_log
from trebuchet.ingest.state_loads import shot_phases
from trebuchet.ingest.systematic_angles import systematic_angles, with_systematic_angles
from trebuchet.ingest.user_calibrated import posed_log
from trebuchet.model.scene import Scene, as_scene
from trebuchet.model.simulate import simulate

__all__ = ["ReconstructOptions", "reconstruct", "loads_from_smoothed", "shot_phases",
           "sling_track_end", "PRESETS", "smoother_settings", "propagation_order",
           "STATE_COLUMNS", "FORMS", "checking_settings", "ReadStage", "read_stage",
           "refined_estimate", "warn_checks", "stone_departure", "check_shot",
           "check_given_release", "matched_scene", "fitted_stage", "loads_stage"]


def _log_frame(path_or_log, fps, columns, points, read_options) -> pd.DataFrame:
    if isinstance(path_or_log, pd.DataFrame):
        if points is not None:
            raise TrebuchetInputError("reconstruct: points= needs a log file of point "
                                      "positions, not a table of angles")
        log = path_or_log.copy()
        if columns:
            log = log.rename(columns=dict(columns))
        if "t" not in log.columns and "frame" in log.columns and fps:
            log.insert(0, "t", log["frame"].to_numpy(dtype=float) / float(fps))
        return log
    if isinstance(path_or_log, str | Path):
        from trebuchet.ingest.logs.read_log import read_log

        return read_log(path_or_log, fps=fps, columns=columns, points=points, **read_options)
    raise TrebuchetInputError("reconstruct: expected a log file path or a DataFrame, got "
                              f"{type(path_or_log).__name__}")


@dataclass(frozen=True, eq=False)
class ReadStage:
    """The read stage's result: ``log``, the table the smoother takes (the calibrated
    angles where the engine calibrated the image); ``source``, its file (or ``"log"``);
    ``user``, the user's calibration (or None) and ``posed``, what posing the plane by it
    found; ``swing``, the log's swing against the scene's (None for a table not read
    from a file); ``calibrated``, the engine's calibration of the image (or None)."""

    log: pd.DataFrame
    source: str
    user: UserCalibration | None
    posed: tuple[str, ...]
    swing: SceneCheck | None
    calibrated: CalibratedLog | None


def read_stage(path_or_log: str | Path | pd.DataFrame, scene: Scene,
               options: ReconstructOptions, *, fps: float | None = None,
               columns: Mapping[str, str] | None = None,
               points: Mapping[str, str] | None = None,
               read_options: Mapping | None = None,
               calibration: str | Path | None = None) -> ReadStage:
    """Stage 1 of :func:`reconstruct`: the log read (``read_options``: the keywords of
    ``read_log``), checked against ``scene`` and calibrated (module doc)."""
    user = read_calibration(calibration) if calibration is not None else None
    if user is not None and isinstance(path_or_log, pd.DataFrame):
        raise TrebuchetInputError("reconstruct: calibration= applies to a log file of tracked "
                                  "points, not to a table of angles")
    log = _log_frame(path_or_log, fps, columns, points,
                     dict(read_options or {}) | {"calibration": user})
    source = log_source(log)
    posed: tuple[str, ...] = ()
    if user is not None and options.image_calibration != "engine":
        log, posed = posed_log(log, scene, user)   # a camera file alone: the plane's pose
    swing = scene_check(log, scene) if read_log_info(log) is not None else None
    in_pixels = False if user is not None and user.fixes_plane else None  # points in m
    calibrated = (calibrated_log(log, scene, in_pixels=in_pixels)
                  if options.image_calibration == "engine" else None)
    if calibrated is not None:
        log = calibrated.log
        for note in calibrated.warnings:
            warn_at_caller(f"{Path(source).name}: {note}", TrebuchetDataWarning)
    return ReadStage(log, source, user, posed, swing, calibrated)


def refined_estimate(est: pd.DataFrame, read: ReadStage, scene: Scene,
                     angles_log: np.ndarray) -> pd.DataFrame:
    """Stage 3 of :func:`reconstruct`: the smoothed ``est`` with the read stage's notes
    (the swing, the user's calibration), the engine's calibration's sd in the bands, the
    counterweight carried on past a lost track and the angles' systematic sd
    (``angles_log`` (3, n): the log's θ, ψ, φ, rad)."""
    if read.swing is not None and read.swing.note:
        est = with_smoothing(est, smoothing_of(est).noted(read.swing.note))
    if read.user is not None:
        est = with_smoothing(est, smoothing_of(est).noted(read.user.describe(), *read.posed))
    calibrated = read.calibrated
    if calibrated is not None:
        est = widened_by_calibration(est, calibrated.common_sd)
        est = with_smoothing(est, smoothing_of(est).noted(*calibrated.notes))
    est = with_continued_counterweight(est, scene, angles_log[ANGLES.index("psi")])
    found = smoothing_of(est).events
    return with_systematic_angles(est, systematic_angles(
        read.log, scene, found.get("trigger"), found.get("release"),
        points=None if calibrated is None else calibrated.plane))


def stone_departure(read: ReadStage, est: pd.DataFrame, scene: Scene) -> StoneLiftOff | None:
    """The stone's own departure from the trough (:mod:`.events.trough_departure`), for a
    point log of a scene that starts in the trough: in the engine's plane where the engine
    calibrated the image, else in the file's unit; candidates from the smoothing's trigger
    to 1.5 × the scene's own time to lift-off after it (and before the release). None
    where there is no stone track, no trigger or no lift-off to seek."""
    info = read_log_info(read.log)
    plane = None if read.calibrated is None else read.calibrated.plane
    points = plane if plane is not None else None if info is None else info.points
    found = smoothing_of(est).events
    trigger, release = found.get("trigger"), found.get("release")
    if (scene.projectile != "trough" or points is None or trigger is None
            or "projectile_x" not in points):
        return None
    lift = simulate(scene, t_eval=[0.0]).attrs["events"].get("lift_off")
    if lift is None:
        return None
    t = np.asarray(points["t"], dtype=float)
    latest = trigger + 1.5 * float(lift)
    if release is not None:
        latest = min(latest, release - TroughDeparture().window_s)
    stone = np.column_stack([np.asarray(points["projectile_x"], dtype=float),
                             np.asarray(points["projectile_y"], dtype=float)])
    return stone_lift_off(t, stone, trigger, latest, float(np.median(np.diff(t))))


#: An event whose sd exceeds this many frames is warned about (its ±2 sd reach beyond two
#: frames: the video bench's rule is that an event more than 2 frames off lies within
#: its stated 2 sd and is warned about).
UNCERTAIN_FRAMES = 1.0


def uncertain_events(done: Reconstruction, warned: tuple[str, ...] = ()) -> list[str]:
    """Sentences for the events of ``done`` known to worse than :data:`UNCERTAIN_FRAMES`
    frames (sd), except those a sentence of ``warned`` already names."""
    frame = 1.0 / done.fps if done.fps > 0 else float("nan")
    out = []
    for key, name in (("trigger", "trigger"), ("lift_off", "lift-off"), ("release", "release")):
        when, sd = done.events.get(key), done.event_sd.get(key, float("nan"))
        if when is None or not np.isfinite(sd) or not sd > UNCERTAIN_FRAMES * frame:
            continue
        if any(name in w for w in warned):
            continue
        out.append(f"the {name} at {when:.4f} s is uncertain: sd {1e3 * sd:.1f} ms "
                   f"({sd / frame:.1f} frames; {done.event_sources.get(key, '')}); the "
                   "loads next to it carry that in their bands")
    return out


#: A log whose beam angle θ spreads over less than this (°, between its 1st and 99th
#: percentile) holds no shot.
NO_SHOT_DEG = 2.0


def check_shot(t: np.ndarray, angles_log: np.ndarray, source: str) -> None:
    """Refuse (``TrebuchetInputError``, one line naming the file) a log whose beam never
    moves: θ (``angles_log[0]``, rad) within :data:`NO_SHOT_DEG` over all its rows (the
    engine at rest: smoothing it gave a table of loads and a "peak" of noise)."""
    theta = np.degrees(angles_log[ANGLES.index("theta")])
    ok = np.isfinite(theta)
    if ok.sum() < 2:
        return
    lo, hi = np.percentile(theta[ok], [1.0, 99.0])
    if hi - lo < NO_SHOT_DEG:
        raise TrebuchetInputError(
            f"{Path(source).name}: no shot in the log: the beam's angle θ stays within "
            f"{hi - lo:.2g}° over its {int(ok.sum())} rows (t = {t[0]:.6g}–{t[-1]:.6g} s); a "
            "shot swings it through tens of degrees")


def check_given_release(given: Mapping[str, float | None], trigger: float | None,
                        source: str) -> None:
    """Refuse a given release at or before the shot's trigger (given or detected, s): no
    sling phase, no lift-off, and F_S zero everywhere."""
    release = given.get("release")
    if release is None or trigger is None or release > trigger:
        return
    how = "given" if "trigger" in given else "detected"
    raise TrebuchetInputError(
        f"{Path(source).name}: {event_named('release', release)} lies at or before the "
        f"shot's trigger at "
        f"{trigger:.4f} s ({how}): the release comes after the trigger")


def matched_scene(est: pd.DataFrame, scene: Scene, options: ReconstructOptions,
                  source: str) -> pd.DataFrame:
    """The smoothed ``est`` checked against ``scene`` (:mod:`.scene_match`): a mismatch is
    noted and warned (ModelValidityWarning), one beyond what a scene a little off gives is
    refused (``TrebuchetInputError``) unless ``options.scene_mismatch`` is "warn"."""
    found = smoothing_of(est).events
    match = scene_match(est, scene, found.get("trigger"), found.get("release"))
    if match.mismatch is None:
        return est
    name = Path(source).name
    if match.refused and options.scene_mismatch == "refuse":
        keyword = ("" if on_command_line() else
                   " (ReconstructOptions(scene_mismatch='warn') computes them anyway)")
        raise TrebuchetInputError(f"{name}: {match.mismatch} Its loads would be another "
                                  f"engine's: refused{keyword}")
    said = f"{match.mismatch} The loads are computed with the scene's masses and lengths"
    warn_at_caller(f"{name}: {said}", ModelValidityWarning)
    return with_smoothing(est, smoothing_of(est).noted(said))


def loads_stage(est: pd.DataFrame, read: ReadStage, scene: Scene,
                given: Mapping[str, float | None], options: ReconstructOptions,
                shot: SmoothedShot, angles_log: np.ndarray) -> pd.DataFrame:
    """Stage 4 of :func:`reconstruct`: :func:`~.loads_table.loads_from_smoothed` on the
    refined ``est``, with the file's line numbers, the release's sd the release stage
    gave, the stone's departure from the trough and which angles were tracked; the log's
    :class:`~.logs.result.ReadLog` in ``attrs["log"]``."""
    info = read_log_info(read.log)
    lines = info.lines if info is not None and info.lines is not None \
        and len(info.lines) == len(est) else None
    result = loads_from_smoothed(est, scene, events=given, options=options, lines=lines,
                                 release_sd=shot.release_sd,
                                 stone_lift=stone_departure(read, est, scene),
                                 tracked=np.isfinite(angles_log))
    if info is not None:
        result.attrs["log"] = info
    return result


def fitted_stage(read: ReadStage, scene: Scene, given: Mapping[str, float | None],
                 options: ReconstructOptions):
    """Issue 23's hook: the loads of the scene's engine fitted to the log
    (:func:`~.identification.fitted_loads.fitted_reconstruction`, its ``result`` None where
    the fit did not pass its check or was not asked for), or None with ``method="smooth"``.
    A log with a given release before the trigger is refused first (the smoothing path
    refuses it after its trigger is found)."""
    if options.method == "smooth":
        return None
    fitted = fitted_reconstruction(read.log, scene, given, form=options.form,
                                   trough=options.trough,
                                   resolution_fraction=options.resolution_fraction,
                                   source=read.source, method=options.method)
    if fitted is not None and fitted.result is not None:
        check_given_release(given, fitted.result.attrs["events"].get("trigger"), read.source)
    return fitted


def warn_checks(result: pd.DataFrame, source: str, warned: tuple[str, ...] = ()) -> None:
    """Stage 5 of :func:`reconstruct`: the events' disagreements and uncertainty, the
    geometry findings and the resolution advisory of ``result`` warned
    (ModelValidityWarning), named by the log's file ``source``; ``warned``: sentences the
    earlier stages warned already."""
    name = Path(source).name
    done = reconstruction_of(result)
    events = list(done.event_warnings)
    for sentence in events + uncertain_events(done, warned + tuple(events)):
        warn_at_caller(f"{name}: {sentence}", ModelValidityWarning)
    warn_findings(list(done.validity), name)
    advice = done.advisories
    if advice:
        warn_at_caller(f"{name}: " + "; ".join(a.message for a in advice),
                       ModelValidityWarning)


def reconstruct(path_or_log: str | Path | pd.DataFrame, scene: Scene | str | Path,
                fps: float | None = None, columns: Mapping[str, str] | None = None,
                points: Mapping[str, str] | None = None, *,
                events: Mapping[str, float | None] | None = None,
                form: str | None = None, trough: str | None = None,
                image_calibration: str | None = None, method: str | None = None,
                q: Noise = None, r: Noise = None,
                min_likelihood: float = MIN_LIKELIHOOD,
                time_unit: str | None = None, angle_unit: str | None = None,
                individual: str | None = None, calibration: str | Path | None = None,
                options: ReconstructOptions | None = None) -> pd.DataFrame:
    """Loads of a filmed shot with their standard deviations.

    Parameters
    ----------
    path_or_log : a log file (any format :func:`~trebuchet.ingest.logs.read_log.read_log`
        reads) or a DataFrame with ``t`` (s) and ``theta``, ``psi``, ``phi`` (rad).
    scene : the engine filmed (a :class:`~trebuchet.model.scene.Scene` or a scene file).
    fps, columns, points, min_likelihood, time_unit, angle_unit, individual, calibration :
        as for ``read_log`` (a log read from a file is then checked against the scene:
        :func:`~trebuchet.ingest.logs.scene_check.scene_check` refuses a beam whose sweep or
        timing is off by a factor of 57, 1000 or the frame rate). ``calibration``, the
        user's own (known plane points, or an OpenCV camera file), is read once; the
        self-calibration (``options.image_calibration="engine"``, default) then fits on the
        points in the plane (known points) or the lens-free pixels (a camera file); with it
        off, a camera file's plane pose is found from the engine's ties
        (:mod:`.user_calibrated`); notes say what was found.
    events : ``{"trigger", "lift_off", "release"}`` in the log's time (s), overriding
        detection; None = no such event in the log. A given time must lie inside the log
        and the given ones be ordered trigger < lift_off < release, else
        ``TrebuchetInputError`` naming the log file and the event.
    form : "projected" (default) or "direct"; trough : "constraint" (default) or
        "measured" (see the module doc); image_calibration : "engine" (default, point
        logs: the engine calibrates the image) or "none" (``ReconstructOptions``); they
        override ``options``.
    method : None (default): the loads of the scene's engine fitted to a log of angles
        where the fit passes its residual check, else the smoother's (with a note why);
        "fit": the same for a log of tracked points too; "smooth": the smoother's
        (:mod:`.identification.fitted_loads`, docs/identify.md).
    q, r : the smoother's process noise and measurement noise sd (rad), per angle or one
        number; default maximum likelihood.
    options : :class:`ReconstructOptions`.

    Returns
    -------
    DataFrame with the log's rows: ``t`` (s, the log's time), ``t_shot`` (s after the
    detected trigger), ``phase`` (0 at rest, 1 trough, 2 sling, 3 released), the angles,
    rates and accelerations, every column of :func:`trebuchet.model.loads.loads`, and
    ``X_sd`` for each of them. ``attrs["reconstruction"]``: a
    :class:`~trebuchet.ingest.reconstruction.Reconstruction` (events with their sd and
    sources, the noise per angle, form, trough, fps, advisories, validity findings,
    notes); ``attrs["events"]``: the events as a plain dict (trigger, lift_off, release;
    log time, s, or None); ``attrs["log"]``: the log's
    :class:`~trebuchet.ingest.logs.result.ReadLog` when it was read from a file.

    Raises
    ------
    TrebuchetInputError : a bad log, scene or option (the message names file, row or key).

    Warns
    -----
    ModelValidityWarning : angles outside the scene's geometry, a slack sling, loads
        the frame rate and noise do not resolve (the advisory), or, where the sling's
        track goes on past the release, accelerations that fit the scene's equations
        neither in the sling nor released (``ReconstructOptions.release_model``).
    """
    if options is None:
        options = ReconstructOptions()
    changes = {k: v for k, v in (("form", form), ("trough", trough), ("method", method),
                                 ("image_calibration", image_calibration)) if v is not None}
    if changes:
        options = dataclasses.replace(options, **changes)
    scene = as_scene(scene, "reconstruct")
    read = read_stage(path_or_log, scene, options, fps=fps, columns=columns, points=points,
                      read_options={"min_likelihood": min_likelihood, "time_unit": time_unit,
                                    "angle_unit": angle_unit, "individual": individual},
                      calibration=calibration)
    t_log, angles_log = validated_log(read.log, smoother_settings(options).min_frames)
    check_shot(t_log, angles_log, read.source)
    given = {} if events is None else checked_events(events, t_log, read.source)
    fitted = fitted_stage(read, scene, given, options)
    if fitted is not None and fitted.result is not None:
        return fitted.result
    shot = smoothed_with_release(read.log, angles_log, scene, options, given, q, r,
                                 plane=None if read.calibrated is None
                                 else read.calibrated.plane)
    check_given_release(given, smoothing_of(shot.est).events.get("trigger"), read.source)
    est = matched_scene(shot.est, scene, options, read.source)
    est = refined_estimate(est, read, scene, angles_log)
    result = loads_stage(est, read, scene, given, options, shot, angles_log)
    warn_checks(result, read.source, () if shot.choice is None or shot.choice.warning is None
                else (shot.choice.warning,))
    return result if fitted is None else fitted.explained(result)  # why not the fit's loads
