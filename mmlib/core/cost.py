r"""A deterministic cost model: the floating-point operations of one run-step of this library's estimators.

:func:`step_flops` takes an estimator exactly as a paper runs it (a :class:`~mmlib.core.estimation.SingleModel`,
:class:`~mmlib.core.estimation.KnownModeSequence`, :class:`~mmlib.core.estimation.IMM` or
:class:`~mmlib.core.layers.adaptive_imm.NoiseAdaptiveIMM`, over any filter of :mod:`mmlib.core.filters` and the
layers of :mod:`mmlib.core.layers`) and returns ``{term: flops}`` with ``"total"`` last, a function of the state
size n, the measurement size m, the rule's points (read from the rule object), the mode count r and the models'
function costs (:func:`function_costs`).  A timing claim judged on these counts cannot flip between identical runs;
``bench/cost_model.py`` checks how well they predict measured kernel time.

**What is counted.**  The arithmetic of the equations mmlib implements (the docstrings of
:mod:`mmlib.core.filters`, :mod:`mmlib.core.estimation` and the layers), in mmlib's formulation -- the
positive-semi-definite moment combination of the mixing, the Cholesky-factor form of the Kalman update (the
Joseph form where a Jacobian H exists), the angle-aware mean of range-bearing predictions -- evaluated
*densely*: each matrix expression a dense product of its full operands (no use of the zeros of ``F`` or ``H``,
of triangular factors, nor of the symmetry of covariances).  The only structure used is the one that defines
the sigma points: :math:`X_i = \hat x + S\xi_i`, where the offset :math:`S\xi` of a pair of unit points
:math:`\pm\xi` is formed once from the k non-zero entries of :math:`\xi` (``n (2k - 1)`` flops) and added to and
subtracted from the mean (``n`` flops per point); the centre point :math:`\xi = 0` is free.  For the unscented,
cubature and central-difference rules (k = 1) that is ``3n^2``; for the fifth-degree cubature rule
``3n^2 + 5n^2(n - 1)``; for the spherical simplex-radial rule the simplex's non-zeros.

**Not counted** (mmlib does them every step; they are checks and diagnostics, not the recursion): the
symmetrisations :math:`(A + A^T)/2`, the Cholesky test of every posterior covariance, the finiteness tests, the
mixture innovation and its covariance and the marginal log-likelihood of an IMM, scalar constants of a rule or a
layer (weights, :math:`1 + \rho`, :math:`\beta - 1`), copies, concatenations and selections.

**Conventions** (those of ``bench/flops.py``, which uses this module).  One flop = one ``+ - * /``, one
comparison, one ``sqrt``, ``floor``, ``log``, ``exp``, ``atan2`` or power; negation and absolute value are free.
A dot product of length k is ``2k - 1`` flops.  Cholesky of an ``n x n`` matrix: ``n(n+1)(2n+1)/6``
(:func:`cholesky_flops`); inverse of a triangular factor: ``m + (m^3 - m)/3`` (:func:`tril_inverse_flops`); an LU
factorisation (``numpy.linalg.solve`` and ``inv``, LAPACK ``getrf``): ``n(n-1)/2 + (n-1)n(2n-1)/3`` without its
pivot search (:func:`lu_flops`); each right-hand side of a solve: ``2n^2 - n`` (:func:`solve_flops`).

**Steady state.**  Layers whose work depends on the step are counted in their steady state: strong tracking after
its first update (V smoothed), the innovation-adaptive layer with a full window, and a strong-tracking layer's
second measurement prediction in the fraction ``inflated`` of steps whose fading factor exceeds 1 (default 1, the
upper bound; in a batch one run with :math:`\lambda > 1` makes the whole batch predict again).

**Approximated** (said in the term names' docstring of :func:`step_flops`): the LU factorisations (pivot search
not counted; ``inv`` counted as LU plus n solves, LAPACK's ``getri`` orders the same work otherwise); the fuzzy
controller of Tseng et al. 2011 (every membership function counted as a full trapezoid, 7 flops, shoulders
included).  Exact for everything else, and tested exactly (``tests/test_cost.py``) against operation-counting
scalar implementations for the KF, UKF, CKF, fifth-degree CKF and an IMM.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mmlib.core.estimation import IMM, KnownModeSequence, MomentMixing, SingleModel
from mmlib.core.filters import ExtendedKalmanFilter, SigmaPointFilter
from mmlib.core.layers.adaptive import InnovationAdaptive
from mmlib.core.layers.adaptive_imm import NoiseAdaptiveIMM, WindowedNoiseAdaptiveIMM
from mmlib.core.layers.bootstrap import ObservationBootstrap
from mmlib.core.layers.fuzzy_noise import FuzzyNoiseBounds
from mmlib.core.layers.strong_tracking import StrongTracking
from mmlib.core.mixing import CubatureMixing
from mmlib.core.models import LinearMeasurement, RangeBearing
from mmlib.core.protocols import Dynamics, Estimator, Filter, MeasurementModel
from mmlib.core.rules import CentralDifference, SigmaPointRule

__all__ = ["step_flops", "filter_flops", "imm_flops", "function_costs", "FunctionCosts", "point_flops",
           "cholesky_flops", "tril_inverse_flops", "lu_flops", "solve_flops", "inverse_flops", "dot", "WRAP_FLOPS",
           "RANGE_BEARING_H_FLOPS", "RANGE_BEARING_JACOBIAN_FLOPS", "MEMBERSHIP_FLOPS"]

#: Wrapping one angle to (-pi, pi]: ``a + 2 pi floor((pi - a) / 2 pi)`` (:func:`mmlib.core.models.wrap_angle`).
WRAP_FLOPS = 5
#: Range-bearing measurement of one point: two differences to the sensor, a hypotenuse (2 products, 1 sum,
#: 1 sqrt) and one atan2.
RANGE_BEARING_H_FLOPS = 7
#: Range-bearing Jacobian at one state: two differences, r^2 (2 products, 1 sum), r (sqrt), four divisions.
RANGE_BEARING_JACOBIAN_FLOPS = 10
#: A trapezoidal membership function at one input: two ramps (a difference and a division each), their minimum
#: and the clip to [0, 1] (two comparisons); shoulders are counted as full trapezoids (approximated).
MEMBERSHIP_FLOPS = 7


def _size(n, name: str) -> int:
    """``n`` a positive integer (a matrix or vector size), else a ValueError naming ``name``."""
    if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"{name}: expected a positive integer size, got {n!r}")
    return int(n)


def dot(k: int) -> int:
    """Flops of a dot product of length ``k``: ``k`` products and ``k - 1`` sums."""
    k = _size(k, "k")
    return 2 * k - 1


def cholesky_flops(n: int) -> int:
    r"""Cholesky factor of an ``n x n`` matrix (column by column, LAPACK's ``potf2``): column j costs ``2j`` for
    its pivot (j squares subtracted), one ``sqrt``, and ``2j + 1`` for each of its ``n - 1 - j`` entries below (j
    products subtracted, one division): :math:`\sum_j (2j + 1)(n - j) = n(n+1)(2n+1)/6` (30 for n = 4, 5 for
    n = 2)."""
    n = _size(n, "n")
    return n * (n + 1) * (2 * n + 1) // 6


def tril_inverse_flops(m: int) -> int:
    r"""Inverse of an ``m x m`` lower-triangular factor by forward substitution
    (:func:`mmlib.core.linalg.tril_inverse`): ``m`` reciprocals of the diagonal, and for entry (i, j), i > j,
    ``i - j`` products, ``i - j - 1`` sums and one product by the reciprocal: :math:`m + \sum_{i>j} 2(i-j) = m +
    (m^3 - m)/3`."""
    m = _size(m, "m")
    return m + (m ** 3 - m) // 3


def lu_flops(n: int) -> int:
    r"""LU factorisation of an ``n x n`` matrix (LAPACK ``getrf``, the pivot search not counted): eliminating
    below pivot k, with ``j = n - 1 - k`` rows and columns left, costs j divisions (the multipliers) and
    :math:`j^2` products and as many differences: :math:`\sum_j (j + 2j^2) = n(n-1)/2 + (n-1)n(2n-1)/3`."""
    n = _size(n, "n")
    return n * (n - 1) // 2 + (n - 1) * n * (2 * n - 1) // 3


def solve_flops(n: int, rhs: int = 1) -> int:
    r"""Solving ``A X = B`` for ``rhs`` right-hand sides given the LU factors of the ``n x n`` ``A``: per
    right-hand side a forward substitution with the unit lower factor (row i: i products and i differences,
    :math:`n(n-1)`) and a back substitution (row i: ``2(n - 1 - i)`` and one division, :math:`n^2`):
    ``rhs (2n^2 - n)``.  The LU itself is :func:`lu_flops`."""
    n, rhs = _size(n, "n"), _size(rhs, "rhs")
    return rhs * (2 * n * n - n)


def inverse_flops(n: int) -> int:
    """Inverse of an ``n x n`` matrix (``numpy.linalg.inv``): :func:`lu_flops` and :func:`solve_flops` with the n
    columns of the identity (approximated: LAPACK ``getri`` orders the same work differently)."""
    return lu_flops(n) + solve_flops(n, n)


def point_flops(rule: SigmaPointRule, n: int) -> int:
    r"""Flops of the sigma points :math:`X_i = \hat x + S\xi_i` of ``rule`` in dimension ``n``, given the factor S:
    for each pair of unit points :math:`\pm\xi` (``rule.unit_points(n).xi``) the offset :math:`S\xi` from the k
    non-zero entries of :math:`\xi` (``n (2k - 1)``), then one sum per coordinate and point (``2n`` for the pair);
    a point without its opposite costs ``n (2k - 1) + n``; the centre (:math:`\xi = 0`) is the mean itself."""
    if not isinstance(rule, SigmaPointRule):
        raise ValueError(f"rule: expected a sigma-point rule of mmlib.core.rules, got {type(rule).__name__}")
    n = _size(n, "n")
    xi = rule.unit_points(n).xi
    done, total = set(), 0
    rows = [tuple(row) for row in xi]
    for i, row in enumerate(rows):
        if i in done:
            continue
        k = int(np.count_nonzero(xi[i]))
        if k == 0:
            continue
        opposite = next((j for j in range(i + 1, len(rows)) if j not in done and np.array_equal(xi[j], -xi[i])),
                        None)
        total += n * (2 * k - 1) + (2 * n if opposite is not None else n)
        done.add(i)
        if opposite is not None:
            done.add(opposite)
    return total


@dataclass(frozen=True)
class FunctionCosts:
    """The models' function costs, in flops: ``f`` the transition of one state or point, ``f_jacobian`` its Jacobian
    at one state (0 for linear dynamics, whose F is stored), ``h`` the measurement function of one point, ``h_jacobian``
    its Jacobian at one state (0 for a linear measurement), ``angles`` the number of angular measurement components
    (residuals wrapped, sigma-point means taken about a reference point), ``f_linear`` whether the dynamics are
    linear (the EKF's F is then the stored matrix).  Non-negative integers, else a ValueError naming the field."""

    f: int
    f_jacobian: int
    h: int
    h_jacobian: int
    angles: int = 0
    f_linear: bool = True

    def __post_init__(self):
        for name in ("f", "f_jacobian", "h", "h_jacobian", "angles"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
                raise ValueError(f"{name}: expected a non-negative integer flop count, got {v!r}")


def function_costs(dynamics: Dynamics, measurement: MeasurementModel, *, f_flops: int | None = None,
                   f_jacobian_flops: int | None = None,
                   h_flops: int | None = None, h_jacobian_flops: int | None = None) -> FunctionCosts:
    """The :class:`FunctionCosts` of a dynamics model (one mode) and a measurement model: linear dynamics
    (``is_linear`` with ``F`` (n, n)): ``f = n (2n - 1)`` (dense ``F x``), no Jacobian; a
    :class:`~mmlib.core.models.LinearMeasurement`: ``h = m (2n - 1)``, no Jacobian; a
    :class:`~mmlib.core.models.RangeBearing`: :data:`RANGE_BEARING_H_FLOPS`, :data:`RANGE_BEARING_JACOBIAN_FLOPS`,
    one angle; GNSS pseudoranges (m satellites): ``h = 10 m`` (3 differences, 3 squares, 2 sums, a sqrt and the
    clock bias per satellite), Jacobian ``12 m`` (differences, norm, three divisions).  Other models need the
    ``*_flops`` arguments (a ValueError naming ``dynamics`` or ``measurement`` otherwise); given, they override."""
    n = getattr(dynamics, "dim", None)
    if not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"dynamics: expected a dynamics model with a state dimension, got {type(dynamics).__name__}")
    linear = bool(getattr(dynamics, "is_linear", False)) and getattr(dynamics, "F", None) is not None
    if f_flops is None:
        if not linear:
            raise ValueError(f"dynamics: the cost of {type(dynamics).__name__}'s transition is unknown; pass f_flops "
                             "and f_jacobian_flops")
        f_flops = n * dot(n)
    if f_jacobian_flops is None:
        if not linear:
            raise ValueError(f"dynamics: the cost of {type(dynamics).__name__}'s Jacobian is unknown; pass "
                             "f_jacobian_flops")
        f_jacobian_flops = 0
    angles = int(sum(bool(a) for a in getattr(measurement, "angular", ())))
    m = getattr(measurement, "dim", None)
    known = None
    if isinstance(measurement, LinearMeasurement):
        known = (m * dot(n), 0)
    elif isinstance(measurement, RangeBearing):
        known = (RANGE_BEARING_H_FLOPS, RANGE_BEARING_JACOBIAN_FLOPS)
    elif type(measurement).__name__ == "Pseudoranges" and hasattr(measurement, "satellites"):
        known = (10 * m, 12 * m)
    if known is None and (h_flops is None or h_jacobian_flops is None):
        raise ValueError(f"measurement: the cost of {type(measurement).__name__}'s h and Jacobian is unknown; pass "
                         "h_flops and h_jacobian_flops")
    return FunctionCosts(int(f_flops), int(f_jacobian_flops), int(known[0] if h_flops is None else h_flops),
                         int(known[1] if h_jacobian_flops is None else h_jacobian_flops), angles, linear)


# --------------------------------------------------------------------------- one mode filter
def _residual(m: int, fc: FunctionCosts) -> int:
    """``z_a - z_b`` with the angular components wrapped."""
    return m + WRAP_FLOPS * fc.angles


def _average(p: int, m: int, fc: FunctionCosts) -> int:
    """The weighted mean of p measurement points: ``sum_i w_i Z_i``, or with angles ``ref + sum_i w_i (Z_i - ref)``
    (``ref = Z_0``, residuals wrapped) and the angles of the result wrapped."""
    if fc.angles:
        return p * _residual(m, fc) + m * dot(p) + m + WRAP_FLOPS * fc.angles
    return m * dot(p)


def _stirling(n: int, d: int, cross: bool) -> int:
    r"""Stirling covariances of :class:`~mmlib.core.rules.CentralDifference` (``form="stirling"``) from deviations
    of dimension d: :math:`a_j` (a difference and a division per entry, ``2nd``), :math:`b_j` (``3nd + d``: sum,
    ``2 d_0``, difference, scale), :math:`P_{yy} = \sum a a^T + b b^T` (``2 d^2 (2n - 1) + d^2``); with ``cross``
    also :math:`s_j = dx_j / h` (``n^2``) and :math:`P_{xy} = \sum s a^T` (``n d (2n - 1)``)."""
    flops = 2 * n * d + 3 * n * d + d + 2 * d * d * dot(n) + d * d
    if cross:
        flops += n * n + n * d * dot(n)
    return flops


def _update(n: int, m: int, fc: FunctionCosts, joseph: bool) -> int:
    r"""The shared Kalman update (:func:`mmlib.core.filters.kalman_update`): :math:`\nu`, :math:`S = LL^T`,
    :math:`L^{-1}`, :math:`A = P_{xz}L^{-T}`, :math:`e = L^{-1}\nu`, :math:`\hat x + Ae`, then :math:`P - AA^T`, or the
    Joseph form (:math:`K = AL^{-1}`, :math:`I - KH`, :math:`(I-KH)P(I-KH)^T + (KR)K^T`), NIS :math:`e^Te`, and
    :math:`\log L = -(\mathrm{NIS} + 2\sum\log L_{ii} + m\log 2\pi)/2` (m logs, m - 1 sums, a doubling, three more)."""
    common = (_residual(m, fc) + cholesky_flops(m) + tril_inverse_flops(m) + n * m * dot(m) + m * dot(m)
              + n * dot(m) + n)
    if joseph:
        cov = (n * m * dot(m) + n * n * dot(m) + n * n + 2 * n * n * dot(n) + n * m * dot(m) + n * n * dot(m)
               + n * n)
    else:
        cov = n * n * dot(m) + n * n
    return common + cov + dot(m) + (m + (m - 1) + 1) + 3


def _base_terms(filt, n: int, m: int, fc: FunctionCosts) -> tuple:
    """``(predict terms, measurement-prediction terms, joseph)`` of an EKF or a sigma-point filter."""
    if isinstance(filt, ExtendedKalmanFilter):
        predict = {"predict: Jacobian": 0 if fc.f_linear else fc.f_jacobian,
                   "predict: transition": fc.f,
                   "predict: moments": 2 * n * n * dot(n) + n * n}          # F (P F^T) + Q
        mp = {"measurement prediction: Jacobian": fc.h_jacobian,
              "measurement prediction: h": fc.h,
              "measurement prediction: moments": n * m * dot(n) + m * m * dot(n) + m * m}   # P H^T, H (P H^T) + R
        return predict, mp, True
    if isinstance(filt, SigmaPointFilter):
        rule = filt.rule
        p = rule.num_points(n)
        pts = point_flops(rule, n)
        stirling = isinstance(rule, CentralDifference) and not rule.weighted_moments
        if stirling:
            moments = n * dot(p) + p * n + _stirling(n, n, False) + n * n
            mmoments = (_average(p, m, fc) + p * _residual(m, fc) + p * n + _stirling(n, m, True) + m * m)
        else:
            moments = n * dot(p) + 2 * p * n + n * n * dot(p) + n * n
            mmoments = (_average(p, m, fc) + p * _residual(m, fc) + p * n + p * m + m * m * dot(p)
                        + n * m * dot(p) + m * m)
        predict = {"predict: Cholesky": cholesky_flops(n), "predict: sigma points": pts,
                   "predict: transition": p * fc.f, "predict: moments": moments}
        mp = {"measurement prediction: Cholesky": cholesky_flops(n), "measurement prediction: sigma points": pts,
              "measurement prediction: h": p * fc.h, "measurement prediction: moments": mmoments}
        return predict, mp, False
    raise ValueError(f"estimator: its filter {type(filt).__name__} is not one the cost model knows (an EKF/KF, a "
                     "SigmaPointFilter, or StrongTracking, ObservationBootstrap, InnovationAdaptive over one)")


def filter_flops(filt: Filter, n: int, m: int, functions: FunctionCosts, *, inflated: float = 1.0) -> dict:
    r"""Flops of one step (time update, measurement prediction, update and the layer's own work) of one mode
    filter ``filt`` on an ``n``-state and an ``m``-dimensional measurement with the models' ``functions``:
    ``{term: flops}`` in the order of the algorithm (zero terms left out), without ``"total"``.

    Filters: :class:`~mmlib.core.filters.ExtendedKalmanFilter` (the KF on linear models): :math:`f(\hat x)`,
    :math:`FPF^T + Q` (two dense n-cube products), :math:`h(\hat x)`, :math:`PH^T` and :math:`H(PH^T) + R`, the
    Joseph-form update; :class:`~mmlib.core.filters.SigmaPointFilter` with any rule: Cholesky factor, points
    (:func:`point_flops`), p transitions, weighted mean and covariance (+ Q); fresh points from :math:`P^-`, p
    measurement functions, the (angle-aware) mean, S (+ R) and :math:`P_{xz}` (the central-difference rule's
    Stirling form: its own covariances, :func:`_stirling`), the update :math:`P - AA^T`.  Layers (each over any of
    these):

    * :class:`~mmlib.core.layers.strong_tracking.StrongTracking` (Liu & Wu 2017, Eqs. 13-19, 28): the innovation,
      :math:`vv^T` and the smoothing of V (``4 m^2``), the fading factor (statistical form: LU of :math:`P^l`, m
      solves, :math:`X^TQX`, N and M; Jacobian form: H, :math:`HQH^T`, :math:`H(P-Q)H^T`, N), the traces, ratio,
      test and maximum; in the fraction ``inflated`` of steps :math:`\lambda(P-Q)+Q` (``3n^2``) and a second
      measurement prediction;
    * :class:`~mmlib.core.layers.bootstrap.ObservationBootstrap` (Hu et al. 2017, Eqs. 15-24), N = ``n_boot``:
      the factor of R and :math:`z + L\epsilon^n`, N + 1 Kalman updates (N with :math:`S + (c-1)R`; printed
      covariance: the gain by a solve and :math:`K(c-1)RK^T`), the fusion (N + 2 inverses, a Cholesky test,
      sums and two sets of products) and the likelihood (log-sum-exp or sum);
    * :class:`~mmlib.core.layers.adaptive.InnovationAdaptive` (NAUKF, Zhou et al. 2017, Eqs. 27-39) with a full
      window W: the innovation, :math:`\hat C = \sum\nu\nu^T/W`, the matching test and :math:`\zeta(P-Q)+Q`, and an
      update without H (the layer's prediction has none).  ``inflate_only`` (an eigendecomposition) is refused.

    ``inflated`` in [0, 1]: the fraction of steps whose fading factor exceeds 1 (the flops are then fractional).
    A filter the model does not know is a ValueError naming ``estimator``."""
    if not (isinstance(inflated, (int, float, np.floating)) and not isinstance(inflated, bool)
            and 0.0 <= float(inflated) <= 1.0):
        raise ValueError(f"inflated: expected the fraction of steps with a fading factor > 1, in [0, 1], got "
                         f"{inflated!r}")
    if isinstance(filt, StrongTracking):
        predict, mp, joseph = _base_terms(filt.base, n, m, functions)
        if filt.form == "jacobian":
            fading = (functions.h_jacobian + 2 * (m * n * dot(n) + m * m * dot(n)) + 3 * m * m + n * n)
        else:
            fading = lu_flops(n) + solve_flops(n, m) + m * n * dot(n) + m * m * dot(n) + 3 * m * m + 4 * m * m
        fading += 2 * (m - 1) + 3
        mp_total = sum(mp.values())
        terms = {**predict, **mp,
                 "strong tracking: innovation": _residual(m, functions),
                 "strong tracking: V": 4 * m * m,
                 "strong tracking: fading factor": fading,
                 "strong tracking: inflation": _scaled(3 * n * n, inflated),
                 "strong tracking: measurement prediction again": _scaled(mp_total, inflated),
                 "update": _update(n, m, functions, joseph)}
    elif isinstance(filt, ObservationBootstrap):
        predict, mp, joseph = _base_terms(filt.base, n, m, functions)
        N = filt.n_boot
        terms = {**predict, **mp}
        if N == 0:
            terms["update"] = _update(n, m, functions, joseph)
        else:
            members = (N + 1) * _update(n, m, functions, joseph) + N * 2 * m * m + (N * m * m if joseph else 0)
            if filt.covariance == "printed":
                members += N * (lu_flops(m) + solve_flops(m, n) + n * m * dot(m) + n * n * dot(m) + 2 * n * n)
            terms.update({
                "bootstrap: observations": cholesky_flops(m) + N * m * dot(m) + N * m,
                "bootstrap: member updates": members,
                "bootstrap: fusion": ((N + 2) * inverse_flops(n) + N * n * n + cholesky_flops(n)
                                      + (N + 1) * n * dot(n) + N * n + n * dot(n)),
                "bootstrap: likelihood": 4 * N + 4 if filt.likelihood == "sum" else N})
    elif isinstance(filt, InnovationAdaptive):
        if filt.inflate_only:
            raise ValueError("estimator: InnovationAdaptive(inflate_only=True) takes an eigendecomposition per step, "
                             "which has no fixed operation count")
        predict, mp, _ = _base_terms(filt.base, n, m, functions)
        W = filt.window
        terms = {**predict, **mp,
                 "adaptive: innovation": _residual(m, functions),
                 "adaptive: innovation covariance": m * m * dot(W) + m * m}
        if filt.zeta:
            terms["adaptive: matching test and inflation"] = (m * m + (m - 1) + (m - 1) + 1 + 1 + n * n + m * m
                                                              + (m - 1) + (n - 1) + 1 + 1 + 2 * n * n)
        terms["update"] = _update(n, m, functions, False)
    else:
        predict, mp, joseph = _base_terms(filt, n, m, functions)
        terms = {**predict, **mp, "update": _update(n, m, functions, joseph)}
    return {k: v for k, v in terms.items() if v}


def _scaled(flops: int, fraction: float):
    """``flops`` times ``fraction``, an integer when the fraction is 0 or 1."""
    return flops if fraction == 1 else (0 if fraction == 0 else flops * float(fraction))


# --------------------------------------------------------------------------- the IMM
def imm_flops(mode_terms: dict, n: int, r: int, *, mixing: str = "moment", with_cov: bool = False) -> dict:
    r"""Flops of one IMM cycle with ``r`` modes on an ``n``-state whose mode filter costs ``mode_terms`` per mode
    (:func:`filter_flops`); ``{term: flops}`` with ``"total"`` last.

    * mixing weights :math:`c_j = \sum_i p_{ij}\mu_i`, :math:`\mu_{i|j} = p_{ij}\mu_i / c_j` (the products shared):
      ``r^2 + r(r-1) + r^2``;
    * ``mixing="moment"`` (:class:`~mmlib.core.estimation.MomentMixing`): mixed means ``r n (2r-1)`` and the
      positive-semi-definite covariances :math:`\sum_i\mu_{i|j}P_i + \sum_i(\mu_{i|j}d_{ji})d_{ji}^T`
      (``2 r^2 n + 2 r n^2 (2r-1) + r n^2``); ``"cubature"`` (:class:`~mmlib.core.mixing.CubatureMixing`, Zhou et al.
      2017): the r factors, the centres, the ``2 r n`` points of each target mode as printed, their mean and
      covariance;
    * the r mode filters (every per-mode term times r);
    * mode probabilities :math:`\mu_j = \exp(\log L_j + \log c_j - \max)/\sum` (``7r - 2``) and the fused mean
      ``n (2r - 1)``; ``with_cov``: the fused covariance (``2 r n + 2 n^2 (2r - 1) + n^2``; the papers' timings run
      without it)."""
    for name, v in (("n", n), ("r", r)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ValueError(f"{name}: expected a positive integer, got {v!r}")
    terms = {"mixing weights": r * r + r * (r - 1) + r * r, "mixed means": r * n * dot(r)}
    if mixing == "moment":
        terms["mixed covariances"] = r * r * n + r * r * n + 2 * r * n * n * dot(r) + r * n * n
    elif mixing == "cubature":
        l = r * n
        terms["mixed covariances"] = (r * cholesky_flops(n) + r * r + r * r * n * n + 2 * r * l * n
                                      + r * n * (2 * l - 1) + r * n + r * 2 * l * n + r * n * n * dot(2 * l)
                                      + r * n * n)
    else:
        raise ValueError(f"mixing: expected 'moment' or 'cubature', got {mixing!r}")
    for k, v in mode_terms.items():
        terms[k] = r * v
    terms["mode probabilities"] = r + r + (r - 1) + r + r + (r - 1) + r
    terms["combination"] = n * dot(r) + ((2 * r * n + 2 * n * n * dot(r) + n * n) if with_cov else 0)
    terms = {k: v for k, v in terms.items() if v}
    terms["total"] = sum(terms.values())
    return terms


def _controller_flops(controller, m: int, r: int, window: int) -> int:
    r"""The FLAS of Tseng et al. 2011 (:class:`~mmlib.core.layers.fuzzy_noise.FuzzyNoiseBounds`): the reference
    variance (trace of S over m, or none for ``normalise="measurement"``, a constant), the degrees of divergence
    (:math:`\sum\nu^2/m/\bar s`: ``2m + 1``; :math:`\sum|\nu|/m/\sqrt{\bar s}`: ``m + 2``), the window mean (W > 1:
    ``2 (W - 1) + 2``), the memberships (:data:`MEMBERSHIP_FLOPS` each, approximated), the firing strengths (one
    product per rule and per first-input set), their sum, the weighted consequents, the division and the power
    of ten per output."""
    if not isinstance(controller, FuzzyNoiseBounds):
        raise ValueError(f"estimator: its controller {type(controller).__name__} is not one the cost model knows "
                         "(FuzzyNoiseBounds)")
    ref = m if controller.normalise == "innovation" else 0         # trace (m - 1 sums) and / m
    dod = (m + (m - 1) + 1 + 1) + ((m - 1) + 1 + 1 + 1)
    if window > 1:
        dod += 2 * (2 * (window - 1) + 1)
    sizes = [len(s) for s in controller.system.inputs]
    rules = int(np.prod(sizes))
    outputs = controller.system.consequents.shape[-1]
    fuzzy = MEMBERSHIP_FLOPS * sum(sizes) + sum(int(np.prod(sizes[:i + 1])) for i in range(len(sizes)))
    fuzzy += (rules - 1) + outputs * dot(rules) + outputs + outputs
    return ref + dod + fuzzy


def step_flops(estimator: Estimator, *, measurement: MeasurementModel | None = None, with_cov: bool = False,
               inflated: float = 1.0,
               f_flops: int | None = None, f_jacobian_flops: int | None = None, h_flops: int | None = None,
               h_jacobian_flops: int | None = None) -> dict:
    """Flops of one run-step of ``estimator`` (module docstring): ``{term: flops}`` in the order of the algorithm
    (zero terms left out) with ``"total"`` last.

    ``estimator``: a :class:`~mmlib.core.estimation.SingleModel` or
    :class:`~mmlib.core.estimation.KnownModeSequence` (one filter step, :func:`filter_flops`), an
    :class:`~mmlib.core.estimation.IMM` (:func:`imm_flops`, moment or cubature mixing) or a
    :class:`~mmlib.core.layers.adaptive_imm.NoiseAdaptiveIMM` (the IMM, ``2 r n^2`` for the modes' noise
    :math:`\\ell_j U + Q_0` and the controller's work, :func:`_controller_flops`; ``frozen``: none).
    ``measurement``: the model of the step when the estimator has none (a ValueError naming ``measurement``
    otherwise); ``with_cov``: an IMM's fused covariance counted (the papers' timings run ``keep_cov=False``);
    ``inflated``: :func:`filter_flops`; the ``*_flops``: :func:`function_costs`.  An estimator, filter, mixing
    or controller the model does not know is a ValueError naming ``estimator``."""
    if not isinstance(with_cov, (bool, np.bool_)):
        raise ValueError(f"with_cov: expected a bool, got {with_cov!r}")
    extra = {}
    if isinstance(estimator, NoiseAdaptiveIMM):
        imm = estimator.imm
        r = imm.n_modes
        n = imm.stacked.dim
        noise_owner = getattr(estimator.noise, "__self__", None)
        if not (hasattr(noise_owner, "unit") and hasattr(noise_owner, "base")):
            raise ValueError("estimator: the cost of its noise family is unknown (expected the Q of a family "
                             "level * unit + base, e.g. mmlib.core.gnss.PVClockNoise)")
        extra["adaptive IMM: process noise"] = 2 * r * n * n
        meas = imm.measurement if measurement is None else measurement
        if not estimator.frozen:
            if meas is None:
                raise ValueError("measurement: the estimator has no measurement model; pass the step's")
            window = estimator.window if isinstance(estimator, WindowedNoiseAdaptiveIMM) else 1
            extra["adaptive IMM: controller"] = _controller_flops(estimator.controller, meas.dim, r, window)
        estimator = imm
    if isinstance(estimator, IMM):
        dynamics, r = estimator.dynamics[0], estimator.n_modes
        filt = estimator.filter
    elif isinstance(estimator, (SingleModel, KnownModeSequence)):
        dynamics = estimator.dynamics if isinstance(estimator, SingleModel) else estimator.dynamics[0]
        filt, r = estimator.filter, None
    else:
        raise ValueError(f"estimator: the cost model knows SingleModel, KnownModeSequence, IMM and NoiseAdaptiveIMM, "
                         f"got {type(estimator).__name__}")
    meas = estimator.measurement if measurement is None else measurement
    if meas is None or not hasattr(meas, "dim"):
        raise ValueError("measurement: the estimator has no measurement model; pass the step's")
    n, m = int(dynamics.dim), int(meas.dim)
    fc = function_costs(dynamics, meas, f_flops=f_flops, f_jacobian_flops=f_jacobian_flops, h_flops=h_flops,
                        h_jacobian_flops=h_jacobian_flops)
    mode = filter_flops(filt, n, m, fc, inflated=inflated)
    if r is None:
        terms = dict(mode)
        terms["total"] = sum(terms.values())
        return terms
    mixing = estimator.mixing
    if type(mixing) is MomentMixing:
        kind = "moment"
    elif isinstance(mixing, CubatureMixing):
        kind = "cubature"
    else:
        raise ValueError(f"estimator: its mixing {type(mixing).__name__} is not one the cost model knows")
    terms = imm_flops(mode, n, r, mixing=kind, with_cov=bool(with_cov))
    if extra:
        total = terms.pop("total")
        terms.update(extra)
        terms["total"] = total + sum(extra.values())
    return terms
