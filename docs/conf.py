"""Sphinx configuration of the mmlib site (built by tools/build_site.py, `make site`).

The builder assembles the page sources in build/.site-work/src/ (this folder's pages, the executed notebooks, the
generated summary, reading-space and API pages) and runs Sphinx there with this file as its configuration.

Offline by construction: MathJax comes from the jupyter-server-mathjax wheel and is copied into _static/ (no CDN);
the theme (furo) ships its own assets and uses system fonts; MyST-NB's widget JavaScript, which loads from a CDN,
is switched off (the notebooks hold no widgets).
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

REPO = Path(os.environ.get("MMLIB_SITE_REPO", Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(REPO))
# MyST-NB imports nbformat, and that jsonschema, which would import rfc3987_syntax and compile its grammars (seconds)
# for format checks no schema here uses: left out as in the notebook runner (tools/run_notebooks.py SKIPPED_IMPORTS)
sys.modules.setdefault("rfc3987_syntax", None)

import mmlib  # noqa: E402

project = "mmlib"
author = "the mmlib replication maintainers"
copyright = "2026, " + author
release = version = mmlib.__version__

extensions = ["myst_nb", "sphinx.ext.autodoc", "sphinx.ext.mathjax"]
source_suffix = {".md": "myst-nb", ".ipynb": "myst-nb"}
# _includes: files other pages include (the README), not pages of their own
exclude_patterns = ["_build", "_includes", "**.ipynb_checkpoints"]

# --- notebooks: rendered from their stored outputs, never re-executed here (make figures executes them)
nb_execution_mode = "off"
nb_render_markdown_format = "myst"      # the notebooks' Markdown outputs hold tables and $math$
nb_ipywidgets_js = {}                   # would load require.js and the widget manager from a CDN
nb_merge_streams = True
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence"]
myst_heading_anchors = 3
myst_dmath_double_inline = True

# --- API reference from the docstrings
# "bysource" is the order of a module's __all__ when it has one (its public API in order of importance; autodoc then
# documents exactly the names of __all__), the source order otherwise (tests/test_public_api_experiment.py)
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_mock_imports: list[str] = []

# --- offline mathematics: a bundled MathJax 2.7 (relative to _static/).  That bundle (the one the Jupyter server
mathjax_path = "mathjax/MathJax.js?config=TeX-AMS-MML_HTMLorMML-full"
# ships) carries the STIX-Web fonts only, so the HTML-CSS output is told to use them and not to look for others; its
# blank measuring font, declared at url('about:blank'), is declared local instead (Chromium refuses a font from
# about:blank with a console error)
_STIX = {"availableFonts": [], "preferredFont": None, "webFont": "STIX-Web", "imageFont": None,
         "styles": {"@font-face": {"font-family": "MathJax_Blank", "src": "local('MathJax_Blank')"}}}
mathjax2_config = {"tex2jax": {"inlineMath": [["\\(", "\\)"]], "displayMath": [["\\[", "\\]"]],
                               "processEscapes": True,
                               # Sphinx marks the page body tex2jax_ignore and its math elements "math" (the
                               # MathJax 3 convention); MathJax 2 is told the same through its class lists
                               "ignoreClass": "tex2jax_ignore|mathjax_ignore",
                               "processClass": "tex2jax_process|mathjax_process|math|output_area"},
                   "HTML-CSS": _STIX, "SVG": {"font": "STIX-Web"}, "showMathMenu": False, "messageStyle": "none",
                   "MathMenu": {"showFontMenu": False}, "menuSettings": {"zoom": "None"}}

html_theme = "furo"
html_title = f"mmlib {release}: five tracking papers, re-run and checked"
# docs/_static, the results contract's JSON Schema (served as _static/results.schema.json: the file of the package,
# never a copy that could drift) and the folder holding the bundled MathJax that the builder stages (as mathjax/)
html_static_path = ["_static", str(REPO / "mmlib" / "experiment" / "results.schema.json"),
                    *filter(None, [os.environ.get("MMLIB_SITE_MATHJAX")])]
html_css_files = ["site.css"]
html_favicon = "_static/favicon.svg"
html_show_sourcelink = False
html_copy_source = False
html_last_updated_fmt = None
pygments_style = "sphinx"
