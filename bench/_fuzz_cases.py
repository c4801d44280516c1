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
"""

from __future__ import annotations

import io
import math
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


# --------------------------------------------------------------------------- text logs

def _delimiter(line: str) -> str:
    for d in ("\t", ";", ","):
        if d in line:
            return d
    return " "


def _number(cell: str) -> float | None:
    s = cell.strip().strip('"').replace(",", ".")
    try:
        return float(s)
    except ValueError:
        return None


def _data_lines(lines: list[str], base: Base) -> list[int]:
    """Indexes of the data lines (the time column, or the first, holds a number)."""
    col = base.time_col if base.time_col is not None else 0
    if base.key.startswith("anipose"):
        col = None
    out = []
    for i, line in enumerate(lines):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        cells = line.rstrip("\r\n").split(_delimiter(line))
        probe = cells[-1] if col is None else (cells[col] if col < len(cells) else "")
        if _number(probe) is not None and i > 0:
            out.append(i)
    return out


def _format_like(old: str, value: float) -> str:
    """``value`` written as the cell ``old`` is (quotes, decimal comma, decimals)."""
    raw = old.strip().strip('"')
    decimals = len(raw.split(".")[-1]) if "." in raw else (
        len(raw.split(",")[-1]) if "," in raw and "E" not in raw.upper() else 6)
    text = f"{value:.{min(decimals, 9)}f}"
    if "," in raw:
        text = text.replace(".", ",")
    return f'"{text}"' if old.strip().startswith('"') else text


def _set_cell(line: str, col: int, new: str) -> str:
    end = line[len(line.rstrip("\r\n")):]
    d = _delimiter(line)
    cells = line.rstrip("\r\n").split(d)
    if col < len(cells):
        cells[col] = new
    return d.join(cells) + end


def _cell(line: str, col: int) -> str:
    cells = line.rstrip("\r\n").split(_delimiter(line))
    return cells[col] if col < len(cells) else ""


def text_cases(base: Base, seed: int) -> list[Case]:
    """Mutations of a text log."""
    raw = base.path.read_bytes()
    text = raw.decode("utf-8-sig", errors="replace")
    lines = text.splitlines(keepends=True)
    data = _data_lines(lines, base)
    header = data[0] - 1 if data else 0
    out: list[Case] = []

    def add(mutation: str, expect: str, content: bytes | str, rows: tuple[int, ...] = ()
            ) -> None:
        body = content.encode("utf-8") if isinstance(content, str) else content
        out.append(Case(f"log/{base.key}/{mutation}", base, mutation, expect, body,
                        rows=rows, suffix=base.path.suffix))

    rng = rng_for(seed, base.key)
    middle = [i for i in data[len(data) // 5: 4 * len(data) // 5]]

    def pick(col: int | None) -> int:
        for _ in range(200):
            i = int(rng.choice(middle))
            if col is None or _number(_cell(lines[i], col)) is not None:
                return i
        return int(middle[0])

    joined = "".join
    add("crlf", "same", joined(ln.rstrip("\r\n") + "\r\n" for ln in lines))
    add("utf8_bom", "same", b"\xef\xbb\xbf" + text.encode("utf-8"))
    add("utf16_bom", "same", "\ufeff".encode("utf-16-le") + text.encode("utf-16-le"))
    add("utf16_odd_bytes", "flag", "\ufeff".encode("utf-16-le") + text.encode("utf-16-le")
        + b"x")
    add("blank_lines", "same", text + "\n\n\n")
    vcol = base.value_col
    if vcol is not None:
        for mutation, new in (("cell_text", "abc"), ("cell_inf", "inf"),
                              ("cell_1e400", "1e400"), ("cell_1e300", "1e300"),
                              ("cell_long", "9" * 140_000)):
            i = pick(vcol)
            add(mutation, "flag", joined(lines[:i] + [_set_cell(lines[i], vcol, new)]
                                         + lines[i + 1:]), (i + 1,))
        for mutation, fn in (("cell_underscore", lambda s: re.sub(r"(\d)(\d)", r"\1_\2", s,
                                                                  count=1)),
                             ("cell_arabic_digits", lambda s: s.translate(
                                 str.maketrans("0123456789", "٠١٢٣٤٥٦٧٨٩"))),
                             ("cell_fullwidth_digits", lambda s: s.translate(
                                 str.maketrans("0123456789", "０１２３４５６７８９")))):
            for _ in range(50):
                i = pick(vcol)
                old = _cell(lines[i], vcol)
                new = fn(old)
                if new != old:
                    break
            add(mutation, "refuse", joined(lines[:i] + [_set_cell(lines[i], vcol, new)]
                                           + lines[i + 1:]), (i + 1,))
        if base.angle_unit:
            for step in (30.0, 90.0):
                i = pick(vcol)
                old = _cell(lines[i], vcol)
                shift = step if base.angle_unit == "deg" else math.radians(step)
                new = _format_like(old, _number(old) + shift)
                add(f"angle_outlier_{step:g}deg", "flag",
                    joined(lines[:i] + [_set_cell(lines[i], vcol, new)] + lines[i + 1:]),
                    (i + 1,))
        else:
            i = pick(vcol)
            old = _number(_cell(lines[i], vcol))
            # a quarter of the picture: the largest range of any column but the time's
            spread = 0.0
            for col in range(len(lines[data[0]].split(_delimiter(lines[data[0]])))):
                if col == base.time_col:
                    continue
                vals = [v for k in data if (v := _number(_cell(lines[k], col))) is not None
                        and math.isfinite(v)]
                if vals:
                    spread = max(spread, max(vals) - min(vals))
            new = _format_like(_cell(lines[i], vcol), old + 0.25 * spread)
            add("point_jump", "flag", joined(lines[:i] + [_set_cell(lines[i], vcol, new)]
                                             + lines[i + 1:]), (i + 1,))
    if header >= 0 and data:
        h = lines[header]
        d = _delimiter(h)
        cells = h.rstrip("\r\n").split(d)
        j = vcol if vcol is not None and vcol < len(cells) else 0
        cells_c = list(cells)
        cells_c[j] = cells_c[j][:1] + "\x1b[2J\x1b]0;pwned\x07" + cells_c[j][1:]
        add("header_control_bytes", "any", joined(lines[:header] + [d.join(cells_c) + "\n"]
                                                  + lines[header + 1:]), (header + 1,))
        cells_l = list(cells) + ["x" * 140_000]
        add("header_long", "flag", joined(lines[:header] + [d.join(cells_l) + "\n"]
                                          + lines[header + 1:]), (header + 1,))
    if data:
        i = pick(None)
        add("nul_byte", "flag", joined(lines[:i]) + lines[i][:3] + "\x00" + lines[i][3:]
            + joined(lines[i + 1:]), (i + 1,))
        cut = len(joined(lines[:i])) + len(lines[i]) // 2
        add("truncated", "flag", joined(lines)[:cut], (i + 1,))
        add("row_deleted", "flag", joined(lines[:i] + lines[i + 1:]), (i, i + 1))
        add("row_duplicated", "flag", joined(lines[:i + 1] + [lines[i]] + lines[i + 1:]),
            (i + 1, i + 2))
        add("rows_swapped", "flag", joined(lines[:i] + [lines[i + 1], lines[i]]
                                           + lines[i + 2:]), (i + 1, i + 2))
        d = _delimiter(lines[i])
        add("row_short", "flag", joined(lines[:i] + [lines[i].rstrip("\r\n").rsplit(d, 1)[0]
                                                     + "\n"] + lines[i + 1:]), (i + 1,))
        add("row_extra_cell", "flag", joined(lines[:i] + [lines[i].rstrip("\r\n") + d + "7"
                                                          + "\n"] + lines[i + 1:]), (i + 1,))
        add("garbage_line", "flag", joined(lines[:i] + ["%&/(garbage)=?\n"] + lines[i:]),
            (i + 1,))
        add("only_header", "flag", joined(lines[:data[0]]))
        if base.time_col is not None:
            tc = base.time_col
            shifted = list(lines)
            for k in data:
                v = _number(_cell(lines[k], tc))
                if v is not None:
                    shifted[k] = _set_cell(lines[k], tc, _format_like(_cell(lines[k], tc),
                                                                    v + 1e15))
            add("time_offset_1e15", "refuse", joined(shifted))
            last = data[-1]
            v = _number(_cell(lines[last], tc))
            add("last_time_1e9", "flag", joined(
                lines[:last] + [_set_cell(lines[last], tc, _format_like(
                    _cell(lines[last], tc), v + 1e9))] + lines[last + 1:]), (last + 1,))
    add("empty", "flag", b"")
    add("binary", "flag", bytes(rng.integers(0, 256, 4096, dtype=np.uint8)))
    return out


# --------------------------------------------------------------------------- HDF5 logs

class _Payload:
    """Pickled, it runs ``open(path, 'w')``: the proof that code from a file ran."""

    def __init__(self, path: str) -> None:
        self.path = path

    def __reduce__(self):
        return (exec, (f"open({self.path!r}, 'w').close()",))


def h5_cases(base: Base, seed: int, marker: Path) -> list[Case]:
    """Mutations of an HDF5 log (DeepLabCut's pandas tables, SLEAP's analysis file)."""
    import h5py

    out: list[Case] = []
    src = base.path.read_bytes()

    def add(mutation: str, expect: str, edit, data: bytes | None = None) -> None:
        if data is not None:
            out.append(Case(f"log/{base.key}/{mutation}", base, mutation, expect, data,
                            suffix=".h5"))
            return
        buf = io.BytesIO(src)
        if edit is not None:
            with h5py.File(buf, "r+") as f:
                edit(f)
        out.append(Case(f"log/{base.key}/{mutation}", base, mutation, expect, buf.getvalue(),
                        suffix=".h5"))

    out.append(Case(f"log/{base.key}/truncated", base, "truncated", "flag",
                    src[: len(src) // 2], suffix=".h5"))
    rng = rng_for(seed, base.key)
    flipped = bytearray(src)
    for k in rng.integers(8, min(len(src), 2048), 16):
        flipped[int(k)] ^= 0xFF
    out.append(Case(f"log/{base.key}/header_bytes_flipped", base, "header_bytes_flipped",
                    "flag", bytes(flipped), suffix=".h5"))
    if base.key.startswith("sleap"):
        _sleap_edits(add)
    else:
        _dlc_edits(add, base, marker)
    return out


def _replace(f, name: str, data) -> None:
    attrs = dict(f[name].attrs)
    del f[name]
    f[name] = data
    f[name].attrs.update(attrs)


def _sleap_edits(add) -> None:
    add("scores_shape_mismatch", "flag",
        lambda f: _replace(f, "point_scores", f["point_scores"][()][..., :-7]))
    add("scores_transposed", "flag",
        lambda f: _replace(f, "point_scores", f["point_scores"][()].T))
    add("tracks_bool", "flag", lambda f: _replace(f, "tracks", f["tracks"][()] > 500))
    add("tracks_3d", "flag", lambda f: _replace(f, "tracks", f["tracks"][()][0]))
    add("tracks_inf", "flag", lambda f: _replace(
        f, "tracks", np.where(np.arange(f["tracks"].shape[-1]) == 40, np.inf, f["tracks"][()])))
    add("tracks_1e300", "flag", lambda f: _replace(
        f, "tracks", np.where(np.arange(f["tracks"].shape[-1]) == 40, 1e300, f["tracks"][()])))
    add("node_names_short", "flag",
        lambda f: _replace(f, "node_names", f["node_names"][()][:-1]))
    add("node_names_control", "any", lambda f: _replace(
        f, "node_names", np.array([b"\x1b[2Jaxle" if i == 0 else n for i, n in
                                   enumerate(f["node_names"][()])])))
    add("tracks_missing", "flag", lambda f: f.__delitem__("tracks"))

    def huge(f):
        n_tracks, _, n_nodes, _ = f["tracks"].shape
        del f["tracks"]
        f.create_dataset("tracks", shape=(n_tracks, 2, n_nodes, 2_000_000_000), dtype="f8",
                         chunks=(1, 2, n_nodes, 1024), fillvalue=np.nan)
    add("tracks_huge_shape", "flag", huge)


def _dlc_edits(add, base: Base, marker: Path) -> None:
    import pickle

    evil = pickle.dumps(_Payload(str(marker)), protocol=0)

    def group(f):
        return f[next(iter(f.keys()))]

    def pickled_attribute(f):  # a pandas "table": PyTables unpickles its attributes
        group(f).attrs["non_index_axes"] = np.bytes_(evil)

    if "fixed" in base.key:
        add("pickled_object", "refuse", None, data=_object_column(base.path, marker))
    else:
        add("pickled_attribute", "refuse", pickled_attribute)

    def attrs_garbage(f):
        g = group(f)
        key = "non_index_axes" if "table" in g else "axis0_nlevels"
        g.attrs[key] = np.bytes_(b"(lp0\n(I1\n(lp1\ngarbage\x00\x01")
    add("attrs_garbage", "flag", attrs_garbage)

    def values(f, fn):
        g = group(f)
        if "table" in g:
            t = g["table"][()]
            t["values_block_0"] = fn(t["values_block_0"])
            _replace(g, "table", t)
        else:
            _replace(g, "block0_values", fn(g["block0_values"][()]))
    add("values_inf", "flag", lambda f: values(f, lambda v: np.where(
        np.arange(v.shape[0])[:, None] == 60, np.inf, v)))
    add("values_1e300", "flag", lambda f: values(f, lambda v: np.where(
        np.arange(v.shape[0])[:, None] == 60, 1e300, v)))
    add("values_all_nan", "flag", lambda f: values(f, lambda v: v * np.nan))

    def index(f, fn):
        g = group(f)
        if "table" in g:
            t = g["table"][()]
            t["index"] = fn(t["index"])
            _replace(g, "table", t)
        else:
            _replace(g, "axis1", fn(g["axis1"][()]))
    add("index_offset_1e15", "refuse", lambda f: index(f, lambda i: i + 10**15))
    add("index_last_1e6", "flag", lambda f: index(
        f, lambda i: np.where(np.arange(i.size) == i.size - 1, 10**6, i)))
    add("index_negative", "flag", lambda f: index(f, lambda i: i - 10**18))

    def drop_table(f):
        g = group(f)
        del g["table" if "table" in g else "block0_values"]
    add("data_missing", "flag", drop_table)

    def control(f):
        g = group(f)
        if "table" in g:
            text = bytes(g.attrs["non_index_axes"]).replace(b"Vaxle", b"V\x1b[2Jaxle", 1)
            g.attrs["non_index_axes"] = np.bytes_(text)
            kind = bytes(g["table"].attrs["values_block_0_kind"]).replace(
                b"Vaxle", b"V\x1b[2Jaxle", 1)
            g["table"].attrs["values_block_0_kind"] = np.bytes_(kind)
        else:
            lv = g["axis0_level1"][()]
            _replace(g, "axis0_level1", np.array([b"\x1b[2J" + v for v in lv]))
    add("bodypart_control_bytes", "any", control)


def _object_column(path: Path, marker: Path) -> bytes:
    """The DeepLabCut table of ``path`` with one more column holding a Python object, written
    by pandas in its "fixed" format (a block of pickled cells): the issue's attack."""
    import tempfile
    import warnings

    import pandas as pd

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df = pd.read_hdf(path)  # the honest file this script wrote
        col = df.columns[0][:-1] + ("note",)
        df[col] = [_Payload(str(marker))] + [0] * (len(df) - 1)
        with tempfile.TemporaryDirectory() as tmp:
            target = Path(tmp) / "evil.h5"
            df.to_hdf(target, key="df_with_missing", format="fixed", mode="w")
            return target.read_bytes()


# --------------------------------------------------------------------------- scenes

SCENE_VALUES = {
    "1e308": "1e308", "10^400": "1" + "0" * 400, "5000_digits": "1" + "0" * 5000,
    "nan": "nan", "inf": "inf", "-inf": "-inf", "zero": "0", "negative": "-1",
    "subnormal": "5e-324", "text": '"text"', "bool": "true", "date": "1979-05-27",
    "array": "[1, 2]", "nested_arrays": "[" * 3000 + "]" * 3000,
    "inline_tables": "{a = " * 3000 + "1" + "}" * 3000, "1e-300": "1e-300",
}
SCENE_KEYS = ("L1", "L2", "L_CM", "L3", "L4", "m_b", "M", "m", "theta_deg", "psi_deg",
              "phi_deg", "time", "g")


def _set_key(text: str, key: str, value: str) -> str:
    """The scene with ``key``'s value replaced (the key added to [engine] if absent)."""
    pattern = re.compile(rf"^(\s*{re.escape(key)}\s*=\s*)[^#\n]*", re.M)
    if pattern.search(text):
        return pattern.sub(lambda m: m.group(1) + value + " ", text, count=1)
    return text.replace("[engine]\n", f"[engine]\n{key} = {value}\n", 1)


def scene_cases(base: Base, seed: int) -> list[Case]:
    text = base.path.read_text(encoding="utf-8")
    rng = rng_for(seed, base.key)
    out: list[Case] = []

    def add(mutation: str, expect: str, content: bytes | str) -> None:
        body = content.encode("utf-8") if isinstance(content, str) else content
        out.append(Case(f"scene/{base.key}/{mutation}", base, mutation, expect, body,
                        suffix=".toml"))

    for key in SCENE_KEYS:
        names = sorted(SCENE_VALUES)
        for value in rng.choice(names, size=4, replace=False):
            add(f"{key}={value}", "flag", _set_key(text, key, SCENE_VALUES[value]))
    for key, value in (("M", "1e308"), ("M", "10^400"), ("M", "5000_digits"),
                       ("L1", "nested_arrays"), ("m", "inline_tables"), ("L1", "1e308")):
        name = f"{key}={value}"
        if not any(c.mutation == name for c in out):
            add(name, "flag", _set_key(text, key, SCENE_VALUES[value]))
    add("I=inf", "flag", _set_key(text, "I", "inf"))
    add("L1=1e200 (I overflows)", "flag", _set_key(text, "L1", "1e200"))
    m = re.search(r"^\s*L4\s*=\s*([0-9.eE+-]+)", text, re.M)
    L4 = float(m.group(1))
    for label, value in (("L4=1mm", "0.001"), ("L4/1000", repr(L4 / 1000)),
                         ("L4/2", repr(L4 / 2)), ("L4*2", repr(L4 * 2)), ("g=1000", "1000.0"),
                         ("M*1e6", None), ("m/1e6", None)):
        if value is None:
            key = label[0]
            mm = re.search(rf"^\s*{key}\s*=\s*([0-9.eE+-]+)", text, re.M)
            v = float(mm.group(1))
            value = repr(v * 1e6) if "*" in label else repr(v / 1e6)
        else:
            key = label.split("=")[0].split("/")[0].split("*")[0]
        add(label, "any", _set_key(text, key, value))
    add("crlf", "same", text.replace("\n", "\r\n"))
    add("utf8_bom", "same", b"\xef\xbb\xbf" + text.encode())
    add("utf16_bom", "flag", "\ufeff".encode("utf-16-le") + text.encode("utf-16-le"))
    add("duplicate_key", "flag", text.replace("[engine]\n", "[engine]\nL1 = 1.0\n", 1))
    add("unknown_key_control", "flag", text.replace("[engine]\n", "[engine]\n\"L\x1b[2J\" = 1\n",
                                                    1))
    add("unknown_section", "flag", text + "\n[extra]\nx = 1\n")
    add("no_engine", "flag", re.sub(r"\[engine\][^\[]*", "", text))
    add("syntax_error", "flag", text.replace("=", "==", 1))
    add("huge_comment", "flag", text + "# " + "x" * (3 << 20) + "\n")
    add("empty", "flag", b"")
    add("binary", "flag", bytes(rng.integers(0, 256, 4096, dtype=np.uint8)))
    return out


# --------------------------------------------------------------------------- calibrations

def calibration_cases(base: Base, seed: int) -> list[Case]:
    text = base.path.read_text(encoding="utf-8")
    rng = rng_for(seed, base.key)
    out: list[Case] = []

    def add(mutation: str, expect: str, content: bytes | str) -> None:
        body = content.encode("utf-8") if isinstance(content, str) else content
        out.append(Case(f"calibration/{base.key}/{mutation}", base, mutation, expect, body,
                        suffix=base.path.suffix))

    numbers = list(re.finditer(r"(?<![\w.])-?\d+\.\d+(?:[eE][-+]?\d+)?", text))
    for label, value in (("1e308", "1e308"), ("nan", "nan"), ("inf", "inf"),
                         ("text", "abc"), ("5000_digits", "1" + "0" * 5000),
                         ("long", "9" * 140_000), ("zero", "0.0")):
        m = numbers[int(rng.integers(0, len(numbers)))]
        add(f"number={label}", "flag", text[:m.start()] + value + text[m.end():])
    m = numbers[0]
    add("first_number_negative", "flag", text[:m.start()] + "-" + m.group(0)
        + text[m.end():])
    add("crlf", "same", text.replace("\n", "\r\n"))
    add("utf8_bom", "same", b"\xef\xbb\xbf" + text.encode())
    add("utf16_bom", "flag", "\ufeff".encode("utf-16-le") + text.encode("utf-16-le"))
    add("empty", "flag", b"")
    add("binary", "flag", bytes(rng.integers(0, 256, 4096, dtype=np.uint8)))
    add("huge", "flag", text + "\n" + "#" * (3 << 20) + "\n")
    if base.path.suffix == ".json":
        add("deep_nesting", "flag", '{"camera_matrix": ' + "[" * 100_000 + "]" * 100_000 + "}")
    if base.path.suffix == ".xml":
        lol = ('<?xml version="1.0"?>\n<!DOCTYPE lolz [<!ENTITY lol "lol">'
               + "".join(f'<!ENTITY lol{i} "' + f"&lol{i - 1};" * 10 + '">'
                         for i in range(1, 10)).replace("&lol0;", "&lol;")
               + ']>\n<opencv_storage><camera_matrix>&lol9;</camera_matrix></opencv_storage>\n')
        add("billion_laughs", "flag", lol)
        add("deep_nesting", "flag", "<opencv_storage>" + "<a>" * 100_000 + "</a>" * 100_000
            + "</opencv_storage>")
    if base.path.suffix in (".toml", ".yml"):
        add("deep_nesting", "flag", text.replace("\n", "\nextra = " + "[" * 3000 + "]" * 3000
                                                 + "\n", 1) if base.path.suffix == ".toml"
            else text + "extra: " + "[" * 100_000 + "]" * 100_000 + "\n")
    if base.path.suffix == ".csv":
        lines = text.splitlines(keepends=True)
        collinear = [lines[0]] + [re.sub(r"^([^,]*,)([^,]*)", r"\g<1>100.0", ln)
                                  for ln in lines[1:]]
        add("collinear_image_points", "flag", "".join(collinear))
        add("three_points", "flag", "".join(lines[:4]))
        add("same_point_repeated", "flag", lines[0] + lines[1] * 6)
        add("header_control_bytes", "flag", lines[0].replace("u", "u\x1b[2J", 1)
            + "".join(lines[1:]))
    return out


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
