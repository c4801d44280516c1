"""Write the SYNTHETIC sample logs of ``data_samples/``: simulated shots, noise, lost frames.

Run ``python data_samples/make_samples.py [--out DIR]`` (default: this folder). Every
file is made from :func:`trebuchet.simulate` of a shipped scene, with Gaussian noise
from a fixed seed, so the output is the same byte for byte on every run. Each file is
written atomically (a temporary file in the same folder, then renamed).

Conventions shared by every sample (see the README this script writes):

* video time ``t`` (s) = time after the trigger + :data:`TRIGGER` (the video does not
  start at the trigger); frames lie at ``k / fps``; the engine rests at its start pose
  before the trigger;
* the sling track (or the projectile point) ends at release, as a tracker loses it;
* positions (m) are the model's: origin on the ground under the pivot, x right, y up;
  the pivot at ``(0, H)``, spigot ``pivot + L1 e_θ``, hinge ``pivot − L2 e_θ``,
  counterweight ``hinge + L3 e_ψ``, projectile ``spigot + L4 e_φ`` (in flight after
  release).
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from trebuchet.data_samples.sample_formats import (  # noqa: F401 - the script's own names too
    DLC_NAMES,
    DLC_SCORER,
    KINOVEA_NAMES,
    ROLES,
    central_rate,
    deeplabcut_text,
    fmt,
    generic_text,
    java_sci,
    kinovea_text,
    sling_branch_note,
    tracker_text,
    wrap_deg,
)
from trebuchet.data_samples.sample_readme import readme_text
from trebuchet.model.scene import Scene
from trebuchet.model.simulate import simulate

HERE = Path(__file__).resolve().parent

#: Master seed; each sample draws from ``numpy.random.default_rng([SEED, index])``.
SEED = 20240617

#: Video time of the trigger, s.
TRIGGER = 1.0

#: Seconds of rest logged before the trigger and of motion logged after release.
BEFORE = 0.2
AFTER = 0.2

PAPER_SCENE = "horsdal_large.toml"
BACKYARD_SCENE = "backyard.toml"

#: The small engine of tests/conftest.py (BACKYARD), written as a scene file.
BACKYARD: dict[str, dict[str, float]] = {
    "engine": {"L1": 2.0, "L2": 0.5, "L_CM": 0.6, "L3": 0.6, "L4": 1.8, "m_b": 15.0,
               "M": 100.0, "m": 1.0},
    "start": {"theta_deg": -45.0, "psi_deg": -90.0, "phi_deg": -180.0},
    "release": {"velocity_angle_deg": 45.0},
    "environment": {"g": 9.81},
}

#: The read_log ``points=`` mapping for the Kinovea sample's point names.
KINOVEA_POINTS = {"pivot": "axle", "spigot": "tip", "hinge": "hinge",
                  "counterweight": "Weight", "projectile": "Stone"}

#: The read_log ``points=`` mapping for the DeepLabCut sample's bodypart names.
DLC_POINTS = dict(DLC_NAMES)
#: Camera of the DeepLabCut sample: px per m, and the pixel of the model's origin.
DLC_SCALE = 40.0
DLC_ORIGIN = (900.0, 1040.0)
DLC_NOISE_PX = 1.0

TRACKER_COLUMNS = {"beam": "theta", "arm": "psi", "sling": "phi"}
TRACKER_EU_COLUMNS = {"Balken": "theta", "Arm": "psi", "Schlinge": "phi"}


# ------------------------------------------------------------------------------ the truth


def load_scene(name: str) -> Scene:
    """A scene of this folder by file name (the backyard one from :data:`BACKYARD`)."""
    if name == BACKYARD_SCENE:
        return Scene.from_dict(BACKYARD, source=name)
    return Scene.from_toml(HERE / name)


def frame_range(fps: float, release: float, start: float | None = None) -> np.ndarray:
    """Frame numbers from ``start`` (s, video time; default BEFORE s before the trigger)
    to AFTER s after ``release`` (s after the trigger)."""
    first = math.ceil(((TRIGGER - BEFORE) if start is None else start) * fps - 1e-9)
    last = math.floor((TRIGGER + release + AFTER) * fps + 1e-9)
    return np.arange(first, last + 1)


def truth(scene: Scene, t_video: np.ndarray) -> pd.DataFrame:
    """The simulated shot at video times ``t_video`` (s): ``t``, ``phase`` (0 at rest),
    ``theta``, ``psi``, ``phi`` (rad, NaN after release), ``x_m``, ``y_m`` (m)."""
    t_shot = np.asarray(t_video, dtype=float) - TRIGGER
    moving = t_shot > 0
    run = simulate(scene, t_eval=t_shot[moving])
    s = scene.start
    rest = {"phase": 0, "theta": s.theta, "psi": s.psi, "phi": s.phi, "x_m": np.nan,
            "y_m": np.nan}
    out = pd.DataFrame({"t": t_video})
    for col, value in rest.items():
        column = np.full(len(t_video), value, dtype=float)
        column[moving] = run[col].to_numpy(dtype=float)
        out[col] = column
    e = scene.engine
    at_rest = ~moving
    out.loc[at_rest, "x_m"] = e.L1 * math.cos(s.theta) + e.L4 * math.cos(s.phi)
    out.loc[at_rest, "y_m"] = s.H + e.L1 * math.sin(s.theta) + e.L4 * math.sin(s.phi)
    out.attrs["release"] = run.attrs["events"]["release"]
    return out


def shot_events(scene: Scene) -> dict[str, float]:
    """Lift-off and release of a scene, s after the trigger."""
    return dict(simulate(scene, t_eval=[0.0]).attrs["events"])


def engine_points(scene: Scene, true: pd.DataFrame) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Positions (m) of the five tracked points; the projectile in flight after release."""
    e, H = scene.engine, scene.start.H
    th, ps, ph = (true[a].to_numpy() for a in ("theta", "psi", "phi"))
    n = len(th)
    pivot = (np.zeros(n), np.full(n, H))
    spigot = (e.L1 * np.cos(th), H + e.L1 * np.sin(th))
    hinge = (-e.L2 * np.cos(th), H - e.L2 * np.sin(th))
    cw = (hinge[0] + e.L3 * np.cos(ps), hinge[1] + e.L3 * np.sin(ps))
    slung = np.isfinite(ph)
    proj = (
        np.where(slung, spigot[0] + e.L4 * np.cos(ph), true["x_m"].to_numpy()),
        np.where(slung, spigot[1] + e.L4 * np.sin(ph), true["y_m"].to_numpy()),
    )
    return {"pivot": pivot, "spigot": spigot, "hinge": hinge, "counterweight": cw,
            "projectile": proj}


def pick(rng: np.random.Generator, candidates: np.ndarray, count: int) -> np.ndarray:
    """``count`` distinct entries of ``candidates``, sorted."""
    return np.sort(rng.choice(candidates, size=count, replace=False))


def noisy_angles(rng: np.random.Generator, true: pd.DataFrame, sd_deg: float) -> np.ndarray:
    """(n, 3) angles in degrees with Gaussian noise of ``sd_deg``; NaN where the truth is."""
    exact = np.degrees(true[["theta", "psi", "phi"]].to_numpy())
    return exact + rng.normal(0.0, sd_deg, exact.shape)


def blank_cells(rng: np.random.Generator, values: np.ndarray, count: int) -> list[tuple[int, int]]:
    """Empty ``count`` cells (one per row, never the first or last row) of ``values``."""
    rows = pick(rng, np.arange(1, len(values) - 1), count)
    where = []
    for r in rows:
        present = np.nonzero(np.isfinite(values[r]))[0]
        c = int(rng.choice(present))
        values[r, c] = np.nan
        where.append((int(r), c))
    return where


# ------------------------------------------------------------------------------ samples


@dataclass
class Sample:
    """A written sample: its file name, text, and a README entry."""

    name: str
    text: str
    readme: str


def _note(rows: Sequence[int], what: str) -> str:
    return f"{len(rows)} {what}" if rows else f"no {what}"


def filmed_shot(index: int, scene_name: str, fps: float, start: float | None = None
                ) -> tuple[np.random.Generator, Scene, np.ndarray, np.ndarray, pd.DataFrame]:
    """The random stream of sample ``index``, the scene, the frame numbers and times (s, video
    time; see :func:`frame_range`) and the true shot at those times."""
    rng = np.random.default_rng([SEED, index])
    scene = load_scene(scene_name)
    frames = frame_range(fps, shot_events(scene)["release"], start=start)
    t = frames / fps
    return rng, scene, frames, t, truth(scene, t)


def generic_sample(name: str, scene_name: str, fps: float, sd: float, n_absent: int,
                   n_blank: int, index: int) -> Sample:
    """A generic log: 'fps' frames, Gaussian angle noise 'sd' (deg), absent rows, empty cells."""
    rng, scene, _, t, true = filmed_shot(index, scene_name, fps)
    deg = noisy_angles(rng, true, sd)
    absent = pick(rng, np.arange(1, len(t) - 1), n_absent)
    keep = np.ones(len(t), dtype=bool)
    keep[absent] = False
    blanks = blank_cells(rng, deg[keep], n_blank)
    kept = np.nonzero(keep)[0]
    for r, c in blanks:
        deg[kept[r], c] = np.nan
    comment = (f"SYNTHETIC log made by data_samples/make_samples.py from {scene_name}: "
               f"not a measurement (see README.md)")
    text = generic_text(comment, t, deg, keep)
    blank_times = ", ".join(f"{t[kept[r]]:.4f} s ({('theta', 'psi', 'phi')[c]})"
                            for r, c in blanks)
    readme = (
        f"Generic angle log of `{scene_name}`: {fps:g} fps, video time {t[0]:.4f}–{t[-1]:.4f} s "
        f"(trigger at {TRIGGER:g} s), Gaussian noise sd {sd:g}° on each angle, rounded to "
        f"0.001°; {_note(list(absent), 'absent rows')} (frames at "
        f"{', '.join(f'{t[k]:.4f}' for k in absent)} s) and "
        f"{_note(blanks, 'empty cells')} ({blank_times}); phi empty after release. "
        f"Seed `[{SEED}, {index}]`. Read: `read_log(path)`."
    )
    return Sample(name, text, readme)


def tracker_sample(index: int) -> Sample:
    """Tracker, tab, formatted numbers (t 0.0000, θ 0.0°, ω 0°/s), three protractors."""
    name, fps, sd = "horsdal_tracker.txt", 120.0, 0.5
    rng, scene, _, t, true = filmed_shot(index, PAPER_SCENE, fps)
    deg = noisy_angles(rng, true, sd)
    blanks = blank_cells(rng, deg, 4)
    rows = []
    rates = [central_rate(t, deg[:, i]) for i in range(3)]
    shown = wrap_deg(deg)
    branch = sling_branch_note(shown[:, 2])
    for k in range(len(t)):
        cells = [f"{t[k]:.4f}"]
        for i in range(3):
            cells += [fmt(shown[k, i], ".1f"), fmt(rates[i][k], ".0f")]
        rows.append(cells)
    text = tracker_text(list(TRACKER_COLUMNS), ["θ", "ω"], rows, "\t", "\n")
    readme = (
        f"Tracker export of `{PAPER_SCENE}` (`#multi:`, tab, name row and header ending in a "
        f"tab, data rows not, as Tracker writes them): protractor tracks `beam`, `arm`, "
        f"`sling` with columns θ (deg, 0.1°) and ω (deg/s, central difference of the noisy θ, "
        f"as Tracker computes it); {fps:g} fps, video time {t[0]:.4f}–{t[-1]:.4f} s (trigger "
        f"at {TRIGGER:g} s), Gaussian noise sd {sd:g}° on θ; θ wrapped into (−180°, 180°] as "
        f"a protractor reports it (the sling starts at ±180° and flips between the two; "
        f"{branch}); {_note(blanks, 'empty θ cells')}; the sling track ends at release "
        f"(empty cells). "
        f"Seed `[{SEED}, {index}]`. Read: "
        f"`read_log(path, columns={TRACKER_COLUMNS!r})`."
    )
    return Sample(name, text, readme)


def tracker_eu_sample(index: int) -> Sample:
    """Tracker, ``;``, decimal comma, Java scientific numbers, CRLF, θ columns only."""
    name, fps, sd = "horsdal_tracker_multi_decimal_comma.txt", 120.0, 0.5
    rng, scene, _, t, true = filmed_shot(index, PAPER_SCENE, fps)
    deg = noisy_angles(rng, true, sd)
    blanks = blank_cells(rng, deg, 4)
    shown = wrap_deg(deg)
    branch = sling_branch_note(shown[:, 2])
    rows = [[java_sci(t[k], True)] + [java_sci(v, True) for v in shown[k]]
            for k in range(len(t))]
    text = tracker_text(list(TRACKER_EU_COLUMNS), ["θ"], rows, ";", "\r\n")
    readme = (
        f"Tracker export of `{PAPER_SCENE}` from a European locale: `#multi:`, `;`, decimal "
        f"comma, unformatted numbers (`-5,012345E1`), CRLF line ends; protractor tracks "
        f"`Balken`, `Arm`, `Schlinge` with θ only (deg); {fps:g} fps, video time "
        f"{t[0]:.4f}–{t[-1]:.4f} s (trigger at {TRIGGER:g} s), Gaussian noise sd {sd:g}°; θ "
        f"wrapped into (−180°, 180°] ({branch}); {_note(blanks, 'empty θ cells')}; the sling "
        f"track ends at release. Seed `[{SEED}, {index}]`. Read: "
        f"`read_log(path, columns={TRACKER_EU_COLUMNS!r})`."
    )
    return Sample(name, text, readme)


def kinovea_sample(index: int) -> Sample:
    """Kinovea trajectories of the five points, m, 1 cm noise, whole-ms times, 240 fps."""
    name, fps, sd = "horsdal_kinovea.csv", 240.0, 0.01
    rng, scene, _, t, true = filmed_shot(index, PAPER_SCENE, fps)
    pts = engine_points(scene, true)
    noisy = {}
    for role in ROLES:
        x, y = pts[role]
        noisy[role] = (x + rng.normal(0.0, sd, len(t)), y + rng.normal(0.0, sd, len(t)))
    after = ~np.isfinite(true["phi"].to_numpy())
    noisy["projectile"][0][after] = np.nan
    noisy["projectile"][1][after] = np.nan
    lost = []
    for k in pick(rng, np.arange(1, int((~after).sum()) - 1), 6):
        role = str(rng.choice(ROLES[1:]))
        noisy[role][0][k] = noisy[role][1][k] = np.nan
        lost.append(f"{KINOVEA_NAMES[role]} at {t[k] * 1e3:.0f} ms")
    t_ms = np.round(t * 1e3)
    text = kinovea_text(t_ms, noisy)
    mapping = KINOVEA_POINTS
    readme = (
        f"Kinovea trajectory CSV of `{PAPER_SCENE}` (English locale: `,`, decimal point, quoted "
        f"cells, CRLF): points {', '.join(f'`{KINOVEA_NAMES[r]}` ({r})' for r in ROLES)}, "
        f"calibrated in m (the model's axes: origin on the ground under the pivot, y up), "
        f"Gaussian noise sd {sd * 100:g} cm on each coordinate, rounded to 1 mm; {fps:g} fps, "
        f"`Time` in whole ms ({t_ms[0]:.0f}–{t_ms[-1]:.0f}, trigger at {TRIGGER * 1e3:g}); "
        f"the stone's trajectory ends at release; {len(lost)} lost positions "
        f"({'; '.join(lost)}). Seed `[{SEED}, {index}]`. Read: "
        f"`read_log(path, fps={fps:g}, points={mapping!r})`."
    )
    return Sample(name, text, readme)


def deeplabcut_sample(index: int) -> Sample:
    """DeepLabCut keypoints in px (y down), 120 fps from frame 0, some low likelihoods."""
    name, fps = "horsdal_dlc.csv", 120.0
    rng, scene, frames, t, true = filmed_shot(index, PAPER_SCENE, fps, start=0.0)
    pts = engine_points(scene, true)
    n = len(t)
    flying = ~np.isfinite(true["phi"].to_numpy())
    px: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    n_low = 0
    for role in ROLES:
        x, y = pts[role]
        u = DLC_ORIGIN[0] + DLC_SCALE * x + rng.normal(0.0, DLC_NOISE_PX, n)
        v = DLC_ORIGIN[1] - DLC_SCALE * y + rng.normal(0.0, DLC_NOISE_PX, n)
        p = rng.uniform(0.95, 0.9999, n)
        if role != "pivot":
            low = rng.random(n) < 0.02
            n_low += int(low.sum())
            p[low] = rng.uniform(0.2, 0.85, int(low.sum()))
            off = rng.uniform(10.0, 40.0, int(low.sum()))
            ang = rng.uniform(0.0, 2 * np.pi, int(low.sum()))
            u[low] += off * np.cos(ang)
            v[low] += off * np.sin(ang)
        if role == "projectile":
            m = int(flying.sum())
            p[flying] = rng.uniform(0.01, 0.3, m)
            u[flying] += rng.normal(0.0, 20.0, m)
            v[flying] += rng.normal(0.0, 20.0, m)
        px[role] = (u, v, p)
    text = deeplabcut_text(frames, px)
    readme = (
        f"DeepLabCut CSV of `{PAPER_SCENE}`: bodyparts "
        f"{', '.join(f'`{DLC_NAMES[r]}` ({r})' for r in ROLES)} in pixels of a 1920×1080 "
        f"camera, {DLC_SCALE:g} px/m, the model's origin (ground under the pivot) at pixel "
        f"{DLC_ORIGIN}, image y down; Gaussian noise sd {DLC_NOISE_PX:g} px on each coordinate, "
        f"likelihood 0.95–0.9999 for good positions; {n_low} positions (2 % of the moving "
        f"points) mislocated by 10–40 px with likelihood 0.2–0.85; after release the stone "
        f"keypoint is lost (likelihood 0.01–0.3, position off by ~20 px). {fps:g} fps, frame "
        f"index {frames[0]}–{frames[-1]} from the start of the video (trigger at frame "
        f"{TRIGGER * fps:g}, t = {TRIGGER:g} s). Seed `[{SEED}, {index}]`. Read: "
        f"`read_log(path, fps={fps:g}, points={DLC_POINTS!r}, min_likelihood=0.9)` (the "
        f"mislocated positions have likelihood up to 0.85: stricter than the default 0.6, "
        f"DeepLabCut's own `pcutoff`; at 0.6 those above it are found instead by the engine's "
        f"geometry and left out, with a note)."
    )
    return Sample(name, text, readme)


def backyard_scene_text() -> str:
    """The BACKYARD engine as a scene file."""
    out = ["# SYNTHETIC samples only: the small backyard engine of tests/conftest.py",
           "# (written by data_samples/make_samples.py)."]
    units = {"L1": "m", "L2": "m", "L_CM": "m", "L3": "m", "L4": "m", "m_b": "kg", "M": "kg",
             "m": "kg", "theta_deg": "deg", "psi_deg": "deg", "phi_deg": "deg",
             "velocity_angle_deg": "deg", "g": "m/s²"}
    for table, values in BACKYARD.items():
        out.append("")
        out.append(f"[{table}]")
        for key, value in values.items():
            out.append(f"{key} = {float(value)!r}  # {units[key]}")
    return "\n".join(out) + "\n"


def build() -> list[Sample]:
    """Every sample, in order."""
    samples = [
        generic_sample("horsdal_240fps.csv", PAPER_SCENE, 240.0, 0.3, 4, 6, 1),
        tracker_sample(2),
        tracker_eu_sample(3),
        kinovea_sample(4),
        deeplabcut_sample(5),
        generic_sample("backyard_240fps.csv", BACKYARD_SCENE, 240.0, 0.3, 3, 4, 6),
    ]
    samples.append(Sample(BACKYARD_SCENE, backyard_scene_text(),
                          "Scene file of the backyard engine (tests/conftest.py BACKYARD), "
                          "for `backyard_240fps.csv`."))
    samples.append(Sample("README.md", readme_text(samples, seed=SEED, trigger=TRIGGER,
                                                    before=BEFORE, after=AFTER), ""))
    return samples


# ------------------------------------------------------------------------------ writing


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_samples(out: Path, log: Callable[[str], None] = print) -> list[Path]:
    """Write every sample into the folder ``out`` (created if missing); return the paths."""
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for s in build():
        p = out / s.name
        write_atomic(p, s.text.encode("utf-8"))
        log(f"wrote {p}")
        paths.append(p)
    return paths


def main(argv: Sequence[str] | None = None) -> int:
    """Command line: ``make_samples.py [--out DIR]``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE,
                        help="folder to write into (default: data_samples/)")
    args = parser.parse_args(argv)
    write_samples(args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
