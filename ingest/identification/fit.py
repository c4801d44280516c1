"""The fit: the engine's equations of motion to the log's angles, by ``scipy.optimize.
least_squares`` (trust-region reflective, bounds on the keys and the release).

The fit takes every frame of the log (or those up to a window's end,
:data:`FIT_AFTER_RELEASE`; the loads of the fitted engine then go on to the log's end, the
smoothed residual of :mod:`.fitted_loads` following what the equations miss there). Start
values: the scene's keys; the trigger from the model-free onset fit of
:func:`~trebuchet.ingest.events.detection.trigger_estimate`; the start angles as the median of
the frames at rest; the release midway between the frames that bound it. Each angle is weighted
by its model-free noise sd (:mod:`.noise`); an angle without enough evenly spaced frames for
that is left out of the fit. The Jacobian is taken by forward differences of relative step
``DIFF_STEP`` (the integrator's tolerance 1e-8 leaves its differences accurate to about 1e-4).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
from scipy.optimize import least_squares

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.events.detection import robust_noise_sd, trigger_estimate
from trebuchet.ingest.identification.check import ResidualCheck, covariance, residual_check
from trebuchet.ingest.identification.noise import difference_noise_sd
from trebuchet.ingest.identification.parameters import FreeKey
from trebuchet.ingest.identification.shot_model import ANGLES, ShotModel, model_angles, wrapped
from trebuchet.model.scene import Scene
from trebuchet.model.simulate import Trajectory

__all__ = ["ShotFit", "shot_model", "fit_shot", "shot_fit", "assessed", "DIFF_STEP",
           "FIT_RTOL"]

#: Relative step of the Jacobian's forward differences.
DIFF_STEP = 1e-4
#: The integrator's relative tolerance inside the fit.
FIT_RTOL = 1e-8
#: The fit's window ends this fraction of the time from the trigger to the release after the
#: release (inf: the whole log, the default). The beam's free swing after the release, its turns
#: (θ̇ = 0) above all, where the bearings' friction turns, tells the friction and the masses
#: apart; measured on the small fast engine with its friction, M 6 % heavier, 0.3° at 240 fps
#: (6 logs, 1.5 s): the window ending 0.25 of the shot after the release gave M's sd 3.2 kg,
#: I's 0.105 kg m², their correlation 0.98, in 0.11 s of CPU; 0.5: 2.2 kg; 0.75: 0.67 kg;
#: 1.0: 0.59 kg; the whole log 0.41 kg, 0.015 kg m², 0.82, in 0.24 s. The integrator follows a
#: turn in 400–700 small steps, the cost of the longer window.
FIT_AFTER_RELEASE = math.inf
#: The fit's tolerances (cost, step, gradient): at 1e-5 against scipy's 1e-8 the small fast
#: engine's fits with friction took 6–9 Jacobians instead of 8–10 and moved no key by more than
#: a hundredth of its sd (the cost by 5e-5 of its 400).
FIT_TOL = 1e-5
#: Residuals beyond which the trust region's steps are solved by LSMR.
LSMR_RESIDUALS = 1500
#: Least noise sd (rad) an angle is weighted with (a log of exact angles).
MIN_NOISE_SD = 1e-6


@dataclass(frozen=True)
class ShotFit:
    """A fitted :class:`~.shot_model.ShotModel`: the vector ``x`` (its layout:
    ``model.names``), its ``covariance`` (units of ``x``) and the Jacobian's ``condition``
    number, the residual ``check``, the normalised residuals (3, n; NaN where no frame) and
    the fitted ``trajectory`` started at ``trigger`` (s, log time); ``nfev`` evaluations;
    ``jacobian``: the weighted residuals' Jacobian at ``x`` (N, p) where the check fails
    (the diagnosis' refit starts from it, :func:`~.refit.extended_fit`), else None."""

    model: ShotModel
    x: np.ndarray
    covariance: np.ndarray
    condition: float
    check: ResidualCheck
    residuals: np.ndarray
    trajectory: Trajectory
    trigger: float
    nfev: int
    jacobian: np.ndarray | None = None

    @property
    def sd(self) -> np.ndarray:
        """sd of each entry of ``x`` (its units)."""
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))

    @property
    def correlations(self) -> np.ndarray:
        """The correlation matrix of ``x``."""
        sd = self.sd
        with np.errstate(invalid="ignore", divide="ignore"):
            c = self.covariance / np.outer(sd, sd)
        return np.where(np.isfinite(c), c, 0.0)

    @property
    def scene(self) -> Scene:
        """The fitted scene (release by time where the log puts it)."""
        return self.trajectory.scene

    @cached_property
    def steps(self) -> tuple[tuple[float, Trajectory | None, float], ...]:
        """Per entry of ``x``, the forward step ``h`` of the gradients of what the fitted
        engine says (its units; backwards at an upper bound) and the trajectory of ``x`` with
        that entry stepped over the whole log (None where that is no engine) with its trigger
        (s, log time): integrated once, for every quantity's gradient
        (:mod:`.table`, :mod:`.fitted_loads`)."""
        _, hi = self.model.bounds(self.x)
        out = []
        for i in range(self.x.size):
            h = DIFF_STEP * max(1.0, abs(self.x[i]))
            if self.x[i] + h > hi[i]:
                h = -h
            x = self.x.copy()
            x[i] += h
            try:
                traj, t0 = self.model.trajectory(x, until=float(self.model.t[-1]))
            except TrebuchetInputError:
                traj, t0 = None, math.nan
            out.append((h, traj, t0))
        return tuple(out)


def _rest_value(t: np.ndarray, z: np.ndarray, t0: float | None, fallback: float) -> float:
    """Median of the angle's frames before ``t0`` (at least three), else ``fallback``."""
    if t0 is None:
        return fallback
    rest = z[(t < t0) & np.isfinite(z)]
    if rest.size < 3:
        return fallback
    return float(fallback + wrapped(np.array([np.median(rest) - fallback]))[0])


def shot_model(scene: Scene, t: np.ndarray, z: np.ndarray, keys: tuple[FreeKey, ...], *,
               trigger: float | None = None, release: float | None = None,
               release_bounds: tuple[float, float] | None = None
               ) -> tuple[ShotModel, np.ndarray]:
    """The model of the log ``t`` (s), ``z`` (3, n; rad) and its start vector (module doc).
    Raises TrebuchetInputError where no angle has enough frames to weigh, or the log shows
    no start of motion and none is given."""
    sd = np.array([difference_noise_sd(t, za) for za in z])
    z = np.array(z, dtype=float)
    if scene.projectile == "none":
        z[2] = np.nan
    z[~np.isfinite(sd)] = np.nan
    if not np.isfinite(sd[:2]).any():
        raise TrebuchetInputError("identify: neither theta nor psi has enough evenly spaced "
                                  "frames (five in a row) to weigh its noise")
    sd = np.where(np.isfinite(sd), np.maximum(sd, MIN_NOISE_SD), 1.0)
    t0 = trigger
    if t0 is None:
        rough = np.array([robust_noise_sd(t, za) for za in z])
        found = trigger_estimate(t, z, np.where(np.isfinite(rough), rough, np.nan))
        if found is None:
            raise TrebuchetInputError(
                "identify: the log shows no rest before the shot (or no motion), so the fit "
                "has no start; give the trigger time (--trigger)")
        t0 = found[0]
    s = scene.start
    start = [_rest_value(t, z[0], t0, s.theta)]
    if not scene.engine.fixed_counterweight:
        start.append(_rest_value(t, z[1], t0, s.psi))
    if scene.projectile == "sling":
        start.append(_rest_value(t, z[2], t0, s.phi))
    model = ShotModel(scene=scene, t=np.asarray(t, dtype=float), z=z, sd=sd, keys=keys,
                      trigger=trigger, release_bounds=release_bounds, release=release,
                      rtol=FIT_RTOL)
    x0 = [k.scene_value / k.scale for k in keys]
    x0 += ([] if trigger is not None else [t0]) + start
    if "release" in model.nuisance_names:
        x0.append(0.5 * (release_bounds[0] + release_bounds[1]))
    x0 = np.array(x0, dtype=float)
    if not math.isfinite(FIT_AFTER_RELEASE):
        return model, x0
    return replace(model, fit_end=_window_end(model, x0, t0)), x0


def _window_end(model: ShotModel, x0: np.ndarray, t0: float) -> float:
    """The fit's window's end (s, log time): :data:`FIT_AFTER_RELEASE` of the shot after the
    release (the log's, the given one, or the scene's from the start values); the whole log
    for a dry fire or a shot the scene does not release."""
    if model.release is not None:
        rel = model.release
    elif model.release_bounds is not None:
        rel = 0.5 * sum(model.release_bounds)
    else:
        try:
            traj, _ = model.trajectory(x0)
        except TrebuchetInputError:
            return np.inf
        if traj.events.get("release") is None:
            return np.inf
        rel = t0 + float(traj.events["release"])
    return rel + FIT_AFTER_RELEASE * max(rel - t0, 0.0)


def fit_shot(model: ShotModel, x0: np.ndarray, max_nfev: int | None = None) -> ShotFit:
    """Fit ``model`` from ``x0`` (module doc). Raises TrebuchetInputError where the start
    values are no engine the equations can integrate."""
    try:
        model.trajectory(x0)
    except TrebuchetInputError as exc:
        raise TrebuchetInputError(f"identify: the scene cannot be simulated from the log's "
                                  f"start: {exc}") from None
    lo, hi = model.bounds(x0)
    x0 = np.clip(x0, lo, hi)
    # the trust region's exact solver takes the SVD of the tall Jacobian, 7–50 ms for 5000
    # residuals here: LSMR's iterations on the long logs (the same minimum on the bench)
    solver = "lsmr" if model.residual_count > LSMR_RESIDUALS else "exact"
    res = least_squares(model.residual, x0, bounds=(lo, hi), method="trf", x_scale="jac",
                        diff_step=DIFF_STEP, max_nfev=max_nfev or 60 * x0.size,
                        tr_solver=solver, ftol=FIT_TOL, xtol=FIT_TOL, gtol=FIT_TOL)
    return shot_fit(model, res.x, res.fun, res.jac, int(res.nfev))


def assessed(model: ShotModel, x: np.ndarray, fun: np.ndarray
             ) -> tuple[Trajectory, float, np.ndarray, ResidualCheck]:
    """The trajectory of ``x`` over the whole log, its trigger (s, log time), the normalised
    residuals (3, n; NaN where no frame) and the residual check, ``fun`` being
    ``model.residual(x)``."""
    traj, t0 = model.trajectory(x, until=float(model.t[-1]))
    normalised = wrapped(model.z - model_angles(traj, t0, model.t)) / model.sd[:, None]
    window = (model.t > t0) & (model.t <= model.fit_end)
    after = {a: normalised[i, window] for i, a in enumerate(ANGLES)
             if np.isfinite(model.z[i]).any()}
    data = fun.size - (model.release_prior is not None)  # the prior's row is the last
    return traj, t0, normalised, residual_check(after, data, x.size,
                                                float(fun[:data] @ fun[:data]))


def shot_fit(model: ShotModel, x: np.ndarray, fun: np.ndarray, jac: np.ndarray, nfev: int,
             done: tuple[Trajectory, float, np.ndarray, ResidualCheck] | None = None
             ) -> ShotFit:
    """The :class:`ShotFit` of ``model`` at ``x`` whose residual vector is ``fun`` and its
    Jacobian ``jac`` (``done``: :func:`assessed` of them, where taken already): the covariance
    added, and the Jacobian kept where the check fails (the diagnosis' refit starts from it,
    :func:`~.refit.extended_fit`)."""
    traj, t0, normalised, check = done or assessed(model, x, fun)
    prior = np.full(x.size, np.inf)
    if model.release_prior is not None:
        j, _, prior[j] = model.release_prior
    data = fun.size - (model.release_prior is not None)
    cov, condition = covariance(jac[:data], check.inflation, prior)
    return ShotFit(model=model, x=x, covariance=cov, condition=condition, check=check,
                   residuals=normalised, trajectory=traj, trigger=t0, nfev=nfev,
                   jacobian=None if check.passed else jac)


def released_at(fit: ShotFit) -> float | None:
    """The fitted release (s, log time), or None where the shot is not released."""
    rel = fit.trajectory.events.get("release")
    return None if rel is None else fit.trigger + float(rel)
