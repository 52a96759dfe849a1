"""The getting-started page docs/compare-two-filters.md runs: its ```python blocks, in order, as one session of a fresh
interpreter (``sys.executable``, matplotlib's non-interactive backend, a temporary working directory), each block at
its own line of the page so that a traceback names the page's lines; then the quantities it computes are checked to be
what the page says they are (finite, of the right sizes, a positive standard error, a figure with labelled axes)."""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from test_readme import NOT_EXECUTED, RUNNER, python_blocks

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "compare-two-filters.md"
TIMEOUT_S = 600          # the first run after an install compiles the kernels (1-2 min on a shared machine)

#: appended after the page's blocks: the quantities they computed, as one JSON line
REPORT = """
import json as _json
print("RESULTS " + _json.dumps({
    "M": M, "K": K, "diff": [float(diff.value), float(diff.stderr), diff.n_runs, diff.n_excluded],
    "mse": {k: [float(v.value), float(v.stderr)] for k, v in mse.items()},
    "anees": {k: [float(x) for x in v] for k, v in anees.items()}, "band": [float(lo), float(hi)],
    "errors_shape": list(ukf.errors(sim.truth).shape),
    "labels": [[ax.get_xlabel(), ax.get_ylabel()] for ax in fig.axes]}))
"""


def page_source() -> str:
    """The page's python blocks, each at its own line (every other line blank), as one program."""
    text = PAGE.read_text(encoding="utf-8")
    lines = [""] * (len(text.splitlines()) + 1)
    for line, code, _ in python_blocks(text):
        for i, row in enumerate(code.splitlines()):
            lines[line + i] = row
    return "\n".join(lines)


def test_page_has_runnable_blocks():
    blocks = python_blocks(PAGE.read_text(encoding="utf-8"))
    assert len(blocks) >= 4, f"{PAGE.name}: expected the page's steps as python blocks, found {len(blocks)}"
    assert not any(skipped for _, _, skipped in blocks), f"{PAGE.name}: a block is marked {NOT_EXECUTED}"


@pytest.fixture(scope="module")
def results(tmp_path_factory) -> dict:
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": os.pathsep.join(
        filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    try:
        proc = subprocess.run([sys.executable, "-c", RUNNER, str(PAGE)], input=page_source() + REPORT,
                              cwd=tmp_path_factory.mktemp("compare-page"), env=env, capture_output=True, text=True,
                              timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        pytest.fail(f"{PAGE.name}: the python blocks did not finish within {TIMEOUT_S} s", pytrace=False)
    if proc.returncode != 0:
        pytest.fail(f"{PAGE.name}: the python blocks failed (exit status {proc.returncode}):\n{proc.stderr}"
                    f"stdout:\n{proc.stdout}", pytrace=False)
    out = {"stdout": proc.stdout}
    line = [x for x in proc.stdout.splitlines() if x.startswith("RESULTS ")]
    assert len(line) == 1, proc.stdout
    out.update(json.loads(line[0][len("RESULTS "):]))
    return out


def test_paired_difference_has_a_standard_error(results):
    value, stderr, n_runs, n_excluded = results["diff"]
    assert math.isfinite(value) and math.isfinite(stderr) and stderr > 0
    assert n_runs + n_excluded == results["M"] and n_runs > results["M"] // 2
    assert results["errors_shape"] == [results["M"], results["K"], 4]
    # the point of pairing: the paired difference's standard error is below that of either MSE alone
    # (the two filters share every run's noise); equal would mean the pairing bought nothing
    for name, (mse, se) in results["mse"].items():
        assert mse > 0 and 0 < stderr < se, name
    assert "standard errors from zero" in results["stdout"]


def test_anees_is_finite_and_compared_with_its_band(results):
    lo, hi = results["band"]
    assert 0 < lo < 4 < hi                            # the band of a mean of chi2(4) contains 4
    assert set(results["anees"]) == {"IMM-UKF", "IMM-CKF"}
    for name, a in results["anees"].items():
        assert len(a) == results["K"] and all(math.isfinite(x) and x > 0 for x in a), name
    assert results["stdout"].count("per-step ANEES inside") == 2


def test_figure_axes_are_labelled_with_units(results):
    labels = results["labels"]
    assert len(labels) == 2
    for xlabel, ylabel in labels:
        assert "(s)" in xlabel and ylabel
    assert "(m²)" in labels[0][1] and "dimensionless" in labels[1][1]
