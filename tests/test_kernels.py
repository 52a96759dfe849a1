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
