"""Files users bring, at their worst: HDF5 files that carry code, corrupt HDF5 files, FIFOs,
devices, huge and cut files. Each is a one-line refusal naming the file, and nothing in a
file runs (issue 21)."""

from __future__ import annotations

import contextlib
import os
import pickle
import signal
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from trebuchet import Scene, TrebuchetInputError, read_log
from trebuchet.ingest.geometry.user_calibration import read_calibration
from trebuchet.ingest.readers.pickle_literals import literal

SAMPLES = Path(__file__).resolve().parents[1] / "data_samples"
h5py = pytest.importorskip("h5py")


class _Payload:
    """Unpickled, it creates the file ``path``: the proof that code from the file ran."""

    def __init__(self, path: str) -> None:
        self.path = path

    def __reduce__(self):
        return (exec, (f"open({self.path!r}, 'w').close()",))


def _quiet_read(path: Path, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return read_log(path, **kwargs)


def _refusal(call, *args, **kwargs) -> str:
    with pytest.raises(TrebuchetInputError) as err, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        call(*args, **kwargs)
    message = str(err.value)
    assert "\n" not in message
    return message


@contextlib.contextmanager
def _within(seconds: int):
    """Fail (instead of hanging the suite) when the block takes longer than ``seconds``."""
    def expire(signum, frame):
        raise TimeoutError(f"still running after {seconds} s")

    old = signal.signal(signal.SIGALRM, expire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


# --------------------------------------------------------------------------- no code runs

def _dlc(exports, name: str = "dlc_single.h5"):
    folder, truths = exports
    if name not in truths:
        pytest.skip("PyTables is needed to write the DeepLabCut .h5 fixtures")
    return folder / name, truths[name].read


def test_an_object_column_in_a_deeplabcut_h5_is_refused_and_nothing_runs(exports, tmp_path):
    """pandas writes a column of Python objects pickled ("fixed" format); pandas' reader
    unpickles it, which ran the payload. Read with h5py, it is refused unread."""
    honest, read = _dlc(exports)
    marker = tmp_path / "code_ran"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df = pd.read_hdf(honest)  # the honest fixture, written by the tests themselves
        df[df.columns[0][:-1] + ("note",)] = [_Payload(str(marker))] + [0] * (len(df) - 1)
        evil = tmp_path / "evil.h5"
        df.to_hdf(evil, key="df_with_missing", format="fixed", mode="w")
    assert not marker.exists()
    message = _refusal(read_log, evil, **read)
    assert not marker.exists(), "code from the file ran"
    assert "evil.h5" in message and "block1_values" in message and "pickled" in message


def test_a_pickled_attribute_in_a_deeplabcut_table_is_refused_and_nothing_runs(exports,
                                                                               tmp_path):
    """In pandas' "table" format the column names are pickled attributes, which PyTables
    unpickles on reading: one holding a call is refused, nothing unpickled."""
    honest, read = _dlc(exports)
    marker = tmp_path / "code_ran"
    evil = tmp_path / "evil_table.h5"
    evil.write_bytes(honest.read_bytes())
    with h5py.File(evil, "r+") as f:
        f["df_with_missing"].attrs["non_index_axes"] = np.bytes_(
            pickle.dumps(_Payload(str(marker)), protocol=0))
    message = _refusal(read_log, evil, **read)
    assert not marker.exists(), "code from the file ran"
    assert "evil_table.h5" in message and "non_index_axes" in message
    assert "pickled Python object" in message


@pytest.mark.parametrize("protocol", range(6))
def test_plain_pickles_are_read_and_calls_refused_at_every_protocol(protocol):
    names = [(1, [("DLC_scorer", "axle", "x"), ("DLC_scorer", "axle", "likelihood")])]
    assert literal(pickle.dumps(names, protocol=protocol), "attr") == names
    info = {1: {"names": ["scorer", "bodyparts", "coords"], "type": "MultiIndex"}, "index": {}}
    assert literal(pickle.dumps(info, protocol=protocol), "attr") == info
    with pytest.raises(TrebuchetInputError, match="pickled Python object"):
        literal(pickle.dumps(_Payload("/nowhere"), protocol=protocol), "attr")


@pytest.mark.parametrize("name, csv, individual", [
    ("dlc_single.h5", "dlc_single.csv", None),
    ("dlc_multi_el.h5", "dlc_multi.csv", "ind1"),
])
def test_honest_deeplabcut_h5_reads_as_its_csv(exports, name, csv, individual):
    """The .h5 and the CSV DeepLabCut writes of one analysis read identically, bit for bit
    (the .h5 now through h5py), in pandas' "table" format and in its "fixed" format."""
    path, read = _dlc(exports, name)
    folder = path.parent
    from_csv = _quiet_read(folder / csv, **read)
    from_h5 = _quiet_read(path, **read)
    pd.testing.assert_frame_equal(from_h5, from_csv, check_exact=True)
    fixed = folder / f"fixed_{name}"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        key = "tracks" if individual else "df_with_missing"
        pd.read_hdf(path).to_hdf(fixed, key=key, format="fixed", mode="w")
    pd.testing.assert_frame_equal(_quiet_read(fixed, **read), from_csv, check_exact=True)


# --------------------------------------------------------------------------- corrupt HDF5

def _edited(src: Path, target: Path, edit) -> Path:
    target.write_bytes(src.read_bytes())
    with h5py.File(target, "r+") as f:
        edit(f)
    return target


def _replace(f, name: str, data) -> None:
    attrs = dict(f[name].attrs)
    del f[name]
    f[name] = data
    f[name].attrs.update(attrs)


@pytest.mark.parametrize("case, edit, expected", [
    ("scores_shape", lambda f: _replace(f, "point_scores", f["point_scores"][()][..., :-7]),
     "dataset 'point_scores'"),
    ("tracks_bool", lambda f: _replace(f, "tracks", f["tracks"][()] > 500),
     "dataset 'tracks': holds bool"),
    ("tracks_3d", lambda f: _replace(f, "tracks", f["tracks"][()][0]), "dataset 'tracks'"),
    ("huge_shape", lambda f: (f.__delitem__("tracks"), f.create_dataset(
        "tracks", shape=(2, 2, 5, 2_000_000_000), dtype="f8", chunks=(1, 2, 5, 1024))),
     "MiB"),
])
def test_corrupt_sleap_h5_is_a_one_line_refusal(exports, tmp_path, case, edit, expected):
    folder, truths = exports
    name = "sleap_two_tracks.analysis.h5"
    if name not in truths:
        pytest.skip("h5py is needed to write the SLEAP fixtures")
    path = _edited(folder / name, tmp_path / f"{case}.h5", edit)
    message = _refusal(read_log, path, **truths[name].read)
    assert f"{case}.h5" in message and expected in message


def _table_values(f, fn):
    t = f["df_with_missing/table"][()]
    t["values_block_0"] = fn(t["values_block_0"])
    _replace(f["df_with_missing"], "table", t)


def _table_index(f, fn):
    t = f["df_with_missing/table"][()]
    t["index"] = fn(t["index"])
    _replace(f["df_with_missing"], "table", t)


@pytest.mark.parametrize("case, edit, expected", [
    ("attrs_garbage", lambda f: f["df_with_missing"].attrs.__setitem__(
        "non_index_axes", np.bytes_(b"(lp0\n(I1\n(lp1\ngarbage\x00")), "non_index_axes"),
    ("value_1e300", lambda f: _table_values(f, lambda v: np.where(
        np.arange(len(v))[:, None] == 60, 1e300, v)), "row 61"),
    ("index_1e15", lambda f: _table_index(f, lambda i: i + 10**15), "frame number"),
    ("no_table", lambda f: f["df_with_missing"].__delitem__("table"), "no dataset 'table'"),
])
def test_corrupt_deeplabcut_h5_is_a_one_line_refusal(exports, tmp_path, case, edit, expected):
    honest, read = _dlc(exports)
    path = _edited(honest, tmp_path / f"{case}.h5", edit)
    message = _refusal(read_log, path, **read)
    assert f"{case}.h5" in message and expected in message


def test_a_cut_hdf5_file_is_a_one_line_refusal(exports, tmp_path):
    honest, read = _dlc(exports)
    cut = tmp_path / "cut.h5"
    cut.write_bytes(honest.read_bytes()[: honest.stat().st_size // 2])
    assert "cut.h5" in _refusal(read_log, cut, **read)


# --------------------------------------------------------------------------- special paths

READERS = {"log": read_log, "scene": Scene.from_toml, "calibration": read_calibration}


@pytest.mark.parametrize("kind", sorted(READERS))
@pytest.mark.parametrize("special", ["fifo", "/dev/zero", "/dev/urandom", "folder",
                                     "sparse"])
def test_no_regular_file_is_refused_at_once(tmp_path, kind, special):
    """A FIFO blocked forever, /dev/zero and a 5 GB sparse file were read whole into memory,
    /dev/urandom never ended: each is now refused in one line, at once."""
    if special == "fifo":
        path = tmp_path / "pipe.csv"
        os.mkfifo(path)
    elif special == "folder":
        path = tmp_path / "folder.csv"
        path.mkdir()
    elif special == "sparse":
        path = tmp_path / "sparse.csv"
        with open(path, "wb") as f:
            f.truncate(5 << 30)
    else:
        path = Path(special)
        if not path.exists():
            pytest.skip(f"no {special} here")
    with _within(10):
        message = _refusal(READERS[kind], path)
    assert path.name in message
    words = {"fifo": "FIFO", "/dev/zero": "character device", "/dev/urandom":
             "character device", "folder": "folder", "sparse": "5 GiB"}
    assert words[special] in message


# --------------------------------------------------------------------------- text

def test_utf16_with_an_odd_byte_count_is_a_one_line_refusal(tmp_path):
    text = (SAMPLES / "horsdal_240fps.csv").read_text(encoding="utf-8")
    path = tmp_path / "odd.csv"
    path.write_bytes("\ufeff".encode("utf-16-le") + text.encode("utf-16-le") + b"x")
    message = _refusal(read_log, path)
    assert "odd.csv" in message and "UTF-16" in message and "odd number of bytes" in message
    even = tmp_path / "even.csv"
    even.write_bytes("\ufeff".encode("utf-16-le") + text.encode("utf-16-le"))
    pd.testing.assert_frame_equal(_quiet_read(even), _quiet_read(SAMPLES / "horsdal_240fps.csv"))


@pytest.mark.parametrize("where", ["cell", "header"])
def test_a_cell_over_the_csv_field_limit_names_its_row(tmp_path, where):
    lines = (SAMPLES / "horsdal_240fps.csv").read_text(encoding="utf-8").splitlines()
    k = 40 if where == "cell" else 1
    lines[k] += "," + "9" * 140_000
    path = tmp_path / "long.csv"
    path.write_text("\n".join(lines) + "\n")
    message = _refusal(read_log, path)
    assert f"long.csv, row {k + 1}" in message and "131,072 characters" in message


def test_a_text_log_over_its_bound_is_refused_unread(tmp_path):
    path = tmp_path / "big.csv"
    with open(path, "wb") as f:
        f.write((SAMPLES / "horsdal_240fps.csv").read_bytes())
        f.truncate(65 << 20)
    message = _refusal(read_log, path)
    assert "big.csv" in message and "64 MiB" in message


def test_calibration_json_nested_deeper_than_python_reads_is_refused(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text('{"camera_matrix": ' + "[" * 100_000 + "]" * 100_000 + "}")
    assert "deep.json" in _refusal(read_calibration, path)


def test_collinear_image_points_are_a_refusal_not_a_linalg_error(tmp_path):
    lines = (SAMPLES / "video_paper_points.csv").read_text().splitlines()
    head = lines[0].split(",")
    u = next(i for i, c in enumerate(head) if c.strip().startswith("u"))
    rows = [ln.split(",") for ln in lines[1:] if ln.strip()]
    for r in rows:
        r[u] = "100.0"
    path = tmp_path / "line.csv"
    path.write_text("\n".join([lines[0]] + [",".join(r) for r in rows]) + "\n")
    message = _refusal(read_calibration, path)
    assert "line.csv" in message and "homography" in message


def test_printable_messages_hold_no_terminal_control(tmp_path, capsys):
    """A column named with escape sequences cannot clear or retitle the terminal: every
    message (errors, warnings, the repairs the command prints) escapes it."""
    lines = (SAMPLES / "horsdal_240fps.csv").read_text(encoding="utf-8").splitlines()
    lines[1] = lines[1].replace("psi (deg)", "p\x1bc\x1b7\x07si (deg)")
    path = tmp_path / "ctl.csv"
    path.write_text("\n".join(lines) + "\n")
    message = _refusal(read_log, path)
    assert "\\x1bc" in message and "\x1b" not in message and "\x07" not in message
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        df = read_log(path, columns={"p\x1bc\x1b7\x07si (deg)": "psi"})
    texts = [str(w.message) for w in caught] + list(df.attrs["log"].repairs)
    assert texts and not any("\x1b" in t or "\x07" in t for t in texts)
