"""Shares of the reading space (mmlib.experiment.multiverse): the Wilson score interval, the uniform sample of
universes, the share estimator against the full factorial of a small synthetic space (and the coverage of its
95 % interval over repeated samples), the claim x option table, the precision-aware closest universe and the joint
tests that isolate coincidences.

The synthetic space (tests/experiment_jobs.py, SHARE_SPACE) has 72 universes whose claim verdict is a known
function of the reading (52 hold, 10 contradicted, 10 not supported), so every share is known exactly.
"""
import math

import numpy as np
import pytest
from scipy import stats

import experiment_jobs as toy
from mmlib.experiment import report, run_multiverse
from mmlib.experiment.metrics import wilson_interval
from mmlib.experiment.multiverse import NO_SHARE, PRECISION, Multiverse
from mmlib.experiment.readings import Design, sample_seed
from mmlib.experiment.universe import PublishedNumber, UniverseResult

SPACE = toy.SHARE_SPACE
M = SPACE.size
TRUE = {"holds": 52 / 72, "contradicted": 10 / 72, "not supported": 10 / 72}
UNIVERSES = {tuple(r.values()): toy.share_universe(r, 4, 0) for r in SPACE.full()}


def _multiverse(design, published=toy.SHARE_PUBLISHED):
    """The multiverse of a design of SHARE_SPACE from the precomputed universes (no grid: they are deterministic)."""
    return Multiverse(SPACE, design, [UNIVERSES[tuple(r.values())] for r in design.readings], published, 4)


# -- the Wilson score interval ----------------------------------------------------------------------------------
def test_wilson_interval_by_hand():
    z2 = 1.959963984540054 ** 2
    # k = 0 and k = n: the closed forms [0, z^2/(n + z^2)] and [n/(n + z^2), 1]
    assert wilson_interval(0, 10) == (0.0, pytest.approx(z2 / (10 + z2), rel=1e-12))
    assert wilson_interval(10, 10) == (pytest.approx(10 / (10 + z2), rel=1e-12), 1.0)
    # k = n/2: centred on 1/2, half-width z sqrt(1/(4n) + z^2/(4n^2)) / (1 + z^2/n)
    half = math.sqrt(z2) * math.sqrt(0.25 / 10 + z2 / 400) / (1 + z2 / 10)
    lo, hi = wilson_interval(5, 10)
    assert lo == pytest.approx(0.5 - half, rel=1e-12) and hi == pytest.approx(0.5 + half, rel=1e-12)
    # Newcombe (1998, Statistics in Medicine 17:857, Table I, method 3): 81/263 -> 0.2553 to 0.3662
    lo, hi = wilson_interval(81, 263)
    assert (round(lo, 4), round(hi, 4)) == (0.2553, 0.3662)
    # another level: 90 % is narrower and nested
    lo90, hi90 = wilson_interval(81, 263, level=0.90)
    assert lo < lo90 < 81 / 263 < hi90 < hi


@pytest.mark.parametrize("args,match", [((0, 0), "n"), ((3, 2), "successes"), ((-1, 2), "successes"),
                                        ((1.5, 2), "successes"), ((True, 2), "successes"), ((1, 2, 1.0), "level"),
                                        ((1, 2, 0.0), "level")])
def test_wilson_interval_bad_input(args, match):
    with pytest.raises(ValueError, match=match):
        wilson_interval(*args)


# -- the uniform sample -----------------------------------------------------------------------------------------
def test_sample_is_deterministic_given_the_seed_and_changes_with_it():
    a, b = SPACE.sample(20, 5), SPACE.sample(20, 5)
    assert a == b and len({tuple(r.values()) for r in a}) == 20          # without replacement
    assert SPACE.sample(20, 6) != a
    d = SPACE.design()
    assert d.kind == "sampled" and d.seed == sample_seed("toy-shares") and len(d.sample) == 20
    assert [d.readings[i] for i in d.sample] == SPACE.sample(20, d.seed)
    assert SPACE.design(seed=6).readings != d.readings
    # the stated derivation of the default seed: the first four bytes of SHA-256 of the name
    import hashlib
    assert sample_seed("toy-shares") == int.from_bytes(hashlib.sha256(b"toy-shares").digest()[:4], "big")
    # reading_at and index_of are inverse, in itertools.product order
    assert [SPACE.reading_at(i) for i in range(M)] == sorted(SPACE.full(), key=SPACE.index_of)
    assert all(SPACE.index_of(SPACE.reading_at(i)) == i for i in range(M))


def test_sample_is_uniform():
    """Over 400 seeds, each of the 72 universes is drawn about 400 x 20/72 = 111 times: Pearson's chi-squared on
    the inclusion counts (71 degrees of freedom; an approximation, each count being binomial with p = 20/72 and
    the counts nearly independent) must not reject at 0.1 %; and the number of 'holds' universes in a sample is
    hypergeometric (72, 52, 20): its mean 14.44 within 4 standard errors of the mean over seeds.  The seeds are
    fixed, so the test is deterministic; a biased sampler (e.g. the first 20 of a shuffle of a sorted list with a
    bad shuffle, or a draw with replacement) fails it."""
    counts = np.zeros(M)
    holds = []
    for seed in range(400):
        sample = SPACE.sample(20, seed)
        for r in sample:
            counts[SPACE.index_of(r)] += 1
        holds.append(sum(toy.share_verdict(r) == "holds" for r in sample))
    expected = 400 * 20 / M
    chi2 = float(((counts - expected) ** 2 / expected).sum())
    assert stats.chi2.sf(chi2, M - 1) > 1e-3, chi2
    hg = stats.hypergeom(M, 52, 20)
    assert abs(np.mean(holds) - hg.mean()) <= 4 * hg.std() / math.sqrt(400)
    assert np.var(holds, ddof=1) < 1.2 * 20 * (52 / 72) * (20 / 72)   # without replacement: below the binomial's


def test_sampled_design_runs_star_and_sample_and_counts_a_drawn_star_reading_once():
    d = SPACE.design("sampled", sample_size=M)                 # the sample is the whole factorial
    star = SPACE.star()
    assert len(d) == M and list(d.readings[:len(star)]) == star and sorted(d.sample) == list(range(M))
    mv = _multiverse(d)
    assert mv.exact and mv.weighting() == f"full factorial of {M}"
    (c,) = mv.claims_summary()
    assert c["share"] == {k: TRUE.get(k, 0.0) for k in report.CLAIM_VERDICTS}
    d = SPACE.design("sampled", sample_size=30, seed=1)
    drawn = SPACE.sample(30, 1)
    in_star = [r for r in drawn if r in star]
    assert len(d) == len(star) + 30 - len(in_star) and len(d.sample) == 30
    assert all(d.readings[i] in star for i in d.sample if i < len(star))


def test_design_bad_input():
    head = SPACE.headline
    with pytest.raises(ValueError, match="seed"):
        Design("sampled", "x", (head,), (0,))                    # a sampled design records its seed
    with pytest.raises(ValueError, match="sample"):
        Design("sampled", "x", (head,), (), 3)
    with pytest.raises(ValueError, match="sample"):
        Design("sampled", "x", (head, head), (0, 0), 3)          # an index twice
    with pytest.raises(ValueError, match="sample"):
        Design("sampled", "x", (head,), (1,), 3)                 # beyond the readings
    with pytest.raises(ValueError, match="sample"):
        Design("fractional", "x", (head,), (0,))
    with pytest.raises(ValueError, match="seed"):
        Design("full", "x", (head,), None, 3)
    with pytest.raises(ValueError, match="kind"):
        SPACE.design("random")
    with pytest.raises(ValueError, match="sample_size"):
        SPACE.design("sampled", sample_size=0)
    with pytest.raises(ValueError, match="seed"):
        SPACE.design("sampled", seed=-1)
    with pytest.raises(ValueError, match="n"):
        SPACE.sample(M + 1, 0)
    with pytest.raises(ValueError, match="index"):
        SPACE.reading_at(M)
    unbudgeted = type(SPACE)("p", SPACE.factors)
    with pytest.raises(ValueError, match="sample_size"):
        unbudgeted.design("sampled")
    with pytest.raises(ValueError, match="repeat"):            # counted universes must be distinct readings
        _multiverse(Design("sampled", "x", (head, head), (0, 1), 3))


# -- the share estimator ----------------------------------------------------------------------------------------
def test_full_factorial_shares_are_exact(tmp_path):
    """Through the grid runner: the full factorial's shares are the known fractions, the interval has no width,
    and no verdict reaches 90 % (holds is 72 %), so the claim depends on the reading."""
    mv = run_multiverse(SPACE, toy.share_universe, published=toy.SHARE_PUBLISHED, n_runs=4, seed=1,
                        algorithms=["alg"], design="full", cache_dir=tmp_path, progress=False, workers=1)
    (c,) = mv.claims_summary()
    assert c["share"] == {k: TRUE.get(k, 0.0) for k in report.CLAIM_VERDICTS}
    assert c["interval"] == {k: [TRUE.get(k, 0.0)] * 2 for k in report.CLAIM_VERDICTS}
    assert c["verdict_counts"] == {"holds": 52, "contradicted": 10, "not supported": 10}
    assert c["n_counted"] == M and c["weighting"] == "full factorial of 72" and c["robust"] is False
    assert c["robustness"] == "depends on the reading"


def test_sampled_share_and_interval_by_hand():
    d = SPACE.design()
    mv = _multiverse(d)
    (c,) = mv.claims_summary()
    drawn = [toy.share_verdict(d.readings[i]) for i in d.sample]
    for k in report.CLAIM_VERDICTS:
        assert c["share"][k] == drawn.count(k) / 20
        assert c["interval"][k] == list(wilson_interval(drawn.count(k), 20))
    assert c["weighting"] == f"uniform sample of 20 of 72, seed {d.seed}" and c["n_counted"] == 20
    assert c["robust"] is (max(lo for lo, _ in c["interval"].values()) >= 0.9)
    # the star is reported apart: its verdicts are those of the one-option readings
    star = [toy.share_verdict(r) for r in SPACE.star()[1:]]
    assert c["star_counts"] == {k: star.count(k) for k in report.CLAIM_VERDICTS if k in star}


def test_interval_covers_the_full_factorial_share():
    """Over 400 samples (seeds 0..399) of 20 of the 72 universes, the 95 % interval of each verdict's share covers
    the full factorial's share about as often as the exact coverage under the hypergeometric law of the count
    (sum over k of P(k) [share in wilson(k, 20)]), within 4 binomial standard errors of 400 trials (at most
    4 sqrt(0.05 x 0.95 / 400) = 0.044); and that exact coverage is at least 95 % here (the Wilson interval ignores
    the finite-population correction, so it is conservative for a sample without replacement)."""
    hits = {k: 0 for k in TRUE}
    for seed in range(400):
        (c,) = _multiverse(SPACE.design("sampled", seed=seed)).claims_summary()
        for k, p in TRUE.items():
            lo, hi = c["interval"][k]
            hits[k] += lo <= p <= hi
    for k, p in TRUE.items():
        hg = stats.hypergeom(M, round(p * M), 20)
        exact = sum(hg.pmf(j) for j in range(21) if wilson_interval(j, 20)[0] <= p <= wilson_interval(j, 20)[1])
        assert exact >= 0.95, (k, exact)
        assert abs(hits[k] / 400 - exact) <= 4 * math.sqrt(exact * (1 - exact) / 400) + 1e-12, (k, hits[k], exact)


def test_robust_is_the_lower_bound():
    """A claim holding in every one of 20 sampled universes has lower bound 20/(20 + z^2) = 0.839 < 0.9: not robust
    on 20 universes (the share is 100 %, the interval says it may be 84 %); on 40 it is (0.912)."""
    d = SPACE.design()
    universes = [UNIVERSES[tuple(SPACE.headline.values())]] * len(d)
    mv = Multiverse(SPACE, d, universes, toy.SHARE_PUBLISHED, 4)
    (c,) = mv.claims_summary()
    verdict = str(report.claim_category(universes[0].claims[0].verdict))
    assert c["share"][verdict] == 1.0 and c["interval"][verdict][0] == pytest.approx(20 / (20 + 1.96 ** 2), rel=1e-3)
    assert c["robust"] is False
    d40 = SPACE.design(sample_size=40)
    (c,) = Multiverse(SPACE, d40, [universes[0]] * len(d40), toy.SHARE_PUBLISHED, 4).claims_summary()
    assert c["robust"] is True and c["robustness"] == "robust"


def test_by_option_sums():
    d = SPACE.design()
    mv = _multiverse(d)
    (c,) = mv.claims_summary()
    for f in SPACE.factors:
        table = c["by_option"][f.id]
        assert list(table) == list(f.names)
        assert sum(cell["n"] for cell in table.values()) == 20
        for o, cell in table.items():
            if cell["n"]:
                assert sum(cell["share"].values()) == pytest.approx(1.0)
                mine = [toy.share_verdict(d.readings[i]) for i in d.sample if d.readings[i][f.id] == o]
                assert cell["share"] == {k: mine.count(k) / len(mine) for k in report.CLAIM_VERDICTS if k in mine}
        for k in report.CLAIM_VERDICTS:         # the options' shares, weighted by their counts, are the share
            assert sum(cell["n"] * cell["share"].get(k, 0.0) for cell in table.values()) / 20 == \
                pytest.approx(c["share"][k])
    # the option that drives the claim: under S2 = o1 (contradicted when it does not hold) "not supported" never occurs
    assert "not supported" not in c["by_option"]["S2"]["o1"]["share"]


@pytest.mark.parametrize("kind", ["fractional", "star"])
def test_no_share_from_a_design_that_is_not_a_uniform_sample(kind):
    mv = _multiverse(SPACE.design(kind))
    (c,) = mv.claims_summary()
    assert c["share"] is None and c["interval"] is None and c["by_option"] is None and c["robust"] is None
    assert c["robustness"] == NO_SHARE == "no share: the design is not a uniform sample"
    assert sum(c["verdict_counts"].values()) == len(mv.universes)          # descriptive counts of the design
    assert mv.as_dict()["design_sample"] == [] and mv.as_dict()["n_counted"] == 0
    with pytest.raises(ValueError, match="labels"):
        mv.shares(["maybe"], report.CLAIM_VERDICTS)


# -- precision-aware forensics ----------------------------------------------------------------------------------
def _with_values(values):
    """A star design of SHARE_SPACE whose universes carry the given (value, stderr) of 'x' (headline first)."""
    d = SPACE.design("star")
    base = UNIVERSES[tuple(SPACE.headline.values())]
    us = [UniverseResult.build(values=[("S", "alg", "x", v, se)], claims=base.claims, diverged={}, n_runs=4)
          for v, se in values]
    us += [base] * (len(d) - len(us))
    return Multiverse(SPACE, d, us, (PublishedNumber("Table S", "S", "alg", "x", "3.82"),), 4, 100)


def test_closest_universe_is_precise_and_ranked_by_relative_distance():
    """zhou2017's case: a printed 3.82 'matched' by 178 +- 17 only because its s.e. is large.  Universe 1 is noisy
    (3.9 +- 2: z near 0, relative distance 2 %), universe 2 precise but farther (4.5 +- 0.05: 18 %), universe 3
    precise and nearer in relative terms but many s.e. away (3.5 +- 0.01: 8 %, z -32).  The closest is universe 3:
    the noisy one cannot win, and the ranking is by relative distance, not by z."""
    mv = _with_values([(10.0, 0.1), (3.9, 2.0), (4.5, 0.05), (3.5, 0.01), (178.0, 17.0)])
    (s,) = mv.numbers_summary()
    pub = mv.published[0]
    assert abs(mv.distance(pub, mv.universes[1])) < abs(mv.distance(pub, mv.universes[3]))   # by z, noisy would win
    assert s["closest_status"] == "found" and s["closest"]["universe"] == 3
    assert s["closest"]["relative_distance"] == pytest.approx(0.32 / 3.82)
    assert s["precision"] == PRECISION and s["n_precise"] == len(mv.universes) - 2     # 1 and 4 are too noisy
    tm = mv.table_match()[0]
    assert tm["best_universe"] == 3 and tm["best_rms_relative"] == pytest.approx(0.32 / 3.82)
    assert tm["n_excluded_imprecise"] == 2
    assert tm["best_sum"] == pytest.approx(mv.distance(pub, mv.universes[3]) ** 2)


def test_none_precise_enough():
    mv = _with_values([(3.9, 2.0)] + [(178.0, 17.0)] * (len(SPACE.star()) - 1))
    (s,) = mv.numbers_summary()
    assert s["closest"] is None and s["closest_status"] == "none precise enough" and s["n_precise"] == 0
    tm = mv.table_match()[0]
    assert tm["best_universe"] is None and tm["best_describe"].startswith("none precise enough")
    # a printed 0: precision and distance refer to half a unit of the last digit (0.005 for '0.00')
    zero = PublishedNumber("Table S", "S", "alg", "x", "0.00")
    mv = Multiverse(mv.space, mv.design, mv.universes, (zero,), 4)
    u = UniverseResult.build(values=[("S", "alg", "x", 0.001, 0.0004)], claims=[], diverged={}, n_runs=4)
    assert mv.precise(zero, u) and mv.relative_distance(zero, u) == pytest.approx(0.2)


# -- joint tests ------------------------------------------------------------------------------------------------
def test_a_reproduced_cell_in_a_failing_row_is_isolated():
    """Two cells of one row: one within 0.5 sigma (reproduced on its own), one 10 sigma away.  Sum z^2 = 100.25 on
    2 degrees of freedom fails (tail exp(-50) < 2 Phi(-3)), so the first cell is *reproduced (isolated)*: not
    counted in n_reproduced, counted in n_isolated.  Alone, the same cell passes and is reproduced."""
    pubs = (PublishedNumber("Table J", "J", "alg", "a", "10.00"), PublishedNumber("Table J", "J", "alg", "b", "10.00"))
    d = SPACE.design("star")
    base = UNIVERSES[tuple(SPACE.headline.values())]
    # the verdict rule's sigma: ours, the paper's (4 vs 100 runs) and half a unit of the printed last digit
    sigma = math.sqrt(0.1 ** 2 * (1 + 4 / 100) + 0.005 ** 2)
    bad = UniverseResult.build(values=[("J", "alg", "a", 10.0 + 0.5 * sigma, 0.1), ("J", "alg", "b", 10.0 + 10 * sigma,
                                                                                    0.1)],
                               claims=base.claims, diverged={}, n_runs=4)
    mv = Multiverse(SPACE, d, [bad] * len(d), pubs, 4, 100)
    a, b = mv.numbers_summary()
    assert a["headline_verdict"] == report.ISOLATED and a["isolated"] is True
    assert a["n_reproduced"] == 0 and a["n_isolated"] == a["n_counted"] == len(d)
    assert a["joint_test"]["row"]["statistic"] == pytest.approx(100.25, rel=1e-6)
    assert a["joint_test"]["row"]["dof"] == 2 and a["joint_test"]["row"]["passes"] is False
    assert b["headline_verdict"] == report.QUALITATIVE and b["n_isolated"] == 0     # 10 % off: not isolated
    tm = mv.table_match()[0]
    assert tm["isolated"] == 1 and tm["headline_n_reproduced"] == 0 and tm["most_n_reproduced"] == 0
    assert tm["n_passing"] == 0
    alone = Multiverse(SPACE, d, [bad] * len(d), pubs[:1], 4, 100)
    (a,) = alone.numbers_summary()
    assert a["headline_verdict"] == report.REPRODUCED and a["n_reproduced"] == len(d) and a["n_isolated"] == 0
