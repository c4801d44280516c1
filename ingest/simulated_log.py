"""Video-like angle logs of a simulated shot, with the simulation as the truth.

For testing and measuring :func:`~trebuchet.ingest.reconstruct.reconstruct`: the engine
rests for ``rest`` s, is triggered, and is filmed at ``fps`` frames per second with
Gaussian angle noise; the sling's track ends at the release (the projectile is gone),
frames may be dropped at random. The truth is :func:`trebuchet.model.simulate.simulate`
at the same frame times (rest rows: the start pose, no motion, phase 0).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from trebuchet.model.forces import loads
from trebuchet.model.scene import Scene
from trebuchet.model.simulate import simulate

__all__ = ["simulated_log", "shot_truth", "SMALL_ENGINE"]

#: The small engine of the ingest bench and tests (a scene file's dict: metres, kg, degrees):
#: fast enough that 60 fps cannot follow its swing.
SMALL_ENGINE = {
    "engine": {"L1": 2.0, "L2": 0.5, "L_CM": 0.6, "L3": 0.5, "L4": 1.8, "m_b": 15.0,
               "M": 100.0, "m": 1.0},
    "start": {"theta_deg": -45.0, "psi_deg": -90.0, "phi_deg": -180.0},
    "release": {"velocity_angle_deg": 45.0},
    "environment": {"g": 9.81},
}

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
