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

* ``factors``, ``design``, ``design_description``, ``design_sample``, ``design_seed``, ``n_universes``,
  ``n_runs``, ``n_counted`` and ``weighting``;
* ``universes``: [{``reading``, ``values``, ``claims``, ``effects``, ``diverged``}];
* ``claims_summary``: per claim, the headline verdict, the verdicts of the star universes (each option varied
  alone, reported apart) and the *share of the declared reading space* holding each verdict: every universe of
  the full factorial weighted equally, exact when the full factorial is run, otherwise estimated from the design's
  uniform random sample (:attr:`~mmlib.experiment.readings.Design.sample`) with a 95 % Wilson score interval
  (:func:`~mmlib.experiment.metrics.wilson_interval`); ``robust`` when the interval's lower bound reaches
  ``ROBUST_FRACTION`` for one verdict; ``by_option``, the shares among the counted universes with each option
  of each factor (the claim x option table).  A covering ("fractional") or star design weights the readings by
  the design, not equally: no share is computed from it;
* ``numbers_summary``: per published number, the headline verdict after the joint tests, the counted universes
  that reproduce it (``n_reproduced``; a cell reproduced inside a row or table that fails its joint test is
  *isolated* and not counted) and ``closest``, the universe whose value is closest to the printed number among
  those precise enough to judge it (s.e. at most ``PRECISION`` times the printed value), ranked by relative
  distance;
* ``table_match``: per published table, the precise universe of smallest root-mean-square relative distance
  over the table's cells, with its sum of squared standardized distances and joint test, and the headline's.

The joint test of a group of cells (one published table; one row: the cells of one item and algorithm) is
:func:`mmlib.experiment.verdicts.joint_test`: the sum of the cells' squared standardized distances against
chi-squared with one degree of freedom per cell, over the cells with a finite distance.

The closest universe and the best table match are forensic findings ("Table 1 is consistent with reading X"),
never the headline. Only readings of the text take part in them (every run universe whose sensitivity factors are at
the headline and none of whose options is motivated by the results or another paper, the star included); only the
declared discrete options take part, so nothing continuous is fitted to a published number. How often such a finding
names the right reading when the answer is known is measured by planting readings (:meth:`Multiverse.recovery`,
``recovery``), which also names the factors a table cannot identify; each sensitivity factor is reported as its own
curve (``sensitivity``); universes with a motivated option (``n_motivated``) and degenerate universes (``degenerate``,
named) are reported apart from every share; ``stability`` holds the run-count check when run.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field as dataclass_field
from typing import Any, Callable, Iterable, Mapping

import numpy as np


from mmlib.core._validate import check_names, check_positive_int
from mmlib.experiment import report
from mmlib.experiment.grid import run_grid
from mmlib.experiment.metrics import wilson_interval
from mmlib.experiment import forensics
from mmlib.experiment.readings import Design, ReadingSpace, sample_seed
from mmlib.experiment.universe import Effect, PublishedNumber, UniverseResult, Value, finite_or_none, items

__all__ = [
    "run_multiverse", "Multiverse", "from_dict", "ROBUST_FRACTION", "INTERVAL_LEVEL", "PRECISION", "RECOVERY_PURPOSE",
    "NO_SHARE"
]


#: a claim is robust when the lower bound of the interval of one verdict's share of the reading space is at least
#: this fraction (the share itself when it is exact, the full factorial run)
ROBUST_FRACTION = 0.9

#: the coverage of the interval of a share estimated from a uniform sample (Wilson score interval)
INTERVAL_LEVEL = 0.95

#: a universe's value is precise enough to be the closest to a printed number (or to take part in a table match)
#: when its standard error is at most this fraction of the printed value's magnitude (of half a unit of its last
#: digit when it is printed as 0): 10 %, so that the relative distances that rank the universes are known to
#: about +-10 % of the printed value, and a value "close" only because it is noisy cannot win
PRECISION = 0.1

#: the purpose of the planted-reading draws in their SeedSequence's spawn key (:meth:`Multiverse.recovery`): apart
#: from the sample's seed and from the stability check's draw
RECOVERY_PURPOSE = 24

#: the robustness label of a claim whose shares cannot be computed
NO_SHARE = "no share: the design is not a uniform sample"


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
    #: the run-count stability check (:func:`mmlib.experiment.stability.run_count_stability`), when run
    stability: dict | None = None
    #: how the universes were obtained (:func:`run_grid`'s ``stats``: ``computed``, ``from_cache``, ``cpu_s``), when
    #: recorded: a measurement of the machine, written to the results' provenance, never to the ``multiverse`` object
    compute: dict | None = dataclass_field(default=None, compare=False)

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
        drawn = [tuple(self.space.validate(self.design.readings[i]).items()) for i in self.design.sample]
        if len(set(drawn)) != len(drawn):
            raise ValueError("design: the counted universes repeat a reading (a uniform sample is drawn without "
                             "replacement)")
        _check_published(self.published)
        if self.compute is not None and not isinstance(self.compute, dict):
            raise ValueError(f"compute: expected None or a dict (run_grid's stats), got {type(self.compute).__name__}")
        check_positive_int(self.n_runs, "n_runs")
        if self.n_runs_paper is not None:
            check_positive_int(self.n_runs_paper, "n_runs_paper")
        self._memo: dict = {}          # derived lookups, computed once per set of universes

    # -- lookups ----------------------------------------------------------------------------------------------
    @property
    def readings(self) -> tuple:
        """The design's readings (dicts factor id -> option), the headline first."""
        return self.design.readings

    @property
    def headline(self) -> UniverseResult:
        """The headline universe's result (``universes[0]``)."""
        return self.universes[0]

    def headline_match(self, headline: UniverseResult, n_runs: int) -> str:
        """Whether the headline universe (``universes[0]``) reproduces ``headline``, the paper's headline evaluation
        at ``n_runs`` Monte Carlo runs, and why not: ``"yes: ..."`` when the numbers are the same
        (:func:`mmlib.experiment.digests.same_numbers`: bit for bit, or to round-off for a universe computed on another
        machine), ``"no: ..."`` with the reason otherwise -- above all a reading space run at another count than the
        headline's (its runs per universe are set by the notebooks' ``MULTIVERSE_RUNS``, not by ``N_RUNS``)."""
        from mmlib.experiment import digests
        if not isinstance(headline, UniverseResult):
            raise ValueError(f"headline: expected a UniverseResult (the paper's summarised headline evaluation), got "
                             f"{type(headline).__name__}")
        n_runs = check_positive_int(n_runs, "n_runs")
        if n_runs != self.n_runs:
            return (f"no: the reading space runs {self.n_runs} runs per universe, the headline {n_runs} "
                    f"(MULTIVERSE_RUNS= sets the reading space's; N_RUNS= only the headline's)")
        if digests.same_numbers(self.headline, headline):
            return f"yes: the same numbers at {n_runs} runs"
        return (f"no: both run {n_runs} runs, but the numbers differ (a reading of the headline universe differs "
                f"from the headline evaluation's, or the code changed between them)")

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

    def precise(self, pub: PublishedNumber, universe: UniverseResult) -> bool:
        """Whether the universe's value of ``pub`` is precise enough to be compared by its distance: produced, with
        a finite standard error at most ``PRECISION`` times the printed value's magnitude (times half a unit of
        its last digit when it is printed as 0).  A value without a standard error (a single run) is not."""
        v = self.value(universe, _check_pub(pub).key)
        if v is None or v.replicated is None or v.stderr is None or not math.isfinite(v.stderr):
            return False
        return v.stderr <= PRECISION * _scale(pub)

    def relative_distance(self, pub: PublishedNumber, universe: UniverseResult) -> float | None:
        """``|replicated - printed| / |printed|`` (over half a unit of the last digit when printed as 0); None when
        the universe does not compute the number, ``inf`` when it computed it but could not produce a value."""
        v = self.value(universe, _check_pub(pub).key)
        if v is None:
            return None
        if v.replicated is None:
            return math.inf
        return abs(v.replicated - float(pub.printed)) / _scale(pub)

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

    # -- which universes a share counts -----------------------------------------------------------------------
    @property
    def uniform(self) -> bool:
        """True when the counted universes are the full factorial or a uniform sample of it (shares computed)."""
        return self.design.uniform

    @property
    def exact(self) -> bool:
        """True when the counted universes are the whole full factorial (shares exact, no interval width)."""
        return self.uniform and len(self.design.sample) == self.space.size

    def counted(self) -> list:
        """Indices of the universes counted in the summaries' counts and shares: the design's sample (every
        universe of a full design, the uniform sample of a sampled one, the headline and star universes only if
        drawn); for a covering or star design, which counts none for shares, every universe (descriptive counts
        only).  Universes with an option motivated by the results or by another paper (:meth:`motivated_indices`)
        and degenerate universes (:meth:`degenerate_indices`) are reported apart, never counted: what is left is a
        uniform sample (or the whole) of the declared readings without motivated options."""
        drawn = sorted(self.design.sample) if self.uniform else list(range(len(self.universes)))
        apart = set(self.motivated_indices()) | set(self.degenerate_indices())
        return [i for i in drawn if i not in apart]

    def drawn(self) -> list:
        """The universes of the design's sample (every universe for a covering or star design), before the
        motivated and degenerate ones are set apart."""
        return sorted(self.design.sample) if self.uniform else list(range(len(self.universes)))

    def motivated_indices(self) -> list:
        """Indices of the universes whose reading has an option motivated by the results or by another paper
        (:attr:`mmlib.experiment.readings.Option.motivated_by`)."""
        if "motivated" not in self._memo:
            self._memo["motivated"] = [i for i, r in enumerate(self.readings) if self.space.motivated(r)]
        return list(self._memo["motivated"])

    def degenerate_indices(self) -> list:
        """Indices of the universes flagged degenerate (every estimator no better than a no-information baseline,
        :func:`mmlib.experiment.evaluation.degenerate_reason`)."""
        return [i for i, u in enumerate(self.universes) if u.degenerate]

    def reading_indices(self) -> list:
        """Indices of the run universes that are readings of the text alone
        (:meth:`mmlib.experiment.readings.ReadingSpace.is_reading`: sensitivity factors at the headline, no
        motivated option): the only ones the table match and "the readings that reproduce" search."""
        if "readings" not in self._memo:
            self._memo["readings"] = [i for i, r in enumerate(self.readings) if self.space.is_reading(r)]
        return list(self._memo["readings"])

    def weighting(self) -> str:
        """How the counted universes weight the reading space: ``"full factorial of M"``, ``"uniform sample of N
        of M, seed S"``, or, for a covering or star design, that it is not a uniform sample."""
        m = self.space.size
        drawn = set(self.drawn())
        n_mot = len(drawn & set(self.motivated_indices()))
        n_deg = len((drawn - set(self.motivated_indices())) & set(self.degenerate_indices()))
        apart = "".join([f"; {n_mot} with a motivated option reported apart" if n_mot else "",
                         f"; {n_deg} degenerate set apart" if n_deg else ""])
        if self.exact:
            return f"full factorial of {m}{apart}"
        if self.uniform:
            return f"uniform sample of {len(self.design.sample)} of {m}, seed {self.design.seed}{apart}"
        return f"none: a {self.design.kind} design of {len(self.universes)} of {m} universes is not a uniform sample"

    def readings_weighting(self, n: int) -> str:
        """:meth:`weighting` narrowed to the ``n`` counted universes that are readings of the text (the counts of
        the readings that reproduce and of the table match), when the space has sensitivity factors."""
        if not self.space.sensitivity_ids:
            return self.weighting()
        return (f"{self.weighting()}; of these, the {n} that are readings of the text (sensitivity factors "
                f"{', '.join(self.space.sensitivity_ids)} at the headline)")

    def claims_weighting(self) -> str:
        """:meth:`weighting` of the claims' shares, which count the levels of sensitivity factors as options."""
        if not self.space.sensitivity_ids:
            return self.weighting()
        return (f"{self.weighting()}; the levels of the sensitivity factors {', '.join(self.space.sensitivity_ids)} "
                f"weighted as options (robustness to the tuning included)")

    def star_indices(self) -> list:
        """Indices of the universes that differ from the headline in exactly one factor (the star without the
        headline), reported apart from the shares."""
        return [i for i, r in enumerate(self.readings) if len(self.space.differs(r)) == 1]

    def shares(self, labels: Iterable[str], vocabulary: Iterable[str]) -> dict:
        """The share of the reading space of each term of ``vocabulary`` given the label of each counted universe
        (``labels``, one per counted universe, in :meth:`counted` order): ``counts``, ``share`` ({term:
        fraction}, every term) and ``interval`` ({term: [low, high]}: ``[share, share]`` when :attr:`exact`, else
        the Wilson score interval at ``INTERVAL_LEVEL``), ``robust`` and ``robustness``.  For a design that is not
        a uniform sample, ``share``, ``interval`` and ``robust`` are None."""
        labels, vocabulary = list(labels), list(vocabulary)
        counts = {k: labels.count(k) for k in vocabulary if k in labels}
        if len(labels) != sum(counts.values()):
            raise ValueError(f"labels: {sorted(set(labels) - set(vocabulary))} are outside the vocabulary")
        n = len(labels)
        if not self.uniform or n == 0:
            return {"counts": counts, "share": None, "interval": None, "robust": None,
                    "robustness": NO_SHARE if not self.uniform else "no share: no counted universe"}
        share = {k: labels.count(k) / n for k in vocabulary}
        if self.exact:
            interval = {k: [f, f] for k, f in share.items()}
        else:
            interval = {k: list(wilson_interval(labels.count(k), n, INTERVAL_LEVEL)) for k in vocabulary}
        robust = max(lo for lo, _ in interval.values()) >= ROBUST_FRACTION
        return {"counts": counts, "share": share, "interval": interval, "robust": robust,
                "robustness": "robust" if robust else "depends on the reading"}

    def by_option(self, labels: Iterable[str], vocabulary: Iterable[str],
                  indices: Iterable[int] | None = None) -> dict | None:
        """The label x option table: per factor, per option, ``n`` (counted universes with that option) and
        ``share`` ({term: fraction} over them, the terms that occur, in vocabulary order; empty when ``n`` is 0);
        ``labels`` one per universe of ``indices`` (default :meth:`counted`).  None for a design that is not a
        uniform sample."""
        if not self.uniform:
            return None
        labels, vocabulary = list(labels), list(vocabulary)
        counted = self.counted() if indices is None else list(indices)
        if len(counted) != len(labels):
            raise ValueError(f"labels: {len(labels)} labels for {len(counted)} universes")
        if any(lab not in vocabulary for lab in labels):
            raise ValueError(f"labels: {sorted(set(labels) - set(vocabulary))} are outside the vocabulary")
        out = {}
        for f in self.space.factors:
            out[f.id] = {}
            for o in f.names:
                mine = [lab for i, lab in zip(counted, labels) if self.readings[i][f.id] == o]
                out[f.id][o] = {"n": len(mine),
                                "share": {k: mine.count(k) / len(mine) for k in vocabulary if k in mine}}
        return out

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
        """Per claim of the headline: ``headline_verdict`` (and ``headline_decisive``), ``star_counts`` (the
        verdicts of the universes varying one option alone, not counted), and over the counted universes
        (:meth:`counted`; every universe of the full factorial weighted equally, so a metric-only factor's readings
        count as the universes they are) ``verdict_counts``, ``share``, ``interval``, ``weighting``, ``robust``,
        ``robustness`` (:meth:`shares`) and ``by_option`` (:meth:`by_option`).  A universe without the claim takes
        no part.  ``motivated`` counts the verdicts of the drawn universes with a motivated option (reported apart,
        ``n_motivated``); ``n_degenerate`` the drawn universes set apart as degenerate."""
        sims = self.simulations()              # checks that metric-only factors change no claim
        counted = self.counted()
        star = self.star_indices()
        mot_all, deg_all = set(self.motivated_indices()), set(self.degenerate_indices())
        motivated = [i for i in self.drawn() if i in mot_all]
        degenerate = [i for i in self.drawn() if i in deg_all and i not in mot_all]
        sim_of = {i: k for k, idx in enumerate(sims) for i in idx}
        out = []
        for c in self.headline.claims:
            def verdicts_of(indices):
                got = []
                for i in indices:
                    v = next((x.verdict for x in self.universes[i].claims if x.claim == c.claim), None)
                    if v is not None:
                        got.append((i, str(report.claim_category(v))))
                return got
            mine = verdicts_of(counted)
            labels = [v for _, v in mine]
            sh = self.shares(labels, report.CLAIM_VERDICTS)
            table = self.by_option(labels, report.CLAIM_VERDICTS, [i for i, _ in mine])
            star_v = [v for _, v in verdicts_of(star)]
            mot_v = [v for _, v in verdicts_of(motivated)]
            out.append({"motivated": {k: mot_v.count(k) for k in report.CLAIM_VERDICTS if k in mot_v},
                        "n_motivated": len(mot_v), "n_degenerate": len(degenerate),
                        "key": c.key, "claim": c.claim, "headline_verdict": c.verdict, "headline_decisive": c.decisive,
                        "verdict_counts": sh["counts"], "n_counted": len(labels),
                        "n_simulations": len({sim_of[i] for i, _ in mine}), "n_universes": len(self.universes),
                        "weighting": self.claims_weighting(), "share": sh["share"], "interval": sh["interval"],
                        "robust": sh["robust"], "robustness": sh["robustness"], "by_option": table,
                        "star_counts": {k: star_v.count(k) for k in report.CLAIM_VERDICTS if k in star_v},
                        "n_star": len(star_v)})
        return out

    def _cells(self) -> dict:
        """Every universe's cells judged with the joint tests: ``verdict[i][j]`` (universe i, published number j;
        a reproduced cell inside a failing row or table re-judged *reproduced (isolated)*), ``distance[i][j]``,
        ``tests[i]`` ({("table", table) or ("row", table, item, algorithm): joint-test dict}) and
        ``groups[j]`` (the table and row keys of number j).  Computed once (the universes do not change)."""
        # valid while the same universe objects (held, so no id is reused), published numbers and paper run count
        # stand: a universe replaced (a test, a re-run) invalidates it
        key = self._memo.get("cells_key")
        stale = key is None or len(key[0]) != len(self.universes) \
            or any(a is not b for a, b in zip(key[0], self.universes)) \
            or key[1] is not self.published or key[2] != self.n_runs_paper
        if stale:
            self._memo["cells"] = self._judge_cells()
            self._memo["cells_key"] = (tuple(self.universes), self.published, self.n_runs_paper)
        return self._memo["cells"]

    def _judge_cells(self) -> dict:
        pubs = self.published
        groups = [(("table", p.table), ("row", p.table, p.item, p.algorithm)) for p in pubs]
        verdicts, distances, tests = [], [], []
        for u in self.universes:
            vs = [self.number_verdict(p, u) for p in pubs]
            ds = [self.distance(p, u) for p in pubs]
            members: dict = {}
            for j, d in enumerate(ds):
                if d is not None and math.isfinite(d):            # the Monte Carlo cells with a distance
                    for g in groups[j]:
                        members.setdefault(g, []).append(j)
            mine = {}
            failing = set()
            for g, idx in members.items():
                t = report.joint_test(ds[j] for j in idx)
                if not t.passes:
                    failing.update(idx)
                n_iso = 0 if t.passes else sum(vs[j] == report.REPRODUCED for j in idx)
                mine[g] = {"item": g[1] if g[0] == "table" else g[2], "algorithm": None if g[0] == "table" else g[3],
                           "statistic": t.statistic, "dof": t.dof, "p_value": t.p_value, "passes": t.passes,
                           "n_isolated": n_iso}
            vs = [report.ISOLATED if (v == report.REPRODUCED and j in failing) else v for j, v in enumerate(vs)]
            verdicts.append(vs)
            distances.append(ds)
            tests.append(mine)
        return {"verdict": verdicts, "distance": distances, "tests": tests, "groups": groups}

    def numbers_summary(self) -> list:
        """Per published number: its headline verdict (after the joint tests) and distance, whether the headline's
        cell is ``isolated`` and the headline's ``joint_test`` of the cell's ``table`` and ``row`` (None where the
        cell has no finite distance); over the counted universes that are readings of the text (:meth:`counted` and
        :meth:`reading_indices`: the readings that reproduce, never a tuning sweep; ``n_counted``, ``weighting``)
        the counts of universes that reproduce it (``n_reproduced``, isolated cells excluded), whose cell is
        reproduced but isolated (``n_isolated``), reproduce it qualitatively and are inconclusive; and, among every
        run universe whose value is precise enough (:meth:`precise`; ``n_precise``), the ``closest`` by relative
        distance among the readings of the text (its universe, reading, value, standardized and relative distance and
        verdict), with
        ``closest_status`` "found", "none precise enough" or "not computed"."""
        cells = self._cells()
        readings = set(self.reading_indices())
        counted = [i for i in self.counted() if i in readings]
        out = []
        for j, pub in enumerate(self.published):
            verdicts = [cells["verdict"][i][j] for i in range(len(self.universes))]
            dists = [cells["distance"][i][j] for i in range(len(self.universes))]
            mine = [verdicts[i] for i in counted]
            rel = [self.relative_distance(pub, u) for u in self.universes]
            precise = [i for i, u in enumerate(self.universes) if i in readings and self.precise(pub, u)]
            closest, status = None, "not computed"
            if any(r is not None for r in rel):
                status = "none precise enough"
            if precise:
                i = min(precise, key=lambda k: (rel[k], k))
                v = self.value(self.universes[i], pub.key)
                closest = {"universe": i, "reading": dict(self.readings[i]),
                           "describe": self.space.describe(self.readings[i]), "replicated": v.replicated,
                           "stderr": v.stderr, "distance": finite_or_none(dists[i]),
                           "relative_distance": finite_or_none(rel[i]), "verdict": verdicts[i]}
                status = "found"
            head_tests = cells["tests"][0]
            table_key, row_key = cells["groups"][j]
            joint = (None if table_key not in head_tests or dists[0] is None or not math.isfinite(dists[0]) else
                     {"table": head_tests[table_key], "row": head_tests[row_key]})
            out.append({"table": pub.table, "item": pub.item, "algorithm": pub.algorithm, "quantity": pub.quantity,
                        "paper": pub.printed, "headline_verdict": verdicts[0],
                        "headline_distance": finite_or_none(dists[0]),
                        "isolated": verdicts[0] == report.ISOLATED, "joint_test": joint,
                        "n_reproduced": sum(v == report.REPRODUCED for v in mine),
                        "n_isolated": sum(v == report.ISOLATED for v in mine),
                        "n_qualitative": sum(v == report.QUALITATIVE for v in mine),
                        "n_inconclusive": sum(v.startswith(report.INCONCLUSIVE) for v in mine),
                        "n_counted": len(mine), "weighting": self.readings_weighting(len(mine)),
                        "n_universes": len(self.universes),
                        "precision": PRECISION, "n_precise": len(precise), "closest": closest,
                        "closest_status": status})
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

    def table_relative_distances(self, table: str) -> list:
        """Root-mean-square over the table's computed cells of the relative distances (:meth:`relative_distance`),
        per universe (None when the universe computes no cell, ``inf`` when a cell failed)."""
        if table not in self.tables:
            raise ValueError(f"table: unknown table {table!r}; published: {self.tables}")
        pubs = [p for p in self.published if p.table == table]
        out = []
        for u in self.universes:
            rs = [r for r in (self.relative_distance(p, u) for p in pubs) if r is not None]
            out.append(math.sqrt(math.fsum(r * r for r in rs) / len(rs)) if rs else None)
        return out

    def table_precise(self, table: str) -> list:
        """Per universe: whether it computes some cell of the table and every cell it computes is precise enough
        (:meth:`precise`): the universes that take part in the table match."""
        if table not in self.tables:
            raise ValueError(f"table: unknown table {table!r}; published: {self.tables}")
        pubs = [p for p in self.published if p.table == table]
        out = []
        for u in self.universes:
            computed = [p for p in pubs if self.value(u, p.key) is not None]
            out.append(bool(computed) and all(self.precise(p, u) for p in computed))
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
        """Per table with a computed cell: the best match (``best_*``: among the universes whose every cell of the
        table is precise enough, :meth:`table_precise`, the one of smallest root-mean-square relative distance,
        with its sum of squared standardized distances ``best_sum`` and its ``best_joint_test``), the headline's
        (``headline_sum``, ``headline_rms_relative``, its ``joint_test`` of the table and the number of its cells
        ``isolated``), ``n_passing`` (counted universes whose table passes its joint test, of ``n_counted``), and
        the most cells any universe reproduces (isolated cells excluded).  Cells reproduced only as isolated
        coincidences never count as reproduced.  Only readings of the text are searched (:meth:`reading_indices`:
        no tuning sweep, no motivated option; ``n_candidates``), and every entry carries ``recovery``, how often
        this match names a planted reading (:meth:`recovery`), with the factors the table cannot identify."""
        cells = self._cells()
        readings = set(self.reading_indices())
        counted = [i for i in self.counted() if i in readings]
        recovery = {r["table"]: r for r in self.recovery()["tables"]}
        out = []
        for table in self.tables:
            idx = [j for j, p in enumerate(self.published) if p.table == table]
            pubs = [self.published[j] for j in idx]
            sums = self.table_distances(table)
            if not any(s is not None for s in sums):
                continue
            rms = self.table_relative_distances(table)
            eligible = self.table_precise(table)
            judged = [all(self.conclusive(p, u) for p in pubs) for u in self.universes]
            n_rep = [sum(cells["verdict"][i][j] == report.REPRODUCED for j in idx) for i in range(len(self.universes))]
            n_iso = [sum(cells["verdict"][i][j] == report.ISOLATED for j in idx) for i in range(len(self.universes))]
            test = [cells["tests"][i].get(("table", table)) for i in range(len(self.universes))]
            most = max(sorted(readings), key=lambda i: (n_rep[i], -i))
            entry = {"table": table, "n_cells": sum(1 for p in pubs if self.distance(p, self.headline) is not None),
                     "precision": PRECISION, "headline_sum": finite_or_none(sums[0]),
                     "headline_rms_relative": finite_or_none(rms[0]), "headline_n_reproduced": n_rep[0],
                     "joint_test": test[0], "isolated": n_iso[0],
                     "n_passing": sum(bool(test[i] and test[i]["passes"]) for i in counted), "n_counted": len(counted),
                     "weighting": self.readings_weighting(len(counted)),
                     "n_excluded_imprecise": sum(not e for e in eligible),
                     "n_excluded_inconclusive": sum(not j for j in judged),
                     "most_n_reproduced": n_rep[most], "most_universe": most,
                     "most_reading": dict(self.readings[most]),
                     "most_describe": self.space.describe(self.readings[most]),
                     "best_universe": None, "best_reading": None,
                     "best_describe": "none precise enough (no universe has every cell's s.e. within "
                                      f"{100 * PRECISION:.0f} % of the printed value)",
                     "best_sum": None, "best_rms_relative": None, "best_joint_test": None, "best_n_reproduced": 0,
                     "n_candidates": len(readings), "recovery": recovery.get(table)}
            finite = [(rms[i], i) for i in sorted(readings)
                      if eligible[i] and rms[i] is not None and math.isfinite(rms[i])]
            if finite:
                best, i = min(finite)
                entry.update({"best_universe": i, "best_reading": dict(self.readings[i]),
                              "best_describe": self.space.describe(self.readings[i]),
                              "best_sum": finite_or_none(sums[i]), "best_rms_relative": best,
                              "best_joint_test": test[i], "best_n_reproduced": n_rep[i]})
            out.append(entry)
        return out

    def _cell_arrays(self, indices: list, cells: list) -> tuple:
        """(values, stderrs) of shape (len(indices), len(cells)) of the published numbers ``cells`` (indices into
        :attr:`published`) in the universes ``indices``; NaN where a value is missing."""
        vals = np.full((len(indices), len(cells)), np.nan)
        ses = np.full_like(vals, np.nan)
        for a, i in enumerate(indices):
            for b, j in enumerate(cells):
                v = self.value(self.universes[i], self.published[j].key)
                if v is not None and v.replicated is not None and v.stderr is not None:
                    vals[a, b], ses[a, b] = v.replicated, v.stderr
        return vals, ses

    def _star_of(self, factor_id: str, option: str) -> int | None:
        """The run universe that differs from the headline in ``factor_id`` alone, set to ``option`` (None if not
        run); the headline itself for the headline option."""
        want = {**self.space.headline, factor_id: option}
        return next((i for i, r in enumerate(self.readings) if dict(r) == want), None)

    def recovery(self, trials: int = forensics.RECOVERY_TRIALS) -> dict:
        """Planted-reading recovery of every table (:func:`mmlib.experiment.forensics.planted_recovery`): among the
        readings of the text whose table cells (those the headline computes) are all precise enough, ``trials``
        universes are planted, each gives a synthetic printed table at the paper's run count and printed precision,
        and the table match is run on it.  Per table: ``planted``, ``top1``, ``top3`` (with Wilson intervals),
        ``by_factor`` and ``by_factor_chance`` (how often the best match, or a random candidate, has the planted
        option of each reading factor), ``indistinguishable`` (factor -> the pairs of its options, each varied alone
        from the headline, that a printed table confuses with probability at least
        :data:`~mmlib.experiment.forensics.CONFUSION`, :func:`mmlib.experiment.forensics.confusion`) and
        ``unidentifiable`` (those factors: a match is no evidence for one of their options).  The summary
        (``planted``, ``top1``, ``top3``, ``unidentifiable``) is the mean of the tables' rates and the factors
        unidentifiable from every table.  Each table's draws use their own generator, seeded from the paper's name
        (:func:`~mmlib.experiment.readings.sample_seed`) and the table's place through a ``SeedSequence`` of purpose
        :data:`RECOVERY_PURPOSE`, never a run's streams or the sample's."""
        trials = check_positive_int(trials, "trials")
        key = ("recovery", trials)
        if self._memo.get(key, (None,))[0] is self._cells():     # the universes' judged cells, computed once
            return self._memo[key][1]
        readings = self.reading_indices()
        factors = [f.id for f in self.space.factors if f.kind == "reading"]
        tables = []
        for t_index, table in enumerate(self.tables):
            cells = [j for j, p in enumerate(self.published) if p.table == table
                     and self.distance(p, self.headline) is not None and math.isfinite(self.distance(p, self.headline))]
            if not cells:
                continue
            pubs = [self.published[j] for j in cells]
            printed = [p.printed for p in pubs]
            ok = [i for i in readings if all(self.precise(p, self.universes[i]) for p in pubs)]
            entry = {"table": table, "n_cells": len(cells), "n_candidates": len(ok), "planted": 0, "top1": None,
                     "top3": None, "top1_interval": None, "top3_interval": None, "by_factor": {},
                     "by_factor_chance": {}, "indistinguishable": {}, "unidentifiable": []}
            if ok:
                vals, ses = self._cell_arrays(ok, cells)
                seed = int(np.random.SeedSequence(sample_seed(self.space.paper),
                                                  spawn_key=(RECOVERY_PURPOSE, t_index)).generate_state(1)[0])
                entry.update(forensics.planted_recovery(
                    vals, ses, printed, [self.readings[i] for i in ok], factors,
                    n_runs=self.n_runs, n_runs_paper=self.n_runs_paper, seed=seed, trials=trials))
            for f in factors:
                star = []                                    # the options varied alone from the headline, with data
                for o in self.space.factor(f).names:
                    i = self._star_of(f, o)
                    if i is not None and i in readings:
                        v, se = self._cell_arrays([i], cells)
                        if np.isfinite(v).all() and np.isfinite(se).all():
                            star.append((o, v[0], se[0]))
                pairs = [[oa, ob] for k, (oa, va, sa) in enumerate(star) for (ob, vb, sb) in star[k + 1:]
                         if forensics.confusion(va, sa, vb, sb, printed, self.n_runs, self.n_runs_paper)["confused"]]
                if pairs:
                    entry["indistinguishable"][f] = pairs
            entry["unidentifiable"] = sorted(entry["indistinguishable"], key=factors.index)
            tables.append(entry)
        run = [t for t in tables if t["planted"]]
        common = [f for f in factors if run and all(f in t["unidentifiable"] for t in run)]
        out = {"planted": sum(t["planted"] for t in run),
               "top1": float(np.mean([t["top1"] for t in run])) if run else None,
               "top3": float(np.mean([t["top3"] for t in run])) if run else None,
               "unidentifiable": common, "trials_per_table": trials, "tables": tables}
        self._memo[key] = (self._cells(), out)
        return out

    def sensitivity(self) -> list:
        """The curve of every sensitivity factor (:attr:`mmlib.experiment.readings.Factor.kind`): per option, the
        universe that differs from the headline in that factor alone (None when not run), its claims' verdicts and,
        per table, its root-mean-square relative distance, its cells reproduced (isolated ones excluded) and
        whether the table passes its joint test: the verdict against the swept value, never a reading that
        reproduces."""
        cells = self._cells()
        out = []
        for f in self.space.factors:
            if f.kind != "sensitivity":
                continue
            opts = []
            for o in f.options:
                i = self._star_of(f.id, o.name)
                entry = {"option": o.name, "label": o.label, "universe": i, "claims": {}, "tables": {}}
                if i is not None:
                    u = self.universes[i]
                    entry["claims"] = {c.claim: c.verdict for c in u.claims}
                    for table in self.tables:
                        idx = [j for j, p in enumerate(self.published) if p.table == table]
                        rms = self.table_relative_distances(table)[i]
                        t = cells["tests"][i].get(("table", table))
                        entry["tables"][table] = {
                            "rms_relative": finite_or_none(rms) if rms is not None else None,
                            "n_reproduced": sum(cells["verdict"][i][j] == report.REPRODUCED for j in idx),
                            "joint_passes": None if t is None else bool(t["passes"])}
                opts.append(entry)
            out.append({"factor": f.id, "label": f.label, "headline": f.headline, "options": opts})
        return out

    def degenerate(self) -> list:
        """The degenerate universes, named: ``universe``, ``reading``, ``describe`` and ``reason``."""
        return [{"universe": i, "reading": dict(self.readings[i]), "describe": self.space.describe(self.readings[i]),
                 "reason": self.universes[i].degenerate} for i in self.degenerate_indices()]

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
                "design_description": self.design.description, "design_sample": list(self.design.sample),
                "design_seed": self.design.seed, "n_counted": len(self.counted()) if self.uniform else 0,
                "n_drawn": len(self.drawn()),
                "weighting": self.weighting(),
                "n_universes": len(self.universes),
                "n_simulations": len(self.simulations()),
                "full_factorial_size": self.space.size, "n_runs": self.n_runs,
                "universes": [{"reading": dict(r), **u.as_json()} for r, u in zip(self.readings, self.universes)],
                "claims_summary": self.claims_summary(), "numbers_summary": self.numbers_summary(),
                "table_match": self.table_match(), "diverged_total": self.diverged_total(),
                "recovery": self.recovery(), "sensitivity": self.sensitivity(),
                "n_degenerate": len(self.degenerate_indices()), "degenerate": self.degenerate(),
                "n_motivated": len(self.motivated_indices()),
                **({"stability": self.stability} if self.stability is not None else {})}


def run_multiverse(space: ReadingSpace, job: Callable, *, published: Iterable[PublishedNumber], n_runs: int,
                   seed: int, algorithms: Iterable[str], design: str = "auto", n_runs_paper: int | None = None,
                   sample_size: int | None = None, sample_seed: int | None = None,
                   **grid_options: Any) -> Multiverse:
    """Run ``job`` on every universe of ``space.design(design, sample_size=sample_size, seed=sample_seed)``
    (``sample_size`` None: the space's budget; ``sample_seed`` None: the paper's
    :func:`~mmlib.experiment.readings.sample_seed`; see :func:`run_grid` for the executor, worker, cache and progress
    options).  ``seed`` is the Monte Carlo root seed, not the sample's."""
    if not isinstance(space, ReadingSpace):
        raise ValueError(f"space: expected a ReadingSpace, got {type(space).__name__}")
    algorithms = check_names(algorithms, "algorithms", nonempty=False)
    published = _check_published(published)
    check_positive_int(n_runs, "n_runs")
    check_positive_int(seed, "seed", minimum=0)
    if n_runs_paper is not None:
        check_positive_int(n_runs_paper, "n_runs_paper")
    d = space.design(design, sample_size=sample_size, seed=sample_seed)
    compute: dict = {}
    results = run_grid(job, d.readings, paper=space.paper, algorithms=algorithms, n_runs=n_runs, seed=seed,
                       result_type=UniverseResult, stats=compute, **grid_options)
    return Multiverse(space, d, results, published, n_runs, n_runs_paper, compute=compute)


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
    sample = doc.get("design_sample")
    return Multiverse(space, Design(doc["design"], doc["design_description"], readings,
                                    None if sample is None else tuple(sample), doc.get("design_seed")),
                      universes, tuple(published), doc["n_runs"], n_runs_paper)


def _scale(pub: PublishedNumber) -> float:
    """The magnitude a published number's precision and relative distance refer to: ``|printed|``, or half a unit
    of its last printed digit when it is printed as 0."""
    return forensics.scale(pub.printed)
