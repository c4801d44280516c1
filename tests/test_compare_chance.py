"""The compare report's verdict: what chance allows for the fraction of the shot outside the
measured band (neighbouring rows share their errors, so far more than a binomial count over
rows), where the prediction leaves the band, and the first screen in the figures' units."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd
import pytest

from trebuchet.ingest.compare import (
    CHANCE_COLUMNS,
    CONTRACT_COLUMNS,
    METRIC_COLUMNS,
    CompareOptions,
    compare,
    outside_spans,
)
from trebuchet.ingest.compare_chance import _autocorrelation, _gaussian_fractions
from trebuchet.model.scene import Scene
from trebuchet.report.verdict import NOMINAL, details_table, verdict_html, verdict_table

from .conftest import HORSDAL, ROOT

DEMO = ROOT / "data_samples" / "horsdal_240fps.csv"


def test_outside_spans_longest_first_with_the_worst_excess():
    t = np.arange(10) * 0.01
    measured, sd = np.zeros(10), np.ones(10)
    predicted = np.array([0, 3, 0, 0, -2.5, -4, 0, -3, 0, 0], dtype=float)
    spans = outside_spans(t, measured, sd, predicted)
    # rows 4, 5 and 7 make one stretch (a single row inside does not split it)
    assert spans[0] == pytest.approx((0.04, 0.07, -4.0))
    assert spans[1] == pytest.approx((0.01, 0.01, 3.0))
    assert outside_spans(t, measured, sd, np.zeros(10)) == []


def test_white_errors_give_the_binomial_spread():
    rng = np.random.default_rng(1)
    rho = np.zeros(300)
    rho[0] = 1.0
    f = _gaussian_fractions(1.0, rho, 2.0, 4000, rng)
    assert np.mean(f) == pytest.approx(NOMINAL, rel=0.05)
    n_eff = NOMINAL * (1 - NOMINAL) / np.var(f)
    assert n_eff == pytest.approx(300, rel=0.15)


def test_correlated_errors_hold_far_fewer_independent_samples():
    rng = np.random.default_rng(2)
    rho = np.exp(-np.arange(300) / 8.0)  # errors shared over ~8 rows, as a smoother does
    f = _gaussian_fractions(1.0, rho, 2.0, 4000, rng)
    n_eff = NOMINAL * (1 - NOMINAL) / np.var(f)
    assert n_eff < 60
    assert np.quantile(f, 0.95) > 2 * NOMINAL  # one shot's fraction varies widely


def test_autocorrelation_recovers_an_ar1_process():
    rng = np.random.default_rng(3)
    a, runs, n = 0.8, 20, 400
    z = np.zeros((runs, n))
    e = rng.standard_normal((runs, n)) * math.sqrt(1 - a * a)
    for i in range(1, n):
        z[:, i] = a * z[:, i - 1] + e[:, i]
    var, rho = _autocorrelation(z)
    assert var == pytest.approx(1.0, rel=0.1)
    assert rho[1] == pytest.approx(a, abs=0.05) and rho[5] == pytest.approx(a ** 5, abs=0.08)


@pytest.fixture(scope="module")
def demo():
    scene = Scene.from_toml(HORSDAL)
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for align in ("fit", "trigger"):
            # the fitted engine finds the trigger within a fraction of a ms: the smoother's
            # detection, 6.9 ms late on this log, is what misaligns a model started there
            method = "fit" if align == "fit" else "smooth"
            table, _, _ = compare(DEMO, scene, options=CompareOptions(align=align),
                                  method=method)
            out[align] = table
    return scene, out


def test_metrics_keep_the_contract_and_add_the_chance_columns(demo):
    _, tables = demo
    table = tables["fit"]
    assert list(table.columns) == METRIC_COLUMNS + CHANCE_COLUMNS
    assert list(table.columns[:6]) == CONTRACT_COLUMNS
    assert table["chance_limit"].notna().all()


def test_the_demo_agrees_within_chance_and_says_what_chance_is(demo):
    """The demo compares a log with the engine it came from: most quantities agree, and
    chance allows more than the nominal 4.6 % because the rows are correlated."""
    _, tables = demo
    table = tables["fit"]
    assert (table["chance_limit"] > NOMINAL).all(), table
    assert (table["effective_samples"] < table["rows"] / 3).all(), table
    assert table["within_chance"].sum() >= 8, table[["quantity", "outside_band_fraction",
                                                     "chance_limit"]]


def test_a_misaligned_model_is_found_to_differ(demo):
    _, tables = demo
    table = tables["trigger"]
    assert (~table["within_chance"]).sum() >= 5, table
    assert not bool(table.loc[table["quantity"] == "E_M", "within_chance"].item())
    assert (table["verdict"] == "differs").sum() >= 4, table[["quantity", "verdict"]]


def test_ten_quantities_at_once_get_the_wider_limit(demo):
    """One of ten quantities above its 95 % limit is chance too: "differs" takes the limit
    for all ten at once (Bonferroni), "borderline" lies between."""
    _, tables = demo
    for table in tables.values():
        assert (table["chance_limit_all"] >= table["chance_limit"]).all()
        assert set(table["verdict"]) <= {"agrees", "borderline", "differs"}
        outside = table["outside_band_fraction"]
        assert ((table["verdict"] == "differs") == (outside > table["chance_limit_all"])).all()
    assert (tables["fit"]["verdict"] != "differs").all(), tables["fit"]


def test_the_first_screen_speaks_the_figures_units(demo):
    scene, tables = demo
    short, classes = verdict_table(tables["fit"], scene)
    assert list(short.columns) == ["quantity", "peak measured ± sd", "peak predicted",
                                   "outside ±2 sd", "chance allows", "verdict"]
    text = short.to_string()
    assert "m·g" in text and "M·g" in text and "kN m" in text and "kJ" in text
    assert "\u00a0kN)" in short.loc[0, "peak measured ± sd"]  # a force in m·g has kN beside it
    assert not any("e+" in str(v) for v in short.to_numpy().ravel()), text
    assert "%" in short.loc[0, "outside ±2 sd"]
    html = verdict_html(tables["trigger"], scene)
    assert "differ in" in html and "independent samples" in html
    details = details_table(tables["fit"], scene)
    assert "chance: limit (%)" in details.columns and "at (ms)" in details.columns
    f_s = details.loc[details["quantity"] == "F_S_abs"].iloc[0]
    assert f_s["unit"] == "m·g" and 40 < f_s["measured peak"] < 70


def test_a_verdict_without_chance_says_so(demo):
    scene, tables = demo
    table = tables["fit"].copy()
    table[["chance_fraction", "chance_limit", "effective_samples"]] = math.nan
    assert "No verdict" in verdict_html(table, scene)
    plain = pd.DataFrame(tables["fit"][METRIC_COLUMNS])
    assert "No verdict" in verdict_html(plain, scene)
