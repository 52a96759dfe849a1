"""The experiment layer (paper-agnostic): Monte Carlo evaluation on common random numbers
(``evaluation``), reading spaces (``readings``), the grid runner with its cache (``grid``),
multiverse summaries (``multiverse``) and their tables and figures (``views``).

It depends on the estimation core (filters, IMM, models, simulation, metrics) and on
``mmlib.experiment.report`` (the one verdict rule); the paper set-ups in ``mmlib.papers`` depend on it.
"""
from mmlib.experiment import evaluation, grid, multiverse, readings
from mmlib.experiment.grid import run_grid
from mmlib.experiment.multiverse import Multiverse, PublishedNumber, run_multiverse, universe_result
from mmlib.experiment.readings import Deviation, Factor, Option, ReadingSpace

__all__ = ["evaluation", "grid", "multiverse", "readings", "run_grid", "Multiverse", "PublishedNumber",
           "run_multiverse", "universe_result", "Deviation", "Factor", "Option", "ReadingSpace"]
