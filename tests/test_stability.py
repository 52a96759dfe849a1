"""Run-count stability (mmlib.experiment.stability): claim verdicts of the headline and a sample of universes at the
multiverse's run count and at the headline's, and which change.

The synthetic jobs make the answer known: :func:`flip_universe`'s claim "the flip claim" is "not supported" in the
universes with option B = s2 below FLIP_RUNS runs and "holds" everywhere else, its "stable claim" always holds; so
between 20 and 100 runs exactly the B = s2 universes change one verdict.  A comparison that looked at the wrong
count, the wrong universe or the wrong claim fails these tests."""
from __future__ import annotations

import dataclasses
import importlib.util
import sys
from pathlib import Path

import numpy as np

import experiment_jobs as toy
from conftest import raises_naming
from mmlib.experiment.multiverse import run_multiverse
from mmlib.experiment.readings import sample_seed
from mmlib.experiment.stability import draw_seed, run_count_stability, sample_pool
from mmlib.experiment.universe import UniverseResult
from mmlib.experiment.verdicts import claim_category

REPO = Path(__file__).resolve().parents[1]

#: below this many runs the flip claim is "not supported" in the B = s2 universes
FLIP_RUNS = 50
FLIP, STABLE = "the flip claim", "the stable claim"


def flip_universe(reading, n_runs, seed, degenerate=""):
    """No simulation: the flip claim's verdict a known function of the reading and ``n_runs``."""
    flips = reading["B"] == "s2" and n_runs < FLIP_RUNS
    return UniverseResult.build(values=[("T1", "alg", "mean", 1.0, 0.1)],
                                claims=[{"claim": FLIP, "verdict": "not supported" if flips else "holds"},
                                        {"claim": STABLE, "verdict": "holds"}],
                                diverged={}, n_runs=n_runs, degenerate=degenerate)


def degenerate_universe(reading, n_runs, seed):
    """:func:`flip_universe`, flagged degenerate when A = one."""
    return flip_universe(reading, n_runs, seed, "every error above the baseline" if reading["A"] == "one" else "")


def never_called(reading, n_runs, seed):
    raise AssertionError("the stability check reran a universe although the run counts coincide")


def _mv(job, tmp_path, n_runs=20, design="full", seed=7):
    return run_multiverse(toy.SPACE, job, published=toy.PUBLISHED, n_runs=n_runs, seed=seed, algorithms=["alg"],
                          design=design, cache_dir=tmp_path / "mv", progress=False)


def _check(mv, job, tmp_path, **kw):
    opts = dict(n_runs=100, seed=7, size=11, algorithms=["alg"], workers=1, progress=False,
                cache_dir=tmp_path / "stability")
    opts.update(kw)
    return run_count_stability(mv, job, **opts)


def test_a_verdict_that_flips_with_the_run_count_is_detected(tmp_path):
    mv = _mv(flip_universe, tmp_path)
    assert len(mv.universes) == 12 and mv.counted() == list(range(12))
    got = _check(mv, flip_universe, tmp_path)           # size 11: the whole pool, every universe checked
    assert got["rerun"] and (got["n_runs_universe"], got["n_runs_check"]) == (20, 100)
    assert (got["low_runs"], got["high_runs"]) == (20, 100)
    assert [e["universe"] for e in got["universes"]] == list(range(12)) and got["universes"][0]["headline"]
    s2 = [i for i, r in enumerate(mv.readings) if r["B"] == "s2"]
    assert len(s2) == 4 and 0 not in s2
    for e in got["universes"]:
        flips = e["universe"] in s2
        assert e["changed"] == ([FLIP] if flips else [])
        assert e["verdicts"][FLIP] == (["not supported", "holds"] if flips else ["holds", "holds"])
        assert e["verdicts"][STABLE] == ["holds", "holds"]
    assert got["n_changed"] == 4 and got["claims_changed"] == {FLIP: 4, STABLE: 0}
    assert got["shares"][FLIP] == {"dominant": "holds", "n": 12, "low": 8 / 12, "high": 1.0,
                                   "counts_low": {"holds": 8, "not supported": 4}, "counts_high": {"holds": 12}}
    assert got["shares"][STABLE]["low"] == got["shares"][STABLE]["high"] == 1.0
    assert got["statement"].startswith("4 of 12 universes") and "between 20 and 100 runs" in got["statement"]
    assert f"{FLIP} (4 universes)" in got["statement"] and STABLE not in got["statement"]


def test_a_multiverse_at_more_runs_than_the_headline_keeps_low_and_high_in_order(tmp_path):
    mv = _mv(flip_universe, tmp_path, n_runs=100)
    got = _check(mv, flip_universe, tmp_path, n_runs=20)
    assert (got["n_runs_universe"], got["n_runs_check"], got["low_runs"], got["high_runs"]) == (100, 20, 20, 100)
    changed = [e for e in got["universes"] if e["changed"]]
    assert len(changed) == 4 and all(e["verdicts"][FLIP] == ["not supported", "holds"] for e in changed)


def test_stable_verdicts_are_not_reported_as_changed(tmp_path):
    low = _mv(flip_universe, tmp_path, n_runs=60)
    got = _check(low, flip_universe, tmp_path, n_runs=200, size=3)   # 60 and 200 runs: both at or above FLIP_RUNS
    assert got["rerun"] and got["n_changed"] == 0 and got["claims_changed"] == {FLIP: 0, STABLE: 0}
    assert got["n_universes"] == 4 and got["sample"]["n_sampled"] == 3
    assert got["statement"] == "No verdict changes between 60 and 200 runs in the headline universe and 3 sampled " \
                               "universes."


def test_coinciding_run_counts_rerun_nothing(tmp_path):
    mv = _mv(flip_universe, tmp_path)
    got = _check(mv, never_called, tmp_path, n_runs=20, size=2)
    assert not got["rerun"] and got["n_changed"] == 0 and got["n_universes"] == 3
    assert all(e["verdicts"][STABLE] == ["holds", "holds"] for e in got["universes"])
    assert got["statement"].startswith("The universe and headline run counts coincide (20 runs): nothing was rerun")


def test_the_draw_is_deterministic_recorded_and_within_the_pool(tmp_path):
    mv = _mv(flip_universe, tmp_path)
    a = _check(mv, flip_universe, tmp_path, size=3)
    b = _check(mv, flip_universe, tmp_path, size=3, use_cache=False)
    assert a == b
    assert a["sample"] == {"size": 3, "n_sampled": 3, "pool": 11, "draw_seed": sample_seed("toy") + 1,
                           "excluded_degenerate": 0, "excluded_motivated": 0}
    assert draw_seed("toy") == sample_seed("toy") + 1
    idx = [e["universe"] for e in a["universes"]]
    order = np.random.default_rng(draw_seed("toy")).permutation(11)[:3]
    assert idx == [0] + sorted(int(j) + 1 for j in order)             # pool = universes 1..11 of the full design
    assert _check(mv, flip_universe, tmp_path, size=0)["universes"][0]["universe"] == 0
    assert _check(mv, flip_universe, tmp_path, size=0)["n_universes"] == 1
    assert _check(mv, flip_universe, tmp_path, size=50)["sample"]["n_sampled"] == 11    # capped at the pool


def test_the_rerun_is_the_job_at_the_headline_count_whatever_the_workers(tmp_path):
    """A Monte Carlo job (the toy universe): one and two workers give the same result, and each rerun universe's
    verdicts are the job's own at that reading, run count and seed."""
    mv = _mv(toy.toy_universe, tmp_path)
    one = _check(mv, toy.toy_universe, tmp_path, n_runs=200, size=4, workers=1, use_cache=False)
    two = _check(mv, toy.toy_universe, tmp_path, n_runs=200, size=4, workers=2, use_cache=False)
    assert one == two
    for e in one["universes"]:
        direct = toy.toy_universe(mv.readings[e["universe"]], 200, 7)
        assert {c.claim: str(claim_category(c.verdict)) for c in direct.claims} == \
               {c: v[1] for c, v in e["verdicts"].items()}
        assert {c.claim: str(claim_category(c.verdict)) for c in mv.universes[e["universe"]].claims} == \
               {c: v[0] for c, v in e["verdicts"].items()}


def test_degenerate_universes_are_left_out_of_the_draw(tmp_path):
    mv = _mv(degenerate_universe, tmp_path)
    pool = sample_pool(mv)
    assert pool["excluded_degenerate"] == 6 and len(pool["pool"]) == 5
    assert all(mv.readings[i]["A"] == "zero" for i in pool["pool"])
    got = _check(mv, degenerate_universe, tmp_path, size=11)
    assert got["n_universes"] == 6 and got["sample"]["excluded_degenerate"] == 6
    assert all("degenerate" not in e for e in got["universes"])


def test_bad_input_names_the_argument(tmp_path):
    mv = _mv(flip_universe, tmp_path)
    with raises_naming("mv"):
        _check(mv.as_dict(), flip_universe, tmp_path)
    with raises_naming("job"):
        _check(mv, "flip_universe", tmp_path)
    for name, value in (("n_runs", 0), ("n_runs", 2.5), ("seed", -1), ("size", -1), ("size", True), ("size", 1.5),
                        ("workers", 0), ("progress", "yes"), ("algorithms", "alg")):
        with raises_naming(name):
            _check(mv, flip_universe, tmp_path, **{name: value})
    with raises_naming("sample_seed"):
        _check(mv, flip_universe, tmp_path, sample_seed=3)
    with raises_naming("mv"):
        sample_pool([])


# ----------------------------------------------------------------------------------- the notebook hook (NotebookRun)
def _minimal_paper():
    spec = importlib.util.spec_from_file_location("minimal_paper", REPO / "docs" / "examples" / "minimal_paper.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def test_notebook_multiverse_checks_the_run_count(tmp_path, monkeypatch):
    from mmlib.experiment.notebook import NotebookRun
    monkeypatch.setenv("MMLIB_CACHE", str(tmp_path / "cache"))
    paper = _minimal_paper().PAPER
    nb = NotebookRun(paper, PROFILE="smoke", OUTPUT_ROOT=str(tmp_path), WORKERS=1, PROGRESS=False,
                     MULTIVERSE_RUNS=10)
    assert nb.stability_universes == 2 and (nb.mv_runs, nb.n_runs) == (10, 20)
    mv = nb.multiverse()
    st = mv.stability
    assert st["rerun"] and (st["n_runs_universe"], st["n_runs_check"]) == (10, 20)
    assert st["mode"] == "headline" and st["n_runs_headline"] == 20
    assert st["n_universes"] == 2 and st["sample"]["n_sampled"] == 1        # the star design: headline and one
    for e in st["universes"]:
        direct = paper.universe(mv.readings[e["universe"]], 20, paper.root_seed)
        assert {c.claim: str(claim_category(c.verdict)) for c in direct.claims} == \
               {c: v[1] for c, v in e["verdicts"].items()}
    assert mv.as_dict()["stability"] == st                   # written into the results file's multiverse
    coincide = NotebookRun(paper, PROFILE="smoke", OUTPUT_ROOT=str(tmp_path), WORKERS=1, PROGRESS=False)
    st = coincide.multiverse().stability              # equal counts: the check runs at half of them instead
    assert st["rerun"] and (st["n_runs_universe"], st["n_runs_check"]) == (20, 10)
    assert st["mode"] == "half" and st["n_runs_headline"] == 20
    off = dataclasses.replace(paper, profiles={"full": paper.profiles["full"],
                                               "smoke": {**paper.profiles["smoke"], "stability_universes": 0}})
    assert NotebookRun(off, PROFILE="smoke", OUTPUT_ROOT=str(tmp_path), WORKERS=1, PROGRESS=False,
                       MULTIVERSE_RUNS=10).multiverse().stability is None
    bad = dataclasses.replace(paper, profiles={"full": paper.profiles["full"],
                                               "smoke": {**paper.profiles["smoke"], "stability_universes": -1}})
    with raises_naming("PROFILE"):
        NotebookRun(bad, PROFILE="smoke", OUTPUT_ROOT=str(tmp_path))
