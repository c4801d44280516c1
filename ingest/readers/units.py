"""Units written in log headers: ``t (s)``, ``time [ms]``, ``theta (deg)``, ``phi [rad]``."""

from __future__ import annotations

import math
import re

from trebuchet.errors import TrebuchetInputError

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
