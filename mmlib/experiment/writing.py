"""Writing the outputs: a results file with its provenance, text files and figures, each atomically.

:func:`write_results` writes ``data/results/<paper>.json`` after checking it against the results contract
(:mod:`mmlib.experiment.results`, whose :func:`~mmlib.experiment.results.read_results` is the one reader);
:func:`provenance` is that file's ``provenance`` object; :func:`atomic_write_text` writes any text file so that it is
never half-written (the grid cache, the reports, the notebook runner's journal); :func:`save_figure` writes a figure
as deterministic PNG and SVG (and a figure with panels side by side as a narrow PNG, its panels stacked:
:func:`narrow_image`).  The rows written are the verdict rule's (:mod:`mmlib.experiment.verdicts`).
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, Mapping, Sequence

import numpy as np

from mmlib.core._validate import check_scalar
from mmlib.experiment import results, verdicts
from mmlib.experiment.verdicts import Row

__all__ = [
    "write_results", "save_figure", "narrow_image", "NARROW_SUFFIX", "FIGURE_DPI", "provenance", "git_commit",
    "atomic_write_text"
]

if TYPE_CHECKING:
    import matplotlib.figure


def git_commit(repo: Path | None = None) -> str:
    """The commit checked out in ``repo`` (default: the current folder), with ``-dirty`` appended when tracked
    files other than the generated outputs (data, figures, executed notebooks, reports) are modified;
    ``"unknown"`` outside a git checkout or without git."""
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                             cwd=repo, check=True).stdout.strip()
        # generated outputs (promoted notebook by notebook) do not make the code "dirty"
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", ".",
                                ":(exclude)data", ":(exclude)figures", ":(exclude)notebooks/executed",
                                ":(exclude)reports"],
                               capture_output=True, text=True, cwd=repo).stdout.strip()
        return out + ("-dirty" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def _version(package: str):
    try:
        from importlib.metadata import version
        return version(package)
    except Exception:          # noqa: BLE001 -- not installed: recorded as None
        return None


def provenance(*, root_seed: int, n_runs: int, profile: str, extra: dict | None = None) -> dict:
    """The ``provenance`` object of a results file: mmlib's git commit (:func:`git_commit`), ``root_seed``,
    ``n_runs``, ``profile``, the Python and package versions and the linear-algebra kernel, updated with
    ``extra``.  ``root_seed`` an integer >= 0, ``n_runs`` an integer >= 1, ``profile`` a string, ``extra`` None or
    a dict with string keys."""
    for value, arg, low in ((root_seed, "root_seed", 0), (n_runs, "n_runs", 1)):
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < low:
            raise ValueError(f"{arg}: expected an integer >= {low}, got {value!r}")
    if not isinstance(profile, str):
        raise ValueError(f"profile: expected a string, got {profile!r}")
    if extra is not None and (not isinstance(extra, Mapping) or not all(isinstance(k, str) for k in extra)):
        raise ValueError(f"extra: expected None or a dict with string keys, got {extra!r}")
    import matplotlib
    import scipy
    from mmlib.core.linalg import kernel
    info = {
        "git_commit": git_commit(Path(__file__).resolve().parent.parent),
        "root_seed": int(root_seed),
        "n_runs": int(n_runs),
        "profile": profile,
        "python": sys.version.split()[0],
        "packages": {"numpy": np.__version__, "scipy": scipy.__version__,
                     "matplotlib": matplotlib.__version__, "numba": _version("numba")},
        "kernel": kernel(),
    }
    info.update(extra or {})
    return info


def _jsonable(obj):
    if isinstance(obj, (np.floating, np.integer, np.bool_)):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Row):
        return asdict(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def atomic_write_text(path: Path, text: str, *, durable: bool = False) -> None:
    """Write via a temporary file in the same folder and ``os.replace``: never half-written.  ``durable``:
    also flushed to disk (the file before the rename, the folder after it), so that it survives a crash
    once this returns (the notebook runner's promotion journal)."""
    if not isinstance(text, str):
        raise ValueError(f"text: expected a string, got {type(text).__name__}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
            if durable:
                fh.flush()
                os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise
    if durable:
        dir_fd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(dir_fd)
        finally:
            os.close(dir_fd)


def _as_row(r, i: int) -> Row:
    """A row of ``rows``: a :class:`Row`, or a mapping of its fields (``distance`` optional)."""
    if isinstance(r, Row):
        return r
    if not isinstance(r, Mapping):
        raise ValueError(f"rows[{i}]: expected a Row (verdicts.make_row) or a mapping of its fields, got {r!r}")
    fields = list(Row.__dataclass_fields__)
    missing = [k for k in fields if k not in r and k not in ("note", "distance")]
    if missing:
        raise ValueError(f"rows[{i}]: lacks {', '.join(missing)}")
    if not set(r) <= set(fields):
        raise ValueError(f"rows[{i}]: keys {sorted(set(r) - set(fields))} are not fields of a Row")
    return Row(**r)


def write_results(path: str | Path, *, paper: str, provenance: dict, rows: Iterable[Row | Mapping[str, Any]],
                  **sections: Any) -> dict:
    """Write ``data/results/<paper>.json`` atomically, after checking it against the results contract
    (:func:`mmlib.experiment.results.validate_results`): a document that breaks it, or holds a NaN or an infinity,
    is a ValueError naming ``path`` and the JSON path of the first problem, and nothing is written.  The rows are
    joint-tested on the way (:func:`mmlib.experiment.verdicts.joint_tests`: a reproduced cell of a failing table or
    row is written *reproduced (isolated)*), and the sections ``rule`` (the rule's stated assumptions) and
    ``joint_tests`` are added."""
    try:
        judged, tests = verdicts.joint_tests([_as_row(r, i) for i, r in enumerate(rows)])
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    rows = [asdict(r) for r in judged]
    sections = {"rule": verdicts.rule(), "joint_tests": tests, **sections}
    doc = {"paper": paper, "provenance": provenance, "rows": rows, **sections}
    plain = json.loads(json.dumps(doc, default=_jsonable))          # numpy values and Rows as plain JSON
    try:
        results.validate_results(plain)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    text = json.dumps(plain, indent=1, allow_nan=False, sort_keys=False)
    atomic_write_text(Path(path), text + "\n")
    return doc


#: the file name ending of a figure's narrow variant (:func:`narrow_image`), shown on a phone's screen by the site
NARROW_SUFFIX = ".narrow.png"
#: the resolution of the saved PNG figures and of their narrow variants (dots per inch)
FIGURE_DPI = 150


def save_figure(fig: matplotlib.figure.Figure, out_dir: str | Path, stem: str,
                formats: Sequence[str] = ("png", "svg"), narrow: bool = True) -> list[str]:
    """Save a figure as PNG and SVG (deterministic SVG ids, no date), atomically per file.  ``formats``: a sequence
    of matplotlib format names (a bare string is refused, never split into letters).  ``narrow``: a figure with
    panels side by side also gets ``<stem>.narrow.png`` (:data:`NARROW_SUFFIX`), its panels stacked in one column
    (:func:`narrow_image`), for a phone's screen; a figure in one column gets none (an older one is removed).
    Returns the paths written, the narrow variant last."""
    import matplotlib
    import matplotlib.figure
    import matplotlib.image
    if not isinstance(fig, matplotlib.figure.Figure):
        raise ValueError(f"fig: expected a matplotlib Figure, got {type(fig).__name__}")
    if not isinstance(out_dir, (str, os.PathLike)):
        raise ValueError(f"out_dir: expected a folder path, got {out_dir!r}")
    if not isinstance(stem, str) or not stem or "/" in stem or any(c.isspace() for c in stem):
        raise ValueError(f"stem: expected a file name without folder, extension or spaces, got {stem!r}")
    if isinstance(formats, (str, bytes)) or not hasattr(formats, "__iter__"):
        raise ValueError(f"formats: expected a sequence of format names such as ('png', 'svg'), got {formats!r}")
    if not isinstance(narrow, bool):
        raise ValueError(f"narrow: expected True or False, got {narrow!r}")
    formats = list(formats)
    supported = fig.canvas.get_supported_filetypes()
    for fmt in formats:
        if fmt not in supported:
            raise ValueError(f"formats: unknown format {fmt!r}; supported: {', '.join(sorted(supported))}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    with matplotlib.rc_context({"svg.hashsalt": "mmlib", "svg.fonttype": "none"}):
        for fmt in formats:
            written.append(_atomic_save(out_dir, f"{stem}.{fmt}", lambda tmp, fmt=fmt: fig.savefig(
                tmp, format=fmt, dpi=FIGURE_DPI, bbox_inches="tight",
                metadata={"Date": None} if fmt == "svg" else {"Software": None})))
    image = narrow_image(fig) if narrow else None
    if image is not None:
        written.append(_atomic_save(out_dir, stem + NARROW_SUFFIX, lambda tmp: matplotlib.image.imsave(
            tmp, image, format="png", metadata={"Software": None})))
    elif narrow:
        (out_dir / (stem + NARROW_SUFFIX)).unlink(missing_ok=True)
    return written



def _atomic_save(out_dir: Path, name: str, save) -> str:
    """``save(tmp)`` writes a temporary file beside ``out_dir / name``, then moved onto it (never half-written)."""
    target = out_dir / name
    fd, tmp = tempfile.mkstemp(dir=out_dir, prefix=f".{name}.", suffix=target.suffix)
    os.close(fd)
    try:
        save(tmp)
        os.replace(tmp, target)
    except BaseException:
        os.unlink(tmp)
        raise
    return str(target)


def narrow_image(fig: matplotlib.figure.Figure, dpi: float = FIGURE_DPI) -> np.ndarray | None:
    """The figure's panels stacked in one column, for a screen narrower than the figure: an RGBA image
    (``(height, width, 4)`` uint8, ``dpi`` dots per inch), or None when the panels already are in one column (or the
    figure holds what cannot be moved: subfigures, figure-level artists other than texts and legends).

    A panel is every axes in one cell of the figure's topmost grid (a colorbar or a twin goes with its axes; an axes
    placed by hand, or a colorbar shared by several panels, with the panel nearest to it), drawn alone at ``dpi``
    (the other panels hidden, the layout held: a neighbour's label reaching into its box is not cut with it) with
    everything it draws (labels, titles, legends, secondary axes, also where they reach out of the figure) and cut
    out; the panels are stacked row by row, left to right.  The figure-level texts (a suptitle, a
    supxlabel) and legends are left out of that drawing and drawn again at the widest panel's width (text wrapped
    and horizontal, the legend in as many columns as fit, its entries drawn with the axes' artists of their labels)
    above the panels, or below them when they were in the
    figure's lower half.  ``fig`` is drawn as it is (its layout engine, if any, runs) and left as it was: the
    figure-level artists are hidden only while it is drawn.  ValueError naming ``fig`` or ``dpi`` when it is not a
    matplotlib Figure or not a positive number."""
    import matplotlib.figure
    import matplotlib.legend
    import matplotlib.text
    from matplotlib.colors import to_rgba
    from matplotlib.transforms import Affine2D, Bbox
    if not isinstance(fig, matplotlib.figure.Figure):
        raise ValueError(f"fig: expected a matplotlib Figure, got {type(fig).__name__}")
    dpi = check_scalar(dpi, "dpi", positive=True)
    if fig.subfigs:
        return None
    cells: dict[tuple[float, float], list] = {}
    loose = []
    for ax in fig.axes:
        if not ax.get_visible():
            continue
        spec = ax.get_subplotspec()
        if spec is None:
            loose.append(ax)
            continue
        top = spec.get_topmost_subplotspec()
        nrows, ncols = top.get_geometry()[:2]
        cells.setdefault((top.rowspan.start / nrows, top.colspan.start / ncols), []).append(ax)
    if len({col for _, col in cells}) < 2:
        return None
    others = [a for a in fig.get_children() if a is not fig.patch and a not in fig.axes and a.get_visible()]
    if any(not isinstance(a, (matplotlib.text.Text, matplotlib.legend.Legend)) for a in others):
        return None
    others = [a for a in others if not (isinstance(a, matplotlib.text.Text) and not a.get_text().strip())]
    height_in = fig.get_figheight()
    lower = {id(a): (lambda b: (b.y0 + b.y1) / 2 < 0.5 * height_in * fig.dpi)(a.get_window_extent()) for a in others}
    engine = fig.get_layout_engine()
    hidden = []
    try:
        for a in others:                         # drawn again below, at a panel's width: not in the panels' cuts
            a.set_visible(False)
        fig.draw_without_rendering()             # the layout engine, if any, places the axes without them
        # everything the figure draws, also out of its frame (as the saved PNG's tight box), at dpi
        area = Bbox.union([fig.bbox_inches, fig.get_tightbbox()])
        # display coordinates (the figure's dpi, from its lower left corner) -> the drawing's pixels
        to_pixels = Affine2D().scale(1 / fig.dpi).translate(-area.x0, -area.y0).scale(dpi)
        frames = {k: Bbox.union([a.get_window_extent() for a in axs]).transformed(to_pixels)
                  for k, axs in cells.items()}
        for ax in loose:
            box = ax.get_window_extent().transformed(to_pixels)
            cells[min(frames, key=lambda k: _distance(frames[k], box))].append(ax)
        if engine is not None:                   # the axes stay where they are while the others are hidden
            fig.set_layout_engine("none")
        panels = []
        for k in sorted(cells):
            # each panel drawn alone (the others hidden): a neighbour's label reaching into its box is not in its cut
            box = Bbox.union([a.get_tightbbox() for a in cells[k]]).transformed(to_pixels)
            hidden = [a for j in cells if j != k for a in cells[j]]
            for a in hidden:
                a.set_visible(False)
            panels.append(_cut(_png_pixels(fig, dpi, area), box, 0.06 * dpi))
            for a in hidden:
                a.set_visible(True)
            hidden = []
    finally:
        for a in (*others, *hidden):
            a.set_visible(True)
        if engine is not None:
            fig.set_layout_engine(engine)
    if any(0 in p.shape[:2] for p in panels):        # a panel outside the drawing: nothing sensible to stack
        return None
    # a legend's entries drawn with the axes' own artists (an errorbar's markers and line style), by label
    known: dict[str, Any] = {}
    for ax in fig.axes:
        for handle, label in zip(*ax.get_legend_handles_labels()):
            known.setdefault(label, handle)
    width_in = max(p.shape[1] for p in panels) / dpi
    head = [_redraw(a, width_in, dpi, fig.get_facecolor(), known) for a in others if not lower[id(a)]]
    foot = [_redraw(a, width_in, dpi, fig.get_facecolor(), known) for a in others if lower[id(a)]]
    parts = head + panels + foot
    width = max(p.shape[1] for p in parts)
    out = np.empty((sum(p.shape[0] for p in parts), width, 4), np.uint8)
    out[:] = np.round(255 * np.array(to_rgba(fig.get_facecolor()))).astype(np.uint8)
    y = 0
    for p in parts:                                # each centred
        x = (width - p.shape[1]) // 2
        out[y:y + p.shape[0], x:x + p.shape[1]] = p
        y += p.shape[0]
    return out


def _draw(fig, dpi: float):
    """Draw ``fig`` (one of ours: its canvas is replaced) at ``dpi`` on an Agg canvas: its renderer and pixels."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    canvas = FigureCanvasAgg(fig)
    fig.set_dpi(dpi)
    canvas.draw()
    return canvas.get_renderer(), np.asarray(canvas.buffer_rgba()).copy()


def _distance(a, b) -> float:
    """The distance between the centres of two boxes."""
    return float(np.hypot((a.x0 + a.x1 - b.x0 - b.x1) / 2, (a.y0 + a.y1 - b.y0 - b.y1) / 2))


def _cut(image: np.ndarray, box, pad: float) -> np.ndarray:
    """The pixels of ``image`` (rows from the top) inside ``box`` (display coordinates, from the bottom) and ``pad``
    pixels around it, within the image."""
    height, width = image.shape[:2]
    x0, y0 = max(0, int(np.floor(box.x0 - pad))), max(0, int(np.floor(box.y0 - pad)))
    x1, y1 = min(width, int(np.ceil(box.x1 + pad))), min(height, int(np.ceil(box.y1 + pad)))
    return image[height - y1:height - y0, x0:x1]


def _png_pixels(fig, dpi: float, area) -> np.ndarray:
    """``fig`` drawn at ``dpi`` over ``area`` (a Bbox in inches) as PNG and read back: its RGBA pixels (uint8), of
    the exact size matplotlib draws (whatever its rounding); the user's savefig settings do not apply."""
    import io
    import matplotlib.image
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches=area, pad_inches=0, transparent=False,
                metadata={"Software": None})
    buf.seek(0)
    image = np.round(255 * matplotlib.image.imread(buf, format="png")).astype(np.uint8)
    if image.shape[2] == 3:
        image = np.concatenate([image, np.full(image.shape[:2] + (1,), 255, np.uint8)], axis=2)
    return image


def _redraw(artist, width_in: float, dpi: float, facecolor, known: Mapping[str, Any]) -> np.ndarray:
    """A figure-level text (wrapped) or legend (in as many columns as fit; an entry drawn with ``known[label]``, the
    axes' own artist of that label, where there is one) drawn alone ``width_in`` inches wide."""
    import matplotlib.figure
    import matplotlib.text
    pad = 0.04 * dpi                               # pixels kept around it: the whole cut within width_in
    columns = getattr(artist, "_ncols", 1)          # matplotlib keeps a legend's column count unexposed
    for ncols in range(max(1, columns), 0, -1):
        f = matplotlib.figure.Figure(figsize=(width_in - 2 * pad / dpi, 8), facecolor=facecolor)
        if isinstance(artist, matplotlib.text.Text):          # horizontal (a supylabel too), wrapped
            drawn = f.text(0.5, 0.5, artist.get_text(), ha="center", va="center", wrap=True,
                           fontproperties=artist.get_fontproperties(), color=artist.get_color())
        else:
            labels = [t.get_text() for t in artist.get_texts()]
            handles = [known.get(label, proxy) for label, proxy in zip(labels, artist.legend_handles)]
            drawn = f.legend(handles, labels, loc="center",
                             ncols=ncols, prop=artist.prop, frameon=artist.get_frame_on(),
                             title=artist.get_title().get_text() or None,
                             title_fontproperties=artist.get_title().get_fontproperties())
        renderer, image = _draw(f, dpi)
        box = drawn.get_window_extent(renderer)
        if box.width + 2 * pad <= width_in * dpi:
            break
    return _cut(image, box, pad)
