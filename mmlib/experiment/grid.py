"""The grid runner: every universe of a design as an independent Monte Carlo job.

A *job* is a module-level function ``job(reading, n_runs, seed) -> dict`` (picklable, so
that worker processes can run it); every job uses the paper's one root seed and the
per-run streams of :mod:`mmlib.montecarlo`, so universes share common random numbers
and a universe's numbers do not depend on which worker ran it, in which order, or
whether it came from the cache.

Jobs run in parallel worker processes (``concurrent.futures.ProcessPoolExecutor``,
one per local core by default, BLAS threads held to one per worker); any
``concurrent.futures.Executor`` can be passed instead (e.g. a Dask client's
``get_executor()``).  Results are cached on disk as JSON under a key of (paper, job,
reading, algorithms, runs, seed, the hash of mmlib's source): re-running after an edit
that leaves ``mmlib/`` alone (a notebook's prose, say) recomputes nothing, and any edit
of the library recomputes everything.
"""
from __future__ import annotations

import concurrent.futures as cf
import functools
import hashlib
import json
import multiprocessing
import os
import sys
import time
from pathlib import Path
from typing import Callable, Mapping

from .._validate import check_positive_int

BLAS_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")


#: modules that only render results (tables, figures): editing them cannot change a universe's numbers
PRESENTATION_MODULES = ("experiment/views.py", "scenarios/presentation.py")


@functools.lru_cache(maxsize=1)
def source_hash() -> str:
    """SHA-256 (first 16 hex digits) of every ``.py`` file of the installed ``mmlib`` package (but the
    presentation modules), by relative path and content, and of the numpy and scipy versions: the
    "mmlib version" of the cache key."""
    import numpy
    import scipy
    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256(f"numpy {numpy.__version__}; scipy {scipy.__version__}".encode())
    for path in sorted(root.rglob("*.py")):
        if path.relative_to(root).as_posix() in PRESENTATION_MODULES:
            continue
        h.update(str(path.relative_to(root)).encode())
        h.update(b"\0")
        h.update(path.read_bytes())
        h.update(b"\0")
    return h.hexdigest()[:16]


def default_cache_dir() -> Path:
    """``$MMLIB_CACHE`` if set, else ``build/cache/multiverse`` of the repository holding mmlib."""
    env = os.environ.get("MMLIB_CACHE")
    return Path(env) if env else Path(__file__).resolve().parents[2] / "build" / "cache" / "multiverse"


def job_name(job: Callable) -> str:
    return f"{getattr(job, '__module__', '?')}.{getattr(job, '__qualname__', repr(job))}"


def key_document(*, paper: str, job: Callable, reading: Mapping, algorithms, n_runs: int, seed: int) -> dict:
    """What a cached universe depends on; stored with the entry and checked when it is read."""
    return {"paper": paper, "job": job_name(job), "reading": dict(sorted(reading.items())),
            "algorithms": list(algorithms), "n_runs": int(n_runs), "seed": int(seed), "mmlib": source_hash()}


def cache_key(**parts) -> str:
    return hashlib.sha256(json.dumps(key_document(**parts), sort_keys=True).encode()).hexdigest()[:32]


RESULT_KEYS = ("values", "claims", "effects", "diverged", "n_runs")


def _read_entry(path: Path, key_doc: dict):
    """The cached result, or None when the entry is missing, unreadable, written for another key or
    not a universe result (it is then recomputed and overwritten)."""
    try:
        entry = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError):
        return None
    if not isinstance(entry, dict) or entry.get("key") != json.loads(json.dumps(key_doc)):
        return None
    res = entry.get("result")
    if not isinstance(res, dict) or any(k not in res for k in RESULT_KEYS):
        return None
    return res


def _write_json_atomic(path: Path, doc) -> None:
    from ..report import atomic_write_text
    atomic_write_text(path, json.dumps(doc, allow_nan=False, sort_keys=True))


def _run_job(job, reading, n_runs, seed):
    return job(dict(reading), n_runs, seed)


def default_workers() -> int:
    """``$WORKERS`` if set, else the number of cores this process may use."""
    env = os.environ.get("WORKERS", "").strip()
    if env:
        if not env.isdigit() or int(env) < 1:
            raise ValueError(f"WORKERS: expected a positive integer (number of worker processes), got {env!r}")
        return int(env)
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


class _SerialExecutor(cf.Executor):
    """Runs each job at submission, in this process (``workers=1``)."""

    def submit(self, fn, *args, **kwargs):
        fut = cf.Future()
        try:
            fut.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # noqa: BLE001 -- re-raised by Future.result()
            fut.set_exception(exc)
        return fut


def run_grid(job: Callable, readings, *, paper: str, algorithms, n_runs: int, seed: int,
             executor: cf.Executor | None = None, workers: int | None = None,
             cache_dir: str | Path | None = None, use_cache: bool = True,
             progress: bool | Callable = True, label: str = "") -> list:
    """Run ``job(reading, n_runs, seed)`` for every reading; results in the order of ``readings``.

    ``executor``: any ``concurrent.futures.Executor`` (it is not shut down here); by default
    a process pool of ``workers`` processes (``default_workers()``), or this process when
    ``workers == 1``.  ``cache_dir``: where results are kept (``default_cache_dir()``);
    ``use_cache=False`` neither reads nor writes it.  ``progress``: True prints one line per
    universe to stderr, a callable receives that line, False is silent.
    """
    readings = [dict(r) for r in readings]
    check_positive_int(n_runs, "n_runs")
    check_positive_int(seed, "seed", minimum=0)
    if not callable(job):
        raise ValueError(f"job: expected a callable job(reading, n_runs, seed), got {job!r}")
    if workers is not None:
        check_positive_int(workers, "workers")
    algorithms = list(algorithms)
    cache = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    say = (lambda line: print(line, file=sys.stderr, flush=True)) if progress is True else (progress or None)
    tag = label or paper
    results: list = [None] * len(readings)
    key_docs = [key_document(paper=paper, job=job, reading=r, algorithms=algorithms, n_runs=n_runs, seed=seed)
                for r in readings]
    keys = [hashlib.sha256(json.dumps(k, sort_keys=True).encode()).hexdigest()[:32] for k in key_docs]
    todo = []
    for i, key in enumerate(keys):
        if use_cache:
            results[i] = _read_entry(cache / paper / f"{key}.json", key_docs[i])
            if results[i] is not None:
                continue
        todo.append(i)
    n_cached = len(readings) - len(todo)
    if say and n_cached:
        say(f"  [{tag}] {n_cached}/{len(readings)} universes from the cache ({cache / paper})")
    if not todo:
        return results
    own = executor is None
    n_workers = workers or default_workers()
    saved_env = {}
    if own and n_workers > 1:
        for var in BLAS_THREAD_VARIABLES:            # inherited by the spawned workers
            saved_env[var] = os.environ.get(var)
            os.environ[var] = "1"
        executor = cf.ProcessPoolExecutor(max_workers=min(n_workers, len(todo)),
                                          mp_context=multiprocessing.get_context("spawn"))
    elif own:
        executor = _SerialExecutor()
    t0 = time.perf_counter()
    try:
        futures = {executor.submit(_run_job, job, readings[i], n_runs, seed): i for i in todo}
        done = 0
        for fut in cf.as_completed(futures):
            i = futures[fut]
            res = fut.result()
            if not isinstance(res, dict):
                raise ValueError(f"job: {job_name(job)} returned {type(res).__name__}, expected a dict")
            results[i] = json.loads(json.dumps(res, allow_nan=False))   # the same form as from the cache
            if any(k not in results[i] for k in RESULT_KEYS):
                raise ValueError(f"job: {job_name(job)} returned a dict without {RESULT_KEYS} "
                                 f"(build it with multiverse.universe_result)")
            if use_cache:
                _write_json_atomic(cache / paper / f"{keys[i]}.json", {"key": key_docs[i], "result": results[i]})
            done += 1
            if say:
                div = res.get("diverged") or {}
                ndiv = sum(div.values()) if isinstance(div, dict) else 0
                say(f"  [{tag}] universe {done}/{len(todo)} done ({time.perf_counter() - t0:.1f} s): "
                    f"{json.dumps(readings[i], sort_keys=False)}" + (f"; diverged runs {div}" if ndiv else ""))
    finally:
        if own:
            executor.shutdown(wait=True, cancel_futures=True)
        for var, value in saved_env.items():
            if value is None:
                os.environ.pop(var, None)
            else:
                os.environ[var] = value
    return results
