"""`trebuchet forces` checks the log against the scene and the events against the log
(issue 26): another engine's log is refused, a scene a little off warns, a log with no shot
and a release before the trigger or after the log are refused in one line with status 2."""

from __future__ import annotations

import tomllib
import warnings

import numpy as np
import pytest

from trebuchet.core.errors import ModelValidityWarning, TrebuchetInputError
from trebuchet.ingest.logs.read_log import read_log, write_log
from trebuchet.ingest.reconstruct import ReconstructOptions, reconstruct

from .conftest import HORSDAL
from .test_cli_errors import _refused, _toml

SAMPLES = HORSDAL.parent
BACKYARD_LOG = SAMPLES / "backyard_240fps.csv"
DEMO_LOG = SAMPLES / "horsdal_240fps.csv"


def test_another_engines_log_is_refused_naming_the_scene_and_the_mismatch(tmp_path, capsys):
    """The backyard sample with the paper's scene: exit 0 and a 590 kN m torque peak for a
    100 kg engine before issue 26."""
    line = _refused(capsys, ["forces", str(BACKYARD_LOG), "--scene", str(HORSDAL), "-o",
                             str(tmp_path / "loads.csv")],
                    "backyard_240fps.csv", "horsdal_large.toml", "0.78×", "1.37×",
                    "is the scene the engine filmed?")
    assert "starts with its beam at -45.0°" in line
    assert not (tmp_path / "loads.csv").exists()


def test_compare_compares_another_engines_log_with_a_warning():
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        res = reconstruct(BACKYARD_LOG, HORSDAL,
                          options=ReconstructOptions(scene_mismatch="warn"))
    assert any(issubclass(w.category, ModelValidityWarning)
               and "not the engine of" in str(w.message) for w in rec)
    assert "not the engine of" in " ".join(res.attrs["reconstruction"].notes)
    with pytest.raises(TrebuchetInputError, match="scene_mismatch='warn'"):
        reconstruct(BACKYARD_LOG, HORSDAL)


def test_a_scene_a_little_off_warns(tmp_path):
    """A counterweight 25 % heavier than the engine filmed: its swing is slower in the
    scene, not another engine's; the smoother's loads are computed, with a warning naming
    the mismatch."""
    data = tomllib.loads(HORSDAL.read_text(encoding="utf-8"))
    data["engine"]["M"] = 1.25 * data["engine"]["M"]
    scene = tmp_path / "heavier.toml"
    scene.write_text(_toml(data), encoding="utf-8")
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        # the smoother's loads use the scene's masses (the fitted engine's, issue 23, fit M)
        reconstruct(DEMO_LOG, scene, method="smooth")
    said = [str(w.message) for w in rec if "not the engine of" in str(w.message)]
    assert len(said) == 1 and "heavier.toml" in said[0] and "rad/s" in said[0]


def test_the_samples_own_scene_raises_no_mismatch():
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        reconstruct(BACKYARD_LOG, SAMPLES / "backyard.toml")
    assert not any("not the engine of" in str(w.message) for w in rec)


def test_a_log_with_no_shot_is_refused(tmp_path, capsys):
    """The engine at rest for 1 s: a 105-column CSV and "peak |F_R| 3.56e5 ± 2.17e5 N"
    before issue 26."""
    log = read_log(DEMO_LOG)
    rest = log[log["t"] < 1.0].copy()
    rng = np.random.default_rng(0)
    still = log.iloc[:240].copy()
    still["t"] = np.arange(240) / 240.0
    for a in ("theta", "psi", "phi"):
        still[a] = float(rest[a].median()) + rng.normal(0.0, np.radians(0.3), 240)
    path = write_log(still, tmp_path / "at_rest.csv")
    _refused(capsys, ["forces", str(path), "--scene", str(HORSDAL), "-o",
                      str(tmp_path / "loads.csv")], "at_rest.csv", "no shot in the log")


@pytest.mark.parametrize("release, words", [("0.9", ("--release 0.9", "before the shot's trigger")),
                                            ("5", ("--release 5", "outside the log"))])
def test_a_release_before_the_trigger_or_after_the_log_is_refused(tmp_path, capsys, release,
                                                                   words):
    """``--release 0.9`` ran with F_S 0 everywhere and no lift-off before issue 26."""
    _refused(capsys, ["forces", str(DEMO_LOG), "--scene", str(HORSDAL), "-o",
                      str(tmp_path / "loads.csv"), "--release", release],
             "horsdal_240fps.csv", *words)


def test_the_verdict_cites_a_stretch_the_figures_show():
    """Before issue 26 the verdict said torque was outside its band "mostly at 1102–1190 ms
    (after release)" while every time figure stops at the release near 1000 ms."""
    from trebuchet.ingest.compare import shown_span
    from trebuchet.report.verdict import _stretch

    spans = [(1.102, 1.190, 3.1), (0.50, 0.52, -2.4)]  # longest first
    assert shown_span(spans, 0.997) == (0.50, 0.52, -2.4)
    assert shown_span(spans[:1], 0.997) == spans[0]
    row = {"outside_start": 1.102, "outside_end": 1.190, "outside_worst_sd": 3.1}
    assert "beyond the time figures" in _stretch(row, 997.0)
