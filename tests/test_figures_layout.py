"""The figures of a compare report are legible: no note drawn over another or over a legend,
every legend entry once, and a measured band's entry shows its dashed mean line."""

from __future__ import annotations

import warnings

import matplotlib

matplotlib.use("Agg")

import pytest  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402

from trebuchet.ingest.compare import CompareOptions, compare  # noqa: E402
from trebuchet.model.scene import Scene  # noqa: E402
from trebuchet.report.figures import FIGURES  # noqa: E402

from .conftest import HORSDAL, ROOT  # noqa: E402


@pytest.fixture(scope="module")
def drawn():
    scene = Scene.from_toml(HORSDAL)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, measured, predicted = compare(ROOT / "data_samples" / "horsdal_240fps.csv", scene,
                                         options=CompareOptions(chance_runs=0))
    out = {}
    for name, make in FIGURES.items():
        fig = make(predicted, measured, scene)
        FigureCanvasAgg(fig).draw()
        out[name] = fig
    return out


def _boxes(ax, renderer):
    boxes = [(f"note {t.get_text()!r}", t.get_window_extent(renderer)) for t in ax.texts]
    if ax.get_legend() is not None:
        boxes.append(("legend", ax.get_legend().get_window_extent(renderer)))
    return boxes


@pytest.mark.parametrize("name", list(FIGURES))
def test_no_note_overlaps_another_or_a_legend(drawn, name):
    fig = drawn[name]
    renderer = fig.canvas.get_renderer()  # an Agg canvas (the fixture's)
    for ax in fig.axes:
        boxes = _boxes(ax, renderer)
        for i, (a, box_a) in enumerate(boxes):
            for b, box_b in boxes[i + 1:]:
                assert not box_a.overlaps(box_b), f"{name}, {ax.get_title()}: {a} over {b}"


@pytest.mark.parametrize("name", list(FIGURES))
def test_legend_entries_once_and_measured_bands_show_their_line(drawn, name):
    for ax in drawn[name].axes:
        legend = ax.get_legend()
        if legend is None:
            continue
        labels = [t.get_text() for t in legend.get_texts()]
        assert len(labels) == len(set(labels)), (name, ax.get_title(), labels)
        dashed = {line.get_gid() for line in ax.get_lines() if line.get_gid()}
        for label in labels:
            if label.endswith("measured ±2 sd") and name not in ("loci",):
                assert label in dashed, (name, label)
