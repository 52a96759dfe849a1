"""What Zhu, Wang & Yuan 2016 print, and what they leave open: the declared text of the paper.

Table 1 as printed (RMSE of Eq. 64 per component, m or m/s, and MATLAB run time, s), the numbered deviations
``DEVIATIONS`` (Z-1 ... Z-15) where the text is missing, contradictory or wrong, the ``FACTORS`` among them that can
move a result and their reading space ``SPACE`` (full factorial 2^5 x 3 x 4 = 384 universes), and ``PUBLISHED``, the
16 Monte Carlo cells of Table 1 a universe replicates.  The name, citation, root seed and Monte Carlo count the
paper's :class:`~mmlib.experiment.paper.Paper` (``mmlib.papers.zhu2016.PAPER``) is built from.
"""
from __future__ import annotations

import math

from mmlib.experiment.readings import Deviation, Factor, Option, ReadingSpace
from mmlib.experiment.universe import PublishedNumber

__all__ = [
    "PUBLISHED", "SPACE", "FACTORS", "DEVIATIONS", "NAME", "TITLE", "DOI", "CITATION", "N_RUNS", "ROOT_SEED",
    "ALGORITHMS", "QUANTITIES", "TABLE1", "RMSE_ALGORITHMS", "MV_ALGORITHMS"
]

NAME = "zhu2016"
TITLE = "Zhu, Wang & Yuan 2016: IMM with the fifth-degree cubature Kalman filter"
DOI = "10.3390/s16060805"
CITATION = ("W. Zhu, W. Wang, G. Yuan, An Improved Interacting Multiple Model Filtering Algorithm "
            "Based on the Cubature Kalman Filter for Maneuvering Target Tracking, Sensors 16(6):805, 2016, "
            "doi:10.3390/s16060805")
N_RUNS = 100                  # Section 4: the paper's Monte Carlo runs
ROOT_SEED = 20160601          # publication date; one root seed for the whole paper

#: the columns of Table 1
ALGORITHMS = ("IMM5CKF", "IMMCKF", "IMMUKF", "5CKF", "OMTM-IMM")
#: Table 1's RMSE rows (Eq. 64) and the state component each is of ([x, vx, y, vy])
QUANTITIES = (("RMSE_X (m)", 0), ("RMSE_X_V (m/s)", 1), ("RMSE_Y (m)", 2), ("RMSE_Y_V (m/s)", 3))

#: Table 1 exactly as printed (strings keep the printed precision).
TABLE1 = {
    "IMM5CKF": ["2.6675", "1.1245", "2.5255", "1.4972", "14.9726"],
    "IMMCKF": ["2.4847", "1.8306", "2.8534", "2.9201", "7.2549"],
    "IMMUKF": ["2.5392", "1.8930", "3.0362", "2.8488", "7.3785"],
    "5CKF": ["27.4975", "5.7001", "21.7947", "12.2331", "5.3101"],
    "OMTM-IMM": ["5.6211", "3.2510", "6.0674", "4.9938", "6.0314"],
}

#: the numbered deviations: where the text is missing, contradictory or wrong, our choice and why
DEVIATIONS = (
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
    Deviation("Z-5", "sensor and measurement noise",
              "Eq. 62: a linear position sensor, H = [1 0 0 0; 0 0 1 0]; 'r = diag([20, 0.1])', no unit",
              "the position sensor with R = diag(20, 0.1) m² as printed (headline); the other options of factor Z-5: "
              "R = diag(20, 20) m² (motivated by Table 1, run and reported apart), and a range-bearing sensor at "
              "the coordinate origin with variances 20 m² and 0.1 rad² or 0.1 deg²",
              "A 0.1 m² y-variance against 20 m² in x has no reason in the text, while (20 m², 0.1 angle²) is the "
              "shape of a radar's (range, bearing) noise, and the paper sets IMM5CKF against 'nonlinear "
              "maneuvering target tracking problems' (Section 5) with a point rule that 'transfer[s] the "
              "nonlinear functions' (Section 2), which a linear sensor gives nothing to act on: the range-bearing "
              "sensor is a reading of the text, and the only one under which its comparison of the point rules "
              "can show a difference. Its bearing unit is not printed: rad² is the unit of the computation (an "
              "unconverted 0.1 in code whose trigonometric functions work in radians; σ = 18°), deg² the unit of "
              "the only angles the paper prints (the turn rates, '-3°'); 0.1 mrad² is not declared, for the paper "
              "uses no milliradians and a unit picked to make the bearing error as small as Table 1's would be "
              "motivated by the results. The sensor's position is not stated: the origin of the coordinates "
              "(the target starts 1.41 km from it, at (1000 m, 1000 m), and flies away). Table 1's IMMCKF ≠ IMMUKF, "
              "impossible under the linear sensor, is consistent with the range-bearing reading but is not its "
              "reason. Equal variances are suggested by Table 1's RMSE_Y ≈ RMSE_X, a result, so that option is "
              "marked as motivated by the results.",
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
              "Irrelevant under the position sensor: on linear models any valid (alpha, beta, kappa) gives the KF "
              "(tested), so it cannot move a result there. Under Z-5's range-bearing sensor it can (with these "
              "values the UKF is the CKF's points plus a centre point of covariance weight 2); the text gives no "
              "value to read, so it is not a reading factor, and the IMMUKF results under that sensor hold for "
              "these values only."),
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
)


# ---------------------------------------------------------------------------------------------------------------
# The reading space (issue 10): every ambiguity that can move a result, as a numbered factor; every factor is a
# reading (alternatives the text supports, quoted), none an unstated tuning sweep.  Z-5's "equal" is motivated by
# Table 1 (run and reported apart, never counted in the shares).  Not factors, and why: Z-1 (the printed weight
# diverges at once), Z-2 (the text gives the central form), Z-3 (a common constant cancels), Z-4 (one consistent
# unit), Z-11 (cannot move a result under the position sensor; under the range-bearing sensor an unstated tuning
# value, not a reading), Z-13 (unambiguous order of root and sums), Z-14 (not published), Z-15 (timing is not a
# universe's value).
# ---------------------------------------------------------------------------------------------------------------
_TURNS = "Section 4: 'The target turns right during 20s ~ 40s, turns left during 60s ~ 80s'"
FACTORS = (
    Factor("Z-5", "the sensor of Eq. 62 and its noise r", (
        Option("printed", "position, R = diag(20, 0.1) m² (as printed)",
               "Eq. 62, 'Z = [1 0 0 0; 0 0 1 0] + R', and Section 4: 'The measure noise R ~ N(0, r), with "
               "r = diag([20, 0.1])'", {"r": (20.0, 0.1)}),
        Option("equal", "position, R = diag(20, 20) m² (equal variances)",
               "Eq. 62: one linear sensor measuring x and y in the same units, no reason given for a 200-fold "
               "accuracy difference", {"r": (20.0, 20.0)},
               motivated_by="results: Table 1 prints RMSE_Y ≈ RMSE_X for every filter"),
        Option("rb-rad", "range-bearing at the origin, R = diag(20 m², 0.1 rad²)",
               "Section 4: 'r = diag([20, 0.1])', no unit: a (range, bearing) variance pair in the units of the "
               "computation; Section 5: IMM5CKF for 'nonlinear maneuvering target tracking problems'",
               {"sensor": "range-bearing"}),
        Option("rb-deg", "range-bearing at the origin, R = diag(20 m², 0.1 deg²)",
               "Section 4: 'r = diag([20, 0.1])' in the unit of the paper's printed angles, 'The right turn rate "
               "is defined as -3°'; Section 5: 'nonlinear maneuvering target tracking problems'",
               {"sensor": "range-bearing", "r": (20.0, 0.1 * (math.pi / 180.0) ** 2)})),
        "printed", "Eq. 62 and Section 4, after it"),
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
#: budget of universes: 2^5 x 3 x 4 = 384 is the full factorial: every share is exact (a universe of 100 runs costs
#: about half a core-second, so the full factorial about 3 core-minutes)
SPACE = ReadingSpace(NAME, FACTORS, budget=384)

#: the RMSE columns every universe replicates (OMTM-IMM is not published, Z-14)
RMSE_ALGORITHMS = ("IMM5CKF", "IMMCKF", "IMMUKF", "5CKF")
#: estimators run in every universe: Table 1's, the IMM-KF they coincide with, and the MMSE floor
MV_ALGORITHMS = RMSE_ALGORITHMS + ("IMM-KF", "clairvoyant KF")
#: every printed Monte Carlo number of Table 1 that a universe replicates (run times are not universes' values)
PUBLISHED = tuple(PublishedNumber("Table 1", "Table 1", alg, q, TABLE1[alg][qi])
                  for alg in RMSE_ALGORITHMS for qi, (q, _) in enumerate(QUANTITIES))
