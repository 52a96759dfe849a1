#!/usr/bin/env python
"""Benchmark: IMM-UKF (CV + two coordinated-turn modes, range-bearing radar, 100 steps)
over 100 Monte Carlo runs in mmlib (batched) and in FilterPy (one run at a time), on
identical measurements; checks that the estimates agree; times 10,000 runs in mmlib
(chunked) with its peak memory.  Writes data/bench/imm_ukf.json.

Not a timed test: timings depend on the machine; run it with `make bench`.
"""
from __future__ import annotations

import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import mmlib
from mmlib import models
from mmlib.simulate import ManeuverSchedule, simulate

REPO = Path(__file__).resolve().parent.parent
T, K = 1.0, 100
OMEGA = np.radians(3.0)
SEED = 2024


def problem(n_runs):
    dyn = [models.constant_velocity(T, 1.0), models.coordinated_turn(T, OMEGA, 1.0),
           models.coordinated_turn(T, -OMEGA, 1.0)]
    radar = models.RangeBearing(np.diag([100.0, np.radians(0.5) ** 2]))
    sched = ManeuverSchedule(dyn, [(30, 50, 1), (70, 85, 2)], 0, T, K)
    mc = mmlib.MonteCarlo(SEED, n_runs)
    x0 = np.array([20000.0, -150.0, 15000.0, 60.0])
    P0 = np.diag([400.0, 100.0, 400.0, 100.0])
    transition = np.array([[0.90, 0.05, 0.05], [0.10, 0.85, 0.05], [0.10, 0.05, 0.85]])
    return dyn, radar, sched, mc, x0, P0, transition


def mmlib_run(n_runs, chunk=2000):
    dyn, radar, sched, mc, x0, P0, transition = problem(n_runs)
    imm = mmlib.IMM(mmlib.SigmaPointFilter(mmlib.Unscented(1.0, 2.0, 0.0)), dyn, radar, transition)
    means, elapsed = [], 0.0
    for runs in mc.chunks(chunk):
        z = simulate(sched, x0, radar, mc, runs).measurements
        t0 = time.perf_counter()
        track = mmlib.run(imm, imm.init(np.tile(x0, (len(runs), 1)), P0), z, keep_cov=False)
        elapsed += time.perf_counter() - t0
        means.append(track.mean)
    return np.concatenate(means), elapsed


def filterpy_run(z_all, x0, P0, dyn, radar, transition):
    from mmlib.crosscheck import filterpy_imm_ukf

    out = np.empty(z_all.shape[:2] + (4,))
    t0 = time.perf_counter()
    for b, zs in enumerate(z_all):
        imm = filterpy_imm_ukf(dyn, radar, x0, P0, transition, alpha=1.0, beta=2.0, kappa=0.0)
        for k, z in enumerate(zs):
            imm.predict()
            imm.update(z)
            out[b, k] = imm.x
    return out, time.perf_counter() - t0


def main():
    repeats = int(os.environ.get("BENCH_REPEATS", "3"))
    if len(sys.argv) > 1 and sys.argv[1] == "--large":      # child process: 10,000 runs, report time
        _, elapsed = mmlib_run(10_000)
        print(json.dumps({"seconds": elapsed}))
        return
    dyn, radar, sched, mc, x0, P0, transition = problem(100)
    z = simulate(sched, x0, radar, mc, range(100)).measurements
    ours, fp = [], []
    for _ in range(repeats):
        est, dt = mmlib_run(100)
        ours.append(dt)
        print(f"mmlib   100 runs: {dt * 1e3:8.1f} ms", flush=True)
    for _ in range(repeats):
        ref, dt = filterpy_run(z, x0, P0, dyn, radar, transition)
        fp.append(dt)
        print(f"FilterPy 100 runs: {dt * 1e3:8.1f} ms", flush=True)
    diff = float(np.max(np.abs(est - ref)))
    agree = diff < 1e-6 * float(np.max(np.abs(ref)))     # round-off scale on positions ~2e4 m
    child = subprocess.run([sys.executable, __file__, "--large"], capture_output=True, text=True, check=True)
    large = json.loads(child.stdout)
    peak_mib = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
    doc = {
        "job": "IMM-UKF, CV + 2 coordinated turns, range-bearing radar, 100 steps",
        "runs": 100, "repeats": repeats,
        "mmlib_median_s": statistics.median(ours), "filterpy_median_s": statistics.median(fp),
        "speedup_median": statistics.median(fp) / statistics.median(ours),
        "max_abs_estimate_difference": diff, "estimates_agree": bool(agree),
        "mmlib_10000_runs_s": large["seconds"], "mmlib_10000_runs_peak_rss_mib": peak_mib,
        "targets": {"speedup_min": 150, "10000_runs_max_s": 10, "peak_memory_max_mib": 1024},
        "machine": {"python": platform.python_version(), "cpu_count": os.cpu_count(), "platform": platform.platform(),
                    "numpy": np.__version__},
    }
    out = REPO / "data" / "bench" / "imm_ukf.json"
    mmlib.report.atomic_write_text(out, json.dumps(doc, indent=1) + "\n")
    print(json.dumps(doc, indent=1))
    if not agree:
        print(f"ERROR: mmlib and FilterPy estimates differ by {diff}", file=sys.stderr)
        sys.exit(1)


if __name__ == "__main__":
    main()
