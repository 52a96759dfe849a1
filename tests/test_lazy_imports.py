"""``import mmlib`` is lazy (issue 25, PEP 562): the package imports a module of the library only when one of its
names is first used, so a notebook kernel that needs ``mmlib.experiment.montecarlo`` (its progress lines) does not
import numba, scipy.stats and the estimation core (2.4 s of imports, measured with ``python -X importtime``).  Every
name ``mmlib`` and ``mmlib.experiment`` bound when they imported eagerly still resolves to the same object, and the
tables of the lazy ``__getattr__`` agree with the imports a type checker reads under ``if TYPE_CHECKING:``."""
from __future__ import annotations

import ast
import importlib
import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

import mmlib
import mmlib.experiment

ROOT = Path(__file__).resolve().parents[1]

#: modules a light import must leave unimported (the heavy ones: the estimation core, numba, scipy.stats)
HEAVY = ("mmlib.core.estimation", "mmlib.core.linalg", "mmlib.experiment.evaluation", "mmlib.experiment.metrics",
         "numba", "scipy.stats")


def _imported_after(statement: str) -> list[str]:
    """The modules of :data:`HEAVY` that ``statement`` imports, in a fresh interpreter."""
    code = f"import json, sys\n{statement}\nprint(json.dumps([m for m in {list(HEAVY)!r} if m in sys.modules]))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("statement", ["import mmlib", "import mmlib.experiment",
                                       "from mmlib.experiment.montecarlo import say_progress",
                                       "from mmlib.experiment.montecarlo import MonteCarlo, Stream",
                                       # what the notebook runner reads: the notebooks' parameter rules, the registry
                                       "from mmlib.experiment.notebook import NotebookRun; from mmlib.papers import "
                                       "REGISTRY"])
def test_a_light_import_does_not_import_the_heavy_modules(statement):
    assert _imported_after(statement) == []


def test_the_reports_views_leave_scipy_stats_unimported_until_an_interval_is_computed():
    """The notebook runner renders reports through mmlib.experiment.views (the multiverse and the metrics): scipy.stats
    (1.1 s) is imported only by the first interval computed."""
    assert "scipy.stats" not in _imported_after("import mmlib.experiment.views")
    assert "scipy.stats" in _imported_after("from mmlib.experiment.metrics import wilson_interval; "
                                            "wilson_interval(3, 10)")


def test_the_probe_sees_a_heavy_import():
    """The check above is not vacuous: a name of the estimation core imports it."""
    assert set(_imported_after("from mmlib import IMM")) >= {"mmlib.core.estimation", "numba"}


@pytest.mark.parametrize("package", [mmlib, mmlib.experiment])
def test_every_name_of_all_resolves(package):
    ns: dict = {}
    exec(f"from {package.__name__} import *", ns)
    assert sorted(k for k in ns if not k.startswith("__")) == sorted(package.__all__)
    for name in package.__all__:
        assert getattr(package, name) is ns[name]
        assert name in dir(package)


def test_the_reexports_are_the_defining_modules_objects():
    from mmlib.core.estimation import IMM
    from mmlib.core.rules import rule_by_name
    assert mmlib.IMM is IMM and mmlib.rule_by_name is rule_by_name
    assert mmlib.models is importlib.import_module("mmlib.core.models")
    assert mmlib.montecarlo is importlib.import_module("mmlib.experiment.montecarlo")
    assert mmlib.core is importlib.import_module("mmlib.core")
    assert mmlib.experiment.evaluation is importlib.import_module("mmlib.experiment.evaluation")
    assert mmlib.__version__ == "0.1.0"
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        mmlib.no_such_name
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        mmlib.experiment.no_such_name
    with pytest.raises(AttributeError):
        mmlib.core.no_such_module


def test_a_submodule_is_an_attribute_of_its_package_in_a_fresh_process():
    """What the eager imports bound as a side effect (``import mmlib.core; mmlib.core.models``) still resolves."""
    code = ("import mmlib.core, mmlib.core.layers, mmlib.experiment\n"
            "print(mmlib.core.models.__name__, mmlib.core.layers.adaptive.__name__, mmlib.experiment.metrics.__name__,"
            " mmlib.papers.__name__)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.split() == ["mmlib.core.models", "mmlib.core.layers.adaptive", "mmlib.experiment.metrics",
                                  "mmlib.papers"]


def _is_module(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except ModuleNotFoundError:                  # a name inside a module (mmlib.core.estimation.IMM)
        return False


def _type_checking_imports(package) -> dict[str, str]:
    """name -> the module it is imported from (or, for a module, the module itself) under ``if TYPE_CHECKING:``."""
    tree = ast.parse(Path(package.__file__).read_text(encoding="utf-8"))
    block = next(n for n in tree.body if isinstance(n, ast.If) and getattr(n.test, "id", None) == "TYPE_CHECKING")
    out = {}
    for node in block.body:
        assert isinstance(node, ast.ImportFrom)
        for alias in node.names:
            sub = f"{node.module}.{alias.name}"
            out[alias.name] = sub if _is_module(sub) else node.module
    return out


@pytest.mark.parametrize("package", [mmlib, mmlib.experiment])
def test_the_type_checking_imports_match_the_lazy_tables(package):
    seen = _type_checking_imports(package)
    objects = {n: m for n, m in seen.items() if n in package._OBJECT_MODULE or n in package.__all__}
    assert objects == package._OBJECT_MODULE
    assert set(package.__all__) == set(package._OBJECT_MODULE)
    modules = {n: m for n, m in seen.items() if n not in objects}
    expected = package._MODULES if isinstance(package._MODULES, dict) else \
        {n: f"{package.__name__}.{n}" for n in package._MODULES}
    assert {n: m for n, m in modules.items() if n in expected} == expected
    for name, module in modules.items():
        assert getattr(package, name) is importlib.import_module(module)


def test_the_table_helpers_the_notebooks_import_from_the_notebook_module_are_the_views_ones():
    """``from mmlib.experiment.notebook import markdown_table, value_pm`` (every paper notebook's first cell) gives
    the views' functions, imported on first use (:func:`mmlib.core._lazy.lazy_attributes` on a plain module); another
    missing name is still an AttributeError (a plain module has no submodule to look for), so ``hasattr`` is False."""
    from mmlib.experiment import notebook, views
    from mmlib.experiment.notebook import markdown_table, value_pm
    assert markdown_table is views.markdown_table and value_pm is views.value_pm
    assert {"markdown_table", "value_pm", "NotebookRun"} <= set(dir(notebook))
    with pytest.raises(AttributeError, match="no attribute 'no_such_helper'"):
        notebook.no_such_helper
    assert not hasattr(notebook, "no_such_helper")
