"""Table 1's run-time column of Zhu, Wang & Yuan 2016 (deviation Z-15), judged on the cost model.

The paper prints MATLAB seconds without saying whether per run or in total; absolute times across languages and
machines are not comparable, ratios are.  A measured time ratio moves with machine load and interpreter overhead, so
it is no verdict: each algorithm's cost per step is the floating-point operations of the filter it runs
(:func:`mmlib.core.cost.step_flops`, deterministic), the rows compare the printed time ratio to IMMCKF with the
model's flop ratio (no standard error), and the claim is a ratio part with the equivalence margin
:data:`mmlib.experiment.verdicts.COST_MARGIN`.  The notebook's measured CPU times
(:func:`mmlib.experiment.evaluation.time_algorithms`, one run at a time and batched) stay as context: the median
ratio with its range over the repeats, each a separate timing of all algorithms.
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from mmlib.core.cost import step_flops
from mmlib.experiment import report
from mmlib.experiment.metrics import ratio_spread_text as _spread
from mmlib.papers.zhu2016.text import ALGORITHMS, TABLE1

__all__ = [
    "judge_timing", "TIMING_PER_REPEAT", "TIMING_CLAIM", "QUANTITY"
]

#: runs timed one at a time per repeat (the fastest of them is the repeat's value)
TIMING_PER_REPEAT = 3
#: the paper's claim on run time (Section 4, Table 1's time column)
TIMING_CLAIM = "IMM5CKF costs more computation than IMMCKF"
#: what the rows and the claim compare
QUANTITY = "model flops per step"


def judge_timing(estimators: Mapping, per_run: Mapping[str, np.ndarray], batched: Mapping[str, np.ndarray],
                 claims: report.Claims) -> tuple:
    """Table 1's time column as ratios to IMMCKF (Z-15): rows with the printed time ratio against the cost model's
    flop ratio (``estimators``: name -> the estimator timed, for :func:`mmlib.core.cost.step_flops`; deterministic,
    an exact row, equal or not to the printed precision), and the timing claim, added to ``claims``, as a
    ratio part on IMM5CKF/IMMCKF flops (holds beyond +10 %).  ``per_run`` and ``batched`` (algorithm -> seconds
    per run in each repeat) are context: notes, evidence and the display table.  Returns (rows, table rows for
    display)."""
    flops = {alg: step_flops(estimators[alg])["total"] for alg in per_run}
    repeats = len(per_run["IMMCKF"])
    ref_paper = float(TABLE1["IMMCKF"][4])
    rows, table = [], []
    for alg in ALGORITHMS:
        paper_ratio = float(TABLE1[alg][4]) / ref_paper
        if alg == "IMMCKF":   # the reference of the ratios: its absolute MATLAB time cannot be compared
            rows.append(report.make_row("Table 1", alg, "Time (s)", TABLE1[alg][4], None, None,
                                        reason="absolute MATLAB time; IMMCKF is the reference of the ratios (Z-15)",
                                        deviations=["Z-15"],
                                        note=f"{flops[alg]} model flops per step; {1e3 * np.median(per_run[alg]):.1f}"
                                             " ms (CPU) per run here"))
            table.append([alg, TABLE1[alg][4], "1 (reference)", f"1 ({flops[alg]} flops)", "1 (reference)",
                          f"{1e3 * np.median(per_run[alg]):.2f}", f"{1e3 * np.median(batched[alg]):.3f}",
                          "1 (reference)"])
            continue
        if alg == "OMTM-IMM":
            rows.append(report.make_row("Table 1", alg, f"Time ratio to IMMCKF ({QUANTITY})", f"{paper_ratio:.3f}",
                                        None, None, reason="method not specified (Z-14)", deviations=["Z-14", "Z-15"]))
            continue
        model = flops[alg] / flops["IMMCKF"]
        rows.append(report.exact_row("Table 1", alg, f"Time ratio to IMMCKF ({QUANTITY})", f"{paper_ratio:.3f}",
                                     model, deviations=["Z-15"],
                                    note=f"cost model {flops[alg]} / {flops['IMMCKF']} flops per step; measured CPU "
                                         f"ratio {_spread(per_run, alg, 'IMMCKF')} one run at a time, "
                                         f"{_spread(batched, alg, 'IMMCKF')} batched (median [range] over "
                                         f"{repeats} repeated timings); {TABLE1[alg][4]} s in MATLAB"))
        table.append([alg, TABLE1[alg][4], f"{paper_ratio:.2f}", f"{model:.2f}", _spread(per_run, alg, "IMMCKF"),
                      f"{1e3 * np.median(per_run[alg]):.2f}", f"{1e3 * np.median(batched[alg]):.3f}",
                      _spread(batched, alg, "IMMCKF")])
    paper5 = float(TABLE1["IMM5CKF"][4]) / ref_paper
    j = report.judge([report.ratio_part("IMM5CKF/IMMCKF", QUANTITY, flops["IMM5CKF"] / flops["IMMCKF"], +1)])
    claims.add(TIMING_CLAIM, report.Judgement(j.verdict, f"{j.decisive}; paper {paper5:.2f}× (MATLAB time)", j.parts),
               f"cost model (mmlib.core.cost): {flops['IMM5CKF']} vs {flops['IMMCKF']} flops per step; measured CPU "
               f"time ratio, context only: {_spread(per_run, 'IMM5CKF', 'IMMCKF')} one run at a time, "
               f"{_spread(batched, 'IMM5CKF', 'IMMCKF')} batched (median [range] over {repeats} repeated "
               f"timings)", key="imm5ckf_costs_more")
    return rows, table
