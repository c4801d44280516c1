"""The Kalman filter's loop over the frames, compiled (numba).

:func:`~trebuchet.ingest.kalman.batch.batch_kalman_filter` runs many scalar series at once;
in numpy each frame costs a dozen small array operations whose overhead, on a 2 s log at
1000 fps, was about half of a reconstruction's time. Here the same predict-then-update
steps run as one compiled loop over frames and series (a few k × k products per step,
k = 3 or 4). The compiled code is cached beside this file (or in numba's user cache); numba
rebuilds it when this file changes (it calls nothing from other files). Where no cache folder
can be written (a read-only installation and home), it is compiled anew in each process
(about 2 s; set ``NUMBA_CACHE_DIR`` to a writable folder to keep it).
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["filter_steps"]


def _filter_steps(first, F, noise, moves, has_noise, valid, z, r2, x, P, S_hist, nu_hist,
                 store, xps, Pps):  # noqa: ANN001, ANN201 - numba
    """Steps ``first`` to ``n - 1`` of the filter, in place.

    ``F`` (n, k, k) transitions; ``noise`` (n, B, k, k) process noise of each step and series;
    ``moves``, ``has_noise`` (n,) bool: ``F`` is not the identity, ``noise`` is not zero;
    ``valid`` (n, B) bool; ``z`` (n, B) measurements of the first state (ignored where not
    valid); ``r2`` (B,) measurement variances; ``x`` (B, k), ``P`` (B, k, k) the state after
    step ``first - 1``, updated to the end. Each step: ``x = F x``, ``P = F P Fᵀ + noise``
    (where they apply), then with a measurement ``S = P₀₀ + r2``, ``K = P[:, 0] / S``,
    ``x += K ν``, ``P -= K P[0, :]`` (the simple form). Writes ``S_hist``, ``nu_hist`` (n, B)
    (ν = 0 at a gap) and, with ``store``, the predicted ``xps`` (n, B, k) and ``Pps``
    (n, B, k, k).
    """
    n, B = z.shape
    k = x.shape[1]
    xn = np.empty(k)
    T = np.empty((k, k))
    row = np.empty(k)
    for i in range(first, n):
        for b in range(B):
            if moves[i]:
                for a in range(k):
                    s = 0.0
                    for m in range(k):
                        s += F[i, a, m] * x[b, m]
                    xn[a] = s
                for a in range(k):
                    x[b, a] = xn[a]
                for a in range(k):
                    for c in range(k):
                        s = 0.0
                        for m in range(k):
                            s += F[i, a, m] * P[b, m, c]
                        T[a, c] = s
                for a in range(k):
                    for c in range(k):
                        s = 0.0
                        for m in range(k):
                            s += T[a, m] * F[i, c, m]
                        P[b, a, c] = s
            if has_noise[i]:
                for a in range(k):
                    for c in range(k):
                        P[b, a, c] += noise[i, b, a, c]
            S = P[b, 0, 0] + r2[b]
            S_hist[i, b] = S
            if store:
                for a in range(k):
                    xps[i, b, a] = x[b, a]
                    for c in range(k):
                        Pps[i, b, a, c] = P[b, a, c]
            if valid[i, b]:
                nu = z[i, b] - x[b, 0]
                for c in range(k):
                    row[c] = P[b, 0, c]
                for a in range(k):
                    gain = row[a] / S
                    x[b, a] += gain * nu
                    for c in range(k):
                        P[b, a, c] -= gain * row[c]
                nu_hist[i, b] = nu


def _compiled(function):  # noqa: ANN001, ANN202 - numba
    """``function`` compiled with an on-disk cache, or without one where numba finds no
    writable cache folder."""
    try:
        return numba.njit(cache=True, error_model="numpy")(function)
    except RuntimeError:  # "cannot cache function ...: no locator available"
        return numba.njit(error_model="numpy")(function)


filter_steps = _compiled(_filter_steps)
