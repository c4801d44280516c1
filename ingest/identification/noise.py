"""Each angle's measurement noise from the log alone, before any model: the weights of a fit.

The fourth difference of five consecutive frames ``Δ⁴z = z₋₂ − 4 z₋₁ + 6 z₀ − 4 z₁ + z₂``
of white noise of sd σ has sd ``√70 σ``; of a smooth motion sampled every ``h`` s it is
``h⁴ z⁗``, a small fraction of the noise except on the few frames where the accelerations
turn fastest (the small fast engine at 120 fps: about a tenth of a 1° noise's at its peak).
The median absolute value of the fourth differences (1.4826 × MAD, robust to those few
frames and to a tracker's outliers) over runs of evenly spaced frames gives σ. Measured on
the identification bench's logs (white noise 0.1–1°, 120–480 fps): within a few per cent of
the noise put in.

Being model-free, it makes the fit's χ² a test of the model: about 1 where the equations
explain the angles, more where they do not.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["difference_noise_sd", "DIFFERENCE_WEIGHTS"]

#: Weights of the fourth difference; their squares sum to 70.
DIFFERENCE_WEIGHTS = np.array([1.0, -4.0, 6.0, -4.0, 1.0])


def difference_noise_sd(t: np.ndarray, z: np.ndarray, *, step_tolerance: float = 0.01
                        ) -> float:
    """Noise sd of the angle ``z`` (rad; NaN gaps) sampled at ``t`` (s), from the fourth
    differences of five consecutive tracked frames whose steps agree within
    ``step_tolerance`` (relative). NaN where fewer than 8 such differences exist."""
    t = np.asarray(t, dtype=float)
    z = np.asarray(z, dtype=float)
    if t.size < 5:
        return math.nan
    windows_z = np.lib.stride_tricks.sliding_window_view(z, 5)
    steps = np.diff(np.lib.stride_tricks.sliding_window_view(t, 5), axis=1)
    even = np.all(np.abs(steps - steps[:, :1]) <= step_tolerance * steps[:, :1], axis=1)
    ok = even & np.all(np.isfinite(windows_z), axis=1)
    if ok.sum() < 8:
        return math.nan
    d = windows_z[ok] @ DIFFERENCE_WEIGHTS
    return float(1.4826 * np.median(np.abs(d)) / math.sqrt(70.0))
