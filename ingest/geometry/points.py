"""The paper's angles from tracked points of the engine.

Conventions (the paper's): x to the right, y up, e_a = (cos a, sin a).

* theta: direction pivot -> spigot (not hinge -> pivot when the spigot is missing:
  phi needs the spigot anyway, so a log without it cannot give all three angles);
* psi: direction hinge -> counterweight;
* phi: direction spigot -> projectile.

Each angle is ``atan2`` of the difference of two positions, unwrapped over its present
values; its 2π branch is that of the paper's start pose: the first present value lies in
[-π, π) for theta and psi and in [-3π/2, π/2) for phi (the sling starts near -180°, where
``atan2`` alone would flip between +180° and -180° with the noise). Positions may be in
any length unit, the same for x and y (pixels, metres). Files with y pointing down
(image coordinates) are flipped by their readers before they get here.
"""

from __future__ import annotations

import numpy as np

from trebuchet.core.errors import Option, TrebuchetInputError
from trebuchet.ingest.readers.mapping import ROLES, Candidate, check_mapping, resolve

#: Lower end of the 2π window holding each angle's first present value (rad).
BRANCH_START: dict[str, float] = {"theta": -np.pi, "psi": -np.pi, "phi": -1.5 * np.pi}

#: For each angle, the pairs of points (from, to) that give it, in order of preference.
NEEDS: dict[str, tuple[tuple[str, str], ...]] = {
    "theta": (("pivot", "spigot"),),
    "psi": (("hinge", "counterweight"),),
    "phi": (("spigot", "projectile"),),
}


def direction(x0: np.ndarray, y0: np.ndarray, x1: np.ndarray, y1: np.ndarray) -> np.ndarray:
    """Angle (rad, in (-π, π]) of the vector from point 0 to point 1; NaN where one is missing."""
    return np.arctan2(y1 - y0, x1 - x0)


def paper_branch(angle: str, values: np.ndarray) -> np.ndarray:
    """Unwrap ``values`` (rad) over the present ones; shift by 2πk into the start-pose window."""
    out = values.copy()
    ok = np.isfinite(values)
    if not ok.any():
        return out
    unwrapped = np.unwrap(values[ok])
    low = BRANCH_START[angle]
    shift = 2 * np.pi * np.floor((unwrapped[0] - low) / (2 * np.pi))
    out[ok] = unwrapped - shift
    return out


def resolve_points(
    tracks: list[Candidate], points: dict[str, str] | None
) -> dict[str, Candidate]:
    """Map engine parts to the file's points (``points=`` then names equal to the part).

    Error naming the missing part when a point an angle needs is not found.
    """
    mapping = check_mapping(points, ROLES, "points")
    chosen = resolve(tracks, mapping, ROLES, "points", "point")
    for angle, pairs in NEEDS.items():
        if any(a in chosen and b in chosen for a, b in pairs):
            continue
        a, b = pairs[0]
        missing = [r for r in (a, b) if r not in chosen]
        found = ", ".join(repr(c.label) for c in tracks) or "none"
        raise TrebuchetInputError(
            f"the angle {angle} needs the points {a} and {b}; no point for "
            f"{' and '.join(missing)} (points found: {found}); name it with "
            f"{Option.point(missing[0], '<point in the file>')}"
        )
    return chosen


def point_angles(
    positions: dict[str, tuple[np.ndarray, np.ndarray]],
) -> dict[str, np.ndarray]:
    """theta, psi, phi (rad, unwrapped, paper's branch) from positions ``{role: (x, y)}``, y up."""
    out: dict[str, np.ndarray] = {}
    for angle, pairs in NEEDS.items():
        for a, b in pairs:
            if a in positions and b in positions:
                out[angle] = paper_branch(angle, direction(*positions[a], *positions[b]))
                break
    return out
