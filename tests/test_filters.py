"""Every filter against the closed-form Kalman filter, limit cases, wrapping, divergence."""
import numpy as np
import pytest

import mmlib as m
from mmlib.core import models
from conftest import random_mode_states, textbook_kf
from mmlib.core import linalg as m_linalg

FILTERS = [m.KalmanFilter(), m.ExtendedKalmanFilter(),
           m.SigmaPointFilter(m.Unscented()), m.SigmaPointFilter(m.Unscented(alpha=0.1, beta=2.0, kappa=0.0)),
           m.SigmaPointFilter(m.Unscented(alpha=1.0, beta=2.0, kappa=-1.0)),
           m.SigmaPointFilter(m.Cubature()), m.SigmaPointFilter(m.FifthDegreeCubature()),
           m.SigmaPointFilter(m.SphericalSimplexRadial()), m.SigmaPointFilter(m.CentralDifference())]
IDS = ["KF", "EKF", "UKF", "UKF-small-alpha", "UKF-kappa-1", "CKF", "5CKF", "SSRCKF", "CDKF"]


def weight_amplification(filt, n=4):
    """sum |w_i|: how much a rule's weights amplify round-off (1 for positive weights,
    ~2/alpha^2 for a scaled unscented rule with small alpha)."""
    rule = getattr(filt, "rule", None)
    return 1.0 if rule is None else float(np.abs(rule.unit_points(n).wm).sum())


@pytest.mark.parametrize("filt", FILTERS, ids=IDS)
def test_equals_closed_form_kf_on_linear_model(filt, linear_problem):
    dyn, meas, x0, P0, zs = linear_problem
    track = m.run(m.SingleModel(filt, dyn, meas), filt.init(x0, P0), zs)
    assert not track.diverged.any()
    # floating-point scale: values ~1e3, ~1e3 flops per run -> ~1e-10, amplified by sum |w|
    atol = 1e-9 * weight_amplification(filt)
    for b in range(x0.shape[0]):
        ref_x, ref_P, _ = textbook_kf(x0[b], P0, dyn.F, dyn.Q, meas.H, meas.R, zs[b])
        np.testing.assert_allclose(track.mean[b], ref_x, rtol=0, atol=atol)
        np.testing.assert_allclose(track.cov[b], ref_P, rtol=0, atol=atol)


@pytest.mark.parametrize("filt", FILTERS, ids=IDS)
def test_loglik_equals_closed_form(filt, linear_problem):
    dyn, meas, x0, P0, zs = linear_problem
    state = filt.init(x0, P0)
    _, _, ref_ll = textbook_kf(x0[0], P0, dyn.F, dyn.Q, meas.H, meas.R, zs[0, :1])
    state = filt.predict(state, dyn)
    _, info = filt.update(state, zs[:, 0], meas)
    assert info.loglik[0] == pytest.approx(ref_ll[0], abs=1e-10 * weight_amplification(filt))


@pytest.mark.parametrize("filt", FILTERS, ids=IDS)
def test_limit_measurement_noise_to_zero_and_infinity(filt, linear_problem):
    dyn, _, x0, P0, zs = linear_problem
    state = filt.predict(filt.init(x0, P0), dyn)
    tiny = models.position_measurement([1e-10, 1e-10])
    post, _ = filt.update(state, zs[:, 0], tiny)
    # R -> 0: the position estimate is the measurement, its variance -> R P/(P+R) < R,
    # up to the cancellation error of P - K S K^T (~100 ulps of P ~ 1e2)
    np.testing.assert_allclose(post.mean[:, [0, 2]], zs[:, 0], rtol=0, atol=1e-6)
    assert np.all(post.cov[:, [0, 2], [0, 2]] <= 1e-10 + 100 * np.finfo(float).eps * state.cov.max())
    huge = models.position_measurement([1e12, 1e12])
    post, _ = filt.update(state, zs[:, 0], huge)
    # R -> inf: the update leaves the prediction unchanged (gain ~ P/R ~ 1e-10)
    np.testing.assert_allclose(post.mean, state.mean, rtol=0, atol=1e-6)
    # (P - K S K^T differs from P by ~P^2/R ~ 1e-8)
    np.testing.assert_allclose(post.cov, state.cov, rtol=0, atol=1e-6)


def test_imm_with_one_model_equals_its_filter(linear_problem):
    dyn, meas, x0, P0, zs = linear_problem
    for filt in FILTERS[:3] + FILTERS[5:7]:
        single = m.run(m.SingleModel(filt, dyn, meas), filt.init(x0, P0), zs)
        imm = m.IMM(filt, [dyn], meas, np.eye(1))
        track = m.run(imm, imm.init(x0, P0), zs)
        np.testing.assert_allclose(track.mean, single.mean, rtol=0, atol=1e-10)
        np.testing.assert_allclose(track.cov, single.cov, rtol=0, atol=1e-10)
        np.testing.assert_array_equal(track.mode_probabilities, 1.0)


def test_imm_with_identical_modes_equals_single_filter(linear_problem):
    dyn, meas, x0, P0, zs = linear_problem
    filt = m.SigmaPointFilter(m.Cubature())
    single = m.run(m.SingleModel(filt, dyn, meas), filt.init(x0, P0), zs)
    imm = m.IMM(filt, [dyn, dyn, dyn], meas, [[0.8, 0.15, 0.05], [0.1, 0.8, 0.1], [0.3, 0.3, 0.4]])
    track = m.run(imm, imm.init(x0, P0, [0.2, 0.3, 0.5]), zs)
    np.testing.assert_allclose(track.mean, single.mean, rtol=0, atol=1e-9)
    # mode probabilities evolve as the Markov chain alone: mu_k = mu_0 T^k
    T = imm.transition
    mu = np.array([0.2, 0.3, 0.5])
    for k in range(zs.shape[1]):
        mu = mu @ T
        np.testing.assert_allclose(track.mode_probabilities[:, k], np.tile(mu, (3, 1)), atol=1e-12)


def test_transition_rows_are_from():
    """c_j = sum_i p_ij mu_i: with mu = e_0 the predicted probabilities are row 0."""
    T = np.array([[0.7, 0.2, 0.1], [0.0, 1.0, 0.0], [0.5, 0.0, 0.5]])
    c, w = m.estimation.mixing_weights(np.array([[1.0, 0.0, 0.0]]), T)
    np.testing.assert_array_equal(c[0], T[0])
    np.testing.assert_allclose(w.sum(axis=1), 1.0)


def test_mixing_matches_explicit_sums():
    B, r = 4, 3
    means, covs, mu = random_mode_states(0, B, r)
    T = np.array([[0.9, 0.05, 0.05], [0.1, 0.8, 0.1], [0.05, 0.15, 0.8]])
    _, w = m.estimation.mixing_weights(mu, T)
    mm, mc = m.MomentMixing()(means, covs, w)
    for b in range(B):
        for j in range(r):
            x = sum(w[b, i, j] * means[b, i] for i in range(r))
            P = sum(w[b, i, j] * (covs[b, i] + np.outer(means[b, i] - x, means[b, i] - x)) for i in range(r))
            np.testing.assert_allclose(mm[b, j], x, rtol=1e-13, atol=1e-11)
            np.testing.assert_allclose(mc[b, j], P, rtol=1e-12, atol=1e-9)


# ------------------------------------------------------------------ bearing wrapping
def test_wrap_angle_range():
    a = np.array([-np.pi, np.pi, 3 * np.pi, -3 * np.pi + 1e-9, 0.0, 7.0, -7.0])
    w = models.wrap_angle(a)
    assert np.all(w > -np.pi) and np.all(w <= np.pi)
    np.testing.assert_allclose(np.cos(w), np.cos(a), atol=1e-12)
    assert models.wrap_angle(np.array(-np.pi)) == np.pi


def test_range_bearing_residual_and_average_across_the_cut():
    rb = models.RangeBearing(np.diag([1.0, 1e-4]))
    a = np.array([100.0, np.pi - 0.01])
    b = np.array([100.0, -np.pi + 0.01])
    assert rb.residual(a, b)[1] == pytest.approx(-0.02, abs=1e-12)
    vals = np.array([[[100.0, np.pi - 0.01], [100.0, -np.pi + 0.01]]])
    avg = rb.average(vals, np.array([0.5, 0.5]))
    assert abs(abs(avg[0, 1]) - np.pi) < 1e-12


@pytest.mark.parametrize("filt", [m.ExtendedKalmanFilter(), m.SigmaPointFilter(m.Unscented()),
                                  m.SigmaPointFilter(m.Cubature()), m.SigmaPointFilter(m.CentralDifference())],
                         ids=["EKF", "UKF", "CKF", "CDKF"])
def test_range_bearing_update_is_rotation_invariant(filt):
    """A target on the -x axis (bearing at the +-pi cut) is updated exactly like the same
    geometry rotated by 90 degrees, where no wrapping occurs."""
    rb = models.RangeBearing(np.diag([25.0, 1e-4]))
    x = np.array([[-1000.0, 5.0, 3.0, -2.0]])
    P = np.diag([400.0, 4.0, 400.0, 4.0])[None]
    z = np.array([[1001.0, np.pi - 0.004]])
    post, _ = filt.update(m.GaussianState(x, P), z, rb)
    R90 = np.array([[0, 0, -1, 0], [0, 0, 0, -1], [1, 0, 0, 0], [0, 1, 0, 0]], float)  # (x,y) -> (-y, x)
    post_r, _ = filt.update(m.GaussianState(x @ R90.T, R90 @ P @ R90.T),
                            np.array([[1001.0, models.wrap_angle(np.pi - 0.004 + np.pi / 2)]]), rb)
    np.testing.assert_allclose(post_r.mean, post.mean @ R90.T, rtol=0, atol=1e-8)
    np.testing.assert_allclose(post_r.cov, R90 @ post.cov @ R90.T, rtol=1e-9, atol=1e-9)


def test_ekf_range_bearing_jacobian_matches_finite_differences():
    rb = models.RangeBearing(np.eye(2), sensor=np.array([10.0, -20.0]))
    x = np.array([300.0, 1.0, 400.0, 2.0])
    J = rb.jacobian(x)
    eps = 1e-6
    num = np.stack([(rb.h(x + eps * e) - rb.h(x - eps * e)) / (2 * eps) for e in np.eye(4)], axis=1)
    np.testing.assert_allclose(J, num, rtol=1e-7, atol=1e-10)


# ------------------------------------------------------------------ divergence
def test_non_pd_covariance_is_reported_not_patched(linear_problem):
    dyn, meas, x0, P0, zs = linear_problem
    filt = m.SigmaPointFilter(m.Cubature())
    state = filt.init(x0, P0)
    bad_cov = state.cov.copy()
    bad_cov[1] = -bad_cov[1]                       # run 1 loses positive definiteness mid-filter
    state = state._replace(cov=bad_cov)
    track = m.run(m.SingleModel(filt, dyn, meas), state, zs)
    assert track.diverged_step.tolist() == [-1, 0, -1]
    assert np.isnan(track.mean[1]).all()
    good = m.run(m.SingleModel(filt, dyn, meas), filt.init(x0, P0), zs)
    np.testing.assert_array_equal(track.mean[[0, 2]], good.mean[[0, 2]])
    with pytest.raises(m.estimation.FilterDivergence, match="run 1 diverged at step 0"):
        m.run(m.SingleModel(filt, dyn, meas), state, zs, on_divergence="raise")


@pytest.mark.parametrize("m", [1, 2, 3, 5])
def test_tril_inverse(m):
    rng = np.random.default_rng(m)
    L = np.tril(rng.standard_normal((7, 2, m, m))) + 3 * np.eye(m)
    inv = m_linalg.tril_inverse(L)
    np.testing.assert_allclose(inv @ L, np.broadcast_to(np.eye(m), L.shape), rtol=0, atol=1e-14)
    np.testing.assert_array_equal(m_linalg.tril_inverse(L[:3]), inv[:3])      # batch-size invariant


def test_cholesky_reports_failures_per_matrix():
    a = np.eye(3) * np.ones((4, 2, 1, 1))
    a[1, 1, 2, 2] = -1.0
    L, failed = m_linalg.cholesky(a)
    assert failed.tolist() == [[False, False], [False, True], [False, False], [False, False]]
    assert np.isnan(L[1, 1]).all() and np.isfinite(L[0]).all()


def test_known_mode_sequence_equals_single_model_when_one_mode(linear_problem):
    dyn, meas, x0, P0, zs = linear_problem
    kf = m.KalmanFilter()
    single = m.run(m.SingleModel(kf, dyn, meas), kf.init(x0, P0), zs)
    known = m.estimation.KnownModeSequence(kf, [dyn], np.zeros(zs.shape[1], int), meas)
    track = m.run(known, known.init(x0, P0), zs)
    np.testing.assert_array_equal(track.mean, single.mean)
    with pytest.raises(ValueError, match="beyond"):
        m.run(known, known.init(x0, P0), np.concatenate([zs, zs], axis=1))


def test_unreachable_mode_does_not_poison_the_imm(linear_problem):
    """mu0 = (1, 0) with an identity transition: mode 2 has predicted probability 0."""
    dyn, meas, x0, P0, zs = linear_problem
    kf = m.KalmanFilter()
    imm = m.IMM(kf, [dyn, models.coordinated_turn(1.0, 0.1, 2.0)], meas, np.eye(2))
    track = m.run(imm, imm.init(x0, P0, [1.0, 0.0]), zs)
    single = m.run(m.SingleModel(kf, dyn, meas), kf.init(x0, P0), zs)
    assert not track.diverged.any()
    np.testing.assert_allclose(track.mean, single.mean, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(track.mode_probabilities[..., 1], 0.0)


def test_measurement_factories_locate_positions_for_cv_and_ca_states():
    x4 = np.array([[3.0, -1.0, 4.0, 2.0]])
    x6 = np.array([[3.0, -1.0, 9.0, 4.0, 2.0, 7.0]])
    assert models.range_bearing(np.eye(2), state_dim=4).h(x4)[0, 0] == pytest.approx(5.0)
    assert models.range_bearing(np.eye(2), state_dim=6).h(x6)[0, 0] == pytest.approx(5.0)
    np.testing.assert_array_equal(models.position_measurement([1.0, 1.0], state_dim=6).h(x6), [[3.0, 4.0]])
    with pytest.raises(ValueError, match="state_dim"):
        models.range_bearing(np.eye(2), state_dim=5)
