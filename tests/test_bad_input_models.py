"""Bad input to the model, rule, GNSS and fuzzy constructors and factories: a ValueError whose message
starts with the argument the caller wrote (``T`` or ``omega``, never the derived ``F``); array-likes and
numpy scalar types are accepted, converted and validated, never repaired (issue 11, section 1).

Every case below failed on the code before this change: a silent NaN or garbage result, a raw
numpy/Python error (AttributeError, TypeError, IndexError, KeyError, ZeroDivisionError), or a message
naming a derived quantity."""
import math
import re

import numpy as np
import pytest

from mmlib.core import fuzzy, gnss, models, rules
from mmlib.core.models import radar_drift
from conftest import raises_naming


def _cv():
    return models.constant_velocity(1.0, 1.0)


def _stacked():
    return models.StackedDynamics.of([models.constant_velocity(1.0, 1.0), models.coordinated_turn(1.0, 0.1, 1.0)])


def _per_run_q(bad_run=1, bad_mode=0):
    """Per-run process noise (3 runs, 2 modes, 4x4), one indefinite matrix."""
    q = np.broadcast_to(_stacked().Q, (3, 2, 4, 4)).copy()
    q[bad_run, bad_mode] = -q[bad_run, bad_mode]
    return q


def _sets():
    return fuzzy.ramp_sets(("N", "M", "L"), (1.0, 2.0, 4.0))


def _fault(B=1, K=3, m=2):
    return models.SensorFault(np.ones((B, K, m)))


EYE2 = np.eye(2)
H24 = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])

# (argument the message must start with, call)
BAD = {
    # ---------------------------------------------------------------- LinearGaussianDynamics
    "LGD-F-nan": ("F", lambda: models.LinearGaussianDynamics(np.array([[np.nan]]), np.eye(1), np.eye(1))),
    "LGD-F-not-square": ("F", lambda: models.LinearGaussianDynamics(np.ones((2, 3)), EYE2, EYE2)),
    "LGD-Q-complex": ("Q", lambda: models.LinearGaussianDynamics(EYE2, EYE2 * (1 + 1j), EYE2)),
    "LGD-Q-not-psd": ("Q", lambda: models.LinearGaussianDynamics(EYE2, -EYE2, EYE2)),
    "LGD-factor-inconsistent": ("noise_factor", lambda: models.LinearGaussianDynamics(EYE2, EYE2, 2 * EYE2)),
    "LGD-factor-shape": ("noise_factor", lambda: models.LinearGaussianDynamics(EYE2, EYE2, np.eye(3)[:, :2])),
    "LGD-name-not-str": ("name", lambda: models.LinearGaussianDynamics(EYE2, EYE2, EYE2, name=3)),
    # ---------------------------------------------------------------- factories
    "gain-F-not-square": ("F", lambda: models.from_noise_gain(np.ones((4, 2)), np.ones((4, 1)), 1.0)),
    "gain-order-4": ("order", lambda: models.acceleration_noise_gain(1.0, order=4)),
    "gain-axes-0": ("axes", lambda: models.acceleration_noise_gain(1.0, axes=0)),
    "gain-T-0": ("T", lambda: models.acceleration_noise_gain(0.0)),
    "CV-T-0": ("T", lambda: models.constant_velocity(0.0, 1.0)),
    "CV-T-negative": ("T", lambda: models.constant_velocity(-1.0, 1.0)),
    "CV-T-inf": ("T", lambda: models.constant_velocity(np.inf, 1.0)),
    "CV-T-nan": ("T", lambda: models.constant_velocity(np.nan, 1.0)),
    "CV-T-str": ("T", lambda: models.constant_velocity("1", 1.0)),
    "CV-T-complex": ("T", lambda: models.constant_velocity(1.0 + 0.5j, 1.0)),
    "CA-T-0": ("T", lambda: models.constant_acceleration(0.0, 1.0)),
    "CTmatrix-omega-nan": ("omega", lambda: models.coordinated_turn_matrix(1.0, np.nan)),
    "CT-omega-nan": ("omega", lambda: models.coordinated_turn(1.0, np.nan, 1.0)),
    "CT-omega-inf": ("omega", lambda: models.coordinated_turn(1.0, np.inf, 1.0)),
    "CT-omega-str": ("omega", lambda: models.coordinated_turn(1.0, "0.1", 1.0)),
    "CT-omega-T-overflow": ("omega", lambda: models.coordinated_turn(10.0, 1e308, 1.0)),
    "CT-T-0": ("T", lambda: models.coordinated_turn(0.0, 0.1, 1.0)),
    "CT-T-negative": ("T", lambda: models.coordinated_turn(-1.0, 0.1, 1.0)),
    # ---------------------------------------------------------------- LinearMeasurement / position_measurement
    "LM-H-empty": ("H", lambda: models.LinearMeasurement(np.zeros((0, 4)), np.zeros((0, 0)))),
    "LM-name-not-str": ("name", lambda: models.LinearMeasurement(H24, EYE2, name=None)),
    "pos-index-out-of-range": ("position_index", lambda: models.position_measurement([1.0, 1.0], 4, (0, 7))),
    "pos-index-negative": ("position_index", lambda: models.position_measurement([1.0, 1.0], 4, (0, -1))),
    "pos-index-repeated": ("position_index", lambda: models.position_measurement([1.0, 1.0], 4, (0, 0))),
    "pos-index-float": ("position_index", lambda: models.position_measurement([1.0, 1.0], 4, (0.0, 2.0))),
    "pos-state_dim-float": ("state_dim", lambda: models.position_measurement([1.0, 1.0], state_dim=4.0)),
    # ---------------------------------------------------------------- RangeBearing / range_bearing
    "RB-sensor-length-3": ("sensor", lambda: models.RangeBearing(EYE2, sensor=[1.0, 2.0, 3.0])),
    "RB-sensor-length-1": ("sensor", lambda: models.RangeBearing(EYE2, sensor=[1.0])),
    "RB-index-repeated": ("position_index", lambda: models.RangeBearing(EYE2, position_index=(0, 0))),
    "RB-index-negative": ("position_index", lambda: models.RangeBearing(EYE2, position_index=(0, -2))),
    "RB-index-one": ("position_index", lambda: models.RangeBearing(EYE2, position_index=(0,))),
    "rb-R-complex": ("R", lambda: models.range_bearing(EYE2 * (1 + 1j))),
    "rb-R-str": ("R", lambda: models.range_bearing("abc")),
    "rb-sensor-length-3": ("sensor", lambda: models.range_bearing(EYE2, sensor=(0.0, 0.0, 0.0))),
    # ---------------------------------------------------------------- StackedDynamics (Q per step / per run)
    "stack-model-str": ("models[0]", lambda: models.StackedDynamics.of(["CV"])),
    "stack-model-array": ("models[1]", lambda: models.StackedDynamics.of([_cv(), np.eye(4)])),
    "stack-Q-nan": ("Q", lambda: _stacked().with_noise(np.full((2, 4, 4), np.nan))),
    "stack-Q-complex": ("Q", lambda: _stacked().with_noise(_stacked().Q * (1 + 1j))),
    "stack-Q-not-psd": ("Q", lambda: _stacked().with_noise(-_stacked().Q)),
    "stack-Q-asymmetric": ("Q", lambda: _stacked().with_noise(_stacked().Q + np.triu(np.ones((4, 4)), 1))),
    "stack-Q-per-run-not-psd": ("Q", lambda: _stacked().with_noise(_per_run_q())),
    "stack-Q-wrong-n": ("Q", lambda: _stacked().with_noise(np.broadcast_to(np.eye(3), (2, 3, 3)))),
    "stack-Q-wrong-modes": ("Q", lambda: _stacked().with_noise(np.broadcast_to(np.eye(4), (3, 4, 4)))),
    "stack-F-not-models": ("F", lambda: models.StackedDynamics(_stacked().models, _stacked().Q,
                                                                np.broadcast_to(np.eye(4), (2, 4, 4)))),
    # ---------------------------------------------------------------- SensorFault
    "fault-delta-2d": ("delta", lambda: models.SensorFault(np.zeros((2, 3)))),
    "fault-delta-nan": ("delta", lambda: models.SensorFault(np.full((1, 3, 2), np.nan))),
    "fault-radar-runs-mismatch": ("bearing_rate",
                                  lambda: radar_drift([1.0], [0.1, 0.2], [1.0, 2.0, 3.0])),
    "fault-radar-times-nan": ("times", lambda: radar_drift([1.0], [0.1], [np.nan])),
    "fault-radar-offset-steps": ("range_offset",
                                 lambda: radar_drift(np.ones((2, 4)), [0.1, 0.2], [1.0, 2.0, 3.0])),
    "fault-apply-dimension": ("measurement", lambda: _fault(m=3).apply(models.RangeBearing(EYE2))),
    "fault-apply-runs": ("delta", lambda: _fault(B=1).apply(models.RangeBearing(EYE2))(
        np.ones((3, 3, 4)), np.zeros((3, 3, 2)))),
    # ---------------------------------------------------------------- rules
    "UKF-kappa-inf": ("kappa", lambda: rules.Unscented(kappa=np.inf)),
    "UKF-kappa-complex": ("kappa", lambda: rules.Unscented(kappa=1 + 1j)),
    "UKF-beta-nan": ("beta", lambda: rules.Unscented(beta=np.nan)),
    "UKF-alpha-inf": ("alpha", lambda: rules.Unscented(alpha=np.inf)),
    "UKF-alpha-str": ("alpha", lambda: rules.Unscented(alpha="1")),
    "UKF-n-0": ("n", lambda: rules.Unscented().unit_points(0)),
    "CD-h-inf": ("h", lambda: rules.CentralDifference(h=np.inf)),
    "CKF-n-0": ("n", lambda: rules.Cubature().unit_points(0)),
    "5CKF-n-negative": ("n", lambda: rules.FifthDegreeCubature().unit_points(-1)),
    "SSR-n-float": ("n", lambda: rules.SphericalSimplexRadial().unit_points(2.5)),
    "simplex-n-0": ("n", lambda: rules.regular_simplex(0)),
    "by-name-foreign-param": ("alpha", lambda: rules.rule_by_name("ckf", alpha=1.0)),
    "by-name-unknown-param": ("gamma", lambda: rules.rule_by_name("ukf", gamma=1.0)),
    # ---------------------------------------------------------------- GNSS
    "orbit-inclination-nan": ("inclination", lambda: gnss.CircularOrbitConstellation([0.1], [0.2], inclination=np.nan)),
    "orbit-inclination-degrees": ("inclination",                        # 55 degrees passed where radians are due
                                  lambda: gnss.CircularOrbitConstellation([0.1], [0.2], inclination=55.0)),
    "orbit-a-inf": ("a", lambda: gnss.CircularOrbitConstellation([0.1], [0.2], a=np.inf)),
    "orbit-a-str": ("a", lambda: gnss.CircularOrbitConstellation([0.1], [0.2], a="26559700")),
    "orbit-no-satellites": ("raan", lambda: gnss.CircularOrbitConstellation([], [])),
    "orbit-names-length": ("names", lambda: gnss.CircularOrbitConstellation([0.1, 0.2], [0.2, 0.3], names=("A",))),
    "orbit-times-nan": ("times", lambda: gnss.nominal_gps24().positions_ecef([np.nan])),
    "gps24-phasing-nan": ("phasing_deg", lambda: gnss.nominal_gps24(phasing_deg=np.nan)),
    "frame-height-nan": ("height", lambda: gnss.LocalFrame(45.0, 10.0, np.nan)),
    "frame-lat-str": ("lat", lambda: gnss.LocalFrame("45", 10.0)),
    "frame-xyz-shape": ("xyz", lambda: gnss.LocalFrame(45.0, 10.0).ecef_to_enu([[1.0, 2.0]])),
    "frame-enu-complex": ("enu", lambda: gnss.LocalFrame(45.0, 10.0).enu_to_ecef([1.0 + 1j, 2.0, 3.0])),
    "elevation-shape": ("satellites_enu", lambda: gnss.elevation(np.ones((2, 2)), np.zeros(3))),
    "pseudoranges-names-length": ("names", lambda: gnss.Pseudoranges(np.ones((2, 3)), EYE2, names=("A",))),
    "clock-T-nan": ("T", lambda: gnss.clock_process_noise(np.nan, 2e-19, 2e-20)),
    "clock-T-str": ("T", lambda: gnss.clock_process_noise("1", 2e-19, 2e-20)),
    "clock-h0-inf": ("h0", lambda: gnss.clock_process_noise(1.0, np.inf, 2e-20)),
    "pvclock-T-inf": ("T", lambda: gnss.PVClockNoise(np.inf, np.zeros((2, 2)))),
    "pvclock-level-str": ("level", lambda: gnss.PVClockNoise(1.0, np.zeros((2, 2))).dynamics("abc")),
    "pvclock-level-nan": ("level", lambda: gnss.PVClockNoise(1.0, np.zeros((2, 2))).dynamics(np.nan)),
    # ---------------------------------------------------------------- fuzzy
    "trapezoid-d-nan": ("d", lambda: fuzzy.Trapezoid("t", 0.0, 1.0, 2.0, np.nan)),
    "trapezoid-a-str": ("a", lambda: fuzzy.Trapezoid("t", "0", 1.0, 2.0, 3.0)),
    "trapezoid-half-left-shoulder": ("b", lambda: fuzzy.Trapezoid("t", -np.inf, 0.0, 1.0, 2.0)),
    "trapezoid-half-right-shoulder": ("c", lambda: fuzzy.Trapezoid("t", 0.0, 1.0, 2.0, np.inf)),
    "trapezoid-name-not-str": ("name", lambda: fuzzy.Trapezoid(3, 0.0, 1.0, 2.0, 3.0)),
    "trapezoid-x-nan": ("x", lambda: fuzzy.Trapezoid("t", 0.0, 1.0, 2.0, 3.0)(np.nan)),
    "trapezoid-x-complex": ("x", lambda: fuzzy.Trapezoid("t", 0.0, 1.0, 2.0, 3.0)([1.0 + 1j])),
    "ramp-breakpoint-nan": ("breakpoints", lambda: fuzzy.ramp_sets(("N", "M"), (1.0, np.nan))),
    "ramp-breakpoint-str": ("breakpoints", lambda: fuzzy.ramp_sets(("N", "M"), ("a", "b"))),
    "ts-set-not-callable": ("inputs[0][0]", lambda: fuzzy.TakagiSugeno(((1, 2),), np.zeros((2, 1)))),
    "ts-no-inputs": ("inputs", lambda: fuzzy.TakagiSugeno((), np.zeros(1))),
    "ts-inputs-not-sequence": ("inputs", lambda: fuzzy.TakagiSugeno(5, np.zeros((2, 1)))),
    "ts-output-names": ("output_names", lambda: fuzzy.TakagiSugeno((_sets(),), np.zeros((3, 1)),
                                                                   output_names=("a", "b", "c"))),
}


@pytest.mark.parametrize("case", list(BAD), ids=list(BAD))
def test_bad_input_is_a_value_error_naming_the_argument(case):
    arg, call = BAD[case]
    with raises_naming(re.escape(arg)):
        call()


def test_per_run_process_noise_names_the_offending_run_and_mode():
    with pytest.raises(ValueError, match=r"^Q: covariance at index \(2, 1\) is not positive semi-definite"):
        _stacked().with_noise(_per_run_q(bad_run=2, bad_mode=1))
    # ... while a semi-definite Q (a zero block: a zero noise level, or no clock noise) is legitimate
    q = np.zeros((3, 2, 4, 4))
    q[:, :, :2, :2] = np.eye(2)
    assert _stacked().with_noise(q).Q.shape == (3, 2, 4, 4)


# --------------------------------------------------------------------------- accepted inputs
def _same_model(a, b, fields):
    return all(np.array_equal(getattr(a, f), getattr(b, f)) for f in fields)


ACCEPTED = {
    "LGD-lists": (lambda: models.LinearGaussianDynamics([[1.0, 1.0], [0.0, 1.0]], [[1.0, 0.0], [0.0, 4.0]],
                                                        [[1.0, 0.0], [0.0, 2.0]]),
                  lambda: models.LinearGaussianDynamics(np.array([[1.0, 1.0], [0.0, 1.0]]), np.diag([1.0, 4.0]),
                                                        np.diag([1.0, 2.0])),
                  ("F", "Q", "noise_factor")),
    "LM-lists": (lambda: models.LinearMeasurement([[1.0, 0.0, 0.0, 0.0]], [[2.0]]),
                 lambda: models.LinearMeasurement(np.array([[1.0, 0.0, 0.0, 0.0]]), np.array([[2.0]])),
                 ("H", "R")),
    "RB-lists": (lambda: models.RangeBearing([[1.0, 0.0], [0.0, 1e-4]], sensor=[10.0, -20.0]),
                 lambda: models.RangeBearing(np.diag([1.0, 1e-4]), sensor=np.array([10.0, -20.0])),
                 ("R", "sensor")),
    "CD-h-float32": (lambda: rules.CentralDifference(h=np.float32(2.0)), lambda: rules.CentralDifference(h=2.0),
                     ("h",)),
    "CD-h-int64": (lambda: rules.CentralDifference(h=np.int64(2)), lambda: rules.CentralDifference(h=2.0), ("h",)),
}


@pytest.mark.parametrize("case", list(ACCEPTED), ids=list(ACCEPTED))
def test_array_likes_and_numpy_scalars_are_accepted(case):
    build, reference, fields = ACCEPTED[case]
    got = build()
    assert _same_model(got, reference(), fields)
    for f in fields:
        value = getattr(got, f)
        assert isinstance(value, (float, np.ndarray)) and np.asarray(value).dtype == np.float64


def test_list_models_work_in_h_and_transition():
    rb = models.RangeBearing([[1.0, 0.0], [0.0, 1e-4]], sensor=[3.0, 4.0])
    np.testing.assert_allclose(rb.h(np.array([[0.0, 0.0, 0.0, 0.0]])), [[5.0, math.atan2(-4.0, -3.0)]])
    lm = models.LinearMeasurement([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]], [[1.0, 0.0], [0.0, 1.0]])
    np.testing.assert_array_equal(lm.h(np.array([[1.0, 2.0, 3.0, 4.0]])), [[1.0, 3.0]])


def test_the_callers_arrays_are_neither_aliased_nor_frozen():
    H, R = H24.copy(), np.eye(2)
    lm = models.LinearMeasurement(H, R)
    assert H.flags.writeable and R.flags.writeable
    H[0, 0] = 7.0
    assert lm.H[0, 0] == 1.0 and not lm.H.flags.writeable
