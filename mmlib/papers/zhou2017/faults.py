"""The sensor faults of Zhou et al. 2017, Eq. 2: an additive ``delta h_out`` on a range-bearing radar's (range m,
bearing rad) measurements, as a :class:`mmlib.core.models.SensorFault` of shape (B, K, 2).

:func:`mmlib.core.models.radar_drift` builds the paper-agnostic drift (any range-bearing radar's constant
range offset and accumulating bearing drift); :func:`radar_fault` draws Case 2's faults of a set-up's fault
reading (Z-6) from each run's FAULT stream.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Sequence

import numpy as np

from mmlib.core import models
from mmlib.core.models import radar_drift
from mmlib.experiment.montecarlo import MonteCarlo, Stream

__all__ = [
    "radar_fault"
]

if TYPE_CHECKING:
    import mmlib


def radar_fault(setup: mmlib.papers.zhou2017.setup.Setup, mc: MonteCarlo, runs: Sequence[int] | np.ndarray,
                times: Sequence[float] | np.ndarray) -> models.SensorFault:
    """The Case 2 fault (Eq. 2's delta h_out) of the runs, from the FAULT stream; every fault kind uses
    the same 2K + 2 normals per run (common random numbers across the Z-6 readings):

    * ``constant-drift``: range offset U[-5, 5] m constant; bearing drift rate U[0, 1e-2] rad/s,
      delta_theta_k = rate * t_k (rad);
    * ``per-step``: fresh U[-5, 5] m and U[0, 1e-2 rad/s * T] rad every step;
    * ``constant``: range offset U[-5, 5] m and bearing offset U[0, 1e-2 rad/s * T] rad, constant."""
    from scipy.special import ndtr
    K = len(times)
    p = ndtr(mc.standard_normal(runs, Stream.FAULT, (2 * K + 2,)))   # uniforms (probability integral transform)
    if setup.fault_kind == "constant-drift":
        dr = (2 * p[:, 0] - 1) * setup.fault_range_max
        rate = p[:, 1] * setup.fault_bearing_rate_max
        return radar_drift(dr, rate, times)
    if setup.fault_kind == "constant":
        dr = np.repeat(((2 * p[:, 0] - 1) * setup.fault_range_max)[:, None], K, axis=1)
        dth = np.repeat((p[:, 1] * setup.fault_bearing_rate_max * setup.T)[:, None], K, axis=1)
        return models.SensorFault(np.stack([dr, dth], axis=-1))
    dr = (2 * p[:, 2:2 + K] - 1) * setup.fault_range_max                    # fresh each step
    dth = p[:, 2 + K:2 + 2 * K] * setup.fault_bearing_rate_max * setup.T    # fresh angle each step
    return models.SensorFault(np.stack([dr, dth], axis=-1))


