"""Scores of a reconstruction against the simulation's truth, per log.

Rows are matched by frame index (``round(t fps)``, both in log time). Over the shot's
frames (the truth's phase ≥ 1):

- ``theta_rms_deg``, ``psi_rms_deg``, ``phi_rms_deg``: RMS error (°) of the log's angles as
  ``trebuchet.read_log`` reads them (φ while the sling holds the stone, phases 1–2);
- ``FR_rms``: RMS error of |F_R| in % of its true peak; ``FR_peak``: error of the peak, %;
- ``FS_rms``: RMS error of |F_S| in phase II, % of its true peak there;
- ``release_err_frames``, ``lift_off_err_frames``: detected minus true event, frames (NaN
  where none was found);
- ``<X>_cover``: % of frames whose truth lies within ±2 sd (``X_sd``) for F_R_x, F_R_y
  (shot frames) and F_S_x, F_S_y (phases 1–2: after the release both are exactly 0);
- ``rows``: % of the shot's frames where the reconstruction has |F_R| (rows the reader
  dropped, or after a track's end, have none).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["COVERED", "frame_index", "shot_scores", "angle_errors", "tracking_scores",
           "event_scores", "EVENT_WARNINGS"]

#: Components whose ±2 sd band coverage is scored, and the phases over which.
COVERED = {"F_R_x": (1, 2, 3), "F_R_y": (1, 2, 3), "F_S_x": (1, 2), "F_S_y": (1, 2)}


def frame_index(t: np.ndarray, fps: float) -> np.ndarray:
    """Frame numbers of log times ``t`` (s)."""
    return np.round(np.asarray(t, dtype=float) * fps).astype(np.int64)


def _aligned(table: pd.DataFrame, truth: pd.DataFrame, fps: float) -> pd.DataFrame:
    """``table``'s rows joined to the truth's on the frame index; truth columns get ``_true``."""
    a = table.assign(frame=frame_index(table["t"], fps))
    b = truth.assign(frame=frame_index(truth["t"], fps))
    return a.merge(b, on="frame", suffixes=("", "_true"), how="inner")


def angle_errors(log: pd.DataFrame, truth: pd.DataFrame, fps: float) -> dict[str, float]:
    """RMS errors (°) of a read log's angles over the shot's frames (φ in phases 1–2)."""
    m = _aligned(log, truth, fps)
    phase = m["phase"].to_numpy()
    out = {}
    for a in ("theta", "psi", "phi"):
        rows = (phase >= 1) & ((phase <= 2) if a == "phi" else True)
        d = np.rad2deg(m[a].to_numpy() - m[a + "_true"].to_numpy())[rows]
        d = d[np.isfinite(d)]
        out[f"{a}_rms_deg"] = float(np.sqrt(np.mean(d * d))) if d.size else np.nan
    return out


def _rms_pct(est: np.ndarray, true: np.ndarray, peak: float) -> float:
    d = est - true
    d = d[np.isfinite(d)]
    return float(100.0 * np.sqrt(np.mean(d * d)) / peak) if d.size else np.nan


def shot_scores(result: pd.DataFrame, truth: pd.DataFrame, fps: float) -> dict[str, float]:
    """The scores of the module doc of a ``trebuchet.reconstruct`` result."""
    m = _aligned(result, truth, fps)
    phase = m["phase_true"].to_numpy()
    shot = phase >= 1
    held2 = phase == 2
    out: dict[str, float] = {}
    true_shot = truth["phase"].to_numpy() >= 1
    fr_true = truth["F_R_abs"].to_numpy()
    peak_fr = float(np.max(fr_true[true_shot]))
    est = m["F_R_abs"].to_numpy()
    out["FR_rms"] = _rms_pct(est[shot], m["F_R_abs_true"].to_numpy()[shot], peak_fr)
    out["FR_peak"] = float(100.0 * (np.nanmax(est[shot]) - peak_fr) / peak_fr)
    peak_fs = float(np.max(truth["F_S_abs"].to_numpy()[truth["phase"].to_numpy() == 2]))
    out["FS_rms"] = _rms_pct(m["F_S_abs"].to_numpy()[held2],
                             m["F_S_abs_true"].to_numpy()[held2], peak_fs)
    events, true_events = result.attrs.get("events", {}), truth.attrs["events"]
    for key in ("release", "lift_off"):
        found = events.get(key)
        out[f"{key}_err_frames"] = (np.nan if found is None or key not in true_events
                                    else float((found - true_events[key]) * fps))
    for col, phases in COVERED.items():
        rows = np.isin(phase, phases)
        est, sd, true = (m[c].to_numpy()[rows] for c in (col, col + "_sd", col + "_true"))
        ok = np.isfinite(est) & np.isfinite(sd)
        inside = np.abs(est[ok] - true[ok]) <= 2.0 * sd[ok]
        out[f"{col}_cover"] = float(100.0 * inside.mean()) if ok.any() else np.nan
    has = shot & np.isfinite(m["F_R_abs"].to_numpy())
    out["rows"] = float(100.0 * has.sum() / max(int(true_shot.sum()), 1))
    return out


def tracking_scores(positions: np.ndarray, scores: np.ndarray, true_px: np.ndarray,
                    phase: np.ndarray, min_likelihood: float = 0.9) -> dict[str, float]:
    """How the tracker did, judged after the fact against the true pixels ``true_px`` ((n, 5,
    2)) while the sling holds the stone (``phase`` ≤ 2): ``track_px``, the median error (px)
    of the positions kept (score ≥ ``min_likelihood``); ``lost_pct``, % of point-frames below
    it (gaps for the reader); ``wrong_pct``, % kept but more than 3 px off (a stuck or
    slid track the reader cannot see)."""
    held = phase <= 2
    err = np.linalg.norm(positions[held] - true_px[held], axis=-1)
    kept = scores[held] >= min_likelihood
    return {"track_px": float(np.nanmedian(err[kept])) if kept.any() else np.nan,
            "lost_pct": float(100.0 * (~kept).mean()),
            "wrong_pct": float(100.0 * (kept & (err > 3.0)).mean())}


#: Phrases of a warning that an event is uncertain or its sources disagree, per event.
EVENT_WARNINGS = {
    "trigger": ("the trigger at",),
    "lift_off": ("the lift-off at", "lift-off sources disagree"),
    "release": ("release is uncertain", "release sources disagree", "the release at"),
}


def event_scores(result: pd.DataFrame, truth: pd.DataFrame, fps: float,
                 warnings: list[str]) -> dict[str, float]:
    """Each event's error and stated sd (frames) and whether a warning named it uncertain
    (``<event>_err``, ``<event>_sd``, ``<event>_warned``; the trigger's truth is the
    truth's ``attrs["events"]["trigger"]``), and ``<event>_ok``: the bench's rule, an event
    more than 2 frames off lies within its stated 2 sd and is warned about (1.0 / 0.0;
    NaN where the event is missing on either side)."""
    rec = result.attrs.get("reconstruction")
    found = rec.events if rec is not None else result.attrs.get("events", {})
    sds = rec.event_sd if rec is not None else {}
    true = truth.attrs["events"]
    out: dict[str, float] = {}
    for key, phrases in EVENT_WARNINGS.items():
        est, want = found.get(key), true.get(key)
        if est is None or want is None:
            out |= {f"{key}_err": np.nan, f"{key}_sd": np.nan, f"{key}_warned": np.nan,
                    f"{key}_ok": np.nan}
            continue
        err = (est - want) * fps
        sd = float(sds.get(key, np.nan)) * fps
        warned = any(p in w for w in warnings for p in phrases)
        ok = abs(err) <= 2.0 or (abs(err) <= 2.0 * sd and warned)
        out |= {f"{key}_err": err, f"{key}_sd": sd, f"{key}_warned": float(warned),
                f"{key}_ok": float(ok)}
    return out
