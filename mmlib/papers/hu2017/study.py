"""Hu et al. 2017: one universe of the reading space -- the five IMMs evaluated under one reading, Table 1's
values, the claims of Sec. 3 and the conclusions, the effects -- and the headline's digest.

Every universe runs the five IMMs on the same per-run streams (common random numbers: truth, measurement and
bootstrap draws do not depend on the reading), so paired differences between algorithms and between universes
are what the claims and the specification curve use.  Errors in km, mean squared errors in km^2.
"""
from __future__ import annotations

from typing import Iterable, Mapping, NamedTuple

import numpy as np

from mmlib.core.estimation import run
from mmlib.core.models import RangeBearing
from mmlib.experiment import digests, evaluation, metrics, report
from mmlib.experiment.montecarlo import MonteCarlo
from mmlib.experiment.universe import UniverseResult
from mmlib.papers.hu2017.setup import Setup, batch, setup, truth_and_radar
from mmlib.papers.hu2017.text import (ALGORITHMS, N_RUNS, NAME, RMSE_METRICS, ROOT_SEED, SPACE, TABLE1,
                                      TABLE1_QUANTITIES, published_position_mse)

__all__ = [
    "universe", "evaluate_reading", "summarise", "judge_claims", "ReadingResult", "measurement_only_errors",
    "table1_metric", "true_mode_probability", "mode_matching_difference", "nees_average", "position_rmse", "degenerate",
    "table1_rows", "headline_digest", "NEES_ALGORITHMS", "KEY_EFFECT", "MSE_EFFECTS", "AXES", "POSITION", "BASELINE",
    "EKF_COMPARATORS"
]

#: estimators whose covariance is kept for NEES
NEES_ALGORITHMS = ("IMMCDKF", "IMMCDKF-OBS")
#: the effects of every universe: name -> (algorithm a, algorithm b) for paired position-MSE differences a - b
KEY_EFFECT = "mse_obs_minus_cdkf"
MSE_EFFECTS = {KEY_EFFECT: ("IMMCDKF-OBS", "IMMCDKF"),
               "mse_cdkf_minus_ukf": ("IMMCDKF", "IMMUKF"),
               "mse_cdkf_minus_ekf": ("IMMCDKF", "IMMEKF"),
               "mse_cdkf_minus_ckf": ("IMMCDKF", "IMMCKF")}
#: Table 1's axes: (label, state component)
AXES = (("horizontal", 0), ("vertical", 2))
#: the state components of the position (x, y)
POSITION = (0, 2)
#: the no-information baseline of the degenerate flag (:func:`degenerate`)
BASELINE = "the measurement-only estimate's position RMSE"


class ReadingResult(NamedTuple):
    """The Monte Carlo evaluation of one reading (runs first everywhere)."""

    setup: Setup
    runs: dict                 # algorithm -> evaluation.RunSet
    nees: dict                 # NEES_ALGORITHMS -> (N, K) NEES per run and step, NaN for diverged runs
    true_modes: np.ndarray     # (K,) index of the true mode at steps 1..K
    nonlinearity: np.ndarray   # (N, K) sigma_pos / range of IMMCDKF's estimate (NaN for diverged runs)
    times: np.ndarray          # (K,) s
    measurement_only: np.ndarray | None = None  # (N, K, 2) position error of each measurement inverted alone (km)


def measurement_only_errors(radar: RangeBearing, truth: np.ndarray, z: np.ndarray) -> np.ndarray:
    r"""Position error (km) of the measurement-only estimate, (B, K, 2): every radar measurement inverted alone,
    :math:`\hat p_k = s + r_k (\cos\theta_k, \sin\theta_k)` with ``s`` the radar's position, minus the true
    position (x, y) at steps 1..K.  ``truth`` (B, K+1, n) with x_0 first, ``z`` (B, K, 2) range (km) and bearing
    (rad).  It uses no dynamics and no prior: the no-information baseline of :func:`degenerate`."""
    r, theta = z[..., 0], z[..., 1]
    est = np.stack([radar.sensor[0] + r * np.cos(theta), radar.sensor[1] + r * np.sin(theta)], axis=-1)
    return est - truth[:, 1:][..., list(radar.position_index)]


def evaluate_reading(reading: Mapping, mc: MonteCarlo, progress: bool = False, chunk_size: int = 250,
                     consistency: bool = False) -> ReadingResult:
    """All five IMMs on ``mc``'s runs under one reading (common random numbers: truth, measurement and
    bootstrap draws come from the per-run streams, whatever the reading), plus a second pass that keeps
    the covariances of IMMCDKF and IMMCDKF-OBS for NEES (Bar-Shalom et al. 2001, Sec. 5.4.2) and inverts every
    measurement alone (:func:`measurement_only_errors`).  ``consistency=True`` also records every IMM's NEES and
    NIS per run and step in its RunSet (:func:`mmlib.experiment.evaluation.evaluate`; the estimates are the same
    bits either way), what :func:`mmlib.papers.hu2017.diagnostics.consistency` reads."""
    s = setup(reading)
    make_batch, estimators = batch(s, mc)
    schedule, radar = truth_and_radar(s)
    label = f"{NAME} {SPACE.describe(reading)}"
    runs = evaluation.evaluate(estimators, make_batch, mc, label=label, progress=progress, chunk_size=chunk_size,
                               consistency=consistency)
    nees = {alg: [] for alg in NEES_ALGORITHMS}
    nonlin, meas_only = [], []
    for chunk in mc.chunks(chunk_size):
        truth, z, init = make_batch(chunk)
        meas_only.append(measurement_only_errors(radar, truth, z))
        for alg in NEES_ALGORITHMS:
            tr = run(estimators[alg], init[alg], z)
            e = tr.mean - truth[:, 1:]
            ok = tr.diverged_step < 0
            val = np.full(e.shape[:2], np.nan)
            if ok.any():
                val[ok] = metrics.nees(e[ok], tr.cov[ok])
            nees[alg].append(val)
            if alg == "IMMCDKF":
                nl = np.full(e.shape[:2], np.nan)
                if ok.any():
                    sd = np.sqrt(tr.cov[ok][..., 0, 0] + tr.cov[ok][..., 2, 2])
                    nl[ok] = sd / np.hypot(tr.mean[ok][..., 0], tr.mean[ok][..., 2])
                nonlin.append(nl)
    return ReadingResult(s, runs, {k: np.concatenate(v) for k, v in nees.items()}, schedule.modes(),
                         np.concatenate(nonlin), schedule.times, np.concatenate(meas_only))


def table1_metric(rs: evaluation.RunSet, component: int, metric: str) -> metrics.MCValue:
    """Table 1's 'mean of RMSE' of one state component (km) under reading H-11, with its standard error:
    ``mean_over_steps`` = (1/K) sum_k sqrt(mean_r e_rk^2) (delta method, :func:`metrics.mean_rmse_over_time`);
    ``mean_over_runs`` = mean_r sqrt((1/K) sum_k e_rk^2) (runs independent); ``rms_runs_steps`` =
    sqrt(mean_r (1/K) sum_k e_rk^2) (:func:`metrics.rmse_time_averaged`)."""
    e = rs.errors[..., component]
    if metric == "mean_over_steps":
        return metrics.mean_rmse_over_time(e, rs.valid)
    if metric == "mean_over_runs":
        return metrics.mean_with_se(np.sqrt((e ** 2).mean(axis=1)), rs.valid)
    if metric == "rms_runs_steps":
        return metrics.rmse_time_averaged(e, rs.valid)
    raise ValueError(f"metric: expected one of {RMSE_METRICS}, got {metric!r}")


def true_mode_probability(res: ReadingResult, alg: str) -> np.ndarray:
    """Per run, the time average of the probability the IMM gives the true mode (N,); the 'model
    matching probability' of Figs. 1-5 reduced to one number per run."""
    mp = res.runs[alg].mode_probabilities
    return mp[:, np.arange(mp.shape[1]), res.true_modes].mean(axis=1)


def mode_matching_difference(res: ReadingResult, a: str, b: str) -> tuple:
    """Paired difference of the true-mode probability, a - b, over runs valid in both:
    (value, standard error, b's mean true-mode probability)."""
    ok = res.runs[a].valid & res.runs[b].valid
    pa, pb = true_mode_probability(res, a)[ok], true_mode_probability(res, b)[ok]
    d = metrics.mean_with_se(pa - pb)
    return float(d.value), float(d.stderr), float(pb.mean())


def _mode_claim(res: ReadingResult, a: str, others: Iterable[str]) -> tuple:
    """Judgement and evidence of "``a`` matches the true mode better than each of ``others``": one part per other
    algorithm on the paired difference of the time-averaged true-mode probability (:func:`mode_matching_difference`,
    relative to the other's mean), judged once (:func:`mmlib.experiment.verdicts.judge`)."""
    parts, ev = [], []
    for b in others:
        d, se, ref = mode_matching_difference(res, a, b)
        parts.append(report.part(f"{a} − {b}", "true-mode probability", d, se, +1, reference=ref, unit="probability",
                                 ops=evaluation.pair_operations(res.runs[a], res.runs[b])))
        ev.append(f"vs {b}: Δ(true-mode probability) = {report.format_pm(d, se, signed=True)} ({b}: {ref:.3f})")
    return report.judge(parts), "; ".join(ev)


def _better(r: dict, a: str, b: str) -> tuple:
    """Judgement and evidence of "``a`` is more accurate than ``b``" on Table 1's axes (:data:`AXES`): paired
    horizontal and vertical mean squared errors in km² (:func:`mmlib.experiment.evaluation.better_claim`)."""
    return evaluation.better_claim(r, a, b, AXES, unit="km²")


#: the comparators of "IMMEKF has the lowest precision": each must have a lower MSE than IMMEKF on both axes
EKF_COMPARATORS = ("IMMUKF", "IMMCKF", "IMMCDKF", "IMMCDKF-OBS")


def judge_claims(res: ReadingResult) -> report.Claims:
    """The accuracy and mode-identification claims of Sec. 3 and the conclusions, judged on paired
    differences over common random numbers, each a :class:`~mmlib.experiment.verdicts.Judgement` (one term of the
    claim vocabulary, its decisive number and its parts).  Under the printed CDKF form (H-1) and Julier's UKF
    parameters (H-10) IMMUKF is IMMCDKF exactly, so their comparisons are parts *identical (to round-off)*."""
    r = res.runs
    cl = report.Claims()
    cl.add("IMMCDKF-OBS is more accurate than IMMCDKF: bootstrapped observations improve precision without new "
           "sensors (abstract, Sec. 3, conclusions)", *_better(r, "IMMCDKF-OBS", "IMMCDKF"), key="obs_vs_immcdkf")
    for other in ("IMMUKF", "IMMEKF", "IMMCKF"):
        cl.add(f"IMMCDKF-OBS is more accurate than {other} (Table 1, Figs. 6-7)", *_better(r, "IMMCDKF-OBS", other),
               key=f"obs_vs_{other.lower()}")
    for other in ("IMMUKF", "IMMEKF", "IMMCKF"):
        cl.add(f"IMMCDKF is more accurate than {other} (Table 1)", *_better(r, "IMMCDKF", other),
               key=f"immcdkf_vs_{other.lower()}")
    # one flat list of parts (each comparator on each axis), judged once
    parts, ev = [], []
    for other in EKF_COMPARATORS:
        j, e = _better(r, other, "IMMEKF")
        parts += j.parts
        ev.append(f"{other} − IMMEKF: {e}")
    cl.add("IMMEKF has the lowest precision (Sec. 3)", report.judge(parts), " | ".join(ev), key="immekf_lowest")
    cl.add("The model matching probability of IMMCDKF is superior to IMMUKF, IMMEKF and IMMCKF (Figs. 1-5)",
           *_mode_claim(res, "IMMCDKF", ("IMMUKF", "IMMEKF", "IMMCKF")), key="immcdkf_mode_probability")
    cl.add("The model matching probability of IMMCDKF-OBS is superior to IMMUKF, IMMEKF and IMMCKF (Figs. 1-5)",
           *_mode_claim(res, "IMMCDKF-OBS", ("IMMUKF", "IMMEKF", "IMMCKF")), key="obs_mode_probability")
    cl.add("IMMCDKF-OBS identifies the modes better than IMMCDKF (Figs. 4-5)",
           *_mode_claim(res, "IMMCDKF-OBS", ("IMMCDKF",)), key="obs_identifies_modes")
    return cl


def nees_average(res: ReadingResult, alg: str) -> metrics.MCValue:
    """Time-averaged NEES per run (4 = consistent for the 4-dimensional state), mean over the runs that
    did not diverge, with its standard error."""
    per_run = np.nanmean(res.nees[alg], axis=1)
    return metrics.mean_with_se(per_run, np.isfinite(per_run))


def position_rmse(res: ReadingResult) -> dict:
    r"""Per IMM, the position RMSE (km) over its valid runs and all steps, :math:`\sqrt{\text{mean}_{r,k}
    (e_x^2 + e_y^2)}` (:func:`mmlib.experiment.metrics.armse`); NaN when every run diverged."""
    return {alg: metrics.armse(rs.errors[..., list(POSITION)], rs.valid) for alg, rs in res.runs.items()}


def degenerate(res: ReadingResult) -> str:
    """Why the universe is degenerate, or "": it is when every IMM's position RMSE (:func:`position_rmse`) is at
    least the measurement-only estimate's (:func:`measurement_only_errors`, the same RMSE over every run and step),
    the no-information baseline (:func:`mmlib.experiment.evaluation.degenerate_reason`): no IMM then does better
    than inverting each radar measurement alone, and comparing them measures only how they fail.  The headline's
    IMMs lie well below it (0.045 km against 0.10 km at 100 runs; IMMCDKF-OBS alone, at 0.25 km, lies above it);
    under the km^2/s^4 reading of the truth's noise (H-4) with a noisy truth (H-13) every IMM lies above it (0.122
    against 0.121 km at 100 runs): the truth is then a random walk of 0.45-0.63 km/s^2 accelerations that no motion
    model predicts, and the filters only add their lag to the measurements."""
    if res.measurement_only is None:
        raise ValueError("res: no measurement-only errors (a ReadingResult from evaluate_reading)")
    return evaluation.degenerate_reason(position_rmse(res), metrics.armse(res.measurement_only), what=BASELINE)


def summarise(res: ReadingResult, n_runs: int) -> UniverseResult:
    """One universe's result: Table 1's cells under the reading's H-11 metric, the claims, the effects (paired
    position-MSE differences in km^2 with their Table 1 counterparts, the true-mode-probability difference of OBS
    and CDKF, the NEES levels), the diverged runs and whether the universe is degenerate (:func:`degenerate`)."""
    metric = res.setup.rmse_metric
    values = []
    for alg in ALGORITHMS:
        for quantity, comp in TABLE1_QUANTITIES:
            v = table1_metric(res.runs[alg], comp, metric)
            values.append(("Table 1", alg, quantity, float(v.value), float(v.stderr)))
    effects = []
    for name, (a, b) in MSE_EFFECTS.items():
        d = evaluation.paired_mse_difference(res.runs[a], res.runs[b], (0, 2))
        effects.append((name, float(d.value), float(d.stderr), published_position_mse(a) - published_position_mse(b)))
    d, se, _ = mode_matching_difference(res, "IMMCDKF-OBS", "IMMCDKF")
    effects.append(("mode_probability_obs_minus_cdkf", d, se, None))
    for alg in NEES_ALGORITHMS:
        ne = nees_average(res, alg)
        effects.append((f"nees_{alg}", float(ne.value), float(ne.stderr), None))
    diverged = {alg: int((~rs.valid).sum()) for alg, rs in res.runs.items()}
    return UniverseResult.build(values=values, claims=judge_claims(res), diverged=diverged, effects=effects,
                                n_runs=n_runs, degenerate=degenerate(res))


def universe(reading: Mapping[str, str], n_runs: int, seed: int) -> UniverseResult:
    """The multiverse job: one reading, ``n_runs`` runs on root seed ``seed`` (module level: picklable)."""
    return summarise(evaluate_reading(reading, MonteCarlo(seed, n_runs)), n_runs)


def table1_rows(result: UniverseResult, n_runs: int) -> list:
    """Table 1's RMSE rows of the results file from a universe's values (the headline universe in the
    notebook), judged by the one verdict rule."""
    rows = []
    quantities = [q for q, _ in TABLE1_QUANTITIES]
    for v in result.values:
        alg = v.algorithm
        devs = ["H-2", "H-3", "H-4", "H-5", "H-9", "H-11", "H-13", "H-14"] + (["H-1"] if "CDKF" in alg else []) + \
               (["H-6", "H-7", "H-8"] if alg.endswith("OBS") else []) + (["H-10"] if alg == "IMMUKF" else [])
        rows.append(report.make_row("Table 1", alg, v.quantity, TABLE1[alg][quantities.index(v.quantity)],
                                    v.replicated, v.stderr, n_runs=n_runs, n_runs_paper=N_RUNS, deviations=devs))
    return rows


def headline_digest(n_runs: int) -> dict:
    """The run digest (:func:`mmlib.experiment.digests.run_digest`) of the headline universe's first
    ``n_runs`` runs (the five IMMs) on the paper's root seed: what the notebook stores as ``digest`` in
    ``data/results/hu2017.json``, recomputed without the notebook (tests/tolerance/test_digest.py)."""
    return digests.run_digest(evaluate_reading(SPACE.headline, MonteCarlo(ROOT_SEED, n_runs)).runs, n_runs)
