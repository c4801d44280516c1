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
)

__all__ = ["Engine", "Friction", "Start", "Release", "Flight", "Scene", "SCENE_KEYS", "as_scene",
           "default_moment_of_inertia", "DEFAULT_SMOOTHING_RATE"]

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


# --------------------------------------------------------------------------- parsing

_SECTIONS = {
    "engine": {"L1", "L2", "L_CM", "L3", "L4", "m_b", "M", "m", "I", "H", "counterweight"},
    "start": {"theta_deg", "psi_deg", "phi_deg", "theta", "psi", "phi", "projectile"},
    "release": {"time", "velocity_angle_deg", "velocity_angle"},
    "environment": {"g"},
    "flight": {"model", "diameter", "drag_coefficient", "air_density"},
    "friction": {"pivot_mu", "pivot_radius", "hinge_mu", "hinge_radius", "smoothing_rate"},
}
_REQUIRED_ENGINE = ("L1", "L2", "L_CM", "L3", "M", "m_b")

#: Every key a scene file may hold, by section (the parser's own list).
SCENE_KEYS: dict[str, frozenset[str]] = {k: frozenset(v) for k, v in _SECTIONS.items()}


#: Largest magnitude of a scene's number (m, kg, s, m/s², degrees or rad): far beyond any
#: engine's, short of the numbers whose products in the equations of motion overflow.
MAX_MAGNITUDE = 1e15
#: Least length (m) of an engine: 1 µm (a shorter sling stalls the integrator).
MIN_LENGTH = 1e-6
#: Least value of any other positive quantity (kg, s, m/s², kg/m³): far below any engine's,
#: above the numbers whose reciprocal overflows.
MIN_POSITIVE = 1e-30
#: Bytes of a scene file (one is a few hundred).
MAX_SCENE_BYTES = 1 << 20


class _Reader:
    """Reads numbers from one scene dict and names file, section and key in every error."""

    def __init__(self, data: dict[str, Any], source: str) -> None:
        self.data = data
        self.source = source

    def fail(self, section: str, key: str | None, problem: str) -> TrebuchetInputError:
        where = f"[{section}] {key}" if key else f"[{section}]"
        return TrebuchetInputError(f"{self.source}: {where}: {problem}")

    def section(self, name: str, required: bool = True) -> dict[str, Any]:
        sec = self.data.get(name)
        if sec is None:
            if required:
                raise self.fail(name, None, "missing section")
            return {}
        if not isinstance(sec, dict):
            raise self.fail(name, None, "must be a table of keys")
        unknown = sorted(set(sec) - _SECTIONS[name])
        if unknown:
            raise self.fail(name, unknown[0], "unknown key (known keys: "
                            + ", ".join(sorted(_SECTIONS[name])) + ")")
        return sec

    @staticmethod
    def shown(value: Any) -> str:
        """``value`` for a message, short whatever it is (a nested array, a huge integer)."""
        if isinstance(value, list):
            return f"an array of {len(value)}"
        if isinstance(value, dict):
            return f"a table of {len(value)} keys"
        if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 64:
            return f"an integer of about {int(value.bit_length() * math.log10(2)) + 1} digits"
        text = repr(value)
        return text if len(text) <= 40 else text[:37] + "..."

    def number(self, section: str, key: str, sec: dict[str, Any], unit: str = "") -> float:
        """A finite number within ±:data:`MAX_MAGNITUDE` (in the key's unit: SI or degrees):
        beyond it no engine's value lies, and the equations of motion overflow. ``unit`` (as
        ``positive`` words it: "mass in kg") is named in the message."""
        value = sec[key]
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(section, key, f"must be a number, got {self.shown(value)}")
        try:
            number = float(value)
        except OverflowError:
            number = math.inf
        if isinstance(value, float) and not math.isfinite(number):
            raise self.fail(section, key, f"must be finite, got {value}")
        if not abs(number) <= MAX_MAGNITUDE:
            shown = self.shown(value) if isinstance(value, int) else f"{number:.4g}"
            symbol = f" {unit.rsplit(' in ', 1)[-1]}" if " in " in unit and not isinstance(
                value, int) else ""
            raise self.fail(section, key, f"= {shown}{symbol}: beyond {MAX_MAGNITUDE:.0e}, "
                            "which no engine's length, mass, angle or time reaches (the "
                            "equations of motion overflow)")
        return number

    def positive(self, section: str, key: str, sec: dict[str, Any], unit: str) -> float:
        """A positive number: a length of at least :data:`MIN_LENGTH`, anything else of at
        least :data:`MIN_POSITIVE` (a vanishing mass or density is a limit worth taking)."""
        value = self.number(section, key, sec, unit)
        if value <= 0.0:
            raise self.fail(section, key, f"= {value:g}: must be a positive {unit}")
        least = MIN_LENGTH if unit.startswith("length") else MIN_POSITIVE
        if value < least:
            raise self.fail(section, key, f"= {value:.4g}: less than {least:g}, which no "
                            f"engine's {unit} is")
        return value

    def choice(self, section: str, key: str, sec: dict[str, Any], options: tuple[str, ...]) -> str:
        """A string key that must be one of ``options``; the first option is the default."""
        value = sec.get(key, options[0])
        if not isinstance(value, str) or value not in options:
            raise self.fail(section, key, f"= {self.shown(value)}: must be one of "
                            + ", ".join(repr(o) for o in options))
        return value

    @staticmethod
    def angle_key(name: str, sec: dict[str, Any]) -> str:
        """The key the file uses for the angle ``name``: ``name_deg`` or ``name`` (rad)."""
        return name if name in sec and f"{name}_deg" not in sec else f"{name}_deg"

    @staticmethod
    def angle_text(name: str, sec: dict[str, Any], value: float) -> str:
        """``= -50°`` or ``= -0.873 rad``: ``value`` (rad) in the unit of the key written."""
        if _Reader.angle_key(name, sec) == name:
            return f"= {value:g} rad ({math.degrees(value):.4g}°)"
        return f"= {math.degrees(value):g}°"

    def angle(self, section: str, name: str, sec: dict[str, Any]) -> float | None:
        """An angle given as ``name_deg`` (degrees) or ``name`` (rad); returns rad or None."""
        has_deg, has_rad = f"{name}_deg" in sec, name in sec
        if has_deg and has_rad:
            raise self.fail(section, name, f"give {name}_deg or {name}, not both")
        if has_deg:
            return math.radians(self.number(section, f"{name}_deg", sec))
        if has_rad:
            return self.number(section, name, sec)
        return None


def _parse_scene(data: dict[str, Any], source: str) -> Scene:
    r = _Reader(data, source)
    unknown = sorted(set(data) - set(_SECTIONS))
    if unknown:
        raise TrebuchetInputError(f"{source}: [{unknown[0]}]: unknown section (known sections: "
                                  + ", ".join(sorted(_SECTIONS)) + ")")
    eng = r.section("engine")
    st = r.section("start")
    projectile = r.choice("start", "projectile", st, ("trough", "sling", "none"))
    required = _REQUIRED_ENGINE + (() if projectile == "none" else ("L4", "m"))
    for key in required:
        if key not in eng:
            raise r.fail("engine", key, "missing key")
    L1, L2, L3 = (r.positive("engine", k, eng, "length in m") for k in ("L1", "L2", "L3"))
    m_b = r.positive("engine", "m_b", eng, "mass in kg")
    M = r.positive("engine", "M", eng, "mass in kg")
    if projectile == "none":
        for key in ("L4", "m"):
            if key in eng and r.number("engine", key, eng) < 0.0:
                raise r.fail("engine", key, "must not be negative")
        L4 = r.number("engine", "L4", eng) if "L4" in eng else 0.0
        m = 0.0
    else:
        L4 = r.positive("engine", "L4", eng, "length in m")
        m = r.positive("engine", "m", eng, "mass in kg")
    L_CM = r.number("engine", "L_CM", eng)
    if not -L2 <= L_CM <= L1:
        raise r.fail("engine", "L_CM", f"= {L_CM:g} m puts the centre of mass off the beam "
                     f"(it must lie between -L2 = {-L2:g} m and L1 = {L1:g} m)")
    if "I" in eng:
        I = r.positive("engine", "I", eng, "moment of inertia in kg m²")
    else:
        I = default_moment_of_inertia(m_b, L1, L2)
    if M * L2 <= m_b * L_CM:
        # a beam ten times its counterweight is a typo in m_b; else the counterweight is light
        key, value = ("m_b", m_b) if m_b > 10.0 * M else ("M", M)
        raise r.fail("engine", key, f"= {value:g} kg: the counterweight cannot lift the beam: "
                     f"its moment M L2 = {M * L2:g} kg m must exceed the beam's m_b L_CM = "
                     f"{m_b * L_CM:g} kg m (M = {M:g} kg, m_b = {m_b:g} kg)")
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
    if not -math.pi / 2 < theta < 0.0:
        key = r.angle_key("theta", st)
        hint = ""
        if key == "theta" and -90.0 < theta < 0.0:
            hint = f"; theta is in rad: for degrees write theta_deg = {theta:g}"
        raise r.fail("start", key, f"{r.angle_text('theta', st, theta)}: the beam must start "
                     f"between -90° and 0° (spigot low, on the projectile's side){hint}")
    H = r.positive("engine", "H", eng, "height in m") if "H" in eng else -L1 * math.sin(theta)
    offset = psi - theta if mount == "fixed" else None
    friction = _parse_friction(r)
    try:
        engine = Engine(L1=L1, L2=L2, L_CM=L_CM, L3=L3, L4=L4, m_b=m_b, M=M, m=m, I=I,
                        counterweight_offset=offset, friction=friction)
    except TrebuchetInputError as exc:  # "Engine: I = inf: ...": the file's key, by name
        raise _engine_error(r, eng, exc) from None
    _check_start_pose(r, engine, theta, psi, phi, H, projectile, st, "H" in eng)
    start = Start(theta=theta, psi=psi, phi=phi, H=H)

    if projectile == "none":
        if "release" in data:
            raise r.fail("release", None, "a dry fire (projectile = \"none\") has no release")
        release = Release()
    else:
        rel = r.section("release")
        t_rel = r.positive("release", "time", rel, "time in s") if "time" in rel else None
        angle_rel = r.angle("release", "velocity_angle", rel)
        if (t_rel is None) == (angle_rel is None):
            raise r.fail("release", None, "give exactly one of time, velocity_angle_deg")
        if angle_rel is not None and not 0.0 < angle_rel < math.pi / 2:
            raise r.fail("release", r.angle_key("velocity_angle", rel),
                         f"{r.angle_text('velocity_angle', rel, angle_rel)}: "
                         "must lie strictly between 0° and 90°")
        release = Release(t_rel, angle_rel)

    env = r.section("environment", required=False)
    g = r.positive("environment", "g", env, "acceleration in m/s²") if "g" in env else 9.81
    return Scene(engine=engine, start=start, release=release, g=g, projectile=projectile,
                 flight=_parse_flight(r), source=source)


def _engine_error(r: _Reader, eng: dict[str, Any], exc: TrebuchetInputError
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


def _parse_friction(r: _Reader) -> Friction | None:
    """The ``[friction]`` section: None where the scene has none (the paper's engine). A
    coefficient needs its radius and a radius its coefficient; each is zero or positive."""
    fr = r.section("friction", required=False)
    if not fr:
        return None
    values: dict[str, float] = {}
    for key in ("pivot_mu", "pivot_radius", "hinge_mu", "hinge_radius"):
        if key in fr:
            values[key] = r.number("friction", key, fr)
            if values[key] < 0.0:
                raise r.fail("friction", key, f"= {values[key]:g}: must not be negative")
    for joint in ("pivot", "hinge"):
        mu, radius = f"{joint}_mu", f"{joint}_radius"
        if (mu in values) != (radius in values):
            given, missing = (mu, radius) if mu in values else (radius, mu)
            raise r.fail("friction", missing, f"missing key ({given} needs it: the {joint}'s "
                         "friction couple is mu x radius x load)")
    if "smoothing_rate" in fr:
        values["smoothing_rate"] = r.positive("friction", "smoothing_rate", fr, "rate in rad/s")
    return Friction(**values)


def _parse_flight(r: _Reader) -> Flight:
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
        diameter=r.positive("flight", "diameter", fl, "length in m"),
        drag_coefficient=(r.positive("flight", "drag_coefficient", fl, "number")
                          if "drag_coefficient" in fl else 0.47),
        air_density=(r.positive("flight", "air_density", fl, "density in kg/m³")
                     if "air_density" in fl else 1.225),
    )


def _check_start_pose(r: _Reader, e: Engine, theta: float, psi: float, phi: float, H: float,
                      projectile: str, st: dict[str, Any] | None = None,
                      H_given: bool = True) -> None:
    """Spigot and counterweight above ground; the projectile in the trough (y = 0) at the end of
    the taut sling, or hanging above ground in the sling. Each refusal names the key that is
    wrong, as the file wrote it (``theta_deg`` or ``theta``)."""
    st = st or {}

    def key(name: str) -> str:
        return r.angle_key(name, st)

    def text(name: str, value: float) -> str:
        return r.angle_text(name, st, value)

    spigot_y = H + e.L1 * math.sin(theta)
    if spigot_y < -1e-9 * e.L1:
        raise r.fail("start", key("theta"), f"{text('theta', theta)} puts the spigot "
                     f"{-spigot_y:.3g} m below ground (pivot height H = {H:g} m)")
    cw_y = H - e.L2 * math.sin(theta) + e.L3 * math.sin(psi)
    if cw_y < 0.0:
        # hanging straight down (ψ = −90°) is its lowest pose: below ground at some ψ means
        # the pivot is too low for L3, whatever ψ; the key at fault sets the pivot's height
        if H_given:
            raise r.fail("engine", "H", f"= {H:g} m: the pivot is too low for the "
                         f"counterweight (L3 = {e.L3:g} m) to hang above ground")
        hint = ""
        if key("theta") == "theta_deg" and -math.radians(90) < math.degrees(theta) < 0.0:
            hint = (f"; theta_deg is in degrees (did you mean theta = {math.degrees(theta):g} "
                    f"rad, i.e. theta_deg = {math.degrees(math.degrees(theta)):.4g}?)")
        raise r.fail("start", key("theta"), f"{text('theta', theta)} puts the pivot only "
                     f"{H:.3g} m above the trough (H = -L1 sin θ), too low for the "
                     f"counterweight (L3 = {e.L3:g} m) to hang above ground{hint}")
    if projectile == "none":
        return
    y_m = spigot_y + e.L4 * math.sin(phi)
    if projectile == "sling":
        if y_m < 0.0:
            raise r.fail("start", key("phi"), f"{text('phi', phi)} puts the projectile "
                         f"{-y_m:.3g} m below ground; raise the pivot with [engine] H")
        return
    if spigot_y > e.L4:
        raise r.fail("engine", "L4", f"= {e.L4:g} m: the sling cannot reach the trough from the "
                     f"spigot {spigot_y:.3g} m above it")
    if abs(y_m) > 1e-6 * e.L4:
        fit = -math.pi + math.asin(spigot_y / e.L4)
        where = "below ground" if y_m < 0 else "above the trough"
        raise r.fail("start", key("phi"), f"{text('phi', phi)} puts the projectile "
                     f"{abs(y_m):.3g} m {where}; the sling lies in the trough at "
                     f"phi_deg = {math.degrees(fit):.6g}")
    if math.cos(phi) > 0.0:
        raise r.fail("start", key("phi"), f"{text('phi', phi)}: the sling must point away "
                     "from the throw (between -270° and -90°), under the beam")
