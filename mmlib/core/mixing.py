r"""Alternative IMM interaction steps (the standard one is :class:`mmlib.core.estimation.MomentMixing`).

Cubature-principle mixing (CPIMM, Zhou, Zhao, Huang & Zhao 2017, Eqs. 13-19): the
interaction is treated as a function of the augmented variable
:math:`\chi = [x_1; \dots; x_m] \sim N(\hat\chi, \mathrm{blkdiag}(P_i))` (independent
modes), :math:`f_j(\chi) = \sum_i \mu_{i|j} x_i`, integrated with the third-degree
cubature rule (``2l`` points, ``l = mn``).

Because :math:`f_j` is **linear** in :math:`\chi`, the rule is exact and the result is
known in closed form:

.. math:: \hat x^{0j} = \sum_i \mu_{i|j}\hat x_i, \qquad P^{0j} = \sum_i \mu_{i|j}^2 P_i ,

the moments of a weighted *sum* of independent Gaussians -- not of the Gaussian
*mixture* the IMM interaction describes (whose covariance is
:math:`\sum_i \mu_{i|j}[P_i + (\hat x_i - \hat x^{0j})(\cdot)^T]`).  The spread-of-means
term disappears and :math:`\mu^2 \le \mu` shrinks the rest.  The class below evaluates
the cubature points literally (as printed); the tests check it against the closed form.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mmlib.core import linalg

__all__ = ["CubatureMixing"]


@dataclass(frozen=True)
class CubatureMixing:
    r"""CPIMM interaction (Zhou et al. 2017, Eqs. 14-19), evaluated on the 2mn cubature points.

    Called as :class:`mmlib.core.estimation.MomentMixing`: ``means`` (B, r, n), ``covs`` (B, r, n, n), mixing
    weights ``w`` (B, r_from, r_to) -> ``(mixed means (B, r, n), mixed covs (B, r, n, n))``, equal (to
    round-off) to :math:`\sum_i \mu_{i|j}\hat x_i` and :math:`\sum_i \mu_{i|j}^2 P_i` (module docstring).  A
    mode covariance that is not positive definite gives NaN for that run."""

    name: str = "cubature-principle"

    def __call__(self, means: np.ndarray, covs: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        B, r, n = means.shape
        l = r * n
        chol, _ = linalg.cholesky(covs)         # (B, r, n, n) blocks of S; a non-PD block gives NaN (reported)
        wt = np.swapaxes(w, -1, -2)                                        # (B, j, i)
        centre = wt @ means                                                # f_j(chi_hat), (B, j, n)
        # point +-sqrt(l) S e_c in block i moves f_j by +-sqrt(l) mu_{i|j} S_i[:, c]
        cols = np.swapaxes(chol, -1, -2)                                   # (B, i, c, n): columns as rows
        shift = math.sqrt(l) * wt[:, :, :, None, None] * cols[:, None]      # (B, j, i, c, n)
        shift = shift.reshape(B, r, l, n)
        pts = np.concatenate([centre[:, :, None, :] + shift, centre[:, :, None, :] - shift], axis=2)
        mean = pts.mean(axis=2)                                            # Eq. 18, weights 1/(2l)
        d = pts - mean[:, :, None, :]
        cov = np.swapaxes(d, -1, -2) @ d / (2 * l)                         # Eq. 19
        return mean, 0.5 * (cov + np.swapaxes(cov, -1, -2))
