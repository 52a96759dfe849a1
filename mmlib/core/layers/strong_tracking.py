r"""Strong tracking (suboptimal fading factor) as a thin layer over any filter.

Zhou & Frank 1996 (Int. J. Control 65, 295-307); Liu & Wu 2017, Eqs. 13-19 and 28.
With the predicted covariance :math:`P^l` (including Q), the innovation
:math:`v_k` of the predicted measurement and

.. math::
    V_k = \begin{cases} v_1 v_1^T & \text{first update (Eq. 17, } k = 0)\\
          (\rho V_{k-1} + v_k v_k^T)/(1 + \rho) & \text{afterwards} \end{cases}

the fading factor is :math:`\lambda_k = \max(1, \mathrm{tr} N_k / \mathrm{tr} M_k)` (Eq. 14) with

* Jacobian form (EKF-based STF, Eqs. 15-16):
  :math:`N = V - HQH^T - \beta R`, :math:`M = H(P^l - Q)H^T` (:math:`= HFPF^TH^T`);
* Jacobian-free form (Eqs. 18-19), any rule, with :math:`\tilde H = P_{xz}^T (P^l)^{-1}`:
  :math:`N = V - \tilde H Q \tilde H^T - \beta R`, :math:`M = P_{zz} - V + N + (\beta - 1)R`.

For the EKF, :math:`P_{xz} = P^l H^T` makes the two forms identical (tested).  The
prediction covariance is then inflated, :math:`P' = \lambda(P^l - Q) + Q` (Eq. 28), the
measurement is predicted again from :math:`P'` (Eqs. 29-33) and the shared Kalman update
follows (Eqs. 34-36).  Where :math:`\lambda = 1` the layer uses :math:`P^l` itself, so a
strong-tracking filter whose factor never exceeds 1 *is* its base filter, bit for bit.

STF, STUKF, STCKF, STSSRCKF (and a strong-tracking 5th-degree CKF or CDKF) are this
layer over the corresponding base filter: configurations, not classes.  Over a plain
sigma-point filter on linear dynamics, a single model's whole step (time update and this
update) runs as one compiled call with the same bits (:meth:`StrongTracking.fused_step`), and a
whole run, over such a filter or over the extended Kalman filter (either form), is one call
(:meth:`StrongTracking.whole_run`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from mmlib.core._validate import check_choice, check_name, check_scalar
from mmlib.core.filters import (LOG_2PI, ExtendedKalmanFilter, FilterLayer, MeasurementPrediction, SigmaPointFilter,
                                 kalman_update)
from mmlib.core import linalg
from mmlib.core.protocols import MeasurementModel

__all__ = ["StrongTracking", "StrongTrackingState"]


class StrongTrackingState(NamedTuple):
    """State of :class:`StrongTracking`: ``mean`` (B, n), ``cov`` (B, n, n), ``V`` (B, m, m) the smoothed
    innovation outer product of Eq. 17, ``Q`` (B, n, n) the process noise of the last prediction and
    ``fading`` (B,) the last fading factor (None before they exist).  Inside an IMM every array has a
    mode axis after B."""

    mean: np.ndarray
    cov: np.ndarray
    V: Any = None            # (..., m, m) smoothed innovation outer product; None before the first update
    Q: Any = None            # (..., n, n) process noise of the last prediction
    fading: Any = None       # (...,) last fading factor lambda_k


@dataclass(frozen=True)
class StrongTracking(FilterLayer):
    """Strong-tracking layer over ``base`` (any filter with ``predict`` / ``predict_measurement``).

    ``beta`` >= 1 is the softening factor, ``rho`` in (0, 1] the forgetting factor
    (Liu & Wu 2017 use 4.5 and 0.95); ``form`` is ``"jacobian"`` (Eqs. 15-16, needs
    ``measurement.jacobian``) or ``"statistical"`` (Eqs. 18-19, Jacobian-free)."""

    base: Any
    beta: float = 4.5
    rho: float = 0.95
    form: str = "statistical"
    name: str = ""
    state_type = StrongTrackingState

    def __post_init__(self):
        self._check_base()
        object.__setattr__(self, "beta", check_scalar(self.beta, "beta", low=1.0))       # softening factor
        object.__setattr__(self, "rho", check_scalar(self.rho, "rho", positive=True, high=1.0))   # forgetting
        check_choice(self.form, "form", ("statistical", "jacobian"))
        check_name(self.name)
        if not self.name:
            object.__setattr__(self, "name", "ST" + getattr(self.base, "name", "filter"))

    def fading_factor(self, state: StrongTrackingState, pred: MeasurementPrediction, V: np.ndarray,
                      measurement: MeasurementModel) -> np.ndarray:
        """lambda_k of Eq. 14 for the predicted ``state`` (P^l (..., n, n), Q) and its measurement prediction
        ``pred``, with the smoothed innovation outer product ``V`` (..., m, m): ``max(1, tr N / tr M)``
        (1 where ``tr M <= 0``), dimensionless, shape (...): :func:`mmlib.core.linalg.jacobian_fading_factor`, and
        for the Jacobian-free form :func:`mmlib.core.linalg.fading_factor`."""
        Q, R = state.Q, measurement.R
        if self.form == "jacobian":
            return linalg.jacobian_fading_factor(measurement.jacobian(state.mean), state.cov, Q, V, R, self.beta)
        return linalg.fading_factor(state.cov, Q, pred.Pxz, V, pred.S, R, self.beta)

    def update(self, state: StrongTrackingState, z: np.ndarray, measurement: MeasurementModel) -> tuple:
        r"""Measurement update with ``z`` (B, m) ((B, 1, m) inside an IMM): innovation of the base filter's
        prediction, ``V`` of Eq. 17 (restarted when the measurement dimension changes), the fading factor
        :math:`\lambda` (:meth:`fading_factor`); where :math:`\lambda > 1` the prior covariance becomes
        :math:`\lambda(P^l - Q) + Q` (Eq. 28) and the measurement is predicted again; then the shared Kalman
        update.  Returns ``(StrongTrackingState, UpdateInfo)`` with ``V`` and ``fading`` recorded;
        ValueError naming ``state`` if no prediction recorded Q, or if it is not a :class:`StrongTrackingState`."""
        self.check_state(state)
        if state.Q is None:
            raise ValueError("state: strong tracking needs predict() before update() (Q of Eq. 28 unknown)")
        pred = self.base.predict_measurement(state, measurement)
        v = measurement.residual(z, pred.z_pred)
        vvt = v[..., :, None] * v[..., None, :]
        # Eq. 17 restarts when the measurement set changes dimension (e.g. the satellites in view): outer
        # products of innovations of different sizes cannot be averaged
        restart = state.V is None or state.V.shape[-1] != vvt.shape[-1]
        V = vvt if restart else (self.rho * state.V + vvt) / (1.0 + self.rho)
        lam = self.fading_factor(state, pred, V, measurement)
        inflate = lam > 1.0
        if inflate.any():
            faded = lam[..., None, None] * (state.cov - state.Q) + state.Q
            cov = np.where(inflate[..., None, None], faded, state.cov)
            state = state._replace(cov=cov)
            pred = self.base.predict_measurement(state, measurement)
        new, info = kalman_update(state, pred, z, measurement)
        return new._replace(V=V, fading=lam), info

    def _fuses(self, state) -> bool:
        """Whether a fused step (:meth:`fused_step`, :meth:`whole_run`) computes this layer's step from ``state``:
        this class itself (a subclass may override a step), the Jacobian-free form, a base that a fused step computes
        (:attr:`mmlib.core.filters.SigmaPointFilter.fusable`), and a ``V`` that is None or float64 (one of another
        precision: the composed update computes Eq. 17 in it)."""
        return (type(self) is StrongTracking and self.form == "statistical" and isinstance(self.base, SigmaPointFilter)
                and self.base.fusable and type(state) is StrongTrackingState
                and (state.V is None or np.asarray(state.V).dtype == np.float64))

    def _runs_ekf(self, state) -> bool:
        """Whether :meth:`whole_run` computes this layer's steps over an extended Kalman filter from ``state``: this
        class itself (either form), exactly an :class:`~mmlib.core.filters.ExtendedKalmanFilter` as the base, and a
        ``V`` that is None or float64 (:meth:`_fuses`)."""
        return (type(self) is StrongTracking and type(self.base) is ExtendedKalmanFilter
                and type(state) is StrongTrackingState
                and (state.V is None or np.asarray(state.V).dtype == np.float64))

    def whole_run(self, state: StrongTrackingState, dynamics: Any, packed: tuple, *, keep_cov: bool, nis: bool,
                  truth: np.ndarray | None = None) -> tuple | None:
        """Every step of a run from ``state`` through ``dynamics`` (linear, one (n, n) ``F``) over the packed
        measurement steps ``packed`` (:func:`mmlib.core.linalg.packed_steps`) in one compiled call
        (:func:`mmlib.core.linalg.strong_tracking_run`): what :meth:`fused_step` computes step after step, V restarted
        where the measurement dimension changes, the same bits; over an extended Kalman filter (:meth:`_runs_ekf`),
        what :meth:`predict` and :meth:`update` compute.  Returns ``(means (B, K, n), covs (B, K, n, n) or None,
        failed (B, K), nis (B, K) or None, nees (B, K) or None)`` (NIS with ``nis``, NEES against ``truth`` when
        given), or None where neither applies (:meth:`_fuses`, :meth:`_runs_ekf`: :func:`mmlib.core.estimation.run`
        then goes step by step)."""
        ekf = self._runs_ekf(state)
        if not ekf and not self._fuses(state):
            return None
        n = dynamics.dim
        if ekf:
            xi, wm, wc = linalg.no_rule_operands(n)
        else:
            up = self.base.rule.unit_points(n)
            xi, wm, wc = up.xi, up.wm, up.wc
        return linalg.strong_tracking_run(state.mean, state.cov, xi, wm, wc, dynamics.F, dynamics.Q, packed,
                                          state.V, self.rho, self.beta, LOG_2PI, keep_cov=keep_cov, nis=nis,
                                          truth=truth, ekf=ekf, jacobian=self.form == "jacobian")

    def fused_step(self, state: StrongTrackingState, dynamics: Any, z: np.ndarray, measurement: MeasurementModel,
                   measure: tuple) -> tuple | None:
        """:meth:`predict` through ``dynamics`` then :meth:`update` with ``z`` (B, m) in one compiled call
        (:func:`mmlib.core.linalg.strong_tracking_step`, the same bits), for a single model whose step the caller
        (:class:`mmlib.core.estimation.SingleModel`) has found fusable: fusion on, linear ``dynamics`` with one
        (n, n) ``F``, and ``measure`` the kernel's form of ``measurement``.  It applies to this class itself (a
        subclass may override a step), the Jacobian-free form, a base that a fused step computes
        (:attr:`mmlib.core.filters.SigmaPointFilter.fusable`), and a ``V`` that is None or float64.
        Returns ``(StrongTrackingState, loglik (B,), innovation (B, m), S (B, m, m), failed (B,))``, or None where it
        does not apply (the composed step runs)."""
        if not self._fuses(state):
            return None
        up = self.base.rule.unit_points(dynamics.dim)
        m = np.shape(z)[-1]
        V = None if state.V is None or state.V.shape[-1] != m else state.V      # Eq. 17 restarts, as in update()
        mean, cov, loglik, innovation, S, failed, V, fading = linalg.strong_tracking_step(
            state.mean, state.cov, up.xi, up.wm, up.wc, dynamics.F, dynamics.Q, z, measure, measurement.angular,
            measurement.R, V, self.rho, self.beta, LOG_2PI)
        new = StrongTrackingState(mean, cov, V, np.broadcast_to(dynamics.Q, cov.shape), fading)
        return new, loglik, innovation, S, failed
