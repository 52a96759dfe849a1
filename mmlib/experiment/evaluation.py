"""Monte Carlo evaluation of estimators on common random numbers, paired comparisons and timing
(the experiment layer; paper-agnostic)."""
from __future__ import annotations

import concurrent.futures as cf
import gc
import math
import time
from collections.abc import Mapping
from typing import Any, Callable, Iterable, NamedTuple, Sequence

import numpy as np
from numpy.typing import ArrayLike

from mmlib.core import linalg
from mmlib.experiment import metrics
from mmlib.core._validate import (as_float_array, check_bool, check_finite, check_finite_runs, check_has,
                                  check_index, check_mask, check_positive_int)
from mmlib.core.estimation import Track, run, select_runs, summarise_divergence
from mmlib.experiment.montecarlo import MonteCarlo, Progress
from mmlib.core.protocols import Estimator, MeasurementModel
from mmlib.experiment.simulate import ManeuverSchedule, simulate
from mmlib.experiment.executors import run_tasks

__all__ = [
    "evaluate", "RunSet", "paired_mse_difference", "better_claim", "nees_profile", "NEESProfile", "consistency",
    "consistency_entries", "simulator", "make_batches", "with_initial_states", "evaluate_with_cost", "select",
    "time_algorithms", "first_runs", "divergence_report", "degenerate_reason", "run_operations", "pair_operations"
]



class RunSet(NamedTuple):
    """Per-run outputs of one estimator over a set of runs (run axis first)."""

    errors: np.ndarray               # (N, K, n) estimate - truth
    mode_probabilities: object       # (N, K, r) or None
    diverged_step: np.ndarray        # (N,)
    example_mean: np.ndarray         # (K, n) estimate of the first run (for trajectory plots)
    diagnostics: object = None       # (N, K, d) per-step diagnostics of adaptive estimators, or None
    divergence_cause: object = None  # (N,) mmlib.core.estimation.Failure codes (0: not diverged), or None
    nees: object = None              # (N, K) NEES per run and step (evaluate(..., consistency=True)), or None
    nis: object = None               # (N, K) NIS per run and step, or None
    nis_dof: object = None           # (K,) measurement dimension m_k of every step (the NIS's degrees of freedom)
    ops: object = None               # floating-point operations of one run (run_operations), or None if unknown

    @property
    def valid(self) -> np.ndarray:
        """(N,) bool: the runs that did not diverge (``diverged_step`` -1)."""
        return self.diverged_step < 0

    def divergence_summary(self) -> str:
        """How many runs diverged, at which steps and why (:func:`mmlib.core.estimation.summarise_divergence`)."""
        return summarise_divergence(self.diverged_step, self.divergence_cause)


def _check_mapping(value, name: str, what: str, nonempty: bool = True) -> Mapping:
    if not isinstance(value, Mapping):
        raise ValueError(f"{name}: expected a dict of {what}, got {type(value).__name__}")
    if nonempty and not value:
        raise ValueError(f"{name}: expected at least one entry ({what}), got an empty dict")
    return value


def _check_callable(value, name: str, what: str, optional: bool = False):
    if (value is None and not optional) or (value is not None and not callable(value)):
        raise ValueError(f"{name}: expected {what}, got {type(value).__name__}")
    return value


def _check_runset(value, name: str) -> RunSet:
    if not isinstance(value, RunSet):
        raise ValueError(f"{name}: expected a RunSet (from evaluate), got {type(value).__name__}")
    return value


def _check_name(value, name: str, known) -> str:
    if not isinstance(value, str) or value not in known:
        raise ValueError(f"{name}: unknown estimator {value!r}; known: {list(known)}")
    return value


def _components(components, n: int, name: str = "components") -> list:
    """``components``: one state index 0..n-1 or a non-empty sequence of distinct ones, as a list."""
    if isinstance(components, (int, np.integer)) and not isinstance(components, (bool, np.bool_)):
        return [check_index(components, name, n)]
    if isinstance(components, (str, bytes)) or not hasattr(components, "__iter__"):
        raise ValueError(f"{name}: expected a state index or a sequence of them, got {components!r}")
    idx = [check_index(c, name, n) for c in components]
    if not idx or len(set(idx)) != len(idx):
        raise ValueError(f"{name}: expected a non-empty sequence of distinct state indices, got {components!r}")
    return idx


def select(estimators: dict, names: Iterable[str] | None = None) -> dict:
    """The estimators named in ``names`` (all if None), in that order."""
    _check_mapping(estimators, "estimators", "estimators by name", nonempty=False)
    if names is None:
        return dict(estimators)
    if isinstance(names, (str, bytes)) or not hasattr(names, "__iter__"):
        raise ValueError(f"names: expected a sequence of estimator names, got {names!r}")
    names = list(names)
    if len(set(names)) != len(names):
        raise ValueError(f"names: repeated estimator names in {names}")
    return {k: estimators[_check_name(k, "names", estimators)] for k in names}


def simulator(mc: MonteCarlo, schedule: ManeuverSchedule, measurement: MeasurementModel, x0: ArrayLike, *,
              process_noise: bool = True,
              fault: Callable | None = None, start: Callable | None = None) -> Callable:
    """``runs -> (truth (B, K+1, n), measurements (B, K, m), start means (B, n))``: the truth and measurements of
    the runs (:func:`mmlib.experiment.simulate.simulate`, optionally with a sensor fault
    ``fault(runs) -> SensorFault``) and the filters' initial means ``start(runs)`` (default: the true x0).
    What a scenario's estimators see, before any of them is initialised (:func:`make_batches` adds that)."""
    if not isinstance(mc, MonteCarlo):
        raise ValueError(f"mc: expected a MonteCarlo, got {type(mc).__name__}")
    if not isinstance(schedule, ManeuverSchedule):
        raise ValueError(f"schedule: expected a ManeuverSchedule, got {type(schedule).__name__}")
    check_has(measurement, "measurement", "a measurement model", ("h", "dim", "noise_factor"))
    x0 = check_finite(as_float_array(x0, "x0"), "x0")
    if x0.ndim != 1 or x0.size == 0:
        raise ValueError(f"x0: expected a state vector of shape (n,), got shape {x0.shape}")
    if x0.size != schedule.models[0].dim:
        raise ValueError(f"x0: expected a state vector of the schedule's dimension {schedule.models[0].dim}, got "
                         f"shape {x0.shape}")
    _check_callable(fault, "fault", "None or a function runs -> SensorFault", optional=True)
    _check_callable(start, "start", "None or a function runs -> (B, n) start means", optional=True)
    if not isinstance(process_noise, (bool, np.bool_)):
        raise ValueError(f"process_noise: expected True or False, got {process_noise!r}")

    def simulate_runs(runs):
        noise_fn = None if fault is None else fault(runs).apply(measurement)
        sc = simulate(schedule, x0, measurement, mc, runs, process_noise=process_noise, measurement_noise_fn=noise_fn)
        m0 = np.tile(x0, (len(runs), 1)) if start is None else start(runs)
        if np.shape(m0) != (len(runs), x0.size):
            raise ValueError(f"start: returned shape {np.shape(m0)}, expected {(len(runs), x0.size)} (runs, n)")
        return sc.truth, sc.measurements, m0

    return simulate_runs


def with_initial_states(simulate_runs: Callable, estimators: dict, init_state: Callable) -> Callable:
    """``runs -> (truth, measurements, {name: initial state})`` from a :func:`simulator`-like
    ``simulate_runs(runs) -> (truth, measurements, start means)``: each estimator initialised by
    ``init_state(estimator, start, runs)``."""
    _check_callable(simulate_runs, "simulate_runs", "a function runs -> (truth, measurements, start means)")
    _check_mapping(estimators, "estimators", "estimators by name", nonempty=False)   # none: truth only
    _check_callable(init_state, "init_state", "a function (estimator, start, runs) -> state")

    def make_batch(runs):
        truth, z, m0 = simulate_runs(runs)
        return truth, z, {n: init_state(e, m0, runs) for n, e in estimators.items()}

    return make_batch


def make_batches(mc: MonteCarlo, schedule: ManeuverSchedule, measurement: MeasurementModel, x0: ArrayLike,
                 estimators: dict, init_state: Callable, *,
                 process_noise: bool = True, fault: Callable | None = None, start: Callable | None = None) -> Callable:
    """The ``make_batch(runs)`` every scenario needs: :func:`simulator` (truth, measurements and start means of the
    runs) with every estimator initialised by ``init_state(estimator, start, runs)``
    (:func:`with_initial_states`).  Returns ``runs -> (truth, measurements, {name: state})``.

    ``x0`` (n,) the true initial state; ``start(runs)`` must return (len(runs), n)."""
    _check_mapping(estimators, "estimators", "estimators by name", nonempty=False)
    _check_callable(init_state, "init_state", "a function (estimator, start, runs) -> state")
    return with_initial_states(simulator(mc, schedule, measurement, x0, process_noise=process_noise, fault=fault,
                                         start=start), estimators, init_state)


def evaluate(estimators: dict, make_batch: Callable, mc: MonteCarlo, *, chunk_size: int = 250,
             label: str = "", progress: bool = True, measurement_models: Sequence[MeasurementModel] | None = None,
             workers: int | None = None, executor: cf.Executor | None = None, consistency: bool = False) -> dict:
    """Run every estimator on the same runs (common random numbers), chunk by chunk.

    ``make_batch(runs)`` returns ``(truth (B, K+1, n), measurements (B, K, m),
    init: dict name -> initial state)``; with ``measurement_models`` (one per step, see
    :func:`mmlib.core.estimation.run`) the measurements are a list of K arrays (B, m_k).
    Returns ``{name: RunSet}``.

    The runs are cut into chunks of ``chunk_size`` (integer >= 1) consecutive runs, and the chunks run in
    parallel where :func:`mmlib.experiment.executors.run_tasks` puts them: ``executor`` if given (any
    ``concurrent.futures.Executor``, not shut down here), else the Dask cluster of ``$MMLIB_SCHEDULER`` if set,
    else ``workers`` local processes (integer >= 1; default ``$WORKERS``, else every core); one chunk, one worker,
    or a call from inside a task (a universe of ``run_grid``) runs in this process.  The chunks depend on
    ``chunk_size`` only, the results are concatenated in chunk order and the filters give a run the same bits in
    any batch, so the numbers are bit for bit those of a serial run, whatever the workers, executor or chunk size.
    ``estimators``, ``make_batch`` and ``measurement_models`` are sent to the workers with cloudpickle (closures
    and notebook functions are fine).  ``progress`` prints a line per finished chunk.  ``consistency=True`` also
    records every run's NEES and NIS per step (``RunSet.nees``, ``nis``, ``nis_dof``;
    :func:`mmlib.core.estimation.run`)."""
    return evaluate_with_cost(estimators, make_batch, mc, chunk_size=chunk_size, label=label, progress=progress,
                              measurement_models=measurement_models, workers=workers, executor=executor,
                              consistency=consistency)[0]


def evaluate_with_cost(estimators: dict, make_batch: Callable, mc: MonteCarlo, *, chunk_size: int = 250,
                       label: str = "", progress: bool = True,
                       measurement_models: Sequence[MeasurementModel] | None = None, workers: int | None = None,
                       executor: cf.Executor | None = None, consistency: bool = False) -> tuple:
    """:func:`evaluate` and what it cost: ``({name: RunSet}, {name: CPU seconds})``, the thread CPU time of each
    estimator's runs summed over the chunks (simulation excluded; a measurement, never part of a result)."""
    _check_mapping(estimators, "estimators", "estimators by name")
    _check_callable(make_batch, "make_batch", "a function runs -> (truth, measurements, init)")
    check_bool(progress, "progress")
    check_bool(consistency, "consistency")
    if not isinstance(label, str):
        raise ValueError(f"label: expected a string, got {label!r}")
    if measurement_models is not None:
        if isinstance(measurement_models, (str, bytes, Mapping)) or not hasattr(measurement_models, "__len__"):
            raise ValueError(f"measurement_models: expected None or a sequence of measurement models, one per step, "
                             f"got {measurement_models!r}")
        for k, model in enumerate(measurement_models):
            check_has(model, f"measurement_models[{k}]", "a measurement model", ("h", "dim", "R"))
    if not isinstance(mc, MonteCarlo):
        raise ValueError(f"mc: expected a MonteCarlo, got {type(mc).__name__}")
    chunks = mc.chunks(chunk_size)
    bar = Progress(label or "Monte Carlo", mc.n_runs, enabled=progress)
    parts = run_tasks(_evaluate_chunk, [(runs,) for runs in chunks],
                      shared=(estimators, make_batch, measurement_models, consistency), workers=workers,
                      executor=executor,
                      on_result=lambda i, _: bar.advance(len(chunks[i])))
    out, cpu = {}, {}
    for name in estimators:
        per = [part[name] for part in parts]
        cat = (lambda field: np.concatenate([p[field] for p in per]) if per[0][field] is not None else None)
        out[name] = RunSet(cat("err"), cat("mu"), cat("div"), per[0]["first"], cat("diag"), cat("cause"),
                           cat("nees"), cat("nis"), per[0]["nis_dof"],
                           run_operations(estimators[name], per[0]["err"].shape[1], measurement_models))
        cpu[name] = float(sum(p["cpu"] for p in per))
    return out, cpu


def run_operations(estimator: Estimator, steps: int,
                   measurement_models: Sequence[MeasurementModel] | None = None) -> int | None:
    r"""The operation count ``c`` of the round-off floor of a run of ``estimator`` over ``steps`` steps
    (:func:`mmlib.experiment.verdicts.identity_floor`): its flops per step :math:`f` by the cost model
    (:func:`mmlib.core.cost.step_flops`; with per-step ``measurement_models``, those of the largest) times
    :math:`\sqrt K` for the ``K`` steps, rounded up: the worst-case rounding of one step's operations, accumulating over
    the steps like a random walk (Higham 2002, *Accuracy and Stability of Numerical Algorithms*, Sec. 2.8) -- a
    filter forgets old steps, so the errors of a whole run do not add linearly.  None when the cost model does not
    know the estimator."""
    from mmlib.core import cost
    steps = check_positive_int(steps, "steps")
    if measurement_models is not None and (isinstance(measurement_models, (str, bytes, Mapping))
                                           or not hasattr(measurement_models, "__len__")):
        raise ValueError(f"measurement_models: expected None or a sequence of measurement models, got "
                         f"{measurement_models!r}")
    try:
        if measurement_models is not None and len(measurement_models):
            largest = max(measurement_models, key=lambda mm: mm.dim)
            per_step = cost.step_flops(estimator, measurement=largest)["total"]
        else:
            per_step = cost.step_flops(estimator)["total"]
    except ValueError:
        return None
    return int(math.ceil(per_step * math.sqrt(steps)))


def pair_operations(a: RunSet, b: RunSet) -> int:
    """The operation count of the round-off floor of a paired comparison of the runs ``a`` and ``b``: the larger of
    their ``RunSet.ops`` (:func:`run_operations`), ``ROUNDOFF_OPS`` when either is unknown."""
    from mmlib.experiment.verdicts import ROUNDOFF_OPS
    _check_runset(a, "a")
    _check_runset(b, "b")
    return ROUNDOFF_OPS if a.ops is None or b.ops is None else max(int(a.ops), int(b.ops))


def _evaluate_chunk(estimators: dict, make_batch: Callable, measurement_models, consistency: bool, runs) -> dict:
    """One chunk of :func:`evaluate` (a task, possibly in a worker process): ``{name: {"err", "mu", "div",
    "diag", "cause", "first"}}`` for the runs ``runs`` (a range of run indices), ``mu``/``diag`` None when the
    estimator has none; ``first`` is the estimate of the chunk's first run."""
    truth, z, init = _checked_batch(make_batch(runs), runs, estimators, measurement_models is not None)
    out = {}
    for name, est in estimators.items():
        t0 = time.thread_time()
        track = run(est, init[name], z, keep_cov=False, measurement_models=measurement_models,
                    consistency=consistency, truth=truth if consistency else None)
        cpu = time.thread_time() - t0
        if track.mean.shape[-1] != truth.shape[-1]:
            raise ValueError(f"make_batch: truth of state dimension {truth.shape[-1]}, but {name!r} estimates "
                             f"{track.mean.shape[-1]}")
        out[name] = {"err": track.errors(truth), "mu": track.mode_probabilities, "div": track.diverged_step,
                     "diag": track.diagnostics, "cause": track.divergence_cause, "first": track.mean[0],
                     "nees": track.nees, "nis": track.nis, "nis_dof": track.nis_dof, "cpu": cpu}
    return out


def paired_mse_difference(a: RunSet | Track, b: RunSet | Track, components: int | Sequence[int], *,
                          truth: ArrayLike | None = None) -> metrics.MCValue:
    r"""Mean over runs of (time-averaged squared error of a minus that of b), with its standard
    error; ``components`` is one state index or a tuple whose squared errors are summed (e.g. x
    and y for a position error).  Runs diverged in either estimator are excluded and counted.

    :math:`d_m = \frac1K\sum_k \sum_{i} (e^a_{m,k,i})^2 - (e^b_{m,k,i})^2` over the runs m valid in both;
    returns the mean of :math:`d_m` and its standard error (unit: squared unit of the components).

    ``a`` and ``b``: two :class:`RunSet` of :func:`evaluate` (their ``errors``), or two
    :class:`~mmlib.core.estimation.Track` of :func:`mmlib.core.estimation.run` on the same runs (common random
    numbers) with ``truth`` the true states (B, K+1, n) x_0..x_K (or (B, K, n)), their errors
    :meth:`Track.errors(truth) <mmlib.core.estimation.Track.errors>`.  ``truth`` is required with tracks and refused
    with RunSets (which hold their errors already); a mix of the two is a ValueError naming ``b``."""
    if isinstance(a, Track) or isinstance(b, Track):
        if not isinstance(a, Track):
            raise ValueError(f"a: expected a Track like b, got {type(a).__name__}")
        if not isinstance(b, Track):
            raise ValueError(f"b: expected a Track like a, got {type(b).__name__}")
        if truth is None:
            raise ValueError("truth: required to compare two tracks (the true states (B, K+1, n))")
        if a.mean.shape != b.mean.shape:
            raise ValueError(f"a, b: expected estimates of the same shape (B, K, n) (the same runs), got "
                             f"{a.mean.shape} and {b.mean.shape}")
        ea, eb, ok_a, ok_b = a.errors(truth), b.errors(truth), ~a.diverged, ~b.diverged
    else:
        _check_runset(a, "a")
        _check_runset(b, "b")
        if truth is not None:
            raise ValueError("truth: only for two tracks; RunSets hold their errors already")
        if a.errors.ndim != 3 or a.errors.shape != b.errors.shape:
            raise ValueError(f"a, b: expected errors of the same shape (N, K, n) (the same runs), got "
                             f"{a.errors.shape} and {b.errors.shape}")
        ea, eb, ok_a, ok_b = a.errors, b.errors, a.valid, b.valid
    idx = _components(components, ea.shape[-1])
    ok = ok_a & ok_b
    check_finite_runs(ea[..., idx], "a.errors", ok)
    check_finite_runs(eb[..., idx], "b.errors", ok)
    ea, eb = ea[ok][..., idx], eb[ok][..., idx]
    d = np.zeros(ok.shape)
    d[ok] = (ea ** 2).sum(axis=-1).mean(axis=1) - (eb ** 2).sum(axis=-1).mean(axis=1)
    return metrics.mean_with_se(d, ok)


def better_claim(results: dict, a: str, b: str, quantities: Iterable[tuple[str, int | Sequence[int]]], *,
                 unit: str = "") -> tuple:
    """Judgement and evidence for "a is more accurate than b" over ``quantities`` = [(label, components)]: one
    :class:`~mmlib.experiment.verdicts.Part` per quantity from the paired difference of mean squared errors on
    common random numbers (:func:`paired_mse_difference`), relative to b's mean squared error, combined by
    :func:`mmlib.experiment.verdicts.judge`; the round-off floor's operation count is the larger of the two runs'
    (``RunSet.ops``, :func:`run_operations`; ``ROUNDOFF_OPS`` when unknown).  ``unit``: the squared unit of the
    components (e.g. ``"m²"``).  Returns ``(Judgement, evidence text)``."""
    from mmlib.experiment.verdicts import judge, part
    _check_mapping(results, "results", "RunSets by estimator name")
    _check_name(a, "a", results)
    _check_name(b, "b", results)
    if a == b:
        raise ValueError(f"b: compares {a!r} with itself")
    if isinstance(quantities, (str, bytes)) or not hasattr(quantities, "__iter__"):
        raise ValueError(f"quantities: expected a sequence of (label, components) pairs, got {quantities!r}")
    quantities = list(quantities)
    if not quantities or not all(isinstance(q, (tuple, list)) and len(q) == 2 and isinstance(q[0], str)
                                 for q in quantities):
        raise ValueError(f"quantities: expected a non-empty sequence of (label, components) pairs, got {quantities!r}")
    ops = pair_operations(results[a], results[b])
    parts = []
    for label, comp in quantities:
        d = paired_mse_difference(results[a], results[b], comp)
        idx = [comp] if np.isscalar(comp) else list(comp)
        ref = float((results[b].errors[results[b].valid][..., idx] ** 2).sum(axis=-1).mean())
        parts.append(part(f"{a} − {b}", f"{label} MSE", float(d.value), float(d.stderr), -1, reference=ref,
                          unit=unit, ops=ops))
    from mmlib.experiment.verdicts import format_pm
    evidence = "; ".join(f"{p.quantity}: Δ = {format_pm(p.difference, p.stderr)}"
                         f"{' ' + p.unit if p.unit else ''} "
                         f"({f'{100 * p.difference / p.reference:+.2g} %' if p.reference else 'reference 0'}; "
                         f"{p.verdict})" for p in parts)
    return judge(parts), evidence


class NEESProfile(NamedTuple):
    """An estimator's normalised estimation error squared over a batch: ``per_step`` (K,) the mean over the runs that
    did not diverge, ``time_average`` the per-run time averages' mean with its standard error, ``n_diverged`` the runs
    left out."""

    per_step: np.ndarray
    time_average: metrics.MCValue
    n_diverged: int


def nees_profile(estimator: Estimator, init: Any, measurements: ArrayLike, truth: ArrayLike) -> NEESProfile:
    r"""The NEES :math:`\tilde x_k^T P_k^{-1} \tilde x_k` of ``estimator`` run from ``init`` on ``measurements``
    (B, K, m) against ``truth`` (B, K+1, n; its first state is the start), per step and time-averaged over the runs
    that did not diverge (:func:`mmlib.experiment.metrics.nees`); consistent filters average the state dimension n."""
    truth = np.asarray(truth)
    tr = run(estimator, init, measurements)
    ok = ~tr.diverged
    nees = metrics.nees(tr.errors(truth), tr.cov, valid=ok)[ok]
    return NEESProfile(nees.mean(axis=0), metrics.mean_with_se(nees.mean(axis=1)), int((~ok).sum()))


def consistency(stat: np.ndarray, dof: int | np.ndarray, ok: np.ndarray, *, white: bool) -> dict:
    """ANEES/ANIS summary of per-run, per-step chi-square statistics ``stat`` (N, K) with ``dof`` degrees of freedom
    (an int, or (K,) per step), over the valid runs ``ok`` (:func:`consistency_entries`).  ``dof`` in the result is
    the mean degrees of freedom over the steps (what a consistent filter's average has as its mean); ``white`` says the
    statistics of one run are independent in time (the NIS of a consistent filter), which makes the band of the run-
    and-time average exact; otherwise (the NEES) the band is that of a run-average at one step
    (:func:`consistency_entries`)."""
    stat = as_float_array(stat, "stat")
    if stat.ndim != 2:
        raise ValueError(f"stat: expected per-run, per-step statistics of shape (N, K), got {stat.shape}")
    ok = check_mask(ok, "ok", stat.shape[0])
    d = as_float_array(dof, "dof")
    if d.shape not in ((), (stat.shape[1],)) or not np.all(np.isfinite(d)) or np.any(d < 1) \
            or np.any(d != np.round(d)):
        raise ValueError(f"dof: expected a count of components >= 1, or one per step ({stat.shape[1]},), got {dof!r}")
    check_bool(white, "white")
    s = stat[ok]
    N, K = s.shape
    dof_k = np.broadcast_to(np.asarray(dof, dtype=float), (K,))
    dof_mean = float(dof_k.mean())
    out = {"value": None, "stderr": None, "dof": dof_mean, "band": None, "band_kind": None, "inside": None,
           "steps_inside": None, "runs_inside": None, "n_runs": int(N)}
    if N < 2 or not np.isfinite(s).all():
        return out
    per_run = s.mean(axis=1)
    value = float(per_run.mean())
    dof_int = np.asarray(dof_k, dtype=int)                       # degrees of freedom are counts of components
    bands = {d: metrics.chi2_band(int(d), N) for d in np.unique(dof_int)}   # a run-average at one step
    step_lo = np.array([bands[d][0] for d in dof_int])
    step_hi = np.array([bands[d][1] for d in dof_int])
    step_mean = s.mean(axis=0)
    total = int(dof_int.sum())
    run_lo, run_hi = (b / K for b in metrics.chi2_band(total, 1))        # one run's time average
    if white:
        band = [b / K for b in metrics.chi2_band(total, N)]
        kind = "run-and-time average, white statistics: chi2(N sum_k m_k) / (N K)"
    else:
        band = list(metrics.chi2_band(int(round(dof_mean)), N))
        kind = "run-average at one step: chi2(n N) / N (the time average of a consistent filter lies inside it " \
               "with at least 95 % probability)"
    band = [float(b) for b in band]
    out.update(value=value, stderr=float(per_run.std(ddof=1) / math.sqrt(N)), band=band, band_kind=kind,
               inside=band[0] <= value <= band[1],
               steps_inside=float(np.mean((step_mean >= step_lo) & (step_mean <= step_hi))),
               runs_inside=float(np.mean((per_run >= run_lo) & (per_run <= run_hi))))
    return out



def consistency_entries(runsets: Mapping[str, RunSet], state_dim: int, *, case: str = "") -> list:
    r"""The ``consistency`` section of a results file: per estimator of ``runsets`` (name -> :class:`RunSet` from
    :func:`evaluate` with ``consistency=True``), ``{"algorithm", "case", "anees", "anis"}`` with ``anees`` and
    ``anis`` the summaries of :func:`consistency` (value, standard error, degrees of freedom, 95 % band and whether
    the value lies inside it) over the runs that did not diverge; ``state_dim`` the NEES's degrees of freedom
    (the state dimension n); ``case`` names the paper's case ("" when it has one).

    The NIS's band is exact for a consistent filter (white innovations):
    :math:`[\chi^2_{N\sum_k m_k}(0.025), \chi^2_{N\sum_k m_k}(0.975)]/(NK)`; the NEES's is the band of a run-average
    at one step, :math:`[\chi^2_{nN}(0.025), \chi^2_{nN}(0.975)]/N`, which the time average of a consistent filter
    lies inside with at least 95 % probability (Bar-Shalom, Li & Kirubarajan 2001, Sec. 5.4.2).  An estimator run
    without ``consistency=True`` (no NEES or NIS) is a ValueError naming it."""
    _check_mapping(runsets, "runsets", "estimator name -> RunSet")
    state_dim = check_positive_int(state_dim, "state_dim")
    if not isinstance(case, str):
        raise ValueError(f"case: expected a string (the paper's case, or ''), got {case!r}")
    out = []
    for name, rs in runsets.items():
        if not isinstance(rs, RunSet):
            raise ValueError(f"runsets[{name!r}]: expected a RunSet (evaluate's), got {type(rs).__name__}")
        if rs.nees is None or rs.nis is None:
            raise ValueError(f"runsets[{name!r}]: no NEES/NIS recorded; run evaluate(..., consistency=True)")
        out.append({"algorithm": str(name), "case": case,
                    "anees": consistency(rs.nees, state_dim, rs.valid, white=False),
                    "anis": consistency(rs.nis, rs.nis_dof, rs.valid, white=True)})
    return out


def _estimate(x, name: str) -> tuple[float, float]:
    """``(value, stderr)`` of a number (standard error 0), a ``(value, stderr)`` pair or a
    :class:`~mmlib.experiment.metrics.MCValue`; ValueError naming ``name`` otherwise."""
    try:
        if isinstance(x, metrics.MCValue):
            return float(x.value), float(x.stderr)
        if isinstance(x, (tuple, list)) and len(x) == 2:
            return float(x[0]), float(x[1])
        return float(x), 0.0
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a number, a (value, stderr) pair or an MCValue, got {x!r}") from None


def degenerate_reason(errors: Mapping[str, Any], baseline: Any, *, what: str) -> str:
    r"""Why a universe is *degenerate*, or "" when it is not.  It is when no estimator is detectably and
    non-negligibly better than the no-information ``baseline`` described by ``what`` (e.g. "the measurement-only
    estimate's position RMSE"): comparing the estimators then measures only how they fail, so the universe's
    comparisons are kept out of the shares of the reading space (:mod:`mmlib.experiment.multiverse`).

    ``errors``: estimator -> its error in the unit of ``baseline`` (e.g. its position RMSE), each a number, a
    ``(value, stderr)`` pair or an :class:`~mmlib.experiment.metrics.MCValue`; ``baseline`` likewise.  An
    estimator beats the baseline when the claim rule (:func:`mmlib.experiment.verdicts.claim_verdict`) says
    "error < baseline" *holds*: the difference :math:`e - b` is below zero by more than ``SIGMA_FACTOR`` times
    :math:`\sqrt{s_e^2 + s_b^2}` (the two estimates' standard errors combined as if independent: on common runs they
    are positively correlated, so this overstates the paired error and errs toward *degenerate*) and by more than
    ``NEGLIGIBLE`` of the baseline.  One rule, so a universe near the boundary is not flagged or not by Monte Carlo
    noise alone.  A non-finite error (a diverged estimator) never beats it."""
    from mmlib.experiment import verdicts
    _check_mapping(errors, "errors", "estimator name -> error")
    b, sb = _estimate(baseline, "baseline")
    if not (math.isfinite(b) and b > 0 and math.isfinite(sb) and sb >= 0):
        raise ValueError(f"baseline: expected a positive finite error with a finite standard error, got {baseline!r}")
    if not isinstance(what, str) or not what.strip():
        raise ValueError(f"what: expected a description of the baseline, got {what!r}")
    vals = {str(name): _estimate(e, f"errors[{name!r}]") for name, e in errors.items()}
    for name, (e, se) in vals.items():
        if math.isfinite(e) and math.isfinite(se) and verdicts.claim_verdict(
                e - b, math.sqrt(se * se + sb * sb), -1, reference=b) == verdicts.PartVerdict.HOLDS:
            return ""
    best = min(vals, key=lambda k: (vals[k][0] if math.isfinite(vals[k][0]) else math.inf, k))
    from mmlib.experiment.verdicts import format_pm
    return (f"no estimator is detectably better than {what} ({format_pm(b, sb)}; the best, {best}'s, is "
            f"{format_pm(*vals[best])})")


def time_algorithms(estimators: dict, init: dict, measurements: ArrayLike, *, repeats: int = 3,
                    per_repeat: int | None = None) -> tuple:
    """CPU seconds per run of each estimator, ``(one_at_a_time, batched)``: dicts name -> array with one
    value per repeat, for ratios between estimators taken per repeat (their standard error from the
    repeats, as the verdict rule needs).

    CPU time of the timing thread (``time.thread_time``; the fused filter steps held to that one thread,
    :func:`mmlib.core.linalg.use_threads`), with the
    garbage collector paused as ``timeit`` does, so that neither other processes nor a notebook kernel's
    own threads enter the timing.  One untimed warm-up run per estimator comes first.  In every repeat the
    estimators take turns run by run, their order rotated from repeat to repeat so that none is always
    first, each running the first ``per_repeat`` runs (default: all) of ``measurements`` one at a time
    (B = 1, the papers' way); the repeat's one-at-a-time value is the fastest of these runs -- every run
    does the same work, so the fastest is the least disturbed measurement of it.  Batched: all runs of
    ``measurements`` in one call, once per repeat."""
    _check_mapping(estimators, "estimators", "estimators by name")
    _check_mapping(init, "init", "initial states by estimator name")
    for a in estimators:
        if a not in init:
            raise ValueError(f"init: lacks the initial state of estimator {a!r}")
    measurements = check_finite(as_float_array(measurements, "measurements"), "measurements")
    if measurements.ndim != 3 or measurements.shape[0] == 0:
        raise ValueError(f"measurements: expected shape (B, K, m) with B >= 1 runs, got {measurements.shape}")
    n = measurements.shape[0]
    per_repeat = n if per_repeat is None else per_repeat
    if isinstance(repeats, (bool, np.bool_)) or not isinstance(repeats, (int, np.integer)) or repeats < 2:
        raise ValueError(f"repeats: expected an integer >= 2 (a standard error needs two), got {repeats!r}")
    if isinstance(per_repeat, (bool, np.bool_)) or not isinstance(per_repeat, (int, np.integer)) \
            or not 1 <= per_repeat <= n:
        raise ValueError(f"per_repeat: expected an integer from 1 to the {n} runs of measurements, got {per_repeat!r}")
    repeats, per_repeat = int(repeats), int(per_repeat)
    names = list(estimators)
    single = {a: np.empty((repeats, per_repeat)) for a in names}
    batched = {a: np.empty(repeats) for a in names}
    for a in names:
        run(estimators[a], select_runs(init[a], slice(0, 1)), measurements[:1], keep_cov=False)
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        with linalg.use_threads(1):
            for r in range(repeats):
                order = names[r % len(names):] + names[:r % len(names)]
                for b in range(per_repeat):
                    for a in order:
                        t0 = time.thread_time()
                        run(estimators[a], select_runs(init[a], slice(b, b + 1)), measurements[b:b + 1],
                            keep_cov=False)
                        single[a][r, b] = time.thread_time() - t0
                for a in order:
                    t0 = time.thread_time()
                    run(estimators[a], init[a], measurements, keep_cov=False)
                    batched[a][r] = (time.thread_time() - t0) / n
    finally:
        if was_enabled:
            gc.enable()
    return {a: v.min(axis=1) for a, v in single.items()}, batched


def first_runs(rs: RunSet, n: int) -> RunSet:
    """The first ``n`` runs of a RunSet: the same numbers a run over ``n`` runs gives (the streams
    are per run and the filters batch-size invariant), without recomputing them.  ``n``: integer from 1
    to the runs of ``rs``."""
    _check_runset(rs, "rs")
    n = check_positive_int(n, "n")
    if n > rs.errors.shape[0]:
        raise ValueError(f"n: {n} runs asked of a RunSet of {rs.errors.shape[0]} runs")
    cut = (lambda a: None if a is None else a[:n])
    return RunSet(rs.errors[:n], cut(rs.mode_probabilities), rs.diverged_step[:n], rs.example_mean, cut(rs.diagnostics),
                  cut(rs.divergence_cause), cut(rs.nees), cut(rs.nis), rs.nis_dof, rs.ops)


def _checked_batch(batch, runs, estimators, per_step: bool):
    """``make_batch``'s return value, checked: ``(truth (B, K+1, n), measurements, {name: initial state})``
    with B = len(runs), K steps of measurements ((B, K, m), or a sequence of K arrays (B, m_k) when
    ``per_step``) and an initial state for every estimator (named errors, not a KeyError or a broadcasting
    error deep inside a filter)."""
    if isinstance(batch, (str, bytes)) or not (isinstance(batch, (tuple, list)) and len(batch) == 3):
        raise ValueError(f"make_batch: expected (truth, measurements, init) for runs {runs!r}, got "
                         f"{type(batch).__name__}")
    truth, z, init = batch
    truth = as_float_array(truth, "make_batch: truth")
    if truth.ndim != 3 or truth.shape[0] != len(runs):
        raise ValueError(f"make_batch: truth must have shape ({len(runs)}, K+1, n) for {len(runs)} runs, "
                         f"got {truth.shape}")
    if per_step:
        steps = len(z)
    else:
        z_arr = as_float_array(z, "make_batch: measurements")
        if z_arr.ndim != 3 or z_arr.shape[0] != len(runs):
            raise ValueError(f"make_batch: measurements must have shape ({len(runs)}, K, m), got {z_arr.shape}")
        steps = z_arr.shape[1]
    if truth.shape[1] != steps + 1:
        raise ValueError(f"make_batch: truth has {truth.shape[1]} epochs for {steps} measurement steps "
                         "(expected one more: x_0 and one per step)")
    if not isinstance(init, Mapping) or any(name not in init for name in estimators):
        missing = [n for n in estimators if not isinstance(init, Mapping) or n not in init]
        raise ValueError(f"make_batch: init must hold an initial state for every estimator; missing {missing}")
    return truth, z, init


def divergence_report(results: Mapping[str, RunSet | Mapping]) -> str:
    """One line per estimator with diverged runs, ``name: n of N runs diverged (steps ...; cause)``, from
    ``{name: RunSet}`` (or dicts of them, names flattened to ``"outer / inner"``); ``"no run diverged"``."""
    lines = [f"{name}: {rs.divergence_summary()}" for name, rs in _flat_runsets(results, "results").items()
             if not rs.valid.all()]
    return "\n".join(lines) if lines else "no run diverged"


def _flat_runsets(results, name: str, prefix: str = "") -> dict:
    """``{name: RunSet}``, nested dicts flattened to ``"outer / inner"`` names."""
    _check_mapping(results, name, "RunSets by estimator name (or dicts of them)")
    out = {}
    for key, value in results.items():
        if not isinstance(key, str):
            raise ValueError(f"{name}: expected estimator names as strings, got {key!r}")
        full = f"{prefix}{key}"
        if isinstance(value, Mapping):
            out.update(_flat_runsets(value, name, f"{full} / "))
        elif isinstance(value, RunSet):
            out[full] = value
        else:
            raise ValueError(f"{name}: entry {full!r} is a {type(value).__name__}, expected a RunSet or a dict")
    return out
