"""The units a file does not state, decided for :func:`read_log` with a sentence each.

* :func:`angle_units`: unit-less angle columns (Tracker's θ in degrees or radians by its
  preference, a plain CSV's ``theta``) in the unit of ``angle_unit=`` or decided from the
  values (:func:`~trebuchet.ingest.readers.units.decide_angle_unit`: the beam's sweep);
* :func:`rate_check`: a file's own rate column (Tracker's ω) must be dθ/dt in the unit the
  angle is read in, per second of the time read: it confirms the time unit (not the angle
  unit, ω scaling with θ);
* :func:`y_axis`: point files whose y direction the file does not say (Kinovea's world
  space, y up, and image space, y down, share one header): the counterweight hangs below
  its hinge at rest.
"""

from __future__ import annotations

import numpy as np

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.readers.units import ANGLE_UNITS, decide_angle_unit

#: The ratio of a rate column to dθ/dt that confirms the time unit (both ways).
RATE_AGREEMENT = 1.5
#: First frames with hinge and counterweight taken as the engine at rest.
REST_FRAMES = 10


def angle_units(raw: dict[str, np.ndarray], labels: dict[str, str], unitless: frozenset[str],
                angle_unit: str | None
                ) -> tuple[dict[str, np.ndarray], list[str], dict[str, float]]:
    """The angles in rad, the decision sentences and each column's factor to rad. ``raw``
    are the chosen columns' values (rad for stated units, as written for the labels in
    ``unitless``)."""
    mine = [a for a in raw if labels[a] in unitless]
    stated = [f"'{labels[a]}'" for a in raw if a not in mine]
    decisions = [f"angle units stated in the headers of {', '.join(stated)}"] if stated else []
    if not mine:
        return raw, decisions, {}
    shown = ", ".join(f"'{labels[a]}'" for a in mine)
    if angle_unit is not None:
        unit, how = angle_unit, f"angle_unit={angle_unit!r}"
    else:
        first = mine[0]
        unit, how = decide_angle_unit((labels[first], raw[first]), [raw[a] for a in mine])
    factor = ANGLE_UNITS[unit]
    out = {a: (v * factor if a in mine else v) for a, v in raw.items()}
    decisions.append(f"angle unit of {shown}: {unit} ({how})")
    return out, decisions, {a: factor for a in mine}


def rate_check(t: np.ndarray, angles: dict[str, np.ndarray], labels: dict[str, str],
               rates: dict, factors: dict[str, float]) -> str | None:
    """Check a rate column against the angle it is the rate of; a sentence, or an error
    when the two disagree (the time is then not in s). ``angles`` in rad, ``t`` in s;
    ``factors``: rad per unit of each angle's column as written (its rate's too)."""
    for a, values in angles.items():
        getter = rates.get(labels[a])
        if getter is None:
            continue
        rate = getter()
        ok = np.isfinite(values) & np.isfinite(t)
        if ok.sum() < 5:
            continue
        d = np.full(values.shape, np.nan)
        d[ok] = np.gradient(np.unwrap(values[ok]), t[ok])
        both = np.isfinite(d) & np.isfinite(rate)
        if both.sum() < 5 or not np.any(d[both]):
            continue
        scaled = rate[both] * factors.get(a, 1.0)
        # the median ratio where the angle moves: one bad cell (whose derivative is huge on
        # two frames) does not sway it, as it sways a least-squares fit
        moving = np.abs(d[both]) >= 0.2 * np.percentile(np.abs(d[both]), 90)
        ratio = float(np.median(scaled[moving] / d[both][moving]))
        if ratio > 0 and 1 / RATE_AGREEMENT <= ratio <= RATE_AGREEMENT:
            return (f"time unit confirmed: the rate column beside '{labels[a]}' is "
                    f"d{a}/dt per s of the time read (ratio {ratio:.3g})")
        raise TrebuchetInputError(
            f"the rate column beside '{labels[a]}' is {ratio:.4g} × d{a}/dt per s of the "
            "time read: the time is not in s (or the column is no rate of it); state the "
            "time unit with time_unit=")
    return None


def y_axis(positions: dict[str, tuple[np.ndarray, np.ndarray]]
           ) -> tuple[bool, str]:
    """(whether y points down, the decision) from the counterweight hanging below its hinge
    over the first frames where both are present."""
    if "hinge" not in positions or "counterweight" not in positions:
        raise TrebuchetInputError(
            "the file does not say which way its y axis points (a Kinovea export in world "
            "or image space), and without the hinge and the counterweight the engine cannot "
            "tell; name them with points=")
    hx, hy = positions["hinge"]
    cx, cy = positions["counterweight"]
    ok = np.nonzero(np.isfinite(hx) & np.isfinite(hy) & np.isfinite(cx) & np.isfinite(cy))[0]
    first = ok[:REST_FRAMES]
    if not first.size:
        raise TrebuchetInputError("no frame with both the hinge and the counterweight")
    dx = float(np.mean(cx[first] - hx[first]))
    dy = float(np.mean(cy[first] - hy[first]))
    if abs(dy) <= abs(dx):
        raise TrebuchetInputError(
            "the file does not say which way its y axis points, and the counterweight does "
            "not hang below or above its hinge over the first frames (the engine at rest)")
    if dy > 0:
        return True, (f"y axis: down, image space (inferred: the counterweight hangs above "
                      f"its hinge in the file's coordinates over the first {first.size} "
                      "frames); turned up")
    return False, (f"y axis: up, world space (checked: the counterweight hangs below its "
                   f"hinge over the first {first.size} frames)")
