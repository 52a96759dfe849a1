"""The notebook pipeline fails loudly and leaves no output that looks current."""
import hashlib
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest() if path.exists() else ""


@pytest.mark.parametrize("param, notebook, messages", [
    ("N_RUNS=-3", str(REPO / "notebooks" / "zhu2016_imm5ckf.py"), ["-p N_RUNS: expected", "got -3"]),
    ("N_RUNS=1", "zhu2016", ["-p N_RUNS: expected", "got 1"]),
    ("NRUNS=5", "zhu2016", ["-p NRUNS: not a parameter of this notebook; it declares N_RUNS, SEED"]),
])
def test_bad_notebook_parameter_is_rejected_up_front_naming_notebook_and_parameter(param, notebook, messages):
    """A paper notebook's bad parameter is rejected before it runs (the runner applies the notebooks' own checks),
    and nothing is promoted."""
    smoke_results = REPO / "build" / "smoke" / "data" / "results" / "zhu2016.json"
    committed = REPO / "data" / "results" / "zhu2016.json"
    before = (_digest(smoke_results), _digest(committed))
    proc = subprocess.run([sys.executable, str(REPO / "tools" / "run_notebooks.py"), "--profile", "smoke",
                           "-p", param, notebook], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2
    assert f"run_notebooks.py: error: notebooks/zhu2016_imm5ckf.py: {messages[0]}" in proc.stderr
    assert all(m in proc.stderr for m in messages)
    assert "executing" not in proc.stdout
    assert (_digest(smoke_results), _digest(committed)) == before      # nothing promoted
    assert not (REPO / "build" / "custom" / f"smoke-{param}").exists()


def test_executed_notebooks_hold_no_machine_local_path():
    """Committed and smoke executed notebooks name no absolute path of this checkout (the runner makes every
    path relative to the repository before promoting a notebook)."""
    paths = sorted((REPO / "notebooks" / "executed").glob("*.ipynb")) + \
        sorted((REPO / "build" / "smoke" / "executed").glob("*.ipynb"))
    assert len(paths) >= 10
    for path in paths:
        text = path.read_text()
        assert str(REPO) not in text and "/staging/" not in text, path
