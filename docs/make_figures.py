"""Write the README's figures for the paper's engine to docs/figures/*.png.

Run from anywhere: ``.venv/bin/python docs/make_figures.py``. The engine is
data_samples/horsdal_large.toml (Table 1 of the paper); the figures are those of
:mod:`trebuchet.report.figures`, predicted curves only.
"""

from __future__ import annotations

import sys
from pathlib import Path

from trebuchet.model.scene import Scene
from trebuchet.model.simulate import simulate
from trebuchet.output import atomic_path
from trebuchet.report.figures import all_figures

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "data_samples" / "horsdal_large.toml"
OUT = ROOT / "docs" / "figures"
DPI = 100


def main() -> int:
    scene = Scene.from_toml(SCENE)
    run = simulate(scene)
    figures = all_figures(run, None, scene,
                          progress=lambda name: print(f"drawing {name}", file=sys.stderr))
    for name, fig in figures.items():
        target = OUT / f"{name}.png"
        with atomic_path(target) as tmp:
            fig.savefig(tmp, dpi=DPI, format="png")
        print(target.relative_to(ROOT))
    return 0


if __name__ == "__main__":
    sys.exit(main())
