"""The benchmark report of ``make bench`` (``bench/imm_ukf.py``): timings are a report, never a test.

Modules: :mod:`bench.job` (the job, its models and targets), :mod:`bench.imm_ukf` (the FilterPy comparison, the
entry point), :mod:`bench.scaling` (the runs-scaling curve, one subprocess per size, and its figure),
:mod:`bench.flops` (the flop count of one IMM-UKF run-step and this core's peak rate), :mod:`bench.notebooks` (the
committed notebooks' wall times) and :mod:`bench.provenance` (what every output records).  Nothing here imports numpy
at import time of the package, so that the entry point can pin the thread counts before numpy loads.
"""
