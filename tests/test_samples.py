"""The shipped SYNTHETIC sample logs (data_samples/): they read, they hold the simulated shot
within their stated noise, they say they are synthetic, and the script remakes them exactly.

The truth is recomputed here from the scene and the documented conventions (trigger at
video time 1 s, engine at rest before it, frames at k / fps), not taken from the script.
"""

from __future__ import annotations

import math
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tests.conftest import BACKYARD
from trebuchet.core.errors import TrebuchetDataWarning
from trebuchet.ingest.logs.read_log import read_log
from trebuchet.model.scene import Scene
from trebuchet.model.simulate import simulate

ROOT = Path(__file__).resolve().parents[1]
SAMPLES_DIR = ROOT / "data_samples"
SCRIPT = SAMPLES_DIR / "make_samples.py"
TRIGGER = 1.0  # s, video time of the trigger (README)
ANGLES = ("theta", "psi", "phi")

PAPER = Scene.from_toml(SAMPLES_DIR / "horsdal_large.toml")
E = PAPER.engine
KINOVEA_POINTS = {"pivot": "axle", "spigot": "tip", "hinge": "hinge",
                  "counterweight": "Weight", "projectile": "Stone"}
DLC_POINTS = {"pivot": "axle", "spigot": "arm_tip", "hinge": "hinge",
              "counterweight": "weight", "projectile": "stone"}


def point_sd(sigma: float, quantum: float = 0.0) -> tuple[float, float, float]:
    """Angle noise (rad) from position noise sigma per coordinate (and rounding), two points
    L apart: sqrt(2 (sigma² + q²/12)) / L for theta (L1), psi (L3), phi (L4)."""
    s = math.sqrt(2 * (sigma**2 + quantum**2 / 12))
    return s / E.L1, s / E.L3, s / E.L4


def angle_sd(sd_deg: float, quantum_deg: float = 0.0) -> tuple[float, float, float]:
    """Angle noise (rad) of sd_deg with rounding to quantum_deg, for all three angles."""
    s = math.radians(math.sqrt(sd_deg**2 + quantum_deg**2 / 12))
    return s, s, s


# file: (format, scene file, read_log arguments as documented, fps, noise sd per angle in rad)
SAMPLES = {
    "horsdal_240fps.csv": ("generic", "horsdal_large.toml", {}, 240.0, angle_sd(0.3, 0.001)),
    "horsdal_tracker.txt": (
        "tracker", "horsdal_large.toml",
        {"columns": {"beam": "theta", "arm": "psi", "sling": "phi"}}, 120.0, angle_sd(0.5, 0.1),
    ),
    "horsdal_tracker_multi_decimal_comma.txt": (
        "tracker", "horsdal_large.toml",
        {"columns": {"Balken": "theta", "Arm": "psi", "Schlinge": "phi"}}, 120.0,
        angle_sd(0.5),
    ),
    "horsdal_kinovea.csv": (
        "kinovea", "horsdal_large.toml", {"fps": 240, "points": KINOVEA_POINTS}, 240.0,
        point_sd(0.01, 0.001),
    ),
    "horsdal_dlc.csv": (
        "deeplabcut", "horsdal_large.toml",
        {"fps": 120, "points": DLC_POINTS, "min_likelihood": 0.9}, 120.0,
        point_sd(1.0 / 40.0),
    ),
    "backyard_240fps.csv": ("generic", "backyard.toml", {}, 240.0, angle_sd(0.3, 0.001)),
}


def quiet_read(path: Path, **kwargs) -> pd.DataFrame:
    """read_log with the repair warnings (gaps) silenced: the samples have gaps on purpose."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TrebuchetDataWarning)
        return read_log(path, **kwargs)


def true_angles(scene: Scene, t_video: np.ndarray) -> tuple[pd.DataFrame, float]:
    """Angles (rad) of the simulated shot at video times (rest before the trigger); release."""
    t_shot = t_video - TRIGGER
    moving = t_shot > 0
    run = simulate(scene, t_eval=t_shot[moving])
    rest = (scene.start.theta, scene.start.psi, scene.start.phi)
    out = pd.DataFrame({"t": t_video})
    for a, r in zip(ANGLES, rest, strict=True):
        col = np.full(len(t_video), r)
        col[moving] = run[a].to_numpy()
        out[a] = col
    return out, run.attrs["events"]["release"]


@pytest.fixture(scope="module", params=list(SAMPLES))
def sample(request):
    """(name, log as read, truth at its frame times, release (s after trigger), spec)."""
    name = request.param
    fmt, scene_file, kwargs, fps, sd = SAMPLES[name]
    log = quiet_read(SAMPLES_DIR / name, **kwargs)
    scene = Scene.from_toml(SAMPLES_DIR / scene_file)
    frames = np.round(log["t"].to_numpy() * fps)
    assert np.abs(log["t"].to_numpy() * fps - frames).max() < 0.02  # times on the frame grid
    true, release = true_angles(scene, frames / fps)
    return name, log, true, release, (fmt, fps, sd)


def test_sample_reads_in_its_format_and_spans_rest_to_after_release(sample):
    name, log, true, release, (fmt, fps, _) = sample
    assert log.attrs["log"].format == fmt
    t = log["t"].to_numpy()
    assert t[0] <= TRIGGER - 0.19  # rest before the trigger, in the video's own time
    assert t[-1] >= TRIGGER + release + 0.19
    assert np.all(np.diff(t) > 0)
    shot = t - TRIGGER
    # the sling (or projectile) track ends at release, as a tracker loses the sling
    assert np.isnan(log["phi"].to_numpy()[shot > release]).all()
    assert np.isfinite(log["phi"].to_numpy()[shot < release]).mean() > 0.9
    for a in ("theta", "psi"):
        assert np.isfinite(log[a]).mean() > 0.95


def test_sample_matches_simulation_within_stated_noise(sample):
    name, log, true, _, (_, _, sd) = sample
    for a, s in zip(ANGLES, sd, strict=True):
        d = log[a].to_numpy() - true[a].to_numpy()
        ok = np.isfinite(d)
        d = d[ok]
        wrapped = np.angle(np.exp(1j * d))
        # one 2π branch over the whole log (see test_tracker_sling_branch below)
        branch = np.round((d - wrapped) / (2 * np.pi))
        assert (branch == branch[0]).all(), (name, a)
        if not name.startswith("horsdal_tracker"):
            assert branch[0] == 0, (name, a)
        n = len(wrapped)
        rms = float(np.sqrt(np.mean(wrapped**2)))
        assert n > 100
        assert 0.8 < rms / s < 1.2, (name, a, math.degrees(rms), math.degrees(s))
        assert abs(float(np.mean(wrapped))) < 4 * s / math.sqrt(n), (name, a)


def test_tracker_sling_branch_is_the_papers():
    log = quiet_read(SAMPLES_DIR / "horsdal_tracker_multi_decimal_comma.txt",
                     columns={"Balken": "theta", "Arm": "psi", "Schlinge": "phi"})
    assert -1.5 * math.pi <= log["phi"].dropna().iloc[0] < 0.5 * math.pi


def test_deeplabcut_mislocated_positions_are_dropped_by_likelihood_or_geometry():
    """The sample's 11 mislocated positions (likelihood 0.2-0.85) are gone whatever the cut:
    the sample's 0.9 drops them by likelihood; below it (the default 0.6, or none at all)
    the engine's geometry finds them (ingest/geometry/stuck_points.off_engine) and a note
    names them."""
    path = SAMPLES_DIR / "horsdal_dlc.csv"
    kept = quiet_read(path, fps=120, points=DLC_POINTS, min_likelihood=0.9)
    true, _ = true_angles(PAPER, kept["t"].to_numpy())
    sd = point_sd(1.0 / 40.0)[0]
    assert np.abs(kept["theta"] - true["theta"]).max() < 5 * sd
    for cut in (None, 0.0):
        kwargs = {} if cut is None else {"min_likelihood": cut}
        with warnings.catch_warnings(record=True) as record:
            warnings.simplefilter("always")
            log = read_log(path, fps=120, points=DLC_POINTS, **kwargs)
        assert np.abs(log["theta"] - true["theta"]).max() < 5 * sd
        assert any("off the engine's geometry" in str(w.message) for w in record)


def test_readme_labels_every_sample_synthetic_and_documents_how_to_read_it():
    text = (SAMPLES_DIR / "README.md").read_text(encoding="utf-8")
    assert "SYNTHETIC" in text and "make_samples.py" in text
    assert "trigger at video time 1 s" in text
    for name, (_, scene_file, kwargs, _, _) in SAMPLES.items():
        row = next(line for line in text.splitlines() if line.startswith(f"| `{name}`"))
        assert f"`{scene_file}`" in row
        assert "Seed" in row
        for key, value in kwargs.items():
            assert f"{key}={value!r}" in row, (name, key)


def test_generic_samples_say_synthetic_in_the_file_and_demo_sample_is_small():
    for name in ("horsdal_240fps.csv", "backyard_240fps.csv"):
        first = (SAMPLES_DIR / name).read_text(encoding="utf-8").splitlines()[0]
        assert first.startswith("# SYNTHETIC")
    assert (SAMPLES_DIR / "horsdal_240fps.csv").stat().st_size < 20_000


def test_the_backyard_engine_is_written_once():
    """make_samples.py writes data_samples/backyard.toml from its BACKYARD; the tests and the
    synthetic logs read that file, and the bench's small engine differs from it in L3 only."""
    from trebuchet.data_samples.make_samples import BACKYARD as written
    from trebuchet.ingest.synthetic.simulated_log import BACKYARD as shipped
    from trebuchet.ingest.synthetic.simulated_log import SMALL_ENGINE

    assert BACKYARD == written == shipped
    assert SMALL_ENGINE == {**written, "engine": {**written["engine"], "L3": 0.5}}


def test_script_reproduces_the_shipped_files_byte_for_byte(tmp_path):
    result = subprocess.run([sys.executable, str(SCRIPT), "--out", str(tmp_path)],
                            capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert result.returncode == 0, result.stderr
    written = sorted(p.name for p in tmp_path.iterdir())
    assert written == sorted([*SAMPLES, "backyard.toml", "README.md"])  # no temp files left
    for name in written:
        assert (tmp_path / name).read_bytes() == (SAMPLES_DIR / name).read_bytes(), name
