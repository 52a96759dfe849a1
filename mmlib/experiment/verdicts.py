"""The one verdict rule of this repository: paper-versus-replication rows and the claim vocabulary.

The verdict rule (the only one in this repository)
--------------------------------------------------
For a printed value ``p`` and our Monte Carlo estimate ``r`` with standard
error ``s`` from ``N`` runs, where the paper used ``N_p`` runs:

* the paper's own Monte Carlo error is unknown; it is estimated as
  ``s_p = s * sqrt(N / N_p)`` (same estimator, same spread), and the printed
  value is only known to half a unit of its last digit, ``u``;
* ``sigma = sqrt(s^2 + s_p^2 + u^2)``;
* **reproduced**            if ``|r - p| <= 3 sigma``  (consistent within Monte Carlo noise);
* **inconclusive**          if it would be reproduced, but ``3 sigma > 0.25 |p|``: our interval is wider
  than the qualitative band, so it cannot tell a reproduction from a 25 % discrepancy (e.g. a value
  whose runs mostly diverged); such a value never counts as reproducing a printed number;
* **qualitatively reproduced** if not within ``3 sigma``, but ``|r - p| <= 0.25 |p|``  (same value
  within 25 %, i.e. the effect sizes the papers argue about are preserved);
* **not reproduced**        otherwise;
* **not replicable**        when no replicated value can be produced (method or data
  not published); the reason is part of the verdict text.

Three refinements complete the rule:

* **exact values**: a value computed analytically (no Monte Carlo error) is **reproduced (exact)** when it equals
  the printed number to the printed precision, **not reproduced (exact)** otherwise (:func:`exact_row`);
* **joint tests**: a table (the rows of one item) and each of its rows (one item and algorithm) are tested
  jointly: the sum of squared standardized distances of their Monte Carlo cells against chi-squared with one
  degree of freedom per cell at the level of the 3-sigma rule, 2 Phi(-3) = 0.0027 (:func:`joint_test`); a cell
  *reproduced* inside a table or row that fails is **reproduced (isolated)**, a coincidence that never counts as
  reproducing the paper (:func:`joint_tests`, :func:`is_reproduced`);
* the paper's own Monte Carlo error is an assumption (:data:`PAPER_ERROR_ASSUMPTION`), stated in every report.

These categories are the members of :class:`Verdict` (``VERDICTS`` in this order).

Claims (rankings, "A is better than B") get a separate verdict from a paired
comparison on common random numbers.  Each tested part of a claim (one quantity,
one pair of algorithms, a :class:`Part`) gets a *part verdict* :class:`PartVerdict` from :func:`claim_verdict`:

* ``identical (to round-off)`` the difference and its standard error both lie within the round-off floor
  :func:`identity_floor` (c x eps x the reference, c the operations of one run: steps x flops per step by the cost
  model, ``ROUNDOFF_OPS`` when unknown): the two computations are one in exact arithmetic as far as floating point
  can tell, and no z-score is computed on round-off;
* ``holds``                   the difference has the claimed sign, >= 3 standard errors from 0;
* ``contradicted``            the opposite sign, >= 3 standard errors from 0;
* ``no detectable difference`` otherwise;
* ``..., but negligible (< 1 %)`` appended to a detected difference smaller than 1 % of the
  reference mean squared error (paired differences detect effects too small to matter).

A deterministic ratio (a cost from :mod:`mmlib.core.cost`) is a part by :func:`ratio_part`: it holds or is
contradicted beyond the equivalence margin ``COST_MARGIN`` (±10 %), and is no difference within it.

A claim's verdict is a :class:`Judgement`: one term of the *claim vocabulary* :class:`ClaimVerdict`
(``CLAIM_VERDICTS``), the one *decisive* number that produced it, and its parts, combined by :func:`judge`:

* **holds**           every part holds (non-negligibly); decisive: the weakest part;
* **partly**          some parts hold, others do not; decisive: the count and the most adverse part;
* **contradicted**    no part holds and at least one is contradicted (non-negligibly); decisive: the strongest;
* **not supported**   no part holds or is contradicted: differences identical, undetectable or negligible;
  decisive: the part nearest to detection, or the identity;
* **not assessable**  the claim cannot be tested by this replication (decisive: the reason).

The categories are string enums (:class:`enum.StrEnum`): a member equals, hashes, formats, prints and serialises
to JSON as its string (``Verdict.REPRODUCED == "reproduced"``), so verdict texts written with them are plain strings
in the results files.  Writing a results file is :mod:`mmlib.experiment.writing`'s; its contract is
:mod:`mmlib.experiment.results`.
"""
from __future__ import annotations

import enum
import math
import re
from dataclasses import dataclass, field, replace
from typing import Iterable, Mapping, NamedTuple

import numpy as np

from mmlib.core._validate import check_pattern

__all__ = [
    "verdict", "make_row", "Row", "Verdict", "judge", "Judgement", "part", "Part", "claim_verdict", "ClaimVerdict",
    "PartVerdict", "Claims", "CLAIM_KEY", "check_claim_key", "joint_test", "joint_tests", "JointTest", "ratio_part",
    "exact_part", "exact_row",
    "analytic_row", "identity_floor", "standardized_distance", "printed_half_unit", "verdict_category",
    "claim_category", "is_reproduced", "qualified", "rule", "REPRODUCED", "REPRODUCED_EXACT", "ISOLATED", "QUALITATIVE",
    "INCONCLUSIVE", "NOT_REPRODUCED", "NOT_REPRODUCED_EXACT", "NOT_REPLICABLE", "VERDICTS", "HOLDS", "PARTLY",
    "CONTRADICTED", "NOT_SUPPORTED", "NOT_ASSESSABLE", "CLAIM_VERDICTS", "RECONSTRUCTION", "PAPER_ERROR_ASSUMPTION",
    "SIGMA_FACTOR", "RELATIVE_BAND", "NEGLIGIBLE", "ROUNDOFF_OPS", "COST_MARGIN", "JOINT_ALPHA", "format_pm"
]


class _Vocabulary(enum.StrEnum):
    """A verdict category: its string in every respect a caller can see (equality, hash, format, JSON and repr, so
    that a printed dict or tuple of categories reads as the strings it holds)."""

    def __repr__(self) -> str:
        return str.__repr__(self)


class Verdict(_Vocabulary):
    """The categories of the verdict rule (module docstring); a row's verdict text starts with one."""

    REPRODUCED = "reproduced"
    REPRODUCED_EXACT = "reproduced (exact)"
    ISOLATED = "reproduced (isolated)"
    QUALITATIVE = "qualitatively reproduced"
    INCONCLUSIVE = "inconclusive"
    NOT_REPRODUCED = "not reproduced"
    NOT_REPRODUCED_EXACT = "not reproduced (exact)"
    NOT_REPLICABLE = "not replicable"


class PartVerdict(_Vocabulary):
    """The verdict on one tested part of a claim (one quantity, one pair of algorithms): :func:`claim_verdict`."""

    HOLDS = "holds"
    HOLDS_NEGLIGIBLE = "holds, but negligible (< 1 %)"
    CONTRADICTED = "contradicted"
    CONTRADICTED_NEGLIGIBLE = "contradicted, but negligible (< 1 %)"
    NO_DIFFERENCE = "no detectable difference"
    IDENTICAL = "identical (to round-off)"
    NOT_COMPARABLE = "not comparable"


class ClaimVerdict(_Vocabulary):
    """The claim vocabulary (module docstring); a claim's verdict text starts with one."""

    HOLDS = "holds"
    PARTLY = "partly"
    CONTRADICTED = "contradicted"
    NOT_SUPPORTED = "not supported"
    NOT_ASSESSABLE = "not assessable"


REPRODUCED = Verdict.REPRODUCED
REPRODUCED_EXACT = Verdict.REPRODUCED_EXACT
ISOLATED = Verdict.ISOLATED
QUALITATIVE = Verdict.QUALITATIVE
INCONCLUSIVE = Verdict.INCONCLUSIVE
NOT_REPRODUCED = Verdict.NOT_REPRODUCED
NOT_REPRODUCED_EXACT = Verdict.NOT_REPRODUCED_EXACT
NOT_REPLICABLE = Verdict.NOT_REPLICABLE
#: the number vocabulary, in the order of the rule
VERDICTS = tuple(Verdict)

HOLDS = ClaimVerdict.HOLDS
PARTLY = ClaimVerdict.PARTLY
CONTRADICTED = ClaimVerdict.CONTRADICTED
NOT_SUPPORTED = ClaimVerdict.NOT_SUPPORTED
NOT_ASSESSABLE = ClaimVerdict.NOT_ASSESSABLE
#: the claim vocabulary, in the order of the module docstring
CLAIM_VERDICTS = tuple(ClaimVerdict)

#: the qualifier of a verdict on a set-up the paper does not give but we had to reconstruct
#: (:attr:`mmlib.experiment.paper.Paper.qualifier`)
RECONSTRUCTION = "reconstruction"
_QUALIFIED = {HOLDS: "holds in the reconstruction", PARTLY: "partly holds in the reconstruction",
              CONTRADICTED: "contradicted by the reconstruction",
              NOT_SUPPORTED: "not supported by the reconstruction",
              NOT_ASSESSABLE: "not assessable in the reconstruction"}


def qualified(verdict: str, qualifier: str) -> str:
    """The words of a claim verdict (its category, :func:`claim_category`) under ``qualifier``: the verdict itself
    when ``qualifier`` is "", and for :data:`RECONSTRUCTION` the verdict on the reconstruction ("contradicted by
    the reconstruction", "holds in the reconstruction"): a verdict on a set-up the paper does not give is a verdict
    on our reconstruction of it, never on the paper, and is kept out of pooled tallies."""
    cat = claim_category(verdict)
    if qualifier == "":
        return str(cat)
    if qualifier != RECONSTRUCTION:
        raise ValueError(f"qualifier: expected '' or {RECONSTRUCTION!r}, got {qualifier!r}")
    return _QUALIFIED[cat]

#: the assumption every report states about the paper's own Monte Carlo error (the rule's ``s_p``)
PAPER_ERROR_ASSUMPTION = ("The papers print no standard errors. The rule assumes the paper's Monte Carlo error is "
                          "that of the same estimator over the paper's own run count: s_p = s·√(N/N_p) from our "
                          "standard error s over N runs, and adds half a unit of the printed last digit.")
#: the number of combined standard errors within which a value is reproduced, and a claim's difference detected
SIGMA_FACTOR = 3.0
#: the qualitative band: within this fraction of the printed value
RELATIVE_BAND = 0.25
#: a detected claim difference below this fraction of the reference is negligible
NEGLIGIBLE = 0.01
#: the default operation count ``c`` of the round-off floor :func:`identity_floor`, for a comparison whose runs'
#: operations are unknown; a paired comparison of two runs passes their count instead (the larger of the two: flops
#: per step by :mod:`mmlib.core.cost` times the square root of the steps,
#: :func:`mmlib.experiment.evaluation.run_operations`).  2^21 = 2.1e6 covers the papers' own filters (the largest,
#: tseng2011's FUZZY-IMMUKF: 3.05e4 flops per epoch over 1800 epochs, 1.3e6)
ROUNDOFF_OPS = 2 ** 21
#: the equivalence margin of a deterministic ratio (:func:`ratio_part`): within ±10 % is no difference
COST_MARGIN = 0.10
#: the level of the joint test (:func:`joint_test`): the two-sided tail of the 3-sigma rule of one cell, 2 Phi(-3)
JOINT_ALPHA = math.erfc(SIGMA_FACTOR / math.sqrt(2.0))


def _printed(text, name: str) -> str:
    """``text`` is a number as printed ('2.48', '1e-3'), else a ValueError naming ``name``."""
    if not isinstance(text, str):
        raise ValueError(f"{name}: expected a number as printed (a string such as '2.48'), got {text!r}")
    try:
        float(text)
    except ValueError:
        raise ValueError(f"{name}: expected a number as printed (e.g. '2.48'), got {text!r}") from None
    return text


# -- the one ± format of the outputs (below views and evaluation, which both use it) ---------------------------------

def _se_decimals(stderr: float) -> int:
    """The decimals that show ``stderr`` (> 0, finite) to two significant figures, after rounding (0.0995 -> 0.10:
    2 decimals, not 3); negative for s.e. >= 100 (rounded to tens, hundreds, ...)."""
    d = 1 - math.floor(math.log10(stderr))
    rounded = round(stderr, d)
    if rounded > 0 and 1 - math.floor(math.log10(rounded)) != d:      # rounding carried to the next power of ten
        d = 1 - math.floor(math.log10(rounded))
    return d


def format_pm(value: float | None, stderr: float | None, *, signed: bool = False) -> str:
    """``"value ± s.e."`` with the standard error to two significant figures and the value rounded to the same
    decimal: ``format_pm(0.0263, 0.00041) == "0.02630 ± 0.00041"``, ``format_pm(1234.5, 56.0) == "1234 ± 56"``,
    ``format_pm(12345.0, 678.0) == "12340 ± 680"``.  Without a usable standard error (None, not finite or 0: an
    exact value) the value alone to 4 significant digits (a negative one is a ValueError naming ``stderr``); "--"
    when ``value`` is None; "nan"/"inf" as such.  ``signed``: a difference, its sign always shown
    (``format_pm(1.0, 0.0, signed=True) == "+1"``, ``format_pm(0.52, 0.031, signed=True) == "+0.520 ± 0.031"``).
    Values of 1e6 and more (or below 1e-4 with a smaller s.e.) in exponent form with the same rule on the mantissa;
    an s.e. below a millionth of the value (a round-off-sized one) as ``"15.537 ± 1.0e-12"``: the value to 6
    significant digits, not to the s.e.'s 13 decimals.
    The one ± formatting of the reports, the site and the notebooks: ``"0.026 ± 0.000"`` never appears."""
    _real(value, "value")
    _real(stderr, "stderr")
    if not isinstance(signed, (bool, np.bool_)):
        raise ValueError(f"signed: expected True or False, got {signed!r}")
    if stderr is not None and stderr < 0:
        raise ValueError(f"stderr: a standard error is not negative, got {stderr!r}")
    if value is None:
        return "--"
    value = float(value)
    sign = "+" if signed else ""
    if not math.isfinite(value):
        return "nan" if math.isnan(value) else f"{value:{sign}}"
    if stderr is None or not math.isfinite(stderr) or stderr <= 0:
        return f"{value:{sign}.4g}"
    stderr = float(stderr)
    if abs(value) >= 1e6 or (0 < abs(value) < 1e-4 and stderr < 1e-4):
        e = math.floor(math.log10(abs(value)))
        m, s = value / 10 ** e, stderr / 10 ** e
        d = max(0, _se_decimals(s)) if s > 0 else 0
        if d <= 8:
            return f"{m:{sign}.{d}f}e{e:+03d} ± {s:.{d}f}e{e:+03d}"
        return f"{value:{sign}.6g} ± {stderr:.1e}"
    if stderr < 1e-6 * abs(value):
        return f"{value:{sign}.6g} ± {stderr:.1e}"
    d = _se_decimals(stderr)
    if d >= 0:
        return f"{value:{sign}.{d}f} ± {stderr:.{d}f}"
    step = 10 ** (-d)
    return f"{round(value / step) * step:{sign}.0f} ± {round(stderr / step) * step:.0f}"


def _real(x, name: str, *, none: bool = True):
    """``x`` a real number (Python or numpy, or a 0-d array; NaN and infinities allowed), or None if ``none``;
    a string, a bool, an array or another object is a ValueError naming ``name``."""
    if x is None and none:
        return x
    ok = isinstance(x, (int, float, np.integer, np.floating)) or (isinstance(x, np.ndarray) and x.ndim == 0
                                                                   and x.dtype.kind in "iuf")
    if not ok or isinstance(x, (bool, np.bool_)):
        raise ValueError(f"{name}: expected a real number{' or None' if none else ''}, got {x!r}")
    return x


def _check_rule(paper, replicated, stderr, n_runs, n_runs_paper) -> None:
    """The arguments of the verdict rule: ``paper`` a printed text or a number (or None), ``replicated`` and
    ``stderr`` numbers or None, ``n_runs`` None or an integer >= 0 (0: no valid run, e.g. all diverged),
    ``n_runs_paper`` None or an integer >= 1."""
    if isinstance(paper, str):
        _printed(paper, "paper")
    else:
        _real(paper, "paper")
    _real(replicated, "replicated")
    _real(stderr, "stderr")
    for value, arg, low in ((n_runs, "n_runs", 0), (n_runs_paper, "n_runs_paper", 1)):
        if value is not None and (isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer))
                                  or value < low):
            raise ValueError(f"{arg}: expected None or an integer >= {low}, got {value!r}")


def printed_half_unit(printed: str) -> float:
    """Half a unit of the last printed digit of a number given as text ('2.6675' -> 5e-5)."""
    text = _printed(printed, "printed").strip().lower().split("e")[0]
    decimals = len(text.split(".")[1]) if "." in text else 0
    return 0.5 * 10.0 ** (-decimals)


def _difference_and_sigma(paper, replicated, stderr, n_runs, n_runs_paper):
    p = float(paper)
    u = printed_half_unit(paper) if isinstance(paper, str) else 0.0
    s = float(stderr) if stderr is not None and np.isfinite(stderr) else 0.0
    s_p = s * math.sqrt(n_runs / n_runs_paper) if (n_runs and n_runs_paper) else 0.0
    return float(replicated) - p, math.sqrt(s * s + s_p * s_p + u * u)


def standardized_distance(paper: str | float, replicated: float, stderr: float | None, n_runs: int | None = None,
                          n_runs_paper: int | None = None) -> float:
    """``(replicated - paper) / sigma`` with the combined standard error ``sigma`` of the verdict
    rule; +-inf when sigma is 0 and the values differ, 0 when they agree exactly."""
    _check_rule(paper, replicated, stderr, n_runs, n_runs_paper)
    if paper is None or replicated is None:
        raise ValueError(f"{'paper' if paper is None else 'replicated'}: expected a number, got None")
    diff, sigma = _difference_and_sigma(paper, replicated, stderr, n_runs, n_runs_paper)
    if sigma > 0:
        return diff / sigma
    return 0.0 if diff == 0 else math.copysign(math.inf, diff)


def verdict_category(text: str) -> Verdict:
    """The verdict of the number vocabulary ``VERDICTS`` that a verdict text starts with (a :class:`Verdict`,
    equal to its string)."""
    head = str(text).split(":")[0].strip()
    if head not in VERDICTS:
        raise ValueError(f"verdict: {text!r} is not in the vocabulary {VERDICTS}")
    return Verdict(head)


def verdict(paper: str | float | None, replicated: float | None, stderr: float | None, n_runs: int | None = None,
            n_runs_paper: int | None = None, reason: str = "") -> str:
    """Apply the verdict rule of this module's docstring."""
    _check_rule(paper, replicated, stderr, n_runs, n_runs_paper)
    if not isinstance(reason, str):
        raise ValueError(f"reason: expected a string, got {reason!r}")
    if replicated is None or paper is None or (isinstance(replicated, float) and math.isnan(replicated)):
        return f"{NOT_REPLICABLE}: {reason}" if reason else NOT_REPLICABLE
    p = float(paper)
    diff, sigma = _difference_and_sigma(paper, replicated, stderr, n_runs, n_runs_paper)
    diff = abs(diff)
    if diff <= SIGMA_FACTOR * sigma:
        if p != 0.0 and SIGMA_FACTOR * sigma > RELATIVE_BAND * abs(p):
            return f"{INCONCLUSIVE}: ± {SIGMA_FACTOR * sigma:.2g} (3 s.e.) is wider than 25 % of the printed value"
        return REPRODUCED
    if diff <= RELATIVE_BAND * abs(p):
        return QUALITATIVE
    return NOT_REPRODUCED


def identity_floor(reference: float, ops: int = ROUNDOFF_OPS) -> float:
    r"""The round-off floor of a paired difference of two computations of one quantity of size ``reference``:
    :math:`c\,\varepsilon\,|\mathrm{reference}|` with :math:`c` = ``ops`` and :math:`\varepsilon` the float64
    unit round-off 2.2e-16.

    For a run of a filter, :math:`c = f\sqrt K` (:func:`mmlib.experiment.evaluation.run_operations`):
    :math:`f\varepsilon` is the worst-case relative error of one step's :math:`f` operations (Higham 2002,
    *Accuracy and Stability of Numerical Algorithms*, Lemma 3.1, :math:`\gamma_f`), and the steps' errors accumulate
    like a random walk over the :math:`K` steps.  A model, checked rather than proved: every pair of the arena's
    algorithms equal in exact arithmetic lies below it (e.g. IMM5CKF and IMMCKF on zhu2016's linear models, 5e-14
    of the reference against a floor of 3e-11), and differences the models really make lie above it (UKF and EKF on
    tseng2011's pseudoranges, 1e-9 against 2.6e-10; tests/test_verdicts.py).  A genuine difference of 1e-6 of the
    reference is far above it (4.7e-10 of the reference for the default ``ops``)."""
    _real(reference, "reference", none=False)
    if not math.isfinite(reference):
        raise ValueError(f"reference: expected a finite number, got {reference!r}")
    if isinstance(ops, (bool, np.bool_)) or not isinstance(ops, (int, np.integer)) or ops < 1:
        raise ValueError(f"ops: expected a positive integer operation count, got {ops!r}")
    return float(ops) * float(np.finfo(np.float64).eps) * abs(float(reference))


def claim_verdict(difference: float, stderr: float, expected_sign: int, reference: float | None = None,
                  ops: int = ROUNDOFF_OPS) -> PartVerdict:
    """Verdict on a claim "A < B" (``expected_sign=-1``) or "A > B" (``+1``) from a paired
    difference A - B with its standard error (a :class:`PartVerdict`):

    * *identical (to round-off)* when ``|difference|`` and ``stderr`` are both within the round-off floor
      :func:`identity_floor` of ``reference`` (``ops`` its operation count), or both exactly 0: no z-score is
      computed on round-off;
    * *holds* if the difference has the expected sign and is at least 3 standard errors from 0, *contradicted* if
      it has the opposite sign by at least 3 standard errors (either ", but negligible (< 1 %)" when smaller than
      1 % of ``reference``), *no detectable difference* otherwise;
    * *not comparable* when the difference or its standard error is not a finite number (fewer than two runs
      valid in both algorithms: nothing was compared, which must not read as "no difference")."""
    _real(difference, "difference", none=False)
    _real(stderr, "stderr", none=False)
    _real(reference, "reference")
    if isinstance(expected_sign, (bool, np.bool_)) or expected_sign not in (-1, 1):
        raise ValueError(f"expected_sign: expected -1 (claim A < B) or +1 (A > B), got {expected_sign!r}")
    if stderr < 0:
        raise ValueError(f"stderr: expected a standard error >= 0, got {stderr!r}")
    if not (math.isfinite(difference) and math.isfinite(stderr)):
        return PartVerdict.NOT_COMPARABLE
    floor = identity_floor(reference, ops) if reference is not None and math.isfinite(reference) else 0.0
    if abs(difference) <= floor and abs(stderr) <= floor:
        return PartVerdict.IDENTICAL
    z = difference / stderr if stderr > 0 else math.copysign(math.inf, difference)
    small = reference is not None and abs(difference) < NEGLIGIBLE * abs(reference)
    if z * expected_sign >= SIGMA_FACTOR:
        return PartVerdict.HOLDS_NEGLIGIBLE if small else PartVerdict.HOLDS
    if z * expected_sign <= -SIGMA_FACTOR:
        return PartVerdict.CONTRADICTED_NEGLIGIBLE if small else PartVerdict.CONTRADICTED
    return PartVerdict.NO_DIFFERENCE


@dataclass(frozen=True)
class Part:
    """One tested part of a claim: ``comparison`` (e.g. ``"IMM5CKF − IMMCKF"``; for a ratio ``"IMM5CKF/IMMCKF"``)
    on ``quantity`` (e.g. ``"position MSE"``), its :class:`PartVerdict`, the ``difference`` A - B (``kind``
    ``"difference"``, in ``unit``, with its Monte Carlo ``stderr``) or the ratio A/B minus one (``kind``
    ``"ratio"``, deterministic: ``stderr`` None), and the ``reference`` the difference is relative to (B's value;
    None if none)."""

    comparison: str
    quantity: str
    verdict: PartVerdict
    difference: float
    stderr: float | None = None
    reference: float | None = None
    unit: str = ""
    kind: str = "difference"
    margin: float | None = None

    def __post_init__(self):
        for arg in ("comparison", "quantity", "unit"):
            if not isinstance(getattr(self, arg), str):
                raise ValueError(f"{arg}: expected a string, got {getattr(self, arg)!r}")
        if self.verdict not in tuple(PartVerdict):
            raise ValueError(f"verdict: expected a PartVerdict, got {self.verdict!r}")
        object.__setattr__(self, "verdict", PartVerdict(self.verdict))
        if self.kind not in ("difference", "ratio", "exact"):
            raise ValueError(f"kind: expected 'difference', 'ratio' or 'exact', got {self.kind!r}")
        _real(self.difference, "difference", none=False)
        _real(self.stderr, "stderr")
        _real(self.reference, "reference")
        _real(self.margin, "margin")
        if self.stderr is not None and self.stderr < 0:
            raise ValueError(f"stderr: expected a standard error >= 0 or None, got {self.stderr!r}")
        object.__setattr__(self, "difference", float(self.difference))
        for arg in ("stderr", "reference", "margin"):
            if getattr(self, arg) is not None:
                object.__setattr__(self, arg, float(getattr(self, arg)))

    def z(self) -> float:
        """The difference in standard errors (in margins for a ratio); NaN when not comparable or identical."""
        if self.verdict in (PartVerdict.NOT_COMPARABLE, PartVerdict.IDENTICAL):
            return math.nan
        scale = self.margin if self.kind in ("ratio", "exact") else self.stderr
        if not scale:
            return 0.0 if self.difference == 0 else math.copysign(math.inf, self.difference)
        return self.difference / scale

    def number(self) -> str:
        """The part as one number: ``"IMMCDKF-OBS − IMMCDKF: position MSE +2.4e+03 %"``, ``"IMM5CKF − IMMCKF:
        position MSE identical to round-off (|Δ| 3e-13 m²)"``, ``"IMM5CKF/IMMCKF: flops per step 2.31×
        (equivalence ±10 %)"`` or, without a reference, the difference with its standard error."""
        head = f"{self.comparison}: {self.quantity}"
        unit = f" {self.unit}" if self.unit else ""
        if self.verdict == PartVerdict.NOT_COMPARABLE:
            return f"{head} not comparable (too few runs valid in both)"
        if self.verdict == PartVerdict.IDENTICAL and self.kind == "exact":
            return f"{head} equal within the numerical error ({abs(self.difference):.0e} ≤ {self.margin:.1e}{unit})"
        if self.verdict == PartVerdict.IDENTICAL:
            if self.difference == 0.0 and not self.stderr:
                return f"{head} equal (Δ = 0 in every run)"
            return f"{head} identical to round-off (|Δ| {abs(self.difference):.0e}{unit})"
        if self.kind == "ratio":
            return f"{head} {1.0 + self.difference:.3g}× (equivalence ±{100 * (self.margin or 0):.0f} %)"
        if self.kind == "exact":
            size = (f"{100 * self.difference / abs(self.reference):+.2g} %" if self.reference
                    else f"{self.difference:+.3g}{unit}")
            return f"{head} {size} (exact; numerical error ≤ {self.margin:.1e}{unit})"
        note = {PartVerdict.HOLDS_NEGLIGIBLE: ", negligible < 1 %", PartVerdict.CONTRADICTED_NEGLIGIBLE:
                ", negligible < 1 %", PartVerdict.NO_DIFFERENCE: ", not detected"}.get(self.verdict, "")
        if self.reference:
            return f"{head} {100 * self.difference / abs(self.reference):+.2g} % (z = {self.z():+.3g}{note})"
        return f"{head} {format_pm(self.difference, self.stderr, signed=True)}{unit}" + (f" ({note[2:]})" if note
                                                                                           else "")

    def as_json(self) -> dict:
        """The fields as a JSON-able dict (the verdict as its string, non-finite numbers as None)."""
        def fin(x):
            return None if x is None or not math.isfinite(x) else x
        return {"comparison": self.comparison, "quantity": self.quantity, "verdict": str(self.verdict),
                "difference": fin(self.difference), "stderr": fin(self.stderr), "reference": fin(self.reference),
                "unit": self.unit, "kind": self.kind, "margin": self.margin, "number": self.number()}


def part(comparison: str, quantity: str, difference: float, stderr: float, expected_sign: int, *,
         reference: float | None = None, unit: str = "", ops: int = ROUNDOFF_OPS) -> Part:
    """A :class:`Part` from a paired Monte Carlo difference A - B and its standard error, judged by
    :func:`claim_verdict` (``expected_sign`` -1 for the claim "A < B", +1 for "A > B")."""
    v = claim_verdict(difference, stderr, expected_sign, reference, ops)
    return Part(comparison, quantity, v, float(difference), float(stderr), reference, unit)


def ratio_part(comparison: str, quantity: str, ratio: float, expected_sign: int, *,
               margin: float = COST_MARGIN) -> Part:
    """A :class:`Part` from a deterministic ratio A/B (e.g. flops per step from a cost model): for the claim "A >
    B" (``expected_sign`` +1; -1 for "A < B") it *holds* if ``expected_sign (ratio - 1) > margin``, is
    *contradicted* if ``< -margin`` and is *no detectable difference* (equivalent within the margin) otherwise."""
    _real(ratio, "ratio", none=False)
    _real(margin, "margin", none=False)
    if not (math.isfinite(ratio) and ratio > 0):
        raise ValueError(f"ratio: expected a positive finite ratio, got {ratio!r}")
    if not 0 <= margin < 1:
        raise ValueError(f"margin: expected a fraction in [0, 1), got {margin!r}")
    if isinstance(expected_sign, (bool, np.bool_)) or expected_sign not in (-1, 1):
        raise ValueError(f"expected_sign: expected -1 (claim A < B) or +1 (A > B), got {expected_sign!r}")
    d = float(ratio) - 1.0
    v = (PartVerdict.HOLDS if expected_sign * d > margin else
         PartVerdict.CONTRADICTED if expected_sign * d < -margin else PartVerdict.NO_DIFFERENCE)
    return Part(comparison, quantity, v, d, None, None, "", "ratio", float(margin))


def exact_part(comparison: str, quantity: str, difference: float, expected_sign: int, *, tolerance: float,
               reference: float | None = None, unit: str = "") -> Part:
    """A :class:`Part` from a difference computed without Monte Carlo error (an analysis, a quadrature): *identical*
    when ``|difference| <= tolerance`` (its stated numerical error, e.g. a quadrature's error bound), otherwise
    *holds* or *contradicted* by its sign against ``expected_sign`` (", but negligible" below 1 % of ``reference``).
    No z-score: the tolerance is a bound, not a standard error."""
    _real(difference, "difference", none=False)
    _real(tolerance, "tolerance", none=False)
    _real(reference, "reference")
    if not math.isfinite(difference):
        raise ValueError(f"difference: expected a finite number, got {difference!r}")
    if not (math.isfinite(tolerance) and tolerance >= 0):
        raise ValueError(f"tolerance: expected a finite bound >= 0, got {tolerance!r}")
    if isinstance(expected_sign, (bool, np.bool_)) or expected_sign not in (-1, 1):
        raise ValueError(f"expected_sign: expected -1 (claim A < B) or +1 (A > B), got {expected_sign!r}")
    d = float(difference)
    small = reference is not None and abs(d) < NEGLIGIBLE * abs(reference)
    if abs(d) <= tolerance:
        v = PartVerdict.IDENTICAL
    elif expected_sign * d > 0:
        v = PartVerdict.HOLDS_NEGLIGIBLE if small else PartVerdict.HOLDS
    else:
        v = PartVerdict.CONTRADICTED_NEGLIGIBLE if small else PartVerdict.CONTRADICTED
    return Part(comparison, quantity, v, d, None, reference, unit, "exact", float(tolerance))


@dataclass(frozen=True)
class Judgement:
    """A claim's verdict: one term of the claim vocabulary, the ``decisive`` number (or reason) that produced it,
    and the ``parts`` it was combined from (:func:`judge`; empty for a claim judged otherwise,
    :meth:`of`)."""

    verdict: ClaimVerdict
    decisive: str
    parts: tuple = ()

    def __post_init__(self):
        if self.verdict not in CLAIM_VERDICTS:
            raise ValueError(f"verdict: expected a term of the claim vocabulary {CLAIM_VERDICTS}, got "
                             f"{self.verdict!r}")
        object.__setattr__(self, "verdict", ClaimVerdict(self.verdict))
        if not isinstance(self.decisive, str):
            raise ValueError(f"decisive: expected a string, got {self.decisive!r}")
        if isinstance(self.parts, (str, bytes)) or not hasattr(self.parts, "__iter__"):
            raise ValueError(f"parts: expected a sequence of Part, got {self.parts!r}")
        parts = tuple(self.parts)
        for i, p in enumerate(parts):
            if not isinstance(p, Part):
                raise ValueError(f"parts[{i}]: expected a Part, got {p!r}")
        object.__setattr__(self, "parts", parts)

    @classmethod
    def of(cls, verdict: str, decisive: str) -> "Judgement":
        """A claim judged without paired parts (an analysis, a count, or *not assessable* with its reason)."""
        return cls(verdict, decisive)

    def text(self) -> str:
        """``"<verdict> — <decisive>"`` (the verdict alone when nothing is decisive)."""
        return f"{self.verdict} — {self.decisive}" if self.decisive else str(self.verdict)


_HOLD = (PartVerdict.HOLDS,)
_AGAINST = (PartVerdict.CONTRADICTED,)


def judge(parts: Iterable[Part]) -> Judgement:
    """One claim verdict from its parts (module docstring): *not assessable* if a part is not comparable;
    *holds* if every part holds (non-negligibly), decisive the weakest part; *partly* if some hold, decisive the
    count and the most adverse part; *contradicted* if none holds and one is contradicted (non-negligibly),
    decisive the most contradicting; *not supported* otherwise, decisive the part nearest to detection (or the
    identity to round-off)."""
    if isinstance(parts, (str, bytes, Part)) or not hasattr(parts, "__iter__"):
        raise ValueError(f"parts: expected a sequence of Part, got {parts!r}")
    parts = tuple(parts)
    if not parts:
        raise ValueError("parts: a claim needs at least one part")
    for i, p in enumerate(parts):
        if not isinstance(p, Part):
            raise ValueError(f"parts[{i}]: expected a Part, got {p!r}")
    n = len(parts)
    of = "" if n == 1 else f" ({n} parts)"

    def strength(p):          # |z|, NaN last
        z = abs(p.z())
        return -1.0 if math.isnan(z) else z

    bad = [p for p in parts if p.verdict == PartVerdict.NOT_COMPARABLE]
    if bad:
        return Judgement(NOT_ASSESSABLE, bad[0].number() + of, parts)
    holds = [p for p in parts if p.verdict in _HOLD]
    against = [p for p in parts if p.verdict in _AGAINST]
    if len(holds) == n:
        return Judgement(HOLDS, min(holds, key=strength).number() + ("" if n == 1 else f" (weakest of {n})"), parts)
    if holds:
        adverse = max(against, key=strength) if against else max((p for p in parts if p not in holds), key=strength)
        return Judgement(PARTLY, f"{len(holds)} of {n} hold; {adverse.number()}", parts)
    if against:
        return Judgement(CONTRADICTED, max(against, key=strength).number() + of, parts)
    identical = [p for p in parts if p.verdict == PartVerdict.IDENTICAL]
    if len(identical) == n:
        return Judgement(NOT_SUPPORTED, identical[0].number() + of, parts)
    nearest = max((p for p in parts if p.verdict != PartVerdict.IDENTICAL), key=strength)
    return Judgement(NOT_SUPPORTED, nearest.number() + of, parts)


@dataclass
class Row:
    """One paper-versus-replication row of a results file: the printed value ``paper`` (text, None if none),
    our ``replicated`` value with its standard error ``stderr`` (in the quantity's unit), the ``verdict`` of the
    verdict rule, the ids of the ``deviations`` that bear on it and a ``note``."""

    item: str
    algorithm: str
    quantity: str
    paper: str | None
    replicated: float | None
    stderr: float | None
    verdict: str
    deviations: list = field(default_factory=list)
    note: str = ""
    distance: float | None = None


def make_row(item: str, algorithm: str, quantity: str, paper: str | None, replicated: float | None,
             stderr: float | None, *, n_runs: int | None = None, n_runs_paper: int | None = None,
             deviations: Iterable[str] = (),
             reason: str = "", note: str = "") -> Row:
    """A :class:`Row` judged by the verdict rule (:func:`verdict`): ``replicated`` and ``stderr`` as floats (None
    kept: the row is *not replicable*, ``reason`` saying why), ``n_runs`` ours and ``n_runs_paper`` the paper's."""
    _check_row_text(item, algorithm, quantity, note)
    deviations = _deviations(deviations)
    _check_rule(paper, replicated, stderr, n_runs, n_runs_paper)
    rep = None if replicated is None else float(replicated)
    se = None if stderr is None else float(stderr)
    dist = None
    if rep is not None and paper is not None and math.isfinite(rep):
        d = standardized_distance(paper, rep, se, n_runs, n_runs_paper)
        dist = d if math.isfinite(d) else None
    return Row(item, algorithm, quantity, paper, rep, se,
               verdict(paper, rep, se, n_runs, n_runs_paper, reason), deviations, note, dist)


def exact_row(item: str, algorithm: str, quantity: str, paper: str, value: float, *,
              deviations: Iterable[str] = (), note: str = "") -> Row:
    """A row whose value is computed analytically (no Monte Carlo error): *reproduced (exact)* when ``value``
    rounded to the printed number's precision (half a unit of its last digit, :func:`printed_half_unit`) equals
    the printed number, *not reproduced (exact)* otherwise; the standard error is 0 and no z-score is computed."""
    _check_row_text(item, algorithm, quantity, note)
    _printed(paper, "paper")
    _real(value, "value", none=False)
    if not math.isfinite(value):
        raise ValueError(f"value: expected a finite number, got {value!r}")
    same = abs(float(value) - float(paper)) <= printed_half_unit(paper) * (1 + 1e-12)
    return Row(item, algorithm, quantity, paper, float(value), 0.0,
               REPRODUCED_EXACT if same else NOT_REPRODUCED_EXACT, _deviations(deviations), note, None)


def is_reproduced(text: str) -> bool:
    """Whether a row's verdict text counts as reproducing the printed number: *reproduced* or *reproduced
    (exact)*; never *reproduced (isolated)* (a coincidence inside a row or table that fails its joint test)."""
    return verdict_category(text) in (REPRODUCED, REPRODUCED_EXACT)


class JointTest(NamedTuple):
    """The joint test of a group of cells: ``statistic`` the sum of their squared standardized distances,
    ``dof`` the number of cells, ``p_value`` its chi-squared tail and ``passes`` (``p_value >= JOINT_ALPHA``)."""

    statistic: float
    dof: int
    p_value: float
    passes: bool


def joint_test(distances: Iterable[float]) -> JointTest:
    r"""Whether a group of cells is jointly consistent with the printed numbers: under the verdict rule's model
    each standardized distance :math:`z_i` is standard normal, so :math:`\sum_i z_i^2 \sim \chi^2_k` with one
    degree of freedom per cell; the group passes when the tail probability is at least ``JOINT_ALPHA``
    (2 Phi(-3), the level of one cell's 3-sigma rule).  An infinite distance (a value that could not be produced,
    or a printed value met with zero uncertainty by a different number) fails.  ValueError for an empty group
    or a NaN distance."""
    from scipy.stats import chi2

    if isinstance(distances, (str, bytes)) or not hasattr(distances, "__iter__"):
        raise ValueError(f"distances: expected a sequence of standardized distances, got {distances!r}")
    zs = [float(_real(z, "distances", none=False)) for z in distances]
    if not zs:
        raise ValueError("distances: a joint test needs at least one cell")
    if any(math.isnan(z) for z in zs):
        raise ValueError("distances: a NaN distance (no value to compare) cannot enter a joint test")
    stat = math.fsum(z * z for z in zs)
    p = 0.0 if math.isinf(stat) else float(chi2.sf(stat, len(zs)))
    return JointTest(stat, len(zs), p, p >= JOINT_ALPHA)


def rule() -> dict:
    """The rule's stated assumptions and constants, as every results file records them (``rule``)."""
    return {"paper_error_assumption": PAPER_ERROR_ASSUMPTION, "joint_alpha": JOINT_ALPHA,
            "roundoff_ops": ROUNDOFF_OPS, "cost_margin": COST_MARGIN}


def _monte_carlo(row: Row) -> bool:
    """A row judged from a Monte Carlo value: it has a finite distance and a standard error, and is neither exact
    nor not replicable (a deterministic value, such as a cost model's ratio, has no standard error: it is judged
    against the printed precision alone and does not enter a joint test)."""
    cat = verdict_category(row.verdict)
    return (row.distance is not None and row.stderr is not None
            and cat not in (REPRODUCED_EXACT, NOT_REPRODUCED_EXACT, NOT_REPLICABLE))


def joint_tests(rows: Iterable[Row]) -> tuple[list, list]:
    """The joint tests (:func:`joint_test`) of every table (rows of one ``item``) and every row of a table (one
    ``item`` and ``algorithm``) over their Monte Carlo cells, and the rows with each *reproduced* cell inside a
    failing table or row re-judged *reproduced (isolated)*.  Returns ``(rows, tests)``: new :class:`Row` s in the
    same order (the input is not changed) and one dict per group (``item``, ``algorithm`` (None for a whole
    table), ``statistic``, ``dof``, ``p_value``, ``passes``, ``n_isolated``).  Idempotent: an isolated cell keeps
    its distance, so a second pass finds the same tests."""
    if isinstance(rows, (str, bytes)) or not hasattr(rows, "__iter__"):
        raise ValueError(f"rows: expected a sequence of Row, got {rows!r}")
    rows = list(rows)
    for i, r in enumerate(rows):
        if not isinstance(r, Row):
            raise ValueError(f"rows[{i}]: expected a Row (make_row), got {r!r}")
    groups: dict = {}
    for i, r in enumerate(rows):
        if _monte_carlo(r):
            groups.setdefault((r.item, None), []).append(i)
            groups.setdefault((r.item, r.algorithm), []).append(i)
    failing, tests = set(), []
    for (item, alg), idx in groups.items():
        t = joint_test(rows[i].distance for i in idx)
        if not t.passes:
            failing.update(idx)
        tests.append({"item": item, "algorithm": alg, "statistic": t.statistic, "dof": t.dof,
                      "p_value": t.p_value, "passes": t.passes,
                      "n_isolated": 0 if t.passes else sum(verdict_category(rows[i].verdict) in (REPRODUCED, ISOLATED)
                                                           for i in idx)})
    out = []
    for i, r in enumerate(rows):
        cat = verdict_category(r.verdict) if r.verdict else None
        if cat in (REPRODUCED, ISOLATED):
            r = replace(r, verdict=ISOLATED if i in failing else REPRODUCED)
        out.append(r)
    return out, tests


def _check_row_text(item, algorithm, quantity, last, last_name: str = "note") -> None:
    for value, arg in ((item, "item"), (algorithm, "algorithm"), (quantity, "quantity"), (last, last_name)):
        if not isinstance(value, str):
            raise ValueError(f"{arg}: expected a string, got {value!r}")


def _deviations(deviations) -> list:
    """Deviation ids as a list of strings: a bare string is one id, never split into its characters -- it is
    refused (``deviations=["Z-1"]``)."""
    if isinstance(deviations, (str, bytes)) or isinstance(deviations, Mapping) or not hasattr(deviations, "__iter__"):
        raise ValueError(f"deviations: expected a sequence of deviation ids (e.g. ['Z-1']), got {deviations!r}")
    out = list(deviations)
    for d in out:
        if not isinstance(d, str):
            raise ValueError(f"deviations: expected deviation ids as strings, got {d!r}")
    return out


def analytic_row(item: str, algorithm: str, quantity: str, paper: str | None, finding: str, holds: bool, *,
                 deviations: Iterable[str] = ()) -> Row:
    """A row judged by analysis rather than by Monte Carlo (e.g. a complexity class): no number, verdict
    *reproduced (exact)* or *not reproduced (exact)* (no Monte Carlo error), with the finding as the note."""
    _check_row_text(item, algorithm, quantity, finding, "finding")
    if paper is not None and not isinstance(paper, str):
        raise ValueError(f"paper: expected the printed text or None, got {paper!r}")
    if not isinstance(holds, (bool, np.bool_)):
        raise ValueError(f"holds: expected True or False, got {holds!r}")
    return Row(item, algorithm, quantity, paper, None, None,
               REPRODUCED_EXACT if holds else f"{NOT_REPRODUCED_EXACT}: {finding}", _deviations(deviations), finding)


def claim_category(text: str) -> ClaimVerdict:
    """The claim verdict of ``CLAIM_VERDICTS`` that a claim's verdict text states (the part before
    ``": "``; a :class:`ClaimVerdict`, equal to its string); ValueError for any text outside the vocabulary, such
    as a bare part verdict."""
    head = str(text).split(":")[0].strip()
    if head not in CLAIM_VERDICTS:
        raise ValueError(f"verdict: {text!r} is not in the claim vocabulary {CLAIM_VERDICTS} "
                         f"(combine part verdicts with judge)")
    return ClaimVerdict(head)


def _judgement(verdict) -> Judgement:
    """A :class:`Judgement`, or a verdict text ``"<claim verdict>[: <decisive>]"`` read as one."""
    if isinstance(verdict, Judgement):
        return verdict
    if not isinstance(verdict, str):
        raise ValueError(f"verdict: expected a Judgement (verdicts.judge) or a claim verdict text, got {verdict!r}")
    cat = claim_category(verdict)
    rest = str(verdict).split(":", 1)[1].strip() if ":" in str(verdict) else ""
    return Judgement(cat, rest)


#: the form of a claim's stable name (:meth:`Claims.add`): a lower-case letter, then lower-case letters, digits, ``_``
CLAIM_KEY = re.compile(r"[a-z][a-z0-9_]*")


def check_claim_key(key: object, name: str = "key") -> str:
    """``key`` if it is a claim's stable name of the form :data:`CLAIM_KEY`; ValueError naming ``name`` otherwise."""
    return check_pattern(key, name, CLAIM_KEY, "a claim key (a lower-case letter, then lower-case letters, digits "
                         "or '_', e.g. 'cpimm_vs_imm')")


class Claims:
    """The claims of a paper with their verdicts and evidence, in the order they are judged.

    ``add`` checks the verdict against the claim vocabulary, so no verdict outside it can be
    recorded."""

    def __init__(self):
        self.items: list = []

    def add(self, claim: str, verdict: Judgement | str, evidence: str = "", *, key: str) -> Judgement:
        """Record ``claim`` with its ``verdict`` (a :class:`Judgement`, or a text ``"<claim verdict>[:
        <decisive>]"``), ``evidence`` and ``key``, the claim's stable name (:data:`CLAIM_KEY`: lower-case letters,
        digits and ``_``, e.g. ``"cpimm_vs_imm"``) by which summaries and findings address it whatever its position
        or wording (:func:`mmlib.papers.summary_values`); returns the judgement.  ValueError for an empty claim, a
        verdict outside the vocabulary, a malformed key, or a claim or key already judged."""
        if not isinstance(claim, str) or not claim.strip():
            raise ValueError(f"claim: expected a non-empty string, got {claim!r}")
        check_claim_key(key, "key")
        j = _judgement(verdict)
        if not isinstance(evidence, str):
            raise ValueError(f"evidence: expected a string, got {evidence!r}")
        if any(c["claim"] == claim for c in self.items):
            raise ValueError(f"claim: {claim!r} is already judged")
        if any(c["key"] == key for c in self.items):
            raise ValueError(f"key: {key!r} already names the claim "
                             f"{next(c['claim'] for c in self.items if c['key'] == key)!r}")
        self.items.append({"key": key, "claim": claim, "verdict": j.verdict, "decisive": j.decisive,
                           "parts": [p.as_json() for p in j.parts], "evidence": evidence})
        return j

    def extend(self, other: "Claims") -> None:
        """Record every claim of ``other`` (another :class:`Claims`) after these, with its decisive number and
        parts; ValueError if one is already judged here."""
        if not isinstance(other, Claims):
            raise ValueError(f"other: expected a Claims, got {type(other).__name__}")
        for c in other.items:
            if any(mine["claim"] == c["claim"] for mine in self.items):
                raise ValueError(f"other: claim {c['claim']!r} is already judged")
            if any(mine["key"] == c["key"] for mine in self.items):
                raise ValueError(f"other: key {c['key']!r} already names a claim here")
        self.items.extend({**c, "parts": [dict(p) for p in c["parts"]]} for c in other.items)

    def __iter__(self):
        return iter(self.items)

    def __len__(self):
        return len(self.items)

    def as_list(self) -> list:
        """Copies of the recorded claims, in order: ``{"key"`` (its stable name), ``"claim", "verdict"`` (one term of
        the claim vocabulary), ``"decisive"`` (the number or reason that produced it), ``"parts"``
        (:meth:`Part.as_json` of each) and ``"evidence"}``."""
        return [{**c, "parts": [dict(p) for p in c["parts"]]} for c in self.items]
