"""The experiment layer (paper-agnostic): Monte Carlo streams (``montecarlo``), truth simulation (``simulate``),
scenarios as data (``scenario``), metrics with standard errors (``metrics``), Monte Carlo evaluation on common random
numbers (``evaluation``), reading spaces (``readings``), the grid runner with its cache (``grid``) and executors
(``executors``), universe results (``universe``), multiverse summaries (``multiverse``), the paper contract
(``paper``), run digests and machine fingerprints (``digests``, ``machine``), the one verdict rule (``verdicts``),
the results contract and its writing (``results``, ``report``), their tables and figures (``views``) and what
every notebook shares (``notebook``).

It depends only on the estimation core (``mmlib.core``); the paper set-ups (``mmlib.papers``) and the arena
(``mmlib.arena``) depend on it.
"""
from typing import TYPE_CHECKING

from mmlib.core._lazy import lazy_attributes

__all__ = [
    "run_grid", "run_multiverse", "Multiverse", "ReadingSpace", "Factor", "Option", "Deviation", "UniverseResult",
    "PublishedNumber"
]

# Imported on first use (PEP 562), as in ``mmlib/__init__.py``: importing one module of this layer (a notebook
# kernel's ``mmlib.experiment.montecarlo``) does not import evaluation, metrics and scipy.stats with it.

#: the modules the eager imports bound here (attributes, not in __all__; every module of the layer is reachable as
#: mmlib.experiment.evaluation ..., imported on first access)
_MODULES = ("evaluation", "grid", "multiverse", "readings")
#: the API objects of __all__, by the module that defines them
_OBJECTS = {
    "mmlib.experiment.grid": ("run_grid",),
    "mmlib.experiment.multiverse": ("Multiverse", "run_multiverse"),
    "mmlib.experiment.universe": ("PublishedNumber", "UniverseResult"),
    "mmlib.experiment.readings": ("Deviation", "Factor", "Option", "ReadingSpace"),
}
_OBJECT_MODULE = {name: module for module, names in _OBJECTS.items() for name in names}

if TYPE_CHECKING:
    from mmlib.experiment import evaluation, grid, multiverse, readings  # noqa: F401
    from mmlib.experiment.grid import run_grid
    from mmlib.experiment.multiverse import Multiverse, run_multiverse
    from mmlib.experiment.universe import PublishedNumber, UniverseResult
    from mmlib.experiment.readings import Deviation, Factor, Option, ReadingSpace


__getattr__, __dir__ = lazy_attributes(__name__, globals(), _MODULES, _OBJECTS)
