"""Zhou, Zhao, Huang & Zhao 2017, "A Cubature-Principle-Assisted IMM-Adaptive UKF Algorithm
for Maneuvering Target Tracking Caused by Sensor Faults", Applied Sciences (MDPI), 2017.

Section 2.3 (Table 1, Fig. 2), Section 4.1 (Case 1: IMM vs CPIMM; Case 2, sensor faults:
IMM-UKF, IMM-NAUKF, CPIMM-UKF, CPIMM-NAUKF), and a clearly labelled synthetic analogue of
the unpublished INS/GPS experiment (Section 4.2).

Reading space (issue 10): the ambiguities are the factors ``FACTORS`` (ids = deviation numbers:
the noise gain Gamma Z-2, R's units Z-3, the truth's process noise Z-4, P0 Z-5, the fault model Z-6,
the UKF's parameters Z-7, NAUKF's window Z-8, NAUKF as printed or inflate-only Z-12, the filters'
process-noise intensity Z-13); ``SPACE`` is their product (1152 universes), run as its stated
fractional design (the strength-2 covering array, 16 universes).  A universe is :func:`universe` = :func:`summarise` of
:func:`evaluate_reading`; the notebook's headline rows and claims are :func:`judge` of the same
evaluation of ``SPACE.headline``, so the headline universe is the notebook's numbers bit for bit.
The key effect (``KEY_EFFECT``) is the paired time-averaged position MSE difference CPIMM-NAUKF
minus IMM-UKF in Case 2; its published counterpart is (m^2 + s^2) of Table 3's rows
(:func:`published_mse_difference`).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from typing import Any, Callable, Iterable, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike

from mmlib.core import estimation, models
from mmlib.core._validate import as_float_array, check_finite
from mmlib.experiment import metrics, report
from mmlib.core.layers.adaptive import InnovationAdaptive
from mmlib.core.estimation import IMM, MomentMixing, SingleModel
from mmlib.core.filters import ExtendedKalmanFilter, SigmaPointFilter
from mmlib.core.mixing import CubatureMixing
from mmlib.core.protocols import MeasurementModel, MomentFilter
from mmlib.experiment.montecarlo import MonteCarlo, Stream, say_progress
from mmlib.core.rules import Cubature, Unscented
from mmlib.experiment.simulate import ManeuverSchedule
from mmlib.experiment import digests, evaluation
from mmlib.experiment.multiverse import PublishedNumber, universe_result
from mmlib.experiment.readings import Deviation, Factor, Option, ReadingSpace
from mmlib.experiment.scenario import Scenario

PAPER = "zhou2017"
CITATION = ("H. Zhou, H. Zhao, H. Huang, X. Zhao, A Cubature-Principle-Assisted IMM-Adaptive UKF Algorithm for "
            "Maneuvering Target Tracking Caused by Sensor Faults, Applied Sciences 7(10), 2017 (published 28 "
            "September 2017)")
ROOT_SEED = 20170928
N_RUNS_PAPER = 100

#: Section 2.3 example and Table 1 (the CP value is quoted in Section 3.1.3).
EXAMPLE_MEANS, EXAMPLE_SD, EXAMPLE_U = (-3.0, 0.0, 5.0), (3.0, 2.25, 1.8), (0.3, 0.4, 0.3)
TABLE1 = {"MSE": ("0.6000", "3.9417"), "MC": ("0.5937", "1.3906"), "CP": ("0.6", "1.3826")}
#: Tables 2 and 3: position mean, s.d. (m); velocity mean, s.d. (m/s).
TABLE2 = {"IMM": ("3.8245", "2.0377", "0.7102", "0.6935"), "CPIMM": ("2.0630", "1.1604", "0.4596", "0.4187")}
TABLE3 = {"IMM-UKF": ("11.8533", "4.3387", "3.1026", "1.9552"), "IMM-NAUKF": ("7.0473", "2.9116", "1.2143", "1.0348"),
          "CPIMM-UKF": ("9.3558", "3.0098", "2.4961", "1.2246"), "CPIMM-NAUKF": ("4.8671", "0.9169", "0.4294", "0.3857")}
TABLE_QUANTITIES = ("position error mean (m)", "position error s.d. (m)", "velocity error mean (m/s)",
                    "velocity error s.d. (m/s)")
#: Tables 4 and 5 (vehicle and UAV experiments; data not published).
TABLE4 = {"EKF": ("8.6533", "7.9816", "8.2107", "7.0044"), "CKF": ("8.4154", "7.5127", "8.0109", "6.8135"),
          "UKF": ("6.9018", "6.5011", "6.9271", "6.6102"), "AUKF": ("4.4225", "4.0118", "4.8159", "4.6825"),
          "NAUKF": ("3.0156", "2.8105", "2.8192", "2.4947")}
TABLE5 = {"IMM-UKF": ("9.0125", "8.2336", "9.0058", "8.1329"), "IMM-NAUKF": ("6.7243", "6.0772", "6.1174", "5.9287"),
          "CPIMM-UKF": ("7.1588", "7.0154", "7.0542", "6.8835"),
          "CPIMM-NAUKF": ("2.8514", "2.2259", "2.3417", "2.0016")}
MAE_QUANTITIES = ("longitude MAE mean (m)", "longitude MAE s.d. (m)", "latitude MAE mean (m)", "latitude MAE s.d. (m)")


@dataclass(frozen=True)
class Setup:
    """Section 4.1 parameters; defaults are the headline reading (see DEVIATIONS and FACTORS).

    Units: T in s; positions m, velocities m/s; ``q_cv``/``q_ct`` acceleration-noise variances in
    m^2/s^4 (Q = q G G^T, G = [T^2/2, T] per axis, Z-2), used by the truth (when
    ``truth_process_noise``) and, times ``filter_q_scale``, by every filter's models (Z-13);
    ``R_diag`` = (range m^2, bearing rad^2) (Z-3); fault bounds in m and rad/s (Z-6)."""

    T: float = 1.0
    n_steps: int = 100
    x0: tuple = (0.0, 10.0, 400.0, 40.0)             # [x, vx, y, vy] (Z-1)
    turns: tuple = ((20.0, 40.0, -0.1), (60.0, 80.0, 0.1))
    q_cv: float = 5.0                                # m^2/s^4 (Z-2)
    q_ct: float = 20.0
    noise_gain: str = "dwna"                         # Gamma: "dwna" G = [T^2/2, T] per axis, or "identity" (Z-2)
    filter_q_scale: float = 1.0                      # filters' Q = scale * printed Q (Z-13)
    R_diag: tuple = (15.0, 15e-6)                    # m^2, rad^2 (15 mrad^2) (Z-3)
    transition: tuple = ((0.99, 0.005, 0.005), (0.005, 0.99, 0.005), (0.005, 0.005, 0.99))
    mode_probabilities0: tuple = (0.99, 0.005, 0.005)
    P0_sd: tuple = (10.0, 5.0, 10.0, 5.0)            # (Z-5)
    truth_process_noise: bool = True                 # (Z-4)
    faults: bool = False                             # Case 2
    fault_range_max: float = 5.0                     # m (Z-6)
    fault_bearing_rate_max: float = 1e-2             # rad/s (Z-6)
    fault_kind: str = "constant-drift"               # or "per-step", "constant" (Z-6)
    ukf: tuple = (1.0, 0.0, -1.0)                    # (Z-7)
    window: int = 10                                 # NAUKF innovation window (Z-8)
    psi: float = 1.0                                 # Eq. 32 (Z-8)
    inflate_only: bool = False                       # bounded NAUKF reading (Z-12)

    def __post_init__(self):
        if self.noise_gain not in NOISE_GAINS:
            raise ValueError(f"noise_gain: expected one of {NOISE_GAINS}, got {self.noise_gain!r}")
        if self.fault_kind not in FAULT_KINDS:
            raise ValueError(f"fault_kind: expected one of {FAULT_KINDS}, got {self.fault_kind!r}")
        if self.psi < 1:
            raise ValueError(f"psi: must be >= 1 (Eq. 32), got {self.psi}")
        if (isinstance(self.filter_q_scale, bool) or not isinstance(self.filter_q_scale, (int, float))
                or not math.isfinite(self.filter_q_scale) or self.filter_q_scale <= 0):
            raise ValueError(f"filter_q_scale: expected a finite number > 0, got {self.filter_q_scale!r}")
        if len(self.R_diag) != 2 or not all(float(r) > 0 for r in self.R_diag):
            raise ValueError(f"R_diag: expected two positive variances (range m^2, bearing rad^2), got {self.R_diag!r}")
        if isinstance(self.window, bool) or not isinstance(self.window, int) or self.window < 2:
            raise ValueError(f"window: expected an integer >= 2, got {self.window!r}")


FAULT_KINDS = ("constant-drift", "per-step", "constant")
NOISE_GAINS = ("dwna", "identity")

DEVIATIONS = [
    Deviation("Z-1", "state ordering", "X = [x, y, xdot, ydot] in Sec. 4.1, but F_CV (Eq. 41) and F_CT (Eq. 43) are "
              "written for [x, xdot, y, ydot]", "[x, vx, y, vy], the ordering the matrices use", ""),
    Deviation("Z-2", "process noise", "Eqs. 42/44 garbled: sigma_CV^2 = 5, sigma_CT^2 = 20; Gamma not given",
              "Q = G q G^T, G = [T^2/2, T] per axis, q = 5 (CV) and 20 (CT) m^2/s^4 (headline)",
              "Gamma = I (q on every state component) is the other reading; measured on 50 runs it moves Table 2-3 "
              "values by up to 15 standard errors (34 %), so it is a factor.", "factor Z-2"),
    Deviation("Z-3", "units of R = diag(15, 15)", "no units", "15 m^2 (range) and 15 mrad^2 (bearing)",
              "15 rad^2 is absurd (a bearing s.d. of 3.9 rad); mrad^2 gives a cross-range error (3.9 m at 1 km) "
              "comparable to the range error (3.9 m); deg^2 (67 m at 1 km) is the other reading.", "factor Z-3"),
    Deviation("Z-4", "truth", "Eqs. 1-2 include Gamma W; Sec. 4.1 describes straight lines and constant turns",
              "the truth carries the process noise of its segment's model (q = 5 CV, 20 CT)",
              "Eqs. 1-2 define the system with process noise and Sec. 4.1 gives its variances; the deterministic "
              "truth of the Sec. 4.1 description is the other reading.", "factor Z-4"),
    Deviation("Z-5", "initial estimate", "not given", "x0 (the true start), P0 = diag(10 m, 5 m/s, 10 m, 5 m/s)^2 "
              "(headline)", "All filters share it. A diffuse P0 (ten times the standard deviations) is the other "
              "reading; measured on 50 runs it moves Table 2-3 values by up to 2.2 standard errors (9 %) and flips "
              "the verdicts of claims resting on small differences (UKF vs EKF/CKF, CPIMM vs IMM in Case 1), so it "
              "is a factor.", "factor Z-5"),
    Deviation("Z-6", "fault model (Eq. 2)", "'distance deviation within [-5 m, 5 m]', 'angle drift rate within "
              "[0, 1e-2 rad/s]'", "per run: range deviation ~ U[-5, 5] m, constant; bearing drift rate ~ U[0, 1e-2] "
              "rad/s, accumulating (delta_theta_k = rate * t_k)", "A drift *rate* accumulates; a deviation within a "
              "range is read as a fixed offset. Other readings: per-step draws (fresh U[-5, 5] m and U[0, 1e-2] rad "
              "each step) and a constant offset of both (U[-5, 5] m, U[0, 1e-2] rad per run: the 'fixed deviation' "
              "of the introduction).", "factor Z-6"),
    Deviation("Z-7", "UKF parameters", "not given (the weights are cited to [3], which does not define them)",
              "alpha = 1, beta = 0, kappa = 3 - n (headline)", "The scaled transform alpha = 1e-3, beta = 2, kappa = 0 "
              "is the other reading. At the radar's ranges the sigma-point rules nearly coincide (measured: the "
              "largest change of an IMM-UKF error over the whole run is < 0.01 m against a 4.6 m RMSE), so the "
              "Table 2-3 values move by < 0.5 standard errors; but it decides the sign of the tiny UKF-vs-EKF/CKF "
              "differences the claim 'UKF has better filtering precision than KF, EKF and CKF' rests on, so it is a "
              "factor.", "factor Z-7"),
    Deviation("Z-8", "NAUKF details", "P_zz~ of Eq. 27 (the innovation covariance) not defined; Psi not given; "
              "Eq. 32's test applied when 'satisfied' (Sec. 3.2) vs 'otherwise' (Sec. 3.3)",
              "P_zz~ = mean of the last 10 innovation outer products (including the current one); Psi = 1; "
              "inflate (Eqs. 33-35) when Eq. 32 is violated; base UKF until 10 innovations exist; Eq. 37 uses the "
              "unmodified P_xz as printed", "The divergence reading of Sec. 3.3 is the only one where inflating P "
              "makes sense. The window (10 or 30) is a factor; Psi = 1 is the smallest value Eq. 32 allows.",
              "factor Z-8"),
    Deviation("Z-9", "'IMM' of Case 1", "'the standard IMM [9]' vs 'CPIMM'", "IMM-UKF vs CPIMM-UKF (same UKF)",
              "The paper's IMM family is IMM-UKF (Sec. 2); only the interaction differs.", ""),
    Deviation("Z-10", "Tables 2-3 statistics", "'mean' and 'standard deviation' of Eq. 45's RMSE",
              "per step, RMSE over runs of the position (velocity) error norm (Eq. 45); Table: its mean and s.d. "
              "over the 100 steps; standard errors by the delta method / jackknife over runs", ""),
    Deviation("Z-11", "Section 4.2", "vehicle INS/GPS and UAV SAR experiments; data and INS model unpublished",
              "Tables 4-5 kept with the verdict 'not replicable: data not published'; a synthetic analogue is "
              "added and labelled as such; the claim 'UKF is more precise than KF, EKF and CKF' is judged on the "
              "Section 4.1 radar scenario instead (Case 1, IMM with each filter)", ""),
    Deviation("Z-12", "NAUKF divergence", "Eqs. 28, 37, 39: S = P_zz~ (empirical), K = P_xz S^-1 with P_xz unmodified",
              "as printed (headline); diverged runs counted and reported. Other reading: S = S_pred + positive "
              "part of (C - S_pred) ('inflate only', the covariance can only grow, as Eq. 34's zeta >= 1 intends)",
              "As printed, the posterior P - P_xz C^-1 P_xz^T is indefinite whenever the windowed C falls below "
              "H P H^T in some direction, which a 10-sample estimate does within a few steps.", "factor Z-12"),
    Deviation("Z-13", "filters' process-noise intensity", "Eqs. 42/44 garbled ('N(,;0;sigma^2)'): the noise's "
              "gain and unit are lost; sigma_CV^2 = 5, sigma_CT^2 = 20 printed",
              "the filters use the printed q (headline); 0.1 q and 0.01 q are declared readings of the lost "
              "scaling (the truth keeps the printed q when it carries noise, Z-4)",
              "Discrete declared options only: nothing is fitted to a published number.", "factor Z-13"),
]

# ---------------------------------------------------------------- reading space (issue 10)
FACTORS = (
    Factor("Z-2", "process-noise gain Gamma (Eqs. 1-2, 42/44)", (
        Option("dwna", "Gamma = [T²/2, T] per axis", "Eqs. 1-2 write Gamma W with Gamma not given; Eqs. 42/44 give one "
               "variance per model (sigma_CV^2 = 5, sigma_CT^2 = 20), i.e. a scalar acceleration noise per axis, whose "
               "discretised gain is [T^2/2, T] (Bar-Shalom, Li & Kirubarajan 2001, Sec. 6.3.2)", {"noise_gain": "dwna"}),
        Option("identity", "Gamma = I (noise on every state component)", "Eqs. 1-2 (Gamma W, Gamma not given) with the "
               "garbled Eqs. 42/44 ('N(,;0;sigma^2)'): sigma^2 read as the variance of every component of W, Gamma = I",
               {"noise_gain": "identity"}),
    ), "dwna", "Eqs. 1-2 and 42/44 (Gamma not given); truth and filters share it"),
    Factor("Z-3", "units of R = diag(15, 15)", (
        Option("mrad2", "bearing variance 15 mrad²", "Sec. 4.1 'R = diag(15, 15)' with no units; mrad² makes the "
               "cross-range error (3.9 m at 1 km) match the range error (3.9 m)", {"R_diag": (15.0, 15e-6)}),
        Option("deg2", "bearing variance 15 deg²", "Sec. 4.1 'R = diag(15, 15)'; degrees are the usual unit of an "
               "'angle' (Sec. 4.1 calls theta the angle measurement)", {"R_diag": (15.0, 15.0 * (math.pi / 180) ** 2)}),
    ), "mrad2", "Sec. 4.1, measurement covariance (no units; 15 rad² — a 3.9 rad bearing s.d. — is not a usable "
                "reading and is left out)"),
    Factor("Z-4", "truth with or without process noise", (
        Option("noisy", "truth with process noise", "Eqs. 1-2 (X_k = f + Gamma W) and the variances of Eqs. 42/44",
               {"truth_process_noise": True}),
        Option("deterministic", "deterministic truth", "Sec. 4.1: 'moves at a constant velocity in a straight line', "
               "'constant right turn rate -0.1 rad/s' (a noiseless description)", {"truth_process_noise": False}),
    ), "noisy", "Eqs. 1-2 vs the description of Sec. 4.1"),
    Factor("Z-5", "filters' initial covariance P0", (
        Option("P0-10m", "P0 = diag(10 m, 5 m/s, 10 m, 5 m/s)²", "Sec. 4.1 gives the target's initial state X0 but no "
               "initial estimate or covariance; a modest P0 (of the order of one measurement's position error, 3.9 m, "
               "and of the velocity error of two-point differencing, ~5.5 m/s) around the true X0",
               {"P0_sd": (10.0, 5.0, 10.0, 5.0)}),
        Option("P0-100m", "P0 = diag(100 m, 50 m/s, 100 m, 50 m/s)²", "Sec. 4.1, P0 not given: a diffuse start, ten "
               "times the modest standard deviations (the filter trusts its first measurements)",
               {"P0_sd": (100.0, 50.0, 100.0, 50.0)}),
    ), "P0-10m", "Sec. 4.1 (P0 not given)"),
    Factor("Z-6", "sensor-fault model of Case 2", (
        Option("drift", "range offset + accumulating bearing drift", "Sec. 4.1 'distance deviation within "
               "[-5 m, 5 m]' and 'angle drift *rate* within [0, 1e-2 rad/s]' (a rate accumulates); Sec. 1 'fixed "
               "deviation, drift deviation'", {"fault_kind": "constant-drift"}),
        Option("per-step", "fresh range and bearing deviations each step", "Sec. 4.1 'delta h_out,k = [delta r_k, "
               "delta theta_k]' carries the step index k: one draw per step", {"fault_kind": "per-step"}),
        Option("constant", "constant range and bearing offsets", "Sec. 1: the faults considered are 'fixed deviation' "
               "and 'drift deviation'; the bearing offset read as a fixed deviation of up to 1e-2 rad",
               {"fault_kind": "constant"}),
    ), "drift", "Sec. 4.1 (Case 2) and Sec. 1"),
    Factor("Z-7", "UKF parameters (alpha, beta, kappa)", (
        Option("kappa3-n", "UKF alpha = 1, beta = 0, kappa = 3 - n", "not given (Sec. 3.2 cites [3] for the weights W_i, "
               "which does not define them); Sec. 4.2.1 'UKF can reach third order accuracy': kappa = 3 - n matches the "
               "Gaussian's fourth moment (Julier & Uhlmann 1997)", {"ukf": (1.0, 0.0, -1.0)}),
        Option("scaled", "UKF alpha = 1e-3, beta = 2, kappa = 0", "not given, as above: the scaled unscented transform "
               "with the usual defaults (Wan & van der Merwe 2000; beta = 2 optimal for Gaussian priors)",
               {"ukf": (1e-3, 2.0, 0.0)}),
    ), "kappa3-n", "Sec. 3.2 (UKF weights cited to [3], not given)"),
    Factor("Z-8", "NAUKF innovation window (P_zz~ of Eq. 27)", (
        Option("w10", "window of 10 innovations", "Eq. 27 needs an estimate of the innovation covariance; not "
               "given — 10 samples is the smallest common choice for a 2-D innovation", {"window": 10}),
        Option("w30", "window of 30 innovations", "Eq. 27, as above; a longer window (30 % of the 100-s run) "
               "trades tracking of the fault for a steadier estimate", {"window": 30}),
    ), "w10", "Sec. 3.2, Eq. 27 (P_zz~ undefined)"),
    Factor("Z-12", "NAUKF innovation covariance (Eqs. 28, 37, 39)", (
        Option("as-printed", "NAUKF as printed", "Eqs. 27-28 give P_zz = P_zz~ (the empirical covariance); "
               "Eqs. 37, 39 use it with the unmodified P_xz", {"inflate_only": False}),
        Option("inflate-only", "NAUKF inflate-only", "Sec. 3.2 'to avoid the divergence problem' and Eq. 34 "
               "(zeta >= 1): the adaptation is meant only to enlarge the covariance", {"inflate_only": True}),
    ), "as-printed", "Secs. 3.2-3.3"),
    Factor("Z-13", "filters' process-noise intensity (Eqs. 42/44)", (
        Option("q", "filters' q as printed", "Sec. 4.1: sigma_CV^2 = 5, sigma_CT^2 = 20", {"filter_q_scale": 1.0}),
        Option("q/10", "filters' q / 10", "Eqs. 42/44 garbled ('N(,;0;sigma^2)'): the noise gain and unit are lost, "
               "so the printed variances fix the filters' Q only up to its unknown scaling", {"filter_q_scale": 0.1}),
        Option("q/100", "filters' q / 100", "Eqs. 42/44 garbled, as above", {"filter_q_scale": 0.01}),
    ), "q", "Sec. 4.1, Eqs. 42/44 (garbled)"),
)
#: the full factorial (2 x 2 x 2 x 2 x 3 x 2 x 2 x 2 x 3 = 1152 universes) does not fit the time budget (60 s wall
#: with 2 workers; ~1.5 CPU s per universe at the paper's 100 runs, measured in the notebook's profile comment), so
#: the design is the stated fractional one: the strength-2 covering array of ReadingSpace.design (16 universes)
SPACE = ReadingSpace(PAPER, FACTORS, budget=64)

CASE1_ALGORITHMS = ("IMM-UKF", "CPIMM-UKF", "IMM-EKF", "IMM-CKF")
CASE2_ALGORITHMS = ("IMM-UKF", "IMM-NAUKF", "CPIMM-UKF", "CPIMM-NAUKF")
MV_ALGORITHMS = tuple(f"case 1 {a}" for a in CASE1_ALGORITHMS) + tuple(f"case 2 {a}" for a in CASE2_ALGORITHMS)
TABLE2_NAMES = (("IMM-UKF", "IMM"), ("CPIMM-UKF", "CPIMM"))
TABLE3_NAMES = tuple((a, a) for a in CASE2_ALGORITHMS)
TABLE2_DEVIATIONS = ["Z-1", "Z-2", "Z-3", "Z-4", "Z-5", "Z-7", "Z-9", "Z-10", "Z-13"]
TABLE3_DEVIATIONS = ["Z-1", "Z-2", "Z-3", "Z-4", "Z-5", "Z-6", "Z-7", "Z-8", "Z-10", "Z-12", "Z-13"]
#: every printed Monte Carlo number a universe replicates (Tables 2 and 3; Table 1 is analytic and
#: does not depend on any reading; Tables 4-5 rest on unpublished data)
PUBLISHED = tuple(PublishedNumber("Table 2", "Table 2", alg, q, printed)
                  for alg, pname in TABLE2_NAMES for q, printed in zip(TABLE_QUANTITIES, TABLE2[pname])) + \
    tuple(PublishedNumber("Table 3", "Table 3", alg, q, printed)
          for alg, pname in TABLE3_NAMES for q, printed in zip(TABLE_QUANTITIES, TABLE3[pname]))
KEY_EFFECT = "CPIMM-NAUKF − IMM-UKF, Case 2 position MSE (m²)"
POSITION, VELOCITY = (0, 2), (1, 3)
Q4 = (("position", POSITION), ("velocity", VELOCITY))
#: steps (0-based, step k at t = k + 1 s) of the 10 s after each maneuver switch (20, 40, 60, 80 s): the
#: transients in which "faster convergence" would show
TRANSIENT_STEPS = tuple(k for t0 in (20, 40, 60, 80) for k in range(t0, t0 + 10))


def published_mse_difference(table: dict, a: str, b: str) -> float:
    r"""Published counterpart of a paired time-averaged MSE difference, from a table's mean m and
    s.d. s over the steps of the per-step RMSE (Eq. 45): the time average of RMSE_k^2 is
    :math:`m^2 + s^2` (s the population s.d. over the steps; if the paper used the sample s.d.,
    the value changes by a factor (K-1)/K on s^2, i.e. < 1 % of it), so the difference is
    :math:`(m_a^2 + s_a^2) - (m_b^2 + s_b^2)` in m^2."""
    ma, sa = float(table[a][0]), float(table[a][1])
    mb, sb = float(table[b][0]), float(table[b][1])
    return (ma * ma + sa * sa) - (mb * mb + sb * sb)


def naukf_filter(base: MomentFilter, setup: Setup, inflate_only: bool | None = None) -> InnovationAdaptive:
    """NAUKF (Eqs. 27-39) over ``base`` with the set-up's window, psi and Z-12 reading (``inflate_only`` overrides
    the reading)."""
    return InnovationAdaptive(base, window=setup.window, psi=setup.psi,
                              inflate_only=setup.inflate_only if inflate_only is None else inflate_only, name="NAUKF")


def aukf_filter(base: MomentFilter, window: int, inflate_only: bool) -> InnovationAdaptive:
    """The classic innovation-based adaptive UKF that Table 4 compares with NAUKF (Mohamed & Schwarz 1999: no adaptive
    gene, the window of innovations before the current one)."""
    return InnovationAdaptive(base, window=window, zeta=False, include_current=False, inflate_only=inflate_only,
                              name="AUKF")


def build(setup: Setup) -> tuple:
    """Truth schedule (printed q), radar, and the estimators (filters' models with q * filter_q_scale)."""
    T = setup.T

    G = models.acceleration_noise_gain(T) if setup.noise_gain == "dwna" else np.eye(4)

    def modes_for(scale):
        cv = models.constant_velocity(T, setup.q_cv * scale, G)
        return [cv] + [models.coordinated_turn(T, w, setup.q_ct * scale, G) for _, _, w in setup.turns]

    truth_modes, modes = modes_for(1.0), modes_for(setup.filter_q_scale)
    radar = models.range_bearing(np.diag(setup.R_diag))
    schedule = ManeuverSchedule(truth_modes, [(a, b, i + 1) for i, (a, b, _) in enumerate(setup.turns)], 0, T,
                                setup.n_steps, truncate=True)     # a shortened set-up runs a prefix
    Tm = np.array(setup.transition)
    ukf = SigmaPointFilter(Unscented(*setup.ukf), name="UKF")
    naukf = naukf_filter(ukf, setup)
    estimators = {
        "IMM-UKF": IMM(ukf, modes, radar, Tm, mixing=MomentMixing(), name="IMM-UKF"),
        "IMM-NAUKF": IMM(naukf, modes, radar, Tm, mixing=MomentMixing(), name="IMM-NAUKF"),
        "CPIMM-UKF": IMM(ukf, modes, radar, Tm, mixing=CubatureMixing(), name="CPIMM-UKF"),
        "CPIMM-NAUKF": IMM(naukf, modes, radar, Tm, mixing=CubatureMixing(), name="CPIMM-NAUKF"),
        "IMM-EKF": IMM(ExtendedKalmanFilter(name="EKF"), modes, radar, Tm, mixing=MomentMixing(), name="IMM-EKF"),
        "IMM-CKF": IMM(SigmaPointFilter(Cubature(), name="CKF"), modes, radar, Tm, mixing=MomentMixing(),
                       name="IMM-CKF"),
    }
    return schedule, radar, estimators


def radar_drift(range_offset: ArrayLike, bearing_rate: ArrayLike, times: ArrayLike) -> models.SensorFault:
    """Eq. 2's fault of a range-bearing radar as a :class:`mmlib.core.models.SensorFault`: range deviation
    ``delta_r`` (m, per run, constant) and bearing drift ``delta_theta_k = rate * t_k`` (rad, rate in rad/s
    per run): arrays of shape (B,) or (B, K);
    ``times`` (K,) the measurement times t_k (s)."""
    t = check_finite(as_float_array(times, "times"), "times")
    if t.ndim != 1 or t.size < 1:
        raise ValueError(f"times: expected shape (K,) with K >= 1, got {t.shape}")
    K = t.shape[0]
    arrays = {}
    for name, value in (("range_offset", range_offset), ("bearing_rate", bearing_rate)):
        a = check_finite(as_float_array(value, name), name)
        if a.ndim not in (1, 2) or a.shape[0] < 1 or (a.ndim == 2 and a.shape[1] != K):
            raise ValueError(f"{name}: expected shape (B,) or (B, {K}) (per run, or per run and step), "
                             f"got {a.shape}")
        arrays[name] = a.reshape(a.shape[0], -1)
    B = arrays["range_offset"].shape[0]
    if arrays["bearing_rate"].shape[0] != B:
        raise ValueError(f"bearing_rate: expected {B} runs (as range_offset), got shape {np.shape(bearing_rate)}")
    dr = np.broadcast_to(arrays["range_offset"], (B, K))
    return models.SensorFault(np.stack([dr, arrays["bearing_rate"] * t[None, :]], axis=-1))


def radar_fault(setup: Setup, mc: MonteCarlo, runs: Sequence[int] | np.ndarray,
                times: Sequence[float] | np.ndarray) -> models.SensorFault:
    """The Case 2 fault (Eq. 2's delta h_out) of the runs, from the FAULT stream; every fault kind uses
    the same 2K + 2 normals per run (common random numbers across the Z-6 readings):

    * ``constant-drift``: range offset U[-5, 5] m constant; bearing drift rate U[0, 1e-2] rad/s,
      delta_theta_k = rate * t_k (rad);
    * ``per-step``: fresh U[-5, 5] m and U[0, 1e-2 rad/s * T] rad every step;
    * ``constant``: range offset U[-5, 5] m and bearing offset U[0, 1e-2 rad/s * T] rad, constant."""
    from scipy.special import ndtr
    K = len(times)
    p = ndtr(mc.standard_normal(runs, Stream.FAULT, (2 * K + 2,)))   # uniforms (probability integral transform)
    if setup.fault_kind == "constant-drift":
        dr = (2 * p[:, 0] - 1) * setup.fault_range_max
        rate = p[:, 1] * setup.fault_bearing_rate_max
        return radar_drift(dr, rate, times)
    if setup.fault_kind == "constant":
        dr = np.repeat(((2 * p[:, 0] - 1) * setup.fault_range_max)[:, None], K, axis=1)
        dth = np.repeat((p[:, 1] * setup.fault_bearing_rate_max * setup.T)[:, None], K, axis=1)
        return models.SensorFault(np.stack([dr, dth], axis=-1))
    dr = (2 * p[:, 2:2 + K] - 1) * setup.fault_range_max                    # fresh each step
    dth = p[:, 2 + K:2 + 2 * K] * setup.fault_bearing_rate_max * setup.T    # fresh angle each step
    return models.SensorFault(np.stack([dr, dth], axis=-1))


def simulator(setup: Setup, schedule: ManeuverSchedule, radar: MeasurementModel) -> Callable:
    """``mc -> (runs -> (truth, measurements, start means))``: truth from x0, radar measurements with the Case 2
    fault when ``setup.faults`` (:func:`radar_fault`, the run's FAULT stream); the filters start at the true x0."""
    def for_mc(mc: MonteCarlo):
        fault = (lambda runs: radar_fault(setup, mc, runs, schedule.times)) if setup.faults else None
        return evaluation.simulator(mc, schedule, radar, setup.x0, process_noise=setup.truth_process_noise,
                                    fault=fault)

    return for_mc


def make_batch_fn(setup: Setup, mc: MonteCarlo, names: Iterable[str] | None = None) -> tuple:
    """``(make_batch, estimators, schedule)`` for the runs of ``mc`` under ``setup``: ``make_batch(runs) ->
    (truth (B, K+1, 4) in m and m/s, radar measurements (B, K, 2) in m and rad, {name: initial state})``
    (:func:`simulator`), every IMM started at the true x0 with P0 = diag(P0_sd)^2 and ``mode_probabilities0``;
    ``estimators`` those of :func:`build` named in ``names`` (all if None; ValueError naming an unknown one);
    ``schedule`` the truth's :class:`ManeuverSchedule`."""
    schedule, radar, estimators = build(setup)
    estimators = evaluation.select(estimators, names)
    P0 = np.diag(np.square(setup.P0_sd))
    make_batch = evaluation.with_initial_states(simulator(setup, schedule, radar)(mc), estimators,
                                                lambda est, m0, runs: est.init(m0, P0, setup.mode_probabilities0))
    return make_batch, estimators, schedule


def scenario(setup: Setup | None = None) -> Scenario:
    """Case 2 of Section 4.1 (sensor faults) under the headline reading, unless ``setup`` is given, as an arena
    scenario: CV and two coordinated-turn modes, a range-bearing radar with the range offset and bearing drift of
    Eq. 2.  Single-model filters use the CV mode: the paper runs single-model UKF, AUKF and NAUKF only in its
    field test (Table 4), whose model it does not give."""
    setup = setups(SPACE.headline)[1] if setup is None else setup
    schedule, radar, estimators = build(setup)
    modes = tuple(estimators["IMM-UKF"].dynamics)
    case = "Case 2 (sensor faults)" if setup.faults else "Case 1 (no fault)"
    return Scenario(name=PAPER, title=f"Zhou et al. 2017 {case}: CV and ±0.1 rad/s turns, range-bearing radar",
                    source=CITATION, root_seed=ROOT_SEED, T=setup.T, n_steps=setup.n_steps,
                    simulator=simulator(setup, schedule, radar), P0=np.diag(np.square(setup.P0_sd)),
                    position=(0, 2), velocity=(1, 3), single=modes[0], modes=modes,
                    transition=np.array(setup.transition), mode_probabilities=setup.mode_probabilities0,
                    measurement=radar, ukf=tuple(setup.ukf),
                    properties={"measurement": "range-bearing" + (" with range offset and bearing drift (Eq. 2)"
                                                                  if setup.faults else ""),
                                "manoeuvre": "turns at ±0.1 rad/s"},
                    notes={"single": "single-model filters use the CV mode of Section 4.1 (the paper's single-model "
                                     "filters appear only in its field test, whose model is not given)"})


def variant(setup: Setup, **changes: Any) -> Setup:
    """A copy of ``setup`` with the fields ``changes`` replaced (validated again: ValueError naming a bad field
    value; TypeError for an unknown field)."""
    return replace(setup, **changes)


# ---------------------------------------------------------------- one universe
def setups(reading: Mapping) -> tuple:
    """(Case 1 set-up, Case 2 set-up) of a reading: the headline Setup with the reading's changes."""
    base = replace(Setup(), **SPACE.changes(reading))
    return replace(base, faults=False), replace(base, faults=True)


#: Setup fields only NAUKF reads, and fields Case 1 (no faults) never reads
_NAUKF_FIELDS = ("window", "psi", "inflate_only")
_FAULT_FIELDS = ("fault_range_max", "fault_bearing_rate_max", "fault_kind")


def relevant_setup(setup: Setup, algorithm: str) -> Setup:
    """``setup`` with the fields ``algorithm``'s results cannot depend on reset to the headline: the
    NAUKF fields for a non-adaptive algorithm, the fault fields when there are no faults, the UKF's
    parameters for the EKF and CKF.  Two
    readings with the same relevant set-up give the same numbers bit for bit (same runs, same
    streams), so their evaluation is shared (:func:`evaluate_algorithm`)."""
    default = Setup()
    fields = ((() if "NAUKF" in algorithm else _NAUKF_FIELDS) + (() if setup.faults else _FAULT_FIELDS)
              + (() if "UKF" in algorithm else ("ukf",)))
    return replace(setup, **{f: getattr(default, f) for f in fields})


@functools.lru_cache(maxsize=64)
def _evaluate_cached(setup: Setup, algorithm: str, mc: MonteCarlo):
    mb, est, _ = make_batch_fn(setup, mc, names=(algorithm,))
    return evaluation.evaluate(est, mb, mc, progress=False)[algorithm]


def evaluate_algorithm(setup: Setup, algorithm: str, mc: MonteCarlo) -> evaluation.RunSet:
    """RunSet of one algorithm under ``setup`` on ``mc``'s runs (chunks of 250 runs, common random
    numbers).  Each algorithm runs alone on the batch every algorithm sees, so the numbers do not
    depend on which others ran; results are memoised per process by the relevant set-up
    (:func:`relevant_setup`), which makes a design's universes that share it cheap.  Treat the
    result as read-only."""
    if algorithm not in CASE1_ALGORITHMS + CASE2_ALGORITHMS:
        raise ValueError(f"algorithm: expected one of {CASE1_ALGORITHMS + CASE2_ALGORITHMS}, got {algorithm!r}")
    return _evaluate_cached(relevant_setup(setup, algorithm), algorithm, mc)


def evaluate_reading(reading: Mapping, mc: MonteCarlo, progress: bool = False) -> dict:
    """Monte Carlo evaluations of a reading on ``mc``'s runs: ``{"case 1": {alg: RunSet}, "case 2": ...}``
    (Case 1: CASE1_ALGORITHMS without faults; Case 2: CASE2_ALGORITHMS with the sensor fault)."""
    case1, case2 = setups(reading)
    out = {"case 1": {}, "case 2": {}}
    for key, setup, names in (("case 1", case1, CASE1_ALGORITHMS), ("case 2", case2, CASE2_ALGORITHMS)):
        for alg in names:
            out[key][alg] = evaluate_algorithm(setup, alg, mc)
            if progress:
                say_progress(f"  zhou2017 {key}: {alg} done ({mc.n_runs} runs)")
    return out


def error_norms(rs: evaluation.RunSet, comps: Sequence[int]) -> np.ndarray:
    """Per run and step, the Euclidean norm of the errors of the state components ``comps`` (e.g. the position's
    x and y, in m): shape (N, K) from a RunSet's errors (N, K, n)."""
    return np.sqrt((rs.errors[..., list(comps)] ** 2).sum(-1))


def table_stats(rs: evaluation.RunSet, comps: Sequence[int]) -> tuple[metrics.MCValue, metrics.MCValue]:
    """Mean and s.d. over the steps of the per-step RMSE over runs (Eq. 45, Z-10), with standard errors
    (delta method; delete-one-run jackknife)."""
    e = error_norms(rs, comps)
    mean = metrics.mean_rmse_over_time(e, rs.valid)
    sd = metrics.jackknife(lambda s: np.sqrt((s ** 2).mean(axis=0)).std(), e, rs.valid)
    return mean, sd


def table_rows(item: str, results: dict, names: Iterable[tuple[str, str]], table: dict,
               devs: Iterable[str]) -> list:
    """Report rows of a Table 2/3-style table; an algorithm diverged in every run gets 'not reproduced'."""
    out = []
    for alg, printed_name in names:
        rs = results[alg]
        vals = [*table_stats(rs, POSITION), *table_stats(rs, VELOCITY)]
        for q, v, printed in zip(TABLE_QUANTITIES, vals, table[printed_name]):
            if v.n_runs == 0:
                out.append(report.analytic_row(item, alg, q, printed, f"diverged in {v.n_excluded}/{v.n_excluded} runs",
                                               False, deviations=devs))
            else:
                out.append(report.make_row(item, alg, q, printed, v.value, v.stderr, n_runs=v.n_runs,
                                           n_runs_paper=N_RUNS_PAPER, deviations=devs,
                                           note=f"{v.n_excluded} diverged runs excluded" if v.n_excluded else ""))
    return out


def _steps(rs, steps):
    return rs if steps is None else rs._replace(errors=rs.errors[:, list(steps)])


def compare(results: dict, pairs: Iterable[tuple[str, str]],
            quantities: Iterable[tuple[str, Sequence[int]]] = Q4,
            steps: Iterable[int] | None = None) -> tuple[str, str]:
    """Verdict (claim vocabulary) and evidence for "a is more accurate than b" for every (a, b) in
    ``pairs``, each over ``quantities``: one part per pair and quantity from the paired time-averaged
    MSE difference on the runs valid in both (:func:`mmlib.experiment.report.claim_verdict`), and, when either
    diverged in some run, one part "a diverges no more often than b" from the paired difference of
    the divergence indicators (a run that diverges has no accuracy).  ``steps`` restricts the MSE to
    those steps."""
    parts, evidence = [], []
    for a, b in pairs:
        ra, rb = _steps(results[a], steps), _steps(results[b], steps)
        da, db = (~ra.valid).astype(float), (~rb.valid).astype(float)
        if da.any() or db.any():
            d = metrics.mean_with_se(da - db)
            part = report.claim_verdict(float(d.value), float(d.stderr), -1)
            parts.append(f"{part} ({a} vs {b}: divergence)")
            evidence.append(f"{a} vs {b}: diverged runs {int(da.sum())} vs {int(db.sum())} of {len(da)}")
        ok = ra.valid & rb.valid
        if not ok.any():
            continue
        for label, comp in quantities:
            d = evaluation.paired_mse_difference(ra, rb, comp)
            ref = float((rb.errors[ok][..., list(comp)] ** 2).sum(axis=-1).mean())
            part = report.claim_verdict(float(d.value), float(d.stderr), -1, reference=ref)
            parts.append(f"{part} ({a} vs {b}: {label})")
            evidence.append(f"{a} vs {b}, {label}: Δ(mean squared error) = {float(d.value):.3g} ± "
                            f"{float(d.stderr):.2g} ({100 * float(d.value) / ref:+.2g} %)")
    return report.combine_claim_verdicts(parts), "; ".join(evidence)


def section23_moments() -> dict:
    """Closed forms of the Section 2.3 example: the mixture's mean and s.d. (Eqs. 11-12, 'MSE'), and the
    cubature rule on the interaction (Eqs. 14-19, 'CP'; exact for the linear f, i.e. the weighted sum
    of independent Gaussians: s.d. sqrt(sum u_i^2 S_i^2)); and, independently of both, the mean and
    variance of the interacted variable itself -- the mixture sum_i u_i N(x_i, S_i^2) that the IMM
    interaction produces -- by adaptive quadrature of its density (``mixture_*``), with the quadrature's
    error estimate (``quadrature_error``, an absolute bound on the variance's error)."""
    from scipy import integrate, stats
    u, xs, sds = np.array(EXAMPLE_U), np.array(EXAMPLE_MEANS), np.array(EXAMPLE_SD)
    mse_mean = float(u @ xs)
    mse_sd = float(np.sqrt(u @ (sds ** 2 + (xs - mse_mean) ** 2)))
    cp_mean, cp_cov = CubatureMixing()(xs[None, :, None], (sds ** 2)[None, :, None, None],
                                       np.tile(u[:, None], (1, 3))[None])
    pdf = (lambda x: float(u @ stats.norm.pdf(x, xs, sds)))
    m1, e1 = integrate.quad(lambda x: x * pdf(x), -np.inf, np.inf, epsabs=1e-12, epsrel=1e-12)
    var, e2 = integrate.quad(lambda x: (x - m1) ** 2 * pdf(x), -np.inf, np.inf, epsabs=1e-12, epsrel=1e-12)
    return {"mse_mean": mse_mean, "mse_sd": mse_sd, "cp_mean": float(cp_mean[0, 0, 0]),
            "cp_sd": float(np.sqrt(cp_cov[0, 0, 0, 0])), "mixture_mean": float(m1), "mixture_var": float(var),
            "quadrature_error": float(e1 + e2)}


def section23_claims() -> dict:
    """Verdicts (claim vocabulary) and evidence of the two claims about the Section 2.3 example, from
    :func:`section23_moments`: each part compares a method's moment of the interacted variable with the
    quadrature value, the quadrature error bound standing in for the standard error (so only a
    difference beyond the numerical error counts).

    * "MSE overestimates the covariance ...; CP is accurate": part 1, MSE's variance minus the mixture's
      (claimed > 0); part 2, CP's absolute variance error minus MSE's (claimed < 0: CP closer);
    * "CPIMM's interaction ... second-order accuracy" (Sec. 3.1.3, which cites this example as 'much
      closer ... than the MSE method'): CP's absolute error minus MSE's, for the mean and for the variance
      (claimed < 0 or at least no worse; a detectably larger error contradicts it)."""
    m = section23_moments()
    mix_m, mix_v, se = m["mixture_mean"], m["mixture_var"], max(m["quadrature_error"], np.finfo(float).eps)
    mse_v, cp_v = m["mse_sd"] ** 2, m["cp_sd"] ** 2
    err = {("MSE", "var"): abs(mse_v - mix_v), ("CP", "var"): abs(cp_v - mix_v),
           ("MSE", "mean"): abs(m["mse_mean"] - mix_m), ("CP", "mean"): abs(m["cp_mean"] - mix_m)}
    over = [f"{report.claim_verdict(mse_v - mix_v, se, +1, reference=mix_v)} (MSE's variance minus the mixture's)",
            f"{report.claim_verdict(err['CP', 'var'] - err['MSE', 'var'], se, -1, reference=mix_v)} (CP's variance "
            "error minus MSE's)"]
    second = [f"{report.claim_verdict(err['CP', 'mean'] - err['MSE', 'mean'], se, -1, reference=mix_v)} (mean: CP's "
              "error minus MSE's)",
              f"{report.claim_verdict(err['CP', 'var'] - err['MSE', 'var'], se, -1, reference=mix_v)} (variance: CP's "
              "error minus MSE's)"]
    numbers = (f"the interacted variable (the mixture sum u_i N(x_i, S_i^2)) by quadrature: mean {mix_m:.4f}, variance "
               f"{mix_v:.4f} (s.d. {math.sqrt(mix_v):.4f}; numerical error < {se:.1g}); MSE (Eqs. 11-12): mean "
               f"{m['mse_mean']:.4f}, variance {mse_v:.4f}; CP (Eqs. 14-19): mean {m['cp_mean']:.4f}, variance {cp_v:.4f} "
               f"(s.d. {m['cp_sd']:.4f}, the s.d. of the weighted sum of independent x_i, which the paper's MC sampled)")
    return {"overestimates": (report.combine_claim_verdicts(over), numbers + "; analytic, no reading changes it"),
            "second order": (report.combine_claim_verdicts(second),
                             numbers + "; the interaction function is linear, so the cubature rule is exact for "
                             "the weighted sum it evaluates, sum(mu^2 P), which is not the mixture the IMM "
                             "interaction produces (mmlib/core/mixing.py); analytic, no reading changes it")}


def section23_rows(seed: int, n_mc: int = 10_000) -> tuple[list, dict]:
    """Table 1 rows: MSE and CP in closed form (:func:`section23_moments`), MC from ``n_mc`` samples of
    the weighted sum (the variable the paper's printed MC value describes), on a stream of the root
    seed reserved for this example; also the samples of the mixture for comparison."""
    u, xs, sds = np.array(EXAMPLE_U), np.array(EXAMPLE_MEANS), np.array(EXAMPLE_SD)
    m = section23_moments()
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(10 ** 6, int(Stream.FILTER))))
    weighted_sum = (u * (xs + sds * rng.standard_normal((n_mc, 3)))).sum(axis=1)
    comp = rng.choice(3, size=n_mc, p=u)
    mixture = xs[comp] + sds[comp] * rng.standard_normal(n_mc)
    sd_ws = float(weighted_sum.std(ddof=1))
    rows = []
    for method, mean_v, sd_v, se_m, se_s, n_run in (
            ("MSE", m["mse_mean"], m["mse_sd"], 0.0, 0.0, None),
            ("MC", float(weighted_sum.mean()), sd_ws, sd_ws / math.sqrt(n_mc), sd_ws / math.sqrt(2 * n_mc), n_mc),
            ("CP", m["cp_mean"], m["cp_sd"], 0.0, 0.0, None)):
        note = {"MSE": "exact moments of the mixture",
                "MC": f"{n_mc:,} samples of the weighted sum (as the paper's value shows)",
                "CP": "exact moments of the weighted sum (closed form)"}[method]
        rows.append(report.make_row("Table 1", method, "mean", TABLE1[method][0], mean_v, se_m, n_runs=n_run,
                                    n_runs_paper=n_run, note=note))
        rows.append(report.make_row("Table 1", method, "'covariance' (a standard deviation)", TABLE1[method][1],
                                    sd_v, se_s, n_runs=n_run, n_runs_paper=n_run, note=note))
    return rows, {"mixture_mean": float(mixture.mean()), "mixture_sd": float(mixture.std(ddof=1)), **m}


def field_experiment_rows() -> list:
    """Tables 4-5: kept with the paper's values and the verdict 'not replicable' (Z-11)."""
    rows = []
    for table, name in ((TABLE4, "Table 4"), (TABLE5, "Table 5")):
        for alg, values in table.items():
            for q, printed in zip(MAE_QUANTITIES, values):
                rows.append(report.make_row(name, alg, q, printed, None, None, reason="data not published (Z-11)",
                                            deviations=["Z-11"]))
    return rows


def judge(results: dict, n_runs: int) -> tuple:
    """Rows of Tables 2-3, the claims (:class:`mmlib.experiment.report.Claims`), effects and diverged-run counts of
    one reading's evaluations (``results`` from :func:`evaluate_reading`)."""
    res1, res2 = results["case 1"], results["case 2"]
    rows = table_rows("Table 2", res1, TABLE2_NAMES, TABLE2, TABLE2_DEVIATIONS)
    rows += table_rows("Table 3", res2, TABLE3_NAMES, TABLE3, TABLE3_DEVIATIONS)
    s23 = section23_claims()
    claims = report.Claims()
    claims.add("MSE overestimates the covariance of the interacted variable; CP is accurate (Sec. 2.3, Table 1)",
               *s23["overestimates"])
    claims.add("CPIMM is more accurate than IMM (Case 1, Table 2)", *compare(res1, [("CPIMM-UKF", "IMM-UKF")]))
    claims.add("CPIMM's interaction solves the non-Gaussian problem with second-order accuracy (Sec. 3.1.3)",
               *s23["second order"])
    claims.add("UKF has better filtering precision than KF, EKF and CKF (Sec. 4.2.1), on the Sec. 4.1 radar "
               "scenario (Case 1)", *(lambda v, e: (v, e + "; KF is not applicable to the range-bearing radar; on "
                                                  "linear models EKF, CKF, UKF and KF coincide exactly"))(
                   *compare(res1, [("IMM-UKF", "IMM-EKF"), ("IMM-UKF", "IMM-CKF")])))
    claims.add("CPIMM-UKF is more accurate than IMM-UKF under sensor faults (Table 3)",
               *compare(res2, [("CPIMM-UKF", "IMM-UKF")]))
    claims.add("IMM-NAUKF is more accurate than IMM-UKF under sensor faults (Table 3)",
               *compare(res2, [("IMM-NAUKF", "IMM-UKF")]))
    claims.add("CPIMM-NAUKF is the most accurate of the four under sensor faults (Table 3)",
               *compare(res2, [("CPIMM-NAUKF", b) for b in ("IMM-UKF", "IMM-NAUKF", "CPIMM-UKF")]))
    claims.add("CPIMM-NAUKF converges faster than IMM-UKF (Sec. 4.1.2, conclusions)",
               *(lambda v, e: (v, "position and velocity MSE over the 10 s after each maneuver switch (20, 40, 60, "
                                  "80 s): " + e))(*compare(res2, [("CPIMM-NAUKF", "IMM-UKF")], steps=TRANSIENT_STEPS)))
    claims.add("NAUKF (Eqs. 27-31) satisfies the third-order precision conditions under faults",
               f"{report.CONTRADICTED}: analysis -- Eqs. 27-28 change only the innovation covariance; the predicted "
               "measurement mean stays the UKF's, without the fault delta h_out of Eq. 2, so under a fault the innovation "
               "has mean delta h_out != 0 and the measurement prediction is wrong at order zero, whatever the order of "
               "the transform; Eqs. 29-31 are asserted, not derived",
               "analytic (Theorem 1 and its proof, Sec. 3.2): Eqs. 27-28 reduce to replacing the predicted innovation "
               "covariance by an empirical one (IAE adaptation); nothing in it removes a measurement bias. As printed, "
               "the posterior P - P_xz C^-1 P_xz^T is not even a covariance whenever C falls below H P H^T (Z-12; "
               "the diverged runs are counted in every universe). No reading changes this.")
    claims.add("CPIMM-NAUKF performs best in the vehicle and UAV experiments (Tables 4-5)",
               f"{report.NOT_ASSESSABLE}: data not published (Z-11)",
               "the synthetic analogue of the notebook is not evidence either way")
    effects = []
    for name, res, a, b, table in ((KEY_EFFECT, res2, "CPIMM-NAUKF", "IMM-UKF", TABLE3),
                                   ("IMM-NAUKF − IMM-UKF, Case 2 position MSE (m²)", res2, "IMM-NAUKF", "IMM-UKF",
                                    TABLE3),
                                   ("CPIMM-UKF − IMM-UKF, Case 2 position MSE (m²)", res2, "CPIMM-UKF", "IMM-UKF",
                                    TABLE3),
                                   ("CPIMM-UKF − IMM-UKF, Case 1 position MSE (m²)", res1, "CPIMM-UKF", "IMM-UKF",
                                    {"CPIMM-UKF": TABLE2["CPIMM"], "IMM-UKF": TABLE2["IMM"]})):
        d = evaluation.paired_mse_difference(res[a], res[b], POSITION)
        value = float(d.value) if d.n_runs else None
        stderr = float(d.stderr) if d.n_runs > 1 else None
        effects.append((name, value, stderr, published_mse_difference(table, a, b)))
    diverged = {f"case {c} {alg}": int((~rs.valid).sum()) for c, res in ((1, res1), (2, res2)) for alg, rs in res.items()}
    return rows, claims, effects, diverged


def summarise(results: dict, n_runs: int) -> dict:
    """The universe result (:func:`mmlib.experiment.universe_result`) of one reading's evaluations: the
    Table 2-3 values (an algorithm diverged in every run is marked failed), the claims, the effects
    (KEY_EFFECT first) and the diverged-run counts."""
    rows, claims, effects, diverged = judge(results, n_runs)
    values = []
    for r in rows:
        if r.replicated is None:
            values.append((r.item, r.algorithm, r.quantity, None, None, r.note))
        else:
            values.append((r.item, r.algorithm, r.quantity, r.replicated, r.stderr))
    return universe_result(values=values, claims=claims, diverged=diverged, effects=effects, n_runs=n_runs)


def universe(reading: dict, n_runs: int, seed: int) -> dict:
    """The multiverse job: one reading on ``n_runs`` runs of the root seed ``seed`` (per-run streams)."""
    return summarise(evaluate_reading(reading, MonteCarlo(seed, n_runs)), n_runs)


def nees_case1(reading: Mapping, mc: MonteCarlo, n: int = 50) -> dict:
    """Time-averaged NEES (4 = consistent) of IMM-UKF and CPIMM-UKF in Case 1 over the first ``n`` runs."""
    case1, _ = setups(reading)
    mb, est, _ = make_batch_fn(case1, mc, names=("IMM-UKF", "CPIMM-UKF"))
    truth, z, init = mb(range(min(mc.n_runs, n)))
    out = {}
    for alg in ("IMM-UKF", "CPIMM-UKF"):
        tr = estimation.run(est[alg], init[alg], z)
        out[alg] = float(metrics.nees(tr.mean - truth[:, 1:], tr.cov, valid=~tr.diverged)[~tr.diverged].mean())
    return out


# ---------------------------------------------------------------- synthetic analogue of Section 4.2.1
@dataclass(frozen=True)
class GPSAnalogue:
    """NOT a replication: a GPS-like position/velocity sensor (5 m, 0.05 m/s, the paper's stated GPS
    precision) on the Section 4.1 trajectory, carrying the paper's two fault types -- a fixed position
    deviation (x, U[-5, 5] m per run) and a drift (y, rate U[0, 0.1] m/s per run, accumulating)."""

    base: Setup = Setup()
    pos_sd: float = 5.0
    vel_sd: float = 0.05
    offset_max: float = 5.0
    drift_rate_max: float = 0.1
    window: int = 10
    inflate_only: bool = False


def gps_analogue(an: GPSAnalogue, mc: MonteCarlo) -> tuple:
    """``(make_batch, estimators, schedule)`` of the synthetic analogue (NOT a replication): single-model EKF, CKF,
    UKF, AUKF and NAUKF on the CV model, measuring position and velocity [x, vx, y, vy] (m, m/s) with the fixed x
    offset and the accumulating y drift of ``an`` drawn per run from the FAULT stream; ``make_batch(runs) ->
    (truth (B, K+1, 4), measurements (B, K, 4), {name: initial state})``, every filter started at the true x0
    with P0 = diag(P0_sd)^2."""
    T = an.base.T
    cv = models.constant_velocity(T, an.base.q_cv)
    gps = models.LinearMeasurement(np.eye(4), np.diag([an.pos_sd ** 2, an.vel_sd ** 2, an.pos_sd ** 2, an.vel_sd ** 2]),
                                   "GPS")
    schedule, _, _ = build(an.base)
    ukf = SigmaPointFilter(Unscented(*an.base.ukf), name="UKF")
    filters = {"EKF": ExtendedKalmanFilter(name="EKF"), "CKF": SigmaPointFilter(Cubature(), name="CKF"), "UKF": ukf,
               "AUKF": aukf_filter(ukf, an.window, an.inflate_only),
               "NAUKF": InnovationAdaptive(ukf, window=an.window, inflate_only=an.inflate_only, name="NAUKF")}
    estimators = {k: SingleModel(f, cv, gps, name=k) for k, f in filters.items()}
    P0 = np.diag(np.square(an.base.P0_sd))

    def fault(runs):
        from scipy.special import ndtr
        p = ndtr(mc.standard_normal(runs, Stream.FAULT, (2,)))
        t = schedule.times
        delta = np.zeros((len(runs), len(t), 4))
        delta[:, :, 0] = ((2 * p[:, 0] - 1) * an.offset_max)[:, None]
        delta[:, :, 2] = (p[:, 1] * an.drift_rate_max)[:, None] * t[None, :]
        return models.SensorFault(delta)

    make_batch = evaluation.make_batches(mc, schedule, gps, an.base.x0, estimators, lambda est, m0, runs: est.init(m0, P0),
                                     process_noise=an.base.truth_process_noise, fault=fault)
    return make_batch, estimators, schedule


def gps_analogue_table(mc: MonteCarlo) -> tuple[list, dict]:
    """The synthetic analogue's table (NOT a replication): x and y mean absolute errors (m, mean over runs
    with standard errors) and diverged runs of EKF, CKF, UKF, AUKF and NAUKF as printed, and of AUKF and
    NAUKF in the inflate-only reading (Z-12).  Returns (rows of cells, {filter [reading]: {"diverged": n}})."""
    from mmlib.experiment.views import value_pm
    rows, diverged = [], {}
    for label, an in (("as printed", GPSAnalogue()), ("inflate-only", GPSAnalogue(inflate_only=True))):
        mba, esta, _ = gps_analogue(an, mc)
        names = tuple(esta) if label == "as printed" else ("AUKF", "NAUKF")
        resa = evaluation.evaluate(evaluation.select(esta, names), mba, mc, progress=False)
        for alg, rs in resa.items():
            ok = rs.valid
            cells = [f"{alg} ({label})" if alg in ("AUKF", "NAUKF") else alg]
            for comp in (0, 2):
                mae = metrics.mean_with_se(np.abs(rs.errors[..., comp]).mean(axis=1), ok)
                cells.append(value_pm(float(mae.value), float(mae.stderr), 2) if mae.n_runs else "--")
            cells.append(f"{int((~ok).sum())}/{mc.n_runs}")
            rows.append(cells)
            diverged[f"{alg} [{label}]"] = {"diverged": int((~ok).sum())}
    return rows, diverged


def headline_digest(n_runs: int) -> dict:
    """The run digest (:func:`mmlib.experiment.digests.run_digest`) of the headline universe's first
    ``n_runs`` runs (both cases) on the paper's root seed: what the notebook stores as ``digest`` in
    ``data/results/zhou2017.json``, recomputed without the notebook (tests/tolerance/test_digest.py)."""
    return digests.run_digest(evaluate_reading(SPACE.headline, MonteCarlo(ROOT_SEED, n_runs)), n_runs)
