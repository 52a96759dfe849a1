"""The replicated papers, one package each, behind one contract (:class:`mmlib.experiment.paper.Paper`).

``REGISTRY`` maps a paper's name to its :class:`~mmlib.experiment.paper.Paper`; it is the one list of papers in the
repository: the arena, the notebook runner, the site and the tests iterate over it.  Each package is imported on
first use (``REGISTRY["zhu2016"]`` imports ``mmlib.papers.zhu2016`` and returns its ``PAPER``).  A paper defined
elsewhere (a user's sixth paper, the worked example of ``docs/new-paper.md``) joins with :meth:`Registry.register`.
"""
from __future__ import annotations

import importlib
from typing import Iterator, Mapping

from mmlib.experiment.paper import Paper

__all__ = [
    "REGISTRY", "Registry", "PACKAGES"
]

#: the packages of the replicated papers, in the order of the README's table; the controls of the pipeline
#: (``Paper.kind == "control"``) first
PACKAGES = ("controls", "zhu2016", "liu2017", "hu2017", "zhou2017", "tseng2011")


class Registry(Mapping):
    """Name -> :class:`Paper`, loading each package's ``PAPER`` on first access."""

    def __init__(self, packages: tuple[str, ...]):
        self._packages = list(packages)
        self._loaded: dict[str, Paper] = {}

    def __getitem__(self, name: str) -> Paper:
        if name not in self._loaded:
            if name not in self._packages:
                raise KeyError(f"{name!r}: not a registered paper ({', '.join(self._packages)})")
            paper = importlib.import_module(f"{__name__}.{name}").PAPER
            if not isinstance(paper, Paper) or paper.name != name:
                raise TypeError(f"mmlib.papers.{name}.PAPER: expected the Paper named {name!r}, got {paper!r}")
            self._loaded[name] = paper
        return self._loaded[name]

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._packages))

    def __len__(self) -> int:
        return len(self._packages)

    def register(self, paper: Paper) -> Paper:
        """Add a paper defined outside this package (returns it); ValueError if the name is taken by another.

        In this process only: worker processes (``workers`` > 1, a Dask cluster) and notebook kernels import the
        registry afresh and see the packages of :data:`PACKAGES`.  A paper meant to be run by ``make figures`` or
        in parallel is a package here, added to :data:`PACKAGES`."""
        if not isinstance(paper, Paper):
            raise ValueError(f"paper: expected a mmlib.experiment.paper.Paper, got {type(paper).__name__}")
        if paper.name in self._packages and self.get(paper.name) is not paper:
            raise ValueError(f"paper: the name {paper.name!r} is already registered")
        if paper.name not in self._packages:
            self._packages.append(paper.name)
        self._loaded[paper.name] = paper
        return paper

    def unregister(self, name: str) -> None:
        """Remove a paper added with :meth:`register` (the packages of this folder stay)."""
        if name in PACKAGES:
            raise ValueError(f"name: {name!r} is a package of mmlib.papers and cannot be removed")
        if name not in self._packages:
            raise ValueError(f"name: {name!r} is not registered")
        self._packages.remove(name)
        self._loaded.pop(name, None)


REGISTRY = Registry(PACKAGES)
