"""The README is a front page, and keeps its promises; the pages it sends the reader to exist and run.

What is checked (issue 26, "findings first"):

* the README is at most :data:`MAX_LINES` lines, and ``## What we found`` is among its first :data:`FINDINGS_BY_LINE`
  lines, followed by exactly one ``<!-- findings:start -->`` and one ``<!-- findings:end -->`` marker; between them
  one line per registered paper (``mmlib.papers.REGISTRY``, the controls of the pipeline excepted), each naming its
  paper by its registry name (e.g. a link to ``reports/<name>.md``), and one line for the controls and the arena
  (tools/make_report.py may regenerate those lines: the same rules apply to what it writes);
* the two commands, ``make figures`` and ``make test``, are in a shell block and are targets of the Makefile;
* the table of papers has a row per registered paper with its DOI and a link to its notebook source;
* every relative link of the README and of the pages moved out of it (:data:`MOVED_PAGES`) resolves: a README link to
  a file or folder of the repository, a page's link to a page of docs/ or one the site builder generates
  (:data:`GENERATED_PAGES`);
* every page of docs/ is in the site's navigation (the toctrees of the home page, built from the committed results
  by ``tools/build_site.py``), the moved pages among them;
* every ```python block of the README and of docs/library.md runs in a fresh interpreter (``sys.executable``, the
  repository root as working directory), and the numbers the prose after an example quotes are the ones it prints.

A block that is not meant to run can be marked by an HTML comment ``<!-- not-executed -->`` on the line before its
opening fence (blank lines in between are allowed); it is then skipped.  No block is marked today: prefer making a
block runnable to marking it.
"""
from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"
LIBRARY_PAGE = DOCS / "library.md"
NOT_EXECUTED = "<!-- not-executed -->"
TIMEOUT_S = 300
#: the README's promise: a front page, read in a minute (issue 26: "about 150 lines")
MAX_LINES = 160
#: "What we found" comes right under the title and its short introduction
FINDINGS_BY_LINE = 15
FINDINGS_START, FINDINGS_END = "<!-- findings:start -->", "<!-- findings:end -->"
#: the pages the README's material moved to (docs/), besides those of tools/build_site.HOW_IT_IS_DONE
MOVED_PAGES = ("library", "getting-started")
#: pages of the site that tools/build_site.py generates (not in docs/): a docs page may link to them
GENERATED_PAGES = ("index.md", "api/index.md")


def _build_site():
    spec = importlib.util.spec_from_file_location("build_site_for_readme_test", ROOT / "tools" / "build_site.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


BUILD_SITE = _build_site()


def moved_pages() -> list[Path]:
    """The docs pages that hold what the README no longer does."""
    return [DOCS / f"{name}.md" for name in (*BUILD_SITE.HOW_IT_IS_DONE, *MOVED_PAGES)]


def python_blocks(text: str) -> list[tuple[int, str, bool]]:
    """``(line of the opening fence (1-based), code, marked not-executed)`` of every ```python fenced block of
    ``text``.  Fences are the CommonMark ones: three or more backticks at the start of a line (up to three spaces of
    indentation), the block closed by a fence of at least as many backticks."""
    lines = text.splitlines()
    blocks = []
    i = 0
    while i < len(lines):
        opening = re.match(r"^ {0,3}(`{3,})\s*([^\s`]*)", lines[i])
        if not opening:
            i += 1
            continue
        fence, lang = opening.group(1), opening.group(2).lower()
        start = i
        j = i + 1
        while j < len(lines) and not re.match(rf"^ {{0,3}}{fence}`*\s*$", lines[j]):
            j += 1
        if lang in ("python", "py", "python3"):
            before = next((lines[k].strip() for k in range(start - 1, -1, -1) if lines[k].strip()), "")
            blocks.append((start + 1, "\n".join(lines[start + 1:j]) + "\n", before == NOT_EXECUTED))
        i = j + 1
    return blocks


def fenced_blocks(text: str, lang: str) -> list[str]:
    """The code of every fenced block of ``text`` in language ``lang`` (e.g. ``sh``)."""
    return re.findall(rf"^```{lang}\n(.*?)^```", text, flags=re.S | re.M)


README_TEXT = README.read_text(encoding="utf-8")
BLOCKS = python_blocks(README_TEXT)
PAGE_BLOCKS = python_blocks(LIBRARY_PAGE.read_text(encoding="utf-8"))


# --- the front page --------------------------------------------------------------------------------------------------

def test_readme_is_a_front_page():
    n = len(README_TEXT.splitlines())
    assert n <= MAX_LINES, f"README.md has {n} lines, the front page promises at most {MAX_LINES}: move detail to docs/"
    lines = README_TEXT.splitlines()
    assert lines[0].startswith("# "), "README.md: the first line is not the title"
    where = [i + 1 for i, line in enumerate(lines) if line.strip() == "## What we found"]
    assert len(where) == 1, f"README.md: expected one '## What we found' heading, found it at lines {where}"
    assert where[0] <= FINDINGS_BY_LINE, f"README.md: '## What we found' at line {where[0]}, after line " \
                                         f"{FINDINGS_BY_LINE}"
    assert "replicated" not in lines[0].lower(), "the title says 'replicated', the opposite of most findings"


def findings_lines(text: str) -> list[str]:
    """The non-blank lines between the findings markers of ``text`` (exactly one of each, in order, after the
    '## What we found' heading: an AssertionError otherwise)."""
    assert text.count(FINDINGS_START) == 1 and text.count(FINDINGS_END) == 1, \
        f"expected exactly one {FINDINGS_START} and one {FINDINGS_END}, found {text.count(FINDINGS_START)} and " \
        f"{text.count(FINDINGS_END)}"
    start, end = text.index(FINDINGS_START), text.index(FINDINGS_END)
    assert text.index("## What we found") < start < end, "the findings markers are not in order under the heading"
    return [line for line in text[start + len(FINDINGS_START):end].splitlines() if line.strip()]


def test_findings_block_has_a_line_per_paper_and_one_for_controls_and_arena():
    from mmlib.papers import REGISTRY
    lines = findings_lines(README_TEXT)
    papers = [name for name in REGISTRY if REGISTRY[name].kind != "control"]
    assert len(lines) == len(papers) + 1, \
        f"expected {len(papers) + 1} findings lines (one per paper of the registry, one for controls and arena), " \
        f"got {len(lines)}:\n" + "\n".join(lines)
    for name in papers:
        naming = [line for line in lines if re.search(rf"\b{re.escape(name)}\b", line)]
        assert len(naming) == 1, f"{name}: expected one findings line naming it, found {len(naming)}"
    rest = [line for line in lines if not any(re.search(rf"\b{re.escape(n)}\b", line) for n in papers)]
    assert len(rest) == 1 and re.search(r"\barena\b", rest[0], re.I) and re.search(r"\bcontrols?\b", rest[0], re.I), \
        f"expected one findings line on the controls and the arena, got {rest}"


def test_findings_parser_counts_what_it_should():
    """The marker rules on small documents: a missing or doubled marker fails, blank lines are not findings."""
    doc = f"# t\n\n## What we found\n\n{FINDINGS_START}\n- a\n\n- b\n{FINDINGS_END}\n"
    assert findings_lines(doc) == ["- a", "- b"]
    for bad in (doc.replace(FINDINGS_END, ""), doc + FINDINGS_START + "\n"):
        with pytest.raises(AssertionError):
            findings_lines(bad)


def test_the_two_commands_are_shown_and_exist():
    shell = "\n".join(fenced_blocks(README_TEXT, "sh"))
    makefile = (ROOT / "Makefile").read_text(encoding="utf-8")
    for target in ("figures", "test"):
        assert re.search(rf"^make {target}\b", shell, re.M), f"README.md: no shell line 'make {target}'"
        assert re.search(rf"^{target}:", makefile, re.M), f"Makefile: no target {target!r}, which the README shows"


def test_table_of_papers_has_every_registered_paper():
    from mmlib.papers import REGISTRY
    rows = [line for line in README_TEXT.splitlines() if line.startswith("|")]
    for name in REGISTRY:
        paper = REGISTRY[name]
        row = [r for r in rows if f"notebooks/{paper.notebook}.py" in r]
        assert len(row) == 1, f"{name}: expected one row of the papers' table linking notebooks/{paper.notebook}.py"
        if paper.doi:
            assert paper.doi in row[0], f"{name}: its DOI {paper.doi} is not in its table row"


# --- links and navigation -------------------------------------------------------------------------------------------

LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)")


def relative_links(text: str) -> list[str]:
    """The targets of the Markdown links of ``text`` that point into the repository or the site (no scheme, no bare
    anchor), without their anchors; links inside fenced code are not links."""
    text = re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)
    text = re.sub(r"`[^`\n]*`", "", text)
    return [t.split("#")[0] for t in LINK.findall(text)
            if not re.match(r"^[a-z][a-z0-9+.-]*:", t, re.I) and not t.startswith("#")]


def test_link_finder():
    doc = "[a](x.md) [b](https://e.org) [c](#here) ![img](p.png) `[d](no.md)` [e](y/z.md#part)\n```\n[f](g.md)\n```\n"
    assert relative_links(doc) == ["x.md", "y/z.md"]


def test_every_relative_link_of_the_readme_resolves():
    links = relative_links(README_TEXT)
    assert len(links) >= 10, f"README.md: expected links to the reports and the docs pages, found {links}"
    broken = [t for t in links if not (ROOT / t).exists()]
    assert not broken, f"README.md: links to nothing in the repository: {broken}"
    for page in moved_pages():
        assert f"docs/{page.name}" in links, f"README.md: no link to docs/{page.name}"


def test_every_relative_link_of_the_moved_pages_resolves():
    for page in moved_pages():
        assert page.is_file(), f"docs/{page.name} is missing"
        for target in relative_links(page.read_text(encoding="utf-8")):
            assert (DOCS / target).is_file() or target in GENERATED_PAGES, \
                f"docs/{page.name}: the link {target!r} is neither a page of docs/ nor one the site generates " \
                f"({', '.join(GENERATED_PAGES)}); refer to a repository file as `code`"


def toctree_entries(markdown: str) -> list[str]:
    """The entries of every ```{toctree} block of a MyST page."""
    entries = []
    for block in re.findall(r"^```\{toctree\}\n(.*?)^```", markdown, flags=re.S | re.M):
        entries += [line.strip() for line in block.splitlines() if line.strip() and not line.startswith(":")]
    return entries


def test_every_docs_page_is_in_the_site_navigation():
    docs, notebooks = BUILD_SITE.load_inputs("full")
    entries = toctree_entries(BUILD_SITE.index_page(docs, notebooks))
    for page in sorted(DOCS.glob("*.md")):
        assert page.stem in entries, f"docs/{page.name} is not in the site's navigation: {entries}"
    for page in moved_pages():
        assert page.stem in entries
    assert toctree_entries("```{toctree}\n:maxdepth: 1\n\na\nb\n```\n") == ["a", "b"]


# --- the examples run -----------------------------------------------------------------------------------------------

def test_readme_has_python_blocks():
    """The README shows the library in at least one python block, and at least one of them runs (otherwise the
    parametrised test below would pass vacuously); so does the library page."""
    for path, blocks in ((README, BLOCKS), (LIBRARY_PAGE, PAGE_BLOCKS)):
        assert blocks, f"{path.name}: no ```python block found"
        assert any(not skipped for _, _, skipped in blocks), f"{path.name}: every python block is marked " \
                                                             f"{NOT_EXECUTED}"


def test_block_parser():
    """The fence parser on a small document: languages, a longer fence holding a shorter one, the marker."""
    doc = ("text\n```sh\nls\n```\n```python\na = 1\n```\n<!-- not-executed -->\n\n```python\nb = 2\n```\n"
           "````python\nprint('```')\n```\nc = 3\n````\n")
    assert python_blocks(doc) == [(5, "a = 1\n", False), (10, "b = 2\n", True),
                                  (13, "print('```')\n```\nc = 3\n", False)]


def _check_block(path: Path, line: int, code: str, skipped: bool) -> subprocess.CompletedProcess:
    """Run the block (skipped if marked); fail naming the place when it times out or exits non-zero; the process."""
    if skipped:
        pytest.skip(f"{path.name}:{line} is marked {NOT_EXECUTED}")
    proc = run_block(code, line, sys.executable, ROOT, path=path)
    if proc is None:
        pytest.fail(f"{path.name}:{line}: the python block did not finish within {TIMEOUT_S} s", pytrace=False)
    if proc.returncode != 0:
        pytest.fail(f"{path.name}:{line}: the python block failed (exit status {proc.returncode}):\n{proc.stderr}"
                    f"stdout:\n{proc.stdout}", pytrace=False)
    return proc


@pytest.mark.parametrize("line, code, skipped", BLOCKS, ids=[f"README.md:{line}" for line, _, _ in BLOCKS])
def test_readme_block_runs(line, code, skipped):
    assert _check_block(README, line, code, skipped).returncode == 0


#: Executes the code read from stdin as ``__main__`` of a fresh interpreter, compiled under the document's path, so
#: that a traceback names it and, the code being padded to its place, the document's own line numbers.
RUNNER = ("import sys; exec(compile(sys.stdin.read(), sys.argv[1], 'exec'), "
          "{'__name__': '__main__'})")


def run_block(code: str, line: int, python: str, cwd: Path, timeout: float = TIMEOUT_S, path: Path = README,
              env: dict | None = None):
    """Run the block that opens at line ``line`` of ``path`` with the interpreter ``python`` in ``cwd`` (environment
    ``env``, None: this process's): the finished ``subprocess.CompletedProcess`` (text stdout and stderr), or None on
    timeout."""
    try:
        return subprocess.run([python, "-c", RUNNER, str(path)], input="\n" * line + code, cwd=cwd, env=env,
                              capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None


NUMBER = r"(\d+(?:\.\d+)?%?)"


def check_quoted(path: Path, blocks: list, pairs: dict[str, tuple[str, str]]) -> dict[str, tuple]:
    """Run the block of ``path`` that calls ``mmlib.run(`` and check that the prose after it quotes each number as
    the block prints it, digit for digit (a run of the same code gives the same bits, so a quoted number that
    differs is out of date): ``pairs`` maps a name to (regex of the printed line, regex of the prose)."""
    text = path.read_text(encoding="utf-8")
    line, code, _ = next(b for b in blocks if "mmlib.run(" in b[1])
    proc = run_block(code, line, sys.executable, ROOT, path=path)
    assert proc is not None and proc.returncode == 0, proc and proc.stderr
    prose = text[text.index(code) + len(code):]
    checked = {}
    for key, (printed, quoted) in pairs.items():
        got, said = re.search(printed, proc.stdout), re.search(quoted, prose)
        assert got, f"{key}: the example of {path.name} no longer prints {printed!r}:\n{proc.stdout}"
        assert said, f"{key}: the prose after the example of {path.name} no longer quotes {quoted!r}"
        assert said.groups() == got.groups(), \
            f"{key}: the example of {path.name} prints {got.groups()}, the text says {said.groups()}"
        checked[key] = got.groups()
    return checked


def test_the_numbers_quoted_after_the_readme_example_are_the_ones_it_prints():
    assert set(check_quoted(README, BLOCKS, {
        "RMSE": (rf"position RMSE {NUMBER} \+/- {NUMBER} m over {NUMBER} runs",
                 rf"position RMSE of {NUMBER} ± {NUMBER} m over {NUMBER} runs")})) == {"RMSE"}


@pytest.mark.parametrize("line, code, skipped", PAGE_BLOCKS,
                         ids=[f"library.md:{line}" for line, _, _ in PAGE_BLOCKS])
def test_library_page_block_runs(line, code, skipped):
    assert _check_block(LIBRARY_PAGE, line, code, skipped).returncode == 0


def test_the_numbers_quoted_after_the_library_example_are_the_ones_it_prints():
    pairs = {
        "RMSE": (rf"position RMSE {NUMBER} \+/- {NUMBER} m", rf"position RMSE of {NUMBER} ± {NUMBER} m"),
        "ANEES": (rf"ANEES {NUMBER} \+/- {NUMBER}", rf"time-averaged NEES is\s+{NUMBER} ± {NUMBER}"),
        "inside": (rf"at {NUMBER} of the", rf"at only {NUMBER} of the"),
        "peak": (rf"peak {NUMBER}", rf"peak of\s+{NUMBER}")}
    assert set(check_quoted(LIBRARY_PAGE, PAGE_BLOCKS, pairs)) == set(pairs)
