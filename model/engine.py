"""The engine's parts as the simulator sees them: its lengths, masses and bearings, the pose it
starts from, the release rule and the projectile's flight, as frozen dataclasses.

:mod:`trebuchet.model.scene` reads them from a scene file (and names the file and key in every
refusal); here each also refuses what no engine can be where a program builds or
``dataclasses.replace``-s one. The symbols are those of Table 1 of Horsdal, "The swinging
counterweight trebuchet: on internal forces" (*the paper*). Lengths in m, masses in kg,
angles in rad, times in s.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

from trebuchet.core.errors import TrebuchetInputError

__all__ = ["Engine", "Friction", "Start", "Release", "Flight", "default_moment_of_inertia",
           "DEFAULT_SMOOTHING_RATE"]

#: rad/s: the sliding rate over which the friction couple's sign turns, ``tanh(w / rate)``.
DEFAULT_SMOOTHING_RATE = 1e-3


def default_moment_of_inertia(m_b: float, L1: float, L2: float) -> float:
    """Moment of inertia of a uniform beam about the pivot, kg m².

    ``I = m_b (L1² − L1 L2 + L2²) / 3`` (the paper, Section 2; 7704 kg m² for Table 1).
    """
    return m_b * (L1 * L1 - L1 * L2 + L2 * L2) / 3.0


@dataclass(frozen=True)
class Friction:
    """Coulomb friction in the engine's two bearings: the paper's "heat in proportion to load".

    At the beam's shaft (the pivot) a couple of magnitude ``pivot_mu · pivot_radius · |F_R|``
    opposes the beam's turning rate θ̇; at the counterweight's hinge pin a couple of magnitude
    ``hinge_mu · hinge_radius · |F_H|`` opposes the arm's rate relative to the beam, ψ̇ − θ̇.
    ``*_mu`` are Coulomb coefficients (dimensionless), ``*_radius`` the radii of shaft and pin
    (m). The sign of a sliding rate ``w`` (rad/s) is taken as ``tanh(w / smoothing_rate)``.
    """

    pivot_mu: float = 0.0
    pivot_radius: float = 0.0
    hinge_mu: float = 0.0
    hinge_radius: float = 0.0
    smoothing_rate: float = DEFAULT_SMOOTHING_RATE

    def __post_init__(self) -> None:
        for name in ("pivot_mu", "pivot_radius", "hinge_mu", "hinge_radius", "smoothing_rate"):
            value = getattr(self, name)
            if not (isinstance(value, numbers.Real) and math.isfinite(value) and value >= 0.0):
                raise TrebuchetInputError(f"Friction: {name} = {value!r}: must be a finite "
                                          "number, zero or positive")
        if self.smoothing_rate <= 0.0:
            raise TrebuchetInputError(f"Friction: smoothing_rate = {self.smoothing_rate!r}: "
                                      "must be positive")

    @property
    def pivot(self) -> float:
        """``μ_P r_P``, m: the pivot's friction couple per newton of bearing load."""
        return self.pivot_mu * self.pivot_radius

    @property
    def hinge(self) -> float:
        """``μ_H r_H``, m: the hinge's friction couple per newton of hinge force."""
        return self.hinge_mu * self.hinge_radius


@dataclass(frozen=True)
class Engine:
    """Lengths (m), masses (kg) and moment of inertia (kg m²) of the engine (paper, Table 1).

    ``L1`` pivot to spigot, ``L2`` pivot to hinge, ``L_CM`` pivot to the beam's
    centre of mass (positive toward the spigot), ``L3`` hinge to counterweight,
    ``L4`` sling, ``m_b`` beam, ``M`` counterweight, ``m`` projectile, ``I``
    beam about the pivot. ``counterweight_offset`` (rad) is None for the paper's hinged
    counterweight; for a counterweight fixed rigidly to the beam it is the constant ``ψ − θ``.
    ``friction``: the bearings' Coulomb friction (:class:`Friction`), None for the paper's
    frictionless engine.
    """

    L1: float
    L2: float
    L_CM: float
    L3: float
    L4: float
    m_b: float
    M: float
    m: float
    I: float
    counterweight_offset: float | None = None
    friction: Friction | None = None

    def __post_init__(self) -> None:
        """Refuse what no engine can be, also where a program builds or ``replace``-s one (a
        scene file's reader names the file and key before it gets here)."""
        positive = ("L1", "L2", "L3", "m_b", "M", "I")
        for name in (*positive, "L4", "m"):  # no sling or projectile in a dry fire: 0
            value = getattr(self, name)
            if not (isinstance(value, numbers.Real) and math.isfinite(value)):
                raise TrebuchetInputError(f"Engine: {name} = {value!r}: must be a finite number")
            if value < 0.0 or (value == 0.0 and name in positive):
                raise TrebuchetInputError(f"Engine: {name} = {value:g}: must be "
                                          + ("positive" if name in positive else
                                             "zero or positive"))
        if not -self.L2 <= self.L_CM <= self.L1:
            raise TrebuchetInputError(f"Engine: L_CM = {self.L_CM!r} m: must lie on the beam, "
                                      f"between -L2 = {-self.L2:g} m and L1 = {self.L1:g} m")

    @property
    def fixed_counterweight(self) -> bool:
        """True when the counterweight is rigid on the beam at ``ψ = θ + counterweight_offset``
        (rad) instead of swinging on its hinge."""
        return self.counterweight_offset is not None

    @property
    def pivot_friction(self) -> float:
        """``μ_P r_P`` (m) of :attr:`friction`; 0 without friction."""
        return 0.0 if self.friction is None else self.friction.pivot

    @property
    def hinge_friction(self) -> float:
        """``μ_H r_H`` (m) of :attr:`friction`; 0 without friction."""
        return 0.0 if self.friction is None else self.friction.hinge

    @property
    def friction_rate(self) -> float:
        """The sliding rate (rad/s) of the friction couples' ``tanh`` sign."""
        return DEFAULT_SMOOTHING_RATE if self.friction is None else self.friction.smoothing_rate

    @property
    def first_moment(self) -> float:
        """Gravity moment ``M L2 − m_b L_CM`` that drives the beam, kg m (paper, ΔU)."""
        return self.M * self.L2 - self.m_b * self.L_CM


@dataclass(frozen=True)
class Start:
    """Pose at rest before the trigger, rad; ``H`` the height of the pivot above the trough, m.

    The paper puts the spigot on the ground at the start, ``H = −L1 sin θ_i``.
    """

    theta: float
    psi: float
    phi: float
    H: float


@dataclass(frozen=True)
class Release:
    """When the projectile leaves the sling: at ``time`` (s after the trigger) or when its
    velocity climbs at ``velocity_angle`` (rad above horizontal), whichever comes first.

    A scene file names exactly one; programs (the FMU's release command) may set both.
    """

    time: float | None = None
    velocity_angle: float | None = None


@dataclass(frozen=True)
class Flight:
    """How the projectile flies after release: ``model`` "vacuum" (the paper) or "drag"
    (quadratic air drag on a sphere of ``diameter`` m, drag coefficient ``drag_coefficient``,
    air density ``air_density`` kg/m³)."""

    model: str = "vacuum"
    diameter: float = 0.0
    drag_coefficient: float = 0.47
    air_density: float = 1.225
