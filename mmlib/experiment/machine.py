"""The machine fingerprint: what decides whether two computations of the same code give the same bits.

The filters give a run the same bits on one machine in any batch, chunking or worker count
(tests/test_batch_independence.py).  Across machines they agree only to round-off, because three
things pick their code per CPU at run time:

* OpenBLAS chooses its kernels by CPU core (``$OPENBLAS_CORETYPE`` overrides it), so matrix products and
  factorisations sum in another order;
* numpy dispatches its elementary functions (``exp`` and ``log``: the IMM's mode-probability update and
  :mod:`mmlib.core.linalg`) by SIMD level (``$NPY_DISABLE_CPU_FEATURES`` lowers it); their results differ
  by a few units in the last place;
* the mmlib kernel (:func:`mmlib.core.linalg.kernel`: compiled or numpy), and numba's target CPU.

:func:`fingerprint` records these (and the CPU model, its flags and the library versions) as a JSON-ready
dict; two computations are expected to agree bit for bit only when their fingerprints are equal, and to
round-off otherwise (:func:`mmlib.experiment.digests.compare_digests`).  The fingerprint is stored in
every run digest and is part of every results-cache key (:mod:`mmlib.experiment.grid`).
"""
from __future__ import annotations

import ctypes
import functools
import hashlib
import json
import os
import platform

__all__ = [
    "fingerprint", "fingerprint_id", "differences", "dispatch_environment", "openblas", "numpy_simd",
    "DISPATCH_VARIABLES"
]

#: the environment variables that change which code the libraries dispatch to (recorded as set or not)
DISPATCH_VARIABLES = ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES", "NPY_ENABLE_CPU_FEATURES", "NUMBA_CPU_NAME",
                      "NUMBA_CPU_FEATURES", "MMLIB_KERNEL")


def _cpuinfo() -> tuple[str, str]:
    """(CPU model name, SHA-256 prefix of its sorted feature flags) from ``/proc/cpuinfo`` (Linux), else
    :func:`platform.processor` and an empty flag hash."""
    model, flags = platform.processor() or platform.machine(), ""
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                key, _, value = line.partition(":")
                key = key.strip()
                if key in ("model name", "Model", "CPU part") and model in ("", platform.machine(),
                                                                            platform.processor()):
                    model = value.strip()
                elif key in ("flags", "Features") and not flags:
                    flags = hashlib.sha256(" ".join(sorted(value.split())).encode()).hexdigest()[:16]
    except OSError:
        pass
    return model, flags


def openblas() -> dict:
    """The OpenBLAS this process loaded (via numpy), asked of the library itself: ``{"openblas_core",
    "openblas_config", "openblas_threads"}``; an empty dict when none is loaded or it cannot be asked
    (not Linux, another BLAS)."""
    import numpy  # noqa: F401  (loads the BLAS numpy links)
    try:
        with open("/proc/self/maps") as fh:
            paths = sorted({line.split()[-1] for line in fh if "openblas" in line.lower() and "/" in line})
    except OSError:
        return {}
    for path in paths:
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for prefix, suffix in (("scipy_openblas", "64_"), ("scipy_openblas", ""), ("openblas", "64_"),
                               ("openblas", "")):
            threads = getattr(lib, f"{prefix}_get_num_threads{suffix}", None)
            if threads is None:
                continue
            threads.restype = ctypes.c_int
            config = getattr(lib, f"{prefix}_get_config{suffix}")
            config.restype = ctypes.c_char_p
            core = getattr(lib, f"{prefix}_get_corename{suffix}", None)
            if core is not None:
                core.restype = ctypes.c_char_p
            return {"openblas_threads": int(threads()), "openblas_config": config().decode(),
                    "openblas_core": core().decode() if core is not None else None}
    return {}


def numpy_simd() -> list[str]:
    """The SIMD targets numpy dispatches to in this process: its build baseline plus every dispatch target
    the CPU supports and ``$NPY_DISABLE_CPU_FEATURES`` leaves enabled (e.g. ``["X86_V2", "X86_V3"]`` on an
    AVX2 machine)."""
    try:
        from numpy._core import _multiarray_umath as m
    except ImportError:                                         # numpy < 2
        from numpy.core import _multiarray_umath as m          # type: ignore[no-redef]
    return list(m.__cpu_baseline__) + [f for f in m.__cpu_dispatch__ if m.__cpu_features__.get(f)]


def _numba_target() -> str | None:
    try:
        import numba
        import llvmlite.binding as llb
    except ImportError:
        return None
    return numba.config.CPU_NAME or llb.get_host_cpu_name()


@functools.lru_cache(maxsize=1)
def _fixed() -> dict:
    """The part of the fingerprint fixed for the life of a process (everything but the kernel)."""
    import numpy
    import scipy
    try:
        import numba
        numba_version = numba.__version__
    except ImportError:
        numba_version = None
    model, flags = _cpuinfo()
    return {"arch": platform.machine(), "cpu": model, "cpu_flags": flags,
            "openblas_core": openblas().get("openblas_core"), "numpy_simd": numpy_simd(),
            "numba_target": _numba_target(), "numpy": numpy.__version__, "scipy": scipy.__version__,
            "numba": numba_version}


def fingerprint() -> dict:
    """This process's machine fingerprint (JSON-ready): ``arch``, ``cpu`` (model name), ``cpu_flags`` (hash of
    the feature flags), ``openblas_core``, ``numpy_simd``, ``numba_target``, the ``numpy``/``scipy``/``numba``
    versions (read once per process) and ``kernel`` (:func:`mmlib.core.linalg.kernel`, read at each call)."""
    from mmlib.core.linalg import kernel
    return {**_fixed(), "kernel": kernel()}


def fingerprint_id(fp: dict | None = None) -> str:
    """Short name of a fingerprint (first 16 hex digits of the SHA-256 of its sorted JSON; default: this
    process's), e.g. for cache keys and messages."""
    fp = fingerprint() if fp is None else fp
    return hashlib.sha256(json.dumps(fp, sort_keys=True).encode()).hexdigest()[:16]


def differences(a: dict, b: dict) -> list[str]:
    """The fields in which two fingerprints differ, as ``"field: a vs b"`` lines (empty when equal)."""
    keys = sorted(set(a) | set(b))
    return [f"{k}: {a.get(k)!r} vs {b.get(k)!r}" for k in keys if a.get(k) != b.get(k)]


def dispatch_environment() -> dict:
    """The dispatch variables of :data:`DISPATCH_VARIABLES` that are set in this process's environment."""
    return {k: os.environ[k] for k in DISPATCH_VARIABLES if k in os.environ}
