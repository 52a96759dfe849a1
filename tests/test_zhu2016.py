"""Paper-level facts of Zhu et al. 2016 under its own set-up."""
import numpy as np
import pytest

from mmlib import MonteCarlo, metrics
from mmlib.experiment import evaluation
from mmlib.scenarios import zhu2016 as paper


@pytest.fixture(scope="module")
def results():
    setup = paper.Setup(n_steps=60)
    mc = MonteCarlo(paper.ROOT_SEED, 6)
    make_batch, estimators, _ = paper.make_batch_fn(setup, mc)
    return evaluation.evaluate(estimators, make_batch, mc, progress=False)


@pytest.mark.parametrize("name", ["IMM5CKF", "IMMCKF", "IMMUKF"])
def test_imm_sigma_point_filters_coincide_with_imm_kf(results, name):
    """Linear models + rules exact to degree >= 2 => the Kalman moments (see the notebook)."""
    ref = results["IMM-KF"]
    # positions ~1e4 m: 1e-7 m is ~1e-11 relative, round-off scale over 60 steps
    np.testing.assert_allclose(results[name].errors, ref.errors, rtol=0, atol=1e-7)
    np.testing.assert_allclose(results[name].mode_probabilities, ref.mode_probabilities, rtol=0, atol=1e-9)


@pytest.mark.parametrize("ukf", [(1.0, 2.0, 0.0), (0.3, 2.0, 0.0), (1.0, 0.0, 3.0 - 4)])
def test_ukf_parameters_do_not_matter_here(ukf):
    setup = paper.Setup(n_steps=30, ukf=ukf)
    mc = MonteCarlo(1, 3)
    make_batch, est, _ = paper.make_batch_fn(setup, mc)
    res = evaluation.evaluate({k: est[k] for k in ("IMMUKF", "IMM-KF")}, make_batch, mc, progress=False)
    np.testing.assert_allclose(res["IMMUKF"].errors, res["IMM-KF"].errors, rtol=0, atol=1e-6)


def test_single_model_is_worse_in_turns(results):
    imm = metrics.rmse_time_averaged(results["IMM5CKF"].errors[..., 0])
    single = metrics.rmse_time_averaged(results["5CKF"].errors[..., 0])
    assert single.value > imm.value


def test_setup_validation():
    with pytest.raises(ValueError, match="initial_estimate"):
        paper.Setup(initial_estimate="perfect")
    with pytest.raises(ValueError, match="single_model"):
        paper.Setup(single_model="CA")


def test_table1_paper_values_are_complete():
    assert set(paper.TABLE1) == set(paper.ALGORITHMS)
    assert all(len(v) == 5 for v in paper.TABLE1.values())
    ids = [d.id for d in paper.DEVIATIONS]
    assert len(ids) == len(set(ids))
