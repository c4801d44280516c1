"""What a format reader hands to the common checks and repairs of :func:`read_log`."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class ParsedLog:
    """A log as read, before the common checks and repairs.

    Arrays run over the data rows in file order. ``rows`` holds each row's 1-based line
    number in the file (for messages). ``angles`` are in rad, NaN where missing; ``labels``
    says which column of the file each angle came from. ``points`` holds point positions
    (``"<role>_x"``, ``"<role>_y"``, in the file's length unit, y up) for point files.
    ``leaves_sling``: (time, sd) in s at which a tracked projectile leaves its sling's
    circle (:mod:`.sling_circle`), if it does. ``held``: ``(role, first, last)`` (s) of each
    run of positions left out because the tracker stood still on something while the
    engine moved (:func:`~trebuchet.ingest.geometry.stuck_points.stuck_runs`).
    """

    fmt: str
    t: np.ndarray
    rows: np.ndarray
    angles: dict[str, np.ndarray]
    labels: dict[str, str]
    frame: np.ndarray | None = None
    fps: float | None = None
    points: dict[str, np.ndarray] | None = None
    point_names: dict[str, str] | None = None
    repairs: list[str] = field(default_factory=list)
    leaves_sling: tuple[float, float] | None = None
    decisions: list[str] = field(default_factory=list)
    held: tuple[tuple[str, float, float], ...] = ()

    def take(self, keep: np.ndarray) -> None:
        """Keep only the rows where the boolean mask ``keep`` is true (in place)."""
        self.t = self.t[keep]
        self.rows = self.rows[keep]
        self.angles = {k: v[keep] for k, v in self.angles.items()}
        if self.frame is not None:
            self.frame = self.frame[keep]
        if self.points is not None:
            self.points = {k: v[keep] for k, v in self.points.items()}


@dataclass
class LogSource:
    """What a format reader found, before any column or point is chosen.

    ``angle_columns`` and ``point_tracks`` are :class:`~.log_mapping.Candidate` objects
    whose ``data`` is a function without arguments: for an angle column it returns the
    angle in rad (NaN where missing); for a point it returns ``(x, y, note)`` with the
    position in the file's length unit, y up, NaN where missing, and an optional repair
    sentence (e.g. positions of low likelihood dropped). Numbers are parsed only when a
    candidate is used, so text in a column nobody asked for is no error.

    ``unitless`` holds the labels of angle columns whose header states no unit: their
    ``data`` returns the numbers as written, and :func:`read_log` decides the unit (from
    ``angle_unit=`` or the values). ``rates`` maps an angle column's label to a function
    returning its rate column as written (Tracker's ω: dθ/dt in the same angle unit, per
    s), which confirms the time unit. ``decisions`` says how each unit was decided.
    ``y_down`` is None when the file does not say which way its y axis points (Kinovea's
    world and image spaces share one header): :func:`read_log` tells it from the engine.
    """

    fmt: str
    t: np.ndarray
    rows: np.ndarray
    time_label: str
    angle_columns: list = field(default_factory=list)
    point_tracks: list = field(default_factory=list)
    frame: np.ndarray | None = None
    fps: float | None = None
    repairs: list[str] = field(default_factory=list)
    unitless: frozenset[str] = frozenset()
    rates: dict = field(default_factory=dict)
    decisions: list[str] = field(default_factory=list)
    y_down: bool | None = False

    def parsed(self, angles: dict[str, np.ndarray], labels: dict[str, str], repairs: list[str],
               decisions: list[str], **chosen: object) -> ParsedLog:
        """The :class:`ParsedLog` of this source's rows (its ``fmt``, ``t``, ``rows``,
        ``frame``, ``fps``) with the ``angles`` (rad) chosen from it, their ``labels``, the
        ``repairs`` and ``decisions`` (sentences), and ``chosen``: the further fields of
        :class:`ParsedLog` a point file fills (``points``, ``point_names``,
        ``leaves_sling``, ``held``)."""
        return ParsedLog(fmt=self.fmt, t=self.t, rows=self.rows, angles=angles, labels=labels,
                         frame=self.frame, fps=self.fps, repairs=repairs, decisions=decisions,
                         **chosen)
