"""Parameter sweeps: simulate every design of a grid and tabulate what matters.

A grid names scene keys as ``"section.key"`` and lists values for each; :func:`sweep`
simulates the cartesian product, one design per combination, and returns one row per design:
its parameters, a ``status``, an ``error`` with the reason for a design that is not ``ok``, and
the figures of :data:`SUMMARY_COLUMNS` (SI units). No design is ever dropped: a design the
model refuses, one that throws backward or into the ground, one whose worker died and one over
its budget each keep their row and say why (:mod:`trebuchet.model.sweep_design`, which also
builds each design's scene).

Each design's figures come from the summary-only path
(:func:`~trebuchet.model.shot_summary.shot_figures`): no table per design, the shot and its
peaks over the continuous shot in the generated C, a chunk of designs a call
(:func:`~trebuchet.model.sweep_design.evaluate_designs`), in this process, an executor's or a
worker process of the sweep's own; there a chunk that dies or runs over one design's budget
is run again one design a call (:func:`~trebuchet.model.sweep_design.evaluate_design`), so
that the worker always knows which design it holds when one of them kills it.

Where designs run: local worker processes (:func:`~trebuchet.model.sweep_pool.run_pool`,
one per core by default; a worker that dies costs the design it was running, and a design over
the :class:`~trebuchet.model.sweep_pool.Budget` of time or memory is stopped), the calling
process (``workers=1``), any :class:`concurrent.futures.Executor` given, or a Dask cluster
(``executor="tcp://host:port"`` or a ``dask.distributed.Client``; dask is imported only then;
:mod:`trebuchet.model.sweep_dask` ends the sweep when every worker is gone).

With a ``journal`` (the command line keeps one beside its output, ``OUTPUT.partial``) every
finished row is appended to it at once, and ``resume=True`` continues from it: a killed sweep
keeps what it finished (:mod:`trebuchet.model.sweep_journal`).
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Iterator, Mapping, Sequence
from concurrent.futures import Executor
from functools import partial
from pathlib import Path
from typing import Any

import pandas as pd
from tqdm.auto import tqdm

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model.scene import Scene
from trebuchet.model.sweep_dask import LOST_AFTER, run_dask
from trebuchet.model.sweep_design import (
    LOST,
    MAX_DESIGNS,
    STATUS_BACKWARD,
    STATUS_FAILED,
    STATUS_GROUND,
    STATUS_OK,
    STATUS_OVER_BUDGET,
    STATUS_REFUSED,
    STATUSES,
    SUMMARY_COLUMNS,
    Budget,
    SimulationOptions,
    accuracy_option,
    batched,
    check_grid,
    design_scene,
    evaluate_design,
    evaluate_designs,
    failed_row,
    grid_designs,
    output_step,
    parse_grid_option,
    parse_grid_values,
    summarize,
)
from trebuchet.model.sweep_journal import open_journal, sweep_digest
from trebuchet.model.sweep_pool import WorkerPool

__all__ = [
    "SUMMARY_COLUMNS", "SimulationOptions", "Budget", "output_step", "accuracy_option",
    "parse_grid_values", "parse_grid_option", "check_grid", "grid_designs", "design_scene",
    "summarize", "evaluate_design", "DesignRunner", "sweep", "default_workers", "MAX_DESIGNS",
    "STATUSES", "STATUS_OK", "STATUS_BACKWARD", "STATUS_GROUND", "STATUS_REFUSED",
    "STATUS_FAILED", "STATUS_OVER_BUDGET",
]


def default_workers() -> int:
    """Cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


_OPTIONS, _BUDGET = SimulationOptions(), Budget()  # the defaults (frozen)

#: Designs per chunk at most: a chunk takes well under a second, so that the progress bar
#: moves from the first second on however large the grid, and a dead worker's chunk is small.
MAX_CHUNK = 64


def _chunk_size(n: int, workers: int, per_worker: int = 4) -> int:
    """About ``per_worker`` chunks per worker (few round trips, and a slow chunk does not stall
    the end; one where a worker runs a chunk in one batched call, ~0.1 ms a design, so that
    the optimiser's small generations cost one round trip a worker), at most
    :data:`MAX_CHUNK` designs."""
    return max(1, min(MAX_CHUNK, math.ceil(n / (per_worker * workers))))


def _chunks(items: Sequence[Any], size: int) -> list[list[Any]]:
    return [list(items[i:i + size]) for i in range(0, len(items), size)]


def _evaluate_chunk(chunk: Sequence[tuple[int, Mapping[str, float]]], base: Scene,
                    options: SimulationOptions, outputs: Sequence[str]) -> list[dict[str, Any]]:
    return evaluate_designs(base, chunk, options=options, outputs=outputs)


def _is_dask_client(obj: Any) -> bool:
    return type(obj).__module__.split(".")[0] == "distributed" and hasattr(obj, "map")


class DesignRunner:
    """Runs batches of designs where :func:`sweep`'s ``executor`` and ``workers`` say, keeping
    its worker processes (or its Dask client) between batches: the optimiser's way in.
    Use it in a ``with`` block; :meth:`run` yields the rows of each batch as they finish."""

    def __init__(self, base: Scene, *, outputs: Sequence[str] = tuple(SUMMARY_COLUMNS),
                 executor: Executor | str | Any | None = None, workers: int | None = None,
                 options: SimulationOptions = _OPTIONS, budget: Budget = _BUDGET,
                 lost_after: float = LOST_AFTER) -> None:
        if not (executor is None or isinstance(executor, Executor | str)
                or _is_dask_client(executor)):
            raise TrebuchetInputError(f"executor {executor!r}: give None, a concurrent.futures "
                                      "Executor, a Dask scheduler address or a Dask Client")
        self.base, self.outputs, self.executor = base, tuple(outputs), executor
        self.workers = workers or default_workers()
        self.options, self.budget, self.lost_after = options, budget, lost_after
        self._evaluate = partial(evaluate_design, base, options=options, outputs=self.outputs)
        self._evaluate_batch = (partial(_evaluate_chunk, base=base, options=options,
                                        outputs=self.outputs) if batched(options) else None)
        self._lost = partial(failed_row, outputs=self.outputs)
        self._stack = contextlib.ExitStack()
        self._pool: WorkerPool | None = None
        self._client: Any = None
        self._warm = False

    def __enter__(self) -> DesignRunner:
        return self

    def __exit__(self, *exc: object) -> None:
        self._stack.close()

    def run(self, items: Sequence[tuple[int, Mapping[str, Any]]]
            ) -> Iterator[list[dict[str, Any]]]:
        """The rows of ``items`` (``(index, params)`` pairs), in batches as they finish."""
        items = list(items)
        if not items:
            return
        if self.executor is None and self.workers == 1:  # a chunk a call of the C engine
            for chunk in _chunks(items, _chunk_size(len(items), 1)):
                yield _evaluate_chunk(chunk, self.base, self.options, self.outputs)
        elif self.executor is None:
            if not self._warm:  # the compiled kernels, loaded once before workers fork
                self._warm = True
                with contextlib.suppress(Exception):
                    self._evaluate(items[0])
            if self._pool is None:
                self._pool = self._stack.enter_context(
                    WorkerPool(self._evaluate, self.workers, self.budget, self._lost,
                               self._evaluate_batch))
            size = _chunk_size(len(items), self.workers, 1 if self._evaluate_batch else 4)
            yield from self._pool.run(_chunks(items, size))
        elif isinstance(self.executor, Executor):
            size = _chunk_size(len(items), self.workers)
            yield from self.executor.map(partial(_evaluate_chunk, base=self.base,
                                                 options=self.options, outputs=self.outputs),
                                         _chunks(items, size))
        else:
            if self._client is None:
                self._client = self._stack.enter_context(_dask_client(self.executor))
            n = max(1, sum(self._client.nthreads().values()))
            yield from run_dask(self._client, _chunks(items, _chunk_size(len(items), n)),
                                _evaluate_chunk, self._lost, self.budget, self.lost_after,
                                base=self.base, options=self.options, outputs=self.outputs)


def sweep(base: Scene, grid: Mapping[str, Sequence[float]], *,
          outputs: Sequence[str] = tuple(SUMMARY_COLUMNS),
          executor: Executor | str | Any | None = None, workers: int | None = None,
          progress: bool = True, options: SimulationOptions = _OPTIONS,
          budget: Budget = _BUDGET, journal: str | Path | None = None,
          resume: bool = False, lost_after: float = LOST_AFTER) -> pd.DataFrame:
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
        None: local worker processes (``workers`` of them; ``workers=1`` runs in this
        process). A ``concurrent.futures.Executor``: its ``map``, chunked. A scheduler address
        (``"tcp://host:port"``) or a ``dask.distributed.Client``: a Dask cluster.
    workers : int, optional
        Local processes (default: the cores this process may use).
    progress : bool
        Show a tqdm progress bar (on stderr).
    options : SimulationOptions
        Solver tolerance, peaks over the continuous shot or a table's rows, phase III length.
    budget : Budget
        Time (s) and memory (bytes) one design may take in a worker process; beyond it the
        design is stopped and its row is ``over_budget``.
    journal : path, optional
        A file to append each finished row to as it comes (kept after a killed run).
    resume : bool
        Continue the sweep whose rows the ``journal`` holds: its designs are not run again,
        except those whose worker died.
    lost_after : float
        Dask: s without any worker after which the designs not yet done are ``failed``.

    Returns
    -------
    DataFrame, one row per design in grid order: ``design`` (index), one column per grid key,
    ``status`` (``ok``, ``backward``, ``ground``, ``refused``, ``failed``, ``over_budget``),
    ``error`` (the reason, empty when ok) and the ``outputs`` (SI units, see
    :data:`SUMMARY_COLUMNS`; NaN where the design gave none).
    """
    grid = check_grid(grid)
    options.check()
    budget.check()
    outputs = tuple(outputs)
    unknown = [k for k in outputs if k not in SUMMARY_COLUMNS]
    if unknown:
        raise TrebuchetInputError(f"outputs: {unknown[0]!r} unknown (known: "
                                  + ", ".join(SUMMARY_COLUMNS) + ")")
    if workers is not None and workers < 1:
        raise TrebuchetInputError(f"workers = {workers}: must be at least 1")
    clash = [k for k in options.sized_keys if k in grid]
    if clash:
        raise TrebuchetInputError(f"grid key {clash[0]!r}: a [sizing] rule sets it from each "
                                  "design's peak load; leave it out of the grid, or the rule "
                                  "out of the scene")
    columns = ["design", *grid, *options.sized_keys, "status", "error", *outputs]
    items = list(enumerate(grid_designs(grid)))
    log, rows = None, []
    if journal is not None:
        log, rows = open_journal(journal, sweep_digest(base.to_dict(), grid, outputs, options),
                                 columns, resume)
        rows = [r for r in rows if not (r["status"] == STATUS_FAILED
                                        and str(r["error"]).startswith(LOST))]
    done = {r["design"] for r in rows}
    todo = [item for item in items if item[0] not in done]
    runner = DesignRunner(base, outputs=outputs, executor=executor, workers=workers,
                          options=options, budget=budget, lost_after=lost_after)
    with contextlib.closing(log) if log else contextlib.nullcontext(), runner, \
            tqdm(total=len(items), initial=len(done), disable=not progress, unit="design",
                 desc="sweep") as bar:
        for batch in runner.run(todo):
            rows.extend(batch)
            if log:
                log.append(batch)
            bar.update(len(batch))
    table = pd.DataFrame(rows, columns=columns)
    return table.sort_values("design", kind="stable").reset_index(drop=True)


@contextlib.contextmanager
def _dask_client(executor: Any) -> Iterator[Any]:
    """The Dask client given, or one connected to the scheduler address given (closed after)."""
    if not isinstance(executor, str):
        yield executor
        return
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
        yield client
