"""Scenes: which engine is fired, from which pose, and when the projectile is released.

A scene is the TOML file of docs/interface.md loaded into frozen dataclasses. Every
value is validated on load; a bad value raises :class:`TrebuchetInputError`
whose message names the file and the key (``horsdal_large.toml: [engine] L3 =
-2.45: ...``). Lengths in m, masses in kg, angles in rad inside the code
(degrees in the file where the key says ``_deg``), times in s.

The engine and its symbols are those of Table 1 of Horsdal, "The swinging
counterweight trebuchet: on internal forces" (called *the paper* below).
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.core.user_files import read_user_file
from trebuchet.model.engine import (
    DEFAULT_SMOOTHING_RATE,
    Engine,
    Flight,
    Friction,
    Release,
    Start,
    default_moment_of_inertia,
    spigot_on_ground,
)
from trebuchet.model.scene_rules import (
    SCENE_KEYS,
    SECTIONS,
    Reader,
    check_lift,
    check_release,
    check_start_pose,
    check_theta,
)

__all__ = ["Engine", "Friction", "Start", "Release", "Flight", "Scene", "SCENE_KEYS", "as_scene",
           "default_moment_of_inertia", "DEFAULT_SMOOTHING_RATE", "with_numbers"]

@dataclass(frozen=True)
class Scene:
    """An engine, its start pose, its release rule, gravity ``g`` (m/s²), where the projectile
    starts (``projectile``: "trough" as in the paper, "sling" hanging at rest in the sling, or
    "none" for a dry fire without projectile or sling) and how it flies after release."""

    engine: Engine
    start: Start
    release: Release
    g: float = 9.81
    projectile: str = "trough"
    flight: Flight = field(default_factory=Flight)
    source: str = field(default="<scene>", compare=False)

    @property
    def friction(self) -> Friction | None:
        """The bearings' friction (the engine's; None for a frictionless engine)."""
        return self.engine.friction

    @property
    def delta_U(self) -> float:
        """Available mechanical energy ``ΔU = (M L2 − m_b L_CM) g (1 − sin θ_i)``, J (the paper's
        Section 4): the beam's fall from its start to upright with the counterweight hanging."""
        return self.engine.first_moment * self.g * (1.0 - math.sin(self.start.theta))

    @property
    def phases(self) -> tuple[int, ...]:
        """The phases this scene goes through: (1, 2, 3) from the trough, (2, 3) from the
        sling, (3,) for a dry fire."""
        return {"trough": (1, 2, 3), "sling": (2, 3), "none": (3,)}[self.projectile]

    @classmethod
    def from_toml(cls, path: str | Path) -> Scene:
        """Load and validate a scene file (docs/interface.md, "Scene file")."""
        path = Path(path)
        try:
            raw = read_user_file(path, "scene file", MAX_SCENE_BYTES)
        except TrebuchetInputError as exc:
            if exc.message == "no such file":
                raise TrebuchetInputError(f"{path}: scene file not found") from None
            raise TrebuchetInputError(f"{path}: {exc.message}") from None
        try:
            text = raw.decode("utf-8-sig")  # a byte-order mark (Windows' editors) is no TOML
        except UnicodeDecodeError as exc:
            raise TrebuchetInputError(f"{path}: cannot read scene file: not UTF-8 text (byte "
                                      f"{exc.start}: a scene file is TOML in UTF-8)") from None
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise TrebuchetInputError(f"{path}: not valid TOML: {exc}") from None
        except ValueError:  # an integer of more than Python's 4300 digits
            long = re.search(r"[0-9_]{4000,}", text)
            where = f"line {text.count(chr(10), 0, long.start()) + 1}: " if long else ""
            raise TrebuchetInputError(f"{path}: not valid TOML: {where}a number of more than "
                                      "4300 digits") from None
        except RecursionError:
            raise TrebuchetInputError(f"{path}: not valid TOML for a scene: arrays or tables "
                                      "nested within each other more deeply than Python "
                                      "reads them (a scene's values are numbers)") from None
        return cls.from_dict(data, source=str(path))

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "<scene>") -> Scene:
        """Build a scene from the nested dict of a scene file, validating every key."""
        return _parse_scene(data, source)

    def with_release(self, time: float | None = None,
                     velocity_angle: float | None = None) -> Scene:
        """The same scene with another release rule."""
        return replace(self, release=Release(time=time, velocity_angle=velocity_angle))

    def to_dict(self) -> dict[str, Any]:
        """The scene as the nested dict of a scene file (degrees where the key says so)."""
        e, s, r = self.engine, self.start, self.release
        release: dict[str, float] = {}
        if r.time is not None:
            release["time"] = r.time
        if r.velocity_angle is not None:
            release["velocity_angle_deg"] = math.degrees(r.velocity_angle)
        engine: dict[str, Any] = {"L1": e.L1, "L2": e.L2, "L_CM": e.L_CM, "L3": e.L3,
                                  "L4": e.L4, "m_b": e.m_b, "M": e.M, "m": e.m, "I": e.I,
                                  "H": s.H}
        if e.fixed_counterweight:
            engine["counterweight"] = "fixed"
        start: dict[str, Any] = {"theta_deg": math.degrees(s.theta),
                                 "psi_deg": math.degrees(s.psi), "phi_deg": math.degrees(s.phi)}
        if self.projectile != "trough":
            start["projectile"] = self.projectile
        data: dict[str, Any] = {"engine": engine, "start": start, "release": release,
                                "environment": {"g": self.g}}
        if self.projectile == "none":
            del data["release"], engine["m"], engine["L4"]
            del start["phi_deg"]
        fr = e.friction
        if fr is not None:
            data["friction"] = {"pivot_mu": fr.pivot_mu, "pivot_radius": fr.pivot_radius,
                                "hinge_mu": fr.hinge_mu, "hinge_radius": fr.hinge_radius,
                                "smoothing_rate": fr.smoothing_rate}
        f = self.flight
        if f.model == "drag":
            data["flight"] = {"model": "drag", "diameter": f.diameter,
                              "drag_coefficient": f.drag_coefficient,
                              "air_density": f.air_density}
        return data


def as_scene(scene: Scene | str | Path, what: str = "trebuchet") -> Scene:
    """A :class:`Scene` as given, or loaded from a scene file's path; ``what`` names the caller
    in the error for anything else."""
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, str | Path):
        return Scene.from_toml(scene)
    raise TrebuchetInputError(f"{what}: expected a Scene or a scene file, got "
                              f"{type(scene).__name__}")


def with_numbers(scene: Scene, numbers: Mapping[str, float | None], source: str | None = None,
                 phi_of: Callable[[float, float, float, float], float | None] | None = None
                 ) -> Scene:
    """``Scene.from_dict`` of the scene's dict (:meth:`Scene.to_dict`) with the file's
    ``numbers`` ("section.key", the file's units) put in, without the dict (a sweep's designs):
    ``engine.I`` or ``engine.H`` None is left out (the file's default); ``phi_of(theta, L1, L4,
    H)`` (rad, m) gives ``phi`` (rad, None: the scene's); a release key replaces the rule. The
    numbers given pass their keys' rules, the scene the rules joining keys (``scene_rules``);
    the scene's own are taken as they are (``from_dict`` has read them). Raises
    TrebuchetInputError where a rule refuses (``from_dict`` words it as the file does),
    KeyError for what it does not take: a word, a dry fire, a section the scene has not."""
    if scene.projectile == "none":
        raise KeyError("with_numbers: a dry fire")
    read = Reader({}, source or scene.source)
    v = _numbers_of(scene).copy()
    releases = 0
    for key, value in numbers.items():
        plain = key.removesuffix("_deg")
        if value is None and key in ("engine.I", "engine.H"):
            v[key] = None
            continue
        if plain not in v or not (plain == key or plain in _ANGLES):
            raise KeyError(f"with_numbers: {key}")
        section, _, name = key.partition(".")
        if section == "release":
            releases += 1
            v["release.time"] = v["release.velocity_angle"] = None
        if plain in _ANGLES:
            number = read.number(section, name, {name: value})
            v[plain] = math.radians(number) if plain != key else number
        else:
            v[key] = read.value(section, name, {name: value})
    if releases > 1:
        raise KeyError("with_numbers: two release rules")
    return _numbers_scene(scene, v, read, phi_of)


def _numbers_of(scene: Scene) -> dict[str, Any]:
    """The scene's numbers as its dict gives them back ("section.key": SI, angles in rad read
    back from degrees), friction's and drag's where it has them. The last scene asked about is
    remembered (a sweep asks about its base for each design)."""
    global _last_numbers
    last = _last_numbers  # one tuple, read and replaced whole (threads)
    if last[0] is not scene:
        e, st, rel, fr, fl = scene.engine, scene.start, scene.release, scene.friction, scene.flight
        theta, psi, phi, angle = (None if a is None else math.radians(math.degrees(a))
                                  for a in (st.theta, st.psi, st.phi, rel.velocity_angle))
        v = {"engine.L1": e.L1, "engine.L2": e.L2, "engine.L_CM": e.L_CM, "engine.L3": e.L3,
             "engine.L4": e.L4, "engine.m_b": e.m_b, "engine.M": e.M, "engine.m": e.m,
             "engine.I": e.I, "engine.H": st.H, "start.theta": theta, "start.psi": psi,
             "start.phi": phi, "release.time": rel.time, "release.velocity_angle": angle,
             "environment.g": scene.g}
        for section, obj in (("friction", fr), ("flight", fl if fl.model == "drag" else None)):
            if obj is not None:
                v.update((f"{section}.{k}", getattr(obj, k))
                         for k in SECTIONS[section] - {"model"})
        last = _last_numbers = (scene, v)
    return last[1]


_last_numbers: tuple[Scene | None, dict[str, Any]] = (None, {})


def _numbers_scene(scene: Scene, v: dict[str, Any], read: Reader,
                   phi_of: Callable[[float, float, float, float], float | None] | None
                   ) -> Scene:
    """:func:`with_numbers`' scene from its numbers ``v`` ("section.key": SI, rad), under the
    rules that join keys, as :func:`_parse_scene` checks them."""
    L1, L2, L_CM, L4, m_b, M = (v[k] for k in _LENGTHS_MASSES)
    theta, psi = v["start.theta"], v["start.psi"]
    check_lift(read, M, L2, m_b, L_CM)
    check_theta(read, theta, {})
    I = v["engine.I"] if v["engine.I"] is not None else default_moment_of_inertia(m_b, L1, L2)
    H = v["engine.H"] if v["engine.H"] is not None else spigot_on_ground(L1, theta)
    phi = None if phi_of is None else phi_of(theta, L1, L4, H)
    phi = v["start.phi"] if phi is None else math.radians(math.degrees(phi))
    fr = scene.friction and Friction(**{k: v[f"friction.{k}"] for k in SECTIONS["friction"]})
    engine = Engine(L1=L1, L2=L2, L_CM=L_CM, L3=v["engine.L3"], L4=L4, m_b=m_b, M=M,
                    m=v["engine.m"], I=I, friction=fr, counterweight_offset=(
                        psi - theta if scene.engine.fixed_counterweight else None))
    check_start_pose(read, engine, theta, psi, phi, H, scene.projectile)
    release = Release(v["release.time"], v["release.velocity_angle"])
    check_release(read, release, {})
    flight = scene.flight if scene.flight.model != "drag" else Flight("drag", **{
        k: v[f"flight.{k}"] for k in ("diameter", "drag_coefficient", "air_density")})
    return Scene(engine=engine, start=Start(theta=theta, psi=psi, phi=phi, H=H), release=release,
                 g=v["environment.g"], projectile=scene.projectile, flight=flight,
                 source=read.source)


_ANGLES = frozenset({"start.theta", "start.psi", "start.phi", "release.velocity_angle"})
_LENGTHS_MASSES = tuple(f"engine.{k}" for k in ("L1", "L2", "L_CM", "L4", "m_b", "M"))


# --------------------------------------------------------------------------- parsing

_REQUIRED_ENGINE = ("L1", "L2", "L_CM", "L3", "M", "m_b")
#: Bytes of a scene file (one is a few hundred).
MAX_SCENE_BYTES = 1 << 20


def _parse_scene(data: dict[str, Any], source: str) -> Scene:
    r = Reader(data, source)
    unknown = sorted(set(data) - set(SECTIONS))
    if unknown:
        raise TrebuchetInputError(f"{source}: [{unknown[0]}]: unknown section (known sections: "
                                  + ", ".join(sorted(SECTIONS)) + ")")
    eng = r.section("engine")
    st = r.section("start")
    projectile = r.choice("start", "projectile", st, ("trough", "sling", "none"))
    required = _REQUIRED_ENGINE + (() if projectile == "none" else ("L4", "m"))
    for key in required:
        if key not in eng:
            raise r.fail("engine", key, "missing key")
    L1, L2, L3, m_b, M = (r.value("engine", k, eng) for k in ("L1", "L2", "L3", "m_b", "M"))
    if projectile == "none":
        for key in ("L4", "m"):
            if key in eng and r.number("engine", key, eng) < 0.0:
                raise r.fail("engine", key, "must not be negative")
        L4 = r.number("engine", "L4", eng) if "L4" in eng else 0.0
        m = 0.0
    else:
        L4, m = r.value("engine", "L4", eng), r.value("engine", "m", eng)
    L_CM = r.value("engine", "L_CM", eng)
    if not -L2 <= L_CM <= L1:
        raise r.fail("engine", "L_CM", f"= {L_CM:g} m puts the centre of mass off the beam "
                     f"(it must lie between -L2 = {-L2:g} m and L1 = {L1:g} m)")
    I = r.value("engine", "I", eng) if "I" in eng else default_moment_of_inertia(m_b, L1, L2)
    check_lift(r, M, L2, m_b, L_CM)
    mount = r.choice("engine", "counterweight", eng, ("hinged", "fixed"))

    angles: dict[str, float] = {}
    for name in ("theta", "psi", "phi"):
        value = r.angle("start", name, st)
        if value is None:
            if name == "phi" and projectile == "none":
                value = -math.pi / 2
            else:
                raise r.fail("start", f"{name}_deg", "missing key")
        angles[name] = value
    theta, psi, phi = angles["theta"], angles["psi"], angles["phi"]
    check_theta(r, theta, st)
    H = r.value("engine", "H", eng) if "H" in eng else spigot_on_ground(L1, theta)
    offset = psi - theta if mount == "fixed" else None
    friction = _parse_friction(r)
    try:
        engine = Engine(L1=L1, L2=L2, L_CM=L_CM, L3=L3, L4=L4, m_b=m_b, M=M, m=m, I=I,
                        counterweight_offset=offset, friction=friction)
    except TrebuchetInputError as exc:  # "Engine: I = inf: ...": the file's key, by name
        raise _engine_error(r, eng, exc) from None
    check_start_pose(r, engine, theta, psi, phi, H, projectile, st, "H" in eng)
    start = Start(theta=theta, psi=psi, phi=phi, H=H)

    if projectile == "none":
        if "release" in data:
            raise r.fail("release", None, "a dry fire (projectile = \"none\") has no release")
        release = Release()
    else:
        rel = r.section("release")
        t_rel = r.value("release", "time", rel) if "time" in rel else None
        angle_rel = r.angle("release", "velocity_angle", rel)
        if (t_rel is None) == (angle_rel is None):
            raise r.fail("release", None, "give exactly one of time, velocity_angle_deg")
        release = Release(t_rel, angle_rel)
        check_release(r, release, rel)

    env = r.section("environment", required=False)
    g = r.value("environment", "g", env) if "g" in env else 9.81
    return Scene(engine=engine, start=start, release=release, g=g, projectile=projectile,
                 flight=_parse_flight(r), source=source)


def _engine_error(r: Reader, eng: dict[str, Any], exc: TrebuchetInputError
                  ) -> TrebuchetInputError:
    """An :class:`Engine`'s refusal in the words of the scene file: the key as written, or
    for a moment of inertia not given, the keys it is computed from."""
    m = re.match(r"Engine: (\w+) = ([^:]*): (.*)", str(exc))
    if m is None:
        return r.fail("engine", None, str(exc))
    name, value, problem = m.groups()
    if name == "I" and "I" not in eng:
        return r.fail("engine", "I", f"(not given: m_b (L1² − L1 L2 + L2²) / 3 of m_b, L1 and "
                      f"L2) = {value}: {problem}")
    return r.fail("engine", name, f"= {value}: {problem}")


def _parse_friction(r: Reader) -> Friction | None:
    """The ``[friction]`` section: None where the scene has none (the paper's engine). A
    coefficient needs its radius and a radius its coefficient; each is zero or positive."""
    fr = r.section("friction", required=False)
    if not fr:
        return None
    values: dict[str, float] = {}
    for key in ("pivot_mu", "pivot_radius", "hinge_mu", "hinge_radius"):
        if key in fr:
            values[key] = r.value("friction", key, fr)
    for joint in ("pivot", "hinge"):
        mu, radius = f"{joint}_mu", f"{joint}_radius"
        if (mu in values) != (radius in values):
            given, missing = (mu, radius) if mu in values else (radius, mu)
            raise r.fail("friction", missing, f"missing key ({given} needs it: the {joint}'s "
                         "friction couple is mu x radius x load)")
    if "smoothing_rate" in fr:
        values["smoothing_rate"] = r.value("friction", "smoothing_rate", fr)
    return Friction(**values)


def _parse_flight(r: Reader) -> Flight:
    fl = r.section("flight", required=False)
    model = r.choice("flight", "model", fl, ("vacuum", "drag"))
    if model == "vacuum":
        extra = sorted(set(fl) - {"model"})
        if extra:
            raise r.fail("flight", extra[0], "only used with model = \"drag\"")
        return Flight()
    if "diameter" not in fl:
        raise r.fail("flight", "diameter", "missing key (model = \"drag\" needs the "
                     "projectile's diameter in m)")
    return Flight(
        model="drag",
        diameter=r.value("flight", "diameter", fl),
        drag_coefficient=(r.value("flight", "drag_coefficient", fl)
                          if "drag_coefficient" in fl else 0.47),
        air_density=(r.value("flight", "air_density", fl) if "air_density" in fl else 1.225),
    )
