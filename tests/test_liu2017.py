"""Paper-level facts of Liu & Wu 2017 under its own set-up."""
import numpy as np
import pytest

from mmlib import MonteCarlo, metrics
from mmlib.experiment import evaluation
from mmlib.scenarios import liu2017 as paper


@pytest.fixture(scope="module")
def example1():
    mc = MonteCarlo(paper.ROOT_SEED, 8)
    make_batch, est, _ = paper.make_batch_fn(paper.EXAMPLE1, mc, names=paper.FILTERS)
    return evaluation.evaluate(est, make_batch, mc, progress=False)


def test_third_degree_st_filters_nearly_coincide(example1):
    """The rules differ only in 4th-order terms of h, ~(sigma/r)^2 <= 1e-2 at these ranges:
    position ARMSE within 1 % of each other."""
    armse = {a: metrics.armse(example1[a].errors[..., [0, 3]]).value for a in ("STUKF", "STCKF", "STSSRCKF")}
    assert max(armse.values()) - min(armse.values()) <= 0.01 * armse["STSSRCKF"]


def test_strong_tracking_beats_plain_filter_after_the_jump(example1):
    after = {a: metrics.armse(example1[a].errors[:, 150:, [0, 3]]).value for a in ("SSRCKF", "STSSRCKF")}
    assert after["STSSRCKF"] < 0.5 * after["SSRCKF"]


def test_truth_follows_the_printed_time_line():
    mc = MonteCarlo(1, 1)
    make_batch, _, _ = paper.make_batch_fn(paper.EXAMPLE1, mc, names=("SSRCKF",))
    truth, _, _ = make_batch(range(1))
    np.testing.assert_array_equal(truth[0, :150][:, [2, 5]], 0.0)          # no acceleration before t = 150 s (L-8)
    np.testing.assert_array_equal(truth[0, 150:, 2], 15.0)
    np.testing.assert_array_equal(truth[0, 150:, 5], 25.0)
    assert truth[0, 100, 0] == pytest.approx(100.0 + 15.0 * 100)           # uniform motion


def test_setup_validation():
    with pytest.raises(ValueError, match="maneuver_start"):
        paper.Setup(maneuver_start=250.0)
    with pytest.raises(ValueError, match="q_sd"):
        paper.Setup(q_sd=0.0)
    with pytest.raises(ValueError, match="initial_estimate"):
        paper.Setup(initial_estimate="perfect")
