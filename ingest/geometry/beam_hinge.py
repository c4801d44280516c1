"""The hinge where the beam puts it: a tracked hinge checked against, and filled from, the
beam's other two points.

Pivot, spigot and hinge lie on one rigid beam (:mod:`trebuchet.model.kinematics`:
``r_H − r_P = −(L2/L1) (r_S − r_P)``). In the image, with ``u = s − p`` the tracked spigot
less the tracked pivot and ``u⊥`` it turned by +90°, the tracked hinge is

    h − p = a u + b u⊥ + c

``a = −L2/L1`` and ``b = 0`` for markers on the beam's axis seen square on; ``c`` (px, or
the file's unit) takes the constant offsets of the three markers (a template's, a click's),
which stay fixed in the image while the beam turns. A camera that views the engine's plane
at an angle (tilt, roll) foreshortens the beam differently in each direction: to first
order ``a`` and ``b`` are linear in ``cos ϑ`` and ``sin ϑ`` (ϑ the image direction of
``u``), which is the model fitted here (8 numbers; iteratively trimmed least squares over
the frames where all three points are tracked, so a hinge that is hidden or slid off its
marker in some frames does not pull the fit).

The fitted hinge has the spigot's and pivot's noise scaled down by ``L2/L1`` and none of
the hinge's own excursions. It replaces the tracked hinge where that one is missing (a
gap of the tracker) or lies further than :data:`OFF_SD` robust sd of the fit's residual
(and :data:`OFF_SHARE` of the beam's length) from it: a marker partly hidden by a frame
member, which a template tracker still finds (with a lower score) but pulled towards the
edge of what hides it. Elsewhere the tracked hinge is kept as it is.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trebuchet.ingest.readers.table import format_rows

__all__ = ["BeamHinge", "beam_hinge", "OFF_SD", "OFF_SHARE", "MIN_FRAMES", "hinge_note"]

#: A tracked hinge this many robust sd (per coordinate) of the fit's residual from the
#: fitted one is off its marker...
OFF_SD = 4.0
#: ...and at least this share of the beam's length (pivot to spigot) away.
OFF_SHARE = 0.001
#: Fewest frames with pivot, spigot and hinge tracked for a fit (8 numbers).
MIN_FRAMES = 30
#: Rounds of the trimmed least squares, and the trim (robust sd of the residual).
ROUNDS = 5
TRIM_SD = 4.0


@dataclass(frozen=True)
class BeamHinge:
    """The hinge (n, 2) the beam gives in every frame where pivot and spigot are tracked
    (``fitted``), the hinge to use (``xy``: tracked, or fitted where ``filled`` or
    ``replaced``), ``filled`` (n,) frames where the tracker had no hinge, ``replaced`` (n,)
    where its hinge lay off the beam's (by up to ``largest``), ``sd`` the fit's robust
    residual sd per coordinate and ``limit`` the distance beyond which a hinge is off (the
    file's unit)."""

    fitted: np.ndarray
    xy: np.ndarray
    filled: np.ndarray
    replaced: np.ndarray
    sd: float
    limit: float
    largest: float


def _design(u: np.ndarray) -> np.ndarray:
    """Rows (2n, 8) of ``h − p = (a0 + a1 cos ϑ + a2 sin ϑ) u + (b0 + …) u⊥ + c``: x rows,
    then y rows."""
    n = u.shape[0]
    v = np.column_stack([-u[:, 1], u[:, 0]])
    th = np.arctan2(u[:, 1], u[:, 0])
    cols = []
    for f in (np.ones(n), np.cos(th), np.sin(th)):
        cols += [f[:, None] * u, f[:, None] * v]
    cols += [np.tile([1.0, 0.0], (n, 1)), np.tile([0.0, 1.0], (n, 1))]
    return np.concatenate([np.column_stack([c[:, 0] for c in cols]),
                           np.column_stack([c[:, 1] for c in cols])])


def beam_hinge(pivot: np.ndarray, spigot: np.ndarray, hinge: np.ndarray) -> BeamHinge | None:
    """The hinge of the rigid beam through the tracked ``pivot`` and ``spigot`` ((n, 2), any
    length unit, NaN in gaps), fitted to the tracked ``hinge`` (module doc); None with fewer
    than :data:`MIN_FRAMES` frames where all three are tracked."""
    pivot, spigot, hinge = (np.asarray(a, dtype=float) for a in (pivot, spigot, hinge))
    n = pivot.shape[0]
    u = spigot - pivot
    M = _design(np.nan_to_num(u))
    y = np.concatenate([(hinge - pivot)[:, 0], (hinge - pivot)[:, 1]])
    beam_ok = np.isfinite(u).all(axis=1)
    both = beam_ok & np.isfinite(hinge).all(axis=1)
    if both.sum() < MIN_FRAMES:
        return None
    use = np.r_[both, both]
    y0 = np.nan_to_num(y)
    sd = np.inf
    for _ in range(ROUNDS):
        coef = np.linalg.lstsq(M[use], y0[use], rcond=None)[0]
        r = np.abs(y0 - M @ coef)
        sd = float(1.4826 * np.median(r[np.r_[both, both]]))
        keep = np.r_[both, both] & (r <= TRIM_SD * max(sd, 1e-12))
        frames = keep[:n] & keep[n:]
        if frames.sum() < MIN_FRAMES:
            break
        use = np.r_[frames, frames]
    pred = M @ coef
    fitted = pivot + np.column_stack([pred[:n], pred[n:]])
    fitted[~beam_ok] = np.nan
    beam = float(np.nanmedian(np.hypot(u[:, 0], u[:, 1])))
    limit = max(OFF_SD * sd * np.sqrt(2.0), OFF_SHARE * beam)
    dist = np.hypot(*(hinge - fitted).T)
    replaced = both & (dist > limit)
    filled = beam_ok & ~np.isfinite(hinge).all(axis=1)
    xy = hinge.copy()
    xy[replaced | filled] = fitted[replaced | filled]
    largest = float(dist[replaced].max()) if replaced.any() else 0.0
    return BeamHinge(fitted, xy, filled, replaced, sd, limit, largest)


def hinge_note(fit: BeamHinge, rows: np.ndarray, label: str) -> str | None:
    """The repair note for the hinge positions ``fit`` took from the beam (None if none):
    ``rows`` the log's row numbers, ``label`` the hinge's point name in the file."""
    parts = []
    if fit.replaced.any():
        parts.append(f"{int(fit.replaced.sum())} tracked positions further than "
                     f"{fit.limit:.3g} (up to {fit.largest:.3g}) from the beam's line in "
                     f"{format_rows(rows[fit.replaced])} (partly hidden?)")
    if fit.filled.any():
        parts.append(f"{int(fit.filled.sum())} missing ones in "
                     f"{format_rows(rows[fit.filled])}")
    if not parts:
        return None
    return (f"hinge ('{label}'): {' and '.join(parts)} taken from the beam through pivot and "
            f"spigot (fitted to the tracked hinge, residual sd {fit.sd:.2g}) for psi")
