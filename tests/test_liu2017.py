"""Paper-level facts of Liu & Wu 2017 under its own set-up."""
import numpy as np
import pytest

from mmlib import MonteCarlo
from mmlib.core.filters import ExtendedKalmanFilter
from mmlib.core.layers.strong_tracking import StrongTracking
from mmlib.experiment import evaluation, metrics, views
from mmlib.experiment.universe import UniverseResult
from mmlib.papers import REGISTRY
from mmlib.papers.liu2017 import diagnostics, setup, study, table2, text
from mmlib.papers.liu2017.claims import judge_claims

PAPER = REGISTRY["liu2017"]
EXAMPLE1 = setup.BASE_SETUPS.example1


@pytest.fixture(scope="module")
def example1():
    mc = MonteCarlo(PAPER.root_seed, 8)
    make_batch, est, _ = setup.make_batch_fn(EXAMPLE1, mc, names=text.FILTERS)
    return evaluation.evaluate(est, make_batch, mc, progress=False)


def test_third_degree_st_filters_nearly_coincide(example1):
    """The rules differ only in 4th-order terms of h, ~(sigma/r)^2 <= 1e-2 at these ranges:
    position ARMSE within 1 % of each other."""
    armse = {a: metrics.armse(example1[a].errors[..., [0, 3]]).value for a in ("STUKF", "STCKF", "STSSRCKF")}
    assert max(armse.values()) - min(armse.values()) <= 0.01 * armse["STSSRCKF"]


def test_strong_tracking_beats_plain_filter_after_the_jump(example1):
    after = {a: metrics.armse(example1[a].errors[:, 150:, [0, 3]]).value for a in ("SSRCKF", "STSSRCKF")}
    assert after["STSSRCKF"] < 0.5 * after["SSRCKF"]


def test_truth_follows_the_printed_time_line():
    mc = MonteCarlo(1, 1)
    make_batch, _, _ = setup.make_batch_fn(EXAMPLE1, mc, names=("SSRCKF",))
    truth, _, _ = make_batch(range(1))
    np.testing.assert_array_equal(truth[0, :150][:, [2, 5]], 0.0)          # no acceleration before t = 150 s (L-8)
    np.testing.assert_array_equal(truth[0, 150:, 2], 15.0)
    np.testing.assert_array_equal(truth[0, 150:, 5], 25.0)
    assert truth[0, 100, 0] == pytest.approx(100.0 + 15.0 * 100)           # uniform motion


def test_setup_validation():
    with pytest.raises(ValueError, match="maneuver_start"):
        setup.Setup(maneuver_start=250.0)
    with pytest.raises(ValueError, match="q_sd"):
        setup.Setup(q_sd=0.0)
    with pytest.raises(ValueError, match="initial_estimate"):
        setup.Setup(initial_estimate="perfect")


# -- reading space and multiverse ---------------------------------------------------------------------------------
import json  # noqa: E402

from mmlib.experiment import report  # noqa: E402
from mmlib.experiment import run_grid  # noqa: E402
from mmlib.experiment.multiverse import Multiverse  # noqa: E402
from mmlib.experiment.readings import Design  # noqa: E402

N_SMALL = 4


def test_headline_universe_from_a_two_process_grid_equals_the_notebook_path(tmp_path):
    """The notebook's headline (evaluate_reading + summarise + table_rows + judge_claims, in process)
    and the multiverse's headline universe (spawned worker, JSON round trip) agree bit for bit."""
    head = PAPER.headline
    other = PAPER.space.with_headline(**{"L-4": "0"})
    grid = run_grid(PAPER.universe, [head, other], paper=PAPER.name, algorithms=PAPER.algorithms,
                    n_runs=N_SMALL, seed=PAPER.root_seed, workers=2, cache_dir=tmp_path, use_cache=False,
                    progress=False, result_type=UniverseResult)
    results = study.evaluate_reading(head, MonteCarlo(PAPER.root_seed, N_SMALL))
    local = study.summarise(results, N_SMALL)
    assert isinstance(local, UniverseResult) and grid[0] == local
    rows = study.table_rows(grid[0])
    assert [(r.item, r.algorithm, r.quantity, r.replicated, r.stderr) for r in rows] == \
        [(v.item, v.algorithm, v.quantity, v.replicated, v.stderr) for v in local.values]
    assert [c["verdict"] for c in judge_claims(results)] == [c.verdict for c in grid[0].claims]
    assert grid[1].values != grid[0].values                 # kappa changes STUKF's numbers ...
    stukf = [i for i, v in enumerate(grid[0].values) if v.algorithm == "STUKF"]
    assert all(grid[1].values[i] == grid[0].values[i]       # ... and nothing else
               for i in range(len(grid[0].values)) if i not in stukf)


def _claim_parts(c):
    return [report.Part(**{k: v for k, v in p.items() if k != "number"}) for p in c["parts"]]


def test_every_claim_has_one_verdict_one_decisive_number_and_its_parts():
    """Each claim: one word of the claim vocabulary, one decisive number (one of its parts', or the reason), and the
    flat list of parts it was judged from once (report.judge); the conclusion's 48 parts are one verdict whose decisive
    number is one part, not a list of counts; the claim x comparison matrix has one column per comparison and
    quantity, shared between claims that test the same part."""
    from mmlib.experiment.notebook import claim_matrix
    results = study.evaluate_reading(PAPER.headline, MonteCarlo(PAPER.root_seed, N_SMALL))
    claims = judge_claims(results).as_list()
    for c in claims:
        assert c["verdict"] in report.CLAIM_VERDICTS and c["decisive"], c
        if c["parts"]:
            j = report.judge(_claim_parts(c))
            assert (j.verdict, j.decisive) == (c["verdict"], c["decisive"]), c["claim"]
            assert any(p["number"] in c["decisive"] for p in c["parts"]), c["claim"]
        else:
            assert c["verdict"] == report.NOT_ASSESSABLE and "no measure" in c["decisive"]
    by = {c["claim"]: c for c in claims}
    conclusion = by["STSSRCKF achieves higher accuracy and robustness than STF, STUKF, STCKF and SSRCKF (conclusions)"]
    n_div = sum(p["quantity"].endswith("share of runs diverged") for p in conclusion["parts"])
    assert len(conclusion["parts"]) == 48 + n_div
    assert "of 48 parts" not in conclusion["decisive"] and "more" not in conclusion["decisive"]
    assert {p["comparison"] for p in conclusion["parts"]} == {f"STSSRCKF − {o}" for o in ("STF", "STUKF", "STCKF",
                                                                                          "SSRCKF")}
    units = {p["quantity"].split()[-2]: p["unit"] for p in conclusion["parts"] if p["quantity"].endswith(" MSE")}
    assert units == {"position": "m²", "velocity": "(m/s)²", "acceleration": "(m/s²)²"}
    assert all(p["reference"] and p["reference"] > 0 for p in conclusion["parts"] if p["quantity"].endswith("MSE"))
    # the Table 1 claim tests parts of the conclusion: the same column of the matrix
    table1 = by["STSSRCKF is more accurate than SSRCKF (Example 1, Table 1)"]
    assert [p["quantity"] for p in table1["parts"]] == ["Example 1 position MSE", "Example 1 velocity MSE",
                                                        "Example 1 acceleration MSE"]
    shared = {(p["comparison"], p["quantity"]) for p in table1["parts"]}
    assert shared <= {(p["comparison"], p["quantity"]) for p in conclusion["parts"]}
    header = claim_matrix(claims).splitlines()[0]
    columns = {f"{p['comparison']}: {p['quantity']}" for c in claims for p in c["parts"]}
    assert header.count("|") == len(columns) + 3 and header.count("STSSRCKF − SSRCKF: Example 1 position MSE |") == 1


def test_accuracy_parts_call_estimators_equal_in_exact_arithmetic_identical(example1):
    """A filter against a copy of itself whose errors differ by one ulp is "identical (to round-off)"; a 1e-6
    relative change is a detected (negligible) difference, not an identity."""
    from mmlib.papers.liu2017 import claims as liu_claims
    rs = example1["STSSRCKF"]
    runs = {"A": rs, "ULP": rs._replace(errors=rs.errors * (1 + 2.0 ** -52)),
            "FAR": rs._replace(errors=rs.errors * (1 + 1e-6))}
    same = liu_claims.accuracy_part(runs, "ULP", "A", "Example 1", "Position", (0, 3))
    assert same.verdict == report.PartVerdict.IDENTICAL and "identical to round-off" in same.number()
    assert (same.comparison, same.quantity, same.unit) == ("ULP − A", "Example 1 position MSE", "m²")
    far = liu_claims.accuracy_part(runs, "FAR", "A", "Example 1", "Position", (0, 3))
    assert far.verdict == report.PartVerdict.CONTRADICTED_NEGLIGIBLE and "z = " in far.number()


def _batches(reading, names=("STSSRCKF",)):
    mc = MonteCarlo(PAPER.root_seed, 3)
    out = {}
    for case, s in PAPER.setup(reading).items():
        make_batch, _, _ = setup.make_batch_fn(s, mc, names=names)
        truth, z, init = make_batch(range(3))
        out[case] = (truth, z, init["STSSRCKF"].mean, s)
    return out


def _noise(truth, z, s):
    from mmlib.core import models
    radar = models.range_bearing(np.diag([s.sigma_r ** 2, s.sigma_theta ** 2]), state_dim=6)
    return z - radar.h(truth[:, 1:])


@pytest.mark.parametrize("factor,option", [("L-2", "10"), ("L-4", "n-3"), ("L-6", "sampled"), ("L-1", "100s"),
                                           ("L-8", "t0+1"), ("L-3", "matched")])
def test_universes_share_common_random_numbers(factor, option):
    """Readings that leave the random structure alone see identical truth and measurements; readings that move
    the truth (onset, truth noise) still see identical measurement-noise draws."""
    base = _batches(PAPER.headline)
    alt = _batches(PAPER.space.with_headline(**{factor: option}))
    for case in text.CASES:
        (t0, z0, m0, s0), (t1, z1, m1, s1) = base[case], alt[case]
        if factor in ("L-2", "L-4", "L-6"):
            np.testing.assert_array_equal(t0, t1)
            np.testing.assert_array_equal(z0, z1)
        else:
            np.testing.assert_allclose(_noise(t0, z0, s0), _noise(t1, z1, s1), rtol=0, atol=1e-9)
        if factor != "L-6":
            np.testing.assert_array_equal(m0, m1)


def test_every_option_changes_the_setups_it_claims():
    head = PAPER.headline_setup()
    for f in PAPER.space.factors:
        for o in f.options:
            sets = PAPER.setup(PAPER.space.with_headline(**{f.id: o.name}))
            for case, s in sets.items():
                for key, value in o.changes.items():
                    assert getattr(s, key) == value, (f.id, o.name, case, key)
            if o.name != f.headline:
                assert any(sets[c] != head[c] for c in text.CASES), (f.id, o.name)
    onset = {o: {c: s.onset for c, s in PAPER.setup(PAPER.space.with_headline(**{"L-1": o})).items()}
             for o in ("150s", "100s")}
    assert onset["150s"] == {"Example 1": 150.0, "Case 1": 150.0, "Case 2": 150.0}
    assert onset["100s"] == {"Example 1": 100.0, "Case 1": 150.0, "Case 2": 150.0}    # L-1: Example 1 only
    late = PAPER.setup(PAPER.space.with_headline(**{"L-1": "100s", "L-8": "t0+1"}))
    assert [late[c].onset for c in text.CASES] == [101.0, 151.0, 151.0]
    ex2_only = PAPER.setup(PAPER.space.with_headline(**{"L-6": "sampled-ex2"}))
    assert [ex2_only[c].samples_initial_estimate for c in text.CASES] == [False, True, True]
    stukf = setup.build(PAPER.setup(PAPER.space.with_headline(**{"L-4": "n-3"})).example1)[2]["STUKF"]
    assert stukf.filter.base.rule.kappa == 3.0


def test_onset_step_moves_the_truth_by_one_step():
    mc = MonteCarlo(1, 1)
    for step, first in ((0, 150), (1, 151)):
        make_batch, _, _ = setup.make_batch_fn(setup.Setup(onset_step=step), mc, names=("SSRCKF",))
        truth, _, _ = make_batch(range(1))
        assert truth[0, first - 1, 2] == 0.0 and truth[0, first, 2] == 15.0


def _without(fid):
    return {k: v for k, v in PAPER.headline.items() if k != fid}


@pytest.mark.parametrize("reading,word", [({**PAPER.headline, "L-99": "x"}, "unknown factor 'L-99'"),
                                          ({**PAPER.headline, "L-2": "3"}, "'L-2' has no option '3'"),
                                          (_without("L-6"), r"leaves out factor\(s\) \['L-6'\]")])
def test_bad_reading_raises_naming_the_factor_or_option(reading, word):
    with pytest.raises(ValueError, match=word):
        PAPER.setup(reading)
    with pytest.raises(ValueError, match=word):
        PAPER.universe(reading, 2, 1)


@pytest.mark.parametrize("kwargs,arg", [(dict(timeline="abstract"), "timeline"), (dict(onset_step=2), "onset_step"),
                                        (dict(onset_step=True), "onset_step"),
                                        (dict(discussion_onset=300.0), "discussion_onset"),
                                        (dict(initial_estimate="sampled-ex2"), "initial_estimate"),
                                        (dict(printed_initial_estimate=1), "printed_initial_estimate"),
                                        (dict(truth_process_noise="yes"), "truth_process_noise"),
                                        (dict(ukf=(0.0, 0.0, -3.0)), "ukf"),
                                        (dict(maneuver_start=199.5, onset_step=1), "onset_step")])
def test_new_setup_fields_are_validated(kwargs, arg):
    with pytest.raises(ValueError, match=arg):
        setup.Setup(**kwargs)


def test_timing_claim_and_rows_follow_the_cost_model_not_the_clock():
    """Measured times that say STSSRCKF is faster, or equal, do not move the verdict: the claim and the time rows are
    the cost model's flop ratios (deterministic, stderr None); the measured ratios are context."""
    from mmlib.core.cost import step_flops
    rng = np.random.default_rng(0)
    base = 0.01 + 1e-4 * rng.standard_normal(5)
    estimators = setup.build(setup.Setup())[2]
    flops = {a: step_flops(estimators[a])["total"] for a in text.FILTERS}
    for factor in (0.5, 1.0, 2.0):
        per_run = {a: base * (factor if a == "STSSRCKF" else 1.0) for a in text.FILTERS}
        rows, claim, display = table2.table2(estimators, per_run, per_run)
        assert report.claim_category(claim[1].verdict) == report.HOLDS
        assert claim[1].decisive.startswith("STSSRCKF/SSRCKF: model flops per step")
        assert "paper 2.14×" in claim[1].decisive
        assert f"{factor:.2f}× [" in claim[2]
        ratio_rows = [r for r in rows if "time ratio" in r.quantity]
        assert [r.algorithm for r in ratio_rows] == [a for a in text.FILTERS if a != "SSRCKF"]
        for r in ratio_rows:
            assert r.stderr == 0.0 and r.replicated == pytest.approx(flops[r.algorithm] / flops["SSRCKF"], rel=1e-15)
            assert report.verdict_category(r.verdict) in (report.REPRODUCED_EXACT, report.NOT_REPRODUCED_EXACT)
        assert len(display) == len(text.FILTERS) and len(display[0]) == 13
    # the claim can fail: SSRCKF timed under both names is equivalent within the margin
    same = {**estimators, "STSSRCKF": estimators["SSRCKF"]}
    _, claim, _ = table2.table2(same, per_run, per_run)
    assert report.claim_category(claim[1].verdict) == report.NOT_SUPPORTED


def test_findings_state_the_onset_reading_from_the_data():
    """On two universes (headline, onset at 100 s) the prose names the reading that reproduces Table 1's
    position column only if the numbers say so."""
    readings = (PAPER.headline, PAPER.space.with_headline(**{"L-1": "100s"}))
    universes = [UniverseResult.from_json(json.loads(json.dumps(PAPER.universe(r, 6, PAPER.root_seed).as_json())))
                 for r in readings]
    mv = Multiverse(PAPER.space, Design("star", "test", readings), universes, PAPER.published, 6, PAPER.n_runs)
    prose = diagnostics.findings(mv)
    pos = [p for p in PAPER.published if p.table == "Table 1" and p.quantity.startswith("Position")]
    reproduced = [all(mv.number_verdict(p, u) == report.REPRODUCED for p in pos) for u in universes]
    assert ("consistent with the maneuver starting at t = 100 s" in prose) == (reproduced == [False, True])
    assert ("its velocity column is" in prose) == any(reproduced)      # the other columns are always reported
    assert "Claims." in prose and "robust" in prose


# -- Table 2's complexity rows are judged from the counts -------------------------------------------------------
def test_printed_complexity_orders_are_read_from_the_text():
    assert table2.printed_complexity_orders("O((2n+2)^3)") == (3, 3)
    assert table2.printed_complexity_orders("O(n^2)") == (0, 2)
    assert table2.printed_complexity_orders("O((2n+1) n^2)") == (1, 3)
    with pytest.raises(ValueError, match="complexity"):
        table2.printed_complexity_orders("cubic")


def test_complexity_rows_follow_the_counts_not_a_constant():
    """As printed (cube of the points; O(n^2) for the EKF-based STF) every row is not reproduced; a complexity
    linear in the points and cubic in n, which the counts give, would be reproduced; and counts whose evaluations
    grew with the cube of the points would make the printed column reproduced."""
    rows = table2.complexity_rows()
    assert [r.algorithm for r in rows] == list(text.FILTERS)
    assert all(report.verdict_category(r.verdict) == report.NOT_REPRODUCED_EXACT for r in rows)
    assert "slope 1.00" in rows[-1].note and "order 3 in n" in rows[1].note
    linear = {a: ("O(n^3)" if a == "STF" else t.replace("^3", " n^2")) for a, t in text.TABLE2_COMPLEXITY.items()}
    assert all(r.verdict == report.REPRODUCED_EXACT for r in table2.complexity_rows(printed=linear))
    cubic = {a: (p, c, p ** 3, 2 * p ** 3, k) if p else (p, c, f, h, k)
             for a, (p, c, f, h, k) in text.TABLE2_COUNTS.items()}
    verdicts = {r.algorithm: r.verdict for r in table2.complexity_rows(counts=cubic)}
    assert all(verdicts[a] == report.REPRODUCED_EXACT for a in text.FILTERS if a != "STF")
    assert report.verdict_category(verdicts["STF"]) == report.NOT_REPRODUCED_EXACT     # O(n^2) vs F P F^T


# -- findings: most cells any reading reproduces vs the forensic best match -------------------------------------
def _synthetic_universe(template, table1_offsets):
    """A copy of ``template`` whose Table 1 cells sit ``table1_offsets[algorithm, quantity]`` combined standard
    errors from the printed value (stderr 0.1 at 200 runs)."""
    u = json.loads(json.dumps(template.as_json()))
    u["n_runs"] = PAPER.n_runs
    for v in u["values"]:
        if v["item"] != "Table 1":
            continue
        qi = [q for q, _ in text.QUANTITIES].index(v["quantity"])
        printed = text.TABLE1[v["algorithm"]][qi]
        sigma = 1.0 / report.standardized_distance(printed, float(printed) + 1.0, 0.1, 200, 200)
        v["replicated"], v["stderr"] = float(printed) + table1_offsets(v["algorithm"], v["quantity"]) * sigma, 0.1
    return UniverseResult.from_json(u)


def test_findings_separate_most_reproduced_from_best_match():
    readings = (PAPER.headline, PAPER.space.with_headline(**{"L-1": "100s"}),
                PAPER.space.with_headline(**{"L-4": "0"}))
    template = PAPER.universe(readings[0], 4, PAPER.root_seed)
    # the best match ranks by root-mean-square relative distance; "reproduced" needs the joint test of the table
    first = (text.FILTERS[0], text.QUANTITIES[1][0])                                 # SSRCKF velocity
    # 14 cells reproduced, Σz² 12.25 (passes χ²_15); RMS relative distance 3.5 x 0.15 / 31.2 / √15 = 0.0043
    many = _synthetic_universe(template, lambda a, q: 3.5 if (a, q) == first else 0.0)
    # the five positions (≈ 120-150 m) 5 s.e. off: Σz² 125 fails the joint test, so no cell counts as reproduced,
    # yet the RMS relative distance is smaller (5 x 0.15 / 125 x √(5/15) = 0.0035): the forensic best match
    close = _synthetic_universe(template, lambda a, q: 5.0 if q == text.QUANTITIES[0][0] else 0.0)
    mv = Multiverse(PAPER.space, Design("star", "test", readings), [template, many, close], PAPER.published,
                    PAPER.n_runs, PAPER.n_runs)
    t1 = [t for t in mv.table_match() if t["table"] == "Table 1"][0]
    assert (t1["most_universe"], t1["most_n_reproduced"], t1["best_universe"], t1["best_n_reproduced"]) == (1, 14, 2, 0)
    prose = diagnostics.findings(mv)
    assert "the most cells any one reading reproduces is 14 of 15" in prose
    assert f"is *{mv.space.describe(readings[2])}*" in prose and "reproducing 0 cells" in prose
    assert "No declared reading reproduces a whole table." in prose
    # universe 1 reproduces the position and acceleration columns, but not SSRCKF's velocity: said, from the data
    assert "its velocity column is reproduced in 4 of 5 cells only" in prose
    assert "its acceleration column is reproduced:" in prose
    assert "not a reproduction of Table 1 as a whole" in prose


# -- the contract: one set-up object holding Example 1 and Example 2's two cases ---------------------------------
def test_setup_holds_the_three_simulations_and_the_headline_case_is_example_1():
    examples = PAPER.headline_setup()
    assert isinstance(examples, PAPER.setup_type) and isinstance(examples, setup.Examples)
    assert [c for c, _ in examples.items()] == list(text.CASES)
    assert examples["Example 1"] is examples.example1 and examples["Case 2"] is examples.case2
    assert examples.example1 == EXAMPLE1 and examples.case1.maneuver_acceleration == (5.0, 5.0)
    with pytest.raises(KeyError, match="Case 3"):
        examples["Case 3"]
    with pytest.raises(ValueError, match="case1"):
        setup.Examples(EXAMPLE1, {"x0": 1}, EXAMPLE1)
    scenario = PAPER.scenario(examples)
    assert (scenario.name, scenario.n_steps, scenario.root_seed) == (PAPER.name, EXAMPLE1.n_steps, PAPER.root_seed)
    make_batch, estimators = PAPER.batch(examples, MonteCarlo(PAPER.root_seed, 2))
    assert set(PAPER.algorithms) <= set(estimators)
    truth, _, _ = make_batch(range(2))
    assert truth.shape[:2] == (2, EXAMPLE1.n_steps + 1)
    for call in (PAPER.scenario, lambda s: PAPER.batch(s, MonteCarlo(1, 2))):
        with pytest.raises(ValueError, match="setup"):
            call(EXAMPLE1)


def test_strong_tracking_layers_carry_the_setups_beta_and_rho():
    """The four ST filters are the core layer with Example 1's softening and forgetting factors (what the arena's
    recipes build from the headline set-up's fields); over the EKF its Jacobian form (STF)."""
    filters = {n: e.filter for n, e in setup.build(EXAMPLE1)[2].items()}
    for name in ("STF", "STUKF", "STCKF", "STSSRCKF"):
        layer = filters[name]
        assert isinstance(layer, StrongTracking)
        assert (layer.beta, layer.rho) == (EXAMPLE1.beta, EXAMPLE1.rho) == (4.5, 0.95)
    assert isinstance(filters["STF"].base, ExtendedKalmanFilter)


# ------------------------------------------------------------------- kinds of factor, consistency, degenerate flag
def test_only_the_filters_process_noise_is_a_sensitivity_factor_and_no_option_is_motivated():
    """L-2 sweeps sqrt(q) over four decades (Q_ca is never stated): a tuning sweep, not a reading; every other
    factor's options quote the text -- L-1's 100 s onset is the paper's own discussion, a reading, not an option
    motivated by the results it gives -- and none is motivated by the results or another paper."""
    space = PAPER.space
    assert space.sensitivity_ids == ("L-2",)
    assert all(f.kind == "reading" for f in space.factors if f.id != "L-2")
    assert not any(o.motivated_by for f in space.factors for o in f.options)
    assert space.is_reading(space.with_headline(**{"L-1": "100s"}))
    assert not space.is_reading(space.with_headline(**{"L-2": "1"}))
    assert space.factor("L-2").as_dict()["kind"] == "sensitivity"


@pytest.fixture(scope="module")
def headline_consistency():
    return study.evaluate_reading(PAPER.headline, MonteCarlo(PAPER.root_seed, N_SMALL), consistency=True)


def test_consistency_entries_cover_every_filter_of_every_case(headline_consistency):
    """One entry per case and filter run there, both statistics with their bands (6 and 2 degrees of freedom);
    SSRCKF, tuned for the non-maneuvering regime, is far over-confident through Example 1's 15-25 m/s^2 maneuver."""
    entries = diagnostics.consistency(headline_consistency)
    assert [(e["case"], e["algorithm"]) for e in entries] == \
        [(case, alg) for case in text.CASES for alg in text.CASE_FILTERS[case]]
    for e in entries:
        for stat, dof in (("anees", 6.0), ("anis", 2.0)):
            c = e[stat]
            assert c["dof"] == dof and c["n_runs"] == N_SMALL and c["value"] is not None
            assert c["band"][0] < dof < c["band"][1] and c["inside"] == (c["band"][0] <= c["value"] <= c["band"][1])
    ssr = next(e for e in entries if e["case"] == "Example 1" and e["algorithm"] == "SSRCKF")
    assert ssr["anees"]["value"] > 10 * ssr["anees"]["band"][1]
    table = views.consistency_table(entries)           # the one renderer (mmlib.experiment.views)
    assert all(case in table for case in text.CASES)
    plain = study.evaluate_reading(PAPER.headline, MonteCarlo(PAPER.root_seed, 2))
    with pytest.raises(ValueError, match="SSRCKF"):
        diagnostics.consistency(plain)


def test_the_consistency_run_leaves_the_digest_unchanged(headline_consistency):
    from mmlib.experiment import digests
    plain = study.evaluate_reading(PAPER.headline, MonteCarlo(PAPER.root_seed, N_SMALL))
    assert digests.run_digest(plain.runs, N_SMALL)["sha256"] == \
        digests.run_digest(headline_consistency.runs, N_SMALL)["sha256"]


def test_measurement_only_estimate_inverts_the_radar():
    """Noise-free measurements invert to the true positions (round-off of values up to ~30 km)."""
    mc = MonteCarlo(PAPER.root_seed, 3)
    make_batch, _, _ = setup.make_batch_fn(EXAMPLE1, mc, names=("SSRCKF",))
    truth, _, _ = make_batch(range(3))
    radar = setup.build(EXAMPLE1)[1]
    exact = study.measurement_only_errors(radar, truth, radar.h(truth[:, 1:]))
    assert np.abs(exact).max() < 1e-12 * np.abs(truth[..., [0, 3]]).max()


def test_degenerate_when_any_case_is(headline_consistency):
    """The rule: a universe is degenerate when any case its claims use is (its claims pool the cases); the reason
    names the degenerate cases only."""
    res = headline_consistency
    assert study.degenerate_cases(res) == {case: "" for case in text.CASES} and study.degenerate(res) == ""
    assert study.summarise(res, N_SMALL).degenerate == ""

    def sharp(cases):                     # measurements a thousand times more precise in ``cases``
        return res._replace(measurement_only={c: e / 1000 if c in cases else e
                                              for c, e in res.measurement_only.items()})
    one = sharp(text.CASES[:1])
    why = study.degenerate(one)
    assert study.degenerate_cases(one)[text.CASES[0]] and why.startswith(text.CASES[0])
    assert not any(case in why for case in text.CASES[1:])
    every = sharp(text.CASES)
    assert all(case in study.degenerate(every) for case in text.CASES)
    assert study.summarise(one, N_SMALL).degenerate == why
    with pytest.raises(ValueError, match="results"):
        study.degenerate(res._replace(measurement_only=None))
