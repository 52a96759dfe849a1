"""Range and bearing from the four operations and the square root (:mod:`mmlib.core._elementary`, the compiled
``_hypot`` / ``_atan2`` of :mod:`mmlib.core._kernels`): within the error bound the module derives (2 ulp) of
references carried with a 64-bit mantissa, the same bits on the numpy and the compiled path, the C library's exact
special values where the operands are not regular, and the compiled loop really vectorised (the reason for it)."""
from __future__ import annotations

import math

import numba
import numpy as np
import pytest

from mmlib.core import _elementary, _kernels, linalg

#: the module's bound: the quotient (0.5 ulp, carried at most 1:1), the polynomial's last addition and the final sum
#: (0.5 ulp each) for the bearing; three roundings halved by the square root plus its own for the range
MAX_ULP = 2.0
EXTENDED = np.finfo(np.longdouble).nmant >= 63

SPECIAL = [0.0, -0.0, math.inf, -math.inf, math.nan, 1.0, -1.0, 5e-324, -5e-324, 1e-300, 1e300, -1e300,
           2.0 ** -451, 2.0 ** -449, 2.0 ** 499, -(2.0 ** 501), 1e-160, 1e160]


def _operands(n: int = 400_000, seed: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """dx, dy over 22 decades, every octant, plus the octant boundaries (|x| = |y|, x = 0, y = 0, signed zeros),
    the reduction's threshold a = 0.66 b from both sides, and every pair of :data:`SPECIAL` values."""
    rng = np.random.default_rng(seed)
    dx = rng.normal(size=n) * 10.0 ** rng.uniform(-11, 11, n)
    dy = rng.normal(size=n) * 10.0 ** rng.uniform(-11, 11, n)
    a = rng.uniform(0.1, 1e4, 1000)
    edge_x = np.concatenate([a, -a, a, -a, a, np.zeros(1000), np.full(1000, -0.0)])
    edge_y = np.concatenate([a, a, -a, -a, np.zeros(1000), a, -a])
    near = np.concatenate([np.nextafter(0.66 * a, 0.0), 0.66 * a, np.nextafter(0.66 * a, 1.0)])
    pairs = np.array([(p, q) for p in SPECIAL for q in SPECIAL])
    return (np.concatenate([dx, edge_x, np.tile(a, 3), -np.tile(a, 3), pairs[:, 0]]),
            np.concatenate([dy, edge_y, near, near, pairs[:, 1]]))


def _ulps(got: np.ndarray, exact: np.ndarray) -> np.ndarray:
    """|got - exact| in units of the last place of doubles in the binade of ``exact`` (long double arithmetic; the
    binade of the exact value, not of its rounding, which may be the next power of two with twice the spacing)."""
    _, e = np.frexp(exact)
    ulp = np.maximum(np.ldexp(np.ones_like(exact), e - 53), np.longdouble(2.0) ** -1074)   # subnormals: 2^-1074
    return np.abs(((got.astype(np.longdouble) - exact) / ulp).astype(np.float64))


def _both_paths(dx: np.ndarray, dy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    x = np.zeros((dx.size, 4))
    x[:, 0], x[:, 2] = dx, dy
    with linalg.use_kernel("numpy"):
        ref = linalg.range_bearing(x, 0, 2, np.zeros(2))
    with linalg.use_kernel("numba"):
        got = linalg.range_bearing(x, 0, 2, np.zeros(2))
    return ref, got


@pytest.mark.skipif(not EXTENDED, reason="np.longdouble is not the 64-bit-mantissa format here")
def test_range_and_bearing_within_two_ulp_of_extended_precision():
    dx, dy = _operands()
    rng, bearing = _elementary.range_bearing(dx, dy)
    finite = np.isfinite(dx) & np.isfinite(dy)
    L = np.longdouble
    exact_r = np.hypot(dx[finite].astype(L), dy[finite].astype(L))
    exact_b = np.arctan2(dy[finite].astype(L), dx[finite].astype(L))
    assert _ulps(rng[finite], exact_r).max() <= MAX_ULP
    assert _ulps(bearing[finite], exact_b).max() <= MAX_ULP
    # the bound is not vacuous: the quotient alone, rounded, is off by more than half an ulp somewhere
    assert _ulps(bearing[finite], exact_b).max() > 0.5


def test_numpy_and_compiled_paths_give_the_same_bits():
    ref, got = _both_paths(*_operands())
    assert np.array_equal(ref.view(np.int64), got.view(np.int64))


def test_regular_bearings_stay_within_plus_minus_pi():
    dx, dy = _operands()
    _, bearing = _elementary.range_bearing(dx, dy)
    finite = np.isfinite(bearing)
    assert finite.sum() > 400_000
    assert (np.abs(bearing[finite]) <= math.pi).all()
    # the cut: y = +-0 with x < 0, and the largest y below 0 with it, round to +-pi at most
    _, b = _elementary.range_bearing(np.array([-1.0, -1.0, -1e300]), np.array([5e-324, -5e-324, 1e-10]))
    assert (np.abs(b) <= math.pi).all() and b[0] == math.pi and b[1] == -math.pi


@pytest.mark.parametrize("dtype", [np.int64, np.float32])
def test_other_dtypes_are_taken_as_float64_on_both_paths(dtype):
    """Integer squares would wrap around and float32 ones lose accuracy: both paths take the operands as float64
    (the compiled one always did), so 3037000500 in both coordinates is a range of 4294967296.03 m."""
    x = np.array([[3037000500, 0, 3037000500, 0], [3, 0, 4, 0]], dtype=dtype)
    sensor = np.zeros(2, dtype=dtype)
    with linalg.use_kernel("numpy"):
        ref = linalg.range_bearing(x, 0, 2, sensor)
    with linalg.use_kernel("numba"):
        got = linalg.range_bearing(x, 0, 2, sensor)
    assert ref.dtype == got.dtype == np.float64
    assert np.array_equal(ref, got)
    want = np.hypot(x[:, 0].astype(np.float64), x[:, 2].astype(np.float64))
    np.testing.assert_allclose(ref[:, 0], want, rtol=4e-16)
    assert ref[1, 0] == 5.0


def test_irregular_operands_get_the_c_librarys_exact_values():
    pairs = np.array([(p, q) for p in SPECIAL for q in SPECIAL])
    dx, dy = pairs[:, 0], pairs[:, 1]
    rng, bearing = _elementary.range_bearing(dx, dy)
    with np.errstate(over="ignore"):
        s = dx * dx + dy * dy
    irregular = ~((s > _elementary.REGULAR_MIN) & (s < _elementary.REGULAR_MAX))
    assert irregular.sum() > 100
    want_r = np.array([math.hypot(a, b) for a, b in zip(dx, dy)])
    want_b = np.array([math.atan2(b, a) for a, b in zip(dx, dy)])
    assert np.array_equal(rng[irregular].view(np.int64), want_r[irregular].view(np.int64))
    assert np.array_equal(bearing[irregular].view(np.int64), want_b[irregular].view(np.int64))
    ref, got = _both_paths(dx, dy)                      # and the compiled path's, the same C library calls
    assert np.array_equal(ref.view(np.int64), got.view(np.int64))
    # a 0-d pair, irregular and regular
    assert _elementary.range_bearing(np.array(0.0), np.array(-0.0))[1] == 0.0
    assert float(_elementary.range_bearing(np.array(3.0), np.array(4.0))[0]) == 5.0
    # the signed zeros and the cut at pi of regular operands too
    r, b = _elementary.range_bearing(np.array([1.0, -1.0, -1.0, -0.0, 0.0]), np.array([-0.0, 0.0, -0.0, 1.0, -1.0]))
    assert b.tolist() == [-0.0, math.pi, -math.pi, math.pi / 2, -math.pi / 2]
    assert math.copysign(1.0, b[0]) < 0 and r.tolist() == [1.0] * 5


def test_the_compiled_loop_is_vectorised():
    """The point of the formulas: compiled afresh (the cached kernel cannot be inspected), the loop over the lanes
    computes several doubles per instruction.  It fails if an edit brings back a call or a select LLVM cannot
    vectorise (an integer octant index did that)."""
    fresh = numba.njit(error_model="numpy")(_kernels._range_bearing_lanes.py_func)
    a = np.ones(8)
    fresh(a, a, 0.0, 0.0, np.empty(8), np.empty(8))
    ir = fresh.inspect_llvm(fresh.signatures[0])
    assert " x double>" in ir and "fdiv <" in ir
