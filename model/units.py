"""The SI unit of every column the package writes, and of every scene key, by name.

The tables of ``simulate``, ``reconstruct`` (``trebuchet forces``) and ``sweep`` are SI
throughout (docs/columns.md); a CSV file of them carries bare names unless asked for units
(``--units``), and then each header cell reads ``name (unit)``, the form the generic log
reader takes units from (docs/formats.md). Units are written in ASCII (``rad/s^2``,
``N m``), so that any spreadsheet reads them.

The unit follows from the name: an ``X_sd`` column has the unit of ``X``; a state column
(``theta``, ``theta_d``, ``theta_dd`` and those of ``psi`` and ``phi``) is rad, rad/s or
rad/s^2; a force ``F_*`` and ``sling_tension`` N; ``torque*`` N m; ``P_*`` W; ``E_*`` J;
positions ``x_m``, ``y_m`` m and velocities ``vx_m``, ``vy_m`` m/s; times ``t``, ``t_shot``
s; a scene key ``section.key`` its unit in the scene file (docs/scenes.md). ``phase`` and
the words of a table (``status``, ``error``) have none. Light to import: no numpy.
"""

from __future__ import annotations

__all__ = ["ANGLE_UNITS", "SCENE_KEY_UNITS", "UNITS_HELP", "column_unit", "column_units"]

#: Help of the ``--units`` option of ``simulate``, ``forces`` and ``sweep``.
UNITS_HELP = ("write each column's SI unit into the header, as 'F_R_x (N)' (default: bare "
              "names; docs/columns.md)")

#: Units of an angle, its rate and its acceleration, by the column's suffix.
ANGLE_UNITS = {"": "rad", "_d": "rad/s", "_dd": "rad/s^2"}
_ANGLES = ("theta", "psi", "phi")
#: Units of the other columns, by the column's first word (the part before the first "_").
_BY_PREFIX = {"F": "N", "torque": "N m", "P": "W", "E": "J", "sling": "N"}
_BY_NAME = {"t": "s", "t_shot": "s", "x_m": "m", "y_m": "m", "vx_m": "m/s", "vy_m": "m/s"}

#: The unit of each number of a scene file, ``section.key`` (docs/scenes.md).
SCENE_KEY_UNITS: dict[str, str] = {
    **{f"engine.{k}": "m" for k in ("L1", "L2", "L_CM", "L3", "L4", "H")},
    **{f"engine.{k}": "kg" for k in ("m_b", "M", "m")},
    "engine.I": "kg m^2",
    **{f"start.{a}_deg": "deg" for a in _ANGLES},
    **{f"start.{a}": "rad" for a in _ANGLES},
    "release.time": "s",
    "release.velocity_angle_deg": "deg",
    "release.velocity_angle": "rad",
    "environment.g": "m/s^2",
    "flight.diameter": "m",
    "flight.drag_coefficient": "1",
    "flight.air_density": "kg/m^3",
}


def column_unit(name: str) -> str | None:
    """The SI unit of the column ``name`` (module doc), or None where it has none or is not
    one of the package's columns."""
    if name.endswith("_sd"):
        return column_unit(name[:-3])
    if name in SCENE_KEY_UNITS:
        return SCENE_KEY_UNITS[name]
    if name in _BY_NAME:
        return _BY_NAME[name]
    stem, _, suffix = name.partition("_")
    if stem in _ANGLES and ("_" + suffix if suffix else "") in ANGLE_UNITS:
        return ANGLE_UNITS["_" + suffix if suffix else ""]
    return _BY_PREFIX.get(stem)


def column_units(names: list[str] | tuple[str, ...]) -> dict[str, str]:
    """``{name: unit}`` for the names of ``names`` that have a unit (:func:`column_unit`)."""
    return {n: u for n in names if (u := column_unit(n)) is not None}
