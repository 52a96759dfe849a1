"""Table 2 of Liu & Wu 2017: computational complexity and time per run.

The complexity column is judged from the operations per step counted in the code (:data:`text.TABLE2_COUNTS`,
n = 6, m = 2): a printed complexity is reproduced when its order in the number of points and in n equal those of
the counts (:func:`complexity_rows`).  The times are judged on a deterministic measure, the
floating-point operations per step of each filter as it runs (:func:`mmlib.core.cost.step_flops`), against the
printed time ratio to SSRCKF; measured CPU times (repeats with every filter interleaved) are context (:func:`table2`).
"""
from __future__ import annotations

import re
from typing import Mapping, Sequence

import numpy as np

from mmlib.core.cost import step_flops
from mmlib.experiment import report
from mmlib.experiment.metrics import ratio_spread_text as _spread
from mmlib.papers.liu2017.text import FILTERS, TABLE2_COMPLEXITY, TABLE2_COUNTS, TABLE2_N, TABLE2_TIME

__all__ = [
    "printed_complexity_orders", "counted_complexity_orders", "complexity_rows", "table2", "TIME_CLAIM_KEY"
]


def printed_complexity_orders(text: str) -> tuple:
    """``(order in the number of points, order in n)`` of a complexity printed as ``O(n^k)``,
    ``O((a n + b)^k)`` or ``O((a n + b) n^k)``, where ``a n + b`` is the filter's number of points
    (``O(n^2)`` has no points: order 0 in them).  ValueError for any other form."""
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


#: the stable key of the timing claim :func:`table2` judges (:meth:`mmlib.experiment.verdicts.Claims.add`)
TIME_CLAIM_KEY = "more_time"


def table2(estimators: Mapping, per_run: Mapping[str, np.ndarray], batched: Mapping[str, np.ndarray]) -> tuple:
    """Rows, the timing claim and a display table for Table 2.

    The time rows compare the printed time ratio to SSRCKF with the cost model's flop ratio
    (:func:`mmlib.core.cost.step_flops` of ``estimators[name]``, the filters timed; deterministic, judged by the
    verdict rule with the printed precision only); the claim "STSSRCKF needs more computational time than SSRCKF" is a
    ratio part on the flops with the equivalence margin :data:`mmlib.experiment.verdicts.COST_MARGIN` (holds beyond
    +10 %).  ``per_run`` and ``batched`` (name -> seconds per run, one value per repeat, every filter interleaved
    within each repeat) are context: the median ratio with its range over the repeats, in the notes, the evidence and
    the display table.  Returns ``(rows, (claim, judgement, evidence), display)``; the claim's key is
    :data:`TIME_CLAIM_KEY`."""
    ref = float(TABLE2_TIME["SSRCKF"])
    flops = {alg: step_flops(estimators[alg])["total"] for alg in FILTERS}
    repeats = len(per_run["SSRCKF"])
    rows, display = [], []
    counted = counted_complexity_orders()
    complexity = {r.algorithm: r for r in complexity_rows()}
    for alg in FILTERS:
        pts, chol, nf, nh, nnn = TABLE2_COUNTS[alg]
        ratio_paper = float(TABLE2_TIME[alg]) / ref
        model = flops[alg] / flops["SSRCKF"]
        c_pts, c_n, _ = counted[alg]
        actual = f"O(n^{c_n})" if not pts else ("O(points · n² + n³)" if c_pts == 1 else f"O(points^{c_pts} + n^{c_n})")
        display.append([alg, TABLE2_COMPLEXITY[alg], pts, chol, nf, nh, nnn, actual, TABLE2_TIME[alg],
                        f"{ratio_paper:.2f}", f"{model:.2f} ({flops[alg]} flops)",
                        _spread(per_run, alg, "SSRCKF"), _spread(batched, alg, "SSRCKF")])
        rows.append(complexity[alg])
        if alg != "SSRCKF":
            note = (f"cost model {flops[alg]} / {flops['SSRCKF']} flops per step; measured CPU ratio "
                    f"{_spread(per_run, alg, 'SSRCKF')} one run at a time, "
                    f"{_spread(batched, alg, 'SSRCKF')} batched (median [range] over {repeats} repeated "
                    f"timings); {TABLE2_TIME[alg]} s in MATLAB")
            rows.append(report.exact_row("Table 2", alg, "time ratio to SSRCKF (model flops per step)",
                                         f"{ratio_paper:.3f}", model, deviations=[], note=note))
    paper_st = float(TABLE2_TIME["STSSRCKF"]) / ref
    j = report.judge([report.ratio_part("STSSRCKF/SSRCKF", "model flops per step",
                                        flops["STSSRCKF"] / flops["SSRCKF"], +1)])
    claim = ("STSSRCKF needs more computational time than SSRCKF (Table 2: 0.15 s vs 0.07 s per run)",
             report.Judgement(j.verdict, f"{j.decisive}; paper {paper_st:.2f}×", j.parts),
             f"cost model (mmlib.core.cost): {flops['STSSRCKF']} vs {flops['SSRCKF']} flops per step, the second "
             f"measurement prediction counted in every step (its upper bound); measured CPU time ratio, context only: "
             f"{_spread(per_run, 'STSSRCKF', 'SSRCKF')} one run at a time, "
             f"{_spread(batched, 'STSSRCKF', 'SSRCKF')} batched (median [range] over {repeats} repeated "
             f"timings); 'acceptable' is a judgement, not tested")
    return rows, claim, display
