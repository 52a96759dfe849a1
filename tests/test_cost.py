"""The cost model (``mmlib.core.cost``) against operations counted directly, exactly (rtol 0).

Each filter -- the KF, UKF, CKF, fifth-degree CKF and an IMM -- runs one step as a scalar implementation on numbers
that count every arithmetic operation, stage by stage (``tests/counting.py``, written independently of the model);
the counts must equal the model's terms, and the same implementation's numbers must equal mmlib's step (to
round-off), so the counted algorithm is the one the library runs.  Then hand-computed small cases, properties of the
layers' counts and bad input.
"""
import math

import numpy as np
import pytest

import counting as cnt
import mmlib
from mmlib.core import cost, models
from mmlib.core.estimation import IMMState, KnownModeSequence, SingleModel
from mmlib.core.filters import ExtendedKalmanFilter, GaussianState, KalmanFilter, SigmaPointFilter
from mmlib.core.layers.adaptive import InnovationAdaptive
from mmlib.core.layers.bootstrap import ObservationBootstrap
from mmlib.core.layers.strong_tracking import StrongTracking
from mmlib.core.mixing import CubatureMixing
from mmlib.core.rules import (CentralDifference, Cubature, FifthDegreeCubature, SphericalSimplexRadial, Unscented)

RULES = {"ukf": Unscented(1.0, 2.0, 0.0), "ckf": Cubature(), "5ckf": FifthDegreeCubature()}


def _models(n, m, r, kind, rng):
    """r random linear dynamics on n states and a measurement: dense linear (m rows) or range-bearing (m = 2)."""
    dyn = []
    for _ in range(r):
        F = np.eye(n) + 0.3 * rng.standard_normal((n, n))
        G = rng.standard_normal((n, n))
        Q = G @ G.T + 0.1 * np.eye(n)
        dyn.append(models.LinearGaussianDynamics(F, Q, np.linalg.cholesky(Q)))
    if kind == "linear":
        H = rng.standard_normal((m, n))
        Rg = rng.standard_normal((m, m))
        return dyn, models.LinearMeasurement(H, Rg @ Rg.T + np.eye(m)), cnt.Measurement(H)
    radar = models.range_bearing(np.diag([30.0 ** 2, 0.01 ** 2]), state_dim=n)
    return dyn, radar, cnt.Measurement(idx=radar.position_index)


def _state(n, rng, kind):
    mean = rng.standard_normal(n) * 3.0
    if kind == "range-bearing":
        i, j = models.position_indices(n)
        mean[i], mean[j] = 2000.0 + mean[i], 1500.0 + mean[j]
    A = rng.standard_normal((n, n))
    return mean, A @ A.T + np.eye(n)


def _count_single(filt_kind, n, m, kind, seed=5):
    """Count one SingleModel step of the KF or a sigma-point filter; return (counts, the model's terms)."""
    rng = np.random.default_rng(seed)
    (dyn,), meas, meas_c = _models(n, m, 1, kind, rng)
    filt = KalmanFilter() if filt_kind == "kf" else SigmaPointFilter(RULES[filt_kind])
    est = SingleModel(filt, dyn, meas)
    mean, cov = _state(n, rng, kind)
    z = meas.h(mean[None])[0] + 0.1
    cnt.reset()
    up = None if filt_kind == "kf" else filt.rule.unit_points(n)
    x, P, ll = cnt.filter_step(filt_kind, cnt.cs(mean), cnt.cs(cov), list(z), dyn.F.tolist(), dyn.Q.tolist(),
                               meas.R.tolist(), meas_c, up)
    counts = dict(cnt.COUNT)
    _, e = est.step(est.init(mean[None], cov[None]), z[None])
    np.testing.assert_allclose(cnt.values(x), e.mean[0], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(cnt.values(P), e.cov[0], rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(cnt.values(ll), e.loglik[0], rtol=1e-9)
    return counts, cost.step_flops(est)


@pytest.mark.parametrize("filt_kind", ["kf", "ukf", "ckf", "5ckf"])
@pytest.mark.parametrize("n,m,kind", [(1, 1, "linear"), (2, 1, "linear"), (3, 2, "linear"), (4, 2, "range-bearing"),
                                      (6, 2, "range-bearing"), (2, 3, "linear")])
def test_single_filters_match_a_direct_operation_count(filt_kind, n, m, kind):
    counts, model = _count_single(filt_kind, n, m, kind)
    total = model.pop("total")
    assert counts == model                             # every term, exactly
    assert sum(counts.values()) == total


@pytest.mark.parametrize("filt_kind,r,n,kind", [("ukf", 3, 4, "range-bearing"), ("ckf", 3, 4, "range-bearing"),
                                                ("5ckf", 2, 3, "linear"), ("kf", 3, 4, "range-bearing"),
                                                ("kf", 2, 2, "linear")])
def test_imm_matches_a_direct_operation_count(filt_kind, r, n, kind):
    rng = np.random.default_rng(11)
    m = 2
    dyn, meas, meas_c = _models(n, m, r, kind, rng)
    filt = KalmanFilter() if filt_kind == "kf" else SigmaPointFilter(RULES[filt_kind])
    M = rng.dirichlet(np.ones(r) * 3, size=r)
    imm = mmlib.IMM(filt, dyn, meas, M)
    centre, _ = _state(n, rng, kind)
    means = centre + rng.standard_normal((r, n))
    A = rng.standard_normal((r, n, n))
    covs = A @ np.swapaxes(A, -1, -2) + np.eye(n)
    mu = rng.dirichlet(np.ones(r))
    z = meas.h(centre[None])[0] + 0.05
    up = None if filt_kind == "kf" else filt.rule.unit_points(n)

    def mode_step(j, x0, P0):
        return cnt.filter_step(filt_kind, x0, P0, list(z), dyn[j].F.tolist(), dyn[j].Q.tolist(), meas.R.tolist(),
                               meas_c, up)

    cnt.reset()
    fused, mu_c, xs, Ps = cnt.imm_step(cnt.cs(means), cnt.cs(covs), cnt.cs(mu), list(z), M.tolist(), mode_step)
    model = cost.step_flops(imm)
    total = model.pop("total")
    assert dict(cnt.COUNT) == model
    assert sum(cnt.COUNT.values()) == total
    new, est = imm.step(IMMState(GaussianState(means[None], covs[None]), mu[None]), z[None])
    np.testing.assert_allclose(cnt.values(fused), est.mean[0], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(cnt.values(mu_c), est.mode_probabilities[0], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(cnt.values(Ps), new.modes.cov[0], rtol=1e-8, atol=1e-9)


def test_the_bench_count_is_the_model_s_count():
    """bench/flops.py's IMM-UKF job is the model's IMM of UKFs (one counting): 5115 flops."""
    from bench.flops import imm_ukf_flops
    imm = mmlib.IMM(SigmaPointFilter(Unscented(1.0, 2.0, 0.0)),
                    [models.constant_velocity(1.0, 1.0), models.coordinated_turn(1.0, 0.1, 1.0),
                     models.coordinated_turn(1.0, -0.1, 1.0)],
                    models.range_bearing(np.diag([1.0, 1e-4])), np.full((3, 3), 1 / 3))
    assert cost.step_flops(imm) == imm_ukf_flops() and imm_ukf_flops()["total"] == 5115


# --------------------------------------------------------------------------- by hand
def test_scalar_kalman_filter_by_hand():
    """n = m = 1: F x (1); F P F (2) + Q (1); H x (1); P H, H (P H) (2) + R (1); update 21 (residual 1, sqrt 1,
    1/L 1, A 1, e 1, x + A e 2; Joseph: K 1, K H 1, 1 - K H 1, (1-KH) P (1-KH) 2, K R K 2, sum 1; NIS 1;
    log-likelihood: log 1, doubling 1, three more 3)."""
    est = SingleModel(KalmanFilter(), models.LinearGaussianDynamics([[1.0]], [[1.0]], [[1.0]]),
                      models.LinearMeasurement([[1.0]], [[1.0]]))
    assert cost.step_flops(est) == {"predict: transition": 1, "predict: moments": 3, "measurement prediction: h": 1,
                                    "measurement prediction: moments": 3, "update": 21, "total": 29}


@pytest.mark.parametrize("rule,n,expected", [
    (Unscented(1.0, 2.0, 0.0), 4, 3 * 16),                 # n pairs, one non-zero each: n + 2n per pair
    (Cubature(), 3, 27),
    (CentralDifference(), 2, 12),
    (FifthDegreeCubature(), 2, 12 + 5 * 4 * 1),            # axes 3n^2; n(n-1) pairs of two non-zeros, 5n each
    (FifthDegreeCubature(), 3, 27 + 5 * 9 * 2),
    (SphericalSimplexRadial(), 2, 6 + 10 + 10),            # a_1 = e_1 (k = 1); a_2, a_3 two non-zeros
])
def test_point_flops_by_hand(rule, n, expected):
    assert cost.point_flops(rule, n) == expected


def test_conventions_by_hand():
    assert [cost.cholesky_flops(k) for k in (1, 2, 4)] == [1, 5, 30]
    assert [cost.tril_inverse_flops(k) for k in (1, 2, 3)] == [1, 4, 11]
    assert [cost.lu_flops(k) for k in (1, 2, 3)] == [0, 3, 3 + 10]          # j + 2 j^2 summed over j < n
    assert cost.solve_flops(3, 2) == 2 * 15 and cost.inverse_flops(2) == 3 + 2 * 6


def test_point_counts_come_from_the_rule_object():
    """A 6-state IMM: 5th-degree CKF (73 points) costs more than the CKF (12) in every point-driven term."""
    dyn = [models.constant_acceleration(1.0, 1.0)] * 2
    radar = models.range_bearing(np.diag([1.0, 1e-4]), state_dim=6)
    T = np.full((2, 2), 0.5)
    five = cost.step_flops(mmlib.IMM(SigmaPointFilter(FifthDegreeCubature()), dyn, radar, T))
    three = cost.step_flops(mmlib.IMM(SigmaPointFilter(Cubature()), dyn, radar, T))
    assert five["measurement prediction: h"] == 2 * 73 * 7 and three["measurement prediction: h"] == 2 * 12 * 7
    assert five["mixed covariances"] == three["mixed covariances"]          # the IMM's own work does not change
    assert 3.0 < five["total"] / three["total"] < 6.0


# --------------------------------------------------------------------------- the layers
def _radar_single(filt, n=6):
    return SingleModel(filt, models.constant_acceleration(1.0, 1.0),
                       models.range_bearing(np.diag([1.0, 1e-4]), state_dim=n))


def test_strong_tracking_adds_its_terms_and_a_second_prediction():
    ssr = SigmaPointFilter(SphericalSimplexRadial())
    base = cost.step_flops(_radar_single(ssr))
    st = cost.step_flops(_radar_single(StrongTracking(ssr)))
    again = st["strong tracking: measurement prediction again"]
    assert again == sum(v for k, v in base.items() if k.startswith("measurement prediction"))
    assert st["total"] > base["total"] + again
    never = cost.step_flops(_radar_single(StrongTracking(ssr)), inflated=0.0)
    assert "strong tracking: measurement prediction again" not in never
    assert st["total"] - never["total"] == again + 3 * 36
    half = cost.step_flops(_radar_single(StrongTracking(ssr)), inflated=0.5)
    assert half["total"] == pytest.approx((st["total"] + never["total"]) / 2, rel=0, abs=1e-9)
    stf = cost.step_flops(_radar_single(StrongTracking(ExtendedKalmanFilter(), form="jacobian")))
    assert stf["measurement prediction: Jacobian"] == cost.RANGE_BEARING_JACOBIAN_FLOPS


def test_bootstrap_with_no_observations_is_its_base_and_grows_with_them():
    cd = SigmaPointFilter(CentralDifference(form="weighted"))
    dyn = [models.coordinated_turn(1.0, w, 1.0) for w in (0.05, -0.05)]
    radar = models.range_bearing(np.diag([1.0, 1e-4]))
    T = np.full((2, 2), 0.5)
    base = cost.step_flops(mmlib.IMM(cd, dyn, radar, T))
    assert cost.step_flops(mmlib.IMM(ObservationBootstrap(cd, n_boot=0), dyn, radar, T)) == base
    totals = [cost.step_flops(mmlib.IMM(ObservationBootstrap(cd, n_boot=k), dyn, radar, T))["total"]
              for k in (1, 2, 3)]
    assert base["total"] < totals[0] < totals[1] < totals[2]
    assert totals[2] - totals[1] == totals[1] - totals[0]                    # linear in N


def test_stirling_central_difference_differs_from_the_weighted_form():
    stir = cost.step_flops(_radar_single(SigmaPointFilter(CentralDifference())))
    weighted = cost.step_flops(_radar_single(SigmaPointFilter(CentralDifference(form="weighted"))))
    assert stir["predict: sigma points"] == weighted["predict: sigma points"]
    assert stir["predict: moments"] != weighted["predict: moments"]


def test_adaptive_layers_and_the_cubature_mixing_are_counted():
    ukf = SigmaPointFilter(Unscented(1.0, 2.0, 0.0))
    dyn = [models.coordinated_turn(1.0, w, 1.0) for w in (0.05, -0.05)]
    radar = models.range_bearing(np.diag([1.0, 1e-4]))
    T = np.full((2, 2), 0.5)
    plain = cost.step_flops(mmlib.IMM(ukf, dyn, radar, T))
    na = cost.step_flops(mmlib.IMM(InnovationAdaptive(ukf), dyn, radar, T))
    cp = cost.step_flops(mmlib.IMM(ukf, dyn, radar, T, mixing=CubatureMixing()))
    assert na["total"] > plain["total"] and "adaptive: matching test and inflation" in na
    assert cp["mixed covariances"] > plain["mixed covariances"]              # 2rn points per target mode
    assert cp["total"] - cp["mixed covariances"] == plain["total"] - plain["mixed covariances"]
    kms = KnownModeSequence(KalmanFilter(), dyn, np.zeros(5, int), radar)
    assert cost.step_flops(kms) == cost.step_flops(SingleModel(KalmanFilter(), dyn[0], radar))


def test_fused_covariance_only_with_cov():
    imm = mmlib.IMM(KalmanFilter(), [models.constant_velocity(1.0, 1.0)] * 3,
                    models.position_measurement([1.0, 1.0]), np.full((3, 3), 1 / 3))
    n, r = 4, 3
    extra = cost.step_flops(imm, with_cov=True)["total"] - cost.step_flops(imm)["total"]
    assert extra == 2 * r * n + 2 * n * n * (2 * r - 1) + n * n


def test_the_fuzzy_imm_is_counted():
    """Tseng et al. 2011's FUZZY-IMMUKF: the IMM-UKF plus the modes' noise and the fuzzy controller."""
    from mmlib.core import gnss
    from mmlib.papers.tseng2011 import setup as tseng
    ests = tseng.build(tseng.Setup())
    sats = np.random.default_rng(0).standard_normal((6, 3)) * 2e7
    meas = gnss.Pseudoranges(sats, np.eye(6) * 9.0)
    fuzzy = cost.step_flops(ests["FUZZY-IMMUKF"], measurement=meas)
    plain = cost.step_flops(ests["IMMUKF"], measurement=meas)
    assert fuzzy["adaptive IMM: process noise"] == 2 * 2 * 8 * 8
    assert fuzzy["total"] - plain["total"] == fuzzy["adaptive IMM: process noise"] + fuzzy["adaptive IMM: controller"]
    assert plain["measurement prediction: h"] == 2 * 17 * 60                 # 2 modes x 17 points x 10 m
    with pytest.raises(ValueError, match="^measurement"):
        cost.step_flops(ests["FUZZY-IMMUKF"])


# --------------------------------------------------------------------------- bad input
def test_bad_input_is_refused_naming_the_argument():
    class Unknown:
        pass

    with pytest.raises(ValueError, match="^estimator"):
        cost.step_flops(Unknown())
    nonlinear = type("Nonlinear", (), {"dim": 4, "is_linear": False})()
    radar = models.range_bearing(np.diag([1.0, 1e-4]))
    with pytest.raises(ValueError, match="^dynamics"):
        cost.function_costs(nonlinear, radar)
    assert cost.function_costs(nonlinear, radar, f_flops=40, f_jacobian_flops=16).f == 40
    odd = type("Odd", (), {"dim": 2})()
    with pytest.raises(ValueError, match="^measurement"):
        cost.function_costs(models.constant_velocity(1.0, 1.0), odd)
    est = _radar_single(StrongTracking(SigmaPointFilter(Cubature())))
    for bad in (-0.1, 1.5, math.nan, "1", True):
        with pytest.raises(ValueError, match="^inflated"):
            cost.step_flops(est, inflated=bad)
    with pytest.raises(ValueError, match="^with_cov"):
        cost.step_flops(est, with_cov="yes")
    with pytest.raises(ValueError, match="^estimator"):
        cost.step_flops(_radar_single(InnovationAdaptive(SigmaPointFilter(Cubature()), inflate_only=True)))
    with pytest.raises(ValueError, match="^measurement"):
        cost.step_flops(SingleModel(KalmanFilter(), models.constant_velocity(1.0, 1.0), None))
    with pytest.raises(ValueError, match="^r"):
        cost.imm_flops({}, 4, 0)
    with pytest.raises(ValueError, match="^mixing"):
        cost.imm_flops({}, 4, 2, mixing="other")
    with pytest.raises(ValueError, match="^h"):
        cost.FunctionCosts(1, 0, -1, 0)
