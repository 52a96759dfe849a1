"""Whole runs of the composed estimators (issue 25): an IMM whose interaction is the cubature principle or whose mode
filters are extended Kalman filters or innovation-adaptive filters (:func:`mmlib.core.linalg.imm_layer_run`), a single
extended Kalman filter (:func:`mmlib.core.linalg.ekf_run`) and strong tracking over one (both forms of the fading
factor; :func:`mmlib.core.linalg.strong_tracking_run`) are each one compiled call from
:func:`mmlib.core.estimation.run`, with the bits of the same estimator run step by step (its composed steps, each
operation compiled), whatever the batch, the block and the threads, over fixed and per-epoch measurement models; the
call is really taken, and declined where the steps would be other operations.

Also the operations whose compiled twins sum the composed layers' BLAS products in order with one fused multiply-add
per term (:func:`mmlib.core.linalg.cubature_mix`, :func:`mmlib.core.linalg.jacobian_fading_factor`): against an exact
reference of that order (:mod:`fractions`), and against numpy's products to round-off.

Every comparison with the step-by-step run is exact (raw bits, NaN == NaN): the kernel runs the same loop bodies on the
same operands, so any difference is a defect, not round-off.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from mmlib import MonteCarlo
from mmlib.core import estimation, linalg, models, rules
from mmlib.core.estimation import IMM, MomentMixing, SingleModel, run
from mmlib.core.filters import ExtendedKalmanFilter, SigmaPointFilter
from mmlib.core.layers.adaptive import InnovationAdaptive
from mmlib.core.layers.strong_tracking import StrongTracking
from mmlib.core.mixing import CubatureMixing
from mmlib.experiment.simulate import ManeuverSchedule, simulate

sys.path.insert(0, str(Path(__file__).parent))
# the shared set-up of the whole-run tests (a turning target, its measurements, Tseng's GNSS epochs) and the exact
# reference of the in-order fused multiply-add sum
from test_fused import K, MEASUREMENTS, P0, T, TRANSITION, X0, _gnss_epochs, _modes, _same, _wild  # noqa: E402
from test_fused import _assert_same_track as _assert_same_estimates  # noqa: E402
from test_kernels import _in_order_fma  # noqa: E402

pytestmark = pytest.mark.skipif(linalg.kernel() != "numba", reason="the whole runs exist on the compiled kernels")

WHOLE_RUNS = ("imm_layer_run", "ekf_run", "strong_tracking_run", "sigma_run", "imm_sigma_run", "adaptive_run")
UKF = rules.Unscented(1.0, 2.0, 0.0)


def _assert_same_track(a, b):
    """Every field of two Tracks bit for bit (``test_fused``'s comparison) and their NIS degrees of freedom."""
    _assert_same_estimates(a, b)
    assert _same(a.nis_dof, b.nis_dof), "nis_dof"


def _spy_whole_runs(monkeypatch) -> list:
    """Wrap the whole-run calls of :data:`WHOLE_RUNS`: ``(name, True)`` for a call that returned a run, ``(name,
    False)`` for one that declined."""
    calls = []

    def noted(name, real):
        def spy(*a, **k):
            out = real(*a, **k)
            calls.append((name, out is not None))
            return out
        return spy
    for name in WHOLE_RUNS:
        monkeypatch.setattr(linalg, name, noted(name, getattr(linalg, name)))
    return calls


def _step_by_step(est, state, z, monkeypatch, **kw):
    with monkeypatch.context() as m:
        m.setattr(estimation, "_whole_run", lambda *a, **k: None)
        return run(est, state, z, **kw)


def _whole_and_steps(est, state, z, monkeypatch, kernel: str, **kw):
    """run() of ``est`` as one call of the compiled ``kernel`` (checked: called once, returned a run), and step by
    step."""
    calls = _spy_whole_runs(monkeypatch)
    whole = run(est, state, z, **kw)
    assert calls == [(kernel, True)], f"the whole run was not one call of {kernel}: {calls}"
    steps = _step_by_step(est, state, z, monkeypatch, **kw)
    assert calls == [(kernel, True)]
    return whole, steps


def _simulation(measurement, B: int, seed: int = 11):
    sched = ManeuverSchedule(_modes(), [(8, 16, 1)], 0, T, K, truncate=True)
    return simulate(sched, X0, measurement, MonteCarlo(seed, B), range(B))


def _adaptive(base, flags, window: int = 3):
    zeta, include_current, inflate_only = flags
    return InnovationAdaptive(base, window=window, psi=1.0, zeta=zeta, include_current=include_current,
                              inflate_only=inflate_only)


#: the IMMs of imm_layer_run: (mixing, mode filter)
IMMS = {
    "CPIMM-UKF": (CubatureMixing, lambda: SigmaPointFilter(UKF)),
    "CPIMM-EKF": (CubatureMixing, lambda: ExtendedKalmanFilter()),
    "IMM-EKF": (MomentMixing, lambda: ExtendedKalmanFilter()),
    "IMM-NAUKF": (MomentMixing, lambda: _adaptive(SigmaPointFilter(UKF), (True, True, False))),
    "IMM-AUKF[inflate-only]": (MomentMixing, lambda: _adaptive(SigmaPointFilter(UKF), (False, False, True))),
    "CPIMM-NAUKF[inflate-only]": (CubatureMixing, lambda: _adaptive(SigmaPointFilter(UKF), (True, True, True))),
    "CPIMM-AUKF": (CubatureMixing, lambda: _adaptive(SigmaPointFilter(rules.Cubature()), (False, True, False))),
}


def _imm(name: str, measurement):
    mixing, filt = IMMS[name]
    return IMM(filt(), _modes(), measurement, TRANSITION, mixing=mixing())


def _imm_state(est, B: int, bad_runs=()):
    state = est.init(np.tile(X0, (B, 1)), P0)
    if bad_runs:
        cov = np.repeat(np.tile(P0, (B, 1, 1))[:, None], len(_modes()), axis=1)
        cov[list(bad_runs), :, 0, 0] = -1.0
        state = state._replace(modes=state.modes._replace(cov=cov))
    return state


@pytest.mark.parametrize("name", sorted(IMMS))
@pytest.mark.parametrize("meas", sorted(MEASUREMENTS))
def test_imm_layer_run_equals_the_run_step_by_step(name, meas, monkeypatch):
    """Every field of the Track bit for bit, with runs whose covariance is not positive definite at the start and runs
    whose every mode's likelihood underflows at a later step (a wild measurement)."""
    measurement = MEASUREMENTS[meas]
    B = 13
    sim = _simulation(measurement, B)
    bounded = "inflate-only" in name    # a failed run's NaN would make numpy's eigh raise for the batch (tested below)
    z = sim.measurements if bounded else _wild(_wild(sim.measurements, 4, 9), 7, 17)
    est = _imm(name, measurement)
    state = _imm_state(est, B, bad_runs=() if bounded else (2, 10))
    with np.errstate(all="ignore"):
        whole, steps = _whole_and_steps(est, state, z, monkeypatch, "imm_layer_run", keep_cov=True,
                                        consistency=True, truth=sim.truth)
    _assert_same_track(whole, steps)
    assert bounded or (whole.diverged_step[[2, 10]] == 0).all()


@pytest.mark.parametrize("name", ["CPIMM-UKF", "IMM-EKF", "IMM-NAUKF"])
@pytest.mark.parametrize("batch", [1, 2, 3, 64])
@pytest.mark.parametrize("block", [2, 128])
def test_imm_layer_run_changes_no_bit_with_the_batch_or_the_block(name, batch, block, monkeypatch):
    """A run's bits whatever the batch it is in and the block of runs the kernel computes at once."""
    measurement = MEASUREMENTS["range-bearing"]
    sim = _simulation(measurement, 64, seed=5)
    est = _imm(name, measurement)
    reference = run(est, _imm_state(est, 64), sim.measurements)
    monkeypatch.setattr(linalg, "FUSED_BLOCK", block)
    got = run(est, _imm_state(est, batch), sim.measurements[:batch])
    for field in ("mean", "cov", "mode_probabilities", "diverged_step"):
        assert _same(getattr(got, field), getattr(reference, field)[:batch]), field


@pytest.mark.parametrize("kernel", ["imm_layer_run", "ekf_run", "strong_tracking_run"])
@pytest.mark.parametrize("count", [2, 3])
def test_thread_count_changes_no_bit(kernel, count, monkeypatch):
    """The runs split over 2 or 3 threads (blocks of 7 runs): the Track of one thread, bit for bit."""
    measurement = MEASUREMENTS["range-bearing off-centre"]
    est = {"imm_layer_run": lambda: _imm("IMM-NAUKF", measurement),
           "ekf_run": lambda: SingleModel(ExtendedKalmanFilter(), models.constant_velocity(T, 1.0), measurement),
           "strong_tracking_run": lambda: SingleModel(StrongTracking(ExtendedKalmanFilter(), form="jacobian"),
                                                      models.constant_velocity(T, 1.0), measurement)}[kernel]()
    z = _simulation(measurement, 45).measurements[:, :12]
    monkeypatch.setattr(linalg, "FUSED_BLOCK", 7)
    state = est.init(np.tile(X0, (45, 1)), P0)
    with linalg.use_threads(1):
        reference = run(est, state, z)
    calls = _spy_whole_runs(monkeypatch)
    with linalg.use_threads(count):
        got = run(est, state, z)
    assert calls == [(kernel, True)]
    _assert_same_track(reference, got)


@pytest.mark.parametrize("form", ["EKF", "STF jacobian", "STF statistical"])
@pytest.mark.parametrize("meas", sorted(MEASUREMENTS))
def test_single_ekf_whole_run_equals_the_run_step_by_step(form, meas, monkeypatch):
    """The extended Kalman filter and strong tracking over it (either form of the fading factor): bit for bit, with a
    run not positive definite at the start and a wild measurement."""
    measurement = MEASUREMENTS[meas]
    B = 13
    sim = _simulation(measurement, B)
    z = _wild(sim.measurements, 4, 9)
    filt = {"EKF": lambda: ExtendedKalmanFilter(),
            "STF jacobian": lambda: StrongTracking(ExtendedKalmanFilter(), beta=4.5, rho=0.95, form="jacobian"),
            "STF statistical": lambda: StrongTracking(ExtendedKalmanFilter(), beta=4.5, rho=0.95)}[form]()
    est = SingleModel(filt, models.constant_velocity(T, 0.5), measurement)
    cov = np.tile(P0, (B, 1, 1))
    cov[2, 0, 0] = -1.0
    state = est.init(np.tile(X0, (B, 1)), P0)._replace(cov=cov)
    kernel = "ekf_run" if form == "EKF" else "strong_tracking_run"
    with np.errstate(all="ignore"):
        whole, steps = _whole_and_steps(est, state, z, monkeypatch, kernel, keep_cov=True, consistency=True,
                                        truth=sim.truth)
    _assert_same_track(whole, steps)
    assert whole.diverged_step[2] == 0 and (whole.diverged_step[[0, 1, 3]] < 0).all()


def _tseng(name: str, n_epochs: int, fewer=()):
    """The arena's ``name`` on Tseng et al. 2011's scenario (``test_fused._gnss_epochs``: 5 runs, one satellite fewer
    at the epochs ``fewer``), its epochs up to ``n_epochs`` past the first change of the satellites in view:
    ``(estimator, state, measurements, models, truth)``."""
    from mmlib.arena import recipes, study
    s = study.scenario("tseng2011")
    dims = [model.dim for model in s.measurement_models]
    first_change = next(k for k in range(1, len(dims)) if dims[k] != dims[k - 1])
    return _gnss_epochs(recipes.build(name, s), first_change + n_epochs, fewer)


@pytest.mark.parametrize("name", ["EKF", "IMMEKF", "STF", "CPIMM-UKF", "CPIMM-NAUKF", "IMM-NAUKF",
                                  "IMM-NAUKF[inflate-only]"])
def test_gnss_whole_runs_equal_the_runs_step_by_step(name, monkeypatch):
    """Tseng et al. 2011's epochs, each its own satellites (the measurement dimension changes, odd and even; an
    adaptive layer's windows restart): packed into one call, the same bits as epoch by epoch."""
    est, state, zs, models_k, truth = _tseng(name, 30, fewer=range(3, 9))
    kernel = {"EKF": "ekf_run", "STF": "strong_tracking_run"}.get(name, "imm_layer_run")
    whole, steps = _whole_and_steps(est, state, zs, monkeypatch, kernel, measurement_models=models_k,
                                    consistency=True, truth=truth)
    _assert_same_track(whole, steps)
    assert len({z.shape[1] for z in zs}) >= 2


def _declined(est, state, z, monkeypatch, kernel: str | None, **kw):
    """run() of ``est`` with the whole run declined by ``kernel`` (called, returned None) or never called: the Track
    equals the run step by step."""
    calls = _spy_whole_runs(monkeypatch)
    got = run(est, state, z, **kw)
    assert all(not ok for _, ok in calls) and all(n == kernel for n, _ in calls), calls
    _assert_same_track(got, _step_by_step(est, state, z, monkeypatch, **kw))
    return calls


@pytest.mark.parametrize("why", ["one mode with cubature mixing", "one-component steps (adaptive)",
                                 "one-component steps (STF jacobian)", "mixing subclass", "EKF subclass",
                                 "fusion off"])
def test_whole_run_declines_where_the_steps_would_be_other_operations(why, monkeypatch):
    """Where the composed steps would not be the kernel's (numpy's ``dot`` or ``gemv`` for a product of one row or
    column, a subclass that may override a step, fusion off), run() goes step by step, with the same Track."""
    one = models.LinearMeasurement([[1.0, 0, 0, 0]], np.array([[100.0]]))
    measurement = MEASUREMENTS["range-bearing"]
    B = 5
    if why == "one mode with cubature mixing":
        est = IMM(SigmaPointFilter(UKF), _modes()[:1], measurement, np.eye(1), mixing=CubatureMixing())
        kernel = "imm_layer_run"
    elif why == "one-component steps (adaptive)":
        measurement = one
        est = _imm("IMM-NAUKF", one)
        kernel = "imm_layer_run"
    elif why == "one-component steps (STF jacobian)":
        measurement = one
        est = SingleModel(StrongTracking(ExtendedKalmanFilter(), form="jacobian"), models.constant_velocity(T, 0.5),
                          one)
        kernel = "strong_tracking_run"
    elif why == "mixing subclass":
        class Mixing(CubatureMixing):
            pass
        est = IMM(SigmaPointFilter(UKF), _modes(), measurement, TRANSITION, mixing=Mixing())
        kernel = None
    elif why == "EKF subclass":
        class EKF(ExtendedKalmanFilter):
            pass
        est = SingleModel(EKF(), models.constant_velocity(T, 0.5), measurement)
        kernel = None
    else:
        est = _imm("IMM-EKF", measurement)
        kernel = None
    z = _simulation(measurement, B).measurements
    state = est.init(np.tile(X0, (B, 1)), P0)
    with linalg.use_fused(why != "fusion off"):
        calls = _declined(est, state, z, monkeypatch, kernel)
    assert (calls == [(kernel, False)]) if kernel else calls == []


@pytest.mark.parametrize("meas", ["range-bearing", "gnss"])
def test_inflate_only_with_a_run_that_is_not_finite_runs_whole_and_reports_it(meas, monkeypatch):
    """The inflate-only reading meets a run whose innovation covariance is not finite (a run diverged at an absurd
    measurement): that run's adaptive covariance is NaN (:func:`mmlib.core.linalg.psd_part`), it is reported at its
    step, the other runs go on; the whole run is taken, with the bits of the run step by step."""
    if meas == "gnss":
        est, state, zs, models_k, _ = _tseng("IMM-NAUKF[inflate-only]", 10)
        zs = [z.copy() for z in zs]
        zs[6][1, 0] = 1e308
        kw = {"measurement_models": models_k}
    else:
        measurement = MEASUREMENTS["range-bearing"]
        est = _imm("IMM-AUKF[inflate-only]", measurement)
        zs = _simulation(measurement, 4).measurements.copy()
        zs[1, 6, 0] = 1e308                       # run 1 diverges there: its innovations are not finite after
        state, kw = _imm_state(est, 4), {}
    with np.errstate(all="ignore"):
        whole, steps = _whole_and_steps(est, state, zs, monkeypatch, "imm_layer_run", **kw)
    _assert_same_track(whole, steps)
    assert whole.diverged_step[1] >= 0 and (whole.diverged_step[[0, 2, 3]] < 0).all()


# --------------------------------------------------------------------------- the operations' compiled twins
def test_jacobian_fading_factor_compiled_is_the_in_order_sum_and_numpys_to_round_off():
    """The Jacobian-form fading factor (Liu & Wu 2017, Eqs. 15-16): the compiled twin's diagonals are the in-order
    fused multiply-add sums (an exact reference), and its factor is numpy's to round-off -- a relative 64 m n eps of
    the traces' terms, the products' error bound with room (m, n <= 9 here)."""
    rng = np.random.default_rng(3)
    for m, n in [(2, 4), (3, 8), (5, 8), (8, 8), (9, 8)]:
        B = 6
        H = rng.standard_normal((B, m, n))
        A = rng.standard_normal((B, n, n))
        Q = np.eye(n) * 0.3
        Pl = A @ np.swapaxes(A, -1, -2) + Q
        v = rng.standard_normal((B, m)) * 3.0
        V = v[:, :, None] * v[:, None, :]
        R = np.eye(m) * 0.5
        with linalg.use_kernel("numba"):
            lam = linalg.jacobian_fading_factor(H, Pl, Q, V, R, 4.5)
        with linalg.use_kernel("numpy"):
            ref = linalg.jacobian_fading_factor(H, Pl, Q, V, R, 4.5)
        for b in range(B):
            hq = _in_order_fma(H[b], Q.T)                     # (HQ)_ck, each summed in order
            hd = _in_order_fma(H[b], (Pl[b] - Q).T)
            dn = [(V[b, c, c] - x) - 4.5 * R[c, c] for c, x in enumerate(np.diagonal(_in_order_fma(hq, H[b])))]
            dm = list(np.diagonal(_in_order_fma(hd, H[b])))
            tr_n, tr_m = float(np.sum(np.array(dn))), float(np.sum(np.array(dm)))
            exact = max(tr_n / tr_m, 1.0) if tr_m > 0 else 1.0
            assert lam[b] == exact, (m, n, b)
            scale = (np.abs(H[b]) @ np.abs(Pl[b]) @ np.abs(H[b]).T).trace() / abs(tr_m) * max(abs(lam[b]), 1.0)
            assert abs(lam[b] - ref[b]) <= 64 * m * n * np.finfo(float).eps * scale, (m, n, b)


def test_cubature_mix_compiled_is_numpys_to_round_off_and_the_closed_form():
    """Cubature-principle mixing (Zhou et al. 2017, Eqs. 14-19): the compiled twin equals numpy's to round-off (a
    relative 64 (2rn) eps of the covariances' scale: the 2rn-term sums of the means and of the outer products), and
    both the closed form of the module docstring of :mod:`mmlib.core.mixing` (sum_i mu_{i|j} x_i and
    sum_i mu_{i|j}^2 P_i), as the rule is exact for this linear map."""
    rng = np.random.default_rng(4)
    for r, n in [(2, 4), (3, 5), (2, 8)]:
        B = 7
        A = rng.standard_normal((B, r, n, n))
        covs = A @ np.swapaxes(A, -1, -2) + np.eye(n)
        means = rng.standard_normal((B, r, n)) * 100.0
        mu = rng.dirichlet(np.ones(r), size=B)
        T_ = np.full((r, r), 0.1 / max(r - 1, 1)) + np.eye(r) * (0.9 - 0.1 / max(r - 1, 1))
        _, w = linalg.mixing_weights(mu, T_)
        with linalg.use_kernel("numba"):
            got_m, got_c = linalg.cubature_mix(means, covs, w)
        with linalg.use_kernel("numpy"):
            ref_m, ref_c = linalg.cubature_mix(means, covs, w)
        eps, terms = np.finfo(float).eps, 2 * r * n
        scale_m = np.abs(means).max() + np.sqrt(np.abs(covs).max() * terms)
        assert np.abs(got_m - ref_m).max() <= 64 * terms * eps * scale_m
        scale_c = np.abs(covs).max()
        assert np.abs(got_c - ref_c).max() <= 64 * terms * eps * scale_c * terms
        wt = np.swapaxes(w, -1, -2)
        assert np.allclose(got_m, wt @ means, rtol=0, atol=1e3 * eps * scale_m)
        closed = np.einsum("bji,bikl->bjkl", wt ** 2, covs)
        assert np.allclose(got_c, closed, rtol=0, atol=1e3 * terms * eps * scale_c)


def test_cubature_mix_of_a_failed_mode_is_nan_in_both_paths():
    """A mode covariance that is not positive definite: that run's mixed moments are NaN in both paths (reported by
    the filter), the other runs' untouched."""
    means = np.zeros((3, 2, 4))
    covs = np.tile(np.eye(4), (3, 2, 1, 1))
    covs[1, 0, 2, 2] = -1.0
    w = np.tile(np.array([[0.9, 0.2], [0.1, 0.8]]), (3, 1, 1))
    for kernel in ("numba", "numpy"):
        with linalg.use_kernel(kernel):
            m, c = linalg.cubature_mix(means, covs, w)
        assert np.isnan(m[1]).all() and np.isnan(c[1]).all(), kernel
        assert np.isfinite(m[[0, 2]]).all() and np.isfinite(c[[0, 2]]).all(), kernel


def test_cubature_mix_reads_a_shared_weight_matrix_for_every_run():
    """One mixing-weight matrix (1, r, r) shared by every run broadcasts in the compiled twin as in numpy's: every run
    mixed with it (the kernel reads the weights run by run, so the operand is broadcast before the call, never read
    past its rows)."""
    rng = np.random.default_rng(6)
    B, r, n = 6, 2, 3
    A = rng.standard_normal((B, r, n, n))
    covs = A @ np.swapaxes(A, -1, -2) + np.eye(n)
    means = rng.standard_normal((B, r, n))
    w = np.array([[[0.7, 0.4], [0.3, 0.6]]])
    with linalg.use_kernel("numba"):
        got = linalg.cubature_mix(means, covs, w)
        each = [linalg.cubature_mix(means[b:b + 1], covs[b:b + 1], w) for b in range(B)]
    with linalg.use_kernel("numpy"):
        ref = linalg.cubature_mix(means, covs, w)
    for g, e, f in zip(got, zip(*each), ref):
        assert _same(g, np.concatenate(e))
        assert np.allclose(g, f, rtol=1e-12, atol=0)


def test_adaptive_whole_run_declines_traces_longer_than_numpys_order(monkeypatch):
    """With the inflation of Eqs. 32-35 the layer sums traces in numpy's order, which the kernel reproduces up to
    :data:`mmlib.core._kernels.NUMPY_SUM_MAX` terms: a measurement of more components makes the whole run decline
    (called, None), and run() gives the run step by step."""
    from mmlib.core import _kernels
    m = _kernels.NUMPY_SUM_MAX + 1
    H = np.zeros((m, 4))
    H[np.arange(m), 2 * (np.arange(m) % 2)] = 1.0          # x and y, alternately
    measurement = models.LinearMeasurement(H, np.eye(m) * 100.0)
    est = SingleModel(_adaptive(SigmaPointFilter(UKF), (True, True, False)), models.constant_velocity(T, 0.5),
                      measurement)
    z = _simulation(measurement, 3).measurements[:, :8]
    state = est.init(np.tile(X0, (3, 1)), P0)
    with np.errstate(all="ignore"):
        calls = _declined(est, state, z, monkeypatch, "adaptive_run")
    assert calls == [("adaptive_run", False)]


def test_an_adaptive_window_longer_than_the_run_needs_no_more_memory(monkeypatch):
    """The kernel's window buffers hold what the run can fill (min(window, K) innovations), not ``window``: a window
    of 10^8 innovations over 25 steps is the base filter's run (never full), as step by step."""
    measurement = MEASUREMENTS["range-bearing"]
    est = SingleModel(_adaptive(SigmaPointFilter(UKF), (True, True, False), window=10 ** 8),
                      models.constant_velocity(T, 0.5), measurement)
    z = _simulation(measurement, 4).measurements
    state = est.init(np.tile(X0, (4, 1)), P0)
    whole, steps = _whole_and_steps(est, state, z, monkeypatch, "adaptive_run")
    _assert_same_track(whole, steps)


def test_strong_tracking_run_refuses_the_jacobian_form_without_the_ekf():
    """The Jacobian form of the fading factor exists over the EKF only: asked for over a sigma-point filter, the
    compiled run is a ValueError naming ``jacobian`` (never the other form computed silently)."""
    n, B = 4, 2
    up = UKF.unit_points(n)
    z = np.zeros((B, 2))
    packed = linalg.packed_steps([z], [(linalg.MEASURE_LINEAR, np.eye(2, n), (), np.zeros(2))], [(False, False)],
                                 [np.eye(2)], n)
    with pytest.raises(ValueError, match="^jacobian:"):
        linalg.strong_tracking_run(np.zeros((B, n)), np.tile(np.eye(n), (B, 1, 1)), up.xi, up.wm, up.wc, np.eye(n),
                                   np.eye(n), packed, None, 0.95, 4.5, 1.0, keep_cov=False, nis=False, jacobian=True)
