"""A filmed shot against the model: reconstructed loads beside the simulation of the same scene.

``compare(log, scene)`` = :func:`~trebuchet.ingest.reconstruct.reconstruct` (the measured
loads with their sd) + :func:`trebuchet.model.simulate.simulate` at the log's frames +
:func:`metrics`.

**Alignment.** The prediction is evaluated at the log's rows, so predicted and measured
rows share their times (``t_shot``, s after the log's detected trigger) and index. The
model's motion starts ``lag`` s after the detected trigger. ``align="trigger"``: lag = 0,
the model starts at the detected trigger. ``align="fit"`` (default): lag is fitted so that
the model's θ and ψ match the measured ones from trigger to release (:func:`fit_lag`).
Why: the trigger is found from the first frames of motion, where the angles barely move
(θ̈ ≈ 6 rad/s² moves the beam by less than the 0.3° noise for 30 ms), and on the demo
sample it lands 6.9 ms late; at ~1 MW a 7 ms shift is a 7 kJ energy difference, 60 sd of
the measured energy, and the comparison then measured the trigger detector, not the model.
The whole swing pins the start to a fraction of a frame; the fitted lag and the angles'
residual (≈ 1 sd² per row when the model fits, hundreds for a wrong engine) are reported.

**Release** (:func:`release_rule`). ``"auto"`` (default): a scene whose release rule is a
*time* (a stop-watch number: the scene does not say what makes the projectile leave) is
released when the log shows release, ``scene.with_release(time=...)``; a scene with a
*velocity angle* says otherwise (a physical rule: the model's own release is part of what
is compared) and keeps its rule, as does any scene when the log shows no release.
``"log"`` always takes the log's release, ``"scene"`` always keeps the scene's rule. The
rule used is said in ``predicted.attrs["release_rule"]``.

**Metrics** (:func:`metrics`), one row per quantity of :data:`QUANTITIES`, over the rows
where both exist: measured rows after the trigger (phase ≥ 1) with a finite value, a
finite sd and a prediction; quantities that exist only while the projectile is held (the
sling force, the projectile's power and energy) from the trigger to the log's release, the
others (beam, counterweight, bearing) on after release as far as both frames go. A peak is
the value of greatest magnitude, sign kept, on those rows (so its time is a frame time).

**Chance** (:func:`chance_levels`). Where the model is right, the prediction still leaves
the measured ±2 sd band on some rows: 4.6 % of them on average for Gaussian errors. But
neighbouring rows of a smoothed log share their errors (the smoother averages over several
frames), so the outside fraction of one shot varies far more than a binomial count over
rows would: a band of 280 rows holds only some 20 to 40 independent samples. The spread is
estimated by simulation: the model's own angles, with the log's measured noise added, are
reconstructed ``runs`` times as the log was (the same pipeline: events found, noise
searched); the normalised errors ``(reconstructed − model) / sd`` of each quantity give how
often a correct model leaves the band (counted over all runs and rows) and the errors'
autocorrelation, and 4000 Gaussian series with that correlation, scaled to leave the band
as often, give the distribution of the outside fraction (a correct model's, the
pipeline's biases included: where the band is too narrow for the error, a correct model
leaves it more often, and chance allows more).
The prediction lies *within chance* when its outside fraction is at most that
distribution's ``level`` quantile (95 %); ``effective_samples`` is the number of
independent rows that would give the same spread (p(1 − p) / variance).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.errors import TrebuchetInputError, check_choice
from trebuchet.ingest.identification.chance import fit_chance_levels
from trebuchet.ingest.reconstruction import Reconstruction, reconstruction_of
from trebuchet.ingest.settings import ALIGN_MODES, CHANCE_RUNS, RELEASE_MODES
from trebuchet.ingest.uncertainty import BAND_SD
from trebuchet.model.scene import Scene, as_scene
from trebuchet.model.simulate import Trajectory, integrate, simulate
from trebuchet.model.timeline import shot_events

__all__ = ["Quantity", "QUANTITIES", "METRIC_COLUMNS", "CONTRACT_COLUMNS", "CHANCE_COLUMNS",
           "CompareOptions", "RELEASE_MODES", "ALIGN_MODES", "release_rule", "fit_lag",
           "predict", "metrics", "metric_row", "event_table", "outside_spans", "chance_levels",
           "compare_measured", "compare"]

#: The keywords of ``read_log`` among the options a caller passes on (the log is read
#: first, then reconstructed, so that ``reconstruct`` needs none of them).
READ_LOG_KEYWORDS = ("fps", "columns", "points", "time_unit", "angle_unit", "min_likelihood",
                     "individual", "calibration")
ATTRS = ("lag", "angle_chi2", "alignment", "release_rule")


@dataclass(frozen=True)
class Quantity:
    """A compared quantity: ``column`` of both frames (its sd in ``column + "_sd"``),
    ``label`` for people, SI ``unit``; ``held`` = it exists only while the projectile is in
    the trough or sling (compared from the trigger to release)."""

    column: str
    label: str
    unit: str
    held: bool = False


QUANTITIES: tuple[Quantity, ...] = (
    Quantity("F_S_abs", "|F_S|, sling force on the projectile", "N", held=True),
    Quantity("F_H_abs", "|F_H|, hinge force on the counterweight", "N"),
    Quantity("F_R_abs", "|F_R|, bearing reaction at the pivot", "N"),
    Quantity("F_R_x", "F_R_x, horizontal component of the bearing reaction", "N"),
    Quantity("F_R_perp", "F_R⊥, bearing reaction across the beam", "N"),
    Quantity("torque", "torque on the beam about the pivot (the paper's N)", "N m"),
    Quantity("P_m", "P_m, rate of work on the projectile", "W", held=True),
    Quantity("E_m", "E_m, energy gained by the projectile", "J", held=True),
    Quantity("E_M", "E_M, energy gained by the counterweight", "J"),
    Quantity("E_beam", "E_beam, energy gained by the beam", "J"),
)

CONTRACT_COLUMNS = ["quantity", "measured_peak", "predicted_peak", "rms_difference",
                    "rms_difference_rel", "outside_band_fraction"]
METRIC_COLUMNS = CONTRACT_COLUMNS + [
    "label", "unit", "measured_peak_sd", "measured_peak_time", "predicted_peak_time",
    "peak_time_difference", "peak_difference_in_sd", "rows", "window_start", "window_end"]
"""metrics.csv: the contract's six columns, then: ``label``; ``unit`` (SI, of the peaks and
differences); ``measured_peak_sd`` (sd of the measured value at its peak row);
``measured_peak_time``, ``predicted_peak_time`` (s after the trigger);
``peak_time_difference`` (predicted − measured, s); ``peak_difference_in_sd``
((predicted − measured peak) / measured_peak_sd); ``rows`` compared and the window
``window_start``, ``window_end`` (s after the trigger); then :data:`CHANCE_COLUMNS` when
the chance levels were estimated."""

CHANCE_COLUMNS = ["chance_fraction", "chance_limit", "chance_limit_all", "effective_samples",
                  "within_chance", "verdict", "outside_start", "outside_end",
                  "outside_worst_sd"]
"""Added to metrics.csv by :func:`compare` (``CompareOptions.chance_runs`` > 0):
``chance_fraction`` (mean outside fraction where the model is right), ``chance_limit`` (its
95 % quantile), ``effective_samples`` (independent rows giving that spread),
``chance_limit_all`` (its 1 − 0.05 / 10 quantile: the limit that a correct model's ten
quantities all stay within 95 % of the time), ``within_chance`` (outside_band_fraction ≤
chance_limit), ``verdict`` ("agrees"; "borderline": above chance_limit, not above
chance_limit_all; "differs": above chance_limit_all), ``outside_start``,
``outside_end`` (s after the trigger: the longest stretch of rows outside the band) and
``outside_worst_sd`` (the largest (predicted − measured) / sd there, sign kept)."""


@dataclass(frozen=True)
class CompareOptions:
    """Settings of the comparison.

    ``release``: "auto", "log" or "scene" (module doc). ``band_sd``: half-width of the
    measured band in sd (the figures' band). ``rtol``: the simulator's tolerance or preset.
    ``chance_runs``: simulated logs for :func:`chance_levels` (0: none, no verdict);
    ``chance_level``: the quantile that bounds chance; ``seed``: of those simulations.
    """

    release: str = "auto"
    align: str = "fit"
    max_lag: float = 0.1
    band_sd: float = BAND_SD
    rtol: float | str = "default"
    chance_runs: int = CHANCE_RUNS
    chance_level: float = 0.95
    seed: int = 0

    def __post_init__(self) -> None:
        check_choice("compare", "align", self.align, ALIGN_MODES)
        if not (math.isfinite(self.max_lag) and self.max_lag > 0):
            raise TrebuchetInputError(f"compare: max_lag = {self.max_lag!r} must be > 0 s")
        check_choice("compare", "release", self.release, RELEASE_MODES)
        if not (math.isfinite(self.band_sd) and self.band_sd > 0):
            raise TrebuchetInputError(f"compare: band_sd = {self.band_sd!r} must be > 0")
        if not (isinstance(self.chance_runs, int) and 0 <= self.chance_runs <= 1000):
            raise TrebuchetInputError(f"compare: chance_runs = {self.chance_runs!r} must be a "
                                      "whole number from 0 to 1000")
        if not 0.5 < self.chance_level < 1.0:
            raise TrebuchetInputError(f"compare: chance_level = {self.chance_level!r} must lie "
                                      "between 0.5 and 1")


# ----------------------------------------------------------------------------- prediction


def _log_release_after_trigger(measured: pd.DataFrame) -> float | None:
    """The log's release in s after its trigger, or None when the log shows none."""
    events = measured.attrs.get("events") or {}
    release = events.get("release")
    if release is None or not math.isfinite(release):
        return None
    trigger = events.get("trigger")
    return float(release) - (float(trigger) if trigger is not None else
                             float(measured["t"].iloc[0]))


def release_rule(scene: Scene, log_release: float | None, mode: str = "auto", *,
                 lag: float = 0.0) -> tuple[Scene, str]:
    """The scene to simulate and a sentence saying which release rule it uses.

    ``log_release``: the log's release, s after the model's start (None: the log shows
    none); ``lag``: the model's start after the log's detected trigger (s), so that the
    sentence gives the release on both clocks.
    ``mode``: "auto" replaces a time rule by the log's release and keeps a velocity-angle
    rule; "log" always takes the log's release; "scene" keeps the scene's rule.
    """
    check_choice("compare", "release", mode, RELEASE_MODES)
    rel = scene.release
    own = ", ".join(
        ([f"time {rel.time:.4g} s"] if rel.time is not None else [])
        + ([f"velocity angle {math.degrees(rel.velocity_angle):.4g}°"]
           if rel.velocity_angle is not None else [])) or "none"
    if scene.projectile == "none":
        return scene, "no release (dry fire)"
    if log_release is not None and not log_release > 0.0:
        raise TrebuchetInputError(f"compare: the log's release ({log_release:.4g} s after "
                                  "the trigger) is not after its trigger")
    take_log = log_release is not None and (
        mode == "log" or (mode == "auto" and rel.velocity_angle is None))
    if take_log:
        clocks = (f"{1e3 * (log_release + lag):.1f} ms after the log's trigger"
                  + (f", {1e3 * log_release:.1f} ms after the model's start" if lag else ""))
        return (scene.with_release(time=log_release),
                f"released when the log shows release ({clocks}; the scene's rule, {own}, "
                "replaced)")
    why = {"scene": "kept as asked",
           "auto": ("the log shows no release" if log_release is None
                    else "a velocity-angle rule is the scene's own"),
           "log": "the log shows no release"}[mode]
    return scene, f"the scene's own rule, {own} ({why})"


def _rest_or_model(traj: Trajectory, tau: np.ndarray) -> np.ndarray:
    """θ and ψ (rad, shape (n, 2)) of the model at times ``tau`` (s of model time): the rest
    pose before its start, the trajectory within it (``tau`` beyond its end is clipped)."""
    start = traj.scene.start
    out = np.tile([start.theta, start.psi], (tau.size, 1)).astype(float)
    moving = tau > 0.0
    if moving.any():
        a = traj.angles(np.minimum(tau[moving], traj.t_end))
        out[moving, 0] = a["theta"].to_numpy()
        out[moving, 1] = a["psi"].to_numpy()
    return out


def fit_lag(traj: Trajectory, measured: pd.DataFrame, max_lag: float = 0.1, *,
            fit: bool = True) -> tuple[float, float]:
    """``(lag, chi2)``: the start of the model's motion after the log's detected trigger
    (s, within ±``max_lag``) that best matches the model's θ and ψ to the measured ones on
    the log's rows from trigger to release (least squares weighted by the angles' sd), and
    the mean squared normalised residual there (≈ 1 when the model fits within the
    measured uncertainty; NaN when no row qualifies, then ``lag`` is 0). ``fit=False``:
    ``lag`` = 0 and its residual."""
    rows = measured["phase"].isin((1, 2)).to_numpy().copy()
    z = measured[["theta", "psi"]].to_numpy(dtype=float)
    sd = measured[["theta_sd", "psi_sd"]].to_numpy(dtype=float)
    rows &= np.isfinite(z).all(axis=1) & np.isfinite(sd).all(axis=1) & (sd > 0).all(axis=1)
    if not rows.any():
        return 0.0, math.nan
    t, z, sd = measured["t_shot"].to_numpy(dtype=float)[rows], z[rows], sd[rows]

    def cost(lag: float) -> float:
        return float(np.mean(((z - _rest_or_model(traj, t - lag)) / sd) ** 2))

    if not fit:
        return 0.0, cost(0.0)

    step = 0.25 * float(np.median(np.diff(t))) if t.size > 1 else 1e-3
    grid = np.linspace(-max_lag, max_lag, max(int(2 * max_lag / step) + 1, 3))
    coarse = np.array([cost(lag) for lag in grid[::4]])
    k = 4 * int(np.argmin(coarse))
    fine = grid[max(k - 4, 0):k + 5]
    costs = np.array([cost(lag) for lag in fine])
    i = int(np.argmin(costs))
    lag = float(fine[i])
    if 0 < i < fine.size - 1:  # parabola through the best three
        c0, c1, c2 = costs[i - 1:i + 2]
        curvature = c0 - 2 * c1 + c2
        if curvature > 0:
            lag += float(0.5 * (c0 - c2) / curvature * (fine[1] - fine[0]))
    return lag, cost(lag)


def predict(scene: Scene, measured: pd.DataFrame, options: CompareOptions | None = None
            ) -> pd.DataFrame:
    """The simulation of ``scene`` at the measured rows, indexed like them.

    The model's motion starts ``lag`` s after the log's detected trigger (0 for
    ``options.align == "trigger"``, fitted by :func:`fit_lag` for ``"fit"``): a measured row
    at ``t_shot`` is predicted at model time ``t = t_shot − lag``, on the rows with ``t``
    within [0, end of the simulated shot]. The release rule follows :func:`release_rule`,
    with the log's release taken to model time.

    Columns as :func:`~trebuchet.model.simulate.simulate` (``t``: model time, s) plus
    ``t_shot`` (the measured rows' time after the trigger, s). ``attrs``: the simulation's,
    with ``events["trigger"] = −lag`` (the log's trigger in model time, so that the figures
    put both frames on one axis), ``lag`` (s), ``angle_chi2`` (of :func:`fit_lag`; computed
    for either alignment), ``release_rule`` and ``alignment`` (sentences), ``scene`` (the
    scene simulated).
    """
    options = options or CompareOptions()
    log_release = _log_release_after_trigger(measured)
    first, _ = release_rule(scene, log_release, options.release)
    traj = integrate(first, rtol=options.rtol)
    lag, chi2 = fit_lag(traj, measured, options.max_lag, fit=options.align == "fit")
    if options.align == "trigger" or not math.isfinite(chi2):
        alignment = "the model starts at the log's detected trigger"
    else:
        alignment = (f"the model starts {1e3 * lag:+.1f} ms after the log's detected trigger "
                     "(fitted to the measured θ and ψ from trigger to release)")
        if abs(lag) >= 0.999 * options.max_lag:
            alignment += f", at the limit of the search (±{1e3 * options.max_lag:g} ms)"
    alignment += f"; angle residuals {chi2:.3g} sd² per row"
    used, sentence = release_rule(scene, None if log_release is None else log_release - lag,
                                  options.release, lag=lag)
    t_end = integrate(used, rtol=options.rtol).t_end
    t_shot = measured["t_shot"].to_numpy(dtype=float)
    tau = t_shot - lag
    keep = np.isfinite(tau) & (tau >= 0.0) & (tau <= t_end)
    if not keep.any():
        raise TrebuchetInputError(f"compare: no log row lies within the simulated shot "
                                  f"(0 to {t_end:.4g} s after the model's start)")
    run = simulate(used, t_eval=tau[keep], rtol=options.rtol)
    run.index = measured.index[keep]
    run.insert(1, "t_shot", t_shot[keep])
    run.attrs["events"] = dict(run.attrs["events"]) | {"trigger": -lag}
    run.attrs.update({"lag": lag, "angle_chi2": chi2, "release_rule": sentence,
                      "alignment": alignment, "scene": used})
    return run


# ----------------------------------------------------------------------------- metrics


def _window(quantity: Quantity, measured: pd.DataFrame, predicted: pd.DataFrame
            ) -> np.ndarray:
    """Labels of the rows where both frames hold ``quantity``."""
    common = measured.index.intersection(predicted.index)
    m = measured.loc[common]
    phase = m["phase"].to_numpy()
    ok = phase >= 1
    if quantity.held:
        ok &= phase <= 2
    c = quantity.column
    for values in (m[c], m[c + "_sd"], predicted.loc[common, c]):
        ok &= np.isfinite(values.to_numpy(dtype=float))
    return common[ok]


def _peak(values: np.ndarray) -> int:
    """Row of the greatest magnitude."""
    return int(np.argmax(np.abs(values)))


def metric_row(quantity: Quantity, t: np.ndarray, measured: np.ndarray, sd: np.ndarray,
               predicted: np.ndarray, band_sd: float = BAND_SD) -> dict[str, float | str]:
    """One row of :func:`metrics` from aligned arrays: ``t`` (s after the trigger), the
    measured values, their sd and the predicted values (SI units of the quantity)."""
    row: dict[str, float | str] = {"quantity": quantity.column, "label": quantity.label,
                                   "unit": quantity.unit, "rows": int(t.size)}
    if t.size == 0:
        return row | {k: math.nan for k in METRIC_COLUMNS if k not in row}
    i, j = _peak(measured), _peak(predicted)
    diff = predicted - measured
    rms = float(np.sqrt(np.mean(diff ** 2)))
    peak = float(measured[i])
    row |= {
        "measured_peak": peak,
        "predicted_peak": float(predicted[j]),
        "rms_difference": rms,
        "rms_difference_rel": rms / abs(peak) if peak != 0.0 else math.nan,
        "outside_band_fraction": float(np.mean(np.abs(diff) > band_sd * sd)),
        "measured_peak_sd": float(sd[i]),
        "measured_peak_time": float(t[i]),
        "predicted_peak_time": float(t[j]),
        "peak_time_difference": float(t[j] - t[i]),
        "peak_difference_in_sd": (float((predicted[j] - peak) / sd[i]) if sd[i] > 0
                                  else math.nan),
        "window_start": float(t[0]),
        "window_end": float(t[-1]),
    }
    return row


def metrics(measured: pd.DataFrame, predicted: pd.DataFrame, *, band_sd: float = BAND_SD,
            quantities: Sequence[Quantity] = QUANTITIES) -> pd.DataFrame:
    """One row per quantity, columns :data:`METRIC_COLUMNS`: peaks with their times and sd,
    the RMS difference (absolute, SI, and relative to the measured peak's magnitude), the
    difference in peak timing, and the fraction of compared rows where the prediction lies
    outside the measured ±``band_sd`` sd band.

    ``measured``: a frame of :func:`~trebuchet.ingest.reconstruct.reconstruct` (``t_shot``,
    ``phase``, ``X`` and ``X_sd``); ``predicted``: rows with the same index labels (as
    :func:`predict` returns). Rows are compared where both exist (module doc).
    """
    rows = []
    for q in quantities:
        for name in (q.column, q.column + "_sd"):
            if name not in measured.columns:
                raise TrebuchetInputError(f"compare: the measured frame has no column {name!r}")
        if q.column not in predicted.columns:
            raise TrebuchetInputError(f"compare: the predicted frame has no column "
                                      f"{q.column!r}")
        labels = _window(q, measured, predicted)
        m = measured.loc[labels]
        rows.append(metric_row(q, m["t_shot"].to_numpy(dtype=float),
                               m[q.column].to_numpy(dtype=float),
                               m[q.column + "_sd"].to_numpy(dtype=float),
                               predicted.loc[labels, q.column].to_numpy(dtype=float), band_sd))
    return pd.DataFrame(rows, columns=METRIC_COLUMNS)


def event_table(measured: pd.DataFrame, predicted: pd.DataFrame) -> pd.DataFrame:
    """Start of motion, lift-off and release, s after the log's detected trigger: measured
    (with sd where known), predicted and predicted − measured."""
    done = measured.attrs.get("reconstruction")
    event_sd = done.event_sd if isinstance(done, Reconstruction) else {}
    found = shot_events(measured) | {"start": 0.0}
    pred = shot_events(predicted) | {"start": float(predicted.attrs.get("lag", 0.0))}
    rows = []
    for name in ("start", "lift_off", "release"):
        m, p = found.get(name, math.nan), pred.get(name, math.nan)
        sd = event_sd.get("trigger" if name == "start" else name)
        rows.append({"event": name, "measured": m,
                     "measured_sd": math.nan if sd is None else float(sd),
                     "predicted": p, "difference": p - m})
    return pd.DataFrame(rows, columns=["event", "measured", "measured_sd", "predicted",
                                       "difference"])


# ----------------------------------------------------------------------------- chance


def outside_spans(t: np.ndarray, measured: np.ndarray, sd: np.ndarray, predicted: np.ndarray,
                  band_sd: float = BAND_SD) -> list[tuple[float, float, float]]:
    """Stretches of rows where the prediction leaves the measured band, longest first:
    ``(start, end, worst)`` with times as ``t`` and ``worst`` the (predicted − measured) / sd
    of greatest magnitude in the stretch (sign kept). A single row inside the band does not
    split a stretch."""
    with np.errstate(all="ignore"):
        z = (predicted - measured) / sd
    out_rows = np.abs(z) > band_sd
    idx = np.flatnonzero(out_rows)
    if idx.size == 0:
        return []
    breaks = np.flatnonzero(np.diff(idx) > 2)
    starts = np.concatenate(([idx[0]], idx[breaks + 1]))
    ends = np.concatenate((idx[breaks], [idx[-1]]))
    spans = []
    for a, b in zip(starts, ends, strict=True):
        zz = z[a:b + 1]
        k = int(np.nanargmax(np.abs(zz)))
        spans.append((float(t[a]), float(t[b]), float(zz[k]), int(b - a + 1)))
    spans.sort(key=lambda sp: -sp[3])
    return [sp[:3] for sp in spans]


def _truth_log(measured: pd.DataFrame, predicted: pd.DataFrame, scene: Scene,
               log: pd.DataFrame | None = None) -> pd.DataFrame:
    """The log the model says was filmed: its θ, ψ, φ at the log's rows, the start pose before
    the model's start, the measured (smoothed) angles after its end; gaps where the log has
    none (``log``: the log as read, whose empty cells and lost tracks are copied, when its
    rows are the measured ones; else where the measured angles are NaN)."""
    log = pd.DataFrame({"t": measured["t"].to_numpy(dtype=float)}, index=measured.index)
    lag = float(predicted.attrs.get("lag", 0.0))
    before = measured["t_shot"].to_numpy(dtype=float) - lag < 0.0
    start = {"theta": scene.start.theta, "psi": scene.start.psi, "phi": scene.start.phi}
    same_rows = (log is not None and len(log) == len(measured) and "t" in log.columns
                 and np.allclose(log["t"].to_numpy(dtype=float),
                                 measured["t"].to_numpy(dtype=float), equal_nan=True))
    for a in ("theta", "psi", "phi"):
        values = measured[a].to_numpy(dtype=float).copy()
        have = np.isfinite(values)
        if same_rows and a in log.columns:
            have &= np.isfinite(log[a].to_numpy(dtype=float))
        values[~have] = math.nan
        values[before & have] = start[a]
        if a in predicted.columns:
            model = predicted[a].reindex(measured.index).to_numpy(dtype=float)
            use = np.isfinite(model) & have
            values[use] = model[use]
        log[a] = values
    return log.reset_index(drop=True)


def _autocorrelation(z: np.ndarray) -> tuple[float, np.ndarray]:
    """``(variance, rho)`` of standardised errors ``z`` (runs × rows; NaN = no value), pooled
    over runs; ``rho`` is cut to zero from its first non-positive lag on. Values beyond four
    robust sd (1.4826 × median absolute value) are clipped there first, so that a few large
    errors (next to an event) do not set the correlation of the rest."""
    ok = np.isfinite(z)
    if not ok.any():
        return math.nan, np.ones(1)
    scale = 1.4826 * float(np.median(np.abs(z[ok]))) or 1.0
    zz = np.where(ok, np.clip(z, -4 * scale, 4 * scale), 0.0)
    n = z.shape[1]
    var = float(np.sum(zz * zz) / max(ok.sum(), 1))
    rho = np.zeros(n)
    rho[0] = 1.0
    for k in range(1, n):
        both = ok[:, k:] & ok[:, :-k]
        if both.sum() < 10:
            break
        c = float(np.sum(zz[:, k:] * zz[:, :-k]) / both.sum()) / var
        if c <= 0.0:
            break
        rho[k] = c
    return var, rho


def _exceedance_scale(z: np.ndarray, band_sd: float) -> tuple[float, float]:
    """``(p, sd)``: how often the simulated errors ``z`` leave ±``band_sd`` (counted, with
    one added to either side: (k + 1) / (N + 2), never 0 or 1 from a finite sample), and the
    sd of a Gaussian error that leaves it as often."""
    from scipy.special import ndtri

    ok = np.isfinite(z)
    k, n = int(np.sum(np.abs(z[ok]) > band_sd)), int(ok.sum())
    p = (k + 1) / (n + 2)
    return p, band_sd / float(ndtri(1.0 - p / 2.0))


def _gaussian_fractions(var: float, rho: np.ndarray, band_sd: float, draws: int,
                        rng: np.random.Generator) -> np.ndarray:
    """Outside fractions of ``draws`` stationary Gaussian series (variance ``var``,
    autocorrelation ``rho``, as long as ``rho``) beyond ±``band_sd``: circulant embedding,
    negative eigenvalues clipped."""
    n = rho.size
    m = 1 << int(math.ceil(math.log2(2 * n)))
    c = np.zeros(m)
    c[:n] = rho
    c[m - n + 1:] = rho[1:][::-1]
    lam = np.clip(np.fft.fft(c).real, 0.0, None)
    fractions = []
    for start in range(0, draws, 1000):
        k = min(1000, draws - start)
        w = rng.standard_normal((k, m)) + 1j * rng.standard_normal((k, m))
        x = np.fft.fft(np.sqrt(lam / m) * w, axis=1)
        series = np.concatenate((x.real[:, :n], x.imag[:, :n])) * math.sqrt(var)
        fractions.append(np.mean(np.abs(series) > band_sd, axis=1))
    return np.concatenate(fractions)[:draws]


def chance_levels(measured: pd.DataFrame, predicted: pd.DataFrame, scene: Scene, *,
                  runs: int = 12, band_sd: float = BAND_SD, level: float = 0.95,
                  seed: int = 0, draws: int = 4000,
                  quantities: Sequence[Quantity] = QUANTITIES,
                  log: pd.DataFrame | None = None) -> pd.DataFrame:
    """How often the prediction would leave the measured band if the model were right
    (module doc, "Chance"): one row per quantity with ``quantity`` and ``chance_fraction``,
    ``chance_limit`` (the ``level`` quantile), ``chance_limit_all`` (the 1 − (1 − level) / n
    quantile for the n quantities: Bonferroni, so that a correct model's n quantities all
    stay within their limits at least ``level`` of the time), ``effective_samples`` (NaN
    where the quantity has no compared rows).

    ``measured`` must come from :func:`~trebuchet.ingest.reconstruct.reconstruct` (its
    :class:`~trebuchet.ingest.reconstruction.Reconstruction` gives the noise per angle,
    the form and the trough setting); ``log``, the log
    it was reconstructed from, gives the simulated logs its gaps (a lost sling track stays
    lost).
    """
    from trebuchet.ingest.reconstruct import reconstruct

    a = reconstruction_of(measured)
    band = getattr(a.identification, "band", None)
    if a.method == "fit" and band is not None:  # issue 23: the fitted engine's error model
        return fit_chance_levels(measured, band, {q.column: _window(q, measured, predicted)
                                                  for q in quantities},
                                 [q.column for q in quantities], band_sd=band_sd, level=level,
                                 seed=seed, draws=draws)
    noise = a.noise
    # every event is found in each simulated log as in the real one: their errors and sd
    # shape the loads and bands of the frames around them
    truth = _truth_log(measured, predicted, scene, log)
    rng = np.random.default_rng(seed)
    windows = {q.column: _window(q, measured, predicted) for q in quantities}
    errors: dict[str, list[np.ndarray]] = {q.column: [] for q in quantities}
    import warnings

    for _ in range(runs):
        log = truth.copy()
        for angle in ("theta", "psi", "phi"):
            r_sd = float((noise.get(angle) or {}).get("r_sd", math.nan))
            if math.isfinite(r_sd):
                log[angle] = log[angle] + r_sd * rng.standard_normal(len(log))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                sim = reconstruct(log, scene, form=a.form, trough=a.trough, method=a.method)
            except TrebuchetInputError:
                continue
        sim.index = measured.index
        for q in quantities:
            rows = windows[q.column]
            with np.errstate(all="ignore"):
                z = ((sim.loc[rows, q.column] - predicted.loc[rows, q.column])
                     / sim.loc[rows, q.column + "_sd"]).to_numpy(dtype=float)
            errors[q.column].append(z)
    out = []
    for q in quantities:
        row = {"quantity": q.column, "chance_fraction": math.nan, "chance_limit": math.nan,
               "chance_limit_all": math.nan, "effective_samples": math.nan}
        if errors[q.column] and windows[q.column].size >= 2:
            z = np.array(errors[q.column])
            _, rho = _autocorrelation(z)
            _, sd = _exceedance_scale(z, band_sd)
            f = _gaussian_fractions(sd * sd, rho, band_sd, draws, rng)
            p = float(np.mean(f))
            spread = float(np.var(f))
            row |= {"chance_fraction": p, "chance_limit": float(np.quantile(f, level)),
                    "chance_limit_all": float(np.quantile(
                        f, 1.0 - (1.0 - level) / len(quantities))),
                    "effective_samples": (p * (1 - p) / spread if spread > 0 else math.nan)}
        out.append(row)
    return pd.DataFrame(out)


def _with_chance(table: pd.DataFrame, chance: pd.DataFrame, measured: pd.DataFrame,
                 predicted: pd.DataFrame, band_sd: float) -> pd.DataFrame:
    """``table`` with :data:`CHANCE_COLUMNS` filled from ``chance`` and the stretches
    outside the band."""
    table = table.merge(chance, on="quantity", how="left")
    outside = table["outside_band_fraction"]
    table["within_chance"] = outside <= table["chance_limit"]
    table["verdict"] = np.where(outside <= table["chance_limit"], "agrees",
                                np.where(outside <= table["chance_limit_all"], "borderline",
                                         "differs"))
    table.loc[table["chance_limit"].isna(), "verdict"] = ""
    starts, ends, worst = [], [], []
    for q in QUANTITIES:
        rows = _window(q, measured, predicted)
        m = measured.loc[rows]
        spans = outside_spans(m["t_shot"].to_numpy(dtype=float),
                              m[q.column].to_numpy(dtype=float),
                              m[q.column + "_sd"].to_numpy(dtype=float),
                              predicted.loc[rows, q.column].to_numpy(dtype=float), band_sd)
        first = spans[0] if spans else (math.nan, math.nan, math.nan)
        starts.append(first[0])
        ends.append(first[1])
        worst.append(first[2])
    by = {q.column: i for i, q in enumerate(QUANTITIES)}
    order = [by.get(c) for c in table["quantity"]]
    for name, values in (("outside_start", starts), ("outside_end", ends),
                         ("outside_worst_sd", worst)):
        table[name] = [values[i] if i is not None else math.nan for i in order]
    return table[METRIC_COLUMNS + CHANCE_COLUMNS]


# ----------------------------------------------------------------------------- entry points


def compare_measured(measured: pd.DataFrame, scene: Scene, options: CompareOptions | None = None
                     ) -> tuple[pd.DataFrame, pd.DataFrame]:
    """``(metrics, predicted)`` for an already reconstructed ``measured`` frame."""
    options = options or CompareOptions()
    predicted = predict(scene, measured, options)
    table = metrics(measured, predicted, band_sd=options.band_sd)
    table.attrs.update({k: predicted.attrs[k] for k in ATTRS})
    return table, predicted


def compare(log_or_path: str | Path | pd.DataFrame, scene: Scene | str | Path, *,
            options: CompareOptions | None = None,
            progress: Callable[[str], None] | None = None,
            **reconstruct_options) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """Compare a filmed shot with the model of ``scene``.

    Parameters
    ----------
    log_or_path : a log file or a DataFrame of angles (as for ``reconstruct``).
    scene : the engine filmed (a Scene or a scene file).
    options : :class:`CompareOptions` (release rule, alignment, band width, tolerance,
        chance runs).
    progress : told each step before it runs (reconstructing takes seconds).
    **reconstruct_options : passed to :func:`~trebuchet.ingest.reconstruct.reconstruct`
        (``fps``, ``columns``, ``points``, ``events``, ``form``, ...).

    Returns
    -------
    ``(metrics, measured, predicted)``: the table of :func:`metrics`, with
    :data:`CHANCE_COLUMNS` when ``options.chance_runs`` > 0 (``attrs``: ``lag``,
    ``angle_chi2``, ``alignment``, ``release_rule``), the reconstructed frame (log time
    ``t``, ``t_shot``, loads and their sd) and the simulation at the measured rows (same
    index and ``t_shot``; ``t`` is model time, see :func:`predict`).
    Warnings of ``reconstruct`` and ``simulate`` pass through.
    """
    from trebuchet.ingest.reconstruct import (
        reconstruct,  # filterpy and the smoother load on first use
    )

    scene = as_scene(scene, "compare")
    say = progress or (lambda message: None)
    name = Path(str(log_or_path)).name if not isinstance(log_or_path, pd.DataFrame) else "log"
    if isinstance(log_or_path, str | Path):  # read first: a bad log is refused before progress
        from trebuchet.ingest.logs.read_log import read_log

        keys = READ_LOG_KEYWORDS
        log_or_path = read_log(log_or_path, **{k: reconstruct_options.pop(k) for k in keys
                                               if k in reconstruct_options})
    say(f"reconstructing the loads of {name}")
    measured = reconstruct(log_or_path, scene, **reconstruct_options)
    say(f"simulating {scene.source} at the log's {len(measured)} frames")
    options = options or CompareOptions()
    table, predicted = compare_measured(measured, scene, options)
    if options.chance_runs > 0:
        say(f"estimating what chance allows from {options.chance_runs} simulated logs")
        chance = chance_levels(measured, predicted, predicted.attrs["scene"],
                               runs=options.chance_runs, band_sd=options.band_sd,
                               level=options.chance_level, seed=options.seed,
                               log=log_or_path if isinstance(log_or_path, pd.DataFrame)
                               else None)
        attrs = dict(table.attrs)
        table = _with_chance(table, chance, measured, predicted, options.band_sd)
        table.attrs.update(attrs)
    return table, measured, predicted
