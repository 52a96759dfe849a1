"""mmlib: batched multiple-model and sigma-point Kalman filtering for replication studies.

Layout: ``rules`` (quadrature rules) -> ``filters`` (one generic recursion, one
Kalman update) -> layers over any filter (``strong_tracking``, ``adaptive``,
``bootstrap``) -> ``estimation`` (single model, IMM combinator with pluggable
``mixing``, batched driver);
``models`` and ``simulate`` (dynamics, sensors, truth); ``montecarlo``
(deterministic per-run streams); ``metrics`` (errors with standard errors);
``report`` (verdict rule, results contract); ``scenarios`` (one module per paper).
"""
from mmlib.core.layers import adaptive, bootstrap, strong_tracking
from mmlib.core import estimation, filters, linalg, mixing, models, rules
from mmlib.experiment import metrics, montecarlo, report, simulate
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
    "adaptive", "bootstrap", "estimation", "filters", "linalg", "metrics", "mixing", "models", "montecarlo", "report",
    "rules", "simulate", "strong_tracking",
    "InnovationAdaptive", "ObservationBootstrap", "CubatureMixing", "StrongTracking",
    "IMM", "MomentMixing", "SingleModel", "Track", "run",
    "ExtendedKalmanFilter", "GaussianState", "KalmanFilter", "SigmaPointFilter", "filter_by_name", "kalman_update",
    "MonteCarlo", "Stream",
    "CentralDifference", "Cubature", "FifthDegreeCubature", "SphericalSimplexRadial", "Unscented", "rule_by_name",
]
