"""Does the fitted engine explain the shot? The residual check of a fit, and the covariance it
honestly allows.

Where the equations explain the angles, what is left of each angle after the fit is its
measurement noise: white, of the noise's size. Where they miss something (friction the scene
lacks, a length that is off), the misfit is a slow curve the noise rides on, so that
neighbouring frames' residuals agree. The check measures both, per angle, on the frames after
the trigger (the frames at rest are noise alone in any model):

- the lag-1 autocorrelation of the residuals ``ρ₁ = Σ r_k r_{k+1} / Σ r_k²`` over consecutive
  frames: about 0 ± 1/√n for white noise. The issue's measurement: right fits below 0.2 in 417
  of 420 logs, every mismatched fit 0.23 and above (a fit without the engine's friction took a
  12 % lighter counterweight at χ² 1.00: ρ₁ caught it, χ² did not). The limit is 0.2, or
  2.5/√n where fewer frames make chance larger;
- χ², the mean squared residual in units of the model-free noise sd
  (:mod:`.noise`): about 1; the limit is 2.

The covariance of the fitted vector is ``(JᵀJ)⁻¹`` of the weighted residuals' Jacobian (with
the precision of a release known to lie between two frames: the uniform's variance ``w²/12``;
without it the release's sd, about as large, spread through its correlations with ``I`` and
``M`` and made the loads' bands 1.3–2× too wide on the bench), inflated by ``max(1, χ²_ν)`` (a
noise larger than estimated) and by the residuals' correlation (neighbouring frames that share
their errors carry less than one frame's information each): ``1 + 2 Σ_k (1 − k/(K+1)) ρ_k``
over the first ``K`` lags (Bartlett's weights), at least 1.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

__all__ = ["ResidualCheck", "residual_check", "covariance", "autocorrelations",
           "LAG1_LIMIT", "CHI2_LIMIT", "INFLATION_LAGS"]

#: ρ₁ above this fails the check (or above 2.5/√n where that is larger).
LAG1_LIMIT = 0.2
#: χ² (per angle) above this fails the check.
CHI2_LIMIT = 2.0
#: Lags of the correlation inflation of the covariance.
INFLATION_LAGS = 5


@dataclass(frozen=True)
class ResidualCheck:
    """The residual check of a fit (module doc).

    ``lag1``, ``chi2``, ``frames``: per fitted angle, on the frames after the trigger;
    ``lag1_limit``: per angle, the limit its ρ₁ is held to; ``chi2_limit``; ``chi2_total``:
    ``Σ r² / (N − p)`` over every frame; ``inflation``: the factor the covariance was
    multiplied by; ``passed``."""

    lag1: Mapping[str, float]
    chi2: Mapping[str, float]
    frames: Mapping[str, int]
    lag1_limit: Mapping[str, float]
    chi2_limit: float
    chi2_total: float
    inflation: float
    passed: bool = field(init=False)

    def __post_init__(self) -> None:
        for name in ("lag1", "chi2", "frames", "lag1_limit"):
            object.__setattr__(self, name, MappingProxyType(dict(getattr(self, name))))
        ok = all(self.lag1[a] <= self.lag1_limit[a] and self.chi2[a] <= self.chi2_limit
                 for a in self.lag1)
        object.__setattr__(self, "passed", bool(ok))

    def __reduce__(self):
        """Pickled as its plain fields (mapping proxies do not pickle)."""
        return (ResidualCheck, (dict(self.lag1), dict(self.chi2), dict(self.frames),
                                dict(self.lag1_limit), self.chi2_limit, self.chi2_total,
                                self.inflation))

    @property
    def failing(self) -> tuple[str, ...]:
        """The angles whose ρ₁ or χ² is beyond its limit."""
        return tuple(a for a in self.lag1 if self.lag1[a] > self.lag1_limit[a]
                     or self.chi2[a] > self.chi2_limit)

    def describe(self) -> str:
        """One line: each angle's ρ₁ and χ², and the verdict."""
        parts = [f"{a} ρ₁ {self.lag1[a]:.2f}, χ² {self.chi2[a]:.2f}" for a in self.lag1]
        verdict = "passed" if self.passed else "FAILED"
        return (f"residual check {verdict} (limits ρ₁ {_limit_text(self.lag1_limit)}, "
                f"χ² {self.chi2_limit:g}): " + "; ".join(parts))


def _limit_text(limits: Mapping[str, float]) -> str:
    values = sorted(set(round(v, 2) for v in limits.values()))
    return "/".join(f"{v:g}" for v in values) or f"{LAG1_LIMIT:g}"


def autocorrelations(r: np.ndarray, lags: int) -> np.ndarray:
    """``ρ_1 … ρ_lags`` of the residual series ``r`` (consecutive frames; NaN = no frame),
    about zero: ``Σ r_k r_{k+l} / Σ r_k²`` over the pairs both present."""
    ok = np.isfinite(r)
    rr = np.where(ok, r, 0.0)
    denom = float(np.sum(rr * rr))
    out = np.zeros(lags)
    if denom <= 0.0:
        return out
    for lag in range(1, lags + 1):
        if lag >= r.size:
            break
        out[lag - 1] = float(np.sum(rr[lag:] * rr[:-lag])) / denom
    return out


def residual_check(residuals: Mapping[str, np.ndarray], n_total: int, n_params: int,
                   chi2_sum: float) -> ResidualCheck:
    """The check of a fit from each angle's normalised residuals on the frames after the
    trigger (``residuals[angle]``, consecutive frames, NaN in gaps), the number of residuals
    ``n_total`` and parameters ``n_params`` of the whole fit and its ``chi2_sum``."""
    lag1, chi2, frames, limits = {}, {}, {}, {}
    pooled = []
    for a, r in residuals.items():
        n = int(np.isfinite(r).sum())
        if n < 3:
            continue
        frames[a] = n
        rho = autocorrelations(r, INFLATION_LAGS)
        lag1[a] = float(rho[0])
        chi2[a] = float(np.nanmean(r * r))
        limits[a] = max(LAG1_LIMIT, 2.5 / math.sqrt(n))
        pooled.append((n, rho))
    weights = np.array([n for n, _ in pooled], dtype=float)
    rho = (np.average(np.array([p for _, p in pooled]), axis=0, weights=weights)
           if pooled else np.zeros(INFLATION_LAGS))
    k = np.arange(1, INFLATION_LAGS + 1)
    correlation = max(1.0, 1.0 + 2.0 * float(np.sum((1.0 - k / (INFLATION_LAGS + 1)) * rho)))
    chi2_total = chi2_sum / max(n_total - n_params, 1)
    return ResidualCheck(lag1=lag1, chi2=chi2, frames=frames, lag1_limit=limits,
                         chi2_limit=CHI2_LIMIT, chi2_total=chi2_total,
                         inflation=correlation * max(1.0, chi2_total))


def covariance(jac: np.ndarray, inflation: float, prior_sd: np.ndarray | None = None
               ) -> tuple[np.ndarray, float]:
    """``(JᵀJ / inflation + P)⁻¹``: the covariance of the weighted residuals' Jacobian ``jac``
    (N, p) inflated, with the precision ``P = diag(prior_sd⁻²)`` of what the fit knows besides
    the log's angles (``prior_sd``: inf where nothing; a release between two frames ``w`` s
    apart: ``w / √12``, the uniform's sd), and the condition number of the data's ``J`` (a
    direction the log does not move makes it huge). By the singular values of ``J`` stacked
    on ``√P``."""
    p = jac.shape[1]
    rows = [jac / math.sqrt(inflation)]
    if prior_sd is not None:
        with np.errstate(divide="ignore"):
            precision = np.where(np.isfinite(prior_sd), 1.0 / np.asarray(prior_sd), 0.0)
        rows.append(np.diag(precision))
    s_data = np.linalg.svd(jac, compute_uv=False)
    _, s, vt = np.linalg.svd(np.vstack(rows), full_matrices=False)
    if s.size == 0 or s[0] == 0.0:
        return np.full((p, p), np.inf), math.inf
    floor = s[0] * 1e-15
    cov = (vt.T / np.maximum(s, floor) ** 2) @ vt
    condition = float(s_data[0] / max(s_data[-1], s_data[0] * 1e-15)) if s_data[0] else math.inf
    return cov, condition
