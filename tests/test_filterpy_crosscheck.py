"""Cross-check against an independent library, FilterPy (test-only dependency).

Version notes (FilterPy 2.0.0): ``UnscentedKalmanFilter.predict`` redraws the
sigma points from the predicted covariance, as mmlib does (1.4.x reused the
propagated points, which leaves Q out of the measurement prediction).
``IMMEstimator``'s docstring says ``M[i, j]`` is the probability of switching
*from j to i*, but its code computes ``cbar = mu @ M`` -- rows are "from",
the convention mmlib uses; the IMM test below pins that down.
"""
import numpy as np
import pytest

filterpy = pytest.importorskip("filterpy")
from filterpy.kalman import KalmanFilter  # noqa: E402 -- after the skip when FilterPy is missing

import mmlib as m  # noqa: E402
from bench.crosscheck import filterpy_imm_ukf, filterpy_ukf  # noqa: E402
from mmlib.core import models  # noqa: E402

T = 1.0
RB = models.RangeBearing(np.diag([100.0, 1e-5]))


def hx(x):
    return RB.h(x[None, None, :])[0, 0]


def _radar_data(K=40, seed=5):
    rng = np.random.default_rng(seed)
    x = np.array([8000.0, -120.0, 6000.0, 40.0])
    ct = models.coordinated_turn_matrix(T, 0.03)
    zs = []
    for k in range(K):
        x = (ct if 15 <= k < 25 else models.coordinated_turn_matrix(T, 0.0)) @ x
        zs.append(hx(x) + rng.standard_normal(2) * np.sqrt([100.0, 1e-5]))
    return np.array(zs)


def test_kalman_filter_matches_filterpy(linear_problem):
    dyn, meas, x0, P0, zs = linear_problem
    track = m.run(m.SingleModel(m.KalmanFilter(), dyn, meas), m.KalmanFilter().init(x0, P0), zs)
    for b in range(x0.shape[0]):
        kf = KalmanFilter(dim_x=4, dim_z=2)
        kf.x, kf.P, kf.F, kf.Q, kf.H, kf.R = x0[b].copy(), P0.copy(), dyn.F, dyn.Q, meas.H, meas.R
        for k, z in enumerate(zs[b]):
            kf.predict()
            kf.update(z)
            # FilterPy uses the Joseph form: equal up to round-off (values ~1e3)
            np.testing.assert_allclose(track.mean[b, k], kf.x, rtol=0, atol=1e-9)
            np.testing.assert_allclose(track.cov[b, k], kf.P, rtol=0, atol=1e-9)


@pytest.mark.parametrize("alpha,beta,kappa", [(1.0, 2.0, 0.0), (0.5, 2.0, 1.0), (1.0, 0.0, -1.0)])
def test_ukf_matches_filterpy_on_range_bearing(alpha, beta, kappa):
    zs = _radar_data()
    dyn = models.constant_velocity(T, 4.0)
    x0 = np.array([8050.0, -110.0, 5950.0, 35.0])
    P0 = np.diag([2500.0, 400.0, 2500.0, 400.0])
    filt = m.SigmaPointFilter(m.Unscented(alpha, beta, kappa))
    track = m.run(m.SingleModel(filt, dyn, RB), filt.init(x0[None], P0), zs[None])
    ukf = filterpy_ukf(dyn, RB, x0, P0, alpha, beta, kappa)
    for k, z in enumerate(zs):
        ukf.predict()
        ukf.update(z)
        np.testing.assert_allclose(track.mean[0, k], ukf.x, rtol=0, atol=1e-7)   # values ~1e4
        np.testing.assert_allclose(track.cov[0, k], ukf.P, rtol=1e-8, atol=1e-8)


def test_imm_ukf_matches_filterpy_with_rows_from_convention():
    zs = _radar_data()
    dyns = [models.constant_velocity(T, 1.0), models.coordinated_turn(T, 0.03, 1.0),
            models.coordinated_turn(T, -0.03, 1.0)]
    M = np.array([[0.90, 0.07, 0.03], [0.20, 0.75, 0.05], [0.10, 0.10, 0.80]])  # asymmetric on purpose
    mu0 = np.array([0.6, 0.3, 0.1])
    x0 = np.array([8050.0, -110.0, 5950.0, 35.0])
    P0 = np.diag([2500.0, 400.0, 2500.0, 400.0])
    filt = m.SigmaPointFilter(m.Unscented(1.0, 2.0, 0.0))
    imm = m.IMM(filt, dyns, RB, M)
    track = m.run(imm, imm.init(x0[None], P0, mu0), zs[None])
    fp = filterpy_imm_ukf(dyns, RB, x0, P0, M, mu0, alpha=1.0, beta=2.0, kappa=0.0)
    for k, z in enumerate(zs):
        fp.predict()
        fp.update(z)
        np.testing.assert_allclose(track.mode_probabilities[0, k], fp.mu, rtol=0, atol=1e-9)
        np.testing.assert_allclose(track.mean[0, k], fp.x, rtol=0, atol=1e-6)
        np.testing.assert_allclose(track.cov[0, k], fp.P, rtol=1e-7, atol=1e-7)
    # and the transposed reading of M gives different probabilities: the convention matters
    imm_t = m.IMM(filt, dyns, RB, M.T / M.T.sum(axis=1, keepdims=True))
    other = m.run(imm_t, imm_t.init(x0[None], P0, mu0), zs[None])
    assert np.abs(other.mode_probabilities - track.mode_probabilities).max() > 1e-3
