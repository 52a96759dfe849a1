"""Paper-level facts of Zhou et al. 2017 under its own set-up."""
import numpy as np
import pytest

from mmlib import MonteCarlo
from mmlib.experiment import evaluation
from mmlib.scenarios import zhou2017 as paper


def test_naukf_as_printed_diverges_and_the_inflate_only_variant_does_not():
    mc = MonteCarlo(paper.ROOT_SEED, 6)
    for inflate_only, expect_diverged in ((False, True), (True, False)):
        mb, est, _ = paper.make_batch_fn(paper.Setup(faults=True, inflate_only=inflate_only), mc, names=("IMM-NAUKF",))
        res = evaluation.evaluate(est, mb, mc, progress=False)
        assert res["IMM-NAUKF"].diverged_step.max() >= 0 if expect_diverged else not (~res["IMM-NAUKF"].valid).any()


def test_linear_gps_analogue_ekf_ckf_ukf_coincide():
    mc = MonteCarlo(paper.ROOT_SEED, 4)
    mb, est, _ = paper.gps_analogue(paper.GPSAnalogue(), mc)
    res = evaluation.evaluate({k: est[k] for k in ("EKF", "CKF", "UKF")}, mb, mc, progress=False)
    np.testing.assert_allclose(res["CKF"].errors, res["EKF"].errors, rtol=0, atol=1e-9)
    np.testing.assert_allclose(res["UKF"].errors, res["EKF"].errors, rtol=0, atol=1e-9)


def test_faults_are_drawn_per_run_and_accumulate():
    mc = MonteCarlo(paper.ROOT_SEED, 3)
    s = paper.Setup(faults=True)
    f = paper.radar_fault(s, mc, range(3), np.arange(1, 101.0))
    assert np.all(np.abs(f.delta[..., 0]) <= 5.0) and np.all(np.diff(f.delta[..., 0], axis=1) == 0)
    rate = f.delta[:, 0, 1]
    np.testing.assert_allclose(f.delta[:, -1, 1], rate * 100.0)
    assert np.all((rate >= 0) & (rate <= 1e-2))


def test_setup_validation():
    with pytest.raises(ValueError, match="fault_kind"):
        paper.Setup(fault_kind="random")
