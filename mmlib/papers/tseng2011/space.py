"""The reading space of Tseng et al. 2011 (issue 10): every ambiguity of the lost set-up that can move a result is a
numbered factor (the deviation of :mod:`mmlib.papers.tseng2011.text` that discusses it) whose options are readings
the surviving text supports, each with the :class:`~mmlib.papers.tseng2011.setup.Setup` fields it sets.

Factors: T-1 speed, T-4 pseudorange noise, T-5 the receiver clock, T-7 the IMM's levels, T-8 the single UKF's level,
T-9 the IMM's Markov chain, T-10a/b the FLAS's input normalisation and breakpoints, T-11 the DOD window.

Kinds (issue 24, :attr:`mmlib.experiment.readings.Factor.kind`).  Section 4 is lost, so nearly every factor sweeps a
value we had to invent rather than choosing between alternatives the text supports: T-1, T-4, T-5, T-7, T-8, T-9,
T-10b and T-11 are ``sensitivity`` factors (their options are tuning values over a plausible range; the quotations in
their sources motivate the range, they do not choose a value; T-11's text even states its value, a window of one,
and the longer windows sweep away from it).  T-10a is the one ``reading`` factor: how the lost membership functions
were scaled is a question about the text (Sec. 3.1 'normalized fuzzy subset' against Sec. 3.2's raw DOD), and its
two options are structural alternatives, not levels of one value.  T-9's option 0.95 is Hu et al. 2017's value,
marked ``motivated_by`` another paper; the headline 0.99 was chosen from the segment table (its mean sojourn is the
shortest segment) before its coincidence with Zhou et al. 2017's value was noted, so it is not motivated by it.

Held fixed
(not factors), each with its reason in its deviation: T-2, T-3, T-6 (the UKF equals the EKF to 1e-6 m here, so its
spread parameters cannot matter), T-9's initial mode probabilities and T-12 (measured: neither moves any value by as
much as one standard error, :data:`NON_INFLUENTIAL`), T-13 and T-15.
"""
from __future__ import annotations

from mmlib.experiment.readings import Factor, Option, ReadingSpace
from mmlib.papers.tseng2011.text import CLOCKS, NAME, P0_SD

__all__ = [
    "SPACE", "FACTORS", "NON_INFLUENTIAL"
]


def _opt(name, label, source, motivated_by="", **changes) -> Option:
    return Option(name, label, source, changes, motivated_by=motivated_by)


_LOST = "Section 4 (simulation set-up) did not survive"
FACTORS = (
    Factor("T-1", "vehicle speed", (
        _opt("20", "20 m/s", f"{_LOST}; a land vehicle ('vehicle navigation', title) at a typical road speed",
             speed=20.0),
        _opt("10", "10 m/s", f"{_LOST}; a slow urban vehicle (the segment table gives times only)", speed=10.0),
        _opt("30", "30 m/s", f"{_LOST}; a highway vehicle (the segment table gives times only)", speed=30.0)),
        "20", "segment table (times only); T-1.  Sensitivity: an invented speed swept over road speeds; no surviving "
        "text chooses among them", kind="sensitivity"),
    Factor("T-4", "pseudorange noise s.d.", (
        _opt("3", "sigma_pr = 3 m", f"{_LOST}; a C/A-code pseudorange after broadcast corrections", sigma_pr=3.0),
        _opt("1", "sigma_pr = 1 m", f"{_LOST}; a smoothed or dual-frequency pseudorange", sigma_pr=1.0),
        _opt("10", "sigma_pr = 10 m", f"{_LOST}; an uncorrected single-frequency pseudorange", sigma_pr=10.0)),
        "3", "'GPS' pseudoranges, noise not given; T-4.  Sensitivity: an invented noise level swept over a decade",
        kind="sensitivity"),
    Factor("T-5", "receiver clock oscillator", (
        _opt("TCXO", "TCXO clock (h0 2e-19, h-2 2e-20)",
             f"{_LOST}; Sec. 1: 'clock bias and drift' states of a vehicle GPS receiver, whose oscillator is a "
             "temperature-compensated crystal (Brown & Hwang 1997, Sec. 9.3)",
             clock_h0=CLOCKS["TCXO"][0], clock_h_minus2=CLOCKS["TCXO"][1]),
        _opt("OCXO", "OCXO clock (h0 8e-20, h-2 4e-23)",
             f"{_LOST}; a receiver with an oven-controlled crystal, the other oscillator of Brown & Hwang's "
             "table (Sec. 9.3)", clock_h0=CLOCKS["OCXO"][0], clock_h_minus2=CLOCKS["OCXO"][1])),
        "TCXO", "clock model not given; T-5.  Sensitivity: invented Allan coefficients, the two crystals of Brown & "
        "Hwang's table", kind="sensitivity"),
    Factor("T-7", "IMM modes' acceleration PSD (lower / upper)", (
        _opt("0.01/1", "IMM S_p 0.01 / 1 m²/s³",
             "Sec. 3 and conclusions: the modes use 'the lower and upper bounds of the process noise'; a straight "
             "leg to the ~0.3-1 m/s² turns of the segment table", s_lower=0.01, s_upper=1.0),
        _opt("0.001/0.1", "IMM S_p 0.001 / 0.1 m²/s³",
             "Sec. 3: lower and upper bounds (values lost); a decade lower: a quiet lower mode", s_lower=0.001,
             s_upper=0.1),
        _opt("0.1/10", "IMM S_p 0.1 / 10 m²/s³",
             "Sec. 3: lower and upper bounds (values lost); a decade higher: a 'high dynamic' upper mode "
             "(conclusions)", s_lower=0.1, s_upper=10.0)),
        "0.01/1", "Sec. 3, conclusions; T-7.  Sensitivity: the text names a lower and an upper bound but no value; the "
        "options shift both by a decade (a tuning sweep of the filters' Q)", kind="sensitivity"),
    Factor("T-8", "single UKF's acceleration PSD", (
        _opt("geometric", "UKF S_p = geometric mean of the IMM's",
             f"{_LOST}; one filter compromising between the IMM's two modes", ukf_rule="geometric"),
        _opt("lower", "UKF S_p = the IMM's lower level",
             "Sec. 1, 5: the 'classical UKF' cannot follow changes in dynamics, i.e. is tuned for the quiet legs",
             ukf_rule="lower"),
        _opt("below", "UKF S_p = 10x below the IMM's lower level",
             "Sec. 2 (abstract): the UKF suffers from the 'uncertainty of the process noise' (an under-set Q)",
             ukf_rule="below"),
        _opt("upper", "UKF S_p = the IMM's upper level",
             f"{_LOST}; a UKF tuned for the maneuvers (the 'high dynamic environments' of the conclusions)",
             ukf_rule="upper")),
        "geometric", "UKF's process noise not given; T-8.  Sensitivity: the UKF's Q is an invented level swept from "
        "ten times below the IMM's lower bound to its upper bound; the quotations motivate the ends of the range, "
        "they do not give a value", kind="sensitivity"),
    Factor("T-9", "IMM's staying probability p_ii", (
        _opt("0.99", "p_ii = 0.99 (mean sojourn 100 s)",
             "Sec. 2.2: the modes are a Markov chain, transition probabilities not printed; the mean sojourn "
             "1/(1 - p_ii) equals the shortest segment of the segment table (100 s); chosen so in the first "
             "reconstruction, before its coincidence with Zhou et al. 2017's value was noted", p_stay=0.99),
        _opt("0.95", "p_ii = 0.95 (mean sojourn 20 s)",
             "Sec. 2.2 (values not printed); a readily switching chain, the staying probability of the two-mode "
             "IMM of Hu et al. 2017 (High Technology Letters 23(2), replicated here)", p_stay=0.95,
             motivated_by="another paper: Hu et al. 2017 (High Technology Letters 23(2)), its two-mode IMM's p_ii"),
        _opt("0.996", "p_ii = 0.996 (mean sojourn 257 s)",
             "Sec. 2.2 (values not printed); the mean sojourn equals the mean segment length of the segment table "
             "(1800 s / 7)", p_stay=0.996)),
        "0.99", "Sec. 2.2 (transition probabilities not printed); T-9.  Sensitivity: an invented staying probability "
        "swept over mean sojourns of 20-257 s", kind="sensitivity"),
    Factor("T-10a", "FLAS input normalisation", (
        _opt("innovation", "DOD over predicted innovation variance",
             "Sec. 3.1: fuzzification 'transforms the error signal into a normalized fuzzy subset'; the innovation's "
             "own predicted variance makes xi/s ~ chi2_m/m", dod_normalise="innovation"),
        _opt("measurement", "DOD over the pseudorange variance",
             "Sec. 3.2: xi and eta are raw innovation magnitudes; dividing by the measurement-noise variance "
             "(the first design of this replication)", dod_normalise="measurement")),
        "innovation", "Sec. 3.1-3.2 (equations lost); T-10.  Reading: which normalisation the lost membership "
        "functions presuppose is a question about the text (Sec. 3.1 'normalized fuzzy subset', Sec. 3.2's DOD in "
        "m²), answered by two structural alternatives, not levels of one value", kind="reading"),
    Factor("T-10b", "FLAS membership-function breakpoints", (
        _opt("x1", "breakpoints (1, 2, 4)", "Sec. 3.1: 'selects reasonable ... membership functions'; chi-square "
             "mean, ~95 % and ~99.9 % quantiles of a consistent filter's DOD", mf_scale=1.0),
        _opt("x0.5", "breakpoints x0.5 (more sensitive)", "Sec. 3.1: membership functions not printed; a FLAS "
             "that reacts earlier", mf_scale=0.5),
        _opt("x2", "breakpoints x2 (less sensitive)", "Sec. 3.1: membership functions not printed; a FLAS "
             "that reacts only to gross divergence", mf_scale=2.0)),
        "x1", "Sec. 3.1 (sets and rules lost); T-10.  Sensitivity: the breakpoints are invented (chi-square "
        "quantiles) and scaled by 0.5 and 2", kind="sensitivity"),
    Factor("T-11", "DOD window", (
        _opt("1", "DOD window 1 epoch", "Sec. 3.2: 'at present epoch (i.e., the window size is one)'",
             dod_window=1),
        _opt("4", "DOD window 4 epochs", "Sec. 3.2: 'window size' of the moving-window innovation covariance; "
             "4 epochs halve the one-epoch DOD's spread", dod_window=4),
        _opt("16", "DOD window 16 epochs", "Sec. 3.2: 'window size' of the moving-window innovation covariance; "
             "16 epochs quarter the spread and stay below the shortest segment (100 s)", dod_window=16)),
        "1", "Sec. 3.2; T-11.  Sensitivity: the text states a window of one; 4 and 16 epochs sweep away from it to "
        "measure how much the DOD's smoothing matters", kind="sensitivity"),
)

#: the full product is 3*3*2*3*4*3*2*3*3 = 11664 universes; a universe (1800 epochs of per-step Python) takes about
#: 5.5 core-seconds, so within the reading spaces' share of the time budget the auto design is a uniform random
#: sample of 60 (shares with a 95 % Wilson interval at most ±12.6 points wide; ±10 needs 96, about 3.3 more
#: core-minutes), beside the headline and the star
SPACE = ReadingSpace(NAME, FACTORS, budget=60)
#: Set-up changes measured not to move any value or effect by one standard error (T-9's initial mode
#: probabilities, T-12's initial-estimate spread), kept fixed rather than declared as factors; the tests
#: check the claim.
NON_INFLUENTIAL = {"T-9 initial mode probabilities (0.9, 0.1)": dict(mu0=(0.9, 0.1)),
                   "T-9 initial mode probabilities (1, 0)": dict(mu0=(1.0, 0.0)),
                   "T-12 P0 x10": dict(p0_sd=tuple(10.0 * v for v in P0_SD)),
                   "T-12 P0 x0.1": dict(p0_sd=tuple(0.1 * v for v in P0_SD))}
