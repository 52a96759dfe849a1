"""mmlib: batched multiple-model and sigma-point Kalman filtering for replication studies.

Layout: ``rules`` (quadrature rules) -> ``filters`` (one generic recursion, one
Kalman update) -> ``estimation`` (single model, IMM combinator, batched driver);
``models`` and ``simulate`` (dynamics, sensors, truth); ``montecarlo``
(deterministic per-run streams); ``metrics`` (errors with standard errors);
``report`` (verdict rule, results contract); ``scenarios`` (one module per paper).
"""
from . import estimation, filters, linalg, metrics, models, montecarlo, report, rules, simulate
from .estimation import IMM, MomentMixing, SingleModel, Track, run
from .filters import (ExtendedKalmanFilter, GaussianState, KalmanFilter, SigmaPointFilter,
                      filter_by_name, kalman_update)
from .montecarlo import MonteCarlo, Stream
from .rules import (CentralDifference, Cubature, FifthDegreeCubature, SphericalSimplexRadial,
                    Unscented, rule_by_name)

__version__ = "0.1.0"

__all__ = [
    "estimation", "filters", "linalg", "metrics", "models", "montecarlo", "report", "rules", "simulate",
    "IMM", "MomentMixing", "SingleModel", "Track", "run",
    "ExtendedKalmanFilter", "GaussianState", "KalmanFilter", "SigmaPointFilter", "filter_by_name", "kalman_update",
    "MonteCarlo", "Stream",
    "CentralDifference", "Cubature", "FifthDegreeCubature", "SphericalSimplexRadial", "Unscented", "rule_by_name",
]
