"""The state-space model of the batched Kalman filter and its results: polynomial transition
matrices, the discretised white noise, the per-step matrices shared by a batch of series,
and the filter's and the smoother's outputs (see :mod:`.batch`)."""

from __future__ import annotations

from dataclasses import dataclass
from math import factorial

import numpy as np

__all__ = ["polynomial_transition", "white_noise_covariance", "matrix_root", "StepModel",
           "FilterResult", "SmootherResult", "LoglikSums"]


def polynomial_transition(k: int, dt: np.ndarray) -> np.ndarray:
    """Transition matrices ``F(dt)`` of a ``k``-state polynomial (Taylor) model.

    ``F[i, j] = dt**(j - i) / (j - i)!`` for ``j >= i``. ``dt`` in the caller's time
    unit, shape ``(n,)``; returns ``(n, k, k)``.
    """
    dt = np.asarray(dt, dtype=float)
    F = np.zeros(dt.shape + (k, k))
    for i in range(k):
        for j in range(i, k):
            F[..., i, j] = dt ** (j - i) / factorial(j - i)
    return F


def white_noise_covariance(k: int, dt: np.ndarray) -> np.ndarray:
    """Exact discretised covariance of white noise (unit spectral density) on the last state.

    Identical to filterpy's ``Q_continuous_white_noise(k, dt, 1.0)`` (k = 2, 3, 4), for an
    array of ``dt``: ``Q[i, j] = dt**(2k-1-i-j) / ((k-1-i)! (k-1-j)! (2k-1-i-j))``.
    Returns ``(n, k, k)``; multiply by the spectral density ``q`` (rad²/s⁵ for k = 3).
    """
    dt = np.asarray(dt, dtype=float)
    Q = np.empty(dt.shape + (k, k))
    for i in range(k):
        for j in range(k):
            a, b = k - 1 - i, k - 1 - j
            p = a + b + 1
            Q[..., i, j] = dt**p / (factorial(a) * factorial(b) * p)
    return Q


def matrix_root(C: np.ndarray) -> np.ndarray:
    """A square root ``R`` (``R Rᵀ = C``) of each symmetric positive semi-definite matrix of
    ``C`` (..., k, k): ``V √w`` from its eigenvectors ``V`` and eigenvalues ``w`` (negative
    round-off clipped to 0), each eigenvector's sign fixed (its largest component
    positive). LAPACK's sign is arbitrary and flips under a change of ``C`` in its last
    bit: a draw ``R ε`` would then flip with it, and a band calibrated on a few draws
    moved by up to 12 % on a shipped sample for a release time 4e-16 s later. A matrix equal
    to the one before it in the stack is not decomposed again (a log's steps come in runs
    of equal intervals)."""
    C = np.asarray(C, dtype=float)
    if C.ndim > 2 and C.shape[0] > 1:
        flat = C.reshape(-1, C.shape[-2] * C.shape[-1])
        new = np.r_[True, np.any(flat[1:] != flat[:-1], axis=1)]
        if not new.all():
            roots = matrix_root(flat[new].reshape((-1,) + C.shape[-2:]))
            return roots[np.cumsum(new) - 1].reshape(C.shape)
    w, v = np.linalg.eigh(C)
    big = np.take_along_axis(v, np.argmax(np.abs(v), axis=-2)[..., None, :], axis=-2)
    v = v * np.where(big < 0.0, -1.0, 1.0)
    return v * np.sqrt(np.clip(w, 0.0, None))[..., None, :]


@dataclass(frozen=True)
class StepModel:
    """Per-step matrices shared by all series of a batch (``n`` steps, ``k`` states).

    Step ``i`` predicts from the time of frame ``i-1`` to frame ``i`` (step 0 is the prior
    at frame 0: ``F[0] = I``, ``Q0[0] = 0``). Process noise of series ``b`` at step ``i`` is
    ``lam[b] * Q0[i] + kick[b] * G[i]``: ``Q0`` the unit white-noise covariance (zero
    at rest), ``G`` the unit covariance of a jump (a "kick") in acceleration at an event
    between the frames, carried to frame ``i``.
    """

    F: np.ndarray  # (n, k, k)
    Q0: np.ndarray  # (n, k, k)
    G: np.ndarray  # (n, k, k)

    @property
    def n(self) -> int:
        return self.F.shape[0]

    @property
    def k(self) -> int:
        return self.F.shape[-1]

    def stretch(self, lo: int, hi: int) -> StepModel:
        """Steps ``lo .. hi-1`` (to run the filter on from the filtered state at ``lo-1``)."""
        return StepModel(self.F[lo:hi], self.Q0[lo:hi], self.G[lo:hi])


@dataclass(frozen=True)
class FilterResult:
    """Output of :func:`~.batch.batch_kalman_filter`, histories indexed ``[step, series, ...]``.

    ``S`` the innovation variance and ``nu`` the innovation (0 at gaps) at every step;
    with ``store=True`` also ``xp``/``Pp`` (state and covariance after the prediction)
    and ``gain`` (Kalman gain, zero at gaps), which :func:`~.batch.backward_smoother`
    needs. ``x_end``/``P_end``: the filtered state (B, k) and covariance (B, k, k) after
    the last step, to continue the filter on a following stretch of steps.
    """

    S: np.ndarray
    nu: np.ndarray
    xp: np.ndarray | None = None
    Pp: np.ndarray | None = None
    gain: np.ndarray | None = None
    x_end: np.ndarray | None = None
    P_end: np.ndarray | None = None

    def series(self, index: np.ndarray) -> FilterResult:
        """The result for the series ``index`` only (e.g. one grid point per angle)."""
        def pick(a: np.ndarray | None, axis: int) -> np.ndarray | None:
            return None if a is None else np.take(a, index, axis=axis)

        return FilterResult(pick(self.S, 1), pick(self.nu, 1), pick(self.xp, 1),
                            pick(self.Pp, 1), pick(self.gain, 1), pick(self.x_end, 0),
                            pick(self.P_end, 0))

    def loglik_sums(self, weight: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``Σ w log S``, ``Σ w ν²/S`` and ``Σ w`` per series; ``weight`` (B, n), 0 at gaps."""
        w = np.asarray(weight, float).T
        ok = self.S > 0.0  # lost positive definiteness (round-off at extreme λ): NaN sums
        log_s = np.log(np.where(ok, self.S, 1.0)) + np.where(ok, 0.0, np.nan)
        return (
            (w * log_s).sum(axis=0),
            (w * self.nu**2 / self.S).sum(axis=0),
            w.sum(axis=0),
        )


@dataclass(frozen=True)
class LoglikSums:
    """Output of :func:`~.batch.filter_loglik`: per series (B,) ``Σ w log S`` (``log_s``),
    ``Σ w ν²/S`` (``nu2_s``) and ``Σ w`` (``count``), and the filtered state after the last
    step ``x_end`` (B, k), ``P_end`` (B, k, k)."""

    log_s: np.ndarray
    nu2_s: np.ndarray
    count: np.ndarray
    x_end: np.ndarray
    P_end: np.ndarray


@dataclass(frozen=True)
class SmootherResult:
    """Output of :func:`~.batch.backward_smoother`, indexed ``[step, series, ...]``.

    ``x``, ``P``: smoothed state and covariance. ``r``, ``N``: for a jump ``d·Δ`` added to
    the state at step ``i`` (between frames ``i-1`` and ``i``, ``d`` in the state at frame
    ``i``) the score is ``d·r[i]`` and the information ``dᵀ N[i] d``: the maximum-
    likelihood jump is ``Δ = d·r / dᵀNd``, and ``(d·r)² / dᵀNd`` the likelihood-ratio
    statistic (χ², 1 degree of freedom per series, when there is no jump).
    """

    x: np.ndarray
    P: np.ndarray
    r: np.ndarray
    N: np.ndarray
