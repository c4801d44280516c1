"""Video-like angle logs of a simulated shot, with the simulation as the truth.

For testing and measuring :func:`~trebuchet.ingest.reconstruct.reconstruct`: the engine
rests for ``rest`` s, is triggered, and is filmed at ``fps`` frames per second with
Gaussian angle noise; the sling's track ends at the release (the projectile is gone),
frames may be dropped at random; or, :func:`continued_sling_log`, goes on past it (an
empty sling swinging, a tracker following the stone). The truth is
:func:`trebuchet.model.simulate.simulate` at the same frame times (rest rows: the start
pose, no motion, phase 0).
"""

from __future__ import annotations

import math
import tomllib
from importlib import resources

import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp

from trebuchet.model import dynamics as dyn
from trebuchet.model.kinematics import dot, rotated_acceleration, spigot_position, unit_perp
from trebuchet.model.loads import loads
from trebuchet.model.scene import Scene
from trebuchet.model.simulate import simulate

__all__ = ["simulated_log", "shot_truth", "continued_sling_log", "empty_sling_angle",
           "SMALL_ENGINE", "BACKYARD"]

#: The backyard engine of the shipped samples (data_samples/backyard.toml, a scene file's
#: dict: metres, kg, degrees).
BACKYARD = tomllib.loads(
    (resources.files("trebuchet.data_samples") / "backyard.toml").read_text(encoding="utf-8"))

#: The small engine of the ingest bench and tests: the backyard engine with a shorter
#: counterweight arm (L3 = 0.5 m against 0.6 m), fast enough that 60 fps cannot follow its
#: swing. Both are meant: the bench's tables (docs/) were measured on this one.
SMALL_ENGINE = {**BACKYARD, "engine": {**BACKYARD["engine"], "L3": 0.5}}

ANGLES = ("theta", "psi", "phi")
DERIVATIVES = tuple(a + s for a in ANGLES for s in ("_d", "_dd"))


def shot_truth(scene: Scene, t: np.ndarray, trigger: float, after_release: float) -> pd.DataFrame:
    """The simulated shot at log times ``t`` (s) for a trigger at ``trigger`` (s, log time).

    Columns of :func:`~trebuchet.model.simulate.simulate` with ``t`` the log's time,
    ``t_shot = t − trigger`` and, before the trigger, the rest pose (rates and
    accelerations zero, phase 0, the static loads of the first phase). ``attrs["events"]``:
    trigger, lift-off (if any) and release in log time (s).
    """
    t = np.asarray(t, dtype=float)
    shot = np.clip(t - trigger, 0.0, None)
    truth = simulate(scene, t_eval=shot, after_release=after_release)
    events = dict(truth.attrs["events"])
    resting = t <= trigger
    if resting.any():
        rest = truth.loc[resting, ["t", "phase", *ANGLES, *DERIVATIVES]].copy()
        rest[list(DERIVATIVES)] = 0.0
        rest["phase"] = scene.phases[0]
        still = loads(rest, scene)
        truth.loc[resting, still.columns] = still.to_numpy()
        truth.loc[resting, "phase"] = 0
    truth.insert(0, "t_shot", t - trigger)
    truth["t"] = t
    truth.attrs["events"] = {"trigger": trigger} | {
        k: trigger + v for k, v in events.items() if k in ("lift_off", "release")}
    return truth


def simulated_log(scene: Scene, fps: float, noise_deg: float, *, rest: float = 0.3,
                  after_release: float = 0.3, drop_fraction: float = 0.0, seed: int = 0,
                  t0: float = 0.0) -> tuple[pd.DataFrame, pd.DataFrame]:
    """A noisy angle log (``t`` s, theta, psi, phi rad; NaN gaps) and its truth.

    ``fps``: frame rate (1/s); ``noise_deg``: sd of the Gaussian noise on every angle (°);
    ``rest``: s at rest before the trigger; ``after_release``: s filmed after the
    release (the sling track is empty there); ``drop_fraction``: frames dropped at random
    per angle; ``t0``: log time of the first frame (s). The truth is :func:`shot_truth`.
    """
    rng = np.random.default_rng(seed)
    probe = simulate(scene, t_eval=[0.0], after_release=after_release)
    release = probe.attrs["events"].get("release", 0.0)
    duration = rest + release + after_release
    n = int(np.floor(duration * fps + 1e-9)) + 1
    t = t0 + np.arange(n) / fps
    truth = shot_truth(scene, t, t0 + rest, after_release)
    log = pd.DataFrame({"t": t})
    for name in ANGLES:
        z = truth[name].to_numpy() + rng.normal(0.0, np.deg2rad(noise_deg), n)
        if drop_fraction:
            z[rng.random(n) < drop_fraction] = np.nan
        log[name] = z
    return log, truth


def empty_sling_angle(scene: Scene, t_shot: np.ndarray, release: float
                      ) -> tuple[np.ndarray, np.ndarray]:
    """θ and φ (rad) at ``t_shot`` (s after the trigger, after ``release``) of an engine whose
    sling, emptied at ``release``, swings on as a point pouch on a massless sling of length
    L4 hung from the spigot: beam and counterweight by phase III, the pouch by
    ``(a_spigot + L4 (φ̈ e_φ⊥ − φ̇² e_φ) − g)·e_φ⊥ = 0`` (the sling pulls along e_φ only),
    from the simulated state at the release."""
    e, g = scene.engine, scene.g
    at = simulate(scene, t_eval=[release]).iloc[0]  # the row holds the phase that ends
    y0 = [at[c] for c in ("theta", "psi", "theta_d", "psi_d", "phi", "phi_d")]
    gravity = np.array([[0.0], [-g]])

    def rates(_t, y):
        th, ps, th_d, ps_d, ph, ph_d = y
        th_dd, ps_dd = dyn.phase_motion(3, [th, ps, th_d, ps_d], e, g, 0.0, math)[6:8]
        a_spigot = e.L1 * rotated_acceleration(np.array([th]), np.array([th_d]),
                                               np.array([th_dd]))
        perp = unit_perp(np.array([ph]))
        ph_dd = (dot(gravity, perp)[0] - dot(a_spigot, perp)[0]) / e.L4
        return [th_d, ps_d, th_dd, ps_dd, ph_d, ph_dd]

    sol = solve_ivp(rates, (release, float(t_shot[-1])), y0, t_eval=t_shot, rtol=1e-10,
                    atol=1e-12, method="DOP853")
    return sol.y[0], sol.y[4]


def continued_sling_log(scene: Scene, fps: float, noise_deg: float, kind: str, seed: int = 0,
                        drop_fraction: float = 0.0, rest: float = 0.3,
                        after_release: float = 0.3) -> tuple[pd.DataFrame, pd.DataFrame]:
    """:func:`simulated_log` with the sling angle tracked past the release, with the same
    noise: ``kind="pendulum"`` the empty sling (:func:`empty_sling_angle`), ``"stone"``
    the direction from the spigot to the stone in flight (the truth's ``x_m``, ``y_m``)."""
    if kind not in ("pendulum", "stone"):
        raise ValueError(f"continued_sling_log: kind must be 'pendulum' or 'stone', not {kind!r}")
    log, truth = simulated_log(scene, fps, noise_deg, seed=seed, drop_fraction=drop_fraction,
                               rest=rest, after_release=after_release)
    trigger, release = (truth.attrs["events"][k] for k in ("trigger", "release"))
    t = log["t"].to_numpy()
    after = t > release
    if kind == "pendulum":
        theta, phi = empty_sling_angle(scene, t[after] - trigger, release - trigger)
        if np.max(np.abs(theta - truth["theta"].to_numpy()[after])) > 1e-6:
            raise RuntimeError("continued_sling_log: the empty sling's beam left the "
                               "simulated one (integration failed)")
    else:
        flight = truth.loc[after]
        spigot = spigot_position(flight["theta"].to_numpy(), scene.engine, scene.start.H)
        phi = np.arctan2(flight["y_m"].to_numpy() - spigot[1],
                         flight["x_m"].to_numpy() - spigot[0])
        last = truth["phi"].to_numpy()[~after][-1]
        phi = np.unwrap(np.concatenate([[last], phi]))[1:]
    rng = np.random.default_rng(seed + 7919)
    z = phi + rng.normal(0.0, np.deg2rad(noise_deg), phi.size)
    if drop_fraction:
        z[rng.random(phi.size) < drop_fraction] = np.nan
    log.loc[after, "phi"] = z
    return log, truth
