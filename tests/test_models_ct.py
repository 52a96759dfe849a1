"""The coordinated-turn model with the turn rate in the state (mmlib.core.models.CoordinatedTurnRate): its
transition against the continuous-time ODE integrated independently, its analytic Jacobian against central
differences, its omega -> 0 limit against the constant-velocity model, its bad input, and the UKF, CKF and EKF
tracking a turning target with it consistently (ANEES)."""
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mmlib as m
from mmlib.core.models import CoordinatedTurnRate, RangeBearing, constant_velocity
from mmlib.core.protocols import SimulatedDynamics
from mmlib.experiment.metrics import chi2_band

EPS = np.finfo(float).eps
T = 2.0
CT = CoordinatedTurnRate(T, q=1.0, q_omega=1e-6)
# turn angles omega * T: zero, tiny (series), both sides of the series/closed-form switch at |theta| = 1, large
RATES = np.array([0.0, 1e-9, -3e-5, math.radians(3.0), -math.radians(12.0), 0.4999, 0.5001, -0.5001, 1.3, -2.9])


def states(rates, seed=0):
    rng = np.random.default_rng(seed)
    x = np.column_stack([rng.normal(0, 5e3, len(rates)), rng.normal(0, 150, len(rates)),
                         rng.normal(0, 5e3, len(rates)), rng.normal(0, 150, len(rates)), rates])
    return x


def ct_ode(_t, s):
    """The continuous-time coordinated turn (Bar-Shalom et al. 2001, Sec. 11.7.1)."""
    x, vx, y, vy, w = s
    return [vx, -w * vy, vy, w * vx, 0.0]


def test_transition_matches_the_integrated_ode():
    # independent reference: DOP853 at rtol 1e-12 over one period; its global error is a few rtol times the
    # state's size, so 1e-9 of the size of each component's scale (position ~ 5e3 m, speed ~ 150 m/s) is met
    # with margin while a wrong sign or a swapped sin/cos term (errors of order v T ~ 100 m) is not
    x = states(RATES)
    got = CT.transition(x)
    for i, xi in enumerate(x):
        ref = solve_ivp(ct_ode, (0.0, T), xi, method="DOP853", rtol=1e-12, atol=1e-9).y[:, -1]
        scale = np.array([5e3, 150, 5e3, 150, 1.0]) + np.abs(xi)
        np.testing.assert_array_less(np.abs(got[i] - ref), 1e-9 * scale, err_msg=f"omega={xi[4]!r}")


def test_transition_is_batched_over_any_leading_axes():
    x = states(RATES).reshape(2, 5, 5)
    np.testing.assert_array_equal(CT.transition(x), CT.transition(x.reshape(-1, 5)).reshape(x.shape))
    np.testing.assert_array_equal(CT.jacobian(x), CT.jacobian(x.reshape(-1, 5)).reshape(2, 5, 5, 5))


def test_jacobian_matches_central_differences():
    x = states(RATES, seed=1)
    J = CT.jacobian(x)
    f0 = np.abs(CT.transition(x)).max(axis=-1)                           # (N,) size of f, for rounding
    # steps: 1e-3 of the component's scale for positions/speeds (f is linear in them: no truncation error) and
    # h_w = 1e-5 rad/s for the rate.  f depends on omega through T s1(omega T) and T c1(omega T), whose third
    # derivatives are T^4 s1''' and T^4 c1''', both bounded by 1/4 (derivatives of sinc-type series), so the
    # central difference's truncation error is <= h_w^2/6 * T^4/4 * (|vx| + |vy|) per row; rounding adds
    # ~ 2 eps |f| / h.
    h = np.array([5.0, 0.15, 5.0, 0.15, 1e-5])
    for j in range(5):
        e = np.zeros(5)
        e[j] = h[j]
        fd = (CT.transition(x + e) - CT.transition(x - e)) / (2 * h[j])
        trunc = (h[j] ** 2 / 6 * T ** 4 / 4 * (np.abs(x[:, 1]) + np.abs(x[:, 3]))) if j == 4 else 0.0
        tol = trunc + 4 * EPS * (f0 + np.abs(x).max(axis=-1) * h[j]) / h[j] + 1e-300
        err = np.abs(fd - J[:, :, j]).max(axis=-1)
        assert np.all(err <= tol), (j, err, tol)


def test_jacobian_check_can_fail():
    # the finite-difference comparison detects a wrong rate column (here: the series' limit b' = T^2/2 dropped)
    x = states(RATES[:3], seed=2)
    J = CT.jacobian(x)
    J[:, 0, 4] += x[:, 3] * T * T / 2
    h = 1e-5
    e = np.array([0, 0, 0, 0, h])
    fd = (CT.transition(x + e) - CT.transition(x - e)) / (2 * h)
    assert np.abs(fd[:, 0] - J[:, 0, 4]).max() > 1.0


@pytest.mark.parametrize("w", [0.0, 1e-300, -1e-12, 1e-7])
def test_zero_rate_limit_is_the_constant_velocity_model(w):
    cv = constant_velocity(T, 1.0)
    x = states(np.full(6, w), seed=3)
    got = CT.transition(x)
    ref = x[:, :4] @ cv.F.T
    # mean-value bound: |df/domega| <= T^2 (|vx| + |vy|) on the position rows and T (|vx| + |vy|) on the
    # velocity rows, so the departure from CV is at most |omega| times that; plus rounding of |x| + T |v|
    v = np.abs(x[:, 1]) + np.abs(x[:, 3])
    bound = np.abs(w) * np.column_stack([T * T * v, T * v, T * T * v, T * v])
    rounding = 4 * EPS * (np.abs(x[:, :4]) + T * v[:, None])
    np.testing.assert_array_less(np.abs(got[:, :4] - ref), bound + rounding + 1e-300)
    assert np.array_equal(got[:, 4], x[:, 4])
    J = CT.jacobian(x)
    np.testing.assert_allclose(J[:, :4, :4], np.broadcast_to(cv.F, (6, 4, 4)), rtol=0, atol=4 * T * abs(w) + 1e-15)
    # the rate column at omega = 0: d/domega of the CT terms, -T^2/2 vy, -T vy, T^2/2 vx, T vx
    lim = np.column_stack([-T * T / 2 * x[:, 3], -T * x[:, 3], T * T / 2 * x[:, 1], T * x[:, 1]])
    np.testing.assert_allclose(J[:, :4, 4], lim, rtol=0, atol=T * T * v.max() * (abs(w) * T + 1e-13))


def test_process_noise_is_white_acceleration_plus_rate_random_walk():
    q, qw = 2.5, 3e-6
    ct = CoordinatedTurnRate(T, q, qw)
    cv = constant_velocity(T, q)
    np.testing.assert_allclose(ct.Q[:4, :4], cv.Q, rtol=1e-15)          # the CV model's white acceleration
    assert ct.Q[4, 4] == pytest.approx(T * T * qw, rel=1e-15)            # rate increment T sqrt(q_omega)
    assert np.all(ct.Q[:4, 4] == 0)
    np.testing.assert_allclose(ct.noise_factor @ ct.noise_factor.T, ct.Q, rtol=1e-15, atol=0)
    assert isinstance(ct, SimulatedDynamics)
    with pytest.raises(ValueError):                                       # read-only
        ct.Q[0, 0] = 1.0


@pytest.mark.parametrize("kwargs, name", [
    (dict(T=0.0, q=1.0, q_omega=1.0), "T"), (dict(T=np.nan, q=1.0, q_omega=1.0), "T"),
    (dict(T=1.0, q=-1.0, q_omega=1.0), "q"), (dict(T=1.0, q="1", q_omega=1.0), "q"),
    (dict(T=1.0, q=1.0, q_omega=np.inf), "q_omega"), (dict(T=1.0, q=1.0, q_omega=-1e-9), "q_omega"),
    (dict(T=1.0, q=1.0, q_omega=1.0, name=3), "name"),
])
def test_bad_parameters_name_the_argument(kwargs, name):
    with pytest.raises(ValueError, match=rf"^{name}:"):
        CoordinatedTurnRate(**kwargs)


@pytest.mark.parametrize("method", ["transition", "jacobian"])
def test_bad_state_names_x(method):
    with pytest.raises(ValueError, match=r"^x:"):
        getattr(CT, method)(np.zeros((3, 4)))


# --------------------------------------------------------------------------- tracking a turning target
B, K = 300, 60
X0 = np.array([6e3, -120.0, 4e3, 60.0, math.radians(4.0)])      # 4 deg/s turn, ~7 km from the radar
P0 = np.diag([40.0 ** 2, 8.0 ** 2, 40.0 ** 2, 8.0 ** 2, math.radians(1.0) ** 2])
MODEL = CoordinatedTurnRate(1.0, q=0.5 ** 2, q_omega=math.radians(0.1) ** 2)
RADAR = RangeBearing(np.diag([15.0 ** 2, math.radians(0.15) ** 2]), position_index=(0, 2))   # at the origin


def _scenario(seed=11):
    """B runs of the CT model itself (so a filter assuming it is matched), truth x_0 ~ N(X0, P0) per run."""
    rng = np.random.default_rng(seed)
    truth = np.empty((B, K + 1, 5))
    truth[:, 0] = X0 + rng.standard_normal((B, 5)) @ np.linalg.cholesky(P0).T
    for k in range(K):
        truth[:, k + 1] = MODEL.transition(truth[:, k]) + rng.standard_normal((B, 3)) @ MODEL.noise_factor.T
    radar = RADAR
    z = radar.h(truth[:, 1:]) + rng.standard_normal((B, K, 2)) @ radar.noise_factor.T
    return truth, z, radar


def _anees(filt, model, truth, z, radar):
    est = m.SingleModel(filt, model, radar)
    track = m.run(est, est.init(np.tile(X0, (B, 1)), P0), z, consistency=True, truth=truth)
    assert not track.diverged.any(), track.divergence_summary()
    per_run = track.nees.mean(axis=1)                     # (B,) time-averaged NEES of each run: independent
    return per_run.mean(), per_run.std(ddof=1) / math.sqrt(B)


FILTERS = {"UKF": lambda: m.SigmaPointFilter(m.Unscented()), "CKF": lambda: m.SigmaPointFilter(m.Cubature()),
           "EKF": lambda: m.ExtendedKalmanFilter()}


@pytest.fixture(scope="module")
def scenario():
    return _scenario()


@pytest.mark.parametrize("name", list(FILTERS))
def test_filters_track_a_turn_consistently(name, scenario):
    # a consistent filter's NEES has mean n = 5 at every step (chi-square, Bar-Shalom et al. 2001 Sec. 5.4.2);
    # the per-run time averages are independent across runs, so their mean is within 3 standard errors of 5
    # (99.7 %) if the filter is consistent; the per-run averages over K correlated steps are not chi-square, so
    # the standard error is estimated from them rather than taken from chi2(5 K).  The run-averages per step
    # must also lie in the two-sided 99 % chi-square band of B runs at (nearly) every step: with 60 steps,
    # ~0.6 are expected outside, and 6 (10 %) outside would be far in the tail even for correlated steps.
    truth, z, radar = scenario
    anees, se = _anees(FILTERS[name](), MODEL, truth, z, radar)
    assert abs(anees - 5.0) <= 3 * se, (name, anees, se)
    est = m.SingleModel(FILTERS[name](), MODEL, radar)
    track = m.run(est, est.init(np.tile(X0, (B, 1)), P0), z, consistency=True, truth=truth)
    lo, hi = chi2_band(5, B, 0.99)
    per_step = track.nees.mean(axis=0)
    assert np.sum((per_step < lo) | (per_step > hi)) < 0.1 * K, (name, per_step)


def test_consistency_check_can_fail(scenario):
    # the same check rejects a filter that assumes 4 times less process noise than the truth has (ANEES ~ 2x)
    truth, z, radar = scenario
    overconfident = CoordinatedTurnRate(1.0, q=MODEL.q / 4, q_omega=MODEL.q_omega / 4)
    anees, se = _anees(FILTERS["UKF"](), overconfident, truth, z, radar)
    assert anees - 5.0 > 3 * se, (anees, se)
