"""Hu et al. 2017, Table 1's time column: the run-time ratios to IMMCDKF and the two timing claims (H-12), judged on
the cost model.

The paper's MATLAB seconds per run are not comparable with ours; their ratios are.  A measured time ratio moves with
machine load and with interpreter overhead (at ~150 µs per step of a 4-state IMM the EKF's saving over a sigma-point
rule cannot show), so the verdicts rest on a deterministic measure: the floating-point operations per step of each
IMM as it runs (:func:`mmlib.core.cost.step_flops`).  The rows compare the printed time ratio to IMMCDKF with the
model's flop ratio (no standard error); the claims are ratio parts with the equivalence margin
:data:`mmlib.experiment.verdicts.COST_MARGIN`.  The notebook's measured CPU times
(:func:`mmlib.experiment.evaluation.time_algorithms`) stay as context: median ratios with their range over the
repeats, each a separate timing of all five.
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from mmlib.core.cost import step_flops
from mmlib.experiment import report
from mmlib.experiment.metrics import ratio_spread_text as _spread
from mmlib.papers.hu2017.text import ALGORITHMS, TABLE1, paper_ratio_text

__all__ = [
    "judge_timing", "QUANTITY", "SHORTEST_CLAIM", "OBS_CLAIM"
]

#: what the rows and the claims compare
QUANTITY = "model flops per step"
SHORTEST_CLAIM = "IMMEKF has the shortest run time (Table 1)"
OBS_CLAIM = "IMMCDKF-OBS costs only slightly more time than IMMCDKF (Sec. 3)"


def judge_timing(estimators: Mapping, per_run: Mapping[str, np.ndarray], batched: Mapping[str, np.ndarray],
                 claims: report.Claims) -> tuple[list, list]:
    """Table 1's time column as ratios to IMMCDKF (H-12): rows with the printed ratio (two significant digits,
    :func:`~mmlib.papers.hu2017.text.paper_ratio_text`) against the cost model's flop ratio (``estimators``: name ->
    the IMM timed; deterministic: an exact row, equal or not to the printed precision), and the two timing
    claims, added to ``claims``:

    * *IMMEKF has the shortest run time*: one ratio part IMMEKF/other < 1 per other IMM (holds below -10 %);
    * *IMMCDKF-OBS costs only slightly more time*: IMMCDKF-OBS/IMMCDKF > 1 (costs more, beyond +10 %) and the
      model ratio below the paper's own factor (its "slightly": ratio / paper ratio < 1 beyond -10 %).

    ``per_run`` and ``batched`` (algorithm -> seconds per run in each repeat, algorithms interleaved in every
    repeat) are context: notes, evidence and the display table.  Returns (rows, table rows for display)."""
    flops = {alg: step_flops(estimators[alg])["total"] for alg in ALGORITHMS}
    repeats = len(per_run["IMMCDKF"])
    rows, table = [], []
    for alg in ALGORITHMS:
        model = flops[alg] / flops["IMMCDKF"]
        if alg != "IMMCDKF":
            rows.append(report.exact_row("Table 1", alg, f"time ratio to IMMCDKF ({QUANTITY})", paper_ratio_text(alg),
                                         model, deviations=["H-12"],
                                        note=f"cost model {flops[alg]} / {flops['IMMCDKF']} flops per step; measured "
                                             f"CPU ratio {_spread(per_run, alg, 'IMMCDKF')} one run at a time, "
                                             f"{_spread(batched, alg, 'IMMCDKF')} batched (median [range] over "
                                             f"{repeats} repeated timings); {TABLE1[alg][2]} s in MATLAB"))
        table.append([alg, TABLE1[alg][2], paper_ratio_text(alg) if alg != "IMMCDKF" else "1", f"{model:.2f}",
                      _spread(per_run, alg, "IMMCDKF"), _spread(batched, alg, "IMMCDKF"),
                      f"{1e3 * np.median(per_run[alg]):.2f}"])
    others = [a for a in ALGORITHMS if a != "IMMEKF"]
    j = report.judge([report.ratio_part(f"IMMEKF/{o}", QUANTITY, flops["IMMEKF"] / flops[o], -1) for o in others])
    paper_ekf = max(float(TABLE1["IMMEKF"][2]) / float(TABLE1[o][2]) for o in others)
    claims.add(SHORTEST_CLAIM, report.Judgement(j.verdict, f"{j.decisive}; paper at most {paper_ekf:.2f}×", j.parts),
               "cost model (mmlib.core.cost): " + ", ".join(f"{o} {flops[o]}" for o in others)
               + f", IMMEKF {flops['IMMEKF']} flops per step; measured CPU time ratios, context only, one run at a "
               "time: " + "; ".join(f"IMMEKF/{o} {_spread(per_run, 'IMMEKF', o)}" for o in others)
               + f" (median [range] over {repeats} repeated timings)", key="immekf_shortest_time")
    paper_obs = float(TABLE1["IMMCDKF-OBS"][2]) / float(TABLE1["IMMCDKF"][2])
    r = flops["IMMCDKF-OBS"] / flops["IMMCDKF"]
    parts = [report.ratio_part("IMMCDKF-OBS/IMMCDKF", QUANTITY, r, +1),
             report.ratio_part(f"IMMCDKF-OBS/IMMCDKF ÷ the paper's {paper_obs:.2f}× ('slightly')", QUANTITY,
                               r / paper_obs, -1)]
    j = report.judge(parts)
    # the operational definition in the decisive text: "more" beyond the margin, "slightly" at most the paper's own
    decisive = (f"IMMCDKF-OBS/IMMCDKF: {QUANTITY} {r:.2f}× (more by over {100 * report.COST_MARGIN:.0f} %, "
                f"'slightly': below the paper's own {paper_obs:.2f}×)" if j.verdict == report.HOLDS
                else f"{j.decisive}; paper {paper_obs:.2f}×")
    claims.add(OBS_CLAIM, report.Judgement(j.verdict, decisive, j.parts),
               f"cost model: {flops['IMMCDKF-OBS']} vs {flops['IMMCDKF']} flops per step ({r:.2f}×, paper "
               f"{paper_obs:.2f}×); measured CPU time ratio, context only: "
               f"{_spread(per_run, 'IMMCDKF-OBS', 'IMMCDKF')} one run at a time, "
               f"{_spread(batched, 'IMMCDKF-OBS', 'IMMCDKF')} batched (median [range] over {repeats} "
               "repeated timings)", key="obs_time")
    return rows, table
