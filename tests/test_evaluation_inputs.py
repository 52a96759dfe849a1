"""Monte Carlo and evaluation helpers: bad input is a ValueError naming the argument the caller wrote; the
run digest of an evaluation's first runs does not depend on how many runs follow or how they are chunked."""
import numpy as np
import pytest

import mmlib as m
from mmlib.core import models
from mmlib.experiment import digests, evaluation
from mmlib.experiment.montecarlo import MonteCarlo, Stream
from mmlib.experiment.simulate import ManeuverSchedule
from conftest import raises_naming

T, K = 1.0, 15
P0 = np.diag([10.0, 4.0, 10.0, 4.0])
X0 = np.array([0.0, 10.0, 0.0, 5.0])


def _problem(mc, names=("IMM-CKF", "KF")):
    """A CV/turn schedule seen by a position sensor; an IMM (mode probabilities) and a single-model KF."""
    cv, ct = models.constant_velocity(T, 1.0), models.coordinated_turn(T, 0.05, 1.0)
    meas = models.position_measurement([4.0, 4.0])
    sched = ManeuverSchedule([cv, ct], [(5, 10, 1)], 0, T, K)
    est = {"IMM-CKF": m.IMM(m.SigmaPointFilter(m.Cubature()), [cv, ct], meas, [[0.95, 0.05], [0.1, 0.9]]),
           "KF": m.SingleModel(m.KalmanFilter(), cv, meas)}
    est = {k: est[k] for k in names}
    make_batch = evaluation.make_batches(mc, sched, meas, X0, est, lambda e, m0, runs: e.init(m0, P0))
    return est, make_batch, sched, meas


@pytest.fixture(scope="module")
def results():
    mc = MonteCarlo(5, 8)
    est, make_batch, _, _ = _problem(mc)
    return evaluation.evaluate(est, make_batch, mc, progress=False)


# -- MonteCarlo ------------------------------------------------------------------------------------------------------
MC = MonteCarlo(3, 4)
MC_BAD = {   # (call, argument); "(passes today)" marks cases the code before this change already rejected
    "root_seed bool (passes today)": (lambda: MonteCarlo(True, 4), "root_seed"),
    "root_seed float (passes today)": (lambda: MonteCarlo(1.0, 4), "root_seed"),
    "root_seed negative (passes today)": (lambda: MonteCarlo(-1, 4), "root_seed"),
    "n_runs 0 (passes today)": (lambda: MonteCarlo(1, 0), "n_runs"),
    "n_runs float (passes today)": (lambda: MonteCarlo(1, 4.0), "n_runs"),
    "run float": (lambda: MC.generator(1.5, Stream.TRUTH), "run"),
    "run bool": (lambda: MC.generator(True, Stream.TRUTH), "run"),
    "run negative (passes today)": (lambda: MC.generator(-1, Stream.TRUTH), "run"),
    "run too large (passes today)": (lambda: MC.generator(4, Stream.TRUTH), "run"),
    "stream unknown": (lambda: MC.generator(0, 7), "stream"),
    "stream float": (lambda: MC.generator(0, 1.0), "stream"),
    "stream bool": (lambda: MC.generator(0, True), "stream"),
    "stream string": (lambda: MC.generator(0, "TRUTH"), "stream"),
    "runs float entry": (lambda: MC.standard_normal([0, 1.5], Stream.TRUTH, (2,)), "runs"),
    "runs out of range": (lambda: MC.standard_normal(range(5), Stream.TRUTH, (2,)), "runs"),
    "runs an int": (lambda: MC.standard_normal(3, Stream.TRUTH, (2,)), "runs"),
    "runs a string": (lambda: MC.standard_normal("01", Stream.TRUTH, (2,)), "runs"),
    "shape negative": (lambda: MC.standard_normal([0], Stream.TRUTH, (2, -1)), "shape"),
    "shape float": (lambda: MC.standard_normal([0], Stream.TRUTH, (2.5,)), "shape"),
    "shape an int": (lambda: MC.standard_normal([0], Stream.TRUTH, 3), "shape"),
    "chunk_size 0 (passes today)": (lambda: MC.chunks(0), "chunk_size"),
    "chunk_size bool (passes today)": (lambda: MC.chunks(True), "chunk_size"),
    "chunk_size float (passes today)": (lambda: MC.chunks(2.0), "chunk_size"),
}


@pytest.mark.parametrize("case", sorted(MC_BAD))
def test_montecarlo_bad_input_names_the_argument(case):
    call, name = MC_BAD[case]
    with raises_naming(name):
        call()


def test_montecarlo_accepts_numpy_integers_and_stores_python_ints():
    mc = MonteCarlo(np.int64(3), np.int32(4))
    assert type(mc.root_seed) is int and type(mc.n_runs) is int and mc == MC
    a = mc.standard_normal(np.arange(4), np.int64(1), (np.int64(2), 3))
    b = MC.standard_normal(range(4), Stream.MEASUREMENT, (2, 3))
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(MC.generator(np.int8(2), Stream.FILTER).standard_normal(3),
                                  MC.generator(2, 3).standard_normal(3))
    assert [list(c) for c in MC.chunks(np.int64(3))] == [[0, 1, 2], [3]]


# -- evaluation helpers ----------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def ctx(results):
    """What the bad calls below need: estimators, batches, a schedule, RunSets (one with NaN in a valid run)."""
    from types import SimpleNamespace
    est, make_batch, sched, meas = _problem(MonteCarlo(5, 3))
    a, b = results["IMM-CKF"], results["KF"]
    nan_run = a._replace(errors=a.errors.copy())
    nan_run.errors[1, 2, 0] = np.nan                           # run 1 is not marked diverged
    return SimpleNamespace(est=est, sched=sched, meas=meas, a=a, b=b, nan_run=nan_run, results=results,
                           init={k: e.init(np.tile(X0, (2, 1)), P0) for k, e in est.items()},
                           z=make_batch(range(2))[1], q=[("x", 0)])


def _make(c, x0=X0, est=None, init_state=lambda e, m0, r: e.init(m0, P0), mc=MC, **kw):
    return evaluation.make_batches(mc, c.sched, c.meas, x0, c.est if est is None else est, init_state, **kw)


EVAL_BAD = {   # (call, argument); "(passes today)" marks cases the code before this change already rejected
    "select names a string": (lambda c: evaluation.select(c.est, "KF"), "names"),
    "select unknown name": (lambda c: evaluation.select(c.est, ["KF", "UKF"]), "names"),
    "select repeated name": (lambda c: evaluation.select(c.est, ["KF", "KF"]), "names"),
    "select not a dict": (lambda c: evaluation.select(list(c.est.values())), "estimators"),
    "paired: a not a RunSet": (lambda c: evaluation.paired_mse_difference("IMM", c.b, 0), "a"),
    "paired: b not a RunSet": (lambda c: evaluation.paired_mse_difference(c.a, c.b.errors, 0), "b"),
    "paired: component out of range": (lambda c: evaluation.paired_mse_difference(c.a, c.b, 4), "components"),
    "paired: negative component": (lambda c: evaluation.paired_mse_difference(c.a, c.b, -1), "components"),
    "paired: float component": (lambda c: evaluation.paired_mse_difference(c.a, c.b, 1.0), "components"),
    "paired: string component": (lambda c: evaluation.paired_mse_difference(c.a, c.b, "x"), "components"),
    "paired: repeated components": (lambda c: evaluation.paired_mse_difference(c.a, c.b, (0, 0)), "components"),
    "paired: empty components": (lambda c: evaluation.paired_mse_difference(c.a, c.b, ()), "components"),
    "paired: NaN in a valid run": (lambda c: evaluation.paired_mse_difference(c.nan_run, c.b, 0), "a.errors"),
    "paired: different runs": (lambda c: evaluation.paired_mse_difference(evaluation.first_runs(c.a, 3), c.b, 0),
                               "a, b"),
    "better_claim unknown a": (lambda c: evaluation.better_claim(c.results, "UKF", "KF", c.q), "a"),
    "better_claim unknown b": (lambda c: evaluation.better_claim(c.results, "KF", "UKF", c.q), "b"),
    "better_claim a == b": (lambda c: evaluation.better_claim(c.results, "KF", "KF", c.q), "b"),
    "better_claim no quantities": (lambda c: evaluation.better_claim(c.results, "IMM-CKF", "KF", []), "quantities"),
    "better_claim bare components": (lambda c: evaluation.better_claim(c.results, "IMM-CKF", "KF", [0, 2]),
                                     "quantities"),
    "better_claim not a dict": (lambda c: evaluation.better_claim([c.a, c.b], "IMM-CKF", "KF", c.q), "results"),
    "first_runs 0": (lambda c: evaluation.first_runs(c.a, 0), "n"),
    "first_runs more than there are": (lambda c: evaluation.first_runs(c.a, 9), "n"),
    "first_runs float": (lambda c: evaluation.first_runs(c.a, 2.0), "n"),
    "first_runs not a RunSet": (lambda c: evaluation.first_runs(c.a.errors, 2), "rs"),
    "time_algorithms repeats 1 (passes today)": (
        lambda c: evaluation.time_algorithms(c.est, c.init, c.z, repeats=1), "repeats"),
    "time_algorithms per_repeat 3 of 2 runs (passes today)": (
        lambda c: evaluation.time_algorithms(c.est, c.init, c.z, per_repeat=3), "per_repeat"),
    "time_algorithms init lacks one": (
        lambda c: evaluation.time_algorithms(c.est, {"KF": c.init["KF"]}, c.z), "init"),
    "time_algorithms measurements 2-D (passes today)": (
        lambda c: evaluation.time_algorithms(c.est, c.init, c.z[0]), "measurements"),
    "time_algorithms measurements NaN (passes today)": (
        lambda c: evaluation.time_algorithms(c.est, c.init, c.z * np.nan), "measurements"),
    "time_algorithms measurements string": (lambda c: evaluation.time_algorithms(c.est, c.init, "z"), "measurements"),
    "make_batches x0 complex": (lambda c: _make(c, x0=X0 + 1j), "x0"),
    "make_batches x0 2-D": (lambda c: _make(c, x0=P0), "x0"),
    "make_batches x0 string": (lambda c: _make(c, x0="x0"), "x0"),
    "make_batches mc": (lambda c: _make(c, mc=3), "mc"),
    "make_batches init_state": (lambda c: _make(c, init_state=None), "init_state"),
    "make_batches estimators": (lambda c: _make(c, est=[]), "estimators"),
    "make_batches fault": (lambda c: _make(c, fault=3), "fault"),
    "make_batches start shape": (lambda c: _make(c, start=lambda runs: np.zeros((1, 4)))(range(2)), "start"),
}


@pytest.mark.parametrize("case", sorted(EVAL_BAD))
def test_evaluation_bad_input_names_the_argument(ctx, case):
    call, name = EVAL_BAD[case]
    with raises_naming(name):
        call(ctx)


def test_time_algorithms_accepts_numpy_integers():
    est, make_batch, _, _ = _problem(MonteCarlo(5, 2), names=("KF",))
    _, z, init = make_batch(range(2))
    one, batched = evaluation.time_algorithms(est, init, z, repeats=np.int64(2), per_repeat=np.int64(1))
    assert one["KF"].shape == batched["KF"].shape == (2,)


def test_paired_difference_counts_excluded_runs_and_keeps_its_value(results):
    a, b = results["IMM-CKF"], results["KF"]
    div = b._replace(diverged_step=np.where(np.arange(8) == 3, 5, -1))
    d = evaluation.paired_mse_difference(a, div, (0, 2))
    ok = np.arange(8) != 3
    per_run = (a.errors[ok][..., [0, 2]] ** 2).sum(-1).mean(1) - (b.errors[ok][..., [0, 2]] ** 2).sum(-1).mean(1)
    assert d.value == per_run.mean() and (d.n_runs, d.n_excluded) == (7, 1)


# -- run digest ------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("n, n_big, chunk_small, chunk_big", [(5, 12, 250, 3), (4, 9, 2, 250), (6, 14, 3, 2),
                                                           (5, 12, 2, 5)])
def test_digest_of_first_runs_independent_of_run_count_and_chunking(n, n_big, chunk_small, chunk_big):
    """A smoke evaluation (n runs) and the first n runs of a larger one (other chunking) give the same digest,
    one-run chunks included (5 runs in chunks of 2 end with a batch of one)."""
    small_mc, big_mc = MonteCarlo(17, n), MonteCarlo(17, n_big)
    est, mb, _, _ = _problem(small_mc)
    small = evaluation.evaluate(est, mb, small_mc, chunk_size=chunk_small, progress=False)
    est, mb, _, _ = _problem(big_mc)
    big = evaluation.evaluate(est, mb, big_mc, chunk_size=chunk_big, progress=False)
    ds, db = digests.run_digest(small, n), digests.run_digest(big, n)
    assert ds == db
    assert ds["n_runs"] == n and ds["algorithms"] == ["IMM-CKF", "KF"]
    assert digests.run_digest(big, n + 1)["sha256"] != ds["sha256"]


def test_digest_detects_one_ulp_and_a_changed_stream_but_not_later_runs(results, monkeypatch):
    ref = digests.run_digest(results, 5)
    # dict order and nesting are part of the names, not of the numbers' order
    assert digests.run_digest(dict(reversed(results.items())), 5) == ref
    nested = digests.run_digest({"case": results}, 5)
    assert nested["algorithms"] == ["case / IMM-CKF", "case / KF"] and nested["sha256"] != ref["sha256"]
    # one ulp of one per-run number among the first runs changes it; any change after them does not
    a = results["KF"]
    for field, index, after in (("errors", (4, 9, 1), (5, 9, 1)), ("diverged_step", (2,), (6,))):
        for where, same in ((index, False), (after, True)):
            arr = getattr(a, field).astype(float if field == "errors" else int).copy()
            arr[where] = np.nextafter(arr[where], np.inf) if field == "errors" else 3
            got = digests.run_digest({**results, "KF": a._replace(**{field: arr})}, 5)
            assert (got["sha256"] == ref["sha256"]) is same, (field, where)
    mp = results["IMM-CKF"].mode_probabilities.copy()
    mp[0, 0, 0] = np.nextafter(mp[0, 0, 0], 0)
    assert digests.run_digest({**results, "IMM-CKF": results["IMM-CKF"]._replace(mode_probabilities=mp)},
                                 5)["sha256"] != ref["sha256"]
    # NaN sign/payload bits are not results: -NaN and NaN hash alike
    e = a.errors.copy()
    e[1] = np.nan
    e2 = e.copy()
    e2[1] = -np.nan
    div = np.where(np.arange(8) == 1, 0, -1)
    d1 = digests.run_digest({"KF": a._replace(errors=e, diverged_step=div)}, 5)
    d2 = digests.run_digest({"KF": a._replace(errors=e2, diverged_step=div)}, 5)
    assert d1 == d2 and d1["diverged"] == {"KF": 1}
    # a change to the random streams (the spawn key's order swapped) changes it
    mc = MonteCarlo(5, 8)

    def swapped(self, run, stream):
        return np.random.default_rng(np.random.SeedSequence(self.root_seed, spawn_key=(int(stream), int(run))))

    monkeypatch.setattr(MonteCarlo, "generator", swapped)
    est, mb, _, _ = _problem(mc)
    assert digests.run_digest(evaluation.evaluate(est, mb, mc, progress=False), 5)["sha256"] != ref["sha256"]


def test_digest_summary_numbers(results):
    d = digests.run_digest(results, 5)
    for name, rs in results.items():
        assert d["mean_squared_error"][name] == float(np.mean(rs.errors[:5] ** 2))
        assert d["diverged"][name] == 0
    assert len(d["sha256"]) == 64 and d["version"] == digests.DIGEST_VERSION


@pytest.mark.parametrize("args, name", [
    (lambda r: ({}, 2), "results"),
    (lambda r: ([r["KF"]], 2), "results"),
    (lambda r: ({"KF": r["KF"].errors}, 2), "results"),
    (lambda r: ({1: r["KF"]}, 2), "results"),
    (lambda r: (r, 0), "n_runs"),
    (lambda r: (r, 9), "n_runs"),
    (lambda r: (r, 2.0), "n_runs"),
    (lambda r: (r, True), "n_runs"),
])
def test_digest_bad_input(results, args, name):
    with raises_naming(name):
        digests.run_digest(*args(results))
