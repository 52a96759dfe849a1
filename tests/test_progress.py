"""The progress of a grid's reruns (mmlib.experiment.grid): ``universe k/N, ~T left``, the time left estimated from the
jobs finished so far, throttled to one line per interval (the first and the last always), the readings only in
verbose mode; and the one-time notice while the numba kernels compile."""
from __future__ import annotations

import re

import pytest

from mmlib.core import linalg
from mmlib.experiment import grid
from mmlib.experiment.grid import GridProgress, format_duration, progress_line

LINE = re.compile(r"^  \[(?P<tag>[^\]]+)\] (?P<unit>\w+) (?P<k>\d+)/(?P<n>\d+), "
                  r"(~(?P<left>[\d.]+ (s|min|h)) left|done in (?P<took>[\d.]+ (s|min|h)))")


class Clock:
    """A fake wall clock the test moves by hand."""

    def __init__(self):
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


@pytest.mark.parametrize("seconds, text", [(0, "0 s"), (40.4, "40 s"), (89, "89 s"), (90, "1.5 min"),
                                           (210, "3.5 min"), (1800, "30 min"), (5399, "90 min"), (5400, "1.5 h"),
                                           (4 * 3600, "4.0 h")])
def test_format_duration(seconds, text):
    assert format_duration(seconds) == text


@pytest.mark.parametrize("bad", [-1, float("nan"), float("inf"), "5", True])
def test_format_duration_rejects_bad_seconds(bad):
    with pytest.raises(ValueError, match="seconds"):
        format_duration(bad)


def test_line_format_and_time_left():
    """3 of 12 universes in 60 s: 20 s each, so 9 left take 180 s = 3.0 min."""
    line = progress_line("hu2017", "universe", 3, 12, 60.0)
    m = LINE.match(line)
    assert m and (m["tag"], m["unit"], m["k"], m["n"], m["left"]) == ("hu2017", "universe", "3", "12", "3.0 min")
    last = LINE.match(progress_line("hu2017", "universe", 12, 12, 240.0))
    assert last and last["took"] == "4.0 min" and last["left"] is None
    assert len(line) < 60                                       # a short line, not the reading's JSON


def test_line_rejects_done_beyond_total():
    with pytest.raises(ValueError, match="done"):
        progress_line("t", "universe", 13, 12, 1.0)


def test_throttled_to_one_line_per_interval_first_and_last_always():
    clock, lines = Clock(), []
    bar = GridProgress("p", "universe", 10, lines.append, interval=15.0, verbose=False, clock=clock)
    for _ in range(10):
        clock.now += 4.0                                        # a universe every 4 s: 40 s in all
        bar.finished({"A": "x"}, {"alg": 0})
    ks = [int(LINE.match(ln)["k"]) for ln in lines]
    # the first (t = 4), then the first job at least 15 s after the last line (t = 20, 36), and the last (t = 40)
    assert ks == [1, 5, 9, 10]
    assert LINE.match(lines[1])["left"] == "20 s"               # 5 done in 20 s: 5 left take 20 s
    assert LINE.match(lines[-1])["took"] == "40 s"
    assert not any("{" in ln for ln in lines)                   # no reading without verbose


def test_verbose_reports_every_job_with_its_reading_and_diverged_runs():
    clock, lines = Clock(), []
    bar = GridProgress("p", "cell", 3, lines.append, interval=15.0, verbose=True, clock=clock)
    for i in range(3):
        clock.now += 1.0
        bar.finished({"A": f"x{i}", "B": "y"}, {"alg": i % 2})
    assert len(lines) == 3
    assert all(LINE.match(ln) for ln in lines)
    assert lines[0].endswith(': {"A": "x0", "B": "y"}')
    assert lines[1].endswith('{"A": "x1", "B": "y"}; diverged runs {\'alg\': 1}')


def test_quiet_last_line_counts_the_jobs_with_diverged_runs():
    lines = []
    bar = GridProgress("p", "universe", 4, lines.append, verbose=False, clock=Clock())
    for div in (0, 2, 0, 1):
        bar.finished({}, {"alg": div})
    assert lines[-1].endswith("(2 universe(s) with diverged runs)")


def test_verbose_comes_from_the_environment(monkeypatch):
    monkeypatch.setenv(grid.VERBOSE_ENV, "1")
    assert GridProgress("p", "universe", 1, print).verbose is True
    monkeypatch.setenv(grid.VERBOSE_ENV, "0")
    assert GridProgress("p", "universe", 1, print).verbose is False
    monkeypatch.delenv(grid.VERBOSE_ENV)
    assert GridProgress("p", "universe", 1, print).verbose is False


@pytest.mark.parametrize("kw, name", [(dict(say="x"), "say"), (dict(interval=-1), "interval"),
                                      (dict(total=0), "total"), (dict(verbose="yes"), "verbose")])
def test_bad_arguments_are_named(kw, name):
    args = {**dict(tag="p", unit="universe", total=2, say=print), **kw}
    with pytest.raises(ValueError, match=name):
        GridProgress(**args)


# ----------------------------------------------------------------------------------- the numba compile notice
def test_cache_is_cold_without_an_index_file_as_new_as_the_source(tmp_path, monkeypatch):
    import os
    monkeypatch.setattr(linalg, "_kernel_cache_dirs", lambda: [tmp_path / "missing", tmp_path])
    assert linalg._kernel_cache_cold() is True                   # empty cache folder
    index = tmp_path / "_kernels._chol-95.py311.nbi"
    index.write_text("")
    assert linalg._kernel_cache_cold() is False
    source = os.stat(os.path.join(os.path.dirname(linalg.__file__), "_kernels.py")).st_mtime
    os.utime(index, (source - 10, source - 10))                  # older than the source: numba drops it
    assert linalg._kernel_cache_cold() is True


def test_compile_notice_once_per_process_only_when_cold(monkeypatch, capsys, tmp_path):
    monkeypatch.delenv("MMLIB_PROGRESS_LOG", raising=False)
    monkeypatch.setattr(linalg, "_NOTICE_GIVEN", [])
    monkeypatch.setattr(linalg, "_kernel_cache_cold", lambda: True)
    linalg.set_kernel(linalg.kernel())                         # importing the kernels compiles nothing: no notice
    assert capsys.readouterr().err == ""
    linalg._compiled_module()
    linalg._compiled_module()
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("mmlib: compiling the filter kernels (first use only, about ")
    assert linalg.COMPILE_TIME in err[0]
    # warm: nothing
    monkeypatch.setattr(linalg, "_NOTICE_GIVEN", [])
    monkeypatch.setattr(linalg, "_kernel_cache_cold", lambda: False)
    linalg._compiled_module()
    assert capsys.readouterr().err == ""
    # under the notebook runner: into its progress log, never into the notebook's stderr
    log = tmp_path / "progress.log"
    monkeypatch.setenv("MMLIB_PROGRESS_LOG", str(log))
    monkeypatch.setattr(linalg, "_NOTICE_GIVEN", [])
    monkeypatch.setattr(linalg, "_kernel_cache_cold", lambda: True)
    linalg._compiled_module()
    assert capsys.readouterr().err == "" and log.read_text().startswith("mmlib: compiling the filter kernels")


def test_compile_notice_once_in_the_log_whatever_the_worker_processes(tmp_path):
    """Worker processes compiling at once (the notebook runner's pool, each its own process) leave one line in the
    progress log, not one per worker; other lines of the log are kept."""
    import subprocess
    import sys
    log = tmp_path / "progress.log"
    log.write_text("a progress line\n")
    code = ("from mmlib.core import linalg; linalg._kernel_cache_cold = lambda: True; "
            "[linalg._compile_notice() for _ in range(3)]")
    env = {**__import__("os").environ, "MMLIB_PROGRESS_LOG": str(log)}
    procs = [subprocess.Popen([sys.executable, "-c", code], env=env) for _ in range(4)]
    assert all(p.wait(timeout=120) == 0 for p in procs)
    lines = log.read_text().splitlines()
    assert lines[0] == "a progress line"
    assert sum(ln.startswith("mmlib: compiling the filter kernels") for ln in lines) == 1, lines


# ------------------------------------------------------------------------------------------ make site, per page
@pytest.fixture(scope="module")
def build_site():
    """tools/build_site.py as a module."""
    import importlib.util
    import sys
    from pathlib import Path
    path = Path(__file__).resolve().parents[1] / "tools" / "build_site.py"
    spec = importlib.util.spec_from_file_location("build_site_for_progress", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault(spec.name, module)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("line, shown", [
    ("reading sources... [ 12%] papers/hu2017\n", "site: reading  12 % papers/hu2017"),
    ("writing output... [100%] index", "site: writing 100 % index"),
    ("reading sources... [  1%] api/mmlib.core.linalg", "site: reading   1 % api/mmlib.core.linalg"),
    ("Running Sphinx v8.1.3", None),
    ("build succeeded.", None),
    ("/tmp/x/src/index.md:3: WARNING: undefined label", None),
])
def test_sphinx_page_lines_become_short_progress_lines(build_site, line, shown):
    assert build_site.page_progress(line) == shown
