"""The no-information baseline of Zhou et al. 2017's universes: the measurement-only estimate (each raw range-bearing
measurement turned into a position alone), its errors on the filters' own runs, and the rule that flags a universe
*degenerate* when no filter is detectably and non-negligibly better than it in a case
(:func:`mmlib.experiment.evaluation.degenerate_reason`; issue 24).  Under the drift reading of Z-6 the fault is
unobservable: every filter tracks the alias trajectory, no better than the raw measurements.
"""
from __future__ import annotations

import math
from typing import Mapping, NamedTuple, Sequence

import numpy as np

from mmlib.experiment import evaluation, metrics
from mmlib.experiment.montecarlo import MonteCarlo
from mmlib.papers.zhou2017.setup import build, setup as reading_setup, simulator

__all__ = [
    "error_norms", "Baseline", "measurement_only_errors", "baselines", "position_rmse", "paired_error",
    "degenerate_reason", "BASELINE_WHAT", "POSITION", "VELOCITY"
]

#: the position and velocity components of the state [x, vx, y, vy]
POSITION, VELOCITY = (0, 2), (1, 3)


def error_norms(rs: evaluation.RunSet, comps: Sequence[int]) -> np.ndarray:
    """Per run and step, the Euclidean norm of the errors of the state components ``comps`` (e.g. the position's
    x and y, in m): shape (N, K) from a RunSet's errors (N, K, n)."""
    return np.sqrt((rs.errors[..., list(comps)] ** 2).sum(-1))


#: what the no-information baseline of :func:`baselines` is, in the words of a degenerate universe's reason
BASELINE_WHAT = ("the measurement-only estimate's position RMSE on the same runs (each raw range-bearing measurement "
                 "converted to x, y; an estimator's ± is that of its paired difference from it)")


class Baseline(NamedTuple):
    """The measurement-only estimate of one case on a set of runs (:func:`baselines`): ``rmse``, its position RMSE
    (m) with the delta-method standard error over runs, and ``per_run`` (N,), each run's time-averaged squared
    position error (m²), for paired comparisons on the same runs."""

    rmse: metrics.MCValue
    per_run: np.ndarray


def measurement_only_errors(truth: np.ndarray, z: np.ndarray, sensor: Sequence[float] = (0.0, 0.0)) -> np.ndarray:
    r"""Per run and step, the position error (m) of the measurement-only estimate: each raw range-bearing
    measurement (r, theta) in m and rad converted to :math:`(x, y) = s + r(\cos\theta, \sin\theta)` (``sensor`` s in
    m), the estimate that ignores the dynamics and every earlier measurement.  ``truth`` (N, K+1, 4) [x, vx, y, vy]
    with the initial state first, ``z`` (N, K, 2); returns (N, K) Euclidean norms."""
    truth, z = np.asarray(truth, dtype=float), np.asarray(z, dtype=float)
    if truth.ndim != 3 or truth.shape[-1] != 4 or z.ndim != 3 or z.shape[-1] != 2 \
            or z.shape[:2] != (truth.shape[0], truth.shape[1] - 1):
        raise ValueError(f"truth, z: expected (N, K+1, 4) and (N, K, 2), got {truth.shape} and {z.shape}")
    sx, sy = (float(v) for v in sensor)
    ex = sx + z[..., 0] * np.cos(z[..., 1]) - truth[:, 1:, 0]
    ey = sy + z[..., 0] * np.sin(z[..., 1]) - truth[:, 1:, 2]
    return np.hypot(ex, ey)


def baselines(reading: Mapping, mc: MonteCarlo) -> dict:
    r"""The no-information baseline of each case of ``reading`` on ``mc``'s runs (the runs every filter sees:
    same truth, measurements and faults): ``{"case 1": Baseline, "case 2": Baseline}``, the measurement-only
    estimate's (:func:`measurement_only_errors`) position RMSE
    :math:`\sqrt{\frac{1}{NK}\sum_{i,k}\lVert \hat p_{i,k} - p_{i,k}\rVert^2}` with its delta-method standard
    error over runs (:func:`mmlib.experiment.metrics.rms_with_se`), and its per-run time-averaged squared errors."""
    out = {}
    for key, setup in zip(("case 1", "case 2"), reading_setup(reading)):
        schedule, radar, _ = build(setup)
        truth, z, _ = simulator(setup, schedule, radar)(mc)(range(mc.n_runs))
        sq = (measurement_only_errors(truth, z, radar.sensor) ** 2).mean(axis=1)
        out[key] = Baseline(metrics.rms_with_se(sq), sq)
    return out


def position_rmse(rs: evaluation.RunSet) -> float:
    """Root of the run- and time-averaged squared position error (m) over the runs that did not diverge, the
    statistic of :func:`baselines`; infinity when every run diverged."""
    ok = rs.valid
    if not ok.any():
        return math.inf
    return float(np.sqrt((error_norms(rs, POSITION)[ok] ** 2).mean()))


def paired_error(rs: evaluation.RunSet, base: Baseline) -> tuple[float, float]:
    r"""``(value, stderr)`` of ``rs``'s position RMSE for a paired comparison with the baseline ``base`` on the same
    runs: over the runs valid for ``rs`` (per-run time-averaged squared errors :math:`m_i` and the baseline's
    :math:`\beta_i`), the difference :math:`d = \sqrt{\bar m} - \sqrt{\bar\beta}` with the delta-method standard
    error of the per-run influence values :math:`m_i / (2\sqrt{\bar m}) - \beta_i / (2\sqrt{\bar\beta})`; returned
    as ``base.rmse.value + d`` so that its difference from the baseline's value is the paired one, and its standard
    error that of the difference (which carries the baseline's own).  ``(inf, nan)`` when every run diverged (never
    better than the baseline), a NaN standard error with a single valid run."""
    ok = rs.valid
    if not ok.any():
        return math.inf, math.nan
    m = (error_norms(rs, POSITION)[ok] ** 2).mean(axis=1)
    beta = np.asarray(base.per_run, dtype=float)[ok]
    e, b = math.sqrt(m.mean()), math.sqrt(beta.mean())
    infl = m / (2 * e) - beta / (2 * b)
    se = float(infl.std(ddof=1) / math.sqrt(len(infl))) if len(infl) > 1 else math.nan
    return float(base.rmse.value) + (e - b), se


def degenerate_reason(results: dict, base: Mapping) -> str:
    r"""Why the universe of ``results`` (:func:`evaluate_reading`) is degenerate, "" when it is not.

    A case is degenerate when none of its algorithms is detectably and non-negligibly more accurate than the
    measurement-only estimate of the same runs, ``base[case]`` (:func:`baselines`):
    :func:`mmlib.experiment.evaluation.degenerate_reason` (the claim rule on "RMSE < baseline": below by more than 3
    standard errors and by more than the claims' negligible 1 %) on each algorithm's paired position RMSE
    (:func:`paired_error`: runs are common, so the difference's standard error is the paired one; a diverged
    algorithm never beats the baseline).  No filter then extracts anything from the target's motion, and a
    comparison of them measures only how they fail.  Measured on the headline's 100 runs: under the drift reading of
    Z-6 the Case 2 filters' RMSE lies 0.1 % below the baseline's (MSE 0.2 %), under the per-step and constant readings
    11 % and 6 % below, in Case 1 22 % below.  It is a no-information test, not an observability test: with R's
    bearing variance read as 15 deg² (Z-3) the raw bearings are so noisy that the filters beat them by averaging, so
    a drift universe there is not flagged although the drift is as unobservable
    (:func:`mmlib.papers.zhou2017.diagnostics.fault_observability`).  ``base[case]`` may also be a plain number (a
    baseline RMSE without runs; each algorithm then enters with its own standard error).

    **The rule per case.**  The universe is flagged when *either* case is degenerate, and the reason names the case.
    The paper's contribution rests on Case 2 (the title's "sensor faults", Table 3, the key effect and four of the six
    simulated claims), so a degenerate Case 2 voids the universe; Case 1's claims do not depend on the fault reading
    (Z-6: its set-up has no fault, :func:`relevant_setup`), so dropping a universe whose Case 2 alone is degenerate
    removes nothing from the Case 1 claims' shares but runs: the same Case 1 numbers occur, bit for bit, in the
    universes of the other fault readings, and in a uniform sample of the space Z-6 is independent of every other
    factor.  A degenerate Case 1 (a fault-free radar the filters cannot beat: measured, filters tuned to q/10 or q/100,
    Z-13) voids the Case 1 claims, and the universe is flagged for it too (a per-case flag would keep its Case 2
    claims; the universe result has one flag)."""
    if not isinstance(results, Mapping) or set(results) != {"case 1", "case 2"}:
        raise ValueError("results: expected evaluate_reading(...)'s {'case 1': {...}, 'case 2': {...}}")
    if not isinstance(base, Mapping) or set(base) != {"case 1", "case 2"}:
        raise ValueError(f"base: expected baselines(...)'s {{'case 1': ..., 'case 2': ...}}, got {base!r:.80}")
    parts = []
    for case in ("case 1", "case 2"):
        b = base[case]
        if isinstance(b, Baseline):
            errors = {alg: paired_error(rs, b) for alg, rs in results[case].items()}
            value = float(b.rmse.value)
        else:
            value = float(b)
            errors = {alg: metrics.rms_with_se(np.nan_to_num((error_norms(rs, POSITION) ** 2).mean(axis=1)),
                                               rs.valid) if rs.valid.any() else (math.inf, math.nan)
                      for alg, rs in results[case].items()}
        why = evaluation.degenerate_reason(errors, (value, 0.0), what=BASELINE_WHAT)
        if why:
            parts.append(f"{case.capitalize()}: {why}")
    return "; ".join(parts)
