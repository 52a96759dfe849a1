r"""An IMM whose modes' process-noise levels are set online from the innovations, and the
fuzzy logic adaptive system (FLAS) of Tseng, Chang & Jwo 2011 (Sec. 3) that sets them.

:class:`NoiseAdaptiveIMM` is a thin layer over :class:`mmlib.estimation.IMM`: at step k it
builds the modes' process noise :math:`Q_j = Q(\ell_{k,j})` from per-run levels
:math:`\ell_k` (B, r), runs one ordinary IMM cycle with those dynamics, and asks a
``controller`` for the levels of step k+1 from the IMM's innovation at k (causal: the levels
used at k depend on measurements up to k-1).  With ``frozen=True`` the levels never change
and the layer *is* the IMM whose modes have the initial levels (tested bit for bit).

Degree of divergence (Tseng et al. 2011, Sec. 3.2), from the innovation
:math:`\upsilon_k` (m satellites) at the present epoch (window size one):

.. math:: \xi_k = \frac{\mathrm{tr}(\upsilon_k\upsilon_k^T)}{m} = \frac{\upsilon_k^T\upsilon_k}{m},
          \qquad \eta_k = \frac1m \sum_i |\upsilon_{k,i}|.

:func:`degree_of_divergence` returns them divided by :math:`\sigma^2` and :math:`\sigma`
(:math:`\sigma^2` the mean measurement-noise variance), so that the fuzzy sets are
dimensionless: for consistent innovations with variance near :math:`\sigma^2`, :math:`\xi/\sigma^2`
is :math:`\chi^2_m/m` (mean 1) and :math:`\eta/\sigma` has mean :math:`\sqrt{2/\pi} \approx 0.80`.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, NamedTuple

import numpy as np

from ._validate import as_float_array
from .estimation import IMM, IMMState
from .fuzzy import TakagiSugeno


def degree_of_divergence(innovation, noise_variance) -> np.ndarray:
    r"""(B, 2): :math:`[\xi/\sigma^2, \eta/\sigma]` for innovations (B, m) and :math:`\sigma^2` (scalar
    or (B,))."""
    nu = np.asarray(innovation, dtype=float)
    s2 = np.asarray(noise_variance, dtype=float)
    if nu.ndim != 2:
        raise ValueError(f"innovation: expected shape (B, m), got {nu.shape}")
    if np.any(~(s2 > 0)):
        raise ValueError(f"noise_variance: must be > 0, got {noise_variance!r}")
    xi = (nu * nu).mean(axis=1) / s2
    eta = np.abs(nu).mean(axis=1) / np.sqrt(s2)
    return np.stack([xi, eta], axis=-1)


@dataclass(frozen=True, eq=False)
class FuzzyNoiseBounds:
    """The FLAS: degree of divergence -> (lower, upper) process-noise levels of a two-mode IMM.

    ``system`` is a Takagi-Sugeno system with the two inputs of :func:`degree_of_divergence`
    and two outputs, the base-10 logarithms of the lower and upper levels (the consequents are
    averaged in log space: the levels are scale parameters spanning decades)."""

    system: TakagiSugeno

    def __post_init__(self):
        if self.system.n_inputs != 2 or self.system.consequents.shape[-1] != 2:
            raise ValueError("system: expected 2 inputs (xi, eta) and 2 outputs (log10 lower, log10 upper)")

    def dod(self, innovation, measurement) -> np.ndarray:
        return degree_of_divergence(innovation, float(np.mean(np.diag(measurement.R))))

    def __call__(self, innovation, measurement) -> np.ndarray:
        """Levels (B, 2); NaN for runs whose innovation is not finite (diverged runs stay visible)."""
        dod = self.dod(innovation, measurement)
        ok = np.isfinite(dod).all(axis=1)
        out = np.full((dod.shape[0], 2), np.nan)
        if ok.any():
            out[ok] = 10.0 ** self.system(dod[ok])
        return out


class NoiseAdaptiveState(NamedTuple):
    imm: IMMState
    levels: np.ndarray          # (B, r) noise level of every mode for the next step


@dataclass(frozen=True, eq=False)
class NoiseAdaptiveIMM:
    """IMM with per-run, per-step process-noise levels (see the module docstring).

    ``noise(levels)`` maps levels (B, r) to Q (B, r, n, n) (e.g. :meth:`mmlib.gnss.PVClockNoise.Q`);
    ``controller(innovation, measurement)`` returns the next levels (B, r);
    ``initial_levels`` (r,) are the levels of the first step.  Each step's ``Estimate.diagnostics``
    holds the levels used in that step."""

    imm: IMM
    noise: Callable
    controller: Any
    initial_levels: tuple
    frozen: bool = False
    name: str = "adaptive IMM"

    def __post_init__(self):
        lv = as_float_array(self.initial_levels, "initial_levels")
        if lv.shape != (self.imm.n_modes,) or np.any(~np.isfinite(lv)) or np.any(lv < 0):
            raise ValueError(f"initial_levels: expected {self.imm.n_modes} finite levels >= 0, got {self.initial_levels!r}")
        object.__setattr__(self, "initial_levels", lv)

    @property
    def measurement(self):
        return self.imm.measurement

    def init(self, mean, cov, mode_probabilities=None, **filter_init) -> NoiseAdaptiveState:
        s = self.imm.init(mean, cov, mode_probabilities, **filter_init)
        B = s.mode_probabilities.shape[0]
        return NoiseAdaptiveState(s, np.tile(self.initial_levels, (B, 1)))

    def step(self, state: NoiseAdaptiveState, z, *, with_cov: bool = True, measurement=None):
        measurement = self.imm.measurement if measurement is None else measurement
        dynamics = self.imm.stacked.with_noise(self.noise(state.levels))
        imm_state, est = self.imm.step(state.imm, z, with_cov=with_cov, measurement=measurement, dynamics=dynamics)
        if self.frozen:
            levels = state.levels
        else:
            levels = np.asarray(self.controller(est.innovation, measurement), dtype=float)
            if levels.shape != state.levels.shape:
                raise ValueError(f"controller: expected levels of shape {state.levels.shape}, got {levels.shape}")
            # a diverged run has a NaN innovation: keep its NaN levels (reported by run(), never patched)
        return NoiseAdaptiveState(imm_state, levels), est._replace(diagnostics=state.levels)
