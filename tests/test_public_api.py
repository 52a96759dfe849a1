"""Every public module of the estimation core (``mmlib.core`` and ``mmlib.core.layers``, found by walking the
package) declares its public API in ``__all__``: the names exist, none is an imported module, a third-party
helper (``np``), a validation helper (``check_*``) or a private name, every public name the module defines is
listed, and the main classes and functions come first (the API pages follow ``__all__``'s order,
``autodoc_member_order = "bysource"``)."""
import ast
import importlib
import inspect
import pkgutil
from pathlib import Path

import pytest

import mmlib.core


def public_modules(package) -> list[str]:
    """The importable modules of ``package`` (itself included) with no underscore-prefixed part."""
    names = [package.__name__]
    for info in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
        if not any(part.startswith("_") for part in info.name.split(".")):
            names.append(info.name)
    return names


CORE = public_modules(mmlib.core)


def defined_names(module) -> list[str]:
    """Public names the module itself defines: top-level classes, functions and assignments in its source."""
    tree = ast.parse(Path(module.__file__).read_text())
    names = []
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.append(node.name)
        elif isinstance(node, ast.Assign):
            for target in node.targets:
                names += [t.id for t in ast.walk(target) if isinstance(t, ast.Name)]
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.append(node.target.id)
    return [n for n in names if not n.startswith("_")]


def test_the_walk_finds_the_core_and_its_layers():
    assert {"mmlib.core", "mmlib.core.estimation", "mmlib.core.rules", "mmlib.core.models", "mmlib.core.layers",
            "mmlib.core.layers.strong_tracking"} <= set(CORE)
    assert not any(part.startswith("_") for name in CORE for part in name.split("."))


def api_problems(module) -> list[str]:
    """What is wrong with ``module.__all__`` (empty when nothing is)."""
    if not hasattr(module, "__all__"):
        return ["no __all__"]
    api = list(module.__all__)
    problems = [f"not a string: {n!r}" for n in api if not isinstance(n, str)]
    problems += [f"repeated: {n!r}" for n in sorted(set(api)) if api.count(n) > 1]
    for n in (n for n in api if isinstance(n, str)):
        if not hasattr(module, n):
            problems.append(f"does not exist: {n!r}")
            continue
        obj = getattr(module, n)
        if n.startswith("_"):
            problems.append(f"private: {n!r}")
        if n.startswith("check_"):
            problems.append(f"validation helper: {n!r}")
        if inspect.ismodule(obj):
            problems.append(f"a module: {n!r}")
        owner = getattr(obj, "__module__", None) if (inspect.isclass(obj) or callable(obj)) else None
        if owner is not None and not owner.startswith("mmlib."):
            problems.append(f"third-party: {n!r} from {owner}")
    if getattr(module, "__file__", None):
        problems += [f"defined but not listed: {n!r}" for n in defined_names(module) if n not in api]
    return problems


@pytest.mark.parametrize("name", CORE)
def test_module_declares_its_public_api(name):
    assert api_problems(importlib.import_module(name)) == []


def test_the_check_rejects_helpers():
    # a careless __all__ re-exporting what models imports is caught, item by item
    import types

    import mmlib.core.models as models
    fake = types.ModuleType("fake")
    fake.np, fake.check_scalar, fake._freeze = models.np, models.check_scalar, models._freeze
    fake.ndarray = models.np.ndarray
    fake.__all__ = ["np", "check_scalar", "_freeze", "ndarray", "absent", "np"]
    problems = api_problems(fake)
    for expected in ("a module: 'np'", "validation helper: 'check_scalar'", "private: '_freeze'",
                     "third-party: 'ndarray' from numpy", "does not exist: 'absent'", "repeated: 'np'"):
        assert expected in problems, (expected, problems)
    assert api_problems(types.ModuleType("bare")) == ["no __all__"]


@pytest.mark.parametrize("name", [n for n in CORE if importlib.import_module(n).__all__])
def test_main_api_comes_first(name):
    # the first name of a module's API is a class or a function, never a constant or a table
    module = importlib.import_module(name)
    first = getattr(module, module.__all__[0])
    assert inspect.isclass(first) or inspect.isfunction(first), (name, module.__all__[0])


def test_estimation_lists_the_estimators_before_the_failure_tables():
    api = mmlib.core.estimation.__all__
    main = [api.index(n) for n in ("IMM", "SingleModel", "run", "Track", "Estimate")]
    tables = [api.index(n) for n in ("Failure", "FAILURE_CAUSES", "FILTER_METHODS")]
    assert max(main) < min(tables), api
