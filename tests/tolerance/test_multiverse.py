"""The reading-space multiverse of every paper: the committed full-fidelity object is what the code
declares now, the smoke multiverse agrees with it within Monte Carlo error, and the headline
universe is the notebook's headline, bit for bit.

Tolerance: the smoke run of a universe uses the first runs of the same streams as the committed
run of that universe (nested samples), so the difference of the two estimates has a standard
deviation below sqrt(se_smoke^2 + se_full^2); 4 of those is the band (as in test_results.py).
"""
import math

import pytest

from mmlib.experiment import report
from mmlib.experiment.multiverse import PRECISION
from mmlib.papers import REGISTRY
from test_results import PAPERS, load

KEYS = ("factors", "design", "design_description", "design_sample", "design_seed", "n_counted", "weighting",
        "n_universes", "n_runs", "universes", "claims_summary", "numbers_summary", "table_match")


def _by_reading(mv):
    return {tuple(sorted(u["reading"].items())): u for u in mv["universes"]}


@pytest.mark.parametrize("paper", sorted(PAPERS))
def test_committed_multiverse_is_the_declared_design(paper):
    space = REGISTRY[paper].space
    mv = load(paper, "full")["multiverse"]
    assert all(k in mv for k in KEYS)
    assert [f["id"] for f in mv["factors"]] == list(space.ids)
    for f, decl in zip(mv["factors"], space.factors):
        assert f["options"] == list(decl.names) and f["headline"] == decl.headline
    # a sampled design is redrawn from its recorded size and seed (the size may be a MULTIVERSE_UNIVERSES override)
    design = (space.design("sampled", sample_size=mv["n_drawn"], seed=mv["design_seed"])
              if mv["design"] == "sampled" else space.design(mv["design"]))
    assert [u["reading"] for u in mv["universes"]] == list(design.readings)
    assert mv["n_universes"] == len(design) == len(mv["universes"])
    assert mv["design_sample"] == list(design.sample) and mv["design_seed"] == design.seed
    assert mv["universes"][0]["reading"] == space.headline


@pytest.mark.parametrize("paper", sorted(PAPERS))
@pytest.mark.parametrize("profile", ["smoke", "full"])
def test_shares_follow_from_the_universes(paper, profile):
    """Every claim's share, interval and claim x option table recomputed from the stored universes of the counted
    sample (the drawn universes without those with a motivated option or flagged degenerate, set apart): shares only
    from a full or sampled design, the interval the Wilson interval (or no width when the full factorial is run),
    robust exactly when a lower bound reaches 90 %."""
    from mmlib.experiment.metrics import wilson_interval
    mv = load(paper, profile)["multiverse"]
    space = REGISTRY[paper].space
    uniform = mv["design"] in ("full", "sampled")
    exact = uniform and len(mv["design_sample"]) == mv["full_factorial_size"]
    counted = [mv["universes"][i] for i in mv["design_sample"]
               if not space.motivated(mv["universes"][i]["reading"]) and not mv["universes"][i].get("degenerate")]
    assert not uniform or len(counted) == mv["n_counted"]
    for c in mv["claims_summary"]:
        if not uniform:
            assert c["share"] is None and c["robust"] is None and c["by_option"] is None
            continue
        got = [report.claim_category(x["verdict"]) for u in counted for x in u["claims"] if x["claim"] == c["claim"]]
        n = len(got)
        assert n == c["n_counted"] == sum(c["verdict_counts"].values())
        for k in report.CLAIM_VERDICTS:
            assert c["share"][k] == got.count(k) / n
            want = [got.count(k) / n] * 2 if exact else list(wilson_interval(got.count(k), n))
            assert c["interval"][k] == pytest.approx(want, abs=1e-12)
        assert c["robust"] is (max(lo for lo, _ in c["interval"].values()) >= 0.9)
        for fid, options in c["by_option"].items():
            assert sum(cell["n"] for cell in options.values()) == n
            for cell in options.values():
                assert not cell["n"] or sum(cell["share"].values()) == pytest.approx(1.0)


@pytest.mark.parametrize("paper", sorted(PAPERS))
@pytest.mark.parametrize("profile", ["smoke", "full"])
def test_every_verdict_in_the_vocabulary_and_every_number_summarised(paper, profile):
    published = REGISTRY[paper].published
    mv = load(paper, profile)["multiverse"]
    for u in mv["universes"]:
        assert isinstance(u["diverged"], dict)
        for c in u["claims"]:
            report.claim_category(c["verdict"])
    assert {(n["item"], n["algorithm"], n["quantity"]) for n in mv["numbers_summary"]} == \
        {p.key for p in published}
    for n in mv["numbers_summary"]:
        report.verdict_category(n["headline_verdict"])
        assert 0 <= n["n_reproduced"] + n["n_isolated"] <= n["n_counted"] <= n["n_universes"] == mv["n_universes"]
        c = n["closest"]
        assert (c is None) == (n["closest_status"] != "found")
        if c is not None:             # precise enough: s.e. within PRECISION of the printed value
            assert c["stderr"] is not None and c["stderr"] <= PRECISION * abs(float(n["paper"])) * (1 + 1e-12)
    assert [c["claim"] for c in mv["claims_summary"]] == [c["claim"] for c in mv["universes"][0]["claims"]]


@pytest.mark.parametrize("paper", sorted(PAPERS))
def test_smoke_universes_within_monte_carlo_error_of_committed(paper):
    smoke, full = _by_reading(load(paper, "smoke")["multiverse"]), _by_reading(load(paper, "full")["multiverse"])
    assert set(smoke) <= set(full), "every smoke universe is a universe of the full design"
    checked = 0
    for key, s in smoke.items():
        f = full[key]
        fv = {(v["item"], v["algorithm"], v["quantity"]): v for v in f["values"]}
        for v in s["values"]:
            w = fv[(v["item"], v["algorithm"], v["quantity"])]
            if w["replicated"] is None:           # every committed run diverged: so did every run of the prefix
                assert v["replicated"] is None, (key, v, w)
                continue
            if v["replicated"] is None:           # every smoke run diverged, some later run did not
                continue
            band = 4.0 * math.hypot(v["stderr"] or 0.0, w["stderr"] or 0.0)
            assert abs(v["replicated"] - w["replicated"]) <= band, (key, v, w, band)
            checked += 1
    assert checked >= 5


@pytest.mark.parametrize("paper", sorted(PAPERS))
@pytest.mark.parametrize("profile", ["smoke", "full"])
def test_headline_universe_is_the_notebook_headline(paper, profile):
    """Bit for bit wherever the multiverse and the notebook use the same run count (always in the smoke profile;
    in the full profile of the papers whose universes run at the paper's count).  Where the universes run fewer
    runs, the headline universe's runs are the first runs of the notebook's (same streams), so the two estimates
    differ by less than 4 sqrt(se_u^2 + se_nb^2), as in the smoke-versus-full test."""
    doc = load(paper, profile)
    mv = doc["multiverse"]
    if profile == "smoke":
        assert mv["n_runs"] == doc["provenance"]["n_runs"], "smoke multiverse runs = smoke notebook runs"
    exact = mv["n_runs"] == doc["provenance"]["n_runs"]
    assert mv["n_runs"] <= doc["provenance"]["n_runs"]
    rows = {(r["item"], r["algorithm"], r["quantity"]): r for r in doc["rows"]}
    head = mv["universes"][0]
    compared = 0
    for v in head["values"]:
        r = rows.get((v["item"], v["algorithm"], v["quantity"]))
        if r is None:
            continue
        if exact:
            assert v["replicated"] == r["replicated"] and v["stderr"] == r["stderr"], (v, r)
        elif r["replicated"] is None or v["replicated"] is None:   # the universe's runs are a prefix of the notebook's
            assert r["replicated"] is not None or v["replicated"] is None, (v, r)
        else:
            band = 4.0 * math.hypot(v["stderr"] or 0.0, r["stderr"] or 0.0)
            assert abs(v["replicated"] - r["replicated"]) <= band, (v, r, band)
        compared += 1
    assert compared >= 1
    if exact:
        verdicts = {c["claim"]: c["verdict"] for c in doc["claims"]}
        for c in head["claims"]:
            if c["claim"] in verdicts:
                assert c["verdict"] == verdicts[c["claim"]], c
