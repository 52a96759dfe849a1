r"""The flop floor of the benchmark job: the floating-point operations of one IMM-UKF run-step,
counted analytically (:func:`imm_ukf_flops`, the library's one counting, :mod:`mmlib.core.cost`), and this
core's peak double-precision rate (:func:`peak_gflops`).  ``floor = flops / peak`` is the time one run-step
would take if every operation ran at the rate of a large matrix product; ``measured / floor`` says how far the
implementation is from the arithmetic.

**What is counted.**  The arithmetic of the equations mmlib implements for this job (the
docstrings of :mod:`mmlib.core.estimation` and :mod:`mmlib.core.filters`), in mmlib's formulation -- the
positive-semi-definite moment combination of the mixing, the Cholesky-factor form of the Kalman
update, the angle-aware mean of range-bearing predictions -- evaluated *densely*, each matrix
expression as a dense product of its full operands (no use of the zeros of ``F``, of the
triangular factors, nor of the symmetry of covariances).  The only structure used is the one that
defines the unscented points: :math:`X_0 = \hat x`, :math:`X_{\pm i} = \hat x \pm c L_{:,i}`
(``n^2`` products and ``2n^2`` sums, not a product by the unit points).  The fused covariance is
not counted: the job runs ``keep_cov=False``.

**Not counted** (mmlib does them every step; they are checks and diagnostics, not the recursion):
the symmetrisations :math:`(A + A^T)/2`, the Cholesky test of every posterior covariance, the
finiteness tests, the mixture innovation and its covariance, the marginal log-likelihood.

**Conventions.**  One flop = one ``+ - * /``, one comparison (the maximum of the mode
log-posteriors), one ``sqrt``, ``floor``, ``log``, ``exp`` or ``atan2``.  Transcendental functions
cost tens of cycles; counting them as one keeps the floor a floor.  A dot product of length k is
``2k - 1`` flops (k products, k - 1 sums).  ``p = 2n + 1`` unscented points.  Negation is free.

``tests/test_bench.py`` checks every term against a direct operation count of a scalar
implementation of the same algorithm (whose numbers it checks against mmlib), for this job and
for small instances.
"""
from __future__ import annotations

import time

from mmlib.core.cost import (RANGE_BEARING_H_FLOPS, WRAP_FLOPS, FunctionCosts, cholesky_flops,  # noqa: F401
                             dot, filter_flops, imm_flops, tril_inverse_flops)


def imm_ukf_flops(n: int = 4, m: int = 2, r: int = 3, *, h_flops: int = RANGE_BEARING_H_FLOPS,
                  angles: int = 1) -> dict:
    """Flops of one run-step of an IMM of ``r`` unscented Kalman filters (``p = 2n + 1`` points) with
    linear mode dynamics on an ``n``-state and an ``m``-dimensional measurement; ``h_flops`` per point
    for the measurement function (7 for range-bearing, ``m (2n - 1)`` for a dense linear ``H x``) and
    ``angles`` wrapped components (1 for range-bearing: its residuals wrap the bearing, and its mean
    of predicted measurements is taken relative to the first point; 0: plain differences and mean).

    Returns ``{term: flops}`` in the order of the algorithm, with ``"total"`` last: the counting of
    :mod:`mmlib.core.cost` (:func:`~mmlib.core.cost.filter_flops` of the UKF,
    :func:`~mmlib.core.cost.imm_flops` with moment mixing, no fused covariance).  The defaults are the
    benchmark job: n = 4, m = 2, r = 3, 9 points.
    """
    for name, v in (("n", n), ("m", m), ("r", r)):
        if not isinstance(v, int) or v < 1:
            raise ValueError(f"{name}: expected a positive integer, got {v!r}")
    from mmlib.core.filters import SigmaPointFilter
    from mmlib.core.rules import Unscented

    functions = FunctionCosts(f=n * dot(n), f_jacobian=0, h=h_flops, h_jacobian=0, angles=angles)
    mode = filter_flops(SigmaPointFilter(Unscented(1.0, 2.0, 0.0)), n, m, functions)
    return imm_flops(mode, n, r)


def peak_gflops(size: int = 2000, repeats: int = 10) -> dict:
    """This core's achievable double-precision rate: ``size x size`` matrix products (``2 size^3`` flops each,
    after one untimed product) with the BLAS thread count in force (the benchmark pins it to one thread
    before numpy loads).  ``gflops``: the best of ``repeats`` per second of the process's CPU time, the rate
    of the core while the process runs (insensitive to waiting for a core on a busy machine; single-threaded,
    CPU time <= wall time); ``gflops_wall``: the best per second of wall time."""
    import numpy as np

    rng = np.random.default_rng(0)
    a, b = rng.standard_normal((size, size)), rng.standard_normal((size, size))
    a @ b
    walls, cpus = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        a @ b
        walls.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
    flops = 2.0 * size ** 3
    return {"method": f"numpy matmul, {size}x{size} float64, best of {repeats} after one warm-up, per CPU second",
            "gflops": flops / min(cpus) / 1e9, "gflops_wall": flops / min(walls) / 1e9,
            "gflops_wall_median": flops / sorted(walls)[len(walls) // 2] / 1e9}
