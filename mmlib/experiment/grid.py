"""The grid runner: every universe of a design as an independent Monte Carlo job.

A *job* is a function ``job(reading, n_runs, seed) -> dict`` (sent to the workers with
cloudpickle; a module-level function keeps its cache key stable); every job uses the paper's one root seed and the
per-run streams of :mod:`mmlib.experiment.montecarlo`, so universes share common random numbers
and a universe's numbers do not depend on which worker ran it, in which order, or
whether it came from the cache.

Jobs run where :mod:`mmlib.experiment.executors` puts them: this process's pool of
spawned worker processes (one per local core by default, ``$WORKERS`` to choose, BLAS
threads held to one per worker), the Dask cluster of ``$MMLIB_SCHEDULER``, or any
``concurrent.futures.Executor`` passed in.  Results are cached on disk as JSON under a key of (paper, job,
reading, algorithms, runs, seed, the hash of mmlib's source): re-running after an edit
that leaves ``mmlib/`` alone (a notebook's prose, say) recomputes nothing, and any edit
of the library recomputes everything.
"""
from __future__ import annotations

import concurrent.futures as cf
import functools
import hashlib
import json
import os
import time
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Sequence

from mmlib.core._validate import check_positive_int
# default_workers lived here: kept importable from this module
from mmlib.experiment.montecarlo import say_progress
from mmlib.experiment.executors import default_workers, run_tasks, worker_count  # noqa: F401


#: modules that only render results (tables, figures): editing them cannot change a universe's numbers
PRESENTATION_MODULES = ("experiment/views.py", "papers/presentation.py", "arena/views.py")


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
    """``module.qualname`` of ``job``: how the cache key and messages name it."""
    return f"{getattr(job, '__module__', '?')}.{getattr(job, '__qualname__', repr(job))}"


def key_document(*, paper: str, job: Callable, reading: Mapping, algorithms: Iterable[str], n_runs: int,
                 seed: int) -> dict:
    """What a cached universe depends on; stored with the entry and checked when it is read."""
    return {"paper": paper, "job": job_name(job), "reading": dict(sorted(reading.items())),
            "algorithms": list(algorithms), "n_runs": int(n_runs), "seed": int(seed), "mmlib": source_hash()}


def cache_key(**parts: Any) -> str:
    """The cache file name of a universe: the first 32 hex digits of the SHA-256 of :func:`key_document`
    ``(**parts)`` (same keyword arguments)."""
    return hashlib.sha256(json.dumps(key_document(**parts), sort_keys=True).encode()).hexdigest()[:32]


RESULT_KEYS = ("values", "claims", "effects", "diverged", "n_runs")


def _read_entry(path: Path, key_doc: dict, result_keys=RESULT_KEYS):
    """The cached result, or None when the entry is missing, unreadable, written for another key or
    lacks a key of ``result_keys`` (it is then recomputed and overwritten)."""
    try:
        entry = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError):
        return None
    if not isinstance(entry, dict) or entry.get("key") != json.loads(json.dumps(key_doc)):
        return None
    res = entry.get("result")
    if not isinstance(res, dict) or any(k not in res for k in result_keys):
        return None
    return res


def _write_json_atomic(path: Path, doc) -> None:
    from mmlib.experiment.report import atomic_write_text
    atomic_write_text(path, json.dumps(doc, allow_nan=False, sort_keys=True))


def _run_job(job, reading, n_runs, seed):
    return job(dict(reading), n_runs, seed)


def run_grid(job: Callable, readings: Iterable[Mapping[str, Any]], *, paper: str, algorithms: Iterable[str],
             n_runs: int, seed: int,
             executor: cf.Executor | None = None, workers: int | None = None,
             cache_dir: str | Path | None = None, use_cache: bool = True,
             progress: bool | Callable = True, label: str = "", result_keys: Sequence[str] = RESULT_KEYS,
             unit: str = "universe") -> list:
    """Run ``job(reading, n_runs, seed)`` for every reading; results in the order of ``readings``.

    ``executor``: any ``concurrent.futures.Executor`` (it is not shut down here); by default
    the Dask cluster of ``$MMLIB_SCHEDULER`` if set, else this process's pool of ``workers``
    local processes (integer >= 1; default ``$WORKERS``, else every core), or this process
    when ``workers == 1`` or one universe is to be computed (:func:`executors.run_tasks`);
    the results do not depend on where the jobs ran.  ``cache_dir``: where results are kept
    (``default_cache_dir()``); ``use_cache=False`` neither reads nor writes it.  ``progress``: True prints one line per
    universe to stderr, a callable receives that line, False is silent.  ``result_keys``: the keys every job result
    must have (default: a universe result of :func:`mmlib.experiment.multiverse.universe_result`); ``unit``: what a
    job is called in the progress lines ("universe", "cell").
    """
    readings = [dict(r) for r in readings]
    check_positive_int(n_runs, "n_runs")
    check_positive_int(seed, "seed", minimum=0)
    if not callable(job):
        raise ValueError(f"job: expected a callable job(reading, n_runs, seed), got {job!r}")
    worker_count(workers)               # a bad workers or $WORKERS is an error even when all is cached
    if executor is not None and not callable(getattr(executor, "submit", None)):
        raise ValueError(f"executor: expected a concurrent.futures.Executor, got {type(executor).__name__}")
    algorithms = list(algorithms)
    cache = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    say = say_progress if progress is True else (progress or None)
    tag = label or paper
    results: list = [None] * len(readings)
    key_docs = [key_document(paper=paper, job=job, reading=r, algorithms=algorithms, n_runs=n_runs, seed=seed)
                for r in readings]
    keys = [hashlib.sha256(json.dumps(k, sort_keys=True).encode()).hexdigest()[:32] for k in key_docs]
    todo = []
    for i, key in enumerate(keys):
        if use_cache:
            results[i] = _read_entry(cache / paper / f"{key}.json", key_docs[i], result_keys)
            if results[i] is not None:
                continue
        todo.append(i)
    n_cached = len(readings) - len(todo)
    if say and n_cached:
        say(f"  [{tag}] {n_cached}/{len(readings)} {unit}s from the cache ({cache / paper})")
    if not todo:
        return results
    t0 = time.perf_counter()
    done = 0

    def finished(k, res):
        nonlocal done
        i = todo[k]
        if not isinstance(res, dict):
            raise ValueError(f"job: {job_name(job)} returned {type(res).__name__}, expected a dict")
        results[i] = json.loads(json.dumps(res, allow_nan=False))   # the same form as from the cache
        if any(key not in results[i] for key in result_keys):
            raise ValueError(f"job: {job_name(job)} returned a dict without {tuple(result_keys)}"
                             + (" (build it with multiverse.universe_result)" if result_keys == RESULT_KEYS else ""))
        if use_cache:
            _write_json_atomic(cache / paper / f"{keys[i]}.json", {"key": key_docs[i], "result": results[i]})
        done += 1
        if say:
            div = res.get("diverged") or {}
            ndiv = sum(div.values()) if isinstance(div, dict) else 0
            say(f"  [{tag}] {unit} {done}/{len(todo)} done ({time.perf_counter() - t0:.1f} s): "
                f"{json.dumps(readings[i], sort_keys=False)}" + (f"; diverged runs {div}" if ndiv else ""))

    run_tasks(_run_job, [(readings[i], n_runs, seed) for i in todo], shared=(job,), workers=workers,
              executor=executor, on_result=finished)
    return results
