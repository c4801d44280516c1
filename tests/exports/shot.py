"""The filmed shot every export fixture is written from: the paper's engine, simulated.

The engine of ``data_samples/horsdal_large.toml`` is simulated by
:func:`trebuchet.simulate`; the five tracked points come from
:mod:`trebuchet.model.kinematics` (pivot, spigot, hinge, counterweight, projectile).
The video starts :data:`TRIGGER` s before the trigger (the engine rests at its start
pose) and ends :data:`AFTER` s after release; the projectile is lost by the tracker at
release (a tracker loses the stone in flight).

A :class:`Camera` maps the model's metres (origin on the ground under the pivot, y up) to
the pixels of a 1920 x 1080 image (origin at the top-left corner, y down), as pose
estimators (DeepLabCut, SLEAP) and Kinovea's image space write them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np

from trebuchet.model import kinematics
from trebuchet.model.scene import Scene
from trebuchet.model.simulate import simulate

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "data_samples" / "horsdal_large.toml"

#: Video time of the trigger, s (the engine rests before it).
TRIGGER = 0.25
#: Seconds filmed after release.
AFTER = 0.1

#: The tracked points, in the order the exports list them.
ROLES = ("pivot", "spigot", "hinge", "counterweight", "projectile")

#: Which pair of points gives each angle (from, to): the package's convention.
PAIRS = {"theta": ("pivot", "spigot"), "psi": ("hinge", "counterweight"),
         "phi": ("spigot", "projectile")}
ANGLES = ("theta", "psi", "phi")


@dataclass(frozen=True)
class Camera:
    """Metres (y up) to pixels (y down): ``px = x0 + s x``, ``py = y0 - s y``."""

    scale: float = 55.0          # px per m
    x0: float = 960.0            # px: the pixel of the model's origin
    y0: float = 1050.0

    def to_pixels(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.x0 + self.scale * x, self.y0 - self.scale * y


CAMERA = Camera()


@dataclass
class Shot:
    """The true shot at the frames of a video.

    ``frame``: video frame numbers from 0; ``t``: video time (s); ``angles``: theta, psi,
    phi (rad, the paper's branch; phi NaN after release); ``points``: ``{role: (x, y)}`` in
    m, y up, the projectile NaN after release (lost); ``release``: video time of release.
    """

    fps: float
    frame: np.ndarray
    t: np.ndarray
    angles: dict[str, np.ndarray]
    points: dict[str, tuple[np.ndarray, np.ndarray]]
    release: float
    trigger_frame: float


@cache
def scene() -> Scene:
    return Scene.from_toml(SCENE)


@cache
def _release() -> float:
    return float(simulate(scene(), t_eval=[0.0]).attrs["events"]["release"])


def filmed(fps: float) -> Shot:
    """The shot filmed at ``fps`` frames per second (frame 0 at video time 0)."""
    sc = scene()
    release = _release()
    last = math.floor((TRIGGER + release + AFTER) * fps + 1e-9)
    frame = np.arange(last + 1)
    t = frame / fps
    t_shot = t - TRIGGER
    moving = t_shot > 0
    run = simulate(sc, t_eval=t_shot[moving])
    s = sc.start
    angles = {}
    for name, rest in (("theta", s.theta), ("psi", s.psi), ("phi", s.phi)):
        values = np.full(len(t), rest, dtype=float)
        values[moving] = run[name].to_numpy(dtype=float)
        angles[name] = values
    angles["phi"][t_shot > release] = np.nan
    e, H = sc.engine, s.H
    th, ps, ph = angles["theta"], angles["psi"], angles["phi"]
    spigot = kinematics.spigot_position(th, e, H)
    hinge = kinematics.hinge_position(th, e, H)
    cw = kinematics.counterweight_position(th, ps, e, H)
    proj = kinematics.projectile_position(th, ph, e, H)   # NaN where phi is (lost)
    n = len(t)
    points = {
        "pivot": (np.zeros(n), np.full(n, H)),
        "spigot": (spigot[0], spigot[1]),
        "hinge": (hinge[0], hinge[1]),
        "counterweight": (cw[0], cw[1]),
        "projectile": (proj[0], proj[1]),
    }
    return Shot(fps=fps, frame=frame, t=t, angles=angles, points=points,
                release=TRIGGER + release, trigger_frame=TRIGGER * fps)


def near_branch(measured: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """``measured`` (rad) moved by whole turns to lie within π of ``reference``."""
    return measured - 2 * np.pi * np.round((measured - reference) / (2 * np.pi))


#: Key of ``angles_of``'s mask of the rows whose psi comes from the beam's hinge, and the
#: tolerance (rad) of psi there: the beam fit's noise, not the rounding of the numbers.
BEAM_ROWS = "psi_from_beam"
BEAM_TOL = 0.01


def angles_of(points: dict[str, tuple[np.ndarray, np.ndarray]], y_up: bool,
              reference: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The paper's angles from written positions (y up, or y down for image pixels), on
    the branch of ``reference`` (the simulated angles); NaN where a point is missing."""
    sign = 1.0 if y_up else -1.0
    out = {}
    for angle, (a, b) in PAIRS.items():
        xa, ya = points[a]
        xb, yb = points[b]
        raw = np.arctan2(sign * (yb - ya), xb - xa)
        ref = reference[angle]
        fill = np.where(np.isfinite(ref), ref, np.nan)
        # after release phi has no reference: continue from the last simulated value
        if np.isnan(fill).any() and np.isfinite(fill).any():
            last = fill[np.isfinite(fill)][-1]
            fill = np.where(np.isfinite(fill), fill, last)
        out[angle] = near_branch(raw, fill)
    # a hinge the tracker lost where pivot and spigot are tracked is the beam's: read_log
    # fills it from them (ingest/geometry/beam_hinge.py), so psi is there, the shot's own
    beam = np.isfinite(points["pivot"][0]) & np.isfinite(points["spigot"][0])
    lost = beam & ~np.isfinite(points["hinge"][0]) & np.isfinite(points["counterweight"][0])
    # (to the beam fit's noise: BEAM_TOL, marked by BEAM_ROWS)
    out["psi"] = np.where(lost, reference["psi"], out["psi"])
    out[BEAM_ROWS] = lost.astype(float)
    return out
