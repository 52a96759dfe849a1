"""Deterministic Monte Carlo: one root seed per paper, one stream per run.

Run ``r`` of a paper with root seed ``s`` draws its random numbers for purpose
``p`` (truth, measurement noise, filter initialisation, filter-internal
randomness such as bootstrapping) from
``numpy.random.SeedSequence(s, spawn_key=(r, p))`` -- the same sequence
``SeedSequence(s).spawn(...)`` would give, but addressable directly.  Hence a
run's numbers do not depend on how many runs are made, in which order, or in
which chunks: a smoke run of N runs is an exact prefix of the full run, and
every filter compared on run ``r`` sees the same truth and the same
measurements (common random numbers, which is what makes paired comparisons
between filters sharp).
"""
from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass
from enum import IntEnum
from typing import Sequence

import numpy as np
from numpy.typing import ArrayLike

from mmlib.core._validate import check_bool, check_index, check_positive_int

__all__ = [
    "MonteCarlo", "Stream", "Progress", "check_stream", "say_progress", "PROGRESS_LOG_ENV"
]


class Stream(IntEnum):
    """The purpose ``p`` of a run's random stream (the second element of its spawn key): TRUTH (process noise of
    the simulated truth), MEASUREMENT (measurement noise), INITIAL (sampled initial estimates), FILTER
    (filter-internal randomness, e.g. bootstrapping) and FAULT (sensor-fault draws)."""

    TRUTH = 0
    MEASUREMENT = 1
    INITIAL = 2
    FILTER = 3
    FAULT = 4


def check_stream(value: int | np.integer, name: str = "stream") -> Stream:
    """A :class:`Stream` member, or an integer (Python or numpy) equal to one's value; booleans, floats
    and other values are rejected."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) \
            or int(value) not in Stream._value2member_map_:
        raise ValueError(f"{name}: expected a Stream ({', '.join(f'{m.name}={m.value}' for m in Stream)}), "
                         f"got {value!r}")
    return Stream(int(value))


@dataclass(frozen=True)
class MonteCarlo:
    """``n_runs`` runs (integer >= 1) of the root seed ``root_seed`` (integer >= 0); numpy integers are
    accepted and stored as Python ints, booleans and floats rejected."""

    root_seed: int
    n_runs: int

    def __post_init__(self):
        object.__setattr__(self, "root_seed", check_positive_int(self.root_seed, "root_seed", minimum=0))
        object.__setattr__(self, "n_runs", check_positive_int(self.n_runs, "n_runs"))

    def generator(self, run: int, stream: Stream) -> np.random.Generator:
        """The generator of run ``run`` (integer index 0..n_runs-1) for purpose ``stream``."""
        run = check_index(run, "run", self.n_runs)
        stream = check_stream(stream)
        return np.random.default_rng(np.random.SeedSequence(self.root_seed, spawn_key=(run, int(stream))))

    def check_runs(self, runs: Sequence[int] | np.ndarray, name: str = "runs") -> list:
        """``runs`` (a range, or a sequence or 1-D integer array of run indices 0..n_runs-1) as a list of ints."""
        if isinstance(runs, (str, bytes)) or not hasattr(runs, "__len__"):
            raise ValueError(f"{name}: expected a range or sequence of run indices, got {type(runs).__name__}")
        if isinstance(runs, np.ndarray) and runs.ndim != 1:
            raise ValueError(f"{name}: expected a 1-D sequence of run indices, got shape {runs.shape}")
        return [check_index(r, name, self.n_runs) for r in runs]

    def standard_normal(self, runs: Sequence[int] | np.ndarray, stream: Stream, shape: Sequence[int]) -> np.ndarray:
        """Per-run standard normals stacked to ``(len(runs), *shape)``: row i from run ``runs[i]``'s
        generator for ``stream``; ``shape`` a sequence of integers >= 0."""
        runs = self.check_runs(runs)
        stream = check_stream(stream)
        if isinstance(shape, (str, bytes)) or not hasattr(shape, "__iter__"):
            raise ValueError(f"shape: expected a sequence of integers >= 0, got {shape!r}")
        shape = tuple(check_positive_int(d, "shape", minimum=0) for d in shape)
        return np.stack([self.generator(r, stream).standard_normal(shape) for r in runs]) \
            if len(runs) else np.zeros((0,) + shape)

    def gaussian(self, runs: Sequence[int] | np.ndarray, stream: Stream, mean: ArrayLike,
                 cov: ArrayLike) -> np.ndarray:
        r"""Per-run draws from :math:`N(\text{mean}, \text{cov})`, shape ``(len(runs), n)``:
        :math:`\text{mean} + L w` with :math:`LL^T = \text{cov}` (Cholesky) and ``w`` the run's standard normals
        of ``stream`` (e.g. a sampled initial estimate, :attr:`Stream.INITIAL`).  ``mean`` (n,) or
        (len(runs), n); the product is the same for a run in any batch, one run included."""
        from mmlib.core._validate import as_float_array, check_covariance, check_finite
        from mmlib.core.linalg import matmul_rows
        runs = self.check_runs(runs)
        cov = check_covariance(cov, "cov")
        mean = check_finite(as_float_array(mean, "mean"), "mean")
        n = cov.shape[0]
        if mean.shape not in ((n,), (len(runs), n)):
            raise ValueError(f"mean: expected shape ({n},) or ({len(runs)}, {n}) for cov's {n} states and "
                             f"{len(runs)} runs, got {mean.shape}")
        w = self.standard_normal(runs, stream, (cov.shape[0],))
        return mean + matmul_rows(w, np.linalg.cholesky(cov).T)

    def bootstrap_noise(self, runs: Sequence[int] | np.ndarray, n_steps: int, n_boot: int, m: int) -> np.ndarray:
        """The standard normals, shape ``(len(runs), n_steps, n_boot, m)``, that an observation-bootstrap layer
        (:class:`mmlib.core.layers.bootstrap.ObservationBootstrap`, Hu et al. 2017) adds to each step's
        ``m``-dimensional measurement, from the run's :attr:`Stream.FILTER`; drawn for ``max(n_boot, 1)``
        observations, so that a run's draws do not depend on ``n_boot`` being 0."""
        n_steps = check_positive_int(n_steps, "n_steps")
        n_boot = check_positive_int(n_boot, "n_boot", minimum=0)
        m = check_positive_int(m, "m")
        return self.standard_normal(runs, Stream.FILTER, (n_steps, max(n_boot, 1), m))[:, :, :n_boot]

    def chunks(self, chunk_size: int | None = None) -> list[range]:
        """Consecutive run-index ranges covering all runs, ``chunk_size`` (integer >= 1, None: all) runs each."""
        size = self.n_runs if chunk_size is None else check_positive_int(chunk_size, "chunk_size")
        return [range(a, min(a + size, self.n_runs)) for a in range(0, self.n_runs, size)]


#: Environment variable naming a file that receives the progress lines instead of stderr.  The notebook runner
#: sets it for every kernel it starts, so that progress goes to the runner's log and never into an executed
#: notebook's outputs (where it would be published as stderr blocks).
PROGRESS_LOG_ENV = "MMLIB_PROGRESS_LOG"


def say_progress(line: str) -> None:
    """Write one progress line: appended to the file ``$MMLIB_PROGRESS_LOG`` names when it is set (opened and
    closed per line, so that several processes may append), else to stderr.  Every progress line of mmlib (Monte
    Carlo chunks, grid jobs, arena cells) goes through here."""
    if not isinstance(line, str):
        raise ValueError(f"line: expected a string, got {line!r}")
    path = os.environ.get(PROGRESS_LOG_ENV)
    if path:
        with open(path, "a", encoding="utf-8") as log:
            log.write(line.rstrip("\n") + "\n")
    else:
        print(line, file=sys.stderr, flush=True)


class Progress:
    """Progress reporting for long Monte Carlo jobs: one line per :meth:`advance` through :func:`say_progress`
    (or to ``stream`` when one is given); ``enabled=False`` is silent."""

    def __init__(self, label: str, total: int, stream=None, enabled: bool = True):
        if not isinstance(label, str):
            raise ValueError(f"label: expected a string, got {label!r}")
        check_positive_int(total, "total", minimum=0)
        if stream is not None and not callable(getattr(stream, "write", None)):
            raise ValueError(f"stream: expected None or a text stream (with write), got {type(stream).__name__}")
        self.label, self.total, self.done = label, total, 0
        self.stream = stream
        self.enabled = check_bool(enabled, "enabled")
        self.t0 = time.perf_counter()

    def advance(self, n: int) -> None:
        """Count ``n`` more finished runs and, if enabled, report the total and the elapsed wall time (s)."""
        check_positive_int(n, "n", minimum=0)
        self.done += n
        if self.enabled:
            dt = time.perf_counter() - self.t0
            line = f"  [{self.label}] {self.done}/{self.total} runs ({dt:.1f} s)"
            if self.stream is None:
                say_progress(line)
            else:
                print(line, file=self.stream, flush=True)
