"""The paper's angles from tracked points of the engine.

Conventions (the paper's): x to the right, y up, e_a = (cos a, sin a).

* theta: direction pivot -> spigot; without a tracked spigot, hinge -> pivot (the
  short arm points the other way);
* psi: direction hinge -> counterweight;
* phi: direction spigot -> projectile.

Each angle is ``atan2`` of the difference of two positions, in (-π, π]; unwrapping is
left to :func:`~.read_log.read_log`. Positions may be in any length unit, the same for
x and y (pixels, metres). Files with y pointing down (image coordinates) are flipped by
their readers before they get here.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from trebuchet.errors import TrebuchetInputError

from .log_mapping import ROLES, Candidate, check_mapping, resolve

#: For each angle, the pairs of points (from, to) that give it, in order of preference.
NEEDS: dict[str, tuple[tuple[str, str], ...]] = {
    "theta": (("pivot", "spigot"), ("hinge", "pivot")),
    "psi": (("hinge", "counterweight"),),
    "phi": (("spigot", "projectile"),),
}


def direction(x0: np.ndarray, y0: np.ndarray, x1: np.ndarray, y1: np.ndarray) -> np.ndarray:
    """Angle (rad, in (-π, π]) of the vector from point 0 to point 1; NaN where one is missing."""
    return np.arctan2(y1 - y0, x1 - x0)


def angles_from_positions(positions: dict[str, tuple[np.ndarray, np.ndarray]]) -> dict[str, str]:
    """Which pair of points each angle will use, from the roles present in ``positions``."""
    chosen: dict[str, str] = {}
    for angle, pairs in NEEDS.items():
        for a, b in pairs:
            if a in positions and b in positions:
                chosen[angle] = f"{a}->{b}"
                break
    return chosen


def resolve_points(
    path: str | Path, tracks: list[Candidate], points: dict[str, str] | None
) -> dict[str, Candidate]:
    """Map engine parts to the file's points (``points=`` then names equal to the part).

    Error naming the missing part when a point an angle needs is not found.
    """
    mapping = check_mapping(path, points, ROLES, "points")
    chosen = resolve(path, tracks, mapping, ROLES, "points", "point")
    for angle, pairs in NEEDS.items():
        if any(a in chosen and b in chosen for a, b in pairs):
            continue
        a, b = pairs[0]
        missing = [r for r in (a, b) if r not in chosen]
        alt = (
            " (or hinge and pivot)" if angle == "theta" and "spigot" in missing else ""
        )
        found = ", ".join(repr(c.label) for c in tracks) or "none"
        raise TrebuchetInputError(
            f"{path}: the angle {angle} needs the points {a} and {b}{alt}; no point for "
            f"{' and '.join(missing)} (points found: {found}); name it with "
            f"points={{{missing[0]!r}: '<point in the file>'}}"
        )
    return chosen


def point_angles(
    positions: dict[str, tuple[np.ndarray, np.ndarray]],
) -> dict[str, np.ndarray]:
    """theta, psi, phi (rad, in (-π, π]) from positions ``{role: (x, y)}``, y up."""
    out: dict[str, np.ndarray] = {}
    for angle, pairs in NEEDS.items():
        for a, b in pairs:
            if a in positions and b in positions:
                out[angle] = direction(*positions[a], *positions[b])
                break
    return out
