"""Write the tracked sample shot of ``data_samples/``: ``video_tilted_dlc.csv`` and its scene
``video_tilted.toml`` (SYNTHETIC: rendered and tracked by this bench, not filmed).

The issue's tripod: the paper's engine filmed 40 m away, pitched up 10°, rolled 0.3°, barrel
distortion k1 = −0.03, 640×480, 120 fps at 1/250 s, the near frame's members in front,
markers tracked from clicks on the first frame by the fixed-template tracker, exported as
DeepLabCut CSV (likelihood = match score). The video starts 1 s before the trigger (frame
120) and ends 0.2 s after the release, as the other samples do.

``python -m bench.video.sample [out_dir]`` (default ``data_samples/``); deterministic.
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from pathlib import Path

import trebuchet as tb

from .shot import Pose, TrackedShot, tracked_shot

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "data_samples" / "horsdal_large.toml"
POSE = Pose(distance=40.0, tilt_deg=10.0, roll_deg=0.3, k1=-0.03)
FPS = 120.0
SHUTTER = 1 / 250
SEED = 15
NAME = "video_tilted"


def scene_text() -> str:
    """The sample's scene file: the paper's engine, with a header naming the camera."""
    body = SCENE.read_text(encoding="utf-8").splitlines()
    while body and body[0].startswith("#"):
        body.pop(0)
    header = [
        "# SYNTHETIC: the engine of Table 1 of Horsdal's paper (as horsdal_large.toml), for",
        f"# {NAME}_dlc.csv: filmed by a simulated camera {POSE.distance:g} m away, pitched up "
        f"{POSE.tilt_deg:g}°,",
        f"# rolled {POSE.roll_deg:g}°, radial distortion k1 = {POSE.k1:g}, "
        f"{POSE.size[0]}x{POSE.size[1]} px, {FPS:g} fps at 1/{1 / SHUTTER:.0f} s;",
        "# tracked by template matching (bench/video; written by python -m bench.video.sample).",
    ]
    return "\n".join(header + body) + "\n"


def write_sample(out_dir: str | Path = ROOT / "data_samples") -> TrackedShot:
    """Write ``video_tilted_dlc.csv`` and ``video_tilted.toml`` into ``out_dir``."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    toml = out_dir / f"{NAME}.toml"
    toml.write_text(scene_text(), encoding="utf-8")
    scene = tb.Scene.from_toml(toml)
    with tempfile.TemporaryDirectory(dir=out_dir) as tmp:
        shot = tracked_shot(scene, POSE, FPS, SHUTTER, True, SEED, out_dir=tmp,
                            rest=1.0, after=0.2, name=f"{NAME}_dlc")
        final = out_dir / shot.path.name
        shutil.move(shot.path, final)
    return TrackedShot(**{**shot.__dict__, "path": final})


if __name__ == "__main__":
    done = write_sample(*sys.argv[1:2])
    print(f"{done.path}: {len(done.truth)} frames; read with fps={FPS:g}")
