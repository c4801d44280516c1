"""What :func:`~trebuchet.ingest.smoothing.smooth.smooth` found besides its columns, as
one typed value: ``est.attrs["smoothing"]``, a :class:`Smoothing`.

Like :class:`~trebuchet.ingest.logs.result.ReadLog` it is frozen, returns itself from
``copy.deepcopy`` (pandas deep-copies ``attrs`` on every operation) and compares by
identity. A stage that changes what a smoothing says (``reconstruct`` names the source of
a release the engine's equations found, adds a note) makes a new one with
:meth:`Smoothing.replace` or :meth:`Smoothing.noted` and sets it on its own table.

``est.attrs["events"]`` (the public interface's key) holds the same event times as a plain
dict.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any

import numpy as np
import pandas as pd

from trebuchet.core.errors import TrebuchetInputError


@dataclass(frozen=True, eq=False)
class Smoothing:
    """How a log was smoothed.

    Attributes
    ----------
    events:
        ``{"trigger", "release"}`` (and ``"lift_off"`` when given): log time (s) or None.
    event_sd:
        sd (s) of the trigger when detected or given (``{"trigger": sd}``), else empty.
    event_sources:
        How each event was found (sentences), e.g. ``"jump search"``, ``"given"``.
    noise:
        Per tracked angle, its noise fit (a read-only mapping): ``q`` (rad²/s⁵ for the
        ``ca`` model, rad²/s⁷ for ``cj``; with local noise the density where the shape is
        at its mean), ``q_ml``, ``r_sd`` (rad), ``loglik``, ``jump_gain``, ``jump_count``
        (:func:`~trebuchet.ingest.smoothing.model_choice.jump_profile`), ``source``
        (``"given"`` or ``"maximum likelihood"``), ``at_grid_edge``, ``pieces`` (list of
        ``{"t_start", "t_end", "q"}``), ``q_frames`` ((n,) density used at each frame),
        ``band_scale`` ((n,) factor of the calibrated band); ``model`` for
        ``"select"``/``"average"``.
    cov:
        Per tracked angle, the (n, k, k) smoothed covariance of [angle, rate,
        acceleration(, jerk)] in SI (rad, rad/s, rad/s², rad/s³), with the bias term of
        ``SmoothSettings.bias_band``; NaN outside the track.
    model:
        ``"ca"``, ``"cj"``, ``"select"`` or ``"average"``.
    loglik:
        Summed log-likelihood over the angles (nats).
    notes:
        Sentences about the smoothing (tracks that end, grid edges, ...).
    model_weights:
        ``{angle: {model: weight}}`` for ``"select"``/``"average"``, else None.
    """

    events: Mapping[str, float | None]
    event_sd: Mapping[str, float] = field(default_factory=dict)
    event_sources: Mapping[str, str] = field(default_factory=dict)
    noise: Mapping[str, Mapping[str, Any]] = field(default_factory=dict, repr=False)
    cov: Mapping[str, np.ndarray] = field(default_factory=dict, repr=False)
    model: str = "ca"
    loglik: float = float("nan")
    notes: tuple[str, ...] = ()
    model_weights: Mapping[str, Mapping[str, float]] | None = None

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        for name in ("events", "event_sd", "event_sources"):
            set_(self, name, MappingProxyType(dict(getattr(self, name))))
        set_(self, "noise", MappingProxyType({a: MappingProxyType(
            {k: _frozen(x) if isinstance(x, np.ndarray) else x for k, x in v.items()})
            for a, v in self.noise.items()}))
        set_(self, "cov", MappingProxyType(
            {a: _frozen(np.asarray(c, dtype=float)) for a, c in self.cov.items()}))
        set_(self, "notes", tuple(self.notes))
        if self.model_weights is not None:
            set_(self, "model_weights", MappingProxyType(
                {a: MappingProxyType(dict(w)) for a, w in self.model_weights.items()}))

    def replace(self, **changes: Any) -> Smoothing:
        """A copy with ``changes``; mapping fields given as dicts."""
        return replace(self, **changes)

    def noted(self, *notes: str | None) -> Smoothing:
        """A copy with ``notes`` appended (None and repeats left out)."""
        kept = list(self.notes)
        for n in notes:
            if n is not None and n not in kept:
                kept.append(n)
        return self if len(kept) == len(self.notes) else replace(self, notes=tuple(kept))

    def with_source(self, event: str, how: str | None) -> Smoothing:
        """A copy whose ``event_sources[event]`` is ``how`` (None removes it)."""
        sources = {k: v for k, v in self.event_sources.items() if k != event}
        if how is not None:
            sources[event] = how
        return replace(self, event_sources=sources)

    def __deepcopy__(self, memo: dict) -> Smoothing:
        return self

    def __copy__(self) -> Smoothing:
        return self

    def __reduce__(self):
        """Pickled as its plain fields (mapping proxies do not pickle)."""
        return (_rebuild, (dict(self.events), dict(self.event_sd), dict(self.event_sources),
                           {a: dict(v) for a, v in self.noise.items()},
                           {a: np.array(c) for a, c in self.cov.items()}, self.model,
                           self.loglik, self.notes,
                           None if self.model_weights is None
                           else {a: dict(w) for a, w in self.model_weights.items()}))


def _frozen(a: np.ndarray) -> np.ndarray:
    if a.flags.writeable:
        a = a.copy()
        a.flags.writeable = False
    return a


def _rebuild(*fields) -> Smoothing:
    return Smoothing(*fields)


def smoothing_of(est: pd.DataFrame) -> Smoothing:
    """``est.attrs["smoothing"]`` of a table :func:`~trebuchet.ingest.smoothing.smooth.smooth`
    made; a table without one is refused (``TrebuchetInputError``)."""
    found = est.attrs.get("smoothing") if isinstance(est, pd.DataFrame) else None
    if not isinstance(found, Smoothing):
        raise TrebuchetInputError("expected the output of trebuchet.smooth (its "
                                  "attrs['smoothing'] is missing)")
    return found


def with_angle_rows(est: pd.DataFrame, angle: str, rows: np.ndarray,
                    values: tuple[np.ndarray, np.ndarray, np.ndarray], cov: np.ndarray
                    ) -> pd.DataFrame:
    """A copy of the smoothed ``est`` whose ``angle`` (rad), its rate (rad/s) and
    acceleration (rad/s²) on the rows at positions ``rows`` are ``values`` (each (k,)),
    with their sd and the smoothing's ``cov[angle]`` there from ``cov`` (k, 3, 3) (the
    rest of those rows' covariance, a jerk's, zero): where a pendulum carries an angle on
    past its track."""
    fit = smoothing_of(est)
    covs = dict(fit.cov)
    full = np.array(covs[angle], dtype=float, copy=True)
    full[rows] = 0.0
    full[rows, :3, :3] = cov
    covs[angle] = full
    out = est.copy()
    for j, suffix in enumerate(("", "_d", "_dd")):
        out.loc[out.index[rows], angle + suffix] = values[j]
        out.loc[out.index[rows], angle + suffix + "_sd"] = np.sqrt(cov[:, j, j])
    return with_smoothing(out, fit.replace(cov=covs))


def with_smoothing(est: pd.DataFrame, smoothing: Smoothing) -> pd.DataFrame:
    """``est`` (changed in place and returned) carrying ``smoothing`` and its events."""
    est.attrs["smoothing"] = smoothing
    est.attrs["events"] = dict(smoothing.events)
    return est
