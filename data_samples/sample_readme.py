"""The README of the sample logs (``make_samples.py``): what is synthetic, how each file was
made and how it is read, with the rows of the files this script does not write."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

__all__ = ["FRICTION_SCENES", "TRACKED_VIDEO", "COMMAND_LINE", "readme_text"]


#: Scene files with friction in the bearings (hand-written, not by this script): their rows
#: of the README's table.
FRICTION_SCENES = (
    ("horsdal_friction.toml",
     "Scene file: the paper's engine (`horsdal_large.toml`) with Coulomb friction in its "
     "bearings, μ 0.15 on a 0.10 m shaft and a 0.06 m hinge pin (`[friction]`, "
     "docs/scenes.md): it loses 12.6 kJ, 5.0 % of ΔU, by the release. Hand-written."),
    ("small_fast.toml",
     "Scene file: a small fast backyard engine (L1 1.5 m, M 100 kg, m 0.5 kg, released at a "
     "40° climb), whose bearing load peaks for about 23 ms, with friction μ 0.3 on a 12.5 mm "
     "shaft radius and a 10 mm pin radius: it loses 8.7 % of ΔU by the release. "
     "Hand-written."),
)

#: The shot tracked from rendered video (written by ``python -m bench.video.sample``, not by
#: this script): its rows of the README's table.
TRACKED_VIDEO = (
    ("video_tilted_dlc.csv",
     "DeepLabCut CSV tracked from rendered video of `video_tilted.toml` (the paper's engine, "
     "equal to `horsdal_large.toml`): a simulated camera 40 m away pitched up 10°, rolled "
     "0.3°, radial distortion k1 = −0.03, 640×480 px, 120 fps at a 1/250 s shutter (motion "
     "blur), lens blur 0.8 px, sensor noise 2 grey levels, the near frame's legs and brace in "
     "front of the engine; markers tracked by masked template matching (OpenCV) from clicks "
     "on frame 0 only (0.25 px sd), likelihood = match score; bodyparts `pivot`, `spigot`, "
     "`hinge`, `counterweight`, `projectile` in image pixels (y down, not undistorted); "
     "frame index 0–263 from the start of the video (trigger at frame 120, t = 1 s; release "
     "at 1.997 s); 76 positions with likelihood below 0.9 (hinge 19 and counterweight 23 "
     "behind frame members, stone 34 blurred or in flight). Seed `15`. Written by "
     "`python -m bench.video.sample` (bench/video), not by make_samples.py. Read: "
     "`read_log(path, fps=120)`; `trebuchet forces data_samples/video_tilted_dlc.csv "
     "--scene data_samples/video_tilted.toml --fps 120`."),
    ("video_tilted.toml",
     "Scene file of `video_tilted_dlc.csv`: the paper's engine (equal to "
     "`horsdal_large.toml`) with a header naming the camera."),
    ("video_paper_dlc.csv",
     "DeepLabCut CSV tracked from rendered video of `video_paper.toml` (the paper's engine, "
     "equal to `horsdal_large.toml`), the tracked shot of `make demo`: a simulated camera "
     "40 m away pitched up 4°, rolled 0.5°, radial distortion k1 = −0.02, 640×480 px, 240 "
     "fps at a 1/1000 s shutter, lens blur, sensor noise, the near frame's legs and brace in "
     "front of the engine; markers tracked by masked template matching (OpenCV) from clicks "
     "on frame 0 only, likelihood = match score; bodyparts `pivot`, `spigot`, `hinge`, "
     "`counterweight`, `projectile` in image pixels (y down, not undistorted); frame index "
     "0–527 (trigger at frame 240, t = 1 s; release at 1.997 s); 128 positions with "
     "likelihood below 0.9 (hinge 41 and counterweight 40 behind frame members, stone 47 in "
     "flight). Seed `16`. Written by `python -m bench.video.sample` (bench/video), not by "
     "make_samples.py. Read: `read_log(path, fps=240, calibration="
     "'data_samples/video_paper_points.csv')`; `trebuchet forces "
     "data_samples/video_paper_dlc.csv --scene data_samples/video_paper.toml --fps 240 "
     "--calibration data_samples/video_paper_points.csv`."),
    ("video_paper.toml",
     "Scene file of `video_paper_dlc.csv`: the paper's engine (equal to `horsdal_large.toml`) "
     "with a header naming the camera."),
    ("video_paper_points.csv",
     "The user's own calibration of `video_paper_dlc.csv`'s camera: six points of the "
     "engine's plane surveyed before the shot (`x (m)`, `y (m)`: the paper's axes, ground "
     "under the pivot at 0) and their pixels `u (px)`, `v (px)` (rows down) as clicked on "
     "the first frame, 0.5 px sd. Read by `calibration=` / `--calibration` (docs/formats.md): "
     "a homography, reprojection residual 0.43 px."),
    ("video_paper_camera.yml",
     "The camera of `video_paper_dlc.csv` as OpenCV's FileStorage YAML (`camera_matrix`, "
     "`distortion_coefficients`, `image_width`, `image_height`): fixes the lens; "
     "`reconstruct` then finds the 4° tilt from the engine's geometry (docs/formats.md)."),
)

#: The README's section on reading each sample from the command line (issue 17: the hints
#: and this page speak the shell user's options, not only Python's keywords).
COMMAND_LINE = [
    '## On the command line',
    '',
    'Every `Read:` call above has its command-line form; `forces` and `compare` take the same',
    'options (`compare` writes a report folder instead of a CSV file):',
    '',
    '    S=data_samples',
    '    trebuchet forces $S/horsdal_240fps.csv --scene $S/horsdal_large.toml -o loads.csv',
    '    trebuchet forces $S/horsdal_tracker.txt --scene $S/horsdal_large.toml -o loads.csv \\',
    '        --column beam=theta --column arm=psi --column sling=phi',
    '    trebuchet forces $S/horsdal_tracker_multi_decimal_comma.txt '
    '--scene $S/horsdal_large.toml \\',
    '        -o loads.csv --column Balken=theta --column Arm=psi --column Schlinge=phi',
    '    trebuchet forces $S/horsdal_kinovea.csv --scene $S/horsdal_large.toml -o loads.csv \\',
    '        --fps 240 --point pivot=axle --point spigot=tip --point hinge=hinge \\',
    '        --point counterweight=Weight --point projectile=Stone',
    '    trebuchet forces $S/horsdal_dlc.csv --scene $S/horsdal_large.toml -o loads.csv \\',
    '        --fps 120 --point pivot=axle --point spigot=arm_tip --point hinge=hinge \\',
    '        --point counterweight=weight --point projectile=stone     # --min-likelihood 0.9',
    '    trebuchet forces $S/backyard_240fps.csv --scene $S/backyard.toml -o loads.csv',
    '    trebuchet forces $S/video_paper_dlc.csv --scene $S/video_paper.toml -o loads.csv \\',
    '        --fps 240 --calibration $S/video_paper_points.csv   # or $S/video_paper_camera.yml',
    '    trebuchet compare $S/horsdal_dlc.csv --scene $S/horsdal_large.toml -o report/ \\',
    '        --fps 120 --point pivot=axle ...  '
    '# the same options, and --trigger, --lift-off, --release',
    '',
    "Without the naming options a file whose names are not the angles' own is refused with the",
    'option that names them (`--column`, `--point`, `--fps`); from Python the same refusal names',
    'the keyword (`columns=`, `points=`, `fps=`).',
]


def readme_text(samples: Sequence[Any], *, seed: int, trigger: float, before: float,
                after: float) -> str:
    """The README of the samples (each with ``name`` and ``readme``): what is synthetic, how
    each file was made and is read; ``seed`` the master seed, ``trigger`` the video time (s) of
    the trigger, ``before``/``after`` the seconds shown before the trigger and after release."""
    lines = [
        "# Sample logs: SYNTHETIC",
        "",
        "**Every log in this folder is SYNTHETIC: made by the simulator, not measured.** "
        "They were written by `data_samples/make_samples.py` (run "
        "`.venv/bin/python data_samples/make_samples.py [--out DIR]`; deterministic, master "
        f"seed {seed}, each file drawing from `numpy.random.default_rng([{seed}, index])`).",
        "",
        "How they were made: `trebuchet.simulate` of the scene named below at the frame times, "
        f"the engine at rest at its start pose before the trigger at video time {trigger:g} s "
        f"(the log's time does not start at the trigger), from about {before:g} s before the "
        f"trigger (DeepLabCut: from frame 0) to {after:g} s after release, then Gaussian noise "
        "(independent per angle or per coordinate and frame) and lost frames. The sling "
        "angle (or the projectile point) ends at release, as a tracker loses the sling. "
        "Positions are in the model's axes: origin on the ground under the pivot, x right, "
        "y up; pivot (0, H), spigot = pivot + L1 e_θ, hinge = pivot − L2 e_θ, counterweight = "
        "hinge + L3 e_ψ, projectile = spigot + L4 e_φ.",
        "",
        "`horsdal_large.toml` is the paper's engine (Table 1); `horsdal_240fps.csv` is the "
        "sample of `make demo`, `video_paper_dlc.csv` its tracked shot (with its "
        "calibration `video_paper_points.csv`).",
        "",
        "| file | what it holds |",
        "|---|---|",
    ]
    for s in samples:
        lines.append(f"| `{s.name}` | {s.readme} |")
    lines += [f"| `{name}` | {text} |" for name, text in (*TRACKED_VIDEO, *FRICTION_SCENES)]
    lines += [""] + COMMAND_LINE + [
        "",
        "Angle noise of the point files follows from the position noise: about "
        "√2 σ / L for an angle between two points L apart (θ: L1, ψ: L3, φ: L4).",
        "",
    ]
    return "\n".join(lines)
