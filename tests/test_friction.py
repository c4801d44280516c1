"""Friction at the pivot and the hinge (issue 22): the model against an independent one, the
energy budget, the zero-friction identity, the loads' own identities, the scene keys."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import trebuchet as tb
from tests.conftest import ROOT
from tests.friction_reference import friction_forces as ref_friction
from tests.friction_reference import loads_at, simulate_reference
from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model import dynamics as dyn
from trebuchet.model import forces as fo
from trebuchet.model.scene import Friction, Scene
from trebuchet.model.simulate import integrate

PAPER = ROOT / "data_samples" / "horsdal_friction.toml"
SMALL = ROOT / "data_samples" / "small_fast.toml"


def with_friction(scene: Scene, friction: Friction | None) -> Scene:
    return dataclasses.replace(scene, engine=dataclasses.replace(scene.engine,
                                                                 friction=friction))


@pytest.fixture(scope="module")
def paper() -> Scene:
    return Scene.from_toml(PAPER)


@pytest.fixture(scope="module")
def small() -> Scene:
    return Scene.from_toml(SMALL)


@pytest.fixture(scope="module")
def paper_run(paper):
    return tb.simulate(paper)


@pytest.fixture(scope="module")
def small_run(small):
    return tb.simulate(small)


# --------------------------------------------------------------------------- the equations

@pytest.mark.parametrize("phase", [1, 2, 3])
def test_accelerations_under_generalised_forces_match_the_lagrangian(paper, phase):
    """dynamics' closed form with friction's Q_θ, Q_ψ equals the mass-matrix solve of the
    Lagrange equations derived by sympy from T − V (tests/friction_reference.py)."""
    rng = np.random.default_rng(phase)
    e, g, H = paper.engine, paper.g, paper.start.H
    for _ in range(20):
        th = rng.uniform(-0.8, 0.9) if phase != 1 else rng.uniform(-0.87, -0.2)
        ps, ph = rng.uniform(-2.5, -0.5), rng.uniform(-3.5, -1.0)
        th_d, ps_d, ph_d = rng.normal(0, 3, 3)
        Q = rng.normal(0, 5e4, 2)
        got = dyn.phase_accelerations(phase, th, ps, ph, th_d, ps_d, ph_d, e, g, H, np, *Q)
        q = [th, ps] if phase != 2 else [th, ps, ph]
        qd = [th_d, ps_d] if phase != 2 else [th_d, ps_d, ph_d]
        want = loads_at(phase, paper, q, qd, (*Q, 0.0))[0]
        np.testing.assert_allclose(got[2:2 + len(q)], want, rtol=1e-9, atol=1e-9)


def test_newton_reaches_the_fixed_point_of_the_couples(paper):
    """The couples solved in three Newton steps equal the reference's fixed point (iterated
    to 1e-15), also with friction ten times the sample's (μ r of a third of L2 at the pin)."""
    rng = np.random.default_rng(7)
    for scale in (1.0, 10.0):
        fr = paper.friction
        strong = with_friction(paper, dataclasses.replace(
            fr, pivot_mu=fr.pivot_mu * scale, hinge_mu=fr.hinge_mu * scale))
        e, g, H = strong.engine, strong.g, strong.start.H
        for phase in (1, 2, 3):
            for _ in range(10):
                th = rng.uniform(-0.8, -0.2)
                ps, ph = rng.uniform(-2.5, -0.5), rng.uniform(-3.5, -2.0)
                th_d, ps_d, ph_d = rng.normal(0, 3, 3)
                q = [th, ps] if phase != 2 else [th, ps, ph]
                qd = [th_d, ps_d] if phase != 2 else [th_d, ps_d, ph_d]
                Q_th, Q_ps, _, _ = dyn.friction_forces(phase, th, ps, ph, th_d, ps_d, ph_d, e, g,
                                                       H, math)
                want = ref_friction(phase, strong, q, qd)[0]
                assert Q_th == pytest.approx(want[0], rel=1e-11, abs=1e-9)
                assert Q_ps == pytest.approx(want[1], rel=1e-11, abs=1e-9)


@pytest.mark.parametrize("which", ["paper", "small"])
def test_newton_stops_where_it_has_converged_to_round_off(which, request):
    """friction_solve stops when its margins say the steps have converged: after two steps on
    the sample engines (the third's change below 4 ulp), three at ten times their friction,
    and its magnitudes equal eight Newton steps' to round-off either way."""
    scene = request.getfixturevalue(which)
    rng = np.random.default_rng(11)
    for scale, steps in ((1.0, 2), (10.0, 3)):
        fr = scene.friction
        strong = with_friction(scene, dataclasses.replace(
            fr, pivot_mu=fr.pivot_mu * scale, hinge_mu=fr.hinge_mu * scale))
        e, g, H = strong.engine, strong.g, strong.start.H
        taken = []
        for phase in (2, 3):
            for _ in range(20):
                th, ps, ph = rng.uniform(-0.5, 1.0), rng.uniform(-2.5, 0.5), rng.uniform(-4, -2)
                th_d, ps_d, ph_d = rng.normal(0, 4, 3)
                p = dyn.friction_pieces(phase, th, ps, ph, th_d, ps_d, ph_d, e, g, H, math)
                n_R, n_H = dyn.friction_start(p, math)
                seq = []
                for _ in range(8):
                    n_R, n_H = dyn.friction_newton_step(p, n_R, n_H, math)
                    seq.append((n_R, n_H))
                got = dyn.friction_solve(p, math)
                np.testing.assert_allclose(got, seq[-1], rtol=1e-15)
                taken.append(next(k + 1 for k in range(8) if seq[k] == got))
        assert max(taken) <= steps and (scale == 1.0 or steps in taken), taken


@pytest.mark.parametrize("which", ["paper", "small"])
def test_a_shot_with_friction_matches_an_independent_model(which, request):
    """Angles, loads, lost energies and events against an independent implementation of the
    same model (sympy Lagrangian, Newton's law on each body, fixed-point couples, scipy's
    solve_ivp): the outside checks' tolerances are 2e-6 rad, 1e-4 of each load's peak and
    0.5 % of the lost energy; these are far tighter."""
    scene = request.getfixturevalue(which)
    run = request.getfixturevalue(f"{which}_run")
    state, events = simulate_reference(scene, rtol=1e-11, after_release=0.2)
    for name in ("lift_off", "release"):
        assert run.attrs["events"][name] == pytest.approx(events[name], abs=1e-8)
    t_end = events["release"] + 0.2
    at_event = np.isin(run.t, [events["lift_off"], events["release"],
                               run.attrs["events"]["lift_off"], run.attrs["events"]["release"]])
    rows = run[(run.t > 0.0) & (run.t < t_end) & ~at_event].iloc[::5]
    peak_R = run.F_R_abs.max()
    peak_H = run.F_H_abs.max()
    for _, row in rows.iterrows():
        phase, q, qd, lost = state(row.t)
        assert phase == row.phase
        assert abs(row.theta - q[0]) < 1e-8 and abs(row.psi - q[1]) < 1e-8
        if phase != 3:
            assert abs(row.phi - q[2]) < 1e-8
        qq, qqd = (q, qd) if phase == 2 else (q[:2], qd)
        Q = ref_friction(phase, scene, qq, qqd)[0]
        _, F_R, F_H, _ = loads_at(phase, scene, qq, qqd, Q)
        assert np.hypot(row.F_R_x - F_R[0], row.F_R_y - F_R[1]) < 1e-7 * peak_R
        assert np.hypot(row.F_H_x - F_H[0], row.F_H_y - F_H[1]) < 1e-7 * peak_H
        assert row.E_loss_pivot == pytest.approx(lost[0], rel=1e-7, abs=1e-9 * scene.delta_U)
        assert row.E_loss_hinge == pytest.approx(lost[1], rel=1e-7, abs=1e-9 * scene.delta_U)


# --------------------------------------------------------------------------- the energy

@pytest.mark.parametrize("which", ["paper", "small"])
def test_energy_plus_losses_is_conserved(which, request):
    scene, run = request.getfixturevalue(which), request.getfixturevalue(f"{which}_run")
    diag = run.attrs["diagnostics"]
    assert diag["energy_drift_rel"] < 1e-8  # E_m + E_M + E_beam + E_loss_* to the integrator
    held = run.phase <= 2
    total = (run.E_m + run.E_M + run.E_beam + run.E_loss_pivot + run.E_loss_hinge)[held]
    assert np.abs(total).max() < 1e-8 * scene.delta_U
    loss = run.E_loss_pivot.iloc[-1] + run.E_loss_hinge.iloc[-1]
    assert loss > 0.01 * scene.delta_U  # and friction does take energy
    frictionless = tb.simulate(with_friction(scene, None))
    assert "E_loss_pivot" not in frictionless.columns
    assert run.attrs["flight"]["range"] < frictionless.attrs["flight"]["range"]


@pytest.mark.parametrize("which", ["paper", "small"])
def test_loss_powers_are_heat_and_integrate_to_the_lost_energy(which, request):
    run = request.getfixturevalue(f"{which}_run")
    for joint in ("pivot", "hinge"):
        P, E = run[f"P_loss_{joint}"].to_numpy(), run[f"E_loss_{joint}"].to_numpy()
        assert P.min() >= 0.0
        assert np.all(np.diff(E) >= -1e-9 * E.max())
        t = run.t.to_numpy()
        trapezoid = np.concatenate([[0.0], np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(t))])
        assert np.abs(trapezoid - E).max() < 2e-3 * E.max()  # the 1 ms grid's own error


def test_the_issues_figures(paper_run, small_run, paper, small):
    """Issue 22's user trial: the paper's engine loses 12.6 kJ, 5.0 % of ΔU, by the release;
    the small engine 8.7 %."""
    for run, scene, share in ((paper_run, paper, 5.0), (small_run, small, 8.7)):
        at = run[run.t <= run.attrs["events"]["release"]].iloc[-1]
        lost = at.E_loss_pivot + at.E_loss_hinge
        assert 100.0 * lost / scene.delta_U == pytest.approx(share, abs=0.05)
    at = paper_run[paper_run.t <= 0.997].iloc[-1]
    assert at.E_loss_pivot + at.E_loss_hinge == pytest.approx(12.6e3, abs=50.0)


# --------------------------------------------------------------------------- identities

def test_no_friction_section_and_zero_friction_give_the_same_numbers(horsdal):
    plain = tb.simulate(horsdal)
    zero = tb.simulate(with_friction(horsdal, Friction()))
    pivot_only = with_friction(horsdal, Friction(pivot_mu=0.0, pivot_radius=0.1))
    assert list(zero.columns) == list(plain.columns)
    for run in (zero, tb.simulate(pivot_only)):
        for c in plain.columns:
            np.testing.assert_array_equal(run[c].to_numpy(), plain[c].to_numpy(), err_msg=c)


@pytest.mark.parametrize("which", ["paper", "small"])
def test_torque_on_the_beam_is_I_theta_dd(which, request):
    """The friction couples are part of the beam's torque: torque = I θ̈ still."""
    scene, run = request.getfixturevalue(which), request.getfixturevalue(f"{which}_run")
    want = scene.engine.I * run.theta_dd
    assert np.abs(run.torque - want).max() < 1e-9 * np.abs(want).max()
    assert np.abs(run.torque_friction).max() > 0.0


@pytest.mark.parametrize("which", ["paper", "small"])
def test_the_couples_follow_the_loads_they_cause(which, request):
    """The accelerations in the output are those the couples of the output's own |F_R|,
    |F_H| give: the implicit equations are solved to round-off, in every phase."""
    scene, run = request.getfixturevalue(which), request.getfixturevalue(f"{which}_run")
    e, g, H = scene.engine, scene.g, scene.start.H
    for _, row in run.iloc[1::11].iterrows():
        tau_P, tau_H = tb.model.friction.friction_couples(row.F_R_abs, row.F_H_abs,
                                                          row.theta_d, row.psi_d, e)
        Q = (tau_H - tau_P, -tau_H)
        got = dyn.phase_accelerations(int(row.phase), row.theta, row.psi, row.phi, row.theta_d,
                                      row.psi_d, row.phi_d, e, g, H, math, *Q)
        assert got[2] == pytest.approx(row.theta_dd, rel=1e-10, abs=1e-10)
        assert got[3] == pytest.approx(row.psi_dd, rel=1e-10, abs=1e-10)


def test_projected_hinge_force_with_a_rubbing_pin_equals_the_direct_form(small, small_run):
    """The arm is massless: the pin's couple sets F_H's component across the arm, so the
    projected form (free of ψ̈) equals eq. (11) on an exact motion."""
    angles = small_run[["t", "phase", "theta", "theta_d", "theta_dd", "psi", "psi_d", "psi_dd",
                        "phi", "phi_d", "phi_dd"]]
    direct = tb.forces(angles, small, form="direct")
    projected = tb.forces(angles, small, form="projected")
    peak = direct.F_H_abs.max()
    for c in ("F_H_x", "F_H_y", "F_R_x", "F_R_y", "P_loss_hinge", "torque"):
        scale = np.abs(direct[c]).max()
        assert np.abs(projected[c] - direct[c]).max() < 1e-9 * max(scale, peak), c
    across = (-direct.F_H_x * np.sin(direct.psi) + direct.F_H_y * np.cos(direct.psi))
    assert np.abs(across).max() > 1e-4 * peak  # the pin's couple does bend F_H off the arm


def test_forces_on_given_angles_report_the_losses(paper, paper_run):
    """tb.forces with a scene with friction: the loss columns from the loads and rates alone
    (no model of the motion), the energies by the trapezoidal rule over the rows."""
    angles = paper_run[["t", "phase", "theta", "theta_d", "theta_dd", "psi", "psi_d", "psi_dd",
                        "phi", "phi_d", "phi_dd"]]
    loads = tb.forces(angles, paper)
    for c in ("P_loss_pivot", "P_loss_hinge"):
        np.testing.assert_allclose(loads[c], paper_run[c], rtol=1e-10, atol=1e-6)
    for c in ("E_loss_pivot", "E_loss_hinge"):
        assert np.abs(loads[c] - paper_run[c]).max() < 2e-3 * paper_run[c].max()


def test_lift_off_is_where_the_trough_lets_go_and_the_accelerations_run_on(paper):
    """At lift-off the trough's force is zero, so phase I's and phase II's equations give the
    same accelerations there (with the couples of each)."""
    traj = integrate(paper)
    t = traj.events["lift_off"]
    p1, p2 = traj.phases[0], traj.phases[1]
    e, g, H = paper.engine, paper.g, paper.start.H
    left = dyn.phase_motion(1, p1.sol(t), e, g, H, math)
    right = dyn.phase_motion(2, p2.sol(t), e, g, H, math)
    for k in (6, 7, 8, 9, 10):  # θ̈, ψ̈, φ̈, P_loss
        assert right[k] == pytest.approx(left[k], rel=1e-7, abs=1e-7)
    t = traj.events["release"]  # at release the state runs on into phase III
    before, after = traj.phases[1].sol(t), traj.phases[2].sol(t)
    np.testing.assert_allclose(after, before[[0, 1, 3, 4, 6, 7]], rtol=0, atol=1e-12)


def test_row_loads_torque_includes_the_couples(paper):
    """row_loads' torque is the three terms of eq. (19) plus the couples on the beam."""
    e = paper.engine
    row = dict(zip(fo.ROW_COLUMNS, fo.row_loads(2, -0.3, 2.0, 10.0, -1.2, 4.0, 3.0, -2.5, 1.0,
                                                 5.0, e, paper.g, paper.start.H, False,
                                                 (0.0, 0.0, 0.0)), strict=True))
    terms = row["torque_hinge"] + row["torque_cm"] + row["torque_spigot"]
    assert row["torque"] == pytest.approx(terms + row["torque_friction"], rel=1e-14)
    tau_P = e.pivot_friction * row["F_R_abs"] * math.tanh(2.0 / e.friction_rate)
    tau_H = e.hinge_friction * row["F_H_abs"] * math.tanh(2.0 / e.friction_rate)
    assert row["torque_friction"] == pytest.approx(tau_H - tau_P, rel=1e-14)
    assert row["P_loss_hinge"] == pytest.approx(tau_H * 2.0, rel=1e-14)


# --------------------------------------------------------------------------- scene keys

def _scene_with(friction: dict) -> dict:
    data = Scene.from_toml(PAPER).to_dict()
    data["friction"] = friction
    return data


@pytest.mark.parametrize("friction, message", [
    ({"pivot_mu": -0.1, "pivot_radius": 0.1}, r"\[friction\] pivot_mu: = -0.1: must not be"),
    ({"pivot_mu": "x", "pivot_radius": 0.1}, r"\[friction\] pivot_mu: must be a number"),
    ({"hinge_mu": 0.1}, r"\[friction\] hinge_radius: missing key"),
    ({"pivot_radius": 0.1}, r"\[friction\] pivot_mu: missing key"),
    ({"pivot_mu": 0.1, "pivot_radius": 0.1, "smoothing_rate": 0.0},
     r"\[friction\] smoothing_rate: = 0: must be a positive"),
    ({"pivot_mu": 0.1, "pivot_radius": 0.1, "mu": 0.1}, r"\[friction\] mu: unknown key"),
])
def test_bad_friction_keys_are_refused_by_name(friction, message):
    with pytest.raises(TrebuchetInputError, match=message):
        Scene.from_dict(_scene_with(friction), source="s.toml")


def test_friction_keys_round_trip_and_sweep(paper):
    again = Scene.from_dict(paper.to_dict())
    assert again.friction == paper.friction
    from trebuchet.model.sweep import sweep

    table = sweep(paper, {"friction.pivot_mu": [0.0, 0.3]}, workers=1, progress=False)
    assert table["status"].eq("ok").all()
    assert table["range"].iloc[1] < table["range"].iloc[0]
