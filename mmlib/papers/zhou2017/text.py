"""What Zhou, Zhao, Huang & Zhao 2017 printed, and what it leaves open, as data.

The Section 2.3 example and Tables 1-5 as printed; the numbered deviations ``DEVIATIONS`` (Z-1 ... Z-13) where the
text is missing, garbled or contradictory; the reading space ``SPACE`` of the ambiguities (``FACTORS``, ids =
deviation numbers); the printed Monte Carlo numbers a universe replicates (``PUBLISHED``, Tables 2 and 3) and the
key effect's name and published counterpart (:func:`published_mse_difference`).  ``NAME``, ``CITATION``, ``DOI``,
``ROOT_SEED`` and ``N_RUNS`` (the paper's 100 Monte Carlo runs, Sec. 4.1) are the values the package's
:class:`~mmlib.experiment.paper.Paper` is built from.
"""
from __future__ import annotations

import math

from mmlib.experiment.readings import Deviation, Factor, Option, ReadingSpace
from mmlib.experiment.universe import PublishedNumber

__all__ = [
    "PUBLISHED", "SPACE", "FACTORS", "DEVIATIONS", "published_mse_difference", "NAME", "TITLE", "CITATION", "DOI",
    "ROOT_SEED", "N_RUNS", "TABLE1", "TABLE2", "TABLE3", "TABLE_QUANTITIES", "TABLE4", "TABLE5", "MAE_QUANTITIES",
    "CASE1_ALGORITHMS", "CASE2_ALGORITHMS", "ALGORITHMS", "TABLE2_NAMES", "TABLE3_NAMES", "TABLE2_DEVIATIONS",
    "TABLE3_DEVIATIONS", "KEY_EFFECT", "EXAMPLE_MEANS", "EXAMPLE_SD", "EXAMPLE_U"
]

NAME = "zhou2017"
TITLE = "Cubature-principle-assisted IMM with a new adaptive UKF (CPIMM-NAUKF)"
CITATION = ("H. Zhou, H. Zhao, H. Huang, X. Zhao, A Cubature-Principle-Assisted IMM-Adaptive UKF Algorithm for "
            "Maneuvering Target Tracking Caused by Sensor Faults, Applied Sciences 7(10), 2017 (published 28 "
            "September 2017)")
DOI = "10.3390/app7101003"
ROOT_SEED = 20170928
N_RUNS = 100                   #: Monte Carlo runs of Sec. 4.1

#: Section 2.3 example and Table 1 (the CP value is quoted in Section 3.1.3).
EXAMPLE_MEANS, EXAMPLE_SD, EXAMPLE_U = (-3.0, 0.0, 5.0), (3.0, 2.25, 1.8), (0.3, 0.4, 0.3)
TABLE1 = {"MSE": ("0.6000", "3.9417"), "MC": ("0.5937", "1.3906"), "CP": ("0.6", "1.3826")}
#: Tables 2 and 3: position mean, s.d. (m); velocity mean, s.d. (m/s).
TABLE2 = {"IMM": ("3.8245", "2.0377", "0.7102", "0.6935"), "CPIMM": ("2.0630", "1.1604", "0.4596", "0.4187")}
TABLE3 = {"IMM-UKF": ("11.8533", "4.3387", "3.1026", "1.9552"), "IMM-NAUKF": ("7.0473", "2.9116", "1.2143", "1.0348"),
          "CPIMM-UKF": ("9.3558", "3.0098", "2.4961", "1.2246"),
          "CPIMM-NAUKF": ("4.8671", "0.9169", "0.4294", "0.3857")}
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

#: the numbered deviations (Z-1 ... Z-13), in the order of the notebook's table
DEVIATIONS = (
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
              "is a factor: a sensitivity factor, P0 being an unstated tuning value.", "sensitivity factor Z-5"),
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
              "makes sense. The window (10 or 30), an unstated tuning value, is a sensitivity factor; Psi = 1 is the "
              "smallest value Eq. 32 allows.", "sensitivity factor Z-8"),
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
              "the filters use the printed q (headline); 0.1 q and 0.01 q sweep the lost scaling (the truth "
              "keeps the printed q when it carries noise, Z-4)",
              "A sensitivity factor, not a reading: the three levels share one sentence of text and tune an unstated "
              "value; they are reported as a curve (verdict against the level), never as a reading that reproduces. "
              "Nothing is fitted to a published number.", "sensitivity factor Z-13"),
)


# ---------------------------------------------------------------- reading space (issue 10)
FACTORS = (
    Factor("Z-2", "process-noise gain Gamma (Eqs. 1-2, 42/44)", (
        Option("dwna", "Gamma = [T²/2, T] per axis", "Eqs. 1-2 write Gamma W with Gamma not given; Eqs. 42/44 give one "
               "variance per model (sigma_CV^2 = 5, sigma_CT^2 = 20), i.e. a scalar acceleration noise per axis, whose "
               "discretised gain is [T^2/2, T] (Bar-Shalom, Li & Kirubarajan 2001, Sec. 6.3.2)",
               {"noise_gain": "dwna"}),
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
    ), "P0-10m", "Sec. 4.1 (P0 not given)", kind="sensitivity"),
    Factor("Z-6", "sensor-fault model of Case 2", (
        Option("drift", "range offset + accumulating bearing drift", "Sec. 4.1 'distance deviation within "
               "[-5 m, 5 m]' and 'angle drift *rate* within [0, 1e-2 rad/s]' (a rate accumulates); Sec. 1 'fixed "
               "deviation, drift deviation'", {"fault_kind": "constant-drift"}),
        Option("per-step", "fresh range and bearing deviations each step", "Sec. 4.1 'delta h_out,k = [delta r_k, "
               "delta theta_k]' carries the step index k: one draw per step", {"fault_kind": "per-step"}),
        Option("constant", "constant range and bearing offsets", "Sec. 1: the faults considered are 'fixed deviation' "
               "and 'drift deviation'; the bearing offset read as a fixed deviation of up to 1e-2 rad",
               {"fault_kind": "constant"},
               motivated_by="results: first declared in answer to issue 10, which opens on the drift reading's IMM-UKF "
                            "error of ~718 m against Table 3's 11.85 m (the per-step reading predates any result)"),
    ), "drift", "Sec. 4.1 (Case 2) and Sec. 1"),
    Factor("Z-7", "UKF parameters (alpha, beta, kappa)", (
        Option("kappa3-n", "UKF alpha = 1, beta = 0, kappa = 3 - n", "not given (Sec. 3.2 cites [3] for the weights "
               "W_i, which does not define them); Sec. 4.2.1 'UKF can reach third order accuracy': kappa = 3 - n "
               "matches the Gaussian's fourth moment (Julier & Uhlmann 1997)", {"ukf": (1.0, 0.0, -1.0)}),
        Option("scaled", "UKF alpha = 1e-3, beta = 2, kappa = 0", "not given, as above: the scaled unscented transform "
               "with the usual defaults (Wan & van der Merwe 2000; beta = 2 optimal for Gaussian priors)",
               {"ukf": (1e-3, 2.0, 0.0)}),
    ), "kappa3-n", "Sec. 3.2 (UKF weights cited to [3], not given)", kind="sensitivity"),
    Factor("Z-8", "NAUKF innovation window (P_zz~ of Eq. 27)", (
        Option("w10", "window of 10 innovations", "Eq. 27 needs an estimate of the innovation covariance; not "
               "given — 10 samples is the smallest common choice for a 2-D innovation", {"window": 10}),
        Option("w30", "window of 30 innovations", "Eq. 27, as above; a longer window (30 % of the 100-s run) "
               "trades tracking of the fault for a steadier estimate", {"window": 30}),
    ), "w10", "Sec. 3.2, Eq. 27 (P_zz~ undefined)", kind="sensitivity"),
    Factor("Z-12", "NAUKF innovation covariance (Eqs. 28, 37, 39)", (
        Option("as-printed", "NAUKF as printed", "Eqs. 27-28 give P_zz = P_zz~ (the empirical covariance); "
               "Eqs. 37, 39 use it with the unmodified P_xz", {"inflate_only": False}),
        Option("inflate-only", "NAUKF inflate-only", "Sec. 3.2 'to avoid the divergence problem' and Eq. 34 "
               "(zeta >= 1): the adaptation is meant only to enlarge the covariance", {"inflate_only": True},
               motivated_by="results: introduced as a variant 'not in the paper' after NAUKF as printed diverged in "
                            "every run of this set-up (commit 845025b); the text it quotes was cited for it later"),
    ), "as-printed", "Secs. 3.2-3.3"),
    Factor("Z-13", "filters' process-noise intensity (Eqs. 42/44)", (
        Option("q", "filters' q as printed", "Sec. 4.1: sigma_CV^2 = 5, sigma_CT^2 = 20", {"filter_q_scale": 1.0}),
        Option("q/10", "filters' q / 10", "Eqs. 42/44 garbled ('N(,;0;sigma^2)'): the noise gain and unit are lost, "
               "so the printed variances fix the filters' Q only up to its unknown scaling", {"filter_q_scale": 0.1}),
        Option("q/100", "filters' q / 100", "Eqs. 42/44 garbled, as above", {"filter_q_scale": 0.01}),
    ), "q", "Sec. 4.1, Eqs. 42/44 (garbled)", kind="sensitivity"),
)
#: Kinds (issue 24): Z-5 (P0), Z-7 (the UKF's weights), Z-8 (NAUKF's window) and Z-13 (the filters' q, q/10, q/100)
#: are *sensitivity* factors:
#: the paper states none of these values, and their options are levels of an unstated tuning value (one sentence of
#: text, "not given", behind every level), not alternatives the text supports; they are reported as curves, never as
#: a reading that reproduces.  The other factors are readings.  Options motivated by results (``motivated_by``): Z-6
#: "constant" and Z-12 "inflate-only" (their histories are in their ``motivated_by``); none is motivated by another
#: paper.  The readings of the text alone are 2 (Z-2) x 2 (Z-3) x 2 (Z-4) x 2 (Z-6) = 16 universes.  Under Z-6 "drift"
#: with the mrad² bearing variance they are degenerate (:func:`mmlib.papers.zhou2017.study.degenerate_reason`); under
#: "drift" with deg² the bearing noise is so large that the filters beat the raw measurements by averaging it, so
#: they are not flagged, although the drift is as unobservable there (the notebook's observability check).
#:
#: the full factorial (2 x 2 x 2 x 2 x 3 x 2 x 2 x 2 x 3 = 1152 universes) exceeds the budget, so the auto design
#: is a uniform random sample of 200 universes (shares with a 95 % Wilson interval at most ±6.9 points wide), beside
#: the headline and the star; every factor is influential, so the full product of the influential factors is the
#: full factorial, ``MULTIVERSE_UNIVERSES=1152``
SPACE = ReadingSpace(NAME, FACTORS, budget=200)

CASE1_ALGORITHMS = ("IMM-UKF", "CPIMM-UKF", "IMM-EKF", "IMM-CKF")
CASE2_ALGORITHMS = ("IMM-UKF", "IMM-NAUKF", "CPIMM-UKF", "CPIMM-NAUKF")
#: the estimators of a universe (its diverged-run counts): Case 1 and Case 2
ALGORITHMS = tuple(f"case 1 {a}" for a in CASE1_ALGORITHMS) + tuple(f"case 2 {a}" for a in CASE2_ALGORITHMS)
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


def published_mse_difference(table: dict, a: str, b: str) -> float:
    r"""Published counterpart of a paired time-averaged MSE difference, from a table's mean m and
    s.d. s over the steps of the per-step RMSE (Eq. 45): the time average of RMSE_k^2 is
    :math:`m^2 + s^2` (s the population s.d. over the steps; if the paper used the sample s.d.,
    the value changes by a factor (K-1)/K on s^2, i.e. < 1 % of it), so the difference is
    :math:`(m_a^2 + s_a^2) - (m_b^2 + s_b^2)` in m^2."""
    ma, sa = float(table[a][0]), float(table[a][1])
    mb, sb = float(table[b][0]), float(table[b][1])
    return (ma * ma + sa * sa) - (mb * mb + sb * sb)

