"""What :func:`~trebuchet.ingest.reconstruct.reconstruct` found besides its columns, as
one typed value: ``result.attrs["reconstruction"]``, a :class:`Reconstruction`.

Frozen, returned by ``copy.deepcopy`` as itself and compared by identity, as
:class:`~trebuchet.ingest.logs.result.ReadLog` and
:class:`~trebuchet.ingest.smoothing.result.Smoothing` are (pandas deep-copies ``attrs``
on every operation). ``result.attrs["events"]`` (the public interface's key) holds the
same event times as a plain dict; ``result.attrs["log"]`` the log's
:class:`~trebuchet.ingest.logs.result.ReadLog` when it was read from a file.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import pandas as pd

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.ingest.advisory import Advisory


@dataclass(frozen=True, eq=False)
class Reconstruction:
    """How the loads of a log were reconstructed.

    Attributes
    ----------
    events:
        ``{"trigger", "lift_off", "release"}``: log time (s) or None.
    event_sd:
        sd (s) of each event (0 for a given one, NaN where none was sought).
    event_sources:
        How each event was found (sentences).
    noise:
        Per tracked angle its noise fit, as in
        :attr:`~trebuchet.ingest.smoothing.result.Smoothing.noise` (``r_sd`` in rad, ...).
    form:
        ``"projected"`` or ``"direct"``: the force formulas used.
    trough:
        ``"constraint"`` or ``"measured"``: phase I's φ.
    model:
        The smoother's model (``"ca"``, ``"cj"``, ``"select"``, ``"average"``).
    preset:
        The speed-accuracy preset of the options, or None.
    fps:
        The log's median frame rate (1/s).
    advisories:
        Loads the frame rate and noise do not resolve
        (:class:`~trebuchet.ingest.advisory.Advisory`).
    validity:
        Sentences: angles outside the scene's geometry, a slack sling.
    notes:
        Sentences about the log, the smoothing and the events.
    method:
        ``"smooth"``: the loads of the smoothed angles; ``"fit"``: of the fitted engine
        (:mod:`~trebuchet.ingest.identification.fitted_loads`).
    identification:
        The engine identified from the log
        (:class:`~trebuchet.ingest.identification.result.Identification`) where a fit ran,
        else None (with ``method="smooth"`` it failed its check, or was not asked for).
    event_warnings:
        Sentences about events whose sources disagree (also in ``notes``), for
        :func:`~trebuchet.ingest.reconstruct.reconstruct` to warn.
    """

    events: Mapping[str, float | None]
    event_sd: Mapping[str, float] = field(default_factory=dict)
    event_sources: Mapping[str, str] = field(default_factory=dict)
    noise: Mapping[str, Mapping[str, Any]] = field(default_factory=dict, repr=False)
    form: str = "projected"
    trough: str = "constraint"
    model: str | None = None
    preset: str | None = None
    fps: float = float("nan")
    advisories: tuple[Advisory, ...] = ()
    validity: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    method: str = "smooth"
    identification: Any = None
    event_warnings: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        for name in ("events", "event_sd", "event_sources"):
            set_(self, name, MappingProxyType(dict(getattr(self, name))))
        set_(self, "noise", MappingProxyType(
            {a: MappingProxyType(dict(v)) for a, v in self.noise.items()}))
        for name in ("advisories", "validity", "notes", "event_warnings"):
            set_(self, name, tuple(getattr(self, name)))

    def __deepcopy__(self, memo: dict) -> Reconstruction:
        return self

    def __copy__(self) -> Reconstruction:
        return self

    def __reduce__(self):
        """Pickled as its plain fields (mapping proxies do not pickle)."""
        return (_rebuild, (dict(self.events), dict(self.event_sd), dict(self.event_sources),
                           {a: dict(v) for a, v in self.noise.items()}, self.form,
                           self.trough, self.model, self.preset, self.fps, self.advisories,
                           self.validity, self.notes, self.method, self.identification,
                           self.event_warnings))


def _rebuild(*fields) -> Reconstruction:
    return Reconstruction(*fields)


def reconstruction_of(result: pd.DataFrame) -> Reconstruction:
    """``result.attrs["reconstruction"]`` of a table
    :func:`~trebuchet.ingest.reconstruct.reconstruct` made; any other table is refused
    (``TrebuchetInputError``)."""
    found = result.attrs.get("reconstruction") if isinstance(result, pd.DataFrame) else None
    if not isinstance(found, Reconstruction):
        raise TrebuchetInputError("expected the output of trebuchet.reconstruct (its "
                                  "attrs['reconstruction'] is missing)")
    return found
