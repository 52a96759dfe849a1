r"""mmlib: batched multiple-model and sigma-point Kalman filtering for replication studies.

The folders are the layers, numbered; each depends only on the layers with a smaller number:

1. ``mmlib.core`` -- the estimation core, paper-agnostic: quadrature rules (``rules``), one generic filter and one
   Kalman update (``filters``), thin layers over any filter (``core.layers``: strong tracking, innovation adaptation,
   observation bootstrapping, noise-adaptive IMM), the IMM combinator and the batched driver (``estimation``,
   ``mixing``), dynamics and measurement models (``models``, ``gnss``), fuzzy inference (``fuzzy``); the interfaces
   as ``typing.Protocol``\ s (``protocols``);
2. ``mmlib.experiment`` -- Monte Carlo streams (``montecarlo``), truth simulation (``simulate``), scenarios as data
   (``scenario``), metrics with standard errors (``metrics``), evaluation, reading spaces and the grid runner, the
   verdict rule (``verdicts``), universe results and the paper contract (``universe``, ``paper``), results files
   (``results``, ``writing``);
3. ``mmlib.papers`` -- one package per paper behind one contract (:class:`mmlib.experiment.paper.Paper`), listed in
   ``mmlib.papers.REGISTRY``: its declared text, set-up, scenario and universe job;
4. ``mmlib.arena`` -- every algorithm of the papers on every scenario (recipes, the controlled ladder, the study).

The most used names are re-exported here (``mmlib.IMM``, ``mmlib.SigmaPointFilter``, ``mmlib.models`` ...).
"""
# the modules, reachable as mmlib.models, mmlib.metrics ... (attributes, not in __all__: its names are the API objects)
from mmlib.core.layers import adaptive, bootstrap, strong_tracking  # noqa: F401
from mmlib.core import estimation, filters, linalg, mixing, models, rules  # noqa: F401
from mmlib.experiment import metrics, montecarlo, report, simulate  # noqa: F401
from mmlib.core.layers.adaptive import InnovationAdaptive
from mmlib.core.layers.bootstrap import ObservationBootstrap
from mmlib.core.mixing import CubatureMixing
from mmlib.core.layers.strong_tracking import StrongTracking
from mmlib.core.estimation import IMM, MomentMixing, SingleModel, Track, run
from mmlib.core.filters import (ExtendedKalmanFilter, GaussianState, KalmanFilter, SigmaPointFilter, filter_by_name,
                                kalman_update)
from mmlib.experiment.montecarlo import MonteCarlo, Stream
from mmlib.core.rules import (CentralDifference, Cubature, FifthDegreeCubature, SphericalSimplexRadial, Unscented,
                              rule_by_name)

__version__ = "0.1.0"

__all__ = [
    "IMM", "SingleModel", "run", "Track", "SigmaPointFilter", "Unscented", "Cubature", "FifthDegreeCubature",
    "SphericalSimplexRadial", "CentralDifference", "rule_by_name", "ExtendedKalmanFilter", "KalmanFilter",
    "filter_by_name", "MonteCarlo", "Stream", "MomentMixing", "CubatureMixing", "StrongTracking", "InnovationAdaptive",
    "ObservationBootstrap", "GaussianState", "kalman_update"
]
