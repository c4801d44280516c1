"""A tracked stone that leaves its sling's circle is released: phi is cut there.

A point tracker that keeps following the stone in flight gives a "sling angle" spigot ->
stone after the release. Left in, the release was found from a jump in acceleration up to
90 ms late and the peak sling tension 60 % high.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from data_samples import make_samples as ms
from trebuchet.core.errors import TrebuchetDataWarning
from trebuchet.ingest.geometry.sling_circle import first_row_off_circle, sling_ratio
from trebuchet.ingest.logs.read_log import read_log
from trebuchet.ingest.reconstruct import reconstruct


def test_ratio_is_sling_over_beam_in_any_unit():
    pivot = (np.zeros(3), np.zeros(3))
    spigot = (np.full(3, 2.0), np.zeros(3))
    stone = (np.array([2.0, 2.0, np.nan]), np.array([-1.0, 3.0, 0.0]))
    np.testing.assert_allclose(sling_ratio(pivot, spigot, stone), [0.5, 1.5, np.nan])
    scaled = [tuple(40.0 * c for c in p) for p in (pivot, spigot, stone)]
    np.testing.assert_allclose(sling_ratio(*scaled), [0.5, 1.5, np.nan])


def test_first_row_off_is_where_the_final_rise_leaves_the_noise():
    rng = np.random.default_rng(3)
    ratio = 0.8 + rng.normal(0.0, 0.002, 200)
    ratio[:30] -= 0.1  # a slack sling at rest lies below the circle: not a release
    ratio[150:] += 0.004 * np.arange(50) ** 2  # the stone flies off from row 150
    ratio[[160, 171]] = np.nan
    first = first_row_off_circle(ratio)
    assert 150 <= first <= 153
    assert first_row_off_circle(ratio[:150]) is None  # the track ends on the circle
    assert first_row_off_circle(ratio[:5]) is None


def test_a_slack_sling_at_rest_and_glitches_on_the_last_rows_are_no_flight():
    rng = np.random.default_rng(4)
    taut = 0.8 + rng.normal(0.0, 0.002, 400)
    slack = taut.copy()
    slack[:300] -= 0.08  # slack for most of the log, taut in the swing, lost at release
    assert first_row_off_circle(slack) is None
    glitch = taut.copy()
    glitch[-2:] += 0.3  # a tracker's two bad last frames
    assert first_row_off_circle(glitch) is None
    back = taut.copy()
    back[-3:-1] += 1.0  # off, then back on the circle on the very last row
    assert first_row_off_circle(back) is None


def _dlc_with_stone_in_flight(tmp_path, fps: float = 120.0, noise_px: float = 1.0):
    """A DeepLabCut file of the paper's engine whose stone is tracked through its flight."""
    rng, scene, frames, t, true = ms.filmed_shot(0, ms.PAPER_SCENE, fps, start=0.8)
    pts = ms.engine_points(scene, true)
    px = {}
    for role in ms.ROLES:
        x, y = pts[role]
        px[role] = (ms.DLC_ORIGIN[0] + ms.DLC_SCALE * x + rng.normal(0.0, noise_px, t.size),
                    ms.DLC_ORIGIN[1] - ms.DLC_SCALE * y + rng.normal(0.0, noise_px, t.size),
                    np.full(t.size, 0.99))
    path = tmp_path / "flight_dlc.csv"
    path.write_text(ms.deeplabcut_text(frames, px))
    release = ms.TRIGGER + true.attrs["release"]
    return path, scene, t, release


def test_points_of_a_stone_in_flight_give_no_sling_angle_after_the_release(tmp_path):
    path, _, t, release = _dlc_with_stone_in_flight(tmp_path)
    with pytest.warns(TrebuchetDataWarning, match="leaves its sling's circle") as record:
        log = read_log(path, fps=120, points=ms.DLC_POINTS)
    found_t, found_sd = log.attrs["log"].leaves_sling
    assert 0 < found_sd < 2.0 / 120
    assert abs(found_t - release) < 3.0 * found_sd
    phi = log["phi"].to_numpy()
    kept = np.isfinite(phi)
    assert t[kept][-1] <= found_t < t[np.flatnonzero(kept)[-1] + 1]  # cut right there
    assert np.isfinite(log["theta"]).all()  # nothing else is touched
    note = next(str(w.message) for w in record if "circle" in str(w.message))
    assert "values from that row on are left out" in note


def test_the_release_of_a_stone_tracked_in_flight_is_found_at_the_cut(tmp_path):
    path, scene, _, release = _dlc_with_stone_in_flight(tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = reconstruct(path, scene, fps=120, points=ms.DLC_POINTS)
    found = res.attrs["events"]["release"]
    sd = res.attrs["reconstruction"].event_sd["release"]
    assert abs(found - release) < 3.0 * sd < 6.0 / 120
    # the stone seen leaving, checked against the engine's equations (issue 26)
    assert "stone" in res.attrs["reconstruction"].event_sources["release"]
