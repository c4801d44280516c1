"""The settings of :func:`~trebuchet.ingest.reconstruct.reconstruct`: its presets, the
smoother settings each gives, and the settings of the smoothing whose release is checked.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from trebuchet.core.errors import TrebuchetInputError, check_choice
from trebuchet.ingest.events.release_model import ReleaseFit
from trebuchet.ingest.settings import FORMS, IMAGE_CALIBRATIONS, METHODS, TROUGH
from trebuchet.ingest.smoothing.noise_tuning import NoiseSearch
from trebuchet.ingest.smoothing.smooth import SmoothSettings

__all__ = ["ReconstructOptions", "PRESETS", "smoother_settings", "propagation_order",
           "checking_settings", "FORMS"]

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
    ``scene_mismatch``: a log whose swing is another engine's than the scene's
    (:mod:`~trebuchet.ingest.scene_match`: its swing time or peak rate off by more than a
    third) is refused ("refuse", default: its loads would be computed with another
    engine's masses) or only warned about ("warn", as ``compare`` does, whose report shows
    how the model differs); a smaller mismatch always warns.
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
    scene_mismatch: str = "refuse"
    method: str | None = None  # issue 23: None (default), "fit" or "smooth" (fitted_loads.py)

    def __post_init__(self) -> None:
        check_choice("reconstruct", "method", self.method, (None, *METHODS))
        check_choice("reconstruct", "preset", self.preset, tuple(PRESETS))
        check_choice("reconstruct", "image_calibration", self.image_calibration,
                     IMAGE_CALIBRATIONS)
        check_choice("reconstruct", "form", self.form, FORMS)
        check_choice("reconstruct", "trough", self.trough, TROUGH)
        check_choice("reconstruct", "scene_mismatch", self.scene_mismatch, ("refuse", "warn"))
        if not (np.isfinite(self.event_sd_frames) and self.event_sd_frames >= 0):
            raise TrebuchetInputError("reconstruct: event_sd_frames must be ≥ 0")


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
