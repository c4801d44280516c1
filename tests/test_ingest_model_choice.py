"""Choosing between the constant-acceleration and constant-jerk smoothers by likelihood:
the criterion (event jumps profiled out, AIC's penalty for them) does not depend on the
arbitrary width of the jump priors, the mixture's moments, and ``smooth(model="select")``
returning the chosen model's smoothing per angle."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.smoothing.model_choice import (
    criterion,
    likelihood_weights,
    mixture_moments,
)
from trebuchet.ingest.smoothing.noise_tuning import NoiseSearch
from trebuchet.ingest.smoothing.smooth import SmoothSettings, smooth
from trebuchet.ingest.synthetic.simulated_log import simulated_log

ML = NoiseSearch(cutoff_factor=1.0)


@pytest.fixture(scope="module")
def paper_240(horsdal):
    log, truth = simulated_log(horsdal, 240, 0.3, seed=3, drop_fraction=0.02)
    return log, {"release": truth.attrs["events"]["release"]}


def _run(log, events, model, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return smooth(log, model=model, events=events, settings=SmoothSettings(noise=ML, **kw))


def test_weights():
    assert likelihood_weights([3.0, 5.0], "select").tolist() == [0.0, 1.0]
    assert likelihood_weights([5.0, 5.0], "select").tolist() == [1.0, 0.0]
    w = likelihood_weights([0.0, np.log(3.0)], "average")
    assert w == pytest.approx([0.25, 0.75])
    assert likelihood_weights([np.nan, 1.0], "average").tolist() == [0.0, 1.0]
    assert likelihood_weights([np.nan, np.nan], "select").tolist() == [1.0, 0.0]


def test_mixture_moments_of_two_gaussians():
    m1, m2 = np.array([[0.0, 1.0]]), np.array([[2.0, 1.0]])
    P1, P2 = np.eye(2)[None], 3 * np.eye(2)[None]
    mean, cov = mixture_moments([m1, m2], [P1, P2], np.array([0.5, 0.5]))
    assert mean[0] == pytest.approx([1.0, 1.0])
    # within-model variance 2, between-model spread 1 in the first state, none in the second
    assert cov[0] == pytest.approx(np.array([[3.0, 0.0], [0.0, 2.0]]))
    # a model of weight 0 leaves no trace, not even its NaN
    mean, cov = mixture_moments([m1, np.full((1, 2), np.nan)], [P1, P2], np.array([1.0, 0.0]))
    assert np.array_equal(mean, m1) and np.array_equal(cov, P1)


def test_criterion_does_not_depend_on_the_width_of_the_jump_priors(paper_240):
    """Widening the jerk kick tenfold (its sd) moves the plain likelihood of ``cj`` by
    ``ln 10`` per event, 4.6 nats; the profiled criterion stays (within the shift of
    the q tuning's optimum)."""
    log, events = paper_240
    narrow = _run(log, events, "cj")
    wide = _run(log, events, "cj", jerk_kick_time=0.005)
    for angle in ("theta", "psi"):
        a, b = narrow.attrs["smoothing"].noise[angle], wide.attrs["smoothing"].noise[angle]
        assert a["loglik"] - b["loglik"] > 4.0
        assert criterion(a) == pytest.approx(criterion(b), abs=0.1)
        assert 3.5 < b["jump_count"] <= 4.0  # acceleration and jerk jump at both events
    wide_acc = _run(log, events, "ca", kick_scale=500.0)
    base = _run(log, events, "ca")
    for angle in ("theta", "psi"):
        a, b = base.attrs["smoothing"].noise[angle], wide_acc.attrs["smoothing"].noise[angle]
        assert a["loglik"] - b["loglik"] > 4.0
        assert criterion(a) == pytest.approx(criterion(b), abs=0.1)


def test_select_returns_the_chosen_models_smoothing(paper_240):
    log, events = paper_240
    sel = _run(log, events, "select")
    ca, cj = _run(log, events, "ca"), _run(log, events, "cj")
    assert sel.attrs["smoothing"].model == "select"
    for angle in ("theta", "psi", "phi"):
        c_ca = criterion(ca.attrs["smoothing"].noise[angle])
        c_cj = criterion(cj.attrs["smoothing"].noise[angle])
        chosen = cj if c_cj > c_ca else ca
        w = sel.attrs["smoothing"].model_weights[angle]
        assert w["cj" if chosen is cj else "ca"] == 1.0
        assert sel.attrs["smoothing"].noise[angle]["model"] == ("cj" if chosen is cj else "ca")
        for col in (angle, angle + "_dd", angle + "_dd_sd"):
            np.testing.assert_allclose(sel[col], chosen[col], rtol=1e-12, equal_nan=True)
        assert sel.attrs["smoothing"].cov[angle].shape[1:] == (3, 3)
    avg = _run(log, events, "average")
    # the mixture's band is at least the weighted mean of the models' variances
    for angle in ("theta", "psi"):
        w = avg.attrs["smoothing"].model_weights[angle]
        inner = w["ca"] * ca[angle + "_dd_sd"] ** 2 + w["cj"] * cj[angle + "_dd_sd"] ** 2
        assert np.all(avg[angle + "_dd_sd"] ** 2 >= inner * (1 - 1e-9))


def test_select_refuses_a_given_q(paper_240):
    log, events = paper_240
    with pytest.raises(TrebuchetInputError, match="q"):
        smooth(log, model="select", q=1.0, events=events)
