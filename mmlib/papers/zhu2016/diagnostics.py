"""What only the notebook of Zhu, Wang & Yuan 2016 shows about the minimum-MSE floor (not in the paper).

:func:`cv_steady_state_sd` checks the clairvoyant floor in closed form away from the turns (the steady state of the
Riccati equation of a CV target); :func:`floor_summary` counts, across the reading space, the universes where
Table 1's smallest printed IMM value lies below the floor (:func:`mmlib.papers.zhu2016.study.floor_check`).
"""
from __future__ import annotations

import numpy as np

from mmlib.experiment import report
from mmlib.experiment.multiverse import Multiverse
from mmlib.papers.zhu2016.setup import Setup, setup
from mmlib.papers.zhu2016.study import floor_is_bound
from mmlib.papers.zhu2016.text import QUANTITIES, TABLE1


def cv_steady_state_sd(setup: Setup) -> dict:
    """Steady-state posterior standard deviations of the Kalman filter for a CV target in each axis
    (discrete algebraic Riccati equation; per axis F = [[1, T], [0, 1]], G = [T²/2, T]ᵀ, Q = G q Gᵀ,
    position measured with variance r): ``{state index: s.d.}`` in m and m/s.  A closed-form check of
    the clairvoyant floor away from the turns."""
    import scipy.linalg
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
