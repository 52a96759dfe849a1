"""Operation counting for the cost-model tests (``tests/test_bench.py``, ``tests/test_cost.py``).

:class:`C` is a float that counts the arithmetic done with it under the current stage name (``STAGE[0]``) into
``COUNT``; negation is free (the cost model's convention).  The scalar filters below run on lists of C, stage by
stage with the term names of :mod:`mmlib.core.cost`, written here independently of it; the tests check their numbers
against mmlib's (the counted algorithm is the one the library runs) and their counts against the model, exactly.
"""
from __future__ import annotations

import math
from collections import Counter

import numpy as np

COUNT = Counter()
STAGE = ["", ""]


def reset():
    """Clear the counts and the stage."""
    COUNT.clear()
    STAGE[:] = ["", ""]


class C:
    """A float that counts the arithmetic done with it (under the current ``STAGE``); negation is free."""

    __slots__ = ("v",)

    def __init__(self, v):
        self.v = float(v)


def _v(x):
    return x.v if isinstance(x, C) else float(x)


def _op(value):
    COUNT[STAGE[0]] += 1
    return C(value)


C.__add__ = lambda a, b: _op(a.v + _v(b))
C.__radd__ = lambda a, b: _op(_v(b) + a.v)
C.__sub__ = lambda a, b: _op(a.v - _v(b))
C.__rsub__ = lambda a, b: _op(_v(b) - a.v)
C.__mul__ = lambda a, b: _op(a.v * _v(b))
C.__rmul__ = lambda a, b: _op(_v(b) * a.v)
C.__truediv__ = lambda a, b: _op(a.v / _v(b))
C.__rtruediv__ = lambda a, b: _op(_v(b) / a.v)
C.__neg__ = lambda a: C(-a.v)


def gt(a, b):
    """A counted comparison ``a > b``."""
    COUNT[STAGE[0]] += 1
    return _v(a) > _v(b)


def _fn(f):
    return lambda *xs: _op(f(*map(_v, xs)))


sqrt, log, exp, atan2, floor = (_fn(f) for f in (math.sqrt, math.log, math.exp, math.atan2, math.floor))


def cs(a):
    """Nested lists of C from an array."""
    a = np.asarray(a, float)
    return C(a) if a.ndim == 0 else [cs(x) for x in a]


def values(a):
    """Nested lists of C (or floats) as an array of floats."""
    if isinstance(a, (list, tuple)):
        return np.array([values(x) for x in a])
    return _v(a)


def dot(a, b):
    """Dot product: k products and k - 1 sums."""
    acc = a[0] * b[0]
    for k in range(1, len(a)):
        acc = acc + a[k] * b[k]
    return acc


def matmul(A, B):
    """Dense product of nested lists."""
    cols = list(zip(*B))
    return [[dot(row, list(col)) for col in cols] for row in A]


def transpose(A):
    return [list(r) for r in zip(*A)]


def chol(A):
    """Lower Cholesky factor, column by column (potf2)."""
    n = len(A)
    L = [[C(0.0) for _ in range(n)] for _ in range(n)]       # dense: the zeros are operands too
    for j in range(n):
        s = A[j][j]
        for k in range(j):
            s = s - L[j][k] * L[j][k]
        L[j][j] = sqrt(s)
        for i in range(j + 1, n):
            s = A[i][j]
            for k in range(j):
                s = s - L[i][k] * L[j][k]
            L[i][j] = s / L[j][j]
    return L


def tril_inverse(L):
    """Inverse of a lower-triangular factor by forward substitution."""
    m = len(L)
    dinv = [1.0 / L[i][i] for i in range(m)]
    inv = [[C(0.0) for _ in range(m)] for _ in range(m)]
    for i in range(m):
        inv[i][i] = dinv[i]
        for j in range(i):
            acc = L[i][j] * inv[j][j]
            for k in range(j + 1, i):
                acc = acc + L[i][k] * inv[k][j]
            inv[i][j] = -acc * dinv[i]
    return inv


TWO_PI = 2.0 * math.pi


def wrap(a):
    return a + TWO_PI * floor((math.pi - a) / TWO_PI)


class Measurement:
    """Range-bearing (sensor at the origin, positions at ``idx``, default 0 and 2) or a dense linear ``H x``."""

    def __init__(self, H=None, idx=(0, 2)):
        self.H = H
        self.idx = idx
        self.angles = 0 if H is not None else 1

    def h(self, x):
        if self.H is not None:
            return [dot(list(row), x) for row in self.H]
        dx, dy = x[self.idx[0]] - 0.0, x[self.idx[1]] - 0.0
        return [sqrt(dx * dx + dy * dy), atan2(dy, dx)]

    def jacobian(self, x):
        """Dense H: the stored matrix (free) or the range-bearing Jacobian (10 flops) at x."""
        if self.H is not None:
            return [list(row) for row in self.H]
        i, j = self.idx
        dx, dy = x[i] - 0.0, x[j] - 0.0
        r2 = dx * dx + dy * dy
        r = sqrt(r2)
        J = [[0.0] * len(x) for _ in range(2)]
        J[0][i], J[0][j], J[1][i], J[1][j] = dx / r, dy / r, -dy / r2, dx / r2
        return J

    def residual(self, a, b):
        if self.H is not None:
            return [ai - bi for ai, bi in zip(a, b)]
        return [a[0] - b[0], wrap(a[1] - b[1])]

    def average(self, Z, wm):
        m = len(Z[0])
        if self.H is not None:
            return [dot(wm, [z[a] for z in Z]) for a in range(m)]
        res = [self.residual(z, Z[0]) for z in Z]
        mean = [Z[0][a] + dot(wm, [q[a] for q in res]) for a in range(m)]
        mean[1] = wrap(mean[1])
        return mean


# --------------------------------------------------------------------------- the filters, stage by stage
def points(mean, cov, xi, prefix):
    r"""Sigma points :math:`\hat x + S\xi_i` in the rule's order: for each pair :math:`\pm\xi` the offset
    :math:`S\xi` from the non-zeros of :math:`\xi` (in index order), added and subtracted; the centre is the mean."""
    STAGE[0] = f"{prefix}: Cholesky"
    L = chol(cov)
    STAGE[0] = f"{prefix}: sigma points"
    n = len(mean)
    out = [None] * len(xi)
    for i, row in enumerate(xi):
        if out[i] is not None:
            continue
        nz = [j for j in range(n) if row[j] != 0.0]
        if not nz:
            out[i] = list(mean)
            continue
        off = [dot([L[a][j] for j in nz], [float(row[j]) for j in nz]) for a in range(n)]
        out[i] = [mean[a] + off[a] for a in range(n)]
        opp = next((j for j in range(i + 1, len(xi)) if out[j] is None and np.array_equal(xi[j], -row)), None)
        if opp is not None:
            out[opp] = [mean[a] - off[a] for a in range(n)]
    return out


def sp_predict(x, P, F, Q, up):
    """Sigma-point time update through ``F x`` with the unit points ``up`` (xi, wm, wc)."""
    X = points(x, P, up.xi, "predict")
    n = len(x)
    STAGE[0] = "predict: transition"
    Y = [[dot(list(F[p]), Xi) for p in range(n)] for Xi in X]
    STAGE[0] = "predict: moments"
    wm, wc = [float(w) for w in up.wm], [float(w) for w in up.wc]
    xb = [dot(wm, [Yi[p] for Yi in Y]) for p in range(n)]
    dY = [[Yi[p] - xb[p] for p in range(n)] for Yi in Y]
    wdY = [[wc[i] * dY[i][p] for p in range(n)] for i in range(len(Y))]
    Pm = [[dot([q[p] for q in dY], [q[s] for q in wdY]) + Q[p][s] for s in range(n)] for p in range(n)]
    return xb, Pm


def sp_measurement(xb, Pm, R, meas, up):
    """Sigma-point measurement prediction: ``(z_pred, S, Pxz)``."""
    X = points(xb, Pm, up.xi, "measurement prediction")
    n, m = len(xb), len(R)
    STAGE[0] = "measurement prediction: h"
    Z = [meas.h(Xi) for Xi in X]
    STAGE[0] = "measurement prediction: moments"
    wm, wc = [float(w) for w in up.wm], [float(w) for w in up.wc]
    zh = meas.average(Z, wm)
    dz = [meas.residual(Zi, zh) for Zi in Z]
    dx = [[Xi[p] - xb[p] for p in range(n)] for Xi in X]
    wdz = [[wc[i] * dz[i][a] for a in range(m)] for i in range(len(Z))]
    S = [[dot([q[a] for q in dz], [q[b] for q in wdz]) + R[a][b] for b in range(m)] for a in range(m)]
    Pxz = [[dot([q[p] for q in dx], [q[b] for q in wdz]) for b in range(m)] for p in range(n)]
    return zh, S, Pxz


def kf_predict(x, P, F, Q):
    """Kalman time update ``F x``, ``F (P F^T) + Q``."""
    n = len(x)
    STAGE[0] = "predict: transition"
    xb = [dot(list(F[p]), x) for p in range(n)]
    STAGE[0] = "predict: moments"
    PFt = matmul(P, transpose(F))
    FPFt = matmul(F, PFt)
    return xb, [[FPFt[p][s] + Q[p][s] for s in range(n)] for p in range(n)]


def kf_measurement(xb, Pm, R, meas):
    """Linearised measurement prediction: ``(z_pred, S, Pxz, H)``."""
    m = len(R)
    STAGE[0] = "measurement prediction: Jacobian"
    H = meas.jacobian(xb)
    STAGE[0] = "measurement prediction: h"
    zh = meas.h(xb)
    STAGE[0] = "measurement prediction: moments"
    PHt = matmul(Pm, transpose(H))
    HPHt = matmul(H, PHt)
    return zh, [[HPHt[a][b] + R[a][b] for b in range(m)] for a in range(m)], PHt, H


def update(xb, Pm, zh, S, Pxz, z, meas, H=None, R=None):
    """The shared Kalman update (Joseph form when H is given): ``(x+, P+, log-likelihood)``."""
    STAGE[0] = "update"
    n, m = len(xb), len(z)
    nu = meas.residual(z, zh)
    Ls = chol(S)
    Li = tril_inverse(Ls)
    A = [[dot(Pxz[p], Li[b]) for b in range(m)] for p in range(n)]
    e = [dot(Li[a], nu) for a in range(m)]
    x = [xb[p] + dot(A[p], e) for p in range(n)]
    if H is None:
        P = [[Pm[p][s] - dot(A[p], A[s]) for s in range(n)] for p in range(n)]
    else:
        K = matmul(A, Li)
        KH = matmul(K, H)
        IKH = [[(1.0 if p == s else 0.0) - KH[p][s] for s in range(n)] for p in range(n)]
        T1 = matmul(matmul(IKH, Pm), transpose(IKH))
        T2 = matmul(matmul(K, R), transpose(K))
        P = [[T1[p][s] + T2[p][s] for s in range(n)] for p in range(n)]
    nis = dot(e, e)
    ld = log(Ls[0][0])
    for a in range(1, m):
        ld = ld + log(Ls[a][a])
    return x, P, -0.5 * (nis + 2.0 * ld + m * math.log(TWO_PI))


def filter_step(kind, x, P, z, F, Q, R, meas, up=None):
    """One step of the KF (``kind="kf"``) or a sigma-point filter with unit points ``up``."""
    if kind == "kf":
        xb, Pm = kf_predict(x, P, F, Q)
        zh, S, Pxz, H = kf_measurement(xb, Pm, R, meas)
        return update(xb, Pm, zh, S, Pxz, z, meas, H, R)
    xb, Pm = sp_predict(x, P, F, Q, up)
    zh, S, Pxz = sp_measurement(xb, Pm, R, meas, up)
    return update(xb, Pm, zh, S, Pxz, z, meas)


def imm_step(x, P, mu, z, M, mode_step):
    """One IMM cycle: moment mixing, ``mode_step(j, x0, P0) -> (x, P, loglik)`` for each mode, mode probabilities
    and the fused mean.  Returns ``(fused mean, mode probabilities, mode means, mode covariances)``."""
    r, n = len(mu), len(x[0])
    STAGE[0] = "mixing weights"
    a = [[M[i][j] * mu[i] for j in range(r)] for i in range(r)]
    cbar = [None] * r
    for j in range(r):
        acc = a[0][j]
        for i in range(1, r):
            acc = acc + a[i][j]
        cbar[j] = acc
    w = [[a[i][j] / cbar[j] for j in range(r)] for i in range(r)]
    STAGE[0] = "mixed means"
    x0 = [[dot([w[i][j] for i in range(r)], [x[i][k] for i in range(r)]) for k in range(n)] for j in range(r)]
    STAGE[0] = "mixed covariances"
    d = [[[x[i][k] - x0[j][k] for k in range(n)] for i in range(r)] for j in range(r)]
    wd = [[[w[i][j] * d[j][i][k] for k in range(n)] for i in range(r)] for j in range(r)]
    P0 = [[[dot([w[i][j] for i in range(r)], [P[i][p][q] for i in range(r)])
            + dot([wd[j][i][p] for i in range(r)], [d[j][i][q] for i in range(r)])
            for q in range(n)] for p in range(n)] for j in range(r)]
    xs, Ps, logliks = [], [], []
    for j in range(r):
        xj, Pj, lj = mode_step(j, x0[j], P0[j])
        xs.append(xj)
        Ps.append(Pj)
        logliks.append(lj)
    STAGE[0] = "mode probabilities"
    lp = [logliks[j] + log(cbar[j]) for j in range(r)]
    top = lp[0]
    for j in range(1, r):
        if gt(lp[j], top):
            top = lp[j]
    post = [exp(lp[j] - top) for j in range(r)]
    tot = post[0]
    for j in range(1, r):
        tot = tot + post[j]
    mu_new = [post[j] / tot for j in range(r)]
    STAGE[0] = "combination"
    fused = [dot(mu_new, [xs[j][p] for j in range(r)]) for p in range(n)]
    return fused, mu_new, xs, Ps
