"""What one universe of a paper's reading space produces: a typed, immutable :class:`UniverseResult`.

A universe is one reading of a paper run for ``n_runs`` Monte Carlo runs.  Its result holds

* ``values``: one :class:`Value` per published number it replicates (``item``, ``algorithm``, ``quantity``
  match a :class:`PublishedNumber`), with the Monte Carlo standard error, or the reason it could not be produced;
* ``claims``: the paper's claims, each a :class:`JudgedClaim` in the claim vocabulary of
  :mod:`mmlib.experiment.verdicts`;
* ``effects``: named paired differences with standard errors (:class:`Effect`, for the specification curve);
* ``diverged``: the diverged runs per algorithm, and ``n_runs``.

It becomes JSON only at the cache boundary (:meth:`UniverseResult.as_json`, :meth:`UniverseResult.from_json`,
used by :func:`mmlib.experiment.grid.run_grid`); the JSON layout is the ``universes`` entry of
``data/results/<paper>.json`` (``docs/results-contract.md``).
"""
from __future__ import annotations

import math
import types
from dataclasses import dataclass, field
from typing import Any, Iterable, Mapping, NamedTuple

import numpy as np

from mmlib.core._validate import as_float_array, check_count, check_positive_int
from mmlib.experiment import verdicts

__all__ = [
    "UniverseResult", "PublishedNumber", "Value", "JudgedClaim", "Effect", "finite_or_none", "items", "JSON_KEYS"
]


class PublishedNumber(NamedTuple):
    """A number printed in the paper: ``table`` groups cells for the table match (e.g.
    "Table 1"), ``item``/``algorithm``/``quantity`` match a universe's value, ``printed`` is the
    text as printed (its last digit sets the rounding uncertainty)."""

    table: str
    item: str
    algorithm: str
    quantity: str
    printed: str

    @property
    def key(self) -> tuple:
        """``(item, algorithm, quantity)``: what a universe's value must match."""
        return (self.item, self.algorithm, self.quantity)


class Value(NamedTuple):
    """A universe's replication of one published number: ``replicated`` ± ``stderr`` (the number's unit), None
    when it could not be produced, with ``failed`` saying why (e.g. "diverged in 20/20 runs")."""

    item: str
    algorithm: str
    quantity: str
    replicated: float | None
    stderr: float | None
    failed: str | None = None

    @property
    def key(self) -> tuple:
        """``(item, algorithm, quantity)``, as :attr:`PublishedNumber.key`."""
        return (self.item, self.algorithm, self.quantity)


class JudgedClaim(NamedTuple):
    """A claim of the paper, its verdict (one term of the claim vocabulary,
    :class:`mmlib.experiment.verdicts.ClaimVerdict`) and the decisive number or reason that produced it
    (:class:`mmlib.experiment.verdicts.Judgement`), and its stable name ``key``
    (:meth:`mmlib.experiment.verdicts.Claims.add`; "" when the universe's claims were given without one)."""

    claim: str
    verdict: str
    decisive: str = ""
    key: str = ""


class Effect(NamedTuple):
    """A named paired difference ``value`` ± ``stderr`` and the paper's counterpart ``published`` (None if it
    prints none)."""

    name: str
    value: float | None
    stderr: float | None
    published: float | None = None


def finite_or_none(x: Any) -> float | None:
    """``x`` as a float, or None when it is None, NaN or infinite (JSON has no NaN)."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def _number_or_none(x, name: str):
    """A real number (Python or numpy, or a 0-d array) as :func:`finite_or_none` stores it, or None; a string, a
    bool, an array or any other object is a ValueError naming ``name``."""
    if x is None:
        return None
    if isinstance(x, (bool, np.bool_)):
        raise ValueError(f"{name}: expected a number or None, got {x!r}")
    arr = as_float_array(x, name)
    if arr.ndim != 0:
        raise ValueError(f"{name}: expected a number or None, got an array of shape {arr.shape}")
    return finite_or_none(x)


def _text(x, name: str) -> str:
    if not isinstance(x, str):
        raise ValueError(f"{name}: expected a string, got {x!r}")
    return x


def items(value: Any, name: str, what: str) -> list:
    """``value`` as a list, or ValueError naming ``name`` when it is a string, a mapping or not iterable."""
    if isinstance(value, (str, bytes, Mapping)) or not hasattr(value, "__iter__"):
        raise ValueError(f"{name}: expected a sequence of {what}, got {value!r}")
    return list(value)


def _tuple_of(entry, name: str, sizes: tuple, what: str) -> tuple:
    if isinstance(entry, (str, bytes)) or not isinstance(entry, (tuple, list)) or len(entry) not in sizes:
        raise ValueError(f"{name}: expected {what}, got {entry!r}")
    return tuple(entry)


@dataclass(frozen=True)
class UniverseResult:
    """The result of one universe (see the module docstring); build it with :meth:`build`, which validates."""

    values: tuple[Value, ...]
    claims: tuple[JudgedClaim, ...]
    effects: tuple[Effect, ...]
    diverged: Mapping[str, int]
    n_runs: int
    #: why the universe is degenerate (:func:`mmlib.experiment.evaluation.degenerate_reason`), "" when it is not
    degenerate: str = ""
    #: the fingerprint of the machine that computed it, when not this process's (:mod:`mmlib.experiment.machine`)
    machine: Mapping[str, Any] | None = field(default=None, compare=False)

    @classmethod
    def build(cls, *, values: Iterable[tuple], claims: Iterable[Any], diverged: Mapping[str, int],
              effects: Iterable[tuple] = (), n_runs: int, degenerate: str = "") -> UniverseResult:
        """Validated result: ``values`` of ``(item, algorithm, quantity, replicated, stderr[, failed])`` (a
        ``failed`` reason marks a value the method was run for but could not produce: verdict "not reproduced:
        <reason>", infinite distance); ``claims`` a :class:`mmlib.experiment.verdicts.Claims`, :class:`JudgedClaim`
        s or dicts with ``claim`` and ``verdict``; ``diverged`` algorithm -> diverged runs (at most ``n_runs``);
        ``effects`` of ``(name, value, stderr[, published])``; ``degenerate`` the reason the universe is degenerate
        (every estimator no better than a no-information baseline: its comparisons are kept out of the shares), ""
        when it is not.  Numbers become floats; NaN and infinities None."""
        n_runs = check_positive_int(n_runs, "n_runs")
        if not isinstance(degenerate, str):
            raise ValueError(f"degenerate: expected the reason (a string, '' when not degenerate), got {degenerate!r}")
        what = "(item, algorithm, quantity, replicated, stderr[, failed])"
        vals = []
        for i, v in enumerate(items(values, "values", what)):
            item, alg, qty, rep, se, *failed = _tuple_of(v, f"values[{i}]", (5, 6), what)
            vals.append(Value(_text(item, f"values[{i}].item"), _text(alg, f"values[{i}].algorithm"),
                              _text(qty, f"values[{i}].quantity"), _number_or_none(rep, f"values[{i}].replicated"),
                              _number_or_none(se, f"values[{i}].stderr"),
                              str(failed[0]) if failed and failed[0] else None))
        cls_ = []
        for i, c in enumerate(items(claims, "claims", "claims (Claims, or dicts with 'claim' and 'verdict')")):
            if isinstance(c, JudgedClaim):
                c = c._asdict()
            if not isinstance(c, Mapping) or "claim" not in c or "verdict" not in c:
                raise ValueError(f"claims[{i}]: expected a dict with 'claim' and 'verdict', got {c!r}")
            text = _text(c["verdict"], f"claims[{i}].verdict")
            cat = verdicts.claim_category(text)
            decisive = c.get("decisive") or (text.split(":", 1)[1].strip() if ":" in text else "")
            key = c.get("key") or ""
            if key:
                verdicts.check_claim_key(key, f"claims[{i}].key")
            cls_.append(JudgedClaim(_text(c["claim"], f"claims[{i}].claim"), str(cat),
                                    _text(decisive, f"claims[{i}].decisive") if decisive else "", key))
        effs = []
        for i, e in enumerate(items(effects, "effects", "(name, value, stderr[, published])")):
            name, value, se, *pub = _tuple_of(e, f"effects[{i}]", (3, 4), "(name, value, stderr[, published])")
            effs.append(Effect(_text(name, f"effects[{i}].name"), _number_or_none(value, f"effects[{i}].value"),
                               _number_or_none(se, f"effects[{i}].stderr"),
                               _number_or_none(pub[0], f"effects[{i}].published") if pub else None))
        try:
            diverged = dict(diverged)
        except (TypeError, ValueError):
            raise ValueError(f"diverged: expected a dict algorithm -> number of diverged runs, got {diverged!r}") \
                from None
        div = {str(k): check_count(v, f"diverged[{k!r}]", n_runs) for k, v in diverged.items()}
        return cls(tuple(vals), tuple(cls_), tuple(effs), types.MappingProxyType(div), n_runs, degenerate)

    # -- lookups ----------------------------------------------------------------------------------------------
    def value(self, key: tuple) -> Value | None:
        """The value whose ``(item, algorithm, quantity)`` is ``key`` (:attr:`PublishedNumber.key`), or None."""
        if not (isinstance(key, tuple) and len(key) == 3):
            raise ValueError(f"key: expected (item, algorithm, quantity) (PublishedNumber.key), got {key!r}")
        return next((v for v in self.values if v.key == key), None)

    def effect(self, name: str) -> Effect:
        """The effect called ``name``; ValueError naming the known effects otherwise."""
        for e in self.effects:
            if e.name == name:
                return e
        raise ValueError(f"effect: no effect {name!r} (effects: {[e.name for e in self.effects]})")

    def claim(self, claim: str) -> str:
        """The verdict of ``claim``; ValueError naming the known claims otherwise."""
        for c in self.claims:
            if c.claim == claim:
                return c.verdict
        raise ValueError(f"claim: no claim {claim!r} (claims: {[c.claim for c in self.claims]})")

    def __reduce__(self):
        # field by field (a read-only mapping cannot be pickled, and results travel between worker processes)
        return (_rebuild, (self.values, self.claims, self.effects, dict(self.diverged), self.n_runs,
                           None if self.machine is None else dict(self.machine), self.degenerate))

    # -- the cache boundary -----------------------------------------------------------------------------------
    def as_json(self) -> dict:
        """The JSON form (the ``universes`` entries of a results file without ``reading``)."""
        doc = {"values": [{"item": v.item, "algorithm": v.algorithm, "quantity": v.quantity,
                           "replicated": v.replicated, "stderr": v.stderr, **({"failed": v.failed} if v.failed else {})}
                          for v in self.values],
               "claims": [{k: v for k, v in c._asdict().items() if k != "key" or v} for c in self.claims],
               "effects": [e._asdict() for e in self.effects],
               "diverged": dict(self.diverged), "n_runs": self.n_runs}
        if self.degenerate:
            doc["degenerate"] = self.degenerate
        if self.machine is not None:
            doc["machine"] = dict(self.machine)
        return doc

    @classmethod
    def from_json(cls, doc: Mapping) -> UniverseResult:
        """The result of :meth:`as_json` (or of a results file's universe entry; ``reading`` is ignored),
        validated as :meth:`build` does."""
        if not isinstance(doc, Mapping):
            raise ValueError(f"doc: expected a universe result's JSON object, got {type(doc).__name__}")
        missing = [k for k in JSON_KEYS if k not in doc]
        if missing:
            raise ValueError(f"doc: expected a universe result's JSON object, lacking {', '.join(missing)}")
        try:
            vals = [(v["item"], v["algorithm"], v["quantity"], v["replicated"], v["stderr"], v.get("failed"))
                    for v in doc["values"]]
            effs = [(e["name"], e["value"], e["stderr"], e.get("published")) for e in doc["effects"]]
        except (KeyError, TypeError) as err:
            raise ValueError(f"doc: a value or an effect lacks {err}") from None
        out = cls.build(values=vals, claims=doc["claims"], effects=effs, diverged=doc["diverged"],
                        n_runs=doc["n_runs"], degenerate=doc.get("degenerate", ""))
        machine = doc.get("machine")
        return out if machine is None else _with_machine(out, machine)


def _rebuild(values, claims, effects, diverged, n_runs, machine, degenerate="") -> UniverseResult:
    """A pickled :class:`UniverseResult`, unchanged (no validation: what was built is what arrives)."""
    return UniverseResult(values, claims, effects, types.MappingProxyType(diverged), n_runs, degenerate,
                          None if machine is None else types.MappingProxyType(machine))


def _with_machine(result: UniverseResult, machine: Mapping) -> UniverseResult:
    """``result`` marked as computed on the machine of fingerprint ``machine``."""
    return UniverseResult(result.values, result.claims, result.effects, result.diverged, result.n_runs,
                          result.degenerate, types.MappingProxyType(dict(machine)))


#: the keys of a universe result's JSON object
JSON_KEYS = ("values", "claims", "effects", "diverged", "n_runs")
