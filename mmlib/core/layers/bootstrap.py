r"""Observation bootstrapping (CDKF-OBS, Hu, Zhang, Fu & Li 2017, Eqs. 15-24) as a thin
layer over any filter.

At each step the layer forms :math:`N` bootstrap observations from the one real
measurement, :math:`\tilde z^n = z + v^n`, :math:`v^n \sim N(0, R)` (Eq. 15), and
updates the prediction once per member of :math:`\Theta = \{z, \tilde z^1..\tilde z^N\}`
with the shared Kalman update, using the innovation covariance
:math:`P_{zz}^n = P_{zz} + (c - 1)R` for the bootstrap members (Eq. 18; the text says
the variance doubles, :math:`c = 2`; Eq. 18 prints :math:`(2\sigma)^2`, :math:`c = 4`).
The :math:`N + 1` posteriors are fused as if independent (Eqs. 22-24):

.. math:: P = \Big[\sum_n (P^n)^{-1}\Big]^{-1}, \qquad \hat x = P \sum_n (P^n)^{-1} \hat x^n .

They are not independent -- every member shares the prior and the real
measurement -- so the fused covariance is over-confident; the notebook shows it
with NEES.  The IMM mode likelihood is the sum over the members of
:math:`N(\tilde z^n; \hat z, P_{zz}^n)` (Section 2.2, read as a sum over all N + 1
members), computed in log space; ``likelihood="product"`` treats them as independent.

Eq. 20 prints the member covariance as :math:`P^n = P - K^n P_{zz} (K^n)^T` with
:math:`K^n = P_{xz} (P_{zz}^n)^{-1}` and the *original* :math:`P_{zz}`; the default
``covariance="kalman"`` uses :math:`P_{zz}^n` there (the Kalman form, the exact covariance of
:math:`\hat x^n` when :math:`\tilde z^n` has covariance :math:`P_{zz}^n`);
``covariance="printed"`` is Eq. 20 as printed,
:math:`P^n_{\rm printed} = P^n_{\rm kalman} + K^n (P_{zz}^n - P_{zz}) (K^n)^T`
(identical for the real measurement, n = 0).

The bootstrap noise is drawn *before* filtering from the run's own stream
(``Stream.FILTER``) and handed to :meth:`ObservationBootstrap.init`, so a run's
numbers do not depend on the batch.  With ``n_boot = 0`` the layer is its base filter.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from mmlib.core import linalg
from mmlib.core._validate import (as_float_array, check_choice, check_finite, check_name,
                                  check_positive_int, check_scalar)
from mmlib.core.filters import FilterLayer, MeasurementPrediction, UpdateInfo, gaussian_state, kalman_update
from mmlib.core.protocols import MeasurementModel

__all__ = ["ObservationBootstrap", "BootstrapState"]


class BootstrapState(NamedTuple):
    """State of :class:`ObservationBootstrap`: ``mean`` (B, n), ``cov`` (B, n, n), the pre-drawn standard
    normals ``noise`` (B, K, N, m) (dimensionless) and the index ``step`` of the next step.  Inside an
    IMM the arrays have a mode axis after B."""

    mean: np.ndarray
    cov: np.ndarray
    noise: Any = None        # (B, K, N, m) standard normals for the bootstrap observations
    step: int = 0


@dataclass(frozen=True)
class ObservationBootstrap(FilterLayer):
    """CDKF-OBS layer over ``base``: ``n_boot`` bootstrap observations per step, their
    innovation variance ``variance_factor`` x R (2 by the text, 4 by Eq. 18).

    ``n_boot`` >= 0 (0: the base filter); ``variance_factor`` > 0, dimensionless; ``likelihood``
    ``"sum"`` or ``"product"``; ``covariance`` ``"kalman"`` or ``"printed"`` (Eq. 20); ``name`` a string
    (default the base's name + ``"-OBS"``).  Bad values are a ValueError naming the field."""

    base: Any
    n_boot: int = 2
    variance_factor: float = 2.0
    likelihood: str = "sum"
    name: str = ""
    covariance: str = "kalman"
    state_type = BootstrapState

    def __post_init__(self):
        self._check_base()
        object.__setattr__(self, "n_boot", check_positive_int(self.n_boot, "n_boot", minimum=0))
        object.__setattr__(self, "variance_factor",
                           check_scalar(self.variance_factor, "variance_factor", positive=True))
        check_choice(self.likelihood, "likelihood", ("sum", "product"))
        check_choice(self.covariance, "covariance", ("kalman", "printed"))   # Eq. 20
        check_name(self.name)
        if not self.name:
            object.__setattr__(self, "name", getattr(self.base, "name", "filter") + "-OBS")

    def init(self, mean: np.ndarray, cov: np.ndarray, noise: np.ndarray | None = None) -> BootstrapState:
        """``noise`` (B, K, N, m): pre-drawn standard normals for K steps, N = ``n_boot`` bootstrap
        observations, m >= every step's measurement dimension (a step with m_k < m uses the first m_k)."""
        g = gaussian_state(mean, cov)
        noise = None if noise is None else check_finite(as_float_array(noise, "noise"), "noise")
        if self.n_boot > 0:
            if noise is None or noise.ndim != 4 or noise.shape[0] != g.mean.shape[0] or noise.shape[2] != self.n_boot \
                    or noise.shape[1] == 0 or noise.shape[3] == 0:
                raise ValueError(f"noise: expected pre-drawn standard normals of shape (B={g.mean.shape[0]}, K, "
                                 f"N={self.n_boot}, m), got {None if noise is None else noise.shape}")
        return BootstrapState(g.mean, g.cov, noise, 0)

    def check_state_for(self, state: BootstrapState, measurement: MeasurementModel) -> None:
        """ValueError naming ``noise`` when the pre-drawn noise of ``state`` (from :meth:`init`) is drawn for another
        measurement dimension than ``measurement``'s: an estimator with one fixed sensor calls this at init, where
        noise for more dimensions than the sensor's would silently use the first m of each draw.  (With a sensor
        that changes per step, ``init``'s m is the largest step's, and no estimator calls this.)"""
        self.check_state(state)
        if self.n_boot > 0 and state.noise is not None and state.noise.shape[-1] != measurement.dim:
            raise ValueError(f"noise: pre-drawn for measurements of dimension {state.noise.shape[-1]}, but the "
                             f"measurement model has dimension {measurement.dim}")

    def update(self, state: BootstrapState, z: np.ndarray, measurement: MeasurementModel) -> tuple:
        r"""Measurement update with ``z`` (B, m) ((B, 1, m) inside an IMM): bootstrap observations
        :math:`\tilde z^n = z + L\epsilon^n` (Eq. 15, :math:`LL^T = R`, :math:`\epsilon` the step's pre-drawn
        normals), one shared Kalman update per member of :math:`\Theta` (innovation covariance
        :math:`P_{zz} + (c-1)R` for the bootstrap members, c = ``variance_factor``), information-weighted
        fusion of the N + 1 posteriors (Eqs. 22-24) and the likelihood of ``likelihood``.  Returns
        ``(BootstrapState, UpdateInfo)``, the innovation, S and NIS those of the real measurement; a run
        is failed when any member's update or the fusion fails.  ValueError naming ``noise`` when no
        pre-drawn noise is left for this step or it is drawn for a smaller measurement dimension; naming ``state``
        when it is not a :class:`BootstrapState`."""
        self.check_state(state)
        pred = self.base.predict_measurement(state, measurement)
        if self.n_boot == 0:
            new, info = kalman_update(state, pred, z, measurement)
            return new._replace(step=state.step + 1), info
        if state.noise is None or state.step >= state.noise.shape[-3]:
            drawn = 0 if state.noise is None else state.noise.shape[-3]
            raise ValueError(f"noise: pre-drawn bootstrap noise for {drawn} steps, but step {state.step} needs it "
                             f"(draw it for every step, see init)")
        m = z.shape[-1]
        if state.noise.shape[-1] < m:
            raise ValueError(f"noise: pre-drawn for measurements of dimension {state.noise.shape[-1]}, "
                             f"but step {state.step} has dimension {m}")
        # (B, N, m), or (B, r, N, m) inside an IMM, where every mode holds the same draws
        eps = state.noise[..., state.step, :, :m]
        boot = z[..., None, :] + eps @ measurement.noise_factor.T            # (..., N, m), Eq. 15
        posts, infos = [], []
        for n in range(self.n_boot + 1):
            if n == 0:
                zn, p = z, pred
            else:
                zn = boot[..., n - 1, :]
                # S^n = HPH^T + c R exactly where H exists: the Joseph form with the effective noise c R
                p = MeasurementPrediction(pred.z_pred, pred.S + (self.variance_factor - 1.0) * measurement.R, pred.Pxz,
                                          pred.H, None if pred.H is None else self.variance_factor * measurement.R)
            post, info = kalman_update(state, p, zn, measurement)
            if n > 0 and self.covariance == "printed":          # Eq. 20 as printed: P_zz, not P_zz^n
                gain = np.swapaxes(np.linalg.solve(p.S, np.swapaxes(p.Pxz, -1, -2)), -1, -2)
                extra = (self.variance_factor - 1.0) * (gain @ measurement.R @ np.swapaxes(gain, -1, -2))
                post = post._replace(cov=linalg.symmetrize(post.cov + extra))
            posts.append(post)
            infos.append(info)
        # Eqs. 22-24: information-weighted fusion of the N + 1 posteriors
        mean, cov, fused_ok = linalg.information_fusion(np.stack([p.mean for p in posts]),
                                                        np.stack([p.cov for p in posts]))
        failed = ~fused_ok
        for i in infos:
            failed = failed | i.failed
        ll = np.stack([i.loglik for i in infos], axis=-1)
        if self.likelihood == "sum":
            top = np.max(ll, axis=-1, keepdims=True)
            # every member's likelihood underflowed: the sum is -inf too (not -inf - -inf = NaN, which the IMM
            # would report as a non-finite state instead of as likelihood underflow)
            top = np.where(np.isneginf(top), 0.0, top)
            with np.errstate(divide="ignore"):          # log(0) = -inf is that underflow
                loglik = (top + np.log(np.exp(ll - top).sum(axis=-1, keepdims=True)))[..., 0]
        else:
            loglik = ll.sum(axis=-1)
        new = state._replace(mean=mean, cov=cov, step=state.step + 1)
        return new, UpdateInfo(infos[0].innovation, infos[0].S, loglik, infos[0].nis, failed)
