"""What only the Hu et al. 2017 notebook shows: the truth's plausibility under the readings of the noise unit
(H-4, H-13), how closely the five IMMs coincide, and how the reading space's universes move from the headline.

Lengths in km, speeds in km/s.  No algorithm lives here: everything is computed from :mod:`mmlib.papers.hu2017.setup`
and :mod:`mmlib.papers.hu2017.study`.
"""
from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from mmlib.experiment import evaluation, report
from mmlib.experiment.montecarlo import MonteCarlo
from mmlib.experiment.multiverse import Multiverse
from mmlib.papers.hu2017.setup import batch, setup
from mmlib.papers.hu2017.study import KEY_EFFECT, ReadingResult
from mmlib.papers.hu2017.text import ALGORITHMS, SPACE

__all__ = [
    "truth_statistics", "consistency", "coincidence", "influence", "bootstrapping_helps", "INFLUENCE_EFFECTS"
]

#: the quantities :func:`influence` watches besides the claim verdicts: every Table 1 cell and these effects
INFLUENCE_EFFECTS = (KEY_EFFECT, "mode_probability_obs_minus_cdkf")


def truth_statistics(reading: Mapping, mc: MonteCarlo, n: int) -> dict:
    """The truth of the first ``n`` runs under a reading (H-4's plausibility argument and H-13's size): median
    over runs of the largest speed (km/s), the largest speed of all, the smallest range to the radar (km), and
    how far the truth's process noise moves the target: per run the largest distance (km) between the truth
    and the noise-free truth of the same reading (H-13 = without; same measurement draws), its median over
    runs and its largest value (0 when the reading's truth is noise-free)."""
    runs = range(min(n, mc.n_runs))
    reading = SPACE.validate(reading)
    truth = batch(setup(reading), mc, names=("IMMCDKF",))[0](runs)[0]
    calm = batch(setup({**reading, "H-13": "without"}), mc, names=("IMMCDKF",))[0](runs)[0]
    speed = np.hypot(truth[..., 1], truth[..., 3])
    rng = np.hypot(truth[..., 0], truth[..., 2])
    moved = np.hypot(truth[..., 0] - calm[..., 0], truth[..., 2] - calm[..., 2]).max(axis=1)
    return {"median_max_speed": float(np.median(speed.max(axis=1))), "max_speed": float(speed.max()),
            "min_range": float(rng.min()), "median_max_noise_displacement": float(np.median(moved)),
            "max_noise_displacement": float(moved.max())}


def consistency(res: ReadingResult) -> list:
    """The ``consistency`` section of the results file: per IMM of :data:`~mmlib.papers.hu2017.text.ALGORITHMS`,
    its ANEES (4 degrees of freedom: the state [x, vx, y, vy]) and ANIS (2: range and bearing) over the runs that
    did not diverge, each with its standard error and 95 % chi-square band
    (:func:`mmlib.experiment.evaluation.consistency_entries`; one case, so ``case`` is "").  ``res`` must come from
    ``evaluate_reading(..., consistency=True)`` (ValueError naming the IMM otherwise).  The NEES is that of the
    IMM's combined estimate and covariance (Bar-Shalom, Li & Kirubarajan 2001, Sec. 5.4.2); IMMCDKF-OBS's is that
    of its fused covariance, which Eqs. 22-24 shrink as if the N + 1 members were independent."""
    return evaluation.consistency_entries({alg: res.runs[alg] for alg in ALGORITHMS}, 4)


def coincidence(res: ReadingResult) -> dict:
    """Largest absolute difference between a position estimate and IMMCDKF's, over all runs and steps (km), per
    other third-degree IMM and the IMMEKF."""
    ref = res.runs["IMMCDKF"].errors[..., [0, 2]]
    return {alg: float(np.max(np.abs(res.runs[alg].errors[..., [0, 2]] - ref)))
            for alg in ("IMMUKF", "IMMCKF", "IMMEKF")}


def influence(mv: Multiverse, factor_id: str) -> dict:
    """How far the one-factor-at-a-time universes of ``factor_id`` move from the headline universe:
    the largest absolute change divided by its combined standard error over the Table 1 cells and over
    :data:`INFLUENCE_EFFECTS`, and the claims whose verdict category changes.  A description, not a test of
    non-influence: the combined standard error sqrt(se_a^2 + se_b^2) ignores the positive correlation of
    common random numbers, so it overstates the standard error of the change and the ratios are *lower
    bounds* of its significance; and a one-factor change cannot show an interaction (H-13 matters far more
    under H-4 = km).  ``moves`` is True when some ratio reaches 1 or a claim verdict changes."""

    def z(va, sa, vb, sb):
        if va is None or vb is None or va == vb:
            return 0.0
        se = math.hypot(sa or 0.0, sb or 0.0)
        return abs(vb - va) / se if se > 0 else math.inf

    head = mv.headline
    cells, effects, changed = 0.0, 0.0, set()
    for i, fid, _ in mv.one_factor_view():
        if fid != factor_id:
            continue
        u = mv.universes[i]
        for a, b in zip(head.values, u.values):
            cells = max(cells, z(a.replicated, a.stderr, b.replicated, b.stderr))
        for name in INFLUENCE_EFFECTS:
            a, b = mv.effect(head, name), mv.effect(u, name)
            effects = max(effects, z(a.value, a.stderr, b.value, b.stderr))
        for ca, cb in zip(head.claims, u.claims):
            if report.claim_category(ca.verdict) != report.claim_category(cb.verdict):
                changed.add(ca.claim)
    return {"table1_cells_se": cells, "effects_se": effects, "claims_changed": sorted(changed),
            "moves": bool(changed) or max(cells, effects) >= 1.0}


def bootstrapping_helps(mv: Multiverse) -> list:
    """The distinct simulations (:meth:`Multiverse.simulations`) in which 'IMMCDKF-OBS is more accurate than IMMCDKF'
    holds: (index of its first universe, description of its reading without the metric-only factors, key
    effect value, its standard error)."""
    out = []
    for idx in mv.simulations():
        u = mv.universes[idx[0]]
        c = next(c for c in u.claims if c.claim.startswith("IMMCDKF-OBS is more accurate than IMMCDKF"))
        if report.claim_category(c.verdict) == "holds":
            e = mv.effect(u, KEY_EFFECT)
            out.append((idx[0], SPACE.describe_simulation(mv.readings[idx[0]]), e.value, e.stderr))
    return out
