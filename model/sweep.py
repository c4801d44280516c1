"""Parameter sweeps: simulate every design of a grid and tabulate what matters.

A grid names scene keys as ``"section.key"`` (the keys of the scene file, e.g.
``"engine.M"`` in kg, ``"release.velocity_angle_deg"`` in degrees) and lists
values for each. :func:`sweep` simulates the cartesian product of the values,
one design per combination, and returns one row per design: the design's
parameters, a ``status`` (``ok``, ``refused``, ``failed``), an ``error`` with the
reason for a design that did not run, and the summary outputs of
:data:`SUMMARY_COLUMNS` (SI units). A design the model refuses is kept with
its reason, never dropped.

Each design is built from the base scene's dict (``Scene.to_dict``) with the
grid's values put in, and validated by ``Scene.from_dict``. Quantities that the
base scene leaves to their defaults follow the swept ones unless the grid names
them: the moment of inertia ``I`` (uniform beam) follows ``m_b``, ``L1`` and
``L2``; the pivot height ``H`` (spigot on the ground) follows ``L1`` and the
start angle; the start sling angle ``phi`` keeps the projectile in the trough.
Setting one release rule (``release.time`` or ``release.velocity_angle_deg``)
replaces the base scene's rule.

Designs run in local processes (:class:`concurrent.futures.ProcessPoolExecutor`,
chunked, one process per core by default), in the calling process
(``workers=1``), in any :class:`concurrent.futures.Executor` given, or on a Dask
cluster (``executor="tcp://host:port"`` or a ``dask.distributed.Client``; dask is
imported only then).

Grid values on the command line (:func:`parse_grid_option`): ``KEY=VALUES``
where ``VALUES`` is a comma list (``10000,19100,30000``), a single number, or
``start:stop:count`` (``count`` evenly spaced values from ``start`` to ``stop``,
both included: ``30:60:7`` is 30, 35, ..., 60).
"""

from __future__ import annotations

import itertools
import math
import os
from collections.abc import Iterable, Iterator, Mapping, Sequence
from concurrent.futures import Executor, ProcessPoolExecutor
from dataclasses import dataclass, replace
from functools import partial
from typing import Any

import numpy as np
import pandas as pd
from tqdm.auto import tqdm

from trebuchet.errors import TrebuchetInputError
from trebuchet.model.c_engine import EngineUnavailable
from trebuchet.model.c_summary import shot_summary
from trebuchet.model.dynamics import trough_sling_angle
from trebuchet.model.output_size import check_output_size
from trebuchet.model.scene import SCENE_KEYS, Scene, default_moment_of_inertia
from trebuchet.model.settings import accuracy_option, output_step
from trebuchet.model.simulate import resolve_rtol, simulate

__all__ = [
    "SUMMARY_COLUMNS",
    "SimulationOptions",
    "output_step",
    "accuracy_option",
    "parse_grid_values",
    "parse_grid_option",
    "check_grid",
    "grid_designs",
    "design_scene",
    "summarize",
    "evaluate_design",
    "sweep",
]

#: Summary outputs of a design, with their units. Peaks are maxima of the magnitude over the
#: simulated rows (trigger to release + ``after_release``).
SUMMARY_COLUMNS: dict[str, str] = {
    "lift_off": "s, lift-off of the projectile from the trough",
    "release_time": "s, release after the trigger",
    "release_speed": "m/s, projectile speed at release",
    "release_angle": "rad, projectile velocity above horizontal at release",
    "release_angle_deg": "°, the same in degrees (as the scene file's _deg keys)",
    "release_height": "m, projectile height at release",
    "range": "m, range in vacuum from the pivot",
    "F_S_peak": "N, peak |F_S| (sling on projectile)",
    "F_H_peak": "N, peak |F_H| (beam on counterweight at the hinge)",
    "F_R_peak": "N, peak |F_R| (bearing reaction at the pivot)",
    "F_R_perp_peak": "N, peak |F_R_perp| (reaction across the beam: bending)",
    "torque_peak": "N m, peak |torque| on the beam about the pivot",
    "sling_tension_min": "N, least sling tension while held (negative: slack, model invalid)",
    "energy_share": "1, projectile's mechanical energy at release over ΔU",
    "energy_drift_rel": "1, max |E_m + E_M + E_beam| over ΔU (solver accuracy)",
}

STATUS_OK, STATUS_REFUSED, STATUS_FAILED = "ok", "refused", "failed"
_RELEASE_KEYS = ("release.time", "release.velocity_angle_deg", "release.velocity_angle")
_ANGLE_PAIRS = {"theta": "theta_deg", "psi": "psi_deg", "phi": "phi_deg",
                "velocity_angle": "velocity_angle_deg"}


@dataclass(frozen=True)
class SimulationOptions:
    """Arguments passed to :func:`trebuchet.model.simulate.simulate` for every design:
    tolerance ``rtol`` (a number or a preset name of ``simulate.ACCURACY``), output step ``dt``
    (s) and ``after_release`` (s of phase III; None: simulate's default)."""

    rtol: float | str = "default"
    dt: float = 1e-3
    after_release: float | None = None

    def check(self) -> None:
        """Raise TrebuchetInputError for options no design could run with."""
        resolve_rtol(self.rtol)
        if not self.dt > 0.0:
            raise TrebuchetInputError(f"dt = {self.dt:g} s: must be positive")
        if self.after_release is not None and not self.after_release >= 0.0:
            raise TrebuchetInputError(f"after_release = {self.after_release:g} s: must not be "
                                      "negative")
        check_output_size(self.dt, self.after_release)  # no design could run beyond these


# --------------------------------------------------------------------------- grid


def parse_grid_values(text: str, where: str = "--grid") -> tuple[float, ...]:
    """Values of one grid key from ``a,b,c``, ``x`` or ``start:stop:count`` (both ends
    included). ``where`` names the argument in errors."""
    text = text.strip()
    if not text:
        raise TrebuchetInputError(f"{where}: no values (give a,b,c or start:stop:count)")
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise TrebuchetInputError(f"{where}: {text!r}: a range is start:stop:count")
        start, stop = (_number(p, where) for p in parts[:2])
        try:
            count = int(parts[2])
        except ValueError:
            raise TrebuchetInputError(f"{where}: {text!r}: count {parts[2]!r} must be a whole "
                                      "number") from None
        if count < 1:
            raise TrebuchetInputError(f"{where}: {text!r}: count must be at least 1")
        if count == 1:
            return (start,)
        return tuple(float(v) for v in np.linspace(start, stop, count))
    return tuple(_number(p, where) for p in text.split(","))


def _number(text: str, where: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise TrebuchetInputError(f"{where}: {text.strip()!r} is not a number") from None
    if not math.isfinite(value):
        raise TrebuchetInputError(f"{where}: {text.strip()!r}: values must be finite")
    return value


def parse_grid_option(text: str) -> tuple[str, tuple[float, ...]]:
    """``"section.key=VALUES"`` (a ``--grid`` argument) as ``(key, values)``."""
    key, sep, values = text.partition("=")
    if not sep:
        raise TrebuchetInputError(f"--grid {text!r}: expected KEY=VALUES, e.g. "
                                  "engine.M=10000,19100 or release.velocity_angle_deg=30:60:7")
    key = key.strip()
    return key, parse_grid_values(values, where=f"--grid {key}")


def check_grid(grid: Mapping[str, Iterable[float | str]]) -> dict[str, tuple[float | str, ...]]:
    """The grid with its keys checked against the scene file's keys and its values as
    tuples of finite floats (words, for the scene's word-valued keys, pass through to the
    scene's validation). A bad key raises :class:`TrebuchetInputError` naming it."""
    if not grid:
        raise TrebuchetInputError("grid: empty (name at least one scene key, e.g. engine.M)")
    out: dict[str, tuple[float, ...]] = {}
    for key, values in grid.items():
        section, dot, name = str(key).partition(".")
        if not dot or section not in SCENE_KEYS or name not in SCENE_KEYS[section]:
            known = ", ".join(f"{s}.{k}" for s in sorted(SCENE_KEYS)
                              for k in sorted(SCENE_KEYS[s]))
            raise TrebuchetInputError(f"grid key {key!r}: not a scene key (known: {known})")
        vals = tuple(values) if not isinstance(values, str | bytes) else (values,)
        if not vals:
            raise TrebuchetInputError(f"grid key {key!r}: no values")
        clean: list[float | str] = []
        for v in vals:
            if isinstance(v, str):  # word-valued keys (engine.counterweight = "fixed")
                clean.append(v)
                continue
            if isinstance(v, bool) or not isinstance(v, int | float | np.integer | np.floating):
                raise TrebuchetInputError(f"grid key {key!r}: value {v!r} is not a number")
            if not math.isfinite(float(v)):
                raise TrebuchetInputError(f"grid key {key!r}: value {v!r} is not finite")
            clean.append(float(v))
        out[str(key)] = tuple(clean)
    rel = [k for k in out if k in _RELEASE_KEYS]
    if len(rel) > 1:
        raise TrebuchetInputError(f"grid keys {rel[0]!r} and {rel[1]!r}: a scene has one "
                                  "release rule; sweep one of them")
    for plain, deg in _ANGLE_PAIRS.items():
        for section in ("start", "release"):
            if f"{section}.{plain}" in out and f"{section}.{deg}" in out:
                raise TrebuchetInputError(f"grid keys {section}.{plain!r} and {section}.{deg!r} "
                                          "name the same angle")
    return out


def grid_designs(grid: Mapping[str, Sequence[float]]) -> list[dict[str, float]]:
    """The cartesian product of the grid's values, the first key varying slowest."""
    keys = list(grid)
    return [dict(zip(keys, combo, strict=True))
            for combo in itertools.product(*(grid[k] for k in keys))]


# --------------------------------------------------------------------------- one design


def design_scene(base: Scene, params: Mapping[str, float | str],
                 source: str | None = None) -> Scene:
    """The base scene with the design's values put in (see the module doc for the quantities
    that follow them), validated by ``Scene.from_dict``; raises TrebuchetInputError."""
    data = base.to_dict()
    e, s = base.engine, base.start
    for key, value in params.items():
        section, _, name = key.partition(".")
        sec = data.setdefault(section, {})
        if section == "release" and key in _RELEASE_KEYS:
            sec.clear()
        sec.pop(_ANGLE_PAIRS.get(name, ""), None)
        sec.pop(next((p for p, d in _ANGLE_PAIRS.items() if d == name), ""), None)
        sec[name] = value
    eng = data["engine"]
    if "engine.I" not in params and math.isclose(
            e.I, default_moment_of_inertia(e.m_b, e.L1, e.L2), rel_tol=1e-12):
        eng.pop("I")
    if "engine.H" not in params and math.isclose(
            s.H, -e.L1 * math.sin(s.theta), rel_tol=1e-12, abs_tol=1e-12 * e.L1):
        eng.pop("H")
    in_trough = params.get("start.projectile", getattr(base, "projectile", "trough")) == "trough"
    if in_trough and not any(k in params for k in ("start.phi", "start.phi_deg")):
        _put_projectile_in_trough(data, base)
    return Scene.from_dict(data, source=source or base.source)


def _put_projectile_in_trough(data: dict[str, Any], base: Scene) -> None:
    """Set the start sling angle so the projectile lies in the trough, on the branch of the
    base scene's angle; leave it alone where the design's numbers do not allow it (the
    scene's validation then names the problem)."""
    eng, st = data["engine"], data["start"]
    try:
        theta = (math.radians(st["theta_deg"]) if "theta_deg" in st else float(st["theta"]))
        L1, L4 = float(eng["L1"]), float(eng["L4"])
        H = float(eng["H"]) if "H" in eng else -L1 * math.sin(theta)
        engine = replace(base.engine, L1=L1, L4=L4)
        phi = trough_sling_angle(theta, engine, H, math)
    except (ValueError, TypeError, KeyError, ZeroDivisionError):
        return
    phi += 2.0 * math.pi * round((base.start.phi - phi) / (2.0 * math.pi))
    st.pop("phi", None)
    st["phi_deg"] = math.degrees(phi)


def summarize(run: pd.DataFrame, scene: Scene) -> dict[str, float]:
    """The :data:`SUMMARY_COLUMNS` of one simulated shot (``simulate``'s DataFrame)."""
    ev, fl, diag = run.attrs["events"], run.attrs["flight"], run.attrs["diagnostics"]
    held = run[run["phase"] <= 2]
    at_release = run[(run["t"] == ev["release"]) & (run["phase"] == 2)]
    energy_share = (float(at_release["E_m"].iloc[0]) / diag["delta_U"]
                    if len(at_release) else math.nan)

    def peak(col: str, rows: pd.DataFrame = run) -> float:
        return float(np.max(np.abs(rows[col].to_numpy()))) if len(rows) else math.nan

    return {
        "lift_off": float(ev["lift_off"]),
        "release_time": float(ev["release"]),
        "release_speed": float(fl["release_speed"]),
        "release_angle": float(fl["release_angle"]),
        "release_angle_deg": math.degrees(float(fl["release_angle"])),
        "release_height": float(fl["release_height"]),
        "range": float(fl["range"]),
        "F_S_peak": peak("F_S_abs"),
        "F_H_peak": peak("F_H_abs"),
        "F_R_peak": peak("F_R_abs"),
        "F_R_perp_peak": peak("F_R_perp"),
        "torque_peak": peak("torque"),
        "sling_tension_min": float(held["sling_tension"].min()) if len(held) else math.nan,
        "energy_share": energy_share,
        "energy_drift_rel": float(diag["energy_drift_rel"]),
    }


def evaluate_design(base: Scene, item: tuple[int, Mapping[str, float]], *,
                    options: SimulationOptions = SimulationOptions(),
                    outputs: Sequence[str] = tuple(SUMMARY_COLUMNS)) -> dict[str, Any]:
    """One row of the sweep table for design ``item = (index, params)``.

    A design the model refuses (TrebuchetInputError) gets ``status = "refused"`` and the
    reason in ``error``; any other exception, or a non-finite output, ``"failed"``.
    """
    index, params = item
    row: dict[str, Any] = {"design": index, **params, "status": STATUS_OK, "error": ""}
    nan = dict.fromkeys(outputs, math.nan)
    try:
        scene = design_scene(base, params, source=f"design {index}")
        try:  # the figures reduced in the generated C, no table (model/c_summary.py)
            summary = shot_summary(scene, rtol=options.rtol, dt=options.dt,
                                   after_release=options.after_release)
        except EngineUnavailable:
            summary = summarize(simulate(scene, rtol=options.rtol, dt=options.dt,
                                         after_release=options.after_release), scene)
    except TrebuchetInputError as exc:
        return {**row, "status": STATUS_REFUSED, "error": str(exc), **nan}
    except Exception as exc:  # noqa: BLE001 - a sweep keeps every design, failures included
        return {**row, "status": STATUS_FAILED, "error": f"{type(exc).__name__}: {exc}", **nan}
    values = {k: summary[k] for k in outputs}
    bad = [k for k, v in values.items() if not math.isfinite(v)]
    if bad:
        row.update(status=STATUS_FAILED, error="non-finite output: " + ", ".join(bad))
    return {**row, **values}


def _evaluate_chunk(chunk: Sequence[tuple[int, Mapping[str, float]]], base: Scene,
                    options: SimulationOptions, outputs: Sequence[str]) -> list[dict[str, Any]]:
    return [evaluate_design(base, item, options=options, outputs=outputs) for item in chunk]


# --------------------------------------------------------------------------- many designs


def default_workers() -> int:
    """Cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def _chunks(items: Sequence[Any], size: int) -> list[Sequence[Any]]:
    return [items[i:i + size] for i in range(0, len(items), size)]


#: Designs per chunk at most: a chunk takes well under a second, so that the progress bar
#: moves from the first second on however large the grid (20,000 designs, 2 workers: 64 per
#: chunk, not 2,500).
MAX_CHUNK = 64


def _chunk_size(n: int, workers: int) -> int:
    """About four chunks per worker (few round trips, and a slow chunk does not stall the end),
    at most :data:`MAX_CHUNK` designs (the progress bar moves)."""
    return max(1, min(MAX_CHUNK, math.ceil(n / (4 * workers))))


def _is_dask_client(obj: Any) -> bool:
    return type(obj).__module__.split(".")[0] == "distributed" and hasattr(obj, "map")


def _run_local(items: list, evaluate: Any, workers: int, bar: Any) -> Iterator[dict]:
    if workers == 1 or len(items) == 1:
        for item in items:
            yield evaluate(item)
            bar.update()
        return
    with ProcessPoolExecutor(max_workers=min(workers, len(items))) as pool:
        yield from _run_executor(pool, items, evaluate, workers, bar)


def _run_executor(pool: Executor, items: list, evaluate: Any, workers: int,
                  bar: Any) -> Iterator[dict]:
    for row in pool.map(evaluate, items, chunksize=_chunk_size(len(items), workers)):
        yield row
        bar.update()


def _run_dask(client: Any, base: Scene, items: list, options: SimulationOptions,
              outputs: Sequence[str], bar: Any) -> Iterator[dict]:
    from dask.distributed import as_completed  # optional dependency: the cluster extra

    workers = max(1, sum(client.nthreads().values()))
    chunks = _chunks(items, _chunk_size(len(items), workers))
    futures = client.map(_evaluate_chunk, chunks, base=base, options=options,
                         outputs=tuple(outputs), pure=False)
    for _, rows in as_completed(futures, with_results=True):
        yield from rows
        bar.update(len(rows))


def sweep(base: Scene, grid: Mapping[str, Sequence[float]], *,
          outputs: Sequence[str] = tuple(SUMMARY_COLUMNS),
          executor: Executor | str | Any | None = None, workers: int | None = None,
          progress: bool = True, options: SimulationOptions = SimulationOptions()
          ) -> pd.DataFrame:
    """Simulate every design of the grid and return one row per design.

    Parameters
    ----------
    base : Scene
        The scene every design starts from.
    grid : mapping of "section.key" to values
        Scene keys (units as in the scene file: ``_deg`` keys in degrees) and their values;
        the cartesian product is simulated, the first key varying slowest.
    outputs : sequence of str
        Summary columns to compute, from :data:`SUMMARY_COLUMNS` (default all).
    executor : None, Executor, str or dask.distributed.Client
        None: local processes (``workers`` of them; ``workers=1`` runs in this process).
        A ``concurrent.futures.Executor``: its ``map``, chunked. A scheduler address
        (``"tcp://host:port"``) or a ``dask.distributed.Client``: a Dask cluster
        (``Client.map`` over chunks of designs, gathered with ``as_completed``).
    workers : int, optional
        Local processes (default: the cores this process may use).
    progress : bool
        Show a tqdm progress bar (on stderr).
    options : SimulationOptions
        Solver tolerance, output step and phase III length for every design.

    Returns
    -------
    DataFrame, one row per design in grid order: ``design`` (index), one column per grid key,
    ``status`` (``ok`` / ``refused`` / ``failed``), ``error`` (the reason, empty when ok) and
    the ``outputs`` (SI units, see :data:`SUMMARY_COLUMNS`; NaN where the design did not run).
    """
    grid = check_grid(grid)
    options.check()
    outputs = tuple(outputs)
    unknown = [k for k in outputs if k not in SUMMARY_COLUMNS]
    if unknown:
        raise TrebuchetInputError(f"outputs: {unknown[0]!r} unknown (known: "
                                  + ", ".join(SUMMARY_COLUMNS) + ")")
    if workers is not None and workers < 1:
        raise TrebuchetInputError(f"workers = {workers}: must be at least 1")
    items = list(enumerate(grid_designs(grid)))
    evaluate = partial(evaluate_design, base, options=options, outputs=outputs)
    with tqdm(total=len(items), disable=not progress, unit="design", desc="sweep") as bar:
        if executor is None:
            rows = list(_run_local(items, evaluate, workers or default_workers(), bar))
        elif isinstance(executor, Executor):
            rows = list(_run_executor(executor, items, evaluate, workers or default_workers(),
                                      bar))
        elif isinstance(executor, str) or _is_dask_client(executor):
            rows = _with_dask(executor, base, items, options, outputs, bar)
        else:
            raise TrebuchetInputError(f"executor {executor!r}: give None, a concurrent.futures "
                                      "Executor, a Dask scheduler address or a Dask Client")
    table = pd.DataFrame(rows, columns=["design", *grid, "status", "error", *outputs])
    return table.sort_values("design", kind="stable").reset_index(drop=True)


def _with_dask(executor: Any, base: Scene, items: list, options: SimulationOptions,
               outputs: Sequence[str], bar: Any) -> list[dict]:
    if not isinstance(executor, str):
        return list(_run_dask(executor, base, items, options, outputs, bar))
    try:
        from dask.distributed import Client
    except ImportError:
        raise TrebuchetInputError(f"scheduler {executor!r}: a Dask cluster needs dask; install "
                                  "the 'cluster' extra (pip install 'trebuchet[cluster]')"
                                  ) from None
    try:
        client = Client(executor, timeout="10s")
    except OSError as exc:
        raise TrebuchetInputError(f"scheduler {executor!r}: cannot connect: {exc}") from None
    with client:
        return list(_run_dask(client, base, items, options, outputs, bar))
