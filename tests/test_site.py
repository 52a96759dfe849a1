"""The site (tools/build_site.py, ``make site``) in a real browser: headless Chromium (Debian's ``chromium`` package,
installed by .ci/run, or here when missing and the test runs as root with apt-get) driven by Playwright opens every
page, served from 127.0.0.1, and checks:

* no console error and no uncaught page error;
* no request leaves the machine (each is intercepted: one to another host is aborted and reported), and no local
  request fails;
* every image loads (``complete`` with a natural width);
* the mathematics is typeset: every ``.math`` element was processed by the bundled MathJax with no error, and no
  ``$...$`` is left as text outside code;
* every comparison table renders as a table (no Markdown pipe row left as text; each paper page has a table with a
  verdict column);
* every internal link resolves to a page of the site and, with a fragment, to an element of that page.

and, at a desktop's and a phone's width (1280 x 800 and 390 x 844 CSS px), on every paper, control, reading-space
page, the arena and the home page (:func:`layout_problems`):

* no table's verdict column (the first column whose header ends in "verdict": "verdict", "headline verdict")
  lies outside the screen sideways;
* no figure is shown narrower than its legible minimum unless it links to its full size;
* no page scrolls sideways;
* each paper page shows its verdict box (``.verdict-box``) within the first screen.

A screenshot of the top of each paper page is written under build/site-check/ for a person to look at, and one of
the first screens of each paper and control page at both widths (``<page>-<width>.png``).  The site is
built from the committed outputs (data/results/, notebooks/executed/) into a temporary folder, so the test also
checks that they build (warnings are errors).
"""
from __future__ import annotations

import functools
import http.server
import importlib.util
import os
import re
import shutil
import subprocess
import threading
from pathlib import Path
from urllib.parse import unquote, urljoin, urlsplit

import pytest

REPO = Path(__file__).resolve().parents[1]
CHECK_DIR = REPO / "build" / "site-check"
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--disable-default-apps", "--disable-extensions", "--metrics-recording-only",
                  "--disable-dev-shm-usage"]


def load_builder():
    spec = importlib.util.spec_from_file_location("build_site", REPO / "tools" / "build_site.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def chromium() -> str:
    """Debian's Chromium; installed with apt-get when missing and this process may (root, apt-get present)."""
    found = shutil.which("chromium")
    if found is None and os.geteuid() == 0 and shutil.which("apt-get"):
        env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
        subprocess.run(["apt-get", "update", "-qq"], env=env, capture_output=True, timeout=600)
        subprocess.run(["apt-get", "install", "-y", "-qq", "--no-install-recommends", "chromium"], env=env,
                       capture_output=True, timeout=900)
        found = shutil.which("chromium")
    if found is None:
        pytest.fail("no chromium on PATH: install Debian's chromium package (apt-get install chromium), "
                    "as .ci/run does")
    return found


class QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The site built from the committed outputs, served on 127.0.0.1: (folder, base URL)."""
    builder = load_builder()
    root = tmp_path_factory.mktemp("site")
    out = builder.build("full", out=root / "site")
    shutil.rmtree(CHECK_DIR, ignore_errors=True)          # this run's screenshots only
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0),
                                             functools.partial(QuietHandler, directory=str(out)))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield out, f"http://127.0.0.1:{server.server_address[1]}/"
    server.shutdown()


@pytest.fixture(scope="module")
def browser():
    from playwright.sync_api import sync_playwright
    path = chromium()
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=path, args=CHROMIUM_FLAGS, headless=True)
        yield b
        b.close()


def pages(out: Path) -> list[str]:
    return sorted(p.relative_to(out).as_posix() for p in out.rglob("*.html")
                  if not p.relative_to(out).as_posix().startswith(("_static/", "_sources/")))


def ids_of(path: Path) -> set[str]:
    return set(re.findall(r'\sid="([^"]+)"', path.read_text(errors="replace")))


# typeset state of every math element Sphinx wrote (class "math notranslate"; MathJax's own output also uses class
# "math" inside): MathJax 2 leaves a script of type math/tex next to its output
MATH_STATE = """() => {
  const maths = Array.from(document.querySelectorAll('.math.notranslate'));
  const raw = maths.filter(m => !m.querySelector('script[type^="math/tex"]')).map(m => m.textContent.slice(0, 80));
  const errors = Array.from(document.querySelectorAll('.MathJax_Error, .mjx-merror, merror'))
                     .map(e => e.textContent.slice(0, 80));
  // an undefined macro is no error to MathJax (noUndefined): it is typeset in red, which its MathML records
  const undefined = Array.from(document.querySelectorAll('[data-mathml]'))
                         .filter(e => e.getAttribute('data-mathml').includes('mathcolor="red"'))
                         .map(e => e.textContent.slice(0, 80));
  errors.push(...undefined);
  return {count: maths.length, raw: raw, errors: errors};
}"""

# text outside code that still looks like Markdown: $math$ or a pipe-table row
LEFTOVER_TEXT = r"""() => {
  const walker = document.createTreeWalker(document.querySelector('article') || document.body, NodeFilter.SHOW_TEXT);
  const dollars = [], pipes = [];
  for (let n = walker.nextNode(); n; n = walker.nextNode()) {
    if (n.parentElement.closest('pre, code, script, style, .highlight, .MathJax, .MathJax_CHTML, .math')) continue;
    const t = n.textContent;
    if (/\$[^$\s][^$]*\$/.test(t)) dollars.push(t.trim().slice(0, 80));
    if (/\|\s*-{3,}\s*\|/.test(t) || /^\s*\|.*\|.*\|\s*$/m.test(t)) pipes.push(t.trim().slice(0, 80));
  }
  return {dollars: dollars, pipes: pipes};
}"""

IMAGES = """() => Array.from(document.images).filter(i => !(i.complete && i.naturalWidth > 0))
                                     .map(i => i.getAttribute('src'))"""

# notebook pages: code cells folded (each behind a <details> toggle), no stderr output published
NOTEBOOK_STATE = """() => ({cells: document.querySelectorAll('div.cell').length,
  unfolded: Array.from(document.querySelectorAll('div.cell')).filter(c => !c.querySelector('details.hide')).length,
  stderr: Array.from(document.querySelectorAll('div.output.stderr'), e => e.textContent.slice(0, 80))})"""

VERDICT_TABLES = """() => Array.from(document.querySelectorAll('table')).filter(
  t => Array.from(t.querySelectorAll('th')).some(h => /verdict/i.test(h.textContent))).length"""


class PageChecker:
    """One browser context and page that visit the site's pages in turn (the cache and MathJax's compiled code shared
    between pages, as when a reader browses: half the time of a context per page), each page's problems attributed
    to it: every request, console message, page error and failed response is recorded under the page being checked."""

    def __init__(self, browser, base: str, out: Path):
        self.base, self.out, self.rel, self.problems = base, out, "", []
        self.context = browser.new_context(viewport={"width": 1280, "height": 1600})
        host = urlsplit(base).netloc

        def route(r):
            if urlsplit(r.request.url).netloc == host or r.request.url.startswith(("data:", "blob:", "about:")):
                r.continue_()
            else:
                self.problems.append(f"{self.rel}: request to another host: {r.request.url}")
                r.abort()

        self.context.route("**/*", route)
        self.page = self.context.new_page()
        self.page.on("console", lambda m: self.problems.append(f"{self.rel}: console {m.type}: {m.text}")
                     if m.type == "error" else None)
        self.page.on("pageerror", lambda e: self.problems.append(f"{self.rel}: page error: {e}"))
        self.page.on("response", lambda r: self.problems.append(f"{self.rel}: {r.status} for {r.url}")
                     if r.status >= 400 and urlsplit(r.url).netloc == host else None)

    def check(self, rel: str) -> list[str]:
        """Every problem of page ``rel``, each a sentence naming the page."""
        self.rel, first = rel, len(self.problems)
        problems: list[str] = []
        page, base, out = self.page, self.base, self.out
        page.goto(base + rel, wait_until="load", timeout=60_000)
        if page.evaluate("() => document.querySelectorAll('.math.notranslate').length"):
            try:          # MathJax loaded, then everything queued before this callback (the page's typesetting) done
                page.wait_for_function("() => window.MathJax && window.MathJax.Hub && MathJax.isReady", timeout=60_000)
                page.evaluate("() => new Promise(done => MathJax.Hub.Queue(() => done(true)))")
            except Exception as exc:  # noqa: BLE001 -- reported with the page, the other checks still run
                problems.append(f"{rel}: MathJax did not load or finish typesetting: {type(exc).__name__}")
            math = page.evaluate(MATH_STATE)
            problems += [f"{rel}: math not typeset: {t!r}" for t in math["raw"][:5]]
            problems += [f"{rel}: MathJax error: {t!r}" for t in math["errors"][:5]]
        left = page.evaluate(LEFTOVER_TEXT)
        problems += [f"{rel}: $...$ left as text: {t!r}" for t in left["dollars"][:5]]
        problems += [f"{rel}: Markdown table left as text: {t!r}" for t in left["pipes"][:5]]
        problems += [f"{rel}: image does not load: {src}" for src in page.evaluate(IMAGES)]
        if rel.startswith("papers/") or rel == "arena.html" or page.evaluate(
                "() => document.querySelectorAll('div.cell').length"):
            nb = page.evaluate(NOTEBOOK_STATE)
            if nb["unfolded"]:
                problems.append(f"{rel}: {nb['unfolded']} of {nb['cells']} code cells not folded")
            problems += [f"{rel}: stderr output published: {t!r}" for t in nb["stderr"][:3]]
        if rel.startswith(("papers/", "controls/")):
            if page.evaluate(VERDICT_TABLES) == 0:
                problems.append(f"{rel}: no comparison table with a verdict column")
            CHECK_DIR.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(CHECK_DIR / f"{Path(rel).stem}.png"), full_page=True,
                            clip={"x": 0, "y": 0, "width": 1280, "height": 4000})
        hrefs = page.evaluate("() => Array.from(document.querySelectorAll('a[href]'), a => a.getAttribute('href'))")
        for href in hrefs:
            problems += link_problems(base, out, rel, href)
        return self.problems[first:] + problems

    def close(self) -> None:
        self.context.close()


#: the two screens of the layout checks, (width, height) in CSS px: a laptop's and a phone's (iPhone 12 to 15, the
#: commonest phone width in 2024; 390 is also under the site's 600 px phone breakpoint, docs/_static/site.css)
SCREENS = ((1280, 800), (390, 844))
#: a figure's legible minimum, as a fraction of its natural width: the figures are saved at 150 dpi with 10 pt text and
#: 8 pt legends (mmlib.experiment.writing, notebook.py's rcParams), i.e. 21 and 17 px glyphs at natural size; at half
#: size the legends are 8 px, the smallest a screen's text stays readable at.  An image narrower than LEGIBLE_FLOOR px
#: at natural size (an icon, a badge) must be shown at its natural width.
LEGIBLE_FRACTION = 0.5
LEGIBLE_FLOOR = 300
#: the widest screen shown a figure's narrow variant (the site's phone layout)
PHONE_WIDTH = load_builder().PHONE_WIDTH

# the layout of the page as shown (scrolled to the top) on a screen of W x H CSS px: verdict columns out of the screen
# sideways, figures shown below their legible minimum without a link to full size, the page's own width and the
# verdict box's top.  The screen's size is given, not read from window.innerWidth: a mobile browser widens its layout
# viewport to a page wider than the screen (zoomed out), so innerWidth would hide the very overflow looked for.
LAYOUT = r"""([fraction, floor, W, H]) => {
  const root = document.querySelector('article') || document.body;
  const offscreen = [], small = [];
  root.querySelectorAll('table').forEach((t, i) => {
    const head = t.querySelector('tr');
    if (!head) return;
    const cells = Array.from(head.children);
    const col = cells.findIndex(c => /\bverdict$/i.test(c.textContent.trim()));
    if (col < 0) return;
    for (const row of Array.from(t.querySelectorAll('tr')).slice(0, 2)) {    // the header and the first row
      const c = row.children[col];
      if (!c) continue;
      const r = c.getBoundingClientRect();
      if (r.width === 0) continue;                                          // not shown (a closed fold)
      if (r.right > W + 1 || r.left < -1)
      { offscreen.push(`table ${i + 1} (${cells[col].textContent.trim().slice(0, 30)}): its left..right ` +
                       `${Math.round(r.left)}..${Math.round(r.right)} px, screen 0..${W}`);
        break; }
    }
  });
  root.querySelectorAll('img').forEach(img => {
    const w = img.getBoundingClientRect().width, n = img.naturalWidth;
    if (w === 0 || !n) return;
    const minimum = Math.min(n, Math.max(floor, fraction * n));
    if (w < minimum - 1 && !img.closest('a[href]'))
      small.push(`${img.getAttribute('src').slice(-60)} shown ${Math.round(w)} px wide, legible from ` +
                 `${Math.round(minimum)} px (natural ${n}), and no link to full size`);
  });
  // a figure with panels side by side: its narrow variant (the panels stacked) is what a phone shows, the
  // figure itself what a wider screen shows
  const pictures = [];
  root.querySelectorAll('picture').forEach(p => {
    const source = p.querySelector('source[media]'), img = p.querySelector('img');
    if (!source || !img) return;
    pictures.push({shown: img.currentSrc, narrow: new URL(source.getAttribute('srcset'), document.baseURI).href,
                   wide: new URL(img.getAttribute('src'), document.baseURI).href,
                   shown_width: img.getBoundingClientRect().width, natural: img.naturalWidth});
  });
  const box = document.querySelector('.verdict-box');
  return {offscreen: offscreen, small: small, pictures: pictures, page_width: document.documentElement.scrollWidth,
          width: W, height: H, box_top: box ? box.getBoundingClientRect().top + window.scrollY : null};
}"""


def layout_problems(page, rel: str, require_box: bool) -> list[str]:
    """The layout problems of the page open in ``page`` (site path ``rel``, its context's viewport the screen),
    scrolled to the top, each a sentence naming the page and the screen's width; ``require_box``: the page must have
    a verdict box."""
    page.evaluate("() => window.scrollTo(0, 0)")
    screen = page.viewport_size
    got = page.evaluate(LAYOUT, [LEGIBLE_FRACTION, LEGIBLE_FLOOR, screen["width"], screen["height"]])
    at = f"{rel} at {got['width']} px"
    problems = [f"{at}: verdict column off-screen: {t}" for t in got["offscreen"]]
    problems += [f"{at}: figure too small: {t}" for t in got["small"]]
    for pic in got["pictures"]:
        want = "narrow" if got["width"] <= PHONE_WIDTH else "wide"
        if pic["shown"] != pic[want]:
            problems.append(f"{at}: a figure with panels side by side shows {pic['shown'][-60:]}, not its {want} "
                            f"variant {pic[want][-60:]}")
    if got["page_width"] > got["width"] + 1:
        problems.append(f"{at}: the page scrolls sideways ({got['page_width']} px wide)")
    if got["box_top"] is None:
        if require_box:
            problems.append(f"{at}: no verdict box (.verdict-box)")
    elif got["box_top"] >= got["height"]:
        problems.append(f"{at}: verdict box below the first screen (its top at {got['box_top']:.0f} px, "
                        f"screen {got['height']} px high)")
    return problems


def open_for_layout(page, url: str) -> None:
    """Open ``url`` and wait for what moves the layout: the images (load) and the mathematics (MathJax's queue)."""
    page.goto(url, wait_until="load", timeout=60_000)
    if page.evaluate("() => document.querySelectorAll('.math.notranslate').length"):
        try:
            page.wait_for_function("() => window.MathJax && window.MathJax.Hub && MathJax.isReady", timeout=60_000)
            page.evaluate("() => new Promise(done => MathJax.Hub.Queue(() => done(true)))")
        except Exception:  # noqa: BLE001 -- the browser test reports MathJax; the layout is checked as it is
            pass


def layout_context(browser, width: int, height: int):
    """A browser context of one screen; a phone's (``width`` < 600) emulates a mobile browser (meta viewport, touch)."""
    phone = width < 600
    return browser.new_context(viewport={"width": width, "height": height}, is_mobile=phone, has_touch=phone)


def test_layout_at_desktop_and_phone_widths(site, browser):
    """Every paper, control and reading-space page, the arena and the home page at a desktop's and a phone's width:
    verdict columns on screen, figures legible or linked to full size, no sideways scrolling, each paper page's
    verdict box within the first screen; screenshots of the paper and control pages' first screens at both widths."""
    out, base = site
    rels = [r for r in pages(out) if r.startswith(("papers/", "controls/", "reading-spaces"))
            or r in ("arena.html", "index.html")]
    assert any(r.startswith("papers/") for r in rels) and any(r.startswith("reading-spaces/") for r in rels)
    CHECK_DIR.mkdir(parents=True, exist_ok=True)
    problems, shots, pictures = [], [], {}
    for width, height in SCREENS:
        context = layout_context(browser, width, height)
        page = context.new_page()
        for rel in rels:
            open_for_layout(page, base + rel)
            problems += layout_problems(page, rel, require_box=rel.startswith("papers/"))
            pictures[rel, width] = page.evaluate("() => document.querySelectorAll('article picture').length")
            if rel.startswith(("papers/", "controls/")):
                shot = CHECK_DIR / f"{Path(rel).stem}-{width}.png"
                page.screenshot(path=str(shot))          # the first screen: what a reader sees before scrolling
                shots.append(shot)
        context.close()
    assert not problems, f"{len(problems)} problem(s):\n" + "\n".join(problems[:60])
    assert shots and all(s.is_file() and s.stat().st_size > 0 for s in shots)
    # the narrow variants were there to check: the controls' two panels and the arena's ladder, at both widths
    assert all(pictures[rel, w] for rel in rels if rel.startswith("controls/") or rel == "arena.html"
               for w, _ in SCREENS), pictures


def test_the_layout_checks_catch_what_they_look_for(site, browser):
    """The layout checks can fail: a real paper page with its verdict box removed, a wide table whose verdict column
    is not kept on screen, a figure shrunk with no link and a block wider than the screen; the same page with a box
    far down; and they pass the same page with a box at its top, at both widths."""
    out, base = site
    rel = next(r for r in pages(out) if r.startswith("papers/"))
    real = (out / rel).read_text()
    assert real.count("</article>") == 1 and "<h1" in real
    real = real.replace('class="verdict-box', 'class="was-verdict-box')     # whatever box it has: ours below
    fig = next((out / "_static" / "figures").rglob("*.png")).relative_to(out).as_posix()
    cols = "".join(f"<th>column {i}</th>" for i in range(12))
    wide = (f'<table class="docutils"><thead><tr>{cols}<th>verdict</th></tr></thead>'
            f'<tbody><tr>{"<td>1234567890.123456789</td>" * 12}<td>contradicted</td></tr></tbody></table>')
    shrunk = f'<img src="../{fig}" style="width: 120px">'
    # a figure whose narrow variant is never shown (its media query matches no screen) and one always shown
    never = f'<picture><source media="(max-width: 10px)" srcset="../{fig}?narrow"><img src="../{fig}"></picture>'
    always = f'<picture><source media="(min-width: 1px)" srcset="../{fig}?narrow"><img src="../{fig}"></picture>'
    box = '<div class="verdict-box">the verdicts</div>'
    cases = {"none": real.replace("</article>", wide + shrunk + never + always + "</article>").replace(
                 "</body>", '<div style="width: 2000px">wide</div></body>'),
             "far": real.replace("</article>", '<div style="height: 3000px"></div>' + box + "</article>"),
             "top": re.sub(r"(</h1>)", r"\1" + box, real, count=1)}
    found = {}
    try:
        for name, html in cases.items():
            (out / "papers" / f"zz-{name}.html").write_text(html)
        for width, height in SCREENS:
            context = layout_context(browser, width, height)
            page = context.new_page()
            for name in cases:
                open_for_layout(page, f"{base}papers/zz-{name}.html")
                found[name, width] = "\n".join(layout_problems(page, f"papers/zz-{name}.html", require_box=True))
            context.close()
    finally:
        for name in cases:
            (out / "papers" / f"zz-{name}.html").unlink(missing_ok=True)
    for width, _ in SCREENS:
        assert "no verdict box (.verdict-box)" in found["none", width], found["none", width]
        assert "verdict column off-screen: table" in found["none", width], found["none", width]
        assert "figure too small:" in found["none", width] and "no link to full size" in found["none", width]
        assert "the page scrolls sideways" in found["none", width], found["none", width]
        # at a phone's width the one never narrow is found, at a desktop's the one always narrow
        assert f"not its {'narrow' if width <= PHONE_WIDTH else 'wide'} variant" in found["none", width]
        assert "panels side by side" not in found["top", width]
        assert "verdict box below the first screen" in found["far", width], found["far", width]
        assert "verdict box" not in found["top", width], found["top", width]


def check_page(browser, base: str, out: Path, rel: str) -> list[str]:
    """Every problem of one page, each a sentence naming the page, in a context of its own."""
    checker = PageChecker(browser, base, out)
    try:
        return checker.check(rel)
    finally:
        checker.close()


@functools.lru_cache(maxsize=None)
def _ids(path: str) -> frozenset:
    return frozenset(ids_of(Path(path)))


def link_problems(base: str, out: Path, rel: str, href: str) -> list[str]:
    """A link of page ``rel`` that points into the site but to no page (or no element) of it."""
    if href.startswith(("mailto:", "javascript:")):
        return []
    url = urljoin(base + rel, href)
    if not url.startswith(base):
        return []                                   # external: a link, never a request (checked above)
    parts = urlsplit(url)
    target = out / unquote(parts.path[len(urlsplit(base).path):])
    if target.is_dir():
        target = target / "index.html"
    if not target.is_file():
        return [f"{rel}: broken link {href!r} (no {target.relative_to(out).as_posix()})"]
    if parts.fragment and target.suffix == ".html" and unquote(parts.fragment) not in _ids(str(target)):
        return [f"{rel}: broken link {href!r} (no element #{parts.fragment} in {target.relative_to(out)})"]
    return []


def test_every_page_in_a_real_browser(site, browser):
    out, base = site
    rels = pages(out)
    assert {"index.html", "getting-started.html", "reading-spaces.html", "arena.html", "api/index.html"} <= set(rels)
    # one reading-space page per paper with a reading space, each linked from the index of reading spaces
    spaces = sorted(r for r in rels if r.startswith("reading-spaces/"))
    assert spaces and all(f'href="{r}"' in (out / "reading-spaces.html").read_text() for r in spaces)
    builder = load_builder()
    docs, notebooks = builder.load_inputs("full")
    controls = builder.controls_of(docs)
    # one page per notebook: the controls under controls/, the papers under papers/, the arena at the top
    assert sorted(r for r in rels if r.startswith("controls/")) == sorted(
        f"controls/{notebooks[c].stem}.html" for c in controls)
    assert sorted(r for r in rels if r.startswith("papers/")) == sorted(
        f"papers/{nb.stem}.html" for p, nb in notebooks.items() if p != "arena" and p not in controls)
    checker = PageChecker(browser, base, out)
    problems = [p for rel in rels for p in checker.check(rel)]
    checker.close()
    assert not problems, f"{len(problems)} problem(s):\n" + "\n".join(problems[:60])
    # (the layout test's screenshots, <page>-<width>.png, share the folder)
    assert sorted(p.name for p in CHECK_DIR.glob("*.png") if not re.search(r"-\d+\.png$", p.name)) == sorted(
        f"{Path(r).stem}.png" for r in rels if r.startswith(("papers/", "controls/")))
    # the controls come first: in the navigation and in the home page's text
    home = (out / "index.html").read_text()
    if controls:
        first = min(home.find(f"controls/{notebooks[c].stem}.html") for c in controls)
        assert 0 <= first < min(home.find(f"papers/{nb.stem}.html") for p, nb in notebooks.items()
                                if p != "arena" and p not in controls)
    # a paper whose verdicts judge a reconstruction wears its chip on the home page and on its page
    import make_report
    for d in docs:
        q = make_report.qualifier_of(d) if d.get("kind") != "arena" else ""
        if q:
            assert f'class="verdict-chip chip-{q}"' in home, d["paper"]
            page = out / builder.page_path(d["paper"], notebooks, controls).replace(".ipynb", ".html")
            assert f'class="verdict-chip chip-{q}"' in page.read_text(), d["paper"]


def test_the_checks_catch_what_they_look_for(site, browser):
    """The checks can fail: a real page of the site (MathJax loaded) with an external script, a broken link and
    anchor, a missing image, raw $math$, an undefined TeX macro, a Markdown table left as text, an unfolded code cell
    and a stderr output injected is reported for each."""
    out, base = site
    page = (out / "api" / "mmlib.core.rules.html").read_text()      # a page that loads MathJax
    defects = ('<p>see $x_k$ here</p><p>| a | b |\n|---|---|</p><img src="../_images/none.png">'
               '<a href="nowhere.html">x</a><a href="../index.html#no-such-id">y</a>'
               '<span class="math notranslate nohighlight">\\(\\undefinedmacro x\\)</span>'
               '<div class="cell docutils container"><div class="cell_output docutils container">'
               '<div class="output stderr"><pre>  [x] 1/2 runs</pre></div></div></div>'
               '<script src="https://cdn.example.org/x.js"></script>')
    assert page.count("</article>") == 1
    bad = out / "api" / "zz-bad-page.html"
    bad.write_text(page.replace("</article>", defects + "</article>"))
    try:
        problems = check_page(browser, base, out, "api/zz-bad-page.html")
    finally:
        bad.unlink()
    text = "\n".join(problems)
    for expected in ("request to another host: https://cdn.example.org/x.js", "broken link 'nowhere.html'",
                     "no element #no-such-id", "image does not load: ../_images/none.png", "$...$ left as text",
                     "Markdown table left as text", "404 for", "MathJax error: ", "1 of 1 code cells not folded",
                     "stderr output published: '  [x] 1/2 runs'"):
        assert expected in text, (expected, text)


def test_committed_notebooks_are_fit_to_publish():
    """The committed executed notebooks hold no stderr output (progress goes to the runner's log) and no path of
    the machine that ran them."""
    import json
    executed = sorted((REPO / "notebooks" / "executed").glob("*.ipynb"))
    assert [p.stem for p in executed] == sorted(p.stem for p in (REPO / "notebooks").glob("*.py"))
    for path in executed:
        text = path.read_text()
        nb = json.loads(text)
        stderr = [i for i, c in enumerate(nb["cells"]) for o in c.get("outputs", []) if o.get("name") == "stderr"]
        assert not stderr, f"{path.name}: stderr output in cells {stderr}"
        for local in (str(REPO), "/home/", "/tmp/", "/root/", "/Users/", "/work/", "/opt/", "/var/", "/mnt/",
                      "C:\\\\"):
            assert local not in text, f"{path.name}: machine-local path {local!r}"


def test_make_figures_site_step_waits_for_missing_outputs_only(tmp_path, monkeypatch, capsys):
    """--if-complete (the last step of make figures) builds nothing and exits 0 when some paper's outputs are
    missing, naming them; any other problem (two notebooks of one paper) is still an error."""
    builder = load_builder()
    (tmp_path / "notebooks").mkdir()
    (tmp_path / "data" / "results").mkdir(parents=True)
    (tmp_path / "notebooks" / "zhu2016_imm5ckf.py").write_text("")
    (tmp_path / "data" / "results" / "zhu2016.json").write_text('{"paper": "zhu2016"}')
    monkeypatch.setattr(builder, "REPO", tmp_path)
    assert builder.main(["--if-complete", "--out", str(tmp_path / "site")]) == 0
    assert "site: not built, the outputs are incomplete: zhu2016: no notebooks/executed/zhu2016_imm5ckf.ipynb" in \
        capsys.readouterr().out
    assert not (tmp_path / "site").exists()
    (tmp_path / "notebooks" / "zhu2016_other.py").write_text("")
    assert builder.main(["--if-complete", "--out", str(tmp_path / "site")]) == 2
    assert "a second notebook of zhu2016" in capsys.readouterr().err


def test_site_before_any_results_says_what_to_run(tmp_path, monkeypatch):
    builder = load_builder()
    monkeypatch.setattr(builder, "REPO", tmp_path)
    with pytest.raises(builder.SiteError, match=r"no results in data/results/: run `make figures` first"):
        builder.build("full", out=tmp_path / "site")
    with pytest.raises(builder.SiteError, match=r"run `make figures PROFILE=smoke` first"):
        builder.build("smoke", out=tmp_path / "site")
    assert not (tmp_path / "site").exists()


def test_a_failing_page_is_named_with_its_notebook_and_cell(tmp_path):
    """A real build of a notebook whose cell 2 holds an unknown directive fails, naming the notebook and cell 2."""
    import nbformat
    builder = load_builder()
    stage = tmp_path / "site-src"
    (stage / "papers").mkdir(parents=True)
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_markdown_cell("# A page"), nbformat.v4.new_code_cell("x = 1"),
                nbformat.v4.new_markdown_cell("Some text.\n\n```{nosuchdirective}\n```\n")]
    nb.metadata["kernelspec"] = {"name": "mmlib", "display_name": "mmlib (.venv)", "language": "python"}
    nbformat.write(nb, stage / "papers" / "broken.ipynb")
    (stage / "index.md").write_text("# Home\n\n```{toctree}\npapers/broken\n```\n")
    with pytest.raises(builder.SiteError) as err:
        builder.sphinx(stage, tmp_path / "html")
    assert "notebook papers/broken.ipynb, cell 2 (index in the .ipynb, from 0): WARNING: Unknown directive type: " \
           "'nosuchdirective'" in str(err.value)
    assert not (tmp_path / "html").exists()
