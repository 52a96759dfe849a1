r"""Error metrics with Monte Carlo standard errors.

All functions take errors or squared errors with the run axis first and a
``valid`` mask of runs (diverged runs excluded *and counted*).  Standard errors
treat runs as independent replications; for root-mean quantities they use the
delta method, :math:`\mathrm{se}(\sqrt{m}) \approx \mathrm{se}(m)/(2\sqrt m)`.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy import stats


class MCValue(NamedTuple):
    value: np.ndarray
    stderr: np.ndarray
    n_runs: int          # runs used
    n_excluded: int      # diverged runs left out


def _valid(valid, n):
    return np.ones(n, dtype=bool) if valid is None else np.asarray(valid, dtype=bool)


def mean_with_se(samples, valid=None) -> MCValue:
    """Mean over runs (axis 0) and its standard error."""
    samples = np.asarray(samples, dtype=float)
    ok = _valid(valid, samples.shape[0])
    s = samples[ok]
    n = s.shape[0]
    if n == 0:
        nan = np.full(samples.shape[1:], np.nan)
        return MCValue(nan, nan, 0, int((~ok).sum()))
    se = s.std(axis=0, ddof=1) / np.sqrt(n) if n > 1 else np.full(s.shape[1:], np.nan)
    return MCValue(s.mean(axis=0), se, n, int((~ok).sum()))


def timing_ratio(times, reference) -> MCValue:
    r"""Run-time ratio of one algorithm to a reference from paired repeated timings (one value per repeat):
    the median of the per-repeat ratios, with the standard error of a median,
    :math:`\sqrt{\pi/2}\,\hat\sigma/\sqrt{n}` (asymptotic, normal data), the spread estimated robustly as
    :math:`\hat\sigma = 1.4826\,\mathrm{MAD}`.  Timings on a shared machine carry occasional large
    disturbances (a repeat several times slower); the median and the MAD keep a few of them from deciding
    a verdict, where a mean and a standard deviation let them flip it between identical runs."""
    times, reference = np.asarray(times, dtype=float), np.asarray(reference, dtype=float)
    if times.shape != reference.shape or times.ndim != 1 or times.size < 2:
        raise ValueError(f"times, reference: expected two 1-D arrays of the same length >= 2, got shapes "
                         f"{times.shape} and {reference.shape}")
    if not (np.all(np.isfinite(times)) and np.all(np.isfinite(reference)) and np.all(reference > 0)):
        raise ValueError("times, reference: timings must be finite and the reference's positive")
    r = times / reference
    med = float(np.median(r))
    sigma = 1.4826 * float(np.median(np.abs(r - med)))
    return MCValue(np.float64(med), np.float64(np.sqrt(np.pi / 2) * sigma / np.sqrt(r.size)), int(r.size), 0)


def rms_with_se(squared_errors, valid=None) -> MCValue:
    """``sqrt(mean over runs of squared_errors)`` (axis 0), delta-method standard error."""
    m = mean_with_se(squared_errors, valid)
    root = np.sqrt(m.value)
    with np.errstate(divide="ignore", invalid="ignore"):
        se = np.where(root > 0, m.stderr / (2.0 * root), 0.0)
    return MCValue(root, se, m.n_runs, m.n_excluded)


def rmse_over_time(err, valid=None) -> MCValue:
    r"""Per-step RMSE across runs, :math:`\sqrt{\frac1M\sum_m e_{m,k}^2}` -- ``err`` (M, K[, d]);
    with a trailing axis d the squared errors are summed over it first (e.g. position
    error = x and y together, Liu & Wu 2017 Eq. 41)."""
    sq = np.asarray(err, dtype=float) ** 2
    return rms_with_se(sq, valid)


def rmse_time_averaged(err, valid=None, steps=None) -> MCValue:
    r"""Zhu et al. 2016 Eq. 64 read as
    :math:`\sqrt{\frac{1}{MK}\sum_m\sum_k e_{m,k}^2}` (runs m, steps k) per component.

    ``err`` (M, K) or (M, K, d); the per-run time means are the independent
    replications for the standard error."""
    sq = np.asarray(err, dtype=float) ** 2
    if steps is not None:
        sq = sq[:, steps]
    return rms_with_se(sq.mean(axis=1), valid)


def nees(err, cov):
    """Normalised estimation error squared per run and step: e^T P^-1 e; err (..., n), cov (..., n, n)."""
    sol = np.linalg.solve(cov, err[..., None])[..., 0]
    return np.sum(err * sol, axis=-1)


def chi2_band(dof: int, n_runs: int, level: float = 0.95):
    """Two-sided acceptance band for the run-average of a chi-square(dof) statistic over n_runs runs
    (Bar-Shalom et al. 2001, Sec. 5.4.2)."""
    lo, hi = stats.chi2.ppf([(1 - level) / 2, (1 + level) / 2], dof * n_runs)
    return lo / n_runs, hi / n_runs


def armse(err, valid=None) -> MCValue:
    r"""Accumulative RMSE (Liu & Wu 2017, Eqs. 41-42):
    :math:`\sqrt{\frac1N\sum_k \mathrm{RMSE}^2(k)}` with
    :math:`\mathrm{RMSE}^2(k) = \frac1M\sum_m \lVert e_{m,k}\rVert^2` -- ``err`` (M, K, d), the
    squared errors summed over the d components (x and y) first."""
    sq = (np.asarray(err, dtype=float) ** 2).sum(axis=-1)
    return rms_with_se(sq.mean(axis=1), valid)


def mean_rmse_over_time(err, valid=None) -> MCValue:
    r"""Mean over steps of the per-step RMSE across runs (Hu et al. 2017, Table 1 "mean of RMSE"):
    :math:`\frac1K\sum_k \sqrt{m_k}`, :math:`m_k = \frac1M\sum_r e_{r,k}^2`; ``err`` (M, K).

    Standard error by the delta method with per-run influence values
    :math:`u_r = \frac1K\sum_k e_{r,k}^2 / (2\sqrt{m_k})` (runs are the independent replications)."""
    e = np.asarray(err, dtype=float)
    ok = _valid(valid, e.shape[0])
    if not ok.any():
        return MCValue(np.nan, np.nan, 0, int((~ok).sum()))
    sq = e[ok] ** 2
    m_k = sq.mean(axis=0)
    value = np.sqrt(m_k).mean()
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.where(m_k > 0, sq / (2.0 * np.sqrt(m_k)), 0.0).mean(axis=1)
    se = u.std(ddof=1) / np.sqrt(len(u)) if len(u) > 1 else np.nan
    return MCValue(value, se, int(ok.sum()), int((~ok).sum()))


def jackknife(statistic, samples, valid=None) -> MCValue:
    """Delete-one-run jackknife standard error of ``statistic(samples)`` (samples: runs first);
    for statistics without a simple closed-form error, e.g. the s.d. over time of a per-step RMSE."""
    s = np.asarray(samples, dtype=float)
    ok = _valid(valid, s.shape[0])
    s = s[ok]
    n = s.shape[0]
    if n == 0:
        return MCValue(np.nan, np.nan, 0, int((~ok).sum()))
    value = float(statistic(s))
    if n < 2:
        return MCValue(value, np.nan, n, int((~ok).sum()))
    loo = np.array([statistic(np.delete(s, i, axis=0)) for i in range(n)])
    se = float(np.sqrt((n - 1) / n * ((loo - loo.mean()) ** 2).sum()))
    return MCValue(value, se, n, int((~ok).sum()))
