"""The notebook runner's execution settings and parallel notebooks: WORKERS and SCHEDULER reach the kernels'
environment without sending the outputs to build/custom/; independent notebooks execute at the same time while each
paper's promotion stays whole (one at a time, so the last cross-paper README describes every paper); bad settings are
rejected by name before anything runs.  Uses the throw-away roots and fake notebooks of tests/test_runner.py."""
from __future__ import annotations

import itertools
import json
import re
import socket
import subprocess
import threading
import time

import pytest
from test_runner import (REPO, assert_no_leftovers, assert_whole, base, generations, repo, run,  # noqa: F401
                         runner, sigkill, snapshot, start_until)

from mmlib.experiment import executors

ENV_CELL = '''
# %%
import os
print("kernel env: WORKERS=" + os.environ.get("WORKERS", "")
      + " MMLIB_THREADS=" + os.environ.get("MMLIB_THREADS", "")
      + " MMLIB_SCHEDULER=" + os.environ.get("MMLIB_SCHEDULER", ""))
'''


def report_environment(root) -> None:
    """Make every fake notebook print the execution settings its kernel sees."""
    for src in (root / "notebooks").glob("*.py"):
        src.write_text(src.read_text() + ENV_CELL)


def test_make_passes_workers_and_scheduler_as_execution_settings():
    proc = subprocess.run(["make", "-n", "-C", str(REPO), "figures", "PAPER=zhu2016", "WORKERS=1",
                           "SCHEDULER=tcp://host:8786"], capture_output=True, text=True, timeout=60, check=True)
    line = next(li for li in proc.stdout.splitlines() if "run_notebooks.py" in li)
    assert line.split("run_notebooks.py", 1)[1].split() == ["--profile", "full", "--workers", "1", "--scheduler",
                                                           "tcp://host:8786", "zhu2016"]


def test_parallel_plan_divides_the_workers_among_the_notebooks_at_once(runner):  # noqa: F811 -- fixtures of test_runner
    """(notebooks at once, WORKERS of each kernel): the split measured best on 2 cores is 2 notebooks with 1 each."""
    assert runner.parallel_plan(2, 5) == (2, 1)
    assert runner.parallel_plan(1, 5) == (1, 1)
    assert runner.parallel_plan(4, 1) == (1, 4)
    assert runner.parallel_plan(8, 5) == (5, 2)
    assert runner.parallel_plan(6, 2) == (2, 3)


def test_makespan_is_when_the_last_lane_frees(runner):  # noqa: F811 -- fixtures of test_runner
    """Each notebook starts, in order, on the first lane to free (run_all's thread pool): the order matters."""
    assert runner.makespan([3.0, 2.0, 2.0], 2) == 4.0          # 3 | 2 + 2
    assert runner.makespan([2.0, 2.0, 3.0], 2) == 5.0          # 2 + 3 | 2
    assert runner.makespan([2.0, 2.0, 3.0], 1) == 7.0
    assert runner.makespan([5.0], 3) == 5.0 and runner.makespan([], 2) == 0.0


def test_lane_order_ends_as_soon_as_the_best_split_of_the_recorded_times(runner, tmp_path):  # noqa: F811
    """The six notebooks' wall times of a full run (2026-12-04): the given (alphabetical) order ends 53 s after the
    best; the planned order ends when the best split into two lanes does (checked against every split, not every
    order); the given order is kept when it is as good, when one lane runs everything, when a notebook has no
    recorded time; beyond EXHAUSTIVE notebooks, longest first."""
    times = {"controls": 22.6, "hu2017_x": 152.9, "liu2017_x": 208.2, "tseng2011_x": 271.1, "zhou2017_x": 211.7,
             "zhu2016_x": 130.8}
    given = [tmp_path / f"{stem}.py" for stem in times]
    order = runner.lane_order(given, 2, times)
    assert sorted(order) == sorted(given)
    total = sum(times.values())
    best_split = min(max(sum(t for t, keep in zip(times.values(), mask) if keep),
                         sum(t for t, keep in zip(times.values(), mask) if not keep))
                     for mask in itertools.product((True, False), repeat=len(times)))
    planned = runner.makespan([times[p.stem] for p in order], 2)
    assert planned == pytest.approx(best_split) and planned < runner.makespan(list(times.values()), 2) - 50
    assert total / 2 <= planned
    assert runner.lane_order(order, 2, times) == order                   # already the best: kept
    assert runner.lane_order(given, 1, times) == given
    assert runner.lane_order(given, 2, {k: v for k, v in times.items() if k != "controls"}) == given
    many = [tmp_path / f"n{i}.py" for i in range(runner.EXHAUSTIVE + 1)]
    many_times = {p.stem: float(i % 4) + 1 for i, p in enumerate(many)}
    assert [many_times[p.stem] for p in runner.lane_order(many, 2, many_times)] == sorted(many_times.values(),
                                                                                           reverse=True)


def test_recorded_times_are_the_last_full_runs_freshly_computed_notebooks(runner, tmp_path):  # noqa: F811
    """From data/bench/notebooks.json: papers and studies by notebook stem; a notebook that read universes from the
    multiverse cache, or has no usable wall time, is left out; a missing or unreadable file gives none."""
    assert runner.recorded_times(tmp_path) == {}
    path = tmp_path / runner.TIMES_FILE
    path.parent.mkdir(parents=True)
    path.write_text("{not json")
    assert runner.recorded_times(tmp_path) == {}
    path.write_text(json.dumps({
        "papers": {"a": {"notebook": "a_one.ipynb", "wall_s": 10.5, "universes_from_cache": 0},
                   "b": {"notebook": "b_two.ipynb", "wall_s": 3.0, "universes_from_cache": 12},
                   "c": {"notebook": "c_three.ipynb", "wall_s": None}},
        "studies": {"arena": {"notebook": "arena.ipynb", "wall_s": 400.0, "universes_from_cache": None}}}))
    assert runner.recorded_times(tmp_path) == {"a_one": 10.5, "arena": 400.0}


def test_the_runner_starts_the_notebooks_in_the_planned_order(repo):  # noqa: F811 -- fixtures of test_runner
    """Three notebooks on two lanes with recorded times 2, 2 and 3 s: in the given order the 3 s one starts last
    and the lanes end at 5 s; planned, it starts with the first (the first best order: 2 + 2 | 3, ending at 4 s),
    the runner says so, and every paper is promoted whole."""
    src = (repo / "notebooks" / "alpha2001_fake.py").read_text()
    (repo / "notebooks" / "gamma2003_fake.py").write_text(src.replace('"alpha2001"', '"gamma2003"'))
    times = repo / "data" / "bench" / "notebooks.json"
    times.parent.mkdir(parents=True)
    times.write_text(json.dumps({"papers": {
        p: {"notebook": f"{p}_fake.ipynb", "wall_s": w, "universes_from_cache": 0}
        for p, w in (("alpha2001", 2.0), ("beta2002", 2.0), ("gamma2003", 3.0))}}))
    proc = run(repo, "--workers", "2", check=0)
    lines = proc.stdout.splitlines()
    assert "order: alpha2001_fake, gamma2003_fake, beta2002_fake, planned from the wall times of the last full run " \
           "(data/bench/notebooks.json), at which its lanes end after 4 s instead of 5 s in the given order" in lines
    started = [ln.split(":")[0] for ln in lines if ": executing " in ln]      # the first two start together
    assert set(started[:2]) == {"[1/3] alpha2001_fake", "[2/3] gamma2003_fake"} and started[2] == "[3/3] beta2002_fake"
    assert_whole(repo, alpha2001="new", beta2002="new")
    assert "gamma2003-new" in (repo / "data" / "results" / "gamma2003.json").read_text()


def test_notebooks_execute_at_once_and_each_promotion_is_whole(repo):  # noqa: F811 -- fixtures of test_runner
    report_environment(repo)
    proc = run(repo, "--workers", "2", check=0)
    lines = proc.stdout.splitlines()
    assert "execution: 2 worker(s): 2 notebook(s) at a time, WORKERS=1 in each" in lines
    for stem in ("alpha2001_fake", "beta2002_fake"):
        assert sum(bool(re.fullmatch(rf"\[\d/2\] {stem}: executing .*", ln)) for ln in lines) == 1
        assert sum(bool(re.fullmatch(rf"\[\d/2\] {stem}: done in \d+\.\d s -> .*", ln)) for ln in lines) == 1
        assert f"[{stem}] kernel env: WORKERS=1 MMLIB_THREADS=1 MMLIB_SCHEDULER=" in lines  # its environment, prefixed
    first_done = next(i for i, ln in enumerate(lines) if ": done in " in ln)
    assert sum(": executing " in ln for ln in lines[:first_done]) == 2          # both started before either ended
    assert_whole(repo, alpha2001="new", beta2002="new")                         # the last README has both papers
    assert_no_leftovers(repo)


def test_workers_never_send_the_outputs_to_custom(repo):  # noqa: F811 -- fixtures of test_runner
    report_environment(repo)
    proc = run(repo, "-p", "WORKERS=3", "alpha2001", check=0)
    assert "kernel env: WORKERS=3 MMLIB_THREADS=3 " in proc.stdout and "build/custom" not in proc.stdout
    assert not (repo / "build" / "custom").exists()
    assert_whole(repo, alpha2001="new", beta2002="old")
    # a user's own MMLIB_THREADS (make figures MMLIB_THREADS=1) stands
    proc = run(repo, "-p", "WORKERS=3", "alpha2001", env={"MMLIB_THREADS": "1"}, check=0)
    assert "kernel env: WORKERS=3 MMLIB_THREADS=1 " in proc.stdout


def test_a_failure_stops_no_running_notebook_and_promotes_nothing_of_itself(repo):  # noqa: F811 -- fixtures of test_runner
    proc = run(repo, "--workers", "2", env={"FAKE_NOTEBOOK_FAILS": "alpha2001"}, check=1)
    assert "FAILED: notebook notebooks/alpha2001_fake.py, cell" in proc.stderr
    assert_whole(repo, alpha2001="old", beta2002="new")      # beta's README carries alpha's current (old) line


def test_killed_during_parallel_promotion_leaves_each_paper_whole(repo):  # noqa: F811 -- fixtures of test_runner
    """Killed with one paper's promotion journaled while the other notebook runs or waits for its turn: recovery
    finishes the one journaled promotion (there is never more than one) and abandons the other."""
    sigkill(start_until(repo, "fault injection: paused at journal", "--workers", "2",
                        env={"RUN_NOTEBOOKS_PAUSE": "journal"}))
    run(repo, "--recover", check=0)
    gens = {paper: set(generations(repo, paper).values()) for paper in ("alpha2001", "beta2002")}
    assert sorted(map(sorted, gens.values())) == [["new"], ["old"]], gens
    assert_no_leftovers(repo)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_bad_execution_settings_are_rejected_by_name_before_anything_runs(runner, repo, capsys, monkeypatch):  # noqa: F811 -- fixtures of test_runner
    monkeypatch.setattr(executors, "SCHEDULER_TIMEOUT", 3.0)
    address = f"tcp://127.0.0.1:{free_port()}"
    before = snapshot(repo)
    cases = [(["--workers", "0"], {}, "--workers: expected a positive integer (number of worker processes), got '0'"),
             (["--workers", "two"], {}, "--workers: expected a positive integer"),
             (["--workers", "-1"], {}, "--workers: expected a positive integer"),
             ([], {"WORKERS": "1.5"}, "WORKERS: expected a positive integer (number of worker processes), got '1.5'"),
             (["-p", "WORKERS=0"], {}, "-p WORKERS: expected an integer >= 1 or None, got 0"),
             (["--workers", "2", "-p", "WORKERS=3"], {}, "--workers 2 and -p WORKERS=3 disagree"),
             (["--scheduler", address], {}, f"--scheduler {address}: no Dask scheduler answered at {address} "
                                            f"within 3 s")]
    for args, env, message in cases:
        for key, value in env.items():
            monkeypatch.setenv(key, value)
        t0 = time.monotonic()
        assert runner.main(["--root", str(repo), *args, "alpha2001"]) == 2, args
        assert time.monotonic() - t0 < 3.0 + 5.0
        out, err = capsys.readouterr()
        assert message in err and "nothing was run or written" in err and "executing" not in out, (args, err)
        for key in env:
            monkeypatch.delenv(key)
    assert snapshot(repo) == before


def test_an_exclusive_notebook_runs_after_the_others_with_every_worker(repo):  # noqa: F811 -- fixtures of test_runner
    """A notebook marked ``# mmlib-runner: exclusive`` (the arena) starts after the others (here one, on one lane: it
    ends first), and its kernel gets all the workers, not a share."""
    report_environment(repo)
    src = repo / "notebooks" / "alpha2001_fake.py"
    src.write_text(src.read_text() + "\n# %% [markdown]\n# mmlib-runner: exclusive\n")
    proc = run(repo, "--workers", "2", check=0)
    lines = proc.stdout.splitlines()
    assert "execution: 2 worker(s): 1 notebook(s) at a time, WORKERS=2 in each; then alpha2001_fake with WORKERS=2 " \
           "after them" in lines
    beta_done = next(i for i, ln in enumerate(lines) if re.fullmatch(r"\[\d/2\] beta2002_fake: done in .*", ln))
    alpha_start = next(i for i, ln in enumerate(lines) if re.fullmatch(r"\[\d/2\] alpha2001_fake: executing .*", ln))
    assert alpha_start > beta_done                                    # after the others
    assert "kernel env: WORKERS=2 MMLIB_THREADS=2 MMLIB_SCHEDULER=" in proc.stdout    # every worker
    assert_whole(repo, alpha2001="new", beta2002="new")
    assert_no_leftovers(repo)


def test_an_exclusive_notebook_starts_on_the_first_lane_to_free_once_the_others_have_started(runner, tmp_path,  # noqa: F811
                                                                                              monkeypatch, capsys):
    """On two lanes, three notebooks (a long one) and two exclusive ones (run_one stubbed, timed): each exclusive
    notebook starts only once every other notebook has started, on the first lane to free, so before the long one
    ends (no core idles meanwhile), with its own WORKERS in its kernel's environment while the others inherit the
    runner's; the exclusive ones never run at the same time; a failure starts nothing after it."""
    events, lock = [], threading.Lock()
    seconds = {"long": 0.6, "a": 0.1, "b": 0.1, "x1": 0.5, "x2": 0.5}   # x2 is queued while x1 runs: the lock

    def fake_run_one(src, layout, profile, params, timeout, promotion_lock=None, stdout=None, stderr=None,
                     kernel_env=None):
        with lock:
            events.append(("start", src.stem, time.monotonic(), dict(kernel_env or {})))
        if src.stem == "fail":
            raise runner.NotebookFailed("cell 1: boom")
        time.sleep(seconds[src.stem])
        with lock:
            events.append(("end", src.stem, time.monotonic(), None))
        return []

    monkeypatch.setattr(runner, "run_one", fake_run_one)
    monkeypatch.setattr(runner, "USER_THREADS", "")                    # no MMLIB_THREADS of the caller's
    layout = runner.Layout(tmp_path, tmp_path, tmp_path, "executed")
    paths = {name: tmp_path / f"{name}.py" for name in seconds}
    assert runner.run_all([paths["long"], paths["a"], paths["b"]], layout, "full", {}, 60, 2,
                          [paths["x1"], paths["x2"]], 2) == 0
    at = {(kind, name): t for kind, name, t, _ in events}
    env = {name: e for kind, name, _, e in events if kind == "start"}
    started_all = max(at[("start", name)] for name in ("long", "a", "b"))
    first = min(("x1", "x2"), key=lambda name: at[("start", name)])
    second = "x2" if first == "x1" else "x1"
    assert started_all <= at[("start", first)] < at[("end", "long")]      # a core freed before the long one ended
    assert at[("start", second)] >= at[("end", first)]                    # one exclusive notebook at a time
    assert env["x1"] == env["x2"] == {"WORKERS": "2", "MMLIB_THREADS": "2"} and env["a"] == env["long"] == {}
    # after a failure nothing further starts, the exclusive notebooks included, on one lane and on two
    paths["fail"] = tmp_path / "fail.py"
    for jobs in (1, 2):
        events.clear()
        assert runner.run_all([paths["fail"], paths["a"], paths["b"]], layout, "full", {}, 60, jobs,
                              [paths["x1"]], 2) == 1
        started = [name for kind, name, _, _ in events if kind == "start"]
        assert started[0] == "fail" and "x1" not in started and "b" not in started
    capsys.readouterr()


def test_is_exclusive_reads_the_mark_on_a_line_of_its_own(runner, tmp_path):  # noqa: F811 -- fixtures of test_runner
    marked, mentioned = tmp_path / "a.py", tmp_path / "b.py"
    marked.write_text("# %%\nx = 1\n# mmlib-runner: exclusive\n")
    mentioned.write_text("# %%\nprint('# mmlib-runner: exclusive')\n")
    assert runner.is_exclusive(marked) and not runner.is_exclusive(mentioned)
