"""The notebook runner (tools/run_notebooks.py): bad arguments are rejected before anything runs, overridden
settings never reach the committed outputs, and a run killed at any stage leaves each paper's outputs entirely old or
entirely new (after the runner's own recovery), with no leftover staging folder or temporary file.

The tests run the real runner as a subprocess against a throw-away repository root (``--root``) holding two tiny
notebooks written here, which declare the parameters of the paper notebooks and write a results file, a figure and a
line of output tagged with the paper and a *generation* ("old" or "new"): every output can then be classified.
Crashes are injected with the runner's hook (``RUN_NOTEBOOKS_FAULT``: ``os._exit`` at a named stage) and with real
SIGKILLs from outside (``RUN_NOTEBOOKS_PAUSE`` makes the runner wait at a stage, where the test kills it)."""
from __future__ import annotations

import importlib.util
import json
import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
RUNNER = REPO / "tools" / "run_notebooks.py"
PAPERS = {"alpha2001": "alpha2001_fake", "beta2002": "beta2002_fake"}    # paper -> notebook name
FAULT_EXIT = 99                                                           # run_notebooks.FAULT_EXIT
# journaled stages (the promotion is finished by recovery) and earlier ones (it is abandoned)
# (every single move is covered by test_recovery_killed_at_every_move_is_finished_by_the_next_one)
LATE_STAGES = ["journal", "rename#5", "promoted", "journal-removed"]
EARLY_STAGES = ["executed", "staged"]
N_MOVES = 10      # a promotion over existing outputs moves 5 old files aside and 5 new ones in

NOTEBOOK = '''# ---
# jupyter:
#   kernelspec:
#     display_name: mmlib (.venv)
#     language: python
#     name: mmlib
# ---

# %% tags=["parameters"]
PROFILE = "full"
N_RUNS = None
SEED = None
OUTPUT_ROOT = ""
N_TIMING_RUNS = None
WORKERS = None
MULTIVERSE_RUNS = None
MULTIVERSE_DESIGN = None
PROGRESS = True

# %%
import json, os, pathlib
PAPER, GENERATION = "{paper}", "{generation}"
if os.environ.get("FAKE_NOTEBOOK_FAILS") == PAPER:
    raise ValueError("deliberate failure")
if os.environ.get("FAKE_NOTEBOOK_BLOCKS") == PAPER:
    print("blocking", flush=True)
    if not open(os.environ["FAKE_NOTEBOOK_FIFO"]).read():   # the runner is SIGKILLed meanwhile: never write
        os._exit(1)
tag = PAPER + "-" + GENERATION
root = pathlib.Path(OUTPUT_ROOT)
(root / "figures" / PAPER).mkdir(parents=True)
(root / "figures" / PAPER / "fig01.png").write_text(tag)
doc = {{"paper": PAPER,
       "provenance": {{"profile": PROFILE, "n_runs": N_RUNS or 4, "root_seed": SEED or 0, "git_commit": "test",
                      "paper_citation": "test"}},
       "rows": [{{"item": "T1", "algorithm": "A", "quantity": "q", "paper": 1.0, "replicated": 1.0, "stderr": 0.1,
                 "verdict": "reproduced", "deviations": [], "note": tag, "distance": 0.0}}],
       "claims": [{{"key": "claim_" + tag.lower().replace("-", "_"), "claim": "claim " + tag, "verdict": "holds",
                   "decisive": "", "parts": [], "evidence": "e"}}],
       "figures": {{"fig01": {{"paper_claim": "c", "ours": tag, "files": ["figures/" + PAPER + "/fig01.png"]}}}}}}
(root / "data" / "results").mkdir(parents=True)
(root / "data" / "results" / (PAPER + ".json")).write_text(json.dumps(doc))
print("figure written to", root / "figures" / PAPER / "fig01.png")
print(tag)
from mmlib.experiment.montecarlo import say_progress
say_progress("progress of " + tag)
'''


def write_notebooks(root: Path, generation: str, papers=tuple(PAPERS)) -> None:
    (root / "notebooks").mkdir(parents=True, exist_ok=True)
    for paper in papers:
        (root / "notebooks" / f"{PAPERS[paper]}.py").write_text(NOTEBOOK.format(paper=paper, generation=generation))


def run(root: Path, *args, env=None, check=None) -> subprocess.CompletedProcess:
    """The runner on ``root`` (one worker, no MMLIB_THREADS of the caller's, extra environment ``env``); asserts the
    exit status ``check`` if given."""
    proc = subprocess.run([sys.executable, str(RUNNER), "--root", str(root), *args], capture_output=True, text=True,
                          env={**os.environ, "WORKERS": "1", "MMLIB_THREADS": "", **(env or {})}, timeout=600)
    if check is not None:
        assert proc.returncode == check, proc.stdout + proc.stderr
    return proc


def outputs(root: Path, paper: str) -> dict[str, Path]:
    """Every output a paper owns in the committed layout."""
    return {"results": root / "data" / "results" / f"{paper}.json", "figure": root / "figures" / paper / "fig01.png",
            "executed": root / "notebooks" / "executed" / f"{PAPERS[paper]}.ipynb",
            "report": root / "reports" / f"{paper}.md", "index": root / "reports" / "README.md"}


def generations(root: Path, paper: str) -> dict[str, str | None]:
    """The generation each output of ``paper`` comes from (None: missing, or from neither)."""
    def tag(path):
        text = path.read_text() if path.exists() else ""
        found = [g for g in ("old", "new") if f"{paper}-{g}" in text]
        return found[0] if len(found) == 1 else None
    return {what: tag(path) for what, path in outputs(root, paper).items()}


def assert_whole(root: Path, **expected: str) -> None:
    """Each paper's outputs all come from the expected generation, and its figures folder holds only its figure."""
    for paper, generation in expected.items():
        assert generations(root, paper) == dict.fromkeys(outputs(root, paper), generation), paper
        assert sorted(p.name for p in (root / "figures" / paper).iterdir()) == ["fig01.png"]


ALLOWED = re.compile(r"(notebooks/\w+\.py|notebooks/executed/\w+\.ipynb|data/results/\w+\.json"
                     r"|figures/\w+/fig01\.png|reports/\w+\.md|build/\.run_notebooks\.lock"
                     r"|build/[\w/=.-]+/converted/\w+\.ipynb|build/[\w/=.-]+/logs/\w+\.progress\.log)")


def assert_no_leftovers(root: Path) -> None:
    """Nothing under the root but sources, promoted outputs, converted inputs and the lock: no staging folder,
    journal, moved-aside old output or temporary file; and no machine-local path in an executed notebook."""
    files = [p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file()]
    assert [f for f in files if not ALLOWED.fullmatch(f)] == []
    assert [p for p in root.glob("build/**/staging/*")] == []
    assert [p for p in root.glob("build/**/staging")] == []          # not even an empty staging folder
    for nb in (root / "notebooks" / "executed").glob("*.ipynb"):
        assert str(root) not in nb.read_text() and "/staging/" not in nb.read_text(), nb


def snapshot(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def runner():
    """tools/run_notebooks.py as a module."""
    spec = importlib.util.spec_from_file_location("run_notebooks", RUNNER)
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("run_notebooks", module)     # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def base(tmp_path_factory) -> Path:
    """A root whose committed outputs come from a clean full run of both notebooks, generation "old"."""
    root = tmp_path_factory.mktemp("base") / "repo"
    write_notebooks(root, "old")
    run(root, check=0)
    assert_whole(root, alpha2001="old", beta2002="old")
    assert_no_leftovers(root)
    return root


@pytest.fixture
def repo(base, tmp_path) -> Path:
    """A fresh copy of the base root whose notebooks now produce generation "new"."""
    root = tmp_path / "repo"
    shutil.copytree(base, root)
    write_notebooks(root, "new")
    return root


# ------------------------------------------------------------------------------------------------- bad arguments
@pytest.mark.parametrize("args, message", [
    (["-p", "NRUNS=5", "alpha2001"], "-p NRUNS: not a parameter of this notebook; it declares N_RUNS, SEED"),
    (["-p", "N_RUNS=1", "alpha2001"], "-p N_RUNS: expected*got 1"),
    (["-p", "N_RUNS=-3", "alpha2001"], "-p N_RUNS: expected*got -3"),
    (["-p", "MULTIVERSE_RUNS=1", "alpha2001"], "-p MULTIVERSE_RUNS: expected*got 1"),
    (["-p", "SEED=seven", "alpha2001"], "-p SEED: expected*got 'seven'"),
    (["-p", "WORKERS=0", "alpha2001"], "-p WORKERS: expected*got 0"),
    (["-p", "MULTIVERSE_DESIGN=stars", "alpha2001"], "-p MULTIVERSE_DESIGN: expected*got 'stars'"),
    (["-p", "PROGRESS=3", "alpha2001"], "-p PROGRESS: expected True or False, got 3"),
    (["-p", "PROFILE=smoke"], "-p PROFILE: set by the runner (use --profile)"),
    (["-p", "OUTPUT_ROOT=/tmp"], "-p OUTPUT_ROOT: set by the runner"),
    (["-p", "N_RUNS"], "-p 'N_RUNS': expected NAME=VALUE"),
    (["-p", "N_RUNS=3", "-p", "N_RUNS=4"], "-p N_RUNS: given twice"),
    (["gamma2003"], "notebook 'gamma2003': unknown; known papers: alpha2001, beta2002"),
    (["nowhere/gamma.py"], "notebook 'nowhere/gamma.py': no such file"),
    (["OUTSIDE"], "not a notebook source of this repository"),
    (["--timeout", "0"], "--timeout: expected a positive number of seconds"),
    (["--recover", "alpha2001"], "--recover: takes no notebooks"),
])
def test_bad_argument_is_rejected_by_name_before_anything_runs(runner, base, tmp_path, capsys, args, message):
    """In process (the checks run before anything is written, so no subprocess is needed).  ``message``: the
    fragments between '*' appear in this order on one line of the error (the value rules' wording is NotebookRun's)."""
    root = tmp_path / "repo"
    shutil.copytree(base, root)
    outside = tmp_path / "alpha2001_variant.py"          # a notebook source outside root/notebooks/
    outside.write_text((root / "notebooks" / "alpha2001_fake.py").read_text())
    args = [str(outside) if a == "OUTSIDE" else a for a in args]
    before = snapshot(root)
    assert runner.main(["--root", str(root), *args]) == 2
    out, err = capsys.readouterr()
    assert re.search(".*".join(map(re.escape, message.split("*"))), err), err
    assert "nothing was run or written" in err and "executing" not in out
    assert snapshot(root) == before


def test_notebook_that_declares_no_output_root_is_rejected(repo):
    """Papermill would inject OUTPUT_ROOT anyway and the notebook would write straight into the outputs."""
    src = repo / "notebooks" / "alpha2001_fake.py"
    src.write_text(src.read_text().replace('OUTPUT_ROOT = ""\n', ""))
    proc = run(repo, "alpha2001", check=2)
    assert "notebooks/alpha2001_fake.py: declares no OUTPUT_ROOT parameter" in proc.stderr


# ---------------------------------------------------------------------------------------------------- overrides
def test_overridden_run_goes_to_its_own_folder_never_over_committed_outputs(repo):
    committed = snapshot(repo)
    proc = run(repo, "--profile", "full", "-p", "N_RUNS=3", "-p", "SEED=7", str(repo / "notebooks" /
                                                                             "alpha2001_fake.py"), check=0)
    custom = repo / "build" / "custom" / "full-N_RUNS=3-SEED=7"
    assert "build/custom/full-N_RUNS=3-SEED=7" in proc.stdout
    assert {k: v for k, v in snapshot(repo).items() if not k.startswith("build/")} == \
        {k: v for k, v in committed.items() if not k.startswith("build/")}
    doc = json.loads((custom / "data" / "results" / "alpha2001.json").read_text())
    assert doc["provenance"]["n_runs"] == 3 and doc["provenance"]["root_seed"] == 7
    for rel in ("figures/alpha2001/fig01.png", "executed/alpha2001_fake.ipynb", "reports/alpha2001.md"):
        assert "alpha2001-new" in (custom / rel).read_text(), rel
    index = (custom / "reports" / "README.md").read_text()
    assert "alpha2001-new" in index and "beta2002" not in index      # the folder's own papers only
    assert not (custom / "staging").exists()


def test_progress_goes_to_the_runners_log_not_into_the_executed_notebook(repo):
    """The kernel's progress lines (mmlib's say_progress) reach the runner's stderr and its log file; the executed
    notebook, which is published, has no stderr output."""
    proc = run(repo, "alpha2001", check=0)
    assert "progress of alpha2001-new" in proc.stderr
    log = next((repo / "build").glob("*/logs/alpha2001_fake.progress.log"))
    assert log.read_text() == "progress of alpha2001-new\n"
    nb = json.loads((repo / "notebooks" / "executed" / "alpha2001_fake.ipynb").read_text())
    streams = [o.get("name") for c in nb["cells"] for o in c.get("outputs", [])]
    assert "stdout" in streams and "stderr" not in streams


# --------------------------------------------------------------------------------------------- kills and recovery
@pytest.mark.parametrize("stage", EARLY_STAGES + LATE_STAGES)
def test_killed_at_each_stage_leaves_each_paper_entirely_old_or_new(repo, stage):
    """os._exit at each stage of alpha's run; the next invocation's recovery completes a journaled promotion and
    abandons an unjournaled one, and removes every leftover."""
    proc = run(repo, "alpha2001", env={"RUN_NOTEBOOKS_FAULT": stage}, check=FAULT_EXIT)
    assert f"fault injection: exiting at {stage if '#' in stage else stage + '#1'}" in proc.stdout
    expected = "old" if stage in EARLY_STAGES else "new"
    if stage in EARLY_STAGES + ["journal-removed"]:
        assert_whole(repo, alpha2001=expected, beta2002="old")      # already whole before any recovery
    proc = run(repo, "--recover", check=0)
    assert ("finished the interrupted promotion of alpha2001" in proc.stdout) == (expected == "new"
                                                                                 and stage != "journal-removed")
    assert_whole(repo, alpha2001=expected, beta2002="old")
    assert_no_leftovers(repo)


@pytest.fixture(scope="module")
def journaled(base, tmp_path_factory) -> Path:
    """A root where alpha's run died right after its journal was written (nothing moved yet)."""
    root = tmp_path_factory.mktemp("journaled") / "repo"
    shutil.copytree(base, root)
    write_notebooks(root, "new")
    run(root, "alpha2001", env={"RUN_NOTEBOOKS_FAULT": "journal"}, check=FAULT_EXIT)
    return root


@pytest.mark.parametrize("move", range(1, N_MOVES + 1))
def test_recovery_killed_at_every_move_is_finished_by_the_next_one(journaled, tmp_path, move):
    """The promotion is killed before, between and after each of its moves (inside recovery, which runs the same
    promotion code), and a second recovery completes it: the promotion is idempotent at every point."""
    root = tmp_path / "repo"
    shutil.copytree(journaled, root)
    run(root, "--recover", env={"RUN_NOTEBOOKS_FAULT": f"rename#{move}"}, check=FAULT_EXIT)
    run(root, "--recover", check=0)
    assert_whole(root, alpha2001="new", beta2002="old")
    assert_no_leftovers(root)


def test_kill_after_one_paper_leaves_it_whole_and_new_reports_included(repo):
    """Killed while the second notebook runs: the first paper is entirely new, its report and its line of the
    cross-paper README included; the second entirely old."""
    run(repo, env={"RUN_NOTEBOOKS_FAULT": "executed#2"}, check=FAULT_EXIT)
    assert_whole(repo, alpha2001="new", beta2002="old")
    run(repo, "--recover", check=0)
    assert_whole(repo, alpha2001="new", beta2002="old")
    assert_no_leftovers(repo)


def start_until(root: Path, marker: str, *args, env=None) -> subprocess.Popen:
    """Start the runner and return once it prints a line starting with ``marker``."""
    proc = subprocess.Popen([sys.executable, str(RUNNER), "--root", str(root), *args], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True,
                            env={**os.environ, "WORKERS": "1", **(env or {})})
    seen = []
    for line in proc.stdout:
        seen.append(line)
        if line.startswith(marker):
            return proc
    proc.wait()
    pytest.fail(f"the runner never printed {marker!r}:\n" + "".join(seen))


def sigkill(proc: subprocess.Popen) -> None:
    os.kill(proc.pid, signal.SIGKILL)
    assert proc.wait() == -signal.SIGKILL
    proc.stdout.close()


def test_sigkill_inside_promotion_is_finished_by_the_next_run(repo):
    """A real SIGKILL from outside between two moves of alpha's promotion; the next ordinary run (of beta) first
    finishes alpha's promotion, then runs beta: both end entirely new, the README describing both."""
    sigkill(start_until(repo, "fault injection: paused at rename#3", "alpha2001",
                        env={"RUN_NOTEBOOKS_PAUSE": "rename#3"}))
    mixed = generations(repo, "alpha2001")      # mid-promotion: results moved in, figures moved aside only
    assert (mixed["results"], mixed["figure"], mixed["report"]) == ("new", None, "old")
    proc = run(repo, "beta2002", check=0)
    assert "recovery: finished the interrupted promotion of alpha2001" in proc.stdout
    assert_whole(repo, alpha2001="new", beta2002="new")
    assert_no_leftovers(repo)


def test_sigkill_while_notebook_executes_leaves_old_outputs(repo, tmp_path):
    """A real SIGKILL from outside while the notebook's kernel is busy: the committed outputs were never touched,
    and recovery removes the staging folder."""
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    proc = start_until(repo, "blocking", "alpha2001", env={"FAKE_NOTEBOOK_BLOCKS": "alpha2001",
                                                           "FAKE_NOTEBOOK_FIFO": str(fifo)})
    sigkill(proc)
    try:                                  # release the orphaned kernel, which then exits without writing
        os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
    except OSError:
        pass                              # it had not opened the FIFO yet, or already exited (its parent died)
    assert_whole(repo, alpha2001="old", beta2002="old")
    assert [p.name for p in (repo / "build" / "full" / "staging").iterdir()] == ["alpha2001_fake"]
    proc = run(repo, "--recover", check=0)
    assert "removed the leftover staging folder build/full/staging/alpha2001_fake" in proc.stdout
    assert_whole(repo, alpha2001="old", beta2002="old")
    assert_no_leftovers(repo)


def test_failed_notebook_names_notebook_and_cell_and_promotes_nothing(repo):
    before = snapshot(repo)
    proc = run(repo, "alpha2001_fake", env={"FAKE_NOTEBOOK_FAILS": "alpha2001"}, check=1)
    assert "FAILED: notebook notebooks/alpha2001_fake.py, cell" in proc.stderr
    assert "ValueError: deliberate failure" in proc.stderr
    assert "partial output kept for inspection: build/full/failed/alpha2001_fake.ipynb" in proc.stderr
    after = snapshot(repo)
    # the runner's own working files (converted inputs, progress logs) aside, nothing changed
    assert {k: v for k, v in after.items() if not any(w in k for w in ("/failed/", "/converted/", "/logs/"))} == \
        {k: v for k, v in before.items() if not any(w in k for w in ("/converted/", "/logs/"))}
    assert [p for p in repo.glob("build/**/staging/*")] == []


def test_notebook_writing_another_papers_results_promotes_nothing(repo):
    """A notebook whose file name says alpha2001 but which writes beta2002's results would replace beta2002's
    results beside alpha2001's executed notebook: rejected before promotion."""
    before = snapshot(repo)
    src = repo / "notebooks" / "alpha2001_fake.py"
    src.write_text(src.read_text().replace('PAPER, GENERATION = "alpha2001"', 'PAPER, GENERATION = "beta2002"'))
    proc = run(repo, "alpha2001", check=1)
    assert "wrote the results of paper 'beta2002', but its file name says 'alpha2001'" in proc.stderr
    after = snapshot(repo)
    assert {k: v for k, v in after.items() if not k.startswith("build/") and not k.startswith("notebooks/")} == \
        {k: v for k, v in before.items() if not k.startswith("build/") and not k.startswith("notebooks/")}


# ------------------------------------------------------------------------------------------------------- make
def test_make_figures_passes_paper_runs_and_seed_to_the_runner():
    """``make -n`` prints the command without running it."""
    proc = subprocess.run(["make", "-n", "-C", str(REPO), "figures", "PAPER=zhu2016", "N_RUNS=500", "SEED=7"],
                          capture_output=True, text=True, timeout=60, check=True)
    line = next(li for li in proc.stdout.splitlines() if "run_notebooks.py" in li)
    assert line.split("run_notebooks.py", 1)[1].split() == ["--profile", "full", "-p", "N_RUNS=500", "-p", "SEED=7",
                                                           "zhu2016"]


def test_recovery_removes_leftover_temporary_files(repo):
    """Temporary files of an interrupted write (an old figure folder moved aside, a figure or results file being
    written atomically, a report being rendered) are removed by the next run; promoted outputs are kept."""
    leftovers = [repo / "figures" / ".alpha2001.old" / "fig01.png", repo / "figures" / "alpha2001" / ".fig01.x.png",
                 repo / "data" / "results" / ".alpha2001.json.tmp", repo / "reports" / ".alpha2001.md.tmp"]
    for path in leftovers:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("partial")
    kept = snapshot(repo)
    proc = run(repo, "--recover", check=0)
    for path in leftovers:
        assert not path.exists(), (path, proc.stdout)
    assert not (repo / "figures" / ".alpha2001.old").exists()
    assert {k: v for k, v in snapshot(repo).items()} == \
        {k: v for k, v in kept.items() if not any(k == str(p.relative_to(repo)) for p in leftovers)}


# ------------------------------------------------------------------------------------------------ what a run says
def test_header_states_every_setting_and_the_reading_space_runs(runner):
    """A registered paper's line: the headline's runs and seed and the reading space's runs per universe, each with
    its origin, and how to change the latter (N_RUNS does not)."""
    from mmlib.papers import REGISTRY
    src = REPO / "notebooks" / "hu2017_immcdkf_obs.py"
    profile = REGISTRY["hu2017"].profiles["full"]
    line = runner.notebook_settings(src, "full", {"N_RUNS": 7})
    assert "N_RUNS=7 (-p)" in line
    assert f"reading space: {profile['mv_runs']} runs per universe (profile full;" in line
    assert "MULTIVERSE_RUNS=" in line
    line = runner.notebook_settings(src, "full", {"MULTIVERSE_RUNS": 9})
    assert f"N_RUNS={profile['n_runs']} (profile full)" in line and "9 runs per universe (-p;" in line
    layout = runner.layout_for(REPO, "full", {"N_RUNS": 7})
    head = runner.settings_header([src], "full", {"N_RUNS": 7}, layout, 3, "", False)
    assert head[0].startswith("settings: profile=full; notebooks: hu2017_immcdkf_obs; overrides: N_RUNS=7")
    assert "workers: 3" in head[0] and "scheduler: none" in head[0] and "build/custom/" in head[0]
    assert str(REPO) not in "".join(head)                           # no machine-local path


def test_reading_space_parameter_leaves_out_notebooks_without_one_and_verbose_reaches_the_kernels(repo):
    """-p MULTIVERSE_RUNS over every notebook: one without a reading space is left out with a note (named, it is an
    error); -v sets MMLIB_PROGRESS_VERBOSE=1 for the kernels; the run leaves no staging folder."""
    src = repo / "notebooks" / "beta2002_fake.py"
    src.write_text(src.read_text().replace("MULTIVERSE_RUNS = None\n", ""))
    alpha = repo / "notebooks" / "alpha2001_fake.py"
    alpha.write_text(alpha.read_text() + '\nprint("verbose=" + os.environ.get("MMLIB_PROGRESS_VERBOSE", ""))\n')
    proc = run(repo, "-v", "-p", "MULTIVERSE_RUNS=3", check=0)
    assert "beta2002_fake left out: it has no reading space (MULTIVERSE_RUNS do not apply)" in proc.stdout
    assert "verbose=1" in proc.stdout and "beta2002" not in proc.stdout.split("left out")[1]
    assert re.search(r"^settings: profile=full; notebooks: alpha2001_fake; overrides: MULTIVERSE_RUNS=3",
                     proc.stdout, re.M), proc.stdout
    assert not list(repo.glob("build/**/staging"))
    assert "without encryption" not in proc.stderr               # the kernels get CurveZMQ keys: no warning
    assert str(repo) not in proc.stdout + proc.stderr               # relative paths only
    named = run(repo, "-p", "MULTIVERSE_RUNS=3", "beta2002", check=2)
    assert "-p MULTIVERSE_RUNS: not a parameter of this notebook" in named.stderr
    quiet = run(repo, "alpha2001", check=0, env={"MMLIB_PROGRESS_VERBOSE": ""})
    assert "verbose=\n" in quiet.stdout and "verbose=1" not in quiet.stdout
    # without -v a user's own MMLIB_PROGRESS_VERBOSE stands (the runner sets it only for -v)
    own = run(repo, "alpha2001", check=0, env={"MMLIB_PROGRESS_VERBOSE": "1"})
    assert "verbose=1" in own.stdout


# ------------------------------------------------------------------------------------------------------- imports
def _format_keywords(node, where="#") -> list[str]:
    """Where a JSON Schema uses the "format" keyword (a string value; a property *named* format is a schema)."""
    found = []
    if isinstance(node, dict):
        if isinstance(node.get("format"), str):
            found.append(where)
        for key, value in node.items():
            found += _format_keywords(value, f"{where}/{key}")
    elif isinstance(node, list):
        for i, value in enumerate(node):
            found += _format_keywords(value, f"{where}/{i}")
    return found


def test_the_runner_leaves_out_an_import_no_check_it_makes_needs():
    """The runner's process never imports what :data:`SKIPPED_IMPORTS` names (rfc3987_syntax: 1.4 s of grammar
    compilation per process, used by jsonschema only to check the "iri" formats), yet papermill, nbformat and
    jsonschema import and validate a notebook; and that is safe because no schema of nbformat, which the runner
    validates notebooks with, uses the "format" keyword at all."""
    code = (f"import runpy, sys; runpy.run_path({str(RUNNER)!r}, run_name='runner'); import papermill, nbformat; "
            "nbformat.validate(nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell('1')])); "
            "print(sorted(n for n in ('rfc3987_syntax', 'lark') if sys.modules.get(n) is not None), "
            "'jsonschema' in sys.modules)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=REPO)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["[]", "True"], proc.stdout
    import nbformat
    schemas = sorted(Path(nbformat.__file__).parent.glob("v*/nbformat.v*.schema.json"))
    assert len(schemas) >= 8, schemas
    used = {p.name: _format_keywords(json.loads(p.read_text())) for p in schemas}
    assert not any(used.values()), {k: v for k, v in used.items() if v}
