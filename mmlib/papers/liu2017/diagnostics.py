"""What only Liu & Wu 2017's notebook shows: why the third-degree rules cannot differ materially at these ranges
(:func:`nonlinearity_index`, :func:`near_equality`), and the multiverse's findings as prose computed from the data
(:func:`findings`).
"""
from __future__ import annotations

from collections import Counter

import numpy as np

from mmlib.core.estimation import run as run_filter
from mmlib.experiment import evaluation, metrics, report
from mmlib.experiment.montecarlo import MonteCarlo
from mmlib.experiment.multiverse import Multiverse
from mmlib.experiment.views import value_pm
from mmlib.papers.liu2017.setup import Setup, make_batch_fn
from mmlib.papers.liu2017.study import ReadingResults
from mmlib.papers.liu2017.text import CASES, KEY_EFFECT, POSITION, QUANTITIES

__all__ = [
    "nonlinearity_index", "consistency", "near_equality", "findings"
]


def nonlinearity_index(setup: Setup, mc: MonteCarlo, n_runs: int = 50) -> np.ndarray:
    """Median over runs of sigma_pos / range of STSSRCKF's estimate at every step, shape (K,) (the size of the
    neglected terms: third-degree rules differ by ~(sigma/r)^2, the EKF by ~sigma/r)."""
    make_batch, est, _ = make_batch_fn(setup, mc, names=("STSSRCKF",))
    _, z, init = make_batch(range(min(mc.n_runs, n_runs)))
    tr = run_filter(est["STSSRCKF"], init["STSSRCKF"], z)
    sd_pos = np.sqrt(tr.cov[..., 0, 0] + tr.cov[..., 3, 3])
    rng = np.hypot(tr.mean[..., 0], tr.mean[..., 3])
    return np.median(sd_pos / rng, axis=0)


def consistency(results: ReadingResults) -> list:
    """The ``consistency`` section of the results file: per case of :data:`~mmlib.papers.liu2017.text.CASES` (the
    entry's ``case``) and per filter run there, its ANEES (6 degrees of freedom: the state [x, vx, ax, y, vy, ay])
    and ANIS (2: range and bearing) over the runs that did not diverge, each with its standard error and 95 %
    chi-square band (:func:`mmlib.experiment.evaluation.consistency_entries`).  ``results`` must come from
    ``evaluate_reading(..., consistency=True)`` (ValueError naming the filter otherwise).  A strong-tracking filter's
    NEES is that of its faded covariance (Eqs. 20-36), the covariance it reports."""
    return [e for case in CASES for e in evaluation.consistency_entries(results.runs[case], 6, case=case)]


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
            vals = [mv.value(u, p.key).replicated for p in st]
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
    out = []
    pos = [p for p in mv.published if p.table == "Table 1" and p.quantity == QUANTITIES[0][0]]
    head = mv.headline
    st_head = [mv.value(head, p.key) for p in pos if p.algorithm != "SSRCKF"]
    lo, hi = min(v.replicated for v in st_head), max(v.replicated for v in st_head)
    printed_st = [float(p.printed) for p in pos if p.algorithm != "SSRCKF"]
    full_pos = [i for i, u in enumerate(mv.universes)
                if all(mv.number_verdict(p, u) == report.REPRODUCED for p in pos)]
    text = (f"**Table 1, position column.** Under the headline reading the four strong-tracking filters reach a "
            f"position ARMSE of {_span([lo, hi])} m (s.e. at most {max(v.stderr for v in st_head):.2g} m), against the "
            f"printed {_span(printed_st)} m: not reproduced. ")
    if full_pos:
        descr = []
        for i in full_pos:
            vals = ", ".join(f"{p.algorithm} {value_pm(v.replicated, v.stderr, 1)}"
                             for p in pos for v in [mv.value(mv.universes[i], p.key)])
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
            judged = len(mv.universes) - t["n_excluded_inconclusive"]
            forensic = (f"the forensic best match (smallest Σz² among the {judged} "
                        f"universes with no inconclusive cell) is *{t['best_describe']}*, Σz² {_g(t['best_sum'])} "
                        f"against the headline's {_g(t['headline_sum'])}, reproducing {t['best_n_reproduced']} cells")
        parts.append(f"{t['table']} ({t['n_cells']} cells): {most}; {forensic}")
    whole = [t["table"] for t in tm if t["most_n_reproduced"] == t["n_cells"]]
    out.append("**Whole tables.** " + "; ".join(parts) + ". "
               + (f"Some reading reproduces the whole of {', '.join(whole)}." if whole else
                  "No declared reading reproduces a whole table."))
    key = [mv.effect(u, KEY_EFFECT) for u in mv.universes]
    pub = key[0].published
    is_neg = [e.value is not None and e.value + report.SIGMA_FACTOR * e.stderr < 0 for e in key]
    neg = sum(is_neg)
    neg_by = {o: (sum(n for n, r in zip(is_neg, mv.readings) if r["L-2"] == o),
                  sum(1 for r in mv.readings if r["L-2"] == o)) for o in mv.space.factor("L-2").names}
    out.append(f"**Key effect** ({KEY_EFFECT}; the paper's counterpart 119.3² − 152.1² = {pub:.0f} m²): headline "
               f"{value_pm(key[0].value, key[0].stderr, 0)} m²; across the universes from "
               f"{min(e.value for e in key):.4g} to {max(e.value for e in key):.4g} m², negative by more than "
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
