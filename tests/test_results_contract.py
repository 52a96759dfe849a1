"""The results contract: the JSON Schema mmlib/experiment/results.schema.json and its one reader,
:func:`mmlib.experiment.results.read_results`.

* every committed results file (``data/results/*.json``, whatever files are there) validates, both with the library's
  own validator and with the reference one (jsonschema, draft 2020-12); a paper's also as complete
  (``$defs/complete_paper_results``);
* the schema is a valid draft 2020-12 schema, documented, and says what the code says: the verdict vocabularies of
  mmlib/experiment/verdicts.py and the row keys write_results requires; a document write_results writes reads back;
* a broken document (a missing key, a wrong type, a verdict outside the vocabulary, ...) is rejected naming the file
  and the JSON path of the violation, and the library's validator and jsonschema agree on what is valid;
* a corrupted file (truncated, a stray character, bytes that are not UTF-8, NaN, empty) is a ValueError naming the
  file and the position;
* the readers of the tools -- the site builder, the report renderer and the notebook runner -- surface that message.
"""
from __future__ import annotations

import copy
import dataclasses
import importlib.util
import json
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from jsonschema import Draft202012Validator

from mmlib.experiment import report, results
from mmlib.experiment.results import read_results, validate_results

REPO = Path(__file__).resolve().parents[1]
RESULTS = sorted((REPO / "data" / "results").glob("*.json"))
SCHEMA_FILE = REPO / "mmlib" / "experiment" / "results.schema.json"


def load_tool(name: str):
    """tools/<name>.py as a module (the tools are scripts, not a package)."""
    spec = importlib.util.spec_from_file_location(name, REPO / "tools" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault(name, module)          # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def schema() -> dict:
    return json.loads(SCHEMA_FILE.read_text())


@pytest.fixture(scope="module")
def reference(schema):
    """jsonschema's validators of the whole contract and of a complete paper's results."""
    return (Draft202012Validator(schema),
            Draft202012Validator({**schema, "$ref": "#/$defs/complete_paper_results"}))


def committed(name: str) -> dict:
    return json.loads((REPO / "data" / "results" / name).read_text())


def small(doc: dict) -> dict:
    """A valid copy of a committed document cut down (a few rows, universes, cells) for fast validation."""
    doc = copy.deepcopy(doc)
    doc["rows"] = doc["rows"][:6]
    if "multiverse" in doc:
        mv = doc["multiverse"]
        mv["universes"] = mv["universes"][:2]
        for key in ("claims_summary", "numbers_summary", "table_match", "factors"):
            mv[key] = mv[key][:2]
    for key in ("cells", "ideas", "scenarios", "paper_claims"):
        if key in doc:
            doc[key] = doc[key][:3] if key != "cells" else [c for c in doc[key] if "reason" in c][:2] + \
                [c for c in doc[key] if "reason" not in c][:2]
    return doc


# ------------------------------------------------------------------------------------------- the committed files
def test_there_are_committed_results():
    assert RESULTS, "no data/results/*.json: nothing to check the contract against"
    assert "arena.json" in [p.name for p in RESULTS]


@pytest.mark.parametrize("path", RESULTS, ids=[p.name for p in RESULTS])
def test_committed_results_validate(path, reference):
    doc = read_results(path, name=f"data/results/{path.name}")     # the library's reader and validator
    whole, complete = reference
    # a paper's document against the complete contract alone: that schema is the whole one plus its $ref, so it
    # passes only what the whole one passes (one pass over the largest files, not two); the whole one then names
    # what breaks the contract itself, apart from what is incomplete
    if doc.get("kind") != "arena" and complete.is_valid(doc):
        return
    problems = [f"{'/'.join(map(str, e.absolute_path))}: {e.message[:200]}" for e in whole.iter_errors(doc)]
    assert not problems, f"data/results/{path.name}:\n" + "\n".join(problems[:10])
    if doc.get("kind") != "arena":
        problems = [f"{'/'.join(map(str, e.absolute_path))}: {e.message[:200]}" for e in complete.iter_errors(doc)]
        assert not problems, f"data/results/{path.name} is not complete:\n" + "\n".join(problems[:10])


def test_the_complete_contract_holds_the_whole_one(reference):
    """test_committed_results_validate checks a paper's document against the complete contract alone: a document
    breaking the whole contract at its root (a key missing, a wrong type) breaks the complete one too, and so does one
    that only the whole contract's root keywords catch (a paper's document calling itself the arena's: its "if" on
    ``kind``), which the complete definition on its own would pass -- the complete schema applies the root's keywords
    beside its $ref, as draft 2020-12 says, and is the whole schema plus that $ref."""
    whole, complete = reference
    doc = small(committed("hu2017.json"))
    assert whole.is_valid(doc) and complete.is_valid(doc)
    for broken in ({k: v for k, v in doc.items() if k != "rows"}, {**doc, "paper": 3}, {**doc, "claims": "none"}):
        assert not whole.is_valid(broken) and not complete.is_valid(broken)
    root_only = {**doc, "kind": "arena"}
    definition_alone = Draft202012Validator({"$defs": whole.schema["$defs"], "$ref": "#/$defs/complete_paper_results"})
    assert definition_alone.is_valid(root_only)
    assert not whole.is_valid(root_only) and not complete.is_valid(root_only)
    assert complete.schema["$ref"] == "#/$defs/complete_paper_results"
    assert {k: v for k, v in complete.schema.items() if k != "$ref"} == whole.schema


# ------------------------------------------------------------------------------------------------- the schema
def _subschemas(node, where="#"):
    """Every schema object of the schema (the values of properties/$defs maps are schemas, the maps are not)."""
    if isinstance(node, dict):
        yield where, node
        for key, value in node.items():
            if key in ("properties", "$defs"):
                for name, sub in value.items():
                    yield from _subschemas(sub, f"{where}/{key}/{name}")
            elif key in ("allOf", "anyOf", "oneOf"):
                for i, sub in enumerate(value):
                    yield from _subschemas(sub, f"{where}/{key}/{i}")
            elif key in ("items", "additionalProperties", "not", "if", "then", "else") and isinstance(value, dict):
                yield from _subschemas(value, f"{where}/{key}")


def test_schema_is_a_documented_draft_2020_12_schema(schema):
    Draft202012Validator.check_schema(schema)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    undocumented = [name for name, sub in schema["$defs"].items() if not (sub.get("description") or sub.get("title"))]
    assert schema["description"] and not undocumented, f"$defs without a description: {undocumented}"
    # the top-level sections of a paper and the arena are documented where they are defined
    for where in ("#/properties", "#/$defs/paper_results/properties", "#/$defs/arena_results/properties"):
        node = schema
        for part in where[2:].split("/"):
            node = node[part]
        bare = [k for k, sub in node.items()
                if not (sub.get("description") or "$ref" in sub or "const" in sub)]
        assert not bare, f"{where}: undocumented {bare}"


def test_schema_uses_only_keywords_the_library_validator_implements(schema):
    known = results._KEYWORDS | results._ANNOTATIONS
    used = {(where, key) for where, sub in _subschemas(schema) for key in sub if key not in known}
    assert not used, f"keywords read_results would refuse: {sorted(used)}"


def test_library_validator_refuses_a_keyword_it_does_not_implement():
    with pytest.raises(RuntimeError, match=r"'maxItems'.* not implemented"):
        list(results._violations([1, 2], {"type": "array", "maxItems": 1}, ()))


def test_schema_vocabularies_are_those_of_the_code(schema):
    """The verdict patterns are the vocabularies of mmlib/experiment/verdicts.py, and the arena's verdict."""
    defs = schema["$defs"]
    alternatives = "|".join(v.replace("(", r"\(").replace(")", r"\)") for v in report.VERDICTS)
    assert defs["number_verdict"]["pattern"] == f"^({alternatives})(:[\\s\\S]*)?$"
    assert defs["claim_verdict"]["pattern"] == f"^({'|'.join(report.CLAIM_VERDICTS)})$"
    assert defs["part"]["properties"]["verdict"]["enum"] == list(report.PartVerdict)
    number, claim = re.compile(defs["number_verdict"]["pattern"]), re.compile(defs["claim_verdict"]["pattern"])
    for text in ["reproduced", "not replicable: no method", report.verdict("2.0", 2.0, 0.001, 10, 10),
                 report.verdict("2.0", 9.0, 0.001), report.verdict("2.0", 2.3, 0.01), report.verdict("2.0", 2.0, 9.0),
                 report.verdict(None, None, None, reason="not published")]:
        assert number.search(text) and report.verdict_category(text), text
    parts = [report.part("A − B", "MSE", d, se, -1) for d, se in ((-1.0, 0.1), (1.0, 0.1), (0.0, 1.0),
                                                                     (float("nan"), 1.0))]
    for text in ["holds", *(report.judge([p]).verdict for p in parts), report.judge(parts[:3]).verdict]:
        assert claim.search(text) and report.claim_category(text), text
    assert not claim.search("partly: holds (a)")                        # one term, the detail is 'decisive'
    assert report.verdict_category("reproduced (exact)") == report.REPRODUCED_EXACT
    for text in ["Reproduced", "reproducedish", "roughly: reproduced", "holds"]:
        assert not number.search(text), text
    assert not claim.search("reproduced") and not claim.search("no detectable difference")


PROV = {"git_commit": "abc", "root_seed": 1, "n_runs": 10, "profile": "smoke"}


@pytest.mark.parametrize("key", ["item", "algorithm", "quantity", "paper", "replicated", "stderr", "verdict",
                                 "deviations"])
def test_write_results_refuses_what_breaks_the_contract(tmp_path, key):
    """write_results checks the document against the schema before writing: a row without a required key is a
    ValueError naming the file and the JSON path, and nothing is written."""
    row = dataclasses.asdict(report.make_row("Table 1", "A", "RMSE (m)", "2.0", 2.01, 0.01, n_runs=10,
                                             n_runs_paper=10))
    target = tmp_path / "x.json"
    with pytest.raises(ValueError, match=rf"^{re.escape(str(target))}: rows\[0\]"):
        report.write_results(target, paper="x", provenance=PROV, rows=[{k: v for k, v in row.items() if k != key}])
    assert not target.exists()


@pytest.mark.parametrize("value", [float("nan"), float("inf"), np.float64("nan")])
def test_write_results_names_a_non_finite_number(tmp_path, value):
    target = tmp_path / "x.json"
    with pytest.raises(ValueError, match=rf"^{re.escape(str(target))}: figures\.extra\.a\[1\]: .* not a finite"):
        report.write_results(target, paper="x", provenance=PROV, rows=[], figures={"extra": {"a": [1.0, value]}})
    assert not target.exists()


def test_what_write_results_writes_reads_back(tmp_path):
    claims = report.Claims()
    claims.add("A beats B", report.judge([report.part("A − B", "MSE", -1.0, 0.1, -1, reference=4.0)]),
               "paired difference", key="a_vs_b")
    rows = [report.make_row("Table 1", "A", "RMSE (m)", "2.0", 2.01, 0.01, n_runs=10, n_runs_paper=10,
                            deviations=["D-1"]),
            report.make_row("Table 1", "B", "RMSE (m)", "3.0", None, None, reason="not published"),
            report.analytic_row("Table 2", "A", "complexity", "O(n^3)", "cubic in n", True)]
    prov = {"git_commit": "abc", "root_seed": 1, "n_runs": 10, "profile": "smoke", "python": "3.11.7",
            "packages": {"numpy": "2.0", "numba": None}, "kernel": "numpy"}
    path = tmp_path / "data" / "results" / "toy2020.json"
    written = report.write_results(path, paper="toy2020", provenance=prov, rows=rows, claims=claims.as_list(),
                                   deviations=[{"id": "D-1", "topic": "t", "paper": "p", "choice": "c", "reason": "r"}],
                                   figures={}, extra_of_the_paper={"anything": [1, None]})
    assert read_results(path) == json.loads(json.dumps(written))


# ------------------------------------------------------------------------------------------- broken documents
def _set(doc, path, value):
    node = doc
    for key in path[:-1]:
        node = node[key]
    if value is KeyError:
        del node[path[-1]]
    else:
        node[path[-1]] = value


#: (file, where, new value or KeyError to delete, the message after the file's name)
BROKEN = [
    ("hu2017.json", ("rows", 3, "verdict"), KeyError, "rows[3].verdict: missing"),
    ("hu2017.json", ("rows", 3, "replicated"), "0.51",
     'rows[3].replicated: expected number or null, got string "0.51"'),
    ("hu2017.json", ("rows", 3, "verdict"), "roughly reproduced",
     'rows[3].verdict: string "roughly reproduced" is not a verdict of the number vocabulary'),
    ("hu2017.json", ("rows", 3, "verdict"), "not replicable: lost", "rows[3].verdict: must not be a 'not replicable'"),
    ("hu2017.json", ("rows", 0, "stderr"), -0.1, "rows[0].stderr: expected a number >= 0"),
    ("hu2017.json", ("rows", 1, "deviations"), "H-1", "rows[1].deviations: expected array"),
    ("hu2017.json", ("paper",), KeyError, "paper: missing"),
    ("hu2017.json", ("paper",), "hu_2017", 'paper: string "hu_2017" does not match'),
    ("hu2017.json", ("provenance", "git_commit"), KeyError, "provenance.git_commit: missing"),
    ("hu2017.json", ("provenance", "profile"), "quick", 'provenance.profile: expected one of "full", "smoke"'),
    ("hu2017.json", ("provenance", "n_runs"), 100.5, "provenance.n_runs: expected integer, got number 100.5"),
    ("hu2017.json", ("claims", 1, "verdict"), "reproduced",
     'claims[1].verdict: string "reproduced" is not a verdict of the claim vocabulary'),
    ("hu2017.json", ("claims", 1, "key"), KeyError, "claims[1].key: missing"),
    ("hu2017.json", ("claims", 1, "key"), "Obs vs UKF", 'claims[1].key: string "Obs vs UKF" does not match'),
    ("hu2017.json", ("deviations", 0, "reason"), KeyError, "deviations[0].reason: missing"),
    ("hu2017.json", ("figures", "fig01_model_probability_immukf", "files"), KeyError,
     "figures.fig01_model_probability_immukf.files: missing"),
    ("hu2017.json", ("digest", "sha256"), "abc", 'digest.sha256: string "abc" does not match'),
    ("hu2017.json", ("digest", "mean_squared_error"), KeyError, "digest.mean_squared_error: missing"),
    ("hu2017.json", ("digest", "machine"), KeyError, "digest.machine: missing"),
    ("hu2017.json", ("digest", "runs", "IMMUKF", "scale"), KeyError, "digest.runs.IMMUKF.scale: missing"),
    ("hu2017.json", ("digest", "diverged", "IMMUKF"), -1, 'digest.diverged.IMMUKF: expected a number >= 0'),
    ("hu2017.json", ("multiverse", "universes", 1, "claims", 0, "verdict"), "yes",
     "multiverse.universes[1].claims[0].verdict: "),
    ("hu2017.json", ("multiverse", "claims_summary", 0, "verdict_counts", "maybe"), 1,
     "multiverse.claims_summary[0].verdict_counts.maybe: not allowed here"),
    ("hu2017.json", ("multiverse", "design"), "random", "multiverse.design: expected one of"),
    ("arena.json", ("cells", 0, "rmse_position"), {"value": 1.0, "stderr": 0.1},
     "cells[0]: matches 2 alternatives where exactly one is allowed"),
    ("arena.json", ("cells", 0, "reason"), KeyError, "cells[0]: matches none of the alternatives"),
    ("arena.json", ("cells", 2, "rmse_position"), KeyError, "cells[2]: matches none of the alternatives"),
    ("arena.json", ("digest", "cells"), KeyError, "digest.cells: missing"),
    ("arena.json", ("findings",), [], "findings: expected at least 1 item(s), got 0"),
    ("arena.json", ("paper",), "arena2", 'paper: expected "arena", got string "arena2"'),
    ("arena.json", ("ideas", 0, "comparisons", 0, "verdict"), "better",
     'ideas[0].comparisons[0].verdict: string "better" is not a verdict of an arena comparison'),
    ("arena.json", ("paper_claims", 0, "pairs", 0, "verdicts", "ladder-nl1"), "nope",
     'paper_claims[0].pairs[0].verdicts["ladder-nl1"]: string "nope" is not a verdict of the claim vocabulary'),
]


@pytest.fixture(scope="module")
def docs() -> dict:
    return {name: small(committed(name)) for name in ("hu2017.json", "arena.json")}


@pytest.mark.parametrize("name, where, value, message", BROKEN,
                         ids=[f"{n.split('.')[0]}:{'.'.join(map(str, w))}" for n, w, _, _ in BROKEN])
def test_broken_document_is_rejected_naming_file_and_json_path(name, where, value, message, docs, reference,
                                                               tmp_path):
    doc = copy.deepcopy(docs[name])
    assert reference[0].is_valid(doc)
    _set(doc, where, value)
    assert not reference[0].is_valid(doc), "jsonschema accepts it: the case tests nothing"
    path = tmp_path / name
    path.write_text(json.dumps(doc, indent=1))
    shown = f"data/results/{name}"
    with pytest.raises(ValueError) as err:
        read_results(path, name=shown)
    assert str(err.value).startswith(f"{shown}: {message}"), str(err.value)
    with pytest.raises(ValueError, match=f"^{re.escape(message)}"):
        validate_results(doc)


def test_a_claim_key_names_one_claim(docs, tmp_path):
    """Two claims under one key (beyond JSON Schema, which cannot say it): the summaries would address either, so
    validate_results refuses it, naming the second claim's key."""
    doc = copy.deepcopy(docs["hu2017.json"])
    validate_results(doc)
    doc["claims"][1]["key"] = doc["claims"][0]["key"]
    message = f"claims[1].key: {doc['claims'][0]['key']!r} already names claims[0]"
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        validate_results(doc)
    path = tmp_path / "hu2017.json"
    path.write_text(json.dumps(doc, indent=1))
    with pytest.raises(ValueError, match=f"^{re.escape('data/results/hu2017.json: ' + message)}$"):
        read_results(path, name="data/results/hu2017.json")


@pytest.mark.parametrize("name, where, value", [
    ("hu2017.json", ("rows", 0, "a_paper_extra"), {"anything": [1, None]}),
    ("hu2017.json", ("an_extra_section",), [1, "two"]),
    ("hu2017.json", ("digest", "machine", "glibc"), "2.36"),
    ("hu2017.json", ("digest", "note"), "a field of a later digest version"),
    ("hu2017.json", ("rows", 0, "paper"), None),
    ("hu2017.json", ("rows", 0, "paper"), 1.25),
    ("hu2017.json", ("multiverse",), KeyError),
    ("arena.json", ("digest", "machine"), {"cpu": "x86-64"}),
    ("arena.json", ("cells", 2, "rmse_position"), None),
])
def test_paper_specific_extras_and_optional_values_are_allowed(name, where, value, docs, reference):
    doc = copy.deepcopy(docs[name])
    _set(doc, where, value)
    assert reference[0].is_valid(doc)
    validate_results(doc)


MUTATIONS = (None, "text", 1.5, 7, -3, True, [], {}, "not replicable: x", "holds", {"value": 1.0, "stderr": 0.1})


def _paths(doc, prefix=()):
    """The path of every node of a document."""
    items = doc.items() if isinstance(doc, dict) else enumerate(doc) if isinstance(doc, list) else ()
    for key, value in items:
        yield prefix + (key,)
        yield from _paths(value, prefix + (key,))


def _cut(doc, keep: dict, maps: set = frozenset(), where=()):
    """``doc`` with every array of objects or arrays cut to its first item, every array of numbers or strings to its
    first two (an interval is a pair), each object at a path of ``maps`` (an object keyed by data: see
    :func:`_maps`) to its first entry, or any of these to its first ``keep[where]`` items (``where`` its path in the
    cut document); the arena's cells to one with the reason it does not apply and one with metrics."""
    if isinstance(doc, dict):
        if isinstance(doc.get("cells"), list):
            doc = {**doc, "cells": [next(c for c in doc["cells"] if "reason" in c),
                                    next(c for c in doc["cells"] if "reason" not in c)]}
            keep = {where + ("cells",): 2, **keep}                   # both kinds of cell
        items = list(doc.items())
        if where in maps:
            items = items[:keep.get(where, 1)]
        return {k: _cut(v, keep, maps, where + (k,)) for k, v in items}
    if isinstance(doc, list):
        leaves = not any(isinstance(x, (dict, list)) for x in doc)
        return [_cut(x, keep, maps, where + (i,)) for i, x in enumerate(doc[:keep.get(where, 2 if leaves else 1)])]
    return doc


#: a key no object of the contract names, added by :func:`_maps` with a value no schema of the contract accepts
PROBE, PROBE_VALUE = "\x00probe", [[["\x00probe"]]]


def _maps(doc, validator) -> set:
    """The paths of the objects of ``doc`` keyed by data (counts by algorithm, verdicts by claim, a reading's options
    by factor): those whose schema gives any further key one schema (``additionalProperties`` a schema).  Found by
    ``validator`` itself: :data:`PROBE` is added to every object at once, and an object is a map where an error lies
    at or below that key, i.e. where the key's value was judged by a schema that applies to the object whatever else
    holds.  Errors inside a failed ``anyOf``/``oneOf`` are not read (a branch the object does not take may be a map
    of another shape): such a map stays whole.  An object that refuses the key (``additionalProperties: false``) or
    accepts anything there is not a map.  The probes may change no other judgement (an ``if`` on the number of keys
    would): any other error is a failure here."""
    def probed(node):
        if isinstance(node, dict):
            return {**{k: probed(v) for k, v in node.items()}, PROBE: PROBE_VALUE}
        return [probed(x) for x in node] if isinstance(node, list) else node
    found: set = set()
    for e in validator.iter_errors(probed(doc)):
        path = tuple(e.absolute_path)
        if PROBE in path:
            found.add(path[:path.index(PROBE)])
        else:
            assert e.validator in ("additionalProperties", "anyOf", "oneOf"), \
                f"the probe keys changed the judgement of {path} ({e.validator}: {e.message[:200]})"
    return found


def tiny(doc, validator):
    """A committed document cut by :func:`_cut` (its maps found by :func:`_maps`), with as many items as the schema's
    ``minItems`` asks where an array has fewer (read from ``validator``'s errors on the cut document, which restore
    the first items of that array): still valid, and small enough to mutate node by node (an item's nodes are those
    its siblings would have: one item of an array, or one entry of a map, covers the items' schema)."""
    keep: dict = {}
    maps = _maps(_cut(doc, keep), validator)
    while True:
        base = _cut(doc, keep, maps)
        short = {tuple(e.absolute_path): e.validator_value for e in validator.iter_errors(base)
                 if e.validator == "minItems"}
        if not short:
            return base
        assert not set(short) & set(keep), f"minItems not met by the committed document at {sorted(short)}"
        keep.update(short)


@pytest.mark.parametrize("name", ["hu2017.json", "arena.json"])
def test_library_validator_agrees_with_jsonschema(name, reference):
    """Every node of a committed document deleted, and replaced by values of other types and vocabularies (a text also
    by the empty text): the validator of read_results accepts exactly what the reference validator accepts (the
    library reads results without jsonschema, not by other rules)."""
    base = tiny(committed(name), reference[0])
    assert reference[0].is_valid(base)
    if name == "arena.json":                  # a cell of each kind is mutated: the one not applicable and the metrics
        assert [("reason" in c) for c in base["cells"]] == [True, False]
    outcomes, disagreements = [], []
    paths = list(_paths(base))
    for i, where in enumerate(paths):
        empty = ("",) if isinstance(_node(base, where), str) else ()      # a text emptied (minLength)
        for value in (KeyError, MUTATIONS[i % len(MUTATIONS)], MUTATIONS[(7 * i + 3) % len(MUTATIONS)], *empty):
            doc = _mutated(base, where, value)
            ours = next(results._violations(doc, results._schema(), ()), None) is None
            outcomes.append(ours)
            if ours != reference[0].is_valid(doc):
                disagreements.append(f"{where} -> {value!r}: read_results {'accepts' if ours else 'rejects'} it")
    assert not disagreements, "\n".join(disagreements[:20])
    assert len(outcomes) > 300 and 0.2 < outcomes.count(False) / len(outcomes) < 0.9, \
        f"{outcomes.count(False)} of {len(outcomes)} mutations invalid: the mutations test too little"


def _node(doc, where):
    """The node of ``doc`` at the path ``where``."""
    for key in where:
        doc = doc[key]
    return doc


def _mutated(base, where, value):
    """``base`` with the node at ``where`` replaced (or deleted), copying only the nodes on the way."""
    doc = dict(base) if isinstance(base, dict) else list(base)
    node = doc
    for key in where[:-1]:
        child = node[key]
        child = dict(child) if isinstance(child, dict) else list(child)
        node[key] = child
        node = child
    if value is KeyError:
        if isinstance(node, dict):
            del node[where[-1]]
        else:
            node.pop(where[-1])
    else:
        node[where[-1]] = copy.deepcopy(value)
    return doc


# ------------------------------------------------------------------------------------------- corrupted files
@pytest.fixture(scope="module")
def text() -> str:
    return (REPO / "data" / "results" / "tseng2011.json").read_text()


def _line_col(text: str, pos: int) -> tuple[int, int]:
    return text.count("\n", 0, pos) + 1, pos - (text.rfind("\n", 0, pos) + 1) + 1


def test_truncated_file_names_file_and_position(text, tmp_path):
    cut = text.index(",\n", 5000) + 2                  # ends after a comma: the next key is missing, at the end
    path = tmp_path / "tseng2011.json"
    path.write_text(text[:cut])
    line, col = _line_col(text, cut)
    with pytest.raises(ValueError) as err:
        read_results(path, name="data/results/tseng2011.json")
    assert str(err.value).startswith(f"data/results/tseng2011.json: not valid JSON: line {line}, column {col} "
                                     f"(character {cut}): "), str(err.value)


def test_stray_character_names_file_and_position(text, tmp_path):
    pos = text.index('"rows"')                         # '"rows": [' becomes '@"rows": ['
    path = tmp_path / "x.json"
    path.write_text(text[:pos] + "@" + text[pos:])
    line, col = _line_col(text, pos)
    with pytest.raises(ValueError, match=rf"^{re.escape(str(path))}: not valid JSON: line {line}, column {col} "):
        read_results(path)                             # named as given


def test_bytes_that_are_not_utf8_name_file_and_byte_offset(text, tmp_path):
    data = text.encode()
    offset = data.index(b'"claims"') + 3              # inside a key
    path = tmp_path / "tseng2011.json"
    path.write_bytes(data[:offset] + b"\xff\xfe" + data[offset:])
    line = data.count(b"\n", 0, offset) + 1
    with pytest.raises(ValueError) as err:
        read_results(path, name="data/results/tseng2011.json")
    assert str(err.value).startswith(f"data/results/tseng2011.json: not UTF-8 text: byte {offset} (line {line}) "
                                     f"is 0xff"), str(err.value)


def test_nan_is_not_json_and_is_named_with_its_path(tmp_path):
    doc = small(committed("tseng2011.json"))
    doc["rows"][2]["stderr"] = float("nan")
    path = tmp_path / "tseng2011.json"
    path.write_text(json.dumps(doc))                   # Python writes NaN; write_results never does
    with pytest.raises(ValueError, match=r"^data/results/tseng2011.json: not valid JSON: rows\[2\]\.stderr: NaN is "
                                         r"not a JSON number"):
        read_results(path, name="data/results/tseng2011.json")


def test_empty_file(tmp_path):
    path = tmp_path / "zhu2016.json"
    path.write_text("")
    with pytest.raises(ValueError, match=r"^data/results/zhu2016.json: not valid JSON: line 1, column 1 "):
        read_results(path, name="data/results/zhu2016.json")


def test_missing_file_is_an_oserror(tmp_path):
    with pytest.raises(FileNotFoundError):
        read_results(tmp_path / "none.json")


# ------------------------------------------------------------------------------------------- the tools' readers
def corrupt_layout(root: Path, paper: str = "tseng2011") -> Path:
    """``root`` laid out like the repository (notebook source, executed notebook, results) with a truncated
    results file; returns that file."""
    (root / "notebooks" / "executed").mkdir(parents=True)
    (root / "notebooks" / f"{paper}_fuzzy_immukf.py").write_text("")
    (root / "notebooks" / "executed" / f"{paper}_fuzzy_immukf.ipynb").write_text("{}")
    results = root / "data" / "results" / f"{paper}.json"
    results.parent.mkdir(parents=True)
    results.write_text('{"paper": "tseng2011",\n "rows": [\n')
    return results


TRUNCATED = r"data/results/tseng2011.json: not valid JSON: line 3, column 1 \(character 34\): Expecting value"


def test_site_builder_names_the_broken_results_file(tmp_path, monkeypatch, capsys):
    builder = load_tool("build_site")
    corrupt_layout(tmp_path)
    monkeypatch.setattr(builder, "REPO", tmp_path)
    with pytest.raises(builder.SiteError, match=f"^{TRUNCATED}") as err:
        builder.load_inputs("full")
    assert not isinstance(err.value, builder.MissingOutputs)      # an error, not "run make figures first"
    # `make figures` last step: a broken file is an error, not incomplete outputs
    assert builder.main(["--if-complete", "--out", str(tmp_path / "site")]) == 2
    assert re.search(f"build_site.py: error: {TRUNCATED}", capsys.readouterr().err)
    assert not (tmp_path / "site").exists()


def test_site_builder_names_the_contract_violation(tmp_path, monkeypatch):
    builder = load_tool("build_site")
    results = corrupt_layout(tmp_path)
    doc = small(committed("tseng2011.json"))
    del doc["rows"][1]["verdict"]
    results.write_text(json.dumps(doc))
    monkeypatch.setattr(builder, "REPO", tmp_path)
    with pytest.raises(builder.SiteError, match=r"^data/results/tseng2011.json: rows\[1\]\.verdict: missing$"):
        builder.load_inputs("full")


def test_report_renderer_names_the_broken_results_file(tmp_path, capsys):
    make_report = load_tool("make_report")
    results = corrupt_layout(tmp_path)
    with pytest.raises(ValueError, match=f"^{re.escape(str(results))}: not valid JSON: line 3, column 1 "):
        make_report.load_results(tmp_path)
    assert make_report.main(["--root", str(tmp_path)]) == 2
    assert f"make_report.py: error: {results}: not valid JSON: line 3, column 1" in capsys.readouterr().err
    assert not (tmp_path / "reports").exists()


def test_report_renderer_names_files_inside_the_repository_relative_to_it():
    make_report = load_tool("make_report")
    assert make_report.shown(REPO / "data" / "results" / "zhu2016.json") == "data/results/zhu2016.json"


def test_runner_fails_a_notebook_whose_results_break_the_contract(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(REPO / "tools"))              # the runner imports make_report from there
    runner = load_tool("run_notebooks")
    staging = tmp_path / "staging" / "tseng2011_fuzzy_immukf"
    corrupt_layout(staging)
    src = REPO / "notebooks" / "tseng2011_fuzzy_immukf.py"
    with pytest.raises(runner.NotebookFailed, match=f"^wrote an invalid results file: {TRUNCATED}"):
        runner.staged_paper(staging, src)
    doc = small(committed("tseng2011.json"))
    doc["claims"][0]["verdict"] = "reproduced"
    (staging / "data" / "results" / "tseng2011.json").write_text(json.dumps(doc))
    with pytest.raises(runner.NotebookFailed, match=r"^wrote an invalid results file: data/results/tseng2011.json: "
                                                    r"claims\[0\]\.verdict: string \"reproduced\" is not a verdict "
                                                    r"of the claim vocabulary"):
        runner.staged_paper(staging, src)


def test_runner_names_another_papers_broken_results_when_rendering_reports(tmp_path, monkeypatch):
    """The cross-paper README is rendered from the other papers' current results: a broken one is named."""
    monkeypatch.syspath_prepend(str(REPO / "tools"))
    runner = load_tool("run_notebooks")
    out = tmp_path / "repo"
    broken = corrupt_layout(out)                                   # the current outputs: tseng2011's is broken
    staging = tmp_path / "staging" / "zhu2016_imm5ckf"
    (staging / "data" / "results").mkdir(parents=True)
    doc = small(committed("zhu2016.json"))
    (staging / "data" / "results" / "zhu2016.json").write_text(json.dumps(doc))
    assert runner.staged_paper(staging, REPO / "notebooks" / "zhu2016_imm5ckf.py") == "zhu2016"
    layout = runner.Layout(out, out, tmp_path, "notebooks/executed")
    with pytest.raises(runner.NotebookFailed, match=f"^could not render the reports: ValueError: "
                                                    f"{re.escape(str(broken))}: not valid JSON: line 3, column 1 "):
        runner.stage_reports(staging, layout, "zhu2016")
