"""One design of a sweep: the grid's syntax, a design's scene, its row of the table.

A grid names scene keys as ``"section.key"`` (the keys of the scene file, e.g. ``"engine.M"``
in kg, ``"release.velocity_angle_deg"`` in degrees) and lists values for each;
:func:`grid_designs` is their cartesian product; :func:`~trebuchet.model.sweep_scene.design_scene`
builds a design's scene (the quantities that follow the swept ones: its module doc).

:func:`evaluate_design` makes a design's row: its parameters, a ``status`` and an ``error``
(the reason, empty when ok) and the figures of :data:`SUMMARY_COLUMNS`
(:func:`~trebuchet.model.shot_summary.shot_figures`, no table per design). Statuses:

* ``ok``;
* ``backward``: the projectile leaves backward or lands behind the pivot; ``ground``: it is
  thrown downward, into the ground (figures given; the throw is not one to want);
* ``refused``: the model refuses the design (the reason says why: no lift-off, a sling that
  hits the ground, a scene value out of range);
* ``failed``: an error or a non-finite figure, or the worker process died running it (the
  error starts "its worker process died");
* ``over_budget``: it ran over the sweep's time or memory budget and was stopped.

Grid values on the command line (:func:`parse_grid_option`): ``KEY=VALUES`` where ``VALUES`` is
a comma list (``10000,19100,30000``), a single number, or ``start:stop:count`` (``count`` evenly
spaced values from ``start`` to ``stop``, both included: ``30:60:7`` is 30, 35, ..., 60).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
import pandas as pd

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model import c_engine
from trebuchet.model import kinematics as kin
from trebuchet.model.design_sizing import Sizing, sized
from trebuchet.model.output_size import check_output_size
from trebuchet.model.scene import SCENE_KEYS, Scene
from trebuchet.model.settings import (
    MAX_DT,
    MEMORY_BUDGET,
    TIME_BUDGET,
    accuracy_option,
    output_step,
)
from trebuchet.model.shot_summary import (
    CLEARANCE_WINDOW,
    FIGURES,
    STATUS_BACKWARD,
    STATUS_GROUND,
    STATUS_OK,
    designs_values,
    shot_figures,
    throw_status,
)
from trebuchet.model.simulate import resolve_rtol
from trebuchet.model.sweep_scene import ANGLE_PAIRS, RELEASE_KEYS, design_scene

__all__ = [
    "SUMMARY_COLUMNS", "STATUSES", "STATUS_OK", "STATUS_REFUSED", "STATUS_FAILED",
    "STATUS_OVER_BUDGET", "STATUS_BACKWARD", "STATUS_GROUND", "SimulationOptions",
    "output_step", "accuracy_option", "parse_grid_values", "parse_grid_option", "check_grid",
    "grid_designs", "design_scene", "summarize", "evaluate_design", "evaluate_designs",
    "failed_row", "Budget", "batched",
    "LOST", "keyed_arguments", "check_workers",
]

#: Summary outputs of a design, with their units (the figures of
#: :func:`~trebuchet.model.shot_summary.shot_figures`).
SUMMARY_COLUMNS: dict[str, str] = dict(FIGURES)

STATUS_REFUSED, STATUS_FAILED, STATUS_OVER_BUDGET = "refused", "failed", "over_budget"
STATUSES = (STATUS_OK, STATUS_BACKWARD, STATUS_GROUND, STATUS_REFUSED, STATUS_FAILED,
            STATUS_OVER_BUDGET)
#: The start of the error of a design whose worker process died while running it (a resumed
#: sweep runs such designs again).
LOST = "its worker process died"
MAX_DESIGNS = 1_000_000  # designs of one sweep at most


@dataclass(frozen=True)
class SimulationOptions:
    """How every design of a sweep is simulated: tolerance ``rtol`` (a number or a preset name
    of ``simulate.ACCURACY``), ``dt`` (None: the peaks over the continuous shot, reduced on the
    integrator's dense output; a step in s: over the rows of ``simulate``'s table at that
    step, slower), ``after_release`` (s of phase III the peaks cover; None: simulate's
    0.5 s) and ``sizing`` (the sizing rules: :mod:`trebuchet.model.design_sizing`)."""

    @property
    def sized_keys(self) -> list[str]:
        """The scene keys the sizing rules set (``friction.pivot_radius`` ...)."""
        return [f"friction.{key}" for key, _, _ in self.sizing.rules]

    rtol: float | str = "default"
    dt: float | None = None
    after_release: float | None = None
    sizing: Sizing = Sizing()

    def check(self) -> None:
        """Raise TrebuchetInputError for options no design could run with."""
        resolve_rtol(self.rtol)
        if self.dt is not None and not 0.0 < self.dt <= MAX_DT:
            raise TrebuchetInputError(f"dt = {self.dt:g} s: must lie in (0, {MAX_DT:g}] s")
        check_output_size(self.dt, self.after_release)  # no design could run beyond these


@dataclass(frozen=True)
class Budget:
    """What one design may cost: ``seconds`` of wall time and ``memory`` bytes of growth of its
    worker's resident memory (None: no limit). Enforced in worker processes (a design run in
    the calling process, ``workers=1``, has no budget)."""

    seconds: float | None = TIME_BUDGET
    memory: int | None = MEMORY_BUDGET

    def check(self) -> None:
        """Refuse a budget no design could meet."""
        if self.seconds is not None and not (math.isfinite(self.seconds) and self.seconds > 0):
            raise TrebuchetInputError(f"time budget {self.seconds!r} s: must be a positive "
                                      "number of seconds")
        if self.memory is not None and not self.memory >= 16 * 1024**2:
            raise TrebuchetInputError(f"memory budget {self.memory!r} bytes: must be at least "
                                      "16 MiB")


# --------------------------------------------------------------------------- grid


def parse_grid_values(text: str, where: str = "--grid") -> tuple[float, ...]:
    """Values of one grid key from ``a,b,c``, ``x`` or ``start:stop:count`` (both ends
    included). ``where`` names the argument in errors."""
    text = text.strip()
    if not text:
        raise TrebuchetInputError(f"{where}: no values (give a,b,c or start:stop:count)")
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise TrebuchetInputError(f"{where}: {text!r}: a range is start:stop:count")
        start, stop = (_number(p, where) for p in parts[:2])
        try:
            count = int(parts[2])
        except ValueError:
            raise TrebuchetInputError(f"{where}: {text!r}: count {parts[2]!r} must be a whole "
                                      "number") from None
        if not 1 <= count <= MAX_DESIGNS:
            raise TrebuchetInputError(f"{where}: {text!r}: count must lie between 1 and "
                                      f"{MAX_DESIGNS:,}")
        if count == 1:
            return (start,)
        return tuple(float(v) for v in np.linspace(start, stop, count))
    return tuple(_number(p, where) for p in text.split(","))


def _number(text: str, where: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise TrebuchetInputError(f"{where}: {text.strip()!r} is not a number") from None
    if not math.isfinite(value):
        raise TrebuchetInputError(f"{where}: {text.strip()!r}: values must be finite")
    return value


def parse_grid_option(text: str) -> tuple[str, tuple[float, ...]]:
    """``"section.key=VALUES"`` (a ``--grid`` argument) as ``(key, values)``."""
    key, sep, values = text.partition("=")
    if not sep:
        raise TrebuchetInputError(f"--grid {text!r}: expected KEY=VALUES, e.g. "
                                  "engine.M=10000,19100 or release.velocity_angle_deg=30:60:7")
    key = key.strip()
    return key, parse_grid_values(values, where=f"--grid {key}")


def keyed_arguments(texts: Iterable[str], parse: Any, flag: str) -> dict[str, Any]:
    """``{key: value}`` of repeated ``KEY=...`` arguments (``--grid``, ``--vary``), each
    parsed by ``parse`` into ``(key, value)``; a key given twice is refused."""
    out: dict[str, Any] = {}
    for text in texts:
        key, value = parse(text)
        if key in out:
            raise TrebuchetInputError(f"{flag} {key}: given twice")
        out[key] = value
    return out


def check_workers(workers: int | None) -> None:
    """``--workers``: None (one per core) or at least 1."""
    if workers is not None and workers < 1:
        raise TrebuchetInputError(f"--workers {workers}: must be at least 1")


def check_grid(grid: Mapping[str, Iterable[float | str]]) -> dict[str, tuple[float | str, ...]]:
    """The grid with its keys checked against the scene file's keys and its values as
    tuples of finite floats (words, for the scene's word-valued keys, pass through to the
    scene's validation). A bad key raises :class:`TrebuchetInputError` naming it."""
    if not grid:
        raise TrebuchetInputError("grid: empty (name at least one scene key, e.g. engine.M)")
    out: dict[str, tuple[float, ...]] = {}
    for key, values in grid.items():
        section, dot, name = str(key).partition(".")
        if not dot or section not in SCENE_KEYS or name not in SCENE_KEYS[section]:
            known = ", ".join(f"{s}.{k}" for s in sorted(SCENE_KEYS)
                              for k in sorted(SCENE_KEYS[s]))
            raise TrebuchetInputError(f"grid key {key!r}: not a scene key (known: {known})")
        vals = tuple(values) if not isinstance(values, str | bytes) else (values,)
        if not vals:
            raise TrebuchetInputError(f"grid key {key!r}: no values")
        clean: list[float | str] = []
        for v in vals:
            if isinstance(v, str):  # word-valued keys (engine.counterweight = "fixed")
                clean.append(v)
                continue
            if isinstance(v, bool) or not isinstance(v, int | float | np.integer | np.floating):
                raise TrebuchetInputError(f"grid key {key!r}: value {v!r} is not a number")
            if not math.isfinite(float(v)):
                raise TrebuchetInputError(f"grid key {key!r}: value {v!r} is not finite")
            clean.append(float(v))
        out[str(key)] = tuple(clean)
    rel = [k for k in out if k in RELEASE_KEYS]
    if len(rel) > 1:
        raise TrebuchetInputError(f"grid keys {rel[0]!r} and {rel[1]!r}: a scene has one "
                                  "release rule; sweep one of them")
    for plain, deg in ANGLE_PAIRS.items():
        for section in ("start", "release"):
            if f"{section}.{plain}" in out and f"{section}.{deg}" in out:
                raise TrebuchetInputError(f"grid keys {section}.{plain!r} and {section}.{deg!r} "
                                          "name the same angle")
    return out


def grid_designs(grid: Mapping[str, Sequence[float]]) -> list[dict[str, float]]:
    """The cartesian product of the grid's values, the first key varying slowest; at most
    :data:`MAX_DESIGNS` designs (a larger grid is refused: split it into sweeps)."""
    keys = list(grid)
    n = math.prod(len(grid[k]) for k in keys)
    if n > MAX_DESIGNS:
        raise TrebuchetInputError(f"grid: {n:,} designs, more than a sweep takes "
                                  f"({MAX_DESIGNS:,}: their rows alone would need gigabytes); "
                                  "split it into several sweeps")
    return [dict(zip(keys, combo, strict=True))
            for combo in itertools.product(*(grid[k] for k in keys))]


# --------------------------------------------------------------------------- one design


def summarize(run: pd.DataFrame, scene: Scene) -> dict[str, float]:
    """The :data:`SUMMARY_COLUMNS` of one simulated shot from ``simulate``'s DataFrame: the
    extrema over its rows (``cw_clearance`` over the rows up to
    :data:`~trebuchet.model.shot_summary.CLEARANCE_WINDOW` s past the release). The check of
    the summary-only path, and of a design the optimiser proposes."""
    ev, fl, diag = run.attrs["events"], run.attrs["flight"], run.attrs["diagnostics"]
    held = run[run["phase"] <= 2]
    at_release = run[(run["t"] == ev["release"]) & (run["phase"] == 2)]
    energy_share = (float(at_release["E_m"].iloc[0]) / diag["delta_U"]
                    if len(at_release) else math.nan)

    def peak(col: str, rows: pd.DataFrame = run) -> float:
        return float(np.max(np.abs(rows[col].to_numpy()))) if len(rows) else math.nan

    early = run[run["t"] <= ev.get("release", math.inf) + CLEARANCE_WINDOW]
    lost = 0.0
    if "E_loss_pivot" in run and len(at_release):
        lost = float(at_release["E_loss_pivot"].iloc[0] + at_release["E_loss_hinge"].iloc[0])
    th, ps = early["theta"].to_numpy(), early["psi"].to_numpy()
    y_M = kin.counterweight_position_xy(np.cos(th), np.sin(th), np.cos(ps), np.sin(ps),
                                        scene.engine, scene.start.H)[1]
    return {
        "lift_off": float(ev["lift_off"]),
        "release_time": float(ev["release"]),
        "release_speed": float(fl["release_speed"]),
        "release_angle": float(fl["release_angle"]),
        "release_angle_deg": math.degrees(float(fl["release_angle"])),
        "release_height": float(fl["release_height"]),
        "range": float(fl["range"]),
        "F_S_peak": peak("F_S_abs"),
        "F_H_peak": peak("F_H_abs"),
        "F_R_peak": peak("F_R_abs"),
        "F_R_perp_peak": peak("F_R_perp"),
        "torque_peak": peak("torque"),
        "sling_tension_min": float(held["sling_tension"].min()) if len(held) else math.nan,
        "energy_share": energy_share,
        "energy_drift_rel": float(diag["energy_drift_rel"]),
        "cw_clearance": float(y_M.min()) if y_M.size else math.nan,
        "E_loss_release": lost,
        "loss_share": 100.0 * lost / diag["delta_U"],
    }


def failed_row(item: tuple[int, Mapping[str, Any]], status: str, error: str,
               outputs: Sequence[str] = tuple(SUMMARY_COLUMNS)) -> dict[str, Any]:
    """The row of a design that gave no figures: its parameters, ``status``, ``error`` and NaN
    outputs."""
    index, params = item
    return {"design": index, **params, "status": status, "error": error,
            **dict.fromkeys(outputs, math.nan)}


def _throw_error(status: str, figures: dict[str, float]) -> str:
    """The reason of a ``backward`` or ``ground`` row, in words."""
    deg, range_ = figures["release_angle_deg"], figures["range"]
    where = (f"lands {-range_:.3g} m behind the pivot" if range_ < 0 else
             f"lands {range_:.3g} m ahead of it")
    if status == STATUS_BACKWARD:
        return f"thrown backward: the projectile leaves at {deg:.4g}° and {where}"
    return (f"thrown into the ground: the projectile leaves at {deg:.4g}° (below the "
            f"horizontal) and {where}")


def _sized_values(scene: Scene, options: SimulationOptions) -> dict[str, float]:
    """The values the sizing rules gave the design's scene keys."""
    if not options.sizing:
        return {}
    friction = scene.to_dict()["friction"]
    return {key: float(friction[key.partition(".")[2]]) for key in options.sized_keys}


def evaluate_design(base: Scene, item: tuple[int, Mapping[str, float]], *,
                    options: SimulationOptions = SimulationOptions(),
                    outputs: Sequence[str] = tuple(SUMMARY_COLUMNS)) -> dict[str, Any]:
    """One row of the sweep table for design ``item = (index, params)`` (statuses: the module
    doc). The figures come from :func:`~trebuchet.model.shot_summary.shot_figures`."""
    index, params = item
    try:
        scene, figures = sized(design_scene(base, params, source=f"design {index}"),
                               options.sizing, partial(shot_figures, rtol=options.rtol,
                                                       after_release=options.after_release,
                                                       dt=options.dt))
    except Exception as exc:  # noqa: BLE001 - a sweep keeps every design, failures included
        return _failure(item, exc, outputs)
    return _design_row(item, scene, figures.as_dict(), options, outputs)


def batched(options: SimulationOptions) -> bool:
    """Whether :func:`evaluate_designs` runs its designs in one call of the C engine: the C
    engine runs here, and the options have no sizing rules and no output step."""
    return not options.sizing and options.dt is None and c_engine.available(quiet=True)


def evaluate_designs(base: Scene, items: Sequence[tuple[int, Mapping[str, float]]], *,
                     options: SimulationOptions = SimulationOptions(),
                     outputs: Sequence[str] = tuple(SUMMARY_COLUMNS)) -> list[dict[str, Any]]:
    """The rows of ``items`` as :func:`evaluate_design` makes them, the figures of them all
    from one call of the C engine (:func:`~trebuchet.model.shot_summary.designs_values`)
    where it runs and the options allow (no sizing rules, no output step); a design the C
    refuses runs alone, which words the refusal."""
    if not batched(options):
        return [evaluate_design(base, item, options=options, outputs=outputs) for item in items]
    rows: list[dict[str, Any] | None] = [None] * len(items)
    built: list[tuple[int, Scene]] = []
    for i, (index, params) in enumerate(items):
        try:
            built.append((i, design_scene(base, params, source=f"design {index}")))
        except Exception as exc:  # noqa: BLE001 - as evaluate_design
            rows[i] = _failure(items[i], exc, outputs)
    try:
        found = designs_values([scene for _, scene in built], rtol=options.rtol,
                               after_release=options.after_release)
    except Exception:  # noqa: BLE001 - each design alone then says what went wrong
        found = [None] * len(built)
    for (i, scene), values in zip(built, found, strict=True):
        rows[i] = (evaluate_design(base, items[i], options=options, outputs=outputs)
                   if values is None else _design_row(items[i], scene, values[0], options,
                                                      outputs))
    return rows  # type: ignore[return-value]


def _failure(item: tuple[int, Mapping[str, Any]], exc: Exception,
             outputs: Sequence[str]) -> dict[str, Any]:
    """The row of a design that raised ``exc``: refused, over the memory budget or failed."""
    if isinstance(exc, TrebuchetInputError):
        return failed_row(item, STATUS_REFUSED, str(exc), outputs)
    if isinstance(exc, MemoryError):
        return failed_row(item, STATUS_OVER_BUDGET, "over the memory budget: an allocation "
                          "failed (MemoryError)", outputs)
    return failed_row(item, STATUS_FAILED, f"{type(exc).__name__}: {exc}", outputs)


def _design_row(item: tuple[int, Mapping[str, Any]], scene: Scene, figures: dict[str, float],
                options: SimulationOptions, outputs: Sequence[str]) -> dict[str, Any]:
    """The row of a design with its figures (:meth:`ShotFigures.as_dict`): ``ok``,
    ``backward``, ``ground``, or ``failed`` where an output is not finite."""
    index, params = item
    values = figures if outputs == _ALL else {k: figures[k] for k in outputs}
    row: dict[str, Any] = {"design": index, **params}
    if options.sizing:
        row.update(_sized_values(scene, options))
    status, error = STATUS_OK, ""
    if not all(map(math.isfinite, values.values())):
        bad = [k for k, v in values.items() if not math.isfinite(v)]
        status, error = STATUS_FAILED, "non-finite output: " + ", ".join(bad)
    elif (thrown := throw_status(figures["release_angle"], figures["range"])) != STATUS_OK:
        status, error = thrown, _throw_error(thrown, figures)
    row["status"], row["error"] = status, error
    row.update(values)
    return row


_ALL = tuple(SUMMARY_COLUMNS)
