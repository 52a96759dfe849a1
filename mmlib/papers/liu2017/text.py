"""What Liu & Wu 2017 print and leave open, as data: the tables as printed, the numbered deviations, the reading
space (:data:`FACTORS`, :data:`SPACE`), the published Monte Carlo numbers (:data:`PUBLISHED`) and the effects of the
specification curve (:data:`EFFECTS`).

Units: m, m/s, m/s^2 (ARMSE, Eq. 42), s (Table 2's times); quantities index the state [x, vx, ax, y, vy, ay]
(Eq. 37).  ``NAME``, ``CITATION``, ``DOI``, ``ROOT_SEED`` and ``N_RUNS`` (the paper's 200 Monte Carlo runs) are
the values :data:`mmlib.papers.liu2017.PAPER` is built from; code outside this package reads them from ``PAPER``.
"""
from __future__ import annotations

from mmlib.experiment.readings import Deviation, Factor, Option, ReadingSpace
from mmlib.experiment.universe import PublishedNumber

__all__ = [
    "PUBLISHED", "SPACE", "FACTORS", "DEVIATIONS", "published_mse_difference", "NAME", "TITLE", "CITATION", "DOI",
    "ROOT_SEED", "N_RUNS", "FILTERS", "QUANTITIES", "POSITION", "TABLE1", "TABLE2_TIME", "TABLE2_COMPLEXITY",
    "TABLE2_COUNTS", "TABLE2_N", "TABLE3", "CASES", "ITEMS", "PRINTED", "CASE_FILTERS", "ALGORITHMS", "ROW_DEVIATIONS",
    "KEY_EFFECT", "EFFECTS"
]

NAME = "liu2017"
TITLE = "Liu & Wu 2017: strong tracking spherical simplex-radial CKF"
CITATION = ("H. Liu, W. Wu, Strong Tracking Spherical Simplex-Radial Cubature Kalman Filter for Maneuvering "
            "Target Tracking, Sensors 17(4):741, 2017, doi:10.3390/s17040741")
DOI = "10.3390/s17040741"
ROOT_SEED = 20170331           # publication date
N_RUNS = 200
FILTERS = ("SSRCKF", "STF", "STUKF", "STCKF", "STSSRCKF")
QUANTITIES = (("Position ARMSE (m)", (0, 3)), ("Velocity ARMSE (m/s)", (1, 4)), ("Acceleration ARMSE (m/s^2)", (2, 5)))
POSITION = (0, 3)

#: Tables as printed: filter -> (position, velocity, acceleration ARMSE).
TABLE1 = {"SSRCKF": ("152.1", "31.2", "6.9"), "STF": ("129.7", "28.4", "6.2"), "STUKF": ("124.5", "27.5", "5.9"),
          "STCKF": ("123.1", "26.7", "5.8"), "STSSRCKF": ("119.3", "25.1", "5.6")}
TABLE2_TIME = {"SSRCKF": "0.07", "STF": "0.02", "STUKF": "0.14", "STCKF": "0.14", "STSSRCKF": "0.15"}
TABLE2_COMPLEXITY = {"SSRCKF": "O((2n+2)^3)", "STF": "O(n^2)", "STUKF": "O((2n+1)^3)", "STCKF": "O((2n)^3)",
                     "STSSRCKF": "O((2n+2)^3)"}
#: Per time step with n = 6, m = 2 (counted from mmlib/core/filters.py and mmlib/core/layers/strong_tracking.py,
#: which follow Eqs. 20-36): points, n x n Cholesky factorisations, evaluations of f, evaluations of h (when
#: lambda > 1), other n x n x n operations (n x n matrix products or linear solves: the EKF's F P F^T and its
#: Joseph-form covariance update (I - KH) P (I - KH)^T, the statistical fading factor's (P^l)^-1 P_xz of Eqs. 18-19).
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
ALGORITHMS = FILTERS + ("CKF",)
ROW_DEVIATIONS = {"Example 1": ["L-1", "L-2", "L-3", "L-4", "L-5", "L-6", "L-8", "L-9", "L-10"],
                  "Case 1": ["L-2", "L-3", "L-4", "L-5", "L-6", "L-7", "L-8", "L-9", "L-10"],
                  "Case 2": ["L-2", "L-3", "L-4", "L-5", "L-6", "L-7", "L-8", "L-9", "L-10"]}

#: where the text is missing, contradictory or wrong, and what we do there
DEVIATIONS = (
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
    Deviation("L-4", "UKF parameters",
              "not given; 'kappa is always set to n - 3' with negative centre weight for n > 3",
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
)

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
    ), "0.1", "Eqs. 37-39 (Q_ca and V not given); deviation L-2", kind="sensitivity"),
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

#: Kinds of factor (issue 24).  L-2 is a *sensitivity* factor: the paper never states Q_ca, so sqrt(q) is an unstated
#: tuning value, and its four levels (0.01 ... 10 m/s^2, a decade apart) sweep it rather than read the text; the
#: table match and "the readings that reproduce" keep it at its headline and its levels are reported as a curve.
#: Every other factor is a *reading*, each option quoting the text: L-1's two onsets are the set-up paragraph's
#: "first 150 s" and the discussion's "first 100 s ... starts at t = 101 s" (the 100 s option is the paper's own
#: sentence, read from its text, not chosen because it reproduces Table 1's position column: that it does is a
#: finding of the multiverse, reported as such); L-8's t0 / t0 + 1 s ("until t = 150 s" vs "a(151)"); L-3's
#: narrative vs Eq. 37; L-4's three kappas, each a sentence of Sec. 2; L-6's printed x_0|0 vs Sec. 3.4's Gaussian
#: prior.  No option is motivated by the results or by another paper (``motivated_by`` empty everywhere).
#:
#: 288 readings; at 200 runs a universe takes about 4 core-seconds, so within the reading spaces' share of the time
#: budget the auto design is a uniform random sample of 60 universes (shares with a 95 % Wilson interval at most
#: ±12.6 points wide; ±10 needs 96, about 2.5 more core-minutes), beside the headline and the star; the full factorial
#: is ``MULTIVERSE_UNIVERSES=288``.
SPACE = ReadingSpace(NAME, FACTORS, budget=60)

#: every printed Monte Carlo number a universe replicates (Table 2 is timing and analysis: not a universe value)
PUBLISHED = tuple(PublishedNumber("Table 1" if case == "Example 1" else "Table 3", ITEMS[case], alg, quantity,
                                  PRINTED[case][alg][qi])
                  for case in CASES for alg in FILTERS for qi, (quantity, _) in enumerate(QUANTITIES))


def published_mse_difference(case: str, a: str, b: str) -> float:
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

