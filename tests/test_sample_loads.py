"""The shipped samples' loads against their truth (issue 26): every log in data_samples/
with its own scene, read as data_samples/README.md says, reconstructed with the defaults;
its events and peak loads against the simulation it was made from (the README's
conventions: the trigger at video time 1 s, the engine at rest before it).

Targets (issue 15's, and issue 26's for the tilted video sample): the release within 3
frames at 120 fps and 2 at 240, lift-off within 2 frames, or either within its stated 2
sd and warned about; peak |F_S| within 10 % and peak |F_R| within 5 % of the truth's.
Before issue 26 the tilted sample's release came 11 frames early (its spigot's clean
track thrown out under the camera's perspective) with |F_S| 28 % low and |F_R| 6 % high."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from trebuchet.ingest.reconstruct import reconstruct
from trebuchet.ingest.reconstruction import reconstruction_of
from trebuchet.ingest.synthetic.simulated_log import shot_truth
from trebuchet.model.scene import Scene

S = Path(__file__).resolve().parents[1] / "data_samples"
DLC = {"pivot": "axle", "spigot": "arm_tip", "hinge": "hinge", "counterweight": "weight",
       "projectile": "stone"}
KINOVEA = {"pivot": "axle", "spigot": "tip", "hinge": "hinge", "counterweight": "Weight",
           "projectile": "Stone"}
#: file: (scene file, keywords as data_samples/README.md reads it)
SAMPLES = {
    "horsdal_240fps.csv": ("horsdal_large.toml", {}),
    "horsdal_tracker.txt": ("horsdal_large.toml",
                            {"columns": {"beam": "theta", "arm": "psi", "sling": "phi"}}),
    "horsdal_tracker_multi_decimal_comma.txt": (
        "horsdal_large.toml", {"columns": {"Balken": "theta", "Arm": "psi",
                                           "Schlinge": "phi"}}),
    "horsdal_kinovea.csv": ("horsdal_large.toml", {"fps": 240, "points": KINOVEA}),
    "horsdal_dlc.csv": ("horsdal_large.toml", {"fps": 120, "points": DLC}),
    "backyard_240fps.csv": ("backyard.toml", {}),
    "video_tilted_dlc.csv": ("video_tilted.toml", {"fps": 120}),
    "video_paper_dlc.csv": ("video_paper.toml",
                            {"fps": 240, "calibration": S / "video_paper_points.csv"}),
}
TRIGGER = 1.0  # s, video time of every sample's trigger


def _within(error_frames: float, sd_frames: float, limit: float, warned: bool) -> bool:
    return abs(error_frames) <= limit or (abs(error_frames) <= 2.0 * sd_frames and warned)


@pytest.mark.parametrize("name", list(SAMPLES))
def test_a_sample_s_events_and_peak_loads_meet_their_targets(name):
    scene_file, keywords = SAMPLES[name]
    scene = Scene.from_toml(S / scene_file)
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        res = reconstruct(S / name, scene, **keywords)
    said = " ".join(str(w.message) for w in record)
    done = reconstruction_of(res)
    t = res["t"].to_numpy()
    truth = shot_truth(scene, t, TRIGGER, 0.3)
    fps = done.fps
    for event, limit in (("release", 3.0 if fps < 200 else 2.0), ("lift_off", 2.0)):
        err = (done.events[event] - truth.attrs["events"][event]) * fps
        sd = done.event_sd[event] * fps
        named = event.replace("_", "-")
        assert _within(err, sd, limit, f"the {named}" in said or
                       f"{named} sources" in said), (name, event, err, sd)
    moving = truth["phase"].to_numpy() >= 1
    for column, limit in (("F_S_abs", 0.10), ("F_R_abs", 0.05)):
        peak = np.nanmax(res[column].to_numpy()[res["phase"].to_numpy() > 0])
        true = np.max(truth[column].to_numpy()[moving])
        assert abs(peak / true - 1.0) <= limit, (name, column, peak / true - 1.0)
