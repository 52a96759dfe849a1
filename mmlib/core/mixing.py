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

from dataclasses import dataclass

import numpy as np

from mmlib.core import linalg

__all__ = ["CubatureMixing"]


@dataclass(frozen=True)
class CubatureMixing:
    r"""CPIMM interaction (Zhou et al. 2017, Eqs. 14-19), evaluated on the 2mn cubature points
    (:func:`mmlib.core.linalg.cubature_mix`).

    Called as :class:`mmlib.core.estimation.MomentMixing`: ``means`` (B, r, n), ``covs`` (B, r, n, n), mixing
    weights ``w`` (B, r_from, r_to) -> ``(mixed means (B, r, n), mixed covs (B, r, n, n))``, equal (to
    round-off) to :math:`\sum_i \mu_{i|j}\hat x_i` and :math:`\sum_i \mu_{i|j}^2 P_i` (module docstring).  A
    mode covariance that is not positive definite gives NaN for that run."""

    name: str = "cubature-principle"

    def __call__(self, means: np.ndarray, covs: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return linalg.cubature_mix(means, covs, w)

    def fused_form(self) -> str | None:
        """``"cubature"`` where a compiled whole IMM run (:func:`mmlib.core.linalg.imm_layer_run`) computes this
        interaction: this class itself, not a subclass (which may override it); else None."""
        return "cubature" if type(self) is CubatureMixing else None
