"""The release from the engine's equations (ingest/events/release_model.py) when the sling's
track goes on past the release: an empty sling swinging, or a tracker on the stone."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pandas as pd
import pytest

from trebuchet.core.errors import ModelValidityWarning, TrebuchetInputError
from trebuchet.ingest.events.release_model import (
    ModelRelease,
    ReleaseFit,
    phase_change_profile,
    release_from_model,
    release_jump_chi2,
    scene_doubt,
)
from trebuchet.ingest.events.release_sources import SceneTiming, release_without_track_end
from trebuchet.ingest.reconstruct import ReconstructOptions, reconstruct
from trebuchet.ingest.smoothing.smooth import smooth
from trebuchet.ingest.synthetic.simulated_log import continued_sling_log, simulated_log

SOURCE = "the engine's equations (phase II before, phase III after)"


def _quiet(fn, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*args, **kw)


# ----------------------------------------------------------------------------- logs


def _release_error_frames(res: pd.DataFrame, truth: pd.DataFrame, fps: float) -> float:
    found = res.attrs["events"]["release"]
    return np.inf if found is None else (found - truth.attrs["events"]["release"]) * fps


def _peak_error(res: pd.DataFrame, truth: pd.DataFrame, col: str = "F_S_abs") -> float:
    return float(res[col].max() / truth[col].max() - 1.0)


# ----------------------------------------------------------------------------- reconstruct


@pytest.mark.parametrize(("engine", "kind", "fps", "noise"), [
    ("horsdal", "pendulum", 120, 0.5),
    ("horsdal", "stone", 240, 0.5),
    ("backyard", "pendulum", 240, 0.1),
    ("backyard", "stone", 60, 0.1),
])
def test_release_when_the_sling_track_goes_on(engine, kind, fps, noise, request):
    scene = request.getfixturevalue(engine)
    log, truth = continued_sling_log(scene, fps, noise, kind, seed=1, drop_fraction=0.02)
    res = _quiet(reconstruct, log, scene)
    err = _release_error_frames(res, truth, fps)
    sd = res.attrs["reconstruction"].event_sd["release"] * fps
    assert abs(err) <= 2.0, (err, res.attrs["reconstruction"].event_sources["release"])
    assert abs(err) <= 3.0 * sd
    assert sd < 3.0
    assert abs(_peak_error(res, truth)) < 0.1
    # the loads after the release are those of phase III: no sling tension
    released = res["t"].to_numpy() > res.attrs["events"]["release"]
    assert (res["phase"].to_numpy()[released] == 3).all()
    assert np.all(res["F_S_abs"].to_numpy()[released] == 0.0)


def test_the_model_free_release_misses_where_the_equations_find_it(backyard):
    """1000 fps, the empty sling swinging on: the jump search alone lands far from the
    release (about 90 frames early on this log); the engine's equations replace it."""
    fps = 1000
    log, truth = continued_sling_log(backyard, fps, 0.1, "pendulum", seed=1)
    # the release from the equations is the smoother's (the fitted engine fits its own)
    free = _quiet(reconstruct, log, backyard, method="smooth",
                  options=ReconstructOptions(release_model=None))
    res = _quiet(reconstruct, log, backyard, method="smooth")
    free_err = _release_error_frames(free, truth, fps)
    err = _release_error_frames(res, truth, fps)
    done, before = res.attrs["reconstruction"], free.attrs["reconstruction"]
    assert done.event_sources["release"] == SOURCE
    assert np.any(done.noise["theta"]["band_scale"] < 1.0)  # the full smoothing's
    assert done.event_sources["trigger"] == before.event_sources["trigger"]
    assert done.event_sd["trigger"] == before.event_sd["trigger"]
    assert abs(err) <= 4.0 and abs(err) <= 3.0 * done.event_sd["release"] * fps
    assert abs(_peak_error(res, truth)) < 0.05
    if abs(free_err) > 10:  # the case the check is for: the note says how far apart
        assert any("from the engine's equations" in n for n in res.attrs["reconstruction"].notes)
        assert abs(_peak_error(res, truth)) < abs(_peak_error(free, truth))


def test_a_sling_track_that_ends_at_the_release_is_unchanged(horsdal):
    log, truth = simulated_log(horsdal, 60, 0.5, seed=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ModelValidityWarning)
        warnings.filterwarnings("ignore", message=".*resol", category=ModelValidityWarning)
        res = _quiet(reconstruct, log, horsdal, method="smooth")
    off = _quiet(reconstruct, log, horsdal, method="smooth",
                 options=ReconstructOptions(release_model=None))
    assert res.attrs["reconstruction"].event_sources["release"] == "end of the sling track"
    assert res.attrs["events"] == off.attrs["events"]
    assert res.attrs["reconstruction"].event_sd == off.attrs["reconstruction"].event_sd
    np.testing.assert_array_equal(res["F_S_abs"].to_numpy(), off["F_S_abs"].to_numpy())


def test_a_scene_a_little_off_warns_where_the_right_one_does_not(horsdal):
    """The projectile's mass doubled passes the misfit check (the phases still fit the
    accelerations within the model-error floor) but the angles near the release fit its
    equations far worse than their noise: a warning naming the parameters."""
    log, _ = continued_sling_log(horsdal, 240, 0.5, "pendulum", seed=0)
    heavy = dataclasses.replace(horsdal, engine=dataclasses.replace(
        horsdal.engine, m=2.0 * horsdal.engine.m))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = reconstruct(log, heavy, method="smooth")
    doubts = [str(w.message) for w in caught if "a little off" in str(w.message)]
    assert len(doubts) == 1 and "mass m" in doubts[0] and "L4" in doubts[0]
    assert any("a little off" in n for n in res.attrs["reconstruction"].notes)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        right = reconstruct(log, horsdal, method="smooth")
    assert not [w for w in caught if "a little off" in str(w.message)]
    assert right.attrs["reconstruction"].event_sources["release"] == SOURCE


def test_scene_doubt():
    fit = ModelRelease(1.0, 0.002, 0.2, 4.0, 100.0, SOURCE, 1e-9)
    assert "a little off" in scene_doubt(fit)
    assert scene_doubt(dataclasses.replace(fit, fit_chance=0.3)) is None
    assert scene_doubt(dataclasses.replace(fit, misfit=12.0)) is None  # another warning
    assert scene_doubt(dataclasses.replace(fit, time=None)) is None
    assert scene_doubt(ModelRelease(1.0, 0.002, 0.2, 1.0, 100.0, SOURCE)) is None  # NaN
    assert scene_doubt(fit, ReleaseFit(min_fit_chance=1e-12)) is None


def test_another_engine_than_the_scene_warns_and_keeps_the_smoothers_release(horsdal,
                                                                              backyard):
    log, _ = continued_sling_log(backyard, 240, 0.5, "pendulum", seed=0)
    with pytest.warns(ModelValidityWarning, match="is the scene the engine filmed"):
        res = reconstruct(log, horsdal, options=ReconstructOptions(scene_mismatch="warn"))
    assert res.attrs["reconstruction"].event_sources["release"] != SOURCE
    # the kept smoothing has the calibrated bands, not the checking smoothing's posterior
    assert np.any(res.attrs["reconstruction"].noise["theta"]["band_scale"] < 1.0)


# ----------------------------------------------------------------------------- pieces


def test_model_release_on_the_smoothed_log_is_honest(backyard):
    """The fine fit's sd covers the error; the misfit is small for the right scene."""
    fps = 240
    z = []
    for seed in range(3):
        log, truth = continued_sling_log(backyard, fps, 0.5, "stone", seed=seed)
        est = _quiet(smooth, log)
        noise = {a: est.attrs["smoothing"].noise[a]["r_sd"] for a in ("theta", "psi")}
        found = release_from_model({a: log[a].to_numpy() for a in ("theta", "psi")}, est,
                                   backyard, est.attrs["events"]["trigger"], noise)
        assert found.time is not None and found.misfit < 1.0 and found.chi2_dof < 1.5
        z.append((found.time - truth.attrs["events"]["release"]) / found.sd)
        dry = release_from_model({a: log[a].to_numpy() for a in ("theta", "psi")}, est,
                                 dataclasses.replace(backyard, projectile="none"), None, noise)
        assert dry.time is None and "dry fire" in dry.how
    assert np.max(np.abs(z)) < 3.0


def test_the_jump_fit_finds_an_exact_release_between_frames():
    """Angles that are exactly c0 + c1 t + ∬a with a linear before and after a release
    between frames: χ² zero there and nowhere else on a tenth-of-a-frame grid."""
    t = np.arange(0.0, 0.5, 0.01)
    release = 0.2337
    before, after = 3.0 + 2.0 * t, -5.0 + t

    def second_integral(a0: float, a1: float, u: np.ndarray) -> np.ndarray:
        return a0 * u**2 / 2 + a1 * u**3 / 6  # of a0 + a1 u from 0

    def angle(c0, c1):
        z = c0 + c1 * t + second_integral(3.0, 2.0, t)
        late = t > release
        u = t[late] - release
        # after the release: the rate and angle carry on, the acceleration is `after`
        a_r = 3.0 + 2.0 * release
        v_r = c1 + 3.0 * release + release**2
        z_r = c0 + c1 * release + second_integral(3.0, 2.0, release)
        z[late] = z_r + v_r * u + (-5.0 + release) * u**2 / 2 + u**3 / 6
        assert a_r != -5.0 + release
        return z

    angles = (angle(0.3, 1.2), angle(-1.0, 0.5))
    grid = release + 0.001 * np.arange(-100, 120)
    chi2, dof = release_jump_chi2(t, angles, (1e-4, 1e-4), (before, before), (after, after),
                                  grid)
    assert dof == 2 * (t.size - 2) - 1
    assert abs(grid[np.argmin(chi2)] - release) < 1e-3
    assert np.min(chi2) < 1e-6 and np.sort(chi2)[2] > 1.0
    # with an acceleration offset, free or with a prior: still exact, the prior costs nothing
    for offset in ((np.inf, np.inf), (0.5, 0.5)):
        chi2_o, dof_o = release_jump_chi2(t, angles, (1e-4, 1e-4), (before, before),
                                          (after, after), grid, offset)
        assert dof_o == dof - (2 if offset[0] == np.inf else 0)
        assert abs(grid[np.argmin(chi2_o)] - release) < 1e-3 and np.min(chi2_o) < 1e-6
    # a missing frame changes nothing but the degrees of freedom
    gappy = (angles[0].copy(), angles[1])
    gappy[0][7] = np.nan
    chi2_g, dof_g = release_jump_chi2(t, gappy, (1e-4, 1e-4), (before, before),
                                      (after, after), grid)
    assert dof_g == dof - 1 and abs(grid[np.argmin(chi2_g)] - release) < 1e-3


def test_phase_change_profile_puts_the_change_where_the_phases_swap():
    n, lift, release = 40, 12, 30
    ll = {p: np.full(n, -5.0) for p in (1, 2, 3)}
    ll[1][:lift] = 0.0
    ll[2][lift:release] = 0.0
    ll[3][release:] = 0.0
    profile = phase_change_profile(ll, 0)
    assert profile.shape == (n + 1,) and int(np.argmax(profile)) == release
    sling_start = {p: v for p, v in ll.items() if p != 1}
    assert int(np.argmax(phase_change_profile(sling_start, lift))) == release - lift


def test_release_choice():
    """Where the sling's track goes on: the equations' release replaces the jump search's
    where they differ; where the equations cannot place it, the jump's is unconfirmed: its
    sd covers the scene's own release time, and it warns."""
    fit = ModelRelease(1.0, 0.002, 0.2, 1.0, 100.0, SOURCE)
    frame, timing = 1 / 240, SceneTiming(1.02)
    agreed = release_without_track_end(fit, 1.0015, 0.5 * frame, frame, timing)
    assert agreed.kind == "jump" and agreed.time == 1.0015 and agreed.note is None
    assert agreed.confirmed and agreed.warning is None
    c = release_without_track_end(fit, 1.05, 0.5 * frame, frame, timing)
    assert c.kind == "equations" and c.time == 1.0 and "50 ms before" in c.note
    c = release_without_track_end(fit, None, 0.5 * frame, frame, timing)
    assert c.kind == "equations" and "no jump" in c.note
    for model in (dataclasses.replace(fit, misfit=12.0), dataclasses.replace(fit, time=None)):
        c = release_without_track_end(model, 1.05, 0.5 * frame, frame, timing)
        assert c.time == 1.05 and not c.confirmed and "uncertain" in c.warning
        assert 2.0 * c.sd >= 0.03  # covers the scene's own release, 30 ms away


def test_bad_input_is_refused(backyard):
    log, _ = simulated_log(backyard, 60, 0.5, seed=0)
    est = _quiet(smooth, log)
    angles = {a: log[a].to_numpy() for a in ("theta", "psi")}
    with pytest.raises(TrebuchetInputError, match="noise sd of psi"):
        release_from_model(angles, est, backyard, None, {"theta": 0.01, "psi": 0.0})
    with pytest.raises(TrebuchetInputError, match="theta has 3 values"):
        release_from_model(angles | {"theta": np.zeros(3)}, est, backyard, None,
                           {"theta": 0.01, "psi": 0.01})
    with pytest.raises(TrebuchetInputError, match="lacks"):
        release_from_model(angles, est.drop(columns="psi_dd_sd"), backyard, None,
                           {"theta": 0.01, "psi": 0.01})
    with pytest.raises(TrebuchetInputError, match="lacks phi_d"):
        release_from_model(angles, est.drop(columns="phi_d"), backyard, None,
                           {"theta": 0.01, "psi": 0.01})
    with pytest.raises(TrebuchetInputError, match="no raw psi"):
        release_from_model({"theta": angles["theta"]}, est, backyard, None,
                           {"theta": 0.01, "psi": 0.01})


def test_release_fit_settings_are_checked():
    for bad in ({"window_fraction": 0.0}, {"max_misfit": float("nan")},
                {"sling_frame_penalty": -1.0}, {"min_window_frames": 4},
                {"offset_fraction": -0.1}):
        with pytest.raises(TrebuchetInputError, match="ReleaseFit"):
            ReleaseFit(**bad)


def test_no_release_from_the_equations_without_a_sling_angle_or_a_release(horsdal):
    log, truth = continued_sling_log(horsdal, 120, 0.3, "pendulum", seed=0)
    no_sling = log.assign(phi=np.nan)
    res = _quiet(reconstruct, no_sling, horsdal)
    assert res.attrs["reconstruction"].event_sources["release"] != SOURCE
    cut = log[log["t"] < truth.attrs["events"]["release"] - 0.05].reset_index(drop=True)
    res = _quiet(reconstruct, cut, horsdal)
    assert res.attrs["events"]["release"] is None
