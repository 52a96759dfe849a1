"""Observation bootstrapping (Hu et al. 2017 Eqs. 15-24) and the two central-difference forms."""
import numpy as np
import pytest

import mmlib as m
from mmlib.core import models
from mmlib.core.layers.bootstrap import ObservationBootstrap
from mmlib.experiment.montecarlo import Stream
from mmlib.experiment.simulate import ManeuverSchedule, simulate


@pytest.fixture(scope="module")
def radar_ct():
    T = 1.0
    G = np.array([[0.0, T / 2], [0.0, T], [T / 2, 0.0], [T, 0.0]])
    dyn = [models.coordinated_turn(T, 0.3, 0.002, G), models.coordinated_turn(T, -0.15, 0.004, G)]
    radar = models.range_bearing(np.diag([0.1 ** 2, np.radians(0.1) ** 2]))
    sched = ManeuverSchedule(dyn, [(10, 25, 1)], 0, T, 35)
    mc = m.MonteCarlo(9, 12)
    x0 = np.array([8.0, 0.4, 6.0, 0.2])
    sc = simulate(sched, x0, radar, mc, range(12))
    noise = mc.standard_normal(range(12), Stream.FILTER, (35, 2, 2))
    P0 = np.diag([0.1, 0.01, 0.1, 0.01]) ** 2
    return dyn, radar, sc, np.tile(x0, (12, 1)), P0, noise, mc


def test_weighted_central_difference_is_the_unscented_rule():
    for n in (2, 4, 6):
        cd = m.CentralDifference(form="weighted").unit_points(n)
        ut = m.Unscented(alpha=1.0, beta=0.0, kappa=3.0 - n).unit_points(n)
        np.testing.assert_allclose(cd.xi, ut.xi, rtol=0, atol=1e-15)
        np.testing.assert_allclose(cd.wm, ut.wm, rtol=0, atol=1e-15)
        np.testing.assert_allclose(cd.wc, ut.wc, rtol=0, atol=1e-15)


def _cd_moments(form, fn, m_, P):
    rule = m.CentralDifference(form=form)
    X = rule.points(m_, np.linalg.cholesky(P))
    Y = fn(X)
    ybar = rule.unit_points(m_.shape[-1]).wm @ Y
    return ybar, rule.covariances(X - m_[:, None], Y - ybar[:, None])


def test_the_two_central_difference_forms_share_the_mean_and_part_on_cross_terms():
    """Stirling (Norgaard et al. 2000) and the weighted form printed by Hu et al. share points and
    mean weights (same mean, both exact on linear maps: tests/test_rules.py); their covariances part
    on nonlinear terms. For y = x^T A x with a cross term the exact variance is
    4 m^T A P A m + 2 tr(APAP) = 14.275; neither form is exact (Stirling 13.33, weighted 13.77)."""
    m_ = np.array([[1.5, -0.4]])
    P = np.array([[[0.5, 0.1], [0.1, 0.3]]])
    A = np.array([[1.0, 1.5], [1.5, -1.0]])
    quad = lambda X: np.stack([np.einsum("...i,ij,...j->...", X, A, X), X[..., 1]], -1)
    (ya, (pa, _)), (yb, (pb, _)) = _cd_moments("stirling", quad, m_, P), _cd_moments("weighted", quad, m_, P)
    np.testing.assert_allclose(ya, yb, rtol=0, atol=1e-12)
    exact = 4 * m_[0] @ A @ P[0] @ A @ m_[0] + 2 * np.trace(A @ P[0] @ A @ P[0])
    assert exact == pytest.approx(14.275)
    assert pa[0, 0, 0] == pytest.approx(13.3286, abs=1e-9) and pb[0, 0, 0] == pytest.approx(13.7654, abs=1e-9)


def test_obs_with_zero_bootstrap_observations_is_the_base_filter(radar_ct):
    dyn, radar, sc, x0, P0, noise, _ = radar_ct
    base = m.SigmaPointFilter(m.CentralDifference(form="weighted"))
    obs0 = ObservationBootstrap(base, n_boot=0)
    for est_a, est_b in ((m.SingleModel(base, dyn[0], radar), m.SingleModel(obs0, dyn[0], radar)),
                         (m.IMM(base, dyn, radar, [[0.95, 0.05], [0.05, 0.95]]),
                          m.IMM(obs0, dyn, radar, [[0.95, 0.05], [0.05, 0.95]]))):
        a = m.run(est_a, est_a.init(x0, P0), sc.measurements)
        b = m.run(est_b, est_b.init(x0, P0), sc.measurements)
        np.testing.assert_array_equal(a.mean, b.mean)


def test_obs_is_deterministic_and_chunk_invariant(radar_ct):
    dyn, radar, sc, x0, P0, noise, mc = radar_ct
    obs = ObservationBootstrap(m.SigmaPointFilter(m.CentralDifference(form="weighted")), n_boot=2)
    imm = m.IMM(obs, dyn, radar, [[0.95, 0.05], [0.05, 0.95]])
    whole = m.run(imm, imm.init(x0, P0, noise=noise), sc.measurements)
    again = m.run(imm, imm.init(x0, P0, noise=mc.standard_normal(range(12), Stream.FILTER, (35, 2, 2))),
                  sc.measurements)
    part = m.run(imm, imm.init(x0[:5], P0, noise=noise[:5]), sc.measurements[:5])
    np.testing.assert_array_equal(whole.mean, again.mean)
    np.testing.assert_array_equal(whole.mean[:5], part.mean)
    assert not whole.diverged.any()


def test_obs_fusion_of_identical_members_shrinks_covariance_by_members(radar_ct):
    """Eqs. 22-24 with N + 1 identical posteriors: the fused covariance is P / (N + 1) -- the
    over-confidence that comes from fusing correlated estimates as independent."""
    dyn, radar, sc, x0, P0, _, _ = radar_ct
    base = m.SigmaPointFilter(m.Cubature())
    obs = ObservationBootstrap(base, n_boot=3, variance_factor=1.0)
    zero = np.zeros((12, 35, 3, 2))                                        # bootstrap obs = z exactly
    pred = base.predict(base.init(x0, P0), dyn[0])
    post_base, _ = base.update(pred, sc.measurements[:, 0], radar)
    post_obs, _ = obs.update(obs.predict(obs.init(x0, P0, noise=zero), dyn[0]), sc.measurements[:, 0], radar)
    np.testing.assert_allclose(post_obs.mean, post_base.mean, rtol=0, atol=1e-10)
    np.testing.assert_allclose(post_obs.cov, post_base.cov / 4.0, rtol=1e-9, atol=1e-15)


def test_imm_likelihood_in_log_space_survives_tiny_likelihoods(radar_ct):
    """Measurements 1e3 standard deviations off: linear-space likelihoods underflow to 0, log space does not."""
    dyn, radar, sc, x0, P0, noise, _ = radar_ct
    imm = m.IMM(m.SigmaPointFilter(m.Cubature()), dyn, radar, [[0.95, 0.05], [0.05, 0.95]])
    z = sc.measurements.copy()
    z[:, 5, 0] += 100.0                                                   # 100 km range outlier
    track = m.run(imm, imm.init(x0, P0), z)
    assert np.isfinite(track.mode_probabilities).all()
    np.testing.assert_allclose(track.mode_probabilities.sum(-1), 1.0, atol=1e-12)


def test_bad_parameters(radar_ct):
    _, radar, _, x0, P0, _, _ = radar_ct
    base = m.SigmaPointFilter(m.Cubature())
    with pytest.raises(ValueError, match="n_boot"):
        ObservationBootstrap(base, n_boot=-1)
    with pytest.raises(ValueError, match="variance_factor"):
        ObservationBootstrap(base, variance_factor=0.0)
    with pytest.raises(ValueError, match="likelihood"):
        ObservationBootstrap(base, likelihood="max")
    with pytest.raises(ValueError, match="noise"):
        ObservationBootstrap(base, n_boot=2).init(x0, P0)
    with pytest.raises(ValueError, match="h"):
        m.CentralDifference(h=0.0)
    with pytest.raises(ValueError, match="form"):
        m.CentralDifference(form="ito")
