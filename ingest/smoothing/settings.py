"""Settings of :func:`~trebuchet.ingest.smoothing.smooth.smooth`, and the measurements behind their
defaults (the ``SmoothSettings`` docstring records every variant tried, with its numbers).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from trebuchet.core.errors import TrebuchetInputError, check_choice
from trebuchet.ingest.events.detection import ReleaseSearch, TriggerSearch
from trebuchet.ingest.smoothing.noise_tuning import NoiseSearch

ANGLES: tuple[str, ...] = ("theta", "psi", "phi")
MODEL_STATES: dict[str, int] = {"ca": 3, "cj": 4}
SUFFIXES: tuple[str, ...] = ("", "_d", "_dd")
#: ``SmoothSettings.band_variance``: the smoother's posterior ``P``, the error of the
#: measurement noise alone, or that plus the posterior's process-noise share scaled by
#: what the data show of it (see ``SmoothSettings``).
BAND_VARIANCES: tuple[str, ...] = ("posterior", "noise", "calibrated")
#: ``SmoothSettings.band_alpha_from``: the calibration ``α`` from the smoother's backward
#: sums of the data, or that shrunk toward the one of the data's smoothing residual as far
#: as the residual's scatter allows (see ``SmoothSettings``).
BAND_ALPHA_FROM: tuple[str, ...] = ("sums", "shrunk")


@dataclass(frozen=True)
class SmoothSettings:
    """Settings of :func:`smooth` that users rarely change.

    ``kick_scale``: sd of the acceleration jump allowed at an event, as a multiple of
    ``excursion / duration²`` of the angle (wide: about 10× a typical peak).
    ``jerk_kick_time`` (s): for ``model="cj"`` the jerk kick sd is the acceleration kick
    sd divided by this. ``min_frames``: fewest valid frames an angle's track may have.
    ``retune_after_release``: re-run the noise search near its optimum once a release
    was found (the jump inflates ``q`` otherwise). ``shot_pieces``: the process noise is
    chosen separately (:func:`~trebuchet.ingest.smoothing.noise_tuning.piecewise_noise`) on up to
    this many stretches of equal duration between trigger and release, each of at least
    ``piece_min_frames`` frames, and on the flight after release (the swing's jerk is
    far larger than the trough's: one ``q`` made the bands about 4× too wide in the
    trough and too narrow in the swing); 0 keeps one ``q`` for the whole log.
    ``release_piece_max_decades``: the stretch that ends at the release may not take a
    ``q`` more than this many decades above the single-``q`` maximum of the whole log
    (``inf``: no bound). Its own maximum is about 3× that ``q`` (the fastest third of the
    swing; so too with the true release given: it is not the release's jump, which the
    kick there takes), and the bands it gave at the peaks held the truth on more than
    99 % of the frames in 11 of 40 bench cells for |F_S|.
    Measured on ``bench/ingest_accuracy.py`` (projected form, 40 cells × 4 loads, |F_S|
    scored before the release only; inside / too narrow / too wide of 85–99 % coverage):
    one ``q`` 131 / 7 / 22, mean |F_R| RMS error 2.16 % of peak; 3 pieces without the
    bound 139 / 5 / 16, 1.86 %; 3 pieces with the bound at 0 decades (default) 140 / 13 /
    7, 1.97 % (bound 0.5 decades: 138 / 5 / 17). The bound trades too-wide cells for
    too-narrow ones at 2° noise and 120 fps. The pieces cost about 60 ms on 2 s at
    1000 fps.
    ``local_noise`` (default; ``shot_pieces`` ≥ 1 takes its place): the process noise
    varies frame by frame in proportion to the squared jerk of a first smoother at
    (the noise grid point nearest) the maximum-likelihood ``q``, averaged over a Gaussian
    window of sd ``local_window`` time constants of that smoother (``λ^(-1/2k)`` frames)
    within each angle's track, and not below ``local_floor`` times its mean
    (:func:`~trebuchet.ingest.smoothing.noise_tuning.jerk_noise_shape`); one scale per angle by
    maximum likelihood (``r`` kept) on a grid of ``±local_scale_decades``,
    ``cutoff_factor`` applied to that scale. ``local_linear``: the window's average is a
    local-linear fit, free of the one-sided window's bias at the ends of a track
    (:func:`~trebuchet.ingest.smoothing.noise_tuning.windowed_noise`). ``local_end_common``: over
    the last this many window widths of a track that ends while the others go on (the
    sling's, at the release), the shape is at least the mean shape of all angles
    (:func:`~trebuchet.ingest.smoothing.noise_tuning.track_end_common_noise`; 0: off): an angle's
    own first pass cannot show its jerk rising in the last frames of its track, the
    angles whose tracks go on do. ``bias_band``: the smoothing bias is added to the
    covariance, ``P + b bᵀ`` (mean squared error = variance + bias²), ``b`` estimated by
    running the same smoother (same gains) on its own smoothed angle: ``M x̂ − x̂`` and its
    derivatives (Tukey's twicing residual; first order in the bias), one more
    filter pass.
    Measured on ``bench/ingest_accuracy.py`` with six seeds per cell (inside / too narrow /
    too wide of 85–99 %, mean |F_R| RMS error): one ``q`` 132 / 10 / 18, 2.15 %; 3
    pieces as above 137 / 22 / 1, 1.97 %; local noise, window 4, local mean (the
    default until this note) 139 / 7 / 14, 1.83 %; window 2 149 / 6 / 5, 1.62 %; window 2
    local-linear 150 / 5 / 5, 1.62 %; and with ``local_end_common = 2`` 150 / 6 / 4,
    1.62 %; and with ``bias_band`` (the default) 151 / 1 / 8, 1.62 %. On the demo sample
    (``horsdal_240fps.csv``) the projectile's energy at the release lands 2.8 sd off
    with window 4, 3.5 sd with window 2, 3.2 sd local-linear (its fit carries the
    sling's falling jerk on to the floor at the track's end: q there ≈ 0), 2.0 sd with
    the track end's common shape and bias. Dropped: one common shape for all angles at
    every frame (window 4: 136 / 10 / 14, 1.94 %; window 2 local-linear 142 / 11 / 7,
    1.78 %); windows that stop at the event kicks (local-linear window 2: 148 / 11 / 1,
    1.61 %, with the common track end 147 / 11 / 2); the local-linear fit kept above the
    local mean 147 / 2 / 11; the bias's noise part taken off by a Monte Carlo run of the
    smoother on simulated noise 150 / 2 / 8; a noise grid of ¼ decade 146 / 4 / 10,
    1.62 %; the first pass's squared jerk less that of the same smoother run on
    simulated noise (the noise's share of it) 132 / 26 / 2, 1.58 % (its quiet stretches
    get too little ``q``; with ``cutoff_factor`` 0.9: 150 / 0 / 10, 1.54 %). Window 1.5
    (preset ``precise``) 151 / 4 / 5, 1.58 %; 1.25 150 / 5 / 5, 1.57 %; 1 150 / 7 / 3,
    1.56 %; 3 145 / 2 / 13, 1.73 %. With all this the ``cutoff_factor`` trades band
    cells for error: 0.7 126 / 33 / 1, 1.87 %; 0.8 (default) 151 / 1 / 8, 1.62 %; 0.85
    143 / 0 / 17, 1.56 %; 0.9 134 / 0 / 26, 1.53 %; 1 105 / 0 / 55, 1.54 %.
    Choosing the window per angle by the likelihood (2, 4 or 8 time constants) picked 2
    on every angle. Local noise costs about 50 ms on 2 s at 1000 fps, the bias band
    about 10 ms; a floor of 0.003–0.03 gave the same cells.
    ``bias_iterations``: terms of the bias's series ``(M − I) x = Σ_j (I − M)^j (M − I) x̂``
    (``x̂ = M x``, ``M`` the smoother): 1 is twicing's residual above, each further term
    the last one less its own smoothing (one more filter pass each). Where the smoother
    flattens a swing (gain ``g`` of ``M`` near 0) the first term gives only ``g`` of the
    bias: about half at the peak of a noise-free bump, two terms about ¾.
    ``band_variance``: ``"posterior"`` the smoother's ``P``; ``"noise"`` the error
    covariance of the measurement noise alone, ``E0``, the same gains run on a truth
    without process noise (but with the event kicks;
    :func:`~trebuchet.ingest.kalman.batch.error_covariance`; the acceleration's is about
    1/6 of ``P``, the rest is the process noise's share); ``"calibrated"`` (default)
    ``E0 + α (P − E0)`` with ``α`` (≤ 1) how much of the model's
    process noise the data show near each frame: the smoother's backward sums ``r``
    have ``E[r rᵀ] = R0 + α (N − R0)`` when the true process noise is ``α`` times the
    model's (``R0``: under noise alone), so ``α`` is the ratio of ``rᵀ λQ r − tr(λQ R0)``
    to ``tr(λQ (N − R0))`` summed over a Gaussian window of sd ``band_window`` time
    constants (the smoothing's ``noise[angle]["band_scale"]``). At the chosen ``q`` (0.8⁶ of the
    likelihood's maximum) ``α`` is 3–6 on most frames and capped at 1; it falls below 1
    where the motion is smoother than the white-jerk model (the low-noise bands that
    held the truth 1.5–2× too well). On data drawn from the model itself the cap makes
    the bands slightly narrow (``α`` scatters about 1; median 0.7–1 on 2 s at 120 fps).
    Measured on ``bench/ingest_accuracy.py`` (inside / too narrow / too wide, seeds
    0–5; seeds 6–11 in brackets; mean |F_R| RMS unchanged, 1.62 %): posterior, one term
    (the default until this note) 151 / 1 / 8 (150 / 0 / 10); posterior, two terms
    148 / 0 / 12; calibrated, one term 154 / 3 / 3 (window 1: 150 / 7 / 3, window 4:
    152 / 3 / 5); calibrated, two terms (default) 157 / 0 / 3 (158 / 0 / 2); three terms
    156 / 0 / 4; noise alone with the bias 48 / 112 / 0 (three terms 122 / 38 / 0: the
    bias estimate cannot stand in for the process noise's share). The three cells still
    too wide are |F_S| at low noise (small engine 60 fps 0.1°, 1000 fps 0.5°; paper 1000
    fps 0.3°): each angle's band holds its truth about right there (z RMS 0.5–1.2) but
    |F_S|'s error is smaller than the independent angles' errors give (z RMS 0.5–0.7):
    the parts of its error from θ and from φ correlate at −0.3 to −0.75 (the smoothing
    errors of coupled motions), which block-diagonal bands cannot show. Dropped: the
    bias as one joint shift of all angles in the loads (``(L(x̂ + b) − L(x̂))²`` in place
    of the per-angle ``b bᵀ``) 156 / 0 / 4; ``α``'s window in local time constants
    (``λ(t)^(−1/2k)`` frames) 155 / 0 / 5.
    The calibration and the second term cost about 40 ms: 2 s at 1000 fps, reconstruct()
    end to end, 0.23 s against 0.19 s.
    Dropped: ``band_cross="white"``, cross-covariances of the angles' process-noise shares
    (white jerks whose cross-covariance per frame came from the backward sums'
    cross-moment, each pair of smoothers' error cross-covariance exact): it found θ̈–φ̈
    −0.5 and ψ̈–φ̈ −0.7 on the sling, but |F_S|'s projected band is 93–97 % θ̈'s and what
    cancels in its error is θ̈'s against φ̇'s (a white cross model correlates only equal
    derivative orders): 155 / 0 / 5 (158 / 0 / 2), with the bias's cross terms 156 / 0 / 4.
    What kept three |F_S| cells wide was θ̈'s own band on the sling at low noise (mean z²
    0.3–0.5; 0.66–2.1 at 2°), where ``α`` from the sums is 2–9 before its cap at every
    noise level: the sums hold what the smoother leaves in its residual ``(I − M) z``, and a
    smooth motion inside the pass band fills them as the white jerk would.
    ``band_alpha_from``: ``"sums"`` ``α`` from the backward sums of the data as above;
    ``"shrunk"`` (default) that ``α`` (capped at 1) is the prior mean of an empirical-Bayes
    estimate (:func:`shrunk_alpha`) whose observation is the ``α`` of the residual: the
    backward sums ``ρ`` of the smoothing residual ``z − x̂`` (the same gains run on it), in
    which a smooth motion inside the pass band is filtered twice and (nearly) vanishes
    while one the smoother flattens stays; ``ρᵀλQρ``'s expectations under noise (with the
    kicks) alone and under the model's white noise alone come from ``band_draws``
    simulated runs of each (fixed seed; :func:`_residual_moments`), windowed as above.
    That ``α`` has few degrees of freedom (its sd is 1.5–3.7 on one frame's window, 50–80 %
    of the mean for a whole shot): its sampling variance ``v`` is the windowed statistic's
    variance over the draws of noise plus process noise (data with ``α = 1``, the prior's
    value on most frames; the noise-only draws understate it), and the prior's spread
    ``τ²`` is DerSimonian and Laird's moment estimate, pooled over the frames with process
    noise of all tracked angles; each frame moves ``τ² / (τ² + v)`` of the way from the
    prior to the residual's ``α``, capped at 1. Where the residual's ``α`` scatters about
    the prior by its own variance only (``τ² = 0``: the demo log ``horsdal_240fps.csv``)
    the band is the one of ``"sums"``; on the bench's logs ``τ²`` is 0.17–18 (median ``v`` 2–14)
    and the mean ``α`` of a shot falls by 0.03–0.40 (paper 1000 fps 0.3° 0.91 → 0.66,
    small 60 fps 0.1° 0.84 → 0.49, paper 60 fps 2° 0.98 → 0.71). Measured
    (ingest_accuracy, inside / narrow / wide on seeds 0–5, 6–11, 12–17, 18–23): sums
    157/0/3, 158/0/2, 160/0/0, 153/1/6; shrunk (default) 160/0/0, 160/0/0, 160/0/0,
    156/1/3 (the direct form, inside of 160: 121 → 140 on seeds 0–5, 110 → 126 on
    18–23); |F_R| RMS on the target cells unchanged (0.6 / 1.2 / 2.2 %, seeds 0–5: the
    estimates do not change); reconstruct() on 2 s at 1000 fps 0.34 s against 0.23 s
    (the draws). Single logs (sums → shrunk): the demo against its own scene 13 % of rows
    outside at most, median 4.3 % (unchanged); ``test_accuracy_at_extreme_rates[60-2.0]``
    ψ̈ 91 → 91 %, φ̈ 91 → 90 %; the 240 fps shot of ``tests/test_smooth.py`` θ̈ 97 → 92 %,
    φ̈ 99.5 → 96 %. Dropped variants (the synthetic logs of ``synthetic_shot`` leave the
    residual's ``α`` below its null there, median −0.03 to −1.3 on ψ and φ at 60 fps 2°: a
    noise estimate ``r`` that took in motion the smoother flattens, which a ``τ²`` per angle
    reads as spread): ``v`` from the noise-only draws with ``τ²`` by unweighted moments
    160/0/0 on seeds 0–5 but ψ̈ 80 %, φ̈ 71 % at 60 fps 2° and θ̈ 84.8 % at 240 fps (limit
    85 %), by DerSimonian–Laird θ̈ 84.8 %; ``τ²`` per angle ψ̈ 74 % (moments) or 83 % (DL),
    by a median (robust) equation 77 %; ``v`` at ``α = 1`` with unweighted moments φ̈
    100 % at 240 fps (limit 99.8 %), 155/0/5 on seeds 18–23; the cap at ``q_ml / q``
    (no more than the likelihood's maximum) in place of 1 160, 160, 160, 153/0/7; one
    ``α`` for all angles from the residual's moments summed over them 155/0/5. Dropped
    before: the residual's ``α`` alone (``band_alpha_from="residual"``, cap ``q_ml / q``,
    8 draws) 160/0/0, 160/0/0, 159/0/1, 159/0/1 but the demo 6–24 % of rows outside
    (limit 15 %) and ψ̈ 71–77 % at 60 fps 2°, with one sd of its scatter added 158/0/2,
    160/0/0, 159/0/1, 156/0/4.
    """

    noise: NoiseSearch = field(default_factory=NoiseSearch)
    trigger: TriggerSearch = field(default_factory=TriggerSearch)
    release: ReleaseSearch = field(default_factory=ReleaseSearch)
    kick_scale: float = 50.0
    jerk_kick_time: float = 0.05
    min_frames: int = 10
    retune_after_release: bool = True
    shot_pieces: int = 0
    piece_min_frames: int = 20
    release_piece_max_decades: float = 0.0
    local_noise: bool = True
    local_window: float = 2.0
    local_floor: float = 0.01
    local_scale_decades: float = 1.0
    local_linear: bool = True
    local_end_common: float = 2.0
    bias_band: bool = True
    bias_iterations: int = 2
    band_variance: str = "calibrated"
    band_window: float = 2.0
    band_alpha_from: str = "shrunk"
    band_draws: int = 8

    def __post_init__(self):
        check_choice("SmoothSettings", "band_variance", self.band_variance, BAND_VARIANCES)
        check_choice("SmoothSettings", "band_alpha_from", self.band_alpha_from, BAND_ALPHA_FROM)
        if int(self.band_draws) != self.band_draws or self.band_draws < 2:
            raise TrebuchetInputError("SmoothSettings: band_draws must be an integer ≥ 2 (the "
                                      "draws' spread needs two)")
        if int(self.bias_iterations) != self.bias_iterations or self.bias_iterations < 1:
            raise TrebuchetInputError("SmoothSettings: bias_iterations must be an integer ≥ 1")
