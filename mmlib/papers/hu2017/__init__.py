"""Hu, Zhang, Fu & Li 2017, "Maneuvering target tracking algorithm based on CDKF in
observation bootstrapping strategy", High Technology Letters 23(2),
doi:10.3772/j.issn.1006-6748.2017.02.005 -- Section 3.

Two coordinated-turn modes (+0.3 and -0.15 rad/s), a two-coordinate radar, 35
steps; IMMUKF, IMMEKF, IMMCKF, IMMCDKF and IMMCDKF-OBS.  Units: km, km/s, rad.

The package behind :data:`PAPER` (the contract of :mod:`mmlib.experiment.paper`):

* :mod:`.text`: Table 1 as printed, the deviations H-1 ... H-14 and the reading space;
* :mod:`.setup`: the :class:`~.setup.Setup` of a reading, the truth, radar and the five IMMs, the Monte Carlo
  batch, the arena scenario (in SI units);
* :mod:`.study`: one universe (evaluation, Table 1's values, claims, effects) and the headline's digest;
* :mod:`.timing` and :mod:`.diagnostics`: what only the notebook shows (Table 1's time ratios and timing claims;
  the truth's plausibility, the coincidence of the filters, the influence of each factor).
"""
from __future__ import annotations

from mmlib.experiment.paper import ArenaEntry, Paper
from mmlib.papers.hu2017 import setup, study, text

__all__ = [
    "PAPER"
]

PAPER = Paper(
    name=text.NAME, title="Hu et al. 2017: IMM with a central difference KF and bootstrapped observations",
    citation=text.CITATION, doi=text.DOI, root_seed=text.ROOT_SEED, n_runs=text.N_RUNS,
    setup_type=setup.Setup, deviations=text.DEVIATIONS, space=text.SPACE, published=text.PUBLISHED,
    algorithms=text.ALGORITHMS, key_effect=study.KEY_EFFECT, setup=setup.setup, scenario=setup.scenario,
    universe=study.universe, batch=setup.batch, headline_digest=study.headline_digest,
    notebook="hu2017_immcdkf_obs",
    # full: the paper's 100 runs, also in each of the multiverse's universes (a uniform sample of 400, text.SPACE);
    # smoke: 20 runs, the star design (headline + each option alone) at the same 20 runs, so that the smoke headline
    # universe equals the smoke headline rows bit for bit.
    profiles={"full": dict(n_runs=text.N_RUNS, timing_runs=20, timing_repeats=8, mv_runs=text.N_RUNS,
                           mv_design="auto"),
              "smoke": dict(n_runs=20, timing_runs=2, timing_repeats=3, mv_runs=20, mv_design="star")},
    # what the arena runs on this paper's scenario, the ideas it contributes and its central claim there
    arena=ArenaEntry(
        algorithms=("IMMCKF", "IMMUKF", "IMMEKF", "IMMCDKF", "IMMCDKF-OBS"),
        ideas=(("central differences", "IMMCDKF", "IMMUKF"),
               ("observation bootstrapping", "IMMCDKF-OBS", "IMMCDKF")),
        claim="IMMCDKF-OBS is more accurate than IMMCDKF, IMMUKF and IMMEKF",
        claim_pairs=(("IMMCDKF-OBS", "IMMCDKF"), ("IMMCDKF-OBS", "IMMUKF"), ("IMMCDKF-OBS", "IMMEKF"))))
