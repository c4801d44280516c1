"""One filmed shot end to end: simulate, frame, render, track, export.

:func:`tracked_shot` is the reusable core of the video bench (tests and calibration work call
it too): given a scene, a camera, a frame rate, a shutter, the occluding frame members and a
seed it renders the frames in memory, tracks the markers from clicks on the first frame,
writes the tracked points as a DeepLabCut or Kinovea file and returns that file with the
truth (the simulation at the frame times) and what is needed to read it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

import trebuchet as tb

from .camera import Camera, camera_framing
from .export import kinovea_coordinates, write_deeplabcut, write_kinovea
from .render import Look, Member, frame_members, look_for, render_frames, sub_samples
from .track import TrackerSettings, track_points
from .truth import POINTS, Filming, engine_points, exposed_points, frame_times, truth_table

__all__ = ["Pose", "TrackedShot", "FORMATS", "KINOVEA_NAMES", "swept_box", "camera_for",
           "tracked_shot"]

#: Export formats: DeepLabCut, and Kinovea with each of its time columns
#: (:data:`~.export.KINOVEA_TIMES`; "kinovea" is whole milliseconds).
FORMATS = ("deeplabcut", "kinovea", "kinovea-classic", "kinovea-milliseconds", "kinovea-frames")

#: Kinovea point names (object/point) of :data:`truth.POINTS`.
KINOVEA_NAMES = ("Beam/pivot", "Beam/spigot", "Beam/hinge", "Weight/counterweight",
                 "Stone/projectile")


@dataclass(frozen=True)
class Pose:
    """Where the camera stands and how its lens draws: ``distance`` (m, to the centre of the
    engine's swept box), ``tilt_deg`` (pitch up, °), ``roll_deg`` (°), ``k1`` (radial
    distortion), ``size`` (px). The focal length frames the swing (:func:`camera_for`)."""

    distance: float
    tilt_deg: float = 0.0
    roll_deg: float = 0.0
    k1: float = 0.0
    size: tuple[int, int] = (640, 480)


@dataclass(frozen=True)
class TrackedShot:
    """A tracked shot: the written ``path`` (format ``fmt``), ``read`` (keyword arguments of
    ``trebuchet.read_log`` / ``reconstruct``: fps and the points mapping), the ``truth``
    (:func:`truth.truth_table` at the frame times, log time ``t`` in s; ``attrs["events"]``
    trigger, lift-off, release in log time), the ``camera``, the tracker's ``positions``
    (px, (n, 5, 2)) and ``scores`` ((n, 5)), the ``clicks`` (px), and ``seconds`` spent
    rendering plus tracking."""

    path: Path
    fmt: str
    read: dict
    truth: pd.DataFrame = field(repr=False)
    camera: Camera
    positions: np.ndarray = field(repr=False)
    scores: np.ndarray = field(repr=False)
    clicks: np.ndarray
    seconds: float


def swept_box(points: np.ndarray, phase: np.ndarray) -> tuple[float, float, float, float]:
    """World box (x0, y0, x1, y1 in m) of every point ((n, 5, 2)) while the sling holds the
    stone (``phase`` ≤ 2)."""
    held = points[phase <= 2].reshape(-1, 2)
    lo, hi = np.nanmin(held, axis=0), np.nanmax(held, axis=0)
    return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])


def camera_for(pose: Pose, box: tuple[float, float, float, float]) -> Camera:
    """The camera of ``pose`` zoomed so that the swept ``box`` (m) fills 85 % of the image."""
    return camera_framing(box, pose.distance, tilt_deg=pose.tilt_deg, roll_deg=pose.roll_deg,
                          k1=pose.k1, size=pose.size)


def tracked_shot(scene: tb.Scene, camera: Camera | Pose, fps: float, shutter: float,
                 occluders: bool | tuple[Member, ...] = True, seed: int = 0, *,
                 out_dir: str | Path, fmt: str = "deeplabcut",
                 tracker: TrackerSettings | None = None, look: Look | None = None,
                 rest: float = 0.3, after: float = 0.3, click_sd_px: float = 0.25,
                 kinovea_min_score: float = 0.9, name: str | None = None) -> TrackedShot:
    """Render, track and export one shot.

    ``scene``: the engine; ``camera``: a :class:`~.camera.Camera` or a :class:`Pose` (then
    zoomed to the swing); ``fps`` (1/s), ``shutter`` (exposure, s, ≤ 1/fps); ``occluders``:
    True for the near frame's members (:func:`~.render.frame_members`), False for none, or
    the members; ``seed``: background texture, sensor noise and the user's clicks (sd
    ``click_sd_px`` px around the true first-frame positions: the only use of the truth
    after rendering); ``out_dir``: where the file goes (``name`` or a name made of the
    settings, ``.csv``); ``fmt``: "deeplabcut" (every position, likelihood = the match
    score) or "kinovea[-<time>]" (positions scoring below ``kinovea_min_score`` left empty,
    as a careful user deletes the points a tracker was unsure of; the time column in whole
    ms, or as Kinovea's time-code preference ``<time>`` writes it, :data:`FORMATS`);
    ``rest``, ``after``: s filmed before the trigger and after the release.
    """
    if fmt not in FORMATS:
        raise ValueError(f"fmt must be one of {FORMATS}, not {fmt!r}")
    tracker = tracker or TrackerSettings()
    start = time.perf_counter()
    filming = Filming(fps=fps, shutter=shutter, rest=rest, after=after)
    t = frame_times(scene, filming)
    truth = truth_table(scene, t, rest, after)
    points = engine_points(scene, truth)
    if isinstance(camera, Pose):
        camera = camera_for(camera, swept_box(points, truth["phase"].to_numpy()))
    members = frame_members(scene) if occluders is True else (occluders or ())
    look = look or look_for(scene)
    n_sub = sub_samples(camera, points, shutter, fps)
    exposed = exposed_points(scene, t, rest, shutter, n_sub, after)
    release = truth.attrs["events"]["release"]
    slung = (t[:, None] + (np.arange(n_sub) + 0.5) / n_sub * shutter - shutter / 2) <= release
    from .camera import project

    rng = np.random.default_rng([seed, 41])
    clicks = project(camera, points[0]) + rng.normal(0.0, click_sd_px, (len(POINTS), 2))
    marker_px = _marker_px(camera, look, points[0, 0])
    frames = render_frames(camera, look, exposed, slung, tuple(members), seed)
    positions, scores = track_points(frames, clicks, marker_px, tracker)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f"{name or _default_name(fmt, fps, shutter, seed)}.csv"
    if fmt == "deeplabcut":
        write_deeplabcut(path, POINTS, positions, scores)
        read = {"fps": fps}
    else:
        m_per_px = scene.engine.L1 / float(np.linalg.norm(clicks[1] - clicks[0]))
        coords = kinovea_coordinates(positions, clicks[0], m_per_px)
        coords[scores < kinovea_min_score] = np.nan
        time_format = fmt.partition("-")[2] or "ms"
        write_kinovea(path, KINOVEA_NAMES, t, coords, fps, time_format)
        read = {"fps": fps, "points": {p: n for p, n in zip(POINTS, KINOVEA_NAMES, strict=True)}}
    return TrackedShot(path=path, fmt=fmt, read=read, truth=truth, camera=camera,
                       positions=positions, scores=scores, clicks=clicks,
                       seconds=time.perf_counter() - start)


def _marker_px(camera: Camera, look: Look, at: np.ndarray) -> float:
    """Marker radius (px) at world point ``at`` (m)."""
    from .camera import project

    uv = project(camera, np.array([at, at + [look.marker_radius, 0.0]]))
    return float(np.linalg.norm(uv[1] - uv[0]))


def _default_name(fmt: str, fps: float, shutter: float, seed: int) -> str:
    return f"shot_{fmt}_{fps:g}fps_1-{1 / shutter:.0f}s_seed{seed}"
