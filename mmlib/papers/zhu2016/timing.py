"""Table 1's run-time column of Zhu, Wang & Yuan 2016 (deviation Z-15), judged as ratios to IMMCKF.

The paper prints MATLAB seconds without saying whether per run or in total; absolute times across languages and
machines are not comparable, ratios are.  The notebook measures CPU time per run
(:func:`mmlib.experiment.evaluation.time_algorithms`: one run at a time, the paper's way, and batched, the algorithms
taking turns run by run in every repeat); :func:`judge_timing` turns the per-repeat ratios into Table 1 rows and
the timing claim.
"""
from __future__ import annotations

from mmlib.experiment import metrics, report
from mmlib.papers.zhu2016.text import ALGORITHMS, TABLE1

#: runs timed one at a time per repeat (the fastest of them is the repeat's value)
TIMING_PER_REPEAT = 3
#: the paper's claim on run time (Section 4, Table 1's time column)
TIMING_CLAIM = "IMM5CKF costs more computation than IMMCKF"


def judge_timing(per_run: dict, batched: dict, claims: report.Claims) -> tuple:
    """Table 1's time column as ratios to IMMCKF (Z-15): rows judged by the verdict rule with the standard error
    of the per-repeat ratios, and the timing claim as a part verdict on ratio - 1.  Returns (rows, table rows for
    display)."""
    repeats = len(per_run["IMMCKF"])
    ref_paper = float(TABLE1["IMMCKF"][4])
    ratios = {alg: metrics.timing_ratio(per_run[alg], per_run["IMMCKF"]) for alg in per_run}
    rows, table = [], []
    for alg in ALGORITHMS:
        paper_ratio = float(TABLE1[alg][4]) / ref_paper
        if alg == "IMMCKF":   # the reference of the ratios: its absolute MATLAB time cannot be compared
            rows.append(report.make_row("Table 1", alg, "Time (s)", TABLE1[alg][4], None, None,
                                        reason="absolute MATLAB time; IMMCKF is the reference of the ratios (Z-15)",
                                        deviations=["Z-15"], note=f"{1e3 * per_run[alg].mean():.1f} ms per run here"))
            table.append([alg, TABLE1[alg][4], "1 (reference)", "1 (reference)", f"{1e3 * per_run[alg].mean():.2f}",
                          f"{1e3 * batched[alg].mean():.3f}", "1 (reference)",
                          f"{per_run[alg].mean() / batched[alg].mean():.0f}×"])
            continue
        if alg == "OMTM-IMM":
            rows.append(report.make_row("Table 1", alg, "Time ratio to IMMCKF (one run at a time)",
                                        f"{paper_ratio:.3f}", None, None, reason="method not specified (Z-14)",
                                        deviations=["Z-14", "Z-15"]))
            continue
        ratio = ratios[alg]
        rows.append(report.make_row("Table 1", alg, "Time ratio to IMMCKF (one run at a time)", f"{paper_ratio:.3f}",
                                    ratio.value, ratio.stderr, deviations=["Z-15"],
                                    note=f"{1e3 * per_run[alg].mean():.1f} ms (CPU) per run here vs "
                                         f"{TABLE1[alg][4]} s (MATLAB); s.e. from {repeats} repeated timings"))
        bratio = metrics.timing_ratio(batched[alg], batched["IMMCKF"])
        table.append([alg, TABLE1[alg][4], f"{paper_ratio:.2f}",
                      f"{float(ratio.value):.3f} ± {float(ratio.stderr):.3f}",
                      f"{1e3 * per_run[alg].mean():.2f}", f"{1e3 * batched[alg].mean():.3f}",
                      f"{float(bratio.value):.2f} ± {float(bratio.stderr):.2f}",
                      f"{per_run[alg].mean() / batched[alg].mean():.0f}×"])
    r5 = ratios["IMM5CKF"]
    claims.add(TIMING_CLAIM, report.paired_claim(float(r5.value) - 1.0, float(r5.stderr), +1),
               f"CPU-time ratio, one run at a time, {float(r5.value):.3f} ± {float(r5.stderr):.3f} over {repeats} "
               f"repeated timings (paper {float(TABLE1['IMM5CKF'][4]) / ref_paper:.2f})")
    return rows, table
