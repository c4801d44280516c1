"""Run the benchmarks: ``python -m bench`` runs every module of this folder that defines
``run(out_dir)``; ``python -m bench model_speed smooth_accuracy`` runs those only.

Each ``run(out_dir)`` returns a DataFrame (its ``attrs["notes"]``, a list of lines, if any, are
printed above the table). The table is written to ``bench/results/NAME.md`` (Markdown) and,
unless the module wrote it itself, ``bench/results/NAME.csv``.
"""

from __future__ import annotations

import argparse
import importlib
import math
import sys
import time
from pathlib import Path

import pandas as pd

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"


def discover() -> list[str]:
    """Benchmark modules: every ``bench/*.py`` not starting with an underscore."""
    return sorted(p.stem for p in HERE.glob("*.py") if not p.stem.startswith("_"))


def _cell(v: object) -> str:
    if isinstance(v, float):
        if math.isnan(v):
            return ""
        return f"{v:.4g}" if abs(v) < 1e5 else f"{v:.3e}"
    return str(v).replace("|", "\\|")


def markdown(table: pd.DataFrame, title: str, notes: list[str]) -> str:
    """A Markdown block (docs/update_docs.py pastes it into docs/benchmarks.md as it is):
    the title as a line, the notes as a list, the table."""
    cols = [str(c) for c in table.columns]
    lines = [title, ""]
    lines += [f"- {n}" for n in notes]
    lines += ["", "| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for row in table.itertuples(index=False):
        lines.append("| " + " | ".join(_cell(v) for v in row) + " |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench", description=__doc__.split("\n")[0])
    ap.add_argument("names", nargs="*", help=f"benchmarks to run (default all: "
                    f"{', '.join(discover())})")
    ap.add_argument("--out", type=Path, default=RESULTS, help="results folder")
    args = ap.parse_args(argv)
    names = args.names or discover()
    unknown = [n for n in names if n not in discover()]
    if unknown:
        ap.error(f"no benchmark {', '.join(unknown)}; there are {', '.join(discover())}")
    args.out.mkdir(parents=True, exist_ok=True)
    for name in names:
        print(f"bench {name} ...", flush=True)
        t0 = time.perf_counter()
        module = importlib.import_module(f"bench.{name}")
        csv = args.out / f"{name}.csv"
        before = csv.stat().st_mtime_ns if csv.exists() else None
        table = module.run(args.out)
        if table is None:
            print(f"bench {name}: done in {time.perf_counter() - t0:.1f} s (no table)")
            continue
        notes = list(table.attrs.get("notes", []))
        doc = (module.__doc__ or name).strip().split("\n")[0]
        (args.out / f"{name}.md").write_text(markdown(table, doc, notes), encoding="utf-8")
        if not csv.exists() or csv.stat().st_mtime_ns == before:
            table.to_csv(csv, index=False)
        for n in notes:
            print(f"  {n}")
        with pd.option_context("display.width", 200, "display.max_columns", 20):
            print(table.to_string(index=False))
        md = (args.out / f"{name}.md").resolve()
        shown = md.relative_to(Path.cwd()) if md.is_relative_to(Path.cwd()) else md
        print(f"bench {name}: done in {time.perf_counter() - t0:.1f} s -> {shown}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
