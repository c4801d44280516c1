"""The fit: the engine's equations of motion to the log's angles, by ``scipy.optimize.
least_squares`` (trust-region reflective, bounds on the keys and the release).

Start values: the scene's keys; the trigger from the model-free onset fit of
:func:`~trebuchet.ingest.events.detection.trigger_estimate`; the start angles as the median of
the frames at rest; the release midway between the frames that bound it. Each angle is weighted
by its model-free noise sd (:mod:`.noise`); an angle without enough evenly spaced frames for
that is left out of the fit. The Jacobian is taken by forward differences of relative step
``DIFF_STEP`` (the integrator's tolerance 1e-8 leaves its differences accurate to about 1e-4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from trebuchet.errors import TrebuchetInputError
from trebuchet.ingest.events.detection import robust_noise_sd, trigger_estimate
from trebuchet.ingest.identification.check import ResidualCheck, covariance, residual_check
from trebuchet.ingest.identification.noise import difference_noise_sd
from trebuchet.ingest.identification.parameters import FreeKey
from trebuchet.ingest.identification.shot_model import ANGLES, ShotModel, model_angles, wrapped
from trebuchet.model.scene import Scene
from trebuchet.model.simulate import Trajectory

__all__ = ["ShotFit", "shot_model", "fit_shot", "DIFF_STEP", "FIT_RTOL"]

#: Relative step of the Jacobian's forward differences.
DIFF_STEP = 1e-4
#: The integrator's relative tolerance inside the fit.
FIT_RTOL = 1e-8
#: Least noise sd (rad) an angle is weighted with (a log of exact angles).
MIN_NOISE_SD = 1e-6


@dataclass(frozen=True)
class ShotFit:
    """A fitted :class:`~.shot_model.ShotModel`: the vector ``x`` (its layout:
    ``model.names``), its ``covariance`` (units of ``x``) and the Jacobian's ``condition``
    number, the residual ``check``, the normalised residuals (3, n; NaN where no frame) and
    the fitted ``trajectory`` started at ``trigger`` (s, log time); ``nfev`` evaluations."""

    model: ShotModel
    x: np.ndarray
    covariance: np.ndarray
    condition: float
    check: ResidualCheck
    residuals: np.ndarray
    trajectory: Trajectory
    trigger: float
    nfev: int

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
    return model, np.array(x0, dtype=float)


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
    res = least_squares(model.residual, x0, bounds=(lo, hi), method="trf", x_scale="jac",
                        diff_step=DIFF_STEP, max_nfev=max_nfev or 60 * x0.size)
    traj, t0 = model.trajectory(res.x)
    normalised = wrapped(model.z - model_angles(traj, t0, model.t)) / model.sd[:, None]
    after = {a: normalised[i, model.t > t0] for i, a in enumerate(ANGLES)
             if np.isfinite(model.z[i]).any()}
    prior = np.full(res.x.size, np.inf)
    data = res.fun.size
    if model.release_prior is not None:  # the prior's row is the residual's last
        j, _, prior[j] = model.release_prior
        data -= 1
    check = residual_check(after, data, res.x.size, float(res.fun[:data] @ res.fun[:data]))
    cov, condition = covariance(res.jac[:data], check.inflation, prior)
    return ShotFit(model=model, x=res.x, covariance=cov, condition=condition, check=check,
                   residuals=normalised, trajectory=traj, trigger=t0, nfev=int(res.nfev))


def released_at(fit: ShotFit) -> float | None:
    """The fitted release (s, log time), or None where the shot is not released."""
    rel = fit.trajectory.events.get("release")
    return None if rel is None else fit.trigger + float(rel)
