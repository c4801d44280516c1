"""A counterweight track that ends while the beam's goes on (issue 15: a frame member in
front of it for the rest of the shot): ψ is carried on by the counterweight's pendulum
driven by the smoothed beam, so |F_R| keeps its peak instead of ending with the track."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from trebuchet.ingest.reconstruct import reconstruct
from trebuchet.ingest.synthetic.simulated_log import simulated_log
from trebuchet.model.dynamics import beam_and_counterweight, counterweight_pendulum_psi_dd


def _quiet(f, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return f(*args, **kwargs)


def test_the_pendulum_is_the_engines_own_counterweight_row(backyard):
    """ψ̈ of the model's beam-and-counterweight equations is the pendulum's, driven by the
    model's own θ̈ (any state)."""
    rng = np.random.default_rng(0)
    th, ps, th_d, ps_d = rng.uniform(-3, 3, (4, 50))
    e, g = backyard.engine, backyard.g
    th_dd, ps_dd = beam_and_counterweight(th, ps, th_d, ps_d, 0.0, 0.0, e, g)
    assert np.allclose(counterweight_pendulum_psi_dd(th, th_d, th_dd, ps, e, g), ps_dd,
                       rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize(("fps", "peak_tol"), [(240.0, 0.05), (120.0, 0.10)])
def test_a_counterweight_lost_before_the_peak_keeps_the_peak(backyard, fps, peak_tol):
    """The issue's |F_R| target (peak within 5 %) at 240 fps; at 120 fps the 6 frames before
    the loss give a less sure start (peak -6.8 % measured on this seed)."""
    log, truth = simulated_log(backyard, fps, 0.3, seed=3)
    shot = truth["phase"].to_numpy() >= 1
    peak = int(np.argmax(np.where(shot, truth["F_R_abs"], -np.inf)))
    lost = log.copy()
    lost.loc[lost.index[peak - int(0.05 * fps):], "psi"] = np.nan  # 50 ms before the peak
    res = _quiet(reconstruct, lost, backyard, method="smooth")  # the smoother's continuation
    est = res["F_R_abs"].to_numpy()
    true = truth["F_R_abs"].to_numpy()
    assert np.isfinite(est[shot]).all()  # before: |F_R| ended with the counterweight's track
    assert abs(np.nanmax(est[shot]) / true[shot].max() - 1) < peak_tol
    rms = np.sqrt(np.mean((est[shot] - true[shot]) ** 2)) / true[shot].max()
    assert rms < 0.03
    psi_err = np.abs(res["psi"].to_numpy() - truth["psi"].to_numpy())
    assert any("counterweight's pendulum" in n for n in res.attrs["reconstruction"].notes)
    # the continued ψ's sd grows from the tracked one's and holds its drift to 3 sd
    sd = res["psi_sd"].to_numpy()
    cut = peak - int(0.05 * fps)
    assert sd[-1] > 3 * sd[cut - 1]
    assert (psi_err[cut:] <= 3 * sd[cut:]).all()


@pytest.mark.parametrize("seed", [3, 4])
def test_a_track_dragged_as_it_is_lost_does_not_set_the_continuations_rate(backyard, seed):
    """Issue 26's backyard engine at 15° tilt: the counterweight's marker, hidden as its
    track ends, drags its last points (here 0.1°, 0.25°, 0.5°); the smoother's rate at the
    last row followed them and the pendulum carried that rate on (ψ 2.3-2.6° off within
    0.2 s, 7-9 sd, on these seeds). Started from the pendulum fitted over the track's last
    points, ψ stays within 1.5° and 4 sd of the truth."""
    log, truth = simulated_log(backyard, 240.0, 0.1, seed=seed)
    shot = truth["phase"].to_numpy() >= 1
    cut = int(np.argmax(np.where(shot, truth["F_R_abs"], -np.inf))) - 12
    lost = log.copy()
    lost.loc[lost.index[cut:], "psi"] = np.nan
    lost.loc[lost.index[cut - 3:cut], "psi"] += np.deg2rad([0.1, 0.25, 0.5])
    res = _quiet(reconstruct, lost, backyard, method="smooth")
    after = slice(cut, cut + 48)  # 0.2 s
    err = np.abs(res["psi"].to_numpy() - truth["psi"].to_numpy())[after]
    assert np.degrees(err.max()) < 1.5
    assert (err <= 4 * res["psi_sd"].to_numpy()[after]).all()
    assert any("fitted to the track's last" in n for n in res.attrs["reconstruction"].notes)
