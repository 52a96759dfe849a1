"""One universe of Zhu, Wang & Yuan 2016: the Monte Carlo evaluation of a reading and everything judged from it.

:func:`universe` is the multiverse job (``PAPER.universe``); the notebook's headline rows and claims come from the
same :func:`evaluate_reading`, :func:`table1_rows`, :func:`judge_claims` and :func:`summarise` applied to the
headline reading, so the headline universe and the headline rows are one computation.

RMSE (Eq. 64, deviation Z-13): per component, the root of the mean over runs and over the 100 steps of the squared
error (m or m/s); the per-run time means are the independent replications of its standard error.  Accuracy claims
are paired differences of mean squared error over common random numbers; the floor is the RMSE of the Kalman filter
told the true mode sequence ("clairvoyant KF"), the minimum-MSE estimator when the truth follows the filters' model.
"""
from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from mmlib.experiment import digests, evaluation, metrics, report
from mmlib.experiment.montecarlo import MonteCarlo
from mmlib.experiment.universe import UniverseResult
from mmlib.papers.zhu2016 import text
from mmlib.papers.zhu2016.setup import Setup, batch, build, setup, simulator
from mmlib.papers.zhu2016.text import MV_ALGORITHMS, QUANTITIES, RMSE_ALGORITHMS, TABLE1

__all__ = [
    "universe", "evaluate_reading", "summarise", "judge_claims", "position_rmse", "measurement_only_rmse", "degenerate",
    "rmse_values", "table1_rows", "coincidence", "floor_is_bound", "floor_check", "floor_parts", "accuracy_claim",
    "effects", "headline_digest", "BASELINE", "FLOOR_CLAIM", "FLOOR_NOT_BOUND", "CLAIM_QUANTITIES", "KEY_EFFECT"
]


def evaluate_reading(reading: Mapping, mc: MonteCarlo, progress: bool = False, consistency: bool = False) -> dict:
    """``{estimator: RunSet}`` for :data:`MV_ALGORITHMS` under ``reading``, on the runs of ``mc``
    (common random numbers: the per-run truth, measurement and initial-estimate streams do not
    depend on the reading); ``consistency=True`` also records every run's NEES and NIS per step
    (:func:`mmlib.experiment.evaluation.evaluate`; the estimates are the same bits either way)."""
    make_batch, estimators = batch(setup(reading), mc)
    return evaluation.evaluate(evaluation.select(estimators, MV_ALGORITHMS), make_batch, mc,
                               label=f"{text.NAME} {text.SPACE.describe(reading)}"[:60], progress=progress,
                               consistency=consistency)


#: the no-information baseline of the degenerate flag (:func:`degenerate`)
BASELINE = "the measurement-only estimate's position RMSE"


def position_rmse(errors: np.ndarray, valid: np.ndarray | None = None) -> float:
    r"""Position RMSE :math:`\sqrt{\mathrm{mean}_{m,k}(e_x^2 + e_y^2)}` (m) of errors (M, K, 4) (state
    ``[x, vx, y, vy]``) over the runs ``valid`` (M,) bool (default all); NaN when no run is valid."""
    e = np.asarray(errors, dtype=float)
    if valid is not None:
        e = e[np.asarray(valid, dtype=bool)]
    if e.shape[0] == 0:
        return math.nan
    return float(np.sqrt(np.mean(e[..., 0] ** 2 + e[..., 2] ** 2)))


def measurement_only_rmse(setup: Setup, mc: MonteCarlo) -> metrics.MCValue:
    r"""Position RMSE (m, :func:`position_rmse`, with its standard error over runs) of the measurement-only estimate
    over the runs of ``mc``: the
    measured position itself under the position sensor, the measured range and bearing turned into Cartesian
    coordinates, :math:`p = p_{\rm sensor} + \rho\,[\cos\theta, \sin\theta]`, under the range-bearing sensor
    (Z-5); the estimate that ignores the dynamics, the no-information baseline of :func:`degenerate`.  The same
    simulated runs as the filters' (common random numbers), vectorised over runs and steps."""
    schedule, meas, _ = build(setup)
    truth, z, _ = simulator(setup, schedule, meas)(mc)(range(mc.n_runs))
    if setup.sensor == "position":
        pos = z
    else:
        pos = np.asarray(setup.sensor_xy) + z[..., :1] * np.stack([np.cos(z[..., 1]), np.sin(z[..., 1])], axis=-1)
    return metrics.armse(pos - truth[:, 1:, [0, 2]])


def degenerate(results: dict, baseline: metrics.MCValue | float) -> str:
    """Why the universe is degenerate (:func:`mmlib.experiment.evaluation.degenerate_reason`), "" when it is not:
    no algorithm of Table 1 (:data:`RMSE_ALGORITHMS`) has a position RMSE (m, valid runs, with its standard error;
    :func:`position_rmse`'s) detectably and non-negligibly below the measurement-only estimate's ``baseline`` (m,
    :func:`measurement_only_rmse`)."""
    return evaluation.degenerate_reason({a: metrics.armse(results[a].errors[..., [0, 2]], results[a].valid)
                                         for a in RMSE_ALGORITHMS}, baseline, what=BASELINE)


def rmse_values(results: dict) -> dict:
    """Eq. 64 (Z-13) per algorithm of Table 1 and per quantity: ``{(algorithm, quantity): MCValue}``
    (m or m/s; diverged runs excluded and counted)."""
    return {(alg, q): metrics.rmse_time_averaged(results[alg].errors[..., comp], results[alg].valid)
            for alg in RMSE_ALGORITHMS for q, comp in QUANTITIES}


def table1_rows(results: dict) -> list:
    """The RMSE rows of Table 1 (:func:`mmlib.experiment.report.make_row`; OMTM-IMM 'not replicable', Z-14)."""
    rmse = rmse_values(results)
    rows = []
    for alg in RMSE_ALGORITHMS + ("OMTM-IMM",):
        for qi, (q, _) in enumerate(QUANTITIES):
            printed = TABLE1[alg][qi]
            if alg == "OMTM-IMM":
                rows.append(report.make_row("Table 1", alg, q, printed, None, None,
                                            reason="method not specified (Z-14)", deviations=["Z-14"]))
                continue
            est = rmse[(alg, q)]
            devs = ["Z-4", "Z-5", "Z-6", "Z-7", "Z-9", "Z-12", "Z-13"] + (["Z-8"] if alg.startswith("IMM") else []) \
                + (["Z-1", "Z-2"] if "5CKF" in alg else []) + (["Z-10"] if alg == "5CKF" else []) \
                + (["Z-11"] if alg == "IMMUKF" else [])
            rows.append(report.make_row("Table 1", alg, q, printed, est.value, est.stderr, n_runs=est.n_runs,
                                        n_runs_paper=text.N_RUNS, deviations=devs,
                                        note=f"{est.n_excluded} diverged runs excluded" if est.n_excluded else ""))
    return rows


def coincidence(results: dict) -> dict:
    """Largest absolute difference over runs and steps between each sigma-point IMM and the IMM-KF: estimates
    (m, m/s) and mode probabilities.  Zero up to round-off under the position sensor (the package docstring);
    under the range-bearing sensor (Z-5) the IMM-KF is an IMM-EKF and the rules differ."""
    ref = results["IMM-KF"]
    return {"max_abs_estimate_difference_vs_IMM_KF":
            {a: float(np.nanmax(np.abs(results[a].errors - ref.errors))) for a in ("IMM5CKF", "IMMCKF", "IMMUKF")},
            "max_abs_mode_probability_difference_vs_IMM_KF":
            {a: float(np.nanmax(np.abs(results[a].mode_probabilities - ref.mode_probabilities)))
             for a in ("IMM5CKF", "IMMCKF", "IMMUKF")}}


FLOOR_CLAIM = "Table 1's IMM errors lie above the minimum-MSE floor of the set-up (implicit)"
#: the floor claim's reason where the floor is no bound (:func:`floor_is_bound`)
FLOOR_NOT_BOUND = ("the clairvoyant KF is the minimum-MSE bound only when the simulated truth follows the filters' "
                   "model (Z-7 noisy truth, Z-9 initial error drawn from N(0, P0)) and every model is linear (Z-5 "
                   "position sensor)")
#: the accuracy claims' quantities: (label, state components, unit of the mean squared error)
CLAIM_QUANTITIES = (("position", (0, 2), "m²"), ("velocity", (1, 3), "m²/s²"))
#: short labels and units of Table 1's quantities, for the parts of the floor claim
_SHORT = {"RMSE_X (m)": ("x position RMSE", "m"), "RMSE_X_V (m/s)": ("x velocity RMSE", "m/s"),
          "RMSE_Y (m)": ("y position RMSE", "m"), "RMSE_Y_V (m/s)": ("y velocity RMSE", "m/s")}


def floor_is_bound(setup: Setup) -> bool:
    """Whether the clairvoyant KF is the minimum-MSE estimator of this set-up: the truth must follow the
    filters' own model, i.e. be driven by Q (Z-7) and start from an initial error drawn from N(0, P0)
    (Z-9), and the models must be linear (the position sensor of Z-5).  Under a noise-free truth or a filter
    started at the true X0 with P0 = diag(1000, ...) it is a reference, not a bound (a filter knowing the truth
    has no noise could do better); under the range-bearing sensor it is an extended Kalman filter, no bound."""
    return bool(setup.truth_process_noise) and setup.initial_estimate == "sampled" and setup.sensor == "position"


def floor_check(results: dict) -> list:
    """Table 1's IMM values against the minimum-MSE floor of this reading.

    With linear-Gaussian modes the Kalman filter told the true mode sequence ("clairvoyant KF")
    is the MMSE estimator, so no IMM can have a smaller expected squared error.  Per quantity: the
    floor (RMSE of the clairvoyant KF, with its standard error), the smallest printed IMM value, and
    ``z`` = (floor - printed) / sigma with the combined sigma of the verdict rule (our error, the
    paper's estimated from its 100 runs, half a unit of the printed digit); ``z >= 3`` means the
    printed value lies significantly below the floor: unattainable under this reading."""
    out = []
    for qi, (q, comp) in enumerate(QUANTITIES):
        b = metrics.rmse_time_averaged(results["clairvoyant KF"].errors[..., comp], results["clairvoyant KF"].valid)
        printed = min((TABLE1[a][qi] for a in ("IMM5CKF", "IMMCKF", "IMMUKF")), key=float)
        z = report.standardized_distance(printed, float(b.value), float(b.stderr), b.n_runs, text.N_RUNS)
        # sigma of the verdict rule: the standardized distance of a unit difference is 1 / sigma
        sigma = 1.0 / report.standardized_distance(printed, float(printed) + 1.0, float(b.stderr), b.n_runs,
                                                   text.N_RUNS)
        out.append({"quantity": q, "floor": float(b.value), "floor_stderr": float(b.stderr),
                    "paper_min_imm": printed, "margin": float(printed) - float(b.value), "sigma": sigma, "z": z})
    return out


def floor_parts(floor: list) -> list:
    """The parts of :data:`FLOOR_CLAIM` from :func:`floor_check`: per quantity, "the smallest printed IMM value
    lies above the floor" (:func:`mmlib.experiment.verdicts.part`, expected sign +1) on the margin printed - floor
    (m or m/s) with the combined sigma of the verdict rule as its standard error, relative to the floor: *holds*
    at z = -``f['z']`` >= 3, *contradicted* (printed below the floor) at z <= -3."""
    return [report.part("Table 1 smallest IMM − clairvoyant KF", _SHORT[f["quantity"]][0], f["margin"], f["sigma"],
                        +1, reference=f["floor"], unit=_SHORT[f["quantity"]][1]) for f in floor]


def _switch_window_probability(rs, true_modes, window: int = 10):
    """Per run: mean probability of the true mode over the ``window`` steps after each mode switch."""
    switch = [k for k in range(1, len(true_modes)) if true_modes[k] != true_modes[k - 1]]
    steps = sorted({k + j for k in switch for j in range(window) if k + j < len(true_modes)})
    mu = rs.mode_probabilities[:, steps, :]
    return np.take_along_axis(mu, np.asarray(true_modes)[steps][None, :, None], axis=2)[..., 0].mean(axis=1)


def accuracy_claim(results: dict, a: str, b: str) -> tuple:
    """Judgement and evidence of "``a`` is more accurate than ``b``": one part per quantity of
    :data:`CLAIM_QUANTITIES` (position and velocity mean squared error, m² and m²/s², paired on common random
    numbers, relative to ``b``'s; :func:`mmlib.experiment.evaluation.better_claim`), judged once
    (:func:`mmlib.experiment.verdicts.judge`)."""
    parts, evidence = [], []
    for label, comps, unit in CLAIM_QUANTITIES:
        j, ev = evaluation.better_claim(results, a, b, [(label, comps)], unit=unit)
        parts += j.parts
        evidence.append(ev)
    return report.judge(parts), "; ".join(evidence)


def judge_claims(results: dict, setup: Setup) -> report.Claims:
    """The paper's accuracy, switching and divergence claims and the implicit attainability of Table 1,
    each a :class:`~mmlib.experiment.verdicts.Judgement` (one term of the claim vocabulary, its decisive number
    and its parts; the timing claim is judged by :func:`mmlib.papers.zhu2016.timing.judge_timing`).  Under the
    position sensor (linear models) IMM5CKF, IMMCKF and IMMUKF are one algorithm (package docstring), so their
    comparisons are parts *identical (to round-off)* and the claims resting on them *not supported*; under the
    range-bearing sensor (Z-5) they differ and the claims are judged on the differences."""
    claims = report.Claims()
    for other in ("IMMCKF", "IMMUKF", "5CKF"):
        claims.add(f"IMM5CKF is more accurate than {other}", *accuracy_claim(results, "IMM5CKF", other),
                   key=f"imm5ckf_vs_{other.lower()}")
    claims.add("IMM5CKF is more accurate than OMTM-IMM",
               report.Judgement.of(report.NOT_ASSESSABLE, "OMTM-IMM is not specified (Z-14)"),
               "Zhou et al. 2014 give no equations, initial values or mode filter", key="imm5ckf_vs_omtm_imm")
    fl = floor_check(results)
    evidence = "; ".join(f"{f['quantity']}: smallest printed IMM value {f['paper_min_imm']} vs floor "
                         f"{report.format_pm(f['floor'], f['floor_stderr'])} (z = {f['z']:+.1f})" for f in fl)
    floor = (report.judge(floor_parts(fl)) if floor_is_bound(setup) else
             report.Judgement.of(report.NOT_ASSESSABLE, FLOOR_NOT_BOUND))
    claims.add(FLOOR_CLAIM, floor, evidence, key="errors_above_floor")
    true_modes = build(setup)[0].modes()
    parts, ev = [], []
    p5 = _switch_window_probability(results["IMM5CKF"], true_modes)
    for other in ("IMMCKF", "IMMUKF"):
        po = _switch_window_probability(results[other], true_modes)
        d = metrics.mean_with_se(p5 - po)
        parts.append(report.part(f"IMM5CKF − {other}", "true-mode probability after switches", float(d.value),
                                 float(d.stderr), +1, reference=float(po.mean()), unit="probability",
                                 ops=evaluation.pair_operations(results["IMM5CKF"], results[other])))
        ev.append(f"vs {other}: Δ(probability of the true mode, 10 steps after each switch) = "
                  f"{report.format_pm(float(d.value), float(d.stderr), signed=True)}")
    claims.add("IMM5CKF switches modes more quickly than IMMCKF/IMMUKF", report.judge(parts), "; ".join(ev),
               key="switches_faster")
    diverged = {a: int((~results[a].valid).sum()) for a in RMSE_ALGORITHMS}
    n_total = sum(results[a].valid.size for a in RMSE_ALGORITHMS)
    claims.add("No algorithm diverges",
               report.Judgement.of(report.HOLDS, f"0 diverged runs of {n_total}") if not any(diverged.values()) else
               report.Judgement.of(report.CONTRADICTED, f"{sum(diverged.values())} diverged runs of {n_total} ("
                                   + ", ".join(f"{a} {n}" for a, n in diverged.items() if n) + ")"),
               f"diverged runs: {diverged}", key="no_divergence")
    return claims


def _published_mse_difference(a: str, b: str, comps) -> float:
    """Table 1's counterpart of a paired MSE difference: sum over the components of RMSE_a^2 - RMSE_b^2."""
    return sum(float(TABLE1[a][c]) ** 2 - float(TABLE1[b][c]) ** 2 for c in comps)


#: the key effect of the specification curve
KEY_EFFECT = "IMM5CKF − IMMCKF: position MSE (m²)"


def effects(results: dict) -> list:
    """Named paired differences (value, standard error, Table 1's counterpart) and the floor margins."""
    out = []
    for name, a, b, comps in ((KEY_EFFECT, "IMM5CKF", "IMMCKF", (0, 2)),
                              ("IMM5CKF − IMMCKF: velocity MSE (m²/s²)", "IMM5CKF", "IMMCKF", (1, 3)),
                              ("IMM5CKF − IMMUKF: position MSE (m²)", "IMM5CKF", "IMMUKF", (0, 2)),
                              ("IMM5CKF − 5CKF: position MSE (m²)", "IMM5CKF", "5CKF", (0, 2))):
        d = evaluation.paired_mse_difference(results[a], results[b], comps)
        out.append((name, float(d.value), float(d.stderr), _published_mse_difference(a, b, comps)))
    for f in floor_check(results):
        out.append((f"smallest printed IMM value − floor: {f['quantity']}", f["margin"], f["sigma"]))
    c = coincidence(results)
    out.append(("max |IMM5CKF − IMM-KF| estimate (m, m/s)",
                c["max_abs_estimate_difference_vs_IMM_KF"]["IMM5CKF"], None))
    return out


def summarise(results: dict, n_runs: int, setup: Setup, degenerate: str = "") -> UniverseResult:
    """The universe's result (:meth:`UniverseResult.build`): Table 1's RMSE cells and the floor (values),
    :func:`judge_claims`, :func:`effects`, the diverged runs per estimator and ``degenerate``, the reason the
    universe is degenerate (:func:`degenerate`; "" when it is not)."""
    values = [("Table 1", alg, q, float(v.value), float(v.stderr)) for (alg, q), v in rmse_values(results).items()]
    for f in floor_check(results):
        values.append(("floor", "clairvoyant KF", f["quantity"], f["floor"], f["floor_stderr"]))
    return UniverseResult.build(values=values, claims=judge_claims(results, setup), effects=effects(results),
                                diverged={a: int((~rs.valid).sum()) for a, rs in results.items()}, n_runs=n_runs,
                                degenerate=degenerate)


def universe(reading: Mapping, n_runs: int, seed: int) -> UniverseResult:
    """The multiverse job: one reading, ``n_runs`` Monte Carlo runs on root seed ``seed``; flagged degenerate
    (:func:`degenerate`) when no algorithm of Table 1 beats the measurement-only estimate."""
    mc = MonteCarlo(seed, n_runs)
    s = setup(reading)
    results = evaluate_reading(reading, mc)
    return summarise(results, n_runs, s, degenerate(results, measurement_only_rmse(s, mc)))


def headline_digest(n_runs: int) -> dict:
    """The run digest (:func:`mmlib.experiment.digests.run_digest`) of the headline universe's first ``n_runs``
    runs (the six estimators of the headline) on the paper's root seed: what the notebook stores as ``digest`` in
    ``data/results/zhu2016.json``, recomputed without the notebook (tests/tolerance/test_digest.py)."""
    return digests.run_digest(evaluate_reading(text.SPACE.headline, MonteCarlo(text.ROOT_SEED, n_runs)), n_runs)
