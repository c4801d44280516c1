"""Resolution advisory: where a load's uncertainty exceeds a tenth of its peak, and what
frame rate or angle noise would resolve it.

The smoother's covariance depends on the data only through the process noise ``q``
(fixed by the motion), the measurement noise ``r`` and the frame interval ``T``. For
a constant-acceleration smoother in steady state its bandwidth is
``ω_c ≈ (q / (r² T))^(1/6)`` and the covariance of derivatives ``i`` and ``j``
(0 angle, 1 rate, 2 acceleration) scales as ``(r² T)^((5 − i − j)/6)``: the acceleration
sd only as ``(r² T)^(1/12)``, the rate sd as ``(r² T)^(1/4)``. A load's linear variance
split by ``i + j`` (:mod:`~trebuchet.ingest.uncertainty`) therefore scales as
``Σ_k v_k s^((5 − k)/6)`` when ``r² T`` is multiplied by ``s``; the rest of the variance
(second order, bias) is scaled as the rates' variance, ``s^(1/2)``. The advisory finds the
``s`` that brings the sd down to the limit and reports ``fps / s`` (same noise) and
``noise · √s`` (same frame rate). Event-time uncertainty (trigger, release) is not
scaled: it shrinks only with the frame interval, on the few frames next to the event.

A band says how far a load may be off, not that the smoother flattened it: a peak shorter
than the smoother's time constant comes out low inside a band that looks right
(:func:`peak_width_advisories` compares each load's peak width with the smoother's bandwidth
``ω_c / 2π`` there and speaks where the peak is likely flattened).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from trebuchet.ingest.scene_fit import row_ranges

__all__ = ["Advisory", "resolution_advisories", "ADVISED", "smoother_bandwidth",
           "peak_width_advisories", "PEAK_CONSTANT", "PEAK_FLATTENING", "PEAK_ADVISED"]

#: Loads the advisory speaks about: column of the value, its label.
ADVISED: dict[str, str] = {
    "F_R_abs": "|F_R|", "F_H_abs": "|F_H|", "F_S_abs": "|F_S|", "F_CM_abs": "|F_CM|",
    "torque": "torque",
}

#: Beyond this factor of r² T the advice is "not reachable by camera alone".
S_FLOOR = 1e-6


@dataclass(frozen=True)
class Advisory:
    """One load whose sd exceeds ``fraction`` of its peak somewhere.

    ``quantity`` column name, ``label``; ``peak`` (the load's unit) over the moving rows;
    ``worst_sd`` and ``worst_t`` (s, log time) of the largest sd; ``rows`` the rows
    (positions) concerned; ``fps_needed`` (1/s) at the log's noise and
    ``noise_needed_deg`` (°) at the log's frame rate, None when no camera change within
    ``1/S_FLOOR`` of ``r² T`` would do; ``message`` one sentence."""

    quantity: str
    label: str
    peak: float
    worst_sd: float
    worst_t: float
    rows: tuple[int, ...]
    fps_needed: float | None
    noise_needed_deg: float | None
    message: str


def _required_scale(by_order: np.ndarray, rest: np.ndarray, limit: float) -> float | None:
    """Largest ``s ≤ 1`` with ``√(Σ v_k s^((5−k)/6) + rest s^½) ≤ limit`` on every row
    (arrays (5, m) and (m,)); None if even ``S_FLOOR`` does not reach it."""
    powers = (5.0 - np.arange(5)) / 6.0

    def worst(s: float) -> float:
        var = (by_order * s ** powers[:, None]).sum(axis=0) + rest * np.sqrt(s)
        return float(np.sqrt(np.max(np.clip(var, 0.0, None))))

    if worst(S_FLOOR) > limit:
        return None
    lo, hi = np.log(S_FLOOR), 0.0
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        if worst(float(np.exp(mid))) <= limit:
            lo = mid
        else:
            hi = mid
    return float(np.exp(lo))


def resolution_advisories(t: np.ndarray, moving: np.ndarray, values: dict[str, np.ndarray],
                          sd: dict[str, np.ndarray], by_order: dict[str, np.ndarray],
                          event_var: dict[str, np.ndarray], fps: float, noise_deg: float,
                          fraction: float = 0.1, lines: np.ndarray | None = None
                          ) -> list[Advisory]:
    """Advisories for the loads of :data:`ADVISED` present in ``values``.

    ``t`` (n,) log time (s); ``moving`` (n,) rows of the shot (after the trigger);
    ``values``/``sd`` (n,) per column; ``by_order`` (5, n) linear variance by derivative
    order; ``event_var`` (n,) the variance from event-time uncertainty (included in
    ``sd``); ``fps`` (1/s); ``noise_deg`` (°) the angles' measurement noise."""
    out: list[Advisory] = []
    for col, label in ADVISED.items():
        if col not in values:
            continue
        v, s = values[col], sd[col]
        ok = moving & np.isfinite(v) & np.isfinite(s)
        if not ok.any():
            continue
        peak = float(np.max(np.abs(v[ok])))
        limit = fraction * peak
        bad = np.flatnonzero(ok & (s > limit))
        if peak == 0.0 or bad.size == 0:
            continue
        w = bad[np.argmax(s[bad])]
        ev = event_var.get(col, np.zeros_like(s))
        lin = by_order[col][:, bad]
        rest = np.clip(s[bad] ** 2 - lin.sum(axis=0) - ev[bad], 0.0, None)
        only_events = bool(np.all(np.sqrt(np.clip(s[bad] ** 2 - ev[bad], 0, None)) <= limit))
        scale = None if only_events else _required_scale(lin, rest, limit)
        where = row_ranges(bad, t, lines=lines)
        head = (f"{label}: sd up to {s[w]:.3g} (at t = {t[w]:.4g} s) exceeds "
                f"{fraction:.0%} of its peak {peak:.3g} on {bad.size} rows, {where}")
        if only_events:
            fps_needed = noise_needed = None
            tail = ("; only next to an event (trigger, release), whose time is known to "
                    "about a frame: a higher frame rate narrows it")
        elif scale is None:
            fps_needed = noise_needed = None
            tail = (f"; the camera cannot resolve it (more than {1 / S_FLOOR:.0e} times "
                    "the frame rate or a thousandth of the noise would be needed): the "
                    "accelerations change faster than the frames")
        else:
            fps_needed = fps / scale
            noise_needed = noise_deg * np.sqrt(scale)
            tail = (f"; about {fps_needed:.3g} fps at this noise ({noise_deg:.2g}°), or "
                    f"angle noise ≤ {noise_needed:.2g}° at {fps:.3g} fps, would resolve it")
        out.append(Advisory(col, label, peak, float(s[w]), float(t[w]),
                            tuple(int(i) for i in bad), fps_needed, noise_needed,
                            head + tail))
    return out


# ----------------------------------------------------------------------------- short peaks

#: The flattening model's constant ``c`` (:func:`peak_width_advisories`).
PEAK_CONSTANT = 0.12
#: A peak expected to come out lower than this fraction warns.
PEAK_FLATTENING = 0.07
#: The loads whose peak the beam's acceleration pulse makes (the bearing's and the hinge's,
#: mostly centripetal there): the flattening model holds for them. The sling force's peak
#: follows φ̇, the torque's and F_CM's are differences of larger terms, and on the paper's
#: engine the model put them 4–10 % low where they came out within 2.4 %.
PEAK_ADVISED = ("F_R_abs", "F_H_abs")


def smoother_bandwidth(noise: Mapping[str, Mapping[str, Any]], t: np.ndarray
                       ) -> np.ndarray | None:
    """The smoother's bandwidth (Hz, per frame) for the beam's angle θ (else ψ, else φ: the
    beam's acceleration pulse is what a short peak is made of):
    ``f_c = (q / (r² T))^(1/6) / 2π`` for the constant-acceleration smoother in steady state
    (module doc), with the angle's process noise at each frame (``q_frames``, else its one
    ``q``; rad²/s⁵), its noise sd ``r_sd`` (rad) and the frame interval ``T`` (s). None
    without noise fits."""
    T = float(np.median(np.diff(t))) if t.size > 1 else float("nan")
    for angle in ("theta", "psi", "phi"):
        fit = noise.get(angle)
        if fit is None:
            continue
        q = fit.get("q_frames")
        q = np.full(t.size, float(fit.get("q", np.nan))) if q is None else np.asarray(q)
        r = float(fit.get("r_sd", np.nan))
        if q.shape != t.shape or not (np.isfinite(r) and r > 0 and T > 0):
            continue
        with np.errstate(invalid="ignore"):
            return (q / (r * r * T)) ** (1.0 / 6.0) / (2.0 * np.pi)
    return None


def _half_width(t: np.ndarray, v: np.ndarray, k: int) -> float:
    """Width (s) at half height of the peak of ``v`` (≥ 0) at row ``k``, the crossings
    interpolated between rows."""
    half = 0.5 * v[k]
    edges = []
    for step in (-1, 1):
        i = k
        while 0 <= i + step < v.size and np.isfinite(v[i + step]) and v[i + step] > half:
            i += step
        j = i + step
        if 0 <= j < v.size and np.isfinite(v[j]):
            edges.append(t[i] + (t[j] - t[i]) * (v[i] - half) / (v[i] - v[j]))
        else:
            edges.append(t[i])
    return float(abs(edges[1] - edges[0]))


def peak_width_advisories(t: np.ndarray, moving: np.ndarray, values: dict[str, np.ndarray],
                          bandwidth: np.ndarray | None, fps: float, noise_deg: float,
                          limit: float = PEAK_FLATTENING, lines: np.ndarray | None = None
                          ) -> list[Advisory]:
    """Advisories for the loads of :data:`PEAK_ADVISED` whose highest peak is too short for the
    smoother. A Gaussian pulse through a Gaussian filter: the smoothed peak, ``σ_s`` s wide
    (its width at half height / 2.355, as smoothed), is the pulse's ``σ_p`` and the filter's
    ``σ_f = c / f_c`` added in quadrature, so it comes out lower by
    ``1 − σ_p/σ_s = 1 − √(1 − (c / (σ_s f_c))²)``, with ``f_c`` the smoother's bandwidth at
    the peak (:func:`smoother_bandwidth`). ``c`` = :data:`PEAK_CONSTANT` is the issue's
    measurement refitted: on the small fast engine (|F_R|'s peak 25 ms wide) at 0.3–1° and
    120–480 fps, smoothed 31–43 ms wide under 11–18 Hz, it came out 11–28 % low (c 0.11–0.14;
    its ±2 sd band held it in 0–10 % of logs while the whole shot's bands read 93 %); at 0.1°
    and 240 fps 3–4 % low (c ≈ 0.08); the paper's engine and the bench's small engine 0–7 %
    low (c 0–0.17). The band does not show that bias, so the advisory speaks where it
    exceeds ``limit`` (:data:`PEAK_FLATTENING`), with the frame rate (``f_c`` ∝
    ``T^(−1/6)``) or noise (∝ ``r^(−1/3)``) that would bring it to ``limit``. ``values``
    (n,) per column, ``bandwidth`` (n,) Hz; times s."""
    out: list[Advisory] = []
    if bandwidth is None:
        return out
    x_limit = float(np.sqrt(1.0 - (1.0 - limit) ** 2))
    for col in PEAK_ADVISED:
        if col not in values:
            continue
        label = ADVISED[col]
        v = np.abs(np.where(moving, values[col], np.nan))
        if not np.isfinite(v).any():
            continue
        k = int(np.nanargmax(v))
        width, fc = _half_width(t, v, k), float(bandwidth[k])
        if not (width > 0 and np.isfinite(fc) and fc > 0):
            continue
        x = PEAK_CONSTANT / (width / 2.355 * fc)
        low = 1.0 - np.sqrt(max(1.0 - x * x, 0.0))
        if low <= limit:
            continue
        needed = PEAK_CONSTANT / (width / 2.355 * x_limit)  # Hz
        fps_needed = fps * (needed / fc) ** 6
        noise_needed = noise_deg * (fc / needed) ** 3
        rows = np.flatnonzero(moving & (np.abs(t - t[k]) <= 0.5 * width))
        where = row_ranges(rows, t, lines=lines) if rows.size else f"t = {t[k]:.4g} s"
        message = (f"{label}: its peak {v[k]:.3g} (at t = {t[k]:.4g} s) is {1e3 * width:.0f} ms "
                   f"wide at half height ({width * fps:.1f} frames) and the smoother's bandwidth "
                   f"there is {fc:.0f} Hz: a peak this short comes out about {100 * low:.0f} % "
                   f"low, and its band does not hold that ({where}); the loads of the fitted "
                   f"engine keep it (method fit), or about {fps_needed:.3g} fps at this noise "
                   f"({noise_deg:.2g}°), or angle noise ≤ {noise_needed:.2g}° at {fps:.3g} "
                   "fps, would resolve it")
        out.append(Advisory(col, label, float(v[k]), float("nan"), float(t[k]),
                            tuple(int(i) for i in rows), float(fps_needed),
                            float(noise_needed), message))
    return out
