"""Zhu, Wang & Yuan 2016, "An Improved Interacting Multiple Model Filtering
Algorithm Based on the Cubature Kalman Filter for Maneuvering Target
Tracking", Sensors 16(6), 805, doi:10.3390/s16060805 -- Section 4 set-up.

Key structural fact (derived in the notebook and tested): the paper's models
are all linear -- constant velocity and coordinated turns with *known* turn
rate (Eq. 61) observed through a linear position sensor (Eq. 62).  Every
sigma-point rule that integrates degree-2 polynomials exactly (UKF, CKF,
5th-degree CKF) then returns the exact Kalman moments, so IMM5CKF, IMMCKF and
IMMUKF are the same algorithm as IMM-KF, up to round-off.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .. import models
from ..estimation import IMM, KnownModeSequence, SingleModel
from ..filters import ExtendedKalmanFilter, SigmaPointFilter
from ..montecarlo import MonteCarlo, Stream
from ..rules import Cubature, FifthDegreeCubature, Unscented
from ..simulate import ManeuverSchedule
from ..experiment import evaluation
from ..experiment.readings import Deviation

PAPER = "zhu2016"
CITATION = ("W. Zhu, W. Wang, G. Yuan, An Improved Interacting Multiple Model Filtering Algorithm "
            "Based on the Cubature Kalman Filter for Maneuvering Target Tracking, Sensors 16(6):805, 2016, "
            "doi:10.3390/s16060805")
N_RUNS_PAPER = 100
ROOT_SEED = 20160601          # publication date; one root seed for the whole paper

ALGORITHMS = ("IMM5CKF", "IMMCKF", "IMMUKF", "5CKF", "OMTM-IMM")
QUANTITIES = (("RMSE_X (m)", 0), ("RMSE_X_V (m/s)", 1), ("RMSE_Y (m)", 2), ("RMSE_Y_V (m/s)", 3))

#: Table 1 exactly as printed (strings keep the printed precision).
TABLE1 = {
    "IMM5CKF": ["2.6675", "1.1245", "2.5255", "1.4972", "14.9726"],
    "IMMCKF": ["2.4847", "1.8306", "2.8534", "2.9201", "7.2549"],
    "IMMUKF": ["2.5392", "1.8930", "3.0362", "2.8488", "7.3785"],
    "5CKF": ["27.4975", "5.7001", "21.7947", "12.2331", "5.3101"],
    "OMTM-IMM": ["5.6211", "3.2510", "6.0674", "4.9938", "6.0314"],
}


@dataclass(frozen=True)
class Setup:
    """Section 4 parameters; defaults are the headline reading (see DEVIATIONS)."""

    T: float = 1.0                                   # s
    n_steps: int = 100                               # simTime = 100 s
    x0: tuple = (1000.0, 200.0, 1000.0, 200.0)       # [x m, vx m/s, y m, vy m/s]
    P0_diag: tuple = (1000.0, 10.0, 1000.0, 10.0)
    q: float = 10.0                                  # q = diag(10, 10), m^2/s^4   (Z-4)
    r: tuple = (20.0, 0.1)                           # r = diag(20, 0.1), m^2, as printed (Z-5)
    turn_rate_deg: float = 3.0                       # deg/s (Z-6)
    right_turn: tuple = (20.0, 40.0)                 # s
    left_turn: tuple = (60.0, 80.0)                  # s
    transition: tuple = ((0.9, 0.05, 0.05), (0.1, 0.8, 0.1), (0.05, 0.15, 0.8))   # Eq. 63
    mode_probabilities0: tuple = (1 / 3, 1 / 3, 1 / 3)                           # (Z-8)
    truth_process_noise: bool = True                 # (Z-7)
    initial_estimate: str = "sampled"                # "sampled" from N(x0, P0), or "true" (Z-9)
    single_model: str = "CV"                         # the 5CKF's one model (Z-10)
    ukf: tuple = (1.0, 2.0, 0.0)                     # alpha, beta, kappa (Z-11)

    def __post_init__(self):
        if self.initial_estimate not in ("sampled", "true"):
            raise ValueError(f"initial_estimate: expected 'sampled' or 'true', got {self.initial_estimate!r}")
        if self.single_model not in ("CV", "CT-right", "CT-left"):
            raise ValueError(f"single_model: expected 'CV', 'CT-right' or 'CT-left', got {self.single_model!r}")


DEVIATIONS = [
    Deviation("Z-1", "5CKF points/weights",
              "Eqs. 2-13 with w2 = 2/(n+2)^2",
              "Jia, Xin & Cheng 2013 rule: w2 = 1/(n+2)^2",
              "With 2/(n+2)^2 the weights sum to 1 + 2n(n-1)/(n+2)^2 = 1.67 for n = 4 and the rule is not "
              "exact even for constants; the cited primary source and two public implementations use 1/(n+2)^2."),
    Deviation("Z-2", "5CKF covariance",
              "Eq. 24 omits -x x^T and +Q; Eq. 45 has -z z^T and +R",
              "P = sum w (X - x)(X - x)^T + Q (and likewise for Pzz, Pxz)",
              "Eq. 24 as printed is not a covariance; Eqs. 45 and 48 show the intended central form."),
    Deviation("Z-3", "likelihood", "Eq. 57: 1/sqrt(2 pi V)",
              "N(z; z_pred, S) = exp(-nu^T S^-1 nu / 2) / sqrt(det(2 pi S)) for the 2-D measurement",
              "Eq. 57 is the scalar density; constant factors cancel in Eq. 58 only if all modes share them."),
    Deviation("Z-4", "process noise", "Q ~ N(0, q), q = [10 0; 0 10], G = [T^2/2 0; T 0; 0 T^2/2; 0 T]",
              "Q = G q G^T, q in m^2/s^4, the same for every mode and for the truth",
              "Units are not stated; m^2/s^4 is the only unit consistent with G multiplying an acceleration."),
    Deviation("Z-5", "measurement noise", "r = diag([20, 0.1]) for the position measurement of Eq. 62",
              "R = diag(20, 0.1) m^2 as printed (headline); diag(20, 20) in the sweep",
              "A 0.1 m^2 y-variance looks like a range-bearing leftover, and the paper's RMSE_Y ~ RMSE_X suggests "
              "equal variances were used; we implement what is printed and show the alternative.",
              "R sweep"),
    Deviation("Z-6", "turn rate", "right turn -3 deg, left turn 3 deg",
              "omega = -/+3 deg/s (T = 1 s), known to the filters; model order 1 = CV, 2 = right, 3 = left",
              "Units by the sampling interval; order as listed, consistent with the row sums of Eq. 63."),
    Deviation("Z-7", "truth", "the truth model is not stated beyond Q",
              "truth driven by the same process noise as the filters (CV / CT, Q = G q G^T)",
              "Q is stated as the system's process noise.", "truth-noise sweep"),
    Deviation("Z-8", "initial mode probabilities", "not given", "uniform (1/3 each)",
              "No information favours a mode; the target starts in uniform motion but the paper does not say "
              "the filter knows it.", "mu0 sweep"),
    Deviation("Z-9", "initial estimate", "X0 and P0 given; whether the filter starts at X0 is not",
              "truth starts at X0; filter mean drawn per run from N(X0, P0) (consistent with P0)",
              "Starting the filter at the true state with P0 = diag(1000, ...) would make P0 a lie.",
              "initialisation sweep"),
    Deviation("Z-10", "5CKF (single model)", "which model the single-model 5CKF uses is not stated",
              "constant velocity with the same Q",
              "The paper argues 5CKF fails because 'a single model algorithm cannot adapt'; CV is the mode the "
              "target is in 60% of the time."),
    Deviation("Z-11", "UKF parameters", "not given", "alpha = 1, beta = 2, kappa = 0",
              "Irrelevant under this set-up: on linear models any valid (alpha, beta, kappa) gives the KF "
              "(tested)."),
    Deviation("Z-12", "time grid", "turns 'during 20 s ~ 40 s' and '60 s ~ 80 s'; 100 s at T = 1 s",
              "100 steps, measurements at t = 1..100 s; a turn covers the transitions that start in [20, 40) s "
              "and [60, 80) s",
              "Interval ends are ambiguous by one step; the effect is one step of the 100."),
    Deviation("Z-13", "RMSE", "Eq. 64 (indices garbled)",
              "per component, RMSE = sqrt(mean over runs and over the 100 steps of squared error)",
              "The only reading of Eq. 64 with a single number per component; per-run time means are the "
              "independent replications for the standard error."),
    Deviation("Z-14", "OMTM-IMM", "cited only (Zhou, Cai, Sun & Shen 2014, Math. Probl. Eng. 813654)",
              "not implemented: column kept with the paper's values, verdict 'not replicable'",
              "Only the abstract of the cited paper is available: the transition matrix is computed by linear "
              "minimum variance from subfilter cross-covariances, but no equations, initial values or mode "
              "filter are given, here or in the cited abstract."),
    Deviation("Z-15", "run time", "MATLAB seconds, total or per run not stated",
              "time per run measured one run at a time (the paper's way) and batched; compared as ratios to "
              "IMMCKF",
              "Absolute times across languages and machines are not comparable; ratios are."),
]


def build(setup: Setup):
    """Dynamics, measurement, schedule and the estimators of Table 1."""
    w = math.radians(setup.turn_rate_deg)
    cv = models.constant_velocity(setup.T, setup.q)
    right = models.coordinated_turn(setup.T, -w, setup.q)
    left = models.coordinated_turn(setup.T, w, setup.q)
    modes = [cv, right, left]
    meas = models.position_measurement(list(setup.r))
    schedule = ManeuverSchedule(modes, [(*setup.right_turn, 1), (*setup.left_turn, 2)], 0,
                                setup.T, setup.n_steps)
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


def make_batch_fn(setup: Setup, mc: MonteCarlo):
    """``runs -> (truth, measurements, initial states)`` for :func:`evaluation.evaluate`."""
    schedule, meas, estimators = build(setup)
    x0 = np.array(setup.x0)
    P0 = np.diag(setup.P0_diag)

    def start(runs):
        if setup.initial_estimate == "sampled":
            return x0 + mc.standard_normal(runs, Stream.INITIAL, (4,)) @ np.linalg.cholesky(P0).T
        return np.tile(x0, (len(runs), 1))

    def init_state(est, m0, runs):
        return est.init(m0, P0, setup.mode_probabilities0) if isinstance(est, IMM) else est.init(m0, P0)

    make_batch = evaluation.make_batches(mc, schedule, meas, x0, estimators, init_state,
                                     process_noise=setup.truth_process_noise, start=start)
    return make_batch, estimators, schedule


def variant(setup: Setup, **changes) -> Setup:
    return replace(setup, **changes)
