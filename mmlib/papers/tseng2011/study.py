"""One universe of Tseng et al. 2011's reading space: its evaluation, values, rows, claims and effects.

``universe(reading, n_runs, seed)`` is the multiverse job; the notebook's headline rows and claims are
:func:`table_rows` and :func:`judge_claims` of :func:`evaluate_reading` on the headline reading, the same functions.
The values (:func:`values`) are the table's East/North position RMS errors over runs and all 1800 epochs (m) and
the relative reductions 100 (1 - RMS_a / RMS_b) they imply (%, with jackknife standard errors); every row is judged
by the one verdict rule (the paper's run count is unknown, T-13: its Monte Carlo error is not added).  The effects
(:func:`effects`) are paired MSE differences over East + North (m²) on common random numbers.  A universe is flagged
*degenerate* (:func:`degenerate_reason`) when no filter's horizontal position RMSE beats the no-information
baseline, the single-epoch least-squares fix from the same pseudoranges (:mod:`mmlib.papers.tseng2011.baseline`).
"""
from __future__ import annotations

import functools
import math
from dataclasses import replace
from typing import Iterable, Mapping

import numpy as np

from mmlib.experiment import digests, evaluation, metrics, report
from mmlib.experiment.metrics import MCValue
from mmlib.experiment.montecarlo import MonteCarlo
from mmlib.experiment.report import Row
from mmlib.experiment.universe import UniverseResult
from mmlib.papers.tseng2011 import baseline
from mmlib.papers.tseng2011.setup import Setup, setup
from mmlib.papers.tseng2011.simulation import GEOMETRY_FIELDS, experiment, make_batch_fn
from mmlib.papers.tseng2011.space import SPACE
from mmlib.papers.tseng2011.text import (ALGORITHMS, AXES, EAST, IMM_EFFECT, ITEM, KEY_EFFECT, NAME, NORTH, PAIRS,
                                         PUBLISHED, ROOT_SEED, published_mse_difference)

__all__ = [
    "universe", "evaluate_reading", "summarise", "judge_claims", "rms", "horizontal_rms", "rms_reduction", "values",
    "table_rows", "size_parts", "direction_parts", "diverged", "divergence_judgement", "effects", "baseline_rms",
    "degenerate_reason", "headline_digest", "BASELINE_FIELDS"
]


# ---------------------------------------------------------------- evaluation
def _canonical(setup: Setup, name: str) -> Setup:
    """The setup with every field that cannot affect estimator ``name`` reset to its default, so that
    readings differing only there share one evaluation (the UKF sees only its own level; the IMM not the
    fuzzy system or the UKF's rule; the fuzzy IMM not the UKF's rule)."""
    d = Setup()
    fuzzy = dict(xi_breakpoints=d.xi_breakpoints, dod_normalise=d.dod_normalise, mf_scale=d.mf_scale,
                 dod_window=d.dod_window)
    if name in ("UKF", "EKF"):
        return replace(setup, s_ukf=setup.ukf_level, ukf_rule=d.ukf_rule, s_lower=d.s_lower, s_upper=d.s_upper,
                       p_stay=d.p_stay, mu0=d.mu0, **fuzzy)
    if name == "IMMUKF":
        return replace(setup, s_ukf=None, ukf_rule=d.ukf_rule, **fuzzy)
    return replace(setup, s_ukf=None, ukf_rule=d.ukf_rule)


@functools.lru_cache(maxsize=48)
def _evaluate_one(setup: Setup, name: str, root_seed: int, n_runs: int, progress: bool, consistency: bool = False):
    ex = experiment(setup, names=(name,))
    mc = MonteCarlo(root_seed, n_runs)
    rs = evaluation.evaluate(ex.estimators, make_batch_fn(ex, mc), mc, label=f"{NAME} {name}", progress=progress,
                             measurement_models=ex.measurement_models, consistency=consistency)[name]
    for arr in rs:
        if isinstance(arr, np.ndarray):
            arr.setflags(write=False)            # shared between readings: never modified in place
    return rs


def evaluate_reading(reading: Mapping, mc: MonteCarlo, progress: bool = False,
                     names: Iterable[str] = ALGORITHMS, consistency: bool = False) -> dict:
    """The Monte Carlo evaluations ``{name: RunSet}`` of a reading, on the paper's per-run streams.

    Each estimator is evaluated alone on its canonical set-up (:func:`_canonical`): its numbers are
    those of a joint evaluation bit for bit (every estimator sees the same truth, measurements and
    initial draws, which depend only on the run), and readings that differ only in fields an
    estimator does not use reuse its evaluation within this process (exact, not approximate).
    ``consistency=True`` also records every run's NEES and NIS per step (``RunSet.nees``, ``nis``, ``nis_dof``:
    :func:`mmlib.experiment.evaluation.evaluate`); the errors are the same bits either way."""
    s = setup(reading)
    return {name: _evaluate_one(_canonical(s, name), name, mc.root_seed, mc.n_runs, bool(progress),
                                bool(consistency))
            for name in names}


# ---------------------------------------------------------------- statistics and values
def rms(rs: evaluation.RunSet, component: int) -> MCValue:
    """RMS over runs and all epochs of one state component (the paper's East/North RMS error, m)."""
    return metrics.rmse_time_averaged(rs.errors[..., component], rs.valid)


def horizontal_rms(rs: evaluation.RunSet) -> MCValue:
    r"""Horizontal position RMSE :math:`\sqrt{\frac{1}{NK}\sum_{r,k}(e_{r,k}^2 + n_{r,k}^2)}` (m) over the valid
    runs and all epochs, with its standard error over runs: what :func:`degenerate_reason` compares with the
    single-epoch fix (:func:`mmlib.papers.tseng2011.baseline.ls_rms`); its square is the sum of the squared East and
    North :func:`rms`."""
    return metrics.rmse_time_averaged(np.hypot(rs.errors[..., EAST], rs.errors[..., NORTH]), rs.valid)


def rms_reduction(a: evaluation.RunSet, b: evaluation.RunSet, component: int) -> MCValue:
    """Percentage reduction of the RMS error of ``a`` relative to ``b``, 100 (1 - RMS_a / RMS_b), on
    common random numbers, with a delete-one-run jackknife standard error (runs diverged in either
    are excluded)."""
    ok = a.valid & b.valid
    pair = np.stack([a.errors[..., component], b.errors[..., component]], axis=-1)      # (N, K, 2)

    def stat(s):
        ms = (s ** 2).mean(axis=(0, 1))
        return 100.0 * (1.0 - math.sqrt(ms[0] / ms[1]))

    return metrics.jackknife(stat, pair, ok)


def values(results: dict) -> list:
    """The universe's values ``(item, algorithm, quantity, replicated, stderr)``: the absolute RMS errors per
    axis (m) and the relative reductions of :data:`~mmlib.papers.tseng2011.text.PAIRS` (%)."""
    out = []
    for alg in ALGORITHMS:
        for lab, _, comp in AXES:
            v = rms(results[alg], comp)
            out.append((ITEM, alg, f"{lab} position RMS error (m)", float(v.value), float(v.stderr)))
    for a, b in PAIRS:
        for lab, _, comp in AXES:
            v = rms_reduction(results[a], results[b], comp)
            out.append((ITEM, f"{a} vs {b}", f"{lab} RMS reduction (%)", float(v.value), float(v.stderr)))
    return out


def table_rows(vals: list, n_runs: int) -> list:
    """The table's rows (``report.Row``) from a universe's :func:`values`, judged by the one verdict rule (the
    paper's run count is unknown, T-13: its Monte Carlo error is not added)."""
    by_key = {(i, a, q): (r, s) for i, a, q, r, s in vals}
    rows = []
    for pub in PUBLISHED:
        replicated, stderr = by_key[pub.key]
        if "reduction" in pub.quantity:
            note, devs = "published value computed from the printed RMS errors", ["T-7", "T-8", "T-10", "T-14"]
        else:
            note = ("absolute error of a reconstructed set-up (Section 4 lost): judged by the rule, but only the "
                    "relative rows are comparable in kind")
            devs = ["T-1", "T-4", "T-7", "T-8", "T-14"]
        rows.append(report.make_row(pub.item, pub.algorithm, pub.quantity, pub.printed, replicated, stderr,
                                    n_runs=n_runs, deviations=devs, note=note))
    return rows


# ---------------------------------------------------------------- claims
def size_parts(rows: Iterable[Row]) -> list:
    """Parts (:class:`mmlib.experiment.report.Part`, one per reduction row ``"A vs B"``, comparison ``"A − B"``,
    quantity ``"<axis> RMS reduction (ours vs printed <p> %)"``) on a claimed *size* of improvement: the claim is
    that the reduction is (at least about) the printed one.  A row the number rule finds reproduced or qualitatively
    reproduced (within 25 %) preserves the claimed size: the part holds.  Otherwise the part is the paired test of
    ``replicated - printed`` (percentage points) against 0 with the row's standard error, expected sign +1 and the
    printed value as reference (:func:`mmlib.experiment.report.part`): a reduction smaller than printed by 3 s.e.
    contradicts the claimed size, a larger one holds, an undetectable difference (e.g. an inconclusive row) is no
    detectable difference."""
    parts = []
    for r in rows:
        a, _, b = r.algorithm.partition(" vs ")
        comparison = f"{a} − {b}" if b else r.algorithm
        quantity = f"{r.quantity.split()[0]} RMS reduction (ours vs printed {r.paper} %)"
        diff, ref = r.replicated - float(r.paper), float(r.paper)
        if report.verdict_category(r.verdict) in (report.REPRODUCED, report.QUALITATIVE):
            parts.append(report.Part(comparison, quantity, report.PartVerdict.HOLDS, diff, r.stderr, ref, "%"))
        else:
            parts.append(report.part(comparison, quantity, diff, r.stderr, +1, reference=ref, unit="%"))
    return parts


def direction_parts(results: dict, a: str, b: str) -> tuple[list, str]:
    """Parts on "``a`` is more accurate than ``b``", one per axis: the paired difference of per-run mean squared
    errors ``a − b`` on common random numbers (m², :func:`mmlib.experiment.evaluation.paired_mse_difference`),
    relative to b's mean squared error; and the evidence text."""
    parts = []
    for lab, _, comp in AXES:
        d = evaluation.paired_mse_difference(results[a], results[b], comp)
        ref = float((results[b].errors[results[b].valid][..., comp] ** 2).mean())
        parts.append(report.part(f"{a} − {b}", f"{lab} position MSE", float(d.value), float(d.stderr), -1,
                                 reference=ref, unit="m²", ops=evaluation.pair_operations(results[a], results[b])))
    return parts, _evidence(parts)


def _evidence(parts) -> str:
    return "; ".join(p.number() for p in parts)


def diverged(results: dict) -> dict:
    """Diverged runs per algorithm of :data:`~mmlib.papers.tseng2011.text.ALGORITHMS`."""
    return {a: int((~results[a].valid).sum()) for a in ALGORITHMS}


def divergence_judgement(div: Mapping[str, int], n_runs: int) -> report.Judgement:
    """The claim "the approach prevents the divergence problem" from the diverged runs per algorithm ``div``
    (:func:`diverged`): *not assessable* when no filter diverged (no divergence to prevent), *holds* when
    FUZZY-IMMUKF never diverged and another did, *contradicted* when it diverged at least as often as both others,
    *partly* otherwise; the decisive text is the counts."""
    counts = f"diverged runs FUZZY-IMMUKF {div['FUZZY-IMMUKF']}, IMMUKF {div['IMMUKF']}, UKF {div['UKF']} of {n_runs}"
    if not any(div.values()):
        return report.Judgement.of(report.NOT_ASSESSABLE, f"no filter diverged ({n_runs} runs): no divergence to "
                                                          f"prevent")
    if div["FUZZY-IMMUKF"] == 0:
        return report.Judgement.of(report.HOLDS, counts)
    if div["FUZZY-IMMUKF"] >= max(div["UKF"], div["IMMUKF"]):
        return report.Judgement.of(report.CONTRADICTED, counts)
    return report.Judgement.of(report.PARTLY, counts)


def judge_claims(results: dict, rows: list, n_runs: int) -> report.Claims:
    """The claims of the abstract and conclusions (:class:`mmlib.experiment.report.Claims`, with evidence), from
    the evaluations and the universe's :func:`table_rows`: direction parts on paired differences
    (:func:`direction_parts`), size parts on the reduction rows (:func:`size_parts`), one flat list of parts judged
    once per claim (:func:`mmlib.experiment.report.judge`)."""
    red = {(r.algorithm, r.quantity.split()[0]): r for r in rows if "reduction" in r.quantity}
    claims = report.Claims()
    direction, evidence = direction_parts(results, "IMMUKF", "UKF")
    claims.add("IMMUKF is more accurate than the UKF (conclusions: 'superior navigation accuracy')",
               report.judge(direction), evidence, key="immukf_vs_ukf")
    for other in ("IMMUKF", "UKF"):
        # "remarkable improvement": more accurate (paired MSE differences) AND by the table's margin (the
        # RMS reductions); one claim verdict from all four parts
        direction, evidence = direction_parts(results, "FUZZY-IMMUKF", other)
        size = size_parts([red[(f"FUZZY-IMMUKF vs {other}", lab)] for lab, _, _ in AXES])
        claims.add(f"FUZZY-IMMUKF shows remarkable improvement over {other} (abstract)",
                   report.judge(direction + size),
                   evidence + "; RMS reductions against the table's: " + _evidence(size),
                   key=f"fuzzy_vs_{other.lower()}")
    for a, b, text, key in (("IMMUKF", "UKF", "IMMUKF's errors are about 62-64 % below the UKF's (table)",
                             "immukf_reduction"),
                            ("FUZZY-IMMUKF", "IMMUKF", "FUZZY-IMMUKF's errors are about 66-68 % below IMMUKF's (table)",
                             "fuzzy_reduction")):
        size = size_parts([red[(f"{a} vs {b}", lab)] for lab, _, _ in AXES])
        claims.add(text, report.judge(size), "relative RMS reductions: " + _evidence(size), key=key)
    direction, evidence = direction_parts(results, "FUZZY-IMMUKF", "IMMUKF")
    claims.add("The FLAS determines better lower and upper process-noise bounds online than fixed bounds "
               "(Sec. 3, conclusions)", report.judge(direction),
               "FUZZY-IMMUKF against IMMUKF with the fixed bounds: " + evidence, key="flas_bounds")
    div = diverged(results)
    claims.add("The approach prevents the divergence problem in high dynamic environments (conclusions)",
               divergence_judgement(div, n_runs), "diverged runs: " + ", ".join(f"{a} {d}/{n_runs}"
                                                                                 for a, d in div.items()),
               key="prevents_divergence")
    claims.add("A lower-order filter model suffices with less computation (conclusions)",
               report.Judgement.of(report.NOT_ASSESSABLE, "no filter-order comparison survives in the text"), "",
               key="lower_order")
    return claims


def effects(results: dict) -> list:
    """The effects ``(name, value, stderr, published)``: paired MSE differences over East + North (m²), the key
    effect FUZZY-IMMUKF minus IMMUKF and the IMM's gain IMMUKF minus UKF, with the published counterparts
    (:func:`~mmlib.papers.tseng2011.text.published_mse_difference`)."""
    out = []
    for name, a, b in ((KEY_EFFECT, "FUZZY-IMMUKF", "IMMUKF"), (IMM_EFFECT, "IMMUKF", "UKF")):
        d = evaluation.paired_mse_difference(results[a], results[b], (EAST, NORTH))
        out.append((name, float(d.value), float(d.stderr), published_mse_difference(a, b)))
    return out


# ---------------------------------------------------------------- the universe
@functools.lru_cache(maxsize=16)
def _baseline(fields: tuple, root_seed: int, n_runs: int) -> MCValue:
    """The single-epoch fix's horizontal RMSE of a geometry and clock (``fields``: (name, value) pairs of
    :data:`BASELINE_FIELDS`) on the runs ``0 .. n_runs - 1``: readings that differ only in filter settings see the same
    truth and pseudoranges, so they share it (deterministic: sharing changes no number)."""
    ex = experiment(Setup(**dict(fields)), names=("UKF",))
    return baseline.ls_rms(ex, MonteCarlo(root_seed, n_runs))


#: the Setup fields the fix's truth and pseudoranges depend on: the geometry's and the clock's
BASELINE_FIELDS = GEOMETRY_FIELDS + ("clock_h0", "clock_h_minus2")


def baseline_rms(reading: Mapping, mc: MonteCarlo) -> MCValue:
    """The no-information baseline of ``reading`` on the runs of ``mc``: the horizontal position RMSE (m) of the
    single-epoch least-squares fix from the same pseudoranges the filters see
    (:func:`mmlib.papers.tseng2011.baseline.ls_rms`)."""
    s = setup(reading)
    return _baseline(tuple((f, getattr(s, f)) for f in BASELINE_FIELDS), mc.root_seed, mc.n_runs)


def degenerate_reason(results: Mapping, baseline_value: metrics.MCValue) -> str:
    """Why the universe of ``results`` (``{name: RunSet}`` of :data:`~mmlib.papers.tseng2011.text.ALGORITHMS`) is
    degenerate, or "" (:func:`mmlib.experiment.evaluation.degenerate_reason`): no filter's horizontal position RMSE
    (:func:`horizontal_rms`, m) is detectably and non-negligibly below ``baseline_value``, the single-epoch fix's
    (:func:`baseline_rms`, m, with its standard error): no filter then learns anything from the dynamics."""
    return evaluation.degenerate_reason({a: horizontal_rms(results[a]) for a in ALGORITHMS},
                                        baseline_value, what=baseline.WHAT)


def summarise(results: dict, n_runs: int, degenerate: str = "") -> UniverseResult:
    """A universe's result from its evaluations: :func:`values`, the claims of :func:`judge_claims` (on the
    :func:`table_rows`), :func:`effects` and the :func:`diverged` runs; ``degenerate`` the reason the universe is
    degenerate (:func:`degenerate_reason`), "" when it is not."""
    vals = values(results)
    claims = judge_claims(results, table_rows(vals, n_runs), n_runs)
    return UniverseResult.build(values=vals, claims=claims, diverged=diverged(results), effects=effects(results),
                                n_runs=n_runs, degenerate=degenerate)


def universe(reading: Mapping, n_runs: int, seed: int) -> UniverseResult:
    """The multiverse job: one reading's universe on the paper's root seed and per-run streams, flagged degenerate
    when no filter beats the single-epoch fix (:func:`degenerate_reason`)."""
    mc = MonteCarlo(seed, n_runs)
    results = evaluate_reading(reading, mc)
    return summarise(results, n_runs, degenerate_reason(results, baseline_rms(reading, mc)))


def headline_digest(n_runs: int) -> dict:
    """The run digest (:func:`mmlib.experiment.digests.run_digest`) of the headline universe's first
    ``n_runs`` runs (the three filters and the EKF) on the paper's root seed: what the notebook stores as
    ``digest`` in ``data/results/tseng2011.json``, recomputed without the notebook (tests/tolerance/test_digest.py)."""
    return digests.run_digest(evaluate_reading(SPACE.headline, MonteCarlo(ROOT_SEED, n_runs),
                                               names=ALGORITHMS + ("EKF",)), n_runs)
