"""The simulated world of Tseng et al. 2011 as reconstructed: the vehicle, the sky, the Monte Carlo batch and the
arena scenario.

The vehicle drives the seven segments of the surviving table on a horizontal plane (T-1); a nominal 24-satellite
constellation is seen from the site above the elevation mask (T-3), so the pseudorange model changes with the
satellites in view at every epoch; the receiver clock follows the two-state model of T-5.  :func:`experiment`
bundles a set-up's geometry (computed once per process and geometry) with its estimators; :func:`make_batch_fn` and
:func:`batch` give the Monte Carlo batch on the paper's per-run streams; :func:`scenario` the arena scenario.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any, Callable, Iterable, NamedTuple

import numpy as np

from mmlib.core import gnss, models
from mmlib.core._validate import check_bool
from mmlib.core.estimation import IMM
from mmlib.core.layers.adaptive_imm import NoiseAdaptiveIMM
from mmlib.experiment import evaluation
from mmlib.experiment.montecarlo import MonteCarlo, Stream
from mmlib.experiment.scenario import Scenario
from mmlib.experiment.simulate import BatchMemo, ManeuverSchedule, propagate
from mmlib.papers.tseng2011.setup import Setup, build, noise_model, transition_matrix
from mmlib.papers.tseng2011.text import ALGORITHMS, CITATION, NAME, ROOT_SEED

__all__ = [
    "scenario", "batch", "simulator", "make_batch_fn", "motion_schedule", "trajectory", "maneuver_intervals", "Sky",
    "sky", "Experiment", "experiment", "NoiseLevels", "GEOMETRY_FIELDS", "SIMULATION_FIELDS", "SIMULATION_MEMO",
    "SIMULATION_MEMO_BYTES"
]


def motion_schedule(setup: Setup) -> ManeuverSchedule:
    """The segment table as a schedule of planar models [e, ve, n, vn]: model 0 = straight line,
    model i = the i-th turn of ``setup.turns`` (noise-free)."""
    T = setup.T
    cv = models.constant_velocity(T, 0.0)
    turns = [models.coordinated_turn(T, math.radians(deg) / (t1 - t0), 0.0) for t0, t1, deg in setup.turns]
    return ManeuverSchedule([cv] + turns, [(t0, t1, i + 1) for i, (t0, t1, _) in enumerate(setup.turns)], 0, T,
                            setup.n_steps, truncate=True)     # a shortened set-up runs a prefix


def trajectory(setup: Setup) -> np.ndarray:
    """Noise-free planar truth [e, ve, n, vn] at t = 0..K T, shape (K+1, 4)."""
    h = math.radians(setup.heading_deg)
    x0 = np.array([[0.0, setup.speed * math.cos(h), 0.0, setup.speed * math.sin(h)]])
    return propagate(motion_schedule(setup), x0)[0]


def maneuver_intervals(setup: Setup) -> list:
    """The turning segments' ``(start, end)`` times (s) of ``setup.turns``, for shading plots."""
    return [(t0, t1) for t0, t1, _ in setup.turns]


@dataclass(frozen=True, eq=False)
class Sky:
    """Satellite geometry along the (deterministic) trajectory: ENU positions (K, S, 3) (m) of the S satellites at
    the measurement epochs, the in-view mask (K, S), their elevations (K, S) (rad), the per-step measurement models
    (K pseudorange models of the satellites in view) and the satellites' names (S,)."""

    satellites_enu: np.ndarray
    visible: np.ndarray
    elevation: np.ndarray
    measurement_models: tuple
    names: tuple


def sky(setup: Setup, truth_enu: np.ndarray) -> Sky:
    """The :class:`Sky` of the set-up's constellation (nominal GPS-24, ``phasing_deg``) seen from ``site`` by a
    receiver at ``truth_enu`` (K, 3) (m, the truth at t_1..t_K), with the elevation mask ``mask_deg`` and
    pseudorange noise ``sigma_pr`` (m).  ValueError naming mask_deg when fewer than 4 satellites are in view at
    some epoch."""
    frame = gnss.LocalFrame(*setup.site)
    const = gnss.nominal_gps24(setup.phasing_deg)
    sats = frame.ecef_to_enu(const.positions_ecef(setup.times))               # (K, S, 3)
    el = gnss.elevation(sats, truth_enu)                                       # (K, S)
    vis = el >= math.radians(setup.mask_deg)
    if vis.sum(axis=1).min() < 4:
        raise ValueError("mask_deg: fewer than 4 satellites in view at some epoch; the position is unobservable")
    var = setup.sigma_pr ** 2
    meas = tuple(gnss.Pseudoranges(sats[k, vis[k]], var * np.eye(int(vis[k].sum())),
                                   tuple(np.array(const.names)[vis[k]])) for k in range(setup.n_steps))
    return Sky(sats, vis, el, meas, const.names)


@dataclass(frozen=True, eq=False)
class Experiment:
    """One set-up ready to run: its noise-free planar truth, its :class:`Sky` and the estimators by name."""

    setup: Setup
    truth_plane: np.ndarray          # (K+1, 4) [e, ve, n, vn]
    sky: Sky
    estimators: dict

    @property
    def measurement_models(self) -> tuple:
        """The K per-step pseudorange models (those of the satellites in view at each epoch)."""
        return self.sky.measurement_models


#: the Setup fields the trajectory and the satellite geometry (with the pseudorange covariance) depend on
GEOMETRY_FIELDS = ("T", "n_steps", "speed", "heading_deg", "turns", "site", "phasing_deg", "mask_deg", "sigma_pr")


@functools.lru_cache(maxsize=8)
def _geometry(**fields):
    """The trajectory and the sky of a set-up's geometry fields, computed once per process: the estimators of one
    reading (evaluated one by one, :func:`mmlib.papers.tseng2011.study.evaluate_reading`) and readings that differ
    only in filter settings share them.  Deterministic, so sharing changes no number; the arrays are read-only."""
    setup = Setup(**fields)
    plane = trajectory(setup)
    enu = np.stack([plane[1:, 0], plane[1:, 2], np.zeros(setup.n_steps)], axis=-1)
    sk = sky(setup, enu)
    for arr in (plane, sk.satellites_enu, sk.visible, sk.elevation):
        arr.setflags(write=False)
    return plane, sk


def experiment(setup: Setup, names: Iterable[str] = ALGORITHMS, **build_kw: Any) -> Experiment:
    """The :class:`Experiment` of ``setup`` with the estimators ``names`` of :func:`build` (``build_kw``, e.g.
    ``frozen_fuzzy=True``, passed on); the geometry is computed once per process per geometry
    (:data:`GEOMETRY_FIELDS`)."""
    plane, sk = _geometry(**{f: getattr(setup, f) for f in GEOMETRY_FIELDS})
    est = build(setup, **build_kw)
    names = list(names)
    unknown = [n for n in names if n not in est]
    if unknown:
        raise ValueError(f"names: unknown estimator(s) {unknown}; expected some of {sorted(est)}")
    return Experiment(setup, plane, sk, {n: est[n] for n in names})


#: the Setup fields the simulated runs depend on (:func:`simulator` reads no other): the geometry's, the receiver
#: clock's and the initial-estimate spread.  Readings that differ only in other fields -- the filters' settings --
#: share their truth and pseudoranges (tests/test_tseng2011.py changes every Setup field alone).
SIMULATION_FIELDS = GEOMETRY_FIELDS + ("clock_h0", "clock_h_minus2", "p0_sd")

#: the batches and bytes of array data the memo of :func:`simulator` keeps: the filters of a reading, evaluated one
#: by one (:func:`mmlib.papers.tseng2011.study.evaluate_reading`), its no-information baseline and the next readings
#: of a worker that differ only in filter settings ask for the same runs; 25 runs of 1800 epochs are about 5 MB
SIMULATION_MEMO = 4
SIMULATION_MEMO_BYTES = 128 * 2**20
_SIMULATIONS = BatchMemo(SIMULATION_MEMO, SIMULATION_MEMO_BYTES)


def simulator(ex: Experiment, memo: bool = True) -> Callable:
    """``mc -> (runs -> (truth (B, K+1, 8), [z_k (B, m_k)], start means (B, 8)))``.

    Per run: the clock random walk from Stream.TRUTH, pseudorange noise from Stream.MEASUREMENT
    (drawn for all 24 satellites at every epoch, so a satellite's noise does not depend on which
    others are in view), the initial-estimate error from Stream.INITIAL.  ``memo``: remember the batches in this
    process under the set-up's :data:`SIMULATION_FIELDS`, the MonteCarlo and the runs (the simulator's own output,
    read-only and shared by the callers: the same bits as simulating again), for an Experiment whose trajectory and
    sky are its set-up's own (:func:`experiment`'s; one built otherwise is simulated afresh each time); the arena's
    scenario passes False (the arena remembers its batches itself)."""
    check_bool(memo, "memo")
    s = ex.setup
    key = tuple(getattr(s, f) for f in SIMULATION_FIELDS)
    try:
        hash(key)
    except TypeError:            # a field given as a list, say: simulated afresh
        memo = False
    if memo:
        plane, sk = _geometry(**{f: getattr(s, f) for f in GEOMETRY_FIELDS})
        memo = ex.truth_plane is plane and ex.sky is sk
    K = s.n_steps
    clock = ManeuverSchedule([gnss.clock_dynamics(s.T, s.clock_h0, s.clock_h_minus2)], [], 0, s.T, K)
    P0 = np.diag(np.square(s.p0_sd))
    n_sat = len(ex.sky.names)

    def for_mc(mc: MonteCarlo):
        def simulate_runs(runs):
            B = len(runs)
            clock_truth = propagate(clock, np.zeros((B, 2)), mc.standard_normal(runs, Stream.TRUTH, (K, 2)))
            truth = np.zeros((B, K + 1, gnss.STATE_DIM))
            truth[:, :, [0, 1, 2, 3]] = ex.truth_plane[None]
            truth[:, :, list(gnss.CLOCK_INDEX)] = clock_truth
            v = mc.standard_normal(runs, Stream.MEASUREMENT, (K, n_sat)) * s.sigma_pr
            z = [model.h(truth[:, k + 1]) + v[:, k, ex.sky.visible[k]]
                 for k, model in enumerate(ex.measurement_models)]
            return truth, z, mc.gaussian(runs, Stream.INITIAL, truth[:, 0], P0)

        if not memo:
            return simulate_runs
        return _SIMULATIONS.wrap(simulate_runs, (key, mc))

    return for_mc


def make_batch_fn(ex: Experiment, mc: MonteCarlo) -> Callable:
    """``runs -> (truth (B, K+1, 8), [z_k (B, m_k)], {name: initial state})`` (:func:`simulator`: the truth and
    pseudoranges are read-only arrays shared with the other callers of the same runs where the memo applies)."""
    s = ex.setup
    P0 = np.diag(np.square(s.p0_sd))

    def init_state(e, x0, runs):
        return e.init(x0, P0, s.mu0) if isinstance(e, (IMM, NoiseAdaptiveIMM)) else e.init(x0, P0)

    return evaluation.with_initial_states(simulator(ex)(mc), ex.estimators, init_state)

def batch(setup: Setup, mc: MonteCarlo) -> tuple:
    """``(make_batch, estimators, measurement_models)`` of ``setup`` on the runs of ``mc``: every estimator of
    :func:`build` (the three filters and the EKF), :func:`make_batch_fn`, and the per-step measurement models (the
    satellites in view change every epoch) that :func:`mmlib.experiment.evaluation.evaluate` needs."""
    if not isinstance(setup, Setup):
        raise ValueError(f"setup: expected the Setup of a reading (PAPER.setup), got {setup!r}")
    ex = experiment(setup, names=ALGORITHMS + ("EKF",))
    return make_batch_fn(ex, mc), ex.estimators, ex.measurement_models


class NoiseLevels(NamedTuple):
    """A process-noise family with the two levels of an IMM whose modes differ only in their noise: ``family``
    (``level -> dynamics``, ``Q(levels)``), ``lower`` and ``upper`` (the family's level unit; for
    :class:`mmlib.core.gnss.PVClockNoise` the acceleration PSD in m^2/s^3)."""

    family: object
    lower: float
    upper: float

def scenario(setup: Setup) -> Scenario:
    """The reconstructed vehicle experiment of ``setup`` (the arena runs the headline's) as an arena scenario:
    8-state position-velocity-clock dynamics, raw pseudoranges of the satellites in view (the sensor changes every
    epoch), the IMM's two modes the lower and upper noise levels, single-model filters at the UKF's level (T-8);
    the noise family the FLAS adapts is the scenario's ``noise_levels``."""
    ex = experiment(setup, names=("UKF",))
    noise = noise_model(setup)
    return Scenario(name=NAME, title="Tseng et al. 2011 (reconstruction): GPS pseudoranges, PV-clock model",
                    source=CITATION, root_seed=ROOT_SEED, T=setup.T, n_steps=setup.n_steps,
                    simulator=simulator(ex, memo=False),
                    P0=np.diag(np.square(setup.p0_sd)), position=gnss.POSITION_INDEX[:2],
                    velocity=gnss.VELOCITY_INDEX[:2], single=noise.dynamics(setup.ukf_level, "UKF"),
                    modes=(noise.dynamics(setup.s_lower, "lower"), noise.dynamics(setup.s_upper, "upper")),
                    transition=transition_matrix(setup), mode_probabilities=setup.mu0,
                    measurement_models=ex.measurement_models, ukf=tuple(setup.ukf),
                    noise_levels=NoiseLevels(noise, setup.s_lower, setup.s_upper),
                    properties={"measurement": f"pseudoranges of 6-7 satellites ({setup.sigma_pr:g} m)",
                                "manoeuvre": "straight and circular segments at 20 m/s"})
