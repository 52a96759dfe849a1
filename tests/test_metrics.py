"""Metrics: every bad input is a ValueError naming the argument the caller wrote (never a silent NaN, a
negative NEES or a cast index list), and ``rmse_over_time`` does what its docstring says."""
import numpy as np
import pytest

from mmlib.experiment import metrics
from conftest import raises_naming

M, K, D = 6, 5, 2
RNG = np.random.default_rng(20240611)
E2 = RNG.standard_normal((M, K))                 # errors (M, K)
E3 = RNG.standard_normal((M, K, D))              # errors (M, K, d)
OK = np.array([True, True, False, True, True, True])


def _with(arr, index, value):
    out = np.array(arr, dtype=complex if isinstance(value, complex) else float)
    out[index] = value
    return out


def _spd(n, rng, lead=()):
    A = rng.standard_normal(lead + (n, n))
    return A @ np.swapaxes(A, -1, -2) + n * np.eye(n)


P3 = _spd(D, np.random.default_rng(1), (M, K))  # (M, K, d, d) SPD
NOT_PD = P3.copy()
NOT_PD[2, 3] = np.diag([1.0, -1.0])              # indefinite: e^T P^-1 e can be negative
ASYM = P3.copy()
ASYM[0, 1, 0, 1] += 1.0

# (call, argument named in the message); each fails on the code before this change unless noted
BAD = {
    # NaN / inf in a run marked valid: a silent NaN before
    "mean_with_se NaN": (lambda: metrics.mean_with_se(_with(E2, (1, 2), np.nan)), "samples"),
    "rms_with_se inf": (lambda: metrics.rms_with_se(_with(E2 ** 2, (0, 0), np.inf)), "squared_errors"),
    "rmse_over_time NaN": (lambda: metrics.rmse_over_time(_with(E2, (3, 0), np.nan), OK), "err"),
    "rmse_time_averaged NaN": (lambda: metrics.rmse_time_averaged(_with(E3, (0, 0, 1), np.nan)), "err"),
    "armse NaN": (lambda: metrics.armse(_with(E3, (5, 4, 0), np.nan)), "err"),
    "mean_rmse_over_time NaN": (lambda: metrics.mean_rmse_over_time(_with(E2, (1, 1), np.nan)), "err"),
    "jackknife NaN": (lambda: metrics.jackknife(np.mean, _with(E2, (4, 0), np.nan)), "samples"),
    "nees NaN error": (lambda: metrics.nees(_with(E3, (0, 0, 0), np.nan), P3), "err"),
    "nees NaN covariance": (lambda: metrics.nees(E3, _with(P3, (1, 1, 0, 0), np.nan)), "cov"),
    # negative squared errors: sqrt of a negative mean was a silent NaN
    "rms_with_se negative": (lambda: metrics.rms_with_se(-E2 ** 2), "squared_errors"),
    # valid: an index list is not a mask ([1, 2, ...] cast to booleans drops run 0 silently)
    "valid index list": (lambda: metrics.mean_with_se(E2, [1, 2, 3, 4, 5, 0]), "valid"),
    "valid short index list": (lambda: metrics.rmse_over_time(E2, [0, 1]), "valid"),
    "valid wrong length": (lambda: metrics.armse(E3, OK[:4]), "valid"),
    "valid float mask": (lambda: metrics.mean_rmse_over_time(E2, OK.astype(float)), "valid"),
    "valid 2-D mask": (lambda: metrics.jackknife(np.mean, E2, np.ones((M, 1), bool)), "valid"),
    # wrong rank
    "mean_with_se scalar": (lambda: metrics.mean_with_se(3.0), "samples"),
    "rmse_over_time 1-D": (lambda: metrics.rmse_over_time(E2[:, 0]), "err"),
    "rmse_over_time 4-D": (lambda: metrics.rmse_over_time(E3[..., None]), "err"),
    "rmse_time_averaged 1-D": (lambda: metrics.rmse_time_averaged(E2[:, 0]), "err"),
    "armse 2-D": (lambda: metrics.armse(E2), "err"),                     # summed over the steps before
    "mean_rmse_over_time 3-D": (lambda: metrics.mean_rmse_over_time(E3), "err"),
    "nees cov shape": (lambda: metrics.nees(E3, P3[..., :1, :1]), "cov"),
    "nees scalar err": (lambda: metrics.nees(1.0, np.eye(1)), "err"),
    # non-PD or asymmetric covariances: a negative or meaningless NEES before
    "nees indefinite": (lambda: metrics.nees(E3, NOT_PD), "cov"),
    "nees asymmetric": (lambda: metrics.nees(E3, ASYM), "cov"),
    # chi-square band arguments: NaN bands before
    "chi2_band dof 0": (lambda: metrics.chi2_band(0, 10), "dof"),
    "chi2_band dof float": (lambda: metrics.chi2_band(2.5, 10), "dof"),
    "chi2_band dof bool": (lambda: metrics.chi2_band(True, 10), "dof"),
    "chi2_band n_runs 0": (lambda: metrics.chi2_band(4, 0), "n_runs"),
    "chi2_band level 1.5": (lambda: metrics.chi2_band(4, 10, 1.5), "level"),
    "chi2_band level 0": (lambda: metrics.chi2_band(4, 10, 0.0), "level"),
    "chi2_band level 1": (lambda: metrics.chi2_band(4, 10, 1.0), "level"),
    "chi2_band level NaN": (lambda: metrics.chi2_band(4, 10, np.nan), "level"),
    "chi2_band level string": (lambda: metrics.chi2_band(4, 10, "0.95"), "level"),
    # complex, strings, ragged lists
    "mean_with_se complex": (lambda: metrics.mean_with_se(E2 + 1j), "samples"),
    "rmse_over_time complex": (lambda: metrics.rmse_over_time(_with(E2, (0, 0), 1j)), "err"),
    "armse string": (lambda: metrics.armse("errors"), "err"),
    "mean_with_se ragged list": (lambda: metrics.mean_with_se([[1.0, 2.0], [3.0]]), "samples"),
    "nees string cov": (lambda: metrics.nees(E3, "P"), "cov"),
    "timing_ratio strings": (lambda: metrics.timing_ratio(["1", "2"], [1.0, 1.0]), "times"),
    "timing_ratio complex": (lambda: metrics.timing_ratio([1.0, 2.0], [1.0, 1j]), "reference"),
    # steps of rmse_time_averaged: an IndexError or an empty selection (NaN) before
    "steps out of range": (lambda: metrics.rmse_time_averaged(E2, steps=[0, K]), "steps"),
    "steps empty slice": (lambda: metrics.rmse_time_averaged(E2, steps=slice(K, None)), "steps"),
    "steps float": (lambda: metrics.rmse_time_averaged(E2, steps=[0.5]), "steps"),
    "steps mask wrong length": (lambda: metrics.rmse_time_averaged(E2, steps=np.ones(K + 1, bool)), "steps"),
    "jackknife not callable": (lambda: metrics.jackknife("mean", E2), "statistic"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input_is_a_value_error_naming_the_argument(case):
    call, name = BAD[case]
    with raises_naming(name):
        call()


def test_diverged_runs_may_hold_anything():
    """Runs marked invalid are excluded before any check: NaN/inf there is fine, and the numbers are those
    of the valid runs alone."""
    bad = _with(E2, (2, 1), np.nan)
    bad[2, 0] = np.inf
    got = metrics.mean_with_se(bad, OK)
    ref = metrics.mean_with_se(E2[OK])
    np.testing.assert_array_equal(got.value, ref.value)
    np.testing.assert_array_equal(got.stderr, ref.stderr)
    assert (got.n_runs, got.n_excluded) == (5, 1)
    assert metrics.rmse_over_time(bad, OK).n_excluded == 1


def test_lists_and_numpy_scalars_are_accepted():
    assert metrics.mean_with_se(E2.tolist()).value.tolist() == metrics.mean_with_se(E2).value.tolist()
    assert metrics.chi2_band(np.int64(4), np.int32(10), np.float64(0.95)) == metrics.chi2_band(4, 10, 0.95)


# -- rmse_over_time: code and docstring agree ---------------------------------------------------------------------
@pytest.mark.parametrize("d", [1, 2, 3])
def test_rmse_over_time_sums_a_trailing_component_axis(d):
    r"""(M, K, d): RMSE_k = sqrt(mean_m sum_i e_{m,k,i}^2), the same as the (M, K) call on the error norms
    (Liu & Wu 2017 Eq. 41); before, the components came back separately, shape (K, d)."""
    e = np.random.default_rng(d).standard_normal((40, 7, d)) * [3.0, 1.0, 0.5][:d]
    got = metrics.rmse_over_time(e, np.arange(40) % 9 != 0)
    norm = metrics.rmse_over_time(np.sqrt((e ** 2).sum(-1)), np.arange(40) % 9 != 0)
    assert got.value.shape == got.stderr.shape == (7,)
    ok = np.arange(40) % 9 != 0
    np.testing.assert_allclose(got.value, np.sqrt((e[ok] ** 2).sum(-1).mean(0)), rtol=1e-14)   # a few ulps
    np.testing.assert_allclose(got.value, norm.value, rtol=1e-14)
    np.testing.assert_allclose(got.stderr, norm.stderr, rtol=1e-12)
    assert got.n_runs == int(ok.sum()) and got.n_excluded == 5


def test_rmse_over_time_per_step_values_unchanged_for_two_dimensional_errors():
    """Every caller in mmlib/ and notebooks/ except Liu's Figs. 1-3 passes (M, K): bit-identical numbers."""
    got = metrics.rmse_over_time(E2, OK)
    np.testing.assert_array_equal(got.value, np.sqrt((E2[OK] ** 2).mean(axis=0)))
    s = E2[OK] ** 2
    np.testing.assert_array_equal(got.stderr, (s.std(axis=0, ddof=1) / np.sqrt(5)) / (2 * got.value))


def test_rmse_time_averaged_keeps_components_and_selects_steps():
    full = metrics.rmse_time_averaged(E3)
    assert full.value.shape == (D,)
    for steps in (slice(1, 4), [1, 2, 3], np.array([False, True, True, True, False])):
        part = metrics.rmse_time_averaged(E3, steps=steps)
        np.testing.assert_array_equal(part.value, np.sqrt((E3[:, 1:4] ** 2).mean(axis=1).mean(axis=0)))


# -- NEES ----------------------------------------------------------------------------------------------------------
def test_nees_matches_the_definition_and_is_never_negative():
    e, P = E3, P3
    ref = np.einsum("mki,mkij,mkj->mk", e, np.linalg.inv(P), e)
    got = metrics.nees(e, P)
    # P well conditioned (eigenvalues >= 2): solve and explicit inverse agree to ~1e-14 relative
    np.testing.assert_allclose(got, ref, rtol=1e-12)
    assert (got >= 0).all()


def test_nees_valid_mask_skips_diverged_runs():
    P = P3.copy()
    P[2] = np.nan                                 # run 2 diverged: its covariance is garbage
    e = _with(E3, (2, 0, 0), np.inf)
    got = metrics.nees(e, P, OK)
    assert np.isnan(got[2]).all()
    np.testing.assert_array_equal(got[OK], metrics.nees(E3[OK], P3[OK]))
    with pytest.raises(ValueError, match=r"^cov: contains NaN or infinite values \(first at index \(2, 0, 0, 0\)\)"):
        metrics.nees(E3, P)                       # unmasked: the garbage is reported, with its index
    with pytest.raises(ValueError, match=r"^cov: covariance at index \(2, 3\) is not positive definite"):
        metrics.nees(E3, NOT_PD)


@pytest.mark.parametrize("difference, stderr", [(float("nan"), float("nan")), (-1.0, float("nan")),
                                                (float("nan"), 0.1)])
def test_a_claim_with_nothing_compared_is_not_assessable(difference, stderr):
    """Old code: a NaN standard error (fewer than two valid runs) gave z = copysign(inf, difference), i.e.
    'holds' or 'contradicted' from nothing."""
    from mmlib.experiment import report
    assert report.claim_verdict(difference, stderr, -1) == "not comparable"
    assert report.judge([report.part("A − B", "MSE", difference, stderr, -1)]).verdict == report.NOT_ASSESSABLE


def test_rms_standard_error_is_nan_without_two_valid_runs_and_zero_for_exact_zeros():
    """No valid run: value and standard error NaN (never a 0 s.e. that reads as exact); all-zero errors over
    several runs: 0 +- 0; a single run: its value, s.e. NaN."""
    sq = np.abs(np.random.default_rng(1).standard_normal((5, 3)))
    none = metrics.rms_with_se(sq, valid=np.zeros(5, bool))
    assert np.all(np.isnan(none.value)) and np.all(np.isnan(none.stderr))
    zeros = metrics.rms_with_se(np.zeros((5, 3)))
    assert np.all(zeros.value == 0) and np.all(zeros.stderr == 0)
    one = metrics.rms_with_se(np.zeros((1, 3)))
    assert np.all(one.value == 0) and np.all(np.isnan(one.stderr))


def test_ratio_spread_text_is_median_and_range_of_the_per_repeat_ratios():
    from mmlib.experiment import metrics
    times = {"a": np.array([2.0, 3.0, 4.4]), "b": np.array([1.0, 2.0, 2.0])}
    assert metrics.ratio_spread_text(times, "a", "b") == "2.00× [1.50, 2.20]"
    with pytest.raises(ValueError, match="times"):
        metrics.ratio_spread_text(times, "a", "c")
    with pytest.raises(ValueError, match="times"):
        metrics.ratio_spread_text({"a": np.array(1.0), "b": np.array(2.0)}, "a", "b")
