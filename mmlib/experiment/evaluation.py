"""Monte Carlo evaluation of estimators on common random numbers, paired comparisons and timing
(the experiment layer; paper-agnostic)."""
from __future__ import annotations

import time
from typing import Callable, NamedTuple

import numpy as np

from .. import metrics
from ..estimation import run, select_runs
from ..montecarlo import MonteCarlo, Progress
from ..simulate import simulate



class RunSet(NamedTuple):
    """Per-run outputs of one estimator over a set of runs (run axis first)."""

    errors: np.ndarray               # (N, K, n) estimate - truth
    mode_probabilities: object       # (N, K, r) or None
    diverged_step: np.ndarray        # (N,)
    example_mean: np.ndarray         # (K, n) estimate of the first run (for trajectory plots)
    diagnostics: object = None       # (N, K, d) per-step diagnostics of adaptive estimators, or None

    @property
    def valid(self) -> np.ndarray:
        return self.diverged_step < 0


def select(estimators: dict, names=None) -> dict:
    """The estimators named in ``names`` (all if None), in that order."""
    return dict(estimators) if names is None else {k: estimators[k] for k in names}


def make_batches(mc: MonteCarlo, schedule, measurement, x0, estimators: dict, init_state: Callable, *,
                 process_noise: bool = True, fault: Callable | None = None, start: Callable | None = None) -> Callable:
    """The ``make_batch(runs)`` every scenario needs: simulate truth and measurements for the runs
    (optionally with a sensor fault ``fault(runs) -> SensorFault``), start every filter from
    ``start(runs)`` (default: the true x0) and initialise each estimator with
    ``init_state(estimator, start, runs)``.  Returns ``runs -> (truth, measurements, {name: state})``."""
    x0 = np.asarray(x0, dtype=float)

    def make_batch(runs):
        noise_fn = None if fault is None else fault(runs).apply(measurement)
        sc = simulate(schedule, x0, measurement, mc, runs, process_noise=process_noise, measurement_noise_fn=noise_fn)
        m0 = np.tile(x0, (len(runs), 1)) if start is None else start(runs)
        return sc.truth, sc.measurements, {n: init_state(e, m0, runs) for n, e in estimators.items()}

    return make_batch


def evaluate(estimators: dict, make_batch: Callable, mc: MonteCarlo, *, chunk_size: int = 250,
             label: str = "", progress: bool = True, measurement_models=None) -> dict:
    """Run every estimator on the same runs (common random numbers), chunk by chunk.

    ``make_batch(runs)`` returns ``(truth (B, K+1, n), measurements (B, K, m),
    init: dict name -> initial state)``; with ``measurement_models`` (one per step, see
    :func:`mmlib.estimation.run`) the measurements are a list of K arrays (B, m_k).
    Returns ``{name: RunSet}``.
    """
    out = {name: {"err": [], "mu": [], "div": [], "diag": []} for name in estimators}
    first = {}
    bar = Progress(label or "Monte Carlo", mc.n_runs, enabled=progress)
    for runs in mc.chunks(chunk_size):
        truth, z, init = make_batch(runs)
        for name, est in estimators.items():
            track = run(est, init[name], z, keep_cov=False, measurement_models=measurement_models)
            out[name]["err"].append(track.mean - truth[:, 1:])
            out[name]["div"].append(track.diverged_step)
            if track.mode_probabilities is not None:
                out[name]["mu"].append(track.mode_probabilities)
            if track.diagnostics is not None:
                out[name]["diag"].append(track.diagnostics)
            if name not in first:
                first[name] = track.mean[0]
        bar.advance(len(runs))
    return {name: RunSet(np.concatenate(d["err"]), np.concatenate(d["mu"]) if d["mu"] else None,
                         np.concatenate(d["div"]), first[name],
                         np.concatenate(d["diag"]) if d["diag"] else None) for name, d in out.items()}


def paired_mse_difference(a: RunSet, b: RunSet, components):
    """Mean over runs of (time-averaged squared error of a minus that of b), with its standard
    error; ``components`` is one state index or a tuple whose squared errors are summed (e.g. x
    and y for a position error).  Runs diverged in either estimator are excluded."""
    idx = [components] if np.isscalar(components) else list(components)
    ok = a.valid & b.valid
    da = (a.errors[ok][..., idx] ** 2).sum(axis=-1).mean(axis=1)
    db = (b.errors[ok][..., idx] ** 2).sum(axis=-1).mean(axis=1)
    return metrics.mean_with_se(da - db)


def better_claim(results: dict, a: str, b: str, quantities) -> tuple[str, str]:
    """Verdict and evidence for "a is more accurate than b" over ``quantities`` = [(label, components)],
    from paired differences on common random numbers (:func:`mmlib.report.claim_verdict`)."""
    from ..report import claim_verdict, combine_claim_verdicts
    parts = []
    for label, comp in quantities:
        d = paired_mse_difference(results[a], results[b], comp)
        idx = [comp] if np.isscalar(comp) else list(comp)
        ref = float((results[b].errors[results[b].valid][..., idx] ** 2).sum(axis=-1).mean())
        parts.append((label, float(d.value), float(d.stderr), ref,
                      claim_verdict(float(d.value), float(d.stderr), -1, reference=ref)))
    verdict = combine_claim_verdicts(f"{v} ({lab})" for lab, _, _, _, v in parts)
    evidence = "; ".join(f"{lab}: Δ(mean squared error) = {v:.3g} ± {se:.2g} ({100 * v / r:+.2g} %)"
                         for lab, v, se, r, _ in parts)
    return verdict, evidence


def _time_one_at_a_time(estimator, init_state, measurements) -> float:
    t0 = time.perf_counter()
    n = measurements.shape[0]
    for b in range(n):
        run(estimator, select_runs(init_state, slice(b, b + 1)), measurements[b:b + 1], keep_cov=False)
    return (time.perf_counter() - t0) / n


def _time_batched(estimator, init_state, measurements) -> float:
    t0 = time.perf_counter()
    run(estimator, init_state, measurements, keep_cov=False)
    return (time.perf_counter() - t0) / measurements.shape[0]


def time_algorithms(estimators: dict, init: dict, measurements, *, repeats: int = 3):
    """Seconds per run of each estimator, ``(one_at_a_time, batched)``: dicts name -> array
    (one value per repeat).  One at a time (B = 1) is the paper's way; batched is all runs in
    one call.  Algorithms are interleaved within every repeat, so that ratios between them
    compare adjacent measurements and are robust to the machine's speed drifting."""
    single = {name: [] for name in estimators}
    batched = {name: [] for name in estimators}
    for _ in range(repeats):
        for name, est in estimators.items():
            single[name].append(_time_one_at_a_time(est, init[name], measurements))
            batched[name].append(_time_batched(est, init[name], measurements))
    return ({k: np.array(v) for k, v in single.items()}, {k: np.array(v) for k, v in batched.items()})


def first_runs(rs: RunSet, n: int) -> RunSet:
    """The first ``n`` runs of a RunSet: the same numbers a run over ``n`` runs gives (the streams
    are per run and the filters batch-size invariant), without recomputing them."""
    cut = (lambda a: None if a is None else a[:n])
    return RunSet(rs.errors[:n], cut(rs.mode_probabilities), rs.diverged_step[:n], rs.example_mean, cut(rs.diagnostics))
