"""Liu & Wu 2017, "Strong Tracking Spherical Simplex-Radial Cubature Kalman Filter for
Maneuvering Target Tracking", Sensors 17(4):741, doi:10.3390/s17040741 -- Section 4.

Constant-acceleration target (Eqs. 37-39) seen by a range-bearing radar at the
origin (Eq. 40); SSRCKF, STF (EKF-based), STUKF, STCKF and STSSRCKF compared by
RMSE (Eq. 41) and accumulative RMSE (Eq. 42).

The paper's ambiguities are the factors of :data:`text.SPACE` (a reading space, see
:mod:`mmlib.experiment.readings`); a *reading* (factor id -> option) gives the three
simulations of Section 4.2, Example 1 and Example 2's two cases (:func:`setup.for_reading`,
the contract's ``setup``), their Monte Carlo evaluation (:func:`study.evaluate_reading`)
and the universe's numbers, claims and effects (:func:`study.summarise`).  The notebook's
headline rows and claim verdicts are these same functions applied to the headline
reading; the multiverse job is :func:`study.universe`.

The package: :mod:`.text` (tables as printed, deviations, reading space, published
numbers), :mod:`.setup` (set-ups, models, filters, batches, the arena scenario),
:mod:`.claims` (the claims' verdicts), :mod:`.study` (one universe), :mod:`.table2`
(Table 2's complexity and time) and :mod:`.diagnostics` (what only the notebook shows).
"""
from __future__ import annotations

from mmlib.experiment.paper import ArenaEntry, Paper
from mmlib.papers.liu2017 import setup, study, text

__all__ = [
    "PAPER"
]

PAPER = Paper(
    name=text.NAME, title=text.TITLE, citation=text.CITATION, doi=text.DOI, root_seed=text.ROOT_SEED,
    n_runs=text.N_RUNS, setup_type=setup.Examples, deviations=text.DEVIATIONS, space=text.SPACE,
    published=text.PUBLISHED, algorithms=text.ALGORITHMS, key_effect=text.KEY_EFFECT,
    setup=setup.for_reading, scenario=setup.scenario, universe=study.universe, batch=setup.batch,
    headline_digest=study.headline_digest, notebook="liu2017_stssrckf",
    # full: the paper's 200 runs, and the multiverse's uniform sample of 60 universes at 200 runs each;
    # smoke: the headline and each option alone at the smoke run count
    profiles={"full": dict(n_runs=text.N_RUNS, timing_runs=5, timing_repeats=5, mv_runs=text.N_RUNS,
                           mv_design="auto"),
              "smoke": dict(n_runs=20, timing_runs=2, timing_repeats=2, mv_runs=20, mv_design="star")},
    # what the arena runs on this paper's scenario, the ideas it contributes and its central claim there
    arena=ArenaEntry(
        algorithms=("SSRCKF", "STF", "STUKF", "STCKF", "STSSRCKF", "CKF", "UKF"),
        ideas=(("spherical simplex-radial rule", "SSRCKF", "CKF"),
               ("strong tracking (simplex-radial CKF)", "STSSRCKF", "SSRCKF"),
               ("strong tracking (UKF)", "STUKF", "UKF"),
               ("strong tracking (EKF: STF)", "STF", "EKF")),
        claim="STSSRCKF is more accurate than SSRCKF, STUKF and STCKF",
        claim_pairs=(("STSSRCKF", "SSRCKF"), ("STSSRCKF", "STUKF"), ("STSSRCKF", "STCKF"))))
