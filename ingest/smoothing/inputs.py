"""What :func:`~trebuchet.ingest.smoothing.smooth.smooth` checks of its input: the log's columns
and times, per-angle options and given event times (errors name the log's file, column
and row)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from trebuchet.core.errors import (
    TrebuchetDataWarning,
    TrebuchetInputError,
    on_command_line,
    warn_at_caller,
)
from trebuchet.ingest.smoothing.settings import ANGLES


def validated_log(log: pd.DataFrame, min_frames: int) -> tuple[np.ndarray, np.ndarray]:
    """Time (n,) and angles (3, n) from ``log``; raises :class:`TrebuchetInputError`.

    Checks: a DataFrame with ``t``, ``theta``, ``psi``, ``phi``; numeric; ``t`` finite and
    strictly increasing, without a gap longer than the rest of the log together
    (:func:`_check_gaps`); angles finite or NaN (a gap); each angle either untracked (all
    NaN) or with at least ``min_frames`` valid frames; at least one tracked.
    """
    if not isinstance(log, pd.DataFrame):
        raise TrebuchetInputError(f"smooth: expected a pandas DataFrame, got {type(log).__name__}")
    for col in ("t", *ANGLES):
        if col not in log.columns:
            raise TrebuchetInputError(f"smooth: the log has no column '{col}'")
    n = len(log)
    if n < min_frames:
        raise TrebuchetInputError(
            f"smooth: the log has {n} rows; smoothing needs at least {min_frames} frames"
        )
    arrays = {}
    for col in ("t", *ANGLES):
        try:
            arrays[col] = log[col].to_numpy(dtype=float, na_value=np.nan)
        except (TypeError, ValueError) as exc:
            raise TrebuchetInputError(f"smooth: column '{col}' is not numeric ({exc})") from None
    t = arrays["t"]
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise TrebuchetInputError(f"smooth: column 't', row {bad[0]}: time is {t[bad[0]]}")
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise TrebuchetInputError(
            f"smooth: column 't', row {i}: time {t[i]:g} s does not increase "
            f"(row {i - 1} has {t[i - 1]:g} s)"
        )
    _check_gaps(t)
    Z = np.vstack([arrays[a] for a in ANGLES])
    for a, name in enumerate(ANGLES):
        bad = np.flatnonzero(np.isinf(Z[a]))
        if bad.size:
            raise TrebuchetInputError(f"smooth: column '{name}', row {bad[0]}: value is infinite")
        nv = int(np.isfinite(Z[a]).sum())
        if 0 < nv < min_frames:
            raise TrebuchetInputError(
                f"smooth: column '{name}' has {nv} valid frames; at least {min_frames} needed"
            )
    if not np.isfinite(Z).any():
        raise TrebuchetInputError("smooth: columns theta, psi and phi are all empty")
    return t, Z


#: A step between two rows may be this many frames (median steps) long whatever the rest.
GAP_FRAMES = 10


def _check_gaps(t: np.ndarray) -> None:
    """Refuse a step between two rows longer than all the other steps together (and than
    :data:`GAP_FRAMES` frames): the smoother's scales (the event kicks' and the priors'
    sizes, the slowest process noise searched) come from the log's duration, which such a
    gap would set (a last time of 1e9 s in a log of a 2 s shot shrank the kicks by 1e17
    and the loads after it were 1e22 N), and nothing of a shot lasts across it. A wrong
    time or frame number, usually."""
    if t.size < 3:
        return
    dt = np.diff(t)
    i = int(np.argmax(dt))
    rest = float(t[-1] - t[0]) - float(dt[i])
    if dt[i] > rest and dt[i] > GAP_FRAMES * float(np.median(dt)):
        raise TrebuchetInputError(
            f"smooth: column 't', row {i + 1}: time {t[i + 1]:g} s comes {dt[i]:g} s after "
            f"row {i} ({t[i]:g} s), longer than all the other rows span together "
            f"({rest:g} s): no shot lasts across such a gap (a wrong time or frame number?); "
            "correct or remove the row")


def unwrapped_angles(Z: np.ndarray) -> np.ndarray:
    """Angles with jumps of more than π between valid frames unwrapped (warns if any)."""
    Z = Z.copy()
    for a, name in enumerate(ANGLES):
        ok = np.isfinite(Z[a])
        if ok.sum() > 1 and np.any(np.abs(np.diff(Z[a][ok])) > np.pi):
            Z[a][ok] = np.unwrap(Z[a][ok])
            warn_at_caller(
                f"smooth: column '{name}' jumps by more than π between frames; unwrapped",
                TrebuchetDataWarning)
    return Z


def per_angle(value, name: str, tracked: list[str]) -> dict[str, float]:
    """``q`` or ``r`` as a positive float per angle (NaN: to be estimated)."""
    if value is None:
        return {a: np.nan for a in tracked}
    if isinstance(value, Mapping):
        unknown = set(value) - set(ANGLES)
        if unknown:
            raise TrebuchetInputError(f"smooth: {name} has unknown angle(s) {sorted(unknown)}")
        vals = {a: (np.nan if value.get(a) is None else value[a]) for a in tracked}
    else:
        vals = {a: value for a in tracked}
    out = {}
    for a, v in vals.items():
        try:
            v = float(v)
        except (TypeError, ValueError):
            raise TrebuchetInputError(f"smooth: {name}['{a}'] = {v!r} is not a number") from None
        if not (np.isnan(v) or (np.isfinite(v) and v > 0)):
            raise TrebuchetInputError(f"smooth: {name}['{a}'] = {v!r} must be positive")
        out[a] = v
    return out


EVENT_ORDER = ("trigger", "lift_off", "release")


def event_named(key: str, value: float) -> str:
    """A given event as the interface called names it: ``--release 0.9`` on the command
    line, ``events['release'] = 0.9 s`` from Python."""
    if on_command_line():
        return f"--{key.replace('_', '-')} {value:g}"
    return f"events[{key!r}] = {value:g} s"


def checked_events(events, t: np.ndarray, source: str = "smooth") -> dict[str, float | None]:
    """Given events (log time, s): key present = given (None = no such event).

    Each given time must lie inside the log's span ``t[0]``–``t[-1]`` and the given ones
    must be ordered trigger < lift-off < release; otherwise a :class:`TrebuchetInputError`
    whose message starts with ``source`` (the log file's name when known) and names the
    event.
    """
    if events is None:
        return {}
    if not isinstance(events, Mapping):
        raise TrebuchetInputError(f"{source}: events must be a dict like "
                                  "{'trigger': t, 'lift_off': t, 'release': t}")
    out: dict[str, float | None] = {}
    for key, v in events.items():
        if key not in EVENT_ORDER:
            raise TrebuchetInputError(f"{source}: unknown event {key!r} in events (known: "
                                      + ", ".join(EVENT_ORDER) + ")")
        if v is None:
            out[key] = None
            continue
        try:
            v = float(v)
        except (TypeError, ValueError):
            raise TrebuchetInputError(f"{source}: events[{key!r}] = {v!r} is not a time "
                                      "in s") from None
        if not (t[0] <= v <= t[-1]):
            raise TrebuchetInputError(
                f"{source}: {event_named(key, v)} lies outside the log "
                f"({t[0]:g}–{t[-1]:g} s)"
            )
        out[key] = v
    timed = [(k, out[k]) for k in EVENT_ORDER if out.get(k) is not None]
    for (k0, v0), (k1, v1) in zip(timed, timed[1:], strict=False):
        if v1 <= v0:
            raise TrebuchetInputError(
                f"{source}: {event_named(k1, v1)} is not after {event_named(k0, v0)} "
                "(the order is trigger < lift_off < release)"
            )
    return out


def log_name(log) -> str:
    """The log's file (``source`` of ``read_log``'s ``attrs["log"]``, as read) for
    messages, else ``"smooth"``."""
    info = log.attrs.get("log") if isinstance(log, pd.DataFrame) else None
    source = getattr(info, "source", None)
    return str(source) if source else "smooth"
