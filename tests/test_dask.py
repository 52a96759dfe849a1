"""Dask distributed scale-out: with ``$MMLIB_SCHEDULER`` set, the chunks of ``evaluate`` and the universes of
``run_grid`` run on the cluster and give the serial run's numbers bit for bit; a worker killed mid-study is replaced
and its chunk recomputed, neither lost nor duplicated; an unreachable scheduler, or one lost mid-run, is an error
naming MMLIB_SCHEDULER and the address within the stated timeout.  The clusters are started here (a LocalCluster of
two worker processes; a scheduler and a worker as subprocesses for the scheduler that disappears)."""
from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

pytest.importorskip("distributed", reason="the optional dask extra is not installed")

from mmlib.experiment import evaluation, executors, run_grid  # noqa: E402
from mmlib.papers import REGISTRY  # noqa: E402

from test_parallel import N_RUNS, assert_same_bits, zhou_study  # noqa: E402

SCHEDULER = executors.SCHEDULER_VARIABLE


@pytest.fixture(scope="module")
def cluster():
    from distributed import LocalCluster
    with LocalCluster(n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None) as lc:
        yield lc
        executors._close_client(lc.scheduler_address)


@pytest.fixture
def on_cluster(cluster, monkeypatch):
    monkeypatch.setenv(SCHEDULER, cluster.scheduler_address)
    return executors.dask_client(cluster.scheduler_address)


@pytest.fixture(scope="module")
def serial():
    estimators, make_batch, mc = zhou_study()
    return evaluation.evaluate(estimators, make_batch, mc, chunk_size=N_RUNS, workers=1, progress=False)


def logged(make_batch, log: Path, delay: float = 0.0):
    """``make_batch`` that appends ``start <first run> <pid>`` and ``end <first run> <pid>`` to ``log`` around
    itself (after sleeping ``delay`` s, which makes a chunk slow enough to be caught running); same numbers."""
    def batch(runs):
        with open(log, "a") as fh:
            fh.write(f"start {runs.start} {os.getpid()}\n")
        time.sleep(delay)
        out = make_batch(runs)
        with open(log, "a") as fh:
            fh.write(f"end {runs.start} {os.getpid()}\n")
        return out
    return batch


def read_log(log: Path) -> list[tuple[str, int, int]]:
    return [(w, int(a), int(p)) for w, a, p in (ln.split() for ln in log.read_text().splitlines())]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_evaluate_on_the_cluster_gives_the_serial_bits(on_cluster, serial, tmp_path):
    estimators, make_batch, mc = zhou_study()
    log = tmp_path / "log"
    got = evaluation.evaluate(estimators, logged(make_batch, log), mc, chunk_size=2, workers=2, progress=False)
    assert_same_bits(got, serial)
    worker_pids = set(on_cluster.run(os.getpid).values())
    ends = [(a, p) for w, a, p in read_log(log) if w == "end"]
    assert sorted(a for a, _ in ends) == [0, 2, 4, 6] and {p for _, p in ends} <= worker_pids


def test_run_grid_on_the_cluster_equals_serial(on_cluster, tmp_path):
    paper = REGISTRY["zhu2016"]
    readings = list(paper.space.design("star").readings)[:3]
    kw = dict(paper=paper.name, algorithms=paper.algorithms, n_runs=4, seed=paper.root_seed, use_cache=False,
              progress=False)
    on_dask = run_grid(paper.universe, readings, **kw)
    given = run_grid(paper.universe, readings, executor=executors.dask_executor(), **kw)
    serial = run_grid(paper.universe, readings, workers=1, **kw)
    assert on_dask == given == serial and serial[0] != serial[1]
    assert set(executors.run_tasks(os.getpid, [()] * 4)) <= set(on_cluster.run(os.getpid).values())


def test_killed_worker_chunk_is_recomputed_not_lost_nor_duplicated(on_cluster, serial, tmp_path):
    """A worker is SIGKILLed while it runs a chunk; the nanny replaces it, Dask reruns the chunk elsewhere, and the
    study completes with the serial bits: every chunk finished exactly once."""
    estimators, make_batch, mc = zhou_study()
    log = tmp_path / "log"
    log.touch()
    pids = set(on_cluster.run(os.getpid).values())
    killed = []

    def killer():
        deadline = time.monotonic() + 60
        while not killed and time.monotonic() < deadline:
            starts = [(a, p) for w, a, p in read_log(log) if w == "start"]
            if starts:
                killed.append(starts[0])
                os.kill(starts[0][1], signal.SIGKILL)     # inside its chunk's 1-s sleep
            time.sleep(0.01)

    thread = threading.Thread(target=killer)
    thread.start()
    got = evaluation.evaluate(estimators, logged(make_batch, log, delay=1.0), mc, chunk_size=2, progress=False)
    thread.join()
    assert_same_bits(got, serial)
    (chunk, pid), = killed
    assert pid in pids
    entries = read_log(log)
    assert sorted(a for w, a, p in entries if w == "end") == [0, 2, 4, 6]    # each chunk finished exactly once
    started_by = [p for w, a, p in entries if w == "start" and a == chunk]
    finished_by = [p for w, a, p in entries if w == "end" and a == chunk]
    assert started_by[0] == pid and len(started_by) >= 2                     # started again after the kill...
    assert len(finished_by) == 1 and finished_by[0] != pid                   # ...and finished by another worker


def test_a_worker_with_another_mmlib_is_refused(on_cluster, monkeypatch):
    monkeypatch.setattr(executors, "source_hash", lambda: "0" * 16)
    with pytest.raises(RuntimeError, match=f"^{SCHEDULER}: the worker .* runs another mmlib"):
        executors.run_tasks(os.getpid, [()] * 2)


def test_unreachable_scheduler_is_named_within_the_timeout(monkeypatch):
    monkeypatch.setattr(executors, "SCHEDULER_TIMEOUT", 3.0)
    address = f"tcp://127.0.0.1:{free_port()}"
    monkeypatch.setenv(SCHEDULER, address)
    estimators, make_batch, mc = zhou_study()
    t0 = time.monotonic()
    with pytest.raises(executors.SchedulerError, match=f"^{SCHEDULER}: no Dask scheduler answered at "
                                                         f"{address} within 3 s"):
        evaluation.evaluate(estimators, make_batch, mc, chunk_size=2, progress=False)
    assert time.monotonic() - t0 < 3.0 + 2.0


@pytest.fixture
def doomed_scheduler(tmp_path):
    """A scheduler and one worker as subprocesses (the test kills the scheduler)."""
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                               "--port", str(port), "--no-dashboard"], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)]
    procs.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
                                   "--no-nanny", "--no-dashboard"], stdout=subprocess.DEVNULL,
                                  stderr=subprocess.DEVNULL))
    try:
        client = executors.dask_client(address)
        client.wait_for_workers(1, timeout=60)
        yield address, procs[0]
    finally:
        executors._close_client(address)
        for proc in procs:
            proc.kill()
            proc.wait()


def test_scheduler_lost_mid_run_is_named_and_returns_nothing(doomed_scheduler, monkeypatch, tmp_path):
    address, scheduler = doomed_scheduler
    monkeypatch.setenv(SCHEDULER, address)
    monkeypatch.setattr(executors, "SCHEDULER_TIMEOUT", 3.0)
    estimators, make_batch, mc = zhou_study()
    log = tmp_path / "log"
    log.touch()
    lost = []

    def kill_scheduler():
        while not log.read_text():
            time.sleep(0.01)
        scheduler.send_signal(signal.SIGKILL)
        lost.append(time.monotonic())

    thread = threading.Thread(target=kill_scheduler)
    thread.start()
    with pytest.raises(executors.SchedulerError, match=f"^{SCHEDULER}: lost the Dask scheduler at {address} "
                                                         "mid-run .*no result of this study is kept"):
        evaluation.evaluate(estimators, logged(make_batch, log, delay=1.0), mc, chunk_size=2, progress=False)
    assert time.monotonic() - lost[0] < executors.SCHEDULER_TIMEOUT
    thread.join()
    t0 = time.monotonic()                                  # the next study finds no scheduler there
    with pytest.raises(executors.SchedulerError, match=f"^{SCHEDULER}: no Dask scheduler answered at {address}"):
        evaluation.evaluate(estimators, make_batch, mc, chunk_size=2, progress=False)
    assert time.monotonic() - t0 < 3.0 + 2.0
