"""Zhu, Wang & Yuan 2016, "An Improved Interacting Multiple Model Filtering
Algorithm Based on the Cubature Kalman Filter for Maneuvering Target
Tracking", Sensors 16(6), 805, doi:10.3390/s16060805 -- Section 4 set-up.

Key structural fact (derived in the notebook and tested): the paper's models
are all linear -- constant velocity and coordinated turns with *known* turn
rate (Eq. 61) observed through a linear position sensor (Eq. 62).  Every
sigma-point rule that integrates degree-2 polynomials exactly (UKF, CKF,
5th-degree CKF) then returns the exact Kalman moments, so IMM5CKF, IMMCKF and
IMMUKF are the same algorithm as IMM-KF, up to round-off.  Every reading with the position sensor keeps the
models linear, so the identity holds in each of those universes (tested on the star design), and the claims
comparing them have parts *identical (to round-off)* and the verdict *not supported* (:func:`.study.judge_claims`).
Only Z-5's range-bearing readings (r = diag(20, 0.1) read as a radar's range and bearing variances, the bearing in
rad² or deg²) make the measurement nonlinear: the only readings under which the abstract's claim that IMM5CKF is
more accurate than IMMCKF and IMMUKF can be judged on a difference.

Reading space (issue 10): ``text.FACTORS`` are the ambiguities that can move a result
(deviations Z-5, Z-6, Z-7, Z-8, Z-9, Z-10, Z-12; the others say in ``text.DEVIATIONS`` why
they cannot), ``text.SPACE`` their full factorial product (2^5 x 3 x 4 = 384 universes),
``text.PUBLISHED`` the 16 Monte Carlo cells of Table 1 a universe replicates, and
``study.universe(reading, n_runs, seed)`` the job run for every universe by
:func:`mmlib.experiment.run_multiverse`; the notebook's headline rows and claims come
from the same ``evaluate_reading`` / ``table1_rows`` / ``judge_claims`` / ``summarise``.

The package: ``text`` (Table 1 as printed, deviations, factors, reading space), ``setup`` (the set-up of a
reading, its models, simulator, batch and arena scenario), ``study`` (one universe: evaluation, rows, claims,
effects, summary, degenerate flag, digest), ``timing`` (Table 1's run-time column, Z-15) and ``diagnostics`` (the
notebook's closed-form floor check, the floor across the reading space, the filters' consistency and the claims
under each sensor of Z-5); ``PAPER`` is its
:class:`~mmlib.experiment.paper.Paper`.
"""
from __future__ import annotations

from mmlib.experiment.paper import ArenaEntry, Paper
from mmlib.papers.zhu2016 import setup, study, text

PAPER = Paper(
    name=text.NAME, title=text.TITLE, citation=text.CITATION, doi=text.DOI, root_seed=text.ROOT_SEED,
    n_runs=text.N_RUNS, setup_type=setup.Setup, deviations=text.DEVIATIONS, space=text.SPACE,
    published=text.PUBLISHED, algorithms=text.MV_ALGORITHMS, key_effect=study.KEY_EFFECT,
    setup=setup.setup, scenario=setup.scenario, universe=study.universe, batch=setup.batch,
    headline_digest=study.headline_digest, notebook="zhu2016_imm5ckf",
    # full: the headline and the full factorial (384 universes) at the paper's 100 runs, so that the headline
    # universe is the headline rows bit for bit, with 30 interleaved repeats of the run-time measurement (context);
    # smoke: a prefix of the same runs, and the star design (headline + each option alone) at the smoke run count,
    # so that the smoke headline universe equals the smoke headline rows bit for bit, with 3 timing repeats
    profiles={"full": dict(n_runs=text.N_RUNS, timing_runs=10, timing_repeats=30, mv_runs=text.N_RUNS,
                           mv_design="auto"),
              "smoke": dict(n_runs=20, timing_runs=2, timing_repeats=3, mv_runs=20, mv_design="star")},
    # what the arena runs on this paper's scenario, the ideas it contributes and its central claim there
    arena=ArenaEntry(
        algorithms=("IMM5CKF", "IMMCKF", "IMMUKF", "5CKF"),
        ideas=(("fifth-degree cubature rule", "IMM5CKF", "IMMCKF"),
               ("fifth-degree rule against the unscented", "IMM5CKF", "IMMUKF"),
               ("fifth-degree rule, single model", "5CKF", "CKF")),
        claim="IMM5CKF is more accurate than IMMCKF and IMMUKF",
        claim_pairs=(("IMM5CKF", "IMMCKF"), ("IMM5CKF", "IMMUKF"))))

__all__ = ["PAPER"]
