"""read_log repairs: each made, listed in attrs["log"].repairs, warned as TrebuchetDataWarning."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from trebuchet.core.errors import TrebuchetDataWarning
from trebuchet.ingest.logs.read_log import read_log

FPS = 100.0


def shot(n: int = 30) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """t (s) and three angles (deg) of an accelerating engine, n frames at 100 fps."""
    k = np.arange(n, dtype=float)
    return k / FPS, -50 + 0.4 * k**2, -90 + 0.3 * k**2, -170 + 0.5 * k**2


def write(tmp_path: Path, t, a, b, c, name: str = "shot.csv") -> Path:
    lines = ["t (s),theta (deg),psi (deg),phi (deg)"]
    for row in zip(t, a, b, c, strict=True):
        lines.append(",".join("" if math.isnan(v) else repr(float(v)) for v in row))
    p = tmp_path / name
    p.write_text("\n".join(lines) + "\n")
    return p


def read_warned(path: Path, **kwargs):
    """read_log and the messages of its TrebuchetDataWarnings."""
    with pytest.warns(TrebuchetDataWarning) as record:
        df = read_log(path, **kwargs)
    messages = [str(w.message) for w in record if w.category is TrebuchetDataWarning]
    return df, messages


def test_a_clean_log_warns_nothing(tmp_path):
    p = write(tmp_path, *shot())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        df = read_log(p)
    assert df.attrs["log"].repairs == ()


def test_every_repair_is_both_listed_and_warned(tmp_path):
    t, a, b, c = shot()
    c = c + 360 * (c > -160)  # wrapped at -180/180 in the file: unwrap
    b[7] = np.nan  # a gap
    p = write(tmp_path, t, a, b, c)
    df, messages = read_warned(p)
    assert len(df.attrs["log"].repairs) == 2
    assert messages == [f"shot.csv: {r}" for r in df.attrs["log"].repairs]


def test_unwrap_removes_the_jump_at_180_degrees(tmp_path):
    t, a, b, c = shot()
    wrapped = (c + 180) % 360 - 180  # -170 ... crosses +180 into -180
    assert np.ptp(np.diff(wrapped)) > 300  # the file really has a jump
    df, messages = read_warned(write(tmp_path, t, a, b, wrapped))
    np.testing.assert_allclose(df["phi"], np.radians(c), atol=1e-12)
    assert any("phi unwrapped" in m for m in messages)


def test_repeated_frames_every_third_frame_are_dropped_and_listed(tmp_path):
    t, a, b, c = shot(32)
    # frame 3 repeats frame 2, frame 6 repeats 5, ... up to 30 (a copy in the very last
    # row could not be told from a stop, and is kept)
    copies = np.arange(3, 31, 3)
    for k in copies:
        a[k], b[k], c[k] = a[k - 1], b[k - 1], c[k - 1]
    df, messages = read_warned(write(tmp_path, t, a, b, c))
    assert len(df) == 32 - len(copies)
    kept = np.setdiff1d(np.arange(32), copies)
    np.testing.assert_allclose(df["t"], t[kept], atol=1e-15)
    np.testing.assert_allclose(df["theta"], np.radians(a[kept]), atol=1e-12)
    note = next(m for m in messages if "repeated frames" in m)
    # file rows are frame + 2 (header on line 1)
    assert f"dropped {len(copies)} repeated frames" in note and "rows 5, 8, 11" in note


def test_an_engine_at_rest_is_not_a_repeated_frame(tmp_path):
    t, a, b, c = shot(40)
    a[:12], b[:12], c[:12] = a[0], b[0], c[0]  # at rest for 12 frames, then moving
    a[12:] = a[12:] - a[12] + a[0] + 0.01
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        df = read_log(write(tmp_path, t, a, b, c))
    assert len(df) == 40


def test_a_pair_of_equal_rows_where_the_engine_turns_back_is_kept(tmp_path):
    t, a, b, c = shot(20)
    a = 10 * np.cos(np.arange(20) / 3)  # theta swings; equal pair at a turning point
    b = b.copy()
    c = c.copy()
    a[9] = a[8]
    b[9], c[9] = b[8], c[8]
    b[10] = b[8] - 1  # every angle turns back after the pair
    c[10] = c[8] - 1
    a[10] = a[8] - 1 if a[8] > a[7] else a[8] + 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        df = read_log(write(tmp_path, t, a, b, c))
    assert len(df) == 20


def test_duplicate_timestamps_identical_rows_dropped(tmp_path):
    t, a, b, c = shot()
    idx = np.insert(np.arange(30), 10, 9)  # row of frame 9 written twice
    df, messages = read_warned(write(tmp_path, t[idx], a[idx], b[idx], c[idx]))
    assert len(df) == 30
    np.testing.assert_allclose(df["t"], t, atol=1e-15)
    note = next(m for m in messages if "repeat the time" in m)
    assert note.startswith("shot.csv: 1 rows") and "dropped" in note and "row 12" in note


def test_duplicate_timestamps_with_differing_angles_are_averaged(tmp_path):
    t, a, b, c = shot()
    idx = np.insert(np.arange(30), 10, 9)
    a2 = a[idx].copy()
    a2[10] += 0.2  # the second measurement of frame 9 differs by 0.2°
    df, messages = read_warned(write(tmp_path, t[idx], a2, b[idx], c[idx]))
    assert len(df) == 30
    assert df["theta"].iloc[9] == pytest.approx(math.radians(a[9] + 0.1), abs=1e-12)
    assert any("1 with differing angles averaged" in m for m in messages)


def test_absent_rows_are_reported_with_count_and_position(tmp_path):
    t, a, b, c = shot()
    keep = np.setdiff1d(np.arange(30), [12, 13, 14, 20])
    df, messages = read_warned(write(tmp_path, t[keep], a[keep], b[keep], c[keep]))
    assert len(df) == 26  # nothing invented
    note = next(m for m in messages if "absent" in m)
    # frame 11 is file row 13, frame 19 is row 18 (three rows fewer above it)
    assert "4 frames are absent" in note
    assert "3 after row 13 (t = 0.11 s)" in note and "1 after row 18 (t = 0.19 s)" in note


def test_frame_numbers_report_gaps_exactly(tmp_path):
    lines = ["frame,theta,psi,phi"]
    frames = [*range(0, 10), *range(15, 25)]
    lines += [f"{f},{0.01 * f},{0.02 * f},{0.03 * f}" for f in frames]
    p = tmp_path / "frames.csv"
    p.write_text("\n".join(lines) + "\n")
    df, messages = read_warned(p, fps=50)
    assert list(df.attrs["log"].frame) == list(frames)
    assert any("5 frames are absent: 5 after row 11" in m for m in messages)


def test_empty_cells_stay_nan_and_are_reported(tmp_path):
    t, a, b, c = shot()
    b[[4, 5, 6, 17]] = np.nan
    df, messages = read_warned(write(tmp_path, t, a, b, c))
    assert len(df) == 30
    assert np.isnan(df["psi"].to_numpy()[[4, 5, 6, 17]]).all()
    assert np.isfinite(df["theta"]).all()
    assert any("psi (psi (deg)) is missing on 4 of 30 rows (rows 6-8, 19)" in m for m in messages)


def test_rows_without_any_angle_are_dropped_and_reported(tmp_path):
    t, a, b, c = shot()
    for arr in (a, b, c):
        arr[[3, 8]] = np.nan
    df, messages = read_warned(write(tmp_path, t, a, b, c))
    assert len(df) == 28
    assert any("dropped 2 rows without any angle (rows 5, 10)" in m for m in messages)


def test_kinovea_times_in_whole_ms_are_put_back_on_a_fitted_frame_grid():
    """Without fps the 240 fps frames rounded to whole ms (steps of 4 and 5 ms) come back on
    one grid, and the log's rate is the film's, not 250 fps of the commonest step."""
    sample = Path(__file__).parents[1] / "data_samples" / "horsdal_kinovea.csv"
    points = {"pivot": "axle", "spigot": "tip", "hinge": "hinge", "counterweight": "Weight",
              "projectile": "Stone"}
    with pytest.warns(TrebuchetDataWarning, match="fitted frame grid at 2(39.9|40.0)"):
        log = read_log(sample, points=points)
    steps = np.diff(log["t"].to_numpy())
    assert 1.0 / np.median(steps) == pytest.approx(240.0, rel=1e-3)
