"""The set-up of Tseng et al. 2011 as reconstructed (every parameter with its deviation number) and its filters.

:class:`Setup` holds every reconstructed parameter; :func:`setup` is the set-up of a reading of the reading space
(:data:`mmlib.papers.tseng2011.space.SPACE`).  The filters (:func:`build`) run on the 8-state
position-velocity-clock model ``[e, ve, n, vn, u, vu, b, d]`` (m, m/s; clock bias and drift in m, m/s) with raw
pseudoranges (T-7): the UKF at one acceleration PSD (T-8), the IMMUKF with two modes at the lower and upper PSD
(T-7, T-9), and the FUZZY-IMMUKF whose two modes' PSDs the FLAS (:mod:`mmlib.core.layers.fuzzy_noise`, with the
breakpoints, normalisation and window of T-10 and T-11) sets online within the IMM's range; the EKF runs alongside
for the coincidence check (T-6).  The trajectory, the sky and the Monte Carlo batch are in
:mod:`mmlib.papers.tseng2011.simulation`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from mmlib.core import gnss
from mmlib.core.estimation import IMM, SingleModel
from mmlib.core.filters import ExtendedKalmanFilter, SigmaPointFilter
from mmlib.core.layers.fuzzy_noise import NORMALISE, fuzzy_imm
from mmlib.core.rules import Unscented
from mmlib.papers.tseng2011.space import SPACE
from mmlib.papers.tseng2011.text import P0_SD

__all__ = [
    "setup", "Setup", "build", "noise_model", "transition_matrix", "UKF_RULES"
]

#: the single UKF's acceleration PSD relative to the IMM's levels (T-8; :attr:`Setup.ukf_level`)
UKF_RULES = ("geometric", "lower", "below", "upper")


@dataclass(frozen=True)
class Setup:
    """Every reconstructed parameter, with its deviation number."""

    T: float = 1.0                               # s (T-2)
    n_steps: int = 1800                          # 1800 s (segment table)
    speed: float = 20.0                          # m/s (T-1)
    heading_deg: float = 0.0                     # initial course, degrees from East (T-1)
    #: (start, end, total course change in degrees; + = counter-clockwise) of the maneuvering segments (T-1)
    turns: tuple = ((300.0, 700.0, 360.0), (800.0, 900.0, 90.0), (1200.0, 1400.0, -90.0))
    site: tuple = (25.15, 121.78, 0.0)           # geodetic lat, lon (deg), height (m) (T-3)
    phasing_deg: float = 15.0                    # constellation (T-3)
    mask_deg: float = 10.0                       # elevation mask (T-3)
    sigma_pr: float = 3.0                        # pseudorange noise s.d. (m) (T-4)
    clock_h0: float = 2e-19                      # TCXO Allan coefficients (T-5)
    clock_h_minus2: float = 2e-20
    s_lower: float = 0.01                        # IMM lower / upper acceleration PSD (m^2/s^3) (T-7)
    s_upper: float = 1.0
    s_ukf: float | None = None                   # UKF's PSD (m^2/s^3); None = set by ukf_rule (T-8)
    ukf_rule: str = "geometric"                  # UKF's PSD relative to the IMM's: "geometric" mean, "lower",
                                                 # "below" (10x below the lower) or "upper" (T-8)
    p_stay: float = 0.99                         # IMM Markov chain (T-9)
    mu0: tuple = (0.5, 0.5)                      # initial mode probabilities (T-9)
    ukf: tuple = (1.0, 2.0, 0.0)                 # alpha, beta, kappa (T-6)
    xi_breakpoints: tuple = (1.0, 2.0, 4.0)      # fuzzy sets of xi / s (T-10)
    dod_normalise: str = "innovation"            # s = predicted innovation variance, or "measurement" (T-10)
    mf_scale: float = 1.0                        # all fuzzy breakpoints scaled by this (T-10b)
    dod_window: int = 1                          # epochs over which the DOD is averaged (T-11); 1 = Sec. 3.2
    p0_sd: tuple = P0_SD                         # initial estimate s.d. (m, m/s) (T-12)

    def __post_init__(self):
        for name in ("T", "speed", "sigma_pr", "s_lower", "s_upper", "mf_scale"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name}: must be > 0, got {getattr(self, name)!r}")
        if not self.s_lower < self.s_upper:
            raise ValueError(f"s_lower, s_upper: need s_lower < s_upper, got {self.s_lower}, {self.s_upper}")
        if not 0.0 < self.p_stay < 1.0:
            raise ValueError(f"p_stay: must be in (0, 1), got {self.p_stay}")
        if self.dod_normalise not in NORMALISE:
            raise ValueError(f"dod_normalise: expected 'innovation' or 'measurement', got {self.dod_normalise!r}")
        if not 0.0 <= self.mask_deg < 90.0:
            raise ValueError(f"mask_deg: expected [0, 90) degrees, got {self.mask_deg}")
        if self.ukf_rule not in UKF_RULES:
            raise ValueError(f"ukf_rule: expected one of {UKF_RULES}, got {self.ukf_rule!r}")
        if self.s_ukf is not None and not self.s_ukf > 0:
            raise ValueError(f"s_ukf: must be > 0 or None, got {self.s_ukf!r}")
        if isinstance(self.dod_window, bool) or not isinstance(self.dod_window, int) or self.dod_window < 1:
            raise ValueError(f"dod_window: expected a positive integer number of epochs, got {self.dod_window!r}")

    @property
    def ukf_level(self) -> float:
        """The single UKF's acceleration PSD (m^2/s^3): ``s_ukf`` if given, else by ``ukf_rule`` from
        the IMM's levels (T-8): the geometric mean sqrt(S_L S_U), S_L, S_L / 10 or S_U."""
        if self.s_ukf is not None:
            return self.s_ukf
        return {"geometric": math.sqrt(self.s_lower * self.s_upper), "lower": self.s_lower,
                "below": self.s_lower / 10.0, "upper": self.s_upper}[self.ukf_rule]

    @property
    def breakpoints(self) -> np.ndarray:
        """The FLAS's breakpoints of xi / s (T-10, dimensionless), ``xi_breakpoints`` scaled by ``mf_scale``
        (T-10b), shape (3,)."""
        return np.array(self.xi_breakpoints) * self.mf_scale

    @property
    def times(self) -> np.ndarray:
        """Measurement epochs t_k = kT (s), k = 1..K, shape (K,)."""
        return np.arange(1, self.n_steps + 1) * self.T



def setup(reading: Mapping) -> Setup:
    """The Setup of a reading (every factor's option applied to the defaults; ValueError naming a bad
    factor or option)."""
    return Setup(**SPACE.changes(reading))


def noise_model(setup: Setup) -> gnss.PVClockNoise:
    """The process-noise family of the 8-state position-velocity-clock model, level = acceleration PSD (m^2/s^3),
    with the receiver clock of ``clock_h0``, ``clock_h_minus2`` (T-5) at the sampling interval ``T`` (s)."""
    return gnss.PVClockNoise(setup.T, gnss.clock_process_noise(setup.T, setup.clock_h0, setup.clock_h_minus2))


def transition_matrix(setup: Setup) -> np.ndarray:
    """The two-mode IMM's transition matrix (2, 2) (T-9): stay with ``p_stay``."""
    return np.array([[setup.p_stay, 1 - setup.p_stay], [1 - setup.p_stay, setup.p_stay]])


def build(setup: Setup, *, frozen_fuzzy: bool = False) -> dict:
    """Estimators {UKF, IMMUKF, FUZZY-IMMUKF, EKF} (the EKF for the coincidence check); every step supplies its
    own measurement model (the satellites in view).  ``frozen_fuzzy=True`` keeps the FLAS's initial ("Normal")
    levels: the FUZZY-IMMUKF is then the plain IMM at those levels."""
    noise = noise_model(setup)
    a, b, k = setup.ukf
    ukf = SigmaPointFilter(Unscented(a, b, k), name="UKF")
    meas0 = None  # every step supplies its own measurement model
    low, high = noise.dynamics(setup.s_lower, "lower"), noise.dynamics(setup.s_upper, "upper")
    Tm = transition_matrix(setup)
    imm = IMM(ukf, [low, high], meas0, Tm, name="IMMUKF")
    fimm = fuzzy_imm(ukf, noise, setup.s_lower, setup.s_upper, Tm, breakpoints=setup.breakpoints,
                     normalise=setup.dod_normalise, window=setup.dod_window, frozen=frozen_fuzzy,
                     name="FUZZY-IMMUKF")
    single = noise.dynamics(setup.ukf_level, "UKF")
    return {
        "UKF": SingleModel(ukf, single, meas0, name="UKF"),
        "IMMUKF": imm,
        "FUZZY-IMMUKF": fimm,
        "EKF": SingleModel(ExtendedKalmanFilter(name="EKF"), single, meas0, name="EKF"),
    }
