"""Tracked points that stand still while the engine moves: a tracker stuck on an occluder.

An uncorrected template tracker that slides onto something in front of a marker (the near
frame's leg, a post) stays there: its point stops while the beam swings on. Each point is
tied to another by a length of the engine (:data:`PARTNERS`: spigot and hinge on the
beam, counterweight L3 from the hinge, projectile L4 from the spigot). Over a window of
frames, a point that is frozen (its spread, the median distance from its median, within
the tracking noise), while its partner moves, and whose tie stretches off its median, is
*stuck*. A point that only stands still (the counterweight at the turn of its swing) keeps
its tie and is not. No scene is needed: the shares are of the log's own lengths, in any
unit, and the noise is the fixed pivot's scatter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .beam_hinge import beam_hinge
from .tie_fit import camera_terms, own_terms, robust_sd, trimmed_fit

__all__ = ["StuckRun", "stuck_runs", "OffEngine", "off_engine", "tracking_noise", "WINDOW",
           "STILL_SHARE"]

#: Frames in the sliding window (a stuck run shorter than this is not found).
WINDOW = 10
#: A point is frozen where its spread is at most this many noise sd plus
#: :data:`STILL_SHARE` of the beam's length...
NOISE_SPREADS = 3.0
STILL_SHARE = 0.001
#: ...while its partner's spread exceeds :data:`MOVING_RATIO` times its own and the
#: frozen limit (the tie's stretch is the evidence that they move apart).
MOVING_RATIO = 2.0


@dataclass(frozen=True)
class StuckRun:
    """Frames ``first``..``last`` (indices into the log, inclusive) where ``point`` stood
    still while ``reference`` moved; ``spread`` and ``moved``: the largest of their windows'
    spreads over the run (the file's unit)."""

    point: str
    reference: str
    first: int
    last: int
    spread: float
    moved: float


def _spread(xy: np.ndarray, lo: int, hi: int) -> float:
    """Median distance of the finite positions ``xy[lo:hi]`` from their median (robust to a
    mislocated position or two; NaN if fewer than half are finite)."""
    w = xy[lo:hi]
    ok = np.isfinite(w).all(axis=1)
    if ok.sum() < max(2, (hi - lo) // 2):
        return float("nan")
    d = w[ok] - np.median(w[ok], axis=0)
    return float(np.median(np.hypot(d[:, 0], d[:, 1])))


def tracking_noise(pivot: np.ndarray) -> float:
    """Robust sd per coordinate (file units) of the fixed pivot's scatter about its median:
    the tracker's noise on a still marker (0 for a tracker that finds it the same way in
    every frame)."""
    ok = np.isfinite(pivot).all(axis=1)
    if ok.sum() < 3:
        return 0.0
    d = pivot[ok] - np.median(pivot[ok], axis=0)
    return float(np.median(np.hypot(d[:, 0], d[:, 1]))) / float(np.sqrt(2.0 * np.log(2.0)))


def _held(xy: np.ndarray, first: int, last: int, tol: float) -> tuple[int, int]:
    """The run ``first``..``last`` trimmed to the frames where the point stands where it
    stood (within ``tol``; the windows that found it overlap its ends), then grown over the
    neighbouring frames where it still does (gaps skipped): the tie stretches only as the
    partner moves away, so the frozen stretch often starts earlier than the broken tie."""
    here = np.nanmedian(xy[first:last + 1], axis=0)

    def at(k: int) -> bool | None:
        if not np.isfinite(xy[k]).all():
            return None
        return bool(np.hypot(*(xy[k] - here)) <= tol)

    while first < last and at(first) is False:  # the windows overlap the run's ends
        first += 1
    while last > first and at(last) is False:
        last -= 1
    k = first - 1
    while k >= 0 and at(k) is not False:
        k -= 1
    first = k + 1
    k = last + 1
    while k < xy.shape[0] and at(k) is not False:
        k += 1
    return first, k - 1


#: Before it stands still, a template sliding onto an occluder drags its point off the
#: engine: the frames just before a stuck run whose tie is off by this share of its size
#: (and 5 noise sd) are the slide, and are left out with the run.
SLIDE_SHARE = 0.02
#: ...over at most this many frames (a stone in flight before a template stuck on
#: something keeps the rest of its flight).
SLIDE_FRAMES = 15


def _slid_from(d: np.ndarray, tie: float, first: int, limit: float) -> int:
    """The first frame of a stuck run starting at ``first`` grown back over the frames
    just before it whose tie ``d`` (per frame) lies further than ``limit`` from its median
    ``tie`` (gaps skipped): the template's slide onto what it sticks to (Kinovea's
    default tracker re-cuts its template on a frame leg over a dozen frames as the stone
    passes behind it; those frames are no sling angle, and were taken for the stone's
    flight)."""
    k = first - 1
    while k >= max(first - SLIDE_FRAMES, 0) and not (np.isfinite(d[k])
                                                     and abs(d[k] - tie) <= limit):
        k -= 1
    start = k + 1
    while start < first and not np.isfinite(d[start]):
        start += 1
    return start


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) of the runs of True."""
    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return []
    cuts = np.flatnonzero(np.diff(idx) > 1)
    starts = np.r_[idx[0], idx[cuts + 1]]
    ends = np.r_[idx[cuts], idx[-1]]
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


#: Each point and the one it is rigidly tied to: beam (spigot and hinge), arm L3, sling L4.
PARTNERS = (("hinge", "spigot"), ("spigot", "hinge"), ("counterweight", "hinge"),
            ("projectile", "spigot"))
#: The tie is broken where it leaves its median by this share of its size (and 5 noise sd).
TIE_SHARE = 0.05


def _tie(xy: dict[str, np.ndarray], point: str, ref: str) -> tuple[np.ndarray, float]:
    """The quantity the engine keeps constant between ``point`` and ``ref`` per frame, and its
    size (file units): on the beam, the hinge's distance from the line pivot-spigot (0 on a
    straight beam; a point frozen while the beam turns bends it); else their distance."""
    if {point, ref} == {"hinge", "spigot"}:
        arm = xy["spigot"] - xy["pivot"]
        short = xy["hinge"] - xy["pivot"]
        length = np.hypot(arm[:, 0], arm[:, 1])
        bend = (arm[:, 0] * short[:, 1] - arm[:, 1] * short[:, 0]) / length
        return bend, float(np.nanmedian(np.hypot(short[:, 0], short[:, 1])))
    d = np.hypot(*(xy[point] - xy[ref]).T)
    return d, float(np.nanmedian(d))


def stuck_runs(positions: dict[str, tuple[np.ndarray, np.ndarray]],
               window: int = WINDOW) -> list[StuckRun]:
    """Runs of frames where a tracked point stands still while the point it is tied to
    moves, and their distance (a length of the engine) breaks.

    ``positions``: ``{role: (x, y)}`` in the file's unit (``pivot`` and ``spigot`` needed,
    others optional), NaN in gaps. A point may stand still by itself (the counterweight at
    the turn of its swing), but not while its tie to a moving point stretches: that needs
    both.
    """
    if "pivot" not in positions or "spigot" not in positions:
        return []
    xy = {r: np.column_stack(p).astype(float) for r, p in positions.items()}
    arm = xy["spigot"] - xy["pivot"]
    beam = float(np.nanmedian(np.hypot(arm[:, 0], arm[:, 1])))
    if not np.isfinite(beam) or beam <= 0:
        return []
    n = arm.shape[0]
    sigma = tracking_noise(xy["pivot"])
    found = []
    for point, ref in PARTNERS:
        if point not in xy or ref not in xy:
            continue
        d, size = _tie(xy, point, ref)
        tie = float(np.nanmedian(d))
        broken = np.abs(d - tie) > max(5.0 * sigma, TIE_SHARE * size)
        stuck = np.zeros(n, bool)
        spreads = np.full(n, np.nan)
        moves = np.full(n, np.nan)
        for lo in range(0, n - window + 1):
            hi = lo + window
            s, m = _spread(xy[point], lo, hi), _spread(xy[ref], lo, hi)
            if not (np.isfinite(s) and np.isfinite(m)):
                continue
            still = s <= NOISE_SPREADS * sigma + STILL_SHARE * beam
            moving = m > max(MOVING_RATIO * s, NOISE_SPREADS * sigma + STILL_SHARE * beam)
            if moving and still and np.nanmean(broken[lo:hi]) >= 0.5:
                stuck[lo:hi] = True
                spreads[lo:hi] = np.fmax(spreads[lo:hi], s)
                moves[lo:hi] = np.fmax(moves[lo:hi], m)
        for first, last in _runs(stuck):
            first, last = _held(xy[point], first, last,
                                NOISE_SPREADS * sigma + STILL_SHARE * beam)
            first = _slid_from(d, tie, first, max(5.0 * sigma, SLIDE_SHARE * size))
            found.append(StuckRun(point, ref, first, last,
                                  float(np.nanmax(spreads[first:last + 1])),
                                  float(np.nanmax(moves[first:last + 1]))))
    return found


#: A tie further than this many robust sd (and :data:`OFF_SHARE` of its size) from the tie
#: the camera should show (:mod:`.tie_fit`) marks a position off the engine...
OFF_SD = 6.0
OFF_SHARE = 0.03
#: ...for the projectile only in runs of at most this many frames (a longer departure is
#: the stone in flight, cut by :mod:`.sling_circle`); the beam's and the arm's ties hold
#: in every phase.
OFF_RUN = 5


#: A run off the engine this long (frames) means the tracker has lost its marker: the
#: positions that follow on from it without a jump are still the wrong thing's.
LOST_RUN = 5
#: ...and it is back on its marker only after a jump followed by this many frames tracked on
#: the engine.
REACQUIRED = 10


def _lost_on(xy: np.ndarray, off: np.ndarray, dev: np.ndarray, limit: float) -> np.ndarray:
    """``off`` (n,) grown forward from each run of at least :data:`LOST_RUN` frames off (gaps
    between them do not break a run) over the
    positions ``xy`` (n, 2) that follow on from its last one without a jump back to the
    engine (a step of at least half the tie's deviation ``dev`` there, and ``limit``, then
    :data:`REACQUIRED` frames tracked and on the engine): a
    template that slid onto an occluder moves on with it, and where the engine swings back
    past it the tie may hold for a while by chance. Gaps are skipped (the step is taken
    across them)."""
    out = off.copy()
    n = xy.shape[0]
    missing = ~np.isfinite(xy).all(axis=1)
    for first, last in _runs(off | missing):  # a run broken only by gaps is one run
        hit = np.flatnonzero(off[first:last + 1])
        if hit.size < LOST_RUN:
            continue
        last = first + int(hit[-1])
        jump = max(0.5 * float(dev[last]), limit)
        prev, k = xy[last], last + 1
        while k < n:
            if not missing[k]:
                back = k + REACQUIRED
                if (np.hypot(*(xy[k] - prev)) >= jump and back <= n
                        and not (missing[k:back] | off[k:back]).any()):
                    break
                out[k] = True
                prev = xy[k]
            k += 1
    return out


@dataclass(frozen=True)
class OffEngine:
    """Frames ``first``..``last`` where ``point`` lies off the engine: its tie to
    ``partner`` leaves the tie the camera should show (:func:`.tie_fit.fitted_tie`) by
    ``largest`` (the file's unit), ``sd`` the robust sd of the tie about that fit."""

    point: str
    partner: str
    first: int
    last: int
    largest: float
    sd: float


def _ties(xy: dict[str, np.ndarray]) -> tuple[dict[str, tuple[np.ndarray, float, float]],
                                               object]:
    """Each point's tie less the tie the camera should show there (:mod:`.tie_fit`: the
    pivot–spigot distance fits the camera, the counterweight's distance from the hinge
    only its own length on top of it, the stone's its own terms; the hinge's bend from the
    beam's line, which a camera keeps straight, its median), the residual's robust sd and
    the tie's size (the file's unit); and the hinge the beam puts there
    (:func:`.beam_hinge.beam_hinge`, or None)."""
    pivot, spigot = xy["pivot"], xy["spigot"]
    arm = spigot - pivot
    length = np.hypot(arm[:, 0], arm[:, 1])
    beam_size = float(np.nanmedian(length))
    if not np.isfinite(beam_size) or beam_size <= 0:
        beam_size = 1.0
    centre = np.nanmedian(pivot, axis=0)
    beam = trimmed_fit(length, np.column_stack([np.ones(length.size),
                                                camera_terms(arm, 0.5 * arm, beam_size)]))
    out = {"spigot": (length - beam.expected, beam.sd, beam_size)}
    lens = beam.coef[1:] if beam.coef.size == 5 else np.zeros(4)  # too few frames: none
    if "hinge" in xy:
        bend, size = _tie(xy, "hinge", "spigot")
        out["hinge"] = (bend - np.nanmedian(bend),
                        robust_sd(np.where(np.abs(bend) < 0.1 * size, bend, np.nan)), size)
    hinge = None
    if "counterweight" in xy and "hinge" in xy:
        # the hinge the beam puts there (tracked where it agrees): a hinge hidden or off its
        # marker neither hides nor fakes a counterweight off its arm
        hinge = beam_hinge(pivot, spigot, xy["hinge"])
        anchor = xy["hinge"] if hinge is None else hinge.xy
        seg = xy["counterweight"] - anchor
        d = np.hypot(seg[:, 0], seg[:, 1])
        camera = camera_terms(seg, anchor + 0.5 * seg - centre, beam_size) @ lens
        fit = trimmed_fit(d, np.ones((d.size, 1)), offset=camera)
        out["counterweight"] = (d - fit.expected, fit.sd, float(np.nanmedian(d)))
    if "projectile" in xy:
        seg = xy["projectile"] - spigot
        d = np.hypot(seg[:, 0], seg[:, 1])
        fit = trimmed_fit(d, own_terms(seg, spigot + 0.5 * seg - centre, beam_size))
        out["projectile"] = (d - fit.expected, fit.sd, float(np.nanmedian(d)))
    return out, hinge


def off_engine(positions: dict[str, tuple[np.ndarray, np.ndarray]]) -> list[OffEngine]:
    """Runs of frames where one tracked point lies off the engine's geometry as the camera
    draws it (a template matched on an occluder or another marker), each blamed on the
    point whose own ties break: the spigot if its distance from the pivot (L1) breaks, the
    hinge if only the beam bends, the counterweight if only L3 stretches, the projectile if
    only L4 does (a spike, not the stone's flight). A tie breaks where it leaves the tie the
    camera's perspective and lens allow (:mod:`.tie_fit`: smooth in the segment's
    direction and position), not its median. ``positions`` as for :func:`stuck_runs`."""
    if "pivot" not in positions or "spigot" not in positions:
        return []
    xy = {r: np.column_stack(p).astype(float) for r, p in positions.items()}
    n = xy["pivot"].shape[0]
    ties, beam = _ties(xy)
    partners = {"spigot": "pivot", "hinge": "spigot", "counterweight": "hinge",
                "projectile": "spigot"}
    bad: dict[str, np.ndarray] = {}
    limits = {}
    for point, (residual, sd, size) in ties.items():
        limits[point] = max(OFF_SD * sd if np.isfinite(sd) else 0.0, OFF_SHARE * size)
        bad[point] = np.nan_to_num(np.abs(residual) > limits[point], nan=False)
    # blame the point whose own tie breaks, not the partner it drags along
    if "hinge" in bad:
        bad["hinge"] &= ~bad["spigot"]
    if "counterweight" in bad and "hinge" in bad and beam is None:
        bad["counterweight"] &= ~bad["hinge"]
    if "projectile" in bad:
        bad["projectile"] &= ~bad["spigot"]
    for point, mask in bad.items():
        if point != "projectile":
            bad[point] = _lost_on(xy[point], mask, np.abs(ties[point][0]), limits[point])
    found = []
    for point, mask in bad.items():
        residual, sd, _ = ties[point]
        for first, last in _runs(mask):
            if point == "projectile" and last - first + 1 > OFF_RUN:
                continue  # the stone in flight leaves its sling's circle for good
            found.append(OffEngine(point, partners[point], first, last,
                                   float(np.nanmax(np.abs(residual[first:last + 1]))),
                                   sd))
    return sorted(found, key=lambda o: (o.first, o.point)) if n else []
