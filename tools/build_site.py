#!/usr/bin/env python
"""Build the offline site (``make site``): every paper as a report-like page from its executed notebook, the arena,
the reading spaces, a getting-started guide and the API reference, into build/site/.

Sources: the results and executed notebooks of a profile's outputs (``full``: the committed ones, data/results/ and
notebooks/executed/; ``smoke``: build/smoke/), this repository's docs/ folder (the configuration and the hand-written
pages) and mmlib's docstrings.  The builder assembles the page sources in a work folder (build/.site-work/src/):

* ``index.md``: the cross-paper verdict summary, rendered from the results by the same code as reports/README.md;
* ``controls/<notebook>.ipynb`` (the controls of the pipeline, first in the navigation), ``papers/<notebook>.ipynb``
  and ``arena.ipynb``: the executed notebooks, each code cell folded (its outputs and the narrative first), the
  papermill parameter cells removed, a paper's qualifier shown as a chip under its title and the forensic sections of
  its results (consistency, sensitivity curves, planted-reading recovery, run-count stability, degenerate universes)
  appended;
* ``reading-spaces.md`` and ``reading-spaces/<paper>.md``: an index and one page per paper's reading space, rendered
  from its results like its report, opening with its claims across the reading space;
* ``new-paper.md`` (from docs/): replicating a new paper, a walk through the contract with a worked example;
* the other hand-written pages of docs/: getting started, comparing two filters, the library, and how the
  replication is done (:data:`HOW_IT_IS_DONE`: the verdict rule, the reading-space method, the arena's design,
  reruns and scale-out, speed, layout and conventions);
* ``results-contract.md`` (from docs/): the results contract, showing and linking its JSON Schema,
  mmlib/experiment/results.schema.json (staged as ``_includes/results.schema.json``; the site also serves it as
  ``_static/results.schema.json``, see docs/conf.py);
* ``api/<module>.md``: one page per public module of mmlib, from its docstrings (autodoc);
* ``_includes/README.md``: the README, whose short library example the getting-started page includes;

then runs Sphinx with MyST-NB (docs/conf.py) with warnings as errors, and finishes the HTML
(:func:`postprocess_html`: the figures' files copied under ``_static/figures/``, each figure a link to its SVG, a
figure with panels side by side shown on a phone as its narrow variant, the panels stacked; every table's verdict
column marked, kept on screen by docs/_static/site.css).  The site is written to a work folder and
moved into place only when the build succeeded, so build/site/ is never half old and half new (see :func:`build`).

Why Sphinx with MyST-NB, not Jupyter Book 2: both are maintained tools of the Jupyter ecosystem, but Jupyter Book 2
(mystmd) is a Node.js program that fetches its site theme from the network when it builds, while Sphinx, MyST-NB and
the furo theme are Python packages pinned in requirements.lock, build offline and render the stored outputs of
.ipynb files directly; the same tool builds the API reference from the docstrings (autodoc).

Bad input: a missing results folder or executed notebook is an error saying which command makes it; a results file
that is not valid JSON or breaks the results contract is an error naming the file and the place
(:func:`mmlib.experiment.results.read_results`); a page that fails to build is named with its notebook and cell (MyST-NB
reports the cell as the line number divided by 10000).
"""
from __future__ import annotations

import argparse
import importlib
import json
import os
import pkgutil
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tools"))

from mmlib.experiment.writing import NARROW_SUFFIX  # noqa: E402

#: the cell-line encoding of MyST-NB's warnings: "line" = (cell index + 1) * 10000 + a line within the cell (the
#: first line of cell 0 is reported as 10002; checked by tests/test_site.py on a real build)
CELL_LINE = 10000


class SiteError(Exception):
    """The site cannot be built; the message says why and what to run."""


class MissingOutputs(SiteError):
    """Some notebook's results or executed notebook do not exist yet (the command that makes them is named)."""


def sources(profile: str) -> tuple[Path, Path, str]:
    """``(root holding data/results, folder of executed notebooks, the command that makes them)``."""
    if profile == "full":
        return REPO, REPO / "notebooks" / "executed", "make figures"
    if profile == "smoke":
        return REPO / "build" / "smoke", REPO / "build" / "smoke" / "executed", "make figures PROFILE=smoke"
    raise SiteError(f"--profile: expected 'full' or 'smoke', got {profile!r}")


def load_inputs(profile: str) -> tuple[list[dict], dict[str, Path]]:
    """The results documents (papers and arena) and ``{paper: executed notebook}``, for exactly the notebook sources
    of notebooks/*.py (``<paper>_<topic>.py``; the arena's is ``arena.py``): a stale results file or executed notebook
    of no current source is never published.  A SiteError names what is missing and the command to run first, or the
    results file that is not valid JSON or breaks the results contract, with the place
    (:func:`mmlib.experiment.results.read_results`)."""
    from mmlib.experiment.results import read_results
    root, executed, command = sources(profile)
    results = root / "data" / "results"
    then = f"then `make site{'' if profile == 'full' else ' PROFILE=' + profile}`"
    if not sorted(results.glob("*.json")):
        raise MissingOutputs(f"no results in {results.relative_to(REPO)}/: run `{command}` first, {then}")
    docs, notebooks, sources_of = [], {}, {}
    for src in sorted((REPO / "notebooks").glob("*.py")):     # first the sources alone: one notebook per paper
        paper = src.stem.split("_")[0]
        if paper in sources_of:
            raise SiteError(f"notebooks/{src.name}: a second notebook of {paper} ({sources_of[paper].name}); "
                            f"one notebook per paper")
        sources_of[paper] = src
    for paper, src in sources_of.items():
        nb, doc = executed / f"{src.stem}.ipynb", results / f"{paper}.json"
        for path in (nb, doc):
            if not path.is_file():
                raise MissingOutputs(f"{paper}: no {path.relative_to(REPO)} (from notebooks/{src.name}): "
                                     f"run `{command}` first, {then}")
        notebooks[paper] = nb
        try:
            docs.append(read_results(doc, name=str(doc.relative_to(REPO))))
        except ValueError as exc:
            raise SiteError(str(exc)) from None
    return sorted(docs, key=lambda d: d["paper"]), notebooks


def page_path(paper: str, notebooks: dict[str, Path], controls: frozenset = frozenset()) -> str:
    """A paper's page in the site: ``arena.ipynb``, ``controls/<notebook>.ipynb`` for a control of the pipeline,
    else ``papers/<notebook>.ipynb``."""
    if paper == "arena":
        return "arena.ipynb"
    return f"{'controls' if paper in controls else 'papers'}/{notebooks[paper].name}"


def page_link(paper: str, notebooks: dict[str, Path], controls: frozenset = frozenset()) -> str:
    """The Markdown link from the home page to a paper's (or the arena's, or a control's) page."""
    return f"[{paper}]({page_path(paper, notebooks, controls)})"


def chip(qualifier: str) -> str:
    """A qualifier of a paper's verdicts as a chip on the site (styled by docs/_static/site.css)."""
    return f'<span class="verdict-chip chip-{qualifier}">{qualifier}</span>'


def controls_of(docs: list[dict]) -> frozenset:
    """The names of the controls of the pipeline among the results documents."""
    import make_report
    return frozenset(d["paper"] for d in docs if d.get("kind") != "arena" and make_report.is_control(d))


def split_title(nb: dict) -> int:
    """Split a notebook's first Markdown cell after its title line (``# ...``), so that what the page opens with can
    be inserted between the title and the rest of that cell; returns the index where to insert (after the title's
    cell; 0 without a Markdown cell)."""
    i = next((i for i, c in enumerate(nb["cells"]) if c["cell_type"] == "markdown"), None)
    if i is None:
        return 0
    text = "".join(nb["cells"][i]["source"]) if isinstance(nb["cells"][i]["source"], list) else nb["cells"][i]["source"]
    title, sep, rest = text.partition("\n")
    if title.startswith("# ") and rest.strip():
        nb["cells"][i]["source"] = title
        nb["cells"].insert(i + 1, _markdown_cell(rest.lstrip("\n")))
    return i + 1


#: the detail tables of a paper page folded under a summary line: (the start of the table's header, the summary)
DETAIL_TABLES = (("| item | algorithm | quantity | paper | replicated", "Comparison rows: every published number"),
                 ("| claim | evidence |", "Claim evidence"),
                 ("| claim | verdict | decisive |", "Claims: verdict and decisive number"),
                 ("| claim | verdict | ", "Claim × comparison"))
#: the start of the deviations table's header (its rows are the deviations' definitions, anchored)
DEVIATIONS_HEADER = "| id | topic | paper | our choice |"


def _outputs_markdown(nb: dict):
    """Every text/markdown output of the notebook's code cells: (the output's data dict, its text)."""
    for cell in nb["cells"]:
        for out in cell.get("outputs", []) if cell["cell_type"] == "code" else []:
            data = out.get("data") or {}
            if "text/markdown" in data:
                md = data["text/markdown"]
                yield data, "".join(md) if isinstance(md, list) else md


def fold_details(nb: dict, deviation_ids: list[str]) -> None:
    """Fold a paper page's detail and link its deviation codes, in the notebook's stored Markdown outputs: the
    comparison rows and the claim detail tables (:data:`DETAIL_TABLES`) go into ``<details class="detail-fold">``
    (closed, a summary line with the rows' count), each row of the deviations table gets the anchor
    ``deviation-<code>`` and every code of ``deviation_ids`` in the folded tables links to it.  A code links only
    when the page defines it (its deviations table is among the outputs)."""
    outputs = list(_outputs_markdown(nb))
    defined = set()
    for data, md in outputs:
        if md.startswith(DEVIATIONS_HEADER):
            def anchor(m):
                defined.add(m.group(2))
                return f'{m.group(1)}<span id="deviation-{m.group(2)}"></span>{m.group(2)} |'
            data["text/markdown"] = re.sub(r"(?m)^(\| )([A-Z]{1,3}-\d+) \|", anchor, md)
    codes = sorted((c for c in deviation_ids if c in defined), key=len, reverse=True)
    pattern = re.compile(r"(?<![\w-])(" + "|".join(map(re.escape, codes)) + r")(?![\w-])") if codes else None
    for data, md in outputs:
        label = next((label for start, label in DETAIL_TABLES if md.startswith(start)), None)
        if label is None:
            continue
        if pattern is not None:
            md = pattern.sub(lambda m: f'<a href="#deviation-{m.group(1)}">{m.group(1)}</a>', md)
        n = sum(1 for line in md.splitlines() if line.startswith("|")) - 2
        data["text/markdown"] = (f'<details class="detail-fold">\n<summary>{label} ({n} rows)</summary>\n\n{md.strip()}'
                                 "\n\n</details>\n")


def verdict_section(doc: dict) -> str:
    """What a paper's page opens with, right after its title (and qualifier chip): the verdict box
    (:func:`mmlib.experiment.views.verdict_box_html`), then the paper's one-paragraph summary
    (:func:`mmlib.papers.summary`, when its package has one), both from its results ``doc``.  The box comes first so
    that it starts on the first screen of a phone too (a summary is about 900 px tall at 390 px; tests/test_site.py
    checks the box's position at both widths)."""
    from mmlib.experiment import views
    from mmlib.papers import has_text, summary
    # a paper without a summary.md (a user's own): the box alone; a summary its results cannot fill is an error
    text = summary(doc["paper"], doc) if has_text(doc["paper"]) else ""
    return "\n\n".join(x for x in (views.verdict_box_html(doc), text) if x)


def fold_notebook(src: Path, dst: Path, doc: dict | None = None) -> None:
    """Copy an executed notebook as a page: papermill's parameter cells removed, every other code cell folded
    (``hide-input``: the source behind a toggle, the outputs shown).  With the paper's results ``doc``: right after
    the title, a chip when its verdicts carry a qualifier (a reconstructed set-up), then the paper's summary and its
    verdict box (:func:`verdict_section`); at the end the forensic sections the
    results carry (controls, consistency, sensitivity curves, planted-reading recovery, run-count stability,
    degenerate universes; :func:`make_report.render_forensic_sections`)."""
    nb = json.loads(src.read_text())
    if doc is not None and doc.get("kind") != "arena":
        import make_report
        at = split_title(nb)
        q = make_report.qualifier_of(doc)
        if q:
            nb["cells"].insert(at, _markdown_cell(
                f"{chip(q)} The set-up of this paper is a {q} (the paper does not give it): every claim verdict here "
                "judges the reconstruction, not the paper, and is kept out of the pooled tallies."))
            at += 1
        nb["cells"].insert(at, _markdown_cell(verdict_section(doc)))
        extra = make_report.render_forensic_sections(doc, level=3, suffix=" (results file)")
        if extra:
            nb["cells"].append(_markdown_cell("\n".join(
                [f"## Forensic checks (from `data/results/{doc['paper']}.json`)"] + extra)))
    if doc is not None and doc.get("kind") != "arena":
        fold_details(nb, [d["id"] for d in doc.get("deviations") or []])
    for cell in nb["cells"]:
        if cell["cell_type"] != "code":
            continue
        tags = cell.setdefault("metadata", {}).setdefault("tags", [])
        if "parameters" in tags or "injected-parameters" in tags:
            tags.append("remove-cell")
        elif "hide-input" not in tags:
            tags.append("hide-input")
    dst.parent.mkdir(parents=True, exist_ok=True)
    dst.write_text(json.dumps(nb))


def _markdown_cell(text: str) -> dict:
    return {"cell_type": "markdown", "metadata": {}, "source": text}


#: the hand-written pages of docs/ on how the replication is done (moved out of the README), in the site's navigation
#: under "How it is done", in this order (tests/test_readme.py checks each is a page of docs/ and in the navigation)
HOW_IT_IS_DONE = ("verdict-rule", "reading-space-method", "arena-design", "rerun-and-scale-out", "speed", "conventions")


def index_page(docs: list[dict], notebooks: dict[str, Path]) -> str:
    """The home page: the controls first (in the text and in the navigation), then the papers, the cross-paper
    pages and the library; the summary is :func:`make_report.render_index` with the site's links and chips."""
    import make_report
    controls = controls_of(docs)
    summary = make_report.render_index(docs, link=lambda p: page_link(p, notebooks, controls), title="## What holds",
                                       chip=chip)
    papers = [d for d in docs if d.get("kind") != "arena" and d["paper"] not in controls]
    commits = sorted({d["provenance"]["git_commit"][:10] for d in docs})
    nav_controls = ["```{toctree}", ":maxdepth: 1", ":caption: Controls", "",
                    *[f"controls/{notebooks[c].stem}" for c in sorted(controls)], "```", ""] if controls else []
    return "\n".join([
        "# Tracking papers, replicated", "",
        f"{len(papers)} papers on maneuvering-target tracking with interacting multiple model (IMM) and sigma-point "
        "Kalman filters, replicated with `mmlib`, a batched filter library; every published number is set beside the "
        "replication with its Monte Carlo standard error and a verdict from one rule "
        "(`mmlib/experiment/verdicts.py`), every ambiguity of the text is run as a declared reading, and every "
        "algorithm is run on every scenario in the arena.", "",
        f"Generated from the results of commit{'s' if len(commits) > 1 else ''} {', '.join(f'`{c}`' for c in commits)} "
        f"({len(papers)} papers{f', {len(controls)} control' + ('s' if len(controls) > 1 else '') if controls else ''}"
        " and the arena).", "",
        *what_we_found(docs, notebooks, controls),
        *nav_controls,
        "```{toctree}", ":maxdepth: 1", ":caption: Papers", "",
        *[f"papers/{notebooks[d['paper']].stem}" for d in sorted(papers, key=lambda d: d["paper"])], "```", "",
        "```{toctree}", ":maxdepth: 1", ":caption: Across the papers", "", "reading-spaces", "arena", "```", "",
        "```{toctree}", ":maxdepth: 1", ":caption: The library", "", "getting-started", "compare-two-filters",
        "library", "api/index", "results-contract", "new-paper", "```", "",
        "```{toctree}", ":maxdepth: 1", ":caption: How it is done", "", *HOW_IT_IS_DONE, "```", "",
        summary])


def what_we_found(docs: list[dict], notebooks: dict[str, Path], controls: frozenset = frozenset()) -> list[str]:
    """The home page's "What we found" section (Markdown lines), above the counts: per paper (the controls first),
    its one-paragraph summary (:func:`mmlib.papers.summary`) after a link to its page, or its one-line findings
    (:func:`mmlib.experiment.views.findings_line`) when its package has no summary; the arena's line last."""
    from mmlib.experiment import views
    from mmlib.papers import has_text, summary
    lines = ["## What we found", ""]
    for d in sorted(docs, key=lambda d: (d["paper"] not in controls, d.get("kind") == "arena", d["paper"])):
        link = f"**{page_link(d['paper'], notebooks, controls)}**"
        # the arena, or a paper without a summary.md: its generated line (a summary that cannot be filled: an error)
        text = f"{link}: {summary(d['paper'], d)}" if has_text(d["paper"]) else views.findings_line(d, link)
        lines += [text, ""]
    return lines


def citation_name(paper: str) -> str:
    """A paper's name as a reader cites it, "author year" (``Hu et al. 2017``, ``Liu & Wu 2017``), from the first
    reference of its registry citation (:data:`mmlib.papers.REGISTRY`, :func:`make_report.citation_label`); the
    registry name when it has none."""
    import make_report
    from mmlib.papers import REGISTRY
    try:
        return make_report.citation_label(getattr(REGISTRY.get(paper), "citation", "") or "")
    except ValueError:
        return paper


#: the section of a paper's reading space that opens its page: the claims' shares, each verdict's robustness
CLAIMS_SECTION = "Claims across the reading space"


def reading_spaces_pages(docs: list[dict], notebooks: dict[str, Path]) -> dict[str, str]:
    """The reading-space pages, ``{page path in the site's sources: Markdown}``: ``reading-spaces.md``, an index
    linking one page per paper with a reading space, ``reading-spaces/<paper>.md``, titled with the paper's citation
    name (:func:`citation_name`) and opening with its robust-claims table (each claim's share of the reading space and
    whether it is robust), then the design, the factors and the forensic sections (:func:`make_report.render_multiverse`
    with its headings one level up).  The controls come first, as in the navigation."""
    controls = controls_of(docs)
    spaces = sorted((d for d in docs if d.get("multiverse")), key=lambda d: (d["paper"] not in controls, d["paper"]))
    pages = {f"reading-spaces/{d['paper']}.md": reading_spaces_page(d, notebooks, controls) for d in spaces}
    index = ["# Reading spaces", "",
             "Where a paper is missing, contradictory or wrong, its defensible readings are declared as factors, "
             "numbered, and all of them run (a multiverse, as in specification curves): each verdict is reported "
             "across every reading, and the readings that reproduce the published tables are named. One page per "
             "paper, rendered from its results, opens with its claims across the reading space (which verdicts are "
             "robust); the paper's own page shows the figures.", "",
             *[f"- [{citation_name(d['paper'])}](reading-spaces/{d['paper']}.md) (`{d['paper']}`"
               + (", control of the pipeline" if d["paper"] in controls else "") + ")" for d in spaces], "",
             "```{toctree}", ":hidden:", ":maxdepth: 1", "", *[f"reading-spaces/{d['paper']}" for d in spaces],
             "```", ""]
    return {"reading-spaces.md": "\n".join(index), **pages}


def reading_spaces_page(doc: dict, notebooks: dict[str, Path], controls: frozenset = frozenset()) -> str:
    """One paper's reading-space page (``reading-spaces/<paper>.md``): its citation name as the title, a link to the
    paper's page, its claims across the reading space first, then the rest of its reading-space section."""
    import make_report
    paper = doc["paper"]
    q = make_report.qualifier_of(doc)
    body = "\n".join(make_report.render_multiverse(doc["multiverse"], q)).split("\n")
    body = [re.sub(r"^#(#+) ", r"\1 ", line) for line in body if line.strip() != "## Reading space (multiverse)"]
    # sections at "## ": the lines before the first are the design paragraph
    starts = [i for i, line in enumerate(body) if line.startswith("## ")] + [len(body)]
    head = body[:starts[0]]
    sections = [body[a:b] for a, b in zip(starts, starts[1:])]
    sections.sort(key=lambda sec: sec[0] != f"## {CLAIMS_SECTION}")      # stable: the others keep their order
    link = f"../{page_path(paper, notebooks, controls)}"
    lines = [f"# {citation_name(paper)}", "",
             f"The reading space of `{paper}` ([its page]({link})"
             + (", a control of the pipeline" if paper in controls else "") + ")."
             + (f"\n\n{chip(q)} verdicts on a {q} of the set-up" if q else ""), ""]
    for i, sec in enumerate(sections):
        lines += sec
        if i == 0:
            lines += ["", "## Design", *head]
    return "\n".join(lines) + "\n"


FIGURE_LINK = ('<a class="figure-link" href="{svg}" title="the full-size figure (SVG)">'
               '<img class="figure-img" src="{png}" alt="{alt}"></a>')
#: a figure with panels side by side: on a screen up to PHONE_WIDTH CSS px wide its narrow variant (the panels
#: stacked, :func:`mmlib.experiment.writing.narrow_image`) is shown instead, in the same link to the full-size SVG
FIGURE_LINK_NARROW = ('<a class="figure-link" href="{svg}" title="the full-size figure (SVG)"><picture>'
                      '<source media="(max-width: {phone}px)" srcset="{narrow}">'
                      '<img class="figure-img" src="{png}" alt="{alt}"></picture></a>')
#: the widest screen shown a figure's narrow variant (CSS px; the site's phone layout, docs/_static/site.css)
PHONE_WIDTH = 600


def link_figures(page: Path, doc: dict | None, rel: str) -> dict[str, str]:
    """Make each figure of the staged notebook ``page`` (site path ``rel``) a link to its full-size SVG: every image
    output followed by the Markdown output "**Paper:** ... **Ours:** ..." of a figure of the results ``doc``
    (``NotebookRun.show``) gets an HTML form, preferred by MyST-NB, showing the figure's PNG in a link to its SVG
    (:data:`FIGURE_LINK`); a figure with a narrow variant (its panels stacked) shows that on a phone
    (:data:`FIGURE_LINK_NARROW`).
    Returns ``{path in the built site: path of the figure file relative to the outputs' root}`` for
    :func:`postprocess_html` to copy (the site shows and links files of figures/, offline)."""
    if not doc or not doc.get("figures"):
        return {}
    by_caption: dict[str, list] = {}          # two figures may share a caption: then their order tells them apart
    for stem, f in doc["figures"].items():
        by_caption.setdefault(f"**Paper:** {f['paper_claim']}  \n**Ours:** {f['ours']}", []).append((stem, f))
    up = "../" * rel.count("/")
    nb = json.loads(page.read_text())
    copies = {}
    for cell in nb["cells"]:
        outs = cell.get("outputs", [])
        for out, nxt in zip(outs, outs[1:]):
            text = "".join(nxt.get("data", {}).get("text/markdown", ""))
            if "image/png" not in out.get("data", {}) or not by_caption.get(text):
                continue
            stem, fig = by_caption[text].pop(0)
            files = {Path(f).suffix: f for f in fig["files"] if not f.endswith(NARROW_SUFFIX)}
            files.update({NARROW_SUFFIX: f for f in fig["files"] if f.endswith(NARROW_SUFFIX)})
            if not {".png", ".svg"} <= set(files):
                continue
            site = {k: f"_static/{v}" for k, v in files.items() if k in (".png", ".svg", NARROW_SUFFIX)}
            copies.update({site[k]: files[k] for k in site})
            alt = f"{stem}: {fig['ours']}".replace("&", "&amp;").replace('"', "&quot;").replace("<", "&lt;")
            if NARROW_SUFFIX in site:
                html = FIGURE_LINK_NARROW.format(svg=up + site[".svg"], png=up + site[".png"], alt=alt,
                                                 narrow=up + site[NARROW_SUFFIX], phone=PHONE_WIDTH)
            else:
                html = FIGURE_LINK.format(svg=up + site[".svg"], png=up + site[".png"], alt=alt)
            out["data"]["text/html"] = html
    page.write_text(json.dumps(nb))
    return copies


#: a verdict column's cells (its header ends in "verdict"; the first such column of a table) get this class, made
#: sticky by docs/_static/site.css so that the verdict stays on screen when a wide table scrolls sideways
VERDICT_COLUMN = "verdict-col"


def postprocess_html(html_dir: Path, copies: dict[str, Path] | None = None) -> None:
    """The built site's finishing pass: copy the figure files (``{site path: source file}``, :func:`link_figures`)
    and mark every table's verdict column (:data:`VERDICT_COLUMN`) in every page."""
    for site, src in (copies or {}).items():
        (html_dir / site).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, html_dir / site)
    for page in html_dir.rglob("*.html"):
        text = page.read_text()
        if "<table" not in text or "erdict" not in text:
            continue
        new = re.sub(r"<table\b.*?</table>", _mark_verdict_column, text, flags=re.S)
        if new != text:
            page.write_text(new)


def _mark_verdict_column(match: re.Match) -> str:
    """A table (docutils HTML: no colspan or rowspan in these tables) with its first verdict column's cells marked."""
    table = match.group(0)
    if "colspan" in table or "rowspan" in table:
        return table
    rows = re.findall(r"<tr\b.*?</tr>", table, flags=re.S)
    if not rows:
        return table
    heads = [re.sub(r"<[^>]+>", "", h) for h in re.findall(r"<th\b.*?</th>", rows[0], flags=re.S)]
    col = next((i for i, h in enumerate(heads) if re.search(r"\bverdict$", h.strip(), re.I)), None)
    if col is None:
        return table

    def mark(row: re.Match) -> str:
        cells = list(re.finditer(r"<(t[hd])\b([^>]*)>", row.group(0)))
        if len(cells) <= col:
            return row.group(0)
        c = cells[col]
        attrs = c.group(2)
        if 'class="' in attrs:
            attrs = attrs.replace('class="', f'class="{VERDICT_COLUMN} ', 1)
        else:
            attrs += f' class="{VERDICT_COLUMN}"'
        return row.group(0)[:c.start()] + f"<{c.group(1)}{attrs}>" + row.group(0)[c.end():]

    return re.sub(r"<tr\b.*?</tr>", mark, table, flags=re.S)


def public_modules() -> list[str]:
    import mmlib
    names = []
    for info in pkgutil.walk_packages(mmlib.__path__, "mmlib."):
        if not any(part.startswith("_") for part in info.name.split(".")[1:]):
            names.append(info.name)
    return sorted(names)


def api_pages(stage: Path) -> None:
    layers = {"mmlib.core": "1. Estimation core", "mmlib.experiment": "2. Experiment layer",
              "mmlib.papers": "3. Paper set-ups", "mmlib.arena": "4. The arena"}
    modules = public_modules()
    lines = ["# API reference", "", "Generated from the docstrings. The folders are the layers; each depends only on "
             "those above it in this list. Units are SI inside the library (m, m/s, s, rad, rad/s) unless a "
             "docstring says otherwise; arrays are batched over Monte Carlo runs (leading axis N).", "",
             "```{eval-rst}", ".. automodule:: mmlib", "   :no-members:", "```", ""]
    for package, title in layers.items():
        members = [m for m in modules if m == package or m.startswith(package + ".")]
        lines += [f"## {title}: `{package}`", "", "```{toctree}", ":maxdepth: 1", "",
                  *[m for m in members], "```", ""]
    (stage / "api").mkdir(parents=True, exist_ok=True)
    (stage / "api" / "index.md").write_text("\n".join(lines))
    for m in modules:
        # a package's own page is its docstring: the names it re-exports are documented once, in their modules
        # (documented twice, every cross-reference to them would be ambiguous)
        package = hasattr(importlib.import_module(m), "__path__")
        (stage / "api" / f"{m}.md").write_text(
            f"# `{m}`\n\n```{{eval-rst}}\n.. automodule:: {m}\n{'   :no-members:' + chr(10) if package else ''}```\n")


def assemble(stage: Path, docs: list[dict], notebooks: dict[str, Path], root: Path = REPO) -> dict[str, Path]:
    """Stage the site's sources in ``stage``; returns the files :func:`postprocess_html` copies into the built site
    (``{site path: file}``: the figures, from the outputs under ``root``)."""
    if stage.exists():
        shutil.rmtree(stage)
    stage.mkdir(parents=True)
    for page in sorted((REPO / "docs").glob("*.md")):
        shutil.copy2(page, stage / page.name)
    (stage / "_includes").mkdir()
    shutil.copy2(REPO / "README.md", stage / "_includes" / "README.md")     # the getting-started example
    # the results contract's JSON Schema, shown by results-contract.md
    shutil.copy2(REPO / "mmlib" / "experiment" / "results.schema.json", stage / "_includes" / "results.schema.json")
    (stage / "index.md").write_text(index_page(docs, notebooks))
    for rel, text in reading_spaces_pages(docs, notebooks).items():
        (stage / rel).parent.mkdir(parents=True, exist_ok=True)
        (stage / rel).write_text(text)
    controls = controls_of(docs)
    by_name = {d["paper"]: d for d in docs}
    copies: dict[str, Path] = {}
    for paper, nb in notebooks.items():
        fold_notebook(nb, stage / page_path(paper, notebooks, controls), by_name.get(paper))
        rel = page_path(paper, notebooks, controls)
        copies.update({k: root / v for k, v in link_figures(stage / rel, by_name.get(paper), rel).items()})
    api_pages(stage)
    # the bundled MathJax (jupyter-server-mathjax's copy of MathJax 2.7), served from _static/mathjax/
    shutil.copytree(_package_data("jupyter_server_mathjax", "static"), stage / "_mathjax" / "mathjax")
    return copies


def explain(line: str, stage: Path) -> str:
    """A Sphinx warning with its page relative to the staging folder and, for a notebook, its cell."""
    line = line.replace(str(stage) + os.sep, "")
    m = re.match(r"(?P<page>[\w./-]+\.ipynb):(?P<line>\d+)", line)
    if m:
        cell = int(m.group("line")) // CELL_LINE - 1
        line = f"notebook {m.group('page')}, cell {cell} (index in the .ipynb, from 0): " + line[m.end():].lstrip(": ")
    return line


#: a line of Sphinx's per-page progress: "reading sources... [ 12%] papers/hu2017" (also "writing output...")
SPHINX_PAGE = re.compile(r"^(?P<phase>reading sources|writing output)\.\.\. \[\s*(?P<pct>\d+)%\] (?P<page>\S+)")


def page_progress(line: str) -> str | None:
    """Sphinx's progress line of one page as a short one, ``"site: reading  12 % papers/hu2017"``; None for any
    other line (Sphinx's banner, its phase summaries, a warning: the warnings are reported from their file)."""
    m = SPHINX_PAGE.match(line.strip())
    if m is None:
        return None
    return f"site: {m['phase'].split()[0]:<7} {int(m['pct']):3d} % {m['page']}"


def _package_data(name: str, folder: str) -> Path:
    """The data ``folder`` of the installed package ``name``, found without importing the package
    (jupyter_server_mathjax, whose import loads jupyter_server and jsonschema, 2.2 s, for a folder of static files):
    the first of its locations that holds it (a namespace package has several); SiteError naming the package or the
    folder when there is none."""
    import importlib.util
    spec = importlib.util.find_spec(name)
    if spec is None or not spec.submodule_search_locations:
        raise SiteError(f"{name} is not installed (make venv installs it)")
    for location in spec.submodule_search_locations:
        if (Path(location) / folder).is_dir():
            return Path(location) / folder
    raise SiteError(f"{name} has no {folder}/ folder in {list(spec.submodule_search_locations)}: reinstall it "
                    f"(rm -r .venv && make venv)")


def sphinx(stage: Path, html: Path, quiet: bool = True) -> None:
    """Run Sphinx on the staged sources into ``html`` (warnings are errors); a SiteError lists the failures, each
    naming its page (and, in a notebook, its cell), and leaves no ``html`` folder.  ``quiet=False`` prints one line
    per page as Sphinx reads it and as it writes it (:func:`page_progress`; ``make site`` takes minutes)."""
    shutil.rmtree(html, ignore_errors=True)
    warnings = stage.parent / f"{stage.name}-warnings.txt"
    # doctrees (Sphinx's cache) beside the HTML, never inside it; MyST-NB puts its jupyter_execute/ there too
    cmd = [sys.executable, "-m", "sphinx", "-b", "html", "-c", str(REPO / "docs"), "-W", "--keep-going",
           "-w", str(warnings), "-d", str(html.parent / "doctrees"), *(["-q"] if quiet else ["-N"]), str(stage),
           str(html)]
    env = {**os.environ, "MMLIB_SITE_REPO": str(REPO), "MMLIB_SITE_MATHJAX": str(stage / "_mathjax"),
           "PYTHONHASHSEED": "0"}
    with tempfile.TemporaryFile("w+") as err:
        proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=err, text=True)
        for line in proc.stdout:
            shown = None if quiet else page_progress(line)
            if shown:
                print(shown, flush=True)
        proc.stdout.close()
        returncode = proc.wait()
        err.seek(0)
        stderr = err.read()
    if returncode != 0:
        lines = [explain(x, stage) for x in (warnings.read_text() if warnings.exists() else "").splitlines() if x]
        detail = "\n  ".join(dict.fromkeys(lines[:40]) or stderr.strip().splitlines()[-20:])
        shutil.rmtree(html, ignore_errors=True)
        raise SiteError(f"the site did not build (Sphinx exit status {returncode}):\n  {detail}")


def build(profile: str = "full", out: Path | None = None, quiet: bool = True) -> Path:
    """Build the site; returns its folder.  Raises SiteError naming what is missing or which page failed.

    Everything but the finished site stays in a work folder beside it, ``.<site>-work/`` (the staged sources
    ``src/``, Sphinx's ``doctrees/`` and MyST-NB's ``jupyter_execute/``, the HTML being built), held under a lock
    (``.<site>.lock``) so that two builds never mix; the new site replaces the old one only once it is complete."""
    import fcntl
    out = Path(out or REPO / "build" / ("site" if profile == "full" else f"site-{profile}"))
    docs, notebooks = load_inputs(profile)
    out.parent.mkdir(parents=True, exist_ok=True)
    work = out.parent / f".{out.name}-work"
    with open(out.parent / f".{out.name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        shutil.rmtree(work, ignore_errors=True)
        copies = assemble(work / "src", docs, notebooks, sources(profile)[0])
        sphinx(work / "src", work / "html", quiet)
        postprocess_html(work / "html", copies)
        if out.exists():
            os.replace(out, work / "old")
        os.replace(work / "html", out)
        shutil.rmtree(work / "old", ignore_errors=True)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--profile", default="full", help="whose outputs: full (the committed ones) or smoke")
    ap.add_argument("--out", default=None, help="site folder (default build/site, build/site-smoke for smoke)")
    ap.add_argument("--if-complete", action="store_true",
                    help="when some paper's outputs are missing, say so and build nothing (exit status 0): what "
                         "`make figures` does after running only some papers")
    args = ap.parse_args(argv)
    if args.if_complete:
        try:
            load_inputs(args.profile)
        except MissingOutputs as exc:            # only missing outputs; any other problem is an error below
            print(f"site: not built, the outputs are incomplete: {exc}")
            return 0
        except SiteError:
            pass
    try:
        print(f"site: building the {args.profile} profile's site (a few minutes: a line per page)", flush=True)
        # absolute: Sphinx reads the staged MathJax folder relative to docs/, where a relative --out would miss it
        out = build(args.profile, Path(args.out).resolve() if args.out else None, quiet=False)
    except SiteError as exc:
        print(f"build_site.py: error: {exc}", file=sys.stderr)
        return 2
    shown = out.relative_to(REPO) if out.is_relative_to(REPO) else out
    print(f"site: {shown}/index.html (open it in a browser; it needs no network)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
