"""Forensics that prove themselves (issue 24): planted-reading recovery on a small synthetic paper whose answer is
known (an identifiable factor, an unidentifiable one), readings kept apart from tuning sweeps and from options
motivated by the results, degenerate universes set apart from the shares, the reconstruction qualifier, and the
no-information baseline.

The synthetic paper: factor A (a reading) moves every cell of its table by tens of standard errors, factor B (a
reading) moves nothing, factor C (a sensitivity sweep) shifts the cells, and option d1 of factor D is motivated by
the results.  So A must be recovered from a planted table, B must be named unidentifiable, and neither a C level
nor d1 may ever be the table's best match, even when the printed table is exactly their values.
"""
import math

import numpy as np
import pytest

from mmlib.experiment import evaluation, forensics, verdicts
from mmlib.experiment.multiverse import Multiverse
from mmlib.experiment.readings import Factor, Option, ReadingSpace
from mmlib.experiment.universe import PublishedNumber, UniverseResult

A = Factor("A", "level", (Option("a0", "a0", "s"), Option("a1", "a1", "s"), Option("a2", "a2", "s")), "a0", "s")
B = Factor("B", "inert", (Option("b0", "b0", "s"), Option("b1", "b1", "s")), "b0", "s")
C = Factor("C", "tuning", (Option("c0", "c0", "s"), Option("c1", "c1", "s"), Option("c2", "c2", "s")), "c0", "s",
           kind="sensitivity")
D = Factor("D", "motivated", (Option("d0", "d0", "s"), Option("d1", "d1", "s", motivated_by="results: Table T")),
           "d0", "s")
SPACE = ReadingSpace("forensic-toy", (A, B, C, D))
CELLS = ("x", "y", "z")
SE = 0.05                       # every value's standard error; the printed numbers have two decimals


def _values(r: dict) -> list:
    """The table of a reading: A moves it by 1.0 per level (20 standard errors), B not at all, C by 0.5 per
    level, d1 by 0.3."""
    a, c = A.names.index(r["A"]), C.names.index(r["C"])
    base = 10.0 + a + 0.5 * c + (0.3 if r["D"] == "d1" else 0.0)
    return [base + 2.0 * j for j in range(len(CELLS))]


def _universe(r: dict, degenerate: str = "") -> UniverseResult:
    vals = _values(r)
    holds = "holds" if r["A"] != "a2" else "contradicted"
    return UniverseResult.build(values=[(c, "F", "rmse", v, SE) for c, v in zip(CELLS, vals)],
                                claims=[{"claim": "F is good", "verdict": holds}], diverged={"F": 0}, n_runs=100,
                                degenerate=degenerate)


def _published(reading: dict) -> tuple:
    return tuple(PublishedNumber("Table T", c, "F", "rmse", f"{v:.2f}") for c, v in zip(CELLS, _values(reading)))


def _multiverse(printed_from: dict | None = None, degenerate=lambda r: "") -> Multiverse:
    design = SPACE.design("full")
    unis = [_universe(r, degenerate(r)) for r in design.readings]
    return Multiverse(SPACE, design, unis, _published(printed_from or SPACE.headline), 100, n_runs_paper=100)


# -- readings, tuning sweeps and motivated options --------------------------------------------------------------
def test_factor_kind_and_motivation_are_declared_and_checked():
    assert C.as_dict()["kind"] == "sensitivity" and A.as_dict()["kind"] == "reading"
    assert D.as_dict()["option_details"][1]["motivated_by"].startswith("results")
    with pytest.raises(ValueError, match="kind"):
        Factor("E", "e", A.options, "a0", "s", kind="tuning")
    with pytest.raises(ValueError, match="headline"):       # the headline is chosen on the text alone
        Factor("E", "e", D.options, "d1", "s")
    r = SPACE.with_headline(C="c1")
    assert not SPACE.is_reading(r) and SPACE.is_reading(SPACE.with_headline(A="a2", B="b1"))
    assert SPACE.motivated(SPACE.with_headline(D="d1")) == ["D"] and SPACE.sensitivity_ids == ("C",)


def test_table_match_searches_readings_only_even_when_a_sweep_matches_exactly():
    for trap in (SPACE.with_headline(C="c2"), SPACE.with_headline(D="d1")):
        mv = _multiverse(printed_from=trap)
        tm = mv.table_match()[0]
        best = mv.readings[tm["best_universe"]]
        assert SPACE.is_reading(best), (trap, best)
        assert tm["n_candidates"] == len(mv.reading_indices()) == 3 * 2       # A x B, C and D at the headline
        for entry in mv.numbers_summary():
            assert SPACE.is_reading(entry["closest"]["reading"])
    # the trap itself is a perfect match: it is the sensitivity curve that shows it, never a reading
    mv = _multiverse(printed_from=SPACE.with_headline(C="c2"))
    curve = mv.sensitivity()
    assert [c["factor"] for c in curve] == ["C"] and [o["option"] for o in curve[0]["options"]] == list(C.names)
    by_opt = {o["option"]: o["tables"]["Table T"] for o in curve[0]["options"]}
    assert by_opt["c2"]["n_reproduced"] == 3 and by_opt["c2"]["rms_relative"] < 1e-3
    assert by_opt["c0"]["n_reproduced"] == 0


def test_motivated_and_degenerate_universes_are_set_apart_from_the_shares():
    mv = _multiverse(degenerate=lambda r: "every filter is worse than the raw measurement" if r["B"] == "b1" else "")
    n_mot = SPACE.size // 2
    assert len(mv.motivated_indices()) == n_mot and len(mv.degenerate_indices()) == SPACE.size // 2
    counted = mv.counted()
    assert len(counted) == SPACE.size // 4                         # d0 and b0
    assert all(mv.readings[i]["D"] == "d0" and mv.readings[i]["B"] == "b0" for i in counted)
    s = mv.claims_summary()[0]
    assert s["n_counted"] == len(counted) and s["n_motivated"] == n_mot and s["n_degenerate"] == SPACE.size // 4
    assert s["share"]["contradicted"] == pytest.approx(1 / 3)   # A = a2 in a third of the counted universes
    assert sum(s["motivated"].values()) == n_mot
    doc = mv.as_dict()
    assert doc["n_degenerate"] == SPACE.size // 2 and doc["n_motivated"] == n_mot
    assert {d["reason"] for d in doc["degenerate"]} == {"every filter is worse than the raw measurement"}
    assert "reported apart" in s["weighting"] and "degenerate set apart" in s["weighting"]
    # the degenerate flag survives the cache boundary and pickling
    u = mv.universes[mv.degenerate_indices()[0]]
    assert UniverseResult.from_json(u.as_json()).degenerate == u.degenerate
    import pickle
    assert pickle.loads(pickle.dumps(u)).degenerate == u.degenerate


# -- planted-reading recovery -------------------------------------------------------------------------------------
def test_recovery_identifies_the_identifiable_factor_and_names_the_unidentifiable_one():
    mv = _multiverse()
    rec = mv.recovery()
    t = rec["tables"][0]
    assert t["n_candidates"] == 6 and t["planted"] == 6                # every candidate planted once
    assert t["by_factor"]["A"] == 1.0                                   # 20 s.e. apart: never confused
    assert t["unidentifiable"] == ["B"] and t["indistinguishable"] == {"B": [["b0", "b1"]]}
    assert "C" not in t["by_factor"]                    # a sensitivity factor is not a reading: never recovered
    assert "A" not in t["unidentifiable"] and rec["unidentifiable"] == ["B"]
    # the B-twin ties exactly: broken at random, the planted reading is first half the time, always in the top three
    assert t["top1"] == 0.5 and t["top3"] == 1.0
    assert t["by_factor_chance"]["A"] == pytest.approx(1 / 3) and t["by_factor_chance"]["B"] == 0.5
    assert mv.as_dict()["table_match"][0]["recovery"]["unidentifiable"] == ["B"]


def test_recovery_fails_when_the_table_cannot_tell_the_levels_apart():
    # a noisy paper: its standard errors dwarf A's effect, so A is no longer identifiable and recovery falls
    space = SPACE
    design = space.design("full")
    unis = []
    for r in design.readings:
        u = _universe(r)
        unis.append(UniverseResult.build(values=[(v.item, v.algorithm, v.quantity, v.replicated, 0.9)
                                                 for v in u.values], claims=u.claims, diverged=u.diverged,
                                         n_runs=100))
    mv = Multiverse(space, design, unis, _published(space.headline), 100, n_runs_paper=100)
    t = mv.recovery(trials=6)["tables"][0]
    assert "A" in t["unidentifiable"]
    assert t["by_factor"]["A"] < 1.0 and t["top1"] < 1.0


def test_recovery_is_deterministic_and_its_draws_have_their_own_seed():
    a = _multiverse().recovery()
    b = _multiverse().recovery()
    assert a == b
    # another purpose in the spawn key: the planted draws are not the sample's nor the stability check's
    from mmlib.experiment import multiverse, stability
    from mmlib.experiment.readings import sample_seed
    import numpy as np
    seed = int(np.random.SeedSequence(sample_seed(SPACE.paper), spawn_key=(multiverse.RECOVERY_PURPOSE, 0))
               .generate_state(1)[0])
    assert seed not in (sample_seed(SPACE.paper), stability.draw_seed(SPACE.paper))


def test_synthetic_table_has_the_variance_of_an_independent_paper():
    # s^2 (1 + M/M_p): with M = 100, M_p = 25 the noise s.d. is s sqrt(5); 4000 draws give its s.d. to +-1.1 %
    rng = np.random.default_rng(7)
    v, s = np.array([100.0]), np.array([0.5])
    draws = np.array([forensics.synthetic_table(v, s, ["100.0000"], rng, 100, 25)[0] for _ in range(4000)])
    sd = 0.5 * math.sqrt(5.0)
    assert abs(draws.mean() - 100.0) < 4 * sd / math.sqrt(4000)
    assert abs(draws.std(ddof=1) / sd - 1) < 4 * math.sqrt(1 / (2 * 3999))
    # rounded to the printed decimals
    assert forensics.synthetic_table(v, np.zeros(1), ["100.0"], rng, 100, None)[0] == 100.0
    one = forensics.synthetic_table(np.array([1.23456]), np.zeros(1), ["1.2"], rng, 100, None)
    assert one[0] == 1.2


@pytest.mark.parametrize("bad,match", [
    (dict(values=np.ones((2, 3)), stderrs=np.ones((2, 2))), "values, stderrs"),
    (dict(values=np.full((2, 3), np.nan)), "finite"),
    (dict(trials=0), "trials"),
    (dict(seed=-1), "seed"),
])
def test_planted_recovery_bad_input(bad, match):
    args = dict(values=np.ones((2, 3)), stderrs=np.ones((2, 3)), printed=["1.0"] * 3,
                readings=[{"A": "a0"}, {"A": "a1"}], factors=["A"], n_runs=10, n_runs_paper=None, seed=1)
    args.update(bad)
    with pytest.raises(ValueError, match=match):
        forensics.planted_recovery(**args)


def test_confusion_is_the_probability_a_printed_table_lies_closer_to_the_other():
    # one cell, d = |a - b| / sigma: Phi(-d/2); d = 2 * 1.6449 gives 5 % exactly, the threshold
    z95 = 1.6448536269514722
    sigma = 0.1 * math.sqrt(2.0)                    # s = 0.1 with M = M_p: sigma^2 = s^2 (1 + 1), printed to 3 dp
    at = forensics.confusion(np.zeros(1), np.full(1, 0.1), np.full(1, 2 * z95 * sigma), np.full(1, 0.1),
                             ["0.000"], 10, 10)
    assert at["probability"] == pytest.approx(0.05, rel=1e-3)
    same = forensics.confusion(np.ones(3), np.full(3, 0.1), np.ones(3), np.full(3, 0.1), ["1.0"] * 3, 10, 10)
    far = forensics.confusion(np.ones(3), np.full(3, 0.01), 2 * np.ones(3), np.full(3, 0.01), ["1.00"] * 3, 10, 10)
    assert same["confused"] and same["probability"] == 0.5 and not far["confused"] and far["probability"] < 1e-12
    with pytest.raises(ValueError, match="a, sa, b, sb"):
        forensics.confusion(np.ones(3), np.ones(2), np.ones(3), np.ones(3), ["1"] * 3, 10, 10)


def test_decimals_of_printed_numbers():
    assert [forensics._decimals(p) for p in ("2.48", "120", "1.5e-3", "2e3", "0.0")] == [2, 0, 4, -3, 1]


# -- the no-information baseline and the reconstruction qualifier ------------------------------------------------
def test_degenerate_reason_flags_only_when_no_estimator_is_detectably_better_than_the_baseline():
    what = "the measurement-only estimate's position RMSE"
    assert evaluation.degenerate_reason({"IMM": 5.0, "UKF": 9.0}, 6.0, what=what) == ""
    reason = evaluation.degenerate_reason({"IMM": 700.0, "UKF": float("nan")}, 650.0, what=what)
    assert reason.startswith("no estimator is detectably better than " + what) and "IMM" in reason
    assert evaluation.degenerate_reason({"IMM": 6.0}, 6.0, what=what) != ""      # equal: not better
    # better by less than 3 combined standard errors: not detectably better, so degenerate whatever the draw
    assert evaluation.degenerate_reason({"IMM": (5.8, 0.05)}, (6.0, 0.05), what=what) != ""
    assert evaluation.degenerate_reason({"IMM": (5.7, 0.05)}, (6.0, 0.05), what=what) == ""
    # detectably better but by less than NEGLIGIBLE (1 %) of the baseline: no better in any way that matters
    assert evaluation.degenerate_reason({"IMM": (5.95, 1e-4)}, 6.0, what=what) != ""
    from mmlib.experiment.metrics import MCValue
    assert evaluation.degenerate_reason({"IMM": MCValue(np.float64(5.0), np.float64(0.1), 10, 0)}, 6.0,
                                        what=what) == ""
    for kwargs, match in ((dict(errors={}, baseline=1.0, what=what), "errors"),
                          (dict(errors={"a": 1.0}, baseline=0.0, what=what), "baseline"),
                          (dict(errors={"a": 1.0}, baseline=(1.0, float("nan")), what=what), "baseline"),
                          (dict(errors={"a": "x"}, baseline=1.0, what=what), r"errors\['a'\]"),
                          (dict(errors={"a": 1.0}, baseline=1.0, what=" "), "what")):
        with pytest.raises(ValueError, match=match):
            evaluation.degenerate_reason(**kwargs)


def test_reconstruction_qualifier_words():
    assert verdicts.qualified("contradicted: IMM 3 % worse", verdicts.RECONSTRUCTION) == \
        "contradicted by the reconstruction"
    assert verdicts.qualified("holds", verdicts.RECONSTRUCTION) == "holds in the reconstruction"
    assert verdicts.qualified("holds: x", "") == "holds"
    with pytest.raises(ValueError, match="qualifier"):
        verdicts.qualified("holds", "guess")


def test_consistency_entries_need_the_nees_and_nis():
    rs = evaluation.RunSet(np.zeros((3, 4, 2)), None, np.full(3, -1), np.zeros((4, 2)))
    with pytest.raises(ValueError, match="consistency=True"):
        evaluation.consistency_entries({"KF": rs}, 2)
    rng = np.random.default_rng(3)
    ok = rs._replace(nees=rng.chisquare(2, (3, 4)), nis=rng.chisquare(1, (3, 4)), nis_dof=np.ones(4))
    e = evaluation.consistency_entries({"KF": ok}, 2, case="case 1")[0]
    assert e["algorithm"] == "KF" and e["case"] == "case 1" and e["anees"]["dof"] == 2 and e["anis"]["dof"] == 1
    with pytest.raises(ValueError, match="state_dim"):
        evaluation.consistency_entries({"KF": ok}, 0)


def test_notebook_writes_the_qualified_words_of_a_reconstruction(tmp_path):
    import dataclasses
    import importlib.util
    import sys
    from pathlib import Path

    from mmlib.experiment.notebook import NotebookRun
    from mmlib.experiment.verdicts import Claims
    path = Path(__file__).resolve().parents[1] / "docs" / "examples" / "minimal_paper.py"
    spec = importlib.util.spec_from_file_location("minimal_paper_forensics", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    claims = Claims()
    claims.add("CKF beats KF", "contradicted: 3 % worse", "a paired difference", key="ckf_vs_kf")
    for qualifier, words in (("", None), (verdicts.RECONSTRUCTION, "contradicted by the reconstruction")):
        paper = dataclasses.replace(module.PAPER, qualifier=qualifier)
        doc = NotebookRun(paper, PROFILE="smoke", OUTPUT_ROOT=str(tmp_path), PROGRESS=False).write_results(
            rows=[], claims=claims)
        c = doc["claims"][0]
        assert c.get("stated") == words and c.get("qualifier", "") == qualifier
        assert c["verdict"] == "contradicted"
