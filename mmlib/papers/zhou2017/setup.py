"""The set-up of Zhou et al. 2017, Section 4.1: the radar scenario, its two cases and their Monte Carlo batches.

A reading (:data:`~mmlib.papers.zhou2017.text.SPACE`) gives a :class:`Cases`: Case 1 (no fault, Table 2) and Case 2
(the sensor faults of Eq. 2, Table 3), two :class:`Setup` s differing only in ``faults``.  :func:`build` assembles
the truth's maneuver schedule, the range-bearing radar and the six IMM estimators of the paper (IMM-UKF, IMM-NAUKF,
CPIMM-UKF, CPIMM-NAUKF, IMM-EKF, IMM-CKF) from the core's pieces; :func:`make_batch_fn` simulates the runs of a
:class:`~mmlib.experiment.montecarlo.MonteCarlo` (truth, radar measurements, the Case 2 fault of
:func:`~mmlib.papers.zhou2017.faults.radar_fault`) with every filter's initial state.  :func:`scenario` and
:func:`batch` are Case 2, the case the arena runs, under the per-step fault reading
(:data:`ARENA_FAULT_KIND`: under the headline's accumulating drift the fault is unobservable and every filter errs by
the measurement-only error).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable, Iterable, Mapping, NamedTuple

import numpy as np

from mmlib.core import models
from mmlib.core.estimation import IMM, MomentMixing
from mmlib.core.filters import ExtendedKalmanFilter, SigmaPointFilter
from mmlib.core.layers.adaptive import InnovationAdaptive
from mmlib.core.mixing import CubatureMixing
from mmlib.core.protocols import MeasurementModel
from mmlib.core.rules import Cubature, Unscented
from mmlib.experiment import evaluation
from mmlib.experiment.montecarlo import MonteCarlo
from mmlib.experiment.scenario import Scenario
from mmlib.experiment.simulate import ManeuverSchedule
from mmlib.papers.zhou2017 import text
from mmlib.papers.zhou2017.faults import radar_fault

__all__ = [
    "setup", "Setup", "build", "scenario", "batch", "simulator", "make_batch_fn", "Cases", "FAULT_KINDS", "NOISE_GAINS",
    "ARENA_FAULT_KIND"
]

FAULT_KINDS = ("constant-drift", "per-step", "constant")
NOISE_GAINS = ("dwna", "identity")


@dataclass(frozen=True)
class Setup:
    """Section 4.1 parameters; defaults are the headline reading (see ``text.DEVIATIONS`` and ``text.FACTORS``).

    Units: T in s; positions m, velocities m/s; ``q_cv``/``q_ct`` acceleration-noise variances in
    m^2/s^4 (Q = q G G^T, G = [T^2/2, T] per axis, Z-2), used by the truth (when
    ``truth_process_noise``) and, times ``filter_q_scale``, by every filter's models (Z-13);
    ``R_diag`` = (range m^2, bearing rad^2) (Z-3); fault bounds in m and rad/s (Z-6)."""

    T: float = 1.0
    n_steps: int = 100
    x0: tuple = (0.0, 10.0, 400.0, 40.0)             # [x, vx, y, vy] (Z-1)
    turns: tuple = ((20.0, 40.0, -0.1), (60.0, 80.0, 0.1))
    q_cv: float = 5.0                                # m^2/s^4 (Z-2)
    q_ct: float = 20.0
    noise_gain: str = "dwna"                         # Gamma: "dwna" G = [T^2/2, T] per axis, or "identity" (Z-2)
    filter_q_scale: float = 1.0                      # filters' Q = scale * printed Q (Z-13)
    R_diag: tuple = (15.0, 15e-6)                    # m^2, rad^2 (15 mrad^2) (Z-3)
    transition: tuple = ((0.99, 0.005, 0.005), (0.005, 0.99, 0.005), (0.005, 0.005, 0.99))
    mode_probabilities0: tuple = (0.99, 0.005, 0.005)
    P0_sd: tuple = (10.0, 5.0, 10.0, 5.0)            # (Z-5)
    truth_process_noise: bool = True                 # (Z-4)
    faults: bool = False                             # Case 2
    fault_range_max: float = 5.0                     # m (Z-6)
    fault_bearing_rate_max: float = 1e-2             # rad/s (Z-6)
    fault_kind: str = "constant-drift"               # or "per-step", "constant" (Z-6)
    ukf: tuple = (1.0, 0.0, -1.0)                    # (Z-7)
    window: int = 10                                 # NAUKF innovation window (Z-8)
    psi: float = 1.0                                 # Eq. 32 (Z-8)
    inflate_only: bool = False                       # bounded NAUKF reading (Z-12)

    def __post_init__(self):
        if self.noise_gain not in NOISE_GAINS:
            raise ValueError(f"noise_gain: expected one of {NOISE_GAINS}, got {self.noise_gain!r}")
        if self.fault_kind not in FAULT_KINDS:
            raise ValueError(f"fault_kind: expected one of {FAULT_KINDS}, got {self.fault_kind!r}")
        if self.psi < 1:
            raise ValueError(f"psi: must be >= 1 (Eq. 32), got {self.psi}")
        if (isinstance(self.filter_q_scale, bool) or not isinstance(self.filter_q_scale, (int, float))
                or not math.isfinite(self.filter_q_scale) or self.filter_q_scale <= 0):
            raise ValueError(f"filter_q_scale: expected a finite number > 0, got {self.filter_q_scale!r}")
        if len(self.R_diag) != 2 or not all(float(r) > 0 for r in self.R_diag):
            raise ValueError(f"R_diag: expected two positive variances (range m^2, bearing rad^2), got {self.R_diag!r}")
        if isinstance(self.window, bool) or not isinstance(self.window, int) or self.window < 2:
            raise ValueError(f"window: expected an integer >= 2, got {self.window!r}")


class Cases(NamedTuple):
    """The set-up of a reading (:func:`setup`): ``case1`` without faults (Table 2) and ``case2`` with the sensor
    faults of Eq. 2 (Table 3), equal in every other field."""

    case1: Setup
    case2: Setup


def setup(reading: Mapping[str, str]) -> Cases:
    """The two cases of a reading: the headline :class:`Setup` with the reading's changes (ValueError naming an
    unknown factor or option)."""
    base = replace(Setup(), **text.SPACE.changes(reading))
    return Cases(replace(base, faults=False), replace(base, faults=True))


def build(setup: Setup) -> tuple:
    """``(schedule, radar, estimators)``: the truth's maneuver schedule (printed q), the range-bearing radar (R =
    diag(R_diag), m^2 and rad^2) and the six IMM estimators by name, whose models carry q * filter_q_scale (Z-13)."""
    T = setup.T

    G = models.acceleration_noise_gain(T) if setup.noise_gain == "dwna" else np.eye(4)

    def modes_for(scale):
        cv = models.constant_velocity(T, setup.q_cv * scale, G)
        return [cv] + [models.coordinated_turn(T, w, setup.q_ct * scale, G) for _, _, w in setup.turns]

    truth_modes, modes = modes_for(1.0), modes_for(setup.filter_q_scale)
    radar = models.range_bearing(np.diag(setup.R_diag))
    schedule = ManeuverSchedule(truth_modes, [(a, b, i + 1) for i, (a, b, _) in enumerate(setup.turns)], 0, T,
                                setup.n_steps, truncate=True)     # a shortened set-up runs a prefix
    Tm = np.array(setup.transition)
    ukf = SigmaPointFilter(Unscented(*setup.ukf), name="UKF")
    naukf = InnovationAdaptive(ukf, window=setup.window, psi=setup.psi, inflate_only=setup.inflate_only,
                               name="NAUKF")                          # Eqs. 27-39 (Z-8, Z-12)
    estimators = {
        "IMM-UKF": IMM(ukf, modes, radar, Tm, mixing=MomentMixing(), name="IMM-UKF"),
        "IMM-NAUKF": IMM(naukf, modes, radar, Tm, mixing=MomentMixing(), name="IMM-NAUKF"),
        "CPIMM-UKF": IMM(ukf, modes, radar, Tm, mixing=CubatureMixing(), name="CPIMM-UKF"),
        "CPIMM-NAUKF": IMM(naukf, modes, radar, Tm, mixing=CubatureMixing(), name="CPIMM-NAUKF"),
        "IMM-EKF": IMM(ExtendedKalmanFilter(name="EKF"), modes, radar, Tm, mixing=MomentMixing(), name="IMM-EKF"),
        "IMM-CKF": IMM(SigmaPointFilter(Cubature(), name="CKF"), modes, radar, Tm, mixing=MomentMixing(),
                       name="IMM-CKF"),
    }
    return schedule, radar, estimators


def simulator(setup: Setup, schedule: ManeuverSchedule, radar: MeasurementModel) -> Callable:
    """``mc -> (runs -> (truth, measurements, start means))``: truth from x0, radar measurements with the Case 2
    fault when ``setup.faults`` (:func:`radar_fault`, the run's FAULT stream); the filters start at the true x0."""
    def for_mc(mc: MonteCarlo):
        fault = (lambda runs: radar_fault(setup, mc, runs, schedule.times)) if setup.faults else None
        return evaluation.simulator(mc, schedule, radar, setup.x0, process_noise=setup.truth_process_noise,
                                    fault=fault)

    return for_mc


def make_batch_fn(setup: Setup, mc: MonteCarlo, names: Iterable[str] | None = None) -> tuple:
    """``(make_batch, estimators, schedule)`` for the runs of ``mc`` under ``setup``: ``make_batch(runs) ->
    (truth (B, K+1, 4) in m and m/s, radar measurements (B, K, 2) in m and rad, {name: initial state})``
    (:func:`simulator`), every IMM started at the true x0 with P0 = diag(P0_sd)^2 and ``mode_probabilities0``;
    ``estimators`` those of :func:`build` named in ``names`` (all if None; ValueError naming an unknown one);
    ``schedule`` the truth's :class:`ManeuverSchedule`."""
    schedule, radar, estimators = build(setup)
    estimators = evaluation.select(estimators, names)
    P0 = np.diag(np.square(setup.P0_sd))
    make_batch = evaluation.with_initial_states(simulator(setup, schedule, radar)(mc), estimators,
                                                lambda est, m0, runs: est.init(m0, P0, setup.mode_probabilities0))
    return make_batch, estimators, schedule


#: the fault reading (Z-6) of the arena's scenario (:func:`scenario`, :func:`batch`): "per-step".  Under the headline
#: "drift" reading the bearing bias accumulates to ~1 rad, no filter can tell it from the target's motion with one
#: range-bearing radar, and every filter errs as much as the raw measurements do (hundreds of m against Table 3's
#: 4.9-11.9 m; :func:`mmlib.papers.zhou2017.study.degenerate_reason` flags such universes): the arena's comparisons
#: on it would measure only how the filters fail.  Of the two other readings, "per-step" is chosen by the text, not by
#: its numbers: Sec. 4.1 defines the fault as delta h_out,k = [delta r_k, delta theta_k]^T with values "within
#: [-5 m, 5 m]" and "within [0, 1e-2]", the step index k on each, i.e. one draw per step within those bounds
#: (T = 1 s turns the rate's bound into 1e-2 rad); "constant" rests on the introduction's list of fault kinds and was
#: declared only after the drift reading's results were seen (``text.SPACE``'s ``motivated_by``).  Both give errors of
#: Table 3's order (IMM-UKF 13.8 and 14.8 m RMSE on the headline's 100 runs).
ARENA_FAULT_KIND = "per-step"


def _arena_case(setup, fault_kind: str | None) -> Setup:
    """Case 2 of the Cases ``setup`` with the fault reading ``fault_kind`` (None: the set-up's own)."""
    case2 = _cases(setup).case2
    if fault_kind is None:
        return case2
    if fault_kind not in FAULT_KINDS:
        raise ValueError(f"fault_kind: expected None or one of {FAULT_KINDS}, got {fault_kind!r}")
    return replace(case2, fault_kind=fault_kind)


def batch(setup: Cases, mc: MonteCarlo, fault_kind: str | None = None) -> tuple:
    """``(make_batch, estimators)`` of Case 2 of ``setup`` on the runs of ``mc`` (:func:`make_batch_fn`, every
    estimator of :func:`build`), with the set-up's own fault reading (or ``fault_kind``): the batch of
    :func:`scenario`."""
    make_batch, estimators, _ = make_batch_fn(_arena_case(setup, fault_kind), mc)
    return make_batch, estimators


def _cases(setup) -> Cases:
    if not isinstance(setup, Cases):
        raise ValueError(f"setup: expected the Cases of a reading (zhou2017 setup(reading)), got {setup!r}")
    return setup


#: how each fault reading (Z-6) reads in a scenario's title and properties
_FAULT_TEXT = {"constant-drift": "range offset and accumulating bearing drift",
               "per-step": "range and bearing deviations drawn each step",
               "constant": "constant range and bearing offsets"}


def scenario(setup: Cases, fault_kind: str | None = None) -> Scenario:
    """Case 2 of Section 4.1 (sensor faults) of ``setup`` as an arena scenario, with the set-up's own fault reading
    of Z-6 (or ``fault_kind``; the arena's set-up takes :data:`ARENA_FAULT_KIND`, through the paper's
    ``ArenaEntry.reading``, since the headline's drift is degenerate: see there): CV and two coordinated-turn
    modes, a range-bearing radar with Eq. 2's range and bearing deviations.  Single-model filters use the CV mode:
    the paper runs single-model UKF, AUKF and NAUKF only in its field test (Table 4), whose model it does not give."""
    setup = _arena_case(setup, fault_kind)
    schedule, radar, estimators = build(setup)
    modes = tuple(estimators["IMM-UKF"].dynamics)
    case = f"Case 2 ({_FAULT_TEXT[setup.fault_kind]}, Z-6 '{setup.fault_kind}')"
    return Scenario(name=text.NAME, title=f"Zhou et al. 2017 {case}: CV and ±0.1 rad/s turns, range-bearing radar",
                    source=text.CITATION, root_seed=text.ROOT_SEED, T=setup.T, n_steps=setup.n_steps,
                    simulator=simulator(setup, schedule, radar), P0=np.diag(np.square(setup.P0_sd)),
                    position=(0, 2), velocity=(1, 3), single=modes[0], modes=modes,
                    transition=np.array(setup.transition), mode_probabilities=setup.mode_probabilities0,
                    measurement=radar, ukf=tuple(setup.ukf),
                    properties={"measurement": f"range-bearing with {_FAULT_TEXT[setup.fault_kind]} (Eq. 2, Z-6 "
                                                   f"'{setup.fault_kind}')",
                                "manoeuvre": "turns at ±0.1 rad/s"},
                    notes={"single": "single-model filters use the CV mode of Section 4.1 (the paper's single-model "
                                     "filters appear only in its field test, whose model is not given)"})


