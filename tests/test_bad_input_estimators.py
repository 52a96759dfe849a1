"""Estimators, their states and the layers: every bad input is a ValueError naming the argument the caller
wrote (never an AttributeError, an IndexError, a numpy broadcasting error or a silently wrong result)."""
import importlib
import numpy as np
import pytest

import mmlib as m
from mmlib.core import models
from mmlib.core.layers.adaptive import InnovationAdaptive
from mmlib.core.layers.bootstrap import ObservationBootstrap
from mmlib.core.layers.strong_tracking import StrongTracking
from conftest import raises_naming

B, K = 3, 6
CV = models.constant_velocity(1.0, 2.0)
POS = models.position_measurement([25.0, 16.0])
UKF = m.SigmaPointFilter(m.Unscented())
X0 = np.tile([100.0, 10.0, -50.0, 5.0], (B, 1))
P0 = np.diag([100.0, 25.0, 100.0, 25.0])
Z = np.random.default_rng(1).standard_normal((B, K, 2)) * 5 + [100.0, -50.0]
TR = [[0.9, 0.1], [0.1, 0.9]]


def _imm():
    return m.IMM(UKF, [CV, models.constant_velocity(1.0, 20.0)], POS, TR)


CASES = {
    "filter is a string": (lambda: m.SingleModel("ukf", CV, POS), "filter"),
    "dynamics is a string": (lambda: m.SingleModel(UKF, "cv", POS), "dynamics"),
    "measurement is a string": (lambda: m.SingleModel(UKF, CV, "radar"), "measurement"),
    "measurement is an array": (lambda: m.SingleModel(UKF, CV, np.eye(2)), "measurement"),
    "IMM dynamics not a sequence": (lambda: m.IMM(UKF, CV, POS, [[1.0]]), "dynamics"),
    "IMM one mode is a string": (lambda: m.IMM(UKF, [CV, "ct"], POS, TR), r"dynamics\[1\]"),
    "IMM filter is a string": (lambda: m.IMM("ukf", [CV, CV], POS, TR), "filter"),
    "IMM mixing not callable": (lambda: m.IMM(UKF, [CV, CV], POS, TR, mixing="moment"), "mixing"),
    "known modes out of range": (lambda: m.estimation.KnownModeSequence(UKF, [CV], np.array([0, 1]), POS), "modes"),
    "state dimension != model's": (lambda: m.SingleModel(UKF, CV, POS).init(X0[:, :3], np.eye(3)), "mean"),
    "IMM mean dimension != model's": (lambda: _imm().init(X0[:, :3], np.eye(3)), "mean"),
    "mode_probabilities wrong length": (lambda: _imm().init(X0, P0, mode_probabilities=[0.2, 0.3, 0.5]),
                                        "mode_probabilities"),
    "mode_probabilities not summing to 1": (lambda: _imm().init(X0, P0, mode_probabilities=[0.2, 0.3]),
                                            "mode_probabilities"),
    "step with an array as state": (lambda: m.SingleModel(UKF, CV, POS).step(X0, Z[:, 0]), "state"),
    "IMM step with a Gaussian state": (lambda: _imm().step(UKF.init(X0, P0), Z[:, 0]), "state"),
    "step with fewer runs of z": (lambda: m.SingleModel(UKF, CV, POS).step(UKF.init(X0, P0), Z[:2, 0]), "z"),
    "IMM step with fewer runs of z": (lambda: _imm().step(_imm().init(X0, P0), Z[:2, 0]), "z"),
    "step with a state of another dimension": (
        lambda: m.SingleModel(UKF, CV, POS).step(UKF.init(np.zeros((B, 6)), np.eye(6)), Z[:, 0]), "state"),
    "run with fewer runs of measurements": (
        lambda: m.run(m.SingleModel(UKF, CV, POS), UKF.init(X0, P0), Z[:2]), "measurements"),
    "run with more runs of measurements": (
        lambda: m.run(_imm(), _imm().init(X0, P0), np.concatenate([Z, Z])), "measurements"),
    "run with K = 0": (lambda: m.run(m.SingleModel(UKF, CV, POS), UKF.init(X0, P0), Z[:, :0]), "measurements"),
    "run with measurement dimension != model's": (
        lambda: m.run(m.SingleModel(UKF, CV, POS), UKF.init(X0, P0), np.zeros((B, K, 3))), "measurements"),
    "run with complex measurements": (
        lambda: m.run(m.SingleModel(UKF, CV, POS), UKF.init(X0, P0), Z + 1j), "measurements"),
    "run with an array as state": (lambda: m.run(m.SingleModel(UKF, CV, POS), X0, Z), "state"),
    "run with a string as estimator": (lambda: m.run("IMM", UKF.init(X0, P0), Z), "estimator"),
    "run with a string as a per-step model": (
        lambda: m.run(m.SingleModel(UKF, CV, None), UKF.init(X0, P0), list(np.swapaxes(Z, 0, 1)),
                      measurement_models=["pos"] * K), r"measurement_models\[0\]"),
    "strong tracking beta NaN": (lambda: StrongTracking(UKF, beta=float("nan")), "beta"),
    "strong tracking beta < 1": (lambda: StrongTracking(UKF, beta=0.5), "beta"),
    "strong tracking rho 0": (lambda: StrongTracking(UKF, rho=0.0), "rho"),
    "strong tracking base string": (lambda: StrongTracking("ukf"), "base"),
    "strong tracking form": (lambda: StrongTracking(UKF, form="exact"), "form"),
    "adaptive window 1": (lambda: InnovationAdaptive(UKF, window=1), "window"),
    "adaptive window float": (lambda: InnovationAdaptive(UKF, window=5.0), "window"),
    "adaptive psi inf": (lambda: InnovationAdaptive(UKF, psi=float("inf")), "psi"),
    "bootstrap n_boot negative": (lambda: ObservationBootstrap(UKF, n_boot=-1), "n_boot"),
    "bootstrap variance_factor NaN": (lambda: ObservationBootstrap(UKF, variance_factor=float("nan")),
                                      "variance_factor"),
    "bootstrap noise of the wrong N": (
        lambda: ObservationBootstrap(UKF, n_boot=2).init(X0, P0, noise=np.zeros((B, K, 3, 2))), "noise"),
    "bootstrap noise of the wrong batch": (
        lambda: ObservationBootstrap(UKF, n_boot=2).init(X0, P0, noise=np.zeros((B + 1, K, 2, 2))), "noise"),
    "bootstrap noise with NaN": (
        lambda: ObservationBootstrap(UKF, n_boot=2).init(X0, P0, noise=np.full((B, K, 2, 2), np.nan)), "noise"),
    "bootstrap noise too short": (
        lambda: m.run(m.SingleModel(ObservationBootstrap(UKF, n_boot=2), CV, POS),
                      ObservationBootstrap(UKF, n_boot=2).init(X0, P0, noise=np.zeros((B, K - 1, 2, 2))), Z), "noise"),
    "bootstrap noise of a smaller dimension": (
        lambda: m.run(m.SingleModel(ObservationBootstrap(UKF, n_boot=2), CV, POS),
                      ObservationBootstrap(UKF, n_boot=2).init(X0, P0, noise=np.zeros((B, K, 2, 1))), Z), "noise"),
}


def test_numpy_scalars_are_accepted_by_the_layers():
    """np.float32 / np.int64 parameters are numbers (the old checks rejected them)."""
    st = StrongTracking(UKF, beta=np.float32(4.5), rho=np.float64(0.95))
    assert st.beta == 4.5 and isinstance(st.beta, float)
    assert InnovationAdaptive(UKF, window=np.int64(5), psi=np.float32(2.0)).window == 5
    assert ObservationBootstrap(UKF, n_boot=np.int32(3), variance_factor=np.float32(2.0)).n_boot == 3


def test_track_has_one_diverged_step_per_run():
    """Old code broadcast two runs of measurements over three runs of state and returned 2 diverged steps."""
    track = m.run(m.SingleModel(UKF, CV, POS), UKF.init(X0, P0), Z)
    assert track.diverged_step.shape == (B,) and track.divergence_cause.shape == (B,)


def _schedule(**kw):
    from mmlib.experiment.simulate import ManeuverSchedule
    args = dict(models=[CV], segments=[], default=0, T=1.0, n_steps=K)
    args.update(kw)
    return ManeuverSchedule(**args)


def _simulate(**kw):
    from mmlib.experiment.simulate import simulate
    args = dict(schedule=_schedule(), x0=X0[0], measurement=POS, mc=m.MonteCarlo(1, B), runs=range(B))
    args.update(kw)
    return simulate(**args)


SIM_CASES = {
    "schedule T = 0": (lambda: _schedule(T=0.0), "T"),
    "schedule T a string": (lambda: _schedule(T="1"), "T"),
    "schedule n_steps = 0": (lambda: _schedule(n_steps=0), "n_steps"),
    "schedule models a string": (lambda: _schedule(models="cv"), "models"),
    "schedule model not a model": (lambda: _schedule(models=[CV, "ct"]), r"models\[1\]"),
    "schedule default out of range": (lambda: _schedule(default=1), "default"),
    "schedule segment model out of range": (lambda: _schedule(segments=[(0, 3, 1)]), r"segments\[0\]"),
    "schedule segment reversed": (lambda: _schedule(segments=[(3, 1, 0)]), r"segments\[0\]"),
    "schedule jump index out of range": (lambda: _schedule(jumps=[(2.0, [7], [1.0])]), r"jumps\[0\]"),
    "schedule jump values NaN": (lambda: _schedule(jumps=[(2.0, [1], [np.nan])]), r"jumps\[0\]"),
    "simulate measurement a string": (lambda: _simulate(measurement="pos"), "measurement"),
    "simulate mc not a MonteCarlo": (lambda: _simulate(mc=7), "mc"),
    "simulate runs beyond n_runs": (lambda: _simulate(runs=range(B + 2)), "runs"),
    "simulate x0 complex": (lambda: _simulate(x0=X0[0] + 1j), "x0"),
    "simulate x0 wrong length": (lambda: _simulate(x0=X0[0, :3]), "x0"),
    "filter init cov a string": (lambda: UKF.init(X0, "P"), "cov"),
}


CA = models.constant_acceleration(1.0, 2.0)


def _evaluate(make_batch):
    from mmlib.experiment.evaluation import evaluate
    return evaluate({"UKF": m.SingleModel(UKF, CV, POS)}, make_batch, m.MonteCarlo(0, B), progress=False)


REVIEW_CASES = {
    "4-state sensor on 6-state dynamics": (lambda: m.SingleModel(UKF, CA, POS), "measurement"),
    "IMM sensor for another state size": (lambda: m.IMM(UKF, [CA, CA], POS, TR), "measurement"),
    "range-bearing indices beyond the state": (
        lambda: m.SingleModel(UKF, CV, models.RangeBearing(np.diag([1.0, 1e-4]), np.zeros(2), (0, 7))),
        "measurement"),
    "simulate sensor for another state size": (lambda: _simulate(measurement=models.position_measurement(
        [1.0, 1.0], state_dim=6)), "measurement"),
    "IMM modes of different state sizes": (lambda: m.IMM(UKF, [CV, CA], None, TR), "dynamics"),
    "IMM step dynamics of another size": (
        lambda: _imm().step(_imm().init(X0, P0), Z[:, 0], dynamics=m.models.StackedDynamics.of([CA, CA])),
        "dynamics"),
    "IMM step per-run Q of the wrong batch": (
        lambda: _imm().step(_imm().init(X0, P0), Z[:, 0],
                            dynamics=_imm().stacked.with_noise(np.tile(CV.Q, (B + 1, 2, 1, 1)))), "dynamics"),
    "run keep_cov not a bool": (lambda: m.run(m.SingleModel(UKF, CV, POS), UKF.init(X0, P0), Z, keep_cov="no"),
                                "keep_cov"),
    "simulate process_noise not a bool": (lambda: _simulate(process_noise="no"), "process_noise"),
    "adaptive flag not a bool": (lambda: InnovationAdaptive(UKF, zeta="no"), "zeta"),
    "adaptive inflate_only = 2": (lambda: InnovationAdaptive(UKF, inflate_only=2), "inflate_only"),
    "single model name not a string": (lambda: m.SingleModel(UKF, CV, POS, name=3), "name"),
    "strong tracking name not a string": (lambda: StrongTracking(UKF, name=3), "name"),
    "bootstrap noise garbage with n_boot = 0": (
        lambda: ObservationBootstrap(UKF, n_boot=0).init(X0, P0, noise="garbage"), "noise"),
    "degree of divergence complex": (
        lambda: importlib.import_module("mmlib.core.layers.adaptive_imm").degree_of_divergence(
            np.ones((2, 3)) + 1j, 1.0),
        "innovation"),
    "fuzzy bounds system a string": (
        lambda: importlib.import_module("mmlib.core.layers.fuzzy_noise").FuzzyNoiseBounds("x"), "system"),
    "evaluate make_batch returns garbage": (lambda: _evaluate(lambda runs: 3), "make_batch"),
    "evaluate init missing an estimator": (
        lambda: _evaluate(lambda runs: (np.zeros((len(runs), K + 1, 4)), Z[list(runs)], {})), "make_batch"),
    "evaluate truth of the wrong length": (
        lambda: _evaluate(lambda runs: (np.zeros((len(runs), K, 4)), Z[list(runs)],
                                        {"UKF": UKF.init(X0[list(runs)], P0)})), "make_batch"),
}


def _x_indexed_model():
    """A valid duck-typed model written for the (runs, points, n) inputs the filters pass (x[:, :, i])."""
    class XY:
        dim, R, noise_factor = 2, np.eye(2), np.eye(2)

        def h(self, x):
            return np.stack([x[:, :, 0], x[:, :, 2]], axis=-1)

        def jacobian(self, x):
            return POS.jacobian(x)

        def residual(self, a, b):
            return a - b

        def average(self, values, weights):
            return weights @ values
    return XY()


SECOND_REVIEW_CASES = {
    "step override for another state size": (
        lambda: m.SingleModel(UKF, CV, POS).step(UKF.init(X0, P0), Z[:, 0],
                                                 measurement=models.position_measurement([1.0, 1.0], state_dim=6)),
        "measurement"),
    "IMM step override for another state size": (
        lambda: _imm().step(_imm().init(X0, P0), Z[:, 0],
                            measurement=models.RangeBearing(np.diag([1.0, 1e-4]), np.zeros(2), (0, 7))),
        "measurement"),
    "run per-step model indices beyond the state": (
        lambda: m.run(m.SingleModel(UKF, CV, None), UKF.init(X0, P0), [Z[:, 0]],
                      measurement_models=[models.RangeBearing(np.diag([1.0, 1e-4]), np.zeros(2), (0, 7))]),
        "measurement"),
    "IMM step dynamics with another number of modes": (
        lambda: _imm().step(_imm().init(X0, P0), Z[:, 0], dynamics=m.models.StackedDynamics.of([CV, CV, CV])),
        "dynamics"),
    "IMM step Q with an extra leading axis": (
        lambda: _imm().step(_imm().init(X0, P0), Z[:, 0],
                            dynamics=_imm().stacked.with_noise(np.tile(CV.Q, (1, B, 2, 1, 1)))), "dynamics"),
    "step with_cov not a bool": (lambda: m.SingleModel(UKF, CV, POS).step(UKF.init(X0, P0), Z[:, 0], with_cov="no"),
                                 "with_cov"),
    "EKF name not a string": (lambda: m.ExtendedKalmanFilter(name=3), "name"),
    "sigma-point filter name bytes": (lambda: m.SigmaPointFilter(m.Unscented(), name=b"x"), "name"),
    "moment mixing name not a string": (lambda: m.estimation.MomentMixing(name=3), "name"),
    "evaluate progress not a bool": (
        lambda: importlib.import_module("mmlib.experiment.evaluation").evaluate(
            {"UKF": m.SingleModel(UKF, CV, POS)}, lambda runs: None, m.MonteCarlo(0, B), progress="no"), "progress"),
    "evaluate truth of another state size": (
        lambda: _evaluate(lambda runs: (np.zeros((len(runs), K + 1, 6)), Z[list(runs)],
                                        {"UKF": UKF.init(X0[list(runs)], P0)})), "make_batch"),
}


def test_valid_inputs_the_checks_must_not_reject():
    """A model written for (runs, points, n) inputs, a make_batch returning a list, per-run nested-list
    measurements: all valid, all accepted."""
    model = _x_indexed_model()
    track = m.run(m.SingleModel(UKF, CV, model), UKF.init(X0, P0), Z)
    assert not track.diverged.any()
    res = _evaluate(lambda runs: [np.zeros((len(runs), K + 1, 4)), Z[list(runs)].tolist(),
                                  {"UKF": UKF.init(X0[list(runs)], P0)}])
    assert res["UKF"].errors.shape == (B, K, 4)


def _windowed_step(levels_shape=(B, 2), dod_shape=(B, 2)):
    """One step of a windowed noise-adaptive IMM whose controller returns arrays of the given shapes."""
    from mmlib.core.layers.adaptive_imm import WindowedNoiseAdaptiveIMM

    class Controller:
        def dod(self, estimate, measurement):
            return np.ones(dod_shape)

        def levels(self, dod):
            return np.ones(levels_shape)

        def __call__(self, estimate, measurement):
            return self.levels(self.dod(estimate, measurement))

    w = WindowedNoiseAdaptiveIMM(_imm(), lambda lv: np.einsum("br,ij->brij", lv, CV.Q), Controller(), (1.0, 1.0),
                                 window=2)
    return w.step(w.init(X0, P0), Z[:, 0])


#: the layers and estimators' init (issue: bad input to the newer modules)
LAYER_CASES = {
    "single model init with an unknown keyword": (lambda: m.SingleModel(UKF, CV, POS).init(X0, P0, foo=1), "foo"),
    "IMM init with an unknown keyword": (lambda: _imm().init(X0, P0, foo=1), "foo"),
    "known modes init with an unknown keyword": (
        lambda: m.estimation.KnownModeSequence(UKF, [CV], np.zeros(K, dtype=int), POS).init(X0, P0, foo=1), "foo"),
    "strong tracking step from a Gaussian state": (
        lambda: m.SingleModel(StrongTracking(UKF), CV, POS).step(UKF.init(X0, P0), Z[:, 0]), "state"),
    "adaptive update of a Gaussian state": (lambda: InnovationAdaptive(UKF).update(UKF.init(X0, P0), Z[:, 0], POS),
                                            "state"),
    "bootstrap noise for another measurement dimension": (
        lambda: m.SingleModel(ObservationBootstrap(UKF, n_boot=2), CV, POS).init(X0, P0, noise=np.zeros((B, K, 2, 3))),
        "noise"),
    "IMM bootstrap noise for another measurement dimension": (
        lambda: m.IMM(ObservationBootstrap(UKF, n_boot=2), [CV, models.constant_velocity(1.0, 20.0)], POS, TR).init(
            X0, P0, noise=np.zeros((B, K, 2, 3))), "noise"),
    "windowed controller levels() of another shape": (lambda: _windowed_step(levels_shape=(B, 3)), "controller"),
    "windowed controller dod() of another shape": (lambda: _windowed_step(dod_shape=(B, 3)), "controller"),
    "a layer over another layer": (lambda: StrongTracking(InnovationAdaptive(UKF)), "base"),
    "layer init with an unknown keyword": (
        lambda: m.SingleModel(StrongTracking(UKF), CV, POS).init(X0, P0, foo=1), "foo"),
    "layer state through an IMM step": (
        lambda: m.IMM(StrongTracking(UKF), [CV, models.constant_velocity(1.0, 20.0)], POS, TR).step(
            m.IMM(UKF, [CV, models.constant_velocity(1.0, 20.0)], POS, TR).init(X0, P0), Z[:, 0]), "state"),
}


ALL_CASES = {**CASES, **SIM_CASES, **REVIEW_CASES, **SECOND_REVIEW_CASES, **LAYER_CASES}
assert len(ALL_CASES) == len(CASES) + len(SIM_CASES) + len(REVIEW_CASES) + len(SECOND_REVIEW_CASES) + len(LAYER_CASES)


def test_known_mode_sequence_over_observation_bootstrap():
    """The clairvoyant benchmark over the bootstrap layer: built, initialised with its pre-drawn noise, stepped
    (the first step with mode 0 is the single-model filter's step, bit for bit) and run over every step."""
    boot = ObservationBootstrap(UKF, n_boot=2)
    modes = np.array([0, 1] * (K // 2))
    kms = m.estimation.KnownModeSequence(boot, [CV, models.constant_velocity(1.0, 20.0)], modes, POS)
    noise = np.random.default_rng(2).standard_normal((B, K, 2, 2))
    state, est = kms.step(kms.init(X0, P0, noise=noise), Z[:, 0])
    assert state.step == 1 and est.mean.shape == (B, 4) and np.all(np.isfinite(est.mean))
    single = m.SingleModel(boot, CV, POS)
    _, first = single.step(single.init(X0, P0, noise=noise), Z[:, 0])
    np.testing.assert_array_equal(est.mean, first.mean)
    track = m.run(kms, kms.init(X0, P0, noise=noise), Z)
    assert track.mean.shape == (B, K, 4) and not track.diverged.any()


@pytest.mark.parametrize("case", list(ALL_CASES), ids=list(ALL_CASES))
def test_bad_input_is_a_value_error_naming_the_argument(case):
    call, name = ALL_CASES[case]
    with raises_naming(name):
        call()
