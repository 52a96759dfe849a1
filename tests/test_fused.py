"""The fused filter steps (issue 25): one compiled call per IMM cycle (:func:`mmlib.core.linalg.imm_sigma_step`) or
per step of a single model (:func:`mmlib.core.linalg.sigma_step`) of a plain sigma-point filter on linear dynamics
computes the same bits as the composed step (mixing, time update, fresh points, measurement function, moments,
Kalman update, IMM output, each its own compiled call), whatever the batch and the block size; the fused path is
really taken where it applies and never where it does not.

A whole run of such an estimator is one compiled call (:func:`mmlib.core.linalg.sigma_run`,
:func:`mmlib.core.linalg.imm_sigma_run`, from :func:`mmlib.core.estimation.run`): every step the fused step's body on
the posterior of the step before, the same bits as the run step by step with the fused steps (:func:`_per_step`
turns the whole-run path off) and as the composed run.

The comparisons are exact (raw bits, NaN == NaN): the fused kernel runs the same loop bodies (``_*_core`` of
:mod:`mmlib.core._kernels`) on the same operands, so any difference is a defect, not round-off.
"""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from mmlib import MonteCarlo
from mmlib.core import estimation, gnss, linalg, models, rules
from mmlib.core.estimation import IMM, MomentMixing, SingleModel, run
from mmlib.core.filters import ExtendedKalmanFilter, SigmaPointFilter
from mmlib.core.layers.adaptive import InnovationAdaptive
from mmlib.core.layers.strong_tracking import StrongTracking
from mmlib.core.mixing import CubatureMixing
from mmlib.experiment.simulate import ManeuverSchedule, simulate
from mmlib.papers import REGISTRY

pytestmark = pytest.mark.skipif(linalg.kernel() != "numba", reason="the fused step exists on the compiled kernels")

K = 25
T, OMEGA = 1.0, np.radians(3.0)
TRANSITION = np.array([[0.90, 0.05, 0.05], [0.10, 0.85, 0.05], [0.10, 0.05, 0.85]])
X0 = np.array([20000.0, -150.0, 15000.0, 60.0])
P0 = np.diag([400.0, 100.0, 400.0, 100.0])


def _bits(a):
    a = np.ascontiguousarray(a)
    return a.view(np.uint8)


def _same(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return a.shape == b.shape and np.array_equal(_bits(a), _bits(b))


def _modes():
    return [models.constant_velocity(T, 1.0), models.coordinated_turn(T, OMEGA, 1.0),
            models.coordinated_turn(T, -OMEGA, 1.0)]


RULES = {"UKF": rules.Unscented(1.0, 2.0, 0.0), "CKF": rules.Cubature(), "5CKF": rules.FifthDegreeCubature()}
MEASUREMENTS = {
    "range-bearing": models.RangeBearing(np.diag([100.0, np.radians(0.5) ** 2])),
    "range-bearing off-centre": models.RangeBearing(np.diag([25.0, np.radians(1.0) ** 2]), sensor=(-3000.0, 500.0)),
    "linear": models.LinearMeasurement([[1.0, 0, 0, 0], [0, 0, 1.0, 0]], np.diag([100.0, 150.0])),
}


def _problem(measurement, n_runs: int, seed: int = 7):
    """Measurements of ``n_runs`` runs of a turning target (independent of the filter under test)."""
    sched = ManeuverSchedule(_modes(), [(8, 16, 1)], 0, T, K, truncate=True)
    return simulate(sched, X0, measurement, MonteCarlo(seed, n_runs), range(n_runs)).measurements


def _track(imm, z, fused: bool, **kw):
    with linalg.use_fused(fused):
        return run(imm, imm.init(np.tile(X0, (z.shape[0], 1)), P0), z, **kw)


def _assert_same_track(a, b):
    for field in ("mean", "cov", "mode_probabilities", "diverged_step", "divergence_cause", "nees", "nis"):
        assert _same(getattr(a, field), getattr(b, field)), field


def _per_step(monkeypatch):
    """run() step by step, each step the fused step (the whole-run kernels turned off for this test)."""
    monkeypatch.setattr(estimation, "_whole_run", lambda *a, **k: None)


@pytest.mark.parametrize("rule", sorted(RULES))
@pytest.mark.parametrize("meas", sorted(MEASUREMENTS))
@pytest.mark.parametrize("keep_cov", [True, False])
def test_fused_equals_composed_bit_for_bit(rule, meas, keep_cov):
    measurement = MEASUREMENTS[meas]
    imm = IMM(SigmaPointFilter(RULES[rule]), _modes(), measurement, TRANSITION)
    z = _problem(measurement, 37)
    _assert_same_track(_track(imm, z, False, keep_cov=keep_cov), _track(imm, z, True, keep_cov=keep_cov))


def test_fused_with_consistency_and_truth_equals_composed():
    measurement = MEASUREMENTS["range-bearing"]
    imm = IMM(SigmaPointFilter(RULES["UKF"]), _modes(), measurement, TRANSITION)
    sched = ManeuverSchedule(_modes(), [(8, 16, 1)], 0, T, K, truncate=True)
    sim = simulate(sched, X0, measurement, MonteCarlo(3, 20), range(20))
    kw = dict(consistency=True, truth=sim.truth)
    _assert_same_track(_track(imm, sim.measurements, False, **kw), _track(imm, sim.measurements, True, **kw))


def test_fused_per_run_noise_override_and_one_step_equal_composed():
    """A per-run, per-mode Q (B, r, n, n), as the noise-adaptive layers pass through ``step(dynamics=)``, is read
    periodically over the (runs, modes) stack exactly as the composed step reads it."""
    measurement = MEASUREMENTS["range-bearing"]
    imm = IMM(SigmaPointFilter(RULES["CKF"]), _modes(), measurement, TRANSITION)
    B = 11
    rng = np.random.default_rng(0)
    scale = rng.uniform(0.5, 4.0, size=(B, 3, 1, 1))
    dyn = imm.stacked.with_noise(imm.stacked.Q[None] * scale)
    state = imm.init(np.tile(X0, (B, 1)), P0)
    z = _problem(measurement, B)[:, 0]
    out = []
    for on in (False, True):
        with linalg.use_fused(on):
            out.append(imm.step(state, z, dynamics=dyn))
    (s0, e0), (s1, e1) = out
    for a, b in zip((s0.modes.mean, s0.modes.cov, s0.mode_probabilities) + tuple(e0),
                    (s1.modes.mean, s1.modes.cov, s1.mode_probabilities) + tuple(e1)):
        assert _same(None if a is None else np.asarray(a), None if b is None else np.asarray(b))


def test_fused_failed_runs_equal_composed():
    """Runs whose covariance is not positive definite fail at the same step with the same cause and the same NaN
    pattern, and the other runs of the batch are untouched."""
    measurement = MEASUREMENTS["range-bearing"]
    imm = IMM(SigmaPointFilter(RULES["UKF"]), _modes(), measurement, TRANSITION)
    B = 9
    z = _problem(measurement, B)
    cov = np.tile(P0, (B, 1, 1))
    cov[[2, 5], 0, 0] = -1.0                       # not positive definite: the first step's points fail
    tracks = []
    for on in (False, True):
        with linalg.use_fused(on):
            state = imm.init(np.tile(X0, (B, 1)), P0)
            state = state._replace(modes=state.modes._replace(cov=np.repeat(cov[:, None], 3, axis=1)))
            tracks.append(run(imm, state, z))
    _assert_same_track(*tracks)
    assert set(np.flatnonzero(tracks[1].diverged)) == {2, 5}


@pytest.mark.parametrize("block", [1, 2, 3, 64, 128, 1000])
def test_fused_block_size_changes_no_bit(block, monkeypatch):
    measurement = MEASUREMENTS["range-bearing"]
    imm = IMM(SigmaPointFilter(RULES["UKF"]), _modes(), measurement, TRANSITION)
    z = _problem(measurement, 130)
    reference = _track(imm, z, True)
    monkeypatch.setattr(linalg, "FUSED_BLOCK", block)
    _assert_same_track(reference, _track(imm, z, True))


@pytest.mark.parametrize("batch", [1, 2, 3, 64])
def test_fused_batch_size_changes_no_bit(batch):
    measurement = MEASUREMENTS["range-bearing"]
    imm = IMM(SigmaPointFilter(RULES["5CKF"]), _modes(), measurement, TRANSITION)
    z = _problem(measurement, 64)
    whole = _track(imm, z, True)
    part = _track(imm, z[:batch], True)
    for field in ("mean", "cov", "mode_probabilities"):
        assert _same(getattr(whole, field)[:batch], getattr(part, field)), field


class _NotDeclaredLinear:
    """A linear model's transition and Jacobian under a class that does not declare itself linear: the stacked
    dynamics have no ``F``, as for a nonlinear model."""

    def __init__(self, model):
        self.model, self.dim, self.Q = model, model.dim, model.Q

    def transition(self, x):
        return self.model.transition(x)

    def jacobian(self, x):
        return self.model.jacobian(x)


def _spy(monkeypatch):
    """Count the fused calls; make the composed step's first operation raise, so a silent fallback fails."""
    calls = []
    real = linalg.imm_sigma_step

    def counting(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    def composed(*args, **kwargs):
        raise AssertionError("the composed step ran where the fused one applies")

    monkeypatch.setattr(linalg, "imm_sigma_step", counting)
    monkeypatch.setattr(linalg, "imm_mix", composed)
    return calls


def test_fused_path_is_taken(monkeypatch):
    """The benchmark's IMM-UKF takes the fused step at every step (it fails if the path silently falls back)."""
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from bench import job
    calls = _spy(monkeypatch)
    whole = []
    real = linalg.imm_sigma_run
    monkeypatch.setattr(linalg, "imm_sigma_run", lambda *a, **k: whole.append(1) or real(*a, **k))
    est = job.mmlib_run(5, 12)
    assert len(whole) == 1 and not calls and np.isfinite(est.mean).all()     # the whole run: one call
    _per_step(monkeypatch)
    est = job.mmlib_run(5, 12)
    assert len(calls) == 12 and len(whole) == 1 and np.isfinite(est.mean).all()     # step by step: one per step


@pytest.mark.parametrize("why", ["numpy kernels", "fusion off", "central differences", "mixing strategy",
                                 "nonlinear dynamics", "user measurement model", "filter subclass"])
def test_fused_path_is_not_taken_where_it_does_not_apply(why, monkeypatch):
    measurement = MEASUREMENTS["range-bearing"]
    modes, filt, mixing = _modes(), SigmaPointFilter(RULES["UKF"]), MomentMixing()
    if why == "central differences":
        filt = SigmaPointFilter(rules.CentralDifference(np.sqrt(3.0)))
    elif why == "mixing strategy":
        class Mixing(MomentMixing):
            pass
        mixing = Mixing()
    elif why == "nonlinear dynamics":
        modes = [models.constant_velocity(T, 1.0), _NotDeclaredLinear(models.coordinated_turn(T, OMEGA, 1.0))]
    elif why == "user measurement model":
        class Radar(models.RangeBearing):
            pass
        measurement = Radar(np.asarray(measurement.R))
    elif why == "filter subclass":
        class Filter(SigmaPointFilter):
            pass
        filt = Filter(RULES["UKF"])
    transition = TRANSITION if len(modes) == 3 else np.array([[0.95, 0.05], [0.05, 0.95]])
    imm = IMM(filt, modes, measurement, transition, mixing=mixing)
    _assert_composed(imm, "imm_sigma_step", why, monkeypatch)


def _assert_composed(est, step: str, why: str, monkeypatch) -> None:
    """``est`` run over 4 runs of the range-bearing problem, with the numpy kernels or fusion off when ``why`` says so,
    never calls the fused step ``step`` (replaced by a stub that would fail the run) and gives a finite track."""
    calls = []
    monkeypatch.setattr(linalg, step, lambda *a, **k: calls.append(1))
    z = _problem(MEASUREMENTS["range-bearing"], 4)
    kernel = "numpy" if why == "numpy kernels" else "numba"
    with linalg.use_kernel(kernel), linalg.use_fused(why != "fusion off"):
        track = run(est, est.init(np.tile(X0, (4, 1)), P0), z)
    assert not calls and np.isfinite(track.mean).all()


def test_use_fused_and_environment_reject_bad_values(monkeypatch):
    with pytest.raises(ValueError, match="on"):
        with linalg.use_fused(1):
            pass
    monkeypatch.setenv("MMLIB_FUSED", "yes")
    with pytest.raises(ValueError, match="MMLIB_FUSED"):
        linalg._initial_fused()
    monkeypatch.setenv("MMLIB_FUSED", "0")
    assert linalg._initial_fused() is False


def test_fused_measure_only_for_the_library_models():
    assert estimation._fused_measure(MEASUREMENTS["linear"])[0] == linalg.MEASURE_LINEAR
    assert estimation._fused_measure(MEASUREMENTS["range-bearing"])[0] == linalg.MEASURE_RANGE_BEARING
    sats = gnss.Pseudoranges(np.array([[2e7, 1e6, 1.5e7], [-1e7, 5e6, 2e7]]), np.eye(2) * 9.0)
    assert estimation._fused_measure(sats)[0] == linalg.MEASURE_PSEUDORANGES

    class Radar(models.RangeBearing):
        pass
    assert estimation._fused_measure(Radar(np.eye(2))) is None


def _headline_tracks(name: str, fused: bool, calls: list) -> dict:
    """Every estimator of paper ``name``'s headline batch (8 runs; a prefix of 40 epochs with per-step measurement
    models), run with the fused step on or off; ``calls`` collects the fused calls."""
    paper = REGISTRY[name]
    batch = paper.batch(paper.headline_setup(), MonteCarlo(paper.root_seed, 8))
    make_batch, estimators = batch[0], batch[1]
    per_step = batch[2] if len(batch) == 3 else None
    truth, z, init = make_batch(range(8))
    if per_step is not None:
        z, per_step = z[:40], per_step[:40]
    out = {}
    with linalg.use_fused(fused):
        for est_name, est in estimators.items():
            before = len(calls)
            out[est_name] = (run(est, init[est_name], z, measurement_models=per_step), len(calls) > before)
    return out


@pytest.mark.parametrize("name", list(REGISTRY))
def test_every_paper_headline_fused_equals_composed(name, monkeypatch):
    """Every estimator of every registered paper's headline gives the same bits with the fused step on and off
    (those that do not take it trivially); a fused step or a whole run is taken by every estimator
    :func:`_should_fuse` names, and by no other."""
    calls = []
    for step in linalg.FUSED_STEPS:
        real = getattr(linalg, step)
        monkeypatch.setattr(linalg, step, lambda *a, _real=real, **k: calls.append(1) or _real(*a, **k))
    composed = _headline_tracks(name, False, calls)
    assert not calls
    fused = _headline_tracks(name, True, calls)
    for est_name, (track, _) in composed.items():
        _assert_same_track(track, fused[est_name][0])
    for est_name, (track, took) in fused.items():
        est = REGISTRY[name].batch(REGISTRY[name].headline_setup(), MonteCarlo(1, 2))[1][est_name]
        assert took == _should_fuse(est), (est_name, took)


def _should_fuse(est) -> bool:
    """Whether run() of an estimator (an IMM, a single model, or a layer holding an IMM as ``imm``) takes a fused step
    or a whole run, written out independently: linear dynamics and a library measurement model, and an IMM with
    moment or cubature-principle mixing, or a single model, whose filter is a plain sigma-point filter with weighted
    moments, an extended Kalman filter, an innovation-adaptive layer over such a sigma-point filter, or (single model)
    strong tracking over such a sigma-point filter (the statistical form) or over an EKF (either form)."""
    inner = getattr(est, "imm", est)
    if isinstance(inner, IMM):
        filt, dyn = inner.filter, inner.stacked
        mixing_ok = type(inner.mixing) in (MomentMixing, CubatureMixing)
    elif isinstance(inner, SingleModel):
        filt, dyn, mixing_ok = inner.filter, inner.dynamics, True
        if type(filt) is StrongTracking and (filt.form == "statistical" or type(filt.base) is ExtendedKalmanFilter):
            filt = filt.base
    else:
        return False
    if type(filt) is InnovationAdaptive:
        filt = filt.base
    measurement_ok = inner.measurement is None or type(inner.measurement) in (models.LinearMeasurement,
                                                                              models.RangeBearing, gnss.Pseudoranges)
    sigma = type(filt) is SigmaPointFilter and filt.rule.weighted_moments
    return (mixing_ok and (sigma or type(filt) is ExtendedKalmanFilter)
            and bool(getattr(dyn, "is_linear", False)) and measurement_ok)


@pytest.mark.parametrize("rule", sorted(RULES))
@pytest.mark.parametrize("meas", sorted(MEASUREMENTS))
def test_single_model_fused_equals_composed_bit_for_bit(rule, meas, monkeypatch):
    measurement = MEASUREMENTS[meas]
    est = SingleModel(SigmaPointFilter(RULES[rule]), models.constant_velocity(T, 1.0), measurement)
    z = _problem(measurement, 21)
    composed = _track(est, z, False)
    calls, whole = [], []
    real, real_run = linalg.sigma_step, linalg.sigma_run
    monkeypatch.setattr(linalg, "sigma_step", lambda *a, **k: calls.append(1) or real(*a, **k))
    monkeypatch.setattr(linalg, "sigma_run", lambda *a, **k: whole.append(1) or real_run(*a, **k))
    at_once = _track(est, z, True)
    assert len(whole) == 1 and not calls
    _assert_same_track(composed, at_once)
    _per_step(monkeypatch)
    fused = _track(est, z, True)
    assert len(calls) == K and len(whole) == 1
    _assert_same_track(composed, fused)


def test_fused_steps_reject_mismatched_shapes():
    """The compiled kernels do not check bounds: a mismatched operand is a ValueError before the call."""
    B, r, n, m, M = 4, 3, 4, 2, 9
    up = RULES["UKF"].unit_points(n)
    args = dict(mu=np.full((B, r), 1 / 3), transition=TRANSITION, means=np.zeros((B, r, n)),
                covs=np.tile(np.eye(n), (B, r, 1, 1)), xi=up.xi, wm=up.wm, wc=up.wc, F=np.tile(np.eye(n), (r, 1, 1)),
                Q=np.eye(n), z=np.ones((B, m)), measure=(linalg.MEASURE_RANGE_BEARING, np.zeros((1, 1)), (0, 2),
                                                         np.zeros(2)),
                angular=(False, True), R=np.eye(m), with_cov=True, log_2pi=np.log(2 * np.pi))
    assert np.isfinite(linalg.imm_sigma_step(**args)[5]).all()
    for name, bad in (("covs", np.zeros((B, r, n, n + 1))), ("xi", np.zeros((M, n + 1))), ("R", np.eye(m + 1)),
                      ("F", np.eye(n)), ("z", np.ones((B, m, 1))), ("angular", (False,)), ("Q", np.eye(n + 1)),
                      ("Q", np.zeros((2, 8)))):
        with pytest.raises(ValueError):
            linalg.imm_sigma_step(**{**args, name: bad})
    for measure in ((linalg.MEASURE_LINEAR, np.zeros((m, n + 1)), (), np.zeros(2)),
                    (linalg.MEASURE_PSEUDORANGES, np.zeros((m, 2)), (0, 2, 4, 6), np.zeros(2)),
                    (linalg.MEASURE_RANGE_BEARING, np.zeros((1, 1)), (0,), np.zeros(2)),
                    (linalg.MEASURE_RANGE_BEARING, np.zeros((1, 1)), (0, 7), np.zeros(2)),
                    (7, np.zeros((1, 1)), (), np.zeros(2))):
        with pytest.raises(ValueError, match="measure"):
            linalg.imm_sigma_step(**{**args, "measure": measure})


def _frozen(a):
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


def test_read_only_operands_compile_nothing_more():
    """A read-only operand (a model's frozen matrix, a memoised measurement batch) is handed to the compiled kernels
    as a writable copy: the same numbers, and no second compilation of the kernel for the read-only type (which
    would also compile again every loop it calls)."""
    from numba.core import types

    from mmlib.core import _kernels
    B, r, n, m = 4, 3, 4, 2
    up = RULES["UKF"].unit_points(n)
    args = dict(mu=np.full((B, r), 1 / 3), transition=TRANSITION, means=np.tile(X0, (B, r, 1)),
                covs=np.tile(P0, (B, r, 1, 1)), xi=up.xi, wm=up.wm, wc=up.wc, F=np.tile(np.eye(n), (r, 1, 1)),
                Q=np.eye(n), z=np.tile([25000.0, 0.6], (B, 1)),
                measure=(linalg.MEASURE_RANGE_BEARING, np.zeros((1, 1)), (0, 2), np.zeros(2)),
                angular=np.array([False, True]), R=np.eye(m), with_cov=True, log_2pi=np.log(2 * np.pi))
    writable = linalg.imm_sigma_step(**args)
    chol = linalg.cholesky(np.tile(P0, (B, 1, 1)))
    counts = (len(_kernels.imm_sigma_step.signatures), len(_kernels.cholesky.signatures))
    frozen = {k: _frozen(v) if isinstance(v, np.ndarray) else v for k, v in args.items()}
    frozen["measure"] = (linalg.MEASURE_RANGE_BEARING, _frozen(np.zeros((1, 1))), (0, 2), _frozen(np.zeros(2)))
    assert not frozen["z"].flags.writeable
    for a, b in zip(writable, linalg.imm_sigma_step(**frozen)):
        assert _same(a, b)
    for a, b in zip(chol, linalg.cholesky(_frozen(np.tile(P0, (B, 1, 1))))):
        assert _same(a, b)
    assert (len(_kernels.imm_sigma_step.signatures), len(_kernels.cholesky.signatures)) == counts
    for fn in (_kernels.imm_sigma_step, _kernels.cholesky):
        assert not any(isinstance(t, types.Array) and not t.mutable for sig in fn.signatures for t in sig)


def _same_steps(est, state, zs, models_k=None, **step_kw) -> tuple:
    """Step ``est`` through the measurements ``zs`` (K, B, m) (or a list of (B, m_k), with ``models_k`` the
    measurement model of each step) with the fused steps off and on: ``(mismatches, fused estimates, fused
    calls)``, the mismatches naming every (step, Estimate field) and final-state leaf whose bits
    differ (the test asserts there is none), the calls counting the fused steps taken."""
    out, calls = [], []
    for on in (False, True):
        s, estimates = state, []
        with linalg.use_fused(on):
            for k, z in enumerate(zs):
                before = {name: getattr(linalg, name) for name in linalg.FUSED_STEPS}
                for name, real in before.items():
                    setattr(linalg, name, lambda *a, _real=real, **kw: calls.append(1) or _real(*a, **kw))
                try:
                    s, e = est.step(s, z, **step_kw, **({} if models_k is None else {"measurement": models_k[k]}))
                finally:
                    for name, real in before.items():
                        setattr(linalg, name, real)
                estimates.append(e)
        out.append((s, estimates))
    (s0, e0), (s1, e1) = out
    mismatches = [f"step {k} {field}" for k, (a, b) in enumerate(zip(e0, e1)) for field, x, y in zip(a._fields, a, b)
                  if not _same(None if x is None else np.asarray(x), None if y is None else np.asarray(y))]
    flat0, flat1 = _leaves(s0), _leaves(s1)
    if len(flat0) != len(flat1):
        mismatches.append(f"final state: {len(flat0)} vs {len(flat1)} arrays")
    mismatches += [f"final state leaf {i}" for i, (x, y) in enumerate(zip(flat0, flat1)) if not _same(x, y)]
    return mismatches, e1, len(calls)


def _leaves(state):
    if isinstance(state, tuple):
        return [leaf for part in state for leaf in _leaves(part)]
    return [np.asarray(state)] if isinstance(state, np.ndarray) else []


def test_every_estimate_field_at_every_step_with_failures_at_a_later_pivot_and_bearings_at_the_cut():
    """Runs whose covariance fails at the last pivot in one mode (run 1) or in every mode (run 4), bearings within
    0.02 rad of the +-pi cut: the log-likelihoods, innovations, their covariances, failures and states agree bit for
    bit at every step, for the IMM and the single model."""
    B = 6
    rng = np.random.default_rng(1)
    radar = models.RangeBearing(np.diag([100.0, np.radians(0.5) ** 2]), sensor=(25000.0, 14000.0))
    zs = []
    for _ in range(4):
        z = np.column_stack([rng.uniform(4000, 6000, B), np.pi - rng.uniform(0, 0.02, B) * rng.choice([-1, 1], B)])
        z[:, 1] = (z[:, 1] + np.pi) % (2 * np.pi) - np.pi
        zs.append(z)
    imm = IMM(SigmaPointFilter(RULES["UKF"]), _modes(), radar, TRANSITION)
    state = imm.init(np.tile(X0, (B, 1)), P0)
    cov = state.modes.cov.copy()
    cov[1, 2, 3, 3] = -1.0
    cov[4, :, 3, 3] = -5.0
    state = state._replace(modes=state.modes._replace(cov=cov))
    mismatches, estimates, calls = _same_steps(imm, state, zs, with_cov=False)
    assert not mismatches and calls == len(zs)
    assert estimates[0].failure[4] != 0 and np.isfinite(estimates[-1].mean[[0, 2, 3, 5]]).all()
    single = SingleModel(SigmaPointFilter(RULES["CKF"]), _modes()[1], radar)
    mismatches, _, calls = _same_steps(single, single.init(np.tile(X0, (B, 1)), P0), zs)
    assert not mismatches and calls == len(zs)


@pytest.mark.parametrize("block", [1, 7, 128])
def test_single_model_over_several_blocks_equals_composed(block, monkeypatch):
    """More runs than a block: every block of the single-model step lands on its own runs."""
    monkeypatch.setattr(linalg, "FUSED_BLOCK", block)
    measurement = MEASUREMENTS["range-bearing off-centre"]
    est = SingleModel(SigmaPointFilter(RULES["5CKF"]), models.constant_velocity(T, 1.0), measurement)
    z = _problem(measurement, 300)
    mismatches, estimates, calls = _same_steps(est, est.init(np.tile(X0, (300, 1)), P0), np.swapaxes(z[:, :6], 0, 1))
    assert not mismatches and calls == 6
    assert np.isfinite(estimates[-1].mean).all() and estimates[-1].mean.shape == (300, 4)


def test_shared_stacks_and_stacked_single_dynamics_equal_composed():
    """Operands the composed step reads periodically -- mode covariances shared by the runs, a single model's
    covariance shared by the runs, its dynamics as a one-model stack -- give the composed bits (the fused wrappers
    broadcast them; the kernel never reads past a stack)."""
    B = 5
    measurement = MEASUREMENTS["range-bearing"]
    zs = np.swapaxes(_problem(measurement, B)[:, :3], 0, 1)
    imm = IMM(SigmaPointFilter(RULES["UKF"]), _modes(), measurement, TRANSITION)
    state = imm.init(np.tile(X0, (B, 1)), P0)
    state = state._replace(modes=state.modes._replace(cov=state.modes.cov[:1]))
    mismatches, _, calls = _same_steps(imm, state, zs)
    assert not mismatches and calls == len(zs)
    single = SingleModel(SigmaPointFilter(RULES["CKF"]), models.constant_velocity(T, 1.0), measurement)
    s0 = single.init(np.tile(X0, (B, 1)), P0)
    mismatches, _, calls = _same_steps(single, s0._replace(cov=P0), zs)
    assert not mismatches and calls == len(zs)
    stacked = SingleModel(SigmaPointFilter(RULES["CKF"]), models.StackedDynamics.of([models.constant_velocity(T, 1.0)]),
                          measurement)
    mismatches, _, calls = _same_steps(stacked, s0, zs)
    assert not mismatches and calls == 0                 # a stacked F falls back to the composed step


def test_huge_bearing_residual_wraps_as_the_composed_residual():
    """A finite but huge bearing (1e20 rad) wraps to the composed residual's bits (np.floor, not an integer floor)."""
    measurement = MEASUREMENTS["range-bearing"]
    imm = IMM(SigmaPointFilter(RULES["UKF"]), _modes(), measurement, TRANSITION)
    z = _problem(measurement, 3)[:, :2].copy()
    z[1, 1, 1] = 1e20
    mismatches, estimates, calls = _same_steps(imm, imm.init(np.tile(X0, (3, 1)), P0), np.swapaxes(z, 0, 1))
    assert not mismatches and calls == 2
    assert -np.pi < estimates[1].innovation[1, 1] <= np.pi      # wrapped, as wrap_angle wraps it


def test_no_vectorised_transcendentals():
    """The kernels call the C library's log one value at a time (and its hypot and atan2 for the operands outside
    the regular range of mmlib.core._elementary): with Intel's SVML numba would vectorise them, and the bits would
    depend on the machine (the lock file does not install it)."""
    import numba
    assert not numba.config.USING_SVML


# --------------------------------------------------------------------------- the fused strong-tracking step
ST_RULES = {**RULES, "SSRCKF": rules.SphericalSimplexRadial()}


def _strong_tracking(rule: str, measurement, q: float = 0.01, **kw) -> SingleModel:
    """A strong-tracking filter (Liu & Wu 2017's beta and rho) on a CV model too quiet for the turn of
    :func:`_problem`, so that its fading factor exceeds 1 at some steps and not at others."""
    return SingleModel(StrongTracking(SigmaPointFilter(ST_RULES[rule]), beta=4.5, rho=0.95, **kw),
                       models.constant_velocity(T, q), measurement)


def _fading_factors(est, state, zs) -> np.ndarray:
    """(K, B) the fading factor of every step (fused steps on)."""
    out = []
    for z in zs:
        state, _ = est.step(state, z)
        out.append(state.fading)
    return np.array(out)


@pytest.mark.parametrize("rule", sorted(ST_RULES))
@pytest.mark.parametrize("meas", sorted(MEASUREMENTS))
@pytest.mark.parametrize("q", [0.01, 30.0])
def test_strong_tracking_fused_equals_composed_bit_for_bit(rule, meas, q):
    """The strong-tracking layer over a plain sigma-point filter: one compiled call per step gives every Estimate field
    at every step and the final state (V of Eq. 17, Q, the fading factor) the bits of the composed layer, through steps
    whose fading factor exceeds 1 (the prior inflated and predicted again) and steps where it is 1, with a small process
    noise and one of the prior's size.  (A run inflated at a factor of 1 shows only where (P - Q) + Q rounds away from
    P, i.e. where an entry of P is below half of Q's: the GNSS case below is the one that catches it.)"""
    measurement = MEASUREMENTS[meas]
    est = _strong_tracking(rule, measurement, q)
    zs = np.swapaxes(_problem(measurement, 21), 0, 1)
    state = est.init(np.tile(X0, (21, 1)), P0)
    mismatches, _, calls = _same_steps(est, state, zs)
    assert not mismatches and calls == K
    lam = _fading_factors(est, state, zs)
    assert (lam > 1.0).any() and (lam == 1.0).any() and not (lam < 1.0).any()


@pytest.mark.parametrize("block", [1, 7, 128])
def test_strong_tracking_over_several_blocks_equals_composed(block, monkeypatch):
    """More runs than a block, and blocks in which only some runs inflate: every block lands on its own runs."""
    monkeypatch.setattr(linalg, "FUSED_BLOCK", block)
    measurement = MEASUREMENTS["range-bearing off-centre"]
    est = _strong_tracking("CKF", measurement)
    zs = np.swapaxes(_problem(measurement, 300)[:, :12], 0, 1)
    state = est.init(np.tile(X0, (300, 1)), P0)
    mismatches, estimates, calls = _same_steps(est, state, zs)
    assert not mismatches and calls == 12 and np.isfinite(estimates[-1].mean).all()
    lam = _fading_factors(est, state, zs)
    assert ((lam > 1.0).any(axis=1) & (lam == 1.0).any(axis=1)).any()      # a step with runs of both kinds


@pytest.mark.parametrize("batch", [1, 2, 3, 64])
def test_strong_tracking_batch_size_changes_no_bit(batch):
    """A run's fused strong-tracking track has the same bits alone, in a batch of 2 or 3 and in one of 64."""
    measurement = MEASUREMENTS["range-bearing"]
    est = _strong_tracking("UKF", measurement)
    z = _problem(measurement, 64)
    ref = _track(est, z, True)
    got = _track(est, z[:batch], True)
    for field in ("mean", "cov", "diverged_step", "nis"):
        a, b = getattr(got, field), getattr(ref, field)
        assert a is None and b is None or _same(a, b[:batch]), field


def _gnss_strong_tracking(K: int) -> tuple:
    """The arena's STUKF on Tseng et al. 2011's scenario, 5 runs, its first K epochs with one satellite fewer at epochs
    4-7 (V restarts there and after, Eq. 17), run 1 not positive definite from the start: ``(estimator, state,
    measurements, models)``."""
    from mmlib.arena import recipes, study
    est, state, zs, models_k, _ = _gnss_epochs(recipes.build("STUKF", study.scenario("tseng2011")), K, range(4, 8))
    cov = state.cov.copy()
    cov[1, 6, 6] = -1.0                         # run 1: not positive definite from the start
    return est, state._replace(cov=cov), zs, models_k


def _gnss_epochs(est, K: int, fewer) -> tuple:
    """``est`` (a single model on Tseng et al. 2011's scenario) over the scenario's first K epochs, 5 runs, with one
    satellite fewer at the epochs ``fewer`` (the measurement dimension changes there and after): ``(estimator, state
    from the arena's initial state, measurements, models, truth (5, K + 1, 8))``."""
    from mmlib.arena import recipes, study
    from mmlib.experiment import evaluation
    s = study.scenario("tseng2011")
    mc = MonteCarlo(s.root_seed, 5)
    make_batch = evaluation.with_initial_states(s.simulator(mc), {est.name: est},
                                                lambda e, start, runs: recipes.initial_state(e, s, start, runs, mc))
    truth, z, init = make_batch(range(5))
    zs, models_k = [], []
    for k in range(K):
        model, zk = s.measurement_models[k], z[k]
        if k in fewer:                          # one satellite fewer
            model = gnss.Pseudoranges(model.satellites[:-1], np.asarray(model.R)[:-1, :-1])
            zk = zk[:, :-1]
        zs.append(zk)
        models_k.append(model)
    return est, init[est.name], zs, models_k, truth[:, :K + 1]


def test_strong_tracking_restart_failures_and_gnss_equal_composed():
    """Pseudoranges whose satellite set changes size (V restarts, Eq. 17), a run whose covariance fails at the first
    step and one that fails later: the same bits as the composed layer, and the failures reported at their steps."""
    est, state, zs, models_k = _gnss_strong_tracking(12)
    mismatches, estimates, calls = _same_steps(est, state, zs, models_k)
    assert not mismatches and calls == len(zs)
    assert estimates[0].failure[1] != 0 and np.isfinite(estimates[-1].mean[[0, 2, 3, 4]]).all()
    assert {e.innovation.shape[1] for e in estimates} == {zs[0].shape[1], zs[0].shape[1] - 1}


@pytest.mark.parametrize("why", ["numpy kernels", "fusion off", "jacobian form", "EKF base", "central differences",
                                 "layer subclass", "stacked dynamics", "user measurement model"])
def test_strong_tracking_fused_path_is_not_taken_where_it_does_not_apply(why, monkeypatch):
    measurement, base, form = MEASUREMENTS["range-bearing"], SigmaPointFilter(RULES["UKF"]), "statistical"
    dynamics = models.constant_velocity(T, 0.01)
    layer = StrongTracking
    if why == "jacobian form":
        form = "jacobian"
    elif why == "EKF base":
        base = ExtendedKalmanFilter()
    elif why == "central differences":
        base = SigmaPointFilter(rules.CentralDifference(np.sqrt(3.0)))
    elif why == "layer subclass":
        class Layer(StrongTracking):
            pass
        layer = Layer
    elif why == "stacked dynamics":
        dynamics = models.StackedDynamics.of([dynamics])
    elif why == "user measurement model":
        class Radar(models.RangeBearing):
            pass
        measurement = Radar(np.asarray(measurement.R))
    est = SingleModel(layer(base, beta=4.5, rho=0.95, form=form), dynamics, measurement)
    _assert_composed(est, "strong_tracking_step", why, monkeypatch)


def test_strong_tracking_step_rejects_mismatched_shapes():
    B, n, m = 4, 4, 2
    up = RULES["UKF"].unit_points(n)
    args = dict(mean=np.zeros((B, n)), cov=np.tile(np.eye(n), (B, 1, 1)), xi=up.xi, wm=up.wm, wc=up.wc, F=np.eye(n),
                Q=np.eye(n), z=np.ones((B, m)), measure=(linalg.MEASURE_LINEAR, np.eye(m, n), (), np.zeros(2)),
                angular=(False, False), R=np.eye(m), V=np.tile(np.eye(m), (B, 1, 1)), rho=0.95, beta=4.5,
                log_2pi=np.log(2 * np.pi))
    assert np.isfinite(linalg.strong_tracking_step(**args)[0]).all()
    for name, bad in (("V", np.eye(m + 1)), ("V", np.zeros((3, m, m))), ("cov", np.zeros((B, n, n + 1))),
                      ("R", np.eye(m + 1)), ("Q", np.eye(n + 1)), ("F", np.eye(n + 1))):
        with pytest.raises(ValueError):
            linalg.strong_tracking_step(**{**args, name: bad})


class _PerRunNoise:
    """Linear CV dynamics with a process noise per run, (B, n, n) (a user's model: the library's single models share
    one Q)."""

    is_linear = True

    def __init__(self, B: int):
        self.model = models.constant_velocity(T, 0.01)
        self.dim, self.F = self.model.dim, self.model.F
        self.Q = self.model.Q * np.linspace(1.0, 400.0, B)[:, None, None]

    def transition(self, x):
        return self.model.transition(x)

    def jacobian(self, x):
        return self.model.jacobian(x)


@pytest.mark.parametrize("block", [1, 4, 128])
def test_strong_tracking_per_run_noise_and_a_given_V_equal_composed(block, monkeypatch):
    """A process noise per run read at each block's own runs, and a V of Eq. 17 given at init (per run, then one
    shared (m, m)): the composed bits."""
    monkeypatch.setattr(linalg, "FUSED_BLOCK", block)
    B = 9
    measurement = MEASUREMENTS["range-bearing"]
    est = SingleModel(StrongTracking(SigmaPointFilter(RULES["CKF"]), beta=4.5, rho=0.95), _PerRunNoise(B), measurement)
    zs = np.swapaxes(_problem(measurement, B)[:, :12], 0, 1)
    V0 = np.diag([400.0, 1e-4]) * np.linspace(0.5, 3.0, B)[:, None, None]
    for V in (V0, V0[0]):
        state = est.init(np.tile(X0, (B, 1)), P0, V=V)
        mismatches, _, calls = _same_steps(est, state, zs)
        assert not mismatches and calls == len(zs)
    lam = _fading_factors(est, est.init(np.tile(X0, (B, 1)), P0), zs)
    assert (lam > 1.0).any()


@pytest.mark.filterwarnings("ignore:overflow:RuntimeWarning")
def test_strong_tracking_a_later_failure_equals_composed():
    """A wild measurement at step 5 of run 2 (V of Eq. 17 overflows, tr M is NaN so the factor is 1, and the estimate
    runs away until the run fails): the composed bits at every step, the failure reported at the same step in both, not
    before step 5, and the other runs untouched."""
    B = 4
    measurement = MEASUREMENTS["range-bearing"]
    est = _strong_tracking("UKF", measurement)
    zs = np.swapaxes(_problem(measurement, B)[:, :8], 0, 1).copy()
    zs[5, 2, 0] = 1e200
    mismatches, estimates, calls = _same_steps(est, est.init(np.tile(X0, (B, 1)), P0), zs)
    assert not mismatches and calls == len(zs)
    assert [e.failure[2] != 0 for e in estimates].index(True) >= 5
    assert np.isfinite(estimates[-1].mean[[0, 1, 3]]).all() and np.isnan(estimates[-1].mean[2]).all()


def test_strong_tracking_a_float32_V_takes_the_composed_step():
    """A V of another precision than float64 given at init (the composed update computes Eq. 17 in it): the first step
    is composed, the later ones (V then float64) fused, and every step has the composed bits."""
    measurement = MEASUREMENTS["linear"]
    est = _strong_tracking("CKF", measurement)
    V = np.array([[100.3, 7.1], [7.1, 0.37]], dtype=np.float32)      # not exact in float32 arithmetic
    state = est.init(np.tile(X0, (3, 1)), P0, V=V)
    zs = np.swapaxes(_problem(measurement, 3)[:, :6], 0, 1)
    mismatches, _, calls = _same_steps(est, state, zs)
    assert not mismatches and calls == len(zs) - 1


# ------------------------------------------------------------------------------------ the runs split over threads
def _spy_ranges(monkeypatch, step: str) -> list:
    """Wrap the compiled ``step`` of :mod:`mmlib.core._kernels`: record ``(start, stop, thread name)`` of each call."""
    from mmlib.core import _kernels
    seen, kernel = [], getattr(_kernels, step)

    def spy(*args):
        import threading
        seen.append((args[-3], args[-2], threading.current_thread().name))
        return kernel(*args)
    monkeypatch.setattr(_kernels, step, spy)
    return seen


THREADED = {
    "imm_sigma_step": lambda m: IMM(SigmaPointFilter(RULES["UKF"]), _modes(), m, TRANSITION),
    "sigma_step": lambda m: SingleModel(SigmaPointFilter(RULES["5CKF"]), models.constant_velocity(T, 1.0), m),
    "strong_tracking_step": lambda m: _strong_tracking("CKF", m),
    "imm_sigma_run": lambda m: IMM(SigmaPointFilter(RULES["UKF"]), _modes(), m, TRANSITION),
    "sigma_run": lambda m: SingleModel(SigmaPointFilter(RULES["5CKF"]), models.constant_velocity(T, 1.0), m),
    "strong_tracking_run": lambda m: _strong_tracking("CKF", m),
    "adaptive_run": lambda m: _adaptive((True, True, True), m),
}


@pytest.mark.parametrize("step", sorted(THREADED))
@pytest.mark.parametrize("count", [2, 3, 8])
def test_thread_count_changes_no_bit(step, count, monkeypatch):
    """The blocks of runs split over 2, 3 or 8 threads (7 blocks of 7 runs, the last short): the track of one thread
    bit for bit, each range of runs computed once (per step, or once for the whole run), the first in the caller's
    thread and the others in helper threads (the split is really taken)."""
    measurement = MEASUREMENTS["range-bearing off-centre"]
    est = THREADED[step](measurement)
    z = _problem(measurement, 45)[:, :10]
    monkeypatch.setattr(linalg, "FUSED_BLOCK", 7)
    if not step.endswith("_run"):
        _per_step(monkeypatch)
    with linalg.use_threads(1):
        reference = _track(est, z, True)
    seen = _spy_ranges(monkeypatch, step)
    with linalg.use_threads(count):
        got = _track(est, z, True)
    _assert_same_track(reference, got)
    calls = 1 if step.endswith("_run") else 10
    ranges = linalg._run_ranges(45, 7, count)
    assert len(ranges) == min(count, 7) and len(seen) == calls * len(ranges)
    assert sorted((a, b) for a, b, _ in seen) == sorted(ranges * calls)
    here = [(a, b) for a, b, name in seen if name == "MainThread"]
    assert here == [ranges[0]] * calls             # the other ranges at once in the helper threads


@pytest.mark.parametrize("block", [1, 3, 128])
def test_run_ranges_cover_every_run_once_in_whole_blocks(block):
    for B in [*range(1, 40), 127, 128, 129, 255, 256, 257, 1000]:
        for count in range(1, 6):
            ranges = linalg._run_ranges(B, block, count)
            blocks = -(-B // block)
            assert ranges[0][0] == 0 and ranges[-1][1] == B and len(ranges) == min(count, blocks)
            assert all(a[1] == b[0] for a, b in zip(ranges, ranges[1:]))
            assert all(start % block == 0 and stop > start for start, stop in ranges)
            sizes = [-(-(stop - start) // block) for start, stop in ranges]
            assert sum(sizes) == blocks and max(sizes) - min(sizes) <= 1


def test_per_run_noise_over_threads_is_read_at_each_runs_own_rows(monkeypatch):
    """Q and R per run and mode (period B r over the flattened stack) and one Q per mode (period r): the rows a
    thread's runs read are their own, whatever range the thread starts at (7 blocks of 7 runs over 1, 2 and 3
    threads give the same bits)."""
    B, r, n = 45, 3, 4
    rng = np.random.default_rng(5)
    up = RULES["CKF"].unit_points(n)
    args = dict(mu=rng.dirichlet(np.ones(r), size=B), transition=TRANSITION,
                means=X0 + rng.normal(0.0, 20.0, size=(B, r, n)), covs=np.tile(P0, (B, r, 1, 1)), xi=up.xi,
                wm=up.wm, wc=up.wc, F=np.stack([m_.F for m_ in _modes()]),
                Q=np.stack([m_.Q for m_ in _modes()])[None] * rng.uniform(0.5, 4.0, size=(B, r, 1, 1)),
                z=np.column_stack([rng.uniform(2e4, 3e4, B), rng.uniform(0.5, 0.8, B)]),
                measure=(linalg.MEASURE_RANGE_BEARING, np.zeros((1, 1)), (0, 2), np.zeros(2)),
                angular=np.array([False, True]),
                R=np.diag([100.0, 1e-4])[None, None] * rng.uniform(0.5, 4.0, size=(B, r, 1, 1)), with_cov=True,
                log_2pi=np.log(2 * np.pi))
    monkeypatch.setattr(linalg, "FUSED_BLOCK", 7)
    for Q in (args["Q"], np.stack([m_.Q for m_ in _modes()])):   # per run and mode; one per mode
        outs = []
        for count in (1, 2, 3):
            with linalg.use_threads(count):
                outs.append(linalg.imm_sigma_step(**{**args, "Q": Q}))
        for other in outs[1:]:
            for a, b in zip(outs[0], other):
                assert _same(a, b)
        assert np.isfinite(outs[0][5]).all()
    # the per-run operands matter: runs given each other's noise change
    with linalg.use_threads(3):
        swapped = linalg.imm_sigma_step(**{**args, "R": args["R"][::-1].copy()})
    assert not _same(swapped[5], outs[0][5])


@pytest.mark.parametrize("step", ["sigma_step", "sigma_run"])
@pytest.mark.parametrize("where", ["the caller's range", "a helper's range"])
def test_an_error_in_any_range_is_raised_once_the_others_finish(where, step, monkeypatch):
    """A range that raises, in the caller's thread or in a helper thread, fails the step (or the whole run) -- never a
    silent gap -- and only once the other ranges have finished (nothing writes to the outputs after it has
    returned)."""
    import time
    from mmlib.core import _kernels
    kernel, done, failing_start = getattr(_kernels, step), [], 0 if where == "the caller's range" else 4
    if step == "sigma_step":
        _per_step(monkeypatch)

    def failing(*args):
        if args[-3] == failing_start:
            raise RuntimeError("range failed")
        time.sleep(0.2)
        out = kernel(*args)
        done.append(args[-3])
        return out
    monkeypatch.setattr(_kernels, step, failing)
    monkeypatch.setattr(linalg, "FUSED_BLOCK", 4)
    est = THREADED["sigma_step"](MEASUREMENTS["linear"])
    z = _problem(MEASUREMENTS["linear"], 12)
    with linalg.use_threads(3), pytest.raises(RuntimeError, match="range failed"):
        _track(est, z, True)
    assert sorted(done) == sorted({0, 4, 8} - {failing_start})


def test_use_threads_and_environment_reject_bad_values(monkeypatch):
    for bad in (0, -1, True, 1.5, "2", None):
        with pytest.raises(ValueError, match="count"):
            with linalg.use_threads(bad):
                pass
    for bad in ("0", "-2", "two", "1.5", "٣"):
        monkeypatch.setenv("MMLIB_THREADS", bad)
        with pytest.raises(ValueError, match="MMLIB_THREADS"):
            linalg._initial_threads()
    monkeypatch.setenv("MMLIB_THREADS", " 3 ")
    assert linalg._initial_threads() == 3
    with linalg.use_threads(5):
        assert linalg.threads() == 5
        with linalg.use_threads(1):
            assert linalg.threads() == 1
        assert linalg.threads() == 5


def test_tasks_run_their_fused_steps_on_one_thread():
    """A task of the experiment layer (here serially in this process, and a lone task) uses one thread: the workers
    are the parallelism, a task never fans out again, and its CPU time is one thread's."""
    from mmlib.experiment import executors
    with linalg.use_threads(4):
        assert executors.run_tasks(lambda: linalg.threads(), [(), ()], workers=1) == [1, 1]
        assert executors.run_tasks(lambda: linalg.threads(), [()]) == [1]          # a lone task, in this process
        assert linalg.threads() == 4


def test_timed_filters_run_on_one_thread(monkeypatch):
    """Every CPU time the library and the bench measure is one thread's (``time.thread_time``): the fused steps
    of a timed call keep to the timing thread, whatever the caller's setting."""
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from bench import cost_model
    from mmlib.experiment import evaluation
    seen, ranges = [], linalg._run_ranges

    def spy(B, block, count):
        seen.append(len(ranges(B, block, count)))
        return ranges(B, block, count)
    monkeypatch.setattr(linalg, "_run_ranges", spy)
    monkeypatch.setattr(linalg, "FUSED_BLOCK", 2)                  # 6 runs: 3 blocks
    measurement = MEASUREMENTS["range-bearing"]
    imm = IMM(SigmaPointFilter(RULES["UKF"]), _modes(), measurement, TRANSITION)
    z = _problem(measurement, 6)[:, :4]
    init = imm.init(np.tile(X0, (6, 1)), P0)
    with linalg.use_threads(4):
        evaluation.time_algorithms({"IMM": imm}, {"IMM": init}, z, repeats=2, per_repeat=1)
        cost_model.time_per_step(imm, init, z, 2)
        run(imm, init, z)
    # the run outside a timing: 3 blocks on 3 of the caller's 4 threads, in one call for the whole run
    assert seen[-1] == 3 and set(seen[:-1]) == {1} and len(seen) > 1


@pytest.mark.parametrize("N", [1, 15, 16, 17, 45])
def test_lanes_and_unlanes_copy_every_lane_once(N):
    """The tiled transpositions of the fused steps (16 lanes at a time): every lane of a block read from its own row
    (the runs themselves, or mode j of a (runs, modes) stack read with period B r, across tile boundaries), and
    written back to its own row and nowhere else."""
    from mmlib.core import _kernels
    B, r, n, b0 = 60, 3, 4, 7
    a = np.arange(B * r * n * n, dtype=float).reshape(B * r, n, n)
    for j in range(r):
        out = np.full((n, n, N), np.nan)
        _kernels._lanes(a, b0, N, (r, j), out)
        assert np.array_equal(out, np.moveaxis(a[[((b0 + lane) * r + j) % (B * r) for lane in range(N)]], 0, -1))
    own = np.full((n, n, N), np.nan)
    _kernels._lanes(a[:B], b0, N, (1, 0), own)
    back = np.full((B, n, n), -1.0)
    _kernels._unlanes(own, b0, back)
    assert np.array_equal(back[b0:b0 + N], a[b0:b0 + N])
    assert (back[:b0] == -1.0).all() and (back[b0 + N:] == -1.0).all()


# ------------------------------------------------------------------------------------------ whole runs in one call
WHOLE_RUNS = ("sigma_run", "imm_sigma_run", "strong_tracking_run", "adaptive_run")


def _wild(z, run_index: int, step: int):
    """``z`` with one run's first component at one step 1e200 off: its NIS overflows, so every mode's likelihood
    underflows there."""
    z = z.copy()
    z[run_index, step, 0] += 1e200
    return z


def _spy_whole_runs(monkeypatch) -> list:
    """Wrap every whole-run call of :data:`WHOLE_RUNS`: the list records, call by call, whether it returned a run (True)
    or declined (None: False)."""
    calls = []

    def noted(real):
        def spy(*a, **k):
            out = real(*a, **k)
            calls.append(out is not None)
            return out
        return spy
    for name in WHOLE_RUNS:
        monkeypatch.setattr(linalg, name, noted(getattr(linalg, name)))
    return calls


def _whole_and_per_step(est, state, z, monkeypatch, **kw):
    """run() of ``est`` from ``state`` as one compiled call (checked to be taken, and not declined) and step by step
    with the fused steps: the two Tracks."""
    calls = _spy_whole_runs(monkeypatch)
    with linalg.use_fused(True):
        whole = run(est, state, z, **kw)
    assert calls == [True], "the whole run was not one compiled call"
    with monkeypatch.context() as m:
        _per_step(m)
        with linalg.use_fused(True):
            steps = run(est, state, z, **kw)
    assert calls == [True]
    return whole, steps


@pytest.mark.parametrize("kind", ["IMM", "single model"])
@pytest.mark.parametrize("meas", sorted(MEASUREMENTS))
@pytest.mark.parametrize("keep_cov", [True, False])
def test_whole_run_equals_the_run_step_by_step(kind, meas, keep_cov, monkeypatch):
    """Every field of the Track -- estimates, covariances, mode probabilities, NIS, NEES, the step and cause of each
    divergence -- bit for bit, with runs that fail at the first step (a covariance that is not positive definite) and
    runs whose every mode's likelihood underflows at a later step (a wild measurement)."""
    measurement = MEASUREMENTS[meas]
    B = 13
    sched = ManeuverSchedule(_modes(), [(8, 16, 1)], 0, T, K, truncate=True)
    sim = simulate(sched, X0, measurement, MonteCarlo(11, B), range(B))
    z = _wild(_wild(sim.measurements, 4, 9), 7, 17)
    cov = np.tile(P0, (B, 1, 1))
    cov[[2, 10], 0, 0] = -1.0
    if kind == "IMM":
        est = IMM(SigmaPointFilter(RULES["UKF"]), _modes(), measurement, TRANSITION)
        state = est.init(np.tile(X0, (B, 1)), P0)
        state = state._replace(modes=state.modes._replace(cov=np.repeat(cov[:, None], 3, axis=1)))
    else:
        est = SingleModel(SigmaPointFilter(RULES["CKF"]), models.constant_velocity(T, 1.0), measurement)
        state = est.init(np.tile(X0, (B, 1)), P0)._replace(cov=cov)
    whole, steps = _whole_and_per_step(est, state, z, monkeypatch, keep_cov=keep_cov, consistency=True,
                                       truth=sim.truth)
    _assert_same_track(whole, steps)
    assert _same(whole.nis_dof, steps.nis_dof)
    assert {2, 10} <= set(np.flatnonzero(whole.diverged))
    if kind == "IMM":
        assert whole.diverged_step[4] == 9 and whole.divergence_cause[4] == estimation.Failure.LIKELIHOOD
        assert whole.diverged_step[7] == 17
    assert np.isnan(whole.nis[2]).all() and np.isfinite(whole.nis[0]).all() and np.isfinite(whole.nees[0]).all()


@pytest.mark.parametrize("batch", [1, 2, 3, 64])
@pytest.mark.parametrize("block", [2, 128])
def test_whole_run_changes_no_bit_with_the_batch_or_the_block(batch, block, monkeypatch):
    """A run's numbers from a whole-run call are those of its batch of 64, whatever the batch (1, 2, 3, 64) and the
    block (2: several blocks of a run; 128: one), as the step by step run gives them."""
    measurement = MEASUREMENTS["range-bearing off-centre"]
    imm = IMM(SigmaPointFilter(RULES["CKF"]), _modes(), measurement, TRANSITION)
    z = _problem(measurement, 64)
    reference = _track(imm, z, True)
    monkeypatch.setattr(linalg, "FUSED_BLOCK", block)
    part, steps = _whole_and_per_step(imm, imm.init(np.tile(X0, (batch, 1)), P0), z[:batch], monkeypatch)
    _assert_same_track(part, steps)
    for field in ("mean", "cov", "mode_probabilities"):
        assert _same(getattr(reference, field)[:batch], getattr(part, field)), field


@pytest.mark.parametrize("name", ["UKF", "IMMUKF"])
def test_whole_run_over_gnss_epochs_equals_the_run_step_by_step(name, monkeypatch):
    """Tseng et al. 2011's filters over the epochs up to 40 past the first change of the satellites in view (each epoch
    its own satellites, the measurement dimension changing):
    the epochs are packed into one call (:func:`mmlib.core.linalg.packed_steps`), the same bits as epoch by epoch."""
    paper = REGISTRY["tseng2011"]
    make_batch, estimators, per_step = paper.batch(paper.headline_setup(), MonteCarlo(paper.root_seed, 5))
    truth, z, init = make_batch(range(5))
    dims = [zk.shape[1] for zk in z]
    K = next(k for k in range(1, len(dims)) if dims[k] != dims[k - 1]) + 40     # 40 epochs past the first change
    whole, steps = _whole_and_per_step(estimators[name], init[name], z[:K], monkeypatch,
                                       measurement_models=per_step[:K], consistency=True, truth=truth[:, :K + 1])
    _assert_same_track(whole, steps)
    assert _same(whole.nis_dof, steps.nis_dof) and np.isfinite(whole.mean).all()


def test_whole_run_raises_at_the_same_run_and_step(monkeypatch):
    """``on_divergence='raise'`` names the run and the step the step-by-step run would stop at (the first step at
    which a run fails, the lowest run failing there)."""
    measurement = MEASUREMENTS["range-bearing"]
    imm = IMM(SigmaPointFilter(RULES["UKF"]), _modes(), measurement, TRANSITION)
    z = _wild(_wild(_problem(measurement, 9), 6, 5), 3, 5)
    state = imm.init(np.tile(X0, (9, 1)), P0)
    messages = _divergence_messages(imm, state, z, monkeypatch)
    assert messages[0] == messages[1] and "run 3 diverged at step 5" in messages[0]


def _divergence_messages(est, state, z, monkeypatch) -> list:
    """The messages of the FilterDivergence that ``run(..., on_divergence="raise")`` raises as a whole run and step by
    step (it must raise both ways)."""
    messages = []
    for whole in (True, False):
        with monkeypatch.context() as m, np.errstate(all="ignore"):
            if not whole:
                _per_step(m)
            with pytest.raises(estimation.FilterDivergence) as err:
                run(est, state, z, on_divergence="raise")
        messages.append(str(err.value))
    return messages


class _OwnSingleModel(SingleModel):
    """A subclass (it may override a step): never run as a whole-run call."""


@pytest.mark.parametrize("why", ["fusion off", "numpy kernels", "known mode sequence", "layer", "subclass",
                                 "mixed measurement kinds", "float32 V"])
def test_whole_run_is_not_taken_where_it_does_not_apply(why, monkeypatch):
    """Where a run's steps are not all fused steps, or one call cannot take its measurement steps, run() goes step by
    step (and gives the Track it always gave)."""
    calls = []
    for name in WHOLE_RUNS:
        real = getattr(linalg, name)
        monkeypatch.setattr(linalg, name, lambda *a, _real=real, **k: calls.append(1) or _real(*a, **k))
    measurement = MEASUREMENTS["linear"]
    cv = models.constant_velocity(T, 1.0)
    est = SingleModel(SigmaPointFilter(RULES["UKF"]), cv, measurement)
    z, kw = _problem(measurement, 4), {}
    if why == "known mode sequence":
        est = estimation.KnownModeSequence(SigmaPointFilter(RULES["UKF"]), _modes(), np.zeros(K, dtype=int),
                                           measurement)
    elif why == "layer":
        est = SingleModel(StrongTracking(SigmaPointFilter(ST_RULES["CKF"]), form="jacobian"), cv, measurement)
    elif why == "subclass":
        est = _OwnSingleModel(SigmaPointFilter(RULES["UKF"]), cv, measurement)
    elif why == "mixed measurement kinds":
        est = SingleModel(SigmaPointFilter(RULES["UKF"]), cv, None)
        bearing = MEASUREMENTS["range-bearing"]
        zb = _problem(bearing, 4)
        kw = dict(measurement_models=[measurement if k % 2 else bearing for k in range(K)])
        z = [z[:, k] if k % 2 else zb[:, k] for k in range(K)]
    state = est.init(np.tile(X0, (4, 1)), P0)
    if why == "float32 V":            # the composed update computes Eq. 17 in float32 at the first step
        est = _strong_tracking("CKF", measurement)
        state = est.init(np.tile(X0, (4, 1)), P0, V=np.array([[100.3, 7.1], [7.1, 0.37]], dtype=np.float32))
    with linalg.use_fused(why != "fusion off"), linalg.use_kernel("numpy" if why == "numpy kernels" else "numba"):
        track = run(est, state, z, **kw)
    assert not calls and np.isfinite(track.mean).all()


def test_whole_run_truth_of_another_dimension_is_named_as_step_by_step():
    measurement = MEASUREMENTS["linear"]
    est = SingleModel(SigmaPointFilter(RULES["UKF"]), models.constant_velocity(T, 1.0), measurement)
    z = _problem(measurement, 3)
    with pytest.raises(ValueError, match="^truth: state dimension 6"):
        run(est, est.init(np.tile(X0, (3, 1)), P0), z, consistency=True, truth=np.zeros((3, K + 1, 6)))


def test_packed_steps_keep_each_steps_rows_and_refuse_what_one_call_cannot_take():
    """Step k's measurements, matrix, R and angular flags at rows zoff[k]..zoff[k+1]-1; None for steps of different
    kinds or sensors; the run kernels refuse offsets that do not describe the packed rows (they read without bounds
    checks)."""
    rng = np.random.default_rng(2)
    B, n = 3, 8
    sats = [rng.normal(size=(m, 3)) * 2e7 for m in (5, 7, 6)]
    zs = [rng.normal(size=(B, s.shape[0])) for s in sats]
    measures = [(linalg.MEASURE_PSEUDORANGES, s, (0, 2, 4, 6), np.zeros(2)) for s in sats]
    Rs = [np.eye(s.shape[0]) * (k + 1.0) for k, s in enumerate(sats)]
    packed = linalg.packed_steps(zs, measures, [np.zeros(s.shape[0], bool) for s in sats], Rs, n)
    z, zoff, kind, A, idx, sensor, angular, R = packed
    assert zoff.tolist() == [0, 5, 12, 18] and kind == linalg.MEASURE_PSEUDORANGES and idx.tolist() == [0, 2, 4, 6]
    for k in range(3):
        lo, hi = zoff[k], zoff[k + 1]
        assert _same(z[:, lo:hi], zs[k]) and _same(A[lo:hi], sats[k]) and _same(R[lo:hi, :hi - lo], Rs[k])
    assert R.shape == (18, 7) and angular.shape == (18,) and not angular.any()
    other = (linalg.MEASURE_PSEUDORANGES, sats[1], (0, 2, 4, 7), np.zeros(2))
    assert linalg.packed_steps(zs, [measures[0], other, measures[2]], [None] * 3, Rs, n) is None
    assert linalg.packed_steps(zs, measures, [None] * 3, [Rs[0], Rs[1][None], Rs[2]], n) is None
    up = RULES["UKF"].unit_points(n)
    bad = (z, np.array([0, 5, 13, 18], dtype=np.int64)) + packed[2:]
    for wrong in (bad, (z, zoff[:1]) + packed[2:], (z, zoff.astype(np.int32)) + packed[2:]):
        with pytest.raises(ValueError, match="^packed: "):
            linalg.sigma_run(np.zeros((B, n)), np.tile(np.eye(n), (B, 1, 1)), up.xi, up.wm, up.wc, np.eye(n),
                             np.eye(n), wrong, 1.8, keep_cov=False, nis=False)


@pytest.mark.parametrize("rule", sorted(ST_RULES))
@pytest.mark.parametrize("meas", sorted(MEASUREMENTS))
@pytest.mark.parametrize("q", [0.01, 30.0])
def test_strong_tracking_whole_run_equals_the_run_step_by_step(rule, meas, q, monkeypatch):
    """The strong-tracking layer's whole run (:meth:`StrongTracking.whole_run`): every Track field the bits of the run
    step by step with its fused steps, through steps whose fading factor exceeds 1 and steps where it is 1 (q 0.01),
    with a run failing at the first step and one whose measurement is wild at a later step, a given float64 V and
    none."""
    measurement = MEASUREMENTS[meas]
    est = _strong_tracking(rule, measurement, q)
    B = 9
    sched = ManeuverSchedule(_modes(), [(8, 16, 1)], 0, T, K, truncate=True)
    sim = simulate(sched, X0, measurement, MonteCarlo(5, B), range(B))
    z = _wild(sim.measurements, 6, 12)
    state = est.init(np.tile(X0, (B, 1)), P0)
    cov = state.cov.copy()
    cov[3, 0, 0] = -1.0
    state = state._replace(cov=cov)
    whole, steps = _whole_and_per_step(est, state, z, monkeypatch, consistency=True, truth=sim.truth)
    _assert_same_track(whole, steps)
    assert whole.diverged[3] and not whole.diverged[0]
    if q == 0.01:
        lam = _fading_factors(est, est.init(np.tile(X0, (B, 1)), P0), np.swapaxes(sim.measurements, 0, 1))
        assert (lam > 1.0).any() and (lam == 1.0).any()          # both branches of Eq. 28 are taken
    V = np.tile(np.diag([100.0, 0.5]), (B, 1, 1)) + 0.1
    given = est.init(np.tile(X0, (B, 1)), P0, V=V)
    whole, steps = _whole_and_per_step(est, given, z, monkeypatch, keep_cov=False)
    _assert_same_track(whole, steps)


def test_strong_tracking_whole_run_restarts_V_where_the_satellites_change(monkeypatch):
    """Pseudoranges whose satellite set changes size (V restarts, Eq. 17) for four epochs, a run whose covariance fails
    at the first step: one call for the whole run, the bits of the run epoch by epoch."""
    est, state, zs, models_k = _gnss_strong_tracking(30)
    whole, steps = _whole_and_per_step(est, state, zs, monkeypatch, measurement_models=models_k, consistency=True)
    _assert_same_track(whole, steps)
    assert whole.diverged[1] and not whole.diverged[[0, 2, 3, 4]].any()
    assert sorted(set(whole.nis_dof.tolist())) == [zs[0].shape[1] - 1, zs[0].shape[1]]


# ------------------------------------------------------------------- the innovation-adaptive layer's whole run
#: the layer's (zeta, include_current, inflate_only): NAUKF as printed (1, 1, 0), the IAE-AUKF of Mohamed & Schwarz
#: (0, 0, 0), their inflate-only readings (1, 1, 1), (0, 0, 1), and the four other combinations
ADAPTIVE_FLAGS = list(itertools.product([False, True], repeat=3))
ADAPTIVE_IDS = [f"zeta{z:d}-current{c:d}-inflate{i:d}" for z, c, i in ADAPTIVE_FLAGS]


def _adaptive(flags, measurement, window: int = 3, psi: float = 1.0, layer=None, dynamics=None) -> SingleModel:
    """A single model of the innovation-adaptive layer ``layer`` (default :class:`InnovationAdaptive`) over the UKF,
    ``flags`` = (zeta, include_current, inflate_only), on a CV model (q = 1) or ``dynamics``."""
    zeta, include_current, inflate_only = flags
    layer = InnovationAdaptive if layer is None else layer
    return SingleModel(layer(SigmaPointFilter(RULES["UKF"]), window=window, psi=psi, zeta=zeta,
                             include_current=include_current, inflate_only=inflate_only),
                       models.constant_velocity(T, 1.0) if dynamics is None else dynamics, measurement)


def _adaptive_branches(est, state, zs, monkeypatch, models_k=None) -> dict:
    """Step ``est`` from ``state`` through ``zs`` (a sequence of (B, m_k)), as run() steps it, recording the branches of
    the layer's update: ``windows`` the measurement dimensions at which a window was full (C computed),
    ``mixed`` how many C - S had eigenvalues of both signs (inflate-only: the PSD part neither 0 nor C - S),
    ``inflated`` how many (step, run) had a zeta above 1 (Eq. 34), ``huge`` how many a zeta of 1e300 or more
    (Eq. 35 infinite, read as the largest float)."""
    seen = {"windows": set(), "mixed": 0, "inflated": 0, "huge": 0}
    gram, psd_part = linalg.gram, linalg.psd_part

    def counting_gram(u):
        seen["windows"].add(u.shape[-1])
        return gram(u)

    def counting_psd_part(d):
        with np.errstate(invalid="ignore"):
            w = np.linalg.eigvalsh(np.where(np.isfinite(d), d, 0.0))
        seen["mixed"] += int(((w > 0).any(axis=-1) & (w < 0).any(axis=-1)).sum())
        return psd_part(d)
    with monkeypatch.context() as m, np.errstate(all="ignore"):
        m.setattr(linalg, "gram", counting_gram)
        m.setattr(linalg, "psd_part", counting_psd_part)
        for k, z in enumerate(zs):
            state, _ = est.step(state, z, **({} if models_k is None else {"measurement": models_k[k]}))
            if state.zeta is not None:
                seen["inflated"] += int((state.zeta > 1.0).sum())
                seen["huge"] += int((state.zeta >= 1e300).sum())
    return seen


#: measurement, window, psi (Eq. 32): a window of 3 (reached at the third or fourth step, the as-printed readings
#: diverging soon after) with Zhou's psi, and one of 5 over range and bearing (some as-printed runs last, through
#: inflations of Eqs. 33-35) with a psi of 2
ADAPTIVE_CASES = {"linear, window 3": ("linear", 3, 1.0), "range-bearing, window 5": ("range-bearing", 5, 2.0)}


@pytest.mark.parametrize("flags", ADAPTIVE_FLAGS, ids=ADAPTIVE_IDS)
@pytest.mark.parametrize("case", sorted(ADAPTIVE_CASES))
def test_adaptive_whole_run_equals_the_run_step_by_step(case, flags, monkeypatch):
    """The innovation-adaptive layer's whole run (:meth:`InnovationAdaptive.whole_run`, one call of
    :func:`mmlib.core.linalg.adaptive_run`) in each of its 8 configurations: every Track field -- estimates,
    covariances, NIS, NEES, the step and cause of each divergence -- the bits of the run step by step, through full
    windows, inflated priors (zeta > 1) and, inflate-only, PSD parts of C - S with eigenvalues of both signs.  As
    printed (not inflate-only) with a run failing at the first step (a covariance that is not positive definite), a
    run whose measurement is wild at step 15 (Eq. 35 infinite: zeta the largest float) and the divergences of the
    printed reading (with the current innovation in the window, run 12 lasts until then)."""
    meas, window, psi = ADAPTIVE_CASES[case]
    measurement = MEASUREMENTS[meas]
    zeta, _, inflate_only = flags
    est = _adaptive(flags, measurement, window, psi)
    B = 13
    sched = ManeuverSchedule(_modes(), [(8, 16, 1)], 0, T, K, truncate=True)
    sim = simulate(sched, X0, measurement, MonteCarlo(11, B), range(B))
    z, state = sim.measurements, est.init(np.tile(X0, (B, 1)), P0)
    if not inflate_only:                 # (inflate-only, a run that is not finite is run step by step: below)
        z = _wild(z, 12, 15)
        cov = state.cov.copy()
        cov[2, 0, 0] = -1.0
        state = state._replace(cov=cov)
    with np.errstate(all="ignore"):
        whole, steps = _whole_and_per_step(est, state, z, monkeypatch, consistency=True, truth=sim.truth)
    _assert_same_track(whole, steps)
    assert _same(whole.nis_dof, steps.nis_dof)
    branches = _adaptive_branches(est, state, np.swapaxes(z, 0, 1), monkeypatch)
    assert branches["windows"] == {2}
    if inflate_only:
        assert not whole.diverged.any() and branches["mixed"] > 0
    else:
        assert whole.diverged_step[2] == 0 and whole.divergence_cause[2] == estimation.Failure.COVARIANCE
        assert whole.diverged.sum() > 1 and not whole.diverged.all() or case == "linear, window 3"
        assert np.isnan(whole.nis[2]).all() and np.isnan(whole.nees[2]).all()
    if zeta:
        assert branches["inflated"] > 0
    if zeta and flags[1] and not inflate_only and case == "range-bearing, window 5":     # the wild innovation in C
        assert branches["huge"] > 0 and whole.diverged_step[12] == 15


@pytest.mark.parametrize("flags", ADAPTIVE_FLAGS, ids=ADAPTIVE_IDS)
def test_adaptive_whole_run_over_gnss_epochs_restarts_the_window(flags, monkeypatch):
    """Pseudoranges whose satellite set loses one satellite at epochs 1-2 (the window restarts twice before it is
    full) and 10-14 (restarts, fills at 6 components, restarts at 7): the layer over Tseng et al. 2011's GNSS model
    (8 states: the traces of Eq. 35 are numpy's pairwise sums), a window of 3 and a psi of 1.5, one call for the whole
    run, every Track field the bits of the run epoch by epoch.  As printed with run 1 not positive definite from the
    start (and the printed reading diverging where the window of 3 innovations, of rank 3 < 7, replaces S)."""
    from mmlib.arena import recipes, study
    s = study.scenario("tseng2011")
    est = SingleModel(InnovationAdaptive(recipes.ukf(s), window=3, psi=1.5, zeta=flags[0], include_current=flags[1],
                                         inflate_only=flags[2]), s.single, s.measurement, name="adaptive")
    est, state, zs, models_k, truth = _gnss_epochs(est, 24, {1, 2, 10, 11, 12, 13, 14})
    if not flags[2]:
        cov = state.cov.copy()
        cov[1, 6, 6] = -1.0
        state = state._replace(cov=cov)
    with np.errstate(all="ignore"):
        whole, steps = _whole_and_per_step(est, state, zs, monkeypatch, measurement_models=models_k,
                                           consistency=True, truth=truth)
    _assert_same_track(whole, steps)
    assert _same(whole.nis_dof, steps.nis_dof) and sorted(set(whole.nis_dof.tolist())) == [6, 7]
    branches = _adaptive_branches(est, state, zs, monkeypatch, models_k)
    assert branches["windows"] == {6, 7}
    if flags[2]:
        assert not whole.diverged.any() and np.isfinite(whole.nees).all() and branches["mixed"] > 0
    else:
        assert whole.diverged_step[1] == 0 and whole.diverged.all()
    if flags[0] and flags[2]:
        assert branches["inflated"] > 0


@pytest.mark.parametrize("flags", [(True, True, False), (False, False, True)], ids=["NAUKF", "AUKF[inflate-only]"])
@pytest.mark.parametrize("batch", [1, 2, 3, 64])
@pytest.mark.parametrize("block", [2, 128])
def test_adaptive_whole_run_changes_no_bit_with_the_batch_or_the_block(flags, batch, block, monkeypatch):
    """A run's numbers from the adaptive whole run are those of its batch of 64, whatever the batch (1, 2, 3, 64) and
    the block (2: several blocks, each with its own window; 128: one), as the run step by step gives them."""
    measurement = MEASUREMENTS["range-bearing off-centre"]
    est = _adaptive(flags, measurement, 5)
    z = _problem(measurement, 64)
    with np.errstate(all="ignore"):
        reference, _ = _whole_and_per_step(est, est.init(np.tile(X0, (64, 1)), P0), z, monkeypatch)
        monkeypatch.setattr(linalg, "FUSED_BLOCK", block)
        part, steps = _whole_and_per_step(est, est.init(np.tile(X0, (batch, 1)), P0), z[:batch], monkeypatch)
    _assert_same_track(part, steps)
    for field in ("mean", "cov", "diverged_step", "divergence_cause"):
        assert _same(getattr(reference, field)[:batch], getattr(part, field)), field
    assert reference.diverged.any() != flags[2]          # as printed some runs diverge; inflate-only none


#: the arena's scenarios of a paper by their measurement: Zhou's radar, Tseng's GNSS (named once each)
ARENA_MEASURED_BY = {"radar": "zhou2017"}
ARENA_MEASURED_BY["gnss"] = "tseng2011"


@pytest.mark.parametrize("name", ["NAUKF", "AUKF", "NAUKF[inflate-only]", "AUKF[inflate-only]"])
@pytest.mark.parametrize("measured_by", sorted(ARENA_MEASURED_BY))
def test_arena_adaptive_filters_run_whole_in_one_call(name, measured_by, monkeypatch):
    """The arena's single-model adaptive filters (window 10) on Zhou's radar and Tseng's GNSS scenarios: run() is one
    call of :func:`mmlib.core.linalg.adaptive_run` that does not decline, and never a step of the layer (its predict
    and update replaced by stubs that fail), with the bits of the run step by step."""
    from mmlib.arena import recipes, study
    from mmlib.core.filters import FilterLayer
    from mmlib.experiment import evaluation
    s = study.scenario(ARENA_MEASURED_BY[measured_by])
    est = recipes.build(name, s)
    B, K_ = 6, 60
    mc = MonteCarlo(s.root_seed, B)
    make_batch = evaluation.with_initial_states(s.simulator(mc), {name: est},
                                                lambda e, start, runs: recipes.initial_state(e, s, start, runs, mc))
    truth, z, init = make_batch(range(B))
    kw = dict(consistency=True, truth=truth[:, :K_ + 1])
    if s.measurement_models is not None:
        z, kw["measurement_models"] = z[:K_], s.measurement_models[:K_]
    else:
        z = z[:, :K_]
    calls = _spy_whole_runs(monkeypatch)

    def no_step(*a, **k):
        raise AssertionError("a step of the layer ran in the whole run")
    with monkeypatch.context() as m, np.errstate(all="ignore"):
        m.setattr(InnovationAdaptive, "update", no_step)
        m.setattr(FilterLayer, "predict", no_step)
        whole = run(est, init[name], z, **kw)
    assert calls == [True]
    _per_step(monkeypatch)
    with np.errstate(all="ignore"):
        steps = run(est, init[name], z, **kw)
    _assert_same_track(whole, steps)
    assert calls == [True]
    assert np.isfinite(whole.mean).all() or "inflate-only" not in name


def _outcome(est, state, z, whole: bool, monkeypatch, **kw):
    """run()'s Track, or the type and message of what it raised; ``whole=False``: step by step."""
    with monkeypatch.context() as m, np.errstate(all="ignore"):
        if not whole:
            _per_step(m)
        try:
            return run(est, state, z, **kw)
        except Exception as err:            # noqa: BLE001 -- the outcome compared is any exception
            return type(err), str(err)


class _OwnAdaptive(InnovationAdaptive):
    """A subclass (it may override a step): never run as a whole-run call."""


@pytest.mark.parametrize("why", ["one-component steps", "layer subclass", "state with innovations", "numpy kernels",
                                 "fusion off"])
def test_adaptive_whole_run_declines_where_its_steps_would_not_be_the_layers(why, monkeypatch):
    """Where the compiled run would not compute the layer's steps, run() goes step by step and gives what it always
    gave: steps of one component (the layer's C is numpy's dot there): :func:`mmlib.core.linalg.adaptive_run` is
    called and returns None; a subclass of the layer, a state that already holds innovations (not a run's start), the
    numpy kernels, fusion off: it is not called.  NAUKF inflate-only."""
    B = 5
    measurement = MEASUREMENTS["linear"]
    est = _adaptive((True, True, True), measurement, layer=_OwnAdaptive if why == "layer subclass" else None)
    sched = ManeuverSchedule(_modes(), [(8, 16, 1)], 0, T, K, truncate=True)
    z, kw = simulate(sched, X0, measurement, MonteCarlo(11, B), range(B)).measurements, {}
    state = est.init(np.tile(X0, (B, 1)), P0)
    declines = why == "one-component steps"
    if why == "one-component steps":        # the x position alone at steps 7-13: a full window of one component
        x_only = models.LinearMeasurement([[1.0, 0, 0, 0]], [[100.0]])
        kw = dict(measurement_models=[x_only if 7 <= k < 14 else measurement for k in range(K)])
        z = [z[:, k, :1] if 7 <= k < 14 else z[:, k] for k in range(K)]
    elif why == "state with innovations":
        state, _ = est.step(state, z[:, 0])
        z = z[:, 1:]
    calls = _spy_whole_runs(monkeypatch)
    with linalg.use_fused(why != "fusion off"), linalg.use_kernel("numpy" if why == "numpy kernels" else "numba"):
        whole = _outcome(est, state, z, True, monkeypatch, **kw)
        assert calls == ([False] if declines else [])
        steps = _outcome(est, state, z, False, monkeypatch, **kw)
    assert isinstance(whole, estimation.Track) and isinstance(steps, estimation.Track)
    _assert_same_track(whole, steps)
    assert np.isfinite(whole.mean).all()


@pytest.mark.parametrize("why", ["a NaN covariance", "a wild measurement", "a NaN covariance over pseudoranges"])
def test_inflate_only_with_a_failed_run_runs_whole_and_reports_it(why, monkeypatch):
    """A run that fails (a NaN covariance from the start, or a wild measurement that makes its C - S overflow) under
    the inflate-only reading: its innovation covariance is NaN from then on (:func:`mmlib.core.linalg.psd_part`), so
    its update fails and it is reported at its step, the other runs untouched, the whole run taken and equal to the
    run step by step (before, numpy's eigh raised for the whole batch, or returned NaN for 2 x 2 matrices)."""
    from mmlib.arena import recipes, study
    B = 5
    measurement = MEASUREMENTS["linear"]
    est = _adaptive((True, True, True), measurement)
    sched = ManeuverSchedule(_modes(), [(8, 16, 1)], 0, T, K, truncate=True)
    z, kw = simulate(sched, X0, measurement, MonteCarlo(11, B), range(B)).measurements, {}
    state = est.init(np.tile(X0, (B, 1)), P0)
    bad = 3 if why != "a wild measurement" else 1
    if why == "a NaN covariance":
        cov = state.cov.copy()
        cov[3] = np.nan
        state = state._replace(cov=cov)
    elif why == "a wild measurement":
        z = _wild(z, 1, 6)
    else:
        s = study.scenario("tseng2011")
        est, state, z, models_k, _ = _gnss_epochs(recipes.build("NAUKF[inflate-only]", s), 20, ())
        kw = dict(measurement_models=models_k)
        cov = state.cov.copy()
        cov[3] = np.nan
        state = state._replace(cov=cov)
    calls = _spy_whole_runs(monkeypatch)
    whole = _outcome(est, state, z, True, monkeypatch, **kw)
    assert calls == [True]
    steps = _outcome(est, state, z, False, monkeypatch, **kw)
    assert isinstance(whole, estimation.Track) and isinstance(steps, estimation.Track)
    _assert_same_track(whole, steps)
    good = [b for b in range(whole.mean.shape[0]) if b != bad]
    assert whole.diverged_step[bad] >= 0 and (whole.diverged_step[good] < 0).all()
    assert np.isfinite(whole.mean[good]).all()


def test_adaptive_whole_run_raises_at_the_same_run_and_step(monkeypatch):
    """``on_divergence='raise'`` over the as-printed NAUKF names the run and the step the step-by-step run stops at."""
    measurement = MEASUREMENTS["range-bearing"]
    est = _adaptive((True, True, False), measurement, 5)
    z = _problem(measurement, 9)
    state = est.init(np.tile(X0, (9, 1)), P0)
    messages = _divergence_messages(est, state, z, monkeypatch)
    assert messages[0] == messages[1] and "diverged at step" in messages[0]


def test_adaptive_whole_run_reads_an_infinite_zeta_as_numpy_does(monkeypatch):
    """Eq. 35 overflowing: NAUKF inflate-only with a sensor of 1 cm on a quiet CV model (tr(P - Q) about 1e-3) and, at
    the last step, one measurement 5e153 m off, so that C stays finite (about 1e307) while tr(C - R) / tr(P - Q) is
    +inf: the layer reads it as the largest float (``np.nan_to_num``) and inflates the prior to about 1e304, which the
    Track shows; the whole run's bits are the run's step by step.  (At the last step: the run fails there, and a run
    that is not finite at a later step would send the whole batch step by step.)"""
    measurement = models.LinearMeasurement([[1.0, 0, 0, 0], [0, 0, 1.0, 0]], np.diag([1e-4, 1e-4]))
    dynamics = models.constant_velocity(T, 1e-4)
    est = _adaptive((True, True, True), measurement, dynamics=dynamics)
    B, K_ = 4, 12
    sim = simulate(ManeuverSchedule([dynamics], [], 0, T, K_, truncate=True), X0, measurement, MonteCarlo(5, B),
                   range(B))
    z = sim.measurements.copy()
    z[1, K_ - 1, 0] += 5e153
    state = est.init(np.tile(X0, (B, 1)), np.eye(4) * 1e-2)
    with np.errstate(all="ignore"):
        whole, steps = _whole_and_per_step(est, state, z, monkeypatch, consistency=True, truth=sim.truth)
    _assert_same_track(whole, steps)
    assert _adaptive_branches(est, state, np.swapaxes(z, 0, 1), monkeypatch)["huge"] == 1
    assert np.isfinite(whole.cov[1, -1]).all() and whole.cov[1, -1].max() > 1e300
    assert not whole.diverged[[0, 2, 3]].any()
