"""The arena (mmlib.arena): the recipe registry, paper cells against the papers' own evaluations, consistency
metrics, the controlled ladder's computed nonlinearity index, ranks, bad input and the study runner."""
import math
from dataclasses import replace

import numpy as np
import pytest

from conftest import raises_naming
from mmlib import MonteCarlo
from mmlib.arena import ladder, recipes, study
from mmlib.core import models
from mmlib.core.estimation import SingleModel, normalised_square, run
from mmlib.core.filters import ExtendedKalmanFilter, SigmaPointFilter
from mmlib.core.rules import Cubature
from mmlib.experiment import evaluation, metrics, report
from mmlib.papers import REGISTRY, hu2017

EPS = np.finfo(float).eps


def cell_runset(algorithm, s, mc, **kw) -> evaluation.RunSet:
    """The RunSet of an arena cell (evaluate_cell also returns the CPU seconds, which no test reads)."""
    return study.evaluate_cell(algorithm, s, mc, **kw)[0]


def cell_metrics(rs, s) -> dict:
    return study.cell_metrics(rs, s, 0.0)


def estimator_for_every_run(s, est, mc):
    """make_batch for a hand-built estimator on scenario ``s``'s runs (start means and P0 of the scenario)."""
    return evaluation.with_initial_states(s.simulator(mc), {"x": est}, lambda e, start, runs: e.init(start, s.P0))


# ================================================================================================ 1. registry
@pytest.mark.parametrize("name", study.SCENARIOS)
def test_every_cell_is_built_or_refused_with_its_reason(name):
    s = study.scenario(name)
    for alg in recipes.ALGORITHMS:
        reason = recipes.applicability(alg, s)
        assert isinstance(reason, str)
        if reason == "":
            est = recipes.build(alg, s)
            assert est.name == alg
            assert callable(getattr(est, "init", None)) and callable(getattr(est, "step", None))
        else:
            assert reason.strip(), (alg, name)
            with pytest.raises(recipes.NotApplicable) as info:
                recipes.build(alg, s)
            assert reason in str(info.value)
            assert isinstance(info.value, ValueError)          # NotApplicable is a ValueError


IMM_ALGORITHMS = ("IMM5CKF", "IMMCKF", "IMMUKF", "IMMEKF", "IMMCDKF", "IMMCDKF-OBS", "IMM-NAUKF", "CPIMM-UKF",
                  "CPIMM-NAUKF")
SINGLE_ALGORITHMS = ("5CKF", "NAUKF", "AUKF", "SSRCKF", "STF", "STUKF", "STCKF", "STSSRCKF", "EKF", "CKF", "UKF")


def test_expected_applicabilities():
    liu, hu = study.scenario("liu2017"), study.scenario("hu2017")
    for alg in IMM_ALGORITHMS:                        # Liu & Wu define no mode set
        assert recipes.applicability(alg, liu).startswith("needs an IMM mode set"), alg
        assert recipes.applicability(alg, hu) == "", alg
        assert recipes.applicability(alg, study.scenario("ladder-linear")).startswith("needs an IMM mode set")
    for alg in SINGLE_ALGORITHMS:                     # Hu et al. define no single motion model
        assert recipes.applicability(alg, hu).startswith("needs a single motion model"), alg
        assert recipes.applicability(alg, liu) == "", alg
    where = [name for name in study.SCENARIOS if recipes.applicability("FUZZY-IMMUKF", study.scenario(name)) == ""]
    assert where == ["tseng2011"]
    # every algorithm applies to the radar rungs of the ladder except the GNSS-only fuzzy IMM
    nl = study.scenario("ladder-nl3")
    assert [a for a in recipes.ALGORITHMS if recipes.applicability(a, nl)] == ["FUZZY-IMMUKF"]


def test_aliases_resolve_to_one_recipe():
    s = study.scenario("zhou2017")
    assert recipes.ALIASES["IMM-UKF"] == "IMMUKF"
    for alias, name in recipes.ALIASES.items():
        assert recipes.recipe(alias) is recipes.recipe(name)
        assert alias not in recipes.ALGORITHMS and name in recipes.ALGORITHMS
        assert recipes.applicability(alias, s) == recipes.applicability(name, s) == ""
        assert recipes.build(alias, s).name == name


def test_unknown_algorithm_and_scenario_list_the_known_names():
    s = study.scenario("ladder-nl1")
    for call in (lambda: recipes.recipe("nope"), lambda: recipes.build("nope", s),
                 lambda: recipes.applicability("nope", s)):
        with raises_naming("algorithm") as info:
            call()
        assert "'nope'" in str(info.value)
        assert all(a in str(info.value) for a in recipes.ALGORITHMS)
    with raises_naming("scenario") as info:
        study.scenario("nope")
    assert all(name in str(info.value) for name in study.SCENARIOS)


# ================================================================= 2. a paper's cell is the paper's own evaluation
@pytest.mark.parametrize("name", study.paper_names())         # controls take no part
def test_every_arena_entry_names_recipes(name):
    entry = REGISTRY[name].arena
    assert entry is not None and entry.algorithms, name
    assert set(entry.algorithms) <= set(recipes.ALGORITHMS), name
    assert {x for _, a, b in entry.ideas for x in (a, b)} <= set(recipes.ALGORITHMS), name
    assert {x for pair in entry.claim_pairs for x in pair} <= set(recipes.ALGORITHMS), name


@pytest.mark.parametrize("name", study.paper_names())         # controls take no part
def test_paper_cell_equals_the_papers_own_evaluation_bit_for_bit(name):
    """Every registered paper's arena cell is the paper's own evaluation of its headline batch (``Paper.batch``):
    the same runs, models and initial states, so the same bits, for every estimator the arena also runs."""
    paper = REGISTRY[name]
    if paper.arena is None:
        pytest.skip(f"{name} declares no arena entry")
    s = study.scenario(name)
    if name == "hu2017":           # the arena runs Hu et al.'s km set-up in metres: equal to round-off, tested below
        pytest.skip("a rescaling to metres: test_hu2017_cell_is_the_papers_evaluation_in_metres")
    n = 8 if s.n_steps <= 500 else 3                   # the 1800-epoch GNSS scenario: 3 runs
    mc = MonteCarlo(paper.root_seed, n)
    make_batch, estimators, *models = paper.batch(paper.arena_setup(), mc)
    # every estimator of the batch that the paper's arena entry runs (by its recipe name or an alias)
    algs = [a for a in estimators if recipes.ALIASES.get(a, a) in paper.arena.algorithms]
    assert algs, f"{name}: no estimator of the paper's batch is one of its arena algorithms"
    own = evaluation.evaluate({a: estimators[a] for a in algs}, make_batch, mc, progress=False, workers=1,
                              measurement_models=models[0] if models else None)
    for alg in algs:
        rs = cell_runset(recipes.ALIASES.get(alg, alg), s, mc, consistency=False)
        # the same runs, models and initial states: exact equality (NaN where a run diverged, e.g. Zhou's NAUKF)
        assert np.array_equal(rs.errors, own[alg].errors, equal_nan=True), alg
        assert np.array_equal(rs.diverged_step, own[alg].diverged_step), alg
        assert (rs.mode_probabilities is None) == (own[alg].mode_probabilities is None), alg
        if rs.mode_probabilities is not None:
            assert np.array_equal(rs.mode_probabilities, own[alg].mode_probabilities, equal_nan=True), alg


#: |arena error (m) - 1000 x paper error (km)| <= RTOL x the largest |true state component| of the run (m).
#: The arena runs Hu et al.'s set-up in metres: x0, sigma_r, P0 and q are multiplied by 1000 (1e6), which is not a
#: power of two, so every input differs from an exact rescaling by up to half an ulp (1.1e-16 relative).  In exact
#: arithmetic the filters are scale-equivariant (bearing is scale-free, the range and every length scale by 1000),
#: so what remains is round-off relative to the state's magnitude (an error is a difference of ~15 km quantities,
#: hence the scale is |x|, not |error|).  Plain sigma-point / extended IMMs propagate it without growth: measured
#: 1.2e-15 (about five ulps of eps = 2.2e-16); 1e-13 leaves a factor ~100 for a different BLAS.  The
#: observation-bootstrap IMM fuses its N + 1 posteriors by an inverse of a sum of inverses into an over-confident
#: covariance, and its round-off grows by ~1.45 per step (measured: 7e-12 m at the first step, 5e-7 m by step 30
#: of 35, 2.3e-10 relative);
#: 1e-8 keeps a factor ~40, and any modelling difference (another q, R, P0 or start) would move the errors by
#: metres, i.e. ~1e-4 of the state, orders of magnitude above it.
HU_RTOL = {"IMMUKF": 1e-13, "IMMEKF": 1e-13, "IMMCKF": 1e-13, "IMMCDKF": 1e-13, "IMMCDKF-OBS": 1e-8}


def test_hu2017_cell_is_the_papers_evaluation_in_metres():
    n = 8
    paper = REGISTRY["hu2017"]
    mc = MonteCarlo(paper.root_seed, n)
    make_batch, estimators = hu2017.setup.batch(paper.headline_setup(), mc, names=tuple(HU_RTOL))
    own = evaluation.evaluate(estimators, make_batch, mc, progress=False, workers=1)
    truth_km = make_batch(range(n))[0]
    scale_m = 1000.0 * np.abs(truth_km).max(axis=(1, 2))                    # (N,) per run
    s = study.scenario("hu2017")
    for alg, rtol in HU_RTOL.items():
        rs = cell_runset(alg, s, mc, consistency=False)
        assert np.array_equal(rs.diverged_step, own[alg].diverged_step), alg
        assert rs.valid.all(), alg
        gap = np.abs(rs.errors - 1000.0 * own[alg].errors).max(axis=(1, 2))
        assert np.all(gap <= rtol * scale_m), (alg, (gap / scale_m).max())
        # and it is a real comparison: the errors are of order 100 m, far above the tolerance
        assert np.abs(rs.errors).max() > 10.0


# ================================================================================================ 3. consistency
@pytest.fixture(scope="module")
def linear_cells():
    """The KF (the EKF on a linear sensor) on ladder-linear over 400 runs, and the same KF told 4R, by hand."""
    s = study.scenario("ladder-linear")
    mc = MonteCarlo(s.root_seed, 400)
    rs = cell_runset("EKF", s, mc)
    kf = lambda R: SingleModel(ExtendedKalmanFilter(name="KF"), s.single, models.position_measurement(R), name="KF")
    own = {f: evaluation.evaluate({"x": kf(f * s.measurement.R)}, estimator_for_every_run(s, kf(f * s.measurement.R),
                                                                                           mc),
                                  mc, progress=False, consistency=True, workers=1)["x"] for f in (1.0, 4.0)}
    return s, rs, own


def test_hand_built_kf_is_the_registry_ekf(linear_cells):
    s, rs, own = linear_cells
    # the inconsistent filter below differs from the registry's EKF cell only in R: with R unchanged, same bits
    assert np.array_equal(own[1.0].errors, rs.errors)
    assert np.array_equal(own[1.0].nees, rs.nees) and np.array_equal(own[1.0].nis, rs.nis)


def test_kalman_filter_is_consistent_on_the_linear_rung(linear_cells):
    s, rs, _ = linear_cells
    m = cell_metrics(rs, s)
    assert m["diverged"] == 0
    N = rs.errors.shape[0]
    for key, dof in (("anees", s.dim), ("anis", 2)):
        c = m[key]
        assert c["dof"] == dof and c["n_runs"] == N
        # the band holds a run-average at one step with probability 0.95; the time average varies less
        lo, hi = c["band"]
        assert lo < dof < hi
        assert lo <= c["value"] <= hi, (key, c)
    # NIS of a consistent KF: innovations white, each run's time average is chi2(m K)/K exactly, so the fraction
    # of runs inside the per-run band is binomial(N, 0.95) / N: 0.95 +- 3 sqrt(0.95 0.05 / N) (+-0.033 at N = 400)
    half = 3.0 * math.sqrt(0.95 * 0.05 / N)
    assert abs(m["anis"]["runs_inside"] - 0.95) <= half, m["anis"]


def test_filter_told_four_times_the_sensor_noise_is_outside_the_band(linear_cells):
    s, _, own = linear_cells
    m = cell_metrics(own[4.0], s)
    # told 4R, the filter over-states its uncertainty: NIS and NEES far below their dof (measured ANIS 0.72,
    # ANEES 2.4 against bands ~[1.81, 2.20] and ~[3.73, 4.28])
    for key in ("anees", "anis"):
        lo, hi = m[key]["band"]
        assert m[key]["value"] < lo, (key, m[key])
        assert m[key]["inside"] is False
    half = 3.0 * math.sqrt(0.95 * 0.05 / own[4.0].errors.shape[0])
    assert m["anis"]["runs_inside"] < 0.95 - half


def test_run_records_the_nees_of_its_covariances():
    s = study.scenario("ladder-nl3")
    n = 6
    mc = MonteCarlo(s.root_seed, n)
    truth, z, start = s.simulator(mc)(range(n))
    est = recipes.build("IMMUKF", s)
    state = recipes.initial_state(est, s, start, range(n), mc)
    tr = run(est, state, z, consistency=True, truth=truth)
    assert tr.nees.shape == tr.nis.shape == (n, s.n_steps) and not tr.diverged.any()
    assert np.array_equal(tr.nis_dof, np.full(s.n_steps, 2))
    ref = metrics.nees(tr.mean - truth[:, 1:], tr.cov)
    # the same quadratic form solved per matrix vs in one batch: LAPACK round-off only (NEES ~ 4, condition
    # numbers of P below ~1e4 here: relative differences ~1e-15; 1e-12 leaves margin)
    np.testing.assert_allclose(tr.nees, ref, rtol=1e-12, atol=0)
    # computed on the fly: the same bits without keeping the covariances, and with truth given as x_1..x_K
    tr2 = run(est, state, z, consistency=True, truth=truth[:, 1:], keep_cov=False)
    assert tr2.cov is None
    assert np.array_equal(tr2.nees, tr.nees) and np.array_equal(tr2.nis, tr.nis)
    with raises_naming("truth"):
        run(est, state, z, truth=truth)                          # the NEES needs consistency=True


def test_normalised_square_hand_computed_and_nan_where_undefined():
    v = np.array([1.0, 2.0])
    S = np.array([[2.0, 1.0], [1.0, 3.0]])
    # S^-1 = [[3, -1], [-1, 2]] / 5, v^T S^-1 v = (3 - 4 + 8) / 5 = 1.4; a 2x2 LU solve: a few ulps
    assert normalised_square(v, S) == pytest.approx(1.4, rel=1e-14, abs=0)
    singular = np.array([[1.0, 1.0], [1.0, 1.0]])
    vs = np.stack([v, v, v, [np.nan, 1.0], v])
    Ss = np.stack([S, singular, np.array([[np.inf, 0.0], [0.0, 1.0]]), S, 2.0 * S])
    out = normalised_square(vs, Ss)                 # one singular matrix in the batch: solved one by one
    assert out.shape == (5,)
    assert out[0] == pytest.approx(1.4, rel=1e-14, abs=0) and out[4] == pytest.approx(0.7, rel=1e-14, abs=0)
    assert np.isnan(out[1:4]).all()
    # leading axes are kept (runs, steps)
    assert normalised_square(np.broadcast_to(v, (2, 3, 2)), np.broadcast_to(S, (2, 3, 2, 2))).shape == (2, 3)
    assert np.isnan(normalised_square(v, singular))


# ================================================================================================ 4. ladder
@pytest.mark.parametrize("name", ["ladder-linear", "zhu2016"])
def test_nonlinearity_index_is_zero_for_a_linear_sensor(name):
    s = study.scenario(name)
    assert not s.nonlinear_measurement
    idx = ladder.nonlinearity_index(s, 20)
    # b = E[Hx] - H E[x] is zero in exact arithmetic; in floating point it is the round-off of a weighted sum of the
    # fifth-degree rule's points at the size of the measurement, a few eps |z|, and eta is b in units of the
    # innovation s.d. >= the sensor's smallest s.d.  Measured (p90): 1.2 eps |z| / sigma on ladder-linear, 0.11
    # on zhu2016; 16 leaves a factor > 10.  (Against 1.8e-3 on the least nonlinear radar rung.)
    z = s.simulator(MonteCarlo(s.root_seed, idx["n_runs"]))(range(idx["n_runs"]))[1]
    sigma_min = math.sqrt(np.linalg.eigvalsh(s.measurement.R).min())
    bound = 16 * EPS * np.abs(z).max() / sigma_min
    assert 0 <= idx["median"] <= idx["p90"] <= bound, (idx, bound)
    assert idx["n_runs"] == 20


NL_RUNGS = tuple(f"ladder-nl{i}" for i in range(1, 7))


def test_nonlinearity_index_increases_along_the_ladder():
    assert [n for n in ladder.NAMES if ladder.rung(n).axis == "nonlinearity"] == list(NL_RUNGS)
    med = [ladder.nonlinearity_index(study.scenario(n))["median"] for n in NL_RUNGS]
    assert all(a < b for a, b in zip(med, med[1:])), med
    assert med[0] < 0.005 and med[-1] > 0.2, med


@pytest.mark.parametrize("name", ["ladder-nl1", "ladder-nl2", "ladder-nl3"])
def test_nonlinearity_index_agrees_with_the_small_spread_closed_form(name):
    """Around the predicted mean at range r, with radial offset a and cross-range offset c,
    range = r + a + c^2/(2r) + ... and bearing = theta + c/r - a c/r^2 + ..., so the second-order mean gap is
    b = [sigma_c^2 / (2r), -P_ac / r^2] with sigma_c^2 the predicted cross-range variance and P_ac the radial-cross
    covariance; with the linearised S = H P H^T + R, eta = sqrt(b^T S^-1 b).  The neglected terms are relatively
    O(sigma_c^2 / r^2) in b (the fourth-order range term) and O(sigma_c^4 / (2 r^2 S_rr)) in S (the variance of the
    quadratic term), so per step |eta_closed / eta - 1| <~ eps_k = sigma_c^2/r^2 + sigma_c^4/(2 r^2 S_rr); every
    quantile of the closed forms then agrees with that of the index within max_k eps_k (a ratio bound per element
    bounds the ratio of order statistics).  The test asserts the small-spread premise (max eps < 0.01) too."""
    s = study.scenario(name)
    n = 20
    idx = ladder.nonlinearity_index(s, n)
    # the index's own loop (the scenario's first n runs, a CKF on its single model), with the closed form per step
    mc = MonteCarlo(s.root_seed, n)
    _, z, start = s.simulator(mc)(range(n))
    ckf = SigmaPointFilter(Cubature())
    state = ckf.init(start, s.P0)
    R = s.measurement.R
    closed, eps = [], []
    for k in range(s.n_steps):
        state = ckf.predict(state, s.single)
        x, P = state.mean, state.cov
        p = x[:, [0, 2]]
        Pp = P[:, [0, 2]][:, :, [0, 2]]
        r = np.linalg.norm(p, axis=1)
        u = p / r[:, None]                                   # radial unit vector
        v = np.stack([-u[:, 1], u[:, 0]], axis=1)            # cross-range unit vector
        s_cc = np.einsum("bi,bij,bj->b", v, Pp, v)
        s_ac = np.einsum("bi,bij,bj->b", u, Pp, v)
        b = np.stack([s_cc / (2 * r), -s_ac / r ** 2], axis=1)
        H = np.zeros((n, 2, 4))
        H[:, 0, [0, 2]] = u
        H[:, 1, [0, 2]] = v / r[:, None]
        S = H @ P @ np.swapaxes(H, 1, 2) + R
        closed.append(np.sqrt(np.einsum("bi,bi->b", b, np.linalg.solve(S, b[..., None])[..., 0])))
        eps.append(s_cc / r ** 2 + s_cc ** 2 / (2 * r ** 2 * S[:, 0, 0]))
        state, _ = ckf.update(state, z[:, k], s.measurement)
    closed, eps_max = np.array(closed), float(np.max(eps))
    assert eps_max < 0.01, eps_max
    assert idx["median"] == pytest.approx(float(np.median(closed)), rel=eps_max, abs=0), (idx, eps_max)
    assert idx["p90"] == pytest.approx(float(np.quantile(closed, 0.9)), rel=eps_max, abs=0), (idx, eps_max)


# ================================================================================================ 5. ranks
def _cells(**per_run):
    return {a: {"per_run": {"position_mse": [None if (v is None or np.isnan(v)) else float(v) for v in vals]}}
            for a, vals in per_run.items()}


def test_rank_a_clearly_worse_algorithm_and_a_tie():
    rng = np.random.default_rng(7)
    base = 100.0 + rng.normal(0, 10, 30)
    # B is A plus 50 m^2 +- 1: paired difference 50 +- 0.2, hundreds of standard errors; C is A exactly
    worse = base + 50.0 + rng.normal(0, 1, 30)
    ranks = study.rank_scenario(_cells(A=base, B=worse, C=base.copy()))
    assert ranks["B"]["rank"] == 3 and ranks["B"]["versus_best"]["verdict"] == "worse"
    assert ranks["A"]["rank"] == ranks["C"]["rank"] == 1
    best = ranks["A"]["versus_best"]["algorithm"]
    assert best in ("A", "C")
    other = "C" if best == "A" else "A"
    assert ranks[best]["versus_best"]["verdict"] == "best"
    # C is A exactly: a difference of 0 with standard error 0 is an identity, not "no detectable difference"
    assert ranks[other]["versus_best"]["verdict"] == "identical (to round-off)"
    # the paired difference on all 30 runs (float64 sums in another order: round-off, 1e-12)
    assert ranks["B"]["versus_best"]["difference_m2"] == pytest.approx(float(np.mean(worse - base)), rel=1e-12)


def test_rank_leaves_cells_with_diverged_runs_unranked():
    rng = np.random.default_rng(11)
    base = 100.0 + rng.normal(0, 10, 20)
    b = base + 5.0 + rng.normal(0, 0.5, 20)
    d = base - 50.0                               # far better on the runs it survives...
    d[0] = np.nan                                 # ... but it diverged in run 0: compared on other runs than A, B
    ranks = study.rank_scenario(_cells(A=base, B=b, D=d))
    assert ranks["D"] == {"rank": None, "versus_best": None}
    vb = ranks["B"]["versus_best"]
    assert vb["algorithm"] == "A" and vb["verdict"] == "worse" and ranks["B"]["rank"] == 2 and ranks["A"]["rank"] == 1
    diff = b - base                               # paired over all 20 runs
    assert vb["difference_m2"] == pytest.approx(float(diff.mean()), rel=1e-12)
    assert vb["stderr_m2"] == pytest.approx(float(diff.std(ddof=1) / math.sqrt(20)), rel=1e-12)


def test_rank_treats_round_off_differences_as_ties():
    """Algorithms that coincide (every rule on a linear model) differ by round-off, which can be many standard errors
    of a paired difference that is itself round-off: within the round-off floor (report.identity_floor: 2^26 eps, 1.5e-8
    of the best one's MSE) it is "identical (to round-off)", never an effect; a 1e-6 relative difference is far above
    the floor (a genuine, detectable but negligible difference) and keeps the tie only by the 1 % negligibility."""
    rng = np.random.default_rng(5)
    base = 100.0 + rng.normal(0, 10, 50)
    nudged = base * (1 + 1e-12) + 1e-13 * rng.normal(0, 1, 50)        # ~1e-12 relative, ~1e3 standard errors
    ranks = study.rank_scenario(_cells(A=base, B=nudged, C=base + 30.0))
    assert ranks["A"]["rank"] == ranks["B"]["rank"] == 1
    assert ranks["C"]["rank"] == 3
    loser = "B" if ranks["A"]["versus_best"]["verdict"] == "best" else "A"
    assert ranks[loser]["versus_best"]["verdict"] == "identical (to round-off)"
    assert ranks["C"]["versus_best"]["verdict"] == "worse"
    # 1e-6 relative (66 times the floor), ~1e3 standard errors: detected, negligible, not an identity
    far = base * (1 + 1e-6) + 1e-7 * rng.normal(0, 1, 50)
    ranks = study.rank_scenario(_cells(A=base, B=far))
    assert ranks["A"]["rank"] == ranks["B"]["rank"] == 1
    assert ranks["B"]["versus_best"]["verdict"] == "worse, but negligible (< 1 %)"


def test_consistency_summary_of_chi_square_draws():
    rng = np.random.default_rng(2024)
    N, K, dof = 300, 200, 3
    stat = rng.chisquare(dof, (N, K))
    stat[7, 50:] = np.nan                        # a diverged run, excluded by ok
    ok = np.ones(N, dtype=bool)
    ok[7] = False
    c = study.consistency(stat, dof, ok, white=True)
    assert c["n_runs"] == N - 1 and c["dof"] == dof
    # white draws: the mean of (N-1) K chi2(dof) values has s.d. sqrt(2 dof / ((N-1) K)) = 0.0058
    assert abs(c["value"] - dof) <= 4 * math.sqrt(2 * dof / ((N - 1) * K)), c
    assert c["stderr"] == pytest.approx(math.sqrt(2 * dof / ((N - 1) * K)), rel=0.2)   # its own estimate (+-~8 %)
    # steps (runs) inside are independent 0.95-events: binomial, within 3 sigma
    assert abs(c["steps_inside"] - 0.95) <= 3 * math.sqrt(0.95 * 0.05 / K), c
    assert abs(c["runs_inside"] - 0.95) <= 3 * math.sqrt(0.95 * 0.05 / (N - 1)), c
    assert c["inside"] is True
    # a per-step dof (e.g. satellites in view) is accepted, and scaled statistics fall outside
    dofs = np.where(np.arange(K) < K // 3, 2, 4)                     # mean 3.33, median 4
    c2 = study.consistency(rng.chisquare(dofs, (N, K)), dofs, np.ones(N, dtype=bool), white=True)
    assert abs(c2["steps_inside"] - 0.95) <= 3 * math.sqrt(0.95 * 0.05 / K), c2
    assert study.consistency(2.0 * stat, dof, ok, white=True)["inside"] is False
    assert study.consistency(stat[:1], dof, ok[:1], white=True)["value"] is None     # one run: no standard error
    # the band of white statistics is the exact one of the run-and-time average: sqrt(K) narrower than a step's
    lenient = study.consistency(stat, dof, ok, white=False)
    assert (lenient["band"][1] - lenient["band"][0]) > 0.8 * math.sqrt(K) * (c["band"][1] - c["band"][0])
    # per-step dof: centred on the mean dof, not the median
    assert c2["dof"] == pytest.approx(float(dofs.mean()))


# ================================================================================================ 6. bad input
def test_run_arena_bad_input_names_the_argument():
    with raises_naming("n_runs"):
        study.run_arena(1)
    with raises_naming("n_runs"):
        study.run_arena(2.5)
    with raises_naming("scenarios") as info:
        study.run_arena(10, scenarios=["nope"])
    assert "ladder-nl1" in str(info.value)
    with raises_naming("algorithms") as info:
        study.run_arena(10, algorithms=["nope"])
    assert "IMMUKF" in str(info.value)
    for kw, name in ((dict(scenarios="ladder-nl1"), "scenarios"), (dict(scenarios=[]), "scenarios"),
                     (dict(algorithms="EKF"), "algorithms"), (dict(algorithms=["IMM-UKF", "IMMUKF"]), "algorithms"),
                     (dict(scenarios=["zhu2016", "zhu2016"]), "scenarios"), (dict(seed="abc"), "seed"),
                     (dict(seed=-1), "seed")):
        with raises_naming(name):
            study.run_arena(10, **kw)
    with raises_naming("scenario"):
        study.scenario(["zhu2016"])


def test_shared_scenarios_are_read_only():
    s = study.scenario("ladder-nl2")
    with pytest.raises(ValueError):
        s.P0[0, 0] = 1.0
    with pytest.raises(ValueError):
        s.transition[0, 0] = 1.0
    with pytest.raises(TypeError):
        s.properties["axis"] = "x"


def test_normalised_square_does_not_depend_on_a_singular_neighbour():
    rng = np.random.default_rng(3)
    A = rng.normal(size=(50, 3, 3))
    S = A @ np.swapaxes(A, -1, -2) + 0.1 * np.eye(3)
    v = rng.normal(size=(50, 3))
    alone = normalised_square(v, S)
    S2 = S.copy()
    S2[7] = 0.0                                   # one run's S singular: the batch takes the one-by-one path
    mixed = normalised_square(v, S2)
    assert np.isnan(mixed[7])
    keep = np.arange(50) != 7
    assert np.array_equal(alone[keep], mixed[keep])       # bit for bit


def test_scenario_rejects_an_inconsistent_transition_matrix():
    s = study.scenario("ladder-nl1")
    assert replace(s, transition=s.transition.copy()).transition.shape == (3, 3)       # the control: accepted
    for bad in ([[0.9, 0.05, 0.05], [0.05, 0.9, 0.05], [0.1, 0.1, 0.9]],           # a row sums to 1.1
                [[0.9, 0.1], [0.1, 0.9]],                                          # 2 x 2 for 3 modes
                [[1.1, -0.05, -0.05], [0.05, 0.9, 0.05], [0.05, 0.05, 0.9]]):      # negative entries
        with raises_naming("transition"):
            replace(s, transition=np.array(bad))


# ================================================================================================ 7. the runner
def test_tiny_arena_serial_and_parallel_give_the_same_bits(tmp_path):
    kw = dict(scenarios=["ladder-nl1", "liu2017"], algorithms=["EKF", "IMMUKF", "UKF"], progress=False)
    serial = study.run_arena(4, workers=1, use_cache=False, **kw)
    cells = serial.cells
    assert [(c["scenario"], c["algorithm"]) for c in cells] == \
        [(s, a) for s in ("ladder-nl1", "liu2017") for a in ("EKF", "IMMUKF", "UKF")]
    for c in cells:
        assert c["n_runs"] == 4
        if (c["scenario"], c["algorithm"]) == ("liu2017", "IMMUKF"):
            assert c["reason"].startswith("needs an IMM mode set") and "rmse_position" not in c
        else:
            assert "reason" not in c
            assert c["diverged"] == 0 and c["rmse_position"]["value"] > 0
            assert c["anees"]["n_runs"] == 4 and c["anis"]["dof"] == 2.0
            assert c["rank"] >= 1 and c["versus_best"]["algorithm"] in ("EKF", "IMMUKF", "UKF")
    parallel = study.run_arena(4, workers=2, use_cache=True, cache_dir=tmp_path, **kw)
    strip = (lambda cs: [{k: v for k, v in c.items() if k != "cost_us_per_run_step"} for c in cs])
    assert strip(parallel.cells) == strip(cells)            # exact equality of every float
    assert serial.per_run.keys() == parallel.per_run.keys()
    assert all(np.array_equal(serial.per_run[k], parallel.per_run[k], equal_nan=True) for k in serial.per_run)


# ===================================================================== 8. comparisons, claims, digest, cost
def _result(**per_run):
    """An ArenaResult over one scenario "s" from per-run position MSE vectors (NaN: diverged)."""
    pr = {("s", a): np.asarray(v, dtype=float) for a, v in per_run.items()}
    cells = [{"scenario": "s", "algorithm": a} for a in per_run]
    return study.ArenaResult(cells, pr, len(next(iter(pr.values()))), {})


def test_compare_and_claims_follow_the_one_rule():
    rng = np.random.default_rng(8)
    b = 100.0 + rng.normal(0, 10, 200)
    helps = b - 10.0 + rng.normal(0, 0.5, 200)          # 10 % smaller, ~280 standard errors
    tiny = b * (1 - 1e-3)                                 # 0.1 % smaller: detectable, negligible
    res = _result(B=b, A=helps, T=tiny)
    c = study.compare(res, "A", "B", "s")
    assert c["verdict"] == "helps" and c["claim"] == "holds"
    assert c["verdict"] is study.ArenaVerdict.HELPS and c["claim"] is report.HOLDS       # enums, not prefixes
    # one decisive number: the part "A − B: position MSE, s" with its relative difference and z
    assert c["part"]["comparison"] == "A − B" and c["part"]["quantity"] == "position MSE, s"
    assert c["part"]["unit"] == "m²" and c["part"]["reference"] == pytest.approx(float(b.mean()), rel=1e-12)
    assert c["decisive"] == c["part"]["number"] and c["decisive"].startswith("A − B: position MSE, s -10 % (z = -")
    t = study.compare(res, "T", "B", "s")
    assert t["verdict"] == "helps, but negligible (< 1 %)"
    assert t["claim"] == "not supported"                  # report.judge: a negligible part is not a claim that holds
    assert study.compare(res, "B", "A", "s")["claim"] == "contradicted"
    assert study.compare(res, "A", "nope", "s") is None   # not applicable: no comparison


def test_rules_equal_in_exact_arithmetic_are_identical_in_real_arena_cells():
    """On the linear rung every third- and fifth-degree rule computes the Kalman filter's moments exactly, so 5CKF,
    SSRCKF and CKF are one filter in exact arithmetic: their comparisons are "identical (to round-off)" (the cells'
    paired differences are round-off, or exactly 0); on the most nonlinear rungs the rules differ, and the
    comparison is never an identity there."""
    res = study.run_arena(8, scenarios=["ladder-linear", "ladder-nl5"], algorithms=["CKF", "5CKF", "SSRCKF"],
                          workers=1, use_cache=False, progress=False)
    for a in ("5CKF", "SSRCKF"):
        lin = study.compare(res, a, "CKF", "ladder-linear")
        assert lin["verdict"] == "identical (to round-off)", lin
        assert abs(lin["difference_m2"]) <= report.identity_floor(lin["part"]["reference"])
        nl = study.compare(res, a, "CKF", "ladder-nl5")
        assert nl["verdict"] != "identical (to round-off)", nl
        assert abs(nl["difference_m2"]) > 1e3 * report.identity_floor(nl["part"]["reference"]), nl
    vb = {c["algorithm"]: c["versus_best"]["verdict"] for c in res.cells if c["scenario"] == "ladder-linear"}
    assert sorted(vb.values()) == ["best", "identical (to round-off)", "identical (to round-off)"], vb


def test_compare_calls_algorithms_equal_in_exact_arithmetic_identical():
    """Two algorithms equal in exact arithmetic (the same per-run errors summed in another order, as two sigma-point
    rules on a linear model) are "identical (to round-off)", distinct from "no detectable difference", with no
    z-score; a 1e-6 relative difference is not."""
    rng = np.random.default_rng(9)
    e = rng.normal(0, 10, (200, 30, 2))
    a = (e ** 2).sum(-1).mean(1)
    b = np.einsum("nki,nki->n", e[:, ::-1], e[:, ::-1]) / 30          # the same numbers, another order
    assert not np.array_equal(a, b)                                    # round-off, not bit-equal ...
    assert np.abs(a - b).max() < 1e-12 * a.max()                       # ... and only round-off
    res = _result(A=a, B=b, N=b * (1 + 1e-6), Z=b + rng.normal(0, 1e-3, 200) * b.mean())
    same = study.compare(res, "A", "B", "s")
    assert same["verdict"] == "identical (to round-off)" and same["claim"] == "not supported"
    assert same["part"]["verdict"] == "identical (to round-off)"
    assert "identical to round-off" in same["decisive"] and "z =" not in same["decisive"]
    assert abs(same["difference_m2"]) <= report.identity_floor(float(b.mean()))
    near = study.compare(res, "N", "B", "s")                           # 1e-6 relative: 66 floors
    assert near["verdict"] == "hurts, but negligible (< 1 %)" and "z =" in near["decisive"]
    noisy = study.compare(res, "Z", "B", "s")                          # a zero-mean difference far above round-off
    assert noisy["verdict"] == "no detectable difference" and noisy["verdict"] != same["verdict"]
    # tallied apart
    summary = study.idea_summary({"idea": "x", "paper": "p", "a": "A", "b": "B", "comparisons": [same, noisy]})
    assert summary["by_verdict"] == {"identical (to round-off)": ["s"], "no detectable difference": ["s"]}


def _two_scenarios(**per_scenario):
    """An ArenaResult over scenarios s1, s2 from {scenario: {algorithm: per-run MSE}}."""
    pr = {(sc, a): np.asarray(v, dtype=float) for sc, d in per_scenario.items() for a, v in d.items()}
    cells = [{"scenario": sc, "algorithm": a, "diverged": 0} for sc, a in pr]
    return study.ArenaResult(cells, pr, len(next(iter(pr.values()))), {})


def test_paper_claims_are_one_judgement_over_every_pair_and_scenario():
    """zhu2016's arena claim (IMM5CKF beats IMMCKF and IMMUKF) on s1, where the three coincide to round-off, and s2,
    where IMM5CKF is 20 % better: one verdict (partly) from the flat list of four parts, the decisive part an
    identity, the identity distinct from "no detectable difference" in the parts, the pairs and the findings."""
    rng = np.random.default_rng(4)
    e = rng.normal(0, 10, (60, 20, 2))
    base = (e ** 2).sum(-1).mean(1)
    reordered = np.einsum("nki,nki->n", e[:, ::-1], e[:, ::-1]) / 20
    better = 0.8 * base + rng.normal(0, 0.5, 60)
    res = _two_scenarios(s1={"IMM5CKF": base, "IMMCKF": reordered, "IMMUKF": base.copy()},
                         s2={"IMM5CKF": better, "IMMCKF": base, "IMMUKF": reordered})
    pcs = {pc["paper"]: pc for pc in study.paper_claims(res)}
    zhu = pcs["zhu2016"]
    assert zhu["verdict"] == "partly" and len(zhu["parts"]) == 4
    assert zhu["decisive"].startswith("2 of 4 hold; ") and "identical to round-off" in zhu["decisive"]
    assert [p["verdict"] for p in zhu["parts"]] == ["identical (to round-off)", "holds"] * 2
    assert [p["quantity"] for p in zhu["parts"]] == ["position MSE, s1", "position MSE, s2"] * 2
    for pair in zhu["pairs"]:
        assert pair["part_verdicts"] == {"s1": "identical (to round-off)", "s2": "holds"}
        assert pair["verdicts"] == {"s1": "not supported", "s2": "holds"}
    # a paper none of whose pairs applies: not assessable, with the reason
    assert pcs["hu2017"]["verdict"] == "not assessable" and pcs["hu2017"]["parts"] == []
    # the same judgements as a Claims collection (claims_table / claim_matrix)
    cl = {c["claim"]: c for c in study.arena_claims(res).as_list()}
    mine = cl[f"{REGISTRY['zhu2016'].arena.claim} (zhu2016, across the arena)"]
    assert (mine["verdict"], mine["decisive"], mine["parts"]) == (zhu["verdict"], zhu["decisive"], zhu["parts"])
    rows = [{"scenario": sc, "nonlinearity_index": {"median": 0.0}, "properties": {}} for sc in ("s1", "s2")]
    text = "\n".join(study.findings(res, rows))
    assert "**zhu2016's claim**" in text and "**partly**" in text
    assert "identical (to round-off) in 1 (s1)" in text and "no detectable difference" not in text


def test_compare_divergence_needs_detectably_more_diverged_runs():
    b = np.full(100, 50.0) + np.arange(100) * 0.01
    few = b.copy()
    few[:2] = np.nan                                      # 2 against 0: within Poisson noise (3 sqrt(2) = 4.2)
    many = b.copy()
    many[:20] = np.nan                                    # 20 against 0: detectable
    res = _result(B=b, F=few, M=many)
    assert study.compare(res, "F", "B", "s")["verdict"] != "diverges"
    m = study.compare(res, "M", "B", "s")
    assert m["verdict"] == "diverges" and m["claim"] == "contradicted"
    # the decisive part is the divergence (20 ± sqrt(20) runs: z = 4.5), not the position MSE
    assert m["part"]["quantity"] == "diverged runs, s" and m["part"]["verdict"] == "contradicted"
    assert m["part"]["difference"] == 20 and m["part"]["stderr"] == pytest.approx(math.sqrt(20))


def test_digest_is_a_prefix_property_and_covers_every_per_run_number():
    kw = dict(scenarios=["ladder-nl1"], algorithms=["EKF", "IMMUKF"], workers=1, use_cache=False, progress=False)
    short, long = study.run_arena(4, **kw), study.run_arena(7, **kw)
    assert study.digest(short, 4) == study.digest(long, 4)
    assert study.digest(long, 5) != study.digest(long, 4)
    changed = {k: dict(v) for k, v in long.details.items()}
    key = ("ladder-nl1", "EKF")
    changed[key]["nis"] = [x * (1 + 1e-15) if x is not None else None for x in changed[key]["nis"]]
    assert study.digest(long._replace(details=changed), 4) != study.digest(long, 4)     # the NIS is digested
    with raises_naming("n_runs"):
        study.digest(long, 8)


def test_cost_is_measured_on_per_step_sensors():
    s = study.scenario("tseng2011")
    mc = MonteCarlo(s.root_seed, 2)
    est = recipes.build("UKF", s)
    make_batch = evaluation.with_initial_states(s.simulator(mc), {"UKF": est},
                                                lambda e, start, runs: recipes.initial_state(e, s, start, runs, mc))
    cost = study.cost_per_run_step(est, make_batch, s, 2)
    assert 0 < cost < 1e-2                                # seconds per run-step: positive and finite


@pytest.mark.parametrize("name, cost_steps", [("tseng2011", None), ("ladder-nl1", None), ("tseng2011", 5),
                                              ("ladder-nl1", 5)])
def test_cost_warm_up_is_one_run_over_the_first_steps_then_the_first_cost_steps_are_timed(name, cost_steps,
                                                                                           monkeypatch):
    """The untimed warm-up steps one run over WARM_UP_STEPS steps (not the whole run: its per-step Python cost was as
    large as the timed run's at a few runs), the timed run every run over the first COST_STEPS steps (tseng2011: 200
    of 1800; 5 when set so, which cuts the ladder rung's 100 too) or every step of a shorter scenario (a ladder rung:
    100); with per-step sensors (tseng2011) and one sensor (a ladder rung).  The time, from a fake thread clock, is
    divided by the runs and the steps timed."""
    import time
    if cost_steps is not None:
        monkeypatch.setattr(study, "COST_STEPS", cost_steps)
    s = study.scenario(name)
    mc = MonteCarlo(s.root_seed, 3)
    inner = recipes.build("UKF", s)
    make_batch = evaluation.with_initial_states(s.simulator(mc), {"UKF": inner},
                                                lambda e, start, runs: recipes.initial_state(e, s, start, runs, mc))
    batches = []

    class Counting:                  # the estimator protocol, recording the runs of every step it is asked to take
        name = inner.name

        def init(self, *args, **kwargs):
            return inner.init(*args, **kwargs)

        def step(self, state, z, **kwargs):
            batches.append(np.shape(z)[0])
            return inner.step(state, z, **kwargs)

    ticks = iter([10.0, 16.0])                            # the clock read before and after the timed run, only
    monkeypatch.setattr(time, "thread_time", lambda: next(ticks))
    cost = study.cost_per_run_step(Counting(), make_batch, s, 3)
    timed = {("tseng2011", None): 200, ("ladder-nl1", None): 100}.get((name, cost_steps), cost_steps)
    assert batches == [1] * study.WARM_UP_STEPS + [3] * timed
    assert cost == 6.0 / (3 * timed)


# ============================================================ 9. who takes part, and what is pooled (issue 24)
@pytest.fixture
def twins():
    """Two papers registered for one test, built from zhu2016's: a control (kind "control", no arena entry) and a
    paper whose set-up is a reconstruction (qualifier); unregistered afterwards."""
    base = REGISTRY["zhu2016"]
    named = lambda name, **kw: replace(base, name=name, notebook=name, space=replace(base.space, paper=name), **kw)  # noqa: E731
    made = {"control": named("ctl-arena-test", kind="control", arena=None),
            "reconstruction": named("recon-arena-test", qualifier="reconstruction")}
    for p in made.values():
        REGISTRY.register(p)
    try:
        yield made
    finally:
        for p in made.values():
            REGISTRY.unregister(p.name)


def test_controls_take_no_part_in_the_arena(twins):
    ctl, recon = twins["control"].name, twins["reconstruction"].name
    assert ctl in REGISTRY and ctl not in study.paper_names() and ctl not in study.known_scenarios()
    assert recon in study.paper_names() and recon in study.known_scenarios()     # the filter is the kind, not the name
    for name in REGISTRY:                                                         # every control of the registry
        if REGISTRY[name].kind == "control":
            assert name not in study.known_scenarios() and name not in study.SCENARIOS
            assert all(p != name for *_, p in study.all_ideas())
            assert all(p != name for p, *_ in study.paper_claim_list())
            with raises_naming("scenario"):
                study.scenario(name)
    assert any(p == recon for *_, p in study.all_ideas())


def test_exclusions_name_degenerate_and_reconstructed_scenarios(twins):
    """A scenario is degenerate when no applicable cell's position RMSE is detectably and non-negligibly (1 %) below
    the measurement-only RMSE (standard errors 1e-3 here, so the 1 % decides, both sides tested; a cell diverged in
    every run never beats it); a paper's scenario is excluded when its qualifier (read from the registry) says
    reconstruction."""
    b = {"value": 10.0, "stderr": 1e-3, "n_runs": 10}
    rmse = lambda v: {"rmse_position": None if v is None else {"value": v, "stderr": 1e-3, "n_runs": 10}}  # noqa: E731
    cells = [{"scenario": "a", "algorithm": "X", **rmse(10.5)}, {"scenario": "a", "algorithm": "Y", **rmse(9.95)},
             {"scenario": "a", "algorithm": "Z", "reason": "needs an IMM mode set"},
             {"scenario": "b", "algorithm": "X", **rmse(9.85)}, {"scenario": "b", "algorithm": "Y", **rmse(20.0)},
             {"scenario": "c", "algorithm": "X", **rmse(None)}, {"scenario": "d", "algorithm": "X", **rmse(1.0)},
             {"scenario": twins["reconstruction"].name, "algorithm": "X", **rmse(1.0)},
             {"scenario": "zhu2016", "algorithm": "X", **rmse(1.0)}]
    ex = study.exclusions(cells, {"a": b, "b": b, "c": b, "d": b, "zhu2016": None})
    assert set(ex) == {"a", "c", twins["reconstruction"].name}
    assert ex["a"].startswith("degenerate: no estimator is detectably better than") and "Y's, is 9.95" in ex["a"]
    assert "reconstruction" in ex[twins["reconstruction"].name]
    assert study.degenerate_reason(cells, "a", None) == "" and study.degenerate_reason(cells, "e", b) == ""
    with raises_naming("baselines"):
        study.exclusions(cells, [b])
    with raises_naming("cells"):
        study.exclusions("cells", {})


def test_measurement_only_baselines():
    """The arena's measurement-only estimate is the zhou2017 package's on the same runs (two implementations, one
    number), the measured positions on a linear position sensor, and none for a sensor without a position."""
    from mmlib.papers.zhou2017 import study as zstudy
    mc = MonteCarlo(REGISTRY["zhou2017"].root_seed, 3)
    s = study.scenario("zhou2017")
    truth, z, _ = s.simulator(mc)(range(3))
    # the package takes np.hypot, the arena the square root of a sum of squares: a few ulps apart (2e-16 measured),
    # 1e-14 leaves margin; any modelling difference (sensor, offset, index) would be metres
    np.testing.assert_allclose(study.measurement_only_errors(s, truth, z), zstudy.measurement_only_errors(truth, z),
                               rtol=1e-14, atol=0)
    lin = study.scenario("ladder-linear")
    truth, z, _ = lin.simulator(MonteCarlo(lin.root_seed, 3))(range(3))
    np.testing.assert_allclose(study.measurement_only_errors(lin, truth, z),
                               np.hypot(*(z - truth[:, 1:][..., list(lin.position)]).transpose(2, 0, 1)), rtol=1e-14)
    b = study.measurement_only_rmse(lin, 3)
    assert b["n_runs"] == 3 and b["value"] > 0 and b["stderr"] > 0
    sq = study.measurement_only_mse(lin, 3)
    assert b["value"] == pytest.approx(float(np.sqrt(sq.mean())), rel=1e-15)
    for name in study.SCENARIOS:
        if study.scenario(name).measurement is None:                  # a sensor per step (GNSS pseudoranges)
            assert study.measurement_only_rmse(study.scenario(name), 2) is None


def test_zhou2017_arena_scenario_is_not_degenerate_but_its_headline_drift_would_be():
    """The arena runs zhou2017's Case 2 under the per-step fault reading: IMMUKF removes ~20 % of the measurement-
    only mean squared error there (not degenerate), but only ~0.2 % under the paper's headline drift (degenerate);
    paired on the common runs (at 10 runs the unpaired standard errors could not tell 11 % in RMSE apart)."""
    from mmlib.papers.zhou2017 import setup as zsetup
    n = 10
    paper = REGISTRY["zhou2017"]
    mc = MonteCarlo(paper.root_seed, n)
    for s, degenerate in ((study.scenario("zhou2017"), False),
                          (paper.scenario(paper.headline_setup()), True)):
        rs, _ = study.evaluate_cell("IMMUKF", s, mc, consistency=False)
        cells = [{"scenario": "zhou2017", "algorithm": "IMMUKF", **study.cell_metrics(rs, s, 0.0)}]
        per_run = {("zhou2017", "IMMUKF"): np.array(study.per_run_values(rs, s)["position_mse"], dtype=float)}
        b = study.measurement_only_rmse(s, n)
        why = study.degenerate_reason(cells, "zhou2017", b, per_run, study.measurement_only_mse(s, n))
        assert bool(why) is degenerate, (s.title, why)
    assert zsetup.ARENA_FAULT_KIND in study.scenario("zhou2017").title


def test_excluded_scenarios_stay_out_of_the_pooled_tallies():
    """zhu2016's claim (IMM5CKF beats IMMCKF and IMMUKF) holds on s1 and is contradicted on s2: pooled over both it is
    'partly'; with s2 excluded the pooled verdict is 'holds' on s1's parts alone and s2 is judged apart
    (contradicted), in paper_claims, arena_claims, the ideas' tallies, the findings and the claim matrix."""
    from mmlib.arena import views
    rng = np.random.default_rng(12)
    base = 100.0 + rng.normal(0, 10, 60)
    better = 0.8 * base + rng.normal(0, 0.5, 60)
    worse = 1.3 * base + rng.normal(0, 0.5, 60)
    res = _two_scenarios(s1={"IMM5CKF": better, "IMMCKF": base, "IMMUKF": base + 0.0},
                         s2={"IMM5CKF": worse, "IMMCKF": base, "IMMUKF": base + 0.0})
    assert {pc["paper"]: pc for pc in study.paper_claims(res)}["zhu2016"]["verdict"] == "partly"
    res = res._replace(excluded={"s2": "degenerate: a test"})
    zhu = {pc["paper"]: pc for pc in study.paper_claims(res)}["zhu2016"]
    assert zhu["verdict"] == "holds" and [p["quantity"] for p in zhu["parts"]] == ["position MSE, s1"] * 2
    assert [(e["scenario"], e["reason"], e["verdict"]) for e in zhu["excluded"]] == \
        [("s2", "degenerate: a test", "contradicted")]
    assert all(pair["verdicts"] == {"s1": "holds", "s2": "contradicted"} for pair in zhu["pairs"])   # shown, all
    cl = {c["claim"]: c for c in study.arena_claims(res).as_list()}
    mine = cl[f"{REGISTRY['zhu2016'].arena.claim} (zhu2016, across the arena)"]
    assert mine["verdict"] == "holds" and "kept out of this verdict: s2 (contradicted there" in mine["evidence"]
    for idea in study.ideas(res):
        summary = study.idea_summary(idea)
        if idea["comparisons"]:
            assert idea["excluded"] == {"s2": "degenerate: a test"}
            assert summary["n_scenarios"] == 1 and all(v == ["s1"] for v in summary["by_verdict"].values())
            assert list(summary["excluded"]) == ["s2"]
    rows = [{"scenario": sc, "nonlinearity_index": {"median": 0.0}, "properties": {}} for sc in ("s1", "s2")]
    text = "\n".join(study.findings(res, rows))
    assert "**Kept out of every pooled tally below**" in text and "s2: degenerate: a test" in text
    assert "kept out of this verdict: s2 **contradicted**" in text and "holds in 1 (s1)" in text
    assert "contradicted in 1 (s2)" not in text
    matrix = views.claim_scenario_matrix(study.paper_claims(res))
    assert "| s2 † |" in matrix and "| s1 |" in matrix and "†: kept out of the pooled verdict" in matrix
