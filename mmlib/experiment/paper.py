"""The contract a replicated paper fulfils: one frozen :class:`Paper` per paper, listed in ``mmlib.papers.REGISTRY``.

A paper package (``mmlib/papers/<name>/``) declares, as data,

* what the paper printed: ``published`` numbers (:class:`~mmlib.experiment.universe.PublishedNumber`) and the
  numbered ``deviations`` (:class:`~mmlib.experiment.readings.Deviation`) where its text is missing, contradictory
  or wrong;
* the ``space`` of defensible readings of that text (:class:`~mmlib.experiment.readings.ReadingSpace`), whose
  headline reading is the one the notebook shows first;

and three callables, the only way the rest of the repository reaches its code:

* ``setup(reading) -> setup_type``: the set-up of a reading (a ``ValueError`` names an unknown factor or option);
* ``scenario(setup) -> Scenario``: the headline case of a set-up as an arena scenario
  (:class:`~mmlib.experiment.scenario.Scenario`), so the arena runs every algorithm on every paper's problem;
* ``universe(reading, n_runs, seed) -> UniverseResult``: one universe of the reading space, run for ``n_runs``
  Monte Carlo runs on root seed ``seed`` (:class:`~mmlib.experiment.universe.UniverseResult`: the values of the
  published numbers, the claims' verdicts, the named effects, the diverged runs);

plus ``batch(setup, mc) -> (make_batch, estimators[, measurement_models])``, the Monte Carlo batch of a set-up's
headline case on the runs of ``mc`` (``make_batch(runs) -> (truth, measurements, {estimator: initial state})`` for
:func:`mmlib.experiment.evaluation.evaluate`, with the per-step measurement models where the sensor changes from step
to step; the batch-independence and arena tests run it for every paper), and
``headline_digest(n_runs)``, the run digest of the headline's first runs
(:func:`mmlib.experiment.digests.run_digest`) that the notebook stores and the tests recompute.

The arena, the notebook runner, the site and the tests iterate over the registry; a new paper is a new package
and one registry line (``docs/new-paper.md`` walks through a minimal one).
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Callable, Mapping, NamedTuple

from mmlib.core._validate import check_positive_int
from mmlib.experiment.readings import Deviation, ReadingSpace
from mmlib.experiment.verdicts import RECONSTRUCTION
from mmlib.experiment.universe import PublishedNumber, UniverseResult

__all__ = [
    "Paper", "Study", "ArenaEntry", "PROFILE_KEYS", "DESIGNS", "KINDS", "QUALIFIERS", "NAME_PATTERN"
]

#: what a notebook profile may set (checked): headline runs, timing runs and repeats, runs per universe, the design;
#: a paper may add keys of its own (e.g. tseng2011's oracle runs)
PROFILE_KEYS = ("n_runs", "timing_runs", "timing_repeats", "mv_runs", "mv_design")
#: the designs of a reading space (:meth:`mmlib.experiment.readings.ReadingSpace.design`)
DESIGNS = ("auto", "full", "fractional", "star")
#: the kinds of study a Paper declares (:attr:`Paper.kind`)
KINDS = ("paper", "control")
#: the qualifiers of a paper's verdicts (:attr:`Paper.qualifier`): none, or a reconstructed set-up
QUALIFIERS = ("", RECONSTRUCTION)
#: a paper's name: a results file's (mmlib/experiment/results.schema.json)
NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9-]*")


class ArenaEntry(NamedTuple):
    """A paper's part in the arena (:mod:`mmlib.arena`, which runs every algorithm on every scenario, the paper's
    headline scenario among them): the ``algorithms`` it proposes or runs (recipe names of
    :data:`mmlib.arena.recipes.RECIPES`, credited to it in the arena's algorithm table), the ``ideas`` it
    contributes (``(idea, algorithm, baseline)``: the arena asks whether the idea helps, scenario by scenario) and
    its central ``claim`` with the ``(algorithm, baseline)`` pairs that test it; ``reading``, ``(factor, option)``
    pairs changing the headline reading for the arena's scenario (:meth:`Paper.arena_setup`), where the headline
    makes a degenerate scenario (zhou2017's unobservable drift: its per-step fault instead)."""

    algorithms: tuple[str, ...]
    ideas: tuple[tuple[str, str, str], ...] = ()
    claim: str = ""
    claim_pairs: tuple[tuple[str, str], ...] = ()
    reading: tuple[tuple[str, str], ...] = ()


class Study(NamedTuple):
    """What a study that is not a paper (the arena) declares to its notebook
    (``mmlib.experiment.notebook.NotebookRun``): its ``name`` (the results file's and the figures folder's),
    ``root_seed``, ``profiles`` (as :attr:`Paper.profiles`) and ``citation`` (empty when none)."""

    name: str
    root_seed: int
    profiles: Mapping[str, Mapping[str, Any]]
    citation: str = ""


@dataclass(frozen=True)
class Paper:
    """One replicated paper (see the module docstring).

    ``name`` is the registry key, the reading space's and the results file's name (``data/results/<name>.json``);
    ``n_runs`` the paper's own Monte Carlo count, whose error the verdict rule adds to ours (None when the paper
    does not state it); ``profiles`` the notebook's profiles (``"full"`` and ``"smoke"``, each a mapping of
    :data:`PROFILE_KEYS`; a paper may add its own keys); ``algorithms`` the estimators every universe runs;
    ``key_effect`` the name of the effect its specification curve sorts by; ``notebook`` the notebook's stem in
    ``notebooks/``; ``title`` a short title for pages and tables.

    ``kind`` is ``"paper"`` for a replicated paper or ``"control"`` for a control of the pipeline (a "published"
    table known in closed form, which the whole pipeline must reproduce, or the same table perturbed, which it must
    reject); controls are listed first in the reports and on the site, and take no part in the arena or in pooled
    tallies of papers.  ``qualifier`` is "" when the paper gives its set-up, or
    :data:`mmlib.experiment.verdicts.RECONSTRUCTION` when the set-up had to be reconstructed (a section lost,
    parameters invented): its claims' verdicts then say so ("contradicted by the reconstruction") and are kept out
    of pooled tallies."""

    name: str
    title: str
    citation: str
    doi: str
    root_seed: int
    n_runs: int | None
    setup_type: type
    deviations: tuple[Deviation, ...]
    space: ReadingSpace
    published: tuple[PublishedNumber, ...]
    algorithms: tuple[str, ...]
    key_effect: str
    setup: Callable[[Mapping[str, str]], Any]
    scenario: Callable[[Any], Any]
    universe: Callable[[Mapping[str, str], int, int], UniverseResult]
    batch: Callable[[Any, Any], tuple]
    headline_digest: Callable[[int], dict]
    notebook: str
    profiles: Mapping[str, Mapping[str, Any]]
    arena: ArenaEntry | None = None
    kind: str = "paper"
    qualifier: str = ""

    def __post_init__(self):
        for name in ("name", "title", "citation", "doi", "key_effect", "notebook"):
            if not isinstance(getattr(self, name), str) or not getattr(self, name):
                raise ValueError(f"{name}: expected a non-empty string, got {getattr(self, name)!r}")
        if not NAME_PATTERN.fullmatch(self.name):
            raise ValueError(f"name: expected letters, digits and '-' (a results file's paper name), got {self.name!r}")
        if self.notebook != self.name and not self.notebook.startswith(self.name + "_"):
            raise ValueError(f"notebook: expected {self.name!r} or '{self.name}_<topic>' (the runner and the site find "
                             f"a paper's notebook by that prefix), got {self.notebook!r}")
        check_positive_int(self.root_seed, "root_seed", minimum=0)
        if self.n_runs is not None:
            check_positive_int(self.n_runs, "n_runs", minimum=2)
        if not isinstance(self.setup_type, type):
            raise ValueError(f"setup_type: expected a class, got {self.setup_type!r}")
        if not isinstance(self.space, ReadingSpace) or self.space.paper != self.name:
            raise ValueError(f"space: expected the ReadingSpace of {self.name!r}, got {self.space!r}")
        for field_, kind in (("deviations", Deviation), ("published", PublishedNumber)):
            value = getattr(self, field_)
            if not isinstance(value, tuple) or not all(isinstance(v, kind) for v in value):
                raise ValueError(f"{field_}: expected a tuple of {kind.__name__}, got {value!r}")
            keys = [v.id if kind is Deviation else v.key for v in value]
            if len(set(keys)) != len(keys):
                raise ValueError(f"{field_}: {sorted({str(k) for k in keys if keys.count(k) > 1})} appear twice")
        if not isinstance(self.algorithms, tuple) or not self.algorithms \
                or not all(isinstance(a, str) for a in self.algorithms):
            raise ValueError(f"algorithms: expected a non-empty tuple of names, got {self.algorithms!r}")
        for name in ("setup", "scenario", "universe", "batch", "headline_digest"):
            if not callable(getattr(self, name)):
                raise ValueError(f"{name}: expected a callable, got {getattr(self, name)!r}")
        if not isinstance(self.profiles, Mapping) or not {"full", "smoke"} <= set(self.profiles):
            raise ValueError(f"profiles: expected a mapping with 'full' and 'smoke', got {self.profiles!r}")
        for pname, prof in self.profiles.items():
            if not isinstance(prof, Mapping) or "n_runs" not in prof:
                raise ValueError(f"profiles[{pname!r}]: expected a mapping with 'n_runs', got {prof!r}")
            for key, least in (("n_runs", 2), ("mv_runs", 2), ("timing_runs", 1), ("timing_repeats", 1)):
                if key in prof:
                    check_positive_int(prof[key], f"profiles[{pname!r}][{key!r}]", minimum=least)
            if prof.get("mv_design", "auto") not in DESIGNS:
                raise ValueError(f"profiles[{pname!r}]['mv_design']: expected one of {DESIGNS}, got "
                                 f"{prof['mv_design']!r}")
        if self.profiles["smoke"]["n_runs"] > self.profiles["full"]["n_runs"]:
            raise ValueError("profiles: the smoke profile's runs are a prefix of the full profile's: no more of them")
        if self.arena is not None:
            _check_arena(self.arena)
            try:
                self.space.with_headline(**dict(self.arena.reading))
            except ValueError as exc:
                raise ValueError(f"arena.reading: {exc}") from None
        if self.kind not in KINDS:
            raise ValueError(f"kind: expected one of {KINDS}, got {self.kind!r}")
        if self.qualifier not in QUALIFIERS:
            raise ValueError(f"qualifier: expected one of {QUALIFIERS}, got {self.qualifier!r}")
        if self.kind == "control" and self.arena is not None:
            raise ValueError("arena: a control takes no part in the arena (arena=None)")
        object.__setattr__(self, "profiles", MappingProxyType({k: MappingProxyType(dict(v))
                                                               for k, v in self.profiles.items()}))

    @property
    def headline(self) -> dict:
        """The headline reading (factor id -> option name)."""
        return self.space.headline

    def runs(self, profile: str) -> int:
        """The headline's Monte Carlo runs in ``profile`` ("full" or "smoke")."""
        if profile not in self.profiles:
            raise ValueError(f"profile: expected one of {sorted(self.profiles)}, got {profile!r}")
        return int(self.profiles[profile]["n_runs"])

    def headline_setup(self) -> Any:
        """The set-up of the headline reading."""
        return self.setup(self.space.headline)

    def arena_setup(self) -> Any:
        """The set-up of the arena's scenario: the headline reading changed by :attr:`ArenaEntry.reading` (the
        headline's own set-up when the paper has no arena entry or the entry changes nothing)."""
        if self.arena is None or not self.arena.reading:
            return self.headline_setup()
        return self.setup(self.space.with_headline(**dict(self.arena.reading)))

    def deviation(self, id_: str) -> Deviation:
        """The deviation numbered ``id_`` (e.g. "Z-5"); ValueError listing the ids otherwise."""
        for d in self.deviations:
            if d.id == id_:
                return d
        raise ValueError(f"id_: no deviation {id_!r} in {self.name} ({[d.id for d in self.deviations]})")


def _check_arena(entry) -> None:
    """``entry`` as an :class:`ArenaEntry` of tuples of names, or ValueError naming the field."""
    if not isinstance(entry, ArenaEntry):
        raise ValueError(f"arena: expected an ArenaEntry or None, got {entry!r}")

    def names(value, field_, size=None):
        ok = isinstance(value, tuple) and all(
            isinstance(v, str) and v if size is None else
            isinstance(v, tuple) and len(v) == size and all(isinstance(x, str) and x for x in v) for v in value)
        if not ok:
            what = "names" if size is None else f"{size}-tuples of names"
            raise ValueError(f"arena.{field_}: expected a tuple of {what}, got {value!r}")

    names(entry.algorithms, "algorithms")
    if not entry.algorithms:
        raise ValueError("arena.algorithms: expected at least one algorithm")
    names(entry.ideas, "ideas", 3)
    names(entry.claim_pairs, "claim_pairs", 2)
    names(entry.reading, "reading", 2)
    if not isinstance(entry.claim, str) or bool(entry.claim) != bool(entry.claim_pairs):
        raise ValueError(f"arena.claim: expected a claim with its pairs, or neither, got {entry.claim!r} with "
                         f"{len(entry.claim_pairs)} pair(s)")
