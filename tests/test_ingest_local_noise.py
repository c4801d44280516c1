"""Local process noise (q per frame from the jerk of a first smoothing; at the end of the
sling's track the angles' common shape), the smoothing bias in the bands, and the exact
shortcuts they and the speed work rely on: filter series picked from a batch, a filter's
means re-run on other data, stacked uncertainty propagation."""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.kalman.batch import (
    StepModel,
    backward_smoother,
    batch_kalman_filter,
    polynomial_transition,
    refiltered,
    smoothed_states,
    white_noise_covariance,
)
from trebuchet.ingest.reconstruct import loads_from_smoothed
from trebuchet.ingest.smoothing.noise_tuning import jerk_noise_shape, track_end_common_noise
from trebuchet.ingest.smoothing.smooth import (
    ANGLES,
    BAND_ALPHA_FROM,
    SmoothSettings,
    shrunk_alpha,
    smooth,
)
from trebuchet.ingest.synthetic.simulated_log import simulated_log
from trebuchet.ingest.uncertainty import propagate


@pytest.fixture(scope="module")
def paper_240(horsdal):
    log, truth = simulated_log(horsdal, 240, 0.3, seed=5, drop_fraction=0.02)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        local = smooth(log, events={"release": truth.attrs["events"]["release"]})
        one = smooth(log, events={"release": truth.attrs["events"]["release"]},
                     settings=SmoothSettings(local_noise=False))
    return log, truth, local, one


def test_q_is_low_in_the_trough_and_high_in_the_swing(paper_240):
    _, truth, local, one = paper_240
    phase = truth["phase"].to_numpy()
    t = truth["t"].to_numpy()
    # the fastest part of the swing: the last fifth of phase 2
    sling = np.flatnonzero(phase == 2)
    swing = sling[int(0.8 * sling.size):]
    trough = np.flatnonzero(phase == 1)
    for name in ("theta", "psi"):
        q = local.attrs["smoothing"].noise[name]["q_frames"]
        assert q.shape == t.shape and np.all(q > 0)
        assert np.median(q[swing]) > 5 * np.median(q[trough]), name
        assert local.attrs["smoothing"].noise[name]["pieces"] == []
        # one q: the same at every frame, the q reported
        q_one = one.attrs["smoothing"].noise[name]["q_frames"]
        np.testing.assert_allclose(q_one, one.attrs["smoothing"].noise[name]["q"], rtol=1e-12)


def test_local_noise_narrows_the_trough_and_keeps_the_truth(paper_240, horsdal):
    """The model's own bands (``band_variance="posterior"``) are narrower in the trough
    with local noise (its smaller ``q`` there). The calibrated bands take off what the data
    do not show of either ``q``: measured with the default calibration φ̈'s trough band
    is 0.29 rad/s² with local noise against 0.26 with one ``q`` (θ̈ 0.27 against 0.52)."""
    log, truth, local, one = paper_240
    phase = truth["phase"].to_numpy()
    events = {"release": truth.attrs["events"]["release"]}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        post = {key: smooth(log, events=events, settings=SmoothSettings(
            local_noise=key == "local", band_variance="posterior")) for key in ("local", "one")}
    for name in ANGLES:
        col = name + "_dd_sd"
        sd_local, sd_one = (np.nanmedian(post[key][col].to_numpy()[phase == 1])
                            for key in ("local", "one"))
        assert sd_local < sd_one, name
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        loads = {key: loads_from_smoothed(est, horsdal) for key, est in
                 (("local", local), ("one", one))}
    moving = phase > 0
    rms = {}
    for key, res in loads.items():
        err = (res["F_R_abs"] - truth["F_R_abs"]).to_numpy()[moving]
        rms[key] = np.sqrt(np.nanmean(err**2))
        if key == "local":
            cover = np.nanmean(np.abs(err) <= 2 * res["F_R_abs_sd"].to_numpy()[moving])
            assert 0.85 <= cover <= 0.99, cover
    assert rms["local"] < rms["one"]


def test_jerk_shape_is_relative_and_ignores_unweighted_steps():
    n = 200
    ts = np.arange(n, dtype=float)
    acc = np.zeros((2, n))
    acc[0] = 0.5 * ts  # constant jerk: a flat shape
    acc[1, 100:] = 0.02 * (ts[100:] - 100) ** 2  # jerk rising after step 100
    weight = np.ones((2, n))
    weight[:, :5] = 0.0
    shape = jerk_noise_shape(acc, ts, weight, np.array([5.0, 5.0]), 0.01)
    np.testing.assert_allclose(shape[0, 10:-10], 1.0, rtol=1e-9)
    # mean 1 over the weighted steps, raised a little by the floor
    assert 1.0 <= np.average(shape[1], weights=weight[1]) < 1.01
    assert shape[1, 190] > 1.0 > shape[1, 50]
    assert shape[1, 50] == pytest.approx(0.01)  # the floor where there is no jerk
    # a wild value where the steps carry no weight (its jerks at steps 2 and 3) is ignored
    wild = acc.copy()
    wild[:, 2] = 1e6
    np.testing.assert_array_equal(jerk_noise_shape(wild, ts, weight, np.array([5.0, 5.0]),
                                                   0.01), shape)


def test_series_of_a_batch_equal_their_own_runs():
    n, k = 120, 3
    dt = np.ones(n)
    F = polynomial_transition(k, dt)
    F[0] = np.eye(k)
    Q0 = white_noise_covariance(k, dt)
    Q0[:30] = 0.0  # a rest: the running-mean shortcut
    steps = StepModel(F, Q0, np.zeros_like(F))
    rng = np.random.default_rng(2)
    z = np.cumsum(np.cumsum(rng.normal(size=n))) * 1e-2 + rng.normal(size=n)
    valid = rng.random(n) > 0.1
    lams = np.array([1e-4, 1e-2, 1.0])
    B = lams.size
    x0 = np.zeros((B, k))
    x0[:, 0] = z[0]
    P0 = np.zeros((B, k, k))
    P0[:, 0, 0] = 100.0
    many = batch_kalman_filter(np.tile(z, (B, 1)), np.tile(valid, (B, 1)), steps, lams,
                               np.zeros(B), np.ones(B), x0, P0, store=True)
    one = batch_kalman_filter(z[None], valid[None], steps, lams[1:2], np.zeros(1),
                              np.ones(1), x0[:1], P0[:1], store=True)
    picked = many.series(np.array([1]))
    for field in ("S", "nu", "xp", "Pp", "gain", "x_end", "P_end"):
        np.testing.assert_allclose(getattr(picked, field), getattr(one, field), rtol=1e-9,
                                   atol=1e-12, err_msg=field)
    # the states-only smoother is the full one's states
    full = backward_smoother(steps, many, np.tile(valid, (B, 1)))
    np.testing.assert_allclose(smoothed_states(steps, many, np.tile(valid, (B, 1))), full.x,
                               rtol=1e-12, atol=1e-12)


def test_stacked_propagation_equals_one_call_per_shift():
    rng = np.random.default_rng(0)
    n = 7
    state = pd.DataFrame({"t": np.arange(n, dtype=float)})
    for a in ("theta", "psi"):
        for suf in ("", "_d", "_dd"):
            state[a + suf] = rng.normal(size=n)
    cov = {}
    for a in ("theta", "psi"):
        m = rng.normal(size=(n, 3, 3))
        cov[a] = m @ np.swapaxes(m, 1, 2) * 0.01

    def loads(s: pd.DataFrame) -> pd.DataFrame:
        th, ps = s["theta"].to_numpy(), s["psi_d"].to_numpy()
        return pd.DataFrame({"y": np.sin(th) * ps ** 2 + s["theta_dd"].to_numpy(),
                             "w": np.hypot(th, s["psi_dd"].to_numpy())})

    for order in (1, 2):
        each = propagate(loads, state, cov, order=order)
        once = propagate(loads, state, cov, order=order, stacked=True)
        assert each.names == once.names
        np.testing.assert_allclose(once.value, each.value, rtol=1e-12)
        np.testing.assert_allclose(once.sd, each.sd, rtol=1e-12)
        np.testing.assert_allclose(once.by_order, each.by_order, rtol=1e-12, atol=1e-15)


def test_local_linear_window_follows_a_trend_to_the_track_end():
    """The local mean of a one-sided window averages a rising trend down at the track's
    end; the local-linear fit reproduces a linear trend exactly, also there, and in the
    interior of evenly weighted steps it equals the local mean for a constant."""
    from trebuchet.ingest.smoothing.noise_tuning import windowed_noise

    n = 200
    t = np.arange(n, dtype=float)
    est = np.vstack([1.0 + 0.05 * t, np.full(n, 3.0)])
    weight = np.ones((2, n))
    weight[:, 150:] = 0.0  # the track ends at step 149
    half = np.array([8.0, 8.0])
    floor = np.zeros(2)
    mean = windowed_noise(est, weight, half, floor)
    lin = windowed_noise(est, weight, half, floor, linear=True)
    np.testing.assert_allclose(lin[0, :150], est[0, :150], rtol=1e-9)
    assert mean[0, 149] < est[0, 149] - 0.2
    np.testing.assert_allclose(lin[1, :150], 3.0, rtol=1e-9)
    np.testing.assert_allclose(mean[1, 40:110], lin[1, 40:110], rtol=1e-12)


def test_track_end_common_noise_raises_only_the_end_of_a_track_that_stops_early():
    n = 200
    shape = np.ones((3, n))
    shape[0, 120:] = 40.0  # the beam's jerk rises at the end of the swing ...
    shape[1, 120:] = 10.0
    shape[2, 120:] = 0.01  # ... the sling's own first pass, ending at 149, misses it
    weight = np.ones((3, n))
    weight[2, 150:] = 0.0
    ends = np.array([199, 199, 149])
    out = track_end_common_noise(shape, weight, ends, 199, np.full(3, 20.0))
    np.testing.assert_array_equal(out[:2], shape[:2])  # tracks that go on: unchanged
    np.testing.assert_array_equal(out[2, :129], shape[2, :129])  # before the span
    np.testing.assert_allclose(out[2, 129:150], (40.0 + 10.0 + 0.01) / 3)  # mean of three
    np.testing.assert_array_equal(out[2, 150:], shape[2, 150:])  # after the track
    # where its own shape is the larger, it stays
    own = shape.copy()
    own[2, 140] = 100.0
    assert track_end_common_noise(own, weight, ends, 199, np.full(3, 20.0))[2, 140] == 100.0
    # a track ending with the others (fewer than three steps before), or one angle: as is
    np.testing.assert_array_equal(
        track_end_common_noise(shape, weight, np.array([199, 199, 197]), 199,
                               np.full(3, 20.0)), shape)
    np.testing.assert_array_equal(
        track_end_common_noise(shape[2:], weight[2:], ends[2:], 199, np.full(1, 20.0)),
        shape[2:])


def test_refiltered_means_equal_a_fresh_filter_of_the_other_data():
    n, k = 150, 3
    dt = np.ones(n)
    F = polynomial_transition(k, dt)
    F[0] = np.eye(k)
    Q0 = white_noise_covariance(k, dt)
    Q0[:30] = 0.0  # a rest before a trigger, then a kick in acceleration at step 31
    G = np.zeros_like(F)
    G[31, 2, 2] = 1.0
    steps = StepModel(F, Q0, G)
    rng = np.random.default_rng(4)
    z1 = np.cumsum(np.cumsum(rng.normal(size=(2, n)), axis=1), axis=1) * 1e-2
    z2 = np.sin(np.arange(n) / 9.0)[None] + rng.normal(size=(2, n))
    valid = rng.random((2, n)) > 0.1
    lam = np.array([[1e-3], [1e-1]]) * np.linspace(0.5, 2.0, n)[None]  # per step
    x0 = np.zeros((2, k))
    x0[:, 0] = z1[:, 0]
    P0 = np.zeros((2, k, k))
    P0[:, 0, 0] = 100.0
    args = (valid, steps, lam, np.full(2, 10.0), np.ones(2))
    first = batch_kalman_filter(z1, *args, x0, P0, store=True)
    fresh = batch_kalman_filter(z2, *args, x0, P0, store=True)
    again = refiltered(steps, first, z2, valid, x0)
    for field in ("xp", "nu", "x_end"):
        np.testing.assert_allclose(getattr(again, field), getattr(fresh, field), rtol=1e-9,
                                   atol=1e-9, err_msg=field)
    np.testing.assert_allclose(smoothed_states(steps, again, valid),
                               backward_smoother(steps, fresh, valid).x, rtol=1e-9, atol=1e-9)


def _bias_pair(log: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    events = {"trigger": None, "release": None}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return (smooth(log, events=events),
                smooth(log, events=events, settings=SmoothSettings(bias_band=False)))


def test_bias_band_is_nil_on_a_parabola_and_widens_a_fast_bump():
    """The constant-acceleration smoother reproduces a parabola, so smoothing its smoothed
    angle again changes nothing: no bias term. A bump faster than the smoother (1° noise
    at 60 fps) is flattened: the band widens there and holds the truth more often."""
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 3.0, 1.0 / 60.0)
    noise = np.radians(1.0)

    def log_of(x):
        return pd.DataFrame({"t": t, "theta": x + rng.normal(0.0, noise, t.size),
                             "psi": 0.5 * x + rng.normal(0.0, noise, t.size), "phi": np.nan})

    with_bias, without = _bias_pair(log_of(0.1 + 0.3 * t - 0.2 * t**2))
    for col in ("theta", "theta_d", "theta_dd"):
        np.testing.assert_array_equal(with_bias[col], without[col])
        np.testing.assert_allclose(with_bias[col + "_sd"], without[col + "_sd"], rtol=1e-3)
    bump = 0.4 * np.exp(-(((t - 1.5) / 0.25) ** 2))
    with_bias, without = _bias_pair(log_of(bump))
    ratio = (with_bias["theta_sd"] / without["theta_sd"]).to_numpy()
    assert ratio.min() >= 1.0 - 1e-12 and ratio.max() > 1.1
    cover = {key: np.mean(np.abs(est["theta"] - bump) <= 2 * est["theta_sd"])
             for key, est in (("bias", with_bias), ("none", without))}
    assert cover["bias"] > cover["none"], cover


def test_sling_band_at_its_track_end_is_wider_than_its_own_first_pass_gives(paper_240):
    """The sling's track ends at the release just as it whips round; its own first pass
    cannot show that, the beam's and the arm's can. Their common shape keeps the sling's
    q up there, and the band of its rate holds the truth closer."""
    log, truth, local, _ = paper_240
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        own = smooth(log, events={"release": truth.attrs["events"]["release"]},
                     settings=SmoothSettings(local_end_common=0.0))
    last = np.flatnonzero(np.isfinite(log["phi"].to_numpy()))[-1]
    end = np.arange(last - 9, last + 1)
    q_common = local.attrs["smoothing"].noise["phi"]["q_frames"][end]
    q_own = own.attrs["smoothing"].noise["phi"]["q_frames"][end]
    # the local-linear fit carries the sling's own falling jerk down to the floor at the end
    assert np.all(q_common >= q_own) and q_common[-1] > 10 * q_own[-1]
    z = {key: np.max(np.abs((est["phi_d"] - truth["phi_d"]).to_numpy()[end]
                            / est["phi_d_sd"].to_numpy()[end]))
         for key, est in (("common", local), ("own", own))}
    assert z["common"] < z["own"] and z["common"] < 3.0, z


def test_second_bias_term_takes_in_more_of_the_flattened_bump():
    """Noise-free bump, q far too small: the error is all bias. Twicing's residual
    (first term) gives about half of it at the peak; the second term of the series
    ``(M − I) x = Σ (I − M)^j (M − I) x̂`` more, still below the whole."""
    t = np.arange(0.0, 3.0, 1.0 / 60.0)
    bump = 0.4 * np.exp(-(((t - 1.5) / 0.15) ** 2))
    log = pd.DataFrame({"t": t, "theta": bump, "psi": np.nan, "phi": np.nan})
    kw = {"events": {"trigger": None, "release": None}, "q": 3e2, "r": np.radians(1.0)}
    plain = smooth(log, **kw, settings=SmoothSettings(bias_band=False, band_variance="posterior"))
    err = np.abs(plain["theta"].to_numpy() - bump)
    near = np.abs(t - 1.5) < 0.45
    share, miss = {}, {}
    for terms in (1, 2):
        est = smooth(log, **kw, settings=SmoothSettings(bias_iterations=terms,
                                                        band_variance="posterior"))
        b = np.sqrt(np.maximum(est["theta_sd"] ** 2 - plain["theta_sd"] ** 2, 0.0)).to_numpy()
        share[terms] = b[np.argmax(err)] / err.max()
        miss[terms] = np.sqrt(np.mean((b - err)[near] ** 2))
    assert 0.3 < share[1] < share[2] - 0.1 and share[2] < 1.0, share
    assert miss[2] < 0.8 * miss[1], miss


def _white_jerk(rng, t, q):
    dt = np.diff(t, prepend=t[0])
    F = polynomial_transition(3, dt)
    Q = white_noise_covariance(3, dt) * q
    x = np.zeros((t.size, 3))
    for i in range(1, t.size):
        x[i] = F[i] @ x[i - 1] + np.linalg.cholesky(Q[i]) @ rng.normal(size=3)
    return x


def _slow_swing():
    """A 0.4 Hz swing of 0.5 rad filmed 3 s at 120 fps with 0.3° noise, no events: the random
    generator, times (s), noise (rad), events, the angle and its acceleration."""
    t = np.arange(0.0, 3.0, 1.0 / 120.0)
    w = 2 * np.pi * 0.4
    return (np.random.default_rng(11), t, np.radians(0.3), {"trigger": None, "release": None},
            0.5 * np.sin(w * t), -0.5 * w**2 * np.sin(w * t))


@pytest.mark.parametrize("alpha_from", BAND_ALPHA_FROM)
def test_calibrated_band_shrinks_only_where_the_data_show_less_jerk_than_the_model(alpha_from):
    """A slow swing smoothed with a q a thousand times too large: the data show almost
    none of that process noise, so the band keeps the measurement noise's share and the
    bias and drops most of the rest (the acceleration's sd about halves), still holding
    the truth. Data drawn from the smoother's own model keep most of the posterior
    (measured: median ``α`` 0.81 from the sums, 1 shrunk; coverage 92 %, 86 %)."""
    rng, t, noise, events, x, x_dd = _slow_swing()
    log = pd.DataFrame({"t": t, "theta": x + rng.normal(0.0, noise, t.size),
                        "psi": 0.3 * x + rng.normal(0.0, noise, t.size), "phi": np.nan})
    posterior = SmoothSettings(band_variance="posterior")
    settings = SmoothSettings(band_alpha_from=alpha_from)
    cal = smooth(log, events=events, q=1e3, r=noise, settings=settings)
    post = smooth(log, events=events, q=1e3, r=noise, settings=posterior)
    scale = cal.attrs["smoothing"].noise["theta"]["band_scale"]
    assert np.median(scale) < 0.2 and scale.max() <= 1.0
    ratio = (cal["theta_dd_sd"] / post["theta_dd_sd"]).to_numpy()
    assert ratio.max() <= 1.0 + 1e-9 and np.median(ratio) < 0.7
    assert np.mean(np.abs(cal["theta_dd"] - x_dd) <= 2 * cal["theta_dd_sd"]) > 0.95
    truth = _white_jerk(rng, t, 30.0)
    log = pd.DataFrame({"t": t, "theta": truth[:, 0] + rng.normal(0.0, noise, t.size),
                        "psi": np.nan, "phi": np.nan})
    cal = smooth(log, events=events, q=30.0, r=noise, settings=settings)
    assert np.median(cal.attrs["smoothing"].noise["theta"]["band_scale"]) > 0.6
    assert np.mean(np.abs(cal["theta_dd"] - truth[:, 2]) <= 2 * cal["theta_dd_sd"]) > 0.85


def test_shrunk_alpha_moves_as_far_as_the_estimates_scatter_beyond_their_variance():
    """``shrunk_alpha`` (empirical Bayes, DerSimonian–Laird ``τ²``): estimates that scatter
    about the prior by their own variance only stay at the prior; estimates of true values
    spread about the prior (``τ² = 9``, variance 1–7) are pulled toward the prior by
    ``v / (τ² + v)``, closer to the truth than either; infinite variance: the prior."""
    rng = np.random.default_rng(4)
    n = 4000
    prior = rng.uniform(0.3, 1.0, n)
    variance = rng.uniform(1.0, 7.0, n)
    frames = np.ones(n, bool)
    noisy = prior + rng.normal(0.0, np.sqrt(variance))
    kept = shrunk_alpha(prior, noisy, variance, frames)
    assert np.mean(np.abs(kept - prior)) < 0.1 * np.mean(np.abs(noisy - prior))
    truth = prior + rng.normal(0.0, 3.0, n)
    estimate = truth + rng.normal(0.0, np.sqrt(variance))
    shrunk = shrunk_alpha(prior, estimate, variance, frames)
    weight = (shrunk - prior) / (estimate - prior)
    np.testing.assert_allclose(weight, 9.0 / (9.0 + variance), rtol=0.1)
    mse = np.mean((shrunk - truth) ** 2)
    assert mse < 0.9 * min(np.mean((estimate - truth) ** 2), np.mean((prior - truth) ** 2))
    # frames outside the mask do not enter τ²; infinite variance keeps the prior
    variance[:10] = np.inf
    frames[10:20] = False
    estimate[10:20] = 1e6
    again = shrunk_alpha(prior, estimate, variance, frames)
    np.testing.assert_array_equal(again[:10], prior[:10])
    np.testing.assert_allclose(again[20:], shrunk[20:], atol=0.02)


@pytest.mark.parametrize("bad", [{"band_variance": "wide"}, {"bias_iterations": 0},
                                 {"bias_iterations": 1.5}, {"band_alpha_from": "guess"},
                                 {"band_draws": 0}, {"band_draws": 1}])
def test_band_settings_are_checked(bad):
    with pytest.raises(TrebuchetInputError):
        SmoothSettings(**bad)
