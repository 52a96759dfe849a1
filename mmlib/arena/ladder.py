r"""A ladder of controlled scenarios: one target and one radar, with the measurement nonlinearity and the manoeuvre
strength stepped one at a time, so that the arena shows where higher-degree rules and the layers pay off -- the five
papers' own scenarios are all only weakly nonlinear.

The target (SI units): starts at (-5 km, 10 km) heading east at 100 m/s, turns right at rate omega over 30-50 s and
left at omega over 65-85 s, 100 steps of T = 1 s, with acceleration noise of variance q = 10 (m/s^2)^2 per step
(discretised white-noise acceleration, :func:`mmlib.core.models.constant_velocity`) in the truth and in every filter's
models (the filters are told the truth's noise, so a consistent filter is possible).  The radar
at the origin measures range precisely (sigma_r = 1 m) and bearing coarsely (sigma_theta).  At ranges r of 10-11 km
the cross-range spread of a bearing is sigma_theta * r, and the second-order term of the range that a linearisation
neglects is about (sigma_theta r)^2 / (2 r) (Lerro & Bar-Shalom 1993, IEEE Trans. AES 29(3):1015: the
converted-measurement bias r sigma_theta^2 relative to sigma_r), so stepping sigma_theta steps the nonlinearity.

Rungs (``RUNGS``): ``linear`` (a linear position sensor with sigma = 10 m per axis and no manoeuvre: every filter is
the Kalman filter, the consistency check of the ladder), six nonlinearity rungs at omega = 3 deg/s (sigma_theta =
1, 3, 10, 30, 80, 200 mrad: cross-range spread sigma_theta r / sigma_r from 11 to 2200; the computed index below runs
from ~0.002 to ~0.4) and three more manoeuvre rungs at sigma_theta = 10 mrad (omega = 1, 6, 10 deg/s).  The largest
bearing noise (200 mrad, 11 degrees) is a poor passive sensor's: it is there to reach the regime where the rules
separate.  The IMM's modes are CV and the two known-rate turns (as in Zhu et
al. 2016 and Zhou et al. 2017), transition probabilities 0.9 to stay; the single-model filters use the CV model.

:func:`nonlinearity_index` *computes* each scenario's index from its own runs (it is never typed in): the
Mahalanobis size, in the predicted innovation covariance, of the gap between the Gaussian mean of the measurement
function and the measurement function at the mean, at the predicted moments of a third-degree CKF -- zero for a
linear sensor, about r sigma_theta^2 / (2 sqrt(S_rr)) for a radar.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from mmlib.core import models
from mmlib.core.filters import SigmaPointFilter
from mmlib.core.rules import Cubature, FifthDegreeCubature
from mmlib.experiment import evaluation
from mmlib.experiment.montecarlo import MonteCarlo, Stream
from mmlib.experiment.scenario import Scenario
from mmlib.experiment.simulate import ManeuverSchedule

__all__ = [
    "rung", "scenario", "nonlinearity_index", "Rung", "RUNGS", "NAMES", "ROOT_SEED", "T", "N_STEPS", "X0", "P0_SD", "Q",
    "SIGMA_R", "LINEAR_SIGMA", "SIGMA_THETA_MRAD", "TURNS", "MANOEUVRE_OMEGA_DEG", "TRANSITION"
]

ROOT_SEED = 20261201          #: the arena's root seed (the ladder's streams; paper scenarios keep their papers')
T = 1.0
N_STEPS = 100
X0 = (-5000.0, 100.0, 10000.0, 0.0)        # [x m, vx m/s, y m, vy m/s]
P0_SD = (100.0, 10.0, 100.0, 10.0)         # initial estimate error, drawn from N(0, P0) (Stream.INITIAL)
Q = 10.0                                   # (m/s^2)^2, acceleration-noise variance of truth and filters
SIGMA_R = 1.0                              # m, the radar's range noise
LINEAR_SIGMA = 10.0                        # m per axis, the linear rung's position sensor
TURNS = ((30.0, 50.0, -1), (65.0, 85.0, +1))   # s, s, sign of the rate (right, then left)
TRANSITION = ((0.9, 0.05, 0.05), (0.05, 0.9, 0.05), (0.05, 0.05, 0.9))


class Rung(NamedTuple):
    """One rung: ``sigma_theta`` (rad; None: a linear position sensor) and turn rate ``omega_deg`` (deg/s; 0: no
    manoeuvre); ``axis`` which ladder it belongs to ("nonlinearity", "manoeuvre" or "linear")."""

    name: str
    sigma_theta: float | None
    omega_deg: float
    axis: str


SIGMA_THETA_MRAD = (1, 3, 10, 30, 80, 200)     #: the nonlinearity rungs' bearing noise (mrad)
MANOEUVRE_OMEGA_DEG = (1.0, 6.0, 10.0)          #: the manoeuvre rungs' turn rates (deg/s), at 10 mrad

RUNGS = (
    Rung("ladder-linear", None, 0.0, "linear"),
    *(Rung(f"ladder-nl{i}", s * 1e-3, 3.0, "nonlinearity") for i, s in enumerate(SIGMA_THETA_MRAD, start=1)),
    *(Rung(f"ladder-turn{i}", 10e-3, w, "manoeuvre") for i, w in enumerate(MANOEUVRE_OMEGA_DEG, start=1)),
)
NAMES = tuple(r.name for r in RUNGS)


def rung(name: str) -> Rung:
    """The :class:`Rung` called ``name`` (one of :data:`NAMES`); ValueError listing the known names otherwise."""
    for r in RUNGS:
        if r.name == name:
            return r
    raise ValueError(f"scenario: unknown ladder rung {name!r}; known: {', '.join(NAMES)}")


def _schedule_and_modes(r: Rung):
    cv = models.constant_velocity(T, Q)
    if r.omega_deg == 0.0:
        return ManeuverSchedule([cv], [], 0, T, N_STEPS), None
    w = math.radians(r.omega_deg)
    right, left = models.coordinated_turn(T, -w, Q), models.coordinated_turn(T, w, Q)
    segments = [(a, b, 1 if sign < 0 else 2) for a, b, sign in TURNS]
    return ManeuverSchedule([cv, right, left], segments, 0, T, N_STEPS), (cv, right, left)


def scenario(name: str) -> Scenario:
    """The ladder rung ``name`` (see :data:`RUNGS`) as a :class:`Scenario`."""
    r = rung(name)
    schedule, modes = _schedule_and_modes(r)
    if r.sigma_theta is None:
        sensor = models.position_measurement([LINEAR_SIGMA ** 2, LINEAR_SIGMA ** 2])
        what = f"linear position sensor ({LINEAR_SIGMA:g} m per axis)"
    else:
        sensor = models.range_bearing(np.diag([SIGMA_R ** 2, r.sigma_theta ** 2]))
        what = f"range-bearing ({SIGMA_R:g} m, {r.sigma_theta * 1e3:g} mrad)"
    x0 = np.array(X0)
    P0 = np.diag(np.square(P0_SD))

    def for_mc(mc: MonteCarlo):
        return evaluation.simulator(mc, schedule, sensor, x0, start=lambda runs: mc.gaussian(runs, Stream.INITIAL,
                                                                                              x0, P0))

    spread = None if r.sigma_theta is None else r.sigma_theta * math.hypot(X0[0], X0[2]) / SIGMA_R
    manoeuvre = "none (constant velocity)" if r.omega_deg == 0 else f"turns at ±{r.omega_deg:g}°/s"
    return Scenario(name=r.name, title=f"ladder: {what}, {manoeuvre}", source="controlled", root_seed=ROOT_SEED,
                    T=T, n_steps=N_STEPS, simulator=for_mc, P0=P0, position=(0, 2), velocity=(1, 3),
                    single=modes[0] if modes else schedule.models[0], modes=modes,
                    transition=None if modes is None else np.array(TRANSITION),
                    mode_probabilities=None if modes is None else (0.8, 0.1, 0.1), measurement=sensor,
                    properties={"axis": r.axis,
                                "sigma_theta_mrad": None if r.sigma_theta is None else r.sigma_theta * 1e3,
                                "omega_deg_s": r.omega_deg, "cross_range_spread": spread,
                                "measurement": what, "manoeuvre": manoeuvre},
                    notes={} if modes else {"modes": "the linear rung has no manoeuvre: one CV model, no mode set"})


def nonlinearity_index(s: Scenario, n_runs: int = 50) -> dict:
    r"""The scenario's measurement nonlinearity, computed from ``n_runs`` of its own runs (the first ones of its root
    seed): at every step, at the predicted moments :math:`N(\hat x^-, P^-)` of a third-degree CKF on the scenario's
    single model (its first IMM mode if it has none),

    .. math:: \eta_k = \sqrt{b_k^T S_k^{-1} b_k}, \qquad b_k = E[h(x)] - h(\hat x^-),

    with :math:`E[h(x)]` and the innovation covariance :math:`S_k = \mathrm{Cov}[h(x)] + R` from the fifth-degree
    cubature rule (exact for polynomials to degree 5).  Returns ``median`` and ``p90`` over runs and steps (diverged
    runs excluded) and ``n_runs``: 0 for a linear sensor; the size, in innovation standard deviations, of the mean
    error a linearisation makes."""
    if not isinstance(s, Scenario):
        raise ValueError(f"s: expected a Scenario, got {s!r}")
    if isinstance(n_runs, bool) or not isinstance(n_runs, (int, np.integer)) or n_runs < 2:
        raise ValueError(f"n_runs: expected an integer >= 2, got {n_runs!r}")
    mc = MonteCarlo(s.root_seed, int(n_runs))
    runs = range(mc.n_runs)
    truth, z, start = s.simulator(mc)(runs)
    ckf = SigmaPointFilter(Cubature())
    fifth = SigmaPointFilter(FifthDegreeCubature())
    dyn = s.single if s.single is not None else s.modes[0]
    state = ckf.init(start, s.P0)
    etas = []
    for k in range(s.n_steps):
        model = s.measurement if s.measurement is not None else s.measurement_models[k]
        z_k = z[:, k] if s.measurement is not None else z[k]
        state = ckf.predict(state, dyn)
        ok = np.isfinite(state.mean).all(axis=1)
        eta = np.full(mc.n_runs, np.nan)
        if ok.any():
            prior = state._replace(mean=state.mean[ok], cov=state.cov[ok])
            pred = fifth.predict_measurement(prior, model)                 # E[h(x)] and Cov[h(x)] + R
            b = model.residual(pred.z_pred, model.h(prior.mean))
            S = pred.S
            eta[ok] = np.sqrt(np.maximum(np.einsum("bi,bi->b", b, np.linalg.solve(S, b[..., None])[..., 0]), 0.0))
        etas.append(eta)
        state, _ = ckf.update(state, z_k, model)
    eta = np.array(etas)
    eta = eta[np.isfinite(eta)]
    return {"median": float(np.median(eta)), "p90": float(np.quantile(eta, 0.9)), "n_runs": mc.n_runs,
            "definition": "Mahalanobis norm of E[h(x)] - h(E x) in the innovation covariance at a CKF's predicted "
                          "moments (fifth-degree rule), median over runs and steps"}
