"""Values users bring, at their worst: numbers that are no numbers, numbers no engine has,
a cell typed 90° off, times that lost their precision, a scene that is not the engine
filmed. Each is a one-line refusal naming the key or row, or a warning naming the row,
never a traceback and never a silently different result (issue 21)."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from trebuchet import Scene, TrebuchetInputError, read_log
from trebuchet.core.errors import TrebuchetDataWarning
from trebuchet.ingest.logs.scene_check import scene_check

SAMPLES = Path(__file__).resolve().parents[1] / "data_samples"
LOG = SAMPLES / "horsdal_240fps.csv"
SCENE = SAMPLES / "horsdal_large.toml"


def _lines() -> list[str]:
    return LOG.read_text(encoding="utf-8").splitlines()


def _write(tmp_path: Path, lines: list[str], name: str = "shot.csv") -> Path:
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _cell(lines: list[str], row: int, col: int, fn) -> list[str]:
    """The lines with the cell of 1-based ``row``, 0-based ``col`` replaced by fn(cell)."""
    out = list(lines)
    cells = out[row - 1].split(",")
    cells[col] = fn(cells[col])
    out[row - 1] = ",".join(cells)
    return out


def _refusal(call, *args, **kwargs) -> str:
    with pytest.raises(TrebuchetInputError) as err, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        call(*args, **kwargs)
    message = str(err.value)
    assert "\n" not in message
    return message


def _read(path: Path, **kwargs) -> tuple[pd.DataFrame, list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        df = read_log(path, **kwargs)
    return df, [str(w.message) for w in caught if issubclass(w.category, TrebuchetDataWarning)]


# --------------------------------------------------------------------------- numbers

@pytest.mark.parametrize("fn", [
    lambda s: s[:2] + "_" + s[2:],                                          # -4_3.010
    lambda s: s.translate(str.maketrans("0123456789", "٠١٢٣٤٥٦٧٨٩")),        # Arabic-Indic
    lambda s: s.translate(str.maketrans("0123456789", "０１２３４５６７８９")),  # full width
])
def test_only_ascii_decimals_are_numbers(tmp_path, fn):
    """float() reads '-5_0.1' and digits of other scripts; CSV tools do not: refused, naming
    the row and the column."""
    shown = fn(_lines()[99].split(",")[1])
    path = _write(tmp_path, _cell(_lines(), 100, 1, fn))
    message = _refusal(read_log, path)
    assert "shot.csv, row 100, column 'theta (deg)'" in message and repr(shown) in message
    assert "ASCII digits" in message


# --------------------------------------------------------------------------- outliers

@pytest.mark.parametrize("offset", [30.0, 90.0])
def test_one_cell_off_by_tens_of_degrees_is_left_out_and_named(tmp_path, offset):
    """One theta cell off by +30° or +90° was absorbed (the noise estimate went from 0.31° to
    5°): no smooth motion reaches it from its neighbours, so it becomes a gap, named in a
    warning, and the log reads as it does with that cell empty."""
    row = 150
    bad = _write(tmp_path, _cell(_lines(), row, 1, lambda s: f"{float(s) + offset:.3f}"))
    gap = _write(tmp_path, _cell(_lines(), row, 1, lambda s: ""), "gap.csv")
    df, notes = _read(bad)
    expected, _ = _read(gap)
    pd.testing.assert_frame_equal(df, expected, check_exact=True)
    named = [n for n in notes if "jumps off the motion" in n]
    assert len(named) == 1 and f"row {row} " in named[0] and "theta" in named[0]


def test_no_frame_of_the_shipped_logs_is_taken_for_an_outlier():
    for name in ("horsdal_240fps.csv", "backyard_240fps.csv"):
        _, notes = _read(SAMPLES / name)
        assert not any("jumps off the motion" in n for n in notes), name


@pytest.mark.parametrize("offset", [30.0, 90.0])
def test_the_loads_of_a_log_with_one_bad_cell_are_those_of_the_clean_log(tmp_path, offset):
    """reconstruct on the shipped log with one theta cell off by 30° or 90°: the noise
    estimate and the peak loads are the clean log's (to a gap's effect, well under 1 %)."""
    from trebuchet.ingest.reconstruct import reconstruct

    bad = _write(tmp_path, _cell(_lines(), 150, 1, lambda s: f"{float(s) + offset:.3f}"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        clean = reconstruct(LOG, SCENE)
        hit = reconstruct(bad, SCENE)
    from trebuchet.ingest.reconstruction import reconstruction_of

    noise = {k: math.degrees(v["r_sd"]) for k, v in reconstruction_of(hit).noise.items()}
    noise0 = {k: math.degrees(v["r_sd"]) for k, v in reconstruction_of(clean).noise.items()}
    assert noise["theta"] == pytest.approx(noise0["theta"], rel=0.05)
    for col in ("F_R_abs", "F_H_abs", "F_S_abs", "torque"):
        peak, peak0 = np.nanmax(np.abs(hit[col])), np.nanmax(np.abs(clean[col]))
        assert peak == pytest.approx(peak0, rel=0.01), col


# --------------------------------------------------------------------------- time

def test_times_that_lost_their_precision_are_refused(tmp_path):
    """Times offset by 1e15 s are 0.125 s apart at best: 319 of 332 rows merged into 13
    with a small sd. Now refused, naming the column and the resolution left."""
    lines = _lines()
    shifted = lines[:2] + [",".join([f"{float(r.split(',')[0]) + 1e15:.6f}"]
                                     + r.split(",")[1:]) for r in lines[2:]]
    message = _refusal(read_log, _write(tmp_path, shifted))
    assert "shot.csv, column 't (s)'" in message and "resolution of only 0.125 s" in message


def test_a_frame_number_no_video_has_is_refused(tmp_path):
    lines = (SAMPLES / "horsdal_dlc.csv").read_text().splitlines()
    lines[-1] = "1000000000000," + lines[-1].split(",", 1)[1]
    path = _write(tmp_path, lines, "dlc.csv")
    message = _refusal(read_log, path, fps=120)
    assert f"dlc.csv, row {len(lines)}" in message and "frame number" in message


# --------------------------------------------------------------------------- scenes

def _scene(tmp_path: Path, old: str, new: str) -> Path:
    text = SCENE.read_text(encoding="utf-8")
    assert old in text
    path = tmp_path / "scene.toml"
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    return path


@pytest.mark.parametrize("old, new, expected", [
    ("M = 19100.0", "M = 1e308", "[engine] M: = 1e+308 kg: beyond 1e+15"),
    ("M = 19100.0", "M = 1" + "0" * 400, "[engine] M: = an integer of about 401 digits"),
    ("M = 19100.0", "M = 1" + "0" * 5000, "line 11: a number of more than 4300 digits"),
    ("L1 = 6.48", "L1 = " + "[" * 3000 + "]" * 3000, "nested within each other"),
    ("m = 100.0", "m = " + "{a = " * 3000 + "1" + "}" * 3000, "nested within each other"),
    ("L1 = 6.48", "L1 = [[1.0]]", "[engine] L1: must be a number, got an array of 1"),
    ("L1 = 6.48", "L1 = 1e200", "[engine] L1: = 1e+200 m: beyond 1e+15"),
    ("L4 = 5.55", "L4 = 5e-324", "[engine] L4: = 4.941e-324: less than 1e-06"),
])
def test_scene_values_no_engine_has_are_refused_by_key(tmp_path, old, new, expected):
    """M = 1e308 ended in ZeroDivisionError, 10^400 in OverflowError, 5000 digits in
    ValueError, nested arrays and inline tables in RecursionError, L1 = 1e200 in "Engine:
    I = inf" (a key the file does not hold): each now names the file and the key."""
    message = _refusal(Scene.from_toml, _scene(tmp_path, old, new))
    assert "scene.toml" in message and expected in message


def test_a_moment_of_inertia_that_overflows_names_the_keys_it_comes_from():
    data = Scene.from_toml(SCENE).to_dict()
    data["engine"].pop("I", None)
    from trebuchet.model import scene as scene_module

    with pytest.raises(TrebuchetInputError, match=r"\[engine\] I: \(not given: m_b .* of m_b, "
                                                  r"L1 and L2\) = inf"):
        original = scene_module.default_moment_of_inertia
        scene_module.default_moment_of_inertia = lambda *a: math.inf
        try:
            Scene.from_dict(data, source="x.toml")
        finally:
            scene_module.default_moment_of_inertia = original


def test_a_scene_whose_sling_cannot_be_the_logs_is_refused_naming_L4(tmp_path):
    """A 1 mm sling on the shipped log gave NaN loads on 285 of 332 rows and a peak |F_S|
    printed as 0, with exit status 0: the log's θ and φ drag the projectile along the trough
    as a 5.5 m sling does, which the scene's L4 cannot be."""
    log, _ = _read(LOG)
    message = _refusal(scene_check, log, _scene(tmp_path, "L4 = 5.55", "L4 = 0.001"))
    assert "horsdal_240fps.csv" in message and "[engine] L4 = 0.001 m" in message
    assert "sling of 5.51 m" in message
    assert "5.51 m" in scene_check(log, SCENE).note


def test_a_file_cut_inside_a_row_says_so_naming_the_row(tmp_path):
    text = LOG.read_text(encoding="utf-8")
    end = text.index("\n", len(text) // 2)
    cut = text[: text.rindex(",", 0, end)]  # inside a row, its last cell gone
    path = tmp_path / "cut.csv"
    path.write_text(cut, encoding="utf-8")
    _, notes = _read(path)
    last = cut.count("\n") + 1
    assert any(f"ends inside row {last}" in n and "cut" in n for n in notes)
    _, honest = _read(LOG)
    assert not any("ends inside row" in n for n in honest)


def test_a_byte_order_mark_before_a_scene_is_read(tmp_path):
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + SCENE.read_bytes())
    assert Scene.from_toml(path) == Scene.from_toml(SCENE)


def test_an_anipose_coordinate_no_survey_reaches_is_refused_naming_it(exports, tmp_path):
    folder, truths = exports
    lines = (folder / "anipose_pose3d.csv").read_text().splitlines()
    cells = lines[40].split(",")
    cells[0] = "1e300"
    lines[40] = ",".join(cells)
    path = _write(tmp_path, lines, "pose.csv")
    message = _refusal(read_log, path, **truths["anipose_pose3d.csv"].read)
    column = lines[0].split(",")[0]
    assert f"pose.csv, row 41, column '{column}'" in message and "1e+300" in message
