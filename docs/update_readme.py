"""Fill the README's measured tables from their sources.

Each table in README.md sits between ``<!-- table:NAME -->`` and ``<!-- /table:NAME -->``.
``paper`` is computed now (``trebuchet paper --markdown``); every other NAME is the file
``bench/results/NAME.md`` written by ``make bench``. A missing source leaves its block as it is
and says so. Run: ``.venv/bin/python docs/update_readme.py`` (``make bench`` does).
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BLOCK = re.compile(r"(<!-- table:(?P<name>[\w-]+) -->\n)(?P<body>.*?)(<!-- /table:(?P=name) -->)",
                   re.S)


def paper_table() -> str:
    from trebuchet.model.cli import format_paper_table
    from trebuchet.model.paper import paper_comparison

    return format_paper_table(paper_comparison(), markdown=True) + "\n"


def source(name: str) -> str | None:
    if name == "paper":
        return paper_table()
    path = ROOT / "bench" / "results" / f"{name}.md"
    return path.read_text() if path.exists() else None


def main() -> int:
    readme = ROOT / "README.md"
    text = readme.read_text()
    missing = []

    def fill(match: re.Match) -> str:
        body = source(match["name"])
        if body is None:
            missing.append(match["name"])
            return match.group(0)
        return match.group(1) + body + match.group(4)

    readme.write_text(BLOCK.sub(fill, text))
    for name in missing:
        print(f"update_readme: no bench/results/{name}.md yet; its table is unchanged",
              file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
