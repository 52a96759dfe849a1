"""The arena: every algorithm of the five papers on every scenario where it applies -- the papers' headline
scenarios and a controlled ladder of nonlinearity and manoeuvre strength -- with accuracy, consistency, divergence
and cost in one table.

``recipes`` (every algorithm built from any scenario's models, parameters stated once), ``ladder`` (the controlled
scenarios and the computed nonlinearity index), ``study`` (the cells as parallel, cached Monte Carlo jobs; metrics,
ranks and the results document) and ``views`` (heat maps and ladder curves).  It sits above the paper set-ups
(``mmlib.papers``): it runs every registered paper's headline scenario (``mmlib.papers.REGISTRY``), the ideas and
claim each paper declares for it (:class:`mmlib.experiment.paper.ArenaEntry`) and the parameters of its headline
set-up; it is used by ``notebooks/arena.py`` only.
"""

__all__: list[str] = []
