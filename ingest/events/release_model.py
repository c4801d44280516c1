"""The release from the engine's equations: where the measured accelerations stop
following phase II (projectile in the sling) and start following phase III (released).

Used by :func:`~trebuchet.ingest.reconstruct.reconstruct` when the sling's track goes on
past the release (an empty sling swinging, a tracker following the stone): the
model-free jump search of :mod:`.detection` then has nothing that marks the release. Two
stages, both with the model's own accelerations
(:func:`trebuchet.model.dynamics.accelerations_phase1` / ``_phase2`` / ``_phase3``) on
the smoothed state:

1. **coarse**: the smoothed θ̈, ψ̈ against each phase's prediction, frame by frame
   (weights: the smoother's sd and a model-error floor, each frame's squared normalised
   residual capped), and the change point "I, then II, then III" of largest likelihood
   (lift-off profiled out for a trough scene), by cumulative sums;
2. **fine**: the raw θ and ψ around it against ``c0 + c1 u + b u²/2`` plus the double
   integral of the phase-II acceleration before ``t_r`` and the phase-III one after it
   (a jump in acceleration of the size the model says, at ``t_r``; ``b`` a small offset of
   the predicted acceleration with a prior); its χ² (noise sd from the smoother)
   profiled over ``t_r`` on a frame grid, then at a tenth of a frame, gives the estimate
   (the profile's mean) and its sd, the χ² per degree of freedom above 1 (model error)
   widening it.

Measured on simulated logs whose sling track goes on (``tests/test_release_model.py``
builds them; both engines, 60–1000 fps, 0.1–2° noise, two seeds, 72 logs, this module
alone): the release within 0.24 frames (median) and 1.5 frames (90 %) of the truth, 93 %
within 2 sd. A free acceleration offset (no prior) took up most of the jump's signature:
0.6 / 10 frames; none at all: 0.09 / 1.9 frames but 86 % within 2 sd. Through
``reconstruct`` (4 seeds, 60/120/240/1000 fps, 192 logs, 2 % dropped frames): release
error median 0.23, 90 % 1.6, worst 10 frames (1000 fps, 2°), 95 % within 2 sd, peak
|F_S| error median 3.5 %, 90 % 10 %; the jump search alone found no release on 110 of
them and missed by 4.5 / 22 / 93 frames on the others, |F_S| 10.5 % / 63 %.

A scene a little off (the projectile's mass, the sling's length) still fits the phases
within the coarse stage's model-error floor and may move the release by many frames
(up to 120 at 1000 fps); the fine fit's χ², improbable under the noise alone
(``ModelRelease.fit_chance``), then warns (:func:`scene_doubt`).

φ enters only before the candidate release (the empty sling's motion is not modelled).
All times in the log's own time (s); angles rad, rates rad/s, accelerations rad/s².
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.stats import chi2 as chi2_distribution

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.events.detection import refined_profile
from trebuchet.model import dynamics as dyn
from trebuchet.model.scene import Scene

__all__ = ["ReleaseFit", "ModelRelease", "phase_accelerations", "phase_change_profile",
           "release_jump_chi2", "release_from_model", "scene_doubt"]


@dataclass(frozen=True)
class ReleaseFit:
    """Settings of :func:`release_from_model`.

    ``model_error_fraction``: floor of the coarse stage's acceleration sd, a fraction of
    the RMS predicted acceleration of each angle; ``offset_fraction``: the same fraction
    for the prior sd of the fine fit's acceleration offset; ``residual_cap``: cap of a frame's
    squared normalised residual there (a frame the smoothing smeared across the release
    fits neither phase). ``min_log_ratio``: the log-likelihood a release
    must gain over none: in the coarse stage over the whole log, or else in the fine fit
    over its window (all phase II, or all phase III). ``window_fraction``: half-width of
    the fine stage's fit window, a fraction of the time from the trigger (or the first
    frame) to the coarse release, at least ``min_window_frames`` frames; candidates keep
    ``edge_frames`` frames from its ends, about ``coarse_candidates`` of them on the
    first pass (every frame's midpoint or a stride of frames). ``subframe_steps``:
    positions per frame on the second pass, over every candidate within
    ``profile_drop`` log-likelihood units of the best (coarser if that takes more than
    ``max_fine_candidates``).
    ``sling_frame_penalty``: log-likelihood each frame pays for phase II in the coarse
    stage: after the release a sling angle that follows the stone (or a slack sling) makes
    phase II's prediction close to phase III's, and the release is the first frame from
    which phase III fits, not the last at which phase II still does.
    ``agreement_sd``: the model's release replaces the model-free one when they differ by
    more than this many of its sd; ``max_misfit``: above this
    :attr:`ModelRelease.misfit` neither phase fits (a wrong scene?) and the model's release
    is not used. ``min_fit_chance``: below this chance of the fine fit's χ² under the
    noise alone (:attr:`ModelRelease.fit_chance`) the scene's equations miss the angles
    near the release and :func:`scene_doubt` says so (the release is still used). On
    the right scene the chance is about uniform (192 simulated logs: none below 0.012), so
    1e-3 is about the rate of false alarms; it caught 37 of the 53 logs where a scene a
    little off moves the release by more than 3 sd and 2 frames (1e-4: 36).
    """

    model_error_fraction: float = 0.05
    residual_cap: float = 25.0
    min_log_ratio: float = 6.0
    window_fraction: float = 0.3
    min_window_frames: int = 10
    edge_frames: int = 3
    subframe_steps: int = 10
    profile_drop: float = 12.0
    coarse_candidates: int = 80
    max_fine_candidates: int = 160
    sling_frame_penalty: float = 0.5
    agreement_sd: float = 1.0
    offset_fraction: float = 0.02
    max_misfit: float = 3.0
    min_fit_chance: float = 1e-3

    def __post_init__(self) -> None:
        for name in ("model_error_fraction", "residual_cap", "window_fraction", "profile_drop",
                     "agreement_sd", "max_misfit", "min_fit_chance"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise TrebuchetInputError(f"ReleaseFit: {name} must be a positive number, "
                                          f"not {value!r}")
        if not (np.isfinite(self.min_log_ratio) and np.isfinite(self.sling_frame_penalty)
                and self.sling_frame_penalty >= 0 and self.offset_fraction >= 0):
            raise TrebuchetInputError("ReleaseFit: min_log_ratio must be finite and "
                                      "sling_frame_penalty and offset_fraction ≥ 0")
        if (self.min_window_frames < 2 * self.edge_frames + 2 or self.subframe_steps < 1
                or self.coarse_candidates < 2 or self.max_fine_candidates < 2):
            raise TrebuchetInputError("ReleaseFit: min_window_frames must exceed 2 edge_frames "
                                      "+ 1, subframe_steps be ≥ 1 and the candidates ≥ 2")


@dataclass(frozen=True)
class ModelRelease:
    """Result of :func:`release_from_model`.

    ``time`` (s, log time; None = no release found) and its ``sd`` (s); ``misfit``: the
    median over the shot's frames away from the release of the best-fitting phase's
    squared normalised acceleration residual per angle (about 0.1–0.7 where the scene is
    the engine filmed, 4–25 for another engine on ``bench``-like logs; NaN if not
    computed); ``chi2_dof``: the fine fit's χ² per degree of freedom (about 1);
    ``log_ratio``: the log-likelihood gain of the release over none, the larger of the
    coarse stage's (whole log) and the fine fit's (its window); ``how``: a phrase;
    ``fit_chance``: the chance of a χ² at least the fine fit's under the noise alone
    (χ² distribution of its degrees of freedom; NaN if not computed): about uniform on
    0–1 where the scene is the engine filmed (192 simulated logs: mean 0.51, smallest
    0.012), below 1e-3 on 37 of the 53 simulated logs where a scene a little off (the
    projectile's mass ×2, the sling's length ×0.8, another arm or counterweight) moves
    the release by more than 3 sd and 2 frames; a sling length ×0.8 at 240 fps, 0.5°
    (25 frames off) gives 0.003, at 2° noise 0.1–0.5: not all of them show.
    """

    time: float | None
    sd: float
    misfit: float
    chi2_dof: float
    log_ratio: float
    how: str
    fit_chance: float = float("nan")


def _none(how: str, misfit: float = float("nan"), log_ratio: float = 0.0) -> ModelRelease:
    """A :class:`ModelRelease` without a release."""
    return ModelRelease(None, float("nan"), misfit, float("nan"), log_ratio, how)


def phase_accelerations(state: Mapping[str, np.ndarray], scene: Scene
                        ) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """θ̈ and ψ̈ (rad/s²) that each phase of ``scene`` predicts on every row of ``state``
    (``theta``, ``psi``, ``phi`` rad and their rates ``_d`` rad/s): the accelerations of
    :func:`~trebuchet.model.dynamics.phase_state` (phase 1 with φ from the trough); NaN where
    a phase's formula is undefined (θ off the trough)."""
    e, g = scene.engine, scene.g
    th, ps, ph = (np.asarray(state[a], dtype=float) for a in ("theta", "psi", "phi"))
    th_d, ps_d, ph_d = (np.asarray(state[a + "_d"], dtype=float) for a in ("theta", "psi", "phi"))
    out: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    states = {1: (th, ps, th_d, ps_d), 2: (th, ps, ph, th_d, ps_d, ph_d), 3: (th, ps, th_d, ps_d)}
    with np.errstate(invalid="ignore", divide="ignore"):
        for kind, y in states.items():
            if kind in scene.phases or kind == 3:
                a, b = dyn.phase_state(kind, y, e, g, scene.start.H)[6:8]
                out[kind] = (_rows(a, th.shape), _rows(b, th.shape))
    return out


def _rows(x: np.ndarray | float, shape: tuple[int, ...]) -> np.ndarray:
    """``x`` as a float array of ``shape`` (a constant spread over the rows, read-only)."""
    x = np.asarray(x, dtype=float)
    return x if x.shape == shape else np.broadcast_to(x, shape)


def _frame_loglik(measured: tuple[np.ndarray, ...], measured_sd: tuple[np.ndarray, ...],
                  predicted: tuple[np.ndarray, ...], floor: tuple[float, ...],
                  cap: float) -> np.ndarray:
    """Per-frame log-likelihood (n,) of measured accelerations under one phase's
    prediction: ``−½ Σ_angles min(r²/(sd² + floor²), cap)``; a missing value counts as
    the cap for every phase (so it favours none)."""
    total = np.zeros(measured[0].shape)
    for z, s, p, f in zip(measured, measured_sd, predicted, floor, strict=True):
        with np.errstate(invalid="ignore"):
            r2 = (z - p) ** 2 / (s**2 + f**2)
        total -= 0.5 * np.where(np.isfinite(r2), np.minimum(r2, cap), cap)
    return total


def phase_change_profile(loglik: Mapping[int, np.ndarray], start: int) -> np.ndarray:
    """Log-likelihood (m + 1,) of "phase II on rows ``start … start+j−1``, phase III from
    row ``start+j``", j = 0 … m (m rows from ``start``), from per-row log-likelihoods of
    each phase (``{2: (n,), 3: (n,)}``, and ``1`` for a trough scene: then the rows begin
    in phase I and the lift-off before the release is profiled out)."""
    c = {p: np.concatenate([[0.0], np.cumsum(v[start:])]) for p, v in loglik.items()}
    before = c[2]
    if 1 in c:
        before = c[2] + np.maximum.accumulate(c[1] - c[2])
    return before + (c[3][-1] - c[3])


def release_jump_chi2(t: np.ndarray, angles: tuple[np.ndarray, ...], noise_sd: tuple[float, ...],
                      before: tuple[np.ndarray, ...], after: tuple[np.ndarray, ...],
                      candidates: np.ndarray, offset_sd: tuple[float, ...] | None = None
                      ) -> tuple[np.ndarray, int]:
    """χ² (C,) of the raw angles (rad, NaN = missing) on the window ``t`` (s) for each
    candidate release time (s) in ``candidates`` (C,), and its degrees of freedom.

    Model of each angle: ``c0 + c1 u + b u²/2 + ∬ a``, ``u = t − t[0]``, the acceleration
    ``a`` (a cubic spline through the frames) the phase-II prediction ``before`` (rad/s²)
    up to the release and the phase-III one ``after`` from it; ``c0, c1`` fitted by least
    squares, residuals weighted by the noise sd (rad), and ``b`` an offset of the predicted
    acceleration (model error, rad/s²) with a Gaussian prior of sd ``offset_sd`` per angle
    (None or 0: no offset; inf: fitted freely, which also takes up much of the release's
    own signature). The release term, ``∫_{t_r}^{t} (t − s)(a_III − a_II)(s) ds`` for
    ``t > t_r``, is integrated exactly for the splines.
    """
    chi2 = np.zeros(candidates.size)
    dof = -1
    u = t - t[0]
    offsets = (0.0,) * len(angles) if offset_sd is None else offset_sd
    for z, sd, a2, a3, b_sd in zip(angles, noise_sd, before, after, offsets, strict=True):
        ok = np.isfinite(z)
        base = CubicSpline(t, a2).antiderivative(2)(t)
        delta = CubicSpline(t, a3 - a2)
        d1, d2 = delta.antiderivative(1), delta.antiderivative(2)
        late = t[None, :] > candidates[:, None]
        jump = np.where(late, d2(t)[None, :] - d2(candidates)[:, None]
                        - (t[None, :] - candidates[:, None]) * d1(candidates)[:, None], 0.0)
        y = ((z - base)[None, ok] - jump[:, ok]) / sd
        columns = [np.ones(ok.sum()), u[ok]]
        if b_sd > 0:
            columns.append(0.5 * u[ok] ** 2)
        basis = np.stack(columns, axis=1) / sd
        if 0 < b_sd < np.inf:  # the prior as one more observation: b = 0 ± b_sd
            prior = np.zeros((1, basis.shape[1]))
            prior[0, -1] = 1.0 / b_sd
            basis = np.vstack([basis, prior])
            y = np.hstack([y, np.zeros((y.shape[0], 1))])
        q, _ = np.linalg.qr(basis)
        resid = y - (y @ q) @ q.T
        chi2 += np.einsum("cm,cm->c", resid, resid)
        dof += int(ok.sum()) - (3 if b_sd == np.inf else 2)
    return chi2, dof


def _state(est: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``t`` (s), the angles (rad), rates (rad/s), accelerations (rad/s²) and the
    accelerations' sd of a smoother output, as float arrays."""
    cols = ["t"] + [a + s for a in ("theta", "psi", "phi") for s in ("", "_d", "_dd", "_dd_sd")]
    missing = [c for c in cols if c not in est]
    if missing:
        raise TrebuchetInputError("release_from_model: the smoothed log lacks "
                                  f"{', '.join(missing)} (pass the output of smooth)")
    return {c: np.asarray(est[c], dtype=float) for c in cols}


def release_from_model(log_angles: Mapping[str, np.ndarray], est: Mapping[str, np.ndarray],
                       scene: Scene,
                       trigger: float | None, noise_sd: Mapping[str, float],
                       settings: ReleaseFit = ReleaseFit()) -> ModelRelease:
    """Release time (s, log time) from the engine's equations; see the module doc.

    ``log_angles``: the raw ``theta``, ``psi`` (rad, NaN = missing) on the rows of ``est``,
    the output of :func:`~trebuchet.ingest.smoothing.smooth.smooth` (angles, rates, accelerations
    and their sd); ``trigger``: its time (s; None = the log starts in motion);
    ``noise_sd``: measurement-noise sd (rad) of ``theta`` and ``psi``.
    """
    s = _state(est)
    t = s["t"]
    for a in ("theta", "psi"):
        if a not in log_angles:
            raise TrebuchetInputError(f"release_from_model: no raw {a} in log_angles")
        if np.shape(log_angles[a]) != t.shape:
            raise TrebuchetInputError(f"release_from_model: {a} has {np.size(log_angles[a])} "
                                      f"values for {t.size} smoothed rows")
        if not (np.isfinite(noise_sd[a]) and noise_sd[a] > 0):
            raise TrebuchetInputError(f"release_from_model: the noise sd of {a} must be a "
                                      f"positive number of rad, not {noise_sd[a]!r}")
    if scene.projectile == "none":
        return _none("a dry fire has no release")
    start = 0 if trigger is None else int(np.searchsorted(t, trigger, side="right"))
    if t.size - start < 2 * settings.min_window_frames:
        return _none("too few frames after the trigger")
    pred = phase_accelerations(s, scene)
    measured = (s["theta_dd"], s["psi_dd"])
    measured_sd = (s["theta_dd_sd"], s["psi_dd_sd"])
    rms = []
    for k in range(2):
        both = np.concatenate([pred[2][k][start:], pred[3][k][start:]])
        both = both[np.isfinite(both)]
        if both.size == 0:
            return _none("the model's accelerations are undefined on the smoothed state")
        rms.append(float(np.sqrt(np.mean(both**2))))
    floor = tuple(settings.model_error_fraction * v for v in rms)
    ll = {p: _frame_loglik(measured, measured_sd, v, floor, settings.residual_cap)
          for p, v in pred.items()}
    # per frame, the best-fitting phase's squared normalised residual per angle
    best_fit = -np.max(np.stack([v[start:] for v in ll.values()]), axis=0)
    ll[2] = ll[2] - settings.sling_frame_penalty
    profile = phase_change_profile(ll, start)
    j = int(np.argmax(profile))
    log_ratio = float(profile[j] - profile[-1])
    if j >= profile.size - settings.min_window_frames or j == 0:
        return _none("the accelerations do not change from phase II to III",
                     float(np.median(best_fit)), log_ratio)
    i = start + j  # first row in phase III
    coarse = 0.5 * (t[i - 1] + t[i])
    dt = float(np.median(np.diff(t)))
    half = max(settings.window_fraction * (coarse - (t[0] if trigger is None else trigger)),
               settings.min_window_frames * dt)
    inside = (t >= coarse - half) & (t <= coarse + half)
    away = ~inside[start:]
    misfit = float(np.median(best_fit[away] if away.any() else best_fit))
    rows = np.flatnonzero(inside)
    if not np.isfinite(pred[2][0][rows][t[rows] < coarse]).all():
        return _none("no sling angle (phase II unknown) before the release", misfit, log_ratio)
    tw = t[rows]
    z = tuple(np.asarray(log_angles[a], dtype=float)[rows] for a in ("theta", "psi"))
    after = tuple(v[rows] for v in pred[3])
    # no sling angle (past the end of its track): no phase II to tell apart from III
    before = tuple(np.where(np.isfinite(v[rows]), v[rows], w)
                   for v, w in zip(pred[2], after, strict=True))
    if not all(np.isfinite(v).all() for v in (*before, *after)):
        return _none("the model's accelerations are undefined near the release", misfit,
                     log_ratio)
    sd = tuple(float(noise_sd[a]) for a in ("theta", "psi"))
    edge = settings.edge_frames
    offset = tuple(settings.offset_fraction * v for v in rms)
    grid = tw[edge:-edge] - 0.5 * dt
    grid = grid[::max(1, grid.size // settings.coarse_candidates)]
    chi2, dof = release_jump_chi2(tw, z, sd, before, after, grid, offset)
    best = float(np.min(chi2))
    chi2_dof = best / max(dof, 1)
    scale = max(1.0, chi2_dof)  # model error beyond the noise widens the profile

    def loglik(times: np.ndarray) -> np.ndarray:
        return -0.5 * release_jump_chi2(tw, z, sd, before, after, times, offset)[0] / scale

    when, spread, best_fine = refined_profile(loglik, grid, -0.5 * chi2 / scale, dt,
                                              settings.profile_drop, settings.subframe_steps,
                                              settings.max_fine_candidates)
    best = min(best, -2.0 * scale * best_fine)
    # against no release in the window: all phase II, or all phase III
    ends, _ = release_jump_chi2(tw, z, sd, before, after,
                                np.array([tw[-1], tw[0] - dt]), offset)
    log_ratio = max(log_ratio, float(0.5 * (np.min(ends) - best) / scale))
    if log_ratio < settings.min_log_ratio:
        return _none("the angles show no jump of the model's size in their acceleration",
                     misfit, log_ratio)
    chance = float(chi2_distribution.sf(best, max(dof, 1)))
    return ModelRelease(when, spread, misfit, chi2_dof, log_ratio,
                        "the engine's equations (phase II before, phase III after)", chance)


def scene_doubt(model: ModelRelease, settings: ReleaseFit = ReleaseFit()) -> str | None:
    """A sentence for the user where the angles near the model's release fit the scene's
    equations worse than their noise allows (:attr:`ModelRelease.fit_chance` below
    ``min_fit_chance``) though the scene passed the misfit check; None otherwise. On
    simulated logs a projectile mass ×2 or a sling length ×0.8 passes that check and
    moves the release by up to 120 frames at 1000 fps."""
    if (model.time is None or not model.misfit <= settings.max_misfit
            or not model.fit_chance < settings.min_fit_chance):
        return None
    return (f"the angles near the release at {model.time:.4f} s fit the scene's equations "
            f"worse than their noise allows (chi2 {model.chi2_dof:.2f} per degree of freedom, "
            f"chance {model.fit_chance:.0e} under the noise alone): is a parameter of the "
            "scene a little off (the projectile's mass m, the sling's length L4, the arms "
            "L1, L2, L3, the masses M, m_b)? The release from the equations may then be off "
            "by more than its sd")
