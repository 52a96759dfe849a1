"""Reading spaces: a paper's ambiguities as declared factors, and the designs that run them.

A paper that is silent, contradictory or garbled somewhere admits several *readings*.
Each ambiguity is a :class:`Factor` (numbered, usually the deviation number that
discusses it) whose :class:`Option` s are the readings the paper's text supports,
each saying where.  One option per factor is the *headline*: the reading chosen on
the text before any run.  A *reading* is a mapping ``factor id -> option name`` that
names every factor; a *universe* is the experiment run under one reading.

The :class:`ReadingSpace` is the full factorial product of the factors (a
multiverse analysis: Steegen, Tuerlinckx, Gelman & Vanpaemel 2016, Perspectives on
Psychological Science 11(5):702, doi:10.1177/1745691616658637; a specification curve:
Simonsohn, Simmons & Nelson 2020, Nature Human Behaviour 4:1208,
doi:10.1038/s41562-020-0912-z).  Every robustness statement is a share of that product, each
universe weighted equally.  :meth:`ReadingSpace.design` runs the full factorial when it fits the
paper's ``budget``; otherwise the *sampled* design: the headline, every option of every factor
varied alone from the headline (the "star", reported apart), and a uniform random sample without
replacement of ``budget`` universes of the full factorial, drawn with a recorded seed (by default
:func:`sample_seed` of the paper's name), from which the shares are estimated.  The covering
design ("fractional": the star, then universes chosen greedily until every pair of options of every
two *influential* factors occurs together, a strength-2 covering array by the greedy construction
of Cohen, Dalal, Fredman & Patton 1997, IEEE Trans. Software Eng. 23(7):437) and the star alone
remain available on request, for exploring interactions; no share is computed from them, since they
weight the readings by the design (the headline options in most universes), not equally.

Only declared discrete options take part: no continuous parameter is ever fitted to a
published number.
"""
from __future__ import annotations

import hashlib
import itertools
import math
from dataclasses import asdict, dataclass, field
from typing import Mapping

import numpy as np

from mmlib.core._validate import as_plain_json, check_bool, check_choice, check_positive_int

__all__ = [
    "ReadingSpace", "Factor", "Option", "Deviation", "Design", "sample_seed", "FACTOR_KINDS", "DESIGN_KINDS",
    "UNIFORM_KINDS"
]


def _check_text(obj, fields, optional=()) -> None:
    """Each of ``fields`` of ``obj`` a non-empty string (``optional`` ones may be empty)."""
    for arg in fields:
        value = getattr(obj, arg)
        if not isinstance(value, str) or (arg not in optional and not value.strip()):
            raise ValueError(f"{arg}: expected a non-empty string, got {value!r}")


@dataclass(frozen=True)
class Deviation:
    """A numbered interpretation: what the paper gives, what we do, and why (every field a string; ``reason`` and
    ``sweep`` may be empty, the others not)."""

    id: str
    topic: str
    paper: str
    choice: str
    reason: str
    sweep: str = ""

    def __post_init__(self):
        _check_text(self, ("id", "topic", "paper", "choice", "reason", "sweep"), optional=("reason", "sweep"))

    def as_dict(self) -> dict:
        """The fields as a JSON-able dict (``id``, ``topic``, ``paper``, ``choice``, ``reason``, ``sweep``)."""
        return asdict(self)


@dataclass(frozen=True)
class Option:
    """One reading of an ambiguity.

    ``name`` is a short identifier used in readings (``"150s"``), ``label`` a phrase for
    tables and figures, ``source`` where the paper's text supports it (section, equation,
    quotation), and ``changes`` the set-up parameters this reading sets (field name ->
    value), merged over all factors by :meth:`ReadingSpace.changes`.

    ``motivated_by`` is empty for an option the text supports on its own; otherwise it says what else motivated it
    (``"results: Table 1 prints IMMCKF != IMMUKF"``, ``"another paper: Hu et al. 2017"``).  A universe with such an
    option is run and reported apart (:meth:`ReadingSpace.motivated`), never counted in the shares of the reading
    space nor searched by the table match: a reading chosen because of the results it gives cannot then be evidence
    that those results are reproduced."""

    name: str
    label: str
    source: str
    changes: Mapping = field(default_factory=dict)
    motivated_by: str = ""

    def __post_init__(self):
        _check_text(self, ("name", "label", "source", "motivated_by"), optional=("motivated_by",))
        if not isinstance(self.changes, Mapping):
            raise ValueError(f"changes: expected a mapping of set-up fields to values, got {self.changes!r}")
        object.__setattr__(self, "changes", as_plain_json(dict(self.changes), "changes"))

    def as_dict(self) -> dict:
        """``name``, ``label``, ``source`` and ``changes`` as a JSON-able dict (tuple values as lists)."""
        return {"name": self.name, "label": self.label, "source": self.source,
                "changes": {k: list(v) if isinstance(v, tuple) else v for k, v in self.changes.items()},
                "motivated_by": self.motivated_by}


#: the kinds of factor (:attr:`Factor.kind`): alternatives the text supports, or an unstated tuning value swept
FACTOR_KINDS = ("reading", "sensitivity")


@dataclass(frozen=True)
class Factor:
    """A numbered ambiguity: its options (readings the text supports) and the headline one.

    ``influential`` marks factors whose pairwise interactions a fractional design must
    cover (a factor shown not to move any result may be declared non-influential; it still
    appears with every option).  ``metric_only`` marks a factor whose options change only how a
    published number is computed from the same simulated runs (e.g. which average of the errors a
    table prints), never the simulation or a claim: universes that differ only in such factors
    are one *simulation*, and claims are counted once per simulation.

    ``kind`` is ``"reading"`` when the options are alternatives the text supports (each quoting it), or
    ``"sensitivity"`` when the factor sweeps an unstated tuning value over a range (e.g. the filters' process noise
    over decades): a sensitivity factor's options are not readings of the paper, so the table match and "the
    readings that reproduce" search only universes whose sensitivity factors are at the headline
    (:meth:`ReadingSpace.is_reading`), and its options are reported as their own curve (verdict against the swept
    value, :meth:`mmlib.experiment.multiverse.Multiverse.sensitivity`)."""

    id: str
    label: str
    options: tuple
    headline: str
    source: str
    influential: bool = True
    metric_only: bool = False
    kind: str = "reading"

    def __post_init__(self):
        _check_text(self, ("id", "label", "source"))
        check_choice(self.kind, "kind", FACTOR_KINDS)
        check_bool(self.influential, "influential")
        check_bool(self.metric_only, "metric_only")
        if isinstance(self.options, (str, bytes)) or not hasattr(self.options, "__iter__"):
            raise ValueError(f"options: factor {self.id!r} needs a sequence of Option objects, got {self.options!r}")
        if not isinstance(self.headline, str):
            raise ValueError(f"headline: expected an option name (a string), got {self.headline!r}")
        options = tuple(self.options)
        if len(options) < 2 or not all(isinstance(o, Option) for o in options):
            raise ValueError(f"options: factor {self.id!r} needs at least two Option objects, got {self.options!r}")
        names = [o.name for o in options]
        if len(set(names)) != len(names):
            raise ValueError(f"options: factor {self.id!r} repeats an option name: {names}")
        if self.headline not in names:
            raise ValueError(f"headline: factor {self.id!r} has no option {self.headline!r} (options: {names})")
        if options[names.index(self.headline)].motivated_by:
            raise ValueError(f"headline: factor {self.id!r}'s headline {self.headline!r} is motivated by "
                             f"{options[names.index(self.headline)].motivated_by!r}; the headline is chosen on the "
                             f"text alone")
        object.__setattr__(self, "options", options)

    @property
    def names(self) -> tuple:
        """The options' names, in declaration order."""
        return tuple(o.name for o in self.options)

    def option(self, name: str) -> Option:
        """The option called ``name``; ValueError (starting ``reading:``) listing the options otherwise."""
        for o in self.options:
            if o.name == name:
                return o
        raise ValueError(f"reading: factor {self.id!r} has no option {name!r} (options: {list(self.names)})")

    def as_dict(self) -> dict:
        """The factor as a JSON-able dict: its fields, the option names and ``option_details``
        (:meth:`Option.as_dict` of each)."""
        return {"id": self.id, "label": self.label, "options": list(self.names), "headline": self.headline,
                "source": self.source, "influential": self.influential, "metric_only": self.metric_only,
                "kind": self.kind,
                "option_details": [o.as_dict() for o in self.options]}


#: the design kinds :meth:`ReadingSpace.design` builds
DESIGN_KINDS = ("full", "sampled", "fractional", "star")

#: the design kinds whose universes are a uniform sample of the full factorial (or the full factorial itself):
#: the only ones shares of the reading space are computed from
UNIFORM_KINDS = ("full", "sampled")


def sample_seed(paper: str) -> int:
    """The default seed of a paper's uniform sample of universes: the first four bytes of the SHA-256 of the
    paper's name (UTF-8), read as a big-endian unsigned integer (0 <= seed < 2**32); stable across Python
    versions and machines, unlike ``hash``."""
    if not isinstance(paper, str) or not paper.strip():
        raise ValueError(f"paper: expected a non-empty string, got {paper!r}")
    return int.from_bytes(hashlib.sha256(paper.encode("utf-8")).digest()[:4], "big")


@dataclass(frozen=True)
class Design:
    """The universes to run: ``kind`` is "full", "sampled", "fractional" or "star"; ``description``
    states how they were chosen; ``readings`` lists them, the headline first, each once.

    ``sample`` holds the indices into ``readings`` of the universes counted in the shares of the reading
    space: every index for "full"; for "sampled", the uniform random sample of the full factorial (which may
    include the headline or a star reading: that universe is run once and counted); empty for "fractional"
    and "star" (no share is computed from them).  ``seed`` is the sample's seed ("sampled" only, else None)."""

    kind: str
    description: str
    readings: tuple
    sample: tuple = None
    seed: int | None = None

    def __post_init__(self):
        check_choice(self.kind, "kind", DESIGN_KINDS)
        _check_text(self, ("description",))
        if isinstance(self.readings, (str, bytes, Mapping)) or not hasattr(self.readings, "__iter__"):
            raise ValueError(f"readings: expected a sequence of readings (dicts factor id -> option), got "
                             f"{self.readings!r}")
        readings = tuple(self.readings)
        if not readings or not all(isinstance(r, Mapping) for r in readings):
            raise ValueError("readings: expected a non-empty sequence of readings (dicts factor id -> option), "
                             "the headline first")
        object.__setattr__(self, "readings", readings)
        sample = self.sample
        if sample is None:
            sample = range(len(readings)) if self.kind == "full" else ()
        if isinstance(sample, (str, bytes, Mapping)) or not hasattr(sample, "__iter__"):
            raise ValueError(f"sample: expected a sequence of indices into readings, got {sample!r}")
        sample = tuple(check_positive_int(i, "sample", minimum=0) for i in sample)
        if any(i >= len(readings) for i in sample) or len(set(sample)) != len(sample):
            raise ValueError(f"sample: expected distinct indices below {len(readings)} (the readings), got "
                             f"{list(sample)}")
        if self.kind == "full" and sorted(sample) != list(range(len(readings))):
            raise ValueError("sample: a full design counts every universe")
        if self.kind == "sampled" and not sample:
            raise ValueError("sample: a sampled design needs the indices of its sampled universes")
        if self.kind in ("fractional", "star") and sample:
            raise ValueError(f"sample: a {self.kind} design is not a uniform sample; it counts no universe")
        if self.seed is not None:
            object.__setattr__(self, "seed", check_positive_int(self.seed, "seed", minimum=0))
        if (self.seed is None) != (self.kind != "sampled"):
            raise ValueError(f"seed: a sampled design records its seed, no other design has one (kind "
                             f"{self.kind!r}, seed {self.seed!r})")
        object.__setattr__(self, "sample", sample)

    def __len__(self):
        return len(self.readings)

    @property
    def uniform(self) -> bool:
        """True when the counted universes are the full factorial or a uniform sample of it (shares may be
        computed), False for a covering or star design."""
        return self.kind in UNIFORM_KINDS


@dataclass(frozen=True)
class ReadingSpace:
    """The full factorial product of a paper's factors, with a budget of universes.

    ``budget`` is the number of universes of the full factorial the paper's run affords: the full factorial is
    run when it has at most ``budget`` universes, otherwise a uniform random sample of ``budget`` of them (the
    "sampled" design; the headline and the star are run in addition and reported apart).  ``None`` means no
    limit (the full factorial is always run)."""

    paper: str
    factors: tuple
    budget: int | None = None

    def __post_init__(self):
        _check_text(self, ("paper",))
        if isinstance(self.factors, (str, bytes)) or not hasattr(self.factors, "__iter__"):
            raise ValueError(f"factors: expected a non-empty sequence of Factor objects, got {self.factors!r}")
        factors = tuple(self.factors)
        if not factors or not all(isinstance(f, Factor) for f in factors):
            raise ValueError(f"factors: expected a non-empty sequence of Factor objects, got {self.factors!r}")
        ids = [f.id for f in factors]
        if len(set(ids)) != len(ids):
            raise ValueError(f"factors: repeated factor id in {ids}")
        if self.budget is not None:
            object.__setattr__(self, "budget", check_positive_int(self.budget, "budget"))
        object.__setattr__(self, "factors", factors)
        object.__setattr__(self, "_designs", {})          # designs are deterministic: computed once

    # -- readings ---------------------------------------------------------------------------------------------
    @property
    def ids(self) -> tuple:
        """The factor ids, in declaration order."""
        return tuple(f.id for f in self.factors)

    def factor(self, factor_id: str) -> Factor:
        """The factor with id ``factor_id``; ValueError (starting ``reading:``) listing the ids otherwise."""
        for f in self.factors:
            if f.id == factor_id:
                return f
        raise ValueError(f"reading: unknown factor {factor_id!r} (factors: {list(self.ids)})")

    @property
    def headline(self) -> dict:
        """The headline reading: factor id -> headline option name, in factor order."""
        return {f.id: f.headline for f in self.factors}

    @property
    def size(self) -> int:
        """Number of universes of the full factorial product."""
        return math.prod(len(f.options) for f in self.factors)

    def validate(self, reading: Mapping) -> dict:
        """The reading in factor order; ValueError naming any unknown factor, unknown option or
        missing factor."""
        if not isinstance(reading, Mapping):
            raise ValueError(f"reading: expected a mapping factor id -> option name, got {reading!r}")
        for fid in reading:
            self.factor(fid)
        missing = [f.id for f in self.factors if f.id not in reading]
        if missing:
            raise ValueError(f"reading: leaves out factor(s) {missing}; a reading names every factor "
                             f"(use ReadingSpace.with_headline to fill the rest with headline options)")
        out = {}
        for f in self.factors:
            f.option(reading[f.id])
            out[f.id] = reading[f.id]
        return out

    def with_headline(self, **changes: str) -> dict:
        """The headline reading with some factors changed: ``space.with_headline(**{"L-1": "100s"})``."""
        return self.validate({**self.headline, **changes})

    def changes(self, reading: Mapping) -> dict:
        """Set-up parameters of a reading: the merged ``Option.changes`` of its options.  Two
        options setting the same parameter to different values is a declaration error."""
        reading = self.validate(reading)
        merged, by = {}, {}
        for f in self.factors:
            for key, value in f.option(reading[f.id]).changes.items():
                if key in merged and merged[key] != value:
                    raise ValueError(f"reading: factors {by[key]!r} and {f.id!r} both set {key!r}")
                merged[key], by[key] = value, f.id
        return merged

    def differs(self, reading: Mapping) -> list:
        """Factor ids in which ``reading`` differs from the headline."""
        reading = self.validate(reading)
        return [fid for fid, opt in reading.items() if opt != self.headline[fid]]

    def motivated(self, reading: Mapping) -> list:
        """Factor ids whose option in ``reading`` is motivated by the results or by another paper
        (:attr:`Option.motivated_by`)."""
        reading = self.validate(reading)
        return [f.id for f in self.factors if f.option(reading[f.id]).motivated_by]

    def is_reading(self, reading: Mapping) -> bool:
        """Whether ``reading`` is a reading of the text alone: every sensitivity factor (:attr:`Factor.kind`) at its
        headline and no option motivated by the results or another paper.  Only such universes are searched by
        the table match and counted among "the readings that reproduce"."""
        reading = self.validate(reading)
        return not self.motivated(reading) and all(reading[f.id] == f.headline for f in self.factors
                                                   if f.kind == "sensitivity")

    @property
    def sensitivity_ids(self) -> tuple:
        """The ids of the sensitivity factors (:attr:`Factor.kind`), in declaration order."""
        return tuple(f.id for f in self.factors if f.kind == "sensitivity")

    def simulation_key(self, reading: Mapping) -> tuple:
        """The reading without its metric-only factors: universes with equal keys run the same simulation."""
        reading = self.validate(reading)
        metric = {f.id for f in self.factors if f.metric_only}
        return tuple((fid, opt) for fid, opt in reading.items() if fid not in metric)

    def describe_simulation(self, reading: Mapping) -> str:
        """:meth:`describe` of the reading with its metric-only factors at their headline option."""
        reading = self.validate(reading)
        return self.describe({**reading, **{f.id: f.headline for f in self.factors if f.metric_only}})

    def describe(self, reading: Mapping) -> str:
        """Short text: 'headline' or the options that differ from it ("L-1: maneuver at 100 s; ...")."""
        diff = self.differs(reading)
        if not diff:
            return "headline"
        return "; ".join(f"{fid}: {self.factor(fid).option(reading[fid]).label}" for fid in diff)

    # -- designs ----------------------------------------------------------------------------------------------
    def full(self) -> list:
        """Every reading, the headline first, then in factor-major order."""
        grid = [dict(zip(self.ids, combo)) for combo in itertools.product(*(f.names for f in self.factors))]
        head = self.headline
        return [head] + [r for r in grid if r != head]

    def star(self) -> list:
        """The headline and every option of every factor varied alone (one factor at a time)."""
        out = [self.headline]
        for f in self.factors:
            out += [self.with_headline(**{f.id: o}) for o in f.names if o != f.headline]
        return out

    def _greedy(self, chosen: list, strength: int, limit: int | None = None) -> list:
        """Add readings to ``chosen`` greedily, each covering the most not yet covered combinations of
        ``strength`` options of as many influential factors, until all are covered or ``limit``
        readings are chosen.  Candidates are the product of the influential factors' options (the
        others at their headline option); ties go to the earliest candidate in that product's order,
        so the result is deterministic."""
        infl = [f for f in self.factors if f.influential]
        if len(infl) < strength:
            return chosen
        names = [f.names for f in infl]
        sizes = [len(n) for n in names]
        grid = np.array(list(itertools.product(*(range(k) for k in sizes))), dtype=np.int64)
        combos = list(itertools.combinations(range(len(infl)), strength))
        codes = np.empty((len(grid), len(combos)), dtype=np.int64)
        offset = 0
        for t, cols in enumerate(combos):           # one integer per (factor combination, options)
            code, mult = np.zeros(len(grid), dtype=np.int64), 1
            for c in reversed(cols):
                code += grid[:, c] * mult
                mult *= sizes[c]
            codes[:, t] = code + offset
            offset += mult
        covered = np.zeros(offset, dtype=bool)
        for r in chosen:
            covered[codes[np.ravel_multi_index([names[j].index(r[f.id]) for j, f in enumerate(infl)], sizes)]] = True
        head = self.headline
        while limit is None or len(chosen) < limit:
            gain = (~covered[codes]).sum(axis=1)
            best = int(np.argmax(gain))
            if gain[best] == 0:                         # everything covered (a chosen reading gains nothing)
                break
            chosen.append({**head, **{f.id: names[j][grid[best, j]] for j, f in enumerate(infl)}})
            covered[codes[best]] = True
        return chosen

    def covering(self) -> list:
        """The star, then greedily chosen readings until every pair of options of every two
        influential factors occurs in some reading (a strength-2 covering array)."""
        return self._greedy(self.star(), 2)

    def reading_at(self, index: int) -> dict:
        """The reading of flat index ``index`` of the full factorial (0 <= index < :attr:`size`): the mixed-radix
        number whose digits are the option positions, the first factor most significant (the order of
        ``itertools.product`` over the factors' options)."""
        index = check_positive_int(index, "index", minimum=0)
        if index >= self.size:
            raise ValueError(f"index: expected an integer below the {self.size} universes, got {index}")
        digits = np.unravel_index(index, [len(f.options) for f in self.factors])
        return {f.id: f.names[int(d)] for f, d in zip(self.factors, digits)}

    def index_of(self, reading: Mapping) -> int:
        """The flat index of ``reading`` in the full factorial (inverse of :meth:`reading_at`)."""
        reading = self.validate(reading)
        return int(np.ravel_multi_index([f.names.index(reading[f.id]) for f in self.factors],
                                        [len(f.options) for f in self.factors]))

    def sample(self, n: int, seed: int) -> list:
        """A uniform random sample without replacement of ``n`` universes of the full factorial (every set of
        ``n`` distinct universes equally likely), drawn by ``numpy.random.Generator(PCG64(seed)).choice`` over the
        flat indices (:meth:`reading_at`) and returned in increasing index order.  Deterministic given ``seed``
        (an integer >= 0); ``n`` from 1 to :attr:`size`."""
        n = check_positive_int(n, "n")
        seed = check_positive_int(seed, "seed", minimum=0)
        if n > self.size:
            raise ValueError(f"n: a sample of {n} from only {self.size} universes")
        idx = np.random.Generator(np.random.PCG64(seed)).choice(self.size, size=n, replace=False)
        return [self.reading_at(int(i)) for i in np.sort(idx)]

    def design(self, kind: str = "auto", *, sample_size: int | None = None, seed: int | None = None) -> Design:
        """``"auto"``: the full factorial when it has at most ``sample_size`` universes (default: the
        ``budget``), else the sampled design; ``"full"``, ``"sampled"``, ``"fractional"`` or ``"star"`` force one.

        The sampled design runs the star (:meth:`star`: the headline and every option varied alone, reported
        apart) and a uniform random sample (:meth:`sample`) of ``sample_size`` universes (default: the budget)
        of the full factorial with ``seed`` (default :func:`sample_seed` of the paper's name); a sampled
        universe that is also a star reading is run once and counted.  ``Design.sample`` lists the counted
        universes.  The fractional design is the covering design (:meth:`covering`), then, while the budget
        allows, readings adding the most uncovered combinations of three influential factors' options (towards a
        strength-3 covering array), so that the budget is spent on interactions; it counts no universe."""
        if kind not in ("auto",) + DESIGN_KINDS:
            raise ValueError(f"kind: expected 'auto', 'full', 'sampled', 'fractional' or 'star', got {kind!r}")
        if sample_size is not None:
            sample_size = check_positive_int(sample_size, "sample_size")
        if seed is not None:
            seed = check_positive_int(seed, "seed", minimum=0)
        n = sample_size if sample_size is not None else self.budget
        if kind == "auto":
            kind = "full" if n is None or self.size <= n else "sampled"
        if kind == "sampled":
            if n is None:
                raise ValueError("sample_size: a sampled design needs a sample size (the space declares no budget)")
            n, seed = min(n, self.size), sample_seed(self.paper) if seed is None else seed
        key = (kind, n, seed) if kind == "sampled" else kind
        if key in self._designs:
            return self._designs[key]
        if kind == "full":
            d = Design("full", f"full factorial: {self.size} universes", tuple(self.full()))
        elif kind == "star":
            s = self.star()
            d = Design("star", f"headline and each of the {len(s) - 1} other options varied alone "
                               f"({len(s)} of {self.size} universes)", tuple(s))
        elif kind == "sampled":
            star = self.star()
            drawn = self.sample(n, seed)
            keys = [tuple(r.values()) for r in star]
            readings, sample = list(star), []
            for r in drawn:
                k = tuple(r.values())
                if k in keys:
                    sample.append(keys.index(k))
                else:
                    sample.append(len(readings))
                    readings.append(r)
                    keys.append(k)
            both = sum(i < len(star) for i in sample)
            d = Design("sampled",
                       f"uniform random sample of {n} of the {self.size} universes (without replacement, seed {seed}), "
                       f"counted in the shares; and the headline with every option varied alone ({len(star)} "
                       f"universes, reported apart{f'; {both} of them drawn in the sample too' if both else ''}): "
                       f"{len(readings)} universes run", tuple(readings), tuple(sample), seed)
        else:
            c = self.covering()
            n2 = len(c)
            if self.budget is not None and n2 < self.budget:
                c = self._greedy(c, 3, limit=min(self.budget, self.size))
            infl = [f.id for f in self.factors if f.influential]
            fill = ("" if len(c) == n2 else
                    f"; then {len(c) - n2} universes adding the most uncovered three-factor combinations, up to the "
                    f"budget of {self.budget}")
            d = Design("fractional",
                       f"{len(c)} of {self.size} universes: the headline, every option varied alone, and greedily "
                       f"added universes until every two-factor combination of options of the influential factors "
                       f"({', '.join(infl)}) occurs at least once (strength-2 covering array, {n2} universes){fill}",
                       tuple(c))
        self._designs[key] = d
        return d

    def as_dict(self) -> list:
        """:meth:`Factor.as_dict` of every factor, in order (the ``factors`` of a results file)."""
        return [f.as_dict() for f in self.factors]
