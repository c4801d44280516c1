"""Local worker processes for sweeps: a dead worker costs one design, never the sweep.

:func:`run_pool` evaluates chunks of designs in worker processes of its own (not a
``concurrent.futures.ProcessPoolExecutor``, which breaks whole when one worker dies and cannot
say which design was running). Each worker writes the index of the design it is running and
its start time into shared memory, so that the parent knows, at every moment, which design
each worker holds:

* a worker that dies (``kill -9``, a crash in compiled code, the kernel's out-of-memory
  killer) costs the design it was running: that design's row is ``failed`` with the reason
  (the signal), the rest of its chunk goes back in the queue and a new worker takes its place;
* a design running longer than the :class:`Budget`'s ``seconds``, or whose worker grows by more
  than its ``memory`` (bytes of resident memory over the worker's own at start, read from
  ``/proc``; the worker's address space is also capped there, so that a single huge allocation
  raises ``MemoryError`` in the design instead), is stopped: its row is ``over_budget``.

Given an ``evaluate_batch`` (the sweep's batched C path, where it applies), a worker first runs
a whole chunk in one call, its slot marked "running a batch" (:data:`_BATCH`) with the start
time: a batch that dies, runs longer than ONE design's ``seconds`` or grows past ``memory`` is
stopped and its whole chunk goes back in the queue marked "one by one", where the per-design
path above names the culprit (no row lost or doubled; a batch's death is no idle death); a
batch that raises is run one by one in the worker itself.

Workers are forked where the platform can (the parent's compiled kernels come along) and
spawned elsewhere; they ignore Ctrl-C (the parent stops them) and die with the parent on Linux.
"""

from __future__ import annotations

import collections
import contextlib
import ctypes
import multiprocessing as mp
import os
import signal
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from multiprocessing.connection import wait
from typing import Any

from trebuchet.model.sweep_design import LOST, STATUS_FAILED, STATUS_OVER_BUDGET, Budget

__all__ = ["WorkerPool", "run_pool"]

_IDLE = -1.0
_BATCH = -2.0  # the slot's mark of a worker running a whole chunk in one call
_POLL = 0.2  # s between the parent's looks at running designs (time, memory)


def _rss(pid: int) -> int | None:
    """Resident memory of process ``pid`` in bytes (Linux ``/proc``), None where unknown."""
    try:
        with open(f"/proc/{pid}/statm", "rb") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return None


def _die_with_parent() -> None:
    """Linux: SIGKILL this process when its parent dies (prctl PR_SET_PDEATHSIG)."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)


def _cap_address_space(memory: int | None) -> None:
    """Cap this process's address space at its size now plus ``memory`` bytes, so that an
    allocation beyond the budget raises MemoryError in the design."""
    if memory is None:
        return
    try:
        import resource

        with open("/proc/self/statm", "rb") as f:
            size = int(f.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
        _, hard = resource.getrlimit(resource.RLIMIT_AS)
        cap = size + memory
        if hard == resource.RLIM_INFINITY or cap < hard:
            resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    except (ImportError, OSError, ValueError):
        pass


def _worker(conn: Any, slot: Any, evaluate: Callable[[Any], dict],
            lost_row: Callable[[Any, str, str], dict], memory: int | None,
            evaluate_batch: Callable[[list], list[dict]] | None = None) -> None:
    """A worker's loop: receive ``(chunk, batched)`` (a chunk of ``(index, params)`` items),
    evaluate it (a batched chunk in one call of ``evaluate_batch``, the slot marked
    :data:`_BATCH`; else, or if that raises, one item at a time, its index and start time in
    ``slot`` meanwhile), send back the rows; stop on None or a closed pipe. An allocation
    beyond the address-space cap makes the design ``over_budget``."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _die_with_parent()
    _cap_address_space(memory)
    while True:
        try:
            task = conn.recv()
        except (EOFError, OSError):
            return
        if task is None:
            return
        chunk, batched = task
        rows = None
        if batched and evaluate_batch is not None:
            slot[1] = time.monotonic()
            slot[0] = _BATCH
            with contextlib.suppress(Exception):  # MemoryError too: one by one says which
                rows = evaluate_batch(chunk)
        if rows is None:
            rows = [_one(item, slot, evaluate, lost_row, memory) for item in chunk]
        slot[0] = _IDLE
        try:
            conn.send(rows)
        except (OSError, ValueError):
            return


def _one(item: Any, slot: Any, evaluate: Callable[[Any], dict],
         lost_row: Callable[[Any, str, str], dict], memory: int | None) -> dict:
    """The row of one design in a worker, its index and start time in ``slot`` meanwhile."""
    slot[1] = time.monotonic()
    slot[0] = float(item[0])
    try:
        return evaluate(item)
    except MemoryError:
        return lost_row(item, STATUS_OVER_BUDGET, "over the memory budget: an allocation "
                        f"failed beyond {(memory or 0) / 2**20:.0f} MiB")
    except Exception as exc:  # noqa: BLE001 - the row says what went wrong
        return lost_row(item, STATUS_FAILED, f"{type(exc).__name__}: {exc}")


class _Worker:
    """One worker process, its pipe, its shared slot and the chunk it holds."""

    def __init__(self, ctx: Any, evaluate: Callable[[Any], dict],
                 lost_row: Callable[[Any, str, str], dict], memory: int | None,
                 evaluate_batch: Callable[[list], list[dict]] | None) -> None:
        self.slot = ctx.RawArray("d", [_IDLE, 0.0])
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=_worker, args=(child, self.slot, evaluate, lost_row,
                                                      memory, evaluate_batch), daemon=True)
        self.proc.start()
        child.close()
        self.task: tuple[list, bool] | None = None  # the chunk it holds, batched or not
        self.baseline = _rss(self.proc.pid)

    @property
    def chunk(self) -> list | None:
        """The chunk it holds, or None when idle."""
        return None if self.task is None else self.task[0]

    def give(self, task: tuple[list, bool]) -> None:
        self.task = task
        self.conn.send(task)

    def tell_stop(self) -> None:
        """Ask it to end (after the chunk it holds)."""
        with contextlib.suppress(OSError, ValueError):
            self.conn.send(None)

    def stop(self, kill: bool = False, told: bool = False) -> None:
        """End it: killed, or asked to (unless ``told`` already) and waited for."""
        if kill and self.proc.is_alive():
            with contextlib.suppress(OSError):
                os.kill(self.proc.pid, signal.SIGKILL)
        if not (kill or told):
            self.tell_stop()
        self.proc.join(timeout=None if kill else 2.0)
        if self.proc.is_alive():
            self.proc.kill()
            self.proc.join()
        self.conn.close()


def _context() -> Any:
    """Fork where there is one (the compiled kernels come along), else spawn."""
    methods = mp.get_all_start_methods()
    return mp.get_context("fork" if "fork" in methods and sys.platform != "darwin" else "spawn")


def _death(exitcode: int | None) -> str:
    if exitcode is not None and exitcode < 0:
        try:
            return f"killed by {signal.Signals(-exitcode).name}"
        except ValueError:
            return f"killed by signal {-exitcode}"
    return f"exit status {exitcode}"


class WorkerPool:
    """Worker processes kept between batches of designs (the optimiser's generations):
    :meth:`run` evaluates chunks in them, :meth:`close` (or leaving the ``with`` block) stops
    them. Each item is ``(index, params)``; a design whose worker died gets
    ``lost_row(item, "failed", reason)``, one over its budget
    ``lost_row(item, "over_budget", reason)``. With ``evaluate_batch`` (rows of a whole chunk
    in one call, the same as ``evaluate``'s one by one) a chunk is first tried in one call."""

    def __init__(self, evaluate: Callable[[Any], dict], workers: int, budget: Budget,
                 lost_row: Callable[[Any, str, str], dict],
                 evaluate_batch: Callable[[list], list[dict]] | None = None) -> None:
        self.evaluate, self.workers, self.budget, self.lost_row = (evaluate, workers, budget,
                                                                   lost_row)
        self.evaluate_batch = evaluate_batch
        self._ctx = _context()
        self._pool: list[_Worker] = []
        self._idle_deaths = 0

    def __enter__(self) -> WorkerPool:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        for w in self._pool:  # all told first, so that they end side by side
            if w.chunk is None:
                w.tell_stop()
        for w in self._pool:
            w.stop(kill=w.chunk is not None, told=True)
        self._pool = []

    def _new(self) -> _Worker:
        return _Worker(self._ctx, self.evaluate, self.lost_row, self.budget.memory,
                       self.evaluate_batch)

    def run(self, chunks: Sequence[list]) -> Iterator[list[dict]]:
        """Yield the rows of each chunk as it finishes (a chunk cut by a dead worker comes
        back in parts)."""
        batched = self.evaluate_batch is not None
        queue = collections.deque((list(c), batched) for c in chunks if len(c))
        while len(self._pool) < min(self.workers, len(queue)):
            self._pool.append(self._new())
        timeout = _POLL if self.budget.seconds is None else min(_POLL, self.budget.seconds / 4)
        try:
            while queue or any(w.chunk is not None for w in self._pool):
                self._hand_out(queue)
                busy = [w for w in self._pool if w.chunk is not None]
                ready = wait([w.conn for w in busy] + [w.proc.sentinel for w in busy], timeout)
                for i, w in enumerate(self._pool):
                    if w.chunk is None:
                        continue
                    rows = _receive(w) if w.conn in ready or w.proc.sentinel in ready else None
                    if rows is not None:
                        w.task = None
                        yield rows
                        continue
                    lost = self._stop_if_due(i, w, queue)
                    if lost:
                        yield lost
        finally:  # a run left early (Ctrl-C, an error): busy workers hold stale chunks
            for i, w in enumerate(self._pool):
                if w.chunk is not None:
                    w.stop(kill=True)
                    self._pool[i] = self._new()

    def _hand_out(self, queue: collections.deque) -> None:
        """A chunk to every idle worker (a worker that died idle is replaced first)."""
        for i, w in enumerate(self._pool):
            if w.chunk is not None or not queue:
                continue
            if not w.proc.is_alive():
                w.stop(kill=True)
                self._pool[i] = w = self._new()
            try:
                w.give(queue.popleft())
            except (OSError, ValueError):  # died just now: its chunk goes back
                queue.appendleft(w.task)
                w.task = None

    def _stop_if_due(self, i: int, w: _Worker, queue: collections.deque) -> list[dict]:
        """Stop a worker that died or whose design (or batch) is over its budget: the design's
        row and the rest of its chunk back in the queue (a batch's whole chunk, one by one),
        a new worker in its place."""
        alive = w.proc.is_alive()
        mark, started = w.slot[0], w.slot[1]
        verdict = _verdict(w, self.budget, alive, mark, started)
        if verdict is None:
            return []
        status, reason = verdict
        w.stop(kill=True)
        chunk, w.task = w.chunk, None
        self._pool[i] = self._new()
        if mark == _BATCH:  # the per-design path names the culprit
            queue.appendleft((chunk, False))
            return []
        index = None if mark == _IDLE else int(mark)
        culprit = [item for item in chunk if item[0] == index]
        rest = [item for item in chunk if item[0] != index]
        if not culprit:
            self._idle_deaths += 1
            if self._idle_deaths > 3 * self.workers + 3:
                raise RuntimeError(f"sweep: worker processes keep dying between designs "
                                   f"({reason})")
        if rest:
            queue.appendleft((rest, False))
        return [self.lost_row(culprit[0], status, reason)] if culprit else []


def run_pool(chunks: Sequence[list], evaluate: Callable[[Any], dict], workers: int,
             budget: Budget, lost_row: Callable[[Any, str, str], dict],
             evaluate_batch: Callable[[list], list[dict]] | None = None,
             ) -> Iterator[list[dict]]:
    """:meth:`WorkerPool.run` once, in a pool of its own."""
    with WorkerPool(evaluate, workers, budget, lost_row, evaluate_batch) as pool:
        yield from pool.run(chunks)


def _receive(w: _Worker) -> list[dict] | None:
    """The rows a worker sent, or None if it has none to give (it died)."""
    try:
        if w.conn.poll():
            return w.conn.recv()
    except (EOFError, OSError):
        return None
    return None


def _verdict(w: _Worker, budget: Budget, alive: bool, mark: float, started: float,
             ) -> tuple[str, str] | None:
    """Why a busy worker must be stopped now: ``("failed", reason)`` if it died,
    ``("over_budget", reason)`` if its design (or its batch: a whole chunk held to one
    design's budget) is over the budget; None to let it run. ``mark`` and ``started`` are its
    slot, read in that order after ``alive`` (the worker writes them the other way round)."""
    if not alive:
        return STATUS_FAILED, f"{LOST} ({_death(w.proc.exitcode)}) while running this design"
    if mark == _IDLE:
        return None
    if budget.seconds is not None and time.monotonic() - started > budget.seconds:
        return STATUS_OVER_BUDGET, ("over the time budget: still running after "
                                    f"{budget.seconds:g} s (stopped)")
    if budget.memory is not None and w.baseline is not None:
        rss = _rss(w.proc.pid)
        if rss is not None and rss - w.baseline > budget.memory:
            return STATUS_OVER_BUDGET, (f"over the memory budget: its worker grew by "
                                 f"{(rss - w.baseline) / 2**20:.0f} MiB, more than "
                                 f"{budget.memory / 2**20:.0f} MiB (stopped)")
    return None
