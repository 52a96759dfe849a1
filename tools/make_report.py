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
import re
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from mmlib.experiment.writing import NARROW_SUFFIX, atomic_write_text  # noqa: E402
from mmlib.experiment.results import read_results  # noqa: E402
from mmlib.experiment import verdicts, views  # noqa: E402
from mmlib.experiment.views import markdown_table, value_pm  # noqa: E402


def sentence(text: str) -> str:
    """``text`` as a sentence: its first letter upper-case, a full stop at the end."""
    return text[:1].upper() + text[1:] + ("" if text.endswith(".") else ".")


def is_control(doc: dict) -> bool:
    """Whether a results document is a control of the pipeline (a Paper of kind "control", e.g.
    data/results/controls.json): its top-level ``kind`` says so, or it carries a ``controls`` section."""
    return doc.get("kind") == "control" or "controls" in doc


def qualifier_of(doc: dict) -> str:
    """The qualifier of a paper's verdicts ("" or "reconstruction"): the document's own ``qualifier`` (top level or
    provenance) or, failing that, the first one its claims carry."""
    q = doc.get("qualifier") or doc.get("provenance", {}).get("qualifier")
    if q:
        return str(q)
    return next((str(c["qualifier"]) for c in doc.get("claims", []) if c.get("qualifier")), "")


def render_forensics(mv: dict) -> list:
    """The forensic subsections of a stored multiverse that the results carry (a file written before them renders
    none of them): sensitivity curves, planted-reading recovery, run-count stability and degenerate universes."""
    lines = []
    if mv.get("sensitivity") is not None:
        lines += ["", "### Sensitivity curves (tuning swept, not readings)", "",
                  "A sensitivity factor sweeps an unstated tuning value over a range; its options are not readings of "
                  "the paper, so they are never searched by the table match nor counted among the readings that "
                  "reproduce. Each row holds the other factors at their headline.", "", views.sensitivity_table(mv)]
    if mv.get("recovery") is not None:
        lines += ["", "### Can the table match find a reading? Planted-reading recovery", "",
                  "Readings drawn at random from the declared space are planted: a synthetic printed table is made "
                  "from each at the paper's run count, seed stream and printed precision, and the table match ranks "
                  "the universes against it. Paper-wide: " + views.recovery_text(mv["recovery"]) + ".", "",
                  views.recovery_table(mv)]
    if mv.get("stability") is not None:
        lines += ["", "### Run-count stability", "", views.stability_text(mv)]
    found = views.degenerate_list(mv)
    if found is not None:
        lines += ["", "### Degenerate universes", "", views.degenerate_text(mv)]
    return lines


def render_forensic_sections(doc: dict, level: int = 2, suffix: str = "") -> list:
    """The forensic sections of a paper's results that a page may lack (the site appends them to the paper's
    notebook page): the controls (for a control), the consistency table and the multiverse's forensic subsections
    (:func:`render_forensics`), each only when the results carry it; ``level`` the heading level of the sections,
    ``suffix`` appended to each heading (so that it cannot collide with a heading of the notebook)."""
    h = "#" * level
    lines = []
    if isinstance(doc.get("controls"), dict):
        lines += ["", f"{h} The controls of the pipeline{suffix}", "", sentence(views.controls_text(doc["controls"]))]
    if doc.get("consistency") is not None:
        lines += ["", f"{h} Consistency: NEES and NIS against their chi-square bands{suffix}", "",
                  views.consistency_table(doc["consistency"])]
    if doc.get("multiverse"):
        sub = render_forensics(doc["multiverse"])
        lines += [x.replace("### ", f"{h} ", 1).rstrip() + suffix if x.startswith("### ") else x for x in sub]
    return lines


def render_multiverse(mv: dict, qualifier: str = "") -> list:
    """The reading-space section of a paper's report, from the stored ``multiverse`` object: the design and its
    weighting, the factors and options, the claims' shares of the reading space with their intervals (the headline
    verdicts qualified by ``qualifier`` for a reconstructed set-up), the claim x option table, the published numbers
    (joint tests, precision-aware closest universe), the table match with its forensic sentences, and the forensic
    subsections the results carry (:func:`render_forensics`)."""
    from mmlib.experiment.multiverse import PRECISION, ROBUST_FRACTION
    shares = ("Every universe of the full factorial weighs the same: a share is exact when the full factorial is "
              "run, else estimated from the uniform random sample with a 95 % Wilson score interval; the headline "
              "and the universes varying one option alone (the star) are reported apart and not counted. A verdict "
              f"is *robust* when its interval's lower bound is at least {100 * ROBUST_FRACTION:.0f} %."
              if mv["weighting"].startswith(("full", "uniform")) else
              "The design is not a uniform sample of the reading space, so no share is computed from it; the counts "
              "describe the design only.")
    return ["", "## Reading space (multiverse)", "",
            f"Design: {mv['design_description']}; {mv['n_runs']} Monte Carlo runs per universe, common random "
            f"numbers across universes. Weighting: {mv['weighting']}. {views.summary_line(mv)}.", "",
            "### Factors", "",
            views.factors_table(mv["factors"]), "", "Each option, and where the paper's text supports it:", "",
            views.options_table(mv["factors"]), "", "### Claims across the reading space", "", shares, "",
            views.claims_table(mv, qualifier), "", "### Claim × option", "",
            "Share of each claim's most frequent verdict among the counted universes with each option: what drives "
            "the verdict.", "", views.claim_option_table(mv), "",
            "### Published numbers across the universes", "",
            "A cell reproduced inside a row or table that fails its joint test (Σz² against χ² with one degree of "
            "freedom per cell) is *isolated* and not counted as reproduced. The closest universe is chosen among "
            f"those whose value is precise enough (s.e. ≤ {100 * PRECISION:.0f} % of the printed value), by relative "
            "distance.", "", views.numbers_table(mv), "",
            "### Which reading matches each published table", "", views.table_match_table(mv),
            "", "The best-matching reading is a forensic finding (which declared reading the printed table is "
            "consistent with), not the headline; no continuous parameter is fitted. Only readings of the text are "
            "searched (sensitivity sweeps and options motivated by the results or another paper are not), and a "
            "factor the table cannot identify (planted-reading recovery) is never named as what it is consistent "
            "with.", "", *[f"- {views.table_match_sentence(t)}." for t in mv["table_match"]],
            *render_forensics(mv)]


def render_figures(doc: dict, root: Path, out_dir: Path) -> list:
    lines = []
    for stem, fig in doc.get("figures", {}).items():
        png = next((f for f in fig["files"] if f.endswith(".png") and not f.endswith(NARROW_SUFFIX)), None)
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
                              else verdicts.format_pm(c['difference_m2'], c['stderr_m2']),
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
             "Verdict rule: `mmlib/experiment/verdicts.py`.", ""]
    if doc.get("rule"):
        lines += [f"*Assumption of the rule:* {doc['rule']['paper_error_assumption']}", ""]
    if isinstance(doc.get("controls"), dict):
        lines += ["## The controls of the pipeline", "",
                  "A control is a \"published\" table known in closed form: the pipeline (simulation, filter, Monte "
                  "Carlo metrics, the verdict rule, the reading space) must reproduce every cell of it (positive "
                  "control) and reject every cell of the same table perturbed (negative control).", "",
                  sentence(views.controls_text(doc["controls"])), ""]
    if qualifier_of(doc):
        lines += [f"*Qualifier:* the set-up is a {qualifier_of(doc)} (the paper does not give it); every claim "
                  "verdict below is a verdict on it, not on the paper, and is kept out of pooled tallies.", ""]
    lines += ["## Comparison", ""]
    lines.append(markdown_table(
        ["item", "algorithm", "quantity", "paper", "replicated ± s.e.", "z", "verdict", "deviations", "note"],
        [[r["item"], r["algorithm"], r["quantity"], r["paper"] or "--",
          value_pm(r["replicated"], r["stderr"]), "--" if r.get("distance") is None else f"{r['distance']:+.1f}",
          r["verdict"], ", ".join(r["deviations"]), r.get("note", "")]
         for r in doc["rows"]]))
    failing = [t for t in doc.get("joint_tests", []) if not t["passes"]]
    if doc.get("joint_tests"):
        lines += ["", f"Joint tests (Σz² against χ² with one degree of freedom per Monte Carlo cell, level "
                      f"{doc['rule']['joint_alpha']:.2g}): {len(doc['joint_tests']) - len(failing)} of "
                      f"{len(doc['joint_tests'])} tables and rows pass"
                  + ("." if not failing else "; failing: " + "; ".join(
                      f"{t['item']}{'' if t['algorithm'] is None else ', ' + t['algorithm']} (Σz² {t['statistic']:.3g}"
                      f" on {t['dof']} cells"
                      + (f", {t['n_isolated']} reproduced cell(s) isolated" if t["n_isolated"] else "") + ")"
                      for t in failing) + ".")]
    if doc.get("claims"):
        across = {c["claim"]: c for c in doc.get("multiverse", {}).get("claims_summary", [])}
        lines += ["", "## Claims of the abstract and conclusions", "",
                  markdown_table(["claim", "verdict — decisive number — share of the reading space", "evidence"],
                                 [[c["claim"], views.claim_cell(c, across.get(c["claim"])), c["evidence"]]
                                  for c in doc["claims"]])]
        if any(c.get("parts") for c in doc["claims"]):
            from mmlib.experiment.notebook import claim_matrix
            lines += ["", "### Claim × comparison", "", claim_matrix(doc["claims"])]
    if doc.get("consistency") is not None:
        lines += ["", "## Consistency: NEES and NIS against their chi-square bands", "",
                  "A consistent filter's ANEES has the state dimension as its mean and its ANIS the measurement "
                  "dimension; the 95 % band of the NIS's run-and-time average is exact for white innovations, the "
                  "NEES's is that of a run-average at one step (Bar-Shalom, Li & Kirubarajan 2001, Sec. 5.4.2).", "",
                  views.consistency_table(doc["consistency"])]
    if doc.get("multiverse"):
        lines += render_multiverse(doc["multiverse"], qualifier_of(doc))
    if doc.get("figures"):
        lines += ["", "## Figures", ""] + render_figures(doc, root, out_dir)
    if doc.get("deviations"):
        lines += ["## Deviations", "", markdown_table(
            ["id", "topic", "paper", "our choice", "why", "sweep"],
            [[d["id"], d["topic"], d["paper"], d["choice"], d["reason"], d.get("sweep", "")]
             for d in doc["deviations"]])]
    return "\n".join(lines) + "\n"


def markdown_chip(qualifier: str) -> str:
    """A qualifier as a chip in plain Markdown (reports/README.md): ``*[reconstruction]*``."""
    return f"*[{qualifier}]*"


def pooled_tallies(docs: list[dict]) -> dict:
    """Verdict tallies pooled over the papers, with what pooling would mix kept apart: the controls (they test the
    pipeline, not a paper) and every verdict carrying a qualifier (a paper whose set-up is reconstructed: its rows
    and claims judge the reconstruction, not the paper), and the claims of a paper whose headline universe is
    degenerate (no filter beats the no-information baseline: its comparisons measure only how the filters fail; its
    rows, printed numbers, stay pooled), listed in ``apart["degenerate_headlines"]``. Returns ``{"papers": [names
    pooled], "rows": {number verdict: count}, "claims": {claim verdict: count}, "apart": {"controls": [names],
    "qualified_papers": [names], "qualified_rows": {verdict: count}, "qualified_claims": {stated words: count}}}``;
    the arena is not a paper and takes no part."""
    from mmlib.experiment.verdicts import CLAIM_VERDICTS, VERDICTS, claim_category, verdict_category
    papers = [d for d in docs if d.get("kind") != "arena"]
    out = {"papers": [], "rows": {str(v): 0 for v in VERDICTS}, "claims": {str(v): 0 for v in CLAIM_VERDICTS},
           "apart": {"controls": [], "qualified_papers": [], "qualified_rows": {str(v): 0 for v in VERDICTS},
                     "qualified_claims": {}}}
    out["apart"]["degenerate_headlines"] = []
    for d in papers:
        if is_control(d):
            out["apart"]["controls"].append(d["paper"])
            continue
        universes = (d.get("multiverse") or {}).get("universes") or [{}]
        degenerate = bool(universes[0].get("degenerate"))  # no filter beats the raw measurements at the headline
        if degenerate:
            out["apart"]["degenerate_headlines"].append(d["paper"])
        q = qualifier_of(d)
        if q:
            out["apart"]["qualified_papers"].append(d["paper"])
        else:
            out["papers"].append(d["paper"])
        rows = out["apart"]["qualified_rows"] if q else out["rows"]
        for r in d["rows"]:
            rows[str(verdict_category(r["verdict"]))] += 1
        for c in d.get("claims", []):
            if degenerate and not (c.get("qualifier") or q):
                words = f"{views.claim_words(c)} (degenerate headline)"
                out["apart"]["qualified_claims"][words] = out["apart"]["qualified_claims"].get(words, 0) + 1
            elif c.get("qualifier") or q:
                words = views.claim_words(c if c.get("qualifier") or c.get("stated") else {**c, "qualifier": q})
                out["apart"]["qualified_claims"][words] = out["apart"]["qualified_claims"].get(words, 0) + 1
            else:
                out["claims"][str(claim_category(c["verdict"]))] += 1
    return out


def _counts(counts: dict) -> str:
    return ", ".join(f"{k} {n}" for k, n in counts.items() if n) or "none"


def render_index(docs, link=None, title: str = "# All papers: what holds", chip=None) -> str:
    """Cross-paper summary: first the controls of the pipeline (does the machinery reproduce a paper that is right?),
    then verdict counts per paper with the tallies pooled over the papers (controls and verdicts on a reconstructed
    set-up kept apart, :func:`pooled_tallies`) and every claim verdict, one line each; the arena's findings.

    ``link(paper)`` is the Markdown link to a paper's page (default: its report, ``[<paper>.md](<paper>.md)``; the
    site links its notebook pages instead); ``title`` the first line; ``chip(qualifier)`` the mark set beside a
    paper whose verdicts carry a qualifier (default :func:`markdown_chip`; the site draws a styled chip)."""
    from mmlib.experiment.multiverse import PRECISION
    from mmlib.experiment.verdicts import PAPER_ERROR_ASSUMPTION, VERDICTS, verdict_category
    link = link or (lambda paper: f"[{paper}.md]({paper}.md)")
    chip = chip or markdown_chip
    arena = [d for d in docs if d.get("kind") == "arena"]
    controls = [d for d in docs if d.get("kind") != "arena" and is_control(d)]
    docs = [d for d in docs if d.get("kind") != "arena" and not is_control(d)]
    pooled = pooled_tallies([*controls, *docs])
    lines = [title, ""]
    if controls:
        lines += ["## Controls: the machinery reproduces when the paper is right", "",
                  "Before any paper, the pipeline (simulation, filter, Monte Carlo metrics, the verdict rule, the "
                  "reading space) is run on \"published\" tables known in closed form: it must reproduce every cell "
                  "of the true table (positive control) and reject every cell of the same table perturbed (negative "
                  "control). The controls are not papers and take no part in the tallies below.", ""]
        lines += [f"- {link(d['paper'])}: " + (views.controls_text(d["controls"]) if isinstance(d.get("controls"), dict)
                                                else "no controls section in its results") + "." for d in controls]
        lines += [""]

    def name(d):
        q = qualifier_of(d)
        return d["paper"] + (f" {chip(q)}" if q else "")

    count_rows = [[name(d), d["provenance"]["n_runs"],
                   *[sum(verdict_category(r["verdict"]) == v for r in d["rows"]) for v in VERDICTS],
                   link(d["paper"])] for d in docs]
    if docs:
        count_rows.append([f"pooled over the {len(pooled['papers'])} papers whose set-up is given", "--",
                           *[pooled["rows"][str(v)] for v in VERDICTS], "--"])
    if pooled["apart"]["qualified_papers"]:
        count_rows.append([f"apart: verdicts on a reconstruction ({', '.join(pooled['apart']['qualified_papers'])})",
                           "--", *[pooled["apart"]["qualified_rows"][str(v)] for v in VERDICTS], "--"])
    lines += ["Generated from `data/results/*.json`. Verdict rule: `mmlib/experiment/verdicts.py`. Counts are over the "
              "comparison rows of each paper (tables; timing rows included); a *reproduced (isolated)* cell matched "
              "inside a table or row that fails its joint test and does not count as reproduced. The pooled row "
              "leaves out the controls and the papers whose set-up had to be reconstructed (their verdicts judge the "
              "reconstruction, not the paper: shown apart); the claims of a paper whose headline universe is "
              "degenerate are counted apart too.", "",
              f"*Assumption of the rule:* {PAPER_ERROR_ASSUMPTION}", "",
              markdown_table(["paper", "runs", *VERDICTS, "report"], count_rows), ""]
    with_mv = [d for d in docs if d.get("multiverse")]
    if with_mv:
        lines += ["## Reading spaces: does some reading reproduce the tables, and are the verdicts robust?", "",
                  "Each paper's ambiguities are declared as factors and every universe of the design is run "
                  "(common random numbers). *Headline* is the reading chosen on the text before any run; "
                  "*best reading* is the declared reading whose numbers are closest to the whole printed table "
                  "(root-mean-square relative distance, among universes whose every value has a standard error "
                  f"within {100 * PRECISION:.0f} % of the printed one) -- a forensic finding, never the headline; "
                  "only readings of the text are searched (no tuning sweep, no option motivated by the results), and "
                  "*recovered first* is how often the table match ranks first a reading planted at random in the "
                  "space. A cell reproduced inside a row or table failing its joint test is isolated and not "
                  "counted.", "",
                  markdown_table(["paper", "universes", "runs each", "weighting", "table", "cells",
                                  "reproduced: headline universe", "headline joint test",
                                  "reproduced: best-matching reading", "best-matching reading",
                                  "most cells any reading reproduces", "that reading",
                                  "planted reading recovered first"],
                                 [[name(d), d["multiverse"]["n_universes"], d["multiverse"]["n_runs"],
                                   d["multiverse"]["weighting"], t["table"], t["n_cells"], t["headline_n_reproduced"],
                                   "--" if t["joint_test"] is None else
                                   ("passes" if t["joint_test"]["passes"] else "fails"),
                                   t["best_n_reproduced"], views.reading_text(t, "best"),
                                   t["most_n_reproduced"], views.most_reading(t),
                                   "--" if not isinstance(t.get("recovery"), dict) or t["recovery"].get("top1") is None
                                   else f"{views.percent(t['recovery']['top1'])} % of {t['recovery']['planted']}"]
                                  for d in with_mv for t in d["multiverse"]["table_match"]]), ""]
    apart = pooled["apart"]["qualified_claims"]
    lines += ["## Claims", "", "Each claim: the headline reading's verdict, the one number that decided it, and the "
              "share of the paper's reading space (every universe of the full factorial weighted equally) with that "
              "verdict, with its 95 % interval when estimated from a uniform sample of universes; *robust* when one "
              "verdict's interval lies at or above 90 %. A verdict on a reconstructed set-up says so (\"contradicted "
              "by the reconstruction\").", "",
              f"Pooled over the {len(pooled['papers'])} papers whose set-up is given "
              f"({sum(pooled['claims'].values())} claims, headline verdicts): {_counts(pooled['claims'])}"
              + (f"; apart, {sum(apart.values())} claims on a reconstruction or a degenerate headline "
                 f"({', '.join(pooled['apart']['qualified_papers'] + pooled['apart']['degenerate_headlines'])}): "
                 f"{_counts(apart)}" if apart else "") + ".", ""]
    for d in docs:
        mv = d.get("multiverse", {})
        across = {c["claim"]: c for c in mv.get("claims_summary", [])}
        note = f" ({mv['weighting']})" if mv.get("weighting") else ""
        q = qualifier_of(d)
        lines += [f"### {d['paper']}", ""]
        if q:
            lines += [f"{chip(q)} The set-up is a {q}: these verdicts judge it, not the paper, and are kept out of "
                      "the pooled tallies.", ""]
        lines += [markdown_table(["claim", "verdict — decisive number — share of the reading space" + note,
                                  "across the reading space"],
                                 [[c["claim"], views.claim_cell(c, across.get(c["claim"])),
                                   across[c["claim"]]["robustness"] if c["claim"] in across else "--"]
                                  for c in d.get("claims", [])]), ""]
    for d in arena:
        lines += ["## The arena: every algorithm on every scenario", "",
                  f"{len(d['cells'])} cells ({sum('reason' not in c for c in d['cells'])} applicable) at "
                  f"{d['provenance']['n_runs']} runs each: {link('arena')}.", "", *d["findings"], ""]
    return "\n".join(lines) + "\n"


#: the markers of the README's generated "What we found" block (exactly one of each, start before end)
FINDINGS_START, FINDINGS_END = "<!-- findings:start -->", "<!-- findings:end -->"


def citation_label(citation: str) -> str:
    """A paper's short name from its citation ("W. Zhu, W. Wang, G. Yuan, An Improved ..., Sensors 16(6):805, 2016"
    -> "Zhu et al. 2016"; two authors "Liu & Wu 2017"; "H. L. van Trees, ..., 1968" -> "van Trees 1968"): the leading
    initial-and-surname authors (a surname with its lower-case particles) and the first year."""
    if not isinstance(citation, str):
        raise ValueError(f"citation: expected a string, got {type(citation).__name__}")
    citation = citation.split(";")[0]                    # the first reference of several
    authors = []
    for part in citation.split(", "):
        m = re.fullmatch(r"(?:[A-Z]\.(?:-[A-Z]\.)?\s?)+((?:(?:van|von|der|den|de|del|della|di|da|du|la|le|ter)\s)*"
                         r"[A-Z][\w'-]+)", part.strip())      # a surname with its particles: "H. L. van Trees"
        if not m:
            break
        authors.append(m.group(1))
    year = re.search(r"(?<=, )(?:19|20)\d\d(?=[,;( ]|$)", citation)       # a year, not a page range
    if not authors or not year:
        raise ValueError(f"citation: no leading authors or year in {citation!r}")
    who = authors[0] if len(authors) == 1 else " & ".join(authors) if len(authors) == 2 else f"{authors[0]} et al."
    return f"{who} {year.group(0)}"


def arena_line(doc: dict) -> str:
    """The arena in a few words for the README: algorithms × scenarios and runs, and its first pooled finding with
    the scenario lists and the kept-out scenarios left out (the report has them)."""
    first = next((f for f in (re.sub(r"^[-*]\s*", "", f) for f in doc.get("findings") or [])
                  if f.startswith("**") and "where both apply" in f), "")
    first = re.sub(r"^\*\*(.+?)\*\* \([^)]*\):", r"\1:", first)           # the algorithms compared
    first = re.sub(r" \((?:[a-z][a-z0-9-]*(?:, )?)+\)", "", first)            # the scenario lists
    first = re.sub(r"; kept out: .*$", "", first).rstrip(". ")
    n_alg, n_scen = len(doc.get("algorithms") or []), len(doc.get("scenarios") or [])
    return (f"{n_alg} algorithms × {n_scen} scenarios, {doc['provenance']['n_runs']} runs each"
            + (f"; {first}" if first else ""))


def findings_block(docs: list[dict]) -> str:
    """The README's "What we found" lines (between the markers, exclusive): one per paper of the registry in its
    order, "**[Zhu et al. 2016](reports/zhu2016.md)** (IMM with ...): ..." (its one-line finding,
    :func:`mmlib.papers.finding`, filled from its results, or :func:`mmlib.experiment.views.findings_line` when its
    package has none), then one line on the controls and the arena together."""
    from mmlib import papers
    by_name = {d["paper"]: d for d in docs}
    lines, last = [], []
    for name in papers.REGISTRY:
        if name not in by_name:
            continue
        paper, doc = papers.REGISTRY[name], by_name[name]
        if paper.kind == "control":
            last.append(f"[Controls](reports/{name}.md): " + papers.finding(name, doc))
            continue
        link = f"**[{citation_label(paper.citation)}](reports/{name}.md)**"
        # a paper without a finding.md: its generated line; a finding its results cannot fill is an error
        lines.append(f"- {link} {papers.finding(name, doc)}" if papers.has_text(name, "finding")
                     else f"- {views.findings_line(doc, link)}")
    last += [f"[the arena](reports/{d['paper']}.md): " + arena_line(d) for d in docs if d.get("kind") == "arena"]
    if last:
        lines.append("- " + "; ".join(last) + ".")
    return "\n".join(lines)


def readme_with_findings(readme_text: str, docs: list[dict]) -> str:
    """``readme_text`` with the block between ``<!-- findings:start -->`` and ``<!-- findings:end -->`` replaced by
    :func:`findings_block` of ``docs`` (the markers kept).  ValueError naming ``readme_text`` when a marker is
    missing, repeated or the end comes before the start."""
    if not isinstance(readme_text, str):
        raise ValueError(f"readme_text: expected the README's text, got {type(readme_text).__name__}")
    for marker in (FINDINGS_START, FINDINGS_END):
        n = readme_text.count(marker)
        if n != 1:
            raise ValueError(f"readme_text: expected exactly one {marker!r}, found {n}")
    start = readme_text.index(FINDINGS_START) + len(FINDINGS_START)
    end = readme_text.index(FINDINGS_END)
    if end < start:
        raise ValueError(f"readme_text: {FINDINGS_END!r} comes before {FINDINGS_START!r}")
    return readme_text[:start] + "\n" + findings_block(docs) + "\n" + readme_text[end:]


def write_readme_findings(readme: Path, docs: list[dict]) -> bool:
    """Rewrite the findings block of the README at ``readme`` from ``docs`` (atomically); True when it changed."""
    old = readme.read_text()
    new = readme_with_findings(old, docs)
    if new != old:
        atomic_write_text(readme, new)
    return new != old


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
        if root == REPO:           # the committed results: the front page's findings follow them
            try:
                if write_readme_findings(REPO / "README.md", docs):
                    print("README.md: findings block rewritten")
            except ValueError as exc:
                print(f"make_report.py: error: README.md: {exc}", file=sys.stderr)
                return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
