"""Write the figures of the README and the docs to docs/figures/*.png.

Run from anywhere: ``.venv/bin/python docs/make_figures.py``. The engine is
data_samples/horsdal_large.toml (Table 1 of the paper); the figures are those of
:mod:`trebuchet.report.figures`, predicted curves only. Then ``report_first_screen.png``
(docs/report.md): the first screen, 1280 x 800, of the demo's compare report (``make demo``:
the shipped sample log against the paper's scene), taken by headless Chromium (Debian's
``chromium``, which ``make install-test`` installs as root); without it that one is left as
it is, and the script says so.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

from trebuchet.core.output import atomic_path
from trebuchet.model.scene import Scene
from trebuchet.model.simulate import simulate
from trebuchet.report.figures import all_figures

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "data_samples" / "horsdal_large.toml"
OUT = ROOT / "docs" / "figures"
DPI = 100
DEMO_LOG = ROOT / "data_samples" / "horsdal_240fps.csv"  # the Makefile's DEMO_LOG
FIRST_SCREEN = (1280, 800)  # px: a laptop's first screen


def first_screen(target: Path) -> bool:
    """Screenshot the first screen of the demo's compare report to ``target``; False (and
    nothing written) without chromium."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        print("make_figures: no chromium: report_first_screen.png left as it is",
              file=sys.stderr)
        return False
    from trebuchet.report.compare_cli import compare_report

    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report, _ = compare_report(DEMO_LOG, SCENE, Path(tmp) / "report")
        shot = Path(tmp) / "first_screen.png"  # chromium takes the image type from the name
        subprocess.run([chromium, "--headless", "--no-sandbox", "--disable-gpu",
                        "--hide-scrollbars", f"--user-data-dir={Path(tmp) / 'profile'}",
                        f"--window-size={FIRST_SCREEN[0]},{FIRST_SCREEN[1]}",
                        f"--screenshot={shot}", (report / "index.html").as_uri()],
                       check=True, capture_output=True, timeout=300)
        image = shot.read_bytes() if shot.is_file() else b""
        if not image.startswith(b"\x89PNG"):
            raise RuntimeError(f"chromium wrote no screenshot of {report / 'index.html'}")
        with atomic_path(target) as tmp_target:
            tmp_target.write_bytes(image)
    return True


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
    target = OUT / "report_first_screen.png"
    if first_screen(target):
        print(target.relative_to(ROOT))
    return 0


if __name__ == "__main__":
    sys.exit(main())
