"""The interfaces of the estimation core (mmlib.core.protocols): every concrete model, filter, layer and estimator of
the library satisfies its protocol, and an object lacking a member is refused by name at construction."""
import numpy as np
import pytest

import mmlib as m
from mmlib.core import gnss, models, protocols
from mmlib.core.layers.adaptive_imm import NoiseAdaptiveIMM

CV = models.constant_velocity(1.0, 1.0)
RADAR = models.range_bearing(np.diag([100.0, 1e-6]))
BASES = [m.KalmanFilter(), m.ExtendedKalmanFilter(), m.SigmaPointFilter(m.Unscented()),
         m.SigmaPointFilter(m.Cubature()), m.SigmaPointFilter(m.FifthDegreeCubature()),
         m.SigmaPointFilter(m.SphericalSimplexRadial()), m.SigmaPointFilter(m.CentralDifference())]
LAYERS = [m.StrongTracking(m.SigmaPointFilter(m.Cubature())), m.InnovationAdaptive(m.SigmaPointFilter(m.Unscented())),
          m.ObservationBootstrap(m.SigmaPointFilter(m.CentralDifference()), n_boot=3)]
IMM = m.IMM(m.SigmaPointFilter(m.Cubature()), [CV, models.coordinated_turn(1.0, 0.05, 1.0)], RADAR,
            [[0.9, 0.1], [0.1, 0.9]])


@pytest.mark.parametrize("model", [CV, models.constant_acceleration(1.0, 1.0), models.coordinated_turn(1.0, 0.05, 1.0),
                                   gnss.PVClockNoise(1.0, np.eye(2)).dynamics(1.0)], ids=lambda d: d.name)
def test_dynamics_satisfy_protocol(model):
    assert isinstance(model, protocols.Dynamics) and not protocols.missing(model, protocols.Dynamics)


@pytest.mark.parametrize("model", [RADAR, models.position_measurement([1.0, 2.0])], ids=lambda d: d.name)
def test_measurements_satisfy_protocol(model):
    assert isinstance(model, protocols.MeasurementModel) and not protocols.missing(model, protocols.MeasurementModel)


@pytest.mark.parametrize("f", BASES + LAYERS, ids=lambda f: f.name)
def test_filters_satisfy_protocol(f):
    assert isinstance(f, protocols.MomentFilter)
    extra = {"noise": np.zeros((2, 5, 3, 2))} if isinstance(f, m.ObservationBootstrap) else {}
    state = f.init(np.zeros((2, 4)), np.eye(4), **extra)
    assert isinstance(state, protocols.State) and state.mean.shape == (2, 4)


@pytest.mark.parametrize("f", LAYERS, ids=lambda f: f.name)
def test_layers_satisfy_protocol(f):
    assert isinstance(f, protocols.Layer) and isinstance(f.base, protocols.MomentFilter)


@pytest.mark.parametrize("est", [m.SingleModel(BASES[2], CV, RADAR), IMM,
                                 NoiseAdaptiveIMM(IMM, lambda lv: np.broadcast_to(np.eye(4), lv.shape + (4, 4)),
                                                  lambda e, z: np.ones((e.mean.shape[0], 2)), (1.0, 1.0))],
                         ids=["single", "imm", "noise-adaptive imm"])
def test_estimators_satisfy_protocol(est):
    assert isinstance(est, protocols.Estimator)


class _NoResidual:
    """A sensor lacking residual/average (what a user might write first)."""
    dim, R = 2, np.eye(2)
    noise_factor = np.eye(2)

    def h(self, x):
        return x[..., [0, 2]]

    def jacobian(self, x):
        return np.broadcast_to(np.eye(2, 4), x.shape[:-1] + (2, 4))


def test_missing_members_named_with_protocol():
    with pytest.raises(ValueError, match=r"^measurement: .*MeasurementModel.*lacking residual, average"):
        m.SingleModel(BASES[0], CV, _NoResidual())
    with pytest.raises(ValueError, match=r"^base: .*MomentFilter"):
        m.StrongTracking(object())
    with pytest.raises(ValueError, match=r"^estimator: .*Estimator"):
        m.run(object(), IMM.init(np.zeros((1, 4)), np.eye(4)), np.zeros((1, 3, 2)))


def test_members_lists_inherited_members_once():
    assert protocols.members(protocols.Layer) == ("init", "predict", "update", "predict_measurement", "base")
    with pytest.raises(ValueError, match=r"^thing: .*Dynamics.*lacks Q, dim, transition, jacobian"):
        protocols.require(object(), "thing", protocols.Dynamics)
    assert protocols.require(CV, "thing", protocols.Dynamics) is CV
