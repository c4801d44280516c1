"""The compiled shot kernel (model/shot_kernel.py): the same steps, events and outputs as the
pure-Python DOP853, the same formulas (it calls dynamics.py and phase_events.py), a cache that
follows the sources, and the pandas-free output path of simulate."""

from __future__ import annotations

import math
from dataclasses import asdict, replace
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model import dynamics as dyn
from trebuchet.model import phase_events as pev
from trebuchet.model import shot_kernel as sk
from trebuchet.model.kernel_phase import KernelSolution, solve_phase
from trebuchet.model.loads import load_columns, loads
from trebuchet.model.shot_checks import refuse_non_finite
from trebuchet.model.simulate import integrate, simulate


@pytest.mark.parametrize("name", ["horsdal", "backyard"])
def test_compiled_and_python_dop853_take_the_same_steps(request, name):
    """Same tableau, error norm, step control and event location: the step starts, the events
    and the dense output agree to rounding (the backyard engine releases by velocity angle)."""
    scene = request.getfixturevalue(name)
    fast = integrate(scene, method="numba-DOP853")
    slow = integrate(scene, method="python-DOP853")
    assert set(fast.events) == set(slow.events)
    for k, t in slow.events.items():
        assert fast.events[k] == pytest.approx(t, rel=0, abs=1e-13), k
    for a, b in zip(fast.phases, slow.phases, strict=True):
        assert a.phase == b.phase
        assert isinstance(a.sol, KernelSolution)
        np.testing.assert_allclose(a.sol.t_steps, b.sol.t_old, rtol=1e-12, atol=1e-15)
        t = np.linspace(a.t0, a.t1, 97)
        scale = np.maximum(1.0, np.abs(b.sol(t)).max(axis=1, keepdims=True))
        assert np.all(np.abs(a.sol(t) - b.sol(t)) <= 1e-11 * scale)
    cols = fast.angle_columns(np.linspace(0.0, fast.t_end, 301))
    ref = slow.angle_columns(np.linspace(0.0, slow.t_end, 301))
    for k in ref:
        np.testing.assert_allclose(cols[k], ref[k], rtol=1e-9, atol=1e-9, err_msg=k)


def test_kernel_accelerations_are_the_dynamics_module_formulas(horsdal):
    """The compiled columns equal the numpy evaluation of dynamics.py on the same states."""
    traj = integrate(horsdal, method="numba-DOP853")
    for p in traj.phases:
        t = np.linspace(p.t0, p.t1, 50)[1:]
        out = np.empty((9, t.size))
        p.sol.columns(t, out)
        y = p.sol(t)
        e, g, H = horsdal.engine, horsdal.g, horsdal.start.H
        if p.phase == 1:
            want = dyn.accelerations_phase1(*y, e, g, H)[2:]
        elif p.phase == 2:
            want = dyn.accelerations_phase2(*y, e, g)
        else:
            want = dyn.accelerations_phase3(*y, e, g)
        for row, w in zip((6, 7, 8), want, strict=False):
            np.testing.assert_allclose(out[row], w, rtol=1e-12, atol=1e-9)


def test_event_functions_match_between_python_and_compiled(horsdal):
    """phase_events on floats in Python and inside the compiled kernel give the same numbers."""
    e, g, H = horsdal.engine, horsdal.g, horsdal.start.H
    je = sk.jit_engine(e)
    y4 = np.array([horsdal.start.theta + 0.3, horsdal.start.psi, 1.2, -0.4])
    y6 = np.array([0.2, -1.0, -2.0, 3.0, 1.0, 6.0])
    for kind, y, par in ((pev.LIFT_OFF, y4, 0.0), (pev.SLING_UPRIGHT, y4, 0.0),
                         (pev.GROUND, y6, 0.0), (pev.RELEASE_TIME, y6, 0.9),
                         (pev.RELEASE_ANGLE, y6, math.radians(40.0))):
        py = pev.event_value(kind, 0.5, list(y), e, g, H, par)
        assert sk._event(kind, 0.5, y, je, g, H, par) == pytest.approx(py, rel=1e-13, abs=1e-13)


def test_fixed_counterweight_runs_compiled():
    """The fixed-counterweight branch of dynamics.py (ψ = θ + offset) compiles and agrees."""
    from tests.test_variants import FIXED, scene_with

    scene = scene_with(**FIXED)
    fast = integrate(scene, method="numba-DOP853")
    slow = integrate(scene, method="python-DOP853")
    for k, t in slow.events.items():
        assert fast.events[k] == pytest.approx(t, abs=1e-12), k
    t = np.linspace(0.0, fast.t_end, 200)
    a, b = fast.angle_columns(t), slow.angle_columns(t)
    np.testing.assert_allclose(a["psi"] - a["theta"], scene.engine.counterweight_offset,
                               atol=1e-12)
    np.testing.assert_allclose(a["theta_dd"], b["theta_dd"], rtol=1e-9, atol=1e-9)


def test_step_too_small_is_reported(horsdal):
    """A right-hand side that turns NaN makes every step fail: status −1, not a hang."""
    with pytest.raises(TrebuchetInputError, match="L3 = nan"):  # an Engine refuses it
        replace(horsdal.engine, L3=math.nan)
    broken = SimpleNamespace(**(asdict(horsdal.engine) | {"L3": math.nan}),
                             fixed_counterweight=False, pivot_friction=0.0, hinge_friction=0.0,
                             friction_rate=1e-3)  # so the kernel gets it unchecked
    sol = solve_phase(3, broken, horsdal.g, horsdal.start.H, 0.0, 1.0,
                         np.array([horsdal.start.theta, horsdal.start.psi, 0.0, 0.0]), 1e-10)
    assert sol.status == -1
    assert "step size" in sol.message


def test_stale_cache_is_discarded_when_a_source_changes(tmp_path, monkeypatch):
    """Numba checks only the cached function's own file; the kernel keeps a digest of the
    formula files and empties the cache index when any of them changes."""
    flushed: list[int] = []
    fakes = [SimpleNamespace(_cache=SimpleNamespace(_cache_path=str(tmp_path),
                                                    flush=lambda i=i: flushed.append(i)))
             for i in range(3)]
    source = tmp_path / "formulas.py"
    source.write_text("x = 1\n")
    monkeypatch.setattr(sk, "_rate", fakes[0])
    monkeypatch.setattr(sk, "_COMPILED", tuple(fakes))
    monkeypatch.setattr(sk, "_SOURCES", (source,))
    assert sk._discard_stale_cache() is True  # no digest yet: build
    assert flushed == [0, 1, 2]
    assert sk._discard_stale_cache() is False  # same sources: keep
    assert flushed == [0, 1, 2]
    source.write_text("x = 2\n")
    assert sk._discard_stale_cache() is True  # a formula changed: discard
    assert flushed == [0, 1, 2, 0, 1, 2]


def test_load_columns_is_loads_without_pandas(horsdal):
    traj = integrate(horsdal)
    cols = traj.angle_columns(np.linspace(0.0, traj.t_end, 400))
    frame = loads(pd.DataFrame(cols), horsdal, release_state=traj.release_state)
    out = load_columns(cols, horsdal, release_state=traj.release_state)
    assert list(out) == list(frame.columns)
    for k, v in out.items():
        np.testing.assert_array_equal(frame[k].to_numpy(), v, err_msg=k)


def test_loads_keeps_a_text_column(horsdal):
    traj = integrate(horsdal)
    angles = traj.angles(np.linspace(0.0, 1.0, 20))
    angles["camera"] = "left"
    out = loads(angles, horsdal)
    assert (out["camera"] == "left").all()
    assert np.isfinite(out["F_R_x"]).all()


def test_non_finite_output_is_refused_naming_the_column(horsdal):
    run = simulate(horsdal, t_eval=np.linspace(0.0, 1.4, 50))
    cols = {k: run[k].to_numpy().copy() for k in run.columns}
    refuse_non_finite(cols, horsdal)  # φ is NaN after the release by design: accepted
    assert np.isnan(cols["phi"][cols["phase"] == 3]).all()
    cols["F_H_x"][7] = np.inf
    with pytest.raises(TrebuchetInputError, match=r"F_H_x is not finite"):
        refuse_non_finite(cols, horsdal)
    cols["F_H_x"][7] = 0.0
    cols["phi"][2] = np.nan  # in phase 1 the sling angle exists
    with pytest.raises(TrebuchetInputError, match=r"phi is not finite"):
        refuse_non_finite(cols, horsdal)
