"""The scene file's reader and its rules: of each number, and those that join several keys.

:class:`Reader` reads numbers from a scene file's dict and names file, section and key in
every refusal (one line, :class:`~trebuchet.errors.TrebuchetInputError`); :data:`RULES` says
which numbers must be positive (in which unit) or not negative; the ``check_*`` functions are
the rules that join keys. :mod:`trebuchet.model.scene` reads a scene file with them, and
builds a sweep's designs without the file's dict under the same rules
(``scene.with_numbers``): each rule lives here once. Lengths in m, masses in kg, angles in
rad.
"""

from __future__ import annotations

import math
from typing import Any

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model.engine import Engine, Release

__all__ = ["RULES", "SECTIONS", "SCENE_KEYS", "Reader", "MAX_MAGNITUDE", "MIN_LENGTH",
           "MIN_POSITIVE", "check_lift", "check_theta", "check_release", "check_start_pose"]

#: The rule of each number of a scene file (the reader's ``value``): the unit of a positive
#: quantity, "not negative", or (a key not here: ``L_CM``, the angles) any finite number.
RULES = {("engine", k): "length in m" for k in ("L1", "L2", "L3", "L4")} | {
    ("engine", k): "mass in kg" for k in ("m_b", "M", "m")} | {
    ("engine", "I"): "moment of inertia in kg m²", ("engine", "H"): "height in m",
    ("release", "time"): "time in s", ("environment", "g"): "acceleration in m/s²",
    ("friction", "smoothing_rate"): "rate in rad/s", ("flight", "diameter"): "length in m",
    ("flight", "drag_coefficient"): "number", ("flight", "air_density"): "density in kg/m³"} | {
    ("friction", k): "not negative" for k in ("pivot_mu", "pivot_radius", "hinge_mu",
                                              "hinge_radius")}
#: The keys of each section of a scene file.
SECTIONS = {
    "engine": {"L1", "L2", "L_CM", "L3", "L4", "m_b", "M", "m", "I", "H", "counterweight"},
    "start": {"theta_deg", "psi_deg", "phi_deg", "theta", "psi", "phi", "projectile"},
    "release": {"time", "velocity_angle_deg", "velocity_angle"},
    "environment": {"g"},
    "flight": {"model", "diameter", "drag_coefficient", "air_density"},
    "friction": {"pivot_mu", "pivot_radius", "hinge_mu", "hinge_radius", "smoothing_rate"},
}

#: Every key a scene file may hold, by section (the parser's own list).
SCENE_KEYS: dict[str, frozenset[str]] = {k: frozenset(v) for k, v in SECTIONS.items()}


#: Largest magnitude of a scene's number (m, kg, s, m/s², degrees or rad): far beyond any
#: engine's, short of the numbers whose products in the equations of motion overflow.
MAX_MAGNITUDE = 1e15
#: Least length (m) of an engine: 1 µm (a shorter sling stalls the integrator).
MIN_LENGTH = 1e-6
#: Least value of any other positive quantity (kg, s, m/s², kg/m³): far below any engine's,
#: above the numbers whose reciprocal overflows.
MIN_POSITIVE = 1e-30
_NUMBER_TYPES = (int, float)


class Reader:
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
        unknown = sorted(set(sec) - SECTIONS[name])
        if unknown:
            raise self.fail(name, unknown[0], "unknown key (known keys: "
                            + ", ".join(sorted(SECTIONS[name])) + ")")
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
        if isinstance(value, bool) or not isinstance(value, _NUMBER_TYPES):
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

    def value(self, section: str, key: str, sec: dict[str, Any]) -> float:
        """The number ``sec[key]`` under its key's rule (:data:`RULES`)."""
        rule = RULES.get((section, key))
        if rule is None:
            return self.number(section, key, sec)
        if rule != "not negative":
            return self.positive(section, key, sec, rule)
        value = self.number(section, key, sec)
        if value < 0.0:
            raise self.fail(section, key, f"= {value:g}: must not be negative")
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
        if Reader.angle_key(name, sec) == name:
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


def check_lift(r: Reader, M: float, L2: float, m_b: float, L_CM: float) -> None:
    """The counterweight's moment ``M L2`` (kg m) must exceed the beam's ``m_b L_CM``."""
    if M * L2 <= m_b * L_CM:
        # a beam ten times its counterweight is a typo in m_b; else the counterweight is light
        key, value = ("m_b", m_b) if m_b > 10.0 * M else ("M", M)
        raise r.fail("engine", key, f"= {value:g} kg: the counterweight cannot lift the beam: "
                     f"its moment M L2 = {M * L2:g} kg m must exceed the beam's m_b L_CM = "
                     f"{m_b * L_CM:g} kg m (M = {M:g} kg, m_b = {m_b:g} kg)")


def check_theta(r: Reader, theta: float, st: dict[str, Any]) -> None:
    """The beam starts between -90° and 0° (``theta`` in rad, named as ``st`` writes it)."""
    if not -math.pi / 2 < theta < 0.0:
        key = r.angle_key("theta", st)
        hint = ""
        if key == "theta" and -90.0 < theta < 0.0:
            hint = f"; theta is in rad: for degrees write theta_deg = {theta:g}"
        raise r.fail("start", key, f"{r.angle_text('theta', st, theta)}: the beam must start "
                     f"between -90° and 0° (spigot low, on the projectile's side){hint}")


def check_release(r: Reader, release: Release, rel: dict[str, Any]) -> None:
    """A release angle lies strictly between 0° and 90° (named as ``rel`` writes it)."""
    angle = release.velocity_angle
    if angle is not None and not 0.0 < angle < math.pi / 2:
        raise r.fail("release", r.angle_key("velocity_angle", rel),
                     f"{r.angle_text('velocity_angle', rel, angle)}: "
                     "must lie strictly between 0° and 90°")


def check_start_pose(r: Reader, e: Engine, theta: float, psi: float, phi: float, H: float,
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
