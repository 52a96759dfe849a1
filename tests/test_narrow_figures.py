"""A figure's narrow variant (issue 26: on a phone a figure with panels side by side shows its panels stacked):
:func:`mmlib.experiment.writing.narrow_image` cuts each panel out with everything it draws and stacks them row by
row, redraws the figure-level texts and legends at a panel's width, leaves the caller's figure alone and gives the
same bits twice; :func:`~mmlib.experiment.writing.save_figure` writes it beside the PNG and SVG (and removes a stale
one); the committed figures with panels side by side have theirs."""
from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.image  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from mmlib.experiment.writing import FIGURE_DPI, NARROW_SUFFIX, narrow_image, save_figure  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
#: one pure colour per panel (RGB, 0-255): found again in the narrow image, each panel's rows tell its place
COLOURS = [(255, 0, 0), (0, 160, 0), (0, 0, 255), (255, 0, 255)]


def _panels(nrows: int, ncols: int, *, suptitle: str = "", legend_entries: int = 0, colorbar: bool = False,
            polar_last: bool = False, secondary: bool = False):
    """A figure of nrows x ncols panels, panel i filled with COLOURS[i] (row by row), labelled, with options."""
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.5 * ncols, 3.2 * nrows), squeeze=False)
    axes = list(axes.ravel())
    if polar_last:                      # as tseng2011's satellite sky plot: a panel replaced by a polar axes
        axes[-1].remove()
        axes[-1] = fig.add_subplot(nrows, ncols, nrows * ncols, projection="polar")
    for i, ax in enumerate(axes):
        ax.axvspan(0.2, 0.8, color=np.array(COLOURS[i]) / 255)
        ax.set(xlim=(0, 1), xlabel="time (s)", ylabel="error (m)", title=f"panel {i}")
    if secondary:                       # as the arena's ladder: a second x axis on top, by functions (not picklable)
        axes[0].secondary_xaxis("top", functions=(lambda x: 2 * x, lambda x: x / 2)).set_xlabel("other (m)")
    if colorbar:
        im = axes[0].imshow(np.arange(4.0).reshape(2, 2), extent=(0, 0.1, 0, 0.1), cmap="Greys")
        fig.colorbar(im, ax=axes[0], label="bound (m)")
    if legend_entries:
        lines = [axes[0].plot([], [], label=f"algorithm {k}")[0] for k in range(legend_entries)]
        fig.legend(lines, [ln.get_label() for ln in lines], loc="lower center", ncol=legend_entries, frameon=False)
    if suptitle:
        fig.suptitle(suptitle)
    fig.tight_layout(rect=(0, 0.08 if legend_entries else 0, 1, 1))
    return fig


def _rows_of(image: np.ndarray, colour) -> np.ndarray:
    """The rows of ``image`` holding pixels of exactly ``colour``."""
    return np.where(np.all(image[..., :3] == np.array(colour, np.uint8), axis=-1).any(axis=1))[0]


def _ink_rows(image: np.ndarray) -> np.ndarray:
    """The rows of ``image`` with a dark pixel (text, lines)."""
    return np.where((image[..., :3].astype(int).sum(axis=-1) < 300).any(axis=1))[0]


@pytest.mark.parametrize("shape", [(1, 2), (1, 3), (2, 2)])
def test_panels_side_by_side_are_stacked_row_by_row(shape):
    fig = _panels(*shape, colorbar=True, polar_last=shape == (1, 3), secondary=shape == (1, 2))
    wide = fig.get_size_inches() * FIGURE_DPI
    image = narrow_image(fig)
    n = shape[0] * shape[1]
    assert image is not None and image.dtype == np.uint8 and image.shape[2] == 4
    # about one panel wide (the widest panel, colorbar included) and n panels high
    assert image.shape[1] < 0.75 * wide[0] and image.shape[1] < 1.6 * wide[0] / shape[1]
    assert image.shape[0] > 0.8 * n * wide[1] / shape[0]
    rows = [_rows_of(image, COLOURS[i]) for i in range(n)]
    assert all(r.size for r in rows), "a panel is missing"
    for above, below in zip(rows, rows[1:]):               # in order, none overlapping the next
        assert above.max() < below.min()
    plt.close(fig)


@pytest.mark.parametrize("shape", [(1, 1), (2, 1), (3, 1)])
def test_a_figure_in_one_column_has_no_narrow_variant(shape):
    fig = _panels(*shape, suptitle="one column")
    assert narrow_image(fig) is None
    plt.close(fig)


def test_suptitle_and_legend_are_redrawn_at_a_panels_width():
    title = "Fig. 13 - a suptitle much longer than one panel is wide, as the papers' figures have, wrapped here"
    fig = _panels(1, 3, suptitle=title, legend_entries=9)
    image = narrow_image(fig)
    for artist in (*fig.texts, *fig.legends):                 # the same panels, without the figure-level artists
        artist.set_visible(False)
    bare = narrow_image(fig)
    assert image.shape[1] == bare.shape[1]                    # no wider than the panels: wrapped, fewer columns
    ink, first, last = _ink_rows(image), _rows_of(image, COLOURS[0]).min(), _rows_of(image, COLOURS[2]).max()
    head = image[:first - int(0.5 * FIGURE_DPI)]             # above the first panel's title and frame
    assert _ink_rows(head).size > 0.15 * FIGURE_DPI          # two lines of title at least: wrapped
    assert ink.max() > last + 0.3 * FIGURE_DPI               # the legend under the last panel
    assert image.shape[0] > bare.shape[0] + 0.4 * FIGURE_DPI
    plt.close(fig)


ORANGE, CYAN = (255, 128, 0), (0, 200, 200)


@pytest.mark.parametrize("width_in", [6.56, 13.62])
def test_any_figure_width_and_the_users_savefig_settings(width_in):
    """Widths where matplotlib's pixel rounding differs from int(width x dpi), under a style that saves tight and
    transparent: the same panels, in order."""
    with matplotlib.rc_context({"savefig.bbox": "tight", "savefig.transparent": True}):
        fig = _panels(1, 2)
        fig.set_size_inches(width_in, 3.5)
        image = narrow_image(fig)
    rows = [_rows_of(image, COLOURS[i]) for i in range(2)]
    assert rows[0].size and rows[1].size and rows[0].max() < rows[1].min()
    assert (image[..., 3] == 255).all()                       # opaque: the page's background never shows through
    plt.close(fig)


def test_what_reaches_out_of_the_figure_is_kept():
    """A legend placed outside the last panel (no layout engine to pull it in) is in the narrow image, as it is in
    the saved PNG (tight box)."""
    from matplotlib.patches import Patch
    fig = _panels(1, 2)
    fig.axes[1].legend(handles=[Patch(facecolor=np.array(ORANGE) / 255, label="outside")],
                       bbox_to_anchor=(1.02, 1.0), loc="upper left", handlelength=4, handleheight=3)
    assert _rows_of(narrow_image(fig), ORANGE).size
    plt.close(fig)


def test_figure_level_texts_are_drawn_once_outside_the_panels():
    """Under a constrained layout, a supxlabel (large, in a colour of its own) appears once, below the panels, and
    never inside a panel's cut; the figure's layout engine is left as it was."""
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.5), layout="constrained")
    for i, ax in enumerate(axes):
        ax.axvspan(0.2, 0.8, color=np.array(COLOURS[i]) / 255)
        ax.set(xlim=(0, 1), title=f"panel {i}")
    fig.supxlabel("COMMON", fontsize=40, fontweight="bold", color=np.array(CYAN) / 255)
    engine = fig.get_layout_engine()
    image = narrow_image(fig)
    cyan, last = _rows_of(image, CYAN), _rows_of(image, COLOURS[1]).max()
    assert cyan.size and cyan.min() > last, "the supxlabel inside a panel's cut, or missing"
    assert fig.get_layout_engine() is engine and fig.texts[0].get_visible()
    plt.close(fig)


def test_a_neighbours_label_reaching_into_a_panel_stays_with_its_own_panel():
    """As the arena's ladder: the left panel's long x label (in a colour of its own) reaches under the right panel;
    it is in the first panel's cut only."""
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.5))
    for i, ax in enumerate(axes):
        ax.axvspan(0.2, 0.8, color=np.array(COLOURS[i]) / 255)
        ax.set(xlim=(0, 1))
    axes[0].set_xlabel("a long label " * 6, fontsize=16, fontweight="bold", color=np.array(CYAN) / 255)
    fig.subplots_adjust(wspace=0.3)
    image = narrow_image(fig)
    assert _rows_of(image, CYAN).size
    assert _rows_of(image, CYAN).max() < _rows_of(image, COLOURS[1]).min()     # none in the second panel's cut
    plt.close(fig)


def test_a_figure_legend_keeps_its_markers():
    """A figure legend of errorbars redrawn with the axes' own artists: their markers (a colour of their own) are
    in the legend under the panels, not only lines."""
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.5))
    for ax in axes:
        ax.errorbar([0.1, 0.5], [0.1, 0.5], yerr=0.05, marker="s", ms=14, mfc=np.array(ORANGE) / 255,
                    mec=np.array(ORANGE) / 255, color="k", label="algorithm")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=1)
    fig.tight_layout(rect=(0, 0.15, 1, 1))
    image = narrow_image(fig)
    fig.legends[0].set_visible(False)
    bare = narrow_image(fig)                                  # the same panels, no foot
    assert np.array_equal(image[:bare.shape[0]], bare)
    assert _rows_of(image[bare.shape[0]:], ORANGE).size, "no marker in the legend"
    plt.close(fig)


def test_a_legend_title_is_kept():
    fig = _panels(1, 2, legend_entries=2)
    fig.legends[0].set_title("TITLE")
    titled = narrow_image(fig)
    fig.legends[0].set_title("")
    assert titled.shape[0] > narrow_image(fig).shape[0] + 0.1 * FIGURE_DPI
    plt.close(fig)


def test_the_callers_figure_is_left_alone_and_the_bits_repeat(tmp_path):
    fig = _panels(1, 2, suptitle="title", legend_entries=2)
    figures = plt.get_fignums()
    dpi, canvas, size = fig.dpi, fig.canvas, tuple(fig.get_size_inches())
    before = tmp_path / "before.png"
    fig.savefig(before, dpi=FIGURE_DPI, metadata={"Software": None})
    first, second = narrow_image(fig), narrow_image(fig)
    after = tmp_path / "after.png"
    fig.savefig(after, dpi=FIGURE_DPI, metadata={"Software": None})
    assert fig.dpi == dpi and fig.canvas is canvas and tuple(fig.get_size_inches()) == size
    assert plt.get_fignums() == figures                       # no second figure for pyplot (or Jupyter) to show
    assert before.read_bytes() == after.read_bytes()
    assert np.array_equal(first, second)
    plt.close(fig)


def test_save_figure_writes_the_narrow_variant_and_removes_a_stale_one(tmp_path):
    fig = _panels(1, 2)
    paths = save_figure(fig, tmp_path, "fig01")
    assert [Path(p).name for p in paths] == ["fig01.png", "fig01.svg", "fig01" + NARROW_SUFFIX]
    saved = matplotlib.image.imread(paths[-1])
    assert saved.shape[:2] == narrow_image(fig).shape[:2]
    again = save_figure(fig, tmp_path / "again", "fig01")
    assert Path(again[-1]).read_bytes() == Path(paths[-1]).read_bytes()          # deterministic file
    single = _panels(1, 1)
    assert [Path(p).name for p in save_figure(single, tmp_path, "fig01")] == ["fig01.png", "fig01.svg"]
    assert not (tmp_path / ("fig01" + NARROW_SUFFIX)).exists()                    # the stale one removed
    assert [Path(p).name for p in save_figure(fig, tmp_path, "fig02", narrow=False)] == ["fig02.png", "fig02.svg"]
    assert sorted(p.name for p in tmp_path.iterdir() if p.is_file()) == ["fig01.png", "fig01.svg", "fig02.png",
                                                                          "fig02.svg"]
    for f in (fig, single):
        plt.close(f)


def test_committed_figures_with_panels_side_by_side_have_a_narrow_variant():
    """Every committed figure listing a narrow variant has the file, narrower and taller than its PNG; and the
    figures known to have panels side by side (the controls' two panels, tseng2011's three) list one."""
    listed = {}
    for path in sorted((REPO / "data" / "results").glob("*.json")):
        for stem, fig in json.loads(path.read_text())["figures"].items() if "figures" in json.loads(
                path.read_text()) else []:
            listed[f"{path.stem}/{stem}"] = fig["files"]
    narrow = {k: [f for f in v if f.endswith(NARROW_SUFFIX)] for k, v in listed.items()}
    for key, files in narrow.items():
        for f in files:
            png = next(g for g in listed[key] if g.endswith(".png") and not g.endswith(NARROW_SUFFIX))
            small, big = matplotlib.image.imread(REPO / f), matplotlib.image.imread(REPO / png)
            assert small.shape[1] < big.shape[1] and small.shape[0] > big.shape[0], key
    assert narrow["controls/fig01_controls"] and narrow["tseng2011/reconstruction_fuzzy_membership_functions"]
    assert not narrow["tseng2011/fig15_rms_errors"]                 # two panels, one above the other
