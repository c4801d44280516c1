"""Repairs made to every log, each returning a sentence for the user (or nothing).

Each function works in place on a :class:`ParsedLog` and returns what it did, so
that :func:`read_log` can list it in ``attrs["repairs"]`` and warn about it.
"""

from __future__ import annotations

import numpy as np

from trebuchet.ingest.geometry.points import paper_branch
from trebuchet.ingest.readers.source import ParsedLog
from trebuchet.ingest.readers.table import format_rows


def _valid(log: ParsedLog) -> np.ndarray:
    """(n, 3) array of the angles, NaN where missing."""
    return np.column_stack([log.angles[a] for a in ("theta", "psi", "phi")])


def drop_rows_without_angles(log: ParsedLog) -> str | None:
    """Drop rows where every angle is missing (they carry no measurement)."""
    empty = np.isnan(_valid(log)).all(axis=1)
    if not empty.any():
        return None
    rows = log.rows[empty]
    log.take(~empty)
    return f"dropped {len(rows)} rows without any angle ({format_rows(rows)})"


def merge_duplicate_times(log: ParsedLog) -> str | None:
    """Merge rows with the same time: identical rows are dropped, differing ones averaged.

    Expects times sorted (checked before). The average ignores missing cells.
    """
    same = np.concatenate([[False], np.diff(log.t) == 0])
    if not same.any():
        return None
    values = _valid(log)
    group = np.cumsum(~same) - 1
    averaged = 0
    merged = values[~same].copy()
    for g in np.unique(group[same]):
        block = values[group == g]
        if not (np.isclose(block, block[0], rtol=0, atol=0, equal_nan=True)).all():
            averaged += 1
            finite = np.isfinite(block)
            counts = finite.sum(axis=0)
            sums = np.where(finite, block, 0.0).sum(axis=0)
            merged[g] = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)
    rows = log.rows[same]
    log.take(~same)
    for i, a in enumerate(("theta", "psi", "phi")):
        log.angles[a] = merged[:, i]
    how = "dropped" if averaged == 0 else f"merged ({averaged} with differing angles averaged)"
    return (
        f"{len(rows)} rows repeat the time of the row before and were {how} "
        f"({format_rows(rows)})"
    )


def report_gaps(log: ParsedLog) -> list[str]:
    """Sentences on missing frames (absent rows) and missing angle cells; changes nothing.

    Absent frames are found from frame numbers when the log has them, else from time
    steps longer than 1.5 median steps.
    """
    out: list[str] = []
    n = len(log.t)
    if n >= 3:
        if log.frame is not None:
            steps = np.diff(log.frame).astype(float)
        else:
            dt = np.diff(log.t)
            median = float(np.median(dt))
            steps = np.round(dt / median) if median > 0 else np.ones_like(dt)
            steps[dt <= 1.5 * median] = 1.0
        where = np.nonzero(steps > 1)[0]
        if len(where):
            missing = int((steps[where] - 1).sum())
            spots = ", ".join(
                f"{int(steps[k]) - 1} after row {log.rows[k]} (t = {log.t[k]:.6g} s)"
                for k in where[:8]
            )
            more = f", ... ({len(where)} gaps)" if len(where) > 8 else ""
            out.append(f"{missing} frames are absent: {spots}{more}; left as gaps")
    for a in ("theta", "psi", "phi"):
        empty = np.isnan(log.angles[a])
        if empty.any():
            out.append(
                f"{a} ({log.labels.get(a, a)}) is missing on {int(empty.sum())} of {n} rows "
                f"({format_rows(log.rows[empty])}); left as gaps"
            )
    return out


def drop_repeated_frames(log: ParsedLog) -> str | None:
    """Drop frames that repeat the frame before while the engine moves through them.

    A row is a repeated frame when all its angles equal the row before (same cells
    missing), the pair is flanked by rows that differ, and at least one angle moves in
    the same direction into and out of the pair (a stall in the middle of a motion,
    as when a tracker or a frame-rate conversion copies every third frame). Runs of
    three or more equal rows are kept: that is an engine at rest.
    """
    v = _valid(log)
    n = len(v)
    if n < 4:
        return None
    equal = np.array(
        [np.array_equal(v[i], v[i - 1], equal_nan=True) and np.isfinite(v[i]).any()
         for i in range(1, n)]
    )
    drop = np.zeros(n, dtype=bool)
    for i in range(2, n - 1):
        # rows i-1 and i equal; rows i-2 and i+1 differ from them
        if not equal[i - 1] or equal[i - 2] or equal[i]:
            continue
        before = v[i - 1] - v[i - 2]
        after = v[i + 1] - v[i]
        moving = np.sign(before) * np.sign(after) > 0
        if moving.any():
            drop[i] = True
    if not drop.any():
        return None
    rows = log.rows[drop]
    log.take(~drop)
    return (
        f"dropped {len(rows)} repeated frames (identical to the frame before while the "
        f"engine moves): {format_rows(rows)}"
    )


def unwrap_angles(log: ParsedLog) -> list[str]:
    """Unwrap each angle with :func:`numpy.unwrap` over its present values (jumps > π) and
    put it on the 2π branch of the paper's start pose (:func:`paper_branch`: the first present
    value in [-π, π) for theta and psi, in [-3π/2, π/2) for phi), as point files are."""
    out = []
    for a in ("theta", "psi", "phi"):
        values = log.angles[a]
        ok = np.isfinite(values)
        if ok.sum() < 2:
            continue
        unwrapped = np.unwrap(values[ok])
        shifted = np.abs(unwrapped - values[ok]) > 1e-9
        if shifted.any():
            first = log.rows[ok][int(np.argmax(shifted))]
            out.append(
                f"{a} unwrapped: jumps of 2π removed, {int(shifted.sum())} values shifted "
                f"from row {first} on"
            )
        on_branch = paper_branch(a, unwrapped)
        turns = int(round((on_branch[0] - unwrapped[0]) / (2 * np.pi)))
        if turns:
            out.append(f"{a} moved by {turns:+d} turn(s) to the paper's start branch (first "
                       f"value {np.degrees(on_branch[0]):.1f}°)")
        values = values.copy()
        values[ok] = on_branch
        log.angles[a] = values
    return out
