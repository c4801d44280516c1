"""The stress grid's confidently wrong events (issue 26, bench/video_stress.py), cut down to
the inputs their decisions saw: each event more than 2 frames off must lie within its
stated 2 sd and be warned about. The figures are those of the grid's cells (seed 26):
each decision's inputs as the reconstruction measured them, the truth from the render."""

from __future__ import annotations

import numpy as np

from trebuchet.ingest.events.lift_off import timing_widened_sd
from trebuchet.ingest.events.release_model import ModelRelease
from trebuchet.ingest.events.release_sources import (
    SceneTiming,
    TrackEnd,
    release_at_track_end,
    release_without_track_end,
)
from trebuchet.ingest.events.stone_flight import StoneRelease


def _covered(time: float, sd: float, truth: float, warning: str | None) -> bool:
    return abs(time - truth) <= 2.0 * sd and warning is not None


def _model(time, sd, misfit=0.3):
    return ModelRelease(time, sd, misfit, 1.0, 40.0, "the engine's equations")


def test_a_normal_force_zero_far_from_the_scene_s_lift_off_covers_it_and_warns():
    """Cell 1064 (paper engine, Kinovea's tracker, 240 fps): the normal force's zero 4.1
    frames late with an sd of 0.8 frame; the stone's departure (sd 17 frames) could not
    check it, the scene's own lift-off lay 0.4 frame from the truth but within a tenth of
    the span. Cell 1094 (backyard, the trigger 1.8 frames early): 8.6 frames early."""
    frame = 1 / 240
    for lift, sd, scene_lift, span, trigger_sd, truth in (
            (0.66497, 0.00329, 0.64941, 0.34783, 0.08 * frame, 0.64780),
            (0.59165, 0.00333, 0.62006, 0.32745, 0.57 * frame, 0.62750)):
        wide, said = timing_widened_sd(lift, sd, scene_lift, span, frame, trigger_sd)
        assert _covered(lift, wide, truth, said) and "scene's own" in said
    # a zero within its sd of the scene's stands
    assert timing_widened_sd(0.6500, 0.00329, 0.64941, 0.34783, frame) == (0.00329, None)


def test_an_unconfirmed_track_end_reaches_past_the_scene_s_release():
    """Cell 1181 (paper, adaptive template, 120 fps): the track's end 3.9 frames late,
    confirmed by nothing; its sd covered only the scene's own release 3.0 frames away (1.8
    frames), the trigger 0.85 frame late with an sd of 0.16."""
    frame = 1 / 120
    end = TrackEnd(1.32917, 0.0024056, 1.325, 1.33333, frame)
    stone = StoneRelease(None, float("nan"), 0.012, 0.97, 0, 1.325, "stays on its circle")
    c = release_at_track_end(end, stone, _model(None, float("nan"), misfit=1.2),
                             SceneTiming(1.30410, 0.997, 0.16 * frame))
    assert _covered(c.time, c.sd, 1.29700, c.warning) and not c.confirmed


def test_equations_too_loose_to_confirm_a_track_end_leave_it_to_the_scene_check():
    """Cell 1096 (small fast engine, a post in front, 240 fps): the stone's track ended 3.9
    frames before the release, and equations with an sd of 9 frames "confirmed" it: taken
    with sd 0.29 frame, unwarned."""
    frame = 1 / 240
    end = TrackEnd(0.772917, 0.0012028, 0.770833, 0.775, frame)
    c = release_at_track_end(end, None, _model(0.81124, 0.03831, misfit=0.23),
                             SceneTiming(0.78841, 0.48930, 0.04 * frame))
    assert c.time == end.time and _covered(c.time, c.sd, 0.78930, c.warning)
    # equations sharp enough still confirm it, unwarned
    sharp = release_at_track_end(end, None, _model(0.7735, 0.5 * frame),
                                 SceneTiming(0.78841, 0.48930))
    assert sharp.sd == end.sd and sharp.warning is None


def test_equations_alone_far_from_the_scene_s_release_cover_it_and_warn():
    """Cell 1126 (paper, Kinovea's tracker, DeepLabCut export, 240 fps): the sling's track
    goes on; the equations' release 6 frames late with sd 0.6 frame, 5.3 frames from the
    scene's own (within a tenth of the span: unwarned)."""
    frame = 1 / 240
    c = release_without_track_end(_model(1.32183, 0.0024655, misfit=0.4), 1.375,
                                  0.5 * frame, frame, SceneTiming(1.29967, 0.997, 0.06 * frame))
    assert c.kind == "equations" and _covered(c.time, c.sd, 1.29700, c.warning)


def test_disagreeing_stone_and_equations_both_late_are_checked_against_the_scene():
    """Cell 1031 (backyard, Kinovea's tracker, 240 fps): a stuck template's "flight" 57
    frames late and the equations 34 late; the stone's flight was taken with an sd covering
    the equations only (13 frames)."""
    frame = 1 / 240
    end = TrackEnd(1.33958, 0.0012028, 1.3375, 1.34167, frame)
    stone = StoneRelease(1.28898, 0.001666, 0.0081, 16.0, 9, 1.3375, "free flight")
    c = release_at_track_end(end, stone, _model(1.19406, 0.0040686, misfit=0.08),
                             SceneTiming(1.05314, 0.75084, 0.07 * frame))
    assert _covered(c.time, c.sd, 1.05080, c.warning)
    assert "disagree" in c.warning and "scene's own" in c.warning
    assert np.isfinite(c.sd)


def test_a_lift_off_whose_own_sd_is_wide_is_still_checked_against_a_far_scene():
    """Cell 1011 (small fast engine, adaptive template, 120 fps): a tracking gap had
    widened the normal force's sd to 1.7 frames; it lay 3.8 frames late, just inside 2 sd
    of its difference from the scene's own lift-off, but further than a tenth of the span
    from it."""
    frame = 1 / 120
    lift, sd = 0.52527, 0.014466
    wide, said = timing_widened_sd(lift, sd, 0.49676, 0.19356, frame, 0.04 * frame)
    assert _covered(lift, wide, 0.49356, said)
