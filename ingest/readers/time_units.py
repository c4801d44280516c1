"""The unit of a time column whose header says none (Kinovea's ``Time``, a generic ``t``).

Kinovea writes its time in the unit of the user's time-code preference (s, ms, µs or frame
numbers, see docs/formats.md) under the same header ``"Time"``; a plain CSV may hold ms
under ``time``. :func:`decide_time_unit` reads such a column in the unit stated by the
caller (``time_unit=``) or decides it from evidence that can fail, the frame pattern:

* each unit turns the median step into a frame rate; a unit is possible when that rate is
  one a film of a shot has (:data:`FRAME_RATE_RANGE`) and the log lasts at least
  :data:`MIN_SPAN` s and at most :data:`MAX_SPAN` s;
* frame numbers are whole and step by 1 (then ``fps`` gives the time);
* with ``fps`` given, a unit must also give that rate (within 5 %), and frame numbers
  must step by 1;
* exactly one possible unit is taken, with a sentence saying why; none, or several, is an
  error naming the likely unit and the option that states it.
"""

from __future__ import annotations

import numpy as np

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.readers.timebase import FRAME_RATE_RANGE
from trebuchet.ingest.readers.units import TIME_UNITS

#: Units a time column can be stated in (``time_unit=``), with their factor to s; frames
#: need ``fps``.
TIME_UNIT_CHOICES: dict[str, float | None] = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "frames": None}
#: Shortest and longest span (s) of a log of one shot.
MIN_SPAN = 0.05
MAX_SPAN = 3600.0
#: Largest relative difference between a unit's frame rate and a given ``fps``.
FPS_TOLERANCE = 0.05

_SHOWN = {"s": "s", "ms": "ms", "us": "µs", "frames": "frames"}


def check_time_unit(time_unit: str | None) -> str | None:
    """``time_unit`` if it is one of :data:`TIME_UNIT_CHOICES` (or None), else an error."""
    if time_unit is None:
        return None
    if time_unit not in TIME_UNIT_CHOICES:
        raise TrebuchetInputError(
            f"time_unit={time_unit!r} must be one of {', '.join(map(repr, TIME_UNIT_CHOICES))}")
    return time_unit


def decide_time_unit(raw: np.ndarray, rows: np.ndarray, label: str, fps: float | None,
                     time_unit: str | None, tool: str
                     ) -> tuple[np.ndarray, np.ndarray | None, str, str]:
    """Read the unit-less time column ``raw`` (values as written, sorted) in s.

    Returns (t in s, frame numbers or None, the unit, the decision sentence). ``label`` is
    the column's header and ``tool`` the format's name (for messages).
    """
    finite = raw[np.isfinite(raw)]
    if time_unit is not None:
        unit, how = time_unit, f"time_unit={time_unit!r}"
        if unit == "frames":
            _check_frames(raw, rows, label, fps, how)
    else:
        unit, how = _infer(finite, label, fps, tool)
    if unit == "frames":
        frame = np.round(raw).astype(np.int64)
        return frame / fps, frame, unit, f"time unit of '{label}': frames ({how})"
    factor = TIME_UNIT_CHOICES[unit]
    return raw * factor, None, unit, f"time unit of '{label}': {_SHOWN[unit]} ({how})"


def _check_frames(raw: np.ndarray, rows: np.ndarray, label: str, fps: float | None,
                  how: str) -> None:
    if fps is None:
        raise TrebuchetInputError.at(
            f"column '{label}'", f"holds frame numbers ({how}); pass the frame rate, "
            "e.g. fps=240")
    frac = np.abs(raw - np.round(raw))
    bad = ~(frac <= 1e-6)
    if bad.any():
        k = int(np.argmax(bad))
        raise TrebuchetInputError.at(f"row {rows[k]}, column '{label}'",
                                     f"frame number {raw[k]:g} is not whole ({how})")


def _rate(period: float) -> str:
    return f"{1.0 / period:.4g} fps" if period > 0 else "no frame rate"


def _infer(t: np.ndarray, label: str, fps: float | None, tool: str) -> tuple[str, str]:
    """(unit, how it was inferred), or an error naming the likely unit."""
    steps = np.diff(t)
    steps = steps[steps > 0]
    if t.size < 3 or not steps.size:
        raise TrebuchetInputError.at(
            f"column '{label}'", "too few distinct times to tell their unit; say it with "
            "time_unit= ('s', 'ms', 'us' or 'frames')")
    median = float(np.median(steps))
    span = float(t[-1] - t[0])
    whole = bool((np.abs(t - np.round(t)) <= 1e-6).all())
    low, high = FRAME_RATE_RANGE
    rates = {u: 1.0 / (median * f) for u, f in TIME_UNIT_CHOICES.items() if f is not None}
    possible = [u for u, r in rates.items()
                if low <= r <= high and MIN_SPAN <= span * TIME_UNIT_CHOICES[u] <= MAX_SPAN]
    frames = whole and median == 1.0
    seen = ", ".join(f"{_SHOWN[u]} {rates[u]:.4g} fps" for u in rates)
    step = f"steps of {median:.6g}"
    if fps is not None:
        near = steps[np.abs(steps / median - 1.0) <= 0.5]
        mean = float(np.mean(near))
        match = [u for u in possible
                 if min(abs(rates[u] / fps - 1.0),
                        abs(1.0 / (mean * TIME_UNIT_CHOICES[u]) / fps - 1.0)) <= FPS_TOLERANCE]
        if frames:
            match.append("frames")
        if len(match) == 1:
            u = match[0]
            if u == "frames":
                return u, (f"inferred: whole numbers in {step} are frame numbers at "
                           f"fps={fps:g}; as {seen.replace(', ', ', as ')}")
            mean_rate = 1.0 / (mean * TIME_UNIT_CHOICES[u])
            rate = min(rates[u], mean_rate, key=lambda r: abs(r / fps - 1.0))
            others = ", ".join(f"{_SHOWN[v]} {rates[v]:.4g} fps" for v in rates if v != u)
            return u, (f"inferred: {step} in {_SHOWN[u]} give {rate:.4g} fps, the given "
                       f"fps={fps:g}; as {others.replace(', ', ', as ')}")
        if not match:
            raise TrebuchetInputError.at(
                f"column '{label}'", f"its {step} fit no time unit at fps={fps:g} (as {seen}"
                f"{', frame numbers' if whole else ''}); correct fps or state the unit with "
                "time_unit= ('s', 'ms', 'us' or 'frames')")
        raise TrebuchetInputError.at(
            f"column '{label}'", f"its {step} are the frame period at fps={fps:g} in "
            f"{' and in '.join(_SHOWN[u] for u in match)}; say which with time_unit="
            f"{match[0]!r}")
    if frames and possible:
        others = " or ".join(f"{_SHOWN[u]} at {rates[u]:.4g} fps" for u in possible)
        raise TrebuchetInputError.at(
            f"column '{label}'", f"whole numbers in {step}: frame numbers (then pass the frame "
            f"rate, e.g. fps=240) or {others} (then say time_unit={possible[0]!r})")
    if frames:
        raise TrebuchetInputError.at(
            f"column '{label}'", "holds frame numbers (whole, in steps of 1); pass the frame "
            "rate, e.g. fps=240")
    if len(possible) == 1:
        u = possible[0]
        others = ", ".join(f"{_SHOWN[v]} {rates[v]:.4g} fps" for v in rates if v != u)
        return u, (f"inferred: {step} in {_SHOWN[u]} give "
                   f"{_rate(median * TIME_UNIT_CHOICES[u])}, a film's rate; as "
                   f"{others.replace(', ', ', as ')}, no film's")
    if not possible:
        likely = min(rates, key=lambda u: abs(np.log10(rates[u] / 240.0)))
        raise TrebuchetInputError.at(
            f"column '{label}'", f"its {step} are no film's frame rate in any unit (as "
            f"{seen}) over a log of {span:.6g}; if the unit is {_SHOWN[likely]}, say "
            f"time_unit={likely!r}")
    likely = min(possible, key=lambda u: abs(np.log10(rates[u] / 240.0)))
    raise TrebuchetInputError.at(
        f"column '{label}'", f"its {step} could be "
        f"{' or '.join(f'{_SHOWN[u]} ({rates[u]:.4g} fps)' for u in possible)}; the {tool} "
        f"file does not say which: state it with time_unit= (likely {likely!r}) or pass fps=")


def stated_time_unit(label: str, unit: str, time_unit: str | None) -> str:
    """The decision sentence for a time unit written in the header; an error when
    ``time_unit=`` says another."""
    if time_unit is not None:
        factor = TIME_UNIT_CHOICES[time_unit]
        if factor is None or TIME_UNITS.get(unit.strip().lower()) != factor:
            raise TrebuchetInputError.at(
                f"column '{label}'", f"its header says {unit!r}, time_unit={time_unit!r} says "
                "otherwise; leave time_unit out or correct the header")
    return f"time unit of '{label}': {unit} (stated in the header)"
