"""Paper-level facts of Hu et al. 2017 under its own set-up."""
import numpy as np
import pytest

from mmlib import MonteCarlo, metrics, run
from mmlib.experiment import evaluation
from mmlib.scenarios import hu2017 as paper


@pytest.fixture(scope="module")
def headline():
    mc = MonteCarlo(paper.ROOT_SEED, 10)
    make_batch, est, _ = paper.make_batch_fn(paper.Setup(), mc)
    return evaluation.evaluate(est, make_batch, mc, progress=False), make_batch, est


def test_immukf_is_immcdkf_in_the_printed_form(headline):
    res, _, _ = headline
    # same algorithm (UKF alpha=1, beta=0, kappa=3-n == weighted CD rule); round-off only (values ~10 km)
    np.testing.assert_allclose(res["IMMUKF"].errors, res["IMMCDKF"].errors, rtol=0, atol=1e-10)


def test_third_degree_rules_and_ekf_nearly_coincide(headline):
    """sigma/r ~ 0.005 here: second-order (EKF) terms ~0.5 %, fourth-order ~3e-5 of the first-order ones."""
    res, _, _ = headline
    level = metrics.mean_rmse_over_time(res["IMMCDKF"].errors[..., 0]).value
    for alg, rel in (("IMMCKF", 1e-3), ("IMMEKF", 0.05)):
        diff = np.abs(res[alg].errors - res["IMMCDKF"].errors)[..., [0, 2]].max()
        assert diff < rel * level, (alg, diff, level)


def test_bootstrapping_is_over_confident(headline):
    _, make_batch, est = headline
    truth, z, init = make_batch(range(10))
    nees = {}
    for alg in ("IMMCDKF", "IMMCDKF-OBS"):
        tr = run(est[alg], init[alg], z)
        nees[alg] = metrics.nees(tr.mean - truth[:, 1:], tr.cov).mean()
    assert nees["IMMCDKF"] < 8.0                 # consistent-ish (4 = ideal)
    assert nees["IMMCDKF-OBS"] > 10 * nees["IMMCDKF"]


def test_truth_follows_the_state_equation_schedule():
    sched = paper.build(paper.Setup())[0]
    modes = sched.modes()
    assert modes[:10].tolist() == [0] * 10 and modes[10:25].tolist() == [1] * 15 and modes[25:].tolist() == [0] * 10


def test_setup_validation():
    with pytest.raises(ValueError, match="mode2_steps"):
        paper.Setup(mode2_steps=(20, 40))
    with pytest.raises(ValueError, match="q"):
        paper.Setup(q=(0.2, -1.0))
