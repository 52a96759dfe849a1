"""One universe of Zhou et al. 2017's reading space: the Monte Carlo evaluation of a reading, its Table 2-3 rows,
the claims of the abstract and conclusions, the effects and the :class:`~mmlib.experiment.universe.UniverseResult`.

A universe is :func:`universe` = :func:`summarise` of :func:`evaluate_reading` (Case 1: IMM-UKF, CPIMM-UKF, IMM-EKF
and IMM-CKF without faults; Case 2: IMM-UKF, IMM-NAUKF, CPIMM-UKF and CPIMM-NAUKF with the sensor faults of Eq. 2,
all on the same runs); the notebook's headline rows and claims are :func:`judge_claims` of the same evaluation of the
headline reading, so the headline universe is the notebook's numbers bit for bit.  The key effect
(:data:`~mmlib.papers.zhou2017.text.KEY_EFFECT`) is the paired time-averaged position MSE difference CPIMM-NAUKF
minus IMM-UKF in Case 2 (m^2); its published counterpart is (m^2 + s^2) of Table 3's rows
(:func:`~mmlib.papers.zhou2017.text.published_mse_difference`).
"""
from __future__ import annotations

import functools
from dataclasses import replace
from typing import Iterable, Mapping, Sequence

import numpy as np

from mmlib.experiment import digests, evaluation, metrics, report
from mmlib.experiment.montecarlo import MonteCarlo, say_progress
from mmlib.experiment.universe import UniverseResult
from mmlib.papers.zhou2017 import text
from mmlib.papers.zhou2017.baseline import (  # noqa: F401  (re-exported: the notebook and tests use them here)
    BASELINE_WHAT, POSITION, VELOCITY, Baseline, baselines, degenerate_reason, error_norms, measurement_only_errors,
    paired_error, position_rmse)
from mmlib.papers.zhou2017.section23 import section23_claims
from mmlib.papers.zhou2017.setup import Setup, make_batch_fn, setup as reading_setup
from mmlib.papers.zhou2017.text import (CASE1_ALGORITHMS, CASE2_ALGORITHMS, KEY_EFFECT, TABLE2, TABLE2_DEVIATIONS,
                                        TABLE2_NAMES, TABLE3, TABLE3_DEVIATIONS, TABLE3_NAMES, TABLE_QUANTITIES,
                                        published_mse_difference)

__all__ = [
    "universe", "evaluate_reading", "summarise", "judge_claims", "relevant_setup", "evaluate_algorithm",
    "consistency_entries", "table_stats", "table_rows", "compare", "headline_digest", "Q4", "TRANSIENT_STEPS",
    "NAUKF_ANALYSIS", "NAUKF_EVIDENCE"
]

Q4 = (("position", POSITION), ("velocity", VELOCITY))
#: steps (0-based, step k at t = k + 1 s) of the 10 s after each maneuver switch (20, 40, 60, 80 s): the
#: transients in which "faster convergence" would show
TRANSIENT_STEPS = tuple(k for t0 in (20, 40, 60, 80) for k in range(t0, t0 + 10))


#: Setup fields only NAUKF reads, and fields Case 1 (no faults) never reads
_NAUKF_FIELDS = ("window", "psi", "inflate_only")
_FAULT_FIELDS = ("fault_range_max", "fault_bearing_rate_max", "fault_kind")


def relevant_setup(setup: Setup, algorithm: str) -> Setup:
    """``setup`` with the fields ``algorithm``'s results cannot depend on reset to the headline: the
    NAUKF fields for a non-adaptive algorithm, the fault fields when there are no faults, the UKF's
    parameters for the EKF and CKF.  Two readings with the same relevant set-up give the same numbers bit
    for bit (same runs, same streams), so their evaluation is shared (:func:`evaluate_algorithm`)."""
    default = Setup()
    fields = ((() if "NAUKF" in algorithm else _NAUKF_FIELDS) + (() if setup.faults else _FAULT_FIELDS)
              + (() if "UKF" in algorithm else ("ukf",)))
    return replace(setup, **{f: getattr(default, f) for f in fields})


@functools.lru_cache(maxsize=64)
def _evaluate_cached(setup: Setup, algorithm: str, mc: MonteCarlo, consistency: bool = False):
    mb, est, _ = make_batch_fn(setup, mc, names=(algorithm,))
    return evaluation.evaluate(est, mb, mc, progress=False, consistency=consistency)[algorithm]


def evaluate_algorithm(setup: Setup, algorithm: str, mc: MonteCarlo, consistency: bool = False
                       ) -> evaluation.RunSet:
    """RunSet of one algorithm under ``setup`` on ``mc``'s runs (chunks of 250 runs, common random
    numbers).  Each algorithm runs alone on the batch every algorithm sees, so the numbers do not
    depend on which others ran; results are memoised per process by the relevant set-up
    (:func:`relevant_setup`), which makes a design's universes that share it cheap.  ``consistency`` also records
    every run's NEES and NIS per step (:func:`mmlib.experiment.evaluation.evaluate`); the estimates, and so every
    other number, are the same bits either way.  Treat the result as read-only."""
    if algorithm not in CASE1_ALGORITHMS + CASE2_ALGORITHMS:
        raise ValueError(f"algorithm: expected one of {CASE1_ALGORITHMS + CASE2_ALGORITHMS}, got {algorithm!r}")
    if not isinstance(consistency, bool):
        raise ValueError(f"consistency: expected True or False, got {consistency!r}")
    return _evaluate_cached(relevant_setup(setup, algorithm), algorithm, mc, consistency)


def evaluate_reading(reading: Mapping, mc: MonteCarlo, progress: bool = False, consistency: bool = False) -> dict:
    """Monte Carlo evaluations of a reading on ``mc``'s runs: ``{"case 1": {alg: RunSet}, "case 2": ...}``
    (Case 1: CASE1_ALGORITHMS without faults; Case 2: CASE2_ALGORITHMS with the sensor fault); ``consistency``
    records the NEES and NIS too (:func:`evaluate_algorithm`; for :func:`consistency_entries`)."""
    case1, case2 = reading_setup(reading)
    out = {"case 1": {}, "case 2": {}}
    for key, setup, names in (("case 1", case1, CASE1_ALGORITHMS), ("case 2", case2, CASE2_ALGORITHMS)):
        for alg in names:
            out[key][alg] = evaluate_algorithm(setup, alg, mc, consistency)
            if progress:
                say_progress(f"  {text.NAME} {key}: {alg} done ({mc.n_runs} runs)")
    return out


def consistency_entries(results: dict) -> list:
    """The ``consistency`` section of the results file (:func:`mmlib.experiment.evaluation.consistency_entries`):
    ANEES (4 degrees of freedom, the state [x, vx, y, vy]) and ANIS (2, range and bearing) with their 95 % chi-square
    bands, for every algorithm of both cases of ``results`` (:func:`evaluate_reading` with ``consistency=True``),
    over the runs that did not diverge; an entry per algorithm per case, ``case`` "case 1" or "case 2"."""
    if not isinstance(results, Mapping) or set(results) != {"case 1", "case 2"}:
        raise ValueError("results: expected evaluate_reading(...)'s {'case 1': {...}, 'case 2': {...}}")
    return [e for case in ("case 1", "case 2")
            for e in evaluation.consistency_entries(results[case], len(Setup().x0), case=case)]




def table_stats(rs: evaluation.RunSet, comps: Sequence[int]) -> tuple[metrics.MCValue, metrics.MCValue]:
    """Mean and s.d. over the steps of the per-step RMSE over runs (Eq. 45, Z-10), with standard errors
    (delta method; delete-one-run jackknife)."""
    e = error_norms(rs, comps)
    mean = metrics.mean_rmse_over_time(e, rs.valid)
    sd = metrics.jackknife(lambda s: np.sqrt((s ** 2).mean(axis=0)).std(), e, rs.valid)
    return mean, sd


def table_rows(item: str, results: dict, names: Iterable[tuple[str, str]], table: dict,
               devs: Iterable[str]) -> list:
    """Report rows of a Table 2/3-style table; an algorithm diverged in every run gets 'not reproduced'."""
    out = []
    for alg, printed_name in names:
        rs = results[alg]
        vals = [*table_stats(rs, POSITION), *table_stats(rs, VELOCITY)]
        for q, v, printed in zip(TABLE_QUANTITIES, vals, table[printed_name]):
            if v.n_runs == 0:
                out.append(report.analytic_row(item, alg, q, printed, f"diverged in {v.n_excluded}/{v.n_excluded} runs",
                                               False, deviations=devs))
            else:
                out.append(report.make_row(item, alg, q, printed, v.value, v.stderr, n_runs=v.n_runs,
                                           n_runs_paper=text.N_RUNS, deviations=devs,
                                           note=f"{v.n_excluded} diverged runs excluded" if v.n_excluded else ""))
    return out


def _steps(rs, steps):
    return rs if steps is None else rs._replace(errors=rs.errors[:, list(steps)])


#: the squared unit of a mean squared error over the state components (position m², velocity m²/s²)
_UNITS = {POSITION: "m²", VELOCITY: "m²/s²"}


def compare(results: dict, pairs: Iterable[tuple[str, str]],
            quantities: Iterable[tuple[str, Sequence[int]]] = Q4,
            steps: Iterable[int] | None = None) -> tuple:
    """Judgement (:func:`mmlib.experiment.verdicts.judge`) and evidence for "a is more accurate than b" for every
    (a, b) in ``pairs``, each over ``quantities``: one part per pair and quantity from the paired time-averaged
    MSE difference on the runs valid in both, relative to b's (:func:`mmlib.experiment.verdicts.part`, "A − B",
    "<quantity> MSE", m² or m²/s²), and, when either diverged in some run, one part "a diverges no more often than
    b" from the paired difference of the divergence indicators relative to b's divergence rate (a run that
    diverges has no accuracy).  ``steps`` restricts the MSE to those steps.  All parts are judged once."""
    parts, evidence = [], []
    for a, b in pairs:
        ra, rb = _steps(results[a], steps), _steps(results[b], steps)
        da, db = (~ra.valid).astype(float), (~rb.valid).astype(float)
        if (da.any() or db.any()) and not (da.all() and db.all()):   # both diverging in every run: no comparison
            d = metrics.mean_with_se(da - db)
            parts.append(report.part(f"{a} − {b}", "divergence rate", float(d.value), float(d.stderr), -1,
                                     reference=float(db.mean()), unit="of the runs"))
            evidence.append(f"{a} vs {b}: diverged runs {int(da.sum())} vs {int(db.sum())} of {len(da)}")
        ok = ra.valid & rb.valid
        if not ok.any():
            continue
        for label, comp in quantities:
            d = evaluation.paired_mse_difference(ra, rb, comp)
            ref = float((rb.errors[ok][..., list(comp)] ** 2).sum(axis=-1).mean())
            parts.append(report.part(f"{a} − {b}", f"{label} MSE", float(d.value), float(d.stderr), -1,
                                     reference=ref, unit=_UNITS.get(tuple(comp), ""),
                                     ops=evaluation.pair_operations(ra, rb)))
            evidence.append(f"{a} vs {b}, {label}: Δ(mean squared error) = "
                            f"{report.format_pm(float(d.value), float(d.stderr), signed=True)} "
                            f"({100 * float(d.value) / ref:+.2g} %)")
    return report.judge(parts), "; ".join(evidence)


#: the decisive finding of the analysis of NAUKF's third-order claim, and its evidence
NAUKF_ANALYSIS = ("analysis: Eqs. 27-28 keep the UKF's predicted measurement mean, so under a fault the innovation "
                  "has mean δh_out ≠ 0: wrong at order zero, whatever the order of the transform")
NAUKF_EVIDENCE = ("analytic (Theorem 1 and its proof, Sec. 3.2): Eqs. 27-28 change only the innovation covariance, "
                  "i.e. they replace the predicted innovation covariance by an empirical one (IAE adaptation); the "
                  "predicted measurement mean stays the UKF's, without the fault delta h_out of Eq. 2, and nothing in "
                  "it removes a measurement bias; Eqs. 29-31 are asserted, not derived. As printed, the posterior "
                  "P - P_xz C^-1 P_xz^T is not even a covariance whenever C falls below H P H^T (Z-12; the diverged "
                  "runs are counted in every universe). No reading changes this.")


def judge_claims(results: dict) -> tuple:
    """Rows of Tables 2-3, the claims (:class:`mmlib.experiment.report.Claims`), effects and diverged-run counts of
    one reading's evaluations (``results`` from :func:`evaluate_reading`)."""
    res1, res2 = results["case 1"], results["case 2"]
    rows = table_rows("Table 2", res1, TABLE2_NAMES, TABLE2, TABLE2_DEVIATIONS)
    rows += table_rows("Table 3", res2, TABLE3_NAMES, TABLE3, TABLE3_DEVIATIONS)
    s23 = section23_claims()
    claims = report.Claims()
    claims.add("MSE overestimates the covariance of the interacted variable; CP is accurate (Sec. 2.3, Table 1)",
               *s23["overestimates"], key="mse_overestimates")
    claims.add("CPIMM is more accurate than IMM (Case 1, Table 2)", *compare(res1, [("CPIMM-UKF", "IMM-UKF")]),
               key="cpimm_vs_imm")
    claims.add("CPIMM's interaction solves the non-Gaussian problem with second-order accuracy (Sec. 3.1.3)",
               *s23["second order"], key="cpimm_second_order")
    ukf, ukf_ev = compare(res1, [("IMM-UKF", "IMM-EKF"), ("IMM-UKF", "IMM-CKF")])
    claims.add("UKF has better filtering precision than KF, EKF and CKF (Sec. 4.2.1), on the Sec. 4.1 radar "
               "scenario (Case 1)", ukf, ukf_ev + "; KF is not applicable to the range-bearing radar; on linear "
               "models EKF, CKF, UKF and KF coincide exactly", key="ukf_best_filter")
    claims.add("CPIMM-UKF is more accurate than IMM-UKF under sensor faults (Table 3)",
               *compare(res2, [("CPIMM-UKF", "IMM-UKF")]), key="cpimm_ukf_faults")
    claims.add("IMM-NAUKF is more accurate than IMM-UKF under sensor faults (Table 3)",
               *compare(res2, [("IMM-NAUKF", "IMM-UKF")]), key="naukf_faults")
    claims.add("CPIMM-NAUKF is the most accurate of the four under sensor faults (Table 3)",
               *compare(res2, [("CPIMM-NAUKF", b) for b in ("IMM-UKF", "IMM-NAUKF", "CPIMM-UKF")]),
               key="cpimm_naukf_best_faults")
    fast, fast_ev = compare(res2, [("CPIMM-NAUKF", "IMM-UKF")],
                            quantities=(("transient position", POSITION), ("transient velocity", VELOCITY)),
                            steps=TRANSIENT_STEPS)
    claims.add("CPIMM-NAUKF converges faster than IMM-UKF (Sec. 4.1.2, conclusions)", fast,
               "position and velocity MSE over the 10 s after each maneuver switch (20, 40, 60, 80 s): " + fast_ev,
               key="cpimm_naukf_converges")
    claims.add("NAUKF (Eqs. 27-31) satisfies the third-order precision conditions under faults",
               report.Judgement.of(report.CONTRADICTED, NAUKF_ANALYSIS), NAUKF_EVIDENCE,
               key="naukf_third_order")
    claims.add("CPIMM-NAUKF performs best in the vehicle and UAV experiments (Tables 4-5)",
               report.Judgement.of(report.NOT_ASSESSABLE, "data not published (Z-11)"),
               "the synthetic analogue of the notebook is not evidence either way", key="field_experiments")
    effects = []
    for name, res, a, b, table in ((KEY_EFFECT, res2, "CPIMM-NAUKF", "IMM-UKF", TABLE3),
                                   ("IMM-NAUKF − IMM-UKF, Case 2 position MSE (m²)", res2, "IMM-NAUKF", "IMM-UKF",
                                    TABLE3),
                                   ("CPIMM-UKF − IMM-UKF, Case 2 position MSE (m²)", res2, "CPIMM-UKF", "IMM-UKF",
                                    TABLE3),
                                   ("CPIMM-UKF − IMM-UKF, Case 1 position MSE (m²)", res1, "CPIMM-UKF", "IMM-UKF",
                                    {"CPIMM-UKF": TABLE2["CPIMM"], "IMM-UKF": TABLE2["IMM"]})):
        d = evaluation.paired_mse_difference(res[a], res[b], POSITION)
        value = float(d.value) if d.n_runs else None
        stderr = float(d.stderr) if d.n_runs > 1 else None
        effects.append((name, value, stderr, published_mse_difference(table, a, b)))
    diverged = {f"case {c} {alg}": int((~rs.valid).sum())
                for c, res in ((1, res1), (2, res2)) for alg, rs in res.items()}
    return rows, claims, effects, diverged


def summarise(results: dict, n_runs: int, base: Mapping) -> UniverseResult:
    """The universe result (:meth:`UniverseResult.build`) of one reading's evaluations: the
    Table 2-3 values (an algorithm diverged in every run is marked failed), the claims, the effects
    (KEY_EFFECT first), the diverged-run counts and, from the measurement-only baselines ``base`` of the same runs
    (:func:`baselines`), why the universe is degenerate (:func:`degenerate_reason`, "" when it is not)."""
    rows, claims, effects, diverged = judge_claims(results)
    values = []
    for r in rows:
        if r.replicated is None:
            values.append((r.item, r.algorithm, r.quantity, None, None, r.note))
        else:
            values.append((r.item, r.algorithm, r.quantity, r.replicated, r.stderr))
    return UniverseResult.build(values=values, claims=claims, diverged=diverged, effects=effects, n_runs=n_runs,
                                degenerate=degenerate_reason(results, base))


def universe(reading: Mapping[str, str], n_runs: int, seed: int) -> UniverseResult:
    """The multiverse job: one reading on ``n_runs`` runs of the root seed ``seed`` (per-run streams), flagged
    degenerate where its filters do no better than the measurement-only estimate (:func:`summarise`)."""
    mc = MonteCarlo(seed, n_runs)
    return summarise(evaluate_reading(reading, mc), n_runs, baselines(reading, mc))


def headline_digest(n_runs: int) -> dict:
    """The run digest (:func:`mmlib.experiment.digests.run_digest`) of the headline universe's first
    ``n_runs`` runs (both cases) on the paper's root seed: what the notebook stores as ``digest`` in
    ``data/results/zhou2017.json``, recomputed without the notebook (tests/tolerance/test_digest.py)."""
    return digests.run_digest(evaluate_reading(text.SPACE.headline, MonteCarlo(text.ROOT_SEED, n_runs)), n_runs)
