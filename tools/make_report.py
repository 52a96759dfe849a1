#!/usr/bin/env python
"""Render reports/<paper>.md from data/results/<paper>.json: the paper-versus-replication
tables, claim verdicts, deviations and embedded figures, readable without Jupyter; and reports/README.md,
the cross-paper summary.

The notebook runner (tools/run_notebooks.py) calls :func:`paper_reports` to render a paper's reports into its
staging folder, so that they are promoted together with the paper's results; run this script by hand only to
re-render every report from the results already in place.  Every results file is read with
``mmlib.experiment.results.read_results``: one that is not valid JSON or breaks the results contract is an error naming
the file and the place (exit status 2)."""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from mmlib.experiment.writing import atomic_write_text  # noqa: E402
from mmlib.experiment.results import read_results  # noqa: E402
from mmlib.experiment import views  # noqa: E402
from mmlib.experiment.views import markdown_table, value_pm  # noqa: E402


def render_multiverse(mv: dict) -> list:
    """The reading-space section of a paper's report, from the stored ``multiverse`` object."""
    return ["", "## Reading space (multiverse)", "",
            f"Design: {mv['design_description']}; {mv['n_runs']} Monte Carlo runs per universe, common random "
            f"numbers across universes. {views.summary_line(mv)}.", "", "### Factors", "",
            views.factors_table(mv["factors"]), "", "Each option, and where the paper's text supports it:", "",
            views.options_table(mv["factors"]), "", "### Claims across the universes", "", views.claims_table(mv), "",
            "### Published numbers across the universes", "", views.numbers_table(mv), "",
            "### Which reading matches each published table", "", views.table_match_table(mv),
            "", "The best-matching reading is a forensic finding (which declared reading the printed table is "
            "consistent with), not the headline; no continuous parameter is fitted."]


def render_figures(doc: dict, root: Path, out_dir: Path) -> list:
    lines = []
    for stem, fig in doc.get("figures", {}).items():
        png = next((f for f in fig["files"] if f.endswith(".png")), None)
        lines += [f"### {stem}", "", f"**Paper:** {fig['paper_claim']}  ", f"**Ours:** {fig['ours']}", ""]
        if png:
            lines += [f"![{stem}]({os.path.relpath(root / png, out_dir)})", ""]
    return lines


def render_arena(doc: dict, root: Path, out_dir: Path) -> str:
    """reports/arena.md: the scenarios, the findings, the papers' ideas scenario by scenario and every cell."""
    from mmlib.arena.views import cell_table
    prov = doc["provenance"]
    lines = ["# The arena: every algorithm on every scenario", "",
             f"Generated from `data/results/arena.json` — profile `{prov['profile']}`, {prov['n_runs']} Monte Carlo "
             f"runs per cell, commit `{prov['git_commit']}`. Verdict rule: `mmlib/experiment/verdicts.py`.", "",
             "## Scenarios", "",
             markdown_table(["scenario", "what", "steps", "nonlinearity index (median)"],
                            [[r["scenario"], r["title"], r["n_steps"], f"{r['nonlinearity_index']['median']:.3g}"]
                             for r in doc["scenarios"]]),
             "", "## Findings", "", *doc["findings"], "", "## The papers' ideas, scenario by scenario", "",
             markdown_table(["idea", "A − B", "scenario", "Δ position MSE (m²) ± s.e.", "verdict"],
                            [[i["idea"], f"{i['a']} − {i['b']}", c["scenario"],
                              "--" if c["difference_m2"] is None
                              else f"{c['difference_m2']:.4g} ± {c['stderr_m2']:.2g}",
                              c["verdict"]] for i in doc["ideas"] for c in i["comparisons"]]),
             "", "## The papers' accuracy claims across the arena", "",
             markdown_table(["paper", "claim", "pair", "scenario: verdict"],
                            [[pc["paper"], pc["claim"], f"{pair['a']} vs {pair['b']}",
                              "; ".join(f"{s}: {v}" for s, v in pair["verdicts"].items()) or "--"]
                             for pc in doc.get("paper_claims", []) for pair in pc["pairs"]]),
             "", "## Figures", ""]
    lines += render_figures(doc, root, out_dir)
    lines += ["## Every cell", ""]
    for r in doc["scenarios"]:
        rows = cell_table(doc["cells"], r["scenario"])
        lines += [f"### {r['scenario']}", "", markdown_table(list(rows[0]), [list(x.values()) for x in rows]), ""]
    return "\n".join(lines) + "\n"


def render(doc: dict, root: Path, out_dir: Path) -> str:
    if doc.get("kind") == "arena":
        return render_arena(doc, root, out_dir)
    prov = doc["provenance"]
    lines = [f"# {doc['paper']}: paper versus replication", "",
             f"{prov.get('paper_citation', '')}", "",
             f"Generated from `data/results/{doc['paper']}.json` — profile `{prov['profile']}`, "
             f"{prov['n_runs']} Monte Carlo runs, root seed {prov['root_seed']}, commit `{prov['git_commit']}`. "
             "Verdict rule: `mmlib/experiment/verdicts.py`.", "", "## Comparison", ""]
    lines.append(markdown_table(
        ["item", "algorithm", "quantity", "paper", "replicated ± s.e.", "verdict", "deviations", "note"],
        [[r["item"], r["algorithm"], r["quantity"], r["paper"] or "--",
          value_pm(r["replicated"], r["stderr"]), r["verdict"], ", ".join(r["deviations"]), r.get("note", "")]
         for r in doc["rows"]]))
    if doc.get("claims"):
        lines += ["", "## Claims of the abstract and conclusions", "",
                  markdown_table(["claim", "verdict", "evidence"],
                                 [[c["claim"], c["verdict"], c["evidence"]] for c in doc["claims"]])]
    if doc.get("multiverse"):
        lines += render_multiverse(doc["multiverse"])
    if doc.get("figures"):
        lines += ["", "## Figures", ""] + render_figures(doc, root, out_dir)
    if doc.get("deviations"):
        lines += ["## Deviations", "", markdown_table(
            ["id", "topic", "paper", "our choice", "why", "sweep"],
            [[d["id"], d["topic"], d["paper"], d["choice"], d["reason"], d.get("sweep", "")]
             for d in doc["deviations"]])]
    return "\n".join(lines) + "\n"


def render_index(docs, link=None, title: str = "# All papers: what holds") -> str:
    """Cross-paper summary: verdict counts per paper and every claim verdict, one line each; the arena's findings.

    ``link(paper)`` is the Markdown link to a paper's page (default: its report, ``[<paper>.md](<paper>.md)``; the
    site links its notebook pages instead); ``title`` the first line."""
    from mmlib.experiment.verdicts import VERDICTS
    link = link or (lambda paper: f"[{paper}.md]({paper}.md)")
    arena = [d for d in docs if d.get("kind") == "arena"]
    docs = [d for d in docs if d.get("kind") != "arena"]
    lines = [title, "",
             "Generated from `data/results/*.json`. Verdict rule: `mmlib/experiment/verdicts.py`. Counts are over the "
             "comparison rows of each paper (tables; timing rows included).", "",
             markdown_table(["paper", "runs", *VERDICTS, "report"],
                            [[d["paper"], d["provenance"]["n_runs"],
                              *[sum(r["verdict"].startswith(v) for r in d["rows"]) for v in VERDICTS],
                              link(d["paper"])] for d in docs]), ""]
    with_mv = [d for d in docs if d.get("multiverse")]
    if with_mv:
        lines += ["## Reading spaces: does some reading reproduce the tables, and are the verdicts robust?", "",
                  "Each paper's ambiguities are declared as factors and every universe of the design is run "
                  "(common random numbers). *Headline* is the reading chosen on the text before any run; "
                  "*best reading* is the declared reading whose numbers are closest to the whole printed table "
                  "(sum of squared standardized distances, among universes whose values are precise enough to judge) "
                  "-- a forensic finding, never the headline.", "",
                  markdown_table(["paper", "universes", "runs each", "table", "cells", "reproduced: headline universe",
                                  "reproduced: best-matching reading", "best-matching reading",
                                  "most cells any reading reproduces", "that reading"],
                                 [[d["paper"], d["multiverse"]["n_universes"], d["multiverse"]["n_runs"], t["table"],
                                   t["n_cells"], t["headline_n_reproduced"], t["best_n_reproduced"], t["best_describe"],
                                   t["most_n_reproduced"], views.most_reading(t)]
                                  for d in with_mv for t in d["multiverse"]["table_match"]]), ""]
    lines += ["## Claims", "", "Verdict of the headline reading, and how it fares across the paper's reading space "
              "(*robust*: one verdict in at least 90 % of the universes).", ""]
    for d in docs:
        across = {c["claim"]: c for c in d.get("multiverse", {}).get("claims_summary", [])}

        def spread(c):
            s = across.get(c["claim"])
            if s is None:
                return "--"
            counts = ", ".join(f"{k} {n}" for k, n in s["verdict_counts"].items())
            return ("robust: " if s["robust"] else "depends on the reading: ") + counts
        lines += [f"### {d['paper']}", "", markdown_table(["claim", "verdict", "across the reading space"],
                                                          [[c["claim"], c["verdict"], spread(c)]
                                                           for c in d.get("claims", [])]), ""]
    for d in arena:
        lines += ["## The arena: every algorithm on every scenario", "",
                  f"{len(d['cells'])} cells ({sum('reason' not in c for c in d['cells'])} applicable) at "
                  f"{d['provenance']['n_runs']} runs each: {link('arena')}.", "", *d["findings"], ""]
    return "\n".join(lines) + "\n"


def shown(path: Path) -> str:
    """``path`` relative to the repository when inside it (as messages name files), else as it is."""
    return str(path.relative_to(REPO)) if path.is_relative_to(REPO) else str(path)


def load_results(root: Path, skip: str | None = None) -> list[dict]:
    """Every results document under ``root/data/results`` (sorted by file name), except paper ``skip``, each read
    and checked by :func:`mmlib.experiment.results.read_results` (ValueError naming the file and the place)."""
    # the file of paper ``skip`` is being replaced: it is not read at all (a broken old copy must not block that)
    return [read_results(path, name=shown(path)) for path in sorted((root / "data" / "results").glob("*.json"))
            if path.stem != skip]


def paper_reports(doc: dict, others: list[dict], root: Path) -> dict[str, str]:
    """The report files a paper owns, ``{path relative to root: text}``: ``reports/<paper>.md`` and the cross-paper
    ``reports/README.md``, rendered from ``doc`` and the other papers' current results ``others``.  Figure links
    are relative to ``root/reports``, where the files are promoted, whatever folder they are written to first."""
    docs = sorted([doc, *others], key=lambda d: d["paper"])
    return {f"reports/{doc['paper']}.md": render(doc, root, root / "reports"),
            "reports/README.md": render_index(docs)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--root", default=str(REPO), help="folder holding data/results and figures")
    args = ap.parse_args(argv)
    root = Path(args.root).resolve()
    out_dir = root / "reports"
    try:
        docs = load_results(root)
    except ValueError as exc:
        print(f"make_report.py: error: {exc}", file=sys.stderr)
        return 2
    for doc in docs:
        target = out_dir / f"{doc['paper']}.md"
        atomic_write_text(target, render(doc, root, out_dir))
        print(f"report: {target.relative_to(REPO) if target.is_relative_to(REPO) else target}")
    if docs:
        atomic_write_text(out_dir / "README.md", render_index(docs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
