r"""A tracking scenario as data: the truth and sensor of an experiment and the models a filter is given, in SI units,
independent of any algorithm.  Every paper module builds its headline scenario as one (``<paper>.scenario()``), the
arena adds a ladder of controlled ones (:mod:`mmlib.arena.ladder`), and the recipes of :mod:`mmlib.arena.recipes`
build each algorithm from a scenario's models alone.

What a scenario provides (SI units throughout: m, s, rad, m/s; a paper that prints km is converted at its boundary):

* ``simulator(mc) -> simulate_runs``, with ``simulate_runs(runs) -> (truth (B, K+1, n), measurements, start (B, n))``:
  the runs' truth, measurements ((B, K, m), or a list of K arrays (B, m_k) when the sensor changes per step) and the
  filters' initial means, each run from its own streams of ``mc`` (:mod:`mmlib.experiment.montecarlo`);
* the filters' models: ``modes`` (the IMM's motion models with ``transition``, rows "from", and ``mode_probabilities``
  at step 0) and ``single`` (the dynamics of single-model filters), either of which may be None with the reason in
  ``notes``; ``measurement`` (or ``measurement_models``, one per step); ``P0`` the initial covariance;
* ``ukf`` the (alpha, beta, kappa) of the scenario's unscented rule (the set-up's own tuning) and ``noise_levels``
  (None, or a process-noise family ``level -> dynamics`` with ``Q(levels)``, for IMMs whose noise levels are set
  online);
* ``position`` and ``velocity``: the state indices of the position and velocity components (for the metrics).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Callable, Mapping

import numpy as np

from mmlib.core._validate import (as_float_array, check_applies, check_covariance, check_finite, check_has,
                                  check_indices, check_name, check_positive_int, check_scalar)
from mmlib.core.protocols import Dynamics, MeasurementModel, require

__all__ = [
    "Scenario"
]


@dataclass(frozen=True, eq=False)
class Scenario:
    """One tracking experiment (see the module docstring).  ``name`` is its key (``zhu2016``, ``ladder-nl3``);
    ``title`` a line for tables; ``source`` its origin (a DOI, or "controlled"); ``root_seed`` the root seed of its
    Monte Carlo streams; ``n_steps`` K and ``T`` (s) the steps and sampling interval; ``properties`` anything
    scenario-specific a table may show (e.g. the nonlinearity design); ``notes`` why a model is absent."""

    name: str
    title: str
    source: str
    root_seed: int
    T: float
    n_steps: int
    simulator: Callable
    P0: np.ndarray
    position: tuple
    velocity: tuple
    single: Any = None
    modes: tuple | None = None
    transition: Any = None
    mode_probabilities: Any = None
    measurement: Any = None
    measurement_models: tuple | None = None
    ukf: tuple = (1.0, 2.0, 0.0)
    noise_levels: Any = None
    properties: dict = field(default_factory=dict)
    notes: dict = field(default_factory=dict)

    def __post_init__(self):
        check_name(self.name, "name")
        if not self.name:
            raise ValueError("name: a scenario needs a name")
        check_name(self.title, "title")
        check_name(self.source, "source")
        # stored as checked (Python int and float: a numpy scalar or 0-d array is not kept as given)
        object.__setattr__(self, "root_seed", check_positive_int(self.root_seed, "root_seed", minimum=0))
        object.__setattr__(self, "T", check_scalar(self.T, "T", positive=True))
        object.__setattr__(self, "n_steps", check_positive_int(self.n_steps, "n_steps"))
        if not callable(self.simulator):
            raise ValueError(f"simulator: expected a function mc -> (runs -> (truth, measurements, start)), got "
                             f"{type(self.simulator).__name__}")
        if self.single is None and self.modes is None:
            raise ValueError("single, modes: a scenario needs the single-model dynamics, the IMM's modes or both")
        if self.single is not None:
            require(self.single, "single", Dynamics)
        if self.modes is not None:
            if isinstance(self.modes, (str, bytes)) or not hasattr(self.modes, "__iter__") or not len(self.modes):
                raise ValueError(f"modes: expected a non-empty sequence of dynamics models, got {self.modes!r}")
            require(self.modes[0], "modes[0]", Dynamics)
        elif self.transition is not None or self.mode_probabilities is not None:
            raise ValueError("transition, mode_probabilities: given without modes (they belong to the IMM's modes)")
        n = self.single.dim if self.single is not None else self.modes[0].dim
        if self.modes is not None:
            object.__setattr__(self, "modes", tuple(self.modes))
            for j, mode in enumerate(self.modes):
                require(mode, f"modes[{j}]", Dynamics)
                if mode.dim != n:
                    raise ValueError(f"modes[{j}]: state dimension {mode.dim}, expected {n}")
            r = len(self.modes)
            T = check_finite(as_float_array(self.transition, "transition"), "transition")
            if T.shape != (r, r) or np.any(T < 0) or not np.allclose(T.sum(axis=1), 1.0, rtol=0, atol=1e-12):
                raise ValueError(f"transition: expected a ({r}, {r}) matrix with rows ('from') summing to 1, "
                                 f"got {T.tolist()}")
            mu = check_finite(as_float_array(self.mode_probabilities, "mode_probabilities"), "mode_probabilities")
            if mu.shape != (r,) or np.any(mu < 0) or abs(mu.sum() - 1.0) > 1e-12:
                raise ValueError(f"mode_probabilities: expected {r} probabilities summing to 1, got {mu.tolist()}")
            object.__setattr__(self, "transition", T)
            object.__setattr__(self, "mode_probabilities", mu)
        if (self.measurement is None) == (self.measurement_models is None):
            raise ValueError("measurement, measurement_models: give exactly one (a fixed sensor, or one per step)")
        if self.measurement is not None:
            require(self.measurement, "measurement", MeasurementModel)
            check_applies(self.measurement, "measurement", n)
        else:
            if isinstance(self.measurement_models, (str, bytes)) or not hasattr(self.measurement_models, "__iter__"):
                raise ValueError(f"measurement_models: expected a sequence of measurement models, one per step, got "
                                 f"{self.measurement_models!r}")
            object.__setattr__(self, "measurement_models", tuple(self.measurement_models))
            if len(self.measurement_models) != self.n_steps:
                raise ValueError(f"measurement_models: {len(self.measurement_models)} models for "
                                 f"{self.n_steps} steps")
            probed = set()
            for k, model in enumerate(self.measurement_models):
                require(model, f"measurement_models[{k}]", MeasurementModel)
                kind = (type(model), model.dim)   # probed once per kind of model, not once per step
                if kind not in probed:
                    check_applies(model, f"measurement_models[{k}]", n)
                    probed.add(kind)
        P0 = check_covariance(as_float_array(self.P0, "P0"), "P0")
        if P0.shape != (n, n):
            raise ValueError(f"P0: expected shape ({n}, {n}), got {P0.shape}")
        object.__setattr__(self, "P0", P0)
        for name in ("position", "velocity"):
            object.__setattr__(self, name, check_indices(getattr(self, name), name, n))
        self._check_ukf(n)
        if self.noise_levels is not None:
            check_has(self.noise_levels, "noise_levels", "None or a process-noise family with its two levels",
                      ("family", "lower", "upper"))
            check_has(self.noise_levels.family, "noise_levels.family", "a process-noise family (level -> dynamics)",
                      ("dynamics", "Q"))
            check_scalar(self.noise_levels.lower, "noise_levels.lower", nonnegative=True)
            check_scalar(self.noise_levels.upper, "noise_levels.upper", nonnegative=True)
        for name in ("properties", "notes"):
            value = getattr(self, name)
            if not isinstance(value, Mapping) or not all(isinstance(k, str) for k in value):
                raise ValueError(f"{name}: expected a dict with string keys, got {value!r}")
        for key, note in self.notes.items():
            check_name(note, f"notes[{key!r}]")
        self._freeze()

    def _check_ukf(self, n: int) -> None:
        """``ukf`` is an (alpha, beta, kappa) the unscented rule accepts for states of dimension ``n``."""
        from mmlib.core.rules import Unscented
        if isinstance(self.ukf, (str, bytes)) or not hasattr(self.ukf, "__len__") or len(self.ukf) != 3:
            raise ValueError(f"ukf: expected the unscented rule's (alpha, beta, kappa), got {self.ukf!r}")
        try:
            Unscented(*self.ukf).unit_points(n)
        except ValueError as exc:
            raise ValueError(f"ukf: {self.ukf!r} is not a valid (alpha, beta, kappa) for {n} states ({exc})") from None

    def _freeze(self):
        """Read-only arrays and mappings: a scenario is shared (cached per process) by every cell that uses it."""
        for name in ("P0", "transition", "mode_probabilities"):
            value = getattr(self, name)
            if isinstance(value, np.ndarray):
                value = value.copy()
                value.setflags(write=False)
                object.__setattr__(self, name, value)
        for name in ("properties", "notes"):
            object.__setattr__(self, name, MappingProxyType(dict(getattr(self, name))))

    @property
    def dim(self) -> int:
        """State dimension n."""
        return self.single.dim if self.single is not None else self.modes[0].dim

    @property
    def measurement_dim(self) -> int:
        """The largest measurement dimension of any step."""
        if self.measurement is not None:
            return int(self.measurement.dim)
        return max(int(m.dim) for m in self.measurement_models)

    @property
    def nonlinear_measurement(self) -> bool:
        """Whether any step's measurement model is nonlinear (a model without ``is_linear`` counts as nonlinear)."""
        models = [self.measurement] if self.measurement is not None else self.measurement_models
        return not all(getattr(m, "is_linear", False) for m in models)
