"""Which frames get which of the scene's constraints, found from the pixel tracks.

At rest (before the trigger) the counterweight hangs plumb; in the trough (until the
lift-off) the projectile lies on the trough's level; in the sling (until the release) it
is L4 from the spigot. A log does not say when these end; the tracks show it: the
motion's onset, the stone's rise off the trough, its flight off the sling's circle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .track_flags import RAYLEIGH_MEDIAN

__all__ = ["onset", "rest_frames", "circle_centre", "sling_frames", "trough_frames",
           "FrameRoles", "frame_roles"]


def onset(d: np.ndarray, low: float, power: float) -> int:
    """Frame where a departure ``d`` (n,) from rest starts, for a departure growing like
    ``(t − t0)^power``: from the first frames ``a`` and ``b`` (three in a row) above ``low``
    and ``4 low``, ``t0 = (4^(1/power) a − b) / (4^(1/power) − 1)`` (earlier when it grows
    more slowly than that: on the safe side). ``d.size`` when it never departs."""
    def first_above(level: float) -> int | None:
        up = np.nan_to_num(d, nan=0.0) > level
        run = up[:-2] & up[1:-1] & up[2:]
        return int(np.flatnonzero(run)[0]) if run.any() else None

    a, b = first_above(low), first_above(4.0 * low)
    if a is None:
        return d.size
    if b is None:
        return a
    q = 4.0 ** (1.0 / power)
    return max(int(np.floor((q * a - b) / (q - 1.0))), 0)


def rest_frames(track: np.ndarray, frames: int = 5, z: float = 6.0) -> np.ndarray:
    """Frames before the engine first moves: ``track`` (n, 2) px of a moving point departs
    from its first ``frames`` positions by more than ``z`` noise sd (noise from the
    frame-to-frame steps there); the onset of that departure (quadratic: the beam's
    acceleration jumps at the trigger) ends the rest."""
    n = track.shape[0]
    ok = np.isfinite(track).all(axis=1)
    head = np.flatnonzero(ok)[:4 * frames]
    if head.size < 2 * frames:
        return np.zeros(n, bool)
    steps = np.hypot(*np.diff(track[head], axis=0).T)
    noise = max(float(np.median(steps)) / RAYLEIGH_MEDIAN / np.sqrt(2.0), 0.05)
    centre = np.median(track[head[:frames]], axis=0)
    first = onset(np.hypot(*(track - centre).T), max(z * noise, 1.0), 2.0)
    rest = np.zeros(n, bool)
    rest[:max(first - 1, 0)] = True
    rest &= ok
    return rest if rest.sum() >= frames else np.zeros(n, bool)


def circle_centre(track: np.ndarray) -> np.ndarray:
    """Centre (2,) px of the circle through a track (n, 2): linear least squares of
    ``x² + y² + D x + E y + F = 0`` (Kåsa), centre ``(−D/2, −E/2)``."""
    q = track[np.isfinite(track).all(axis=1)]
    A = np.column_stack([q[:, 0], q[:, 1], np.ones(len(q))])
    D, E, _ = np.linalg.lstsq(A, -(q[:, 0] ** 2 + q[:, 1] ** 2), rcond=None)[0]
    return np.array([-D / 2, -E / 2])


def sling_frames(obs: dict[str, np.ndarray], pivot: np.ndarray) -> np.ndarray:
    """Frames before the projectile flies off its sling's circle: the ratio
    |projectile − spigot| / |spigot − pivot| (pixels) rises for good above 1.1 × its
    median over the first half of the track."""
    n = obs["projectile"].shape[0]
    if "spigot" not in obs:
        return np.ones(n, bool)
    sling = np.hypot(*(obs["projectile"] - obs["spigot"]).T)
    beam = np.hypot(*(obs["spigot"] - pivot).T)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = sling / beam
    ok = np.flatnonzero(np.isfinite(ratio))
    if ok.size < 10:
        return np.ones(n, bool)
    level = float(np.median(ratio[ok[:ok.size // 2]]))
    near = ok[ratio[ok] <= 1.1 * level]
    last = near[-1] if near.size else -1
    out = np.ones(n, bool)
    if ok[-1] - last >= 5:                                       # a sustained final rise
        out[last + 1:] = False
    return out


def trough_frames(y: np.ndarray, rest: np.ndarray, tol: float) -> np.ndarray:
    """Frames from the start on which the projectile's height ``y`` (units of L1, trough at
    0) stays on the trough's level: until the onset of its rise above ``tol`` (cubic: at
    lift-off the trough's push falls to zero continuously)."""
    first = onset(y, tol, 3.0)
    out = np.zeros(y.size, bool)
    out[:max(first - 1, 0)] = True
    return out & (np.isfinite(y) | rest)


@dataclass(frozen=True)
class FrameRoles:
    """Which frames of a point log get which constraint of :func:`calibrate` ((n,) bool
    each): ``rest`` (the engine at rest), ``plumb`` (the counterweight hangs plumb: at rest,
    for a hinged arm), ``sling`` (the projectile L4 from the spigot), ``flight`` (on its
    parabola), ``trough`` (on the trough's level); ``tau`` (n,) s since the first flight
    frame."""

    rest: np.ndarray
    plumb: np.ndarray
    sling: np.ndarray
    flight: np.ndarray
    trough: np.ndarray
    tau: np.ndarray


def frame_roles(obs: dict[str, np.ndarray], n: int, hinged: bool, pivot_img: np.ndarray,
                *, g: float | None, t: np.ndarray | None, at_rest: np.ndarray | None,
                in_trough: np.ndarray | None, in_sling: np.ndarray | None,
                trough: bool) -> FrameRoles:
    """The :class:`FrameRoles` of the tracks ``obs`` (px, y up; n frames): as given, else
    found from the tracks; ``hinged``: the counterweight swings on a hinge (it hangs
    plumb at rest); ``g`` (m/s²) and ``t`` (s) for the stone's flight (None: not fitted);
    see :func:`~.calibration.calibrate`."""
    moving = next(obs[k] for k in ("spigot", "projectile", "counterweight", "hinge")
                  if k in obs)
    rest = np.asarray(at_rest, bool) if at_rest is not None else rest_frames(moving)
    sling = np.ones(n, bool)
    if "projectile" in obs:
        sling = (np.asarray(in_sling, bool) if in_sling is not None else
                 sling_frames(obs, pivot_img))
    flight = ~sling & (g is not None) & (t is not None)
    if "projectile" in obs and np.isfinite(obs["projectile"][flight]).all(axis=1).sum() < 5:
        flight[:] = False
    tau = np.zeros(n)
    if flight.any():
        tt = np.asarray(t, float)
        tau = tt - tt[np.flatnonzero(flight)[0]]                 # s since the first flight frame
    trough_mask = (np.asarray(in_trough, bool) if in_trough is not None
                   else (rest.copy() if trough and "projectile" in obs else np.zeros(n, bool)))
    plumb = rest if hinged else np.zeros(n, bool)  # a rigid arm does not hang plumb
    return FrameRoles(rest, plumb, sling, flight, trough_mask, tau)
