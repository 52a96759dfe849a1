r"""Mode-matched Gaussian filters, batched over Monte Carlo runs.

Every filter is a small immutable object with two methods

* ``predict(state, dynamics) -> state``  (time update)
* ``predict_measurement(state, measurement) -> MeasurementPrediction``

and shares **one** Kalman update, :func:`kalman_update` (Bar-Shalom et al.
2001, Eq. 5.2.3-10 to -15, in the covariance form that sigma-point filters
use):

.. math::
    \nu = z - \hat z,\quad K = P_{xz} S^{-1},\quad \hat x^+ = \hat x + K\nu,
    \quad P^+ = P - K S K^T,\quad
    \log L = -\tfrac12\left(\nu^T S^{-1}\nu + \log|2\pi S|\right).

The variants differ only in how the predicted moments are obtained:
:class:`ExtendedKalmanFilter` linearises (Jacobians; on linear models it *is*
the Kalman filter), :class:`SigmaPointFilter` integrates with any rule from
:mod:`mmlib.core.rules`.  Layers such as strong tracking or adaptive noise wrap a
filter and override one of the two methods; they never copy the update.

States are immutable ``NamedTuple`` objects with fields ``mean`` (..., n) and
``cov`` (..., n, n) -- any leading batch axes: (B,) for one filter over B
Monte Carlo runs, (B, r) inside an IMM with r modes.  Layers may extend the
state with extra fields, which the IMM carries through untouched (it only
replaces ``mean`` and ``cov``).  Dynamics may be stacked per mode
(:class:`mmlib.core.models.StackedDynamics`); measurements broadcast.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from mmlib.core import linalg
from mmlib.core._validate import as_float_array, check_batch_vector, check_covariance, check_has, check_name
from mmlib.core.protocols import Dynamics, MeasurementModel, MomentFilter, State, members
from mmlib.core.rules import SigmaPointRule, rule_by_name

__all__ = ["SigmaPointFilter", "ExtendedKalmanFilter", "KalmanFilter", "filter_by_name", "GaussianState",
           "gaussian_state", "kalman_update", "MeasurementPrediction", "UpdateInfo", "FilterLayer", "LOG_2PI"]

LOG_2PI = math.log(2.0 * math.pi)


class GaussianState(NamedTuple):
    """A batch of Gaussian estimates: ``mean`` (B, n), ``cov`` (B, n, n)."""

    mean: np.ndarray
    cov: np.ndarray


class MeasurementPrediction(NamedTuple):
    """Predicted measurement ``z_pred`` (B, m), innovation covariance ``S`` (B, m, m)
    (including R) and state-measurement cross-covariance ``Pxz`` (B, n, m).  ``H`` (B, m, n): the
    measurement Jacobian when the prediction is a linearisation, :math:`S = HPH^T + R` and
    :math:`P_{xz} = PH^T` exactly (EKF/KF); it selects the Joseph-form covariance update.  A layer
    that changes S builds a new prediction without H (the Joseph form would then be wrong)."""

    z_pred: np.ndarray
    S: np.ndarray
    Pxz: np.ndarray
    H: Any = None
    R: Any = None               # the measurement noise in S = HPH^T + R when it is not measurement.R


class UpdateInfo(NamedTuple):
    r"""What a Kalman update reports besides the posterior (:func:`kalman_update`): ``innovation``
    :math:`\nu = z - \hat z` (B, m), residual-wrapped (angles in :math:`(-\pi, \pi]`), in the measurement's
    units; its covariance ``S`` (B, m, m); ``loglik`` (B,) :math:`\log N(\nu; 0, S)` (NaN for a failed
    run); ``nis`` (B,) :math:`\nu^T S^{-1}\nu` (dimensionless); ``failed`` (B,) bool, S or the posterior
    covariance not positive definite (that run's state is NaN).  Inside an IMM every field has a mode
    axis after B."""

    innovation: np.ndarray      # (B, m), residual-wrapped
    S: np.ndarray               # (B, m, m)
    loglik: np.ndarray          # (B,)  log N(innovation; 0, S), NaN if S not PD
    nis: np.ndarray             # (B,)  normalised innovation squared
    failed: Any = None          # (B,) bool: S or the posterior covariance not positive definite (state NaN)


def gaussian_state(mean: np.ndarray, cov: np.ndarray) -> GaussianState:
    """Validated initial state: mean (B, n) and cov (B, n, n) or a shared (n, n) (broadcast to every run), in
    the state's units (m, m/s, ...; cov squared).  The mean is copied, a shared cov broadcast into a new
    array; a float64 (B, n, n) cov is used as given (not copied).  A mean that is not (B, n) and finite,
    or a cov that is not symmetric positive definite of matching size, is a ValueError naming it."""
    mean = check_batch_vector(mean, "mean")
    cov_arr = as_float_array(cov, "cov")
    if cov_arr.ndim == 2:
        cov_arr = check_covariance(cov_arr, "cov", mean.shape[1])
        cov_arr = np.broadcast_to(cov_arr, (mean.shape[0],) + cov_arr.shape).copy()
    else:
        cov_arr = check_covariance(cov_arr, "cov", mean.shape[1], batch=True)
        if cov_arr.shape[0] != mean.shape[0]:
            raise ValueError(f"cov: batch size {cov_arr.shape[0]} does not match mean's {mean.shape[0]}")
    return GaussianState(mean.copy(), cov_arr)


def kalman_update(state: State, pred: MeasurementPrediction, z: np.ndarray,
                  measurement: MeasurementModel) -> tuple:
    r"""The one Kalman update shared by every filter (see module docstring).

    ``state``: the predicted state (mean (..., n), cov (..., n, n); any NamedTuple with these fields,
    the others are kept); ``pred``: its :class:`MeasurementPrediction`; ``z`` (..., m) the measurement
    (broadcasting against ``pred.z_pred``); ``measurement`` the model (its ``residual``, and ``R`` for
    the Joseph form).  Returns ``(posterior state, UpdateInfo)``.

    Computed through the Cholesky factor :math:`S = L L^T`: with
    :math:`A = P_{xz} L^{-T}` and :math:`e = L^{-1}\nu`, the gain is
    :math:`K = A L^{-1}`, :math:`K\nu = A e`, :math:`K S K^T = A A^T` and the
    NIS is :math:`e^T e`.  Runs whose innovation covariance is not positive
    definite get a NaN state and log-likelihood (reported by
    :func:`mmlib.core.estimation.run` as diverged), never a patched one.

    **Positive-definiteness check, for every filter.**  The posterior
    :math:`P^+ = P - AA^T` is symmetrised and factorised; a run whose :math:`P^+` has no
    Cholesky factor (LAPACK ``potrf``: a pivot :math:`\le 0`, i.e. not positive definite to
    working precision, tolerance zero) is diverged *at this step*: its mean, covariance and
    log-likelihood become NaN and ``UpdateInfo.failed`` is True.  Without the check a
    KF/EKF could return a negative variance silently, and a sigma-point filter would only
    fail at the next step's sigma points (one step late).

    **Joseph form where H exists** (``pred.H``, the EKF/KF): :math:`P^+ = (I - KH)P(I - KH)^T + KRK^T`
    (Bar-Shalom et al. 2001, Eq. 5.2.3-18), a sum of positive semi-definite terms, so it stays positive
    definite where :math:`P - KSK^T` loses the small eigenvalues to cancellation (e.g. a prior of
    1e10 m² measured with R = 1e-6 m²).  Sigma-point filters have no H (their statistically linearised
    Joseph form needs :math:`S - P_{xz}^T P^{-1} P_{xz}`, the same cancellation) and use :math:`P - AA^T`.
    """
    nu = measurement.residual(z, pred.z_pred)
    R = None if pred.H is None else (measurement.R if pred.R is None else pred.R)
    mean, cov, nis, logdet, failed = linalg.kalman_moments(state.mean, state.cov, nu, pred.S, pred.Pxz, pred.H, R)
    loglik = -0.5 * (nis + logdet + nu.shape[-1] * LOG_2PI)
    if failed.any():
        loglik = np.where(failed, np.nan, loglik)
    return state._replace(mean=mean, cov=cov), UpdateInfo(nu, pred.S, loglik, nis, failed)


class _FilterBase:
    """``update`` = measurement prediction + the shared Kalman update."""

    def update(self, state, z: np.ndarray, measurement) -> tuple:
        """Measurement update with ``z`` (B, m) ((B, 1, m) inside an IMM): :meth:`predict_measurement`, then
        :func:`kalman_update`; returns ``(posterior state, UpdateInfo)``."""
        return kalman_update(state, self.predict_measurement(state, measurement), z, measurement)

    def init(self, mean: np.ndarray, cov: np.ndarray) -> GaussianState:
        """The state at step 0: :func:`gaussian_state` of ``mean`` (B, n) and ``cov`` (B, n, n) or (n, n)."""
        return gaussian_state(mean, cov)

    def predict_measurement(self, state, measurement):  # pragma: no cover - implemented by subclasses
        raise NotImplementedError


@dataclass(frozen=True)
class ExtendedKalmanFilter(_FilterBase):
    r"""First-order linearisation: :math:`\hat x^- = f(\hat x)`, :math:`P^- = F P F^T + Q`,
    :math:`\hat z = h(\hat x^-)`, :math:`S = H P^- H^T + R`, :math:`P_{xz} = P^- H^T`
    (Bar-Shalom et al. 2001, Sec. 10.3).  On linear models this is exactly the Kalman filter."""

    name: str = "EKF"

    def __post_init__(self):
        check_name(self.name)

    def predict(self, state: State, dynamics: Dynamics) -> State:
        r"""Time update :math:`\hat x^- = f(\hat x)`, :math:`P^- = F P F^T + Q` with :math:`F` the Jacobian of
        ``dynamics`` at the prior mean: ``state`` mean (..., n), cov (..., n, n) (e.g. (B, n) or (B, r, n) with a
        :class:`~mmlib.core.models.StackedDynamics` of r modes); returns the state with the predicted mean
        and cov (other fields kept).  Linear dynamics (``is_linear``, with ``F``) take the fused
        :func:`mmlib.core.linalg.linear_predict`."""
        if getattr(dynamics, "is_linear", False):
            mean, cov = linalg.linear_predict(state.mean, state.cov, dynamics.F, dynamics.Q)
            return state._replace(mean=mean, cov=cov)
        F = dynamics.jacobian(state.mean)
        cov, _ = linalg.congruence(F, state.cov, dynamics.Q)
        mean = dynamics.transition(state.mean[..., None, :])[..., 0, :]
        return state._replace(mean=mean, cov=cov)

    def predict_measurement(self, state: State, measurement: MeasurementModel) -> MeasurementPrediction:
        r"""Linearised measurement moments at the predicted mean: :math:`\hat z = h(\hat x^-)` (..., m),
        :math:`S = H P^- H^T + R` (..., m, m), :math:`P_{xz} = P^- H^T` (..., n, m), and ``H`` (..., m, n), which
        selects the Joseph-form update."""
        H = measurement.jacobian(state.mean)
        S, pxz = linalg.congruence(H, state.cov, measurement.R)
        return MeasurementPrediction(measurement.h(state.mean[..., None, :])[..., 0, :], S, pxz, H)


def KalmanFilter(name: str = "KF") -> ExtendedKalmanFilter:
    """The linear Kalman filter: the EKF applied to linear models (identical algebra)."""
    return ExtendedKalmanFilter(name=name)


@dataclass(frozen=True)
class SigmaPointFilter(_FilterBase):
    r"""Generic sigma-point (deterministic-sampling) Kalman filter over any rule.

    Time update (e.g. Zhu et al. 2016, Eqs. 1-26 for the fifth-degree rule):
    :math:`X_i = \hat x + S\xi_i`, :math:`\hat x^- = \sum w^m_i f(X_i)`,
    :math:`P^- = \mathrm{cov}_{rule}(f(X_i)) + Q`.
    Measurement prediction (Eqs. 27-50): fresh points from :math:`P^-`,
    :math:`\hat z = \sum w^m_i h(X_i)`, :math:`S = \mathrm{cov}_{rule}(h(X_i)) + R`,
    :math:`P_{xz} = \mathrm{cross}_{rule}(X_i, h(X_i))`.
    UKF, CKF, 5th-degree CKF, SSR-CKF and CDKF are this class with a different rule.
    """

    rule: SigmaPointRule
    name: str = ""

    def __post_init__(self):
        if not isinstance(self.rule, SigmaPointRule):
            raise ValueError(f"rule: expected a SigmaPointRule, got {type(self.rule).__name__}")
        check_name(self.name)
        if not self.name:
            object.__setattr__(self, "name", self.rule.name)

    @property
    def fusable(self) -> bool:
        """Whether a fused step (:func:`mmlib.core.linalg.sigma_step` and the steps built like it) computes this
        filter's step: this class itself (a subclass may override a step) with a rule whose covariances are weighted
        outer products (``weighted_moments``: every rule but the Stirling central differences)."""
        return type(self) is SigmaPointFilter and self.rule.weighted_moments

    def _points(self, state):
        """The rule's sigma points from the state's Cholesky factor (NaN for a run whose P is not PD)."""
        X, _failed = linalg.sigma_points(state.mean, state.cov, self.rule.unit_points(state.mean.shape[-1]).xi)
        return X

    def predict(self, state: State, dynamics: Dynamics) -> State:
        r"""Time update through the rule: :math:`X_i = \hat x + S\xi_i` (:math:`SS^T = P`),
        :math:`\hat x^- = \sum_i w^m_i f(X_i)`, :math:`P^- = \mathrm{cov}_{rule}(f(X_i)) + Q`.  ``state`` mean
        (..., n), cov (..., n, n) (e.g. (B, n), or (B, r, n) with stacked mode dynamics); returns the state with
        the predicted mean and cov (other fields kept).  A run whose P is not positive definite gets NaN
        points, hence a NaN prediction.  Linear dynamics (``is_linear``, with ``F``) and a rule whose
        covariances are weighted outer products (``weighted_moments``: every rule but the Stirling central
        differences) take the fused :func:`mmlib.core.linalg.sigma_point_predict_linear`."""
        up = self.rule.unit_points(state.mean.shape[-1])
        if self.rule.weighted_moments and getattr(dynamics, "is_linear", False):
            mean, cov = linalg.sigma_point_predict_linear(state.mean, state.cov, up.xi, up.wm, up.wc, dynamics.F,
                                                          dynamics.Q)
            return state._replace(mean=mean, cov=cov)
        X = self._points(state)
        Y = dynamics.transition(X)
        mean = linalg.weighted_mean(Y, up.wm)
        cov = self.rule.covariance(X - state.mean[..., None, :], Y - mean[..., None, :], add=dynamics.Q)
        return state._replace(mean=mean, cov=cov)

    def predict_measurement(self, state: State, measurement: MeasurementModel) -> MeasurementPrediction:
        r"""Measurement moments from fresh sigma points :math:`X_i` of the predicted state:
        :math:`\hat z` = ``measurement.average`` of :math:`h(X_i)` (..., m) (angles averaged about a reference
        point), :math:`S = \mathrm{cov}_{rule}(h(X_i)) + R` (..., m, m) and
        :math:`P_{xz} = \mathrm{cross}_{rule}(X_i, h(X_i))` (..., n, m), deviations residual-wrapped; no ``H``.
        A model of this library that states its ``angular`` components, with a ``weighted_moments`` rule, takes the
        fused :func:`mmlib.core.linalg.measurement_moments` (average and residual by those flags, which is what the
        library's models' ``average`` and ``residual`` do); a model whose ``average`` or ``residual`` is defined
        elsewhere (a user's override) always goes through its own methods."""
        X = self._points(state)
        Z = measurement.h(X)
        up = self.rule.unit_points(state.mean.shape[-1])
        angular = getattr(measurement, "angular", None)
        if angular is not None and self.rule.weighted_moments and _library_moments(measurement):
            z_pred, S, pxz = linalg.measurement_moments(X, state.mean, Z, up.wm, up.wc, angular, measurement.R)
            return MeasurementPrediction(z_pred, S, pxz)
        wm = up.wm
        z_pred = measurement.average(Z, wm)
        dz = measurement.residual(Z, z_pred[..., None, :])
        pzz, pxz = self.rule.covariances(X - state.mean[..., None, :], dz, add=measurement.R)
        return MeasurementPrediction(z_pred, pzz, pxz)


class FilterLayer:
    """Base of the thin layers over a filter (strong tracking, innovation adaptation, observation
    bootstrapping).  It delegates the time update and the measurement prediction to ``self.base``,
    records the process noise Q of the prediction when the layer's state has a ``Q`` field (layers
    that rescale :math:`P - Q` need it at update time), and builds the layer's ``state_type``.
    A layer overrides ``update`` only -- and never copies the Kalman update."""

    state_type: Any = None

    def _check_base(self):
        """``self.base`` provides a :class:`mmlib.core.protocols.MomentFilter` and is a filter, not another layer
        (ValueError naming ``base``: a layer delegates only the time update and the measurement prediction, so an
        inner layer's update would silently never run)."""
        if isinstance(self.base, FilterLayer):
            raise ValueError(f"base: {type(self).__name__} over another layer ({type(self.base).__name__}) is not "
                             "supported: the inner layer's update would never run; give it the filter itself")
        check_has(self.base, "base", "a filter predicting measurement moments (protocols.MomentFilter)",
                  members(MomentFilter))

    def init(self, mean: np.ndarray, cov: np.ndarray, **extra: Any) -> State:
        """The layer's ``state_type`` at step 0 from :func:`gaussian_state` of ``mean`` (B, n) and ``cov``
        (B, n, n) or (n, n); ``extra`` fills the layer's own fields (a keyword that is none of them is a ValueError
        naming it)."""
        own = self.state_type._fields[2:]
        for key in extra:
            if key not in own:
                raise ValueError(f"{key}: {type(self).__name__}.init takes no argument {key!r} (its own: "
                                 f"{', '.join(own) if own else 'none beyond mean and cov'})")
        g = gaussian_state(mean, cov)
        return self.state_type(g.mean, g.cov, **extra)

    def check_state(self, state: Any, name: str = "state") -> Any:
        """``state`` is this layer's ``state_type`` (as its ``init`` returns it), else a ValueError naming ``name``: a
        plain :class:`GaussianState` (e.g. the base filter's own ``init``) lacks the layer's fields."""
        if self.state_type is not None and not isinstance(state, self.state_type):
            raise ValueError(f"{name}: expected the {self.state_type.__name__} of {type(self).__name__}.init(), got "
                             f"{type(state).__name__} (initialise with the layer's init, not its base filter's)")
        return state

    def predict(self, state: State, dynamics: Dynamics) -> State:
        """The base filter's time update; when the state has a ``Q`` field it records ``dynamics.Q``
        broadcast to the covariance's shape (..., n, n) (a read-only view).  A state of another type than the
        layer's is a ValueError naming ``state`` (:meth:`check_state`)."""
        self.check_state(state)
        s = self.base.predict(state, dynamics)
        if "Q" in s._fields:
            s = s._replace(Q=np.broadcast_to(dynamics.Q, s.cov.shape))
        return s

    def predict_measurement(self, state: State, measurement: MeasurementModel) -> MeasurementPrediction:
        """The base filter's measurement prediction (:class:`MeasurementPrediction`), unchanged."""
        return self.base.predict_measurement(state, measurement)


_FILTER_NAMES = {"kf": "KF", "ekf": "EKF"}


def filter_by_name(name: str, **rule_params: Any) -> ExtendedKalmanFilter | SigmaPointFilter:
    """``kf``/``ekf`` (an :class:`ExtendedKalmanFilter` named ``KF``/``EKF``, which takes no ``rule_params``)
    or any rule name of :func:`mmlib.core.rules.rule_by_name` (a :class:`SigmaPointFilter` named
    by the upper-cased name, ``rule_params`` passed to the rule).  Any case; an unknown name or rule
    parameter is a ValueError naming it."""
    if not isinstance(name, str):
        raise ValueError(f"name: expected a filter name (string), got {type(name).__name__}")
    key = name.lower()
    if key in _FILTER_NAMES:
        if rule_params:
            raise ValueError(f"{', '.join(sorted(rule_params))}: {name!r} has no quadrature rule, so no rule "
                             f"parameters")
        return ExtendedKalmanFilter(name=_FILTER_NAMES[key])
    return SigmaPointFilter(rule_by_name(key, **rule_params), name=str(name).upper())


def _library_moments(measurement: MeasurementModel) -> bool:
    """Whether ``measurement``'s ``average`` and ``residual`` are this library's (defined in ``mmlib.core``), whose
    results the fused measurement moments reproduce from the model's ``angular`` flags."""
    cls = type(measurement)
    return all(getattr(getattr(cls, m, None), "__module__", "").startswith("mmlib.core.") for m in ("average",
                                                                                                   "residual"))
