"""The summary-only path of sweeps (model/shot_summary.py, model/summary_kernel.py): figures
without a table, checked against simulate's table of the same shot; and the statuses of throws
that go backward or into the ground."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from trebuchet.model import kinematics as kin
from trebuchet.model.scene import Scene
from trebuchet.model.shot_summary import (
    CLEARANCE_WINDOW,
    FIGURES,
    shot_figures,
    throw_status,
)
from trebuchet.model.simulate import simulate
from trebuchet.model.sweep import SimulationOptions, summarize, sweep

PEAKS = {"F_S_peak": "F_S_abs", "F_H_peak": "F_H_abs", "F_R_peak": "F_R_abs",
         "F_R_perp_peak": "F_R_perp", "torque_peak": "torque"}


FRICTION = Path(__file__).resolve().parents[1] / "data_samples" / "horsdal_friction.toml"


@pytest.fixture(scope="module", params=["horsdal", "backyard", "friction"])
def scene(request, horsdal, backyard) -> Scene:
    base = {"horsdal": horsdal, "backyard": backyard,
            "friction": Scene.from_toml(FRICTION)}[request.param]
    return base.with_release(velocity_angle=math.radians(40.0))


@pytest.fixture(scope="module")
def figures(scene):
    return shot_figures(scene)


@pytest.fixture(scope="module")
def table(scene):
    return simulate(scene)  # rows every 1 ms, 0.5 s past the release


def test_events_and_flight_as_simulate(figures, table):
    ev, fl = table.attrs["events"], table.attrs["flight"]
    assert figures.lift_off == ev["lift_off"] and figures.release_time == ev["release"]
    assert figures.range == fl["range"] and figures.release_speed == fl["release_speed"]
    assert figures.release_angle_deg == pytest.approx(40.0, abs=1e-9)
    assert list(figures.as_dict()) == list(FIGURES)


@pytest.mark.parametrize("name", list(PEAKS))
def test_peaks_are_the_continuous_maxima(figures, table, scene, name):
    """No row of simulate's table lies above a peak, the rows come within 1e-4 of it, and the
    loads at the peak's own time give its value; a table at 1 µs steps around that time (the
    next best thing to the continuous maximum) finds nothing higher."""
    col = PEAKS[name]
    peak, t_peak = getattr(figures, name), figures.times[name]
    row_max = float(table[col].abs().max())
    assert peak >= row_max * (1 - 1e-13)
    assert peak <= row_max * (1 + 1e-4)
    at = simulate(scene, t_eval=[t_peak])
    assert abs(float(at[col].iloc[0])) == pytest.approx(peak, rel=1e-12)
    end = figures.release_time + 0.5
    fine = simulate(scene, t_eval=np.linspace(max(t_peak - 2e-3, 0.0), min(t_peak + 2e-3, end),
                                              4001))
    assert float(fine[col].abs().max()) <= peak * (1 + 1e-12)


def test_least_tension_and_clearance(figures, table, scene):
    held = table[table["phase"] <= 2]
    assert figures.sling_tension_min <= held["sling_tension"].min() + 1e-9
    assert figures.sling_tension_min == pytest.approx(held["sling_tension"].min(), rel=1e-4,
                                                      abs=1e-6 * scene.engine.m * scene.g)
    t_low = figures.times["cw_clearance"]
    assert t_low <= figures.release_time + CLEARANCE_WINDOW + 1e-12
    at = simulate(scene, t_eval=[t_low])
    y = kin.counterweight_position_xy(np.cos(at["theta"]), np.sin(at["theta"]),
                                      np.cos(at["psi"]), np.sin(at["psi"]), scene.engine,
                                      scene.start.H)[1]
    assert float(y[0]) == pytest.approx(figures.cw_clearance, rel=1e-12)
    rows = summarize(table, scene)["cw_clearance"]
    assert figures.cw_clearance <= rows + 1e-12 and rows - figures.cw_clearance < 1e-3


def test_rows_path_equals_the_table(scene, table):
    """With an output step the figures are the table's own extrema, to the last bit."""
    on_rows = shot_figures(scene, dt=1e-3).as_dict()
    expected = summarize(table, scene)
    for name in FIGURES:
        if name == "energy_drift_rel":
            assert on_rows[name] == pytest.approx(expected[name], rel=1e-6)
        else:
            assert on_rows[name] == expected[name], name


def test_heat_by_the_release(figures, table, scene):
    """E_loss_release is the table's integrated heat at the release row; the energy sum with
    it stays at the solver's accuracy (a frictionless engine makes none)."""
    at = table[(table["t"] == figures.release_time) & (table["phase"] == 2)]
    if scene.friction is None:
        assert figures.E_loss_release == 0.0 and "E_loss_pivot" not in table
    else:
        expected = float(at["E_loss_pivot"].iloc[0] + at["E_loss_hinge"].iloc[0])
        assert figures.E_loss_release == pytest.approx(expected, rel=1e-12)
        assert figures.E_loss_release > 0.01 * scene.delta_U
    assert figures.loss_share == pytest.approx(100 * figures.E_loss_release / scene.delta_U)
    assert figures.energy_drift_rel < 1e-8


def test_short_phase_three_keeps_the_clearance_window(scene):
    """Peaks over 0.1 s of phase III, the clearance still over 0.5 s past the release."""
    short = shot_figures(scene, after_release=0.1)
    full = shot_figures(scene)
    assert short.cw_clearance == pytest.approx(full.cw_clearance, rel=1e-9)
    assert short.times["F_R_peak"] <= short.release_time + 0.1 + 1e-12


@pytest.mark.parametrize(("angle_deg", "range_", "status"), [
    (40.0, 400.0, "ok"), (120.0, -95.0, "backward"), (95.0, 3.0, "backward"),
    (10.0, -2.0, "backward"), (-5.0, 60.0, "ground"), (-115.0, 3.3, "ground"),
    (float("nan"), float("nan"), "ok")])
def test_throw_status(angle_deg, range_, status):
    assert throw_status(math.radians(angle_deg), range_) == status


def test_sweep_marks_backward_and_ground_throws(horsdal):
    """With the scene's fixed release time, light counterweights let go late in the swing
    (backward, behind the pivot) and a long time lets go on the way down (into the ground):
    each keeps its figures and says so; none is "ok"."""
    table = sweep(horsdal, {"engine.M": [12000.0, 19100.0], "release.time": [0.997, 1.3]},
                  workers=1, progress=False)
    by = {(r["engine.M"], r["release.time"]): r for _, r in table.iterrows()}
    back = by[(12000.0, 0.997)]
    assert back["status"] == "backward" and back["range"] < 0
    assert "behind the pivot" in back["error"]
    down = by[(19100.0, 1.3)]
    assert down["status"] == "ground" and down["release_angle"] < 0
    assert "into the ground" in down["error"]
    assert by[(19100.0, 0.997)]["status"] == "ok"


def test_sweep_figures_are_the_summary_path(horsdal):
    table = sweep(horsdal, {"engine.M": [19100.0]}, workers=1, progress=False)
    direct = shot_figures(horsdal).as_dict()
    assert {k: table[k].iloc[0] for k in FIGURES} == direct


def test_rows_option_refused_out_of_range():
    from trebuchet.core.errors import TrebuchetInputError

    with pytest.raises(TrebuchetInputError, match="dt"):
        SimulationOptions(dt=0.5).check()
    with pytest.raises(TrebuchetInputError, match="after_release"):
        SimulationOptions(after_release=1e6).check()


def test_friction_keys_sweep(horsdal):
    """``friction.pivot_mu=0:0.3:4`` on the paper's engine with friction: more friction, more
    heat and less range; without a [friction] section a coefficient alone is refused with the
    reason (it needs the shaft's radius)."""
    base = Scene.from_toml(FRICTION)
    table = sweep(base, {"friction.pivot_mu": [0.0, 0.1, 0.2, 0.3]}, workers=1, progress=False)
    assert (table["status"] == "ok").all()
    assert np.all(np.diff(table["E_loss_release"]) > 0) and np.all(np.diff(table["range"]) < 0)
    refused = sweep(horsdal, {"friction.pivot_mu": [0.1]}, workers=1, progress=False)
    assert refused["status"].iloc[0] == "refused" and "pivot_radius" in refused["error"].iloc[0]
