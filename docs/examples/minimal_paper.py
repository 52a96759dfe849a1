"""A minimal worked paper behind the contract of :mod:`mmlib.experiment.paper` (``docs/new-paper.md`` walks through
it; ``tests/test_registry.py`` registers it, runs its smoke universes and renders its report).

The "paper" is a fictional note, *Doe & Roe 2026*, which tracks a constant-velocity target with a linear position
sensor and claims that its cubature Kalman filter (CKF) is more accurate than the Kalman filter (KF).  Its set-up
prints "r = 4" without a unit: a variance of 4 m^2 or a standard deviation of 4 m.  The note is not real; its
Table 1 is invented for the example, and nothing here is a finding.

Theory settles the claim before any run: on a linear-Gaussian model a third-degree rule returns the exact Kalman
moments, so the CKF and the KF coincide to round-off, whatever the reading.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from mmlib.core import models
from mmlib.core.estimation import SingleModel
from mmlib.core.filters import ExtendedKalmanFilter, SigmaPointFilter
from mmlib.core.rules import Cubature
from mmlib.experiment import digests, evaluation, metrics
from mmlib.experiment import report
from mmlib.experiment.montecarlo import MonteCarlo, Stream
from mmlib.experiment.paper import Paper, PublishedNumber, UniverseResult
from mmlib.experiment.readings import Deviation, Factor, Option, ReadingSpace
from mmlib.experiment.scenario import Scenario
from mmlib.experiment.simulate import ManeuverSchedule

NAME = "example2026"
CITATION = "J. Doe, R. Roe, A fictional note on cubature filters, Journal of Examples 1:1, 2026, doi:10.0000/example"

# -- the declared text: what the paper printed, where it is ambiguous, and the readings of it ------------------------
TABLE1 = {"KF": "2.10", "CKF": "1.60"}           # position RMSE (m) as printed
DEVIATIONS = (
    Deviation("E-1", "measurement noise", "'r = 4' (no unit)",
              "R = 4 I m^2 (a variance, headline); a standard deviation of 4 m is the other option",
              "Eq. 3 writes v ~ N(0, r), so r reads as a variance; the unit is not printed.", "factor E-1"),
)
FACTORS = (
    Factor("E-1", "measurement noise r of Eq. 3", (
        Option("variance", "R = 4 I m²", "Eq. 3: v ~ N(0, r)", {"r": 4.0}),
        Option("sd", "R = 16 I m² (r read as a standard deviation)", "Section 3: 'noise of r = 4'", {"r": 16.0})),
        "variance", "Eq. 3"),
)
SPACE = ReadingSpace(NAME, FACTORS, budget=2)
PUBLISHED = tuple(PublishedNumber("Table 1", "Table 1", alg, "RMSE position (m)", TABLE1[alg]) for alg in TABLE1)
ALGORITHMS = ("KF", "CKF")
KEY_EFFECT = "CKF − KF: position MSE (m²)"


# -- the set-up ------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Setup:
    """Section 3: T = 1 s, 50 steps, state [x m, vx m/s, y m, vy m/s], q in m²/s⁴, R = r I (m²)."""

    T: float = 1.0
    n_steps: int = 50
    x0: tuple = (0.0, 10.0, 0.0, 5.0)
    P0_diag: tuple = (25.0, 4.0, 25.0, 4.0)
    q: float = 0.5
    r: float = 4.0


def setup(reading: Mapping[str, str]) -> Setup:
    """The set-up of a reading; ValueError naming an unknown factor or option."""
    return Setup(**SPACE.changes(reading))


def _models(s: Setup):
    cv = models.constant_velocity(s.T, s.q)
    return cv, models.position_measurement([s.r, s.r]), ManeuverSchedule([cv], [], 0, s.T, s.n_steps)


def batch(s: Setup, mc: MonteCarlo) -> tuple:
    """``(make_batch, estimators)``: truth with process noise, position measurements, filters started from
    N(x0, P0) drawn on the INITIAL stream."""
    cv, meas, schedule = _models(s)
    x0, P0 = np.array(s.x0), np.diag(s.P0_diag)
    estimators = {"KF": SingleModel(ExtendedKalmanFilter(name="KF"), cv, meas, name="KF"),
                  "CKF": SingleModel(SigmaPointFilter(Cubature()), cv, meas, name="CKF")}
    sim = evaluation.simulator(mc, schedule, meas, x0, start=lambda runs: mc.gaussian(runs, Stream.INITIAL, x0, P0))
    make_batch = evaluation.with_initial_states(sim, estimators, lambda est, m0, runs: est.init(m0, P0))
    return make_batch, estimators


def scenario(s: Setup) -> Scenario:
    """The set-up as an arena scenario (one CV model, the linear sensor)."""
    cv, meas, schedule = _models(s)
    x0 = np.array(s.x0)
    return Scenario(name=NAME, title="Doe & Roe 2026 (fictional): CV target, position sensor", source=CITATION,
                    root_seed=ROOT_SEED, T=s.T, n_steps=s.n_steps, P0=np.diag(s.P0_diag), position=(0, 2),
                    velocity=(1, 3), single=cv, measurement=meas,
                    simulator=lambda mc: evaluation.simulator(mc, schedule, meas, x0))


# -- one universe ----------------------------------------------------------------------------------------------------
def evaluate_reading(reading: Mapping[str, str], mc: MonteCarlo) -> dict:
    """``{algorithm: RunSet}`` under ``reading`` on the runs of ``mc`` (common random numbers)."""
    make_batch, estimators = batch(setup(reading), mc)
    return evaluation.evaluate(estimators, make_batch, mc, progress=False)


def summarise(results: dict, n_runs: int) -> UniverseResult:
    """Table 1's values (position RMSE over x and y, Eq. 5), the claim and the key effect."""
    values = []
    for alg in ALGORITHMS:
        se = results[alg].errors[..., [0, 2]] ** 2
        v = metrics.rmse_time_averaged(np.sqrt(se.sum(axis=-1)), results[alg].valid)
        values.append(("Table 1", alg, "RMSE position (m)", v.value, v.stderr))
    claims = report.Claims()
    claims.add("the CKF is more accurate than the KF",
               *evaluation.better_claim(results, "CKF", "KF", [("position", (0, 2))]), key="ckf_vs_kf")
    d = evaluation.paired_mse_difference(results["CKF"], results["KF"], (0, 2))
    published = float(TABLE1["CKF"]) ** 2 - float(TABLE1["KF"]) ** 2
    return UniverseResult.build(values=values, claims=claims, effects=[(KEY_EFFECT, d.value, d.stderr, published)],
                                diverged={a: int((~rs.valid).sum()) for a, rs in results.items()}, n_runs=n_runs)


def universe(reading: Mapping[str, str], n_runs: int, seed: int) -> UniverseResult:
    """The multiverse job: one reading, ``n_runs`` runs on root seed ``seed``."""
    return summarise(evaluate_reading(reading, MonteCarlo(seed, n_runs)), n_runs)


def headline_digest(n_runs: int) -> dict:
    """The run digest of the headline's first ``n_runs`` runs."""
    return digests.run_digest(evaluate_reading(SPACE.headline, MonteCarlo(ROOT_SEED, n_runs)), n_runs)


ROOT_SEED = 20260101
PAPER = Paper(name=NAME, title="Doe & Roe 2026 (a fictional worked example)", citation=CITATION,
              doi="10.0000/example", root_seed=ROOT_SEED, n_runs=100, setup_type=Setup, deviations=DEVIATIONS,
              space=SPACE, published=PUBLISHED, algorithms=ALGORITHMS, key_effect=KEY_EFFECT, setup=setup,
              scenario=scenario, universe=universe, batch=batch, headline_digest=headline_digest,
              notebook="example2026", profiles={"full": {"n_runs": 100, "mv_runs": 100, "mv_design": "full"},
                                               "smoke": {"n_runs": 20, "mv_runs": 20, "mv_design": "star"}})
