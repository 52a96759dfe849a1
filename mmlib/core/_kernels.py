r"""Compiled (numba) kernels of :mod:`mmlib.core.linalg`: the same mathematics as its numpy reference
path, fused into one loop nest per filter operation.

Why: the filters spend their time in many small operations on ``(B, r, n, n)`` stacks (n = 2..9).
numpy pays a dispatch per operation far larger than its arithmetic; a plain compiled loop per run
is no better, because each run's sums are chains of dependent additions (latency bound).  Here every
kernel copies its operands into a **batch-innermost** layout ``(n, n, N)`` (:func:`_inner`, back with
:func:`_outer`) and runs each scalar operation of the algorithm as a loop over the N runs: independent
lanes that LLVM turns into SIMD instructions, with no temporaries and one call per filter operation.

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
  and the bits do not depend on the machine's instruction set; transcendental functions (log, atan2)
  are not used in vectorised loops;
* the two paths agree to round-off, not bit for bit (BLAS and LAPACK sum in other orders;
  ``tests/test_kernels.py`` states the bounds).

Nothing here is called directly: each public kernel is the compiled twin of one operation of
:mod:`mmlib.core.linalg`, declared there next to its numpy body, and which of the two runs is decided there
once (:func:`mmlib.core.linalg.kernel`; ``MMLIB_KERNEL=numpy`` selects the reference path).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

_OPTS = dict(cache=True, nogil=True, error_model="numpy")
_TWO_PI = 2.0 * math.pi


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
    m = nu.shape[1]
    joseph = H.shape[1] > 0
    P = _inner(cov, N)
    Sb = _inner(S, N)
    Pxzb = _inner(Pxz, N)
    nub = _inner(nu, N)
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
    nis = np.zeros(N)
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
    mean_b = _inner(mean, N)
    for i in range(n):
        for k in range(m):
            for b in range(N):
                mean_b[i, b] += A[i, k, b] * e[k, b]
    C = np.empty((n, n, N))
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
        Hb = _inner(H, N)
        Rb = _inner(R, N)
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
    logdet = np.zeros(N)
    for i in range(m):                                       # scalar loop: log is not vectorised
        for b in range(N):
            logdet[b] += math.log(L[i, i, b])
    failed = np.empty(N, dtype=np.bool_)
    for b in range(N):
        failed[b] = s_bad[b] or p_bad[b]
        if s_bad[b]:
            nis[b] = np.nan
            logdet[b] = np.nan
    for b in range(N):
        logdet[b] = 2.0 * logdet[b]
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
def sigma_point_predict_linear(mean, cov, xi, wm, wc, F, Q):
    r"""Fused sigma-point time update through linear dynamics :math:`f(x) = Fx` (the moments
    :func:`sigma_points`, ``F X``, :func:`weighted_mean` and :func:`weighted_outer` give in turn):
    :math:`X_p = m + L\xi_p`, :math:`Y_p = FX_p`, :math:`\bar y = \sum w^m_p Y_p`,
    :math:`P^- = \sum w^c_p (Y_p - \bar y)(Y_p - \bar y)^T + Q`.  mean (N, n), cov (N, n, n), xi (M, n),
    wm, wc (M,), F (N, n, n), Q (N, n, n) -> ``(mean-, cov-, failed)``; a failed run's moments are NaN."""
    N, n = mean.shape
    M = xi.shape[0]
    L = np.empty((n, n, N))
    failed = np.zeros(N, dtype=np.bool_)
    _chol(_inner(cov, N), L, failed)
    X = np.empty((M, n, N))
    _points(_inner(mean, N), L, xi, X)
    Fb = _inner(F, N)
    Y = np.zeros((M, n, N))
    ybar = np.zeros((n, N))
    for p in range(M):
        for i in range(n):
            for j in range(n):
                for b in range(N):
                    Y[p, i, b] += Fb[i, j, b] * X[p, j, b]
            wp = wm[p]
            for b in range(N):
                ybar[i, b] += wp * Y[p, i, b]
    for p in range(M):
        for i in range(n):
            for b in range(N):
                Y[p, i, b] -= ybar[i, b]
    Pm = np.empty((n, n, N))
    _outer_sums(Y, wc, np.empty((M, 0, N)), _inner(Q, N), Pm, np.empty((0, n, N)))
    mean_out = _outer(ybar)
    cov_out = _outer(Pm)
    _nan_rows(mean_out, failed)
    _nan_rows(cov_out, failed)
    return mean_out, cov_out, failed


@njit(**_OPTS)
def _wrap(a):
    return a + _TWO_PI * math.floor((math.pi - a) / _TWO_PI)


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
    Zb = _inner(Z, N)
    DX = _inner(X, N)
    mb = _inner(mean, N)
    for p in range(M):
        for i in range(n):
            for b in range(N):
                DX[p, i, b] -= mb[i, b]
    zp = np.zeros((m, N))
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
    S = np.empty((m, m, N))
    Pxz = np.empty((n, m, N))
    _outer_sums(Zb, wc, DX, _inner(R, N), S, Pxz)
    return _outer(zp), _outer(S), _outer(Pxz)


@njit(**_OPTS)
def imm_mix(mu, T, means, covs):
    r"""IMM interaction (Zhu et al. 2016, Eqs. 54-56) fused: :math:`c_j = \sum_i \mu_i T_{ij}`,
    :math:`\mu_{i|j} = T_{ij}\mu_i / c_j` (for a mode no other mode reaches, :math:`c_j = 0`: :math:`\mu`
    itself), mixed means :math:`x^{0j} = \sum_i \mu_{i|j} x^i` and covariances
    :math:`\mathrm{sym}\sum_i \mu_{i|j}[P^i + (x^i - x^{0j})(x^i - x^{0j})^T]`.
    mu (B, r), T (r, r) rows "from", means (B, r, n), covs (B, r, n, n) -> ``(c, mixed means, mixed covs)``."""
    B, r = mu.shape
    n = means.shape[2]
    mub = _inner(mu, B)
    c = np.zeros((r, B))
    for j in range(r):
        for i in range(r):
            t = T[i, j]
            for b in range(B):
                c[j, b] += mub[i, b] * t
    W = np.empty((r, r, B))                                  # W[j, i] = mu_{i|j}
    for j in range(r):
        for i in range(r):
            t = T[i, j]
            for b in range(B):
                W[j, i, b] = t * mub[i, b] / c[j, b] if c[j, b] > 0.0 else mub[i, b]
    Xb = _inner(means, B)
    mm = np.zeros((r, n, B))
    for j in range(r):
        for k in range(n):
            for i in range(r):
                for b in range(B):
                    mm[j, k, b] += W[j, i, b] * Xb[i, k, b]
    out = np.empty((r, n, n, B))
    _combine(W, Xb, _inner(covs, B), mm, out)
    return _outer(c), _outer(mm), _outer(out)


@njit(**_OPTS)
def range_bearing(x, i, j, sx, sy):
    r"""Range and bearing of the points x (N, n) from a sensor at (sx, sy): :math:`(\sqrt{dx^2 + dy^2},
    \operatorname{atan2}(dy, dx))` with :math:`dx = x_i - s_x`, :math:`dy = x_j - s_y` -> (N, 2)
    (``hypot`` and ``atan2`` of the C library, as numpy calls them; scalar loop)."""
    N = x.shape[0]
    out = np.empty((N, 2))
    for b in range(N):
        dx = x[b, i] - sx
        dy = x[b, j] - sy
        out[b, 0] = math.hypot(dx, dy)
        out[b, 1] = math.atan2(dy, dx)
    return out


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
    mu = np.empty((B, r))
    marginal = np.empty(B)
    underflow = np.zeros(B, dtype=np.bool_)
    lp = np.empty(r)
    for b in range(B):
        top = -np.inf
        for j in range(r):
            lp[j] = loglik[b, j] + math.log(c[b, j]) if c[b, j] > 0.0 else -np.inf + loglik[b, j]
            if lp[j] != lp[j] or top != top:
                top = np.nan
            elif lp[j] > top:
                top = lp[j]
        total = 0.0
        for j in range(r):
            mu[b, j] = math.exp(lp[j] - top) if top > -np.inf else np.nan
            total += mu[b, j]
        for j in range(r):
            mu[b, j] = mu[b, j] / total
        marginal[b] = top + math.log(total) if total > 0.0 else np.nan
        underflow[b] = top == -np.inf
    mub = np.empty((1, r, B))
    cb = np.empty((1, r, B))
    for b in range(B):
        for j in range(r):
            mub[0, j, b] = mu[b, j]
            cb[0, j, b] = c[b, j]
    Xb = _inner(means, B)
    fused = np.zeros((1, n, B))
    for j in range(r):
        for k in range(n):
            for b in range(B):
                fused[0, k, b] += mub[0, j, b] * Xb[j, k, b]
    Nb = _inner(nu, B)
    innov = np.zeros((1, m, B))
    for j in range(r):
        for k in range(m):
            for b in range(B):
                innov[0, k, b] += cb[0, j, b] * Nb[j, k, b]
    icov = np.empty((1, m, m, B))
    _combine(cb, Nb, _inner(S, B), innov, icov)
    if with_cov:
        fcov = np.empty((1, n, n, B))
        _combine(mub, Xb, _inner(covs, B), fused, fcov)
        cov_out = _outer(fcov)[:, 0]
    else:
        cov_out = np.empty((B, 0, 0))
    return (mu, marginal, underflow, _outer(fused)[:, 0], cov_out, _outer(innov)[:, 0],
            _outer(icov)[:, 0])


@njit(**_OPTS)
def congruence(A, P, add):
    r"""The linearised moments of the EKF: :math:`A P A^T + \mathrm{add}` and :math:`P A^T` for a stack:
    A (N, d, n) (a Jacobian), P (N, n, n), add (N, d, d) (the noise Q or R) -> ``((N, d, d), (N, n, d))``;
    :math:`APA^T` is computed as :math:`A(PA^T)` and symmetrised as the numpy path's sum is not."""
    N = P.shape[0]                          # (A and add may be periodic over the runs)
    d, n = A.shape[1], A.shape[2]
    Ab = _inner(A, N)
    Pb = _inner(P, N)
    PAt = np.zeros((n, d, N))
    for i in range(n):
        for j in range(d):
            for k in range(n):
                for b in range(N):
                    PAt[i, j, b] += Pb[i, k, b] * Ab[j, k, b]
    S = _inner(add, N)
    for i in range(d):
        for j in range(d):
            for k in range(n):
                for b in range(N):
                    S[i, j, b] += Ab[i, k, b] * PAt[k, j, b]
    return _outer(S), _outer(PAt)


@njit(**_OPTS)
def linear_predict(mean, cov, F, Q):
    r"""The Kalman filter's time update through linear dynamics, fused: :math:`(F m, F P F^T + Q)` with
    :math:`FPF^T = F(PF^T)` (as :func:`congruence`): mean (N, n), cov (N, n, n), F (N, n, n), Q (N, n, n)."""
    N, n = mean.shape
    Fb = _inner(F, N)
    mb = _inner(mean, N)
    out = np.zeros((n, N))
    for i in range(n):
        for k in range(n):
            for b in range(N):
                out[i, b] += Fb[i, k, b] * mb[k, b]
    S, _ = congruence(F, cov, Q)
    return _outer(out), S
