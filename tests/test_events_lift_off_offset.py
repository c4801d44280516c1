"""Lift-off's sd holds the angles' common offset (issue 15: "no event silently wrong"): a
camera rolled by 1° adds 1° to every angle a log reads, which moves the trough normal
force's zero by frames while the smoother's sd says a fraction of one."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from trebuchet.ingest.events.lift_off import offset_widened_sd, rest_offset
from trebuchet.ingest.reconstruct import reconstruct
from trebuchet.ingest.reconstruction import reconstruction_of
from trebuchet.ingest.synthetic.simulated_log import simulated_log

FPS = 240.0


def _lift_off(log, scene):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = reconstruct(log, scene)
    return res.attrs["events"]["lift_off"], reconstruction_of(res).event_sd["lift_off"]


@pytest.fixture(scope="module")
def shot(horsdal):
    return simulated_log(horsdal, FPS, 0.05, seed=4)


def test_rest_offset_is_the_logs_beam_at_rest_against_the_scenes():
    t = np.arange(10) / 100.0
    theta = np.full(10, -0.85)
    assert rest_offset(t, theta, 0.05, -0.87) == pytest.approx(0.02)
    assert np.isnan(rest_offset(t, theta, None, -0.87))
    assert np.isnan(rest_offset(t, theta, 0.01, -0.87))  # two rest rows only


def test_offset_widened_sd():
    assert offset_widened_sd(0.001, 1.0, 1.004) == pytest.approx(np.hypot(0.001, 0.004))
    assert offset_widened_sd(0.001, 1.0, None) == 0.001


def test_a_rolled_camera_widens_the_lift_offs_sd_to_cover_its_error(horsdal, shot):
    log, truth = shot
    true = truth.attrs["events"]["lift_off"]
    level, level_sd = _lift_off(log, horsdal)
    rolled = log.copy()
    for a in ("theta", "psi", "phi"):
        rolled[a] = rolled[a] + np.deg2rad(1.0)
    when, sd = _lift_off(rolled, horsdal)
    err = when - true
    assert abs(err) * FPS > 1.0  # the roll moves lift-off (the check can fail)
    assert abs(err) <= 2.0 * sd, (err * FPS, sd * FPS)
    assert abs(level - true) <= 2.0 * level_sd
    assert sd > 2.0 * level_sd  # the level log's sd is not widened much
