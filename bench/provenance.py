"""Provenance and thread settings recorded in every benchmark output.

Importing this module does not import numpy: :func:`pin_threads` must run before numpy is first
imported (the BLAS and OpenMP runtimes read their thread counts once, when they load).
"""
from __future__ import annotations

import datetime
import os
import platform
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

#: Thread-count variables of the runtimes numpy, scipy and numba may use, and of mmlib's fused steps
#: (:func:`mmlib.core.linalg.threads`); all set to BENCH_THREADS (default 1).
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS",
                    "NUMBA_NUM_THREADS", "MMLIB_THREADS")


def pin_threads() -> str:
    """Set every variable of :data:`THREAD_VARIABLES` to ``$BENCH_THREADS`` (default ``"1"``: single-threaded);
    call before numpy is imported.  Subprocesses inherit the setting."""
    threads = os.environ.get("BENCH_THREADS", "1").strip()
    if not threads.isdigit() or int(threads) < 1:
        raise ValueError(f"BENCH_THREADS: expected a positive integer (threads), got {threads!r}")
    if "numpy" in sys.modules:
        raise RuntimeError("pin_threads: numpy is already imported; the thread counts would not apply")
    for var in THREAD_VARIABLES:
        os.environ[var] = threads
    return threads


def _openblas() -> dict:
    """The thread count and build of the OpenBLAS numpy loaded (:func:`mmlib.experiment.machine.openblas`)."""
    from mmlib.experiment.machine import openblas
    return openblas()


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def threads() -> dict:
    """The thread settings in force: the environment variables and what OpenBLAS reports."""
    info = {var: os.environ.get(var) for var in THREAD_VARIABLES}
    info.update(_openblas())
    return info


def provenance() -> dict:
    """Git commit (``-dirty`` if the code differs from it), date, machine, package versions, thread settings,
    mmlib's kernel implementation."""
    import numpy as np

    import mmlib
    from mmlib.experiment.writing import git_commit

    packages = {"numpy": np.__version__}
    for name in ("scipy", "numba", "filterpy", "matplotlib"):
        try:
            packages[name] = __import__(name).__version__
        except ImportError:
            packages[name] = None
    try:
        from mmlib.core import linalg
        kernel = linalg.kernel() if hasattr(linalg, "kernel") else "numpy"
    except Exception:                       # noqa: BLE001 -- provenance must not fail the report
        kernel = None
    return {
        "git_commit": git_commit(REPO),
        "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "machine": {"cpu": cpu_model(), "cpu_count": os.cpu_count(),
                    "cpus_usable": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
                    "platform": platform.platform(), "python": platform.python_version()},
        "packages": packages,
        "mmlib": getattr(mmlib, "__version__", None),
        "mmlib_kernel": kernel,
        "threads": threads(),
        "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
        "load_average_note": "1, 5 and 15-minute load averages when this was recorded: other work on the "
                             "machine slows the timings",
    }
