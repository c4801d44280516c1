"""Tracked points that break the engine's geometry: outliers and stuck tracks.

After the calibration every tracked position has a residual, the pixel distance between
where the tracker put the point and where the fitted engine puts it. With the random
noise ``σ`` px per coordinate that distance follows a Rayleigh law (median 1.18 σ); a
position further than ``threshold`` σ (and ``min_px``) is off the engine, if it is the
frame's worst (one wrong point drags the fitted engine, and so its neighbours'
residuals, with it: the caller refits and looks again). Runs of such
frames (joined across short breaks) become gaps. A run whose tracked positions stand
still (within a few σ of their median) while the engine's point moves is a *stuck* track
(the tracker held on an occluder): it is extended to every neighbouring frame where the
track still stands there, since those positions are the occluder's too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["FlaggedTrack", "RAYLEIGH_MEDIAN", "outlier_limit", "flag_tracks"]

#: Median of the distance of a 2-D Gaussian error of unit sd per coordinate: √(2 ln 2).
RAYLEIGH_MEDIAN = float(np.sqrt(2.0 * np.log(2.0)))


@dataclass(frozen=True)
class FlaggedTrack:
    """Frames ``first``..``last`` (inclusive, indices into the log) of ``point`` taken out
    of the fit: ``kind`` "stuck" (the track stands still while the engine moves) or
    "outlier" (off the engine's geometry: jumped, swapped, hidden); ``largest_px`` its
    largest residual; ``note`` says so in a sentence."""

    point: str
    first: int
    last: int
    kind: str
    largest_px: float
    note: str


def _runs(mask: np.ndarray, join: int) -> list[tuple[int, int]]:
    """(first, last) of the runs of True in ``mask``, joining runs separated by at most
    ``join`` False frames."""
    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return []
    breaks = np.flatnonzero(np.diff(idx) > join + 1)
    starts = np.concatenate([[idx[0]], idx[breaks + 1]])
    ends = np.concatenate([idx[breaks], [idx[-1]]])
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


def outlier_limit(noise_px: float, threshold: float = 6.0, min_px: float = 2.0) -> float:
    """The residual (px) beyond which a position is off the engine."""
    return max(threshold * noise_px, min_px)


def flag_tracks(observed: dict[str, np.ndarray], predicted: dict[str, np.ndarray],
                noise_px: float, threshold: float = 6.0, min_px: float = 2.0,
                join: int = 2, culprits: dict[str, np.ndarray] | None = None
                ) -> tuple[tuple[FlaggedTrack, ...], dict[str, np.ndarray]]:
    """Flag the positions of each point that break the engine's geometry.

    ``observed`` and ``predicted`` (n, 2) px per point (NaN where not tracked), ``noise_px``
    the random noise sd per coordinate. ``culprits`` (n,) per point: the positions found
    to blame (by leaving each point out of its frame's fit); without them each frame's
    worst residual beyond the limit. Returns the flagged runs and, per point, the (n,)
    mask of the positions to treat as gaps.
    """
    flagged: list[FlaggedTrack] = []
    gaps: dict[str, np.ndarray] = {}
    limit = outlier_limit(noise_px, threshold, min_px)
    still = max(4.0 * noise_px, 1.0)                                 # a stuck track's spread
    names = list(observed)
    dists = np.array([np.nan_to_num(np.hypot(*(observed[k] - predicted[k]).T), nan=0.0)
                      for k in names])                               # residuals, px
    worst = np.argmax(dists, axis=0)                                 # each frame's worst
    for i, name in enumerate(names):
        obs = observed[name]
        dist = np.hypot(*(obs - predicted[name]).T)
        bad = (culprits[name] if culprits is not None else
               (dists[i] > limit) & (worst == i))
        gap = np.zeros(obs.shape[0], bool)
        for a, b in _runs(bad, join):
            seg = obs[a:b + 1]
            ok = np.isfinite(seg).all(axis=1)
            centre = np.median(seg[ok], axis=0)
            spread = np.hypot(*(seg[ok] - centre).T)
            pred = predicted[name][a:b + 1][ok]
            moved = np.hypot(*(pred - pred[0]).T)                    # the engine's point
            stuck = bool(np.quantile(spread, 0.9) < still and moved.max() > limit)
            if stuck:  # extend to the neighbouring frames where the track stands there too
                near = np.hypot(*(obs - centre).T) < still
                while a > 0 and near[a - 1]:
                    a -= 1
                while b + 1 < obs.shape[0] and near[b + 1]:
                    b += 1
            gap[a:b + 1] = True
            largest = float(np.nanmax(dist[a:b + 1]))
            how = (f"up to {largest:.1f} px away" if largest > limit else
                   "the frame's other points fit only without it")
            if stuck:
                note = (f"{name}: stuck at ({centre[0]:.0f}, {centre[1]:.0f}) px in frames "
                        f"{a}-{b} while the engine moves ({how}); treated as a gap")
            else:
                note = (f"{name}: off the engine's geometry in frames {a}-{b} ({how}; "
                        f"jumped, swapped or hidden?); treated as a gap")
            flagged.append(FlaggedTrack(name, a, b, "stuck" if stuck else "outlier",
                                        largest, note))
        gaps[name] = gap
    return tuple(flagged), gaps
