"""Writing the outputs: a results file with its provenance, text files and figures, each atomically.

:func:`write_results` writes ``data/results/<paper>.json`` after checking it against the results contract
(:mod:`mmlib.experiment.results`, whose :func:`~mmlib.experiment.results.read_results` is the one reader);
:func:`provenance` is that file's ``provenance`` object; :func:`atomic_write_text` writes any text file so that it is
never half-written (the grid cache, the reports, the notebook runner's journal); :func:`save_figure` writes a figure
as deterministic PNG and SVG.  The rows written are the verdict rule's (:mod:`mmlib.experiment.verdicts`).
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

from mmlib.experiment import results, verdicts
from mmlib.experiment.verdicts import Row

__all__ = [
    "write_results", "save_figure", "provenance", "git_commit", "atomic_write_text"
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


def save_figure(fig: matplotlib.figure.Figure, out_dir: str | Path, stem: str,
                formats: Sequence[str] = ("png", "svg")) -> list[str]:
    """Save a figure as PNG and SVG (deterministic SVG ids, no date), atomically per file.  ``formats``: a sequence
    of matplotlib format names (a bare string is refused, never split into letters)."""
    import matplotlib
    import matplotlib.figure
    if not isinstance(fig, matplotlib.figure.Figure):
        raise ValueError(f"fig: expected a matplotlib Figure, got {type(fig).__name__}")
    if not isinstance(out_dir, (str, os.PathLike)):
        raise ValueError(f"out_dir: expected a folder path, got {out_dir!r}")
    if not isinstance(stem, str) or not stem or "/" in stem:
        raise ValueError(f"stem: expected a file name without folder or extension, got {stem!r}")
    if isinstance(formats, (str, bytes)) or not hasattr(formats, "__iter__"):
        raise ValueError(f"formats: expected a sequence of format names such as ('png', 'svg'), got {formats!r}")
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
            target = out_dir / f"{stem}.{fmt}"
            fd, tmp = tempfile.mkstemp(dir=out_dir, prefix=f".{stem}.", suffix=f".{fmt}")
            os.close(fd)
            try:
                fig.savefig(tmp, format=fmt, dpi=150, bbox_inches="tight",
                            metadata={"Date": None} if fmt == "svg" else {"Software": None})
                os.replace(tmp, target)
            except BaseException:
                os.unlink(tmp)
                raise
            written.append(str(target))
    return written
