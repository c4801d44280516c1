"""trigger_estimate(): rest then a monotone departure, profiled over the onset time."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from trebuchet.ingest.events.detection import robust_noise_sd, trigger_estimate
from trebuchet.ingest.logs.read_log import read_log
from trebuchet.ingest.synthetic.simulated_log import simulated_log
from trebuchet.model.scene import Scene

ROOT = Path(__file__).resolve().parents[1]
PAPER = Scene.from_toml(ROOT / "data_samples" / "horsdal_large.toml")


def _estimate(log):
    t = log["t"].to_numpy()
    Z = log[["theta", "psi", "phi"]].to_numpy().T
    sd = np.array([robust_noise_sd(t, z) for z in Z])
    return trigger_estimate(t, Z, sd)


@pytest.mark.parametrize("fps, noise", [(60, 0.3), (120, 2.0)])
def test_trigger_error_within_its_sd(fps, noise):
    """Seed 0 put the old cubic fit 10 (60 fps / 0.3°) and 31 (120 fps / 2°) frames early."""
    z = []
    for seed in range(4):
        log, truth = simulated_log(PAPER, fps, noise, seed=seed, drop_fraction=0.02)
        found, sd = _estimate(log)
        z.append((found - truth.attrs["events"]["trigger"]) / sd)
    assert np.all(np.abs(z) < 3.0), z


def test_trigger_sd_grows_with_noise():
    sds = []
    for noise in (0.1, 2.0):
        log, _ = simulated_log(PAPER, 120, noise, seed=1)
        sds.append(_estimate(log)[1] * 120)
    assert sds[0] < 1.0 < 3 * sds[0] < sds[1], sds


def test_demo_sample_trigger_and_its_sd():
    """True trigger at 1.000 s (240 fps, 0.3°); the sd is estimated, not half a frame."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        log = read_log(ROOT / "data_samples" / "horsdal_240fps.csv")
    found, sd = _estimate(log)
    assert abs(found - 1.0) < 2.0 * sd
    assert sd * 240 != pytest.approx(0.5, abs=0.05)
