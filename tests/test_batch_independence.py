"""A run's numbers do not depend on the batch it is in (issue 11, section 3).

Run r of a paper draws its random numbers from its own streams (:mod:`mmlib.experiment.montecarlo`), so the
truth, the measurements and every filter output of run r (which carry its initial state) must be the same *bits*
whether run r is computed alone (B = 1), with one or two others (B = 2, 3) or in a large chunk
(B = 64).  Round-off differences are not tolerated: a smoke run must be an exact prefix of the full
run, and chunking (or a one-run chunk at the end of a Monte Carlo job) must change nothing.

Every estimator each scenario module builds is checked, on a shortened horizon (a prefix of
tseng2011's 1800 epochs), together with a few reading variants that reach other code paths
(Stirling central differences, Eq. 20 as printed, the product likelihood, the bounded NAUKF, the
windowed fuzzy DOD); plus :func:`mmlib.experiment.simulate.simulate` on its own, the Monte Carlo streams, and
:func:`mmlib.experiment.evaluation.evaluate` whatever its chunk size.
"""
from __future__ import annotations

import functools
import warnings
from dataclasses import replace

import numpy as np
import pytest

from mmlib import MonteCarlo, Stream
from mmlib.core import linalg, models
from mmlib.core.estimation import run
from mmlib.experiment import evaluation
from mmlib.experiment.simulate import ManeuverSchedule, simulate
from mmlib.papers import REGISTRY
from mmlib.papers.hu2017 import setup as hu_setup
from mmlib.papers.liu2017 import setup as liu_setup
from mmlib.papers.tseng2011 import setup as tseng_setup
from mmlib.papers.zhou2017 import setup as zhou_setup
from mmlib.core.models import radar_drift
from mmlib.papers.zhu2016 import setup as zhu_setup

BATCH_SIZES = (1, 2, 3, 64)
REFERENCE = 64
N_CHECKED = 3                  # runs 0, 1, 2 (where the batch has them)


# ---------------------------------------------------------------------------------------------- helpers
def _bits(a) -> np.ndarray:
    """The raw bits of a numeric array (NaN == NaN, -0.0 != +0.0): exact, tolerance-free comparison
    (other dtypes, e.g. strings, are returned as they are and compared by value)."""
    a = np.ascontiguousarray(a)
    if a.dtype.kind not in "biufc":
        return a
    return a.view(np.uint8).reshape(a.shape + (a.dtype.itemsize,))


def _differences(label: str, got, ref, n: int) -> list:
    """Messages for the first ``n`` runs of ``got`` that are not bit-identical to those of ``ref``."""
    if got is None or ref is None:
        return [] if got is None and ref is None else [f"{label}: None in one batch only"]
    got, ref = np.asarray(got), np.asarray(ref)
    if got.dtype != ref.dtype or got.shape[1:] != ref.shape[1:]:
        return [f"{label}: dtype/shape {got.dtype}{got.shape} vs {ref.dtype}{ref.shape}"]
    out = []
    for i in range(n):
        if not np.array_equal(_bits(got[i]), _bits(ref[i])):
            rel = np.nan
            if got.dtype.kind == "f":
                with np.errstate(invalid="ignore"), warnings.catch_warnings():
                    warnings.simplefilter("ignore", RuntimeWarning)          # all-NaN slices
                    rel = np.nanmax(np.abs(got[i] - ref[i]) / np.maximum(np.abs(ref[i]), 1e-300))
            out.append(f"{label} run {i}: not bit-identical (max relative difference {rel:.3g})")
    return out


class Case:
    """One paper set-up: ``make_batch(runs) -> (truth, measurements, {name: initial state})``, its
    estimators, and the per-step measurement models (tseng2011) or None.  ``n_steps`` keeps a prefix
    of the measurements."""

    def __init__(self, make_batch, estimators, measurement_models=None, n_steps=None):
        self.make_batch = make_batch
        self.estimators = estimators
        self.measurement_models = measurement_models
        self.n_steps = n_steps

    def batch(self, B):
        truth, z, init = self.make_batch(range(B))
        if self.n_steps is not None:
            truth, z = truth[:, :self.n_steps + 1], z[:self.n_steps]
        return truth, z, init

    def run(self, name, init, z):
        models_k = None if self.measurement_models is None else self.measurement_models[:len(z)]
        return run(self.estimators[name], init[name], z, measurement_models=models_k)


def _mc(seed):
    return MonteCarlo(seed, REFERENCE)


def _headline(name: str) -> Case:
    """A registered paper's headline batch (``Paper.batch``); with per-step measurement models (tseng2011's 1800
    epochs), a prefix of 40 steps."""
    paper = REGISTRY[name]
    batch = paper.batch(paper.headline_setup(), _mc(paper.root_seed))
    return Case(*batch, n_steps=40 if len(batch) == 3 else None)


def _zhu2016(**changes):
    paper = REGISTRY["zhu2016"]
    return Case(*paper.batch(replace(zhu_setup.Setup(n_steps=30), **changes), _mc(paper.root_seed)))


def _hu2017(**changes):
    paper = REGISTRY["hu2017"]
    return Case(*paper.batch(replace(hu_setup.Setup(n_steps=30), **changes), _mc(paper.root_seed)))


def _liu2017(case, **changes):
    # the maneuver (acceleration jump) moved into the shortened horizon, so that strong tracking fades
    setup = replace(liu_setup.BASE_SETUPS[case], n_steps=40, maneuver_start=20.0, discussion_onset=None, **changes)
    make_batch, estimators, _ = liu_setup.make_batch_fn(setup, _mc(REGISTRY["liu2017"].root_seed))
    return Case(make_batch, estimators)


def _zhou2017(faults, **changes):
    setup = replace(zhou_setup.Setup(n_steps=45), faults=faults, **changes)
    make_batch, estimators, _ = zhou_setup.make_batch_fn(setup, _mc(REGISTRY["zhou2017"].root_seed))
    return Case(make_batch, estimators)


def _tseng2011(**changes):
    paper = REGISTRY["tseng2011"]
    return Case(*paper.batch(replace(tseng_setup.Setup(), **changes), _mc(paper.root_seed)), n_steps=40)


#: every registered paper's headline batch (a new paper is covered without an edit here), then reading variants that
#: reach other code paths of the five papers (their ids name the paper first)
CASES = {name: functools.partial(_headline, name) for name in REGISTRY}
CASES.update({
    "zhu2016: true initial estimate": lambda: _zhu2016(initial_estimate="true", truth_process_noise=False),
    "hu2017: Stirling CDKF, Eq. 20 printed, product likelihood": lambda: _hu2017(
        cd_form="stirling", obs_covariance="printed", obs_likelihood="product"),
    "liu2017: Example 1, maneuver in the horizon": lambda: _liu2017("Example 1"),
    "liu2017: Case 1 sampled start, noisy truth": lambda: _liu2017("Case 1", initial_estimate="sampled",
                                                                    truth_process_noise=True),
    "liu2017: Case 2": lambda: _liu2017("Case 2"),
    "zhou2017: case 1": lambda: _zhou2017(False),
    "zhou2017: case 2 bounded NAUKF, per-step fault": lambda: _zhou2017(True, inflate_only=True,
                                                                        fault_kind="per-step"),
    "tseng2011: windowed DOD": lambda: _tseng2011(dod_window=3),
})


@functools.lru_cache(maxsize=None)
def _outputs(case_id: str, B: int):
    """Truth, measurements and every estimator's track for runs 0..B-1 of a case."""
    case = CASES[case_id]()
    truth, z, init = case.batch(B)
    return truth, z, {name: case.run(name, init, z) for name in case.estimators}


def test_every_estimator_of_every_paper_is_covered():
    """The cases above reach every estimator of every registered paper's headline batch (none forgotten), and the
    variants' estimators too."""
    for name in REGISTRY:
        paper = REGISTRY[name]
        built = set(paper.batch(paper.headline_setup(), _mc(paper.root_seed))[1])
        assert built and set(CASES[name]().estimators) == built, name
    # and against each set-up module's own list of estimators (not through Paper.batch)
    covered: dict = {}
    for case_id, make in CASES.items():
        covered.setdefault(case_id.split(":")[0], set()).update(make().estimators)
    assert covered["zhu2016"] >= set(zhu_setup.build(zhu_setup.Setup())[2])
    assert covered["hu2017"] >= set(hu_setup.build(hu_setup.Setup())[2])
    assert covered["liu2017"] >= set(liu_setup.build(liu_setup.BASE_SETUPS.example1)[2])
    assert covered["zhou2017"] >= set(zhou_setup.build(zhou_setup.Setup())[2])
    assert covered["tseng2011"] >= set(tseng_setup.build(tseng_setup.Setup()))


# ---------------------------------------------------------------------------------------------- the product
@pytest.mark.parametrize("layout", ["C", "transposed"])
def test_matmul_rows_does_not_depend_on_the_number_of_rows(layout):
    """``linalg.matmul_rows`` (the row-vector x matrix product of the hot paths) gives every row the
    same bits for any number of rows, one included, and any inner dimension (GEMM up to
    ``GEMM_MAX_INNER``, numpy accumulation beyond); and it is the product ``x @ b`` to round-off.
    Also the guard on another BLAS: a build whose gemm rows depend on the number of rows fails here."""
    rng = np.random.default_rng(11)
    ks = sorted({1, 2, 3, 4, 6, 8, 9, 13, linalg.GEMM_MAX_INNER, linalg.GEMM_MAX_INNER + 1, 25, 33})
    for k in ks:
        for d in (1, 2, 3, 4, 9, 17, 33):
            x = rng.standard_normal((257, k)) * 1e3
            b = rng.standard_normal((k, d))
            if layout == "transposed":
                b = np.ascontiguousarray(b.T).T
            ref = linalg.matmul_rows(x, b)
            np.testing.assert_allclose(ref, x @ b, rtol=1e-12, atol=1e-9)
            for M in (1, 2, 3, 4, 5, 7, 64):
                assert not _differences(f"k={k} d={d} M={M}", linalg.matmul_rows(x[:M], b), ref, M)
            # leading axes are flattened: (B, p, k) rows as in a batch of sigma points
            stacked = linalg.matmul_rows(x[:12].reshape(3, 4, k), b)
            assert np.array_equal(_bits(stacked), _bits(ref[:12].reshape(3, 4, d)))


# ---------------------------------------------------------------------------------------------- estimators
@pytest.mark.parametrize("B", [b for b in BATCH_SIZES if b != REFERENCE])
@pytest.mark.parametrize("case_id", list(CASES))
def test_estimator_outputs_do_not_depend_on_batch_size(case_id, B):
    """Runs 0..min(B, 3)-1 of a batch of B runs give the bits of the same runs in a batch of 64:
    truth, measurements, and for every estimator means, covariances, mode probabilities, diverged
    steps and diagnostics."""
    truth, z, tracks = _outputs(case_id, B)
    rtruth, rz, rtracks = _outputs(case_id, REFERENCE)
    n = min(B, N_CHECKED)
    bad = _differences("truth", truth, rtruth, n)
    if isinstance(z, list):                              # per-step measurement dimension (tseng2011)
        for k, (zk, rzk) in enumerate(zip(z, rz)):
            bad += _differences(f"measurements[{k}]", zk, rzk, n)
    else:
        bad += _differences("measurements", z, rz, n)
    assert set(tracks) == set(rtracks)
    for name, track in tracks.items():
        for field in track._fields:
            bad += _differences(f"{name}.{field}", getattr(track, field), getattr(rtracks[name], field), n)
    assert not bad, f"{case_id}, B = {B} vs B = {REFERENCE}:\n" + "\n".join(bad[:40]) + \
        (f"\n... and {len(bad) - 40} more" if len(bad) > 40 else "")


def test_reference_batch_is_not_degenerate():
    """The comparison is meaningful: the runs differ from each other, and the checked runs of the
    reference batch have finite estimates (from the first step on; NAUKF as printed may diverge
    later, which is reported, not a defect), so a NaN == NaN match is not all the test sees."""
    for case_id in CASES:
        truth, z, tracks = _outputs(case_id, REFERENCE)
        zz = z[0] if isinstance(z, list) else z[:, 0]
        assert not np.array_equal(zz[0], zz[1])
        finite = []
        for name, track in tracks.items():
            assert np.isfinite(track.mean[:N_CHECKED, 0]).all(), (case_id, name)
            finite.append(np.isfinite(track.mean[:N_CHECKED]).mean())
        assert sum(f == 1.0 for f in finite) >= len(finite) / 2, (case_id, finite)   # most never diverge


# ---------------------------------------------------------------------------------------------- truth simulation
def _schedules():
    T = 1.0
    cv = models.constant_velocity(T, 2.0)
    ct = models.coordinated_turn(T, 0.05, 2.0)
    ca = models.constant_acceleration(T, 0.5)
    pos = models.position_measurement([25.0, 16.0])
    radar = models.range_bearing(np.diag([100.0, 1e-4]))
    return {
        "CV/CT, position sensor": (ManeuverSchedule([cv, ct], [(5, 12, 1)], 0, T, 20), [100.0, 10.0, -50.0, 5.0],
                                   pos, None),
        "CV/CT, radar": (ManeuverSchedule([cv, ct], [(5, 12, 1)], 0, T, 20), [1e4, -100.0, 2e4, 50.0], radar, None),
        "CA with a jump, radar on 6 states": (
            ManeuverSchedule([ca], [], 0, T, 20, jumps=[(8.0, (2, 5), (3.0, -2.0))]),
            [100.0, 15.0, 0.0, 400.0, 20.0, 0.0], models.range_bearing(np.diag([900.0, 1e-4]), state_dim=6), None),
        "radar with a sensor fault": (ManeuverSchedule([cv], [], 0, T, 20), [1e4, -100.0, 2e4, 50.0], radar,
                                      "fault"),
    }


@pytest.mark.parametrize("name", list(_schedules()))
def test_simulate_does_not_depend_on_batch_size(name):
    schedule, x0, measurement, fault = _schedules()[name]
    mc = MonteCarlo(2024, REFERENCE)

    def sim(B):
        fn = None
        if fault:
            rng_range = mc.standard_normal(range(B), Stream.FAULT, (2,))
            fn = radar_drift(rng_range[:, 0] * 5.0, np.abs(rng_range[:, 1]) * 1e-3,
                                          schedule.times).apply(measurement)
        return simulate(schedule, x0, measurement, mc, range(B), measurement_noise_fn=fn)

    ref = sim(REFERENCE)
    for B in BATCH_SIZES[:-1]:
        sc = sim(B)
        n = min(B, N_CHECKED)
        bad = _differences("truth", sc.truth, ref.truth, n) + _differences("measurements", sc.measurements,
                                                                            ref.measurements, n)
        assert not bad, f"{name}, B = {B}: " + "; ".join(bad)


@pytest.mark.parametrize("stream", list(Stream))
def test_monte_carlo_streams_do_not_depend_on_batch_size(stream):
    mc = MonteCarlo(99, REFERENCE)
    ref = mc.standard_normal(range(REFERENCE), stream, (7, 3))
    for B in BATCH_SIZES[:-1]:
        assert not _differences("standard_normal", mc.standard_normal(range(B), stream, (7, 3)), ref,
                                min(B, N_CHECKED))
    # and a run does not depend on which other runs are drawn with it
    assert np.array_equal(_bits(mc.standard_normal([5, 2], stream, (4,))[1]),
                          _bits(mc.standard_normal(range(3), stream, (4,))[2]))


# ---------------------------------------------------------------------------------------------- evaluate chunking
#: chunking is paper-agnostic code: checked on a sample of the registry, its first two papers, cut to 25 steps
EVALUATE_PAPERS = list(REGISTRY)[:2]


@pytest.mark.parametrize("paper", EVALUATE_PAPERS)
def test_evaluate_does_not_depend_on_chunk_size(paper):
    """``evaluate`` with chunks of 1, 2 and 3 runs gives the RunSets of one chunk, bit for bit (a last
    chunk of one run included: 7 runs in chunks of 2 or 3)."""
    p = REGISTRY[paper]
    mc = MonteCarlo(p.root_seed, 7)
    setup = p.headline_setup()
    if hasattr(setup, "n_steps"):
        setup = replace(setup, n_steps=25)
    make_batch, estimators, *models = p.batch(setup, mc)
    measurement_models = models[0] if models else None
    results = {size: evaluation.evaluate(estimators, make_batch, mc, chunk_size=size, progress=False,
                                         measurement_models=measurement_models)
               for size in (7, 1, 2, 3)}
    ref = results[7]
    bad = []
    for size in (1, 2, 3):
        for name, rs in results[size].items():
            for field in rs._fields:
                a, b = getattr(rs, field), getattr(ref[name], field)
                if a is None or b is None:
                    bad += [] if a is None and b is None else [f"chunk {size}: {name}.{field} None in one only"]
                elif np.shape(a) != np.shape(b) or not np.array_equal(_bits(np.asarray(a)), _bits(np.asarray(b))):
                    bad.append(f"chunk {size}: {name}.{field} differs")
    assert not bad, "\n".join(bad)
