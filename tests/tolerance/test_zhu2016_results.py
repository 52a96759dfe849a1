"""Tolerance tests: the smoke profile's results against the committed full-fidelity results.

The smoke run is an exact prefix (first 20 runs) of the full run, so a smoke
value and the committed full value estimate the same quantity from nested
samples; their difference has a standard deviation below
sqrt(se_smoke^2 + se_full^2).  We allow 4 of those (a 4-sigma band: a stale
committed result or a changed algorithm moves values by far more, while the
check stays deterministic because the seed is fixed).
"""
import json
import math
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SMOKE = REPO / "build" / "smoke" / "data" / "results" / "zhu2016.json"
FULL = REPO / "data" / "results" / "zhu2016.json"


def _load(path):
    if not path.exists():
        pytest.fail(f"{path.relative_to(REPO)} is missing: run 'make test' (smoke) / 'make figures' (full) first")
    return json.loads(path.read_text())


@pytest.fixture(scope="module")
def smoke():
    return _load(SMOKE)


@pytest.fixture(scope="module")
def full():
    return _load(FULL)


def _rmse_rows(doc):
    return {(r["algorithm"], r["quantity"]): r for r in doc["rows"] if r["quantity"].startswith("RMSE")}


def test_results_contract(smoke, full):
    for doc in (smoke, full):
        assert doc["paper"] == "zhu2016"
        for key in ("git_commit", "root_seed", "n_runs", "packages", "profile"):
            assert key in doc["provenance"]
        for row in doc["rows"]:
            for key in ("item", "algorithm", "quantity", "paper", "replicated", "stderr", "verdict", "deviations"):
                assert key in row
    assert smoke["provenance"]["profile"] == "smoke" and full["provenance"]["profile"] == "full"
    assert smoke["provenance"]["root_seed"] == full["provenance"]["root_seed"]
    assert full["provenance"]["n_runs"] == 100


def test_smoke_rmse_within_monte_carlo_error_of_committed_full(smoke, full):
    s_rows, f_rows = _rmse_rows(smoke), _rmse_rows(full)
    assert s_rows.keys() == f_rows.keys()
    checked = 0
    for key, f in f_rows.items():
        s = s_rows[key]
        if f["replicated"] is None:
            assert s["replicated"] is None and s["verdict"].startswith("not replicable")
            continue
        band = 4.0 * math.hypot(s["stderr"], f["stderr"])
        assert abs(s["replicated"] - f["replicated"]) <= band, (key, s["replicated"], f["replicated"], band)
        checked += 1
    assert checked == 16


def test_paper_values_match_the_scenario_module(full):
    from mmlib.scenarios import zhu2016 as paper
    for row in full["rows"]:
        if row["quantity"].startswith("RMSE"):
            qi = [q for q, _ in paper.QUANTITIES].index(row["quantity"])
            assert row["paper"] == paper.TABLE1[row["algorithm"]][qi]


def test_coincidence_of_the_imm_sigma_point_filters(smoke, full):
    for doc in (smoke, full):
        diffs = doc["coincidence"]["max_abs_estimate_difference_vs_IMM_KF"]
        assert set(diffs) == {"IMM5CKF", "IMMCKF", "IMMUKF"}
        assert max(diffs.values()) < 1e-6


def test_no_divergence_and_figures_listed(smoke, full):
    for doc in (smoke, full):
        assert not any(doc["diverged_runs"].values())
    stems = set(full["figures"])
    assert {"fig02_trajectory", "fig03_rmse_position", "fig04_rmse_velocity", "fig05_mode_probability_1",
            "fig06_mode_probability_2", "fig07_mode_probability_3"} <= stems
    for entry in full["figures"].values():
        for f in entry["files"]:
            assert (REPO / f).exists(), f
