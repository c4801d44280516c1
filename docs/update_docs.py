"""Fill the measured tables of the README and the docs pages from their sources.

Each table sits between ``<!-- table:NAME -->`` and ``<!-- /table:NAME -->``, in README.md or
in any page ``docs/*.md``. ``paper`` is computed now (``trebuchet paper --markdown``); every
other NAME is the file ``bench/results/NAME.md`` written by ``make bench``. A missing source
leaves its block as it is and says so. Run: ``.venv/bin/python docs/update_docs.py``
(``make bench`` does).
"""

from __future__ import annotations

import re
import sys
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BLOCK = re.compile(r"(<!-- table:(?P<name>[\w-]+) -->\n)(?P<body>.*?)(<!-- /table:(?P=name) -->)",
                   re.S)


def pages() -> list[Path]:
    """Every file whose blocks are filled: the README and the docs pages."""
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


@cache
def paper_table() -> str:
    from trebuchet.model.cli import format_paper_table
    from trebuchet.model.paper import paper_comparison

    return format_paper_table(paper_comparison(), markdown=True) + "\n"


def source(name: str) -> str | None:
    if name == "paper":
        return paper_table()
    path = ROOT / "bench" / "results" / f"{name}.md"
    return path.read_text() if path.exists() else None


def fill_page(page: Path, missing: set[str]) -> bool:
    """Fill every block of ``page``; True if the page changed."""
    text = page.read_text()

    def fill(match: re.Match) -> str:
        body = source(match["name"])
        if body is None:
            missing.add(match["name"])
            return match.group(0)
        return match.group(1) + body + match.group(4)

    new = BLOCK.sub(fill, text)
    if new != text:
        page.write_text(new)
    return new != text


def main() -> int:
    missing: set[str] = set()
    for page in pages():
        if fill_page(page, missing):
            print(f"update_docs: filled {page.relative_to(ROOT)}")
    for name in sorted(missing):
        print(f"update_docs: no bench/results/{name}.md yet; its table is unchanged",
              file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
