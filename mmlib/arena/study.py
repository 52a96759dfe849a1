r"""The arena study: one *cell* per (algorithm, scenario), each an independent Monte Carlo job.

A cell runs the algorithm (built by :mod:`mmlib.arena.recipes`) on its scenario's runs -- the first ``n_runs`` runs
of the scenario's root seed, so every algorithm of a scenario sees the same truth, measurements and initial
estimates (common random numbers), and a paper scenario's cell reproduces the paper's own evaluation of the same
algorithm bit for bit (Hu et al. 2017 to round-off: its km are converted to m) -- and returns its metrics
(:func:`cell_metrics`) with each run's time-averaged squared position error, from which the ranks within the scenario
are computed afterwards (:func:`rank_scenario`).  An algorithm that cannot apply to a
scenario gets a cell with the reason instead of metrics.

Cells run through :func:`mmlib.experiment.grid.run_grid`: in parallel worker processes (or on a Dask cluster), cached
on disk by scenario, algorithm, runs, seed and mmlib's source, with a progress line (``cell k/N, ~T left``)
at most every 15 s.

Metrics per cell (units: m, m/s; Bar-Shalom, Li & Kirubarajan 2001, Sec. 5.4.2 for the consistency tests):

* ``rmse_position``, ``rmse_velocity``: :math:`\sqrt{\frac{1}{NK}\sum_{i,k}\lVert e_{i,k}\rVert^2}` over the
  position (velocity) components, with the delta-method standard error from the per-run time averages (the runs
  are the independent replications);
* ``anees``: the NEES averaged over runs and steps, its standard error from the per-run averages, and ``band``, the
  95 % band of a run-average of N consistent NEES values at one step,
  :math:`[\chi^2_{nN}(0.025), \chi^2_{nN}(0.975)]/N`.
  The errors of one run are correlated in time, so the time average of a consistent filter's ANEES has a spread
  between the white value and that of one step and lies inside this band with at least 95 % probability: ``inside``
  is a lenient test; ``steps_inside``, the fraction of steps whose run-average NEES lies inside the band, is the
  textbook one (about 0.95 for a consistent filter);
* ``anis``: the same for the NIS with ``dof`` the mean measurement dimension over the steps; the innovations of a
  consistent filter are white, so its ``band`` is the exact one of the run-and-time average,
  :math:`[\chi^2_{N\sum_k m_k}(0.025), \chi^2_{N\sum_k m_k}(0.975)]/(NK)`;
  for both, ``runs_inside`` is the fraction of runs whose own time average lies inside
  :math:`[\chi^2_{\sum_k m_k}(0.025), \chi^2_{\sum_k m_k}(0.975)]/K` -- about 0.95 for the NIS of a consistent
  filter, less for its NEES (a consistent KF shows ~0.77 on the linear rung: time-correlated errors spread the
  per-run averages beyond the white band);
* ``diverged``: runs that diverged (excluded from every other metric) and the summary of their steps and causes;
* ``cost_us_per_run_step``: CPU time per run and step in microseconds of one batched run of the first
  :data:`COST_RUNS` runs over the first :data:`COST_STEPS` steps (every step of a shorter scenario; Tseng et al.
  2011's first 200 of its 1800 epochs, within -13 % and +2 % of a whole run's) without the NEES/NIS bookkeeping,
  after an untimed warm-up (thread time, simulation excluded) -- a measurement, reported, never tested, never part of
  a rank or digest;
* ``rank``: for the cells none of whose runs diverged, 1 + the number of them whose position error is detectably and
  not negligibly smaller (:func:`rank_scenario`); ``versus_best``: the paired difference to the scenario's best
  algorithm with its standard error and verdict ("no detectable difference" where the interval covers zero,
  "identical (to round-off)" where the difference and its standard error lie within the round-off floor
  :func:`mmlib.experiment.report.identity_floor` of the best one's mean squared error: two algorithms that are one in
  exact arithmetic on the scenario, e.g. every sigma-point rule on a linear model).

Comparisons (:func:`compare`) read the part verdict of the one rule (:func:`mmlib.experiment.report.claim_verdict`)
in the arena's vocabulary :class:`ArenaVerdict`: helps, hurts, no detectable difference, identical (to round-off),
diverges, not comparable.

Who takes part, and what is pooled (issue 24):

* the scenarios are the registered papers' (:func:`paper_names`: every paper of :data:`mmlib.papers.REGISTRY` except
  the controls, ``kind == "control"``, which test the pipeline and take no part in the arena) and the ladder's; a
  paper's scenario is what its ``Paper.scenario`` builds from its headline set-up (Zhou et al. 2017: Case 2 under the
  per-step fault reading, :data:`mmlib.papers.zhou2017.setup.ARENA_FAULT_KIND`, because the headline's accumulating
  bearing drift is unobservable and every filter errs by the measurement-only error there);
* cross-scenario (pooled) tallies -- a paper's claim judged across the arena (:func:`paper_claims`), an idea's
  counts of verdicts (:func:`idea_summary`), the consistency counts of :func:`findings` -- leave out the
  *excluded* scenarios (:attr:`ArenaResult.excluded`, :func:`exclusions`) and report them apart: a scenario from a
  paper whose verdicts judge a reconstruction (``Paper.qualifier``, e.g. a set-up the paper does not give), and a
  *degenerate* scenario, on which no applicable algorithm's position RMSE is detectably and non-negligibly below the
  measurement-only estimate's (:func:`measurement_only_rmse`, paired on the common runs; the claim rule of
  :func:`mmlib.experiment.evaluation.degenerate_reason`): no algorithm there extracts anything from the motion, so
  comparing them measures only how they fail.  The per-scenario tables and comparisons keep every scenario.
"""
from __future__ import annotations

import functools
import math
import os
import concurrent.futures as cf
import enum
from pathlib import Path
from typing import Callable, Iterable, Mapping, NamedTuple, Sequence

import numpy as np

from mmlib.arena import ladder, recipes
from mmlib.core import models
from mmlib.core._validate import (check_bool, check_has, check_names,
                                  check_positive_int, check_scalar)
from mmlib.core.protocols import Estimator
from mmlib.experiment import evaluation, metrics, report
from mmlib.experiment.grid import run_grid
from mmlib.experiment.montecarlo import MonteCarlo, say_progress
from mmlib.experiment.paper import Study
from mmlib.experiment.scenario import Scenario
from mmlib.experiment.simulate import BatchMemo
from mmlib.papers import REGISTRY

__all__ = [
    "run_arena", "ArenaResult", "findings", "compare", "arena_claims", "paper_claims", "paper_claim_list",
    "idea_summary", "ideas", "all_ideas", "ARENA_IDEAS", "scenario_table", "evaluate_cell", "simulated", "cell",
    "cell_metrics",
    "per_run_values", "rank_scenario", "cost_per_run_step", "scenario", "known_scenarios", "seed_of",
    "measurement_only_errors", "measurement_only_mse", "measurement_only_rmse", "degenerate_reason", "exclusions",
    "digest", "paper_names", "ArenaVerdict", "ARENA_READING", "VERSUS_BEST", "BASELINE_WHAT", "PAPER", "STUDY",
    "SCENARIOS", "ALGORITHMS", "CHUNK_SIZE", "COST_RUNS", "COST_STEPS", "WARM_UP_STEPS", "RESULT_KEYS",
    "SIMULATION_MEMO", "SIMULATION_MEMO_BYTES"
]


def paper_names() -> tuple:
    """The registered papers that take part in the arena, in the registry's order: every paper of
    :data:`mmlib.papers.REGISTRY` (including papers registered after import) except the controls (``kind ==
    "control"``: a closed-form check of the pipeline, not a tracking problem of the literature)."""
    return tuple(name for name in REGISTRY if REGISTRY[name].kind != "control")


PAPER = "arena"
#: the arena notebook's name, root seed (the ladder's; paper scenarios keep their papers') and profiles: 1000 runs per
#: cell, smoke the first 20 of the same streams (so the smoke digest equals the full study's)
STUDY = Study(PAPER, ladder.ROOT_SEED, {"full": {"n_runs": 1000}, "smoke": {"n_runs": 20}})
#: the default scenarios: every registered paper's headline (in the registry's order, controls skipped:
#: :func:`paper_names`), then the ladder's rungs
SCENARIOS = paper_names() + ladder.NAMES
ALGORITHMS = recipes.ALGORITHMS
CHUNK_SIZE = 250
COST_RUNS = 100           #: runs of the batched run that measures a cell's cost (the same batch for every algorithm)
#: at most this many steps of that run, the first ones: a cell's cost is shown, never judged, and a whole run of Tseng
#: et al. 2011's 1800 epochs was 29-39 % of the CPU time of its cells at the smoke profile's 20 runs (every other
#: scenario has 200 steps or fewer and is timed whole).  Its first 200 epochs (7 satellites each; 6.66 on average over
#: the run) cost 13 % less to 2 % more per run-step than the whole run, measured per step side by side (EKF -13 %,
#: 5CKF -10 %, IMMUKF +1 %, IMM-NAUKF[inflate-only] +1.5 %), well inside this VM's run-to-run variation
COST_STEPS = 200
WARM_UP_STEPS = 2         #: steps of the untimed one-run warm-up before that run (:func:`cost_per_run_step`)
RESULT_KEYS = ("metrics", "reason", "n_runs", "diverged", "per_run")
#: the simulated batches a process keeps, the most recently used (:func:`simulated`; the limits of its memo, built at
#: import): a cell asks for its chunks and its cost batch (n_runs / CHUNK_SIZE + 1 = 5 batches at 1000 runs), and the
#: cells of a scenario run one after the other (run_arena orders them by scenario), so the next algorithm of the
#: scenario finds them all
SIMULATION_MEMO = 5
#: and at most this many bytes of them (a batch larger than that is not kept): Tseng et al. 2011's 250 runs of 1800
#: epochs are about 58 MB
SIMULATION_MEMO_BYTES = 512 * 2**20


class ArenaVerdict(enum.StrEnum):
    """The verdict of an arena comparison "A against B" (:func:`compare`): the part verdict of the one rule
    (:class:`mmlib.experiment.report.PartVerdict`) read for an idea A adds to B, and *diverges*.  A member equals,
    formats and serialises to JSON as its string."""

    HELPS = "helps"
    HELPS_NEGLIGIBLE = "helps, but negligible (< 1 %)"
    HURTS = "hurts"
    HURTS_NEGLIGIBLE = "hurts, but negligible (< 1 %)"
    NO_DIFFERENCE = "no detectable difference"
    IDENTICAL = "identical (to round-off)"
    DIVERGES = "diverges"
    NOT_COMPARABLE = "not comparable"

    def __repr__(self) -> str:
        return str.__repr__(self)


#: the arena's reading of each part verdict of "A is more accurate than B"
ARENA_READING = {report.PartVerdict.HOLDS: ArenaVerdict.HELPS,
                 report.PartVerdict.HOLDS_NEGLIGIBLE: ArenaVerdict.HELPS_NEGLIGIBLE,
                 report.PartVerdict.CONTRADICTED: ArenaVerdict.HURTS,
                 report.PartVerdict.CONTRADICTED_NEGLIGIBLE: ArenaVerdict.HURTS_NEGLIGIBLE,
                 report.PartVerdict.NO_DIFFERENCE: ArenaVerdict.NO_DIFFERENCE,
                 report.PartVerdict.IDENTICAL: ArenaVerdict.IDENTICAL,
                 report.PartVerdict.NOT_COMPARABLE: ArenaVerdict.NOT_COMPARABLE}
#: the reading of each part verdict of "A is worse than the best" in a cell's ``versus_best`` (:func:`rank_scenario`)
VERSUS_BEST = {report.PartVerdict.HOLDS: "worse", report.PartVerdict.HOLDS_NEGLIGIBLE: "worse, but negligible (< 1 %)",
               report.PartVerdict.CONTRADICTED: "better",
               report.PartVerdict.CONTRADICTED_NEGLIGIBLE: "better, but negligible (< 1 %)",
               report.PartVerdict.NO_DIFFERENCE: "no detectable difference",
               report.PartVerdict.IDENTICAL: "identical (to round-off)",
               report.PartVerdict.NOT_COMPARABLE: "not comparable"}

#: the ANEES/ANIS summary of a cell, in the experiment layer since issue 24 (every paper reports it too)
consistency = evaluation.consistency


def scenario(name: str) -> Scenario:
    """The scenario ``name``: a paper's headline scenario (``zhu2016`` ...) or a ladder rung; ValueError listing the
    known names otherwise.  Built once per process (its arrays are read-only)."""
    if not isinstance(name, str):
        raise ValueError(f"scenario: expected a scenario name, got {name!r}; known: {', '.join(known_scenarios())}")
    return _scenario(name)


def known_scenarios() -> tuple:
    """Every scenario name: the registered papers' (:func:`paper_names`: :data:`mmlib.papers.REGISTRY`, including
    papers registered after import, without the controls) and the ladder's."""
    return paper_names() + ladder.NAMES


@functools.lru_cache(maxsize=32)
def _scenario(name: str) -> Scenario:
    if name in REGISTRY and name in paper_names():
        paper = REGISTRY[name]
        return paper.scenario(paper.arena_setup())
    if name in ladder.NAMES:
        return ladder.scenario(name)
    raise ValueError(f"scenario: unknown scenario {name!r}; known: {', '.join(known_scenarios())}")


def seed_of(s: Scenario, seed: int | None) -> int:
    """The root seed of a scenario's runs: its own (a paper's root seed, the ladder's) unless ``seed`` (None or an
    integer >= 0) overrides it."""
    recipes._check_scenario(s, "s")
    return s.root_seed if seed is None else check_positive_int(seed, "seed", minimum=0)


#: the batches of this process (:func:`simulated`): keyed by (id of the scenario, mc) and the runs, each entry holding
#: the scenario, so that its id cannot be reused by another while the entry lives
_SIMULATIONS = BatchMemo(SIMULATION_MEMO, SIMULATION_MEMO_BYTES)


def simulated(s: Scenario, mc: MonteCarlo) -> Callable:
    """``s.simulator(mc)``, ``runs -> (truth, measurements, start means)``, remembering the last
    :data:`SIMULATION_MEMO` batches of this process (at most :data:`SIMULATION_MEMO_BYTES`; a
    :class:`~mmlib.experiment.simulate.BatchMemo`): every algorithm of a
    scenario is evaluated on the same runs, which are simulated once per process instead of once per cell.  A batch is
    keyed by everything that determines it -- the scenario (the object: its simulator), the root seed and run count
    of ``mc`` and the run indices -- and is the simulator's own output, so a remembered batch is the one a fresh
    simulation gives, bit for bit; its arrays are read-only (shared by every caller: ValueError on a write)."""
    recipes._check_scenario(s, "s")
    if not isinstance(mc, MonteCarlo):
        raise ValueError(f"mc: expected a MonteCarlo, got {type(mc).__name__}")
    return _SIMULATIONS.wrap(s.simulator(mc), (id(s), mc), owner=s)


def evaluate_cell(algorithm: str, s: Scenario, mc: MonteCarlo, consistency: bool = True) -> tuple:
    """``(RunSet, CPU seconds per run-step)`` of ``algorithm`` on ``s`` over the runs of ``mc`` (chunks of
    :data:`CHUNK_SIZE`; with NEES and NIS when ``consistency``); :class:`recipes.NotApplicable` where it cannot
    apply.  The cost is measured apart (:func:`cost_per_run_step`), so that neither the NEES/NIS bookkeeping nor the
    first call's compilation enters it."""
    if not isinstance(mc, MonteCarlo):
        raise ValueError(f"mc: expected a MonteCarlo, got {type(mc).__name__}")
    check_bool(consistency, "consistency")
    est = recipes.build(algorithm, s)
    make_batch = evaluation.with_initial_states(simulated(s, mc), {algorithm: est},
                                                lambda e, start, runs: recipes.initial_state(e, s, start, runs, mc))
    runs = evaluation.evaluate({algorithm: est}, make_batch, mc, chunk_size=CHUNK_SIZE, progress=False,
                               measurement_models=s.measurement_models, consistency=consistency, workers=1)
    return runs[algorithm], cost_per_run_step(est, make_batch, s, min(mc.n_runs, COST_RUNS))


def cost_per_run_step(est: Estimator, make_batch: Callable[[Sequence[int]], tuple], s: Scenario,
                      n: int) -> float:
    """Thread CPU seconds per run and step of one batched run of ``est`` over the first ``n`` runs and the first
    ``min(COST_STEPS, s.n_steps)`` steps (no NEES/NIS), after an untimed warm-up of one run over the first
    :data:`WARM_UP_STEPS` steps, which compiles what those steps call and fills the caches.  What only later steps
    call is compiled by the cell's evaluation before it in the same process (:func:`evaluate_cell`); a caller timing
    an estimator that has run nowhere else in its process may see that compilation in the time.  A whole warm-up run
    would cost the Python of every step: as much as the timed run itself at a few runs (the per-step cost of a batch
    hardly depends on its size)."""
    recipes._check_scenario(s, "s")
    check_has(est, "est", "an estimator (protocols.Estimator)", ("init", "step", "name"))
    if not callable(make_batch):
        raise ValueError(f"make_batch: expected a function runs -> (truth, measurements, init), got "
                         f"{type(make_batch).__name__}")
    n = check_positive_int(n, "n")
    import time
    from mmlib.core import linalg
    from mmlib.core.estimation import run, select_runs
    _, z, init = make_batch(range(n))
    state = init[est.name]
    first, models = _first(z, s, 1, WARM_UP_STEPS)
    run(est, select_runs(state, slice(0, 1)), first, keep_cov=False, measurement_models=models)
    k = min(COST_STEPS, s.n_steps)
    timed, models = _first(z, s, n, k)
    with linalg.use_threads(1):                                  # one thread's CPU time
        t0 = time.thread_time()
        run(est, state, timed, keep_cov=False, measurement_models=models)
        return (time.thread_time() - t0) / (n * k)


def _first(z, s: Scenario, runs: int, steps: int) -> tuple:
    """``(measurements, measurement models)`` of the first ``runs`` runs and ``steps`` steps of a batch's
    measurements ``z`` of scenario ``s``, as :func:`mmlib.core.estimation.run` takes them: (B, K, m) sliced and no
    models, or, with per-step sensors, the first steps' arrays (B, m_k) of the list and the scenario's first
    models."""
    if s.measurement_models is None:
        return z[:runs, :steps], None
    return [zk[:runs] for zk in z[:steps]], s.measurement_models[:steps]


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


def cell_metrics(rs: evaluation.RunSet, s: Scenario, cost_seconds: float) -> dict:
    """The metrics of one cell (module docstring) from its RunSet and its cost (CPU seconds per run-step)."""
    _check_cell_inputs(rs, s)
    check_scalar(cost_seconds, "cost_seconds", nonnegative=True)
    ok = rs.valid
    out = {"diverged": int((~ok).sum()), "divergence": rs.divergence_summary(),
           "cost_us_per_run_step": 1e6 * cost_seconds, "operations_per_run": rs.ops}
    if ok.sum() >= 2:
        out["rmse_position"] = _mc_value(metrics.rms_with_se(np.nan_to_num(_per_run_squared(rs, s.position)), ok))
        out["rmse_velocity"] = _mc_value(metrics.rms_with_se(np.nan_to_num(_per_run_squared(rs, s.velocity)), ok))
    else:
        out["rmse_position"] = out["rmse_velocity"] = None
    out["anees"] = evaluation.consistency(rs.nees, s.dim, ok, white=False) if rs.nees is not None else None
    out["anis"] = evaluation.consistency(rs.nis, rs.nis_dof, ok, white=True) if rs.nis is not None else None
    return out


def cell(reading: dict, n_runs: int, seed: int) -> dict:
    """The job of one cell, ``reading = {"scenario": ..., "algorithm": ..., "seed": None or a root seed}``: its
    metrics, or the reason it does not apply (``run_grid``'s ``seed`` is the arena's; the cell uses its scenario's
    own unless the reading overrides it)."""
    if not isinstance(reading, Mapping) or any(k not in reading for k in ("scenario", "algorithm")) \
            or any(k not in ("scenario", "algorithm", "seed") for k in reading):
        raise ValueError(f"reading: expected {{'scenario': ..., 'algorithm': ..., 'seed': None or a root seed}}, "
                         f"got {reading!r}")
    n_runs = check_positive_int(n_runs, "n_runs")
    s = scenario(reading["scenario"])
    algorithm = reading["algorithm"]
    reason = recipes.applicability(algorithm, s)
    if reason:
        return {"metrics": None, "reason": reason, "n_runs": int(n_runs), "diverged": {}, "per_run": None}
    mc = MonteCarlo(seed_of(s, reading.get("seed")), n_runs)
    rs, cost = evaluate_cell(algorithm, s, mc)
    m = cell_metrics(rs, s, cost)
    return {"metrics": m, "reason": "", "n_runs": int(n_runs), "diverged": {algorithm: m["diverged"]},
            "per_run": per_run_values(rs, s)}


def _check_cell_inputs(rs, s) -> None:
    if not isinstance(rs, evaluation.RunSet):
        raise ValueError(f"rs: expected a RunSet (evaluation.evaluate), got {type(rs).__name__}")
    recipes._check_scenario(s, "s")
    if rs.errors.ndim != 3 or rs.errors.shape[-1] != s.dim:
        raise ValueError(f"rs: errors of shape {rs.errors.shape}, expected (N, K, {s.dim}) for scenario {s.name!r}")


def _listed(values) -> list:
    return [None if not math.isfinite(v) else float(v) for v in np.asarray(values, dtype=float)]


def per_run_values(rs: evaluation.RunSet, s: Scenario) -> dict:
    """Per run: the time-averaged squared position and velocity errors (for paired comparisons and ranks), the
    time-averaged NEES and NIS, and the step at which it diverged (-1: never); None for a diverged run's values."""
    _check_cell_inputs(rs, s)
    ok = rs.valid
    avg = (lambda stat: _listed(np.where(ok, np.nanmean(np.where(ok[:, None], stat, 0.0), axis=1), np.nan))
           if stat is not None else None)
    return {"position_mse": _listed(_per_run_squared(rs, s.position)),
            "velocity_mse": _listed(_per_run_squared(rs, s.velocity)),
            "nees": avg(rs.nees), "nis": avg(rs.nis), "diverged_step": [int(k) for k in rs.diverged_step]}


def rank_scenario(cells: dict) -> dict:
    """``{algorithm: {"rank", "versus_best"}}`` for one scenario's cells ``{algorithm: cell result}``.

    Only cells none of whose runs diverged are ranked (a cell with diverged runs would be compared on fewer, easier
    runs; its rank is None and its divergence is reported instead), so every comparison is paired over the same runs.
    The best is the ranked algorithm with the smallest mean time-averaged squared position error; an algorithm's rank
    is 1 + the number of ranked algorithms that are better by the one rule -- a paired difference at least 3 standard
    errors from zero and not negligible (at least 1 % of the worse one's mean squared error;
    :func:`mmlib.experiment.report.claim_verdict` with its reference), so that round-off between algorithms that
    coincide (every rule on a linear model) never orders them."""
    if not isinstance(cells, Mapping):
        raise ValueError(f"cells: expected a dict algorithm -> cell result, got {type(cells).__name__}")
    for a, c in cells.items():
        if not isinstance(c, Mapping) or "per_run" not in c \
                or c["per_run"] is not None and "position_mse" not in c["per_run"]:
            raise ValueError(f"cells: the cell of {a!r} is not a cell result (study.cell) with 'per_run'")
    per_run = {a: np.array([np.nan if v is None else v for v in c["per_run"]["position_mse"]])
               for a, c in cells.items() if c.get("per_run") is not None}
    ranked = {a: v for a, v in per_run.items() if np.isfinite(v).all() and v.size >= 2}
    out = {a: {"rank": None, "versus_best": None} for a in per_run if a not in ranked}
    if not ranked:
        return out

    def operations(a) -> int | None:
        m = cells[a].get("metrics") or {}
        return m.get("operations_per_run")

    def worse(a, b) -> tuple:
        """The part verdict of "a is worse than b" (paired; the reference of the 1 % negligibility and of the
        round-off floor is b's mean squared error, and its operation count the larger of the two runs', as in
        :func:`compare`) and the paired difference."""
        d = metrics.mean_with_se(ranked[a] - ranked[b])
        oa, ob = operations(a), operations(b)
        ops = report.ROUNDOFF_OPS if oa is None or ob is None else max(oa, ob)
        return report.claim_verdict(float(d.value), float(d.stderr), +1, reference=float(ranked[b].mean()),
                                    ops=ops), d

    best = min(ranked, key=lambda a: float(ranked[a].mean()))
    for a in ranked:
        rank = 1 + sum(worse(a, b)[0] == report.PartVerdict.HOLDS for b in ranked if b != a)
        if a == best:
            out[a] = {"rank": rank, "versus_best": {"algorithm": best, "difference_m2": 0.0, "stderr_m2": 0.0,
                                                    "verdict": "best"}}
            continue
        verdict, d = worse(a, best)
        out[a] = {"rank": rank, "versus_best": {"algorithm": best, "difference_m2": float(d.value),
                                                "stderr_m2": float(d.stderr), "verdict": VERSUS_BEST[verdict]}}
    return out


class ArenaResult(NamedTuple):
    """What :func:`run_arena` returns: ``cells`` (one document per (algorithm, scenario), scenario-major, with metrics
    and ranks or the reason it does not apply), ``per_run`` ({(scenario, algorithm): (N,) per-run time-averaged
    squared position error, NaN for diverged runs}) for paired comparisons, ``details`` (every per-run number of
    :func:`per_run_values`), ``baselines`` ({scenario: the measurement-only position RMSE, :func:`measurement_only_rmse`
    as ``{"value", "stderr", "n_runs"}`` in m, or None where the sensor has no measurement-only position estimate}) and
    ``excluded`` ({scenario: why it is kept out of the pooled tallies}, :func:`exclusions`)."""

    cells: list
    per_run: dict
    n_runs: int
    details: dict = {}        #: {(scenario, algorithm): per_run_values(...)}: every per-run number (for the digest)
    ops: dict = {}            #: {(scenario, algorithm): floating-point operations of one run, or None if unknown}
    baselines: dict = {}      #: {scenario: measurement-only position RMSE {"value", "stderr", "n_runs"} (m), or None}
    excluded: dict = {}       #: {scenario: reason}: kept out of every pooled tally, reported apart

    def operations(self, scenario_name: str, a: str, b: str) -> int:
        """The operation count of the round-off floor of a paired comparison of ``a`` and ``b`` on one scenario:
        the larger of their runs' (:func:`mmlib.experiment.evaluation.run_operations`), ``ROUNDOFF_OPS`` when
        either is unknown."""
        oa, ob = self.ops.get((scenario_name, a)), self.ops.get((scenario_name, b))
        return report.ROUNDOFF_OPS if oa is None or ob is None else max(oa, ob)


def _check_result(result) -> ArenaResult:
    if not isinstance(result, ArenaResult):
        raise ValueError(f"result: expected an ArenaResult (run_arena), got {type(result).__name__}")
    return result


#: what a scenario's no-information baseline is, in a degenerate scenario's reason (:func:`degenerate_reason`)
BASELINE_WHAT = ("the measurement-only estimate's position RMSE on the same runs (an algorithm's ± is that of its "
                 "paired difference from it where the runs are known)")


def measurement_only_errors(s: Scenario, truth: np.ndarray, z: np.ndarray) -> np.ndarray | None:
    r"""Per run and step, the position error norm (m) of the *measurement-only* estimate of scenario ``s``: each
    measurement turned into a position without the dynamics or any other measurement -- for a range-bearing radar
    (:class:`mmlib.core.models.RangeBearing`) :math:`s + r(\cos\theta, \sin\theta)`, for a linear sensor whose
    rows include one unit row per position component the measured positions themselves.  ``truth`` (N, K+1, n) with
    the initial state first, ``z`` (N, K, m) the scenario's measurements; returns (N, K), or None where the sensor
    gives no such estimate (per-step sensors, e.g. GNSS pseudoranges; a sensor that does not measure the position)."""
    recipes._check_scenario(s, "s")
    m = s.measurement
    if m is None or not isinstance(z, np.ndarray):
        return None
    truth = np.asarray(truth, dtype=float)
    pos = list(s.position)
    if truth.ndim != 3 or truth.shape[-1] != s.dim or z.ndim != 3 or z.shape[:2] != (truth.shape[0],
                                                                                      truth.shape[1] - 1):
        raise ValueError(f"truth, z: expected (N, K+1, {s.dim}) and (N, K, m), got {truth.shape} and {z.shape}")
    if isinstance(m, models.RangeBearing) and len(pos) == 2 and tuple(m.position_index) == tuple(pos):
        sx, sy = (float(v) for v in m.sensor)
        est = np.stack([sx + z[..., 0] * np.cos(z[..., 1]), sy + z[..., 0] * np.sin(z[..., 1])], axis=-1)
    elif isinstance(m, models.LinearMeasurement):
        rows = []
        for p in pos:
            unit = np.zeros(s.dim)
            unit[p] = 1.0
            hits = [r for r in range(m.H.shape[0]) if np.array_equal(m.H[r], unit)]
            if not hits:
                return None
            rows.append(hits[0])
        est = z[..., rows]
    else:
        return None
    return np.sqrt(((est - truth[:, 1:][..., pos]) ** 2).sum(axis=-1))


def measurement_only_mse(s: Scenario, n_runs: int, seed: int | None = None) -> np.ndarray | None:
    """Per run, the time-averaged squared position error (m², (N,)) of the measurement-only estimate of scenario
    ``s`` (:func:`measurement_only_errors`) on its first ``n_runs`` runs (root seed :func:`seed_of`: the runs every
    cell sees); None where the sensor gives no measurement-only estimate."""
    recipes._check_scenario(s, "s")
    n_runs = check_positive_int(n_runs, "n_runs")
    if s.measurement is None:
        return None
    truth, z, _ = simulated(s, MonteCarlo(seed_of(s, seed), n_runs))(range(n_runs))
    e = measurement_only_errors(s, truth, z)
    return None if e is None else (e ** 2).mean(axis=1)


def measurement_only_rmse(s: Scenario, n_runs: int, seed: int | None = None) -> dict | None:
    r"""The no-information baseline of scenario ``s`` on its first ``n_runs`` runs: the measurement-only estimate's
    position RMSE :math:`\sqrt{\frac{1}{NK}\sum_{i,k}\lVert \hat p_{i,k} - p_{i,k}\rVert^2}` (m;
    :func:`measurement_only_mse`), the statistic of a cell's ``rmse_position``, as ``{"value", "stderr", "n_runs"}``
    (delta-method standard error over runs); None where the sensor gives no measurement-only estimate."""
    sq = measurement_only_mse(s, n_runs, seed)
    return None if sq is None else _mc_value(metrics.rms_with_se(sq))


def _paired(m: np.ndarray, beta: np.ndarray, base_value: float) -> tuple[float, float]:
    """``(value, stderr)`` of the RMSE whose per-run time-averaged squared errors are ``m`` (NaN: a diverged run),
    paired with the baseline's ``beta`` on the same runs: ``base_value`` plus the difference of the two RMSEs over
    the runs valid for it, with the delta-method standard error of that difference (per-run influence values
    m_i / (2 e) - beta_i / (2 b))."""
    ok = np.isfinite(m)
    if not ok.any():
        return math.inf, math.nan
    m, beta = m[ok], np.asarray(beta, dtype=float)[ok]
    e, b = math.sqrt(m.mean()), math.sqrt(beta.mean())
    infl = m / (2 * e) - beta / (2 * b)
    se = float(infl.std(ddof=1) / math.sqrt(len(infl))) if len(infl) > 1 else math.nan
    return base_value + (e - b), se


def degenerate_reason(cells: Iterable[Mapping], scenario_name: str, baseline: Mapping | None,
                      per_run: Mapping | None = None, baseline_per_run: np.ndarray | None = None) -> str:
    r"""Why scenario ``scenario_name`` is degenerate, "" when it is not (or has no ``baseline``, or no applicable
    cell): no applicable cell of it in ``cells`` (:func:`run_arena`'s documents) has a position RMSE detectably and
    non-negligibly below the measurement-only RMSE ``baseline["value"]`` (:func:`measurement_only_rmse`), by the
    claim rule (:func:`mmlib.experiment.evaluation.degenerate_reason`: more than 3 standard errors and more than the
    claims' negligible 1 %).  With the cells' per-run squared errors ``per_run`` ({(scenario, algorithm): (N,)},
    :attr:`ArenaResult.per_run`) and the baseline's ``baseline_per_run`` (:func:`measurement_only_mse`) the
    difference is paired on the common runs; otherwise each cell enters with its own standard error and the
    baseline's (as if independent: toward *degenerate*).  A cell without an RMSE (every run diverged) never beats
    the baseline."""
    if not isinstance(scenario_name, str):
        raise ValueError(f"scenario_name: expected a scenario name, got {scenario_name!r}")
    if baseline is not None and not isinstance(baseline, Mapping):
        raise ValueError(f"baseline: expected None or measurement_only_rmse's dict, got {baseline!r}")
    if baseline is None or baseline.get("value") is None:
        return ""
    b, sb = float(baseline["value"]), float(baseline.get("stderr") or 0.0)
    per_run = {} if per_run is None else per_run
    errors = {}
    for c in cells:
        if not isinstance(c, Mapping) or "scenario" not in c or "algorithm" not in c:
            raise ValueError(f"cells: expected run_arena's cell documents (scenario, algorithm, ...), got {c!r:.80}")
        if c["scenario"] != scenario_name or "reason" in c:
            continue
        key = (scenario_name, c["algorithm"])
        r = c.get("rmse_position")
        if key in per_run and baseline_per_run is not None:
            errors[c["algorithm"]] = _paired(np.asarray(per_run[key], dtype=float), baseline_per_run, b)
        elif r is None or r.get("value") is None:
            errors[c["algorithm"]] = (math.inf, math.nan)
        else:
            errors[c["algorithm"]] = (float(r["value"]), math.hypot(float(r.get("stderr") or 0.0), sb))
    if not errors:
        return ""
    why = evaluation.degenerate_reason(errors, (b, 0.0), what=BASELINE_WHAT)
    return f"degenerate: {why}" if why else ""


def exclusions(cells: Iterable[Mapping], baselines: Mapping[str, Mapping | None], per_run: Mapping | None = None,
               baseline_per_run: Mapping[str, np.ndarray | None] | None = None) -> dict:
    """``{scenario: reason}``: the scenarios of ``cells`` kept out of the pooled tallies (module docstring) -- a
    registered paper's scenario whose verdicts judge a reconstruction (its ``Paper.qualifier``, read from the
    registry), and a degenerate scenario (:func:`degenerate_reason` against ``baselines[scenario]``, paired on the
    runs where ``per_run`` and ``baseline_per_run[scenario]`` are given)."""
    if isinstance(cells, (str, bytes, Mapping)) or not hasattr(cells, "__iter__"):
        raise ValueError(f"cells: expected run_arena's list of cell documents, got {type(cells).__name__}")
    cells = list(cells)
    if not isinstance(baselines, Mapping):
        raise ValueError(f"baselines: expected a dict scenario -> measurement-only RMSE (or None), got {baselines!r}")
    baseline_per_run = {} if baseline_per_run is None else baseline_per_run
    out = {}
    for name in dict.fromkeys(c.get("scenario") for c in cells if isinstance(c, Mapping)):
        reasons = []
        if name in REGISTRY and REGISTRY[name].qualifier:
            reasons.append(f"its verdicts judge a {REGISTRY[name].qualifier} (the paper does not give the set-up: "
                           f"Paper.qualifier of {name})")
        why = degenerate_reason(cells, name, baselines.get(name), per_run, baseline_per_run.get(name))
        if why:
            reasons.append(why)
        if reasons:
            out[name] = "; ".join(reasons)
    return out


def run_arena(n_runs: int, *, scenarios: Iterable[str] | None = None, algorithms: Iterable[str] = ALGORITHMS,
              seed: int | None = None, workers: int | None = None, executor: cf.Executor | None = None,
              progress: bool | Callable[[str], None] = True, use_cache: bool = True,
              cache_dir: str | Path | None = None) -> ArenaResult:
    """Every cell of ``algorithms`` x ``scenarios`` at ``n_runs`` runs (integer >= 2), in parallel and cached
    (:func:`mmlib.experiment.grid.run_grid`), with the ranks of each scenario.  Unknown names are a ValueError listing
    the known ones; ``scenarios`` None is every known one (:func:`known_scenarios`).  ``seed`` overrides every
    scenario's root seed.  Beside the cells: each scenario's measurement-only baseline and the scenarios kept out of
    the pooled tallies (:attr:`ArenaResult.baselines`, :attr:`ArenaResult.excluded`)."""
    scenarios = known_scenarios() if scenarios is None else scenarios
    scenarios = check_names(scenarios, "scenarios")
    algorithms = check_names(algorithms, "algorithms")
    check_bool(use_cache, "use_cache")
    if cache_dir is not None and not isinstance(cache_dir, (str, os.PathLike)):
        raise ValueError(f"cache_dir: expected None or a folder path, got {cache_dir!r}")
    try:
        algorithms = [recipes.recipe(a).name for a in algorithms]
    except ValueError as exc:
        raise ValueError("algorithms: " + str(exc).removeprefix("algorithm: ")) from None
    if len(set(algorithms)) != len(algorithms):
        raise ValueError(f"algorithms: names the same algorithm twice (aliases resolved): {algorithms}")
    for name in scenarios:
        if name not in known_scenarios():
            raise ValueError(f"scenarios: unknown scenario {name!r}; known: {', '.join(known_scenarios())}")
    if isinstance(n_runs, bool) or not isinstance(n_runs, (int, np.integer)) or n_runs < 2:
        raise ValueError(f"n_runs: expected an integer >= 2 (a standard error needs two runs), got {n_runs!r}")
    # a numpy integer is not JSON (the readings key the cache): the check returns a Python int
    seed = None if seed is None else check_positive_int(seed, "seed", minimum=0)
    readings = [{"scenario": s, "algorithm": a, "seed": seed} for s in scenarios for a in algorithms]
    # the algorithm is part of each reading, so the cache key needs no list of them: a subset reuses the cells
    results = run_grid(cell, readings, paper=PAPER, algorithms=[], n_runs=int(n_runs),
                       seed=ladder.ROOT_SEED if seed is None else int(seed), workers=workers, executor=executor,
                       progress=_progress(progress), use_cache=use_cache, cache_dir=cache_dir,
                       label="arena", result_keys=RESULT_KEYS, unit="cell", result_type=None)
    cells, per_run, details, ops = [], {}, {}, {}
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
                per_run[(s, a)] = np.array([np.nan if v is None else v for v in c["per_run"]["position_mse"]])
                details[(s, a)] = c["per_run"]
                ops[(s, a)] = c["metrics"].get("operations_per_run")
            cells.append(doc)
    base_runs = {s: measurement_only_mse(scenario(s), int(n_runs), seed) for s in scenarios}
    baselines = {s: None if sq is None else _mc_value(metrics.rms_with_se(sq)) for s, sq in base_runs.items()}
    return ArenaResult(cells, per_run, int(n_runs), details, ops, baselines,
                       exclusions(cells, baselines, per_run, base_runs))


def _progress(progress):
    """``run_grid``'s progress for the arena's cells, checked: ``progress`` True prints to stderr, a callable receives
    the lines, False is silent (``run_grid`` throttles them itself: :class:`mmlib.experiment.grid.GridProgress`,
    ``cell k/N, ~T left`` at most every 15 s)."""
    if not (isinstance(progress, bool) or callable(progress)):
        raise ValueError(f"progress: expected True, False or a function of one line, got {progress!r}")
    if not progress:
        return False
    return say_progress if progress is True else progress


#: The arena's own ideas as paired comparisons "A against B" (A adds the idea to B), on every scenario: (idea, A, B);
#: each paper's ideas are its :attr:`mmlib.experiment.paper.ArenaEntry.ideas`
ARENA_IDEAS = (
    ("IMM over one model (UKF)", "IMMUKF", "UKF"),
    ("sigma points against linearisation (IMM)", "IMMUKF", "IMMEKF"),
)


def all_ideas() -> tuple:
    """``(idea, A, B, paper)``: every registered paper's ideas (its ``arena`` entry, in the registry's order), then
    the arena's own (:data:`ARENA_IDEAS`, paper "all")."""
    out = [(idea, a, b, name) for name in paper_names() if REGISTRY[name].arena is not None
           for idea, a, b in REGISTRY[name].arena.ideas]
    return tuple(out) + tuple((idea, a, b, "all") for idea, a, b in ARENA_IDEAS)


def _compare(result: ArenaResult, a: str, b: str, scenario_name: str) -> tuple | None:
    """``(compare(...) document, its Part)``, or None where either does not apply."""
    _check_result(result)
    for value, arg in ((a, "a"), (b, "b"), (scenario_name, "scenario_name")):
        if not isinstance(value, str):
            raise ValueError(f"{arg}: expected a name (a string), got {value!r}")
    if (scenario_name, a) not in result.per_run or (scenario_name, b) not in result.per_run:
        return None
    va, vb = result.per_run[(scenario_name, a)], result.per_run[(scenario_name, b)]
    da, db = int((~np.isfinite(va)).sum()), int((~np.isfinite(vb)).sum())
    ok = np.isfinite(va) & np.isfinite(vb)
    out = {"scenario": scenario_name, "a": a, "b": b, "diverged_a": da, "diverged_b": db, "n_runs": int(ok.sum()),
           "difference_m2": None, "stderr_m2": None, "relative": None}
    comparison = f"{a} − {b}"
    # a diverges detectably more often than b: the difference of the counts, sqrt(d_a + d_b) its standard error
    # (Poisson counts), at least 3 standard errors -- the one rule on the divergence part
    more = da - db >= report.SIGMA_FACTOR * math.sqrt(da + db) and da > db
    diverges = report.part(comparison, f"diverged runs, {scenario_name}", float(da - db), math.sqrt(da + db), -1,
                           unit="runs")
    if ok.sum() < 2:
        p = diverges if more else report.Part(comparison, f"position MSE, {scenario_name}",
                                              report.PartVerdict.NOT_COMPARABLE, math.nan, math.nan, None, "m²")
        verdict = ArenaVerdict.DIVERGES if more else ArenaVerdict.NOT_COMPARABLE
    else:
        d = metrics.mean_with_se(np.where(ok, va - vb, 0.0), ok)
        ref = float(vb[ok].mean())
        p = report.part(comparison, f"position MSE, {scenario_name}", float(d.value), float(d.stderr), -1,
                        reference=ref, unit="m²", ops=result.operations(scenario_name, a, b))
        verdict = ARENA_READING[p.verdict]
        out.update(difference_m2=float(d.value), stderr_m2=float(d.stderr),
                   relative=float(d.value) / ref if ref else None)
        if more:
            p, verdict = diverges, ArenaVerdict.DIVERGES
    j = report.judge([p])
    out.update(verdict=verdict, claim=j.verdict, decisive=j.decisive, part=p.as_json())
    return out, p


def compare(result: ArenaResult, a: str, b: str, scenario_name: str) -> dict | None:
    """The paired comparison of ``a`` against ``b`` on one scenario: mean over the runs valid in both of the
    difference of their time-averaged squared position errors (m^2) with its standard error and relative to b's MSE
    (``reference``); ``part``, the :class:`mmlib.experiment.report.Part` "``a − b``: position MSE, <scenario>" of the
    one rule (:func:`mmlib.experiment.report.part`, with b's MSE as the reference of the 1 % negligibility and of
    the round-off floor); ``verdict``, its reading :class:`ArenaVerdict` ("helps" (a smaller), "hurts" (a larger),
    "no detectable difference", "identical (to round-off)", with ", but negligible (< 1 %)" where it says so), or
    "diverges" when a diverged in detectably more runs than b (the part is then "diverged runs": the difference of
    the counts at least 3 standard errors, sqrt(d_a + d_b) for Poisson counts); ``claim`` and ``decisive``, the
    verdict of the claim "a is more accurate than b" (:func:`mmlib.experiment.report.judge` of the one part:
    contradicted when a diverges detectably more, not supported when identical to round-off).  None where either
    does not apply."""
    got = _compare(result, a, b, scenario_name)
    return None if got is None else got[0]


def ideas(result: ArenaResult, scenarios: Iterable[str] | None = None) -> list:
    """Every idea of :func:`all_ideas` on every scenario where both its algorithms apply: ``[{idea, paper, a, b,
    comparisons: [compare(...)], excluded: {scenario: reason}}]``, ``excluded`` naming those of its comparisons'
    scenarios that the pooled tallies leave out (:attr:`ArenaResult.excluded`; :func:`idea_summary`)."""
    _check_result(result)
    names = list(dict.fromkeys(c["scenario"] for c in result.cells)) if scenarios is None else \
        check_names(scenarios, "scenarios")
    out = []
    for idea, a, b, paper in all_ideas():
        comps = [c for c in (compare(result, a, b, s) for s in names) if c is not None]
        out.append({"idea": idea, "paper": paper, "a": a, "b": b, "comparisons": comps,
                    "excluded": {c["scenario"]: result.excluded[c["scenario"]] for c in comps
                                 if c["scenario"] in result.excluded}})
    return out


def digest(result: ArenaResult, n_runs: int) -> dict:
    """SHA-256 of every applicable cell's per-run numbers over the first ``n_runs`` runs -- position and velocity
    squared errors, NEES, NIS (time averages) and divergence steps (:func:`per_run_values`; float64 bytes, NaN
    canonical), by scenario and algorithm: the same for a study of ``n_runs`` runs and of any larger one (the runs'
    streams are fixed and a run's numbers do not depend on its batch), so the smoke profile recomputes the committed
    full study's digest exactly on a machine of the same fingerprint (``machine``:
    :func:`mmlib.experiment.machine.fingerprint`; ``tests/tolerance/test_arena_results.py``)."""
    import hashlib
    from mmlib.core.linalg import kernel
    _check_result(result)
    if check_positive_int(n_runs, "n_runs") > result.n_runs:
        raise ValueError(f"n_runs: expected an integer from 1 to the study's {result.n_runs} runs, got {n_runs!r}")
    h = hashlib.sha256(b"mmlib-arena-digest-2")
    for key in sorted(result.details):
        h.update(f"\0{key[0]}\0{key[1]}".encode())
        for field in ("position_mse", "velocity_mse", "nees", "nis", "diverged_step"):
            values = result.details[key][field]
            if values is None:
                continue
            v = np.array([np.nan if x is None else x for x in values[:n_runs]], dtype=np.float64)
            h.update(f"\0{field}\0".encode())
            h.update(np.where(np.isnan(v), np.nan, v).tobytes())
    from mmlib.experiment.machine import fingerprint
    return {"n_runs": int(n_runs), "sha256": h.hexdigest(), "cells": len(result.details), "kernel": kernel(),
            "machine": fingerprint()}


def scenario_table(names: Iterable[str] | None = None, n_index_runs: int = 50, max_run_steps: int = 18_000) -> list:
    """One row per scenario: name, title, source, steps, state and measurement dimensions, its properties and its
    computed nonlinearity index (:func:`mmlib.arena.ladder.nonlinearity_index`) over ``n_index_runs`` runs, or fewer
    where they would exceed ``max_run_steps`` run-steps (10 runs for the 1800-epoch GNSS scenario); ``names`` None is
    every known scenario."""
    names = known_scenarios() if names is None else names
    for value, name in ((n_index_runs, "n_index_runs"), (max_run_steps, "max_run_steps")):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 2:
            raise ValueError(f"{name}: expected an integer >= 2, got {value!r}")
    rows = []
    for name in check_names(names, "names"):
        s = scenario(name)
        runs = max(2, min(n_index_runs, max_run_steps // s.n_steps))
        rows.append({"scenario": name, "title": s.title, "source": s.source, "n_steps": s.n_steps, "dim": s.dim,
                     "measurement_dim": s.measurement_dim, "nonlinearity_index": ladder.nonlinearity_index(s, runs),
                     "properties": dict(s.properties), "root_seed": s.root_seed})
    return rows


def paper_claim_list() -> tuple:
    """``(paper, claim, ((A, B), ...))``: each registered paper's central accuracy claim as "A is more accurate than
    B" comparisons (its ``arena`` entry), checked on every scenario where both apply."""
    return tuple((name, REGISTRY[name].arena.claim, REGISTRY[name].arena.claim_pairs) for name in paper_names()
                 if REGISTRY[name].arena is not None and REGISTRY[name].arena.claim)


def _judge_parts(parts: list) -> report.Judgement:
    """The one judgement of a claim on ``parts`` (not assessable without any)."""
    if parts:
        return report.judge(parts)
    return report.Judgement.of(report.NOT_ASSESSABLE, "no scenario where both algorithms of a pair apply and two "
                                                      "runs are valid in both")


def _paper_judgements(result: ArenaResult) -> list:
    """``(paper, claim, Judgement, pairs, excluded)`` per paper claim of :func:`paper_claim_list`
    (:func:`paper_claims`): the judgement pooled over the scenarios not excluded (:attr:`ArenaResult.excluded`),
    and ``excluded`` ``[(scenario, reason, Judgement)]``, each excluded scenario judged alone."""
    _check_result(result)
    names = list(dict.fromkeys(c["scenario"] for c in result.cells))
    out = []
    for paper, claim, pairs in paper_claim_list():
        parts, docs, apart = [], [], {}
        for a, b in pairs:
            verdicts, part_verdicts = {}, {}
            for s in names:
                got = _compare(result, a, b, s)
                if got is None:
                    continue
                c, p = got
                verdicts[s], part_verdicts[s] = c["claim"], p.verdict
                if p.verdict != report.PartVerdict.NOT_COMPARABLE:
                    (apart.setdefault(s, []) if s in result.excluded else parts).append(p)
            docs.append({"a": a, "b": b, "verdicts": verdicts, "part_verdicts": part_verdicts})
        excluded = [(s, result.excluded[s], _judge_parts(apart.get(s, []))) for s in names
                    if s in result.excluded and any(s in d["verdicts"] for d in docs)]
        out.append((paper, claim, _judge_parts(parts), docs, excluded))
    return out


def paper_claims(result: ArenaResult) -> list:
    """Each paper's accuracy claim (:func:`paper_claim_list`) across the arena: one ``verdict`` of the claim
    vocabulary with its ``decisive`` number, judged once (:func:`mmlib.experiment.report.judge`) on the flat list of
    its ``parts`` -- one per pair "A is more accurate than B" and scenario where both apply (:func:`compare`'s
    part; a scenario where they are not comparable is left out, and so is every excluded scenario,
    :attr:`ArenaResult.excluded`) -- and per pair the ``verdicts`` (scenario -> the one-part claim verdict) and
    ``part_verdicts`` (scenario -> the part verdict, e.g. "identical (to round-off)"), every scenario included.
    ``excluded`` reports the excluded scenarios apart: ``[{scenario, reason, verdict, decisive, parts}]``, the claim
    judged on that scenario's parts alone."""
    return [{"paper": paper, "claim": claim, "verdict": j.verdict, "decisive": j.decisive,
             "parts": [p.as_json() for p in j.parts], "pairs": pairs,
             "excluded": [{"scenario": s, "reason": why, "verdict": je.verdict, "decisive": je.decisive,
                           "parts": [p.as_json() for p in je.parts]} for s, why, je in excluded]}
            for paper, claim, j, pairs, excluded in _paper_judgements(result)]


def arena_claims(result: ArenaResult) -> report.Claims:
    """The papers' accuracy claims across the arena (:func:`paper_claims`) as a :class:`mmlib.experiment.report.Claims`
    (claim ``"<claim> (<paper>, across the arena)"``, its judgement and, as evidence, the part verdicts counted per
    pair), for :func:`mmlib.experiment.notebook.claims_table`."""
    claims = report.Claims()
    for paper, claim, j, pairs, excluded in _paper_judgements(result):
        evidence = " | ".join(f"{pair['a']} − {pair['b']}: " + (", ".join(
            f"{v} {n}" for v, n in _count(v_ for s_, v_ in pair["part_verdicts"].items()
                                          if s_ not in result.excluded).items()) or "no scenario")
            for pair in pairs)
        if excluded:
            evidence += " | kept out of this verdict: " + "; ".join(f"{s} ({je.verdict} there; {why})"
                                                                    for s, why, je in excluded)
        claims.add(f"{claim} ({paper}, across the arena)", j, evidence, key=paper)
    return claims


def _count(values) -> dict:
    out: dict = {}
    for v in values:
        out[str(v)] = out.get(str(v), 0) + 1
    return out


def _scenario_list(names) -> str:
    return ", ".join(names) if names else "none"


def idea_summary(idea: dict) -> dict:
    """Counts of one idea's verdicts over the scenarios where it applies and that the pooled tallies keep
    (``n_scenarios``, ``by_verdict``: verdict -> scenarios), and apart, ``excluded``: {scenario: its verdict} for the
    scenarios of the idea's ``excluded`` (:func:`ideas`)."""
    if not isinstance(idea, Mapping) or any(k not in idea for k in ("idea", "paper", "a", "b", "comparisons")):
        raise ValueError(f"idea: expected an item of ideas(...) (idea, paper, a, b, comparisons), got {idea!r}")
    out_of = idea.get("excluded", {})
    groups: dict = {}
    kept = [c for c in idea["comparisons"] if c["scenario"] not in out_of]
    for c in kept:
        groups.setdefault(c["verdict"], []).append(c["scenario"])
    return {"idea": idea["idea"], "paper": idea["paper"], "a": idea["a"], "b": idea["b"],
            "n_scenarios": len(kept), "by_verdict": groups,
            "excluded": {c["scenario"]: c["verdict"] for c in idea["comparisons"] if c["scenario"] in out_of}}


def findings(result: ArenaResult, scenario_rows: list) -> list:
    """The arena's findings as Markdown bullets, every number from ``result`` and ``scenario_rows``
    (:func:`scenario_table`): which scenarios the pooled tallies leave out and why (:attr:`ArenaResult.excluded`),
    which idea helps where, which algorithms are consistent, which diverge, and where the rules separate along the
    ladder; the tallies over scenarios (ideas, consistency counts, the papers' claims) leave the excluded scenarios
    out and name them apart."""
    _check_result(result)
    if isinstance(scenario_rows, (str, bytes, Mapping)) or not hasattr(scenario_rows, "__iter__") or not all(
            isinstance(r, Mapping) and all(k in r for k in ("scenario", "nonlinearity_index", "properties"))
            for r in scenario_rows):
        raise ValueError("scenario_rows: expected the rows of scenario_table() (scenario, nonlinearity_index, "
                         "properties)")
    out = []
    index = {r["scenario"]: r["nonlinearity_index"]["median"] for r in scenario_rows}
    if result.excluded:
        out.append("- **Kept out of every pooled tally below** (each reported apart): " + "; ".join(
            f"{name}: {why}" for name, why in result.excluded.items()) + ".")
    for idea in ideas(result):
        s = idea_summary(idea)
        apart = ("; kept out: " + ", ".join(f"{sc} {v}" for sc, v in s["excluded"].items())) if s["excluded"] else ""
        if not s["n_scenarios"]:
            out.append(f"- **{s['idea']}** ({s['a']} against {s['b']}): applies to no pooled scenario of this run"
                       f"{apart}.")
            continue
        parts = [f"{k} in {len(v)} ({_scenario_list(v)})" for k, v in sorted(s["by_verdict"].items())]
        out.append(f"- **{s['idea']}** ({s['a']} against {s['b']}, {s['paper']}): over the {s['n_scenarios']} "
                   f"scenarios where both apply, " + "; ".join(parts) + apart + ".")
    metric_cells = [c for c in result.cells if "reason" not in c]
    for stat, what in (("anis", "ANIS inside its exact 95 % band (white innovations)"),
                       ("anees", "ANEES inside its 95 % one-step band (a lenient test: module docstring)")):
        judged = {}
        for c in metric_cells:
            if c["scenario"] in result.excluded:
                continue
            m = c.get(stat) or {}
            if m.get("inside") is not None:
                judged.setdefault(c["algorithm"], []).append(bool(m["inside"]))
        order = sorted(judged, key=lambda a: (-sum(judged[a]), a))
        out.append(f"- **Consistency: {what}**, in the scenarios where the algorithm has a value: "
                   + "; ".join(f"{a} {sum(judged[a])}/{len(judged[a])}" for a in order) + ".")
    diverging = {}
    for c in metric_cells:
        if c["diverged"]:
            diverging.setdefault(c["algorithm"], []).append(f"{c['scenario']} {c['diverged']}/{c['n_runs']}")
    out.append("- **Divergence** (runs diverged, counted and excluded): " + (
        "; ".join(f"{a}: {', '.join(v)}" for a, v in diverging.items()) if diverging else "no run diverged") + ".")
    ladder_nl = [r["scenario"] for r in scenario_rows if r["properties"].get("axis") == "nonlinearity"]
    sep = []
    for name in ladder_nl:
        c = compare(result, "IMMUKF", "IMMEKF", name)
        d = compare(result, "IMM5CKF", "IMMCKF", name)
        if c and d:
            sep.append(f"{name} (index {index.get(name, float('nan')):.3g}): IMMUKF vs IMMEKF {_with_relative(c)}, "
                       f"IMM5CKF vs IMMCKF {_with_relative(d)}")
    if sep:
        out.append("- **Where the rules separate** (position MSE, paired): " + "; ".join(sep) + ".")
    for pc in paper_claims(result):
        parts = []
        for pair in pc["pairs"]:
            groups: dict = {}
            for sc, v in pair["part_verdicts"].items():
                if sc in result.excluded:
                    continue
                groups.setdefault(str(v), []).append(sc)
            counts = "; ".join(f"{v} in {len(ss)} ({_scenario_list(ss)})" for v, ss in sorted(groups.items()))
            parts.append(f"{pair['a']} against {pair['b']}: " + (counts or "no scenario where both apply"))
        apart = ("; kept out of this verdict: " + "; ".join(f"{e['scenario']} **{e['verdict']}** ({e['decisive']})"
                                                            for e in pc["excluded"])) if pc["excluded"] else ""
        out.append(f"- **{pc['paper']}'s claim** *{pc['claim']}*, across the arena: **{pc['verdict']}** "
                   f"({pc['decisive']}); " + " | ".join(parts) + apart + ".")
    return out


def _with_relative(c: dict) -> str:
    """A comparison's verdict with its relative difference (none on round-off: no effect to size)."""
    if c.get("relative") is None or c["verdict"] == ArenaVerdict.IDENTICAL:
        return str(c["verdict"])
    return f"{c['verdict']} ({100 * c['relative']:+.1f} %)"
