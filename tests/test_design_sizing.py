"""Sizing rules (model/design_sizing.py): a shaft in double shear sized from its own peak
load, the radius at the fixed point of friction and load, in sweeps and in the design."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import sympy as sp

from trebuchet import cli
from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model.design import design
from trebuchet.model.design_output import scene_toml
from trebuchet.model.design_search import SearchOptions
from trebuchet.model.design_sizing import Sizing, read_scene, shaft_radius, sized
from trebuchet.model.scene import Scene
from trebuchet.model.shot_summary import shot_figures
from trebuchet.model.sweep import SimulationOptions, sweep

FRICTION = Path(__file__).resolve().parents[1] / "data_samples" / "horsdal_friction.toml"
TAU = 40e6


@pytest.fixture(scope="module")
def base() -> Scene:
    return Scene.from_toml(FRICTION).with_release(velocity_angle=math.radians(40.0))


def test_radius_of_a_shaft_in_double_shear():
    """τ = (F/2) / (π r²) on each of the two shear planes, solved for r with sympy."""
    F, tau, r = sp.symbols("F tau r", positive=True)
    (root,) = sp.solve(sp.Eq(tau, (F / 2) / (sp.pi * r**2)), r)
    for load, stress in ((4.69e5, 40e6), (1.0, 1.0), (2.5e3, 1.2e8)):
        assert shaft_radius(load, stress) == pytest.approx(
            float(root.subs({F: load, tau: stress})), rel=1e-15)
    assert 2 * shaft_radius(4.69e5, 40e6) == pytest.approx(math.sqrt(2 * 4.69e5 / (math.pi
                                                                                  * 40e6)))


def test_radius_at_its_fixed_point(base):
    calls = []

    def figures(scene):
        calls.append(scene.friction.pivot_radius)
        return shot_figures(scene)

    scene, figs = sized(base, Sizing(pivot_shear_stress=TAU), figures)
    r = scene.friction.pivot_radius
    assert r == pytest.approx(shaft_radius(figs.F_R_peak, TAU), rel=1e-9)
    assert shot_figures(scene).F_R_peak == figs.F_R_peak
    assert abs(r - base.friction.pivot_radius) > 0.01 and len(calls) <= 5
    assert scene.friction.hinge_radius == base.friction.hinge_radius  # no rule for it


def test_sizing_needs_friction(horsdal):
    with pytest.raises(TrebuchetInputError, match=r"\[sizing\] pivot_shear_stress.*\[friction\]"):
        sized(horsdal, Sizing(pivot_shear_stress=TAU), shot_figures)


def test_read_scene_with_sizing(tmp_path, base):
    path = tmp_path / "s.toml"
    path.write_text(scene_toml(base) + "\n[sizing]\npivot_shear_stress = 40e6\n")
    scene, sizing = read_scene(path)
    assert scene == base and sizing == Sizing(pivot_shear_stress=40e6)
    assert read_scene(FRICTION)[1] == Sizing() and not Sizing()
    for bad, match in (("pivot_stress = 1e6", "unknown key"), ("pivot_shear_stress = -1",
                                                                "positive stress"),
                       ("pivot_shear_stress = true", "positive stress")):
        path.write_text(scene_toml(base) + f"\n[sizing]\n{bad}\n")
        with pytest.raises(TrebuchetInputError, match=match):
            read_scene(path)


def test_sweep_sizes_each_design(base):
    """A heavier counterweight loads its shaft more, gets a thicker one and loses more."""
    rule = SimulationOptions(sizing=Sizing(pivot_shear_stress=TAU))
    table = sweep(base, {"engine.M": [15000.0, 25000.0]}, workers=1, progress=False,
                  options=rule)
    assert list(table.columns[:3]) == ["design", "engine.M", "friction.pivot_radius"]
    radius = table["friction.pivot_radius"].to_numpy()
    assert radius == pytest.approx([shaft_radius(f, TAU) for f in table["F_R_peak"]],
                                   rel=1e-8)
    assert radius[1] > radius[0] and table["E_loss_release"].iloc[1] > table[
        "E_loss_release"].iloc[0]
    with pytest.raises(TrebuchetInputError, match="friction.pivot_radius"):
        sweep(base, {"friction.pivot_radius": [0.1]}, workers=1, progress=False, options=rule)


def test_design_with_sizing(base, tmp_path):
    path = tmp_path / "start.toml"
    path.write_text(scene_toml(base) + "\n[sizing]\npivot_shear_stress = 40e6\n")
    res = design(path, {"engine.M": (15000.0, 25000.0)}, maximize="range",
                 limits=["F_R_peak <= 500000"], seed=1, workers=1,
                 search_options=SearchOptions(popsize=5, generations=5))
    r = res.scene.friction.pivot_radius
    assert r == pytest.approx(shaft_radius(res.figures["F_R_peak"], TAU), rel=1e-8)
    assert res.sizing == Sizing(pivot_shear_stress=TAU) and all(c.met for c in res.limits)
    best = tmp_path / "best.toml"
    assert cli.main(["design", str(path), "-o", str(best), "--vary", "engine.M=15000:25000",
                     "--maximize", "range", "--limit", "F_R_peak<=500000", "--seed", "1",
                     "--workers", "1", "--popsize", "5", "--generations", "5", "--quiet"]) == 0
    text = best.read_text()
    assert "# Sized: friction.pivot_radius" in text
    assert Scene.from_toml(best).friction.pivot_radius == pytest.approx(
        res.scene.friction.pivot_radius, rel=1e-9)
    with pytest.raises(TrebuchetInputError, match="--vary friction.pivot_radius"):
        design(path, {"friction.pivot_radius": (0.05, 0.2)}, maximize="range", workers=1)
