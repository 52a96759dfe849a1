r"""The arena study: one *cell* per (algorithm, scenario), each an independent Monte Carlo job.

A cell runs the algorithm (built by :mod:`mmlib.arena.recipes`) on its scenario's runs -- the first ``n_runs`` runs
of the scenario's root seed, so every algorithm of a scenario sees the same truth, measurements and initial
estimates (common random numbers), and a paper scenario's cell reproduces the paper's own evaluation bit for bit --
and returns its metrics (:func:`cell_metrics`) with each run's time-averaged squared position error, from which the
ranks within the scenario are computed afterwards (:func:`rank_scenario`).  An algorithm that cannot apply to a
scenario gets a cell with the reason instead of metrics.

Cells run through :func:`mmlib.experiment.grid.run_grid`: in parallel worker processes (or on a Dask cluster), cached
on disk by scenario, algorithm, runs, seed and mmlib's source, with a progress line per cell.

Metrics per cell (units: m, m/s; Bar-Shalom, Li & Kirubarajan 2001, Sec. 5.4.2 for the consistency tests):

* ``rmse_position``, ``rmse_velocity``: :math:`\sqrt{\frac{1}{NK}\sum_{i,k}\lVert e_{i,k}\rVert^2}` over the
  position (velocity) components, with the delta-method standard error from the per-run time averages (the runs
  are the independent replications);
* ``anees``: the NEES averaged over runs and steps, its standard error from the per-run averages, and the 95 %
  band of a run-average of N consistent NEES values at one step, :math:`[\chi^2_{nN}(0.025), \chi^2_{nN}(0.975)]/N`
  (the time average of a consistent filter's ANEES lies inside it with at least that probability: errors of one
  run are correlated in time, so its spread is between the white value and that of one step);
  ``steps_inside``: the fraction of steps whose run-average NEES is inside that band (about 0.95 for a consistent
  filter); ``runs_inside``: the fraction of runs whose own time-averaged NEES lies inside
  :math:`[\chi^2_{nK}(0.025), \chi^2_{nK}(0.975)]/K` (conservative for the NEES, whose terms are correlated in
  time; exact for the NIS of a consistent filter, whose innovations are white);
* ``anis``: the same for the NIS, with ``dof`` the measurement dimension (the median over steps when it varies);
* ``diverged``: runs that diverged (excluded from every other metric) and the summary of their steps and causes;
* ``cost_us_per_run_step``: the CPU time of the batched run (thread time of the cell's evaluation, simulation
  excluded) per run and step, in microseconds -- a measurement, reported, never tested;
* ``rank``: 1 + the number of algorithms of the scenario whose position error is detectably smaller (paired
  difference of the per-run time-averaged squared position errors, on the runs valid in both, at least 3 standard
  errors: the verdict rule of :func:`mmlib.experiment.report.claim_verdict`); ``versus_best``: the paired difference
  to the scenario's best algorithm with its standard error and verdict ("no detectable difference" where the
  interval covers zero).
"""
from __future__ import annotations

import functools
import math

import numpy as np
from scipy import stats

from mmlib.arena import ladder, recipes
from mmlib.experiment import evaluation, metrics, report
from mmlib.experiment.grid import run_grid
from mmlib.experiment.montecarlo import MonteCarlo
from mmlib.experiment.scenario import Scenario
from mmlib.papers import hu2017, liu2017, tseng2011, zhou2017, zhu2016

PAPER = "arena"
PAPER_SCENARIOS = {m.PAPER: m for m in (zhu2016, hu2017, liu2017, zhou2017, tseng2011)}
SCENARIOS = tuple(PAPER_SCENARIOS) + ladder.NAMES
ALGORITHMS = recipes.ALGORITHMS
CHUNK_SIZE = 250
RESULT_KEYS = ("metrics", "reason", "n_runs", "diverged", "per_run_position_mse")


@functools.lru_cache(maxsize=32)
def scenario(name: str) -> Scenario:
    """The scenario ``name``: a paper's headline scenario (``zhu2016`` ...) or a ladder rung; ValueError listing the
    known names otherwise.  Built once per process."""
    if name in PAPER_SCENARIOS:
        return PAPER_SCENARIOS[name].scenario()
    if name in ladder.NAMES:
        return ladder.scenario(name)
    raise ValueError(f"scenario: unknown scenario {name!r}; known: {', '.join(SCENARIOS)}")


def seed_of(s: Scenario, seed: int | None) -> int:
    """The root seed of a scenario's runs: its own (a paper's root seed, the ladder's) unless ``seed`` overrides it."""
    return s.root_seed if seed is None else int(seed)


def evaluate_cell(algorithm: str, s: Scenario, mc: MonteCarlo, consistency: bool = True) -> evaluation.RunSet:
    """The RunSet of ``algorithm`` on ``s`` over the runs of ``mc`` (chunks of :data:`CHUNK_SIZE`; with NEES and NIS
    when ``consistency``); :class:`recipes.NotApplicable` where it cannot apply."""
    est = recipes.build(algorithm, s)
    make_batch = evaluation.with_initial_states(s.simulator(mc), {algorithm: est},
                                                lambda e, start, runs: recipes.initial_state(e, s, start, runs, mc))
    return evaluation.evaluate({algorithm: est}, make_batch, mc, chunk_size=CHUNK_SIZE, progress=False,
                               measurement_models=s.measurement_models, consistency=consistency, workers=1)[algorithm]


def _mc_value(v: metrics.MCValue) -> dict:
    return {"value": _num(v.value), "stderr": _num(v.stderr), "n_runs": int(v.n_runs)}


def _num(x):
    x = float(x)
    return x if math.isfinite(x) else None


def _per_run_squared(rs: evaluation.RunSet, idx) -> np.ndarray:
    """Per run, the time average of the squared error summed over the components ``idx`` (NaN for diverged runs)."""
    sq = np.full(rs.errors.shape[0], np.nan)
    ok = rs.valid
    sq[ok] = (rs.errors[ok][..., list(idx)] ** 2).sum(axis=-1).mean(axis=1)
    return sq


def consistency(stat: np.ndarray, dof, ok: np.ndarray) -> dict:
    """ANEES/ANIS summary of per-run, per-step chi-square statistics ``stat`` (N, K) with ``dof`` degrees of freedom
    (an int, or (K,) per step), over the valid runs ``ok`` (see the module docstring)."""
    s = stat[ok]
    N, K = s.shape
    dof_k = np.broadcast_to(np.asarray(dof, dtype=float), (K,))
    if N < 2 or not np.isfinite(s).all():
        return {"value": None, "stderr": None, "dof": float(np.median(dof_k)), "band": None, "steps_inside": None,
                "runs_inside": None, "n_runs": int(N)}
    per_run = s.mean(axis=1)
    value = float(per_run.mean())
    se = float(per_run.std(ddof=1) / math.sqrt(N))
    lo_k = stats.chi2.ppf(0.025, dof_k * N) / N
    hi_k = stats.chi2.ppf(0.975, dof_k * N) / N
    step_mean = s.mean(axis=0)
    steps_inside = float(np.mean((step_mean >= lo_k) & (step_mean <= hi_k)))
    total = dof_k.sum()
    lo_r, hi_r = stats.chi2.ppf([0.025, 0.975], total) / K
    runs_inside = float(np.mean((per_run >= lo_r) & (per_run <= hi_r)))
    dof_med = float(np.median(dof_k))
    band = [float(stats.chi2.ppf(0.025, dof_med * N) / N), float(stats.chi2.ppf(0.975, dof_med * N) / N)]
    return {"value": value, "stderr": se, "dof": dof_med, "band": band, "steps_inside": steps_inside,
            "runs_inside": runs_inside, "n_runs": int(N), "inside": band[0] <= value <= band[1]}


def cell_metrics(rs: evaluation.RunSet, s: Scenario) -> dict:
    """The metrics of one cell (module docstring) from its RunSet."""
    ok = rs.valid
    N, K = rs.errors.shape[:2]
    out = {"diverged": int((~ok).sum()), "divergence": rs.divergence_summary(),
           "cost_us_per_run_step": 1e6 * rs.cpu_seconds / (N * K)}
    if ok.sum() >= 2:
        out["rmse_position"] = _mc_value(metrics.rms_with_se(np.nan_to_num(_per_run_squared(rs, s.position)), ok))
        out["rmse_velocity"] = _mc_value(metrics.rms_with_se(np.nan_to_num(_per_run_squared(rs, s.velocity)), ok))
    else:
        out["rmse_position"] = out["rmse_velocity"] = None
    out["anees"] = consistency(rs.nees, s.dim, ok) if rs.nees is not None else None
    out["anis"] = consistency(rs.nis, rs.nis_dof, ok) if rs.nis is not None else None
    return out


def cell(reading: dict, n_runs: int, seed: int) -> dict:
    """The job of one cell, ``reading = {"scenario": ..., "algorithm": ..., "seed": None or a root seed}``: its
    metrics, or the reason it does not apply (``run_grid``'s ``seed`` is the arena's; the cell uses its scenario's
    own unless the reading overrides it)."""
    s = scenario(reading["scenario"])
    algorithm = reading["algorithm"]
    reason = recipes.applicability(algorithm, s)
    if reason:
        return {"metrics": None, "reason": reason, "n_runs": int(n_runs), "diverged": {},
                "per_run_position_mse": None}
    mc = MonteCarlo(seed_of(s, reading.get("seed")), n_runs)
    rs = evaluate_cell(algorithm, s, mc)
    m = cell_metrics(rs, s)
    sq = _per_run_squared(rs, s.position)
    return {"metrics": m, "reason": "", "n_runs": int(n_runs), "diverged": {algorithm: m["diverged"]},
            "per_run_position_mse": [None if not math.isfinite(v) else float(v) for v in sq]}


def rank_scenario(cells: dict) -> dict:
    """``{algorithm: {"rank", "versus_best"}}`` for one scenario's cells ``{algorithm: cell result}`` (those with
    metrics and at least two valid runs), from paired differences of the per-run position errors (module docstring)."""
    per_run = {a: np.array([np.nan if v is None else v for v in c["per_run_position_mse"]])
               for a, c in cells.items() if c.get("per_run_position_mse") is not None}
    per_run = {a: v for a, v in per_run.items() if np.isfinite(v).sum() >= 2}
    if not per_run:
        return {}

    def paired(a, b):
        ok = np.isfinite(per_run[a]) & np.isfinite(per_run[b])
        d = metrics.mean_with_se(np.where(ok, per_run[a] - per_run[b], 0.0), ok)
        return float(d.value), float(d.stderr)

    means = {a: float(np.nanmean(v)) for a, v in per_run.items()}
    best = min(means, key=means.get)
    out = {}
    for a in per_run:
        worse_than = 0
        for b in per_run:
            if b == a:
                continue
            d, se = paired(a, b)
            if report.claim_verdict(d, se, +1).startswith("holds"):
                worse_than += 1
        d, se = paired(a, best) if a != best else (0.0, 0.0)
        verdict = "best" if a == best else report.claim_verdict(d, se, +1)
        verdict = {"holds": "worse", "contradicted": "better"}.get(verdict, verdict)
        out[a] = {"rank": 1 + worse_than, "versus_best": {"algorithm": best, "difference_m2": d, "stderr_m2": se,
                                                          "verdict": verdict}}
    return out


def run_arena(n_runs: int, *, scenarios=SCENARIOS, algorithms=ALGORITHMS, seed: int | None = None,
              workers: int | None = None, executor=None, progress=True, use_cache: bool = True,
              cache_dir=None) -> list:
    """Every cell of ``algorithms`` x ``scenarios`` at ``n_runs`` runs (integer >= 2): a list of cell documents
    ``{"algorithm", "scenario", "metrics" | "reason", ...}`` with ranks, in scenario-major order.  Unknown names are a
    ValueError listing the known ones.  ``seed`` overrides every scenario's root seed."""
    scenarios, algorithms = list(scenarios), [recipes.recipe(a).name for a in algorithms]
    for name in scenarios:
        if name not in SCENARIOS:
            raise ValueError(f"scenarios: unknown scenario {name!r}; known: {', '.join(SCENARIOS)}")
    if isinstance(n_runs, bool) or not isinstance(n_runs, (int, np.integer)) or n_runs < 2:
        raise ValueError(f"n_runs: expected an integer >= 2 (a standard error needs two runs), got {n_runs!r}")
    readings = [{"scenario": s, "algorithm": a, "seed": seed} for s in scenarios for a in algorithms]
    results = run_grid(cell, readings, paper=PAPER, algorithms=algorithms, n_runs=int(n_runs),
                       seed=ladder.ROOT_SEED if seed is None else int(seed), workers=workers, executor=executor,
                       progress=progress, use_cache=use_cache, cache_dir=cache_dir, label="arena",
                       result_keys=RESULT_KEYS, unit="cell")
    cells = []
    for s in scenarios:
        here = {r["algorithm"]: res for r, res in zip(readings, results) if r["scenario"] == s}
        ranks = rank_scenario({a: c for a, c in here.items() if c["metrics"] is not None})
        for a in algorithms:
            c = here[a]
            doc = {"algorithm": a, "scenario": s, "n_runs": c["n_runs"]}
            if c["metrics"] is None:
                doc["reason"] = c["reason"]
            else:
                doc.update(c["metrics"])
                doc.update(ranks.get(a, {"rank": None, "versus_best": None}))
            cells.append(doc)
    return cells


def scenario_table(names=SCENARIOS, n_index_runs: int = 50) -> list:
    """One row per scenario: name, title, source, steps, state and measurement dimensions, its properties and its
    computed nonlinearity index (:func:`mmlib.arena.ladder.nonlinearity_index`; 10 runs for the 1800-epoch GNSS
    scenario)."""
    rows = []
    for name in names:
        s = scenario(name)
        runs = 10 if s.n_steps > 500 else n_index_runs
        rows.append({"scenario": name, "title": s.title, "source": s.source, "n_steps": s.n_steps, "dim": s.dim,
                     "measurement_dim": s.measurement_dim, "nonlinearity_index": ladder.nonlinearity_index(s, runs),
                     "properties": s.properties, "root_seed": s.root_seed})
    return rows
