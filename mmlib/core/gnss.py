r"""GNSS pieces for pseudorange-level ("tightly coupled") navigation filters.

State ordering (stated once, used everywhere in this module): per local East-North-Up axis,
position then velocity, then the receiver clock, all in metres:

    ``[e, ve, n, vn, u, vu, b, d]``  with ``b = c * dt_rx`` (m) and ``d = c * d(dt_rx)/dt`` (m/s).

This follows :mod:`mmlib.core.models` (per axis, position then its derivative).

* :class:`CircularOrbitConstellation` -- satellites on circular Keplerian orbits, propagated in
  closed form and rotated into the Earth-fixed frame (IS-GPS-200 user algorithm with e = 0 and
  no perturbations).  ``nominal_gps24`` gives a 24-satellite, 6-plane, 55-degree constellation.
* :class:`LocalFrame` -- ECEF <-> local ENU at a reference point, through ``pymap3d``.
* :class:`Pseudoranges` -- :math:`\rho_i = \lVert s_i - p\rVert + b + v_i` for the satellites in
  view; a measurement model of the :mod:`mmlib.core.filters` interface whose dimension is the number
  of satellites (it changes from step to step: use ``run(..., measurement_models=...)``).
* :func:`clock_process_noise` and :class:`PVClockNoise` -- the two-state clock model and the
  position-velocity (continuous white-noise acceleration) process noise of the 8-state filter.

Signal transit time, the Sagnac correction, atmospheric delays and multipath are *not*
simulated: truth and filter share one geometric model, so leaving them out changes no
comparison between filters (it would only add terms a receiver corrects with models).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mmlib.core import linalg
from mmlib.core._validate import as_float_array, check_covariance, check_finite, check_scalar
from mmlib.core.models import LinearGaussianDynamics, _cholesky_of_R, _psd_factor, psd_by_construction

__all__ = ["Pseudoranges", "nominal_gps24", "CircularOrbitConstellation", "LocalFrame", "elevation", "clock_dynamics",
           "clock_process_noise", "PVClockNoise", "STATE_DIM", "POSITION_INDEX", "VELOCITY_INDEX", "CLOCK_INDEX",
           "SPEED_OF_LIGHT", "EARTH_ROTATION", "EARTH_GM", "GPS_SEMI_MAJOR_AXIS"]

SPEED_OF_LIGHT = 299_792_458.0          # m/s
EARTH_ROTATION = 7.2921151467e-5        # rad/s (WGS 84, IS-GPS-200)
EARTH_GM = 3.986005e14                  # m^3/s^2 (WGS 84 value used by GPS)
GPS_SEMI_MAJOR_AXIS = 26_559_700.0      # m, nominal (two-body period 43,077 s, half a sidereal day - 5 s)

POSITION_INDEX = (0, 2, 4)
VELOCITY_INDEX = (1, 3, 5)
CLOCK_INDEX = (6, 7)
STATE_DIM = 8


# --------------------------------------------------------------------------- constellation
@dataclass(frozen=True, eq=False)
class CircularOrbitConstellation:
    r"""Satellites on circular orbits: radius ``a`` (m), inclination ``inclination`` (rad),
    longitude of the ascending node at t = 0 ``raan`` (rad, Earth-fixed) and argument of
    latitude at t = 0 ``arg_latitude`` (rad), one entry per satellite.

    Earth-fixed position at time t (IS-GPS-200 Table 20-IV with e = 0, no harmonic corrections,
    :math:`\dot\Omega = 0` in inertial space):

    .. math::
        u = u_0 + n t,\quad \Omega = \Omega_0 - \omega_E t,\quad n = \sqrt{GM/a^3},\\
        s = a\,[\cos u\cos\Omega - \sin u\cos i\sin\Omega,\;
                \cos u\sin\Omega + \sin u\cos i\cos\Omega,\; \sin u\sin i].

    ``raan``, ``arg_latitude``: (S,), S >= 1, rad; ``inclination`` in [0, pi] rad; ``a`` (m) above the
    Earth's equatorial radius; ``names``: S strings (default ``S01``, ``S02``, ...).
    """

    raan: np.ndarray
    arg_latitude: np.ndarray
    inclination: float = math.radians(55.0)
    a: float = GPS_SEMI_MAJOR_AXIS
    names: tuple = ()

    def __post_init__(self):
        raan = check_finite(as_float_array(self.raan, "raan"), "raan")
        if raan.ndim != 1 or raan.shape[0] < 1:
            raise ValueError(f"raan: expected shape (S,) with S >= 1 satellites, got {raan.shape}")
        u0 = check_finite(as_float_array(self.arg_latitude, "arg_latitude"), "arg_latitude")
        if raan.shape != u0.shape:
            raise ValueError(f"arg_latitude: expected the shape of raan {raan.shape}, got {u0.shape}")
        inclination = check_scalar(self.inclination, "inclination", low=0.0, high=math.pi)
        a = check_scalar(self.a, "a")
        if not a > 6_378_137.0:
            raise ValueError(f"a: orbit radius (m) must exceed the Earth's radius 6,378,137 m, got {a}")
        object.__setattr__(self, "raan", raan)
        object.__setattr__(self, "arg_latitude", u0)
        object.__setattr__(self, "inclination", inclination)
        object.__setattr__(self, "a", a)
        if isinstance(self.names, str) or not isinstance(self.names, (tuple, list)):
            raise ValueError(f"names: expected a tuple of {len(raan)} satellite names, got {type(self.names).__name__}")
        if not self.names:
            object.__setattr__(self, "names", tuple(f"S{i + 1:02d}" for i in range(len(raan))))
        elif len(self.names) != len(raan) or not all(isinstance(nm, str) for nm in self.names):
            raise ValueError(f"names: expected {len(raan)} satellite names (strings), got {self.names!r}")
        else:
            object.__setattr__(self, "names", tuple(self.names))

    @property
    def size(self) -> int:
        """Number of satellites S."""
        return self.raan.shape[0]

    @property
    def mean_motion(self) -> float:
        r"""Two-body mean motion :math:`n = \sqrt{GM/a^3}` (rad/s), the rate of the argument of latitude."""
        return math.sqrt(EARTH_GM / self.a ** 3)

    def positions_ecef(self, times: np.ndarray) -> np.ndarray:
        """Earth-fixed positions (K, S, 3) (m) at ``times`` (K,) seconds (any shape, flattened to K; finite,
        else a ValueError naming ``times``), by the formula of the class docstring."""
        t = check_finite(as_float_array(times, "times"), "times").reshape(-1, 1)
        u = self.arg_latitude[None, :] + self.mean_motion * t
        om = self.raan[None, :] - EARTH_ROTATION * t
        cu, su, co, so = np.cos(u), np.sin(u), np.cos(om), np.sin(om)
        ci, si = math.cos(self.inclination), math.sin(self.inclination)
        return self.a * np.stack([cu * co - su * ci * so, cu * so + su * ci * co, su * si], axis=-1)


def nominal_gps24(phasing_deg: float = 15.0, raan0_deg: float = 0.0, u0_deg: float = 0.0) -> CircularOrbitConstellation:
    """A nominal 24-satellite GPS-like constellation: 6 planes 60 degrees apart in right
    ascension, 4 satellites 90 degrees apart in each, 55 degrees inclination, radius
    26,559.7 km (two-body period within 5 s of half a sidereal day).  Adjacent planes are phased by ``phasing_deg``
    (a Walker 24/6/1 pattern for 15 degrees).  The broadcast GPS constellation has uneven
    in-plane spacing; this regular pattern keeps 6-12 satellites above a 10-degree mask.  All three
    arguments are finite angles in degrees."""
    phasing_deg = check_scalar(phasing_deg, "phasing_deg")
    raan0_deg = check_scalar(raan0_deg, "raan0_deg")
    u0_deg = check_scalar(u0_deg, "u0_deg")
    planes, per_plane = 6, 4
    p = np.repeat(np.arange(planes), per_plane)
    s = np.tile(np.arange(per_plane), planes)
    raan = np.radians(raan0_deg + 60.0 * p)
    u0 = np.radians(u0_deg + 90.0 * s + phasing_deg * p)
    names = tuple(f"{'ABCDEF'[i]}{j + 1}" for i, j in zip(p, s))
    return CircularOrbitConstellation(raan, u0, names=names)


@dataclass(frozen=True)
class LocalFrame:
    """Local East-North-Up frame at geodetic ``lat``, ``lon`` (degrees), ``height`` (m, WGS 84);
    conversions by ``pymap3d`` (a maintained package, so no hand-written geodesy)."""

    lat: float
    lon: float
    height: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "lat", check_scalar(self.lat, "lat", low=-90.0, high=90.0))
        object.__setattr__(self, "lon", check_scalar(self.lon, "lon", low=-180.0, high=360.0))
        object.__setattr__(self, "height", check_scalar(self.height, "height"))

    @staticmethod
    def _points(value, name: str) -> np.ndarray:
        arr = check_finite(as_float_array(value, name), name)
        if arr.ndim < 1 or arr.shape[-1] != 3:
            raise ValueError(f"{name}: expected points of shape (..., 3) (metres), got {arr.shape}")
        return arr

    @property
    def origin_ecef(self) -> np.ndarray:
        """The frame's origin (``lat``, ``lon``, ``height``) in ECEF coordinates (3,) (m, WGS 84)."""
        import pymap3d
        return np.array(pymap3d.geodetic2ecef(self.lat, self.lon, self.height))

    def ecef_to_enu(self, xyz: np.ndarray) -> np.ndarray:
        """ECEF points (..., 3) to ENU (..., 3) in this frame (metres)."""
        import pymap3d
        xyz = self._points(xyz, "xyz")
        e, n, u = pymap3d.ecef2enu(xyz[..., 0], xyz[..., 1], xyz[..., 2], self.lat, self.lon, self.height)
        return np.stack([np.asarray(e), np.asarray(n), np.asarray(u)], axis=-1)

    def enu_to_ecef(self, enu: np.ndarray) -> np.ndarray:
        """ENU points (..., 3) in this frame to ECEF (..., 3) (metres)."""
        import pymap3d
        enu = self._points(enu, "enu")
        x, y, z = pymap3d.enu2ecef(enu[..., 0], enu[..., 1], enu[..., 2], self.lat, self.lon, self.height)
        return np.stack([np.asarray(x), np.asarray(y), np.asarray(z)], axis=-1)


def elevation(satellites_enu: np.ndarray, receiver_enu: np.ndarray) -> np.ndarray:
    """Elevation angle (rad) of satellites (..., S, 3) seen from receivers (..., 3), both in one
    ENU frame, measured from that frame's horizontal plane.  For a receiver within 25 km of the
    frame's origin the local vertical differs from the frame's by < 0.25 degrees (truth and filter
    share this geometry, so applying the mask in the frame's horizon changes no comparison)."""
    sats = LocalFrame._points(satellites_enu, "satellites_enu")
    rx = LocalFrame._points(receiver_enu, "receiver_enu")
    d = sats - rx[..., None, :]
    return np.arcsin(d[..., 2] / np.linalg.norm(d, axis=-1))


# --------------------------------------------------------------------------- measurement
@dataclass(frozen=True, eq=False)
class Pseudoranges:
    r"""Pseudoranges to ``satellites`` (m, 3) (ENU, metres) from a receiver with the state of this
    module: :math:`\rho_i = \lVert s_i - p\rVert + b + v_i`, :math:`v \sim N(0, R)`.

    Jacobian: :math:`\partial\rho_i/\partial p = -(s_i - p)^T/\lVert s_i - p\rVert` (minus the unit
    line of sight), :math:`\partial\rho_i/\partial b = 1` (Kaplan & Hegarty 2006, Sec. 2.4.2)."""

    satellites: np.ndarray
    R: np.ndarray
    names: tuple = ()
    name: str = "pseudoranges"
    is_linear: bool = field(default=False, init=False)

    def __post_init__(self):
        sats = check_finite(as_float_array(self.satellites, "satellites"), "satellites")
        if sats.ndim != 2 or sats.shape[1] != 3 or sats.shape[0] < 1:
            raise ValueError(f"satellites: expected shape (m >= 1, 3), got {sats.shape}")
        R = check_covariance(self.R, "R", sats.shape[0])
        if not isinstance(self.name, str):
            raise ValueError(f"name: expected a string, got {type(self.name).__name__}")
        if isinstance(self.names, str) or not isinstance(self.names, (tuple, list)) or (
                self.names and (len(self.names) != sats.shape[0] or not all(isinstance(nm, str) for nm in self.names))):
            raise ValueError(f"names: expected () or {sats.shape[0]} satellite names (strings), got {self.names!r}")
        R = np.array(R, dtype=float)
        sats = np.array(sats, dtype=float)
        object.__setattr__(self, "names", tuple(self.names))
        sats.setflags(write=False)
        R.setflags(write=False)
        object.__setattr__(self, "satellites", sats)
        # the satellites' E, N and U coordinates as three contiguous rows (linalg._lines_of_sight in the Jacobian)
        enu = np.ascontiguousarray(sats.T)
        enu.setflags(write=False)
        object.__setattr__(self, "_satellites_enu", enu)
        object.__setattr__(self, "R", R)

    @property
    def dim(self) -> int:
        """Measurement dimension m: the number of satellites in view."""
        return self.satellites.shape[0]

    @property
    def noise_factor(self) -> np.ndarray:
        """Lower Cholesky factor L (m, m) of ``R`` (metres), :math:`L L^T = R`, used to draw the noise (computed once,
        read-only)."""
        return _cholesky_of_R(self)

    @property
    def angular(self) -> tuple:
        """Which components are angles (residuals wrapped): none."""
        return (False,) * self.dim

    def h(self, x: np.ndarray) -> np.ndarray:
        r"""Pseudoranges :math:`\lVert s_i - p\rVert + b` (..., m) in m for states or sigma points ``x`` (..., 8)
        of this module's ordering (position p = ``x[..., (0, 2, 4)]``, clock bias b = ``x[..., 6]``, m)."""
        return linalg.pseudoranges(x, self.satellites, POSITION_INDEX, CLOCK_INDEX[0])

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        r""":math:`\partial\rho/\partial x` (..., m, 8) at states ``x`` (..., 8): minus the unit lines of sight
        :math:`-(s_i - p)^T/\lVert s_i - p\rVert` in the position columns, 1 in the clock-bias column, 0 for
        the velocities and the clock drift (dimensionless)."""
        d, r = linalg._lines_of_sight(x, self._satellites_enu, POSITION_INDEX)
        jac = np.zeros(x.shape[:-1] + (self.dim, x.shape[-1]))
        for dk, i in zip(d, POSITION_INDEX):
            jac[..., i] = -dk / r
        jac[..., CLOCK_INDEX[0]] = 1.0
        return jac

    def residual(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """``a - b`` for pseudoranges (..., m) (m); no component is an angle."""
        return a - b

    def average(self, values: np.ndarray, weights: np.ndarray) -> np.ndarray:
        r"""Weighted mean :math:`\sum_i w_i \rho_i` of pseudorange vectors ``values`` (..., p, m) with weights
        (p,); returns (..., m) (m)."""
        return weights @ values


# --------------------------------------------------------------------------- process noise
def clock_process_noise(T: float, h0: float, h_minus2: float) -> np.ndarray:
    r"""Discrete process noise (m^2, m^2/s, m^2/s^2) of the two-state clock ``[b, d]`` over T
    seconds, from the Allan-variance coefficients :math:`h_0` and :math:`h_{-2}`
    (Brown & Hwang 1997, Sec. 9.3: :math:`S_f = h_0/2`, :math:`S_g = 2\pi^2 h_{-2}`):

    .. math:: Q = c^2\begin{bmatrix} S_f T + S_g T^3/3 & S_g T^2/2\\ S_g T^2/2 & S_g T\end{bmatrix}.

    ``T`` (s) > 0; ``h0`` (s) and ``h_minus2`` (1/s) finite and >= 0.  Shape (2, 2).
    """
    T = check_scalar(T, "T", positive=True)
    h0 = check_scalar(h0, "h0", nonnegative=True)
    h_minus2 = check_scalar(h_minus2, "h_minus2", nonnegative=True)
    sf, sg = h0 / 2.0, 2.0 * math.pi ** 2 * h_minus2
    c2 = SPEED_OF_LIGHT ** 2
    return c2 * np.array([[sf * T + sg * T ** 3 / 3.0, sg * T ** 2 / 2.0], [sg * T ** 2 / 2.0, sg * T]])


def clock_dynamics(T: float, h0: float, h_minus2: float) -> LinearGaussianDynamics:
    """The two-state clock ``[b, d]`` (m, m/s) as dynamics: ``F = [[1, T], [0, 1]]``, Q of
    :func:`clock_process_noise` (same arguments)."""
    Q = clock_process_noise(T, h0, h_minus2)
    T = check_scalar(T, "T", positive=True)
    return LinearGaussianDynamics(np.array([[1.0, T], [0.0, 1.0]]), Q, _psd_factor(Q), "clock")


def _pv_transition(T: float) -> np.ndarray:
    return np.kron(np.eye(4), np.array([[1.0, T], [0.0, 1.0]]))


@dataclass(frozen=True, eq=False)
class PVClockNoise:
    r"""Process noise of the 8-state position-velocity-clock model as a function of the
    acceleration power spectral density :math:`S_p` (m^2/s^3, the same on every axis):

    .. math:: Q(S_p) = S_p\,\mathrm{blkdiag}(Q_1, Q_1, Q_1, 0_2) + \mathrm{blkdiag}(0_6, Q_{clock}),
              \quad Q_1 = \begin{bmatrix}T^3/3 & T^2/2\\ T^2/2 & T\end{bmatrix}

    (continuous white-noise acceleration, Bar-Shalom et al. 2001, Eq. 6.2.2-12).  ``Q(levels)``
    takes any array of levels and returns Q with two trailing axes: an IMM's modes and a
    per-run adapted level use the same arithmetic, so equal levels give bit-identical Q.

    ``T``: sampling interval (s, finite, > 0); ``clock`` (2, 2): positive semi-definite clock process
    noise (m^2, m^2/s, m^2/s^2), e.g. :func:`clock_process_noise`."""

    T: float
    clock: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "T", check_scalar(self.T, "T", positive=True))
        clock = np.array(check_covariance(self.clock, "clock", 2, semidefinite=True), dtype=float)
        clock.setflags(write=False)
        object.__setattr__(self, "clock", clock)
        q1 = np.array([[self.T ** 3 / 3.0, self.T ** 2 / 2.0], [self.T ** 2 / 2.0, self.T]])
        unit = np.zeros((STATE_DIM, STATE_DIM))
        unit[:6, :6] = np.kron(np.eye(3), q1)
        base = np.zeros((STATE_DIM, STATE_DIM))
        base[6:, 6:] = self.clock
        object.__setattr__(self, "unit", unit)
        object.__setattr__(self, "base", base)

    @psd_by_construction
    def Q(self, levels: np.ndarray | float) -> np.ndarray:
        r""":math:`Q(S_p)` (..., 8, 8) for acceleration spectral densities ``levels`` (any shape (...), e.g. (r,)
        for an IMM's modes or (B, r) per run; m^2/s^3, finite, >= 0, else a ValueError naming ``levels``);
        units m^2, m^2/s, m^2/s^2 by entry.

        Marked :func:`mmlib.core.models.psd_by_construction`: every Q returned passes the check a noise-adaptive IMM
        would otherwise run each step (:func:`mmlib.core._validate.check_covariance` with ``semidefinite=True``).
        Finite: the levels are, and a level so large that a product overflows is refused (ValueError naming
        ``levels``).  Q is block diagonal, :math:`S_p Q_1` three times and the clock's block alone in its rows and
        columns, so its eigenvalues are the blocks'.  Each entry of :math:`S_p Q_1` is one rounded product of the level
        and the exactly symmetric :math:`Q_1`, so the block is exactly symmetric, and :math:`\det Q_1 = T^4/12` is a
        quarter of the product of its diagonal, so rounding (relative 1e-16, or an underflow to a subnormal, of the
        order of the smallest double) moves its eigenvalues by far less than the check's tolerance, ``RTOL`` x the
        largest entry.  The clock's block passed the same check on construction (symmetric and semi-definite to
        ``RTOL`` of its own largest entry, at most Q's)."""
        levels = as_float_array(levels, "levels")
        if np.any(~np.isfinite(levels)) or np.any(levels < 0):
            raise ValueError("levels: acceleration spectral densities must be finite and >= 0")
        with np.errstate(over="ignore"):
            Q = levels[..., None, None] * self.unit + self.base
        if not np.isfinite(Q).all():
            raise ValueError(f"levels: a level up to {float(np.max(levels)):.3g} m^2/s^3 overflows Q (the largest "
                             f"that does not: about {np.finfo(float).max / self.unit.max():.3g})")
        return Q

    def affine(self) -> tuple[np.ndarray, np.ndarray]:
        r"""``(unit, base)``, each (8, 8): :meth:`Q` is ``levels[..., None, None] * unit + base``, entry by entry (what
        a compiled whole run of a noise-adaptive IMM computes itself, :func:`mmlib.core.linalg.fuzzy_imm_run`)."""
        return self.unit, self.base

    def dynamics(self, level: float, name: str = "") -> LinearGaussianDynamics:
        """The 8-state model with one level (m^2/s^3, finite, >= 0): ``x_k = F x_{k-1} + w``,
        ``w ~ N(0, Q(level))``; ``name`` a string (default ``PV(S_p=level)``)."""
        level = check_scalar(level, "level", nonnegative=True)
        if not isinstance(name, str):
            raise ValueError(f"name: expected a string, got {type(name).__name__}")
        Q = self.Q(level)
        return LinearGaussianDynamics(_pv_transition(self.T), Q, _psd_factor(Q), name or f"PV(S_p={level:g})")
