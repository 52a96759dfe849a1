r"""The flop floor of the benchmark job: the floating-point operations of one IMM-UKF run-step,
counted analytically (:func:`imm_ukf_flops`), and this core's peak double-precision rate
(:func:`peak_gflops`).  ``floor = flops / peak`` is the time one run-step would take if every
operation ran at the rate of a large matrix product; ``measured / floor`` says how far the
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

#: Range-bearing measurement of one point: two differences to the sensor, a hypotenuse
#: (2 products, 1 sum, 1 sqrt) and one atan2.
RANGE_BEARING_H_FLOPS = 7

#: Wrapping one angle to (-pi, pi]: ``a + 2 pi floor((pi - a) / 2 pi)`` (mmlib.core.models.wrap_angle).
WRAP_FLOPS = 5


def dot(k: int) -> int:
    """Flops of a dot product of length ``k``: ``k`` products and ``k - 1`` sums."""
    return 2 * k - 1


def cholesky_flops(n: int) -> int:
    r"""Cholesky factor of an ``n x n`` matrix (column by column, LAPACK's ``potf2``): column j costs
    ``2j`` for its pivot (j squares subtracted), one ``sqrt``, and ``2j + 1`` for each of its ``n - 1 - j``
    entries below (j products subtracted, one division): :math:`\sum_j [2j + 1 + (n-1-j)(2j+1)]
    = n(n+1)(2n+1)/6` (30 for n = 4, 5 for n = 2)."""
    return n * (n + 1) * (2 * n + 1) // 6


def tril_inverse_flops(m: int) -> int:
    r"""Inverse of an ``m x m`` lower-triangular factor by forward substitution (mmlib.core.linalg.tril_inverse):
    ``m`` reciprocals of the diagonal, and for entry (i, j), i > j, ``i - j`` products, ``i - j - 1`` sums
    and one product by the reciprocal: :math:`m + \sum_{i>j} 2(i-j) = m + (m^3 - m)/3`."""
    return m + (m ** 3 - m) // 3


def imm_ukf_flops(n: int = 4, m: int = 2, r: int = 3, *, h_flops: int = RANGE_BEARING_H_FLOPS,
                  angles: int = 1) -> dict:
    """Flops of one run-step of an IMM of ``r`` unscented Kalman filters (``p = 2n + 1`` points) with
    linear mode dynamics on an ``n``-state and an ``m``-dimensional measurement; ``h_flops`` per point
    for the measurement function (7 for range-bearing, ``m (2n - 1)`` for a dense linear ``H x``) and
    ``angles`` wrapped components (1 for range-bearing: its residuals wrap the bearing, and its mean
    of predicted measurements is taken relative to the first point; 0: plain differences and mean).

    Returns ``{term: flops}`` in the order of the algorithm, with ``"total"`` last.  The defaults are the
    benchmark job: n = 4, m = 2, r = 3, 9 points.
    """
    for name, v in (("n", n), ("m", m), ("r", r)):
        if not isinstance(v, int) or v < 1:
            raise ValueError(f"{name}: expected a positive integer, got {v!r}")
    p = 2 * n + 1
    residual = m + WRAP_FLOPS * angles                       # z_a - z_b, bearing wrapped
    if angles:                                               # ref + sum_i w_i (Z_i - ref), ref = Z_0, wrapped
        average = p * residual + m * dot(p) + m + WRAP_FLOPS * angles
    else:                                                    # sum_i w_i Z_i
        average = m * dot(p)
    terms = {
        # 1. c_j = sum_i p_ij mu_i and mu_i|j = p_ij mu_i / c_j, with the products p_ij mu_i shared
        "mixing weights": r * r + r * (r - 1) + r * r,
        # 2. x0_j = sum_i mu_i|j x_i
        "mixed means": r * n * dot(r),
        # 3. P0_j = sum_i mu_i|j P_i + sum_i (mu_i|j d_ji) d_ji^T, d_ji = x_i - x0_j
        #    (mmlib.core.estimation.combine_covariances)
        "mixed covariances": r * r * n + r * r * n + 2 * r * n * n * dot(r) + r * n * n,
        # 4.-7. time update of each mode: factor, points, transition F X_i, mean and covariance (+ Q)
        "predict: Cholesky": r * cholesky_flops(n),
        "predict: sigma points": r * 3 * n * n,
        "predict: transition": r * p * n * dot(n),
        "predict: moments": r * (n * dot(p) + 2 * p * n + n * n * dot(p) + n * n),
        # 8.-11. measurement prediction of each mode: fresh points from P-, h, mean, S (+ R) and Pxz
        "measurement prediction: Cholesky": r * cholesky_flops(n),
        "measurement prediction: sigma points": r * 3 * n * n,
        "measurement prediction: h": r * p * h_flops,
        "measurement prediction: moments": r * (average + p * residual + p * n + p * m
                                                + m * m * dot(p) + n * m * dot(p) + m * m),
        # 12. Kalman update of each mode (mmlib.core.filters.kalman_update): nu, S = L L^T, L^-1, A = Pxz L^-T,
        #     e = L^-1 nu, x + A e, P - A A^T, NIS e^T e, log-likelihood -(NIS + 2 sum log L_ii + m log 2 pi)/2
        "update": r * (residual + cholesky_flops(m) + tril_inverse_flops(m) + n * m * dot(m) + m * dot(m)
                       + n * dot(m) + n + n * n * dot(m) + n * n + dot(m) + (m + (m - 1) + 1) + 3),
        # 13. mu_j = exp(log L_j + log c_j - max) / sum: r logs, r sums, r - 1 comparisons, r differences,
        #     r exps, r - 1 sums, r divisions
        "mode probabilities": r + r + (r - 1) + r + r + (r - 1) + r,
        # 14. fused mean sum_j mu_j x_j (the fused covariance is not computed: keep_cov=False)
        "combination": n * dot(r),
    }
    terms["total"] = sum(terms.values())
    return terms


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
