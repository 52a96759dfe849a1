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
from typing import TYPE_CHECKING

from mmlib.core._lazy import lazy_attributes

__version__ = "0.1.0"

__all__ = [
    "IMM", "SingleModel", "run", "Track", "SigmaPointFilter", "Unscented", "Cubature", "FifthDegreeCubature",
    "SphericalSimplexRadial", "CentralDifference", "rule_by_name", "ExtendedKalmanFilter", "KalmanFilter",
    "filter_by_name", "MonteCarlo", "Stream", "MomentMixing", "CubatureMixing", "StrongTracking", "InnovationAdaptive",
    "ObservationBootstrap", "GaussianState", "kalman_update"
]

# Everything below is imported on first use (PEP 562): ``import mmlib`` alone imports nothing of the library, so a
# process that needs one small module (a notebook kernel's ``mmlib.experiment.montecarlo``) does not pay for numba,
# scipy.stats and the whole estimation core (issue 25: its imports took 2.4 s, now numpy's 0.2 s).  ``mmlib.IMM``,
# ``from mmlib import IMM`` and ``mmlib.models`` work as before; the first access imports the defining module and
# binds the name here.  A type checker reads the same names from the block under TYPE_CHECKING, which
# tests/test_lazy_imports.py keeps equal to the tables.

#: the modules, reachable as mmlib.models, mmlib.metrics ... (attributes, not in __all__: its names are the API objects)
_MODULES = {
    "adaptive": "mmlib.core.layers.adaptive", "bootstrap": "mmlib.core.layers.bootstrap",
    "strong_tracking": "mmlib.core.layers.strong_tracking", "estimation": "mmlib.core.estimation",
    "filters": "mmlib.core.filters", "linalg": "mmlib.core.linalg", "mixing": "mmlib.core.mixing",
    "models": "mmlib.core.models", "rules": "mmlib.core.rules", "metrics": "mmlib.experiment.metrics",
    "montecarlo": "mmlib.experiment.montecarlo", "report": "mmlib.experiment.report",
    "simulate": "mmlib.experiment.simulate",
}
#: the API objects of __all__, by the module that defines them
_OBJECTS = {
    "mmlib.core.layers.adaptive": ("InnovationAdaptive",),
    "mmlib.core.layers.bootstrap": ("ObservationBootstrap",),
    "mmlib.core.mixing": ("CubatureMixing",),
    "mmlib.core.layers.strong_tracking": ("StrongTracking",),
    "mmlib.core.estimation": ("IMM", "MomentMixing", "SingleModel", "Track", "run"),
    "mmlib.core.filters": ("ExtendedKalmanFilter", "GaussianState", "KalmanFilter", "SigmaPointFilter",
                           "filter_by_name", "kalman_update"),
    "mmlib.experiment.montecarlo": ("MonteCarlo", "Stream"),
    "mmlib.core.rules": ("CentralDifference", "Cubature", "FifthDegreeCubature", "SphericalSimplexRadial", "Unscented",
                         "rule_by_name"),
}
_OBJECT_MODULE = {name: module for module, names in _OBJECTS.items() for name in names}

if TYPE_CHECKING:
    from mmlib.core.layers import adaptive, bootstrap, strong_tracking  # noqa: F401
    from mmlib.core import estimation, filters, linalg, mixing, models, rules  # noqa: F401
    from mmlib.experiment import metrics, montecarlo, report, simulate  # noqa: F401
    from mmlib import core, experiment  # noqa: F401  (and every subpackage, on first access)
    from mmlib.core.layers.adaptive import InnovationAdaptive
    from mmlib.core.layers.bootstrap import ObservationBootstrap
    from mmlib.core.mixing import CubatureMixing
    from mmlib.core.layers.strong_tracking import StrongTracking
    from mmlib.core.estimation import IMM, MomentMixing, SingleModel, Track, run
    from mmlib.core.filters import (ExtendedKalmanFilter, GaussianState, KalmanFilter, SigmaPointFilter,
                                    filter_by_name, kalman_update)
    from mmlib.experiment.montecarlo import MonteCarlo, Stream
    from mmlib.core.rules import (CentralDifference, Cubature, FifthDegreeCubature, SphericalSimplexRadial,
                                  Unscented, rule_by_name)


__getattr__, __dir__ = lazy_attributes(__name__, globals(), _MODULES, _OBJECTS)
