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
the job's own code, reading, algorithms, runs, seed, the hash of mmlib's source, the machine fingerprint):
re-running after an edit that leaves ``mmlib/`` and the job alone (a notebook's prose, say) recomputes
nothing; any edit of the library, or of a job defined outside it (a script's or a notebook's function, a
lambda, and the functions and values it uses outside mmlib: :func:`job_code`), recomputes what it
touches; a cache filled on a machine of another fingerprint (:mod:`mmlib.experiment.machine`: CPU, OpenBLAS
core, numpy SIMD level, kernel) is not served, since its numbers agree with this machine's only to round-off.

Each entry carries the SHA-256 of its result.  An entry that cannot be read (not UTF-8, not JSON, another
key, a missing field, a checksum that does not match: an edited number) is recomputed and overwritten, with
one :class:`CacheWarning` naming the file.  A cache folder that cannot be written (read-only, or not
creatable) gives one warning per study, which then runs uncached: every result is still returned.

A result computed on a machine whose fingerprint differs from this process's (a Dask worker of another CPU)
carries that fingerprint under ``"machine"``, so that a bit-for-bit comparison with a result of this process
can fall back to round-off (:func:`mmlib.experiment.digests.same_numbers`).
"""
from __future__ import annotations

import concurrent.futures as cf
import functools
import hashlib
import json
import os
import re
import sys
import sysconfig
import time
import types
import warnings
from pathlib import Path
from typing import Any, Callable, Iterable, Mapping, Sequence

import numpy as np

from mmlib.core._validate import as_plain_json, check_bool, check_names, check_pattern, check_positive_int
# default_workers lived here: kept importable from this module
from mmlib.experiment.executors import default_workers, run_tasks, worker_count  # noqa: F401
from mmlib.experiment.machine import fingerprint, fingerprint_id
from mmlib.experiment.universe import JSON_KEYS, UniverseResult
from mmlib.experiment.montecarlo import say_progress
# source_hash and PRESENTATION_MODULES lived here (moved below executors, which needs them too): kept importable
from mmlib.experiment.source import PRESENTATION_MODULES, source_hash  # noqa: F401
from mmlib.experiment.writing import atomic_write_text

__all__ = [
    "run_grid", "CacheWarning", "GridProgress", "default_cache_dir", "key_document", "result_checksum", "job_name",
    "job_code", "check_paper", "progress_line", "format_duration", "verbose_progress", "PAPER_NAME", "RESULT_KEYS",
    "PROGRESS_INTERVAL", "VERBOSE_ENV"
]

#: least seconds between two progress lines of a grid (the first and the last finished job are always reported)
PROGRESS_INTERVAL = 15.0

#: environment variable: "1" makes every grid report each finished job with its reading (the factors' levels);
#: ``tools/run_notebooks.py -v`` sets it for the kernels it starts
VERBOSE_ENV = "MMLIB_PROGRESS_VERBOSE"


def verbose_progress() -> bool:
    """Whether ``$MMLIB_PROGRESS_VERBOSE`` asks for a line per finished job with its reading ("1", "true", "yes")."""
    return os.environ.get(VERBOSE_ENV, "").strip().lower() in ("1", "true", "yes")


def format_duration(seconds: float) -> str:
    """A wall time in seconds as a person reads it: ``"40 s"``, ``"3.5 min"``, ``"1.2 h"`` (two significant figures
    at most; a negative or non-finite value is a ValueError)."""
    if isinstance(seconds, bool) or not isinstance(seconds, (int, float)) or not np.isfinite(seconds) \
            or seconds < 0:
        raise ValueError(f"seconds: expected a finite number >= 0, got {seconds!r}")
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 90 * 60:
        minutes = seconds / 60
        return f"{minutes:.1f} min" if minutes < 10 else f"{minutes:.0f} min"
    return f"{seconds / 3600:.1f} h"


def progress_line(tag: str, unit: str, done: int, total: int, elapsed: float) -> str:
    """The progress line of a grid: ``"  [tag] universe k/N, ~T left"`` while jobs remain, the time left estimated
    from the mean wall time per finished job so far (``elapsed`` seconds for ``done`` jobs, whatever the number of
    workers: it is their throughput), and ``"  [tag] universe N/N, done in T"`` for the last one."""
    done, total = check_positive_int(done, "done"), check_positive_int(total, "total")
    if done > total:
        raise ValueError(f"done: expected at most total ({total}), got {done}")
    if done == total:
        return f"  [{tag}] {unit} {done}/{total}, done in {format_duration(elapsed)}"
    return f"  [{tag}] {unit} {done}/{total}, ~{format_duration(elapsed / done * (total - done))} left"


class GridProgress:
    """The progress of a grid's jobs as they finish: :func:`progress_line` through ``say`` for the first and the last
    job, and otherwise at most one line every ``interval`` seconds; ``verbose`` (default:
    :func:`verbose_progress`) reports every job, followed by its reading (the levels of its factors) and its
    diverged runs.  Without ``verbose``, the last line counts the jobs with diverged runs.  ``clock``: the wall
    clock in seconds (a test's fake one)."""

    def __init__(self, tag: str, unit: str, total: int, say: Callable[[str], None],
                 interval: float = PROGRESS_INTERVAL, verbose: bool | None = None,
                 clock: Callable[[], float] = time.perf_counter):
        if not callable(say):
            raise ValueError(f"say: expected a callable receiving each line, got {say!r}")
        if isinstance(interval, bool) or not isinstance(interval, (int, float)) or not interval >= 0:
            raise ValueError(f"interval: expected a number of seconds >= 0, got {interval!r}")
        self.tag, self.unit, self.say, self.interval, self.clock = tag, unit, say, float(interval), clock
        self.total = check_positive_int(total, "total")
        self.verbose = verbose_progress() if verbose is None else check_bool(verbose, "verbose")
        self.done, self.with_diverged = 0, 0
        self.t0 = self.last = clock()

    def finished(self, reading: Mapping | None = None, diverged: Mapping | None = None) -> None:
        """Count one more finished job (its ``reading`` and ``{algorithm: diverged runs}``, for the verbose line and
        the count of jobs with diverged runs) and report it if it is due."""
        self.done += 1
        ndiv = sum(v for v in (diverged or {}).values() if isinstance(v, (int, float)))
        self.with_diverged += bool(ndiv)
        now = self.clock()
        last = self.done == self.total
        if not (self.verbose or last or self.done == 1 or now - self.last >= self.interval):
            return
        self.last = now
        line = progress_line(self.tag, self.unit, min(self.done, self.total), self.total, now - self.t0)
        if self.verbose:
            line += (f": {json.dumps(dict(reading or {}), sort_keys=False)}"
                     + (f"; diverged runs {dict(diverged)}" if ndiv else ""))
        elif last and self.with_diverged:
            line += f" ({self.with_diverged} {self.unit}(s) with diverged runs)"
        self.say(line)


def _shown(path: Path) -> str:
    """``path`` relative to the repository holding mmlib when it lies inside it (no machine-local path in a log)."""
    repo = Path(__file__).resolve().parents[2]
    path = Path(path).resolve()
    return str(path.relative_to(repo)) if path.is_relative_to(repo) else str(path)


def default_cache_dir() -> Path:
    """``$MMLIB_CACHE`` if set, else ``build/cache/multiverse`` of the repository holding mmlib."""
    env = os.environ.get("MMLIB_CACHE")
    return Path(env) if env else Path(__file__).resolve().parents[2] / "build" / "cache" / "multiverse"


def job_name(job: Callable) -> str:
    """``module.qualname`` of ``job``: how the cache key and messages name it."""
    return f"{getattr(job, '__module__', '?')}.{getattr(job, '__qualname__', repr(job))}"


class CacheWarning(UserWarning):
    """A cache entry was unreadable or inconsistent (and is recomputed), or the cache folder cannot be written
    (the study runs uncached)."""


#: a paper name: a cache sub-folder, so letters, digits, ``_``, ``.`` and ``-`` only, not starting with a dot
PAPER_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")


def check_paper(paper: str, name: str = "paper") -> str:
    """``paper`` if it is a valid paper name (:data:`PAPER_NAME`: no path separator, no ``..``), else ValueError."""
    return check_pattern(paper, name, PAPER_NAME, "a paper name of letters, digits, '_', '.' and '-' (no path "
                         "separator, not starting with '.')")


@functools.lru_cache(maxsize=1)
def _library_roots() -> tuple:
    paths = sysconfig.get_paths()
    roots = {paths.get(k) for k in ("stdlib", "platstdlib", "purelib", "platlib")} | {sys.base_prefix, sys.prefix}
    return tuple(str(Path(r).resolve()) for r in roots if r)


def _is_mmlib(module: str) -> bool:
    return module == "mmlib" or module.startswith("mmlib.")


def _is_library(module: str) -> bool:
    """Whether ``module`` is installed code (the standard library or a site package), whose changes come
    with its version, rather than a user's script or notebook."""
    mod = sys.modules.get(module)
    path = getattr(mod, "__file__", None)
    if mod is None or module == "__main__":
        return False
    if path is None:                                    # builtin or namespace modules
        return True
    path = str(Path(path).resolve())
    return any(path.startswith(root + os.sep) for root in _library_roots())


def _sub_hash(value, seen: set, depth: int) -> str:
    sub = hashlib.sha256()
    _feed_value(value, sub, seen, depth)
    return sub.hexdigest()


def _object_state(value) -> dict | None:
    """An object's own state as a dict: dataclass fields, else ``__getstate__``'s dict, else its ``__dict__`` and
    ``__slots__``, without underscore-prefixed attributes (private memos filled lazily, e.g. a design cache);
    None when it has none of these."""
    import dataclasses
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: getattr(value, f.name, None) for f in dataclasses.fields(value)}
    state = {}
    for cls in type(value).__mro__:
        for slot in getattr(cls, "__slots__", ()):
            if isinstance(slot, str) and not slot.startswith("_") and hasattr(value, slot):
                state[slot] = getattr(value, slot)
    if hasattr(value, "__dict__"):
        state.update({k: v for k, v in vars(value).items() if not k.startswith("_")})
    return state if state or hasattr(value, "__dict__") else None


def _feed_value(value, h, seen: set, depth: int) -> None:
    """Hash a data value deterministically: numbers and strings by value, arrays by dtype, shape and bytes,
    containers element by element (sets in the sorted order of their elements' hashes), callables by their
    code (:func:`_feed_callable`), other objects by their type and state (:func:`_object_state`); a container or
    object met again is hashed once (shared structure costs nothing more)."""
    if depth > 50:
        h.update(b"<deep>")
        return
    if value is None or isinstance(value, (bool, int, float, complex, str, bytes)):
        h.update(f"{type(value).__name__}:{value!r}".encode())
        return
    if isinstance(value, (np.ndarray, np.generic)):
        arr = np.asarray(value)
        h.update(f"<array {arr.dtype.str} {arr.shape}>".encode())
        h.update(np.ascontiguousarray(arr).tobytes() if arr.dtype != object else repr(arr.tolist()).encode())
        return
    if isinstance(value, types.ModuleType):
        _feed_module(value, h, seen)
        return
    if id(value) in seen:
        h.update(b"<seen>")
        return
    if isinstance(value, (types.FunctionType, types.MethodType, types.BuiltinFunctionType, functools.partial, type)):
        _feed_callable(value, h, seen, depth + 1)
        return
    seen.add(id(value))
    if isinstance(value, (list, tuple)):
        h.update(f"<{type(value).__name__} {len(value)}>".encode())
        for v in value:
            _feed_value(v, h, seen, depth + 1)
    elif isinstance(value, (set, frozenset)):
        h.update(f"<set {sorted(_sub_hash(v, set(), depth + 1) for v in value)}>".encode())
    elif isinstance(value, Mapping):
        h.update(f"<{type(value).__name__} {len(value)}>".encode())
        for k, v in value.items():
            _feed_value(k, h, seen, depth + 1)
            _feed_value(v, h, seen, depth + 1)
    else:
        cls = type(value)
        h.update(f"<object {cls.__module__}.{cls.__qualname__}>".encode())
        if not (_is_mmlib(cls.__module__) or _is_library(cls.__module__)):
            _feed_callable(cls, h, seen, depth + 1)            # a user's class: its code too
        state = _object_state(value)
        if state is not None:
            _feed_value(state, h, seen, depth + 1)
        else:
            import cloudpickle
            try:
                h.update(cloudpickle.dumps(value))
            except Exception:                           # noqa: BLE001 -- an unpicklable value keys by its type
                h.update(b"<opaque>")


def _feed_module(module: types.ModuleType, h, seen: set) -> None:
    """A module: installed libraries and mmlib by name (their code comes with a version or the source hash), a
    user's module by the bytes of its source file."""
    name = module.__name__
    h.update(f"<module {name}>".encode())
    if _is_mmlib(name) or _is_library(name) or ("module", name) in seen:
        return
    seen.add(("module", name))
    path = getattr(module, "__file__", None)
    if path:
        try:
            h.update(Path(path).read_bytes())
        except OSError:
            h.update(b"<unreadable>")


def _feed_code(code: types.CodeType, h) -> None:
    """Hash a code object without its file name and line numbers (a notebook's cells get a new file per kernel)."""
    h.update(code.co_code)
    h.update(repr((code.co_names, code.co_varnames, code.co_freevars, code.co_cellvars, code.co_argcount,
                   code.co_kwonlyargcount, code.co_posonlyargcount, code.co_flags)).encode())
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            _feed_code(const, h)
        elif isinstance(const, frozenset):
            h.update(f"<frozenset {sorted(repr(v) for v in const)}>".encode())
        else:
            h.update(f"{type(const).__name__}:{const!r}".encode())


def _global_names(code: types.CodeType) -> set:
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= _global_names(const)
    return names


def _feed_callable(fn, h, seen: set, depth: int) -> None:
    """Hash a callable's own code, recursively through what it uses outside mmlib and installed libraries."""
    if id(fn) in seen:
        h.update(b"<seen>")
        return
    seen.add(id(fn))
    if isinstance(fn, functools.partial):
        h.update(b"<partial>")
        _feed_callable(fn.func, h, seen, depth + 1)
        _feed_value(fn.args, h, seen, depth + 1)
        _feed_value(dict(fn.keywords), h, seen, depth + 1)
        return
    if isinstance(fn, types.MethodType):
        h.update(b"<method>")
        _feed_callable(fn.__func__, h, seen, depth + 1)
        _feed_value(fn.__self__, h, seen, depth + 1)
        return
    module = getattr(fn, "__module__", None) or ""
    name = f"{module}.{getattr(fn, '__qualname__', type(fn).__qualname__)}"
    if _is_mmlib(module) or _is_library(module):
        # mmlib's code is in source_hash and a library's comes with its version: the name stands for the code, but
        # what the caller put in (a closure's values, an instance's state) is hashed
        h.update(f"<ref {name}>".encode())
        if isinstance(fn, types.FunctionType):
            for cell in fn.__closure__ or ():
                try:
                    _feed_value(cell.cell_contents, h, seen, depth + 1)
                except ValueError:
                    h.update(b"<empty cell>")
        elif not isinstance(fn, (type, types.BuiltinFunctionType)):
            _feed_value(_object_state(fn) or {}, h, seen, depth + 1)
        return
    h.update(f"<def {name}>".encode())
    if isinstance(fn, type):                              # a user's class: its bases and every attribute it defines
        for base in fn.__mro__[1:]:
            if base is not object:
                _feed_callable(base, h, seen, depth + 1)
        for key, value in sorted(vars(fn).items()):
            if key not in ("__dict__", "__weakref__", "__module__", "__qualname__", "__doc__"):
                h.update(key.encode())
                _feed_value(value, h, seen, depth + 1)
        return
    if not isinstance(fn, types.FunctionType):            # a callable instance of a user's class
        _feed_callable(type(fn), h, seen, depth + 1)
        _feed_value(_object_state(fn) or {}, h, seen, depth + 1)
        return
    _feed_code(fn.__code__, h)
    _feed_value(fn.__defaults__, h, seen, depth + 1)
    _feed_value(fn.__kwdefaults__, h, seen, depth + 1)
    for cell in fn.__closure__ or ():
        try:
            _feed_value(cell.cell_contents, h, seen, depth + 1)
        except ValueError:                                # an empty cell
            h.update(b"<empty cell>")
    for gname in sorted(_global_names(fn.__code__)):
        if gname in fn.__globals__:
            h.update(f"<global {gname}>".encode())
            _feed_value(fn.__globals__[gname], h, seen, depth + 1)


def job_code(job: Callable) -> str:
    """The SHA-256 prefix (16 hex digits) of a job's own code, for the cache key.

    A function of mmlib is keyed by its name (its code is in :func:`source_hash`), a function of an installed
    library by its name too (its code changes with its version).  Any other callable -- a script's function,
    a notebook's ``__main__`` function, a lambda, a closure, a ``functools.partial``, a bound method, an
    instance with ``__call__`` -- is keyed by its byte code (without file names and line numbers), its default
    arguments, its closure's values, and recursively every global it names: the functions and classes it
    calls outside mmlib and the values it reads (numbers, arrays, containers).  So an edit of such a job
    between two :func:`run_grid` calls recomputes its universes."""
    h = hashlib.sha256(b"mmlib-job-code-1")
    _feed_callable(job, h, set(), 0)
    return h.hexdigest()[:16]


def key_document(*, paper: str, job: Callable, reading: Mapping, algorithms: Iterable[str], n_runs: int,
                 seed: int, code: str | None = None) -> dict:
    """What a cached universe depends on; stored with the entry and checked when it is read: the paper, the
    job's name and code (:func:`job_code`), the reading, algorithms, runs and seed, mmlib's source
    (:func:`source_hash`) and this machine's fingerprint (:func:`mmlib.experiment.machine.fingerprint_id`).
    ``code``: ``job_code(job)`` when the caller has it (a study keys many readings of one job)."""
    return {"paper": check_paper(paper), "job": job_name(job), "job_code": code or job_code(job),
            "reading": dict(sorted(_plain_reading(reading, "reading").items())),
            "algorithms": check_names(algorithms, "algorithms", nonempty=False),
            "n_runs": check_positive_int(n_runs, "n_runs"),
            "seed": check_positive_int(seed, "seed", minimum=0), "mmlib": source_hash(), "machine": fingerprint_id()}


RESULT_KEYS = JSON_KEYS


def result_checksum(result: Mapping) -> str:
    """SHA-256 of a result's canonical JSON (sorted keys): stored with every cache entry and checked on reading."""
    return hashlib.sha256(json.dumps(result, sort_keys=True, allow_nan=False).encode()).hexdigest()


def _read_entry(path: Path, key_doc: dict, result_keys=RESULT_KEYS):
    """The cached result, or None when the entry is missing (silently) or unreadable, written for another key,
    lacking a key of ``result_keys`` or failing its checksum (with a :class:`CacheWarning` naming the file); it
    is then recomputed and overwritten.  A result computed on a machine of another fingerprint carries it as
    ``"machine"``."""
    try:
        text = path.read_bytes()
    except (FileNotFoundError, NotADirectoryError):      # no entry (or no cache folder) yet
        return None
    except OSError as err:
        return _stale(path, f"cannot be read ({err.strerror or err})")
    try:
        entry = json.loads(text.decode("utf-8"))
    except UnicodeDecodeError as err:
        return _stale(path, f"is not UTF-8 (byte {err.start})")
    except json.JSONDecodeError as err:
        return _stale(path, f"is not JSON (line {err.lineno}, column {err.colno}: {err.msg})")
    if not isinstance(entry, dict) or entry.get("key") != json.loads(json.dumps(key_doc)):
        return _stale(path, "was written for another key")
    res = entry.get("result")
    if not isinstance(res, dict) or any(k not in res for k in result_keys):
        return _stale(path, f"lacks a result with {tuple(result_keys)}")
    try:
        ok = entry.get("sha256") == result_checksum(res)
    except ValueError:                                  # NaN in a hand-edited entry
        ok = False
    if not ok:
        return _stale(path, "fails its checksum (its result was edited or damaged)")
    machine = entry.get("machine")
    if isinstance(machine, dict) and machine != fingerprint():
        res["machine"] = machine
    return res


def _stale(path: Path, why: str) -> None:
    warnings.warn(f"cache entry {path} {why}: recomputing it", CacheWarning, stacklevel=3)
    return None


def _write_json_atomic(path: Path, doc) -> None:
    atomic_write_text(path, json.dumps(doc, allow_nan=False, sort_keys=True))


def _run_job(job, reading, n_runs, seed):
    """Run a job where the executor put it; its result with the fingerprint of the machine that computed it and the
    CPU seconds of the thread that ran it (``cpu_s``: every task computes on one thread, :func:`run_tasks`)."""
    start = time.thread_time()
    result = job(dict(reading), n_runs, seed)
    return {"result": result, "machine": fingerprint(), "cpu_s": time.thread_time() - start}


def _plain_reading(reading, name: str) -> dict:
    """A reading as a dict of plain JSON values (numpy scalars converted: :func:`as_plain_json`), or ValueError
    naming the entry."""
    if not isinstance(reading, Mapping):
        raise ValueError(f"{name}: expected a reading (a dict of factor: option), got {type(reading).__name__}")
    return as_plain_json(dict(reading), name)


def run_grid(job: Callable, readings: Iterable[Mapping[str, Any]], *, paper: str, algorithms: Iterable[str],
             n_runs: int, seed: int,
             executor: cf.Executor | None = None, workers: int | None = None,
             cache_dir: str | Path | None = None, use_cache: bool = True,
             progress: bool | Callable = True, label: str = "", result_keys: Sequence[str] = RESULT_KEYS,
             unit: str = "universe", result_type: type | None = UniverseResult, stats: dict | None = None) -> list:
    """Run ``job(reading, n_runs, seed)`` for every reading; results in the order of ``readings``.

    ``executor``: any ``concurrent.futures.Executor`` (it is not shut down here); by default
    the Dask cluster of ``$MMLIB_SCHEDULER`` if set, else this process's pool of ``workers``
    local processes (integer >= 1; default ``$WORKERS``, else every core), or this process
    when ``workers == 1`` or one universe is to be computed (:func:`executors.run_tasks`);
    the results do not depend on where the jobs ran.  ``cache_dir``: where results are kept
    (``default_cache_dir()``); ``use_cache=False`` neither reads nor writes it.  ``progress``: True prints the
    progress lines (:class:`GridProgress`: ``universe k/N, ~T left``, at most one every :data:`PROGRESS_INTERVAL`
    seconds; with ``$MMLIB_PROGRESS_VERBOSE=1`` one per universe with its reading) through
    :func:`~mmlib.experiment.montecarlo.say_progress`, a callable receives them, False is silent.
    ``result_keys``: the keys every job result must have in JSON (default: a universe result's,
    :class:`mmlib.experiment.universe.UniverseResult`); ``unit``: what a job is called in the progress lines
    ("universe", "cell").  ``result_type``: a class with ``as_json()`` and
    ``from_json(doc)`` that every job returns (default :class:`~mmlib.experiment.universe.UniverseResult`): results
    are JSON only in the cache and are returned as ``result_type`` objects; None: jobs return plain JSON dicts
    (the arena's cells), returned as such.  ``stats``: None, or a dict this call fills with how the results were
    obtained -- ``computed`` jobs run, ``from_cache`` jobs read from the cache and ``cpu_s``, the CPU seconds of the
    computed jobs (each job's thread time where it ran: a measurement of the machine, never part of a result)
    (``make figures`` reports universes per CPU-minute from it, ``bench/notebooks.py``).
    """
    if isinstance(readings, (str, bytes, Mapping)) or not isinstance(readings, Iterable):
        raise ValueError(f"readings: expected a sequence of readings (dicts), got {type(readings).__name__}")
    readings = [_plain_reading(r, f"readings[{i}]") for i, r in enumerate(readings)]
    check_paper(paper)
    n_runs = check_positive_int(n_runs, "n_runs")
    seed = check_positive_int(seed, "seed", minimum=0)
    if not callable(job):
        raise ValueError(f"job: expected a callable job(reading, n_runs, seed), got {job!r}")
    worker_count(workers)               # a bad workers or $WORKERS is an error even when all is cached
    if executor is not None and not callable(getattr(executor, "submit", None)):
        raise ValueError(f"executor: expected a concurrent.futures.Executor, got {type(executor).__name__}")
    algorithms = check_names(algorithms, "algorithms", nonempty=False)
    if isinstance(result_keys, (str, bytes)) or not result_keys or not all(isinstance(k, str) for k in result_keys):
        raise ValueError(f"result_keys: expected a non-empty sequence of key names, got {result_keys!r}")
    for value, name in ((label, "label"), (unit, "unit")):
        if not isinstance(value, str):
            raise ValueError(f"{name}: expected a string, got {value!r}")
    if isinstance(cache_dir, bool) or (cache_dir is not None and not isinstance(cache_dir, (str, os.PathLike))):
        raise ValueError(f"cache_dir: expected a folder path, got {cache_dir!r}")
    use_cache = check_bool(use_cache, "use_cache")
    if stats is not None and not isinstance(stats, dict):
        raise ValueError(f"stats: expected None or a dict to fill, got {type(stats).__name__}")
    if not (isinstance(progress, bool) or callable(progress)):
        raise ValueError(f"progress: expected True, False or a callable receiving each line, got {progress!r}")
    cache = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    say = say_progress if progress is True else (progress or None)
    tag = label or paper
    results: list = [None] * len(readings)
    code = job_code(job)
    key_docs = [key_document(paper=paper, job=job, reading=r, algorithms=algorithms, n_runs=n_runs, seed=seed,
                             code=code) for r in readings]
    keys = [hashlib.sha256(json.dumps(k, sort_keys=True).encode()).hexdigest()[:32] for k in key_docs]
    todo = []
    for i, key in enumerate(keys):
        if use_cache:
            results[i] = _read_entry(cache / paper / f"{key}.json", key_docs[i], result_keys)
            if results[i] is not None:
                continue
        todo.append(i)
    n_cached = len(readings) - len(todo)
    counts = {"computed": len(todo), "from_cache": n_cached, "cpu_s": 0.0}
    if stats is not None:
        stats.update(counts)
    if say and n_cached:
        say(f"  [{tag}] {n_cached}/{len(readings)} {unit}s from the cache ({_shown(cache / paper)})")
    if result_type is not None:
        results = [None if r is None else result_type.from_json(r) for r in results]
    if not todo:
        return results
    bar = GridProgress(tag, unit, len(todo), say) if say else None
    writable = [use_cache]

    def finished(k, out):
        i = todo[k]
        res, machine = out["result"], out["machine"]
        counts["cpu_s"] += out["cpu_s"]
        if stats is not None:
            stats["cpu_s"] = counts["cpu_s"]
        if result_type is not None:
            if not isinstance(res, result_type):
                raise ValueError(f"job: {job_name(job)} returned {type(res).__name__}, expected a "
                                 f"{result_type.__name__}")
            res = res.as_json()
        if not isinstance(res, dict):
            raise ValueError(f"job: {job_name(job)} returned {type(res).__name__}, expected a dict")
        try:
            results[i] = json.loads(json.dumps(res, allow_nan=False))   # the same form as from the cache
        except (TypeError, ValueError) as err:
            raise ValueError(f"job: {job_name(job)} returned a result that is not plain JSON for reading "
                             f"{readings[i]!r} ({err}; NaN and infinity are not allowed: use None)") from None
        if any(key not in results[i] for key in result_keys):
            raise ValueError(f"job: {job_name(job)} returned a dict without {tuple(result_keys)}"
                             + (" (build it with UniverseResult.build)" if result_keys == RESULT_KEYS else ""))
        if writable[0]:
            try:
                _write_json_atomic(cache / paper / f"{keys[i]}.json",
                                   {"key": key_docs[i], "result": results[i], "sha256": result_checksum(results[i]),
                                    "machine": machine})
            except OSError as err:
                writable[0] = False
                warnings.warn(f"cache folder {cache / paper} cannot be written ({err.strerror or err}): this study "
                              "runs uncached (its results are returned but not kept)", CacheWarning, stacklevel=2)
        if machine != fingerprint():
            results[i]["machine"] = machine
        div = results[i].get("diverged") or {}
        if result_type is not None:
            results[i] = result_type.from_json(results[i])
        if bar is not None:
            bar.finished(readings[i], div if isinstance(div, dict) else None)

    run_tasks(_run_job, [(readings[i], n_runs, seed) for i in todo], shared=(job,), workers=workers,
              executor=executor, on_result=finished)
    return results
