"""Multiverse.headline_match: whether the reading space's headline universe reproduces the headline evaluation, and
the reason when it does not (the notebooks printed a bare False, which a rerun with N_RUNS alone always gave)."""
from __future__ import annotations

import dataclasses

import pytest

import experiment_jobs as toy
from mmlib.experiment import run_multiverse


def _mv(tmp_path, n_runs):
    return run_multiverse(toy.SPACE, toy.toy_universe, published=toy.PUBLISHED, n_runs=n_runs, seed=3,
                          algorithms=["alg"], design="star", cache_dir=tmp_path, progress=False, workers=1)


def test_same_runs_same_numbers_is_yes(tmp_path):
    mv = _mv(tmp_path, 20)
    assert mv.headline_match(toy.toy_universe(toy.SPACE.headline, 20, 3), 20).startswith("yes")


def test_another_run_count_names_both_counts_and_the_parameter(tmp_path):
    mv = _mv(tmp_path, 20)
    reason = mv.headline_match(toy.toy_universe(toy.SPACE.headline, 50, 3), 50)
    assert reason.startswith("no: ")
    assert "20 runs per universe" in reason and "the headline 50" in reason and "MULTIVERSE_RUNS=" in reason


def test_same_runs_other_numbers_says_so(tmp_path):
    mv = _mv(tmp_path, 20)
    other = toy.toy_universe(toy.SPACE.headline, 20, 4)              # another seed: other numbers
    reason = mv.headline_match(other, 20)
    assert reason.startswith("no: both run 20 runs, but the numbers differ")
    assert mv.headline_match(dataclasses.replace(mv.headline), 20).startswith("yes")


def test_bad_arguments_are_named(tmp_path):
    mv = _mv(tmp_path, 20)
    with pytest.raises(ValueError, match="headline"):
        mv.headline_match({"values": []}, 20)
    with pytest.raises(ValueError, match="n_runs"):
        mv.headline_match(mv.headline, 0)
