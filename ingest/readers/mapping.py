"""Which column of a log is which angle, and which tracked point is which part of the engine.

A format lists what it found as :class:`Candidate` objects (a column, a Tracker track, a
Kinovea or DeepLabCut point). The user's ``columns=`` or ``points=`` mapping picks
candidates by any of their names; targets the user did not map fall back to candidates
named after the target itself (``theta``, ``θ``, ``pivot``, ...).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from trebuchet.core.errors import Option, TrebuchetInputError

ANGLES = ("theta", "psi", "phi")
ROLES = ("pivot", "spigot", "hinge", "counterweight", "projectile")

#: Names that mean an angle without any mapping (compared case-insensitively).
ANGLE_NAMES: dict[str, str] = {
    "theta": "theta",
    "θ": "theta",
    "psi": "psi",
    "ψ": "psi",
    "phi": "phi",
    "φ": "phi",
    "ϕ": "phi",
}


@dataclass(frozen=True)
class Candidate:
    """Something in the file that can be mapped: shown as ``label``, matched by ``aliases``."""

    label: str
    aliases: frozenset[str]
    default: str | None = None
    data: Any = field(default=None, compare=False, hash=False)


def angle_default(name: str) -> str | None:
    """The angle a bare column or track name stands for (``"θ"`` -> ``"theta"``), if any."""
    return ANGLE_NAMES.get(name.strip().lower())


def role_default(name: str) -> str | None:
    """The engine part a bare point name stands for (``"Pivot"`` -> ``"pivot"``), if any."""
    key = name.strip().lower()
    return key if key in ROLES else None


def check_mapping(
    mapping: Mapping[str, str] | None, targets: tuple[str, ...], arg: str
) -> dict[str, str]:
    """Validate a user's ``columns=``/``points=`` mapping; return it as a plain dict."""
    if mapping is None:
        return {}
    if not isinstance(mapping, Mapping):
        raise TrebuchetInputError(f"{arg}= must be a mapping, got {type(mapping).__name__}")
    out: dict[str, str] = {}
    for key, value in mapping.items():
        if arg == "columns":
            name, target = key, value
        else:
            target, name = key, value
        if not isinstance(name, str) or not isinstance(target, str):
            raise TrebuchetInputError(f"{arg}= entry {key!r}: {value!r} must be text")
        if target not in targets:
            raise TrebuchetInputError(
                f"{arg}= entry {key!r}: {target!r} is not one of {', '.join(targets)}"
            )
        out[name] = target
    return out


def resolve(
    candidates: list[Candidate],
    mapping: dict[str, str],
    targets: tuple[str, ...],
    arg: str,
    what: str,
) -> dict[str, Candidate]:
    """Assign candidates to targets from ``mapping`` (name in file -> target) and defaults.

    Returns target -> candidate for every target that could be assigned (missing targets
    are for the caller to judge). A name matching nothing or several candidates, two
    names for one target, or several default candidates for one target is a
    :class:`TrebuchetInputError` that lists what the file holds.
    """
    found = ", ".join(repr(c.label) for c in candidates) or "none"
    chosen: dict[str, Candidate] = {}
    by_name: dict[str, str] = {}
    for name, target in mapping.items():
        matches = [c for c in candidates if name in c.aliases]
        if not matches:
            low = name.strip().lower()
            matches = [c for c in candidates if low in {a.lower() for a in c.aliases}]
        if not matches and not candidates and what == "column":
            raise TrebuchetInputError(
                f"no column named {name!r}: the file holds point positions, not "
                "angle columns; map its points with points= (--point pivot=NAME ...)")
        if not matches:
            raise TrebuchetInputError(f"no {what} named {name!r} ({what}s found: {found})")
        if len(matches) > 1:
            raise TrebuchetInputError(
                f"{arg}= name {name!r} is ambiguous: it matches "
                f"{', '.join(repr(c.label) for c in matches)}; use the full name"
            )
        if target in chosen:
            raise TrebuchetInputError(
                f"{arg}= is ambiguous: both {by_name[target]!r} and {name!r} are "
                f"mapped to {target}"
            )
        chosen[target] = matches[0]
        by_name[target] = name
    used = {c.label for c in chosen.values()}
    for target in targets:
        if target in chosen:
            continue
        defaults = [c for c in candidates if c.default == target and c.label not in used]
        if len(defaults) > 1:
            raise TrebuchetInputError(
                f"ambiguous {what}s for {target}: "
                f"{', '.join(repr(c.label) for c in defaults)}; say which with "
                f"{_example(arg, defaults[0].label, target)}"
            )
        if defaults:
            chosen[target] = defaults[0]
    return chosen


def _example(arg: str, name: str, target: str) -> Option:
    """An example of the mapping argument, for messages (``columns={name: target}`` or
    ``points={target: name}``, in the words of the interface called)."""
    if arg == "columns":
        return Option.column(name, target)
    return Option.point(target, name)


def missing_angle_error(
    angle: str, candidates: list[Candidate], what: str = "column"
) -> TrebuchetInputError:
    """The error for an angle without a column: lists what the file has, suggests ``columns=``."""
    found = ", ".join(repr(c.label) for c in candidates) or "none"
    return TrebuchetInputError(
        f"no {what} for the angle {angle} ({what}s found: {found}); name it with "
        f"{Option.column('<' + what + ' in the file>', angle)}"
    )
