"""What chance allows a prediction that is right, when the measured loads are the fitted
engine's: ``compare``'s chance levels (:func:`~trebuchet.ingest.compare.chance_levels`) for
``reconstruct(method="fit")``.

The smoother's errors are many local ones, and ``compare`` learns their spread from simulated
logs. The fitted engine's errors are few and global: row ``r`` of a load errs by ``g_r·δx``,
the gradient of the load by the fitted vector times the vector's error ``δx ~ N(0, C)``, plus
a small part of its own (the smoothed residual, the events' times; taken independent from row
to row). So whole stretches of the shot leave the band together or not at all, and a dozen
simulated logs say little about how often: on the demo log the 12 runs' estimate took the
paper engine's own prediction for a difference in one quantity of ten, 40 runs in another.
Here the outside fraction's distribution is drawn directly, ``draws`` times, from that error
model; the levels are its quantiles as in ``compare``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from trebuchet.ingest.identification.result import LoadBand

__all__ = ["fit_chance_levels"]


def fit_chance_levels(measured: pd.DataFrame, band: LoadBand, windows: Mapping[str, pd.Index],
                      quantities: Sequence[str], *, band_sd: float = 2.0, level: float = 0.95,
                      seed: int = 0, draws: int = 4000) -> pd.DataFrame:
    """One row per quantity: ``quantity``, ``chance_fraction`` (the mean fraction of its
    ``windows`` rows a right prediction leaves the ±``band_sd`` band), ``chance_limit`` (its
    ``level`` quantile), ``chance_limit_all`` (the 1 − (1 − level) / n quantile of n
    quantities) and ``effective_samples`` (p(1 − p) / variance), as
    :func:`~trebuchet.ingest.compare.chance_levels` gives them; NaN for a quantity without
    its gradients or with fewer than two rows."""
    rng = np.random.default_rng(seed)
    C = np.asarray(band.covariance, dtype=float)
    vals, vecs = np.linalg.eigh(0.5 * (C + C.T))
    root = vecs * np.sqrt(np.clip(vals, 0.0, None))
    dx = root @ rng.standard_normal((C.shape[0], draws))
    rows = []
    for q in quantities:
        row = {"quantity": q, "chance_fraction": np.nan, "chance_limit": np.nan,
               "chance_limit_all": np.nan, "effective_samples": np.nan}
        where = measured.index.get_indexer(windows.get(q, pd.Index([])))
        where = where[where >= 0]
        if q in band.gradients and where.size >= 2:
            sd = measured[q + "_sd"].to_numpy(dtype=float)[where]
            error = band.gradients[q][:, where].T @ dx
            error += band.other_sd[q][where, None] * rng.standard_normal(error.shape)
            f = np.mean(np.abs(error) > band_sd * sd[:, None], axis=0)
            p, spread = float(np.mean(f)), float(np.var(f))
            row |= {"chance_fraction": p, "chance_limit": float(np.quantile(f, level)),
                    "chance_limit_all": float(np.quantile(
                        f, 1.0 - (1.0 - level) / len(quantities))),
                    "effective_samples": p * (1 - p) / spread if spread > 0 else np.nan}
        rows.append(row)
    return pd.DataFrame(rows)
