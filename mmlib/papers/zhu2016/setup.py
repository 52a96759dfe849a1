"""Section 4 of Zhu, Wang & Yuan 2016 as code: the set-up of a reading, its models, its simulator and its batch.

State ``[x, vx, y, vy]`` (m, m/s), sampling interval ``T = 1`` s, 100 steps (measurements at t = 1..100 s).  Three
modes (Eq. 63's order, factor Z-6): constant velocity and coordinated turns at -3 and +3 deg/s with the turn rate
known to the filters (Eq. 61), all driven by ``Q = G q G^T`` with ``q = 10`` m^2/s^4 (Z-4); a linear position
sensor ``z = [x, y] + v``, ``v ~ N(0, diag(r))`` (Eq. 62, Z-5), or under Z-5's range-bearing readings a radar at
``sensor_xy`` measuring ``z = [sqrt(dx^2 + dy^2), atan2(dy, dx)] + v`` (m, rad; bearing residuals wrapped,
:class:`mmlib.core.models.RangeBearing`), ``v ~ N(0, diag(r))`` in (m^2, rad^2); the mode transition matrix of
Eq. 63.  The truth turns right during 20-40 s and left during 60-80 s (Z-12) and is driven by the same Q unless the
reading says it is noise-free (Z-7); the filters start from ``N(x0, P0)`` draws or from ``x0`` (Z-9) with the
initial mode probabilities of Z-8.  Under the position sensor every model is linear, so every sigma-point rule
exact to degree 2 returns the Kalman moments; under the range-bearing sensor the measurement is nonlinear, the rules
differ, and the "IMM-KF" and "clairvoyant KF" of :func:`build` linearise it (extended Kalman filter).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np

from mmlib.core import models
from mmlib.core.estimation import IMM, KnownModeSequence, SingleModel
from mmlib.core.filters import ExtendedKalmanFilter, SigmaPointFilter
from mmlib.core.protocols import MeasurementModel
from mmlib.core.rules import Cubature, FifthDegreeCubature, Unscented
from mmlib.experiment import evaluation
from mmlib.experiment.montecarlo import MonteCarlo, Stream
from mmlib.experiment.scenario import Scenario
from mmlib.experiment.simulate import ManeuverSchedule
from mmlib.papers.zhu2016 import text

__all__ = [
    "setup", "Setup", "build", "scenario", "batch", "simulator", "measurement", "MODE_ORDERS", "SENSORS"
]

#: which turn is model 2 and which is model 3 of Eq. 63 (Z-6)
MODE_ORDERS = ("right-left", "left-right")
#: what the sensor of Eq. 62 measures (Z-5): the position (as printed) or range and bearing
SENSORS = ("position", "range-bearing")


@dataclass(frozen=True)
class Setup:
    """Section 4 parameters; defaults are the headline reading (see ``text.DEVIATIONS``)."""

    T: float = 1.0                                   # s
    n_steps: int = 100                               # simTime = 100 s
    x0: tuple = (1000.0, 200.0, 1000.0, 200.0)       # [x m, vx m/s, y m, vy m/s]
    P0_diag: tuple = (1000.0, 10.0, 1000.0, 10.0)
    q: float = 10.0                                  # q = diag(10, 10), m^2/s^4   (Z-4)
    r: tuple = (20.0, 0.1)                           # r = diag(20, 0.1): m^2 (position) or (m^2, rad^2) (Z-5)
    sensor: str = "position"                         # "position" (Eq. 62) or "range-bearing" (Z-5)
    sensor_xy: tuple = (0.0, 0.0)                    # the range-bearing sensor's (x, y), m: the origin (Z-5)
    turn_rate_deg: float = 3.0                       # deg/s (Z-6)
    right_turn: tuple = (20.0, 40.0)                 # s
    left_turn: tuple = (60.0, 80.0)                  # s
    transition: tuple = ((0.9, 0.05, 0.05), (0.1, 0.8, 0.1), (0.05, 0.15, 0.8))   # Eq. 63
    mode_probabilities0: tuple = (1 / 3, 1 / 3, 1 / 3)                           # (Z-8)
    truth_process_noise: bool = True                 # (Z-7)
    initial_estimate: str = "sampled"                # "sampled" from N(x0, P0), or "true" (Z-9)
    single_model: str = "CV"                         # the 5CKF's one model (Z-10)
    ukf: tuple = (1.0, 2.0, 0.0)                     # alpha, beta, kappa (Z-11)
    mode_order: str = "right-left"                   # model 2 = right turn, model 3 = left turn (Z-6)

    def __post_init__(self):
        if self.mode_order not in MODE_ORDERS:
            raise ValueError(f"mode_order: expected one of {MODE_ORDERS}, got {self.mode_order!r}")
        if self.initial_estimate not in ("sampled", "true"):
            raise ValueError(f"initial_estimate: expected 'sampled' or 'true', got {self.initial_estimate!r}")
        if self.sensor not in SENSORS:
            raise ValueError(f"sensor: expected one of {SENSORS}, got {self.sensor!r}")
        if self.single_model not in ("CV", "CT-right", "CT-left"):
            raise ValueError(f"single_model: expected 'CV', 'CT-right' or 'CT-left', got {self.single_model!r}")


def setup(reading: Mapping) -> Setup:
    """The Setup of a reading (``factor id -> option name``): the headline Setup with the reading's
    option changes; ValueError naming an unknown factor/option or a left-out factor."""
    return Setup(**text.SPACE.changes(reading))


def measurement(setup: Setup) -> MeasurementModel:
    """The sensor of a set-up (Z-5): the linear position sensor of Eq. 62 with ``R = diag(r)`` (m^2), or a
    range-bearing radar at ``sensor_xy`` (m) with ``R = diag(r)`` (m^2, rad^2), its bearing residuals wrapped to
    (-pi, pi] (:func:`mmlib.core.models.range_bearing`)."""
    if setup.sensor == "position":
        return models.position_measurement(list(setup.r))
    return models.range_bearing(np.diag(setup.r), 4, setup.sensor_xy)


def build(setup: Setup) -> tuple:
    """``(schedule, measurement, estimators)``: the truth's manoeuvre schedule, the sensor (:func:`measurement`) and
    the estimators of Table 1 with the IMM-KF and the clairvoyant KF (the Kalman filter told the true mode
    sequence).  Under the position sensor the sigma-point IMMs coincide with the IMM-KF and the clairvoyant KF is the
    MMSE floor; under the range-bearing sensor both "KF"s are extended Kalman filters (the measurement linearised
    about the prediction) and neither is a bound."""
    w = math.radians(setup.turn_rate_deg)
    cv = models.constant_velocity(setup.T, setup.q)
    right = models.coordinated_turn(setup.T, -w, setup.q)
    left = models.coordinated_turn(setup.T, w, setup.q)
    i_right, i_left = (1, 2) if setup.mode_order == "right-left" else (2, 1)
    modes = [cv, right, left] if setup.mode_order == "right-left" else [cv, left, right]
    meas = measurement(setup)
    schedule = ManeuverSchedule(modes, [(*setup.right_turn, i_right), (*setup.left_turn, i_left)], 0,
                                setup.T, setup.n_steps, truncate=True)     # a shortened set-up runs a prefix
    T = np.array(setup.transition)
    single = {"CV": cv, "CT-right": right, "CT-left": left}[setup.single_model]
    estimators = {
        "IMM5CKF": IMM(SigmaPointFilter(FifthDegreeCubature()), modes, meas, T, name="IMM5CKF"),
        "IMMCKF": IMM(SigmaPointFilter(Cubature()), modes, meas, T, name="IMMCKF"),
        "IMMUKF": IMM(SigmaPointFilter(Unscented(*setup.ukf)), modes, meas, T, name="IMMUKF"),
        "5CKF": SingleModel(SigmaPointFilter(FifthDegreeCubature()), single, meas, name="5CKF"),
        "IMM-KF": IMM(ExtendedKalmanFilter(name="KF"), modes, meas, T, name="IMM-KF"),
        # not in the paper: the Kalman filter told the true mode sequence (MMSE lower bound)
        "clairvoyant KF": KnownModeSequence(ExtendedKalmanFilter(name="KF"), modes, schedule.modes(), meas,
                                            name="clairvoyant KF"),
    }
    return schedule, meas, estimators


def simulator(setup: Setup, schedule: ManeuverSchedule, meas: MeasurementModel) -> Callable:
    """``mc -> (runs -> (truth, measurements, start means))``: the truth (with process noise under Z-7), the
    measurements of ``meas`` and the filters' initial means (x0, or x0 + N(0, P0) from the run's INITIAL stream,
    Z-9)."""
    x0 = np.array(setup.x0)
    P0 = np.diag(setup.P0_diag)

    def for_mc(mc: MonteCarlo):
        def start(runs):
            if setup.initial_estimate == "sampled":
                return mc.gaussian(runs, Stream.INITIAL, x0, P0)
            return np.tile(x0, (len(runs), 1))

        return evaluation.simulator(mc, schedule, meas, x0, process_noise=setup.truth_process_noise, start=start)

    return for_mc


def batch(setup: Setup, mc: MonteCarlo) -> tuple:
    """``(make_batch, estimators)``: ``make_batch(runs) -> (truth, measurements, {name: initial state})`` for
    :func:`mmlib.experiment.evaluation.evaluate` (:func:`simulator`; IMMs started with P0 and
    ``mode_probabilities0``, single-model filters with P0) and the estimators of :func:`build`."""
    schedule, meas, estimators = build(setup)
    P0 = np.diag(setup.P0_diag)

    def init_state(est, m0, runs):
        return est.init(m0, P0, setup.mode_probabilities0) if isinstance(est, IMM) else est.init(m0, P0)

    make_batch = evaluation.with_initial_states(simulator(setup, schedule, meas)(mc), estimators, init_state)
    return make_batch, estimators


def scenario(setup: Setup) -> Scenario:
    """Section 4's set-up as an arena scenario: the IMM's three modes (CV and the two known-rate turns), the
    single-model 5CKF's model (Z-10) and the sensor of Z-5 (at the headline the position sensor: all linear, so
    every rule returns the Kalman moments); SI units as printed."""
    schedule, meas, estimators = build(setup)
    sensor = ("linear position sensor" if setup.sensor == "position" else
              f"range-bearing sensor at {tuple(setup.sensor_xy)} m")
    return Scenario(name=text.NAME, title=f"Zhu et al. 2016: CV and ±3°/s turns, {sensor}",
                    source=text.CITATION, root_seed=text.ROOT_SEED, T=setup.T, n_steps=setup.n_steps,
                    simulator=simulator(setup, schedule, meas), P0=np.diag(setup.P0_diag), position=(0, 2),
                    velocity=(1, 3), single=estimators["5CKF"].dynamics, modes=tuple(estimators["IMM5CKF"].dynamics),
                    transition=np.array(setup.transition), mode_probabilities=setup.mode_probabilities0,
                    measurement=meas, ukf=tuple(setup.ukf),
                    properties={"measurement": "linear position (x, y)" if setup.sensor == "position" else
                                "range and bearing (m, rad)", "manoeuvre": "±3°/s turns, known rate"})
