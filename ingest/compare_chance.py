"""What chance allows (:mod:`trebuchet.ingest.compare`, "Chance"): the outside fraction of a
correct model's prediction, from simulated logs of the model itself reconstructed as the log
was, and the verdict columns it gives the metrics table."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pandas as pd

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.compare_metrics import (
    CHANCE_COLUMNS,
    METRIC_COLUMNS,
    QUANTITIES,
    Quantity,
    compared_rows,
    outside_spans,
    shown_span,
)
from trebuchet.ingest.identification.chance import fit_chance_levels
from trebuchet.ingest.reconstruction import reconstruction_of
from trebuchet.ingest.uncertainty import BAND_SD
from trebuchet.model.scene import Scene

__all__ = ["chance_levels", "with_chance"]


def _truth_log(measured: pd.DataFrame, predicted: pd.DataFrame, scene: Scene,
               log: pd.DataFrame | None = None) -> pd.DataFrame:
    """The log the model says was filmed: its θ, ψ, φ at the log's rows, the start pose before
    the model's start, the measured (smoothed) angles after its end; gaps where the log has
    none (``log``: the log as read, whose empty cells and lost tracks are copied, when its
    rows are the measured ones; else where the measured angles are NaN)."""
    log = pd.DataFrame({"t": measured["t"].to_numpy(dtype=float)}, index=measured.index)
    lag = float(predicted.attrs.get("lag", 0.0))
    before = measured["t_shot"].to_numpy(dtype=float) - lag < 0.0
    start = {"theta": scene.start.theta, "psi": scene.start.psi, "phi": scene.start.phi}
    same_rows = (log is not None and len(log) == len(measured) and "t" in log.columns
                 and np.allclose(log["t"].to_numpy(dtype=float),
                                 measured["t"].to_numpy(dtype=float), equal_nan=True))
    for a in ("theta", "psi", "phi"):
        values = measured[a].to_numpy(dtype=float).copy()
        have = np.isfinite(values)
        if same_rows and a in log.columns:
            have &= np.isfinite(log[a].to_numpy(dtype=float))
        values[~have] = math.nan
        values[before & have] = start[a]
        if a in predicted.columns:
            model = predicted[a].reindex(measured.index).to_numpy(dtype=float)
            use = np.isfinite(model) & have
            values[use] = model[use]
        log[a] = values
    return log.reset_index(drop=True)


def _autocorrelation(z: np.ndarray) -> tuple[float, np.ndarray]:
    """``(variance, rho)`` of standardised errors ``z`` (runs × rows; NaN = no value), pooled
    over runs; ``rho`` is cut to zero from its first non-positive lag on. Values beyond four
    robust sd (1.4826 × median absolute value) are clipped there first, so that a few large
    errors (next to an event) do not set the correlation of the rest."""
    ok = np.isfinite(z)
    if not ok.any():
        return math.nan, np.ones(1)
    scale = 1.4826 * float(np.median(np.abs(z[ok]))) or 1.0
    zz = np.where(ok, np.clip(z, -4 * scale, 4 * scale), 0.0)
    n = z.shape[1]
    var = float(np.sum(zz * zz) / max(ok.sum(), 1))
    rho = np.zeros(n)
    rho[0] = 1.0
    for k in range(1, n):
        both = ok[:, k:] & ok[:, :-k]
        if both.sum() < 10:
            break
        c = float(np.sum(zz[:, k:] * zz[:, :-k]) / both.sum()) / var
        if c <= 0.0:
            break
        rho[k] = c
    return var, rho


def _exceedance_scale(z: np.ndarray, band_sd: float) -> tuple[float, float]:
    """``(p, sd)``: how often the simulated errors ``z`` leave ±``band_sd`` (counted, with
    one added to either side: (k + 1) / (N + 2), never 0 or 1 from a finite sample), and the
    sd of a Gaussian error that leaves it as often."""
    from scipy.special import ndtri

    ok = np.isfinite(z)
    k, n = int(np.sum(np.abs(z[ok]) > band_sd)), int(ok.sum())
    p = (k + 1) / (n + 2)
    return p, band_sd / float(ndtri(1.0 - p / 2.0))


def _gaussian_fractions(var: float, rho: np.ndarray, band_sd: float, draws: int,
                        rng: np.random.Generator) -> np.ndarray:
    """Outside fractions of ``draws`` stationary Gaussian series (variance ``var``,
    autocorrelation ``rho``, as long as ``rho``) beyond ±``band_sd``: circulant embedding,
    negative eigenvalues clipped."""
    n = rho.size
    m = 1 << int(math.ceil(math.log2(2 * n)))
    c = np.zeros(m)
    c[:n] = rho
    c[m - n + 1:] = rho[1:][::-1]
    lam = np.clip(np.fft.fft(c).real, 0.0, None)
    fractions = []
    for start in range(0, draws, 1000):
        k = min(1000, draws - start)
        w = rng.standard_normal((k, m)) + 1j * rng.standard_normal((k, m))
        x = np.fft.fft(np.sqrt(lam / m) * w, axis=1)
        series = np.concatenate((x.real[:, :n], x.imag[:, :n])) * math.sqrt(var)
        fractions.append(np.mean(np.abs(series) > band_sd, axis=1))
    return np.concatenate(fractions)[:draws]


def chance_levels(measured: pd.DataFrame, predicted: pd.DataFrame, scene: Scene, *,
                  runs: int = 12, band_sd: float = BAND_SD, level: float = 0.95,
                  seed: int = 0, draws: int = 4000,
                  quantities: Sequence[Quantity] = QUANTITIES,
                  log: pd.DataFrame | None = None) -> pd.DataFrame:
    """How often the prediction would leave the measured band if the model were right
    (module doc, "Chance"): one row per quantity with ``quantity`` and ``chance_fraction``,
    ``chance_limit`` (the ``level`` quantile), ``chance_limit_all`` (the 1 − (1 − level) / n
    quantile for the n quantities: Bonferroni, so that a correct model's n quantities all
    stay within their limits at least ``level`` of the time), ``effective_samples`` (NaN
    where the quantity has no compared rows).

    ``measured`` must come from :func:`~trebuchet.ingest.reconstruct.reconstruct` (its
    :class:`~trebuchet.ingest.reconstruction.Reconstruction` gives the noise per angle,
    the form and the trough setting); ``log``, the log
    it was reconstructed from, gives the simulated logs its gaps (a lost sling track stays
    lost).
    """
    from trebuchet.ingest.reconstruct import reconstruct

    a = reconstruction_of(measured)
    band = getattr(a.identification, "band", None)
    if a.method == "fit" and band is not None:  # issue 23: the fitted engine's error model
        return fit_chance_levels(measured, band, {q.column: compared_rows(q, measured, predicted)
                                                  for q in quantities},
                                 [q.column for q in quantities], band_sd=band_sd, level=level,
                                 seed=seed, draws=draws)
    noise = a.noise
    # every event is found in each simulated log as in the real one: their errors and sd
    # shape the loads and bands of the frames around them
    truth = _truth_log(measured, predicted, scene, log)
    rng = np.random.default_rng(seed)
    windows = {q.column: compared_rows(q, measured, predicted) for q in quantities}
    errors: dict[str, list[np.ndarray]] = {q.column: [] for q in quantities}
    import warnings

    for _ in range(runs):
        log = truth.copy()
        for angle in ("theta", "psi", "phi"):
            r_sd = float((noise.get(angle) or {}).get("r_sd", math.nan))
            if math.isfinite(r_sd):
                log[angle] = log[angle] + r_sd * rng.standard_normal(len(log))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                sim = reconstruct(log, scene, form=a.form, trough=a.trough, method=a.method)
            except TrebuchetInputError:
                continue
        sim.index = measured.index
        for q in quantities:
            rows = windows[q.column]
            with np.errstate(all="ignore"):
                z = ((sim.loc[rows, q.column] - predicted.loc[rows, q.column])
                     / sim.loc[rows, q.column + "_sd"]).to_numpy(dtype=float)
            errors[q.column].append(z)
    out = []
    for q in quantities:
        row = {"quantity": q.column, "chance_fraction": math.nan, "chance_limit": math.nan,
               "chance_limit_all": math.nan, "effective_samples": math.nan}
        if errors[q.column] and windows[q.column].size >= 2:
            z = np.array(errors[q.column])
            _, rho = _autocorrelation(z)
            _, sd = _exceedance_scale(z, band_sd)
            f = _gaussian_fractions(sd * sd, rho, band_sd, draws, rng)
            p = float(np.mean(f))
            spread = float(np.var(f))
            row |= {"chance_fraction": p, "chance_limit": float(np.quantile(f, level)),
                    "chance_limit_all": float(np.quantile(
                        f, 1.0 - (1.0 - level) / len(quantities))),
                    "effective_samples": (p * (1 - p) / spread if spread > 0 else math.nan)}
        out.append(row)
    return pd.DataFrame(out)


def with_chance(table: pd.DataFrame, chance: pd.DataFrame, measured: pd.DataFrame,
                 predicted: pd.DataFrame, band_sd: float) -> pd.DataFrame:
    """``table`` with :data:`CHANCE_COLUMNS` filled from ``chance`` and the stretches
    outside the band: the longest that starts by the release, where the report's time
    figures stop (a verdict citing 1102–1190 ms beside figures that end near 1000 ms
    pointed at nothing a reader can see), else the longest after it."""
    table = table.merge(chance, on="quantity", how="left")
    outside = table["outside_band_fraction"]
    table["within_chance"] = outside <= table["chance_limit"]
    table["verdict"] = np.where(outside <= table["chance_limit"], "agrees",
                                np.where(outside <= table["chance_limit_all"], "borderline",
                                         "differs"))
    table.loc[table["chance_limit"].isna(), "verdict"] = ""
    starts, ends, worst = [], [], []
    events = reconstruction_of(measured).events
    drawn_until = (math.inf if events.get("release") is None or events.get("trigger") is None
                   else events["release"] - events["trigger"])
    for q in QUANTITIES:
        rows = compared_rows(q, measured, predicted)
        m = measured.loc[rows]
        spans = outside_spans(m["t_shot"].to_numpy(dtype=float),
                              m[q.column].to_numpy(dtype=float),
                              m[q.column + "_sd"].to_numpy(dtype=float),
                              predicted.loc[rows, q.column].to_numpy(dtype=float), band_sd)
        first = shown_span(spans, drawn_until)
        starts.append(first[0])
        ends.append(first[1])
        worst.append(first[2])
    by = {q.column: i for i, q in enumerate(QUANTITIES)}
    order = [by.get(c) for c in table["quantity"]]
    for name, values in (("outside_start", starts), ("outside_end", ends),
                         ("outside_worst_sd", worst)):
        table[name] = [values[i] if i is not None else math.nan for i in order]
    return table[METRIC_COLUMNS + CHANCE_COLUMNS]
