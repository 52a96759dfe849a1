"""Every public module, class, function, method and property of mmlib has a docstring.

"Public" is what a user reaches without an underscore: a module none of whose path parts (below ``mmlib``) starts
with ``_``; a class or function defined in that module (not imported into it) whose name has no leading
underscore; a method or property a class defines itself (inherited and generated members, e.g. a NamedTuple's
field accessors, are documented where they are defined).  Units and shapes are a reader's matter, but where a
number has a unit the user must know, its docstring is checked to state it (``UNIT_DOCS``).
"""
from __future__ import annotations

import importlib
import inspect
import pkgutil

import pytest

import mmlib


def public_modules():
    names = ["mmlib"]
    for info in pkgutil.walk_packages(mmlib.__path__, "mmlib."):
        if not any(part.startswith("_") for part in info.name.split(".")[1:]):
            names.append(info.name)
    return names


def public_objects(module_name: str) -> list[tuple[str, object]]:
    """``(qualified name, object)`` of every public class and function a module defines itself (the one definition
    of the public API, used by this test and by tests/test_annotations.py)."""
    mod = importlib.import_module(module_name)
    return [(f"{module_name}.{name}", obj) for name, obj in vars(mod).items()
            if not name.startswith("_") and getattr(obj, "__module__", None) == module_name
            and (inspect.isclass(obj) or inspect.isfunction(obj))]


def public_methods(path: str, cls: type) -> list[tuple[str, object]]:
    """``(qualified name, function)`` of every public method, static or class method and property getter a class
    defines itself."""
    out = []
    for attr, member in vars(cls).items():
        fn = member.fget if isinstance(member, property) else getattr(member, "__func__", member)
        if not attr.startswith("_") and inspect.isfunction(fn):
            out.append((f"{path}.{attr}", fn))
    return out


def undocumented(module_name: str) -> list[str]:
    missing = [] if inspect.getdoc(importlib.import_module(module_name)) else [module_name]
    for path, obj in public_objects(module_name):
        doc = (obj.__doc__ or "").strip()
        # a dataclass or NamedTuple without a docstring gets a generated one: its signature, "Name(a, b)"
        if not doc or (inspect.isclass(obj) and doc.startswith(f"{obj.__name__}(") and doc.endswith(")")
                       and "\n" not in doc):
            missing.append(path)
        if inspect.isclass(obj):
            missing += [name for name, fn in public_methods(path, obj) if not (fn.__doc__ or "").strip()]
    return missing


@pytest.mark.parametrize("module_name", public_modules())
def test_every_public_item_has_a_docstring(module_name):
    missing = undocumented(module_name)
    assert not missing, f"{len(missing)} public item(s) without a docstring: {', '.join(missing)}"


def test_the_checker_sees_a_missing_docstring(tmp_path, monkeypatch):
    """The check can fail: a module with one undocumented public function and one documented one."""
    (tmp_path / "doccheck_probe.py").write_text(
        '"""A probe."""\nimport dataclasses\n\ndef f():\n    pass\n\n\ndef g():\n    """Documented."""\n\n\n'
        '@dataclasses.dataclass\nclass C:\n    a: int = 0\n\n    def m(self):\n        pass\n')
    monkeypatch.syspath_prepend(str(tmp_path))
    assert undocumented("doccheck_probe") == ["doccheck_probe.f", "doccheck_probe.C", "doccheck_probe.C.m"]


#: (object path, words its docstring must contain): the units a caller must get right.
UNIT_DOCS = [
    ("mmlib.core.models.coordinated_turn", ["rad/s", "(s"]),
    ("mmlib.core.models.coordinated_turn_matrix", ["rad/s", "seconds"]),
    ("mmlib.core.models.constant_velocity", ["s"]),
    ("mmlib.core.models.RangeBearing", ["rad", "m"]),
    ("mmlib.core.models.constant_velocity", ["(m/s^2)^2"]),
    ("mmlib.core.models.constant_acceleration", ["(m/s^2)^2", "(s"]),
    ("mmlib.core.models.coordinated_turn", ["172 deg/s"]),
    ("mmlib.core.models.range_bearing", ["rad", "m^2"]),
    ("mmlib.core.gnss.PVClockNoise", ["m^2/s^3", "(s"]),
]


@pytest.mark.parametrize("path, words", UNIT_DOCS, ids=[p for p, _ in UNIT_DOCS])
def test_units_are_stated(path, words):
    module_name, _, name = path.rpartition(".")
    doc = inspect.getdoc(getattr(importlib.import_module(module_name), name)) or ""
    absent = [w for w in words if w not in doc]
    assert not absent, f"{path}: its docstring does not state {absent}"
