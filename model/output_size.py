"""Bounds of what a simulated shot can mean (docs/columns.md, "How many rows").

Beyond them a run would only fill the memory or never end (an output step of 1e-9 s asked
for 11 GiB, a phase III of ``inf`` never ended), so :func:`check_output_size` refuses it in
one line naming the option (``dt``/``--dt``, ``after_release``/``--after-release``).
:func:`trebuchet.model.simulate.simulate` calls it before the run and again once the shot's
length is known; ``sweep`` before its first design.
"""

from __future__ import annotations

import math

from trebuchet.core.errors import Option, TrebuchetInputError

__all__ = ["check_output_size", "MIN_DT", "MAX_ROWS", "MAX_AFTER_RELEASE"]

MIN_DT = 1e-6  # s: the finest output step, finer than any camera or sensor filming a shot
MAX_ROWS = 1_000_000  # output rows of one run: ~1.1 GB of memory at the peak, ~0.9 GB of CSV
MAX_AFTER_RELEASE = 60.0  # s of phase III: the beam has long swung back by then


def check_output_size(dt: float | None = None, after_release: float | None = None, *,
                      span: float | None = None) -> None:
    """Refuse an output step ``dt`` (s) or a phase III of ``after_release`` (s) beyond
    :data:`MIN_DT`, :data:`MAX_AFTER_RELEASE` and :data:`MAX_ROWS` rows over ``span`` (s
    simulated; before the run, ``after_release`` at least). None: not checked."""
    if after_release is not None and not 0.0 <= after_release <= MAX_AFTER_RELEASE:
        raise TrebuchetInputError(
            f"{Option('after_release', after_release)} s: phase III is simulated for 0 to "
            f"{MAX_AFTER_RELEASE:g} s (the beam has long swung back by then)")
    if dt is None:
        return
    if not (math.isfinite(dt) and dt > 0.0):
        raise TrebuchetInputError(f"dt = {dt:g} s: the output step must be a positive number "
                                  "of seconds")
    if dt < MIN_DT:
        raise TrebuchetInputError(f"{Option('dt', dt)} s: the output step must be at least "
                                  f"{MIN_DT:g} s (finer than any camera or sensor)")
    length = after_release if span is None else span
    if length is not None and length / dt + 1 > MAX_ROWS:
        step = length / (MAX_ROWS - 1)
        unit = 10.0 ** (math.floor(math.log10(step)) - 1)  # rounded up to two digits
        also = f" or a shorter {Option('after_release')}" if span is None else ""
        raise TrebuchetInputError(
            f"{Option('dt', dt)} s: {length / dt + 1:,.0f} output rows over the {length:.4g} s "
            f"simulated, more than the {MAX_ROWS:,} of one run; give a step of at least "
            f"{math.ceil(step / unit) * unit:.2g} s{also}")
