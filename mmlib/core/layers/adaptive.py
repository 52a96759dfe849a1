r"""Innovation-based adaptive filtering as one thin layer over any sigma-point filter.

NAUKF (Zhou, Zhao, Huang & Zhao 2017, Eqs. 27-39).  With the rule's measurement
covariance :math:`P_{zz}^{sp} = \sum_i W_i (\gamma_i - \hat z)(\cdot)^T` and an estimate
:math:`\hat C_k` of the innovation covariance :math:`P_{\tilde z\tilde z}`, the adaptive
gene :math:`\Delta_k = (\hat C_k - P_{zz}^{sp})R^{-1}` (Eq. 27) enters
:math:`\bar P_{zz} = P_{zz}^{sp} + \Delta_k R` (Eq. 28), i.e.

.. math:: \bar P_{zz} = \hat C_k

identically: the "adaptive gene" replaces the predicted innovation covariance by the
empirical one.  That is innovation-based adaptive estimation of R (Mohamed & Schwarz
1999, J. Geodesy 73:193-203: :math:`\hat R = \hat C - P_{zz}^{sp}`,
:math:`S = P_{zz}^{sp} + \hat R = \hat C`).  What NAUKF adds is the covariance-matching
test (Eq. 32) and, when the innovation is too large, the inflation
:math:`\bar P = \zeta(P - Q) + Q` with :math:`\zeta = \max(1, \mathrm{tr}(\hat C - R) /
\mathrm{tr}(P - Q))` (Eqs. 33-35) -- the same form as a strong-tracking fading factor.
The gain uses the *unmodified* cross-covariance (Eq. 37, as printed).

:math:`\hat C_k` is the mean of :math:`\tilde z\tilde z^T` over a sliding window
(``window`` innovations; ``include_current`` decides whether the current innovation is
in it).  Until ``window`` innovations exist the standard predicted covariance is used.

As printed, :math:`\bar P_{zz} = \hat C` with the unmodified :math:`P_{xz}` gives the posterior
:math:`P - P_{xz}\hat C^{-1}P_{xz}^T`, which is positive definite only if :math:`\hat C` exceeds
:math:`P_{xz}^T P^{-1} P_{xz}` (= :math:`HPH^T` for linear h) in every direction; a windowed
estimate violates that whenever R is not much larger than :math:`HPH^T`, and the run diverges
(reported).  ``inflate_only=True`` -- *not in the paper*, a labelled variant -- keeps only the
positive part of :math:`\hat C - P_{zz}`, so the adaptive covariance can only grow.

Configurations: ``InnovationAdaptive(base, zeta=True, include_current=True)`` is NAUKF;
``InnovationAdaptive(base, zeta=False, include_current=False)`` is the IAE adaptive UKF
of Mohamed & Schwarz (window of past innovations).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from mmlib.core import linalg
from mmlib.core._validate import check_bool, check_name, check_positive_int, check_scalar
from mmlib.core.filters import LOG_2PI, FilterLayer, MeasurementPrediction, SigmaPointFilter, kalman_update
from mmlib.core.linalg import trace
from mmlib.core.protocols import MeasurementModel

__all__ = ["InnovationAdaptive", "AdaptiveState"]


class AdaptiveState(NamedTuple):
    """State of :class:`InnovationAdaptive`: ``mean`` (B, n), ``cov`` (B, n, n); ``innovations`` (B, W, m)
    the last W <= ``window`` innovations (newest last, None before the first update); ``count`` updates so
    far; ``Q`` (B, n, n) the process noise of the last prediction; ``zeta`` (B,) the last inflation
    factor of Eq. 34 (None until computed).  Inside an IMM every array has a mode axis after B."""

    mean: np.ndarray
    cov: np.ndarray
    innovations: Any = None    # (..., window, m) most recent innovations, newest last
    count: int = 0
    Q: Any = None
    zeta: Any = None


@dataclass(frozen=True)
class InnovationAdaptive(FilterLayer):
    """Innovation-covariance-matching layer (NAUKF / IAE-AUKF); see the module docstring.

    ``base``: a :class:`mmlib.core.protocols.MomentFilter`; ``window`` >= 2 innovations in
    :math:`\\hat C_k`; ``psi`` >= 1 the coefficient of the covariance-matching test (Eq. 32,
    dimensionless); ``zeta``: apply the inflation of Eqs. 33-35; ``include_current``: the current
    innovation is in the window; ``inflate_only``: the labelled non-paper variant; ``name`` a string
    (default ``"NA"``/``"A"`` + the base's name).  Bad values are a ValueError naming the field."""

    base: Any
    window: int = 10
    psi: float = 1.0
    zeta: bool = True
    include_current: bool = True
    inflate_only: bool = False
    name: str = ""
    state_type = AdaptiveState

    def __post_init__(self):
        self._check_base()
        object.__setattr__(self, "window", check_positive_int(self.window, "window", minimum=2))
        object.__setattr__(self, "psi", check_scalar(self.psi, "psi", low=1.0))   # Eq. 32 coefficient
        for flag in ("zeta", "include_current", "inflate_only"):
            check_bool(getattr(self, flag), flag)
        check_name(self.name)
        if not self.name:
            object.__setattr__(self, "name", ("NA" if self.zeta else "A") + getattr(self.base, "name", "filter"))

    def update(self, state: AdaptiveState, z: np.ndarray, measurement: MeasurementModel) -> tuple:
        r"""Measurement update with ``z`` (B, m) ((B, 1, m) inside an IMM): the base filter's prediction, the
        innovation :math:`\tilde z = z - \hat z` appended to the window, then the shared Kalman update with
        :math:`\bar P_{zz} = \hat C_k = \frac1W\sum \tilde z\tilde z^T` (Eqs. 27-28; ``inflate_only``: the
        predicted S plus the positive part of :math:`\hat C_k - S`) and the unmodified :math:`P_{xz}`
        (Eq. 37).  With ``zeta``, where the test of Eq. 32, :math:`\tilde z^T\tilde z \le \psi\,\mathrm{tr}\,S`,
        fails, the prior covariance is first inflated to :math:`\zeta(P - Q) + Q` (Eqs. 33-35).  Until
        ``window`` innovations exist it is the base filter's update.  A measurement of another dimension
        restarts the window.  Returns ``(AdaptiveState, UpdateInfo)``; ValueError naming ``state`` if
        ``zeta`` is set and no prediction recorded Q, or if it is not an :class:`AdaptiveState`."""
        self.check_state(state)
        pred = self.base.predict_measurement(state, measurement)
        nu = measurement.residual(z, pred.z_pred)
        past = state.innovations
        if past is not None and past.shape[-1] != nu.shape[-1]:
            past = None    # the measurement set changed dimension: innovations of different sets are not pooled
        window_now = nu[..., None, :] if past is None else np.concatenate([past, nu[..., None, :]], axis=-2)
        window_now = window_now[..., -self.window:, :]
        used = window_now if self.include_current else past
        new_state = state._replace(innovations=window_now, count=state.count + 1)
        have = 0 if used is None else used.shape[-2]
        if have < self.window:                       # not enough innovations yet: the base filter
            new, info = kalman_update(new_state, pred, z, measurement)
            return new, info
        C = linalg.gram(used) / have                                       # empirical innovation covariance
        S_bar = C                                                          # Eqs. 27-28: P_zz + Delta R = C
        if self.inflate_only:
            # NOT in the paper: S_bar = S + PSD part of (C - S), so the adaptive covariance can only grow.
            # As printed, S_bar = C below H P H^T makes P - Pxz C^-1 Pxz^T indefinite (the filter diverges).
            S_bar = pred.S + linalg.psd_part(C - pred.S)
        if self.zeta:
            if state.Q is None:
                raise ValueError("state: predict() must run before update() (Q of Eq. 33 unknown)")
            matched = trace(nu[..., :, None] * nu[..., None, :]) <= self.psi * trace(pred.S)   # Eq. 32
            base_part = state.cov - state.Q
            with np.errstate(divide="ignore", invalid="ignore"):
                z0 = trace(C - measurement.R) / trace(base_part)                              # Eq. 35
            zeta = np.where(matched, 1.0, np.maximum(np.nan_to_num(z0, nan=1.0), 1.0))         # Eq. 34
            inflate = zeta > 1.0
            cov = np.where(inflate[..., None, None], zeta[..., None, None] * base_part + state.Q, state.cov)
            new_state = new_state._replace(cov=cov, zeta=zeta)
        new, info = kalman_update(new_state, MeasurementPrediction(pred.z_pred, S_bar, pred.Pxz), z, measurement)
        return new, info

    def _fuses(self, state) -> bool:
        """Whether :meth:`whole_run` computes this layer's steps from ``state``: this class itself (a subclass may
        override a step), a base that a fused step computes (:attr:`mmlib.core.filters.SigmaPointFilter.fusable`), and
        a state from :meth:`init` with no innovation yet (a run's start)."""
        return (type(self) is InnovationAdaptive and isinstance(self.base, SigmaPointFilter) and self.base.fusable
                and type(state) is AdaptiveState and state.innovations is None)

    def fused_adaptive_form(self, state: Any) -> tuple | None:
        """``(window, psi, zeta, include_current, inflate_only)`` where a compiled whole run computes this layer's
        steps from ``state`` (:meth:`_fuses`; e.g. the mode filters of :func:`mmlib.core.linalg.imm_layer_run`), else
        None."""
        if not self._fuses(state):
            return None
        return self.window, self.psi, self.zeta, self.include_current, self.inflate_only

    def whole_run(self, state: AdaptiveState, dynamics: Any, packed: tuple, *, keep_cov: bool, nis: bool,
                  truth: np.ndarray | None = None) -> tuple | None:
        """Every step of a run from ``state`` through ``dynamics`` (linear, one (n, n) ``F``) over the packed
        measurement steps ``packed`` (:func:`mmlib.core.linalg.packed_steps`) in one compiled call
        (:func:`mmlib.core.linalg.adaptive_run`): what :meth:`predict` and :meth:`update` compute step after step, the
        window restarted where the measurement dimension changes, the same bits.  Returns ``(means (B, K, n), covs
        (B, K, n, n) or None, failed (B, K), nis (B, K) or None, nees (B, K) or None)``, or None where it does not
        apply (:meth:`_fuses`, or :func:`~mmlib.core.linalg.adaptive_run` declines): :func:`mmlib.core.estimation.run`
        then goes step by step."""
        if not self._fuses(state):
            return None
        up = self.base.rule.unit_points(dynamics.dim)
        return linalg.adaptive_run(state.mean, state.cov, up.xi, up.wm, up.wc, dynamics.F, dynamics.Q, packed,
                                   self.window, self.psi, self.zeta, self.include_current, self.inflate_only, LOG_2PI,
                                   keep_cov=keep_cov, nis=nis, truth=truth)
