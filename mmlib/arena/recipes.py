r"""Every algorithm of the five papers as a recipe: how to build it from any scenario's models
(:class:`mmlib.experiment.scenario.Scenario`), with its parameters stated once.

A recipe says which paper proposed or ran the algorithm, what it needs of a scenario (an IMM's mode set, a
single motion model, a process-noise family whose level can be set online) and how to assemble it from the
core's pieces: a rule, the one generic filter, thin layers, the IMM combinator.  Where an algorithm cannot apply to
a scenario, :func:`applicability` says why (e.g. "needs an IMM mode set: ..."), never a blank.

Parameters, stated once here:

* the layers' parameters come from the proposing paper's headline set-up: strong tracking's softening factor
  beta = 4.5 and forgetting factor rho = 0.95 (Liu & Wu 2017, :class:`mmlib.papers.liu2017.setup.Setup`); NAUKF's window
  and Eq. 27-28 options and AUKF's (Zhou et al. 2017, :class:`mmlib.papers.zhou2017.setup.Setup`, its Table 4 analogue);
  the bootstrap's N, variance factor, likelihood and fused covariance, and the central-difference form (Hu et al.
  2017, :class:`mmlib.papers.hu2017.setup.Setup`); the FLAS's breakpoints, normalisation and window (Tseng et al. 2011,
  :class:`mmlib.papers.tseng2011.setup.Setup`);
* what belongs to a scenario's set-up comes from the scenario: its models, process noise, P0, transition matrix,
  initial mode probabilities and its unscented rule's (alpha, beta, kappa) (each paper tunes its own UKF; the
  ladder uses (1, 2, 0));
* NAUKF and AUKF as printed diverge wherever the windowed innovation covariance falls below :math:`HPH^T`
  (:mod:`mmlib.core.layers.adaptive`); the arena also runs them under the bounded reading of Zhou et al.'s factor
  Z-12 (``[inflate-only]``), a declared reading, labelled;
* names: one spelling per algorithm (``IMMUKF``; Zhou et al.'s ``IMM-UKF``, ``IMM-EKF`` and ``IMM-CKF`` are
  aliases of ``IMMUKF``, ``IMMEKF`` and ``IMMCKF``).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from mmlib.core._validate import check_bool, check_choice, check_has
from mmlib.core.estimation import IMM, MomentMixing, SingleModel
from mmlib.core.filters import ExtendedKalmanFilter, SigmaPointFilter
from mmlib.core.layers.adaptive import InnovationAdaptive
from mmlib.core.layers.adaptive_imm import NoiseAdaptiveIMM
from mmlib.core.layers.fuzzy_noise import fuzzy_imm
from mmlib.core.layers.bootstrap import ObservationBootstrap
from mmlib.core.layers.strong_tracking import StrongTracking
from mmlib.core.protocols import Estimator, MomentFilter
from mmlib.core.mixing import CubatureMixing
from mmlib.core.rules import CentralDifference, Cubature, FifthDegreeCubature, SphericalSimplexRadial, Unscented
from mmlib.experiment.montecarlo import MonteCarlo
from mmlib.experiment.scenario import Scenario
from mmlib.papers import REGISTRY

__all__ = [
    "build", "recipe", "Recipe", "RECIPES", "ALGORITHMS", "ALIASES", "applicability", "requirement", "NotApplicable",
    "initial_state", "ukf", "cdkf", "naukf", "aukf", "cdkf_obs", "strong", "LIU", "ZHOU", "HU", "TSENG", "KINDS"
]

#: the proposing papers' headline set-ups (their headline readings), whose layer parameters the recipes use
LIU = REGISTRY["liu2017"].headline_setup().example1
ZHOU = REGISTRY["zhou2017"].headline_setup().case1
HU = REGISTRY["hu2017"].headline_setup()
TSENG = REGISTRY["tseng2011"].headline_setup()


#: what a recipe builds on: the scenario's IMM modes, its single model, or its noise family (an IMM set online)
KINDS = ("imm", "single", "noise-adaptive imm")


class NotApplicable(ValueError):
    """An algorithm that cannot run on a scenario; the message says why."""


# ------------------------------------------------------------------------------------------------ mode filters
def ukf(s: Scenario) -> SigmaPointFilter:
    """The scenario's unscented KF, named "UKF": its own rule parameters ``s.ukf`` = (alpha, beta, kappa)."""
    _check_scenario(s, "s")
    return SigmaPointFilter(Unscented(*s.ukf), name="UKF")


def cdkf(s: Scenario) -> SigmaPointFilter:
    """Hu et al.'s CDKF (Eqs. 10-17) in the central-difference form of their headline (factor H-1)."""
    _check_scenario(s, "s")
    return SigmaPointFilter(CentralDifference(form=HU.cd_form), name="CDKF")


def naukf(s: Scenario, inflate_only: bool | None = None) -> InnovationAdaptive:
    """NAUKF (Zhou et al. 2017, Eqs. 27-39) over the scenario's UKF, with the window, psi (Eq. 32) and Z-12 reading
    of Zhou's headline; ``inflate_only=True`` is the bounded reading of factor Z-12."""
    _check_inflate_only(inflate_only)
    return InnovationAdaptive(ukf(s), window=ZHOU.window, psi=ZHOU.psi,
                              inflate_only=ZHOU.inflate_only if inflate_only is None else inflate_only, name="NAUKF")


def aukf(s: Scenario, inflate_only: bool | None = None) -> InnovationAdaptive:
    """The classic innovation-based adaptive UKF that Zhou et al.'s Table 4 compares with NAUKF (Mohamed & Schwarz
    1999: no adaptive gene, the window of innovations before the current one) over the scenario's UKF, with NAUKF's
    window and Z-12 reading of Zhou's headline."""
    _check_inflate_only(inflate_only)
    return InnovationAdaptive(ukf(s), window=ZHOU.window, zeta=False, include_current=False,
                              inflate_only=ZHOU.inflate_only if inflate_only is None else inflate_only, name="AUKF")


def cdkf_obs(s: Scenario) -> ObservationBootstrap:
    """Observation bootstrapping (Hu et al. 2017) over the CDKF with Hu's headline N, variance factor, likelihood
    and fused covariance (Sec. 2.2, Eqs. 18-23; factors H-6, H-7, H-8)."""
    return ObservationBootstrap(cdkf(s), n_boot=HU.n_boot, variance_factor=HU.boot_variance_factor,
                                likelihood=HU.obs_likelihood, covariance=HU.obs_covariance, name="CDKF-OBS")


def _check_inflate_only(value) -> None:
    if value is not None:
        check_bool(value, "inflate_only")


def strong(base: MomentFilter, name: str) -> StrongTracking:
    """Strong tracking (Liu & Wu 2017, Eqs. 20-36) over ``base`` with the softening factor beta and forgetting factor
    rho of Liu's headline Example 1; over an EKF the Jacobian form of the fading factor (the STF of Zhou & Frank)."""
    form = {"form": "jacobian"} if isinstance(base, ExtendedKalmanFilter) else {}
    return StrongTracking(base, beta=LIU.beta, rho=LIU.rho, name=name, **form)


# ------------------------------------------------------------------------------------------------ recipes
@dataclass(frozen=True)
class Recipe:
    """How to build one algorithm: ``kind`` "imm" (over the scenario's modes), "single" (over its single model) or
    "noise-adaptive imm" (over its noise family); ``filter(scenario)`` the mode filter (with its layers); ``mixing``
    the IMM's interaction; :attr:`papers` the registered papers that run it."""

    name: str
    kind: str
    filter: Callable
    description: str
    mixing: Callable = MomentMixing

    def __post_init__(self):
        for arg in ("name", "description"):
            if not isinstance(getattr(self, arg), str) or not getattr(self, arg):
                raise ValueError(f"{arg}: expected a non-empty string, got {getattr(self, arg)!r}")
        check_choice(self.kind, "kind", KINDS)
        for arg in ("filter", "mixing"):
            if not callable(getattr(self, arg)):
                raise ValueError(f"{arg}: expected a function of the scenario (or a mixing class), got "
                                 f"{type(getattr(self, arg)).__name__}")

    @property
    def papers(self) -> tuple:
        """The registered papers whose arena entry runs this algorithm (:attr:`mmlib.experiment.paper.ArenaEntry`), in
        the registry's order."""
        return tuple(n for n in REGISTRY if REGISTRY[n].arena is not None and self.name in REGISTRY[n].arena.algorithms)

    def build(self, s: Scenario) -> SingleModel | IMM | NoiseAdaptiveIMM:
        """The estimator on scenario ``s``; :class:`NotApplicable` (with the reason) where it cannot apply."""
        _check_scenario(s)
        reason = requirement(self, s)
        if reason:
            raise NotApplicable(f"{self.name} on {s.name}: {reason}")
        f = self.filter(s)
        if self.kind == "single":
            return SingleModel(f, s.single, s.measurement, name=self.name)
        if self.kind == "imm":
            return IMM(f, list(s.modes), s.measurement, s.transition, mixing=self.mixing(), name=self.name)
        levels = s.noise_levels
        # the FLAS of Tseng et al. 2011 (mmlib.core.layers.fuzzy_noise) with the breakpoints, normalisation and
        # window of Tseng's headline, its level range the scenario's two noise levels
        return fuzzy_imm(f, levels.family, levels.lower, levels.upper, s.transition, breakpoints=TSENG.breakpoints,
                         normalise=TSENG.dod_normalise, window=TSENG.dod_window, measurement=s.measurement,
                         name=self.name)


def _check_scenario(s, name: str = "scenario"):
    if not isinstance(s, Scenario):
        raise ValueError(f"{name}: expected a Scenario (e.g. mmlib.arena.study.scenario(name)), got {s!r}")
    return s


def requirement(recipe: Recipe, s: Scenario) -> str:
    """Why ``recipe`` cannot run on ``s`` ("" if it can)."""
    if not isinstance(recipe, Recipe):
        raise ValueError(f"recipe: expected a Recipe (recipes.recipe(name)), got {recipe!r}")
    _check_scenario(s)
    if recipe.kind == "single" and s.single is None:
        return "needs a single motion model: " + s.notes.get("single", "the scenario has none")
    if recipe.kind == "imm" and s.modes is None:
        return "needs an IMM mode set: " + s.notes.get("modes", "the scenario has none")
    if recipe.kind == "noise-adaptive imm":
        if s.noise_levels is None:
            return ("needs a process-noise family whose level the FLAS sets online (two modes differing only in "
                    "their noise, as the GNSS position-velocity-clock model provides); the scenario's modes are "
                    "fixed motion models")
        if s.modes is None or len(s.modes) != 2:
            return "needs a two-mode IMM (the FLAS sets a lower and an upper noise level)"
    return ""


_EKF = (lambda s: ExtendedKalmanFilter(name="EKF"))
_CKF = (lambda s: SigmaPointFilter(Cubature(), name="CKF"))
_CKF5 = (lambda s: SigmaPointFilter(FifthDegreeCubature(), name="5CKF"))
_SSR = (lambda s: SigmaPointFilter(SphericalSimplexRadial(), name="SSRCKF"))

RECIPES = {r.name: r for r in (
    # Zhu, Wang & Yuan 2016
    Recipe("IMM5CKF", "imm", _CKF5, "IMM of fifth-degree cubature KFs (Jia, Xin & Cheng 2013)"),
    Recipe("IMMCKF", "imm", _CKF, "IMM of third-degree cubature KFs"),
    Recipe("IMMUKF", "imm", ukf, "IMM of unscented KFs"),
    Recipe("5CKF", "single", _CKF5, "single-model fifth-degree cubature KF"),
    # Hu, Zhang, Fu & Li 2017
    Recipe("IMMEKF", "imm", _EKF, "IMM of extended KFs"),
    Recipe("IMMCDKF", "imm", cdkf, "IMM of central-difference KFs"),
    Recipe("IMMCDKF-OBS", "imm", cdkf_obs, "IMM of CDKFs fed bootstrapped observations"),
    # Zhou, Zhao, Huang & Zhao 2017
    Recipe("IMM-NAUKF", "imm", naukf, "IMM of NAUKFs (adaptive R, Eqs. 27-28)"),
    Recipe("CPIMM-UKF", "imm", ukf, "cubature-principle mixing, UKF modes", mixing=CubatureMixing),
    Recipe("CPIMM-NAUKF", "imm", naukf, "cubature-principle mixing, NAUKF modes",
           mixing=CubatureMixing),
    Recipe("NAUKF", "single", naukf, "single-model NAUKF (Table 4)"),
    Recipe("AUKF", "single", aukf, "single-model innovation-adaptive UKF (Table 4)"),
    # ... and under the bounded reading of Zhou's factor Z-12 (as printed, the adaptation diverges: see adaptive.py)
    Recipe("IMM-NAUKF[inflate-only]", "imm", lambda s: naukf(s, True),
           "IMM of NAUKFs, adaptive covariance only enlarged (reading Z-12)"),
    Recipe("NAUKF[inflate-only]", "single", lambda s: naukf(s, True),
           "single-model NAUKF, adaptive covariance only enlarged (reading Z-12)"),
    Recipe("AUKF[inflate-only]", "single", lambda s: aukf(s, True),
           "single-model adaptive UKF, adaptive covariance only enlarged (reading Z-12)"),
    # Liu & Wu 2017
    Recipe("SSRCKF", "single", _SSR, "spherical simplex-radial cubature KF"),
    Recipe("STF", "single", lambda s: strong(ExtendedKalmanFilter(), "STF"),
           "strong tracking filter (EKF, Jacobian fading factor)"),
    Recipe("STUKF", "single", lambda s: strong(ukf(s), "STUKF"), "strong tracking UKF"),
    Recipe("STCKF", "single", lambda s: strong(_CKF(s), "STCKF"), "strong tracking CKF"),
    Recipe("STSSRCKF", "single", lambda s: strong(_SSR(s), "STSSRCKF"),
           "strong tracking simplex-radial CKF"),
    # single-model baselines run by several papers
    Recipe("EKF", "single", _EKF, "extended KF"),
    Recipe("CKF", "single", _CKF, "third-degree cubature KF"),
    Recipe("UKF", "single", ukf, "unscented KF"),
    # Tseng, Chang & Jwo 2011
    Recipe("FUZZY-IMMUKF", "noise-adaptive imm", ukf,
           "two-level IMM-UKF whose noise levels a fuzzy system sets online"),
)}

#: other papers' spellings of the same algorithms
ALIASES = {"IMM-UKF": "IMMUKF", "IMM-EKF": "IMMEKF", "IMM-CKF": "IMMCKF"}

ALGORITHMS = tuple(RECIPES)


def recipe(name: str) -> Recipe:
    """The recipe of algorithm ``name`` (or an alias); ValueError listing the known names otherwise."""
    key = ALIASES.get(name, name) if isinstance(name, str) else None
    if key not in RECIPES:
        raise ValueError(f"algorithm: unknown algorithm {name!r}; known: {', '.join(ALGORITHMS)} "
                         f"(aliases: {', '.join(f'{a} = {b}' for a, b in ALIASES.items())})")
    return RECIPES[key]


def applicability(name: str, s: Scenario) -> str:
    """Why algorithm ``name`` cannot run on ``s``; "" if it can."""
    return requirement(recipe(name), s)


def build(name: str, s: Scenario) -> SingleModel | IMM | NoiseAdaptiveIMM:
    """Algorithm ``name`` on scenario ``s`` (:meth:`Recipe.build`)."""
    return recipe(name).build(s)


def initial_state(estimator: Estimator, s: Scenario, start: np.ndarray, runs: Sequence[int] | np.ndarray,
                  mc: MonteCarlo) -> Any:
    """``estimator``'s state at step 0 on ``s``: means ``start`` (B, n), covariance ``s.P0``, the scenario's initial
    mode probabilities for IMMs, and for observation bootstrapping the pre-drawn standard normals of the runs' own
    FILTER stream (:meth:`mmlib.experiment.montecarlo.MonteCarlo.bootstrap_noise`, at the scenario's largest measurement
    dimension)."""
    _check_scenario(s, "s")
    if not isinstance(mc, MonteCarlo):
        raise ValueError(f"mc: expected a MonteCarlo, got {type(mc).__name__}")
    runs = mc.check_runs(runs)
    check_has(estimator, "estimator", "an estimator (protocols.Estimator)", ("init", "step"))
    imm = getattr(estimator, "imm", estimator)
    f = getattr(imm, "filter", None)
    extra = {}
    if isinstance(f, ObservationBootstrap):
        extra["noise"] = mc.bootstrap_noise(runs, s.n_steps, f.n_boot, s.measurement_dim)
    if isinstance(imm, IMM):
        return estimator.init(start, s.P0, s.mode_probabilities, **extra)
    return estimator.init(start, s.P0, **extra)
