"""An HTML report: figures as PNG files, tables, advisories, in one directory written whole.

:func:`write_report` is generic: the ``report`` command (a simulated scene) and the
``compare`` command (a measured log against the simulation) both call it. The directory
is built under a temporary name and renamed into place only when every file is written
(:func:`trebuchet.core.output.atomic_dir`): after an error, no report, not half of one.
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

from trebuchet.core.output import atomic_dir

__all__ = ["write_report", "render_index", "table_html", "FIGURE_DPI", "VIEWPORT"]

FIGURE_DPI = 100
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")

_STYLE = """
* { box-sizing: border-box; }
body { font-family: sans-serif; max-width: 1100px; margin: 1em auto; padding: 0 1em;
       color: #222; line-height: 1.4; overflow-wrap: anywhere; }
h1 { font-size: 1.4em; }
table { border-collapse: collapse; margin: 0.5em 0 1em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.5em; text-align: right;
         vertical-align: top; overflow-wrap: normal; }
th { background: #f0f0f0; text-align: left; }
td:first-child, th:first-child, td.text { text-align: left; }
.scroll { overflow-x: auto; max-width: 100%; }
.verdict { border-left: 6px solid #888; padding: 0.4em 1em; margin: 1em 0; }
.verdict.agree { background: #edf7ed; border-color: #2ca02c; }
.verdict.differ { background: #fdeeee; border-color: #d62728; }
.verdict p { margin: 0.4em 0; }
.verdict table { background: #fff; }
tr.differ td { background: #fbd5d5; font-weight: bold; }
tr.borderline td { background: #fff4e0; }
.advisories { background: #fff4e0; border-left: 4px solid #e69500; padding: 0.5em 1em; }
.small { font-size: 0.85em; color: #444; }
details { margin: 1em 0; }
summary { cursor: pointer; font-weight: bold; }
figure { margin: 1em 0 2em 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { font-size: 0.9em; color: #444; }
.phone { display: none; }
@media (max-width: 700px) {
  body { padding: 0 0.5em; }
  table.stack, table.stack tbody, table.stack tr, table.stack td { display: block; }
  table.stack thead { display: none; }
  table.stack { width: 100%; border: 0; }
  table.stack tr { border: 1px solid #ccc; margin: 0 0 0.6em 0; }
  table.stack td { border: 0; text-align: left; padding: 0.1em 0.5em; }
  table.stack td::before { content: attr(data-label) ": "; font-weight: bold; }
  table.stack td:first-child { font-weight: bold; }
  table.stack td:first-child::before { content: ""; }
  .figscroll { overflow-x: auto; max-width: 100%; }
  .figscroll img { max-width: none; width: auto; }
  .phone { display: block; }
}
"""

#: The page is laid out for phones as well: width of the device, no zoom-out.
VIEWPORT = '<meta name="viewport" content="width=device-width, initial-scale=1">'


def _check_name(name: str, what: str) -> None:
    if not _NAME.match(name) or name == "index":
        raise ValueError(f"{what} name {name!r}: use letters, digits, '_', '-', '.', not "
                         "'index'")


def _cell(value: object) -> str:
    if isinstance(value, float):
        return "" if value != value else f"{value:.4g}"
    return "" if value is None else str(value)


def table_html(frame: pd.DataFrame, *, css_class: str = "", stack: bool = False,
               row_classes: Sequence[str] | None = None) -> str:
    """A table with every cell escaped; ``stack``: on a phone each row becomes a block whose
    cells are labelled with their column's heading (``data-label``). Text cells are
    left-aligned, numbers right-aligned; ``row_classes`` (one per row) style rows."""
    esc = html.escape
    classes = " ".join(c for c in (css_class, "stack" if stack else "") if c)
    out = [f'<table class="{classes}">' if classes else "<table>", "<thead><tr>"]
    out += [f"<th>{esc(str(c))}</th>" for c in frame.columns]
    out.append("</tr></thead><tbody>")
    for i, row in enumerate(frame.itertuples(index=False)):
        cls = row_classes[i] if row_classes is not None else ""
        out.append(f'<tr class="{esc(cls)}">' if cls else "<tr>")
        for name, value in zip(frame.columns, row, strict=True):
            text = _cell(value)
            numeric = isinstance(value, int | float) and not isinstance(value, bool)
            align = "" if numeric else ' class="text"'
            out.append(f'<td data-label="{esc(str(name))}"{align}>{esc(text)}</td>')
        out.append("</tr>")
    out.append("</tbody></table>")
    return "".join(out)


def _table_html(frame: pd.DataFrame) -> str:
    return '<div class="scroll">' + table_html(frame) + "</div>"


def render_index(title: str, figures: Sequence[tuple[str, str]],
                 tables: Mapping[str, pd.DataFrame], advisories: Sequence[str],
                 captions: Mapping[str, str] | None = None, intro: str | None = None, *,
                 lead_html: str | None = None,
                 details: Mapping[str, pd.DataFrame] | None = None,
                 links: Sequence[str] = ()) -> str:
    """The text of index.html: title, ``lead_html`` (a verdict: HTML built by the caller
    with every value escaped), ``intro``, advisories, tables, then every figure (``(name,
    file)`` pairs) with its caption, then the ``details`` tables folded under "Details"
    with ``links`` to the files beside the page. All text is HTML-escaped."""
    esc = html.escape
    captions = captions or {}
    parts = ["<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
             VIEWPORT, f"<title>{esc(title)}</title>", f"<style>{_STYLE}</style>", "</head>",
             "<body>", f"<h1>{esc(title)}</h1>"]
    if lead_html:
        parts.append(lead_html)
    if intro:
        parts.append(f'<p class="small">{esc(intro)}</p>')
    if advisories:
        parts.append('<div class="advisories"><h2>Advisories</h2><ul>')
        parts += [f"<li>{esc(a)}</li>" for a in advisories]
        parts.append("</ul></div>")
    for name, frame in tables.items():
        parts.append(f"<h2>{esc(name)}</h2>")
        parts.append(_table_html(frame))
    if figures:
        parts.append("<h2>Figures</h2>")
        parts.append('<p class="small phone">Wide figures scroll sideways; tap one to open it '
                     "at full size.</p>")
    for name, file in figures:
        parts.append(f'<figure id="{esc(name)}"><div class="figscroll"><a href="{esc(file)}">'
                     f'<img src="{esc(file)}" alt="{esc(captions.get(name, name))}"></a></div>')
        parts.append(f"<figcaption>{esc(captions.get(name, name))}</figcaption></figure>")
    if details or links:
        parts.append('<details id="details"><summary>Details</summary>')
        for name, frame in (details or {}).items():
            parts.append(f"<h3>{esc(name)}</h3>")
            parts.append(_table_html(frame))
        if links:
            parts.append("<p>Files: " + ", ".join(f'<a href="{esc(f)}">{esc(f)}</a>'
                                                  for f in links) + "</p>")
        parts.append("</details>")
    parts += ["</body>", "</html>", ""]
    return "\n".join(parts)


def write_report(out_dir: str | Path, figures: Mapping[str, Figure | Callable[[], Figure]],
                 tables: Mapping[str, pd.DataFrame] | None = None,
                 advisories: Iterable[str] = (), title: str = "trebuchet report", *,
                 captions: Mapping[str, str] | None = None, intro: str | None = None,
                 csv_tables: Iterable[str] = (),
                 progress: Callable[[str], None] | None = None,
                 lead_html: str | None = None,
                 details: Mapping[str, pd.DataFrame] | None = None,
                 files: Mapping[str, pd.DataFrame] | None = None,
                 inputs: Iterable[str | Path | None] = ()) -> Path:
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
    lead_html : str, optional
        HTML put first under the title (the compare report's verdict); the caller escapes
        every value in it.
    details : {heading: DataFrame}, optional
        Tables folded under "Details" after the figures.
    files : {file name: DataFrame}, optional
        Written as CSV beside the page (``metrics.csv``) without being shown, linked from
        "Details" as the ``csv_tables`` are.
    inputs : paths, optional
        The files the report was made from: refused as ``out_dir`` or inside it
        (:func:`trebuchet.core.output.atomic_dir`).

    Returns
    -------
    The report directory's path.
    """
    out_dir = Path(out_dir)
    tables = dict(tables or {})
    advisories = [str(a) for a in advisories]
    csv_tables = list(csv_tables)
    files = dict(files or {})
    for name in files:
        _check_name(name.removesuffix(".csv"), "file")
    for name in figures:
        _check_name(name, "figure")
    for name in csv_tables:
        _check_name(name, "table")
        if name not in tables:
            raise ValueError(f"csv_tables names {name!r}, which is not among the tables")
    with atomic_dir(out_dir, inputs=inputs) as tmp:
        pngs = []
        for name, item in figures.items():
            if progress is not None:
                progress(f"drawing {name}.png")
            fig = item() if callable(item) else item
            fig.savefig(tmp / f"{name}.png", dpi=FIGURE_DPI, format="png")
            pngs.append((name, f"{name}.png"))
        for name in csv_tables:
            tables[name].to_csv(tmp / f"{name}.csv", index=False)
        for name, frame in files.items():
            frame.to_csv(tmp / name, index=False)
        links = [f"{name}.csv" for name in csv_tables] + list(files)
        (tmp / "index.html").write_text(
            render_index(title, pngs, tables, advisories, captions, intro,
                         lead_html=lead_html, details=details, links=links),
            encoding="utf-8")
    return out_dir
