"""Divergence is reported at the step where it happens, with its cause, for every filter, layer and the IMM.

Fault injection: at step ``K_BAD`` the measurement model's R is slightly *negative*, -1e-3 I.  For a linear
position measurement with predicted position variance p (>> 1e-3 here), S = p + R > 0 still has a Cholesky
factor, but the posterior variance p - p^2/(p + R) = pR/(p + R) < 0: the posterior covariance stops being
positive definite at exactly that step.  For the sigma-point rules the measurement is linear, so every
rule computes the same S and P_xz (to round-off) and the same indefinite posterior.
"""
import numpy as np
import pytest

import mmlib as m
from mmlib.core import models
from mmlib.core.layers.adaptive import InnovationAdaptive
from mmlib.core.layers.bootstrap import ObservationBootstrap
from mmlib.core.estimation import Failure, FilterDivergence, combine_covariances
from mmlib.core.layers.strong_tracking import StrongTracking
from test_filters import FILTERS, IDS

K_BAD = 7


class NegativeR:
    """A duck-typed linear position measurement whose R is -1e-3 I (an injected fault)."""

    def __init__(self, base):
        self.base = base
        self.R = -1e-3 * np.eye(base.dim)
        self.dim = base.dim
        self.noise_factor = base.noise_factor

    def h(self, x):
        return self.base.h(x)

    def jacobian(self, x):
        return self.base.jacobian(x)

    def residual(self, a, b):
        return self.base.residual(a, b)

    def average(self, values, weights):
        return self.base.average(values, weights)


def _faulty_models(meas, K):
    return [NegativeR(meas) if k == K_BAD else meas for k in range(K)]


@pytest.mark.parametrize("filt", FILTERS, ids=IDS)
def test_posterior_not_positive_definite_is_reported_at_its_step(filt, linear_problem):
    """Fails on the old code: KF/EKF returned a negative variance unreported, sigma-point filters reported K_BAD+1."""
    dyn, meas, x0, P0, zs = linear_problem
    K = zs.shape[1]
    track = m.run(m.SingleModel(filt, dyn, None), filt.init(x0, P0), list(np.swapaxes(zs, 0, 1)),
                  measurement_models=_faulty_models(meas, K))
    assert track.diverged_step.tolist() == [K_BAD] * x0.shape[0]
    assert (track.divergence_cause == Failure.COVARIANCE).all()
    assert np.isfinite(track.mean[:, :K_BAD]).all() and np.isnan(track.mean[:, K_BAD]).all()
    # no negative variance is ever returned
    var = np.diagonal(track.cov, axis1=-2, axis2=-1)
    assert not (var < 0).any()


@pytest.mark.parametrize("layer", ["strong-tracking", "adaptive", "bootstrap"])
def test_layers_report_the_injected_fault_at_its_step(layer, linear_problem):
    dyn, meas, x0, P0, zs = linear_problem
    K = zs.shape[1]
    base = m.SigmaPointFilter(m.Cubature())
    filt = {"strong-tracking": StrongTracking(base), "adaptive": InnovationAdaptive(base, window=20),
            "bootstrap": ObservationBootstrap(base, n_boot=2)}[layer]
    extra = {"noise": np.random.default_rng(0).standard_normal((x0.shape[0], K, 2, 2))} if layer == "bootstrap" else {}
    track = m.run(m.SingleModel(filt, dyn, None), filt.init(x0, P0, **extra), list(np.swapaxes(zs, 0, 1)),
                  measurement_models=_faulty_models(meas, K))
    assert track.diverged_step.tolist() == [K_BAD] * x0.shape[0]
    assert (track.divergence_cause == Failure.COVARIANCE).all()


def test_imm_reports_a_mode_failure_at_its_step(linear_problem):
    dyn, meas, x0, P0, zs = linear_problem
    K = zs.shape[1]
    filt = m.SigmaPointFilter(m.Unscented())
    imm = m.IMM(filt, [dyn, models.constant_velocity(1.0, 20.0)], None, [[0.95, 0.05], [0.05, 0.95]])
    track = m.run(imm, imm.init(x0, P0), list(np.swapaxes(zs, 0, 1)), measurement_models=_faulty_models(meas, K))
    assert track.diverged_step.tolist() == [K_BAD] * x0.shape[0]
    assert (track.divergence_cause == Failure.COVARIANCE).all()


def test_imm_likelihood_underflow_is_reported_as_such(linear_problem):
    """A 1e300 measurement: every mode's log-likelihood is -inf, the mode probabilities 0/0.  The old code
    reported "covariance no longer positive definite"."""
    dyn, meas, x0, P0, zs = linear_problem
    zs = zs.copy()
    zs[1, 4] = 1e300
    imm = m.IMM(m.KalmanFilter(), [dyn, models.constant_velocity(1.0, 20.0)], meas, [[0.95, 0.05], [0.05, 0.95]])
    track = m.run(imm, imm.init(x0, P0), zs)
    assert track.diverged_step.tolist() == [-1, 4, -1]
    assert track.divergence_cause.tolist() == [0, Failure.LIKELIHOOD, 0]
    assert track.divergence_summary().startswith("1 of 3 runs diverged (step 4; every mode's likelihood underflowed")
    with pytest.raises(FilterDivergence, match="IMM: run 1 diverged at step 4 .*likelihood underflowed"):
        m.run(imm, imm.init(x0, P0), zs, on_divergence="raise")


def test_single_model_divergence_message_names_the_filter(linear_problem):
    """The old message started with an empty name (SingleModel.name defaulted to "")."""
    dyn, meas, x0, P0, zs = linear_problem
    filt = m.SigmaPointFilter(m.Cubature())
    state = filt.init(x0, P0)
    state = state._replace(cov=-state.cov)
    with pytest.raises(FilterDivergence, match=r"^cubature3: run 0 diverged at step 0 \(covariance no longer positive"):
        m.run(m.SingleModel(filt, dyn, meas), state, zs, on_divergence="raise")


def test_fused_covariance_stays_positive_semidefinite_under_cancellation():
    """Components far from the first one and close to each other: the old form, sum w (P + y y^T) - c c^T with
    y, c ~ 1e8, cancelled ~1e16 * eps ~ 2 against a true spread of ~1e-6 and returned a negative variance.
    Exact answer: P + w1 w2 (x2 - x3)^2 with x2 - x3 = 1e-3, i.e. 1e-6 + 0.25e-6."""
    means = np.array([[[0.0, 0.0], [1e8, 1e8], [1e8 + 1e-3, 1e8 + 1e-3]]])
    covs = np.broadcast_to(1e-6 * np.eye(2), (1, 3, 2, 2))
    wt = np.array([[[0.0, 0.5, 0.5]]])
    centre = wt @ means
    out = combine_covariances(wt, means, covs, centre)[0, 0]
    # exact: the centre itself is rounded (ulp of 1e8 ~ 1.5e-8), which moves the spread by <= 2 * 1.5e-8 * 5e-4
    expected = 1e-6 * np.eye(2) + 0.25e-6 * np.ones((2, 2))
    np.testing.assert_allclose(out, expected, rtol=0, atol=3e-11)
    assert np.linalg.eigvalsh(out).min() > 0


@pytest.mark.parametrize("layer", ["strong-tracking", "adaptive", "bootstrap"])
def test_layers_accept_a_measurement_dimension_that_changes_per_step(layer, linear_problem):
    """The satellites in view change: the layers restart their innovation statistics instead of crashing
    (old code: a shape error ended the whole run()).  With the dimension fixed the layer is unchanged."""
    dyn, meas, x0, P0, zs = linear_problem
    K = zs.shape[1]
    base = m.SigmaPointFilter(m.Cubature())
    filt = {"strong-tracking": StrongTracking(base), "adaptive": InnovationAdaptive(base, window=3, inflate_only=True),
            "bootstrap": ObservationBootstrap(base, n_boot=2)}[layer]
    x_only = models.LinearMeasurement(meas.H[:1].copy(), meas.R[:1, :1].copy())
    models_k = [x_only if 8 <= k < 12 else meas for k in range(K)]
    zs_k = [zs[:, k, :1] if 8 <= k < 12 else zs[:, k] for k in range(K)]
    extra = {"noise": np.random.default_rng(0).standard_normal((x0.shape[0], K, 2, 2))} if layer == "bootstrap" else {}
    track = m.run(m.SingleModel(filt, dyn, None), filt.init(x0, P0, **extra), zs_k, measurement_models=models_k)
    assert not track.diverged.any()
    fixed = m.run(m.SingleModel(filt, dyn, meas), filt.init(x0, P0, **extra), zs)
    np.testing.assert_array_equal(track.mean[:, :8], fixed.mean[:, :8])
    # the same inside an IMM
    imm = m.IMM(filt, [dyn, models.constant_velocity(1.0, 20.0)], None, [[0.95, 0.05], [0.05, 0.95]])
    track = m.run(imm, imm.init(x0, P0, **extra), zs_k, measurement_models=models_k)
    assert not track.diverged.any()


def test_strong_tracking_restarts_its_innovation_average_when_the_dimension_changes(linear_problem):
    """Eq. 17 restarts (V = v v^T) for a measurement set of another dimension; the old code broadcast the 2x2
    average against the 1x1 outer product and carried a wrong-sized V on silently."""
    dyn, meas, x0, P0, zs = linear_problem
    st = StrongTracking(m.SigmaPointFilter(m.Cubature()))
    state = st.update(st.predict(st.init(x0, P0), dyn), zs[:, 0], meas)[0]
    assert state.V.shape == (x0.shape[0], 2, 2)
    x_only = models.LinearMeasurement(meas.H[:1].copy(), meas.R[:1, :1].copy())
    pred_state = st.predict(state, dyn)
    new, info = st.update(pred_state, zs[:, 1, :1], x_only)
    assert new.V.shape == (x0.shape[0], 1, 1)
    np.testing.assert_array_equal(new.V, info.innovation[:, :, None] * info.innovation[:, None, :])


def test_evaluation_keeps_the_step_and_cause_of_every_divergence(linear_problem):
    from mmlib.experiment.evaluation import evaluate
    dyn, meas, x0, P0, zs = linear_problem
    zs = zs.copy()
    zs[1, 4] = 1e300
    imm = m.IMM(m.KalmanFilter(), [dyn, models.constant_velocity(1.0, 20.0)], meas, [[0.95, 0.05], [0.05, 0.95]])
    truth = np.zeros((3, zs.shape[1] + 1, 4))
    res = evaluate({"IMM": imm},
                   lambda runs: (truth[list(runs)], zs[list(runs)], {"IMM": imm.init(x0[list(runs)], P0)}),
                   m.MonteCarlo(0, 3), chunk_size=2, progress=False)["IMM"]
    assert res.diverged_step.tolist() == [-1, 4, -1]
    assert res.divergence_cause.tolist() == [0, Failure.LIKELIHOOD, 0]
    assert res.divergence_summary().startswith("1 of 3 runs diverged (step 4; every mode's likelihood underflowed")
    from mmlib.experiment.evaluation import divergence_report
    assert divergence_report({"case": {"IMM": res}}).startswith("case / IMM: 1 of 3 runs diverged (step 4;")
    assert divergence_report({"IMM": res._replace(diverged_step=np.full(3, -1))}) == "no run diverged"


def test_divergence_summary_counts_runs_sharing_a_step():
    from mmlib.experiment.evaluation import RunSet
    rs = RunSet(np.zeros((5, 3, 1)), None, np.array([2, -1, 2, 0, -1]), np.zeros((3, 1)),
                divergence_cause=np.array([1, 0, 1, 1, 0], dtype=np.int8))
    assert rs.divergence_summary() == "3 of 5 runs diverged (steps 0, 2 ×2; covariance no longer positive definite)"


def _borderline_matrix():
    """A 4x4 symmetric matrix LAPACK's Cholesky accepts although eigvalsh finds its smallest eigenvalue <= 0
    (rank 3 plus ~1e-16 I): found by a seeded search, a few draws at most."""
    rng = np.random.default_rng(0)
    for _ in range(10_000):
        v = rng.standard_normal((4, 3))
        a = v @ v.T + 10 ** rng.uniform(-18, -14) * np.eye(4)
        a = 0.5 * (a + a.T)
        try:
            np.linalg.cholesky(a)
        except np.linalg.LinAlgError:
            continue
        if np.linalg.eigvalsh(a)[0] <= 0:
            return a
    pytest.skip("no borderline matrix found with this LAPACK")


def test_cholesky_verdict_of_a_matrix_does_not_depend_on_its_neighbours():
    """The old slow path (taken when any matrix of the stack failed) judged every matrix by eigvalsh instead of
    LAPACK: a borderline run passed alone and failed next to a diverged one (a batch-size dependence)."""
    from mmlib.core import linalg
    a = _borderline_matrix()
    alone = linalg.cholesky(a[None])
    for neighbour in (-np.eye(4), np.full((4, 4), np.nan), np.eye(4)):
        L, failed = linalg.cholesky(np.stack([a, neighbour]))
        assert failed[0] == alone[1][0]
        np.testing.assert_array_equal(L[0], alone[0][0])
    assert linalg.cholesky(np.stack([a, -np.eye(4)]))[1][1]
    assert linalg.cholesky(np.full((2, 4, 4), np.nan))[1].all()        # NaN in: failed, whichever path


def test_kalman_filter_stays_positive_definite_for_a_vague_prior_and_a_precise_sensor():
    """P0 = 1e10 I, R = 1e-6 I: P - K S K^T loses the 1e-6 eigenvalues to cancellation (~1e10 * eps = 2e-6) and
    the old check declared every run diverged at step 0; the Joseph form keeps them (posterior position
    variance R P/(P + R) ~ 1e-6)."""
    dyn = models.constant_velocity(1.0, 1.0)
    meas = models.position_measurement([1e-6, 1e-6])
    x0 = np.zeros((2, 4))
    zs = np.random.default_rng(3).standard_normal((2, 5, 2))
    for filt in (m.KalmanFilter(), m.ExtendedKalmanFilter()):
        track = m.run(m.SingleModel(filt, dyn, meas), filt.init(x0, 1e10 * np.eye(4)), zs)
        assert not track.diverged.any()
        assert np.linalg.eigvalsh(track.cov[:, 0]).min() > 0
        np.testing.assert_allclose(track.cov[:, 0, 0, 0], 1e-6, rtol=1e-6)


@pytest.mark.parametrize("where, value, fails", [((0, 2), np.nan, False), ((2, 0), np.nan, True),
                                                 ((1, 1), np.inf, True), ((2, 1), np.inf, True),
                                                 ((0, 0), np.nan, True), ((2, 2), -np.inf, True)])
def test_cholesky_verdict_on_non_finite_entries_does_not_depend_on_neighbours(where, value, fails):
    """Only the lower triangle is read (LAPACK's convention): a non-finite entry there fails, one above the
    diagonal is ignored, on the fast path (alone) and on the slow path (next to a failing matrix) alike; the
    old code judged the slow path by the whole matrix."""
    from mmlib.core import linalg
    a = 2 * np.eye(3)
    a[where] = value
    assert linalg.cholesky(a[None])[1].tolist() == [fails]
    assert linalg.cholesky(np.stack([a, -np.eye(3)]))[1].tolist() == [fails, True]
    assert linalg.cholesky(np.stack([a, np.eye(3)]))[1].tolist() == [fails, False]


def test_bootstrap_members_keep_the_joseph_form_over_an_ekf():
    """S^n = H P H^T + c R holds exactly for the bootstrap members of an EKF: with the Joseph form and the
    effective noise c R, a vague prior measured precisely is not declared diverged."""
    dyn = models.constant_velocity(1.0, 1.0)
    meas = models.position_measurement([1e-6, 1e-6])
    x0 = np.zeros((2, 4))
    zs = np.random.default_rng(3).standard_normal((2, 4, 2))
    filt = ObservationBootstrap(m.ExtendedKalmanFilter(), n_boot=2)
    noise = np.random.default_rng(4).standard_normal((2, 4, 2, 2))
    track = m.run(m.SingleModel(filt, dyn, meas), filt.init(x0, 1e11 * np.eye(4), noise=noise), zs)
    assert not track.diverged.any()


@pytest.mark.parametrize("likelihood", ["sum", "product"])
def test_bootstrap_imm_likelihood_underflow_is_reported_as_such(linear_problem, likelihood):
    """The same 1e300 measurement through bootstrapped mode filters: every member's log-likelihood is -inf, so is
    their combination (the "sum" rule's log-sum-exp once gave -inf - -inf = NaN, reported as a non-finite state)."""
    dyn, meas, x0, P0, zs = linear_problem
    zs = zs.copy()
    zs[1, 4] = 1e300
    filt = ObservationBootstrap(m.ExtendedKalmanFilter(), n_boot=2, likelihood=likelihood)
    imm = m.IMM(filt, [dyn, models.constant_velocity(1.0, 20.0)], meas, [[0.95, 0.05], [0.05, 0.95]])
    noise = np.random.default_rng(5).standard_normal((x0.shape[0], zs.shape[1], 2, 2))
    track = m.run(imm, imm.init(x0, P0, noise=noise), zs)
    assert track.diverged_step.tolist() == [-1, 4, -1]
    assert track.divergence_cause.tolist() == [0, Failure.LIKELIHOOD, 0]
