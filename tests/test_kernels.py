"""The compiled kernels (numba, :mod:`mmlib.core._kernels`) against the numpy reference path (issue 12).

Both paths implement the same mathematics; they sum in different orders (BLAS/LAPACK vs index order), so
they agree to round-off, not bit for bit:

* one kernel call on well-conditioned random operands: a few ulp per term, ``RTOL_ONE_CALL = 1e-13``
  relative to the output's scale (n <= 9 terms per sum, condition numbers <= 1e2 here);
* whole filter runs of every paper: the differences of one step propagate through the recursion, amplified
  by the covariance's condition number (up to ~1e5 in liu2017's scenario), and mode probabilities
  ``mu ~ exp(log L)`` turn a relative round-off of a log-likelihood of magnitude |log L| (up to ~1e3 for an
  unlikely mode) into that much absolute difference: eps * K * cond(P) * |log L| ~ 2.2e-16 * 45 * 1e5 *
  1e3 ~ 1e-6, hence ``RTOL_RUN = 1e-6`` of each field's scale per run; the divergence step and cause of
  every run must be equal.

Failure semantics (which matrices are not positive definite) are the same decision in both paths
(LAPACK's ``potrf`` test); each path gives a run the same bits in any batch and any blocking.
"""
from __future__ import annotations

import functools
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from mmlib.core import linalg
from mmlib.core.estimation import combine_covariances, imm_output, mixing_weights

sys.path.insert(0, str(Path(__file__).parent))
import test_batch_independence as tbi      # noqa: E402  (the cases: every estimator of every paper)

RTOL_ONE_CALL = 1e-13
RTOL_RUN = 1e-6

pytest.importorskip("numba")


def _spd(rng, N, n, cond=10.0):
    A = rng.standard_normal((N, n, n))
    return A @ np.swapaxes(A, -1, -2) + np.eye(n) * (n / cond) + np.eye(n) * 0.1


def _both(fn, *args, **kwargs):
    out = {}
    for k in linalg.KERNELS:
        with linalg.use_kernel(k):
            out[k] = fn(*args, **kwargs)
    return out["numba"], out["numpy"]


def _close(a, b, rtol, label=""):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape, (label, a.shape, b.shape)
    if a.dtype == bool or b.dtype == bool:                  # failure masks: the same decision
        assert np.array_equal(a, b), f"{label}: differs"
        return
    assert np.array_equal(np.isnan(a), np.isnan(b)), f"{label}: NaN in one path only"
    scale = np.nanmax(np.abs(b)) if np.isfinite(b).any() else 1.0
    err = np.nanmax(np.abs(a - b)) if np.isfinite(b).any() else 0.0
    assert err <= rtol * max(scale, 1e-300), f"{label}: max difference {err:.3g} > {rtol:g} x scale {scale:.3g}"


# ---------------------------------------------------------------------------------------------- one kernel at a time
def test_every_kernel_matches_the_numpy_path_on_random_operands():
    rng = np.random.default_rng(7)
    B, r, n, m, M = 37, 3, 4, 2, 9
    P = _spd(rng, B * r, n).reshape(B, r, n, n)
    mean = rng.standard_normal((B, r, n)) * 10.0
    xi = np.vstack([np.zeros((1, n)), 1.7 * np.eye(n), -1.7 * np.eye(n)])
    w = rng.uniform(0.05, 0.2, M)
    for got, ref in zip(*_both(linalg.cholesky, P)):
        _close(got, ref, RTOL_ONE_CALL, "cholesky")
    for got, ref in zip(*_both(linalg.sigma_points, mean, P, xi)):
        _close(got, ref, RTOL_ONE_CALL, "sigma_points")
    Y = rng.standard_normal((B, r, M, n))
    _close(*_both(linalg.weighted_mean, Y, w), RTOL_ONE_CALL, "weighted_mean")
    dz = rng.standard_normal((B, r, M, m))
    R = np.diag([2.0, 0.5])
    for got, ref in zip(*_both(linalg.weighted_covariances, dz, w, Y, R)):
        _close(got, ref, RTOL_ONE_CALL, "weighted_covariances")
    got, ref = _both(linalg.weighted_covariances, Y, w, None, P)
    _close(got[0], ref[0], RTOL_ONE_CALL, "weighted_covariances (no cross term)")
    assert got[1] is None and ref[1] is None
    S = _spd(rng, B * r, m).reshape(B, r, m, m)
    Pxz = rng.standard_normal((B, r, n, m)) * 0.3
    nu = rng.standard_normal((B, r, m))
    for got, ref in zip(*_both(linalg.kalman_moments, mean, P, nu, S, Pxz)):
        _close(got, ref, RTOL_ONE_CALL, "kalman_moments")
    H = rng.standard_normal((B, r, m, n)) * 0.2
    for got, ref in zip(*_both(linalg.kalman_moments, mean, P, nu, S, Pxz, H, R)):
        _close(got, ref, RTOL_ONE_CALL, "kalman_moments (Joseph)")
    for got, ref in zip(*_both(linalg.congruence, H, P, R)):
        _close(got, ref, RTOL_ONE_CALL, "congruence")
    wt = rng.dirichlet(np.ones(r), size=(B, r))
    for got, ref in zip(*_both(combine_covariances, wt, mean, P, rng.standard_normal((B, r, n)))):
        _close(got, ref, RTOL_ONE_CALL, "combine_covariances")
    mu = rng.dirichlet(np.ones(r), size=B)
    T = np.array([[0.9, 0.05, 0.05], [0.1, 0.8, 0.1], [0.0, 0.3, 0.7]])
    loglik = rng.normal(-5.0, 3.0, (B, r))
    c, _ = mixing_weights(mu, T)
    for got, ref in zip(*_both(imm_output, loglik, c, mean, P, nu, S, True)):
        _close(got, ref, RTOL_ONE_CALL, "imm_output")
    # NIS and NEES: positive definite, indefinite (a broken filter's covariance: its value, in both paths),
    # singular and not finite (NaN in both), and a vector broadcast against a stack of matrices
    _close(*_both(linalg.normalised_square, nu, S), RTOL_ONE_CALL, "normalised_square (NIS)")
    _close(*_both(linalg.normalised_square, mean, P), RTOL_ONE_CALL, "normalised_square (NEES)")
    odd = P.copy()
    odd[0, 0] = np.diag([1.0, -2.0, 3.0, 0.5])                 # indefinite
    odd[0, 1] = np.outer(np.ones(n), np.ones(n))               # singular (rank one): an exactly zero pivot
    odd[1, 2, 0, 0] = np.nan
    vec = mean.copy()
    vec[0, 0] = [0.0, 1.0, 0.0, 0.0]                           # along the negative eigenvalue: v^T S^-1 v = -0.5
    got, ref = _both(linalg.normalised_square, vec, odd)
    _close(got, ref, RTOL_ONE_CALL, "normalised_square (odd matrices)")
    assert got[0, 0] == -0.5 and np.isnan(got[0, 1]) and np.isnan(got[1, 2]) and np.isfinite(got[2:]).all()
    _close(*_both(linalg.normalised_square, mean[0, 0], P), RTOL_ONE_CALL, "normalised_square (broadcast)")
    # information fusion of three members per run and mode (the bootstrap layer's Eqs. 22-24), and its failures:
    # a member not finite (NaN in both), a total information that is not positive definite (cov in both, mean NaN)
    members = np.stack([P, P * 2.0, P + 0.5 * np.eye(n)]), np.stack([mean, mean + 1.0, mean * 0.5])
    for got, ref, what in zip(*_both(linalg.information_fusion, members[1], members[0]), ("mean", "cov", "ok")):
        _close(got, ref, RTOL_ONE_CALL, f"information_fusion {what}")
    covs = members[0].copy()
    covs[1, 0, 0, 1, 1] = np.nan
    covs[:, 0, 1] = np.diag([1.0, -2.0, 3.0, 0.5])            # every member indefinite: so is the total
    got, ref = _both(linalg.information_fusion, members[1], covs)
    for g, r_, what in zip(got, ref, ("mean", "cov", "ok")):
        _close(g, r_, RTOL_ONE_CALL, f"information_fusion {what} (odd matrices)")
    assert not got[2][0, 0] and not got[2][0, 1] and got[2][1:].all() and np.isfinite(got[1][0, 1]).all()
    assert np.isnan(got[0][0, :2]).all() and np.isnan(got[1][0, 0]).all()
    # solve: well-conditioned, a stack of right-hand sides broadcast against the matrices, singular and NaN (NaN in
    # both), an indefinite nonsingular matrix (solved in both)
    rhs = rng.standard_normal((B, r, n, 3))
    _close(*_both(linalg.solve, P, rhs), RTOL_ONE_CALL, "solve")
    _close(*_both(linalg.solve, P, rhs[0, 0]), RTOL_ONE_CALL, "solve (broadcast)")
    got, ref = _both(linalg.solve, odd, rhs)
    _close(got, ref, RTOL_ONE_CALL, "solve (odd matrices)")
    assert np.isnan(got[0, 1]).all() and np.isnan(got[1, 2]).all() and np.isfinite(got[0, 0]).all()
    assert np.isfinite(np.delete(got.reshape(B * r, n, 3), [1, r + 2], axis=0)).all()
    # the leading axes of the members broadcast (one covariance per member shared by every run), in both paths; other
    # members or leading axes are a ValueError naming the argument, never a read out of bounds
    shared = np.stack([P[0, 0], 2.0 * P[0, 0]])
    for got, ref, what in zip(*_both(linalg.information_fusion, members[1][:2], shared), ("mean", "cov", "ok")):
        _close(got, ref, RTOL_ONE_CALL, f"information_fusion {what} (shared covariances)")
        assert got.shape[:2] == (B, r)
    for kernel in linalg.KERNELS:
        with linalg.use_kernel(kernel):
            with pytest.raises(ValueError, match="^covs: "):
                linalg.information_fusion(members[1], members[0][:2])
            with pytest.raises(ValueError, match="^covs: "):
                linalg.information_fusion(members[1], np.swapaxes(members[0], 1, 2))
    # the strong-tracking fading factor (Jacobian-free form): S large enough for tr M > 0 (M = S - R - X^T Q X), V
    # scaled so that some factors exceed 1 and others are 1; a prior without a Cholesky factor gives 1 in both paths
    Qs = _spd(rng, 1, n)[0] * 0.1
    X = np.linalg.solve(P, Pxz)
    S_st = R + 2.0 * np.swapaxes(Pxz, -1, -2) @ X + np.eye(m)
    V = _spd(rng, B * r, m).reshape(B, r, m, m) * rng.uniform(0.1, 20.0, (B, r, 1, 1))
    got, ref = _both(linalg.fading_factor, P, Qs, Pxz, V, S_st, R, 4.5)
    _close(got, ref, RTOL_ONE_CALL, "fading_factor")
    assert (got > 1.0).any() and (got == 1.0).any() and not (got < 1.0).any()
    # tr M < 0 with tr N < 0 (a ratio above 1 that is not a fading factor), and tr M = 0 exactly with tr N = 7 > 0
    # (Q = 0, S = R = I, V = 8 I: M = (1 - 8) + 3.5 + 3.5 = 0 in floating point; without the guard, +inf): 1 in both
    neg = _both(linalg.fading_factor, P, Qs, Pxz, 0.1 * np.eye(m), 0.5 * R, R, 4.5)
    zero = _both(linalg.fading_factor, P, np.zeros((n, n)), Pxz, 8.0 * np.eye(m), np.eye(m), np.eye(m), 4.5)
    for got, ref in (neg, zero):
        assert (got == 1.0).all() and (ref == 1.0).all()
    # a process noise or measurement noise batched beyond the other operands broadcasts in both paths
    Q_runs = Qs * rng.uniform(0.5, 2.0, (B, r, 1, 1))
    for args in ((P[0, 0], Q_runs, Pxz[0, 0], V[0, 0], S_st[0, 0], R), (P[0, 0], Qs, Pxz[0, 0], V[0, 0], S_st[0, 0],
                                                                         R * rng.uniform(0.5, 2.0, (B, r, 1, 1)))):
        got, ref = _both(linalg.fading_factor, *args, 4.5)
        _close(got, ref, RTOL_ONE_CALL, "fading_factor (a batched Q or R)")
        assert got.shape == (B, r)
    got, ref = _both(linalg.fading_factor, odd, Qs, Pxz, V, S_st, R, 4.5)
    _close(got, ref, RTOL_ONE_CALL, "fading_factor (odd matrices)")
    assert got[0, 0] == 1.0 and got[0, 1] == 1.0 and got[1, 2] == 1.0     # indefinite, singular, NaN: no factor
    # a kernel operand with a divisor of the runs' rows is periodic (linalg._SHAPES): row b % rows
    from mmlib.core import _kernels
    flat_P, flat_rhs = P.reshape(-1, n, n), rhs.reshape(-1, n, 3)
    assert _kernels.solve(flat_P[:1], flat_rhs).tobytes() == _kernels.solve(
        np.repeat(flat_P[:1], B * r, axis=0), flat_rhs).tobytes()
    with linalg.use_kernel("numba"):                            # an exactly singular member: NaN, not an exception
        sing = members[0].copy()
        sing[2, 2, 0] = np.outer(np.ones(n), np.ones(n))
        m_, c_, ok_ = linalg.information_fusion(members[1], sing)
        assert not ok_[2, 0] and np.isnan(m_[2, 0]).all() and np.isnan(c_[2, 0]).all() and ok_.sum() == ok_.size - 1


def test_fused_steps_agree_across_kernels():
    """The fused operations (linear time updates, sigma-point measurement moments, IMM interaction and output)
    as the filters and the IMM call them: the compiled twins within round-off of the numpy bodies."""
    from mmlib import IMM, SigmaPointFilter, Unscented
    from mmlib.core import models
    from mmlib.core.filters import GaussianState
    rng = np.random.default_rng(3)
    B, n = 23, 4
    dyn = [models.constant_velocity(1.0, 1.0), models.coordinated_turn(1.0, 0.05, 1.0)]
    radar = models.RangeBearing(np.diag([100.0, 1e-4]))
    imm = IMM(SigmaPointFilter(Unscented(1.0, 2.0, 0.0)), dyn, radar, np.array([[0.9, 0.1], [0.2, 0.8]]))
    assert imm.filter.rule.weighted_moments and imm.stacked.is_linear      # the fused operations apply
    P = _spd(rng, B * 2, n, cond=5.0).reshape(B, 2, n, n) * 100.0
    state = GaussianState(rng.standard_normal((B, 2, n)) * 100.0 + np.array([2e4, 10.0, 1e4, 5.0]), P)
    got, ref = _both(imm.filter.predict, state, imm.stacked)
    _close(got.mean, ref.mean, RTOL_ONE_CALL, "predict mean")
    _close(got.cov, ref.cov, RTOL_ONE_CALL, "predict cov")
    from mmlib import ExtendedKalmanFilter
    got, ref = _both(ExtendedKalmanFilter().predict, state, imm.stacked)
    _close(got.mean, ref.mean, RTOL_ONE_CALL, "EKF predict mean")
    _close(got.cov, ref.cov, RTOL_ONE_CALL, "EKF predict cov")
    got, ref = _both(imm.filter.predict_measurement, state, radar)
    for g, r_, f in zip(got, ref, got._fields):
        if g is not None:
            _close(g, r_, RTOL_ONE_CALL, f"predict_measurement {f}")
    mu = rng.dirichlet(np.ones(2), size=B)
    st = imm.init(state.mean[:, 0], P[:, 0], mode_probabilities=mu)
    st = st._replace(modes=state)
    z = radar.h(state.mean[:, 0]) + rng.standard_normal((B, 2)) * np.array([10.0, 1e-2])
    (s1, e1), (s2, e2) = _both(imm.step, st, z)
    for f in ("mean", "cov", "mode_probabilities", "loglik", "innovation", "innovation_cov"):
        _close(getattr(e1, f), getattr(e2, f), 1e-12, f"imm.step {f}")


def _bit_differences(pairs) -> list:
    """The labels of the ``(got, expected, label)`` pairs whose arrays differ in shape or in any bit."""
    return [label for got, expected, label in pairs
            if np.shape(got) != np.shape(expected) or np.asarray(got).tobytes() != np.asarray(expected).tobytes()]


def test_fused_numpy_bodies_are_the_generic_composition_bit_for_bit():
    """On the numpy path a fused operation computes what the generic operations and the models compose, to the
    bit: the numpy path gives the numbers it gave when the filters composed them themselves."""
    from mmlib import Unscented
    from mmlib.core import models
    from mmlib.core.estimation import MomentMixing
    rng = np.random.default_rng(11)
    B, r, n = 9, 3, 4
    dyn = [models.constant_velocity(1.0, 1.0), models.coordinated_turn(1.0, 0.05, 1.0),
           models.coordinated_turn(1.0, -0.05, 2.0)]
    stacked = models.StackedDynamics.of(dyn)
    P = _spd(rng, B * r, n, cond=5.0).reshape(B, r, n, n) * 100.0
    mean = rng.standard_normal((B, r, n)) * 100.0 + np.array([2e4, 10.0, -1e4, 5.0])
    up = Unscented(1.0, 2.0, 0.0).unit_points(n)
    pairs = []                                  # (numpy body's result, the generic composition's, label)
    with linalg.use_kernel("numpy"):
        for dynamics, m, c in ((stacked, mean, P), (dyn[1], mean[:, 0], P[:, 0])):    # per mode, and one model
            got = linalg.linear_predict(m, c, dynamics.F, dynamics.Q)
            cov, _ = linalg.congruence(dynamics.jacobian(m), c, dynamics.Q)
            pairs += [(got[0], dynamics.transition(m[..., None, :])[..., 0, :], "linear_predict mean"),
                      (got[1], cov, "linear_predict cov")]
            got = linalg.sigma_point_predict_linear(m, c, up.xi, up.wm, up.wc, dynamics.F, dynamics.Q)
            X, _ = linalg.sigma_points(m, c, up.xi)
            Y = dynamics.transition(X)
            ym = linalg.weighted_mean(Y, up.wm)
            pairs += [(got[0], ym, "sigma_point_predict_linear mean"),
                      (got[1], linalg.weighted_covariances(Y - ym[..., None, :], up.wc, None, dynamics.Q)[0],
                       "sigma_point_predict_linear cov")]
        X, _ = linalg.sigma_points(mean, P, up.xi)
        for meas in (models.RangeBearing(np.diag([100.0, 1e-4]), sensor=(-3e4, 2e3)),
                     models.position_measurement(np.diag([4.0, 9.0]))):
            Z = meas.h(X)
            got = linalg.measurement_moments(X, mean, Z, up.wm, up.wc, meas.angular, meas.R)
            z_pred = meas.average(Z, up.wm)
            S, Pxz = linalg.weighted_covariances(meas.residual(Z, z_pred[..., None, :]), up.wc,
                                                 X - mean[..., None, :], meas.R)
            pairs += [(g, e, f"measurement_moments {meas.name} {f}")
                      for g, e, f in zip(got, (z_pred, S, Pxz), ("z_pred", "S", "Pxz"))]
        mu = rng.dirichlet(np.ones(r), size=B)
        T = np.array([[0.9, 0.05, 0.05], [0.1, 0.8, 0.1], [0.0, 0.3, 0.7]])
        c, w = mixing_weights(mu, T)
        pairs += [(g, e, f"imm_mix {f}")
                  for g, e, f in zip(linalg.imm_mix(mu, T, mean, P), (c,) + MomentMixing()(mean, P, w),
                                     ("c", "means", "covs"))]
    assert len(pairs) == 4 * 2 + 3 * 2 + 3
    assert not _bit_differences(pairs), _bit_differences(pairs)
    # the comparison is bitwise: one ulp in one element of any result is a difference
    for k in range(len(pairs)):
        got, expected, label = pairs[k]
        nudged = np.array(got, dtype=float)
        nudged.flat[0] = np.nextafter(nudged.flat[0], np.inf)
        assert _bit_differences([(nudged, expected, label)]) == [label]


def test_every_operation_has_a_numpy_body_and_a_compiled_twin():
    """Each operation of mmlib.core.linalg with a compiled form is one object holding both implementations,
    the compiled twin declared right after the numpy body."""
    ops = {name: obj for name, obj in vars(linalg).items() if hasattr(obj, "implementations")}
    assert {"cholesky", "matmul_rows", "sigma_points", "weighted_mean", "weighted_covariances", "kalman_moments",
            "combine_covariances", "congruence", "range_bearing", "linear_predict", "sigma_point_predict_linear",
            "measurement_moments", "imm_mix", "imm_output", "normalised_square", "information_fusion",
            "solve", "pseudoranges", "fading_factor"} <= set(ops)
    for name, op in ops.items():
        assert set(op.implementations) == set(linalg.KERNELS), name
        assert op.implementations["numba"].__name__ == f"_{name}_compiled", name
        assert op.__doc__ and op.__wrapped__ is op.implementations["numpy"], name


#: where the kernel's name may be read: to record it (results, digests, fingerprints), to pass it to workers, or to
#: key what a process remembers (simulate.BatchMemo: the two kernels agree only to round-off)
KERNEL_RECORDERS = ("mmlib/experiment/writing.py", "mmlib/experiment/digests.py", "mmlib/experiment/machine.py",
                    "mmlib/experiment/executors.py", "mmlib/experiment/simulate.py", "mmlib/arena/study.py",
                    "bench/provenance.py")
#: names that reach into linalg's dispatch or the compiled module
DISPATCH_NAMES = ("_kernels", "_compiled", "_compiled_module", "_KERNEL", "implementations", "_call", "compiled",
                  "_operation")


def kernel_choices(path: Path, rel: str) -> list:
    """Places in one source file (``rel`` its path from the repository root) that choose between the kernels or
    reach into linalg's dispatch: an import or attribute of :data:`DISPATCH_NAMES`, the compiled module's name or
    ``MMLIB_KERNEL`` as a string, or a ``kernel()`` call outside :data:`KERNEL_RECORDERS`."""
    import ast
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        names = []
        if isinstance(node, ast.ImportFrom):
            names = [node.module or ""] + [a.name for a in node.names]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.Attribute):
            names = [node.attr]
        bad = any(n.split(".")[-1] in DISPATCH_NAMES for n in names)
        bad |= isinstance(node, ast.Constant) and isinstance(node.value, str) and (
            "core._kernels" in node.value or node.value == "MMLIB_KERNEL")
        bad |= (isinstance(node, ast.Call) and getattr(node.func, "id", getattr(node.func, "attr", None)) == "kernel"
                and rel not in KERNEL_RECORDERS)
        if bad:
            out.append(f"{rel}:{node.lineno}")
    return out


def test_the_kernel_is_chosen_in_one_place():
    """Outside mmlib/core/linalg.py (and the compiled module itself) nothing in the library, the benchmark, the tools
    or the notebooks imports the compiled kernels, reaches into linalg's dispatch, names the switch's variable, or
    reads the kernel's name other than to record it."""
    repo = Path(linalg.__file__).resolve().parents[2]
    exempt = {"mmlib/core/linalg.py", "mmlib/core/_kernels.py", "mmlib/experiment/machine.py"}  # machine: env list
    files = [p for folder in ("mmlib", "bench", "tools", "notebooks") for p in (repo / folder).glob("**/*.py")
             if "executed" not in p.parts]
    offenders = [hit for p in files if p.relative_to(repo).as_posix() not in exempt
                 for hit in kernel_choices(p, p.relative_to(repo).as_posix())]
    assert not offenders, offenders


@pytest.mark.parametrize("source", [
    "from mmlib.core import _kernels", "import mmlib.core._kernels as K", "from . import _kernels",
    "import importlib\nK = importlib.import_module('mmlib.core._kernels')", "linalg._call(f, x)",
    "k = linalg.kernel()\nif k == 'numba': pass", "if kernel().startswith('n'): pass", "f = {'numba': 1}[kernel()]",
    "import os\nos.environ['MMLIB_KERNEL'] == 'numpy'", "linalg.cholesky.implementations['numpy'](x)"])
def test_the_kernel_scan_finds_a_planted_choice(tmp_path, source):
    path = tmp_path / "planted.py"
    path.write_text(source + "\n")
    assert kernel_choices(path, "mmlib/planted.py"), source


def test_linalg_is_the_bottom_of_the_core():
    """mmlib.core.linalg imports no module of mmlib but the compiled twins, the range-and-bearing formulas and the
    counts from the environment (anywhere in it, functions included), the twins only those formulas, and the formulas
    and the counts none, so the core's imports cannot cycle through it."""
    import ast
    here = Path(linalg.__file__)
    for path, allowed in ((here, {"mmlib.core._kernels", "mmlib.core._elementary", "mmlib.core._env"}),
                          (here.with_name("_kernels.py"), {"mmlib.core._elementary"}),
                          (here.with_name("_elementary.py"), set()), (here.with_name("_env.py"), set())):
        tree = ast.parse(path.read_text())
        imported = [(node.module or "") + ("." + a.name if node.module == "mmlib.core" else "")
                    for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) for a in node.names]
        imported += [a.name for node in ast.walk(tree) if isinstance(node, ast.Import) for a in node.names]
        assert not [m for m in imported if m.startswith("mmlib") and m not in allowed], (path.name, imported)


@pytest.mark.parametrize("bad", ["negative pivot", "NaN", "inf on the diagonal", "inf below", "semidefinite"])
def test_not_positive_definite_is_the_same_decision_in_both_paths(bad):
    rng = np.random.default_rng(5)
    A = _spd(rng, 6, 3)
    X = A.copy()
    if bad == "negative pivot":
        X[2] = np.diag([1.0, -1.0, 1.0])
    elif bad == "NaN":
        X[2, 1, 0] = np.nan
    elif bad == "inf on the diagonal":
        X[2, 1, 1] = np.inf
    elif bad == "inf below":
        X[2, 2, 0] = -np.inf
    else:
        X[2] = np.ones((3, 3))
    (L1, f1), (L2, f2) = _both(linalg.cholesky, X)
    assert f1.tolist() == f2.tolist() == [False, False, True, False, False, False]
    assert np.isnan(L1[2]).all() and np.isnan(L2[2]).all()
    (X1, g1), (X2, g2) = _both(linalg.sigma_points, np.zeros((6, 3)), X, np.eye(3))
    assert g1.tolist() == g2.tolist() == f1.tolist() and np.isnan(X1[2]).all() and np.isnan(X2[2]).all()


# ---------------------------------------------------------------------------------------------- every paper
@pytest.mark.parametrize("case_id", list(tbi.CASES))
def test_every_estimator_of_every_paper_agrees_across_kernels(case_id):
    """Every filter, layer and IMM of every paper's headline (and the reading variants that reach other code
    paths), run by both paths on the same 6 runs: estimates, covariances, mode probabilities and
    diagnostics within ``RTOL_RUN`` of each field's scale; the same runs diverge at the same steps for the
    same causes."""
    case = tbi.CASES[case_id]()
    truth, z, init = case.batch(6)
    for name in case.estimators:
        got, ref = _both(case.run, name, init, z)
        assert got.diverged_step.tolist() == ref.diverged_step.tolist(), name
        assert got.divergence_cause.tolist() == ref.divergence_cause.tolist(), name
        for field in ("mean", "cov", "mode_probabilities", "diagnostics"):
            a, b = getattr(got, field), getattr(ref, field)
            assert (a is None) == (b is None), (name, field)
            if a is None:
                continue
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                for run_ in range(a.shape[0]):
                    _close(a[run_], b[run_], RTOL_RUN, f"{case_id} {name}.{field} run {run_}")


# ---------------------------------------------------------------------------------------------- blocking, selection
def test_blocking_does_not_change_a_bit(monkeypatch):
    """Kernel calls split a large stack into blocks (for the cache): every run gets the bits of an unblocked
    call, with operands periodic over the runs (one Q per mode) included."""
    case = tbi.CASES["zhou2017: case 1"]()
    truth, z, init = case.batch(40)
    with linalg.use_kernel("numba"):
        ref = {name: case.run(name, init, z) for name in case.estimators}
        monkeypatch.setattr(linalg, "BLOCK", 4)
        for name in case.estimators:
            got = case.run(name, init, z)
            for field in ("mean", "cov", "mode_probabilities", "diverged_step"):
                a, b = getattr(got, field), getattr(ref[name], field)
                if a is not None:
                    assert np.array_equal(a, b, equal_nan=True), (name, field)


def test_kernel_selection(monkeypatch):
    monkeypatch.setenv("MMLIB_KERNEL", "fortran")
    with pytest.raises(ValueError, match="^MMLIB_KERNEL: "):
        linalg._initial_kernel()
    monkeypatch.setenv("MMLIB_KERNEL", "numpy")
    assert linalg._initial_kernel() == "numpy"
    with pytest.raises(ValueError, match="^name: "):
        linalg.set_kernel("cuda")
    before = linalg.kernel()
    with linalg.use_kernel("numpy"):
        assert linalg.kernel() == "numpy"
    assert linalg.kernel() == before


def test_a_shape_mismatch_is_an_error_not_a_silent_read():
    """The compiled kernels do not check bounds; their wrapper does, so inconsistent operands fail loudly."""
    with linalg.use_kernel("numba"):
        with pytest.raises(ValueError, match="matmul_rows"):
            linalg.matmul_rows(np.ones((3, 6)), np.ones((4, 2)))
        with pytest.raises(ValueError, match="sigma_points"):
            linalg.sigma_points(np.zeros((2, 3)), np.broadcast_to(np.eye(4), (2, 4, 4)), np.eye(3))


# ---------------------------------------------------------------------------------------------- gram and psd_part
# The compiled twins of linalg.gram (U^T U) and linalg.psd_part (V max(L, 0) V^T) sum every entry over its terms in
# order, one fused multiply-add per term from 0.0, then add 0.0 (mmlib.core._kernels._gram_core, _psd_part_lane): the
# order of OpenBLAS's AVX2 kernels.  Checked three ways: against an exact reference of that sum (rational arithmetic,
# each FMA rounded once: the compiled twin's bits on every machine), against the numpy body to a round-off bound
# derived below (every machine), and against the numpy body bit for bit where a probe finds that this machine's numpy
# sums that way (else skipped, saying why).
EPS = np.finfo(float).eps
UNIT = EPS / 2                                       # the unit round-off
TINY = np.finfo(float).smallest_subnormal

#: (K rows, m columns) of the stacks U: the adaptive layer's windows (K = 2..10) of 2..7-component innovations, and
#: beyond (m = 9, 13; K = 20, 40)
GRAM_SHAPES = [(2, 2), (3, 2), (2, 5), (5, 3), (10, 7), (20, 9), (3, 13), (40, 4)]


def _fma(a: float, b: float, c: float) -> float:
    """a b + c rounded once to the nearest double (ties to even): ``Fraction`` is exact and its ``float`` rounds
    correctly, subnormals included."""
    from fractions import Fraction
    return float(Fraction(a) * Fraction(b) + Fraction(c))


def _in_order_fma(a: np.ndarray, b: np.ndarray, fused: bool = True) -> np.ndarray:
    """out[..., i, j] = sum over k of a[..., i, k] b[..., j, k], summed in order k = 0, 1, ... from 0.0 with one FMA
    per term (``fused=False``: the product and the sum each rounded), then added to 0.0: a (..., M, K), b (..., P, K)
    -> (..., M, P).  The reference: Python floats and fractions, one term at a time."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    lead = a.shape[:-2]
    A, Bm = a.reshape((-1,) + a.shape[-2:]), b.reshape((-1,) + b.shape[-2:])
    out = np.empty((A.shape[0], A.shape[1], Bm.shape[1]))
    for s in range(A.shape[0]):
        for i in range(A.shape[1]):
            for j in range(Bm.shape[1]):
                acc = 0.0
                for k in range(A.shape[2]):
                    x, y = float(A[s, i, k]), float(Bm[s, j, k])
                    acc = _fma(x, y, acc) if fused else acc + x * y
                out[s, i, j] = acc + 0.0
    return out.reshape(lead + out.shape[1:])


def _gram_reference(u, fused: bool = True) -> np.ndarray:
    ut = np.swapaxes(np.asarray(u, dtype=float), -1, -2)
    return _in_order_fma(ut, ut, fused)


def _same_bits(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _spread(rng, shape, decades: int = 12) -> np.ndarray:
    """Standard normals scaled by powers of ten over ``2 decades + 1`` decades, entry by entry."""
    return rng.standard_normal(shape) * 10.0 ** rng.integers(-decades, decades + 1, shape)


def _gram_stacks(K: int, m: int) -> list:
    """Stacks (N, K, m) for gram: magnitudes over 25 decades; over 3 decades with exact cancellations (a row and its
    negative) and signed zeros; and (4-D) a stack of stacks whose products are subnormal for one of its matrices."""
    rng = np.random.default_rng(1000 * K + m)
    wide = _spread(rng, (4, K, m))
    mild = _spread(rng, (3, K, m), 1)
    mild[0, 1] = -mild[0, 0]
    mild[1, :, 0] = -0.0
    mild[2, 0, :] = 0.0
    tiny = _spread(rng, (2, 2, K, m), 1)
    tiny[1, 0] *= 1e-160                              # products near 1e-320: subnormal, each rounded once
    return [wide, mild, tiny]


@functools.lru_cache(maxsize=None)
def _numpy_gram_order() -> str:
    """"" if this machine's numpy computes ``u^T u`` (BLAS ``syrk``) of the probe stacks -- the adaptive layer's
    shapes -- with the bits of the in-order FMA sum, else why not.  The probe discriminates: on it that sum differs
    from the sum of separately rounded products and from the in-order FMA sum of the rows reversed."""
    rng = np.random.default_rng(2024)
    for K, m in ((3, 2), (10, 7)):
        u = _spread(rng, (6, K, m), 3)
        ref = _gram_reference(u)
        assert not _same_bits(ref, _gram_reference(u, fused=False)), "the probe does not tell FMA from mul + add"
        assert not _same_bits(ref, _gram_reference(u[..., ::-1, :])), "the probe does not tell the order of the rows"
        if not _same_bits(np.swapaxes(u, -1, -2) @ u, ref):
            return (f"numpy's u^T u of ({K}, {m}) matrices does not sum each entry in order with one FMA per term on "
                    f"this machine (its BLAS kernel sums otherwise): the twins agree to round-off only")
    return ""


@functools.lru_cache(maxsize=None)
def _numpy_psd_part_order(m: int) -> str:
    """"" if on this machine numpy's ``eigh`` of the probe matrices (m, m) has the bits of numba's (the LAPACK of
    scipy, which the compiled twin calls) and numpy's product of two (m, m) matrices, the second transposed (BLAS
    ``gemm``), the bits of the in-order FMA sum; else why not."""
    import numba
    eigh = numba.njit(lambda a: np.linalg.eigh(a))
    rng = np.random.default_rng(4096 + m)
    d = rng.standard_normal((4, m, m))
    d = d + np.swapaxes(d, -1, -2)
    for one in d:
        w, v = np.linalg.eigh(one)
        w_nb, v_nb = eigh(one)
        if not (_same_bits(w, w_nb) and _same_bits(v, v_nb)):
            return (f"numpy's eigh of a ({m}, {m}) matrix differs from numba's (scipy's LAPACK) on this machine: the "
                    f"twins agree to round-off only")
    a, b = _spread(rng, (4, m, m), 3), _spread(rng, (4, m, m), 3)
    ref = _in_order_fma(a, b)
    assert m < 2 or not _same_bits(ref, _in_order_fma(a, b, fused=False)), "the probe does not tell FMA from mul + add"
    if not _same_bits(a @ np.swapaxes(b, -1, -2), ref):
        return (f"numpy's product of two ({m}, {m}) matrices does not sum each entry in order with one FMA per term on "
                f"this machine (its BLAS kernel sums otherwise, e.g. OpenBLAS's Haswell dgemm in the last row of an "
                f"odd number of rows, over 8 terms or more): the twins agree to round-off only")
    return ""


@pytest.mark.parametrize("K, m", GRAM_SHAPES)
def test_gram_compiled_is_the_in_order_fma_sum(K, m):
    """The compiled twin's bits are those of the exact reference of its summation (each entry in order over the K
    rows, one correctly rounded FMA per term from 0.0, then + 0.0), on every machine: magnitudes over 25 decades,
    exact cancellations, signed zeros, subnormal products, a 4-D stack.  The data tell that sum from the sum of
    separately rounded products and from the rows summed in reverse."""
    gram = linalg.gram.implementations["numba"]
    for u in _gram_stacks(K, m):
        ref = _gram_reference(u)
        got = gram(u)
        assert got.shape == u.shape[:-2] + (m, m)
        assert _same_bits(got, ref), np.argwhere(got != ref)[:5]
    assert (np.abs(ref[1, 0]) < np.finfo(float).tiny).all() and ref[1, 0].any()     # subnormal sums, not all 0
    u = _gram_stacks(K, m)[1]
    assert not _same_bits(_gram_reference(u), _gram_reference(u, fused=False))
    assert not _same_bits(_gram_reference(u), _gram_reference(u[..., ::-1, :]))


@pytest.mark.parametrize("K, m", GRAM_SHAPES + [(64, 12)])
def test_gram_compiled_agrees_with_numpy_within_round_off(K, m):
    """On every machine: a computed inner product of K terms, in any order, with or without FMA, is within
    gamma_K sum_t |u_ti u_tj| of the exact one (gamma_K = K u / (1 - K u), u the unit round-off; Higham, Accuracy and
    Stability, Sec. 3.1), plus K times half the smallest subnormal for products that underflow; the two twins, each
    so close to the exact value, differ by at most twice that."""
    for u in _gram_stacks(K, m)[:2] + [_spread(np.random.default_rng(K * m), (5, K, m), 3)]:
        got, ref = _both(linalg.gram, u)
        bound = 2 * K * UNIT / (1 - K * UNIT) * (np.swapaxes(np.abs(u), -1, -2) @ np.abs(u)) + K * TINY
        assert got.shape == ref.shape == u.shape[:-2] + (m, m)
        assert (np.abs(got - ref) <= bound).all(), np.max(np.abs(got - ref) / bound)


@pytest.mark.parametrize("K, m", GRAM_SHAPES)
def test_gram_compiled_is_numpys_bits_where_blas_sums_in_order_with_fma(K, m):
    """Where numpy's ``u^T u`` sums as the compiled twin does (a probe against the exact reference decides: OpenBLAS's
    AVX2 kernels, the reference machine's), the twins agree bit for bit."""
    why = _numpy_gram_order()
    if why:
        pytest.skip(why)
    for u in _gram_stacks(K, m):
        got, ref = _both(linalg.gram, u)
        assert _same_bits(got, ref), np.argwhere(got != ref)[:5]


def _symmetric(rng, N: int, m: int) -> np.ndarray:
    """N symmetric (m, m) matrices Q diag(lam) Q^T, Q orthogonal, lam of both signs over 16 decades (a pair of them
    equal, one 0 in some), each matrix scaled by a power of ten in 1e-8..1e8."""
    Q, _ = np.linalg.qr(rng.standard_normal((N, m, m)))
    lam = rng.choice([-1.0, 1.0], (N, m)) * 10.0 ** rng.uniform(-8, 8, (N, m))
    lam[::3, -1] = lam[::3, 0]
    lam[1::3, 0] = 0.0
    scale = 10.0 ** rng.integers(-8, 9, (N, 1, 1))
    return scale * ((Q * lam[:, None, :]) @ np.swapaxes(Q, -1, -2))


#: the bound on |psd_part(D) - the exact PSD part| in units of m eps ||D||_F, for either twin: LAPACK's eigensolver is
#: accepted by its own tests (sep.in, threshold 50) with a backward error ||D - V L V^T|| and a loss of orthogonality
#: ||I - V^T V|| below 50 m eps ||D|| and 50 m eps; the PSD part is a projection onto a convex set, so it moves by no
#: more than the backward error (Frobenius norm); V not orthogonal adds 2 x 50 m eps ||D||, the product's round-off
#: m eps ||D||: 151, rounded up to 160 -- for one twin; the two differ by at most twice that
PSD_ROUND_OFF = 160.0


@pytest.mark.parametrize("m", [2, 3, 4, 6, 7, 9])
def test_psd_part_compiled_agrees_with_numpy_within_round_off(m):
    """On every machine: each matrix's PSD part from the compiled twin within 2 x PSD_ROUND_OFF m eps ||D||_F of the
    numpy body's, matrices of both signs, repeated and zero eigenvalues, over 16 decades; a 4-D stack."""
    rng = np.random.default_rng(m)
    for d in (_symmetric(rng, 30, m), _symmetric(rng, 6, m).reshape(2, 3, m, m)):
        got, ref = _both(linalg.psd_part, d)
        assert got.shape == ref.shape == d.shape
        bound = 2 * PSD_ROUND_OFF * m * EPS * np.linalg.norm(d, axis=(-2, -1))
        assert (np.abs(got - ref).max(axis=(-2, -1)) <= bound).all()


@pytest.mark.parametrize("m", [2, 3, 4, 6, 7, 8])
def test_psd_part_compiled_is_numpys_bits_where_lapack_and_blas_agree(m):
    """Where numpy's ``eigh`` gives numba's bits and its product sums in order with one FMA per term (a probe
    decides), the twins agree bit for bit: random symmetric matrices (m, m), and not symmetric ones (both read the
    lower triangle)."""
    why = _numpy_psd_part_order(m)
    if why:
        pytest.skip(why)
    rng = np.random.default_rng(100 + m)
    d = _spread(rng, (40, m, m), 2)
    for stack in (d + np.swapaxes(d, -1, -2), d, _symmetric(rng, 30, m)):
        got, ref = _both(linalg.psd_part, stack)
        assert _same_bits(got, ref), np.argwhere(got != ref)[:5]


@pytest.mark.parametrize("kernel", linalg.KERNELS)
@pytest.mark.parametrize("m", [2, 3, 5, 9])
def test_psd_part_is_the_positive_semi_definite_part(kernel, m):
    """Against its definition, in both twins: D = Q diag(lam) Q^T (Q orthogonal) gives Q diag(max(lam, 0)) Q^T, to
    PSD_ROUND_OFF m eps ||D||_F (with the round-off of forming D and of Q's orthogonality, a few m eps ||D|| more:
    2 x PSD_ROUND_OFF); symmetric and with no eigenvalue below minus that; D itself where D is PSD (rank deficient
    included); exactly zero where D is negative definite (every computed eigenvalue negative: every term 0), +0.0 in
    the compiled twin (its sums start at +0.0)."""
    rng = np.random.default_rng(7 * m)
    N = 24
    Q, _ = np.linalg.qr(rng.standard_normal((N, m, m)))
    lam = rng.standard_normal((N, m)) * 10.0 ** rng.uniform(-3, 3, (N, m))
    lam[:8] = np.abs(lam[:8])                       # PSD ...
    lam[:4, 0] = 0.0                                # ... rank deficient
    lam[8:12] = -np.abs(lam[8:12]) - 1e-3 * np.abs(lam[8:12]).max(axis=1, keepdims=True)     # negative definite
    lam[12:, 0], lam[12:, -1] = 1.0, -1.0           # both signs
    d = (Q * lam[:, None, :]) @ np.swapaxes(Q, -1, -2)
    expected = (Q * np.maximum(lam, 0.0)[:, None, :]) @ np.swapaxes(Q, -1, -2)
    with linalg.use_kernel(kernel):
        p = linalg.psd_part(d)
    tol = 2 * PSD_ROUND_OFF * m * EPS * np.linalg.norm(d, axis=(-2, -1))[:, None, None]
    assert (np.abs(p - expected) <= tol).all()
    assert (np.abs(p - np.swapaxes(p, -1, -2)) <= tol).all()
    assert (np.linalg.eigvalsh(p) >= -tol[:, 0]).all()
    assert (np.abs(p[:8] - d[:8]) <= tol[:8]).all()
    assert (p[8:12] == 0.0).all()
    if kernel == "numba":
        assert not np.signbit(p[8:12]).any()
    assert (np.abs(p[12:]).max(axis=(-2, -1)) > 0.1).all()     # the positive part is there


def _outcome(fn, *args):
    """``fn(*args)``'s result, or the type and message of what it raised."""
    try:
        return fn(*args)
    except Exception as err:            # noqa: BLE001 -- the outcome compared is any exception
        return type(err), str(err)


def _same_outcome(a, b) -> bool:
    if isinstance(a, tuple) or isinstance(b, tuple):
        return a == b
    return _same_bits(a, b)


def test_psd_part_of_a_matrix_that_is_not_finite_is_nan_in_both_twins(monkeypatch):
    """A matrix whose lower triangle (what ``eigh`` reads) is not finite -- a failed run's -- is NaN in both twins,
    never an error (numpy's ``eigh`` would raise for the whole stack, or return NaN for 2 x 2 matrices, as LAPACK
    decides); one not finite above the diagonal only is computed from its lower triangle; the other matrices of the
    stack keep the bits they have alone (the batch changes no bit)."""
    from mmlib.core import _kernels
    called = []
    real = _kernels.psd_part
    monkeypatch.setattr(_kernels, "psd_part", lambda *a: called.append(1) or real(*a))
    rng = np.random.default_rng(3)
    for m in (2, 3, 7):
        base = rng.standard_normal((3, m, m))
        base = base + np.swapaxes(base, -1, -2)
        for kernel in linalg.KERNELS:
            alone = [linalg.psd_part.implementations[kernel](base[b:b + 1])[0] for b in range(3)]
            for value, where in ((np.nan, (m - 1, 0)), (np.inf, (0, 0)), (-np.inf, (m - 1, m - 1)),
                                 (np.nan, (0, m - 1))):
                d = base.copy()
                d[1][where] = value
                got = linalg.psd_part.implementations[kernel](d)
                for b in (0, 2):
                    assert _same_bits(got[b], alone[b]), (kernel, m, value, where)
                if where[0] >= where[1]:                       # in the lower triangle: a failed run
                    assert np.isnan(got[1]).all(), (kernel, m, value, where)
                else:                                          # above it: not read
                    upper = d[1].copy()
                    upper[where] = upper[where[::-1]]
                    assert _same_bits(got[1], linalg.psd_part.implementations[kernel](upper[None])[0])
    assert called                                   # the compiled twin's kernel, also for the stacks with NaN


def test_gram_and_psd_part_of_one_component_or_one_row_are_numpys(monkeypatch):
    """m = 1 (numpy's product is a dot, summed in another order) and, for gram, K = 1: the compiled twins run the numpy
    body (the same bits, the kernels not called); an empty stack too.  The data tell the dot from the in-order FMA
    sum, so a twin that ran its kernel for m = 1 would differ."""
    from mmlib.core import _kernels
    called = []
    for name in ("gram", "psd_part"):
        real = getattr(_kernels, name)
        monkeypatch.setattr(_kernels, name, lambda *a, _real=real: called.append(1) or _real(*a))
    rng = np.random.default_rng(8)
    u = _spread(rng, (40, 10, 1), 3)
    assert not _same_bits(_gram_reference(u), np.swapaxes(u, -1, -2) @ u)
    for stack in (u, _spread(rng, (5, 1, 4), 3), _spread(rng, (2, 3, 1, 1), 3), np.zeros((0, 3, 2))):
        assert _same_bits(linalg.gram.implementations["numba"](stack), linalg.gram.implementations["numpy"](stack))
    d = np.array([[[2.5]], [[-1.0]], [[0.0]], [[-0.0]], [[1e-300]]])
    for stack in (d, d.reshape(5, 1, 1, 1), np.zeros((0, 3, 3))):
        assert _same_bits(linalg.psd_part.implementations["numba"](stack),
                          linalg.psd_part.implementations["numpy"](stack))
    assert not called


def test_gram_and_psd_part_name_a_bad_argument():
    """The compiled twins' operands: a stack of matrices for gram (``u``), of square matrices for psd_part (``d``),
    else a ValueError naming the argument (the kernels do not check bounds)."""
    with linalg.use_kernel("numba"):
        for bad in (np.ones(3), np.float64(2.0)):
            with pytest.raises(ValueError, match="^u: "):
                linalg.gram(bad)
        for bad in (np.ones(3), np.ones((2, 3, 4)), np.ones((3, 2))):
            with pytest.raises(ValueError, match="^d: "):
                linalg.psd_part(bad)
