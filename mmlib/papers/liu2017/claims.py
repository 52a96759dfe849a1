"""The claims of Liu & Wu 2017's abstract, introduction, Section 4.2 and conclusions, judged on one reading's Monte
Carlo runs (:func:`judge_claims`), every verdict from paired differences over common random numbers in the claim
vocabulary of :mod:`mmlib.experiment.report` (holds / partly / contradicted / not supported / not assessable): each
claim is one :class:`~mmlib.experiment.report.Judgement` -- one verdict, the one decisive number that produced it and
the flat list of its parts (:class:`~mmlib.experiment.report.Part`, comparison ``"A − B"``, quantity e.g.
``"Case 1 velocity MSE"``), judged once; a difference within the round-off floor is "identical (to round-off)", never
an effect.

Accuracy is the paired difference of per-run mean squared errors (m^2, (m/s)^2, (m/s^2)^2) of the x-y position,
velocity or acceleration (Eq. 42's ARMSE squared); robustness, which the paper does not define, is judged as
:data:`ROBUSTNESS_DEFINITION` states.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Sequence

import numpy as np

from mmlib.experiment import evaluation, metrics, report
from mmlib.papers.liu2017.text import CASES, POSITION, QUANTITIES

__all__ = [
    "judge_claims", "after_onset", "accuracy_part", "after_onset_part", "divergence_part", "ROBUSTNESS_DEFINITION",
    "UNITS"
]

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


#: the squared unit of each quantity's mean squared error, by its short label (:data:`QUANTITIES`)
UNITS = {"Position": "m²", "Velocity": "(m/s)²", "Acceleration": "(m/s²)²"}


def accuracy_part(results: dict, a: str, b: str, case: str, label: str, idx: int | Sequence[int]) -> report.Part:
    """The part "``a`` is more accurate than ``b``" in ``case`` on one quantity (``label`` one of :data:`UNITS`,
    ``idx`` its state components): the paired difference of per-run mean squared errors ``a − b`` on common random
    numbers, relative to b's mean squared error (:func:`mmlib.experiment.report.part`, the round-off floor on it)."""
    d = evaluation.paired_mse_difference(results[a], results[b], idx)
    return report.part(f"{a} − {b}", f"{case} {label.lower()} MSE", float(d.value), float(d.stderr), -1,
                       reference=_mse(results[b], idx), unit=UNITS[label],
                       ops=evaluation.pair_operations(results[a], results[b]))


def after_onset_part(results: ReadingResults, a: str, b: str, case: str) -> report.Part:
    """The part "``a``'s position error after the onset is smaller than ``b``'s" in ``case`` (robustness (i) of
    :data:`ROBUSTNESS_DEFINITION`): the paired position-MSE difference over the steps from the onset on (m²),
    relative to b's."""
    k0 = results.setups[case].onset_index
    ra, rb = after_onset(results.runs[case][a], k0), after_onset(results.runs[case][b], k0)
    d = evaluation.paired_mse_difference(ra, rb, POSITION)
    return report.part(f"{a} − {b}", f"{case} position MSE after the onset", float(d.value), float(d.stderr), -1,
                       reference=_mse(rb, POSITION), unit="m²", ops=evaluation.pair_operations(ra, rb))


def divergence_part(a: evaluation.RunSet, b: evaluation.RunSet, comparison: str, case: str) -> report.Part | None:
    """The part "``a`` diverges less often than ``b``" (robustness (ii)): the paired difference of the divergence
    indicators (share of runs), or None when neither diverges."""
    da, db = (~a.valid).astype(float), (~b.valid).astype(float)
    if not (da.any() or db.any()):
        return None
    m = metrics.mean_with_se(da - db)
    return report.part(comparison, f"{case} share of runs diverged", float(m.value), float(m.stderr), -1)


def _evidence(parts) -> str:
    return "; ".join(p.number() for p in parts)


def judge_claims(results: ReadingResults) -> report.Claims:
    """The verdicts on the abstract's and conclusions' claims for one reading: one
    :class:`~mmlib.experiment.report.Judgement` per claim (one term of the claim vocabulary, its decisive number and
    its parts: :func:`mmlib.experiment.report.judge`), with their evidence."""
    R = results.runs
    ex1 = R["Example 1"]
    claims = report.Claims()
    qty = [(q.split()[0], idx) for q, idx in QUANTITIES]

    def accuracy(case, a, b):
        return [accuracy_part(R[case], a, b, case, label, idx) for label, idx in qty]

    # 1. SSRCKF declines and may diverge after the abrupt maneuver (Example 1)
    ssr = ex1["SSRCKF"]
    k0 = results.setups["Example 1"].onset_index
    sq = (ssr.errors[ssr.valid][..., list(POSITION)] ** 2).sum(axis=-1)
    decline = metrics.mean_with_se(sq[:, k0:].mean(axis=1) - sq[:, :k0].mean(axis=1))
    n_div = int((~ssr.valid).sum())
    peak = float(metrics.rmse_over_time(np.sqrt((ssr.errors[..., list(POSITION)] ** 2).sum(-1)), ssr.valid).value.max())
    parts = [report.part("SSRCKF after − before the onset", "Example 1 position MSE", float(decline.value),
                         float(decline.stderr), +1, reference=float(sq[:, :k0].mean()), unit="m²")]
    if n_div:
        rate = metrics.mean_with_se((~ssr.valid).astype(float))
        parts.append(report.part("SSRCKF", "Example 1 share of runs diverged", float(rate.value),
                                 float(rate.stderr), +1))
    else:   # no run diverged: nothing observed (not a round-off identity, which a 0 ± 0 difference would read as)
        parts.append(report.Part("SSRCKF", "Example 1 share of runs diverged", report.PartVerdict.NO_DIFFERENCE,
                                 0.0, 0.0))
    claims.add("SSRCKF may decline in accuracy and even diverge after an abrupt maneuver (abstract; Example 1)",
               report.judge(parts),
               f"position MSE after minus before the onset "
               f"{report.format_pm(float(decline.value), float(decline.stderr), signed=True)} m²; RMSE peaks "
               f"at {peak:.0f} m; diverged runs {n_div} of {len(ssr.valid)}", key="ssrckf_declines")

    # 2. the SSR rule against the CKF's, without strong tracking; 3. Table 1 ranking; 4. Table 3
    comparisons = [("The SSR rule is more accurate than the CKF's (abstract; Example 1, no strong tracking)",
                    "Example 1", "SSRCKF", "CKF", "ssr_vs_ckf_rule")]
    comparisons += [(f"STSSRCKF is more accurate than {other} (Example 1, Table 1)", "Example 1", "STSSRCKF", other,
                     f"example1_vs_{other.lower()}") for other in ("SSRCKF", "STF", "STUKF", "STCKF")]
    comparisons += [(f"STSSRCKF is more accurate than SSRCKF ({case}, Table 3)", case, "STSSRCKF", "SSRCKF",
                     f"{case.lower().replace(' ', '')}_vs_ssrckf") for case in ("Case 1", "Case 2")]
    comparisons.append(("STSSRCKF is more accurate than STF (weak maneuver, Table 3 Case 2)", "Case 2", "STSSRCKF",
                        "STF", "case2_vs_stf"))
    for text, case, a, b, key in comparisons:
        parts = accuracy(case, a, b)
        claims.add(text, report.judge(parts), _evidence(parts), key=key)

    # 5. normal accuracy for weak maneuvers: ARMSE_ST < (1 + band) ARMSE_SSR  <=>  MSE_ST - (1 + band)^2 MSE_SSR < 0
    c2 = R["Case 2"]
    ok = c2["STSSRCKF"].valid & c2["SSRCKF"].valid
    f2 = (1.0 + report.RELATIVE_BAND) ** 2
    mse_run = {a: (c2[a].errors[ok][..., list(POSITION)] ** 2).sum(-1).mean(1) for a in ("STSSRCKF", "SSRCKF")}
    d = metrics.mean_with_se(mse_run["STSSRCKF"] - f2 * mse_run["SSRCKF"])
    arm = {a: metrics.armse(c2[a].errors[..., list(POSITION)], c2[a].valid) for a in ("STSSRCKF", "SSRCKF")}
    band = report.part(f"STSSRCKF − {f2:.4g}·SSRCKF", "Case 2 position MSE", float(d.value), float(d.stderr), -1,
                       reference=f2 * float(mse_run["SSRCKF"].mean()), unit="m²")
    claims.add(f"STSSRCKF keeps normal accuracy for weak maneuvers (introduction; Case 2 position ARMSE within "
               f"{100 * report.RELATIVE_BAND:.0f} % of SSRCKF's)", report.judge([band]),
               f"MSE_STSSRCKF − {f2:.4g} MSE_SSRCKF = {report.format_pm(float(d.value), float(d.stderr), signed=True)}"
               " m²; position ARMSE " + ", ".join(f"{a} {report.format_pm(float(arm[a].value), float(arm[a].stderr))} m"
                                                  for a in ("STSSRCKF", "SSRCKF")),
               key="weak_maneuver_accuracy")

    # 6. robustness (operational definition ROBUSTNESS_DEFINITION)
    def robustness_parts(other):
        parts = []
        for case in CASES:
            parts.append(after_onset_part(results, "STSSRCKF", other, case))
            dv = divergence_part(R[case]["STSSRCKF"], R[case][other], f"STSSRCKF − {other}", case)
            if dv is not None:
                parts.append(dv)
        return parts

    parts = robustness_parts("SSRCKF")
    claims.add("STSSRCKF has greater robustness than SSRCKF (abstract)", report.judge(parts),
               _evidence(parts) + ". " + ROBUSTNESS_DEFINITION, key="robustness")

    # 7. conclusions: higher accuracy and robustness than each of the other four, in every maneuver: one flat list of
    # parts judged once
    parts = []
    for other in ("STF", "STUKF", "STCKF", "SSRCKF"):
        for case in CASES:
            parts += accuracy(case, "STSSRCKF", other)
        parts += robustness_parts(other)
    claims.add("STSSRCKF achieves higher accuracy and robustness than STF, STUKF, STCKF and SSRCKF (conclusions)",
               report.judge(parts),
               "accuracy: paired MSE of position, velocity and acceleration in Example 1 and both cases of Example 2; "
               "robustness: position MSE after the onset in each (parts in the claim matrix). " + ROBUSTNESS_DEFINITION,
               key="best_of_five")

    claims.add("STSSRCKF has the best balance between computational complexity and estimation accuracy (Sec. 4.2)",
               report.Judgement.of(report.NOT_ASSESSABLE, "the paper defines no measure of the balance"),
               "accuracy and time are each judged above (Table 1, Table 2 claims)", key="best_balance")
    return claims
