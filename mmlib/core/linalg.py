"""Batched small-matrix linear algebra with divergence reporting, in two implementations.

Layout: the batch (Monte Carlo run) axis is the leading axis, ``(B, n, n)`` (any leading axes, e.g.
runs and modes, are flattened into one stack).

**Two kernels, one mathematics** (:func:`kernel`, ``MMLIB_KERNEL``):

* ``"numba"`` (default when numba imports): the compiled kernels of :mod:`mmlib.core._kernels`, each filter
  operation fused into one batch-innermost loop nest vectorised across the runs;
* ``"numpy"``: the reference path, LAPACK gufuncs and ``matmul`` on the leading-batch layout (measured on
  the 2-core reference machine, numpy 2.4, n = 4: ``np.linalg.cholesky`` on a ``(100, 4, 4)`` stack
  ~38 us; ``matmul`` 5x faster than ``einsum`` for these shapes).

Measured on the IMM-UKF benchmark (3 modes, 100 runs, 100 steps): ~150 ms per study with the numpy path,
~45 ms with the compiled one.  The paths agree to round-off (``tests/test_kernels.py``); each gives a run
the same bits in any batch (``tests/test_batch_independence.py``).  The fused kernels
(:func:`sigma_point_predict_linear`, :func:`measurement_moments`, :func:`imm_mix`, :func:`imm_output`) exist
only compiled: on the numpy path the filters compose the generic functions instead.

A matrix that is not positive definite never raises inside the batch: the
affected runs are returned in a mask and their factor is NaN, so that the
divergence propagates to that run only and is *reported* by the caller
(:func:`mmlib.core.estimation.run`) instead of being patched.
"""
from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Iterator
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

if TYPE_CHECKING:
    from mmlib.core.rules import UnitPoints

#: The implementations of the kernels below: ``"numba"`` (compiled loops, :mod:`mmlib.core._kernels`) and
#: ``"numpy"`` (the reference path).  They compute the same mathematics and agree to round-off
#: (``tests/test_kernels.py``); each gives every run the same bits in any batch.
KERNELS = ("numba", "numpy")


def _initial_kernel() -> str:
    """``$MMLIB_KERNEL`` if set, else numba when it imports, else numpy."""
    env = os.environ.get("MMLIB_KERNEL", "").strip()
    if env and env not in KERNELS:
        raise ValueError(f"MMLIB_KERNEL: expected one of {KERNELS}, got {env!r}")
    if env == "numpy":
        return "numpy"
    try:
        from mmlib.core import _kernels  # noqa: F401
    except ImportError:
        if env == "numba":
            raise ValueError("MMLIB_KERNEL: 'numba' asked for, but numba is not installed (pip install numba)")
        return "numpy"
    return "numba"


_KERNEL = [_initial_kernel()]


def kernel() -> str:
    """The kernel implementation in use, ``"numba"`` or ``"numpy"`` (recorded in every results file)."""
    return _KERNEL[0]


def set_kernel(name: str) -> None:
    """Select the kernel implementation for this process (``"numba"`` or ``"numpy"``)."""
    if name not in KERNELS:
        raise ValueError(f"name: expected one of {KERNELS}, got {name!r}")
    if name == "numba":
        from mmlib.core import _kernels
    _KERNEL[0] = name


@contextlib.contextmanager
def use_kernel(name: str) -> Iterator[None]:
    """Context manager: run the body with the kernel implementation ``name`` (``"numba"`` or ``"numpy"``,
    else a ValueError naming ``name``), restoring the previous one on exit."""
    previous = kernel()
    set_kernel(name)
    try:
        yield
    finally:
        _KERNEL[0] = previous


_KERNELS_MODULE: list = []


def _compiled():
    """The compiled kernels module when numba is selected, else None."""
    if _KERNEL[0] != "numba":
        return None
    if not _KERNELS_MODULE:
        from mmlib.core import _kernels
        _KERNELS_MODULE.append(_kernels)
    return _KERNELS_MODULE[0]


#: Runs per compiled-kernel call for large stacks: a kernel's batch-innermost temporaries for this many runs
#: (e.g. 9 sigma points x 4 states x 1024 runs x 8 bytes = 295 KB) stay within the core's L2 cache, and the
#: Python cost of a call is paid a few times per step, not hundreds.  Measured on the reference machine (IMM-UKF,
#: 10,000 runs in chunks of 2,000, CPU seconds, busy machine): 3.6 s with blocks of 256 runs, 3.3 s with 512,
#: 2.9 s with 1,024, 3.4-3.8 s with 2,048 and more (unblocked: 6,000 runs x 3 modes per call).
BLOCK = 1024


#: Shapes of each compiled kernel's array arguments, by axis symbol ("N": the runs of the flattened stack, of
#: which an operand may hold a divisor, its rows being periodic; "-": not checked; None: not an array; a
#: signature starting with "?" is checked only when the argument is not empty).  The kernels do not check
#: bounds, so :func:`_call` checks these before every call: a mismatch is a ValueError, never a silent read
#: out of bounds.
_SHAPES = {
    "cholesky": ("N n n",),
    "matmul_rows": ("N k", "k d"),
    "sigma_points": ("N n", "N n n", "M n"),
    "weighted_mean": ("N M d", "M"),
    "weighted_outer": ("N M d", "M", "N M e", "N d d"),
    "kalman_moments": ("N n", "N n n", "N m", "N m m", "N n m", "?N m n", "?N m m"),
    "combine_covariances": ("N J I", "N I n", "N I n n", "N J n"),
    "sigma_point_predict_linear": ("N n", "N n n", "M n", "M", "M", "N n n", "N n n"),
    "measurement_moments": ("N M n", "N n", "N M m", "M", "M", "m", "N m m"),
    "imm_mix": ("N r", "r r", "N r n", "N r n n"),
    "congruence": ("N d n", "N n n", "N d d"),
    "linear_predict": ("N n", "N n n", "N n n", "N n n"),
    "imm_output": ("N r", "N r", "N r n", "N r n n", "N r m", "N r m m", None),
}
_CHECKED: set = set()


def _check_shapes(name: str, n_runs: int, args) -> None:
    key = (name, n_runs) + tuple(getattr(a, "shape", None) for a in args)
    if key in _CHECKED:
        return
    sizes = {"N": n_runs}
    for pos, (sig, a) in enumerate(zip(_SHAPES[name], args)):
        if sig is None:
            continue
        optional = sig.startswith("?")
        axes = sig.lstrip("?").split()
        shape = np.shape(a)
        if optional and 0 in shape:
            continue
        if len(shape) != len(axes):
            raise ValueError(f"{name}: argument {pos} has shape {shape}, expected ({', '.join(axes)})")
        for ax, size in zip(axes, shape):
            if ax == "-":
                continue
            if ax == "N":
                if size == 0 or n_runs % size:
                    raise ValueError(f"{name}: argument {pos} holds {size} rows for a stack of {n_runs}")
                continue
            if sizes.setdefault(ax, size) != size:
                raise ValueError(f"{name}: argument {pos} has shape {shape}: axis {ax} is {size}, elsewhere "
                                 f"{sizes[ax]}")
    _CHECKED.add(key)


def _call(name: str, n_runs: int, *args):
    """Call compiled kernel ``name`` on stacks of ``n_runs`` runs, in blocks of about :data:`BLOCK` runs (every
    argument with ``n_runs`` rows is sliced; the others -- rule constants, operands periodic over the runs --
    are passed whole, the block length being a multiple of their period); outputs are concatenated.  A run's
    numbers do not depend on the blocking (the kernels compute every run from its own operands)."""
    _check_shapes(name, n_runs, args)
    fn = getattr(_compiled(), name)
    if n_runs <= 2 * BLOCK:
        return fn(*args)
    step, sliced = 1, []
    for a in args:
        rows = a.shape[0] if isinstance(a, np.ndarray) and a.ndim else 0
        sliced.append(rows == n_runs)
        if 0 < rows < n_runs and n_runs % rows == 0:
            step = math.lcm(step, rows)
    step = step * -(-BLOCK // step)
    parts = [fn(*[a[b0:b0 + step] if cut else a for a, cut in zip(args, sliced)]) for b0 in range(0, n_runs, step)]
    if isinstance(parts[0], tuple):
        return tuple(np.concatenate(col) for col in zip(*parts))
    return np.concatenate(parts)


def _stack(a, tail_ndim: int, lead=None) -> np.ndarray:
    """``a`` as a C-contiguous float64 stack ``(N,) + tail`` (broadcast to ``lead + tail`` first if given)."""
    if type(a) is not np.ndarray or a.dtype != np.float64:
        a = np.asarray(a, dtype=np.float64)
    tail = a.shape[a.ndim - tail_ndim:]
    if lead is not None and a.shape[:a.ndim - tail_ndim] != lead:
        a = np.broadcast_to(a, lead + tail)
    if not a.flags.c_contiguous:
        a = np.ascontiguousarray(a)
    return a.reshape((-1,) + tail)


def _periodic(a, tail_ndim: int, lead) -> np.ndarray:
    """An operand broadcast against the stack ``lead`` (a tuple of leading axes), as a C-contiguous
    ``(P,) + tail`` whose row ``b % P`` belongs to run ``b`` of the flattened stack (the kernels' convention):
    no copy when its own leading axes are a suffix of ``lead`` (a shared matrix, one per mode, one per
    run and mode), a broadcast copy otherwise."""
    if type(a) is not np.ndarray or a.dtype != np.float64:
        a = np.asarray(a, dtype=np.float64)
    own = a.shape[:a.ndim - tail_ndim]
    while own and own[0] == 1:
        own = own[1:]
    if own != lead[len(lead) - len(own):]:
        return _stack(a, tail_ndim, lead)
    if not a.flags.c_contiguous:
        a = np.ascontiguousarray(a)
    return a.reshape((-1,) + a.shape[a.ndim - tail_ndim:])


def symmetrize(a: np.ndarray) -> np.ndarray:
    """(A + A^T)/2 over the last two axes (round-off hygiene, not a PD repair)."""
    return 0.5 * (a + np.swapaxes(a, -1, -2))


def cholesky(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower Cholesky factors of a stack ``(..., n, n)``.

    Returns ``(L, failed)`` where ``failed`` is a boolean ``(...)`` mask of the
    matrices that are not (numerically) positive definite; their ``L`` is NaN.
    "Positive definite" means LAPACK's ``potrf`` succeeds (every pivot > 0, tolerance
    zero), judged matrix by matrix whatever else is in the stack.  Only the lower triangle
    is read (LAPACK's convention; the library's covariances are symmetric).  A matrix whose
    lower triangle is not finite is not positive definite: OpenBLAS does not flag NaN itself,
    but a NaN or infinity there always reaches the factor's diagonal (a NaN propagates down
    the rows through the divisions by the pivots; an infinite diagonal entry is a pivot; an
    infinite entry below it makes a later pivot's radicand -inf, which LAPACK rejects), so
    the diagonal of the factor is what is checked.  The fast path is one LAPACK call for the
    whole stack.
    """
    k = _compiled()
    if k is not None:
        flat = _stack(a, 2)
        L, failed = _call("cholesky", flat.shape[0], flat)
        return L.reshape(a.shape), failed.reshape(a.shape[:-2])
    try:
        L = np.linalg.cholesky(a)
        failed = _nonfinite_diagonal(L)
        if failed.any():                   # a NaN input: LAPACK does not flag it, the factor is partly NaN
            L = np.where(failed[..., None, None], np.nan, L)
        return L, failed
    except np.linalg.LinAlgError:
        pass
    lead = a.shape[:-2]
    out, failed = _cholesky_slow(a.reshape((-1,) + a.shape[-2:]))
    return out.reshape(a.shape), failed.reshape(lead)


def _nonfinite_diagonal(L):
    return ~np.isfinite(np.diagonal(L, axis1=-2, axis2=-1)).all(axis=-1)


def _cholesky_slow(a):
    """Per-matrix verdicts for a stack in which LAPACK rejected something: every matrix is judged by LAPACK's
    own Cholesky (the same test as the fast path), never by another criterion, so a run's verdict does not
    depend on the other matrices of its batch."""
    failed = ~np.isfinite(np.tril(a)).all(axis=(-2, -1))
    out = np.full_like(a, np.nan)
    ok = np.flatnonzero(~failed)
    try:                                   # usually the only failures were non-finite (already diverged runs)
        out[ok] = np.linalg.cholesky(a[ok])
    except np.linalg.LinAlgError:
        for b in ok:
            try:
                out[b] = np.linalg.cholesky(a[b])
            except np.linalg.LinAlgError:
                failed[b] = True
    failed |= _nonfinite_diagonal(out)
    out[failed] = np.nan
    return out, failed


def trace(a: np.ndarray) -> np.ndarray:
    """Trace over the last two axes."""
    return np.trace(a, axis1=-2, axis2=-1)


def log_det_from_cholesky(l_factor: np.ndarray) -> np.ndarray:
    r""":math:`\log|A| = 2\sum_i \log L_{ii}` from lower Cholesky factors ``l_factor`` (..., m, m) of
    :math:`A = LL^T` (e.g. the innovation covariance S); returns (...).  A NaN factor (a failed run)
    gives NaN."""
    return 2.0 * np.log(np.diagonal(l_factor, axis1=-2, axis2=-1)).sum(axis=-1)


def tril_inverse(l_factor: np.ndarray) -> np.ndarray:
    """Inverse of lower-triangular matrices (..., m, m) by forward substitution.

    Written as O(m^3) element-wise array operations over the batch: for the 2x2 and
    3x3 innovation factors of tracking filters this is ~10x faster than a LAPACK
    call per matrix, and every run's result is independent of the batch size.
    """
    m = l_factor.shape[-1]
    inv = np.zeros_like(l_factor)
    diag_inv = 1.0 / np.diagonal(l_factor, axis1=-2, axis2=-1)
    for i in range(m):
        inv[..., i, i] = diag_inv[..., i]
        for j in range(i):
            acc = l_factor[..., i, j] * inv[..., j, j]
            for k in range(j + 1, i):
                acc = acc + l_factor[..., i, k] * inv[..., k, j]
            inv[..., i, j] = -acc * diag_inv[..., i]
    return inv


#: Inner dimension from which :func:`matmul_rows` stops trusting GEMM (see there).
GEMM_MAX_INNER = 15


def matmul_rows(x: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``x @ b`` for row vectors ``x`` (..., k) over any leading axes and one matrix ``b`` (k, d),
    every row with the same bits whatever the number of rows: a Monte Carlo run computed alone
    (B = 1) gets the numbers it gets in any chunk (batch independence).

    Why not a plain ``@``: numpy hands a one-row product (1, k) @ (k, d), and a one-column product
    (M, k) @ (k, 1), to BLAS ``gemv``, whose summation order is not ``gemm``'s and, for one column,
    changes with M: a run alone in its batch got other bits than in a batch of two or more
    (~1e-16 per product, ~1e-11 after a filter run).  Here, for k <= ``GEMM_MAX_INNER``, the
    product is one GEMM (rows, k) x (k, d) over all leading axes, a single row (column) computed
    as two rows (columns) with a copy of itself so that it takes the ``gemm`` path every other
    batch size takes.  For such short inner dimensions OpenBLAS's ``gemm`` computes each row from
    that row alone in an order that does not depend on the number of rows (measured, OpenBLAS
    0.3.31 on x86-64 AVX-512: k <= 15, any d, 2 to 200,000 rows); from k = 16 on its row results
    can depend on the number of rows modulo 4, so longer products are accumulated in numpy
    instead, one inner index at a time (sequential, no BLAS: the same bits for any number of rows
    by construction).  Every product of the library has k <= 9 (states, modes, fuzzy rules).
    ``tests/test_batch_independence.py`` checks this function and every estimator of every paper
    at B = 1, 2, 3 and 64.

    Chosen for speed: the GEMM keeps the cost of the former single GEMM (padding costs one small
    copy, only for a one-row or one-column product).  The alternatives that do not rely on
    ``gemm``'s row independence, a per-row stacked matmul ``x[..., None, :] @ b`` (one BLAS call
    per row) or the numpy accumulation used for k > 15, are 4-7x slower on the ~1000-row products
    of a batch of sigma points and slowed the IMM-UKF benchmark by 10-20 %."""
    kern = _compiled()
    if kern is not None:
        flat = _stack(x, 1)
        out = _call("matmul_rows", flat.shape[0], flat, np.ascontiguousarray(b, dtype=np.float64))
        return out.reshape(x.shape[:-1] + (b.shape[-1],))
    rows = x.reshape(-1, x.shape[-1])
    n_rows, k, n_cols = rows.shape[0], rows.shape[1], b.shape[-1]
    if k > GEMM_MAX_INNER:
        cols = np.ascontiguousarray(rows.T)                  # (k, rows): long inner loops over the rows
        acc = b[0][:, None] * cols[0]
        for j in range(1, k):
            acc += b[j][:, None] * cols[j]
        return acc.T.reshape(x.shape[:-1] + (n_cols,))
    if n_rows == 1:
        rows = np.concatenate([rows, rows])
    if n_cols == 1:
        b = np.concatenate([b, b], axis=-1)
    out = rows @ b
    if n_rows == 1 or n_cols == 1:
        out = out[:n_rows, :n_cols]
    return out.reshape(x.shape[:-1] + (n_cols,))


# --------------------------------------------------------------------------- fused filter kernels
# Each has a numpy reference implementation here and a compiled one in mmlib.core._kernels (selected by kernel()).

def sigma_points(mean: np.ndarray, cov: np.ndarray, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Sigma points :math:`X_p = m + L\xi_p` with :math:`LL^T = P` (:func:`cholesky`), for a stack.

    ``mean`` (..., n), ``cov`` (..., n, n), unit points ``xi`` (M, n) -> ``(X (..., M, n), failed (...))``;
    the points of a run whose covariance is not positive definite are NaN (its ``failed`` is True)."""
    lead = mean.shape[:-1]
    n = mean.shape[-1]
    k = _compiled()
    if k is not None:
        flat = _stack(mean, 1)
        X, failed = _call("sigma_points", flat.shape[0], flat, _stack(cov, 2, lead),
                          np.ascontiguousarray(xi, dtype=np.float64))
        return X.reshape(lead + (xi.shape[0], n)), failed.reshape(lead)
    chol, failed = cholesky(cov)
    # one GEMM for the whole batch: (L xi_p)_i = sum_j L_ij xi_pj, batch-size independent (matmul_rows)
    offsets = matmul_rows(chol, xi.T)
    return mean[..., None, :] + np.swapaxes(offsets, -1, -2), failed


def weighted_mean(Y: np.ndarray, w: np.ndarray) -> np.ndarray:
    r""":math:`\sum_p w_p Y_p`: ``Y`` (..., M, d), weights ``w`` (M,) -> (..., d)."""
    k = _compiled()
    if k is not None:
        lead = Y.shape[:-2]
        flat = _stack(Y, 2)
        return _call("weighted_mean", flat.shape[0], flat, np.ascontiguousarray(w, dtype=np.float64)).reshape(
            lead + Y.shape[-1:])
    return w @ Y


def weighted_covariances(dy: np.ndarray, w: np.ndarray, dx: np.ndarray | None = None,
                         add: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    r"""``(P_yy, P_xy)``: :math:`P_{yy} = \sum_p w_p\,dy_p dy_p^T + \mathrm{add}` and
    :math:`P_{xy} = \sum_p w_p\,dx_p dy_p^T` (None when ``dx`` is None).

    ``dy`` (..., M, d), ``w`` (M,), ``dx`` (..., M, n) with the same leading axes, ``add`` broadcasting
    against (..., d, d) (e.g. the noise Q or R) or None."""
    lead, d = dy.shape[:-2], dy.shape[-1]
    k = _compiled()
    if k is not None:
        dx_s = np.empty((int(np.prod(lead, dtype=np.int64)), dy.shape[-2], 0)) if dx is None else _stack(dx, 2, lead)
        add_s = _periodic(add, 2, lead) if add is not None else np.zeros((1, d, d))
        flat = _stack(dy, 2)
        pyy, pxy = _call("weighted_outer", flat.shape[0], flat, np.ascontiguousarray(w, dtype=np.float64), dx_s, add_s)
        return pyy.reshape(lead + (d, d)), (None if dx is None else pxy.reshape(lead + (dx.shape[-1], d)))
    wdy = dy * w[:, None]
    if dx is None:
        pyy = np.swapaxes(dy, -1, -2) @ wdy
        return (pyy if add is None else pyy + add), None
    both = np.swapaxes(np.concatenate([dy, dx], axis=-1), -1, -2) @ wdy   # one matmul
    pyy = both[..., :d, :]
    return (pyy if add is None else pyy + add), both[..., d:, :]


def kalman_moments(mean: np.ndarray, cov: np.ndarray, nu: np.ndarray, S: np.ndarray, Pxz: np.ndarray,
                   H: np.ndarray | None = None, R: np.ndarray | None = None) -> tuple:
    r"""The numerical part of the shared Kalman update (:func:`mmlib.core.filters.kalman_update`).

    ``mean`` (..., n), ``cov`` (..., n, n), residual-wrapped innovation ``nu`` (..., m), ``S`` (..., m, m),
    ``Pxz`` (..., n, m); ``H`` (..., m, n) with ``R`` (broadcasting to (..., m, m)) selects the Joseph form.
    With :math:`S = LL^T`, :math:`A = P_{xz}L^{-T}`, :math:`e = L^{-1}\nu`, :math:`K = AL^{-1}`:
    :math:`\hat x^+ = \hat x + Ae`, :math:`P^+ = \mathrm{sym}(P - AA^T)` or
    :math:`\mathrm{sym}((I - KH)P(I - KH)^T + KRK^T)` (Bar-Shalom et al. 2001, Eq. 5.2.3-18).
    Returns ``(mean+, cov+, nis (...), logdet_S (...), failed (...))``: a run fails when S or :math:`P^+`
    has no Cholesky factor (:func:`cholesky`); its mean and covariance are NaN."""
    lead = mean.shape[:-1]
    n, m = mean.shape[-1], nu.shape[-1]
    k = _compiled()
    if k is not None:
        if H is None:
            Hs = Rs = np.empty((1, 0, 0))
        else:
            Hs, Rs = _periodic(H, 2, lead), _periodic(R, 2, lead)
        flat = _stack(mean, 1)
        out = _call("kalman_moments", flat.shape[0], flat, _periodic(cov, 2, lead), _periodic(nu, 1, lead),
                    _periodic(S, 2, lead), _periodic(Pxz, 2, lead), Hs, Rs)
        mean_p, cov_p, nis, logdet, failed = out
        return (mean_p.reshape(lead + (n,)), cov_p.reshape(lead + (n, n)), nis.reshape(lead), logdet.reshape(lead),
                failed.reshape(lead))
    chol_s, s_failed = cholesky(S)
    linv = tril_inverse(chol_s)
    a = Pxz @ np.swapaxes(linv, -1, -2)                         # (..., n, m)
    e = (linv @ nu[..., None])[..., 0]                          # (..., m)
    mean_p = mean + (a @ e[..., None])[..., 0]
    if H is None:
        cov_p = symmetrize(cov - a @ np.swapaxes(a, -1, -2))
    else:                                                       # Joseph form
        gain = a @ linv                                         # K = Pxz S^-1, (..., n, m)
        i_kh = np.eye(n) - gain @ H
        cov_p = symmetrize(i_kh @ cov @ np.swapaxes(i_kh, -1, -2) + gain @ R @ np.swapaxes(gain, -1, -2))
    with np.errstate(over="ignore"):                            # a wild measurement: NIS = inf, L = 0
        nis = (e * e).sum(axis=-1)
    logdet = log_det_from_cholesky(chol_s)
    _, post_failed = cholesky(cov_p)        # non-finite covariances (NaN in, NaN out) fail too
    failed = s_failed | post_failed
    if failed.any():
        mean_p = np.where(failed[..., None], np.nan, mean_p)
        cov_p = np.where(failed[..., None, None], np.nan, cov_p)
    return mean_p, cov_p, nis, logdet, failed


def combine_covariances(wt: np.ndarray, means: np.ndarray, covs: np.ndarray, centres: np.ndarray) -> np.ndarray:
    r""":math:`\mathrm{sym}\sum_i w_{ji}[P_i + (x_i - c_j)(x_i - c_j)^T]` for every j.

    ``wt`` (B, J, I), ``means`` (B, I, n), ``covs`` (B, I, n, n), ``centres`` (B, J, n) -> (B, J, n, n).
    Deviations are taken from each centre, :math:`d_{ji} = x_i - c_j`: every term is positive
    semi-definite, so the sum stays so to round-off (no subtraction of :math:`cc^T`, which can cancel
    and give a negative variance).  Every product is per run (batch-size independent)."""
    k = _compiled()
    if k is not None:
        return _call("combine_covariances", wt.shape[0], _stack(wt, 2), _stack(means, 2), _stack(covs, 3),
                     _stack(centres, 2))
    B, J, I = wt.shape
    n = means.shape[-1]
    pooled = (wt @ covs.reshape(B, I, n * n)).reshape(B, J, n, n)
    d = means[:, None, :, :] - centres[:, :, None, :]                  # (B, J, I, n)
    wd = wt[..., :, None] * d                                          # (B, J, I, n)
    spread = pooled + np.swapaxes(wd, -1, -2) @ d                      # (B, J, n, n)
    return 0.5 * (spread + np.swapaxes(spread, -1, -2))


# Fused steps: compiled only (the numpy path composes the generic functions above in mmlib.core.filters and
# mmlib.core.estimation; tests/test_kernels.py checks that both paths agree).

def sigma_point_predict_linear(mean: np.ndarray, cov: np.ndarray, points: UnitPoints, F: np.ndarray,
                               Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Sigma-point time update through linear dynamics, fused (compiled kernel only): the rule's unit
    ``points`` (:class:`mmlib.core.rules.UnitPoints`) about ``mean`` (..., n) with covariance ``cov`` (..., n, n),
    mapped by ``F`` and ``Q`` (each broadcasting against (..., n, n)).  Returns ``(mean-, cov-)``: the
    moments :func:`sigma_points`, ``F X``, :func:`weighted_mean` and :func:`weighted_covariances` give."""
    lead = mean.shape[:-1]
    n = mean.shape[-1]
    flat = _stack(mean, 1)
    m, c, _ = _call("sigma_point_predict_linear", flat.shape[0], flat, _stack(cov, 2, lead), points.xi, points.wm,
                                                  points.wc, _periodic(F, 2, lead), _periodic(Q, 2, lead))
    return m.reshape(lead + (n,)), c.reshape(lead + (n, n))


def measurement_moments(X: np.ndarray, mean: np.ndarray, Z: np.ndarray, points: UnitPoints, angular: ArrayLike,
                        R: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Sigma-point measurement moments, fused (compiled kernel only): points ``X`` (..., M, n) about
    ``mean`` (..., n), their images ``Z`` (..., M, m), the rule's weights ``points``, the measurement's
    ``angular`` components (m,) (residuals wrapped, averaged about the first point) and noise ``R``.
    Returns ``(z_pred (..., m), S (..., m, m), Pxz (..., n, m))``."""
    lead = mean.shape[:-1]
    n, m = mean.shape[-1], Z.shape[-1]
    flat = _stack(mean, 1)
    zp, S, Pxz = _call("measurement_moments", flat.shape[0], _stack(X, 2), flat, _stack(Z, 2, lead),
                                              points.wm, points.wc, np.asarray(angular, dtype=np.bool_),
                                              _periodic(R, 2, lead))
    return zp.reshape(lead + (m,)), S.reshape(lead + (m, m)), Pxz.reshape(lead + (n, m))


def imm_mix(mu: np.ndarray, transition: np.ndarray, means: np.ndarray,
            covs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""IMM interaction fused (compiled kernel only): ``(c (B, r), mixed means (B, r, n), mixed covs
    (B, r, n, n))`` from mode probabilities ``mu`` (B, r), ``transition`` (r, r) (rows "from") and the mode
    estimates; the same as :func:`mmlib.core.estimation.mixing_weights` then :class:`mmlib.core.estimation.MomentMixing`."""
    return _call("imm_mix", mu.shape[0], _stack(mu, 1), np.ascontiguousarray(transition, dtype=np.float64), _stack(means, 2),
                            _stack(covs, 3))


def imm_output(loglik: np.ndarray, c: np.ndarray, means: np.ndarray, covs: np.ndarray, nu: np.ndarray,
               S: np.ndarray, with_cov: bool) -> tuple:
    """The end of an IMM cycle fused (compiled kernel only): :func:`mmlib.core.estimation.imm_output`."""
    mu, marginal, underflow, mean, cov, innovation, innovation_cov = _call("imm_output", loglik.shape[0],
        _stack(loglik, 1), _stack(c, 1), _stack(means, 2), _stack(covs, 3), _stack(nu, 2), _stack(S, 3), bool(with_cov))
    return mu, marginal, underflow, mean, (cov if with_cov else None), innovation, innovation_cov


def congruence(A: np.ndarray, P: np.ndarray, add: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""The EKF's linearised moments ``(A P A^T + add, P A^T)``: ``A`` (..., d, n) (a Jacobian, broadcasting over
    the stack), ``P`` (..., n, n), ``add`` broadcasting against (..., d, d) (the noise Q or R).  The same
    products as the numpy path's ``A @ P @ A^T + add`` and ``P @ A^T``, compiled when :func:`kernel` is numba."""
    lead = P.shape[:-2]
    d, n = A.shape[-2], A.shape[-1]
    k = _compiled()
    if k is not None:
        flat = _stack(P, 2)
        S, PAt = _call("congruence", flat.shape[0], _periodic(A, 2, lead), flat, _periodic(add, 2, lead))
        return S.reshape(lead + (d, d)), PAt.reshape(lead + (n, d))
    PAt = P @ np.swapaxes(A, -1, -2)
    return A @ PAt + add, PAt


def linear_predict(mean: np.ndarray, cov: np.ndarray, F: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Time update through linear dynamics fused (compiled kernel only): ``(F m, F P F^T + Q)`` for ``mean``
    (..., n), ``cov`` (..., n, n) and ``F``, ``Q`` broadcasting against (..., n, n) (e.g. one per mode)."""
    lead = mean.shape[:-1]
    n = mean.shape[-1]
    flat = _stack(mean, 1)
    m, c = _call("linear_predict", flat.shape[0], flat, _stack(cov, 2, lead), _periodic(F, 2, lead), _periodic(Q, 2, lead))
    return m.reshape(lead + (n,)), c.reshape(lead + (n, n))
