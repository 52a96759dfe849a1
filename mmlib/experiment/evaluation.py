"""Monte Carlo evaluation of estimators on common random numbers, paired comparisons and timing
(the experiment layer; paper-agnostic)."""
from __future__ import annotations

import gc
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


def time_algorithms(estimators: dict, init: dict, measurements, *, repeats: int = 3,
                    per_repeat: int | None = None) -> tuple:
    """CPU seconds per run of each estimator, ``(one_at_a_time, batched)``: dicts name -> array with one
    value per repeat, for ratios between estimators taken per repeat (their standard error from the
    repeats, as the verdict rule needs).

    CPU time of the timing thread (``time.thread_time``: the filters are single-threaded numpy), with the
    garbage collector paused as ``timeit`` does, so that neither other processes nor a notebook kernel's
    own threads enter the timing.  One untimed warm-up run per estimator comes first.  In every repeat the
    estimators take turns run by run, their order rotated from repeat to repeat so that none is always
    first, each running the first ``per_repeat`` runs (default: all) of ``measurements`` one at a time
    (B = 1, the papers' way); the repeat's one-at-a-time value is the fastest of these runs -- every run
    does the same work, so the fastest is the least disturbed measurement of it.  Batched: all runs of
    ``measurements`` in one call, once per repeat."""
    n = measurements.shape[0]
    per_repeat = n if per_repeat is None else per_repeat
    if isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 2:
        raise ValueError(f"repeats: expected an integer >= 2 (a standard error needs two), got {repeats!r}")
    if isinstance(per_repeat, bool) or not isinstance(per_repeat, int) or not 1 <= per_repeat <= n:
        raise ValueError(f"per_repeat: expected an integer from 1 to the {n} runs of measurements, got {per_repeat!r}")
    names = list(estimators)
    single = {a: np.empty((repeats, per_repeat)) for a in names}
    batched = {a: np.empty(repeats) for a in names}
    for a in names:
        run(estimators[a], select_runs(init[a], slice(0, 1)), measurements[:1], keep_cov=False)
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        for r in range(repeats):
            order = names[r % len(names):] + names[:r % len(names)]
            for b in range(per_repeat):
                for a in order:
                    t0 = time.thread_time()
                    run(estimators[a], select_runs(init[a], slice(b, b + 1)), measurements[b:b + 1], keep_cov=False)
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
    are per run and the filters batch-size invariant), without recomputing them."""
    cut = (lambda a: None if a is None else a[:n])
    return RunSet(rs.errors[:n], cut(rs.mode_probabilities), rs.diverged_step[:n], rs.example_mean, cut(rs.diagnostics))
