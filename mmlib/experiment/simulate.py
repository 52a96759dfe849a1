r"""Ground truth and measurements for piecewise maneuver schedules.

Time grid (stated once): ``x_0`` at ``t = 0``; step ``k = 1..K`` moves the
target over ``[t_{k-1}, t_k)`` with the dynamics of the segment that contains
``t_{k-1}`` and then measures it at ``t_k = kT``.  A segment ``(t0, t1, mode)``
therefore covers the transitions that *start* in ``[t0, t1)``.  A jump
``(t, indices, values)`` overwrites state components of the truth at ``t``
(after the step that ends at ``t``), e.g. an acceleration switched on at t.
"""
from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any, Callable, Hashable, Iterable, NamedTuple, Sequence

import numpy as np
from numpy.typing import ArrayLike

from mmlib.core._validate import (as_float_array, check_applies, check_bool, check_finite, check_has, check_index,
                                  check_positive_int, check_scalar)
from mmlib.core.linalg import kernel, matmul_rows
from mmlib.experiment.montecarlo import MonteCarlo, Stream
from mmlib.core.protocols import MeasurementModel, SimulatedDynamics, members

__all__ = [
    "simulate", "ManeuverSchedule", "Scenario", "propagate", "SIMULATED_DYNAMICS_METHODS", "BatchMemo", "runs_key"
]

SIMULATED_DYNAMICS_METHODS = members(SimulatedDynamics)


@dataclass(frozen=True, eq=False)
class ManeuverSchedule:
    """Which of ``models`` drives each step: ``segments`` of ``(t_start, t_end, model_index)``,
    ``default`` elsewhere.

    Every segment must contain the start of a step and every jump must fall on a measurement time ``t_k = kT``:
    one that no step reaches (a mistyped time, a segment between two steps) would be silently ignored, so it is a
    ValueError naming it.  ``truncate=True`` declares the schedule the first ``n_steps`` of a longer one (e.g. a
    paper's set-up run for fewer steps): segments and jumps after the last step are then dropped, as intended."""

    models: Sequence
    segments: Sequence[tuple]
    default: int
    T: float
    n_steps: int
    jumps: Sequence[tuple] = ()      # (t, state indices, values): set after the step that ends at t
    truncate: bool = False           # the first n_steps of a longer schedule: what lies beyond is dropped

    def __post_init__(self):
        check_positive_int(self.n_steps, "n_steps")
        check_bool(self.truncate, "truncate")
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
        for arg in ("segments", "jumps"):
            value = getattr(self, arg)
            if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
                raise ValueError(f"{arg}: expected a sequence of tuples, got {value!r}")
        object.__setattr__(self, "T", check_scalar(self.T, "T", positive=True))    # sampling interval (s)
        t_start = np.arange(self.n_steps) * self.T          # when each step's transition starts (module docstring)
        for i, seg in enumerate(self.segments):
            try:
                t0, t1 = check_scalar(seg[0], "t_start"), check_scalar(seg[1], "t_end")
                check_index(seg[2], "model index", r)
                if len(seg) != 3 or not t0 < t1:
                    raise ValueError("need t_start < t_end")
            except (ValueError, TypeError, IndexError) as exc:
                raise ValueError(f"segments[{i}]: bad segment {seg!r} (need (t_start < t_end, model index < {r}): "
                                 f"{exc})") from None
            beyond = t0 - 1e-9 > t_start[-1]                 # after the last step starts
            if not np.any((t_start >= t0 - 1e-9) & (t_start < t1 - 1e-9)) and not (beyond and self.truncate):
                raise ValueError(f"segments[{i}]: ({t0:g}, {t1:g}) s contains the start of none of the "
                                 f"{self.n_steps} steps (t = 0..{t_start[-1]:g} s, T = {self.T:g} s): beyond the "
                                 f"horizon or between two steps, it would be ignored (truncate=True: the first "
                                 f"n_steps of a longer schedule)")
        check_index(self.default, "default", r)
        times = self.times
        for i, jump in enumerate(self.jumps):
            try:
                t = check_scalar(jump[0], "t")
                if isinstance(jump[1], (str, bytes)):
                    raise ValueError("state indices: expected a sequence of integers")
                idx = [check_index(j, "state index", n) for j in jump[1]]
                values = check_finite(as_float_array(jump[2], "values"), "values")
                if len(jump) != 3 or values.shape != (len(idx),):
                    raise ValueError("need (t, indices, values) of equal lengths")
            except (ValueError, TypeError, IndexError) as exc:
                raise ValueError(f"jumps[{i}]: bad jump {jump!r}: {exc}") from None
            if not np.any(np.abs(times - t) < 1e-9) and not (t - 1e-9 > times[-1] and self.truncate):
                raise ValueError(f"jumps[{i}]: t = {t:g} s is none of the measurement times t_k = kT "
                                 f"({times[0]:g}..{times[-1]:g} s, T = {self.T:g} s): beyond the horizon or between "
                                 f"two steps, it would be ignored (truncate=True: the first n_steps of a longer "
                                 f"schedule)")

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


def _check_schedule(schedule) -> ManeuverSchedule:
    if not isinstance(schedule, ManeuverSchedule):
        raise ValueError(f"schedule: expected a ManeuverSchedule, got {type(schedule).__name__}")
    return schedule


def propagate(schedule: ManeuverSchedule, x0: ArrayLike, process_noise: np.ndarray | None = None) -> np.ndarray:
    """Truth (B, K+1, n) from ``x0`` (B, n) under ``schedule``; ``process_noise`` is None (a
    deterministic trajectory) or standard normals (B, K, n_w) scaled by each step's model."""
    _check_schedule(schedule)
    n = schedule.models[0].dim
    x0 = check_finite(as_float_array(x0, "x0"), "x0")
    if x0.ndim != 2 or x0.shape[1] != n:
        raise ValueError(f"x0: expected shape (B, {n}), got {x0.shape}")
    if process_noise is not None:
        process_noise = check_finite(as_float_array(process_noise, "process_noise"), "process_noise")
        n_w = max(m.noise_factor.shape[1] for m in schedule.models)
        if process_noise.ndim != 3 or process_noise.shape[:2] != (x0.shape[0], schedule.n_steps) \
                or process_noise.shape[2] < n_w:
            raise ValueError(f"process_noise: expected None or standard normals of shape ({x0.shape[0]}, "
                             f"{schedule.n_steps}, >= {n_w}), got {process_noise.shape}")
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
    _check_schedule(schedule)
    if measurement_noise_fn is not None and not callable(measurement_noise_fn):
        raise ValueError(f"measurement_noise_fn: expected None or a function (truth, noise) -> measurements, got "
                         f"{type(measurement_noise_fn).__name__}")
    if isinstance(runs, (str, bytes)) or not hasattr(runs, "__iter__"):
        raise ValueError(f"runs: expected a range or sequence of run indices, got {runs!r}")
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


# --------------------------------------------------------------------------- remembered batches
def runs_key(runs: Any) -> tuple | None:
    """The run indices of ``runs`` as a tuple of ints, or None for anything but a range, list, tuple or 1-D integer
    array of them (left to the simulator to use or refuse)."""
    if isinstance(runs, range):
        return tuple(runs)
    if isinstance(runs, np.ndarray):
        if runs.ndim != 1 or runs.dtype.kind not in "iu":
            return None
        return tuple(int(r) for r in runs)
    if not isinstance(runs, (list, tuple)) or \
            not all(isinstance(r, (int, np.integer)) and not isinstance(r, bool) for r in runs):
        return None
    return tuple(int(r) for r in runs)


def _read_only(value) -> tuple:
    """``value`` (an array, or a list or tuple -- a NamedTuple included -- of them, as a simulator returns) with its
    arrays made read-only, and the bytes of their data."""
    if isinstance(value, np.ndarray):
        value.setflags(write=False)
        return value, value.nbytes
    if isinstance(value, (list, tuple)):
        parts = [_read_only(v) for v in value]
        return _same_kind(value, [p for p, _ in parts]), sum(n for _, n in parts)
    return value, 0


def _handed_out(value):
    """A remembered ``value`` as handed to a caller: a list is a new list (a caller may append to its own), every
    array the same read-only one."""
    if isinstance(value, (list, tuple)):
        return _same_kind(value, [_handed_out(v) for v in value])
    return value


def _same_kind(like, items: list):
    """``items`` as a container of ``like``'s type (a NamedTuple rebuilt field by field)."""
    return like._make(items) if hasattr(like, "_make") else type(like)(items)


class BatchMemo:
    """Simulated Monte Carlo batches a process remembers, the most recently used: at most ``max_batches`` of them
    and ``max_bytes`` of array data in all (a batch larger than that is not kept).  Estimators evaluated one after
    the other on the same runs (the cells of an arena scenario, the filters of a reading) ask for the same batches;
    each is simulated once.  A remembered batch is the simulator's own output under the kernel implementation in use
    (:func:`mmlib.core.linalg.kernel`, part of every entry's key: the two agree only to round-off), so it is the one
    a fresh simulation gives, bit for bit; its arrays are read-only (a caller's write is a ValueError) and a list in
    it is a new list for each caller.

    :meth:`wrap` memoises one simulator under a ``key`` that must determine its batches together with the run
    indices (a paper's simulation fields and the MonteCarlo, say); ``owner``, when given, is held by the entries and
    must be the very object again for a hit (a key built from ``id(owner)`` then cannot match an object that reuses
    the id).  The limits are fixed at construction.  Safe to share between threads (the simulator itself runs
    outside the lock).  Pickled (a wrapped simulator sent to a worker process), it arrives empty: batches are never
    shipped between processes."""

    def __init__(self, max_batches: int, max_bytes: int):
        self._max_batches = check_positive_int(max_batches, "max_batches")
        self._max_bytes = check_positive_int(max_bytes, "max_bytes", minimum=0)
        self._entries: OrderedDict = OrderedDict()      # (key, kernel, runs) -> (owner, read-only batch, bytes)
        self._lock = threading.Lock()

    def __reduce__(self):
        return BatchMemo, (self._max_batches, self._max_bytes)

    @property
    def max_batches(self) -> int:
        """The most batches kept."""
        return self._max_batches

    @property
    def max_bytes(self) -> int:
        """The most bytes of array data kept."""
        return self._max_bytes

    def __len__(self) -> int:
        return len(self._entries)

    def __iter__(self):
        """The entries' ``(key, kernel, runs)``, the least recently used first."""
        with self._lock:
            return iter(list(self._entries))

    def clear(self) -> None:
        """Forget every batch."""
        with self._lock:
            self._entries.clear()

    def wrap(self, simulate_runs: Callable, key: Hashable, owner: Any = None) -> Callable:
        """``runs -> batch``: ``simulate_runs(runs)`` remembered under ``(key, kernel, run indices)``.  Runs that are
        not a range, list, tuple or 1-D integer array of indices go to the simulator unremembered (its own error, if
        any).  ValueError naming ``simulate_runs`` (not callable) or ``key`` (not hashable)."""
        if not callable(simulate_runs):
            raise ValueError(f"simulate_runs: expected a function runs -> batch, got {type(simulate_runs).__name__}")
        try:
            hash(key)
        except TypeError:
            raise ValueError(f"key: expected a hashable key, got {type(key).__name__}") from None

        def memoised(runs):
            rk = runs_key(runs)
            if rk is None:
                return simulate_runs(runs)
            return self._get((key, kernel(), rk), owner, lambda: simulate_runs(runs))

        return memoised

    def _get(self, full_key: tuple, owner, simulate: Callable):
        entries = self._entries
        with self._lock:
            hit = entries.get(full_key)
            if hit is not None and hit[0] is owner:
                entries.move_to_end(full_key)
                return _handed_out(hit[1])
        batch, size = _read_only(simulate())
        if size <= self._max_bytes:
            with self._lock:
                entries.pop(full_key, None)              # a stale entry (another owner) leaves its place too
                entries[full_key] = (owner, batch, size)
                while entries and (len(entries) > self._max_batches
                                   or sum(e[2] for e in entries.values()) > self._max_bytes):
                    entries.popitem(last=False)
        return _handed_out(batch)
