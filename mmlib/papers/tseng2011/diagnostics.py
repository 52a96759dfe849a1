"""What only the notebook of Tseng et al. 2011 uses: the UKF/EKF coincidence claim, the clairvoyant reference
("oracle") schedules of the process noise, the filters' consistency (NEES/NIS) and the claims' verdicts in the words
of a reconstruction.
"""
from __future__ import annotations

from typing import Iterable, Mapping, Sequence

import numpy as np

from mmlib.core.estimation import KnownModeSequence
from mmlib.core.filters import SigmaPointFilter
from mmlib.core.rules import Unscented
from mmlib.core import gnss
from mmlib.experiment import evaluation, report, verdicts
from mmlib.experiment.montecarlo import MonteCarlo
from mmlib.papers.tseng2011.setup import Setup, noise_model
from mmlib.papers.tseng2011.simulation import Experiment, make_batch_fn, motion_schedule
from mmlib.papers.tseng2011.study import direction_parts, rms, rms_reduction
from mmlib.papers.tseng2011.text import ALGORITHMS, AXES, EAST, NAME, NORTH

__all__ = [
    "ekf_claim", "maneuver_flags", "clairvoyant_schedules", "evaluate_oracles", "oracle_summary", "consistency",
    "qualified_claims"
]


def ekf_claim(results: dict) -> tuple:
    """Judgement and evidence on "the UKF avoids the EKF's linearisation errors" (needs the EKF in ``results``):
    not assessable when the two coincide to far below the noise (1 mm), since there are then no linearisation
    errors to avoid; else the paired comparison per axis (:func:`mmlib.papers.tseng2011.study.direction_parts`).
    Returns ``((Judgement, evidence), largest |UKF - EKF| position difference (m))``."""
    diff = float(np.abs(results["UKF"].errors[..., [0, 2, 4]] - results["EKF"].errors[..., [0, 2, 4]]).max())
    if diff < 1e-3:
        return (report.Judgement.of(report.NOT_ASSESSABLE,
                                    f"|UKF − EKF| ≤ {diff:.1e} m: the pseudoranges are linear over the filter's "
                                    f"spread, so there are no linearisation errors to avoid"),
                f"|UKF - EKF| <= {diff:.1e} m over all runs and epochs"), diff
    parts, evidence = direction_parts(results, "UKF", "EKF")
    return (report.judge(parts), evidence), diff


def maneuver_flags(setup: Setup) -> np.ndarray:
    """1 for the steps the truth spends turning, else 0 (K,): the schedule's own step-to-segment map."""
    return (motion_schedule(setup).modes() > 0).astype(int)


def clairvoyant_schedules(ex: Experiment, straight: Sequence[float] = (0.0, 1e-4, 1e-3),
                          turning: Sequence[float] = (0.1, 0.3, 1.0)) -> dict:
    """NOT a filter one can run: the UKF told *when* the vehicle maneuvers, with process-noise level
    ``straight`` on the straight legs (down to 0, the truth's value) and ``turning`` in the turns (m^2/s^3).  The
    best schedule of the grid (chosen in hindsight) is a *reference* for what adapting Q to the
    maneuvers can buy -- not a strict bound (other schedules, or an IMM with adapted modes, could
    do somewhat better)."""
    noise = noise_model(ex.setup)
    ukf = SigmaPointFilter(Unscented(*ex.setup.ukf), name="UKF")
    flags = maneuver_flags(ex.setup)
    return {f"oracle S_p {a:g}/{b:g}": KnownModeSequence(ukf, [noise.dynamics(a), noise.dynamics(b)], flags, None,
                                                         name=f"oracle {a:g}/{b:g}")
            for a in straight for b in turning}


def evaluate_oracles(ex: Experiment, mc: MonteCarlo, progress: bool = False) -> dict:
    """``{schedule: RunSet}`` of the :func:`clairvoyant_schedules` on ``ex``'s geometry and the runs of ``mc`` (the
    same truth and measurements as the filters)."""
    oracles = clairvoyant_schedules(ex)
    ex_or = Experiment(ex.setup, ex.truth_plane, ex.sky, oracles)
    return evaluation.evaluate(oracles, make_batch_fn(ex_or, mc), mc, label=f"{NAME} oracle", progress=progress,
                               measurement_models=ex.measurement_models)


def oracle_summary(oracles: dict, imm: evaluation.RunSet) -> list:
    """Per schedule of ``oracles`` (:func:`evaluate_oracles`): its East and North RMS errors ``[value, s.e.]`` (m)
    and its RMS reductions against the IMMUKF's runs ``imm`` (the same runs) ``[[East], [North]]`` (%), as the
    results file's ``oracle_schedules``."""
    out = []
    for name, r_ in oracles.items():
        e_, n_ = rms(r_, EAST), rms(r_, NORTH)
        red_e, red_n = (rms_reduction(r_, imm, comp) for _, _, comp in AXES)
        out.append({"schedule": name, "east": [float(e_.value), float(e_.stderr)],
                    "north": [float(n_.value), float(n_.stderr)],
                    "reduction_vs_immukf_percent": [[float(red_e.value), float(red_e.stderr)],
                                                    [float(red_n.value), float(red_n.stderr)]]})
    return out


def consistency(results: Mapping, names: Sequence[str] = ALGORITHMS) -> list:
    r"""The results file's ``consistency`` section: per filter of ``names`` (default every algorithm of the paper),
    the ANEES over the 8-state position-velocity-clock vector (:math:`\chi^2_8` per step for a consistent filter)
    and the ANIS over the pseudoranges of the satellites in view (:math:`\chi^2_{m_k}`, m_k = 6 or 7 changing with
    this sky, so the band is built from the per-step degrees of freedom), with their 95 % bands
    (:func:`mmlib.experiment.evaluation.consistency_entries`).  ``results`` ``{name: RunSet}`` from
    :func:`~mmlib.papers.tseng2011.study.evaluate_reading` with ``consistency=True``; a name missing from it, or
    evaluated without NEES/NIS, is a ValueError naming it."""
    names = list(names)
    missing = [n for n in names if n not in results]
    if missing:
        raise ValueError(f"names: {missing} not in results (have {sorted(results)})")
    for n in names:
        if getattr(results[n], "nees", None) is None or getattr(results[n], "nis", None) is None:
            raise ValueError(f"results[{n!r}]: no NEES/NIS recorded; evaluate the reading with consistency=True")
    return evaluation.consistency_entries({n: results[n] for n in names}, gnss.STATE_DIM)


def qualified_claims(claims: Iterable[Mapping], qualifier: str) -> list:
    """Copies of judged claims (:meth:`mmlib.experiment.verdicts.Claims.as_list` entries) for display, each
    ``verdict`` in the words of ``qualifier`` (:func:`mmlib.experiment.verdicts.qualified`: for a reconstruction,
    "contradicted by the reconstruction", "holds in the reconstruction"): the paper's set-up is lost (Section 4), so
    a verdict is on our reconstruction of it, never on the paper.  The results file keeps the plain verdict (the
    qualifier is written beside it)."""
    out = []
    for c in claims:
        if not isinstance(c, Mapping) or "verdict" not in c:
            raise ValueError(f"claims: expected judged claims (Claims.as_list() entries), got {c!r}")
        out.append({**c, "verdict": verdicts.qualified(c["verdict"], qualifier)})
    return out
