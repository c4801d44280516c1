"""Synthetic angle logs with exact derivatives, for testing and measuring the smoother.

Not a trebuchet simulation (that is ``trebuchet.model``): each angle rests until the
trigger, then follows ``c + a s²/2 + A (1 - cos ω s)`` (``s`` time since the trigger),
whose acceleration jumps from 0 to ``a + A ω²`` at the trigger, and jumps again by
``jump`` at the release. Magnitudes are trebuchet-like (accelerations of 10–100 rad/s²).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from trebuchet.ingest.smoothing.smooth import ANGLES


@dataclass(frozen=True)
class AngleShape:
    """One angle: rest value ``c`` (rad), ``a`` (rad/s²), ``A`` (rad), ``omega`` (rad/s),
    ``jump`` (rad/s², change of acceleration at the release)."""

    c: float
    a: float
    A: float
    omega: float
    jump: float


SHAPES: dict[str, AngleShape] = {
    "theta": AngleShape(-0.87, 2.0, 0.3, 6.0, -4.0),
    "psi": AngleShape(-1.57, -3.0, 1.2, 8.0, 15.0),
    "phi": AngleShape(-3.14, 5.0, 2.0, 7.0, -30.0),
}


def exact_angles(
    t: np.ndarray, trigger: float, release: float | None, shapes: dict[str, AngleShape] = SHAPES
) -> pd.DataFrame:
    """True angles (rad), rates (rad/s), accelerations (rad/s²) at times ``t`` (s)."""
    s = np.maximum(t - trigger, 0.0)
    moving = t > trigger
    out = {"t": t}
    for name in ANGLES:
        p = shapes[name]
        c, sn = np.cos(p.omega * s), np.sin(p.omega * s)
        x = p.c + p.a * s**2 / 2 + p.A * (1 - c)
        v = p.a * s + p.A * p.omega * sn
        acc = np.where(moving, p.a + p.A * p.omega**2 * c, 0.0)
        if release is not None:
            u = np.maximum(t - release, 0.0)
            x = x + p.jump * u**2 / 2
            v = v + p.jump * u
            acc = acc + np.where(t > release, p.jump, 0.0)
        out[name] = x
        out[name + "_d"] = v
        out[name + "_dd"] = acc
    return pd.DataFrame(out)


def synthetic_log(
    fps: float,
    noise_deg: float,
    *,
    duration: float = 2.0,
    trigger: float = 0.3,
    release: float | None = 1.3,
    drop_fraction: float = 0.0,
    jitter: float = 0.0,
    seed: int = 0,
    shapes: dict[str, AngleShape] = SHAPES,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """A noisy log (``t``, theta, psi, phi; NaN for dropped frames) and the exact truth.

    ``noise_deg``: Gaussian noise sd (degrees) on every angle; ``drop_fraction``: frames
    dropped at random per angle; ``jitter``: frame-time jitter as a fraction of the frame
    interval (uniform, keeps times increasing).
    """
    rng = np.random.default_rng(seed)
    n = int(round(duration * fps)) + 1
    t = np.arange(n) / fps
    if jitter:
        t = t + rng.uniform(-jitter / 2, jitter / 2, n) / fps
    truth = exact_angles(t, trigger, release, shapes)
    log = pd.DataFrame({"t": t})
    for name in ANGLES:
        z = truth[name].to_numpy() + rng.normal(0.0, np.deg2rad(noise_deg), n)
        z[rng.random(n) < drop_fraction] = np.nan
        log[name] = z
    return log, truth
