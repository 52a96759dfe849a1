"""Controls of the pipeline: a "paper" whose printed table is known in closed form, which the whole pipeline must
reproduce (the positive control), and the same table perturbed, which it must reject (the negative controls).

The table is the steady state of the Kalman filter for the nearly-constant-velocity (DWNA) model with position
measurements, a function of the tracking index alone (Kalata 1984, IEEE Trans. AES 20(2):174,
doi:10.1109/TAES.1984.310438; Bar-Shalom, Li & Kirubarajan 2001, Sec. 6.5; :mod:`.closed_form`): the per-axis
position and velocity error standard deviations at six tracking indices, printed to four significant figures
(:mod:`.text`).  The pipeline -- the simulation and Monte Carlo streams, the repository's Kalman filter and cubature
Kalman filter, the metrics with their standard errors, the verdict rule, the reading space and the notebook --
must give "reproduced" for every cell, and must not reproduce the cells perturbed by ±10 % (the rule's "qualitatively
reproduced": beyond 3 sigma, within 25 %) or +50 % ("not reproduced").  :mod:`.control` computes what the controls
conclude (the ``controls`` section) and the power of the rule against a perturbation.

The package: :mod:`.closed_form`, :mod:`.text`, :mod:`.setup`, :mod:`.study`, :mod:`.control`.  ``kind="control"``:
no arena entry, and no part in pooled tallies of papers.
"""
from __future__ import annotations

from mmlib.experiment.paper import Paper
from mmlib.papers.controls import setup, study, text

__all__ = [
    "PAPER"
]

PAPER = Paper(
    name=text.NAME, title=text.TITLE, citation=text.CITATION, doi=text.DOI, root_seed=text.ROOT_SEED,
    n_runs=None, setup_type=setup.Setup, deviations=text.DEVIATIONS, space=text.SPACE, published=text.PUBLISHED,
    algorithms=text.ALGORITHMS, key_effect=text.KEY_EFFECT, setup=setup.setup, scenario=setup.scenario,
    universe=study.universe, batch=setup.batch, headline_digest=study.headline_digest, notebook="controls",
    # full: 400 runs (the per-axis RMS errors to 0.3-0.6 % standard error, against the 10 % perturbation), the 2 x 2
    # reading space in full at the same runs; smoke: 100 runs (about 1.2 %), the full factorial too
    profiles={"full": {"n_runs": 400, "mv_runs": 400, "mv_design": "full"},
              "smoke": {"n_runs": 100, "mv_runs": 100, "mv_design": "full"}},
    arena=None, kind="control")
