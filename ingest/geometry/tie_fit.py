"""The engine's ties as a camera draws them: what a rigid segment's image length may do.

Two tracked points of a rigid engine keep their distance (pivot–spigot L1, hinge–
counterweight L3, spigot–projectile L4 in the sling). In the image they keep it only for a
camera square to the engine's plane with a perfect lens. Seen at an angle, the plane's
map to the image (a homography ``x ↦ X = (A x + b) / (1 + cᵀ x)`` from the image back to
the plane, then the lens) stretches a segment by a factor that depends on its direction
and on where it lies: to first order in ``c``,
``log ℓ ≈ log L − ½ log(e_βᵀ AᵀA e_β) + cᵀ x`` (``e_β`` the segment's image direction,
``x`` its midpoint): second harmonics of ``β`` (the affine part's anisotropy) and a
gradient across the image, the same for every segment of the engine. So one camera
model, ``log ℓ = log L + a₂ cos 2β + b₂ sin 2β + c_u u + c_v v`` (``u, v`` the midpoint
from the pivot in beam lengths), is fitted on the pivot–spigot distance, whose long arm
sweeps the camera's directions and whose pivot stands still (a wrong match there is a
short spike, a frozen spigot is :func:`~.stuck_points.stuck_runs`' to find), and each other
tie gets only its own length ``L`` on top of it: a counterweight track that stuck on a
frame member (its distance from the hinge then changes by tens of per cent) cannot pass
for perspective. The stone's tie, whose wrong matches are flagged only as spikes of a few
frames, gets the model's terms of its own (the gradient across its long reach is poorly
pinned by the beam's circle).

Measured on the video bench's cameras (``bench/video``: the paper's engine 40 m away, the
backyard engine at 6.6 m, the small fast one at 5 m; pitch up to 15°, roll 1°, k1 to
−0.08) on the true pixels: the pivot–spigot distance varies by up to 9 % and leaves the
model by at most 0.01 %; the counterweight's by up to 7.4 %, off the model by at most
1.3 %; the stone's by up to 16.7 %, off its own model by at most 3.8 %. On the tilted
sample (``data_samples/video_tilted_dlc.csv``: 10° pitch, k1 −0.03) the pivot–spigot
distance shrinks smoothly from 175.6 px at rest to 168.4 px at the release, 4 % of it:
against the median that was "a tracker's wrong match" in rows 233–267.

The fits are iteratively trimmed least squares over the frames (a wrong match or a stuck
run, a few per cent of the frames, does not pull them), in ``log ℓ``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["robust_sd", "camera_terms", "own_terms", "trimmed_fit", "TieFit", "ROUNDS",
           "TRIM_SD", "START_SHARE"]

#: Rounds of the trimmed least squares, and the trim (robust sd of the residual).
ROUNDS = 8
TRIM_SD = 4.0
#: The first round keeps frames within this share (in log ℓ) of the tie's median (a stone
#: in flight, a template on another marker are further); later rounds trim by sd.
START_SHARE = 0.1


def robust_sd(r: np.ndarray) -> float:
    """1.4826 × the median absolute deviation of the finite values of ``r`` (NaN if none)."""
    ok = r[np.isfinite(r)]
    return float(1.4826 * np.median(np.abs(ok - np.median(ok)))) if ok.size else float("nan")


def _direction(segment: np.ndarray) -> np.ndarray:
    return np.arctan2(segment[:, 1], segment[:, 0])


def camera_terms(segment: np.ndarray, midpoint: np.ndarray, beam: float) -> np.ndarray:
    """The camera's columns (n, 4) of ``log ℓ`` (module doc): cos 2β, sin 2β of the
    segment's image direction (``segment`` (n, 2), its far end less its near end) and the
    midpoint ``midpoint`` (n, 2; from the pivot, the file's unit) over ``beam``."""
    beta = _direction(segment)
    return np.column_stack([np.cos(2 * beta), np.sin(2 * beta), midpoint / beam])


def own_terms(segment: np.ndarray, midpoint: np.ndarray, beam: float) -> np.ndarray:
    """A tie's own model (n, 7): 1, cos β, sin β (its markers' constant offsets) and the
    camera's terms (:func:`camera_terms`)."""
    beta = _direction(segment)
    return np.column_stack([np.ones_like(beta), np.cos(beta), np.sin(beta),
                            camera_terms(segment, midpoint, beam)])


@dataclass(frozen=True, eq=False)
class TieFit:
    """A trimmed least-squares fit of ``log ℓ``: ``expected`` (n,) the tie each frame should
    show (the file's unit, NaN where ``d`` or a term is missing), ``coef`` the terms'
    coefficients, ``sd`` the robust sd of the kept frames' residual (the file's unit)."""

    expected: np.ndarray
    coef: np.ndarray
    sd: float


def trimmed_fit(d: np.ndarray, terms: np.ndarray, offset: np.ndarray | None = None,
                rounds: int = ROUNDS, trim_sd: float = TRIM_SD) -> TieFit:
    """``log d − offset`` (``d`` (n,), the file's unit; ``offset`` (n,), a known part of
    ``log ℓ``, default 0) fitted on ``terms`` (n, k) by iteratively trimmed least squares
    (module doc). Fewer than 3 k usable frames: the median of ``log d − offset`` alone."""
    d = np.asarray(d, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        y = np.log(d) - (0.0 if offset is None else offset)
    ok = np.isfinite(y) & np.isfinite(terms).all(axis=1)
    expected = np.full(d.size, np.nan)
    if not ok.any():
        return TieFit(expected, np.zeros(terms.shape[1]), float("nan"))
    median = float(np.median(y[ok]))
    keep = ok & (np.abs(np.where(ok, y, median) - median) < START_SHARE)
    if keep.sum() < 3 * terms.shape[1]:
        terms, keep = np.ones((d.size, 1)), ok
    fit = np.full(d.size, np.nan)
    coef = np.zeros(terms.shape[1])
    for _ in range(rounds):
        coef, *_ = np.linalg.lstsq(terms[keep], y[keep], rcond=None)
        fit[ok] = terms[ok] @ coef
        residual = np.where(ok, y - fit, np.inf)
        sd_log = robust_sd(residual[keep])
        new = ok & (np.abs(residual) <= trim_sd * max(sd_log, 1e-12))
        if new.sum() < 3 * terms.shape[1] or (new == keep).all():
            break
        keep = new
    expected[ok] = np.exp(fit[ok] + (0.0 if offset is None else offset[ok]))
    return TieFit(expected, coef, robust_sd((d - expected)[keep]))
