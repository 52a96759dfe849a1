r"""The interfaces of the estimation core, declared once as :class:`typing.Protocol`\ s.

Everything in :mod:`mmlib` is duck-typed against these: a dynamics model, measurement model, filter, layer or
estimator of your own works wherever the library's do if it provides the members listed here (with the shapes
stated).  The library checks an object's members at construction (:func:`require`), so a missing one is a
``ValueError`` naming the argument and the protocol, never an ``AttributeError`` deep inside a filter step.

Shapes: ``B`` runs (the batch axis, always first), ``r`` IMM modes, ``p`` sigma points, ``n`` the state and ``m``
the measurement dimension.  Units: SI inside the library (m, s, rad, m/s, rad/s).

* :class:`Dynamics` -- :math:`x_k = f(x_{k-1}) + w_k`, :math:`w_k \sim N(0, Q)` (:class:`SimulatedDynamics` when it
  also drives a simulated truth);
* :class:`MeasurementModel` -- :math:`z_k = h(x_k) + v_k`, :math:`v_k \sim N(0, R)`, with residuals and means
  of measurements that know which components are angles (bearings are wrapped to (-pi, pi]);
* :class:`Filter` -- a mode-matched Gaussian filter: ``init``, ``predict`` (time update through a Dynamics)
  and ``update`` (the one Kalman update, :func:`mmlib.core.filters.kalman_update`);
* :class:`MomentFilter` -- a Filter that predicts the measurement moments the shared update consumes;
* :class:`Layer` -- a MomentFilter wrapping another one (strong tracking, adaptation, bootstrapping);
* :class:`Estimator` -- what :func:`mmlib.core.estimation.run` drives: ``init`` and ``step`` (a single model,
  an IMM, an adaptive IMM);
* :class:`State` -- a filter's state: an immutable NamedTuple with at least ``mean`` (B, n) and ``cov``
  (B, n, n) (layers add their own fields; an IMM's state holds the stacked mode states).
"""
from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np

__all__ = ["Dynamics", "SimulatedDynamics", "MeasurementModel", "Filter", "MomentFilter", "Layer", "Estimator", "State",
           "require", "members", "missing"]


@runtime_checkable
class Dynamics(Protocol):
    """A discrete-time motion model of state dimension ``dim``."""

    @property
    def dim(self) -> int:
        """State dimension n."""

    Q: np.ndarray
    """Process-noise covariance (n, n) per step, in SI units squared."""

    def transition(self, x: np.ndarray) -> np.ndarray:
        """f(x) for states or sigma points of shape (..., n); returns (..., n)."""

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """df/dx at means (B, n) or (B, r, n); returns (..., n, n)."""


@runtime_checkable
class SimulatedDynamics(Dynamics, Protocol):
    """A Dynamics that can also generate a truth (:func:`mmlib.experiment.simulate.simulate`): it gives a square root
    of its process noise."""

    @property
    def noise_factor(self) -> np.ndarray:
        """A factor G (n, k) with G G^T = Q, used to draw the process noise."""


@runtime_checkable
class MeasurementModel(Protocol):
    """A sensor: measurement function, its Jacobian, noise and the algebra of its residuals."""

    @property
    def dim(self) -> int:
        """Measurement dimension m."""

    R: np.ndarray
    """Measurement-noise covariance (m, m), in the measurement's units squared (m^2, rad^2)."""

    @property
    def noise_factor(self) -> np.ndarray:
        """A square root L (m, m) of R, L L^T = R, used to draw the measurement noise."""

    def h(self, x: np.ndarray) -> np.ndarray:
        """h(x) for states (..., n); returns (..., m)."""

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """dh/dx at states (..., n); returns (..., m, n)."""

    def residual(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """a - b for measurements (..., m), angular components wrapped to (-pi, pi]."""

    def average(self, values: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """Weighted mean of measurements (..., p, m) with weights (p,) (angles averaged on the circle)."""


@runtime_checkable
class State(Protocol):
    """A filter's state (an immutable NamedTuple): mean (B, n) and covariance (B, n, n)."""

    mean: np.ndarray
    cov: np.ndarray


@runtime_checkable
class Filter(Protocol):
    """A mode-matched Gaussian filter, batched over runs (and over IMM modes, stacked on a second axis)."""

    def init(self, mean: np.ndarray, cov: np.ndarray) -> Any:
        """The state at step 0 from means (B, n) and covariances (n, n) or (B, n, n)."""

    def predict(self, state: Any, dynamics: Dynamics) -> Any:
        """Time update: the predicted state."""

    def update(self, state: Any, z: np.ndarray, measurement: MeasurementModel) -> tuple:
        """Measurement update with z (B, m): ``(posterior state, UpdateInfo)`` (log-likelihood, innovation, S and
        the runs whose covariance stopped being positive definite)."""


@runtime_checkable
class MomentFilter(Filter, Protocol):
    """A Filter whose update is the shared Kalman update fed by its own prediction of the measurement moments:
    the filters differ only there (EKF: linearisation; sigma-point filters: their rule)."""

    def predict_measurement(self, state: Any, measurement: MeasurementModel) -> Any:
        """Predicted measurement mean (B, m), its covariance S (B, m, m) and the cross-covariance (B, n, m)
        (:class:`mmlib.core.filters.MeasurementPrediction`)."""


@runtime_checkable
class Layer(MomentFilter, Protocol):
    """A filter that wraps another (``base``, a :class:`MomentFilter`) and changes only what differs: e.g. strong
    tracking inflates the predicted covariance, innovation adaptation re-estimates R, observation bootstrapping
    fuses pseudo-measurements."""

    base: MomentFilter


@runtime_checkable
class Estimator(Protocol):
    """What :func:`mmlib.core.estimation.run` drives over a measurement sequence."""

    def init(self, mean: np.ndarray, cov: np.ndarray, *args: Any, **kwargs: Any) -> Any:
        """The estimator's state at step 0."""

    def step(self, state: Any, z: np.ndarray, *, with_cov: bool = True, measurement: Any = None) -> tuple:
        """One step with measurements z (B, m): ``(state, Estimate)`` (:class:`mmlib.core.estimation.Estimate`);
        ``measurement`` overrides the measurement model for this step."""


def members(protocol: type) -> tuple:
    """The members a class must provide to satisfy ``protocol``, in declaration order (methods, properties and
    annotated attributes of the protocol and of the protocols it extends)."""
    names = []
    for klass in reversed(protocol.__mro__):
        if klass in (object, Protocol) or not getattr(klass, "_is_protocol", False):
            continue
        for name in list(getattr(klass, "__annotations__", {})) + list(vars(klass)):
            if name.startswith("_") or name in names:
                continue
            names.append(name)
    return tuple(names)


def missing(obj: Any, protocol: type) -> list:
    """The members of ``protocol`` that ``obj`` lacks (empty when it satisfies it)."""
    return [name for name in members(protocol) if not hasattr(obj, name)]


def require(obj: Any, name: str, protocol: type, what: str | None = None) -> Any:
    """``obj`` if it provides every member of ``protocol``; else ValueError naming the argument ``name``, the
    protocol and the members it lacks."""
    lacking = missing(obj, protocol)
    if lacking:
        what = what or f"a {protocol.__name__}"
        raise ValueError(f"{name}: expected {what} (mmlib.core.protocols.{protocol.__name__}: "
                         f"{', '.join(members(protocol))}); {type(obj).__name__} lacks {', '.join(lacking)}")
    return obj
