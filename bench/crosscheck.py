"""Equivalent FilterPy estimators for cross-checks (tests and the benchmark).

FilterPy is a test-only dependency: it is imported lazily here.  Conventions
mapped: FilterPy's ``IMMEstimator`` uses ``M[i, j]`` = P(from i to j) in its
code (its docstring says the opposite), the same as mmlib; ``residual_z`` wraps
bearings through the mmlib measurement model.
"""
from __future__ import annotations

import numpy as np


def filterpy_ukf(dynamics, measurement, x0, P0, alpha=1.0, beta=2.0, kappa=0.0, dt=1.0):
    """A FilterPy ``UnscentedKalmanFilter`` on an mmlib linear dynamics model and measurement model."""
    from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

    def hx(x):
        return measurement.h(np.asarray(x)[None, None, :])[0, 0]

    def residual_z(a, b):
        return measurement.residual(np.asarray(a, dtype=float), np.asarray(b, dtype=float))

    n = dynamics.dim
    f = UnscentedKalmanFilter(n, measurement.dim, dt, hx, lambda x, _dt, F=dynamics.F: F @ x,
                              MerweScaledSigmaPoints(n, alpha, beta, kappa), residual_z=residual_z)
    f.x, f.P, f.Q, f.R = np.array(x0, float), np.array(P0, float), np.array(dynamics.Q), np.array(measurement.R)
    return f


def filterpy_imm_ukf(dynamics, measurement, x0, P0, transition, mode_probabilities=None, **ukf_params):
    """A FilterPy ``IMMEstimator`` of UKFs, one per mmlib dynamics model."""
    from filterpy.kalman import IMMEstimator

    r = len(dynamics)
    mu = np.full(r, 1.0 / r) if mode_probabilities is None else np.array(mode_probabilities, float)
    filters = [filterpy_ukf(d, measurement, x0, P0, **ukf_params) for d in dynamics]
    return IMMEstimator(filters, mu, np.asarray(transition, float))
