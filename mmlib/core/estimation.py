r"""Estimators that run over a measurement sequence: a single mode-matched
filter (:class:`SingleModel`) and the interacting multiple model combinator
(:class:`IMM`), plus the batched driver :func:`run`.

IMM (Blom & Bar-Shalom 1988; Bar-Shalom et al. 2001, Sec. 11.6.6; Zhu et al.
2016, Eqs. 54-60).  **Convention, stated once:** ``transition[i, j]`` is the
probability of switching *from* mode ``i`` *to* mode ``j``; rows sum to 1.
With :math:`\mu_i` the mode probabilities at k-1:

1. predicted mode probabilities :math:`c_j = \sum_i p_{ij}\mu_i`, mixing weights
   :math:`\mu_{i|j} = p_{ij}\mu_i / c_j`;
2. mixing (Eqs. 55-56) by a pluggable :class:`MomentMixing` strategy;
3. mode-matched predict + update with each mode's filter and dynamics, giving
   log-likelihoods :math:`\log L_j`;
4. :math:`\mu_j \propto L_j c_j` (Eq. 58), computed in log space;
5. fused output (Eqs. 59-60) -- an output only, never fed back.
"""
from __future__ import annotations

import weakref
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any, Callable, NamedTuple, Sequence

import numpy as np
from numpy.typing import ArrayLike

from mmlib.core import linalg, protocols
from mmlib.core.linalg import (combine_covariances, imm_output, mixing_weights,  # noqa: F401  (public here too)
                               normalised_square)
from mmlib.core.filters import LOG_2PI, ExtendedKalmanFilter, GaussianState, SigmaPointFilter
from mmlib.core.gnss import CLOCK_INDEX, POSITION_INDEX, Pseudoranges
from mmlib.core.models import LinearMeasurement, RangeBearing, StackedDynamics
from mmlib.core._validate import (check_finite, as_float_array, check_applies, check_batch_vector, check_bool,
                                  check_has, check_index, check_mask, check_name, check_probabilities,
                                  check_transition_matrix)

__all__ = ["IMM", "SingleModel", "run", "Track", "Estimate", "IMMState", "MomentMixing", "KnownModeSequence",
           "SwitchingState", "FilterDivergence", "summarise_divergence", "select_runs",
           "batch_size", "Failure", "FAILURE_CAUSES", "FILTER_METHODS", "DYNAMICS_METHODS", "MEASUREMENT_METHODS",
           "ESTIMATOR_METHODS", "packed_imm_steps"]


class Failure(IntEnum):
    """Why a run diverged (``Estimate.failure``, ``Track.divergence_cause``); 0 = it did not."""

    NONE = 0
    COVARIANCE = 1      # an innovation or posterior covariance stopped being positive definite
    LIKELIHOOD = 2      # every mode's likelihood underflowed to zero: the mode probabilities are undefined
    NONFINITE = 3       # the estimate became non-finite otherwise (overflow)


# the codes as numpy scalars: an IntEnum member as a numpy operand is slow (numpy probes it for array
# interfaces through Enum.__getattr__), and they are used once per step in the hot loop
_NONE, _COVARIANCE, _LIKELIHOOD, _NONFINITE = (np.int8(f) for f in Failure)

#: Human-readable cause of each :class:`Failure`.
FAILURE_CAUSES = {
    Failure.COVARIANCE: "covariance no longer positive definite",
    Failure.LIKELIHOOD: "every mode's likelihood underflowed to zero (measurement incompatible with every mode); "
                        "mode probabilities undefined",
    Failure.NONFINITE: "estimate no longer finite (overflow)",
}

#: What the library expects of each kind of object (the members of its protocol, checked at construction).
FILTER_METHODS = protocols.members(protocols.Filter)
DYNAMICS_METHODS = protocols.members(protocols.Dynamics)
MEASUREMENT_METHODS = protocols.members(protocols.MeasurementModel)
ESTIMATOR_METHODS = protocols.members(protocols.Estimator)


def _check_filter(f, name: str = "filter"):
    return check_has(f, name, "a mode-matched filter (protocols.Filter)", FILTER_METHODS)


def _check_dynamics(d, name: str = "dynamics"):
    return check_has(d, name, "a dynamics model (protocols.Dynamics)", DYNAMICS_METHODS)


#: the measurement models of this library, frozen dataclasses with read-only arrays compared by identity: what a check
#: of one finds cannot change, so it is checked once per process (:data:`_FITTING`), not at every step that uses it
_IMMUTABLE_MODELS = (LinearMeasurement, RangeBearing, Pseudoranges)
#: such a model -> the state dimensions it was found to measure (None: found to be a measurement model); a per-step
#: model (Tseng et al. 2011: 1800 of them) is checked by every run() and, inside a layer, by the IMM at every step
_FITTING: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _check_measurement_model(m, name: str = "measurement", n: int | None = None):
    """A measurement model (or None); with ``n``, one that measures states of dimension ``n``."""
    if m is None:
        return None
    immutable = type(m) in _IMMUTABLE_MODELS
    if immutable and n in _FITTING.get(m, ()):
        return m
    check_has(m, name, "a measurement model (protocols.MeasurementModel)", MEASUREMENT_METHODS)
    if n is not None:
        check_applies(m, name, n)
    if immutable:
        _FITTING.setdefault(m, set()).update((None, n))
    return m


def batch_size(state: tuple | np.ndarray) -> int:
    """Number of runs B of any (nested NamedTuple) estimator state: the leading axis of its first array."""
    if isinstance(state, np.ndarray):
        return state.shape[0]
    for part in state:
        if isinstance(part, np.ndarray) and part.ndim:
            return part.shape[0]
        if isinstance(part, tuple):
            try:
                return batch_size(part)
            except ValueError:
                continue
    raise ValueError("state: holds no per-run array")


def _check_state(state, name: str, fields, dim: int | None = None, kind: str = "filter state"):
    """``state`` is a NamedTuple with ``fields`` (as returned by ``init``); its mean has dimension ``dim``."""
    if not (isinstance(state, tuple) and hasattr(state, "_fields")) or any(f not in state._fields for f in fields):
        raise ValueError(f"{name}: expected a {kind} as returned by init() (fields {', '.join(fields)}), "
                         f"got {type(state).__name__}")
    if dim is not None:
        mean = state.mean if "mean" in state._fields else state.modes.mean
        if np.shape(mean)[-1] != dim:
            raise ValueError(f"{name}: state dimension {np.shape(mean)[-1]} does not match the dynamics' {dim}")
    return state


def _filter_init(filt, mean, cov, filter_init: dict, measurement=None):
    """``filt.init(mean, cov, **filter_init)``, a keyword the filter's ``init`` does not take being a ValueError
    naming it (not Python's TypeError); then, when the estimator has a fixed ``measurement`` model and the filter
    can check its state against one (``check_state_for``, e.g. pre-drawn bootstrap noise of another measurement
    dimension), that check."""
    import inspect
    if filter_init:
        try:
            params = inspect.signature(filt.init).parameters
        except (TypeError, ValueError):
            params = None
        if params is not None and not any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
            takes = [n for n, p in params.items() if p.kind in (inspect.Parameter.POSITIONAL_OR_KEYWORD,
                                                                 inspect.Parameter.KEYWORD_ONLY)][2:]
            for key in filter_init:
                if key not in takes:
                    raise ValueError(f"{key}: {type(filt).__name__}.init takes no argument {key!r} (its own: "
                                     f"{', '.join(takes) if takes else 'none beyond mean and cov'})")
    state = filt.init(mean, cov, **filter_init)
    check = getattr(filt, "check_state_for", None)
    if measurement is not None and callable(check):
        check(state, measurement)
    return state


def _check_mean_dim(mean, dim: int):
    shape = np.shape(as_float_array(mean, "mean"))
    if len(shape) != 2 or shape[1] != dim:
        raise ValueError(f"mean: expected shape (B, {dim}) for the dynamics' state dimension {dim}, got {shape}")


class Estimate(NamedTuple):
    r"""Per-step output: fused ``mean`` (B, n), ``cov`` (B, n, n), ``mode_probabilities`` (B, r) or None,
    ``loglik`` (B,), ``innovation`` (B, m) and its predicted covariance ``innovation_cov`` (B, m, m):
    the residual of the measurement against the predicted measurement (for an IMM, that of the
    mixture prior: mean :math:`\sum_j c_j \hat z_j`, covariance
    :math:`\sum_j c_j [S_j + (\hat z_j - \hat z)(\hat z_j - \hat z)^T]`); ``diagnostics`` (B, d): anything
    an adaptive estimator wants recorded per step (collected by :func:`run`)."""

    mean: np.ndarray
    cov: np.ndarray
    mode_probabilities: Any = None
    loglik: Any = None
    innovation: Any = None
    diagnostics: Any = None
    innovation_cov: Any = None
    failure: Any = None           # (B,) Failure codes of the runs that failed at this step (0: none), or None


def _failure_codes(failed):
    """Failure codes (B,) from a ``failed`` mask (B,) or (B, r) of the mode filters, or None."""
    if failed is None:
        return None
    failed = np.asarray(failed)
    if failed.ndim > 1:
        failed = failed.any(axis=tuple(range(1, failed.ndim)))
    return np.where(failed, _COVARIANCE, _NONE)


def _step_measurement(default, override, n: int):
    """The measurement model of this step: the estimator's own (checked at construction) or a per-step override,
    checked here to be a measurement model of states of dimension ``n``."""
    if override is not None and override is not default:
        return _check_measurement_model(override, n=n)
    return _measurement_model(default, override)


def _measurement_model(default, override):
    model = default if override is None else override
    if model is None:
        raise ValueError("measurement: no measurement model for this step (construct the estimator with one, or "
                         "pass measurement= / run(..., measurement_models=...))")
    return model


def _check_measurement(z, dim: int, name: str = "z", batch: int | None = None) -> np.ndarray:
    z = check_batch_vector(z, name, dim)
    if batch is not None and z.shape[0] != batch:
        raise ValueError(f"{name}: {z.shape[0]} runs of measurements for a state of {batch} runs")
    return z


# --------------------------------------------------------------------------- single model
@dataclass(frozen=True, eq=False)
class SingleModel:
    """One filter, one dynamics model, one measurement model.  ``step`` accepts a per-step
    ``measurement`` model overriding the default one (e.g. the satellites visible at that step).

    ``filter``: a :class:`mmlib.core.protocols.Filter`; ``dynamics``: a
    :class:`mmlib.core.protocols.Dynamics` of state dimension n; ``measurement``: a
    :class:`mmlib.core.protocols.MeasurementModel` of states of dimension n, or None when every step
    supplies its own; ``name`` a string (default: the filter's name).  Each is checked on construction
    (ValueError naming it)."""

    filter: Any
    dynamics: Any
    measurement: Any
    name: str = ""

    def __post_init__(self):
        _check_filter(self.filter)
        _check_dynamics(self.dynamics)
        _check_measurement_model(self.measurement, n=self.dynamics.dim)
        check_name(self.name)
        if not self.name:
            object.__setattr__(self, "name", str(getattr(self.filter, "name", "") or type(self.filter).__name__))

    def init(self, mean: np.ndarray, cov: np.ndarray, **filter_init: Any) -> Any:
        """The filter's state at step 0 from ``mean`` (B, n) and ``cov`` (B, n, n) or (n, n), in the state's
        units; ``filter_init`` goes to the filter's ``init`` (e.g. pre-drawn bootstrap noise; a keyword it does not
        take is a ValueError naming it)."""
        _check_mean_dim(mean, self.dynamics.dim)
        return _filter_init(self.filter, mean, cov, filter_init, self.measurement)

    def step(self, state: Any, z: np.ndarray, *, with_cov: bool = True,
             measurement: protocols.MeasurementModel | None = None) -> tuple:
        """One predict + update with the measurements ``z`` (B, m): returns ``(state, Estimate)``, the
        estimate holding the posterior mean (B, n), cov (B, n, n), log-likelihood (B,), innovation (B, m) and
        its covariance (B, m, m) and the failure codes (B,) (mode probabilities None).  ``measurement``
        overrides the measurement model for this step; ``with_cov`` is accepted for the
        :class:`mmlib.core.protocols.Estimator` interface (the covariance is always computed).  A state,
        ``z`` or model that does not fit is a ValueError naming it."""
        z, measurement = self._check_step(state, z, with_cov, measurement)
        return self._step(state, z, with_cov, measurement)

    def _check_step(self, state, z, with_cov, measurement) -> tuple:
        """The inputs of :meth:`step` checked (ValueError naming the one that does not fit): ``(z, the measurement
        model of the step)``.  :func:`run` calls it once per measurement model, then :meth:`_step`."""
        _check_state(state, "state", ("mean", "cov"), self.dynamics.dim)
        check_bool(with_cov, "with_cov")
        measurement = _step_measurement(self.measurement, measurement, self.dynamics.dim)
        return _check_measurement(z, measurement.dim, batch=batch_size(state)), measurement

    def _step(self, state, z, with_cov, measurement) -> tuple:
        """:meth:`step` on inputs :meth:`_check_step` has checked (``measurement`` the step's model, not None)."""
        measure = _fused_measure(measurement) if _fusable(self.filter, state, self.dynamics) \
            and np.ndim(self.dynamics.F) == 2 else None
        if measure is not None:
            up = self.filter.rule.unit_points(self.dynamics.dim)
            mean, cov, loglik, innovation, S, failed = linalg.sigma_step(
                state.mean, state.cov, up.xi, up.wm, up.wc, self.dynamics.F, self.dynamics.Q, z, measure,
                measurement.angular, measurement.R, LOG_2PI)
            fused = GaussianState(mean, cov), loglik, innovation, S, failed
        else:
            fused = _fused_layer_step(self.filter, state, self.dynamics, z, measurement)
        if fused is not None:
            state, loglik, innovation, S, failed = fused
            return state, Estimate(state.mean, state.cov, None, loglik, innovation, innovation_cov=S,
                                   failure=_failure_codes(failed))
        state = self.filter.predict(state, self.dynamics)
        state, info = self.filter.update(state, z, measurement)
        return state, Estimate(state.mean, state.cov, None, info.loglik, info.innovation, innovation_cov=info.S,
                               failure=_failure_codes(getattr(info, "failed", None)))


class SwitchingState(NamedTuple):
    """State of :class:`KnownModeSequence`: the filter's own state (mean (B, n), cov (B, n, n), ...) and the
    index ``step`` of the next step (0 at init)."""

    filter_state: Any
    step: int


@dataclass(frozen=True, eq=False)
class KnownModeSequence:
    """A filter told the true mode of every step ("clairvoyant" benchmark): step k uses
    ``dynamics[modes[k]]``.  With linear models and the Kalman filter it is the MMSE
    estimator, hence a lower bound on the error of any filter, IMM included.

    ``dynamics``: one or more models of one state dimension n; ``modes`` (K,) integer indices into
    ``dynamics``, one per step (K steps at most); ``filter``, ``measurement``, ``name`` as in
    :class:`SingleModel`."""

    filter: Any
    dynamics: Sequence[Any]
    modes: np.ndarray
    measurement: Any
    name: str = "clairvoyant"

    def __post_init__(self):
        _check_filter(self.filter)
        dyn = tuple(_check_dynamics(d, f"dynamics[{i}]") for i, d in enumerate(self.dynamics))
        if not dyn or len({d.dim for d in dyn}) != 1:
            raise ValueError(f"dynamics: expected one or more models of one state dimension, got {len(dyn)} models")
        modes = np.asarray(self.modes)
        if modes.ndim != 1 or modes.dtype.kind not in "iu" or np.any(modes < 0) or np.any(modes >= len(dyn)):
            raise ValueError(f"modes: expected a 1-D integer array of model indices in 0..{len(dyn) - 1}, "
                             f"got {self.modes!r}")
        _check_measurement_model(self.measurement, n=dyn[0].dim)
        check_name(self.name)
        object.__setattr__(self, "dynamics", dyn)

    def init(self, mean: np.ndarray, cov: np.ndarray, **filter_init: Any) -> SwitchingState:
        """:class:`SwitchingState` at step 0 from ``mean`` (B, n) and ``cov`` (B, n, n) or (n, n); ``filter_init``
        goes to the filter's ``init`` (e.g. pre-drawn bootstrap noise), as in :meth:`SingleModel.init`."""
        _check_mean_dim(mean, self.dynamics[0].dim)
        return SwitchingState(_filter_init(self.filter, mean, cov, filter_init, self.measurement), 0)

    def step(self, state: SwitchingState, z: np.ndarray, *, with_cov: bool = True,
             measurement: protocols.MeasurementModel | None = None) -> tuple:
        """Step k: predict with ``dynamics[modes[k]]``, update with ``z`` (B, m); returns
        ``(SwitchingState, Estimate)`` as :meth:`SingleModel.step` does.  A step beyond ``len(modes)`` is a
        ValueError naming ``z``."""
        z, measurement = self._check_step(state, z, with_cov, measurement)
        return self._step(state, z, with_cov, measurement)

    def _check_step(self, state, z, with_cov, measurement) -> tuple:
        """The inputs of :meth:`step` checked: ``(z, the measurement model of the step)`` (as
        :meth:`SingleModel._check_step`)."""
        if not isinstance(state, SwitchingState):
            raise ValueError(f"state: expected the SwitchingState returned by init(), got {type(state).__name__}")
        _check_state(state.filter_state, "state", ("mean", "cov"), self.dynamics[0].dim)
        check_bool(with_cov, "with_cov")
        measurement = _step_measurement(self.measurement, measurement, self.dynamics[0].dim)
        return _check_measurement(z, measurement.dim, batch=batch_size(state.filter_state)), measurement

    def _step(self, state, z, with_cov, measurement) -> tuple:
        """:meth:`step` on inputs :meth:`_check_step` has checked (the step count is checked here, every step)."""
        if state.step >= len(self.modes):
            raise ValueError(f"z: step {state.step} beyond the {len(self.modes)} known modes")
        s = self.filter.predict(state.filter_state, self.dynamics[int(self.modes[state.step])])
        s, info = self.filter.update(s, z, measurement)
        return SwitchingState(s, state.step + 1), Estimate(s.mean, s.cov, None, info.loglik, info.innovation,
                                                           innovation_cov=info.S,
                                                           failure=_failure_codes(getattr(info, "failed", None)))


# --------------------------------------------------------------------------- IMM
@dataclass(frozen=True)
class MomentMixing:
    r"""Standard IMM interaction (Eqs. 55-56): for each target mode j,

    :math:`x^{0j} = \sum_i \mu_{i|j} x^i`,
    :math:`P^{0j} = \sum_i \mu_{i|j}[P^i + (x^i - x^{0j})(x^i - x^{0j})^T]`.

    ``means`` (B, r, n), ``covs`` (B, r, n, n), ``w`` (B, r_from, r_to) (:func:`mmlib.core.linalg.mixing_weights`)
    -> ``(mixed means (B, r, n), mixed covs (B, r, n, n))``, in the state's units
    (:func:`mmlib.core.linalg.mix_moments`; an IMM with this mixing takes the fused
    :func:`mmlib.core.linalg.imm_mix`, or the whole fused step :func:`mmlib.core.linalg.imm_sigma_step` where it
    applies).
    Alternative strategies (e.g. cubature-principle mixing, Zhou et al. 2017)
    implement the same call."""

    name: str = "moment"

    def __post_init__(self):
        check_name(self.name)

    def __call__(self, means: np.ndarray, covs: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return linalg.mix_moments(means, covs, w)


class IMMState(NamedTuple):
    """State of :class:`IMM`: the mode filters' states stacked on a mode axis (``modes.mean`` (B, r, n),
    ``modes.cov`` (B, r, n, n), a layer's extra per-run fields likewise) and the mode probabilities
    ``mode_probabilities`` (B, r), rows summing to 1."""

    modes: Any                       # the mode filters' state, stacked: mean (B, r, n), cov (B, r, n, n)
    mode_probabilities: np.ndarray   # (B, r)


@dataclass(frozen=True, eq=False)
class IMM:
    """Interacting multiple model combinator over any mode-matched filter.

    One ``filter`` serves every mode; the modes differ by their ``dynamics``
    (sequence of r models).  The mode filters' states are stacked on a mode
    axis, (B, r, ...), so all modes are predicted and updated in one batched
    call.  ``transition`` is (r, r) with rows = "from", columns = "to".
    ``mixing`` is a strategy with the signature of :class:`MomentMixing`.
    ``measurement`` may be None when every step supplies its own model
    (``run(..., measurement_models=...)``).

    ``dynamics``: r >= 1 models of one state dimension n (e.g. :func:`mmlib.core.models.constant_velocity`
    and :func:`mmlib.core.models.coordinated_turn` with rates in rad/s), stacked once into a
    :class:`~mmlib.core.models.StackedDynamics` (attribute ``stacked``); ``transition`` (r, r) a
    row-stochastic matrix of per-step switching probabilities (dimensionless, entries in [0, 1], rows
    summing to 1 within 1e-9 r), stored read-only; ``name`` a string.  Each argument is checked on
    construction (ValueError naming it).
    """

    filter: Any
    dynamics: Sequence[Any]
    measurement: Any
    transition: np.ndarray
    mixing: Any = field(default_factory=MomentMixing)
    name: str = "IMM"

    def __post_init__(self):
        if isinstance(self.dynamics, (str, bytes, np.ndarray)) or not hasattr(self.dynamics, "__iter__"):
            raise ValueError(f"dynamics: expected a sequence of dynamics models, got {type(self.dynamics).__name__}")
        dyn = tuple(_check_dynamics(d, f"dynamics[{i}]") for i, d in enumerate(self.dynamics))
        if not dyn:
            raise ValueError("dynamics: an IMM needs at least one mode")
        if len({d.dim for d in dyn}) != 1:
            raise ValueError(f"dynamics: every mode must have one state dimension, got {[d.dim for d in dyn]}")
        T = check_transition_matrix(self.transition, "transition")
        if T.shape[0] != len(dyn):
            raise ValueError(f"transition: expected {len(dyn)}x{len(dyn)} for {len(dyn)} modes, got {T.shape}")
        _check_filter(self.filter)
        _check_measurement_model(self.measurement, n=dyn[0].dim)
        check_name(self.name)
        if not callable(self.mixing):
            raise ValueError(f"mixing: expected a mixing strategy (callable), got {type(self.mixing).__name__}")
        object.__setattr__(self, "dynamics", dyn)
        object.__setattr__(self, "stacked", StackedDynamics.of(dyn))
        T = T.copy()                   # frozen below: the caller's matrix must stay theirs (and writable)
        object.__setattr__(self, "transition", T)
        T.setflags(write=False)

    @property
    def n_modes(self) -> int:
        """Number of modes r."""
        return len(self.dynamics)

    def init(self, mean: np.ndarray, cov: np.ndarray, mode_probabilities: np.ndarray | None = None,
             **filter_init: Any) -> IMMState:
        """:class:`IMMState` at step 0 from ``mean`` (B, n) and ``cov`` (B, n, n) or (n, n): every mode starts
        from the same state (every per-run field repeated on a mode axis, (B, r, ...)).
        ``filter_init`` goes to the mode filter's ``init``.  ``mode_probabilities`` (r,) or (B, r), each
        row a probability vector, default uniform ``1/r``; a wrong shape or a row not summing to 1 is a
        ValueError naming ``mode_probabilities``."""
        _check_mean_dim(mean, self.stacked.dim)
        base = _filter_init(self.filter, mean, cov, filter_init, self.measurement)
        B = base.mean.shape[0]
        r = self.n_modes
        if mode_probabilities is None:
            mu = np.full((B, r), 1.0 / r)
        else:
            mu = as_float_array(mode_probabilities, "mode_probabilities")
            if mu.shape not in ((r,), (B, r)):
                raise ValueError(f"mode_probabilities: expected shape ({r},) or ({B}, {r}) for {r} modes and "
                                 f"{B} runs, got {mu.shape}")
            mu = check_probabilities(np.broadcast_to(mu, (B, r)), "mode_probabilities")
        # every per-run field of the mode filter's state gets a mode axis; other fields pass through
        stacked = tuple(np.repeat(f[:, None], r, axis=1) if isinstance(f, np.ndarray) and f.ndim and f.shape[0] == B
                        else f for f in base)
        return IMMState(type(base)(*stacked), np.array(mu, dtype=float))

    def step(self, state: IMMState, z: np.ndarray, *, with_cov: bool = True,
             measurement: protocols.MeasurementModel | None = None,
             dynamics: StackedDynamics | None = None) -> tuple:
        """One IMM cycle (steps 1-5 of the module docstring) with the measurements ``z`` (B, m), the same for
        every mode.  Returns ``(IMMState, Estimate)``: fused mean (B, n) and cov (B, n, n), posterior mode
        probabilities (B, r), the log marginal likelihood :math:`\\log\\sum_j c_j L_j` (B,), the innovation of
        the mixture prior (B, m) with its covariance (B, m, m), and failure codes (B,)
        (:class:`Failure`).  ``with_cov=False`` skips the fused covariance (an output only; ``cov`` None).
        ``measurement`` overrides the measurement model for this step; ``dynamics`` overrides the
        stacked mode dynamics (a :class:`~mmlib.core.models.StackedDynamics`, e.g. with per-run adapted Q
        broadcasting to (B, r, n, n))."""
        z, measurement = self._check_step(state, z, with_cov, measurement)
        if dynamics is not None:
            self._check_dynamics(state, dynamics)
        return self._step(state, z, with_cov, measurement, dynamics)

    def _check_step(self, state, z, with_cov, measurement) -> tuple:
        """The inputs of :meth:`step` but ``dynamics`` checked: ``(z, the measurement model of the step)`` (as
        :meth:`SingleModel._check_step`)."""
        if not isinstance(state, IMMState):
            raise ValueError(f"state: expected the IMMState returned by init(), got {type(state).__name__}")
        _check_state(state.modes, "state", ("mean", "cov"), self.stacked.dim, "IMM mode-filter state")
        check_bool(with_cov, "with_cov")
        measurement = _step_measurement(self.measurement, measurement, self.stacked.dim)
        return _check_measurement(z, measurement.dim, batch=state.mode_probabilities.shape[0]), measurement

    def _check_dynamics(self, state, dynamics) -> None:
        """A ``dynamics`` override of :meth:`step`: stacked mode dynamics of the IMM's state dimension and modes,
        whose Q broadcasts to (B, r, n, n) (ValueError naming ``dynamics``)."""
        check_has(dynamics, "dynamics", "stacked mode dynamics (mmlib.core.models.StackedDynamics)",
                  ("transition", "jacobian", "Q", "dim"))
        B, r, n = state.modes.mean.shape
        if dynamics.dim != n:
            raise ValueError(f"dynamics: state dimension {dynamics.dim}, the IMM's is {n}")
        if len(getattr(dynamics, "models", ())) != r:
            raise ValueError(f"dynamics: {len(getattr(dynamics, 'models', ()))} mode models for an IMM of {r} modes")
        try:
            fits = np.broadcast_shapes(np.shape(dynamics.Q), (B, r, n, n)) == (B, r, n, n)
        except ValueError:
            fits = False
        if not fits:
            raise ValueError(f"dynamics: Q of shape {np.shape(dynamics.Q)} does not broadcast to "
                             f"({B}, {r}, {n}, {n}) (runs, modes, state, state)")

    def _step(self, state, z, with_cov, measurement, dynamics=None) -> tuple:
        """:meth:`step` on inputs :meth:`_check_step` (and :meth:`_check_dynamics`) have checked."""
        fused = self._fused_step(state, z, with_cov, measurement, dynamics)
        if fused is not None:
            return fused
        modes = state.modes
        if type(self.mixing) is MomentMixing:
            c, mixed_means, mixed_covs = linalg.imm_mix(state.mode_probabilities, self.transition, modes.mean,
                                                        modes.cov)
        else:
            c, w = mixing_weights(state.mode_probabilities, self.transition)
            mixed_means, mixed_covs = self.mixing(modes.mean, modes.cov, w)
        modes = modes._replace(mean=mixed_means, cov=mixed_covs)
        modes = self.filter.predict(modes, self.stacked if dynamics is None else dynamics)
        modes, info = self.filter.update(modes, z[:, None, :], measurement)
        mu, marginal, underflow, fused_mean, fused_cov, innovation, innovation_cov = imm_output(
            info.loglik, c, modes.mean, modes.cov, info.innovation, info.S, with_cov)
        failure = _failure_codes(getattr(info, "failed", None))
        # every mode's likelihood underflowed (log L_j = -inf for all j, e.g. a wild measurement): the
        # posterior mode probabilities are 0/0, undefined.  Diverged, with that cause, never patched.
        if underflow.any():
            if failure is None:
                failure = np.zeros(mu.shape[0], dtype=np.int8)
            failure = np.where(underflow & (failure == _NONE), _LIKELIHOOD, failure)
        return IMMState(modes, mu), Estimate(fused_mean, fused_cov, mu, marginal, innovation,
                                             innovation_cov=innovation_cov, failure=failure)

    def _fused_step(self, state, z, with_cov, measurement, dynamics):
        """:meth:`_step` in one compiled call (:func:`mmlib.core.linalg.imm_sigma_step`, the same bits) where that
        call computes exactly what the composed step does: the compiled kernels with fusion on
        (:func:`mmlib.core.linalg.fused`), moment-matching mixing, a plain :class:`SigmaPointFilter` (not a layer or a
        subclass) whose rule's covariances are weighted outer products, linear mode dynamics, a
        :class:`~mmlib.core.filters.GaussianState` per mode and a measurement model whose function the kernel
        evaluates itself (:func:`_fused_measure`); None otherwise (the composed step runs)."""
        stacked = self.stacked if dynamics is None else dynamics
        if type(self.mixing) is not MomentMixing or not _fusable(self.filter, state.modes, stacked):
            return None
        measure = _fused_measure(measurement)
        if measure is None:
            return None
        up = self.filter.rule.unit_points(stacked.dim)
        means, covs, mu, marginal, underflow, mean, cov, innovation, innovation_cov, failed = linalg.imm_sigma_step(
            state.mode_probabilities, self.transition, state.modes.mean, state.modes.cov, up.xi, up.wm, up.wc,
            stacked.F, stacked.Q, z, measure, measurement.angular, measurement.R, with_cov, LOG_2PI)
        failure = _failure_codes(failed)
        if underflow.any():
            failure = np.where(underflow & (failure == _NONE), _LIKELIHOOD, failure)
        return IMMState(GaussianState(means, covs), mu), Estimate(mean, cov, mu, marginal, innovation,
                                                                  innovation_cov=innovation_cov, failure=failure)


def _fusable(filt, state, dynamics) -> bool:
    """Whether a step of ``filt`` from ``state`` through ``dynamics`` can run as one compiled call (with a measurement
    model :func:`_fused_measure` knows): the compiled kernels with fusion on (:func:`mmlib.core.linalg.fused`), a
    plain :class:`SigmaPointFilter` (not a layer or a subclass, which may override a step) whose rule's covariances
    are weighted outer products, a :class:`~mmlib.core.filters.GaussianState` and linear dynamics."""
    return (linalg.fused() and isinstance(filt, SigmaPointFilter) and filt.fusable
            and type(state) is GaussianState and bool(getattr(dynamics, "is_linear", False)))


def _fused_layer_step(filt, state, dynamics, z, measurement) -> tuple | None:
    """A layer's whole single-model step in one compiled call, where the layer offers one (``fused_step``, e.g.
    :meth:`mmlib.core.layers.strong_tracking.StrongTracking.fused_step`) and the step can be fused: the compiled
    kernels with fusion on (:func:`mmlib.core.linalg.fused`), linear dynamics with one (n, n) ``F`` and a measurement
    model :func:`_fused_measure` knows.  ``(state, loglik, innovation, S, failed)``, or None (the composed step runs):
    the layer itself decides whether its configuration and state are ones its fused step computes."""
    step = getattr(filt, "fused_step", None)
    if step is None or not linalg.fused() or not bool(getattr(dynamics, "is_linear", False)) \
            or np.ndim(dynamics.F) != 2:
        return None
    measure = _fused_measure(measurement)
    return None if measure is None else step(state, dynamics, z, measurement, measure)


def _fused_measure(measurement) -> tuple | None:
    """The measurement function of ``measurement`` as :func:`mmlib.core.linalg.imm_sigma_step` takes it, ``(kind, A,
    idx, sensor)``, for the models whose ``h``, ``average`` and ``residual`` the fused step reproduces (exactly
    :class:`LinearMeasurement`, :class:`RangeBearing` and :class:`~mmlib.core.gnss.Pseudoranges`, not a subclass,
    which may override them); None for any other."""
    cls = type(measurement)
    if cls is LinearMeasurement:
        return linalg.MEASURE_LINEAR, measurement.H, (), np.zeros(2)
    if cls is RangeBearing:
        return linalg.MEASURE_RANGE_BEARING, np.zeros((1, 1)), measurement.position_index, measurement.sensor
    if cls is Pseudoranges:
        return (linalg.MEASURE_PSEUDORANGES, measurement.satellites, POSITION_INDEX + CLOCK_INDEX[:1],
                np.zeros(2))
    return None


# --------------------------------------------------------------------------- driver
class Track(NamedTuple):
    r"""Output of :func:`run` over K steps: ``mean`` (B, K, n), ``cov`` (B, K, n, n) or None,
    ``mode_probabilities`` (B, K, r) or None, ``diverged_step`` (B,) first step at which
    the run failed (a covariance stopped being positive definite, every mode likelihood
    underflowed, or the estimate overflowed), -1 if it never did; ``diagnostics`` (B, K, d) or
    None (see :class:`Estimate`); ``divergence_cause`` (B,) :class:`Failure` codes (0: none).

    With ``run(..., consistency=True)``: ``nis`` (B, K) the normalised innovation squared
    :math:`\nu_k^T S_k^{-1} \nu_k` of every step (chi-square with ``nis_dof[k]`` = m_k degrees of freedom for a
    consistent filter) and, when ``truth`` was given, ``nees`` (B, K) the normalised estimation error squared
    :math:`(\hat x_k - x_k)^T P_k^{-1} (\hat x_k - x_k)` (chi-square with n degrees of freedom); NaN from a
    run's divergence on.  Bar-Shalom, Li & Kirubarajan 2001, Sec. 5.4.2."""

    mean: np.ndarray
    cov: Any
    mode_probabilities: Any
    diverged_step: np.ndarray
    diagnostics: Any = None
    divergence_cause: Any = None
    nees: Any = None
    nis: Any = None
    nis_dof: Any = None

    @property
    def diverged(self) -> np.ndarray:
        """(B,) bool: the runs that diverged at some step (``diverged_step >= 0``)."""
        return self.diverged_step >= 0

    def divergence_summary(self) -> str:
        """How many runs diverged, at which steps and why (:func:`summarise_divergence`)."""
        return summarise_divergence(self.diverged_step, self.divergence_cause)

    def errors(self, truth: ArrayLike) -> np.ndarray:
        r"""The estimation errors :math:`\tilde x_k = \hat x_{k|k} - x_k`, k = 1..K, (B, K, n), in the state's units.

        ``truth``: the true states x_0..x_K (B, K+1, n), as :func:`mmlib.experiment.simulate.simulate` returns them
        (its first state x_0 is the start, before the first measurement, and is dropped), or x_1..x_K (B, K, n).
        Estimate k of ``mean`` (0-based; the estimate after the (k+1)-th measurement) is compared with truth
        ``x_{k+1}``, the state the measurement z_{k+1} was drawn from -- the alignment of ``run(..., truth=)``'s NEES
        and of :func:`mmlib.experiment.evaluation.evaluate`.  Runs that diverged carry what their estimates hold
        (non-finite from the divergence on): select ``~track.diverged`` before averaging.  A ``truth`` of another
        shape (runs, steps or state dimension) or non-numeric is a ValueError naming ``truth``."""
        B, K, n = self.mean.shape
        return self.mean - _aligned_truth(truth, B, K, n)


def _aligned_truth(truth, B: int, K: int, n: int | None = None) -> np.ndarray:
    """x_1..x_K (B, K, n) from the true states ``truth`` x_0..x_K (B, K+1, n) or x_1..x_K (B, K, n): the one alignment
    of truth and estimates (:meth:`Track.errors`, ``run(..., truth=)``); ValueError naming ``truth`` otherwise."""
    x = as_float_array(truth, "truth")
    if x.ndim != 3 or x.shape[0] != B or x.shape[1] not in (K, K + 1) or (n is not None and x.shape[2] != n):
        raise ValueError(f"truth: expected shape ({B}, {K + 1}, {'n' if n is None else n}) (x_0..x_K) or "
                         f"({B}, {K}, {'n' if n is None else n}) (x_1..x_K), got {x.shape}")
    return x[:, 1:] if x.shape[1] == K + 1 else x


def summarise_divergence(diverged_step: np.ndarray, cause: np.ndarray | None = None) -> str:
    """``"4 of 100 runs diverged (steps 12, 40 ×2, 41; covariance no longer positive definite)"`` from the
    per-run ``diverged_step`` (-1: did not) and :class:`Failure` codes ``cause`` (None: unknown, read as
    overflow); ``""`` if no run diverged.  The one formatting of divergences (Track, RunSet, reports)."""
    diverged_step = np.asarray(diverged_step)
    bad = np.flatnonzero(diverged_step >= 0)
    if not bad.size:
        return ""
    steps, counts = np.unique(diverged_step[bad], return_counts=True)
    shown = ", ".join(f"{int(k)}" + (f" ×{int(c)}" if c > 1 else "") for k, c in zip(steps[:8], counts[:8])) \
        + (", ..." if steps.size > 8 else "")
    codes = np.full(bad.size, int(Failure.NONFINITE)) if cause is None else np.asarray(cause)[bad]
    kinds = sorted(set(codes.tolist()))
    causes = "; ".join(FAILURE_CAUSES[Failure(int(c))] + (f" ({int((codes == c).sum())})" if len(kinds) > 1 else "")
                       for c in kinds)
    return f"{bad.size} of {diverged_step.size} runs diverged (step{'s' if steps.size > 1 else ''} {shown}; {causes})"


class FilterDivergence(RuntimeError):
    """Raised by :func:`run` with ``on_divergence='raise'`` at the first step where a run fails
    (:class:`Failure`); the message names the estimator, the run, the step and the cause."""


def _per_step_measurements(measurements, measurement_models):
    """Validated ``[(z_k (B, m_k), model_k)]`` for a run whose measurement model changes per step."""
    models = list(measurement_models)
    zs = list(measurements)
    if len(zs) != len(models):
        raise ValueError(f"measurement_models: {len(models)} models for {len(zs)} measurement steps")
    out, B = [], None
    for k, (z, model) in enumerate(zip(zs, models)):
        _check_measurement_model(model, f"measurement_models[{k}]")
        z = check_finite(as_float_array(z, f"measurements[{k}]"), f"measurements[{k}]")
        if z.ndim != 2 or z.shape[1] != model.dim or (B is not None and z.shape[0] != B):
            raise ValueError(f"measurements[{k}]: expected shape ({B if B is not None else 'B'}, {model.dim}) "
                             f"for measurement_models[{k}], got {z.shape}")
        B = z.shape[0]
        out.append((z, model))
    if not out:
        raise ValueError("measurements: no steps (K = 0)")
    return out


def run(estimator: protocols.Estimator, state: tuple, measurements: ArrayLike | Sequence[ArrayLike], *,
        measurement_models: Sequence[protocols.MeasurementModel] | None = None, keep_cov: bool = True,
        on_divergence: str = "record", consistency: bool = False, truth: np.ndarray | None = None) -> Track:
    """Run ``estimator`` over ``measurements`` (B, K, m), batched over runs.

    ``estimator``: a :class:`mmlib.core.protocols.Estimator` (:class:`SingleModel`, :class:`IMM`, ...);
    ``state``: its state from ``estimator.init`` (B runs); ``measurements`` in the measurement model's
    units (e.g. m for positions, (m, rad) for range-bearing), finite.  Returns a :class:`Track`:
    ``mean`` (B, K, n), ``cov`` (B, K, n, n) (None with ``keep_cov=False``), mode probabilities
    (B, K, r) for an IMM.  Bad input (shapes, a non-finite measurement, an unknown ``on_divergence``) is
    a ValueError naming the argument.  Every input is checked once, here or at the first step that uses it:
    the estimators of this module are then stepped without checking again at every step.

    ``consistency=True`` records every step's NIS and, with ``truth`` (B, K+1, n) the true states x_0..x_K
    (or (B, K, n), x_1..x_K), its NEES (:class:`Track`), computed on the fly: the covariances need not be kept.

    With ``measurement_models`` (a sequence of K models), step k uses model k and
    ``measurements`` is a sequence of K arrays (B, m_k): the measurement dimension may change
    from step to step (e.g. the satellites in view).

    A run whose estimate fails at step k (see :class:`Failure`) is *recorded* in
    ``diverged_step`` and ``divergence_cause`` (``on_divergence='record'``) or raises
    :class:`FilterDivergence` naming the estimator, run, step and cause (``'raise'``).
    It is never patched.
    """
    if on_divergence not in ("record", "raise"):
        raise ValueError(f"on_divergence: expected 'record' or 'raise', got {on_divergence!r}")
    keep_cov = check_bool(keep_cov, "keep_cov")
    consistency = check_bool(consistency, "consistency")
    check_has(estimator, "estimator", "an estimator (protocols.Estimator)", ESTIMATOR_METHODS)
    if isinstance(state, np.ndarray) or not isinstance(state, tuple):
        raise ValueError(f"state: expected the state returned by estimator.init(), got {type(state).__name__}")
    B = batch_size(state)
    if measurement_models is None:
        z_all = as_float_array(measurements, "measurements")
        if z_all.ndim != 3:
            raise ValueError(f"measurements: expected shape (B, K, m), got {z_all.shape}")
        if z_all.shape[1] == 0:
            raise ValueError("measurements: no steps (K = 0)")
        model = getattr(estimator, "measurement", None)
        if model is not None and hasattr(model, "dim") and z_all.shape[2] != model.dim:
            raise ValueError(f"measurements: measurement dimension {z_all.shape[2]} does not match the estimator's "
                             f"measurement model ({model.dim})")
        check_finite(z_all, "measurements")
        steps = [(z_all[:, k], None) for k in range(z_all.shape[1])]
    else:
        steps = _per_step_measurements(measurements, measurement_models)
    if steps[0][0].shape[0] != B:
        raise ValueError(f"measurements: {steps[0][0].shape[0]} runs of measurements for a state of {B} runs")
    name = str(getattr(estimator, "name", "") or type(estimator).__name__)
    x_true = _check_truth(truth, B, len(steps), consistency)
    means, covs, mus, diags, nees, nis = [], [], [], [], [], []
    diverged_step = np.full(B, -1)
    cause = np.zeros(B, dtype=np.int8)
    with_cov = keep_cov or x_true is not None
    # this module's estimators split step() into _check_step() and _step(): the state, the flag and each measurement
    # model are checked once, at the first step that uses them (the measurements were checked whole above); any
    # other estimator's step() runs every step, checking its inputs or not -- and so does a subclass or wrapper that
    # overrides step() (the fast path is taken only where step() is this module's own)
    split = getattr(type(estimator), "step", None) in (SingleModel.step, KnownModeSequence.step, IMM.step)
    check, advance = (estimator._check_step, estimator._step) if split else (None, None)
    if check is not None:
        track = _whole_run(estimator, state, steps, check, with_cov, keep_cov, consistency, x_true, name,
                           on_divergence)
        if track is not None:
            return track
    elif callable(getattr(estimator, "whole_run", None)) and linalg.fused():
        # an estimator with a compiled whole run of its own (e.g. NoiseAdaptiveIMM.whole_run, which checks its inputs
        # as its steps would, or returns None where the loop must run: step by step)
        parts = estimator.whole_run(state, steps, with_cov=with_cov, keep_cov=keep_cov, nis=consistency,
                                    truth=x_true)
        if parts is not None:
            return _assemble(*parts, steps, consistency, name, on_divergence)
    models: dict = {}                       # id(a step's measurement model; None: the default) -> the model
    for k, (z_k, model_k) in enumerate(steps):
        if check is None or advance is None:
            state, est = (estimator.step(state, z_k, with_cov=with_cov) if model_k is None
                          else estimator.step(state, z_k, with_cov=with_cov, measurement=model_k))
        else:
            if id(model_k) not in models:
                z_k, models[id(model_k)] = check(state, z_k, with_cov, model_k)
            state, est = advance(state, z_k, with_cov, models[id(model_k)])
        failure = np.zeros(B, dtype=np.int8) if est.failure is None else est.failure
        bad = (~np.isfinite(est.mean).all(axis=1) | (failure != _NONE)) & (diverged_step < 0)
        if bad.any():
            diverged_step[bad] = k
            cause[bad] = np.where(failure[bad] != _NONE, failure[bad], _NONFINITE)
            if on_divergence == "raise":
                r = int(np.argmax(bad))
                raise FilterDivergence(f"{name}: run {r} diverged at step {k} "
                                       f"({FAILURE_CAUSES[Failure(int(cause[r]))]})")
        means.append(est.mean)
        if keep_cov:
            covs.append(est.cov)
        if consistency:
            nis.append(normalised_square(est.innovation, est.innovation_cov))
            if x_true is not None:
                if x_true.shape[-1] != est.mean.shape[-1]:
                    raise ValueError(f"truth: state dimension {x_true.shape[-1]}, but the estimator estimates "
                                     f"{est.mean.shape[-1]}")
                nees.append(normalised_square(est.mean - x_true[:, k], est.cov))
        if est.mode_probabilities is not None:
            mus.append(est.mode_probabilities)
        if est.diagnostics is not None:
            diags.append(est.diagnostics)
    track = Track(np.stack(means, axis=1), np.stack(covs, axis=1) if keep_cov else None,
                  np.stack(mus, axis=1) if mus else None, diverged_step,
                  np.stack(diags, axis=1) if diags else None, cause)
    if consistency:
        after = np.arange(len(steps))[None, :] >= np.where(diverged_step >= 0, diverged_step, len(steps))[:, None]
        nis_arr = np.where(after, np.nan, np.stack(nis, axis=1))
        nees_arr = np.where(after, np.nan, np.stack(nees, axis=1)) if nees else None
        track = track._replace(nees=nees_arr, nis=nis_arr, nis_dof=np.array([z.shape[1] for z, _ in steps]))
    return track


def _whole_run(estimator, state, steps, check, with_cov: bool, keep_cov: bool, consistency: bool, x_true,
               name: str, on_divergence: str) -> Track | None:
    """:func:`run` in one compiled call where every step of it is one the compiled kernels compute: a
    :class:`SingleModel` (exactly, not a subclass) over linear dynamics with one ``F`` whose filter is a plain
    sigma-point filter (:func:`_fusable`: :func:`mmlib.core.linalg.sigma_run`), an extended Kalman filter
    (:func:`_ekf_runs`: :func:`mmlib.core.linalg.ekf_run`) or a layer offering a ``whole_run`` of its own, which
    decides (:meth:`mmlib.core.layers.strong_tracking.StrongTracking.whole_run`,
    :meth:`mmlib.core.layers.adaptive.InnovationAdaptive.whole_run`); or an :class:`IMM` whose steps
    :meth:`IMM._fused_step` fuses (moment mixing: :func:`mmlib.core.linalg.imm_sigma_run`) or whose cycles
    :func:`_imm_layer_run` takes (cubature-principle mixing, EKF or innovation-adaptive mode filters); with
    measurement models whose function the kernels evaluate (:func:`_fused_measure`) and that one call can take
    (:func:`mmlib.core.linalg.packed_steps`: one kind, one R per step).  The steps' inputs are checked as the
    step-by-step loop checks them (``check`` once per model), the kernel computes every step as the step does, and
    the divergences, NIS and NEES follow from its per-step outputs as the loop records them (:func:`_assemble`): the
    same Track, bit for bit (``tests/test_fused.py``, ``tests/test_whole_runs_layers.py``).  None where it
    does not apply (the loop runs).  Every step's model is checked before the first step runs: a model that does not
    fit is named even where, step by step, a run diverging earlier would have stopped ``on_divergence='raise'``
    first."""
    imm = type(estimator) is IMM
    if not linalg.fused() or not (imm or type(estimator) is SingleModel):
        return None
    if x_true is not None and x_true.shape[-1] != (estimator.stacked if imm else estimator.dynamics).dim:
        return None                     # the loop names the mismatch
    if imm:
        packed = packed_imm_steps(estimator, state, steps, with_cov, check)
        if packed is None:
            return _imm_layer_run(estimator, state, steps, check, with_cov, keep_cov, consistency, x_true, name,
                                  on_divergence)
        up = estimator.filter.rule.unit_points(estimator.stacked.dim)
        means, covs, mus, failed, underflow, nis, nees = linalg.imm_sigma_run(
            state.mode_probabilities, estimator.transition, state.modes.mean, state.modes.cov, up.xi, up.wm, up.wc,
            estimator.stacked.F, estimator.stacked.Q, packed, with_cov, LOG_2PI, keep_cov=keep_cov, nis=consistency,
            truth=x_true)
        return _assemble(means, covs, mus, failed, underflow, None, nis, nees, steps, consistency, name, on_divergence)
    dynamics = estimator.dynamics
    if not bool(getattr(dynamics, "is_linear", False)) or np.ndim(dynamics.F) != 2:
        return None
    # a plain sigma-point filter, an EKF, or a layer with a whole run of its own (it decides whether its state allows
    # it)
    plain = _fusable(estimator.filter, state, dynamics)
    ekf = not plain and _ekf_runs(estimator.filter, state)
    layer_run = None if plain or ekf else getattr(estimator.filter, "whole_run", None)
    if not plain and not ekf and layer_run is None:
        return None
    packed = _packed(state, steps, with_cov, check, dynamics.dim)
    if packed is None:
        return None
    if ekf:
        out = linalg.ekf_run(state.mean, state.cov, dynamics.F, dynamics.Q, packed, LOG_2PI, keep_cov=keep_cov,
                             nis=consistency, truth=x_true)
    elif layer_run is not None:
        out = layer_run(state, dynamics, packed, keep_cov=keep_cov, nis=consistency, truth=x_true)
        if out is None:
            return None
    else:
        up = estimator.filter.rule.unit_points(dynamics.dim)
        out = linalg.sigma_run(state.mean, state.cov, up.xi, up.wm, up.wc, dynamics.F, dynamics.Q, packed, LOG_2PI,
                               keep_cov=keep_cov, nis=consistency, truth=x_true)
    means, covs, failed, nis, nees = out
    return _assemble(means, covs, None, failed, None, None, nis, nees, steps, consistency, name, on_divergence)


def _ekf_runs(filt, state) -> bool:
    """Whether a compiled whole run computes the steps of ``filt`` from ``state``: the compiled kernels with fusion
    on, exactly an :class:`~mmlib.core.filters.ExtendedKalmanFilter` (a subclass may override a step) and a
    :class:`~mmlib.core.filters.GaussianState` (the caller checks the dynamics: linear, one F, or one per mode)."""
    return linalg.fused() and type(filt) is ExtendedKalmanFilter and type(state) is GaussianState


def _imm_layer_run(imm: "IMM", state, steps, check, with_cov: bool, keep_cov: bool, consistency: bool, x_true,
                   name: str, on_divergence: str) -> Track | None:
    """:func:`_whole_run` of an :class:`IMM` (exactly) over linear mode dynamics whose cycles
    :func:`mmlib.core.linalg.imm_layer_run` computes and :func:`mmlib.core.linalg.imm_sigma_run` does not: moment or
    cubature-principle mixing (a mixing strategy whose ``fused_form()`` is ``"cubature"``,
    :class:`mmlib.core.mixing.CubatureMixing`) with extended Kalman mode filters (:func:`_ekf_runs`) or
    innovation-adaptive ones (a filter whose ``fused_adaptive_form(state.modes)`` gives its parameters,
    :class:`mmlib.core.layers.adaptive.InnovationAdaptive`), and cubature-principle mixing with plain sigma-point
    mode filters.  The Track of the step-by-step loop, bit for bit, or None where it does not apply (the loop
    runs)."""
    if not isinstance(state, IMMState) or not bool(getattr(imm.stacked, "is_linear", False)):
        return None
    moment = type(imm.mixing) is MomentMixing
    mixing_form = getattr(imm.mixing, "fused_form", None)
    cubature = not moment and callable(mixing_form) and mixing_form() == "cubature"
    if not (moment or cubature):
        return None
    filter_form = getattr(imm.filter, "fused_adaptive_form", None)
    adaptive = filter_form(state.modes) if callable(filter_form) else None
    ekf = adaptive is None and _ekf_runs(imm.filter, state.modes)
    if adaptive is None and not ekf and (moment or not _fusable(imm.filter, state.modes, imm.stacked)):
        return None
    packed = _packed(state, steps, with_cov, check, imm.stacked.dim)
    if packed is None:
        return None
    n = imm.stacked.dim
    if ekf:
        xi, wm, wc = linalg.no_rule_operands(n)
    else:
        up = (imm.filter if adaptive is None else imm.filter.base).rule.unit_points(n)
        xi, wm, wc = up.xi, up.wm, up.wc
    out = linalg.imm_layer_run(state.mode_probabilities, imm.transition, state.modes.mean, state.modes.cov, xi, wm,
                               wc, imm.stacked.F, imm.stacked.Q, packed, cubature, adaptive, with_cov, LOG_2PI,
                               keep_cov=keep_cov, nis=consistency, truth=x_true, ekf=ekf)
    if out is None:
        return None
    means, covs, mus, failed, underflow, nis, nees = out
    return _assemble(means, covs, mus, failed, underflow, None, nis, nees, steps, consistency, name, on_divergence)


def _packed(state, steps, with_cov: bool, check, n: int) -> tuple | None:
    """The measurement steps of a run packed for one compiled call (:func:`mmlib.core.linalg.packed_steps`), each
    model checked once with ``check(state, z, with_cov, model)`` as the step-by-step loop checks it; None where a
    model's function is not one the kernels evaluate (:func:`_fused_measure`) or one call cannot take the steps."""
    zs, measures, angulars, Rs, models = [], [], [], [], {}
    for z_k, model_k in steps:
        if id(model_k) not in models:
            z_k, models[id(model_k)] = check(state, z_k, with_cov, model_k)
        model = models[id(model_k)]
        measure = _fused_measure(model)
        if measure is None:
            return None
        zs.append(z_k)
        measures.append(measure)
        angulars.append(model.angular)
        Rs.append(model.R)
    return linalg.packed_steps(zs, measures, angulars, Rs, n)


def packed_imm_steps(imm: "IMM", state: "IMMState", steps: Sequence[tuple], with_cov: bool,
                     check: Callable | None = None) -> tuple | None:
    """The measurement steps ``steps`` ((z_k (B, m_k), model_k or None) pairs, as :func:`run` holds them) of a run of
    ``imm`` from ``state`` packed for one compiled call (:func:`mmlib.core.linalg.packed_steps`), each model checked as
    :meth:`IMM.step` checks it (``check``: that check, default ``imm._check_step``); None where the IMM's steps would
    not be fused steps (exactly an :class:`IMM`, moment mixing, :func:`_fusable`) or one call cannot take the
    steps.  For the layers that run an IMM's cycles in a compiled whole run of their own (e.g.
    :meth:`mmlib.core.layers.adaptive_imm.NoiseAdaptiveIMM.whole_run`)."""
    if not linalg.fused() or type(imm) is not IMM or type(imm.mixing) is not MomentMixing \
            or not isinstance(state, IMMState) or not _fusable(imm.filter, state.modes, imm.stacked):
        return None
    return _packed(state, steps, with_cov, imm._check_step if check is None else check, imm.stacked.dim)


def _assemble(means, covs, mus, failed, underflow, diagnostics, nis, nees, steps, consistency: bool, name: str,
              on_divergence: str) -> Track:
    """The Track of a whole run from its per-step outputs (means (B, K, n), covs or None, mode probabilities or None,
    failed (B, K) (a filter failed), underflow (B, K) or None (every mode's likelihood underflowed), diagnostics
    (B, K, d) or None, NIS and NEES (B, K) or None), as the step-by-step loop of :func:`run` records them: a run
    diverges at the first step whose estimate is not finite or whose filter failed, with that cause; the NIS and NEES
    NaN from its divergence on; ``on_divergence='raise'`` names the first run failing at the first such step."""
    failure = np.where(failed, _COVARIANCE, _NONE)
    if underflow is not None:
        failure = np.where(underflow & (failure == _NONE), _LIKELIHOOD, failure)
    B, K = failure.shape
    bad = ~np.isfinite(means).all(axis=2) | (failure != _NONE)
    hit = bad.any(axis=1)
    first = np.argmax(bad, axis=1)
    diverged_step = np.where(hit, first, -1)
    cause = np.zeros(B, dtype=np.int8)
    rows = np.flatnonzero(hit)
    at = failure[rows, first[rows]]
    cause[rows] = np.where(at != _NONE, at, _NONFINITE)
    if on_divergence == "raise" and rows.size:
        k = int(diverged_step[rows].min())
        r = int(np.flatnonzero(diverged_step == k)[0])
        raise FilterDivergence(f"{name}: run {r} diverged at step {k} ({FAILURE_CAUSES[Failure(int(cause[r]))]})")
    track = Track(means, covs, mus, diverged_step, diagnostics, cause)
    if consistency:
        after = np.arange(K)[None, :] >= np.where(diverged_step >= 0, diverged_step, K)[:, None]
        track = track._replace(nees=None if nees is None else np.where(after, np.nan, nees),
                               nis=np.where(after, np.nan, nis), nis_dof=np.array([z.shape[1] for z, _ in steps]))
    return track


def _check_truth(truth, B: int, K: int, consistency: bool):
    """The true states x_1..x_K (B, K, n) of ``run(..., truth=)``, or None."""
    if truth is None:
        return None
    if not consistency:
        raise ValueError("truth: only used with consistency=True (the NEES)")
    return check_finite(_aligned_truth(truth, B, K), "truth")


def select_runs(state: Any, index: slice | np.ndarray) -> Any:
    """The sub-batch ``index`` of any (nested NamedTuple) filter state of B runs: ``index`` a slice, a 1-D
    sequence or array of run indices 0..B-1, or a boolean mask (B,).  ValueError naming ``state`` (no per-run
    array) or ``index`` (anything else: a float, an index beyond the runs, a mask of another length)."""
    if not isinstance(state, (tuple, np.ndarray)):
        raise ValueError(f"state: expected a filter or estimator state (as returned by init), got "
                         f"{type(state).__name__}")
    B = batch_size(state)
    if not isinstance(index, slice):
        arr = np.asarray(index) if not isinstance(index, (str, bytes)) else None
        if arr is not None and arr.dtype.kind == "b":
            index = check_mask(arr, "index", B)
        elif arr is None or arr.ndim != 1 or (arr.size and arr.dtype.kind not in "iu"):
            raise ValueError(f"index: expected a slice, a 1-D sequence of run indices or a boolean mask of the {B} "
                             f"runs, got {index!r}")
        else:
            index = np.array([check_index(i, "index", B) for i in arr.tolist()], dtype=int)
    return _select_runs(state, index)


def _select_runs(state, index):
    if isinstance(state, tuple):
        parts = [_select_runs(s, index) for s in state]
        return type(state)(*parts) if hasattr(state, "_fields") else tuple(parts)
    if isinstance(state, np.ndarray):
        return state[index]
    return state
