"""``__all__`` of the experiment layer, the arena, the paper packages and ``mmlib`` itself: every public module states
its public API, in order of importance, with nothing it merely imports (no modules, no helpers re-exported from
elsewhere; the packages' ``__init__`` files excepted, whose purpose is to re-export), and nothing public left out; the
API pages list a module's members in the order of its ``__all__`` (docs/conf.py: ``autodoc_member_order =
"bysource"``, which autodoc reads as the order of ``__all__`` when a module has one)."""
from __future__ import annotations

import ast
import importlib
import inspect
import os
import pkgutil
import re
import subprocess
import sys
import types
from pathlib import Path

import pytest

import mmlib.papers

ROOT = Path(__file__).resolve().parents[1]


def _walk(package: str) -> list[str]:
    pkg = importlib.import_module(package)
    return [package] + sorted(info.name for info in pkgutil.walk_packages(pkg.__path__, package + ".")
                              if not any(part.startswith("_") for part in info.name.split(".")[1:]))


#: the modules this test holds to the rule: mmlib's own __init__, every public module of the experiment layer and the
#: arena, the papers' registry package and each paper package's __init__
MODULES = (["mmlib"] + _walk("mmlib.experiment") + _walk("mmlib.arena") + ["mmlib.papers"]
           + _walk("mmlib.papers"))


def _is_package(module: types.ModuleType) -> bool:
    return hasattr(module, "__path__")


def _alias(module: types.ModuleType, x: str) -> bool:
    obj = getattr(module, x)
    return (inspect.isclass(obj) or inspect.isfunction(obj)) and obj.__module__ != module.__name__


def defined_names(module: types.ModuleType) -> list[str]:
    """The public names a module's source binds at top level (def, class, assignment), in source order."""
    tree = ast.parse(Path(module.__file__).read_text(encoding="utf-8"))
    names = []
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.append(node.name)
        elif isinstance(node, ast.Assign):
            names += [t.id for t in node.targets if isinstance(t, ast.Name)]
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.append(node.target.id)
    return [n for n in dict.fromkeys(names) if not n.startswith("_")]


@pytest.mark.parametrize("name", MODULES)
def test_module_states_its_public_api(name):
    module = importlib.import_module(name)
    assert hasattr(module, "__all__"), f"{name}: no __all__"
    exported = module.__all__
    assert isinstance(exported, (list, tuple)) and all(isinstance(x, str) for x in exported), name
    assert len(set(exported)) == len(exported), f"{name}: __all__ names {exported} twice"
    assert not [x for x in exported if not hasattr(module, x)], f"{name}: __all__ names what the module lacks"
    modules = [x for x in exported if isinstance(getattr(module, x), types.ModuleType)]
    assert not modules, f"{name}: __all__ re-exports the modules {modules}"
    # nothing public left out: what the module defines is in __all__ (a helper meant to stay private is _named; an
    # alias of another module's function or class, kept for old callers, is that module's API, not this one's)
    missing = [x for x in defined_names(module) if x not in exported and not _alias(module, x)]
    assert not missing, f"{name}: defines {missing} but leaves them out of __all__ (add them, or make them _private)"


@pytest.mark.parametrize("name", [m for m in MODULES if not _is_package(importlib.import_module(m))])
def test_module_exports_only_what_it_defines(name):
    """A module's ``__all__`` holds its own definitions only: a function or class imported from elsewhere (``np``,
    ``check_*``) is not part of its API, and autodoc would document it a second time."""
    module = importlib.import_module(name)
    own = set(defined_names(module))
    foreign = [x for x in module.__all__ if x not in own or _alias(module, x)]
    assert not foreign, f"{name}: __all__ re-exports {foreign}"


@pytest.mark.parametrize("name", [m for m in MODULES if _is_package(importlib.import_module(m))])
def test_package_re_exports_public_objects_of_the_library(name):
    """A package's ``__all__`` may re-export, but only the library's own public objects (never a third-party name)."""
    module = importlib.import_module(name)
    for x in module.__all__:
        obj = getattr(module, x)
        origin = getattr(obj, "__module__", None) or name
        assert origin.startswith("mmlib"), f"{name}.{x} comes from {origin}"
        assert not x.startswith("_") and not any(p.startswith("_") for p in origin.split(".")[1:] if p != "__init__")


def test_the_first_names_are_the_ones_a_reader_starts_from():
    """Order of importance, on the modules a new user meets first (the order itself is a judgement; this pins the
    first names so that a reordering is deliberate)."""
    from mmlib.experiment import evaluation, metrics, simulate
    assert mmlib.__all__[:3] == ["IMM", "SingleModel", "run"]
    assert evaluation.__all__[:3] == ["evaluate", "RunSet", "paired_mse_difference"]
    assert metrics.__all__[:2] == ["MCValue", "mean_with_se"]
    assert simulate.__all__[0] == "simulate"


def test_autodoc_documents_members_in_the_order_of_all(tmp_path):
    """Sphinx with the site's configuration (docs/conf.py), on the API page of a module whose ``__all__`` order differs
    from its source order: the top-level members appear in the HTML in ``__all__`` order, the first first."""
    from mmlib.experiment import evaluation
    name = evaluation.__name__
    src = tmp_path / "src"
    src.mkdir()
    (src / "index.md").write_text(f"# `{name}`\n\n```{{eval-rst}}\n.. automodule:: {name}\n```\n")
    html = tmp_path / "html"
    env = {**os.environ, "MMLIB_SITE_REPO": str(ROOT), "PYTHONHASHSEED": "0"}
    proc = subprocess.run([sys.executable, "-m", "sphinx", "-b", "html", "-q", "-c", str(ROOT / "docs"),
                           "-d", str(tmp_path / "doctrees"), str(src), str(html)],
                          env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    page = (html / "index.html").read_text(encoding="utf-8")
    ids = re.findall(rf'<dt class="sig sig-object py" id="{re.escape(name)}\.([A-Za-z_][A-Za-z0-9_]*)"', page)
    assert len(ids) >= 5, f"too few members documented: {ids}"
    in_all = [x for x in evaluation.__all__ if x in ids]
    assert ids == in_all, f"documented in the order {ids}, __all__ says {in_all}"
    assert ids[0] == evaluation.__all__[0]
    source_order = [x for x in defined_names(evaluation) if x in ids]
    assert source_order != ids, "the check needs a module whose source order differs from its __all__ order"
