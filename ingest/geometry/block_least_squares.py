"""Robust least squares for a few global parameters and many small blocks (bundle style).

The calibration's unknowns are ``ng`` global parameters (the camera, the markers' offsets)
and one block of ``b`` angles per frame, which touches only that frame's residuals. Its
normal matrix ``JᵀJ = [[U, W], [Wᵀ, V]]`` has a block-diagonal ``V`` (n blocks b×b), so a
Levenberg–Marquardt step is solved through the Schur complement (Triggs et al., "Bundle
adjustment — a modern synthesis", Section 6.1)::

    (U − W V⁻¹ Wᵀ) δg = −∇g + W V⁻¹ ∇a          (ng × ng, dense)
    δa_f = −V_f⁻¹ (∇a_f + W_fᵀ δg)                (b × b per frame)

in a time linear in the frames, where a general sparse solver (``scipy.optimize.
least_squares`` with ``lsmr``) needs many inner iterations per step. The loss is scipy's
soft-L1, ``ρ(z) = 2 (√(1 + z) − 1)`` on ``z = (r / f)²``, by iteratively reweighted least
squares (weights ``ρ'(z) = 1/√(1 + z)``), so the cost is the one ``least_squares``
minimises: ``½ f² Σ ρ((r/f)²)``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.sparse as sp

__all__ = ["RowBlocks", "BlockSolution", "soft_l1_cost", "block_least_squares",
           "normal_blocks"]


@dataclass(frozen=True)
class RowBlocks:
    """A Jacobian by kinds of rows, in this order: ``k`` *dense* rows with global part
    ``Jg`` (k, ng) and block part ``Ja`` (k, b) on block ``frame`` (k,); block-only rows
    ``Ba`` (kb, b) on blocks ``bframe`` (kb,); *prior* rows with one global entry each
    (``prior_cols``, ``prior_vals``); ``n b`` rows with ``weak`` on each block parameter."""

    Jg: np.ndarray
    Ja: np.ndarray
    frame: np.ndarray
    Ba: np.ndarray
    bframe: np.ndarray
    prior_cols: np.ndarray
    prior_vals: np.ndarray
    weak: float
    ng: int
    n: int

    @property
    def b(self) -> int:
        return self.Ja.shape[1]

    @property
    def n_rows(self) -> int:
        return self.Jg.shape[0] + self.Ba.shape[0] + self.prior_cols.size + self.n * self.b

    def matrix(self) -> sp.csr_matrix:
        """The Jacobian as a sparse matrix (globals first, then the blocks)."""
        k, ng, b, n = self.Jg.shape[0], self.ng, self.b, self.n
        kb, kp = self.Ba.shape[0], self.prior_cols.size
        r = np.arange(k)
        rows = [np.repeat(r, ng), np.repeat(r, b), np.repeat(k + np.arange(kb), b),
                k + kb + np.arange(kp), k + kb + kp + np.arange(n * b)]
        cols = [np.tile(np.arange(ng), k), (ng + b * self.frame[:, None] + np.arange(b)).ravel(),
                (ng + b * self.bframe[:, None] + np.arange(b)).ravel(), self.prior_cols,
                ng + np.arange(n * b)]
        vals = [self.Jg.ravel(), self.Ja.ravel(), self.Ba.ravel(), self.prior_vals,
                np.full(n * b, self.weak)]
        return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows),
                                                     np.concatenate(cols))),
                             shape=(self.n_rows, ng + n * b))

    def normal(self, w: np.ndarray, r: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``U`` (ng, ng), ``W`` (n, ng, b), ``V`` (n, b, b) of ``(D J)ᵀ (D J)`` and the
        gradient ``(D J)ᵀ D r`` split as (ng,), (n, b), for row weights ``D = diag(w)``:
        each block's sums by a sparse indicator product, never the whole ``JᵀJ``."""
        k, b, n = self.Jg.shape[0], self.b, self.n
        kb, kp = self.Ba.shape[0], self.prior_cols.size
        w1, wr1 = w[:k, None], (w * w * r)[:k]
        Jg, Ja = self.Jg * w1, self.Ja * w1
        P = sp.csr_matrix((np.ones(k), (self.frame, np.arange(k))), shape=(n, k))
        U = np.einsum("ki,kj->ij", Jg, Jg)     # einsum, not BLAS: its threads cost more here
        W = np.stack([P @ (Jg * Ja[:, j:j + 1]) for j in range(b)], axis=-1)  # (n, ng, b)
        V = (P @ (Ja[:, :, None] * Ja[:, None, :]).reshape(k, b * b)).reshape(n, b, b)
        gg = np.einsum("ki,k->i", self.Jg, wr1)
        ga = P @ (self.Ja * wr1[:, None])
        if kb:
            w2 = w[k:k + kb, None]
            Ba = self.Ba * w2
            Q = sp.csr_matrix((np.ones(kb), (self.bframe, np.arange(kb))), shape=(n, kb))
            V = V + (Q @ (Ba[:, :, None] * Ba[:, None, :]).reshape(kb, b * b)).reshape(n, b, b)
            ga = ga + Q @ (self.Ba * (w * w * r)[k:k + kb, None])
        wp = w[k + kb:k + kb + kp] * self.prior_vals
        np.add.at(U, (self.prior_cols, self.prior_cols), wp * wp)
        np.add.at(gg, self.prior_cols, wp * w[k + kb:k + kb + kp] * r[k + kb:k + kb + kp])
        ww = (w[k + kb + kp:] * self.weak).reshape(n, b)
        V = V + ww[:, :, None] ** 2 * np.eye(b)
        ga = ga + ww * w[k + kb + kp:].reshape(n, b) * r[k + kb + kp:].reshape(n, b)
        return U, W, V, gg, ga


@dataclass(frozen=True)
class BlockSolution:
    """Result of :func:`block_least_squares`, named as scipy's ``OptimizeResult``: ``x``,
    ``cost`` (½ f² Σ ρ), ``jac`` (the Jacobian at ``x`` with rows scaled by √ρ', so that
    ``JᵀJ`` is the Gauss–Newton Hessian of the cost), ``nfev``, ``njev``, ``success``,
    ``message``, ``normal`` (U, W, V of that ``JᵀJ``; ``jac`` is built from the blocks on
    first use)."""

    x: np.ndarray
    cost: float
    normal: tuple[np.ndarray, np.ndarray, np.ndarray]
    nfev: int
    njev: int
    success: bool
    message: str
    blocks: RowBlocks
    weights: np.ndarray

    @cached_property
    def jac(self) -> sp.csr_matrix:
        return (sp.diags(self.weights) @ self.blocks.matrix()).tocsr()


def soft_l1_cost(r: np.ndarray, f_scale: float) -> float:
    """``½ f² Σ 2 (√(1 + (r/f)²) − 1)``."""
    z = (r / f_scale) ** 2
    return float(f_scale ** 2 * np.sum(np.sqrt(1.0 + z) - 1.0))


def normal_blocks(J: sp.spmatrix, ng: int, n: int, b: int
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``U`` (ng, ng), ``W`` (n, ng, b), ``V`` (n, b, b) of ``JᵀJ`` for parameters ordered
    as ng globals then n blocks of b."""
    J = sp.csr_matrix(J)
    JtJ = (J.T @ J).tocsr()
    U = JtJ[:ng, :ng].toarray()
    W = JtJ[:ng, ng:].toarray().reshape(ng, n, b).transpose(1, 0, 2)
    A = JtJ[ng:, ng:]
    V = np.zeros((n, b, b))
    base = b * np.arange(n)
    for i in range(b):
        for j in range(b):
            d = A.diagonal(j - i)                                 # entries (m, m + j − i)
            V[:, i, j] = d[base + min(i, j)]
    return U, W, V


def _step(U: np.ndarray, W: np.ndarray, V: np.ndarray, gg: np.ndarray, ga: np.ndarray,
          lam: float) -> tuple[np.ndarray, np.ndarray]:
    """The damped Gauss–Newton step (δg, δa) through the Schur complement; ``W`` (n, ng, b).
    """
    n, ng, b = W.shape
    eye = np.eye(b)
    Vd = V + lam * (V * eye) + 1e-12 * eye                        # Marquardt damping
    Ud = U + lam * np.diag(np.diag(U)) + 1e-12 * np.eye(ng)
    Vinv = np.linalg.inv(Vd)                                      # V_f⁻¹
    WV = W @ Vinv                                                 # W_f V_f⁻¹, (n, ng, b)
    S = Ud - np.einsum("fgj,fhj->gh", WV, W)                      # U − Σ W_f V_f⁻¹ W_fᵀ
    rhs = -gg + np.einsum("fgj,fj->g", WV, ga)                     # −∇g + W V⁻¹ ∇a
    dg = np.linalg.lstsq(S, rhs, rcond=None)[0] if ng else np.zeros(0)
    da = -(Vinv @ (ga + (W.transpose(0, 2, 1) @ dg))[:, :, None])[:, :, 0]
    return dg, da


def block_least_squares(fun: Callable[[np.ndarray], np.ndarray],
                        blocks: Callable[[np.ndarray], RowBlocks], x0: np.ndarray, ng: int,
                        b: int = 3, f_scale: float = 3.0, max_iter: int = 100,
                        ftol: float = 1e-10, xtol: float = 1e-10) -> BlockSolution:
    """Minimise ``½ f² Σ ρ((fun(x)/f)²)`` (soft-L1) from ``x0``, whose first ``ng`` entries
    are global and the rest blocks of ``b``, with the Jacobian's :class:`RowBlocks` from
    ``blocks`` (see the module doc). Stops when the cost drops by less than ``ftol`` of
    itself or the step is below ``xtol`` of ``x``."""
    x = np.asarray(x0, dtype=float).copy()
    r = fun(x)
    cost = soft_l1_cost(r, f_scale)
    lam, nfev, njev = 1e-3, 1, 0
    message, success = "the maximum number of iterations is reached", False
    for _ in range(max_iter):
        w = 1.0 / np.sqrt(np.sqrt(1.0 + (r / f_scale) ** 2))       # √ρ'
        U, W, V, gg, ga = blocks(x).normal(w, r)
        njev += 1
        improved = False
        while lam < 1e10:
            dg, da = _step(U, W, V, gg, ga, lam)
            dx = np.concatenate([dg, da.ravel()])
            x_new = x + dx
            r_new = fun(x_new)
            nfev += 1
            cost_new = soft_l1_cost(r_new, f_scale)
            if np.isfinite(cost_new) and cost_new <= cost:
                improved = True
                break
            lam *= 4.0
        if not improved:
            message, success = "no step lowers the cost", True
            break
        drop = cost - cost_new
        x, r, cost = x_new, r_new, cost_new
        lam = max(lam / 3.0, 1e-9)
        if drop <= ftol * cost:
            message, success = "`ftol` termination condition is satisfied", True
            break
        if np.linalg.norm(dx) <= xtol * (xtol + np.linalg.norm(x)):
            message, success = "`xtol` termination condition is satisfied", True
            break
    w = 1.0 / np.sqrt(np.sqrt(1.0 + (r / f_scale) ** 2))
    rb = blocks(x)
    U, W, V, _, _ = rb.normal(w, r)
    return BlockSolution(x, cost, (U, W, V), nfev, njev + 1, success, message, rb, w)
