"""Zhou, Zhao, Huang & Zhao 2017, "A Cubature-Principle-Assisted IMM-Adaptive UKF Algorithm
for Maneuvering Target Tracking Caused by Sensor Faults", Applied Sciences (MDPI) 7(10):1003, 2017.

Section 2.3 (Table 1, Fig. 2), Section 4.1 (Case 1: IMM vs CPIMM; Case 2, sensor faults:
IMM-UKF, IMM-NAUKF, CPIMM-UKF, CPIMM-NAUKF), and a clearly labelled synthetic analogue of
the unpublished INS/GPS experiment (Section 4.2).  CPIMM is a mixing strategy of the IMM combinator
(:class:`mmlib.core.mixing.CubatureMixing`, Eqs. 13-19) and NAUKF a layer over a sigma-point filter
(:class:`mmlib.core.layers.adaptive.InnovationAdaptive`, Eqs. 27-39).

The package, behind :data:`PAPER` (:class:`mmlib.experiment.paper.Paper`):

* :mod:`.text`: Tables 1-5 as printed, the deviations (Z-1 ... Z-13), the factors and the reading space, the
  published numbers and the key effect;
* :mod:`.setup`: the :class:`~.setup.Setup` of Section 4.1, a reading's :class:`~.setup.Cases` (Case 1 without
  faults, Case 2 with them), the estimators, the Monte Carlo batches, the arena scenario (Case 2 under the per-step
  fault reading, :data:`~.setup.ARENA_FAULT_KIND`: the headline's accumulating drift is unobservable); :mod:`.faults`:
  Eq. 2's radar faults;
* :mod:`.study`: one universe (evaluation, Table 2-3 rows, claims, effects, the measurement-only baselines and the
  degenerate flag, :class:`UniverseResult`), the consistency entries, the digest; :mod:`.section23`: the analytic
  example of Section 2.3 and its claims;
* :mod:`.diagnostics`: what only the notebook shows (NEES and NIS of every algorithm, the evidence that the drift
  fault is unobservable, Tables 4-5, the synthetic analogue of Section 4.2).

Reading space (issue 10): the ambiguities are the factors ``text.FACTORS`` (ids = deviation numbers:
the noise gain Gamma Z-2, R's units Z-3, the truth's process noise Z-4, P0 Z-5, the fault model Z-6,
the UKF's parameters Z-7, NAUKF's window Z-8, NAUKF as printed or inflate-only Z-12, the filters'
process-noise intensity Z-13; Z-5, Z-8 and Z-13 are sensitivity factors, Z-6 "constant" and Z-12 "inflate-only"
options motivated by results); ``text.SPACE`` is their product (1152 universes), run as a uniform random
sample of 200 universes beside the headline and the star (:meth:`~mmlib.experiment.readings.ReadingSpace.design`).
A universe is :func:`.study.universe` = :func:`.study.summarise` of
:func:`.study.evaluate_reading`; the notebook's headline rows and claims are :func:`.study.judge_claims` of the same
evaluation of the headline reading, so the headline universe is the notebook's numbers bit for bit.
The key effect (``text.KEY_EFFECT``) is the paired time-averaged position MSE difference CPIMM-NAUKF
minus IMM-UKF in Case 2; its published counterpart is (m^2 + s^2) of Table 3's rows
(:func:`.text.published_mse_difference`).
"""
from __future__ import annotations

from mmlib.experiment.paper import ArenaEntry, Paper
from mmlib.papers.zhou2017 import setup as _setup
from mmlib.papers.zhou2017 import study as _study
from mmlib.papers.zhou2017 import text as _text

__all__ = ["PAPER"]

PAPER = Paper(name=_text.NAME, title=_text.TITLE, citation=_text.CITATION, doi=_text.DOI, root_seed=_text.ROOT_SEED,
              n_runs=_text.N_RUNS, setup_type=_setup.Cases, deviations=_text.DEVIATIONS, space=_text.SPACE,
              published=_text.PUBLISHED, algorithms=_text.ALGORITHMS, key_effect=_text.KEY_EFFECT,
              setup=_setup.setup, scenario=_setup.scenario, universe=_study.universe, batch=_setup.batch,
              headline_digest=_study.headline_digest, notebook="zhou2017_cpimm_naukf",
              # full: the paper's 100 runs for the headline and for every universe of the design (a uniform sample
              # of 200 of the 1152, text.SPACE); smoke: 20 runs
              # and the star design at the same 20 runs, so that its headline universe is the notebook's headline
              # rows bit for bit
              profiles={"full": dict(n_runs=_text.N_RUNS, mv_runs=_text.N_RUNS,
                                     mv_design="auto"),
                        "smoke": dict(n_runs=20, mv_runs=20, mv_design="star")},
    # what the arena runs on this paper's scenario, the ideas it contributes and its central claim there
    arena=ArenaEntry(
        reading=(("Z-6", _setup.ARENA_FAULT_KIND),),   # the headline's drift is degenerate (see ARENA_FAULT_KIND)
        algorithms=("IMMCKF", "IMMUKF", "IMMEKF", "IMM-NAUKF", "CPIMM-UKF", "CPIMM-NAUKF", "NAUKF", "AUKF",
                    "IMM-NAUKF[inflate-only]", "NAUKF[inflate-only]", "AUKF[inflate-only]", "EKF", "CKF", "UKF"),
        ideas=(("NAUKF innovation adaptation (IMM)", "IMM-NAUKF", "IMMUKF"),
               ("NAUKF innovation adaptation (single model)", "NAUKF", "UKF"),
               ("NAUKF against the classic adaptive UKF", "NAUKF", "AUKF"),
               ("NAUKF adaptation, inflate-only reading (IMM)", "IMM-NAUKF[inflate-only]", "IMMUKF"),
               ("NAUKF adaptation, inflate-only reading (single model)", "NAUKF[inflate-only]", "UKF"),
               ("NAUKF against AUKF, inflate-only reading", "NAUKF[inflate-only]", "AUKF[inflate-only]"),
               ("cubature-principle mixing", "CPIMM-UKF", "IMMUKF")),
        claim="CPIMM and NAUKF make the IMM more accurate (CPIMM-UKF, IMM-NAUKF and CPIMM-NAUKF beat IMM-UKF)",
        claim_pairs=(("CPIMM-UKF", "IMMUKF"), ("IMM-NAUKF", "IMMUKF"), ("CPIMM-NAUKF", "IMMUKF"))))
