"""Strong tracking layer (Liu & Wu 2017, Eqs. 13-19, 28)."""
import numpy as np
import pytest

import mmlib as m
from mmlib.core import models
from mmlib.experiment.simulate import ManeuverSchedule, simulate
from mmlib.core.layers.strong_tracking import StrongTracking

BASES = [m.ExtendedKalmanFilter(), m.SigmaPointFilter(m.Unscented(1.0, 0.0, -3.0)), m.SigmaPointFilter(m.Cubature()),
         m.SigmaPointFilter(m.SphericalSimplexRadial()), m.SigmaPointFilter(m.FifthDegreeCubature()),
         m.SigmaPointFilter(m.CentralDifference())]
BASE_IDS = ["EKF", "UKF", "CKF", "SSRCKF", "5CKF", "CDKF"]


@pytest.fixture(scope="module")
def radar_ca():
    """CA target, range-bearing radar; an acceleration jump at t = 20 s the filter's small Q cannot follow."""
    T = 1.0
    ca = models.constant_acceleration(T, 0.01)
    radar = models.range_bearing(np.diag([30.0 ** 2, 0.01 ** 2]), state_dim=6)
    sched = ManeuverSchedule([ca], [], 0, T, 40, jumps=[(20.0, (2, 5), (6.0, 8.0))])   # along the line of sight
    mc = m.MonteCarlo(5, 30)
    x0 = np.array([3000.0, 15.0, 0.0, 4000.0, 20.0, 0.0])
    sc = simulate(sched, x0, radar, mc, range(30), process_noise=False)
    P0 = np.diag([50.0, 20.0, 1.0, 50.0, 10.0, 1.0]) ** 2
    return ca, radar, sc, np.tile(x0, (30, 1)), P0


@pytest.mark.parametrize("base", BASES, ids=BASE_IDS)
def test_strong_tracking_off_is_the_base_filter_bit_for_bit(base, radar_ca):
    ca, radar, sc, x0, P0 = radar_ca
    off = StrongTracking(base, beta=1e12, rho=0.95)        # N << 0 => lambda = 1 at every step
    ref = m.run(m.SingleModel(base, ca, radar), base.init(x0, P0), sc.measurements)
    st = m.run(m.SingleModel(off, ca, radar), off.init(x0, P0), sc.measurements)
    np.testing.assert_array_equal(st.mean, ref.mean)
    np.testing.assert_array_equal(st.cov, ref.cov)


@pytest.mark.parametrize("base", BASES, ids=BASE_IDS)
def test_fading_factor_at_least_one_and_helps_after_a_jump(base, radar_ca):
    ca, radar, sc, x0, P0 = radar_ca
    st = StrongTracking(base)
    state = st.init(x0, P0)
    lams = []
    for k in range(sc.measurements.shape[1]):
        state = st.predict(state, ca)
        state, _ = st.update(state, sc.measurements[:, k], radar)
        lams.append(state.fading)
    lams = np.array(lams)
    assert np.all(lams >= 1.0)
    # the jump at t = 20 s is detected: ~2.0 afterwards against ~1.1 before (30 runs, fixed seed)
    assert lams[21:31].mean() > 1.5 * lams[5:19].mean()
    err = lambda tr: np.sqrt(((tr.mean[:, 20:, [0, 3]] - sc.truth[:, 21:, [0, 3]]) ** 2).sum(-1).mean())
    plain = m.run(m.SingleModel(base, ca, radar), base.init(x0, P0), sc.measurements)
    strong = m.run(m.SingleModel(st, ca, radar), st.init(x0, P0), sc.measurements)
    # with beta = 4.5 the gain is small (a converged CA filter needs lambda ~ 1e4 to follow the jump)
    assert err(strong) < err(plain)


def test_fading_factor_is_one_when_innovations_match_their_prediction(radar_ca):
    ca, radar, sc, x0, P0 = radar_ca
    for form, base in (("statistical", m.SigmaPointFilter(m.Cubature())), ("jacobian", m.ExtendedKalmanFilter())):
        st = StrongTracking(base, beta=1.0, form=form)
        state = st.predict(st.init(x0, P0), ca)
        pred = st.predict_measurement(state, radar)
        lam = st.fading_factor(state, pred, pred.S, radar)          # V_k = P_zz exactly
        np.testing.assert_array_equal(lam, 1.0)
        lam_big = st.fading_factor(state, pred, 50.0 * pred.S, radar)
        assert np.all(lam_big > 1.0)


def test_jacobian_and_statistical_forms_coincide_for_the_ekf(radar_ca):
    ca, radar, sc, x0, P0 = radar_ca
    tracks = {}
    for form in ("jacobian", "statistical"):
        st = StrongTracking(m.ExtendedKalmanFilter(), form=form)
        tracks[form] = m.run(m.SingleModel(st, ca, radar), st.init(x0, P0), sc.measurements)
    # Pxz = P H^T makes Eqs. 18-19 equal Eqs. 15-16; differences are round-off of a P^-1 solve (values ~1e4)
    np.testing.assert_allclose(tracks["statistical"].mean, tracks["jacobian"].mean, rtol=0, atol=1e-6)


def test_strong_tracking_inside_an_imm(radar_ca):
    ca, radar, sc, x0, P0 = radar_ca
    ca2 = models.constant_acceleration(1.0, 1.0)
    base = m.SigmaPointFilter(m.Cubature())
    imm_st = m.IMM(StrongTracking(base, beta=1e12), [ca, ca2], radar, [[0.95, 0.05], [0.05, 0.95]])
    imm = m.IMM(base, [ca, ca2], radar, [[0.95, 0.05], [0.05, 0.95]])
    a = m.run(imm_st, imm_st.init(x0, P0), sc.measurements)
    b = m.run(imm, imm.init(x0, P0), sc.measurements)
    np.testing.assert_array_equal(a.mean, b.mean)


def test_bad_parameters():
    base = m.SigmaPointFilter(m.Cubature())
    with pytest.raises(ValueError, match="beta"):
        StrongTracking(base, beta=0.5)
    with pytest.raises(ValueError, match="rho"):
        StrongTracking(base, rho=0.0)
    with pytest.raises(ValueError, match="rho"):
        StrongTracking(base, rho=1.5)
    with pytest.raises(ValueError, match="form"):
        StrongTracking(base, form="hessian")
    st = StrongTracking(base)
    with pytest.raises(ValueError, match="predict"):
        st.update(st.init(np.zeros((1, 4)), np.eye(4)), np.zeros((1, 2)), models.RangeBearing(np.eye(2)))
