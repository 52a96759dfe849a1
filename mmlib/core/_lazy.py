"""Lazy attributes of a package (PEP 562), written once for the packages that use them (``mmlib``,
``mmlib.core``, ``mmlib.core.layers``, ``mmlib.experiment``): importing a package imports none of its modules, and
the first access to a re-exported name imports the module that defines it (issue 25: a notebook kernel that needs
``mmlib.experiment.montecarlo`` alone no longer pays for numba, scipy.stats and the estimation core).  Imports
nothing of :mod:`mmlib`."""
from __future__ import annotations

import importlib
import importlib.util
from collections.abc import Callable, Iterable, Mapping

__all__ = ["lazy_attributes"]


def lazy_attributes(package: str, namespace: dict, modules: Mapping[str, str] | Iterable[str] = (),
                    objects: Mapping[str, Iterable[str]] | None = None,
                    ) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for the package (or plain module) named ``package`` whose globals are ``namespace``:
    a name of ``modules`` (``{name: module path}``, or names of the package's own modules) is that module, a name of
    ``objects`` (``{module path: names}``) the object the module defines, each imported on first access and then
    bound in ``namespace``; for a package, any other submodule is imported on access (``mmlib.core.models`` after
    ``import mmlib.core``); anything else is an AttributeError, as for a module without it (a plain module, e.g.
    :mod:`mmlib.experiment.notebook`, has no submodules to look for)."""
    table = dict(modules) if isinstance(modules, Mapping) else {name: f"{package}.{name}" for name in modules}
    owner = {name: module for module, names in (objects or {}).items() for name in names}

    def __getattr__(name: str) -> object:
        """A re-exported module or object, imported on first access and then bound in the package; a submodule."""
        if name in table:
            value = importlib.import_module(table[name])
        elif name in owner:
            value = getattr(importlib.import_module(owner[name]), name)
        elif "__path__" in namespace and name.isidentifier() and not name.startswith("__") \
                and importlib.util.find_spec(f"{package}.{name}"):
            return importlib.import_module(f"{package}.{name}")     # the import binds it in the package
        else:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        """The package's names: those bound so far and those it imports on access."""
        return sorted(set(namespace) | set(table) | set(owner))

    return __getattr__, __dir__
