"""Run-count stability: do a paper's claim verdicts change between the universe run count and the headline's?

The universes of a paper's multiverse run ``n_runs`` Monte Carlo runs each (the profile's ``mv_runs``); its headline
runs the notebook's ``n_runs`` (the paper's own count where it states one).  A verdict that holds at one count and
not at the other is decided by the noise of the count, not by the reading.  :func:`run_count_stability` reruns the
headline universe and a deterministic sample of ``size`` universes of the multiverse at the headline count, through
:func:`mmlib.experiment.grid.run_grid` exactly as :func:`mmlib.experiment.multiverse.run_multiverse` runs them (same
job, root seed, algorithms, cache, executor and workers), and compares every claim's verdict category
(:func:`mmlib.experiment.verdicts.claim_category`) between the two counts.

Both counts run on the same root seed, so the runs are nested: run ``r`` of a universe is the same simulation at
either count (the per-run streams of :mod:`mmlib.experiment.montecarlo`), and the larger count only adds runs.  A
changed verdict therefore says that the runs added (or removed) moved a claim across a boundary of the verdict rule.

The sample is drawn from the universes the multiverse counts in its shares
(:meth:`~mmlib.experiment.multiverse.Multiverse.counted`) other than the headline, which leave out the degenerate
universes (:attr:`~mmlib.experiment.universe.UniverseResult.degenerate`) and those with an option motivated by the
results or another paper (:meth:`~mmlib.experiment.readings.ReadingSpace.motivated`): ``k = min(size, pool)`` indices
drawn uniformly without replacement by ``numpy.random.default_rng(draw_seed)``, with ``draw_seed = sample_seed(paper)
+ 1`` (:func:`mmlib.experiment.readings.sample_seed`, one past the seed of the multiverse's own sample, so the two
draws are independent), sorted.  The result records the draw.
"""
from __future__ import annotations

from typing import Any, Callable, Iterable

import numpy as np

from mmlib.core._validate import check_names, check_positive_int
from mmlib.experiment.executors import worker_count
from mmlib.experiment.grid import run_grid
from mmlib.experiment.multiverse import Multiverse
from mmlib.experiment.readings import sample_seed
from mmlib.experiment.universe import UniverseResult
from mmlib.experiment.verdicts import CLAIM_VERDICTS, claim_category

__all__ = ["run_count_stability", "draw_seed", "sample_pool", "GRID_OPTIONS"]

#: the options of :func:`mmlib.experiment.grid.run_grid` that :func:`run_count_stability` passes on (where and how
#: the jobs run; never what they compute)
GRID_OPTIONS = ("executor", "cache_dir", "use_cache")


def draw_seed(paper: str) -> int:
    """The seed of the stability sample's draw: :func:`~mmlib.experiment.readings.sample_seed` of ``paper`` plus
    one (an integer in [1, 2**32])."""
    return sample_seed(paper) + 1


def sample_pool(mv: Multiverse) -> dict:
    """The universes the stability sample is drawn from: ``pool`` (indices into ``mv.universes``, ascending), the
    counted universes (:meth:`~mmlib.experiment.multiverse.Multiverse.counted`: the design's sample without the
    degenerate ones and those with a motivated option) without the headline (index 0); ``excluded_degenerate`` and
    ``excluded_motivated`` count the universes of the design's sample
    (:meth:`~mmlib.experiment.multiverse.Multiverse.drawn`) other than the headline left out as such."""
    if not isinstance(mv, Multiverse):
        raise ValueError(f"mv: expected a Multiverse (mmlib.experiment.multiverse.run_multiverse), got "
                         f"{type(mv).__name__}")
    drawn = [i for i in mv.drawn() if i != 0]
    degenerate, motivated = set(mv.degenerate_indices()), set(mv.motivated_indices()) - set(mv.degenerate_indices())
    counted = set(mv.counted())
    pool = [i for i in drawn if i in counted]
    n_degenerate = sum(i in degenerate for i in drawn)
    n_motivated = sum(i in motivated for i in drawn)
    return {"pool": pool, "excluded_degenerate": n_degenerate, "excluded_motivated": n_motivated}


def _categories(u: UniverseResult) -> dict:
    """{claim: verdict category (a plain string)} of one universe, in its order."""
    return {c.claim: str(claim_category(c.verdict)) for c in u.claims}


def _universes(n: int) -> str:
    return f"{n} universe" + ("" if n == 1 else "s")


def run_count_stability(mv: Multiverse, job: Callable, *, n_runs: int, seed: int, size: int,
                        algorithms: Iterable[str] = (), workers: int | None = None,
                        progress: bool | Callable = True, **grid_options: Any) -> dict:
    """Claim verdicts of the headline universe and ``size`` sampled universes at the multiverse's run count
    (``mv.n_runs``, the universes' results as run) and at ``n_runs`` (rerun), and which change.

    ``job``, ``seed`` and ``algorithms`` must be those the multiverse ran with (``job(reading, n_runs, seed) ->
    UniverseResult``, the Monte Carlo root seed, the algorithms of the cache key); ``workers``, ``progress`` and
    ``grid_options`` (:data:`GRID_OPTIONS`: ``executor``, ``cache_dir``, ``use_cache``) go to
    :func:`~mmlib.experiment.grid.run_grid`; the results do not depend on them.  ``size`` (integer >= 0) is the number
    of sampled universes besides the headline (fewer when the pool, :func:`sample_pool`, is smaller).

    Returns a JSON-able dict: ``n_runs_universe`` (``mv.n_runs``), ``n_runs_check`` (``n_runs``, the other
    count), ``rerun``
    (False when the two counts coincide: nothing is rerun and no verdict can change), ``low_runs`` and
    ``high_runs`` (the smaller and larger count), ``sample`` (the draw: ``size`` asked, ``n_sampled``, ``pool``
    size, ``draw_seed``, ``excluded_degenerate``, ``excluded_motivated``), ``universes`` (per universe checked,
    the headline first: ``universe`` (its index in ``mv``), ``reading``, ``headline``, ``degenerate`` (the
    reason, only when degenerate), ``verdicts`` ({claim: [category at ``low_runs``, at ``high_runs``]}, None where
    the universe has no such claim at that count) and ``changed`` (the claims whose category differs)),
    ``n_universes``, ``n_changed`` (universes with any change), ``claims_changed`` ({claim: number of universes in
    which it changed}, every claim), ``shares`` (per claim: ``dominant``, the most frequent category at the
    larger count (ties to the first of the claim vocabulary), ``low`` and ``high``, its share of the universes
    judging the claim at each count, ``n`` those universes, and ``counts_low`` / ``counts_high``, the counts of
    each category: exact over these universes, not an estimate of the reading space) and ``statement``, one
    sentence."""
    if not isinstance(mv, Multiverse):
        raise ValueError(f"mv: expected a Multiverse (mmlib.experiment.multiverse.run_multiverse), got "
                         f"{type(mv).__name__}")
    if not callable(job):
        raise ValueError(f"job: expected a callable job(reading, n_runs, seed), got {job!r}")
    n_runs = check_positive_int(n_runs, "n_runs")
    seed = check_positive_int(seed, "seed", minimum=0)
    size = check_positive_int(size, "size", minimum=0)
    algorithms = check_names(algorithms, "algorithms", nonempty=False)
    worker_count(workers)                     # a bad workers is an error even when nothing is rerun
    if not (isinstance(progress, bool) or callable(progress)):
        raise ValueError(f"progress: expected True, False or a callable receiving each line, got {progress!r}")
    unknown = sorted(set(grid_options) - set(GRID_OPTIONS))
    if unknown:
        raise ValueError(f"{unknown[0]}: not an option of the stability rerun (its grid options: {GRID_OPTIONS})")
    paper = mv.space.paper
    drawn = sample_pool(mv)
    pool = drawn["pool"]
    k = min(size, len(pool))
    dseed = draw_seed(paper)
    order = np.random.default_rng(dseed).permutation(len(pool))[:k]
    indices = [0] + sorted(pool[int(j)] for j in order)
    rerun = n_runs != mv.n_runs
    at_mv = [mv.universes[i] for i in indices]
    if rerun:
        at_n = run_grid(job, [mv.readings[i] for i in indices], paper=paper, algorithms=algorithms, n_runs=n_runs,
                        seed=seed, workers=workers, progress=progress, label=f"{paper} stability at {n_runs} runs",
                        result_type=UniverseResult, **grid_options)
    else:
        at_n = at_mv
    low_first = n_runs >= mv.n_runs              # the multiverse's universes ran the smaller count
    low_runs, high_runs = (mv.n_runs, n_runs) if low_first else (n_runs, mv.n_runs)
    claims: list = []
    entries = []
    for i, a, b in zip(indices, at_mv, at_n):
        lo, hi = (_categories(a), _categories(b)) if low_first else (_categories(b), _categories(a))
        names = list(lo) + [c for c in hi if c not in lo]
        claims += [c for c in names if c not in claims]
        entry = {"universe": i, "reading": dict(mv.readings[i]), "headline": i == 0,
                 "verdicts": {c: [lo.get(c), hi.get(c)] for c in names},
                 "changed": [c for c in names if lo.get(c) != hi.get(c)]}
        if mv.universes[i].degenerate:
            entry["degenerate"] = mv.universes[i].degenerate
        entries.append(entry)
    claims_changed = {c: sum(c in e["changed"] for e in entries) for c in claims}
    shares = {}
    for c in claims:
        low = [e["verdicts"][c][0] for e in entries if c in e["verdicts"] and e["verdicts"][c][0] is not None]
        high = [e["verdicts"][c][1] for e in entries if c in e["verdicts"] and e["verdicts"][c][1] is not None]
        counts_low = {str(v): low.count(v) for v in CLAIM_VERDICTS if v in low}
        counts_high = {str(v): high.count(v) for v in CLAIM_VERDICTS if v in high}
        ref = counts_high or counts_low
        dominant = max(ref, key=lambda v: (ref[v], -CLAIM_VERDICTS.index(v))) if ref else None
        shares[c] = {"dominant": dominant, "n": len(high) if counts_high else len(low),
                     "low": counts_low.get(dominant, 0) / len(low) if low else None,
                     "high": counts_high.get(dominant, 0) / len(high) if high else None,
                     "counts_low": counts_low, "counts_high": counts_high}
    n_changed = sum(bool(e["changed"]) for e in entries)
    where = "the headline universe" + (f" and {k} sampled universe{'' if k == 1 else 's'}" if k else "")
    if not rerun:
        statement = (f"The universe and headline run counts coincide ({n_runs} runs): nothing was rerun, so no "
                     f"verdict can change between them ({where}).")
    elif not n_changed:
        statement = f"No verdict changes between {low_runs} and {high_runs} runs in {where}."
    else:
        which = "; ".join(f"{c} ({_universes(m)})" for c, m in claims_changed.items() if m)
        statement = (f"{n_changed} of {len(entries)} universes (the headline and {_universes(k)} sampled) change a "
                     f"verdict between {low_runs} and {high_runs} runs: {which}.")
    return {"n_runs_universe": mv.n_runs, "n_runs_check": n_runs, "rerun": rerun, "low_runs": low_runs,
            "high_runs": high_runs,
            "sample": {"size": size, "n_sampled": k, "pool": len(pool), "draw_seed": dseed,
                       "excluded_degenerate": drawn["excluded_degenerate"],
                       "excluded_motivated": drawn["excluded_motivated"]},
            "universes": entries, "n_universes": len(entries), "n_changed": n_changed,
            "claims_changed": claims_changed, "shares": shares, "statement": statement}
