r"""An IMM whose modes' process-noise levels are set online from the innovations, and the
fuzzy logic adaptive system (FLAS) of Tseng, Chang & Jwo 2011 (Sec. 3) that sets them.

:class:`NoiseAdaptiveIMM` is a thin layer over :class:`mmlib.core.estimation.IMM`: at step k it
builds the modes' process noise :math:`Q_j = Q(\ell_{k,j})` from per-run levels
:math:`\ell_k` (B, r), runs one ordinary IMM cycle with those dynamics, and asks a
``controller`` for the levels of step k+1 from the IMM's innovation at k (causal: the levels
used at k depend on measurements up to k-1).  With ``frozen=True`` the levels never change
and the layer *is* the IMM whose modes have the initial levels (tested bit for bit).

Degree of divergence (Tseng et al. 2011, Sec. 3.2), from the innovation
:math:`\upsilon_k` (m satellites) at the present epoch (window size one):

.. math:: \xi_k = \frac{\mathrm{tr}(\upsilon_k\upsilon_k^T)}{m} = \frac{\upsilon_k^T\upsilon_k}{m},
          \qquad \eta_k = \frac1m \sum_i |\upsilon_{k,i}|.

:func:`degree_of_divergence` divides them by a reference variance :math:`\bar s` and its square
root, so that the fuzzy sets are dimensionless.  The FLAS (:class:`mmlib.core.layers.fuzzy_noise.FuzzyNoiseBounds`) uses
by default the *predicted* innovation variance per measurement, :math:`\bar s = \mathrm{tr}(S_k)/m` (for an IMM,
of the mixture prior): for a consistent filter, :math:`\xi/\bar s` is then close to
:math:`\chi^2_m/m` (mean 1) and :math:`\eta/\sqrt{\bar s}` has mean :math:`\approx\sqrt{2/\pi} = 0.80`,
whatever the filter's own uncertainty.  ``normalise="measurement"`` uses the measurement-noise
variance instead (mean :math:`1 + \mathrm{tr}(HPH^T)/(m\sigma^2) > 1`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, NamedTuple, Sequence

import numpy as np

from mmlib.core._validate import as_float_array, check_bool, check_has, check_name, check_positive_int
from mmlib.core import linalg
from mmlib.core.estimation import IMM, IMMState, packed_imm_steps
from mmlib.core.filters import LOG_2PI
from mmlib.core.models import is_psd_by_construction
from mmlib.core.protocols import MeasurementModel

__all__ = ["NoiseAdaptiveIMM", "WindowedNoiseAdaptiveIMM", "NoiseAdaptiveState", "WindowedNoiseAdaptiveState",
           "degree_of_divergence"]


def degree_of_divergence(innovation: np.ndarray, noise_variance: np.ndarray | float) -> np.ndarray:
    r"""(B, 2): :math:`[\xi/\bar s, \eta/\sqrt{\bar s}]` for innovations (B, m) and a reference variance
    :math:`\bar s` (scalar or (B,)), in the innovation's units squared (m^2 for pseudoranges), so that
    both components are dimensionless (Tseng et al. 2011, Sec. 3.2).  ValueError naming ``innovation``
    for another shape, ``noise_variance`` for a value that is not > 0."""
    nu = as_float_array(innovation, "innovation")
    s2 = as_float_array(noise_variance, "noise_variance")
    if nu.ndim != 2:
        raise ValueError(f"innovation: expected shape (B, m), got {nu.shape}")
    if np.any(~(s2 > 0)):
        raise ValueError(f"noise_variance: must be > 0, got {noise_variance!r}")
    xi = (nu * nu).mean(axis=1) / s2
    eta = np.abs(nu).mean(axis=1) / np.sqrt(s2)
    return np.stack([xi, eta], axis=-1)


class NoiseAdaptiveState(NamedTuple):
    """State of :class:`NoiseAdaptiveIMM`: the IMM's state and the levels (B, r) of the next step."""

    imm: IMMState
    levels: np.ndarray          # (B, r) noise level of every mode for the next step


@dataclass(frozen=True, eq=False)
class NoiseAdaptiveIMM:
    """IMM with per-run, per-step process-noise levels (see the module docstring).

    ``noise(levels)`` maps levels (B, r) to Q (B, r, n, n) (e.g. :meth:`mmlib.core.gnss.PVClockNoise.Q`);
    ``controller(estimate, measurement)`` returns the next levels (B, r) from this step's
    :class:`~mmlib.core.estimation.Estimate` (innovation and its predicted covariance);
    ``initial_levels`` (r,) are the levels of the first step.  Each step's ``Estimate.diagnostics``
    holds the levels used in that step."""

    imm: IMM
    noise: Callable
    controller: Any
    initial_levels: tuple
    frozen: bool = False
    name: str = "adaptive IMM"

    def __post_init__(self):
        if not isinstance(self.imm, IMM):
            raise ValueError(f"imm: expected an mmlib.core.estimation.IMM, got {type(self.imm).__name__}")
        if not callable(self.noise):
            raise ValueError(f"noise: expected a callable levels (B, r) -> Q (B, r, n, n), "
                             f"got {type(self.noise).__name__}")
        check_bool(self.frozen, "frozen")
        check_name(self.name)
        lv = as_float_array(self.initial_levels, "initial_levels")
        if lv.shape != (self.imm.n_modes,) or np.any(~np.isfinite(lv)) or np.any(lv < 0):
            raise ValueError(f"initial_levels: expected {self.imm.n_modes} finite levels >= 0, "
                             f"got {self.initial_levels!r}")
        object.__setattr__(self, "initial_levels", lv)
        # a family marked psd_by_construction (e.g. PVClockNoise.Q) is not re-checked every step
        object.__setattr__(self, "_check_noise", not is_psd_by_construction(self.noise))
        if not self.frozen and not callable(self.controller):
            raise ValueError(f"controller: expected a callable (estimate, measurement) -> levels, "
                             f"got {type(self.controller).__name__}")

    @property
    def measurement(self) -> MeasurementModel | None:
        """The IMM's default measurement model (None when every step supplies its own)."""
        return self.imm.measurement

    def init(self, mean: np.ndarray, cov: np.ndarray, mode_probabilities: np.ndarray | None = None,
             **filter_init: Any) -> NoiseAdaptiveState:
        """The IMM's state at step 0 (:meth:`mmlib.core.estimation.IMM.init`: ``mean`` (B, n), ``cov`` (B, n, n)
        or (n, n), ``mode_probabilities`` (r,) or (B, r)) and ``initial_levels`` repeated for every run,
        (B, r)."""
        s = self.imm.init(mean, cov, mode_probabilities, **filter_init)
        B = s.mode_probabilities.shape[0]
        return NoiseAdaptiveState(s, np.tile(self.initial_levels, (B, 1)))

    def whole_run(self, state: NoiseAdaptiveState, steps: Sequence[tuple], *, with_cov: bool, keep_cov: bool, nis: bool,
                  truth: np.ndarray | None = None) -> tuple | None:
        """Every step of a run (:func:`mmlib.core.estimation.run` calls this with its checked ``steps``, (z_k (B, m_k),
        model_k or None) pairs) in one compiled call (:func:`mmlib.core.linalg.fuzzy_imm_run`), where the layer is this
        class itself (a subclass may override a step), its IMM's cycles are fused steps
        (:func:`mmlib.core.estimation.packed_imm_steps`), its noise family is affine in the level (``affine()``,
        e.g. :meth:`mmlib.core.gnss.PVClockNoise.affine`) and its controller has a compiled form (``compiled_form()``,
        e.g. :meth:`mmlib.core.layers.fuzzy_noise.FuzzyNoiseBounds.compiled_form`) or the layer is frozen.  Returns
        ``(means, covs, mode probabilities, failed, underflow, levels (B, K, r), nis, nees)`` per step, the bits of the
        run step by step (``tests/test_gnss_fuzzy.py``), or None where it does not apply or the controller would refuse
        an input (then the steps run, and raise)."""
        if type(self) is not NoiseAdaptiveIMM or type(state) is not NoiseAdaptiveState or not linalg.fused():
            return None
        B = state.levels.shape[0]
        return _whole_run(self, state, steps, np.zeros((B, 1, 2)), np.zeros(B, dtype=np.int64), with_cov=with_cov,
                          keep_cov=keep_cov, nis=nis, truth=truth)

    def step(self, state: NoiseAdaptiveState, z: np.ndarray, *, with_cov: bool = True,
             measurement: MeasurementModel | None = None) -> tuple:
        r"""One IMM cycle with the modes' noise :math:`Q_j = Q(\ell_{k,j})` from this step's levels (B, r) (a
        non-finite level, from a diverged run, replaced by the initial one), then the levels of step k+1
        from ``controller(estimate, measurement)`` (unless ``frozen``).  ``z`` (B, m).  Returns
        ``(NoiseAdaptiveState, Estimate)``, ``Estimate.diagnostics`` (B, r) the levels of this step as
        stored in the state; a controller returning another shape than (B, r) is a ValueError naming
        ``controller``."""
        if not isinstance(state, NoiseAdaptiveState):
            raise ValueError(f"state: expected the NoiseAdaptiveState returned by init(), got {type(state).__name__}")
        measurement = self.imm.measurement if measurement is None else measurement
        # a diverged run has NaN levels (kept, and recorded in the diagnostics); its state is NaN already, so
        # any finite placeholder lets the other runs of the batch go on while run() reports this one
        levels_now = np.where(np.isfinite(state.levels), state.levels, self.initial_levels)
        dynamics = self.imm.stacked.with_noise(self.noise(levels_now), check=self._check_noise)
        imm_state, est = self.imm.step(state.imm, z, with_cov=with_cov, measurement=measurement, dynamics=dynamics)
        if self.frozen:
            levels = state.levels
        else:
            levels = np.asarray(self.controller(est, measurement), dtype=float)
            if levels.shape != state.levels.shape:
                raise ValueError(f"controller: expected levels of shape {state.levels.shape}, got {levels.shape}")
        return NoiseAdaptiveState(imm_state, levels), est._replace(diagnostics=state.levels)


def _whole_run(layer, state, steps, history, filled, *, with_cov: bool, keep_cov: bool, nis: bool,
               truth) -> tuple | None:
    """:meth:`NoiseAdaptiveIMM.whole_run` for a layer (exactly :class:`NoiseAdaptiveIMM` or
    :class:`WindowedNoiseAdaptiveIMM`) from its ``state`` with the DOD ``history`` (B, W, 2) and ``filled`` (B,)."""
    owner = getattr(layer.noise, "__self__", None)
    own = vars(type(owner)) if owner is not None else {}
    # the class that defines Q defines affine() too (a subclass overriding Q alone computes another Q)
    if "affine" not in own or "Q" not in own or layer.noise != getattr(owner, "Q", None):
        return None                                     # a noise family the kernel does not compute
    form = None if layer.frozen else getattr(layer.controller, "compiled_form", lambda: None)()
    if not layer.frozen and form is None:
        return None
    B, r, n = state.imm.modes.mean.shape
    normalise, rule_base = form if form is not None else (True, _no_rules(r))
    unit, base = owner.affine()
    levels = np.asarray(state.levels)
    if levels.shape != (B, r) or levels.dtype != np.float64 or history.shape[1:] != (getattr(layer, "window", 1), 2) \
            or np.shape(filled) != (B,) or (truth is not None and truth.shape[-1] != n):
        return None                                     # a state the steps would refuse or read otherwise
    now = np.where(np.isfinite(levels), levels, layer.initial_levels)
    if (now < 0).any() or (np.asarray(filled) < 0).any() or (np.asarray(filled) > history.shape[1]).any():
        return None                                     # the steps name it
    top = max(float(np.max(layer.initial_levels)), float(np.max(now)),
              float(10.0 ** np.max(rule_base[2])) if form is not None else 0.0)
    with np.errstate(over="ignore", invalid="ignore"):
        if not np.isfinite(2.0 * top * np.asarray(unit) + base).all():
            return None                                 # a level whose Q overflows: the step names it
    packed = packed_imm_steps(layer.imm, state.imm, [(z, layer.imm.measurement if m is None else m) for z, m in steps],
                              with_cov)
    if packed is None:
        return None
    refs = np.zeros(len(steps)) if normalise else np.array(
        [float(np.mean(np.diag((layer.imm.measurement if m is None else m).R))) for _, m in steps])
    imm = layer.imm
    up = imm.filter.rule.unit_points(n)
    out = linalg.fuzzy_imm_run(
        state.imm.mode_probabilities, imm.transition, state.imm.modes.mean, state.imm.modes.cov, up.xi, up.wm, up.wc,
        imm.stacked.F, (unit, base), state.levels, layer.initial_levels, packed, with_cov, LOG_2PI, frozen=layer.frozen,
        normalise_innovation=normalise, refs=refs, history=history, filled=filled, rule_base=rule_base,
        keep_cov=keep_cov, nis=nis, truth=truth)
    if out is None:
        return None
    means, covs, mus, failed, underflow, nis_k, nees_k, levels = out
    return means, covs, mus, failed, underflow, levels, nis_k, nees_k


def _no_rules(r: int) -> tuple:
    """A rule base of the right shape for a frozen layer's whole run, of r modes (never evaluated)."""
    return np.zeros((2, 4, 1)), np.ones(2, dtype=np.int64), np.zeros((1, r))


def _array_of(value, method: str, shape: tuple, what: str) -> np.ndarray:
    """What ``controller.<method>()`` returned, as a float array of ``shape`` (the array itself when it is one),
    else a ValueError naming ``controller`` (not a broadcasting error one step later)."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.shape != shape:
        got = type(value).__name__ if arr is None else f"shape {arr.shape}"
        raise ValueError(f"controller: {method}() returned {got}, expected shape {shape} {what}")
    return arr


class WindowedNoiseAdaptiveState(NamedTuple):
    """State of :class:`WindowedNoiseAdaptiveIMM`: the IMM's state, the next levels (B, r), the last W
    normalised degrees of divergence (B, W, 2) and how many of them are real epochs (B,)."""

    imm: IMMState
    levels: np.ndarray          # (B, r) noise level of every mode for the next step
    dod: np.ndarray             # (B, W, 2) the last W degrees of divergence, newest last
    filled: np.ndarray          # (B,) how many of them are real epochs (min(k, W))


@dataclass(frozen=True, eq=False)
class WindowedNoiseAdaptiveIMM(NoiseAdaptiveIMM):
    r"""The FLAS with the degree of divergence averaged over a moving window of ``window`` epochs.

    Tseng et al. 2011 (Sec. 3.2) define :math:`\xi` as the trace of the innovation covariance
    "at present epoch (i.e., the window size is one)": the innovation covariance estimated over
    a moving window, :math:`\hat C_k = \frac1W\sum_{j=k-W+1}^{k}\upsilon_j\upsilon_j^T` (Mohamed &
    Schwarz 1999, J. Geodesy 73:193), of which one epoch is the case the paper names.  Here each
    epoch's normalised DOD :math:`[\xi_j/\bar s_j, \eta_j/\sqrt{\bar s_j}]` (see
    :func:`degree_of_divergence`; the number of satellites may change between epochs) is averaged
    over the last ``min(k, W)`` epochs before the inference.  ``controller`` must split its work in two:
    ``dod(estimate, measurement) -> (B, 2)`` and ``levels(dod) -> (B, r)`` (as the FLAS,
    :class:`mmlib.core.layers.fuzzy_noise.FuzzyNoiseBounds`, does).  With ``window=1`` this is
    :class:`NoiseAdaptiveIMM` bit for bit."""

    window: int = 1

    def __post_init__(self):
        super().__post_init__()
        check_positive_int(self.window, "window")
        check_has(self.controller, "controller", "a controller with dod(estimate, measurement) and levels(dod) "
                  "(a windowed DOD averages between the two)", ("dod", "levels"))

    def init(self, mean: np.ndarray, cov: np.ndarray, mode_probabilities: np.ndarray | None = None,
             **filter_init: Any) -> WindowedNoiseAdaptiveState:
        """As :meth:`NoiseAdaptiveIMM.init`, plus an empty DOD history (B, ``window``, 2) (zeros, none filled)."""
        s = NoiseAdaptiveIMM.init(self, mean, cov, mode_probabilities, **filter_init)
        B = s.levels.shape[0]
        return WindowedNoiseAdaptiveState(s.imm, s.levels, np.zeros((B, int(self.window), 2)), np.zeros(B, dtype=int))

    def whole_run(self, state: WindowedNoiseAdaptiveState, steps: Sequence[tuple], *, with_cov: bool, keep_cov: bool,
                  nis: bool,
                  truth: np.ndarray | None = None) -> tuple | None:
        """:meth:`NoiseAdaptiveIMM.whole_run` with the DOD averaged over the window (its history and count in
        ``state``), for this class itself."""
        if type(self) is not WindowedNoiseAdaptiveIMM or type(state) is not WindowedNoiseAdaptiveState \
                or not linalg.fused():
            return None
        return _whole_run(self, state, steps, state.dod, state.filled, with_cov=with_cov, keep_cov=keep_cov, nis=nis,
                          truth=truth)

    def step(self, state: WindowedNoiseAdaptiveState, z: np.ndarray, *, with_cov: bool = True,
             measurement: MeasurementModel | None = None) -> tuple:
        """One IMM cycle as :meth:`NoiseAdaptiveIMM.step`; the next levels are ``controller.levels`` of the mean
        of ``controller.dod(estimate, measurement)`` (B, 2) over the last ``min(k, window)`` epochs.  Returns
        ``(WindowedNoiseAdaptiveState, Estimate)``, ``Estimate.diagnostics`` (B, r) this step's levels."""
        if not isinstance(state, WindowedNoiseAdaptiveState):
            raise ValueError(f"state: expected the WindowedNoiseAdaptiveState returned by init(), "
                             f"got {type(state).__name__}")
        measurement = self.imm.measurement if measurement is None else measurement
        levels_now = np.where(np.isfinite(state.levels), state.levels, self.initial_levels)
        dynamics = self.imm.stacked.with_noise(self.noise(levels_now), check=self._check_noise)
        imm_state, est = self.imm.step(state.imm, z, with_cov=with_cov, measurement=measurement, dynamics=dynamics)
        if self.frozen:
            return (WindowedNoiseAdaptiveState(imm_state, state.levels, state.dod, state.filled),
                    est._replace(diagnostics=state.levels))
        dod_now = _array_of(self.controller.dod(est, measurement), "dod", state.dod.shape[::2],
                            "(runs, [xi, eta])")                                            # (B, 2)
        history = np.concatenate([state.dod[:, 1:], dod_now[:, None]], axis=1)            # (B, W, 2)
        filled = np.minimum(state.filled + 1, int(self.window))
        W = int(self.window)
        if W == 1:
            dod = history[:, 0]
        else:
            recent = np.arange(W)[None, :] >= (W - filled)[:, None]                      # (B, W) real epochs
            dod = np.where(recent[..., None], history, 0.0).sum(axis=1) / filled[:, None]
        levels = _array_of(self.controller.levels(dod), "levels", state.levels.shape, "(runs, modes)")
        return (WindowedNoiseAdaptiveState(imm_state, levels, history, filled),
                est._replace(diagnostics=state.levels))
