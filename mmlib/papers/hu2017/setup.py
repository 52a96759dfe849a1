"""Hu et al. 2017, Section 3: the set-up of a reading, the truth and radar, the five IMMs, the Monte Carlo batch
and the arena scenario.

State [x, vx, y, vy] in km and km/s (the paper's unit; :func:`in_metres` converts at the arena's boundary),
T = 1 s, 35 steps; two coordinated-turn modes (+0.3 and -0.15 rad/s) with the printed noise gain Gamma (H-3), a
range-bearing radar at the origin (H-2).  The five estimators are IMMs over the same two modes: UKF, EKF, CKF, the
central-difference KF (Eqs. 10-17, in the form of H-1) and the CDKF fed N bootstrapped observations (Sec. 2.2,
Eqs. 18-23: :class:`mmlib.core.layers.bootstrap.ObservationBootstrap`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable, Iterable, Mapping

import numpy as np

from mmlib.core import models
from mmlib.core.estimation import IMM
from mmlib.core.filters import ExtendedKalmanFilter, SigmaPointFilter
from mmlib.core.layers.bootstrap import ObservationBootstrap
from mmlib.core.protocols import MeasurementModel
from mmlib.core.rules import CentralDifference, Cubature, Unscented
from mmlib.experiment import evaluation
from mmlib.experiment.montecarlo import MonteCarlo
from mmlib.experiment.scenario import Scenario
from mmlib.experiment.simulate import ManeuverSchedule
from mmlib.papers.hu2017.text import CITATION, NAME, RMSE_METRICS, ROOT_SEED, SPACE

__all__ = [
    "setup", "Setup", "build", "scenario", "batch", "simulator", "truth_and_radar", "in_metres", "KM"
]


@dataclass(frozen=True)
class Setup:
    """Section 3 parameters; defaults are the headline reading (see :data:`~mmlib.papers.hu2017.text.DEVIATIONS`
    and :data:`~mmlib.papers.hu2017.text.FACTORS`).

    ``q`` is the truth's process-noise variance per mode (km^2/s^4); ``q_filter`` the variance
    the filters' mode models assume (Eq. 7), ``None`` meaning the truth's (H-14)."""

    T: float = 1.0
    n_steps: int = 35
    omegas: tuple = (0.3, -0.15)                     # rad/s, modes 1 and 2
    mode2_steps: tuple = (11, 25)                    # steps k using F2 (state equation) (H-5)
    q: tuple = (0.2e-6, 0.4e-6)                      # truth's process-noise variances: 0.2, 0.4 m^2/s^4 in km (H-4)
    q_filter: tuple | None = None                    # filters' variances (km^2/s^4); None = the truth's (H-14)
    x0: tuple = (8.0, 0.4, 6.0, 0.2)                 # km, km/s
    sigma_r: float = 0.1                             # km
    sigma_theta_deg: float = 0.1                     # deg
    P0_sd: tuple = (0.1, 0.02, 0.1, 0.02)            # km, km/s (H-9)
    mode_probabilities0: tuple = (0.5, 0.5)          # (H-9)
    transition: tuple = ((0.95, 0.05), (0.05, 0.95))
    truth_process_noise: bool = True                 # (H-13)
    n_boot: int = 2
    boot_variance_factor: float = 2.0                # (H-6)
    obs_likelihood: str = "sum"                      # (H-7)
    obs_covariance: str = "kalman"                   # Eq. 20 with P_zz^n; "printed": with P_zz (H-8)
    ukf: tuple = (1.0, 0.0, -1.0)                    # alpha, beta, kappa = 3 - n (H-10)
    cd_form: str = "weighted"                        # as printed, Eqs. 7, 10, 11 (H-1)
    rmse_metric: str = "mean_over_steps"             # Table 1's "mean of RMSE" (H-11)

    def __post_init__(self):
        a, b = self.mode2_steps
        if not 1 <= a <= b <= self.n_steps:
            raise ValueError(f"mode2_steps: expected 1 <= first <= last <= {self.n_steps}, got {self.mode2_steps}")
        if len(self.q) != len(self.omegas) or any(not v > 0 for v in self.q):
            raise ValueError(f"q: expected {len(self.omegas)} process-noise variances > 0, got {self.q}")
        if self.q_filter is not None and (len(self.q_filter) != len(self.omegas)
                                          or any(not (isinstance(v, (int, float)) and v > 0) for v in self.q_filter)):
            raise ValueError(f"q_filter: expected None (the truth's q) or {len(self.omegas)} variances > 0, "
                             f"got {self.q_filter!r}")
        if self.obs_covariance not in ("kalman", "printed"):
            raise ValueError(f"obs_covariance: expected 'kalman' or 'printed' (Eq. 20), got {self.obs_covariance!r}")
        if self.rmse_metric not in RMSE_METRICS:
            raise ValueError(f"rmse_metric: expected one of {RMSE_METRICS}, got {self.rmse_metric!r}")
        if not isinstance(self.truth_process_noise, bool):
            raise ValueError(f"truth_process_noise: expected True or False, got {self.truth_process_noise!r}")

    @property
    def filter_q(self) -> tuple:
        """The process-noise variances the filters assume (km^2/s^4)."""
        return self.q if self.q_filter is None else tuple(self.q_filter)


def setup(reading: Mapping[str, str]) -> Setup:
    """The Setup of a reading (ValueError naming an unknown or missing factor/option)."""
    return Setup(**SPACE.changes(reading))


def _gamma(T: float) -> np.ndarray:
    """Gamma as printed (H-3), (4, 2)."""
    return np.array([[0.0, T / 2], [0.0, T], [T / 2, 0.0], [T, 0.0]])


def truth_and_radar(setup: Setup) -> tuple:
    """``(schedule, radar)``: the truth's :class:`ManeuverSchedule` (the two turn modes with the truth's ``q``, mode
    2 at the steps ``mode2_steps``, H-5) and the range-bearing radar (variances: ``sigma_r`` squared in km², and
    ``sigma_theta_deg`` in radians, squared, in rad²)."""
    T = setup.T
    truth_modes = [models.coordinated_turn(T, w, q, _gamma(T)) for w, q in zip(setup.omegas, setup.q)]
    radar = models.range_bearing(np.diag([setup.sigma_r ** 2, math.radians(setup.sigma_theta_deg) ** 2]))
    a, b = setup.mode2_steps
    return ManeuverSchedule(truth_modes, [((a - 1) * T, b * T, 1)], 0, T, setup.n_steps), radar


def build(setup: Setup) -> tuple:
    """Truth schedule and radar (:func:`truth_and_radar`), and the five IMM estimators (mode models with the filters'
    ``q``; Eq. 7): the CDKF (Eqs. 10-17) in the form ``cd_form`` (H-1), and observation bootstrapping over it
    (Sec. 2.2, Eqs. 18-23) with the set-up's N, variance factor, likelihood and fused covariance (H-6, H-7, H-8)."""
    schedule, radar = truth_and_radar(setup)
    modes = [models.coordinated_turn(setup.T, w, q, _gamma(setup.T)) for w, q in zip(setup.omegas, setup.filter_q)]
    cdkf = SigmaPointFilter(CentralDifference(form=setup.cd_form), name="CDKF")
    filters = {"IMMUKF": SigmaPointFilter(Unscented(*setup.ukf), name="UKF"),
               "IMMEKF": ExtendedKalmanFilter(name="EKF"),
               "IMMCKF": SigmaPointFilter(Cubature(), name="CKF"),
               "IMMCDKF": cdkf,
               "IMMCDKF-OBS": ObservationBootstrap(cdkf, n_boot=setup.n_boot,
                                                   variance_factor=setup.boot_variance_factor,
                                                   likelihood=setup.obs_likelihood, covariance=setup.obs_covariance,
                                                   name="CDKF-OBS")}
    estimators = {name: IMM(f, modes, radar, np.array(setup.transition), name=name) for name, f in filters.items()}
    return schedule, radar, estimators


def simulator(setup: Setup, schedule: ManeuverSchedule, radar: MeasurementModel) -> Callable:
    """``mc -> (runs -> (truth, measurements, start means))``: truth from x0 with the truth's process noise (H-13),
    radar measurements; the filters start at the true x0 (H-9)."""
    return lambda mc: evaluation.simulator(mc, schedule, radar, setup.x0, process_noise=setup.truth_process_noise)


def batch(setup: Setup, mc: MonteCarlo, names: Iterable[str] | None = None) -> tuple:
    """``(make_batch, estimators)`` for the runs of ``mc`` under ``setup``: ``make_batch(runs) -> (truth (B, K+1, 4)
    in km and km/s, radar measurements (B, K, 2) in km and rad, {name: initial state})``, every IMM started at the
    true x0 with P0 = diag(P0_sd)^2 and ``mode_probabilities0`` (the OBS filter with its bootstrap noise,
    :meth:`~mmlib.experiment.montecarlo.MonteCarlo.bootstrap_noise`); ``estimators`` those of :func:`build` named
    in ``names`` (all if None; ValueError naming an unknown one)."""
    schedule, radar, estimators = build(setup)
    estimators = evaluation.select(estimators, names)
    P0 = np.diag(np.square(setup.P0_sd))

    def init_state(est, m0, runs):
        extra = {}
        if isinstance(est.filter, ObservationBootstrap):     # bootstrap noise from the run's own stream
            extra = {"noise": mc.bootstrap_noise(runs, setup.n_steps, setup.n_boot, 2)}
        return est.init(m0, P0, setup.mode_probabilities0, **extra)

    make_batch = evaluation.with_initial_states(simulator(setup, schedule, radar)(mc), estimators, init_state)
    return make_batch, estimators


KM = 1000.0        #: metres per kilometre: the paper's unit of length (H-2) and the arena's SI boundary


def in_metres(setup: Setup) -> Setup:
    """The same set-up in SI units (m, m/s, m^2/s^4): lengths times 1000, variances times 1e6.  The paper's
    tables are in km, so the notebook keeps km; the arena converts here, at the paper's boundary."""
    q_filter = None if setup.q_filter is None else tuple(v * KM ** 2 for v in setup.q_filter)
    return replace(setup, x0=tuple(v * KM for v in setup.x0), sigma_r=setup.sigma_r * KM,
                   P0_sd=tuple(v * KM for v in setup.P0_sd), q=tuple(v * KM ** 2 for v in setup.q), q_filter=q_filter)


def scenario(setup: Setup) -> Scenario:
    """Section 3's set-up (in km, e.g. the headline's) as an arena scenario, converted to SI units
    (:func:`in_metres`): two coordinated-turn modes (0.3 and -0.15 rad/s) with the printed noise gain, a
    range-bearing radar.  The paper runs only IMMs: it defines no single motion model."""
    if not isinstance(setup, Setup):
        raise ValueError(f"setup: expected a hu2017 Setup (PAPER.setup(reading)), got {type(setup).__name__}")
    setup = in_metres(setup)
    schedule, radar, estimators = build(setup)
    imm = estimators["IMMCDKF"]
    return Scenario(name=NAME, title="Hu et al. 2017: two turn modes (0.3, -0.15 rad/s), range-bearing radar",
                    source=CITATION, root_seed=ROOT_SEED, T=setup.T, n_steps=setup.n_steps,
                    simulator=simulator(setup, schedule, radar), P0=np.diag(np.square(setup.P0_sd)),
                    position=(0, 2), velocity=(1, 3), modes=tuple(imm.dynamics), transition=np.array(setup.transition),
                    mode_probabilities=setup.mode_probabilities0, measurement=radar, ukf=tuple(setup.ukf),
                    properties={"measurement": "range-bearing (100 m, 0.1°)", "manoeuvre": "turns at 0.3, -0.15 rad/s",
                                "units": "converted from km"},
                    notes={"single": "the paper runs only IMMs (two coordinated-turn modes): it defines no single "
                                     "motion model"})
