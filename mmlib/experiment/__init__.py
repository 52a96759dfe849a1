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
from mmlib.experiment import evaluation, grid, multiverse, readings  # noqa: F401  (modules: attributes, not in __all__)
from mmlib.experiment.grid import run_grid
from mmlib.experiment.multiverse import Multiverse, run_multiverse
from mmlib.experiment.universe import PublishedNumber, UniverseResult
from mmlib.experiment.readings import Deviation, Factor, Option, ReadingSpace

__all__ = [
    "run_grid", "run_multiverse", "Multiverse", "ReadingSpace", "Factor", "Option", "Deviation", "UniverseResult",
    "PublishedNumber"
]
