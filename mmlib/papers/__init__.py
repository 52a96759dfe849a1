"""One module per replicated paper: its set-up, numbered deviations and experiments.

Notebooks call these; tests import them to check the paper-level claims
(e.g. that two algorithms coincide under the paper's set-up)."""
from __future__ import annotations

import importlib
import pkgutil


def with_headline_digest() -> list[str]:
    """The names of the paper modules that define ``headline_digest(n_runs)`` (every replicated paper), found by
    walking this package rather than listed, so a new paper is covered by the digest tests and the cross-CPU
    measurement (tests/tolerance/test_digest.py, tools/emulated_tests.py) when it defines one."""
    names = []
    for info in pkgutil.iter_modules(__path__):
        if not info.name.startswith("_") and hasattr(importlib.import_module(f"{__name__}.{info.name}"),
                                                     "headline_digest"):
            names.append(info.name)
    return sorted(names)
