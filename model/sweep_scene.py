"""A design's scene: the base scene with a design's values put in, under the scene file's rules.

:func:`design_scene` gives what ``Scene.from_dict`` gives for the base scene's dict
(``Scene.to_dict``) with the design's values put in. Quantities that the base scene leaves to
their defaults follow the swept ones unless the design names them: the moment of inertia
``I`` (uniform beam) follows ``m_b``, ``L1`` and ``L2``; the pivot height ``H`` (spigot on the
ground) follows ``L1`` and the start angle; the start sling angle ``phi`` keeps the projectile
in the trough. Setting one release rule (``release.time`` or ``release.velocity_angle_deg``)
replaces the base scene's rule.

Where a design changes numbers only, the scene is built without the dict
(:func:`~trebuchet.model.scene.with_numbers`: the same rules, the same scene, ~4 x faster);
any design it does not take, and every refusal, goes through ``Scene.from_dict``, which words
the refusal as the scene file's reader does.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model.kinematics import trough_sling_angle
from trebuchet.model.scene import (
    Engine,
    Scene,
    default_moment_of_inertia,
    spigot_on_ground,
    with_numbers,
)

__all__ = ["design_scene", "RELEASE_KEYS", "ANGLE_PAIRS"]

#: The keys of the release rules (a design sets one at most).
RELEASE_KEYS = ("release.time", "release.velocity_angle_deg", "release.velocity_angle")
#: The angles a scene file gives in rad or in degrees.
ANGLE_PAIRS = {"theta": "theta_deg", "psi": "psi_deg", "phi": "phi_deg",
               "velocity_angle": "velocity_angle_deg"}


def design_scene(base: Scene, params: Mapping[str, float | str],
                 source: str | None = None) -> Scene:
    """The base scene with the design's values put in (see the module doc for the quantities
    that follow them), validated as ``Scene.from_dict`` validates a scene file; raises
    TrebuchetInputError."""
    source = source or base.source
    reads_back, follows_inertia, follows_height, phi_of = _base_facts(base)
    if reads_back:
        numbers: dict[str, Any] = dict(params)
        if follows_inertia and "engine.I" not in params:
            numbers["engine.I"] = None
        if follows_height and "engine.H" not in params:
            numbers["engine.H"] = None
        trough = (base.projectile == "trough" and "start.projectile" not in params
                  and "start.phi" not in params and "start.phi_deg" not in params)
        try:
            return with_numbers(base, numbers, source, phi_of=phi_of if trough else None)
        except (KeyError, TrebuchetInputError):
            pass  # not a design of numbers only, or refused: the file's reader words it
    return _from_dict(base, params, source)


def _base_facts(base: Scene) -> tuple[bool, bool, bool, Any]:
    """Whether ``Scene.from_dict`` reads the scene's own dict back (its numbers pass the scene
    file's rules, so that :func:`with_numbers` may take them as they are), whether its ``I``
    and its ``H`` follow the quantities they are computed from, and the trough's sling angle
    on its branch (:func:`_trough_phi`). The last base asked about is remembered: a sweep
    asks about one."""
    global _last_base
    last = _last_base  # one tuple, read and replaced whole (threads)
    if last[0] is not base:
        try:
            Scene.from_dict(base.to_dict(), source=base.source)
            reads_back = True
        except TrebuchetInputError:
            reads_back = False
        last = (base, (reads_back, _follows_inertia(base.engine), _follows_height(base),
                       _trough_phi(base.start.phi)))
        _last_base = last
    return last[1]


_last_base: tuple[Scene | None, tuple[bool, bool, bool, Any]] = (None, (False,) * 4)


def _follows_inertia(e: Engine) -> bool:
    """The beam's moment of inertia is the uniform beam's (it follows m_b, L1, L2)."""
    return math.isclose(e.I, default_moment_of_inertia(e.m_b, e.L1, e.L2), rel_tol=1e-12)


def _follows_height(base: Scene) -> bool:
    """The pivot stands where the spigot starts on the ground (it follows L1, theta)."""
    e, s = base.engine, base.start
    return math.isclose(s.H, spigot_on_ground(e.L1, s.theta), rel_tol=1e-12,
                        abs_tol=1e-12 * e.L1)


def _trough_phi(near: float) -> Any:
    """``phi_of(theta, L1, L4, H)``: the start sling angle (rad) that lays the projectile in
    the trough, on the branch of the angle ``near`` (rad); None where the numbers allow none
    (the scene's checks then name the problem)."""
    def phi_of(theta: float, L1: float, L4: float, H: float) -> float | None:
        try:
            phi = trough_sling_angle(theta, _Lengths(L1, L4), H, math)
        except (ValueError, TypeError, ZeroDivisionError):
            return None
        return phi + 2.0 * math.pi * round((near - phi) / (2.0 * math.pi))
    return phi_of


class _Lengths:
    """The engine's lengths the trough's constraint takes (m)."""

    def __init__(self, L1: float, L4: float) -> None:
        self.L1, self.L4 = L1, L4


def _from_dict(base: Scene, params: Mapping[str, float | str], source: str) -> Scene:
    """The design's scene through ``Scene.from_dict`` of the base scene's dict with the
    design's values put in: the reader of scene files words every refusal."""
    data = base.to_dict()
    for key, value in params.items():
        section, _, name = key.partition(".")
        sec = data.setdefault(section, {})
        if section == "release" and key in RELEASE_KEYS:
            sec.clear()
        sec.pop(ANGLE_PAIRS.get(name, ""), None)
        sec.pop(next((p for p, d in ANGLE_PAIRS.items() if d == name), ""), None)
        sec[name] = value
    eng = data["engine"]
    _, follows_inertia, follows_height, _ = _base_facts(base)
    if follows_inertia and "engine.I" not in params:
        eng.pop("I")
    if follows_height and "engine.H" not in params:
        eng.pop("H")
    in_trough = params.get("start.projectile", getattr(base, "projectile", "trough")) == "trough"
    if in_trough and not any(k in params for k in ("start.phi", "start.phi_deg")):
        _put_projectile_in_trough(data, base)
    return Scene.from_dict(data, source=source)


def _put_projectile_in_trough(data: dict[str, Any], base: Scene) -> None:
    """Set the start sling angle so the projectile lies in the trough, on the branch of the
    base scene's angle; leave it alone where the design's numbers do not allow it (the
    scene's validation then names the problem)."""
    eng, st = data["engine"], data["start"]
    try:
        theta = (math.radians(st["theta_deg"]) if "theta_deg" in st else float(st["theta"]))
        L1, L4 = float(eng["L1"]), float(eng["L4"])
        H = float(eng["H"]) if "H" in eng else spigot_on_ground(L1, theta)
        replace(base.engine, L1=L1, L4=L4)  # an engine that cannot be is refused here
    except (ValueError, TypeError, KeyError, ZeroDivisionError):
        return
    phi = _trough_phi(base.start.phi)(theta, L1, L4, H)
    if phi is not None:
        st.pop("phi", None)
        st["phi_deg"] = math.degrees(phi)
