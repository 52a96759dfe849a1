"""Pieces shared by the paper scenarios: deviations, Monte Carlo evaluation of
estimators on common random numbers, timing."""
from __future__ import annotations

import time
from dataclasses import dataclass, asdict
from typing import Callable, NamedTuple

import numpy as np

from .. import metrics
from ..estimation import run, select_runs
from ..montecarlo import MonteCarlo, Progress


@dataclass(frozen=True)
class Deviation:
    """A numbered interpretation: what the paper gives, what we do, and why."""

    id: str
    topic: str
    paper: str
    choice: str
    reason: str
    sweep: str = ""

    def as_dict(self) -> dict:
        return asdict(self)


class RunSet(NamedTuple):
    """Per-run outputs of one estimator over a set of runs (run axis first)."""

    errors: np.ndarray               # (N, K, n) estimate - truth
    mode_probabilities: object       # (N, K, r) or None
    diverged_step: np.ndarray        # (N,)
    example_mean: np.ndarray         # (K, n) estimate of the first run (for trajectory plots)

    @property
    def valid(self) -> np.ndarray:
        return self.diverged_step < 0


def evaluate(estimators: dict, make_batch: Callable, mc: MonteCarlo, *, chunk_size: int = 250,
             label: str = "", progress: bool = True) -> dict:
    """Run every estimator on the same runs (common random numbers), chunk by chunk.

    ``make_batch(runs)`` returns ``(truth (B, K+1, n), measurements (B, K, m),
    init: dict name -> initial state)``.  Returns ``{name: RunSet}``.
    """
    out = {name: {"err": [], "mu": [], "div": []} for name in estimators}
    first = {}
    bar = Progress(label or "Monte Carlo", mc.n_runs, enabled=progress)
    for runs in mc.chunks(chunk_size):
        truth, z, init = make_batch(runs)
        for name, est in estimators.items():
            track = run(est, init[name], z, keep_cov=False)
            out[name]["err"].append(track.mean - truth[:, 1:])
            out[name]["div"].append(track.diverged_step)
            if track.mode_probabilities is not None:
                out[name]["mu"].append(track.mode_probabilities)
            if name not in first:
                first[name] = track.mean[0]
        bar.advance(len(runs))
    return {name: RunSet(np.concatenate(d["err"]), np.concatenate(d["mu"]) if d["mu"] else None,
                         np.concatenate(d["div"]), first[name]) for name, d in out.items()}


def paired_mse_difference(a: RunSet, b: RunSet, component: int):
    """Mean over runs of (time-averaged squared error of a - of b) for one state component,
    with its standard error; runs diverged in either are excluded."""
    ok = a.valid & b.valid
    da = (a.errors[ok, :, component] ** 2).mean(axis=1)
    db = (b.errors[ok, :, component] ** 2).mean(axis=1)
    return metrics.mean_with_se(da - db)


def time_per_run(estimator, init_state, measurements, *, repeats: int = 3) -> np.ndarray:
    """Seconds per run, the paper's way (one run at a time, B = 1); one value per repeat."""
    times = []
    n = measurements.shape[0]
    for _ in range(repeats):
        t0 = time.perf_counter()
        for b in range(n):
            run(estimator, select_runs(init_state, slice(b, b + 1)), measurements[b:b + 1], keep_cov=False)
        times.append((time.perf_counter() - t0) / n)
    return np.array(times)


def time_batched(estimator, init_state, measurements, *, repeats: int = 3) -> np.ndarray:
    """Seconds per run when all runs go through in one batch; one value per repeat."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        run(estimator, init_state, measurements, keep_cov=False)
        times.append((time.perf_counter() - t0) / measurements.shape[0])
    return np.array(times)
