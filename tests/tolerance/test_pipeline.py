"""The notebook pipeline fails loudly and leaves no output that looks current."""
import hashlib
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest() if path.exists() else ""


def test_bad_notebook_parameter_names_notebook_cell_and_parameter():
    smoke_results = REPO / "build" / "smoke" / "data" / "results" / "zhu2016.json"
    committed = REPO / "data" / "results" / "zhu2016.json"
    before = (_digest(smoke_results), _digest(committed))
    proc = subprocess.run([sys.executable, str(REPO / "tools" / "run_notebooks.py"), "--profile", "smoke",
                           "-p", "N_RUNS=-3", str(REPO / "notebooks" / "zhu2016_imm5ckf.py")],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 1
    assert "FAILED: notebook notebooks/zhu2016_imm5ckf.py, cell" in proc.stderr
    assert "N_RUNS: expected a positive integer" in proc.stderr
    assert (_digest(smoke_results), _digest(committed)) == before      # nothing promoted


def test_executed_notebooks_hold_no_machine_local_path():
    """Committed and smoke executed notebooks name no absolute path of this checkout (the runner makes every
    path relative to the repository before promoting a notebook)."""
    paths = sorted((REPO / "notebooks" / "executed").glob("*.ipynb")) + \
        sorted((REPO / "build" / "smoke" / "executed").glob("*.ipynb"))
    assert len(paths) >= 10
    for path in paths:
        text = path.read_text()
        assert str(REPO) not in text and "/staging/" not in text, path
