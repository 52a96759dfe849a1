"""The Makefile refuses an unknown upper-case variable on the command line (a misspelt ``NRUNS=200`` would otherwise
be dropped silently, rerunning the full profile over the committed outputs), with the list of the accepted ones;
accepted variables, environment variables and lower-case names pass; ``MULTIVERSE_RUNS`` reaches the runner.

Every test runs ``make -n`` (a dry run: the commands are printed, none is run)."""
from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def make(*args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(["make", "-n", "-C", str(REPO), *args], capture_output=True, text=True, timeout=60,
                          env={**os.environ, **(env or {})})


def accepted() -> list[str]:
    """ACCEPTED_VARIABLES as written in the Makefile (continuation lines joined)."""
    text = (REPO / "Makefile").read_text().replace("\\\n", " ")
    match = re.search(r"^ACCEPTED_VARIABLES\s*:=\s*(.*)$", text, re.M)
    assert match, "the Makefile defines no ACCEPTED_VARIABLES"
    return match.group(1).split()


def runner_line(stdout: str) -> list[str]:
    """The arguments the dry run passes to tools/run_notebooks.py."""
    line = next(li for li in stdout.splitlines() if "run_notebooks.py" in li)
    return line.split("run_notebooks.py", 1)[1].split()


def test_a_misspelt_variable_is_refused_with_the_accepted_list():
    proc = make("figures", "PAPER=hu2017", "NRUNS=200")
    assert proc.returncode != 0
    message = proc.stderr
    assert "NRUNS" in message and "nothing was run" in message, message
    listed = message.split("Accepted:", 1)[1].split(".", 1)[0].split()     # make ends it with ".  Stop."
    assert listed == accepted()
    assert "run_notebooks.py" not in proc.stdout            # no command was even printed


def test_every_unknown_variable_is_named_once():
    proc = make("site", "FOO=1", "N_RUN=3")
    assert proc.returncode != 0
    head = proc.stderr.split("Accepted:", 1)[0]
    assert re.search(r"\bFOO\b", head) and re.search(r"\bN_RUN\b", head), proc.stderr


def test_accepted_variables_pass():
    names = accepted()
    assert {"PAPER", "N_RUNS", "SEED", "MULTIVERSE_RUNS", "PROFILE", "WORKERS", "SCHEDULER"} <= set(names)
    values = {"PAPER": "zhu2016", "PROFILE": "smoke", "SCHEDULER": "tcp://host:8786", "PYTHON": "python3"}
    proc = make("figures", *(f"{n}={values.get(n, '3')}" for n in names))
    assert proc.returncode == 0, proc.stderr
    assert "run_notebooks.py" in proc.stdout


def test_verbose_is_the_runners_v():
    assert runner_line(make("figures", "PAPER=hu2017", "VERBOSE=1").stdout) == ["--profile", "full", "-v", "hu2017"]
    assert "-v" not in runner_line(make("figures", "PAPER=hu2017").stdout)
    assert "-v" not in runner_line(make("figures", "PAPER=hu2017", "VERBOSE=0").stdout)     # 0 means off


def test_the_readme_findings_follow_only_a_run_of_the_committed_outputs():
    """make figures rewrites the README's findings (tools/make_report.py) after a full run over the committed
    outputs, never after a custom run (build/custom/) or a smoke run (build/smoke/)."""
    def runs_report(*args: str) -> bool:
        return any(li.strip().endswith("python tools/make_report.py") and not li.lstrip().startswith("#")
                   for li in make("figures", "PAPER=hu2017", *args).stdout.splitlines())

    assert runs_report()
    for extra in (["N_RUNS=5"], ["SEED=3"], ["MULTIVERSE_RUNS=7"], ["PROFILE=smoke"]):
        assert not runs_report(*extra), extra


def test_environment_and_lower_case_variables_are_not_refused():
    """Only the command line is checked: the environment holds many upper-case names make does not read."""
    proc = make("figures", "PAPER=zhu2016", "verbose=1", env={"NRUNS": "200", "SOME_TOOL_HOME": "/opt"})
    assert proc.returncode == 0, proc.stderr


def test_every_accepted_variable_is_read_somewhere():
    """The list is not padded: each name is used by the Makefile beyond the list, or read by a script it runs."""
    makefile = (REPO / "Makefile").read_text()
    rest = re.sub(r"^ACCEPTED_VARIABLES\s*:=(.*\\\n)*.*$", "", makefile, flags=re.M)
    sources = "\n".join(p.read_text() for folder in ("bench", "mmlib", "tools") for p in (REPO / folder).rglob("*.py"))
    for name in accepted():
        assert f"$({name})" in rest or f"origin {name}" in rest or f'"{name}"' in sources, name


def test_multiverse_runs_reaches_the_runner_and_is_a_custom_setting():
    """MULTIVERSE_RUNS is passed as the notebooks' parameter (a results-changing one: outputs to build/custom/), and,
    like N_RUNS, makes no benchmark and no site of the custom run."""
    proc = make("figures", "PAPER=hu2017", "MULTIVERSE_RUNS=50")
    assert proc.returncode == 0, proc.stderr
    assert runner_line(proc.stdout) == ["--profile", "full", "-p", "MULTIVERSE_RUNS=50", "hu2017"]
    assert "build_site.py" not in proc.stdout and "bench.notebooks" not in proc.stdout
    plain = make("figures", "PAPER=hu2017")
    assert "build_site.py" in plain.stdout                   # the check above can fail


def test_make_venv_says_what_it_installs_and_how_long_it_takes():
    proc = make("-B", "venv")
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    first_install = next(i for i, li in enumerate(lines) if "pip install" in li)
    notice = " ".join(li for li in lines[:first_install] if li.startswith("echo"))
    assert "requirements.lock" in notice and re.search(r"about \d+ minutes?", notice), lines[:first_install]
    # the installs write no bytecode ahead (Python compiles what it imports): three quarters of the install's time
    installs = [li for li in lines if "pip install" in li and not li.startswith("echo")]
    assert installs and all("--no-compile" in li for li in installs), installs
