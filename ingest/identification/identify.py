"""``identify(log, scene)``: the engine of a filmed shot, by its own equations of motion.

The log's angles are fitted by the equations of the scene's engine (:mod:`.fit`), with the
freed keys (default: ``engine.M``, ``engine.I``, and the friction coefficients where the scene
gives their radii; :mod:`.parameters`) and the nuisances every fit has (trigger, start pose,
the release where the log shows it: :mod:`.shot_model`), each angle weighted by its model-free
noise (:mod:`.noise`). The result (:class:`~.result.Identification`) carries the fitted scene,
the table of fitted values with their sd (:mod:`.table`), their covariance and correlations,
the residual check (:mod:`.check`), the bearings' heat by the release where the fitted engine
has friction, and warnings where the fit cannot say what it seems to (:mod:`.diagnosis`).

Measured on the identification bench (``bench/identify_accuracy.py``; docs/benchmarks.md).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.core.errors import (
    ModelValidityWarning,
    TrebuchetInputError,
    check_choice,
    warn_at_caller,
)
from trebuchet.ingest.identification.diagnosis import (
    check_separable,
    mass_scale_warnings,
    missing_piece_warning,
)
from trebuchet.ingest.identification.fit import ShotFit, fit_shot, shot_model
from trebuchet.ingest.identification.log_angles import angle_log, release_bracket
from trebuchet.ingest.identification.parameters import FreeKey, free_keys
from trebuchet.ingest.identification.refit import extended_fit
from trebuchet.ingest.identification.result import Identification
from trebuchet.ingest.identification.shot_model import ANGLES
from trebuchet.ingest.identification.table import (
    ShotQuantities,
    fit_table,
    loss_energy,
    shot_quantities,
)
from trebuchet.ingest.logs.read_log import MIN_LIKELIHOOD
from trebuchet.ingest.settings import IMAGE_CALIBRATIONS
from trebuchet.ingest.smoothing.inputs import checked_events, validated_log
from trebuchet.model.friction import has_friction
from trebuchet.model.scene import Release, Scene, as_scene

__all__ = ["IdentifyOptions", "identify", "identify_angles", "fitted_identification",
           "MIN_FRAMES"]

#: Frames a log needs for a fit.
MIN_FRAMES = 20


@dataclass(frozen=True)
class IdentifyOptions:
    """Settings of :func:`identify`. ``image_calibration``: as ``reconstruct``'s (point logs:
    the engine calibrates the image, "engine", or the points are taken as seen, "none");
    ``diagnose``: on a failed check, fit again with the bearings' friction free to name the
    likely missing piece (:mod:`.diagnosis`; about one more fit); ``max_nfev``: most residual
    evaluations of the fit (default 60 per fitted entry)."""

    image_calibration: str = "engine"
    diagnose: bool = True
    max_nfev: int | None = None

    def __post_init__(self) -> None:
        check_choice("identify", "image_calibration", self.image_calibration,
                     IMAGE_CALIBRATIONS)


def identify(log: str | Path | pd.DataFrame, scene: Scene | str | Path,
             free: Iterable[str] | None = None, *, fps: float | None = None,
             columns: Mapping[str, str] | None = None, points: Mapping[str, str] | None = None,
             events: Mapping[str, float | None] | None = None,
             image_calibration: str | None = None, min_likelihood: float = MIN_LIKELIHOOD,
             time_unit: str | None = None, angle_unit: str | None = None,
             individual: str | None = None, calibration: str | Path | None = None,
             options: IdentifyOptions | None = None) -> Identification:
    """Identify the engine of a filmed shot (module doc).

    Parameters
    ----------
    log : a log file (any format ``read_log`` reads) or a DataFrame with ``t`` (s) and
        ``theta``, ``psi``, ``phi`` (rad).
    scene : the engine filmed, as designed (a Scene or a scene file).
    free : the scene keys to fit (``"engine.M"``, ``"friction.pivot_mu"``, ...); default
        ``engine.M``, ``engine.I`` and the friction coefficients whose radii the scene gives.
    fps, columns, points, min_likelihood, time_unit, angle_unit, individual, calibration :
        as for ``read_log`` and ``reconstruct``.
    events : ``{"trigger", "lift_off", "release"}`` in the log's time (s): a given trigger or
        release is held, not fitted (None: no such event in the log); lift-off always comes
        from the fitted engine.
    image_calibration : "engine" or "none", as for ``reconstruct`` (point logs only).
    options : :class:`IdentifyOptions`.

    Returns
    -------
    :class:`~trebuchet.ingest.identification.result.Identification`.

    Raises
    ------
    TrebuchetInputError : a bad log, scene or key; every mass freed at once; two freed keys
        the log cannot separate; a log without rest and no trigger given.

    Warns
    -----
    ModelValidityWarning : the residual check failed (with the likely missing piece), freed
        keys the log barely separates, a coefficient fitted at zero.
    """
    options = options or IdentifyOptions()
    if image_calibration is not None:
        options = replace(options, image_calibration=image_calibration)
    scene = as_scene(scene, "identify")
    keys = free_keys(scene, free)
    frame, source, _ = angle_log(
        log, scene, fps=fps, columns=columns, points=points, calibration=calibration,
        image_calibration=options.image_calibration,
        read_options={"min_likelihood": min_likelihood, "time_unit": time_unit,
                      "angle_unit": angle_unit, "individual": individual})
    t, z = validated_log(frame, MIN_FRAMES)
    given = checked_events(events, t, source) if events is not None else {}
    result = identify_angles(t, z, scene, keys, given, source=source, options=options)
    name = Path(source).name
    for text in result.warnings:
        warn_at_caller(f"{name}: {text}", ModelValidityWarning)
    return result


def identify_angles(t: np.ndarray, z: np.ndarray, scene: Scene, keys: tuple[FreeKey, ...],
                    given: Mapping[str, float | None], *, source: str = "log",
                    options: IdentifyOptions | None = None) -> Identification:
    """:func:`identify` on the log's time ``t`` (s) and angles ``z`` (3, n; rad, NaN gaps),
    the freed ``keys`` and the ``given`` events (checked); its warnings are returned, not
    warned."""
    return fitted_identification(t, z, scene, keys, given, source=source, options=options)[0]


def fitted_identification(t: np.ndarray, z: np.ndarray, scene: Scene,
                          keys: tuple[FreeKey, ...], given: Mapping[str, float | None], *,
                          source: str = "log", options: IdentifyOptions | None = None
                          ) -> tuple[Identification, ShotFit]:
    """:func:`identify_angles` and the fit itself (its vector, covariance and trajectory:
    what the loads of the fitted engine need)."""
    options = options or IdentifyOptions()
    if "trigger" in given and given["trigger"] is None:
        raise TrebuchetInputError(f"{Path(source).name}: identify: a log without a trigger "
                                  "(trigger none) has no start for the engine's equations")
    release, bounds = None, None
    if scene.projectile != "none":
        if "release" in given:
            release = given["release"]
        else:
            bounds = release_bracket(t, z)
    fit = _fit(scene, t, z, keys, given.get("trigger"), release, bounds, options.max_nfev)
    table, names, cov = fit_table(fit)
    free = tuple(k.name for k in keys)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = np.where(np.outer(sd, sd) > 0, cov / np.outer(sd, sd), 0.0)
    warnings = check_separable(names, corr, free)
    values, qcov = shot_quantities(fit)
    table = _with_release_rows(table, fit, scene, values, qcov, bounds is not None or
                               release is not None)
    if not fit.check.passed:
        refit = None if not options.diagnose else (
            lambda sc, fr: _refit(sc, fr, fit, t, z, given.get("trigger"), release, bounds))
        warnings.insert(0, missing_piece_warning(fit.check, scene, free, refit))
    warnings += _bound_warnings(table) + mass_scale_warnings(table, scene)
    q = dict(zip(ShotQuantities.NAMES, values, strict=True))
    qsd = dict(zip(ShotQuantities.NAMES, np.sqrt(np.clip(np.diag(qcov), 0, None)),
                   strict=True))
    loss = loss_energy(values, qcov) if has_friction(fit.scene.engine) else None
    residuals = pd.DataFrame({"t": t} | {a: fit.residuals[i] * fit.model.sd[i]
                                         for i, a in enumerate(ANGLES)
                                         if np.isfinite(fit.model.z[i]).any()})
    trigger_sd = float(sd[names.index("trigger")]) if "trigger" in names else 0.0
    rel = None if math.isnan(q["release"]) else float(q["release"])
    return Identification(
        scene=_fitted_scene(fit, scene, q["climb_deg"], rel is not None and (
            bounds is not None or release is not None)),
        given=scene, table=table, names=names, covariance=cov, correlations=corr,
        check=fit.check, trigger=fit.trigger, trigger_sd=trigger_sd, release=rel,
        release_sd=0.0 if release is not None else float(qsd["release"]),
        noise_sd={a: float(fit.model.sd[i]) for i, a in enumerate(ANGLES)
                  if np.isfinite(fit.model.z[i]).any()},
        loss=loss, warnings=tuple(warnings), notes=tuple(_notes(fit, given, bounds)),
        residuals=residuals, lift_off=None if math.isnan(q["lift_off"]) else q["lift_off"],
        lift_off_sd=float(qsd["lift_off"])), fit


def _fit(scene: Scene, t: np.ndarray, z: np.ndarray, keys: tuple[FreeKey, ...],
         trigger: float | None, release: float | None,
         bounds: tuple[float, float] | None, max_nfev: int | None = None) -> ShotFit:
    model, x0 = shot_model(scene, t, z, keys, trigger=trigger, release=release,
                           release_bounds=bounds)
    return fit_shot(model, x0, max_nfev)


def _refit(scene: Scene, free: tuple[str, ...], first: ShotFit, t: np.ndarray, z: np.ndarray,
           trigger: float | None, release: float | None, bounds: tuple[float, float] | None
           ) -> tuple[object, float]:
    """The check of a fit of ``scene`` with ``free`` to the log ``t``, ``z`` of ``first`` (a
    fit that failed its check) and its bearings' share of ΔU by the release (the diagnosis'
    refit): from ``first``'s solution (:func:`~.refit.extended_fit`), from the scene's own
    start where its first steps do not pass."""
    model, x0 = shot_model(scene, t, z, free_keys(scene, free), trigger=trigger,
                           release=release, release_bounds=bounds)
    fit = extended_fit(model, first) or fit_shot(model, x0)
    q = ShotQuantities(fit.trajectory, fit.trigger).values
    names = ShotQuantities.NAMES
    share = (q[names.index("loss_pivot")] + q[names.index("loss_hinge")]) / q[
        names.index("delta_U")]
    return fit.check, float(share)


def _with_release_rows(table: pd.DataFrame, fit: ShotFit, scene: Scene, values: np.ndarray,
                       qcov: np.ndarray, from_log: bool) -> pd.DataFrame:
    """The table with the release's climb angle (a derived row) where the log puts the
    release and the scene's rule is a velocity angle, or the release time where the scene's
    rule puts it (derived: it follows from the fitted engine)."""
    names = ShotQuantities.NAMES
    sd = np.sqrt(np.clip(np.diag(qcov), 0.0, None))
    rows = []
    rule = scene.release
    if from_log and rule.velocity_angle is not None and np.isfinite(values[1]):
        rows.append(("release.velocity_angle_deg", math.degrees(rule.velocity_angle),
                     values[1], sd[1], "°", "derived"))
    if not from_log and np.isfinite(values[0]):
        i = names.index("release")
        rows.append(("release.time", rule.time if rule.time is not None else math.nan,
                     values[i] - fit.trigger, sd[i], "s", "derived"))
    if not rows:
        return table
    return pd.concat([table, pd.DataFrame(rows, columns=table.columns)], ignore_index=True)


def _bound_warnings(table: pd.DataFrame) -> list[str]:
    """Coefficients fitted at zero (their bound)."""
    out = []
    for row in table.itertuples(index=False):
        if row.kind == "free" and row.parameter.endswith("_mu") and row.value <= 1e-9:
            out.append(f"{row.parameter} is fitted at 0, its bound: the log shows no friction "
                       "there; its sd does not describe a value below zero")
    return out


def _fitted_scene(fit: ShotFit, scene: Scene, climb_deg: float, from_log: bool) -> Scene:
    """The fitted scene with the given scene's kind of release rule: a velocity angle (the
    climb at the fitted release) where the scene has one and the log puts the release."""
    fitted = replace(fit.scene, source=scene.source)
    if from_log and scene.release.velocity_angle is not None and math.isfinite(climb_deg):
        fitted = replace(fitted, release=Release(velocity_angle=math.radians(climb_deg)))
    elif not from_log:
        fitted = replace(fitted, release=scene.release)
    return fitted


def _notes(fit: ShotFit, given: Mapping[str, float | None],
           bounds: tuple[float, float] | None) -> list[str]:
    model = fit.model
    frames = ", ".join(f"{a} {int(np.isfinite(model.z[i]).sum())}"
                       for i, a in enumerate(ANGLES) if np.isfinite(model.z[i]).any())
    noise = ", ".join(f"{a} {math.degrees(model.sd[i]):.3g}°"
                      for i, a in enumerate(ANGLES) if np.isfinite(model.z[i]).any())
    notes = [f"fitted {len(model.keys)} scene keys and {len(model.nuisance_names)} nuisances "
             f"({', '.join(model.nuisance_names)}) to the angles of {frames} frames in "
             f"{fit.nfev} evaluations; noise sd from the log's fourth differences: {noise}"]
    if "trigger" in given:
        notes.append(f"trigger given at {given['trigger']:.4f} s (held)")
    if given.get("release") is not None:
        notes.append(f"release given at {given['release']:.4f} s (held)")
    elif bounds is not None:
        notes.append(f"the sling's track ends between {bounds[0]:.4f} and {bounds[1]:.4f} s: "
                     "the release is fitted there")
    else:
        notes.append("the log does not show the release: the scene's rule stands")
    if "lift_off" in given:
        notes.append("lift-off comes from the fitted engine (the given time is not used)")
    return notes
