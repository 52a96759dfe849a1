"""The controls' set-up: the DWNA target and position sensor of each tracking index (:func:`build`), the Monte Carlo
batch of one case (:func:`make_batch_fn`, the contract's ``batch``) and the scenario of the headline case.

State ``[x, vx, y, vy]`` (m, m/s); the two axes are independent copies of the per-axis model of
:mod:`.closed_form`.  The estimators are the Kalman filter (``mmlib.core.filters.ExtendedKalmanFilter``, which on a
linear model is the Kalman filter) and the cubature Kalman filter (``SigmaPointFilter(Cubature())``), both given the
true model: the closed form is the steady state of exactly this filter.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from mmlib.core import models
from mmlib.core.estimation import SingleModel
from mmlib.core.filters import ExtendedKalmanFilter, SigmaPointFilter
from mmlib.core.rules import Cubature
from mmlib.experiment import evaluation
from mmlib.experiment.montecarlo import MonteCarlo, Stream
from mmlib.experiment.scenario import Scenario
from mmlib.experiment.simulate import ManeuverSchedule
from mmlib.papers.controls import closed_form, text

__all__ = [
    "setup", "Setup", "build", "scenario", "batch", "make_batch_fn", "case_seed", "STARTS"
]

STARTS = ("steady", "two-point")


@dataclass(frozen=True)
class Setup:
    """The controls' set-up under one reading; defaults are the headline reading.

    ``T`` (s), ``sigma_w`` (m), ``lambdas`` the tracking indices (one case each), ``x0`` the true initial state
    [m, m/s, m, m/s]; ``start`` "steady" (the filter starts at the closed-form steady state) or "two-point" (at the
    two-point differencing covariance); ``n_steps`` the steps simulated, of which the first ``burn_in`` are left out
    of the averages; ``report`` which filter's errors fill the table ("KF" or "CKF", factor C-1)."""

    T: float = text.T
    sigma_w: float = text.SIGMA_W
    lambdas: tuple = text.LAMBDAS
    x0: tuple = (0.0, 10.0, 0.0, -5.0)
    start: str = "steady"
    burn_in: int = 0
    n_steps: int = 200
    report: str = "KF"

    def __post_init__(self):
        if self.start not in STARTS:
            raise ValueError(f"start: expected one of {STARTS}, got {self.start!r}")
        if self.report not in text.ALGORITHMS:
            raise ValueError(f"report: expected one of {text.ALGORITHMS}, got {self.report!r}")
        if not (isinstance(self.burn_in, int) and isinstance(self.n_steps, int) and 0 <= self.burn_in < self.n_steps):
            raise ValueError(f"burn_in: expected an integer in [0, n_steps = {self.n_steps}), got {self.burn_in!r}")
        if not self.lambdas or not all(float(lam) > 0 for lam in self.lambdas):
            raise ValueError(f"lambdas: expected positive tracking indices, got {self.lambdas!r}")

    @property
    def window(self) -> slice:
        """The steps averaged: the ``n_steps - burn_in`` after the burn-in (indices into the error arrays)."""
        return slice(self.burn_in, self.n_steps)

    def initial_covariance(self, lam: float) -> np.ndarray:
        """P0 (4, 4) of case ``lam``: the closed-form updated steady state per axis ("steady") or the two-point
        differencing covariance ("two-point"), the same on x and y."""
        P1 = (closed_form.steady_state(lam, self.T, self.sigma_w).P if self.start == "steady"
              else closed_form.two_point_covariance(self.T, self.sigma_w))
        return np.kron(np.eye(2), P1)


def setup(reading: Mapping[str, str]) -> Setup:
    """The contract's ``setup(reading)``: ValueError names an unknown factor or option."""
    return Setup(**text.SPACE.changes(reading))


def case_seed(root_seed: int, case: int) -> int:
    """The root seed of case ``case`` (its index in ``Setup.lambdas``): the first 32 bits of
    ``numpy.random.SeedSequence([root_seed, case])``; each case has its own streams, so the table's cells are
    independent (deviation C-3), and a case's runs are the same in every profile."""
    return int(np.random.SeedSequence([int(root_seed), int(case)]).generate_state(1)[0])


def build(s: Setup, lam: float) -> tuple:
    """``(dynamics, sensor, schedule, estimators)`` of case ``lam``: the DWNA model with acceleration variance
    sigma_v^2 = (lam sigma_w / T^2)^2 per axis (``models.constant_velocity``), the position sensor R = sigma_w^2 I,
    the schedule of ``n_steps`` steps and the KF and CKF on the true model."""
    sv = closed_form.acceleration_sd(lam, s.T, s.sigma_w)
    cv = models.constant_velocity(s.T, sv * sv)
    sensor = models.position_measurement([s.sigma_w ** 2, s.sigma_w ** 2])
    schedule = ManeuverSchedule([cv], [], 0, s.T, s.n_steps)
    estimators = {"KF": SingleModel(ExtendedKalmanFilter(name="KF"), cv, sensor, name="KF"),
                  "CKF": SingleModel(SigmaPointFilter(Cubature(), name="CKF"), cv, sensor, name="CKF")}
    return cv, sensor, schedule, estimators


def make_batch_fn(s: Setup, case: int, mc: MonteCarlo) -> tuple:
    """``(make_batch, estimators, case_mc)`` of case ``case`` (index into ``s.lambdas``) on the runs of ``mc``: the
    truth with process noise from x0, the position measurements, and every filter started from x̂0 ~ N(x0, P0) (drawn
    on the run's INITIAL stream) with covariance P0 (:meth:`Setup.initial_covariance`), all on the case's own root
    seed (:func:`case_seed`)."""
    lam = s.lambdas[case]
    _, sensor, schedule, estimators = build(s, lam)
    cmc = MonteCarlo(case_seed(mc.root_seed, case), mc.n_runs)
    x0, P0 = np.array(s.x0), s.initial_covariance(lam)
    sim = evaluation.simulator(cmc, schedule, sensor, x0, start=lambda runs: cmc.gaussian(runs, Stream.INITIAL, x0, P0))
    make_batch = evaluation.with_initial_states(sim, estimators, lambda est, m0, runs: est.init(m0, P0))
    return make_batch, estimators, cmc


def batch(s: Setup, mc: MonteCarlo) -> tuple:
    """The contract's ``batch``: ``(make_batch, estimators)`` of the headline case (lambda = 1) on the runs of
    ``mc``."""
    if not isinstance(s, Setup):
        raise ValueError(f"s: expected the controls' Setup (PAPER.setup), got {s!r}")
    make_batch, estimators, _ = make_batch_fn(s, text.HEADLINE_CASE, mc)
    return make_batch, estimators


def scenario(s: Setup) -> Scenario:
    """The headline case as a scenario (the contract asks every study for one; a control takes no part in the arena,
    ``Paper.arena`` is None)."""
    if not isinstance(s, Setup):
        raise ValueError(f"s: expected the controls' Setup (PAPER.setup), got {s!r}")
    lam = s.lambdas[text.HEADLINE_CASE]
    cv, sensor, schedule, _ = build(s, lam)
    x0, P0 = np.array(s.x0), s.initial_covariance(lam)
    return Scenario(name=text.NAME, title=f"Control: DWNA target, position sensor, tracking index {lam:g}",
                    source=text.CITATION, root_seed=text.ROOT_SEED, T=s.T, n_steps=s.n_steps, P0=P0,
                    position=(0, 2), velocity=(1, 3), single=cv, measurement=sensor,
                    simulator=lambda mc: evaluation.simulator(
                        mc, schedule, sensor, x0, start=lambda runs: mc.gaussian(runs, Stream.INITIAL, x0, P0)),
                    notes={"arena": "a control of the pipeline: not an arena scenario (Paper.kind 'control')"})
