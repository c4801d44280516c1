"""What a design search is asked: the keys it may vary and their bounds, the figure it
maximises or minimises, and the limits every design must meet.

Keys are scene keys as in a sweep (``section.key``, units of the scene file; any numeric key,
the release rule's time or climb angle included); figures are the sweep table's columns
(:data:`~trebuchet.model.shot_summary.FIGURES`: ``range``, ``F_R_peak``, ..., ``cw_clearance``),
in SI units. On the command line::

    --vary engine.L4=3:8          a key and its bounds, LO:HI (LO below HI)
    --limit F_R_peak<=468905      a figure, <= or >=, and a value in SI units
    --maximize range | --minimize F_R_peak

Each parse or check refuses what it cannot use in one line that names it
(:class:`~trebuchet.core.errors.TrebuchetInputError`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model.scene import Scene
from trebuchet.model.shot_summary import FIGURES
from trebuchet.model.sweep import check_grid

__all__ = ["Variable", "Limit", "Problem", "parse_vary", "parse_limit", "check_figure",
           "make_problem", "WORD_KEYS"]

#: Scene keys whose values are words: not for an optimiser.
WORD_KEYS = ("engine.counterweight", "start.projectile", "flight.model")
_ANGLE_RAD = {"theta": "theta_deg", "psi": "psi_deg", "phi": "phi_deg",
              "velocity_angle": "velocity_angle_deg"}


@dataclass(frozen=True)
class Variable:
    """A scene key the search may set, between ``lo`` and ``hi`` (units of the scene file)."""

    key: str
    lo: float
    hi: float


@dataclass(frozen=True)
class Limit:
    """``figure <= value`` or ``figure >= value`` (``op``), SI units."""

    figure: str
    op: str
    value: float

    @property
    def text(self) -> str:
        return f"{self.figure} {self.op} {self.value:.6g}"

    def margin(self, value: float) -> float:
        """How far ``value`` lies inside the limit, in the figure's unit (negative: broken;
        NaN for a NaN value)."""
        return self.value - value if self.op == "<=" else value - self.value

    @property
    def scale(self) -> float:
        """The unit of a relative margin: the limit's value (1 where it is 0)."""
        return abs(self.value) or 1.0


def check_figure(name: str, where: str) -> str:
    """``name`` if it is a figure of :data:`FIGURES`, else a refusal naming ``where``."""
    if name not in FIGURES:
        raise TrebuchetInputError(f"{where}: {name!r} is not a figure (figures: "
                                  + ", ".join(FIGURES) + ")")
    return name


_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


def parse_limit(text: str | Limit) -> Limit:
    """A :class:`Limit` from ``FIGURE<=VALUE`` or ``FIGURE>=VALUE`` (spaces allowed)."""
    if isinstance(text, Limit):
        return Limit(check_figure(text.figure, f"limit {text.text!r}"), text.op,
                     _finite(text.value, f"limit {text.text!r}"))
    m = re.fullmatch(rf"\s*([A-Za-z_]\w*)\s*(<=|>=)\s*({_NUMBER})\s*", str(text))
    if not m:
        raise TrebuchetInputError(f"--limit {text!r}: expected FIGURE<=VALUE or FIGURE>=VALUE "
                                  "in SI units, e.g. F_R_peak<=468905 or cw_clearance>=1.0")
    figure = check_figure(m.group(1), f"--limit {text!r}")
    return Limit(figure, m.group(2), _finite(float(m.group(3)), f"--limit {text!r}"))


def _finite(value: Any, where: str) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise TrebuchetInputError(f"{where}: {value!r} is not a number") from None
    if not math.isfinite(value):
        raise TrebuchetInputError(f"{where}: {value} must be finite")
    return value


def parse_vary(text: str) -> tuple[str, tuple[float, float]]:
    """``KEY=LO:HI`` (a ``--vary`` argument) as ``(key, (lo, hi))``."""
    key, sep, bounds = str(text).partition("=")
    parts = bounds.split(":")
    if not sep or len(parts) != 2:
        raise TrebuchetInputError(f"--vary {text!r}: expected KEY=LO:HI, e.g. engine.L4=3:8")
    key = key.strip()
    lo, hi = (_finite(p.strip() or "?", f"--vary {key}") for p in parts)
    return key, (lo, hi)


def _variable(key: str, bounds: Any) -> Variable:
    where = f"--vary {key}"
    if isinstance(bounds, str):
        _, (lo, hi) = parse_vary(f"{key}={bounds}")
    else:
        try:
            lo, hi = bounds
        except (TypeError, ValueError):
            raise TrebuchetInputError(f"{where}: give the bounds as (LO, HI) or 'LO:HI'"
                                      ) from None
        lo, hi = _finite(lo, where), _finite(hi, where)
    if key in WORD_KEYS:
        raise TrebuchetInputError(f"{where}: takes a word, not a number; an optimiser varies "
                                  "numbers (sweep the words with trebuchet sweep --grid)")
    if not lo < hi:
        raise TrebuchetInputError(f"{where}={lo:g}:{hi:g}: the lower bound must lie below the "
                                  f"upper ({'equal' if lo == hi else 'the wrong way round'})")
    return Variable(key, lo, hi)


@dataclass(frozen=True)
class Problem:
    """A design search: ``variables`` of ``base``, the ``objective`` figure to maximise
    (``sense`` +1) or minimise (−1), and the ``limits``."""

    base: Scene
    variables: tuple[Variable, ...]
    objective: str
    sense: float
    limits: tuple[Limit, ...]

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(v.key for v in self.variables)

    @property
    def lo(self) -> np.ndarray:
        return np.array([v.lo for v in self.variables])

    @property
    def hi(self) -> np.ndarray:
        return np.array([v.hi for v in self.variables])

    def params(self, u: np.ndarray) -> dict[str, float]:
        """The scene values of a point ``u`` of the unit cube (0: every lower bound)."""
        x = self.lo + np.clip(u, 0.0, 1.0) * (self.hi - self.lo)
        return {k: float(v) for k, v in zip(self.keys, x, strict=True)}

    def unit(self, params: Mapping[str, float]) -> np.ndarray:
        x = np.array([params[k] for k in self.keys], dtype=float)
        return (x - self.lo) / (self.hi - self.lo)

    def start_params(self) -> dict[str, float]:
        """The base scene's own values of the varied keys (NaN where it has none: a climb
        angle when the base releases by time)."""
        data = self.base.to_dict()
        out = {}
        for key in self.keys:
            section, _, name = key.partition(".")
            sec = data.get(section, {})
            if name in sec:
                out[key] = float(sec[name])
            elif name in _ANGLE_RAD and _ANGLE_RAD[name] in sec:
                out[key] = math.radians(float(sec[_ANGLE_RAD[name]]))
            else:
                out[key] = math.nan
        return out


def make_problem(base: Scene, vary: Mapping[str, Any], maximize: str | None = None,
                 minimize: str | None = None, limits: Sequence[str | Limit] = ()) -> Problem:
    """Check everything a search is given and return its :class:`Problem`."""
    if not vary:
        raise TrebuchetInputError("--vary: name at least one scene key and its bounds, e.g. "
                                  "--vary engine.L4=3:8")
    try:  # the keys: scene keys, one release rule, each angle once
        check_grid({k: [1.0] for k in vary})
    except TrebuchetInputError as exc:
        raise TrebuchetInputError(str(exc).replace("grid keys", "--vary keys")
                                  .replace("grid key", "--vary")
                                  .replace("sweep one of them", "vary one of them")) from None
    variables = tuple(_variable(str(k), b) for k, b in vary.items())
    if (maximize is None) == (minimize is None):
        raise TrebuchetInputError("give exactly one of --maximize FIGURE and --minimize FIGURE")
    objective = check_figure(maximize or minimize, "--maximize" if maximize else "--minimize")
    return Problem(base, variables, objective, 1.0 if maximize else -1.0,
                   tuple(parse_limit(x) for x in limits))
