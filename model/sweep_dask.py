"""Sweeps on a Dask cluster that end, whatever happens to the cluster.

:func:`run_dask` maps chunks of designs over the cluster's workers and yields each chunk's
rows as it finishes, watching the cluster meanwhile:

* a chunk whose worker died running it (Dask reports ``KilledWorker`` once the scheduler's
  ``allowed-failures`` are spent) or that failed on the worker: its designs are ``failed``,
  with the reason;
* no worker left (all killed, or the cluster shut down) for ``lost_after`` s: every design not
  yet done is ``failed`` ("no Dask worker left") and the sweep ends; the same when the
  scheduler itself is gone;
* a chunk processing for longer than the :class:`~trebuchet.model.sweep_pool.Budget`'s
  ``seconds`` per design: its designs are ``over_budget`` and the chunk is cancelled (a
  worker's thread cannot be stopped; the worker's memory is its nanny's ``memory_limit``).

dask is imported only here, and only when a sweep asks for a cluster.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from trebuchet.model.sweep_design import LOST, STATUS_FAILED, STATUS_OVER_BUDGET, Budget

__all__ = ["run_dask", "LOST_AFTER"]

#: s without any worker after which a Dask sweep gives up its remaining designs.
LOST_AFTER = 30.0
_POLL = 0.05
_WATCH = 1.0  # s between looks at the cluster


def run_dask(client: Any, chunks: Sequence[list], evaluate_chunk: Callable[..., list],
             lost_row: Callable[[Any, str, str], dict], budget: Budget,
             lost_after: float = LOST_AFTER, **kwargs: Any) -> Iterator[list[dict]]:
    """Evaluate ``evaluate_chunk(chunk, **kwargs)`` for every chunk on the cluster of
    ``client``; yield each chunk's rows (``lost_row(item, status, reason)`` for a design that
    did not run). Ends when every chunk has an answer (see the module doc)."""
    from dask.distributed import as_completed  # the cluster extra

    futures = client.map(evaluate_chunk, chunks, pure=False, **kwargs)
    chunk_of = {f.key: list(c) for f, c in zip(futures, chunks, strict=True)}
    pending = {f.key: f for f in futures}
    done = as_completed(futures, with_results=True, raise_errors=False)  # fetched at once
    started: dict[str, float] = {}
    no_worker_since: float | None = None
    next_watch = time.monotonic() + _WATCH
    try:
        while pending:
            if done.has_ready():
                for future, result in done.next_batch(block=False):
                    if pending.pop(future.key, None) is not None:
                        yield _rows_of(future, result, chunk_of[future.key], lost_row)
                continue
            time.sleep(_POLL)
            if time.monotonic() < next_watch:
                continue
            next_watch = time.monotonic() + _WATCH
            verdict = _watch(client, pending, chunk_of, started, budget)
            if verdict == "no workers":
                no_worker_since = no_worker_since or time.monotonic()
                if time.monotonic() - no_worker_since < lost_after:
                    continue
                verdict = f"no Dask worker left (none for {lost_after:g} s)"
            elif verdict is None:
                no_worker_since = None
                continue
            if isinstance(verdict, list):  # chunks over their time budget
                for key in verdict:
                    pending.pop(key).cancel()
                    yield [lost_row(item, STATUS_OVER_BUDGET, "over the time budget on the Dask "
                                    f"cluster: its chunk ran over {budget.seconds:g} s a design"
                                    " (cancelled; the worker's thread may run on)")
                           for item in chunk_of[key]]
                continue
            for key, future in list(pending.items()):
                future.cancel()
                del pending[key]
                yield [lost_row(item, STATUS_FAILED, f"{verdict}; --resume runs it again")
                       for item in chunk_of[key]]
    finally:
        for future in pending.values():
            future.cancel()


def _rows_of(future: Any, result: Any, chunk: list,
             lost_row: Callable[[Any, str, str], dict]) -> list[dict]:
    """The rows of a finished future, or a ``failed`` row per design where it gave none."""
    if future.status == "finished" and isinstance(result, list):
        return result
    if type(result).__name__ == "KilledWorker":
        reason = f"{LOST} (Dask: KilledWorker) while running this design's chunk"
    elif isinstance(result, BaseException):
        reason = f"Dask: {type(result).__name__}: {result}"
    else:
        reason = f"{LOST} (Dask: its chunk's result was {future.status})"
    return [lost_row(item, STATUS_FAILED, reason) for item in chunk]


def _watch(client: Any, pending: dict, chunk_of: dict, started: dict[str, float],
           budget: Budget) -> str | list[str] | None:
    """A look at the cluster: ``"no workers"``; a message if the scheduler is gone; the keys
    of chunks over their time budget; or None when all is well."""
    try:
        nthreads = client.nthreads()
        processing = client.processing() if budget.seconds is not None else {}
    except Exception as exc:  # noqa: BLE001 - any failure to reach the scheduler
        return f"the Dask scheduler is gone ({type(exc).__name__})"
    if not nthreads:
        return "no workers"
    if budget.seconds is None:
        return None
    now = time.monotonic()
    running = {str(k) for keys in processing.values() for k in keys}
    over = []
    for key in pending:
        if str(key) in running:
            started.setdefault(key, now)
            if now - started[key] > budget.seconds * len(chunk_of[key]):
                over.append(key)
    return over or None
