"""Paper-level facts of Zhu et al. 2016 under its own set-up."""
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import pytest

from mmlib import MonteCarlo
from mmlib.core.estimation import SingleModel
from mmlib.core.filters import SigmaPointFilter
from mmlib.core.rules import FifthDegreeCubature, _frozen
from mmlib.experiment import evaluation, metrics, report, run_grid
from mmlib.experiment.universe import UniverseResult
from mmlib.papers import REGISTRY
from mmlib.core.models import RangeBearing
from mmlib.papers.zhu2016 import diagnostics, study, text, timing
from mmlib.papers.zhu2016.setup import Setup, batch, build, setup, simulator

PAPER = REGISTRY["zhu2016"]


@pytest.fixture(scope="module")
def results():
    mc = MonteCarlo(PAPER.root_seed, 6)
    make_batch, estimators = batch(Setup(n_steps=60), mc)
    return evaluation.evaluate(estimators, make_batch, mc, progress=False)


@pytest.mark.parametrize("name", ["IMM5CKF", "IMMCKF", "IMMUKF"])
def test_imm_sigma_point_filters_coincide_with_imm_kf(results, name):
    """Linear models + rules exact to degree >= 2 => the Kalman moments (see the notebook)."""
    ref = results["IMM-KF"]
    # positions ~1e4 m: 1e-7 m is ~1e-11 relative, round-off scale over 60 steps
    np.testing.assert_allclose(results[name].errors, ref.errors, rtol=0, atol=1e-7)
    np.testing.assert_allclose(results[name].mode_probabilities, ref.mode_probabilities, rtol=0, atol=1e-9)


@pytest.mark.parametrize("ukf", [(1.0, 2.0, 0.0), (0.3, 2.0, 0.0), (1.0, 0.0, 3.0 - 4)])
def test_ukf_parameters_do_not_matter_here(ukf):
    mc = MonteCarlo(1, 3)
    make_batch, est = batch(Setup(n_steps=30, ukf=ukf), mc)
    res = evaluation.evaluate({k: est[k] for k in ("IMMUKF", "IMM-KF")}, make_batch, mc, progress=False)
    np.testing.assert_allclose(res["IMMUKF"].errors, res["IMM-KF"].errors, rtol=0, atol=1e-6)


def test_single_model_is_worse_in_turns(results):
    imm = metrics.rmse_time_averaged(results["IMM5CKF"].errors[..., 0])
    single = metrics.rmse_time_averaged(results["5CKF"].errors[..., 0])
    assert single.value > imm.value


def test_setup_validation():
    with pytest.raises(ValueError, match="initial_estimate"):
        Setup(initial_estimate="perfect")
    with pytest.raises(ValueError, match="single_model"):
        Setup(single_model="CA")


def test_table1_paper_values_are_complete():
    assert set(text.TABLE1) == set(text.ALGORITHMS)
    assert all(len(v) == 5 for v in text.TABLE1.values())
    ids = [d.id for d in PAPER.deviations]
    assert len(ids) == len(set(ids))


# --- the reading space (issue 10) ------------------------------------------------------------------------------
def _non_headline_readings():
    return [(f.id, o, PAPER.space.with_headline(**{f.id: o})) for f in PAPER.space.factors for o in f.names
            if o != f.headline]


def test_headline_universe_through_a_process_pool_equals_the_notebook_path(tmp_path):
    """run_grid with 2 spawned workers gives the same bits as the in-process path the notebook uses."""
    n, seed = 4, PAPER.root_seed
    other = PAPER.space.with_headline(**{"Z-5": "equal", "Z-10": "CT-left"})
    grid = run_grid(PAPER.universe, [PAPER.headline, other], paper=PAPER.name, algorithms=PAPER.algorithms,
                    n_runs=n, seed=seed, workers=2, cache_dir=tmp_path, use_cache=False, progress=False)
    for reading, got in zip([PAPER.headline, other], grid):
        local = study.summarise(study.evaluate_reading(reading, MonteCarlo(seed, n)), n, setup(reading))
        assert got == local          # exact equality of every float


def test_headline_universe_values_are_the_headline_table1_rows():
    n = 3
    results = study.evaluate_reading(PAPER.headline, MonteCarlo(PAPER.root_seed, n))
    u = PAPER.universe(PAPER.headline, n, PAPER.root_seed)
    rows = [r for r in study.table1_rows(results) if r.replicated is not None]
    vals = [v for v in u.values if v.item == "Table 1"]
    assert [(v.algorithm, v.quantity, v.replicated, v.stderr) for v in vals] == \
        [(r.algorithm, r.quantity, r.replicated, r.stderr) for r in rows]
    assert [c.claim for c in u.claims] == [c["claim"] for c in study.judge_claims(results, Setup())]


def _draws(reading, n=3):
    s = setup(reading)
    mc = MonteCarlo(PAPER.root_seed, n)
    make_batch, _ = batch(s, mc)
    truth, z, init = make_batch(range(n))
    meas = build(s)[1]
    v = meas.residual(z, meas.h(truth[:, 1:])) / np.sqrt(np.array(s.r))     # standardized measurement noise
    return truth, z, v, init["5CKF"].mean


@pytest.mark.parametrize("fid,option,reading", _non_headline_readings(), ids=lambda x: x if isinstance(x, str) else "")
def test_common_random_numbers_across_readings(fid, option, reading):
    """Every universe uses the same per-run draws: a factor that leaves the random structure alone changes
    neither the truth nor the measurements; the others change only what they claim to."""
    t0, z0, v0, m0 = _draws(PAPER.headline)
    t1, z1, v1, m1 = _draws(reading)
    # standardized measurement noise is the same draw in every universe (to round-off of scaling back and forth:
    # a bearing of ~0.8 rad over a standard deviation of 5.5e-3 rad is ~1e-16 / 5.5e-3 ~ 2e-14 standardized)
    np.testing.assert_allclose(v1, v0, rtol=0, atol=1e-9)
    if fid in ("Z-8", "Z-10", "Z-6", "Z-9", "Z-5"):
        np.testing.assert_array_equal(t1, t0)                 # same truth, bit for bit
    if fid in ("Z-8", "Z-10", "Z-6", "Z-9"):
        np.testing.assert_array_equal(z1, z0)
    if fid != "Z-9":
        np.testing.assert_array_equal(m1, m0)                 # same initial estimates
    else:
        np.testing.assert_array_equal(m1, np.tile(Setup().x0, (3, 1)))
    if fid in ("Z-7", "Z-12"):
        assert not np.array_equal(t1, t0)


@pytest.mark.parametrize("fid,option,reading", _non_headline_readings(), ids=lambda x: x if isinstance(x, str) else "")
def test_every_option_changes_the_setup_it_claims_to(fid, option, reading):
    s, head = setup(reading), setup(PAPER.headline)
    changes = PAPER.space.factor(fid).option(option).changes
    assert changes
    for field, value in changes.items():
        assert getattr(s, field) == value and getattr(head, field) != value
    assert {f for f in s.__dataclass_fields__ if getattr(s, f) != getattr(head, f)} == set(changes)
    # ... and the change reaches the simulation or the estimators
    r0 = study.evaluate_reading(PAPER.headline, MonteCarlo(PAPER.root_seed, 2))
    r1 = study.evaluate_reading(reading, MonteCarlo(PAPER.root_seed, 2))
    target = "5CKF" if fid == "Z-10" else "IMMCKF"
    assert not np.array_equal(r1[target].errors, r0[target].errors)


def test_headline_options_are_the_setup_defaults():
    assert PAPER.headline_setup() == Setup() and PAPER.setup_type is Setup
    assert PAPER.space.design("auto").kind == "full" and PAPER.space.size == 384


@pytest.mark.parametrize("reading,match", [
    ({**PAPER.headline, "Z-99": "x"}, "Z-99"),
    ({**PAPER.headline, "Z-5": "diag(1, 1)"}, "diag\\(1, 1\\)"),
    ({k: v for k, v in PAPER.headline.items() if k != "Z-7"}, "Z-7"),
])
def test_bad_reading_names_the_factor_or_option(reading, match):
    with pytest.raises(ValueError, match=match):
        PAPER.setup(reading)
    with pytest.raises(ValueError, match=match):
        PAPER.universe(reading, 2, PAPER.root_seed)


def test_mode_order_validation_and_effect():
    with pytest.raises(ValueError, match="mode_order"):
        Setup(mode_order="right")
    a = build(Setup())[0]
    b = build(Setup(mode_order="left-right"))[0]
    # the same physical manoeuvres, with models 2 and 3 swapped
    np.testing.assert_array_equal(np.choose(a.modes(), [0, 2, 1]), b.modes())
    np.testing.assert_array_equal(a.models[1].F, b.models[2].F)


def _position_sensor(reading) -> bool:
    return setup(reading).sensor == "position"


@pytest.mark.parametrize("reading", [r for r in PAPER.space.design("star").readings if _position_sensor(r)],
                         ids=lambda r: PAPER.space.describe(r))
def test_sigma_point_imms_coincide_with_imm_kf_in_every_star_universe(reading):
    """The identity holds in every reading with the position sensor: they keep the models linear."""
    res = study.evaluate_reading(reading, MonteCarlo(PAPER.root_seed, 3))
    for name in ("IMM5CKF", "IMMCKF", "IMMUKF"):
        # positions ~1e4 m: 1e-7 m is ~1e-11 relative, round-off over 100 steps
        np.testing.assert_allclose(res[name].errors, res["IMM-KF"].errors, rtol=0, atol=1e-7)
        np.testing.assert_allclose(res[name].mode_probabilities, res["IMM-KF"].mode_probabilities, rtol=0, atol=1e-9)


def _claim(claims, text_):
    return next(c for c in claims.as_list() if c["claim"] == text_)


def test_coinciding_algorithms_give_identical_parts_and_unsupported_claims(results):
    """IMM5CKF, IMMCKF and IMMUKF are IMM-KF here (package docstring): every part of their accuracy and switching
    comparisons is *identical (to round-off)*, so those claims are *not supported* with the identity as the decisive
    number, while the single-model 5CKF differs by a detected amount (its parts are not identical).  The round-off
    of the estimates (~1e-11 relative, test above) is far below the floor ROUNDOFF_OPS x eps ~ 1.5e-8 of the MSE."""
    claims = study.judge_claims(results, Setup(n_steps=60))
    for other in ("IMMCKF", "IMMUKF"):
        c = _claim(claims, f"IMM5CKF is more accurate than {other}")
        assert c["verdict"] == report.NOT_SUPPORTED
        assert [(p["comparison"], p["quantity"], p["unit"]) for p in c["parts"]] == \
            [(f"IMM5CKF − {other}", "position MSE", "m²"), (f"IMM5CKF − {other}", "velocity MSE", "m²/s²")]
        assert all(p["verdict"] == report.PartVerdict.IDENTICAL for p in c["parts"])
        assert c["decisive"].startswith(f"IMM5CKF − {other}: position MSE identical to round-off")
    switch = _claim(claims, "IMM5CKF switches modes more quickly than IMMCKF/IMMUKF")
    assert switch["verdict"] == report.NOT_SUPPORTED
    assert {p["verdict"] for p in switch["parts"]} == {report.PartVerdict.IDENTICAL}
    single = _claim(claims, "IMM5CKF is more accurate than 5CKF")
    assert not any(p["verdict"] == report.PartVerdict.IDENTICAL for p in single["parts"])
    assert single["decisive"] and single["decisive"].startswith("IMM5CKF − 5CKF: ")
    # one verdict word each, one decisive text, no nested verdict strings
    for c in claims.as_list():
        assert c["verdict"] in report.CLAIM_VERDICTS and c["decisive"]
        assert report.CLAIM_VERDICTS.count(c["verdict"]) == 1 and " — " not in c["decisive"]
    assert _claim(claims, "IMM5CKF is more accurate than OMTM-IMM")["parts"] == []


def test_a_difference_beyond_round_off_is_no_longer_identical(results):
    """Scaling IMMCKF's errors by 1 + 1e-6 makes its MSE larger by 2e-6 of itself, above the round-off floor
    (1.5e-8 of it), on every run: the parts are then detected (IMM5CKF better, but negligibly, < 1 %), no longer
    identical -- the identity verdict comes from the numbers, not from the names."""
    perturbed = dict(results, IMMCKF=results["IMMCKF"]._replace(errors=results["IMMCKF"].errors * (1 + 1e-6)))
    c = _claim(study.judge_claims(perturbed, Setup(n_steps=60)), "IMM5CKF is more accurate than IMMCKF")
    assert [p["verdict"] for p in c["parts"]] == [report.PartVerdict.HOLDS_NEGLIGIBLE] * 2
    assert c["verdict"] == report.NOT_SUPPORTED and "identical" not in c["decisive"]


def test_floor_claim_parts_follow_the_floor_check(results):
    """The floor claim's parts are the margins printed - floor with the verdict rule's sigma: part z = -floor z."""
    fl = study.floor_check(results)
    parts = study.floor_parts(fl)
    assert [p.comparison for p in parts] == ["Table 1 smallest IMM − clairvoyant KF"] * 4
    assert [p.unit for p in parts] == ["m", "m/s", "m", "m/s"]
    for f, p in zip(fl, parts):
        assert p.z() == pytest.approx(-f["z"], rel=1e-12)
        assert p.reference == f["floor"] and p.difference == f["margin"]
        # "above the floor" is the claimed sign: a printed value below the floor contradicts it
        if p.verdict in (report.PartVerdict.HOLDS, report.PartVerdict.HOLDS_NEGLIGIBLE):
            assert f["margin"] > 0 and -f["z"] >= report.SIGMA_FACTOR
        if p.verdict in (report.PartVerdict.CONTRADICTED, report.PartVerdict.CONTRADICTED_NEGLIGIBLE):
            assert f["margin"] < 0 and f["z"] >= report.SIGMA_FACTOR
    assert any(p.verdict == report.PartVerdict.CONTRADICTED for p in parts)   # the printed velocities lie below it


def test_published_numbers_are_table1_rmse_cells_and_universe_values():
    assert len(PAPER.published) == 16
    for p in PAPER.published:
        qi = [q for q, _ in text.QUANTITIES].index(p.quantity)
        assert p.printed == text.TABLE1[p.algorithm][qi]
    u = PAPER.universe(PAPER.headline, 2, PAPER.root_seed)
    assert isinstance(u, UniverseResult)
    assert {p.key for p in PAPER.published} <= {v.key for v in u.values}
    # Table 1: (2.6675^2 + 2.5255^2) - (2.4847^2 + 2.8534^2)
    assert u.effect(PAPER.key_effect).published == pytest.approx(-0.82191915, abs=1e-8)
    for c in u.claims:
        report.claim_category(c.verdict)


def test_floor_claim_is_not_assessable_where_the_floor_is_no_bound():
    for fid, opt in (("Z-7", "clean"), ("Z-9", "true")):
        u = PAPER.universe(PAPER.space.with_headline(**{fid: opt}), 3, PAPER.root_seed)
        assert report.claim_category(u.claim(study.FLOOR_CLAIM)) == "not assessable"
        assert next(c for c in u.claims if c.claim == study.FLOOR_CLAIM).decisive == study.FLOOR_NOT_BOUND
    u = PAPER.universe(PAPER.headline, 3, PAPER.root_seed)
    assert report.claim_category(u.claim(study.FLOOR_CLAIM)) != "not assessable"


@dataclass(frozen=True)
class _PrintedWeights(FifthDegreeCubature):
    """Eq. 13 as printed: w2 = 2/(n+2)^2 (deviation Z-1)."""

    @lru_cache(maxsize=None)
    def unit_points(self, n):
        u = FifthDegreeCubature().unit_points(n)
        w = u.wm.copy()
        w[1 + 2 * n:] *= 2.0
        return _frozen(u.xi, w)


def test_printed_fifth_degree_weight_is_not_a_runnable_reading():
    """Z-1: the printed weights sum to 5/3 (not 1), and a 5CKF using them diverges at once in every run."""
    w = _PrintedWeights().unit_points(4).wm
    assert w.sum() == pytest.approx(5 / 3, rel=1e-12)
    assert FifthDegreeCubature().unit_points(4).wm.sum() == pytest.approx(1.0, rel=1e-12)
    s = Setup()
    sched, meas, _ = build(s)
    est = SingleModel(SigmaPointFilter(_PrintedWeights()), sched.models[0], meas, name="printed")
    mc = MonteCarlo(PAPER.root_seed, 5)
    make_batch = evaluation.make_batches(mc, sched, meas, np.array(s.x0), {"printed": est},
                                         lambda e, m0, runs: e.init(m0, np.diag(s.P0_diag)))
    res = evaluation.evaluate({"printed": est}, make_batch, mc, progress=False)
    assert (res["printed"].diverged_step >= 0).all() and res["printed"].diverged_step.max() <= 2


# --- run time (Z-15) ---------------------------------------------------------------------------------------------
def _timing_inputs(n=3):
    mc = MonteCarlo(PAPER.root_seed, n)
    make_batch, est = batch(Setup(n_steps=10), mc)
    truth, z, init = make_batch(range(n))
    return {a: est[a] for a in ("IMMCKF", "5CKF")}, init, z


def test_time_algorithms_shapes_fastest_run_and_gc_restored(monkeypatch):
    """The bookkeeping of time_algorithms on a scripted clock (a timed assertion would flip with machine load):
    each (start, stop) pair of thread_time calls is given a known duration, so the per-repeat value must be the
    fastest of that repeat's one-at-a-time runs of that estimator, and the batched value the call's time per run."""
    import gc
    import itertools
    ests, init, z = _timing_inputs()
    names, repeats, per_repeat, n = list(ests), 3, 2, z.shape[0]
    durations = iter(itertools.count(1))                       # the k-th timed call lasts k seconds
    clock = {"t": 0.0, "open": False}

    def fake_thread_time():
        if clock["open"]:
            clock["t"] += next(durations)
        clock["open"] = not clock["open"]
        return clock["t"]

    monkeypatch.setattr(evaluation.time, "thread_time", fake_thread_time)
    assert gc.isenabled()
    per_run, batched = evaluation.time_algorithms(ests, init, z, repeats=repeats, per_repeat=per_repeat)
    assert gc.isenabled()                                      # the collector is paused only while timing
    # the expected values from the documented call order: per repeat, runs b in turn, the estimators rotated
    k, single, batch = itertools.count(1), {a: [] for a in names}, {a: [] for a in names}
    for r in range(repeats):
        order = names[r % len(names):] + names[:r % len(names)]
        times = {a: [] for a in names}
        for _b in range(per_repeat):
            for a in order:
                times[a].append(next(k))
        for a in order:
            batch[a].append(next(k) / n)
        for a in names:
            single[a].append(min(times[a]))
    for a in names:
        assert per_run[a].shape == (repeats,) and batched[a].shape == (repeats,)
        np.testing.assert_array_equal(per_run[a], single[a])
        np.testing.assert_array_equal(batched[a], batch[a])
    with pytest.raises(ValueError, match="per_repeat"):
        evaluation.time_algorithms(ests, init, z, repeats=3, per_repeat=4)
    with pytest.raises(ValueError, match="repeats"):
        evaluation.time_algorithms(ests, init, z, repeats=1)


def _fake_times(ratio5, spread, n=30):
    rng = np.random.default_rng(0)
    base = 0.02 * (1 + 0.01 * rng.standard_normal(n))
    per_run = {"IMMCKF": base, "IMM5CKF": base * (ratio5 + spread * rng.standard_normal(n)),
               "IMMUKF": base * 1.01, "5CKF": base * 0.55}
    return per_run, {k: v / 7 for k, v in per_run.items()}


@pytest.mark.parametrize("ratio5,spread", [(1.05, 0.01), (1.0, 0.01), (0.9, 0.01), (1.05, 0.5)])
def test_timing_claim_and_rows_follow_the_cost_model_not_the_clock(ratio5, spread):
    """Whatever the measured times (faster, equal, slower, noisy), the claim and the rows are the cost model's:
    IMM5CKF/IMMCKF flops per step, deterministic, so the verdict cannot flip between identical runs; the measured
    ratios are context (their median and range over the repeats in the note)."""
    from mmlib.core.cost import step_flops
    per_run, batched = _fake_times(ratio5, spread)
    estimators = build(Setup())[2]
    claims = report.Claims()
    rows, table = timing.judge_timing(estimators, per_run, batched, claims)
    c = claims.as_list()[0]
    model = step_flops(estimators["IMM5CKF"])["total"] / step_flops(estimators["IMMCKF"])["total"]
    assert model > 1.1                                   # 33 points against 8: far beyond the +-10 % margin
    assert c["claim"] == timing.TIMING_CLAIM and report.claim_category(c["verdict"]) == "holds"
    assert c["decisive"].startswith(f"IMM5CKF/IMMCKF: {timing.QUANTITY} {model:.3g}×")
    assert "paper 2.06×" in c["decisive"] and c["parts"][0]["kind"] == "ratio" and c["parts"][0]["stderr"] is None
    r = per_run["IMM5CKF"] / per_run["IMMCKF"]
    assert f"{np.median(r):.2f}× [{r.min():.2f}, {r.max():.2f}]" in c["evidence"]
    row = [x for x in rows if x.algorithm == "IMM5CKF"][0]
    assert row.replicated == pytest.approx(model, rel=1e-15) and row.stderr == 0.0 and row.distance is None
    # a deterministic value: an exact row, equal or not to the printed precision (never a z-score)
    assert row.verdict == report.exact_row("Table 1", "IMM5CKF", "q", row.paper, row.replicated).verdict
    assert row.paper == f"{14.9726 / 7.2549:.3f}"
    assert [x.algorithm for x in rows] == ["IMM5CKF", "IMMCKF", "IMMUKF", "5CKF", "OMTM-IMM"]
    assert [x.verdict.split(":")[0] for x in rows if x.algorithm in ("IMMCKF", "OMTM-IMM")] == ["not replicable"] * 2
    assert [t[0] for t in table] == ["IMM5CKF", "IMMCKF", "IMMUKF", "5CKF"]


def test_timing_claim_is_contradicted_or_equivalent_by_the_model():
    """The claim can fail: with the CKF timed under both names the model ratio is 1 (no detectable difference),
    with the roles swapped it is contradicted."""
    per_run, batched = _fake_times(1.05, 0.01)
    est = build(Setup())[2]
    for swap, expected in (({"IMM5CKF": est["IMMCKF"]}, "not supported"),
                           ({"IMM5CKF": est["IMMCKF"], "IMMCKF": est["IMM5CKF"]}, "contradicted")):
        claims = report.Claims()
        timing.judge_timing({**est, **swap}, per_run, batched, claims)
        assert report.claim_category(claims.as_list()[0]["verdict"]) == expected


def test_paper_contract_fields():
    """The registry's Paper: the headline scenario, the batch's estimators and the profiles of the notebook."""
    s = PAPER.scenario(PAPER.headline_setup())
    assert (s.name, s.root_seed, s.source) == (PAPER.name, PAPER.root_seed, PAPER.citation)
    assert len(s.modes) == 3 and s.position == (0, 2)
    _, estimators = PAPER.batch(Setup(n_steps=5), MonteCarlo(PAPER.root_seed, 2))
    assert set(PAPER.algorithms) == set(estimators)
    assert PAPER.runs("full") == PAPER.n_runs == 100 and PAPER.runs("smoke") == 20
    assert PAPER.key_effect == study.KEY_EFFECT and PAPER.deviation("Z-15").topic == "run time"


# --- Z-5's range-bearing readings, the degenerate flag and the consistency section (issue 24) ----------------------
_RB = [o.name for o in PAPER.space.factor("Z-5").options if "range-bearing" in o.label]


def test_range_bearing_readings_are_declared_with_both_bearing_units():
    """Z-5 declares the range-bearing sensor with the bearing variance 0.1 in rad² and in deg², each quoting the
    text and neither motivated by the results; "equal" is motivated by Table 1 and so reported apart; every factor
    is a reading (none an unstated tuning sweep)."""
    f = PAPER.space.factor("Z-5")
    assert _RB == ["rb-rad", "rb-deg"] and f.headline == "printed"
    bearing = {o: setup(PAPER.space.with_headline(**{"Z-5": o})).r for o in _RB}
    assert bearing["rb-rad"] == (20.0, 0.1)
    assert bearing["rb-deg"][0] == 20.0 and bearing["rb-deg"][1] == pytest.approx(0.1 * (np.pi / 180) ** 2, rel=1e-15)
    for o in _RB:
        assert not f.option(o).motivated_by and "r = diag([20, 0.1])" in f.option(o).source
    assert f.option("equal").motivated_by.startswith("results: Table 1")
    assert PAPER.space.motivated(PAPER.space.with_headline(**{"Z-5": "equal"})) == ["Z-5"]
    assert all(PAPER.space.is_reading(PAPER.space.with_headline(**{"Z-5": o})) for o in ["printed"] + _RB)
    assert {x.kind for x in PAPER.space.factors} == {"reading"} and PAPER.space.sensitivity_ids == ()


@pytest.mark.parametrize("option", _RB)
def test_range_bearing_reading_builds_a_nonlinear_setup_whose_filters_use_it(option):
    """The simulated sensor and every estimator's measurement model are one range-bearing radar at the origin with
    R = diag(r) (m², rad²), its bearing an angle (residuals wrapped), and the floor is no bound there."""
    s = setup(PAPER.space.with_headline(**{"Z-5": option}))
    _, meas, estimators = build(s)
    assert isinstance(meas, RangeBearing) and not meas.is_linear and meas.angular == (False, True)
    np.testing.assert_array_equal(meas.R, np.diag(s.r))
    np.testing.assert_array_equal(meas.sensor, [0.0, 0.0])
    assert meas.position_index == (0, 2)
    assert all(e.measurement is meas for e in estimators.values())
    # the wrapped residual: bearings either side of the -pi/pi cut differ by a small angle
    np.testing.assert_allclose(meas.residual(np.array([1.0, np.pi - 0.01]), np.array([1.0, -np.pi + 0.01])),
                               [0.0, -0.02], atol=1e-12)
    assert not study.floor_is_bound(s)
    with pytest.raises(ValueError, match="setup"):
        diagnostics.cv_steady_state_sd(s)


@pytest.mark.parametrize("option", _RB)
def test_ukf_and_ckf_differ_under_the_range_bearing_sensor(option):
    """Under the nonlinear sensor the rules are no longer the Kalman moments: IMMUKF and IMMCKF (and IMM5CKF) differ
    far beyond the round-off of the linear identity (1e-7 m, test above), and the accuracy claims are judged on
    differences, never *identical (to round-off)*."""
    reading = PAPER.space.with_headline(**{"Z-5": option})
    res = study.evaluate_reading(reading, MonteCarlo(PAPER.root_seed, 4))
    pos = (slice(None), slice(None), [0, 2])
    # bearing s.d. 0.32 rad or 5.5 mrad at ranges of km: the rules' moments differ by far more than 1e-3 m
    assert np.abs(res["IMMUKF"].errors[pos] - res["IMMCKF"].errors[pos]).max() > 1e-3
    assert np.abs(res["IMM5CKF"].errors[pos] - res["IMMCKF"].errors[pos]).max() > 1e-3
    claims = study.judge_claims(res, setup(reading))
    for other in ("IMMCKF", "IMMUKF"):
        c = _claim(claims, f"IMM5CKF is more accurate than {other}")
        assert not any(p["verdict"] == report.PartVerdict.IDENTICAL for p in c["parts"])
    assert report.claim_category(_claim(claims, study.FLOOR_CLAIM)["verdict"]) == "not assessable"


def test_consistency_entries_cover_every_algorithm():
    """The results file's consistency section: one entry per estimator of the headline with the ANEES (4 dof) and the
    ANIS (2 dof), each with a band; without recorded NEES/NIS it is a ValueError, not a silent gap."""
    n = 4
    res = study.evaluate_reading(PAPER.headline, MonteCarlo(PAPER.root_seed, n), consistency=True)
    entries = diagnostics.consistency(res)
    assert [e["algorithm"] for e in entries] == list(text.MV_ALGORITHMS) == list(PAPER.algorithms)
    for e in entries:
        assert e["anees"]["dof"] == 4.0 and e["anis"]["dof"] == 2.0 and e["anees"]["n_runs"] == n
        for stat in (e["anees"], e["anis"]):
            assert np.isfinite(stat["value"]) and stat["band"][0] < stat["band"][1]
            assert stat["inside"] == (stat["band"][0] <= stat["value"] <= stat["band"][1])
        np.testing.assert_allclose(diagnostics.nees_over_time(res[e["algorithm"]]).mean(), e["anees"]["value"],
                                   rtol=1e-12)
    # recording the NEES/NIS changes no estimate (the digest of the headline is the same)
    plain = study.evaluate_reading(PAPER.headline, MonteCarlo(PAPER.root_seed, n))
    for a in plain:
        np.testing.assert_array_equal(plain[a].errors, res[a].errors)
    with pytest.raises(ValueError, match="NEES"):
        diagnostics.consistency(plain)


def test_measurement_only_baseline_is_the_sensor_noise():
    """The no-information baseline: under the position sensor its mean square is tr(R) = 20.1 m² (one chi-square draw
    per run and step: variance 2 (20² + 0.1²) = 800 m⁴, 20 x 100 independent draws, s.e. 0.63 m²); under the
    range-bearing sensor with the bearing in deg², sigma_r² + rho² sigma_theta² to first order (the second-order term
    rho² sigma_theta⁴ / 2 is ~1e-5 of it), within 5 standard errors of the same kind."""
    n = 20
    mc = MonteCarlo(PAPER.root_seed, n)
    b = float(study.measurement_only_rmse(Setup(), mc).value)
    assert abs(b ** 2 - 20.1) <= 5 * np.sqrt(800 / (n * 100))
    s = setup(PAPER.space.with_headline(**{"Z-5": "rb-deg"}))
    sched, meas, _ = build(s)
    truth = simulator(s, sched, meas)(mc)(range(n))[0][:, 1:]
    rho2 = truth[..., 0] ** 2 + truth[..., 2] ** 2
    per_draw = s.r[0] + rho2 * s.r[1]                       # expected squared error of each draw (m²)
    se = np.sqrt(np.mean(2 * per_draw ** 2) / per_draw.size)  # chi-square-like draws, 2 sigma^4 each
    assert abs(float(study.measurement_only_rmse(s, mc).value) ** 2 - per_draw.mean()) <= 5 * se


def test_degenerate_flag_is_false_at_the_headline_and_set_when_no_algorithm_beats_the_baseline():
    """At the headline the IMMs beat the measured position (sqrt(20.1) ~ 4.5 m), so the universe is not degenerate;
    against a baseline below every algorithm's error the same results are flagged, naming the baseline."""
    n = 6
    u = PAPER.universe(PAPER.headline, n, PAPER.root_seed)
    assert u.degenerate == "" and "degenerate" not in u.as_json()
    mc = MonteCarlo(PAPER.root_seed, n)
    res = study.evaluate_reading(PAPER.headline, mc)
    base = study.measurement_only_rmse(Setup(), mc)
    rmse = {a: study.position_rmse(res[a].errors, res[a].valid) for a in text.RMSE_ALGORITHMS}
    assert min(rmse.values()) < float(base.value) and study.degenerate(res, base) == ""
    reason = study.degenerate(res, 0.5 * min(rmse.values()))
    assert reason and study.BASELINE in reason
    # the boundary (the claim rule): a baseline equal to the best error, or above it by less than the negligible
    # 1 % or 3 standard errors, is degenerate; one well above it is not
    best = min(rmse.values())
    assert study.degenerate(res, best) != "" and study.degenerate(res, best * 1.001) != ""
    assert study.degenerate(res, best * 1.5) == ""
