"""Friction in the measured path and the report (issue 22): the losses of a filmed shot from
its reconstructed loads and rates, with honest sd; the report's energy figure and table."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import trebuchet as tb
from tests.conftest import ROOT
from trebuchet.ingest.synthetic.simulated_log import simulated_log
from trebuchet.model.scene import Scene

SMALL = ROOT / "data_samples" / "small_fast.toml"


@pytest.fixture(scope="module")
def small() -> Scene:
    return Scene.from_toml(SMALL)


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("method", ["smooth", "fit"])
def test_losses_of_a_filmed_shot_hold_the_truth(small, seed, method):
    """The small fast engine filmed at 240 fps with 0.3° of noise. With the smoother's loads
    and the scene's bearings (the formula needs no model of the motion): the heat made by the
    release within 3 % and its ±3 sd, the loss powers inside their ±2 sd band on most rows.
    With the fitted engine (issue 23's default, the friction coefficients free): within ±3 sd
    of its own, wider, sd."""
    log, truth = simulated_log(small, 240.0, 0.3, seed=seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        measured = tb.reconstruct(log, small, method=method)
    assert measured.attrs["reconstruction"].method == method
    release = measured.attrs["events"]["release"]
    i = int(np.searchsorted(measured.t.to_numpy(), release)) - 1
    for joint in ("pivot", "hinge"):
        est, sd = measured[f"E_loss_{joint}"].iloc[i], measured[f"E_loss_{joint}_sd"].iloc[i]
        want = truth[f"E_loss_{joint}"].iloc[i]
        assert abs(est - want) <= 3.0 * sd
        if method == "fit":
            continue
        assert est == pytest.approx(want, rel=0.03)
        P, P_sd = measured[f"P_loss_{joint}"], measured[f"P_loss_{joint}_sd"]
        moving = (measured.phase > 0) & (measured.t <= release)
        inside = (np.abs(P - truth[f"P_loss_{joint}"]) <= 2.0 * P_sd)[moving]
        assert inside.mean() >= 0.85


def test_forces_prints_the_losses(small, tmp_path, capsys):
    from trebuchet.cli import main

    log, _ = simulated_log(small, 240.0, 0.3, seed=0)
    path = tmp_path / "shot.csv"
    log.to_csv(path, index=False)
    assert main(["forces", str(path), "--scene", str(SMALL), "-o", str(tmp_path / "l.csv"),
                 "--time-unit", "s", "--angle-unit", "rad", "--method", "smooth"]) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.startswith("lost to friction"))
    assert "by the release: pivot" in line and "hinge" in line and " J" in line


def test_report_shows_the_losses(small):
    from trebuchet.report.figures import fig_energy
    from trebuchet.report.figures_numbers import peak_table

    run = tb.simulate(small)
    fig = fig_energy(run, None, small)
    titles = [ax.get_title(loc="left") for ax in fig.axes]
    assert "g) lost to friction" in titles and "h) lost to friction since t = 0" in titles
    table = peak_table(run, small)
    share = table[table.quantity.str.startswith("heat made") & (table.unit == "%")]
    assert len(share) == 2
    assert share.value.sum() == pytest.approx(8.7, abs=0.05)  # % of ΔU by the release
    plain = fig_energy(tb.simulate(small.__class__.from_dict(
        {k: v for k, v in small.to_dict().items() if k != "friction"})), None, small)
    assert len(plain.axes) == 6
