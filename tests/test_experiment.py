"""The experiment layer: reading spaces and designs, the grid runner and its cache, the multiverse
summaries, and the claim vocabulary."""
import concurrent.futures as cf
import dataclasses
import itertools
import json
import math
import time

import numpy as np
import pytest

import experiment_jobs as toy
from mmlib.experiment import report
from mmlib.experiment import Factor, Option, ReadingSpace, UniverseResult, grid, machine, run_grid, run_multiverse
from mmlib.experiment.multiverse import Multiverse, from_dict
from mmlib.experiment.universe import JSON_KEYS, JudgedClaim, Effect, Value


def _opt(name, **changes):
    return Option(name, f"option {name}", "Sec. 1", changes)


def _space(levels, influential=None, budget=None):
    influential = influential or [True] * len(levels)
    return ReadingSpace("s", tuple(
        Factor(f"F{i}", f"factor {i}", tuple(_opt(f"o{j}", **{f"p{i}": j}) for j in range(n)), "o0", "Sec. 2",
               influential=infl) for i, (n, infl) in enumerate(zip(levels, influential))), budget=budget)


# -- designs ---------------------------------------------------------------------------------------------------
def test_full_factorial_is_every_reading_once_headline_first():
    space = _space([2, 3, 4])
    d = space.design()
    assert d.kind == "full" and len(d) == space.size == 24
    assert d.readings[0] == space.headline
    assert len({tuple(r.values()) for r in d.readings}) == 24


def test_star_design_varies_each_option_alone():
    space = _space([2, 3, 4])
    star = space.star()
    assert len(star) == 1 + 1 + 2 + 3 and star[0] == space.headline
    for r in star[1:]:
        assert len(space.differs(r)) == 1
    for f in space.factors:
        assert {r[f.id] for r in star} == set(f.names)


@pytest.mark.parametrize("levels,influential", [([3, 3, 3, 3], None),
                                                ([2, 4, 3, 2, 5], [True, True, False, True, True]),
                                                ([6, 2, 2, 2, 2, 2, 3], None)])
def test_fractional_design_covers_every_option_and_influential_pair(levels, influential):
    space = _space(levels, influential, budget=1)
    d = space.design("fractional")
    assert d.kind == "fractional" and d.readings[0] == space.headline and d.sample == () and d.seed is None
    assert len(d) < space.size
    rows = [tuple(r.values()) for r in d.readings]
    assert len(set(rows)) == len(rows)
    for i, f in enumerate(space.factors):
        assert {r[i] for r in rows} == set(f.names)
    infl = [i for i, f in enumerate(space.factors) if f.influential]
    for a, b in itertools.combinations(infl, 2):
        pairs = {(r[a], r[b]) for r in rows}
        assert pairs == set(itertools.product(space.factors[a].names, space.factors[b].names))
    assert set(map(tuple, (r.values() for r in space.star()))) <= set(rows)      # the smoke subset is inside


def test_fractional_design_is_deterministic():
    a, b = _space([3, 3, 2, 4], budget=5), _space([3, 3, 2, 4], budget=5)
    assert a.design("fractional").readings == b.design("fractional").readings


def test_auto_design_uses_the_budget():
    assert _space([2, 2], budget=4).design().kind == "full"
    d = _space([2, 2, 2], budget=4).design()
    assert d.kind == "sampled" and len(d.sample) == 4 and d.seed is not None
    # the override of the sample size: more universes, or the full factorial once it fits
    assert len(_space([2, 2, 2], budget=4).design(sample_size=6).sample) == 6
    assert _space([2, 2, 2], budget=4).design(sample_size=8).kind == "full"


# -- readings: bad input ---------------------------------------------------------------------------------------
def test_reading_errors_name_the_factor_or_option():
    space = _space([2, 2])
    with pytest.raises(ValueError, match="unknown factor 'F9'"):
        space.validate({"F0": "o0", "F1": "o0", "F9": "o0"})
    with pytest.raises(ValueError, match="factor 'F1' has no option 'o7'"):
        space.validate({"F0": "o0", "F1": "o7"})
    with pytest.raises(ValueError, match=r"leaves out factor\(s\) \['F1'\]"):
        space.validate({"F0": "o0"})
    with pytest.raises(ValueError, match="reading"):
        space.validate(["F0"])
    with pytest.raises(ValueError, match="kind"):
        space.design("random")


def test_declaration_errors():
    with pytest.raises(ValueError, match="headline"):
        Factor("F", "f", (_opt("a"), _opt("b")), "c", "Sec. 1")
    with pytest.raises(ValueError, match="options"):
        Factor("F", "f", (_opt("a"),), "a", "Sec. 1")
    with pytest.raises(ValueError, match="repeats"):
        Factor("F", "f", (_opt("a"), _opt("a")), "a", "Sec. 1")
    with pytest.raises(ValueError, match="source"):
        Option("a", "label", "", {})
    f = Factor("F", "f", (_opt("a"), _opt("b")), "a", "Sec. 1")
    with pytest.raises(ValueError, match="repeated factor id"):
        ReadingSpace("p", (f, f))
    with pytest.raises(ValueError, match="budget"):
        ReadingSpace("p", (f,), budget=0)


def test_changes_merge_and_conflict():
    space = _space([2, 3])
    assert space.changes(space.with_headline(F1="o2")) == {"p0": 0, "p1": 2}
    clash = ReadingSpace("p", (Factor("A", "a", (_opt("x", q=1), _opt("y", q=2)), "x", "s"),
                               Factor("B", "b", (_opt("x"), _opt("y", q=3)), "x", "s")))
    assert clash.changes({"A": "x", "B": "x"}) == {"q": 1}
    with pytest.raises(ValueError, match="both set 'q'"):
        clash.changes({"A": "x", "B": "y"})


# -- grid runner and cache -------------------------------------------------------------------------------------
def _counting(calls):
    """A stand-in for grid._run_job that records its calls and runs the toy universe here."""
    return lambda *a: calls.append(a) or {"result": toy.toy_universe(*a[1:]), "machine": machine.fingerprint(),
                                          "cpu_s": 0.0}


def _grid(tmp_path, **kw):
    opts = dict(paper="toy", algorithms=["alg"], n_runs=50, seed=7, cache_dir=tmp_path, progress=False)
    opts.update(kw)
    return run_grid(toy.toy_universe, toy.SPACE.full(), **opts)


def test_run_grid_counts_the_computed_and_cached_jobs_and_their_cpu_seconds(tmp_path):
    """``stats`` says how the results were obtained: every job computed the first time, each with the CPU seconds of
    its own thread (a job that spins for SPIN CPU-seconds adds at least that, in this process or in a worker's, and the
    jobs' sum cannot exceed the CPU the whole call used); all read from the cache the second time, with no CPU."""
    n = len(toy.SPACE.full())
    for workers in (1, 2):
        cache = tmp_path / f"w{workers}"
        stats = {}
        wall = time.perf_counter()
        first = run_grid(toy.spinning_universe, toy.SPACE.full(), paper="toy", algorithms=[], n_runs=5, seed=3,
                         cache_dir=cache, progress=False, workers=workers, stats=stats)
        wall = time.perf_counter() - wall
        assert set(stats) == {"computed", "from_cache", "cpu_s"}
        assert (stats["computed"], stats["from_cache"]) == (n, 0)
        assert n * toy.SPIN <= stats["cpu_s"] <= workers * wall, (stats, wall)
        again = {}
        assert run_grid(toy.spinning_universe, toy.SPACE.full(), paper="toy", algorithms=[], n_runs=5, seed=3,
                        cache_dir=cache, progress=False, workers=workers, stats=again) == first
        assert again == {"computed": 0, "from_cache": n, "cpu_s": 0.0}
    with pytest.raises(ValueError, match="^stats: "):
        run_grid(toy.toy_universe, [toy.SPACE.headline], paper="toy", algorithms=[], n_runs=5, seed=3,
                 cache_dir=tmp_path, progress=False, stats=[])


def test_results_independent_of_executor_and_worker_count(tmp_path):
    serial = _grid(tmp_path / "a", workers=1)
    pool = _grid(tmp_path / "b", workers=2)
    with cf.ThreadPoolExecutor(3) as ex:
        threads = _grid(tmp_path / "c", executor=ex)
    assert serial == pool == threads
    assert serial[0] == toy.toy_universe(toy.SPACE.headline, 50, 7)


def test_cache_returns_identical_numbers_without_recomputing(tmp_path, monkeypatch):
    first = _grid(tmp_path, workers=1)
    files = sorted((tmp_path / "toy").glob("*.json"))
    assert len(files) == toy.SPACE.size
    calls = []
    monkeypatch.setattr(grid, "_run_job", _counting(calls))
    again = _grid(tmp_path, workers=1)
    assert again == first and calls == []


@pytest.mark.parametrize("change", [dict(n_runs=51), dict(seed=8), dict(algorithms=["alg", "other"]),
                                    dict(paper="toy2")])
def test_cache_recomputes_when_a_key_part_changes(tmp_path, monkeypatch, change):
    _grid(tmp_path, workers=1)
    calls = []
    monkeypatch.setattr(grid, "_run_job", _counting(calls))
    _grid(tmp_path, workers=1, **change)
    assert len(calls) == toy.SPACE.size


def test_cache_key_covers_reading_job_and_library_source(monkeypatch):
    base = dict(paper="toy", job=toy.toy_universe, reading=toy.SPACE.headline, algorithms=["alg"], n_runs=5, seed=1)
    k = grid.key_document(**base)
    assert grid.key_document(**{**base, "reading": toy.SPACE.with_headline(A="one")}) != k
    assert grid.key_document(**{**base, "job": toy.not_a_dict}) != k
    monkeypatch.setattr(grid, "source_hash", lambda: "0" * 16)
    assert grid.key_document(**base) != k


def test_grid_bad_input(tmp_path):
    with pytest.raises(ValueError, match="n_runs"):
        _grid(tmp_path, n_runs=0)
    with pytest.raises(ValueError, match="workers"):
        _grid(tmp_path, workers=0)
    with pytest.raises(ValueError, match=r"^job: experiment_jobs\.not_a_dict returned list, expected a "
                                         r"UniverseResult"):
        run_grid(toy.not_a_dict, [toy.SPACE.headline], paper="toy", algorithms=[], n_runs=2, seed=1,
                 cache_dir=tmp_path, progress=False, workers=1)


def test_progress_line_per_universe_when_verbose(tmp_path, monkeypatch):
    """Verbose ($MMLIB_PROGRESS_VERBOSE=1): a line per universe with its reading; else the first and the last (the
    toy grid takes well under PROGRESS_INTERVAL), the last counting the universes with diverged runs."""
    monkeypatch.setenv(grid.VERBOSE_ENV, "1")
    lines = []
    _grid(tmp_path, workers=1, progress=lines.append)
    assert len(lines) == toy.SPACE.size and all("universe" in ln for ln in lines)
    assert all('"A": ' in ln for ln in lines)                  # the reading's levels
    assert any("diverged runs" in ln for ln in lines)           # option c2 reports one diverged run
    monkeypatch.delenv(grid.VERBOSE_ENV)
    lines.clear()
    _grid(tmp_path / "quiet", workers=1, progress=lines.append)
    n = toy.SPACE.size
    assert [ln.split("] ", 1)[1].split(",")[0] for ln in lines] == [f"universe 1/{n}", f"universe {n}/{n}"]
    assert f"({n // 2} universe(s) with diverged runs)" in lines[-1] and '"A"' not in "".join(lines)
    lines.clear()
    _grid(tmp_path, workers=1, progress=lines.append)
    assert len(lines) == 1 and "from the cache" in lines[0]


def test_universes_share_common_random_numbers(tmp_path):
    """A factor that leaves the random structure alone (C) changes nothing drawn: same values."""
    res = _grid(tmp_path, workers=1)
    by = {tuple(r.values()): u for r, u in zip(toy.SPACE.full(), res)}
    assert by[("zero", "s1", "c1")].values == by[("zero", "s1", "c2")].values
    # scale multiplies the same draws: the mean of the scale-2 universe is exactly twice
    m1 = by[("zero", "s1", "c1")].values[0].replicated
    m2 = by[("zero", "s2", "c1")].values[0].replicated
    assert m2 == pytest.approx(2 * m1, rel=1e-12, abs=1e-15)


# -- summaries against hand-computed cases ---------------------------------------------------------------------
def _mv(tmp_path, design="full", n_runs=1600):
    return run_multiverse(toy.SPACE, toy.toy_universe, published=toy.PUBLISHED, n_runs=n_runs, seed=3,
                          algorithms=["alg"], design=design, n_runs_paper=6400, cache_dir=tmp_path, progress=False,
                          workers=1)


def _hand_verdict(r, se, printed, p):
    """The verdict rule written out: sigma from ours, the paper's (1600 vs 6400 runs) and half a unit."""
    sig = math.sqrt(se ** 2 * (1 + 1600 / 6400) + (0.5 * 10 ** -(len(printed.split(".")[1]))) ** 2)
    d = (r - p) / sig
    if abs(d) <= 3:
        return d, ("inconclusive" if 3 * sig > 0.25 * abs(p) else "reproduced")
    return d, ("qualitatively reproduced" if abs(r - p) <= 0.25 * abs(p) else "not reproduced")


def _hand_isolated(mv):
    """Per universe, whether Table 1 (its two cells, also its one row) fails the joint test, by hand: with two
    cells, the chi-squared tail of the sum of squares is exp(-S/2), compared with 2 Phi(-3)."""
    alpha = math.erfc(3 / math.sqrt(2))
    out = []
    for u in mv.universes:
        ds = [_hand_verdict(u.values[k].replicated, u.values[k].stderr, p, float(p))[0]
              for k, p in ((0, "1.0"), (1, "2.0"))]
        out.append(math.exp(-(ds[0] ** 2 + ds[1] ** 2) / 2) < alpha)
    return out


def test_numbers_summary_by_hand(tmp_path):
    mv = _mv(tmp_path)
    s = {x["quantity"]: x for x in mv.numbers_summary()}
    failing = _hand_isolated(mv)
    for k, (qty, printed) in enumerate((("mean", "1.0"), ("sd", "2.0"))):
        verdicts, dists = [], []
        for u in mv.universes:
            v = u.values[k]
            d, verdict = _hand_verdict(v.replicated, v.stderr, printed, float(printed))
            dists.append(d)
            verdicts.append(verdict)
        got = s[qty]
        assert [mv.number_verdict(toy.PUBLISHED[k], u).split(":")[0] for u in mv.universes] == verdicts
        rep = [verdicts[i] == "reproduced" and not failing[i] for i in range(12)]
        iso = [verdicts[i] == "reproduced" and failing[i] for i in range(12)]
        assert got["n_reproduced"] == sum(rep) and got["n_isolated"] == sum(iso)
        assert got["n_inconclusive"] == verdicts.count("inconclusive")
        assert got["n_counted"] == 12 and got["weighting"] == "full factorial of 12"
        # the closest: among the universes with s.e. <= 10 % of the printed value, the smallest relative distance
        precise = [j for j, u in enumerate(mv.universes) if u.values[k].stderr <= 0.1 * float(printed)]
        rel = [abs(u.values[k].replicated - float(printed)) / float(printed) for u in mv.universes]
        i = min(precise, key=rel.__getitem__)
        assert got["closest_status"] == "found" and got["n_precise"] == len(precise)
        assert got["closest"]["universe"] == i and got["closest"]["relative_distance"] == pytest.approx(rel[i])
        assert got["closest"]["distance"] == pytest.approx(dists[i])
        assert got["isolated"] is (verdicts[0] == "reproduced" and failing[0])
        assert got["joint_test"]["table"]["dof"] == 2 and got["joint_test"]["table"]["passes"] is (not failing[0])
    assert s["mean"]["headline_verdict"] == "not reproduced"                # headline has no bias
    assert s["mean"]["n_reproduced"] >= 1 and s["mean"]["n_inconclusive"] >= 1   # both branches exercised
    assert sum(s[q]["n_isolated"] for q in ("mean", "sd")) >= 1             # an isolated coincidence exercised
    never = s["never computed"]
    assert never["headline_verdict"] == "not replicable" and never["n_reproduced"] == 0 and never["closest"] is None
    assert never["closest_status"] == "not computed" and never["joint_test"] is None


def test_table_match_by_hand(tmp_path):
    mv = _mv(tmp_path)
    tm = {t["table"]: t for t in mv.table_match()}
    assert set(tm) == {"Table 1"}                       # Table 2 has no replicated cell
    failing = _hand_isolated(mv)
    sums, precise, rms, n_rep, n_iso = [], [], [], [], []
    for i, u in enumerate(mv.universes):
        s, ok, n, r2 = 0.0, True, 0, 0.0
        for k, p in ((0, "1.0"), (1, "2.0")):
            v = u.values[k]
            d, verdict = _hand_verdict(v.replicated, v.stderr, p, float(p))
            s += d * d
            ok &= v.stderr <= 0.1 * float(p)
            n += verdict == "reproduced"
            r2 += ((v.replicated - float(p)) / float(p)) ** 2
        sums.append(s)
        precise.append(ok)
        rms.append(math.sqrt(r2 / 2))
        n_rep.append(0 if failing[i] else n)
        n_iso.append(n if failing[i] else 0)
    best = min((j for j in range(len(sums)) if precise[j]), key=rms.__getitem__)
    t = tm["Table 1"]
    assert t["best_universe"] == best and t["best_rms_relative"] == pytest.approx(rms[best])
    assert t["best_sum"] == pytest.approx(sums[best]) and t["best_joint_test"]["statistic"] == pytest.approx(sums[best])
    assert t["headline_sum"] == pytest.approx(sums[0]) and t["n_excluded_imprecise"] == precise.count(False)
    assert t["headline_rms_relative"] == pytest.approx(rms[0])
    assert t["most_n_reproduced"] == max(n_rep) and t["headline_n_reproduced"] == n_rep[0] and t["isolated"] == n_iso[0]
    assert t["n_passing"] == failing.count(False) and t["n_counted"] == 12
    assert t["joint_test"]["passes"] is (not failing[0]) and t["joint_test"]["dof"] == 2
    assert mv.readings[best]["A"] == "one" and mv.readings[best]["B"] == "s2"   # bias 1, s.d. 2: the printed table


def test_claims_summary_by_hand(tmp_path):
    mv = _mv(tmp_path)
    (c,) = mv.claims_summary()
    cats = [report.claim_category(u.claims[0].verdict) for u in mv.universes]
    assert c["verdict_counts"] == {k: cats.count(k) for k in report.CLAIM_VERDICTS if k in cats}
    assert c["n_universes"] == 12 and c["headline_verdict"] == mv.universes[0].claims[0].verdict
    assert c["robust"] is (max(cats.count(k) for k in set(cats)) >= 0.9 * 12)
    assert c["robust"] is False                        # the mean is positive only under bias 1
    # the full factorial: exact shares, the interval of zero width
    assert c["share"] == {k: cats.count(k) / 12 for k in report.CLAIM_VERDICTS}
    assert c["interval"] == {k: [cats.count(k) / 12] * 2 for k in report.CLAIM_VERDICTS}
    assert c["weighting"] == "full factorial of 12" and c["robustness"] == "depends on the reading"
    # the star (headline and each option alone) is reported apart: A=one, B=s2, B=s3, C=c2
    star = [i for i, r in enumerate(mv.readings) if len(toy.SPACE.differs(r)) == 1]
    assert c["n_star"] == len(star) == 4
    assert c["star_counts"] == {k: [cats[i] for i in star].count(k) for k in report.CLAIM_VERDICTS
                                if k in [cats[i] for i in star]}


def test_robust_threshold_is_ninety_percent(tmp_path):
    mv = _mv(tmp_path)
    u0 = mv.universes[0].claims[0]
    assert report.claim_category(u0.verdict) != "holds"    # the headline has no bias: breaking it changes a verdict
    for k in range(len(mv.universes)):                 # make every universe agree, then break one
        mv.universes[k] = dataclasses.replace(mv.universes[k], claims=(u0,))
    assert mv.claims_summary()[0]["robust"]
    mv.universes[-1] = dataclasses.replace(mv.universes[-1], claims=(u0._replace(verdict="holds"),))
    assert mv.claims_summary()[0]["robust"] is (11 >= 0.9 * 12)
    mv.universes[-2] = dataclasses.replace(mv.universes[-2], claims=(u0._replace(verdict="holds"),))
    assert mv.claims_summary()[0]["robust"] is False   # 10 of 12 < 90 %


@pytest.mark.parametrize("design", ["fractional", "sampled"])
def test_multiverse_json_round_trip(tmp_path, design):
    mv = _mv(tmp_path, design=design)
    doc = json.loads(json.dumps(mv.as_dict(), allow_nan=False))
    assert doc["design_sample"] == list(mv.design.sample) and doc["design_seed"] == mv.design.seed
    for key in ("factors", "design", "n_universes", "universes", "claims_summary", "numbers_summary", "table_match"):
        assert key in doc
    assert doc["design"] == design and doc["n_universes"] == len(doc["universes"])
    assert all({"reading", "values", "claims", "diverged"} <= set(u) for u in doc["universes"])
    assert {f["id"] for f in doc["factors"]} == {"A", "B", "C"}
    back = from_dict(toy.SPACE, doc, toy.PUBLISHED, 6400)
    assert back.as_dict() == doc
    assert back.universes == mv.universes and all(isinstance(u, UniverseResult) for u in back.universes)


# -- the claim vocabulary --------------------------------------------------------------------------------------
def _p(v, z=5.0, ref=None):
    """A part with verdict ``v`` (a PartVerdict) and a difference of ``z`` standard errors."""
    return report.Part("A − B", f"q{z}", v, z, 1.0, ref)


H, C, N, I = (report.PartVerdict.HOLDS, report.PartVerdict.CONTRADICTED, report.PartVerdict.NO_DIFFERENCE,
              report.PartVerdict.IDENTICAL)


@pytest.mark.parametrize("parts,expected", [
    ([H, H], "holds"),
    ([H, N], "partly"),
    ([N, C], "contradicted"),
    ([C, C], "contradicted"),
    ([report.PartVerdict.HOLDS_NEGLIGIBLE, N], "not supported"),
    ([report.PartVerdict.CONTRADICTED_NEGLIGIBLE], "not supported"),
    ([N], "not supported"),
    ([I, I], "not supported"),
    ([H, report.PartVerdict.NOT_COMPARABLE], "not assessable"),
])
def test_judge_combines_parts_by_the_claim_rule(parts, expected):
    j = report.judge([_p(v, z=3.0 + k) for k, v in enumerate(parts)])
    assert j.verdict == expected and isinstance(j.verdict, report.ClaimVerdict) and j.decisive


def test_judge_names_the_decisive_part():
    """holds: the weakest part; contradicted: the strongest contradiction; partly: the count and the most adverse."""
    weak, strong = report.part("A − B", "x MSE", -4.0, 1.0, -1), report.part("A − B", "y MSE", -40.0, 1.0, -1)
    assert report.judge([strong, weak]).decisive == weak.number() + " (weakest of 2)"
    c1, c2 = report.part("A − B", "x MSE", 4.0, 1.0, -1), report.part("A − B", "y MSE", 40.0, 1.0, -1)
    assert report.judge([c1, c2]).decisive == c2.number() + " (2 parts)"
    assert report.judge([weak, c1, c2]).decisive == f"1 of 3 hold; {c2.number()}"
    same = report.part("A − B", "x MSE", 1e-13, 1e-14, -1, reference=100.0, unit="m²")
    j = report.judge([same])
    assert j.verdict == "not supported" and "identical to round-off" in j.decisive and same.z() != same.z()


def test_claims_collector_rejects_verdicts_outside_the_vocabulary():
    c = report.Claims()
    c.add("A beats B", "holds", "evidence", key="a_vs_b")
    with pytest.raises(ValueError, match="claim vocabulary"):
        c.add("C beats D", "depends on the UKF's tuning", key="c_vs_d")
    with pytest.raises(ValueError, match="claim vocabulary"):
        c.add("C beats D", "holds, but negligible (< 1 %)", key="c_vs_d")      # a part verdict, not a claim verdict
    with pytest.raises(ValueError, match="already judged"):
        c.add("A beats B", "holds", key="a_vs_b_again")
    with pytest.raises(ValueError, match="^key: 'a_vs_b' already names the claim 'A beats B'"):
        c.add("A beats B, reworded", "holds", key="a_vs_b")      # one key names one claim
    j = c.add("E beats F", report.judge([report.part("E − F", "MSE", -5.0, 1.0, -1, reference=100.0)]), key="e_vs_f")
    assert c.as_list()[0] == {"key": "a_vs_b", "claim": "A beats B", "verdict": "holds", "decisive": "", "parts": [],
                              "evidence": "evidence"}
    e = c.as_list()[1]
    assert e["verdict"] == "holds" == j.verdict and e["decisive"] == j.decisive and len(e["parts"]) == 1
    assert e["parts"][0]["verdict"] == "holds" and e["parts"][0]["number"] == j.parts[0].number()
    other = report.Claims()
    other.add("G beats H", report.Judgement.of("not assessable", "G is not specified"), key="g_vs_h")
    c.extend(other)
    assert [x["claim"] for x in c] == ["A beats B", "E beats F", "G beats H"]
    assert [x["key"] for x in c] == ["a_vs_b", "e_vs_f", "g_vs_h"]
    with pytest.raises(ValueError, match="already judged"):
        c.extend(other)
    clash = report.Claims()
    clash.add("G beats H, another wording", "holds", key="g_vs_h")
    with pytest.raises(ValueError, match="^other: key 'g_vs_h' already names a claim here"):
        c.extend(clash)


def test_standardized_distance_is_the_verdict_rule():
    z = report.standardized_distance("10.0", 10.3, 0.1, 100, 100)
    sigma = math.sqrt(0.01 + 0.01 + 0.05 ** 2)
    assert z == pytest.approx(0.3 / sigma)
    assert (abs(z) <= 3) == (report.verdict("10.0", 10.3, 0.1, 100, 100) == "reproduced")
    assert report.standardized_distance(2.0, 2.0, 0.0) == 0.0
    assert report.standardized_distance(2.0, 3.0, 0.0) == math.inf


def test_a_failed_value_is_not_reproduced_and_never_the_best_match(tmp_path):
    """A value the method was run for but could not produce (every run diverged) is judged 'not reproduced' with
    its reason, has an infinite distance, and cannot be the best table match; 'not replicable' stays reserved for
    what was never published."""
    mv = _mv(tmp_path)
    failed = UniverseResult.build(values=[("T1", "alg", "mean", None, None, "diverged in 400/400 runs"),
                                          ("T1", "alg", "sd", 2.0, 0.01)],
                                  claims=mv.universes[0].claims, diverged={"alg": 400}, n_runs=400)
    assert failed.values[0].failed == "diverged in 400/400 runs" and failed.values[1].failed is None
    assert "failed" not in failed.as_json()["values"][1]
    mv.universes[1] = failed
    pub = toy.PUBLISHED[0]
    assert mv.number_verdict(pub, failed) == "not reproduced: diverged in 400/400 runs"
    assert mv.distance(pub, failed) == math.inf
    assert mv.table_distances("Table 1")[1] == math.inf
    assert all(t["best_universe"] != 1 for t in mv.table_match())
    never = toy.PUBLISHED[2]
    assert mv.number_verdict(never, failed) == "not replicable"


def test_a_cache_entry_for_another_key_or_not_a_result_is_recomputed(tmp_path, monkeypatch):
    first = _grid(tmp_path, workers=1)
    files = sorted((tmp_path / "toy").glob("*.json"))
    files[0].write_text(json.dumps({"values": 3}))                       # not a cache entry
    entry = json.loads(files[1].read_text())
    entry["key"]["n_runs"] = 999                                          # an entry written for another key
    files[1].write_text(json.dumps(entry))
    files[2].write_text("{truncated")
    calls = []
    monkeypatch.setattr(grid, "_run_job", _counting(calls))
    with pytest.warns(grid.CacheWarning) as caught:
        again = _grid(tmp_path, workers=1)
    assert len(calls) == 3 and again == first
    assert sorted(str(w.message).split()[2] for w in caught) == sorted(str(p) for p in files[:3])


def test_workers_from_the_environment(monkeypatch):
    monkeypatch.setenv("WORKERS", "3")
    assert grid.default_workers() == 3
    for bad in ("two", "0", "-1"):
        monkeypatch.setenv("WORKERS", bad)
        with pytest.raises(ValueError, match="WORKERS"):
            grid.default_workers()


def test_presentation_modules_left_out_of_the_hash_are_not_used_by_any_computation():
    """The cache key ignores the presentation modules, which is safe only while computing a universe never
    touches them: run every paper's job (2 runs) in a fresh interpreter and check they were never imported."""
    import subprocess
    import sys
    code = ("import sys\n"
            "from mmlib.papers import REGISTRY\n"
            "for name in REGISTRY:\n"
            "    paper = REGISTRY[name]\n"
            "    paper.universe(paper.space.headline, 2, 1)\n"
            "print(sorted(n for n in sys.modules if n in ('mmlib.experiment.views', 'mmlib.experiment.notebook')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=True)
    assert out.stdout.strip() == "[]", out.stdout
    assert {rel.split("/")[-1] for rel in grid.PRESENTATION_MODULES} == {"views.py", "notebook.py"}


def test_inconclusive_is_never_reproduced():
    # within 3 sigma, but 3 sigma is wider than 25 % of the printed value
    assert report.verdict("10.0", 12.0, 1.0, 100, 100).startswith("inconclusive")
    assert report.verdict_category(report.verdict("10.0", 12.0, 1.0, 100, 100)) == "inconclusive"
    # precise and close: reproduced; precise and 20 % off: qualitatively reproduced
    assert report.verdict("10.0", 10.1, 0.05, 100, 100) == "reproduced"
    assert report.verdict("10.0", 12.0, 0.05, 100, 100) == "qualitatively reproduced"


def test_closest_and_best_match_skip_inconclusive_universes(tmp_path):
    mv = _mv(tmp_path)
    before = {x["quantity"]: x for x in mv.numbers_summary()}
    tm_before = mv.table_match()[0]
    assert mv.number_verdict(toy.PUBLISHED[0], mv.universes[2]) == "not reproduced"
    head = mv.universes[0]
    mean, sd = head.values[0]._replace(replicated=1.0001, stderr=5.0), head.values[1]._replace(replicated=2.0001,
                                                                                               stderr=5.0)
    noisy = dataclasses.replace(head, values=(mean, sd, *head.values[2:]))   # "matches" only because it is noisy
    was_precise = mv.precise(toy.PUBLISHED[0], mv.universes[2])
    mv.universes[2] = noisy
    pub = toy.PUBLISHED[0]
    assert mv.number_verdict(pub, noisy).startswith("inconclusive") and abs(mv.distance(pub, noisy)) < 1e-3
    s = {x["quantity"]: x for x in mv.numbers_summary()}
    assert s["mean"]["closest"]["universe"] != 2 and not mv.precise(pub, noisy)
    assert s["mean"]["n_inconclusive"] == before["mean"]["n_inconclusive"] + 1
    assert s["mean"]["n_precise"] == before["mean"]["n_precise"] - was_precise
    tm = mv.table_match()[0]
    assert tm["best_universe"] != 2 and tm["n_excluded_inconclusive"] == tm_before["n_excluded_inconclusive"] + 1
    assert tm["n_excluded_imprecise"] == tm_before["n_excluded_imprecise"] + 1
    assert tm["most_n_reproduced"] == 2 and mv.readings[tm["most_universe"]]["A"] == "one"


def _triples(space, readings):
    infl = [f for f in space.factors if f.influential]
    return {(a.id, r[a.id], b.id, r[b.id], c.id, r[c.id]) for r in readings
            for a, b, c in itertools.combinations(infl, 3)}


def test_fractional_design_spends_the_budget_on_three_factor_combinations():
    space = _space([3, 3, 2, 2, 3], budget=20)
    cover = space.covering()
    d = space.design("fractional")
    assert d.kind == "fractional" and len(cover) < len(d) == 20 < space.size
    assert list(d.readings[:len(cover)]) == cover                 # the strength-2 covering comes first
    assert len({tuple(r.values()) for r in d.readings}) == 20
    counts = [len(_triples(space, d.readings[:k])) for k in range(len(cover), 21)]
    assert all(b > a for a, b in zip(counts, counts[1:]))          # every added universe covers new triples
    # with a budget beyond what strength 3 needs, filling stops once every triple is covered
    roomy = _space([2, 2, 2, 2], budget=15)
    full_triples = _triples(roomy, roomy.full())
    dr = roomy.design("fractional")
    assert _triples(roomy, dr.readings) == full_triples and len(dr) < 15
    assert "three-factor" in d.description and "budget of 20" in d.description


def test_metric_only_factor_counts_each_simulation_once(tmp_path):
    mv = run_multiverse(toy.METRIC_SPACE, toy.metric_universe, published=toy.PUBLISHED, n_runs=1600, seed=3,
                        algorithms=["alg"], design="full", n_runs_paper=6400, cache_dir=tmp_path, progress=False,
                        workers=1)
    assert len(mv.universes) == 24 and len(mv.simulations()) == 12
    (c,) = mv.claims_summary()
    # every universe of the full factorial counts once (a simulation as many times as it has metric readings)
    assert c["n_universes"] == 24 and c["n_simulations"] == 12 and sum(c["verdict_counts"].values()) == 24
    (c12,) = _mv(tmp_path / "plain").claims_summary()
    assert c["share"] == c12["share"] and c["verdict_counts"] == {k: 2 * n for k, n in c12["verdict_counts"].items()}
    assert mv.as_dict()["n_simulations"] == 12
    r = toy.METRIC_SPACE.with_headline(M="ml", B="s2")
    assert toy.METRIC_SPACE.simulation_key(r) == toy.METRIC_SPACE.simulation_key({**r, "M": "unbiased"})
    assert toy.METRIC_SPACE.describe_simulation(r) == "B: scale 2"
    # the values may differ between the metric readings of one simulation ...
    ia, ib = mv.simulations()[0]
    a, b = mv.universes[ia], mv.universes[ib]
    assert a.values[1] != b.values[1]
    # ... but a claim that differs is a declaration error
    other = "holds" if a.claims[0].verdict != "holds" else "contradicted"
    mv.universes[ib] = dataclasses.replace(b, claims=(b.claims[0]._replace(verdict=other),))
    with pytest.raises(ValueError, match="metric-only"):
        mv.simulations()


# -- the typed universe result (mmlib.experiment.universe) ---------------------------------------------------------
def _typed():
    """A result with a failed value, an effect whose published value is None, a numpy scalar, NaN and infinity
    (stored as None), -0.0, a subnormal and a claim given as a JudgedClaim."""
    return UniverseResult.build(
        values=[("T1", "alg", "mean", np.float64(0.1) + 0.2, 1e-300),
                ("T1", "alg", "sd", None, None, "diverged in 3/3 runs"),
                ("T2", "alg", "x", -0.0, float("nan"))],
        claims=[{"claim": "A beats B", "verdict": "holds"}, JudgedClaim("B beats C", "contradicted")],
        effects=[("d", 5e-324, 2.0 / 3.0), ("e", -1.5, 0.25, None), ("f", float("inf"), 0.1, 2.5)],
        diverged={"alg": 3}, n_runs=3)


def test_universe_result_json_round_trip_is_bit_for_bit():
    u = _typed()
    for doc in (u.as_json(), json.loads(json.dumps(u.as_json(), allow_nan=False))):      # as the cache stores it
        back = UniverseResult.from_json(doc)
        assert back == u
        assert repr(back) == repr(u)                      # every float to the bit (repr tells -0.0 from 0.0)
        assert math.copysign(1.0, back.values[2].replicated) == -1.0
        assert back.values[1].failed == "diverged in 3/3 runs" and back.values[1].replicated is None
        assert back.effects[1].published is None and back.effects[0].published is None
        assert back.effects[2].value is None and back.values[2].stderr is None      # inf and NaN: None
        assert [type(v) for v in back.values] == [Value] * 3 and [type(e) for e in back.effects] == [Effect] * 3
        assert [type(c) for c in back.claims] == [JudgedClaim] * 2
        assert type(back.values[0].replicated) is float and type(back.n_runs) is int
        assert back.as_json() == doc
    # a universe computed on another machine keeps its fingerprint (not part of ==), and a results file's
    # universe entry (with its reading) reads back
    other = UniverseResult.from_json({**u.as_json(), "machine": {"cpu": "other"}, "reading": {"A": "zero"}})
    assert other == u and other.machine == {"cpu": "other"} and u.machine is None
    assert other.as_json() == {**u.as_json(), "machine": {"cpu": "other"}}
    # the toy job's result, through JSON text
    toy_u = toy.toy_universe(toy.SPACE.headline, 20, 1)
    assert UniverseResult.from_json(json.loads(json.dumps(toy_u.as_json()))) == toy_u


def test_as_json_is_the_dict_universe_result_built():
    """The layout of the untyped dicts that multiverse.universe_result returned (the ``universes`` entries of a
    results file and the cache's results): same keys in the same order, ``failed`` only on a failed value, every
    number a Python float or None."""
    doc = _typed().as_json()
    assert doc == {
        "values": [{"item": "T1", "algorithm": "alg", "quantity": "mean", "replicated": 0.1 + 0.2, "stderr": 1e-300},
                   {"item": "T1", "algorithm": "alg", "quantity": "sd", "replicated": None, "stderr": None,
                    "failed": "diverged in 3/3 runs"},
                   {"item": "T2", "algorithm": "alg", "quantity": "x", "replicated": -0.0, "stderr": None}],
        "claims": [{"claim": "A beats B", "verdict": "holds", "decisive": ""},
                   {"claim": "B beats C", "verdict": "contradicted", "decisive": ""}],
        "effects": [{"name": "d", "value": 5e-324, "stderr": 2.0 / 3.0, "published": None},
                    {"name": "e", "value": -1.5, "stderr": 0.25, "published": None},
                    {"name": "f", "value": None, "stderr": 0.1, "published": 2.5}],
        "diverged": {"alg": 3}, "n_runs": 3}
    assert list(doc) == list(JSON_KEYS) == list(grid.RESULT_KEYS)
    value_keys = ["item", "algorithm", "quantity", "replicated", "stderr"]
    assert [list(v) for v in doc["values"]] == [value_keys, value_keys + ["failed"], value_keys]
    assert all(list(c) == ["claim", "verdict", "decisive"] for c in doc["claims"])
    assert all(list(e) == ["name", "value", "stderr", "published"] for e in doc["effects"])
    assert type(doc["values"][0]["replicated"]) is float and type(doc["diverged"]) is dict
    assert json.loads(json.dumps(doc, allow_nan=False)) == doc
    # a Claims collector: its evidence stays out of the result, as before; its key goes in (and reads back)
    claims = report.Claims()
    claims.add("A beats B", "holds", "a paired difference", key="a_vs_b")
    keyed = UniverseResult.build(values=[], claims=claims, diverged={}, n_runs=1)
    assert keyed.claims[0].key == "a_vs_b" and UniverseResult.from_json(keyed.as_json()) == keyed
    assert keyed.as_json() == {
        "values": [], "claims": [{"claim": "A beats B", "verdict": "holds", "decisive": "", "key": "a_vs_b"}],
        "effects": [],
        "diverged": {},
        "n_runs": 1}


def test_a_universe_result_cannot_be_changed():
    u = _typed()
    for name, value in (("n_runs", 4), ("values", ()), ("claims", ()), ("diverged", {}), ("machine", {})):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(u, name, value)
    with pytest.raises(AttributeError):
        u.values[0].replicated = 1.0
    with pytest.raises(AttributeError):
        u.effects[1].published = 1.0
    with pytest.raises(AttributeError):
        u.claims[0].verdict = "holds"
    with pytest.raises(TypeError):
        u.values[0] = u.values[1]
    with pytest.raises(TypeError):
        u.diverged["alg"] = 0
    # neither the arguments it was built from nor its JSON reach back into it
    diverged = {"alg": 1}
    v = UniverseResult.build(values=[], claims=[], diverged=diverged, n_runs=3)
    diverged["alg"] = 2
    doc = u.as_json()
    doc["values"][0]["replicated"] = 9.0
    doc["diverged"]["alg"] = 0
    assert v.diverged == {"alg": 1} and repr(u) == repr(_typed())


def test_a_universe_result_travels_to_and_from_worker_processes():
    """A job's result comes back from a local worker process by pickle (concurrent.futures), from a Dask worker by
    Dask's serialisation: both give the same result, bit for bit, with its machine."""
    import pickle
    u = _typed()
    other = UniverseResult.from_json({**u.as_json(), "machine": {"cpu": "other"}})
    for x in (u, other):
        back = pickle.loads(pickle.dumps(x))
        assert back == x and repr(back) == repr(x) and back.machine == x.machine
        with pytest.raises(TypeError):
            back.diverged["alg"] = 0                       # still read-only


def test_value_effect_and_claim_lookups():
    u = _typed()
    assert u.value(("T1", "alg", "sd")) == Value("T1", "alg", "sd", None, None, "diverged in 3/3 runs")
    assert u.value(toy.PUBLISHED[0].key) == u.values[0] and u.value(("T9", "alg", "mean")) is None
    for bad in ("T1", ("T1", "alg"), ["T1", "alg", "mean"], None):
        with pytest.raises(ValueError, match=r"^key: expected \(item, algorithm, quantity\)"):
            u.value(bad)
    assert u.effect("e") == Effect("e", -1.5, 0.25, None) and u.effect("d").published is None
    with pytest.raises(ValueError, match=r"^effect: no effect 'g' \(effects: \['d', 'e', 'f'\]\)"):
        u.effect("g")
    assert u.claim("A beats B") == "holds" and u.claim("B beats C") == "contradicted"
    with pytest.raises(ValueError, match=r"^claim: no claim 'C beats D' \(claims: \['A beats B', 'B beats C'\]\)"):
        u.claim("C beats D")


def test_multiverse_lookups_are_the_universe_results(tmp_path):
    mv = _mv(tmp_path, n_runs=50)
    u = mv.universes[3]
    assert all(type(x) is UniverseResult for x in mv.universes) and mv.headline is mv.universes[0]
    assert mv.value(u, toy.PUBLISHED[0].key) == u.value(toy.PUBLISHED[0].key) == u.values[0]
    assert mv.value(u, toy.PUBLISHED[2].key) is None
    assert mv.effect(u, "mean") == u.effect("mean") and mv.effect(u, "mean").published == 1.0
    with pytest.raises(ValueError, match="^effect: no effect 'nope'"):
        mv.effect(u, "nope")
    with pytest.raises(ValueError, match="^universe: expected a UniverseResult"):
        mv.value(u.as_json(), toy.PUBLISHED[0].key)
    with pytest.raises(ValueError, match=r"^universes\[0\]: expected a UniverseResult"):
        Multiverse(mv.space, mv.design, [x.as_json() for x in mv.universes], mv.published, mv.n_runs)


def test_run_grid_refuses_a_job_returning_a_dict_when_it_expects_a_universe_result(tmp_path):
    kw = dict(paper="toy", algorithms=["alg"], n_runs=20, seed=1, cache_dir=tmp_path, progress=False, workers=1)
    with pytest.raises(ValueError, match=r"^job: experiment_jobs\.a_dict returned dict, expected a UniverseResult"):
        run_grid(toy.a_dict, [toy.SPACE.headline], **kw)
    with pytest.raises(ValueError, match=r"^job: experiment_jobs\.a_dict returned dict, expected a UniverseResult"):
        run_grid(toy.a_dict, [toy.SPACE.headline], result_type=UniverseResult, **kw)
    assert not list(tmp_path.rglob("*.json"))                       # nothing refused is cached
    # plain dicts (the arena's cells, result_type=None) are accepted and returned as such, and a UniverseResult
    # is then refused
    (plain,) = run_grid(toy.a_dict, [toy.SPACE.headline], result_type=None, **kw)
    assert type(plain) is dict and plain == toy.toy_universe(toy.SPACE.headline, 20, 1).as_json()
    with pytest.raises(ValueError, match=r"^job: experiment_jobs\.toy_universe returned UniverseResult, expected a "
                                         r"dict"):
        run_grid(toy.toy_universe, [toy.SPACE.headline], result_type=None, **kw)
    # the default: a UniverseResult, computed and then from the cache
    (computed,) = run_grid(toy.toy_universe, [toy.SPACE.headline], **kw)
    (cached,) = run_grid(toy.toy_universe, [toy.SPACE.headline], **kw)
    assert type(computed) is type(cached) is UniverseResult and computed == cached
    assert repr(cached) == repr(toy.toy_universe(toy.SPACE.headline, 20, 1))
