"""What only the notebook of Zhu, Wang & Yuan 2016 shows (not in the paper): the minimum-MSE floor, the filters'
consistency and the claims under each sensor of Z-5.

:func:`cv_steady_state_sd` checks the clairvoyant floor in closed form away from the turns (the steady state of the
Riccati equation of a CV target); :func:`floor_summary` counts, across the reading space, the universes where
Table 1's smallest printed IMM value lies below the floor (:func:`mmlib.papers.zhu2016.study.floor_check`);
:func:`consistency` is the results file's ``consistency`` section (NEES and NIS of every estimator against their
chi-square bands) and :func:`nees_over_time` the per-step average NEES of one; :func:`sensor_claims` the abstract's
claims in the universes that change only the sensor of Eq. 62 (Z-5).
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from mmlib.experiment import evaluation, report
from mmlib.experiment.evaluation import RunSet
from mmlib.experiment.multiverse import Multiverse
from mmlib.papers.zhu2016.setup import Setup, setup
from mmlib.papers.zhu2016.study import floor_is_bound
from mmlib.papers.zhu2016.text import QUANTITIES, SPACE, TABLE1

__all__ = [
    "consistency", "nees_over_time", "sensor_claims", "cv_steady_state_sd", "floor_summary", "STATE_DIM",
    "SENSOR_CLAIMS"
]

#: the state dimension n of ``[x, vx, y, vy]``: the NEES's degrees of freedom
STATE_DIM = 4
#: the claims of the abstract judged under each sensor of Z-5 (:func:`sensor_claims`)
SENSOR_CLAIMS = ("IMM5CKF is more accurate than IMMCKF", "IMM5CKF is more accurate than IMMUKF",
                 "IMM5CKF switches modes more quickly than IMMCKF/IMMUKF")


def consistency(results: Mapping[str, RunSet]) -> list:
    """The ``consistency`` section of the results file (:func:`mmlib.experiment.evaluation.consistency_entries`):
    per estimator of ``results`` (name -> RunSet of :func:`mmlib.papers.zhu2016.study.evaluate_reading` with
    ``consistency=True``), the time- and run-averaged NEES (4 degrees of freedom, dimensionless) and NIS (2
    degrees of freedom) over the runs that did not diverge, each with its standard error, its 95 % chi-square band
    and whether it lies inside (a consistent filter's covariance is honest: ANEES near 4, ANIS near 2)."""
    return evaluation.consistency_entries(results, STATE_DIM)


def nees_over_time(rs: RunSet) -> np.ndarray:
    """The NEES averaged over the runs that did not diverge, per step: (K,) (dimensionless; 4 for a consistent
    filter), from a RunSet recorded with ``consistency=True``; ValueError naming ``rs`` otherwise."""
    if not isinstance(rs, RunSet) or rs.nees is None:
        raise ValueError("rs: expected a RunSet with NEES recorded (evaluate_reading(..., consistency=True))")
    return np.asarray(rs.nees, dtype=float)[rs.valid].mean(axis=0)


def sensor_claims(mv: Multiverse) -> list:
    """The claims :data:`SENSOR_CLAIMS` per option of Z-5 (the sensor of Eq. 62 and its noise): ``option``,
    ``label``, ``motivated_by``, ``linear`` (position sensor), then for the universe that changes only Z-5 (the
    headline for the headline option; absent from a design that does not run it) ``verdicts`` and ``decisive``
    (claim -> text, None when not run), and across the counted universes of that option (:meth:`Multiverse.counted`:
    motivated and degenerate universes left out) ``counts``, claim -> {verdict: number of universes}, with
    ``n_counted`` universes."""
    factor = SPACE.factor("Z-5")
    counted = set(mv.counted())
    out = []
    for opt in factor.options:
        one = SPACE.with_headline(**{"Z-5": opt.name})
        idx = next((i for i, r in enumerate(mv.readings) if dict(r) == dict(one)), None)
        verdicts, decisive = {}, {}
        for c in SENSOR_CLAIMS:
            found = None if idx is None else next(x for x in mv.universes[idx].claims if x.claim == c)
            verdicts[c] = None if found is None else found.verdict
            decisive[c] = None if found is None else found.decisive
        these = [i for i in sorted(counted) if mv.readings[i]["Z-5"] == opt.name]
        counts = {c: {} for c in SENSOR_CLAIMS}
        for i in these:
            for c in SENSOR_CLAIMS:
                v = mv.universes[i].claim(c)
                counts[c][v] = counts[c].get(v, 0) + 1
        out.append({"option": opt.name, "label": opt.label, "motivated_by": opt.motivated_by,
                    "linear": setup(one).sensor == "position", "verdicts": verdicts, "decisive": decisive,
                    "counts": counts, "n_counted": len(these)})
    return out


def cv_steady_state_sd(setup: Setup) -> dict:
    """Steady-state posterior standard deviations of the Kalman filter for a CV target in each axis
    (discrete algebraic Riccati equation; per axis F = [[1, T], [0, 1]], G = [T²/2, T]ᵀ, Q = G q Gᵀ,
    position measured with variance r): ``{state index: s.d.}`` in m and m/s.  A closed-form check of
    the clairvoyant floor away from the turns; the position sensor only (ValueError naming ``setup`` otherwise)."""
    import scipy.linalg
    if not isinstance(setup, Setup) or setup.sensor != "position":
        raise ValueError("setup: expected a Setup with the position sensor (the closed form is the linear one's)")
    out = {}
    for pos, r_var in ((0, setup.r[0]), (2, setup.r[1])):
        F1 = np.array([[1.0, setup.T], [0.0, 1.0]])
        G1 = np.array([[setup.T ** 2 / 2], [setup.T]])
        P_pred = scipy.linalg.solve_discrete_are(F1.T, np.array([[1.0], [0.0]]), G1 @ G1.T * setup.q,
                                                 np.array([[r_var]]))
        P_post = P_pred - np.outer(P_pred[:, 0], P_pred[:, 0]) / (P_pred[0, 0] + r_var)
        out[pos], out[pos + 1] = float(np.sqrt(P_post[0, 0])), float(np.sqrt(P_post[1, 1]))
    return out


def floor_summary(mv: Multiverse) -> list:
    """Across a multiverse: per quantity, in how many universes the smallest printed IMM value of
    Table 1 lies more than 3 combined standard errors below that universe's clairvoyant floor (all
    universes, and those where the floor is a bound, :func:`floor_is_bound`), and the range of the
    floor (m or m/s)."""
    bound = [floor_is_bound(setup(r)) for r in mv.readings]
    out = []
    for q, _ in QUANTITIES:
        margins = [mv.effect(u, f"smallest printed IMM value − floor: {q}") for u in mv.universes]
        floors = [mv.value(u, ("floor", "clairvoyant KF", q)).replicated for u in mv.universes]
        below = [m.value <= -report.SIGMA_FACTOR * m.stderr for m in margins]
        out.append({"quantity": q, "n_below": int(sum(below)), "n_universes": len(margins),
                    "n_bound": int(sum(bound)), "n_below_where_bound": int(sum(b and x for b, x in zip(bound, below))),
                    "floor_min": float(min(floors)), "floor_max": float(max(floors)),
                    "paper_min_imm": min((TABLE1[a][[x for x, _ in QUANTITIES].index(q)]
                                          for a in ("IMM5CKF", "IMMCKF", "IMMUKF")), key=float)})
    return out
