"""The lean DOP853 integrator (model/integrator.py): accuracy against analytic solutions, dense
output between steps, events, counters, and agreement with scipy's solve_ivp on a shot."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from trebuchet.model.integrator import solve
from trebuchet.model.simulate import simulate


def oscillator(t, y):
    return [y[1], -y[0]]


def pendulum(t, y):
    return [y[1], -9.81 * math.sin(y[0])]


def pendulum_energy(y):
    return 0.5 * y[1] ** 2 + 9.81 * (1.0 - np.cos(y[0]))


def _event(fun, terminal=True, direction=0.0):
    fun.terminal = terminal
    fun.direction = direction
    return fun


def test_harmonic_oscillator_steps_and_dense_output():
    res = solve(oscillator, (0.0, 10.0), [1.0, 0.0], rtol=1e-10, atol=1e-12)
    assert res.status == 0 and res.success and res.t[-1] == 10.0
    exact = np.array([np.cos(res.t), -np.sin(res.t)])
    at_steps = np.max(np.abs(res.y - exact))
    assert at_steps < 1e-9
    t = np.linspace(0.0, 10.0, 2001)  # most of these fall between steps
    dense = np.max(np.abs(res.sol(t) - np.array([np.cos(t), -np.sin(t)])))
    assert dense < 1e-9
    assert dense < 10 * at_steps + 1e-13  # the interpolant adds no error of its own
    assert res.sol(2.5).shape == (2,)
    assert res.sol(t).shape == (2, t.size)


def test_pendulum_conserves_energy():
    y0 = [2.5, 0.0]  # a large swing: strongly non-linear
    res = solve(pendulum, (0.0, 20.0), y0, rtol=1e-11, atol=1e-13)
    e0 = pendulum_energy(np.array(y0))
    t = np.linspace(0.0, 20.0, 4001)
    drift = np.max(np.abs(pendulum_energy(res.sol(t)) - e0)) / e0
    assert drift < 1e-9


def test_dense_output_is_seventh_order_on_one_step():
    """One step of size h on y' = y: the interpolant's worst error shrinks as h^8."""
    def errors(h):
        res = solve(lambda t, y: [y[0]], (0.0, h), [1.0], rtol=1.0, atol=1.0, first_step=h)
        assert res.n_accepted == 1
        t = np.linspace(0.0, h, 101)
        return np.max(np.abs(res.sol(t)[0] - np.exp(t)))

    e1, e2 = errors(0.8), errors(0.4)
    assert e1 > 1e-13
    assert e1 / e2 > 2 ** 7


def test_falling_body_hits_ground_at_sqrt_2h_over_g():
    g, h = 9.81, 10.0
    hit = _event(lambda t, y: y[0], terminal=True, direction=-1)
    res = solve(lambda t, y: [y[1], -g], (0.0, 10.0), [h, 0.0], rtol=1e-10, atol=1e-12,
                events=[hit])
    assert res.status == 1 and res.message.startswith("A termination event")
    t_hit = math.sqrt(2 * h / g)
    assert abs(res.t_events[0][0] - t_hit) < 1e-12
    assert abs(res.y_events[0][0][0]) < 1e-12
    assert res.y_events[0][0][1] == pytest.approx(-g * t_hit, rel=1e-12)
    assert res.t[-1] == res.t_events[0][0]  # the run ends at the event
    assert res.sol.t_max == res.t[-1]


@pytest.mark.parametrize("direction, fires", [(-1, True), (1, False), (0, True)])
def test_event_direction(direction, fires):
    """A body falling through y = 5: only a falling or either-way event fires."""
    cross = _event(lambda t, y: y[0] - 5.0, terminal=True, direction=direction)
    res = solve(lambda t, y: [y[1], -9.81], (0.0, 1.2), [10.0, 0.0], rtol=1e-10, atol=1e-12,
                events=[cross])
    assert (res.t_events[0].size == 1) == fires
    assert res.status == (1 if fires else 0)
    if fires:
        assert res.t_events[0][0] == pytest.approx(math.sqrt(2 * 5.0 / 9.81), abs=1e-12)


def test_non_terminal_and_counted_terminal_events():
    """cos t crosses zero at (k + 1/2) π: recorded without stopping, or stopping at the 3rd."""
    zero = _event(lambda t, y: y[0], terminal=False, direction=0)
    down = _event(lambda t, y: y[0], terminal=False, direction=-1)
    res = solve(oscillator, (0.0, 10.0), [1.0, 0.0], rtol=1e-10, atol=1e-12,
                events=[zero, down])
    assert res.status == 0
    np.testing.assert_allclose(res.t_events[0], (np.arange(3) + 0.5) * np.pi, atol=1e-10)
    np.testing.assert_allclose(res.t_events[1], [0.5 * np.pi, 2.5 * np.pi], atol=1e-10)
    third = _event(lambda t, y: y[0], terminal=3, direction=0)
    res = solve(oscillator, (0.0, 20.0), [1.0, 0.0], rtol=1e-10, atol=1e-12, events=[third])
    assert res.status == 1 and res.t[-1] == pytest.approx(2.5 * np.pi, abs=1e-10)


def test_nfev_counts_every_call():
    calls = []

    def fun(t, y):
        calls.append(t)
        return oscillator(t, y)

    res = solve(fun, (0.0, 5.0), [1.0, 0.0], rtol=1e-8, atol=1e-10)
    assert res.nfev == len(calls)
    res.sol(np.linspace(0.0, 5.0, 50))  # the lazy dense output adds 3 per step it builds
    assert res.nfev + res.sol.nfev == len(calls)
    assert res.sol.nfev == 3 * res.n_accepted


def test_agrees_with_scipy_on_a_nonlinear_system():
    y0 = [2.5, 0.0]
    ours = solve(pendulum, (0.0, 5.0), y0, rtol=1e-10, atol=1e-12)
    ref = solve_ivp(pendulum, (0.0, 5.0), y0, method="DOP853", rtol=1e-10, atol=1e-12,
                    dense_output=True)
    t = np.linspace(0.0, 5.0, 777)
    assert np.max(np.abs(ours.sol(t) - ref.sol(t))) < 1e-9
    assert abs(ours.n_accepted - (len(ref.t) - 1)) <= 2  # the same step-size control


def test_array_state_and_vector_atol():
    def fun(t, y):
        assert isinstance(y, np.ndarray)
        return np.array([y[1], -y[0]])

    res = solve(fun, (0.0, 3.0), np.array([1.0, 0.0]), rtol=1e-10, atol=[1e-12, 1e-12],
                array_state=True)
    assert res.y[0, -1] == pytest.approx(math.cos(3.0), abs=1e-9)


def test_blow_up_reports_failure():
    res = solve(lambda t, y: [y[0] * y[0]], (0.0, 2.0), [1.0], rtol=1e-6, atol=1e-9)
    assert res.status == -1 and not res.success
    assert res.t[-1] == pytest.approx(1.0, abs=1e-3)


def test_bad_arguments():
    with pytest.raises(ValueError):
        solve(oscillator, (1.0, 0.0), [1.0, 0.0])
    with pytest.raises(ValueError):
        solve(oscillator, (0.0, 1.0), [1.0, 0.0], rtol=0.0)
    with pytest.raises(ValueError):
        solve(lambda t, y: [1.0], (0.0, 1.0), [1.0, 0.0])


# --- the trebuchet shot, against scipy's solve_ivp ---------------------------------------

@pytest.mark.parametrize("name", ["horsdal", "backyard"])
def test_shot_agrees_with_solve_ivp(request, name):
    """Angles at many times, lift-off and release (by time for the paper's engine, by velocity
    angle for the backyard one) agree with scipy's DOP853 to ~1e-9."""
    scene = request.getfixturevalue(name)
    ours = simulate(scene, dt=2e-4)
    ref = simulate(scene, dt=2e-4, method="scipy-DOP853")
    assert ref.attrs["diagnostics"]["method"] == "scipy-DOP853"
    for k in ("lift_off", "release", "end"):
        assert ours.attrs["events"][k] == pytest.approx(ref.attrs["events"][k], abs=1e-11), k
    assert len(ours) == len(ref)
    assert (ours.phase.to_numpy() == ref.phase.to_numpy()).all()
    for col in ("theta", "psi", "phi", "theta_d", "psi_d", "phi_d", "theta_dd", "psi_dd"):
        a, b = ours[col].to_numpy(), ref[col].to_numpy()
        scale = max(1.0, float(np.nanmax(np.abs(b))))
        assert np.nanmax(np.abs(a - b)) < 1e-9 * scale, col
    if scene.release.velocity_angle is not None:
        assert ours.attrs["flight"]["release_angle"] == pytest.approx(
            scene.release.velocity_angle, abs=1e-10)


def test_shot_falls_back_to_other_solve_ivp_methods(horsdal):
    run = simulate(horsdal, t_eval=[0.1, 0.5, 1.0], method="RK45", rtol=1e-8)
    fast = simulate(horsdal, t_eval=[0.1, 0.5, 1.0])
    np.testing.assert_allclose(run.theta, fast.theta, atol=1e-5)


def test_dense_solution_pickles_without_fun():
    import pickle

    def fun(t, y):  # a closure-like local function: not picklable itself
        return [y[1], -y[0]]

    res = solve(fun, (0.0, 3.0), [1.0, 0.0], rtol=1e-10, atol=1e-12)
    t = np.linspace(0.0, 3.0, 31)
    back = pickle.loads(pickle.dumps(res.sol))
    np.testing.assert_array_equal(back(t), res.sol(t))


def test_vectorised_dense_output_equals_the_step_by_step_one():
    """Coefficients built for all steps at once through the array right-hand side equal those
    built step by step through the float one."""
    def pendulum(t, y):
        return [y[1], -math.sin(y[0]) - 0.1 * y[1]]

    def pendulum_arrays(t, y):
        return np.array([y[1], -np.sin(y[0]) - 0.1 * y[1]])

    plain = solve(pendulum, (0.0, 10.0), [2.0, 0.0], rtol=1e-10, atol=1e-12)
    fast = solve(pendulum, (0.0, 10.0), [2.0, 0.0], rtol=1e-10, atol=1e-12,
                 vectorized_fun=pendulum_arrays)
    t = np.linspace(0.0, 10.0, 997)
    assert np.allclose(fast.sol(t), plain.sol(t), rtol=0, atol=1e-13)
    assert fast.sol.nfev == plain.sol.nfev  # three extra stages per step either way
