r"""The steady-state Kalman filter of the nearly-constant-velocity model in closed form: the positive control's
"published" numbers.

The model, per Cartesian axis (the discrete white-noise acceleration model, DWNA; Bar-Shalom, Li & Kirubarajan 2001,
*Estimation with Applications to Tracking and Navigation*, Wiley, Sec. 6.3.2): state :math:`[p, v]` (m, m/s),

.. math::
    x_k = F x_{k-1} + \Gamma a_{k-1},\quad F = \begin{bmatrix}1 & T\\ 0 & 1\end{bmatrix},\quad
    \Gamma = \begin{bmatrix}T^2/2\\ T\end{bmatrix},\quad a \sim N(0, \sigma_v^2),\qquad
    z_k = p_k + w_k,\quad w \sim N(0, \sigma_w^2),

with ``T`` the sampling interval (s), :math:`\sigma_v` the acceleration noise's standard deviation (m/s^2) and
:math:`\sigma_w` the position measurement's (m).  The steady state of the Kalman filter depends on the three only
through the *tracking index* (Kalata 1984, IEEE Trans. Aerospace and Electronic Systems 20(2):174,
doi:10.1109/TAES.1984.310438; Bar-Shalom et al. 2001, Sec. 6.5.3)

.. math:: \lambda = \sigma_v T^2 / \sigma_w .

The steady-state gain is :math:`K = [\alpha, \beta/T]^T` with (Kalata 1984; Bar-Shalom et al. 2001, Sec. 6.5.3)

.. math::
    \alpha = -\tfrac18\left(\lambda^2 + 8\lambda - (\lambda + 4)\sqrt{\lambda^2 + 8\lambda}\right),\qquad
    \beta = \tfrac14\left(\lambda^2 + 4\lambda - \lambda\sqrt{\lambda^2 + 8\lambda}\right),

and the covariances follow from :math:`K = M H^T / (H M H^T + \sigma_w^2)` and :math:`P = (I - K H) M`, :math:`H =
[1, 0]` (Bar-Shalom et al. 2001, Sec. 6.5.3): the *predicted* covariance

.. math::
    M_{11} = \frac{\alpha}{1-\alpha}\sigma_w^2,\quad M_{12} = \frac{\beta}{1-\alpha}\frac{\sigma_w^2}{T},\quad
    M_{22} = P_{22} + \sigma_v^2 T^2,

and the *updated* one

.. math::
    P_{11} = \alpha\sigma_w^2,\quad P_{12} = \beta\frac{\sigma_w^2}{T},\quad
    P_{22} = \frac{\beta(\alpha - \beta/2)}{1-\alpha}\frac{\sigma_w^2}{T^2}.

So the updated position error's standard deviation is :math:`\sqrt{\alpha}\,\sigma_w` and the velocity error's
:math:`\sqrt{\beta(\alpha-\beta/2)/(1-\alpha)}\,\sigma_w/T`.  :func:`riccati` iterates the Riccati recursion to
convergence, the independent check (tests/test_controls.py)."""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from mmlib.core._validate import check_scalar

__all__ = [
    "SteadyState", "acceleration_sd", "steady_state", "riccati", "two_point_covariance", "settling_steps"
]


class SteadyState(NamedTuple):
    """The steady state of the DWNA Kalman filter per axis: the gains ``alpha`` and ``beta`` (dimensionless), the
    updated covariance ``P`` and the predicted ``M`` ((2, 2), [m², m²/s; m²/s, m²/s²]), and the updated errors'
    standard deviations ``position_sd`` (m) and ``velocity_sd`` (m/s)."""

    alpha: float
    beta: float
    P: np.ndarray
    M: np.ndarray

    @property
    def position_sd(self) -> float:
        """:math:`\\sqrt{P_{11}}` (m)."""
        return math.sqrt(self.P[0, 0])

    @property
    def velocity_sd(self) -> float:
        """:math:`\\sqrt{P_{22}}` (m/s)."""
        return math.sqrt(self.P[1, 1])


def _check(lam, T, sigma_w) -> tuple[float, float, float]:
    return (check_scalar(lam, "lam", positive=True), check_scalar(T, "T", positive=True),
            check_scalar(sigma_w, "sigma_w", positive=True))


def acceleration_sd(lam: float, T: float, sigma_w: float) -> float:
    """The acceleration noise's standard deviation :math:`\\sigma_v = \\lambda\\sigma_w/T^2` (m/s²) of tracking index
    ``lam`` (> 0) at sampling interval ``T`` (s, > 0) and measurement standard deviation ``sigma_w`` (m, > 0)."""
    lam, T, sigma_w = _check(lam, T, sigma_w)
    return lam * sigma_w / (T * T)


def steady_state(lam: float, T: float, sigma_w: float) -> SteadyState:
    """The closed-form steady state (module docstring) of tracking index ``lam`` (> 0), sampling interval ``T`` (s)
    and position measurement standard deviation ``sigma_w`` (m)."""
    lam, T, sigma_w = _check(lam, T, sigma_w)
    r = math.sqrt(lam * lam + 8.0 * lam)
    alpha = -(lam * lam + 8.0 * lam - (lam + 4.0) * r) / 8.0
    beta = (lam * lam + 4.0 * lam - lam * r) / 4.0
    s2 = sigma_w * sigma_w
    p22 = beta * (alpha - beta / 2.0) / (1.0 - alpha) * s2 / (T * T)
    P = np.array([[alpha * s2, beta * s2 / T], [beta * s2 / T, p22]])
    sv = lam * sigma_w / (T * T)
    M = np.array([[alpha / (1.0 - alpha) * s2, beta / (1.0 - alpha) * s2 / T],
                  [beta / (1.0 - alpha) * s2 / T, p22 + sv * sv * T * T]])
    return SteadyState(alpha, beta, P, M)


def riccati(lam: float, T: float, sigma_w: float, P0: np.ndarray, n_steps: int) -> np.ndarray:
    """The Kalman filter's updated covariances (n_steps, 2, 2) of the DWNA model per axis from the updated covariance
    ``P0`` (2, 2) at step 0: :math:`M = F P F^T + \\Gamma\\Gamma^T\\sigma_v^2`, :math:`K = M H^T/(M_{11} +
    \\sigma_w^2)`, :math:`P = M - K H M` for k = 1..n_steps (the recursion the closed form is the fixed point of)."""
    lam, T, sigma_w = _check(lam, T, sigma_w)
    sv = acceleration_sd(lam, T, sigma_w)
    F = np.array([[1.0, T], [0.0, 1.0]])
    G = np.array([[T * T / 2.0], [T]])
    Q = G @ G.T * sv * sv
    P = np.array(P0, dtype=float)
    if P.shape != (2, 2):
        raise ValueError(f"P0: expected a (2, 2) covariance, got shape {P.shape}")
    out = []
    for _ in range(int(n_steps)):
        M = F @ P @ F.T + Q
        K = M[:, 0] / (M[0, 0] + sigma_w * sigma_w)
        P = M - np.outer(K, M[0])
        out.append(P)
    return np.array(out)


def two_point_covariance(T: float, sigma_w: float) -> np.ndarray:
    """The error covariance per axis of two-point differencing, :math:`\\hat x = [z_1, (z_1 - z_0)/T]`:
    :math:`[[\\sigma_w^2, \\sigma_w^2/T], [\\sigma_w^2/T, 2\\sigma_w^2/T^2]]` (Bar-Shalom et al. 2001, Sec. 5.5.3,
    process noise between the two points neglected), (2, 2) in m², m²/s, m²/s²."""
    T = check_scalar(T, "T", positive=True)
    s2 = check_scalar(sigma_w, "sigma_w", positive=True) ** 2
    return np.array([[s2, s2 / T], [s2 / T, 2.0 * s2 / (T * T)]])


def settling_steps(lam: float, T: float, sigma_w: float, P0: np.ndarray, rtol: float, horizon: int = 10_000) -> int:
    """The first step k after which every updated standard deviation of the Riccati recursion from ``P0``
    (:func:`riccati`) stays within ``rtol`` (relative) of the closed form's, up to ``horizon`` steps."""
    ss = steady_state(lam, T, sigma_w)
    Ps = riccati(lam, T, sigma_w, P0, horizon)
    sd = np.sqrt(np.stack([Ps[:, 0, 0], Ps[:, 1, 1]], axis=1))
    ref = np.array([ss.position_sd, ss.velocity_sd])
    off = np.nonzero(np.abs(sd / ref - 1.0).max(axis=1) > rtol)[0]
    return 0 if off.size == 0 else int(off[-1]) + 1
