"""The claims of Liu & Wu 2017's abstract, introduction, Section 4.2 and conclusions, judged on one reading's Monte
Carlo runs (:func:`judge_claims`), every verdict from paired differences over common random numbers in the claim
vocabulary of :mod:`mmlib.experiment.report` (holds / partly / contradicted / not supported / not assessable).

Accuracy is the paired difference of per-run mean squared errors (m^2, (m/s)^2, (m/s^2)^2) of the x-y position,
velocity or acceleration (Eq. 42's ARMSE squared); robustness, which the paper does not define, is judged as
:data:`ROBUSTNESS_DEFINITION` states.
"""
from __future__ import annotations

from collections import Counter
from typing import TYPE_CHECKING, Sequence

import numpy as np

from mmlib.experiment import evaluation, metrics, report
from mmlib.papers.liu2017.text import CASES, POSITION, QUANTITIES

if TYPE_CHECKING:
    from mmlib.papers.liu2017.study import ReadingResults

ROBUSTNESS_DEFINITION = (
    "Robustness (the paper gives no definition; ours): (i) the position error after the abrupt change -- the paired "
    "difference of the per-run mean squared position error over the steps after the onset -- in each of the three "
    "maneuvers (Example 1 high, Example 2 Case 1 medium, Case 2 weak), and (ii) where any run diverges in either "
    "filter, the paired difference of the divergence indicators. 'More robust' holds when every part holds.")


def after_onset(rs: evaluation.RunSet, start: int) -> evaluation.RunSet:
    """The RunSet restricted to the steps from index ``start`` on (errors only)."""
    return rs._replace(errors=rs.errors[:, start:])


def _mse(rs: evaluation.RunSet, idx) -> float:
    return float((rs.errors[rs.valid][..., list(idx)] ** 2).sum(axis=-1).mean())


def _paired_part(a, b, idx, sign=-1):
    d = evaluation.paired_mse_difference(a, b, idx)
    return report.claim_verdict(float(d.value), float(d.stderr), sign, reference=_mse(b, idx)), d


def _divergence_part(a, b):
    """Part verdict for 'a diverges less often than b', or None when neither diverges."""
    da, db = (~a.valid).astype(float), (~b.valid).astype(float)
    if not (da.any() or db.any()):
        return None
    m = metrics.mean_with_se(da - db)
    return report.claim_verdict(float(m.value), float(m.stderr), -1)


def combine_parts(parts: Sequence[tuple[str, str]]) -> str:
    """One claim verdict from labelled part verdicts ``[(label, part verdict)]``; for many parts the
    detail is condensed to counts and the labels of the parts that do not hold."""
    full = report.combine_claim_verdicts(f"{v} ({lab})" for lab, v in parts)
    if len(parts) <= 4:
        return full
    head = report.claim_category(full)
    if head == report.HOLDS:
        return head
    counts = Counter(v.split(" (")[0] for _, v in parts)
    not_holding = [lab for lab, v in parts if v != "holds"]
    shown = ", ".join(not_holding[:8]) + (f" and {len(not_holding) - 8} more" if len(not_holding) > 8 else "")
    return (f"{head}: of {len(parts)} parts, " + ", ".join(f"{n} {k}" for k, n in counts.items())
            + f"; not holding: {shown}")


def judge_claims(results: ReadingResults) -> report.Claims:
    """The verdicts on the abstract's and conclusions' claims for one reading (claim vocabulary of
    :mod:`mmlib.experiment.report`), with their evidence."""
    R = results.runs
    ex1 = R["Example 1"]
    onset = {case: results.setups[case].onset_index for case in CASES}
    claims = report.Claims()
    qty = [(q.split()[0], idx) for q, idx in QUANTITIES]

    # 1. SSRCKF declines and may diverge after the abrupt maneuver (Example 1)
    ssr = ex1["SSRCKF"]
    k0 = onset["Example 1"]
    sq = (ssr.errors[ssr.valid][..., list(POSITION)] ** 2).sum(axis=-1)
    decline = metrics.mean_with_se(sq[:, k0:].mean(axis=1) - sq[:, :k0].mean(axis=1))
    n_div = int((~ssr.valid).sum())
    div_rate = metrics.mean_with_se((~ssr.valid).astype(float))
    peak = float(metrics.rmse_over_time(np.sqrt((ssr.errors[..., list(POSITION)] ** 2).sum(-1)), ssr.valid).value.max())
    claims.add("SSRCKF may decline in accuracy and even diverge after an abrupt maneuver (abstract; Example 1)",
               report.combine_claim_verdicts([
                   f"{report.claim_verdict(float(decline.value), float(decline.stderr), +1)} (decline: position MSE "
                   f"after minus before the onset)",
                   f"{report.claim_verdict(float(div_rate.value), float(div_rate.stderr), +1)} (divergence)"]),
               f"position MSE after minus before the onset {decline.value:.4g} ± {decline.stderr:.2g} m²; RMSE peaks "
               f"at {peak:.0f} m; diverged runs {n_div} of {len(ssr.valid)}")

    # 2. the SSR rule against the CKF's, without strong tracking
    claims.add("The SSR rule is more accurate than the CKF's (abstract; Example 1, no strong tracking)",
               *evaluation.better_claim(ex1, "SSRCKF", "CKF", qty))
    # 3. Table 1 ranking, 4. Table 3
    for other in ("SSRCKF", "STF", "STUKF", "STCKF"):
        claims.add(f"STSSRCKF is more accurate than {other} (Example 1, Table 1)",
                   *evaluation.better_claim(ex1, "STSSRCKF", other, qty))
    for case in ("Case 1", "Case 2"):
        claims.add(f"STSSRCKF is more accurate than SSRCKF ({case}, Table 3)",
                   *evaluation.better_claim(R[case], "STSSRCKF", "SSRCKF", qty))
    claims.add("STSSRCKF is more accurate than STF (weak maneuver, Table 3 Case 2)",
               *evaluation.better_claim(R["Case 2"], "STSSRCKF", "STF", qty))

    # 5. normal accuracy for weak maneuvers: ARMSE_ST < (1 + band) ARMSE_SSR  <=>  MSE_ST - (1 + band)^2 MSE_SSR < 0
    c2 = R["Case 2"]
    ok = c2["STSSRCKF"].valid & c2["SSRCKF"].valid
    f2 = (1.0 + report.RELATIVE_BAND) ** 2
    mse_run = {a: (c2[a].errors[ok][..., list(POSITION)] ** 2).sum(-1).mean(1) for a in ("STSSRCKF", "SSRCKF")}
    d = metrics.mean_with_se(mse_run["STSSRCKF"] - f2 * mse_run["SSRCKF"])
    arm = {a: metrics.armse(c2[a].errors[..., list(POSITION)], c2[a].valid) for a in ("STSSRCKF", "SSRCKF")}
    claims.add(f"STSSRCKF keeps normal accuracy for weak maneuvers (introduction; Case 2 position ARMSE within "
               f"{100 * report.RELATIVE_BAND:.0f} % of SSRCKF's)",
               report.paired_claim(float(d.value), float(d.stderr), -1),
               f"MSE_STSSRCKF − {f2:.4g} MSE_SSRCKF = {d.value:.4g} ± {d.stderr:.2g} m²; position ARMSE STSSRCKF "
               f"{arm['STSSRCKF'].value:.1f} ± {arm['STSSRCKF'].stderr:.1f} m, SSRCKF {arm['SSRCKF'].value:.1f} ± "
               f"{arm['SSRCKF'].stderr:.1f} m")

    # 6. robustness (operational definition ROBUSTNESS_DEFINITION)
    def robustness_parts(other):
        parts, ev = [], []
        for case in CASES:
            v, dd = _paired_part(after_onset(R[case]["STSSRCKF"], onset[case]),
                                 after_onset(R[case][other], onset[case]), POSITION)
            parts.append((f"{case} after the onset vs {other}", v))
            ev.append(f"{case}: Δ = {dd.value:.4g} ± {dd.stderr:.2g} m²")
            dv = _divergence_part(R[case]["STSSRCKF"], R[case][other])
            if dv is not None:
                parts.append((f"{case} divergence vs {other}", dv))
        return parts, ev

    parts, ev = robustness_parts("SSRCKF")
    claims.add("STSSRCKF has greater robustness than SSRCKF (abstract)", combine_parts(parts),
               "position MSE after the onset, STSSRCKF − SSRCKF: " + "; ".join(ev) + ". " + ROBUSTNESS_DEFINITION)

    # 7. conclusions: higher accuracy and robustness than each of the other four, in every maneuver
    parts, ev = [], []
    for other in ("STF", "STUKF", "STCKF", "SSRCKF"):
        for case in CASES:
            for label, idx in qty:
                v, _ = _paired_part(R[case]["STSSRCKF"], R[case][other], idx)
                parts.append((f"{case} {label.lower()} vs {other}", v))
        rp, rev = robustness_parts(other)
        parts += rp
        ev.append(f"after the onset vs {other}: " + "; ".join(rev))
    claims.add("STSSRCKF achieves higher accuracy and robustness than STF, STUKF, STCKF and SSRCKF (conclusions)",
               combine_parts(parts),
               "accuracy: paired MSE of position, velocity and acceleration in Example 1 and both cases of "
               "Example 2; " + " | ".join(ev) + ". " + ROBUSTNESS_DEFINITION)

    claims.add("STSSRCKF has the best balance between computational complexity and estimation accuracy (Sec. 4.2)",
               f"{report.NOT_ASSESSABLE}: the paper defines no measure of the balance",
               "accuracy and time are each judged above (Table 1, Table 2 claims)")
    return claims
