"""Export fixtures: one small file per tool layout, time code, locale and unit, with its truth.

Every file is written at test time (``write_all(folder)``) from the package's own
simulation of the paper's engine (see :mod:`.shot`), in the layout the tool itself
writes; each writer module names the tool's source file it follows. ``write_all`` returns
``{file name: Truth}`` (see :mod:`.truth`). Run ``python -m tests.exports DIR`` to write
them into a folder and look at them.
"""

from __future__ import annotations

from pathlib import Path

from . import anipose, deeplabcut, generic, kinovea, sleap, tracker
from .truth import Truth

WRITERS = (deeplabcut, sleap, anipose, kinovea, tracker, generic)


def write_all(folder: str | Path) -> dict[str, Truth]:
    """Write every fixture into ``folder`` (created); return their truths by file name."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    out: dict[str, Truth] = {}
    for module in WRITERS:
        for truth in module.write(folder):
            out[truth.name] = truth
    return out


def read_export(exports: tuple[Path, dict[str, Truth]], name: str, **kwargs):
    """``trebuchet.read_log`` of the fixture ``name`` with the keywords its truth documents
    (``kwargs`` override them), repair warnings silenced."""
    import warnings

    import trebuchet

    folder, truths = exports
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return trebuchet.read_log(folder / name, **(truths[name].read | kwargs))

