"""Tseng, Chang & Jwo 2011, "Fuzzy Adaptive Interacting Multiple Model Nonlinear Filter for
Integrated Navigation Sensor Fusion", Sensors 11(2), 2090-2111, doi:10.3390/s110202090.

A *documented reconstruction*: the paper's Section 4 (simulation set-up) did not survive, only
the table of the vehicle's seven motion segments, two figure captions (13, 15) and the table of
East/North position RMS errors.  Every element of the set-up that is not in the surviving text is a
numbered deviation (T-1 ... T-15, ``text.DEVIATIONS``).

The ambiguities that move a result are the factors of ``space.SPACE`` (issue 10): T-1 speed, T-4
pseudorange noise, T-5 the receiver clock, T-7 the IMM's levels, T-8 the single UKF's level, T-9 the
IMM's Markov chain, T-10a/b the FLAS's input normalisation and breakpoints, T-11 the DOD window.  Only T-10a is a
``reading`` factor; the others sweep values the lost section leaves us to invent (``sensitivity`` factors, issue 24;
the reasons are in ``space``), and T-9's option 0.95 is motivated by another paper (Hu et al. 2017).
``study.universe(reading, n_runs, seed)`` is the multiverse job; the notebook's headline rows and claims are
``study.table_rows`` and ``study.judge_claims`` of ``study.evaluate_reading`` on the headline reading, the same
functions.  Held fixed (not factors), each with its reason in its deviation: T-2, T-3, T-6 (the UKF equals the
EKF to 1e-6 m here, so its spread parameters cannot matter), T-9's initial mode probabilities and T-12
(measured: neither moves any value by as much as one standard error, ``space.NON_INFLUENTIAL``), T-13 and T-15.

The fuzzy logic adaptive system (FLAS) and the IMM it drives are a core layer,
:mod:`mmlib.core.layers.fuzzy_noise`; this package holds the paper's reading of them (breakpoints, levels,
normalisation, window: the fields of ``setup.Setup``).

Because the set-up is a reconstruction, ``PAPER.qualifier`` is :data:`mmlib.experiment.verdicts.RECONSTRUCTION`:
a claim's verdict says what our reconstruction shows ("contradicted by the reconstruction", "holds in the
reconstruction"), never what the paper's own set-up would, and it is kept out of pooled tallies (issue 24).

The package: ``text`` (the surviving tables, deviations, published numbers, effects), ``space`` (factors, reading
space, the held-fixed changes), ``setup`` (the set-up of a reading and its filters), ``simulation`` (trajectory,
sky, Monte Carlo batch, arena scenario), ``baseline`` (the single-epoch least-squares fix, the no-information
baseline of a degenerate universe), ``study`` (one universe: evaluation, values, rows, claims, effects, degenerate
flag, summary, digest) and ``diagnostics`` (the notebook's UKF/EKF coincidence, clairvoyant schedules, consistency
and claims in the reconstruction's words); ``PAPER`` is its :class:`~mmlib.experiment.paper.Paper`.
"""
from __future__ import annotations

from mmlib.experiment import verdicts
from mmlib.experiment.paper import ArenaEntry, Paper
from mmlib.papers.tseng2011 import setup, simulation, space, study, text

PAPER = Paper(
    name=text.NAME, title=text.TITLE, citation=text.CITATION, doi=text.DOI, root_seed=text.ROOT_SEED,
    n_runs=None, setup_type=setup.Setup, deviations=text.DEVIATIONS, space=space.SPACE,
    published=text.PUBLISHED, algorithms=text.ALGORITHMS, key_effect=text.KEY_EFFECT, setup=setup.setup,
    scenario=simulation.scenario, universe=study.universe, batch=simulation.batch,
    headline_digest=study.headline_digest, notebook="tseng2011_fuzzy_immukf",
    # Section 4 is lost and speed, sigma_pr, clock, Q levels and p_ii are invented (T-1 ... T-15): every claim verdict
    # is a verdict on the reconstruction ("contradicted by the reconstruction"), kept out of pooled tallies
    qualifier=verdicts.RECONSTRUCTION,
    # full: the headline at 100 runs (the paper's count is not known, T-13), the oracle reference at 50, the
    # multiverse's uniform sample of 60 universes at 25 runs each (standard errors are shown throughout);
    # the run-count stability check reruns the headline and 3 sampled universes at 100 runs (about 1.5 core-min;
    # 8 would take about 3.4);
    # smoke: a prefix of the same runs and the star design at the smoke run count, so its headline universe is
    # the notebook's headline bit for bit
    profiles={"full": dict(n_runs=text.HEADLINE_RUNS, oracle_runs=50, mv_runs=25,
                           mv_design="auto", stability_universes=3),
              "smoke": dict(n_runs=6, oracle_runs=6, mv_runs=6, mv_design="star")},
    # what the arena runs on this paper's scenario, the ideas it contributes and its central claim there
    arena=ArenaEntry(
        algorithms=("IMMUKF", "EKF", "UKF", "FUZZY-IMMUKF"),
        ideas=(("fuzzy-adapted process noise", "FUZZY-IMMUKF", "IMMUKF"),),
        claim="FUZZY-IMMUKF is more accurate than IMMUKF, and IMMUKF than the UKF",
        claim_pairs=(("FUZZY-IMMUKF", "IMMUKF"), ("IMMUKF", "UKF"))))

__all__ = ["PAPER"]
