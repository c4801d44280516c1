"""Marker tracking by template matching, set up as a careful user would.

The user clicks each marker on the first frame only (``clicks``, px); that is the one time
the truth is read. From then on each point is found by normalised cross-correlation
(``cv2.matchTemplate``, ``TM_CCOEFF_NORMED``) of the template cut around the click
(masked to the disk of the ringed marker), in a
search window around a constant-velocity prediction from the last two good positions, with
a parabolic sub-pixel peak. The peak's correlation is the position's score (DeepLabCut's
likelihood in the export). Below ``lost_score`` the point is taken as lost for that frame:
its reported position is the best match anyway (as a tracker reports one), but the next
search starts from the prediction, coasting on the last velocity (at most
:data:`COAST_FRAMES` frames), in a window that widens frame by frame up to
``max_search_px``; no match is taken on top of another tracked marker (they look alike).
With ``update_rate > 0`` the template drifts toward each good match (Kinovea-like adaptive
tracking: it follows motion blur, and can slide onto an occluding member and stay there).
With ``recut_score`` set (Kinovea's default tracker, left unedited), a match that scores
below it but at least ``lost_score`` is taken as found and the template is cut anew
there: when a marker passes behind a frame member, the new template is the member's, which
then matches perfectly where it stands, and the point stays stuck on the member.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["TrackerSettings", "track_points", "template_half_size", "template_mask",
           "peak_offset"]


@dataclass(frozen=True)
class TrackerSettings:
    """``search_px``: search radius (px) around the prediction, plus ``speed_factor`` × the
    last step (px per frame), widened by ``search_px`` for every frame the point has been
    lost, up to ``max_search_px``; ``lost_score``: below it the point is lost this frame (a
    partly hidden marker scores 0.6–0.8, and so do look-alike spots of the background);
    ``update_rate``: blend of a good match into the template (0: the clicked template
    only); ``update_score``: a match good enough to update the template; ``recut_score``:
    a match below it (and at least ``lost_score``) replaces the template by the patch
    there (None: never; Kinovea's default re-cuts so); ``recut_lost``: a point below
    ``lost_score`` is not lost but found at its best match, whose patch becomes the
    template (a tracker that never lets go: behind a frame member it takes the member)."""

    search_px: float = 6.0
    speed_factor: float = 0.75
    max_search_px: float = 15.0
    lost_score: float = 0.8
    update_rate: float = 0.0
    update_score: float = 0.8
    recut_score: float | None = None
    recut_lost: bool = False


def template_half_size(marker_px: float) -> int:
    """Half-width (px) of a template around a marker of radius ``marker_px`` (px): the ringed
    marker (radius 1.5 ``marker_px``) and a band of 2 px around it."""
    return int(np.ceil(1.5 * marker_px + 2.0))


def template_mask(half: int, marker_px: float) -> np.ndarray:
    """Disk mask (float32, 1 inside) of the template: the ringed marker to its anti-aliased
    edge (0.5 px beyond the ring), so that the beam or sling leaving the marker does not count
    (the match does not change as they turn)."""
    size = 2 * half + 1
    mask = np.zeros((size, size), np.float32)
    radius = min(1.5 * marker_px + 0.5, half + 0.5)
    cv2.circle(mask, (half * 16, half * 16), int(round(radius * 16)), 1.0, -1, cv2.LINE_8, 4)
    return mask


def peak_offset(scores: np.ndarray, i: int, j: int) -> tuple[float, float]:
    """Sub-pixel offset (dx, dy) of the peak at row ``i``, column ``j`` of a score map, from a
    parabola through it and its neighbours in each direction (0 at an edge)."""

    def vertex(a: float, b: float, c: float) -> float:
        d = a - 2.0 * b + c
        return 0.0 if d >= 0 else float(np.clip(0.5 * (a - c) / d, -0.5, 0.5))

    h, w = scores.shape
    dx = vertex(scores[i, j - 1], scores[i, j], scores[i, j + 1]) if 0 < j < w - 1 else 0.0
    dy = vertex(scores[i - 1, j], scores[i, j], scores[i + 1, j]) if 0 < i < h - 1 else 0.0
    return dx, dy


#: Frames a lost point's prediction is carried on at its last velocity (a marker behind a
#: frame member keeps moving); beyond them the prediction stays put.
COAST_FRAMES = 30


@dataclass
class _Point:
    """Tracking state of one point (mutable, private to :func:`track_points`)."""

    template: np.ndarray
    offset: np.ndarray  # click minus the template's centre pixel, px
    good: np.ndarray  # last good position, px
    velocity: np.ndarray  # px per frame
    lost: int = 0  # frames since the last good match

    @property
    def prediction(self) -> np.ndarray:
        """Where the point should be in the next frame (constant velocity, extrapolated over
        at most :data:`COAST_FRAMES` frames since the last good match), px."""
        return self.good + self.velocity * min(self.lost + 1, COAST_FRAMES)


def track_points(frames: Iterable[np.ndarray], clicks: np.ndarray, marker_px: float,
                 settings: TrackerSettings = TrackerSettings()) -> tuple[np.ndarray, np.ndarray]:
    """Positions (px, (n_frames, k, 2), u right, v down) and scores ((n_frames, k), the peak
    correlation) of ``k`` points clicked at ``clicks`` (px, (k, 2)) on the first frame. Where
    the search window leaves the image the position is the prediction clipped to the image
    and the score 0 (a tracker always reports a position, as DeepLabCut does)."""
    half = template_half_size(marker_px)
    mask = template_mask(half, marker_px)
    points: list[_Point] = []
    positions: list[np.ndarray] = []
    scores: list[np.ndarray] = []
    for n, frame in enumerate(frames):
        image = frame.astype(np.float32)
        if n == 0:
            for c in np.asarray(clicks, dtype=float):
                centre = np.round(c).astype(int)
                patch = _patch(image, centre, half)
                if patch is None:
                    raise ValueError(f"click {c} too near the image's edge for a template")
                points.append(_Point(patch, c - centre, c.copy(), np.zeros(2)))
            positions.append(np.asarray(clicks, dtype=float).copy())
            scores.append(np.ones(len(points)))
            continue
        here = np.full((len(points), 2), np.nan)
        score = np.zeros(len(points))
        for i, p in enumerate(points):
            others = np.array([q.good for q in points if q is not p])
            found = _search(image, p, half, mask, settings, others, 3.0 * marker_px)
            if found is None:  # off the image: report the prediction, score 0
                here[i] = np.clip(p.prediction, 0.0, np.array(image.shape[::-1]) - 1.0)
                p.lost += 1
                continue
            here[i], score[i] = found
            if settings.recut_lost and score[i] < settings.lost_score:
                patch = _patch(image, np.round(here[i] - p.offset).astype(int), half)
                if patch is not None:
                    p.template = patch
                p.velocity = (here[i] - p.good) / (p.lost + 1)
                p.good, p.lost = here[i], 0
            elif score[i] >= settings.lost_score:
                p.velocity = (here[i] - p.good) / (p.lost + 1)
                p.good = here[i]
                p.lost = 0
                if settings.recut_score is not None and score[i] < settings.recut_score:
                    patch = _patch(image, np.round(here[i] - p.offset).astype(int), half)
                    if patch is not None:
                        p.template = patch
                elif settings.update_rate > 0 and score[i] >= settings.update_score:
                    patch = _patch(image, np.round(here[i] - p.offset).astype(int), half)
                    if patch is not None:
                        p.template = ((1 - settings.update_rate) * p.template
                                      + settings.update_rate * patch)
            else:
                p.lost += 1
        positions.append(here)
        scores.append(score)
    return np.array(positions), np.array(scores)


def _patch(image: np.ndarray, centre: np.ndarray, half: int) -> np.ndarray | None:
    """The (2 half + 1)² patch of ``image`` centred on pixel ``centre``, None off the image."""
    x, y = int(centre[0]), int(centre[1])
    h, w = image.shape
    if x - half < 0 or y - half < 0 or x + half >= w or y + half >= h:
        return None
    return image[y - half:y + half + 1, x - half:x + half + 1].copy()


def _search(image: np.ndarray, p: _Point, half: int, mask: np.ndarray,
            settings: TrackerSettings, others: np.ndarray,
            keep_off: float) -> tuple[np.ndarray, float] | None:
    """Best match (px) and its score around the point's prediction, None if the window
    holds no whole template. Matches within ``keep_off`` px of the other points' last good
    positions (``others``, (m, 2)) are not taken: the markers look alike."""
    guess = p.prediction
    if not np.isfinite(guess).all():
        return None
    base = settings.search_px + settings.speed_factor * float(np.linalg.norm(p.velocity))
    radius = min(base + settings.search_px * p.lost, max(base, settings.max_search_px))
    h, w = image.shape
    centre = np.round(guess - p.offset).astype(int)
    r = int(np.ceil(radius))
    x0, y0 = max(centre[0] - r - half, 0), max(centre[1] - r - half, 0)
    x1, y1 = min(centre[0] + r + half + 1, w), min(centre[1] + r + half + 1, h)
    if x1 - x0 < 2 * half + 1 or y1 - y0 < 2 * half + 1:
        return None
    result = cv2.matchTemplate(image[y0:y1, x0:x1], p.template.astype(np.float32),
                               cv2.TM_CCOEFF_NORMED, mask=mask)
    result = np.nan_to_num(result, nan=-1.0, posinf=-1.0, neginf=-1.0)
    if len(others):
        cols = x0 + half + p.offset[0] + np.arange(result.shape[1])
        rows = y0 + half + p.offset[1] + np.arange(result.shape[0])
        for o in others:
            near = (rows[:, None] - o[1]) ** 2 + (cols[None, :] - o[0]) ** 2 < keep_off**2
            result[near] = -1.0
    _, best, _, (j, i) = cv2.minMaxLoc(result)
    dx, dy = peak_offset(result, i, j)
    position = np.array([x0 + j + half + dx, y0 + i + half + dy]) + p.offset
    return position, float(best)
