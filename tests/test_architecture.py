"""The import structure of mmlib, read from the source (ast, nothing imported): no import cycle among mmlib's
modules, and the layers in order, core -> experiment -> papers -> arena, each importing only from those before it.

An import counts wherever it is written -- at module level or inside a function (it runs when the function does) --
except under ``if TYPE_CHECKING:`` (annotations only, never executed).  ``from package import name`` is an import of
the submodule ``package.name`` when there is one, else of the package itself (its ``__init__``); importing a
submodule is not counted as importing its parent packages, whose ``__init__`` modules would otherwise make every
package that re-exports its submodules a cycle.
"""
from __future__ import annotations

import ast
from pathlib import Path
from typing import NamedTuple

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "mmlib"
#: the packages scanned for cycles: the library and the benchmark (whose imm_ukf <-> scaling cycle issue 22 broke)
SCANNED = ("mmlib", "bench")

#: layer -> the layers it must not import from
FORBIDDEN = {
    "mmlib.core": ("mmlib.experiment", "mmlib.papers", "mmlib.arena"),
    "mmlib.experiment": ("mmlib.papers", "mmlib.arena"),
    "mmlib.papers": ("mmlib.arena",),
}


class Import(NamedTuple):
    source: str          # the importing module
    target: str          # the imported mmlib module
    line: int
    text: str            # the import statement as written

    def __str__(self) -> str:
        return f"{module_path(self.source)}:{self.line}: {self.text}  ({self.source} -> {self.target})"


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def module_path(name: str) -> str:
    """The file of a module, relative to the repository."""
    base = ROOT.joinpath(*name.split("."))
    path = base / "__init__.py" if base.is_dir() else base.with_suffix(".py")
    return path.relative_to(ROOT).as_posix()


def modules() -> dict[str, Path]:
    return {module_name(p): p for top in SCANNED for p in sorted((ROOT / top).rglob("*.py"))
            if "__pycache__" not in p.parts}


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or \
        (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _import_nodes(tree: ast.AST):
    """Every Import/ImportFrom node that can run: the bodies of ``if TYPE_CHECKING:`` are skipped (their ``else:``
    is not)."""
    stack = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
            continue
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            stack.extend(node.orelse)
            continue
        stack.extend(ast.iter_child_nodes(node))


def _resolve(name: str, known: dict[str, Path]) -> str | None:
    """The scanned module ``name`` stands for (itself if it is one), None outside :data:`SCANNED`."""
    if not any(name == top or name.startswith(top + ".") for top in SCANNED):
        return None
    while name not in known and "." in name:          # an attribute of a module, e.g. mmlib.core.linalg.kernel
        name = name.rsplit(".", 1)[0]
    return name if name in known else None


def imports_of(name: str, path: Path, known: dict[str, Path]) -> list[Import]:
    """The mmlib modules that module ``name`` (file ``path``) imports, one entry per imported module and statement."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    is_package = path.name == "__init__.py"
    out = []
    for node in _import_nodes(tree):
        text = ast.get_source_segment(path.read_text(encoding="utf-8"), node) or ast.dump(node)
        text = " ".join(text.split())
        targets = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        else:
            if node.level:                               # relative: from its package
                package = name if is_package else name.rsplit(".", 1)[0]
                for _ in range(node.level - 1):
                    package = package.rsplit(".", 1)[0]
                base = f"{package}.{node.module}" if node.module else package
            else:
                base = node.module
            for alias in node.names:
                sub = f"{base}.{alias.name}"
                targets.append(sub if sub in known else base)
        for target in dict.fromkeys(targets):
            resolved = _resolve(target, known)
            if resolved is not None and resolved != name:
                out.append(Import(name, resolved, node.lineno, text))
    return sorted(out, key=lambda e: (e.line, e.target))


@pytest.fixture(scope="module")
def graph() -> dict[str, list[Import]]:
    known = modules()
    return {name: imports_of(name, path, known) for name, path in known.items()}


def _cycles(graph: dict[str, list[Import]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index, low, on_stack, stack, found = {}, {}, set(), [], []
    counter = [0]

    def visit(v):                                       # recursion depth: at most the number of modules
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for edge in graph.get(v, ()):
            w = edge.target
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(found)


def test_the_scan_sees_the_imports(graph):
    """Not a vacuous pass: the scan finds the layers and imports known to exist."""
    assert {"mmlib.core.linalg", "mmlib.experiment.grid", "mmlib.papers", "mmlib.arena"} <= set(graph)
    assert "mmlib.experiment.executors" in {e.target for e in graph["mmlib.experiment.grid"]}
    assert any(e.target.startswith("mmlib.core") for e in graph["mmlib.experiment.grid"])


def test_type_checking_imports_are_not_counted_and_function_imports_are(tmp_path):
    known = {"mmlib.a": tmp_path / "a.py", "mmlib.b": tmp_path / "b.py", "mmlib.c": tmp_path / "c.py"}
    path = tmp_path / "x.py"
    path.write_text("from typing import TYPE_CHECKING\n"
                    "if TYPE_CHECKING:\n    from mmlib import a\n"
                    "else:\n    import mmlib.b\n"
                    "def f():\n    from mmlib.c import g\n")
    assert [(e.target, e.line) for e in imports_of("mmlib.x", path, known)] == [("mmlib.b", 5), ("mmlib.c", 7)]


def test_no_import_cycle(graph):
    cycles = _cycles(graph)
    lines = []
    for component in cycles:
        members = set(component)
        lines.append(f"cycle among {', '.join(component)}:")
        lines += [f"  {edge}" for v in component for edge in graph[v] if edge.target in members]
    if lines:
        print("\n".join(lines))
    assert not cycles, "import cycles (module-level and function-level imports; TYPE_CHECKING ones excepted):\n" + \
        "\n".join(lines)


@pytest.mark.parametrize("layer", sorted(FORBIDDEN))
def test_layer_imports_nothing_from_the_layers_above(graph, layer):
    above = FORBIDDEN[layer]
    offending = [edge for name, edges in sorted(graph.items()) if name == layer or name.startswith(layer + ".")
                 for edge in edges if any(edge.target == a or edge.target.startswith(a + ".") for a in above)]
    for edge in offending:
        print(edge)
    assert not offending, f"{layer} must not import from {', '.join(above)}:\n" + \
        "\n".join(f"  {edge}" for edge in offending)
