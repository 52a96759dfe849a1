"""The results contract: its JSON Schema and the one reader of results files.

A paper's ``data/results/<paper>.json`` (written by :func:`mmlib.experiment.writing.write_results`) and the arena's
``data/results/arena.json`` follow the JSON Schema ``results.schema.json`` beside this module (draft 2020-12;
:func:`results_schema`).  :func:`read_results` is how every tool and test reads them: it names the file and the
place (byte, line and column, or the JSON path of the first violation) when one is unreadable or breaks the
contract.  :func:`validate_results` checks a parsed document; ``write_results`` calls it before writing, so a file
that breaks the contract is never written.

The schema is checked by a small interpreter of the draft 2020-12 keywords it uses, so that the library reads
results with its core dependencies only and reports the first violation as a JSON path; tests/test_results_contract.py
checks that it agrees with the reference validator (jsonschema), and it refuses a schema with any keyword it does
not implement.
"""
from __future__ import annotations

import copy
import functools
import json
import math
import re
from pathlib import Path
from typing import Any, Iterator, Sequence

__all__ = [
    "read_results", "validate_results", "results_schema", "RESULTS_SCHEMA_FILE"
]

#: the JSON Schema of the results contract, a file of this package beside this module
RESULTS_SCHEMA_FILE = "results.schema.json"

_ANNOTATIONS = frozenset({"$schema", "$id", "$comment", "$defs", "title", "description", "examples", "default"})
_KEYWORDS = frozenset({"$ref", "type", "enum", "const", "required", "properties", "additionalProperties", "items",
                       "minItems", "minimum", "minLength", "pattern", "allOf", "anyOf", "oneOf", "not", "if", "then",
                       "else"})
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


class _NotJSON:
    """What ``json.loads`` makes of ``NaN``, ``Infinity`` or ``-Infinity``, which are not JSON."""

    def __init__(self, token: str):
        self.token = token


@functools.lru_cache(maxsize=1)
def _schema() -> dict:
    from importlib.resources import files
    return json.loads(files(__package__).joinpath(RESULTS_SCHEMA_FILE).read_text(encoding="utf-8"))


def results_schema() -> dict:
    """The JSON Schema (draft 2020-12) of the results contract, ``mmlib/experiment/results.schema.json``: what a
    paper's ``data/results/<paper>.json`` (:func:`mmlib.experiment.writing.write_results`) and the arena's
    ``data/results/arena.json`` hold.  A new copy on every call."""
    return copy.deepcopy(_schema())


def _json_path(path: Sequence[str | int]) -> str:
    """``rows[3].verdict`` for ``("rows", 3, "verdict")``; keys that are not identifiers as ``["a key"]``; ``$``
    for the document itself."""
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
        elif _IDENTIFIER.fullmatch(part):
            out += f".{part}" if out else part
        else:
            out += f"[{json.dumps(part, ensure_ascii=False)}]"
    return out or "$"


def _json_type(x: Any) -> str:
    if x is None:
        return "null"
    if isinstance(x, bool):
        return "boolean"
    if isinstance(x, int):
        return "integer"
    if isinstance(x, float):
        return "number"
    if isinstance(x, str):
        return "string"
    if isinstance(x, list):
        return "array"
    if isinstance(x, dict):
        return "object"
    return x.token if isinstance(x, _NotJSON) else type(x).__name__


def _is_type(x: Any, name: str) -> bool:
    kind = _json_type(x)
    if name == "number":
        return kind in ("integer", "number")
    if name == "integer":
        return kind == "integer" or (kind == "number" and x.is_integer())
    return kind == name


def _describe(x: Any) -> str:
    kind = _json_type(x)
    if kind in ("object", "array") or isinstance(x, _NotJSON):
        return kind
    text = json.dumps(x, ensure_ascii=False)
    return f"{kind} {text if len(text) <= 60 else text[:57] + '...'}"


def _same(a: Any, b: Any) -> bool:
    """JSON equality: a boolean is not a number, 1 and 1.0 are the same number."""
    if isinstance(a, bool) or isinstance(b, bool):
        return isinstance(a, bool) and isinstance(b, bool) and a == b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return a == b
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    return type(a) is type(b) and a == b


@functools.lru_cache(maxsize=None)
def _regex(pattern: str) -> re.Pattern:
    return re.compile(pattern)


def _resolve(ref: str) -> Any:
    if not ref.startswith("#"):
        raise RuntimeError(f"results schema: $ref {ref!r} is not a reference into the schema itself")
    node: Any = _schema()
    for part in filter(None, ref[1:].split("/")):
        node = node[part.replace("~1", "/").replace("~0", "~")]
    return node


def _violations(x: Any, schema: Any, path: tuple) -> Iterator[tuple[tuple, str]]:
    """Every violation of ``schema`` by the instance ``x`` at ``path``, as ``(path, message)``, in document order
    within each keyword."""
    if schema is True:
        return
    if schema is False:
        yield path, "not allowed here"
        return
    unknown = set(schema) - _KEYWORDS - _ANNOTATIONS
    if unknown:
        raise RuntimeError(f"results schema: keyword(s) {sorted(unknown)} (checking {_json_path(path)}) are not "
                           f"implemented by mmlib.experiment.results' validator")
    if "$ref" in schema:
        yield from _violations(x, _resolve(schema["$ref"]), path)
    if "type" in schema:
        names = [schema["type"]] if isinstance(schema["type"], str) else list(schema["type"])
        if not any(_is_type(x, n) for n in names):
            yield path, f"expected {' or '.join(names)}, got {_describe(x)}"
            return                    # the other keywords of this schema concern the expected type
    if "enum" in schema and not any(_same(x, e) for e in schema["enum"]):
        yield path, (f"expected one of {', '.join(json.dumps(e, ensure_ascii=False) for e in schema['enum'])}, "
                     f"got {_describe(x)}")
    if "const" in schema and not _same(x, schema["const"]):
        yield path, f"expected {json.dumps(schema['const'], ensure_ascii=False)}, got {_describe(x)}"
    if isinstance(x, dict):
        for key in schema.get("required", ()):
            if key not in x:
                yield path + (key,), "missing"
        props = schema.get("properties", {})
        extra = schema.get("additionalProperties", True)
        for key, value in x.items():
            if key in props:
                yield from _violations(value, props[key], path + (key,))
            elif extra is False:
                yield path + (key,), "not allowed here (not a key of the results contract)"
            elif extra is not True:
                yield from _violations(value, extra, path + (key,))
    if isinstance(x, list):
        if "items" in schema:
            for i, value in enumerate(x):
                yield from _violations(value, schema["items"], path + (i,))
        if len(x) < schema.get("minItems", 0):
            yield path, f"expected at least {schema['minItems']} item(s), got {len(x)}"
    if _is_type(x, "number") and "minimum" in schema and x < schema["minimum"]:
        yield path, f"expected a number >= {schema['minimum']}, got {_describe(x)}"
    if isinstance(x, str):
        if len(x) < schema.get("minLength", 0):
            yield path, f"expected a string of at least {schema['minLength']} character(s), got {_describe(x)}"
        if "pattern" in schema and not _regex(schema["pattern"]).search(x):
            what = f"is not a {schema['title']}" if "title" in schema else "does not match"
            yield path, f"{_describe(x)} {what} (pattern {schema['pattern']})"
    for sub in schema.get("allOf", ()):
        yield from _violations(x, sub, path)
    for key in ("anyOf", "oneOf"):
        if key in schema:
            first = [next(_violations(x, sub, path), None) for sub in schema[key]]
            matching = [sub for sub, problem in zip(schema[key], first) if problem is None]
            if not matching:
                alternatives = "; ".join(f"{_json_path(p)}: {m}" for p, m in first)
                yield path, f"matches none of the alternatives ({alternatives})"
            elif key == "oneOf" and len(matching) > 1:
                names = "; ".join(sub.get("description", json.dumps(sub)) for sub in matching)
                yield path, f"matches {len(matching)} alternatives where exactly one is allowed ({names})"
    if "not" in schema and next(_violations(x, schema["not"], path), None) is None:
        sub = schema["not"]
        yield path, f"must not be {sub.get('description', json.dumps(sub))}; got {_describe(x)}"
    if "if" in schema:
        branch = "then" if next(_violations(x, schema["if"], path), None) is None else "else"
        if branch in schema:
            yield from _violations(x, schema[branch], path)


def _not_json_at(x: Any, path: tuple = ()) -> tuple | None:
    """The path of the first NaN or infinity in a document (parsed, or about to be written), or None."""
    if isinstance(x, _NotJSON) or (isinstance(x, float) and not math.isfinite(x)):
        return path
    items = x.items() if isinstance(x, dict) else enumerate(x) if isinstance(x, list) else ()
    for key, value in items:
        found = _not_json_at(value, path + (key,))
        if found is not None:
            return found
    return None


def validate_results(doc: Any) -> None:
    """Check a results document (parsed, or about to be written) against the results contract
    (:func:`results_schema`, and every claim's ``key`` unique); ``ValueError`` ``"<JSON path>: <what is wrong>"`` for
    the first violation, e.g. ``"rows[3].verdict: missing"``, or for the first NaN or infinity (not JSON)."""
    bad = _not_json_at(doc)
    if bad is not None:
        value = functools.reduce(lambda node, key: node[key], bad, doc)
        raise ValueError(f"{_json_path(bad)}: {getattr(value, 'token', value)} is not a finite number (a value that "
                         "could not be produced is null)")
    problem = next(_violations(doc, _schema(), ()), None)
    if problem is not None:
        raise ValueError(f"{_json_path(problem[0])}: {problem[1]}")
    seen: dict = {}
    for i, c in enumerate(doc.get("claims") or []):     # a claim's key names one claim (summaries address it)
        if c["key"] in seen:
            raise ValueError(f"claims[{i}].key: {c['key']!r} already names claims[{seen[c['key']]}]")
        seen[c["key"]] = i


def read_results(path: str | Path, *, name: str | None = None) -> dict:
    """Read a results file, ``data/results/<paper>.json``, and check it against the results contract
    (:func:`results_schema`); returns the document.

    ``name``: how the file is called in messages (default: ``path`` as given; the tools pass the path relative to
    the repository).  Raises ``ValueError`` naming the file and the place: ``"<name>: not UTF-8 text: byte <offset>
    (line <n>) ..."`` (offset from 0), ``"<name>: not valid JSON: line <n>, column <m> (character <offset>): ..."``
    (from 1, as :class:`json.JSONDecodeError` counts them; also for NaN and infinities, which write_results refuses
    to write: then at their JSON path), or ``"<name>: <JSON path>: <what is wrong>"`` for the first violation of the
    contract, e.g. ``"data/results/hu2017.json: rows[3].verdict: missing"``.  ``OSError`` (e.g.
    ``FileNotFoundError``) when the file cannot be read."""
    shown = str(path) if name is None else name
    data = Path(path).read_bytes()
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise ValueError(f"{shown}: not UTF-8 text: byte {exc.start} (line {line}) is 0x{data[exc.start]:02x}: "
                         f"{exc.reason}") from None
    constants: list = []               # NaN, Infinity, -Infinity: parsed by Python's json, but not JSON
    try:
        doc = json.loads(text, parse_constant=lambda token: constants.append(token) or _NotJSON(token))
    except json.JSONDecodeError as exc:
        raise ValueError(f"{shown}: not valid JSON: line {exc.lineno}, column {exc.colno} (character {exc.pos}): "
                         f"{exc.msg}") from None
    bad = _not_json_at(doc) if constants else None
    if bad is not None:
        token = functools.reduce(lambda node, key: node[key], bad, doc).token
        raise ValueError(f"{shown}: not valid JSON: {_json_path(bad)}: {token} is not a JSON number (a non-finite "
                         f"value is not written: write it as null)")
    try:
        validate_results(doc)
    except ValueError as exc:
        raise ValueError(f"{shown}: {exc}") from None
    return doc
