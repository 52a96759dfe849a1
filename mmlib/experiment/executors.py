"""Where Monte Carlo tasks run: this process, a pool of local worker processes, or a Dask cluster.

The one execution policy of :func:`mmlib.experiment.evaluation.evaluate` (a task is a chunk of runs) and of
:func:`mmlib.experiment.grid.run_grid` (a task is a universe), applied by :func:`run_tasks`:

* an ``executor`` the caller passes (any ``concurrent.futures.Executor``; it is never shut down here);
* else, inside a task (a worker process, a Dask worker, or a serial run asked for with ``workers=1``): this
  process -- a task never fans out again, so workers are never oversubscribed by nested pools;
* else, one task: this process (nothing to spread);
* else, with ``$MMLIB_SCHEDULER`` set (e.g. ``tcp://host:8786``): that Dask cluster, through one client per
  process (Dask is an optional extra, imported only then);
* else ``workers`` local processes (default ``$WORKERS``, else every core this process may use), or this process
  when that is 1.

Wherever a task runs, its fused filter steps keep to one thread (:func:`mmlib.core.linalg.use_threads`): the workers
are the parallelism, and a task's CPU time is one thread's.

The local pool is created on first use, kept for the life of the process and shut down at exit (a pool of another
size replaces it).  Its workers are spawned -- fresh interpreters started with one BLAS thread each -- which costs
an interpreter start and the imports of numpy, scipy and numba once per process (a fork would start faster, but
would copy a notebook kernel's threads and the parent's already-started BLAS thread pool, and would still need a
serialiser for the tasks).  A worker leaves by itself when the process that started it dies
(a killed kernel leaves no worker computing for nobody).  Tasks and their shared arguments travel as cloudpickle
bytes, so closures (``make_batch`` of :func:`mmlib.experiment.evaluation.make_batches`) and functions defined in a
notebook's ``__main__`` run in any worker (plain pickle refuses both); results travel back by plain pickle.

Guarantee: :func:`run_tasks` returns the results in task order whatever the order in which they finish, and a
task computes the same bits wherever it runs -- the tasks are deterministic functions of their arguments (per-run
random streams, batch-size-independent filters), and the kernel implementation of :mod:`mmlib.core.linalg` selected in
this process is selected in the worker for the task.  A Dask worker whose ``mmlib`` source differs from this
process's is refused (its numbers could differ).  A worker that dies mid-task is replaced by Dask and its task
recomputed (never lost nor duplicated); a local worker's death, or the loss of the Dask scheduler, is an error and
no result of the study is returned.
"""
from __future__ import annotations

import atexit
import concurrent.futures as cf
import contextlib
import multiprocessing
import multiprocessing.context
import os
import threading
import time
from typing import TYPE_CHECKING, Any, Callable, Sequence

from mmlib.core._env import count_from_env
from mmlib.core._validate import check_positive_int
from mmlib.experiment.source import source_hash

__all__ = [
    "run_tasks", "choose_executor", "default_workers", "worker_count", "SerialExecutor", "local_pool", "dask_executor",
    "dask_client", "scheduler_address", "in_task", "shutdown", "SchedulerError", "WORKERS_VARIABLE",
    "SCHEDULER_VARIABLE", "SCHEDULER_TIMEOUT", "BLAS_THREAD_VARIABLES", "PARENT_POLL", "DASK_HINT"
]

if TYPE_CHECKING:
    import distributed

#: environment variable: the number of local worker processes (default: every core this process may use)
WORKERS_VARIABLE = "WORKERS"
#: environment variable: the address of a Dask scheduler (``tcp://host:8786``); unset or empty: local processes
SCHEDULER_VARIABLE = "MMLIB_SCHEDULER"
#: seconds allowed to reach the Dask scheduler (and to reconnect to it) before it counts as unreachable
SCHEDULER_TIMEOUT = 10.0
#: thread counts of BLAS/OpenMP/numba, set to one in every local worker process (the workers are the parallelism)
BLAS_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS",
                         "NUMBA_NUM_THREADS")
#: seconds between a local worker's checks that the process which started it is alive
PARENT_POLL = 1.0
DASK_HINT = "install the optional extra: pip install .[dask]  (or pip install dask distributed)"


class SchedulerError(RuntimeError):
    """The Dask scheduler of ``$MMLIB_SCHEDULER`` cannot be reached, or was lost mid-run (the message starts with
    ``MMLIB_SCHEDULER:`` and gives the address).  No result of the study is returned."""


# ------------------------------------------------------------------------------------------------------ settings
def default_workers() -> int:
    """``$WORKERS`` if set (a positive integer; anything else is a ValueError naming WORKERS), else the number of
    cores this process may use."""
    return count_from_env(WORKERS_VARIABLE, "number of worker processes")


def worker_count(workers: int | None = None) -> int:
    """``workers`` (an integer >= 1; ValueError naming ``workers`` otherwise), or :func:`default_workers` if None."""
    return default_workers() if workers is None else check_positive_int(workers, "workers")


def scheduler_address() -> str | None:
    """``$MMLIB_SCHEDULER`` (stripped), or None when unset or empty; ValueError naming MMLIB_SCHEDULER if it holds
    whitespace."""
    address = os.environ.get(SCHEDULER_VARIABLE, "").strip()
    if address and any(c.isspace() for c in address):
        raise ValueError(f"{SCHEDULER_VARIABLE}: expected a scheduler address such as tcp://host:8786, "
                         f"got {address!r}")
    return address or None


# -------------------------------------------------------------------------------------------- inside a task or not
_local = threading.local()


def in_task() -> bool:
    """True while this thread runs a task of :func:`run_tasks` (in a worker, or serially in this process)."""
    return getattr(_local, "depth", 0) > 0


@contextlib.contextmanager
def _task_scope():
    """The body runs as a task: :func:`in_task` is true, and the fused filter steps use one thread
    (:func:`mmlib.core.linalg.use_threads`): the workers are the parallelism."""
    from mmlib.core import linalg
    _local.depth = getattr(_local, "depth", 0) + 1
    try:
        with linalg.use_threads(1):
            yield
    finally:
        _local.depth -= 1


def _process_state() -> dict:
    """What a worker must share with this process to compute the same bits: the kernel implementation of
    :mod:`mmlib.core.linalg` (a process setting, ``linalg.use_kernel``), when the library has one."""
    from mmlib.core import linalg
    kernel = getattr(linalg, "kernel", None)
    return {"kernel": kernel()} if callable(kernel) else {}


@contextlib.contextmanager
def _entered(state: dict):
    from mmlib.core import linalg
    use = getattr(linalg, "use_kernel", None)
    with (use(state["kernel"]) if "kernel" in state and callable(use) else contextlib.nullcontext()):
        yield


def _run_task(shared: bytes, payload: bytes, state: dict, source: str | None):
    """Runs in a worker: ``fn(*shared, *args)`` with the caller's process state, marked as a task."""
    import cloudpickle
    if source is not None:
        if source_hash() != source:
            import socket
            raise RuntimeError(f"{SCHEDULER_VARIABLE}: the worker on {socket.gethostname()} (pid {os.getpid()}) "
                               f"runs another mmlib (source hash {source_hash()}, the client's {source}): start "
                               f"the workers from the same checkout and lock as the client")
    fn, args = cloudpickle.loads(payload)
    with _task_scope(), _entered(state):
        return fn(*cloudpickle.loads(shared), *args)


# ------------------------------------------------------------------------------------------- executors
class SerialExecutor(cf.Executor):
    """Runs each task at submission, in this process, marked as a task (so that it never fans out again)."""

    def submit(self, fn: Callable, /, *args: Any, **kwargs: Any) -> cf.Future:
        """Run ``fn(*args, **kwargs)`` now and return a done Future holding its result (or the exception it
        raised, re-raised by ``Future.result()``)."""
        fut = cf.Future()
        try:
            with _task_scope():
                fut.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # noqa: BLE001 -- re-raised by Future.result()
            fut.set_exception(exc)
        return fut


class _PinnedSpawnProcess(multiprocessing.context.SpawnProcess):
    """A spawned process started with one BLAS thread: the variables are read when BLAS loads, i.e. in the new
    interpreter, so they are set around the start (the pool spawns its workers on demand, at any submission)."""

    def start(self):
        with _ENV_LOCK:
            saved = {var: os.environ.get(var) for var in BLAS_THREAD_VARIABLES}
            os.environ.update(dict.fromkeys(BLAS_THREAD_VARIABLES, "1"))
            try:
                super().start()
            finally:
                for var, value in saved.items():
                    if value is None:
                        os.environ.pop(var, None)
                    else:
                        os.environ[var] = value


class _PinnedSpawnContext(multiprocessing.context.SpawnContext):
    Process = _PinnedSpawnProcess


def _watch_parent(parent: int) -> None:
    """Pool worker initializer: leave as soon as the process that started the pool is gone -- a notebook kernel
    killed mid-study would otherwise leave its workers computing for nobody -- and ignore SIGINT, which a terminal's
    Ctrl-C or a kernel's shutdown sends to the whole process group: the process that owns the pool decides when its
    workers stop (the pool's shutdown), so an interrupt is handled once, there, not as a traceback per worker."""
    import signal
    signal.signal(signal.SIGINT, signal.SIG_IGN)

    def watch():
        while os.getppid() == parent:
            time.sleep(PARENT_POLL)
        os._exit(1)
    threading.Thread(target=watch, name="mmlib-parent-watch", daemon=True).start()


_ENV_LOCK = threading.Lock()
_LOCK = threading.RLock()
_pool: cf.ProcessPoolExecutor | None = None
_pool_workers = 0
_clients: dict = {}      # address -> distributed.Client


def local_pool(workers: int) -> cf.ProcessPoolExecutor:
    """This process's pool of ``workers`` spawned worker processes (integer >= 2), created on first use and
    reused (a pool of another size replaces it); shut down at exit."""
    global _pool, _pool_workers
    workers = check_positive_int(workers, "workers", minimum=2)
    with _LOCK:
        if _pool is None or _pool_workers != workers:
            _discard_pool()
            _pool = cf.ProcessPoolExecutor(max_workers=workers, mp_context=_PinnedSpawnContext(),
                                           initializer=_watch_parent, initargs=(os.getpid(),))
            _pool_workers = workers
        return _pool


def _discard_pool() -> None:
    global _pool, _pool_workers
    with _LOCK:
        if _pool is not None:
            _pool.shutdown(wait=True, cancel_futures=True)
        _pool, _pool_workers = None, 0


def _import_distributed():
    try:
        import distributed
    except ImportError:
        raise ImportError(f"{SCHEDULER_VARIABLE} is set, which needs Dask distributed: {DASK_HINT}") from None
    return distributed


def dask_client(address: str) -> distributed.Client:
    """The ``distributed.Client`` of this process for the scheduler at ``address``, connected on first use within
    :data:`SCHEDULER_TIMEOUT` seconds (:class:`SchedulerError` naming the address otherwise) and reused."""
    distributed = _import_distributed()
    with _LOCK:
        client = _clients.get(address)
        if client is not None and client.status == "running":
            return client
        if client is not None:
            _close_client(address)
        try:
            client = distributed.Client(address, timeout=SCHEDULER_TIMEOUT, set_as_default=False)
        except (OSError, TimeoutError) as exc:
            raise SchedulerError(f"{SCHEDULER_VARIABLE}: no Dask scheduler answered at {address} within "
                                 f"{SCHEDULER_TIMEOUT:g} s ({type(exc).__name__}: {exc}); start one with "
                                 f"`dask scheduler`, or unset {SCHEDULER_VARIABLE} to run on local "
                                 f"processes") from None
        except ValueError as exc:
            raise ValueError(f"{SCHEDULER_VARIABLE}: expected a scheduler address such as tcp://host:8786, got "
                             f"{address!r} ({exc})") from None
        _clients[address] = client
        return client


def dask_executor(address: str | None = None) -> cf.Executor:
    """A ``concurrent.futures`` executor on the Dask cluster at ``address`` (default ``$MMLIB_SCHEDULER``), for
    ``executor=`` of :func:`run_tasks`, ``evaluate`` or ``run_grid``."""
    if address is not None and not isinstance(address, str):
        raise ValueError(f"address: expected a scheduler address such as tcp://host:8786, got {address!r}")
    address = address or scheduler_address()
    if not address:
        raise ValueError(f"address: no scheduler address given and {SCHEDULER_VARIABLE} is not set")
    return dask_client(address).get_executor(pure=False)


def _close_client(address: str) -> None:
    client = _clients.pop(address, None)
    if client is not None:
        with contextlib.suppress(Exception):
            client.close(timeout=SCHEDULER_TIMEOUT)


@atexit.register
def shutdown() -> None:
    """Shut down this process's local pool and close its Dask clients (at exit; also safe to call any time)."""
    with _LOCK:
        _discard_pool()
        for address in list(_clients):
            _close_client(address)


# ------------------------------------------------------------------------------------------------ running tasks
def _dask_address_of(executor) -> str | None:
    """The scheduler address of a Dask ``ClientExecutor`` (None for any other executor)."""
    client = getattr(executor, "_client", None)
    return getattr(client, "scheduler", None) and getattr(client.scheduler, "address", None)


def choose_executor(n_tasks: int, *, workers: int | None = None,
                    executor: cf.Executor | None = None) -> tuple[cf.Executor | None, str]:
    """``(executor, where)`` for ``n_tasks`` tasks by the policy of this module; ``where`` describes it for
    messages.  ``workers`` is validated (and ``$WORKERS`` read) whatever is chosen, so a bad setting is always an
    error."""
    check_positive_int(n_tasks, "n_tasks", minimum=0)
    n_workers = worker_count(workers)
    if executor is not None:
        if not callable(getattr(executor, "submit", None)):
            raise ValueError(f"executor: expected a concurrent.futures.Executor, got {type(executor).__name__}")
        return executor, "the given executor"
    if in_task():
        return SerialExecutor(), "this process (inside a task)"
    if n_tasks <= 1:
        return None, "this process (one task)"
    address = scheduler_address()
    if address:
        return dask_executor(address), f"the Dask scheduler at {address} ({SCHEDULER_VARIABLE})"
    if n_workers == 1:
        return SerialExecutor(), "this process (one worker)"
    return local_pool(n_workers), f"{n_workers} local worker processes"


def run_tasks(fn: Callable, tasks: Sequence[tuple], *, shared: tuple = (), workers: int | None = None,
              executor: cf.Executor | None = None, on_result: Callable | None = None) -> list:
    """``[fn(*shared, *task) for task in tasks]``, the tasks run where :func:`choose_executor` says.

    ``shared``: arguments common to every task, serialised once.  ``on_result(i, result)`` is called in this
    process as each task finishes (completion order; for progress and caching); an exception it raises, or one a
    task raises, cancels the tasks not yet started and is re-raised.  Returns the results in task order."""
    if not callable(fn):
        raise ValueError(f"fn: expected a function, got {type(fn).__name__}")
    if isinstance(tasks, (str, bytes)) or not hasattr(tasks, "__iter__"):
        raise ValueError(f"tasks: expected a sequence of argument tuples, got {tasks!r}")
    tasks = list(tasks)
    for i, t in enumerate(tasks):
        if not isinstance(t, (tuple, list)):
            raise ValueError(f"tasks: expected a sequence of argument tuples, task {i} is {t!r}")
    if not isinstance(shared, (tuple, list)):
        raise ValueError(f"shared: expected a tuple of arguments common to every task, got {shared!r}")
    if on_result is not None and not callable(on_result):
        raise ValueError(f"on_result: expected None or a function (index, result), got {type(on_result).__name__}")
    from mmlib.core import linalg
    tasks = [tuple(t) for t in tasks]
    ex, where = choose_executor(len(tasks), workers=workers, executor=executor)
    results: list = [None] * len(tasks)
    if ex is None or isinstance(ex, SerialExecutor):
        for i, task in enumerate(tasks):
            with (linalg.use_threads(1) if ex is None else _task_scope()):
                results[i] = fn(*shared, *task)
            if on_result is not None:
                on_result(i, results[i])
        return results
    import cloudpickle
    from concurrent.futures.process import BrokenProcessPool
    address = _dask_address_of(ex)
    setting = "executor" if executor is not None else SCHEDULER_VARIABLE
    source = None
    if address is not None:          # a remote worker may hold another checkout: refuse it rather than differ
        source = source_hash()
    blob, state = cloudpickle.dumps(tuple(shared)), _process_state()
    futures = {ex.submit(_run_task, blob, cloudpickle.dumps((fn, task)), state, source): i
               for i, task in enumerate(tasks)}
    try:
        for fut in cf.as_completed(futures):
            i = futures[fut]
            if fut.cancelled():      # nothing here cancels before this loop ends: Dask cancels on losing the scheduler
                done = sum(f.done() and not f.cancelled() for f in futures)
                raise SchedulerError(f"{setting}: lost the Dask scheduler at {address} mid-run ({done} of "
                                     f"{len(tasks)} tasks had finished); no result of this study is kept")
            try:
                results[i] = fut.result()
            except BrokenProcessPool as exc:
                if ex is _pool:
                    _discard_pool()  # unusable now; the next study starts a fresh pool
                raise RuntimeError(f"a worker process died while running a task on {where} ({exc}); no result "
                                   f"of this study is kept (out of memory? set {WORKERS_VARIABLE} lower)") from None
            if on_result is not None:
                on_result(i, results[i])
    except BaseException:
        for fut in futures:
            fut.cancel()
        if address is not None and executor is None:
            client = _clients.get(address)
            if client is not None and client.status != "running":
                _close_client(address)   # the next study reconnects, or reports the scheduler unreachable
        raise
    return results
