"""The FMU's variables: every scene key as a parameter, the release command, every output.

One table, :data:`VARIABLES`, is the interface: value references are the positions in the
table (the C glue's ``treb_variables.h`` is generated from it), and the build writes units,
display units, ranges, Enumerations and the model structure of ``modelDescription.xml`` from
it. Parameter names are the scene file's ``[section] key`` written ``section.key``; the choices
(counterweight, projectile, flight model) are Enumerations whose FMI values count from 1.
:func:`scene_from_parameters` turns parameter values into a
:class:`~trebuchet.model.scene.Scene` through ``Scene.from_dict`` (the in-process reference
the tests compare the FMU with); the FMU's C checks the same rules with the same messages.

Units are SI (m, kg, kg m², s, N, N m, W, J, rad) except the start pose and release angle,
which are in degrees as in the scene file (``*_deg``); the angle outputs are in rad, shown in
deg (display unit).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

from trebuchet.model.forces import LOAD_COLUMNS
from trebuchet.model.scene import DEFAULT_SMOOTHING_RATE, Scene

__all__ = ["Variable", "VARIABLES", "PARAMETERS", "OUTPUTS", "OUTPUT_NAMES", "RELEASE_COMMAND",
           "UNITS",
           "scene_from_parameters", "parameters_from_scene", "choice_name", "choice_index",
           "DISPLAY_UNITS"]


@dataclass(frozen=True)
class Variable:
    """One FMI scalar variable: name, kind, unit and, for parameters, start value and range."""

    name: str
    causality: Literal["parameter", "input", "output"]
    type: Literal["Real", "Integer", "Boolean", "Enumeration"]
    unit: str | None
    description: str
    start: float | bool | str | None = None
    min: float | None = None
    max: float | None = None
    display_unit: str | None = None
    choices: tuple[str, ...] = ()

    @property
    def type_name(self) -> str | None:
        """The declared type of an Enumeration (its choices' name), else None."""
        return f"{self.name.split('.')[-1]}_choice" if self.type == "Enumeration" else None


# Units: name -> (SI base exponents kg, m, s, rad; factor to the base unit).
UNITS: dict[str, tuple[dict[str, int], float]] = {
    "m": ({"m": 1}, 1.0),
    "kg": ({"kg": 1}, 1.0),
    "kg.m2": ({"kg": 1, "m": 2}, 1.0),
    "kg/m3": ({"kg": 1, "m": -3}, 1.0),
    "s": ({"s": 1}, 1.0),
    "m/s": ({"m": 1, "s": -1}, 1.0),
    "m/s2": ({"m": 1, "s": -2}, 1.0),
    "rad": ({"rad": 1}, 1.0),
    "deg": ({"rad": 1}, 0.017453292519943295),
    "rad/s": ({"rad": 1, "s": -1}, 1.0),
    "rad/s2": ({"rad": 1, "s": -2}, 1.0),
    "N": ({"kg": 1, "m": 1, "s": -2}, 1.0),
    "N.m": ({"kg": 1, "m": 2, "s": -2}, 1.0),
    "W": ({"kg": 1, "m": 2, "s": -3}, 1.0),
    "J": ({"kg": 1, "m": 2, "s": -2}, 1.0),
}
#: Display units: unit -> (display unit, factor: display value = factor * value).
DISPLAY_UNITS: dict[str, tuple[str, float]] = {
    "rad": ("deg", 57.29577951308232), "rad/s": ("deg/s", 57.29577951308232),
    "rad/s2": ("deg/s2", 57.29577951308232),
}

# Start values: the large engine of Table 1 of the paper (data_samples/horsdal_large.toml).
PARAMETERS: tuple[Variable, ...] = (
    Variable("engine.L1", "parameter", "Real", "m", "pivot to spigot (long arm)",
             6.48, 0.0, 100.0),
    Variable("engine.L2", "parameter", "Real", "m", "pivot to hinge (short arm)",
             0.86, 0.0, 100.0),
    Variable("engine.L_CM", "parameter", "Real", "m",
             "pivot to the beam's centre of mass, toward the spigot (between -L2 and L1)",
             2.81, -100.0, 100.0),
    Variable("engine.L3", "parameter", "Real", "m", "hinge to counterweight", 2.45, 0.0, 100.0),
    Variable("engine.L4", "parameter", "Real", "m", "sling", 5.55, 0.0, 100.0),
    Variable("engine.m_b", "parameter", "Real", "kg", "beam mass", 622.0, 0.0, 1e6),
    Variable("engine.M", "parameter", "Real", "kg", "counterweight mass", 19100.0, 0.0, 1e7),
    Variable("engine.m", "parameter", "Real", "kg", "projectile mass", 100.0, 0.0, 1e5),
    Variable("engine.counterweight", "parameter", "Enumeration", None,
             "\"hinged\" (swings on its hinge, the paper) or \"fixed\" (rigid on the beam)",
             "hinged", choices=("hinged", "fixed")),
    Variable("engine.I", "parameter", "Real", "kg.m2",
             "beam moment of inertia about the pivot; 0: uniform beam, "
             "m_b (L1^2 - L1 L2 + L2^2) / 3", 0.0, 0.0, 1e8),
    Variable("engine.H", "parameter", "Real", "m",
             "pivot height above the trough; 0: spigot on the ground at the start, "
             "-L1 sin(theta)", 0.0, 0.0, 100.0),
    Variable("start.theta_deg", "parameter", "Real", "deg", "beam angle at rest",
             -50.0, -90.0, 0.0),
    Variable("start.psi_deg", "parameter", "Real", "deg", "counterweight arm angle at rest",
             -90.0, -360.0, 360.0),
    Variable("start.phi_deg", "parameter", "Real", "deg",
             "sling angle at rest (the projectile must lie in the trough)",
             -180.0, -270.0, -90.0),
    Variable("start.projectile", "parameter", "Enumeration", None,
             "\"trough\" (the paper), \"sling\" (hanging at rest in the sling) or \"none\" "
             "(dry fire: set release.time and release.velocity_angle_deg to 0)", "trough",
             choices=("trough", "sling", "none")),
    Variable("release.time", "parameter", "Real", "s",
             "release at this time after the trigger; 0: no time rule", 0.997, 0.0, 60.0),
    Variable("release.velocity_angle_deg", "parameter", "Real", "deg",
             "release when the projectile's velocity climbs at this angle above horizontal; "
             "0: no angle rule", 0.0, 0.0, 90.0),
    Variable("environment.g", "parameter", "Real", "m/s2", "gravity", 9.82, 0.0, 100.0),
    Variable("flight.model", "parameter", "Enumeration", None,
             "flight after release: \"vacuum\" (the paper) or \"drag\" (quadratic air drag)",
             "vacuum", choices=("vacuum", "drag")),
    Variable("flight.diameter", "parameter", "Real", "m",
             "projectile diameter (used with flight.model = \"drag\")", 0.0, 0.0, 10.0),
    Variable("flight.drag_coefficient", "parameter", "Real", None,
             "drag coefficient (used with flight.model = \"drag\")", 0.47, 0.0, 10.0),
    Variable("flight.air_density", "parameter", "Real", "kg/m3",
             "air density (used with flight.model = \"drag\")", 1.225, 0.0, 100.0),
    Variable("friction.pivot_mu", "parameter", "Real", None,
             "Coulomb coefficient at the beam's shaft (0 with pivot_radius 0: no friction)",
             0.0, 0.0, 10.0),
    Variable("friction.pivot_radius", "parameter", "Real", "m", "radius of the beam's shaft",
             0.0, 0.0, 10.0),
    Variable("friction.hinge_mu", "parameter", "Real", None,
             "Coulomb coefficient at the counterweight's hinge pin", 0.0, 0.0, 10.0),
    Variable("friction.hinge_radius", "parameter", "Real", "m",
             "radius of the counterweight's hinge pin", 0.0, 0.0, 10.0),
    Variable("friction.smoothing_rate", "parameter", "Real", "rad/s",
             "the friction couples' sign of a sliding rate w is tanh(w / smoothing_rate)",
             DEFAULT_SMOOTHING_RATE, 0.0, 100.0),
)

RELEASE_COMMAND = Variable(
    "release_command", "input", "Boolean", None,
    "releases the projectile when it rises (false to true at a communication point), in "
    "addition to the scene's own release rule; ignored (with a logged warning) before "
    "lift-off, and after the release", False)

_ANGLES = (
    ("theta", "rad", "beam angle"), ("psi", "rad", "counterweight arm angle"),
    ("phi", "rad", "sling angle (0 after release)"),
)
_LOAD_UNITS = {"F": "N", "t": "N.m", "P": "W", "E": "J", "x": "m", "y": "m", "v": "m/s"}
_FRICTION_OUTPUTS = (
    ("torque_friction", "N.m", "the friction couples' torque on the beam (in torque)"),
    ("P_loss_pivot", "W", "heat made at the pivot by friction"),
    ("P_loss_hinge", "W", "heat made at the hinge by friction"),
    ("E_loss_pivot", "J", "heat made at the pivot since t = 0"),
    ("E_loss_hinge", "J", "heat made at the hinge since t = 0"),
)
_LOAD_TEXT = {
    "F_S": "sling tension on the projectile", "F_H": "force from the beam on the counterweight "
    "at the hinge", "F_CM": "internal force on the beam's centre of mass",
    "F_R": "bearing reaction on the beam at the pivot", "torque": "torque on the beam about "
    "the pivot", "P_m": "rate of work on the projectile", "P_M": "rate of work on the "
    "counterweight", "P_beam": "rate of work on the beam", "E_m": "projectile energy gained "
    "since t = 0", "E_M": "counterweight energy gained since t = 0", "E_beam": "beam energy "
    "gained since t = 0", "x_m": "projectile x (origin on the ground under the pivot)",
    "y_m": "projectile height", "vx_m": "projectile velocity x", "vy_m": "projectile "
    "velocity y",
}


def _load_variable(column: str) -> Variable:
    stem = column[:-2] if column.endswith(("_x", "_y")) and column.startswith("F_") else column
    text = _LOAD_TEXT[stem] + (f", {column[-1]} component" if stem != column else "")
    return Variable(column, "output", "Real", _LOAD_UNITS[column[0]], text)


OUTPUTS: tuple[Variable, ...] = (
    Variable("phase", "output", "Integer", None, "1 trough, 2 in sling, 3 after release"),
    *(Variable(a, "output", "Real", u, d, display_unit="deg") for a, u, d in _ANGLES),
    *(Variable(f"{a}_d", "output", "Real", f"{u}/s", f"{d}, rate", display_unit="deg/s")
      for a, u, d in _ANGLES),
    *(Variable(f"{a}_dd", "output", "Real", f"{u}/s2", f"{d}, acceleration",
               display_unit="deg/s2") for a, u, d in _ANGLES),
    *(_load_variable(c) for c in LOAD_COLUMNS),
    Variable("F_N", "output", "Real", "N", "normal force of the trough on the projectile"),
    Variable("sling_tension", "output", "Real", "N",
             "sling tension (negative: the sling would be slack, the model is outside its "
             "validity)"),
    *(Variable(name, "output", "Real", unit, text) for name, unit, text in _FRICTION_OUTPUTS),
)

VARIABLES: tuple[Variable, ...] = (*PARAMETERS, RELEASE_COMMAND, *OUTPUTS)
#: The outputs' names, in order.
OUTPUT_NAMES: tuple[str, ...] = tuple(v.name for v in OUTPUTS)

_BY_NAME = {v.name: v for v in VARIABLES}


def choice_name(v: Variable, value: int | str) -> str:
    """The choice an Enumeration's value names: its name, or its position from 1 (FMI)."""
    if isinstance(value, str):
        return value
    return v.choices[int(value) - 1]


def choice_index(v: Variable, value: str) -> int:
    """The FMI value (position from 1) of an Enumeration's choice."""
    return v.choices.index(value) + 1


_OPTIONAL_ZERO = {"engine.I", "engine.H", "release.time", "release.velocity_angle_deg"}
_DRAG_ONLY = {"flight.diameter", "flight.drag_coefficient", "flight.air_density"}
_FRICTION = ("friction.pivot_mu", "friction.pivot_radius", "friction.hinge_mu",
             "friction.hinge_radius")


def _nested(values: Mapping[str, float | str], release_key: str | None) -> dict:
    """The scene dict: keys left at their "not given" value (0, or a choice at the paper's
    default) are left out, so a scene file without them means the same."""
    data: dict[str, dict[str, float | str]] = {}
    drag = choice_name(_BY_NAME["flight.model"], values["flight.model"]) != "vacuum"
    friction = any(float(values[k]) != 0.0 for k in _FRICTION)
    for p in PARAMETERS:
        section, key = p.name.split(".", 1)
        if p.type == "Enumeration":
            value: float | str = choice_name(p, values[p.name])
            if value == p.start:
                continue
        else:
            value = float(values[p.name])
            if p.name in _OPTIONAL_ZERO and value == 0.0:
                continue
        if (section == "release" and key != release_key) or (p.name in _DRAG_ONLY
                                                             and not drag):
            continue
        if section == "friction" and not friction:  # no friction: no [friction] section
            continue
        data.setdefault(section, {})[key] = value
    return data


def scene_from_parameters(values: Mapping[str, float | str],
                          source: str = "FMU parameters") -> Scene:
    """The scene of the FMU's parameter values (``section.key`` -> value in the unit of
    :data:`PARAMETERS`). ``engine.I``, ``engine.H``, ``release.time`` and
    ``release.velocity_angle_deg`` at 0 mean "not given"; at least one release rule must be
    given, and with both the release comes at whichever is reached first.

    Raises :class:`~trebuchet.core.errors.TrebuchetInputError` with the scene's message.
    """
    has_time = float(values["release.time"]) != 0.0
    has_angle = float(values["release.velocity_angle_deg"]) != 0.0
    if has_time and has_angle:
        by_time = Scene.from_dict(_nested(values, "time"), source=source)
        by_angle = Scene.from_dict(_nested(values, "velocity_angle_deg"), source=source)
        return by_time.with_release(time=by_time.release.time,
                                    velocity_angle=by_angle.release.velocity_angle)
    key = "time" if has_time else "velocity_angle_deg" if has_angle else None
    data = _nested(values, key)
    if key is None and choice_name(_BY_NAME["start.projectile"],
                                   values["start.projectile"]) != "none":
        data["release"] = {}  # the scene names the missing rule
    return Scene.from_dict(data, source=source)


def parameters_from_scene(scene: Scene) -> dict[str, float | str]:
    """FMU parameter values (``section.key`` -> value) of ``scene``; angles go through degrees,
    so build the reference scene with :func:`scene_from_parameters` of these values."""
    d = scene.to_dict()
    values: dict[str, float | str] = {p.name: p.start if p.type == "Enumeration" else 0.0
                                      for p in PARAMETERS}
    for name in (*_DRAG_ONLY, "friction.smoothing_rate"):
        values[name] = next(p.start for p in PARAMETERS if p.name == name)
    for section, keys in d.items():
        for key, value in keys.items():
            values[f"{section}.{key}"] = value if isinstance(value, str) else float(value)
    return values
