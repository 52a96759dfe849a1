"""Scaling curve of the benchmark job in mmlib: time per run-step and peak memory for N = 10 ... 100,000
Monte Carlo runs, each size in a fresh process so that its peak resident memory is its own (the
child's ``VmHWM``, see :func:`_rss_mib` for why not ``ru_maxrss``), the runs chunked as
:func:`bench.job.mmlib_run` does (2000 a call); with the flop floor of :mod:`bench.flops`.

One throwaway child runs first (it compiles mmlib's numba kernels if their on-disk cache is stale,
so that no point pays for the compiler's memory).  Each child (``python -m bench.scaling --child N``)
records its peak resident memory after importing numpy, after importing mmlib, and after 10 runs of
5 steps run untimed (imports, compiled kernels: the *baseline*), then runs the job: 3 times for
N <= 1000 (median), once above.  The estimates of every run are kept, as the job keeps them:
``N x 100 x 4`` doubles (3.2 MB per 1000 runs), reported apart as ``estimates_mib``.
"""
from __future__ import annotations

import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
SIZES = (10, 100, 1_000, 10_000, 100_000)


def _rss_mib() -> float:
    """Peak resident memory of this process since it started (MiB): ``VmHWM`` of ``/proc/self/status``.

    Not ``getrusage(RUSAGE_SELF).ru_maxrss``: on Linux that carries over, across ``exec``, the high-water mark
    of the process that spawned the child (the forked copy of the benchmark's parent, large after the FilterPy
    runs), so every size would report at least the parent's peak.  ``ru_maxrss`` is the fallback
    where ``/proc`` is missing (and recorded beside it)."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0                     # kB
    except OSError:
        pass
    return _ru_maxrss_mib()


def _ru_maxrss_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0      # Linux: KiB


def child(n_runs: int) -> dict:
    """One size of the curve, in this (fresh) process."""
    import numpy  # noqa: F401
    after_numpy = _rss_mib()
    import mmlib  # noqa: F401
    after_mmlib = _rss_mib()
    from bench.job import CHUNK, K, N_STATE, mmlib_run

    mmlib_run(10, 5)
    baseline = _rss_mib()
    repeats = 3 if n_runs <= 1000 else 1
    seconds, cpus, walls = [], [], []
    for _ in range(repeats):
        est = None
        t0 = time.perf_counter()
        est = mmlib_run(n_runs)
        walls.append(time.perf_counter() - t0)
        seconds.append(est.seconds)
        cpus.append(est.cpu_seconds)
    peak = _rss_mib()
    filter_s = statistics.median(seconds)
    return {"runs": n_runs, "steps": K, "chunk": CHUNK, "repeats": repeats,
            "filter_seconds": filter_s, "filter_seconds_all": seconds, "filter_cpu_seconds_all": cpus,
            "with_simulation_seconds": statistics.median(walls),
            "us_per_run_step": filter_s / (n_runs * K) * 1e6,
            "peak_rss_mib": peak, "baseline_rss_mib": baseline,
            "rss_after_import_numpy_mib": after_numpy, "rss_after_import_mmlib_mib": after_mmlib,
            "ru_maxrss_mib": _ru_maxrss_mib(),
            "estimates_mib": n_runs * K * N_STATE * 8 / 2 ** 20}


def run_child(n_runs: int, env: dict | None = None) -> dict:
    """:func:`child` in a subprocess (the environment, thread settings included, is inherited; ``env`` is added)."""
    out = subprocess.run([sys.executable, "-m", "bench.scaling", "--child", str(n_runs)], cwd=REPO,
                         capture_output=True, text=True, env={**os.environ, **(env or {})})
    if out.returncode:
        raise RuntimeError(f"scaling child for {n_runs} runs failed:\n{out.stderr[-4000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def scaling_report(sizes=SIZES, say=print) -> dict:
    """The curve over ``sizes`` with the flop count, this core's peak rate and each point's ratio to the floor."""
    from bench.flops import imm_ukf_flops, peak_gflops
    from bench.job import JOB, N_MEAS, N_MODES, N_STATE

    flops = imm_ukf_flops(N_STATE, N_MEAS, N_MODES)
    peak = peak_gflops()
    floor_us = flops["total"] / (peak["gflops"] * 1e9) * 1e6
    say(f"  flops per run-step {flops['total']}; peak {peak['gflops']:.1f} GFLOP/s; floor {floor_us:.4f} us")
    t0 = time.perf_counter()
    run_child(10)
    say(f"  warm-up process (compiles mmlib's kernels if their cache is stale): {time.perf_counter() - t0:.0f} s")
    points = []
    for n in sizes:
        t0 = time.perf_counter()
        p = run_child(n)
        p["ratio_to_floor"] = p["us_per_run_step"] / floor_us
        p["process_seconds"] = time.perf_counter() - t0
        points.append(p)
        say(f"  {n:>7} runs: {p['us_per_run_step']:8.3f} us per run-step ({p['ratio_to_floor']:.0f}x floor), "
            f"filter {p['filter_seconds']:.2f} s, peak RSS {p['peak_rss_mib']:.0f} MiB "
            f"(baseline {p['baseline_rss_mib']:.0f}, estimates {p['estimates_mib']:.1f}); "
            f"process {p['process_seconds']:.0f} s")
    large = [p for p in points if p["runs"] >= 10_000]
    from mmlib.core._env import usable_cores
    cores = usable_cores()
    every_core = None
    if cores > 1 and 10_000 in sizes:
        # the same job on every core: the fused steps split their blocks of runs over MMLIB_THREADS threads (BLAS
        # stays pinned); the points above use BENCH_THREADS (default 1)
        every_core = run_child(10_000, {"MMLIB_THREADS": str(cores)})
        every_core["threads"] = cores
        every_core["speedup_over_pinned"] = next(p for p in points if p["runs"] == 10_000)["filter_seconds"] \
            / every_core["filter_seconds"]
        say(f"   10000 runs on {cores} threads: filter {every_core['filter_seconds']:.2f} s "
            f"({every_core['speedup_over_pinned']:.2f}x the point at BENCH_THREADS), "
            f"peak RSS {every_core['peak_rss_mib']:.0f} MiB")
    return {
        "job": JOB, "what": "mmlib, time per run-step and peak resident memory against the number of runs; one "
                            "process per size (a fresh interpreter: peak RSS includes the imports)",
        "points": points,
        "every_core_10000_runs": every_core,
        "every_core_note": "10,000 runs with the fused steps' blocks split over every core this process may use "
                           "(MMLIB_THREADS; BLAS pinned as for the points); the same bits as one thread "
                           "(tests/test_fused.py); speedup_over_pinned: the 10,000-run point's filter time over "
                           "this one's",
        "flops_per_run_step": flops,
        "flops_convention": "bench/flops.py: the equations of mmlib's IMM-UKF evaluated densely, unscented points "
                            "as mean +/- scaled Cholesky columns; +,-,*,/, comparisons, sqrt, floor, log, exp, "
                            "atan2 one flop each; checks and diagnostics (symmetrisation, posterior Cholesky "
                            "test, mixture innovation) not counted",
        "peak": peak,
        "floor_us_per_run_step": floor_us,
        "large_n_cost_ratio": (large[-1]["us_per_run_step"] / large[0]["us_per_run_step"]) if len(large) > 1 else None,
        "large_n_cost_ratio_note": "us per run-step at the largest size over that at 10,000 runs (1 = constant "
                                   "per-run-step cost)",
    }


def figure(doc: dict, out_dir: Path) -> list:
    """``scaling.png``: time per run-step (log-log) with the flop floor and the target, peak memory below."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bench.job import K, TARGETS
    from mmlib.experiment.writing import save_figure

    pts = doc["points"]
    runs = [p["runs"] for p in pts]
    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(7.5, 7.5), height_ratios=(3, 2))
    ax1.loglog(runs, [p["us_per_run_step"] for p in pts], "o-", color="C0", label="mmlib (batched, chunks of 2000)")
    for p in pts:
        ax1.annotate(f"{p['ratio_to_floor']:.0f}× floor", (p["runs"], p["us_per_run_step"]),
                     textcoords="offset points", xytext=(0, 7), ha="center", fontsize=8)
    every = doc.get("every_core_10000_runs")
    if every:
        ax1.loglog([every["runs"]], [every["us_per_run_step"]], "D", color="C1", ms=6,
                   label=f"mmlib, 10,000 runs on {every['threads']} threads (every core; wall time, against a "
                         f"floor of one core)")
    if doc.get("filterpy_us_per_run_step"):
        ax1.axhline(doc["filterpy_us_per_run_step"], color="C3", ls="-.", lw=1,
                    label=f"FilterPy 2.0, one run at a time ({doc['filterpy_us_per_run_step']:.0f} µs, 100 runs)")
    target_us = TARGETS["10000_runs_max_s"] / (10_000 * K) * 1e6
    ax1.axhline(target_us, color="C2", ls=":", lw=1.2,
                label=f"target: 10,000 runs ≤ {TARGETS['10000_runs_max_s']:g} s ({target_us:g} µs per run-step)")
    f = doc["flops_per_run_step"]["total"]
    ax1.axhline(doc["floor_us_per_run_step"], color="k", ls="--", lw=1,
                label=f"flop floor: {f} flops / {doc['peak']['gflops']:.0f} GFLOP/s = "
                      f"{doc['floor_us_per_run_step'] * 1e3:.0f} ns")
    ax1.axhline(doc["floor_us_per_run_step"] * TARGETS["floor_ratio_max"], color="k", ls=":", lw=1,
                label=f"target: ≤ {TARGETS['floor_ratio_max']:g}× the floor at 10,000 runs")
    ax1.set_ylabel("time per run-step (µs, log scale)")
    ax1.grid(True, which="both", alpha=0.3)
    top = max([p["us_per_run_step"] for p in pts] + [doc.get("filterpy_us_per_run_step") or 0])
    ax1.set_ylim(doc["floor_us_per_run_step"] / 2, top * 4)
    ax1.legend(fontsize=8, loc="upper right", bbox_to_anchor=(1.0, 0.85))
    ax2.semilogx(runs, [p["peak_rss_mib"] for p in pts], "o-", color="C0", label="peak resident memory of the process")
    ax2.semilogx(runs, [p["baseline_rss_mib"] for p in pts], "s--", color="C7", ms=4,
                 label="after imports and warm-up (baseline)")
    ax2.semilogx(runs, [p["baseline_rss_mib"] + p["estimates_mib"] for p in pts], ":", color="C1",
                 label="baseline + the kept estimates (N × 100 × 4 doubles)")
    ax2.axhline(TARGETS["peak_memory_max_mib"], color="C2", ls=":", lw=1.2,
                label=f"target at 10,000 runs: ≤ {TARGETS['peak_memory_max_mib']} MiB")
    ax2.set_ylabel("peak memory (MiB)")
    ax2.set_xlabel("Monte Carlo runs N (log scale)")
    ax2.set_ylim(0, 1.6 * max([p["peak_rss_mib"] for p in pts] + [TARGETS["peak_memory_max_mib"]]))
    ax2.grid(True, which="both", alpha=0.3)
    ax2.legend(fontsize=8, loc="upper left")
    th = doc.get("threads", {})
    mach = doc.get("machine", {})
    fig.suptitle(f"{doc['job']}\nmmlib ({doc.get('mmlib_kernel')} kernels), {th.get('OPENBLAS_NUM_THREADS')} thread; "
                 f"{mach.get('cpu')}, {mach.get('cpu_count')} cores; {doc.get('date', '')[:10]}", fontsize=9)
    fig.tight_layout()
    written = save_figure(fig, out_dir, "scaling", formats=("png",))
    plt.close(fig)
    return written


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--child":
        if os.environ.get("OPENBLAS_NUM_THREADS") is None:
            print("warning: thread counts not pinned (run through bench/imm_ukf.py)", file=sys.stderr)
        print(json.dumps(child(int(sys.argv[2]))))
    else:
        sys.exit("usage: python -m bench.scaling --child N   (the curve is run by bench/imm_ukf.py)")
