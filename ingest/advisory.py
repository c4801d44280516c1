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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trebuchet.ingest.scene_fit import row_ranges

__all__ = ["Advisory", "resolution_advisories", "ADVISED"]

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
