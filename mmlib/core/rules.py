r"""Gaussian quadrature ("sigma-point") rules as small immutable objects.

A rule approximates Gaussian-weighted integrals

.. math:: \int g(x)\,\mathrm{N}(x; m, P)\,dx \approx \sum_i w_i\, g(m + S\xi_i), \qquad P = S S^T,

with unit points :math:`\xi_i` and weights :math:`w_i` that depend only on the
dimension ``n``.  A rule knows nothing about filtering: the generic filter in
:mod:`mmlib.core.filters` asks it for points and mean weights (``unit_points``) and
for the (cross-)covariance of the deviations of transformed points.  Rules whose
covariance is *not* a weighted sum of outer products (central differences)
override :meth:`SigmaPointRule.covariances`.

Conventions: ``S`` is the lower Cholesky factor; ``points`` returns the sigma
points with shape ``(..., m, n)`` (any batch axes, point, coordinate).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields
from functools import lru_cache
from itertools import combinations

import numpy as np

from mmlib.core._validate import check_positive_int, check_scalar
from mmlib.core.linalg import offset_points, weighted_covariances

__all__ = ["Unscented", "Cubature", "FifthDegreeCubature", "SphericalSimplexRadial", "CentralDifference",
           "rule_by_name", "SigmaPointRule", "UnitPoints", "regular_simplex"]


@dataclass(frozen=True)
class UnitPoints:
    """Points and weights of a rule for a fixed dimension (read-only arrays): ``xi`` (M, n) unit points in
    :math:`N(0, I)` coordinates (dimensionless), ``wm`` (M,) mean weights, ``wc`` (M,) covariance weights
    (NaN for the Stirling central-difference rule, which does not use them)."""

    xi: np.ndarray        # (m, n) unit points, N(0, I) coordinates
    wm: np.ndarray        # (m,) weights for the mean
    wc: np.ndarray        # (m,) weights for the covariance

    def __post_init__(self):
        for arr in (self.xi, self.wm, self.wc):
            arr.setflags(write=False)


def _frozen(xi, wm, wc=None) -> UnitPoints:
    xi = np.asarray(xi, dtype=float)
    wm = np.asarray(wm, dtype=float)
    wc = wm.copy() if wc is None else np.asarray(wc, dtype=float)
    return UnitPoints(xi, wm, wc)


class SigmaPointRule:
    """Base class: a deterministic rule given by :meth:`unit_points`.

    Subclasses are frozen dataclasses holding only their hyper-parameters;
    ``unit_points(n)`` is cached per (rule, n) -- rules are tiny, immutable and
    long-lived, so the cache holding them is intended.
    """

    name = "rule"
    degree = 3
    #: True when the rule's covariances are the weighted outer products of :meth:`covariances` (the fused
    #: operations of :mod:`mmlib.core.linalg` implement that form; a rule that overrides it says False)
    weighted_moments = True

    def unit_points(self, n: int) -> UnitPoints:  # pragma: no cover - abstract
        r"""The rule for dimension ``n`` >= 1: unit points :math:`\xi_i` (M, n) in :math:`N(0, I)` coordinates
        (dimensionless), mean weights (M,) and covariance weights (M,) (:class:`UnitPoints`, read-only,
        cached per (rule, n)).  A bad ``n`` is a ValueError naming ``n``."""
        raise NotImplementedError

    def num_points(self, n: int) -> int:
        """Number of points M of the rule in dimension ``n`` (e.g. 2n + 1 unscented, 2n cubature,
        2n^2 + 1 fifth-degree cubature, 2n + 2 spherical simplex-radial)."""
        return self.unit_points(n).xi.shape[0]

    # -- generic moment computations -------------------------------------
    def points(self, mean: np.ndarray, chol: np.ndarray) -> np.ndarray:
        """Sigma points ``m + S xi_i``: mean (..., n), chol (..., n, n) (the lower factor S of P, in the
        state's units) -> (..., M, n), M = :meth:`num_points`, in the state's units
        (:func:`mmlib.core.linalg.offset_points`)."""
        return offset_points(mean, chol, self.unit_points(mean.shape[-1]).xi)

    def covariances(self, dx: np.ndarray, dy: np.ndarray,
                    add: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        r"""``(P_yy + add, P_xy)`` ((..., d, d), (..., n, d)) from deviations ``dx = X_i - m`` (..., M, n) and
        ``dy = Y_i - \bar y`` (..., M, d):  :math:`\sum_i w^c_i dy_i dy_i^T` and
        :math:`\sum_i w^c_i dx_i dy_i^T` (:func:`mmlib.core.linalg.weighted_covariances`); ``add`` (e.g. the
        noise R) broadcasts against (..., d, d)."""
        return weighted_covariances(dy, self.unit_points(dx.shape[-1]).wc, dx, add)

    def covariance(self, dx: np.ndarray, dy: np.ndarray, add: np.ndarray | None = None) -> np.ndarray:
        """Only ``P_yy + add`` (..., d, d) (prediction step, ``add`` e.g. the noise Q); ``dx`` (..., M, n) gives
        the dimension n of the rule (and is needed by rules that pair points); ``dy`` (..., M, d)."""
        return weighted_covariances(dy, self.unit_points(dx.shape[-1]).wc, None, add)[0]


@dataclass(frozen=True)
class Unscented(SigmaPointRule):
    r"""Scaled unscented transform, defaults ``alpha=1, beta=2, kappa=0`` (Julier 2002; Wan & van der Merwe 2000).

    :math:`\lambda = \alpha^2 (n+\kappa) - n`; points :math:`0, \pm\sqrt{n+\lambda}\,e_i`;
    :math:`w^m_0 = \lambda/(n+\lambda)`, :math:`w^c_0 = w^m_0 + 1 - \alpha^2 + \beta`,
    :math:`w_i = 1/(2(n+\lambda))` (Liu & Wu 2017, Eq. 2; Wan & van der Merwe 2000, Eq. 15).  Exact for
    polynomials of degree 3 (and for degree-2 covariances whatever ``beta``).

    ``alpha`` > 0, ``beta`` and ``kappa`` finite real numbers (dimensionless; stored as floats);
    ``n + lambda > 0`` is checked per dimension in :meth:`unit_points`.

    **The defaults** ``(alpha, beta, kappa) = (1, 2, 0)``, also the default ``ukf`` of
    :class:`mmlib.experiment.scenario.Scenario` and of :func:`rule_by_name`:

    * ``beta = 2`` is the value Wan & van der Merwe 2000 (Sec. 3, after Eq. 15) and Julier 2002 give as
      optimal for a Gaussian prior: the extra centre weight :math:`1 - \alpha^2 + \beta` carries the
      prior's kurtosis into the covariance (for scalar :math:`x \sim N(m, s^2)` the rule gives
      :math:`\mathrm{Var}[x^2] = 4m^2s^2 + 2s^4` exactly; tested);
    * ``kappa = 0`` is the secondary scaling "usually set to 0" of Wan & van der Merwe 2000 (Sec. 3).
      Julier & Uhlmann's ``kappa = 3 - n`` (1997; 2004) depends on the state dimension,
      so it is not a default here: pass it, e.g. ``Unscented(1.0, 2.0, 3.0 - n)``;
    * ``alpha = 1`` keeps every mean weight non-negative (:math:`w^m_0 = 0`): the small ``alpha`` (e.g.
      1e-3) Wan & van der Merwe suggest gives :math:`w^m_0 \approx 1 - 1/\alpha^2 \approx -10^6`, whose
      cancellation costs about 6 of the 16 digits of float64.

    With these defaults the outer points and the mean weights are those of :class:`Cubature` (the centre
    point has mean weight 0, so the transformed *means* and the cross-covariances are the cubature rule's)
    and the covariance :math:`P_{yy}` differs from the cubature rule's by :math:`2\,(Y_0 - \bar y)(Y_0 -
    \bar y)^T`, :math:`Y_0` the image of the mean: the two rules agree on linear maps and differ wherever
    the image of the mean is not the mean of the images, i.e. on curved maps such as a range (tested).  The setting
    ``alpha=1, beta=0, kappa=0``, this class's default before, *is* the cubature rule.  Every paper's
    set-up passes its own three parameters.
    """

    alpha: float = 1.0
    beta: float = 2.0
    kappa: float = 0.0
    name = "unscented"
    degree = 3

    def __post_init__(self):
        object.__setattr__(self, "alpha", check_scalar(self.alpha, "alpha", positive=True))
        object.__setattr__(self, "beta", check_scalar(self.beta, "beta"))
        object.__setattr__(self, "kappa", check_scalar(self.kappa, "kappa"))

    @lru_cache(maxsize=None)
    def unit_points(self, n: int) -> UnitPoints:
        r"""``2n + 1`` points (0, then :math:`+\sqrt{n+\lambda}\,e_i`, then :math:`-\sqrt{n+\lambda}\,e_i`) and
        the weights of the class docstring; ValueError naming ``kappa`` if :math:`n + \lambda \le 0`."""
        n = check_positive_int(n, "n")
        lam = self.alpha ** 2 * (n + self.kappa) - n
        if not n + lam > 0:
            raise ValueError(f"kappa: n + lambda must be > 0 (n={n}, lambda={lam})")
        c = math.sqrt(n + lam)
        eye = np.eye(n)
        xi = np.vstack([np.zeros((1, n)), c * eye, -c * eye])
        wm = np.full(2 * n + 1, 0.5 / (n + lam))
        wm[0] = lam / (n + lam)
        wc = wm.copy()
        wc[0] += 1.0 - self.alpha ** 2 + self.beta
        return _frozen(xi, wm, wc)


@dataclass(frozen=True)
class Cubature(SigmaPointRule):
    r"""Third-degree spherical-radial cubature rule (Arasaratnam & Haykin 2009,
    IEEE TAC 54(6), Eq. 38-39): ``2n`` points :math:`\pm\sqrt n\,e_i`, weights ``1/(2n)``."""

    name = "cubature3"
    degree = 3

    @lru_cache(maxsize=None)
    def unit_points(self, n: int) -> UnitPoints:
        r"""``2n`` points :math:`+\sqrt n\,e_i` then :math:`-\sqrt n\,e_i`, weights ``1/(2n)`` (mean and covariance)."""
        n = check_positive_int(n, "n")
        eye = np.eye(n) * math.sqrt(n)
        return _frozen(np.vstack([eye, -eye]), np.full(2 * n, 0.5 / n))


@dataclass(frozen=True)
class FifthDegreeCubature(SigmaPointRule):
    r"""Fifth-degree spherical-radial cubature rule (Jia, Xin & Cheng 2013,
    Automatica 49, 510-518), ``2n^2 + 1`` points:

    ========================================  ===========  ==========================
    point                                       count        weight
    ========================================  ===========  ==========================
    0                                           1            2/(n+2)
    :math:`\pm\sqrt{n+2}\,e_i`                  2n           (4-n)/(2(n+2)^2)
    :math:`\pm\sqrt{n+2}\,s^\pm_{jl}`           2n(n-1)      1/(n+2)^2
    ========================================  ===========  ==========================

    with :math:`s^\pm_{jl} = (e_j \pm e_l)/\sqrt 2`, ``j < l``.  Zhu et al. 2016
    print the last weight as 2/(n+2)^2 (their Eq. 13); that value makes the
    weights sum to 1 + 2n(n-1)/(n+2)^2 and is a misprint (their deviation Z-1).
    """

    name = "cubature5"
    degree = 5

    @lru_cache(maxsize=None)
    def unit_points(self, n: int) -> UnitPoints:
        """The ``2n^2 + 1`` points and weights of the table in the class docstring (mean weights = covariance
        weights), in the order: centre, axis pairs, then the pairs of each ``j < l``."""
        n = check_positive_int(n, "n")
        r = math.sqrt(n + 2.0)
        eye = np.eye(n)
        pts = [np.zeros(n)]
        wts = [2.0 / (n + 2)]
        for i in range(n):
            pts += [r * eye[i], -r * eye[i]]
            wts += [(4.0 - n) / (2.0 * (n + 2) ** 2)] * 2
        for j, l in combinations(range(n), 2):
            for s in ((eye[j] + eye[l]), (eye[j] - eye[l])):
                s = s / math.sqrt(2.0)
                pts += [r * s, -r * s]
                wts += [1.0 / (n + 2) ** 2] * 2
        return _frozen(np.array(pts), np.array(wts))


def regular_simplex(n: int) -> np.ndarray:
    r"""Vertices :math:`a_1..a_{n+1}` of a regular n-simplex on the unit sphere, (n+1, n): row
    ``j - 1`` is :math:`a_j`, ``n >= 1``.

    The closed form of Wang, Feng & Tse 2014 (IEEE SPL 21(1):43-46, the simplex of the spherical
    simplex-radial rule), :math:`a_j = [a_{j,1}, \dots, a_{j,n}]^T`:

    .. math::
        a_{j,i} = \begin{cases}
            -\sqrt{\dfrac{n+1}{n\,(n-i+2)(n-i+1)}}, & i < j,\\[4pt]
            \sqrt{\dfrac{(n+1)(n-j+1)}{n\,(n-j+2)}}, & i = j,\\[4pt]
            0, & i > j,
        \end{cases}
        \qquad j = 1, \dots, n+1,\quad i = 1, \dots, n,

    so :math:`a_1 = e_1` and the vertex matrix is lower triangular apart from its last row.  Every
    entry is one correctly rounded quotient of integers and one square root, so the vertices are
    reproducible to the last bit on any IEEE platform (an earlier QR-based construction depended on
    LAPACK's sign convention and gave :math:`-a_j`).  Properties (tested): unit norm,
    :math:`a_i^T a_j = -1/n` for ``i != j``, :math:`\sum_j a_j = 0` and
    :math:`\sum_j a_j a_j^T = (n+1)/n\, I`.
    """
    n = check_positive_int(n, "n")
    i = np.arange(1, n + 1, dtype=float)              # coordinate index, columns
    j = np.arange(1, n + 2, dtype=float)[:, None]     # vertex index, rows
    below = -np.sqrt((n + 1) / (n * (n - i + 2) * (n - i + 1)))
    diagonal = np.sqrt((n + 1) * (n - i + 1) / (n * (n - i + 2)))
    return np.where(i < j, below, np.where(i == j, diagonal, 0.0))


@dataclass(frozen=True)
class SphericalSimplexRadial(SigmaPointRule):
    r"""Third-degree spherical simplex-radial rule (Wang, Feng & Tse 2014, IEEE
    SPL 21(1); Liu & Wu 2017, Eq. 12): ``2n + 2`` points :math:`\pm\sqrt n\,a_j`
    with :math:`a_j` the vertices of the regular simplex of :func:`regular_simplex`, equal weights
    ``1/(2n+2)``; the points are ordered :math:`+\sqrt n\,a_1, \dots, +\sqrt n\,a_{n+1},
    -\sqrt n\,a_1, \dots, -\sqrt n\,a_{n+1}`."""

    name = "ssr3"
    degree = 3

    @lru_cache(maxsize=None)
    def unit_points(self, n: int) -> UnitPoints:
        r"""``2n + 2`` points :math:`\pm\sqrt n\,a_j` in the order of the class docstring, weights ``1/(2n+2)``."""
        n = check_positive_int(n, "n")
        a = regular_simplex(n) * math.sqrt(n)
        return _frozen(np.vstack([a, -a]), np.full(2 * n + 2, 1.0 / (2 * n + 2)))


@dataclass(frozen=True)
class CentralDifference(SigmaPointRule):
    r"""Second-order Stirling interpolation (central difference / DD2 filter,
    Nørgaard, Poulsen & Ravn 2000, Automatica 36, Sec. 4; Hu et al. 2017, Eqs. 1-14).

    Points :math:`x,\ x \pm h s_j` (``s_j`` the columns of ``S``); with
    :math:`Y_0, Y_j^\pm` the transformed points:

    * mean  :math:`\bar y = \frac{h^2-n}{h^2} Y_0 + \frac{1}{2h^2}\sum_j (Y_j^+ + Y_j^-)`
    * :math:`P_{yy} = \sum_j a_j a_j^T + b_j b_j^T`, with
      :math:`a_j = (Y_j^+ - Y_j^-)/(2h)` and
      :math:`b_j = \frac{\sqrt{h^2-1}}{2h^2}(Y_j^+ + Y_j^- - 2Y_0)`
    * :math:`P_{xy} = \sum_j s_j a_j^T` (first-order term only).

    ``h = sqrt(3)`` is optimal for Gaussian priors (kurtosis 3).  Exact for
    linear maps (then ``b_j = 0``, ``a_j = F s_j``).

    ``form="weighted"`` is the form Hu et al. 2017 print (Eqs. 1-11): the same points
    and mean weights, but covariances as weighted outer products of deviations with
    the *mean* weights, :math:`\sum_l w_l (Y_l - \bar y)(Y_l - \bar y)^T`.  That is
    exactly the scaled unscented rule with alpha = 1, beta = 0, kappa = h^2 - n (tested);
    the two forms agree on linear maps and differ in the second-order terms.

    ``h``: the half-step in standard deviations (dimensionless), a finite real number > 1 (any real
    type, e.g. ``np.float32``; stored as a float); ``form``: ``"stirling"`` or ``"weighted"``.
    """

    h: float = math.sqrt(3.0)
    form: str = "stirling"
    name = "central_difference"
    degree = 3

    def __post_init__(self):
        h = check_scalar(self.h, "h")
        if not h > 1.0:
            raise ValueError(f"h: half-step must be > 1 (the second-order weight is sqrt(h^2 - 1)), got {h!r}")
        object.__setattr__(self, "h", h)
        if not isinstance(self.form, str) or self.form not in ("stirling", "weighted"):
            raise ValueError(f"form: expected 'stirling' (Norgaard et al. 2000) or 'weighted' (Hu et al. 2017), "
                             f"got {self.form!r}")

    @lru_cache(maxsize=None)
    def unit_points(self, n: int) -> UnitPoints:
        """``2n + 1`` points 0, ``+h e_j``, ``-h e_j`` (in that order), mean weights ``(h^2 - n)/h^2`` and
        ``1/(2h^2)``; covariance weights = mean weights (``form="weighted"``) or NaN (Stirling, unused)."""
        n = check_positive_int(n, "n")
        h2 = self.h ** 2
        eye = np.eye(n) * self.h
        xi = np.vstack([np.zeros((1, n)), eye, -eye])
        wm = np.full(2 * n + 1, 0.5 / h2)
        wm[0] = (h2 - n) / h2
        # Stirling form: wc unused (see covariances); weighted form: wc = wm (Hu et al. Eqs. 7, 10, 11)
        return _frozen(xi, wm, wm.copy() if self.form == "weighted" else np.full(2 * n + 1, np.nan))

    @property
    def weighted_moments(self) -> bool:
        """True for ``form="weighted"`` (covariances are weighted outer products, the fused operations of
        :mod:`mmlib.core.linalg` apply); False for the Stirling form, whose covariances :meth:`covariances`
        computes itself."""
        return self.form == "weighted"

    def covariance(self, dx: np.ndarray, dy: np.ndarray, add: np.ndarray | None = None) -> np.ndarray:
        r"""Only :math:`P_{yy}` + ``add`` (..., d, d) of :meth:`covariances` (prediction step, ``add`` e.g. Q);
        ``dx`` (..., 2n+1, n), ``dy`` (..., 2n+1, d) deviations of the points and of their images."""
        if self.form == "weighted":
            return SigmaPointRule.covariance(self, dx, dy, add)
        return self.covariances(dx, dy, add)[0]

    def covariances(self, dx: np.ndarray, dy: np.ndarray,
                    add: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        r"""``(P_yy + add, P_xy)`` ((..., d, d), (..., n, d)) from the deviations ``dx`` (..., 2n+1, n) of the
        points :math:`x, x + h s_j, x - h s_j` (in that order) and ``dy`` (..., 2n+1, d) of their images.
        Stirling form (Nørgaard et al. 2000; Hu et al. 2017, Eqs. 1-14):
        :math:`P_{yy} = \sum_j a_j a_j^T + b_j b_j^T` with :math:`a_j = (Y_j^+ - Y_j^-)/(2h)`,
        :math:`b_j = \frac{\sqrt{h^2-1}}{2h^2}(Y_j^+ + Y_j^- - 2Y_0)`, and :math:`P_{xy} = \sum_j s_j a_j^T`
        (differences of images, so the centre of ``dy`` does not matter); ``form="weighted"``: the weighted
        outer products of :meth:`SigmaPointRule.covariances`.  ``add`` broadcasts against (..., d, d)."""
        if self.form == "weighted":
            return SigmaPointRule.covariances(self, dx, dy, add)
        n = dx.shape[-1]
        h = self.h
        d0 = dy[..., :1, :]
        dp, dm = dy[..., 1:n + 1, :], dy[..., n + 1:, :]
        a = (dp - dm) / (2.0 * h)                                   # (B, n, d)
        b = (dp + dm - 2.0 * d0) * (math.sqrt(h * h - 1.0) / (2.0 * h * h))
        at = np.swapaxes(a, -1, -2)
        pyy = at @ a + np.swapaxes(b, -1, -2) @ b
        s = dx[..., 1:n + 1, :] / h                                   # rows are s_j^T
        pxy = np.swapaxes(s, -1, -2) @ a
        return (pyy if add is None else pyy + add), pxy


_RULES = {
    "ukf": Unscented, "unscented": Unscented,
    "ckf": Cubature, "cubature3": Cubature,
    "5ckf": FifthDegreeCubature, "cubature5": FifthDegreeCubature,
    "ssrckf": SphericalSimplexRadial, "ssr3": SphericalSimplexRadial,
    "cdkf": CentralDifference, "central_difference": CentralDifference,
}


def rule_by_name(name: str, **params: float | str) -> SigmaPointRule:
    """Look up a rule by its short name (``ukf``, ``ckf``, ``5ckf``, ``ssrckf``, ``cdkf``, any case);
    ``params`` are the rule's own parameters (e.g. ``alpha``, ``beta``, ``kappa`` for ``ukf``, ``h`` and
    ``form`` for ``cdkf``); an unknown parameter is a ValueError naming it.  Parameters left out take the
    class's defaults: ``rule_by_name("ukf")`` is ``Unscented()``, i.e. ``alpha=1, beta=2, kappa=0``
    (:class:`Unscented`; not the cubature rule), ``rule_by_name("cdkf")`` is ``CentralDifference()``
    (``h = sqrt(3)``, Stirling form)."""
    if not isinstance(name, str):
        raise ValueError(f"name: expected a rule name (a string), got {type(name).__name__}")
    key = name.lower()
    if key not in _RULES:
        raise ValueError(f"name: unknown quadrature rule {name!r}; expected one of {sorted(_RULES)}")
    cls = _RULES[key]
    allowed = sorted(f.name for f in fields(cls))
    unknown = sorted(set(params) - set(allowed))
    if unknown:
        raise ValueError(f"{unknown[0]}: not a parameter of {cls.__name__} (rule {name!r}); "
                         f"its parameters: {', '.join(allowed) or 'none'}")
    return cls(**params)
