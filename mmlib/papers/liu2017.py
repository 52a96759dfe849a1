"""Liu & Wu 2017, "Strong Tracking Spherical Simplex-Radial Cubature Kalman Filter for
Maneuvering Target Tracking", Sensors 17(4):741, doi:10.3390/s17040741 -- Section 4.

Constant-acceleration target (Eqs. 37-39) seen by a range-bearing radar at the
origin (Eq. 40); SSRCKF, STF (EKF-based), STUKF, STCKF and STSSRCKF compared by
RMSE (Eq. 41) and accumulative RMSE (Eq. 42).

The paper's ambiguities are the factors of :data:`SPACE` (a reading space, see
:mod:`mmlib.experiment.readings`); a *reading* (factor id -> option) gives the three
set-ups of Section 4.2 (:func:`setups`), their Monte Carlo evaluation
(:func:`evaluate_reading`) and the universe's numbers, claims and effects
(:func:`summarise`).  The notebook's headline rows and claim verdicts are these same
functions applied to ``SPACE.headline``; the multiverse job is :func:`universe`.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, replace
from typing import Callable, Iterable, Mapping, NamedTuple, Sequence

import numpy as np

from mmlib.experiment import metrics, report
from mmlib.core import models
from mmlib.core.estimation import SingleModel
from mmlib.core.estimation import run as run_filter
from mmlib.core.filters import ExtendedKalmanFilter, SigmaPointFilter
from mmlib.experiment.montecarlo import MonteCarlo, Stream
from mmlib.core.rules import Cubature, SphericalSimplexRadial, Unscented
from mmlib.experiment.simulate import ManeuverSchedule
from mmlib.core.layers.strong_tracking import StrongTracking
from mmlib.experiment import digests, evaluation
from mmlib.core.protocols import MeasurementModel, MomentFilter
from mmlib.experiment.multiverse import Multiverse, PublishedNumber, universe_result
from mmlib.experiment.readings import Deviation, Factor, Option, ReadingSpace
from mmlib.experiment.scenario import Scenario

PAPER = "liu2017"
CITATION = ("H. Liu, W. Wu, Strong Tracking Spherical Simplex-Radial Cubature Kalman Filter for Maneuvering "
            "Target Tracking, Sensors 17(4):741, 2017, doi:10.3390/s17040741")
ROOT_SEED = 20170331           # publication date
N_RUNS_PAPER = 200
FILTERS = ("SSRCKF", "STF", "STUKF", "STCKF", "STSSRCKF")
QUANTITIES = (("Position ARMSE (m)", (0, 3)), ("Velocity ARMSE (m/s)", (1, 4)), ("Acceleration ARMSE (m/s^2)", (2, 5)))
POSITION = (0, 3)

#: Tables as printed: filter -> (position, velocity, acceleration ARMSE).
TABLE1 = {"SSRCKF": ("152.1", "31.2", "6.9"), "STF": ("129.7", "28.4", "6.2"), "STUKF": ("124.5", "27.5", "5.9"),
          "STCKF": ("123.1", "26.7", "5.8"), "STSSRCKF": ("119.3", "25.1", "5.6")}
TABLE2_TIME = {"SSRCKF": "0.07", "STF": "0.02", "STUKF": "0.14", "STCKF": "0.14", "STSSRCKF": "0.15"}
TABLE2_COMPLEXITY = {"SSRCKF": "O((2n+2)^3)", "STF": "O(n^2)", "STUKF": "O((2n+1)^3)", "STCKF": "O((2n)^3)",
                     "STSSRCKF": "O((2n+2)^3)"}
#: Per time step with n = 6, m = 2 (counted from mmlib/core/filters.py and mmlib/core/layers/strong_tracking.py, which follow
#: Eqs. 20-36): points, n x n Cholesky factorisations, evaluations of f, evaluations of h (when lambda > 1),
#: other n x n x n operations (n x n matrix products or linear solves: the EKF's F P F^T and its Joseph-form
#: covariance update (I - KH) P (I - KH)^T, the statistical fading factor's (P^l)^-1 P_xz of Eqs. 18-19).
TABLE2_COUNTS = {"SSRCKF": (14, 2, 14, 14, 0), "STF": (0, 0, 1, 1, 4), "STUKF": (13, 3, 13, 26, 1),
                 "STCKF": (12, 3, 12, 24, 1), "STSSRCKF": (14, 3, 14, 28, 1)}
TABLE2_N = 6
TABLE3 = {
    "Case 1": {"SSRCKF": ("101.6", "21.2", "5"), "STF": ("95.3", "20.2", "4.5"), "STUKF": ("88.5", "16.4", "4.1"),
               "STCKF": ("87.4", "16.8", "4.1"), "STSSRCKF": ("81.1", "15.9", "3.7")},
    "Case 2": {"SSRCKF": ("50.5", "8.2", "1.8"), "STF": ("65.1", "10.8", "2.4"), "STUKF": ("57.3", "8.8", "2.2"),
               "STCKF": ("56.3", "8.3", "2.2"), "STSSRCKF": ("53.4", "8.4", "2.1")},
}

#: The three simulations of Section 4.2, the table item of each, its printed numbers and the filters run.
CASES = ("Example 1", "Case 1", "Case 2")
ITEMS = {"Example 1": "Table 1", "Case 1": "Table 3 Case 1", "Case 2": "Table 3 Case 2"}
PRINTED = {"Example 1": TABLE1, "Case 1": TABLE3["Case 1"], "Case 2": TABLE3["Case 2"]}
CASE_FILTERS = {"Example 1": FILTERS + ("CKF",), "Case 1": FILTERS, "Case 2": FILTERS}
#: every algorithm a universe runs (CKF in Example 1 only, for the claim "the SSR rule is more accurate than CKF")
MV_ALGORITHMS = FILTERS + ("CKF",)
ROW_DEVIATIONS = {"Example 1": ["L-1", "L-2", "L-3", "L-4", "L-5", "L-6", "L-8", "L-9", "L-10"],
                  "Case 1": ["L-2", "L-3", "L-4", "L-5", "L-6", "L-7", "L-8", "L-9", "L-10"],
                  "Case 2": ["L-2", "L-3", "L-4", "L-5", "L-6", "L-7", "L-8", "L-9", "L-10"]}

TIMELINES = ("set-up", "discussion")
INITIAL_ESTIMATES = ("true", "sampled", "sampled-if-unprinted")


@dataclass(frozen=True)
class Setup:
    """One simulation of Section 4.2; defaults are Example 1 under the headline reading.

    Units: s, m, m/s, m/s^2, rad.  The state is [x, vx, ax, y, vy, ay] (Eq. 37).  The
    maneuver sets the acceleration components to ``maneuver_acceleration`` at the time
    :attr:`onset` and keeps them to the end (t = ``n_steps * T``)."""

    T: float = 1.0
    n_steps: int = 200                                        # L-1: 'up to the end of this simulation at t = 200 s'
    maneuver_start: float = 150.0                             # s, onset as the set-up paragraph states it (L-1)
    discussion_onset: float | None = 100.0                    # s, onset as the discussion of the results states
                                                              # it (Example 1: 100 s); None when there is none
    timeline: str = "set-up"                                  # L-1: which statement of the onset: "set-up"/"discussion"
    onset_step: int = 0                                       # L-8: 0 = acceleration in the state at the stated time
                                                              # t0 (acts over [t0, t0 + T]); 1 = first at t0 + T
    maneuver_acceleration: tuple = (15.0, 25.0)               # m/s^2
    x0: tuple = (100.0, 15.0, 0.0, 400.0, 20.0, 0.0)          # [x, vx, ax, y, vy, ay]
    initial_estimate: str = "true"                            # L-6: "true" (x0), "sampled" (x0 + N(0, P0)) or
                                                              # "sampled-if-unprinted" (sampled where the paper
                                                              # prints no x_0|0)
    printed_initial_estimate: bool = True                     # the paper prints x_0|0 for this example (Example 1)
    P0_sd: tuple = (50.0, 20.0, 1.0, 50.0, 10.0, 1.0)
    sigma_r: float = 30.0                                     # m
    sigma_theta: float = 0.010                                # rad (10 mrad)
    q_sd: float = 0.1                                         # m/s^2 per step, filter's acceleration increment (L-2)
    truth_process_noise: bool = False                         # L-3: truth carries the filter's process noise
    beta: float = 4.5                                         # softening factor
    rho: float = 0.95                                         # forgetting factor
    ukf: tuple = (1.0, 0.0, -3.0)                             # alpha, beta, kappa = 3 - n (L-4)

    def __post_init__(self):
        if self.timeline not in TIMELINES:
            raise ValueError(f"timeline: expected one of {TIMELINES}, got {self.timeline!r}")
        if isinstance(self.onset_step, bool) or self.onset_step not in (0, 1):
            raise ValueError(f"onset_step: expected 0 or 1 (steps after the stated onset), got {self.onset_step!r}")
        if self.discussion_onset is not None and not 0 < self.discussion_onset < self.n_steps * self.T:
            raise ValueError(f"discussion_onset: must be None or lie inside (0, {self.n_steps * self.T}), "
                             f"got {self.discussion_onset}")
        if not 0 < self.maneuver_start < self.n_steps * self.T:
            raise ValueError(f"maneuver_start: must lie inside the simulation (0, {self.n_steps * self.T}), "
                             f"got {self.maneuver_start}")
        if not 0 < self.onset < self.n_steps * self.T:
            raise ValueError(f"onset_step: the onset {self.onset} s must lie inside the simulation "
                             f"(0, {self.n_steps * self.T})")
        if not self.q_sd > 0:
            raise ValueError(f"q_sd: must be > 0, got {self.q_sd}")
        if self.initial_estimate not in INITIAL_ESTIMATES:
            raise ValueError(f"initial_estimate: expected one of {INITIAL_ESTIMATES}, got {self.initial_estimate!r}")
        if not isinstance(self.printed_initial_estimate, bool):
            raise ValueError(f"printed_initial_estimate: expected a bool, got {self.printed_initial_estimate!r}")
        if not isinstance(self.truth_process_noise, bool):
            raise ValueError(f"truth_process_noise: expected a bool, got {self.truth_process_noise!r}")
        if len(tuple(self.ukf)) != 3 or not float(self.ukf[0]) > 0:
            raise ValueError(f"ukf: expected (alpha > 0, beta, kappa), got {self.ukf!r}")

    @property
    def onset(self) -> float:
        """Time (s) from which the acceleration state holds the maneuver's value: the stated onset
        of the chosen time line (L-1) plus ``onset_step`` sampling intervals (L-8)."""
        stated = (self.discussion_onset if self.timeline == "discussion" and self.discussion_onset is not None
                  else self.maneuver_start)
        return stated + self.onset_step * self.T

    @property
    def onset_index(self) -> int:
        """Index into the error arrays (step k = index + 1, t = k T) of the first step whose
        truth has moved away from the constant-velocity path (t > onset)."""
        return int(round(self.onset / self.T))

    @property
    def samples_initial_estimate(self) -> bool:
        """Whether the filters start from a draw x0 + N(0, P0) (Stream.INITIAL) rather than the true x0 (L-6):
        ``initial_estimate`` "sampled", or "sampled-if-unprinted" for an example that prints no x_0|0."""
        return self.initial_estimate == "sampled" or (self.initial_estimate == "sampled-if-unprinted"
                                                      and not self.printed_initial_estimate)


EXAMPLE1 = Setup()
EXAMPLE2_CASE1 = Setup(x0=(5000.0, 150.0, 0.0, 5000.0, 80.0, 0.0), maneuver_acceleration=(5.0, 5.0),
                       discussion_onset=None, printed_initial_estimate=False)
EXAMPLE2_CASE2 = Setup(x0=(5000.0, 150.0, 0.0, 5000.0, 80.0, 0.0), maneuver_acceleration=(0.5, 0.5),
                       discussion_onset=None, printed_initial_estimate=False)
BASE_SETUPS = {"Example 1": EXAMPLE1, "Case 1": EXAMPLE2_CASE1, "Case 2": EXAMPLE2_CASE2}

DEVIATIONS = [
    Deviation("L-1", "time line (Example 1)",
              "'simulation time is 100 s'; 'uniform motion during the first 150 s', maneuver 'up to the end of this "
              "simulation at t = 200 s'; discussion: 'uniform motion within the first 100 s', 'the maneuver starts "
              "at t = 101 s'",
              "headline: 200 s; acceleration switched on at t = 150 s (acts over [150, 200] s)",
              "Two statements of the set-up paragraph (150 s, 200 s) agree with each other and with Example 2's "
              "explicit 150 s / 200 s time line; '100 s' contradicts both. Chosen on the text, before any run. "
              "The discussion's onset (100 s, with the 200 s end) is option '100s' of factor L-1; L-1 applies to "
              "Example 1 only (Example 2's time line is explicit).",
              "factor L-1: onset 150 s / 100 s"),
    Deviation("L-2", "filter process noise", "Q_ca and the noise V of Eq. 37 are not given",
              "Q = G q G^T per axis with G of Eq. 39 and sqrt(q) = 0.1 m/s^2 per step (nearly constant "
              "acceleration, Bar-Shalom et al. 2001 Sec. 6.3.3)",
              "Strong tracking exists for a filter tuned to the non-maneuvering regime; the truth's acceleration "
              "is constant between the jumps, so a small increment is the design value. Never fitted to Table 1: "
              "a decade grid of declared options, both examples.",
              "factor L-2: sqrt(q) = 0.01 / 0.1 / 1 / 10 m/s^2"),
    Deviation("L-3", "truth", "whether the truth carries process noise is not said",
              "deterministic piecewise constant-acceleration truth (no process noise)",
              "The text describes uniform motion and constant acceleration only; Eq. 37 read as the truth model "
              "is the alternative (both examples).", "factor L-3: none / the filter's Q"),
    Deviation("L-4", "UKF parameters", "not given; 'kappa is always set to n - 3' with negative centre weight for n > 3",
              "alpha = 1, beta = 0, kappa = 3 - n = -3 (centre weight -1)",
              "Julier's classic choice, the only one with the negative centre weight the paper describes "
              "(n - 3 as printed gives a positive one, kappa = 0 makes the UKF the CKF, as Sec. 2 says). "
              "Acts on STUKF only.", "factor L-4: kappa = -3 / +3 / 0"),
    Deviation("L-5", "V_0 of Eq. 17", "V_0 = v_0 v_0^T without saying what v_0 is",
              "at the first update V = v_1 v_1^T, then the recursion of Eq. 17",
              "Eq. 17 read literally: the first residual is the only v_0 the text defines; it acts on the first "
              "step's fading factor only. No second reading, so no factor."),
    Deviation("L-6", "initial estimate", "Example 1 gives x_0|0 equal to the true initial state; Example 2 gives none",
              "filter starts at the true initial state with Example 1's P0, in both examples",
              "Example 2 is 'the same' set-up otherwise; drawing the estimate from N(x0, P0) (Sec. 3.4's Gaussian "
              "prior) in Example 2 only, or in both examples, are the alternatives.",
              "factor L-6: true / sampled in Example 2 / sampled in both"),
    Deviation("L-7", "Example 2 noise and run count", "not given",
              "sigma_r = 30 m, sigma_theta = 10 mrad, 200 runs, beta = 4.5, rho = 0.95, P0 as Example 1",
              "No factor: Example 2's text gives none of these values, and the paper prints no other value for any "
              "of them than Example 1's (Sec. 4.2), so Example 1's are the only readings its text supports; any other "
              "value would be invented on a continuous scale, and choosing one to match Table 3 would be fitting a "
              "parameter to a published number. The run count moves only the Monte Carlo error, not the expected "
              "ARMSE (the verdict rule estimates the paper's error with Example 1's 200 runs)."),
    Deviation("L-8", "maneuver onset step", "'(a_x(151), a_y(151))'; 'the maneuver starts at t = 101 s'",
              "headline: acceleration state set at the stated time t0 (150 s), so it acts from the step "
              "[t0, t0 + 1] s on",
              "One-step ambiguity between 'until t = 150 s' and 'a(151)' (and between 'the first 100 s' and "
              "'starts at t = 101 s'); both examples.", "factor L-8: t0 / t0 + 1 s"),
    Deviation("L-9", "STF", "EKF-based strong tracking filter, Eqs. 13-17",
              "StrongTracking(EKF, form='jacobian') with analytic range-bearing Jacobians",
              "As printed; Eqs. 18-19 give the identical factor for the EKF (tested)."),
    Deviation("L-10", "ARMSE", "Eqs. 41-42; velocity and acceleration 'defined in the same way'",
              "ARMSE = sqrt(mean over runs and all N steps of the squared x-y error norm)",
              "Eq. 42 averages RMSE^2(k), which is the run-and-time mean of squared errors."),
]

# -- the reading space ---------------------------------------------------------------------------------------------
FACTORS = (
    Factor("L-1", "onset of Example 1's maneuver (Example 1 only; Example 2's time line is explicit)", (
        Option("150s", "maneuver from t = 150 s (set-up paragraph)",
               "Sec. 4.2, Example 1 set-up: 'The target makes a uniform motion during the first 150 s. Then, it takes "
               "a high maneuver ... up to the end of this simulation at t = 200 s'", {"timeline": "set-up"}),
        Option("100s", "maneuver from t = 100 s (discussion)",
               "Sec. 4.2, discussion of Figs. 1-3: 'when the target is making uniform motion within the first "
               "100 s ... When the maneuver starts at t = 101 s'; end at t = 200 s as in the set-up paragraph "
               "('simulation time is 100 s' contradicts every onset)", {"timeline": "discussion"}),
    ), "150s", "Sec. 4.2 Example 1; deviation L-1"),
    Factor("L-8", "step at which the maneuver's acceleration first appears (both examples)", (
        Option("t0", "acceleration in the state from the stated time t0",
               "Example 1: 'uniform motion during the first 150 s. Then, it takes a high maneuver'; Example 2: "
               "'moves with initial acceleration until t = 150 s'", {"onset_step": 0}),
        Option("t0+1", "first non-zero acceleration at t0 + 1 s",
               "Example 2: '(a_x(151), a_y(151)) = (5 m/s^2, 5 m/s^2)'; Example 1 discussion: 'the maneuver "
               "starts at t = 101 s'", {"onset_step": 1}),
    ), "t0", "Sec. 4.2, Examples 1 and 2; deviation L-8"),
    Factor("L-2", "filters' process noise sqrt(q) (both examples)", (
        Option("0.01", "√q = 0.01 m/s²",
               "Eq. 37 leaves Q_ca unstated; 'uniform motion' / constant acceleration between the jumps "
               "(Sec. 4.2): a nearly noise-free CA model", {"q_sd": 0.01}),
        Option("0.1", "√q = 0.1 m/s²",
               "Eq. 37 leaves Q_ca unstated; nearly-constant-acceleration model with increments small against the "
               "maneuver (Bar-Shalom, Li & Kirubarajan 2001, Sec. 6.3.3)", {"q_sd": 0.1}),
        Option("1", "√q = 1 m/s²",
               "Eq. 37 leaves Q_ca unstated; acceleration increments of the order of the weak and medium "
               "maneuvers of Example 2 (0.5-5 m/s²)", {"q_sd": 1.0}),
        Option("10", "√q = 10 m/s²",
               "Eq. 37 leaves Q_ca unstated; increments of the order of Example 1's high maneuver (15-25 m/s²), "
               "the G V term of Eq. 37 read as the maneuver input", {"q_sd": 10.0}),
    ), "0.1", "Eqs. 37-39 (Q_ca and V not given); deviation L-2"),
    Factor("L-3", "process noise in the truth (both examples)", (
        Option("none", "deterministic truth",
               "Sec. 4.2: 'uniform motion', then a constant acceleration 'up to the end of this simulation'",
               {"truth_process_noise": False}),
        Option("matched", "truth with the filters' process noise",
               "Eq. 37: X_k = diag[Φ, Φ] X_{k-1} + G V_{k-1} + w_{k-1}, the model of the target itself",
               {"truth_process_noise": True}),
    ), "none", "Eq. 37 vs the Sec. 4.2 narrative; deviation L-3"),
    Factor("L-4", "UKF scaling κ of STUKF (α = 1, β = 0; both examples)", (
        Option("3-n", "κ = 3 − n = −3",
               "Sec. 2: κ = n − 3 'will lead to the negative weight of the center point' for n > 3, which only "
               "κ = 3 − n < 0 does (Julier & Uhlmann's choice)", {"ukf": (1.0, 0.0, -3.0)}),
        Option("n-3", "κ = n − 3 = +3 (as printed)",
               "Sec. 2: 'For UKF, the scaling parameter κ is always set to n − 3'", {"ukf": (1.0, 0.0, 3.0)}),
        Option("0", "κ = 0 (UKF = CKF)",
               "Sec. 2: 'If the parameter κ is set to zero ... the UKF becomes identical to the CKF'",
               {"ukf": (1.0, 0.0, 0.0)}),
    ), "3-n", "Sec. 2 after Eq. 3; deviation L-4"),
    Factor("L-6", "filters' initial estimate", (
        Option("true", "x̂0|0 = true x0 in both examples",
               "Example 1: x̂0|0 = [100 m, 15 m/s, 0, 400 m, 20 m/s, 0] = the true initial state; Example 2 "
               "otherwise 'the same'", {"initial_estimate": "true"}),
        Option("sampled-ex2", "x̂0|0 ~ N(x0, P0) in Example 2 only",
               "Example 2 prints no x̂0|0; Sec. 3.4: 'The initial state is assumed to be Gaussian distribution "
               "with x̂0|0 and P0|0'", {"initial_estimate": "sampled-if-unprinted"}),
        Option("sampled", "x̂0|0 ~ N(x0, P0) in both examples",
               "Sec. 3.4's Gaussian prior in every run: Example 1's printed x̂0|0 read as the prior mean",
               {"initial_estimate": "sampled"}),
    ), "true", "Sec. 4.2 and Sec. 3.4; deviation L-6"),
)

#: 288 readings; a universe costs ~5 CPU-s at 200 runs, so the budget of 20 universes (~100 CPU-s, ~50 s on two
#: workers) asks for the fractional design: headline, every option alone, and a strength-2 covering (17).
SPACE = ReadingSpace(PAPER, FACTORS, budget=20)

#: every printed Monte Carlo number a universe replicates (Table 2 is timing and analysis: not a universe value)
PUBLISHED = tuple(PublishedNumber("Table 1" if case == "Example 1" else "Table 3", ITEMS[case], alg, quantity,
                                  PRINTED[case][alg][qi])
                  for case in CASES for alg in FILTERS for qi, (quantity, _) in enumerate(QUANTITIES))


def _published_mse_difference(case: str, a: str, b: str) -> float:
    """The paper's counterpart of a paired position MSE difference: ARMSE_a^2 - ARMSE_b^2 (m^2),
    because the mean over runs of the time-averaged squared error is ARMSE^2 (Eq. 42)."""
    return float(PRINTED[case][a][0]) ** 2 - float(PRINTED[case][b][0]) ** 2


#: the key effect of the specification curve
KEY_EFFECT = "Example 1: STSSRCKF − SSRCKF position MSE (m²)"
EFFECTS = ((KEY_EFFECT, "Example 1", "STSSRCKF", "SSRCKF", False),
           ("Case 1: STSSRCKF − SSRCKF position MSE (m²)", "Case 1", "STSSRCKF", "SSRCKF", False),
           ("Case 2: STSSRCKF − SSRCKF position MSE (m²)", "Case 2", "STSSRCKF", "SSRCKF", False),
           ("Example 1: STSSRCKF − STCKF position MSE (m²)", "Example 1", "STSSRCKF", "STCKF", False),
           ("Example 1 after the onset: STSSRCKF − SSRCKF position MSE (m²)", "Example 1", "STSSRCKF", "SSRCKF",
            True))


def setups(reading: Mapping) -> dict:
    """The three set-ups of Section 4.2 under a reading: {"Example 1", "Case 1", "Case 2"} -> Setup.
    ValueError names an unknown factor or option, or a factor left out."""
    changes = SPACE.changes(reading)
    return {case: replace(BASE_SETUPS[case], **changes) for case in CASES}


def strong_tracking(base: MomentFilter, setup: Setup, name: str) -> StrongTracking:
    """The strong-tracking layer (Eqs. 20-36) over ``base`` with the set-up's softening factor beta and forgetting
    factor rho; over an EKF the Jacobian form of the fading factor (the STF of Zhou & Frank)."""
    form = {"form": "jacobian"} if isinstance(base, ExtendedKalmanFilter) else {}
    return StrongTracking(base, beta=setup.beta, rho=setup.rho, name=name, **form)


def build(setup: Setup) -> tuple:
    """Dynamics, radar, schedule and the five filters of Table 1 (plus the plain CKF and UKF)."""
    ca = models.constant_acceleration(setup.T, setup.q_sd ** 2)
    radar = models.range_bearing(np.diag([setup.sigma_r ** 2, setup.sigma_theta ** 2]), state_dim=6)
    schedule = ManeuverSchedule([ca], [], 0, setup.T, setup.n_steps,
                                jumps=[(setup.onset, (2, 5), setup.maneuver_acceleration)])
    ssr = SigmaPointFilter(SphericalSimplexRadial(), name="SSRCKF")
    ckf = SigmaPointFilter(Cubature(), name="CKF")
    ukf = SigmaPointFilter(Unscented(*setup.ukf), name="UKF")
    filters = {
        "SSRCKF": ssr,
        "STF": strong_tracking(ExtendedKalmanFilter(), setup, "STF"),
        "STUKF": strong_tracking(ukf, setup, "STUKF"),
        "STCKF": strong_tracking(ckf, setup, "STCKF"),
        "STSSRCKF": strong_tracking(ssr, setup, "STSSRCKF"),
        "CKF": ckf,      # not in the paper's tables: for the claim "SSR is more accurate than CKF"
        "UKF": ukf,
    }
    estimators = {name: SingleModel(f, ca, radar, name=name) for name, f in filters.items()}
    return schedule, radar, estimators


def simulator(setup: Setup, schedule: ManeuverSchedule, radar: MeasurementModel) -> Callable:
    """``mc -> (runs -> (truth, measurements, start means))``: truth from x0 (with the filter's Q as process noise
    under L-3 "matched"), radar measurements, and the filters' initial means x0 or x0 + N(0, P0) drawn from the run's
    INITIAL stream (L-6), with P0 = diag(P0_sd^2)."""
    x0 = np.array(setup.x0)
    P0 = np.diag(np.square(setup.P0_sd))

    def for_mc(mc: MonteCarlo):
        def start(runs):
            if setup.samples_initial_estimate:
                return mc.gaussian(runs, Stream.INITIAL, x0, P0)
            return np.tile(x0, (len(runs), 1))

        return evaluation.simulator(mc, schedule, radar, x0, process_noise=setup.truth_process_noise, start=start)

    return for_mc


def make_batch_fn(setup: Setup, mc: MonteCarlo, names: Iterable[str] | None = None) -> tuple:
    """``(make_batch, estimators, schedule)`` for one set-up (:func:`simulator`, every filter started with P0)."""
    schedule, radar, estimators = build(setup)
    estimators = evaluation.select(estimators, names)
    P0 = np.diag(np.square(setup.P0_sd))
    make_batch = evaluation.with_initial_states(simulator(setup, schedule, radar)(mc), estimators,
                                                lambda est, m0, runs: est.init(m0, P0))
    return make_batch, estimators, schedule


def scenario(setup: Setup | None = None) -> Scenario:
    """Example 1 under the headline reading (unless ``setup`` is given) as an arena scenario: a constant-acceleration
    model with an acceleration step at the onset, a range-bearing radar (30 m, 10 mrad).  The paper's filters are all
    single-model: it defines no mode set for an IMM."""
    setup = setups(SPACE.headline)["Example 1"] if setup is None else setup
    schedule, radar, estimators = build(setup)
    return Scenario(name=PAPER, title="Liu & Wu 2017 Example 1: CA model, acceleration step, range-bearing radar",
                    source=CITATION, root_seed=ROOT_SEED, T=setup.T, n_steps=setup.n_steps,
                    simulator=simulator(setup, schedule, radar), P0=np.diag(np.square(setup.P0_sd)),
                    position=(0, 3), velocity=(1, 4), single=estimators["SSRCKF"].dynamics, measurement=radar,
                    ukf=tuple(setup.ukf),
                    properties={"measurement": "range-bearing (30 m, 10 mrad)",
                                "manoeuvre": f"acceleration step to {setup.maneuver_acceleration} m/s² at "
                                             f"t = {setup.onset:g} s"},
                    notes={"modes": "the paper's filters are all single-model (one constant-acceleration model): it "
                                    "defines no mode set for an IMM"})


class ReadingResults(NamedTuple):
    """Monte Carlo results of one reading: ``runs[case][algorithm]`` is a RunSet."""

    reading: dict
    setups: dict
    runs: dict


def evaluate_reading(reading: Mapping[str, str], mc: MonteCarlo, progress: bool = False) -> ReadingResults:
    """Example 1 (the five filters of Table 1 and the plain CKF) and both cases of Example 2 (the five
    filters of Table 3) under ``reading``, all on the runs of ``mc`` (common random numbers)."""
    reading = SPACE.validate(reading)
    sets = setups(reading)
    runs = {}
    for case in CASES:
        make_batch, estimators, _ = make_batch_fn(sets[case], mc, names=CASE_FILTERS[case])
        runs[case] = evaluation.evaluate(estimators, make_batch, mc, label=f"liu2017 {case}", progress=progress)
    return ReadingResults(reading, sets, runs)


# -- claims ---------------------------------------------------------------------------------------------------------
ROBUSTNESS_DEFINITION = (
    "Robustness (the paper gives no definition; ours): (i) the position error after the abrupt change -- the paired "
    "difference of the per-run mean squared position error over the steps after the onset -- in each of the three "
    "maneuvers (Example 1 high, Example 2 Case 1 medium, Case 2 weak), and (ii) where any run diverges in either "
    "filter, the paired difference of the divergence indicators. 'More robust' holds when every part holds.")


def after_onset(rs: evaluation.RunSet, start: int) -> evaluation.RunSet:
    """The RunSet restricted to the steps from index ``start`` on (errors only)."""
    return rs._replace(errors=rs.errors[:, start:])


def _mse(rs: evaluation.RunSet, idx) -> float:
    return float((rs.errors[rs.valid][..., list(idx)] ** 2).sum(axis=-1).mean())


def _paired_part(a, b, idx, sign=-1):
    d = evaluation.paired_mse_difference(a, b, idx)
    return report.claim_verdict(float(d.value), float(d.stderr), sign, reference=_mse(b, idx)), d


def _divergence_part(a, b):
    """Part verdict for 'a diverges less often than b', or None when neither diverges."""
    da, db = (~a.valid).astype(float), (~b.valid).astype(float)
    if not (da.any() or db.any()):
        return None
    m = metrics.mean_with_se(da - db)
    return report.claim_verdict(float(m.value), float(m.stderr), -1)


def combine_parts(parts: Sequence[tuple[str, str]]) -> str:
    """One claim verdict from labelled part verdicts ``[(label, part verdict)]``; for many parts the
    detail is condensed to counts and the labels of the parts that do not hold."""
    full = report.combine_claim_verdicts(f"{v} ({lab})" for lab, v in parts)
    if len(parts) <= 4:
        return full
    head = report.claim_category(full)
    if head == report.HOLDS:
        return head
    counts = Counter(v.split(" (")[0] for _, v in parts)
    not_holding = [lab for lab, v in parts if v != "holds"]
    shown = ", ".join(not_holding[:8]) + (f" and {len(not_holding) - 8} more" if len(not_holding) > 8 else "")
    return (f"{head}: of {len(parts)} parts, " + ", ".join(f"{n} {k}" for k, n in counts.items())
            + f"; not holding: {shown}")


def judge_claims(results: ReadingResults) -> report.Claims:
    """The verdicts on the abstract's and conclusions' claims for one reading (claim vocabulary of
    :mod:`mmlib.experiment.report`), with their evidence."""
    R = results.runs
    ex1 = R["Example 1"]
    onset = {case: results.setups[case].onset_index for case in CASES}
    claims = report.Claims()
    qty = [(q.split()[0], idx) for q, idx in QUANTITIES]

    # 1. SSRCKF declines and may diverge after the abrupt maneuver (Example 1)
    ssr = ex1["SSRCKF"]
    k0 = onset["Example 1"]
    sq = (ssr.errors[ssr.valid][..., list(POSITION)] ** 2).sum(axis=-1)
    decline = metrics.mean_with_se(sq[:, k0:].mean(axis=1) - sq[:, :k0].mean(axis=1))
    n_div = int((~ssr.valid).sum())
    div_rate = metrics.mean_with_se((~ssr.valid).astype(float))
    peak = float(metrics.rmse_over_time(np.sqrt((ssr.errors[..., list(POSITION)] ** 2).sum(-1)), ssr.valid).value.max())
    claims.add("SSRCKF may decline in accuracy and even diverge after an abrupt maneuver (abstract; Example 1)",
               report.combine_claim_verdicts([
                   f"{report.claim_verdict(float(decline.value), float(decline.stderr), +1)} (decline: position MSE "
                   f"after minus before the onset)",
                   f"{report.claim_verdict(float(div_rate.value), float(div_rate.stderr), +1)} (divergence)"]),
               f"position MSE after minus before the onset {decline.value:.4g} ± {decline.stderr:.2g} m²; RMSE peaks "
               f"at {peak:.0f} m; diverged runs {n_div} of {len(ssr.valid)}")

    # 2. the SSR rule against the CKF's, without strong tracking
    claims.add("The SSR rule is more accurate than the CKF's (abstract; Example 1, no strong tracking)",
               *evaluation.better_claim(ex1, "SSRCKF", "CKF", qty))
    # 3. Table 1 ranking, 4. Table 3
    for other in ("SSRCKF", "STF", "STUKF", "STCKF"):
        claims.add(f"STSSRCKF is more accurate than {other} (Example 1, Table 1)",
                   *evaluation.better_claim(ex1, "STSSRCKF", other, qty))
    for case in ("Case 1", "Case 2"):
        claims.add(f"STSSRCKF is more accurate than SSRCKF ({case}, Table 3)",
                   *evaluation.better_claim(R[case], "STSSRCKF", "SSRCKF", qty))
    claims.add("STSSRCKF is more accurate than STF (weak maneuver, Table 3 Case 2)",
               *evaluation.better_claim(R["Case 2"], "STSSRCKF", "STF", qty))

    # 5. normal accuracy for weak maneuvers: ARMSE_ST < (1 + band) ARMSE_SSR  <=>  MSE_ST - (1 + band)^2 MSE_SSR < 0
    c2 = R["Case 2"]
    ok = c2["STSSRCKF"].valid & c2["SSRCKF"].valid
    f2 = (1.0 + report.RELATIVE_BAND) ** 2
    mse_run = {a: (c2[a].errors[ok][..., list(POSITION)] ** 2).sum(-1).mean(1) for a in ("STSSRCKF", "SSRCKF")}
    d = metrics.mean_with_se(mse_run["STSSRCKF"] - f2 * mse_run["SSRCKF"])
    arm = {a: metrics.armse(c2[a].errors[..., list(POSITION)], c2[a].valid) for a in ("STSSRCKF", "SSRCKF")}
    claims.add(f"STSSRCKF keeps normal accuracy for weak maneuvers (introduction; Case 2 position ARMSE within "
               f"{100 * report.RELATIVE_BAND:.0f} % of SSRCKF's)",
               report.paired_claim(float(d.value), float(d.stderr), -1),
               f"MSE_STSSRCKF − {f2:.4g} MSE_SSRCKF = {d.value:.4g} ± {d.stderr:.2g} m²; position ARMSE STSSRCKF "
               f"{arm['STSSRCKF'].value:.1f} ± {arm['STSSRCKF'].stderr:.1f} m, SSRCKF {arm['SSRCKF'].value:.1f} ± "
               f"{arm['SSRCKF'].stderr:.1f} m")

    # 6. robustness (operational definition ROBUSTNESS_DEFINITION)
    def robustness_parts(other):
        parts, ev = [], []
        for case in CASES:
            v, dd = _paired_part(after_onset(R[case]["STSSRCKF"], onset[case]),
                                 after_onset(R[case][other], onset[case]), POSITION)
            parts.append((f"{case} after the onset vs {other}", v))
            ev.append(f"{case}: Δ = {dd.value:.4g} ± {dd.stderr:.2g} m²")
            dv = _divergence_part(R[case]["STSSRCKF"], R[case][other])
            if dv is not None:
                parts.append((f"{case} divergence vs {other}", dv))
        return parts, ev

    parts, ev = robustness_parts("SSRCKF")
    claims.add("STSSRCKF has greater robustness than SSRCKF (abstract)", combine_parts(parts),
               "position MSE after the onset, STSSRCKF − SSRCKF: " + "; ".join(ev) + ". " + ROBUSTNESS_DEFINITION)

    # 7. conclusions: higher accuracy and robustness than each of the other four, in every maneuver
    parts, ev = [], []
    for other in ("STF", "STUKF", "STCKF", "SSRCKF"):
        for case in CASES:
            for label, idx in qty:
                v, _ = _paired_part(R[case]["STSSRCKF"], R[case][other], idx)
                parts.append((f"{case} {label.lower()} vs {other}", v))
        rp, rev = robustness_parts(other)
        parts += rp
        ev.append(f"after the onset vs {other}: " + "; ".join(rev))
    claims.add("STSSRCKF achieves higher accuracy and robustness than STF, STUKF, STCKF and SSRCKF (conclusions)",
               combine_parts(parts),
               "accuracy: paired MSE of position, velocity and acceleration in Example 1 and both cases of "
               "Example 2; " + " | ".join(ev) + ". " + ROBUSTNESS_DEFINITION)

    claims.add("STSSRCKF has the best balance between computational complexity and estimation accuracy (Sec. 4.2)",
               f"{report.NOT_ASSESSABLE}: the paper defines no measure of the balance",
               "accuracy and time are each judged above (Table 1, Table 2 claims)")
    return claims


def table_values(results: ReadingResults) -> list:
    """``(item, algorithm, quantity, ARMSE, standard error)`` of every printed cell of Tables 1 and 3
    (Eq. 42; diverged runs excluded)."""
    out = []
    for case in CASES:
        for alg in FILTERS:
            rs = results.runs[case][alg]
            for quantity, idx in QUANTITIES:
                est = metrics.armse(rs.errors[..., list(idx)], rs.valid)
                out.append((ITEMS[case], alg, quantity, float(est.value), float(est.stderr)))
    return out


def effects(results: ReadingResults) -> list:
    """Named paired position MSE differences (m²) with standard errors and the published counterpart
    (ARMSE_a² − ARMSE_b² from the tables; none for the after-the-onset effect, which the paper does not
    print)."""
    out = []
    for name, case, a, b, after in EFFECTS:
        ra, rb = results.runs[case][a], results.runs[case][b]
        if after:
            k0 = results.setups[case].onset_index
            ra, rb = after_onset(ra, k0), after_onset(rb, k0)
        d = evaluation.paired_mse_difference(ra, rb, POSITION)
        out.append((name, float(d.value), float(d.stderr), None if after else _published_mse_difference(case, a, b)))
    return out


def diverged(results: ReadingResults) -> dict:
    """Diverged runs per ``"<case> <algorithm>"`` (e.g. ``"Example 1 STCKF"``), over every case of ``CASES``."""
    return {f"{case} {alg}": int((~rs.valid).sum()) for case in CASES for alg, rs in results.runs[case].items()}


def summarise(results: ReadingResults, n_runs: int) -> dict:
    """The universe result of one reading: Table 1 and 3 values, claim verdicts, effects (the key
    effect first) and diverged-run counts."""
    return universe_result(values=table_values(results), claims=judge_claims(results), diverged=diverged(results),
                           effects=effects(results), n_runs=n_runs)


def universe(reading: Mapping[str, str], n_runs: int, seed: int) -> dict:
    """The multiverse job: one reading on ``n_runs`` runs of the root seed ``seed``."""
    return summarise(evaluate_reading(reading, MonteCarlo(seed, n_runs)), n_runs)


def table_rows(summary: dict) -> list:
    """Comparison rows (:func:`mmlib.experiment.report.make_row`) of Tables 1 and 3 from a universe result."""
    n = summary["n_runs"]
    case_of = {v: k for k, v in ITEMS.items()}
    rows = []
    for v in summary["values"]:
        case = case_of[v["item"]]
        qi = [q for q, _ in QUANTITIES].index(v["quantity"])
        ndiv = summary["diverged"].get(f"{case} {v['algorithm']}", 0)
        rows.append(report.make_row(v["item"], v["algorithm"], v["quantity"], PRINTED[case][v["algorithm"]][qi],
                                    v["replicated"], v["stderr"], n_runs=n, n_runs_paper=N_RUNS_PAPER,
                                    deviations=ROW_DEVIATIONS[case],
                                    note=f"{ndiv} diverged runs excluded" if ndiv else ""))
    return rows


# -- Table 2 and the near-equality of the third-degree rules -------------------------------------------------------
def printed_complexity_orders(text: str) -> tuple:
    """``(order in the number of points, order in n)`` of a complexity printed as ``O(n^k)``,
    ``O((a n + b)^k)`` or ``O((a n + b) n^k)``, where ``a n + b`` is the filter's number of points
    (``O(n^2)`` has no points: order 0 in them).  ValueError for any other form."""
    import re
    t = text.replace(" ", "")
    pts = r"\((\d*)n([+-]\d+)?\)"
    m = re.fullmatch(r"O\(n\^(\d+)\)", t)
    if m:
        return 0, int(m.group(1))
    m = re.fullmatch(r"O\(" + pts + r"\^(\d+)\)", t)
    if m:
        return int(m.group(3)), int(m.group(3))
    m = re.fullmatch(r"O\(" + pts + r"n(?:\^(\d+))?\)", t)
    if m:
        return 1, 1 + int(m.group(3) or 1)
    raise ValueError(f"text: cannot read a complexity order from {text!r}")


def counted_complexity_orders(counts: Mapping[str, Sequence[int]] | None = None) -> dict:
    """``{filter: (order in the number of points, order in n, slope)}`` of the operations per step counted in
    ``counts`` (default :data:`TABLE2_COUNTS`).

    Order in the points: the log-log slope of the f and h evaluations per step against the number of points,
    fitted across the strong-tracking sigma-point filters (identical algorithm, different rule: 12, 13 and 14
    points), and the same for the Cholesky and n x n x n operation counts; the largest slope, rounded, applies
    to every filter with points (SSRCKF is the same sigma-point filter without the layer).  Order in n: 3 when a
    step does an n x n Cholesky factorisation or an n x n x n product or solve, else 2 (f of a linear model is
    an n x n matrix-vector product)."""
    counts = TABLE2_COUNTS if counts is None else counts
    group = [a for a in counts if a.startswith("ST") and counts[a][0] > 0]
    pts = np.log([counts[a][0] for a in group])
    slopes = []
    for col in ((2, 3), (1,), (4,)):
        y = [sum(counts[a][i] for i in col) for a in group]
        if min(y) > 0 and np.ptp(pts) > 0:
            slopes.append(float(np.polyfit(pts, np.log(y), 1)[0]))
        elif np.ptp(pts) > 0:
            slopes.append(0.0)
    slope = max(slopes) if slopes else float("nan")
    out = {}
    for alg, (npts, chol, nf, nh, nnn) in counts.items():
        order_n = 3 if (chol or nnn) else 2
        out[alg] = (int(round(slope)) if npts > 0 else 0, order_n, slope if npts > 0 else None)
    return out


def complexity_rows(printed: Mapping[str, str] | None = None,
                    counts: Mapping[str, Sequence[int]] | None = None) -> list:
    """Table 2's complexity rows, judged from the counts: the printed complexity is *reproduced* when its
    order in the number of points and its order in n both equal those of the counted operations per step
    (:func:`counted_complexity_orders`), else *not reproduced*, with the finding as the note."""
    printed = TABLE2_COMPLEXITY if printed is None else printed
    counts = TABLE2_COUNTS if counts is None else counts
    counted = counted_complexity_orders(counts)
    rows = []
    for alg in FILTERS:
        p_pts, p_n = printed_complexity_orders(printed[alg])
        c_pts, c_n, slope = counted[alg]
        npts, chol, nf, nh, nnn = counts[alg]
        holds = (p_pts, p_n) == (c_pts, c_n)
        what = (f"{chol} Cholesky factorisation(s) and {nnn} other n × n × n operation(s) (products, solves), "
                f"{nf} f and {nh} h evaluation(s) per step")
        if npts:
            finding = (f"printed order {p_pts} in the number of points ({npts} at n = {TABLE2_N}) and {p_n} in n; "
                       f"counted: {npts} points, {what}; the evaluations grow linearly with the points (log-log "
                       f"slope {slope:.2f} across STCKF, STUKF, STSSRCKF), the factorisations not at all: order "
                       f"{c_pts} in the points, {c_n} in n, O(points · n² + n³)")
        else:
            finding = (f"printed order {p_n} in n; counted: no points, {what}: order {c_n} in n")
        rows.append(report.analytic_row("Table 2", alg, "computational complexity per step", printed[alg], finding,
                                        holds))
    return rows


def table2(per_run: dict, batched: dict) -> tuple:
    """Rows, the timing claim and a display table for Table 2 from repeated timings (dicts name ->
    seconds per run, one value per repeat).  Ratios to SSRCKF are formed per repeat (adjacent
    measurements), so their standard errors come from the repeats; the verdict rule judges them."""
    ref = float(TABLE2_TIME["SSRCKF"])
    rows, display = [], []
    counted = counted_complexity_orders()
    complexity = {r.algorithm: r for r in complexity_rows()}
    for alg in FILTERS:
        pts, chol, nf, nh, nnn = TABLE2_COUNTS[alg]
        ratio_paper = float(TABLE2_TIME[alg]) / ref
        r1 = metrics.timing_ratio(per_run[alg], per_run["SSRCKF"])
        r2 = metrics.timing_ratio(batched[alg], batched["SSRCKF"])
        c_pts, c_n, _ = counted[alg]
        actual = f"O(n^{c_n})" if not pts else ("O(points · n² + n³)" if c_pts == 1 else f"O(points^{c_pts} + n^{c_n})")
        display.append([alg, TABLE2_COMPLEXITY[alg], pts, chol, nf, nh, nnn, actual, TABLE2_TIME[alg],
                        f"{ratio_paper:.2f}", (float(r1.value), float(r1.stderr)), (float(r2.value), float(r2.stderr))])
        rows.append(complexity[alg])
        if alg != "SSRCKF":
            rows.append(report.make_row("Table 2", alg, "time ratio to SSRCKF (one run at a time)", f"{ratio_paper:.3f}",
                                        r1.value, r1.stderr, deviations=[],
                                        note=f"{1e3 * per_run[alg].mean():.1f} ms per run here vs {TABLE2_TIME[alg]} s"))
    st = metrics.timing_ratio(per_run["STSSRCKF"], per_run["SSRCKF"])
    claim = ("STSSRCKF needs more computational time than SSRCKF (Table 2: 0.15 s vs 0.07 s per run)",
             report.paired_claim(float(st.value) - 1.0, float(st.stderr), +1),
             f"time ratio STSSRCKF / SSRCKF, one run at a time: {st.value:.2f} ± {st.stderr:.2f} over "
             f"{len(per_run['SSRCKF'])} repeats (paper 2.14); 'acceptable' is a judgement, not tested")
    return rows, claim, display


def nonlinearity_index(setup: Setup, mc: MonteCarlo, n_runs: int = 50) -> np.ndarray:
    """Median over runs of sigma_pos / range of STSSRCKF's estimate at every step, shape (K,) (the size of the
    neglected terms: third-degree rules differ by ~(sigma/r)^2, the EKF by ~sigma/r)."""
    make_batch, est, _ = make_batch_fn(setup, mc, names=("STSSRCKF",))
    _, z, init = make_batch(range(min(mc.n_runs, n_runs)))
    tr = run_filter(est["STSSRCKF"], init["STSSRCKF"], z)
    sd_pos = np.sqrt(tr.cov[..., 0, 0] + tr.cov[..., 3, 3])
    rng = np.hypot(tr.mean[..., 0], tr.mean[..., 3])
    return np.median(sd_pos / rng, axis=0)


def near_equality(runs: dict) -> tuple[dict, dict]:
    """Largest position difference (m) of STCKF, STUKF, STF from STSSRCKF over all runs and steps, and
    the absolute differences of their position ARMSE (m)."""
    ref = runs["STSSRCKF"]
    max_diff = {a: float(np.max(np.abs(runs[a].errors - ref.errors)[..., list(POSITION)]))
                for a in ("STCKF", "STUKF", "STF")}
    arm = {a: float(metrics.armse(runs[a].errors[..., list(POSITION)], runs[a].valid).value)
           for a in ("STCKF", "STUKF", "STF", "STSSRCKF")}
    return max_diff, {a: abs(arm[a] - arm["STSSRCKF"]) for a in ("STCKF", "STUKF", "STF")}


# -- what the multiverse says (prose computed from the data) --------------------------------------------------------
def _g(x) -> str:
    """A table-match sum for prose (None: a cell failed, the sum is infinite)."""
    return "∞ (a cell failed)" if x is None else f"{x:.3g}"


def _other_columns(mv, universes) -> str:
    """How Table 1's velocity and acceleration columns fare in the given universes (those that reproduce its
    position column): the strong-tracking filters' range against the printed range, and the verdict counts."""
    out = []
    for i in universes:
        u = mv.universes[i]
        cols = []
        for quantity, unit in ((QUANTITIES[1][0], "m/s"), (QUANTITIES[2][0], "m/s²")):
            pubs = [p for p in mv.published if p.table == "Table 1" and p.quantity == quantity]
            st = [p for p in pubs if p.algorithm != "SSRCKF"]
            vals = [mv.value(u, p.key)["replicated"] for p in st]
            printed = [float(p.printed) for p in st]
            verdicts = Counter(report.verdict_category(mv.number_verdict(p, u)) for p in pubs)
            n_rep = verdicts.get(report.REPRODUCED, 0)
            head = ("reproduced" if n_rep == len(pubs) else
                    "not reproduced" if n_rep == 0 else f"reproduced in {n_rep} of {len(pubs)} cells only")
            cols.append(f"its {quantity.split()[0].lower()} column is {head}: the strong-tracking filters reach "
                        f"{_span(vals)} {unit} against the printed {_span(printed)} {unit} (verdicts over its "
                        f"{len(pubs)} cells: "
                        + ", ".join(f"{k} {n}" for k, n in verdicts.items()) + ")")
        out.append(f"Under *{mv.space.describe(mv.readings[i])}* " + "; ".join(cols) + ".")
    reproduced_all = all(
        all(mv.number_verdict(p, mv.universes[i]) == report.REPRODUCED
            for p in mv.published if p.table == "Table 1")
        for i in universes)
    return " ".join(out) + ("" if reproduced_all else
                            " The position-column match is therefore not a reproduction of Table 1 as a whole.")


def _span(values, digits: int = 1) -> str:
    """'a–b' for a range of values, or one value when they agree at the shown precision."""
    lo, hi = f"{min(values):.{digits}f}", f"{max(values):.{digits}f}"
    return lo if lo == hi else f"{lo}–{hi}"


def findings(mv: Multiverse) -> str:
    """Markdown paragraphs stating, from a :class:`~mmlib.experiment.multiverse.Multiverse` of this
    paper, whether some reading reproduces the published tables (Table 1's position column, whole
    tables) and whether each claim's verdict is robust.  Forensic: the best-matching reading is a
    finding about the paper, never the headline."""
    from mmlib.experiment.views import value_pm
    out = []
    pos = [p for p in mv.published if p.table == "Table 1" and p.quantity == QUANTITIES[0][0]]
    head = mv.headline
    st_head = [mv.value(head, p.key) for p in pos if p.algorithm != "SSRCKF"]
    lo, hi = min(v["replicated"] for v in st_head), max(v["replicated"] for v in st_head)
    printed_st = [float(p.printed) for p in pos if p.algorithm != "SSRCKF"]
    full_pos = [i for i, u in enumerate(mv.universes)
                if all(mv.number_verdict(p, u) == report.REPRODUCED for p in pos)]
    text = (f"**Table 1, position column.** Under the headline reading the four strong-tracking filters reach a "
            f"position ARMSE of {_span([lo, hi])} m (± {max(v['stderr'] for v in st_head):.1f} m), against the "
            f"printed {_span(printed_st)} m: not reproduced. ")
    if full_pos:
        descr = []
        for i in full_pos:
            vals = ", ".join(f"{p.algorithm} {value_pm(mv.value(mv.universes[i], p.key)['replicated'], mv.value(mv.universes[i], p.key)['stderr'], 1)}"
                             for p in pos)
            descr.append(f"*{mv.space.describe(mv.readings[i])}* ({vals} m)")
        text += (f"{len(full_pos)} of {len(mv.universes)} universe(s) reproduce all five printed position ARMSEs: "
                 + "; ".join(descr) + ". Table 1's position column is consistent with the maneuver starting at "
                 "t = 100 s, the onset of the paper's own discussion, rather than the 150 s of its set-up paragraph."
                 if all(mv.readings[i]["L-1"] == "100s" for i in full_pos) else
                 f"{len(full_pos)} of {len(mv.universes)} universe(s) reproduce all five printed position ARMSEs: "
                 + "; ".join(descr) + ".")
        text += " " + _other_columns(mv, full_pos)
    else:
        text += f"No universe of the {len(mv.universes)} reproduces all five printed position ARMSEs."
    out.append(text)
    parts = []
    tm = mv.table_match()
    for t in tm:
        most = (f"the most cells any one reading reproduces is {t['most_n_reproduced']} of {t['n_cells']} "
                f"(*{t['most_describe']}*; the headline {t['headline_n_reproduced']})")
        if t["best_universe"] is None:
            forensic = "no universe can be judged on every cell (some value inconclusive)"
        else:
            forensic = (f"the forensic best match (smallest Σz² among the {len(mv.universes) - t['n_excluded_inconclusive']} "
                        f"universes with no inconclusive cell) is *{t['best_describe']}*, Σz² {_g(t['best_sum'])} "
                        f"against the headline's {_g(t['headline_sum'])}, reproducing {t['best_n_reproduced']} cells")
        parts.append(f"{t['table']} ({t['n_cells']} cells): {most}; {forensic}")
    whole = [t["table"] for t in tm if t["most_n_reproduced"] == t["n_cells"]]
    out.append("**Whole tables.** " + "; ".join(parts) + ". "
               + (f"Some reading reproduces the whole of {', '.join(whole)}." if whole else
                  "No declared reading reproduces a whole table."))
    key = [mv.effect(u, KEY_EFFECT) for u in mv.universes]
    pub = key[0]["published"]
    is_neg = [e["value"] is not None and e["value"] + report.SIGMA_FACTOR * e["stderr"] < 0 for e in key]
    neg = sum(is_neg)
    neg_by = {o: (sum(n for n, r in zip(is_neg, mv.readings) if r["L-2"] == o),
                  sum(1 for r in mv.readings if r["L-2"] == o)) for o in mv.space.factor("L-2").names}
    out.append(f"**Key effect** ({KEY_EFFECT}; the paper's counterpart 119.3² − 152.1² = {pub:.0f} m²): headline "
               f"{value_pm(key[0]['value'], key[0]['stderr'], 0)} m²; across the universes from "
               f"{min(e['value'] for e in key):.4g} to {max(e['value'] for e in key):.4g} m², negative by more than "
               f"3 standard errors in {neg} of {len(key)}; by the filters' process noise (L-2): "
               + "; ".join(f"{mv.space.factor('L-2').option(o).label}: negative in {neg_by[o][0]} of {neg_by[o][1]}"
                           for o in mv.space.factor("L-2").names) + ".")
    robust = [c for c in mv.claims_summary() if c["robust"]]
    fragile = [c for c in mv.claims_summary() if not c["robust"]]

    def counts(c):
        return ", ".join(f"{k} {n}" for k, n in c["verdict_counts"].items())
    out.append(f"**Claims.** {len(robust)} of {len(robust) + len(fragile)} claim verdicts are robust (one verdict in "
               f"≥ 90 % of the {len(mv.universes)} universes): "
               + "; ".join(f"{c['claim']} — *{report.claim_category(c['headline_verdict'])}*" for c in robust)
               + ". Reading-dependent: " + ("; ".join(f"{c['claim']} ({counts(c)})" for c in fragile) or "none") + ".")
    return "\n\n".join(out)


def headline_digest(n_runs: int) -> dict:
    """The run digest (:func:`mmlib.experiment.digests.run_digest`) of the headline universe's first
    ``n_runs`` runs (Example 1 and both cases of Example 2) on the paper's root seed: what the notebook stores as ``digest`` in
    ``data/results/liu2017.json``, recomputed without the notebook (tests/tolerance/test_digest.py)."""
    return digests.run_digest(evaluate_reading(SPACE.headline, MonteCarlo(ROOT_SEED, n_runs)).runs, n_runs)
