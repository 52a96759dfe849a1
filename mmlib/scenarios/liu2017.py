"""Liu & Wu 2017, "Strong Tracking Spherical Simplex-Radial Cubature Kalman Filter for
Maneuvering Target Tracking", Sensors 17(4):741, doi:10.3390/s17040741 -- Section 4.

Constant-acceleration target (Eqs. 37-39) seen by a range-bearing radar at the
origin (Eq. 40); SSRCKF, STF (EKF-based), STUKF, STCKF and STSSRCKF compared by
RMSE (Eq. 41) and accumulative RMSE (Eq. 42).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .. import models
from ..estimation import SingleModel
from ..filters import ExtendedKalmanFilter, SigmaPointFilter
from ..montecarlo import MonteCarlo, Stream
from ..rules import Cubature, SphericalSimplexRadial, Unscented
from ..simulate import ManeuverSchedule
from ..strong_tracking import StrongTracking
from ..experiment import evaluation
from ..experiment.readings import Deviation

PAPER = "liu2017"
CITATION = ("H. Liu, W. Wu, Strong Tracking Spherical Simplex-Radial Cubature Kalman Filter for Maneuvering "
            "Target Tracking, Sensors 17(4):741, 2017, doi:10.3390/s17040741")
ROOT_SEED = 20170331           # publication date
N_RUNS_PAPER = 200
FILTERS = ("SSRCKF", "STF", "STUKF", "STCKF", "STSSRCKF")
QUANTITIES = (("Position ARMSE (m)", (0, 3)), ("Velocity ARMSE (m/s)", (1, 4)), ("Acceleration ARMSE (m/s^2)", (2, 5)))

#: Tables as printed: filter -> (position, velocity, acceleration ARMSE).
TABLE1 = {"SSRCKF": ("152.1", "31.2", "6.9"), "STF": ("129.7", "28.4", "6.2"), "STUKF": ("124.5", "27.5", "5.9"),
          "STCKF": ("123.1", "26.7", "5.8"), "STSSRCKF": ("119.3", "25.1", "5.6")}
TABLE2_TIME = {"SSRCKF": "0.07", "STF": "0.02", "STUKF": "0.14", "STCKF": "0.14", "STSSRCKF": "0.15"}
TABLE2_COMPLEXITY = {"SSRCKF": "O((2n+2)^3)", "STF": "O(n^2)", "STUKF": "O((2n+1)^3)", "STCKF": "O((2n)^3)",
                     "STSSRCKF": "O((2n+2)^3)"}
TABLE3 = {
    "Case 1": {"SSRCKF": ("101.6", "21.2", "5"), "STF": ("95.3", "20.2", "4.5"), "STUKF": ("88.5", "16.4", "4.1"),
               "STCKF": ("87.4", "16.8", "4.1"), "STSSRCKF": ("81.1", "15.9", "3.7")},
    "Case 2": {"SSRCKF": ("50.5", "8.2", "1.8"), "STF": ("65.1", "10.8", "2.4"), "STUKF": ("57.3", "8.8", "2.2"),
               "STCKF": ("56.3", "8.3", "2.2"), "STSSRCKF": ("53.4", "8.4", "2.1")},
}


@dataclass(frozen=True)
class Setup:
    """One simulation of Section 4.2; defaults are Example 1 under the headline reading."""

    T: float = 1.0
    n_steps: int = 200                                        # L-1
    maneuver_start: float = 150.0                             # s (L-1)
    maneuver_acceleration: tuple = (15.0, 25.0)               # m/s^2
    x0: tuple = (100.0, 15.0, 0.0, 400.0, 20.0, 0.0)          # [x, vx, ax, y, vy, ay]
    initial_estimate: str = "true"                            # "true" = x0 (as Example 1 prints) or "sampled" (L-6)
    P0_sd: tuple = (50.0, 20.0, 1.0, 50.0, 10.0, 1.0)
    sigma_r: float = 30.0                                     # m
    sigma_theta: float = 0.010                                # rad (10 mrad)
    q_sd: float = 0.1                                         # m/s^2 per step, filter's acceleration increment (L-2)
    truth_process_noise: bool = False                         # L-3
    beta: float = 4.5                                         # softening factor
    rho: float = 0.95                                         # forgetting factor
    ukf: tuple = (1.0, 0.0, -3.0)                             # alpha, beta, kappa = 3 - n (L-4)

    def __post_init__(self):
        if not 0 < self.maneuver_start < self.n_steps * self.T:
            raise ValueError(f"maneuver_start: must lie inside the simulation (0, {self.n_steps * self.T}), "
                             f"got {self.maneuver_start}")
        if not self.q_sd > 0:
            raise ValueError(f"q_sd: must be > 0, got {self.q_sd}")
        if self.initial_estimate not in ("true", "sampled"):
            raise ValueError(f"initial_estimate: expected 'true' or 'sampled', got {self.initial_estimate!r}")


EXAMPLE1 = Setup()
EXAMPLE2_CASE1 = Setup(x0=(5000.0, 150.0, 0.0, 5000.0, 80.0, 0.0), maneuver_acceleration=(5.0, 5.0))
EXAMPLE2_CASE2 = Setup(x0=(5000.0, 150.0, 0.0, 5000.0, 80.0, 0.0), maneuver_acceleration=(0.5, 0.5))

DEVIATIONS = [
    Deviation("L-1", "time line (Example 1)",
              "'simulation time is 100 s'; 'uniform motion during the first 150 s', maneuver 'up to the end of this "
              "simulation at t = 200 s'; discussion: 'the maneuver starts at t = 101 s'",
              "200 s; acceleration switched on at t = 150 s (acts over [150, 200] s)",
              "Two statements of the set-up paragraph (150 s, 200 s) agree with each other and with Example 2's "
              "explicit 150 s / 200 s time line; '100 s' contradicts both. Chosen on the text, before any run.",
              "maneuver at t = 100 s"),
    Deviation("L-2", "filter process noise", "Q_ca and the noise V of Eq. 37 are not given",
              "Q = G q G^T per axis with G of Eq. 39 and sqrt(q) = 0.1 m/s^2 per step (nearly constant "
              "acceleration, Bar-Shalom et al. 2001 Sec. 6.3.3)",
              "Strong tracking exists for a filter tuned to the non-maneuvering regime; the truth's acceleration "
              "is constant between the jumps, so a small increment is the design value. Never fitted to Table 1.",
              "q sweep 0.01-10 m/s^2"),
    Deviation("L-3", "truth", "whether the truth carries process noise is not said",
              "deterministic piecewise constant-acceleration truth (no process noise)",
              "The text describes uniform motion and constant acceleration only.", "truth-noise sweep"),
    Deviation("L-4", "UKF parameters", "not given; 'kappa is always set to n - 3' with negative centre weight for n > 3",
              "alpha = 1, beta = 0, kappa = 3 - n = -3 (centre weight -1)",
              "Julier's classic choice, the only one with the negative centre weight the paper describes "
              "(n - 3 would give a positive one).", "kappa = 0 sweep"),
    Deviation("L-5", "V_0 of Eq. 17", "V_0 = v_0 v_0^T without saying what v_0 is",
              "at the first update V = v_1 v_1^T, then the recursion of Eq. 17", "Eq. 17 read literally."),
    Deviation("L-6", "initial estimate", "Example 1 gives x_0|0 equal to the true initial state; Example 2 gives none",
              "filter starts at the true initial state with Example 1's P0, in both examples",
              "Example 2 is 'the same' set-up otherwise; drawing from P0 is the alternative (sweep).",
              "sampled-initialisation sweep"),
    Deviation("L-7", "Example 2 noise and run count", "not given",
              "sigma_r = 30 m, sigma_theta = 10 mrad, 200 runs, beta = 4.5, rho = 0.95, as Example 1", ""),
    Deviation("L-8", "maneuver onset", "'(a_x(151), a_y(151))'",
              "acceleration state set at t = 150 s, so it acts from the step [150, 151] s on",
              "One-step ambiguity between 'until t = 150 s' and 'a(151)'."),
    Deviation("L-9", "STF", "EKF-based strong tracking filter, Eqs. 13-17",
              "StrongTracking(EKF, form='jacobian') with analytic range-bearing Jacobians",
              "As printed; Eqs. 18-19 give the identical factor for the EKF (tested)."),
    Deviation("L-10", "ARMSE", "Eqs. 41-42; velocity and acceleration 'defined in the same way'",
              "ARMSE = sqrt(mean over runs and all N steps of the squared x-y error norm)",
              "Eq. 42 averages RMSE^2(k), which is the run-and-time mean of squared errors."),
]


def build(setup: Setup):
    """Dynamics, radar, schedule and the five filters of Table 1 (plus the plain CKF and UKF)."""
    ca = models.constant_acceleration(setup.T, setup.q_sd ** 2)
    radar = models.range_bearing(np.diag([setup.sigma_r ** 2, setup.sigma_theta ** 2]), state_dim=6)
    schedule = ManeuverSchedule([ca], [], 0, setup.T, setup.n_steps,
                                jumps=[(setup.maneuver_start, (2, 5), setup.maneuver_acceleration)])
    st = dict(beta=setup.beta, rho=setup.rho)
    ssr = SigmaPointFilter(SphericalSimplexRadial(), name="SSRCKF")
    ckf = SigmaPointFilter(Cubature(), name="CKF")
    ukf = SigmaPointFilter(Unscented(*setup.ukf), name="UKF")
    filters = {
        "SSRCKF": ssr,
        "STF": StrongTracking(ExtendedKalmanFilter(), form="jacobian", name="STF", **st),
        "STUKF": StrongTracking(ukf, name="STUKF", **st),
        "STCKF": StrongTracking(ckf, name="STCKF", **st),
        "STSSRCKF": StrongTracking(ssr, name="STSSRCKF", **st),
        "CKF": ckf,      # not in the paper's tables: for the claim "SSR is more accurate than CKF"
        "UKF": ukf,
    }
    estimators = {name: SingleModel(f, ca, radar, name=name) for name, f in filters.items()}
    return schedule, radar, estimators


def make_batch_fn(setup: Setup, mc: MonteCarlo, names=None):
    schedule, radar, estimators = build(setup)
    estimators = evaluation.select(estimators, names)
    x0 = np.array(setup.x0)
    P0 = np.diag(np.square(setup.P0_sd))

    def start(runs):
        m0 = np.tile(x0, (len(runs), 1))
        if setup.initial_estimate == "sampled":
            m0 = m0 + mc.standard_normal(runs, Stream.INITIAL, (6,)) * np.array(setup.P0_sd)
        return m0

    make_batch = evaluation.make_batches(mc, schedule, radar, x0, estimators, lambda est, m0, runs: est.init(m0, P0),
                                     process_noise=setup.truth_process_noise, start=start)
    return make_batch, estimators, schedule


def variant(setup: Setup, **changes) -> Setup:
    return replace(setup, **changes)
