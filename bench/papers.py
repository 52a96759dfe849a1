"""Every registered paper's filters against the flop floor, fused and composed (``make bench``): a benchmark, never a
test.

For each paper of :data:`mmlib.papers.REGISTRY` (the controls too: their KF and CKF are the simplest filters), every
estimator of its headline batch (``Paper.batch`` of its headline set-up) is run on the first ``BENCH_PAPER_STEPS``
steps of ``BENCH_PAPER_RUNS`` runs, batched (``run(..., keep_cov=False)``, the papers' timing setting), after one
untimed call: CPU time per run-step (the fastest of ``BENCH_PAPER_REPEATS``, ``time.thread_time``, garbage collector
paused, :func:`bench.cost_model.time_per_step`), with the fused filter steps on (the default) and off
(``linalg.use_fused(False)``: every step composed of its operations), and whether the fused step was taken.
Beside each: its flops per run-step (the cost model,
:func:`mmlib.core.cost.step_flops`; with per-step measurement models, those of the largest) and the ratio of the
measured time to the *flop floor*, those flops at this core's peak rate (:func:`bench.flops.peak_gflops`, a large
matrix product).  Written to ``data/bench/papers.json`` with its provenance.

The floor assumes the peak of a matrix product: fused multiply-adds on the widest vectors.  mmlib's kernels use
neither contraction nor reassociation (a run's bits must not depend on the machine's instruction set), so their own
ceiling is a fraction of that peak; the ratio says how far from the arithmetic a filter is, not how far from what
its kernels could reach.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

if __name__ == "__main__":            # before numpy is imported (the BLAS reads its thread count when it loads)
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from bench.provenance import pin_threads
    pin_threads()

import json                             # noqa: E402

import numpy as np                      # noqa: E402

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "data" / "bench"


def _env_int(name: str, default: int) -> int:
    v = os.environ.get(name, str(default)).strip()
    if not v.isdigit() or int(v) < 1:
        raise ValueError(f"{name}: expected a positive integer, got {v!r}")
    return int(v)


def paper_filters(n_runs: int, n_steps: int, repeats: int, peak_gflops: float) -> list:
    """One row per estimator of every registered paper's headline batch (see the module docstring)."""
    from bench.cost_model import time_per_step
    from mmlib.core import cost, linalg
    from mmlib.experiment.montecarlo import MonteCarlo
    from mmlib.papers import REGISTRY

    rows = []
    for name, paper in REGISTRY.items():
        batch = paper.batch(paper.headline_setup(), MonteCarlo(paper.root_seed, n_runs))
        make_batch, estimators = batch[0], batch[1]
        models = list(batch[2][:n_steps]) if len(batch) == 3 else None
        _, z, init = make_batch(range(n_runs))
        z = list(z[:n_steps]) if models is not None else np.ascontiguousarray(np.asarray(z)[:, :n_steps])
        for est_name, est in estimators.items():
            largest = max(models, key=lambda m: m.dim) if models is not None else None
            flops = cost.step_flops(est, measurement=largest)["total"] if largest is not None \
                else cost.step_flops(est)["total"]
            calls = []
            fused_steps = {step: getattr(linalg, step) for step in linalg.FUSED_STEPS}
            for step, real in fused_steps.items():
                setattr(linalg, step, lambda *a, _real=real, **k: calls.append(1) or _real(*a, **k))
            try:
                fused = time_per_step(est, init[est_name], z, repeats, models)["best_s"]
            finally:
                for step, real in fused_steps.items():
                    setattr(linalg, step, real)
            with linalg.use_fused(False):
                composed = time_per_step(est, init[est_name], z, repeats, models)["best_s"]
            floor = flops / (peak_gflops * 1e9)
            row = {"paper": name, "filter": est_name, "runs": n_runs, "steps": n_steps, "flops_per_run_step": flops,
                   "fused_step_taken": bool(calls), "us_per_run_step": 1e6 * fused,
                   "us_per_run_step_composed": 1e6 * composed, "floor_us_per_run_step": 1e6 * floor,
                   "ratio_to_floor": fused / floor, "ratio_to_floor_composed": composed / floor}
            rows.append(row)
            print(f"  {name:10s} {est_name:22s} {flops:8d} flops  {row['us_per_run_step']:7.3f} us/run-step "
                  f"({'fused' if calls else 'composed'}; composed {row['us_per_run_step_composed']:7.3f})  "
                  f"{row['ratio_to_floor']:6.1f}x the floor", flush=True)
    return rows


def main() -> int:
    from bench.flops import peak_gflops
    from bench.provenance import provenance
    from mmlib.experiment.writing import atomic_write_text

    n_runs = _env_int("BENCH_PAPER_RUNS", 1000)
    n_steps = _env_int("BENCH_PAPER_STEPS", 20)
    repeats = _env_int("BENCH_PAPER_REPEATS", 3)
    peak = peak_gflops()
    print(f"every paper's filters, {n_runs} runs x {n_steps} steps, against the flop floor "
          f"(peak {peak['gflops']:.1f} GFLOP/s)", flush=True)
    rows = paper_filters(n_runs, n_steps, repeats, peak["gflops"])
    doc = {"what": "per registered paper, every headline estimator: CPU time per run-step batched (keep_cov=False), "
                   "fused filter steps on and off, flops per run-step (mmlib.core.cost.step_flops) and the ratio to "
                   "the flop floor (flops at the peak rate of a matrix product); see bench/papers.py",
           "method": f"fastest of {repeats} timed run() calls after one untimed, {n_runs} runs x {n_steps} steps",
           "peak": peak, "filters": rows, **provenance()}
    OUT.mkdir(parents=True, exist_ok=True)
    atomic_write_text(OUT / "papers.json", json.dumps(doc, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
