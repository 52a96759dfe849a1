"""``Track.errors(truth)`` aligns the true states with the estimates as ``evaluate`` does, and
``paired_mse_difference`` compares two tracks against their truth exactly as it compares two ``RunSet``s."""
from __future__ import annotations

import numpy as np
import pytest

import mmlib
from mmlib import models
from mmlib.core.estimation import SingleModel, Track, run
from mmlib.experiment.evaluation import RunSet, paired_mse_difference
from mmlib.experiment.simulate import ManeuverSchedule, simulate

T, K, M = 1.0, 12, 40
CV = models.constant_velocity(T, q=0.5 ** 2)
POS = models.position_measurement(np.diag([20.0 ** 2, 20.0 ** 2]))
X0 = np.array([0.0, 10.0, 0.0, -5.0])
P0 = np.diag([50.0 ** 2, 5.0 ** 2, 50.0 ** 2, 5.0 ** 2])


@pytest.fixture(scope="module")
def case():
    """Two different Kalman filters (the CV model with two process-noise levels) on the same simulated runs."""
    mc = mmlib.MonteCarlo(root_seed=7, n_runs=M)
    sim = simulate(ManeuverSchedule([CV], segments=[], default=0, T=T, n_steps=K), X0, POS, mc, range(M))
    m0 = mc.gaussian(range(M), mmlib.Stream.INITIAL, X0, P0)
    tracks = []
    for q in (0.5 ** 2, 3.0 ** 2):
        est = SingleModel(mmlib.KalmanFilter(), models.constant_velocity(T, q=q), POS)
        tracks.append(run(est, est.init(m0, P0), sim.measurements))
    return sim.truth, tracks[0], tracks[1]


def runset(track: Track, truth: np.ndarray) -> RunSet:
    """The RunSet ``evaluate`` would build, with the errors sliced by hand (estimate k against x_{k+1})."""
    return RunSet(track.mean - truth[:, 1:], track.mode_probabilities, track.diverged_step, track.mean[0])


def test_errors_are_estimate_minus_the_next_true_state(case):
    truth, a, _ = case
    assert truth.shape == (M, K + 1, 4) and a.mean.shape == (M, K, 4)
    np.testing.assert_array_equal(a.errors(truth), a.mean - truth[:, 1:])
    np.testing.assert_array_equal(a.errors(truth[:, 1:]), a.mean - truth[:, 1:])   # x_1..x_K given directly


@pytest.mark.parametrize("bad", [
    lambda t: t[:, 2:],            # K-1 steps
    lambda t: t[:-1],              # one run fewer
    lambda t: t[..., :2],          # state dimension 2, estimates of 4
    lambda t: t[0],                # no run axis
    lambda t: "truth",             # not numbers
], ids=["steps", "runs", "dimension", "2-d", "string"])
def test_errors_refuse_a_truth_of_another_shape(case, bad):
    truth, a, _ = case
    with pytest.raises(ValueError, match=r"^truth: "):
        a.errors(bad(truth))


def test_paired_difference_of_tracks_equals_that_of_runsets(case):
    truth, a, b = case
    for comps in (0, [0, 2], (1, 3)):
        from_tracks = paired_mse_difference(a, b, comps, truth=truth)
        from_arrays = paired_mse_difference(runset(a, truth), runset(b, truth), comps)
        assert from_tracks == from_arrays
    assert from_tracks.stderr > 0 and from_tracks.n_runs == M


def test_paired_difference_excludes_the_runs_diverged_in_either_track(case):
    truth, a, b = case
    a = a._replace(diverged_step=np.where(np.arange(M) == 3, 5, -1))
    b = b._replace(diverged_step=np.where(np.arange(M) == 8, 0, -1))
    d = paired_mse_difference(a, b, [0, 2], truth=truth)
    assert (d.n_runs, d.n_excluded) == (M - 2, 2)
    assert d == paired_mse_difference(runset(a, truth), runset(b, truth), [0, 2])


def test_paired_difference_of_a_filter_with_itself_is_exactly_zero(case):
    truth, a, _ = case
    d = paired_mse_difference(a, a, [0, 2], truth=truth)
    assert d.value == 0.0 and d.stderr == 0.0


def test_paired_difference_bad_input_names_the_argument(case):
    truth, a, b = case
    with pytest.raises(ValueError, match=r"^truth: required"):
        paired_mse_difference(a, b, 0)
    with pytest.raises(ValueError, match=r"^truth: only for two tracks"):
        paired_mse_difference(runset(a, truth), runset(b, truth), 0, truth=truth)
    with pytest.raises(ValueError, match=r"^b: expected a Track"):
        paired_mse_difference(a, runset(b, truth), 0, truth=truth)
    with pytest.raises(ValueError, match=r"^a: expected a Track"):
        paired_mse_difference(runset(a, truth), b, 0, truth=truth)
    with pytest.raises(ValueError, match=r"^truth: "):
        paired_mse_difference(a, b, 0, truth=truth[:, 2:])
    with pytest.raises(ValueError, match=r"^a, b: "):
        paired_mse_difference(a, b._replace(mean=b.mean[:, 1:]), 0, truth=truth)
