"""The arithmetic of the benchmark report (``make bench``), untimed: its agreement check against FilterPy,
and its flop count of one IMM-UKF run-step against a direct operation count.

The direct count runs a scalar implementation of the IMM-UKF step (written here, independently of
``bench/flops.py``) on numbers that count every arithmetic operation, stage by stage; the same
implementation's numbers are checked against mmlib's ``IMM.step``, so the counted algorithm is the
one the library runs (up to the symmetrisations and checks the floor leaves out).
"""
import json
import math

import numpy as np
import pytest

pytest.importorskip("filterpy")

import mmlib
from bench.flops import imm_ukf_flops
from bench.imm_ukf import AGREEMENT_RTOL, MODE_PROBABILITY_ATOL, agreement, problem
from mmlib.core import models
from mmlib.core.estimation import IMMState
from mmlib.core.filters import GaussianState


# --------------------------------------------------------------------------- agreement with FilterPy
def test_bench_estimates_agree_with_filterpy_to_the_stated_tolerance():
    res = agreement(3, 40)            # 3 runs, 40 steps: the first turn starts at step 30
    assert res["agree"], res
    assert res["max_abs_estimate_difference"] <= AGREEMENT_RTOL * res["estimate_scale"]
    assert res["max_abs_mode_probability_difference"] <= MODE_PROBABILITY_ATOL
    assert res["estimate_scale"] > 1e4                     # the tolerance is relative to positions ~2e4 m


def test_bench_agreement_fails_for_another_algorithm():
    """The tolerance separates round-off from a real difference: mmlib with beta = 0 (FilterPy: 2) fails."""
    res = agreement(3, 40, ukf=(1.0, 0.0, 0.0))
    assert not res["agree"]
    assert res["relative_difference"] > 100 * AGREEMENT_RTOL


# --------------------------------------------------------------------------- the flop count
# the counting numbers and scalar helpers, shared with tests/test_cost.py
from counting import COUNT, STAGE, TWO_PI, C, Measurement, chol, dot, exp, log, tril_inverse  # noqa: E402
from counting import gt as _gt  # noqa: E402


def counted_imm_ukf_step(x, P, mu, z, M, F, Q, R, meas, ukf=(1.0, 2.0, 0.0)):
    """One IMM-UKF run-step in scalars (lists of C), stage by stage as bench/flops.py names them;
    returns the fused mean, the mode probabilities and the mode means and covariances."""
    r, n, m = len(mu), len(x[0]), len(z)
    alpha, beta, kappa = ukf
    lam = alpha ** 2 * (n + kappa) - n
    c_pts = math.sqrt(n + lam)
    wm = [lam / (n + lam)] + [0.5 / (n + lam)] * (2 * n)
    wc = [wm[0] + 1.0 - alpha ** 2 + beta] + wm[1:]

    def points(mean, cov):
        STAGE[0] = f"{STAGE[1]}: Cholesky"
        L = chol(cov)
        STAGE[0] = f"{STAGE[1]}: sigma points"
        cl = [[c_pts * L[a][b] for b in range(n)] for a in range(n)]
        return ([mean] + [[mean[a] + cl[a][i] for a in range(n)] for i in range(n)]
                + [[mean[a] - cl[a][i] for a in range(n)] for i in range(n)])

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
        STAGE[1] = "predict"
        X = points(x0[j], P0[j])
        STAGE[0] = "predict: transition"
        Y = [[dot(list(F[j][p]), Xi) for p in range(n)] for Xi in X]
        STAGE[0] = "predict: moments"
        xb = [dot(wm, [Yi[p] for Yi in Y]) for p in range(n)]
        dY = [[Yi[p] - xb[p] for p in range(n)] for Yi in Y]
        wdY = [[wc[i] * dY[i][p] for p in range(n)] for i in range(len(Y))]
        Pm = [[dot([q[p] for q in dY], [q[s] for q in wdY]) + Q[j][p][s] for s in range(n)] for p in range(n)]

        STAGE[1] = "measurement prediction"
        X = points(xb, Pm)
        STAGE[0] = "measurement prediction: h"
        Z = [meas.h(Xi) for Xi in X]
        STAGE[0] = "measurement prediction: moments"
        zh = meas.average(Z, wm)
        dz = [meas.residual(Zi, zh) for Zi in Z]
        dx = [[Xi[p] - xb[p] for p in range(n)] for Xi in X]
        wdz = [[wc[i] * dz[i][a] for a in range(m)] for i in range(len(Z))]
        S = [[dot([q[a] for q in dz], [q[b] for q in wdz]) + R[a][b] for b in range(m)] for a in range(m)]
        Pxz = [[dot([q[p] for q in dx], [q[b] for q in wdz]) for b in range(m)] for p in range(n)]

        STAGE[0] = "update"
        nu = meas.residual(z, zh)
        Ls = chol(S)
        Li = tril_inverse(Ls)
        A = [[dot(Pxz[p], Li[b]) for b in range(m)] for p in range(n)]
        e = [dot(Li[a], nu) for a in range(m)]
        xs.append([xb[p] + dot(A[p], e) for p in range(n)])
        Ps.append([[Pm[p][s] - dot(A[p], A[s]) for s in range(n)] for p in range(n)])
        nis = dot(e, e)
        ld = log(Ls[0][0])
        for a_ in range(1, m):
            ld = ld + log(Ls[a_][a_])
        logliks.append(-0.5 * (nis + 2.0 * ld + m * math.log(TWO_PI)))

    STAGE[0] = "mode probabilities"
    lp = [logliks[j] + log(cbar[j]) for j in range(r)]
    top = lp[0]
    for j in range(1, r):
        if _gt(lp[j], top):
            top = lp[j]
    post = [exp(lp[j] - top) for j in range(r)]
    tot = post[0]
    for j in range(1, r):
        tot = tot + post[j]
    mu_new = [post[j] / tot for j in range(r)]
    STAGE[0] = "combination"
    fused = [dot(mu_new, [xs[j][p] for j in range(r)]) for p in range(n)]
    return fused, mu_new, xs, Ps


def _case(kind, n, m, r, seed=3):
    """An IMM (mmlib), its state and a measurement: the benchmark's job, or a random linear instance."""
    rng = np.random.default_rng(seed)
    if kind == "job":
        dyn, radar, _, _, x_init, P_init, M = problem(1)
        meas_mm, meas_c = radar, Measurement()
        means = x_init + rng.standard_normal((r, n)) * [50.0, 5.0, 50.0, 5.0]
        z = radar.h(x_init[None])[0] + [30.0, 0.004]
    else:
        dyn = []
        for _ in range(r):
            F = np.eye(n) + 0.3 * rng.standard_normal((n, n))
            G = rng.standard_normal((n, n))
            Q = G @ G.T + 0.1 * np.eye(n)
            dyn.append(models.LinearGaussianDynamics(F, Q, np.linalg.cholesky(Q)))
        H = rng.standard_normal((m, n))
        Rg = rng.standard_normal((m, m))
        meas_mm = models.LinearMeasurement(H, Rg @ Rg.T + np.eye(m))
        meas_c = Measurement(H)
        M = rng.dirichlet(np.ones(r), size=r)
        P_init = np.eye(n)
        means = rng.standard_normal((r, n)) * 3.0
        z = rng.standard_normal(m)
    A = rng.standard_normal((r, n, n))
    covs = A @ np.swapaxes(A, -1, -2) + np.asarray(P_init)
    mu = rng.dirichlet(np.ones(r))
    imm = mmlib.IMM(mmlib.SigmaPointFilter(mmlib.Unscented(1.0, 2.0, 0.0)), dyn, meas_mm, M)
    return imm, means, covs, mu, z, meas_c


@pytest.mark.parametrize("kind,n,m,r", [("job", 4, 2, 3), ("linear", 1, 1, 1), ("linear", 2, 1, 2),
                                        ("linear", 3, 2, 2), ("linear", 2, 3, 3)])
def test_flop_count_matches_a_direct_operation_count(kind, n, m, r):
    imm, means, covs, mu, z, meas_c = _case(kind, n, m, r)
    F = [d.F.tolist() for d in imm.dynamics]
    Q = [d.Q.tolist() for d in imm.dynamics]
    Rm = imm.measurement.R.tolist()
    COUNT.clear()
    STAGE[:] = ["", ""]
    fused, mu_c, xs, Ps = counted_imm_ukf_step(
        [[C(v) for v in row] for row in means], [[[C(v) for v in row] for row in cov] for cov in covs],
        [C(v) for v in mu], list(z), imm.transition.tolist(), F, Q, Rm, meas_c)
    expected = imm_ukf_flops(n, m, r, **({} if kind == "job" else {"h_flops": m * (2 * n - 1), "angles": 0}))
    total = expected.pop("total")
    assert dict(COUNT) == expected
    assert sum(COUNT.values()) == total
    # the counted implementation is mmlib's algorithm: the same numbers as IMM.step (to round-off)
    state = IMMState(GaussianState(means[None], covs[None]), mu[None])
    new, est = imm.step(state, np.asarray(z, float)[None])
    np.testing.assert_allclose([v.v for v in fused], est.mean[0], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose([v.v for v in mu_c], est.mode_probabilities[0], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose([[v.v for v in row] for row in xs], new.modes.mean[0], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose([[[v.v for v in row] for row in P] for P in Ps], new.modes.cov[0],
                               rtol=1e-8, atol=1e-9)


def test_flop_count_by_hand_for_a_scalar_filter_of_one_mode():
    """n = m = r = 1 (3 unscented points, h(x) = H x: one product a point), counted by hand."""
    by_hand = {
        "mixing weights": 2,                      # p mu; mu p / c (the sum over one mode is free)
        "mixed means": 1,                         # w x
        "mixed covariances": 5,                   # d = x - x0, w d, w P, (w d) d, pooled + spread
        "predict: Cholesky": 1,                   # sqrt
        "predict: sigma points": 3,               # c L, x + c L, x - c L
        "predict: transition": 3,                 # F X_i for 3 points
        "predict: moments": 17,                   # mean 3+2, deviations 3, weighted 3, covariance 3+2, + Q 1
        "measurement prediction: Cholesky": 1,
        "measurement prediction: sigma points": 3,
        "measurement prediction: h": 3,           # H X_i
        "measurement prediction: moments": 25,    # mean 5, dz 3, dx 3, wc dz 3, S 5, Pxz 5, + R 1
        "update": 15,   # nu 1, sqrt 1, 1/L 1, A 1, e 1, x + A e 2, P - A A 2, e e 1, 2 log L 2, loglik 3
        "mode probabilities": 5,                  # log c, + , - max, exp, / sum
        "combination": 1,                         # mu x
    }
    flops = imm_ukf_flops(1, 1, 1, h_flops=1, angles=0)
    assert flops.pop("total") == sum(by_hand.values()) == 85
    assert flops == by_hand


def test_flop_count_of_the_benchmark_job():
    """n = 4, m = 2, r = 3, 9 points, range-bearing: the number the report divides by."""
    flops = imm_ukf_flops()
    assert flops["total"] == 5115
    assert flops["predict: transition"] == 3 * 9 * 4 * 7          # F X_i: 9 points x 4 rows x (4 + 3)
    assert flops["predict: Cholesky"] == 3 * 30                    # n^3/3 + n^2/2 + n/6 = 30 for n = 4


def test_notebook_times_split_at_the_reading_space_and_count_universes_per_minute(tmp_path):
    """bench.notebooks reads papermill's metadata: the headline is the cells before ``nb.multiverse()``, the cached
    universes are parsed from that cell's output, and the computed ones per minute of the multiverse's wall time
    follow from the results file's universes."""
    from bench import notebooks

    def cell(src, seconds, text=""):
        return {"cell_type": "code", "source": src, "metadata": {"papermill": {"duration": seconds}},
                "outputs": [{"name": "stderr", "output_type": "stream", "text": text}]}
    nb = {"metadata": {"papermill": {"start_time": "a", "end_time": "b", "duration": 40.0, "parameters": {}}},
          "cells": [cell("x = 1", 5.0), cell("mv = nb.multiverse()", 30.0,
                                             "  [p] 2/12 universes from the cache (build/cache/p)\n"),
                    cell("mv.table()", 3.0)]}
    path = tmp_path / "p_notebook.ipynb"
    path.write_text(json.dumps(nb))
    t = notebooks.notebook_time(path)
    assert (t["headline_s"], t["multiverse_s"], t["universes_from_cache"], t["multiverse_first_cell"]) == \
        (5.0, 33.0, 2, 1)
    rate = notebooks._throughput({"multiverse": {"universes": [{}] * 12}}, t)
    assert rate == {"universes": 12, "universes_computed": 10, "universes_per_minute": 60.0 * 10 / 33.0}
    assert notebooks._throughput({"rows": []}, t) == {}
    # where the run recorded how it obtained its universes (the provenance, from run_grid's stats), its counts replace
    # the parsed one and the computed universes per CPU-minute of their jobs follow
    prov = {"multiverse_computed": 9, "multiverse_from_cache": 3, "multiverse_cpu_s": 45.0}
    rate = notebooks._throughput({"provenance": prov, "multiverse": {"universes": [{}] * 12}}, t)
    assert rate == {"universes": 12, "universes_computed": 9, "universes_per_minute": 60.0 * 9 / 33.0,
                    "universes_from_cache": 3, "multiverse_cpu_s": 45.0, "universes_per_cpu_minute": 60.0 * 9 / 45.0}
    none = notebooks._throughput({"provenance": dict(prov, multiverse_computed=0, multiverse_from_cache=12),
                                  "multiverse": {"universes": [{}] * 12}}, t)
    assert none["universes_per_minute"] is None and none["universes_per_cpu_minute"] is None
