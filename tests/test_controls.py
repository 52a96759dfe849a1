"""The controls (mmlib.papers.controls): the closed form is the fixed point of the Riccati recursion, the printed
table is the closed form to its printed precision, the CKF is the KF on the linear model to round-off, and through
the real pipeline (the reading space's universes, the rows, the verdict rule) the positive control reproduces every
cell while the negative controls refuse every cell with the verdict expected of it -- and stop doing so when the
rule's constants are loosened or tightened (monkeypatched), so the controls do check the rule."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mmlib.experiment import verdicts
from mmlib.experiment.montecarlo import MonteCarlo
from mmlib.experiment.multiverse import run_multiverse
from mmlib.papers import PACKAGES, REGISTRY
from mmlib.papers.controls import closed_form, control, study, text
from mmlib.papers.controls.setup import Setup

PAPER = REGISTRY["controls"]


def test_the_controls_are_a_control_listed_first_outside_the_arena():
    assert PACKAGES[0] == "controls" and PAPER.kind == "control" and PAPER.arena is None
    assert PAPER.n_runs is None                     # the closed form has no Monte Carlo error (deviation C-4)
    assert all(f.kind == "reading" for f in PAPER.space.factors) and PAPER.space.size == 4


@pytest.mark.parametrize("lam", text.LAMBDAS)
def test_closed_form_is_the_fixed_point_of_the_riccati_recursion(lam):
    ss = closed_form.steady_state(lam, text.T, text.SIGMA_W)
    P = closed_form.riccati(lam, text.T, text.SIGMA_W, 1e6 * np.eye(2), 3000)[-1]
    # the recursion converges geometrically (rate < 0.96 per step at lambda = 0.01): 3000 steps reach round-off
    np.testing.assert_allclose(P, ss.P, rtol=1e-10, atol=0)
    # Kalata's relations: lambda^2 = beta^2 / (1 - alpha) and beta = 2 (2 - alpha) - 4 sqrt(1 - alpha)
    assert math.isclose(lam * lam, ss.beta ** 2 / (1 - ss.alpha), rel_tol=1e-12)
    assert math.isclose(ss.beta, 2 * (2 - ss.alpha) - 4 * math.sqrt(1 - ss.alpha), rel_tol=1e-9, abs_tol=1e-13)
    # the predicted covariance is F P F^T + Q
    F = np.array([[1.0, text.T], [0.0, 1.0]])
    G = np.array([[text.T ** 2 / 2], [text.T]]) * closed_form.acceleration_sd(lam, text.T, text.SIGMA_W)
    np.testing.assert_allclose(F @ ss.P @ F.T + G @ G.T, ss.M, rtol=1e-12)


def test_printed_table_is_the_closed_form_to_its_printed_precision():
    for lam, cells in text.TABLE.items():
        ss = closed_form.steady_state(lam, text.T, text.SIGMA_W)
        for printed, exact in zip(cells, (ss.position_sd, ss.velocity_sd)):
            row = verdicts.exact_row("t", "KF", "q", printed, exact)
            assert row.verdict == verdicts.REPRODUCED_EXACT, (lam, printed, exact)
            assert len(printed.replace(".", "").lstrip("0")) == 4          # four significant figures
    assert text.perturbed("8.660", 0.10) == "9.526" and text.perturbed("8.660", -0.10) == "7.794"


def test_two_point_burn_in_reaches_the_steady_state():
    burn = dict(PAPER.space.factors[1].option("two-point").changes)["burn_in"]
    for lam in text.LAMBDAS:
        P0 = closed_form.two_point_covariance(text.T, text.SIGMA_W)
        assert closed_form.settling_steps(lam, text.T, text.SIGMA_W, P0, 1e-3) < burn


def test_ckf_is_the_kf_on_the_linear_model_to_round_off():
    results = study.evaluate_reading(PAPER.headline, MonteCarlo(PAPER.root_seed, 5))
    for label, runs in results.runs.items():
        kf, ckf = runs["KF"].errors, runs["CKF"].errors
        scale = np.abs(runs["KF"].example_mean).max()
        # round-off: the two compute the same moments in different orders (measured at most 9 eps of the state's
        # scale over these 200 steps); the stable error dynamics do not amplify a step's round-off, so 1000 eps
        # leaves room for other machines while a real difference (a wrong weight: 1e-3 of the scale) fails
        assert np.abs(ckf - kf).max() <= 1e3 * np.finfo(float).eps * scale, label


@pytest.fixture(scope="module")
def multiverse(tmp_path_factory):
    """The reading space at the smoke profile's runs, through run_multiverse (the notebook's path), in this
    process with a private cache."""
    import os
    old = os.environ.get("MMLIB_CACHE")
    os.environ["MMLIB_CACHE"] = str(tmp_path_factory.mktemp("cache"))
    try:
        n = PAPER.profiles["smoke"]["mv_runs"]
        return run_multiverse(PAPER.space, PAPER.universe, published=PAPER.published, n_runs=n, seed=PAPER.root_seed,
                              algorithms=PAPER.algorithms, design="full", n_runs_paper=PAPER.n_runs, workers=1,
                              progress=False)
    finally:
        if old is None:
            os.environ.pop("MMLIB_CACHE")
        else:
            os.environ["MMLIB_CACHE"] = old


def _outcome(u):
    """The controls' outcome of a universe, judged by the rule as it is now."""
    rows = study.table_rows(u)
    s = control.section(rows, n_runs=u.n_runs)
    return s["positive"]["all_reproduced"], s["negative"]["all_rejected"], s


def test_every_reading_reproduces_the_positive_and_refuses_the_negative_controls(multiverse):
    assert len(multiverse.universes) == 4
    for reading, u in zip(multiverse.readings, multiverse.universes):
        pos_ok, neg_ok, s = _outcome(u)
        assert pos_ok and s["positive"]["joint_test"]["passes"], (reading, s["positive"])
        assert neg_ok and s["negative"]["n_expected"] == s["negative"]["n_cells"] == 36, (reading, s["negative"])
        # the precision the power rests on: every positive cell's s.e. within 2 % of its value
        assert all(v.stderr <= 0.02 * v.replicated for v in u.values), reading
        assert all(c.verdict == verdicts.NOT_SUPPORTED and "identical" in c.decisive for c in u.claims), reading
    summary = multiverse.numbers_summary()
    assert all(n["n_reproduced"] == n["n_counted"] for n in summary if n["table"] == text.POSITIVE)
    assert all(n["n_reproduced"] == n["n_isolated"] == n["n_inconclusive"] == 0 for n in summary
               if n["table"] != text.POSITIVE)


def test_the_controls_fail_when_the_rule_is_loosened_or_tightened(multiverse, monkeypatch):
    u = multiverse.headline
    ok_pos, ok_neg, s = _outcome(u)
    assert ok_pos and ok_neg
    low, high = s["rule_window"]["sigma_factor"]
    band_low, band_high = s["rule_window"]["relative_band"]
    assert low < verdicts.SIGMA_FACTOR < high and band_low < verdicts.RELATIVE_BAND < band_high
    for factor, fails in ((0.99 * low, "positive"), (1.0, "positive"), (1.01 * high, "negative"),
                          (20.0, "negative")):
        monkeypatch.setattr(verdicts, "SIGMA_FACTOR", factor)
        pos_ok, neg_ok, _ = _outcome(u)
        assert (pos_ok, neg_ok) == ((False, True) if fails == "positive" else (True, False)), factor
    monkeypatch.setattr(verdicts, "SIGMA_FACTOR", 3.0)
    for band, fails in ((0.99 * band_low, "negative"), (0.02, "positive"), (1.01 * band_high, "negative")):
        monkeypatch.setattr(verdicts, "RELATIVE_BAND", band)
        pos_ok, neg_ok, _ = _outcome(u)
        assert not (pos_ok and neg_ok) and (pos_ok if fails == "negative" else not pos_ok), band


def test_power_of_the_rule():
    # a printed value equal to the truth, no rounding: the rule's false rejection rate 2 Phi(-3)
    assert math.isclose(control.rejection_power(8.0, "8.000000", 0.1), math.erfc(3 / math.sqrt(2)), rel_tol=1e-4)
    # a 10 % error at 1 % standard error is refused with certainty; at 5 % s.e. (z = 2) mostly not
    assert control.rejection_power(10.0, "11.00", 0.1) > 1 - 1e-9
    assert control.rejection_power(10.0, "11.00", 0.5) < 0.5
    assert math.isclose(control.tightening_detection(3.0, 1), math.erfc(3 / math.sqrt(2)), rel_tol=1e-12)
    with pytest.raises(ValueError, match="stderr"):
        control.rejection_power(10.0, "11.00", 0.0)


def test_setup_refuses_what_it_cannot_run():
    for change, arg in (({"start": "cold"}, "start"), ({"report": "UKF"}, "report"),
                        ({"burn_in": 200}, "burn_in"), ({"lambdas": (0.1, -1.0)}, "lambdas")):
        with pytest.raises(ValueError, match=f"^{arg}"):
            Setup(**change)
    with pytest.raises(ValueError, match="lam"):
        closed_form.steady_state(0.0, 1.0, 1.0)
