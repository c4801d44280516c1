"""A sweep design in one call of the C (model/c_peaks.py, fmu/c/treb_peaks.c) and its scene
without the scene file's dict (scene.with_numbers, model/sweep_scene.py): the same figures as
the numba peak search on the C's steps (the path before), to rounding; the same scenes and the
same refusals as Scene.from_dict; a batch the same as its designs one by one."""

from __future__ import annotations

import math
import shutil

import pytest

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model import shot_summary, sweep_design, sweep_scene
from trebuchet.model.scene import Scene, with_numbers
from trebuchet.model.shot_summary import FIGURES, designs_figures, shot_figures
from trebuchet.model.sweep_design import evaluate_design, evaluate_designs
from trebuchet.model.sweep_scene import design_scene

from .conftest import ROOT
from .test_variants import DRAG, DRY, FIXED, HANGING, scene_with

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None, reason="needs gcc")

FRICTION = Scene.from_toml(ROOT / "data_samples" / "horsdal_friction.toml")
EXACT = ("lift_off", "release_time", "release_speed", "release_angle", "release_angle_deg",
         "release_height", "range")
ANGLE = dict(release={"time": None, "velocity_angle_deg": 40.0})
DESIGNS = {  # (scene, after_release)
    "paper": (scene_with(), None), "angle": (scene_with(**ANGLE), None),
    "fixed": (scene_with(**FIXED), None), "sling": (scene_with(**HANGING), None),
    "dry": (scene_with(**DRY), None), "drag": (scene_with(**DRAG), None),
    "friction": (FRICTION, None),
    "friction_angle": (FRICTION.with_release(velocity_angle=math.radians(35.0)), None),
    "backward": (scene_with(engine={"M": 12000.0}), None),
    "ground": (scene_with(release={"time": 1.3}), None),
    "short_phase_three": (scene_with(**ANGLE), 0.1),
}


def _before(monkeypatch, scene: Scene, after_release: float | None):
    """The figures as the sweep took them before: the C integrates, numba's summary kernel
    searches the peaks on its steps."""
    with monkeypatch.context() as m:
        m.setattr(shot_summary, "designs_figures", lambda scenes, **kw: [None] * len(scenes))
        return shot_figures(scene, after_release=after_release)


@pytest.mark.parametrize("name", sorted(DESIGNS))
def test_one_c_call_gives_the_figures_of_the_numba_search(name, monkeypatch):
    scene, after = DESIGNS[name]
    new = shot_figures(scene, after_release=after)
    old = _before(monkeypatch, scene, after)
    a, b = new.as_dict(), old.as_dict()
    for k in FIGURES:
        if k in EXACT or math.isnan(b[k]):
            assert a[k] == b[k] or (math.isnan(a[k]) and math.isnan(b[k])), k
        elif k == "energy_drift_rel":  # a sum of energies to 1e-16 of each, over ΔU
            assert a[k] == pytest.approx(b[k], rel=1e-3, abs=1e-13)
        else:
            assert a[k] == pytest.approx(b[k], rel=1e-10, abs=1e-9), k
    for k, t in old.times.items():  # the same maximum, located on a flat top
        assert new.times[k] == pytest.approx(t, abs=1e-5, nan_ok=True), k
    assert new.status == old.status


def test_a_batch_is_its_designs_one_by_one():
    """One call for many designs gives each design's figures bit for bit, a refused one
    None; and shot_figures words the refusal as simulate does."""
    refused = scene_with(release={"time": 0.1})  # before lift-off
    scenes = [DESIGNS["paper"][0], FRICTION, refused, DESIGNS["dry"][0], DESIGNS["fixed"][0]]
    batch = designs_figures(scenes)
    assert batch[2] is None
    for scene, figures in zip(scenes, batch, strict=True):
        if figures is not None:
            alone = shot_figures(scene)
            assert figures.as_dict() == pytest.approx(alone.as_dict(), rel=0, nan_ok=True)
            assert figures.times == pytest.approx(alone.times, rel=0, nan_ok=True)
    with pytest.raises(TrebuchetInputError, match="comes before lift-off"):
        shot_figures(refused)


GRID = [  # varied designs of the friction engine, refused ones among them
    {"engine.M": 19100.0, "release.velocity_angle_deg": 40.0},
    {"engine.M": 12000.0, "release.time": 0.997},  # backward
    {"engine.M": 30.0, "release.velocity_angle_deg": 40.0},  # cannot lift the beam
    {"engine.M": 700.0, "release.velocity_angle_deg": 40.0},  # too slow to lift off
    {"engine.L4": -1.0},  # a scene value out of range
    {"friction.pivot_mu": 0.4, "start.theta_deg": -40.0},
    {"engine.counterweight": "fixed", "start.psi_deg": 130.0, "engine.L3": 0.5},
    {"release.velocity_angle_deg": 95.0},
    {"engine.L1": 7.5, "engine.m_b": 800.0},  # I and H follow
]


def test_the_sweep_rows_are_those_of_the_path_before(monkeypatch):
    """evaluate_designs (a scene without the dict, one C call for the chunk) gives the rows
    of the path before (Scene.from_dict, numba's peak search per design): statuses and
    reasons equal, figures to rounding."""
    items = list(enumerate(GRID))
    rows = evaluate_designs(FRICTION, items)
    with monkeypatch.context() as m:
        m.setattr(shot_summary, "designs_figures", lambda scenes, **kw: [None] * len(scenes))
        m.setattr(sweep_design, "designs_values", lambda scenes, **kw: [None] * len(scenes))
        m.setattr(sweep_scene, "with_numbers", _refuse)
        before = [evaluate_design(FRICTION, item) for item in items]
    assert [r["status"] for r in rows] == [r["status"] for r in before]
    assert {r["status"] for r in rows} >= {"ok", "backward", "refused"}
    for new, old in zip(rows, before, strict=True):
        assert new["error"] == old["error"]
        assert list(new) == list(old)
        for k in FIGURES:
            if math.isnan(old[k]):
                assert math.isnan(new[k]), k
            elif k == "energy_drift_rel":
                assert new[k] == pytest.approx(old[k], rel=1e-3, abs=1e-13)
            else:
                assert new[k] == pytest.approx(old[k], rel=1e-10, abs=1e-9), k


def _refuse(*args, **kwargs):
    raise KeyError("the dict's path")


BASES = {"paper": scene_with(), "friction": FRICTION, "fixed": scene_with(**FIXED),
         "sling": scene_with(**HANGING), "drag": scene_with(**DRAG), "dry": scene_with(**DRY),
         "own_I_and_H": scene_with(engine={"I": 9000.0, "H": 6.0}, start={"phi_deg": math.degrees(
             -math.pi + math.asin((6.0 + 6.48 * math.sin(math.radians(-50.0))) / 5.55))})}
PARAMS = [
    {}, {"engine.M": 20000.0, "release.velocity_angle_deg": 40.0}, {"release.time": 0.9},
    {"engine.L1": 7.0, "start.theta_deg": -40.0}, {"engine.m_b": 3000.0},
    {"start.theta": -0.7}, {"start.psi_deg": -80.0}, {"engine.I": 8000.0}, {"engine.H": 7.0},
    {"environment.g": 3.7}, {"engine.L_CM": 0.0}, {"flight.diameter": 0.3},
    {"friction.pivot_mu": 0.3, "friction.smoothing_rate": 0.01},
    # refused: each by one rule of the scene file
    {"engine.M": 100.0}, {"engine.L4": 0.5}, {"engine.L4": 1e-9}, {"start.theta_deg": 10.0},
    {"engine.H": 0.5}, {"engine.L_CM": 20.0}, {"engine.M": 1e16}, {"engine.m": -1.0},
    {"release.velocity_angle_deg": 95.0}, {"release.time": 0.0}, {"environment.g": 0.0},
    {"friction.pivot_mu": -0.3}, {"flight.diameter": -1.0}, {"engine.I": 1e-40},
    # not numbers only: the dict's path
    {"engine.counterweight": "fixed"}, {"flight.model": "drag", "flight.diameter": 0.3},
    {"start.projectile": "sling", "start.phi_deg": -90.0, "engine.H": 12.0},
]


@pytest.mark.parametrize("base", sorted(BASES))
def test_a_design_scene_without_the_dict_is_that_of_from_dict(base):
    """The same scene, field for field, or the same refusal in the same words."""
    scene = BASES[base]
    for params in PARAMS:
        try:
            fast = design_scene(scene, params, "design 3")
        except TrebuchetInputError as exc:
            fast = str(exc)
        try:
            slow = sweep_scene._from_dict(scene, params, "design 3")
        except TrebuchetInputError as exc:
            slow = str(exc)
        assert fast == slow, params
        if isinstance(fast, Scene):
            assert fast.source == "design 3"


def test_with_numbers_takes_numbers_only(horsdal):
    for numbers in ({"engine.counterweight": "fixed"}, {"friction.pivot_mu": 0.1},
                    {"flight.diameter": 0.3}, {"engine.L1_deg": 3.0},
                    {"release.time": 0.9, "release.velocity_angle_deg": 40.0}):
        with pytest.raises(KeyError):
            with_numbers(horsdal, numbers)
    with pytest.raises(KeyError):
        with_numbers(scene_with(**DRY), {"engine.M": 20000.0})
    with pytest.raises(TrebuchetInputError, match=r"\[engine\] M: = -5: must be a positive"):
        with_numbers(horsdal, {"engine.M": -5.0})
    moved = with_numbers(horsdal, {"release.velocity_angle_deg": 40.0, "engine.M": 2e4})
    assert moved.release.time is None and moved.engine.M == 2e4
    assert moved == Scene.from_dict({**horsdal.to_dict(), "release": {
        "velocity_angle_deg": 40.0}, "engine": {**horsdal.to_dict()["engine"], "M": 2e4}})


def test_a_base_the_file_would_refuse_goes_the_dicts_way(horsdal):
    """A scene built in code past the file's rules (H below the least a file may give) is
    refused in every design, as Scene.from_dict refuses it."""
    from dataclasses import replace

    odd = replace(horsdal, start=replace(horsdal.start, H=-1.0))
    with pytest.raises(TrebuchetInputError, match=r"\[engine\] H: = -1: must be a positive"):
        design_scene(odd, {"engine.M": 20000.0})
