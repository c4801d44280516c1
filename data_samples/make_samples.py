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

#: Kinovea point names (object/point) and the read_log ``points=`` mapping for them.
KINOVEA_NAMES = {
    "pivot": "Beam/axle",
    "spigot": "Beam/tip",
    "hinge": "Beam/hinge",
    "counterweight": "Weight/centre",
    "projectile": "Stone/centre",
}
KINOVEA_POINTS = {"pivot": "axle", "spigot": "tip", "hinge": "hinge",
                  "counterweight": "Weight", "projectile": "Stone"}

#: DeepLabCut bodypart names and the read_log ``points=`` mapping for them.
DLC_NAMES = {"pivot": "axle", "spigot": "arm_tip", "hinge": "hinge",
             "counterweight": "weight", "projectile": "stone"}
DLC_POINTS = dict(DLC_NAMES)
DLC_SCORER = "DLC_resnet50_trebuchetJun17shuffle1_200000"
#: Camera of the DeepLabCut sample: px per m, and the pixel of the model's origin.
DLC_SCALE = 40.0
DLC_ORIGIN = (900.0, 1040.0)
DLC_NOISE_PX = 1.0

TRACKER_COLUMNS = {"beam": "theta", "arm": "psi", "sling": "phi"}
TRACKER_EU_COLUMNS = {"Balken": "theta", "Arm": "psi", "Schlinge": "phi"}

ROLES = ("pivot", "spigot", "hinge", "counterweight", "projectile")


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


# ------------------------------------------------------------------------------ formats


def fmt(value: float, spec: str) -> str:
    """``format(value, spec)``, empty for NaN."""
    return "" if not math.isfinite(value) else format(value, spec)


def java_sci(value: float, comma: bool) -> str:
    """Java DecimalFormat ``0.000000E0`` (Tracker's unformatted export); empty for NaN."""
    if not math.isfinite(value):
        return ""
    mantissa, exponent = f"{value:.6E}".split("E")
    text = f"{mantissa}E{int(exponent)}"
    return text.replace(".", ",") if comma else text


def wrap_deg(d: np.ndarray) -> np.ndarray:
    """Angles (deg) into (−180, 180], as Tracker's protractor reports them."""
    return d - 360.0 * np.ceil((d - 180.0) / 360.0)


def sling_branch_note(shown: np.ndarray) -> str:
    """Where the first written sling angle (deg) lies, and what that means when read."""
    first = float(shown[np.isfinite(shown)][0])
    text = f"first sling value {first:+.1f}°"
    if first > 0:
        text += "; `read_log` moves each angle to the paper's start branch and reports it"
    return text


def central_rate(t: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Tracker's ω: ``(θ[i+1] − θ[i−1]) / (t[i+1] − t[i−1])``, NaN without both neighbours."""
    out = np.full(len(d), np.nan)
    out[1:-1] = (d[2:] - d[:-2]) / (t[2:] - t[:-2])
    return out


def generic_text(comment: str, t: np.ndarray, deg: np.ndarray, keep: np.ndarray) -> str:
    """A generic log: a comment line, ``t (s),theta (deg),psi (deg),phi (deg)``, rows."""
    lines = [f"# {comment}", "t (s),theta (deg),psi (deg),phi (deg)"]
    for k in np.nonzero(keep)[0]:
        lines.append(",".join([f"{t[k]:.6f}"] + [fmt(v, ".3f") for v in deg[k]]))
    return "\n".join(lines) + "\n"


def tracker_text(
    names: Sequence[str],
    header: Sequence[str],
    rows: list[list[str]],
    delimiter: str,
    newline: str,
) -> str:
    """Tracker's multi-track export: ``#multi:``, track names, column names, data rows.

    As Tracker writes it: the name row and the header end with the delimiter, the data
    rows do not; ``header`` is the columns of one track (repeated for each).
    """
    name_row = delimiter + "".join(n + delimiter * len(header) for n in names)
    head = "t" + delimiter + "".join(c + delimiter for _ in names for c in header)
    lines = ["#multi:", name_row, head] + [delimiter.join(r) for r in rows]
    return newline.join(lines) + newline


def kinovea_text(t_ms: np.ndarray, points: dict[str, tuple[np.ndarray, np.ndarray]]) -> str:
    """Kinovea trajectory CSV (English locale): quoted cells, ``,``, time in whole ms, CRLF."""
    head = ['"Time"']
    for role in ROLES:
        head += [f'"{KINOVEA_NAMES[role]}/X"', f'"{KINOVEA_NAMES[role]}/Y"']
    lines = [",".join(head)]
    for k, ms in enumerate(t_ms):
        cells = [f'"{int(ms)}"']
        for role in ROLES:
            x, y = points[role]
            for v in (x[k], y[k]):
                cells.append(f'"{v:.3f}"' if math.isfinite(v) else "")
        lines.append(",".join(cells))
    return "\r\n".join(lines) + "\r\n"


def deeplabcut_text(frames: np.ndarray, px: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]
                    ) -> str:
    """DeepLabCut CSV: scorer, bodyparts, coords rows, then frame index, x, y, likelihood."""
    parts = [DLC_NAMES[r] for r in ROLES]
    lines = [
        ",".join(["scorer"] + [DLC_SCORER] * (3 * len(parts))),
        ",".join(["bodyparts"] + [p for p in parts for _ in range(3)]),
        ",".join(["coords"] + ["x", "y", "likelihood"] * len(parts)),
    ]
    for k, f in enumerate(frames):
        cells = [str(int(f))]
        for role in ROLES:
            x, y, p = px[role]
            cells += [f"{x[k]:.4f}", f"{y[k]:.4f}", f"{p[k]:.4f}"]
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"


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
    samples.append(Sample("README.md", readme_text(samples), ""))
    return samples


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


def readme_text(samples: list[Sample]) -> str:
    """The README of the samples: what is synthetic, how each file was made and is read."""
    lines = [
        "# Sample logs: SYNTHETIC",
        "",
        "**Every log in this folder is SYNTHETIC: made by the simulator, not measured.** "
        "They were written by `data_samples/make_samples.py` (run "
        "`.venv/bin/python data_samples/make_samples.py [--out DIR]`; deterministic, master "
        f"seed {SEED}, each file drawing from `numpy.random.default_rng([{SEED}, index])`).",
        "",
        "How they were made: `trebuchet.simulate` of the scene named below at the frame times, "
        f"the engine at rest at its start pose before the trigger at video time {TRIGGER:g} s "
        f"(the log's time does not start at the trigger), from about {BEFORE:g} s before the "
        f"trigger (DeepLabCut: from frame 0) to {AFTER:g} s after release, then Gaussian noise "
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
