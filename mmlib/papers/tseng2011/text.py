"""What Tseng, Chang & Jwo 2011 print, and what the reconstruction declares: the declared text of the paper.

What survives of the paper (the table of the vehicle's seven motion segments ``SEGMENTS`` and the table of
East/North position RMS errors ``TABLE``, m), the numbered deviations ``DEVIATIONS`` (T-1 ... T-15) for everything
the lost Section 4 leaves open, ``PUBLISHED``, the 12 numbers a universe replicates (the six RMS cells and the six
relative reductions 100 (1 - RMS_a / RMS_b) they imply, %), the names of the effects, and the name, citation and
root seed the paper's :class:`~mmlib.experiment.paper.Paper` (``mmlib.papers.tseng2011.PAPER``) is built from.
The reading space is in :mod:`mmlib.papers.tseng2011.space`.
"""
from __future__ import annotations

from mmlib.core import gnss
from mmlib.experiment.readings import Deviation
from mmlib.experiment.universe import PublishedNumber

__all__ = [
    "PUBLISHED", "DEVIATIONS", "published_mse_difference", "NAME", "TITLE", "DOI", "CITATION", "ROOT_SEED",
    "HEADLINE_RUNS", "CLOCKS", "P0_SD", "SEGMENTS", "TABLE", "ALGORITHMS", "PAIRS", "AXES", "ITEM", "KEY_EFFECT",
    "IMM_EFFECT", "EAST", "NORTH"
]

NAME = "tseng2011"
TITLE = "Tseng, Chang & Jwo 2011: fuzzy adaptive IMM-UKF for GPS navigation (a reconstruction)"
DOI = "10.3390/s110202090"
CITATION = ("C.-H. Tseng, C.-W. Chang, D.-J. Jwo, Fuzzy Adaptive Interacting Multiple Model Nonlinear Filter for "
            "Integrated Navigation Sensor Fusion, Sensors 11(2), 2090-2111, 2011, doi:10.3390/s110202090")
ROOT_SEED = 20110211
HEADLINE_RUNS = 100     # our headline's Monte Carlo runs: the paper's run count is not known (T-13)

#: Brown & Hwang 1997 (Introduction to Random Signals and Applied Kalman Filtering, 3rd ed., Sec. 9.3):
#: Allan-variance coefficients (h0, h-2) of a temperature-compensated and an oven-controlled crystal
CLOCKS = {"TCXO": (2e-19, 2e-20), "OCXO": (8e-20, 4e-23)}
#: the initial estimate's standard deviations (T-12): 10 m, 1 m/s per axis; 30 m, 1 m/s for the clock
P0_SD = (10.0, 1.0, 10.0, 1.0, 10.0, 1.0, 30.0, 1.0)

#: The surviving table of motion segments: (start s, end s, motion).
SEGMENTS = ((0, 300, "constant velocity straight line"), (301, 700, "circular motion (counter-clockwise)"),
            (701, 800, "constant velocity straight line"), (801, 900, "counter-clockwise turn"),
            (901, 1200, "constant velocity straight line"), (1201, 1400, "clockwise turn"),
            (1401, 1800, "constant velocity straight line"))
#: The surviving table of East/North position RMS errors (m).
TABLE = {"UKF": ("7.9530", "6.3195"), "IMMUKF": ("2.9967", "2.3021"), "FUZZY-IMMUKF": ("1.0184", "0.7286")}
ALGORITHMS = ("UKF", "IMMUKF", "FUZZY-IMMUKF")
EAST, NORTH = gnss.POSITION_INDEX[0], gnss.POSITION_INDEX[1]

#: the numbered deviations: what the lost set-up leaves open, our choice and why (and the factor that sweeps it)
DEVIATIONS = (
    Deviation("T-1", "vehicle motion", "seven segments over 1800 s (table); speeds, turn rates, start not given",
              "a land vehicle at a constant 20 m/s on a horizontal plane, starting East; segment 2 a full "
              "counter-clockwise circle in 400 s (0.9 deg/s, radius 1.27 km, 0.31 m/s^2), segment 4 a 90-degree "
              "counter-clockwise turn in 100 s (0.9 deg/s), segment 6 a 90-degree clockwise turn in 200 s (0.45 "
              "deg/s); "
              "turn boundaries at 300/700/800/900/1200/1400 s",
              "The table's segment lengths with plain road-vehicle turns (a circle is 360 degrees; a 'turn' is read "
              "as a 90-degree change of course).  Speed sets the centripetal acceleration and is swept.",
              "factor T-1 (speed 10 / 30 m/s)"),
    Deviation("T-2", "sampling", "not given (the segment table is in whole seconds)", "T = 1 s, 1800 epochs", ""),
    Deviation("T-3", "satellites", "'GPS' only; constellation, epoch, site and elevation mask not given",
              "a nominal 24-satellite constellation (6 planes of 4, 55 deg, circular orbits, Walker 24/6/1 phasing) "
              "propagated in closed form (mmlib.core.gnss), site at 25.15 N, 121.78 E (the authors' university, "
              "Keelung), "
              "10-degree mask: 6-7 satellites in view, the set changing once in the 30 minutes",
              "No package propagates a nominal constellation without an almanac; a circular orbit is a closed form "
              "(IS-GPS-200 with e = 0).  Frames are converted with pymap3d.", ""),
    Deviation("T-4", "pseudorange noise", "not given", "white, 3 m s.d., independent between satellites; no "
              "atmospheric or multipath errors, no transit time or Sagnac term (truth and filter share the model)",
              "A C/A-code pseudorange after broadcast corrections.", "factor T-4 (sigma 1 / 10 m)"),
    Deviation("T-5", "receiver clock", "'clock bias and drift' (issue); values not given",
              "two-state clock, TCXO Allan coefficients h0 = 2e-19, h-2 = 2e-20 (Brown & Hwang 1997, Sec. 9.3, "
              "table of timing standards), the same model in truth and filter; truth starts at zero bias and drift",
              "A vehicle receiver's oscillator is a temperature-compensated crystal.  The clock's random walk is "
              "common to all pseudoranges but trades off against the position through the geometry, so it moves "
              "the absolute errors (an oven-controlled crystal lowers them by ~3 %, several s.e.): a factor.",
              "factor T-5 (TCXO / OCXO)"),
    Deviation("T-6", "UKF parameters", "alpha in [1e-4, 1], beta = 2, kappa 'usually 0' (Sec. 2.2)",
              "alpha = 1, beta = 2, kappa = 0",
              "Within the printed ranges; alpha << 1 puts weights of order -1e6 on points whose pseudoranges are "
              "~2e7 m, which costs digits for nothing (the measurement is nearly linear over the spread).", ""),
    Deviation("T-7", "filter model and IMM modes", "'tightly-coupled' GPS/INS (Fig. 4); state, INS and Q not "
              "given; IMM modes 'use' the lower and upper bounds of the process noise (Sec. 3, conclusions)",
              "8-state position-velocity-clock filter on raw pseudoranges (the tightly coupled measurement); no "
              "INS: the kinematic model stands in for it; two IMM modes with acceleration PSD S_p = 0.01 "
              "(straight legs) and 1 m^2/s^3 (maneuvers)",
              "Simulating an INS would turn the filter's process noise into inertial-sensor noise, which does not "
              "change with the vehicle's maneuvers: the paper's premise (Q must follow the dynamics) fits the "
              "kinematic model.  The bounds span a straight leg to ~1 m/s^2 turns.", "factor T-7 (0.001/0.1, 0.1/10)"),
    Deviation("T-8", "UKF's process noise", "not given", "S_p = the geometric mean of the IMM's bounds (0.1 m^2/s^3)",
              "A single filter must compromise between the straight legs and the turns; giving it the IMM's lower "
              "bound would make the comparison a straw man.  Reading-space factor T-8: geometric mean, the IMM's "
              "lower bound, ten times below it, the IMM's upper bound.",
              "factor T-8"),
    Deviation("T-9", "IMM Markov chain and start", "not given", "p_ii = 0.99 (mean sojourn 100 s, the shortest "
              "segment), initial mode probabilities (0.5, 0.5)",
              "The staying probability sets how readily the IMM switches to its upper mode and moves every IMM "
              "result (0.95 shrinks IMMUKF's gain over the UKF by a third): a factor.  The initial mode "
              "probabilities cannot move a result: the mode probabilities forget their start within a few of the "
              "1800 epochs; measured on the full set-up at 25 runs, (0.9, 0.1) and (1, 0) move no value or effect "
              "by more than 0.2 standard errors and change no claim verdict (test_tseng2011 checks < 1 s.e.).",
              "factor T-9 (p_ii 0.99 / 0.95 / 0.996); initial mode probabilities fixed (measured)"),
    Deviation("T-10", "FLAS membership functions and rules", "Takagi-Sugeno with DOD inputs (Sec. 3.2); sets, rules "
              "and consequents lost", "inputs xi/s and eta/sqrt(s), the Sec. 3.2 DOD over the predicted innovation "
              "variance per satellite s = tr(S)/m (of the IMM's mixture prior); three sets each, "
              "Normal/Moderate/Large, "
              "peaks at (1, 2, 4) for xi/s and 0.80 * sqrt of those for eta/sqrt(s); 9 rules: the output position "
              "p = max(level of xi, level of eta)/2; log10 lower = log10 S_L + p * D, log10 upper = log10 S_L + D + "
              "p * D with D = half the IMM's log-range, so the bounds slide between (0.01, 0.1) and (0.1, 1)",
              "First principles, not fitted: for a consistent filter xi/s ~ chi2_m/m (mean 1; 95 % quantile ~2, "
              "99.9 % ~3.5-3.7 for the 6-7 satellites in view) and eta/sqrt(s) ~ 0.80 sqrt(xi/s); either input "
              "diverging raises the noise; the fuzzy bounds never leave the plain IMM's range, so the comparison is "
              "fair.  The first version divided by the pseudorange variance sigma^2 instead; review found its "
              "stated justification wrong (the mean is 1 + tr(HPH^T)/(m sigma^2) ~ 1.25, not 1), so it was "
              "corrected and is kept as an option of factor "
              "T-10a.", "factors T-10a (normalisation), T-10b (breakpoints x0.5 / x2)"),
    Deviation("T-11", "FLAS timing, innovation and DOD window", "the DOD uses the innovation 'at present epoch "
              "(i.e., the window size is one)' (Sec. 3.2); timing not given",
              "window of one epoch; the DOD at epoch k (innovation against the IMM's predicted measurement "
              "sum_j c_j zhat_j) sets the bounds used from epoch k+1; the first epoch uses the 'Normal' bounds",
              "The text names a window of one.  'Window size' presupposes the moving-window innovation covariance "
              "(1/W) sum v v^T of innovation-based adaptive filtering, so longer windows are declared readings: "
              "4 epochs (halves the DOD's chi-square spread) and 16 (a quarter; still far shorter than the shortest "
              "segment, 100 s).", "factor T-11 (window 1 / 4 / 16 epochs)"),
    Deviation("T-12", "initial estimate", "not given", "truth plus a draw from N(0, P0), P0 = diag(10 m, 1 m/s per "
              "axis; 30 m, 1 m/s clock)^2, the same draw for all filters",
              "A rough first fix.  It cannot move a result: 6-7 pseudoranges of 3 m fix the position within an "
              "epoch, so the initial error is a transient of a few of the 1800 epochs averaged.  Measured on the "
              "full set-up at 25 runs (the same standard normal draws, scaled): P0 ten times larger moves no value "
              "or effect by more than 0.3 standard errors, ten times smaller by at most 0.8, and no claim verdict "
              "changes (test_tseng2011 checks < 1 s.e.).", "fixed (measured non-influential)"),
    Deviation("T-13", "Monte Carlo", "not stated (Fig. 15 shows RMS errors, so several runs)",
              "100 runs; RMS over runs and all 1800 epochs; 25 runs per universe of the reading space", ""),
    Deviation("T-15", "strong tracking (Appendix B)", "the STUKF of ref. [9] is summarised in Appendix B",
              "not used", "Neither the table nor the surviving text uses STUKF in the comparison; FUZZY-IMMUKF adapts "
              "Q through the IMM's bounds, not through fading factors (mmlib's StrongTracking layer would give "
              "it).", ""),
    Deviation("T-14", "verdict basis", "absolute errors depend on every unknown above",
              "absolute RMS rows are judged by the one verdict rule like every row with a value (their note says "
              "the set-up is a reconstruction); the ranking and the relative improvements (1 - RMS_a/RMS_b) are the "
              "rows a reconstruction can meaningfully test", ""),
)


#: the absolute RMS cells and the relative reductions they imply
PAIRS = (("IMMUKF", "UKF"), ("FUZZY-IMMUKF", "IMMUKF"), ("FUZZY-IMMUKF", "UKF"))
#: (label, column of TABLE, state component) of the two axes
AXES = (("East", 0, EAST), ("North", 1, NORTH))
ITEM = "Table (RMS errors)"
PUBLISHED = tuple(
    [PublishedNumber(ITEM, ITEM, alg, f"{lab} position RMS error (m)", TABLE[alg][i])
     for alg in ALGORITHMS for lab, i, _ in AXES]
    + [PublishedNumber("RMS reductions (from the table)", ITEM, f"{a} vs {b}", f"{lab} RMS reduction (%)",
                       f"{100.0 * (1.0 - float(TABLE[a][i]) / float(TABLE[b][i])):.2f}")
       for a, b in PAIRS for lab, i, _ in AXES])
#: the key effect (the specification curve's) and the IMM's gain over the UKF: paired MSE differences (m²)
KEY_EFFECT = "FUZZY-IMMUKF - IMMUKF: Δ MSE East+North (m²)"
IMM_EFFECT = "IMMUKF - UKF: Δ MSE East+North (m²)"


def published_mse_difference(a: str, b: str) -> float:
    """The published counterpart of a paired MSE difference (m²): RMS² is the mean squared error over
    runs and epochs, so (E_a² + N_a²) - (E_b² + N_b²) from the printed table."""
    sq = (lambda alg: sum(float(v) ** 2 for v in TABLE[alg]))
    return sq(a) - sq(b)
