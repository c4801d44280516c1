"""Units written in log headers: ``t (s)``, ``time [ms]``, ``theta (deg)``, ``phi [rad]``."""

from __future__ import annotations

import math
import re

import numpy as np

from trebuchet.core.errors import TrebuchetInputError

#: Factors to seconds.
TIME_UNITS: dict[str, float] = {
    "s": 1.0,
    "sec": 1.0,
    "ms": 1e-3,
    "us": 1e-6,
    "µs": 1e-6,
    "μs": 1e-6,
}

#: Factors to radians.
ANGLE_UNITS: dict[str, float] = {
    "rad": 1.0,
    "deg": math.pi / 180.0,
    "degree": math.pi / 180.0,
    "degrees": math.pi / 180.0,
    "°": math.pi / 180.0,
}

_UNIT = re.compile(r"^(?P<name>.*?)\s*[\(\[]\s*(?P<unit>[^\)\]]*?)\s*[\)\]]\s*$")


def split_unit(header: str) -> tuple[str, str | None]:
    """Split ``"theta (deg)"`` into ``("theta", "deg")``; ``"theta"`` into ``("theta", None)``."""
    m = _UNIT.match(header.strip())
    if m is None:
        return header.strip(), None
    return m.group("name").strip(), m.group("unit")


def _factor(header: str, unit: str | None, default: float,
            table: dict[str, float], what: str) -> float:
    """Factor from a column's unit to SI by ``table`` (``default`` when no unit is written)."""
    if unit is None:
        return default
    key = unit.strip().lower()
    if key not in table:
        raise TrebuchetInputError.at(
            f"column '{header}'", f"unknown {what} unit {unit!r} "
            f"(known: {', '.join(sorted(set(table)))})"
        )
    return table[key]


def time_factor(header: str, unit: str | None, default: float) -> float:
    """Factor from the time column's unit to seconds (``default`` when no unit is written)."""
    return _factor(header, unit, default, TIME_UNITS, "time")


def angle_factor(header: str, unit: str | None, default: float) -> float:
    """Factor from an angle column's unit to radians (``default`` when no unit is written)."""
    return _factor(header, unit, default, ANGLE_UNITS, "angle")


#: Units an angle column can be stated in (``angle_unit=``).
ANGLE_UNIT_CHOICES = ("deg", "rad")
#: rad: no angle of a shot lies further from zero than two turns.
TWO_TURNS = 4.0 * math.pi
#: deg: the least sweep of the beam that reads as part of a shot (a whole shot sweeps the
#: beam by ~100-200°).
LEAST_SWEEP_DEG = 20.0


def check_angle_unit(angle_unit: str | None) -> str | None:
    """``angle_unit`` if it is ``"deg"``, ``"rad"`` or None, else an error."""
    if angle_unit is not None and angle_unit not in ANGLE_UNIT_CHOICES:
        raise TrebuchetInputError(f"angle_unit={angle_unit!r} must be 'deg' or 'rad'")
    return angle_unit


def decide_angle_unit(swing: tuple[str, np.ndarray], values: list[np.ndarray]
                      ) -> tuple[str, str]:
    """The unit of unit-less angle columns: (``"deg"`` or ``"rad"``, how it was decided).

    ``swing`` is (label, values as written) of the column whose sweep decides (the beam's
    when it is among them); ``values`` are all the unit-less columns used. Evidence:

    * a value further than two turns from zero (in rad) is no shot's: degrees;
    * a sweep of more than a turn is no beam's in rad: degrees, if it is at least
      :data:`LEAST_SWEEP_DEG` degrees (a shot's); between the two, an error;
    * otherwise (every value within two turns, a sweep of at most 2π): radians, since in
      degrees the beam would sweep less than 6.3° (a misread: a shot sweeps ~100-200°).
    """
    label, v = swing
    v = v[np.isfinite(v)]
    every = np.concatenate([x[np.isfinite(x)] for x in values]) if values else v
    largest = float(np.max(np.abs(every))) if every.size else 0.0
    sweep = float(np.ptp(v)) if v.size else 0.0
    deg_sweep = float(np.ptp(np.unwrap(v, period=360.0))) if v.size else 0.0
    if largest > TWO_TURNS:
        return "deg", (f"inferred: values reach {largest:.4g}, more than two turns in rad; "
                       f"'{label}' sweeps {deg_sweep:.4g}°")
    if sweep > 2 * math.pi:
        if deg_sweep >= LEAST_SWEEP_DEG:
            return "deg", (f"inferred: '{label}' sweeps {sweep:.4g}, more than a turn in rad, "
                           f"{deg_sweep:.4g}° in degrees")
        raise TrebuchetInputError.at(
            f"column '{label}'", f"without a unit it sweeps {sweep:.4g}: more than a turn in "
            f"rad, and only {deg_sweep:.4g}° in degrees (a shot's beam sweeps ~100-200°); "
            "say the unit with angle_unit= (likely 'deg') or in the header, e.g. "
            f"'{label} (deg)'")
    return "rad", (f"inferred: every value within ±{largest:.3g}, '{label}' sweeps "
                   f"{math.degrees(sweep):.4g}° in rad; in degrees it would sweep "
                   f"{sweep:.3g}°, which no shot does")
