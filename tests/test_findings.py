"""Findings first (issue 26): the papers' one-paragraph summaries, the verdict box of the paper pages, the ± format
and the README's generated "What we found" block, all from the committed results (data/results/*.json)."""
from __future__ import annotations

import copy
import functools
import json
import re
import sys
from pathlib import Path

import pytest

from mmlib.experiment import verdicts, views
from mmlib.experiment.results import read_results
from mmlib.experiment.verdicts import CLAIM_VERDICTS, claim_category
from mmlib.papers import REGISTRY, finding, summary, summary_template, summary_values

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tools"))
RESULTS = REPO / "data" / "results"


@functools.lru_cache(maxsize=None)
def _read(path: Path) -> dict:
    """A committed results file read and validated once per process (read_results' validation of the larger files
    takes most of a second; the committed files do not change while the tests run)."""
    return read_results(path)


def committed(name: str) -> dict:
    """The committed results of paper ``name``, a copy of its own (a test may change it)."""
    return copy.deepcopy(_read(RESULTS / f"{name}.json"))


def all_docs() -> list[dict]:
    return [copy.deepcopy(_read(p)) for p in sorted(RESULTS.glob("*.json"))]


# -- summaries ---------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", list(REGISTRY))
def test_summary_exists_and_is_one_filled_paragraph(name):
    text = summary(name)
    assert text == summary(name, committed(name))          # the default is the committed results
    assert len(text.split()) >= 40, "a summary says what was found, in a paragraph"
    assert "\n\n" not in text and "{" not in text and "}" not in text, "one paragraph, every placeholder filled"


def _literal_numbers(template: str) -> list[str]:
    """The numbers written in a summary's text itself, outside its placeholders."""
    return re.findall(r"\d+(?:\.\d+)?", re.sub(r"\{[^{}]*\}", " ", template))


@pytest.mark.parametrize("kind", ["summary", "finding"])
@pytest.mark.parametrize("name", list(REGISTRY))
def test_summary_has_no_stale_number(name, kind):
    """Every number a summary or one-line finding writes itself (not filled from the results) appears in the paper's
    results document, so neither can carry a count or value of an older run; the rest are placeholders (checked live
    below)."""
    tokens = set(re.findall(r"\d+(?:\.\d+)?", json.dumps(committed(name), ensure_ascii=False)))
    missing = [n for n in _literal_numbers(summary_template(name, kind)) if n not in tokens]
    assert not missing, f"{name}: numbers in {kind}.md that the results do not contain: {missing}"


@pytest.mark.parametrize("name", list(REGISTRY))
def test_finding_is_one_filled_line(name):
    """The README's line of a paper: one line, every placeholder filled, each with the value the results give."""
    doc = committed(name)
    text = finding(name)
    assert text == finding(name, doc) and "\n" not in text and "{" not in text and "}" not in text
    used = set(re.findall(r"\{(\w+)\}", summary_template(name, "finding")))
    assert used, "a finding's numbers come from the results"
    values = summary_values(doc)
    for key in used:
        assert str(values[key]) in text, key
    with pytest.raises(ValueError, match="kind"):
        summary_template(name, "abstract")


def test_citation_labels_name_the_first_author_and_the_year():
    import make_report
    for name in REGISTRY:
        label = make_report.citation_label(REGISTRY[name].citation)
        assert re.fullmatch(r"[A-Z][\w'-]+( et al\.| & [A-Z][\w'-]+)? (19|20)\d\d", label), label
        if name[-4:].isdigit():
            assert label.endswith(name[-4:]) and label.split()[0].lower() == re.sub(r"\d", "", name), (name, label)
    assert make_report.citation_label("A. One, B. Two, Title, J. 12(3), 100-120, 2001, doi:x") == "One & Two 2001"
    assert make_report.citation_label("A. One, B. Two, C. Three, T, 1999") == "One et al. 1999"
    # a surname with lower-case particles stays whole; a title word after the authors is no author
    assert make_report.citation_label("H. L. van Trees, Detection, Estimation, and Modulation Theory, 1968") == \
        "van Trees 1968"
    assert make_report.citation_label("J. de la Cruz, K. Lee, T, 2010") == "de la Cruz & Lee 2010"
    with pytest.raises(ValueError, match="citation"):
        make_report.citation_label("Anonymous report, no year")


@pytest.mark.parametrize("name", list(REGISTRY))
def test_summary_placeholders_follow_the_results(name):
    """Change the results the placeholders read (the headline runs and the first claim's verdict): the summary
    changes with them; a summary without any placeholder would not."""
    doc = committed(name)
    template = summary_template(name)
    assert re.search(r"\{\w+\}", template), "a summary's numbers come from the results"
    mutated = copy.deepcopy(doc)
    mutated["provenance"]["n_runs"] = 987654321
    if doc.get("multiverse"):
        mutated["multiverse"]["n_universes"] = 987654322
        mutated["multiverse"]["n_runs"] = 987654323
    mutated["claims"][0]["verdict"] = "not assessable" if claim_category(doc["claims"][0]["verdict"]) != \
        "not assessable" else "holds"
    assert summary(name, mutated) != summary(name, doc)
    values = summary_values(mutated)
    used = set(re.findall(r"\{(\w+)", template))
    assert {"n_runs", "n_universes", "multiverse_runs"} & used, "a summary states how much was run"
    for key in used & {"n_runs", "n_universes", "multiverse_runs"}:
        assert str(values[key]) in summary(name, mutated)


def test_summary_bad_input():
    with pytest.raises(ValueError, match="name"):
        summary("nosuchpaper2099")
    with pytest.raises(ValueError, match="name"):
        summary_template(None)
    with pytest.raises(ValueError, match="doc"):
        summary("zhu2016", committed("hu2017"))      # another paper's results


# -- the verdict box ---------------------------------------------------------------------------------------------

def _chips(html: str) -> list[str]:
    return re.findall(r'<span class="claim-chip (claim-[a-z-]+)">', html)


@pytest.mark.parametrize("name", list(REGISTRY))
def test_verdict_box_from_results(name):
    doc = committed(name)
    box = views.verdict_box_html(doc)
    assert box.startswith('<div class="verdict-box">') and box.endswith("</div>")
    # one chip per claim, coloured by its verdict's category (the claim vocabulary)
    assert _chips(box) == ["claim-" + str(claim_category(c["verdict"])).replace(" ", "-") for c in doc["claims"]]
    assert {c.removeprefix("claim-").replace("-", " ") for c in _chips(box)} <= {str(v) for v in CLAIM_VERDICTS}
    v = views.paper_verdicts(doc)
    assert v["tables"], "every paper and control has at least one table with a joint test"
    for t in v["tables"]:
        assert 0 <= t["n_reproduced"] <= t["n_cells"]
        assert f"{t['table']}: {t['n_reproduced']}/{t['n_cells']} cells reproduced" in box
    # the robustness share of the first claim is the reading space's share of its headline verdict
    first, across = v["claims"][0], doc["multiverse"]["claims_summary"]
    entry = next(c for c in across if c["claim"] == first["claim"])
    assert first["share"] == pytest.approx(entry["share"][first["verdict"]])
    assert f"{views.percent(first['share'])} %" in box


def test_verdict_box_follows_a_changed_verdict():
    doc = committed("hu2017")
    before = _chips(views.verdict_box_html(doc))
    mutated = copy.deepcopy(doc)
    old = claim_category(mutated["claims"][0]["verdict"])
    new = "holds" if old != "holds" else "contradicted"
    mutated["claims"][0]["verdict"] = new
    after = _chips(views.verdict_box_html(mutated))
    assert after[0] == "claim-" + new and after[1:] == before[1:] and before[0] != after[0]
    # a table's count follows the table match
    t = mutated["multiverse"]["table_match"][0]
    t["headline_n_reproduced"] = t["n_cells"] - 1
    assert f"{t['table']}: {t['n_cells'] - 1}/{t['n_cells']} cells reproduced" in views.verdict_box_html(mutated)


def test_verdict_box_bad_input():
    with pytest.raises(ValueError, match="doc"):
        views.paper_verdicts({"rows": []})
    with pytest.raises(ValueError, match="docs"):
        views.findings_lines(committed("zhu2016"))         # one document, not a sequence of them


# -- the ± format --------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("value, se, expected", [
    (0.0263, 0.00041, "0.02630 ± 0.00041"),    # s.e. to 2 significant figures, the value to the same decimal
    (0.026, 0.0001, "0.02600 ± 0.00010"),      # never "0.026 ± 0.000"
    (-3.14159, 0.0995, "-3.14 ± 0.10"),        # 0.0995 rounds up to 0.10: two decimals, not three
    (-0.5, 0.12, "-0.50 ± 0.12"),
    (4.02, 0.05, "4.020 ± 0.050"),
    (1234.4, 56.0, "1234 ± 56"),
    (12344.0, 678.0, "12340 ± 680"),           # s.e. >= 100: rounded to tens
    (159375.6, 64401.4, "159000 ± 64000"),
    (2.5, 0.0, "2.5"),                         # zero s.e. (an exact value): the value alone
    (2.5, None, "2.5"),
    (None, 0.1, "--"),
])
def test_format_pm(value, se, expected):
    assert verdicts.format_pm(value, se) == expected


@pytest.mark.parametrize("value, se, expected", [
    (1.0, 0.0, "+1"),                          # every run diverged in A, none in B: an exact difference, no "± 0"
    (0.0, 0.0, "+0"),
    (0.52, 0.031, "+0.520 ± 0.031"),
    (-0.52, 0.031, "-0.520 ± 0.031"),
    (-12344.0, 678.0, "-12340 ± 680"),
    (3.2e7, 4.1e5, "+3.200e+07 ± 0.041e+07"),
])
def test_format_pm_signed_shows_the_sign_of_a_difference(value, se, expected):
    assert verdicts.format_pm(value, se, signed=True) == expected
    assert verdicts.format_pm(value, se) == expected.removeprefix("+")
    with pytest.raises(ValueError, match="signed"):
        verdicts.format_pm(value, se, signed="yes")


def test_format_pm_round_off_sized_se_keeps_the_value_readable():
    """An s.e. of round-off size (below a millionth of the value) does not drag the value to 13 decimals."""
    assert verdicts.format_pm(15.537, 1e-12) == "15.537 ± 1.0e-12"
    assert verdicts.format_pm(15.537, 2e-5) == "15.537000 ± 0.000020"
    assert verdicts.format_pm(-2.5e-6, 1e-21, signed=True) == "-2.5e-06 ± 1.0e-21"


def test_part_number_never_prints_a_zero_stderr():
    """A paired difference with a zero standard error (e.g. a divergence rate 1 against 0) reads "+1", not "+1 ± 0"."""
    p = verdicts.Part("A − B", "divergence rate", verdicts.PartVerdict.CONTRADICTED, 1.0, 0.0, None, "of the runs")
    assert p.number() == "A − B: divergence rate +1 of the runs"
    q = verdicts.Part("A − B", "MSE", verdicts.PartVerdict.HOLDS, -0.52, 0.031, None, "m²")
    assert q.number() == "A − B: MSE -0.520 ± 0.031 m²"


def test_format_pm_large_and_tiny_keep_two_significant_figures_of_the_se():
    big = verdicts.format_pm(3.2e7, 4.1e5)
    mantissa, se = re.match(r"([\d.]+)e\+07 ± ([\d.]+)e\+07", big).groups()
    assert float(mantissa) * 1e7 == pytest.approx(3.2e7) and float(se) * 1e7 == pytest.approx(4.1e5)
    assert len(se.replace("0.", "", 1).lstrip("0")) == 2
    # value_pm goes through format_pm: its s.e. is never shown as zero
    assert not re.search(r"± 0\.0*$", views.value_pm(0.026, 0.0001, 3))
    with pytest.raises(ValueError, match="stderr"):
        verdicts.format_pm(1.0, "x")
    with pytest.raises(ValueError, match="stderr"):
        verdicts.format_pm(1.0, -0.1)


# -- the README's findings block ----------------------------------------------------------------------------------

def test_readme_findings_block_is_current():
    """The committed README's "What we found" block is what make_report renders from the committed results: a
    stale README (results rerun, block not rewritten) fails here."""
    import make_report
    text = (REPO / "README.md").read_text()
    assert make_report.readme_with_findings(text, all_docs()) == text
    block = text.split(make_report.FINDINGS_START)[1].split(make_report.FINDINGS_END)[0]
    for doc in all_docs():
        assert f"](reports/{doc['paper']}.md)" in block


def test_readme_findings_rewrites_only_the_block_and_checks_markers():
    import make_report
    docs = all_docs()
    text = f"# title\n\n{make_report.FINDINGS_START}\nstale block text\n{make_report.FINDINGS_END}\n\nrest\n"
    new = make_report.readme_with_findings(text, docs)
    assert new.startswith(f"# title\n\n{make_report.FINDINGS_START}\n") and new.endswith(
        f"{make_report.FINDINGS_END}\n\nrest\n")
    assert "stale block text" not in new and "(reports/zhu2016.md)" in new
    assert make_report.readme_with_findings(new, docs) == new          # idempotent
    for bad in (text.replace(make_report.FINDINGS_START, ""), text + make_report.FINDINGS_END,
                f"{make_report.FINDINGS_END}\n{make_report.FINDINGS_START}\n"):
        with pytest.raises(ValueError, match="readme_text"):
            make_report.readme_with_findings(bad, docs)


# -- the site: the box opens every paper page, the home page opens with the findings --------------------------------

def test_site_pages_open_with_the_verdict(tmp_path):
    import build_site
    docs, notebooks = build_site.load_inputs("full")
    by_name = {d["paper"]: d for d in docs}
    for paper, nb in notebooks.items():
        if paper == "arena":
            continue
        out = tmp_path / f"{paper}.ipynb"
        build_site.fold_notebook(nb, out, by_name[paper])
        cells = json.loads(out.read_text())["cells"]
        assert cells[0]["source"].startswith("# ") and "\n" not in cells[0]["source"].strip()
        k = 2 if "verdict-chip" in cells[1]["source"] else 1
        # the box first (it must start on a phone's first screen: tests/test_site.py), then the summary
        assert cells[k]["source"].startswith('<div class="verdict-box">'), paper
        assert cells[k]["source"].endswith(summary(paper, by_name[paper])), paper
    index = build_site.index_page(docs, notebooks)
    assert "## What we found" in index and index.index("## What we found") < index.index("## What holds")
    for paper in REGISTRY:
        assert summary(paper, by_name[paper]) in index


def test_detail_folds_and_deviation_links(tmp_path):
    """The comparison rows and claim detail of every paper page fold into <details class="detail-fold">, every
    deviation code in them links to an anchor the page defines, and every deviation of the results is anchored."""
    import build_site
    docs, notebooks = build_site.load_inputs("full")
    by_name = {d["paper"]: d for d in docs}
    for paper in REGISTRY:
        out = tmp_path / f"{paper}.ipynb"
        build_site.fold_notebook(notebooks[paper], out, by_name[paper])
        texts = [md for _, md in build_site._outputs_markdown(json.loads(out.read_text()))]
        folded = [t for t in texts if t.startswith('<details class="detail-fold">')]
        assert any("| item | algorithm | quantity | paper |" in t for t in folded), paper
        assert not [t for t in texts if t.startswith("| item | algorithm | quantity | paper | replicated")], paper
        for t in folded:      # the table inside stays Markdown: blank lines around it, closed after it
            assert "\n\n| " in t and t.rstrip().endswith("\n\n</details>")
        anchors = set(re.findall(r'id="deviation-([^"]+)"', "".join(texts)))
        assert anchors == {d["id"] for d in by_name[paper]["deviations"]}, paper
        links = set(re.findall(r'href="#deviation-([^"]+)"', "".join(texts)))
        assert links and links <= anchors, paper


@pytest.mark.parametrize("kind", ["summary", "finding"])
@pytest.mark.parametrize("name", list(REGISTRY))
def test_verdict_words_follow_the_results(name, kind):
    """Every verdict a summary or finding states comes from the results: flip every claim's verdict and empty every
    table, and each claim verdict and table status the text uses reads the new value (no verdict is written into the
    prose around the placeholders)."""
    doc = committed(name)
    template = summary_template(name, kind)
    mutated = copy.deepcopy(doc)
    for claim in mutated["claims"]:
        claim["verdict"] = "not assessable" if claim_category(claim["verdict"]) != "not assessable" else "holds"
        claim.pop("stated", None)           # a qualified verdict's words (tseng2011): stated from the new verdict
    from mmlib.experiment.verdicts import is_reproduced
    failed = next(r["verdict"] for d in all_docs() for r in d["rows"] if not is_reproduced(r["verdict"]))
    for row in mutated["rows"]:
        row["verdict"] = failed
    for table in (mutated.get("multiverse") or {}).get("table_match") or []:
        table["headline_n_reproduced"] = 0
    before, after = summary_values(doc), summary_values(mutated)
    text = (summary if kind == "summary" else finding)(name, mutated)
    used = set(re.findall(r"\{(\w+)\}", template))
    claim_keys = {c["key"] for c in doc["claims"]}
    for key in sorted(k for k in used if re.fullmatch(r"t\d+_status", k) or k.removesuffix("_verdict") in claim_keys):
        assert str(after[key]) in text, (key, after[key])
        if key.endswith("_verdict"):
            assert after[key] != before[key], key
    for key in (k for k in used if k.startswith("t") and k.endswith("_status")):
        assert after[key] == "not reproduced", (key, after[key])


@pytest.mark.parametrize("kind", ["summary", "finding"])
@pytest.mark.parametrize("name", list(REGISTRY))
def test_texts_address_claims_by_key_not_position(name, kind):
    """A summary or finding names each claim by its stable key (``{<key>_verdict}``), never by its position: the
    claims judged in another order give the same text, and every claim placeholder names a claim of the results."""
    doc = committed(name)
    template = summary_template(name, kind)
    keys = {c["key"] for c in doc["claims"]}
    fields = ("verdict", "decisive", "short", "share", "robust")
    named = {m.group(1) for m in re.finditer(r"\{(\w+?)_(?:%s)\}" % "|".join(fields), template)}
    assert named - {n for n in named if re.fullmatch(r"t\d+|tm\d+", n)} <= keys
    assert not re.search(r"\{c\d+_", template), "a claim addressed by its position"
    reordered = copy.deepcopy(doc)
    reordered["claims"].reverse()
    text = summary if kind == "summary" else finding
    assert text(name, reordered) == text(name, doc)


def test_claim_keys_fill_their_own_placeholders():
    """summary_values keys each claim's words by the claim's key; a key that would shadow another value fails."""
    doc = copy.deepcopy(committed("zhu2016"))
    first = doc["claims"][0]
    values = summary_values(doc)
    assert values[first["key"] + "_decisive"] == first["decisive"]
    doc["claims"][0]["key"] = "n"             # n_robust would be both a count and this claim's robustness
    with pytest.raises(ValueError, match="^doc: claim key 'n'"):
        summary_values(doc)


@pytest.mark.parametrize("n, cells, joint, words", [(0, 6, False, "not reproduced"), (6, 6, True, "reproduced"),
                                                    (6, 6, None, "reproduced"), (6, 6, False, "partly reproduced"),
                                                    (3, 6, False, "partly reproduced")])
def test_table_status_words(n, cells, joint, words):
    from mmlib.papers import _table_status
    assert _table_status(n, cells, joint) == words


def test_a_summary_the_results_cannot_fill_is_an_error_not_a_fallback(monkeypatch):
    """A paper with a summary.md whose placeholders its results lack: the site and the README fail loudly instead of
    falling back to the generic line (a template broken by a rerun would otherwise vanish unnoticed)."""
    import build_site
    import make_report

    import mmlib.papers as papers
    doc = committed("zhu2016")
    monkeypatch.setattr(papers, "summary_template", lambda name, kind="summary": "{no_such_claim_verdict}")
    with pytest.raises(ValueError, match="no_such_claim_verdict"):
        build_site.verdict_section(doc)
    with pytest.raises(ValueError, match="no_such_claim_verdict"):
        make_report.findings_block([doc])
    assert papers.has_text("zhu2016") and papers.has_text("zhu2016", "finding") and not papers.has_text("nosuch")
