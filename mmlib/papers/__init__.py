"""The replicated papers, one package each, behind one contract (:class:`mmlib.experiment.paper.Paper`).

``REGISTRY`` maps a paper's name to its :class:`~mmlib.experiment.paper.Paper`; it is the one list of papers in the
repository: the arena, the notebook runner, the site and the tests iterate over it.  Each package is imported on
first use (``REGISTRY["zhu2016"]`` imports ``mmlib.papers.zhu2016`` and returns its ``PAPER``).  A paper defined
elsewhere (a user's sixth paper, the worked example of ``docs/new-paper.md``) joins with :meth:`Registry.register`.
"""
from __future__ import annotations

import importlib
import importlib.resources
import re
from pathlib import Path
from typing import Any, Iterator, Mapping

from mmlib.experiment.paper import Paper

__all__ = [
    "REGISTRY", "Registry", "summary", "finding", "has_text", "summary_values", "summary_template", "PACKAGES"
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


# -- the one-paragraph summaries (issue 26: findings first) -------------------------------------------------------

#: the texts a paper package may carry, filled from its results (:func:`summary_template`)
_TEXTS = ("summary", "finding")

#: where the committed results live when mmlib runs from its checkout (``data/results/<paper>.json``)
_RESULTS = Path(__file__).resolve().parent.parent.parent / "data" / "results"


def summary_template(name: str, kind: str = "summary") -> str:
    """The text of ``mmlib/papers/<name>/<kind>.md``: ``kind`` "summary" (one paragraph saying what the replication
    of paper ``name`` found) or "finding" (the same in one line, the README's "What we found"), with its numbers as
    placeholders (``{n_universes}``, ``{cpimm_vs_imm_share}``, ...; :func:`summary_values`) filled from the results by
    :func:`summary` and :func:`finding`.  ValueError naming ``name`` for a name that is not a registered paper or a
    paper without that text, naming ``kind`` for another kind."""
    if kind not in _TEXTS:
        raise ValueError(f"kind: expected one of {', '.join(_TEXTS)}, got {kind!r}")
    if not isinstance(name, str) or name not in REGISTRY:
        raise ValueError(f"name: expected a registered paper ({', '.join(REGISTRY)}), got {name!r}")
    try:
        return importlib.resources.files(f"{__name__}.{name}").joinpath(f"{kind}.md").read_text(encoding="utf-8")
    except (FileNotFoundError, ModuleNotFoundError, OSError):
        raise ValueError(f"name: the paper {name!r} has no {kind}.md in its package") from None


def _table_status(n_reproduced: int, n_cells: int, joint: bool | None) -> str:
    """A table's verdict in words from its cells reproduced under the headline and its whole-table joint test."""
    if n_reproduced == 0:
        return "not reproduced"
    if n_reproduced == n_cells and joint is not False:
        return "reproduced"
    return "partly reproduced"


def summary_values(doc: Mapping[str, Any]) -> dict:
    """The values a summary's placeholders name, from a paper's results document
    (:func:`mmlib.experiment.results.read_results`): ``n_runs`` (the headline's Monte Carlo runs), and of the reading
    space ``multiverse_runs`` (runs per universe), ``n_universes`` (run), ``n_counted`` (counted in the shares),
    ``n_simulations`` (distinct), ``full_factorial_size``, ``n_degenerate``, ``n_factors``; per table ``i`` (from 1,
    in the order of :func:`mmlib.experiment.views.paper_verdicts`) ``t<i>_name``, ``t<i>_cells``, ``t<i>_reproduced``
    (headline), ``t<i>_status`` ("reproduced": every cell and the joint test; "not reproduced": no cell; else "partly
    reproduced") and ``t<i>_joint`` ("passes"/"fails"/"--"), and ``tm<i>_most`` (the most cells any reading reproduces,
    table match order); per claim, addressed by its stable ``key`` (:meth:`mmlib.experiment.verdicts.Claims.add`),
    never by its position, ``<key>_verdict`` (its words), ``<key>_decisive``, ``<key>_short`` (the decisive number
    without its parts count), ``<key>_share`` ("92 % [85, 96]" or "--") and ``<key>_robust`` ("robust"/"depends on
    the reading"/"--"); ``n_claims``, ``n_robust``; and ``doc`` itself for any other number
    (``{doc[rows][0][paper]}``).  Counts are integers, the rest strings.  ValueError naming ``doc`` when a claim's
    key would shadow another value."""
    from mmlib.experiment import views
    v = views.paper_verdicts(dict(doc))
    mv = doc.get("multiverse") or {}
    out: dict = {"doc": doc, "n_runs": doc["provenance"]["n_runs"], "multiverse_runs": mv.get("n_runs", "--"),
                 "n_factors": len(mv.get("factors") or [])}
    for key in ("n_universes", "n_counted", "n_simulations", "full_factorial_size", "n_degenerate"):
        out[key] = mv.get(key, "--")
    for i, t in enumerate(v["tables"], 1):
        out.update({f"t{i}_status": _table_status(t["n_reproduced"], t["n_cells"], t["joint"]),
                    f"t{i}_name": t["table"], f"t{i}_cells": t["n_cells"], f"t{i}_reproduced": t["n_reproduced"],
                    f"t{i}_joint": "--" if t["joint"] is None else ("passes" if t["joint"] else "fails")})
    for i, t in enumerate(mv.get("table_match") or [], 1):
        out[f"tm{i}_most"] = t["most_n_reproduced"]
    out["n_claims"] = len(v["claims"])
    out["n_robust"] = sum(bool(c["robust"]) for c in v["claims"])
    for c in v["claims"]:
        share = "--"
        if c["share"] is not None:
            lo, hi = c["interval"] or (c["share"], c["share"])
            band = "" if lo == hi == c["share"] else f" [{views.percent(lo)}, {views.percent(hi)}]"
            share = f"{views.percent(c['share'])} %{band}"
        mine = {"verdict": c["words"], "decisive": c["decisive"], "share": share,
                "short": re.sub(r" \((\d+ parts|weakest of \d+)\)$", "", c["decisive"]),
                "robust": "--" if c["robust"] is None else ("robust" if c["robust"] else "depends on the reading")}
        for field, value in mine.items():
            name = f"{c['key']}_{field}"
            if name in out:
                raise ValueError(f"doc: claim key {c['key']!r} gives {name!r}, which names another value")
            out[name] = value
    return out


def has_text(name: str, kind: str = "summary") -> bool:
    """Whether paper ``name`` is registered and its package carries ``<kind>.md`` (:func:`summary_template`), so that a
    caller can fall back for a paper without one while a template its results cannot fill stays an error."""
    if kind not in _TEXTS:
        raise ValueError(f"kind: expected one of {', '.join(_TEXTS)}, got {kind!r}")
    if not isinstance(name, str) or name not in REGISTRY:
        return False
    try:
        return importlib.resources.files(f"{__name__}.{name}").joinpath(f"{kind}.md").is_file()
    except ModuleNotFoundError:
        return False


def summary(name: str, doc: Mapping[str, Any] | None = None) -> str:
    """What the replication of paper ``name`` found, in one paragraph (Markdown): its ``summary.md``
    (:func:`summary_template`) with the placeholders filled from its results ``doc`` (default: the committed
    ``data/results/<name>.json`` of this checkout, read by :func:`mmlib.experiment.results.read_results`).
    ValueError naming ``name`` for an unknown paper or one without a summary, naming ``doc`` when the results lack a
    value the summary needs or belong to another paper."""
    return _filled(name, "summary", doc)


def finding(name: str, doc: Mapping[str, Any] | None = None) -> str:
    """What the replication of paper ``name`` found, in one line (Markdown, the README's "What we found"; it starts
    after the paper's name, e.g. "(IMM with a fifth-degree CKF): 0 of Table 1's 16 cells ..."): its ``finding.md``
    filled from its results ``doc`` as :func:`summary` fills the paragraph; the same errors."""
    return _filled(name, "finding", doc)


def _filled(name: str, kind: str, doc: Mapping[str, Any] | None) -> str:
    template = summary_template(name, kind)
    if doc is None:
        path = _RESULTS / f"{name}.json"
        if not path.is_file():
            raise ValueError(f"doc: no results given and no {path} (run `make figures PAPER={name}`)")
        from mmlib.experiment.results import read_results
        doc = read_results(path)
    if not isinstance(doc, Mapping) or doc.get("paper") != name:
        raise ValueError(f"doc: expected the results document of {name!r}, got "
                         f"{doc.get('paper') if isinstance(doc, Mapping) else type(doc).__name__!r}")
    try:
        return template.strip().format_map(summary_values(doc))
    except (KeyError, IndexError, AttributeError) as exc:
        raise ValueError(f"doc: the {kind} of {name!r} needs {exc} from the results, which lack it") from None
