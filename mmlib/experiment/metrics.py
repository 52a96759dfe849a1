r"""Error metrics with Monte Carlo standard errors.

All functions take errors or squared errors with the run axis first and a
``valid`` mask of runs (diverged runs excluded *and counted*).  Standard errors
treat runs as independent replications; for root-mean quantities they use the
delta method, :math:`\mathrm{se}(\sqrt{m}) \approx \mathrm{se}(m)/(2\sqrt m)`.
"""
from __future__ import annotations

from typing import Mapping, Callable, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from mmlib.core.linalg import normalised_square

from mmlib.core._validate import (as_float_array, check_covariance, check_finite, check_finite_runs, check_index,
                                  check_mask, check_positive_int, check_scalar)

# scipy.stats (1.1 s to import) is imported by the two functions that use it: a process that imports this module
# through the multiverse's views without computing an interval (the notebook runner, once per run) never loads it

__all__ = [
    "MCValue", "mean_with_se", "armse", "rmse_over_time", "rmse_time_averaged", "mean_rmse_over_time", "rms_with_se",
    "nees", "chi2_band", "jackknife", "wilson_interval", "timing_ratio", "ratio_spread_text"
]


class MCValue(NamedTuple):
    """A Monte Carlo estimate: ``value`` and its standard error ``stderr`` (same shape and unit), from
    ``n_runs`` valid runs, ``n_excluded`` diverged runs left out."""

    value: np.ndarray
    stderr: np.ndarray
    n_runs: int          # runs used
    n_excluded: int      # diverged runs left out


def _valid(valid, n):
    """The ``valid`` argument as a boolean mask of the n runs (None: all runs).  An index list is not a
    mask: it is rejected, never cast (``[1, 2]`` as booleans would silently drop run 0)."""
    return np.ones(n, dtype=bool) if valid is None else check_mask(valid, "valid", n)


def _runs(value, name: str, valid, ndims=None) -> tuple[np.ndarray, np.ndarray]:
    """``value`` as a float array with the run axis first (rank in ``ndims`` if given, else >= 1), the
    ``valid`` mask of its runs, and finiteness checked in the valid runs (diverged runs may hold
    anything: they are excluded)."""
    arr = as_float_array(value, name)
    if (ndims is not None and arr.ndim not in ndims) or arr.ndim < 1:
        want = " or ".join(f"{d}-D" for d in ndims) if ndims else "at least 1-D (runs first)"
        raise ValueError(f"{name}: expected an array {want}, got shape {arr.shape}")
    ok = _valid(valid, arr.shape[0])
    return check_finite_runs(arr, name, ok), ok


def mean_with_se(samples: ArrayLike, valid: ArrayLike | None = None) -> MCValue:
    r"""Mean over runs (axis 0) and its standard error, :math:`\bar s` and
    :math:`\hat\sigma/\sqrt{n}` (sample s.d. with n - 1) over the n valid runs.

    ``samples`` (M, ...) with runs first; ``valid`` None or a boolean mask (M,).  With no valid run the
    value and standard error are NaN and ``n_runs`` is 0; with one, the standard error is NaN."""
    samples, ok = _runs(samples, "samples", valid)
    return _mean_se(samples, ok)


def _mean_se(samples: np.ndarray, ok: np.ndarray) -> MCValue:
    """:func:`mean_with_se` of checked arguments."""
    s = samples[ok]
    n = s.shape[0]
    if n == 0:
        nan = np.full(samples.shape[1:], np.nan)
        return MCValue(nan, nan, 0, int((~ok).sum()))
    se = s.std(axis=0, ddof=1) / np.sqrt(n) if n > 1 else np.full(s.shape[1:], np.nan)
    return MCValue(s.mean(axis=0), se, n, int((~ok).sum()))


def ratio_spread_text(times: Mapping, alg: str, ref: str) -> str:
    """The spread across separate repeated timings of the per-repeat ratio ``times[alg] / times[ref]`` (``times``:
    algorithm -> seconds per run in each repeat), as ``"1.05× [1.01, 1.12]"``: median [min, max].  Context beside a
    cost-model verdict, never a verdict itself."""
    if not isinstance(times, Mapping) or alg not in times or ref not in times:
        raise ValueError(f"times: expected a mapping holding {alg!r} and {ref!r}, got {type(times).__name__}")
    r = np.asarray(times[alg], float) / np.asarray(times[ref], float)
    if r.ndim != 1 or r.size == 0:
        raise ValueError(f"times: expected one time per repeat for {alg!r} and {ref!r}, got shape {r.shape}")
    return f"{float(np.median(r)):.2f}× [{float(r.min()):.2f}, {float(r.max()):.2f}]"


def timing_ratio(times: ArrayLike, reference: ArrayLike) -> MCValue:
    r"""Run-time ratio of one algorithm to a reference from paired repeated timings (one value per repeat):
    the median of the per-repeat ratios, with the standard error of a median,
    :math:`\sqrt{\pi/2}\,\hat\sigma/\sqrt{n}` (asymptotic, normal data), the spread estimated robustly as
    :math:`\hat\sigma = 1.4826\,\mathrm{MAD}`.  Timings on a shared machine carry occasional large
    disturbances (a repeat several times slower); the median and the MAD keep a few of them from deciding
    a verdict, where a mean and a standard deviation let them flip it between identical runs."""
    times, reference = as_float_array(times, "times"), as_float_array(reference, "reference")
    if times.shape != reference.shape or times.ndim != 1 or times.size < 2:
        raise ValueError(f"times, reference: expected two 1-D arrays of the same length >= 2, got shapes "
                         f"{times.shape} and {reference.shape}")
    if not (np.all(np.isfinite(times)) and np.all(np.isfinite(reference)) and np.all(reference > 0)):
        raise ValueError("times, reference: timings must be finite and the reference's positive")
    r = times / reference
    med = float(np.median(r))
    sigma = 1.4826 * float(np.median(np.abs(r - med)))
    return MCValue(np.float64(med), np.float64(np.sqrt(np.pi / 2) * sigma / np.sqrt(r.size)), int(r.size), 0)


def _rms(sq: np.ndarray, ok: np.ndarray) -> MCValue:
    """Root of the mean over the valid runs of checked, non-negative squared errors ``sq``."""
    m = _mean_se(sq, ok)
    root = np.sqrt(m.value)
    with np.errstate(divide="ignore", invalid="ignore"):
        # delta method; at a zero root the errors are all zero (s.e. 0, or NaN from a single run); no valid run: NaN
        se = np.where(root > 0, m.stderr / (2.0 * root), np.where(root == 0, m.stderr * 0.0, np.nan))
    return MCValue(root, se, m.n_runs, m.n_excluded)


def rms_with_se(squared_errors: ArrayLike, valid: ArrayLike | None = None) -> MCValue:
    """``sqrt(mean over runs of squared_errors)`` (axis 0), delta-method standard error;
    ``squared_errors`` (M, ...) must be >= 0 in the valid runs."""
    sq, ok = _runs(squared_errors, "squared_errors", valid)
    if np.any(sq[ok] < 0):
        raise ValueError("squared_errors: contains negative values in a run marked valid")
    return _rms(sq, ok)


def rmse_over_time(err: ArrayLike, valid: ArrayLike | None = None) -> MCValue:
    r"""Per-step RMSE across runs, :math:`\mathrm{RMSE}_k = \sqrt{\frac1M\sum_m \lVert e_{m,k}\rVert^2}`
    over the M valid runs, in the unit of ``err``.

    ``err`` (M, K): one error per run and step; (M, K, d): the squared errors are summed over the d
    components first (e.g. position error = x and y together, Liu & Wu 2017 Eq. 41).  Returns
    ``value`` and ``stderr`` of shape (K,) (delta method, runs as replications)."""
    e, ok = _runs(err, "err", valid, ndims=(2, 3))
    sq = e ** 2 if e.ndim == 2 else (e ** 2).sum(axis=-1)
    return _rms(sq, ok)


def rmse_time_averaged(err: ArrayLike, valid: ArrayLike | None = None,
                       steps: slice | ArrayLike | None = None) -> MCValue:
    r"""Zhu et al. 2016 Eq. 64 read as
    :math:`\sqrt{\frac{1}{MK}\sum_m\sum_k e_{m,k}^2}` (runs m, steps k) per component.

    ``err`` (M, K) or (M, K, d) (value and standard error per component: () or (d,)); ``steps``
    None (all K steps), a slice, a boolean mask (K,) or a sequence of step indices 0..K-1, selecting
    a non-empty set of steps; the per-run time means are the independent replications for the
    standard error."""
    e, ok = _runs(err, "err", valid, ndims=(2, 3))
    sq = e ** 2
    if steps is not None:
        sq = sq[:, _steps(steps, e.shape[1])]
    return _rms(sq.mean(axis=1), ok)


def _steps(steps, K: int):
    """The ``steps`` argument as an index into an axis of K steps (non-empty)."""
    if isinstance(steps, slice):
        chosen = range(K)[steps]
        if len(chosen) == 0:
            raise ValueError(f"steps: the slice {steps} selects none of the {K} steps")
        return steps
    arr = np.asarray(steps) if not isinstance(steps, (str, bytes)) else None
    if arr is not None and arr.dtype.kind == "b":
        mask = check_mask(arr, "steps", K)
        if not mask.any():
            raise ValueError("steps: the mask selects no step")
        return mask
    if arr is None or arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"steps: expected a slice, a boolean mask of length {K} or a non-empty sequence of "
                         f"step indices, got {steps!r}")
    return np.array([check_index(i, "steps", K) for i in arr.tolist()], dtype=int)


def nees(err: ArrayLike, cov: ArrayLike, valid: ArrayLike | None = None) -> np.ndarray:
    r"""Normalised estimation error squared :math:`\epsilon = e^T P^{-1} e` (dimensionless; chi-square
    with n degrees of freedom for a consistent filter), per leading index, e.g. per run and step.

    ``err`` (..., n) estimate minus truth, ``cov`` (..., n, n) the filter's covariances, symmetric
    positive definite (a covariance that is not would give a meaningless, possibly negative, NEES:
    it is rejected).  ``valid`` None or a boolean mask over the first axis (runs): the entries of the
    other runs (diverged) are NaN and their errors and covariances are not checked."""
    e = as_float_array(err, "err")
    P = as_float_array(cov, "cov")
    if e.ndim < 1 or e.shape[-1] == 0:
        raise ValueError(f"err: expected errors of shape (..., n) with n >= 1, got shape {e.shape}")
    if P.shape != e.shape + e.shape[-1:]:
        raise ValueError(f"cov: expected shape {e.shape + e.shape[-1:]} (err's shape {e.shape} plus n), "
                         f"got {P.shape}")
    if valid is None:
        check_finite(e, "err")
        check_covariance(P, "cov", stack=True)
        return normalised_square(e, P)          # the quadratic form run() records on the fly, written once
    if e.ndim < 2:
        raise ValueError(f"valid: needs err with a run axis first, shape (M, ..., n), got {e.shape}")
    ok = _valid(valid, e.shape[0])
    check_finite_runs(e, "err", ok)
    if not ok.all():          # the excluded runs are not checked: stand-ins that pass, NaN in the result
        e, P = np.where(ok.reshape((-1,) + (1,) * (e.ndim - 1)), e, 0.0), P.copy()
        P[~ok] = np.eye(e.shape[-1])
    out = nees(e, P)
    out[~ok] = np.nan
    return out


def chi2_band(dof: int, n_runs: int, level: float = 0.95) -> tuple[float, float]:
    r"""Two-sided acceptance band for the run-average of a chi-square(dof) statistic over n_runs runs
    (Bar-Shalom et al. 2001, Sec. 5.4.2): :math:`[\chi^2_{Mn}((1-\alpha)/2),\ \chi^2_{Mn}((1+\alpha)/2)]/M`
    with n = ``dof`` (integer >= 1), M = ``n_runs`` (integer >= 1), :math:`\alpha` = ``level`` in (0, 1)."""
    dof = check_positive_int(dof, "dof")
    n_runs = check_positive_int(n_runs, "n_runs")
    level = check_scalar(level, "level", positive=True)
    if not level < 1.0:
        raise ValueError(f"level: expected a probability in (0, 1), got {level!r}")
    from scipy import stats
    lo, hi = stats.chi2.ppf([(1 - level) / 2, (1 + level) / 2], dof * n_runs)
    return lo / n_runs, hi / n_runs


def armse(err: ArrayLike, valid: ArrayLike | None = None) -> MCValue:
    r"""Accumulative RMSE (Liu & Wu 2017, Eqs. 41-42):
    :math:`\sqrt{\frac1N\sum_k \mathrm{RMSE}^2(k)}` with
    :math:`\mathrm{RMSE}^2(k) = \frac1M\sum_m \lVert e_{m,k}\rVert^2` -- ``err`` (M, K, d), the
    squared errors summed over the d components (x and y) first."""
    e, ok = _runs(err, "err", valid, ndims=(3,))
    sq = (e ** 2).sum(axis=-1)
    return _rms(sq.mean(axis=1), ok)


def mean_rmse_over_time(err: ArrayLike, valid: ArrayLike | None = None) -> MCValue:
    r"""Mean over steps of the per-step RMSE across runs (Hu et al. 2017, Table 1 "mean of RMSE"):
    :math:`\frac1K\sum_k \sqrt{m_k}`, :math:`m_k = \frac1M\sum_r e_{r,k}^2`; ``err`` (M, K).

    Standard error by the delta method with per-run influence values
    :math:`u_r = \frac1K\sum_k e_{r,k}^2 / (2\sqrt{m_k})` (runs are the independent replications)."""
    e, ok = _runs(err, "err", valid, ndims=(2,))
    if not ok.any():
        return MCValue(np.nan, np.nan, 0, int((~ok).sum()))
    sq = e[ok] ** 2
    m_k = sq.mean(axis=0)
    value = np.sqrt(m_k).mean()
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.where(m_k > 0, sq / (2.0 * np.sqrt(m_k)), 0.0).mean(axis=1)
    se = u.std(ddof=1) / np.sqrt(len(u)) if len(u) > 1 else np.nan
    return MCValue(value, se, int(ok.sum()), int((~ok).sum()))


def _statistic_value(x) -> float:
    """What a jackknife ``statistic`` returned, as a float: a real number (Python or numpy, or a 0-d array), else a
    ValueError naming ``statistic``."""
    arr = np.asarray(x) if not isinstance(x, (str, bytes)) else None
    if arr is None or arr.shape != () or arr.dtype.kind not in "iuf":
        raise ValueError(f"statistic: expected a function returning a real number, it returned "
                         f"{type(x).__name__}{'' if arr is None or arr.shape == () else f' of shape {arr.shape}'}")
    return float(x)


def jackknife(statistic: Callable, samples: ArrayLike, valid: ArrayLike | None = None) -> MCValue:
    """Delete-one-run jackknife standard error of ``statistic(samples)`` (samples: runs first);
    for statistics without a simple closed-form error, e.g. the s.d. over time of a per-step RMSE.

    ``statistic`` maps an array of runs (n, ...) to a real number; ``samples`` (M, ...) runs first;
    ``valid`` None or a boolean mask (M,)."""
    if not callable(statistic):
        raise ValueError(f"statistic: expected a function of the samples, got {type(statistic).__name__}")
    s, ok = _runs(samples, "samples", valid)
    s = s[ok]
    n = s.shape[0]
    if n == 0:
        return MCValue(np.nan, np.nan, 0, int((~ok).sum()))
    value = _statistic_value(statistic(s))
    if n < 2:
        return MCValue(value, np.nan, n, int((~ok).sum()))
    loo = np.array([_statistic_value(statistic(np.delete(s, i, axis=0))) for i in range(n)])
    se = float(np.sqrt((n - 1) / n * ((loo - loo.mean()) ** 2).sum()))
    return MCValue(value, se, n, int((~ok).sum()))


def wilson_interval(successes: int, n: int, level: float = 0.95) -> tuple[float, float]:
    r"""Wilson score interval for a binomial proportion (Wilson 1927, J. Amer. Statist. Assoc. 22:209; Agresti &
    Coull 1998, The American Statistician 52(2):119): with :math:`\hat p = k/n` and
    :math:`z = \Phi^{-1}((1 + \mathrm{level})/2)` (1.96 at 95 %),

    .. math:: \frac{\hat p + z^2/(2n) \pm z\sqrt{\hat p(1-\hat p)/n + z^2/(4n^2)}}{1 + z^2/n}.

    ``successes`` k and ``n`` integers with 0 <= k <= n, n >= 1; ``level`` in (0, 1).  Returns ``(low, high)``
    within [0, 1] (exactly 0 when k = 0 and 1 when k = n).  For a sample drawn without replacement from a finite
    population the interval is conservative (it ignores the finite-population correction)."""
    n = check_positive_int(n, "n")
    k = check_positive_int(successes, "successes", minimum=0)
    if k > n:
        raise ValueError(f"successes: {k} of only n = {n}")
    level = check_scalar(level, "level", positive=True)
    if not level < 1.0:
        raise ValueError(f"level: expected a probability in (0, 1), got {level!r}")
    from scipy import stats
    z = float(stats.norm.ppf(0.5 + level / 2))
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    low = 0.0 if k == 0 else max(0.0, float(centre - half))
    high = 1.0 if k == n else min(1.0, float(centre + half))
    return low, high
