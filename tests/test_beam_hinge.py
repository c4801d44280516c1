"""The hinge from the beam (issue 15): a hinge the tracker lost, or found pulled off its
marker by a frame member in front of it, is taken from the rigid beam through pivot and
spigot; the counterweight's tie is checked against that hinge, and a counterweight track
that lost its marker stays flagged until it jumps back."""

from __future__ import annotations

import numpy as np
import pytest

from trebuchet.ingest.geometry.beam_hinge import MIN_FRAMES, beam_hinge
from trebuchet.ingest.geometry.stuck_points import off_engine
from trebuchet.ingest.synthetic.filmed_points import simulated_plane_track

ROLES = ("pivot", "spigot", "hinge", "counterweight", "projectile")


@pytest.fixture(scope="module")
def shot(horsdal):
    return simulated_plane_track(horsdal, 240.0, rest=0.3)


def _tracked(shot, noise: float, seed: int = 0) -> dict[str, np.ndarray]:
    """Positions (m) with a constant offset per marker (as a click leaves) and white noise."""
    rng = np.random.default_rng(seed)
    return {r: shot.points[r] + rng.normal(0.0, 3 * noise, 2) + rng.normal(0.0, noise,
                                                                               shot.points[r].shape)
            for r in ROLES}


def test_a_hidden_and_a_pulled_hinge_come_from_the_beam(shot):
    noise = 0.002
    pos = _tracked(shot, noise)
    offset = np.median(pos["hinge"] - shot.points["hinge"], axis=0)
    moving = np.flatnonzero(shot.t > 0.6)
    hidden, pulled = moving[:20], moving[40:55]
    hinge = pos["hinge"].copy()
    hinge[hidden] = np.nan
    hinge[pulled] += [0.03, -0.02]  # a frame member's edge drags the template 36 mm
    fit = beam_hinge(pos["pivot"], pos["spigot"], hinge)
    assert fit is not None
    assert fit.filled[hidden].all() and fit.filled.sum() == hidden.size
    assert fit.replaced[pulled].all() and fit.replaced.sum() <= pulled.size + 2
    # where the tracker's hinge was lost or pulled, the beam's is on the marker (with the
    # marker's constant offset) to about the tracking noise
    err = np.hypot(*(fit.xy - shot.points["hinge"] - offset).T)
    assert err[np.r_[hidden, pulled]].max() < 4 * noise
    # elsewhere the tracked hinge is kept as it was
    keep = ~(fit.filled | fit.replaced)
    assert np.array_equal(fit.xy[keep], hinge[keep])


def test_a_clean_hinge_is_kept(shot):
    pos = _tracked(shot, 0.002, seed=1)
    fit = beam_hinge(pos["pivot"], pos["spigot"], pos["hinge"])
    assert not fit.filled.any() and fit.replaced.sum() <= 1


def test_too_few_frames_give_no_fit(shot):
    pos = _tracked(shot, 0.002)
    hinge = pos["hinge"].copy()
    hinge[MIN_FRAMES - 1:] = np.nan
    assert beam_hinge(pos["pivot"], pos["spigot"], hinge) is None


def test_a_counterweight_track_that_lost_its_marker_stays_flagged(shot):
    """A template slid onto something still and stayed there: the counterweight's tie to the
    hinge breaks, then, as the arm swings back past that spot, holds again by chance for a
    while; the track never jumped back, so all of it is flagged."""
    pos = _tracked(shot, 0.001)
    cw = pos["counterweight"].copy()
    moving = np.flatnonzero(shot.t > 0.6)
    start = moving[0]
    arm = float(np.median(np.hypot(*(pos["counterweight"] - pos["hinge"]).T)))
    # where the tie holds again later on: the spot at L3 from the hinge at a frame 'back'
    back = moving[60]
    spot = pos["hinge"][back] + arm * np.array([1.0, 0.0])
    cw[start:] = spot + np.random.default_rng(2).normal(0.0, 0.001, (cw.shape[0] - start, 2))
    d = np.hypot(*(cw - pos["hinge"]).T)
    assert abs(d[back] - arm) < 0.01  # the tie holds there
    xy = {r: (pos[r][:, 0], pos[r][:, 1]) for r in ROLES}
    xy["counterweight"] = (cw[:, 0], cw[:, 1])
    found = [o for o in off_engine(xy) if o.point == "counterweight"]
    hit = set().union(*(range(o.first, o.last + 1) for o in found))
    assert set(range(start + 5, cw.shape[0])) <= hit
    assert min(hit) >= start - 2


def test_a_counterweight_track_that_finds_its_marker_again_is_kept(shot):
    """The same slid template, but the tracker jumps back onto the marker 40 frames on and
    stays there: from there on the track is the counterweight's again."""
    pos = _tracked(shot, 0.001)
    cw = pos["counterweight"].copy()
    moving = np.flatnonzero(shot.t > 0.6)
    start, back = moving[0], moving[40]
    cw[start:back] = cw[start] + np.random.default_rng(2).normal(0.0, 0.001, (back - start, 2))
    xy = {r: (pos[r][:, 0], pos[r][:, 1]) for r in ROLES}
    xy["counterweight"] = (cw[:, 0], cw[:, 1])
    found = [o for o in off_engine(xy) if o.point == "counterweight"]
    hit = set().union(*(range(o.first, o.last + 1) for o in found))
    assert set(range(start + 10, back - 5)) <= hit  # once the tie has broken
    assert not hit & set(range(back, cw.shape[0]))
