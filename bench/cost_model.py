"""Validation of the cost model (:mod:`mmlib.core.cost`) against measured time: a benchmark, never a test.

Two sets of filters, each timed batched (B runs of K steps in one ``run`` call, ``keep_cov=False``, the papers'
timing setting) at a batch size where the compiled kernels, not the interpreter, dominate:

* **the ladder**: the KF, UKF, CKF, fifth-degree CKF, SSR-CKF and CDKF (weighted form) as single-model filters on a
  random dense linear n-state (n = 2, 4, ..., 12) with a dense 2 x n linear measurement;
* **the papers' filters**: the timed estimators of Zhu et al. 2016 (IMM5CKF, IMMCKF, IMMUKF, 5CKF), Hu et al. 2017
  (the five IMMs) and Liu & Wu 2017 (SSRCKF and the four strong-tracking filters) at their headline set-ups.

For each: the model's flops per run-step (``step_flops(estimator)["total"]``) and the CPU time per run-step (the
fastest of ``BENCH_COST_REPEATS`` repeats, ``time.thread_time``, garbage collector paused).  Reported, into
``data/bench/cost_model.json``: the least-squares time per flop through the origin and with an intercept (the
per-step overhead the flops do not see), R² of each, the relative residuals per filter, and for the papers' timing
claims the model's ratio beside the measured batched ratio.

Options (environment variables): ``BENCH_COST_REPEATS`` (default 5), ``BENCH_COST_STEPS`` (K, default 10),
``BENCH_COST_WORK`` (target flops per timed call, default 3e8: B = work / (flops K), clipped to 200..4000),
``BENCH_THREADS`` (default 1).  Run with ``python -m bench.cost_model`` or ``make bench``.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

if __name__ == "__main__":            # before numpy is imported (the BLAS reads its thread count when it loads)
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from bench.provenance import pin_threads
    pin_threads()

import gc                               # noqa: E402
import json                             # noqa: E402
import time                             # noqa: E402

import numpy as np                      # noqa: E402

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "data" / "bench"
LADDER_N = (2, 4, 6, 8, 10, 12)
LADDER_M = 2


def _env_int(name: str, default: int) -> int:
    v = os.environ.get(name, str(default)).strip()
    if not v.isdigit() or int(v) < 1:
        raise ValueError(f"{name}: expected a positive integer, got {v!r}")
    return int(v)


def _env_float(name: str, default: float) -> float:
    try:
        v = float(os.environ.get(name, str(default)))
    except ValueError:
        raise ValueError(f"{name}: expected a positive number, got {os.environ.get(name)!r}") from None
    if not v > 0:
        raise ValueError(f"{name}: expected a positive number, got {v!r}")
    return v


def time_per_step(estimator, init, z, repeats: int, measurement_models=None) -> dict:
    """CPU seconds per run-step of ``run(estimator, init, z, keep_cov=False)``: the fastest of ``repeats`` timed
    calls after one untimed call, and the median; ``z`` (B, K, m), or with per-step ``measurement_models`` a list of
    K arrays (B, m_k).  One thread's CPU time: the fused steps are held to this thread."""
    from mmlib.core import linalg
    with linalg.use_threads(1):
        return _time_per_step(estimator, init, z, repeats, measurement_models)


def _time_per_step(estimator, init, z, repeats: int, measurement_models) -> dict:
    from mmlib.core.estimation import run

    B = (z[0] if measurement_models is not None else z).shape[0]
    K = len(z) if measurement_models is not None else z.shape[1]
    run(estimator, init, z, keep_cov=False, measurement_models=measurement_models)
    times = []
    was = gc.isenabled()
    gc.disable()
    try:
        for _ in range(repeats):
            t0 = time.thread_time()
            run(estimator, init, z, keep_cov=False, measurement_models=measurement_models)
            times.append((time.thread_time() - t0) / (B * K))
    finally:
        if was:
            gc.enable()
    return {"best_s": min(times), "median_s": float(np.median(times)), "runs": B, "steps": K}


def _batch_size(flops: float, steps: int, work: float) -> int:
    return int(np.clip(work / (flops * steps), 200, 4000))


def ladder(steps: int, repeats: int, work: float) -> list:
    """The single-model filters on random dense linear models of n = 2..12 states."""
    from mmlib.core import cost, models
    from mmlib.core.estimation import SingleModel
    from mmlib.core.filters import KalmanFilter, SigmaPointFilter
    from mmlib.core.rules import CentralDifference, Cubature, FifthDegreeCubature, SphericalSimplexRadial, Unscented

    filters = {"KF": KalmanFilter(), "UKF": SigmaPointFilter(Unscented(1.0, 2.0, 0.0)),
               "CKF": SigmaPointFilter(Cubature()), "5CKF": SigmaPointFilter(FifthDegreeCubature()),
               "SSRCKF": SigmaPointFilter(SphericalSimplexRadial()),
               "CDKF": SigmaPointFilter(CentralDifference(form="weighted"))}
    out = []
    for n in LADDER_N:
        rng = np.random.default_rng(n)
        A = rng.standard_normal((n, n))
        F = np.linalg.qr(A)[0] * 0.98                       # stable, dense
        G = rng.standard_normal((n, n))
        Q = G @ G.T / n + 0.1 * np.eye(n)
        dyn = models.LinearGaussianDynamics(F, Q, np.linalg.cholesky(Q))
        meas = models.LinearMeasurement(rng.standard_normal((LADDER_M, n)), np.eye(LADDER_M))
        for name, filt in filters.items():
            est = SingleModel(filt, dyn, meas)
            flops = cost.step_flops(est)["total"]
            B = _batch_size(flops, steps, work)
            init = est.init(rng.standard_normal((B, n)), np.eye(n))
            z = rng.standard_normal((B, steps, LADDER_M))
            t = time_per_step(est, init, z, repeats)
            out.append({"group": "ladder", "filter": name, "n": n, "m": LADDER_M,
                        "points": filt.rule.num_points(n) if hasattr(filt, "rule") else 0, "flops": flops, **t})
            print(f"  ladder n={n:2d} {name:7s} {flops:9d} flops  {1e6 * t['best_s']:8.3f} us/run-step (B={B})",
                  flush=True)
    return out


def papers(steps: int, repeats: int, work: float) -> list:
    """The papers' timed estimators at their headline set-ups (the first ``steps`` steps of their batches)."""
    from mmlib.core import cost
    from mmlib.experiment.montecarlo import MonteCarlo
    from mmlib.papers import REGISTRY
    from mmlib.papers.hu2017 import text as hu_text
    from mmlib.papers.liu2017 import setup as liu_setup
    from mmlib.papers.liu2017 import text as liu_text
    from mmlib.papers.zhu2016 import text as zhu_text

    out = []
    jobs = []
    for key, names in (("zhu2016", zhu_text.RMSE_ALGORITHMS), ("hu2017", hu_text.ALGORITHMS)):
        paper = REGISTRY[key]
        jobs.append((key, paper.batch, paper.headline_setup(), names))
    liu = REGISTRY["liu2017"].headline_setup().example1
    jobs.append(("liu2017", lambda s, mc: liu_setup.make_batch_fn(s, mc, names=liu_text.FILTERS)[:2], liu,
                 liu_text.FILTERS))
    for key, batch, setup, names in jobs:
        probe_batch, estimators = batch(setup, MonteCarlo(0, 2))
        for name in names:
            est = estimators[name]
            flops = cost.step_flops(est)["total"]
            B = _batch_size(flops, steps, work)
            make_batch, ests = batch(setup, MonteCarlo(0, B))
            _, z, init = make_batch(range(B))
            z = np.asarray(z)[:, :steps]
            t = time_per_step(ests[name], init[name], z, repeats)
            out.append({"group": key, "filter": name, "flops": flops, **t})
            print(f"  {key} {name:12s} {flops:9d} flops  {1e6 * t['best_s']:8.3f} us/run-step (B={B})", flush=True)
    return out


def fit(points: list) -> dict:
    """Least-squares time per flop: ``t = a f`` (through the origin) and ``t = a f + b`` (b: the per-step overhead
    the flops do not count); R² of each (1 - residual / total sum of squares about the mean time) and the relative
    residuals ``(t - fit) / t`` per point (max |.| and root mean square)."""
    f = np.array([p["flops"] for p in points], float)
    t = np.array([p["best_s"] for p in points], float)
    ss_tot = float(((t - t.mean()) ** 2).sum())
    a0 = float(f @ t / (f @ f))
    r0 = t - a0 * f
    X = np.stack([f, np.ones_like(f)], axis=1)
    (a1, b1), *_ = np.linalg.lstsq(X, t, rcond=None)
    r1 = t - (a1 * f + b1)

    def summary(res, a, b=None):
        rel = res / t
        d = {"seconds_per_flop": a, "gflops_effective": 1e-9 / a if a > 0 else None,
             "r2": 1.0 - float((res ** 2).sum()) / ss_tot if ss_tot > 0 else None,
             "relative_residual_max": float(np.abs(rel).max()),
             "relative_residual_rms": float(np.sqrt((rel ** 2).mean()))}
        if b is not None:
            d["overhead_s_per_run_step"] = float(b)
        return d

    out = {"points": len(points), "through_origin": summary(r0, a0), "affine": summary(r1, float(a1), b1)}
    for p, ra, rb in zip(points, r0 / t, r1 / t):
        p["relative_residual_origin"] = float(ra)
        p["relative_residual_affine"] = float(rb)
    return out


def claim_ratios(points: list) -> list:
    """The papers' timing claims: the model's flop ratio beside the measured batched time ratio."""
    by = {(p["group"], p["filter"]): p for p in points}
    pairs = [("zhu2016", "IMM5CKF", "IMMCKF"), ("hu2017", "IMMEKF", "IMMCDKF"), ("hu2017", "IMMEKF", "IMMUKF"),
             ("hu2017", "IMMEKF", "IMMCKF"), ("hu2017", "IMMCDKF-OBS", "IMMCDKF"), ("liu2017", "STSSRCKF", "SSRCKF"),
             ("liu2017", "STF", "SSRCKF"), ("liu2017", "STUKF", "SSRCKF"), ("liu2017", "STCKF", "SSRCKF")]
    out = []
    for g, a, b in pairs:
        if (g, a) in by and (g, b) in by:
            out.append({"paper": g, "ratio": f"{a}/{b}", "model": by[(g, a)]["flops"] / by[(g, b)]["flops"],
                        "measured_batched": by[(g, a)]["best_s"] / by[(g, b)]["best_s"]})
    return out


def main(argv=None) -> int:
    from bench.provenance import provenance
    from mmlib.experiment.writing import atomic_write_text

    repeats = _env_int("BENCH_COST_REPEATS", 5)
    steps = _env_int("BENCH_COST_STEPS", 10)
    work = _env_float("BENCH_COST_WORK", 3e8)
    print("cost model vs measured time (CPU time per run-step, batched)", flush=True)
    lad = ladder(steps, repeats, work)
    pap = papers(steps, repeats, work)
    doc = {
        "what": "mmlib.core.cost.step_flops against measured CPU time per run-step, batched (keep_cov=False)",
        "method": f"fastest of {repeats} timed run() calls after one untimed, {steps} steps, B runs chosen so that "
                  f"a call does about {work:.0e} flops (200..4000 runs); least squares over the points",
        "fit_ladder": fit(lad), "fit_papers": fit(pap), "fit_all": fit(lad + pap),
        "claim_ratios": claim_ratios(pap),
        "ladder": lad, "papers": pap,
        "provenance": provenance(),
    }
    OUT.mkdir(parents=True, exist_ok=True)
    atomic_write_text(OUT / "cost_model.json", json.dumps(doc, indent=1) + "\n")
    for k in ("fit_ladder", "fit_papers", "fit_all"):
        print(k, json.dumps(doc[k]), flush=True)
    for c in doc["claim_ratios"]:
        print(f"  {c['paper']} {c['ratio']}: model {c['model']:.2f}x, measured {c['measured_batched']:.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
