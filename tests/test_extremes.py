"""The extremes of the parameter space: each case simulates with small energy drift or stops
with a reason the user can act on; output never holds NaN or infinity silently."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from trebuchet.core.errors import ModelValidityWarning, TrebuchetInputError
from trebuchet.model.simulate import simulate

from .test_variants import scene_with

UNDEFINED = {"phi", "phi_d", "phi_dd"}  # the sling after release: documented, phase 3 only


def assert_sound(run):
    assert run.attrs["diagnostics"]["energy_drift_rel"] < 1e-8
    numeric = run.select_dtypes("number")
    for name in numeric.columns:
        values = numeric[name].to_numpy()
        rows = run.phase.to_numpy() != 3 if name in UNDEFINED else slice(None)
        assert np.isfinite(values[rows]).all(), name


@pytest.mark.parametrize("M", [1e4, 1e6, 1e8, 1e10])
def test_heavy_counterweights_simulate(M):
    run = simulate(scene_with(engine={"M": M}, release={"time": None,
                                                      "velocity_angle_deg": 40.0}))
    assert_sound(run)
    assert run.attrs["flight"]["release_angle"] == pytest.approx(np.radians(40), abs=1e-8)


def test_heavy_counterweight_with_late_release_strikes_the_ground():
    with pytest.raises(TrebuchetInputError, match=r"\[release\] time = 0.997 s: the projectile "
                       r"strikes the ground"):
        simulate(scene_with(engine={"M": 1e8}))


@pytest.mark.parametrize("M", [1e2, 1e3])
def test_counterweight_too_light_to_lift_the_beam_is_refused(M):
    with pytest.raises(TrebuchetInputError, match=r"\[engine\] M.*cannot lift the beam"):
        scene_with(engine={"M": M})


def test_counterweight_too_light_to_lift_the_projectile_is_refused():
    with pytest.raises(TrebuchetInputError, match=r"\[engine\] M = 19100 kg: the counterweight "
                       "cannot lift the projectile"):
        simulate(scene_with(engine={"m": 5000.0}))


@pytest.mark.parametrize("m", [1e-3, 1e-1, 1e3])
def test_projectile_masses(m):
    assert_sound(simulate(scene_with(engine={"m": m})))


@pytest.mark.parametrize("L3", [1e-3, 1e-2, 1e-1])
def test_short_counterweight_arms_are_stiff_but_sound(L3):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelValidityWarning)
        run = simulate(scene_with(engine={"L3": L3}))
    assert_sound(run)
    if L3 == 1e-3:
        assert any("counterweight = \"fixed\"" in a for a in run.attrs["diagnostics"]["advice"])


def test_slack_sling_is_reported():
    with pytest.warns(ModelValidityWarning, match="slack"):
        run = simulate(scene_with(engine={"L3": 1e-3}))
    assert run.attrs["diagnostics"]["slack"]
    for a, b in run.attrs["diagnostics"]["slack"]:
        rows = run[(run.t >= a) & (run.t <= b)]
        assert (rows.sling_tension < 0).all()


@pytest.mark.parametrize("theta", [-80.0, -50.0, -30.0])
def test_start_angles(theta):
    assert_sound(simulate(scene_with(start={"theta_deg": theta})))


def test_near_vertical_beam_lifts_off_late_and_the_release_time_says_so():
    with pytest.raises(TrebuchetInputError, match=r"\[release\] time = 0.997 s comes before "
                       "lift-off"):
        simulate(scene_with(start={"theta_deg": -89.9}))
    run = simulate(scene_with(start={"theta_deg": -89.9},
                              release={"time": None, "velocity_angle_deg": 40.0}))
    assert_sound(run)


def test_start_that_buries_the_counterweight_is_refused():
    # no psi could lift the counterweight off the ground: the beam's angle (which sets the
    # pivot's height) is the key at fault, not psi (issue 17)
    with pytest.raises(TrebuchetInputError, match=r"\[start\] theta_deg: = -10° puts the "
                       r"pivot only 1.13 m above the trough.*counterweight.*above ground"):
        scene_with(start={"theta_deg": -10.0})


@pytest.mark.parametrize("L4", [8.0, 12.0, 20.0])
def test_long_slings(L4):
    assert_sound(simulate(scene_with(engine={"L4": L4})))
