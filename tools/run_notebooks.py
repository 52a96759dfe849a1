#!/usr/bin/env python
"""Execute the paper notebooks headlessly with papermill, and promote each paper's outputs all at once.

Each notebook (jupytext percent source in notebooks/*.py; give a paper name such as ``zhu2016``, a notebook name,
or a path; default: all of them) is converted to .ipynb and executed with the ``mmlib`` kernel into a fresh
*staging* folder.  Where the outputs of a run are promoted to:

* profile ``full``, no ``-p``:  the committed outputs -- data/results/<paper>.json, figures/<paper>/,
  notebooks/executed/<name>.ipynb, reports/<paper>.md and reports/README.md
* profile ``smoke``, no ``-p``: the same files under build/smoke/ (executed notebooks in build/smoke/executed/)
* any ``-p NAME=VALUE``:        build/custom/<profile>-<NAME=VALUE...>/, laid out like build/smoke/.  A run with
  other settings is never written over the committed outputs (nor over the smoke outputs the tolerance tests read).

Every argument is checked before anything runs: ``-p`` names a parameter the notebook declares, with a value the
notebooks accept (the rules of ``mmlib.experiment.notebook.NotebookRun``: e.g. at least two Monte Carlo runs,
since a standard error needs two); a bad one is an error naming it (exit status 2).

Promotion is all-or-nothing per paper.  Only if every cell succeeds are the paper's reports rendered into its
staging folder too (the cross-paper README from the new results and the other papers' current ones), all staged
files made durable, and a journal written listing every move; then each current file is moved aside into the
staging folder, each new one moved into place, and the journal and staging folder removed.  A run killed at any
point leaves either no journal (the old outputs are untouched) or a complete journal: every invocation starts by
finishing such a promotion (``--recover`` does only that) and removing leftover staging folders and temporary files,
so what is on disk is entirely the old or entirely the new outputs of each paper.

A failed notebook is named with its cell (exit status 1); nothing of it is promoted, and its partial executed
notebook is kept for inspection under <build folder>/failed/.  So is a notebook whose results file breaks the results
contract (mmlib/experiment/results.schema.json, checked by ``mmlib.experiment.results.read_results``): the file and the
JSON path of the first violation are named.

A run opens with a header of every setting in force: the profile, the notebooks, the overrides and where the
outputs go, the workers and the scheduler, and per notebook its headline's runs and seed and its reading space's runs
per universe (``-p MULTIVERSE_RUNS=N`` changes them; ``N_RUNS`` does not), each with where it comes from.  A
reading-space parameter (``MULTIVERSE_*``) given without notebook names leaves out the notebooks that have no reading
space (the arena).  Progress: ``universe k/N, ~T left`` per reading space, at most every 15 s; ``-v`` prints every
universe with its levels.

Execution settings change where the work runs, never a result, so they never send the outputs to build/custom/:
``--workers N`` (default ``$WORKERS``, else every core; ``-p WORKERS=N`` is the same setting) and ``--scheduler
ADDRESS`` (default ``$MMLIB_SCHEDULER``: a Dask scheduler that receives the notebooks' Monte Carlo chunks and
universes; checked before anything runs).  Both reach the kernels through their environment.  Independent notebooks
run in parallel, up to N at a time (see ``parallel_plan``), started in the order that ends soonest at the wall times
of the last full run (``lane_order``, from data/bench/notebooks.json; the order changes no output), each logged by
one line when it starts and one when it finishes, with its wall time; their printed output is prefixed with the
notebook's name.  Execution is parallel, promotion is not: one paper is promoted at a time (its cross-paper README
rendered from the papers promoted before it), so each promotion stays atomic and the last README describes every
paper.
"""
from __future__ import annotations

import argparse
import ast
import contextlib
import hashlib
import inspect
import itertools
import json
import logging
import os
import re
import shutil
import signal
import sys
import tempfile
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
# jsonschema (imported by nbformat, hence by papermill and jupytext) registers checks of the "iri" formats when the
# optional rfc3987_syntax is installed (the lock has it: jupyter_server's jsonschema[format-nongpl]), whose import
# compiles 39 lark grammars: 1.4 s of every runner process, and the tests start about seventy.  No schema the runner
# validates (the notebooks' nbformat schema; results are read by mmlib's own validator) has a "format" keyword, so
# the runner never imports it: jsonschema then leaves those two formats unchecked (tests/test_runner.py)
SKIPPED_IMPORTS = ("rfc3987_syntax",)
for _name in SKIPPED_IMPORTS:
    sys.modules.setdefault(_name, None)
KERNEL = "mmlib"
JOURNAL = "journal.json"
PROFILES = ("full", "smoke")
# parameters the runner sets itself, and what to use instead
RUNNER_SET = {"PROFILE": "use --profile", "OUTPUT_ROOT": "outputs go to the folder the runner chooses"}
FAULT_ENV, PAUSE_ENV = "RUN_NOTEBOOKS_FAULT", "RUN_NOTEBOOKS_PAUSE"
FAULT_EXIT = 99
# notebook parameters that are execution settings, not results-changing ones: the runner option that sets them
EXECUTION_PARAMS = {"WORKERS": "--workers"}


class UsageError(Exception):
    """A bad argument; the message names it.  Raised before anything runs or is written."""


class NotebookFailed(Exception):
    """A notebook failed to execute or wrote outputs that cannot be promoted; nothing of it was promoted."""


# ----------------------------------------------------------------------------------------------- where outputs go
@dataclass(frozen=True)
class Layout:
    """Where one invocation reads and writes: ``root`` holds notebooks/ (the repository, or a test's copy),
    ``out`` receives the promoted outputs, ``work`` holds converted/, staging/ and failed/."""
    root: Path
    out: Path
    work: Path
    executed_dir: str   # folder of executed notebooks, relative to ``out``

    def show(self, path: Path) -> str:
        """``path`` relative to the root, for messages."""
        return str(path.relative_to(self.root)) if path.is_relative_to(self.root) else str(path)

    @property
    def destination(self) -> str:
        """Where the outputs go, for messages."""
        return "the committed outputs" if self.out == self.root else f"{self.show(self.out)}/"


def show(path: Path, root: Path) -> str:
    """``path`` relative to ``root`` (or to the current folder) when it lies inside it, for messages: no
    machine-local path in a log."""
    path = Path(path).resolve()
    for base in (Path(root).resolve(), Path.cwd().resolve()):
        if path.is_relative_to(base):
            return str(path.relative_to(base)) or "."
    return str(path)


def custom_name(profile: str, params: dict) -> str:
    """Folder name of a run with overridden parameters: the profile and every NAME=VALUE, sorted, file-name safe."""
    name = "-".join([profile, *(f"{k}={params[k]}" for k in sorted(params))])
    name = re.sub(r"[^A-Za-z0-9._=+-]", "_", name)
    return name if len(name) <= 100 else f"{name[:80]}-{hashlib.sha256(name.encode()).hexdigest()[:12]}"


def layout_for(root: Path, profile: str, params: dict) -> Layout:
    """The committed layout for a plain full run, build/<profile>/ for a plain smoke run, build/custom/... for any
    run with -p overrides (so that overridden settings can never replace the committed or smoke outputs)."""
    if params:
        folder = root / "build" / "custom" / custom_name(profile, params)
        return Layout(root, folder, folder, "executed")
    if profile == "full":
        return Layout(root, root, root / "build" / "full", "notebooks/executed")
    return Layout(root, root / "build" / profile, root / "build" / profile, "executed")


# -------------------------------------------------------------------------------------------- checking arguments
def parse_params(items: list[str]) -> dict:
    """``-p NAME=VALUE`` items as a dict; values are Python literals where they parse as one, else strings."""
    params = {}
    for item in items:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key.isidentifier():
            raise UsageError(f"-p {item!r}: expected NAME=VALUE")
        if key in params:
            raise UsageError(f"-p {key}: given twice")
        if key in RUNNER_SET:
            raise UsageError(f"-p {key}: set by the runner ({RUNNER_SET[key]})")
        try:
            params[key] = ast.literal_eval(text)
        except (ValueError, SyntaxError):
            params[key] = text
    return params


def known_notebooks(root: Path) -> dict[str, list[Path]]:
    """Notebook sources by the names that select them: the file stem and the paper name before its first '_'."""
    names: dict[str, list[Path]] = {}
    for src in sorted((root / "notebooks").glob("*.py")):
        names.setdefault(src.stem, []).append(src)
        if "_" in src.stem:
            names.setdefault(src.stem.split("_")[0], []).append(src)
    return names


def resolve_notebooks(root: Path, names: list[str]) -> list[Path]:
    """Notebook sources for the command-line names (paper name, notebook name or path); all of them if none."""
    known = known_notebooks(root)
    if not names:
        sources = sorted({src for srcs in known.values() for src in srcs})
        if not sources:
            raise UsageError(f"no notebook sources (*.py) under {show(root / 'notebooks', root)}")
        return sources
    sources = []
    for name in names:
        if name.endswith(".py") or os.sep in name:
            src = Path(name).resolve()
            if not src.is_file():
                raise UsageError(f"notebook {name!r}: no such file")
            if src.parent != (root / "notebooks").resolve():
                # its outputs are named after its paper, its executed notebook after its file: a source from
                # elsewhere could replace one paper's results beside another notebook's executed copy
                raise UsageError(f"notebook {name!r}: not a notebook source of this repository "
                                 f"({show(root / 'notebooks', root)}/*.py); copy it there to run it")
        elif len(known.get(name, [])) == 1:
            src = known[name][0]
        elif name in known:
            raise UsageError(f"notebook {name!r}: ambiguous, matches {', '.join(s.stem for s in known[name])}")
        else:
            papers = sorted(k for k in known if "_" not in k)
            raise UsageError(f"notebook {name!r}: unknown; known papers: {', '.join(papers) or 'none'} "
                             f"(or give a notebook name or the path of a notebook source)")
        if src not in sources:
            sources.append(src)
    return sources


def convert(src: Path, target: Path) -> Path:
    """The jupytext source as an .ipynb at ``target`` (kernel ``mmlib`` unless the source names one)."""
    import jupytext
    nb = jupytext.read(src)
    nb.metadata.setdefault("kernelspec", {"name": KERNEL, "language": "python", "display_name": KERNEL})
    target.parent.mkdir(parents=True, exist_ok=True)
    jupytext.write(nb, target)
    return target


def declared_parameters(src: Path) -> dict[str, str]:
    """The parameters a notebook declares in its ``parameters`` cell, {name: default as written}."""
    import papermill as pm
    with tempfile.TemporaryDirectory() as tmp:
        info = pm.inspect_notebook(str(convert(src, Path(tmp) / f"{src.stem}.ipynb")))
    return {name: p["default"] for name, p in info.items()}


def check_values(params: dict, declared: dict[str, str], profile: str) -> None:
    """Reject values the notebook would reject, with the notebooks' own rules (``NotebookRun`` validates every
    shared parameter; written once there), before any notebook runs; plus the rule NotebookRun lacks:
    True/False for a parameter whose default is a boolean."""
    if not params:
        return
    from mmlib.experiment.paper import Study
    from mmlib.experiment.notebook import NotebookRun
    accepted = inspect.signature(NotebookRun).parameters
    shared = {k: v for k, v in params.items() if k in accepted and k != "PROFILE"}
    probe = Study("probe", 0, {p: dict(n_runs=2, timing_runs=1, timing_repeats=1) for p in (profile, "smoke")})
    try:
        NotebookRun(probe, PROFILE=profile, **shared)
    except ValueError as exc:
        raise UsageError(f"-p {exc}") from None
    for key, value in params.items():
        if declared[key] in ("True", "False") and not isinstance(value, bool):
            raise UsageError(f"-p {key}: expected True or False, got {value!r}")


def check_notebook(src: Path, params: dict, profile: str, layout: Layout, declared: dict | None = None) -> None:
    """The notebook declares the parameters the runner sets and every ``-p`` one, and accepts their values
    (``declared``: its parameters, when already read)."""
    declared = declared_parameters(src) if declared is None else declared
    where = layout.show(src)
    missing = [k for k in RUNNER_SET if k not in declared]
    if missing:
        raise UsageError(f"{where}: declares no {' or '.join(missing)} parameter, so its outputs could not be "
                         f"staged; its parameters cell must declare {' and '.join(RUNNER_SET)}")
    for key in params:
        if key not in declared:
            raise UsageError(f"{where}: -p {key}: not a parameter of this notebook; it declares "
                             f"{', '.join(k for k in declared if k not in RUNNER_SET)}")
    try:
        check_values(params, declared, profile)
    except UsageError as exc:
        raise UsageError(f"{where}: {exc}") from None


# ------------------------------------------------------------------------------------------------ fault injection
_reached: dict[str, int] = {}
_reached_lock = threading.Lock()


def checkpoint(stage: str) -> None:
    """Fault-injection hook for the crash tests; does nothing unless asked.  ``RUN_NOTEBOOKS_FAULT=<stage>[#n]``
    makes the runner exit at once (``os._exit``, no clean-up) the n-th time (default: first) it reaches ``stage``;
    ``RUN_NOTEBOOKS_PAUSE`` makes it print ``paused at <stage>#n`` and wait there for a signal (a test's SIGKILL).
    Stages: executed, staged, journal, rename (every move of a promotion), promoted, journal-removed."""
    with _reached_lock:            # notebooks run in threads: the n-th arrival must be counted once
        n = _reached[stage] = _reached.get(stage, 0) + 1
    here = (f"{stage}#{n}",) + ((stage,) if n == 1 else ())
    if os.environ.get(FAULT_ENV) in here:
        print(f"fault injection: exiting at {stage}#{n}", flush=True)
        os._exit(FAULT_EXIT)
    if os.environ.get(PAUSE_ENV) in here:
        print(f"fault injection: paused at {stage}#{n}", flush=True)
        while True:
            signal.pause()


# ------------------------------------------------------------------------------------------- durable file moves
def fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def fsync_tree(path: Path) -> None:
    """Flush every file and folder under ``path`` to disk (staged outputs must survive a crash once journaled)."""
    for folder, _, files in os.walk(path):
        for name in files:
            fd = os.open(Path(folder, name), os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        fsync_dir(Path(folder))


def move(src: Path, dst: Path) -> None:
    """Rename a file or folder (same file system, atomic), then reach the ``rename`` checkpoint."""
    dst.parent.mkdir(parents=True, exist_ok=True)
    os.replace(src, dst)
    checkpoint("rename")


# ------------------------------------------------------------------------------------ journaled promotion, recovery
def owned_paths(layout: Layout, paper: str, name: str) -> list[str]:
    """Every output a paper owns, relative to the output folder."""
    return [f"data/results/{paper}.json", f"figures/{paper}", f"{layout.executed_dir}/{name}.ipynb",
            f"reports/{paper}.md", "reports/README.md"]


def write_journal(staging: Path, layout: Layout, paper: str, name: str) -> None:
    """The commit point of a promotion: a durable list of the paper's outputs and whether a new one is staged
    (an output the new run did not produce, e.g. a figures folder, is removed).  Written only once every staged
    file is on disk, so that an interrupted promotion can always be finished."""
    entries = [{"path": rel, "staged": (staging / rel).exists()} for rel in owned_paths(layout, paper, name)]
    journal = {"out": os.path.relpath(layout.out, layout.root), "paper": paper, "entries": entries}
    from mmlib.experiment.writing import atomic_write_text
    atomic_write_text(staging / JOURNAL, json.dumps(journal, indent=1) + "\n", durable=True)
    checkpoint("journal")


def settle(entry: dict, staging: Path, out: Path) -> None:
    """Bring one journal entry to its new state; idempotent, so a promotion killed anywhere can be rerun.  The
    current output is moved aside into staging/.backup/ (unless the new one is already in place), then the new one
    moved in.  While the staged file exists, the output in place is still the old one."""
    final, new, backup = out / entry["path"], staging / entry["path"], staging / ".backup" / entry["path"]
    if entry["staged"] and not os.path.lexists(new):
        return                                  # already moved in
    if os.path.lexists(final):
        move(final, backup)
    if entry["staged"]:
        move(new, final)


def finish_promotion(staging: Path, root: Path) -> str:
    """Carry out (or finish) the journaled promotion of ``staging``, then delete the journal, the moved-aside old
    outputs and the staging folder.  Returns the paper's name."""
    journal = json.loads((staging / JOURNAL).read_text())
    out = (root / journal["out"]).resolve()
    for entry in journal["entries"]:
        settle(entry, staging, out)
    for folder in {(out / e["path"]).parent for e in journal["entries"]}:
        if folder.is_dir():
            fsync_dir(folder)
    checkpoint("promoted")
    (staging / JOURNAL).unlink()
    fsync_dir(staging)
    checkpoint("journal-removed")
    shutil.rmtree(staging)
    return journal["paper"]


def output_roots(root: Path) -> list[Path]:
    return [root, root / "build" / "smoke", *sorted((root / "build" / "custom").glob("*"))]


# leftovers of atomic writes and of the former promotion scheme, relative to an output folder
STALE = ("figures/.*.old", "figures/*/.*", "data/results/.*.tmp", "reports/.*.tmp")


def recover(root: Path) -> list[str]:
    """Finish every journaled promotion an interrupted run left under ``root``, and remove leftover staging
    folders (no journal: the old outputs were never touched) and temporary files.  Returns what was done."""
    done = []
    build = root / "build"
    for staging in sorted([*build.glob("*/staging/*"), *build.glob("custom/*/staging/*")]):
        if (staging / JOURNAL).exists():
            paper = finish_promotion(staging, root)
            done.append(f"finished the interrupted promotion of {paper} ({staging.relative_to(root)})")
        else:
            shutil.rmtree(staging)
            done.append(f"removed the leftover staging folder {staging.relative_to(root)}")
    remove_empty_staging(root)
    for out in output_roots(root):
        for pattern in STALE:
            for path in out.glob(pattern):
                shutil.rmtree(path) if path.is_dir() and not path.is_symlink() else path.unlink()
                done.append(f"removed the leftover temporary {path.relative_to(root)}")
    return done


def remove_empty_staging(root: Path) -> None:
    """Remove the staging folders under ``root``/build that hold nothing (every paper's folder in them is removed
    when its promotion ends, and an empty ``staging/`` left behind looks like an interrupted run)."""
    build = root / "build"
    for staging in [*build.glob("*/staging"), *build.glob("custom/*/staging")]:
        with contextlib.suppress(OSError):          # not empty (another paper's promotion): kept
            staging.rmdir()


@contextlib.contextmanager
def runner_lock(root: Path):
    """One runner at a time per root: recovery removes staging folders, which must not be another run's."""
    import fcntl
    path = root / "build" / ".run_notebooks.lock"
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            print(f"waiting for another run_notebooks.py to finish ({show(path, root)})", flush=True)
            fcntl.flock(fh, fcntl.LOCK_EX)
        yield


# ---------------------------------------------------------------------------------------------- running a notebook
def sanitize(executed: Path, staging: Path, final_root: Path, root: Path = REPO) -> None:
    """Strip machine-local paths from an executed notebook before it is promoted: the staging folder
    becomes the folder the outputs are promoted to, and every path inside the repository becomes
    relative to it (papermill's metadata, the injected parameters, printed output paths)."""
    text = executed.read_text()
    text = text.replace(str(staging), str(final_root))
    for base in dict.fromkeys([root, REPO]):
        text = text.replace(str(base) + "/", "").replace(str(base), ".")
    executed.write_text(text)


class PrefixedLines:
    """A text stream that writes each complete line to ``target`` prefixed with ``prefix`` (the rest is held until
    its newline), under a lock shared by the notebooks that run at once, so that their outputs stay readable."""

    def __init__(self, target, prefix: str, lock: threading.Lock):
        self.target, self.prefix, self.lock, self.pending = target, prefix, lock, ""

    def write(self, text: str) -> int:
        # under the lock as a whole: papermill's thread and the progress tail's both write to one stream
        with self.lock:
            *lines, self.pending = (self.pending + text).split("\n")
            if lines:
                self.target.write("".join(f"{self.prefix}{line}\n" for line in lines))
        return len(text)

    def flush(self) -> None:
        with self.lock:
            self.target.flush()

    def close(self) -> None:
        if self.pending:
            self.write("\n")


class RelativePaths:
    """A text stream that writes to ``target`` with machine-local paths made relative: the staging folder becomes the
    folder its outputs are promoted to, and the repository root's paths become relative to it (a kernel printing
    where it wrote a file would otherwise show the absolute staging path, which is gone once promoted)."""

    def __init__(self, target, staging: Path, layout: Layout):
        out = layout.show(layout.out)
        self.target = target
        self.subs = [(str(staging), out), (str(layout.root) + os.sep, ""),
                     (str(layout.root), ".")]

    def write(self, text: str) -> int:
        """Write ``text`` with the paths replaced (a kernel writes whole lines, so a path is not split across calls);
        returns the length of ``text`` as given, as a stream's write does."""
        shown = text
        for old, new in self.subs:
            shown = shown.replace(old, new)
        self.target.write(shown)
        return len(text)

    def flush(self) -> None:
        self.target.flush()


def execute(src: Path, staging: Path, layout: Layout, profile: str, params: dict, timeout: int,
            stdout=None, stderr=None, kernel_env: dict | None = None) -> Path:
    """Run the notebook with its outputs directed to ``staging``; returns the executed notebook (in ``staging``,
    where the promotion expects it).  ``kernel_env``: added to the kernel's environment (:func:`run_one`).  The
    kernel's printed output goes to ``stdout``/``stderr`` (default: this
    process's).  Raises NotebookFailed naming the notebook and the cell."""
    import papermill as pm
    from papermill.exceptions import PapermillExecutionError
    # the kernel's progress lines (mmlib.experiment.montecarlo.say_progress) go to this file, and from it to the
    # runner's log: never into the executed notebook
    from mmlib.experiment.montecarlo import PROGRESS_LOG_ENV
    nb_in = convert(src, layout.work / "converted" / f"{src.stem}.ipynb")
    executed = staging / layout.executed_dir / f"{src.stem}.ipynb"
    executed.parent.mkdir(parents=True)
    log = layout.work / "logs" / f"{src.stem}.progress.log"
    log.parent.mkdir(parents=True, exist_ok=True)
    log.write_text("")
    tail = ProgressTail(log, stderr or sys.stderr)
    try:
        pm.execute_notebook(str(nb_in), str(executed), kernel_name=KERNEL,
                            parameters={**params, "PROFILE": profile, "OUTPUT_ROOT": str(staging)},
                            cwd=str(layout.root / "notebooks"), execution_timeout=timeout,
                            progress_bar=False, log_output=False,
                            stdout_file=RelativePaths(stdout or sys.stdout, staging, layout),
                            stderr_file=RelativePaths(stderr or sys.stderr, staging, layout),
                            kernel_manager_class=kernel_manager_with_env(
                                {**(kernel_env or {}), PROGRESS_LOG_ENV: str(log.resolve())}))
    except PapermillExecutionError as exc:
        raise NotebookFailed(f"cell {exc.cell_index} (execution count {exc.exec_count}): {exc.ename}: "
                             f"{exc.evalue}") from None
    except Exception as exc:  # kernel death, timeout, missing kernel
        raise NotebookFailed(f"{type(exc).__name__}: {exc}") from None
    finally:
        tail.stop()
    checkpoint("executed")
    return executed


def kernel_manager_with_env(extra: dict):
    """A jupyter_client kernel manager class whose kernels start with ``extra`` added to this process's
    environment.  Per notebook, because notebooks execute in threads of one process, whose os.environ they share.
    Its kernels get CurveZMQ keys when their kernelspec declares support (``transport_encryption="auto"``; the
    ``mmlib`` kernel does), so that the kernel does not warn that it runs over TCP without encryption."""
    import zmq
    from jupyter_client.manager import AsyncKernelManager
    curve = zmq.has("curve")

    class KernelManagerWithEnv(AsyncKernelManager):
        async def _async_pre_start_kernel(self, **kw):
            kw["env"] = {**kw.get("env", os.environ), **extra}
            if curve and "transport_encryption" in inspect.signature(super()._async_pre_start_kernel).parameters:
                kw.setdefault("transport_encryption", "auto")        # jupyter_client >= 8.9
            return await super()._async_pre_start_kernel(**kw)

    return KernelManagerWithEnv


class ProgressTail:
    """Copies the lines appended to a notebook's progress log to ``target`` (the runner's log) while it runs: the
    progress of a long notebook is seen live, and never lands in its executed notebook as stderr output."""

    def __init__(self, path: Path, target, interval: float = 0.5):
        self.path, self.target, self.interval = path, target, interval
        self.done, self.offset = threading.Event(), 0
        self.thread = threading.Thread(target=self._run, name=f"tail-{path.stem}", daemon=True)
        self.thread.start()

    def _copy(self) -> None:
        try:
            with open(self.path, "rb") as f:
                f.seek(self.offset)
                data = f.read()
        except FileNotFoundError:
            return
        end = data.rfind(b"\n") + 1          # whole lines only; the rest is read next time
        if end:
            self.offset += end
            self.target.write(data[:end].decode("utf-8", "replace"))
            self.target.flush()

    def _run(self) -> None:
        while not self.done.wait(self.interval):
            self._copy()

    def stop(self) -> None:
        """Stop after copying whatever the log holds now."""
        self.done.set()
        self.thread.join()
        self._copy()


def staged_results(staging: Path, paper: str) -> dict:
    """The results document a notebook staged, read and checked against the results contract
    (:func:`mmlib.experiment.results.read_results`); NotebookFailed naming the file and the place otherwise."""
    from mmlib.experiment.results import read_results
    try:
        return read_results(staging / "data" / "results" / f"{paper}.json", name=f"data/results/{paper}.json")
    except ValueError as exc:
        raise NotebookFailed(f"wrote an invalid results file: {exc}") from None


def staged_paper(staging: Path, src: Path) -> str:
    """The paper whose outputs the notebook staged: exactly one results file, figures for that paper only, and
    the paper its file name starts with (``<paper>_<topic>.py``), whose executed notebook it replaces."""
    results = sorted((staging / "data" / "results").glob("*.json"))
    if len(results) != 1:
        raise NotebookFailed(f"wrote {len(results)} results files ({', '.join(p.name for p in results) or 'none'});"
                             f" expected exactly one, data/results/<paper>.json")
    paper = results[0].stem
    doc_paper = staged_results(staging, paper)["paper"]
    if doc_paper != paper:
        raise NotebookFailed(f"data/results/{paper}.json names paper {doc_paper!r}")
    if src.stem.split("_")[0] != paper:
        raise NotebookFailed(f"wrote the results of paper {paper!r}, but its file name says "
                             f"{src.stem.split('_')[0]!r} (<paper>_<topic>.py)")
    others = [p.name for p in (staging / "figures").glob("*") if p.name != paper]
    if others:
        raise NotebookFailed(f"wrote figures for {', '.join(others)}, not for its paper {paper}")
    return paper


def stage_reports(staging: Path, layout: Layout, paper: str) -> None:
    """Render the paper's report and the cross-paper README into staging, from the new results and the other
    papers' current ones, so that they are promoted together with the results they describe."""
    import make_report
    doc = staged_results(staging, paper)
    try:
        reports = make_report.paper_reports(doc, make_report.load_results(layout.out, skip=paper), layout.out)
    except (KeyError, TypeError, ValueError) as exc:
        raise NotebookFailed(f"could not render the reports: {type(exc).__name__}: {exc}") from None
    for rel, text in reports.items():
        (staging / rel).parent.mkdir(parents=True, exist_ok=True)
        (staging / rel).write_text(text)


def run_one(src: Path, layout: Layout, profile: str, params: dict, timeout: int,
            promotion_lock: threading.Lock | None = None, stdout=None, stderr=None,
            kernel_env: dict | None = None) -> list[str]:
    """Execute one notebook and promote its outputs all at once; returns the promoted paths.  On failure keeps the
    partial executed notebook under <work>/failed/, promotes nothing and raises NotebookFailed.  ``kernel_env``:
    variables the notebook's kernel gets on top of this process's environment (an exclusive notebook's WORKERS).

    Notebooks may execute at the same time, but ``promotion_lock`` (shared by them) admits one promotion at a time,
    from the rendering of the reports to the removal of the journal: the cross-paper README staged with a paper is
    rendered from the results promoted before it, and is never replaced by one rendered without them."""
    staging = layout.work / "staging" / src.stem
    failed = layout.work / "failed" / f"{src.stem}.ipynb"
    staging.mkdir(parents=True)
    lock = promotion_lock or contextlib.nullcontext()
    try:
        executed = execute(src, staging, layout, profile, params, timeout, stdout, stderr, kernel_env)
        sanitize(executed, staging, layout.out, layout.root)
        paper = staged_paper(staging, src)
        with lock:
            stage_reports(staging, layout, paper)
            fsync_tree(staging)
            checkpoint("staged")
            write_journal(staging, layout, paper, src.stem)
            finish_promotion(staging, layout.root)
    except NotebookFailed:
        partial = staging / layout.executed_dir / f"{src.stem}.ipynb"
        if partial.exists():
            failed.parent.mkdir(parents=True, exist_ok=True)
            os.replace(partial, failed)
        shutil.rmtree(staging)
        raise
    failed.unlink(missing_ok=True)
    return [layout.show(layout.out / rel) for rel in owned_paths(layout, paper, src.stem)]


#: A line of a notebook source that asks to run with every worker, one such notebook at a time, started once every
#: other notebook has started (:func:`run_all`): a study that keeps all the cores busy by itself (the arena's cells)
#: would otherwise hold only its share of them long after the others ended.
EXCLUSIVE_MARK = "# mmlib-runner: exclusive"


def is_exclusive(src: Path) -> bool:
    """Whether the notebook source carries :data:`EXCLUSIVE_MARK` on a line of its own."""
    return any(line.strip() == EXCLUSIVE_MARK for line in src.read_text().splitlines())


def parallel_plan(workers: int, n_notebooks: int) -> tuple[int, int]:
    """``(notebooks at once, WORKERS of each kernel)`` for ``workers`` worker processes in all.

    As many notebooks at once as there are workers (at most one per notebook), the workers divided among them and
    rounded up (no core idles for a remainder; at most one process per notebook beyond the workers).  A notebook's
    serial parts (set-up, headline evaluation, timings, figures) then overlap other notebooks' work instead of
    leaving cores idle, and when the workers divide evenly (2 cores: 2 notebooks with 1 worker each) the run times
    (``time_algorithms``: CPU time of one thread) are not taken on oversubscribed cores -- but while an exclusive
    notebook (:data:`EXCLUSIVE_MARK`) overlaps the last of the others, which CPU time mostly ignores and their wall
    times and universes per minute do not."""
    slots = max(1, min(workers, n_notebooks))
    return slots, -(-workers // slots)


#: the wall times the notebooks' order is planned from (``python -m bench.notebooks`` writes them after each full
#: ``make figures``), relative to the root
TIMES_FILE = Path("data") / "bench" / "notebooks.json"
#: up to this many notebooks every order is tried (8! = 40,320 simulated runs); longest first beyond
EXHAUSTIVE = 8


def recorded_times(root: Path) -> dict[str, float]:
    """Wall seconds by notebook stem from the last full run's :data:`TIMES_FILE` under ``root``, for the notebooks
    that computed every universe there (one that read its universes from the multiverse cache says nothing about a
    fresh run); {} when the file is missing or unreadable."""
    try:
        doc = json.loads((root / TIMES_FILE).read_text())
    except (OSError, ValueError):
        return {}
    out = {}
    for group in ("papers", "studies"):
        entries = doc.get(group) if isinstance(doc, dict) else None
        for e in (entries.values() if isinstance(entries, dict) else ()):
            if isinstance(e, dict) and isinstance(e.get("notebook"), str) and not e.get("universes_from_cache") \
                    and isinstance(e.get("wall_s"), (int, float)) and e["wall_s"] > 0:
                out[Path(e["notebook"]).stem] = float(e["wall_s"])
    return out


def makespan(durations: Sequence[float], jobs: int) -> float:
    """When the last of ``durations`` ends if each starts, in this order, on the first of ``jobs`` lanes to free (the
    thread pool of :func:`run_all`)."""
    lanes = [0.0] * max(1, jobs)
    for d in durations:
        i = lanes.index(min(lanes))
        lanes[i] += d
    return max(lanes)


def lane_order(sources: list[Path], jobs: int, times: dict[str, float]) -> list[Path]:
    """``sources`` in the order whose run on ``jobs`` lanes ends soonest (:func:`makespan`) given each notebook's
    ``times`` (seconds by stem, :func:`recorded_times`): every order of up to :data:`EXHAUSTIVE` notebooks, the first
    best one kept (the given order unless another ends sooner), longest first beyond that.  The given order when
    one lane runs them all or a notebook has no time.  Outputs do not depend on the order; only when the last lane
    frees does (two lanes that end far apart leave a core idle)."""
    if jobs <= 1 or len(sources) <= 1 or any(src.stem not in times for src in sources):
        return list(sources)
    if len(sources) > EXHAUSTIVE:
        return sorted(sources, key=lambda src: -times[src.stem])
    best, best_end = list(sources), makespan([times[src.stem] for src in sources], jobs)
    for order in itertools.permutations(sources):
        end = makespan([times[src.stem] for src in order], jobs)
        if end < best_end - 1e-9:
            best, best_end = list(order), end
    return best


#: MMLIB_THREADS as the user set it when the runner started (a command line's ``make figures MMLIB_THREADS=1``)
USER_THREADS = os.environ.get("MMLIB_THREADS", "").strip()


def kernel_threads(workers: int) -> dict:
    """The fused-step threads of a kernel given ``workers`` (:func:`mmlib.core.linalg.threads`): as many as its
    workers, its share of the cores, unless the user set MMLIB_THREADS, which stands."""
    return {"MMLIB_THREADS": USER_THREADS or str(workers)}


def run_all(sources: list[Path], layout: Layout, profile: str, params: dict, timeout: int, jobs: int = 1,
            exclusive: list[Path] = (), exclusive_workers: int | None = None) -> int:
    """Run the notebooks, up to ``jobs`` at a time (in threads; each kernel is its own process), each promoted as
    soon as it succeeds; then the ``exclusive`` ones, one at a time, each kernel with ``exclusive_workers`` workers
    (its own environment's WORKERS): each starts on the first lane to free once every other notebook has started,
    so that no core idles while the last of the others finishes (the cores are shared until it does; a run's
    numbers do not depend on its worker count).  At the first failure no further notebook starts; those already
    running finish (and are promoted if they succeed); exit status 1."""
    t_all = time.perf_counter()
    n = len(sources) + len(exclusive)
    jobs = max(1, min(jobs, len(sources) or 1))
    promotion_lock, print_lock = threading.Lock(), threading.Lock()
    failures: list[str] = []
    stop = threading.Event()

    def say(text: str, file=None) -> None:
        with print_lock:
            print(text, file=file or sys.stdout, flush=True)

    exclusive_env = {} if exclusive_workers is None else {"WORKERS": str(exclusive_workers),
                                                          **kernel_threads(exclusive_workers)}
    exclusive_lock = threading.Lock()               # the exclusive notebooks one at a time

    def one(i: int, src: Path, kernel_env: dict | None = None) -> None:
        if stop.is_set():
            return
        say(f"[{i}/{n}] {src.stem}: executing (profile={profile}, kernel={KERNEL})")
        streams = (PrefixedLines(sys.stdout, f"[{src.stem}] ", print_lock),
                   PrefixedLines(sys.stderr, f"[{src.stem}] ", print_lock)) if jobs > 1 else (None, None)
        t0 = time.perf_counter()
        try:
            moved = run_one(src, layout, profile, params, timeout, promotion_lock, *streams, kernel_env=kernel_env)
        except NotebookFailed as exc:
            stop.set()
            failed = layout.work / "failed" / f"{src.stem}.ipynb"
            kept = f"  partial output kept for inspection: {layout.show(failed)}\n" if failed.exists() else ""
            failures.append(src.stem)
            say(f"\nFAILED: notebook {layout.show(src)}, {exc} (after {time.perf_counter() - t0:.1f} s)\n{kept}"
                f"  nothing of it was promoted; its outputs in {layout.destination} are untouched.", sys.stderr)
            return
        finally:
            for stream in streams:
                if stream is not None:
                    stream.close()
        say(f"[{i}/{n}] {src.stem}: done in {time.perf_counter() - t0:.1f} s -> " + ", ".join(moved))

    def alone(i: int, src: Path) -> None:
        with exclusive_lock:
            one(i, src, exclusive_env)

    numbered = [(one, i, src) for i, src in enumerate(sources, 1)] \
        + [(alone, i, src) for i, src in enumerate(exclusive, len(sources) + 1)]
    if jobs == 1:
        for fn, i, src in numbered:
            fn(i, src)
            if failures:
                return 1
    else:
        import concurrent.futures as cf
        pool = cf.ThreadPoolExecutor(max_workers=jobs, thread_name_prefix="notebook")
        try:
            # a thread pool starts its tasks in order: an exclusive notebook only after every other one has started
            for fut in [pool.submit(fn, i, src) for fn, i, src in numbered]:
                fut.result()
        except KeyboardInterrupt:
            # the threads wait on kernels that would outlive a normal exit; every stage is safe to kill (the next
            # run finishes a journaled promotion), so leave at once: the kernels exit with their parent
            say("interrupted: stopping (the next run finishes or abandons any promotion under way)", sys.stderr)
            os._exit(130)
        pool.shutdown(wait=True)
        if failures:
            return 1
    print(f"all {n} notebook(s) done in {time.perf_counter() - t_all:.1f} s (profile={profile}, "
          f"outputs: {layout.destination}, {jobs} at a time)")
    return 0


def positive_workers(text: str, name: str) -> int:
    """A worker count as written on the command line or in the environment (``name`` for the message)."""
    text = str(text).strip()
    if not text.isdigit() or int(text) < 1:
        raise UsageError(f"{name}: expected a positive integer (number of worker processes), got {text!r}")
    return int(text)


def check_scheduler(address: str) -> None:
    """The Dask scheduler answers at ``address`` within mmlib's scheduler timeout, else a UsageError naming it."""
    from mmlib.experiment import executors
    try:
        executors.dask_client(address)
    except ImportError:
        raise UsageError(f"--scheduler {address}: needs Dask distributed; {executors.DASK_HINT}") from None
    except (executors.SchedulerError, ValueError) as exc:
        raise UsageError(f"--scheduler {address}: {str(exc).split(': ', 1)[1]}") from None
    finally:
        executors.shutdown()


def execution_workers(option: str | None, parameter) -> int:
    """The worker count: ``--workers``, or ``-p WORKERS`` (the same setting; both must agree), else ``$WORKERS``,
    else every core; each checked, the error naming the one written."""
    if option is not None:
        workers = positive_workers(option, "--workers")
        if parameter is not None and parameter != workers:
            raise UsageError(f"--workers {workers} and -p WORKERS={parameter} disagree (the same setting)")
        return workers
    if parameter is not None:
        return parameter                       # checked by check_notebook with the notebook's rule
    from mmlib.experiment.executors import default_workers
    try:
        return default_workers()               # $WORKERS, else every core
    except ValueError as exc:
        raise UsageError(str(exc)) from None


#: the notebook parameters of the reading space: a notebook without one (the arena) declares none of them, and is
#: left out of a run of every notebook that sets one (named on the command line, it is an error)
READING_SPACE_PARAMS = ("MULTIVERSE_RUNS", "MULTIVERSE_DESIGN", "MULTIVERSE_UNIVERSES")


def notebook_settings(src: Path, profile: str, params: dict) -> str:
    """One line of the settings a notebook runs with: its headline's Monte Carlo runs and seed, and its reading
    space's runs per universe, each with where it comes from and how to change it (the paper of the registry
    ``mmlib.papers`` the notebook's name starts with; a notebook of no registered paper shows the overrides only)."""
    from mmlib.experiment.notebook import NotebookRun
    from mmlib.experiment.paper import Paper
    from mmlib.papers import REGISTRY
    paper = REGISTRY.get(src.stem.split("_")[0])
    if not isinstance(paper, Paper) or profile not in paper.profiles:
        given = ", ".join(f"{k}={v}" for k, v in params.items())
        return f"  {src.stem}: {given or 'the notebook defaults'} (no reading space of a registered paper)"
    accepted = inspect.signature(NotebookRun).parameters
    run = NotebookRun(paper, PROFILE=profile, **{k: v for k, v in params.items() if k in accepted})

    def origin(name: str, default: str) -> str:
        return "-p" if name in params else default

    own_seed = "the paper's root seed"
    # the profile's mv_runs, else the headline's runs (NotebookRun's rule): whether N_RUNS moves them
    follows = "N_RUNS leaves it alone" if "mv_runs" in paper.profiles[profile] else "else it follows N_RUNS"
    return (f"  {src.stem}: N_RUNS={run.n_runs} ({origin('N_RUNS', 'profile ' + profile)}), SEED={run.seed} "
            f"({origin('SEED', own_seed)}); reading space: {run.mv_runs} runs per universe "
            f"({origin('MULTIVERSE_RUNS', 'profile ' + profile)}; change with MULTIVERSE_RUNS=, {follows}), "
            f"design {run.mv_design}")


def settings_header(sources: list[Path], profile: str, params: dict, layout: Layout, workers: int, scheduler: str,
                    verbose: bool) -> list[str]:
    """The header of a run: every setting in force (profile, notebooks, overrides and where the outputs go,
    workers, scheduler, progress detail), then one line per notebook (:func:`notebook_settings`)."""
    overrides = ", ".join(f"{k}={v}" for k, v in params.items()) or "none"
    lines = [f"settings: profile={profile}; notebooks: {', '.join(s.stem for s in sources) or 'none'}; "
             f"overrides: {overrides} (outputs: {layout.destination}); workers: {workers}; scheduler: "
             f"{scheduler or 'none (local processes)'}; progress: "
             + ("every universe with its levels (-v)" if verbose else "universe k/N and time left (-v: the levels)")]
    return lines + [notebook_settings(src, profile, params) for src in sources]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--profile", default="full", choices=PROFILES)
    ap.add_argument("--timeout", type=int, default=3600,
                    help="seconds per cell (positive; the arena's study cell is the longest)")
    ap.add_argument("-p", "--param", action="append", default=[], metavar="NAME=VALUE",
                    help="notebook parameter (value parsed as Python literal, else string); "
                         "outputs then go to build/custom/<profile>-<NAME=VALUE...>/")
    ap.add_argument("--root", default=str(REPO),
                    help="repository root holding notebooks/ and receiving the outputs (default: this repository)")
    ap.add_argument("--workers", default=None, metavar="N",
                    help="worker processes in all (default $WORKERS, else every core); an execution setting: the "
                         "outputs go where they would without it")
    ap.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="Dask scheduler (tcp://host:8786) receiving the Monte Carlo chunks and universes (default "
                         "$MMLIB_SCHEDULER); an execution setting")
    ap.add_argument("-v", "--verbose", action="store_true",
                    help="progress: every universe of a reading space with its levels (default: universe k/N and the "
                         "time left, at most every 15 s)")
    ap.add_argument("--recover", action="store_true",
                    help="only finish an interrupted promotion and remove leftovers (every run does this first)")
    ap.add_argument("notebooks", nargs="*", help="paper names (zhu2016), notebook names or paths (default: all)")
    args = ap.parse_args(argv)
    root = Path(args.root).resolve()
    try:
        if not (root / "notebooks").is_dir():
            raise UsageError(f"--root {args.root}: no notebooks/ folder there")
        if args.timeout <= 0:
            raise UsageError(f"--timeout: expected a positive number of seconds, got {args.timeout}")
        if args.recover and (args.notebooks or args.param):
            raise UsageError("--recover: takes no notebooks and no -p parameters")
        params = parse_params(args.param)
        # execution settings are checked with the notebook's rules, then taken out of the results-changing ones
        settings = {k: params.pop(k) for k in list(params) if k in EXECUTION_PARAMS}
        layout = layout_for(root, args.profile, params)
        sources, left_out = [], []
        for src in [] if args.recover else resolve_notebooks(root, args.notebooks):
            declared = declared_parameters(src)
            no_space = [k for k in params if k in READING_SPACE_PARAMS and k not in declared]
            if no_space and not args.notebooks:
                left_out.append(f"{src.stem} left out: it has no reading space ({', '.join(no_space)} do not apply)")
                continue
            check_notebook(src, {**params, **settings}, args.profile, layout, declared)
            sources.append(src)
        workers = execution_workers(args.workers, settings.get("WORKERS"))
        scheduler = (args.scheduler if args.scheduler is not None else os.environ.get("MMLIB_SCHEDULER", "")).strip()
        if scheduler and sources:
            check_scheduler(scheduler)
    except UsageError as exc:
        print(f"run_notebooks.py: error: {exc}\n  nothing was run or written.", file=sys.stderr)
        return 2
    logging.basicConfig(level=logging.WARNING, format="%(message)s")
    with runner_lock(root):
        for note in recover(root):
            print(f"recovery: {note}", flush=True)
        if args.recover:
            return 0
        for line in settings_header(sources, args.profile, params, layout, workers, scheduler, args.verbose) \
                + left_out:
            print(line, flush=True)
        if params:
            print(f"parameters {params} override the profile: outputs go to {layout.destination} "
                  f"(never over the committed or smoke outputs)", flush=True)
        alone = [src for src in sources if is_exclusive(src)]
        sources = [src for src in sources if src not in alone]
        jobs, kernel_workers = parallel_plan(workers, len(sources) or 1)
        times = recorded_times(root)
        ordered = lane_order(sources, jobs, times)
        if ordered != sources:
            print(f"order: {', '.join(s.stem for s in ordered)}, planned from the wall times of the last full run "
                  f"({TIMES_FILE.as_posix()}), at which its lanes end after "
                  f"{makespan([times[s.stem] for s in ordered], jobs):.0f} s instead of "
                  f"{makespan([times[s.stem] for s in sources], jobs):.0f} s in the given order", flush=True)
            sources = ordered
        # the kernels inherit this environment: their worker count, as many threads for the fused filter steps they
        # run themselves (mmlib.core.linalg.threads), and the scheduler (or none)
        os.environ["WORKERS"] = str(kernel_workers if sources else workers)
        os.environ.update(kernel_threads(kernel_workers if sources else workers))
        if scheduler:
            os.environ["MMLIB_SCHEDULER"] = scheduler
        else:
            os.environ.pop("MMLIB_SCHEDULER", None)
        from mmlib.experiment.grid import VERBOSE_ENV
        if args.verbose:            # -v asks for the levels; without it a user's own MMLIB_PROGRESS_VERBOSE stands
            os.environ[VERBOSE_ENV] = "1"
        print(f"execution: {workers} worker(s): "
              + (f"{jobs} notebook(s) at a time, WORKERS={kernel_workers} in each" if sources else "")
              + ("; then " if sources and alone else "")
              + (f"{', '.join(s.stem for s in alone)} with WORKERS={workers}"
                 + (" on the first lane to free once the others have started" if jobs > 1 and len(sources) > 1
                    else " after them" if sources else "") if alone else "")
              + (f"; Monte Carlo chunks and universes on the Dask scheduler at {scheduler}" if scheduler else ""),
              flush=True)
        try:
            return run_all(sources, layout, args.profile, params, args.timeout, jobs, alone, workers)
        finally:
            remove_empty_staging(root)


if __name__ == "__main__":
    sys.exit(main())
