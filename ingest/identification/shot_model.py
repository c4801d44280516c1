"""The log as the engine's equations of motion say it should look: the model of a fit.

The engine rests at its start pose until the trigger ``t0`` (the log's time, s), then moves as
:func:`trebuchet.model.simulate.integrate` integrates it. The fitted vector ``x`` holds, in this
order:

- the freed scene keys (:mod:`.parameters`), each as ``value / scale`` (about 1);
- the nuisances every fit has: the trigger ``t0`` (s, log time), unless given; the start angles
  ``θ0`` and, for a hinged counterweight, ``ψ0`` (rad; a fixed counterweight keeps its offset
  ``ψ − θ``); for a projectile hanging in the sling, ``φ0`` (rad; in the trough φ0 follows
  from θ0 by the trough's constraint, and a dry fire has no sling);
- the release ``t_r`` (s, log time) where the log shows it: the sling's track ends between two
  frames, which bound it, and a prior of the uniform's mean and variance over them joins the
  residual (the angles alone put it about as well: alone, a release fitted to a bound dragged
  ``M`` and ``I`` 2 sd off with it on the bench's logs). Elsewhere the release is given
  (``--release``: fixed) or the scene's rule stands (velocity angle or time).

The fit takes the log's frames up to :attr:`ShotModel.fit_end` (every frame by default; the
window of :mod:`.fit`). The residual of each angle at each frame is the wrapped difference ``z
− model`` in units of that angle's noise sd (the weights). Frames where the model has no such
angle (the sling after the model's release, a log whose sling track goes on past it) count
zero, so that the residual vector keeps its length while the release moves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.identification.parameters import (
    FreeKey,
    follows_default_H,
    scene_with,
)
from trebuchet.model.kinematics import trough_sling_angle
from trebuchet.model.scene import Release, Scene, Start
from trebuchet.model.simulate import Trajectory, integrate

__all__ = ["ShotModel", "ANGLES", "wrapped"]

ANGLES = ("theta", "psi", "phi")
#: Residual (in sd) of every frame of a trial the equations cannot integrate (no engine): a
#: step there is rejected.
FAILED_RESIDUAL = 1e3


def wrapped(d: np.ndarray) -> np.ndarray:
    """Angle differences (rad) into [−π, π)."""
    return (d + math.pi) % (2.0 * math.pi) - math.pi


@dataclass(frozen=True)
class ShotModel:
    """The model of one log (module doc).

    ``t`` (n,) log time (s); ``z`` (3, n) the log's θ, ψ, φ (rad, NaN gaps); ``sd`` (3,) each
    angle's noise sd (rad); ``keys`` the freed keys; ``trigger``: a given trigger (s, log
    time) or None (fitted); ``release_bounds``: the frames (s) between which the log's sling
    track ends (the release is fitted there) or None; ``release``: a given release (s, log
    time), or None (then the scene's rule, unless bounded); ``rtol``: the integrator's."""

    scene: Scene
    t: np.ndarray
    z: np.ndarray
    sd: np.ndarray
    keys: tuple[FreeKey, ...]
    trigger: float | None = None
    release_bounds: tuple[float, float] | None = None
    release: float | None = None
    rtol: float = 1e-8
    fit_end: float = math.inf

    # ----------------------------------------------------------------- layout of x

    @property
    def nuisance_names(self) -> tuple[str, ...]:
        """Names of the nuisances in ``x`` after the freed keys: ``trigger``, ``theta0``,
        ``psi0``, ``phi0``, ``release`` as the scene and log call for them."""
        names = [] if self.trigger is not None else ["trigger"]
        names.append("theta0")
        if not self.scene.engine.fixed_counterweight:
            names.append("psi0")
        if self.scene.projectile == "sling":
            names.append("phi0")
        if self.release_bounds is not None and self.release is None:
            names.append("release")
        return tuple(names)

    @property
    def names(self) -> tuple[str, ...]:
        """Every entry of ``x``: the freed keys' names, then :attr:`nuisance_names`."""
        return tuple(k.name for k in self.keys) + self.nuisance_names

    def unpack(self, x: np.ndarray) -> tuple[dict[str, float], dict[str, float]]:
        """``({key: value in the file's units}, {nuisance: value})`` of ``x``."""
        p = len(self.keys)
        values = {k.name: float(x[i]) * k.scale for i, k in enumerate(self.keys)}
        return values, dict(zip(self.nuisance_names, (float(v) for v in x[p:]), strict=True))

    def bounds(self, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of ``x``: the keys above their least value, the release
        between its two frames, the rest free."""
        lo = np.full(x0.size, -np.inf)
        hi = np.full(x0.size, np.inf)
        for i, k in enumerate(self.keys):
            lo[i] = k.lower / k.scale
        if "release" in self.nuisance_names and self.release_bounds is not None:
            j = len(self.keys) + self.nuisance_names.index("release")
            lo[j], hi[j] = self.release_bounds
        return lo, hi

    # ----------------------------------------------------------------- the model

    def scene_at(self, x: np.ndarray) -> tuple[Scene, float]:
        """The scene of ``x`` (its start pose and release rule included; the release as a
        time after the trigger where the log puts it) and the trigger (s, log time)."""
        values, nuisance = self.unpack(x)
        scene = scene_with(self.scene, values)
        t0 = self.trigger if self.trigger is not None else nuisance["trigger"]
        scene = replace(scene, start=self._start(scene, nuisance))
        t_rel = self.release if self.release is not None else nuisance.get("release")
        if t_rel is not None:
            scene = replace(scene, release=Release(time=max(t_rel - t0, 1e-6)))
        return scene, t0

    def _start(self, scene: Scene, nuisance: dict[str, float]) -> Start:
        e, s = scene.engine, scene.start
        theta = nuisance["theta0"]
        psi = theta + e.counterweight_offset if e.fixed_counterweight else nuisance["psi0"]
        H = -e.L1 * math.sin(theta) if follows_default_H(self.scene) else s.H
        if scene.projectile == "trough":
            phi = trough_sling_angle(theta, e, H, math) if abs(
                (H + e.L1 * math.sin(theta)) / e.L4) <= 1.0 else s.phi
            phi += 2.0 * math.pi * round((s.phi - phi) / (2.0 * math.pi))
        elif scene.projectile == "sling":
            phi = nuisance["phi0"]
        else:
            phi = s.phi
        return Start(theta=theta, psi=psi, phi=phi, H=H)

    @property
    def fitted(self) -> np.ndarray:
        """(3, n) bool: the frames the fit takes (tracked, up to :attr:`fit_end`)."""
        return np.isfinite(self.z) & (self.t <= self.fit_end)[None, :]

    def trajectory(self, x: np.ndarray, until: float | None = None
                   ) -> tuple[Trajectory, float]:
        """The integrated shot of ``x`` long enough for the log's frames up to ``until`` (s,
        log time; default the fit's window, :attr:`fit_end`, or the log's last frame), and
        the trigger (s, log time). Raises TrebuchetInputError where ``x`` is no engine."""
        scene, t0 = self.scene_at(x)
        if until is None:
            until = min(self.fit_end, float(self.t[-1]))
        span = until - t0
        after = max(span, 0.0) + 0.01
        if scene.release.time is not None:
            after = max(span - scene.release.time, 0.0) + 0.01
        traj = integrate(scene, rtol=self.rtol, after_release=after)
        if traj.t_end < span:  # released earlier than guessed: integrate long enough
            traj = integrate(scene, rtol=self.rtol, after_release=span + 0.01)
        return traj, t0

    def angles(self, x: np.ndarray) -> np.ndarray:
        """The model's θ, ψ, φ (3, n; rad) at the log's frames (NaN where the model has no
        such angle: the sling after release, no sling in a dry fire)."""
        traj, t0 = self.trajectory(x)
        return model_angles(traj, t0, self.t)

    @property
    def residual_count(self) -> int:
        """Length of :meth:`residual`: the tracked frames of every angle, and the release's
        prior term where it is fitted."""
        return int(self.fitted.sum()) + (self.release_prior is not None)

    @property
    def release_prior(self) -> tuple[int, float, float] | None:
        """``(index in x, mean, sd)`` of the release's prior where it is fitted between two
        frames: a Gaussian with the mean and variance of the uniform over them (``w²/12``)."""
        if "release" not in self.nuisance_names or self.release_bounds is None:
            return None
        lo, hi = self.release_bounds
        return (len(self.keys) + self.nuisance_names.index("release"), 0.5 * (lo + hi),
                (hi - lo) / math.sqrt(12.0))

    def residual(self, x: np.ndarray) -> np.ndarray:
        """Wrapped ``(z − model) / sd`` of every tracked frame of every angle, one vector
        (zero where the model has no such angle), then the release's prior term
        ``(t_r − mean) / sd`` where it is fitted (:attr:`release_prior`);
        :data:`FAILED_RESIDUAL` everywhere where ``x`` is no engine."""
        ok = self.fitted
        prior = self.release_prior
        extra = [] if prior is None else [(x[prior[0]] - prior[1]) / prior[2]]
        try:
            model = self.angles(x)
        except TrebuchetInputError:
            return np.full(int(ok.sum()) + len(extra), FAILED_RESIDUAL)
        r = wrapped(self.z - model) / self.sd[:, None]
        return np.concatenate([np.where(np.isfinite(r), r, 0.0)[ok], extra])


def model_angles(traj: Trajectory, t0: float, t: np.ndarray) -> np.ndarray:
    """θ, ψ, φ (3, n; rad) of the trajectory ``traj`` started at ``t0`` (s, log time) at the
    log's times ``t``: the start pose before, the integrated motion after (times past its end
    are NaN)."""
    s = traj.scene.start
    out = np.empty((3, t.size))
    out[0], out[1], out[2] = s.theta, s.psi, s.phi
    if traj.scene.projectile == "none":
        out[2] = np.nan
    u = t - t0
    moving = u > 0.0
    inside = moving & (u <= traj.t_end)
    if inside.any():
        cols = traj.angle_columns(u[inside])
        for i, a in enumerate(ANGLES):
            out[i, inside] = cols[a]
    out[:, moving & ~inside] = np.nan
    return out
