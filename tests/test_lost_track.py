"""A sling track that ends before the release is a lost track, not a release (issue 15):
the engine's equations on θ and ψ find the release, and φ is carried on by the sling's
pendulum so that phase II keeps its sling loads."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from trebuchet.ingest.events.sling_continuation import continued_sling
from trebuchet.ingest.reconstruct import ReconstructOptions, reconstruct
from trebuchet.ingest.synthetic.simulated_log import simulated_log


def _quiet(f, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return f(*args, **kwargs)


def _lose_sling(log, frames):
    """The log with the sling angle's last ``frames`` values before its end blanked."""
    phi = log["phi"].to_numpy()
    last = int(np.flatnonzero(np.isfinite(phi))[-1])
    out = log.copy()
    out.loc[out.index[last - frames + 1: last + 1], "phi"] = np.nan
    return out


def _release_in_log_time(truth):
    """The true release in the log's time, s (the truth's events are in the log's time)."""
    return float(truth.attrs["events"]["release"])


def _sling_rms(res, truth):
    """|F_S| RMS error over the true phase II, as a fraction of its peak (NaN counts as 0)."""
    ph2 = (truth["phase"] == 2).to_numpy()
    true = np.hypot(truth["F_S_x"], truth["F_S_y"]).to_numpy()[ph2]
    got = np.nan_to_num(np.hypot(res["F_S_x"], res["F_S_y"]).to_numpy()[ph2])
    return float(np.sqrt(np.mean((got - true) ** 2)) / true.max())


@pytest.fixture(scope="module")
def lost_120(horsdal):
    log, truth = simulated_log(horsdal, 120, 0.3, seed=0)
    return _lose_sling(log, 30), truth


def test_a_sling_track_lost_30_frames_early_is_not_the_release(horsdal, lost_120):
    log, truth = lost_120
    res = _quiet(reconstruct, log, horsdal)
    frame = 1 / 120
    assert abs(res.attrs["events"]["release"] - _release_in_log_time(truth)) < frame
    assert "lost" in res.attrs["reconstruction"].event_sources["release"]
    assert any("not released" in n for n in res.attrs["reconstruction"].notes)
    # phase II keeps its sling loads: today's track-end release set them to 0 (RMS ~44 %)
    assert _sling_rms(res, truth) < 0.05
    blind = _quiet(reconstruct, log, horsdal, options=ReconstructOptions(release_model=None))
    assert _sling_rms(blind, truth) > 0.3


@pytest.mark.parametrize("fps, noise, seed", [(240, 0.3, 1), (60, 1.0, 3), (120, 2.0, 0)])
def test_a_sling_track_that_ends_at_the_release_stays_the_release(horsdal, fps, noise, seed):
    """Noisy low-rate logs too: at 1 sd of the equations' release these were taken for lost
    tracks."""
    log, truth = simulated_log(horsdal, fps, noise, seed=seed)
    res = _quiet(reconstruct, log, horsdal, method="smooth")  # the smoother's release
    assert res.attrs["reconstruction"].event_sources["release"] == "end of the sling track"
    assert abs(res.attrs["events"]["release"] - _release_in_log_time(truth)) < 1 / fps
    assert not any("not released" in n for n in res.attrs["reconstruction"].notes)


def test_the_continued_sling_follows_the_true_angle_with_an_honest_sd(horsdal, lost_120):
    """Carried on from the smoothed state at the track's last frame, φ stays on the true
    sling angle up to the release, and the truth lies within 3 sd of it."""
    from trebuchet.ingest.smoothing.smooth import smooth

    log, truth = lost_120
    est = _quiet(smooth, log)
    phi = est["phi"].to_numpy()
    last = int(np.flatnonzero(np.isfinite(phi))[-1])
    cont = continued_sling({c: est[c].to_numpy() for c in est.columns}, horsdal, last,
                           est.attrs["smoothing"].cov["phi"][last][:3, :3])
    before = truth["phase"].to_numpy()[cont.rows] == 2
    assert before.sum() >= 25
    err = cont.phi[before] - truth["phi"].to_numpy()[cont.rows][before]
    sd = np.sqrt(cont.cov[before, 0, 0])
    assert np.max(np.abs(err)) < np.deg2rad(2.0)
    assert np.mean(np.abs(err) <= 3 * sd + np.deg2rad(0.05)) > 0.9
