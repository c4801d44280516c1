"""What :func:`~trebuchet.ingest.identification.identify.identify` returns: one frozen, typed
:class:`Identification`.

Its ``table`` has one row per fitted quantity, the columns ``parameter`` (the scene key, e.g.
``engine.M``; ``trigger`` for the trigger's log time), ``scene_value`` (the scene's value,
NaN for the trigger), ``value``, ``sd``, ``unit`` (the scene file's units: m, kg, kg m², °, s,
1) and ``kind`` (``free``: a key freed by the caller; ``nuisance``: the trigger, the start
pose and the release, which every fit fits; ``derived``: a quantity of the fitted engine, such
as the release's climb angle). ``covariance`` and ``correlations`` are over the rows of
``free`` and ``nuisance`` kind, in the table's units and order (``names``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np
import pandas as pd

from trebuchet.ingest.identification.check import ResidualCheck
from trebuchet.model.scene import Scene

__all__ = ["Identification", "LossEnergy", "LoadBand", "TABLE_COLUMNS", "summary_sentence"]

TABLE_COLUMNS = ["parameter", "scene_value", "value", "sd", "unit", "kind"]


@dataclass(frozen=True)
class LossEnergy:
    """The heat the fitted engine's bearings make from the trigger to the release: ``joules``
    and its ``sd`` (J), and the same as a ``fraction`` of the fitted scene's ΔU (with
    ``fraction_sd``); ``pivot`` and ``hinge`` (J) split it."""

    joules: float
    sd: float
    fraction: float
    fraction_sd: float
    pivot: float
    hinge: float


@dataclass(frozen=True, eq=False)
class LoadBand:
    """How the loads of a fitted engine err (``reconstruct(method="fit")``), per load column
    of ``gradients``: its gradient by the fitted vector (``(p, n)``, the load's unit per unit
    of each entry) whose ``covariance`` (``(p, p)``) is the fit's, and the sd (``(n,)``) the
    smoothed residual and the events add to it, row by row. Where the model is right the
    error of row ``r`` is ``g_r·δx`` plus that part, ``δx ~ N(0, covariance)``: what a
    comparison needs to know how often chance takes a prediction out of the band
    (:func:`~trebuchet.ingest.identification.chance.fit_chance_levels`)."""

    gradients: Mapping[str, np.ndarray]
    covariance: np.ndarray
    other_sd: Mapping[str, np.ndarray]

    def __deepcopy__(self, memo: dict) -> LoadBand:
        return self

    def __copy__(self) -> LoadBand:
        return self


@dataclass(frozen=True, eq=False)
class Identification:
    """An engine identified from its filmed shot (module doc).

    Attributes
    ----------
    scene:
        The fitted :class:`~trebuchet.model.scene.Scene`, a scene a user can simulate: the
        freed keys at their fitted values, the start pose of the log's rest, the release rule
        of the given scene with the value the log puts it at (a velocity angle where the scene
        has one, else a time).
    given:
        The scene as given.
    table, names, covariance, correlations:
        Module doc.
    check:
        The residual check (:class:`~.check.ResidualCheck`).
    trigger, release:
        The fitted trigger and release (s, the log's time; release None for a dry fire or a
        log that shows none) with ``trigger_sd``, ``release_sd``.
    noise_sd:
        Each fitted angle's noise sd (rad) from the log alone (the weights).
    loss:
        :class:`LossEnergy` where the fitted scene has friction, else None.
    warnings:
        Sentences, each also warned as a ModelValidityWarning: a failed check with the likely
        missing piece, parameters the log cannot separate, a coefficient at zero.
    notes:
        Sentences on how the fit ran (log, frames, evaluations, what was fixed).
    residuals:
        ``t`` (s, log time) and each fitted angle's residual (rad) at every frame.
    lift_off, lift_off_sd:
        The fitted engine's lift-off (s, log time; None without a trough) and its sd.
    band:
        Where the loads were taken from the fitted engine, how they err (:class:`LoadBand`),
        row by row of the reconstruction; else None.
    """

    scene: Scene
    given: Scene
    table: pd.DataFrame
    names: tuple[str, ...]
    covariance: np.ndarray
    correlations: np.ndarray
    check: ResidualCheck
    trigger: float
    trigger_sd: float
    release: float | None
    release_sd: float
    noise_sd: Mapping[str, float]
    loss: LossEnergy | None
    warnings: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    residuals: pd.DataFrame = field(default_factory=pd.DataFrame, repr=False)
    lift_off: float | None = None
    lift_off_sd: float = float("nan")
    band: LoadBand | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "noise_sd", MappingProxyType(dict(self.noise_sd)))
        for name in ("covariance", "correlations"):
            a = np.array(getattr(self, name), dtype=float)
            a.flags.writeable = False
            object.__setattr__(self, name, a)

    def __deepcopy__(self, memo: dict) -> Identification:
        return self  # frozen: pandas' attrs copies share it

    def __copy__(self) -> Identification:
        return self

    def __reduce__(self):
        """Pickled as its plain fields (mapping proxies do not pickle)."""
        return (_rebuild, (self.scene, self.given, self.table, self.names,
                           np.array(self.covariance), np.array(self.correlations), self.check,
                           self.trigger, self.trigger_sd, self.release, self.release_sd,
                           dict(self.noise_sd), self.loss, self.warnings, self.notes,
                           self.residuals, self.lift_off, self.lift_off_sd, self.band))

    @property
    def passed(self) -> bool:
        """True when the residual check passed: the fitted engine explains the shot."""
        return self.check.passed

    @property
    def sentence(self) -> str:
        """One sentence of what the shot says of the scene (:func:`summary_sentence`)."""
        return summary_sentence(self)

    @property
    def free(self) -> tuple[str, ...]:
        """The freed keys, in the table's order."""
        return tuple(self.table.loc[self.table["kind"] == "free", "parameter"])

    def value(self, parameter: str) -> float:
        """The fitted value of a row of the table (its units)."""
        return float(self._row(parameter)["value"])

    def sd(self, parameter: str) -> float:
        """The sd of a row of the table (its units)."""
        return float(self._row(parameter)["sd"])

    def ratio(self, parameter: str) -> float:
        """Fitted over scene value of a row (NaN where the scene's is zero)."""
        row = self._row(parameter)
        return float(row["value"] / row["scene_value"]) if row["scene_value"] else float("nan")

    def _row(self, parameter: str) -> pd.Series:
        rows = self.table[self.table["parameter"] == parameter]
        if rows.empty:
            raise KeyError(f"{parameter!r} is not in the identification's table (rows: "
                           + ", ".join(self.table["parameter"]) + ")")
        return rows.iloc[0]


def _ratio_part(row: Any) -> str:
    short = row.parameter.partition(".")[2]
    if row.scene_value and not row.parameter.endswith("_mu"):
        sd = row.sd / abs(row.scene_value)
        return (f"{short} {row.value / row.scene_value:.{2 if sd >= 0.005 else 3}f} × the "
                f"scene's (sd {sd:.2g})")
    return f"{short} {row.value:.3g} (sd {row.sd:.2g}; scene's {row.scene_value:.3g})"


def summary_sentence(ident: Identification) -> str:
    """One sentence: each freed key against the scene's and the friction's share of ΔU by the
    release ("the shot fits M 1.06 × the scene's (sd 0.01); friction takes 5.0 % (sd 0.4) of
    ΔU by the release"); for a fit that fails its check, that it does not explain the shot."""
    free = ident.table[ident.table["kind"] == "free"]
    parts = [_ratio_part(row) for row in free.itertuples(index=False)]
    text = "the shot fits " + (", ".join(parts) if parts else "the scene as given")
    if ident.loss is not None:
        when = "by the release" if ident.release is not None else "over the log"
        text += (f"; friction takes {100 * ident.loss.fraction:.1f} % (sd "
                 f"{100 * ident.loss.fraction_sd:.1f}) of ΔU {when}")
    if not ident.passed:
        text = ("the fitted engine does NOT explain the shot (its residual check fails; see "
                "the warning): taken as it is, " + text)
    return text


def _rebuild(*fields) -> Identification:
    return Identification(*fields)
