"""Zhu, Wang & Yuan 2016, "An Improved Interacting Multiple Model Filtering
Algorithm Based on the Cubature Kalman Filter for Maneuvering Target
Tracking", Sensors 16(6), 805, doi:10.3390/s16060805 -- Section 4 set-up.

Key structural fact (derived in the notebook and tested): the paper's models
are all linear -- constant velocity and coordinated turns with *known* turn
rate (Eq. 61) observed through a linear position sensor (Eq. 62).  Every
sigma-point rule that integrates degree-2 polynomials exactly (UKF, CKF,
5th-degree CKF) then returns the exact Kalman moments, so IMM5CKF, IMMCKF and
IMMUKF are the same algorithm as IMM-KF, up to round-off.  Every declared reading
of the paper (``FACTORS``) keeps the models linear, so the identity holds in every
universe of the reading space ``SPACE`` (tested on the star design).

Reading space (issue 10): ``FACTORS`` are the ambiguities that can move a result
(deviations Z-5, Z-6, Z-7, Z-8, Z-9, Z-10, Z-12; the others say in ``DEVIATIONS`` why
they cannot), ``SPACE`` their full factorial product (2^6 x 3 = 192 universes),
``PUBLISHED`` the 16 Monte Carlo cells of Table 1 a universe replicates, and
``universe(reading, n_runs, seed)`` the job run for every universe by
:func:`mmlib.experiment.run_multiverse`; the notebook's headline rows and claims come
from the same ``evaluate_reading`` / ``table1_rows`` / ``judge_claims`` / ``summarise``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np

from mmlib.experiment import metrics, report
from mmlib.core import models
from mmlib.core.estimation import IMM, KnownModeSequence, SingleModel
from mmlib.core.filters import ExtendedKalmanFilter, SigmaPointFilter
from mmlib.experiment.montecarlo import MonteCarlo, Stream
from mmlib.core.rules import Cubature, FifthDegreeCubature, Unscented
from mmlib.experiment.simulate import ManeuverSchedule
from mmlib.experiment import digests, evaluation
from mmlib.core.protocols import MeasurementModel
from mmlib.experiment.multiverse import Multiverse, PublishedNumber, universe_result
from mmlib.experiment.readings import Deviation, Factor, Option, ReadingSpace
from mmlib.experiment.scenario import Scenario

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


#: which turn is model 2 and which is model 3 of Eq. 63 (Z-6)
MODE_ORDERS = ("right-left", "left-right")


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
    mode_order: str = "right-left"                   # model 2 = right turn, model 3 = left turn (Z-6)

    def __post_init__(self):
        if self.mode_order not in MODE_ORDERS:
            raise ValueError(f"mode_order: expected one of {MODE_ORDERS}, got {self.mode_order!r}")
        if self.initial_estimate not in ("sampled", "true"):
            raise ValueError(f"initial_estimate: expected 'sampled' or 'true', got {self.initial_estimate!r}")
        if self.single_model not in ("CV", "CT-right", "CT-left"):
            raise ValueError(f"single_model: expected 'CV', 'CT-right' or 'CT-left', got {self.single_model!r}")


DEVIATIONS = [
    Deviation("Z-1", "5CKF points/weights",
              "Eqs. 2-13 with w2 = 2/(n+2)^2",
              "Jia, Xin & Cheng 2013 rule: w2 = 1/(n+2)^2",
              "With 2/(n+2)^2 the weights sum to 1 + 2n(n-1)/(n+2)^2 = 5/3 for n = 4 and the rule is not "
              "exact even for constants; the cited primary source and two public implementations use 1/(n+2)^2. "
              "Not a factor of the reading space: run as printed, Eq. 21 predicts 5/3 of the propagated mean "
              "and every run diverges (non-finite estimate) at the second step (tests/test_zhu2016.py), "
              "against the paper's 'no error divergence' and its finite Table 1; rescaling the printed "
              "weights to sum to one is not in the text."),
    Deviation("Z-2", "5CKF covariance",
              "Eq. 24 omits -x x^T and +Q; Eq. 45 has -z z^T and +R",
              "P = sum w (X - x)(X - x)^T + Q (and likewise for Pzz, Pxz)",
              "Eq. 24 as printed is not a covariance; Eqs. 45 and 48 show the intended central form. Not a "
              "factor: the text itself gives the central form for the measurement step."),
    Deviation("Z-3", "likelihood", "Eq. 57: 1/sqrt(2 pi V)",
              "N(z; z_pred, S) = exp(-nu^T S^-1 nu / 2) / sqrt(det(2 pi S)) for the 2-D measurement",
              "Eq. 57 is the scalar density. Not a factor: reading its 1/sqrt(2 pi V) as 1/sqrt(2 pi det V) "
              "instead changes every mode's likelihood by the same constant factor, which cancels in Eq. 58."),
    Deviation("Z-4", "process noise", "Q ~ N(0, q), q = [10 0; 0 10], G = [T^2/2 0; T 0; 0 T^2/2; 0 T]",
              "Q = G q G^T, q in m^2/s^4, the same for every mode and for the truth",
              "Units are not stated; m^2/s^4 is the only unit consistent with G multiplying an acceleration."),
    Deviation("Z-5", "measurement noise", "r = diag([20, 0.1]) for the position measurement of Eq. 62",
              "R = diag(20, 0.1) m^2 as printed (headline); diag(20, 20) is the other option of factor Z-5",
              "A 0.1 m^2 y-variance looks like a range-bearing leftover, and the paper's RMSE_Y ~ RMSE_X suggests "
              "equal variances were used; we implement what is printed and run the alternative.",
              "factor Z-5"),
    Deviation("Z-6", "turn rate and model order", "right turn -3 deg, left turn 3 deg; Figs. 6-7 say only "
              "'model 2', 'model 3'",
              "omega = -/+3 deg/s (T = 1 s), known to the filters; model order 1 = CV, 2 = right, 3 = left "
              "(headline), 2 = left, 3 = right the other option",
              "Units by the sampling interval; order as listed in Section 4. Eq. 63's rows 2 and 3 differ, so the "
              "order matters and, not being stated, is factor Z-6.", "factor Z-6"),
    Deviation("Z-7", "truth", "the truth model is not stated beyond Q",
              "truth driven by the same process noise as the filters (CV / CT, Q = G q G^T)",
              "Q is stated as the system's process noise; a noise-free truth ('uniform motion', exact turns) "
              "is the other option.", "factor Z-7"),
    Deviation("Z-8", "initial mode probabilities", "not given", "uniform (1/3 each)",
              "No information favours a mode; the target starts in uniform motion but the paper does not say "
              "the filter knows it; starting in CV is the other option.", "factor Z-8"),
    Deviation("Z-9", "initial estimate", "X0 and P0 given; whether the filter starts at X0 is not",
              "truth starts at X0; filter mean drawn per run from N(X0, P0) (consistent with P0)",
              "Starting the filter at the true state with P0 = diag(1000, ...) would make P0 a lie; it is the "
              "other option.", "factor Z-9"),
    Deviation("Z-10", "5CKF (single model)", "which model the single-model 5CKF uses is not stated",
              "constant velocity with the same Q",
              "The paper argues 5CKF fails because 'a single model algorithm cannot adapt'; CV is the mode the "
              "target is in 60% of the time. The coordinated turns of Eq. 61 (the only model matrix printed) "
              "are the other options.", "factor Z-10"),
    Deviation("Z-11", "UKF parameters", "not given", "alpha = 1, beta = 2, kappa = 0",
              "Irrelevant under this set-up: on linear models any valid (alpha, beta, kappa) gives the KF "
              "(tested), so not a factor: it cannot move a result."),
    Deviation("Z-12", "time grid", "turns 'during 20 s ~ 40 s' and '60 s ~ 80 s'; 100 s at T = 1 s",
              "100 steps, measurements at t = 1..100 s; a turn covers the transitions that start in [20, 40) s "
              "and [60, 80) s",
              "Interval ends are ambiguous by one step; both ends inclusive (21 turn steps, the states at "
              "t = 20..40 s) is the other option.", "factor Z-12"),
    Deviation("Z-13", "RMSE", "Eq. 64 (indices garbled)",
              "per component, RMSE = sqrt(mean over runs and over the 100 steps of squared error)",
              "The only reading of Eq. 64 with a single number per component; per-run time means are the "
              "independent replications for the standard error. Not a factor: the printed order of the root "
              "and the sums is not ambiguous, only the indices are."),
    Deviation("Z-14", "OMTM-IMM", "cited only (Zhou, Cai, Sun & Shen 2014, Math. Probl. Eng. 813654)",
              "not implemented: column kept with the paper's values, verdict 'not replicable'",
              "Only the abstract of the cited paper is available: the transition matrix is computed by linear "
              "minimum variance from subfilter cross-covariances, but no equations, initial values or mode "
              "filter are given, here or in the cited abstract."),
    Deviation("Z-15", "run time", "MATLAB seconds, total or per run not stated",
              "CPU time per run (time.thread_time), one run at a time (the paper's way) and batched, compared "
              "as ratios to IMMCKF; the algorithms take turns run by run in every repeat, and a repeat's "
              "one-at-a-time time is its fastest run (evaluation.time_algorithms)",
              "Absolute times across languages and machines are not comparable; ratios are. CPU time and the "
              "fastest of a repeat's identical-work runs keep other processes on the machine out of the ratio."),
]


# ---------------------------------------------------------------------------------------------------------------
# The reading space (issue 10): every ambiguity that can move a result, as a numbered factor.  Not factors, and
# why: Z-1 (the printed weight diverges at once), Z-2 (the text gives the central form), Z-3 (a common constant
# cancels), Z-4 (one consistent unit), Z-11 (cannot move a result under linear models), Z-13 (unambiguous order of
# root and sums), Z-14 (not published), Z-15 (timing is not a universe's value).
# ---------------------------------------------------------------------------------------------------------------
_TURNS = "Section 4: 'The target turns right during 20s ~ 40s, turns left during 60s ~ 80s'"
FACTORS = (
    Factor("Z-5", "measurement noise variance r of Eq. 62", (
        Option("printed", "R = diag(20, 0.1) m² (as printed)",
               "Section 4: 'The measure noise R ~ N(0, r), with r = diag([20, 0.1])'", {"r": (20.0, 0.1)}),
        Option("equal", "R = diag(20, 20) m² (equal variances)",
               "Eq. 62: one linear sensor measuring x and y in the same units, no reason given for a 200-fold "
               "accuracy difference; Table 1 prints RMSE_Y ≈ RMSE_X for every filter", {"r": (20.0, 20.0)})),
        "printed", "Section 4, after Eq. 62"),
    Factor("Z-7", "process noise in the simulated truth", (
        Option("noisy", "truth driven by Q = G q Gᵀ",
               "Section 4: 'process noise Q ~ N(0, q), q = [10, 0; 0, 10], process noise weight matrix G'",
               {"truth_process_noise": True}),
        Option("clean", "noise-free truth (exact CV and turns)",
               "Section 4: the target 'maintains uniform motion during the other time' and turns at ∓3°",
               {"truth_process_noise": False})),
        "noisy", "Section 4, simulation set-up"),
    Factor("Z-8", "initial mode probabilities μ0", (
        Option("uniform", "μ0 = (1/3, 1/3, 1/3)",
               "Section 3.1 (Eqs. 54-56) uses μ_{k-1} without an initial value; nothing favours a mode",
               {"mode_probabilities0": (1 / 3, 1 / 3, 1 / 3)}),
        Option("cv", "μ0 = (1, 0, 0): starts in CV",
               "Section 4: the target 'maintains uniform motion during the other time', i.e. starts in CV",
               {"mode_probabilities0": (1.0, 0.0, 0.0)})),
        "uniform", "not given (Section 4)"),
    Factor("Z-9", "filters' initial estimate", (
        Option("sampled", "drawn per run from N(X0, P0)",
               "Section 4: 'initial associate covariance is P0 = diag([1000, 10, 1000, 10])', the covariance "
               "of the initial estimate's error", {"initial_estimate": "sampled"}),
        Option("true", "the true X0",
               "Section 4: 'The initial state X0 = [1000 m, 200 m/s, 1000 m, 200 m/s]' given as the start",
               {"initial_estimate": "true"})),
        "sampled", "Section 4, X0 and P0"),
    Factor("Z-10", "the single-model 5CKF's model", (
        Option("CV", "constant velocity",
               "Section 4: 'a single model algorithm cannot adapt'; the target 'maintains uniform motion' 60 % of "
               "the time", {"single_model": "CV"}),
        Option("CT-right", "coordinated turn, −3°/s",
               "Eq. 61, 'The coordinated turn model is', the only model matrix printed, with 'the right turn rate "
               "-3°'", {"single_model": "CT-right"}),
        Option("CT-left", "coordinated turn, +3°/s",
               "Eq. 61 with 'the left turn rate is 3°'", {"single_model": "CT-left"})),
        "CV", "not stated (Section 4)"),
    Factor("Z-12", "ends of the turn intervals", (
        Option("half-open", "20 turn steps (states 21–40 s, 61–80 s)",
               _TURNS + " (the motion between 20 s and 40 s is the turn)",
               {"right_turn": (20.0, 40.0), "left_turn": (60.0, 80.0)}),
        Option("inclusive", "21 turn steps (states 20–40 s, 60–80 s)",
               _TURNS + " (both ends inclusive, e.g. a loop 'k >= 20 and k <= 40' over the state index)",
               {"right_turn": (19.0, 40.0), "left_turn": (59.0, 80.0)})),
        "half-open", _TURNS),
    Factor("Z-6", "which turn is model 2 of Eq. 63", (
        Option("right-left", "model 2 = right turn, model 3 = left turn",
               "Section 4 lists 'The right turn rate is defined as -3°, and the left turn rate is 3°' in this "
               "order, and the target turns right first", {"mode_order": "right-left"}),
        Option("left-right", "model 2 = left turn, model 3 = right turn",
               "Figs. 6-7 are captioned only 'model 2', 'model 3'; Eq. 63's rows 2 and 3 differ",
               {"mode_order": "left-right"})),
        "right-left", "Eq. 63, Figs. 5-7"),
)
#: budget of universes: 2^6 x 3 = 192 is the full factorial (see the notebook for its cost)
SPACE = ReadingSpace(PAPER, FACTORS, budget=192)

#: the RMSE columns every universe replicates (OMTM-IMM is not published, Z-14)
RMSE_ALGORITHMS = ("IMM5CKF", "IMMCKF", "IMMUKF", "5CKF")
#: estimators run in every universe: Table 1's, the IMM-KF they coincide with, and the MMSE floor
MV_ALGORITHMS = RMSE_ALGORITHMS + ("IMM-KF", "clairvoyant KF")
#: every printed Monte Carlo number of Table 1 that a universe replicates (run times are not universes' values)
PUBLISHED = tuple(PublishedNumber("Table 1", "Table 1", alg, q, TABLE1[alg][qi])
                  for alg in RMSE_ALGORITHMS for qi, (q, _) in enumerate(QUANTITIES))


def build(setup: Setup) -> tuple:
    """Dynamics, measurement, schedule and the estimators of Table 1."""
    w = math.radians(setup.turn_rate_deg)
    cv = models.constant_velocity(setup.T, setup.q)
    right = models.coordinated_turn(setup.T, -w, setup.q)
    left = models.coordinated_turn(setup.T, w, setup.q)
    i_right, i_left = (1, 2) if setup.mode_order == "right-left" else (2, 1)
    modes = [cv, right, left] if setup.mode_order == "right-left" else [cv, left, right]
    meas = models.position_measurement(list(setup.r))
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
    position measurements and the filters' initial means (x0, or x0 + N(0, P0) from the run's INITIAL stream, Z-9)."""
    x0 = np.array(setup.x0)
    P0 = np.diag(setup.P0_diag)

    def for_mc(mc: MonteCarlo):
        def start(runs):
            if setup.initial_estimate == "sampled":
                return mc.gaussian(runs, Stream.INITIAL, x0, P0)
            return np.tile(x0, (len(runs), 1))

        return evaluation.simulator(mc, schedule, meas, x0, process_noise=setup.truth_process_noise, start=start)

    return for_mc


def make_batch_fn(setup: Setup, mc: MonteCarlo) -> tuple:
    """``(make_batch, estimators, schedule)``: ``make_batch(runs) -> (truth, measurements, {name: initial state})``
    for :func:`evaluation.evaluate` (:func:`simulator`; IMMs started with P0 and ``mode_probabilities0``, single-model
    filters with P0), the estimators of :func:`build` and the truth's schedule."""
    schedule, meas, estimators = build(setup)
    P0 = np.diag(setup.P0_diag)

    def init_state(est, m0, runs):
        return est.init(m0, P0, setup.mode_probabilities0) if isinstance(est, IMM) else est.init(m0, P0)

    make_batch = evaluation.with_initial_states(simulator(setup, schedule, meas)(mc), estimators, init_state)
    return make_batch, estimators, schedule


def scenario(setup: Setup | None = None) -> Scenario:
    """Section 4's set-up (the headline reading unless ``setup`` is given) as an arena scenario: the IMM's three
    modes (CV and the two known-rate turns), the single-model 5CKF's model (Z-10) and the position sensor, all
    linear (so every rule returns the Kalman moments); SI units as printed."""
    setup = Setup() if setup is None else setup
    schedule, meas, estimators = build(setup)
    return Scenario(name=PAPER, title="Zhu et al. 2016: CV and ±3°/s turns, linear position sensor", source=CITATION,
                    root_seed=ROOT_SEED, T=setup.T, n_steps=setup.n_steps, simulator=simulator(setup, schedule, meas),
                    P0=np.diag(setup.P0_diag), position=(0, 2), velocity=(1, 3),
                    single=estimators["5CKF"].dynamics, modes=tuple(estimators["IMM5CKF"].dynamics),
                    transition=np.array(setup.transition), mode_probabilities=setup.mode_probabilities0,
                    measurement=meas, ukf=tuple(setup.ukf),
                    properties={"measurement": "linear position (x, y)", "manoeuvre": "±3°/s turns, known rate"})


# ---------------------------------------------------------------------------------------------------------------
# One universe: the Monte Carlo evaluation of a reading and everything judged from it.  The notebook's headline
# rows and claims come from these same functions applied to SPACE.headline.
# ---------------------------------------------------------------------------------------------------------------
def setups(reading: Mapping) -> Setup:
    """The Setup of a reading (``factor id -> option name``): the headline Setup with the reading's
    option changes; ValueError naming an unknown factor/option or a left-out factor."""
    return Setup(**SPACE.changes(reading))


def evaluate_reading(reading: Mapping, mc: MonteCarlo, progress: bool = False) -> dict:
    """``{estimator: RunSet}`` for :data:`MV_ALGORITHMS` under ``reading``, on the runs of ``mc``
    (common random numbers: the per-run truth, measurement and initial-estimate streams do not
    depend on the reading)."""
    make_batch, estimators, _ = make_batch_fn(setups(reading), mc)
    return evaluation.evaluate(evaluation.select(estimators, MV_ALGORITHMS), make_batch, mc,
                               label=f"{PAPER} {SPACE.describe(reading)}"[:60], progress=progress)


def rmse_values(results: dict) -> dict:
    """Eq. 64 (Z-13) per algorithm of Table 1 and per quantity: ``{(algorithm, quantity): MCValue}``
    (m or m/s; diverged runs excluded and counted)."""
    return {(alg, q): metrics.rmse_time_averaged(results[alg].errors[..., comp], results[alg].valid)
            for alg in RMSE_ALGORITHMS for q, comp in QUANTITIES}


def table1_rows(results: dict) -> list:
    """The RMSE rows of Table 1 (:func:`mmlib.experiment.report.make_row`; OMTM-IMM 'not replicable', Z-14)."""
    rmse = rmse_values(results)
    rows = []
    for alg in RMSE_ALGORITHMS + ("OMTM-IMM",):
        for qi, (q, _) in enumerate(QUANTITIES):
            printed = TABLE1[alg][qi]
            if alg == "OMTM-IMM":
                rows.append(report.make_row("Table 1", alg, q, printed, None, None,
                                            reason="method not specified (Z-14)", deviations=["Z-14"]))
                continue
            est = rmse[(alg, q)]
            devs = ["Z-4", "Z-5", "Z-6", "Z-7", "Z-9", "Z-12", "Z-13"] + (["Z-8"] if alg.startswith("IMM") else []) \
                + (["Z-1", "Z-2"] if "5CKF" in alg else []) + (["Z-10"] if alg == "5CKF" else []) \
                + (["Z-11"] if alg == "IMMUKF" else [])
            rows.append(report.make_row("Table 1", alg, q, printed, est.value, est.stderr, n_runs=est.n_runs,
                                        n_runs_paper=N_RUNS_PAPER, deviations=devs,
                                        note=f"{est.n_excluded} diverged runs excluded" if est.n_excluded else ""))
    return rows


def coincidence(results: dict) -> dict:
    """Largest absolute difference over runs and steps between each sigma-point IMM and the IMM-KF: estimates
    (m, m/s) and mode probabilities.  Zero up to round-off under every reading (module docstring)."""
    ref = results["IMM-KF"]
    return {"max_abs_estimate_difference_vs_IMM_KF":
            {a: float(np.nanmax(np.abs(results[a].errors - ref.errors))) for a in ("IMM5CKF", "IMMCKF", "IMMUKF")},
            "max_abs_mode_probability_difference_vs_IMM_KF":
            {a: float(np.nanmax(np.abs(results[a].mode_probabilities - ref.mode_probabilities)))
             for a in ("IMM5CKF", "IMMCKF", "IMMUKF")}}


FLOOR_CLAIM = "Table 1's IMM errors lie above the minimum-MSE floor of the set-up (implicit)"


def floor_is_bound(setup: Setup) -> bool:
    """Whether the clairvoyant KF is the minimum-MSE estimator of this set-up: the truth must follow the
    filters' own model, i.e. be driven by Q (Z-7) and start from an initial error drawn from N(0, P0)
    (Z-9).  Under a noise-free truth or a filter started at the true X0 with P0 = diag(1000, ...) it is
    a reference, not a bound (a filter knowing the truth has no noise could do better)."""
    return bool(setup.truth_process_noise) and setup.initial_estimate == "sampled"


def floor_check(results: dict) -> list:
    """Table 1's IMM values against the minimum-MSE floor of this reading.

    With linear-Gaussian modes the Kalman filter told the true mode sequence ("clairvoyant KF")
    is the MMSE estimator, so no IMM can have a smaller expected squared error.  Per quantity: the
    floor (RMSE of the clairvoyant KF, with its standard error), the smallest printed IMM value, and
    ``z`` = (floor - printed) / sigma with the combined sigma of the verdict rule (our error, the
    paper's estimated from its 100 runs, half a unit of the printed digit); ``z >= 3`` means the
    printed value lies significantly below the floor: unattainable under this reading."""
    out = []
    for qi, (q, comp) in enumerate(QUANTITIES):
        b = metrics.rmse_time_averaged(results["clairvoyant KF"].errors[..., comp], results["clairvoyant KF"].valid)
        printed = min((TABLE1[a][qi] for a in ("IMM5CKF", "IMMCKF", "IMMUKF")), key=float)
        z = report.standardized_distance(printed, float(b.value), float(b.stderr), b.n_runs, N_RUNS_PAPER)
        # sigma of the verdict rule: the standardized distance of a unit difference is 1 / sigma
        sigma = 1.0 / report.standardized_distance(printed, float(printed) + 1.0, float(b.stderr), b.n_runs,
                                                   N_RUNS_PAPER)
        out.append({"quantity": q, "floor": float(b.value), "floor_stderr": float(b.stderr),
                    "paper_min_imm": printed, "margin": float(printed) - float(b.value), "sigma": sigma, "z": z})
    return out


def _switch_window_probability(rs, true_modes, window: int = 10):
    """Per run: mean probability of the true mode over the ``window`` steps after each mode switch."""
    switch = [k for k in range(1, len(true_modes)) if true_modes[k] != true_modes[k - 1]]
    steps = sorted({k + j for k in switch for j in range(window) if k + j < len(true_modes)})
    mu = rs.mode_probabilities[:, steps, :]
    return np.take_along_axis(mu, np.asarray(true_modes)[steps][None, :, None], axis=2)[..., 0].mean(axis=1)


def judge_claims(results: dict, setup: Setup) -> report.Claims:
    """The paper's accuracy, switching and divergence claims and the implicit attainability of Table 1,
    each in the claim vocabulary of :mod:`mmlib.experiment.report` (the timing claim is judged by :func:`judge_timing`)."""
    claims = report.Claims()
    for other in ("IMMCKF", "IMMUKF", "5CKF"):
        claims.add(f"IMM5CKF is more accurate than {other}",
                   *evaluation.better_claim(results, "IMM5CKF", other, QUANTITIES))
    claims.add("IMM5CKF is more accurate than OMTM-IMM", "not assessable: OMTM-IMM is not specified (Z-14)",
               "Zhou et al. 2014 give no equations, initial values or mode filter")
    fl = floor_check(results)
    evidence = "; ".join(f"{f['quantity']}: smallest printed IMM value {f['paper_min_imm']} vs floor "
                         f"{f['floor']:.3f} ± {f['floor_stderr']:.3f} (z = {f['z']:+.1f})" for f in fl)
    if floor_is_bound(setup):
        # the part verdict of claim_verdict on the z-score (unit standard error): 'holds' if printed >= floor + 3 sigma
        verdict = report.combine_claim_verdicts(f"{report.claim_verdict(-f['z'], 1.0, +1)} ({f['quantity']})"
                                                for f in fl)
    else:
        verdict = ("not assessable: the clairvoyant KF is the minimum-MSE bound only when the simulated truth "
                   "follows the filters' model (Z-7 noisy truth, Z-9 initial error drawn from N(0, P0))")
    claims.add(FLOOR_CLAIM, verdict, evidence)
    true_modes = build(setup)[0].modes()
    parts, ev = [], []
    p5 = _switch_window_probability(results["IMM5CKF"], true_modes)
    for other in ("IMMCKF", "IMMUKF"):
        po = _switch_window_probability(results[other], true_modes)
        d = metrics.mean_with_se(p5 - po)
        parts.append(f"{report.claim_verdict(float(d.value), float(d.stderr), +1, reference=float(po.mean()))} "
                     f"({other})")
        ev.append(f"vs {other}: Δ(probability of the true mode, 10 steps after each switch) = "
                  f"{float(d.value):.2g} ± {float(d.stderr):.2g}")
    claims.add("IMM5CKF switches modes more quickly than IMMCKF/IMMUKF", report.combine_claim_verdicts(parts),
               "; ".join(ev))
    diverged = {a: int((~results[a].valid).sum()) for a in RMSE_ALGORITHMS}
    claims.add("No algorithm diverges", "holds" if not any(diverged.values()) else
               f"contradicted: {sum(diverged.values())} diverged runs", f"diverged runs: {diverged}")
    return claims


def _published_mse_difference(a: str, b: str, comps) -> float:
    """Table 1's counterpart of a paired MSE difference: sum over the components of RMSE_a^2 - RMSE_b^2."""
    return sum(float(TABLE1[a][c]) ** 2 - float(TABLE1[b][c]) ** 2 for c in comps)


#: the key effect of the specification curve
KEY_EFFECT = "IMM5CKF − IMMCKF: position MSE (m²)"


def effects(results: dict) -> list:
    """Named paired differences (value, standard error, Table 1's counterpart) and the floor margins."""
    out = []
    for name, a, b, comps in ((KEY_EFFECT, "IMM5CKF", "IMMCKF", (0, 2)),
                              ("IMM5CKF − IMMCKF: velocity MSE (m²/s²)", "IMM5CKF", "IMMCKF", (1, 3)),
                              ("IMM5CKF − IMMUKF: position MSE (m²)", "IMM5CKF", "IMMUKF", (0, 2)),
                              ("IMM5CKF − 5CKF: position MSE (m²)", "IMM5CKF", "5CKF", (0, 2))):
        d = evaluation.paired_mse_difference(results[a], results[b], comps)
        out.append((name, float(d.value), float(d.stderr), _published_mse_difference(a, b, comps)))
    for f in floor_check(results):
        out.append((f"smallest printed IMM value − floor: {f['quantity']}", f["margin"], f["sigma"]))
    c = coincidence(results)
    out.append(("max |IMM5CKF − IMM-KF| estimate (m, m/s)",
                c["max_abs_estimate_difference_vs_IMM_KF"]["IMM5CKF"], None))
    return out


def summarise(results: dict, n_runs: int, setup: Setup) -> dict:
    """The universe's result (:func:`mmlib.experiment.universe_result`): Table 1's RMSE cells and the
    floor (values), :func:`judge_claims`, :func:`effects` and the diverged runs per estimator."""
    values = [("Table 1", alg, q, float(v.value), float(v.stderr)) for (alg, q), v in rmse_values(results).items()]
    for f in floor_check(results):
        values.append(("floor", "clairvoyant KF", f["quantity"], f["floor"], f["floor_stderr"]))
    return universe_result(values=values, claims=judge_claims(results, setup), effects=effects(results),
                           diverged={a: int((~rs.valid).sum()) for a, rs in results.items()}, n_runs=n_runs)


def universe(reading: dict, n_runs: int, seed: int) -> dict:
    """The multiverse job: one reading, ``n_runs`` Monte Carlo runs on root seed ``seed``."""
    mc = MonteCarlo(seed, n_runs)
    return summarise(evaluate_reading(reading, mc), n_runs, setups(reading))


def cv_steady_state_sd(setup: Setup) -> dict:
    """Steady-state posterior standard deviations of the Kalman filter for a CV target in each axis
    (discrete algebraic Riccati equation; per axis F = [[1, T], [0, 1]], G = [T²/2, T]ᵀ, Q = G q Gᵀ,
    position measured with variance r): ``{state index: s.d.}`` in m and m/s.  A closed-form check of
    the clairvoyant floor away from the turns."""
    import scipy.linalg
    out = {}
    for pos, r_var in ((0, setup.r[0]), (2, setup.r[1])):
        F1 = np.array([[1.0, setup.T], [0.0, 1.0]])
        G1 = np.array([[setup.T ** 2 / 2], [setup.T]])
        P_pred = scipy.linalg.solve_discrete_are(F1.T, np.array([[1.0], [0.0]]), G1 @ G1.T * setup.q,
                                                 np.array([[r_var]]))
        P_post = P_pred - np.outer(P_pred[:, 0], P_pred[:, 0]) / (P_pred[0, 0] + r_var)
        out[pos], out[pos + 1] = float(np.sqrt(P_post[0, 0])), float(np.sqrt(P_post[1, 1]))
    return out


def floor_summary(mv: Multiverse) -> list:
    """Across a multiverse: per quantity, in how many universes the smallest printed IMM value of
    Table 1 lies more than 3 combined standard errors below that universe's clairvoyant floor (all
    universes, and those where the floor is a bound, :func:`floor_is_bound`), and the range of the
    floor (m or m/s)."""
    bound = [floor_is_bound(setups(r)) for r in mv.readings]
    out = []
    for q, _ in QUANTITIES:
        margins = [mv.effect(u, f"smallest printed IMM value − floor: {q}") for u in mv.universes]
        floors = [mv.value(u, ("floor", "clairvoyant KF", q))["replicated"] for u in mv.universes]
        below = [m["value"] <= -report.SIGMA_FACTOR * m["stderr"] for m in margins]
        out.append({"quantity": q, "n_below": int(sum(below)), "n_universes": len(margins),
                    "n_bound": int(sum(bound)), "n_below_where_bound": int(sum(b and x for b, x in zip(bound, below))),
                    "floor_min": float(min(floors)), "floor_max": float(max(floors)),
                    "paper_min_imm": min((TABLE1[a][[x for x, _ in QUANTITIES].index(q)]
                                          for a in ("IMM5CKF", "IMMCKF", "IMMUKF")), key=float)})
    return out


# ---------------------------------------------------------------------------------------------------------------
# Run time (Table 1's last column, Z-15)
# ---------------------------------------------------------------------------------------------------------------
#: runs timed one at a time per repeat (the fastest of them is the repeat's value)
TIMING_PER_REPEAT = 3


TIMING_CLAIM = "IMM5CKF costs more computation than IMMCKF"


def judge_timing(per_run: dict, batched: dict, claims: report.Claims) -> tuple:
    """Table 1's time column as ratios to IMMCKF (Z-15): rows judged by the verdict rule with the standard error
    of the per-repeat ratios, and the timing claim as a part verdict on ratio - 1.  Returns (rows, table rows for
    display)."""
    repeats = len(per_run["IMMCKF"])
    ref_paper = float(TABLE1["IMMCKF"][4])
    ratios = {alg: metrics.timing_ratio(per_run[alg], per_run["IMMCKF"]) for alg in per_run}
    rows, table = [], []
    for alg in ALGORITHMS:
        paper_ratio = float(TABLE1[alg][4]) / ref_paper
        if alg == "IMMCKF":   # the reference of the ratios: its absolute MATLAB time cannot be compared
            rows.append(report.make_row("Table 1", alg, "Time (s)", TABLE1[alg][4], None, None,
                                        reason="absolute MATLAB time; IMMCKF is the reference of the ratios (Z-15)",
                                        deviations=["Z-15"], note=f"{1e3 * per_run[alg].mean():.1f} ms per run here"))
            table.append([alg, TABLE1[alg][4], "1 (reference)", "1 (reference)", f"{1e3 * per_run[alg].mean():.2f}",
                          f"{1e3 * batched[alg].mean():.3f}", "1 (reference)",
                          f"{per_run[alg].mean() / batched[alg].mean():.0f}×"])
            continue
        if alg == "OMTM-IMM":
            rows.append(report.make_row("Table 1", alg, "Time ratio to IMMCKF (one run at a time)",
                                        f"{paper_ratio:.3f}", None, None, reason="method not specified (Z-14)",
                                        deviations=["Z-14", "Z-15"]))
            continue
        ratio = ratios[alg]
        rows.append(report.make_row("Table 1", alg, "Time ratio to IMMCKF (one run at a time)", f"{paper_ratio:.3f}",
                                    ratio.value, ratio.stderr, deviations=["Z-15"],
                                    note=f"{1e3 * per_run[alg].mean():.1f} ms (CPU) per run here vs "
                                         f"{TABLE1[alg][4]} s (MATLAB); s.e. from {repeats} repeated timings"))
        bratio = metrics.timing_ratio(batched[alg], batched["IMMCKF"])
        table.append([alg, TABLE1[alg][4], f"{paper_ratio:.2f}", f"{float(ratio.value):.3f} ± {float(ratio.stderr):.3f}",
                      f"{1e3 * per_run[alg].mean():.2f}", f"{1e3 * batched[alg].mean():.3f}",
                      f"{float(bratio.value):.2f} ± {float(bratio.stderr):.2f}",
                      f"{per_run[alg].mean() / batched[alg].mean():.0f}×"])
    r5 = ratios["IMM5CKF"]
    claims.add(TIMING_CLAIM, report.paired_claim(float(r5.value) - 1.0, float(r5.stderr), +1),
               f"CPU-time ratio, one run at a time, {float(r5.value):.3f} ± {float(r5.stderr):.3f} over {repeats} "
               f"repeated timings (paper {float(TABLE1['IMM5CKF'][4]) / ref_paper:.2f})")
    return rows, table


def headline_digest(n_runs: int) -> dict:
    """The run digest (:func:`mmlib.experiment.digests.run_digest`) of the headline universe's first
    ``n_runs`` runs (the six estimators of the headline) on the paper's root seed: what the notebook stores as ``digest`` in
    ``data/results/zhu2016.json``, recomputed without the notebook (tests/tolerance/test_digest.py)."""
    return digests.run_digest(evaluate_reading(SPACE.headline, MonteCarlo(ROOT_SEED, n_runs)), n_runs)
