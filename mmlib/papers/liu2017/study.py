"""One universe of Liu & Wu 2017's reading space: Example 1 and both cases of Example 2 run under a reading on
common random numbers (:func:`evaluate_reading`), and what they give (:func:`summarise`): the ARMSE (Eq. 42) of
every printed cell of Tables 1 and 3 (m, m/s, m/s^2) with its Monte Carlo standard error, the claims' verdicts
(:func:`mmlib.papers.liu2017.claims.judge_claims`), the paired position-MSE effects (m^2) and the diverged runs.

:func:`universe` is the multiverse's job; :func:`table_rows` the notebook's comparison rows of a universe; and
:func:`headline_digest` the run digest the notebook stores and the tests recompute.
"""
from __future__ import annotations

from typing import Mapping, NamedTuple

import numpy as np

from mmlib.core.models import RangeBearing
from mmlib.experiment import digests, evaluation, metrics, report
from mmlib.experiment.montecarlo import MonteCarlo
from mmlib.experiment.universe import UniverseResult
from mmlib.papers.liu2017 import text
from mmlib.papers.liu2017.claims import after_onset, judge_claims
from mmlib.papers.liu2017.setup import Examples, build, for_reading, make_batch_fn

__all__ = [
    "universe", "evaluate_reading", "summarise", "ReadingResults", "measurement_only_errors", "table_values", "effects",
    "diverged", "position_rmse", "degenerate_cases", "degenerate", "table_rows", "headline_digest", "BASELINE"
]

#: the no-information baseline of the degenerate flag (:func:`degenerate`)
BASELINE = "the measurement-only estimate's position RMSE"


class ReadingResults(NamedTuple):
    """Monte Carlo results of one reading: ``runs[case][algorithm]`` is a RunSet, ``setups`` the reading's
    :class:`~mmlib.papers.liu2017.setup.Examples`, ``measurement_only[case]`` the (N, K, 2) position error (m) of
    every radar measurement inverted alone (:func:`measurement_only_errors`)."""

    reading: dict
    setups: Examples
    runs: dict
    measurement_only: dict | None = None


def measurement_only_errors(radar: RangeBearing, truth: np.ndarray, z: np.ndarray) -> np.ndarray:
    r"""Position error (m) of the measurement-only estimate, (B, K, 2): every radar measurement inverted alone,
    :math:`\hat p_k = s + r_k (\cos\theta_k, \sin\theta_k)` with ``s`` the radar's position (the origin, Eq.
    40), minus the true position (x, y) at steps 1..K.  ``truth`` (B, K+1, 6) with x_0 first, ``z`` (B, K, 2)
    range (m) and bearing (rad).  It uses no dynamics and no prior: the no-information baseline of
    :func:`degenerate`."""
    r, theta = z[..., 0], z[..., 1]
    est = np.stack([radar.sensor[0] + r * np.cos(theta), radar.sensor[1] + r * np.sin(theta)], axis=-1)
    return est - truth[:, 1:][..., list(radar.position_index)]


def evaluate_reading(reading: Mapping[str, str], mc: MonteCarlo, progress: bool = False,
                     consistency: bool = False) -> ReadingResults:
    """Example 1 (the five filters of Table 1 and the plain CKF) and both cases of Example 2 (the five
    filters of Table 3) under ``reading``, all on the runs of ``mc`` (common random numbers), and each case's
    measurement-only errors (:func:`measurement_only_errors`, from the same truth and measurements).
    ``consistency=True`` also records every filter's NEES and NIS per run and step in its RunSet
    (:func:`mmlib.experiment.evaluation.evaluate`; the estimates are the same bits either way), what
    :func:`mmlib.papers.liu2017.diagnostics.consistency` reads."""
    reading = text.SPACE.validate(reading)
    sets = for_reading(reading)
    runs, meas_only = {}, {}
    for case in text.CASES:
        make_batch, estimators, _ = make_batch_fn(sets[case], mc, names=text.CASE_FILTERS[case])
        runs[case] = evaluation.evaluate(estimators, make_batch, mc, label=f"{text.NAME} {case}", progress=progress,
                                         consistency=consistency)
        radar = build(sets[case])[1]
        parts = []
        for chunk in mc.chunks(250):
            truth, z, _ = make_batch(chunk)
            parts.append(measurement_only_errors(radar, truth, z))
        meas_only[case] = np.concatenate(parts)
    return ReadingResults(reading, sets, runs, meas_only)


def table_values(results: ReadingResults) -> list:
    """``(item, algorithm, quantity, ARMSE, standard error)`` of every printed cell of Tables 1 and 3
    (Eq. 42; diverged runs excluded)."""
    out = []
    for case in text.CASES:
        for alg in text.FILTERS:
            rs = results.runs[case][alg]
            for quantity, idx in text.QUANTITIES:
                est = metrics.armse(rs.errors[..., list(idx)], rs.valid)
                out.append((text.ITEMS[case], alg, quantity, float(est.value), float(est.stderr)))
    return out


def effects(results: ReadingResults) -> list:
    """Named paired position MSE differences (m²) with standard errors and the published counterpart
    (ARMSE_a² − ARMSE_b² from the tables; none for the after-the-onset effect, which the paper does not
    print)."""
    out = []
    for name, case, a, b, after in text.EFFECTS:
        ra, rb = results.runs[case][a], results.runs[case][b]
        if after:
            k0 = results.setups[case].onset_index
            ra, rb = after_onset(ra, k0), after_onset(rb, k0)
        d = evaluation.paired_mse_difference(ra, rb, text.POSITION)
        published = None if after else text.published_mse_difference(case, a, b)
        out.append((name, float(d.value), float(d.stderr), published))
    return out


def diverged(results: ReadingResults) -> dict:
    """Diverged runs per ``"<case> <algorithm>"`` (e.g. ``"Example 1 STCKF"``), over every case of
    :data:`text.CASES`."""
    return {f"{case} {alg}": int((~rs.valid).sum()) for case in text.CASES for alg, rs in results.runs[case].items()}


def position_rmse(results: ReadingResults, case: str) -> dict:
    """Per filter of ``case``, its position ARMSE (m, Eq. 42: over its valid runs and every step; NaN when every
    run diverged)."""
    return {alg: metrics.armse(rs.errors[..., list(text.POSITION)], rs.valid)
            for alg, rs in results.runs[case].items()}


def degenerate_cases(results: ReadingResults) -> dict:
    """Per case of :data:`text.CASES`, why it is degenerate or ""
    (:func:`mmlib.experiment.evaluation.degenerate_reason`): every filter's position ARMSE (:func:`position_rmse`) at
    least the measurement-only estimate's (:func:`measurement_only_errors`, the same ARMSE over every run and step),
    the no-information baseline."""
    if results.measurement_only is None:
        raise ValueError("results: no measurement-only errors (ReadingResults from evaluate_reading)")
    return {case: evaluation.degenerate_reason(position_rmse(results, case),
                                               metrics.armse(results.measurement_only[case]),
                                               what=BASELINE)
            for case in text.CASES}


def degenerate(results: ReadingResults) -> str:
    """Why the universe is degenerate, or "".  The rule (zhou2017's too): a universe is degenerate when *any* case its
    claims use (Example 1 and both cases of Example 2, :data:`text.CASES`) is degenerate (:func:`degenerate_cases`):
    the universe's claims pool its cases, so a comparison on a case where no filter beats the measurement-only
    estimate would enter the shares through them."""
    cases = degenerate_cases(results)
    if not any(cases.values()):
        return ""
    return "; ".join(f"{case}: {why}" for case, why in cases.items() if why)


def summarise(results: ReadingResults, n_runs: int) -> UniverseResult:
    """The universe result of one reading: Table 1 and 3 values, claim verdicts, effects (the key
    effect first), diverged-run counts and whether the universe is degenerate (:func:`degenerate`)."""
    return UniverseResult.build(values=table_values(results), claims=judge_claims(results),
                                diverged=diverged(results), effects=effects(results), n_runs=n_runs,
                                degenerate=degenerate(results))


def universe(reading: Mapping[str, str], n_runs: int, seed: int) -> UniverseResult:
    """The paper's ``universe`` (the multiverse job): one reading on ``n_runs`` runs of the root seed ``seed``."""
    return summarise(evaluate_reading(reading, MonteCarlo(seed, n_runs)), n_runs)


def table_rows(summary: UniverseResult) -> list:
    """Comparison rows (:func:`mmlib.experiment.report.make_row`) of Tables 1 and 3 from a universe result."""
    case_of = {v: k for k, v in text.ITEMS.items()}
    rows = []
    for v in summary.values:
        case = case_of[v.item]
        qi = [q for q, _ in text.QUANTITIES].index(v.quantity)
        ndiv = summary.diverged.get(f"{case} {v.algorithm}", 0)
        rows.append(report.make_row(v.item, v.algorithm, v.quantity, text.PRINTED[case][v.algorithm][qi],
                                    v.replicated, v.stderr, n_runs=summary.n_runs, n_runs_paper=text.N_RUNS,
                                    deviations=text.ROW_DEVIATIONS[case],
                                    note=f"{ndiv} diverged runs excluded" if ndiv else ""))
    return rows


def headline_digest(n_runs: int) -> dict:
    """The run digest (:func:`mmlib.experiment.digests.run_digest`) of the headline universe's first
    ``n_runs`` runs (Example 1 and both cases of Example 2) on the paper's root seed: what the notebook stores as
    ``digest`` in ``data/results/liu2017.json``, recomputed without the notebook (tests/tolerance/test_digest.py)."""
    return digests.run_digest(evaluate_reading(text.SPACE.headline, MonteCarlo(text.ROOT_SEED, n_runs)).runs, n_runs)
