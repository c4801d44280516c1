"""The cases of ``bench/fuzz_inputs.py``: mutated logs, scenes and calibration files.

Every case is a file a user could bring (or a path that is no file), its bytes fixed by the
seed and the case's name, with what it ought to give:

* ``same``: a benign variant of an honest file (CRLF, a byte-order mark, UTF-16): it must
  read identically;
* ``flag``: damage (a cut row, a cell off by 90°, a cell of text, an object column in an
  HDF5 file): a one-line refusal, or a warning that names the row it touched;
* ``refuse``: something that is no number or no file (``-5_0.1``, Arabic-Indic digits, a
  FIFO): reading it as a number is a silent misreading;
* ``any``: a different but well-formed input (a scene with another sling): whatever it
  gives, no traceback, no hang and no loads that are silently missing.

The bases and special paths are here; the mutations of text logs in :mod:`._fuzz_text`, of
HDF5 logs, scenes and calibration files in :mod:`._fuzz_files`.
"""

from __future__ import annotations

import re
import shutil
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SAMPLES = ROOT / "data_samples"

#: Where an HDF5 payload would write if code from a file ran (relative to the case folder).
MARKER = "CODE_RAN"


@dataclass(frozen=True)
class Base:
    """An honest input the mutations start from: a log (with how it is read and the scene
    it is the shot of), a scene or a calibration file."""

    key: str
    kind: str                      # "log" | "scene" | "calibration"
    path: Path
    read: dict = field(default_factory=dict)
    scene: Path | None = None
    time_col: int | None = None    # the column of the time (or frame) in a text log
    value_col: int | None = None   # a column that is used (an angle or a point's x)
    angle_unit: str | None = None  # the unit of value_col when it is an angle


@dataclass(frozen=True)
class Case:
    """One fuzzed input: ``data`` the file's bytes (None for a ``special`` path: "fifo",
    "dev_zero", ...), ``rows`` the lines it touched (1-based, for the warning that must
    name them), ``expect`` as in the module doc."""

    name: str
    base: Base
    mutation: str
    expect: str
    data: bytes | None = None
    special: str | None = None
    rows: tuple[int, ...] = ()
    suffix: str = ""

    @property
    def kind(self) -> str:
        return self.base.kind


def rng_for(seed: int, name: str) -> np.random.Generator:
    return np.random.default_rng([seed, zlib.crc32(name.encode())])


# --------------------------------------------------------------------------- bases

def bases(folder: Path) -> list[Base]:
    """The honest inputs, written into ``folder``: the shipped samples, the export fixtures
    of tests/exports and a fixed-format DeepLabCut .h5 of one of them."""
    from tests.exports import write_all

    exports = folder / "exports"
    truths = write_all(exports)
    horsdal = SAMPLES / "horsdal_large.toml"
    dlc_points = {"pivot": "axle", "spigot": "arm_tip", "hinge": "hinge",
                  "counterweight": "weight", "projectile": "stone"}
    out = [
        Base("horsdal_240fps.csv", "log", SAMPLES / "horsdal_240fps.csv", {}, horsdal, 0, 1,
             "deg"),
        Base("backyard_240fps.csv", "log", SAMPLES / "backyard_240fps.csv", {},
             SAMPLES / "backyard.toml", 0, 2, "deg"),
        Base("horsdal_tracker.txt", "log", SAMPLES / "horsdal_tracker.txt",
             {"columns": {"beam": "theta", "arm": "psi", "sling": "phi"}}, horsdal, 0, 1,
             "deg"),
        Base("horsdal_tracker_multi_decimal_comma.txt", "log",
             SAMPLES / "horsdal_tracker_multi_decimal_comma.txt",
             {"columns": {"Balken": "theta", "Arm": "psi", "Schlinge": "phi"}}, horsdal, 0, 1,
             "deg"),
        Base("horsdal_kinovea.csv", "log", SAMPLES / "horsdal_kinovea.csv",
             {"fps": 240, "points": {"pivot": "axle", "spigot": "tip", "hinge": "hinge",
                                     "counterweight": "Weight", "projectile": "Stone"}},
             horsdal, 0, 3),
        Base("horsdal_dlc.csv", "log", SAMPLES / "horsdal_dlc.csv",
             {"fps": 120, "points": dlc_points, "min_likelihood": 0.9}, horsdal, 0, 4),
        Base("video_paper_dlc.csv", "log", SAMPLES / "video_paper_dlc.csv",
             {"fps": 240, "calibration": str(SAMPLES / "video_paper_points.csv")},
             SAMPLES / "video_paper.toml", 0, 4),
    ]
    text_exports = {"sleap_two_tracks.analysis.csv": (1, 3), "anipose_pose3d.csv": (None, 0),
                    "kinovea_2025_classic_s_fr.csv": (0, 3), "tracker_pointmass.txt": (0, 1),
                    "generic_nounit_deg.csv": (0, 1), "tracker_protractor_rad.txt": (0, 1)}
    units = {"generic_nounit_deg.csv": "deg", "tracker_protractor_rad.txt": "rad"}
    for name, (tcol, vcol) in text_exports.items():
        out.append(Base(name, "log", exports / name, dict(truths[name].read), horsdal, tcol,
                        vcol, units.get(name)))
    for name in ("dlc_single.h5", "dlc_multi_el.h5", "sleap_two_tracks.analysis.h5",
                 "sleap_untracked.analysis.h5"):
        if name in truths:
            out.append(Base(name, "log", exports / name, dict(truths[name].read), horsdal))
    if "dlc_single.h5" in truths:
        fixed = _fixed_format(exports / "dlc_single.h5", folder / "dlc_single_fixed.h5")
        out.append(Base("dlc_single_fixed.h5", "log", fixed, dict(truths["dlc_single.h5"].read),
                        horsdal))
    out += [Base("horsdal_large.toml", "scene", horsdal),
            Base("backyard.toml", "scene", SAMPLES / "backyard.toml")]
    out += calibration_bases(folder)
    return out


def _fixed_format(table: Path, target: Path) -> Path:
    """The same DeepLabCut table in pandas' "fixed" HDF5 format (older DeepLabCut)."""
    import warnings

    import pandas as pd

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df = pd.read_hdf(table)  # an honest file this script wrote itself
        df.to_hdf(target, key="df_with_missing", format="fixed", mode="w")
    return target


def calibration_bases(folder: Path) -> list[Base]:
    """The shipped calibration files and the same numbers as JSON (camera), TOML (points)
    and OpenCV XML (camera)."""
    points = SAMPLES / "video_paper_points.csv"
    camera = SAMPLES / "video_paper_camera.yml"
    text = camera.read_text()
    K = [float(v) for v in re.search(r"camera_matrix.*?data:\s*\[([^\]]*)\]", text,
                                     re.S).group(1).split(",")]
    d = [float(v) for v in re.search(r"distortion_coefficients.*?data:\s*\[([^\]]*)\]", text,
                                     re.S).group(1).split(",")]
    (folder / "camera.json").write_text(
        '{"camera_matrix": [' + ", ".join(f"[{K[3 * i]}, {K[3 * i + 1]}, {K[3 * i + 2]}]"
                                          for i in range(3))
        + '], "distortion_coefficients": [' + ", ".join(map(str, d)) + "]}\n")
    (folder / "camera.xml").write_text(
        '<?xml version="1.0"?>\n<opencv_storage>\n<camera_matrix type_id="opencv-matrix">'
        "<rows>3</rows><cols>3</cols><dt>d</dt>\n<data>" + " ".join(map(str, K))
        + "</data></camera_matrix>\n<distortion_coefficients type_id=\"opencv-matrix\">"
        f"<rows>1</rows><cols>{len(d)}</cols><dt>d</dt>\n<data>" + " ".join(map(str, d))
        + "</data></distortion_coefficients>\n</opencv_storage>\n")
    rows = [ln.split(",") for ln in points.read_text().splitlines()[1:] if ln.strip()]
    head = [c.strip().split(" ")[0] for c in points.read_text().splitlines()[0].split(",")]
    toml = []
    for r in rows:
        cells = dict(zip(head, r, strict=False))
        toml.append("[[point]]\n" + "".join(f"{k} = {float(cells[k])}\n" for k in "uvxy"))
    (folder / "points.toml").write_text("\n".join(toml))
    return [Base(p.name, "calibration", p) for p in
            (points, camera, folder / "camera.json", folder / "points.toml",
             folder / "camera.xml")]


# --------------------------------------------------------------------------- special paths

SPECIALS = ("fifo", "dev_zero", "dev_urandom", "dev_null", "sparse_5GB", "folder", "missing",
            "symlink_dev_zero")


def special_cases(base: Base) -> list[Case]:
    return [Case(f"{base.kind}/{s}", base, s, "refuse", special=s, suffix=base.path.suffix)
            for s in SPECIALS]


def make_special(kind: str, folder: Path, suffix: str) -> Path:
    """The path of a special case, made in ``folder``."""
    import os

    path = folder / f"special{suffix}"
    if path.exists() or path.is_symlink():
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        else:
            path.unlink()
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "dev_zero":
        return Path("/dev/zero")
    elif kind == "dev_urandom":
        return Path("/dev/urandom")
    elif kind == "dev_null":
        return Path("/dev/null")
    elif kind == "sparse_5GB":
        with open(path, "wb") as f:
            f.truncate(5 << 30)
    elif kind == "folder":
        path.mkdir()
    elif kind == "symlink_dev_zero":
        path.symlink_to("/dev/zero")
    return path


def all_cases(folder: Path, seed: int) -> list[Case]:
    """Every case of the corpus (bases written into ``folder``)."""
    from bench._fuzz_files import calibration_cases, h5_cases, scene_cases
    from bench._fuzz_text import text_cases

    marker = folder / MARKER
    out: list[Case] = []
    done_special: set[str] = set()
    for base in bases(folder):
        if base.kind == "log" and base.path.suffix == ".h5":
            out += h5_cases(base, seed, marker)
        elif base.kind == "log":
            out += text_cases(base, seed)
        elif base.kind == "scene":
            out += scene_cases(base, seed)
        else:
            out += calibration_cases(base, seed)
        if base.kind not in done_special:
            done_special.add(base.kind)
            out += special_cases(base)
    return out
