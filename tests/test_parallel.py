"""Every local core, bit for bit: the chunks of ``evaluate`` and the universes of ``run_grid`` run in a pool of
spawned worker processes (mmlib.experiment.executors) and give exactly the numbers of a serial run, whatever the
worker count or chunk size; closures and ``__main__`` functions travel (cloudpickle); the pool is reused; a task
never fans out again; a dead worker is an error and the next study gets a fresh pool; bad settings are errors
naming them."""
from __future__ import annotations

import os
import pickle
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mmlib.core import linalg
from mmlib.experiment import digests, evaluation, executors, run_grid
from mmlib.experiment.montecarlo import MonteCarlo
from mmlib.papers import REGISTRY

from conftest import raises_naming

N_RUNS = 7                      # chunks of 2 and 3 runs: 4 and 3 chunks, the last one short


def zhou_study(n_runs: int = N_RUNS):
    """Zhou 2017 Case 2 (sensor faults; IMM and CPIMM with the UKF and the adaptive NAUKF, which diverges: NaN
    estimates and divergence causes travel too) on ``n_runs``."""
    paper = REGISTRY["zhou2017"]
    mc = MonteCarlo(paper.root_seed, n_runs)
    make_batch, estimators = paper.batch(paper.headline_setup(), mc)  # Case 2 of the headline reading
    return estimators, make_batch, mc


def assert_same_bits(a: dict, b: dict) -> None:
    """Two ``{name: RunSet}`` hold the same bytes in every field (NaN payloads included)."""
    assert list(a) == list(b)
    for name in a:
        for field in a[name]._fields:
            x, y = getattr(a[name], field), getattr(b[name], field)
            assert (x is None) == (y is None), (name, field)
            if field == "ops":                              # the operation count of a run: an integer or None
                assert x == y and type(x) is type(y), (name, field)
            elif x is not None:
                assert x.shape == y.shape and x.dtype == y.dtype and x.tobytes() == y.tobytes(), (name, field)


@pytest.fixture(scope="module")
def serial():
    """The study in one chunk, in this process: the reference."""
    estimators, make_batch, mc = zhou_study()
    return evaluation.evaluate(estimators, make_batch, mc, chunk_size=N_RUNS, workers=1, progress=False)


def test_pool_gives_the_serial_bits_whatever_workers_and_chunk_size(serial):
    estimators, make_batch, mc = zhou_study()
    assert serial["IMM-UKF"].mode_probabilities is not None and not serial["IMM-NAUKF"].valid.all()
    for chunk_size in (2, 3):
        for workers in (1, 2):
            got = evaluation.evaluate(estimators, make_batch, mc, chunk_size=chunk_size, workers=workers,
                                      progress=False)
            assert_same_bits(got, serial)
    assert digests.run_digest(got, N_RUNS) == digests.run_digest(serial, N_RUNS)


def test_chunks_run_in_worker_processes_of_one_reused_pool():
    pids = executors.run_tasks(os.getpid, [()] * 6, workers=2)
    pool = executors._pool
    assert pool is not None and os.getpid() not in pids and 1 <= len(set(pids)) <= 2
    again = executors.run_tasks(os.getpid, [()] * 6, workers=2)
    assert executors._pool is pool and set(again) <= {p.pid for p in pool._processes.values()}


def test_one_task_or_one_worker_runs_in_this_process():
    assert executors.run_tasks(os.getpid, [()], workers=2) == [os.getpid()]
    assert executors.run_tasks(os.getpid, [()] * 3, workers=1) == [os.getpid()] * 3


def where_five_tasks_run(workers: int = 2) -> str:
    return executors.choose_executor(5, workers=workers)[1]


def test_a_task_never_fans_out_again():
    """Inside a task (a universe whose evaluate has many chunks) the policy is this process, so workers are never
    oversubscribed by nested pools; outside, the pool."""
    assert where_five_tasks_run() == "2 local worker processes"
    assert executors.run_tasks(where_five_tasks_run, [()] * 2, workers=2) == ["this process (inside a task)"] * 2
    assert executors.run_tasks(where_five_tasks_run, [()] * 2, workers=1) == ["this process (inside a task)"] * 2


def test_progress_advances_once_per_finished_chunk(serial, capsys):
    estimators, make_batch, mc = zhou_study()
    evaluation.evaluate(estimators, make_batch, mc, chunk_size=2, workers=2, label="pp", progress=True)
    lines = [ln for ln in capsys.readouterr().err.splitlines() if "[pp]" in ln]
    assert len(lines) == 4 and lines[-1].split()[1] == f"{N_RUNS}/{N_RUNS}"
    done = [0] + [int(ln.split()[1].split("/")[0]) for ln in lines]
    assert sorted(b - a for a, b in zip(done, done[1:])) == [1, 2, 2, 2]      # one line per chunk of 2, 2, 2, 1


MAIN_SOURCE = '''
def make_batch(runs):                      # defined in __main__, as in a notebook
    truth, z, init = base(runs)
    return truth, z, init
'''


def test_functions_defined_in_main_and_closures_travel(serial):
    """A notebook's functions live in ``__main__`` and make_batch is a closure: plain pickle refuses both, the
    workers still run them (cloudpickle)."""
    estimators, base, mc = zhou_study()
    namespace = {"__name__": "__main__", "base": base}
    exec(MAIN_SOURCE, namespace)
    make_batch = namespace["make_batch"]
    assert make_batch.__module__ == "__main__"
    for fn in (base, make_batch):
        with pytest.raises((pickle.PicklingError, AttributeError, TypeError)):
            pickle.loads(pickle.dumps(fn))
    got = evaluation.evaluate(estimators, make_batch, mc, chunk_size=3, workers=2, progress=False)
    assert_same_bits(got, serial)


def test_run_grid_on_the_pool_equals_serial(tmp_path):
    paper = REGISTRY["zhu2016"]
    readings = list(paper.space.design("star").readings)[:3]
    kw = dict(paper=paper.name, algorithms=paper.algorithms, n_runs=4, seed=paper.root_seed, use_cache=False,
              progress=False)
    serial = run_grid(paper.universe, readings, workers=1, **kw)
    pooled = run_grid(paper.universe, readings, workers=2, **kw)
    assert pooled == serial and len(serial) == 3 and serial[0] != serial[1]
    assert [u.as_json() for u in pooled] == [u.as_json() for u in serial]   # the machine too (== leaves it out)


@pytest.mark.skipif(not hasattr(linalg, "use_kernel"), reason="mmlib.core.linalg has no selectable kernels")
def test_the_callers_kernel_is_the_workers_kernel():
    """The kernel implementation is a process setting; a worker computes with the caller's."""
    for name in linalg.KERNELS:
        with linalg.use_kernel(name):
            assert executors.run_tasks(linalg.kernel, [()] * 2, workers=2) == [name, name]


def _die_on_chunk(runs):
    if runs.start == 2:
        os.kill(os.getpid(), signal.SIGKILL)
    return runs.start


def test_a_dead_local_worker_is_an_error_and_the_next_study_gets_a_fresh_pool():
    with pytest.raises(RuntimeError, match="worker process died"):
        executors.run_tasks(_die_on_chunk, [(range(a, a + 2),) for a in (0, 2, 4)], workers=2)
    assert executors.run_tasks(_die_on_chunk, [(range(a, a + 2),) for a in (0, 4, 6)], workers=2) == [0, 4, 6]


ORPHANING = """
import os, time
from mmlib.experiment import executors
executors.run_tasks(os.getpid, [()] * 4, workers=2)
print(*[p.pid for p in executors._pool._processes.values()], flush=True)
executors.run_tasks(time.sleep, [(60,)] * 2, workers=2)
"""


def alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] not in ("Z", "X")
    except FileNotFoundError:
        return False


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads process states from /proc")
def test_workers_of_a_killed_process_leave_at_once():
    """A notebook kernel killed mid-study must not leave its workers computing for nobody."""
    proc = subprocess.Popen([sys.executable, "-c", ORPHANING], stdout=subprocess.PIPE, text=True)
    try:
        pids = [int(p) for p in proc.stdout.readline().split()]
        assert len(pids) == 2 and all(map(alive, pids))
        time.sleep(0.5)                                         # both workers inside their 60-s task
    finally:
        proc.kill()
        proc.wait()
        proc.stdout.close()
    deadline = time.monotonic() + executors.PARENT_POLL + 5
    while any(map(alive, pids)) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(map(alive, pids))


# ----------------------------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("workers", [0, -1, 1.5, "2", True])
def test_bad_workers_argument_is_named(workers):
    estimators, make_batch, mc = zhou_study(2)
    with raises_naming("workers"):
        evaluation.evaluate(estimators, make_batch, mc, workers=workers, progress=False)
    paper = REGISTRY["zhu2016"]
    with raises_naming("workers"):
        run_grid(paper.universe, [paper.space.headline], paper="p", algorithms=[], n_runs=2, seed=1,
                 workers=workers, use_cache=False, progress=False)


@pytest.mark.parametrize("value", ["0", "-1", "two", "1.5", "2 workers"])
def test_bad_workers_environment_is_named(monkeypatch, value):
    """Even a study of one chunk (which needs no worker) reports a bad $WORKERS."""
    estimators, make_batch, mc = zhou_study(2)
    monkeypatch.setenv("WORKERS", value)
    with raises_naming("WORKERS"):
        evaluation.evaluate(estimators, make_batch, mc, progress=False)


def test_bad_executor_and_scheduler_address_are_named(monkeypatch):
    estimators, make_batch, mc = zhou_study(2)
    with raises_naming("executor"):
        evaluation.evaluate(estimators, make_batch, mc, executor="pool", progress=False)
    monkeypatch.setenv(executors.SCHEDULER_VARIABLE, "tcp://host 8786")
    with raises_naming(executors.SCHEDULER_VARIABLE):
        executors.run_tasks(os.getpid, [()] * 2, workers=2)


def test_time_algorithms_stays_in_this_process(monkeypatch):
    """A timing must not share the machine with its own workers: time_algorithms never submits a task."""
    def refuse(*args, **kwargs):
        raise AssertionError("time_algorithms submitted tasks")
    monkeypatch.setattr(executors, "run_tasks", refuse)
    monkeypatch.setattr(evaluation, "run_tasks", refuse)
    monkeypatch.setattr(executors, "local_pool", refuse)
    estimators, make_batch, mc = zhou_study(2)
    _, z, init = make_batch(range(2))
    single, batched = evaluation.time_algorithms(estimators, init, z, repeats=2)
    assert set(single) == set(batched) == set(estimators) and all(v.shape == (2,) for v in batched.values())


def test_a_scheduler_without_dask_installed_says_how_to_install_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)          # import distributed -> ImportError
    monkeypatch.setenv(executors.SCHEDULER_VARIABLE, "tcp://127.0.0.1:8786")
    with pytest.raises(ImportError, match=r"^MMLIB_SCHEDULER is set, which needs Dask distributed: .*"
                                          r"pip install \.\[dask\]"):
        executors.run_tasks(os.getpid, [()] * 2, workers=2)
