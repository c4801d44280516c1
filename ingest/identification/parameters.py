"""The scene keys a fit may free: their names, units, values, and the scene with new values.

A key is named as in a scene file and in ``trebuchet sweep``'s grid: ``"section.key"``
(``"engine.M"`` in kg, ``"friction.pivot_mu"``, dimensionless). Any numeric key that moves the
engine's angles may be freed: the engine's lengths, masses and moment of inertia, the pivot's
height, gravity, and the friction's coefficients, radii and smoothing rate. The start pose and
the release are always fitted (as nuisances: :mod:`.shot_model`); the projectile's flight after
release moves no angle of the engine.

Refused, each with the option that resolves it:

- every mass free at once (``m_b``, ``M``, ``m`` and the beam's ``I``): gravity and inertia
  both scale with mass, so a shot fixes only the ratios of the masses; one must come from the
  scene (the stone's, by default, since it is the one weighed most easily);
- a friction coefficient and its radius together: the couple is ``μ r |F|``, only their
  product moves the engine;
- a friction coefficient whose radius the scene does not give (the couple needs it).

Where the scene leaves ``I`` to its uniform-beam default, ``I`` follows a freed ``m_b``, ``L1``
or ``L2``; where it leaves ``H`` to its default (the spigot on the ground at the start), ``H``
follows the fitted start angle (:func:`scene_with`), as ``trebuchet sweep`` does.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace

from trebuchet.core.errors import Option, TrebuchetInputError
from trebuchet.model.scene import SCENE_KEYS, Friction, Scene, default_moment_of_inertia

__all__ = ["FreeKey", "UNITS", "MASS_KEYS", "default_free", "free_keys", "scene_value",
           "scene_with", "follows_default_I", "follows_default_H"]

#: Unit of each key that may be freed (the scene file's units).
UNITS: dict[str, str] = {
    "engine.L1": "m", "engine.L2": "m", "engine.L_CM": "m", "engine.L3": "m", "engine.L4": "m",
    "engine.m_b": "kg", "engine.M": "kg", "engine.m": "kg", "engine.I": "kg m²",
    "engine.H": "m", "environment.g": "m/s²",
    "friction.pivot_mu": "1", "friction.pivot_radius": "m", "friction.hinge_mu": "1",
    "friction.hinge_radius": "m", "friction.smoothing_rate": "rad/s",
}

#: The masses that gravity and inertia scale together (with ``engine.I``).
MASS_KEYS = ("engine.m_b", "engine.M", "engine.m", "engine.I")

#: Keys fitted anyway (nuisances) or that move no angle of the engine: freeing them is refused
#: with the reason.
_NOT_FREE = {
    "start": "the start pose is always fitted (a nuisance of every fit)",
    "release": "the release is always fitted where the log shows it, else the scene's rule "
               "stands",
    "flight": "the projectile's flight after release moves no angle of the engine",
}


@dataclass(frozen=True)
class FreeKey:
    """A freed scene key: ``name`` (``"engine.M"``), ``unit``, the scene's value and the
    ``scale`` of the fitted variable (the fit varies ``value / scale``)."""

    name: str
    unit: str
    scene_value: float
    scale: float

    @property
    def short(self) -> str:
        """The key without its section: ``M``, ``pivot_mu``."""
        return self.name.partition(".")[2]

    @property
    def lower(self) -> float:
        """Least value the fit may try: 0 for coefficients, a thousandth of the scene's
        value for lengths and masses (a sign change is no engine)."""
        if self.name.startswith("friction.") and self.name.endswith("_mu"):
            return 0.0
        return 1e-3 * abs(self.scene_value) if self.scene_value else 0.0


def scene_value(scene: Scene, key: str) -> float:
    """The value of a freeable ``key`` in ``scene`` (the file's units: m, kg, kg m², 1)."""
    section, _, name = key.partition(".")
    if section == "engine":
        return float(scene.start.H if name == "H" else getattr(scene.engine, name))
    if section == "environment":
        return float(scene.g)
    if section == "friction":
        return float(getattr(scene.friction or Friction(), name))
    raise KeyError(key)


def follows_default_I(scene: Scene) -> bool:
    """True where the scene's ``I`` is the uniform beam's (it then follows ``m_b``, ``L1``,
    ``L2``)."""
    e = scene.engine
    return math.isclose(e.I, default_moment_of_inertia(e.m_b, e.L1, e.L2), rel_tol=1e-12)


def follows_default_H(scene: Scene) -> bool:
    """True where the scene's ``H`` puts the spigot on the ground at its start (it then
    follows the start angle)."""
    e, s = scene.engine, scene.start
    return math.isclose(s.H, -e.L1 * math.sin(s.theta), rel_tol=1e-12, abs_tol=1e-12 * e.L1)


def default_free(scene: Scene) -> tuple[str, ...]:
    """``engine.M``, ``engine.I`` and, where the scene gives their radii, the friction
    coefficients ``friction.pivot_mu`` and ``friction.hinge_mu``. A dry fire frees ``M`` but
    not ``I``: without a stone only the beam's weight sets the masses' scale, and on the
    backyard engine ``M`` and ``I`` then correlated at 0.9999 (refused)."""
    keys = ["engine.M"] if scene.projectile == "none" else ["engine.M", "engine.I"]
    fr = scene.friction
    if fr is not None:
        keys += [f"friction.{j}_mu" for j in ("pivot", "hinge") if getattr(fr, f"{j}_radius") > 0]
    return tuple(keys)


def free_keys(scene: Scene, free: Iterable[str] | None) -> tuple[FreeKey, ...]:
    """The freed keys (default :func:`default_free`) checked against the scene (module doc)."""
    names = default_free(scene) if free is None else tuple(dict.fromkeys(str(k) for k in free))
    for key in names:
        _check_key(scene, key)
    _check_masses(scene, names)
    for joint in ("pivot", "hinge"):
        if f"friction.{joint}_mu" in names and f"friction.{joint}_radius" in names:
            raise TrebuchetInputError(
                f"free keys friction.{joint}_mu and friction.{joint}_radius: the {joint}'s "
                "couple is mu x radius x load, so the shot fixes only their product; free one "
                f"(drop {Option('free', f'friction.{joint}_radius')})")
    out = []
    for key in names:
        value = scene_value(scene, key)
        scale = abs(value) if value else _typical(scene, key)
        out.append(FreeKey(key, UNITS[key], value, scale))
    return tuple(out)


def _typical(scene: Scene, key: str) -> float:
    """Scale of a key whose scene value is zero: 0.1 for a coefficient, a hundredth of L2 for
    a radius, 1 otherwise."""
    if key.endswith("_mu"):
        return 0.1
    if key.endswith("_radius"):
        return 0.01 * scene.engine.L2
    return 1.0


def _check_key(scene: Scene, key: str) -> None:
    section, dot, name = key.partition(".")
    if not dot or section not in SCENE_KEYS or name not in SCENE_KEYS[section]:
        known = ", ".join(sorted(UNITS))
        raise TrebuchetInputError(f"free key {key!r}: not a scene key (keys a fit may free: "
                                  f"{known})")
    if section in _NOT_FREE:
        raise TrebuchetInputError(f"free key {key!r}: {_NOT_FREE[section]}")
    if key not in UNITS:
        raise TrebuchetInputError(f"free key {key!r}: not a number a fit can vary (keys a fit "
                                  f"may free: {', '.join(sorted(UNITS))})")
    if key in ("engine.m", "engine.L4") and scene.projectile == "none":
        raise TrebuchetInputError(f"free key {key!r}: a dry fire has no projectile or sling")
    if section == "friction":
        joint = name.partition("_")[0]
        fr = scene.friction
        if name.endswith("_mu") and (fr is None or getattr(fr, f"{joint}_radius") <= 0):
            raise TrebuchetInputError(
                f"free key {key!r}: the scene gives no friction.{joint}_radius (the {joint}'s "
                "couple is mu x radius x load); add it to the scene's [friction] section")
        if name.endswith("_radius") and (fr is None or getattr(fr, f"{joint}_mu") <= 0):
            raise TrebuchetInputError(
                f"free key {key!r}: the scene gives no friction.{joint}_mu to go with it; add "
                "it to the scene's [friction] section")


def _check_masses(scene: Scene, names: Sequence[str]) -> None:
    """Refuse a free set in which every mass of the engine is free (module doc)."""
    masses = [k for k in MASS_KEYS if not (k == "engine.m" and scene.engine.m == 0.0)]
    free = set(names)
    if "engine.m_b" in free and follows_default_I(scene):
        free.add("engine.I")  # I follows m_b
    if all(k in free for k in masses):
        fixed = "engine.m" if "engine.m" in masses else "engine.m_b"
        raise TrebuchetInputError(
            "free keys " + ", ".join(k for k in names if k in MASS_KEYS) + ": gravity and "
            "inertia both scale with mass, so a shot fixes only the ratios of the masses; keep "
            f"one from the scene (drop {Option('free', fixed)}: the stone's mass is the one "
            "weighed most easily)")


def scene_with(scene: Scene, values: Mapping[str, float]) -> Scene:
    """``scene`` with the freed keys at ``values`` (the file's units), ``I`` following a freed
    ``m_b``, ``L1`` or ``L2`` where the scene's is the uniform beam's. Raises
    TrebuchetInputError where the values are no engine (the Engine's own checks)."""
    e, fr, g, start = scene.engine, scene.friction, scene.g, scene.start
    engine: dict[str, float] = {}
    friction: dict[str, float] = {}
    for key, value in values.items():
        section, _, name = key.partition(".")
        if section == "engine" and name == "H":
            start = replace(start, H=float(value))
        elif section == "engine":
            engine[name] = float(value)
        elif section == "environment":
            g = float(value)
        else:
            friction[name] = float(value)
    if "I" not in engine and any(k in engine for k in ("m_b", "L1", "L2")) \
            and follows_default_I(scene):
        new = {k: engine.get(k, getattr(e, k)) for k in ("m_b", "L1", "L2")}
        engine["I"] = default_moment_of_inertia(new["m_b"], new["L1"], new["L2"])
    if friction:
        engine["friction"] = replace(fr or Friction(), **friction)
    if engine:
        e = replace(e, **engine)
    return replace(scene, engine=e, g=g, start=start)
