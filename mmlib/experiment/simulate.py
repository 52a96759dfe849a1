r"""Ground truth and measurements for piecewise maneuver schedules.

Time grid (stated once): ``x_0`` at ``t = 0``; step ``k = 1..K`` moves the
target over ``[t_{k-1}, t_k)`` with the dynamics of the segment that contains
``t_{k-1}`` and then measures it at ``t_k = kT``.  A segment ``(t0, t1, mode)``
therefore covers the transitions that *start* in ``[t0, t1)``.  A jump
``(t, indices, values)`` overwrites state components of the truth at ``t``
(after the step that ends at ``t``), e.g. an acceleration switched on at t.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterable, NamedTuple, Sequence

import numpy as np
from numpy.typing import ArrayLike

from mmlib.core._validate import (as_float_array, check_applies, check_bool, check_finite, check_has, check_index,
                                  check_positive_int, check_scalar)
from mmlib.core.linalg import matmul_rows
from mmlib.experiment.montecarlo import MonteCarlo, Stream
from mmlib.core.protocols import MeasurementModel, SimulatedDynamics, members

SIMULATED_DYNAMICS_METHODS = members(SimulatedDynamics)


@dataclass(frozen=True, eq=False)
class ManeuverSchedule:
    """Which of ``models`` drives each step: ``segments`` of ``(t_start, t_end, model_index)``,
    ``default`` elsewhere."""

    models: Sequence
    segments: Sequence[tuple]
    default: int
    T: float
    n_steps: int
    jumps: Sequence[tuple] = ()      # (t, state indices, values): set after the step that ends at t

    def __post_init__(self):
        check_positive_int(self.n_steps, "n_steps")
        if isinstance(self.models, (str, bytes)) or not hasattr(self.models, "__len__") or not len(self.models):
            raise ValueError(f"models: expected a non-empty sequence of dynamics models, got {self.models!r}")
        for j, model in enumerate(self.models):
            check_has(model, f"models[{j}]", "a dynamics model that drives a truth (protocols.SimulatedDynamics)",
                      SIMULATED_DYNAMICS_METHODS)
        r = len(self.models)
        n = self.models[0].dim
        if any(model.dim != n for model in self.models):
            raise ValueError(f"models: every model must have the state dimension {n}, got "
                             f"{[model.dim for model in self.models]}")
        for i, seg in enumerate(self.segments):
            try:
                t0, t1 = check_scalar(seg[0], "t_start"), check_scalar(seg[1], "t_end")
                check_index(seg[2], "model index", r)
                if len(seg) != 3 or not t0 < t1:
                    raise ValueError("need t_start < t_end")
            except (ValueError, TypeError, IndexError) as exc:
                raise ValueError(f"segments[{i}]: bad segment {seg!r} (need (t_start < t_end, model index < {r}): "
                                 f"{exc})") from None
        check_index(self.default, "default", r)
        object.__setattr__(self, "T", check_scalar(self.T, "T", positive=True))    # sampling interval (s)
        for i, jump in enumerate(self.jumps):
            try:
                check_scalar(jump[0], "t")
                idx = [check_index(j, "state index", n) for j in jump[1]]
                values = check_finite(as_float_array(jump[2], "values"), "values")
                if len(jump) != 3 or values.shape != (len(idx),):
                    raise ValueError("need (t, indices, values) of equal lengths")
            except (ValueError, TypeError, IndexError) as exc:
                raise ValueError(f"jumps[{i}]: bad jump {jump!r}: {exc}") from None

    def modes(self) -> np.ndarray:
        """Index of the model used for step k = 1..K, shape (K,)."""
        t_start = np.arange(self.n_steps) * self.T
        out = np.full(self.n_steps, self.default)
        for t0, t1, mode in self.segments:
            out[(t_start >= t0 - 1e-9) & (t_start < t1 - 1e-9)] = mode
        return out

    @property
    def times(self) -> np.ndarray:
        """Measurement times t_k = kT (s) of the steps k = 1..K, shape (K,)."""
        return np.arange(1, self.n_steps + 1) * self.T


class Scenario(NamedTuple):
    """What :func:`simulate` returns for B runs: ``truth`` (B, K+1, n), ``measurements`` (B, K, m) and the
    schedule's model index per step ``modes`` (K,)."""

    truth: np.ndarray          # (B, K+1, n), index 0 is x_0
    measurements: np.ndarray   # (B, K, m)
    modes: np.ndarray          # (K,)


def propagate(schedule: ManeuverSchedule, x0: ArrayLike, process_noise: np.ndarray | None = None) -> np.ndarray:
    """Truth (B, K+1, n) from ``x0`` (B, n) under ``schedule``; ``process_noise`` is None (a
    deterministic trajectory) or standard normals (B, K, n_w) scaled by each step's model."""
    modes = schedule.modes()
    x = np.array(x0, dtype=float)
    truth = [x]
    times = schedule.times
    for k in range(schedule.n_steps):
        model = schedule.models[modes[k]]
        x = model.transition(x)
        if process_noise is not None:
            L = model.noise_factor
            x = x + matmul_rows(process_noise[:, k, :L.shape[1]], L.T)      # same bits whatever B
        for t_jump, idx, values in schedule.jumps:
            if abs(times[k] - t_jump) < 1e-9:
                x[:, list(idx)] = values
        truth.append(x)
    return np.stack(truth, axis=1)


def simulate(schedule: ManeuverSchedule, x0: ArrayLike, measurement: MeasurementModel, mc: MonteCarlo,
             runs: Iterable[int], *, process_noise: bool = True,
             measurement_noise_fn: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None) -> Scenario:
    """Truth trajectories and noisy measurements for the given runs.

    Process noise of run r comes from its ``Stream.TRUTH`` stream, measurement noise
    from ``Stream.MEASUREMENT`` (one draw of shape (K, n_w) / (K, m) per run), so the
    truth of run r is the same whichever filters, chunks or measurement model follow.
    ``measurement_noise_fn(truth, noise)`` may replace the additive-noise model
    (e.g. sensor faults).
    """
    runs = list(runs)
    check_has(measurement, "measurement", "a measurement model", ("h", "dim", "noise_factor"))
    check_applies(measurement, "measurement", schedule.models[0].dim)
    process_noise = check_bool(process_noise, "process_noise")
    if not isinstance(mc, MonteCarlo):
        raise ValueError(f"mc: expected a MonteCarlo, got {type(mc).__name__}")
    x0 = check_finite(as_float_array(x0, "x0"), "x0")
    n = schedule.models[0].dim
    if x0.shape not in ((n,), (len(runs), n)):
        raise ValueError(f"x0: expected shape ({n},) or ({len(runs)}, {n}), got {x0.shape}")
    modes = schedule.modes()
    K = schedule.n_steps
    n_w = max(m.noise_factor.shape[1] for m in schedule.models)
    w = mc.standard_normal(runs, Stream.TRUTH, (K, n_w))
    truth = propagate(schedule, np.broadcast_to(x0, (len(runs), n)), w if process_noise else None)
    v = mc.standard_normal(runs, Stream.MEASUREMENT, (K, measurement.dim))
    if measurement_noise_fn is None:
        z = measurement.h(truth[:, 1:]) + v @ measurement.noise_factor.T
    else:
        z = measurement_noise_fn(truth[:, 1:], v)
    return Scenario(truth, z, modes)
