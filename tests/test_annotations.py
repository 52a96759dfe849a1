"""Every public function and method of mmlib annotates all its parameters (``self``/``cls`` aside) and its return.

"Public" is that of ``tests/test_docstrings.py`` (whose :func:`public_modules` is reused): a module none of whose
path parts below ``mmlib`` starts with ``_``; a function defined in that module without a leading underscore; a
method, static or class method or property (its getter) that a public class defines itself, without a leading
underscore (dunder methods are not checked).  Members generated elsewhere -- a dataclass's or NamedTuple's -- are
skipped: only functions whose ``__module__`` is the module being checked count.

The annotations are strings (``from __future__ import annotations``), so they are also resolved with
:func:`typing.get_type_hints`.  Names a module imports only under ``if TYPE_CHECKING:`` (matplotlib's
``Figure``/``Axes``, ``distributed.Client``, names whose import would be a cycle) do not exist at run time and
cannot be resolved from the module's globals; an annotation that mentions such a name is left out of that check (it
is still required to be present), every other annotation of the function must resolve.  A separate test then makes
those TYPE_CHECKING imports (as a type checker would; skipped where one is not installed) and resolves every
annotation of those modules with them.
"""
from __future__ import annotations

import ast
import importlib
import inspect
import types
import typing

import pytest

from test_docstrings import public_methods, public_modules, public_objects


def public_functions(module_name: str) -> list[tuple[str, types.FunctionType]]:
    """``(qualified name, function)`` of every public function, method and property getter of a module, as
    tests/test_docstrings.py defines them, less the members generated elsewhere."""
    out = []
    for path, obj in public_objects(module_name):
        if inspect.isfunction(obj):
            out.append((path, obj))
        elif inspect.isclass(obj):
            out += [(name, fn) for name, fn in public_methods(path, obj) if fn.__module__ == module_name]
    return out


def missing_annotations(fn: types.FunctionType) -> list[str]:
    """The parameters of ``fn`` (``self``/``cls`` as first parameter aside) without an annotation, and
    ``"return"`` if its return is not annotated."""
    sig = inspect.signature(fn)
    missing = [p.name for i, p in enumerate(sig.parameters.values())
               if p.annotation is inspect.Parameter.empty and not (i == 0 and p.name in ("self", "cls"))]
    if sig.return_annotation is inspect.Signature.empty:
        missing.append("return")
    return missing


def unannotated(module_name: str) -> list[str]:
    """``qualified name(missing, ...)`` for every public function of the module lacking an annotation."""
    return [f"{path}({', '.join(miss)})" for path, fn in public_functions(module_name)
            if (miss := missing_annotations(fn))]


def type_checking_names(module_name: str) -> set[str]:
    """The names a module binds only inside ``if TYPE_CHECKING:`` (``import a.b`` binds ``a``)."""
    tree = ast.parse(inspect.getsource(importlib.import_module(module_name)))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for stmt in node.body:
                if isinstance(stmt, ast.Import):
                    names.update((a.asname or a.name).split(".")[0] for a in stmt.names)
                elif isinstance(stmt, ast.ImportFrom):
                    names.update(a.asname or a.name for a in stmt.names)
    return names


def type_checking_namespace(module_name: str) -> dict:
    """The names of the module's ``if TYPE_CHECKING:`` imports, imported (ImportError if one is not installed)."""
    tree = ast.parse(inspect.getsource(importlib.import_module(module_name)))
    ns: dict = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            exec(compile(ast.Module(body=node.body, type_ignores=[]), module_name, "exec"), ns)
    ns.pop("__builtins__", None)
    return ns


def _mentions(annotation: object, names: set[str]) -> bool:
    """Whether the annotation (a string, possibly quoting a string: ``'"a.B"'``) names one of ``names``."""
    if not isinstance(annotation, str):
        return False
    try:
        tree = ast.parse(annotation, mode="eval")
    except SyntaxError:                                          # a string that is no expression, e.g. a Literal's
        return False
    return any((isinstance(n, ast.Name) and n.id in names)
               or (isinstance(n, ast.Constant) and isinstance(n.value, str) and _mentions(n.value, names))
               for n in ast.walk(tree))


def unresolved(module_name: str) -> list[str]:
    """``qualified name: error`` for every public function whose annotations (those not mentioning a
    TYPE_CHECKING-only name) :func:`typing.get_type_hints` cannot resolve."""
    importlib.import_module(module_name)
    only_for_checkers = type_checking_names(module_name)
    bad = []
    for path, fn in public_functions(module_name):
        kept = {k: v for k, v in fn.__annotations__.items() if not _mentions(v, only_for_checkers)}
        probe = types.SimpleNamespace(__annotations__=kept)     # the function's annotations less those names
        try:
            typing.get_type_hints(probe, globalns=inspect.unwrap(fn).__globals__)
        except Exception as exc:                                 # NameError, AttributeError, TypeError, ...
            bad.append(f"{path}: {type(exc).__name__}: {exc}")
    return bad


@pytest.mark.parametrize("module_name", public_modules())
def test_every_public_function_is_annotated(module_name):
    missing = unannotated(module_name)
    assert not missing, f"{len(missing)} public function(s) lacking annotations: {'; '.join(missing)}"


@pytest.mark.parametrize("module_name", public_modules())
def test_annotations_resolve(module_name):
    bad = unresolved(module_name)
    assert not bad, f"{len(bad)} public function(s) whose annotations do not resolve: {'; '.join(bad)}"


TYPE_CHECKING_MODULES = [m for m in public_modules() if type_checking_names(m)]


@pytest.mark.parametrize("module_name", TYPE_CHECKING_MODULES)
def test_type_checking_only_names_resolve_for_a_checker(module_name):
    """What the check above leaves out: with the module's TYPE_CHECKING imports actually made (as a type checker
    sees them; skipped if one of them, e.g. matplotlib, is not installed), every annotation resolves."""
    try:
        ns = type_checking_namespace(module_name)
    except ImportError as exc:
        pytest.skip(f"{module_name}: a TYPE_CHECKING import is not installed ({exc})")
    bad = []
    for path, fn in public_functions(module_name):
        try:
            typing.get_type_hints(fn, globalns={**inspect.unwrap(fn).__globals__, **ns})
        except Exception as exc:
            bad.append(f"{path}: {type(exc).__name__}: {exc}")
    assert not bad, f"{len(bad)} public function(s) whose annotations do not resolve: {'; '.join(bad)}"


def test_the_library_has_public_functions_to_check():
    """The walk finds the functions the brief names (it is not vacuous)."""
    found = {path for m in public_modules() for path, _ in public_functions(m)}
    for path in ("mmlib.core.estimation.run", "mmlib.core.estimation.IMM.step", "mmlib.core.filters.kalman_update",
                 "mmlib.core.filters.SigmaPointFilter.predict", "mmlib.arena.recipes.initial_state",
                 "mmlib.core.estimation.IMM.n_modes", "mmlib.core.models.StackedDynamics.of"):
        assert path in found


PROBE = '''"""A probe."""
from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import matplotlib.figure


def bare(a, b: int = 0):
    pass


def no_return(a: int):
    pass


def varargs(*args, **kwargs: int) -> None:
    pass


def fine(a: int, *, b: str = "") -> "matplotlib.figure.Figure | None":
    pass


def unknown(a: NoSuchName) -> int:
    pass


def _private(a):
    pass


@dataclasses.dataclass
class C:
    a: int = 0

    def m(self, x) -> int:
        return x

    @classmethod
    def make(cls) -> C:
        return cls()

    @staticmethod
    def s(y):
        return y

    @property
    def p(self):
        return 1

    def ok(self, x: float) -> float:
        return x
'''


def test_the_checker_sees_a_missing_annotation(tmp_path, monkeypatch):
    """The checks can fail: unannotated parameters, returns, ``*args``, methods, static methods and properties are
    flagged (private names, ``self``/``cls`` and the dataclass's generated members are not); an unresolvable name
    fails ``get_type_hints`` while a TYPE_CHECKING-only one is left out of that check."""
    (tmp_path / "annotation_probe.py").write_text(PROBE)
    monkeypatch.syspath_prepend(str(tmp_path))
    assert unannotated("annotation_probe") == [
        "annotation_probe.bare(a, return)", "annotation_probe.no_return(return)",
        "annotation_probe.varargs(args)", "annotation_probe.C.m(x)", "annotation_probe.C.s(y, return)",
        "annotation_probe.C.p(return)"]
    assert type_checking_names("annotation_probe") == {"matplotlib"}
    bad = unresolved("annotation_probe")
    assert [b.split(":")[0] for b in bad] == ["annotation_probe.unknown"]
    assert "NoSuchName" in bad[0]
