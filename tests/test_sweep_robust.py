"""A sweep survives its workers: a worker killed (kill -9) costs the design it was running, a
design over its time or memory budget is stopped, a killed sweep keeps its finished rows for
--resume, and a Dask cluster without workers ends the sweep instead of hanging it."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from trebuchet.core.errors import TrebuchetInputError
from trebuchet.model import sweep as sweep_module
from trebuchet.model.sweep import Budget, SimulationOptions, sweep
from trebuchet.model.sweep_journal import journal_path, open_journal

from .conftest import HORSDAL

GRID = {"engine.M": [15000.0, 17000.0, 19100.0, 21000.0],
        "release.velocity_angle_deg": [35.0, 45.0]}
FAST = SimulationOptions(rtol="fast")
PARENT = os.getpid()


@pytest.fixture(scope="module")
def serial(horsdal) -> pd.DataFrame:
    return sweep(horsdal, GRID, workers=1, progress=False, options=FAST)


def _sabotage(monkeypatch, victim: int, act) -> None:
    """Make design ``victim`` run ``act()`` in a worker process (never in this process), run
    alone or in a batch (a worker's chunk in one call: then the batch dies, stalls or grows,
    and the chunk's rerun one design a call names the victim)."""
    real, real_many = sweep_module.evaluate_design, sweep_module.evaluate_designs

    def evaluate(base, item, **kwargs):
        if item[0] == victim and os.getpid() != PARENT:
            act()
        return real(base, item, **kwargs)

    def evaluate_many(base, items, **kwargs):
        if any(index == victim for index, _ in items) and os.getpid() != PARENT:
            act()
        return real_many(base, items, **kwargs)

    monkeypatch.setattr(sweep_module, "evaluate_design", evaluate)
    monkeypatch.setattr(sweep_module, "evaluate_designs", evaluate_many)


def _others_equal(table: pd.DataFrame, serial: pd.DataFrame, victim: int) -> None:
    keep = table["design"] != victim
    pd.testing.assert_frame_equal(table[keep].reset_index(drop=True),
                                  serial[keep].reset_index(drop=True))


def test_killed_worker_costs_one_design(monkeypatch, horsdal, serial):
    _sabotage(monkeypatch, 5, lambda: os.kill(os.getpid(), signal.SIGKILL))
    table = sweep(horsdal, GRID, workers=2, progress=False, options=FAST)
    lost = table.iloc[5]
    assert lost["status"] == "failed"
    assert lost["error"].startswith("its worker process died (killed by SIGKILL)")
    assert np.isnan(lost["range"])
    _others_equal(table, serial, 5)


def test_design_over_time_budget_is_stopped(monkeypatch, horsdal, serial):
    _sabotage(monkeypatch, 2, lambda: time.sleep(60))
    t0 = time.monotonic()
    table = sweep(horsdal, GRID, workers=2, progress=False, options=FAST,
                  budget=Budget(seconds=1.0))
    assert time.monotonic() - t0 < 20
    slow = table.iloc[2]
    assert slow["status"] == "over_budget" and "time budget" in slow["error"]
    _others_equal(table, serial, 2)


def test_design_over_memory_budget_is_stopped(monkeypatch, horsdal, serial):
    """A design that allocates 4 GiB in a worker allowed 256 MiB: its row says so, the
    machine's memory is not touched (the worker's address space is capped)."""
    from trebuchet.model import sweep_design

    real, real_many = sweep_design.shot_figures, sweep_design.designs_values

    def figures(scene, **kwargs):
        if scene.source == "design 6" and os.getpid() != PARENT:
            np.ones(2**29)
        return real(scene, **kwargs)

    def many(scenes, **kwargs):  # a batch holding design 6 runs out of memory too
        if any(s.source == "design 6" for s in scenes) and os.getpid() != PARENT:
            np.ones(2**29)
        return real_many(scenes, **kwargs)

    monkeypatch.setattr(sweep_design, "shot_figures", figures)
    monkeypatch.setattr(sweep_design, "designs_values", many)
    table = sweep(horsdal, GRID, workers=2, progress=False, options=FAST,
                  budget=Budget(memory=256 * 2**20))
    big = table.iloc[6]
    assert big["status"] == "over_budget" and "memory budget" in big["error"]
    _others_equal(table, serial, 6)


# --------------------------------------------------------------------------- batches

#: 24 designs: on 2 workers two chunks of 12, each run in one batched call of the C.
BIG = {"engine.M": [15000.0, 16000.0, 17000.0, 18000.0, 19100.0, 20000.0, 21000.0, 22000.0],
       "release.velocity_angle_deg": [35.0, 40.0, 45.0]}


def _logged(log: Path, what: str, items) -> None:
    with open(log, "a") as f:
        f.write(f"{os.getpid()} {what} {' '.join(str(i) for i, _ in items)}\n")


def test_batch_killed_midway_loses_no_design(monkeypatch, tmp_path, horsdal):
    """A worker killed half-way through a batch: its chunk is run again one design a call,
    which names the victim; no row is lost or doubled, the others are the serial table's."""
    victim, log = 10, tmp_path / "calls.txt"
    real, real_many = sweep_module.evaluate_design, sweep_module.evaluate_designs

    def evaluate(base, item, **kwargs):
        if os.getpid() != PARENT:
            _logged(log, "one", [item])
            if item[0] == victim:
                os.kill(os.getpid(), signal.SIGKILL)
        return real(base, item, **kwargs)

    def evaluate_many(base, items, **kwargs):
        if os.getpid() != PARENT:
            _logged(log, "batch", items)
            if any(index == victim for index, _ in items):  # half done, then killed
                real_many(base, [it for it in items if it[0] < victim], **kwargs)
                os.kill(os.getpid(), signal.SIGKILL)
        return real_many(base, items, **kwargs)

    serial = sweep(horsdal, BIG, workers=1, progress=False, options=FAST)
    monkeypatch.setattr(sweep_module, "evaluate_design", evaluate)
    monkeypatch.setattr(sweep_module, "evaluate_designs", evaluate_many)
    table = sweep(horsdal, BIG, workers=2, progress=False, options=FAST)
    assert list(table["design"]) == list(range(24))
    assert list(table.index[table["status"] != "ok"]) == [victim]
    assert table["error"].iloc[victim].startswith("its worker process died (killed by SIGKILL)")
    _others_equal(table, serial, victim)
    calls = [line.split() for line in log.read_text().splitlines()]
    batches = [c[2:] for c in calls if c[1] == "batch"]
    ones = sorted(int(c[2]) for c in calls if c[1] == "one")
    assert sorted(map(len, batches)) == [12, 12] and ["10"] in [b[10:11] for b in batches]
    # the victim's chunk only, one by one; then its rest (0-9, whose rows died with the
    # worker, and 11) in a new worker
    assert ones == sorted([*range(10), *range(12)])


def test_batch_that_raises_runs_one_by_one_in_its_worker(monkeypatch, tmp_path, horsdal,
                                                          serial):
    """An exception in a worker's batched call: the worker runs that chunk one design a call
    itself (no worker lost), and the rows are the serial table's."""
    log = tmp_path / "calls.txt"
    real, real_many = sweep_module.evaluate_design, sweep_module.evaluate_designs

    def evaluate(base, item, **kwargs):
        if os.getpid() != PARENT:
            _logged(log, "one", [item])
        return real(base, item, **kwargs)

    def evaluate_many(base, items, **kwargs):
        if os.getpid() != PARENT:
            _logged(log, "batch", items)
            if any(index == 3 for index, _ in items):
                raise RuntimeError("sabotage")
        return real_many(base, items, **kwargs)

    monkeypatch.setattr(sweep_module, "evaluate_design", evaluate)
    monkeypatch.setattr(sweep_module, "evaluate_designs", evaluate_many)
    table = sweep(horsdal, GRID, workers=2, progress=False, options=FAST)
    pd.testing.assert_frame_equal(table, serial)
    calls = [line.split() for line in log.read_text().splitlines()]
    raised = [c for c in calls if c[1] == "batch" and "3" in c[2:]]
    assert len(raised) == 1 and len(raised[0]) > 3  # one batch, of several designs
    pid, _, *indices = raised[0]
    assert [c for c in calls if c[1] == "one"] == [[pid, "one", i] for i in indices]


def _row(item):
    return {"design": item[0], "status": "ok"}


def _kill_batch(chunk):
    os.kill(os.getpid(), signal.SIGKILL)


def _lost_row(item, status, reason):
    return {"design": item[0], "status": status}


@pytest.mark.skipif(sys.platform != "linux", reason="kill -9 of workers")
def test_batch_deaths_are_not_idle_deaths():
    """Every batch dies: more deaths than the pool forgives between designs (3 a worker + 3),
    yet each chunk's rerun one design a call gives every row."""
    from trebuchet.model.sweep_pool import WorkerPool

    chunks = [[(i, {})] for i in range(12)] + [[(12, {}), (13, {})]]
    with WorkerPool(_row, 2, Budget(), _lost_row, _kill_batch) as pool:
        rows = [row for batch in pool.run(chunks) for row in batch]
    assert sorted(r["design"] for r in rows) == list(range(14))
    assert {r["status"] for r in rows} == {"ok"}


def test_bad_budget_refused(horsdal):
    with pytest.raises(TrebuchetInputError, match="time budget"):
        sweep(horsdal, GRID, progress=False, budget=Budget(seconds=0.0))
    with pytest.raises(TrebuchetInputError, match="memory budget"):
        sweep(horsdal, GRID, progress=False, budget=Budget(memory=1000))


# --------------------------------------------------------------------------- journal


def test_journal_resume_runs_only_the_rest(tmp_path, horsdal, serial, monkeypatch):
    log = tmp_path / "s.csv.partial"
    first = sweep(horsdal, {"engine.M": GRID["engine.M"][:2],
                            "release.velocity_angle_deg": [35.0, 45.0]}, workers=1,
                  progress=False, options=FAST)
    # a journal of the full grid holding its first four rows, the last cut by a kill
    columns = list(serial.columns)
    digest = sweep_module.sweep_digest(horsdal.to_dict(), sweep_module.check_grid(GRID),
                                       tuple(sweep_module.SUMMARY_COLUMNS), FAST)
    journal, rows = open_journal(log, digest, columns, resume=False)
    assert rows == []
    journal.append(first.to_dict("records"))
    journal.close()
    with open(log, "a") as f:
        f.write("4,17000.0,35.0,ok,,0.3")  # a line cut short
    ran = []
    real = sweep_module.evaluate_designs
    monkeypatch.setattr(sweep_module, "evaluate_designs", lambda base, items, **kw: ran.extend(
        i for i, _ in items) or real(base, items, **kw))
    with pytest.raises(TrebuchetInputError, match="--resume"):
        sweep(horsdal, GRID, workers=1, progress=False, options=FAST, journal=log)
    table = sweep(horsdal, GRID, workers=1, progress=False, options=FAST, journal=log,
                  resume=True)
    assert ran == [4, 5, 6, 7]
    pd.testing.assert_frame_equal(table, serial)
    assert len(log.read_text().splitlines()) == 2 + 8  # the cut line is gone


def test_journal_of_another_sweep_refused(tmp_path, horsdal):
    log = tmp_path / "s.csv.partial"
    sweep(horsdal, {"engine.M": [19100.0]}, workers=1, progress=False, options=FAST,
          journal=log)
    with pytest.raises(TrebuchetInputError, match="another sweep"):
        sweep(horsdal, {"engine.M": [20000.0]}, workers=1, progress=False, options=FAST,
              journal=log, resume=True)


# --------------------------------------------------------------------------- the command line

GRID_ARGS = ["--grid", "engine.M=15000:22000:20", "--grid",
             "release.velocity_angle_deg=30:50:10", "--accuracy", "fast", "--quiet"]  # 200
#: The command line with every design slowed by TB_TEST_DELAY s, so that a test can act
#: while it runs (in worker processes one design a call, in this process a chunk a call).
_SLOW_CLI = """
import os, sys, time
from trebuchet import cli
from trebuchet.model import sweep
real, delay = sweep.evaluate_design, float(os.environ["TB_TEST_DELAY"])
real_many = sweep.evaluate_designs
def slow(base, item, **kw):
    time.sleep(delay)
    return real(base, item, **kw)
def slow_many(base, items, **kw):  # workers=1: a chunk of designs a call of the C
    rows = []
    for item in items:  # a design at a time, so that rows come in while the test acts
        time.sleep(delay)
        rows += real_many(base, [item], **kw)
    return rows
sweep.evaluate_design, sweep.evaluate_designs = slow, slow_many
sys.exit(cli.main(sys.argv[1:]))
"""


def _cli(args: list[str], delay: float = 0.0) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", _SLOW_CLI, "sweep", str(HORSDAL), *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "TB_TEST_DELAY": str(delay)})


def _wait_for_rows(journal: Path, n: int, proc: subprocess.Popen, timeout: float = 60) -> None:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if journal.is_file() and len(journal.read_bytes().splitlines()) >= n + 2:
            return
        if proc.poll() is not None:
            pytest.fail(f"the sweep ended early: {proc.communicate()}")
        time.sleep(0.02)
    pytest.fail("no rows came")


def _children(pid: int) -> list[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        pytest.skip("no /proc children list here")
    return [int(c) for c in text.split()]


@pytest.mark.skipif(sys.platform != "linux", reason="kills a worker found in /proc")
def test_cli_worker_killed_sweep_goes_on(tmp_path):
    out = tmp_path / "sweep.csv"
    proc = _cli([*GRID_ARGS, "-o", str(out), "--workers", "2"], delay=0.01)
    _wait_for_rows(journal_path(out), 20, proc)
    workers = _children(proc.pid)
    assert workers, "no worker processes"
    os.kill(workers[0], signal.SIGKILL)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 0, stderr
    assert "Traceback" not in stderr
    table = pd.read_csv(out, keep_default_na=False, na_values=[""])
    assert sorted(table["design"]) == list(range(200))
    failed = table[table["status"] == "failed"]
    assert len(failed) <= 1 and (table["status"] == "ok").sum() >= 199
    assert all(e.startswith("its worker process died") for e in failed["error"])
    assert "failed" in stdout or failed.empty
    assert not journal_path(out).exists()


@pytest.mark.skipif(sys.platform != "linux", reason="kill -9 of the sweep")
def test_cli_killed_sweep_resumes(tmp_path, capsys):
    out = tmp_path / "sweep.csv"
    proc = _cli([*GRID_ARGS, "-o", str(out), "--workers", "1"], delay=0.01)
    _wait_for_rows(journal_path(out), 40, proc)
    proc.kill()
    proc.communicate()
    assert not out.exists()
    kept = pd.read_csv(journal_path(out), comment="#", keep_default_na=False, na_values=[""])
    assert len(kept) >= 40
    from trebuchet import cli

    assert cli.main(["sweep", str(HORSDAL), *GRID_ARGS, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "--resume" in err and err.count("\n") == 1 and not out.exists()
    assert cli.main(["sweep", str(HORSDAL), *GRID_ARGS, "-o", str(out), "--resume"]) == 0
    table = pd.read_csv(out, keep_default_na=False, na_values=[""])
    assert list(table["design"]) == list(range(200))
    assert (table["status"] == "ok").all()
    merged = table.set_index("design").loc[kept["design"]]
    pd.testing.assert_frame_equal(merged.reset_index()[kept.columns], kept, check_exact=True)
    assert not journal_path(out).exists()


# --------------------------------------------------------------------------- Dask


def test_dask_without_workers_ends(horsdal):
    """A cluster whose workers are all gone (here: none ever came) gives its designs back as
    failed after ``lost_after`` s, instead of waiting for ever."""
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=0, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        t0 = time.monotonic()
        table = sweep(horsdal, GRID, executor=client, progress=False, options=FAST,
                      lost_after=1.0)
    assert time.monotonic() - t0 < 15
    assert (table["status"] == "failed").all() and len(table) == 8
    assert table["error"].str.startswith("no Dask worker left").all()
    assert math.isnan(table["range"].iloc[0])


def test_dask_workers_gone_mid_sweep_keeps_what_finished(horsdal, monkeypatch):
    """Every worker of the cluster closed while the sweep runs: the rows finished before are
    kept, the others come back failed after ``lost_after`` s, and the sweep ends."""
    import threading

    distributed = pytest.importorskip("dask.distributed")
    started = threading.Event()
    real = sweep_module.evaluate_designs

    def slow(base, items, **kwargs):
        if any(index >= 2 for index, _ in items):
            started.set()
            time.sleep(0.5)
        return real(base, items, **kwargs)

    monkeypatch.setattr(sweep_module, "evaluate_designs", slow)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        out: dict = {}
        run = threading.Thread(target=lambda: out.update(table=sweep(
            horsdal, GRID, executor=client, progress=False, options=FAST, lost_after=1.0)))
        run.start()
        assert started.wait(30)
        time.sleep(0.3)  # the first chunk's rows reach the client
        cluster.scale(0)
        run.join(60)
        assert not run.is_alive(), "the sweep hangs"
    table = out["table"]
    assert len(table) == 8 and (table["status"].iloc[:2] == "ok").all()
    gone = table.iloc[2:]
    assert (gone["status"] == "failed").all()
    assert gone["error"].str.startswith(("no Dask worker left", "its worker process died")).all()


@pytest.mark.skipif(sys.platform != "linux", reason="finds the workers in /proc")
def test_cli_ctrl_c_keeps_the_journal_and_stops_the_workers(tmp_path):
    out = tmp_path / "sweep.csv"
    proc = _cli([*GRID_ARGS, "-o", str(out), "--workers", "2"], delay=0.01)
    _wait_for_rows(journal_path(out), 20, proc)
    workers = _children(proc.pid)
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130 and stderr.strip() == "trebuchet: interrupted"
    assert not out.exists() and journal_path(out).is_file()
    time.sleep(0.5)
    assert not [pid for pid in workers if Path(f"/proc/{pid}").exists()
                and "Z" not in Path(f"/proc/{pid}/stat").read_text().split()[2]]


def test_dask_design_over_its_time_budget(horsdal, monkeypatch):
    """On a cluster a design over its time budget is flagged and its chunk cancelled; the
    sweep ends without waiting for it."""
    distributed = pytest.importorskip("dask.distributed")
    _sabotage_threads = sweep_module.evaluate_designs

    def slow(base, items, **kwargs):
        if any(index == 7 for index, _ in items):
            time.sleep(5.0)
        return _sabotage_threads(base, items, **kwargs)

    monkeypatch.setattr(sweep_module, "evaluate_designs", slow)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        t0 = time.monotonic()
        table = sweep(horsdal, GRID, executor=client, progress=False, options=FAST,
                      budget=Budget(seconds=0.3))
        assert time.monotonic() - t0 < 4.5
    assert table["status"].iloc[7] == "over_budget" and "Dask" in table["error"].iloc[7]
    assert (table["status"].iloc[:6] == "ok").all()
