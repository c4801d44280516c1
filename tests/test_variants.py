"""Scenes that model only what they need: fixed counterweight, projectile hanging in the sling,
dry fire, flight with drag. Each keeps the consistency checks of the general model and agrees
with it where the two describe the same engine."""

from __future__ import annotations

import copy
import tomllib

import numpy as np
import pytest

from trebuchet.model import kinematics as kin
from trebuchet.model.scene import Scene
from trebuchet.model.simulate import simulate

from .conftest import HORSDAL

BASE = tomllib.loads(HORSDAL.read_text())


def scene_with(**sections) -> Scene:
    data = copy.deepcopy(BASE)
    for section, keys in sections.items():
        if keys is None:
            data.pop(section, None)
            continue
        data.setdefault(section, {})
        for key, value in keys.items():
            if value is None:
                data[section].pop(key, None)
            else:
                data[section][key] = value
    return Scene.from_dict(data, source="variant")


FIXED = dict(engine={"counterweight": "fixed", "L3": 0.5}, start={"psi_deg": 130.0})
HANGING = dict(engine={"H": 12.0}, start={"projectile": "sling", "phi_deg": -90.0})
DRY = dict(engine={"m": None, "L4": None}, start={"projectile": "none", "phi_deg": None},
           release=None)
DRAG = dict(flight={"model": "drag", "diameter": 0.42})
VARIANTS = {"fixed": FIXED, "hanging": HANGING, "dry": DRY, "drag": DRAG}


@pytest.fixture(scope="module", params=sorted(VARIANTS))
def variant(request):
    scene = scene_with(**VARIANTS[request.param])
    return request.param, scene, simulate(scene, dt=1e-3)


def test_scene_decides_the_phases(variant):
    name, scene, run = variant
    expected = {"fixed": (1, 2, 3), "hanging": (2, 3), "dry": (3,), "drag": (1, 2, 3)}[name]
    assert scene.phases == expected
    assert tuple(sorted(set(run.phase))) == expected


def test_energy_conserved(variant):
    _, _, run = variant
    assert run.attrs["diagnostics"]["energy_drift_rel"] < 1e-9


def test_torque_equals_I_theta_dd(variant):
    _, scene, run = variant
    scale = np.max(np.abs(run.torque))
    assert np.max(np.abs(run.torque - scene.engine.I * run.theta_dd)) < 1e-9 * scale


def test_forces_along_their_arms(variant):
    name, _, run = variant
    if name != "fixed":  # a rigid mount carries force across the arm
        across = kin.dot(np.array([run.F_H_x, run.F_H_y]), kin.unit_perp(run.psi.to_numpy()))
        assert np.max(np.abs(across)) < 1e-9 * np.max(run.F_H_abs)
    held = run[run.phase <= 2]
    if len(held):
        across = kin.dot(np.array([held.F_S_x, held.F_S_y]), kin.unit_perp(held.phi.to_numpy()))
        assert np.max(np.abs(across)) < 1e-9 * np.max(held.F_S_abs)


def test_fixed_counterweight_keeps_its_angle_on_the_beam():
    scene = scene_with(**FIXED)
    run = simulate(scene, dt=1e-3)
    offset = scene.engine.counterweight_offset
    assert np.allclose(run.psi - run.theta, offset, atol=1e-12)
    assert np.allclose(run.psi_d, run.theta_d, atol=1e-12)
    assert np.allclose(run.psi_dd, run.theta_dd, atol=1e-9)


def test_fixed_counterweight_agrees_with_a_beam_that_carries_it():
    """A counterweight fixed on the beam's axis beyond the hinge is part of the beam: the same
    engine as a hinged model whose beam holds the counterweight's mass and inertia and whose
    own counterweight is negligible."""
    fixed = scene_with(**FIXED)
    e = fixed.engine
    rho = e.L2 + e.L3  # offset π: the counterweight sits on the axis, beyond the hinge
    m_b = e.m_b + e.M
    L_CM = (e.m_b * e.L_CM - e.M * rho) / m_b
    merged = scene_with(engine={"M": 1e-9, "L2": rho, "L3": 1.0, "m_b": m_b, "L_CM": L_CM,
                                "I": e.I + e.M * rho**2, "H": fixed.start.H},
                        start={"psi_deg": -90.0})
    a, b = simulate(fixed, dt=1e-3), simulate(merged, dt=1e-3)
    assert a.attrs["events"]["lift_off"] == pytest.approx(b.attrs["events"]["lift_off"],
                                                          abs=1e-9)
    t = np.linspace(0, 1.4, 50)
    a, b = simulate(fixed, t_eval=t), simulate(merged, t_eval=t)
    assert np.allclose(a.theta, b.theta, atol=1e-9)
    assert np.allclose(a.F_S_abs, b.F_S_abs, rtol=1e-7, atol=1e-9 * a.F_S_abs.max())
    assert np.allclose(a.F_R_x, b.F_R_x, atol=1e-7 * a.F_R_abs.max())
    assert np.allclose(a.F_R_y, b.F_R_y, atol=1e-7 * a.F_R_abs.max())
    # the torque on the merged beam also turns the counterweight it carries
    assert np.allclose(b.torque, a.torque + e.M * rho**2 * a.theta_dd,
                       atol=1e-7 * np.abs(b.torque).max())


def test_dry_fire_agrees_with_a_vanishing_projectile():
    dry = scene_with(**DRY)
    tiny = scene_with(engine={"m": 1e-7})
    t = np.linspace(0, 0.99, 60)
    a, b = simulate(dry, t_eval=t), simulate(tiny, t_eval=t)
    assert np.allclose(a.theta, b.theta, atol=1e-8)
    assert np.allclose(a.F_R_y, b.F_R_y, atol=1e-6 * a.F_R_abs.max())
    assert (a.F_S_x == 0).all() and (a.P_m == 0).all() and (a.E_m == 0).all()
    assert a.x_m.isna().all()  # no projectile to place
    assert a.attrs["flight"] is None and set(a.attrs["events"]) == {"end"}


def test_drag_vanishes_to_vacuum_and_shortens_the_range():
    vacuum = simulate(scene_with()).attrs["flight"]
    thin = simulate(scene_with(flight={"model": "drag", "diameter": 0.42,
                                       "air_density": 1e-12})).attrs["flight"]
    air = simulate(scene_with(**DRAG)).attrs["flight"]
    assert thin["range"] == pytest.approx(vacuum["range"], rel=1e-8)
    assert thin["time_of_flight"] == pytest.approx(vacuum["time_of_flight"], rel=1e-8)
    assert thin["apex_height"] == pytest.approx(vacuum["apex_height"], rel=1e-4)
    assert air["range"] < 0.95 * vacuum["range"]
    assert air["impact_speed"] < vacuum["impact_speed"]


def test_drag_flight_loses_energy_after_release():
    run = simulate(scene_with(**DRAG), dt=1e-3)
    flying = run[run.phase == 3]
    assert (np.diff(flying.E_m) < 0).all()


def test_hanging_start_begins_at_rest_in_the_sling():
    scene = scene_with(**HANGING)
    run = simulate(scene, t_eval=[0.0])
    row = run.iloc[0]
    assert row.phase == 2 and row.theta_d == 0 and row.phi_d == 0
    assert row.y_m == pytest.approx(12.0 + 6.48 * np.sin(np.radians(-50)) - 5.55)


@pytest.mark.parametrize("mutate, key", [
    (dict(engine={"counterweight": "swinging"}), "[engine] counterweight"),
    (dict(start={"projectile": "cup"}), "[start] projectile"),
    (dict(flight={"model": "drag"}), "[flight] diameter"),
    (dict(flight={"diameter": 0.4}), "[flight] diameter"),
    (dict(start={"projectile": "sling", "phi_deg": -90.0}), "[start] phi_deg"),
    (dict(start={"projectile": "none", "phi_deg": None}), "[release]"),
])
def test_variant_keys_are_validated(mutate, key):
    with pytest.raises(Exception) as info:
        scene_with(**mutate)
    assert key in str(info.value)


def test_powers_balance(variant):
    """Internal forces do no net work in every variant: P_m + P_M + P_beam = 0."""
    _, _, run = variant
    total = run.P_m + run.P_M + run.P_beam
    assert np.max(np.abs(total)) < 1e-9 * np.max(np.abs(run.P_M))
