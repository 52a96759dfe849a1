"""Cubature-principle mixing (Zhou et al. 2017 Eqs. 14-19) and the innovation-adaptive layer (Eqs. 27-39)."""
import numpy as np
import pytest

import mmlib as m
from mmlib.core import models
from mmlib.core.models import radar_drift
from mmlib.core.layers.adaptive import InnovationAdaptive
from mmlib.core.mixing import CubatureMixing
from mmlib.experiment.simulate import ManeuverSchedule, simulate
from conftest import random_mode_states


def test_cubature_mixing_is_the_weighted_sum_of_independent_gaussians():
    """Independent computation: mean sum mu x, covariance sum mu^2 P (the interaction is linear)."""
    B, r = 5, 3
    means, covs, mu = random_mode_states(1, B, r, scale=50.0)
    T = np.array([[0.99, 0.005, 0.005], [0.005, 0.99, 0.005], [0.005, 0.005, 0.99]])
    _, w = m.estimation.mixing_weights(mu, T)
    mean, cov = CubatureMixing()(means, covs, w)
    for b in range(B):
        for j in range(r):
            np.testing.assert_allclose(mean[b, j], sum(w[b, i, j] * means[b, i] for i in range(r)), rtol=0, atol=1e-10)
            np.testing.assert_allclose(cov[b, j], sum(w[b, i, j] ** 2 * covs[b, i] for i in range(r)),
                                       rtol=1e-12, atol=1e-10)
    # and it is smaller than the moment-matched mixture covariance
    _, mm_cov = m.MomentMixing()(means, covs, w)
    assert np.all(np.linalg.eigvalsh(mm_cov - cov) > 0)


def test_paper_table1_one_dimensional_example():
    """x = [-3, 0, 5], S = [3, 2.25, 1.8], u = [0.3, 0.4, 0.3]: CP gives mean 0.6 and s.d. 1.3826,
    the mixture's exact s.d. is 3.9417 -- the printed 'covariance' column holds standard deviations."""
    means = np.array([[[-3.0], [0.0], [5.0]]])
    covs = np.array([[[[9.0]], [[2.25 ** 2]], [[1.8 ** 2]]]])
    w = np.tile(np.array([0.3, 0.4, 0.3])[:, None], (1, 3))[None]           # mu_{i|j} = u_i for every j
    mean, cov = CubatureMixing()(means, covs, w)
    assert mean[0, 0, 0] == pytest.approx(0.6, abs=1e-12)
    assert np.sqrt(cov[0, 0, 0, 0]) == pytest.approx(1.3826, abs=5e-5)
    _, mm = m.MomentMixing()(means, covs, w)
    assert np.sqrt(mm[0, 0, 0, 0]) == pytest.approx(3.9417, abs=5e-5)


@pytest.fixture(scope="module")
def radar_cv():
    T = 1.0
    cv = models.constant_velocity(T, 5.0)
    radar = models.range_bearing(np.diag([15.0, 15e-6]))
    sched = ManeuverSchedule([cv], [], 0, T, 40)
    mc = m.MonteCarlo(4, 10)
    x0 = np.array([0.0, 10.0, 400.0, 40.0])
    sc = simulate(sched, x0, radar, mc, range(10), process_noise=False)
    return cv, radar, sc, np.tile(x0, (10, 1)), np.diag([100.0, 10.0, 100.0, 10.0])


def test_adaptive_layer_is_the_base_filter_until_its_window_fills(radar_cv):
    cv, radar, sc, x0, P0 = radar_cv
    base = m.SigmaPointFilter(m.Unscented(1.0, 0.0, -1.0))
    ad = InnovationAdaptive(base, window=50)                                 # never fills in 40 steps
    a = m.run(m.SingleModel(base, cv, radar), base.init(x0, P0), sc.measurements)
    b = m.run(m.SingleModel(ad, cv, radar), ad.init(x0, P0), sc.measurements)
    np.testing.assert_array_equal(a.mean, b.mean)


def _has_cholesky(a):
    try:
        np.linalg.cholesky(a)
        return True
    except np.linalg.LinAlgError:
        return False


def test_naukf_innovation_covariance_is_the_empirical_one(radar_cv):
    """Eqs. 27-28: P_zz + Delta R equals the windowed innovation covariance, whatever the rule gives."""
    cv, radar, sc, x0, P0 = radar_cv
    base = m.SigmaPointFilter(m.Unscented(1.0, 0.0, -1.0))
    ad = InnovationAdaptive(base, window=5, zeta=False)
    state = ad.init(x0, P0)
    for k in range(8):
        state = ad.predict(state, cv)
        pred = ad.predict_measurement(state, radar)
        new, info = ad.update(state, sc.measurements[:, k], radar)
        if k >= 4:
            C = np.swapaxes(new.innovations, -1, -2) @ new.innovations / 5
            np.testing.assert_allclose(info.S, C, rtol=1e-12, atol=0)
            K = pred.Pxz @ np.linalg.inv(C)
            # as printed, P - K C K^T can be indefinite: exactly those runs are diverged at this step (NaN)
            alive = np.isfinite(state.cov).all(axis=(1, 2))         # runs not diverged at an earlier step
            post = (state.cov - K @ C @ np.swapaxes(K, -1, -2))[alive]
            indefinite = np.zeros_like(alive)
            indefinite[alive] = [not _has_cholesky(0.5 * (q + q.T)) for q in post]   # LAPACK's verdict, per matrix
            np.testing.assert_array_equal(info.failed[alive], indefinite[alive])
            assert np.isnan(new.mean[indefinite | ~alive]).all()
            ok = alive & ~indefinite
            assert ok.any()
            np.testing.assert_allclose(new.mean[ok], (state.mean + (K @ info.innovation[..., None])[..., 0])[ok],
                                       rtol=1e-10)
        state = new


def test_zeta_inflation_only_when_covariance_matching_fails(radar_cv):
    cv, radar, sc, x0, P0 = radar_cv
    base = m.SigmaPointFilter(m.Unscented(1.0, 0.0, -1.0))
    ad = InnovationAdaptive(base, window=3, psi=1.0)
    state = ad.init(x0, P0)
    for k in range(10):
        state = ad.predict(state, cv)
        state, _ = ad.update(state, sc.measurements[:, k], radar)
        if state.zeta is not None:
            assert np.all(state.zeta >= 1.0)
    huge = InnovationAdaptive(base, window=3, psi=1e12)                      # Eq. 32 always satisfied
    state = huge.init(x0, P0)
    for k in range(10):
        state = huge.predict(state, cv)
        state, _ = huge.update(state, sc.measurements[:, k], radar)
        if state.zeta is not None:
            np.testing.assert_array_equal(state.zeta, 1.0)


def test_sensor_fault_model():
    fault = radar_drift(np.array([3.0, -5.0]), np.array([0.0, 0.01]), np.arange(1, 4.0))
    d = fault.delta
    assert d.shape == (2, 3, 2)
    np.testing.assert_array_equal(d[0, :, 0], 3.0)
    np.testing.assert_allclose(d[1, :, 1], [0.01, 0.02, 0.03])


def test_bad_parameters():
    base = m.SigmaPointFilter(m.Cubature())
    with pytest.raises(ValueError, match="window"):
        InnovationAdaptive(base, window=1)
    with pytest.raises(ValueError, match="psi"):
        InnovationAdaptive(base, psi=0.5)
