"""The same filter and smoother run through filterpy, one series at a time.

Reference for :mod:`trebuchet.ingest.kalman.batch` (tests compare the two) and the
``backend="filterpy"`` of :func:`trebuchet.ingest.smoothing.smooth.smooth`. filterpy 2.0.0:
``KalmanFilter.batch_filter`` (gaps as ``None``) and ``rts_smoother`` (four return
values), about 30k samples/s; it is imported here, lazily, because ``import filterpy``
takes about a second (docs/background.md, "Differentiating video angles").
"""

from __future__ import annotations

import numpy as np

from trebuchet.ingest.kalman.batch import StepModel


def filterpy_filter_smoother(
    z: np.ndarray,
    valid: np.ndarray,
    steps: StepModel,
    lam: float | np.ndarray,
    kick: float,
    r2: float,
    x0: np.ndarray,
    P0: np.ndarray,
) -> dict[str, np.ndarray]:
    """Filter and RTS-smooth one series with filterpy's ``KalmanFilter``.

    Arguments as one series of :func:`~trebuchet.ingest.kalman.batch.batch_kalman_filter`
    (``lam`` a number or one per step).
    Returns ``x``, ``P`` (filtered), ``xp``, ``Pp`` (predicted), ``xs``, ``Ps``
    (smoothed), ``loglik_terms`` (``log S + ν²/S`` per valid step, NaN at gaps).
    The smoother is given ``np.linalg.pinv``: at rest the predicted covariance is singular.
    """
    from filterpy.kalman import KalmanFilter

    k = steps.k
    kf = KalmanFilter(dim_x=k, dim_z=1)
    kf.x = np.asarray(x0, float).reshape(k, 1).copy()
    kf.P = np.asarray(P0, float).copy()
    kf.H = np.eye(1, k)
    kf.R = np.array([[r2]])
    Fs = [steps.F[i] for i in range(steps.n)]
    lam = np.broadcast_to(np.asarray(lam, float), (steps.n,))
    Qs = [lam[i] * steps.Q0[i] + kick * steps.G[i] for i in range(steps.n)]
    zs = [np.array([[v]]) if ok else None for v, ok in zip(z, valid, strict=True)]
    x, P, xp, Pp = kf.batch_filter(zs, Fs=Fs, Qs=Qs)
    xs, Ps, _, _ = kf.rts_smoother(x, P, Fs=Fs, Qs=Qs, inv=np.linalg.pinv)
    S = Pp[:, 0, 0] + r2
    nu = np.where(valid, z - xp[:, 0, 0], np.nan)
    return {
        "x": x[:, :, 0],
        "P": P,
        "xp": xp[:, :, 0],
        "Pp": Pp,
        "xs": xs[:, :, 0],
        "Ps": Ps,
        "loglik_terms": np.log(S) + nu * nu / S,
    }
