"""What only the notebook of Zhou et al. 2017 shows: every algorithm's consistency (NEES and NIS, both cases), the
evidence that the headline's accumulating bearing drift cannot be told from the target's motion
(:func:`fault_observability`), Section 4.2, whose field
experiments (Tables 4-5) rest on unpublished data (Z-11), with a clearly labelled synthetic analogue of the
vehicle INS/GPS test (NOT a replication), and the key effect across the reading space against the value Table 3
implies (:func:`key_effect_across`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from mmlib.core import models
from mmlib.core.estimation import SingleModel
from mmlib.core.filters import ExtendedKalmanFilter, SigmaPointFilter
from mmlib.core.layers.adaptive import InnovationAdaptive
from mmlib.core.rules import Cubature, Unscented
from mmlib.experiment import evaluation, metrics, report
from mmlib.experiment.montecarlo import MonteCarlo, Stream
from mmlib.experiment.multiverse import Multiverse
from mmlib.papers.zhou2017 import study, text
from mmlib.papers.zhou2017.faults import radar_fault
from mmlib.papers.zhou2017.setup import Setup, build, setup, simulator
from mmlib.papers.zhou2017.text import MAE_QUANTITIES, TABLE4, TABLE5

__all__ = [
    "consistency", "alias_positions", "fault_observability", "field_experiment_rows", "GPSAnalogue", "gps_analogue",
    "gps_analogue_table", "key_effect_across"
]


def consistency(reading: Mapping, mc: MonteCarlo) -> list:
    """NEES and NIS of every algorithm of both cases of ``reading`` on ``mc``'s runs: the ``consistency`` section of
    the results file (:func:`mmlib.papers.zhou2017.study.consistency_entries`: ANEES with 4 and ANIS with 2 degrees
    of freedom and their 95 % chi-square bands, over the runs that did not diverge; one entry per algorithm and case,
    "case 1" and "case 2").  The estimates are those of :func:`~mmlib.papers.zhou2017.study.evaluate_reading`, bit for
    bit."""
    return study.consistency_entries(study.evaluate_reading(reading, mc, consistency=True))


def alias_positions(setup: Setup, truth: np.ndarray, delta: np.ndarray) -> np.ndarray:
    r"""Per run and step, the position (x, y) in m of the *alias* of the faulted radar: the point whose fault-free
    range and bearing equal the truth's faulted ones, :math:`s + (r_k + \delta r_k)(\cos(\theta_k + \delta\theta_k),
    \sin(\theta_k + \delta\theta_k))` for the true range r_k and bearing theta_k seen from the radar at s and the
    fault ``delta`` (N, K, 2) of Eq. 2 (m, rad).  A target moving along the alias, seen by a fault-free radar, gives
    the same measurements in distribution as the true target seen by the faulted one: no filter of this sensor can
    tell the two apart unless the alias's motion is implausible under the filter's models.  ``truth`` (N, K+1, 4)
    [x, vx, y, vy]; returns (N, K, 2)."""
    _, radar, _ = build(setup)
    truth, delta = np.asarray(truth, dtype=float), np.asarray(delta, dtype=float)
    if truth.ndim != 3 or truth.shape[-1] != 4 or delta.shape != (truth.shape[0], truth.shape[1] - 1, 2):
        raise ValueError(f"truth, delta: expected (N, K+1, 4) and (N, K, 2), got {truth.shape} and {delta.shape}")
    s = np.asarray(radar.sensor, dtype=float)
    faulted = radar.h(truth[:, 1:]) + delta          # the radar's own measurement function, faulted (Eq. 2)
    r, th = faulted[..., 0], faulted[..., 1]
    return np.stack([s[0] + r * np.cos(th), s[1] + r * np.sin(th)], axis=-1)


def fault_observability(mc: MonteCarlo, reading: Mapping | None = None, faults: tuple | None = None) -> list:
    r"""The evidence on whether Case 2's fault can be told from the target's motion, for each fault reading of
    factor Z-6 (``faults``, default every option; every other factor as in ``reading``, default the headline), on
    ``mc``'s runs.  Per fault reading a
    dict: ``fault`` (the option), ``baseline`` (the measurement-only estimate's position RMSE, m, with ``stderr``:
    :func:`~mmlib.papers.zhou2017.study.baselines`), ``errors`` ({algorithm: position RMSE over its valid runs, m}),
    ``gain`` ({algorithm: 1 - MSE / baseline MSE}, the share of the measurement-only mean squared error the filter
    removes), ``alias_rmse`` ({algorithm: RMSE of its position estimate from the alias trajectory of
    :func:`alias_positions` over its valid runs, m}) -- each None for an algorithm diverged in every run --,
    ``alias_offset`` (RMSE of the alias from the truth, m: the error of an estimator that recovers the alias
    exactly), ``anis`` ({algorithm: the ANIS summary of
    :func:`mmlib.experiment.evaluation.consistency`, 2 degrees of freedom: whether the innovations betray the
    fault}), ``diverged`` ({algorithm: diverged runs}) and ``degenerate`` (the universe's reason,
    :func:`~mmlib.papers.zhou2017.study.degenerate_reason`, "" when it is not).  Case 1's filter gain is ``case1_gain``
    (the same for every fault reading)."""
    reading = text.SPACE.headline if reading is None else text.SPACE.validate(reading)
    names = text.SPACE.factor("Z-6").names
    if faults is not None and (isinstance(faults, str) or not all(f in names for f in faults)):
        raise ValueError(f"faults: expected None or a tuple of Z-6 options {names}, got {faults!r}")
    out = []
    for fault in names if faults is None else faults:
        r = {**reading, "Z-6": fault}
        res = study.evaluate_reading(r, mc, consistency=True)
        base = study.baselines(r, mc)
        case2 = setup(r).case2
        schedule, radar, _ = build(case2)
        truth, _, _ = simulator(case2, schedule, radar)(mc)(range(mc.n_runs))
        delta = radar_fault(case2, mc, range(mc.n_runs), schedule.times).delta
        alias = alias_positions(case2, truth, delta)
        offset = np.sqrt(((alias - truth[:, 1:][..., [0, 2]]) ** 2).sum(-1).mean())
        row = {"fault": fault, "baseline": float(base["case 2"].rmse.value),
               "stderr": float(base["case 2"].rmse.stderr),
               "errors": {}, "gain": {}, "alias_rmse": {}, "alias_offset": float(offset), "anis": {},
               "diverged": {}, "degenerate": study.degenerate_reason(res, base)}
        for alg, rs in res["case 2"].items():
            ok = rs.valid
            err = study.position_rmse(rs)
            finite = math.isfinite(err)
            row["errors"][alg] = err if finite else None
            row["gain"][alg] = 1 - (err / row["baseline"]) ** 2 if finite else None
            est = truth[:, 1:][..., [0, 2]] + rs.errors[..., list(study.POSITION)]
            row["alias_rmse"][alg] = float(np.sqrt(((est[ok] - alias[ok]) ** 2).sum(-1).mean())) if finite else None
            row["anis"][alg] = evaluation.consistency(rs.nis, rs.nis_dof, ok, white=True)
            row["diverged"][alg] = int((~ok).sum())
        b1 = float(base["case 1"].rmse.value)
        row["case1_gain"] = {alg: 1 - (study.position_rmse(rs) / b1) ** 2 if rs.valid.any() else None
                             for alg, rs in res["case 1"].items()}
        out.append(row)
    return out


def field_experiment_rows() -> list:
    """Tables 4-5: kept with the paper's values and the verdict 'not replicable' (Z-11)."""
    rows = []
    for table, name in ((TABLE4, "Table 4"), (TABLE5, "Table 5")):
        for alg, values in table.items():
            for q, printed in zip(MAE_QUANTITIES, values):
                rows.append(report.make_row(name, alg, q, printed, None, None, reason="data not published (Z-11)",
                                            deviations=["Z-11"]))
    return rows


# ---------------------------------------------------------------- synthetic analogue of Section 4.2.1
@dataclass(frozen=True)
class GPSAnalogue:
    """NOT a replication: a GPS-like position/velocity sensor (5 m, 0.05 m/s, the paper's stated GPS
    precision) on the Section 4.1 trajectory, carrying the paper's two fault types -- a fixed position
    deviation (x, U[-5, 5] m per run) and a drift (y, rate U[0, 0.1] m/s per run, accumulating)."""

    base: Setup = Setup()
    pos_sd: float = 5.0
    vel_sd: float = 0.05
    offset_max: float = 5.0
    drift_rate_max: float = 0.1
    window: int = 10
    inflate_only: bool = False


def gps_analogue(an: GPSAnalogue, mc: MonteCarlo) -> tuple:
    """``(make_batch, estimators, schedule)`` of the synthetic analogue (NOT a replication): single-model EKF, CKF,
    UKF, AUKF and NAUKF on the CV model, measuring position and velocity [x, vx, y, vy] (m, m/s) with the fixed x
    offset and the accumulating y drift of ``an`` drawn per run from the FAULT stream; ``make_batch(runs) ->
    (truth (B, K+1, 4), measurements (B, K, 4), {name: initial state})``, every filter started at the true x0
    with P0 = diag(P0_sd)^2."""
    T = an.base.T
    cv = models.constant_velocity(T, an.base.q_cv)
    gps = models.LinearMeasurement(np.eye(4), np.diag([an.pos_sd ** 2, an.vel_sd ** 2, an.pos_sd ** 2, an.vel_sd ** 2]),
                                   "GPS")
    schedule, _, _ = build(an.base)
    ukf = SigmaPointFilter(Unscented(*an.base.ukf), name="UKF")
    filters = {"EKF": ExtendedKalmanFilter(name="EKF"), "CKF": SigmaPointFilter(Cubature(), name="CKF"), "UKF": ukf,
               "AUKF": InnovationAdaptive(ukf, window=an.window, zeta=False, include_current=False,
                                          inflate_only=an.inflate_only, name="AUKF"),   # Mohamed & Schwarz 1999
               "NAUKF": InnovationAdaptive(ukf, window=an.window, inflate_only=an.inflate_only, name="NAUKF")}
    estimators = {k: SingleModel(f, cv, gps, name=k) for k, f in filters.items()}
    P0 = np.diag(np.square(an.base.P0_sd))

    def fault(runs):
        from scipy.special import ndtr
        p = ndtr(mc.standard_normal(runs, Stream.FAULT, (2,)))
        t = schedule.times
        delta = np.zeros((len(runs), len(t), 4))
        delta[:, :, 0] = ((2 * p[:, 0] - 1) * an.offset_max)[:, None]
        delta[:, :, 2] = (p[:, 1] * an.drift_rate_max)[:, None] * t[None, :]
        return models.SensorFault(delta)

    make_batch = evaluation.make_batches(mc, schedule, gps, an.base.x0, estimators,
                                         lambda est, m0, runs: est.init(m0, P0),
                                         process_noise=an.base.truth_process_noise, fault=fault)
    return make_batch, estimators, schedule


def gps_analogue_table(mc: MonteCarlo) -> tuple[list, dict]:
    """The synthetic analogue's table (NOT a replication): x and y mean absolute errors (m, mean over runs
    with standard errors) and diverged runs of EKF, CKF, UKF, AUKF and NAUKF as printed, and of AUKF and
    NAUKF in the inflate-only reading (Z-12).  Returns (rows of cells, {filter [reading]: {"diverged": n}})."""
    from mmlib.experiment.views import value_pm
    rows, diverged = [], {}
    for label, an in (("as printed", GPSAnalogue()), ("inflate-only", GPSAnalogue(inflate_only=True))):
        mba, esta, _ = gps_analogue(an, mc)
        names = tuple(esta) if label == "as printed" else ("AUKF", "NAUKF")
        resa = evaluation.evaluate(evaluation.select(esta, names), mba, mc, progress=False)
        for alg, rs in resa.items():
            ok = rs.valid
            cells = [f"{alg} ({label})" if alg in ("AUKF", "NAUKF") else alg]
            for comp in (0, 2):
                mae = metrics.mean_with_se(np.abs(rs.errors[..., comp]).mean(axis=1), ok)
                cells.append(value_pm(float(mae.value), float(mae.stderr), 2) if mae.n_runs else "--")
            cells.append(f"{int((~ok).sum())}/{mc.n_runs}")
            rows.append(cells)
            diverged[f"{alg} [{label}]"] = {"diverged": int((~ok).sum())}
    return rows, diverged




def key_effect_across(mv: Multiverse) -> dict:
    """The key effect (:data:`~mmlib.papers.zhou2017.text.KEY_EFFECT`, CPIMM-NAUKF − IMM-UKF, Case 2 position MSE,
    m²) in every universe of a :class:`~mmlib.experiment.multiverse.Multiverse`, against the value Table 3 implies
    (``published``: an implied, not a printed, number).  Per universe with a value and a standard error:

    * its sign, as the part "CPIMM-NAUKF < IMM-UKF" (:func:`mmlib.experiment.verdicts.part`, expected sign -1):
      ``below`` if it *holds* (at least 3 s.e. below zero), ``above`` if *contradicted*;
    * the verdict rule on the implied number (:func:`mmlib.experiment.verdicts.verdict`, no printed digit and no
      paper run count: the implied value has no Monte Carlo error of its own): ``reproduced`` (within 3 s.e. and
      precise enough to tell, 3 s.e. <= 25 % of it) or ``inconclusive`` (within 3 s.e. only because 3 s.e. is wider).

    Returns ``{"published", "n_universes", "valued"`` (universes with a value: in the others CPIMM-NAUKF diverged in
    every run), ``"no_stderr"`` (values resting on a single surviving run), ``"below"``, ``"above"``,
    ``"reproduced"``, ``"inconclusive"}``, the last four lists of ``(Effect, reading)``."""
    from mmlib.papers.zhou2017.text import KEY_EFFECT
    published = mv.effect(mv.headline, KEY_EFFECT).published
    out = {"published": published, "n_universes": len(mv.universes), "valued": 0, "no_stderr": 0,
           "below": [], "above": [], "reproduced": [], "inconclusive": []}
    for u, reading in zip(mv.universes, mv.readings):
        e = mv.effect(u, KEY_EFFECT)
        if e.value is None:
            continue
        out["valued"] += 1
        if e.stderr is None:
            out["no_stderr"] += 1
            continue
        sign = report.part("CPIMM-NAUKF − IMM-UKF", "Case 2 position MSE", e.value, e.stderr, -1, unit="m²").verdict
        if sign == report.PartVerdict.HOLDS:
            out["below"].append((e, reading))
        elif sign == report.PartVerdict.CONTRADICTED:
            out["above"].append((e, reading))
        if published is not None:
            cat = report.verdict_category(report.verdict(float(published), e.value, e.stderr))
            if cat == report.REPRODUCED:
                out["reproduced"].append((e, reading))
            elif cat == report.INCONCLUSIVE:
                out["inconclusive"].append((e, reading))
    return out
