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

import sys
import time
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from ._validate import check_positive_int


class Stream(IntEnum):
    TRUTH = 0
    MEASUREMENT = 1
    INITIAL = 2
    FILTER = 3
    FAULT = 4


@dataclass(frozen=True)
class MonteCarlo:
    root_seed: int
    n_runs: int

    def __post_init__(self):
        check_positive_int(self.root_seed, "root_seed", minimum=0)
        check_positive_int(self.n_runs, "n_runs")

    def generator(self, run: int, stream: Stream) -> np.random.Generator:
        if not 0 <= run < self.n_runs:
            raise ValueError(f"run: index {run} outside 0..{self.n_runs - 1}")
        return np.random.default_rng(np.random.SeedSequence(self.root_seed, spawn_key=(int(run), int(stream))))

    def standard_normal(self, runs, stream: Stream, shape) -> np.ndarray:
        """Per-run standard normals stacked to ``(len(runs), *shape)``."""
        shape = tuple(shape)
        return np.stack([self.generator(r, stream).standard_normal(shape) for r in runs]) \
            if len(runs) else np.zeros((0,) + shape)

    def chunks(self, chunk_size: int | None = None):
        """Consecutive run-index ranges covering all runs."""
        size = self.n_runs if chunk_size is None else check_positive_int(chunk_size, "chunk_size")
        return [range(a, min(a + size, self.n_runs)) for a in range(0, self.n_runs, size)]


class Progress:
    """Minimal progress reporting to stderr for long Monte Carlo jobs."""

    def __init__(self, label: str, total: int, stream=None, enabled: bool = True):
        self.label, self.total, self.done = label, total, 0
        self.stream = sys.stderr if stream is None else stream
        self.enabled = enabled
        self.t0 = time.perf_counter()

    def advance(self, n: int):
        self.done += n
        if self.enabled:
            dt = time.perf_counter() - self.t0
            print(f"  [{self.label}] {self.done}/{self.total} runs ({dt:.1f} s)", file=self.stream, flush=True)
