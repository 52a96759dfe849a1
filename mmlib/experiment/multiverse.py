"""A paper's multiverse: every universe of its reading space run, and what holds across them.

A paper module provides

* ``SPACE``: its :class:`~mmlib.experiment.readings.ReadingSpace`;
* ``PUBLISHED``: every published number a universe can be compared with, as
  :class:`PublishedNumber` s (table, item, algorithm, quantity, the printed text);
* a job ``universe(reading, n_runs, seed) -> UniverseResult`` (:mod:`mmlib.experiment.universe`):
  the universe's ``values`` (one per published number it replicates, same item, algorithm
  and quantity), its ``claims`` (verdicts in the claim vocabulary of :mod:`mmlib.experiment.report`),
  its ``effects`` (named paired differences with standard errors, for the specification
  curve) and its ``diverged`` run counts per algorithm.

:func:`run_multiverse` runs a design through :func:`~mmlib.experiment.grid.run_grid` and
returns a :class:`Multiverse`, whose :meth:`Multiverse.as_dict` is the ``multiverse``
object of ``data/results/<paper>.json``:

* ``factors``, ``design``, ``design_description``, ``n_universes``, ``n_runs``;
* ``universes``: [{``reading``, ``values``, ``claims``, ``effects``, ``diverged``}];
* ``claims_summary``: per claim, the headline verdict, the count of each verdict across the
  distinct simulations (universes that differ only in metric-only factors count once), and
  ``robust`` (one verdict in at least 90 % of them);
* ``numbers_summary``: per published number, the headline verdict, ``n_reproduced`` (universes
  whose value is *reproduced* under the one verdict rule) and ``closest``, the universe of
  smallest standardized distance, with its reading and verdict;
* ``table_match``: per published table, the universe minimising the sum over its cells of the
  squared standardized distances, that sum, and the headline's.

The closest universe and the best table match are forensic findings ("Table 1 is
consistent with reading X"), never the headline; only the declared discrete options take
part, so nothing continuous is fitted to a published number.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Iterable, Mapping


from mmlib.core._validate import check_names, check_positive_int
from mmlib.experiment import report
from mmlib.experiment.grid import run_grid
from mmlib.experiment.readings import Design, ReadingSpace
from mmlib.experiment.universe import Effect, PublishedNumber, UniverseResult, Value, finite_or_none, items


#: a claim is robust when one verdict holds in at least this fraction of the universes
ROBUST_FRACTION = 0.9


def _check_pub(pub) -> PublishedNumber:
    if not isinstance(pub, PublishedNumber):
        raise ValueError(f"pub: expected a PublishedNumber (an item of Multiverse.published), got {pub!r}")
    return pub


def _check_universe(universe) -> None:
    if not isinstance(universe, UniverseResult):
        raise ValueError(f"universe: expected a UniverseResult (an item of Multiverse.universes), got "
                         f"{type(universe).__name__}")


@dataclass
class Multiverse:
    """Universes of a design with their results (``universes[i]`` ran ``design.readings[i]``)."""

    space: ReadingSpace
    design: Design
    universes: list
    published: tuple
    n_runs: int
    n_runs_paper: int | None = None

    def __post_init__(self):
        if not isinstance(self.space, ReadingSpace):
            raise ValueError(f"space: expected a ReadingSpace, got {type(self.space).__name__}")
        if not isinstance(self.design, Design):
            raise ValueError(f"design: expected a Design (ReadingSpace.design), got {type(self.design).__name__}")
        if isinstance(self.universes, (str, bytes, Mapping)) or not hasattr(self.universes, "__len__"):
            raise ValueError(f"universes: expected a list of universe results, got {type(self.universes).__name__}")
        if len(self.universes) != len(self.design.readings):
            raise ValueError("universes: one result per reading of the design is needed")
        for i, u in enumerate(self.universes):
            if not isinstance(u, UniverseResult):
                raise ValueError(f"universes[{i}]: expected a UniverseResult (mmlib.experiment.universe), got "
                                 f"{type(u).__name__}")
        if self.design.readings[0] != self.space.headline:
            raise ValueError("design: the headline must be the first universe")
        _check_published(self.published)
        check_positive_int(self.n_runs, "n_runs")
        if self.n_runs_paper is not None:
            check_positive_int(self.n_runs_paper, "n_runs_paper")

    # -- lookups ----------------------------------------------------------------------------------------------
    @property
    def readings(self) -> tuple:
        """The design's readings (dicts factor id -> option), the headline first."""
        return self.design.readings

    @property
    def headline(self) -> UniverseResult:
        """The headline universe's result (``universes[0]``)."""
        return self.universes[0]

    def value(self, universe: UniverseResult, key: tuple) -> Value | None:
        """The universe's :class:`~mmlib.experiment.universe.Value` whose ``(item, algorithm, quantity)`` is ``key``
        (:attr:`PublishedNumber.key`), or None when the universe does not compute it."""
        _check_universe(universe)
        return universe.value(key)

    def effect(self, universe: UniverseResult, name: str) -> Effect:
        """The universe's :class:`~mmlib.experiment.universe.Effect` called ``name``; ValueError naming the known
        effects otherwise."""
        _check_universe(universe)
        return universe.effect(name)

    def number_verdict(self, pub: PublishedNumber, universe: dict) -> str:
        """The verdict rule on one universe's value; a value the universe computed but could not produce
        (``replicated`` None, e.g. every run diverged) is *not reproduced*; a number no universe
        computes is *not replicable*."""
        v = self.value(universe, _check_pub(pub).key)
        if v is None:
            return report.NOT_REPLICABLE
        if v.replicated is None:
            return f"{report.NOT_REPRODUCED}: {v.failed or 'no value (every run diverged)'}"
        return report.verdict(pub.printed, v.replicated, v.stderr, universe.n_runs, self.n_runs_paper)

    def conclusive(self, pub: PublishedNumber, universe: dict) -> bool:
        """False when the universe's value is too uncertain to judge (verdict *inconclusive*)."""
        return not self.number_verdict(pub, universe).startswith(report.INCONCLUSIVE)

    def distance(self, pub: PublishedNumber, universe: dict) -> float | None:
        """The standardized distance of the universe's value from the printed number
        (:func:`mmlib.experiment.report.standardized_distance`); None when the universe does not compute it,
        ``inf`` when it computed it but could not produce a value."""
        v = self.value(universe, _check_pub(pub).key)
        if v is None:
            return None
        if v.replicated is None:
            return math.inf                       # run but failed: matches no printed value
        return report.standardized_distance(pub.printed, v.replicated, v.stderr, universe.n_runs,
                                            self.n_runs_paper)

    # -- summaries --------------------------------------------------------------------------------------------
    def simulations(self) -> list:
        """The distinct simulations: lists of universe indices whose readings differ only in metric-only
        factors, in order of first appearance (the headline's first).  ValueError if the universes of one
        simulation disagree in a claim verdict, an effect or a divergence count (a metric-only factor must
        change none of them)."""
        groups: dict = {}
        for i, r in enumerate(self.readings):
            groups.setdefault(self.space.simulation_key(r), []).append(i)
        for idx in groups.values():
            first = self.universes[idx[0]]
            for i in idx[1:]:
                u = self.universes[i]
                if (u.claims, u.effects, dict(u.diverged)) != (first.claims, first.effects, dict(first.diverged)):
                    raise ValueError(f"universes {idx[0]} and {i} differ only in metric-only factors but not only in "
                                     f"their values: a metric-only factor changed a claim, an effect or a divergence")
        return list(groups.values())

    def claims_summary(self) -> list:
        """Per claim of the headline: the verdict counts over the distinct simulations (each once, whatever
        its number of metric-only readings; without metric-only factors, one per universe) and ``robust``
        when one verdict holds in at least ``ROBUST_FRACTION`` of them."""
        groups = self.simulations()
        out = []
        for c in self.headline.claims:
            verdicts = [u_c.verdict for idx in groups for u_c in self.universes[idx[0]].claims
                        if u_c.claim == c.claim]
            counts: dict = {}
            for v in verdicts:
                cat = report.claim_category(v)
                counts[cat] = counts.get(cat, 0) + 1
            top = max(counts.values())
            out.append({"claim": c.claim, "headline_verdict": c.verdict,
                        "verdict_counts": {k: counts[k] for k in report.CLAIM_VERDICTS if k in counts},
                        "n_simulations": len(verdicts), "n_universes": len(self.universes),
                        "robust": top >= ROBUST_FRACTION * len(verdicts)})
        return out

    def numbers_summary(self) -> list:
        """Per published number: its headline verdict and distance, the counts of universes that reproduce it
        (``n_reproduced``), reproduce it qualitatively and are inconclusive, and ``closest``, the universe of
        smallest absolute standardized distance among the judged ones (its reading, value, distance and verdict;
        None if none)."""
        out = []
        for pub in self.published:
            verdicts = [self.number_verdict(pub, u) for u in self.universes]
            dists = [self.distance(pub, u) for u in self.universes]
            # the closest universe among those whose value can be judged (an inconclusive value is close
            # only because it is noisy)
            finite = [(abs(d), i) for i, d in enumerate(dists)
                      if d is not None and math.isfinite(d) and not verdicts[i].startswith(report.INCONCLUSIVE)]
            closest = None
            if finite:
                _, i = min(finite)
                v = self.value(self.universes[i], pub.key)
                closest = {"universe": i, "reading": dict(self.readings[i]),
                           "describe": self.space.describe(self.readings[i]), "replicated": v.replicated,
                           "stderr": v.stderr, "distance": finite_or_none(dists[i]), "verdict": verdicts[i]}
            out.append({"table": pub.table, "item": pub.item, "algorithm": pub.algorithm, "quantity": pub.quantity,
                        "paper": pub.printed, "headline_verdict": verdicts[0],
                        "headline_distance": finite_or_none(dists[0]),
                        "n_reproduced": sum(v == report.REPRODUCED for v in verdicts),
                        "n_qualitative": sum(v == report.QUALITATIVE for v in verdicts),
                        "n_inconclusive": sum(v.startswith(report.INCONCLUSIVE) for v in verdicts),
                        "n_universes": len(verdicts), "closest": closest})
        return out

    def table_distances(self, table: str) -> list:
        """Sum over the table's replicated cells of squared standardized distances, per universe; ``table`` one of
        :attr:`tables`."""
        if table not in self.tables:
            raise ValueError(f"table: unknown table {table!r}; published: {self.tables}")
        pubs = [p for p in self.published if p.table == table]
        out = []
        for u in self.universes:
            ds = [self.distance(p, u) for p in pubs]
            ds = [d for d in ds if d is not None]
            out.append(sum(d * d for d in ds) if ds else None)
        return out

    @property
    def tables(self) -> list:
        """The published tables' names, in order of first appearance in ``published``."""
        seen = []
        for p in self.published:
            if p.table not in seen:
                seen.append(p.table)
        return seen

    def table_match(self) -> list:
        """Per table: the best match (smallest sum of squared standardized distances, among the universes
        none of whose cells in the table is inconclusive -- a noisy universe is close only because it is
        noisy), the headline's sum, and the most cells any universe reproduces."""
        out = []
        for table in self.tables:
            pubs = [p for p in self.published if p.table == table]
            sums = self.table_distances(table)
            judged = [all(self.conclusive(p, u) for p in pubs) for u in self.universes]
            finite = [(s, i) for i, s in enumerate(sums) if s is not None and math.isfinite(s) and judged[i]]
            if not any(s is not None for s in sums):
                continue
            n_rep = [sum(self.number_verdict(p, u) == report.REPRODUCED for p in pubs) for u in self.universes]
            most = max(range(len(n_rep)), key=lambda i: (n_rep[i], -i))
            entry = {"table": table, "n_cells": sum(1 for p in pubs if self.distance(p, self.headline) is not None),
                     "headline_sum": finite_or_none(sums[0]), "headline_n_reproduced": n_rep[0],
                     "n_excluded_inconclusive": sum(not j for j in judged),
                     "most_n_reproduced": n_rep[most], "most_universe": most,
                     "most_reading": dict(self.readings[most]),
                     "most_describe": self.space.describe(self.readings[most]),
                     "best_universe": None, "best_reading": None, "best_describe": "no universe can be judged",
                     "best_sum": None, "best_n_reproduced": 0}
            if finite:
                best, i = min(finite)
                entry.update({"best_universe": i, "best_reading": dict(self.readings[i]),
                              "best_describe": self.space.describe(self.readings[i]), "best_sum": finite_or_none(best),
                              "best_n_reproduced": n_rep[i]})
            out.append(entry)
        return out

    def one_factor_view(self) -> list:
        """The universes that differ from the headline in at most one factor, headline first:
        the classic one-at-a-time sweep, as a view of the multiverse.  Items: (index, factor id or
        None, reading)."""
        out = []
        for i, r in enumerate(self.readings):
            diff = self.space.differs(r)
            if len(diff) <= 1:
                out.append((i, diff[0] if diff else None, r))
        return out

    def diverged_total(self) -> dict:
        """Algorithm -> diverged runs summed over all universes."""
        tot: dict = {}
        for u in self.universes:
            for k, v in u.diverged.items():
                tot[k] = tot.get(k, 0) + v
        return tot

    def as_dict(self) -> dict:
        """The ``multiverse`` object of ``data/results/<paper>.json`` (see the module docstring); JSON-able."""
        return {"factors": self.space.as_dict(), "design": self.design.kind,
                "design_description": self.design.description, "n_universes": len(self.universes),
                "n_simulations": len(self.simulations()),
                "full_factorial_size": self.space.size, "n_runs": self.n_runs,
                "universes": [{"reading": dict(r), **u.as_json()} for r, u in zip(self.readings, self.universes)],
                "claims_summary": self.claims_summary(), "numbers_summary": self.numbers_summary(),
                "table_match": self.table_match(), "diverged_total": self.diverged_total()}


def run_multiverse(space: ReadingSpace, job: Callable, *, published: Iterable[PublishedNumber], n_runs: int,
                   seed: int, algorithms: Iterable[str], design: str = "auto", n_runs_paper: int | None = None,
                   **grid_options: Any) -> Multiverse:
    """Run ``job`` on every universe of ``space.design(design)`` (see :func:`run_grid` for the
    executor, worker, cache and progress options)."""
    if not isinstance(space, ReadingSpace):
        raise ValueError(f"space: expected a ReadingSpace, got {type(space).__name__}")
    algorithms = check_names(algorithms, "algorithms", nonempty=False)
    published = _check_published(published)
    check_positive_int(n_runs, "n_runs")
    check_positive_int(seed, "seed", minimum=0)
    if n_runs_paper is not None:
        check_positive_int(n_runs_paper, "n_runs_paper")
    d = space.design(design)
    results = run_grid(job, d.readings, paper=space.paper, algorithms=algorithms, n_runs=n_runs, seed=seed,
                       result_type=UniverseResult, **grid_options)
    return Multiverse(space, d, results, published, n_runs, n_runs_paper)


def _check_published(published) -> tuple:
    """``published`` as a tuple of :class:`PublishedNumber` whose ``printed`` texts are numbers."""
    out = tuple(items(published, "published", "PublishedNumber"))
    for i, p in enumerate(out):
        if not isinstance(p, PublishedNumber):
            raise ValueError(f"published[{i}]: expected a PublishedNumber, got {p!r}")
        for field in PublishedNumber._fields:
            if not isinstance(getattr(p, field), str):
                raise ValueError(f"published[{i}].{field}: expected a string, got {getattr(p, field)!r}")
        try:
            float(p.printed)
        except ValueError:
            raise ValueError(f"published[{i}].printed: expected a number as printed (e.g. '2.48'), got "
                             f"{p.printed!r}") from None
    return out


def from_dict(space: ReadingSpace, doc: dict, published: Iterable[PublishedNumber],
              n_runs_paper: int | None = None) -> Multiverse:
    """Rebuild a :class:`Multiverse` from the ``multiverse`` object of a results file."""
    if not isinstance(space, ReadingSpace):
        raise ValueError(f"space: expected a ReadingSpace, got {type(space).__name__}")
    missing = [k for k in ("universes", "design", "design_description", "n_runs")
               if not isinstance(doc, Mapping) or k not in doc]
    if missing:
        raise ValueError(f"doc: expected the 'multiverse' object of a results file, lacking {', '.join(missing)}")
    for i, u in enumerate(doc["universes"]):
        if not isinstance(u, Mapping) or "reading" not in u:
            raise ValueError(f"doc: universe {i} has no 'reading'")
    readings = tuple(space.validate(u["reading"]) for u in doc["universes"])
    universes = [UniverseResult.from_json(u) for u in doc["universes"]]
    return Multiverse(space, Design(doc["design"], doc["design_description"], readings), universes,
                      tuple(published), doc["n_runs"], n_runs_paper)
