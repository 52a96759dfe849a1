#!/usr/bin/env python
"""Render reports/<paper>.md from data/results/<paper>.json: the paper-versus-replication
tables, claim verdicts, deviations and embedded figures, readable without Jupyter."""
from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from mmlib.report import atomic_write_text  # noqa: E402
from mmlib.scenarios.presentation import markdown_table, value_pm  # noqa: E402


def render(doc: dict, root: Path, out_dir: Path) -> str:
    prov = doc["provenance"]
    lines = [f"# {doc['paper']}: paper versus replication", "",
             f"{prov.get('paper_citation', '')}", "",
             f"Generated from `data/results/{doc['paper']}.json` — profile `{prov['profile']}`, "
             f"{prov['n_runs']} Monte Carlo runs, root seed {prov['root_seed']}, commit `{prov['git_commit']}`. "
             "Verdict rule: `mmlib/report.py`.", "", "## Comparison", ""]
    lines.append(markdown_table(
        ["item", "algorithm", "quantity", "paper", "replicated ± s.e.", "verdict", "deviations", "note"],
        [[r["item"], r["algorithm"], r["quantity"], r["paper"] or "--",
          value_pm(r["replicated"], r["stderr"]), r["verdict"], ", ".join(r["deviations"]), r.get("note", "")]
         for r in doc["rows"]]))
    if doc.get("claims"):
        lines += ["", "## Claims of the abstract and conclusions", "",
                  markdown_table(["claim", "verdict", "evidence"],
                                 [[c["claim"], c["verdict"], c["evidence"]] for c in doc["claims"]])]
    if doc.get("figures"):
        lines += ["", "## Figures", ""]
        for stem, fig in doc["figures"].items():
            png = next((f for f in fig["files"] if f.endswith(".png")), None)
            lines += [f"### {stem}", "", f"**Paper:** {fig['paper_claim']}  ", f"**Ours:** {fig['ours']}", ""]
            if png:
                lines += [f"![{stem}]({os.path.relpath(root / png, out_dir)})", ""]
    if doc.get("deviations"):
        lines += ["## Deviations", "", markdown_table(
            ["id", "topic", "paper", "our choice", "why", "sweep"],
            [[d["id"], d["topic"], d["paper"], d["choice"], d["reason"], d.get("sweep", "")]
             for d in doc["deviations"]])]
    return "\n".join(lines) + "\n"


def render_index(docs) -> str:
    """Cross-paper summary: verdict counts per paper and every claim verdict, one line each."""
    from mmlib.report import VERDICTS
    lines = ["# All papers: what holds", "",
             "Generated from `data/results/*.json`. Verdict rule: `mmlib/report.py`. Counts are over the comparison "
             "rows of each paper (tables; timing rows included).", "",
             markdown_table(["paper", "runs", *VERDICTS, "report"],
                            [[d["paper"], d["provenance"]["n_runs"],
                              *[sum(r["verdict"].startswith(v) for r in d["rows"]) for v in VERDICTS],
                              f"[{d['paper']}.md]({d['paper']}.md)"] for d in docs]), "", "## Claims", ""]
    for d in docs:
        lines += [f"### {d['paper']}", "", markdown_table(["claim", "verdict"],
                                                          [[c["claim"], c["verdict"]] for c in d.get("claims", [])]), ""]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--root", default=str(REPO), help="folder holding data/results and figures")
    args = ap.parse_args(argv)
    root = Path(args.root).resolve()
    out_dir = root / "reports"
    docs = []
    for path in sorted((root / "data" / "results").glob("*.json")):
        doc = json.loads(path.read_text())
        docs.append(doc)
        target = out_dir / f"{doc['paper']}.md"
        atomic_write_text(target, render(doc, root, out_dir))
        print(f"report: {target.relative_to(REPO) if target.is_relative_to(REPO) else target}")
    if docs:
        atomic_write_text(out_dir / "README.md", render_index(docs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
