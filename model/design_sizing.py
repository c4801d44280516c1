"""Sizing rules: a bearing's shaft sized from its own peak load, as a derived scene key.

The paper's summary asks for "short shafts with just sufficient diameters and strengths". A
scene read by ``trebuchet design`` or ``trebuchet sweep`` may carry::

    [sizing]
    pivot_shear_stress = 40e6   # Pa: friction.pivot_radius follows the design's peak |F_R|
    hinge_shear_stress = 40e6   # Pa: friction.hinge_radius follows its peak |F_H|

so that a heavier counterweight pays for the thicker shaft it needs in friction.

**The rule** (docs/design.md): a solid round shaft of radius ``r`` carried by two bearings,
one either side of the beam that loads it (the beam's shaft between the frame's two uprights;
the hinge pin through the beam's end between the counterweight's two hangers), is in double
shear: each of its two cross-sections between the load and a bearing carries half the load,
``V = F/2``. With the average shear stress ``τ = V / (π r²)`` held at the allowable ``τ``:

    r = √(F / (2 π τ)),   diameter d = √(2 F / (π τ)),

``F`` the peak load (N), ``τ`` in Pa, ``r`` in m. (The largest shear stress of a round section
under a transverse load is 4/3 of the average: to size by it, give ¾ of the allowable.)

**The fixed point**: friction turns with the radius and the peak load with friction, so the
radius is the fixed point of ``r ↦ √(F_peak(r) / (2 π τ))``, found by iterating from the
scene's own radius (friction moves the peak load by a few per cent at most, so each step
gains some seven digits; :data:`TOLERANCE` is met in two or three shots). The scene needs the
bearing's coefficient in its ``[friction]`` section: the radius matters to nothing else.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model.scene import Scene
from trebuchet.model.shot_summary import ShotFigures

__all__ = ["Sizing", "shaft_radius", "read_scene", "sized", "RULES", "TOLERANCE"]

#: Each rule: the ``[sizing]`` key, the ``[friction]`` key it sets, the figure it follows.
RULES = {"pivot_shear_stress": ("pivot_radius", "F_R_peak"),
         "hinge_shear_stress": ("hinge_radius", "F_H_peak")}
TOLERANCE = 1e-9  # relative change of a radius at which the fixed point is taken as found
_MAX_ROUNDS = 12


def shaft_radius(load: float, shear_stress: float) -> float:
    """Radius (m) of a solid round shaft in double shear whose average shear stress under the
    load ``load`` (N) is ``shear_stress`` (Pa): ``r = √(F / (2 π τ))`` (module doc)."""
    return math.sqrt(load / (2.0 * math.pi * shear_stress))


@dataclass(frozen=True)
class Sizing:
    """The allowable shear stresses (Pa) of the beam's shaft and the hinge pin; None: that
    radius is the scene's own."""

    pivot_shear_stress: float | None = None
    hinge_shear_stress: float | None = None

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = "<scene>") -> Sizing:
        """The ``[sizing]`` section of a scene file, each key checked."""
        if not isinstance(data, Mapping):
            raise TrebuchetInputError(f"{source}: [sizing]: must be a table of keys")
        unknown = sorted(set(data) - set(RULES))
        if unknown:
            raise TrebuchetInputError(f"{source}: [sizing] {unknown[0]}: unknown key (known "
                                      "keys: " + ", ".join(RULES) + ")")
        values = {}
        for key, value in data.items():
            if isinstance(value, bool) or not isinstance(value, int | float) or not (
                    math.isfinite(value) and value > 0):
                raise TrebuchetInputError(f"{source}: [sizing] {key} = {value!r}: must be a "
                                          "positive stress in Pa, e.g. 40e6")
            values[key] = float(value)
        return cls(**values)

    @property
    def rules(self) -> list[tuple[str, str, float]]:
        """``(friction key, figure, shear stress)`` of each rule given."""
        return [(*RULES[k], getattr(self, k)) for k in RULES if getattr(self, k) is not None]

    def __bool__(self) -> bool:
        return bool(self.rules)

    def check(self, scene: Scene) -> None:
        """Refuse rules for an engine without bearing friction: the radius they size matters
        to nothing else."""
        if scene.friction is None and self.rules:
            key = self.rules[0][0]
            raise TrebuchetInputError(
                f"{scene.source}: [sizing] {key.replace('radius', 'shear_stress')}: sizes "
                f"friction.{key}, which only friction uses; give the scene a [friction] "
                f"section with {key.replace('radius', 'mu')} and a first {key}")


def read_scene(path: str | Path) -> tuple[Scene, Sizing]:
    """A scene file and its ``[sizing]`` section (an empty :class:`Sizing` without one)."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return Scene.from_toml(path), Sizing()  # its reader says what is wrong
    sizing = Sizing.from_dict(data.pop("sizing", {}), str(path))
    return Scene.from_dict(data, source=str(path)), sizing


def _with_radii(scene: Scene, radii: Mapping[str, float]) -> Scene:
    data = scene.to_dict()
    data.setdefault("friction", {}).update(radii)
    return Scene.from_dict(data, source=scene.source)


def sized(scene: Scene, sizing: Sizing, figures_of: Callable[[Scene], ShotFigures]
          ) -> tuple[Scene, ShotFigures]:
    """The scene with each sized radius at its fixed point, and that scene's figures
    (``figures_of`` computes them). Raises TrebuchetInputError where there is no bearing
    friction to size for, or where the iteration does not settle."""
    if not sizing:
        return scene, figures_of(scene)
    sizing.check(scene)
    for _ in range(_MAX_ROUNDS):
        figures = figures_of(scene)
        data = scene.to_dict()["friction"]
        radii = {key: shaft_radius(getattr(figures, figure), tau)
                 for key, figure, tau in sizing.rules}
        if all(abs(r - data[k]) <= TOLERANCE * r for k, r in radii.items()):
            return scene, figures
        scene = _with_radii(scene, radii)
    raise TrebuchetInputError(f"{scene.source}: [sizing]: the shaft radii did not settle in "
                              f"{_MAX_ROUNDS} rounds (friction that strong changes the loads "
                              "more than the radius it sizes)")
