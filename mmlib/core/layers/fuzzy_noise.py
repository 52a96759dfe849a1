r"""A fuzzy controller of process-noise levels: the fuzzy logic adaptive system (FLAS) of Tseng, Chang & Jwo
2011 (Sec. 3), which sets the lower and upper process-noise levels of a two-mode IMM from the degree of
divergence of its innovations, and the IMM it drives.

:class:`FuzzyNoiseBounds` is the ``controller`` of a :class:`~mmlib.core.layers.adaptive_imm.NoiseAdaptiveIMM`
(or, with a moving DOD window, of a :class:`~mmlib.core.layers.adaptive_imm.WindowedNoiseAdaptiveIMM`): at step k
it takes the IMM's innovation :math:`\upsilon_k` (B, m) and its predicted covariance :math:`S_k` and returns the
levels (B, 2) of step k+1.  Its inputs are the two degrees of divergence of
:func:`~mmlib.core.layers.adaptive_imm.degree_of_divergence` (Tseng et al. 2011, Sec. 3.2),
:math:`[\xi/\bar s, \eta/\sqrt{\bar s}]`, with :math:`\bar s = \mathrm{tr}(S_k)/m` the predicted innovation
variance per measurement (``normalise="innovation"``) or the mean measurement-noise variance
(``"measurement"``); its outputs are :math:`\log_{10}` of the lower and upper levels (the consequents are
averaged in log space: the levels are scale parameters spanning decades).

:func:`fuzzy_system` builds the zero-order Takagi-Sugeno rule base (:class:`mmlib.core.fuzzy.TakagiSugeno`) from a
few numbers.  The paper's own membership functions and rules did not survive; this rule base is a first-principles
reconstruction, not fitted to any result (the replication declares it as its deviation T-10):

* the sets of :math:`\xi/\bar s`: ramp sets (:func:`mmlib.core.fuzzy.ramp_sets`, a partition of unity) reaching 1
  at ``breakpoints`` :math:`b_1 < \dots < b_n` (dimensionless); for a consistent filter :math:`\xi/\bar s` is
  close to :math:`\chi^2_m/m` (mean 1), so breakpoints at its mean and upper quantiles grade "consistent" to
  "diverging";
* the sets of :math:`\eta/\sqrt{\bar s}`: ramp sets at :math:`\sqrt{2/\pi}\,\sqrt{b_i}`, since for Gaussian
  innovations :math:`\mathrm{E}|\upsilon_i| = \sqrt{2/\pi}\,\sigma_i`, i.e. :math:`\eta/\sqrt{\bar s} \approx
  0.80\sqrt{\xi/\bar s}`;
* the :math:`n^2` rules: with :math:`i, j` the sets of the two inputs, the output position
  :math:`p = \max(i, j)/(n - 1) \in [0, 1]` (either input diverging raises the noise) slides a band half the
  log-range wide along the range: :math:`\log_{10} \ell_{\rm lower} = \log_{10} L + p D`,
  :math:`\log_{10} \ell_{\rm upper} = \log_{10} L + D + p D`, with :math:`D = \tfrac12 (\log_{10} U -
  \log_{10} L)`; the levels therefore never leave :math:`[L, U]` (``lower``, ``upper``, in the noise family's
  level unit, e.g. an acceleration PSD in m^2/s^3), and the first rule ("Normal" for both inputs) gives the
  bottom band :math:`(L, \sqrt{LU})`.

:func:`fuzzy_imm` assembles the IMM over any mode filter and any process-noise family: its two modes start at the
first rule's levels and the FLAS resets them every step.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from mmlib.core import linalg
from mmlib.core._validate import as_float_array, check_choice, check_has, check_positive_int, check_scalar
from mmlib.core.estimation import IMM, Estimate
from mmlib.core.fuzzy import TakagiSugeno, ramp_sets
from mmlib.core.layers.adaptive_imm import NoiseAdaptiveIMM, WindowedNoiseAdaptiveIMM, degree_of_divergence
from mmlib.core.protocols import MeasurementModel, MomentFilter

__all__ = ["fuzzy_imm", "FuzzyNoiseBounds", "fuzzy_system", "NORMALISE", "SET_NAMES"]

#: the reference variances the degree of divergence is divided by (see the module docstring)
NORMALISE = ("innovation", "measurement")
#: the default names of the fuzzy sets, lowest first (three sets)
SET_NAMES = ("Normal", "Moderate", "Large")


def fuzzy_system(breakpoints: Sequence[float] | np.ndarray, lower: float, upper: float,
                 names: Sequence[str] = SET_NAMES) -> TakagiSugeno:
    r"""The FLAS rule base of the module docstring: inputs ``(xi / s, eta / sqrt(s))``, outputs ``(log10 lower,
    log10 upper)``.  ``breakpoints`` (n,): where the sets of :math:`\xi/\bar s` reach 1, increasing
    (dimensionless); ``lower`` < ``upper``: the range of the levels (> 0, the noise family's level unit);
    ``names``: n set names, lowest first.  Returns a :class:`~mmlib.core.fuzzy.TakagiSugeno` with consequents
    (n, n, 2).  ValueError naming ``breakpoints``, ``lower``, ``upper`` or ``names`` otherwise."""
    bx = as_float_array(breakpoints, "breakpoints")
    if bx.ndim != 1 or bx.shape[0] < 2 or np.any(~np.isfinite(bx)) or np.any(bx < 0):
        raise ValueError(f"breakpoints: expected at least two finite values >= 0, got {breakpoints!r}")
    lower, upper = check_scalar(lower, "lower", positive=True), check_scalar(upper, "upper", positive=True)
    if not lower < upper:
        raise ValueError(f"upper: expected lower < upper, got lower={lower}, upper={upper}")
    be = math.sqrt(2.0 / math.pi) * np.sqrt(bx)
    n = bx.shape[0]
    lo, hi = math.log10(lower), math.log10(upper)
    half = (hi - lo) / 2.0
    p = np.maximum.outer(np.arange(n), np.arange(n)) / (n - 1)             # rule grid (xi set, eta set)
    cons = np.stack([lo + p * half, lo + half + p * half], axis=-1)
    return TakagiSugeno((ramp_sets(names, bx), ramp_sets(names, be)), cons,
                        ("xi / s", "eta / sqrt(s)"), ("log10 lower level", "log10 upper level"))


@dataclass(frozen=True, eq=False)
class FuzzyNoiseBounds:
    """The FLAS as the controller of a :class:`~mmlib.core.layers.adaptive_imm.NoiseAdaptiveIMM`: degree of
    divergence -> (lower, upper) process-noise levels of a two-mode IMM.

    ``system`` is a Takagi-Sugeno system with the two inputs of :func:`degree_of_divergence` and two outputs, the
    base-10 logarithms of the lower and upper levels (e.g. :func:`fuzzy_system`).  ``normalise`` is
    ``"innovation"`` (divide by the predicted innovation variance per measurement) or ``"measurement"`` (by the
    mean measurement-noise variance)."""

    system: TakagiSugeno
    normalise: str = "innovation"

    def __post_init__(self):
        if not isinstance(self.system, TakagiSugeno):
            raise ValueError(f"system: expected a TakagiSugeno system, got {type(self.system).__name__}")
        if self.system.n_inputs != 2 or self.system.consequents.shape[-1] != 2:
            raise ValueError("system: expected 2 inputs (xi, eta) and 2 outputs (log10 lower, log10 upper)")
        if self.normalise not in NORMALISE:
            raise ValueError(f"normalise: expected 'innovation' or 'measurement', got {self.normalise!r}")

    def dod(self, estimate: Estimate, measurement: MeasurementModel) -> np.ndarray:
        """Degrees of divergence (B, 2), ``[xi / s, eta / sqrt(s)]`` (:func:`degree_of_divergence`), of this
        step's innovations, ``s`` the reference variance of ``normalise``: the mean of the predicted innovation
        variances (per run) or of ``measurement.R``'s diagonal."""
        if self.normalise == "measurement":
            ref = float(np.mean(np.diag(measurement.R)))
        else:
            S = estimate.innovation_cov
            ref = np.trace(S, axis1=-2, axis2=-1) / S.shape[-1]
            ref = np.where(np.isfinite(ref), ref, 1.0)          # diverged runs: NaN innovation anyway
        return degree_of_divergence(estimate.innovation, ref)

    def __call__(self, estimate, measurement) -> np.ndarray:
        """Levels (B, 2) of the next step from this step's estimate (:meth:`levels` of :meth:`dod`)."""
        return self.levels(self.dod(estimate, measurement))

    def levels(self, dod: np.ndarray) -> np.ndarray:
        """Levels (B, 2) from degrees of divergence (B, 2); NaN for runs whose DOD is not finite (diverged runs
        stay visible)."""
        ok = np.isfinite(dod).all(axis=1)
        out = np.full((dod.shape[0], 2), np.nan)
        if ok.any():
            out[ok] = linalg.power(10.0, self.system(dod[ok]))
        return out

    def compiled_form(self) -> tuple | None:
        """``(normalise_innovation, (bounds, sizes, consequents))``: this controller as a compiled whole run of its IMM
        computes it (:func:`mmlib.core.linalg.fuzzy_imm_run`), for a rule base whose sets are all trapezoids and
        whose rules a compiled call sums in numpy's order; None otherwise (the IMM then runs step by step)."""
        if type(self) is not FuzzyNoiseBounds:          # a subclass may compute its degrees or levels otherwise
            return None
        form = self.system.trapezoid_form()
        return None if form is None else (self.normalise == "innovation", form)


def fuzzy_imm(filter: MomentFilter, noise: Any, lower: float, upper: float, transition: np.ndarray, *,
              breakpoints: Sequence[float] | np.ndarray, normalise: str = "innovation", window: int = 1,
              names: Sequence[str] = SET_NAMES, frozen: bool = False, measurement: MeasurementModel | None = None,
              name: str = "FUZZY-IMM") -> NoiseAdaptiveIMM:
    """A two-mode IMM over ``filter`` whose modes' process-noise levels the FLAS sets every step (Tseng et al.
    2011, Sec. 3): ``noise`` a process-noise family (``level -> dynamics`` with ``Q(levels)``, e.g.
    :class:`mmlib.core.gnss.PVClockNoise`), the levels within ``lower`` < ``upper`` (:func:`fuzzy_system` with
    ``breakpoints`` and ``names``), ``transition`` (2, 2) the IMM's Markov chain, ``normalise`` the DOD's
    reference variance (:class:`FuzzyNoiseBounds`), ``window`` the epochs the DOD is averaged over (1: the
    present epoch, a :class:`NoiseAdaptiveIMM`; more: a :class:`WindowedNoiseAdaptiveIMM`).  The modes start at
    the first rule's levels; ``frozen=True`` keeps them there (the plain IMM, bit for bit).  ``measurement``
    None when every step supplies its own model."""
    check_has(noise, "noise", "a process-noise family (level -> dynamics, levels -> Q)", ("dynamics", "Q"))
    check_choice(normalise, "normalise", NORMALISE)
    window = check_positive_int(window, "window")
    system = fuzzy_system(breakpoints, lower, upper, names)
    normal = 10.0 ** system.consequents[0, 0]
    base = IMM(filter, [noise.dynamics(normal[0]), noise.dynamics(normal[1])], measurement, transition, name=name)
    flas = FuzzyNoiseBounds(system, normalise)
    if window == 1:
        return NoiseAdaptiveIMM(base, noise.Q, flas, tuple(normal), frozen=frozen, name=name)
    return WindowedNoiseAdaptiveIMM(base, noise.Q, flas, tuple(normal), frozen=frozen, name=name, window=window)
