"""Cross-checks of the formulas over whole shots, for the paper's engine and a backyard one.

Each check compares two independent routes to the same number: energy from the state against
zero (conservation), the torque summed from the forces against I θ̈, forces against the arm they
must lie along, work (integrated power) against energy gained, and the phase-I sling force
against m times the numerically differentiated projectile position.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import cumulative_simpson

from trebuchet.model import kinematics as kin
from trebuchet.model.initial import heavy_counterweight_limits, initial_accelerations
from trebuchet.model.simulate import simulate


@pytest.fixture(scope="module", params=["horsdal", "backyard"])
def shot(request):
    scene = request.getfixturevalue(request.param)
    return scene, simulate(scene, dt=1e-4)


def _scale(run, *cols):
    return max(float(np.max(np.abs(run[c]))) for c in cols)


def test_energy_conserved(shot):
    scene, run = shot
    delta_u = run.attrs["diagnostics"]["delta_U"]
    total = run.E_m + run.E_M + run.E_beam
    assert np.max(np.abs(total)) < 1e-9 * delta_u
    assert run.attrs["diagnostics"]["energy_drift_rel"] < 1e-9


def test_powers_sum_to_zero(shot):
    """Internal forces do no net work: P_m + P_M + P_beam = 0 at every instant."""
    _, run = shot
    total = run.P_m + run.P_M + run.P_beam
    assert np.max(np.abs(total)) < 1e-8 * _scale(run, "P_m", "P_M", "P_beam")


def test_torque_equals_I_theta_dd(shot):
    scene, run = shot
    assert np.allclose(run.torque, scene.engine.I * run.theta_dd, rtol=0,
                       atol=1e-9 * _scale(run, "torque"))
    assert np.allclose(run.torque_hinge + run.torque_cm + run.torque_spigot, run.torque)


def test_hinge_force_along_counterweight_arm(shot):
    _, run = shot
    across = kin.dot(np.array([run.F_H_x, run.F_H_y]), kin.unit_perp(run.psi.to_numpy()))
    assert np.max(np.abs(across)) < 1e-9 * _scale(run, "F_H_abs")


def test_sling_force_along_sling_while_held(shot):
    _, run = shot
    held = run[run.phase <= 2]
    across = kin.dot(np.array([held.F_S_x, held.F_S_y]), kin.unit_perp(held.phi.to_numpy()))
    assert np.max(np.abs(across)) < 1e-9 * _scale(held, "F_S_abs")
    assert (held.sling_tension >= 0).all()


def test_work_equals_energy_gained(shot):
    """∫ P dt of each part, phase by phase, equals the mechanical energy it gained."""
    _, run = shot
    delta_u = run.attrs["diagnostics"]["delta_U"]
    ev = run.attrs["events"]
    edges = [0.0, ev["lift_off"], ev["release"], ev["end"]]
    for part in ("m", "M", "beam"):
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            seg = run[(run.t >= a) & (run.t <= b)]
            if part == "m" or a > 0:
                # rows at an event time belong to the phase before: use the interior
                seg = seg[(seg.t > a) | (a == 0.0)]
            work = cumulative_simpson(seg[f"P_{part}"].to_numpy(), x=seg.t.to_numpy(), initial=0)
            gained = seg[f"E_{part}"].to_numpy() - seg[f"E_{part}"].iloc[0]
            assert np.max(np.abs(work - gained)) < 2e-6 * delta_u, (part, a, b)


def test_trough_sling_force_is_m_times_acceleration(shot):
    """Phase I: F_S·e_x equals m d²x_m/dt², with x_m differentiated numerically."""
    scene, run = shot
    ph1 = run[(run.phase == 1) & (run.t < run.attrs["events"]["lift_off"])]  # uniform grid
    t, x = ph1.t.to_numpy(), ph1.x_m.to_numpy()
    h = t[1] - t[0]
    a_x = (x[2:] - 2 * x[1:-1] + x[:-2]) / h**2
    F = ph1.F_S_x.to_numpy()[1:-1]
    assert np.max(np.abs(scene.engine.m * a_x - F)) < 1e-5 * np.max(np.abs(F))
    # and the projectile stays in the trough
    assert np.max(np.abs(ph1.y_m)) < 1e-9 * scene.engine.L4


def test_simulated_start_matches_closed_form(shot):
    scene, run = shot
    closed = initial_accelerations(scene)
    row = run.iloc[0]
    assert row.t == 0 and row.phase == 1
    assert (row.theta_dd, row.psi_dd, row.phi_dd) == pytest.approx(closed, rel=1e-12)


@pytest.mark.parametrize("M", [1e6, 1e8, 1e10])
def test_heavy_counterweight_limits(horsdal, M):
    """θ̈_i, ψ̈_i, φ̈_i approach the paper's M → ∞ closed forms as 1/M."""
    scene = dataclasses.replace(horsdal, engine=dataclasses.replace(horsdal.engine, M=M))
    lim = heavy_counterweight_limits(scene)
    acc = initial_accelerations(scene)
    e, th = scene.engine, scene.start.theta
    # first-order correction: (I + m L1² sin² θ_i)/(M L2² cos² θ_i), plus m_b L_CM/(M L2)
    rel = 1.5 * ((e.I + e.m * e.L1**2) / (M * e.L2**2 * math.cos(th) ** 2)
                 + e.m_b * e.L_CM / (M * e.L2))
    assert acc == pytest.approx((lim["theta_dd"], lim["psi_dd"], lim["phi_dd"]), rel=rel)
    a_m = -scene.engine.L1 * math.sin(th) * acc[0]
    assert a_m == pytest.approx(lim["a_m_x"], rel=rel)


def test_events_located_to_solver_accuracy(shot):
    """Lift-off: F_N = 0 at the event; release by angle: the climb equals the target angle."""
    scene, run = shot
    ev = run.attrs["events"]
    at_lift = simulate(scene, t_eval=[ev["lift_off"]])
    assert abs(at_lift.F_N.iloc[0]) < 1e-7 * scene.engine.m * scene.g
    if scene.release.velocity_angle is not None:
        assert run.attrs["flight"]["release_angle"] == pytest.approx(
            scene.release.velocity_angle, abs=1e-8)
    else:
        assert ev["release"] == scene.release.time


def test_forces_on_bad_angles_name_the_problem(horsdal):
    import pandas as pd

    from trebuchet.core.errors import TrebuchetInputError
    from trebuchet.model.loads import loads

    run = simulate(horsdal, t_eval=[0.0, 0.5])
    angles = run[["t", "phase", "theta", "psi", "phi", "theta_d", "psi_d", "phi_d",
                  "theta_dd", "psi_dd", "phi_dd"]]
    again = loads(angles, horsdal)
    assert np.allclose(again.F_R_x, run.F_R_x) and np.allclose(again.torque, run.torque)
    with pytest.raises(TrebuchetInputError, match="lack the column.*psi_dd"):
        loads(angles.drop(columns=["psi_dd"]), horsdal)
    with pytest.raises(TrebuchetInputError, match="row 1 has 7"):
        loads(angles.assign(phase=pd.Series([1, 7])), horsdal)
