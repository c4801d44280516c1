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

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.core.errors import TrebuchetInputError, check_choice
from trebuchet.ingest.compare_chance import chance_levels, with_chance
from trebuchet.ingest.compare_metrics import (
    CHANCE_COLUMNS,
    CONTRACT_COLUMNS,
    METRIC_COLUMNS,
    QUANTITIES,
    Quantity,
    event_table,
    metric_row,
    metrics,
    outside_spans,
    shown_span,
)
from trebuchet.ingest.settings import ALIGN_MODES, CHANCE_RUNS, RELEASE_MODES
from trebuchet.ingest.uncertainty import BAND_SD
from trebuchet.model.scene import Scene, as_scene
from trebuchet.model.simulate import Trajectory, integrate, simulate

__all__ = ["Quantity", "QUANTITIES", "METRIC_COLUMNS", "CONTRACT_COLUMNS", "CHANCE_COLUMNS",
           "CompareOptions", "RELEASE_MODES", "ALIGN_MODES", "release_rule", "fit_lag",
           "predict", "metrics", "metric_row", "event_table", "outside_spans", "shown_span",
           "chance_levels",
           "compare_measured", "compare"]

#: The keywords of ``read_log`` among the options a caller passes on (the log is read
#: first, then reconstructed, so that ``reconstruct`` needs none of them).
READ_LOG_KEYWORDS = ("fps", "columns", "points", "time_unit", "angle_unit", "min_likelihood",
                     "individual", "calibration")
ATTRS = ("lag", "angle_chi2", "alignment", "release_rule")


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
    from trebuchet.ingest.reconstruct import (  # filterpy and the smoother load on first use
        ReconstructOptions,
        reconstruct,
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
    # another engine's log is compared, not refused: the report shows how the model differs
    given = reconstruct_options.get("options") or ReconstructOptions()
    reconstruct_options["options"] = dataclasses.replace(given, scene_mismatch="warn")
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
        table = with_chance(table, chance, measured, predicted, options.band_sd)
        table.attrs.update(attrs)
    return table, measured, predicted
