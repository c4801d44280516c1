"""reconstruct(): events, phases, accuracy of both forms, honest bands, overrides, checks."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from trebuchet.core.errors import ModelValidityWarning, TrebuchetInputError
from trebuchet.ingest.logs.result import ReadLog
from trebuchet.ingest.reconstruct import (
    ReconstructOptions,
    checking_settings,
    loads_from_smoothed,
    reconstruct,
    sling_track_end,
)
from trebuchet.ingest.smoothing.smooth import SmoothSettings, smooth
from trebuchet.ingest.synthetic.simulated_log import SMALL_ENGINE, simulated_log
from trebuchet.ingest.uncertainty import propagate
from trebuchet.model.forces import LOAD_COLUMNS
from trebuchet.model.scene import Scene

FPS, NOISE = 240, 0.3


def _quiet(fn, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*args, **kw)


@pytest.fixture(scope="module")
def paper_shot(horsdal):
    log, truth = simulated_log(horsdal, FPS, NOISE, seed=11, drop_fraction=0.02, t0=5.0)
    est = smooth(log)
    res = {form: _quiet(loads_from_smoothed, est, horsdal,
                        options=ReconstructOptions(form=form))
           for form in ("projected", "direct")}
    return log, truth, est, res


def _moving(truth: pd.DataFrame, res: pd.DataFrame) -> np.ndarray:
    return (truth["phase"].to_numpy() > 0) & np.isfinite(res["F_R_abs"].to_numpy())


def _rms_rel(res, truth, col) -> float:
    m = _moving(truth, res)
    err = res[col].to_numpy()[m] - truth[col].to_numpy()[m]
    return float(np.sqrt(np.mean(err**2)) / np.max(np.abs(truth[col].to_numpy()[m])))


def _coverage(res, truth, col) -> float:
    """Share of the shot's frames with the truth inside ±2 sd; |F_S| only while the sling
    holds the projectile (after the release load and truth are both 0: inside any band)."""
    m = _moving(truth, res)
    if col == "F_S_abs":
        m &= truth["phase"].to_numpy() <= 2
    err = np.abs(res[col].to_numpy()[m] - truth[col].to_numpy()[m])
    return float(np.mean(err <= 2 * res[col + "_sd"].to_numpy()[m]))


def test_columns_time_and_phases(paper_shot, horsdal):
    log, truth, _, res = paper_shot
    r = res["projected"]
    np.testing.assert_array_equal(r["t"], log["t"])  # the log's own time
    trig = r.attrs["events"]["trigger"]
    np.testing.assert_allclose(r["t_shot"], log["t"] - trig)
    for col in ["theta", "psi_d", "phi_dd", *LOAD_COLUMNS, "F_N", "sling_tension"]:
        assert col in r and col + "_sd" in r, col
    phase = r["phase"].to_numpy()
    assert set(np.unique(phase)) == {0, 1, 2, 3}
    assert np.all(np.diff(phase) >= 0)
    rest = phase == 0
    assert np.all(r["t"].to_numpy()[rest] <= trig)
    # at rest: no motion, the projectile lies in the trough with its whole weight
    assert np.all(r.loc[rest, ["theta_d", "psi_dd"]].to_numpy() == 0.0)
    e = horsdal.engine
    np.testing.assert_allclose(r.loc[rest, "F_N"], e.m * horsdal.g, rtol=1e-9)
    # phase 3: no sling force at all
    assert np.all(r.loc[phase == 3, "F_S_abs"] == 0.0)


def test_events_in_log_time_match_the_simulation(paper_shot):
    _, truth, _, res = paper_shot
    found, sd = res["projected"].attrs["events"], res["projected"].attrs["reconstruction"].event_sd
    true = truth.attrs["events"]
    assert abs(found["trigger"] - true["trigger"]) * FPS < 3
    assert abs(found["release"] - true["release"]) * FPS < 2
    assert 0 < sd["lift_off"] < 0.05
    assert abs(found["lift_off"] - true["lift_off"]) < 3 * sd["lift_off"] + 1 / FPS


def test_projected_form_meets_targets_and_beats_direct(paper_shot):
    _, truth, _, res = paper_shot
    proj, direct = res["projected"], res["direct"]
    for col in ("F_R_abs", "F_H_abs", "F_S_abs"):
        assert _rms_rel(proj, truth, col) < 0.05, col
        m = _moving(truth, proj)
        peak_true = np.max(np.abs(truth[col].to_numpy()[m]))
        assert abs(np.max(np.abs(proj[col].to_numpy()[m])) - peak_true) < 0.05 * peak_true
    assert _rms_rel(proj, truth, "F_R_abs") <= _rms_rel(direct, truth, "F_R_abs")
    assert _rms_rel(proj, truth, "torque") < _rms_rel(direct, truth, "torque")


def test_bands_are_honest(paper_shot):
    _, truth, _, res = paper_shot
    for col in ("F_R_abs", "F_H_abs", "F_S_abs"):
        cover = _coverage(res["projected"], truth, col)
        assert 0.85 <= cover <= 0.995, (col, cover)


def test_sd_bands_widen_at_the_release(paper_shot):
    _, _, _, res = paper_shot
    r = res["projected"]
    rel = r.attrs["events"]["release"]
    t = r["t"].to_numpy()
    near = np.abs(t - rel) < 1.0 / FPS
    sling = (r["phase"].to_numpy() == 2) & (t < rel - 0.05)
    assert r["F_S_abs_sd"].to_numpy()[near].max() > 5 * np.median(r["F_S_abs_sd"][sling])


def test_events_given_override_detection(horsdal):
    log, truth = simulated_log(horsdal, 120, 0.3, seed=4)
    true = truth.attrs["events"]
    r = _quiet(reconstruct, log, horsdal, events=true)
    assert r.attrs["events"] == {k: pytest.approx(v) for k, v in true.items()}
    done = r.attrs["reconstruction"]
    assert done.event_sources["lift_off"] == "given"
    assert done.event_sd["trigger"] == 0.0 and done.event_sd["release"] == 0.0
    t = r["t"].to_numpy()
    np.testing.assert_array_equal(r["phase"].to_numpy(), truth["phase"].to_numpy()[:len(t)])
    with pytest.raises(TrebuchetInputError, match="unknown event 'launch'"):
        reconstruct(log, horsdal, events={"launch": 1.0})


def _shot_file(horsdal, tmp_path):
    log, truth = simulated_log(horsdal, 120, 0.3, seed=4, t0=0.8)
    path = tmp_path / "shot.csv"
    log.to_csv(path, index=False)
    return path, log["t"].to_numpy(), truth.attrs["events"]


@pytest.mark.filterwarnings("ignore::trebuchet.core.errors.TrebuchetDataWarning")
def test_given_event_outside_the_log_is_refused_naming_file_and_event(horsdal, tmp_path):
    path, t, true = _shot_file(horsdal, tmp_path)
    for key, v in (("lift_off", t[-1] + 3.0), ("release", 100.0), ("trigger", t[0] - 0.1)):
        with pytest.raises(TrebuchetInputError) as err:
            reconstruct(path, horsdal, events={**true, key: v})
        msg = str(err.value)
        assert msg.startswith(str(path)) and f"events['{key}']" in msg, msg
        assert "lies outside the log" in msg and f"{t[0]:g}" in msg, msg
    # at the log's edges and inside it the events are accepted
    r = _quiet(reconstruct, path, horsdal, events={"trigger": float(t[0]),
                                                  "release": true["release"]})
    assert r.attrs["events"]["trigger"] == pytest.approx(t[0])


@pytest.mark.filterwarnings("ignore::trebuchet.core.errors.TrebuchetDataWarning")
def test_given_events_out_of_order_are_refused_naming_file_and_event(horsdal, tmp_path):
    path, t, true = _shot_file(horsdal, tmp_path)
    trig, lift, rel = true["trigger"], true["lift_off"], true["release"]
    cases = (({"lift_off": rel + 0.01, "release": rel}, "release", "lift_off"),
             ({"trigger": lift + 0.01, "lift_off": lift}, "lift_off", "trigger"),
             ({"trigger": rel, "release": trig}, "release", "trigger"),
             ({"trigger": trig, "lift_off": None, "release": trig}, "release", "trigger"))
    for events, late, early in cases:
        with pytest.raises(TrebuchetInputError) as err:
            reconstruct(path, horsdal, events=events)
        msg = str(err.value)
        assert msg.startswith(str(path)), msg
        assert f"events['{late}']" in msg and f"after events['{early}']" in msg, msg
    # smooth() names the file too when the log carries its source
    from trebuchet.ingest.logs.read_log import read_log

    with pytest.raises(TrebuchetInputError, match=r"shot\.csv: events\['release'\] = 1.2 s is "
                       r"not after events\['trigger'\]"):
        smooth(read_log(path), events={"trigger": 1.5, "release": 1.2})


def test_propagation_is_exact_for_a_square():
    """sd of y = x_d² for x_d ~ N(μ, σ²): var 4μ²σ² + 2σ⁴, bias σ²."""
    mu, sig = np.array([0.0, 1.0, 3.0]), np.array([0.5, 0.2, 1.0])
    state = pd.DataFrame({"t": [0.0, 1.0, 2.0], "theta": 0.0, "theta_d": mu, "theta_dd": 0.0})
    cov = np.zeros((3, 3, 3))
    cov[:, 1, 1] = sig**2
    cov[:, 0, 0] = 1.0  # y does not depend on theta: no contribution

    def square(s):
        return pd.DataFrame({"y": s["theta_d"].to_numpy() ** 2})

    p = propagate(square, state, {"theta": cov}, ["y"])
    expected = np.sqrt(4 * mu**2 * sig**2 + 2 * sig**4 + sig**4)
    np.testing.assert_allclose(p.sd[:, 0], expected, rtol=1e-12)


def test_propagation_over_two_angles_adds_their_independent_variances():
    """y = 2 θ̈ − 3 φ̇ + θ φ: the variance from each angle's full 3×3 covariance, the two
    angles' errors independent; first order exact for the linear part."""
    rng = np.random.default_rng(5)
    n = 4
    state = pd.DataFrame({"t": np.arange(n, dtype=float)}
                         | {a + s: rng.normal(size=n) for a in ("theta", "phi")
                            for s in ("", "_d", "_dd")})
    full = np.zeros((n, 6, 6))
    for i in range(n):
        for k in (0, 3):
            m = rng.normal(size=(3, 3))
            full[i, k:k + 3, k:k + 3] = m @ m.T / 3
    cov = {"theta": full[:, :3, :3], "phi": full[:, 3:, 3:]}

    def linear(s):
        return pd.DataFrame({"y": 2 * s["theta_dd"].to_numpy() - 3 * s["phi_d"].to_numpy()})

    grad = np.array([0, 0, 2, 0, -3, 0], float)
    want = np.sqrt(np.einsum("i,nij,j->n", grad, full, grad))
    for order in (1, 2):
        p = propagate(linear, state, cov, ["y"], order=order)
        np.testing.assert_allclose(p.sd[:, 0], want, rtol=1e-10)

    def product(s):
        return pd.DataFrame({"y": s["theta"].to_numpy() * s["phi"].to_numpy()})

    # x y is linear in each angle (no diagonal curvature): its variance μy² σx² + μx² σy²
    mx, my = state["theta"].to_numpy(), state["phi"].to_numpy()
    vx, vy = full[:, 0, 0], full[:, 3, 3]
    p = propagate(product, state, cov, ["y"])
    np.testing.assert_allclose(p.sd[:, 0] ** 2, my**2 * vx + mx**2 * vy, rtol=1e-10)


def test_small_engine_at_low_frame_rate_gets_an_advisory():
    scene = Scene.from_dict(SMALL_ENGINE, source="small")
    log, _ = simulated_log(scene, 60, 1.0, seed=2)
    with pytest.warns(ModelValidityWarning, match="exceeds 10% of its peak"):
        r = reconstruct(log, scene)
    adv = r.attrs["reconstruction"].advisories
    assert adv
    for a in adv:
        assert a.worst_sd > 0.1 * a.peak
        assert a.fps_needed is None or a.fps_needed > 60
        assert a.noise_needed_deg is None or a.noise_needed_deg < 1.0


def test_angles_off_the_trough_name_the_rows(horsdal):
    log, truth = simulated_log(horsdal, 120, 0.2, seed=5)
    bad = log.copy()
    sel = (truth["phase"] == 1).to_numpy()
    bad.loc[sel, "phi"] += np.radians(30.0)  # the projectile far below ground in the trough
    with pytest.warns(ModelValidityWarning, match=r"rows \d+.*below ground") as rec:
        r = reconstruct(bad, horsdal, events=truth.attrs["events"])
    assert any("in the trough" in str(w.message) for w in rec)
    assert any("in the trough" in v for v in r.attrs["reconstruction"].validity)


def test_psi_beyond_its_range_names_the_rows(horsdal):
    log, truth = simulated_log(horsdal, 120, 0.2, seed=6)
    bad = log.copy()
    rows = np.arange(80, 95)
    bad.loc[rows, "psi"] = bad.loc[rows, "theta"] + np.radians(20.0)  # arm through the beam
    with pytest.warns(ModelValidityWarning, match="through the beam") as rec:
        reconstruct(bad, horsdal, events=truth.attrs["events"])
    text = " ".join(str(w.message) for w in rec)
    assert "rows 8" in text or "rows 7" in text


def test_rows_of_a_log_file_are_named_by_the_files_line_numbers(horsdal, tmp_path):
    """The findings name the same numbers as the reader's notes: the file's lines (here the
    header is line 1 and 40 rows were dropped before the bad ones, so they differ)."""
    from trebuchet.ingest.logs.read_log import write_log

    log, truth = simulated_log(horsdal, 120, 0.2, seed=6)
    bad = log.copy()
    rows = np.arange(80, 95)
    bad.loc[rows, "psi"] = bad.loc[rows, "theta"] + np.radians(20.0)  # arm through the beam
    bad.loc[np.arange(10, 50), ["theta", "psi", "phi"]] = np.nan  # dropped by read_log
    path = write_log(bad, tmp_path / "shot.csv")
    with pytest.warns(ModelValidityWarning, match="through the beam") as rec:
        reconstruct(path, horsdal, events=truth.attrs["events"])
    text = " ".join(str(w.message) for w in rec if "through the beam" in str(w.message))
    assert "lines 8" in text and "of the file" in text  # data row 80 is line 82 of the file


def test_a_clean_log_raises_no_validity_warning(horsdal):
    log, truth = simulated_log(horsdal, 240, 0.1, seed=8)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        r = reconstruct(log, horsdal)
    assert not r.attrs["reconstruction"].validity, r.attrs["reconstruction"].validity
    assert not any("through the beam" in str(w.message) or "in the trough" in str(w.message)
                   for w in rec)


def test_bad_arguments():
    with pytest.raises(TrebuchetInputError, match="form must be"):
        ReconstructOptions(form="sideways")
    with pytest.raises(TrebuchetInputError, match="scene file not found"):
        reconstruct(pd.DataFrame({"t": [0.0]}), "/nonexistent/scene.toml")


def test_release_at_the_end_of_the_sling_track(horsdal):
    log, truth = simulated_log(horsdal, 60, 1.0, seed=3)
    r = _quiet(reconstruct, log, horsdal, method="smooth")  # the smoother's own events
    assert r.attrs["reconstruction"].event_sources["release"] == "end of the sling track"
    err = r.attrs["events"]["release"] - truth.attrs["events"]["release"]
    assert abs(err) <= 0.5 / 60
    assert 0 < r.attrs["reconstruction"].event_sd["release"] <= 1 / 60


def test_presets_are_named_and_trade_order(horsdal):
    log, truth = simulated_log(horsdal, 120, 0.5, seed=3)
    fast = _quiet(reconstruct, log, horsdal,
                  options=ReconstructOptions(preset="fast", method="smooth"))
    default = _quiet(reconstruct, log, horsdal, method="smooth")  # presets set the smoother
    assert fast.attrs["reconstruction"].preset == "fast"
    assert default.attrs["reconstruction"].preset == "default"
    # the fast preset (coarse tuning, first-order bands) still meets the accuracy target
    assert np.isfinite(fast["F_R_abs_sd"].to_numpy()[truth["phase"].to_numpy() > 0]).all()
    assert _rms_rel(fast, truth, "F_R_abs") < 0.05
    with pytest.raises(TrebuchetInputError, match="preset"):
        ReconstructOptions(preset="quick")


def test_the_checking_smoothing_finds_the_same_events(horsdal):
    """The release check's first smoothing (no band calibration, coarser noise search)
    finds the trigger and release the full one finds on this log."""
    log, _ = simulated_log(horsdal, 240, 0.5, seed=3)
    lean = _quiet(smooth, log, settings=checking_settings(SmoothSettings()))
    full = _quiet(smooth, log)
    assert lean.attrs["events"] == full.attrs["events"]
    assert lean.attrs["events"]["release"] is not None


def test_a_second_smoothing_may_reuse_the_noise_search(horsdal):
    """``tuned``: an earlier smoothing's noise (here the checking one, without the
    release) in place of the search; local noise refits its scale, so the result is
    that of a new search within a small part of its sd. Ignored where q is given."""
    log, truth = simulated_log(horsdal, 240, 0.5, seed=3)
    events = {"release": sling_track_end(log)[0]}
    earlier = _quiet(smooth, log, settings=checking_settings(SmoothSettings()))
    new = _quiet(smooth, log, events=events)
    reused = _quiet(smooth, log, events=events, tuned=earlier.attrs["smoothing"].noise)
    moving = truth["phase"].to_numpy() > 0
    for a in ("theta", "psi", "phi"):
        ratio = reused.attrs["smoothing"].noise[a]["q"] / new.attrs["smoothing"].noise[a]["q"]
        assert abs(np.log10(ratio)) < 0.25, (a, ratio)
        z = np.abs((reused[a + "_dd"] - new[a + "_dd"]) / new[a + "_dd_sd"]).to_numpy()[moving]
        z = z[np.isfinite(z)]  # phi ends with its track
        assert z.size > 100 and np.median(z) < 0.3 and np.max(z) < 1.0, (a, np.median(z), np.max(z))
    q = {a: new.attrs["smoothing"].noise[a]["q"] for a in ("theta", "psi", "phi")}
    given = _quiet(smooth, log, events=events, q=q)
    ignored = _quiet(smooth, log, events=events, q=q, tuned=earlier.attrs["smoothing"].noise)
    np.testing.assert_array_equal(ignored["theta_dd"].to_numpy(), given["theta_dd"].to_numpy())


def test_a_release_inside_the_sling_tracks_last_interval_stands(horsdal):
    """The fitted time a tracked stone leaves its sling's circle lies between the sling's
    last frame and the next; it is not pulled back to their midpoint."""
    log, _ = simulated_log(horsdal, 120, 0.3, seed=2)
    t = log["t"].to_numpy()
    last = int(np.flatnonzero(np.isfinite(log["phi"].to_numpy()))[-1])
    late = float(t[last] + 0.8 * (t[last + 1] - t[last]))
    log.attrs["log"] = ReadLog(source="shot.csv", format="deeplabcut",
                               leaves_sling=(late, 0.002))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # the smoother's events, the cut taken as it is (the arbitration of issue 26 would
        # weigh it with the engine's equations)
        res = reconstruct(log, horsdal, method="smooth",
                          options=ReconstructOptions(release_model=None))
    assert res.attrs["events"]["release"] == late
    assert res.attrs["reconstruction"].event_sd["release"] == 0.002
    assert (res["phase"].to_numpy()[t > late] == 3).all()


def test_without_psi_the_release_check_is_skipped_and_a_note_says_so(horsdal):
    log, truth = simulated_log(horsdal, 240, 0.3, seed=3)
    t, phi = log["t"].to_numpy(), log["phi"].to_numpy()
    ok = np.flatnonzero(np.isfinite(phi))
    rate = (phi[ok[-1]] - phi[ok[-5]]) / (t[ok[-1]] - t[ok[-5]])
    after = t > t[ok[-1]]
    log.loc[after, "phi"] = phi[ok[-1]] + rate * (t[after] - t[ok[-1]])  # the track goes on
    log["psi"] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = reconstruct(log, horsdal, method="smooth")  # the smoother's release check
    assert any("not checked against the engine's equations (psi not tracked)" in n
               for n in res.attrs["reconstruction"].notes)
