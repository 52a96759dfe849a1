"""The committed results come from the committed code, on this machine or any other.

Each paper's headline digest (the per-run numbers of the first smoke-size runs,
:func:`mmlib.experiment.digests.run_digest`) is recomputed here in-process, without the notebooks, and
compared with the digest stored in ``data/results/<paper>.json`` by
:func:`mmlib.experiment.digests.compare_digests`: bit for bit where the machine fingerprint equals the one
that made the committed outputs, to the derived round-off bound elsewhere.  ``tools/emulated_tests.py``
(run by ``make test``) runs this file again under an emulated AVX2 and an emulated SSE4.2 machine and sets
``MMLIB_EXPECT_EMULATED``, so the round-off path is exercised on the reference machine too.
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from mmlib.papers import REGISTRY
from mmlib.experiment import digests, machine
from test_results import load

REPO = Path(__file__).resolve().parents[2]
PAPERS = tuple(REGISTRY)


def committed_digest(paper: str) -> dict:
    return load(paper, "full")["digest"]


@pytest.mark.parametrize("paper", PAPERS)
def test_headline_digest_matches_committed(paper):
    committed = committed_digest(paper)
    ours = REGISTRY[paper].headline_digest(committed["n_runs"])
    result = digests.compare_digests(ours, committed)
    assert result.ok, (f"data/results/{paper}.json: the headline's first {committed['n_runs']} runs recomputed "
                       f"by this code do not match the committed digest; {result.message()}\nIf the code changed "
                       "the numbers on purpose, regenerate the committed outputs ('make figures') in the same "
                       "commit; if only the machine differs, the difference is beyond round-off and is a defect.")
    if os.environ.get("MMLIB_EXPECT_EMULATED") and machine.differences(ours["machine"], committed["machine"]):
        # an emulated CPU other than the committed outputs' machine: the round-off rule is what passed
        assert result.rule.startswith("round-off"), (result.rule, machine.dispatch_environment())


def test_committed_digests_record_their_machine():
    """Every committed digest carries the fingerprint and per-run numbers the cross-machine rule needs."""
    for paper in PAPERS:
        d = committed_digest(paper)
        assert set(d["machine"]) >= {"cpu", "openblas_core", "numpy_simd", "kernel"}, paper
        assert set(d["runs"]) == set(d["algorithms"]), paper
        for alg, runs in d["runs"].items():
            assert len(runs["rmse"]) == len(runs["diverged_step"]) == d["n_runs"], (paper, alg)
            assert runs["scale"] > 0, (paper, alg)
