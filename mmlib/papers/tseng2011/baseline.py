r"""The no-information baseline of Tseng et al. 2011's reconstruction: the single-epoch least-squares position fix.

A receiver that ignores the vehicle's dynamics altogether fixes its position from each epoch's pseudoranges alone:
the four unknowns :math:`y = [e, n, u, b]` (local East-North-Up position and receiver clock bias, m) minimise
:math:`\sum_i (\rho_i - \lVert s_i - p\rVert - b)^2` over the m >= 4 satellites in view (equal weights: the
pseudorange noise is white with one standard deviation, T-4).  A filter that is no more accurate than this fix has
learnt nothing from the dynamics, so a universe in which every filter's horizontal position RMSE is at least the
fix's is *degenerate* (:func:`mmlib.experiment.evaluation.degenerate_reason`; issue 24).

:func:`ls_fix` is the vectorised Gauss-Newton solution (Kaplan & Hegarty 2006, Sec. 2.4.2; Misra & Enge 2011,
Sec. 6.1): from :math:`y^{(0)}`, :math:`y^{(j+1)} = y^{(j)} + (H^T H)^{-1} H^T (\rho - h(y^{(j)}))` with
:math:`H_i = [-(s_i - p)^T/\lVert s_i - p\rVert, 1]`, which converges quadratically from the local frame's origin for
a receiver within kilometres of it (the satellites are ~2e7 m away).  :func:`ls_errors` runs it on the runs of a
Monte Carlo (the same truth and pseudoranges as the filters, :func:`mmlib.papers.tseng2011.simulation.simulator`) and
:func:`ls_rms` gives the fix's horizontal RMSE.
"""
from __future__ import annotations

import numpy as np

from mmlib.core._validate import as_float_array, check_finite, check_positive_int
from mmlib.experiment import metrics
from mmlib.experiment.metrics import MCValue
from mmlib.experiment.montecarlo import MonteCarlo
from mmlib.papers.tseng2011.simulation import Experiment, simulator
from mmlib.papers.tseng2011.text import EAST, NORTH

__all__ = [
    "ls_fix", "ls_errors", "ls_rms", "WHAT"
]

#: what the baseline is, in the words of a degenerate universe's reason
WHAT = "the single-epoch least-squares fix's horizontal position RMSE"


def ls_fix(satellites: np.ndarray, pseudoranges: np.ndarray, *, max_iterations: int = 20,
           tol: float = 1e-6) -> np.ndarray:
    r"""Least-squares fix :math:`[e, n, u, b]` (..., 4) (m) of one epoch's pseudoranges ``pseudoranges`` (..., m) (m)
    from satellites at ``satellites`` (..., m, 3) (ENU, m; broadcast against the pseudoranges' leading axes), m >= 4,
    by Gauss-Newton from the frame's origin with zero clock bias (module docstring).  It stops when every
    solution's step is below ``tol`` (m) or after ``max_iterations`` iterations; a ValueError names ``satellites`` or
    ``pseudoranges`` for a shape that does not fit, fewer than four satellites or a non-finite value."""
    sats = check_finite(as_float_array(satellites, "satellites"), "satellites")
    rho = check_finite(as_float_array(pseudoranges, "pseudoranges"), "pseudoranges")
    if sats.ndim < 2 or sats.shape[-1] != 3:
        raise ValueError(f"satellites: expected shape (..., m, 3), got {sats.shape}")
    if sats.shape[-2] < 4:
        raise ValueError(f"satellites: a fix needs at least 4 satellites, got {sats.shape[-2]}")
    if rho.ndim < 1 or rho.shape[-1] != sats.shape[-2]:
        raise ValueError(f"pseudoranges: expected shape (..., {sats.shape[-2]}) for {sats.shape[-2]} satellites, got "
                         f"{rho.shape}")
    try:
        lead = np.broadcast_shapes(sats.shape[:-2], rho.shape[:-1])
    except ValueError:
        raise ValueError(f"pseudoranges: leading shape {rho.shape[:-1]} does not broadcast against the satellites' "
                         f"{sats.shape[:-2]}") from None
    max_iterations = check_positive_int(max_iterations, "max_iterations")
    if not tol > 0:
        raise ValueError(f"tol: expected a positive step size (m), got {tol!r}")
    m = sats.shape[-2]
    y = np.zeros(lead + (4,))
    for _ in range(max_iterations):
        d = sats - y[..., None, :3]                                    # (..., m, 3)
        r = np.sqrt((d * d).sum(axis=-1))                              # (..., m)
        H = np.concatenate([-d / r[..., None], np.ones(lead + (m, 1))], axis=-1)   # (..., m, 4)
        res = rho - (r + y[..., 3:])                                   # (..., m)
        Ht = np.swapaxes(H, -1, -2)
        step = np.linalg.solve(Ht @ H, (Ht @ res[..., None]))[..., 0]
        y = y + step
        if np.abs(step).max() <= tol:
            break
    return y


def ls_errors(ex: Experiment, mc: MonteCarlo) -> np.ndarray:
    """Horizontal errors (N, K, 2) (East, North; m) of the single-epoch fix (:func:`ls_fix`) at every epoch of the
    runs of ``mc`` on ``ex``'s geometry: the truth and pseudoranges the filters see (the same streams,
    :func:`~mmlib.papers.tseng2011.simulation.simulator`).  Epochs with the same number of satellites in view are
    solved together."""
    if not isinstance(ex, Experiment):
        raise ValueError(f"ex: expected an Experiment (simulation.experiment), got {type(ex).__name__}")
    if not isinstance(mc, MonteCarlo):
        raise ValueError(f"mc: expected a MonteCarlo, got {type(mc).__name__}")
    simulate = simulator(ex)(mc)
    models = ex.measurement_models
    dims = np.array([model.dim for model in models])
    out = []
    for runs in mc.chunks():
        truth, z, _ = simulate(runs)
        err = np.empty((len(runs), len(models), 2))
        for m in np.unique(dims):
            steps = np.flatnonzero(dims == m)
            sats = np.stack([models[k].satellites for k in steps])          # (K_m, m, 3)
            rho = np.stack([z[k] for k in steps], axis=1)                   # (B, K_m, m)
            fix = ls_fix(sats, rho)
            err[:, steps, 0] = fix[..., 0] - truth[:, steps + 1, EAST]
            err[:, steps, 1] = fix[..., 1] - truth[:, steps + 1, NORTH]
        out.append(err)
    return np.concatenate(out)


def ls_rms(ex: Experiment, mc: MonteCarlo) -> MCValue:
    r"""The fix's horizontal position RMSE :math:`\sqrt{\frac{1}{NK}\sum_{r,k}(e_{r,k}^2 + n_{r,k}^2)}` (m) over the
    runs of ``mc`` and all epochs, with its standard error over runs (:func:`ls_errors`)."""
    err = ls_errors(ex, mc)
    return metrics.rmse_time_averaged(np.hypot(err[..., 0], err[..., 1]))
