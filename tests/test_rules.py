"""Each quadrature rule integrates every monomial up to its degree exactly against N(0, I)."""
import dataclasses
import itertools
import math

import numpy as np
import pytest

from mmlib.core import rules

RULES = [rules.Unscented(), rules.Unscented(alpha=0.5, beta=2.0, kappa=1.0), rules.Cubature(),
         rules.FifthDegreeCubature(), rules.SphericalSimplexRadial(), rules.CentralDifference(),
         rules.CentralDifference(form="weighted")]


def gaussian_moment(alpha):
    """E[prod x_i^a_i] for x ~ N(0, I): product of (a-1)!! for even a, 0 if any a is odd."""
    out = 1.0
    for a in alpha:
        if a % 2:
            return 0.0
        out *= math.prod(range(a - 1, 0, -2))
    return out


def monomials(n, degree):
    for total in range(degree + 1):
        for combo in itertools.combinations_with_replacement(range(n), total):
            alpha = [0] * n
            for i in combo:
                alpha[i] += 1
            yield tuple(alpha)


@pytest.mark.parametrize("rule", RULES, ids=lambda r: repr(r))
@pytest.mark.parametrize("n", [1, 2, 3, 4, 6])
def test_exact_for_monomials_up_to_degree(rule, n):
    if isinstance(rule, rules.Unscented) and n + rule.alpha ** 2 * (n + rule.kappa) - n <= 0:
        pytest.skip("invalid scaling")
    up = rule.unit_points(n)
    for alpha in monomials(n, rule.degree):
        values = np.prod(up.xi ** np.array(alpha), axis=1)
        # tolerance: floating-point scale of the largest term of the sum
        scale = np.sum(np.abs(up.wm * values)) + 1.0
        assert abs(up.wm @ values - gaussian_moment(alpha)) <= 1e-13 * scale, (alpha, up.wm @ values)


@pytest.mark.parametrize("rule", [rules.Cubature(), rules.SphericalSimplexRadial(), rules.Unscented()],
                         ids=lambda r: repr(r))
def test_third_degree_rules_are_not_fifth_degree(rule):
    # sanity: the exactness test can fail -- E[x1^4] = 3 is missed by degree-3 rules for n = 4
    up = rule.unit_points(4)
    assert abs(up.wm @ up.xi[:, 0] ** 4 - 3.0) > 1e-3


def test_fifth_degree_weights_jia_2013():
    n = 4
    up = rules.FifthDegreeCubature().unit_points(n)
    assert up.xi.shape == (2 * n * n + 1, n)
    assert up.wm[0] == pytest.approx(2 / (n + 2), abs=1e-15)
    # the misprinted 2/(n+2)^2 of Zhu et al. Eq. 13 would not sum to one
    assert up.wm.sum() == pytest.approx(1.0, abs=1e-14)
    assert np.isclose(up.wm[-1], 1 / (n + 2) ** 2)
    wrong = up.wm.copy()
    wrong[2 * n + 1:] = 2 / (n + 2) ** 2
    assert abs(wrong.sum() - 1.0) > 0.5


@pytest.mark.parametrize("n", [1, 2, 3, 4, 6, 9])
def test_regular_simplex(n):
    a = rules.regular_simplex(n)
    assert a.shape == (n + 1, n)
    np.testing.assert_allclose(np.linalg.norm(a, axis=1), 1.0, atol=1e-14)
    gram = a @ a.T
    off = gram[~np.eye(n + 1, dtype=bool)]
    np.testing.assert_allclose(off, -1.0 / n, atol=1e-14)
    np.testing.assert_allclose(a.sum(axis=0), 0.0, atol=1e-14)
    np.testing.assert_allclose(a.T @ a, (n + 1) / n * np.eye(n), atol=1e-14)


def wang_feng_tse_simplex(n):
    """Closed form of Wang, Feng & Tse 2014 (IEEE SPL 21(1)), entry by entry in exact integer arithmetic
    up to one rounded quotient and one square root: a_{j,i} = -sqrt((n+1)/(n(n-i+2)(n-i+1))) for i < j,
    sqrt((n+1)(n-j+1)/(n(n-j+2))) for i = j, 0 for i > j (j = 1..n+1 vertices, i = 1..n coordinates)."""
    a = np.zeros((n + 1, n))
    for j in range(1, n + 2):
        for i in range(1, n + 1):
            if i < j:
                a[j - 1, i - 1] = -math.sqrt((n + 1) / (n * (n - i + 2) * (n - i + 1)))
            elif i == j:
                a[j - 1, i - 1] = math.sqrt((n + 1) * (n - j + 1) / (n * (n - j + 2)))
    return a


@pytest.mark.parametrize("n", [1, 2, 3, 4, 6, 8, 9])
def test_regular_simplex_is_the_closed_form_of_wang_feng_tse(n):
    """Pinned orientation (issue 11, section 6): the QR construction gave the negated simplex.  Every
    entry lies in [-1, 1] and is one correctly rounded quotient and one square root, so 2 ulps of 1
    (4.4e-16) bound any difference between two evaluations of the formula."""
    atol = 2 * np.finfo(float).eps
    a = rules.regular_simplex(n)
    ref = wang_feng_tse_simplex(n)
    np.testing.assert_allclose(a, ref, rtol=0, atol=atol)
    np.testing.assert_array_equal(a[0], np.eye(n)[0])                      # a_1 = e_1
    assert np.all(a[np.triu_indices(n + 1, 1, n)] == 0.0)                    # a_{j,i} = 0 for i > j
    # the properties of a regular simplex on the unit sphere, at floating-point scale (n terms of size <= 1)
    tol = 4 * n * np.finfo(float).eps
    np.testing.assert_allclose(np.linalg.norm(a, axis=1), 1.0, rtol=0, atol=tol)
    gram = a @ a.T
    np.testing.assert_allclose(gram[~np.eye(n + 1, dtype=bool)], -1.0 / n, rtol=0, atol=tol)
    np.testing.assert_allclose(a.sum(axis=0), 0.0, rtol=0, atol=tol)
    # the SSR rule's points are +sqrt(n) a_j then -sqrt(n) a_j, in vertex order
    up = rules.SphericalSimplexRadial().unit_points(n)
    np.testing.assert_allclose(up.xi, np.vstack([ref, -ref]) * math.sqrt(n), rtol=0, atol=atol * math.sqrt(n))
    np.testing.assert_array_equal(up.wm, np.full(2 * n + 2, 1.0 / (2 * n + 2)))


@pytest.mark.parametrize("rule", RULES, ids=lambda r: repr(r))
def test_linear_map_moments_are_exact(rule):
    """Mean, covariance and cross-covariance of y = A x + b, x ~ N(m, P), are exact."""
    rng = np.random.default_rng(3)
    n, d, B = 4, 3, 5
    A = rng.standard_normal((d, n))
    b = rng.standard_normal(d)
    m = rng.standard_normal((B, n))
    L = np.tril(rng.standard_normal((B, n, n))) + 3 * np.eye(n)
    P = L @ np.swapaxes(L, -1, -2)
    X = rule.points(m, np.linalg.cholesky(P))
    Y = X @ A.T + b
    ybar = rule.unit_points(n).wm @ Y
    pyy, pxy = rule.covariances(X - m[:, None], Y - ybar[:, None])
    np.testing.assert_allclose(ybar, m @ A.T + b, rtol=0, atol=1e-12)
    np.testing.assert_allclose(pyy, A @ P @ A.T, rtol=0, atol=1e-10)
    np.testing.assert_allclose(pxy, P @ A.T, rtol=0, atol=1e-10)
    np.testing.assert_allclose(rule.covariance(X - m[:, None], Y - ybar[:, None]), pyy, rtol=0, atol=1e-12)


def test_central_difference_second_order_term():
    """For y = x^2 (n = 1, x ~ N(m, s^2)): the CD mean m^2 + s^2 is exact and the
    variance is 4 m^2 s^2 + (h^2 - 1) s^4, which equals the true 4 m^2 s^2 + 2 s^4 at h^2 = 3."""
    rule = rules.CentralDifference()
    m, s = np.array([[1.5]]), np.array([[[0.7]]])
    X = rule.points(m, s)
    Y = X ** 2
    ybar = rule.unit_points(1).wm @ Y
    pyy, _ = rule.covariances(X - m[:, None], Y - ybar[:, None])
    assert ybar[0, 0] == pytest.approx(1.5 ** 2 + 0.49, abs=1e-14)
    assert pyy[0, 0, 0] == pytest.approx(4 * 1.5 ** 2 * 0.49 + 2 * 0.49 ** 2, abs=1e-13)


def test_rule_lookup_and_bad_parameters():
    assert isinstance(rules.rule_by_name("5CKF"), rules.FifthDegreeCubature)
    with pytest.raises(ValueError, match="name"):
        rules.rule_by_name("gauss-hermite")
    with pytest.raises(ValueError, match="alpha"):
        rules.Unscented(alpha=0.0)
    with pytest.raises(ValueError, match="h"):
        rules.CentralDifference(h=1.0)
    with pytest.raises(ValueError, match="kappa"):
        rules.Unscented(kappa=-5.0).unit_points(2)


def _transform(rule, mean, chol, g):
    """Mean (B, d) and covariance (B, d, d) of g(x), x ~ N(mean, chol chol^T), by ``rule``."""
    X = rule.points(mean, chol)
    Y = g(X)
    up = rule.unit_points(mean.shape[-1])
    ybar = np.einsum("p,...pd->...d", up.wm, Y)
    return ybar, rule.covariance(X - mean[..., None, :], Y - ybar[..., None, :])


def test_unscented_defaults_are_stated_in_the_first_docstring_line():
    # the defaults are read from the dataclass, so changing them without the docstring fails here
    first = rules.Unscented.__doc__.strip().splitlines()[0]
    defaults = {f.name: f.default for f in dataclasses.fields(rules.Unscented)}
    assert set(defaults) == {"alpha", "beta", "kappa"}
    for name, value in defaults.items():
        assert f"{name}={value:g}" in first, (name, value, first)


def test_default_unscented_is_not_the_cubature_rule():
    # scalar x ~ N(m, s^2): Var[x^2] = 4 m^2 s^2 + 2 s^4 (Gaussian fourth moment).  The default beta = 2 puts
    # the centre covariance weight 2 there and gets it exactly; the cubature rule (two points m +- s) misses the
    # 2 s^4 term entirely, and so does the former default (alpha, beta, kappa) = (1, 0, 0).
    m, s = 1.5, 0.7
    mean, chol = np.array([[m]]), np.array([[[s]]])
    exact = 4 * m * m * s * s + 2 * s ** 4
    got = {name: _transform(rule, mean, chol, lambda x: x ** 2)
           for name, rule in (("ukf", rules.Unscented()), ("ckf", rules.Cubature()),
                              ("former", rules.Unscented(1.0, 0.0, 0.0)))}
    for name, (ybar, _) in got.items():             # E[x^2] = m^2 + s^2: degree 2, every rule exact
        assert ybar[0, 0] == pytest.approx(m * m + s * s, rel=1e-14), name
    # tolerance: a few roundings of numbers of size 4 m^2 s^2 ~ 4.4
    assert got["ukf"][1][0, 0, 0] == pytest.approx(exact, rel=1e-13)
    assert got["ckf"][1][0, 0, 0] == pytest.approx(exact - 2 * s ** 4, rel=1e-13)
    assert got["former"][1][0, 0, 0] == pytest.approx(got["ckf"][1][0, 0, 0], rel=1e-13)


@pytest.mark.parametrize("n", [2, 4, 5])
def test_default_unscented_differs_from_cubature_by_the_centre_term(n):
    # the documented relation: same means, P_yy differs by 2 (Y_0 - ybar)(Y_0 - ybar)^T, which is not zero on a
    # curved map (range from the origin) and is zero on a linear one
    rng = np.random.default_rng(n)
    mean = rng.normal(size=(3, n)) * 10.0
    a = rng.normal(size=(3, n, n))
    chol = np.linalg.cholesky(a @ np.swapaxes(a, -1, -2) + np.eye(n))
    ukf, ckf = rules.Unscented(), rules.Cubature()

    def rng_(x):
        return np.linalg.norm(x[..., :2], axis=-1, keepdims=True)
    (mu, pu), (mc, pc) = _transform(ukf, mean, chol, rng_), _transform(ckf, mean, chol, rng_)
    np.testing.assert_allclose(mu, mc, rtol=1e-13)
    y0 = rng_(mean) - mu                                          # (B, 1): image of the mean minus mean of images
    assert np.all(np.abs(y0) > 1e-6)                              # curved: the centre term is not zero
    # tolerance: P_yy's entries are ~ (10 * spread)^2; the difference is formed from sums of such entries
    np.testing.assert_allclose(pu - pc, 2.0 * y0[..., None] * y0[..., None, :], rtol=1e-9,
                               atol=1e-12 * np.abs(pu).max())
    H = rng.normal(size=(2, n))
    qu = _transform(ukf, mean, chol, lambda x: x @ H.T)[1]
    qc = _transform(ckf, mean, chol, lambda x: x @ H.T)[1]
    np.testing.assert_allclose(qu, qc, rtol=1e-12, atol=1e-12 * np.abs(qu).max())


def test_rule_by_name_ukf_is_the_documented_default():
    assert rules.rule_by_name("ukf") == rules.Unscented() == rules.rule_by_name("UNSCENTED")
    assert rules.rule_by_name("ukf") != rules.Unscented(1.0, 0.0, 0.0)       # not the cubature setting
    assert "Unscented()" in rules.rule_by_name.__doc__
    defaults = {f.name: f.default for f in dataclasses.fields(rules.Unscented)}
    assert all(f"{k}={v:g}" in " ".join(rules.rule_by_name.__doc__.split()) for k, v in defaults.items())
    # a parameter given replaces only that default
    assert rules.rule_by_name("ukf", kappa=-1.0) == rules.Unscented(defaults["alpha"], defaults["beta"], -1.0)
    from mmlib.core.filters import filter_by_name
    assert filter_by_name("ukf").rule == rules.Unscented()
