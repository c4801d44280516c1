"""The metrics of :mod:`trebuchet.ingest.compare`: the quantities compared, their peaks, RMS
differences and the rows outside the measured band, the events side by side, and the
stretches outside the band a verdict cites. Units SI; times in s after the log's trigger.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.reconstruction import Reconstruction
from trebuchet.ingest.uncertainty import BAND_SD
from trebuchet.model.timeline import shot_events

__all__ = ["Quantity", "QUANTITIES", "METRIC_COLUMNS", "CONTRACT_COLUMNS", "CHANCE_COLUMNS",
           "metrics", "metric_row", "event_table", "outside_spans", "shown_span",
           "compared_rows"]


@dataclass(frozen=True)
class Quantity:
    """A compared quantity: ``column`` of both frames (its sd in ``column + "_sd"``),
    ``label`` for people, SI ``unit``; ``held`` = it exists only while the projectile is in
    the trough or sling (compared from the trigger to release)."""

    column: str
    label: str
    unit: str
    held: bool = False


QUANTITIES: tuple[Quantity, ...] = (
    Quantity("F_S_abs", "|F_S|, sling force on the projectile", "N", held=True),
    Quantity("F_H_abs", "|F_H|, hinge force on the counterweight", "N"),
    Quantity("F_R_abs", "|F_R|, bearing reaction at the pivot", "N"),
    Quantity("F_R_x", "F_R_x, horizontal component of the bearing reaction", "N"),
    Quantity("F_R_perp", "F_R⊥, bearing reaction across the beam", "N"),
    Quantity("torque", "torque on the beam about the pivot (the paper's N)", "N m"),
    Quantity("P_m", "P_m, rate of work on the projectile", "W", held=True),
    Quantity("E_m", "E_m, energy gained by the projectile", "J", held=True),
    Quantity("E_M", "E_M, energy gained by the counterweight", "J"),
    Quantity("E_beam", "E_beam, energy gained by the beam", "J"),
)

CONTRACT_COLUMNS = ["quantity", "measured_peak", "predicted_peak", "rms_difference",
                    "rms_difference_rel", "outside_band_fraction"]
METRIC_COLUMNS = CONTRACT_COLUMNS + [
    "label", "unit", "measured_peak_sd", "measured_peak_time", "predicted_peak_time",
    "peak_time_difference", "peak_difference_in_sd", "rows", "window_start", "window_end"]
"""metrics.csv: the contract's six columns, then: ``label``; ``unit`` (SI, of the peaks and
differences); ``measured_peak_sd`` (sd of the measured value at its peak row);
``measured_peak_time``, ``predicted_peak_time`` (s after the trigger);
``peak_time_difference`` (predicted − measured, s); ``peak_difference_in_sd``
((predicted − measured peak) / measured_peak_sd); ``rows`` compared and the window
``window_start``, ``window_end`` (s after the trigger); then :data:`CHANCE_COLUMNS` when
the chance levels were estimated."""

CHANCE_COLUMNS = ["chance_fraction", "chance_limit", "chance_limit_all", "effective_samples",
                  "within_chance", "verdict", "outside_start", "outside_end",
                  "outside_worst_sd"]
"""Added to metrics.csv by :func:`compare` (``CompareOptions.chance_runs`` > 0):
``chance_fraction`` (mean outside fraction where the model is right), ``chance_limit`` (its
95 % quantile), ``effective_samples`` (independent rows giving that spread),
``chance_limit_all`` (its 1 − 0.05 / 10 quantile: the limit that a correct model's ten
quantities all stay within 95 % of the time), ``within_chance`` (outside_band_fraction ≤
chance_limit), ``verdict`` ("agrees"; "borderline": above chance_limit, not above
chance_limit_all; "differs": above chance_limit_all), ``outside_start``,
``outside_end`` (s after the trigger: the longest stretch of rows outside the band) and
``outside_worst_sd`` (the largest (predicted − measured) / sd there, sign kept)."""


def compared_rows(quantity: Quantity, measured: pd.DataFrame, predicted: pd.DataFrame
            ) -> np.ndarray:
    """Labels of the rows where both frames hold ``quantity``."""
    common = measured.index.intersection(predicted.index)
    m = measured.loc[common]
    phase = m["phase"].to_numpy()
    ok = phase >= 1
    if quantity.held:
        ok &= phase <= 2
    c = quantity.column
    for values in (m[c], m[c + "_sd"], predicted.loc[common, c]):
        ok &= np.isfinite(values.to_numpy(dtype=float))
    return common[ok]


def _peak(values: np.ndarray) -> int:
    """Row of the greatest magnitude."""
    return int(np.argmax(np.abs(values)))


def metric_row(quantity: Quantity, t: np.ndarray, measured: np.ndarray, sd: np.ndarray,
               predicted: np.ndarray, band_sd: float = BAND_SD) -> dict[str, float | str]:
    """One row of :func:`metrics` from aligned arrays: ``t`` (s after the trigger), the
    measured values, their sd and the predicted values (SI units of the quantity)."""
    row: dict[str, float | str] = {"quantity": quantity.column, "label": quantity.label,
                                   "unit": quantity.unit, "rows": int(t.size)}
    if t.size == 0:
        return row | {k: math.nan for k in METRIC_COLUMNS if k not in row}
    i, j = _peak(measured), _peak(predicted)
    diff = predicted - measured
    rms = float(np.sqrt(np.mean(diff ** 2)))
    peak = float(measured[i])
    row |= {
        "measured_peak": peak,
        "predicted_peak": float(predicted[j]),
        "rms_difference": rms,
        "rms_difference_rel": rms / abs(peak) if peak != 0.0 else math.nan,
        "outside_band_fraction": float(np.mean(np.abs(diff) > band_sd * sd)),
        "measured_peak_sd": float(sd[i]),
        "measured_peak_time": float(t[i]),
        "predicted_peak_time": float(t[j]),
        "peak_time_difference": float(t[j] - t[i]),
        "peak_difference_in_sd": (float((predicted[j] - peak) / sd[i]) if sd[i] > 0
                                  else math.nan),
        "window_start": float(t[0]),
        "window_end": float(t[-1]),
    }
    return row


def metrics(measured: pd.DataFrame, predicted: pd.DataFrame, *, band_sd: float = BAND_SD,
            quantities: Sequence[Quantity] = QUANTITIES) -> pd.DataFrame:
    """One row per quantity, columns :data:`METRIC_COLUMNS`: peaks with their times and sd,
    the RMS difference (absolute, SI, and relative to the measured peak's magnitude), the
    difference in peak timing, and the fraction of compared rows where the prediction lies
    outside the measured ±``band_sd`` sd band.

    ``measured``: a frame of :func:`~trebuchet.ingest.reconstruct.reconstruct` (``t_shot``,
    ``phase``, ``X`` and ``X_sd``); ``predicted``: rows with the same index labels (as
    :func:`predict` returns). Rows are compared where both exist (module doc).
    """
    rows = []
    for q in quantities:
        for name in (q.column, q.column + "_sd"):
            if name not in measured.columns:
                raise TrebuchetInputError(f"compare: the measured frame has no column {name!r}")
        if q.column not in predicted.columns:
            raise TrebuchetInputError(f"compare: the predicted frame has no column "
                                      f"{q.column!r}")
        labels = compared_rows(q, measured, predicted)
        m = measured.loc[labels]
        rows.append(metric_row(q, m["t_shot"].to_numpy(dtype=float),
                               m[q.column].to_numpy(dtype=float),
                               m[q.column + "_sd"].to_numpy(dtype=float),
                               predicted.loc[labels, q.column].to_numpy(dtype=float), band_sd))
    return pd.DataFrame(rows, columns=METRIC_COLUMNS)


def event_table(measured: pd.DataFrame, predicted: pd.DataFrame) -> pd.DataFrame:
    """Start of motion, lift-off and release, s after the log's detected trigger: measured
    (with sd where known), predicted and predicted − measured."""
    done = measured.attrs.get("reconstruction")
    event_sd = done.event_sd if isinstance(done, Reconstruction) else {}
    found = shot_events(measured) | {"start": 0.0}
    pred = shot_events(predicted) | {"start": float(predicted.attrs.get("lag", 0.0))}
    rows = []
    for name in ("start", "lift_off", "release"):
        m, p = found.get(name, math.nan), pred.get(name, math.nan)
        sd = event_sd.get("trigger" if name == "start" else name)
        rows.append({"event": name, "measured": m,
                     "measured_sd": math.nan if sd is None else float(sd),
                     "predicted": p, "difference": p - m})
    return pd.DataFrame(rows, columns=["event", "measured", "measured_sd", "predicted",
                                       "difference"])


# ----------------------------------------------------------------------------- chance


def outside_spans(t: np.ndarray, measured: np.ndarray, sd: np.ndarray, predicted: np.ndarray,
                  band_sd: float = BAND_SD) -> list[tuple[float, float, float]]:
    """Stretches of rows where the prediction leaves the measured band, longest first:
    ``(start, end, worst)`` with times as ``t`` and ``worst`` the (predicted − measured) / sd
    of greatest magnitude in the stretch (sign kept). A single row inside the band does not
    split a stretch."""
    with np.errstate(all="ignore"):
        z = (predicted - measured) / sd
    out_rows = np.abs(z) > band_sd
    idx = np.flatnonzero(out_rows)
    if idx.size == 0:
        return []
    breaks = np.flatnonzero(np.diff(idx) > 2)
    starts = np.concatenate(([idx[0]], idx[breaks + 1]))
    ends = np.concatenate((idx[breaks], [idx[-1]]))
    spans = []
    for a, b in zip(starts, ends, strict=True):
        zz = z[a:b + 1]
        k = int(np.nanargmax(np.abs(zz)))
        spans.append((float(t[a]), float(t[b]), float(zz[k]), int(b - a + 1)))
    spans.sort(key=lambda sp: -sp[3])
    return [sp[:3] for sp in spans]


def shown_span(spans: list[tuple[float, float, float]], drawn_until: float
               ) -> tuple[float, float, float]:
    """The stretch outside the band a verdict cites: of ``spans`` (longest first, as
    :func:`outside_spans` gives them) the longest that starts by ``drawn_until`` (s after
    the trigger: the release, where the report's time figures stop), else the longest
    (NaNs where there is none)."""
    drawn = [sp for sp in spans if sp[0] <= drawn_until]
    return (drawn or spans or [(math.nan, math.nan, math.nan)])[0]
