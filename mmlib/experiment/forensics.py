"""Forensics that prove themselves: how often the table match names the right reading when the answer is known.

The table match (:meth:`mmlib.experiment.multiverse.Multiverse.table_match`) names the declared reading whose
values lie closest to a published table.  Whether that is a finding or noise depends on how well the table
identifies a reading at the paper's run count and printed precision.  :func:`planted_recovery` measures it: it
*plants* readings, drawing universes at random from the candidates, generates from each a synthetic printed table,
runs the same match on it, and counts how often the planted reading is ranked first and within the first three.
:func:`indistinguishable` names the options of a factor whose tables a paper-sized Monte Carlo cannot tell apart:
such a factor is *unidentifiable* from the table, and a match can never be evidence for one of its options.

A synthetic table from planted universe :math:`p` is, cell by cell,

.. math:: y_j = \\operatorname{round}_{d_j}\\bigl(v_{pj} + \\varepsilon_j\\bigr),\\qquad
          \\varepsilon_j \\sim N\\bigl(0,\\ s_{pj}^2 + s_{pj}^2 M / M_p\\bigr),

with :math:`v_{pj}` and :math:`s_{pj}` our value and standard error at :math:`M` runs per universe, :math:`M_p` the
paper's run count (its Monte Carlo error, the verdict rule's :math:`s_p`, is 0 when the paper does not state
:math:`M_p`) and :math:`d_j` the printed number's decimals.  Our estimate :math:`v_{pj}` stands for the truth, so
the paper's draw is an independent stream: the difference between the synthetic table and our value then has the
variance :math:`s_{pj}^2 (1 + M/M_p)` that an independent paper and our estimate would have
(Gaussian approximation of the Monte Carlo errors; the draws come from their own seeded generator, never from a
run's streams).  Two assumptions make the rates upper bounds rather than exact: the candidates' own values are held
fixed, so their Monte Carlo differences count as real separation (exact only when all universes share our runs'
errors, as common random numbers nearly make them), and a paper that does not state its run count is given no
Monte Carlo error of its own.

A factor is *unidentifiable* from a table when two of its options, varied alone from the headline (the headline's
option and the star universes'), are confused by the match more often than :data:`CONFUSION`: for tables
:math:`a` and :math:`b` and per-cell noise :math:`\\sigma_j^2 = s_j^2 (1 + M/M_p) + u_j^2` (a printed table's
Monte Carlo error and rounding, :math:`u_j` half a unit of its last digit), the probability that a printed table from
:math:`a` lies closer to :math:`b` is :math:`\\Phi(-d/2)` with :math:`d^2 = \\sum_j (a_j - b_j)^2/\\sigma_j^2`
(two Gaussians of one covariance).  Such options give "the same table within noise"; a match can be no evidence for
either.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from mmlib.core._validate import as_float_array, check_positive_int
from mmlib.experiment import verdicts
from mmlib.experiment.metrics import wilson_interval

__all__ = [
    "planted_recovery", "confusion", "synthetic_table", "rms_relative", "scale", "CONFUSION", "RECOVERY_TRIALS"
]

#: two options are confused (their factor unidentifiable) when a printed table from one is closer to the other with
#: at least this probability
CONFUSION = 0.05

#: planted readings drawn per table (at most the number of candidates): a rate from 50 trials is known to about
#: +-14 points (95 % Wilson interval at 50 %)
RECOVERY_TRIALS = 50


def _decimals(printed: str) -> int:
    """Decimals to round to for a number as printed: '2.48' -> 2, '120' -> 0, '1.5e-3' -> 4 (the last printed digit's
    place; negative for a printed exponent above it, e.g. '2e3' -> -3)."""
    mantissa, _, exponent = printed.strip().lower().partition("e")
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    return decimals - (int(exponent) if exponent else 0)


def scale(printed: str) -> float:
    """The magnitude a printed number's relative distance refers to: ``|printed|``, or half a unit of its last
    printed digit when it is printed as 0 (the table match's, :mod:`mmlib.experiment.multiverse`)."""
    p = abs(float(printed))
    return p if p > 0 else verdicts.printed_half_unit(printed)


def synthetic_table(values: np.ndarray, stderrs: np.ndarray, printed: Sequence[str], rng: np.random.Generator,
                    n_runs: int, n_runs_paper: int | None) -> np.ndarray:
    """One synthetic printed table (J,) from one universe's ``values`` and ``stderrs`` (J,) (module docstring):
    Gaussian noise of variance :math:`s^2(1 + M/M_p)` (``n_runs`` M, ``n_runs_paper`` M_p, None for an unstated
    count: :math:`s^2`), rounded to each ``printed`` number's decimals."""
    values = as_float_array(values, "values")
    stderrs = as_float_array(stderrs, "stderrs")
    if values.shape != stderrs.shape or values.ndim != 1 or len(printed) != values.shape[0]:
        raise ValueError(f"values, stderrs, printed: expected one of each per cell, got shapes {values.shape}, "
                         f"{stderrs.shape} and {len(printed)} printed numbers")
    n_runs = check_positive_int(n_runs, "n_runs")
    ratio = 0.0 if n_runs_paper is None else n_runs / check_positive_int(n_runs_paper, "n_runs_paper")
    noisy = values + stderrs * math.sqrt(1.0 + ratio) * rng.standard_normal(values.shape[0])
    return np.array([round(float(y), _decimals(p)) for y, p in zip(noisy, printed)])


def rms_relative(candidates: np.ndarray, table: np.ndarray, scales: np.ndarray) -> np.ndarray:
    """Root-mean-square relative distance of every candidate's values (C, J) from a printed ``table`` (J,), each
    cell over its ``scales`` (J,) (:func:`scale`): the distance the table match ranks by."""
    rel = (candidates - table[None, :]) / scales[None, :]
    return np.sqrt(np.mean(rel * rel, axis=1))


def planted_recovery(values: np.ndarray, stderrs: np.ndarray, printed: Sequence[str], readings: Sequence[dict],
                     factors: Sequence[str], *, n_runs: int, n_runs_paper: int | None, seed: int,
                     trials: int = RECOVERY_TRIALS) -> dict:
    """Plant readings and match them back (module docstring).

    ``values``, ``stderrs``: (C, J) the candidates' values and standard errors of the J cells (every candidate a
    reading of the text whose every cell is precise enough, as the table match requires); ``printed``: the J printed
    numbers (their decimals and magnitudes); ``readings``: the C candidates' readings; ``factors``: the factor ids
    whose recovery is reported.  ``trials`` candidates (at most C) are planted, drawn without replacement with
    ``numpy.random.default_rng(seed)``, which also draws the synthetic tables.

    Returns ``planted`` (trials run), ``top1`` and ``top3`` (the mean over trials of the probability that the planted
    universe ranks first, within the first three, with ties among equally distant candidates broken at random: a
    trial with ``b`` candidates strictly closer and ``t`` others tied scores ``clip((k - b)/(1 + t), 0, 1)`` for
    the first ``k``), their 95 % Wilson intervals ``top1_interval``, ``top3_interval`` (on the rounded count of
    successes), ``by_factor`` (factor -> fraction of trials whose best match, ties broken by candidate order, has
    the planted option of that factor) and ``by_factor_chance`` (the same for a match drawn at random among the
    candidates: the mean share of candidates that have the planted option)."""
    if isinstance(readings, (str, bytes, dict)) or not all(isinstance(r, dict) for r in readings):
        raise ValueError("readings: expected one reading (a dict factor id -> option) per candidate")
    if isinstance(factors, (str, bytes)) or not all(isinstance(f, str) and all(f in r for r in readings)
                                                     for f in factors):
        raise ValueError(f"factors: expected factor ids that every reading names, got {factors!r}")
    values = as_float_array(values, "values")
    stderrs = as_float_array(stderrs, "stderrs")
    if values.ndim != 2 or values.shape != stderrs.shape or values.shape[0] != len(readings) \
            or values.shape[1] != len(printed):
        raise ValueError(f"values, stderrs: expected (candidates, cells) = ({len(readings)}, {len(printed)}), got "
                         f"{values.shape} and {stderrs.shape}")
    if not (np.isfinite(values).all() and np.isfinite(stderrs).all()):
        raise ValueError("values, stderrs: every candidate's cells must be finite (precise candidates only)")
    trials = check_positive_int(trials, "trials")
    C = values.shape[0]
    rng = np.random.default_rng(check_positive_int(seed, "seed", minimum=0))
    planted = rng.choice(C, size=min(trials, C), replace=False)
    scales = np.array([scale(p) for p in printed])
    top1 = top3 = 0.0
    hits = {f: 0 for f in factors}
    chance = {f: 0.0 for f in factors}
    for p in planted:
        table = synthetic_table(values[p], stderrs[p], printed, rng, n_runs, n_runs_paper)
        d = rms_relative(values, table, scales)
        better, tied = int(np.sum(d < d[p])), int(np.sum(d == d[p])) - 1
        top1 += min(1.0, max(0.0, (1 - better) / (1 + tied)))
        top3 += min(1.0, max(0.0, (3 - better) / (1 + tied)))
        best = int(np.argmin(d))
        for f in factors:
            hits[f] += readings[best][f] == readings[p][f]
            chance[f] += sum(r[f] == readings[p][f] for r in readings) / C
    n = len(planted)
    return {"planted": n, "top1": top1 / n, "top3": top3 / n,
            "top1_interval": list(wilson_interval(int(round(top1)), n)),
            "top3_interval": list(wilson_interval(int(round(top3)), n)),
            "by_factor": {f: hits[f] / n for f in factors}, "by_factor_chance": {f: chance[f] / n for f in factors}}


def confusion(a: np.ndarray, sa: np.ndarray, b: np.ndarray, sb: np.ndarray, printed: Sequence[str],
              n_runs: int, n_runs_paper: int | None) -> dict:
    r"""How often a printed table from one of two universes' tables (values ``a``, ``b`` with standard errors
    ``sa``, ``sb``, all (J,)) would lie closer to the other (module docstring): ``distance``
    :math:`d = \sqrt{\sum_j (a_j - b_j)^2/\sigma_j^2}` with :math:`\sigma_j^2 = \bar s_j^2 (1 + M/M_p) + u_j^2`
    (:math:`\bar s_j` the larger standard error, M ``n_runs``, M_p ``n_runs_paper`` (None: no paper error),
    :math:`u_j` half a unit of the printed number's last digit), ``probability`` :math:`\Phi(-d/2)`, and
    ``confused``, whether it reaches :data:`CONFUSION`."""
    a, sa, b, sb = (as_float_array(x, name) for x, name in ((a, "a"), (sa, "sa"), (b, "b"), (sb, "sb")))
    if not (a.shape == sa.shape == b.shape == sb.shape == (len(printed),)):
        raise ValueError(f"a, sa, b, sb: expected one value per printed number ({len(printed)}), got {a.shape}, "
                         f"{sa.shape}, {b.shape}, {sb.shape}")
    n_runs = check_positive_int(n_runs, "n_runs")
    ratio = 0.0 if n_runs_paper is None else n_runs / check_positive_int(n_runs_paper, "n_runs_paper")
    u = np.array([verdicts.printed_half_unit(p) for p in printed])
    sigma2 = np.maximum(sa, sb) ** 2 * (1.0 + ratio) + u ** 2
    diff2 = (a - b) ** 2
    if np.any((sigma2 == 0) & (diff2 > 0)):
        d = math.inf
    else:
        d = float(np.sqrt(np.sum(np.where(sigma2 > 0, diff2 / np.where(sigma2 > 0, sigma2, 1.0), 0.0))))
    prob = 0.5 * math.erfc(d / 2.0 / math.sqrt(2.0))
    return {"distance": d, "probability": prob, "confused": prob >= CONFUSION}
