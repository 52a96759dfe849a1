r"""Range and bearing from the four IEEE operations and the square root only: the one definition of
:math:`\sqrt{\Delta x^2 + \Delta y^2}` and :math:`\operatorname{atan2}(\Delta y, \Delta x)` that
:func:`mmlib.core.linalg.range_bearing` evaluates on numpy arrays and its compiled twin (the kernels' ``_hypot``
and ``_atan2``) evaluates one lane at a time, in the same order.

Why not the C library's ``hypot`` and ``atan2``: they are scalar calls (numba vectorises them only with Intel's
SVML), about a third of a radar IMM-UKF step's time, and their bits depend on the library's version and on the
code path it picks for the CPU (glibc has an FMA variant of ``atan2``); numpy's own ``arctan2`` is another
implementation again on AVX-512 machines.  Built from correctly rounded ``+ - * /``, ``sqrt``, ``abs``, comparisons
and ``copysign``, with no fused multiply-add (numba without ``fastmath`` does not contract), the functions below give
the same bits on both paths, in SIMD lanes or not, on every IEEE machine.

Accuracy (:math:`u = 2^{-53}`; ``tests/test_elementary.py`` measures both against 64-bit-mantissa references):

* range: the two squares, their sum and the square root are each rounded once, :math:`|\delta| \le 2u` relative,
  i.e. below 2 ulp; the C library's ``hypot`` is within 1 ulp;
* bearing: Cephes' ``atan`` (S. L. Moshier, *Cephes Mathematical Library*, ``atan.c``; rational approximation
  :math:`\arctan u \approx u + u\,z\,P(z)/Q(z)`, :math:`z = u^2`, :math:`|u| \le 0.66`, relative error ~1e-17) after
  the octant reduction: with :math:`a = \min(|x|,|y|)`, :math:`b = \max(|x|,|y|)`, :math:`u = a/b`, or, where
  :math:`a > 0.66\,b`, :math:`u = (a - b)/(a + b)` about :math:`\pi/4` (a - b exact: a >= b/2); the angle is then a
  multiple :math:`k\pi/4` (k = 0..4, a two-part constant) plus or minus :math:`\arctan u`, with the sign of y.
  Rounding errors: u (one rounding, or, reduced, two that weigh at most 0.35 of the angle) carried into
  :math:`\arctan u` (up to 1 ulp of it where the two fall at different places in their binades), the polynomial's
  tail and last addition, the two-part sum and the approximation (~1e-17): measured at most 1.58 ulp over six million
  samples aimed at the worst quotients; the test's bound is 2 ulp.  Two divisions and no branch: the compiled loops
  run it in SIMD lanes.

The fast formulas hold for *regular* operands: :math:`\Delta x^2 + \Delta y^2` in :math:`(2^{-900}, 2^{1000})`
(both finite, not both zero, no square overflowing, the smaller square's underflow below the larger's rounding).
Elsewhere (zeros, infinities, NaN, :math:`|d|` beyond :math:`2^{500}` or below :math:`2^{-450}`) the C library's
``hypot`` and ``atan2`` answer, one value at a time on both paths (``math.hypot``, ``math.atan2``: numpy's own
``arctan2`` is another implementation on AVX-512 machines); their special values (signed zeros, :math:`\pm\pi`,
infinities) are exact.
"""
from __future__ import annotations

import math
from decimal import Decimal, localcontext

import numpy as np

_PI_DIGITS = "3.14159265358979323846264338327950288419716939937510582097494459230781640628620899862803482534211706798"


def _two_part(multiple_of_quarter_pi: int) -> tuple[float, float]:
    """``(hi, lo)``: :math:`k\\pi/4` as the nearest double and the double nearest the remainder."""
    with localcontext() as ctx:
        ctx.prec = 100
        exact = Decimal(_PI_DIGITS) * multiple_of_quarter_pi / 4
        hi = float(exact)
        return hi, float(exact - Decimal(hi))


#: :math:`k\pi/4` for k = 1..4 as two-part constants (hi, lo) (k = 0: zero)
(QPI1_HI, QPI1_LO), (QPI2_HI, QPI2_LO), (QPI3_HI, QPI3_LO), (QPI4_HI, QPI4_LO) = (_two_part(k) for k in range(1, 5))

_QPI_HI = np.array([0.0, QPI1_HI, QPI2_HI, QPI3_HI, QPI4_HI])
_QPI_LO = np.array([0.0, QPI1_LO, QPI2_LO, QPI3_LO, QPI4_LO])

#: Cephes atan.c: arctan u = u + u z P(z)/Q(z), z = u^2, |u| <= 0.66 (Q monic)
P0, P1, P2, P3, P4 = (-8.750608600031904122785e-01, -1.615753718733365076637e+01, -7.500855792314704667340e+01,
                      -1.228866684490136173410e+02, -6.485021904942025371773e+01)
Q0, Q1, Q2, Q3, Q4 = (2.485846490142306297962e+01, 1.650270098316988542046e+02, 4.328810604912902668951e+02,
                      4.853903996359136964868e+02, 1.945506571482613964425e+02)
#: above this quotient, arctan t = pi/4 + arctan((t - 1)/(t + 1))
REDUCE_ABOVE = 0.66
#: the regular range of dx^2 + dy^2 (see the module docstring): 2^-900 and 2^1000
REGULAR_MIN, REGULAR_MAX = 2.0 ** -900, 2.0 ** 1000


def range_bearing(dx: np.ndarray, dy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Range :math:`\sqrt{dx^2 + dy^2}` and bearing :math:`\operatorname{atan2}(dy, dx)` of arrays ``dx``, ``dy``
    (same shape, m) -> two arrays (m, rad in :math:`[-\pi, \pi]`): the operations of the compiled kernels' ``_hypot``
    and ``_atan2`` in their order, hence their bits; the C library's ``hypot`` and
    ``atan2`` where the operands are not regular.  The operands are taken as float64 (as the compiled path takes
    them): integer squares would wrap around, float32 ones lose the accuracy stated."""
    dx, dy = np.broadcast_arrays(np.asarray(dx, dtype=np.float64), np.asarray(dy, dtype=np.float64))
    ax, ay = np.abs(dx), np.abs(dy)
    swap = ay > ax
    small, big = np.where(swap, ax, ay), np.where(swap, ay, ax)
    with np.errstate(all="ignore"):               # the irregular lanes are replaced below
        s = dx * dx + dy * dy
        regular = (s > REGULAR_MIN) & (s < REGULAR_MAX)
        reduce = small > REDUCE_ABOVE * big
        u = np.where(reduce, small - big, small) / np.where(reduce, small + big, big)
        z = u * u
        p = (((P0 * z + P1) * z + P2) * z + P3) * z + P4
        q = ((((z + Q0) * z + Q1) * z + Q2) * z + Q3) * z + Q4
        r = u + u * (z * p / q)
        rng = np.sqrt(s)
    # the octant: k pi/4 +- r, k = 1 if reduced, mirrored by the swap (pi/2 - .) and by x < 0 (pi - .)
    negative_x = np.signbit(dx)
    k = np.where(reduce, 1.0, 0.0)
    k = np.where(swap, 2.0 - k, k)
    k = np.where(negative_x, 4.0 - k, k).astype(np.intp)
    r = np.where(swap != negative_x, -r, r)
    bearing = np.copysign(_QPI_HI[k] + (_QPI_LO[k] + r), dy)
    irregular = np.flatnonzero(~regular)
    if irregular.size:                                 # few: the C library's values one at a time, as compiled
        rng, bearing = np.array(rng, dtype=np.float64), np.array(bearing, dtype=np.float64)
    for f in irregular:
        a, b = float(dx.flat[f]), float(dy.flat[f])
        rng.flat[f], bearing.flat[f] = math.hypot(a, b), math.atan2(b, a)
    return rng, bearing
