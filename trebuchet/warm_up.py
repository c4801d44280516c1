"""Compile (or load from their caches) the engines and kernels a user's first call would wait for.

``make install`` runs ``python -m trebuchet.warm_up``: a shot of the paper's engine with all
its outputs in the generated C (:mod:`trebuchet.model.c_engine`: sympy and gcc, ~20 s when
fresh; without a compiler one line says so and the numba kernel simulates), the same shot with
the numba kernels (the fallback, the ones that word a refused shot, the load columns of
measured logs and the sweep's peak search: ~30 s when fresh), the smoothing of a short
synthetic log and the reconstruction of a simulated one (the Kalman filter's passes, the load
propagation's sums and the pendulums that carry a lost angle on).
"""

from __future__ import annotations

import warnings

import numpy as np

__all__ = ["warm_up_model", "warm_up_ingest", "main"]


def warm_up_model() -> None:
    """Simulate the paper's shot with every output, and evaluate each phase's dense output."""
    from trebuchet.model.paper import horsdal_scene_path
    from trebuchet.model.scene import Scene
    from trebuchet.model.shot_summary import shot_figures
    from trebuchet.model.simulate import integrate, simulate

    scene = Scene.from_toml(horsdal_scene_path())
    simulate(scene)  # builds the C engine
    simulate(scene, method="numba-DOP853")
    shot_figures(scene)  # the sweep's and the optimiser's peak search
    for p in integrate(scene, method="numba-DOP853").phases:
        p.sol(np.array([p.t0, p.t1]))


def warm_up_ingest() -> None:
    """Smooth a short synthetic log (120 fps, 0.5° noise, a few dropped frames), and
    reconstruct a simulated one of the paper's engine (the load propagation's sums and the
    sling's pendulum, compiled too)."""
    from trebuchet.ingest.reconstruct import reconstruct
    from trebuchet.ingest.smoothing.smooth import smooth
    from trebuchet.ingest.synthetic.shaped_log import synthetic_log
    from trebuchet.ingest.synthetic.simulated_log import simulated_log
    from trebuchet.model.paper import horsdal_scene_path
    from trebuchet.model.scene import Scene

    log, _ = synthetic_log(120.0, 0.5, duration=1.0, trigger=0.2, release=0.7,
                           drop_fraction=0.02)
    scene = Scene.from_toml(horsdal_scene_path())
    shot, _ = simulated_log(scene, 60.0, 0.5, drop_fraction=0.02)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        smooth(log)
        reconstruct(shot, scene)


def main() -> None:
    warm_up_model()
    warm_up_ingest()


if __name__ == "__main__":
    main()
