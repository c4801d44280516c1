"""The loads of a filmed shot from its fitted engine: ``reconstruct(..., method="fit")``.

The engine is identified from the log (:mod:`.identify`, the default free keys). Where the fit
passes its residual check, the state of every row is the fitted engine's motion plus the
smoothed residual (the log's angles minus the model's, smoothed by
:func:`~trebuchet.ingest.smoothing.smooth.smooth` with the fitted trigger and release given):
where the equations explain the angles the residual is white noise and its smoothing about
zero; where they miss a little, it carries what they miss. The loads are the force formulas on
that state (:func:`~trebuchet.ingest.state_loads.evaluate_loads`), and each one's sd is

    sd² = g C gᵀ (the fit's covariance C through the load's gradient g by the fitted vector)
        + the smoothed residual's covariance propagated as the smoother's bands are
          (:func:`~trebuchet.ingest.uncertainty.propagate`)
        + the fitted trigger's and release's sd on the frames next to them.

Where the fit fails its check, :func:`fitted_reconstruction` returns no loads and the reason,
and ``reconstruct`` keeps the smoother's (with a note and the check's warning). Why: the
smoother's bandwidth clips a short peak (the small fast engine's |F_R| peak, 23 ms wide, came
out 10–16 % low at 0.3–0.5° and 240 fps, its bands covering the peak in 5–10 % of logs); the
fitted engine follows it (``bench/identify_accuracy.py``, docs/benchmarks.md).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.core.errors import ModelValidityWarning, TrebuchetInputError, warn_at_caller
from trebuchet.ingest.advisory import ADVISED, resolution_advisories
from trebuchet.ingest.identification.fit import ShotFit
from trebuchet.ingest.identification.identify import MIN_FRAMES, fitted_identification
from trebuchet.ingest.identification.parameters import free_keys
from trebuchet.ingest.identification.result import Identification, LoadBand
from trebuchet.ingest.identification.shot_model import ANGLES, wrapped
from trebuchet.ingest.logs.result import read_log_info
from trebuchet.ingest.reconstruction import Reconstruction
from trebuchet.ingest.scene_fit import geometry_findings, warn_findings
from trebuchet.ingest.smoothing.inputs import validated_log
from trebuchet.ingest.smoothing.noise_tuning import NoiseSearch
from trebuchet.ingest.smoothing.result import smoothing_of
from trebuchet.ingest.smoothing.settings import SmoothSettings
from trebuchet.ingest.smoothing.smooth import smooth
from trebuchet.ingest.state_loads import (
    CUMULATIVE_COLUMNS,
    evaluate_load_columns,
    event_variance,
    flight_carry,
    shot_phases,
)
from trebuchet.ingest.uncertainty import Columns, Propagation, chunk_rows, propagate
from trebuchet.model.frames import frame
from trebuchet.model.loads import cumulative_energy
from trebuchet.model.scene import Scene
from trebuchet.model.simulate import Trajectory

__all__ = ["FittedLoads", "fitted_reconstruction", "model_state", "STATE_COLUMNS"]

STATE_COLUMNS = [a + s for a in ANGLES for s in ("", "_d", "_dd")]
#: The residual's smoothing: one process noise for the whole log at its maximum likelihood and
#: the posterior's band (the residual of a fit that passes its check is white noise, its
#: smoothing about zero; the default's local noise, bias term and calibrated band are made
#: for a motion, and widened the loads' bands of a right fit beyond 99 % cover).
#: The loads whose gradients the result keeps (:class:`~.result.LoadBand`): those ``compare``
#: compares and the resolution advisory's.
BAND_COLUMNS = ("F_S_abs", "F_H_abs", "F_R_abs", "F_R_x", "F_R_perp", "torque", "P_m", "E_m",
                "E_M", "E_beam", "F_CM_abs")
#: The noise search's grid is the "fast" preset's (a decade): the residual's process noise
#: sets only a small share of the bands.
RESIDUAL_SMOOTHING = SmoothSettings(local_noise=False, bias_band=False,
                                    band_variance="posterior",
                                    noise=NoiseSearch(log10_step=1.0))


@dataclass(frozen=True)
class FittedLoads:
    """What :func:`fitted_reconstruction` gives ``reconstruct``: the frame of its loads with
    their sd (None where the fit fails its check, or cannot run on this log) and the
    identification (None where it could not run), with ``note`` saying why the loads are not
    the fitted engine's and ``warning`` the check's warning to pass on."""

    result: pd.DataFrame | None
    identification: Identification | None
    note: str | None = None
    warning: str | None = None

    def explained(self, result: pd.DataFrame) -> pd.DataFrame:
        """``reconstruct``'s frame of the smoother's loads with the reason they are not the
        fitted engine's in its notes and the identification (where one ran) in its
        ``Reconstruction``."""
        done = result.attrs.get("reconstruction")
        if not isinstance(done, Reconstruction):
            return result
        notes = (*done.notes, *([self.note] if self.note else []))
        result.attrs["reconstruction"] = replace(done, notes=notes,
                                                 identification=self.identification)
        return result


def model_state(traj: Trajectory, t0: float, t: np.ndarray) -> dict[str, np.ndarray]:
    """θ, ψ, φ and their rates and accelerations (rad, rad/s, rad/s²) of ``traj`` started at
    ``t0`` (s, log time) at the log's times ``t``: the start pose at rest before, NaN past its
    end."""
    s = traj.scene.start
    n = t.size
    out = {c: np.zeros(n) for c in STATE_COLUMNS}
    out["theta"][:], out["psi"][:], out["phi"][:] = s.theta, s.psi, s.phi
    u = t - t0
    moving = u > 0.0
    inside = moving & (u <= traj.t_end)
    if inside.any():
        cols = traj.angle_columns(u[inside])
        for c in STATE_COLUMNS:
            out[c][inside] = cols[c]
    for c in STATE_COLUMNS:
        out[c][moving & ~inside] = np.nan
    return out


def _events(traj: Trajectory, t0: float) -> tuple[float | None, float | None]:
    """Lift-off and release of ``traj`` (s, log time; None where it has none)."""
    ev = traj.events
    return tuple(None if ev.get(k) is None else t0 + float(ev[k])  # type: ignore[return-value]
                 for k in ("lift_off", "release"))


def _residual_smoothing(t: np.ndarray, z: np.ndarray, model: dict[str, np.ndarray],
                        trigger: float, release: float | None) -> pd.DataFrame:
    """The log's angles minus the model's (rad), smoothed with the fitted trigger and release
    given."""
    log = pd.DataFrame({"t": t})
    for i, a in enumerate(ANGLES):
        log[a] = wrapped(z[i] - model[a])
    events = {"trigger": trigger, "release": release}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the residual's smoothing speaks through the band
        return smooth(log, events=events, settings=RESIDUAL_SMOOTHING)


def _residual_propagation(state: Columns, cov: dict[str, np.ndarray], phase: np.ndarray,
                          scene: Scene, form: str, trough: str) -> Propagation:
    """The loads on ``state`` and the smoothed residual's covariance ``cov`` propagated to
    them (first order), by chunks of rows; the bearings' heat, an integral over the rows
    (:data:`~trebuchet.ingest.state_loads.CUMULATIVE_COLUMNS`), on the whole log at once."""

    def evaluate(s: Columns) -> dict[str, np.ndarray]:
        return evaluate_load_columns(s, phase[np.asarray(s.index)], scene, form, trough)

    prop = propagate(evaluate, state, cov, order=1, chunk=chunk_rows(len(state)),
                     carry=flight_carry(phase), order_names=list(ADVISED), columns=True)
    cumulative = [c for c in prop.names if c in CUMULATIVE_COLUMNS]
    if cumulative:
        whole = propagate(lambda s: {c: v for c, v in evaluate(s).items() if c in cumulative},
                          state, cov, names=cumulative, order=1, columns=True)
        for k, c in enumerate(cumulative):
            j = prop.names.index(c)
            prop.value[:, j], prop.sd[:, j] = whole.value[:, k], whole.sd[:, k]
    return prop


def _fit_variance(fit: ShotFit, phase: np.ndarray, state: Columns,
                  shift: dict[str, np.ndarray], base: np.ndarray, names: list[str],
                  form: str, trough: str, band: list[str]
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``g C gᵀ`` per row and column of the loads (n, m) and of the state (n, 9), and the
    gradients ``g`` (len(band), p, n) of the loads ``band``: the gradient by forward
    differences of the fitted vector (the loads of each step's engine on its motion), each
    row kept in its phase (a row whose phase a step moves counts no gradient: the events' sd
    covers it). By chunks of rows (the gradients of every load of a whole log would hold
    p × m numbers a row); the bearings' heat, an integral over the rows, from each step's
    power on the whole log."""
    t = state["t"]
    n, m = base.shape
    C = np.nan_to_num(fit.covariance, posinf=0.0)
    steps = [(i, h, traj, t0) for i, (h, traj, t0) in enumerate(fit.steps) if traj is not None]
    same = {i: shot_phases(t, fit.scene, t0, *_events(traj, t0)) == phase
            for i, _, traj, t0 in steps}
    heat = {names.index(e): names.index(p) for e, p in CUMULATIVE_COLUMNS.items() if e in names}
    powers = np.zeros((fit.x.size, n, len(heat)))
    var_loads, var_state = np.empty((n, m)), np.empty((n, len(STATE_COLUMNS)))
    at = [names.index(c) for c in band]
    gradients = np.empty((len(at), fit.x.size, n))
    carry, chunk = flight_carry(phase), chunk_rows(n)
    for lo in range(0, n, chunk):
        hi = min(lo + chunk, n)
        extra = np.asarray(carry(lo, hi), dtype=np.int64)
        rows, k = np.r_[extra, np.arange(lo, hi)], extra.size
        now = np.column_stack([state[c][lo:hi] for c in STATE_COLUMNS])
        G = np.zeros((fit.x.size, hi - lo, m))
        G_state = np.zeros((fit.x.size, hi - lo, len(STATE_COLUMNS)))
        for i, h, traj, t0 in steps:
            moved = model_state(traj, t0, t[rows])
            frame = Columns({"t": t[rows]} | {c: moved[c] + shift[c][rows]
                                              for c in STATE_COLUMNS}, rows)
            loads = evaluate_load_columns(frame, phase[rows], traj.scene, form, trough)
            values = np.stack([loads[c][k:] for c in names], axis=1)
            moved_state = np.column_stack([frame[c][k:] for c in STATE_COLUMNS])
            keep = same[i][lo:hi, None]
            G[i] = np.where(keep, np.nan_to_num((values - base[lo:hi]) / h), 0.0)
            G_state[i] = np.where(keep, np.nan_to_num((moved_state - now) / h), 0.0)
            powers[i, lo:hi] = values[:, list(heat.values())]
        var_loads[lo:hi] = np.einsum("irm,ij,jrm->rm", G, C, G)
        var_state[lo:hi] = np.einsum("irm,ij,jrm->rm", G_state, C, G_state)
        gradients[:, :, lo:hi] = np.moveaxis(G[:, :, at], 2, 0)
    for q, j in enumerate(heat):
        G = np.zeros((fit.x.size, n))
        for i, h, _, _ in steps:
            energy = cumulative_energy(t, powers[i, :, q])
            G[i] = np.where(same[i], np.nan_to_num((energy - base[:, j]) / h), 0.0)
        var_loads[:, j] = np.einsum("ir,ij,jr->r", G, C, G)
        if j in at:
            gradients[at.index(j)] = G
    return np.clip(var_loads, 0.0, None), np.clip(var_state, 0.0, None), gradients


def fitted_reconstruction(log: pd.DataFrame, scene: Scene, given: Mapping[str, float | None],
                          *, form: str = "projected", trough: str = "constraint",
                          resolution_fraction: float = 0.1, source: str = "log",
                          method: str | None = "fit") -> FittedLoads:
    """The loads of ``log`` (a table of ``t`` and the angles, as ``reconstruct`` prepared it)
    from the engine of ``scene`` fitted to it (module doc); ``given`` events (checked, log
    time) are held. The frame has ``reconstruct``'s columns and ``attrs``, and its warnings
    (the geometry's findings, the advisories, the identification's) are warned here, as
    ``reconstruct`` warns the smoother's; a fit that fails its check warns why and gives no
    frame. ``method``: "fit", or None (the default of ``reconstruct``: the same, but a log of
    tracked points keeps the smoother's loads, whose bands carry the camera's systematic
    errors, :mod:`~trebuchet.ingest.systematic_angles`, where the fit's bands know only the
    noise)."""
    name = Path(source).name
    info = read_log_info(log)
    if method is None and info is not None and info.points is not None:
        return FittedLoads(None, None, note="the loads are the smoother's: a log of tracked "
                           "points carries the camera's systematic errors, which the smoother's "
                           "bands hold and the fitted engine's would not (method fit fits it "
                           "anyway)")
    if "lift_off" in given:
        return FittedLoads(None, None, note="the loads are the smoother's: lift-off is given, "
                           "and the fitted engine would put it where its equations do")
    try:
        t, z = validated_log(log, MIN_FRAMES)
        ident, fit = fitted_identification(t, z, scene, free_keys(scene, None), given,
                                           source=source)
    except TrebuchetInputError as exc:
        return FittedLoads(None, None, note="the loads are the smoother's: the engine could "
                           f"not be fitted to the log ({exc})")
    if not ident.passed:
        warning = ident.warnings[0] if ident.warnings else None
        if warning:
            warn_at_caller(f"{name}: {warning}", ModelValidityWarning)
        return FittedLoads(None, ident, note="the loads are the smoother's: the fitted engine "
                           "fails its residual check (" + ident.check.describe() + ")",
                           warning=warning)
    lines = info.lines if info is not None and info.lines is not None \
        and len(info.lines) == len(log) else None
    result = _loads(log, t, z, scene, ident, fit, form, trough, resolution_fraction, lines)
    if info is not None:
        result.attrs["log"] = info
    done = result.attrs["reconstruction"]
    warn_findings(list(done.validity), name)
    for text in ident.warnings:
        warn_at_caller(f"{name}: {text}", ModelValidityWarning)
    if done.advisories:
        warn_at_caller(f"{name}: " + "; ".join(a.message for a in done.advisories),
                       ModelValidityWarning)
    return FittedLoads(result, done.identification)


def _loads(log: pd.DataFrame, t: np.ndarray, z: np.ndarray, scene: Scene,
           ident: Identification, fit: ShotFit, form: str, trough: str,
           resolution_fraction: float, lines: np.ndarray | None) -> pd.DataFrame:
    """The frame of :func:`fitted_reconstruction` for a fit that passed its check (the
    arrays of the whole log freed as soon as they are used: issue 25's 4 KiB a row)."""
    t0 = fit.trigger
    lift, release = _events(fit.trajectory, t0)
    if release is not None and release >= t[-1]:
        release = None  # the log ends before the fitted engine releases
    phase = shot_phases(t, fit.scene, t0, lift, release)
    model = model_state(fit.trajectory, t0, t)
    est = _residual_smoothing(t, z, model, t0, release)
    shift = {c: np.nan_to_num(est[c].to_numpy(dtype=float)) for c in STATE_COLUMNS}
    smoothed_sd = {c: np.nan_to_num(est[c + "_sd"].to_numpy(dtype=float))
                   for c in STATE_COLUMNS}
    cov = {a: np.nan_to_num(np.asarray(c, dtype=float)[:, :3, :3])
           for a, c in smoothing_of(est).cov.items()}
    del est
    state = Columns({"t": t} | {c: model[c] + shift[c] for c in STATE_COLUMNS},
                    np.arange(t.size))
    del model
    prop = _residual_propagation(state, cov, phase, fit.scene, form, trough)
    del cov
    band = [c for c in prop.names if c in BAND_COLUMNS]
    var_fit, var_state, G = _fit_variance(fit, phase, state, shift, prop.value, prop.names,
                                          form, trough, band)
    del shift
    ev_var = event_variance(t, t0, ident.trigger_sd, prop.value)
    event_variance(t, release, ident.release_sd, prop.value, out=ev_var)
    col = {c: j for j, c in enumerate(prop.names)}
    other = {c: np.sqrt(prop.sd[:, col[c]] ** 2 + ev_var[:, col[c]]) for c in band}
    sd = prop.sd  # √(sd² + g C gᵀ + the events' variance), in place
    np.square(sd, out=sd)
    sd += var_fit
    del var_fit
    np.sqrt(np.add(sd, ev_var, out=sd), out=sd)
    advice = _advice(ident, t, phase, prop, ev_var, resolution_fraction, lines)
    value = prop.value
    del ev_var, prop  # and the variance by order with it, before the frame's block
    out: dict[str, np.ndarray] = {"t": t, "t_shot": t - t0, "phase": phase}
    for c in STATE_COLUMNS:
        out[c] = state[c]
    for c, j in col.items():
        out[c] = value[:, j]
    for k, c in enumerate(STATE_COLUMNS):
        out[c + "_sd"] = np.sqrt(smoothed_sd[c] ** 2 + var_state[:, k])
    for c, j in col.items():
        out[c + "_sd"] = sd[:, j]
    result = frame(out, index=log.index)
    del out, state, value, sd
    ident = replace(ident, band=LoadBand(
        gradients={c: G[k] for k, c in enumerate(band)},
        covariance=np.nan_to_num(fit.covariance, posinf=0.0), other_sd=other))
    _attach(result, ident, fit, lift, release, advice, form, trough, lines, scene)
    return result


def _advice(ident: Identification, t: np.ndarray, phase: np.ndarray, prop: Propagation,
            ev_var: np.ndarray, resolution_fraction: float, lines: np.ndarray | None
            ) -> list:
    """The resolution advisories of the fitted loads (``prop.sd`` holds their whole sd)."""
    fps = 1.0 / float(np.median(np.diff(t)))
    noise_deg = math.degrees(float(np.median(list(ident.noise_sd.values()))))
    col = {c: j for j, c in enumerate(prop.names)}
    return resolution_advisories(
        t, phase > 0, {c: prop.value[:, j] for c, j in col.items()},
        {c: prop.sd[:, j] for c, j in col.items()},
        {c: prop.orders(c) for c in prop.order_names},
        {c: ev_var[:, j] for c, j in col.items()}, fps, noise_deg, resolution_fraction,
        lines=lines)


def _attach(result: pd.DataFrame, ident: Identification, fit: ShotFit, lift: float | None,
            release: float | None, advice: list, form: str, trough: str,
            lines: np.ndarray | None, scene: Scene) -> None:
    """``attrs["events"]`` and ``attrs["reconstruction"]`` of the fitted loads."""
    t = result["t"].to_numpy()
    phase = result["phase"].to_numpy()
    fps = 1.0 / float(np.median(np.diff(t)))
    noise = {a: {"r_sd": s, "source": "fourth differences of the log"}
             for a, s in ident.noise_sd.items()}
    validity = geometry_findings(t, phase, result["theta"].to_numpy(), result["psi"].to_numpy(),
                                 result["phi"].to_numpy(), scene,
                                 tension=result["sling_tension"].to_numpy(),
                                 tension_sd=result["sling_tension_sd"].to_numpy(), lines=lines)
    events = {"trigger": fit.trigger, "lift_off": lift, "release": release}
    how = "the fitted engine's equations"
    sources = {"trigger": "given" if fit.model.trigger is not None else f"fitted ({how})",
               "lift_off": f"{how} (the trough's normal force reaches zero)"
               if lift is not None else f"no trough (projectile {scene.projectile!r})",
               "release": ("given" if fit.model.release is not None else
                           f"fitted between the sling track's last frame and the next ({how})"
                           if fit.model.release_bounds is not None else
                           f"the scene's release rule on the fitted engine ({how})")}
    event_sd = {"trigger": ident.trigger_sd, "lift_off": ident.lift_off_sd,
                "release": ident.release_sd}
    notes = [f"loads from the fitted engine (method fit): {ident.sentence}",
             ident.check.describe(), *ident.notes]
    result.attrs["events"] = dict(events)
    result.attrs["reconstruction"] = Reconstruction(
        events=events, event_sd=event_sd, event_sources=sources, noise=noise, form=form,
        trough=trough, model=None, preset=None, fps=fps, advisories=advice, validity=validity,
        notes=notes, method="fit", identification=ident)
