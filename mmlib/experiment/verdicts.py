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

These five categories are the members of :class:`Verdict` (``VERDICTS`` in this order).

Claims (rankings, "A is better than B") get a separate verdict from a paired
comparison on common random numbers.  Each tested part of a claim (one quantity,
one pair of algorithms) gets a *part verdict* from :func:`claim_verdict`:

* ``holds``                   the difference has the claimed sign, >= 3 standard errors from 0;
* ``contradicted``            the opposite sign, >= 3 standard errors from 0;
* ``no detectable difference`` otherwise;
* ``..., but negligible (< 1 %)`` appended to a detected difference smaller than 1 % of the
  reference mean squared error (paired differences detect effects too small to matter).

A claim's verdict is one of the *claim vocabulary* :class:`ClaimVerdict` (``CLAIM_VERDICTS``), optionally
followed by ``": "`` and detail, combined from its parts by :func:`combine_claim_verdicts`:

* **holds**           every part holds (non-negligibly);
* **partly**          some parts hold, others do not;
* **contradicted**    no part holds and at least one is contradicted (non-negligibly);
* **not supported**   no part holds or is contradicted: differences undetectable or negligible;
* **not assessable**  the claim cannot be tested by this replication (the reason follows).

Run times are judged by the same rules: a timing row's standard error comes from
repeated timings, and a timing claim is a part verdict on a ratio minus one.

The categories are string enums (:class:`enum.StrEnum`): a member equals, hashes, formats, prints and serialises
to JSON as its string (``Verdict.REPRODUCED == "reproduced"``), so verdict texts written with them are plain strings
in the results files.  Writing a results file is :mod:`mmlib.experiment.writing`'s; its contract is
:mod:`mmlib.experiment.results`.
"""
from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from typing import Iterable, Mapping

import numpy as np


class _Vocabulary(enum.StrEnum):
    """A verdict category: its string in every respect a caller can see (equality, hash, format, JSON and repr, so
    that a printed dict or tuple of categories reads as the strings it holds)."""

    def __repr__(self) -> str:
        return str.__repr__(self)


class Verdict(_Vocabulary):
    """The categories of the verdict rule (module docstring); a row's verdict text starts with one."""

    REPRODUCED = "reproduced"
    QUALITATIVE = "qualitatively reproduced"
    INCONCLUSIVE = "inconclusive"
    NOT_REPRODUCED = "not reproduced"
    NOT_REPLICABLE = "not replicable"


class ClaimVerdict(_Vocabulary):
    """The claim vocabulary (module docstring); a claim's verdict text starts with one."""

    HOLDS = "holds"
    PARTLY = "partly"
    CONTRADICTED = "contradicted"
    NOT_SUPPORTED = "not supported"
    NOT_ASSESSABLE = "not assessable"


REPRODUCED = Verdict.REPRODUCED
QUALITATIVE = Verdict.QUALITATIVE
INCONCLUSIVE = Verdict.INCONCLUSIVE
NOT_REPRODUCED = Verdict.NOT_REPRODUCED
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

#: the number of combined standard errors within which a value is reproduced, and a claim's difference detected
SIGMA_FACTOR = 3.0
#: the qualitative band: within this fraction of the printed value
RELATIVE_BAND = 0.25
#: a detected claim difference below this fraction of the reference is negligible
NEGLIGIBLE = 0.01


def _printed(text, name: str) -> str:
    """``text`` is a number as printed ('2.48', '1e-3'), else a ValueError naming ``name``."""
    if not isinstance(text, str):
        raise ValueError(f"{name}: expected a number as printed (a string such as '2.48'), got {text!r}")
    try:
        float(text)
    except ValueError:
        raise ValueError(f"{name}: expected a number as printed (e.g. '2.48'), got {text!r}") from None
    return text


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
            return f"{INCONCLUSIVE}: ± {SIGMA_FACTOR * sigma:.3g} (3 s.e.) is wider than 25 % of the printed value"
        return REPRODUCED
    if diff <= RELATIVE_BAND * abs(p):
        return QUALITATIVE
    return NOT_REPRODUCED


def claim_verdict(difference: float, stderr: float, expected_sign: int, reference: float | None = None) -> str:
    """Verdict on a claim "A < B" (``expected_sign=-1``) or "A > B" (``+1``) from a paired
    difference A - B with its standard error: 'holds' if the difference has the expected sign
    and is at least 3 standard errors from 0, 'contradicted' if it has the opposite sign
    by at least 3 standard errors, 'no detectable difference' otherwise; 'not comparable' when the
    difference or its standard error is not a finite number (fewer than two runs valid in both
    algorithms: nothing was compared, which must not read as "no difference")."""
    _real(difference, "difference", none=False)
    _real(stderr, "stderr", none=False)
    _real(reference, "reference")
    if isinstance(expected_sign, (bool, np.bool_)) or expected_sign not in (-1, 1):
        raise ValueError(f"expected_sign: expected -1 (claim A < B) or +1 (A > B), got {expected_sign!r}")
    if not (math.isfinite(difference) and math.isfinite(stderr)):
        return "not comparable"
    if stderr == 0.0 and difference == 0.0:
        return "no detectable difference (identical)"
    z = difference / stderr if stderr > 0 else math.copysign(math.inf, difference)
    small = reference is not None and abs(difference) < NEGLIGIBLE * abs(reference)
    if z * expected_sign >= SIGMA_FACTOR:
        return "holds, but negligible (< 1 %)" if small else "holds"
    if z * expected_sign <= -SIGMA_FACTOR:
        return "contradicted, but negligible (< 1 %)" if small else "contradicted"
    return "no detectable difference"


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
    return Row(item, algorithm, quantity, paper, rep, se,
               verdict(paper, rep, se, n_runs, n_runs_paper, reason), deviations, note)


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
    """A row judged by analysis rather than by Monte Carlo (e.g. a complexity class): no number,
    verdict 'reproduced' or 'not reproduced', with the finding as the note."""
    _check_row_text(item, algorithm, quantity, finding, "finding")
    if paper is not None and not isinstance(paper, str):
        raise ValueError(f"paper: expected the printed text or None, got {paper!r}")
    if not isinstance(holds, (bool, np.bool_)):
        raise ValueError(f"holds: expected True or False, got {holds!r}")
    return Row(item, algorithm, quantity, paper, None, None,
               REPRODUCED if holds else f"{NOT_REPRODUCED}: {finding}", _deviations(deviations), finding)


def claim_category(text: str) -> ClaimVerdict:
    """The claim verdict of ``CLAIM_VERDICTS`` that a claim's verdict text states (the part before
    ``": "``; a :class:`ClaimVerdict`, equal to its string); ValueError for any text outside the vocabulary, such
    as a bare part verdict."""
    head = str(text).split(":")[0].strip()
    if head not in CLAIM_VERDICTS:
        raise ValueError(f"verdict: {text!r} is not in the claim vocabulary {CLAIM_VERDICTS} "
                         f"(combine part verdicts with combine_claim_verdicts)")
    return ClaimVerdict(head)


def combine_claim_verdicts(verdicts: Iterable[str]) -> str:
    """One claim verdict (module docstring) from the part verdicts of :func:`claim_verdict`, each
    optionally labelled as ``"<part verdict> (<quantity>)"``."""
    if isinstance(verdicts, (str, bytes)) or not hasattr(verdicts, "__iter__"):
        raise ValueError(f"verdicts: expected a sequence of part verdicts (a list of strings), got {verdicts!r}")
    verdicts = list(verdicts)
    if not verdicts:
        raise ValueError("verdicts: a claim needs at least one part verdict")
    for v in verdicts:
        if not isinstance(v, str):
            raise ValueError(f"verdicts: expected part verdicts as strings, got {v!r}")
    kinds = [v.split(" (")[0] for v in verdicts]
    for v, k in zip(verdicts, kinds):
        if k not in ("holds", "contradicted", "no detectable difference", "holds, but negligible",
                     "contradicted, but negligible", "not comparable"):
            raise ValueError(f"verdicts: {v!r} is not a part verdict of claim_verdict")
    detail = "; ".join(verdicts)
    if any(k == "not comparable" for k in kinds):
        return f"{NOT_ASSESSABLE}: too few runs valid in both algorithms; {detail}"
    if all(k == "holds" for k in kinds):
        return HOLDS
    if any(k == "holds" for k in kinds):
        return f"{PARTLY}: {detail}"
    if any(k == "contradicted" for k in kinds):
        return CONTRADICTED if all(k == "contradicted" for k in kinds) else f"{CONTRADICTED}: {detail}"
    if all(k == "no detectable difference" for k in kinds) and len(kinds) == 1:
        return f"{NOT_SUPPORTED}: no detectable difference" + (" (identical)" if "identical" in detail else "")
    return f"{NOT_SUPPORTED}: differences negligible or undetectable; {detail}"


def paired_claim(difference: float, stderr: float, expected_sign: int, reference: float | None = None) -> str:
    """A one-part claim's verdict (claim vocabulary) from a paired difference and its standard error."""
    return combine_claim_verdicts([claim_verdict(difference, stderr, expected_sign, reference)])


class Claims:
    """The claims of a paper with their verdicts and evidence, in the order they are judged.

    ``add`` checks the verdict against the claim vocabulary, so no verdict outside it can be
    recorded."""

    def __init__(self):
        self.items: list = []

    def add(self, claim: str, verdict: str, evidence: str = "") -> str:
        """Record ``claim`` with its ``verdict`` (claim vocabulary, :func:`claim_category`) and ``evidence``;
        returns the verdict.  ValueError for an empty claim, a verdict outside the vocabulary or a claim already
        judged."""
        if not isinstance(claim, str) or not claim.strip():
            raise ValueError(f"claim: expected a non-empty string, got {claim!r}")
        if not isinstance(verdict, str):
            raise ValueError(f"verdict: expected a claim verdict (a string), got {verdict!r}")
        if not isinstance(evidence, str):
            raise ValueError(f"evidence: expected a string, got {evidence!r}")
        claim_category(verdict)
        if any(c["claim"] == claim for c in self.items):
            raise ValueError(f"claim: {claim!r} is already judged")
        self.items.append({"claim": claim, "verdict": verdict, "evidence": evidence})
        return verdict

    def __iter__(self):
        return iter(self.items)

    def __len__(self):
        return len(self.items)

    def as_list(self) -> list:
        """Copies of the recorded claims, ``{"claim", "verdict", "evidence"}`` each, in order."""
        return [dict(c) for c in self.items]
