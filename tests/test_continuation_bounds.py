"""The pendulums that carry a lost angle on go only as far as they are used, never across a
gap in the beam's rows, and a log whose time jumps further than it lasts is refused (issue 21:
a last time of 1e9 s, or a DeepLabCut frame index of 1e6, hung in the continuation; issue
25: a 60 s log spent most of its reconstruction integrating 25 pendulums to its end)."""

from __future__ import annotations

import time
import warnings

import numpy as np
import pytest

from trebuchet.cli import main
from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.events.driven_pendulum import MAX_GAP_FRAMES
from trebuchet.ingest.events.sling_continuation import continued_sling, release_horizon
from trebuchet.ingest.reconstruct import reconstruct
from trebuchet.ingest.smoothing.smooth import smooth
from trebuchet.ingest.synthetic.simulated_log import simulated_log

from .conftest import ROOT


def _quiet(f, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return f(*args, **kwargs)


@pytest.fixture(scope="module")
def swinging(horsdal):
    """A 240 fps log going on 2.5 s after the release, smoothed; the sling's last row."""
    log, truth = simulated_log(horsdal, 240, 0.3, seed=0, after_release=2.5)
    est = _quiet(smooth, log, events={"release": truth.attrs["events"]["release"]})
    last = int(np.flatnonzero(np.isfinite(log["phi"].to_numpy()))[-1])
    cols = {c: est[c].to_numpy() for c in ("t", "theta", "theta_d", "theta_dd", "phi", "phi_d")}
    return est, cols, last, truth


def test_a_continuation_up_to_a_time_is_the_whole_ones_start(horsdal, swinging):
    est, cols, last, _ = swinging
    cov = est.attrs["smoothing"].cov["phi"][last][:3, :3]
    whole = continued_sling(cols, horsdal, last, cov)
    until = float(cols["t"][last + 60])
    part = continued_sling(cols, horsdal, last, cov, until=until)
    assert part.rows[-1] == last + 60 and whole.rows[-1] == len(cols["t"]) - 1
    n = part.rows.size
    # the same steps but the last (cut at ``until``): equal to the integrator's tolerance
    np.testing.assert_allclose(part.phi, whole.phi[:n], rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(part.cov, whole.cov[:n], rtol=1e-6, atol=1e-12)
    # the start alone (the release check's): the ensemble's first member, no sd
    alone = continued_sling(cols, horsdal, last, cov, until=until, spread=False)
    np.testing.assert_allclose(alone.phi, part.phi, rtol=1e-7, atol=1e-8)
    assert np.isnan(alone.cov).all()


def test_the_release_check_looks_no_further_than_the_beams_turn(swinging):
    """The horizon: the beam's first turn after the track's end (a stone still in the sling
    then is thrown nowhere), or twice the shot's time up to the track's end, whichever is
    later; here well before the log's end, and after the true release."""
    est, cols, last, truth = swinging
    t, theta_d = cols["t"], cols["theta_d"]
    trigger = est.attrs["smoothing"].events["trigger"]
    horizon = release_horizon(t, theta_d, last, trigger)
    turn = t[last + np.flatnonzero(np.sign(theta_d[last:]) != np.sign(theta_d[last]))[0]]
    assert horizon == pytest.approx(max(turn, t[last] + 2 * (t[last] - trigger)))
    assert truth.attrs["events"]["release"] < horizon < t[-1] - 0.3


def test_a_pendulum_stops_at_a_gap_in_the_beams_rows(horsdal, swinging):
    est, cols, last, _ = swinging
    cut = last + 20
    jumped = {c: v.copy() for c, v in cols.items()}
    jumped["t"][cut + 1:] += 1e9  # the rows after ``cut`` a billion seconds later
    t0 = time.perf_counter()
    run = continued_sling(jumped, horsdal, last,
                          est.attrs["smoothing"].cov["phi"][last][:3, :3])
    assert time.perf_counter() - t0 < 30.0
    assert run.rows[-1] == cut and run.gap == jumped["t"][cut]
    # a step of MAX_GAP_FRAMES frames is still crossed
    frame = float(np.median(np.diff(cols["t"])))
    slow = {c: v.copy() for c, v in cols.items()}
    slow["t"][cut + 1:] += (MAX_GAP_FRAMES - 1.5) * frame
    run = continued_sling(slow, horsdal, last, est.attrs["smoothing"].cov["phi"][last][:3, :3],
                          until=float(slow["t"][cut + 10]))
    assert run.gap is None and run.rows[-1] == cut + 10


def test_a_log_whose_last_time_is_1e9_is_refused_at_once(horsdal):
    log, _ = simulated_log(horsdal, 240, 0.3, seed=0)
    log.loc[log.index[-1], "t"] = 1e9
    t0 = time.perf_counter()
    with pytest.raises(TrebuchetInputError, match=r"row \d+: time 1e\+09 s comes .* after row"):
        _quiet(reconstruct, log, horsdal)
    assert time.perf_counter() - t0 < 30.0


def test_a_deeplabcut_frame_index_of_1e6_is_one_line_on_the_command_line(tmp_path, capsys):
    rows = (ROOT / "data_samples" / "horsdal_dlc.csv").read_text().splitlines()
    last = rows[-1].split(",")
    last[0] = "1000000"
    path = tmp_path / "dlc.csv"
    path.write_text("\n".join(rows[:-1] + [",".join(last)]) + "\n")
    argv = ["forces", str(path), "--scene", str(ROOT / "data_samples" / "horsdal_large.toml"),
            "-o", str(tmp_path / "loads.csv"), "--fps", "120", "--point", "pivot=axle",
            "--point", "spigot=arm_tip", "--point", "hinge=hinge", "--point",
            "counterweight=weight", "--point", "projectile=stone"]
    t0 = time.perf_counter()
    assert main(argv) == 2
    assert time.perf_counter() - t0 < 60.0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0]
    assert "8333.33 s" in err[0] and "row 263" in err[0]
    assert not (tmp_path / "loads.csv").exists()


def test_the_compiled_integration_takes_scipys_steps(horsdal, swinging):
    """The pendulums' DOP853 compiled (``pendulum_kernel``) against scipy's ``solve_ivp``
    with the numpy right-hand side (``numpy_passes``): the same method and step control;
    their sums round differently, and the error estimate (a difference of nearly equal
    stages) turns that into step sizes a few 1e-7 apart, so the results agree to the
    integrator's tolerance, not to the last bit."""
    from trebuchet.ingest.kalman.reference import numpy_passes

    est, cols, last, _ = swinging
    cov = est.attrs["smoothing"].cov["phi"][last][:3, :3]
    until = float(cols["t"][last + 150])
    fast = continued_sling(cols, horsdal, last, cov, until=until)
    with numpy_passes():
        slow = continued_sling(cols, horsdal, last, cov, until=until)
    for a, b in ((fast.phi, slow.phi), (fast.phi_d, slow.phi_d), (fast.phi_dd, slow.phi_dd)):
        assert np.max(np.abs(a - b)) <= 1e-6 * np.max(np.abs(b))
    assert np.max(np.abs(fast.cov - slow.cov)) <= 1e-4 * np.max(np.abs(slow.cov))
