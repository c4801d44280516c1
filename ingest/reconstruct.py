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
  :class:`~trebuchet.errors.ModelValidityWarning` and in ``attrs``.

Measured accuracy of both forms and the bands' coverage: ``bench/ingest_accuracy.py``.
Units: SI (s, rad, rad/s, rad/s², N, N m, W, J, m, m/s).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.special import ndtr

from trebuchet.errors import (
    ModelValidityWarning,
    TrebuchetDataWarning,
    TrebuchetInputError,
    check_choice,
    warn_at_caller,
)
from trebuchet.ingest.advisory import (
    ADVISED,
    peak_width_advisories,
    resolution_advisories,
    smoother_bandwidth,
)
from trebuchet.ingest.calibrated_angles import calibrated_log, widened_by_calibration
from trebuchet.ingest.events.lift_off import (
    lift_off_sd,
    lift_off_time,
    offset_widened_sd,
    rest_offset,
)
from trebuchet.ingest.events.release_model import (
    ModelRelease,
    ReleaseFit,
    release_choice,
    release_from_model,
    scene_doubt,
)
from trebuchet.ingest.events.release_sources import TrackEndRelease, release_at_track_end
from trebuchet.ingest.events.sling_continuation import continued_sling, release_horizon
from trebuchet.ingest.events.stone_flight import points_stone_release
from trebuchet.ingest.geometry.user_calibration import read_calibration
from trebuchet.ingest.identification.fitted_loads import fitted_reconstruction
from trebuchet.ingest.logs.read_log import MIN_LIKELIHOOD
from trebuchet.ingest.logs.result import read_log_info
from trebuchet.ingest.logs.scene_check import scene_check
from trebuchet.ingest.reconstruction import Reconstruction, reconstruction_of
from trebuchet.ingest.scene_fit import geometry_findings, warn_findings
from trebuchet.ingest.settings import FORMS, IMAGE_CALIBRATIONS, METHODS, TROUGH
from trebuchet.ingest.smoothing.counterweight_continuation import with_continued_counterweight
from trebuchet.ingest.smoothing.noise_tuning import NoiseSearch
from trebuchet.ingest.smoothing.result import smoothing_of, with_angle_rows, with_smoothing
from trebuchet.ingest.smoothing.smooth import (
    ANGLES,
    SUFFIXES,
    SmoothSettings,
    checked_events,
    smooth,
    validated_log,
)
from trebuchet.ingest.systematic_angles import systematic_angles, with_systematic_angles
from trebuchet.ingest.uncertainty import chunk_rows, propagate
from trebuchet.ingest.user_calibrated import posed_log
from trebuchet.model import dynamics as dyn
from trebuchet.model.loads import load_columns
from trebuchet.model.scene import Scene, as_scene

__all__ = ["ReconstructOptions", "reconstruct", "loads_from_smoothed", "shot_phases",
           "sling_track_end", "PRESETS", "smoother_settings", "propagation_order",
           "STATE_COLUMNS", "FORMS"]

STATE_COLUMNS = [a + s for a in ANGLES for s in SUFFIXES]
DERIVATIVE_COLUMNS = [a + s for a in ANGLES for s in SUFFIXES[1:]]
#: preset -> (smoother settings, uncertainty propagation order); see ReconstructOptions.
PRESETS: dict[str, tuple[SmoothSettings, int]] = {
    "fast": (SmoothSettings(noise=NoiseSearch(log10_step=1.0), band_variance="posterior",
                            bias_iterations=1), 1),
    "default": (SmoothSettings(), 2),
    "precise": (SmoothSettings(local_window=1.5), 2),
}


def smoother_settings(options: ReconstructOptions) -> SmoothSettings:
    """The smoother settings of ``options``: its own, else its preset's."""
    return options.smooth if options.smooth is not None else PRESETS[options.preset][0]


def propagation_order(options: ReconstructOptions) -> int:
    """Order (1 or 2) of the uncertainty propagation of ``options``' preset."""
    return PRESETS[options.preset][1]


@dataclass(frozen=True)
class ReconstructOptions:
    """Settings of :func:`reconstruct`.

    ``form``: "projected" or "direct" (see the module doc). ``trough``: "constraint" or
    "measured" φ in phase I. ``event_sd_frames``: sd of a detected release time, in frames,
    and of a detected trigger when the smoother does not give one (it gives the spread of
    the trigger's likelihood profile, :func:`~trebuchet.ingest.events.detection.trigger_estimate`);
    a given event is exact. ``release_at_track_end``: when the sling's track
    ends while the others go on, the release is put between its last frame and the next
    (sd: the gap / √12) and handed to the smoother, instead of the smoother's search for
    a jump in the last frames of the track (which at 60 fps landed about 6 frames early
    on simulated logs, ``bench/ingest_accuracy.py``); with ``release_model`` set, a
    track's end is the release only if the engine or the stone agrees
    (:func:`_lost_or_released`: a track lost before the release is carried on by the
    sling's pendulum; a stone tracked in flight past the release is found leaving its
    sling's circle, :mod:`.events.stone_flight`; the sources are weighed by their sd,
    :mod:`.events.release_sources`). On the video bench (``bench/video_accuracy.py``, 28
    logs of both engines, tilts to 15°, 120 and 240 fps) the track's end came 1.4–11
    frames after the release with a stated sd of 0.29 frame; with the stone and the
    equations every release lies within 0.71 frame, sd 0.36–0.5 frame.
    ``resolution_fraction``: the advisory speaks where a load's sd exceeds this fraction of
    its peak. ``model``: the smoother's model ("ca", "cj", or per angle the likelier of
    both, "select", or their mixture, "average":
    :mod:`~trebuchet.ingest.smoothing.model_choice`); ``smooth``: its settings (default: the
    preset's). Measured on ``bench/ingest_accuracy.py`` (six seeds,
    projected form; inside / too narrow / too wide of 85–99 %, mean |F_R| RMS error):
    the default 157 / 0 / 3, 1.62 % (seeds 6–11: 158 / 0 / 2, 12–17: 160 / 0 / 0;
    :class:`~trebuchet.ingest.smoothing.smooth.SmoothSettings` gives the steps to it: bands of
    the measurement noise's error plus the process noise's share as far as the data
    show it, and two terms of the bias; before them 151 / 1 / 8, 150 / 0 / 10 and
    154 / 0 / 6); with the default smoother settings before that (local noise
    over a window of 4 time constants, no bias term; 139 / 7 / 14, 1.83 %) and at the
    maximum-likelihood ``q``
    (``smooth=SmoothSettings(noise=NoiseSearch(cutoff_factor=1.0))``) "ca" 86 / 0 / 74,
    1.71 %, "cj" 131 / 29 / 0, 1.79 %, "select" 142 / 2 / 16, 1.68 %, "average" 139 / 0 /
    21, 1.67 %; "select" with the default ``cutoff_factor`` 59 / 99 / 2 (the likelihood
    prefers "cj" for most angles, whose bands at 0.8⁸ of its q are far too narrow).
    "select" and "average" run both smoothers: about 1.5–2× the time (2 s at 1000 fps:
    over the 0.5 s budget), so they are not the default.

    ``preset`` trades time for accuracy (``bench/ingest_trade.py`` measures it):

    - ``"fast"``: the default's estimates from a coarser noise search (grid step 1
      decade of ``q/r²``) and plainer bands: the smoother's posterior ``P`` instead of
      its calibrated process-noise share (``SmoothSettings.band_variance="posterior"``:
      no simulated draws), one term of the bias instead of two, first-order uncertainty
      propagation (forward differences: 9 load evaluations instead of 18, no
      second-order variance or bias term). Measured (``bench/ingest_accuracy.py``'s 160
      cells, seeds 0–5, projected form): mean |F_R| RMS error 1.63 % against 1.62 %,
      the three target cells 0.60 / 1.14 / 2.13 % (default 0.60 / 1.17 / 2.16 %), bands
      inside 85–99 % in 148 cells (4 too narrow, 8 too wide) against 160; smoothing and
      loads 0.036 s a log against 0.093 s, ``reconstruct`` of the 2 s log at 1000 fps
      about 0.5× the default's (``bench/reconstruct_speed.py``). Until this note it had
      one process noise for the whole log (``local_noise=False``) and the default's
      bands: 137 / 0 / 23 cells, 2.12 % (its single ``q`` widened the bands where the
      motion is slow), and it was slower than the default on that log;
    - ``"default"``: grid step ½ decade, the process noise shaped frame by frame by the
      jerk of a first smoothing over a window of 2 time constants (local-linear; at the
      end of the sling's track at least the angles' common shape), the smoothing bias in
      the bands (two terms of its series) and the posterior's process-noise share only
      as far as the data show it (``SmoothSettings.local_noise``, ``bias_band``,
      ``band_variance``), second-order propagation (central differences, variance and
      bias);
    - ``"precise"``: as the default with a window of 1.5 time constants: smaller errors
      (``bench/ingest_accuracy.py``, six seeds: mean |F_R| RMS error 1.58 % of the peak
      against 1.62 %, the three target cells 0.60 / 1.15 / 2.05 % against 0.60 / 1.17 /
      2.16 %) and as many cells inside 85–99 % (151 of 160; on seeds 6–11 157 against
      150, on 12–17 152 against 154), but more of the misses are too narrow bands (4
      against 1; 0 and 2 against 0 and 0), at 2° noise and 60–120 fps. A noise grid
      of ¼ decade instead: 146 / 4 / 10, 1.62 %. Until the bias term and the common
      track end (default since) it was the window of 2 time constants. With the
      calibrated bands and two bias terms (default since): 154 / 4 / 2 against the
      default's 157 / 0 / 3 (seeds 6–11: 160 / 0 / 0 against 158 / 0 / 2), the misses
      too narrow at 2° noise and 60–120 fps.

    An explicit ``smooth`` replaces the preset's smoother settings.

    ``release_model``: when the release is neither given nor the end of the sling's
    track (the track goes on past it: an empty sling swinging, a tracker following the
    stone), it is checked against the engine's equations (:mod:`.events.release_model`: the
    measured θ̈, ψ̈ follow phase II before it and phase III after it); where the two
    disagree, or the smoother found no release, the model's release is handed to the
    smoother (a second smoothing) with its sd. None: no check. The first smoothing then
    runs with :func:`checking_settings` and the second, with the full settings and a
    release given (the model's, or where it is not used the smoother's own), takes its
    trigger and noise search (``smooth(tuned=…)``; 2 s at 1000 fps: about 0.47 s against
    0.7 s for two full smoothings; accuracy on the 192 logs of :mod:`.events.release_model`:
    release error median 0.24, 90 % 1.5 frames, 97 % within 2 sd, peak |F_S| 3.5 % /
    9.8 %). Angles near the release that fit the scene's equations worse than their
    noise allows warn (:func:`~.release_model.scene_doubt`: a scene a little off).
    ``image_calibration``: for a log of tracked points, "engine" (default) fits the camera
    (tilt, roll, lens, scale, marker offsets) with the scene's geometry
    (:mod:`.calibrated_angles`; points that break it are named and left out, and the
    calibration's sd widens the angles' bands) and takes each angle from its two points
    through that camera; a camera that puts the angles more than 5° from the image's own
    is refused with a warning. "none" keeps the angles ``read_log`` took from two points
    each (right for a camera square to the engine with a perfect lens). Logs of angles
    are not touched. Measured on the video bench's default grid (34 cells, seed 0,
    rendered and tracked shots of both engines): median release error 5.2 → 2.3 frames,
    release target met in 8 cells (4), median cover of the ±2 sd bands F_R_x 44 → 71 %,
    F_S_y 71 → 85 %, |F_R| RMS error 3.1 → 3.2 % of its peak (median), |F_S| 1.7 → 1.5 %;
    about 1 s more for a few hundred frames.
    """

    form: str = "projected"
    trough: str = "constraint"
    event_sd_frames: float = 0.5
    resolution_fraction: float = 0.1
    release_at_track_end: bool = True
    model: str = "ca"
    smooth: SmoothSettings | None = None
    preset: str = "default"
    release_model: ReleaseFit | None = ReleaseFit()
    image_calibration: str = "engine"
    method: str | None = None  # issue 23: None (default), "fit" or "smooth" (fitted_loads.py)

    def __post_init__(self) -> None:
        check_choice("reconstruct", "method", self.method, (None, *METHODS))
        check_choice("reconstruct", "preset", self.preset, tuple(PRESETS))
        check_choice("reconstruct", "image_calibration", self.image_calibration,
                     IMAGE_CALIBRATIONS)
        check_choice("reconstruct", "form", self.form, FORMS)
        check_choice("reconstruct", "trough", self.trough, TROUGH)
        if not (np.isfinite(self.event_sd_frames) and self.event_sd_frames >= 0):
            raise TrebuchetInputError("reconstruct: event_sd_frames must be ≥ 0")


# ----------------------------------------------------------------------------- phases


def shot_phases(t: np.ndarray, scene: Scene, trigger: float | None, lift_off: float | None,
                release: float | None) -> np.ndarray:
    """Phase of each row (int): 0 at rest (``t ≤ trigger``), then the scene's phases: 1 in
    the trough until ``lift_off``, 2 in the sling until ``release``, 3 after (times in s,
    the log's time; None = no such event in the log)."""
    t = np.asarray(t, dtype=float)
    first = scene.phases[0]
    phase = np.full(t.size, first, dtype=np.int64)
    if first == 1 and lift_off is not None:
        phase[t > lift_off] = 2
    if first != 3 and release is not None:
        phase[t > release] = 3
    if trigger is not None:
        phase[t <= trigger] = 0
    return phase


def _evaluate(state: pd.DataFrame, phase: np.ndarray, scene: Scene, form: str,
              trough: str) -> dict[str, np.ndarray]:
    """The columns of ``loads`` (pandas-free: :func:`~trebuchet.model.loads.load_columns`)
    on ``state`` with rest rows (phase 0) as the scene's first phase at zero rates and
    accelerations, and, for ``trough="constraint"``, φ and its derivatives from θ in the
    trough."""
    cols = {c: np.asarray(state[c], dtype=float) for c in state.columns}
    rest = phase == 0
    first = scene.phases[0]
    run_phase = np.where(rest, first, phase)
    if rest.any():
        for col in DERIVATIVE_COLUMNS:
            cols[col] = np.where(rest, 0.0, cols[col])
    if trough == "constraint" and first == 1:
        sel = run_phase == 1
        if sel.any():
            e, H = scene.engine, scene.start.H
            th, th_d, th_dd = (cols[c][sel] for c in ("theta", "theta_d", "theta_dd"))
            with np.errstate(invalid="ignore", divide="ignore"):
                ph = dyn.trough_sling_angle(th, e, H)
                ph_d = dyn.trough_phi_d(th, ph, th_d, e)
                ph_dd = dyn.trough_phi_dd(th, ph, th_d, ph_d, th_dd, e)
            for col, v in (("phi", ph), ("phi_d", ph_d), ("phi_dd", ph_dd)):
                values = cols[col].copy()
                values[sel] = v
                cols[col] = values
    cols["phase"] = run_phase
    try:
        out = load_columns(cols, scene, form=form)
    except ValueError as exc:  # phase-3 rows without a sling row before them
        raise TrebuchetInputError(f"reconstruct: {exc}") from None
    out["phase"] = phase
    return out


def _flight_carry(phase: np.ndarray) -> Callable[[int, int], list[int]]:
    """``carry`` of a chunked propagation: rows in flight (phase 3) need the last row in the
    sling (the flight starts from its state) in their chunk."""
    held = np.flatnonzero(phase != 3)
    last = int(held[-1]) if held.size else -1

    def carry(lo: int, hi: int) -> list[int]:
        return [last] if 0 <= last < lo and bool(np.any(phase[lo:hi] == 3)) else []

    return carry


def _state(est: pd.DataFrame) -> pd.DataFrame:
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


def _event_variance(t: np.ndarray, event: float | None, sd: float,
                    values: np.ndarray) -> np.ndarray:
    """Variance (n, m) from the chance that a row lies on the other side of an event whose
    time (s) has sd ``sd`` (s): ``P(other side) × (load across the event − load)²``, the
    load across the event taken from the nearest row on the other side."""
    var = np.zeros_like(values)
    if event is None or not sd > 0:
        return var
    after = t > event
    if after.all() or not after.any():
        return var
    i_before = int(np.flatnonzero(~after)[-1])
    i_after = int(np.flatnonzero(after)[0])
    near = np.flatnonzero(np.abs(t - event) < 6.0 * sd)  # only these rows: no (n, m) temporaries
    p_after = ndtr((t[near] - event) / sd)
    p_other = np.where(after[near], 1.0 - p_after, p_after)
    other = np.where(after[near, None], values[i_before][None, :], values[i_after][None, :])
    diff = np.nan_to_num(other - values[near])
    var[near] = p_other[:, None] * diff ** 2
    return var


# ----------------------------------------------------------------------------- main


def _detect_lift_off(state: pd.DataFrame, cov: dict[str, np.ndarray], scene: Scene,
                     trigger: float | None, release: float | None,
                     options: ReconstructOptions) -> tuple[float | None, float]:
    """Lift-off (s, log time) and its sd (s) from the phase-I normal force on every row;
    the sd widened by the shift the angles' common offset at rest (the log's θ at rest
    against the scene's start θ: a camera's roll) makes (:func:`.events.lift_off.
    offset_widened_sd`)."""
    t = state["t"].to_numpy()
    trial = shot_phases(t, scene, trigger, None, None)
    trial[trial == 3] = 1
    fn = _evaluate(state, trial, scene, options.form, options.trough)["F_N"]
    when = lift_off_time(t, fn, trigger, release)
    if when is None:
        return None, float("nan")
    i = int(np.clip(np.searchsorted(t, when), 1, t.size - 1))
    rows = np.arange(max(i - 1, 0), min(i + 1, t.size))
    sub = state.iloc[rows].reset_index(drop=True)
    sub_cov = {a: c[rows] for a, c in cov.items()}
    # the trial phases have no phase 3, so the rows are independent: one stacked call
    prop = propagate(lambda s: _evaluate(s, np.resize(trial[rows], len(s)), scene,
                                         options.form, options.trough),
                     sub, sub_cov, ["F_N"], order=propagation_order(options), stacked=True)
    sd = lift_off_sd(t[rows], prop.value[:, 0], prop.sd[:, 0], when)
    offset = rest_offset(t, state["theta"].to_numpy(), trigger, scene.start.theta)
    if np.isfinite(offset) and offset != 0.0:  # the angles' common offset moves F_N's zero
        shifted = state.assign(theta=state["theta"].to_numpy() - offset)
        fn_shifted = _evaluate(shifted, trial, scene, options.form, options.trough)["F_N"]
        sd = offset_widened_sd(sd, when, lift_off_time(t, fn_shifted, trigger,
                                                        release))
    return when, sd


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


def loads_from_smoothed(est: pd.DataFrame, scene: Scene, *,
                        events: Mapping[str, float | None] | None = None,
                        options: ReconstructOptions | None = None,
                        release_sd: float | None = None,
                        lines: np.ndarray | None = None) -> pd.DataFrame:
    """Every load and its sd from the output of :func:`~trebuchet.ingest.smoothing.smooth.smooth`.

    ``lines``: the file's line number of each row (``read_log``'s ``ReadLog.lines``); the
    advisories and validity findings then name rows by them, as the reader's notes do.

    ``events``: given event times (s, log time; None = no such event) overriding those in
    the smoothing's and the lift-off detection; ``release_sd`` (s): sd of the
    release time in ``est`` if known (default ``event_sd_frames`` frames). Returns the
    frame of :func:`reconstruct` (without the log's own attrs).
    """
    options = options or ReconstructOptions()
    given = dict(events or {})
    t = est["t"].to_numpy(dtype=float)
    state = _state(est)
    fit = smoothing_of(est)
    cov = {a: np.asarray(c, dtype=float)[:, :3, :3] for a, c in fit.cov.items()}
    found = dict(fit.events)
    sources = dict(fit.event_sources)
    trigger = given["trigger"] if "trigger" in given else found.get("trigger")
    release = given["release"] if "release" in given else found.get("release")
    if scene.projectile == "none":
        release = None
    elif release is not None and "release" not in given:
        release = _release_within_sling_track(t, est["phi"].to_numpy(dtype=float), release)
    fps = 1.0 / float(np.median(np.diff(t)))
    sd_event = options.event_sd_frames / fps
    trigger_sd = fit.event_sd.get("trigger", sd_event)
    event_sd = {"trigger": 0.0 if "trigger" in given or trigger is None else trigger_sd,
                "release": 0.0 if "release" in given or release is None
                else (sd_event if release_sd is None else release_sd)}
    lift = None
    event_sd["lift_off"] = float("nan")
    if scene.projectile == "trough":
        if "lift_off" in given:
            lift = given["lift_off"]
            sources["lift_off"] = "given" if lift is not None else "given as none"
            event_sd["lift_off"] = 0.0
        else:
            lift, event_sd["lift_off"] = _detect_lift_off(state, cov, scene, trigger, release,
                                                          options)
            sources["lift_off"] = ("trough normal force reaches zero" if lift is not None
                                   else "the normal force never reaches zero before release")
    else:
        sources["lift_off"] = f"no trough (projectile {scene.projectile!r})"
    phase = shot_phases(t, scene, trigger, lift, release)

    prop = propagate(lambda s: _evaluate(s, phase[np.asarray(s.index)], scene, options.form,
                                         options.trough),
                     state, cov, order=propagation_order(options), chunk=chunk_rows(len(state)),
                     carry=_flight_carry(phase), order_names=list(ADVISED), columns=True)
    ev_var = _event_variance(t, trigger, event_sd["trigger"], prop.value)
    ev_var += _event_variance(t, release, event_sd["release"], prop.value)
    sd = prop.sd  # √(sd² + the events' variance), in place (a 60 s log: 20 MB an array)
    np.sqrt(np.add(np.square(sd, out=sd), ev_var, out=sd), out=sd)

    notes = list(fit.notes)
    if trigger is None:
        notes.append("no rest found at the start: t_shot counts from the first frame")
    moving = phase > 0
    noise = fit.noise
    noise_deg = float(np.degrees(np.median([v["r_sd"] for v in noise.values()]))) \
        if noise else float("nan")
    col = {c: j for j, c in enumerate(prop.names)}
    advice = resolution_advisories(
        t, moving, {c: prop.value[:, j] for c, j in col.items()},
        {c: sd[:, j] for c, j in col.items()}, {c: prop.orders(c) for c in prop.order_names},
        {c: ev_var[:, j] for c, j in col.items()}, fps, noise_deg,
        options.resolution_fraction, lines=lines)
    advice += peak_width_advisories(t, moving, {c: prop.value[:, j] for c, j in col.items()},
                                    smoother_bandwidth(noise, t), fps, noise_deg, lines=lines)
    del ev_var

    t_shot = t - (trigger if trigger is not None else t[0])
    out: dict[str, np.ndarray] = {"t": t, "t_shot": t_shot, "phase": phase}
    for c in STATE_COLUMNS:  # the smoothed angles (phase-I loads may use φ from θ)
        out[c] = state[c].to_numpy()
    for j, c in enumerate(prop.names):
        out[c] = prop.value[:, j]
    for c in STATE_COLUMNS:
        out[c + "_sd"] = est[c + "_sd"].to_numpy(dtype=float)
    for j, c in enumerate(prop.names):
        out[c + "_sd"] = sd[:, j]
    result = pd.DataFrame(out, index=est.index)
    del out, prop, sd
    validity = geometry_findings(t, phase, result["theta"].to_numpy(), result["psi"].to_numpy(),
                                 result["phi"].to_numpy(), scene,
                                 tension=result["sling_tension"].to_numpy(),
                                 tension_sd=result["sling_tension_sd"].to_numpy(), lines=lines)
    events = {"trigger": trigger, "lift_off": lift, "release": release}
    result.attrs["events"] = dict(events)
    result.attrs["reconstruction"] = Reconstruction(
        events=events, event_sd=event_sd, event_sources=sources, noise=noise,
        form=options.form, trough=options.trough, model=fit.model, preset=options.preset,
        fps=fps, advisories=advice, validity=validity, notes=notes)
    return result


def checking_settings(settings: SmoothSettings) -> SmoothSettings:
    """The smoother settings of the smoothing whose release is checked against the
    engine's equations, whose result is not kept (the log is smoothed again with the
    release given: the model's, on 188 of 192 simulated logs whose sling track goes on,
    or the smoother's own): ``settings`` without the bands' calibration (the check's
    coarse stage only weighs the accelerations by their sd), with the noise grid of
    the "fast" preset (1 decade) and no second search after a release is found.
    Measured (``/tmp``-run table of 192 such logs, 1000 fps 2 s: 0.47 s against 0.7 s):
    the release as accurate (error median 0.24, 90 % 1.5 frames, 97 % within 2 sd;
    before 0.23, 1.6, 95 %); the smoother's own release moved on 1 of the 4 logs where
    it is kept (by 0.25 frame). Kept: local noise (without it: 90 % 2.3 frames, 92 %
    within 2 sd) and the bias term (without it one release was lost)."""
    return dataclasses.replace(settings, band_variance="posterior",
                               noise=dataclasses.replace(settings.noise, log10_step=1.0),
                               retune_after_release=False)


def _release_by_the_equations(log: pd.DataFrame, angles_log: np.ndarray, est: pd.DataFrame,
                              scene: Scene, options: ReconstructOptions,
                              smooth_events: dict[str, float | None],
                              q: float | Mapping[str, float] | None,
                              r: float | Mapping[str, float] | None
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
    fitted = _model_release(angles_log, est, scene, settings)
    t = est["t"].to_numpy(dtype=float)
    sd_free = options.event_sd_frames * float(np.median(np.diff(t)))
    use, sentence = release_choice(fitted, found.get("release"), settings)
    name = Path(_source(log)).name
    if sentence is not None and not use:
        warn_at_caller(f"{name}: {sentence}", ModelValidityWarning)
    doubt = scene_doubt(fitted, settings)
    if doubt is not None:
        warn_at_caller(f"{name}: {doubt}", ModelValidityWarning)
    if not use:
        # the smoother's own release stands: the log smoothed again with it given
        est = _smooth_again(log, est, options, smooth_events, q, r, found.get("release"))
        est = with_smoothing(est, smoothing_of(est).noted(doubt, sentence))
        if sentence is not None:
            return est, None
        # agreed: the smoother's time stands, with the wider of the two sds
        return est, (None if fitted.time is None or found.get("release") is None
                     else max(sd_free, fitted.sd))
    notes = smoothing_of(est).notes
    est = _smooth_again(log, est, options, smooth_events, q, r, fitted.time)
    again = smoothing_of(est)
    again = again.replace(notes=notes).noted(*again.notes, sentence, doubt)
    return with_smoothing(est, again.with_source("release", fitted.how)), fitted.sd


def _model_release(angles_log: np.ndarray, est: pd.DataFrame, scene: Scene,
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


def _with_continued_sling(est: pd.DataFrame, scene: Scene, last: int,
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


def _lost_or_released(log: pd.DataFrame, angles_log: np.ndarray, est: pd.DataFrame,
                      scene: Scene, options: ReconstructOptions,
                      smooth_events: dict[str, float | None],
                      q: float | Mapping[str, float] | None,
                      r: float | Mapping[str, float] | None,
                      track_end: tuple[float, float]) -> tuple[pd.DataFrame, float]:
    """The smoothed log and the release's sd (s) where the sling's track ends while θ and ψ
    go on: a release only if the engine or the stone agrees
    (:func:`.events.release_sources.release_at_track_end`). The sources: the engine's
    equations on θ and ψ (:func:`_model_release`, φ carried on past the track by the
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
    fitted = _model_release(angles_log, _with_continued_sling(est, scene, last), scene,
                            settings)
    info = read_log_info(log)
    stone = (None if info is None or info.points is None
             else points_stone_release(info.points, scene, float(t[last])))
    choice = release_at_track_end(track_end, float(t[last]), float(t[last + 1]),
                                  float(np.median(np.diff(t))), stone, fitted,
                                  TrackEndRelease(max_misfit=settings.max_misfit))
    if choice.warning is not None:
        warn_at_caller(f"{Path(_source(log)).name}: {choice.warning}", ModelValidityWarning)
    if choice.kind == "track end" and choice.time == track_end[0]:
        return with_smoothing(est, smoothing_of(est).noted(choice.note, choice.warning)), \
            choice.sd
    if choice.kind == "lost":
        t_last = float(t[last])
        again = _smooth_again(log, est, options, smooth_events, q, r, choice.time)
        again = _with_continued_sling(again, scene, last, until=choice.time)
        gap = choice.time - track_end[0]
        fit = smoothing_of(again).with_source("release", choice.source).noted(
            f"the sling's track ends at {t_last:.4f} s, but θ and ψ follow the engine in the "
            f"sling until {choice.time:.4f} s (sd {1e3 * choice.sd:.1f} ms, "
            f"{1e3 * gap:.0f} ms later): the track was lost, not released; φ is carried on "
            "by the sling's pendulum up to the release", choice.note, choice.warning)
        return with_smoothing(again, fit), choice.sd
    cut = log.copy()
    cut.loc[cut["t"].to_numpy(dtype=float) > choice.time, "phi"] = np.nan
    again = _smooth_again(cut, est, options, smooth_events, q, r, choice.time)
    fit = smoothing_of(again).with_source("release", choice.source).noted(choice.note,
                                                                          choice.warning)
    return with_smoothing(again, fit), choice.sd


def _smooth_again(log: pd.DataFrame, est: pd.DataFrame, options: ReconstructOptions,
                  smooth_events: dict[str, float | None],
                  q: float | Mapping[str, float] | None, r: float | Mapping[str, float] | None,
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


def _source(log: pd.DataFrame) -> str:
    """The log's file as ``read_log`` was given it, else ``"log"``."""
    info = read_log_info(log)
    return "log" if info is None else info.source


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


def reconstruct(path_or_log: str | Path | pd.DataFrame, scene: Scene | str | Path,
                fps: float | None = None, columns: Mapping[str, str] | None = None,
                points: Mapping[str, str] | None = None, *,
                events: Mapping[str, float | None] | None = None,
                form: str | None = None, trough: str | None = None,
                image_calibration: str | None = None, method: str | None = None,
                q: float | Mapping[str, float] | None = None,
                r: float | Mapping[str, float] | None = None,
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
    user = read_calibration(calibration) if calibration is not None else None
    read_options = {"min_likelihood": min_likelihood, "time_unit": time_unit,
                    "angle_unit": angle_unit, "individual": individual, "calibration": user}
    if user is not None and isinstance(path_or_log, pd.DataFrame):
        raise TrebuchetInputError("reconstruct: calibration= applies to a log file of tracked "
                                  "points, not to a table of angles")
    log = _log_frame(path_or_log, fps, columns, points, read_options)
    source = _source(log)
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
    given: dict[str, float | None] = {}
    t_log, angles_log = validated_log(log, smoother_settings(options).min_frames)
    if events is not None:
        given = checked_events(events, t_log, source)
    # issue 23: the loads of the engine fitted to the log, where it passes its residual check
    fitted = (fitted_reconstruction(log, scene, given, form=options.form, trough=options.trough,
                                    resolution_fraction=options.resolution_fraction,
                                    source=source, method=options.method)
              if options.method != "smooth" else None)
    if fitted is not None and fitted.result is not None:
        return fitted.result
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
            est, release_sd = _lost_or_released(log, angles_log, est, scene, options,
                                                smooth_events, q, r, track_end)
    elif check:
        est, release_sd = _release_by_the_equations(log, angles_log, est, scene, options,
                                                    smooth_events, q, r)
    elif unchecked:
        est = with_smoothing(est, smoothing_of(est).noted(
            "the release was not checked against the engine's equations "
            f"({' and '.join(untracked)} not tracked); it comes from the jump search alone"))
    if swing is not None and swing.note:
        est = with_smoothing(est, smoothing_of(est).noted(swing.note))
    if user is not None:
        est = with_smoothing(est, smoothing_of(est).noted(user.describe(), *posed))
    if calibrated is not None:
        est = widened_by_calibration(est, calibrated.common_sd)
        est = with_smoothing(est, smoothing_of(est).noted(*calibrated.notes))
    est = with_continued_counterweight(est, scene, angles_log[ANGLES.index("psi")])
    found = smoothing_of(est).events
    est = with_systematic_angles(est, systematic_angles(
        log, scene, found.get("trigger"), found.get("release"),
        points=None if calibrated is None else calibrated.plane))
    info = read_log_info(log)
    lines = info.lines if info is not None and info.lines is not None \
        and len(info.lines) == len(est) else None
    result = loads_from_smoothed(est, scene, events=given, options=options, lines=lines,
                                 release_sd=release_sd)
    if info is not None:
        result.attrs["log"] = info
    name = Path(source).name
    done = reconstruction_of(result)
    warn_findings(list(done.validity), name)
    advice = done.advisories
    if advice:
        warn_at_caller(f"{name}: " + "; ".join(a.message for a in advice),
                      ModelValidityWarning)
    return result if fitted is None else fitted.explained(result)  # why not the fit's loads
