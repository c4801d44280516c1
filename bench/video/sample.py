"""Write the tracked sample shots of ``data_samples/`` (SYNTHETIC: rendered and tracked by this
bench, not filmed).

* ``video_tilted_dlc.csv`` and its scene ``video_tilted.toml``: the issue's tripod. The
  paper's engine filmed 40 m away, pitched up 10°, rolled 0.3°, barrel distortion
  k1 = −0.03, 640×480, 120 fps at 1/250 s, the near frame's members in front.
* ``video_paper_dlc.csv`` and its scene ``video_paper.toml`` (the demo's tracked shot):
  the paper's engine filmed 40 m away by a camera pitched up 4°, rolled 0.5°, k1 = −0.02,
  640×480, 240 fps at 1/1000 s, the near frame's members in front; with the user's own
  calibration of it: ``video_paper_points.csv`` (six known points of the engine's plane,
  clicked with 0.5 px error) and ``video_paper_camera.yml`` (the camera's matrix and
  distortion as OpenCV's ``FileStorage`` writes them). (The backyard engine was tried: its
  counterweight passes behind the frame's brace and is lost for the rest of the shot at
  every tilt tried, 2–6°, so its loads stop before their peak.)

Markers are tracked from clicks on the first frame by the fixed-template tracker and
exported as DeepLabCut CSV (likelihood = match score). Each video starts 1 s before the
trigger and ends 0.2 s after the release, as the other samples do.

``python -m bench.video.sample [out_dir] [name …]`` (default ``data_samples/``, both
shots); deterministic.
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import trebuchet as tb

from .camera import Camera, camera_matrix, project
from .shot import Pose, TrackedShot, swept_box, tracked_shot
from .truth import engine_points

ROOT = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class SampleShot:
    """One tracked sample: ``name`` (file stem), the ``scene`` file it films and its
    ``engine`` in words, ``pose``, ``fps`` (1/s), ``shutter`` (s), ``seed``;
    ``calibration``: also write the user's own calibration files (known plane points, the
    camera file)."""

    name: str
    scene: Path
    engine: str
    pose: Pose
    fps: float
    shutter: float
    seed: int
    calibration: bool = False


SHOTS = {
    "video_tilted": SampleShot("video_tilted", ROOT / "data_samples" / "horsdal_large.toml",
                               "the engine of Table 1 of Horsdal's paper (as horsdal_large.toml)",
                               Pose(distance=40.0, tilt_deg=10.0, roll_deg=0.3, k1=-0.03),
                               120.0, 1 / 250, 15),
    "video_paper": SampleShot("video_paper", ROOT / "data_samples" / "horsdal_large.toml",
                              "the engine of Table 1 of Horsdal's paper (as horsdal_large.toml)",
                              Pose(distance=40.0, tilt_deg=4.0, roll_deg=0.5, k1=-0.02),
                              240.0, 1 / 1000, 16, calibration=True),
}
#: Sd (px) of the user's clicks on the known plane points.
CLICK_SD_PX = 0.5


def scene_text(shot: SampleShot) -> str:
    """The sample's scene file: its engine, with a header naming the camera."""
    body = shot.scene.read_text(encoding="utf-8").splitlines()
    while body and body[0].startswith("#"):
        body.pop(0)
    pose = shot.pose
    header = [
        f"# SYNTHETIC: {shot.engine}, for",
        f"# {shot.name}_dlc.csv: filmed by a simulated camera {pose.distance:g} m away, "
        f"pitched up {pose.tilt_deg:g}°,",
        f"# rolled {pose.roll_deg:g}°, radial distortion k1 = {pose.k1:g}, "
        f"{pose.size[0]}x{pose.size[1]} px, {shot.fps:g} fps at 1/{1 / shot.shutter:.0f} s;",
        "# tracked by template matching (bench/video; written by python -m bench.video.sample).",
    ]
    return "\n".join(header + body) + "\n"


def known_points(scene: tb.Scene, done: TrackedShot) -> tuple[np.ndarray, np.ndarray]:
    """Six points of the engine's plane a user surveys before the shot (marks on the ground
    and high up, at either end of the swing and under the pivot; m, the paper's axes) and
    their pixels as clicked (rows down, ``CLICK_SD_PX`` px of error)."""
    x0, _, x1, y1 = swept_box(engine_points(scene, done.truth), done.truth["phase"].to_numpy())
    top = round(0.9 * y1, 1)
    xy = np.array([[round(x0, 1), 0.0], [round(x0, 1), top], [0.0, 0.0], [0.0, top],
                   [round(x1, 1), 0.0], [round(x1, 1), top]])
    rng = np.random.default_rng([done.clicks.size, 23])
    return xy, project(done.camera, xy) + rng.normal(0.0, CLICK_SD_PX, xy.shape)


def write_points_csv(path: Path, xy: np.ndarray, uv: np.ndarray) -> Path:
    """The known points as a calibration CSV (name, u, v in px rows down, x, y in m)."""
    lines = ["name,u (px),v (px),x (m),y (m)"]
    names = ("left ground", "left high", "pivot ground", "pivot high", "right ground",
             "right high")
    for name, (u, v), (x, y) in zip(names, uv, xy, strict=True):
        lines.append(f"{name},{u:.1f},{v:.1f},{x:.2f},{y:.2f}")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def write_camera_yml(path: Path, camera: Camera) -> Path:
    """The camera's matrix and distortion in OpenCV's FileStorage YAML (as its calibration
    sample writes them: image_width, image_height, camera_matrix, distortion_coefficients)."""
    K = camera_matrix(camera)

    def matrix(name: str, rows: int, cols: int, data: list[float]) -> list[str]:
        return [f"{name}: !!opencv-matrix", f"   rows: {rows}", f"   cols: {cols}",
                "   dt: d", "   data: [ " + ", ".join(f"{v:.10g}" for v in data) + " ]"]

    lines = ["%YAML:1.0", "---", f"image_width: {camera.size[0]}",
             f"image_height: {camera.size[1]}", *matrix("camera_matrix", 3, 3, K.ravel().tolist()),
             *matrix("distortion_coefficients", 5, 1, [camera.k1, camera.k2, 0.0, 0.0, 0.0])]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def write_sample(out_dir: str | Path = ROOT / "data_samples",
                 shot: SampleShot = SHOTS["video_tilted"]) -> TrackedShot:
    """Write ``<name>_dlc.csv`` and ``<name>.toml`` (and for a shot with ``calibration``,
    ``<name>_points.csv`` and ``<name>_camera.yml``) into ``out_dir``."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    toml = out_dir / f"{shot.name}.toml"
    toml.write_text(scene_text(shot), encoding="utf-8")
    scene = tb.Scene.from_toml(toml)
    with tempfile.TemporaryDirectory(dir=out_dir) as tmp:
        done = tracked_shot(scene, shot.pose, shot.fps, shot.shutter, True, shot.seed,
                            out_dir=tmp, rest=1.0, after=0.2, name=f"{shot.name}_dlc")
        final = out_dir / done.path.name
        shutil.move(done.path, final)
    done = TrackedShot(**{**done.__dict__, "path": final})
    if shot.calibration:
        write_points_csv(out_dir / f"{shot.name}_points.csv", *known_points(scene, done))
        write_camera_yml(out_dir / f"{shot.name}_camera.yml", done.camera)
    return done


if __name__ == "__main__":
    target = sys.argv[1] if len(sys.argv) > 1 else ROOT / "data_samples"
    for key in sys.argv[2:] or list(SHOTS):
        written = write_sample(target, SHOTS[key])
        print(f"{written.path}: {len(written.truth)} frames; read with fps={SHOTS[key].fps:g}")
