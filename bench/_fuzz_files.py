"""Mutations of the HDF5 logs (pickled objects and attributes, corrupt metadata, SLEAP
datasets of the wrong type or shape, absurd values and frame numbers), the scenes (every
key set to what no engine has) and the calibration files (deep nesting, billion laughs,
collinear points) of the fuzz corpus (:mod:`._fuzz_cases`)."""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np

from bench._fuzz_cases import Base, Case, rng_for

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


