"""An HTML report: figures as PNG files, tables, advisories, in one directory written whole.

:func:`write_report` is generic: the ``report`` command (a simulated scene) and the
``compare`` command (a measured log against the simulation) both call it. The directory
is built under a temporary name and renamed into place only when every file is written
(:func:`trebuchet.output.atomic_dir`): after an error, no report, not half of one.
"""

from __future__ import annotations

import html
import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

if TYPE_CHECKING:
    from matplotlib.figure import Figure

from trebuchet.output import atomic_dir

__all__ = ["write_report", "FIGURE_DPI"]

FIGURE_DPI = 100
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")

_STYLE = """
body { font-family: sans-serif; max-width: 1400px; margin: 1em auto; padding: 0 1em;
       color: #222; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.6em; text-align: right; }
th { background: #f0f0f0; }
td:first-child, th:first-child { text-align: left; }
.advisories { background: #fff4e0; border-left: 4px solid #e69500; padding: 0.5em 1em; }
figure { margin: 1em 0 2em 0; }
figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 0.9em; color: #444; }
"""


def _check_name(name: str, what: str) -> None:
    if not _NAME.match(name) or name == "index":
        raise ValueError(f"{what} name {name!r}: use letters, digits, '_', '-', '.', not "
                         "'index'")


def _table_html(frame: pd.DataFrame) -> str:
    return frame.to_html(index=False, escape=True, border=0, na_rep="",
                         float_format=lambda v: f"{v:.4g}")


def render_index(title: str, figures: Sequence[tuple[str, str]],
                 tables: Mapping[str, pd.DataFrame], advisories: Sequence[str],
                 captions: Mapping[str, str] | None = None, intro: str | None = None) -> str:
    """The text of index.html: title, advisories, tables, then every figure
    (``(name, file)`` pairs) with its caption. All text is HTML-escaped."""
    esc = html.escape
    captions = captions or {}
    parts = ["<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
             f"<title>{esc(title)}</title>", f"<style>{_STYLE}</style>", "</head>", "<body>",
             f"<h1>{esc(title)}</h1>"]
    if intro:
        parts.append(f"<p>{esc(intro)}</p>")
    if advisories:
        parts.append('<div class="advisories"><h2>Advisories</h2><ul>')
        parts += [f"<li>{esc(a)}</li>" for a in advisories]
        parts.append("</ul></div>")
    for name, frame in tables.items():
        parts.append(f"<h2>{esc(name)}</h2>")
        parts.append(_table_html(frame))
    if figures:
        parts.append("<h2>Figures</h2>")
    for name, file in figures:
        parts.append(f'<figure id="{esc(name)}"><img src="{esc(file)}" alt="{esc(name)}">')
        parts.append(f"<figcaption>{esc(captions.get(name, name))}</figcaption></figure>")
    parts += ["</body>", "</html>", ""]
    return "\n".join(parts)


def write_report(out_dir: str | Path, figures: Mapping[str, Figure | Callable[[], Figure]],
                 tables: Mapping[str, pd.DataFrame] | None = None,
                 advisories: Iterable[str] = (), title: str = "trebuchet report", *,
                 captions: Mapping[str, str] | None = None, intro: str | None = None,
                 csv_tables: Iterable[str] = (),
                 progress: Callable[[str], None] | None = None) -> Path:
    """Write ``out_dir/index.html``, one ``<name>.png`` per figure and ``<name>.csv`` for each
    table named in ``csv_tables``, atomically: the directory appears complete or not at all
    (an existing one is replaced only on success).

    Parameters
    ----------
    out_dir : path
        The report directory.
    figures : {name: Figure or function returning one}
        Written in this order; ``name`` becomes the file name (letters, digits, ``_-.``). A
        function is called inside the atomic write, so a figure that fails to draw leaves
        no report behind.
    tables : {heading: DataFrame}
        Shown above the figures, in this order, under their headings.
    advisories : strings
        Warnings for the reader (model out of its range, poor data), shown first.
    title : str
        Page title.
    captions : {figure name: text}, optional
        Caption under each figure (default: its name).
    intro : str, optional
        A paragraph under the title.
    csv_tables : table headings
        Tables also written as ``<heading>.csv`` (e.g. ``metrics`` for compare).
    progress : callable, optional
        Told what is being written (each figure), for feedback on slow steps.

    Returns
    -------
    The report directory's path.
    """
    out_dir = Path(out_dir)
    tables = dict(tables or {})
    advisories = [str(a) for a in advisories]
    csv_tables = list(csv_tables)
    for name in figures:
        _check_name(name, "figure")
    for name in csv_tables:
        _check_name(name, "table")
        if name not in tables:
            raise ValueError(f"csv_tables names {name!r}, which is not among the tables")
    with atomic_dir(out_dir) as tmp:
        files = []
        for name, item in figures.items():
            if progress is not None:
                progress(f"drawing {name}.png")
            fig = item() if callable(item) else item
            fig.savefig(tmp / f"{name}.png", dpi=FIGURE_DPI, format="png")
            files.append((name, f"{name}.png"))
        for name in csv_tables:
            tables[name].to_csv(tmp / f"{name}.csv", index=False)
        (tmp / "index.html").write_text(
            render_index(title, files, tables, advisories, captions, intro), encoding="utf-8")
    return out_dir
