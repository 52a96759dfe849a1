"""One universe of the controls: every tracking index run under a reading (:func:`evaluate_reading`: the KF and the
CKF on common random numbers, each case on its own streams) and what it gives (:func:`summarise`): the per-axis
RMS position and velocity errors over the averaging window with their Monte Carlo standard errors, one value per
cell of every control table (the positive table and the perturbed ones hold the same replicated numbers), the
claims, the effects and the diverged runs.

:func:`universe` is the multiverse's job, :func:`table_rows` the notebook's rows, :func:`headline_digest` the digest
the tests recompute, :func:`consistency` the NEES/NIS section.
"""
from __future__ import annotations

import re
from typing import Mapping, NamedTuple

import numpy as np

from mmlib.experiment import digests, evaluation, metrics, report
from mmlib.experiment.montecarlo import MonteCarlo
from mmlib.experiment.universe import UniverseResult
from mmlib.papers.controls import closed_form, text
from mmlib.papers.controls.setup import Setup, make_batch_fn, setup

__all__ = [
    "universe", "evaluate_reading", "summarise", "ControlResults", "rms_per_axis", "case_values", "values", "claims",
    "effects", "table_rows", "consistency", "headline_digest"
]


class ControlResults(NamedTuple):
    """``runs[case label][algorithm]`` a RunSet per tracking index, ``setup`` the reading's :class:`Setup`."""

    reading: dict
    setup: Setup
    runs: dict


def evaluate_reading(reading: Mapping[str, str], mc: MonteCarlo, *, consistency: bool = False) -> ControlResults:
    """Every case of ``reading`` on the runs of ``mc`` (each case on its own root seed, ``setup.case_seed``), the KF
    and the CKF on common random numbers; ``consistency`` records NEES and NIS."""
    reading = text.SPACE.validate(reading)
    s = setup(reading)
    runs = {}
    for i, lam in enumerate(s.lambdas):
        make_batch, estimators, cmc = make_batch_fn(s, i, mc)
        runs[text.case_label(lam)] = evaluation.evaluate(estimators, make_batch, cmc, progress=False,
                                                         consistency=consistency)
    return ControlResults(reading, s, runs)


def rms_per_axis(rs: evaluation.RunSet, components: tuple, window: slice) -> metrics.MCValue:
    r"""Per-axis RMS error over the runs and the window's steps (deviation C-2): :math:`\sqrt{\overline{(e_x^2 +
    e_y^2)/2}}` for ``components`` (x index, y index), the per-run time means being the replications
    (:func:`mmlib.experiment.metrics.rms_with_se`, delta-method standard error); unit of the components."""
    sq = (rs.errors[:, window][..., list(components)] ** 2).mean(axis=(1, 2))
    return metrics.rms_with_se(sq, rs.valid)


def case_values(results: ControlResults) -> dict:
    """``{(case label, quantity): MCValue}`` of the filter the reading reports (factor C-1)."""
    s = results.setup
    return {(label, q): rms_per_axis(results.runs[label][s.report], idx, s.window)
            for label in results.runs for q, idx in text.QUANTITIES}


def values(results: ControlResults) -> list:
    """``(item, algorithm, quantity, value, standard error)`` for every published cell of every control table."""
    cv = case_values(results)
    return [(p.item, p.algorithm, p.quantity, float(cv[(p.item.split(" (")[0], p.quantity)].value),
             float(cv[(p.item.split(" (")[0], p.quantity)].stderr)) for p in text.PUBLISHED]


def claims(results: ControlResults) -> report.Claims:
    """The known answers of the claim rule: on a linear-Gaussian model the CKF is the Kalman filter, so "the CKF is
    more accurate than the KF" is *not supported* (identical to round-off) at every tracking index."""
    out = report.Claims()
    for label, runs in results.runs.items():
        window = {k: evaluation.RunSet(**{**rs._asdict(), "errors": rs.errors[:, results.setup.window]})
                  for k, rs in runs.items()}
        out.add(f"the CKF is more accurate than the KF ({label})",
                *evaluation.better_claim(window, "CKF", "KF", [("position", (0, 2))], unit="m²"),
                key="ckf_vs_kf_" + re.sub(r"[^0-9a-z]+", "_", label.split("=")[-1].lower()).strip("_"))
    return out


def effects(results: ControlResults) -> list:
    """The key effect (the KF's replicated position MSE per axis of the headline case, m², beside the closed form
    alpha sigma_w^2; the KF's whatever factor C-1 reports, since C-1 is metric-only: it changes no effect) and the
    paired CKF − KF position MSE (m²) of every case."""
    s = results.setup
    lam = s.lambdas[text.HEADLINE_CASE]
    head = rms_per_axis(results.runs[text.case_label(lam)]["KF"], (0, 2), s.window)
    mse, se = float(head.value) ** 2, 2.0 * float(head.value) * float(head.stderr)
    out = [(text.KEY_EFFECT, mse, se, closed_form.steady_state(lam, s.T, s.sigma_w).P[0, 0])]
    for label, runs in results.runs.items():
        d = evaluation.paired_mse_difference(runs["CKF"], runs["KF"], (0, 2))
        out.append((f"CKF − KF position MSE, {label} (m²)", float(d.value), float(d.stderr), 0.0))
    return out


def summarise(results: ControlResults, n_runs: int) -> UniverseResult:
    """The universe result of one reading."""
    return UniverseResult.build(values=values(results), claims=claims(results), effects=effects(results),
                                diverged={f"{label} {alg}": int((~rs.valid).sum())
                                          for label, runs in results.runs.items() for alg, rs in runs.items()},
                                n_runs=n_runs)


def universe(reading: Mapping[str, str], n_runs: int, seed: int) -> UniverseResult:
    """The contract's ``universe``: one reading on ``n_runs`` runs of root seed ``seed``."""
    return summarise(evaluate_reading(reading, MonteCarlo(seed, n_runs)), n_runs)


def table_rows(summary: UniverseResult) -> list:
    """The rows of every control table (:func:`mmlib.experiment.report.make_row`): the closed form has no Monte
    Carlo error (``n_runs_paper`` None, deviation C-4)."""
    devs = ["C-1", "C-2", "C-3", "C-4"]
    return [report.make_row(p.item, p.algorithm, p.quantity, p.printed, v.replicated, v.stderr,
                            n_runs=summary.n_runs, n_runs_paper=None, deviations=devs, note=p.table)
            for p in text.PUBLISHED for v in [summary.value(p.key)]]


def consistency(results: ControlResults) -> list:
    """The ``consistency`` section: NEES and NIS of the KF and the CKF in every case over the averaging window
    (:func:`mmlib.experiment.evaluation.consistency_entries`; ``results`` from ``consistency=True``)."""
    w = results.setup.window
    out = []
    for label, runs in results.runs.items():
        cut = {k: evaluation.RunSet(**{**rs._asdict(), "errors": rs.errors[:, w], "nees": rs.nees[:, w],
                                       "nis": rs.nis[:, w], "nis_dof": np.asarray(rs.nis_dof)[w]})
               for k, rs in runs.items()}
        out += evaluation.consistency_entries(cut, 4, case=label)
    return out


def headline_digest(n_runs: int) -> dict:
    """The run digest of the headline reading's first ``n_runs`` runs, every case (what the notebook stores)."""
    return digests.run_digest(evaluate_reading(text.SPACE.headline, MonteCarlo(text.ROOT_SEED, n_runs)).runs, n_runs)
