"""read_log: each format from hand-written fixtures, units, and angles from points.

The fixtures in tests/fixtures/logs/ (see the README there) hold 14 frames at 240 fps of
theta = -50° + 0.5° k², psi = -90° + 0.3° k², phi = -180° + 0.2° k² (k = frame).
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from trebuchet.core.errors import TrebuchetDataWarning, TrebuchetInputError
from trebuchet.ingest.logs.read_log import read_log, write_log

LOGS = Path(__file__).parent / "fixtures" / "logs"
FPS = 240.0
K = np.arange(14)
THETA = np.radians(-50 + 0.5 * K**2)
PSI = np.radians(-90 + 0.3 * K**2)
PHI = np.radians(-180 + 0.2 * K**2)
KINOVEA_POINTS = {
    "pivot": "axle",
    "spigot": "tip",
    "hinge": "hinge",
    "counterweight": "Weight",
    "projectile": "Stone",
}


def num(v: float) -> str:
    """Shortest text that reads back as the same float."""
    return repr(float(v))


def quiet_read(path, **kwargs) -> pd.DataFrame:
    """read_log with its repair warnings collected (they are tested elsewhere)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TrebuchetDataWarning)
        return read_log(path, **kwargs)


# ------------------------------------------------------------------------------ generic


def test_generic_with_units_in_header_converts_ms_and_degrees(tmp_path):
    p = tmp_path / "shot.csv"
    lines = ["time [ms],theta (deg),psi (rad),phi (°)"]
    for k in K:
        lines.append(f"{num(k * 1000 / FPS)},{num(math.degrees(THETA[k]))},{num(PSI[k])},"
                     f"{num(math.degrees(PHI[k]))}")
    p.write_text("\n".join(lines) + "\n")
    df = read_log(p)
    assert list(df.columns) == ["t", "theta", "psi", "phi"]
    assert all(df[c].dtype == np.float64 for c in df.columns)
    np.testing.assert_allclose(df["t"], K / FPS, rtol=0, atol=1e-15)
    np.testing.assert_allclose(df["theta"], THETA, rtol=0, atol=1e-12)
    np.testing.assert_allclose(df["psi"], PSI, rtol=0, atol=1e-12)
    np.testing.assert_allclose(df["phi"], PHI, rtol=0, atol=1e-12)
    assert df.attrs["log"].format == "generic"
    assert df.attrs["log"].source == str(p)
    assert df.attrs["log"].repairs == ()


def test_generic_angle_without_unit_is_radians_and_time_without_unit_is_seconds(tmp_path):
    p = tmp_path / "rad.csv"
    rows = [f"{num(k / FPS)},{num(THETA[k])},{num(PSI[k])},{num(PHI[k])}" for k in K]
    p.write_text("t,theta,psi,phi\n" + "\n".join(rows) + "\n")
    df = read_log(p)
    np.testing.assert_allclose(df["theta"], THETA, atol=1e-15)
    np.testing.assert_allclose(df["t"], K / FPS, atol=1e-15)


def test_generic_frame_column_needs_fps_and_gives_frame_over_fps(tmp_path):
    p = tmp_path / "frames.csv"
    rows = [f"{k + 100};{num(THETA[k])};{num(PSI[k])};{num(PHI[k])}" for k in K]
    p.write_text("frame;theta;psi;phi\n" + "\n".join(rows) + "\n")
    df = read_log(p, fps=120)
    np.testing.assert_allclose(df["t"], (K + 100) / 120.0, atol=1e-15)
    assert df.attrs["log"].fps == 120.0
    assert list(df.attrs["log"].frame) == [int(k) + 100 for k in K]


def test_generic_decimal_comma_with_semicolons_and_greek_names(tmp_path):
    p = tmp_path / "komma.csv"
    rows = [
        ";".join(f"{v:.6f}".replace(".", ",") for v in (k / FPS, *np.degrees([a, b, c])))
        for k, a, b, c in zip(K, THETA, PSI, PHI, strict=True)
    ]
    p.write_text("t (s);θ (deg);ψ (deg);φ (deg)\n" + "\n".join(rows) + "\n")
    df = read_log(p)
    np.testing.assert_allclose(df["phi"], PHI, atol=1e-7)


def _angle_rows(times: list[str]) -> str:
    return "t (s),theta (rad),psi (rad),phi (rad)\n" + "\n".join(
        f"{s},{num(THETA[k])},{num(PSI[k])},{num(PHI[k])}" for k, s in enumerate(times)) + "\n"


def test_times_rounded_to_a_few_decimals_go_back_on_the_frame_grid_with_a_note(tmp_path):
    """Times of 120 fps written to 0.1 ms (8.3 or 8.4 ms apart) gave 120.5 fps."""
    p = tmp_path / "rounded.csv"
    p.write_text(_angle_rows([f"{0.8 + k / 120.0:.4f}" for k in K]))
    with pytest.warns(TrebuchetDataWarning, match=r"rounded to 0\.1 ms .* fitted frame grid"):
        df = read_log(p)
    step = np.diff(df["t"])
    np.testing.assert_allclose(step, step[0], rtol=1e-9)  # one frame period
    assert abs(step[0] * 120.0 - 1.0) < 1e-4  # 14 frames fix the rate to 0.01 %
    assert np.abs(df["t"] - (0.8 + K / 120.0)).max() < 0.5e-4
    assert len(df.attrs["log"].repairs) == 1


def test_rounded_times_go_on_the_exact_grid_of_a_given_fps(tmp_path):
    p = tmp_path / "rounded.csv"
    p.write_text(_angle_rows([f"{0.8 + k / 120.0:.4f}" for k in K]))
    with pytest.warns(TrebuchetDataWarning, match=r"rounded to 0\.1 ms .* grid at fps=120"):
        df = read_log(p, fps=120)
    np.testing.assert_allclose(np.diff(df["t"]), 1.0 / 120.0, rtol=1e-9)  # exact spacing
    assert np.abs(df["t"] - (0.8 + K / 120.0)).max() < 0.5e-4  # offset within the rounding


def test_times_rounded_coarser_than_the_frames_are_kept_with_a_note(tmp_path):
    """60 fps written to 0.01 s: steps of 0.01 and 0.02 s, no grid to fit."""
    p = tmp_path / "coarse.csv"
    times = [f"{k / 60.0:.2f}" for k in K]
    p.write_text(_angle_rows(times))
    with pytest.warns(TrebuchetDataWarning, match="too coarse .* pass fps="):
        df = read_log(p)
    assert df["t"].tolist() == [float(x) for x in times]
    with pytest.warns(TrebuchetDataWarning, match="grid at fps=60"):
        exact = read_log(p, fps=60)
    np.testing.assert_allclose(np.diff(exact["t"]), 1.0 / 60.0, rtol=1e-9)
    assert np.abs(exact["t"] - K / 60.0).max() < 0.005


def test_times_on_an_exact_grid_are_left_alone_without_a_note(tmp_path):
    p = tmp_path / "exact.csv"
    p.write_text(_angle_rows([f"{k / 100.0:.2f}" for k in K]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        df = read_log(p)
    assert df["t"].tolist() == [float(f"{k / 100.0:.2f}") for k in K]
    assert df.attrs["log"].repairs == ()


def test_columns_maps_other_names_and_leaves_unmapped_angles_to_their_names(tmp_path):
    p = tmp_path / "named.csv"
    rows = [f"{num(k / FPS)},{num(THETA[k])},{num(PSI[k])},{num(PHI[k])},1" for k in K]
    p.write_text("t,beam (rad),psi,sling (rad),note\n" + "\n".join(rows) + "\n")
    df = read_log(p, columns={"beam": "theta", "sling (rad)": "phi"})
    np.testing.assert_allclose(df["theta"], THETA, atol=1e-15)
    np.testing.assert_allclose(df["phi"], PHI, atol=1e-15)
    assert df.attrs["log"].columns == {"theta": "beam (rad)", "psi": "psi", "phi": "sling (rad)"}


def test_write_log_round_trip_keeps_values_and_gaps(tmp_path):
    df = pd.DataFrame({"t": K / FPS, "theta": THETA, "psi": PSI, "phi": PHI})
    df.loc[5, "psi"] = np.nan
    for unit in ("deg", "rad"):
        back = quiet_read(write_log(df, tmp_path / f"w_{unit}.csv", unit=unit))
        np.testing.assert_allclose(back.to_numpy(), df.to_numpy(), rtol=0, atol=1e-12)
        assert np.isnan(back.loc[5, "psi"]) and np.isfinite(back.loc[5, "theta"])


# ------------------------------------------------------------------------------ Tracker


def test_tracker_multi_tab_with_track_names_mapped_to_angles():
    df = read_log(
        LOGS / "tracker_multi_tab.txt", columns={"beam": "theta", "arm": "psi", "sling": "phi"}
    )
    assert df.attrs["log"].format == "tracker"
    assert df.attrs["log"].columns == {"theta": "beam/θ", "psi": "arm/θ", "phi": "sling/θ"}
    # its times, written to 0.1 ms, go back on a fitted frame grid (a repair)
    np.testing.assert_allclose(df["t"], K / FPS, atol=0.5e-4)
    np.testing.assert_allclose(np.diff(df["t"]), 1.0 / FPS, rtol=1e-4)
    # written with 3 decimals in degrees
    np.testing.assert_allclose(df["theta"], THETA, atol=math.radians(0.0005) + 1e-15)
    np.testing.assert_allclose(df["psi"], PSI, atol=math.radians(0.0005) + 1e-15)
    np.testing.assert_allclose(df["phi"], PHI, atol=math.radians(0.0005) + 1e-15)


def test_tracker_track_column_name_also_works_as_key():
    df = quiet_read(
        LOGS / "tracker_multi_tab.txt",
        columns={"beam/θ": "theta", "arm/θ": "psi", "sling": "phi"},
    )
    np.testing.assert_allclose(df["psi"], PSI, atol=1e-5)


def test_tracker_multi_semicolon_decimal_comma_with_tracks_named_after_the_angles():
    with pytest.warns(TrebuchetDataWarning) as record:
        df = read_log(LOGS / "tracker_multi_semicolon.csv")
    assert df.attrs["log"].format == "tracker"
    # Tracker wrote a time-only row for every skipped frame (step size 2): dropped, reported
    assert len(df) == 14
    np.testing.assert_allclose(df["t"], 2 * K / FPS, rtol=1e-6)
    np.testing.assert_allclose(df["theta"], THETA, atol=1e-8)
    np.testing.assert_allclose(df["phi"], PHI, atol=1e-8)
    # the missing psi mark on frame 12 (file row 16) stays a gap, the row stays
    assert np.isnan(df["psi"].iloc[6]) and np.isfinite(df["theta"].iloc[6])
    messages = [str(w.message) for w in record]
    assert any("13 rows without any angle" in m for m in messages)
    assert any("psi" in m and "row 16" in m for m in messages)


def test_tracker_single_protractor_lacks_two_angles_and_says_what_it_has():
    with pytest.raises(TrebuchetInputError) as err:
        read_log(LOGS / "tracker_protractor_tab.txt", columns={"beam": "theta"})
    msg = str(err.value)
    assert "tracker_protractor_tab.txt" in msg
    assert "psi" in msg and "'beam/θ'" in msg and "columns=" in msg


def test_tracker_point_masses_give_angles_with_points(tmp_path):
    px, py = _points_from_angles(THETA, PSI, PHI)
    roles = ["pivot", "spigot", "hinge", "counterweight", "projectile"]
    names = ["A", "B", "C", "D", "E"]
    lines = ["#multi:", "," + "".join(f"{n},," for n in names), "t," + "x,y," * 5]
    for k in K:
        cells = [num(k / FPS)] + [f"{num(v)}" for r in roles for v in (px[r][k], py[r][k])]
        lines.append(",".join(cells) + ",")
    p = tmp_path / "masses.csv"
    p.write_text("\n".join(lines) + "\n")
    df = read_log(p, points=dict(zip(roles, names, strict=True)))
    np.testing.assert_allclose(df["theta"], THETA, atol=1e-12)
    np.testing.assert_allclose(df["psi"], PSI, atol=1e-12)
    np.testing.assert_allclose(df["phi"], PHI, atol=1e-12)
    assert df.attrs["log"].point_names["hinge"] == "C"


# ------------------------------------------------------------------------------ Kinovea


def test_kinovea_quoted_semicolon_file_with_fps_gives_exact_frame_times():
    with pytest.warns(TrebuchetDataWarning) as record:
        df = read_log(LOGS / "kinovea_semicolon.csv", fps=FPS, points=KINOVEA_POINTS)
    assert any("rounded to 1 ms" in str(w.message) for w in record)
    assert df.attrs["log"].format == "kinovea"
    np.testing.assert_allclose(df["t"], K / FPS, rtol=0, atol=1e-15)
    # coordinates written with 4 decimals (0.1 mm) on arms of 2.45 m and more
    np.testing.assert_allclose(df["theta"], THETA, atol=1e-4)
    np.testing.assert_allclose(df["psi"], PSI, atol=1e-4)
    # the paper's branch for phi: -180° at the start, not +180°
    assert df["phi"].iloc[0] == pytest.approx(-math.pi, abs=1e-4)
    ok = np.isfinite(df["phi"]).to_numpy()
    np.testing.assert_allclose(df["phi"][ok], PHI[ok], atol=1e-4)
    # the stone's empty cells on frame 4 (file row 6) are a gap in phi only
    assert np.isnan(df["phi"].iloc[4]) and np.isfinite(df["psi"].iloc[4])
    pts = pd.DataFrame(dict(df.attrs["log"].points))
    assert list(pts.columns[:1]) == ["t"] and len(pts) == len(df)
    assert pts["spigot_y"].iloc[0] == pytest.approx(0.0360)
    assert df.attrs["log"].point_names["counterweight"] == "Weight/centre"


def test_kinovea_without_fps_fits_a_frame_grid_close_to_the_true_rate():
    df = quiet_read(LOGS / "kinovea_semicolon.csv", points=KINOVEA_POINTS)
    dt = np.diff(df["t"])
    # uniform steps (no 4/4/5 ms rounding jitter) within 2 % of 1/240 s
    assert np.ptp(dt) < 1e-12
    assert dt[0] == pytest.approx(1 / FPS, rel=0.02)
    assert "fps" not in df.attrs
    assert any("fitted frame grid" in r for r in df.attrs["log"].repairs)


def test_kinovea_time_without_unit_is_read_in_the_unit_its_steps_tell(tmp_path):
    """Kinovea's ClassicTime (s) and the kinematics dialogs' whole ms share the header."""
    p = tmp_path / "kin.csv"
    lines = ['"Time","p/a/X","p/a/Y"'] + [f'"{k * 0.004:.3f}","1","2"' for k in K]
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(TrebuchetInputError, match=r"kin\.csv: the angle theta needs"):
        read_log(p)  # the time is read (in s); the file lacks the engine's points
    with pytest.raises(TrebuchetInputError, match=r"kin\.csv, column 'Time'.*fps=.*'ms'"):
        read_log(p, fps=100)  # steps of 4 ms are 250 fps, not 100


# ------------------------------------------------------------------------------ DeepLabCut


def test_deeplabcut_three_header_rows_low_likelihood_as_gaps():
    with pytest.warns(TrebuchetDataWarning) as record:
        df = read_log(LOGS / "deeplabcut.csv", fps=FPS, min_likelihood=0.9)
    assert df.attrs["log"].format == "deeplabcut"
    np.testing.assert_allclose(df["t"], K / FPS, atol=1e-15)
    # pixels with 4 decimals, 100 px per m, y flipped from image (down) to up
    ok = np.isfinite(df["theta"])
    np.testing.assert_allclose(df["theta"][ok], THETA[ok], atol=1e-5)
    np.testing.assert_allclose(df["psi"], PSI, atol=1e-5)
    # projectile on frame 5 (likelihood 0.42) and spigot on frame 9 (0.65) are gaps
    assert np.isnan(df["phi"].iloc[5]) and np.isnan(df["phi"].iloc[9])
    assert np.isnan(df["theta"].iloc[9]) and np.isfinite(df["theta"].iloc[5])
    assert list(df.attrs["log"].frame) == list(range(14))
    pts = pd.DataFrame(dict(df.attrs["log"].points))
    assert pts["pivot_y"].iloc[0] == pytest.approx(-400.0)  # image y 400 px, flipped
    messages = " ".join(str(w.message) for w in record)
    assert "'projectile' with likelihood below 0.9" in messages and "row 9" in messages


def test_deeplabcut_likelihood_threshold_is_a_keyword_default_dlcs_pcutoff():
    df = quiet_read(LOGS / "deeplabcut.csv", fps=FPS)
    assert np.isfinite(df["theta"].iloc[9])  # spigot at 0.65 kept by the default 0.6
    assert np.isnan(df["phi"].iloc[5])  # projectile at 0.42 a gap
    strict = quiet_read(LOGS / "deeplabcut.csv", fps=FPS, min_likelihood=0.9)
    assert np.isnan(strict["theta"].iloc[9])


def test_deeplabcut_needs_fps():
    with pytest.raises(TrebuchetInputError, match=r"deeplabcut\.csv.*fps="):
        read_log(LOGS / "deeplabcut.csv")


# ------------------------------------------------------------------------------ points


def _points_from_angles(theta, psi, phi, scale=1.0, origin=(0.0, 0.0)):
    """Positions (x, y up) of the five points for given angles (paper's geometry)."""
    L1, L2, L3, L4 = 6.48, 0.86, 2.45, 5.55
    e = {a: (np.cos(v), np.sin(v)) for a, v in (("t", theta), ("s", psi), ("p", phi))}
    x = {"pivot": np.full_like(theta, origin[0])}
    y = {"pivot": np.full_like(theta, origin[1])}
    x["spigot"], y["spigot"] = x["pivot"] + L1 * e["t"][0], y["pivot"] + L1 * e["t"][1]
    x["hinge"], y["hinge"] = x["pivot"] - L2 * e["t"][0], y["pivot"] - L2 * e["t"][1]
    x["counterweight"] = x["hinge"] + L3 * e["s"][0]
    y["counterweight"] = y["hinge"] + L3 * e["s"][1]
    x["projectile"] = x["spigot"] + L4 * e["p"][0]
    y["projectile"] = y["spigot"] + L4 * e["p"][1]
    return ({k: v * scale for k, v in x.items()}, {k: v * scale for k, v in y.items()})


# a shot through the awkward places: phi through -180° and -90°, theta through 90°
N = 60
_S = np.linspace(0.0, 1.0, N)
TRUE = {
    "theta": np.radians(-50 + 160 * _S**2),
    "psi": np.radians(-90 + 200 * _S**1.5),
    "phi": np.radians(-200 + 250 * _S**2),
}


def test_points_round_trip_through_a_deeplabcut_file(tmp_path):
    x, y = _points_from_angles(TRUE["theta"], TRUE["psi"], TRUE["phi"], scale=80.0,
                               origin=(7.5, 4.0))
    parts = ["pin", "tip", "joint", "box", "ball"]
    roles = ["pivot", "spigot", "hinge", "counterweight", "projectile"]
    lines = [
        "scorer," + ",".join(["DLC_x"] * 15),
        "bodyparts," + ",".join(p for p in parts for _ in range(3)),
        "coords," + ",".join(["x", "y", "likelihood"] * 5),
    ]
    for k in range(N):
        cells = [str(k)]
        for r in roles:
            cells += [num(1000.0 + x[r][k]), num(1000.0 - y[r][k]), "0.99"]  # image y down
        lines.append(",".join(cells))
    p = tmp_path / "dlc.csv"
    p.write_text("\n".join(lines) + "\n")
    df = read_log(p, fps=500, points=dict(zip(roles, parts, strict=True)))
    for a in ("theta", "psi", "phi"):
        np.testing.assert_allclose(df[a], TRUE[a], rtol=0, atol=1e-12, err_msg=a)


def test_points_round_trip_through_a_kinovea_file_with_decimal_comma(tmp_path):
    x, y = _points_from_angles(TRUE["theta"], TRUE["psi"], TRUE["phi"], origin=(-2.0, 9.0))
    roles = ["pivot", "spigot", "hinge", "counterweight", "projectile"]
    head = ['"Time"'] + [f'"Engine/{r}/{ax}"' for r in roles for ax in "XY"]
    lines = [";".join(head)]
    for k in range(N):
        cells = [f'"{round(k * 1000 / 250)}"']  # 250 fps: whole ms, exact
        cells += ['"' + repr(float(v)).replace(".", ",") + '"' for r in roles
                  for v in (x[r][k], y[r][k])]
        lines.append(";".join(cells))
    p = tmp_path / "kin.csv"
    p.write_text("\r\n".join(lines) + "\r\n")
    df = quiet_read(p)  # points named after the parts: no mapping needed
    # times on a 4 ms grid are not touched; their unit (none written) is inferred and said
    assert df.attrs["log"].repairs == (df.attrs["log"].decisions[0],)
    assert df.attrs["log"].decisions[0].startswith("time unit of 'Time': ms (inferred: steps of 4")
    np.testing.assert_allclose(df["t"], np.arange(N) * 0.004, atol=1e-15)
    for a in ("theta", "psi", "phi"):
        np.testing.assert_allclose(df[a], TRUE[a], rtol=0, atol=1e-12, err_msg=a)


def test_missing_point_is_named_with_the_angle_that_needs_it(tmp_path):
    p = tmp_path / "four.csv"
    lines = ['"Time","B/pivot/X","B/pivot/Y","B/spigot/X","B/spigot/Y","B/hinge/X","B/hinge/Y",'
             '"W/cw/X","W/cw/Y"']
    lines += [f'"{4 * k}","0","0","1","{k}","-1","0","-1","-1"' for k in K]
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(TrebuchetInputError) as err:
        read_log(p, points={"counterweight": "W"})
    msg = str(err.value)
    assert "four.csv" in msg and "phi" in msg and "projectile" in msg and "'W/cw'" in msg


def test_attrs_hold_plain_values_so_logs_can_be_concatenated():
    df = quiet_read(LOGS / "deeplabcut.csv", fps=FPS)
    both = pd.concat([df, df.copy()])  # pandas compares attrs: arrays there would raise
    assert len(both) == 2 * len(df)
    assert both.attrs["log"].format == "deeplabcut"


def test_tracker_space_delimited_with_frame_numbers_and_a_utf8_bom(tmp_path):
    lines = ["#multi:", " theta psi phi ", "frame θ θ θ "]
    lines += [f"{k + 7} {math.degrees(THETA[k])} {math.degrees(PSI[k])} {math.degrees(PHI[k])} "
              for k in K]
    p = tmp_path / "space.txt"
    p.write_bytes(b"\xef\xbb\xbf" + ("\n".join(lines) + "\n").encode())
    df = read_log(p, fps=FPS)
    assert df.attrs["log"].format == "tracker"
    np.testing.assert_allclose(df["t"], (K + 7) / FPS, atol=1e-15)
    np.testing.assert_allclose(df["psi"], PSI, atol=1e-12)
