"""Counts read from the environment: the cores this process may use, and a positive count set in an environment
variable (the worker processes of :mod:`mmlib.experiment.executors`, the threads of the fused filter steps of
:mod:`mmlib.core.linalg`).  Imports nothing but the standard library, so that the bottom of the core and the
notebook runner can use it without loading numpy or numba."""
from __future__ import annotations

import os


def usable_cores() -> int:
    """The cores this process may use: its CPU affinity where the platform has one, else the machine's count."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def count_from_env(name: str, what: str) -> int:
    """``$name`` as a positive integer (anything else is a ValueError naming ``name`` and saying it counts ``what``),
    else :func:`usable_cores`."""
    env = os.environ.get(name, "").strip()
    if env:
        if not (env.isascii() and env.isdigit()) or int(env) < 1:
            raise ValueError(f"{name}: expected a positive integer ({what}), got {env!r}")
        return int(env)
    return usable_cores()
