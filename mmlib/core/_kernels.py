r"""Compiled (numba) kernels of :mod:`mmlib.core.linalg`: the same mathematics as its numpy reference
path, fused into one loop nest per filter operation, and whole filter steps made of those loop nests.

Why: the filters spend their time in many small operations on ``(B, r, n, n)`` stacks (n = 2..9).
numpy pays a dispatch per operation far larger than its arithmetic; a plain compiled loop per run
is no better, because each run's sums are chains of dependent additions (latency bound).  Here every
kernel copies its operands into a **batch-innermost** layout ``(n, n, N)`` (:func:`_inner`, back with
:func:`_outer`) and runs each scalar operation of the algorithm as a loop over the N runs: independent
lanes that LLVM turns into SIMD instructions, with no temporaries and one call per filter operation.  Each
operation's loop nest is a ``_*_core`` function on batch-innermost operands; the public kernel wraps it in the
layout changes, and the *fused steps* (:func:`sigma_step`, :func:`imm_sigma_step`, :func:`strong_tracking_step`) chain
the same cores for a block of runs at a time, so a whole filter, IMM or strong-tracking step is one call with one
layout change of the state, and gives the bits of the composed operations.  The *whole runs* (:func:`sigma_run`,
:func:`imm_sigma_run`, :func:`strong_tracking_run`) chain those steps over every measurement step of a run, the state
kept batch innermost from step to step: a run is one call, with the bits of its steps.

Conventions shared with the numpy path (:mod:`mmlib.core.linalg`), and tested against it
(``tests/test_kernels.py``):

* the public kernels take and return stacks with the run axis first, ``(N, ...)``, C-contiguous
  (the compiled twins in :mod:`mmlib.core.linalg` broadcast and flatten leading axes);
* a Cholesky factor is LAPACK ``potf2``'s: only the lower triangle is read; a matrix fails when a pivot
  is not > 0 (NaN included) or not finite; a failed run's outputs are NaN and it is reported, never
  patched;
* **batch-size independence**: a run's numbers are computed from its own operands by the same
  sequence of IEEE operations whatever N (SIMD lanes and the scalar remainder execute the same
  additions, multiplications, divisions and square roots, each correctly rounded); there is no
  ``fastmath``, so LLVM neither reassociates sums nor contracts ``a*b + c`` into a fused multiply-add,
  and the bits do not depend on the machine's instruction set (the explicit fused multiply-adds of :func:`_fma`,
  which reproduce the order of the BLAS products of the composed layers, are exactly rounded with or without the
  instruction); the log is the C library's scalar one
  (numba vectorises it only with Intel's SVML, which the lock file does not install, and ``tests/test_fused.py``
  checks that it is not in use); range and bearing are :mod:`mmlib.core._elementary`'s, made of the four operations
  and the square root (the same bits as the numpy path's, in SIMD lanes or not, the C library's ``hypot`` and
  ``atan2`` only for operands outside their regular range);
* the two paths agree to round-off, not bit for bit (BLAS and LAPACK sum in other orders;
  ``tests/test_kernels.py`` states the bounds), except the operations whose compiled twin sums as OpenBLAS does on
  the reference machine (:func:`gram`, :func:`psd_part`, :func:`cubature_mix`, :func:`jacobian_fading_factor`:
  bit for bit there for the shapes the papers use, so that the composed layers' committed numbers keep their bits).

Nothing here is called directly: each public kernel is the compiled twin of one operation of
:mod:`mmlib.core.linalg`, declared there next to its numpy body, and which of the two runs is decided there
once (:func:`mmlib.core.linalg.kernel`; ``MMLIB_KERNEL=numpy`` selects the reference path).  The fused steps have
no numpy twin: their reference is the composition of the operations, which the estimators of
:mod:`mmlib.core.estimation` run instead wherever a fused step does not apply or is turned off
(:func:`mmlib.core.linalg.fused`).
"""
from __future__ import annotations

import math

import numpy as np
from llvmlite import ir as _ir
from numba import njit, types as _types
from numba.extending import intrinsic

from mmlib.core._elementary import (P0, P1, P2, P3, P4, Q0, Q1, Q2, Q3, Q4, QPI1_HI, QPI1_LO, QPI2_HI, QPI2_LO,
                                    QPI3_HI, QPI3_LO, QPI4_HI, QPI4_LO, REDUCE_ABOVE, REGULAR_MAX, REGULAR_MIN)

_OPTS = dict(cache=True, nogil=True, error_model="numpy")
_TWO_PI = 2.0 * math.pi


# --------------------------------------------------------------------------- fused multiply-add
@intrinsic
def _fma(typingctx, a, b, c):
    """:math:`ab + c` rounded once (LLVM's ``llvm.fma``: the FMA instruction, or the C library's ``fma`` on a CPU
    without one, the same bits).  Only in the compiled twins of the composed layers' BLAS products
    (:func:`_gram_core`, :func:`_psd_part_lane`, :func:`_jacobian_fading`, :func:`_cubature_points_core`)."""
    sig = _types.float64(_types.float64, _types.float64, _types.float64)

    def codegen(context, builder, signature, args):
        d = _ir.DoubleType()
        fn = builder.module.declare_intrinsic("llvm.fma", [d], _ir.FunctionType(d, [d, d, d]))
        return builder.call(fn, args)
    return sig, codegen


# --------------------------------------------------------------------------- layout helpers
@njit(**_OPTS)
def _inner(a, N):
    """(P, ...) -> (..., N): the run axis moved innermost, run b taking ``a[b % P]`` (P divides N: an operand
    shared by the runs, or periodic over the flattened (runs, modes) axes, e.g. one Q per mode).  ``a``
    C-contiguous, any number of axes."""
    P = a.shape[0]
    flat = a.reshape((P, a.size // P))
    k = flat.shape[1]
    out = np.empty((k, N))
    if P == N:                      # (the common case: no modulo, writes contiguous along the runs)
        for i in range(k):
            for b in range(N):
                out[i, b] = flat[b, i]
    else:
        for b in range(N):
            src = b % P
            for i in range(k):
                out[i, b] = flat[src, i]
    return out.reshape(a.shape[1:] + (N,))


@njit(**_OPTS)
def _outer(a):
    """(..., N) -> (N, ...): the run axis (innermost, N runs) moved back to the front; ``a`` C-contiguous."""
    N = a.shape[-1]
    flat = a.reshape((a.size // N, N))
    k = flat.shape[0]
    out = np.empty((N, k))
    for i in range(k):
        for b in range(N):
            out[b, i] = flat[i, b]
    return out.reshape((N,) + a.shape[:-1])


@njit(**_OPTS)
def _nan_rows(a, failed):
    """Every entry of ``a[b]`` NaN for the runs b with ``failed[b]`` (run axis first)."""
    for b in range(a.shape[0]):
        if failed[b]:
            a[b] = np.nan


# --------------------------------------------------------------------------- batch-innermost building blocks
@njit(**_OPTS)
def _chol(A, L, bad):
    r"""Lower Cholesky factors, batch innermost: A (n, n, N) -> L (n, n, N) (upper triangle 0);
    ``bad[b]`` is set when a pivot of run b is not > 0 or not finite (its factor is then NaN or garbage,
    to be replaced by NaN by the caller).  Reads the lower triangle of A only (LAPACK ``potf2`` order)."""
    n, N = A.shape[0], A.shape[2]
    s = np.empty(N)
    for j in range(n):
        for i in range(j):
            L[i, j, :] = 0.0
        for b in range(N):
            s[b] = A[j, j, b]
        for k in range(j):
            for b in range(N):
                s[b] -= L[j, k, b] * L[j, k, b]
        for b in range(N):
            ok = s[b] > 0.0 and s[b] < np.inf
            bad[b] = bad[b] or not ok
            s[b] = math.sqrt(s[b]) if ok else np.nan
            L[j, j, b] = s[b]
        for i in range(j + 1, n):
            for b in range(N):
                L[i, j, b] = A[i, j, b]
            for k in range(j):
                for b in range(N):
                    L[i, j, b] -= L[i, k, b] * L[j, k, b]
            for b in range(N):
                L[i, j, b] = L[i, j, b] / s[b]


@njit(**_OPTS)
def _points(mean, L, xi, X):
    r""":math:`X_p = m + L\xi_p`, batch innermost: mean (n, N), L (n, n, N), xi (M, n) -> X (M, n, N)."""
    M, n = xi.shape
    N = mean.shape[1]
    for p in range(M):
        for i in range(n):
            for b in range(N):
                X[p, i, b] = mean[i, b]
            for j in range(i + 1):
                c = xi[p, j]
                if c != 0.0:
                    for b in range(N):
                        X[p, i, b] += L[i, j, b] * c
                else:                      # keeps NaN factors NaN, as 0 * NaN does in the numpy path
                    for b in range(N):
                        X[p, i, b] += L[i, j, b] * 0.0


@njit(**_OPTS)
def _outer_sums(D, w, E, add, out_dd, out_ed):
    r""":math:`\sum_p w_p D_p D_p^T + \mathrm{add}` into out_dd (d, d, N) and :math:`\sum_p w_p E_p D_p^T` into
    out_ed (e, d, N); D (M, d, N), E (M, e, N) (e may be 0), add (d, d, N)."""
    M, d, N = D.shape
    e = E.shape[1]
    for i in range(d):
        for j in range(i + 1):
            for b in range(N):
                out_dd[i, j, b] = add[i, j, b]
            for p in range(M):
                wp = w[p]
                for b in range(N):
                    out_dd[i, j, b] += D[p, i, b] * (wp * D[p, j, b])
            if j < i:
                for b in range(N):
                    out_dd[j, i, b] = out_dd[i, j, b]
    for i in range(e):
        for j in range(d):
            for b in range(N):
                out_ed[i, j, b] = 0.0
            for p in range(M):
                wp = w[p]
                for b in range(N):
                    out_ed[i, j, b] += E[p, i, b] * (wp * D[p, j, b])


# --------------------------------------------------------------------------- public kernels ((N, ...) in and out)
@njit(**_OPTS)
def cholesky(a):
    """``(L, failed)`` for a stack ``a`` (N, n, n); a failed matrix's factor is NaN."""
    N = a.shape[0]
    L = np.empty(a.shape[1:] + (N,))
    failed = np.zeros(N, dtype=np.bool_)
    _chol(_inner(a, N), L, failed)
    out = _outer(L)
    _nan_rows(out, failed)
    return out, failed


@njit(**_OPTS)
def _lu_solve(A, X):
    """Solve A Y = X in place for one matrix ``A`` (d, d) and right-hand sides ``X`` (d, k): ``A`` overwritten by
    its LU factors (partial pivoting, the row exchanges applied to ``X``, as LAPACK's ``gesv``), ``X`` by Y.  False
    (``X`` unspecified) where an entry of ``A`` or ``X`` is not finite or a pivot is exactly zero."""
    d, k = X.shape
    for i in range(d):
        for j in range(d):
            if not math.isfinite(A[i, j]):
                return False
        for c in range(k):
            if not math.isfinite(X[i, c]):
                return False
    for q in range(d):
        p, big = q, abs(A[q, q])
        for i in range(q + 1, d):
            if abs(A[i, q]) > big:
                p, big = i, abs(A[i, q])
        if big == 0.0:                     # singular
            return False
        if p != q:
            for j in range(d):
                A[q, j], A[p, j] = A[p, j], A[q, j]
            for c in range(k):
                X[q, c], X[p, c] = X[p, c], X[q, c]
        for i in range(q + 1, d):
            f = A[i, q] / A[q, q]
            for j in range(q + 1, d):
                A[i, j] -= f * A[q, j]
            for c in range(k):
                X[i, c] -= f * X[q, c]
    for c in range(k):                     # back substitution, column by column
        for i in range(d - 1, -1, -1):
            t = X[i, c]
            for j in range(i + 1, d):
                t -= A[i, j] * X[j, c]
            X[i, c] = t / A[i, i]
    return True


@njit(**_OPTS)
def solve(A, B):
    """X with A X = B per run, A (N, n, n), B (N, n, k) -> X (N, n, k) (:func:`_lu_solve`): NaN where an operand is
    not finite or A is exactly singular."""
    NA, NB = A.shape[0], B.shape[0]
    N, n, k = max(NA, NB), B.shape[1], B.shape[2]
    out = np.empty((N, n, k))
    M = np.empty((n, n))
    X = np.empty((n, k))
    for b in range(N):                     # an operand with fewer rows is periodic over the runs (linalg._SHAPES)
        for i in range(n):
            for j in range(n):
                M[i, j] = A[b % NA, i, j]
            for c in range(k):
                X[i, c] = B[b % NB, i, c]
        if _lu_solve(M, X):
            for i in range(n):
                for c in range(k):
                    out[b, i, c] = X[i, c]
        else:
            for i in range(n):
                for c in range(k):
                    out[b, i, c] = np.nan
    return out


@njit(**_OPTS)
def information_fusion(means, covs):
    r"""Information-weighted fusion of M estimates per run: ``means`` (N, M, n), ``covs`` (N, M, n, n) ->
    ``(mean (N, n), cov (N, n, n), ok (N,))``, :math:`P = (\sum_p P_p^{-1})^{-1}` symmetrised,
    :math:`\hat x = P \sum_p P_p^{-1}\hat x_p` (Hu et al. 2017, Eqs. 22-24); ``ok`` where the symmetrised total
    information passes the Cholesky test of :func:`cholesky`.  A run whose member covariance or total information
    is not finite or exactly singular gets NaN and ``ok`` False; a run that is not ``ok`` has a NaN mean.  Run by
    run (the pivoting differs between runs), the members summed in order."""
    NM, M, n = means.shape
    NC = covs.shape[0]
    N = max(NM, NC)                        # an operand with fewer rows is periodic over the runs (linalg._SHAPES)
    total = np.zeros((N, n, n))
    weighted = np.zeros((N, n))
    good = np.ones(N, dtype=np.bool_)
    A = np.empty((n, n))
    Y = np.empty((n, n))
    for b in range(N):
        for p in range(M):
            for i in range(n):
                for j in range(n):
                    A[i, j] = covs[b % NC, p, i, j]
                    Y[i, j] = 1.0 if i == j else 0.0
            if not _lu_solve(A, Y):
                good[b] = False
                break
            for i in range(n):
                t = 0.0
                for j in range(n):
                    total[b, i, j] += Y[i, j]
                    t += Y[i, j] * means[b % NM, p, j]
                weighted[b, i] += t
    sym = np.empty((N, n, n))
    for b in range(N):
        for i in range(n):
            for j in range(n):
                sym[b, i, j] = 0.5 * (total[b, i, j] + total[b, j, i])
    _, failed = cholesky(sym)
    mean = np.full((N, n), np.nan)
    cov = np.full((N, n, n), np.nan)
    ok = np.zeros(N, dtype=np.bool_)
    for b in range(N):
        if not good[b]:
            continue
        for i in range(n):
            for j in range(n):
                A[i, j] = total[b, i, j]
                Y[i, j] = 1.0 if i == j else 0.0
        if not _lu_solve(A, Y):
            continue
        for i in range(n):
            for j in range(n):
                cov[b, i, j] = 0.5 * (Y[i, j] + Y[j, i])
        if failed[b]:
            continue
        ok[b] = True
        for i in range(n):
            t = 0.0
            for j in range(n):
                t += cov[b, i, j] * weighted[b, j]
            mean[b, i] = t
    return mean, cov, ok


@njit(**_OPTS)
def normalised_square(v, S):
    r""":math:`v^T S^{-1} v` per run, v (N, d), S (N, d, d): NaN where an operand is not finite or S is singular
    (an exactly zero pivot, as LAPACK's ``gesv``).  LU with partial pivoting, the row exchanges applied to v, then
    back substitution (:func:`_lu_solve`) and the dot product with v.  Run by run, not batch innermost: the pivoting
    differs between runs, and at d <= 9 one run's elimination is a few hundred operations (the numpy path pays a
    LAPACK call's overhead per matrix)."""
    N, d = v.shape
    out = np.empty(N)
    A = np.empty((d, d))
    x = np.empty((d, 1))
    for b in range(N):
        for i in range(d):
            x[i, 0] = v[b, i]
            for j in range(d):
                A[i, j] = S[b, i, j]
        out[b] = _quadratic(A, x)
    return out


@njit(**_OPTS)
def _quadratic(A, x):
    r""":math:`v^T A^{-1} v` of one run from A (d, d) and x (d, 1) holding v (both overwritten): LU with partial
    pivoting (:func:`_lu_solve`), then the dot product of the solution with v, summed in index order; NaN where an
    operand is not finite or A is exactly singular.  The one body of :func:`normalised_square` and
    :func:`_nsq_lanes`."""
    d = x.shape[0]
    v = x[:, 0].copy()
    if not _lu_solve(A, x):
        return np.nan
    t = 0.0
    for i in range(d):
        t += v[i] * x[i, 0]
    return t


@njit(**_OPTS)
def sigma_points(mean, cov, xi):
    r"""Sigma points :math:`X_{bp} = m_b + L_b \xi_p` with :math:`L_b L_b^T = P_b`: mean (N, n),
    cov (N, n, n), unit points xi (M, n) -> ``(X (N, M, n), failed (N,))``; a failed run's points are NaN."""
    N, n = mean.shape
    M = xi.shape[0]
    L = np.empty((n, n, N))
    failed = np.zeros(N, dtype=np.bool_)
    _chol(_inner(cov, N), L, failed)
    X = np.empty((M, n, N))
    _points(_inner(mean, N), L, xi, X)
    out = _outer(X)
    _nan_rows(out, failed)
    return out, failed


@njit(**_OPTS)
def matmul_rows(x, b):
    """``x @ b`` for rows x (N, k) and one matrix b (k, d), each row summed in index order."""
    N, k = x.shape
    d = b.shape[1]
    out = np.zeros((N, d))
    for j in range(k):
        for c in range(d):
            bj = b[j, c]
            for r in range(N):
                out[r, c] += x[r, j] * bj
    return out


@njit(**_OPTS)
def weighted_mean(Y, w):
    r""":math:`\sum_p w_p Y_{bp}`: Y (N, M, d), w (M,) -> (N, d)."""
    N, M, d = Y.shape
    out = np.zeros((N, d))
    for p in range(M):
        wp = w[p]
        for b in range(N):
            for i in range(d):
                out[b, i] += wp * Y[b, p, i]
    return out


@njit(**_OPTS)
def weighted_outer(dy, w, dx, add):
    r"""``(P_yy + add, P_xy)``: :math:`P_{yy} = \sum_p w_p\, dy_p dy_p^T`, :math:`P_{xy} = \sum_p w_p\,
    dx_p dy_p^T`; dy (N, M, d), w (M,), dx (N, M, n) (or (N, M, 0) for no cross term), add (N, d, d)."""
    N, M, d = dy.shape
    n = dx.shape[2]
    pyy = np.empty((d, d, N))
    pxy = np.empty((n, d, N))
    _outer_sums(_inner(dy, N), w, _inner(dx, N), _inner(add, N), pyy, pxy)
    return _outer(pyy), _outer(pxy)


@njit(**_OPTS)
def _kalman_core(mean_b, P, nub, Sb, Pxzb, Hb, Rb, joseph, C, nis, logdet, failed):
    r"""The body of :func:`kalman_moments`, batch innermost: the prior mean mean_b (n, N) (overwritten by the
    posterior mean), cov P (n, n, N), innovation nub (m, N), Sb (m, m, N), Pxzb (n, m, N), and with ``joseph`` Hb
    (m, n, N) and Rb (m, m, N) -> posterior cov C (n, n, N), nis, logdet, failed (N,) (a failed run's mean and C
    are to be replaced by NaN by the caller)."""
    n, N = mean_b.shape
    m = nub.shape[0]
    s_bad = np.zeros(N, dtype=np.bool_)
    L = np.empty((m, m, N))
    _chol(Sb, L, s_bad)
    # inverse of the lower-triangular factor by forward substitution
    Li = np.zeros((m, m, N))
    for i in range(m):
        for b in range(N):
            Li[i, i, b] = 1.0 / L[i, i, b]
        for j in range(i):
            acc = np.zeros(N)
            for k in range(j, i):
                for b in range(N):
                    acc[b] += L[i, k, b] * Li[k, j, b]
            for b in range(N):
                Li[i, j, b] = -acc[b] * Li[i, i, b]
    e = np.zeros((m, N))
    nis[:] = 0.0
    for i in range(m):
        for k in range(i + 1):
            for b in range(N):
                e[i, b] += Li[i, k, b] * nub[k, b]
        for b in range(N):
            nis[b] += e[i, b] * e[i, b]
    A = np.zeros((n, m, N))                                  # A = Pxz Linv^T
    for i in range(n):
        for j in range(m):
            for k in range(j + 1):
                for b in range(N):
                    A[i, j, b] += Pxzb[i, k, b] * Li[j, k, b]
    for i in range(n):
        for k in range(m):
            for b in range(N):
                mean_b[i, b] += A[i, k, b] * e[k, b]
    if not joseph:
        # sym(P - AA^T): (AA^T)_ij is symmetric bit for bit; P is symmetrised as given
        s = np.empty(N)
        for i in range(n):
            for j in range(i + 1):
                s[:] = 0.0
                for k in range(m):
                    for b in range(N):
                        s[b] += A[i, k, b] * A[j, k, b]
                for b in range(N):
                    v = 0.5 * ((P[i, j, b] - s[b]) + (P[j, i, b] - s[b]))
                    C[i, j, b] = v
                    C[j, i, b] = v
    else:
        K = np.zeros((n, m, N))                              # K = A Linv
        for i in range(n):
            for j in range(m):
                for k in range(j, m):
                    for b in range(N):
                        K[i, j, b] += A[i, k, b] * Li[k, j, b]
        IKH = np.empty((n, n, N))                            # I - K H
        for i in range(n):
            for j in range(n):
                for b in range(N):
                    IKH[i, j, b] = 0.0
                for k in range(m):
                    for b in range(N):
                        IKH[i, j, b] += K[i, k, b] * Hb[k, j, b]
                d = 1.0 if i == j else 0.0
                for b in range(N):
                    IKH[i, j, b] = d - IKH[i, j, b]
        T1 = np.zeros((n, n, N))                             # (I - KH) P
        for i in range(n):
            for j in range(n):
                for k in range(n):
                    for b in range(N):
                        T1[i, j, b] += IKH[i, k, b] * P[k, j, b]
        KR = np.zeros((n, m, N))                             # K R
        for i in range(n):
            for j in range(m):
                for k in range(m):
                    for b in range(N):
                        KR[i, j, b] += K[i, k, b] * Rb[k, j, b]
        for i in range(n):
            for j in range(n):
                for b in range(N):
                    C[i, j, b] = 0.0
                for k in range(n):
                    for b in range(N):
                        C[i, j, b] += T1[i, k, b] * IKH[j, k, b]
                acc = np.zeros(N)
                for k in range(m):
                    for b in range(N):
                        acc[b] += KR[i, k, b] * K[j, k, b]
                for b in range(N):
                    C[i, j, b] += acc[b]
        for i in range(n):
            for j in range(i):
                for b in range(N):
                    v = 0.5 * (C[i, j, b] + C[j, i, b])
                    C[i, j, b] = v
                    C[j, i, b] = v
    p_bad = np.zeros(N, dtype=np.bool_)
    Lp = np.empty((n, n, N))
    _chol(C, Lp, p_bad)
    logdet[:] = 0.0
    for i in range(m):                                       # scalar loop: log is not vectorised
        for b in range(N):
            logdet[b] += math.log(L[i, i, b])
    for b in range(N):
        failed[b] = s_bad[b] or p_bad[b]
        if s_bad[b]:
            nis[b] = np.nan
            logdet[b] = np.nan
    for b in range(N):
        logdet[b] = 2.0 * logdet[b]


@njit(**_OPTS)
def kalman_moments(mean, cov, nu, S, Pxz, H, R):
    r"""The numerical part of :func:`mmlib.core.filters.kalman_update` for a stack of N runs.

    mean (N, n), cov (N, n, n), innovation nu (N, m), S (N, m, m), Pxz (N, n, m); ``H`` (N, m, n) and
    ``R`` (N, m, m) select the Joseph form (``H`` of shape (N, 0, 0): the form :math:`P - AA^T`).
    With :math:`S = LL^T`, :math:`A = P_{xz}L^{-T}`, :math:`e = L^{-1}\nu`: :math:`\hat x^+ = \hat x + Ae`,
    :math:`P^+ = \mathrm{sym}(P - AA^T)` or :math:`\mathrm{sym}((I-KH)P(I-KH)^T + KRK^T)` with
    :math:`K = AL^{-1}`; NIS :math:`e^Te`; :math:`\log|S| = 2\sum\log L_{ii}`.
    Returns ``(mean+, cov+, nis, logdet, failed)``; a run fails when S or :math:`P^+` has no Cholesky
    factor: its mean and covariance (and, if S failed, NIS and log-determinant) are NaN."""
    N, n = mean.shape
    joseph = H.shape[1] > 0
    mean_b = _inner(mean, N)
    C = np.empty((n, n, N))
    nis = np.empty(N)
    logdet = np.empty(N)
    failed = np.empty(N, dtype=np.bool_)
    Hb = _inner(H, N) if joseph else np.empty((0, 0, N))
    Rb = _inner(R, N) if joseph else np.empty((0, 0, N))
    _kalman_core(mean_b, _inner(cov, N), _inner(nu, N), _inner(S, N), _inner(Pxz, N), Hb, Rb, joseph, C, nis,
                 logdet, failed)
    mean_out = _outer(mean_b)
    cov_out = _outer(C)
    _nan_rows(mean_out, failed)
    _nan_rows(cov_out, failed)
    return mean_out, cov_out, nis, logdet, failed


@njit(**_OPTS)
def _combine(W, X, P, Cn, out):
    r"""out[j] = sym sum_i W[j, i] (P[i] + (X[i] - Cn[j])(X[i] - Cn[j])^T), batch innermost:
    W (J, I, N), X (I, n, N), P (I, n, n, N), Cn (J, n, N), out (J, n, n, N)."""
    J, I, N = W.shape
    n = X.shape[1]
    D = np.empty((n, N))
    WD = np.empty((n, N))
    acc = np.empty((n, n, N))
    for j in range(J):
        acc[:, :, :] = 0.0
        for i in range(I):
            for k in range(n):
                for b in range(N):
                    D[k, b] = X[i, k, b] - Cn[j, k, b]
                    WD[k, b] = W[j, i, b] * D[k, b]
            for k in range(n):
                for l in range(n):
                    for b in range(N):
                        acc[k, l, b] += W[j, i, b] * P[i, k, l, b] + WD[k, b] * D[l, b]
        for k in range(n):
            for l in range(n):
                for b in range(N):
                    out[j, k, l, b] = 0.5 * (acc[k, l, b] + acc[l, k, b])


@njit(**_OPTS)
def combine_covariances(wt, means, covs, centres):
    r""":math:`\mathrm{sym}\sum_i w_{ji}[P_i + (x_i - c_j)(x_i - c_j)^T]`: wt (B, J, I), means (B, I, n),
    covs (B, I, n, n), centres (B, J, n) -> (B, J, n, n); every term positive semi-definite (no
    subtraction of :math:`cc^T`)."""
    B, J, I = wt.shape
    n = means.shape[2]
    out = np.empty((J, n, n, B))
    _combine(_inner(wt, B), _inner(means, B), _inner(covs, B), _inner(centres, B), out)
    return _outer(out)


@njit(**_OPTS)
def _predict_core(mb, Pb, xi, wm, wc, Fb, Qb, ybar, Pm, failed):
    r"""The body of :func:`sigma_point_predict_linear`, batch innermost: mean mb (n, N), cov Pb (n, n, N),
    F and Q as Fb, Qb (n, n, N) -> ybar (n, N), Pm (n, n, N), ``failed`` (N,) set for the runs whose P has no
    Cholesky factor (their outputs are to be replaced by NaN by the caller)."""
    n, N = mb.shape
    M = xi.shape[0]
    failed[:] = False
    L = np.empty((n, n, N))
    _chol(Pb, L, failed)
    X = np.empty((M, n, N))
    _points(mb, L, xi, X)
    Y = np.zeros((M, n, N))
    ybar[:, :] = 0.0
    for p in range(M):
        wp = wm[p]
        for i in range(n):
            y = Y[p, i]
            for j in range(n):
                f = Fb[i, j]
                x = X[p, j]
                for b in range(N):
                    y[b] += f[b] * x[b]
            yb = ybar[i]
            for b in range(N):
                yb[b] += wp * y[b]
    for p in range(M):
        for i in range(n):
            y = Y[p, i]
            yb = ybar[i]
            for b in range(N):
                y[b] -= yb[b]
    _outer_sums(Y, wc, np.empty((M, 0, N)), Qb, Pm, np.empty((0, n, N)))


@njit(**_OPTS)
def sigma_point_predict_linear(mean, cov, xi, wm, wc, F, Q):
    r"""Fused sigma-point time update through linear dynamics :math:`f(x) = Fx` (the moments
    :func:`sigma_points`, ``F X``, :func:`weighted_mean` and :func:`weighted_outer` give in turn):
    :math:`X_p = m + L\xi_p`, :math:`Y_p = FX_p`, :math:`\bar y = \sum w^m_p Y_p`,
    :math:`P^- = \sum w^c_p (Y_p - \bar y)(Y_p - \bar y)^T + Q`.  mean (N, n), cov (N, n, n), xi (M, n),
    wm, wc (M,), F (N, n, n), Q (N, n, n) -> ``(mean-, cov-, failed)``; a failed run's moments are NaN."""
    N, n = mean.shape
    failed = np.zeros(N, dtype=np.bool_)
    ybar = np.empty((n, N))
    Pm = np.empty((n, n, N))
    _predict_core(_inner(mean, N), _inner(cov, N), xi, wm, wc, _inner(F, N), _inner(Q, N), ybar, Pm, failed)
    mean_out = _outer(ybar)
    cov_out = _outer(Pm)
    _nan_rows(mean_out, failed)
    _nan_rows(cov_out, failed)
    return mean_out, cov_out, failed


@njit(**_OPTS)
def _wrap(a):
    """:func:`mmlib.core.linalg.wrap_angle` of one angle, the same bits for every float (``np.floor``: a float, where
    ``math.floor`` would overflow an integer beyond 2**63 and at infinity)."""
    return a + _TWO_PI * np.floor((math.pi - a) / _TWO_PI)


@njit(**_OPTS)
def _measurement_core(DX, mb, Zb, wm, wc, angular, Rb, zp, S, Pxz):
    r"""The body of :func:`measurement_moments`, batch innermost: the points DX (M, n, N) (overwritten by their
    deviations from the mean mb (n, N)), their images Zb (M, m, N) (overwritten by the residuals about the predicted
    measurement), R as Rb (m, m, N) -> zp (m, N), S (m, m, N), Pxz (n, m, N)."""
    M, n, N = DX.shape
    m = Zb.shape[1]
    for p in range(M):
        for i in range(n):
            for b in range(N):
                DX[p, i, b] -= mb[i, b]
    zp[:, :] = 0.0
    for c in range(m):
        if angular[c]:
            for p in range(M):
                wp = wm[p]
                for b in range(N):
                    zp[c, b] += wp * _wrap(Zb[p, c, b] - Zb[0, c, b])
            for b in range(N):
                zp[c, b] = _wrap(Zb[0, c, b] + zp[c, b])
        else:
            for p in range(M):
                wp = wm[p]
                for b in range(N):
                    zp[c, b] += wp * Zb[p, c, b]
    for p in range(M):
        for c in range(m):
            if angular[c]:
                for b in range(N):
                    Zb[p, c, b] = _wrap(Zb[p, c, b] - zp[c, b])
            else:
                for b in range(N):
                    Zb[p, c, b] -= zp[c, b]
    _outer_sums(Zb, wc, DX, Rb, S, Pxz)


@njit(**_OPTS)
def measurement_moments(X, mean, Z, wm, wc, angular, R):
    r"""Fused sigma-point measurement moments: from the points X (N, M, n) of the prior with mean
    (N, n) and their images Z (N, M, m) under h, the predicted measurement
    :math:`\hat z = \sum w^m_p Z_p` (for the components flagged ``angular`` (m,): the reference point
    plus the mean of the wrapped residuals about it, wrapped to :math:`(-\pi, \pi]`),
    :math:`S = \sum w^c_p\, dz_p dz_p^T + R` and :math:`P_{xz} = \sum w^c_p (X_p - m) dz_p^T` with
    :math:`dz_p = Z_p - \hat z` (angles wrapped).  R (N, m, m).  Returns ``(z_pred, S, Pxz)``."""
    N, M, n = X.shape
    m = Z.shape[2]
    zp = np.empty((m, N))
    S = np.empty((m, m, N))
    Pxz = np.empty((n, m, N))
    _measurement_core(_inner(X, N), _inner(mean, N), _inner(Z, N), wm, wc, angular, _inner(R, N), zp, S, Pxz)
    return _outer(zp), _outer(S), _outer(Pxz)


@njit(**_OPTS)
def _mix_core(mub, T, Xb, Pb, c, mm, out):
    r"""The body of :func:`imm_mix`, batch innermost: mub (r, N), T (r, r), means Xb (r, n, N), covs Pb (r, n, n, N)
    -> c (r, N), mixed means mm (r, n, N), mixed covs out (r, n, n, N)."""
    r, N = mub.shape
    n = Xb.shape[1]
    W = np.empty((r, r, N))                                  # W[j, i] = mu_{i|j}
    _mixing_weights_core(mub, T, c, W)
    mm[:, :, :] = 0.0
    for j in range(r):
        for k in range(n):
            for i in range(r):
                for b in range(N):
                    mm[j, k, b] += W[j, i, b] * Xb[i, k, b]
    _combine(W, Xb, Pb, mm, out)


@njit(**_OPTS)
def imm_mix(mu, T, means, covs):
    r"""IMM interaction (Zhu et al. 2016, Eqs. 54-56) fused: :math:`c_j = \sum_i \mu_i T_{ij}`,
    :math:`\mu_{i|j} = T_{ij}\mu_i / c_j` (for a mode no other mode reaches, :math:`c_j = 0`: :math:`\mu`
    itself), mixed means :math:`x^{0j} = \sum_i \mu_{i|j} x^i` and covariances
    :math:`\mathrm{sym}\sum_i \mu_{i|j}[P^i + (x^i - x^{0j})(x^i - x^{0j})^T]`.
    mu (B, r), T (r, r) rows "from", means (B, r, n), covs (B, r, n, n) -> ``(c, mixed means, mixed covs)``."""
    B, r = mu.shape
    n = means.shape[2]
    c = np.empty((r, B))
    mm = np.empty((r, n, B))
    out = np.empty((r, n, n, B))
    _mix_core(_inner(mu, B), T, _inner(means, B), _inner(covs, B), c, mm, out)
    return _outer(c), _outer(mm), _outer(out)


@njit(**_OPTS)
def _regular(dx, dy):
    """Whether :func:`_hypot` and :func:`_atan2` hold for (dx, dy): dx^2 + dy^2 in the regular range of
    :mod:`mmlib.core._elementary` (else the C library's ``hypot`` and ``atan2`` answer)."""
    s = dx * dx + dy * dy
    return (s > REGULAR_MIN) & (s < REGULAR_MAX)


@njit(**_OPTS)
def _hypot(dx, dy):
    r""":math:`\sqrt{dx^2 + dy^2}` for regular operands (:mod:`mmlib.core._elementary`: below 2 ulp)."""
    return math.sqrt(dx * dx + dy * dy)


@njit(**_OPTS)
def _atan2(dy, dx):
    r""":math:`\operatorname{atan2}(dy, dx)` for regular operands, branch-free (the selects vectorise): the octant
    reduction, Cephes' rational arctan and the multiple of pi/4 of :func:`mmlib.core._elementary.range_bearing`, the
    same operations in the same order (below 2 ulp)."""
    ax = abs(dx)
    ay = abs(dy)
    swap = ay > ax
    small = ax if swap else ay
    big = ay if swap else ax
    reduce = small > REDUCE_ABOVE * big
    u = (small - big if reduce else small) / (small + big if reduce else big)
    z = u * u
    p = (((P0 * z + P1) * z + P2) * z + P3) * z + P4
    q = ((((z + Q0) * z + Q1) * z + Q2) * z + Q3) * z + Q4
    r = u + u * (z * p / q)
    negative_x = math.copysign(1.0, dx) < 0.0
    k = 1.0 if reduce else 0.0              # a float: integer selects keep LLVM from vectorising the loop
    k = 2.0 - k if swap else k
    k = 4.0 - k if negative_x else k
    r = -r if swap != negative_x else r
    hi = QPI4_HI if k == 4.0 else (QPI3_HI if k == 3.0 else (QPI2_HI if k == 2.0 else (QPI1_HI if k == 1.0 else 0.0)))
    lo = QPI4_LO if k == 4.0 else (QPI3_LO if k == 3.0 else (QPI2_LO if k == 2.0 else (QPI1_LO if k == 1.0 else 0.0)))
    return math.copysign(hi + (lo + r), dy)


@njit(**_OPTS)
def _range_bearing_lanes(x0, x1, sx, sy, rng, bearing):
    """Range and bearing of the points (x0[b], x1[b]) (N,) from (sx, sy) into rng, bearing (N,): a loop of the
    branch-free formulas over every lane (vectorised), then the C library's ``hypot`` and ``atan2`` for the lanes
    whose operands are not regular (:mod:`mmlib.core._elementary`)."""
    N = x0.shape[0]
    for b in range(N):
        dx = x0[b] - sx
        dy = x1[b] - sy
        rng[b] = _hypot(dx, dy)
        bearing[b] = _atan2(dy, dx)
    for b in range(N):
        dx = x0[b] - sx
        dy = x1[b] - sy
        if not _regular(dx, dy):
            rng[b] = math.hypot(dx, dy)
            bearing[b] = math.atan2(dy, dx)


@njit(**_OPTS)
def range_bearing(x, i, j, sx, sy):
    r"""Range and bearing of the points x (N, n) from a sensor at (sx, sy): :math:`(\sqrt{dx^2 + dy^2},
    \operatorname{atan2}(dy, dx))` with :math:`dx = x_i - s_x`, :math:`dy = x_j - s_y` -> (N, 2)
    (:func:`_range_bearing_lanes`: the bits of :func:`mmlib.core._elementary.range_bearing`)."""
    N = x.shape[0]
    x0 = np.empty(N)
    x1 = np.empty(N)
    for b in range(N):
        x0[b] = x[b, i]
        x1[b] = x[b, j]
    rng = np.empty(N)
    bearing = np.empty(N)
    _range_bearing_lanes(x0, x1, sx, sy, rng, bearing)
    out = np.empty((N, 2))
    for b in range(N):
        out[b, 0] = rng[b]
        out[b, 1] = bearing[b]
    return out


#: the most terms :func:`_numpy_sum` adds in numpy's order (numpy splits a longer sum in halves, recursively: a
#: recursive kernel would not survive numba's on-disk cache, numba issue 6061)
NUMPY_SUM_MAX = 128


@njit(**_OPTS)
def _numpy_sum(a, lo, n):
    """``a[lo:lo + n].sum()`` in numpy's order of summation for n <= :data:`NUMPY_SUM_MAX` (``np.add.reduce`` of a
    row: its pairwise sum, added to 0.0): one term at a time below eight terms, else eight running sums combined as
    ((0+1)+(2+3))+((4+5)+(6+7)), then the remainder one at a time.  The same bits as numpy, signed zeros included
    (``tests/test_gnss_fuzzy.py``)."""
    if n < 8:
        res = -0.0
        for i in range(lo, lo + n):
            res += a[i]
        return 0.0 + res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    top = n - n % 8
    for i in range(lo + 8, lo + top, 8):
        r0 += a[i]
        r1 += a[i + 1]
        r2 += a[i + 2]
        r3 += a[i + 3]
        r4 += a[i + 4]
        r5 += a[i + 5]
        r6 += a[i + 6]
        r7 += a[i + 7]
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    for i in range(lo + top, lo + n):
        res += a[i]
    return 0.0 + res


@njit(**_OPTS)
def _trapezoid(x, a, b, c, d):
    """One trapezoid's membership at x, as numpy evaluates it (:func:`mmlib.core.linalg.trapezoid_memberships`):
    ``clip(minimum(up, down), 0, 1)`` with numpy's ``minimum`` (NaN from either side, the second of two equal values)
    and ``clip`` (a NaN kept, a signed zero kept)."""
    if a == -np.inf:
        up = 1.0
    elif b == a:
        up = 1.0 if x >= b else 0.0
    else:
        up = (x - a) / (b - a)
    if d == np.inf:
        down = 1.0
    elif d == c:
        down = 1.0 if x <= c else 0.0
    else:
        down = (d - x) / (d - c)
    v = up if (up < down or up != up) else down             # numpy's minimum: the second on a tie, NaN kept
    if v != v:
        return v
    if v < 0.0:
        return 0.0
    if v > 1.0:
        return 1.0
    return v


@njit(**_OPTS)
def trapezoid_rules(x, bounds, sizes, cons):
    """A zero-order Takagi-Sugeno system whose input sets are all trapezoids (:func:`mmlib.core.linalg.trapezoid_rules`,
    which checks the shapes): for inputs x (B, d), the sets of input i ``bounds[i, :, :sizes[i]]`` (rows a, b, c, d;
    (d, 4, k_max)) and the consequents cons (K, p) of the K = prod(k_i) rules in C order (the last input's set
    fastest; K <= :data:`NUMPY_SUM_MAX`), ``(output (B, p), total weight (B,))``: rule weights
    ``((1 * mu_0) * mu_1) * ...``, their sum in numpy's order (:func:`_numpy_sum`), and :func:`matmul_rows` of the
    weights and the consequents over that sum."""
    B, d = x.shape
    K = cons.shape[0]
    mu = np.empty((d, bounds.shape[2]))
    weights = np.empty((B, K))
    digit = np.empty(d, dtype=np.int64)
    total = np.empty(B)
    for row in range(B):
        w = weights[row]
        for i in range(d):
            for s in range(sizes[i]):
                mu[i, s] = _trapezoid(x[row, i], bounds[i, 0, s], bounds[i, 1, s], bounds[i, 2, s], bounds[i, 3, s])
        for r in range(K):
            rest = r
            for i in range(d - 1, -1, -1):
                digit[i] = rest % sizes[i]
                rest //= sizes[i]
            v = 1.0
            for i in range(d):
                v = v * mu[i, digit[i]]
            w[r] = v
        total[row] = _numpy_sum(w, 0, K)
    out = matmul_rows(weights, cons)
    for row in range(B):
        for c in range(out.shape[1]):
            out[row, c] = out[row, c] / total[row]
    return out, total


@njit(**_OPTS)
def pseudoranges(x, sats, i0, i1, i2, ib):
    r"""Pseudoranges :math:`\lVert s_c - p\rVert + b` of the points x (N, n) to the satellites ``sats`` (m, 3),
    p = x[:, (i0, i1, i2)], b = x[:, ib] -> (N, m): the squares summed from the first axis on, as numpy reduces three
    terms (the operations of :func:`_measure`'s kind 2; scalar loop)."""
    N = x.shape[0]
    m = sats.shape[0]
    out = np.empty((N, m))
    for b in range(N):
        p0, p1, p2, bias = x[b, i0], x[b, i1], x[b, i2], x[b, ib]
        for c in range(m):
            d0 = sats[c, 0] - p0
            d1 = sats[c, 1] - p1
            d2 = sats[c, 2] - p2
            out[b, c] = math.sqrt((d0 * d0 + d1 * d1) + d2 * d2) + bias
    return out


@njit(**_OPTS)
def _output_core(ll, cb, Xb, Pb, Nb, Sb, with_cov, mub, marginal, underflow, fused, fcov, innov, icov):
    r"""The body of :func:`imm_output`, batch innermost: ll (r, N), cb (1, r, N), Xb (r, n, N), Pb (r, n, n, N),
    Nb (r, m, N), Sb (r, m, m, N) -> mub (1, r, N), marginal, underflow (N,), fused (1, n, N), fcov (1, n, n, N)
    (if ``with_cov``), innov (1, m, N), icov (1, m, m, N)."""
    r, N = ll.shape
    n = Xb.shape[1]
    m = Nb.shape[1]
    lp = np.empty(r)
    for b in range(N):
        top = -np.inf
        for j in range(r):
            lp[j] = ll[j, b] + math.log(cb[0, j, b]) if cb[0, j, b] > 0.0 else -np.inf + ll[j, b]
            if lp[j] != lp[j] or top != top:
                top = np.nan
            elif lp[j] > top:
                top = lp[j]
        total = 0.0
        for j in range(r):
            mub[0, j, b] = math.exp(lp[j] - top) if top > -np.inf else np.nan
            total += mub[0, j, b]
        for j in range(r):
            mub[0, j, b] = mub[0, j, b] / total
        marginal[b] = top + math.log(total) if total > 0.0 else np.nan
        underflow[b] = top == -np.inf
    fused[:, :, :] = 0.0
    for j in range(r):
        for k in range(n):
            for b in range(N):
                fused[0, k, b] += mub[0, j, b] * Xb[j, k, b]
    innov[:, :, :] = 0.0
    for j in range(r):
        for k in range(m):
            for b in range(N):
                innov[0, k, b] += cb[0, j, b] * Nb[j, k, b]
    _combine(cb, Nb, Sb, innov, icov)
    if with_cov:
        _combine(mub, Xb, Pb, fused, fcov)


@njit(**_OPTS)
def _output_buffers(r, n, m, N, with_cov):
    """The outputs of :func:`_output_core` for N runs innermost: ``(mu (1, r, N), marginal (N,), underflow (N,)
    zeroed, fused mean (1, n, N), its covariance (1, n, n, N) or (1, 0, 0, N) without ``with_cov``, innovation
    (1, m, N), its covariance (1, m, m, N))``."""
    return (np.empty((1, r, N)), np.empty(N), np.zeros(N, dtype=np.bool_), np.empty((1, n, N)),
            np.empty((1, n, n, N) if with_cov else (1, 0, 0, N)), np.empty((1, m, N)), np.empty((1, m, m, N)))


@njit(**_OPTS)
def imm_output(loglik, c, means, covs, nu, S, with_cov):
    r"""The end of an IMM cycle fused (Zhu et al. 2016, Eqs. 57-59): mode probabilities
    :math:`\mu_j \propto c_j L_j` (computed in logs about the largest term), the log marginal likelihood
    :math:`\log\sum_j c_j L_j`, the fused estimate :math:`\hat x = \sum_j \mu_j x_j` and (if ``with_cov``) its
    covariance :math:`\sum_j \mu_j[P_j + (x_j - \hat x)(x_j - \hat x)^T]`, and the innovation of the mixture
    prior :math:`\sum_j c_j \nu_j` with its covariance :math:`\sum_j c_j[S_j + (\nu_j - \nu)(\nu_j - \nu)^T]`.

    loglik, c (B, r); means (B, r, n); covs (B, r, n, n); nu (B, r, m); S (B, r, m, m).  Returns
    ``(mu, marginal, underflow, mean, cov, innovation, innovation_cov)``; ``underflow[b]``: every mode's
    likelihood of run b underflowed (its mu is NaN); a NaN log-likelihood makes the run's mu NaN."""
    B, r = loglik.shape
    n = means.shape[2]
    m = nu.shape[2]
    mub, marginal, underflow, fused, fcov, innov, icov = _output_buffers(r, n, m, B, with_cov)
    _output_core(_inner(loglik, B), _inner(c, B).reshape((1, r, B)), _inner(means, B), _inner(covs, B),
                 _inner(nu, B), _inner(S, B), with_cov, mub, marginal, underflow, fused, fcov, innov, icov)
    cov_out = _outer(fcov)[:, 0] if with_cov else np.empty((B, 0, 0))
    return (_outer(mub[0]), marginal, underflow, _outer(fused)[:, 0], cov_out, _outer(innov)[:, 0],
            _outer(icov)[:, 0])


@njit(**_OPTS)
def congruence(A, P, add):
    r"""The linearised moments of the EKF: :math:`A P A^T + \mathrm{add}` and :math:`P A^T` for a stack:
    A (N, d, n) (a Jacobian), P (N, n, n), add (N, d, d) (the noise Q or R) -> ``((N, d, d), (N, n, d))``;
    :math:`APA^T` is computed as :math:`A(PA^T)` (:func:`_congruence_core`) and not symmetrised (the numpy path's
    product is not either)."""
    N = P.shape[0]                          # (A and add may be periodic over the runs)
    d, n = A.shape[1], A.shape[2]
    S = np.empty((d, d, N))
    PAt = np.empty((n, d, N))
    _congruence_core(_inner(A, N), _inner(P, N), _inner(add, N), S, PAt)
    return _outer(S), _outer(PAt)


@njit(**_OPTS)
def _linear_mean_core(Fb, mb, out):
    """out (n, N) = F m for F (n, n, N) and m (n, N), batch innermost, each sum in index order from 0."""
    n, N = mb.shape
    for i in range(n):
        for b in range(N):
            out[i, b] = 0.0
        for k in range(n):
            for b in range(N):
                out[i, b] += Fb[i, k, b] * mb[k, b]


@njit(**_OPTS)
def linear_predict(mean, cov, F, Q):
    r"""The Kalman filter's time update through linear dynamics, fused: :math:`(F m, F P F^T + Q)` with
    :math:`FPF^T = F(PF^T)` (as :func:`congruence`): mean (N, n), cov (N, n, n), F (N, n, n), Q (N, n, n)."""
    N, n = mean.shape
    out = np.empty((n, N))
    _linear_mean_core(_inner(F, N), _inner(mean, N), out)
    S, _ = congruence(F, cov, Q)
    return _outer(out), S


# --------------------------------------------------------------------------- a whole IMM sigma-point step
#: lanes per tile of the transpositions between the run-first arrays and the batch-innermost blocks: a tile's rows
#: of both sides (a few KB) stay in the L1 cache, where a whole block's (tens of KB) would not
_TILE = 16


@njit(**_OPTS)
def _lanes(a, b0, N, period_of, out):
    """out (..., N) <- rows of ``a`` (P, ...) (C-contiguous) for the N lanes of a block starting at run b0: lane l
    takes row ``((b0 + l) * stride + offset) % P`` with ``period_of = (stride, offset)``: (1, 0) the runs b0..b0+N-1
    themselves, (r, j) mode j of the flattened (runs, r modes) stack, a shared or periodic operand either way.
    Copied :data:`_TILE` lanes at a time."""
    P = a.shape[0]
    flat = a.reshape((P, a.size // P))
    k = flat.shape[1]
    o = out.reshape((k, N))
    stride, offset = period_of
    rows = np.empty(_TILE, dtype=np.int64)
    for t0 in range(0, N, _TILE):
        t = min(_TILE, N - t0)
        for lane in range(t):
            rows[lane] = ((b0 + t0 + lane) * stride + offset) % P
        for i in range(k):
            for lane in range(t):
                o[i, t0 + lane] = flat[rows[lane], i]


@njit(**_OPTS)
def _unlanes(src, b0, out):
    """Rows b0..b0+N-1 of ``out`` (B, ...) (C-contiguous) <- the N lanes of ``src`` (..., N), the inverse of
    :func:`_lanes` over the runs themselves, :data:`_TILE` lanes at a time."""
    N = src.shape[-1]
    s = src.reshape((src.size // N, N))
    k = s.shape[0]
    o = out.reshape((out.shape[0], k))
    for t0 in range(0, N, _TILE):
        t = min(_TILE, N - t0)
        for i in range(k):
            for lane in range(t):
                o[b0 + t0 + lane, i] = s[i, t0 + lane]


@njit(**_OPTS)
def _nan_lanes(a, failed):
    """Every entry of lane b of ``a`` (..., N) NaN for the lanes with ``failed[b]``."""
    N = a.shape[-1]
    flat = a.reshape((a.size // N, N))
    for b in range(N):
        if failed[b]:
            for i in range(flat.shape[0]):
                flat[i, b] = np.nan


@njit(**_OPTS)
def _measure(X, kind, A, idx, sensor, Z):
    r"""The images Z (M, m, N) of the points X (M, n, N) under the measurement function ``kind``, computed as the
    model's own ``h`` computes them:

    * 0, linear: :math:`Hx` with H = A (m, n), summed in index order from 0 (:func:`matmul_rows`);
    * 1, range and bearing of the position components idx[0], idx[1] seen from ``sensor`` (2,) (:func:`range_bearing`:
      :func:`_range_bearing_lanes`);
    * 2, pseudoranges :math:`\lVert s_i - p\rVert + b` to the satellites A (m, 3) of the position components
      idx[0..2] with the clock bias idx[3] (:class:`mmlib.core.gnss.Pseudoranges`: the squares summed from the first
      axis on, as numpy reduces three terms)."""
    M, n, N = X.shape
    m = Z.shape[1]
    if kind == 0:
        for p in range(M):
            for c in range(m):
                z = Z[p, c]
                for b in range(N):
                    z[b] = 0.0
                for j in range(n):
                    h = A[c, j]
                    x = X[p, j]
                    for b in range(N):
                        z[b] += x[b] * h
    elif kind == 1:
        i0, i1 = idx[0], idx[1]
        sx, sy = sensor[0], sensor[1]
        for p in range(M):
            _range_bearing_lanes(X[p, i0], X[p, i1], sx, sy, Z[p, 0], Z[p, 1])
    else:
        # each point's rows taken before the loop over the runs: indexed there by idx, the loop is not vectorised and
        # the square roots run one at a time (a correctly rounded vector square root gives the same bits)
        for p in range(M):
            x0, x1, x2, xb = X[p, idx[0]], X[p, idx[1]], X[p, idx[2]], X[p, idx[3]]
            for c in range(m):
                a0, a1, a2 = A[c, 0], A[c, 1], A[c, 2]
                z = Z[p, c]
                for b in range(N):
                    d0 = a0 - x0[b]
                    d1 = a1 - x1[b]
                    d2 = a2 - x2[b]
                    z[b] = math.sqrt((d0 * d0 + d1 * d1) + d2 * d2) + xb[b]


@njit(**_OPTS)
def _moments_core(mean, Pm, xi, wm, wc, kind, A, idx, sensor, angular, Rb, zp, S, Pxz):
    r"""The measurement prediction of a sigma-point filter, batch innermost, as the composed operations compute it:
    fresh points of the prior mean (n, N) and cov Pm (n, n, N) (:func:`sigma_points`, NaN for a run whose Pm has no
    Cholesky factor), their images (:func:`_measure`) and :func:`measurement_moments` with Rb (m, m, N) -> zp (m, N),
    S (m, m, N), Pxz (n, m, N)."""
    n, N = mean.shape
    M = xi.shape[0]
    m = zp.shape[0]
    f_pts = np.zeros(N, dtype=np.bool_)
    L = np.empty((n, n, N))
    _chol(Pm, L, f_pts)
    X = np.empty((M, n, N))
    _points(mean, L, xi, X)
    _nan_lanes(X, f_pts)
    Z = np.empty((M, m, N))
    _measure(X, kind, A, idx, sensor, Z)
    _measurement_core(X, mean, Z, wm, wc, angular, Rb, zp, S, Pxz)


@njit(**_OPTS)
def _residual_core(zb, zp, angular, nu):
    """nu (m, N) <- the residual zb - zp (m, N), the ``angular`` components wrapped (:func:`_wrap`), as the library's
    measurement models' ``residual``."""
    m, N = zb.shape
    for i in range(m):
        if angular[i]:
            for lane in range(N):
                nu[i, lane] = _wrap(zb[i, lane] - zp[i, lane])
        else:
            for lane in range(N):
                nu[i, lane] = zb[i, lane] - zp[i, lane]


@njit(**_OPTS)
def _update_core(mean, Pm, nu, S, Pxz, log_2pi, cov, ll, failed):
    r""":func:`kalman_moments` (the form :math:`P - AA^T`) of the prior mean (n, N) (overwritten by the posterior mean)
    and cov Pm (n, n, N) with nu (m, N), S (m, m, N), Pxz (n, m, N) -> ``cov`` (n, n, N), the log-likelihood
    :math:`-\tfrac12(\nu^TS^{-1}\nu + \log|S| + m\log 2\pi)` ``ll`` (N,) and ``failed`` (N,) (S or the posterior
    covariance without a Cholesky factor: its mean, cov and ll NaN), as :func:`mmlib.core.filters.kalman_update`."""
    no_H = np.empty((0, 0, nu.shape[1]))
    _joseph_update_core(mean, Pm, nu, S, Pxz, no_H, no_H, log_2pi, cov, ll, failed)


@njit(**_OPTS)
def _predict_and_moments(mb, Pb, xi, wm, wc, Fb, Qb, kind, A, idx, sensor, angular, Rb, prior, Pl, zp, S, Pxz):
    r"""The time update of a sigma-point filter on linear dynamics (:func:`_predict_core`: the prior ``prior`` (n, N)
    and ``Pl`` (n, n, N), NaN for a run whose covariance has no Cholesky factor) then its measurement prediction
    (:func:`_moments_core`: ``zp`` (m, N), ``S`` (m, m, N), ``Pxz`` (n, m, N)), batch innermost."""
    f_pred = np.empty(mb.shape[1], dtype=np.bool_)
    _predict_core(mb, Pb, xi, wm, wc, Fb, Qb, prior, Pl, f_pred)
    _nan_lanes(prior, f_pred)
    _nan_lanes(Pl, f_pred)
    _moments_core(prior, Pl, xi, wm, wc, kind, A, idx, sensor, angular, Rb, zp, S, Pxz)


@njit(**_OPTS)
def _filter_step(mb, Pb, xi, wm, wc, Fb, Qb, Rb, zb, kind, A, idx, sensor, angular, log_2pi, mean, cov, nu, S, ll,
                 failed):
    r"""One step of a sigma-point filter on linear dynamics, batch innermost, as the composed operations compute it:
    :func:`sigma_point_predict_linear` of the prior mb (n, N), Pb (n, n, N) through Fb, Qb (n, n, N); fresh points
    (:func:`sigma_points`); their images (:func:`_measure`); :func:`measurement_moments` with Rb (m, m, N); the
    residual of zb (m, N) (``angular`` components wrapped); :func:`kalman_moments` (the form :math:`P - AA^T`); the
    log-likelihood :math:`-\tfrac12(\nu^TS^{-1}\nu + \log|S| + m\log 2\pi)`.  Writes the posterior ``mean`` (n, N) and
    ``cov`` (n, n, N) (NaN for a failed run), ``nu`` (m, N), ``S`` (m, m, N), ``ll`` (N,) (NaN for a failed run) and
    ``failed`` (N,): S or the posterior covariance without a Cholesky factor."""
    n, N = mb.shape
    m = zb.shape[0]
    Pm = np.empty((n, n, N))
    zp = np.empty((m, N))
    Pxz = np.empty((n, m, N))
    _predict_and_moments(mb, Pb, xi, wm, wc, Fb, Qb, kind, A, idx, sensor, angular, Rb, mean, Pm, zp, S, Pxz)
    _residual_core(zb, zp, angular, nu)
    _update_core(mean, Pm, nu, S, Pxz, log_2pi, cov, ll, failed)


@njit(**_OPTS)
def _fading_core(Pl, Qb, Pxz, V, S, Rb, beta, lam):
    r"""The strong-tracking fading factor of the Jacobian-free form (Liu & Wu 2017, Eqs. 14, 18-19), batch innermost:
    :math:`X = (P^l)^{-1}P_{xz}` through the Cholesky factor of the covariance :math:`P^l` (:func:`_chol`, forward then
    back substitution, column by column), the diagonals of :math:`N = V - X^TQX - \beta R` and
    :math:`M = P_{zz} - V + N + (\beta - 1)R`, their traces summed in index order,
    :math:`\lambda = \max(1, \mathrm{tr}N/\mathrm{tr}M)` (1 where :math:`\mathrm{tr}M` is not > 0; NaN where tr N is
    NaN and tr M > 0, as ``np.maximum``).  Pl, Qb (n, n, N), Pxz (n, m, N), V, S, Rb (m, m, N) -> lam (N,).  A run
    whose :math:`P^l` is not positive definite (no covariance) gets X NaN, hence :math:`\lambda = 1`."""
    n, m, N = Pxz.shape
    L = np.empty((n, n, N))
    bad = np.zeros(N, dtype=np.bool_)
    _chol(Pl, L, bad)
    X = np.empty((n, m, N))
    for c in range(m):
        for i in range(n):                           # L Y = Pxz
            for b in range(N):
                X[i, c, b] = Pxz[i, c, b]
            for k in range(i):
                for b in range(N):
                    X[i, c, b] -= L[i, k, b] * X[k, c, b]
            for b in range(N):
                X[i, c, b] = X[i, c, b] / L[i, i, b]
        for i in range(n - 1, -1, -1):               # L^T X = Y
            for k in range(i + 1, n):
                for b in range(N):
                    X[i, c, b] -= L[k, i, b] * X[k, c, b]
            for b in range(N):
                X[i, c, b] = X[i, c, b] / L[i, i, b]
    _nan_lanes(X, bad)
    tr_n = np.zeros(N)
    tr_m = np.zeros(N)
    t = np.empty(N)
    d = np.empty(N)
    for c in range(m):
        d[:] = 0.0                                   # (X^T Q X)_cc
        for i in range(n):
            t[:] = 0.0                               # (Q X)_ic
            for k in range(n):
                for b in range(N):
                    t[b] += Qb[i, k, b] * X[k, c, b]
            for b in range(N):
                d[b] += X[i, c, b] * t[b]
        for b in range(N):
            n_cc = (V[c, c, b] - d[b]) - beta * Rb[c, c, b]
            tr_n[b] += n_cc
            tr_m[b] += ((S[c, c, b] - V[c, c, b]) + n_cc) + (beta - 1.0) * Rb[c, c, b]
    for b in range(N):
        ratio = tr_n[b] / tr_m[b] if tr_m[b] > 0.0 else 1.0
        lam[b] = ratio if (ratio > 1.0 or ratio != ratio) else 1.0


@njit(**_OPTS)
def fading_factor(Pl, Q, Pxz, V, S, R, beta):
    r"""The strong-tracking fading factor (:func:`_fading_core`) for a stack of N runs: Pl (N, n, n), Q (P, n, n),
    Pxz (N, n, m), V (N, m, m), S (N, m, m), R (P', m, m) (Q and R periodic over the runs) -> lam (N,)."""
    N = Pl.shape[0]
    lam = np.empty(N)
    _fading_core(_inner(Pl, N), _inner(Q, N), _inner(Pxz, N), _inner(V, N), _inner(S, N), _inner(R, N), beta, lam)
    return lam


@njit(**_OPTS)
def _block_operands(mean, cov, F, Q, R, z, b0, N):
    r"""The operands of a single-model fused step for the N runs of a block starting at run b0, batch innermost:
    ``(mb (n, N), Pb (n, n, N), Fb (n, n, N), Qb (n, n, N), Rb (m, m, N), zb (m, N))`` from mean (B, n), cov (B, n, n),
    the one F (n, n) copied into every lane, Q and R periodic over the runs (:func:`_lanes`) and z (B, m)."""
    m = z.shape[1]
    mb, Pb, Fb, Qb = _single_block_start(mean, cov, F, Q, b0, N)
    Rb = np.empty((m, m, N))
    _lanes(R, b0, N, (1, 0), Rb)
    zb = np.empty((m, N))
    _lanes(z, b0, N, (1, 0), zb)
    return mb, Pb, Fb, Qb, Rb, zb


@njit(**_OPTS)
def _step_outputs(B, n, m):
    """The outputs of a single-model fused step for B runs, run axis first: ``(mean (B, n), cov (B, n, n), loglik (B,),
    innovation (B, m), S (B, m, m), failed (B,) all False)``, filled block by block by :func:`_store_block`."""
    return (np.empty((B, n)), np.empty((B, n, n)), np.empty(B), np.empty((B, m)), np.empty((B, m, m)),
            np.zeros(B, dtype=np.bool_))


@njit(**_OPTS)
def _store_block(b0, mean, cov, ll, nu, S, failed, mean_out, cov_out, ll_out, nu_out, S_out, failed_out):
    """A single-model fused step's results for the block of runs starting at b0 (batch innermost: mean (n, N), cov
    (n, n, N), ll, failed (N,), nu (m, N), S (m, m, N)) written to the runs' rows of the outputs (run axis first)."""
    for lane in range(mean.shape[1]):
        ll_out[b0 + lane] = ll[lane]
        failed_out[b0 + lane] = failed[lane]
    _unlanes(mean, b0, mean_out)
    _unlanes(cov, b0, cov_out)
    _unlanes(nu, b0, nu_out)
    _unlanes(S, b0, S_out)


@njit(**_OPTS)
def _strong_tracking_core(mb, Pb, xi, wm, wc, Fb, Qb, kind, A, idx, sensor, angular, Rb, zb, Vb, restart, rho, beta,
                          log_2pi, prior, post_cov, nu, S, ll, failed, lam, ekf, jacobian):
    r"""One strong-tracking step for the N lanes of a block, batch innermost (:func:`strong_tracking_step`'s body):
    from the prior mb (n, N), Pb (n, n, N), with Fb, Qb (n, n, N), Rb (m, m, N) and zb (m, N), the posterior mean
    ``prior`` (n, N) (overwritten from the predicted mean), ``post_cov`` (n, n, N), ``nu`` (m, N), ``S`` (m, m, N),
    ``ll``, ``failed`` and the fading factor ``lam`` (N,); ``Vb`` (m, m, N) holds the last smoothed innovation outer
    product on entry (read only without ``restart``) and this step's on exit (Eq. 17).  With ``ekf`` the base filter
    is the extended Kalman filter (:func:`_ekf_predict_and_moments`, :func:`_ekf_moments`, :func:`_joseph_update_core`;
    the rule's arguments unused), with ``jacobian`` the fading factor of the Jacobian form
    (:func:`_jacobian_fading`)."""
    n, N = mb.shape
    m = zb.shape[0]
    scale = 1.0 + rho
    Pl = np.empty((n, n, N))
    zp = np.empty((m, N))
    Pxz = np.empty((n, m, N))
    H = np.empty((m, n, N) if ekf else (0, 0, N))
    if ekf:
        _ekf_predict_and_moments(mb, Pb, Fb, Qb, kind, A, idx, sensor, Rb, prior, Pl, zp, S, Pxz, H)
    else:
        _predict_and_moments(mb, Pb, xi, wm, wc, Fb, Qb, kind, A, idx, sensor, angular, Rb, prior, Pl, zp, S, Pxz)
    v = np.empty((m, N))
    _residual_core(zb, zp, angular, v)
    if restart:
        for i in range(m):
            for k in range(m):
                for lane in range(N):
                    Vb[i, k, lane] = v[i, lane] * v[k, lane]
    else:
        for i in range(m):
            for k in range(m):
                for lane in range(N):
                    Vb[i, k, lane] = (rho * Vb[i, k, lane] + v[i, lane] * v[k, lane]) / scale
    if ekf and jacobian:
        _jacobian_fading(H, Pl, Qb, Vb, Rb, beta, lam)
    else:
        _fading_core(Pl, Qb, Pxz, Vb, S, Rb, beta, lam)
    inflate = False
    for lane in range(N):
        inflate = inflate or lam[lane] > 1.0
    if inflate:
        for i in range(n):
            for k in range(n):
                for lane in range(N):
                    if lam[lane] > 1.0:
                        Pl[i, k, lane] = lam[lane] * (Pl[i, k, lane] - Qb[i, k, lane]) + Qb[i, k, lane]
        if ekf:
            _ekf_moments(prior, Pl, kind, A, idx, sensor, Rb, zp, S, Pxz, H)
        else:
            _moments_core(prior, Pl, xi, wm, wc, kind, A, idx, sensor, angular, Rb, zp, S, Pxz)
    _residual_core(zb, zp, angular, nu)
    if ekf:
        _joseph_update_core(prior, Pl, nu, S, Pxz, H, Rb, log_2pi, post_cov, ll, failed)
    else:
        _update_core(prior, Pl, nu, S, Pxz, log_2pi, post_cov, ll, failed)


@njit(**_OPTS)
def strong_tracking_step(mean, cov, xi, wm, wc, F, Q, z, kind, A, idx, sensor, angular, R, V, restart, rho, beta,
                         log_2pi, mean_out, cov_out, ll_out, nu_out, S_out, failed_out, V_out, lam_out, start, stop,
                         block):
    r"""One step of a strong-tracking sigma-point filter on linear dynamics in one call
    (:class:`mmlib.core.layers.strong_tracking.StrongTracking`, the Jacobian-free form, over a plain sigma-point
    filter): the time update to :math:`P^l` (:func:`_predict_core`), the measurement prediction
    (:func:`_moments_core`), the innovation :math:`v`, :math:`V = vv^T` (``restart``) or
    :math:`(\rho V_{k-1} + vv^T)/(1 + \rho)` (Eq. 17), the fading factor :math:`\lambda` (:func:`_fading_core`), and
    where :math:`\lambda > 1` the prior :math:`\lambda(P^l - Q) + Q` (Eq. 28) predicted again (the whole block when one
    of its runs inflates: the others get their own bits again), then the Kalman update (:func:`_update_core`): the
    operations the layer composes, the same bits (:func:`_strong_tracking_core`).  mean (B, n), cov (B, n, n), the
    rule xi (M, n), wm, wc (M,), F (n, n), Q (P, n, n) and R (P', m, m) periodic over the runs, z (B, m), the
    measurement function (:func:`_measure`), V (B, m, m) (read only without ``restart``).  Writes the runs
    start..stop-1 of ``(mean+, cov+, loglik, innovation, S, failed, V, fading)`` into ``mean_out`` ... ``lam_out``
    (B, ...) (:func:`_step_outputs`)."""
    n = mean.shape[1]
    m = z.shape[1]
    for b0 in range(start, stop, block):
        N = min(block, stop - b0)
        mb, Pb, Fb, Qb, Rb, zb = _block_operands(mean, cov, F, Q, R, z, b0, N)
        Vb = np.empty((m, m, N))
        if not restart:
            _lanes(V, b0, N, (1, 0), Vb)
        prior = np.empty((n, N))
        post_cov = np.empty((n, n, N))
        nu = np.empty((m, N))
        S = np.empty((m, m, N))
        ll = np.empty(N)
        failed = np.empty(N, dtype=np.bool_)
        lam = np.empty(N)
        _strong_tracking_core(mb, Pb, xi, wm, wc, Fb, Qb, kind, A, idx, sensor, angular, Rb, zb, Vb, restart, rho,
                              beta, log_2pi, prior, post_cov, nu, S, ll, failed, lam, False, False)
        _store_block(b0, prior, post_cov, ll, nu, S, failed, mean_out, cov_out, ll_out, nu_out, S_out, failed_out)
        for lane in range(N):
            lam_out[b0 + lane] = lam[lane]
        _unlanes(Vb, b0, V_out)


@njit(**_OPTS)
def sigma_step(mean, cov, xi, wm, wc, F, Q, z, kind, A, idx, sensor, angular, R, log_2pi, mean_out, cov_out, ll_out,
               nu_out, S_out, failed_out, start, stop, block):
    r"""One step of a single-model sigma-point filter on linear dynamics in one call (:func:`_filter_step`, the same
    bits as the composed operations), for blocks of ``block`` runs: mean (B, n), cov (B, n, n), rule xi (M, n), wm, wc
    (M,), F (n, n), Q (P, n, n) and R (P', m, m) periodic over the runs, z (B, m), the measurement function
    (:func:`_measure`).  Writes the runs start..stop-1 of ``(mean+, cov+, loglik, innovation, S, failed)`` into
    ``mean_out`` ... ``failed_out`` (B, ...) (:func:`_step_outputs`)."""
    n = mean.shape[1]
    m = z.shape[1]
    for b0 in range(start, stop, block):
        N = min(block, stop - b0)
        mb, Pb, Fb, Qb, Rb, zb = _block_operands(mean, cov, F, Q, R, z, b0, N)
        post_mean = np.empty((n, N))
        post_cov = np.empty((n, n, N))
        nu = np.empty((m, N))
        S = np.empty((m, m, N))
        ll = np.empty(N)
        failed = np.empty(N, dtype=np.bool_)
        _filter_step(mb, Pb, xi, wm, wc, Fb, Qb, Rb, zb, kind, A, idx, sensor, angular, log_2pi, post_mean, post_cov,
                     nu, S, ll, failed)
        _store_block(b0, post_mean, post_cov, ll, nu, S, failed, mean_out, cov_out, ll_out, nu_out, S_out, failed_out)


@njit(**_OPTS)
def imm_sigma_step(mu, T, means, covs, xi, wm, wc, F, Q, z, kind, A, idx, sensor, angular, R, with_cov, log_2pi,
                   means_out, covs_out, mu_out, marginal, underflow, mean_out, cov_out, innov_out, icov_out, failed_out,
                   start, stop, block):
    r"""One whole IMM cycle of a sigma-point filter with linear mode dynamics, fused: what :func:`imm_mix`,
    :func:`sigma_point_predict_linear`, :func:`sigma_points`, the measurement function (:func:`_measure`),
    :func:`measurement_moments`, the residual, :func:`kalman_moments` (the form :math:`P - AA^T`), the
    log-likelihood :math:`-\tfrac12(\nu^TS^{-1}\nu + \log|S| + m\log 2\pi)` and :func:`imm_output` compute in turn,
    by the same loop bodies (``_*_core``), hence the same bits, for blocks of ``block`` runs at a time with every
    intermediate batch innermost: one transposition of the state in and out per step instead of one per operation.

    mu (B, r), T (r, r), means (B, r, n), covs (B, r, n, n), rule xi (M, n), wm, wc (M,), F (r, n, n),
    Q (P, n, n) periodic over the flattened (runs, modes) stack (row ``(b r + j) % P`` for run b, mode j),
    z (B, m), the measurement function ``kind``, A, idx, sensor (:func:`_measure`), angular (m,),
    R (P', m, m) periodic as Q, ``log_2pi`` = log(2 pi) as the numpy path computes it.

    Writes the runs start..stop-1 of ``(means+, covs+, mu+, marginal, underflow, mean, cov, innovation,
    innovation_cov, failed)`` into ``means_out`` ... ``failed_out`` (:func:`_imm_outputs`): the mode filters'
    posteriors (B, r, n), (B, r, n, n), the mode probabilities (B, r), the log marginal likelihood (B,),
    ``underflow`` (B,), the fused estimate (B, n) and covariance (B, n, n) ((B, 0, 0) without ``with_cov``), the
    mixture prior's innovation (B, m) and its covariance (B, m, m), and ``failed`` (B, r): a mode filter whose S or
    posterior covariance has no Cholesky factor (its mean and covariance NaN, its log-likelihood NaN)."""
    r = mu.shape[1]
    n = means.shape[2]
    m = z.shape[1]
    for b0 in range(start, stop, block):
        N = min(block, stop - b0)
        mub, Xb, Pb, Fb = _run_block_start(mu, means, covs, F, b0, N)
        Qb = np.empty((r, n, n, N))
        Rb = np.empty((r, m, m, N))
        for j in range(r):
            _lanes(Q, b0, N, (r, j), Qb[j])
            _lanes(R, b0, N, (r, j), Rb[j])
        zb = np.empty((m, N))
        _lanes(z, b0, N, (1, 0), zb)
        failed = np.empty(N, dtype=np.bool_)
        failed_modes = np.empty((r, N), dtype=np.bool_)
        mu_b, marg, under, fused, fcov, innov, icov, post_mean, post_cov = _imm_cycle(
            mub, T, Xb, Pb, xi, wm, wc, Fb, Qb, Rb, zb, kind, A, idx, sensor, angular, log_2pi, with_cov, failed,
            failed_modes)
        for lane in range(N):
            marginal[b0 + lane] = marg[lane]
            underflow[b0 + lane] = under[lane]
            for j in range(r):
                failed_out[b0 + lane, j] = failed_modes[j, lane]
        _unlanes(mu_b, b0, mu_out)
        _unlanes(post_mean, b0, means_out)
        _unlanes(post_cov, b0, covs_out)
        _unlanes(fused, b0, mean_out)
        if with_cov:
            _unlanes(fcov, b0, cov_out)
        _unlanes(innov, b0, innov_out)
        _unlanes(icov, b0, icov_out)


@njit(**_OPTS)
def _imm_outputs(B, r, n, m, with_cov):
    """The outputs of :func:`imm_sigma_step` for B runs, run axis first: ``(means+ (B, r, n), covs+ (B, r, n, n),
    mu+ (B, r), marginal (B,), underflow (B,), mean (B, n), cov (B, n, n) or (B, 0, 0), innovation (B, m),
    innovation_cov (B, m, m), failed (B, r))``, every run's rows written by the step."""
    return (np.empty((B, r, n)), np.empty((B, r, n, n)), np.empty((B, r)), np.empty(B), np.zeros(B, dtype=np.bool_),
            np.empty((B, n)), np.empty((B, n, n) if with_cov else (B, 0, 0)), np.empty((B, m)), np.empty((B, m, m)),
            np.zeros((B, r), dtype=np.bool_))


# --------------------------------------------------------------------------- whole runs: every step of a block of runs
@njit(**_OPTS)
def _nsq_lanes(v, S, out):
    r""":math:`v^T S^{-1} v` for each lane of v (d, N) and S (d, d, N) into out (N,): for every lane the operations
    :func:`normalised_square` does for that run (the same bits)."""
    d, N = v.shape
    A = np.empty((d, d))
    x = np.empty((d, 1))
    for b in range(N):
        for i in range(d):
            x[i, 0] = v[i, b]
            for j in range(d):
                A[i, j] = S[i, j, b]
        out[b] = _quadratic(A, x)


@njit(**_OPTS)
def _step_measurement(k, z, zoff, A, R, angular, b0, N):
    """The measurement operands of step k for the N lanes of a block starting at run b0: ``(zb (m, N), A_k, Rb (m, m,
    N), angular_k)`` from the packed steps -- z (B, sum m_k), A (sum m_k, a) and R (sum m_k, max m_k) with step k's
    rows zoff[k]..zoff[k+1]-1, angular (sum m_k,) -- R_k copied into every lane (one R per step, shared by the runs)."""
    lo, hi = zoff[k], zoff[k + 1]
    m = hi - lo
    zb = np.empty((m, N))
    for i in range(m):
        for lane in range(N):
            zb[i, lane] = z[b0 + lane, lo + i]
    Rb = np.empty((m, m, N))
    for i in range(m):
        for j in range(m):
            Rb[i, j, :] = R[lo + i, j]
    # copies, C-contiguous as sigma_step's operands: the step's cores then run as compiled for it (no other layout)
    return zb, A[lo:hi].copy(), Rb, angular[lo:hi].copy()


@njit(**_OPTS)
def _store_step(src, b0, k, out):
    """Step k of the runs b0.. of ``out`` (B, K, ...) (C-contiguous) <- the lanes of ``src`` (..., N)."""
    N = src.shape[-1]
    s = src.reshape((src.size // N, N))
    q = s.shape[0]
    o = out.reshape((out.shape[0], out.shape[1], q))
    for i in range(q):
        for lane in range(N):
            o[b0 + lane, k, i] = s[i, lane]


@njit(**_OPTS)
def _consistency_step(k, b0, mean, cov, nu, S, nis_on, truth, nis_out, nees_out):
    """The NIS of step k (``nu`` (m, N), ``S`` (m, m, N)) when ``nis_on`` and, when ``truth`` (B, K, n) is given (not
    empty), the NEES of ``mean`` (n, N) and ``cov`` (n, n, N) against truth[:, k], for the lanes of the runs b0..:
    what ``run(..., consistency=True)`` computes per step with :func:`normalised_square`."""
    n, N = mean.shape
    if nis_on:
        out = np.empty(N)
        _nsq_lanes(nu, S, out)
        for lane in range(N):
            nis_out[b0 + lane, k] = out[lane]
    if truth.shape[0] > 0:
        err = np.empty((n, N))
        for i in range(n):
            for lane in range(N):
                err[i, lane] = mean[i, lane] - truth[b0 + lane, k, i]
        out = np.empty(N)
        _nsq_lanes(err, cov, out)
        for lane in range(N):
            nees_out[b0 + lane, k] = out[lane]


@njit(**_OPTS)
def _single_block_start(mean, cov, F, Q, b0, N):
    """The state and dynamics of a block of N runs from run b0, batch innermost, at the start of a single model's run:
    ``(mb (n, N), Pb (n, n, N), Fb (n, n, N), Qb (n, n, N))``, the one F copied into every lane, Q periodic."""
    n = mean.shape[1]
    mb = np.empty((n, N))
    Pb = np.empty((n, n, N))
    _lanes(mean, b0, N, (1, 0), mb)
    _lanes(cov, b0, N, (1, 0), Pb)
    Fb = np.empty((n, n, N))
    for i in range(n):
        for j in range(n):
            Fb[i, j, :] = F[i, j]
    Qb = np.empty((n, n, N))
    _lanes(Q, b0, N, (1, 0), Qb)
    return mb, Pb, Fb, Qb


@njit(**_OPTS)
def _store_single_step(k, b0, mean, cov, nu, S, failed, keep_cov, nis_on, truth, mean_out, cov_out, failed_out,
                       nis_out, nees_out):
    """A single model's outputs of step k for the lanes of the runs b0..: the posterior mean (and covariance with
    ``keep_cov``), failed, the NIS and NEES (:func:`_consistency_step`)."""
    _store_step(mean, b0, k, mean_out)
    if keep_cov:
        _store_step(cov, b0, k, cov_out)
    for lane in range(failed.shape[0]):
        failed_out[b0 + lane, k] = failed[lane]
    _consistency_step(k, b0, mean, cov, nu, S, nis_on, truth, nis_out, nees_out)


@njit(**_OPTS)
def sigma_run(mean, cov, xi, wm, wc, F, Q, z, zoff, kind, A, idx, sensor, angular, R, log_2pi, ekf, truth, nis_on,
              keep_cov, mean_out, cov_out, failed_out, nis_out, nees_out, start, stop, block):
    r"""Every step of a single-model sigma-point filter on linear dynamics over K packed measurement steps, for blocks
    of ``block`` runs: step k is :func:`sigma_step`'s body (:func:`_filter_step`) on the posterior of step k - 1, the
    state kept batch innermost from step to step, hence the bits of K calls of :func:`sigma_step`.

    mean (B, n), cov (B, n, n), the rule xi, wm, wc, F (n, n), Q (P, n, n) periodic over the runs; the measurements of
    step k z[:, zoff[k]:zoff[k+1]] of z (B, sum m_k), with the rows zoff[k]..zoff[k+1]-1 of A (the measurement
    function's matrix, :func:`_measure` ``kind``, ``idx``, ``sensor``), of R (sum m_k, max m_k) (step k's R, shared by
    the runs) and of angular (sum m_k,).  ``truth`` (B, K, n) for the NEES or (0, 0, 0), ``nis_on`` for the NIS.
    Writes, for the runs start..stop-1: the posterior means mean_out (B, K, n), covariances cov_out (B, K, n, n) (if
    ``keep_cov``), ``failed_out`` (B, K) (:func:`_filter_step`), nis_out and nees_out (B, K) (when computed).  With
    ``ekf`` the filter is the extended Kalman filter instead (:func:`_ekf_step`; the rule's arguments unused)."""
    n = mean.shape[1]
    K = zoff.shape[0] - 1
    for b0 in range(start, stop, block):
        N = min(block, stop - b0)
        mb, Pb, Fb, Qb = _single_block_start(mean, cov, F, Q, b0, N)
        ll = np.empty(N)
        failed = np.empty(N, dtype=np.bool_)
        for k in range(K):
            zb, Ak, Rb, ang = _step_measurement(k, z, zoff, A, R, angular, b0, N)
            m = zb.shape[0]
            post_mean = np.empty((n, N))
            post_cov = np.empty((n, n, N))
            nu = np.empty((m, N))
            S = np.empty((m, m, N))
            if ekf:
                _ekf_step(mb, Pb, Fb, Qb, Rb, zb, kind, Ak, idx, sensor, ang, log_2pi, post_mean, post_cov, nu, S, ll,
                          failed)
            else:
                _filter_step(mb, Pb, xi, wm, wc, Fb, Qb, Rb, zb, kind, Ak, idx, sensor, ang, log_2pi, post_mean,
                             post_cov, nu, S, ll, failed)
            _store_single_step(k, b0, post_mean, post_cov, nu, S, failed, keep_cov, nis_on, truth, mean_out, cov_out,
                               failed_out, nis_out, nees_out)
            mb, Pb = post_mean, post_cov


@njit(**_OPTS)
def _imm_cycle(mub, T, Xb, Pb, xi, wm, wc, Fb, Qb, Rb, zb, kind, A, idx, sensor, angular, log_2pi, with_cov, failed,
               failed_modes):
    r"""One IMM cycle for the N lanes of a block, batch innermost: mixing (:func:`_mix_core`) of mub (r, N), Xb
    (r, n, N), Pb (r, n, n, N), every mode's filter step (:func:`_filter_step`; Fb, Qb (r, n, n, N) per mode, Rb
    (P, m, m, N) mode j's at row j % P, zb (m, N) shared), the output (:func:`_output_core`): the body of
    :func:`imm_sigma_step` and of the whole runs.  ``failed_modes`` (r, N) becomes which mode filters failed and
    ``failed`` (N,) whether some did.  Returns ``(mu (1, r, N), marginal (N,), underflow (N,), fused (1, n, N), fcov
    (1, n, n, N) or (1, 0, 0, N), innovation (1, m, N), its covariance (1, m, m, N), the modes' posterior means
    (r, n, N) and covariances (r, n, n, N))``."""
    r, n, N = Xb.shape
    m = zb.shape[0]
    c = np.empty((1, r, N))
    mm = np.empty((r, n, N))
    mc = np.empty((r, n, n, N))
    _mix_core(mub, T, Xb, Pb, c[0], mm, mc)
    ll = np.empty((r, N))
    post_mean = np.empty((r, n, N))
    post_cov = np.empty((r, n, n, N))
    nu = np.empty((r, m, N))
    S = np.empty((r, m, m, N))
    failed[:] = False
    for j in range(r):
        _filter_step(mm[j], mc[j], xi, wm, wc, Fb[j], Qb[j], Rb[j % Rb.shape[0]], zb, kind, A, idx, sensor, angular,
                     log_2pi, post_mean[j], post_cov[j], nu[j], S[j], ll[j], failed_modes[j])
        for lane in range(N):
            failed[lane] = failed[lane] or failed_modes[j, lane]
    mu_b, marg, under, fused, fcov, innov, icov = _output_buffers(r, n, m, N, with_cov)
    _output_core(ll, c, post_mean, post_cov, nu, S, with_cov, mu_b, marg, under, fused, fcov, innov, icov)
    return mu_b, marg, under, fused, fcov, innov, icov, post_mean, post_cov


@njit(**_OPTS)
def _run_block_start(mu, means, covs, F, b0, N):
    """The state of a block of N runs from run b0, batch innermost, at the start of an IMM run: ``(mub (r, N),
    Xb (r, n, N), Pb (r, n, n, N), Fb (r, n, n, N))``, each mode's F copied into every lane."""
    r, n = mu.shape[1], means.shape[2]
    mub = np.empty((r, N))
    Xb = np.empty((r, n, N))
    Pb = np.empty((r, n, n, N))
    _lanes(mu, b0, N, (1, 0), mub)
    _lanes(means, b0, N, (1, 0), Xb)
    _lanes(covs, b0, N, (1, 0), Pb)
    Fb = np.empty((r, n, n, N))
    for j in range(r):
        for i in range(n):
            for q in range(n):
                Fb[j, i, q, :] = F[j, i, q]
    return mub, Xb, Pb, Fb


@njit(**_OPTS)
def _imm_block_start(mu, means, covs, F, Q, b0, N):
    """:func:`_run_block_start` and each mode's Q (r, n, n, N), Q (P, n, n) periodic over the flattened (runs, modes)
    stack: ``(mub, Xb, Pb, Fb, Qb)``."""
    r, n = mu.shape[1], means.shape[2]
    mub, Xb, Pb, Fb = _run_block_start(mu, means, covs, F, b0, N)
    Qb = np.empty((r, n, n, N))
    for j in range(r):
        _lanes(Q, b0, N, (r, j), Qb[j])
    return mub, Xb, Pb, Fb, Qb


@njit(**_OPTS)
def _store_imm_step(k, b0, under, fused, fcov, innov, icov, mu_b, failed, keep_cov, nis_on, truth, mean_out, cov_out,
                    mu_out, failed_out, underflow_out, nis_out, nees_out):
    """An IMM cycle's outputs of step k for the lanes of the runs b0..: the fused estimate (and covariance with
    ``keep_cov``), the mode probabilities, failed, underflow, the NIS and NEES (:func:`_consistency_step`)."""
    N = failed.shape[0]
    _store_step(fused[0], b0, k, mean_out)
    if keep_cov:
        _store_step(fcov[0], b0, k, cov_out)
    _store_step(mu_b[0], b0, k, mu_out)
    for lane in range(N):
        failed_out[b0 + lane, k] = failed[lane]
        underflow_out[b0 + lane, k] = under[lane]
    _consistency_step(k, b0, fused[0], fcov[0], innov[0], icov[0], nis_on, truth, nis_out, nees_out)


@njit(**_OPTS)
def imm_sigma_run(mu, T, means, covs, xi, wm, wc, F, Q, z, zoff, kind, A, idx, sensor, angular, R, with_cov, log_2pi,
                  truth, nis_on, keep_cov, mean_out, cov_out, mu_out, failed_out, underflow_out, nis_out, nees_out,
                  start, stop, block):
    r"""Every IMM cycle of a sigma-point filter with linear mode dynamics over K packed measurement steps, for blocks
    of ``block`` runs: cycle k is :func:`imm_sigma_step`'s body (:func:`_imm_cycle`) on the mode probabilities and mode
    posteriors of cycle k - 1, kept batch innermost from step to step, hence the bits of K calls of
    :func:`imm_sigma_step`.

    mu (B, r), T (r, r), means (B, r, n), covs (B, r, n, n), the rule, F (r, n, n), Q (P, n, n) periodic over the
    flattened (runs, modes) stack, the packed measurement steps z, zoff, A, R, angular (:func:`sigma_run`), the
    measurement function ``kind``, ``idx``, ``sensor``; ``with_cov`` the fused covariance; truth, nis_on as
    :func:`sigma_run`.  Writes, for the runs start..stop-1: the fused means mean_out (B, K, n), covariances cov_out
    (B, K, n, n) (if ``keep_cov``), the mode probabilities mu_out (B, K, r), ``failed_out`` (B, K) (some mode filter
    failed), ``underflow_out`` (B, K) (every mode's likelihood underflowed), nis_out and nees_out (B, K) (when
    computed: the NIS of the mixture prior's innovation, the NEES of the fused estimate)."""
    r = mu.shape[1]
    K = zoff.shape[0] - 1
    for b0 in range(start, stop, block):
        N = min(block, stop - b0)
        mub, Xb, Pb, Fb, Qb = _imm_block_start(mu, means, covs, F, Q, b0, N)
        failed = np.empty(N, dtype=np.bool_)
        failed_modes = np.empty((r, N), dtype=np.bool_)
        for k in range(K):
            zb, Ak, Rb, ang = _step_measurement(k, z, zoff, A, R, angular, b0, N)
            mu_b, _, under, fused, fcov, innov, icov, post_mean, post_cov = _imm_cycle(
                mub, T, Xb, Pb, xi, wm, wc, Fb, Qb, Rb.reshape((1,) + Rb.shape), zb, kind, Ak, idx, sensor, ang,
                log_2pi, with_cov, failed, failed_modes)
            _store_imm_step(k, b0, under, fused, fcov, innov, icov, mu_b, failed, keep_cov, nis_on, truth, mean_out,
                            cov_out, mu_out, failed_out, underflow_out, nis_out, nees_out)
            mub, Xb, Pb = mu_b[0], post_mean, post_cov


@njit(**_OPTS)
def strong_tracking_run(mean, cov, xi, wm, wc, F, Q, z, zoff, kind, A, idx, sensor, angular, R, V, restart, rho, beta,
                        log_2pi, ekf, jacobian, truth, nis_on, keep_cov, mean_out, cov_out, failed_out, nis_out,
                        nees_out, start, stop, block):
    r"""Every step of a strong-tracking sigma-point filter on linear dynamics over K packed measurement steps, for
    blocks of ``block`` runs: step k is :func:`strong_tracking_step`'s body (:func:`_strong_tracking_core`) on step
    k - 1's posterior and smoothed innovation outer product V, which restarts (Eq. 17, :math:`V = vv^T`) at the first
    step when ``restart`` and wherever the measurement dimension changes, as the layer restarts it: the bits of K
    calls of :func:`strong_tracking_step`.  mean ... R, truth, nis_on, keep_cov and the outputs as
    :func:`sigma_run`; V (B, m_0, m_0) the state's V (read only without ``restart``), ``rho`` and ``beta`` the
    layer's forgetting and softening factors; ``ekf``: over the extended Kalman filter instead (the rule unused), and
    ``jacobian`` its fading factor's Jacobian form."""
    n = mean.shape[1]
    K = zoff.shape[0] - 1
    for b0 in range(start, stop, block):
        N = min(block, stop - b0)
        mb, Pb, Fb, Qb = _single_block_start(mean, cov, F, Q, b0, N)
        m0 = zoff[1] - zoff[0]
        Vb = np.empty((m0, m0, N))
        if not restart:
            _lanes(V, b0, N, (1, 0), Vb)
        ll = np.empty(N)
        failed = np.empty(N, dtype=np.bool_)
        lam = np.empty(N)
        for k in range(K):
            zb, Ak, Rb, ang = _step_measurement(k, z, zoff, A, R, angular, b0, N)
            m = zb.shape[0]
            fresh = restart if k == 0 else m != Vb.shape[0]
            if fresh and m != Vb.shape[0]:
                Vb = np.empty((m, m, N))
            post_mean = np.empty((n, N))
            post_cov = np.empty((n, n, N))
            nu = np.empty((m, N))
            S = np.empty((m, m, N))
            _strong_tracking_core(mb, Pb, xi, wm, wc, Fb, Qb, kind, Ak, idx, sensor, ang, Rb, zb, Vb, fresh, rho,
                                  beta, log_2pi, post_mean, post_cov, nu, S, ll, failed, lam, ekf, jacobian)
            _store_single_step(k, b0, post_mean, post_cov, nu, S, failed, keep_cov, nis_on, truth, mean_out, cov_out,
                               failed_out, nis_out, nees_out)
            mb, Pb = post_mean, post_cov


@njit(**_OPTS)
def _gram_core(U, k0, k1, out):
    r""":math:`\sum_t U_t^T U_t` over the rows t = k0..k1-1 of U (K, m, N), batch innermost, into out (m, m, N): each
    entry summed over t in order, one fused multiply-add per term from 0, then added to 0 -- how OpenBLAS's ``syrk``
    kernels for AVX2 CPUs (Haswell and later, the reference machine's) sum the product numpy's ``@`` hands them
    (:func:`mmlib.core.linalg.gram`), and its ``gemm`` kernels for most shapes (not the one for a last odd row)."""
    m, N = U.shape[1], U.shape[2]
    for i in range(m):
        for j in range(m):
            acc = out[i, j]
            acc[:] = 0.0
            for t in range(k0, k1):
                ui = U[t, i]
                uj = U[t, j]
                for b in range(N):
                    acc[b] = _fma(ui[b], uj[b], acc[b])
            for b in range(N):
                acc[b] = acc[b] + 0.0


@njit(**_OPTS)
def gram(U):
    r""":math:`U^T U` for a stack U (N, K, m) -> (N, m, m) (:func:`_gram_core`)."""
    N, K, m = U.shape
    out = np.empty((m, m, N))
    _gram_core(_inner(U, N), 0, K, out)
    return _outer(out)


@njit(**_OPTS)
def _psd_part_lane(D, out):
    r"""The positive semi-definite part :math:`V\max(\Lambda, 0)V^T` of the symmetric D (m, m) into out (m, m): numpy's
    ``eigh`` (LAPACK ``syevd``, lower triangle; numba calls the LAPACK of scipy), the eigenvalues clipped at 0 (+0
    for -0), each column of V scaled by its eigenvalue, then the product with :math:`V^T` summed as
    :func:`_gram_core` sums (OpenBLAS's ``gemm`` on AVX2 CPUs for most shapes).  A D whose lower triangle (what
    ``eigh`` reads) is not finite gives NaN (a failed run, reported by the caller), as :func:`mmlib.core.linalg.
    psd_part` says.  D is a scratch copy: its upper triangle is overwritten by the lower one."""
    m = D.shape[0]
    for i in range(m):
        for j in range(i + 1):
            if not np.isfinite(D[i, j]):
                out[:, :] = np.nan
                return
            D[j, i] = D[i, j]               # the upper triangle, which LAPACK does not read, mirrored (numba checks it)
    w, v = np.linalg.eigh(D)
    a = np.empty((m, m))
    for k in range(m):
        c = w[k] if w[k] > 0.0 else 0.0
        for i in range(m):
            a[i, k] = v[i, k] * c
    for i in range(m):
        for j in range(m):
            acc = 0.0
            for k in range(m):
                acc = _fma(a[i, k], v[j, k], acc)
            out[i, j] = acc + 0.0


@njit(**_OPTS)
def psd_part(D):
    r""":func:`_psd_part_lane` of each matrix of a stack D (N, m, m) of symmetric matrices -> (N, m, m)."""
    N, m = D.shape[0], D.shape[1]
    out = np.empty((N, m, m))
    Dc = np.empty((m, m))
    for b in range(N):
        for i in range(m):
            for j in range(m):
                Dc[i, j] = D[b, i, j]
        _psd_part_lane(Dc, out[b])
    return out


@njit(**_OPTS)
def _diagonal_sum(M, lane, tmp):
    """The sum of the diagonal of lane ``lane`` of M (m, m, N) in numpy's order (``np.trace``: :func:`_numpy_sum`)."""
    m = M.shape[0]
    for i in range(m):
        tmp[i] = M[i, i, lane]
    return _numpy_sum(tmp, 0, m)


@njit(**_OPTS)
def _adaptive_core(mb, Pb, xi, wm, wc, Fb, Qb, kind, A, idx, sensor, angular, Rb, zb, past, n_past, window, psi,
                   zeta_on, include_current, inflate_only, log_2pi, prior, post_cov, nu, S_used, ll, failed, now):
    r"""One step of the innovation-adaptive layer (:class:`mmlib.core.layers.adaptive.InnovationAdaptive`) over a
    sigma-point filter on linear dynamics for the N lanes of a block, batch innermost: the time update and the
    measurement prediction (:func:`_predict_and_moments`), the innovation ``nu`` (m, N), the window ``now`` (rows
    0..n_now-1, oldest first) of the last ``window`` innovations -- the ``n_past`` rows of ``past`` (W, m, N) then
    ``nu`` --, and with ``window`` innovations in the window used (``now``, or ``past`` without ``include_current``)
    their mean outer product :math:`\hat C` (:func:`_gram_core`, divided by their count) as the innovation
    covariance (Eqs. 27-28; ``inflate_only``: S plus the PSD part of :math:`\hat C - S`, :func:`_psd_part_lane`); with
    ``zeta_on``, where :math:`\nu^T\nu > \psi\,\mathrm{tr}S`, the prior :math:`\zeta(P - Q) + Q` with
    :math:`\zeta = \max(1, \mathrm{tr}(\hat C - R)/\mathrm{tr}(P - Q))` (NaN read as 1, infinities as the largest
    floats, as ``np.nan_to_num``; Eqs. 32-35); then the Kalman update (:func:`_update_core`) with that covariance
    ``S_used`` (m, m, N).  The layer's update, the same bits.  Returns ``n_now``.  A lane whose :math:`\hat C - S` is
    not finite (a failed run) gets a NaN innovation covariance with ``inflate_only``, hence a failed update."""
    n, N = mb.shape
    m = zb.shape[0]
    Pl = np.empty((n, n, N))
    zp = np.empty((m, N))
    S = np.empty((m, m, N))
    Pxz = np.empty((n, m, N))
    _predict_and_moments(mb, Pb, xi, wm, wc, Fb, Qb, kind, A, idx, sensor, angular, Rb, prior, Pl, zp, S, Pxz)
    _residual_core(zb, zp, angular, nu)
    first = max(0, n_past + 1 - window)
    n_now = n_past + 1 - first
    for t in range(first, n_past):
        now[t - first, :, :] = past[t]
    now[n_now - 1, :, :] = nu
    have = n_now if include_current else n_past
    if have < window:                                   # not enough innovations yet: the base filter's update
        S_used[:, :, :] = S
        _update_core(prior, Pl, nu, S, Pxz, log_2pi, post_cov, ll, failed)
        return n_now
    used = now if include_current else past
    _gram_core(used, 0, have, S_used)
    for i in range(m):
        for j in range(m):
            for lane in range(N):
                S_used[i, j, lane] = S_used[i, j, lane] / have          # C, Eqs. 27-28: S_bar = C
    tmp = np.empty(max(m, n))
    if zeta_on:
        tr_c = np.empty(N)
        d = np.empty((m, m, N))
        for i in range(m):
            for j in range(m):
                for lane in range(N):
                    d[i, j, lane] = S_used[i, j, lane] - Rb[i, j, lane]
        for lane in range(N):
            tr_c[lane] = _diagonal_sum(d, lane, tmp)                     # tr(C - R), before C is modified
    if inflate_only:
        D = np.empty((m, m))
        P = np.empty((m, m))
        for lane in range(N):
            for i in range(m):
                for j in range(m):
                    D[i, j] = S_used[i, j, lane] - S[i, j, lane]
            _psd_part_lane(D, P)
            for i in range(m):
                for j in range(m):
                    S_used[i, j, lane] = S[i, j, lane] + P[i, j]
    if zeta_on:
        for lane in range(N):
            for i in range(m):
                tmp[i] = nu[i, lane] * nu[i, lane]
            tr_nu = _numpy_sum(tmp, 0, m)
            matched = tr_nu <= psi * _diagonal_sum(S, lane, tmp)                       # Eq. 32
            for i in range(n):
                tmp[i] = Pl[i, i, lane] - Qb[i, i, lane]
            z0 = tr_c[lane] / _numpy_sum(tmp, 0, n)                                    # Eq. 35
            if z0 != z0:
                z0 = 1.0
            elif z0 == np.inf:
                z0 = 1.7976931348623157e308
            elif z0 == -np.inf:
                z0 = -1.7976931348623157e308
            zeta = 1.0 if matched else (z0 if z0 > 1.0 else 1.0)                       # Eq. 34
            if zeta > 1.0:
                for i in range(n):
                    for j in range(n):
                        Pl[i, j, lane] = zeta * (Pl[i, j, lane] - Qb[i, j, lane]) + Qb[i, j, lane]
    _update_core(prior, Pl, nu, S_used, Pxz, log_2pi, post_cov, ll, failed)
    return n_now


@njit(**_OPTS)
def adaptive_run(mean, cov, xi, wm, wc, F, Q, z, zoff, kind, A, idx, sensor, angular, R, window, psi, zeta_on,
                 include_current, inflate_only, log_2pi, truth, nis_on, keep_cov, mean_out, cov_out, failed_out,
                 nis_out, nees_out, start, stop, block):
    r"""Every step of an innovation-adaptive sigma-point filter (NAUKF / IAE-AUKF,
    :class:`mmlib.core.layers.adaptive.InnovationAdaptive`) on linear dynamics over K packed measurement steps, for
    blocks of ``block`` runs: step k is :func:`_adaptive_core` on step k - 1's posterior and innovation window, which
    starts empty and restarts wherever the measurement dimension changes, as the layer's does: the bits of the
    layer's steps.  mean ... R, truth, nis_on, keep_cov and the outputs as :func:`sigma_run` (the NIS with the
    covariance the update used); ``window``, ``psi``, ``zeta_on``, ``include_current``, ``inflate_only`` the
    layer's."""
    n = mean.shape[1]
    K = zoff.shape[0] - 1
    for b0 in range(start, stop, block):
        N = min(block, stop - b0)
        mb, Pb, Fb, Qb = _single_block_start(mean, cov, F, Q, b0, N)
        ll = np.empty(N)
        failed = np.empty(N, dtype=np.bool_)
        m_cur = -1
        n_past = 0
        cap = min(window, K)                # the innovations a window can hold in this run
        past = np.empty((cap, 1, N))
        now = np.empty((cap, 1, N))
        for k in range(K):
            zb, Ak, Rb, ang = _step_measurement(k, z, zoff, A, R, angular, b0, N)
            m = zb.shape[0]
            if m != m_cur:                  # the measurement set changed dimension: the window starts again
                past = np.empty((cap, m, N))
                now = np.empty((cap, m, N))
                n_past = 0
                m_cur = m
            post_mean = np.empty((n, N))
            post_cov = np.empty((n, n, N))
            nu = np.empty((m, N))
            S = np.empty((m, m, N))
            n_now = _adaptive_core(mb, Pb, xi, wm, wc, Fb, Qb, kind, Ak, idx, sensor, ang, Rb, zb, past, n_past, window,
                                   psi, zeta_on, include_current, inflate_only, log_2pi, post_mean, post_cov, nu, S, ll,
                                   failed, now)
            _store_single_step(k, b0, post_mean, post_cov, nu, S, failed, keep_cov, nis_on, truth, mean_out, cov_out,
                               failed_out, nis_out, nees_out)
            mb, Pb = post_mean, post_cov
            past, now = now, past
            n_past = n_now


@njit(**_OPTS)
def _congruence_core(Ab, Pb, add, out, PAt):
    r""":func:`congruence`'s body, batch innermost: Ab (d, n, N), Pb (n, n, N), add (d, d, N) -> out (d, d, N) =
    add + A(PA^T) and PAt (n, d, N) = PA^T, each sum in index order."""
    d, n, N = Ab.shape
    for i in range(n):
        for j in range(d):
            for b in range(N):
                PAt[i, j, b] = 0.0
            for k in range(n):
                for b in range(N):
                    PAt[i, j, b] += Pb[i, k, b] * Ab[j, k, b]
    for i in range(d):
        for j in range(d):
            for b in range(N):
                out[i, j, b] = add[i, j, b]
            for k in range(n):
                for b in range(N):
                    out[i, j, b] += Ab[i, k, b] * PAt[k, j, b]


@njit(**_OPTS)
def _jacobian(mean, kind, A, idx, sensor, H):
    r"""The measurement Jacobian H (m, n, N) at the means (n, N), as the models' ``jacobian`` computes it: ``kind`` 0
    the matrix A itself; 1 range and bearing of the position components idx[0], idx[1] seen from ``sensor``
    (:meth:`mmlib.core.models.RangeBearing.jacobian`); 2 pseudoranges to the satellites A (m, 3) with the clock bias
    idx[3] (:meth:`mmlib.core.gnss.Pseudoranges.jacobian`: the lines of sight summed as :func:`_measure` sums them)."""
    m, n, N = H.shape
    H[:, :, :] = 0.0
    if kind == 0:
        for c in range(m):
            for j in range(n):
                H[c, j, :] = A[c, j]
    elif kind == 1:
        i0, i1 = idx[0], idx[1]
        for b in range(N):
            dx = mean[i0, b] - sensor[0]
            dy = mean[i1, b] - sensor[1]
            r2 = dx * dx + dy * dy
            r = math.sqrt(r2)
            H[0, i0, b] = dx / r
            H[0, i1, b] = dy / r
            H[1, i0, b] = -dy / r2
            H[1, i1, b] = dx / r2
    else:
        for c in range(m):
            for b in range(N):
                d0 = A[c, 0] - mean[idx[0], b]
                d1 = A[c, 1] - mean[idx[1], b]
                d2 = A[c, 2] - mean[idx[2], b]
                r = math.sqrt((d0 * d0 + d1 * d1) + d2 * d2)
                H[c, idx[0], b] = -d0 / r
                H[c, idx[1], b] = -d1 / r
                H[c, idx[2], b] = -d2 / r
                H[c, idx[3], b] = 1.0


@njit(**_OPTS)
def _ekf_moments(mean, Pl, kind, A, idx, sensor, Rb, zp, S, Pxz, H):
    r"""The extended Kalman filter's measurement prediction (:meth:`mmlib.core.filters.ExtendedKalmanFilter.
    predict_measurement`) at the means (n, N) with the covariances Pl (n, n, N), batch innermost, as its compiled
    operations compute it: the Jacobian H (m, n, N) (:func:`_jacobian`), the predicted measurement zp (m, N)
    (:func:`_measure` of the mean), :math:`S = R + H(PH^T)` (m, m, N) and :math:`P_{xz} = PH^T` (n, m, N)
    (:func:`congruence`)."""
    n, N = mean.shape
    m = zp.shape[0]
    _jacobian(mean, kind, A, idx, sensor, H)
    Z = np.empty((1, m, N))
    _measure(mean.reshape((1, n, N)), kind, A, idx, sensor, Z)
    zp[:, :] = Z[0]
    _congruence_core(H, Pl, Rb, S, Pxz)


@njit(**_OPTS)
def _ekf_predict_and_moments(mb, Pb, Fb, Qb, kind, A, idx, sensor, Rb, prior, Pl, zp, S, Pxz, H):
    r"""The extended Kalman filter's time update on linear dynamics, :math:`(Fm, F(PF^T) + Q)`
    (:func:`linear_predict`: the prior ``prior`` (n, N) and ``Pl`` (n, n, N)), then its measurement prediction
    (:func:`_ekf_moments`), batch innermost."""
    n, N = mb.shape
    _linear_mean_core(Fb, mb, prior)
    PFt = np.empty((n, n, N))
    _congruence_core(Fb, Pb, Qb, Pl, PFt)
    _ekf_moments(prior, Pl, kind, A, idx, sensor, Rb, zp, S, Pxz, H)


@njit(**_OPTS)
def _joseph_update_core(mean, Pm, nu, S, Pxz, H, Rb, log_2pi, cov, ll, failed):
    r""":func:`_update_core` in the Joseph form (H (m, n, N) and Rb (m, m, N): :func:`kalman_moments` with H), as
    :func:`mmlib.core.filters.kalman_update` computes it for the extended Kalman filter; with H of shape (0, 0, N) the
    form :math:`P - AA^T` (:func:`_update_core`)."""
    m, N = nu.shape
    nis = np.empty(N)
    logdet = np.empty(N)
    _kalman_core(mean, Pm, nu, S, Pxz, H, Rb, H.shape[0] > 0, cov, nis, logdet, failed)
    _nan_lanes(mean, failed)
    _nan_lanes(cov, failed)
    for lane in range(N):
        ll[lane] = np.nan if failed[lane] else -0.5 * (nis[lane] + logdet[lane] + m * log_2pi)


@njit(**_OPTS)
def _jacobian_fading(H, Pl, Qb, Vb, Rb, beta, lam):
    r"""The strong-tracking fading factor of the Jacobian form (Liu & Wu 2017, Eqs. 15-16; the layer's
    ``fading_factor`` with ``form="jacobian"``, :func:`mmlib.core.linalg.jacobian_fading_factor`), batch innermost:
    the diagonals of :math:`N = (V - (HQ)H^T) - \beta R` and :math:`M = (H(P^l - Q))H^T`, each product summed in order
    with one fused multiply-add per term from 0, then + 0 (as OpenBLAS's ``gemm`` on AVX2 CPUs for most shapes, not
    its kernel for a last odd row), their traces in numpy's order
    (:func:`_numpy_sum`), :math:`\lambda = \max(1, \mathrm{tr}N/\mathrm{tr}M)` (1 where tr M is not > 0; NaN where the
    ratio is, as ``np.maximum``).  H (m, n, N), Pl, Qb (n, n, N), Vb, Rb (m, m, N) -> lam (N,)."""
    m, n, N = H.shape
    hq = np.empty(n)
    hd = np.empty(n)
    dn = np.empty(m)
    dm = np.empty(m)
    for b in range(N):
        for c in range(m):
            for k in range(n):
                a1 = 0.0
                a2 = 0.0
                for q in range(n):
                    a1 = _fma(H[c, q, b], Qb[q, k, b], a1)
                    a2 = _fma(H[c, q, b], Pl[q, k, b] - Qb[q, k, b], a2)
                hq[k] = a1 + 0.0
                hd[k] = a2 + 0.0
            a1 = 0.0
            a2 = 0.0
            for k in range(n):
                a1 = _fma(hq[k], H[c, k, b], a1)
                a2 = _fma(hd[k], H[c, k, b], a2)
            dn[c] = (Vb[c, c, b] - (a1 + 0.0)) - beta * Rb[c, c, b]
            dm[c] = a2 + 0.0
        tr_n = _numpy_sum(dn, 0, m)
        tr_m = _numpy_sum(dm, 0, m)
        ratio = tr_n / tr_m if tr_m > 0.0 else 1.0
        lam[b] = ratio if (ratio > 1.0 or ratio != ratio) else 1.0


@njit(**_OPTS)
def jacobian_fading_factor(H, Pl, Q, V, R, beta):
    r""":func:`_jacobian_fading` for a stack of N runs: H (N, m, n), Pl (N, n, n), Q (P, n, n) and R (P', m, m) periodic
    over the runs, V (N, m, m) -> lam (N,)."""
    N = H.shape[0]
    lam = np.empty(N)
    _jacobian_fading(_inner(H, N), _inner(Pl, N), _inner(Q, N), _inner(V, N), _inner(R, N), beta, lam)
    return lam


@njit(**_OPTS)
def _ekf_step(mb, Pb, Fb, Qb, Rb, zb, kind, A, idx, sensor, angular, log_2pi, mean, cov, nu, S, ll, failed):
    r"""One step of the extended Kalman filter (:class:`mmlib.core.filters.ExtendedKalmanFilter`) on linear dynamics,
    batch innermost, as its composed operations compute it: the time update and the measurement prediction
    (:func:`_ekf_predict_and_moments`), the residual and the Joseph-form Kalman update (:func:`_joseph_update_core`).
    Outputs as :func:`_filter_step`."""
    n, N = mb.shape
    m = zb.shape[0]
    Pl = np.empty((n, n, N))
    zp = np.empty((m, N))
    Pxz = np.empty((n, m, N))
    H = np.empty((m, n, N))
    _ekf_predict_and_moments(mb, Pb, Fb, Qb, kind, A, idx, sensor, Rb, mean, Pl, zp, S, Pxz, H)
    _residual_core(zb, zp, angular, nu)
    _joseph_update_core(mean, Pl, nu, S, Pxz, H, Rb, log_2pi, cov, ll, failed)


@njit(**_OPTS)
def _mixing_weights_core(mub, T, c, W):
    r"""c (r, N) and W (r, r, N), W[j, i] = :math:`\mu_{i|j}`, from mub (r, N) and T (r, r), batch innermost, as
    :func:`mmlib.core.linalg.mixing_weights` computes them with the compiled kernels (``matmul_rows``, then
    :math:`T_{ij}\mu_i / c_j`, :math:`\mu_i` itself where :math:`c_j` is not > 0: ``mixing_weights`` tests
    :math:`c_j \le 0`, which differs only for a NaN :math:`c_j`, whose run's mode probabilities are then all NaN in both
    paths, :func:`_output_core`)."""
    r, N = mub.shape
    c[:, :] = 0.0
    for j in range(r):
        for i in range(r):
            t = T[i, j]
            for b in range(N):
                c[j, b] += mub[i, b] * t
    for j in range(r):
        for i in range(r):
            t = T[i, j]
            for b in range(N):
                W[j, i, b] = t * mub[i, b] / c[j, b] if c[j, b] > 0.0 else mub[i, b]


@njit(**_OPTS)
def _cubature_points_core(W, Xb, Pb, mm, out):
    r"""Cubature-principle IMM interaction (:class:`mmlib.core.mixing.CubatureMixing`, Zhou et al. 2017, Eqs. 14-19),
    batch innermost, as its composed operations compute it: from the weights W (r, r, N), W[j, i] =
    :math:`\mu_{i|j}`, and the modes' means Xb (r, n, N) and covs Pb (r, n, n, N): the modes' Cholesky factors
    (:func:`_chol`, NaN for a failed one), the centre :math:`\sum_i \mu_{i|j}\hat x_i` (summed as :func:`_gram_core`
    sums, the order of OpenBLAS's ``gemm`` on AVX2 CPUs for most shapes), the 2rn points centre
    :math:`\pm\sqrt{rn}\,\mu_{i|j}S_i e_c` (the + points first), their mean (summed in order from the first, over
    2rn) and covariance (:func:`_gram_core` of the deviations, over 2rn), symmetrised -> the mixed means mm (r, n, N)
    and covs out (r, n, n, N)."""
    r, n, N = Xb.shape
    l = r * n
    L = np.empty((r, n, n, N))
    for i in range(r):
        bad = np.zeros(N, dtype=np.bool_)
        _chol(Pb[i], L[i], bad)
        _nan_lanes(L[i], bad)
    root = math.sqrt(l)
    centre = np.empty((n, N))
    pts = np.empty((2 * l, n, N))
    cov = np.empty((n, n, N))
    for j in range(r):
        for k in range(n):
            for b in range(N):
                acc = 0.0
                for i in range(r):
                    acc = _fma(W[j, i, b], Xb[i, k, b], acc)
                centre[k, b] = acc + 0.0
        for i in range(r):
            for cc in range(n):
                p = i * n + cc
                for k in range(n):
                    for b in range(N):
                        shift = (root * W[j, i, b]) * L[i, k, cc, b]
                        pts[p, k, b] = centre[k, b] + shift
                        pts[l + p, k, b] = centre[k, b] - shift
        for k in range(n):
            for b in range(N):
                acc = pts[0, k, b]
                for p in range(1, 2 * l):
                    acc += pts[p, k, b]
                mm[j, k, b] = acc / (2 * l)
        for p in range(2 * l):
            for k in range(n):
                for b in range(N):
                    pts[p, k, b] = pts[p, k, b] - mm[j, k, b]
        _gram_core(pts, 0, 2 * l, cov)
        for i in range(n):
            for k in range(n):
                for b in range(N):
                    cov[i, k, b] = cov[i, k, b] / (2 * l)
        for i in range(n):
            for k in range(n):
                for b in range(N):
                    out[j, i, k, b] = 0.5 * (cov[i, k, b] + cov[k, i, b])


@njit(**_OPTS)
def cubature_mix(means, covs, w):
    r""":func:`_cubature_points_core` for B runs: means (B, r, n), covs (B, r, n, n), w (B, r_from, r_to) ->
    ``(mixed means (B, r, n), mixed covs (B, r, n, n))``."""
    B, r, n = means.shape
    W = np.empty((r, r, B))
    for j in range(r):
        for i in range(r):
            for b in range(B):
                W[j, i, b] = w[b, i, j]
    mm = np.empty((r, n, B))
    out = np.empty((r, n, n, B))
    _cubature_points_core(W, _inner(means, B), _inner(covs, B), mm, out)
    return _outer(mm), _outer(out)


@njit(**_OPTS)
def imm_layer_run(mu, T, means, covs, xi, wm, wc, F, Q, z, zoff, kind, A, idx, sensor, angular, R, cubature, adaptive,
                  ekf, window, psi, zeta_on, include_current, inflate_only, with_cov, log_2pi, truth, nis_on, keep_cov,
                  mean_out, cov_out, mu_out, failed_out, underflow_out, nis_out, nees_out, start, stop, block):
    r"""Every IMM cycle over K packed measurement steps, for blocks of ``block`` runs, of an IMM whose interaction is
    moment matching (:func:`_mix_core`) or, with ``cubature``, the cubature principle (:func:`_mixing_weights_core`,
    :func:`_cubature_points_core`),
    and whose mode filters are sigma-point filters on linear dynamics (:func:`_filter_step`), extended Kalman filters
    (``ekf``, :func:`_ekf_step`; the rule's arguments unused) or, with ``adaptive``,
    innovation-adaptive ones (:func:`_adaptive_core`; ``window`` ... ``inflate_only`` the layer's, one window of
    innovations per mode, restarted wherever the measurement dimension changes), then the IMM output
    (:func:`_output_core`): the composed IMM's cycles, the same bits.  Arguments and outputs as
    :func:`imm_sigma_run`."""
    r = mu.shape[1]
    n = means.shape[2]
    K = zoff.shape[0] - 1
    for b0 in range(start, stop, block):
        N = min(block, stop - b0)
        mub, Xb, Pb, Fb, Qb = _imm_block_start(mu, means, covs, F, Q, b0, N)
        failed = np.empty(N, dtype=np.bool_)
        failed_modes = np.empty((r, N), dtype=np.bool_)
        m_cur = -1
        n_past = 0
        cap = min(window, K) if adaptive else 1     # the innovations a window can hold in this run
        past = np.empty((r, cap, 1, N))
        now = np.empty((r, cap, 1, N))
        for k in range(K):
            zb, Ak, Rb, ang = _step_measurement(k, z, zoff, A, R, angular, b0, N)
            m = zb.shape[0]
            if m != m_cur:                  # the measurement set changed dimension: the windows start again
                past = np.empty((r, cap, m if adaptive else 1, N))
                now = np.empty((r, cap, m if adaptive else 1, N))
                n_past = 0
                m_cur = m
            c = np.empty((1, r, N))
            mm = np.empty((r, n, N))
            mc = np.empty((r, n, n, N))
            if cubature:
                W = np.empty((r, r, N))
                _mixing_weights_core(mub, T, c[0], W)
                _cubature_points_core(W, Xb, Pb, mm, mc)
            else:
                _mix_core(mub, T, Xb, Pb, c[0], mm, mc)
            ll = np.empty((r, N))
            post_mean = np.empty((r, n, N))
            post_cov = np.empty((r, n, n, N))
            nu = np.empty((r, m, N))
            S = np.empty((r, m, m, N))
            failed[:] = False
            n_now = 0
            for j in range(r):
                if adaptive:
                    n_now = _adaptive_core(mm[j], mc[j], xi, wm, wc, Fb[j], Qb[j], kind, Ak, idx, sensor, ang, Rb, zb,
                                           past[j], n_past, window, psi, zeta_on, include_current, inflate_only,
                                           log_2pi, post_mean[j], post_cov[j], nu[j], S[j], ll[j], failed_modes[j],
                                           now[j])
                elif ekf:
                    _ekf_step(mm[j], mc[j], Fb[j], Qb[j], Rb, zb, kind, Ak, idx, sensor, ang, log_2pi, post_mean[j],
                              post_cov[j], nu[j], S[j], ll[j], failed_modes[j])
                else:
                    _filter_step(mm[j], mc[j], xi, wm, wc, Fb[j], Qb[j], Rb, zb, kind, Ak, idx, sensor, ang, log_2pi,
                                 post_mean[j], post_cov[j], nu[j], S[j], ll[j], failed_modes[j])
                for lane in range(N):
                    failed[lane] = failed[lane] or failed_modes[j, lane]
            mu_b, marg, under, fused, fcov, innov, icov = _output_buffers(r, n, m, N, with_cov)
            _output_core(ll, c, post_mean, post_cov, nu, S, with_cov, mu_b, marg, under, fused, fcov, innov, icov)
            _store_imm_step(k, b0, under, fused, fcov, innov, icov, mu_b, failed, keep_cov, nis_on, truth, mean_out,
                            cov_out, mu_out, failed_out, underflow_out, nis_out, nees_out)
            mub, Xb, Pb = mu_b[0], post_mean, post_cov
            if adaptive:
                past, now = now, past
                n_past = n_now


@njit(**_OPTS)
def power(base, x):
    """``base ** x`` elementwise for x (N,): the C library's ``pow`` one value at a time, ``base`` a run-time operand
    (a literal 10 could let the compiler call another function, ``exp10``)."""
    out = np.empty(x.shape[0])
    for i in range(x.shape[0]):
        out[i] = math.pow(base, x[i])
    return out


@njit(**_OPTS)
def _degrees_of_divergence(innov, icov, ref, norm_innov, dod):
    r"""The degrees of divergence :math:`[\xi/\bar s, \eta/\sqrt{\bar s}]` of the lanes of innov (m, N) into dod (2, N),
    as :meth:`mmlib.core.layers.fuzzy_noise.FuzzyNoiseBounds.dod` computes them in numpy (sums in numpy's order,
    :func:`_numpy_sum`): :math:`\bar s` the trace of icov (m, m, N) over m (1 where it is not finite) with
    ``norm_innov``, else ``ref``.  False where some lane's :math:`\bar s` is not > 0 (the numpy path refuses it)."""
    m, N = innov.shape
    tmp = np.empty(m)
    ok = True
    for lane in range(N):
        if norm_innov:
            for i in range(m):
                tmp[i] = icov[i, i, lane]
            s = _numpy_sum(tmp, 0, m) / m
            if not math.isfinite(s):
                s = 1.0
        else:
            s = ref
        if not s > 0.0:
            ok = False
        for i in range(m):
            tmp[i] = innov[i, lane] * innov[i, lane]
        dod[0, lane] = _numpy_sum(tmp, 0, m) / m / s
        for i in range(m):
            tmp[i] = abs(innov[i, lane])
        dod[1, lane] = _numpy_sum(tmp, 0, m) / m / math.sqrt(s)
    return ok


@njit(**_OPTS)
def fuzzy_imm_run(mu, T, means, covs, xi, wm, wc, F, unit, base, levels, initial, z, zoff, kind, A, idx, sensor,
                  angular, R, with_cov, log_2pi, truth, nis_on, keep_cov, frozen, norm_innov, refs, history0, filled0,
                  bounds, sizes, cons, ten, mean_out, cov_out, mu_out, failed_out, underflow_out, diag_out, nis_out,
                  nees_out, refused, start, stop, block):
    r"""Every cycle of a noise-adaptive IMM (:class:`mmlib.core.layers.adaptive_imm.NoiseAdaptiveIMM`, or its windowed
    form) of a sigma-point filter over linear mode dynamics, with an affine noise family and the FLAS controller
    (:class:`mmlib.core.layers.fuzzy_noise.FuzzyNoiseBounds`), over K packed measurement steps, for blocks of runs:
    at step k each mode's :math:`Q_j = \ell_j\,\mathrm{unit} + \mathrm{base}` from the levels (a level that is not
    finite replaced by ``initial``), one IMM cycle (:func:`_imm_cycle`), then (unless ``frozen``) the next levels:
    the degrees of divergence of the mixture prior's innovation (:func:`_degrees_of_divergence`, the reference
    variance ``refs[k]`` without ``norm_innov``), averaged over the last ``min(k, W)`` epochs in the history (W =
    history0's second axis, numpy's order: the epochs one after the other), and ``ten ** TS(dod)``
    (:func:`trapezoid_rules`, :func:`power`) where both degrees are finite, NaN elsewhere.  The operations of the layer
    step by step, the same bits.

    Operands as :func:`imm_sigma_run`, plus unit, base (n, n), levels (B, r), initial (r,), history0 (B, W, 2),
    filled0 (B,) int64, the rule base bounds (2, 4, k), sizes (2,), cons (K_r, r); outputs as :func:`imm_sigma_run`
    plus diag_out (B, K, r) (each step's levels as the state held them) and ``refused`` (B,): a run of a block in which
    the controller refused its input (a reference variance not > 0, a degree firing no rule), where the layer step by
    step raises."""
    r = mu.shape[1]
    n = means.shape[2]
    K = zoff.shape[0] - 1
    W = history0.shape[1]
    for b0 in range(start, stop, block):
        N = min(block, stop - b0)
        mub, Xb, Pb, Fb = _run_block_start(mu, means, covs, F, b0, N)
        lev = np.empty((r, N))
        _lanes(levels, b0, N, (1, 0), lev)
        hist = np.empty((W, 2, N))
        _lanes(history0, b0, N, (1, 0), hist)
        filled = np.empty(N, dtype=np.int64)
        for lane in range(N):
            filled[lane] = filled0[b0 + lane]
        Qb = np.empty((r, n, n, N))
        failed = np.empty(N, dtype=np.bool_)
        failed_modes = np.empty((r, N), dtype=np.bool_)
        dod = np.empty((2, N))
        avg = np.empty((2, N))
        x = np.empty((N, 2))
        rows = np.empty(N, dtype=np.int64)
        for k in range(K):
            zb, Ak, Rb, ang = _step_measurement(k, z, zoff, A, R, angular, b0, N)
            _store_step(lev, b0, k, diag_out)
            for j in range(r):
                for lane in range(N):
                    level = lev[j, lane] if math.isfinite(lev[j, lane]) else initial[j]
                    for i in range(n):
                        for q in range(n):
                            Qb[j, i, q, lane] = level * unit[i, q] + base[i, q]
            mu_b, _, under, fused, fcov, innov, icov, post_mean, post_cov = _imm_cycle(
                mub, T, Xb, Pb, xi, wm, wc, Fb, Qb, Rb.reshape((1,) + Rb.shape), zb, kind, Ak, idx, sensor, ang,
                log_2pi, with_cov, failed, failed_modes)
            _store_imm_step(k, b0, under, fused, fcov, innov, icov, mu_b, failed, keep_cov, nis_on, truth, mean_out,
                            cov_out, mu_out, failed_out, underflow_out, nis_out, nees_out)
            mub, Xb, Pb = mu_b[0], post_mean, post_cov
            if frozen:
                continue
            if not _degrees_of_divergence(innov[0], icov[0], refs[k], norm_innov, dod):
                for lane in range(N):
                    refused[b0 + lane] = True
            for w in range(W - 1):
                for c in range(2):
                    for lane in range(N):
                        hist[w, c, lane] = hist[w + 1, c, lane]
            for c in range(2):
                for lane in range(N):
                    hist[W - 1, c, lane] = dod[c, lane]
            for lane in range(N):
                filled[lane] = min(filled[lane] + 1, W)
            if W == 1:
                for c in range(2):
                    for lane in range(N):
                        avg[c, lane] = hist[0, c, lane]
            else:
                for c in range(2):
                    for lane in range(N):
                        t = hist[0, c, lane] if 0 >= W - filled[lane] else 0.0
                        for w in range(1, W):
                            t += hist[w, c, lane] if w >= W - filled[lane] else 0.0
                        avg[c, lane] = t / filled[lane]
            count = 0
            for lane in range(N):
                if math.isfinite(avg[0, lane]) and math.isfinite(avg[1, lane]):
                    x[count, 0] = avg[0, lane]
                    x[count, 1] = avg[1, lane]
                    rows[count] = lane
                    count += 1
                else:
                    for j in range(r):
                        lev[j, lane] = np.nan
            if count:
                out, total = trapezoid_rules(x[:count], bounds, sizes, cons)
                for q in range(count):
                    if not total[q] > 0.0:
                        for lane in range(N):
                            refused[b0 + lane] = True
                    lane = rows[q]
                    for j in range(r):
                        lev[j, lane] = math.pow(ten, out[q, j])
