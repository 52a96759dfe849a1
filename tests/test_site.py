"""The site (tools/build_site.py, ``make site``) in a real browser: headless Chromium (Debian's ``chromium`` package,
installed by .ci/run, or here when missing and the test runs as root with apt-get) driven by Playwright opens the
pages, served from 127.0.0.1, and checks:

* no console error and no uncaught page error;
* no request leaves the machine (each is watched: one to another host is reported, and the browser's proxy, a port
  that refuses connections, fails it at once), and no local request fails;
* every image loads (``complete`` with a natural width);
* the mathematics is typeset: every ``.math`` element was processed by the bundled MathJax with no error, and no
  ``$...$`` is left as text outside code;
* every comparison table renders as a table (no Markdown pipe row left as text; each paper page has a table with a
  verdict column);
* every internal link resolves to a page of the site and, with a fragment, to an element of that page.

The browser opens every page but most of the API's module pages (:func:`in_browser`): every page outside api/, the
API's index, and of the module pages under api/ (autodoc's, all of one template) the first in sorted order of each
set of scripts and stylesheets, and any that has an image or other media, a notebook cell, a style with url(), a
formula where MathJax does not look or a formula whose effect reaches the next ones (a macro or label defined).  The
other module pages run the same code over the same template as one opened: what a browser alone sees on them is
their mathematics, which the bundled MathJax typesets in the browser all on one shared page of the same head, each
problem named with the formula's page (:meth:`PageChecker.check_formulas`); the rest is read from their HTML
(:class:`StaticPage`, :func:`static_problems`): no URL their elements load is on another host or missing from the
site, no ``$...$`` or Markdown table is left as text outside code, every internal link resolves.  The static checks
read every API page, the opened ones too.

and, at a desktop's and a phone's width (1280 x 800 and 390 x 844 CSS px), on every paper, control, reading-space
page, the arena and the home page (:func:`layout_problems`; the desktop's in the same visit of each page as the
checks above):

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
import html
import html.parser
import http.server
import importlib.util
import os
import re
import shutil
import socket
import subprocess
import sys
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
    with sync_playwright() as p, socket.socket() as nowhere:
        nowhere.bind(("127.0.0.1", 0))
        b = p.chromium.launch(executable_path=path, headless=True, args=CHROMIUM_FLAGS + [
            f"--proxy-server=http://127.0.0.1:{nowhere.getsockname()[1]}"])
        yield b
        b.close()


def pages(out: Path) -> list[str]:
    return sorted(p.relative_to(out).as_posix() for p in out.rglob("*.html")
                  if not p.relative_to(out).as_posix().startswith(("_static/", "_sources/")))


def ids_of(path: Path) -> set[str]:
    return set(re.findall(r'\sid="([^"]+)"', path.read_text(errors="replace")))


# typeset state of every math element Sphinx wrote (class "math notranslate"; MathJax's own output also uses class
# "math" inside) under a root: MathJax 2 leaves a script of type math/tex next to its output
_MATH_UNDER = """(root) => {
  const maths = Array.from(root.querySelectorAll('.math.notranslate'));
  const raw = maths.filter(m => !m.querySelector('script[type^="math/tex"]')).map(m => m.textContent.slice(0, 80));
  const errors = Array.from(root.querySelectorAll('.MathJax_Error, .mjx-merror, merror'))
                     .map(e => e.textContent.slice(0, 80));
  // an undefined macro is no error to MathJax (noUndefined): it is typeset in red, which its MathML records
  const undefined = Array.from(root.querySelectorAll('[data-mathml]'))
                         .filter(e => e.getAttribute('data-mathml').includes('mathcolor="red"'))
                         .map(e => e.textContent.slice(0, 80));
  errors.push(...undefined);
  return {count: maths.length, raw: raw, errors: errors};
}"""
MATH_STATE = f"() => ({_MATH_UNDER})(document)"
# the same for each page's formulas on a shared formula page (PageChecker.check_formulas): [[page, state], ...]
FORMULA_STATE = f"() => Array.from(document.querySelectorAll('[data-page]'), d => [d.dataset.page, ({_MATH_UNDER})(d)])"

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

#: LEFTOVER_TEXT's patterns, for the static checks (StaticPage)
DOLLARS = re.compile(r"\$[^$\s][^$]*\$")
PIPES = (re.compile(r"\|\s*-{3,}\s*\|"), re.compile(r"^\s*\|.*\|.*\|\s*$", re.M))

IMAGES = """() => Array.from(document.images).filter(i => !(i.complete && i.naturalWidth > 0))
                                     .map(i => i.getAttribute('src'))"""

# notebook pages: code cells folded (each behind a <details> toggle), no stderr output published
NOTEBOOK_STATE = """() => ({cells: document.querySelectorAll('div.cell').length,
  unfolded: Array.from(document.querySelectorAll('div.cell')).filter(c => !c.querySelector('details.hide')).length,
  stderr: Array.from(document.querySelectorAll('div.output.stderr'), e => e.textContent.slice(0, 80))})"""

PICTURES = "() => document.querySelectorAll('article picture').length"

VERDICT_TABLES = """() => Array.from(document.querySelectorAll('table')).filter(
  t => Array.from(t.querySelectorAll('th')).some(h => /verdict/i.test(h.textContent))).length"""


class PageChecker:
    """One browser context and page, at the desktop screen (``SCREENS[0]``), that visit the site's pages in turn (the
    HTTP cache and MathJax's compiled code shared between pages, as when a reader browses: half the time of a context
    per page), each page's problems attributed to it: every request, console message, page error and failed response
    is recorded under the page being checked.

    Requests are watched, not routed: Playwright turns Chromium's HTTP cache off in a context with a route ("Enabling
    routing disables http cache", its documentation: every page would fetch and compile MathJax and its fonts anew),
    so a request to another host is reported from the request event, and the browser's proxy (:func:`browser`, a port
    that refuses connections; 127.0.0.1 is never proxied) fails it at once."""

    def __init__(self, browser, base: str, out: Path):
        self.base, self.out, self.rel, self.problems = base, out, "", []
        #: what each page checked had: {page: problems}, and for the layout pages (:func:`is_layout_page`) the layout
        #: at the desktop screen, {page: (problems, number of <picture> figures)}
        self.problems_of: dict[str, list[str]] = {}
        self.layout: dict[str, tuple[list[str], int]] = {}
        self.formula_problems: list[str] = []
        self.context = browser.new_context(viewport=dict(zip(("width", "height"), SCREENS[0])))
        host = urlsplit(base).netloc
        self.page = self.context.new_page()
        self.page.on("request", lambda r: None if urlsplit(r.url).netloc == host or r.url.startswith(
            ("data:", "blob:", "about:")) else self.problems.append(f"{self.rel}: request to another host: {r.url}"))
        self.page.on("console", lambda m: self.problems.append(f"{self.rel}: console {m.type}: {m.text}")
                     if m.type == "error" else None)
        self.page.on("pageerror", lambda e: self.problems.append(f"{self.rel}: page error: {e}"))
        self.page.on("response", lambda r: self.problems.append(f"{self.rel}: {r.status} for {r.url}")
                     if r.status >= 400 and urlsplit(r.url).netloc == host else None)

    def check(self, rel: str) -> list[str]:
        """Every problem of page ``rel``, each a sentence naming the page.  A layout page's layout problems at the
        desktop screen go to :attr:`layout`, with a screenshot of its first screen when it is a paper or control page
        (the layout test's, checked here while the page is open rather than opened a second time)."""
        self.rel, first = rel, len(self.problems)
        page, base, out = self.page, self.base, self.out
        problems = self.open(rel)
        if page.evaluate("() => document.querySelectorAll('.math.notranslate').length"):
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
        if is_layout_page(rel):
            self.layout[rel] = (layout_problems(page, rel, require_box=rel.startswith("papers/")),
                                page.evaluate(PICTURES))
            if rel.startswith(("papers/", "controls/")):
                CHECK_DIR.mkdir(parents=True, exist_ok=True)     # the first screen, before the 4000 px one
                page.screenshot(path=str(CHECK_DIR / f"{Path(rel).stem}-{SCREENS[0][0]}.png"))
        if rel.startswith(("papers/", "controls/")):
            if page.evaluate(VERDICT_TABLES) == 0:
                problems.append(f"{rel}: no comparison table with a verdict column")
            CHECK_DIR.mkdir(parents=True, exist_ok=True)
            # the top 4000 px as a screen that tall shows them (the sticky sidebar drawn whole): a full-page capture
            # costs 2-4 times as much (seconds on a page a million px tall); the desktop screen back after
            page.set_viewport_size({"width": SCREENS[0][0], "height": 4000})
            page.screenshot(path=str(CHECK_DIR / f"{Path(rel).stem}.png"))
            page.set_viewport_size(dict(zip(("width", "height"), SCREENS[0])))
        hrefs = page.evaluate("() => Array.from(document.querySelectorAll('a[href]'), a => a.getAttribute('href'))")
        for href in hrefs:
            problems += link_problems(base, out, rel, href)
        self.problems_of[rel] = self.problems[first:] + problems
        return self.problems_of[rel]

    def open(self, rel: str) -> list[str]:
        """Open page ``rel`` and wait for its typesetting, if it has mathematics; a problem if MathJax fails to."""
        self.page.goto(self.base + rel, wait_until="load", timeout=60_000)
        if self.page.evaluate("() => document.querySelectorAll('.math.notranslate').length"):
            try:          # MathJax loaded, then everything queued before this callback (the page's typesetting) done
                self.page.wait_for_function("() => window.MathJax && window.MathJax.Hub && MathJax.isReady",
                                            timeout=60_000)
                self.page.evaluate("() => new Promise(done => MathJax.Hub.Queue(() => done(true)))")
            except Exception as exc:  # noqa: BLE001 -- reported with the page, the other checks still run
                return [f"{rel}: MathJax did not load or finish typesetting: {type(exc).__name__}"]
        return []

    def check_formulas(self, rels: list[str]) -> list[str]:
        """The formulas of pages ``rels`` (read by :class:`StaticPage`), typeset by the bundled MathJax on shared
        pages: the pages whose scripts and stylesheets are the same share one, made of the first one's HTML (its
        head: the site's MathJax and its configuration) with their formulas in its article, each page's in a ``<div
        data-page>``, written beside them as ``zz-formulas-<n>.html`` and removed after.  Each problem of a formula
        names the page it comes from; a console error, page error or failed request names the shared page."""
        groups: dict[tuple, list[str]] = {}
        for rel in rels:
            if static_page(str(self.out / rel)).formulas:
                groups.setdefault(tuple(static_page(str(self.out / rel)).scripts), []).append(rel)
        problems: list[str] = []
        for n, members in enumerate(groups.values()):
            shared = (Path(members[0]).parent / f"zz-formulas-{n}.html").as_posix()
            assert all(Path(r).parent == Path(shared).parent for r in members), members   # same relative URLs
            assert not (self.out / shared).exists(), shared                                # never a page of the site
            template = (self.out / members[0]).read_text()
            start = re.search(r"<article\b[^>]*>", template)
            assert start and template.count("</article>") == 1, members[0]
            body = "".join(f'<div data-page="{html.escape(rel)}">' + "".join(
                f'<{tag} class="{html.escape(cls)}">{html.escape(tex, quote=False)}</{tag}>'
                for tag, cls, tex in static_page(str(self.out / rel)).formulas) + "</div>" for rel in members)
            (self.out / shared).write_text(template[:start.end()] + body + template[template.index("</article>"):])
            try:
                self.rel, first = f"{shared} (the formulas of {len(members)} pages)", len(self.problems)
                problems += self.open(shared)
                typeset = dict(self.page.evaluate(FORMULA_STATE))
            finally:
                (self.out / shared).unlink()
            problems += self.problems[first:]
            for rel in members:
                got, want = typeset.get(rel, {"count": 0, "raw": [], "errors": []}), len(
                    static_page(str(self.out / rel)).formulas)
                if got["count"] != want:
                    problems.append(f"{rel}: {got['count']} of its {want} formulas on the formula page")
                problems += [f"{rel}: math not typeset: {t!r}" for t in got["raw"][:5]]
                problems += [f"{rel}: MathJax error: {t!r}" for t in got["errors"][:5]]
        return problems

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


def is_layout_page(rel: str) -> bool:
    """A page whose layout is checked: every paper, control and reading-space page, the arena and the home page."""
    return rel.startswith(("papers/", "controls/", "reading-spaces")) or rel in ("arena.html", "index.html")


@pytest.fixture(scope="module")
def desktop_visit(site, browser) -> PageChecker:
    """The pages of :func:`in_browser` opened once each, in turn, at the desktop screen: the browser test's checks of
    each page (:meth:`PageChecker.check`, its problems in ``problems_of``) and the layout test's at that screen
    (``layout``); then the other pages' formulas on shared pages (:meth:`PageChecker.check_formulas`, the problems in
    ``formula_problems``)."""
    out, base = site
    checker = PageChecker(browser, base, out)
    rels = pages(out)
    opened = in_browser(out, rels)
    for rel in opened:
        checker.check(rel)
    checker.formula_problems = checker.check_formulas([r for r in rels if r not in opened])
    checker.close()
    return checker


def test_layout_at_desktop_and_phone_widths(site, browser, desktop_visit):
    """Every paper, control and reading-space page, the arena and the home page at a desktop's and a phone's width:
    verdict columns on screen, figures legible or linked to full size, no sideways scrolling, each paper page's
    verdict box within the first screen; screenshots of the paper and control pages' first screens at both widths.
    The desktop's are checked in the browser test's visit of each page (:func:`desktop_visit`), the phone's here."""
    out, base = site
    rels = [r for r in pages(out) if is_layout_page(r)]
    assert any(r.startswith("papers/") for r in rels) and any(r.startswith("reading-spaces/") for r in rels)
    CHECK_DIR.mkdir(parents=True, exist_ok=True)
    assert sorted(desktop_visit.layout) == rels
    problems = [p for rel in rels for p in desktop_visit.layout[rel][0]]
    pictures = {(rel, SCREENS[0][0]): desktop_visit.layout[rel][1] for rel in rels}
    shots = [CHECK_DIR / f"{Path(rel).stem}-{SCREENS[0][0]}.png" for rel in rels
             if rel.startswith(("papers/", "controls/"))]
    for width, height in SCREENS[1:]:
        context = layout_context(browser, width, height)
        page = context.new_page()
        for rel in rels:
            open_for_layout(page, base + rel)
            problems += layout_problems(page, rel, require_box=rel.startswith("papers/"))
            pictures[rel, width] = page.evaluate(PICTURES)
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
    # the smallest paper page: the quickest to open six times
    rel = min((r for r in pages(out) if r.startswith("papers/")), key=lambda r: (out / r).stat().st_size)
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


class StaticPage(html.parser.HTMLParser):
    """A page's HTML as served, read without a browser (the API pages that :func:`in_browser` leaves out): the URLs
    its elements load (``loads``), its links, its code (``scripts``: each script's URL or text and each stylesheet, in
    order), its text outside code as LEFTOVER_TEXT reads it (``texts``), its formulas, and what would make it need a
    browser of its own (``needs_browser``)."""

    VOID = frozenset("area base br col embed hr img input link meta param source track wbr".split())
    #: where LEFTOVER_TEXT does not look for Markdown left as text
    NOT_TEXT_TAGS = frozenset("pre code script style".split())
    NOT_TEXT_CLASSES = frozenset("highlight MathJax MathJax_CHTML math".split())
    #: where MathJax 2 does not look for mathematics (tex2jax's skipTags)
    NOT_MATH_TAGS = frozenset("script noscript style textarea pre code annotation annotation-xml".split())
    #: what only a browser sees load or draw (and <base> or a <meta> refresh: URLs or a page not as read here)
    MEDIA = frozenset("img picture video audio iframe frame object embed canvas".split())
    #: the attributes by which an element other than a link (<a>, <area>) makes the browser load a URL
    LOADS = ("src", "href", "srcset", "data", "poster", "action", "xlink:href", "background")
    #: a formula whose effect reaches the formulas after it on its page (a macro, environment or operator defined,
    #: an extension loaded, a label or tag numbered): its page is typeset on its own, never beside other pages'
    REACHES = re.compile(r"\\(def|gdef|edef|xdef|let|newcommand|renewcommand|providecommand|newenvironment|"
                         r"renewenvironment|DeclareMathOperator|require|label|tag)(?![A-Za-z])")

    def __init__(self, text: str):
        super().__init__(convert_charrefs=True)
        self.stack: list[tuple[str, frozenset]] = []
        self.loads: list[str] = []
        self.links: list[str] = []
        self.scripts: list[str] = []
        self.texts: list[str] = []                       # text nodes outside code, in <article> (or <body>)
        self.formulas: list[tuple[str, str, str]] = []   # (tag, class, TeX), as written
        self.needs_browser: list[str] = []
        self._article = False
        self._body_texts: list[str] = []
        self._data: list[str] = []
        self._formula: list | None = None
        self.feed(text)
        self.close()
        self._flush()
        if not self._article:
            self.texts = self._body_texts

    def _flush(self) -> None:
        """One text node ends (at a tag or a comment): where it belongs."""
        text, self._data = "".join(self._data), []
        if not text or (self._formula is None and text.isspace()):
            return                                         # (no Markdown, no code: most text nodes)
        tags = {t for t, _ in self.stack}
        classes = frozenset().union(*(c for _, c in self.stack))
        if self._formula is not None:
            self._formula[2] += text
        elif tags & {"script", "style"}:
            self.scripts.append(f"{self.stack[-1][0]} {text}")
            if "url(" in text:
                self.needs_browser.append("a style with url()")
        elif not (tags & self.NOT_TEXT_TAGS or classes & self.NOT_TEXT_CLASSES):
            (self.texts if "article" in tags else self._body_texts).append(text)

    def handle_data(self, data: str) -> None:
        self._data.append(data)

    def handle_comment(self, data: str) -> None:
        self._flush()

    def handle_starttag(self, tag: str, attrs: list) -> None:
        self._flush()
        a = {k: v or "" for k, v in attrs}
        classes = frozenset(a.get("class", "").split())
        self._article |= tag == "article"
        if tag in ("a", "area") and "href" in a:
            self.links.append(a["href"])
        elif tag != "a":
            for k in self.LOADS:
                if k in a:
                    self.loads += [u.split()[0] for u in a[k].split(",") if u.strip()] if k == "srcset" else [a[k]]
        if tag == "script" and "src" in a:
            self.scripts.append(f"script src {a['src']}")
        if tag == "link" and "stylesheet" in a.get("rel", "").split():
            self.scripts.append(f"stylesheet {a.get('href', '')}")
        if tag in self.MEDIA or tag == "base" or (tag == "meta" and a.get("http-equiv", "").lower() == "refresh"):
            self.needs_browser.append(f"<{tag}>")
        if tag == "div" and "cell" in classes:
            self.needs_browser.append("a notebook cell")
        if "url(" in a.get("style", ""):
            self.needs_browser.append("a style attribute with url()")
        if {"math", "notranslate"} <= classes:
            if {t for t, _ in self.stack} & self.NOT_MATH_TAGS:
                self.needs_browser.append(f"a formula where MathJax does not look, in <{self.stack[-1][0]}>")
            self._formula = [tag, a["class"], ""]
        if tag not in self.VOID:
            self.stack.append((tag, classes))

    def handle_startendtag(self, tag: str, attrs: list) -> None:
        self.handle_starttag(tag, attrs)
        if tag not in self.VOID:
            self.handle_endtag(tag)

    def handle_endtag(self, tag: str) -> None:
        self._flush()
        if self._formula is not None and tag == self._formula[0]:
            self.formulas.append(tuple(self._formula))
            if self.REACHES.search(self._formula[2]):
                self.needs_browser.append(f"a formula that reaches the next ones: {self._formula[2][:60]!r}")
            self._formula = None
        for i in range(len(self.stack) - 1, -1, -1):      # an element left open closes with its parent
            if self.stack[i][0] == tag:
                del self.stack[i:]
                break


@functools.lru_cache(maxsize=None)
def static_page(path: str) -> StaticPage:
    return StaticPage(Path(path).read_text())


def in_browser(out: Path, rels: list[str]) -> list[str]:
    """The pages opened in the browser: every page outside api/ and the API's index; of the API's module pages
    (autodoc's, one template), the first in sorted order of each set of scripts and stylesheets, and each one that
    needs a browser of its own (an image or other media, a notebook cell, a style with url(), a formula where MathJax
    does not look or one whose effect reaches the next formulas: :class:`StaticPage`)."""
    opened, seen = [], set()
    for rel in rels:
        if not rel.startswith("api/") or rel == "api/index.html":
            opened.append(rel)
            continue
        page = static_page(str(out / rel))
        if page.needs_browser or tuple(page.scripts) not in seen:
            opened.append(rel)
        seen.add(tuple(page.scripts))
    return opened


def static_problems(base: str, out: Path, rel: str, page: StaticPage) -> list[str]:
    """The problems of page ``rel`` (read as ``page``) that its HTML shows: a URL loaded from another host or missing
    from the site, $...$ or a Markdown table left as text outside code, a broken link; each a sentence naming it."""
    problems = []
    for url in page.loads:
        full = urljoin(base + rel, url)
        if full.startswith(("data:", "blob:", "about:")):
            continue
        if not full.startswith(base):
            problems.append(f"{rel}: request to another host: {url}")
            continue
        target = out / unquote(urlsplit(full).path[len(urlsplit(base).path):])
        if not (target / "index.html" if target.is_dir() else target).is_file():
            problems.append(f"{rel}: loads {url}, which is not in the site")
    problems += [f"{rel}: $...$ left as text: {t.strip()[:80]!r}" for t in page.texts if DOLLARS.search(t)][:5]
    problems += [f"{rel}: Markdown table left as text: {t.strip()[:80]!r}" for t in page.texts
                 if any(p.search(t) for p in PIPES)][:5]
    for href in page.links:
        problems += link_problems(base, out, rel, href)
    return problems


def test_every_page_in_a_real_browser(site, desktop_visit):
    """Every page that can show a problem only a browser sees, opened in it (:func:`in_browser`: all but API module
    pages like one opened, whose formulas are typeset on a shared page and whose HTML is read), no problem on any."""
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
    # opened in the browser: every page but API module pages like one opened (at least half of those are read
    # statically: a check that the choice still leaves the browser the pages it should is the catch test's)
    opened = in_browser(out, rels)
    assert sorted(desktop_visit.problems_of) == opened
    assert [r for r in rels if r not in opened and not r.startswith("api/mmlib.")] == []
    problems = [p for rel in opened for p in desktop_visit.problems_of[rel]] + desktop_visit.formula_problems
    # every API page read (the pages opened too: the static checks agree with the browser there)
    problems += [p for rel in rels if rel.startswith("api/")
                 for p in static_problems(base, out, rel, static_page(str(out / rel)))]
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
    """The checks can fail: a real page of the site (MathJax loaded) with an external script (reported, and failed by
    the browser's proxy), a broken link and anchor, a missing image, raw $math$, an undefined TeX macro, a Markdown
    table left as text, an unfolded code cell and a stderr output injected is reported for each."""
    out, base = site
    # a page that loads MathJax, the one with the fewest formulas (the quickest to typeset)
    rel = min((r for r in pages(out) if r.startswith("api/") and static_page(str(out / r)).formulas),
              key=lambda r: len(static_page(str(out / r)).formulas))
    page = (out / rel).read_text()
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
                     "stderr output published: '  [x] 1/2 runs'",
                     # and the browser's proxy stopped it at once: it never left the machine
                     "console error: Failed to load resource: net::ERR_PROXY_CONNECTION_FAILED"):
        assert expected in text, (expected, text)


def test_the_static_checks_catch_what_they_look_for(site, browser):
    """The API pages read without a browser: the static checks report, on a real one of them with defects injected,
    an external script and stylesheet, a missing image file, a broken link and anchor, raw $math$ and a Markdown
    table left as text; a page with an image, a notebook cell, a formula in code, a formula defining a macro or a
    script of its own is opened in the browser instead; and the shared formula page names the page of an undefined
    macro and of a TeX error, and nothing of a page whose formulas are fine."""
    out, base = site
    rels = pages(out)
    static = [r for r in rels if r not in in_browser(out, rels)]
    rel = next(r for r in static if static_page(str(out / r)).formulas)         # a page with formulas, read
    real = (out / rel).read_text()
    assert real.count("</article>") == 1 and not static_problems(base, out, rel, StaticPage(real))

    def page(extra: str) -> str:
        return real.replace("</article>", extra + "</article>")

    defects = ('<p>see $x_k$ here</p><p>| a | b |\n|---|---|</p><a href="nowhere.html">x</a>'
               '<a href="../index.html#no-such-id">y</a><script src="https://cdn.example.org/x.js"></script>'
               '<link rel="stylesheet" href="//cdn.example.org/x.css"><source srcset="../_images/none.png 2x">')
    text = "\n".join(static_problems(base, out, rel, StaticPage(page(defects))))
    for expected in ("request to another host: https://cdn.example.org/x.js",
                     "request to another host: //cdn.example.org/x.css", "broken link 'nowhere.html'",
                     "no element #no-such-id", "loads ../_images/none.png, which is not in the site",
                     "$...$ left as text: 'see $x_k$ here'", "Markdown table left as text: '| a | b |"):
        assert expected in text, (expected, text)
    # what needs a browser goes to one: each variant, written beside the real page, is among the pages opened
    math = '<span class="math notranslate nohighlight">\\({}\\)</span>'
    variants = {"img": '<img src="../_static/favicon.svg">', "cell": '<div class="cell docutils container"></div>',
                "code": f"<pre>{math.format('x')}</pre>", "macro": math.format("\\newcommand{\\R}{x} \\R"),
                "script": "<script>document.title = 'x'</script>"}
    written = [out / "api" / f"zz-needs-{name}.html" for name in variants]
    try:
        for path, extra in zip(written, variants.values()):
            path.write_text(page(extra))
        opened = in_browser(out, pages(out))
    finally:
        for path in written:
            path.unlink()
    assert [p.name for p in written if f"api/{p.name}" not in opened] == []
    assert rel not in opened
    # the shared formula page: an undefined macro and a TeX error, each named with its page; a good page not named
    bad, good = out / "api" / "zz-bad-formulas.html", out / "api" / "zz-good-formulas.html"
    bad.write_text(page(math.format("\\undefinedmacro x") + math.format("\\frac{1}{")))
    good.write_text(real)
    checker = PageChecker(browser, base, out)
    try:
        found = checker.check_formulas(["api/zz-bad-formulas.html", "api/zz-good-formulas.html"])
    finally:
        checker.close()
        bad.unlink()
        good.unlink()
    text = "\n".join(found)
    assert "api/zz-bad-formulas.html: MathJax error: '\\\\undefinedmacro" in text, text
    assert "api/zz-bad-formulas.html: MathJax error: '\\\\frac{1}{'" in text, text
    assert not [p for p in found if p.startswith("api/zz-good-formulas.html")], text


#: the most lines of text a cell of an executed notebook may show: a reader scrolls a page of narration, tables and
#: figures (the longest, the arena's scenario list, is a few hundred lines); a dump of a results document (tens of
#: thousands of lines, the site's page a million pixels tall) belongs in data/results/, not on the page
MAX_CELL_OUTPUT_LINES = 1000


def _output_lines(output: dict) -> int:
    """The lines of text one output of a notebook cell shows: its stream text, or the longest of its text/*
    representations (a frontend shows one of them)."""
    texts = ["".join(output.get("text", ""))] + ["".join(v) for k, v in output.get("data", {}).items()
                                                  if k.startswith("text/")]
    return max(len(t.splitlines()) for t in texts)


def test_committed_notebooks_are_fit_to_publish():
    """The committed executed notebooks hold no stderr output (progress goes to the runner's log), no path of
    the machine that ran them, and no cell showing more than :data:`MAX_CELL_OUTPUT_LINES` lines of text."""
    import json
    executed = sorted((REPO / "notebooks" / "executed").glob("*.ipynb"))
    assert [p.stem for p in executed] == sorted(p.stem for p in (REPO / "notebooks").glob("*.py"))
    for path in executed:
        text = path.read_text()
        nb = json.loads(text)
        stderr = [i for i, c in enumerate(nb["cells"]) for o in c.get("outputs", []) if o.get("name") == "stderr"]
        assert not stderr, f"{path.name}: stderr output in cells {stderr}"
        long = {i: n for i, c in enumerate(nb["cells"])
                if (n := sum(_output_lines(o) for o in c.get("outputs", []))) > MAX_CELL_OUTPUT_LINES}
        assert not long, f"{path.name}: cells showing more than {MAX_CELL_OUTPUT_LINES} lines: {long}"
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


def test_the_sphinx_process_leaves_out_the_imports_the_runner_leaves_out():
    """docs/conf.py, run first in the site's Sphinx process, leaves out every import the notebook runner leaves out
    (tools/run_notebooks.py ``SKIPPED_IMPORTS``, read from its source: rfc3987_syntax, jsonschema's optional "iri"
    format checker, seconds of grammar compiling), so MyST-NB's nbformat imports and validates without them; the
    control, a process that does not run docs/conf.py, imports rfc3987_syntax wherever it is installed."""
    import ast
    tree = ast.parse((REPO / "tools" / "run_notebooks.py").read_text())
    skipped = next(ast.literal_eval(node.value) for node in tree.body if isinstance(node, ast.Assign)
                   and any(getattr(t, "id", "") == "SKIPPED_IMPORTS" for t in node.targets))
    assert "rfc3987_syntax" in skipped
    code = (f"import runpy, sys; runpy.run_path({str(REPO / 'docs' / 'conf.py')!r}); import myst_nb, nbformat; "
            "nbformat.validate(nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell('1')])); "
            f"print(sorted(n for n in {tuple(skipped)!r} if sys.modules.get(n, 0) is not None), "
            "'jsonschema' in sys.modules)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=REPO)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split()[-2:] == ["[]", "True"], proc.stdout
    if importlib.util.find_spec("rfc3987_syntax") is not None:
        plain = subprocess.run([sys.executable, "-c", "import nbformat, sys; print('rfc3987_syntax' in sys.modules)"],
                               capture_output=True, text=True, timeout=120, check=True)
        assert plain.stdout.strip() == "True"


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


def test_the_bundled_mathjax_is_found_without_importing_its_package():
    """The site copies jupyter-server-mathjax's static/ folder, found without importing the package (which loads
    jupyter_server); a missing package or folder is a SiteError naming it."""
    builder = load_builder()
    folder = builder._package_data("jupyter_server_mathjax", "static")
    assert (folder / "MathJax.js").is_file() or any(folder.rglob("MathJax.js")), folder
    with pytest.raises(builder.SiteError, match="no_such_package_xyz is not installed"):
        builder._package_data("no_such_package_xyz", "static")
    with pytest.raises(builder.SiteError, match="json has no no_such_folder/ folder"):
        builder._package_data("json", "no_such_folder")
