"""The refinements of the verdict rule (issue 23): identity to round-off, deterministic ratios, exact rows, joint
tests of tables and rows, and the one-line claim verdict (mmlib/experiment/verdicts.py)."""
import math

import numpy as np
import pytest
from scipy.stats import chi2

import mmlib as m
from mmlib.experiment import evaluation, report
from mmlib.experiment.evaluation import RunSet

EPS = np.finfo(float).eps


def _runset(errors):
    n = errors.shape[0]
    return RunSet(errors, None, np.full(n, -1), errors[0], None)


# -- numerical identity ---------------------------------------------------------------------------------------
def _linear_errors(filt, linear_problem):
    """Estimates of ``filt`` on the linear problem minus a fixed "truth" (100 in every component)."""
    dyn, meas, x0, P0, zs = linear_problem
    track = m.run(m.SingleModel(filt, dyn, meas), filt.init(x0, P0), zs)
    return track.mean - 100.0


@pytest.mark.parametrize("filt", [m.SigmaPointFilter(m.Unscented()), m.SigmaPointFilter(m.Cubature()),
                                  m.SigmaPointFilter(m.FifthDegreeCubature())], ids=["UKF", "CKF", "5CKF"])
def test_filters_equal_in_exact_arithmetic_are_identical_not_a_difference(filt, linear_problem):
    """On a linear-Gaussian model every sigma-point filter is the Kalman filter in exact arithmetic: the paired
    difference of their mean squared errors is round-off, judged 'identical (to round-off)' with no z-score --
    although its paired standard error is also round-off, so z alone could read anything."""
    a = _runset(_linear_errors(filt, linear_problem))
    b = _runset(_linear_errors(m.KalmanFilter(), linear_problem))
    d = evaluation.paired_mse_difference(a, b, (0, 2))
    ref = float((b.errors[..., [0, 2]] ** 2).sum(-1).mean())
    p = report.part("UKF − KF", "position MSE", float(d.value), float(d.stderr), -1, reference=ref, unit="m²")
    assert p.verdict == report.PartVerdict.IDENTICAL and math.isnan(p.z())
    assert report.judge([p]).verdict == report.NOT_SUPPORTED and "identical to round-off" in report.judge([p]).decisive


def test_a_difference_of_one_part_in_a_million_is_not_round_off(linear_problem):
    """The same pair with one filter's errors scaled by 1 + 1e-6: a real (tiny) difference, far above the floor
    (1.5e-8 of the reference), so it gets a z-score and the ordinary rule, never 'identical'."""
    e = _linear_errors(m.KalmanFilter(), linear_problem)
    a, b = _runset(e * (1 + 1e-6)), _runset(e)
    d = evaluation.paired_mse_difference(a, b, (0, 2))
    ref = float((e[..., [0, 2]] ** 2).sum(-1).mean())
    assert abs(float(d.value)) > 100 * report.identity_floor(ref)
    p = report.part("A − B", "position MSE", float(d.value), float(d.stderr), +1, reference=ref)
    assert p.verdict != report.PartVerdict.IDENTICAL and math.isfinite(p.z()) and p.z() > 0


def test_identity_floor_is_ops_eps_reference():
    assert report.identity_floor(100.0) == report.ROUNDOFF_OPS * EPS * 100.0
    assert report.identity_floor(-2.0, ops=10) == 10 * EPS * 2.0
    assert report.claim_verdict(0.0, 0.0, -1) == report.PartVerdict.IDENTICAL          # exact zero, no reference
    # without a reference only an exact zero is identical: the smallest positive difference with zero error is a
    # difference (contradicting "A < B")
    assert report.claim_verdict(1e-300, 0.0, -1) == report.PartVerdict.CONTRADICTED
    floor = report.identity_floor(1.0)
    assert report.claim_verdict(floor, floor, -1, reference=1.0) == report.PartVerdict.IDENTICAL
    assert report.claim_verdict(-2 * floor, floor / 10, -1, reference=1.0) == report.PartVerdict.HOLDS_NEGLIGIBLE
    for bad, arg in (({"reference": "x"}, "reference"), ({"ops": 0}, "ops"), ({"ops": 1.5}, "ops")):
        with pytest.raises(ValueError, match=arg):
            report.identity_floor(**{"reference": 1.0, **bad})


# -- deterministic ratios -------------------------------------------------------------------------------------
@pytest.mark.parametrize("ratio,sign,expected", [(2.31, +1, "holds"), (1.05, +1, "no detectable difference"),
                                                 (0.95, +1, "no detectable difference"), (0.8, +1, "contradicted"),
                                                 (0.8, -1, "holds"), (1.11, -1, "contradicted")])
def test_ratio_part_has_an_equivalence_margin(ratio, sign, expected):
    p = report.ratio_part("A/B", "flops per step", ratio, sign)
    assert p.verdict == expected and p.stderr is None and p.margin == report.COST_MARGIN
    assert f"{ratio:.3g}×" in p.number() and "±10 %" in p.number()


def test_ratio_part_refuses_bad_input():
    for kwargs, arg in (({"ratio": -1.0}, "ratio"), ({"ratio": float("nan")}, "ratio"), ({"margin": 1.5}, "margin"),
                        ({"expected_sign": 0}, "expected_sign")):
        with pytest.raises(ValueError, match=arg):
            report.ratio_part(**{"comparison": "A/B", "quantity": "q", "ratio": 2.0, "expected_sign": 1, **kwargs})


# -- exact rows ----------------------------------------------------------------------------------------------------
def test_exact_rows_are_judged_by_equality_to_the_printed_precision():
    r = report.exact_row("Table 1", "CP", "mean", "0.6", 0.6)
    assert r.verdict == report.REPRODUCED_EXACT and r.distance is None and report.is_reproduced(r.verdict)
    assert report.exact_row("Table 1", "CP", "mean", "0.6", 0.64).verdict == report.REPRODUCED_EXACT
    assert report.exact_row("Table 1", "CP", "mean", "0.6", 0.66).verdict == report.NOT_REPRODUCED_EXACT
    assert report.exact_row("Table 1", "CP", "mean", "0.60", 0.606).verdict == report.NOT_REPRODUCED_EXACT
    # the Monte Carlo rule would call an exact 0.6 'inconclusive' (3 x 0.05 half-units = 25 % of 0.6)
    assert report.verdict("0.6", 0.6, 0.0) != report.REPRODUCED_EXACT
    with pytest.raises(ValueError, match="value"):
        report.exact_row("Table 1", "CP", "mean", "0.6", float("nan"))


# -- joint tests ----------------------------------------------------------------------------------------------------
def test_joint_test_is_chi_squared_with_one_degree_per_cell():
    t = report.joint_test([1.0, -2.0, 0.5])
    assert t.statistic == 5.25 and t.dof == 3 and t.p_value == pytest.approx(chi2.sf(5.25, 3), rel=1e-12)
    assert t.passes
    assert report.JOINT_ALPHA == pytest.approx(2 * (1 - 0.998650101968370), rel=1e-9)     # 2 Phi(-3)
    # one cell: the joint test is the 3-sigma rule
    assert report.joint_test([2.99]).passes and not report.joint_test([3.01]).passes
    assert not report.joint_test([0.0, math.inf]).passes
    with pytest.raises(ValueError, match="distances"):
        report.joint_test([])
    with pytest.raises(ValueError, match="distances"):
        report.joint_test([math.nan])


def _row(alg, printed, value, se=0.01):
    return report.make_row("Table 1", alg, "RMSE (m)", printed, value, se, n_runs=100, n_runs_paper=100)


def test_a_coincidence_in_a_failing_row_is_isolated_and_not_counted():
    """Row A: one cell on the printed value, two hundreds of s.e. away -> its reproduced cell is isolated.
    Row B: all three cells within 1 s.e. -> reproduced, but the table fails (it holds row A)."""
    rows = [_row("A", "2.00", 2.0), _row("A", "3.00", 5.0), _row("A", "4.00", 9.0),
            _row("B", "2.00", 2.005), _row("B", "3.00", 3.005), _row("B", "4.00", 3.995)]
    assert [r.verdict for r in rows].count(report.REPRODUCED) == 4
    judged, tests = report.joint_tests(rows)
    verdicts = [r.verdict for r in judged]
    assert verdicts[0] == report.ISOLATED and not report.is_reproduced(verdicts[0])
    # row B passes, but the table fails: its cells are isolated too
    assert verdicts[3:] == [report.ISOLATED] * 3
    by = {(t["item"], t["algorithm"]): t for t in tests}
    assert not by[("Table 1", None)]["passes"] and by[("Table 1", None)]["dof"] == 6
    assert by[("Table 1", "B")]["passes"] and not by[("Table 1", "A")]["passes"]
    assert by[("Table 1", None)]["n_isolated"] == 4
    # the joint-tested rows are unchanged by a second pass (idempotent), and the input is not changed
    assert report.joint_tests(judged)[0] == judged and rows[0].verdict == report.REPRODUCED
    # a table of row B alone passes: nothing isolated
    alone, _ = report.joint_tests(rows[3:])
    assert all(r.verdict == report.REPRODUCED for r in alone)


def test_joint_tests_leave_out_exact_and_not_replicable_rows():
    """Exact and not replicable rows stay out of the joint tests, and so do deterministic values (a cost model's
    ratio: no standard error), judged on the printed precision alone."""
    rows = [_row("A", "2.00", 2.0), report.exact_row("Table 1", "A", "mean", "0.6", 0.6),
            report.make_row("Table 1", "A", "time", "1.0", None, None, reason="MATLAB seconds"),
            report.make_row("Table 1", "A", "time ratio", "0.26", 0.618, None)]
    assert rows[3].distance == pytest.approx((0.618 - 0.26) / 0.005)          # half a unit of the printed digit
    judged, tests = report.joint_tests(rows)
    assert [t["dof"] for t in tests] == [1, 1] and all(t["passes"] for t in tests) and judged == rows
    with pytest.raises(ValueError, match=r"rows\[1\]"):
        report.joint_tests([rows[0], {"item": "x"}])


# -- the one-line verdict ---------------------------------------------------------------------------------------------
def test_a_part_reads_as_one_number():
    p = report.part("IMMCDKF-OBS − IMMCDKF", "position MSE", 2400.0, 50.0, -1, reference=100.0, unit="m²")
    assert p.verdict == report.PartVerdict.CONTRADICTED
    assert p.number() == "IMMCDKF-OBS − IMMCDKF: position MSE +2.4e+03 % (z = +48)"
    assert p.as_json()["number"] == p.number() and p.as_json()["verdict"] == "contradicted"
    q = report.part("A − B", "NEES", -0.5, 0.1, -1)
    assert q.number() == "A − B: NEES -0.50 ± 0.10"          # format_pm: the s.e. to two significant figures
    with pytest.raises(ValueError, match="verdict"):
        report.Part("A − B", "q", "maybe", 1.0)
    with pytest.raises(ValueError, match="kind"):
        report.Part("A − B", "q", report.PartVerdict.HOLDS, 1.0, kind="other")


def test_judgement_is_one_term_of_the_vocabulary():
    j = report.Judgement.of("not assessable", "OMTM-IMM is not specified (Z-14)")
    assert j.verdict is report.NOT_ASSESSABLE and j.text() == "not assessable — OMTM-IMM is not specified (Z-14)"
    for bad in ("partly: holds (a)", "holds, but negligible (< 1 %)", 3):
        with pytest.raises(ValueError, match="verdict"):
            report.Judgement(bad, "")
    with pytest.raises(ValueError, match="parts"):
        report.judge([])
    with pytest.raises(ValueError, match=r"parts\[0\]"):
        report.judge(["holds"])


def test_the_floor_counts_the_operations_of_the_runs_compared():
    """better_claim's floor uses the runs' own operation count (RunSet.ops: flops per step by the cost model times
    the square root of the steps): a difference of 2e-10 of the reference is below the default 2^21 floor (4.7e-10)
    but far above that of a run counted at 1.8e5 operations (3.9e-11), so there it is judged as a difference, never as
    round-off."""
    rng = np.random.default_rng(1)
    e = np.full((50, 10, 4), 10.0)
    scale = 1 + 2e-10 * (1 + 0.01 * rng.standard_normal((50, 1, 1)))
    a, b = _runset(e * np.sqrt(scale)), _runset(e)
    unknown, _ = evaluation.better_claim({"A": a, "B": b}, "A", "B", [("position", (0, 2))])
    assert unknown.parts[0].verdict == report.PartVerdict.IDENTICAL
    counted, _ = evaluation.better_claim({"A": a._replace(ops=176_300), "B": b._replace(ops=170_100)}, "A", "B",
                                         [("position", (0, 2))])
    assert counted.parts[0].verdict == report.PartVerdict.CONTRADICTED_NEGLIGIBLE
    assert counted.parts[0].z() > 100


def test_run_operations_are_steps_times_the_cost_model():
    from mmlib.core import cost, models
    dyn, meas = models.constant_velocity(1.0, 2.0), models.position_measurement([25.0, 16.0])
    est = m.SingleModel(m.KalmanFilter(), dyn, meas)
    assert evaluation.run_operations(est, 25) == 5 * cost.step_flops(est)["total"] > 0     # f sqrt(K)
    assert evaluation.run_operations(est, 2) == math.ceil(math.sqrt(2) * cost.step_flops(est)["total"])
    assert evaluation.run_operations(object(), 25) is None                    # unknown to the cost model
    with pytest.raises(ValueError, match="steps"):
        evaluation.run_operations(est, 0)


def test_the_floor_separates_round_off_from_a_curvature_difference():
    """The arena's cells on two scenarios: on zhu2016's linear models IMM5CKF and IMMCKF are one algorithm in exact
    arithmetic (identical to round-off); on tseng2011's pseudoranges the UKF's points see a curvature the EKF's
    linearisation does not (1e-9 of the MSE, about 9 times the floor of its 1.2e6 operations): a difference, not
    round-off, though negligible."""
    from mmlib.arena import study
    def cells(scenario):
        return study.run_arena(20, scenarios=[scenario], algorithms=["IMMCKF", "IMM5CKF", "IMMUKF", "IMMEKF"],
                               progress=False, use_cache=False, workers=1)
    assert study.compare(cells("zhu2016"), "IMM5CKF", "IMMCKF", "zhu2016")["verdict"] == "identical (to round-off)"
    res = cells("tseng2011")
    c = study.compare(res, "IMMUKF", "IMMEKF", "tseng2011")
    assert c["verdict"] != "identical (to round-off)" and c["part"]["verdict"] != "identical (to round-off)"
    assert abs(c["relative"]) > report.identity_floor(1.0, res.operations("tseng2011", "IMMUKF", "IMMEKF"))
