"""Hu, Zhang, Fu & Li 2017, "Maneuvering target tracking algorithm based on CDKF in
observation bootstrapping strategy", High Technology Letters 23(2),
doi:10.3772/j.issn.1006-6748.2017.02.005 -- Section 3.

Two coordinated-turn modes (+0.3 and -0.15 rad/s), a two-coordinate radar, 35
steps; IMMUKF, IMMEKF, IMMCKF, IMMCDKF and IMMCDKF-OBS.  Units: km, km/s, rad.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .. import models
from ..bootstrap import ObservationBootstrap
from ..estimation import IMM
from ..filters import ExtendedKalmanFilter, SigmaPointFilter
from ..montecarlo import MonteCarlo, Stream
from ..rules import CentralDifference, Cubature, Unscented
from ..simulate import ManeuverSchedule
from ..experiment import evaluation
from ..experiment.readings import Deviation

PAPER = "hu2017"
CITATION = ("Z. Hu, J. Zhang, C. Fu, X. Li, Maneuvering target tracking algorithm based on CDKF in observation "
            "bootstrapping strategy, High Technology Letters 23(2), 2017, doi:10.3772/j.issn.1006-6748.2017.02.005")
ROOT_SEED = 20170615
N_RUNS_PAPER = 100
ALGORITHMS = ("IMMUKF", "IMMEKF", "IMMCKF", "IMMCDKF", "IMMCDKF-OBS")
#: Table 1 as printed: horizontal (x) and vertical (y) mean RMSE in km, time per run in s.
TABLE1 = {"IMMUKF": ("0.0648", "0.1165", "0.0096"), "IMMEKF": ("0.0615", "0.1118", "0.0025"),
          "IMMCKF": ("0.0605", "0.1123", "0.0138"), "IMMCDKF": ("0.0433", "0.0721", "0.0096"),
          "IMMCDKF-OBS": ("0.0289", "0.0379", "0.0352")}


@dataclass(frozen=True)
class Setup:
    """Section 3 parameters; defaults are the headline reading (see DEVIATIONS)."""

    T: float = 1.0
    n_steps: int = 35
    omegas: tuple = (0.3, -0.15)                     # rad/s, modes 1 and 2
    mode2_steps: tuple = (11, 25)                    # steps k using F2 (state equation) (H-5)
    q: tuple = (0.2e-6, 0.4e-6)                      # process-noise variances per mode: 0.2, 0.4 m^2/s^4 in km (H-4)
    x0: tuple = (8.0, 0.4, 6.0, 0.2)                 # km, km/s
    sigma_r: float = 0.1                             # km
    sigma_theta_deg: float = 0.1                     # deg
    P0_sd: tuple = (0.1, 0.02, 0.1, 0.02)            # km, km/s (H-9)
    mode_probabilities0: tuple = (0.5, 0.5)          # (H-9)
    transition: tuple = ((0.95, 0.05), (0.05, 0.95))
    truth_process_noise: bool = True                 # (H-4)
    n_boot: int = 2
    boot_variance_factor: float = 2.0                # (H-6)
    obs_likelihood: str = "sum"                      # (H-7)
    ukf: tuple = (1.0, 0.0, -1.0)                    # alpha, beta, kappa = 3 - n (H-10)
    cd_form: str = "weighted"                        # as printed, Eqs. 7, 10, 11 (H-1)

    def __post_init__(self):
        a, b = self.mode2_steps
        if not 1 <= a <= b <= self.n_steps:
            raise ValueError(f"mode2_steps: expected 1 <= first <= last <= {self.n_steps}, got {self.mode2_steps}")
        if any(not v > 0 for v in self.q):
            raise ValueError(f"q: process-noise variances must be > 0, got {self.q}")


DEVIATIONS = [
    Deviation("H-1", "CDKF form",
              "Eqs. 7, 10, 11: covariances as weighted outer products with the mean weights (L-h^2)/h^2, 1/(2h^2)",
              "the printed form (headline); Norgaard et al. 2000 Stirling/DD2 covariances in the sweep",
              "The printed form is exactly the unscented rule with alpha = 1, beta = 0, kappa = h^2 - L (tested); "
              "Eq. 10 prints xi - z_hat for xi - x_hat (typo).", "CD-form sweep"),
    Deviation("H-2", "measurement", "range printed as x^2 + y^2, bearing as arctan(y/r)",
              "range sqrt(x^2 + y^2), bearing atan2(y, x), radar at the origin",
              "A 'two-coordinate radar' measures range and azimuth; the printed forms are typos (x^2 + y^2 is not a "
              "range; r is not a coordinate)."),
    Deviation("H-3", "Gamma", "Gamma = [0 0 tau/2 tau; tau/2 tau 0 0]^T",
              "as printed (tau/2 where tau^2/2 is usual; identical at tau = 1 s; the noise components are swapped "
              "between axes, immaterial for isotropic noise)", ""),
    Deviation("H-4", "noise units, truth", "sigma_u1^2 = 0.2 I, sigma_u2^2 = 0.4 I (no unit); state equation has "
              "Gamma u", "m^2/s^4 (0.2e-6 and 0.4e-6 km^2/s^4); the truth carries this noise",
              "Read in km^2/s^4 (the state's unit) the random acceleration, 0.45-0.63 km/s^2, is 4-5x the turn's "
              "centripetal acceleration (0.12 km/s^2): in our runs the truth's speed random-walks up to 4 km/s and "
              "targets pass within 2 km of the radar -- not a maneuvering-target scenario. In m^2/s^4 the turns "
              "dominate and the speed stays ~0.45 km/s. Decided on the truth's plausibility (shown in the notebook), "
              "not on Table 1; the km reading is swept.", "noise-unit sweep"),
    Deviation("H-5", "mode schedule", "text: first 10 steps +0.3; 'from 10 to 25' -0.15; 'from 11 to 35' +0.3; "
              "state equation: F1 for k = 1..10, F2 for 11..25, F1 for 26..35",
              "the state equation (k = 11..25 in mode 2)",
              "The only self-consistent statement; the text's '11 to 35' overlaps '10 to 25'."),
    Deviation("H-6", "bootstrap variance", "text: variance of z~ is twice that of z; Eq. 18 prints (2 sigma)^2",
              "2 sigma^2 (the text; var(v + v^n) = 2 sigma^2 for independent v, v^n)",
              "Eq. 18's (2 sigma)^2 = 4 sigma^2 contradicts the paper's own derivation.", "factor-4 sweep"),
    Deviation("H-7", "OBS mode likelihood", "l^i = sum_{n=1}^{N} sum ... l^{n,i} (garbled)",
              "l^i = sum over all N + 1 members of N(z~^n; z_hat, P_zz^n), in log space",
              "A sum over the members is what survives the garbling; the product (independent members) is swept.",
              "product sweep"),
    Deviation("H-8", "Eq. 20", "P^n = P - K^n P_zz (K^n)^T with K^n = P_xz (P_zz^n)^-1",
              "P^n = P - K^n P_zz^n (K^n)^T (the Kalman form, the exact covariance of x^n when z~^n has variance "
              "P_zz^n)", "With the original P_zz the printed P^n is not the covariance of x^n."),
    Deviation("H-9", "P0 and mu0", "not given (x_0|0 = x_0 is)",
              "P0 = diag(0.1 km, 0.02 km/s, 0.1 km, 0.02 km/s)^2; mu0 = (0.5, 0.5)",
              "Position s.d. equal to the range noise; velocity s.d. 5-10 % of the speed; no mode preferred.",
              "mu0 sweep"),
    Deviation("H-10", "UKF parameters", "not given", "alpha = 1, beta = 0, kappa = 3 - n (= -1)",
              "Julier's classic choice. With it IMMUKF is *exactly* IMMCDKF in the printed form (H-1); beta = 2 "
              "is swept.", "UKF sweep"),
    Deviation("H-11", "'mean of RMSE'", "Table 1 'mean of RMSE' over 100 runs",
              "mean over the 35 steps of the per-step RMSE across runs, per axis (x horizontal, y vertical)",
              "Matches Figs. 6-7, which plot the per-step RMSE; the run-and-time RMS is reported alongside.", ""),
    Deviation("H-12", "time", "MATLAB seconds per run", "ratios to IMMCDKF, one run at a time and batched", ""),
]


def build(setup: Setup):
    T = setup.T
    G = np.array([[0.0, T / 2], [0.0, T], [T / 2, 0.0], [T, 0.0]])          # Gamma as printed (H-3)
    modes = [models.coordinated_turn(T, w, q, G) for w, q in zip(setup.omegas, setup.q)]
    radar = models.range_bearing(np.diag([setup.sigma_r ** 2, math.radians(setup.sigma_theta_deg) ** 2]))
    a, b = setup.mode2_steps
    schedule = ManeuverSchedule(modes, [((a - 1) * T, b * T, 1)], 0, T, setup.n_steps)
    Tm = np.array(setup.transition)
    cdkf = SigmaPointFilter(CentralDifference(form=setup.cd_form), name="CDKF")
    filters = {"IMMUKF": SigmaPointFilter(Unscented(*setup.ukf), name="UKF"),
               "IMMEKF": ExtendedKalmanFilter(name="EKF"),
               "IMMCKF": SigmaPointFilter(Cubature(), name="CKF"),
               "IMMCDKF": cdkf,
               "IMMCDKF-OBS": ObservationBootstrap(cdkf, n_boot=setup.n_boot,
                                                   variance_factor=setup.boot_variance_factor,
                                                   likelihood=setup.obs_likelihood, name="CDKF-OBS")}
    estimators = {name: IMM(f, modes, radar, Tm, name=name) for name, f in filters.items()}
    return schedule, radar, estimators


def make_batch_fn(setup: Setup, mc: MonteCarlo, names=None):
    schedule, radar, estimators = build(setup)
    estimators = evaluation.select(estimators, names)
    P0 = np.diag(np.square(setup.P0_sd))

    def init_state(est, m0, runs):
        extra = {}
        if isinstance(est.filter, ObservationBootstrap):     # bootstrap noise from the run's own stream
            noise = mc.standard_normal(runs, Stream.FILTER, (setup.n_steps, max(setup.n_boot, 1), 2))
            extra = {"noise": noise[:, :, :setup.n_boot]}
        return est.init(m0, P0, setup.mode_probabilities0, **extra)

    make_batch = evaluation.make_batches(mc, schedule, radar, setup.x0, estimators, init_state,
                                     process_noise=setup.truth_process_noise)
    return make_batch, estimators, schedule


def variant(setup: Setup, **changes) -> Setup:
    return replace(setup, **changes)
