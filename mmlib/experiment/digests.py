"""Run digests: proof that committed results come from the committed code, on any machine.

:func:`run_digest` fingerprints the per-run numbers of the first runs of an evaluation (the same runs in
every profile: the streams are per run) and records the machine that computed them
(:func:`mmlib.experiment.machine.fingerprint`).  :func:`compare_digests` compares a recomputed digest with a
committed one by the rule the results must meet:

* **same machine fingerprint and kernel: bit for bit.**  The SHA-256 of every per-run number must be
  equal (the filters give a run the same bits in any batch, chunking or worker count:
  tests/test_batch_independence.py).
* **another fingerprint (CPU, OpenBLAS core, numpy SIMD level, numba target, library versions): to
  round-off.**  Every run must diverge at the same step for the same cause, and every run's RMSE may
  differ by at most ``RTOL_MACHINE * S``, S the algorithm's state scale (``scale``).  Where the bound comes
  from: the code that differs between CPUs (numpy's SIMD ``exp``/``log``, a few units in the last place
  apart; OpenBLAS's summation order) perturbs each step by a few u = 2**-53 = 1.1e-16 of S; the a-priori
  worst case of tests/test_kernels.py (eps K cond(P) abs(log L), up to 1e-6 of S with cond(P) ~ 1e5) covers
  any reordering but would let a real change of 1e-6 S pass.  The CPU-dependent code is not such a
  reordering of whole computations, and the measured differences (``make bench``:
  ``data/bench/cross_cpu.json``, each paper's headline under emulated AVX2 and SSE4.2 CPUs) lie more than
  two orders of magnitude below 1e-9 S, which tests/test_digests.py checks against that file.
  ``RTOL_MACHINE = 1e-9`` is therefore an empirical margin between the two, re-checked under both
  emulations by every ``make test``.  An RMSE is 1-Lipschitz in the
  error vector (triangle inequality), so it inherits the estimates' bound.
* **another kernel** (``MMLIB_KERNEL``: compiled vs numpy): to ``RTOL_KERNEL * S`` per run with the same
  divergences; the compiled and numpy paths reorder whole computations (tests/test_kernels.py, where
  ``RTOL_RUN`` derives 1e-6 from eps K cond(P) abs(log L)).

A swap of the random streams of two runs, or a change that moves some run's RMSE by more than the bound, fails on
every machine.  Across machines only the per-run RMSE and divergences are compared: mode probabilities and
diagnostics are compared (in the SHA-256) on one machine only.
"""
from __future__ import annotations

import hashlib
import math
from typing import Mapping, NamedTuple

import numpy as np

from mmlib.core._validate import check_positive_int
from mmlib.core.linalg import kernel
from mmlib.experiment.evaluation import RunSet, _flat_runsets
from mmlib.experiment.machine import differences, fingerprint

__all__ = [
    "run_digest", "compare_digests", "DigestComparison", "same_numbers", "DIGEST_VERSION", "RTOL_MACHINE", "RTOL_KERNEL"
]

#: Tag hashed first by :func:`run_digest`; change it whenever what is hashed changes.
DIGEST_VERSION = "mmlib-run-digest-2"

#: per-run RMSE tolerance, in units of the state scale S, between machines of different fingerprints (module
#: docstring: above the differences measured across emulated CPUs by 100 at least, 1000 below the worst case)
RTOL_MACHINE = 1e-9
#: the same between the compiled and numpy kernels (tests/test_kernels.py, RTOL_RUN)
RTOL_KERNEL = 1e-6


def _scale(example_mean) -> float:
    """Largest finite absolute value of an estimate track (1.0 when none is finite)."""
    a = np.abs(np.asarray(example_mean, dtype=np.float64))
    a = a[np.isfinite(a)]
    return float(a.max()) if a.size and a.max() > 0 else 1.0


def run_digest(results: Mapping[str, RunSet | Mapping], n_runs: int) -> dict:
    r"""Fingerprint of the per-run numbers of the first ``n_runs`` runs of an evaluation, for proving that
    committed results come from the committed code (``tests/tolerance/test_results.py``).

    ``results``: ``{name: RunSet}`` as :func:`mmlib.experiment.evaluation.evaluate` returns, or a dict of such dicts
    (e.g. per case; names flattened to ``"case / name"``); ``n_runs``: integer from 1 to the runs of every RunSet.
    Per run the streams are fixed (:mod:`mmlib.experiment.montecarlo`) and the filters give a run the same bits in
    any batch, one run included (tests/test_batch_independence.py), so the digest of the first n runs is the same for
    an evaluation of n runs and of any N > n runs, whatever the chunking.

    ``sha256`` is the SHA-256 of, for each name in sorted order: the name, then for ``errors`` (N, K, n),
    ``diverged_step`` (N,), ``divergence_cause`` (N,), ``mode_probabilities`` (N, K, r) and ``diagnostics``
    (N, K, d) (the last three when present) restricted to the first n runs, the field name, the shape and the float64
    bytes (C order, every NaN written as the one canonical NaN: NaN sign and payload bits are not results).
    Beside it, for a readable mismatch message, per name: ``mean_squared_error`` (mean over the valid
    runs among the first n, the K steps and the n components of the squared error, in the squared unit
    of the state; None if no run is valid) and ``diverged`` (runs among the first n that diverged); ``kernel``:
    the implementation that computed them (:func:`mmlib.core.linalg.kernel`: the compiled and numpy paths agree to
    round-off, not bit for bit, so digests compare only within one kernel).  For comparison on another machine
    (:func:`compare_digests`): ``machine``, the fingerprint of the machine that computed them
    (:func:`mmlib.experiment.machine.fingerprint`), and ``runs``, per name the per-run numbers of the first n runs:
    ``rmse`` (root mean square over the run's finite errors, in the unit of the state; None if none is finite),
    ``diverged_step`` and ``divergence_cause`` (integers; -1 and 0 for a run that did not diverge), and ``scale``, the
    largest finite absolute estimate of the name's first run (``example_mean``; the state's scale S, in its unit)."""
    flat = _flat_runsets(results, "results")
    n_runs = check_positive_int(n_runs, "n_runs")
    h = hashlib.sha256(DIGEST_VERSION.encode())
    mse, diverged, per_run = {}, {}, {}
    for name in sorted(flat):
        rs = flat[name]
        if rs.errors.shape[0] < n_runs:
            raise ValueError(f"n_runs: {n_runs} runs asked, but {name!r} has only {rs.errors.shape[0]}")
        h.update(b"\0name\0" + name.encode())
        for field in ("errors", "diverged_step", "divergence_cause", "mode_probabilities", "diagnostics"):
            value = getattr(rs, field)
            if value is None:
                continue
            arr = np.ascontiguousarray(np.asarray(value)[:n_runs], dtype=np.float64)
            arr = np.where(np.isnan(arr), np.nan, arr)
            h.update(f"\0{field}{arr.shape}\0".encode())
            h.update(arr.tobytes())
        ok = rs.valid[:n_runs]
        diverged[name] = int((~ok).sum())
        m = float(np.mean(rs.errors[:n_runs][ok] ** 2)) if ok.any() else None
        mse[name] = m if m is not None and np.isfinite(m) else None
        sq = np.asarray(rs.errors[:n_runs], dtype=np.float64).reshape(n_runs, -1) ** 2
        finite = np.isfinite(sq)
        count = finite.sum(axis=1)
        rms = np.sqrt(np.where(finite, sq, 0.0).sum(axis=1) / np.maximum(count, 1))
        cause = (np.zeros(n_runs, dtype=np.int64) if rs.divergence_cause is None
                 else np.asarray(rs.divergence_cause)[:n_runs].astype(np.int64))
        per_run[name] = {"rmse": [float(v) if c else None for v, c in zip(rms, count)],
                         "diverged_step": [int(v) for v in np.asarray(rs.diverged_step)[:n_runs]],
                         "divergence_cause": [int(v) for v in cause], "scale": _scale(rs.example_mean)}
    return {"version": DIGEST_VERSION, "n_runs": n_runs, "algorithms": sorted(flat), "sha256": h.hexdigest(),
            "mean_squared_error": mse, "diverged": diverged, "kernel": kernel(), "machine": fingerprint(),
            "runs": per_run}


class DigestComparison(NamedTuple):
    """The outcome of :func:`compare_digests`.

    ``rule``: ``"bit for bit"`` (same machine fingerprint and kernel), ``"round-off across machines"`` or
    ``"round-off across kernels"``; ``ok``: whether the recomputed digest meets it; ``problems``: what
    differs, one line each; ``machine_differences``: the fingerprint fields that differ (``"field: ours vs
    committed"``); ``largest``: the largest per-run RMSE difference over the tolerance (``abs(d rmse) / (rtol S)``,
    so at most 1 when ``ok``; 0 under the bit-for-bit rule)."""

    rule: str
    ok: bool
    problems: tuple
    machine_differences: tuple
    largest: float

    def message(self, ours: str = "recomputed", committed: str = "committed") -> str:
        """A readable account: the rule applied and why, then what differs."""
        if self.rule != "bit for bit":
            why = "the machines differ in " + "; ".join(self.machine_differences)
        elif self.machine_differences:
            why = "; ".join(self.machine_differences)
        else:
            why = "the machine fingerprints and kernels are equal"
        head = f"compared {self.rule} ({why}): " + ("agree" if self.ok else "DIFFER")
        if self.rule != "bit for bit":
            head += f"; largest per-run RMSE difference {self.largest:.3g} of the tolerance"
        return "\n".join([head] + [f"  {p}" for p in self.problems[:20]]
                         + ([f"  ... and {len(self.problems) - 20} more"] if len(self.problems) > 20 else []))


def compare_digests(ours: Mapping, committed: Mapping) -> DigestComparison:
    """Compare a recomputed digest (:func:`run_digest`) with a committed one by the rule of the module docstring:
    bit for bit when the machine fingerprints (``machine``, with ``kernel``) are equal, else every run's
    divergence step and cause equal and its RMSE within ``RTOL_MACHINE * S`` (``RTOL_KERNEL * S`` when the kernels
    differ).  The digest version, run count and algorithm names must be equal in every case.  A committed digest
    without ``machine`` (written before fingerprints were recorded) can only be compared bit for bit."""
    for name, d in (("ours", ours), ("committed", committed)):
        if not isinstance(d, Mapping):
            raise ValueError(f"{name}: expected a run digest (run_digest), got {type(d).__name__}")
        missing = [k for k in ("version", "n_runs", "algorithms", "sha256", "kernel") if k not in d]
        if missing:
            raise ValueError(f"{name}: not a run digest: {', '.join(missing)} missing")
        if "machine" in d and not isinstance(d["machine"], Mapping):
            raise ValueError(f"{name}: 'machine' must be a fingerprint dict, got {d['machine']!r}")
        runs = d.get("runs")
        if runs is not None:
            if not isinstance(runs, Mapping) or set(runs) != set(d["algorithms"]):
                raise ValueError(f"{name}: 'runs' must hold the per-run numbers of exactly the algorithms "
                                 f"{d['algorithms']}")
            for alg, r in runs.items():
                if not isinstance(r, Mapping) or any(
                        not isinstance(r.get(k), list) or len(r[k]) != d["n_runs"]
                        for k in ("rmse", "diverged_step", "divergence_cause")):
                    raise ValueError(f"{name}: runs[{alg!r}] must hold rmse, diverged_step and divergence_cause "
                                     f"for each of the {d['n_runs']} runs")
                scale = r.get("scale")
                if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not scale > 0 \
                        or not math.isfinite(scale):
                    raise ValueError(f"{name}: runs[{alg!r}]['scale'] must be a positive number, got {scale!r}")
    m_ours = {**ours.get("machine", {}), "kernel": ours.get("kernel")}
    m_comm = {**committed.get("machine", {}), "kernel": committed.get("kernel")} if "machine" in committed else None
    diff = tuple(differences(m_ours, m_comm)) if m_comm is not None else (
        "the committed digest records no machine fingerprint",)
    problems = [f"{k}: {ours[k]!r} vs {committed[k]!r}" for k in ("version", "n_runs", "algorithms")
                if ours[k] != committed[k]]
    if m_comm is None or not diff or "runs" not in ours or "runs" not in committed:
        if ours["sha256"] != committed["sha256"]:
            problems.append(f"sha256 of the per-run numbers: {ours['sha256']} vs {committed['sha256']}")
        elif "runs" in ours and "runs" in committed and ours["runs"] != committed["runs"]:
            problems.append("the per-run numbers recorded beside the SHA-256 differ (the committed ones were edited)")
        return DigestComparison("bit for bit", not problems, tuple(problems), diff, 0.0)
    kernels = ours.get("kernel") != committed.get("kernel")
    rtol = RTOL_KERNEL if kernels else RTOL_MACHINE
    largest = 0.0
    for alg in sorted(set(ours["runs"]) & set(committed["runs"])):
        a, b = ours["runs"][alg], committed["runs"][alg]
        for field in ("diverged_step", "divergence_cause"):
            bad = [i for i, (x, y) in enumerate(zip(a[field], b[field])) if x != y]
            if bad or len(a[field]) != len(b[field]):
                problems.append(f"{alg}: {field} differs in runs {bad[:10]} ({[a[field][i] for i in bad[:10]]} vs "
                                f"{[b[field][i] for i in bad[:10]]})")
        tol = rtol * float(b.get("scale", 1.0))
        for i, (x, y) in enumerate(zip(a["rmse"], b["rmse"])):
            if (x is None) != (y is None):
                problems.append(f"{alg}: run {i} RMSE {x} vs {y}")
            elif x is not None:
                ratio = 0.0 if x == y else abs(x - y) / tol
                ratio = math.inf if math.isnan(ratio) else ratio
                largest = max(largest, ratio)
                if ratio > 1.0:
                    problems.append(f"{alg}: run {i} RMSE {x!r} vs {y!r}: difference {abs(x - y):.3g} > "
                                    f"{rtol:g} x scale {b.get('scale')} = {tol:.3g}")
    rule = "round-off across kernels" if kernels else "round-off across machines"
    return DigestComparison(rule, not problems, tuple(problems), diff, largest)


def _numbers(doc) -> list:
    if isinstance(doc, bool) or doc is None or isinstance(doc, str):
        return []
    if isinstance(doc, (int, float)):
        return [abs(float(doc))] if math.isfinite(doc) else []
    items = doc.values() if isinstance(doc, Mapping) else doc if isinstance(doc, (list, tuple)) else []
    return [x for v in items for x in _numbers(v)]


def _close(a, b, rtol: float, atol: float) -> bool:
    if isinstance(a, Mapping) and isinstance(b, Mapping):
        return a.keys() == b.keys() and all(_close(a[k], b[k], rtol, atol) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_close(x, y, rtol, atol) for x, y in zip(a, b))
    if isinstance(a, float) or isinstance(b, float):
        if isinstance(a, bool) or isinstance(b, bool) or not isinstance(a, (int, float)) \
                or not isinstance(b, (int, float)):
            return False
        return a == b or abs(a - b) <= rtol * max(abs(a), abs(b)) + atol
    return a == b


def same_numbers(universe: Mapping, local: Mapping) -> bool:
    """Whether a universe result (a :class:`~mmlib.experiment.universe.UniverseResult` or its JSON, from
    :func:`mmlib.experiment.grid.run_grid`) equals one computed in this process.

    Bit for bit (``==``) when the universe was computed on a machine of this process's fingerprint: it then has
    no ``"machine"`` entry.  A universe computed on another machine (a Dask worker of another CPU) carries that
    machine's fingerprint under ``"machine"`` and is compared, without that entry, to round-off: every string,
    integer and flag equal, every float within ``RTOL_KERNEL`` of the larger magnitude or ``RTOL_MACHINE`` of the
    document's largest number (differences of near-equal numbers are pure round-off)."""
    # a UniverseResult (mmlib.experiment.universe) is compared in its JSON form
    universe, local = (x.as_json() if hasattr(x, "as_json") else x for x in (universe, local))
    for value, name in ((universe, "universe"), (local, "local")):
        if not isinstance(value, Mapping):
            raise ValueError(f"{name}: expected a result dict, got {type(value).__name__}")
    if "machine" not in universe:
        return dict(universe) == dict(local)
    doc = {k: v for k, v in universe.items() if k != "machine"}
    scale = max(_numbers(local), default=0.0)
    return _close(doc, dict(local), RTOL_KERNEL, RTOL_MACHINE * scale)
