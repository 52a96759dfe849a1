"""GNSS geometry, clock model, Takagi-Sugeno inference, the noise-adaptive IMM, the fuzzy noise controller
(mmlib.core.layers.fuzzy_noise) and the Tseng et al. 2011 reconstruction (hand-checkable cases, limits,
invariances, bad inputs)."""
import dataclasses
import math

import numpy as np
import pytest

from mmlib.core import gnss
from mmlib.core.layers.adaptive_imm import NoiseAdaptiveIMM, WindowedNoiseAdaptiveIMM, degree_of_divergence
from mmlib.core.layers.fuzzy_noise import FuzzyNoiseBounds, fuzzy_imm, fuzzy_system
from scipy.linalg import expm

from mmlib.core.estimation import IMM, Estimate, SingleModel, run
from mmlib.core.filters import KalmanFilter, SigmaPointFilter
from mmlib.core.fuzzy import TakagiSugeno, Trapezoid, ramp_sets
from mmlib.core.models import constant_velocity, coordinated_turn, position_measurement
from mmlib.core.rules import Unscented
from mmlib.experiment.montecarlo import MonteCarlo
from mmlib.experiment import evaluation
from mmlib.papers import REGISTRY
from mmlib.papers.tseng2011.diagnostics import maneuver_flags
from mmlib.papers.tseng2011.setup import Setup, noise_model, transition_matrix
from mmlib.papers.tseng2011.simulation import experiment, make_batch_fn, trajectory

ROOT_SEED = REGISTRY["tseng2011"].root_seed

SITE = (25.15, 121.78, 0.0)


def up_unit(lat_deg, lon_deg):
    """Geodetic normal in ECEF, written out independently of pymap3d."""
    la, lo = math.radians(lat_deg), math.radians(lon_deg)
    return np.array([math.cos(la) * math.cos(lo), math.cos(la) * math.sin(lo), math.sin(la)])


# --------------------------------------------------------------------------- geometry
def test_satellite_at_zenith_has_range_plus_bias_and_90_degrees_elevation():
    frame = gnss.LocalFrame(*SITE)
    r = 20_200e3
    sat_ecef = frame.origin_ecef + r * up_unit(SITE[0], SITE[1])
    enu = frame.ecef_to_enu(sat_ecef)
    # double precision at 2e7 m: ~1e-8 m per operation, a few operations in pymap3d
    np.testing.assert_allclose(enu, [0.0, 0.0, r], rtol=0, atol=1e-6)
    assert math.degrees(gnss.elevation(enu[None], np.zeros(3))[0]) == pytest.approx(90.0, abs=1e-6)
    pr = gnss.Pseudoranges(enu[None], np.eye(1))
    b = 1234.5
    x = np.array([0, 0, 0, 0, 0, 0, b, 0.0])
    assert pr.h(x)[0] == pytest.approx(r + b, rel=0, abs=1e-6)


def test_pseudorange_and_jacobian_at_a_known_position():
    sats = np.array([[3.0, 0.0, 4.0], [0.0, 0.0, 10.0], [-6.0, 8.0, 0.0]])
    pr = gnss.Pseudoranges(sats, np.eye(3))
    x = np.zeros(8)
    x[6] = 2.0                                          # clock bias, m
    np.testing.assert_allclose(pr.h(x), [5.0 + 2.0, 10.0 + 2.0, 10.0 + 2.0], rtol=0, atol=1e-12)
    H = pr.jacobian(x)
    np.testing.assert_allclose(H[0, [0, 2, 4]], [-0.6, 0.0, -0.8], atol=1e-12)   # minus the line of sight
    assert np.all(H[:, 6] == 1.0) and np.all(H[:, [1, 3, 5, 7]] == 0.0)
    # finite differences at a generic point
    x = np.array([1.0, 0.5, -2.0, 0.1, 0.3, 0.0, 7.0, 0.2])
    eps = 1e-6
    fd = np.stack([(pr.h(x + eps * e) - pr.h(x - eps * e)) / (2 * eps) for e in np.eye(8)], axis=-1)
    np.testing.assert_allclose(pr.jacobian(x), fd, rtol=0, atol=1e-8)


def test_receiver_position_roundtrip_and_horizon():
    frame = gnss.LocalFrame(*SITE)
    enu = np.array([[100.0, -250.0, 3.0], [0.0, 0.0, 0.0]])
    np.testing.assert_allclose(frame.ecef_to_enu(frame.enu_to_ecef(enu)), enu, atol=1e-6)
    el = gnss.elevation(np.array([[1e7, 0.0, 0.0], [0.0, 1e7, 1e7]]), np.zeros(3))
    np.testing.assert_allclose(np.degrees(el), [0.0, 45.0], atol=1e-12)


def test_circular_orbits_closed_form():
    i = math.radians(55.0)
    c = gnss.CircularOrbitConstellation(np.array([0.0, 0.0]), np.array([0.0, math.pi / 2]))
    p0 = c.positions_ecef([0.0])[0]
    np.testing.assert_allclose(p0[0], [c.a, 0, 0], atol=1e-6)
    np.testing.assert_allclose(p0[1], [0, c.a * math.cos(i), c.a * math.sin(i)], atol=1e-6)
    p = c.positions_ecef(np.linspace(0, 86_400, 7))
    np.testing.assert_allclose(np.linalg.norm(p, axis=-1), c.a, rtol=1e-14)
    # two-body period of the nominal radius: half a sidereal day to 5 s (the real orbit's J2 and
    # radius adjustments close the gap); 10 s bounds it
    assert 2 * math.pi / c.mean_motion == pytest.approx(math.pi / gnss.EARTH_ROTATION, abs=10.0)
    # sign of the Earth's rotation: an equatorial orbit with the Earth's rate is fixed in ECEF
    geo = gnss.CircularOrbitConstellation(np.array([0.3]), np.array([0.0]), inclination=0.0,
                                          a=(gnss.EARTH_GM / gnss.EARTH_ROTATION ** 2) ** (1 / 3))
    g = geo.positions_ecef([0.0, 3_600.0, 40_000.0])[:, 0]
    np.testing.assert_allclose(g[1:], np.broadcast_to(g[0], (2, 3)), rtol=0, atol=1e-6 * geo.a)
    const = gnss.nominal_gps24()
    assert const.size == 24 and len(set(const.names)) == 24
    with pytest.raises(ValueError, match="arg_latitude"):
        gnss.CircularOrbitConstellation(np.zeros(3), np.zeros(2))
    with pytest.raises(ValueError, match="lat"):
        gnss.LocalFrame(95.0, 0.0)


def van_loan(A, Qc, T):
    """Discrete process noise of dx = A x dt + dw, E[dw dw^T] = Qc dt, over T (Van Loan 1978):
    an independent numerical route to the closed forms."""
    n = A.shape[0]
    M = np.block([[-A, Qc], [np.zeros((n, n)), A.T]]) * T
    E = expm(M)
    phi = E[n:, n:].T
    return phi @ E[:n, n:]


def test_clock_noise_matches_van_loan_and_validates():
    T, h0, hm2 = 2.0, 2e-19, 2e-20
    c2 = gnss.SPEED_OF_LIGHT ** 2
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    Qc = c2 * np.diag([h0 / 2, 2 * math.pi ** 2 * hm2])          # Brown & Hwang: S_f, S_g
    np.testing.assert_allclose(gnss.clock_process_noise(T, h0, hm2), van_loan(A, Qc, T), rtol=1e-9)
    assert np.all(np.linalg.eigvalsh(gnss.clock_process_noise(T, h0, hm2)) > 0)
    with pytest.raises(ValueError, match="h0"):
        gnss.clock_process_noise(1.0, -1.0, 0.0)


def test_pv_process_noise_matches_van_loan():
    T, S = 1.5, 0.37
    noise = gnss.PVClockNoise(T, np.zeros((2, 2)))
    A = np.kron(np.eye(3), np.array([[0.0, 1.0], [0.0, 0.0]]))
    Qc = np.kron(np.eye(3), np.diag([0.0, S]))                   # white acceleration on each axis
    np.testing.assert_allclose(noise.Q(S)[:6, :6], van_loan(A, Qc, T), rtol=1e-9, atol=1e-15)


def test_pv_clock_noise_levels_are_bit_identical_to_single_models():
    noise = gnss.PVClockNoise(1.0, gnss.clock_process_noise(1.0, 2e-19, 2e-20))
    levels = np.array([[0.01, 1.0], [0.3, 0.0]])
    Q = noise.Q(levels)
    assert Q.shape == (2, 2, 8, 8)
    assert np.array_equal(Q[0, 1], noise.dynamics(1.0).Q) and np.array_equal(Q[0, 0], noise.dynamics(0.01).Q)
    np.testing.assert_allclose(Q[1, 1][:6, :6], 0.0)
    with pytest.raises(ValueError, match="levels"):
        noise.Q(np.array([-1.0]))


def test_pv_clock_noise_is_psd_by_construction_as_marked():
    """The mark that lets a noise-adaptive IMM skip its per-step check must be true: every Q the family returns for
    levels it accepts passes the full check (zero, tiny, huge and random levels, per run and mode)."""
    from mmlib.core._validate import check_covariance
    from mmlib.core.models import is_psd_by_construction
    from mmlib.core.models import psd_by_construction
    rng = np.random.default_rng(3)
    for T in (1e-3, 1.0, 2.0, 30.0):                 # T > 1.44: T^3/3 > 1, the largest level below finfo.max
        noise = gnss.PVClockNoise(T, gnss.clock_process_noise(T, 2e-19, 2e-20))
        assert is_psd_by_construction(noise.Q)
        top = np.finfo(float).max / max(noise.unit.max(), 1.0)       # about the largest level whose Q is finite
        levels = np.concatenate([[0.0, 5e-324, 1e-300, 1e-12, 1.0, 1e12, top * 0.25, top * 0.5],
                                 10.0 ** rng.uniform(-300, np.log10(top * 0.5), 992)])
        check_covariance(noise.Q(levels.reshape(500, 2)), "Q", 8, stack=True, semidefinite=True)
        if noise.unit.max() > 1.0:
            with pytest.raises(ValueError, match="^levels: .*overflows"):     # a level whose Q is not finite: refused
                noise.Q(np.array([1.0, top * 1.01]))
    assert not is_psd_by_construction(lambda levels: noise.Q(levels))      # an unmarked callable is checked
    with pytest.raises(ValueError, match="^fn: "):
        psd_by_construction(noise.Q)                                           # a bound method cannot be marked


def test_noise_adaptive_imm_checks_an_unmarked_noise_every_step_and_skips_a_marked_one(monkeypatch):
    ex = experiment(SHORT, names=("FUZZY-IMMUKF",))
    base = ex.estimators["FUZZY-IMMUKF"]
    mc = MonteCarlo(ROOT_SEED, 2)
    truth, z, init = make_batch_fn(ex, mc)(range(2))
    from mmlib.core import models
    calls = []
    real = models.check_covariance
    monkeypatch.setattr(models, "check_covariance", lambda *a, **k: calls.append(k) or real(*a, **k))
    traces = {}
    for label, noise in (("marked", base.noise), ("unmarked", lambda levels: base.noise(levels))):
        layer = NoiseAdaptiveIMM(base.imm, noise, base.controller, tuple(base.initial_levels))
        calls.clear()
        st = layer.init(truth[:, 0], np.diag(np.square(SHORT.p0_sd)), SHORT.mu0)
        traces[label] = run(layer, st, z[:5], measurement_models=ex.measurement_models[:5])
        assert len(calls) == (0 if label == "marked" else 5), label
    assert np.array_equal(traces["marked"].mean, traces["unmarked"].mean)   # the same bits either way
    # an unmarked family returning an indefinite Q is refused at the step, naming Q
    bad = NoiseAdaptiveIMM(base.imm, lambda levels: -base.noise(levels), base.controller, tuple(base.initial_levels))
    with pytest.raises(ValueError, match="^Q: "):
        run(bad, bad.init(truth[:, 0], np.diag(np.square(SHORT.p0_sd)), SHORT.mu0), z[:2],
            measurement_models=ex.measurement_models[:2])
    with pytest.raises(ValueError, match="^Q: "):                    # the unchecked path still checks the shape
        base.imm.stacked.with_noise(np.zeros((2, 3, 8, 8)), check=False)
    with pytest.raises(ValueError, match="^check: "):
        base.imm.stacked.with_noise(base.noise(np.ones(2)), check="no")
    stacked = base.imm.stacked
    with pytest.raises(ValueError, match="^q_psd_by_construction: "):
        type(stacked)(stacked.models, stacked.Q, stacked.F, q_psd_by_construction="yes")
    with pytest.raises(ValueError, match="^Q: "):                     # and a non-finite Q
        stacked.with_noise(np.where(np.eye(8) > 0, np.nan, stacked.Q), check=False)
    with pytest.raises(ValueError, match="^F: "):                     # the unchecked Q still checks the rest
        type(stacked)(stacked.models, stacked.Q, stacked.F[:1], q_psd_by_construction=True)
    # the instance says which path it took, and a replaced Q is checked again (replace() reads the InitVar's class
    # default, never the unchecked path of the instance it copies)
    unchecked = stacked.with_noise(base.noise(np.ones(2)), check=False)
    assert unchecked.q_checked is False and stacked.with_noise(base.noise(np.ones(2))).q_checked is True
    with pytest.raises(ValueError, match="^Q: "):
        dataclasses.replace(unchecked, Q=-base.noise(np.ones(2)))


def test_pseudoranges_are_the_bits_of_the_vector_formula():
    """h and the Jacobian, computed component by component, equal bit for bit the formula on (..., m, 3) lines of
    sight (the sum of the three squares along the last axis)."""
    rng = np.random.default_rng(5)
    sats = rng.standard_normal((7, 3)) * 2e7
    pr = gnss.Pseudoranges(sats, 25.0 * np.eye(7))
    x = rng.standard_normal((40, 3, 17, 8)) * 1e3
    d = sats - x[..., None, [0, 2, 4]]
    r = np.sqrt((d * d).sum(axis=-1))
    from mmlib.core import linalg
    for kernel in linalg.KERNELS:                  # the compiled twin too: the same IEEE operations, the same bits
        with linalg.use_kernel(kernel):
            assert pr.h(x).tobytes() == (r + x[..., 6, None]).tobytes(), kernel
            assert pr.h(x[3, 1, 2]).tobytes() == (r + x[..., 6, None])[3, 1, 2].tobytes(), kernel   # one point
    for kernel in linalg.KERNELS:                  # bad operands named, never read out of bounds
        with linalg.use_kernel(kernel):
            with pytest.raises(IndexError):
                linalg.pseudoranges(x, sats, (0, 2, 9), 6)
            with pytest.raises(ValueError, match="^satellites: "):
                linalg.pseudoranges(x, sats[:, :2], (0, 2, 4), 6)
            with pytest.raises(ValueError, match="^position: "):
                linalg.pseudoranges(x, sats, (0, 2, 1.7), 6)
            with pytest.raises(ValueError, match="^bias: "):
                linalg.pseudoranges(x, sats, (0, 2, 4), True)
            # range and bearing share the index check: a float or a bool is named, not truncated to a column
            for i, j, bad in ((0.9, 2, "i"), (0, True, "j"), (np.float64(2.0), 1, "i")):
                with pytest.raises(ValueError, match=f"^{bad}: expected an integer index"):
                    linalg.range_bearing(x, i, j, np.zeros(2))
            with pytest.raises(IndexError):
                linalg.range_bearing(x, 0, 8, np.zeros(2))
            assert linalg.range_bearing(x, -8, -6, np.ones(2)).tobytes() == \
                linalg.range_bearing(x, 0, 2, np.ones(2)).tobytes()
    jac = np.zeros(x.shape[:-1] + (7, 8))
    jac[..., [0, 2, 4]] = -d / r[..., None]
    jac[..., 6] = 1.0
    assert np.array_equal(pr.jacobian(x), jac)


def test_pseudoranges_validate():
    with pytest.raises(ValueError, match="satellites"):
        gnss.Pseudoranges(np.zeros((2, 2)), np.eye(2))
    with pytest.raises(ValueError, match="R"):
        gnss.Pseudoranges(np.ones((2, 3)), -np.eye(2))
    with pytest.raises(ValueError, match="satellites"):
        gnss.Pseudoranges(np.array([[np.nan, 0, 0]]), np.eye(1))


# --------------------------------------------------------------------------- fuzzy inference
def test_trapezoid_and_partition_of_unity():
    t = Trapezoid("T", 0.0, 1.0, 2.0, 4.0)
    np.testing.assert_allclose(t([-1, 0, 0.5, 1, 1.5, 2, 3, 4, 5]), [0, 0, 0.5, 1, 1, 1, 0.5, 0, 0])
    sets = ramp_sets(("N", "M", "L"), (1.0, 2.0, 4.0))
    x = np.linspace(-3, 10, 1001)
    np.testing.assert_allclose(sum(s(x) for s in sets), 1.0, atol=1e-15)
    assert sets[0](0.0) == 1.0 and sets[1](2.0) == 1.0 and sets[2](100.0) == 1.0
    with pytest.raises(ValueError, match="a <= b"):
        Trapezoid("bad", 2.0, 1.0, 3.0, 4.0)
    with pytest.raises(ValueError, match="breakpoints"):
        ramp_sets(("N", "M"), (2.0, 1.0))


def _membership(t, x: float) -> float:
    """A trapezoid's membership at one point, written from its definition in scalar Python arithmetic (the
    independent reference: one IEEE operation per step, so the bits a correct vectorised evaluation must give)."""
    up = 1.0 if t.a == -math.inf else (float(x >= t.b) if t.b == t.a else (x - t.a) / (t.b - t.a))
    down = 1.0 if t.d == math.inf else (float(x <= t.c) if t.d == t.c else (t.d - x) / (t.d - t.c))
    return min(max(min(up, down), 0.0), 1.0)


def test_trapezoids_evaluated_at_once_are_the_bits_of_each_set():
    """TakagiSugeno evaluates an input's trapezoids in one call, and each set's own call goes through the same
    function: both the bits of the definition evaluated point by point, at the breakpoints, between them, far out,
    at -0.0, for shoulders, triangles, a step (a = b) and a plateau, and for any shape of input."""
    from mmlib.core.fuzzy import _trapezoid_memberships
    sets = ramp_sets(("N", "M", "L"), (0.5, 1.0, 3.0)) + (Trapezoid("step", 1.0, 1.0, 2.0, 2.0),
                                                          Trapezoid("tri", 0.2, 0.7, 0.7, 1.5),
                                                          Trapezoid("at0", 0.0, 1.0, 2.0, 3.0))   # -0.0 -> -0.0
    x = np.concatenate([np.random.default_rng(2).standard_normal(2000) * 3,
                        [0.5, 1.0, 3.0, 2.0, 0.2, 0.7, 1.5, -1e300, 1e300, 0.0, -0.0]])
    ref = np.array([[_membership(t, v) for t in sets] for v in x.tolist()])
    bounds = np.array([[t.a, t.b, t.c, t.d] for t in sets]).T
    assert np.signbit(ref[-1, -1]) and ref[-1, -1] == 0          # the signed zero is there to compare (x = -0.0)
    assert _trapezoid_memberships(bounds, x).tobytes() == ref.tobytes()
    assert np.stack([t(x) for t in sets], axis=-1).tobytes() == ref.tobytes()
    assert sets[3](x.reshape(1, -1, 1)).tobytes() == ref[:, 3].tobytes()          # any shape in, same shape out
    assert sets[3](x.reshape(1, -1, 1)).shape == (1, x.size, 1)
    assert type(sets[4](0.7)) is np.float64 and sets[4](0.7) == _membership(sets[4], 0.7)     # a scalar for a scalar
    # and the system uses it, with the same output as through the sets one by one
    ts = two_input_system()
    assert all(b is not None for b in ts._bounds)
    xy = np.random.default_rng(4).uniform(-1, 6, (300, 2))
    w = np.ones((300, 1, 1))
    for i, sets_i in enumerate(ts.inputs):
        mu = np.array([[_membership(t, v) for t in sets_i] for v in xy[:, i].tolist()])
        w = w * mu.reshape((300, 3, 1) if i == 0 else (300, 1, 3))
    assert ts.firing_strengths(xy).tobytes() == w.tobytes()


def two_input_system(cons=None):
    sets = ramp_sets(("N", "M", "L"), (1.0, 2.0, 4.0))
    cons = np.arange(18.0).reshape(3, 3, 2) if cons is None else cons
    return TakagiSugeno((sets, sets), cons)


def test_takagi_sugeno_corners_return_the_corner_rules():
    ts = two_input_system()
    x = np.array([[0.0, 0.0], [100.0, 100.0], [0.0, 100.0], [100.0, 0.0], [2.0, 2.0]])
    np.testing.assert_array_equal(ts(x), ts.consequents[[0, 2, 0, 2, 1], [0, 2, 2, 0, 1]])
    # between two rules: the weighted average (x1 = 1.5 -> N and M at 1/2 each)
    np.testing.assert_allclose(ts(np.array([[1.5, 0.0]])), [0.5 * (ts.consequents[0, 0] + ts.consequents[1, 0])])
    # always inside the hull of the consequents
    y = ts(np.random.default_rng(1).uniform(0, 6, (200, 2)))
    assert y.min() >= ts.consequents.min() and y.max() <= ts.consequents.max()


def test_takagi_sugeno_bad_inputs():
    with pytest.raises(ValueError, match="consequents"):
        two_input_system(np.zeros((3, 2, 2)))
    ts = two_input_system()
    with pytest.raises(ValueError, match="x"):
        ts(np.zeros((4, 3)))
    with pytest.raises(ValueError, match="x"):
        ts(np.array([[np.nan, 0.0]]))
    gap = TakagiSugeno(((Trapezoid("low", -math.inf, -math.inf, 0.0, 1.0),),), np.zeros((1, 1)))
    with pytest.raises(ValueError, match="fires no rule"):
        gap(np.array([[5.0]]))


def _mixed_system(d: int, k: int, seed: int, wide: bool = False) -> TakagiSugeno:
    """d inputs of k trapezoids each: ramp sets (shoulders and triangles), and in the first input a step (a = b)
    and a plateau in place of two of them, so every branch of a membership is taken; ``wide``: triangles that all
    span the whole range instead, so every rule fires and the order of summing the weights shows."""
    rng = np.random.default_rng(seed)
    sets = []
    for i in range(d):
        bp = np.cumsum(rng.uniform(0.3, 1.5, k))
        if wide:
            ss = [Trapezoid(f"w{j}", -1.5, b, b, bp[-1] + 1.5) for j, b in enumerate(bp)]
        else:
            ss = list(ramp_sets([f"s{j}" for j in range(k)], bp))
        if i == 0 and k >= 3 and not wide:
            ss[1] = Trapezoid("step", bp[0], bp[0], bp[1], bp[1])
            ss[2] = Trapezoid("plateau", bp[0], bp[1], bp[1] + 0.2, bp[2])
        sets.append(tuple(ss))
    return TakagiSugeno(tuple(sets), rng.standard_normal((k,) * d + (2,)) * 10.0 ** rng.uniform(-3, 3, (k,) * d + (2,)))


@pytest.mark.parametrize("d, k, wide", [(1, 2, False), (1, 9, False), (2, 3, False), (2, 5, False), (2, 12, False),
                                        (3, 4, False), (1, 13, True), (2, 11, True), (2, 12, True)])
def test_the_compiled_rule_base_gives_the_bits_of_the_numpy_one(d, k, wide):
    """linalg.trapezoid_rules, compiled, against its numpy body on the compiled kernels (whose matmul_rows the
    numpy body calls), and against the system evaluated as before it existed (firing strengths, their sum,
    matmul_rows): output and total, bit for bit, at random inputs, at every breakpoint, at -0.0 and far out; with
    1 to 3 inputs and 2 to 144 rules, with sets that fire at most two rules per input and with sets that all fire
    (13, 121 and 144 rules of nonzero weight; above 128 the compiled form hands the sum to numpy)."""
    from mmlib.core import linalg
    from mmlib.core.linalg import trapezoid_rules
    ts = _mixed_system(d, k, seed=10 * d + k, wide=wide)
    rng = np.random.default_rng(d * 100 + k)
    points = sorted({v for sets in ts.inputs for t in sets for v in (t.a, t.b, t.c, t.d) if math.isfinite(v)})
    x = np.concatenate([rng.uniform(-1.0, points[-1] + 1.0, (400, d)),
                        np.repeat(np.array(points + [-0.0, 0.0, -1e300, 1e300])[:, None], d, axis=1)])
    with linalg.use_kernel("numba"):
        ref = trapezoid_rules.implementations["numpy"](x, *ts._trapezoids, ts._rule_consequents)
        got = trapezoid_rules.implementations["numba"](x, *ts._trapezoids, ts._rule_consequents)
        wf = ts.firing_strengths(x).reshape(len(x), -1)
        with np.errstate(invalid="ignore", divide="ignore"):      # rows firing no rule (the step and plateau)
            before = linalg.matmul_rows(wf, ts._rule_consequents) / wf.sum(axis=1, keepdims=True)
        fired = ref[1] > 0
        assert fired.sum() > 100
        assert got[1].tobytes() == ref[1].tobytes()
        assert got[0][fired].tobytes() == ref[0][fired].tobytes() == before[fired].tobytes()
        assert ts(x[fired]).tobytes() == got[0][fired].tobytes()
        if wide:        # every rule of a row inside the sets' span fires: the order of the sum matters (numpy's)
            assert (wf[fired] > 0).all()


def test_the_compiled_memberships_are_numpys_bit_for_bit():
    """The compiled membership of one trapezoid (``_kernels._trapezoid``) against numpy's
    (``linalg.trapezoid_memberships``), bit for bit: shoulders, triangles, a step, a plateau, a set starting at 0
    (at x = -0.0 its membership is -0.0 in both), at the breakpoints, between them and far out."""
    from mmlib.core import _kernels
    from mmlib.core.linalg import trapezoid_memberships
    sets = ramp_sets(("N", "M", "L"), (0.5, 1.0, 3.0)) + (Trapezoid("step", 1.0, 1.0, 2.0, 2.0),
                                                          Trapezoid("tri", 0.2, 0.7, 0.7, 1.5),
                                                          Trapezoid("at0", 0.0, 1.0, 2.0, 3.0))
    x = np.concatenate([np.random.default_rng(5).standard_normal(500) * 3,
                        [0.5, 1.0, 3.0, 2.0, 0.2, 0.7, 1.5, -1e300, 1e300, 0.0, -0.0]])
    bounds = np.array([[t.a, t.b, t.c, t.d] for t in sets]).T
    ref = trapezoid_memberships(bounds, x)
    got = np.array([[_kernels._trapezoid(v, t.a, t.b, t.c, t.d) for t in sets] for v in x.tolist()])
    assert np.signbit(ref[-1, -1]) and ref[-1, -1] == 0
    assert got.tobytes() == ref.tobytes()


def test_the_rule_base_refuses_operands_that_do_not_fit_by_name_on_either_kernel():
    from mmlib.core import linalg
    from mmlib.core.linalg import trapezoid_rules
    ts = two_input_system()
    bounds, sizes = ts._trapezoids
    x = np.ones((4, 2))
    for kernel in linalg.KERNELS:
        with linalg.use_kernel(kernel):
            with pytest.raises(ValueError, match="consequents: 5 rules"):
                trapezoid_rules(x, bounds, sizes, np.zeros((5, 2)))
            with pytest.raises(ValueError, match="sizes"):
                trapezoid_rules(x, bounds, np.array([3, 4]), np.zeros((12, 2)))
            with pytest.raises(ValueError, match="trapezoid_rules"):
                trapezoid_rules(np.ones((4, 3)), bounds, sizes, ts._rule_consequents)


def test_the_fuzzy_system_takes_the_compiled_rule_base_and_numpys_sum_order():
    """On the compiled kernels a system of trapezoids is evaluated by the compiled kernel (a spy on the kernel
    module sees the call; on the numpy kernels it is not called, and the result is the numpy body's), and the kernel
    sums in numpy's order: ``_numpy_sum`` equals ``numpy.sum`` bit for bit for 0 to 128 terms of mixed magnitudes
    and signs with a signed zero among them; a sum of negative zeros is +0.0 as numpy's is."""
    from mmlib.core import _kernels, linalg
    rng = np.random.default_rng(7)
    for n in range(_kernels.NUMPY_SUM_MAX + 1):
        a = rng.standard_normal(n) * 10.0 ** rng.uniform(-8, 8, n)
        if n:
            a[rng.integers(n)] = -0.0
        total = _kernels._numpy_sum(a, 0, n)
        assert total == np.sum(a) and np.signbit(total) == np.signbit(np.sum(a)), n
        assert _kernels._numpy_sum(np.concatenate([[5.0, 7.0], a]), 2, n) == total       # an offset start
    assert not np.signbit(_kernels._numpy_sum(np.full(9, -0.0), 0, 9)) and not np.signbit(np.sum(np.full(9, -0.0)))
    ts = two_input_system()
    x = np.random.default_rng(3).uniform(-1, 6, (50, 2))
    calls = []
    real = _kernels.trapezoid_rules

    def spy(*args):
        calls.append(args[0].shape)
        return real(*args)

    big = _mixed_system(2, 12, seed=3, wide=True)                 # 144 rules: numpy's sum, not the kernel's
    try:
        _kernels.trapezoid_rules = spy
        with linalg.use_kernel("numba"):
            compiled = ts(x)
            assert calls == [(50, 2)]
            big(x)
        assert calls == [(50, 2)]
        with linalg.use_kernel("numpy"):
            reference = ts(x)
        assert calls == [(50, 2)]
    finally:
        _kernels.trapezoid_rules = real
    np.testing.assert_allclose(compiled, reference, rtol=1e-14, atol=0)   # the kernels agree to round-off


@pytest.mark.parametrize("kernel", ["numba", "numpy"])
def test_an_input_firing_no_rule_is_refused_on_either_kernel(kernel):
    from mmlib.core import linalg
    gap = TakagiSugeno(((Trapezoid("low", -math.inf, -math.inf, 0.0, 1.0),),
                        (Trapezoid("all", -math.inf, -math.inf, math.inf, math.inf),)), np.zeros((1, 1, 1)))
    with linalg.use_kernel(kernel):
        assert gap(np.array([[0.5, 3.0]])).shape == (1, 1)
        with pytest.raises(ValueError, match=r"input \[5.0, 3.0\] \(row 1\) fires no rule"):
            gap(np.array([[0.5, 3.0], [5.0, 3.0]]))
        with pytest.raises(ValueError, match=r"input \[5, 3\] \(row 1\) fires no rule"):   # as the caller wrote it
            gap([[0, 3], [5, 3]])
        for system in (gap, TakagiSugeno(((lambda v: np.ones_like(v),),), np.zeros((1, 1)))):   # trapezoids or not
            with pytest.raises(ValueError, match=r"x: expected shape \(B, \d\) with B >= 1"):
                system(np.zeros((0, system.n_inputs)))


def test_degree_of_divergence_definitions():
    nu = np.array([[3.0, -3.0, 3.0, -3.0], [0.0, 0.0, 0.0, 6.0]])
    dod = degree_of_divergence(nu, 9.0)
    np.testing.assert_allclose(dod, [[1.0, 1.0], [1.0, 0.5]])        # same xi, different eta
    with pytest.raises(ValueError, match="noise_variance"):
        degree_of_divergence(nu, 0.0)
    with pytest.raises(ValueError, match="innovation"):
        degree_of_divergence(nu[0], 1.0)


def estimate_with(innovation, S):
    return Estimate(None, None, innovation=np.asarray(innovation, float), innovation_cov=np.asarray(S, float))


def flas_system(setup):
    """The FLAS of a Tseng set-up: its breakpoints and level range."""
    return fuzzy_system(setup.breakpoints, setup.s_lower, setup.s_upper)


def test_fuzzy_system_rules_slide_a_half_range_band_with_the_larger_input():
    """Rule (i, j) of n sets: p = max(i, j) / (n - 1); log10 levels (lo + p D, lo + D + p D), D = half the
    log-range; the inputs' sets reach 1 at the breakpoints (xi) and at sqrt(2/pi) sqrt(breakpoints) (eta)."""
    ts = fuzzy_system((1.0, 2.0, 4.0), 0.01, 1.0)
    assert ts.consequents.shape == (3, 3, 2) and [s.name for s in ts.inputs[0]] == ["Normal", "Moderate", "Large"]
    np.testing.assert_allclose(ts.consequents[0, 0], [-2.0, -1.0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(ts.consequents[1, 0], ts.consequents[0, 1], rtol=0, atol=0)
    np.testing.assert_allclose(ts.consequents[2, 1], [-1.0, 0.0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(ts.consequents[1, 2], [-1.0, 0.0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(ts.consequents[1, 1], [-1.5, -0.5], rtol=0, atol=1e-15)
    eta_peaks = [s.b for s in ts.inputs[1][1:]]                # where the sets reach 1
    np.testing.assert_allclose(eta_peaks, math.sqrt(2 / math.pi) * np.sqrt([2.0, 4.0]), rtol=1e-15)
    four = fuzzy_system((0.5, 1.0, 2.0, 4.0), 0.1, 10.0, names=("a", "b", "c", "d"))
    np.testing.assert_allclose(four.consequents[3, 0], [0.0, 1.0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(four.consequents[1, 1], [-1.0 + 1 / 3, 1 / 3], rtol=0, atol=1e-15)
    for kw, name in ((dict(breakpoints=(2.0, 1.0, 4.0)), "breakpoints"), (dict(breakpoints=(1.0,)), "breakpoints"),
                     (dict(lower=0.0), "lower"), (dict(upper=0.01), "upper"), (dict(names=("a", "b")), "breakpoints")):
        args = dict(breakpoints=(1.0, 2.0, 4.0), lower=0.01, upper=1.0) | kw
        with pytest.raises(ValueError, match=name):
            fuzzy_system(**args)


def test_flas_corners_give_the_stated_bounds_and_nan_runs_stay_nan():
    setup = Setup()
    flas = FuzzyNoiseBounds(flas_system(setup))
    R = gnss.Pseudoranges(np.ones((4, 3)), setup.sigma_pr ** 2 * np.eye(4))
    S = np.tile(12.0 * np.eye(4), (2, 1, 1))
    quiet, loud = estimate_with(np.zeros((2, 4)), S), estimate_with(np.full((2, 4), 100.0), S)
    mid = math.sqrt(setup.s_lower * setup.s_upper)
    np.testing.assert_allclose(flas(quiet, R), [[setup.s_lower, mid]] * 2, rtol=1e-14)
    np.testing.assert_allclose(flas(loud, R), [[mid, setup.s_upper]] * 2, rtol=1e-14)
    out = flas(estimate_with(np.array([[np.nan] * 4, [0.0] * 4]), S), R)
    assert np.isnan(out[0]).all() and np.isfinite(out[1]).all()
    with pytest.raises(ValueError, match="normalise"):
        FuzzyNoiseBounds(flas_system(setup), "sigma")


def test_flas_normalises_by_the_predicted_innovation_variance():
    ts = flas_system(Setup())
    s_pred, sigma2 = 12.0, 9.0
    est = estimate_with(np.full((1, 4), math.sqrt(s_pred)), s_pred * np.eye(4)[None])
    R = gnss.Pseudoranges(np.ones((4, 3)), sigma2 * np.eye(4))
    np.testing.assert_allclose(FuzzyNoiseBounds(ts).dod(est, R), [[1.0, 1.0]], rtol=1e-14)
    np.testing.assert_allclose(FuzzyNoiseBounds(ts, "measurement").dod(est, R),
                               [[s_pred / sigma2, math.sqrt(s_pred / sigma2)]], rtol=1e-14)


def test_imm_innovation_and_its_covariance_against_closed_form():
    """First step from a common initial state: mixing is the identity, so each mode predicts
    zhat_j = H F_j x, S_j = H (F_j P F_j^T + Q_j) H^T + R, and the IMM's innovation is that of the
    mixture prior with c = mu0 @ transition."""
    cv, ct = constant_velocity(1.0, 0.5), coordinated_turn(1.0, math.radians(20), 2.0)
    meas = position_measurement([4.0, 9.0])
    Tm = np.array([[0.9, 0.1], [0.25, 0.75]])
    imm = IMM(KalmanFilter(), [cv, ct], meas, Tm)
    x = np.array([[10.0, 3.0, -5.0, 4.0]])
    P = np.diag([4.0, 1.0, 9.0, 2.0])
    mu0 = np.array([0.3, 0.7])
    z = np.array([[13.5, -0.5]])
    _, est = imm.step(imm.init(x, P, mu0), z)
    c = mu0 @ Tm
    H = meas.H
    zj = [H @ m.F @ x[0] for m in (cv, ct)]
    Sj = [H @ (m.F @ P @ m.F.T + m.Q) @ H.T + meas.R for m in (cv, ct)]
    zbar = c[0] * zj[0] + c[1] * zj[1]
    S = sum(c[j] * (Sj[j] + np.outer(zj[j] - zbar, zj[j] - zbar)) for j in range(2))
    np.testing.assert_allclose(est.innovation[0], z[0] - zbar, rtol=0, atol=1e-12)
    np.testing.assert_allclose(est.innovation_cov[0], S, rtol=1e-12)


class RecordingController:
    """Returns levels that encode the call number, so the test can see when they are used."""

    def __init__(self):
        self.calls = 0

    def __call__(self, est, measurement):
        self.calls += 1
        B = est.innovation.shape[0]
        return np.tile([0.01 * self.calls, 0.1 * self.calls], (B, 1))


def test_noise_adaptive_imm_uses_the_levels_of_the_previous_step():
    ex = experiment(SHORT, names=("FUZZY-IMMUKF",))
    base = ex.estimators["FUZZY-IMMUKF"]
    layer = NoiseAdaptiveIMM(base.imm, base.noise, RecordingController(), (0.5, 5.0))
    mc = MonteCarlo(ROOT_SEED, 2)
    truth, z, init = make_batch_fn(ex, mc)(range(2))
    st = layer.init(truth[:, 0], np.diag(np.square(SHORT.p0_sd)), SHORT.mu0)
    tr = run(layer, st, z[:5], measurement_models=ex.measurement_models[:5])
    np.testing.assert_array_equal(tr.diagnostics[:, 0], [[0.5, 5.0]] * 2)        # step 0: the initial levels
    for k in range(1, 5):                                                          # step k: call k's output
        np.testing.assert_allclose(tr.diagnostics[:, k], [[0.01 * k, 0.1 * k]] * 2, rtol=1e-15)


def test_a_diverged_run_is_recorded_and_the_batch_goes_on():
    ex = experiment(SHORT, names=("FUZZY-IMMUKF",))
    est = ex.estimators["FUZZY-IMMUKF"]
    mc = MonteCarlo(ROOT_SEED, 3)
    truth, z, init = make_batch_fn(ex, mc)(range(3))
    st = init["FUZZY-IMMUKF"]
    modes = st.imm.modes
    bad_mean = modes.mean.copy()
    bad_mean[0] = np.nan                                      # run 0 broken before the first step
    st = st._replace(imm=st.imm._replace(modes=modes._replace(mean=bad_mean)))
    tr = run(est, st, z[:20], measurement_models=ex.measurement_models[:20])
    assert tr.diverged_step.tolist() == [0, -1, -1]
    assert np.isnan(tr.diagnostics[0, 1:]).all() and np.isfinite(tr.diagnostics[1:]).all()
    assert np.isfinite(tr.mean[1:]).all()


# --------------------------------------------------------------------------- per-step measurement models
def test_per_step_models_equal_the_fixed_array_path():
    cv = constant_velocity(1.0, 0.5)
    meas = position_measurement([4.0, 4.0])
    est = SingleModel(KalmanFilter(), cv, meas)
    rng = np.random.default_rng(0)
    z = rng.normal(size=(5, 12, 2))
    x0, P0 = np.zeros((5, 4)), np.eye(4)
    a = run(est, est.init(x0, P0), z)
    b = run(est, est.init(x0, P0), [z[:, k] for k in range(12)], measurement_models=[meas] * 12)
    assert np.array_equal(a.mean, b.mean) and np.array_equal(a.cov, b.cov)
    with pytest.raises(ValueError, match="measurement_models"):
        run(est, est.init(x0, P0), [z[:, k] for k in range(12)], measurement_models=[meas] * 11)
    bad = [z[:, k] for k in range(12)]
    bad[3] = np.full((5, 2), np.nan)
    with pytest.raises(ValueError, match=r"measurements\[3\]"):
        run(est, est.init(x0, P0), bad, measurement_models=[meas] * 12)
    with pytest.raises(ValueError, match=r"measurements\[0\]"):
        run(est, est.init(x0, P0), [z[:, 0, :1]] + [z[:, k] for k in range(1, 12)], measurement_models=[meas] * 12)
    no_model = SingleModel(KalmanFilter(), cv, None)
    with pytest.raises(ValueError, match="no measurement model"):
        run(no_model, no_model.init(x0, P0), z)


# --------------------------------------------------------------------------- the reconstruction
SHORT = Setup(n_steps=150, turns=((40.0, 90.0, 90.0),))


def short_results(setup, names, n_runs, **build_kw):
    ex = experiment(setup, names=names, **build_kw)
    mc = MonteCarlo(ROOT_SEED, n_runs)
    return evaluation.evaluate(ex.estimators, make_batch_fn(ex, mc), mc, progress=False,
                           measurement_models=ex.measurement_models)


def test_frozen_fuzzy_imm_is_the_imm_at_its_initial_bounds_bit_for_bit():
    ex = experiment(SHORT, names=("FUZZY-IMMUKF",), frozen_fuzzy=True)
    frozen = ex.estimators["FUZZY-IMMUKF"]
    plain = frozen.imm                                    # the IMM whose modes have the 'Normal' bounds
    mc = MonteCarlo(ROOT_SEED, 6)
    truth, z, init = make_batch_fn(ex, mc)(range(6))
    a = run(frozen, init["FUZZY-IMMUKF"], z, measurement_models=ex.measurement_models)
    b = run(plain, init["FUZZY-IMMUKF"].imm, z, measurement_models=ex.measurement_models)
    assert np.array_equal(a.mean, b.mean) and np.array_equal(a.mode_probabilities, b.mode_probabilities)
    np.testing.assert_array_equal(a.diagnostics, np.broadcast_to(frozen.initial_levels, a.diagnostics.shape))


def test_constant_fuzzy_output_equals_the_imm_to_rounding():
    setup = SHORT
    ex = experiment(setup, names=("FUZZY-IMMUKF", "IMMUKF"))
    imm = ex.estimators["IMMUKF"]
    ts = flas_system(setup)
    const = TakagiSugeno(ts.inputs, np.broadcast_to(np.log10([setup.s_lower, setup.s_upper]), ts.consequents.shape))
    fz = NoiseAdaptiveIMM(imm, noise_model(setup).Q, FuzzyNoiseBounds(const), (setup.s_lower, setup.s_upper))
    mc = MonteCarlo(ROOT_SEED, 4)
    truth, z, init = make_batch_fn(ex, mc)(range(4))
    a = run(fz, fz.init(truth[:, 0], np.diag(np.square(setup.p0_sd)), setup.mu0), z,
            measurement_models=ex.measurement_models)
    b = run(imm, imm.init(truth[:, 0], np.diag(np.square(setup.p0_sd)), setup.mu0), z,
            measurement_models=ex.measurement_models)
    # 10**log10(s) differs from s by a few ulp; positions are ~1e4 m
    np.testing.assert_allclose(a.mean, b.mean, rtol=0, atol=1e-6)


def test_ukf_equals_ekf_on_pseudoranges():
    res = short_results(SHORT, ("UKF", "EKF"), 8)
    pos = [0, 2, 4]
    # the UKF and EKF differ by the pseudorange's curvature over the spread, ~ sigma_p^2 / (2 r): with the initial
    # 10 m per axis (sigma_p^2 = 300 m^2) and r >= 2e7 m that is <= 7.5e-6 m per update, and the filter forgets it
    assert np.abs(res["UKF"].errors[..., pos] - res["EKF"].errors[..., pos]).max() < 2e-5
    assert all(r.valid.all() for r in res.values())


def test_reconstruction_is_deterministic_and_prefix_consistent():
    a = short_results(SHORT, ("FUZZY-IMMUKF",), 6)["FUZZY-IMMUKF"]
    b = short_results(SHORT, ("FUZZY-IMMUKF",), 6)["FUZZY-IMMUKF"]
    c = short_results(SHORT, ("FUZZY-IMMUKF",), 3)["FUZZY-IMMUKF"]
    assert np.array_equal(a.errors, b.errors) and np.array_equal(a.diagnostics, b.diagnostics)
    head = evaluation.first_runs(a, 3)          # what the notebook's sweep reuses instead of recomputing
    assert np.array_equal(head.errors, c.errors) and np.array_equal(head.diagnostics, c.diagnostics)
    assert np.array_equal(head.mode_probabilities, c.mode_probabilities)


def test_trajectory_follows_the_segment_table():
    s = Setup()
    x = trajectory(s)
    speed = np.hypot(x[:, 1], x[:, 3])
    np.testing.assert_allclose(speed, s.speed, rtol=1e-12)
    heading = np.degrees(np.arctan2(x[:, 3], x[:, 1]))
    # after the full circle the course is East again; +90 after segment 4; back to East after segment 6
    assert heading[700] == pytest.approx(0.0, abs=1e-6)
    assert heading[900] == pytest.approx(90.0, abs=1e-6)
    assert heading[1400] == pytest.approx(0.0, abs=1e-6)
    np.testing.assert_allclose(x[300, [0, 2]], x[700, [0, 2]], atol=1e-6)       # a closed circle


def test_setup_and_estimator_validation():
    with pytest.raises(ValueError, match="p_stay"):
        Setup(p_stay=1.0)
    with pytest.raises(ValueError, match="s_lower"):
        Setup(s_lower=2.0, s_upper=1.0)
    with pytest.raises(ValueError, match="mask_deg"):
        experiment(Setup(n_steps=5, mask_deg=80.0))
    ex = experiment(SHORT, names=("IMMUKF",))
    with pytest.raises(ValueError, match="initial_levels"):
        NoiseAdaptiveIMM(ex.estimators["IMMUKF"], noise_model(SHORT).Q, None, (0.1,))
    with pytest.raises(ValueError, match="system"):
        FuzzyNoiseBounds(TakagiSugeno((ramp_sets("NL", (0, 1)),), np.zeros((2, 1))))
    ukf, noise, Tm = SigmaPointFilter(Unscented(1.0, 2.0, 0.0)), noise_model(SHORT), transition_matrix(SHORT)
    for kw, name in ((dict(window=0), "window"), (dict(window=True), "window"), (dict(normalise="sigma"), "normalise"),
                     (dict(breakpoints=(4.0, 2.0, 1.0)), "breakpoints")):
        with pytest.raises(ValueError, match=name):
            fuzzy_imm(ukf, noise, 0.01, 1.0, Tm, **(dict(breakpoints=(1.0, 2.0, 4.0)) | kw))
    with pytest.raises(ValueError, match="noise"):
        fuzzy_imm(ukf, noise.Q, 0.01, 1.0, Tm, breakpoints=(1.0, 2.0, 4.0))
    with pytest.raises(ValueError, match="upper"):
        fuzzy_imm(ukf, noise, 1.0, 0.01, Tm, breakpoints=(1.0, 2.0, 4.0))


def test_truth_clock_follows_the_clock_model():
    """Increments b_{k+1} - F b_k of the simulated clock have covariance Q (sample of 20 runs x 150 steps:
    relative s.e. of a variance sqrt(2/3000) = 2.6 %, of the correlation ~1.8 %; 4 s.e. allowed)."""
    ex = experiment(SHORT, names=("UKF",))
    mc = MonteCarlo(ROOT_SEED, 20)
    truth, _, _ = make_batch_fn(ex, mc)(range(20))
    dyn = gnss.clock_dynamics(SHORT.T, SHORT.clock_h0, SHORT.clock_h_minus2)
    c = truth[..., list(gnss.CLOCK_INDEX)]
    assert np.all(c[:, 0] == 0.0)
    inc = (c[:, 1:] - c[:, :-1] @ dyn.F.T).reshape(-1, 2)
    C = inc.T @ inc / len(inc)
    np.testing.assert_allclose(np.diag(C), np.diag(dyn.Q), rtol=4 * math.sqrt(2 / len(inc)))
    rho, rho_model = C[0, 1] / math.sqrt(C[0, 0] * C[1, 1]), dyn.Q[0, 1] / math.sqrt(dyn.Q[0, 0] * dyn.Q[1, 1])
    assert abs(rho - rho_model) < 4 * (1 - rho_model ** 2) / math.sqrt(len(inc))


def test_maneuver_flags_follow_the_segment_table():
    flags = maneuver_flags(Setup())
    start = np.arange(1800)                       # transition k starts at t = k s
    expect = ((start >= 300) & (start < 700)) | ((start >= 800) & (start < 900)) | ((start >= 1200) & (start < 1400))
    np.testing.assert_array_equal(flags, expect.astype(int))


def test_fuzzy_imm_starts_at_the_first_rule_and_windows_by_request():
    """fuzzy_imm: a two-mode IMM at the "Normal" levels (L, sqrt(L U)), a plain NoiseAdaptiveIMM for a window of one
    and a WindowedNoiseAdaptiveIMM otherwise, with the FLAS of its breakpoints and normalisation."""
    ukf, noise, Tm = SigmaPointFilter(Unscented(1.0, 2.0, 0.0)), noise_model(SHORT), transition_matrix(SHORT)
    one = fuzzy_imm(ukf, noise, 0.01, 1.0, Tm, breakpoints=(1.0, 2.0, 4.0))
    assert type(one) is NoiseAdaptiveIMM and one.name == "FUZZY-IMM" and one.imm.measurement is None
    np.testing.assert_allclose(one.initial_levels, [0.01, 0.1], rtol=1e-14)
    np.testing.assert_array_equal(one.imm.dynamics[1].Q, noise.dynamics(one.initial_levels[1]).Q)
    assert one.controller.normalise == "innovation"
    np.testing.assert_array_equal(one.controller.system.consequents,
                                  fuzzy_system((1.0, 2.0, 4.0), 0.01, 1.0).consequents)
    four = fuzzy_imm(ukf, noise, 0.01, 1.0, Tm, breakpoints=(1.0, 2.0, 4.0), normalise="measurement", window=4,
                     frozen=True, name="F")
    assert isinstance(four, WindowedNoiseAdaptiveIMM) and four.window == 4 and four.frozen and four.name == "F"
    assert four.controller.normalise == "measurement"


# --------------------------------------------------------------------------- the whole run in one compiled call
def _runs_both_ways(est, state, z, models, monkeypatch, **kw):
    """run() of a noise-adaptive IMM as one compiled call (checked to be taken) and step by step: the two Tracks."""
    from mmlib.core import linalg
    calls = []
    real = linalg.fuzzy_imm_run
    monkeypatch.setattr(linalg, "fuzzy_imm_run", lambda *a, **k: calls.append(1) or real(*a, **k))
    whole = run(est, state, z, measurement_models=models, **kw)
    assert calls == [1], "the whole run was not one compiled call"
    with monkeypatch.context() as m:
        m.setattr(type(est), "whole_run", lambda *a, **k: None)
        steps = run(est, state, z, measurement_models=models, **kw)
    return whole, steps


def _same_bits(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and np.array_equal(a.view(np.uint8), b.view(np.uint8))


@pytest.mark.parametrize("fields", [{}, {"dod_window": 4}, {"dod_window": 16}, {"dod_normalise": "measurement"},
                                    {"mf_scale": 0.5}, {"frozen": True}])
def test_the_fuzzy_imm_whole_run_gives_the_bits_of_its_steps(fields, monkeypatch):
    """Tseng et al. 2011's noise-adaptive IMM up to 60 epochs past the first change of the satellites in view: one
    compiled call gives every Track field -- estimates, covariances, mode probabilities, levels, NIS, NEES,
    divergences -- the bits of the layer step by step, with the DOD of one epoch or averaged over 4 or 16,
    normalised by the innovation's or the measurement's variance, sharper membership functions, or the levels frozen;
    a run broken before the first step diverges at step 0 and the others go on."""
    fields = dict(fields)
    frozen = fields.pop("frozen", False)
    setup = dataclasses.replace(Setup(), **fields)
    ex = experiment(setup, names=("FUZZY-IMMUKF",), frozen_fuzzy=frozen)
    est = ex.estimators["FUZZY-IMMUKF"]
    mc = MonteCarlo(ROOT_SEED, 6)
    truth, z, init = make_batch_fn(ex, mc)(range(6))
    dims = [zk.shape[1] for zk in z]
    K = next(k for k in range(1, len(dims)) if dims[k] != dims[k - 1]) + 60      # 60 epochs past the first change
    st = init["FUZZY-IMMUKF"]
    bad = st.imm.modes.mean.copy()
    bad[2] = np.nan
    st = st._replace(imm=st.imm._replace(modes=st.imm.modes._replace(mean=bad)))
    whole, steps = _runs_both_ways(est, st, z[:K], ex.measurement_models[:K], monkeypatch, consistency=True,
                                   truth=truth[:, :K + 1])
    for field in whole._fields:
        assert _same_bits(getattr(whole, field), getattr(steps, field)), field
    assert whole.diverged_step.tolist() == [-1, -1, 0, -1, -1, -1]
    levels = whole.diagnostics[[0, 1, 3, 4, 5]]
    assert np.isfinite(levels).all() and (frozen or len(np.unique(levels[:, :, 1])) > 10)


@pytest.mark.parametrize("batch", [1, 2, 3])
def test_the_fuzzy_imm_whole_run_changes_no_bit_with_the_batch(batch, monkeypatch):
    from mmlib.core import linalg
    ex = experiment(SHORT, names=("FUZZY-IMMUKF",))
    est = ex.estimators["FUZZY-IMMUKF"]
    mc = MonteCarlo(ROOT_SEED, 8)
    truth, z, init = make_batch_fn(ex, mc)(range(8))
    monkeypatch.setattr(linalg, "FUSED_BLOCK", 3)
    full = run(est, init["FUZZY-IMMUKF"], z, measurement_models=ex.measurement_models)
    part = run(est, init["FUZZY-IMMUKF"]._replace(imm=_first(init["FUZZY-IMMUKF"].imm, batch),
                                                   levels=init["FUZZY-IMMUKF"].levels[:batch]),
               [zk[:batch] for zk in z], measurement_models=ex.measurement_models)
    for field in ("mean", "mode_probabilities", "diagnostics"):
        assert _same_bits(getattr(full, field)[:batch], getattr(part, field)), field


def _first(imm_state, batch):
    from mmlib.core.estimation import select_runs
    return select_runs(imm_state, slice(0, batch))


def test_the_fuzzy_imm_whole_run_falls_back_where_the_controller_refuses_or_does_not_apply(monkeypatch):
    """A rule base whose sets do not cover the degrees of divergence fires no rule: the whole run declines and the
    steps raise the layer's error; a controller subclass, a noise family that is not affine in its level and fusion
    off run step by step (the compiled call not made)."""
    from mmlib.core import linalg
    ex = experiment(SHORT, names=("FUZZY-IMMUKF",))
    est = ex.estimators["FUZZY-IMMUKF"]
    mc = MonteCarlo(ROOT_SEED, 3)
    truth, z, init = make_batch_fn(ex, mc)(range(3))
    narrow = (Trapezoid("low", -np.inf, -np.inf, 1e-9, 2e-9),)
    system = TakagiSugeno((narrow, narrow), np.zeros((1, 1, 2)))
    refusing = dataclasses.replace(est, controller=FuzzyNoiseBounds(system))
    tried = []
    real = linalg.fuzzy_imm_run
    with monkeypatch.context() as m:
        m.setattr(linalg, "fuzzy_imm_run", lambda *a, **k: tried.append(real(*a, **k)) or tried[-1])
        with pytest.raises(ValueError, match="fires no rule"):
            run(refusing, init["FUZZY-IMMUKF"], z[:10], measurement_models=ex.measurement_models[:10])
    assert tried == [None]                     # attempted, declined, then the steps raised

    class OwnBounds(FuzzyNoiseBounds):
        pass

    noise = est.noise.__self__
    calls = []
    real = linalg.fuzzy_imm_run
    monkeypatch.setattr(linalg, "fuzzy_imm_run", lambda *a, **k: calls.append(1) or real(*a, **k))
    for other in (dataclasses.replace(est, controller=OwnBounds(est.controller.system)),
                  dataclasses.replace(est, noise=lambda levels: noise.Q(levels))):
        run(other, init["FUZZY-IMMUKF"], z[:10], measurement_models=ex.measurement_models[:10])
    with linalg.use_fused(False):
        run(est, init["FUZZY-IMMUKF"], z[:10], measurement_models=ex.measurement_models[:10])
    assert not calls
    run(est, init["FUZZY-IMMUKF"], z[:10], measurement_models=ex.measurement_models[:10])
    assert calls == [1]


def test_the_fuzzy_imm_whole_run_carries_a_given_history_and_any_mode_count(monkeypatch):
    """A windowed layer started from a carried-in DOD history (some epochs filled, non-zero degrees) with a NaN level
    (replaced by the initial one, kept in the diagnostics), and a frozen layer of three modes: the whole run gives
    the bits of the steps."""
    ex = experiment(dataclasses.replace(SHORT, dod_window=4), names=("FUZZY-IMMUKF",))
    est = ex.estimators["FUZZY-IMMUKF"]
    mc = MonteCarlo(ROOT_SEED, 4)
    truth, z, init = make_batch_fn(ex, mc)(range(4))
    st = init["FUZZY-IMMUKF"]
    rng = np.random.default_rng(3)
    levels = st.levels.copy()
    levels[1, 0] = np.nan
    st = st._replace(levels=levels, dod=rng.uniform(0.5, 3.0, st.dod.shape), filled=np.array([0, 2, 4, 3]))
    whole, steps = _runs_both_ways(est, st, z[:60], ex.measurement_models[:60], monkeypatch)
    for field in whole._fields:
        assert _same_bits(getattr(whole, field), getattr(steps, field)), field
    assert np.isnan(whole.diagnostics[1, 0, 0]) and np.isfinite(whole.mean).all()
    noise = est.noise.__self__
    three = IMM(est.imm.filter, [noise.dynamics(v) for v in (0.01, 0.1, 1.0)], None,
                np.full((3, 3), 0.05) + np.eye(3) * 0.85)
    frozen = NoiseAdaptiveIMM(three, noise.Q, None, (0.01, 0.1, 1.0), frozen=True)
    state = frozen.init(truth[:, 0], np.diag(np.square(SHORT.p0_sd)))
    whole, steps = _runs_both_ways(frozen, state, z[:60], ex.measurement_models[:60], monkeypatch)
    for field in whole._fields:
        assert _same_bits(getattr(whole, field), getattr(steps, field)), field


def test_the_fuzzy_imm_whole_run_leaves_what_it_does_not_compute_to_the_steps(monkeypatch):
    """A noise family whose subclass overrides Q (and inherits affine) and starting levels the noise family refuses
    are left to the steps: the first gives the steps' bits, the second the steps' error naming the levels."""
    from mmlib.core import linalg
    ex = experiment(SHORT, names=("FUZZY-IMMUKF",))
    est = ex.estimators["FUZZY-IMMUKF"]
    mc = MonteCarlo(ROOT_SEED, 3)
    truth, z, init = make_batch_fn(ex, mc)(range(3))

    class Louder(gnss.PVClockNoise):
        def Q(self, levels):
            return 100.0 * super().Q(levels)

    noise = est.noise.__self__
    louder = dataclasses.replace(est, noise=Louder(noise.T, noise.clock).Q)
    calls = []
    real = linalg.fuzzy_imm_run
    monkeypatch.setattr(linalg, "fuzzy_imm_run", lambda *a, **k: calls.append(1) or real(*a, **k))
    got = run(louder, init["FUZZY-IMMUKF"], z[:20], measurement_models=ex.measurement_models[:20])
    assert not calls
    plain = run(est, init["FUZZY-IMMUKF"], z[:20], measurement_models=ex.measurement_models[:20])
    assert calls == [1] and not np.array_equal(got.mean, plain.mean)
    negative = init["FUZZY-IMMUKF"]._replace(levels=np.full_like(init["FUZZY-IMMUKF"].levels, -5.0))
    with pytest.raises(ValueError, match="^levels: "):
        run(est, negative, z[:20], measurement_models=ex.measurement_models[:20])
    assert calls == [1]


@pytest.mark.parametrize("count", [2, 3])
def test_the_fuzzy_imm_whole_run_split_over_threads_changes_no_bit(count, monkeypatch):
    """Blocks of two runs split over 2 or 3 threads: the bits of one thread, each range once (the split taken)."""
    from mmlib.core import _kernels, linalg
    ex = experiment(dataclasses.replace(SHORT, dod_window=4), names=("FUZZY-IMMUKF",))
    est = ex.estimators["FUZZY-IMMUKF"]
    mc = MonteCarlo(ROOT_SEED, 7)
    truth, z, init = make_batch_fn(ex, mc)(range(7))
    monkeypatch.setattr(linalg, "FUSED_BLOCK", 2)
    with linalg.use_threads(1):
        one = run(est, init["FUZZY-IMMUKF"], z, measurement_models=ex.measurement_models)
    seen, kernel = [], _kernels.fuzzy_imm_run
    monkeypatch.setattr(_kernels, "fuzzy_imm_run", lambda *a: seen.append((a[-3], a[-2])) or kernel(*a))
    with linalg.use_threads(count):
        split = run(est, init["FUZZY-IMMUKF"], z, measurement_models=ex.measurement_models)
    for field in one._fields:
        assert _same_bits(getattr(one, field), getattr(split, field)), field
    assert sorted(seen) == linalg._run_ranges(7, 2, count) and len(seen) == count
