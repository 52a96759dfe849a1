"""Which mmlib computed a result: the hash of the library's source.

:func:`source_hash` is the "mmlib version" of the grid cache's key (:mod:`mmlib.experiment.grid`) and what a Dask
worker must share with its client (:mod:`mmlib.experiment.executors`); it lives below both so that neither imports
the other for it.
"""
from __future__ import annotations

import functools
import hashlib
from pathlib import Path

__all__ = [
    "source_hash", "PRESENTATION_MODULES"
]

#: modules that only render results (tables, figures): editing them cannot change a universe's numbers
PRESENTATION_MODULES = ("experiment/views.py", "experiment/notebook.py", "arena/views.py")


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
