"""The simulations of Liu & Wu 2017, Section 4.2: the :class:`Setup` of one simulation, the :class:`Examples` of a
reading (Example 1 and the two cases of Example 2), the models and filters of a set-up (:func:`build`), its Monte
Carlo batches (:func:`make_batch_fn`) and its arena scenario (:func:`scenario`).

Constant-acceleration target (Eqs. 37-39), state [x, vx, ax, y, vy, ay] in m, m/s, m/s^2, seen by a range-bearing
radar at the origin (Eq. 40; range in m, bearing in rad), sampling interval T in s.  The filters: SSRCKF (the
spherical simplex-radial CKF) and STF, STUKF, STCKF, STSSRCKF, the strong-tracking layer (Eqs. 20-36,
:class:`mmlib.core.layers.strong_tracking.StrongTracking`) over an EKF, a UKF, a CKF and the SSRCKF.
"""
from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Callable, Iterable, Iterator, Mapping

import numpy as np

from mmlib.core import models
from mmlib.core.estimation import SingleModel
from mmlib.core.filters import ExtendedKalmanFilter, SigmaPointFilter
from mmlib.core.layers.strong_tracking import StrongTracking
from mmlib.core.protocols import MeasurementModel, MomentFilter
from mmlib.core.rules import Cubature, SphericalSimplexRadial, Unscented
from mmlib.experiment import evaluation
from mmlib.experiment.montecarlo import MonteCarlo, Stream
from mmlib.experiment.scenario import Scenario
from mmlib.experiment.simulate import ManeuverSchedule
from mmlib.papers.liu2017 import text

__all__ = [
    "Setup", "build", "scenario", "batch", "simulator", "make_batch_fn", "Examples", "for_reading", "TIMELINES",
    "INITIAL_ESTIMATES", "BASE_SETUPS"
]

TIMELINES = ("set-up", "discussion")
INITIAL_ESTIMATES = ("true", "sampled", "sampled-if-unprinted")


@dataclass(frozen=True)
class Setup:
    """One simulation of Section 4.2; defaults are Example 1 under the headline reading.

    Units: s, m, m/s, m/s^2, rad.  The state is [x, vx, ax, y, vy, ay] (Eq. 37).  The
    maneuver sets the acceleration components to ``maneuver_acceleration`` at the time
    :attr:`onset` and keeps them to the end (t = ``n_steps * T``)."""

    T: float = 1.0
    n_steps: int = 200                                        # L-1: 'up to the end of this simulation at t = 200 s'
    maneuver_start: float = 150.0                             # s, onset as the set-up paragraph states it (L-1)
    discussion_onset: float | None = 100.0                    # s, onset as the discussion of the results states
                                                              # it (Example 1: 100 s); None when there is none
    timeline: str = "set-up"                                  # L-1: which statement of the onset: "set-up"/"discussion"
    onset_step: int = 0                                       # L-8: 0 = acceleration in the state at the stated time
                                                              # t0 (acts over [t0, t0 + T]); 1 = first at t0 + T
    maneuver_acceleration: tuple = (15.0, 25.0)               # m/s^2
    x0: tuple = (100.0, 15.0, 0.0, 400.0, 20.0, 0.0)          # [x, vx, ax, y, vy, ay]
    initial_estimate: str = "true"                            # L-6: "true" (x0), "sampled" (x0 + N(0, P0)) or
                                                              # "sampled-if-unprinted" (sampled where the paper
                                                              # prints no x_0|0)
    printed_initial_estimate: bool = True                     # the paper prints x_0|0 for this example (Example 1)
    P0_sd: tuple = (50.0, 20.0, 1.0, 50.0, 10.0, 1.0)
    sigma_r: float = 30.0                                     # m
    sigma_theta: float = 0.010                                # rad (10 mrad)
    q_sd: float = 0.1                                         # m/s^2 per step, filter's acceleration increment (L-2)
    truth_process_noise: bool = False                         # L-3: truth carries the filter's process noise
    beta: float = 4.5                                         # softening factor
    rho: float = 0.95                                         # forgetting factor
    ukf: tuple = (1.0, 0.0, -3.0)                             # alpha, beta, kappa = 3 - n (L-4)

    def __post_init__(self):
        if self.timeline not in TIMELINES:
            raise ValueError(f"timeline: expected one of {TIMELINES}, got {self.timeline!r}")
        if isinstance(self.onset_step, bool) or self.onset_step not in (0, 1):
            raise ValueError(f"onset_step: expected 0 or 1 (steps after the stated onset), got {self.onset_step!r}")
        if self.discussion_onset is not None and not 0 < self.discussion_onset < self.n_steps * self.T:
            raise ValueError(f"discussion_onset: must be None or lie inside (0, {self.n_steps * self.T}), "
                             f"got {self.discussion_onset}")
        if not 0 < self.maneuver_start < self.n_steps * self.T:
            raise ValueError(f"maneuver_start: must lie inside the simulation (0, {self.n_steps * self.T}), "
                             f"got {self.maneuver_start}")
        if not 0 < self.onset < self.n_steps * self.T:
            raise ValueError(f"onset_step: the onset {self.onset} s must lie inside the simulation "
                             f"(0, {self.n_steps * self.T})")
        if not self.q_sd > 0:
            raise ValueError(f"q_sd: must be > 0, got {self.q_sd}")
        if self.initial_estimate not in INITIAL_ESTIMATES:
            raise ValueError(f"initial_estimate: expected one of {INITIAL_ESTIMATES}, got {self.initial_estimate!r}")
        if not isinstance(self.printed_initial_estimate, bool):
            raise ValueError(f"printed_initial_estimate: expected a bool, got {self.printed_initial_estimate!r}")
        if not isinstance(self.truth_process_noise, bool):
            raise ValueError(f"truth_process_noise: expected a bool, got {self.truth_process_noise!r}")
        if len(tuple(self.ukf)) != 3 or not float(self.ukf[0]) > 0:
            raise ValueError(f"ukf: expected (alpha > 0, beta, kappa), got {self.ukf!r}")

    @property
    def onset(self) -> float:
        """Time (s) from which the acceleration state holds the maneuver's value: the stated onset
        of the chosen time line (L-1) plus ``onset_step`` sampling intervals (L-8)."""
        stated = (self.discussion_onset if self.timeline == "discussion" and self.discussion_onset is not None
                  else self.maneuver_start)
        return stated + self.onset_step * self.T

    @property
    def onset_index(self) -> int:
        """Index into the error arrays (step k = index + 1, t = k T) of the first step whose
        truth has moved away from the constant-velocity path (t > onset)."""
        return int(round(self.onset / self.T))

    @property
    def samples_initial_estimate(self) -> bool:
        """Whether the filters start from a draw x0 + N(0, P0) (Stream.INITIAL) rather than the true x0 (L-6):
        ``initial_estimate`` "sampled", or "sampled-if-unprinted" for an example that prints no x_0|0."""
        return self.initial_estimate == "sampled" or (self.initial_estimate == "sampled-if-unprinted"
                                                      and not self.printed_initial_estimate)



@dataclass(frozen=True)
class Examples:
    """The three simulations of Section 4.2 under one reading, the paper's set-up (``PAPER.setup_type``):
    ``example1`` (Figs. 1-3, Table 1, the headline case) and Example 2's ``case1`` (medium maneuver) and ``case2``
    (weak maneuver) (Table 3).  ``examples["Case 1"]`` looks a simulation up by its name in :data:`text.CASES`."""

    example1: Setup
    case1: Setup
    case2: Setup

    def __post_init__(self):
        for f in fields(self):
            if not isinstance(getattr(self, f.name), Setup):
                raise ValueError(f"{f.name}: expected a Setup, got {getattr(self, f.name)!r}")

    def __getitem__(self, case: str) -> Setup:
        if case not in text.CASES:
            raise KeyError(f"{case!r}: expected one of {text.CASES}")
        return getattr(self, fields(self)[text.CASES.index(case)].name)

    def items(self) -> Iterator[tuple[str, Setup]]:
        """``(case, Setup)`` pairs in the order of :data:`text.CASES`."""
        return ((case, self[case]) for case in text.CASES)


#: Section 4.2's simulations before a reading's changes (Example 2 is 'the same' as Example 1 otherwise)
BASE_SETUPS = Examples(
    example1=Setup(),
    case1=Setup(x0=(5000.0, 150.0, 0.0, 5000.0, 80.0, 0.0), maneuver_acceleration=(5.0, 5.0),
                discussion_onset=None, printed_initial_estimate=False),
    case2=Setup(x0=(5000.0, 150.0, 0.0, 5000.0, 80.0, 0.0), maneuver_acceleration=(0.5, 0.5),
                discussion_onset=None, printed_initial_estimate=False))


def for_reading(reading: Mapping[str, str]) -> Examples:
    """The paper's ``setup(reading)``: the three simulations of Section 4.2 under ``reading`` (factor id -> option
    of :data:`text.SPACE`).  ValueError names an unknown factor or option, or a factor left out."""
    changes = text.SPACE.changes(reading)
    return Examples(*(replace(s, **changes) for _, s in BASE_SETUPS.items()))


def _strong_tracking(base: MomentFilter, setup: Setup, name: str) -> StrongTracking:
    """The strong-tracking layer (Eqs. 20-36) over ``base`` with the set-up's softening factor beta and forgetting
    factor rho; over an EKF the Jacobian form of the fading factor (the STF of Zhou & Frank)."""
    form = {"form": "jacobian"} if isinstance(base, ExtendedKalmanFilter) else {}
    return StrongTracking(base, beta=setup.beta, rho=setup.rho, name=name, **form)


def build(setup: Setup) -> tuple:
    """Dynamics, radar, schedule and the five filters of Table 1 (plus the plain CKF and UKF)."""
    ca = models.constant_acceleration(setup.T, setup.q_sd ** 2)
    radar = models.range_bearing(np.diag([setup.sigma_r ** 2, setup.sigma_theta ** 2]), state_dim=6)
    schedule = ManeuverSchedule([ca], [], 0, setup.T, setup.n_steps,
                                jumps=[(setup.onset, (2, 5), setup.maneuver_acceleration)])
    ssr = SigmaPointFilter(SphericalSimplexRadial(), name="SSRCKF")
    ckf = SigmaPointFilter(Cubature(), name="CKF")
    ukf = SigmaPointFilter(Unscented(*setup.ukf), name="UKF")
    filters = {
        "SSRCKF": ssr,
        "STF": _strong_tracking(ExtendedKalmanFilter(), setup, "STF"),
        "STUKF": _strong_tracking(ukf, setup, "STUKF"),
        "STCKF": _strong_tracking(ckf, setup, "STCKF"),
        "STSSRCKF": _strong_tracking(ssr, setup, "STSSRCKF"),
        "CKF": ckf,      # not in the paper's tables: for the claim "SSR is more accurate than CKF"
        "UKF": ukf,
    }
    estimators = {name: SingleModel(f, ca, radar, name=name) for name, f in filters.items()}
    return schedule, radar, estimators


def simulator(setup: Setup, schedule: ManeuverSchedule, radar: MeasurementModel) -> Callable:
    """``mc -> (runs -> (truth, measurements, start means))``: truth from x0 (with the filter's Q as process noise
    under L-3 "matched"), radar measurements, and the filters' initial means x0 or x0 + N(0, P0) drawn from the run's
    INITIAL stream (L-6), with P0 = diag(P0_sd^2)."""
    x0 = np.array(setup.x0)
    P0 = np.diag(np.square(setup.P0_sd))

    def for_mc(mc: MonteCarlo):
        def start(runs):
            if setup.samples_initial_estimate:
                return mc.gaussian(runs, Stream.INITIAL, x0, P0)
            return np.tile(x0, (len(runs), 1))

        return evaluation.simulator(mc, schedule, radar, x0, process_noise=setup.truth_process_noise, start=start)

    return for_mc


def make_batch_fn(setup: Setup, mc: MonteCarlo, names: Iterable[str] | None = None) -> tuple:
    """``(make_batch, estimators, schedule)`` for one set-up (:func:`simulator`, every filter started with P0)."""
    schedule, radar, estimators = build(setup)
    estimators = evaluation.select(estimators, names)
    P0 = np.diag(np.square(setup.P0_sd))
    make_batch = evaluation.with_initial_states(simulator(setup, schedule, radar)(mc), estimators,
                                                lambda est, m0, runs: est.init(m0, P0))
    return make_batch, estimators, schedule


def scenario(setup: Examples) -> Scenario:
    """Example 1 of ``setup`` (the headline case) as an arena scenario: a constant-acceleration model with an
    acceleration step at the onset, a range-bearing radar (30 m, 10 mrad).  The paper's filters are all single-model:
    it defines no mode set for an IMM."""
    if not isinstance(setup, Examples):
        raise ValueError(f"setup: expected the Examples of a reading (PAPER.setup), got {setup!r}")
    setup = setup.example1
    schedule, radar, estimators = build(setup)
    return Scenario(name=text.NAME, title="Liu & Wu 2017 Example 1: CA model, acceleration step, range-bearing radar",
                    source=text.CITATION, root_seed=text.ROOT_SEED, T=setup.T, n_steps=setup.n_steps,
                    simulator=simulator(setup, schedule, radar), P0=np.diag(np.square(setup.P0_sd)),
                    position=(0, 3), velocity=(1, 4), single=estimators["SSRCKF"].dynamics, measurement=radar,
                    ukf=tuple(setup.ukf),
                    properties={"measurement": "range-bearing (30 m, 10 mrad)",
                                "manoeuvre": f"acceleration step to {setup.maneuver_acceleration} m/s² at "
                                             f"t = {setup.onset:g} s"},
                    notes={"modes": "the paper's filters are all single-model (one constant-acceleration model): it "
                                    "defines no mode set for an IMM"})


def batch(setup: Examples, mc: MonteCarlo) -> tuple:
    """``(make_batch, estimators)`` of Example 1 of ``setup`` (the headline case, every filter of :func:`build`) on
    the runs of ``mc`` (:func:`make_batch_fn`)."""
    if not isinstance(setup, Examples):
        raise ValueError(f"setup: expected the Examples of a reading (PAPER.setup), got {setup!r}")
    make_batch, estimators, _ = make_batch_fn(setup.example1, mc)
    return make_batch, estimators
