r"""Motion and measurement models, batched over any leading axes.

State ordering (stated once, used everywhere): per Cartesian axis, position
then its derivatives, axes in order x, y: ``[x, vx, y, vy]`` for constant
velocity / coordinated turn, ``[x, vx, ax, y, vy, ay]`` for constant
acceleration.  This is the ordering of Zhu et al. 2016 (Sec. 4), Hu et al.
2017 and Liu & Wu 2017.

Dynamics are ``x_k = f(x_{k-1}) + w_k`` with :math:`w_k \sim N(0, Q)`,
:math:`Q = G q G^T`, ``G`` the noise gain.  Measurements are
``z_k = h(x_k) + v_k`` with :math:`v_k \sim N(0, R)`.
"""
from __future__ import annotations

import math
from dataclasses import InitVar, dataclass, field
from typing import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from mmlib.core._validate import (RTOL, as_float_array, check_bool, check_covariance, check_finite, check_has,
                                  check_index, check_matrix, check_positive_int, check_scalar)
from mmlib.core import linalg
from mmlib.core.linalg import linear_transition, matmul_rows, wrap_angle
from mmlib.core.protocols import Dynamics, MeasurementModel

__all__ = ["constant_velocity", "constant_acceleration", "coordinated_turn", "CoordinatedTurnRate", "range_bearing",
           "position_measurement", "RangeBearing", "LinearMeasurement", "LinearGaussianDynamics", "from_noise_gain",
           "acceleration_noise_gain", "coordinated_turn_matrix", "StackedDynamics", "position_indices", "SensorFault",
           "radar_drift", "TWO_PI", "psd_by_construction", "is_psd_by_construction"]


TWO_PI = 2.0 * math.pi


def psd_by_construction(fn: Callable) -> Callable:
    """Mark ``fn``, a process-noise family's ``levels -> Q`` (..., n, n), as returning for every level it accepts (it
    raises a ValueError for the others) a finite, symmetric, positive semi-definite Q by construction, proved in its
    docstring (e.g. :meth:`mmlib.core.gnss.PVClockNoise.Q`).  A :class:`mmlib.core.layers.adaptive_imm.NoiseAdaptiveIMM`
    over a marked family builds each step's dynamics without re-checking Q (:meth:`StackedDynamics.with_noise` with
    ``check=False``); an unmarked callable is checked at every step.  Returns ``fn`` itself, marked."""
    if not callable(fn):
        raise ValueError(f"fn: expected a function levels -> Q, got {type(fn).__name__}")
    try:
        fn.psd_by_construction = True
    except AttributeError:
        raise ValueError(f"fn: expected a function (mark it where it is defined, not a bound method), got "
                         f"{type(fn).__name__}") from None
    return fn


def is_psd_by_construction(noise: Callable) -> bool:
    """Whether ``noise`` (a function, or a bound method) is marked by :func:`psd_by_construction`."""
    return getattr(noise, "psd_by_construction", False) is True


def _psd_factor(q: np.ndarray) -> np.ndarray:
    """A factor L with L L^T = q for a PSD q (Cholesky when PD, else eigen)."""
    try:
        return np.linalg.cholesky(q)
    except np.linalg.LinAlgError:
        w, v = np.linalg.eigh(q)
        return v * np.sqrt(np.clip(w, 0.0, None))


def _check_name(value, name: str = "name") -> str:
    if not isinstance(value, str):
        raise ValueError(f"{name}: expected a string, got {type(value).__name__}")
    return value


def _freeze(obj, **arrays) -> None:
    """Store read-only float64 copies of validated arrays on a frozen dataclass (the caller's arrays are
    neither aliased nor made read-only)."""
    for attr, arr in arrays.items():
        arr = np.array(arr, dtype=float)
        arr.setflags(write=False)
        object.__setattr__(obj, attr, arr)


def _cholesky_of_R(obj) -> np.ndarray:
    """The lower Cholesky factor of the read-only ``obj.R`` of a frozen measurement model, computed on its first use and
    kept on ``obj`` (read-only, shared by every caller): a pure function of ``R``, asked for at every step of the
    observation bootstrap and by every protocol check of the model (``hasattr`` evaluates the property)."""
    L = obj.__dict__.get("_noise_factor")
    if L is None:
        L = np.linalg.cholesky(obj.R)
        L.setflags(write=False)
        object.__setattr__(obj, "_noise_factor", L)
    return L


def _check_period(T) -> float:
    return check_scalar(T, "T", positive=True)


# --------------------------------------------------------------------------- dynamics
@dataclass(frozen=True, eq=False)
class LinearGaussianDynamics:
    """``x_k = F x_{k-1} + w_k``, ``w_k ~ N(0, Q)``; ``Q = noise_factor @ noise_factor.T``.

    ``F`` (n, n): the transition over one sampling interval; ``Q`` (n, n): symmetric positive
    semi-definite process-noise covariance, in squared state units (SI: m^2, m^2/s^2, ... for the
    ``[x, vx, y, vy]`` ordering of this module); ``noise_factor`` (n, k), k >= 1, with
    ``noise_factor @ noise_factor.T == Q`` to ``RTOL`` of Q's largest entry (it draws the truth's noise,
    Q is what the filters assume: the two must agree); ``name`` a string.  Lists and other array-likes
    are accepted; the arrays are stored as read-only float64 copies."""

    F: np.ndarray
    Q: np.ndarray
    noise_factor: np.ndarray
    name: str = "linear"
    is_linear: bool = field(default=True, init=False)

    def __post_init__(self):
        _check_name(self.name)
        F = check_matrix(self.F, "F")
        n = F.shape[0]
        if F.shape != (n, n) or n < 1:
            raise ValueError(f"F: expected a square (n, n) transition matrix, got shape {F.shape}")
        Q = check_covariance(self.Q, "Q", n, semidefinite=True)
        L = check_matrix(self.noise_factor, "noise_factor")
        if L.shape[0] != n or L.shape[1] < 1:
            raise ValueError(f"noise_factor: expected shape ({n}, k >= 1) for a {n}-state model, got {L.shape}")
        scale = max(float(np.max(np.abs(Q))), np.finfo(float).tiny)
        mismatch = float(np.max(np.abs(L @ L.T - Q)))
        if not mismatch <= RTOL * scale:
            raise ValueError(f"noise_factor: noise_factor @ noise_factor.T differs from Q by {mismatch:.3g} "
                             f"(largest entry of Q {scale:.3g}); the factor must reproduce Q")
        _freeze(self, F=F, Q=Q, noise_factor=L)

    @property
    def dim(self) -> int:
        """State dimension n (the size of ``F``)."""
        return self.F.shape[0]

    def transition(self, x: np.ndarray) -> np.ndarray:
        """:math:`F x` for states or sigma points ``x`` (..., n), any leading axes (e.g. (N, n) or
        (N, p, n), N runs, p points); returns (..., n) in the state's units.  One GEMM for the whole
        stack, the same bits per run whatever N (:func:`mmlib.core.linalg.linear_transition`)."""
        return linear_transition(x, self.F)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        r""":math:`\partial f/\partial x = F` at states ``x`` (..., n): ``F`` broadcast to (..., n, n), a
        read-only view (the values of ``x`` are not used)."""
        return np.broadcast_to(self.F, x.shape[:-1] + self.F.shape)

    def with_noise(self, Q: np.ndarray) -> "LinearGaussianDynamics":
        """Same transition with another process-noise covariance ``Q`` (n, n), symmetric positive
        semi-definite (e.g. adapted online)."""
        q = check_covariance(Q, "Q", self.dim, semidefinite=True)
        return LinearGaussianDynamics(self.F.copy(), q.copy(), _psd_factor(q), self.name)


def from_noise_gain(F: np.ndarray, G: np.ndarray, q: np.ndarray | float,
                    name: str = "linear") -> LinearGaussianDynamics:
    """Dynamics with ``Q = G q G^T``: ``F`` (n, n) transition, ``G`` (n, k) noise gain, ``q`` (k, k)
    positive semi-definite covariance of the k noise inputs (e.g. acceleration, (m/s^2)^2), or a
    scalar >= 0 for isotropic noise ``q I``; ``name`` a string.  The noise factor is ``G L`` with
    ``L L^T = q`` (Cholesky, or an eigen-factor for a singular ``q``).  A non-square ``F``, a ``G``
    with another number of rows or a ``q`` that is not a (k, k) covariance is a ValueError naming it."""
    _check_name(name)
    F = check_matrix(F, "F")
    if F.shape[0] != F.shape[1] or F.shape[0] < 1:
        raise ValueError(f"F: expected a square (n, n) transition matrix, got shape {F.shape}")
    G = check_matrix(G, "G")
    if G.shape[0] != F.shape[0] or G.shape[1] < 1:
        raise ValueError(f"G: expected shape ({F.shape[0]}, k >= 1) (rows = state dimension), got shape {G.shape}")
    q = as_float_array(q, "q")
    q = check_scalar(q, "q", nonnegative=True) * np.eye(G.shape[1]) if q.ndim == 0 else q
    q = check_covariance(q, "q", G.shape[1], semidefinite=True)
    Q = G @ q @ G.T
    return LinearGaussianDynamics(F, 0.5 * (Q + Q.T), G @ _psd_factor(q), name)


def acceleration_noise_gain(T: float, order: int = 2, axes: int = 2) -> np.ndarray:
    r"""Discrete white-noise gain per axis (Bar-Shalom, Li & Kirubarajan 2001, Sec. 6.3.2):
    ``[T^2/2, T]^T`` for order 2 (CV), ``[T^2/2, T, 1]^T`` for order 3 (CA), block-diagonal over axes.
    For order 2, two axes this is the ``G`` of Zhu et al. 2016 (Sec. 4).

    ``T`` sampling interval (s, > 0); ``order`` 2 or 3; ``axes`` >= 1.  Shape (order * axes, axes)."""
    T = _check_period(T)
    order = check_positive_int(order, "order")
    if order not in (2, 3):
        raise ValueError(f"order: expected 2 (constant velocity) or 3 (constant acceleration), got {order}")
    axes = check_positive_int(axes, "axes")
    block = {2: [[T * T / 2.0], [T]], 3: [[T * T / 2.0], [T], [1.0]]}[order]
    return np.kron(np.eye(axes), np.array(block))


def constant_velocity(T: float, q: np.ndarray | float, G: np.ndarray | None = None) -> LinearGaussianDynamics:
    r"""Constant velocity, state ``[x, vx, y, vy]`` (m, m/s): ``T`` sampling interval (s, > 0), ``q``
    acceleration-noise variance ((m/s^2)^2, scalar or (k, k)), ``G`` (4, k) noise gain (default
    :func:`acceleration_noise_gain`).

    :math:`F = \mathrm{blkdiag}(F_1, F_1)`, :math:`F_1 = [[1, T], [0, 1]]`, :math:`Q = G q G^T`.  With the
    default gain ``[T^2/2, T]^T`` per axis the noise is a white acceleration held constant over each
    interval (the discrete white-noise acceleration model, Bar-Shalom et al. 2001, Sec. 6.3.2) and ``q``
    is the variance of that acceleration per axis, in (m/s^2)^2 (e.g. ``q = 0.1**2`` for a 0.1 m/s^2
    standard deviation): a scalar is the same variance on x and y, a (2, 2) matrix their covariance.
    With a user ``G``, ``q`` is in the squared units of G's inputs.  Name ``"CV"``."""
    T = _check_period(T)
    F = np.kron(np.eye(2), np.array([[1.0, T], [0.0, 1.0]]))
    return from_noise_gain(F, acceleration_noise_gain(T) if G is None else G, q, "CV")


def constant_acceleration(T: float, q: np.ndarray | float, G: np.ndarray | None = None) -> LinearGaussianDynamics:
    r"""Constant acceleration, state ``[x, vx, ax, y, vy, ay]`` (m, m/s, m/s^2): ``T`` sampling interval
    (s, > 0), ``q`` noise variance (scalar or (k, k)), ``G`` (6, k) noise gain (default
    :func:`acceleration_noise_gain` of order 3).

    :math:`F = \mathrm{blkdiag}(F_1, F_1)`, :math:`F_1 = [[1, T, T^2/2], [0, 1, T], [0, 0, 1]]`,
    :math:`Q = G q G^T`.  With the default gain ``[T^2/2, T, 1]^T`` per axis the noise is the
    acceleration increment over one interval (the discrete Wiener-process acceleration model,
    Bar-Shalom et al. 2001) and ``q`` is its variance per axis, in (m/s^2)^2 (a scalar: the same on x
    and y; (2, 2): their covariance).  With a user ``G``, ``q`` is in the squared units of G's inputs.
    Name ``"CA"``."""
    T = _check_period(T)
    F1 = np.array([[1.0, T, T * T / 2.0], [0.0, 1.0, T], [0.0, 0.0, 1.0]])
    F = np.kron(np.eye(2), F1)
    return from_noise_gain(F, acceleration_noise_gain(T, 3) if G is None else G, q, "CA")


def coordinated_turn_matrix(T: float, omega: float) -> np.ndarray:
    r"""Coordinated turn with known rate ``omega`` (rad/s, finite, positive = counter-clockwise) over
    ``T`` seconds (> 0), state ``[x, vx, y, vy]`` (m, m/s); shape (4, 4)
    (Zhu et al. 2016, Eq. 61; Bar-Shalom et al. 2001, Eq. 11.7.1-4).
    ``omega -> 0`` gives the constant-velocity matrix."""
    T = _check_period(T)
    omega = check_scalar(omega, "omega")
    wt = omega * T
    if not math.isfinite(wt):
        raise ValueError(f"omega: turn angle omega * T overflows (omega={omega!r} rad/s, T={T!r} s)")
    if abs(wt) < 1e-12:
        return np.kron(np.eye(2), np.array([[1.0, T], [0.0, 1.0]]))
    s, c = math.sin(wt), math.cos(wt)
    return np.array([
        [1.0, s / omega, 0.0, (c - 1.0) / omega],
        [0.0, c, 0.0, -s],
        [0.0, (1.0 - c) / omega, 1.0, s / omega],
        [0.0, s, 0.0, c],
    ])


def coordinated_turn(T: float, omega: float, q: np.ndarray | float,
                     G: np.ndarray | None = None) -> LinearGaussianDynamics:
    """Coordinated turn at the known rate ``omega`` (rad/s) of :func:`coordinated_turn_matrix`, state
    ``[x, vx, y, vy]`` (m, m/s); ``T`` (s, > 0), ``q`` and ``G`` as in :func:`constant_velocity` (with the
    default gain ``q`` is the acceleration-noise variance per axis, (m/s^2)^2).

    ``omega`` is in **rad/s**, not degrees: ``omega=3`` is a turn of 172 deg/s, while a 3 deg/s turn is
    ``math.radians(3)`` = 0.0524 rad/s.  Positive ``omega`` turns counter-clockwise.  Transition of
    Zhu et al. 2016, Eq. 61; ``Q = G q G^T``; the model's name states the rate in deg/s, e.g.
    ``"CT(+3 deg/s)"``."""
    F = coordinated_turn_matrix(T, omega)
    omega = check_scalar(omega, "omega")
    return from_noise_gain(F, acceleration_noise_gain(T) if G is None else G, q,
                           f"CT({math.degrees(omega):+.3g} deg/s)")


# turn-rate functions: sin(t)/t, (1 - cos t)/t and their derivatives, by their Taylor series for |t| < 1 (no
# division by a small t, no cancellation) and in closed form beyond; 10 terms leave a truncation error below
# 1/21! ~ 2e-20 at |t| = 1
_SERIES_TERMS = 10
_SERIES_LIMIT = 1.0


def _turn_functions(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    r""":math:`s_1 = \sin\theta/\theta`, :math:`c_1 = (1-\cos\theta)/\theta` and their derivatives
    :math:`s_1' = (\theta\cos\theta - \sin\theta)/\theta^2`, :math:`c_1' = (\theta\sin\theta - 1 + \cos\theta)/\theta^2`
    for turn angles ``theta`` (any shape, rad), continuous through ``theta = 0`` (1, 0, 0, 1/2 there)."""
    t = np.asarray(theta, dtype=float)
    small = np.abs(t) < _SERIES_LIMIT
    ts = np.where(small, t, 0.0)
    t2 = ts * ts
    s1 = np.zeros_like(ts)
    c1 = np.zeros_like(ts)
    ds1 = np.zeros_like(ts)
    dc1 = np.zeros_like(ts)
    # Horner from the highest term: s1 = sum (-t^2)^k/(2k+1)!, c1 = t sum (-t^2)^k/(2k+2)!,
    # ds1 = t sum (-t^2)^k (-(2k+2))/(2k+3)!, dc1 = sum (-t^2)^k (2k+1)/(2k+2)!
    for k in range(_SERIES_TERMS - 1, -1, -1):
        s1 = s1 * -t2 + 1.0 / math.factorial(2 * k + 1)
        c1 = c1 * -t2 + 1.0 / math.factorial(2 * k + 2)
        ds1 = ds1 * -t2 - (2 * k + 2) / math.factorial(2 * k + 3)
        dc1 = dc1 * -t2 + (2 * k + 1) / math.factorial(2 * k + 2)
    c1, ds1 = c1 * ts, ds1 * ts
    tl = np.where(small, 1.0, t)                       # large angles only: no division by a small number
    sin, cos = np.sin(tl), np.cos(tl)
    one_minus_cos = 2.0 * np.sin(0.5 * tl) ** 2        # 1 - cos t without cancellation
    return (np.where(small, s1, sin / tl), np.where(small, c1, one_minus_cos / tl),
            np.where(small, ds1, (tl * cos - sin) / (tl * tl)),
            np.where(small, dc1, (tl * sin - one_minus_cos) / (tl * tl)))


@dataclass(frozen=True, eq=False)
class CoordinatedTurnRate:
    r"""Nearly coordinated turn with the turn rate in the state, ``[x, vx, y, vy, omega]`` (m, m/s, m, m/s, rad/s).

    The turn rate :math:`\omega` (positive counter-clockwise) is estimated with the kinematics, so the model is
    nonlinear.  Over one period ``T`` the exact discretisation of the continuous-time coordinated turn
    :math:`\dot x = v_x,\ \dot v_x = -\omega v_y,\ \dot y = v_y,\ \dot v_y = \omega v_x,\ \dot\omega = 0`
    (Bar-Shalom, Li & Kirubarajan 2001, Sec. 11.7.1: the matrix of Eq. 11.7.1-4 with the rate :math:`\Omega`
    appended to the state; Li & Jilkov 2003, IEEE TAES 39(4), Sec. V, the coordinated turn with unknown rate)
    is, with :math:`\theta = \omega T`,

    .. math::
        f(x) = \begin{bmatrix}
            x + \frac{\sin\theta}{\omega} v_x - \frac{1-\cos\theta}{\omega} v_y \\
            \cos\theta\, v_x - \sin\theta\, v_y \\
            y + \frac{1-\cos\theta}{\omega} v_x + \frac{\sin\theta}{\omega} v_y \\
            \sin\theta\, v_x + \cos\theta\, v_y \\
            \omega \end{bmatrix},

    the known-rate matrix of :func:`coordinated_turn_matrix` applied with the state's own rate.  The
    coefficients :math:`\sin\theta/\omega = T\,\sin\theta/\theta` and :math:`(1-\cos\theta)/\omega` are computed
    through their series for :math:`|\theta| < 1`, so :math:`\omega \to 0` gives the constant-velocity
    transition continuously, with no division by a small rate (tested against :func:`constant_velocity`).

    Process noise, the nearly-coordinated-turn model (Bar-Shalom et al. 2001, Sec. 11.7.1; Li & Jilkov 2003,
    Sec. V): a discrete white acceleration on each position axis (gain :math:`[T^2/2, T]^T`, Sec. 6.3.2, as
    :func:`acceleration_noise_gain`) and a random walk of the turn rate (gain ``T``),
    :math:`Q = \Gamma\,\mathrm{diag}(q, q, q_\omega)\,\Gamma^T`,
    :math:`\Gamma = \begin{bmatrix} T^2/2 & 0 & 0\\ T & 0 & 0\\ 0 & T^2/2 & 0\\ 0 & T & 0\\ 0 & 0 & T
    \end{bmatrix}`.

    ``T`` the sampling period (s, > 0); ``q`` the variance of the acceleration noise per axis
    ((m/s^2)^2, >= 0); ``q_omega`` the variance of the turn-rate acceleration noise ((rad/s^2)^2, >= 0; the rate's
    increment over a step has standard deviation :math:`T\sqrt{q_\omega}` rad/s); ``name`` a string.  Each is a
    ValueError naming it when bad.  Satisfies :class:`mmlib.core.protocols.SimulatedDynamics`: the UKF, CKF and
    the other sigma-point filters use :meth:`transition`, the EKF :meth:`jacobian` (analytic)."""

    T: float
    q: float
    q_omega: float
    name: str = "CT(omega in state)"
    is_linear: bool = field(default=False, init=False)

    def __post_init__(self):
        _check_name(self.name)
        T = _check_period(self.T)
        q = check_scalar(self.q, "q", nonnegative=True)
        q_omega = check_scalar(self.q_omega, "q_omega", nonnegative=True)
        object.__setattr__(self, "T", T)
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "q_omega", q_omega)
        G = self.noise_gain
        factor = G * np.sqrt([q, q, q_omega])
        Q = G @ np.diag([q, q, q_omega]) @ G.T
        _freeze(self, Q=0.5 * (Q + Q.T), _factor=factor)

    dim = 5

    @property
    def noise_gain(self) -> np.ndarray:
        r"""The gain :math:`\Gamma` (5, 3) of the class docstring (s^2, s): columns the x and y accelerations
        and the turn-rate acceleration."""
        T = self.T
        G = np.zeros((5, 3))
        G[0:2, 0] = G[2:4, 1] = (0.5 * T * T, T)
        G[4, 2] = T
        return G

    @property
    def noise_factor(self) -> np.ndarray:
        r""":math:`\Gamma\,\mathrm{diag}(\sqrt q, \sqrt q, \sqrt{q_\omega})` (5, 3), a factor of ``Q``
        (:math:`G G^T = Q`), used to draw the truth's process noise."""
        return self._factor

    def _check_x(self, x) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        if x.ndim < 1 or x.shape[-1] != 5:
            raise ValueError(f"x: expected states of shape (..., 5), [x, vx, y, vy, omega], got shape {x.shape}")
        return x

    def transition(self, x: np.ndarray) -> np.ndarray:
        r""":math:`f(x)` of the class docstring for states or sigma points ``x`` (..., 5), any leading axes
        (e.g. (B, 5) or (B, p, 5)), in m, m/s and rad/s; returns a new array (..., 5).  A last axis other than 5
        is a ValueError naming ``x``."""
        x = self._check_x(x)
        T = self.T
        px, vx, py, vy, w = (x[..., i] for i in range(5))
        theta = w * T
        s1, c1, _, _ = _turn_functions(theta)
        a, b = T * s1, T * c1                              # sin(wT)/w, (1 - cos(wT))/w
        sin, cos = np.sin(theta), np.cos(theta)
        return np.stack([px + a * vx - b * vy, cos * vx - sin * vy, py + b * vx + a * vy,
                         sin * vx + cos * vy, w], axis=-1)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        r""":math:`\partial f/\partial x` (..., 5, 5) at states ``x`` (..., 5), analytic: with
        :math:`a = \sin\theta/\omega`, :math:`b = (1-\cos\theta)/\omega`, :math:`\theta = \omega T`,

        .. math::
            \begin{bmatrix}
            1 & a & 0 & -b & v_x a' - v_y b' \\
            0 & \cos\theta & 0 & -\sin\theta & -T(\sin\theta\, v_x + \cos\theta\, v_y) \\
            0 & b & 1 & a & v_x b' + v_y a' \\
            0 & \sin\theta & 0 & \cos\theta & T(\cos\theta\, v_x - \sin\theta\, v_y) \\
            0 & 0 & 0 & 0 & 1 \end{bmatrix},

        :math:`a' = \partial a/\partial\omega = T^2(\theta\cos\theta - \sin\theta)/\theta^2`,
        :math:`b' = \partial b/\partial\omega = T^2(\theta\sin\theta - 1 + \cos\theta)/\theta^2` (series for
        small :math:`\theta`; 0 and :math:`T^2/2` at :math:`\omega = 0`).
        Units: the last column in m/(rad/s) and m/s/(rad/s) per row.  A last axis other than 5 is a ValueError
        naming ``x``."""
        x = self._check_x(x)
        T = self.T
        vx, vy, w = x[..., 1], x[..., 3], x[..., 4]
        theta = w * T
        s1, c1, ds1, dc1 = _turn_functions(theta)
        a, b, da, db = T * s1, T * c1, T * T * ds1, T * T * dc1
        sin, cos = np.sin(theta), np.cos(theta)
        jac = np.zeros(x.shape[:-1] + (5, 5))
        jac[..., 0, 0] = jac[..., 2, 2] = jac[..., 4, 4] = 1.0
        jac[..., 0, 1], jac[..., 0, 3], jac[..., 0, 4] = a, -b, vx * da - vy * db
        jac[..., 1, 1], jac[..., 1, 3], jac[..., 1, 4] = cos, -sin, -T * (sin * vx + cos * vy)
        jac[..., 2, 1], jac[..., 2, 3], jac[..., 2, 4] = b, a, vx * db + vy * da
        jac[..., 3, 1], jac[..., 3, 3], jac[..., 3, 4] = sin, cos, T * (cos * vx - sin * vy)
        return jac


# --------------------------------------------------------------------------- measurements
@dataclass(frozen=True, eq=False)
class LinearMeasurement:
    """``z = H x + v``, ``v ~ N(0, R)``: ``H`` (m, n), m, n >= 1, maps the state to the measurement;
    ``R`` (m, m) symmetric positive definite, in squared measurement units (e.g. m^2 for positions);
    ``name`` a string.  Lists and other array-likes are accepted; the arrays are stored as read-only
    float64 copies."""

    H: np.ndarray
    R: np.ndarray
    name: str = "linear"
    is_linear: bool = field(default=True, init=False)

    def __post_init__(self):
        _check_name(self.name)
        H = check_matrix(self.H, "H")
        if H.shape[0] < 1 or H.shape[1] < 1:
            raise ValueError(f"H: expected shape (m >= 1, n >= 1), got {H.shape}")
        R = check_covariance(self.R, "R", H.shape[0])
        _freeze(self, H=H, R=R)

    @property
    def dim(self) -> int:
        """Measurement dimension m (rows of ``H``)."""
        return self.H.shape[0]

    @property
    def noise_factor(self) -> np.ndarray:
        """Lower Cholesky factor L (m, m) of ``R``, :math:`L L^T = R` (measurement units), used to draw the
        measurement noise ``v = L e``, ``e ~ N(0, I)`` (computed once, read-only)."""
        return _cholesky_of_R(self)

    def h(self, x: np.ndarray) -> np.ndarray:
        """:math:`H x` for states or sigma points ``x`` (..., n), e.g. (N, n) or (N, p, n); returns (..., m)
        in the measurement's units (the same bits per run whatever N, :func:`mmlib.core.linalg.matmul_rows`)."""
        return matmul_rows(x, self.H.T)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        r""":math:`\partial h/\partial x = H` at states ``x`` (..., n): ``H`` broadcast to (..., m, n), a
        read-only view."""
        return np.broadcast_to(self.H, x.shape[:-1] + self.H.shape)

    @property
    def angular(self) -> tuple:
        """Which components are angles (residuals wrapped): none."""
        return (False,) * self.dim

    def residual(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """``a - b`` for measurements (..., m) (broadcasting); no component is an angle, nothing is wrapped."""
        return a - b

    def average(self, values: np.ndarray, weights: np.ndarray) -> np.ndarray:
        r"""Weighted mean :math:`\sum_i w_i z_i` of measurement-space points ``values`` (..., p, m), e.g. the
        images of p sigma points, with weights ``weights`` (p,); returns (..., m)."""
        return weights @ values


def position_indices(state_dim: int) -> tuple:
    """Indices of x and y in the state ordering of this module: (0, 2) for [x, vx, y, vy],
    (0, 3) for [x, vx, ax, y, vy, ay]."""
    state_dim = check_positive_int(state_dim, "state_dim")
    if state_dim not in (4, 6):
        raise ValueError(f"state_dim: expected 4 (CV/CT) or 6 (CA), got {state_dim!r}")
    return (0, state_dim // 2)


def _check_position_index(value, name: str = "position_index", size: int | None = None,
                          length: int | None = None) -> tuple:
    """Distinct non-negative integer state indices (each < ``size`` if given), ``length`` of them if given."""
    if isinstance(value, (str, bytes)) or np.ndim(value) != 1:
        raise ValueError(f"{name}: expected a sequence of integer state indices, got {value!r}")
    idx = tuple(value)
    if length is not None and len(idx) != length:
        raise ValueError(f"{name}: expected {length} state indices, got {len(idx)} ({value!r})")
    if not idx:
        raise ValueError(f"{name}: expected at least one state index, got none")
    for i in idx:
        if isinstance(i, (bool, np.bool_)) or not isinstance(i, (int, np.integer)) or i < 0:
            raise ValueError(f"{name}: expected non-negative integer state indices, got {value!r}")
        if size is not None:
            check_index(i, name, size)
    if len(set(int(i) for i in idx)) != len(idx):
        raise ValueError(f"{name}: repeated state index in {value!r}")
    return tuple(int(i) for i in idx)


def position_measurement(R: np.ndarray, state_dim: int = 4,
                         position_index: tuple[int, ...] | None = None) -> LinearMeasurement:
    """Linear x-y position measurement (Zhu et al. 2016, Eq. 62): ``H`` picks the state components
    ``position_index`` (default: x and y of :func:`position_indices`) of a ``state_dim``-state;
    ``R`` (m^2): an (m, m) covariance or the m variances, m = number of indices.  ``z = H x + v`` in m,
    ``H`` (m, ``state_dim``); name ``"position"``.  A bad ``state_dim``, ``position_index`` or ``R`` is a
    ValueError naming it."""
    state_dim = check_positive_int(state_dim, "state_dim")
    if position_index is None:
        position_index = position_indices(state_dim)
    else:
        position_index = _check_position_index(position_index, "position_index", state_dim)
    H = np.zeros((len(position_index), state_dim))
    H[np.arange(len(position_index)), list(position_index)] = 1.0
    R = as_float_array(R, "R")
    R = check_covariance(np.diag(R) if R.ndim == 1 else R, "R", H.shape[0])
    return LinearMeasurement(H, R, "position")


@dataclass(frozen=True, eq=False)
class RangeBearing:
    r"""2-D radar: :math:`z = [\sqrt{\Delta x^2+\Delta y^2},\ \mathrm{atan2}(\Delta y, \Delta x)]^T + v`,
    :math:`\Delta = p - p_{\rm sensor}`.  Bearing residuals are wrapped to :math:`(-\pi, \pi]`
    and the mean of sigma-point bearings is taken relative to the first point, so that
    targets near the :math:`\pm\pi` cut are averaged correctly.

    ``R`` (2, 2): covariance of (range, bearing) noise, symmetric positive definite, units
    (m^2, m rad, rad^2); ``sensor`` (2,): the sensor's (x, y) position (m); ``position_index``: the
    two distinct state indices of x and y (e.g. (0, 2) for ``[x, vx, y, vy]``; their range within the
    state is checked by :func:`range_bearing`, which knows the state dimension); ``name`` a string.
    Lists and other array-likes are accepted; arrays are stored as read-only float64 copies."""

    R: np.ndarray
    sensor: np.ndarray = field(default_factory=lambda: np.zeros(2))
    position_index: tuple = (0, 2)
    name: str = "range-bearing"
    is_linear: bool = field(default=False, init=False)

    def __post_init__(self):
        _check_name(self.name)
        R = check_covariance(self.R, "R", 2)
        sensor = check_finite(as_float_array(self.sensor, "sensor"), "sensor")
        if sensor.shape != (2,):
            raise ValueError(f"sensor: expected the sensor's (x, y) position, shape (2,), got shape {sensor.shape}")
        object.__setattr__(self, "position_index", _check_position_index(self.position_index, length=2))
        _freeze(self, R=R, sensor=sensor)

    dim = 2
    #: which components are angles: the bearing (its residuals are wrapped to (-pi, pi], its average is
    #: taken about a reference point); mmlib.core.linalg.measurement_moments reads this
    angular = (False, True)

    @property
    def noise_factor(self) -> np.ndarray:
        """Lower Cholesky factor L (2, 2) of ``R`` (m, rad), :math:`L L^T = R`, used to draw the noise (computed
        once, read-only)."""
        return _cholesky_of_R(self)

    def h(self, x: np.ndarray) -> np.ndarray:
        r"""Range and bearing :math:`[\sqrt{\Delta x^2+\Delta y^2},\ \mathrm{atan2}(\Delta y, \Delta x)]` of
        states or sigma points ``x`` (..., n) (positions in m at ``position_index``); returns (..., 2):
        range in m, bearing in rad in :math:`[-\pi, \pi]` (``arctan2``), counter-clockwise from the +x
        axis (:func:`mmlib.core.linalg.range_bearing`)."""
        i, j = self.position_index
        return linalg.range_bearing(x, i, j, self.sensor)

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        r""":math:`\partial h/\partial x` (..., 2, n) at states ``x`` (..., n), with :math:`r^2 = \Delta x^2 +
        \Delta y^2`: range row :math:`[\Delta x/r, \Delta y/r]` (dimensionless), bearing row
        :math:`[-\Delta y/r^2, \Delta x/r^2]` (rad/m), in the position columns; zero elsewhere.  Not
        finite at the sensor itself (r = 0)."""
        i, j = self.position_index
        dx = x[..., i] - self.sensor[0]
        dy = x[..., j] - self.sensor[1]
        r2 = dx * dx + dy * dy
        r = np.sqrt(r2)
        jac = np.zeros(x.shape[:-1] + (2, x.shape[-1]))
        jac[..., 0, i] = dx / r
        jac[..., 0, j] = dy / r
        jac[..., 1, i] = -dy / r2
        jac[..., 1, j] = dx / r2
        return jac

    def residual(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        r"""``a - b`` for (range m, bearing rad) measurements (..., 2), broadcasting, the bearing difference
        wrapped to :math:`(-\pi, \pi]` (:func:`wrap_angle`); returns a new array (..., 2)."""
        d = np.subtract(a, b)
        d[..., 1] = wrap_angle(d[..., 1])
        return d

    def average(self, values: np.ndarray, weights: np.ndarray) -> np.ndarray:
        r"""Weighted mean of measurements ``values`` (..., p, 2) with weights (p,), taken about the first
        point: :math:`\bar z = z_0 + \sum_i w_i\,\mathrm{residual}(z_i, z_0)` (for weights summing to 1),
        the bearing wrapped to :math:`(-\pi, \pi]`, so that points straddling the :math:`\pm\pi` cut average
        correctly; returns (..., 2) (m, rad)."""
        ref = values[..., :1, :]
        mean = ref[..., 0, :] + weights @ self.residual(values, ref)
        mean[..., 1] = wrap_angle(mean[..., 1])
        return mean


@dataclass(frozen=True, eq=False)
class StackedDynamics:
    """r dynamics models acting on states with a mode axis: means (..., r, n),
    sigma points (..., r, p, n).  Linear models are stacked into one ``F`` (r, n, n),
    so an IMM runs all its mode filters in one batched call; nonlinear models are
    evaluated mode by mode.  ``Q`` is (r, n, n), or any shape broadcasting against
    (..., r, n, n) (e.g. per-run adapted noise): symmetric positive semi-definite, finite, in squared
    state units; it is checked on construction, so also at every :meth:`with_noise` (per step).
    ``F``, if given, is (r, n, n) and equals the models' own ``F`` (all models linear).
    ``q_psd_by_construction=True`` (:meth:`with_noise` with ``check=False``) says ``Q`` comes from a noise family
    marked :func:`psd_by_construction`: then only its dtype, shape and finiteness are checked, not its symmetry and
    definiteness (what the marking promises); the models and ``F`` are checked either way."""

    models: tuple
    Q: np.ndarray
    F: np.ndarray | None = None
    q_psd_by_construction: InitVar[bool] = False

    @property
    def q_checked(self) -> bool:
        """Whether ``Q``'s symmetry and definiteness were checked on construction (False: ``q_psd_by_construction``;
        the InitVar itself reads its class default on every instance)."""
        return self._q_checked

    @staticmethod
    def _check_models(models) -> tuple:
        if isinstance(models, (str, bytes, np.ndarray)) or not hasattr(models, "__iter__"):
            raise ValueError(f"models: expected a sequence of dynamics models, got {type(models).__name__}")
        models = tuple(models)
        if not models:
            raise ValueError("models: expected at least one dynamics model, got none")
        for j, m in enumerate(models):
            check_has(m, f"models[{j}]", "a dynamics model", ("dim", "Q", "transition", "jacobian"))
        dims = {m.dim for m in models}
        if len(dims) != 1:
            raise ValueError(f"models: all modes must share one state dimension, got {sorted(dims)}")
        return models

    def __post_init__(self, q_psd_by_construction: bool):
        models = self._check_models(self.models)
        r, n = len(models), models[0].dim
        # recorded under another name: dataclasses.replace() reads an InitVar with a default from the instance, so
        # storing the flag itself would carry the unchecked path into a replaced Q
        object.__setattr__(self, "_q_checked", not check_bool(q_psd_by_construction, "q_psd_by_construction"))
        if not self._q_checked:
            Q = np.asarray(self.Q)
            if Q.dtype != float or Q.ndim < 2 or Q.shape[-2:] != (n, n):
                raise ValueError(f"Q: expected a float array of shape (..., {r}, {n}, {n}) from a noise family "
                                 f"marked psd_by_construction, got {Q.dtype} {Q.shape}")
            check_finite(Q, "Q")                 # cheap; symmetry and definiteness are what the marking promises
        else:
            Q = check_covariance(self.Q, "Q", n, stack=True, semidefinite=True)
        if Q.ndim >= 3 and Q.shape[-3] not in (1, r):
            raise ValueError(f"Q: expected shape ({r}, {n}, {n}) or (..., {r}, {n}, {n}) (one covariance per mode), "
                             f"got {Q.shape}")
        F = self.F
        if F is not None:
            F = check_finite(as_float_array(F, "F"), "F")
            if F.shape != (r, n, n):
                raise ValueError(f"F: expected shape ({r}, {n}, {n}) (one transition per mode), got {F.shape}")
            for j, m in enumerate(models):
                if not getattr(m, "is_linear", False) or not np.array_equal(F[j], m.F):
                    raise ValueError(f"F: mode {j} differs from the transition matrix of models[{j}] "
                                     "(F is the stack of the linear models' own F)")
        object.__setattr__(self, "models", models)
        object.__setattr__(self, "Q", Q)
        object.__setattr__(self, "F", F)

    @staticmethod
    def of(models: Sequence[Dynamics]) -> "StackedDynamics":
        """Stack dynamics models (each with ``dim``, ``Q``, ``transition``, ``jacobian``; one state dimension)."""
        models = StackedDynamics._check_models(models)
        Q = np.stack([as_float_array(m.Q, f"models[{j}].Q") for j, m in enumerate(models)])
        F = np.stack([m.F for m in models]) if all(getattr(m, "is_linear", False) for m in models) else None
        return StackedDynamics(models, Q, F)

    @property
    def dim(self) -> int:
        """State dimension n, shared by every mode."""
        return self.models[0].dim

    @property
    def is_linear(self) -> bool:
        """All modes linear (then ``F`` is their stack)."""
        return self.F is not None

    def transition(self, points: np.ndarray) -> np.ndarray:
        r"""Each mode's ``f`` applied to its own points: ``points`` (..., r, p, n) (mode axis at -3, p points
        per mode) give (..., r, p, n).  For linear modes any shape broadcasting against ``F`` (r, n, n) also
        works, :math:`X F_j^T` (e.g. shared points (..., 1, p, n)); nonlinear modes need the mode axis."""
        if self.F is not None:
            return linear_transition(points, self.F)     # mode axis at -3: one GEMM per mode
        return np.stack([m.transition(points[..., j, :, :]) for j, m in enumerate(self.models)], axis=-3)

    def jacobian(self, mean: np.ndarray) -> np.ndarray:
        """Each mode's Jacobian at its own mean: ``mean`` (..., r, n) -> (..., r, n, n) (for linear modes the
        stacked ``F``, a read-only broadcast view)."""
        if self.F is not None:
            return np.broadcast_to(self.F, mean.shape[:-1] + self.F.shape[-2:])
        return np.stack([m.jacobian(mean[..., j, :]) for j, m in enumerate(self.models)], axis=-3)

    def with_noise(self, Q: np.ndarray, *, check: bool = True) -> "StackedDynamics":
        """The same modes with process noise ``Q`` ((r, n, n) or (..., r, n, n), e.g. per run and
        per step); a NaN, asymmetric or indefinite ``Q`` is a ValueError naming ``Q``.  ``check=False``: ``Q``
        comes from a family marked :func:`psd_by_construction` and only its shape and finiteness are checked (the
        per-step path of a noise-adaptive IMM: the full check costs a Cholesky of every matrix, every step)."""
        return StackedDynamics(self.models, Q, self.F, q_psd_by_construction=not check_bool(check, "check"))


def range_bearing(R: np.ndarray, state_dim: int = 4,
                  sensor: tuple[float, float] | np.ndarray = (0.0, 0.0)) -> "RangeBearing":
    """Range-bearing radar at ``sensor`` ((x, y), m) for a state of dimension ``state_dim`` (4 or 6;
    positions located by :func:`position_indices`; Liu & Wu 2017 Eq. 40, Hu et al. 2017); ``R``
    (2, 2) covariance of (range m, bearing rad), units (m^2, m rad, rad^2): e.g.
    ``np.diag([10.0**2, math.radians(0.1)**2])`` for 10 m and 0.1 degree standard deviations."""
    return RangeBearing(R, sensor, position_indices(state_dim))


@dataclass(frozen=True, eq=False)
class SensorFault:
    """An additive sensor fault of any measurement model: ``z = h(x) + v + delta``, ``delta`` (B, K, m) per run
    and step, finite, in the measurement's units (m and rad for a range-bearing radar); e.g. the range
    deviation and bearing drift of Zhou et al. 2017, Eq. 2 (built by :func:`radar_drift`).
    Use as ``simulate(..., measurement_noise_fn=fault.apply(measurement))``."""

    delta: np.ndarray

    def __post_init__(self):
        d = check_finite(as_float_array(self.delta, "delta"), "delta")
        if d.ndim != 3 or 0 in d.shape:
            raise ValueError(f"delta: expected shape (B, K, m) (runs, steps, measurement dimension), got {d.shape}")
        _freeze(self, delta=d)

    def apply(self, measurement: MeasurementModel) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
        """``noise_fn(truth (B, K, n), v (B, K, m))`` for :func:`mmlib.experiment.simulate.simulate`, returning
        ``z = h(truth) + v L^T + delta`` (B, K, m) with ``v`` standard normals and ``L`` the model's
        ``noise_factor``; the measurement model's dimension (checked here, ValueError naming
        ``measurement``) and the truth's runs and steps (checked per call, naming ``delta``) must match
        ``delta``."""
        check_has(measurement, "measurement", "a measurement model", ("h", "noise_factor", "dim"))
        if measurement.dim != self.delta.shape[-1]:
            raise ValueError(f"measurement: dimension {measurement.dim} does not match the fault's "
                             f"{self.delta.shape[-1]} (delta of shape {self.delta.shape})")

        def noise_fn(truth, v):
            if np.shape(truth)[:-1] != self.delta.shape[:-1]:
                raise ValueError(f"delta: fault for (runs, steps) {self.delta.shape[:-1]} applied to a truth of "
                                 f"(runs, steps) {np.shape(truth)[:-1]}")
            return measurement.h(truth) + v @ measurement.noise_factor.T + self.delta
        return noise_fn


def radar_drift(range_offset: ArrayLike, bearing_rate: ArrayLike, times: ArrayLike) -> SensorFault:
    """Eq. 2's fault of a range-bearing radar as a :class:`mmlib.core.SensorFault`: range deviation
    ``delta_r`` (m, per run, constant) and bearing drift ``delta_theta_k = rate * t_k`` (rad, rate in rad/s
    per run): arrays of shape (B,) or (B, K);
    ``times`` (K,) the measurement times t_k (s)."""
    t = check_finite(as_float_array(times, "times"), "times")
    if t.ndim != 1 or t.size < 1:
        raise ValueError(f"times: expected shape (K,) with K >= 1, got {t.shape}")
    K = t.shape[0]
    arrays = {}
    for name, value in (("range_offset", range_offset), ("bearing_rate", bearing_rate)):
        a = check_finite(as_float_array(value, name), name)
        if a.ndim not in (1, 2) or a.shape[0] < 1 or (a.ndim == 2 and a.shape[1] != K):
            raise ValueError(f"{name}: expected shape (B,) or (B, {K}) (per run, or per run and step), "
                             f"got {a.shape}")
        arrays[name] = a.reshape(a.shape[0], -1)
    B = arrays["range_offset"].shape[0]
    if arrays["bearing_rate"].shape[0] != B:
        raise ValueError(f"bearing_rate: expected {B} runs (as range_offset), got shape {np.shape(bearing_rate)}")
    dr = np.broadcast_to(arrays["range_offset"], (B, K))
    return SensorFault(np.stack([dr, arrays["bearing_rate"] * t[None, :]], axis=-1))
