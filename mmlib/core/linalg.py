r"""Batched small-matrix linear algebra with divergence reporting, in two implementations.

Layout: the batch (Monte Carlo run) axis is the leading axis, ``(B, n, n)`` (any leading axes, e.g.
runs and modes, are flattened into one stack).

**Two kernels, one mathematics** (:func:`kernel`, ``MMLIB_KERNEL``).  Every operation below that has a
compiled form is declared here as a pair: its numpy body, the reference path (LAPACK gufuncs and
``matmul`` on the leading-batch layout), and right after it its compiled twin, which flattens the stack
and calls the loop nest of :mod:`mmlib.core._kernels` (batch innermost, vectorised across the runs).
Callers call the operation and never choose; the choice is made in one place, the dispatch that
``_operation`` builds, from :func:`kernel`: ``"numba"`` (default when numba imports) or ``"numpy"``.  The two fused
steps below are the exception: compiled only, taken by the estimators where they apply (:func:`fused`).

The fused operations (:func:`linear_predict`, :func:`sigma_point_predict_linear`,
:func:`measurement_moments`, :func:`imm_mix`, :func:`imm_output`) do a whole part of a filter step in one
compiled call; their numpy bodies compose the generic operations exactly as a filter step does
(``tests/test_kernels.py`` checks that bit for bit).  On the compiled kernels, the *fused steps*
(:func:`sigma_step`, :func:`imm_sigma_step`, :func:`strong_tracking_step`) go further: a whole step of a plain
sigma-point filter, of its IMM or of its strong-tracking layer on linear dynamics in one call, with the bits of
composing those operations (``tests/test_fused.py``); the estimators
of :mod:`mmlib.core.estimation` take them where they apply (:func:`fused`, ``MMLIB_FUSED=0`` turns them off) and
spread their blocks of runs over :func:`threads` threads (``MMLIB_THREADS``; a run's bits do not depend on it).  The
numpy and compiled paths agree to round-off, not bit for bit (BLAS and LAPACK sum in other orders;
``tests/test_kernels.py``); each gives a run the same bits in any batch (``tests/test_batch_independence.py``).

A matrix that is not positive definite never raises inside the batch: the
affected runs are returned in a mask and their factor is NaN, so that the
divergence propagates to that run only and is *reported* by the caller
(:func:`mmlib.core.estimation.run`) instead of being patched.

This module imports nothing else of :mod:`mmlib` but :mod:`mmlib.core._elementary` (range and bearing from the
four operations, numpy only), :mod:`mmlib.core._env` (counts from the environment, the standard library only) and
:mod:`mmlib.core._kernels`, the compiled twins (when loaded, to see whether numba imports; that module imports
nothing of :mod:`mmlib` but :mod:`mmlib.core._elementary`'s constants): it is the bottom of the estimation core's
imports.
"""
from __future__ import annotations

import concurrent.futures as cf
import contextlib
import functools
import math
import os
import threading
from collections.abc import Callable, Iterator, Sequence

import numpy as np
from numpy.typing import ArrayLike

from mmlib.core import _elementary, _env

__all__ = ["kernel", "set_kernel", "use_kernel", "KERNELS", "fused", "use_fused", "threads", "use_threads",
           "THREADS_VARIABLE", "sigma_points", "offset_points",
           "weighted_mean", "weighted_covariances", "kalman_moments", "measurement_moments", "congruence", "cholesky",
           "log_det_from_cholesky", "gram", "psd_part", "normalised_square", "solve", "information_fusion",
           "tril_inverse", "symmetrize",
           "trace", "wrap_angle", "range_bearing", "pseudoranges", "matmul_rows", "trapezoid_memberships",
           "rule_weights", "rule_output", "trapezoid_rules",
           "linear_transition", "linear_predict", "sigma_point_predict_linear", "sigma_step", "imm_sigma_step",
           "fading_factor", "jacobian_fading_factor", "strong_tracking_step", "packed_steps", "sigma_run",
           "imm_sigma_run", "strong_tracking_run",
           "adaptive_run", "imm_layer_run", "ekf_run", "cubature_mix", "no_rule_operands",
           "fuzzy_imm_run", "power", "compiled_rule_count",
           "mixing_weights", "mix_moments", "imm_mix", "imm_output", "combine_covariances", "BLOCK", "FUSED_BLOCK",
           "FUSED_STEPS",
           "GEMM_MAX_INNER", "MEASURE_LINEAR", "MEASURE_RANGE_BEARING", "MEASURE_PSEUDORANGES",
           "COMPILE_TIME"]

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
        _compiled_module(notice=False)          # numba must import; nothing is compiled yet
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


def _operation(numpy_body: Callable) -> Callable:
    """Declare an operation by its numpy body; ``@<operation>.compiled`` on the function after it declares its
    compiled twin.  The operation calls the implementation :func:`kernel` names: the one place where the
    compiled/numpy choice is made.  ``<operation>.implementations`` maps ``"numpy"`` and ``"numba"`` to the two
    (``tests/test_kernels.py`` compares them).  The numpy bodies run only on the numpy path, so the operations
    they call are the numpy ones too."""
    implementations = {"numpy": numpy_body}

    @functools.wraps(numpy_body)
    def operation(*args, **kwargs):
        return implementations[_KERNEL[0]](*args, **kwargs)

    def compiled(twin: Callable) -> Callable:
        implementations["numba"] = twin
        return twin

    operation.implementations = implementations
    operation.compiled = compiled
    return operation


# --------------------------------------------------------------------------- calling the compiled kernels
_KERNELS_MODULE: list = []


def _compiled_module(notice: bool = True):
    """:mod:`mmlib.core._kernels` (imported when this module loads, unless ``MMLIB_KERNEL=numpy``; it imports
    numba).  ``notice``: the caller is about to call a kernel, which numba compiles on its first call: the first
    such caller of a process prints :func:`_compile_notice` when the kernels' cache is cold."""
    if not _KERNELS_MODULE:
        from mmlib.core import _kernels
        _KERNELS_MODULE.append(_kernels)
    if notice and not _NOTICE_GIVEN:
        _NOTICE_GIVEN.append(True)
        if _kernel_cache_cold():
            _compile_notice()
    return _KERNELS_MODULE[0]


#: The wall time of compiling the kernels on a cold cache (every kernel a filter study uses; measured on the
#: reference machine, 2 cores; once per install: numba caches the machine code beside the package)
COMPILE_TIME = "1–2 min"

_NOTICE_GIVEN: list = []


def _kernel_cache_dirs() -> list:
    """Where numba may cache :mod:`mmlib.core._kernels`: ``$NUMBA_CACHE_DIR`` alone when set, else the
    ``__pycache__`` beside the module and numba's user-wide cache (``~/.cache/numba``)."""
    from pathlib import Path
    here = Path(__file__).resolve().parent
    if os.environ.get("NUMBA_CACHE_DIR"):
        # numba uses it alone, mirroring the source's absolute path under it
        return [Path(os.environ["NUMBA_CACHE_DIR"]) / here.relative_to(here.anchor)]
    # beside the package when it can be written there, else numba's user-wide cache
    return [here / "__pycache__", Path.home() / ".cache" / "numba" / here.relative_to(here.anchor)]


def _kernel_cache_cold() -> bool:
    """Whether numba's on-disk cache of :mod:`mmlib.core._kernels` is cold: no index file (``_kernels.*.nbi``) as
    new as the module's source in any of :func:`_kernel_cache_dirs` (numba drops the entries of an older source).
    A cheap look at file dates, not numba's own check: a warm cache of another Python version counts as warm."""
    from pathlib import Path
    source = Path(__file__).resolve().parent / "_kernels.py"
    try:
        stamp = source.stat().st_mtime
    except OSError:
        return False
    for folder in _kernel_cache_dirs():
        try:
            if any(p.stat().st_mtime >= stamp for p in folder.glob("_kernels.*.nbi")):
                return False
        except OSError:
            continue
    return True


def _compile_notice() -> None:
    """Say, once, that the filter kernels are being compiled: to the file ``$MMLIB_PROGRESS_LOG`` names when set
    (the notebook runner's log: never into an executed notebook; once in the log, whatever the number of worker
    processes compiling at once: the line is written under a file lock only when the log does not hold it yet),
    else to stderr (once per process)."""
    import sys
    line = (f"mmlib: compiling the filter kernels (first use only, about {COMPILE_TIME}: numba then caches them "
            f"on disk; MMLIB_KERNEL=numpy skips it)...")
    path = os.environ.get("MMLIB_PROGRESS_LOG")   # mmlib.experiment.montecarlo.PROGRESS_LOG_ENV (core imports none)
    if path:
        with open(path, "a+", encoding="utf-8") as log:
            try:
                import fcntl
                fcntl.flock(log, fcntl.LOCK_EX)    # released when the file closes
            except (ImportError, OSError):         # no POSIX locks (Windows, some network file systems)
                pass
            log.seek(0)
            if line not in log.read():
                log.write(line + "\n")
    else:
        print(line, file=sys.stderr, flush=True)


#: Runs per compiled-kernel call for large stacks: a kernel's batch-innermost temporaries for this many runs
#: (e.g. 9 sigma points x 4 states x 1024 runs x 8 bytes = 295 KB) stay within a core's L2 cache, and the
#: Python cost of a call is paid a few times per step, not hundreds.  A tuning choice only: a run's numbers do
#: not depend on it (``tests/test_kernels.py``).
BLOCK = 1024


#: Shapes of each compiled kernel's array arguments, by axis symbol ("N": the runs of the flattened stack, of
#: which an operand may hold a divisor, its rows being periodic; "-": not checked; "...": any leading axes;
#: None: not an array; a signature starting with "?" is checked only when the argument is not empty).
#: The kernels do not check bounds, so :func:`_call` (and each fused step) checks these before every call: a mismatch
#: is a ValueError, never a silent read out of bounds.
_SHAPES = {
    "cholesky": ("N n n",),
    "normalised_square": ("N d", "N d d"),
    "information_fusion": ("N M n", "N M n n"),
    "solve": ("N n n", "N n k"),
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
    # the fused steps (FUSED_STEPS): the array arguments they check, R any stack of
    # (m, m) (periodic over the runs and modes: read modulo its rows)
    "imm_sigma_step": ("N r", "r r", "N r n", "N r n n", "M n", "M", "M", "r n n", "N m", "... m m", "m", "... n n"),
    "sigma_step": ("N n", "N n n", "M n", "M", "M", "n n", "N m", "... m m", "m", "... n n"),
    "strong_tracking_step": ("N n", "N n n", "M n", "M", "M", "n n", "N m", "... m m", "m", "... n n", "N m m"),
    # (z, A, R, angular) of packed_steps: t = the steps' measurements in all, w >= the largest step's
    "sigma_run": ("N n", "N n n", "M n", "M", "M", "n n", "N t", "t a", "t w", "t", "... n n"),
    "imm_sigma_run": ("N r", "r r", "N r n", "N r n n", "M n", "M", "M", "r n n", "N t", "t a", "t w", "t", "... n n"),
    "strong_tracking_run": ("N n", "N n n", "M n", "M", "M", "n n", "N t", "t a", "t w", "t", "... n n", "N v v"),
    "adaptive_run": ("N n", "N n n", "M n", "M", "M", "n n", "N t", "t a", "t w", "t", "... n n"),
    "imm_layer_run": ("N r", "r r", "N r n", "N r n n", "M n", "M", "M", "r n n", "N t", "t a", "t w", "t", "... n n"),
    "fuzzy_imm_run": ("N r", "r r", "N r n", "N r n n", "M n", "M", "M", "r n n", "n n", "n n", "N r", "r", "N t",
                      "t a", "t w", "t", "N h c", "N"),
    "fading_factor": ("N n n", "N n n", "N n m", "N m m", "N m m", "N m m", None),
    "gram": ("N k m",),
    "jacobian_fading_factor": ("N m n", "N n n", "N n n", "N m m", "N m m", None),
    "cubature_mix": ("N r n", "N r n n", "N r r"),
    "psd_part": ("N m m",),
    "trapezoid_rules": ("N d", "d - -", "d", "- -"),
}
_CHECKED: set = set()


def _check_shapes(name: str, n_runs: int, args) -> None:
    key = (name, n_runs, *[getattr(a, "shape", None) for a in args])
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
        if axes[0] == "...":                       # any leading axes: the trailing ones are checked
            axes = axes[1:]
            shape = shape[len(shape) - len(axes):] if len(shape) >= len(axes) else shape
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


def _writable(args) -> list:
    """The operands ``args`` of a compiled kernel with every read-only array replaced by a writable copy.  Numba
    compiles a kernel once per signature, and a read-only array is another type than a writable one: the models'
    frozen matrices and the simulation memo's read-only batches would otherwise each add a compilation of the kernel
    and of every loop it calls.  The kernels never write their operands, so the copy changes no number; read-only
    operands are few and small (a model's matrices, a step's measurements)."""
    return [a.copy() if isinstance(a, np.ndarray) and not a.flags.writeable else a for a in args]


def _call(name: str, n_runs: int, *args):
    """Call compiled kernel ``name`` on stacks of ``n_runs`` runs, in blocks of about :data:`BLOCK` runs (every
    argument with ``n_runs`` rows is sliced; the others -- rule constants, operands periodic over the runs --
    are passed whole, the block length being a multiple of their period); outputs are concatenated.  A run's
    numbers do not depend on the blocking (the kernels compute every run from its own operands)."""
    _check_shapes(name, n_runs, args)
    args = _writable(args)
    fn = getattr(_compiled_module(), name)
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


def _contiguous(a) -> np.ndarray:
    """``a`` as a C-contiguous float64 array (a rule constant or a shared matrix, passed whole)."""
    return np.ascontiguousarray(a, dtype=np.float64)


# --------------------------------------------------------------------------- numpy only (no compiled form)
def symmetrize(a: np.ndarray) -> np.ndarray:
    """(A + A^T)/2 over the last two axes (round-off hygiene, not a PD repair)."""
    return 0.5 * (a + np.swapaxes(a, -1, -2))


def trace(a: np.ndarray) -> np.ndarray:
    """Trace over the last two axes."""
    return np.trace(a, axis1=-2, axis2=-1)


@_operation
def gram(u: np.ndarray) -> np.ndarray:
    r""":math:`U^TU` of each matrix of a stack ``u`` (..., K, m) -> (..., m, m): numpy's ``@``, which hands it to
    BLAS ``syrk``.  The compiled twin sums each entry over the K rows in order, one fused multiply-add per term
    (:func:`mmlib.core._kernels._gram_core`): how OpenBLAS's ``syrk`` sums it on AVX2 CPUs for K <= 256 (beyond, it
    sums blocks of 256), so the two agree bit for bit there and to round-off where BLAS sums otherwise
    (``tests/test_kernels.py``).  The compiled order is the same on every machine (a fused multiply-add is exact
    rounding, in hardware or in the C library).  For m = 1 or K = 1 (numpy's ``dot``, which sums in another order)
    both run numpy's product."""
    u = np.asarray(u, dtype=np.float64)
    return np.swapaxes(u, -1, -2) @ u


@gram.compiled
def _gram_compiled(u):
    u = np.asarray(u, dtype=np.float64)
    if u.ndim < 2:
        raise ValueError(f"u: expected a stack of matrices (..., K, m), got shape {u.shape}")
    K, m = u.shape[-2:]
    if m < 2 or K < 2 or u.size == 0:
        return gram.implementations["numpy"](u)
    flat = _stack(u, 2)
    return _call("gram", flat.shape[0], flat).reshape(u.shape[:-2] + (m, m))


@_operation
def psd_part(d: np.ndarray) -> np.ndarray:
    r"""The positive semi-definite part :math:`V\max(\Lambda, 0)V^T` of each symmetric matrix of a stack ``d``
    (..., m, m) (:math:`d = V\Lambda V^T`, numpy's ``eigh``, lower triangle) -> (..., m, m); NaN for a matrix whose
    lower triangle is not finite (a failed run: reported by the caller at its step, where numpy's ``eigh`` would
    raise for the whole stack or, for 2 x 2 matrices, return NaN).  Each matrix from itself alone (the batch
    changes no bit).  The compiled twin runs the same LAPACK routine (numba calls scipy's) and sums the product in
    order with one fused multiply-add per term (:func:`mmlib.core._kernels._psd_part_lane`), as OpenBLAS's ``gemm``
    does on AVX2 CPUs for most shapes (not its kernel for a last odd row, e.g. m = 9): the same bits there,
    round-off otherwise (``tests/test_kernels.py``); for m = 1 both run numpy's."""
    d = np.asarray(d, dtype=np.float64)
    ok = np.isfinite(np.tril(d)).all(axis=(-2, -1))
    if ok.all():
        w, v = np.linalg.eigh(d)
        return (v * np.clip(w, 0.0, None)[..., None, :]) @ np.swapaxes(v, -1, -2)
    out = np.full(d.shape, np.nan)
    if ok.any():
        w, v = np.linalg.eigh(d[ok])
        out[ok] = (v * np.clip(w, 0.0, None)[..., None, :]) @ np.swapaxes(v, -1, -2)
    return out


@psd_part.compiled
def _psd_part_compiled(d):
    d = np.asarray(d, dtype=np.float64)
    if d.ndim < 2 or d.shape[-1] != d.shape[-2]:
        raise ValueError(f"d: expected a stack of square matrices (..., m, m), got shape {d.shape}")
    m = d.shape[-1]
    if m < 2 or d.size == 0:
        return psd_part.implementations["numpy"](d)          # m = 1: numpy's dot
    flat = _stack(d, 2)
    return _call("psd_part", flat.shape[0], flat).reshape(d.shape)


def log_det_from_cholesky(l_factor: np.ndarray) -> np.ndarray:
    r""":math:`\log\det A = 2\sum_i \log L_{ii}` from lower Cholesky factors ``l_factor`` (..., m, m) of
    :math:`A = LL^T` (e.g. the innovation covariance S); returns (...).  A NaN factor (a failed run)
    gives NaN."""
    return 2.0 * np.log(np.diagonal(l_factor, axis1=-2, axis2=-1)).sum(axis=-1)


def tril_inverse(l_factor: np.ndarray) -> np.ndarray:
    """Inverse of lower-triangular matrices (..., m, m) by forward substitution.

    Written as O(m^3) element-wise array operations over the batch: for the 2x2 and
    3x3 innovation factors of tracking filters this is faster than a LAPACK call per
    matrix, and every run's result is independent of the batch size.
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


_TWO_PI = 2.0 * math.pi


def wrap_angle(a: np.ndarray | float) -> np.ndarray:
    r"""Wrap angles to :math:`(-\pi, \pi]`: :math:`a + 2\pi\lfloor(\pi - a)/2\pi\rfloor` (faster than
    ``np.mod``).  ``a`` in rad, any shape (array or scalar); returns the same shape, in rad.  Also
    :func:`mmlib.core.models.wrap_angle`."""
    return a + _TWO_PI * np.floor((np.pi - a) / _TWO_PI)


# --------------------------------------------------------------------------- generic operations
@_operation
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


@cholesky.compiled
def _cholesky_compiled(a):
    flat = _stack(a, 2)
    L, failed = _call("cholesky", flat.shape[0], flat)
    return L.reshape(a.shape), failed.reshape(a.shape[:-2])


@_operation
def normalised_square(v: np.ndarray, S: np.ndarray) -> np.ndarray:
    r""":math:`v^T S^{-1} v` per leading index (the two leading shapes broadcast) for vectors ``v`` (..., d) and
    matrices ``S`` (..., d, d): the NIS of an innovation and its covariance, the NEES of an estimation error and
    the state covariance (dimensionless: the units cancel).  NaN where either is not finite or S is singular (a
    diverged run).  Any nonsingular S is solved (LU with partial pivoting, as LAPACK's ``gesv``), not only positive
    definite ones: a broken filter's indefinite covariance gives its (meaningless, possibly negative) value, never
    a silent NaN.  Each matrix is solved on its own (LAPACK per matrix here, a loop per run in the compiled twin),
    so a run's value does not depend on the rest of its batch."""
    v = np.asarray(v, dtype=float)
    S = np.asarray(S, dtype=float)
    lead = np.broadcast_shapes(v.shape[:-1], S.shape[:-2])      # the leading axes broadcast against each other
    v, S = np.broadcast_to(v, lead + v.shape[-1:]), np.broadcast_to(S, lead + S.shape[-2:])
    ok = np.isfinite(v).all(axis=-1) & np.isfinite(S).all(axis=(-2, -1))
    out = np.full(lead, np.nan)
    if ok.any():
        vo = v[ok]
        sol = _solve_each(S[ok], vo[..., None])[..., 0]
        out[ok] = (vo * sol).sum(axis=-1)    # the same reduction on either path: a run's bits do not depend on
    return out                               # whether another run of its batch is singular


def _solve_each(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``np.linalg.solve`` of finite stacks A (K, n, n), B (K, n, k); on a singular matrix (LinAlgError) the matrices
    one by one, NaN for the singular ones (LAPACK per matrix either way: the same bits for the others)."""
    try:
        return np.linalg.solve(A, B)
    except np.linalg.LinAlgError:
        out = np.full(B.shape, np.nan)
        for i in range(A.shape[0]):
            try:
                out[i] = np.linalg.solve(A[i], B[i])
            except np.linalg.LinAlgError:
                pass
        return out


@normalised_square.compiled
def _normalised_square_compiled(v, S):
    v = np.asarray(v, dtype=np.float64)
    lead = np.broadcast_shapes(v.shape[:-1], np.shape(S)[:-2])
    flat_v = _stack(v, 1, lead)
    flat_S = _stack(S, 2, lead)
    return _call("normalised_square", flat_v.shape[0], flat_v, flat_S).reshape(lead)


@_operation
def solve(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    r""":math:`X = A^{-1} B` per leading index (the leading shapes broadcast) for matrices ``A`` (..., n, n) and
    right-hand sides ``B`` (..., n, k): LU with partial pivoting per matrix (LAPACK's ``gesv`` here, a loop per run in
    the compiled twin), so a run's values do not depend on the rest of its batch.  NaN for a matrix that is not finite
    or is exactly singular (a diverged run), in both paths."""
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    lead = np.broadcast_shapes(A.shape[:-2], B.shape[:-2])
    A, B = np.broadcast_to(A, lead + A.shape[-2:]), np.broadcast_to(B, lead + B.shape[-2:])
    ok = np.isfinite(A).all(axis=(-2, -1)) & np.isfinite(B).all(axis=(-2, -1))
    out = np.full(B.shape, np.nan)
    if ok.any():
        out[ok] = _solve_each(A[ok], B[ok])
    return out


@solve.compiled
def _solve_compiled(A, B):
    A = np.asarray(A, dtype=np.float64)
    B = np.asarray(B, dtype=np.float64)
    lead = np.broadcast_shapes(A.shape[:-2], B.shape[:-2])
    flat_A, flat_B = _stack(A, 2, lead), _stack(B, 2, lead)
    return _call("solve", flat_A.shape[0], flat_A, flat_B).reshape(lead + B.shape[-2:])


@_operation
def fading_factor(Pl: np.ndarray, Q: np.ndarray, Pxz: np.ndarray, V: np.ndarray, S: np.ndarray, R: np.ndarray,
                  beta: float) -> np.ndarray:
    r"""The strong-tracking fading factor of the Jacobian-free form (Liu & Wu 2017, Eqs. 14, 18-19):
    with :math:`\tilde H = P_{xz}^T (P^l)^{-1}` (:func:`solve`), :math:`N = V - \tilde H Q \tilde H^T - \beta R` and
    :math:`M = P_{zz} - V + N + (\beta - 1)R`, :math:`\lambda = \max(1, \mathrm{tr}N / \mathrm{tr}M)`, 1 where
    :math:`\mathrm{tr}M` is not > 0 (NaN where tr N is NaN and tr M > 0).  ``Pl`` (..., n, n) the predicted covariance
    (Q included), ``Q`` (..., n, n) broadcasting, ``Pxz`` (..., n, m), ``V`` (..., m, m) the smoothed innovation outer
    product (Eq. 17), ``S`` (..., m, m) the predicted measurement covariance (R included), ``R`` broadcasting against
    (..., m, m), ``beta`` >= 1 the softening factor; returns :math:`\lambda` (...), dimensionless.  A run whose
    :math:`P^l` is not positive definite (:func:`cholesky`), hence no covariance, gets 1 (no inflation; over a
    sigma-point filter its points are NaN and the run fails at this step's update).  The compiled twin solves through
    the Cholesky factor and forms only the diagonals of N and M (:func:`mmlib.core._kernels._fading_core`): the two
    agree to round-off."""
    X = solve(Pl, Pxz)                                           # (P^l)^-1 Pxz, (..., n, m)
    _, not_pd = cholesky(Pl)
    if not_pd.any():                                             # a failed run: its sigma points are NaN too
        X = np.where(not_pd[..., None, None], np.nan, X)
    N = V - np.swapaxes(X, -1, -2) @ Q @ X - beta * R
    M = S - V + N + (beta - 1.0) * R
    tr_n, tr_m = trace(N), trace(M)
    with np.errstate(divide="ignore", invalid="ignore"):
        c = np.where(tr_m > 0.0, tr_n / tr_m, 1.0)
    return np.maximum(c, 1.0)


@fading_factor.compiled
def _fading_factor_compiled(Pl, Q, Pxz, V, S, R, beta):
    Pl = np.asarray(Pl, dtype=np.float64)
    lead = np.broadcast_shapes(Pl.shape[:-2], np.shape(Q)[:-2], np.shape(Pxz)[:-2], np.shape(V)[:-2],
                               np.shape(S)[:-2], np.shape(R)[:-2])
    flat = _stack(Pl, 2, lead)
    lam = _call("fading_factor", flat.shape[0], flat, _periodic(Q, 2, lead), _stack(Pxz, 2, lead), _stack(V, 2, lead),
                _stack(S, 2, lead), _periodic(R, 2, lead), float(beta))
    return lam.reshape(lead)


@_operation
def jacobian_fading_factor(H: np.ndarray, Pl: np.ndarray, Q: np.ndarray, V: np.ndarray, R: np.ndarray,
                           beta: float) -> np.ndarray:
    r"""The strong-tracking fading factor of the Jacobian form (Liu & Wu 2017, Eqs. 15-16; the STF of Zhou & Frank):
    :math:`N = V - HQH^T - \beta R`, :math:`M = H(P^l - Q)H^T`, :math:`\lambda = \max(1, \mathrm{tr}N/\mathrm{tr}M)`,
    1 where :math:`\mathrm{tr}M` is not > 0 (NaN where the ratio is).  ``H`` (..., m, n) the measurement Jacobian,
    ``Pl`` (..., n, n) the predicted covariance (Q included), ``Q`` (..., n, n) and ``R`` (..., m, m) broadcasting,
    ``V`` (..., m, m) the smoothed innovation outer product (Eq. 17), ``beta`` >= 1; returns :math:`\lambda` (...),
    dimensionless.  numpy's products here; the compiled twin (:func:`mmlib.core._kernels._jacobian_fading`) forms only
    the diagonals, each product summed in order with one fused multiply-add per term (how OpenBLAS's ``gemm`` sums
    on AVX2 CPUs for most shapes; to round-off otherwise) -- for m = 1 (numpy's ``gemv``) both run numpy's."""
    Ht = np.swapaxes(H, -1, -2)
    N = V - H @ Q @ Ht - beta * R
    M = H @ (Pl - Q) @ Ht
    tr_n, tr_m = trace(N), trace(M)
    with np.errstate(divide="ignore", invalid="ignore"):
        c = np.where(tr_m > 0.0, tr_n / tr_m, 1.0)
    return np.maximum(c, 1.0)


@jacobian_fading_factor.compiled
def _jacobian_fading_factor_compiled(H, Pl, Q, V, R, beta):
    H = np.asarray(H, dtype=np.float64)
    if H.ndim < 2 or H.shape[-2] < 2:
        return jacobian_fading_factor.implementations["numpy"](H, Pl, Q, V, R, beta)
    lead = np.broadcast_shapes(H.shape[:-2], np.shape(Pl)[:-2], np.shape(Q)[:-2], np.shape(V)[:-2],
                               np.shape(R)[:-2])
    flat = _stack(H, 2, lead)
    lam = _call("jacobian_fading_factor", flat.shape[0], flat, _stack(Pl, 2, lead), _periodic(Q, 2, lead),
                _stack(V, 2, lead), _periodic(R, 2, lead), float(beta))
    return lam.reshape(lead)


@_operation
def information_fusion(means: np.ndarray, covs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Fuse M estimates as if independent, in information form (Hu et al. 2017, Eqs. 22-24):

    .. math:: P = \Big[\sum_p P_p^{-1}\Big]^{-1}, \qquad \hat x = P \sum_p P_p^{-1} \hat x_p .

    ``means`` (M, ..., n) and ``covs`` (M, ..., n, n), the M members along the first axis (any leading axes after
    it, e.g. runs and modes).  Returns ``(mean (..., n), cov (..., n, n), ok (...))``: ``cov`` symmetrised, ``ok``
    where the symmetrised total information passes the Cholesky test (:func:`cholesky`), ``mean`` NaN where it does
    not (a failed run, reported by the caller).  A member covariance that is not finite gives NaN.  Each run on its
    own (LAPACK per matrix here; a loop per run in the compiled twin, where an exactly singular matrix also gives NaN,
    not numpy's LinAlgError), so a run's values do not depend on the rest of its batch."""
    means, covs, _ = _fusion_operands(means, covs)
    infos = [np.linalg.inv(c) for c in covs]
    total = sum(infos)
    chol, _ = cholesky(symmetrize(total))
    cov = symmetrize(np.linalg.inv(total))
    weighted = sum(Y @ m[..., None] for Y, m in zip(infos, means))[..., 0]
    mean = (cov @ weighted[..., None])[..., 0]
    ok = np.isfinite(chol).all(axis=(-2, -1))
    return np.where(ok[..., None], mean, np.nan), cov, ok


def _fusion_operands(means, covs) -> tuple:
    """``(means, covs, lead)`` of :func:`information_fusion`, float arrays whose leading axes after the members are
    broadcast to ``lead``; a ValueError naming ``means`` or ``covs`` for another number of members or dimension."""
    means = np.asarray(means, dtype=np.float64)
    covs = np.asarray(covs, dtype=np.float64)
    if means.ndim < 2 or means.shape[0] < 1:
        raise ValueError(f"means: expected shape (M, ..., n) with M >= 1 members, got {means.shape}")
    M, n = means.shape[0], means.shape[-1]
    if covs.ndim < 3 or covs.shape[0] != M or covs.shape[-2:] != (n, n):
        raise ValueError(f"covs: expected shape ({M}, ..., {n}, {n}) (the members of means), got {covs.shape}")
    try:
        lead = np.broadcast_shapes(means.shape[1:-1], covs.shape[1:-2])
    except ValueError:
        raise ValueError(f"covs: leading axes {covs.shape[1:-2]} do not broadcast against those of means, "
                         f"{means.shape[1:-1]}") from None
    def spread(a, tail):                     # the members' axis kept first, the leading axes aligned on the right
        own = a.shape[1:a.ndim - len(tail)]
        return np.broadcast_to(a.reshape((M,) + (1,) * (len(lead) - len(own)) + own + tail), (M,) + lead + tail)
    return spread(means, (n,)), spread(covs, (n, n)), lead


@information_fusion.compiled
def _information_fusion_compiled(means, covs):
    means, covs, lead = _fusion_operands(means, covs)
    M, n = means.shape[0], means.shape[-1]
    flat_m = np.ascontiguousarray(np.moveaxis(means.reshape((M, -1, n)), 0, 1))            # (N, M, n)
    flat_c = np.ascontiguousarray(np.moveaxis(covs.reshape((M, -1, n, n)), 0, 1))          # (N, M, n, n)
    mean, cov, ok = _call("information_fusion", flat_m.shape[0], flat_m, flat_c)
    return mean.reshape(lead + (n,)), cov.reshape(lead + (n, n)), ok.reshape(lead)


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


#: Inner dimension from which :func:`matmul_rows` stops trusting GEMM (see there).
GEMM_MAX_INNER = 15


@_operation
def matmul_rows(x: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``x @ b`` for row vectors ``x`` (..., k) over any leading axes and one matrix ``b`` (k, d),
    every row with the same bits whatever the number of rows: a Monte Carlo run computed alone
    (B = 1) gets the numbers it gets in any chunk (batch independence).

    Why not a plain ``@``: numpy hands a one-row product (1, k) @ (k, d), and a one-column product
    (M, k) @ (k, 1), to BLAS ``gemv``, whose summation order is not ``gemm``'s and, for one column,
    changes with M: a run alone in its batch got other bits than in a batch of two or more
    (about one ulp per product, more after a filter run).  Here, for k <= ``GEMM_MAX_INNER``, the
    product is one GEMM (rows, k) x (k, d) over all leading axes, a single row (column) computed
    as two rows (columns) with a copy of itself so that it takes the ``gemm`` path every other
    batch size takes.  For such short inner dimensions OpenBLAS's ``gemm`` computes each row from
    that row alone in an order that does not depend on the number of rows (OpenBLAS 0.3.31 on
    x86-64 AVX-512: k <= 15, any d, 2 to 200,000 rows); from k = 16 on its row results can depend on
    the number of rows modulo 4, so longer products are accumulated in numpy instead, one inner
    index at a time (sequential, no BLAS: the same bits for any number of rows by construction).
    Every product of the library has k <= 9 (states, modes, fuzzy rules).
    ``tests/test_batch_independence.py`` checks this function and every estimator of every paper
    at B = 1, 2, 3 and 64, on the machine at hand.

    Chosen for speed: the GEMM keeps the cost of a single GEMM (padding costs one small copy, only
    for a one-row or one-column product).  The alternatives that do not rely on ``gemm``'s row
    independence, a per-row stacked matmul ``x[..., None, :] @ b`` (one BLAS call per row) or the
    numpy accumulation used for k > 15, are several times slower on the ~1000-row products of a
    batch of sigma points."""
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


@matmul_rows.compiled
def _matmul_rows_compiled(x, b):
    flat = _stack(x, 1)
    out = _call("matmul_rows", flat.shape[0], flat, _contiguous(b))
    return out.reshape(x.shape[:-1] + (b.shape[-1],))


def offset_points(mean: np.ndarray, chol: np.ndarray, xi: np.ndarray) -> np.ndarray:
    r"""Sigma points :math:`X_p = m + L\xi_p` from a factor: ``mean`` (..., n), ``chol`` (..., n, n) (the lower
    factor L of the covariance), unit points ``xi`` (M, n) -> (..., M, n), in the state's units.  One
    :func:`matmul_rows` for the whole stack, :math:`(L\xi_p)_i = \sum_j L_{ij}\xi_{pj}`: a run's points have
    the same bits whatever the batch size, one run and a one-dimensional state included."""
    offsets = matmul_rows(chol, xi.T)
    return mean[..., None, :] + np.swapaxes(offsets, -1, -2)


@_operation
def sigma_points(mean: np.ndarray, cov: np.ndarray, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Sigma points :math:`X_p = m + L\xi_p` with :math:`LL^T = P` (:func:`cholesky`), for a stack.

    ``mean`` (..., n), ``cov`` (..., n, n), unit points ``xi`` (M, n) -> ``(X (..., M, n), failed (...))``;
    the points of a run whose covariance is not positive definite are NaN (its ``failed`` is True)."""
    chol, failed = cholesky(cov)
    return offset_points(mean, chol, xi), failed


@sigma_points.compiled
def _sigma_points_compiled(mean, cov, xi):
    lead = mean.shape[:-1]
    flat = _stack(mean, 1)
    X, failed = _call("sigma_points", flat.shape[0], flat, _stack(cov, 2, lead), _contiguous(xi))
    return X.reshape(lead + (xi.shape[0], mean.shape[-1])), failed.reshape(lead)


@_operation
def weighted_mean(Y: np.ndarray, w: np.ndarray) -> np.ndarray:
    r""":math:`\sum_p w_p Y_p`: ``Y`` (..., M, d), weights ``w`` (M,) -> (..., d)."""
    return w @ Y


@weighted_mean.compiled
def _weighted_mean_compiled(Y, w):
    flat = _stack(Y, 2)
    return _call("weighted_mean", flat.shape[0], flat, _contiguous(w)).reshape(Y.shape[:-2] + Y.shape[-1:])


@_operation
def weighted_covariances(dy: np.ndarray, w: np.ndarray, dx: np.ndarray | None = None,
                         add: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    r"""``(P_yy, P_xy)``: :math:`P_{yy} = \sum_p w_p\,dy_p dy_p^T + \mathrm{add}` and
    :math:`P_{xy} = \sum_p w_p\,dx_p dy_p^T` (None when ``dx`` is None).

    ``dy`` (..., M, d), ``w`` (M,), ``dx`` (..., M, n) with the same leading axes, ``add`` broadcasting
    against (..., d, d) (e.g. the noise Q or R) or None."""
    d = dy.shape[-1]
    wdy = dy * w[:, None]
    if dx is None:
        pyy = np.swapaxes(dy, -1, -2) @ wdy
        return (pyy if add is None else pyy + add), None
    both = np.swapaxes(np.concatenate([dy, dx], axis=-1), -1, -2) @ wdy   # one matmul
    pyy = both[..., :d, :]
    return (pyy if add is None else pyy + add), both[..., d:, :]


@weighted_covariances.compiled
def _weighted_covariances_compiled(dy, w, dx=None, add=None):
    lead, d = dy.shape[:-2], dy.shape[-1]
    dx_s = np.empty((int(np.prod(lead, dtype=np.int64)), dy.shape[-2], 0)) if dx is None else _stack(dx, 2, lead)
    add_s = _periodic(add, 2, lead) if add is not None else np.zeros((1, d, d))
    flat = _stack(dy, 2)
    pyy, pxy = _call("weighted_outer", flat.shape[0], flat, _contiguous(w), dx_s, add_s)
    return pyy.reshape(lead + (d, d)), (None if dx is None else pxy.reshape(lead + (dx.shape[-1], d)))


@_operation
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
    n = mean.shape[-1]
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


@kalman_moments.compiled
def _kalman_moments_compiled(mean, cov, nu, S, Pxz, H=None, R=None):
    lead = mean.shape[:-1]
    n = mean.shape[-1]
    if H is None:
        Hs = Rs = np.empty((1, 0, 0))
    else:
        Hs, Rs = _periodic(H, 2, lead), _periodic(R, 2, lead)
    flat = _stack(mean, 1)
    mean_p, cov_p, nis, logdet, failed = _call("kalman_moments", flat.shape[0], flat, _periodic(cov, 2, lead),
                                               _periodic(nu, 1, lead), _periodic(S, 2, lead),
                                               _periodic(Pxz, 2, lead), Hs, Rs)
    return (mean_p.reshape(lead + (n,)), cov_p.reshape(lead + (n, n)), nis.reshape(lead), logdet.reshape(lead),
            failed.reshape(lead))


@_operation
def combine_covariances(wt: np.ndarray, means: np.ndarray, covs: np.ndarray, centres: np.ndarray) -> np.ndarray:
    r""":math:`\mathrm{sym}\sum_i w_{ji}[P_i + (x_i - c_j)(x_i - c_j)^T]` for every j.

    ``wt`` (B, J, I), ``means`` (B, I, n), ``covs`` (B, I, n, n), ``centres`` (B, J, n) -> (B, J, n, n).
    Deviations are taken from each centre, :math:`d_{ji} = x_i - c_j`: every term is positive
    semi-definite, so the sum stays so to round-off (no subtraction of :math:`cc^T`, which can cancel
    and give a negative variance).  Every product is per run (batch-size independent)."""
    B, J, I = wt.shape
    n = means.shape[-1]
    pooled = (wt @ covs.reshape(B, I, n * n)).reshape(B, J, n, n)
    d = means[:, None, :, :] - centres[:, :, None, :]                  # (B, J, I, n)
    wd = wt[..., :, None] * d                                          # (B, J, I, n)
    spread = pooled + np.swapaxes(wd, -1, -2) @ d                      # (B, J, n, n)
    return 0.5 * (spread + np.swapaxes(spread, -1, -2))


@combine_covariances.compiled
def _combine_covariances_compiled(wt, means, covs, centres):
    return _call("combine_covariances", wt.shape[0], _stack(wt, 2), _stack(means, 2), _stack(covs, 3),
                 _stack(centres, 2))


@_operation
def congruence(A: np.ndarray, P: np.ndarray, add: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""The EKF's linearised moments ``(A P A^T + add, P A^T)``: ``A`` (..., d, n) (a Jacobian, broadcasting over
    the stack), ``P`` (..., n, n), ``add`` broadcasting against (..., d, d) (the noise Q or R);
    :math:`APA^T` computed as :math:`A(PA^T)`."""
    PAt = P @ np.swapaxes(A, -1, -2)
    return A @ PAt + add, PAt


@congruence.compiled
def _congruence_compiled(A, P, add):
    lead = P.shape[:-2]
    d, n = A.shape[-2], A.shape[-1]
    flat = _stack(P, 2)
    S, PAt = _call("congruence", flat.shape[0], _periodic(A, 2, lead), flat, _periodic(add, 2, lead))
    return S.reshape(lead + (d, d)), PAt.reshape(lead + (n, d))


@_operation
def range_bearing(x: np.ndarray, i: int, j: int, sensor: np.ndarray) -> np.ndarray:
    r"""Range and bearing :math:`(\sqrt{\Delta x^2 + \Delta y^2}, \operatorname{atan2}(\Delta y, \Delta x))` of
    the points ``x`` (..., n) from a sensor at ``sensor`` (2,) (m), with :math:`\Delta x = x_i - s_x`,
    :math:`\Delta y = x_j - s_y` -> (..., 2) (m, rad in :math:`[-\pi, \pi]`), computed by
    :func:`mmlib.core._elementary.range_bearing` from the four operations and the square root, the same bits on
    either path and every machine (below 2 ulp of the exact values; the C library's ``hypot`` and ``atan2`` for zeros,
    infinities, NaN and :math:`|d|` beyond :math:`2^{500}` or below :math:`2^{-450}`)
    (:meth:`mmlib.core.models.RangeBearing.h`).  An index beyond the state is an IndexError, one that is not an
    integer a ValueError naming ``i`` or ``j``."""
    i, j = _last_axis_index(x, i, "i"), _last_axis_index(x, j, "j")
    x, sensor = np.asarray(x, dtype=np.float64), np.asarray(sensor, dtype=np.float64)     # as the compiled path
    dx = x[..., i] - sensor[0]
    dy = x[..., j] - sensor[1]
    return np.stack(_elementary.range_bearing(dx, dy), axis=-1)


@range_bearing.compiled
def _range_bearing_compiled(x, i, j, sensor):
    n = x.shape[-1]
    i, j = _last_axis_index(x, i, "i"), _last_axis_index(x, j, "j")     # the kernel does not check bounds
    flat = _contiguous(x).reshape(-1, n)
    out = _compiled_module().range_bearing(*_writable([flat]), i, j, float(sensor[0]), float(sensor[1]))
    return out.reshape(x.shape[:-1] + (2,))


@_operation
def pseudoranges(x: np.ndarray, satellites: np.ndarray, position: tuple, bias: int) -> np.ndarray:
    r"""Pseudoranges :math:`\lVert s_c - p\rVert + b` (..., m) in m of the points ``x`` (..., n) to ``satellites``
    (m, 3) (m), with p = ``x[..., position]`` (three indices) and the clock bias b = ``x[..., bias]``
    (:meth:`mmlib.core.gnss.Pseudoranges.h`).  The same IEEE operations on either path, in the same order (the three
    squares summed from the first on, a correctly rounded square root, then the bias), so the same bits."""
    x, satellites, position, bias = _pseudorange_operands(x, satellites, position, bias)
    return _lines_of_sight(x, satellites.T, position)[1] + x[..., bias, None]


def _lines_of_sight(x: np.ndarray, satellites_enu: np.ndarray, position: tuple) -> tuple:
    r"""``(d, r)``: the lines of sight :math:`s_c - p` from the points ``x`` (..., n) to the satellites, as their
    three components ``d`` (three arrays (..., m), m), and their lengths :math:`r = \sqrt{(d_0^2 + d_1^2) + d_2^2}`
    (..., m), in m; ``satellites_enu`` (3, m) holds the satellites' three coordinates as rows (m), ``position`` the
    three indices of p in ``x``.  Component by component, with no (..., m, 3) copy, and the squares summed in that
    order: the arithmetic of :func:`pseudoranges` (which adds the bias to r) and of the pseudoranges' Jacobian
    (:meth:`mmlib.core.gnss.Pseudoranges.jacobian`).  The operands are taken as given: the callers have checked
    them (:func:`_pseudorange_operands`; a :class:`mmlib.core.gnss.Pseudoranges` its satellites)."""
    d = tuple(satellites_enu[k] - x[..., i, None] for k, i in enumerate(position))
    return d, np.sqrt((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2])


def _last_axis_index(x: np.ndarray, index: int, name: str) -> int:
    """``index`` (an integer, negative from the end) into the last axis of ``x`` as a non-negative int: a ValueError
    naming ``name`` for anything but an integer (a bool or a float included), numpy's IndexError beyond the axis (the
    compiled kernels check neither).  The integer test is :func:`mmlib.core._validate.check_index`'s, written again
    here: that module imports this one (its covariance check calls :func:`cholesky`), and this one stays at the
    bottom of the core's imports (tests/test_architecture.py refuses the cycle)."""
    if isinstance(index, (bool, np.bool_)) or not isinstance(index, (int, np.integer)):
        raise ValueError(f"{name}: expected an integer index, got {index!r}")
    n = x.shape[-1] if x.ndim else 0
    if not -n <= index < n:
        raise IndexError(f"index {index} is out of bounds for axis {max(x.ndim - 1, 0)} with size {n}")
    return int(index) % n


def _pseudorange_operands(x, satellites, position, bias) -> tuple:
    """The operands of :func:`pseudoranges` checked: ``x`` a float array (..., n), ``satellites`` (m, 3) (ValueError
    naming it otherwise), ``position`` three and ``bias`` one integer index into the last axis of ``x`` (non-negative;
    an IndexError beyond it, a ValueError naming ``position`` or ``bias`` for another kind of index)."""
    x = np.asarray(x, dtype=np.float64)
    satellites = np.asarray(satellites, dtype=np.float64)
    if satellites.ndim != 2 or satellites.shape[1] != 3 or satellites.shape[0] < 1:
        raise ValueError(f"satellites: expected shape (m >= 1, 3), got {satellites.shape}")
    if isinstance(position, (str, bytes)) or not hasattr(position, "__len__") or len(position) != 3:
        raise ValueError(f"position: expected three indices, got {position!r}")
    indices = []
    for name, index in (("position", position[0]), ("position", position[1]), ("position", position[2]),
                        ("bias", bias)):
        indices.append(_last_axis_index(x, index, name))
    return x, satellites, tuple(indices[:3]), indices[3]


@pseudoranges.compiled
def _pseudoranges_compiled(x, satellites, position, bias):
    x, satellites, (i0, i1, i2), bias = _pseudorange_operands(x, satellites, position, bias)
    n = x.shape[-1]
    out = _compiled_module().pseudoranges(*_writable([_contiguous(x).reshape(-1, n), _contiguous(satellites)]), i0, i1,
                                          i2, bias)
    return out.reshape(x.shape[:-1] + (satellites.shape[0],))


# --------------------------------------------------------------------------- fuzzy inference
def trapezoid_memberships(bounds: np.ndarray, x: np.ndarray) -> np.ndarray:
    r"""The memberships (B, k) of ``x`` (B,) in k trapezoids at once, ``bounds`` (4, k) their ``a, b, c, d``
    (:class:`mmlib.core.fuzzy.Trapezoid`, which calls it with k = 1): per entry :math:`\min(\mathrm{up},
    \mathrm{down})` clipped to [0, 1], with up = 1 for a left shoulder, :math:`[x \ge b]` for a = b, else
    :math:`(x - a)/(b - a)`, and down = 1 for a right shoulder, :math:`[x \le c]` for c = d, else
    :math:`(d - x)/(d - c)`; each entry's arithmetic depends on its own operands only, so the same bits whatever k
    and B."""
    a, b, c, d = bounds
    X = x[:, None]
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):     # the branches np.where drops
        up = np.where(a == -math.inf, 1.0, np.where(b == a, (X >= b).astype(float), (X - a) / (b - a)))
        down = np.where(d == math.inf, 1.0, np.where(d == c, (X <= c).astype(float), (d - X) / (d - c)))
    return np.clip(np.minimum(up, down), 0.0, 1.0)


def rule_weights(memberships: list) -> np.ndarray:
    r"""The weights (B, k_1, ..., k_d) of the rules of a complete grid, :math:`w_r = \prod_i \mu_{i, r_i}` taken
    in input order from 1, from each input's memberships (B, k_i) in its sets."""
    B, d = memberships[0].shape[0], len(memberships)
    w = np.ones((B,) + (1,) * d)
    for i, mu in enumerate(memberships):
        shape = [B] + [1] * d
        shape[1 + i] = mu.shape[1]
        w = w * mu.reshape(shape)
    return w


def rule_output(weights: np.ndarray, consequents: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""``(output (B, p), total (B,))`` of a zero-order Takagi-Sugeno system from its rule weights (B, K) and the
    consequents (K, p): :math:`\sum_r w_r c_r / \sum_r w_r` by :func:`matmul_rows`, and :math:`\sum_r w_r`.  A row
    whose total is not > 0 fires no rule (its output is then not a number; the caller refuses it)."""
    total = weights.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return matmul_rows(weights, consequents) / total[:, None], total


def _check_rules(x, bounds, sizes, consequents) -> None:
    """The operands of :func:`trapezoid_rules`, checked (the compiled kernel does not check bounds): a ValueError
    naming the argument that does not fit the others, never a read out of bounds."""
    _check_shapes("trapezoid_rules", x.shape[0], (x, bounds, sizes, consequents))
    if bounds.shape[1] != 4 or np.any(sizes < 1) or np.any(sizes > bounds.shape[2]):
        raise ValueError(f"sizes: {np.asarray(sizes).tolist()} sets in bounds of shape {bounds.shape} "
                         f"(expected (d, 4, k) holding at least one set per input)")
    if consequents.shape[0] != int(np.prod(sizes)):
        raise ValueError(f"consequents: {consequents.shape[0]} rules, but the inputs' sets "
                         f"{np.asarray(sizes).tolist()} make {int(np.prod(sizes))}")


@_operation
def trapezoid_rules(x: np.ndarray, bounds: np.ndarray, sizes: np.ndarray,
                    consequents: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""A zero-order Takagi-Sugeno system whose input sets are all trapezoids (:class:`mmlib.core.fuzzy.TakagiSugeno`
    calls it): for inputs ``x`` (B, d), input i's ``sizes[i]`` sets ``bounds[i, :, :sizes[i]]`` (rows a, b, c, d of
    :func:`trapezoid_memberships`; ``bounds`` (d, 4, max k_i)) and the consequents (K, p) of the K = prod k_i rules in
    C order, ``(output (B, p), total weight (B,))``: the weights of :func:`rule_weights`, their sum and
    :func:`rule_output` of them.  A row whose total is not > 0 fires no rule (its output is then not a number; the
    caller refuses it).  The compiled form gives the bits of this one on the compiled kernels
    (``tests/test_gnss_fuzzy.py``): numpy's order of summation for the total, :func:`matmul_rows`'s for the output.
    Operands that do not fit each other are a ValueError naming the argument."""
    _check_rules(x, bounds, sizes, consequents)
    mus = [trapezoid_memberships(bounds[i, :, :sizes[i]], x[:, i]) for i in range(x.shape[1])]
    return rule_output(rule_weights(mus).reshape(x.shape[0], consequents.shape[0]), consequents)


def compiled_rule_count(count: int) -> bool:
    """Whether the compiled :func:`trapezoid_rules` sums ``count`` rule weights itself in numpy's order (more fall
    back to the numpy body, whose sum is numpy's recursion)."""
    return count <= _compiled_module().NUMPY_SUM_MAX


@trapezoid_rules.compiled
def _trapezoid_rules_compiled(x, bounds, sizes, consequents):
    _check_rules(x, bounds, sizes, consequents)
    kernels = _compiled_module()
    if consequents.shape[0] > kernels.NUMPY_SUM_MAX:     # the total in numpy's order needs its recursion: numpy's
        return trapezoid_rules.implementations["numpy"](x, bounds, sizes, consequents)     # (matmul_rows compiled)
    args = _writable([_contiguous(x), _contiguous(bounds), np.ascontiguousarray(sizes, dtype=np.int64),
                      _contiguous(consequents)])
    return kernels.trapezoid_rules(*args)


@_operation
def power(base: float, x: np.ndarray) -> np.ndarray:
    """``base ** x`` elementwise for any array ``x`` (e.g. the FLAS's levels from their base-10 logarithms): numpy's
    power on this path, the C library's ``pow`` one value at a time on the compiled one (numpy may evaluate it with a
    vector library on some CPUs: a whole run, :func:`fuzzy_imm_run`, then gives its step-by-step bits on every CPU)."""
    return float(base) ** np.asarray(x, dtype=float)


@power.compiled
def _power_compiled(base, x):
    x = np.asarray(x, dtype=np.float64)
    return _compiled_module().power(float(base), np.ascontiguousarray(x).reshape(-1)).reshape(x.shape)


# --------------------------------------------------------------------------- whole fused filter steps (compiled only)
def _initial_fused() -> bool:
    """``$MMLIB_FUSED``: ``0`` turns the fused filter steps off (every step then composes the operations above), ``1``
    or unset leaves them on."""
    env = os.environ.get("MMLIB_FUSED", "").strip()
    if env not in ("", "0", "1"):
        raise ValueError(f"MMLIB_FUSED: expected 0 or 1, got {env!r}")
    return env != "0"


_FUSED = [_initial_fused()]


def fused() -> bool:
    """Whether a filter or IMM step that can be fused (:func:`sigma_step`, :func:`imm_sigma_step`,
    :func:`strong_tracking_step`) is, and a run all of whose steps can be is one call (the whole runs of
    :data:`FUSED_STEPS`, from :func:`mmlib.core.estimation.run`): fusion on and the compiled kernels in use."""
    return _FUSED[0] and _KERNEL[0] == "numba"


@contextlib.contextmanager
def use_fused(on: bool) -> Iterator[None]:
    """Context manager: run the body with the fused filter steps on or off (``on`` a bool, else a ValueError naming it);
    the numbers are the same bits either way (``tests/test_fused.py``), only the time differs."""
    if not isinstance(on, bool):
        raise ValueError(f"on: expected True or False, got {on!r}")
    previous = _FUSED[0]
    _FUSED[0] = on
    try:
        yield
    finally:
        _FUSED[0] = previous


#: environment variable: the threads a fused step spreads its blocks of runs over (default: every core this process
#: may use); :func:`threads`
THREADS_VARIABLE = "MMLIB_THREADS"


def _initial_threads() -> int:
    """``$MMLIB_THREADS`` (a positive integer; anything else is a ValueError naming it), else the cores this process
    may use."""
    return _env.count_from_env(THREADS_VARIABLE, "threads")


_THREADS = [_initial_threads()]
_THREADS_HERE = threading.local()          # use_threads: this thread's own count, over the process's


def threads() -> int:
    """The threads a fused step (:func:`sigma_step`, :func:`imm_sigma_step`, :func:`strong_tracking_step`) of this
    thread spreads its runs over: :func:`use_threads` where it is in force, else ``$MMLIB_THREADS``, else every core
    this process may use.  The blocks of :data:`FUSED_BLOCK` runs are split between the threads, which run the compiled
    step at once (it holds no GIL); a run's numbers do not depend on the split (``tests/test_fused.py``).  The
    experiment layer runs every task of :func:`mmlib.experiment.executors.run_tasks` with one thread (the workers are
    the parallelism), and times every filter it times on one thread (a CPU time of one thread)."""
    return getattr(_THREADS_HERE, "count", None) or _THREADS[0]


@contextlib.contextmanager
def use_threads(count: int) -> Iterator[None]:
    """Context manager: this thread's fused steps use ``count`` threads (an integer >= 1, else a ValueError naming
    ``count``) in the body; other threads keep theirs."""
    if isinstance(count, bool) or not isinstance(count, int | np.integer) or count < 1:
        raise ValueError(f"count: expected a positive integer (threads), got {count!r}")
    previous = getattr(_THREADS_HERE, "count", None)
    _THREADS_HERE.count = int(count)
    try:
        yield
    finally:
        _THREADS_HERE.count = previous


_POOL: list = []                            # [(pid, helpers, executor)]: the helper threads of the fused steps
_POOL_LOCK = threading.Lock()


def _pool(helpers: int) -> cf.ThreadPoolExecutor:
    """This process's pool of at least ``helpers`` threads, made on first use and made again, larger, when a step
    needs more (the old pool's idle threads end once no step holds it: a thread pool's workers exit when it is
    garbage collected)."""
    with _POOL_LOCK:
        if not _POOL or _POOL[0][0] != os.getpid() or _POOL[0][1] < helpers:
            _POOL[:] = [(os.getpid(), helpers, cf.ThreadPoolExecutor(helpers, thread_name_prefix="mmlib-fused"))]
        return _POOL[0][2]


def _forget_pool_after_fork() -> None:
    """In a forked child: a new lock (the parent's may have been held at the fork) and no pool (its threads were
    not forked)."""
    global _POOL_LOCK
    _POOL_LOCK = threading.Lock()
    _POOL.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pool_after_fork)


def _run_ranges(B: int, block: int, count: int) -> list:
    """The runs ``[start, stop)`` of each thread of a fused step over B runs in blocks of ``block``: ``min(count,
    blocks)`` ranges of whole blocks (the last block may end short) whose numbers of blocks differ by at most one,
    covering 0..B-1 once, in order."""
    blocks = -(-B // block)
    k = max(1, min(count, blocks))
    q, extra = divmod(blocks, k)
    edges = [0]
    for i in range(k):
        edges.append(edges[-1] + q + (i < extra))
    return [(a * block, min(B, b * block)) for a, b in zip(edges, edges[1:])]


def _over_threads(step: Callable, args: tuple, outputs: tuple, B: int) -> tuple:
    """``step(*args, *outputs, start, stop, FUSED_BLOCK)`` for the ranges of runs of :func:`_run_ranges` at
    :func:`threads`, the first in this thread and the others at once in the pool's; returns ``outputs``, every run's
    rows written.  An exception of any range is raised once every range has finished.  The helper threads compute
    in the process's default floating-point environment (round to nearest, subnormals kept), as the caller's
    thread does: nothing in the library changes it."""
    args = _writable(args)
    ranges = _run_ranges(B, FUSED_BLOCK, threads())
    if len(ranges) == 1:
        step(*args, *outputs, 0, B, FUSED_BLOCK)
        return outputs
    pool = _pool(len(ranges) - 1)
    futures = [pool.submit(step, *args, *outputs, start, stop, FUSED_BLOCK) for start, stop in ranges[1:]]
    try:
        step(*args, *outputs, ranges[0][0], ranges[0][1], FUSED_BLOCK)
    finally:
        cf.wait(futures)
    for f in futures:
        f.result()
    return outputs


#: Runs per block of the fused steps: every intermediate of a step for this many runs (a few tens of KB for n = 4,
#: r = 3) stays in a core's L1/L2 cache while the loops over the runs stay long enough to vectorise.  A tuning choice
#: only: a run's numbers do not depend on it (``tests/test_fused.py``).
FUSED_BLOCK = 128

#: the names of the fused steps below, each a whole filter step in one compiled call (what a caller spies on to see
#: whether one was taken: ``bench/papers.py``, ``tests/test_fused.py``)
FUSED_STEPS = ("imm_sigma_step", "sigma_step", "strong_tracking_step", "sigma_run", "imm_sigma_run",
               "strong_tracking_run", "adaptive_run", "imm_layer_run", "ekf_run", "fuzzy_imm_run")

#: the measurement functions the fused steps evaluate themselves (:func:`mmlib.core._kernels._measure`)
MEASURE_LINEAR, MEASURE_RANGE_BEARING, MEASURE_PSEUDORANGES = 0, 1, 2


def imm_sigma_step(mu: np.ndarray, transition: np.ndarray, means: np.ndarray, covs: np.ndarray, xi: np.ndarray,
                   wm: np.ndarray, wc: np.ndarray, F: np.ndarray, Q: np.ndarray, z: np.ndarray, measure: tuple,
                   angular: ArrayLike, R: np.ndarray, with_cov: bool, log_2pi: float) -> tuple:
    r"""One IMM cycle of a sigma-point filter over linear mode dynamics in one compiled call (compiled kernels only;
    :func:`fused`): mixing, the rule's time update through :math:`F_j`, fresh points, the measurement function,
    the measurement moments, the residual, the Kalman update :math:`P - AA^T` and the IMM output, computed by the
    same loop bodies as the operations :func:`imm_mix`, :func:`sigma_point_predict_linear`, :func:`sigma_points`,
    :func:`measurement_moments`, :func:`kalman_moments` and :func:`imm_output` (the same bits as composing them,
    ``tests/test_fused.py``), the runs in blocks of :data:`FUSED_BLOCK`.

    ``mu`` (B, r), ``transition`` (r, r) rows "from", ``means`` (B, r, n), ``covs`` (B, r, n, n), the rule's unit
    points ``xi`` (M, n) and weights ``wm``, ``wc`` (M,), ``F`` (r, n, n), ``Q`` broadcasting against
    (B, r, n, n), ``z`` (B, m); ``measure`` = ``(kind, A, idx, sensor)``: :data:`MEASURE_LINEAR` with H = A (m, n),
    :data:`MEASURE_RANGE_BEARING` with the position indices idx = (i, j) and the ``sensor`` (x, y) in m, or
    :data:`MEASURE_PSEUDORANGES` with the satellites A (m, 3) in m and idx = the position and clock-bias indices
    (:func:`mmlib.core._kernels._measure`); ``angular`` (m,) the components whose residuals are wrapped; ``R``
    broadcasting against (B, r, m, m); ``log_2pi`` the constant of the log-likelihood.  Returns
    ``(means+, covs+, mu+, marginal, underflow, mean, cov, innovation, innovation_cov, failed)``
    (:func:`mmlib.core._kernels.imm_sigma_step`; ``cov`` None without ``with_cov``)."""
    B, r, n = mu.shape[0], mu.shape[1], means.shape[-1]
    lead = (B, r)
    # the kernel reads every run's own rows: a stack shared by the runs (read periodically by the composed step) is
    # broadcast to all of them first
    means, covs = _stack(means, 2, (B,)), _stack(covs, 3, (B,))
    angular = np.asarray(angular, dtype=np.bool_)
    _check_shapes("imm_sigma_step", B, (mu, transition, means, covs, xi, wm, wc, F, z, R, angular, Q))
    kernels, m = _compiled_module(), z.shape[-1]
    out = _over_threads(kernels.imm_sigma_step, (
        _contiguous(mu), _contiguous(transition), _contiguous(means), _contiguous(covs), _contiguous(xi),
        _contiguous(wm), _contiguous(wc), _contiguous(F), _periodic(Q, 2, lead), _contiguous(z),
        *_measure_args(measure, n, m), angular, _periodic(R, 2, lead), bool(with_cov), float(log_2pi)),
        kernels._imm_outputs(B, r, n, m, bool(with_cov)), B)
    return out[:6] + ((out[6] if with_cov else None),) + out[7:]


def sigma_step(mean: np.ndarray, cov: np.ndarray, xi: np.ndarray, wm: np.ndarray, wc: np.ndarray, F: np.ndarray,
               Q: np.ndarray, z: np.ndarray, measure: tuple, angular: ArrayLike, R: np.ndarray,
               log_2pi: float) -> tuple:
    r"""One step of a single-model sigma-point filter over linear dynamics in one compiled call (compiled kernels
    only; :func:`fused`): what :func:`sigma_point_predict_linear`, :func:`sigma_points`, the measurement function,
    :func:`measurement_moments`, the residual and :func:`kalman_moments` compute in turn, the same bits.  ``mean``
    (B, n), ``cov`` (B, n, n), the rule ``xi``, ``wm``, ``wc``, ``F`` (n, n), ``Q`` broadcasting against (B, n, n),
    ``z`` (B, m), ``measure``, ``angular``, ``R``, ``log_2pi`` as :func:`imm_sigma_step`.  Returns ``(mean+, cov+,
    loglik, innovation, S, failed)`` (each (B, ...))."""
    B, n = mean.shape
    cov = _stack(cov, 2, (B,))                 # a covariance shared by the runs: every run's own copy
    angular = np.asarray(angular, dtype=np.bool_)
    _check_shapes("sigma_step", B, (mean, cov, xi, wm, wc, F, z, R, angular, Q))
    kernels, m = _compiled_module(), z.shape[-1]
    return _over_threads(kernels.sigma_step, (
        _contiguous(mean), _contiguous(cov), _contiguous(xi), _contiguous(wm), _contiguous(wc), _contiguous(F),
        _periodic(Q, 2, (B,)), _contiguous(z), *_measure_args(measure, n, m), angular, _periodic(R, 2, (B,)),
        float(log_2pi)), kernels._step_outputs(B, n, m), B)


def strong_tracking_step(mean: np.ndarray, cov: np.ndarray, xi: np.ndarray, wm: np.ndarray, wc: np.ndarray,
                         F: np.ndarray, Q: np.ndarray, z: np.ndarray, measure: tuple, angular: ArrayLike, R: np.ndarray,
                         V: np.ndarray | None, rho: float, beta: float, log_2pi: float) -> tuple:
    r"""One step of a strong-tracking sigma-point filter over linear dynamics in one compiled call (compiled kernels
    only; :func:`fused`): what :class:`mmlib.core.layers.strong_tracking.StrongTracking` (Jacobian-free form) composes
    over a plain sigma-point filter -- :func:`sigma_point_predict_linear`, the measurement moments, the innovation,
    :math:`V` of Eq. 17, :func:`fading_factor`, the inflated prior :math:`\lambda(P^l - Q) + Q` predicted again where
    :math:`\lambda > 1`, :func:`kalman_moments` -- the same bits.  ``mean`` ... ``log_2pi`` as :func:`sigma_step`;
    ``V`` (B, m, m) the last smoothed innovation outer product, or None to restart it (:math:`V = vv^T`); ``rho`` the
    forgetting and ``beta`` the softening factor.  Returns ``(mean+, cov+, loglik, innovation, S, failed, V, fading)``
    (each (B, ...))."""
    B, n = mean.shape
    m = z.shape[-1]
    cov = _stack(cov, 2, (B,))                 # a covariance shared by the runs: every run's own copy
    angular = np.asarray(angular, dtype=np.bool_)
    Vs = np.zeros((1, m, m)) if V is None else _stack(V, 2, (B,))
    _check_shapes("strong_tracking_step", B, (mean, cov, xi, wm, wc, F, z, R, angular, Q, Vs))
    kernels = _compiled_module()
    return _over_threads(kernels.strong_tracking_step, (
        _contiguous(mean), _contiguous(cov), _contiguous(xi), _contiguous(wm), _contiguous(wc), _contiguous(F),
        _periodic(Q, 2, (B,)), _contiguous(z), *_measure_args(measure, n, m), angular, _periodic(R, 2, (B,)),
        _contiguous(Vs), V is None, float(rho), float(beta), float(log_2pi)),
        kernels._step_outputs(B, n, m) + (np.empty((B, m, m)), np.empty(B)), B)


def packed_steps(zs: Sequence[np.ndarray], measures: Sequence[tuple], angulars: Sequence[ArrayLike],
                 Rs: Sequence[np.ndarray], n: int) -> tuple | None:
    r"""K measurement steps packed for a whole run in one compiled call (:func:`sigma_run`, :func:`imm_sigma_run`):
    step k's measurements ``zs[k]`` (B, m_k), measurement function ``measures[k]`` = ``(kind, A, idx, sensor)``
    (:func:`imm_sigma_step`), ``angulars[k]`` (m_k,) and covariance ``Rs[k]`` (m_k, m_k) shared by the runs, for an
    n-state.  Returns ``(z (B, sum m_k), zoff (K+1,), kind, A (sum m_k, a), idx, sensor, angular (sum m_k,),
    R (sum m_k, max m_k))`` -- step k's rows zoff[k]..zoff[k+1]-1 -- or None where one call cannot take the steps:
    a kind, position index or sensor that changes between steps, or an R that is not one (m_k, m_k) matrix.  A
    measurement function that does not fit its step is a ValueError naming ``measure`` (:func:`_measure_args`)."""
    if not zs:
        return None
    kind0, idx0, sensor0 = None, None, None
    As, offsets = [], [0]
    for z, measure, R in zip(zs, measures, Rs):
        m = z.shape[-1]
        kind, A, idx, sensor = _measure_args(measure, n, m)
        if kind0 is None:
            kind0, idx0, sensor0 = kind, idx, sensor
        elif kind != kind0 or not np.array_equal(idx, idx0) or not np.array_equal(sensor, sensor0):
            return None
        if np.shape(R) != (m, m):
            return None
        As.append(A if kind != MEASURE_RANGE_BEARING else np.zeros((m, 1)))
        offsets.append(offsets[-1] + m)
    widths = {A.shape[1] for A in As}
    if len(widths) != 1:
        return None
    mmax = max(z.shape[-1] for z in zs)
    R_all = np.zeros((offsets[-1], mmax))
    for k, R in enumerate(Rs):
        R_all[offsets[k]:offsets[k + 1], :offsets[k + 1] - offsets[k]] = R
    angular = np.concatenate([np.broadcast_to(np.asarray(a, dtype=np.bool_), (z.shape[-1],))
                              for a, z in zip(angulars, zs)])
    z_all = np.ascontiguousarray(np.concatenate([np.asarray(z, dtype=np.float64) for z in zs], axis=-1))
    return (z_all, np.array(offsets, dtype=np.int64), kind0, np.ascontiguousarray(np.concatenate(As)), idx0,
            sensor0, angular, R_all)


def _check_offsets(zoff: np.ndarray, R: np.ndarray, z: np.ndarray, B: int) -> None:
    """The step offsets of :func:`packed_steps`: int64 from 0 to R's rows, at least one step, none wider than R, and
    measurements of every one of the B runs (the kernels read step k's rows zoff[k]..zoff[k+1]-1 and each run's own
    row without checking bounds); else a ValueError naming ``packed``."""
    widths = np.diff(zoff) if isinstance(zoff, np.ndarray) and zoff.ndim == 1 and zoff.dtype == np.int64 else None
    if widths is None or widths.size == 0 or zoff[0] != 0 or zoff[-1] != R.shape[0] or (widths < 1).any() \
            or widths.max() > R.shape[1]:
        raise ValueError(f"packed: step offsets {zoff!r} do not describe the {R.shape[0]} packed measurements")
    if z.shape[0] != B:
        raise ValueError(f"packed: measurements of {z.shape[0]} runs for a state of {B} runs")


def _run_outputs(B: int, K: int, n: int, keep_cov: bool, nis: bool, nees: bool) -> tuple:
    """The outputs of a whole run (:func:`sigma_run`), run axis first: means (B, K, n), covariances (B, K, n, n) or
    empty, failed (B, K), NIS and NEES (B, K) or empty (every computed entry written by the kernel)."""
    return (np.empty((B, K, n)), np.empty((B, K, n, n) if keep_cov else (0, 0, 0, 0)),
            np.zeros((B, K), dtype=np.bool_), np.empty((B, K) if nis else (0, 0)),
            np.empty((B, K) if nees else (0, 0)))


def _truth_operand(truth, B: int, K: int, n: int) -> np.ndarray:
    """``truth`` x_1..x_K (B, K, n) as the kernels read it, or an empty (0, 0, 0) without one."""
    if truth is None:
        return np.zeros((0, 0, 0))
    truth = np.ascontiguousarray(truth, dtype=np.float64)
    if truth.shape != (B, K, n):
        raise ValueError(f"truth: expected shape ({B}, {K}, {n}) (x_1..x_K), got {truth.shape}")
    return truth


def sigma_run(mean: np.ndarray, cov: np.ndarray, xi: np.ndarray, wm: np.ndarray, wc: np.ndarray, F: np.ndarray,
              Q: np.ndarray, packed: tuple, log_2pi: float, *, keep_cov: bool, nis: bool,
              truth: np.ndarray | None = None) -> tuple:
    r"""Every step of a single-model sigma-point filter over linear dynamics in one compiled call (compiled kernels
    only; :func:`fused`): step k is what :func:`sigma_step` computes on step k - 1's posterior, the same bits, the
    state never leaving the compiled loop.  ``mean`` (B, n), ``cov`` (B, n, n), the rule ``xi``, ``wm``, ``wc``,
    ``F`` (n, n), ``Q`` broadcasting against (B, n, n), ``packed`` the K measurement steps (:func:`packed_steps`),
    ``log_2pi``.  Returns ``(means (B, K, n), covs (B, K, n, n) or None without ``keep_cov``, failed (B, K),
    nis (B, K) or None, nees (B, K) or None)``: the NIS of each step's innovation with ``nis``, the NEES of each
    posterior against ``truth`` x_1..x_K (B, K, n) when given, each as :func:`normalised_square` computes it."""
    return _single_run(mean, cov, xi, wm, wc, F, Q, packed, log_2pi, False, keep_cov, nis, truth)


def _single_run(mean, cov, xi, wm, wc, F, Q, packed, log_2pi, ekf: bool, keep_cov: bool, nis: bool, truth) -> tuple:
    """:func:`sigma_run`, or with ``ekf`` :func:`ekf_run` (the rule's operands then unused): one kernel."""
    B, n = mean.shape
    z, zoff, kind, A, idx, sensor, angular, R = packed
    K = zoff.shape[0] - 1
    cov = _stack(cov, 2, (B,))
    _check_shapes("sigma_run", B, (mean, cov, xi, wm, wc, F, z, A, R, angular, Q))
    _check_offsets(zoff, R, z, B)
    out = _over_threads(_compiled_module().sigma_run, (
        _contiguous(mean), _contiguous(cov), _contiguous(xi), _contiguous(wm), _contiguous(wc), _contiguous(F),
        _periodic(Q, 2, (B,)), z, zoff, kind, A, idx, sensor, angular, R, float(log_2pi), bool(ekf),
        _truth_operand(truth, B, K, n), bool(nis), bool(keep_cov)),
        _run_outputs(B, K, n, keep_cov, nis, truth is not None), B)
    means, covs, failed, nis_out, nees_out = out
    return means, covs if keep_cov else None, failed, nis_out if nis else None, nees_out if truth is not None else None


def fuzzy_imm_run(mu: np.ndarray, transition: np.ndarray, means: np.ndarray, covs: np.ndarray, xi: np.ndarray,
                  wm: np.ndarray, wc: np.ndarray, F: np.ndarray, affine: tuple, levels: np.ndarray,
                  initial: np.ndarray, packed: tuple, with_cov: bool, log_2pi: float, *, frozen: bool,
                  normalise_innovation: bool, refs: np.ndarray, history: np.ndarray, filled: np.ndarray,
                  rule_base: tuple, keep_cov: bool, nis: bool, truth: np.ndarray | None = None) -> tuple | None:
    r"""Every cycle of a noise-adaptive IMM of a sigma-point filter over linear mode dynamics whose modes' process
    noise is affine in their levels, :math:`Q(\ell) = \ell\,U + B` (``affine`` = (U, B), each (n, n)), and whose
    controller is the FLAS (Tseng et al. 2011; :class:`mmlib.core.layers.fuzzy_noise.FuzzyNoiseBounds`), in one
    compiled call (compiled kernels only; :func:`fused`): what the layer computes step by step
    (:class:`mmlib.core.layers.adaptive_imm.NoiseAdaptiveIMM`, :class:`~mmlib.core.layers.adaptive_imm.
    WindowedNoiseAdaptiveIMM`), the same bits.  ``mu`` ... ``F``, ``packed``, ``with_cov``, ``log_2pi``, ``keep_cov``,
    ``nis``, ``truth`` as :func:`imm_sigma_run`; ``levels`` (B, r) the state's levels, ``initial`` (r,) those that
    replace a level that is not finite; ``frozen`` keeps the levels; the degrees of divergence over the mixture prior's
    predicted innovation variance (``normalise_innovation``) or ``refs[k]`` (K,) at step k, averaged over the last
    epochs of ``history`` (B, W, 2) (``filled`` (B,) of them real); ``rule_base`` = (bounds, sizes, consequents) of
    :func:`trapezoid_rules`.  Returns ``(means, covs or None, mu, failed, underflow, nis or None, nees or None,
    levels (B, K, r))``, each step's levels as the state held them; None where the controller refuses an input (a
    reference variance not > 0, a degree of divergence firing no rule: the layer step by step raises)."""
    B, r, n = mu.shape[0], mu.shape[1], means.shape[-1]
    z, zoff, kind, A, idx, sensor, angular, R = packed
    K = zoff.shape[0] - 1
    if (keep_cov or truth is not None) and not with_cov:
        raise ValueError("with_cov: the fused covariance is needed to keep it or for the NEES")
    unit, base = (_contiguous(a) for a in affine)
    bounds, sizes, cons = rule_base
    bounds, sizes, cons = _contiguous(bounds), np.ascontiguousarray(sizes, dtype=np.int64), _contiguous(cons)
    means, covs = _stack(means, 2, (B,)), _stack(covs, 3, (B,))
    history, filled = _contiguous(history), np.ascontiguousarray(filled, dtype=np.int64)
    refs = _contiguous(refs)
    _check_shapes("fuzzy_imm_run", B, (mu, transition, means, covs, xi, wm, wc, F, unit, base, levels, initial, z, A,
                                       R, angular, history, filled))
    _check_offsets(zoff, R, z, B)
    kernels = _compiled_module()
    if history.shape[1] < 1 or history.shape[2] != 2 or history.shape[0] != B or filled.shape != (B,) \
            or refs.shape != (K,) or cons.shape[1] != r or bounds.shape[:2] != (2, 4) \
            or sizes.shape != (2,) or int(np.prod(sizes)) != cons.shape[0] or cons.shape[0] > kernels.NUMPY_SUM_MAX \
            or (sizes > bounds.shape[2]).any() or (sizes < 1).any():
        raise ValueError(f"rule_base: bounds {bounds.shape}, sizes {sizes.tolist()}, consequents {cons.shape} with "
                         f"history {history.shape} and refs {refs.shape} do not describe a two-input rule base of "
                         f"{r} outputs")
    nees = truth is not None
    means_out, covs_out, failed, nis_out, nees_out = _run_outputs(B, K, n, keep_cov, nis, nees)
    refused = np.zeros(B, dtype=np.bool_)
    outputs = (means_out, covs_out, np.empty((B, K, r)), failed, np.zeros((B, K), dtype=np.bool_), np.empty((B, K, r)),
               nis_out, nees_out, refused)
    out = _over_threads(kernels.fuzzy_imm_run, (
        _contiguous(mu), _contiguous(transition), _contiguous(means), _contiguous(covs), _contiguous(xi),
        _contiguous(wm), _contiguous(wc), _contiguous(F), unit, base, _contiguous(levels), _contiguous(initial), z,
        zoff, kind, A, idx, sensor, angular, R, bool(with_cov), float(log_2pi), _truth_operand(truth, B, K, n),
        bool(nis), bool(keep_cov), bool(frozen), bool(normalise_innovation), refs, history, filled, bounds, sizes,
        cons, 10.0), outputs, B)
    means_k, covs_k, mu_k, failed, underflow, diag, nis_out, nees_out, refused = out
    if refused.any():
        return None
    return (means_k, covs_k if keep_cov else None, mu_k, failed, underflow, nis_out if nis else None,
            nees_out if nees else None, diag)


def ekf_run(mean: np.ndarray, cov: np.ndarray, F: np.ndarray, Q: np.ndarray, packed: tuple, log_2pi: float, *,
            keep_cov: bool, nis: bool, truth: np.ndarray | None = None) -> tuple:
    r"""Every step of an extended Kalman filter over linear dynamics (:class:`mmlib.core.filters.ExtendedKalmanFilter`,
    the Joseph-form update) in one compiled call (compiled kernels only; :func:`fused`): step k is what the filter's
    predict and update compute from step k - 1's posterior with the compiled operations, the same bits.  ``mean``,
    ``cov``, ``F``, ``Q``, ``packed``, ``log_2pi`` and the returns as :func:`sigma_run`."""
    xi, wm, wc = no_rule_operands(mean.shape[-1])
    return _single_run(mean, cov, xi, wm, wc, F, Q, packed, log_2pi, True, keep_cov, nis, truth)


def imm_layer_run(mu: np.ndarray, transition: np.ndarray, means: np.ndarray, covs: np.ndarray, xi: np.ndarray,
                  wm: np.ndarray, wc: np.ndarray, F: np.ndarray, Q: np.ndarray, packed: tuple, cubature: bool,
                  adaptive: tuple | None, with_cov: bool, log_2pi: float, *, keep_cov: bool, nis: bool,
                  truth: np.ndarray | None = None, ekf: bool = False) -> tuple | None:
    r"""Every IMM cycle in one compiled call (compiled kernels only; :func:`fused`) of an IMM over linear mode
    dynamics whose interaction is moment matching or, with ``cubature``, the cubature principle (:func:`cubature_mix`),
    and whose mode filters are sigma-point filters, extended Kalman filters (``ekf``; the rule's arguments are then
    not used) or, with ``adaptive`` = ``(window, psi, zeta, include_current, inflate_only)``, innovation-adaptive
    sigma-point ones (:class:`mmlib.core.layers.adaptive.InnovationAdaptive`, from empty
    windows): cycle k is what the composed IMM computes from cycle k - 1's state, the same bits.  Arguments and
    returns as :func:`imm_sigma_run` (the NIS with the innovation covariances the modes' updates used); None where
    the composed cycles would not be these (cubature mixing of one mode or a one-dimensional state, where numpy's
    product is ``dot``; an adaptive layer's steps :func:`_adaptive_declines` declines)."""
    B, r, n = mu.shape[0], mu.shape[1], means.shape[-1]
    z, zoff, kind, A, idx, sensor, angular, R = packed
    K = zoff.shape[0] - 1
    if (cubature and (r < 2 or n < 2)) or (adaptive is not None and _adaptive_declines(zoff, n, adaptive[2])):
        return None
    window, psi, zeta, include_current, inflate_only = (2, 1.0, False, False, False) if adaptive is None \
        else adaptive
    if (keep_cov or truth is not None) and not with_cov:
        raise ValueError("with_cov: the fused covariance is needed to keep it or for the NEES")
    means, covs = _stack(means, 2, (B,)), _stack(covs, 3, (B,))
    _check_shapes("imm_layer_run", B, (mu, transition, means, covs, xi, wm, wc, F, z, A, R, angular, Q))
    _check_offsets(zoff, R, z, B)
    means_out, covs_out, failed, nis_out, nees_out = _run_outputs(B, K, n, keep_cov, nis, truth is not None)
    outputs = (means_out, covs_out, np.empty((B, K, r)), failed, np.zeros((B, K), dtype=np.bool_), nis_out, nees_out)
    out = _over_threads(_compiled_module().imm_layer_run, (
        _contiguous(mu), _contiguous(transition), _contiguous(means), _contiguous(covs), _contiguous(xi),
        _contiguous(wm), _contiguous(wc), _contiguous(F), _periodic(Q, 2, (B, r)), z, zoff, kind, A, idx, sensor,
        angular, R, bool(cubature), adaptive is not None, bool(ekf), int(window), float(psi), bool(zeta),
        bool(include_current),
        bool(inflate_only), bool(with_cov), float(log_2pi), _truth_operand(truth, B, K, n), bool(nis), bool(keep_cov)),
        outputs, B)
    means_k, covs_k, mu_k, failed, underflow, nis_out, nees_out = out
    return (means_k, covs_k if keep_cov else None, mu_k, failed, underflow, nis_out if nis else None,
            nees_out if truth is not None else None)


def strong_tracking_run(mean: np.ndarray, cov: np.ndarray, xi: np.ndarray, wm: np.ndarray, wc: np.ndarray,
                        F: np.ndarray, Q: np.ndarray, packed: tuple, V: np.ndarray | None, rho: float, beta: float,
                        log_2pi: float, *, keep_cov: bool, nis: bool, truth: np.ndarray | None = None,
                        ekf: bool = False, jacobian: bool = False) -> tuple | None:
    r"""Every step of a strong-tracking sigma-point filter over linear dynamics in one compiled call (compiled kernels
    only; :func:`fused`): step k is what :func:`strong_tracking_step` computes from step k - 1's posterior and smoothed
    innovation outer product, restarted where the measurement dimension changes (the same bits).  ``mean`` ...
    ``packed`` and ``log_2pi`` as :func:`sigma_run`; ``V`` (B, m_0, m_0) the state's last smoothed outer product, or
    None to restart it at the first step (as where its dimension is not the first step's); ``rho``, ``beta`` the
    forgetting and softening factors; ``ekf``: over the extended Kalman filter (:func:`ekf_run`'s steps; ``xi``, ``wm``,
    ``wc`` unused), and ``jacobian`` with the fading factor's Jacobian form.  Returns :func:`sigma_run`'s ``(means,
    covs, failed, nis, nees)``, or None for the Jacobian form with a step measuring one component (numpy's product
    is ``gemv`` there, which sums in another order)."""
    B, n = mean.shape
    z, zoff, kind, A, idx, sensor, angular, R = packed
    K = zoff.shape[0] - 1
    if jacobian and not ekf:
        raise ValueError("jacobian: the Jacobian form of the fading factor needs the EKF base (ekf=True)")
    if ekf and jacobian and (np.diff(zoff) < 2).any():
        return None
    m0 = int(zoff[1] - zoff[0]) if zoff.shape[0] > 1 else 0
    cov = _stack(cov, 2, (B,))
    restart = V is None or np.shape(V)[-1] != m0
    Vs = np.zeros((1, 1, 1)) if restart else _stack(V, 2, (B,))
    _check_shapes("strong_tracking_run", B, (mean, cov, xi, wm, wc, F, z, A, R, angular, Q, Vs))
    _check_offsets(zoff, R, z, B)
    out = _over_threads(_compiled_module().strong_tracking_run, (
        _contiguous(mean), _contiguous(cov), _contiguous(xi), _contiguous(wm), _contiguous(wc), _contiguous(F),
        _periodic(Q, 2, (B,)), z, zoff, kind, A, idx, sensor, angular, R, _contiguous(Vs), bool(restart), float(rho),
        float(beta), float(log_2pi), bool(ekf), bool(jacobian), _truth_operand(truth, B, K, n), bool(nis),
        bool(keep_cov)),
        _run_outputs(B, K, n, keep_cov, nis, truth is not None), B)
    means, covs, failed, nis_out, nees_out = out
    return means, covs if keep_cov else None, failed, nis_out if nis else None, nees_out if truth is not None else None


def _adaptive_declines(zoff: np.ndarray, n: int, zeta: bool) -> bool:
    """Whether the compiled adaptive layer would not compute the layer's steps over the packed steps of offsets
    ``zoff``: a step of one component (the composed product is numpy's ``dot``), or, with ``zeta``, traces of more
    terms than :data:`mmlib.core._kernels.NUMPY_SUM_MAX` (numpy sums those in another order)."""
    widths = np.diff(zoff)
    return bool((widths < 2).any()) or (zeta and max(int(widths.max()), n) > _compiled_module().NUMPY_SUM_MAX)


def no_rule_operands(n: int) -> tuple:
    """``(xi (1, n), wm (1,), wc (1,))`` of zeros: the rule operands of a whole run whose filter has no rule (the
    extended Kalman filter; :func:`ekf_run`'s IMM and strong-tracking forms), which the kernel does not read."""
    return np.zeros((1, n)), np.zeros(1), np.zeros(1)


def adaptive_run(mean: np.ndarray, cov: np.ndarray, xi: np.ndarray, wm: np.ndarray, wc: np.ndarray, F: np.ndarray,
                 Q: np.ndarray, packed: tuple, window: int, psi: float, zeta: bool, include_current: bool,
                 inflate_only: bool, log_2pi: float, *, keep_cov: bool, nis: bool,
                 truth: np.ndarray | None = None) -> tuple | None:
    r"""Every step of an innovation-adaptive sigma-point filter over linear dynamics
    (:class:`mmlib.core.layers.adaptive.InnovationAdaptive`: NAUKF, IAE-AUKF) in one compiled call (compiled kernels
    only; :func:`fused`), from an empty innovation window: step k is what the layer's predict and update compute from
    step k - 1's posterior and window, the same bits.  ``mean`` ... ``packed`` and ``log_2pi`` as :func:`sigma_run`;
    ``window``, ``psi``, ``zeta``, ``include_current``, ``inflate_only`` the layer's fields.  Returns
    :func:`sigma_run`'s ``(means, covs, failed, nis, nees)`` (the NIS with the innovation covariance the update
    used), or None where the layer's steps would not be these (:func:`_adaptive_declines`: a step measuring one
    component, numpy's ``dot`` there; traces longer than numpy's order the kernel reproduces)."""
    B, n = mean.shape
    z, zoff, kind, A, idx, sensor, angular, R = packed
    K = zoff.shape[0] - 1
    if _adaptive_declines(zoff, n, zeta):
        return None
    cov = _stack(cov, 2, (B,))
    _check_shapes("adaptive_run", B, (mean, cov, xi, wm, wc, F, z, A, R, angular, Q))
    _check_offsets(zoff, R, z, B)
    out = _over_threads(_compiled_module().adaptive_run, (
        _contiguous(mean), _contiguous(cov), _contiguous(xi), _contiguous(wm), _contiguous(wc), _contiguous(F),
        _periodic(Q, 2, (B,)), z, zoff, kind, A, idx, sensor, angular, R, int(window), float(psi), bool(zeta),
        bool(include_current), bool(inflate_only), float(log_2pi), _truth_operand(truth, B, K, n), bool(nis),
        bool(keep_cov)),
        _run_outputs(B, K, n, keep_cov, nis, truth is not None), B)
    means, covs, failed, nis_out, nees_out = out
    return means, covs if keep_cov else None, failed, nis_out if nis else None, nees_out if truth is not None else None


def imm_sigma_run(mu: np.ndarray, transition: np.ndarray, means: np.ndarray, covs: np.ndarray, xi: np.ndarray,
                  wm: np.ndarray, wc: np.ndarray, F: np.ndarray, Q: np.ndarray, packed: tuple, with_cov: bool,
                  log_2pi: float, *, keep_cov: bool, nis: bool, truth: np.ndarray | None = None) -> tuple:
    r"""Every IMM cycle of a sigma-point filter over linear mode dynamics in one compiled call (compiled kernels only;
    :func:`fused`): cycle k is what :func:`imm_sigma_step` computes from cycle k - 1's mode probabilities and mode
    posteriors, the same bits.  ``mu`` (B, r), ``transition`` (r, r) rows "from", ``means`` (B, r, n), ``covs``
    (B, r, n, n), the rule, ``F`` (r, n, n), ``Q`` broadcasting against (B, r, n, n), ``packed`` the K measurement steps
    (:func:`packed_steps`), ``with_cov`` the fused covariance (needed by ``keep_cov`` and ``truth``), ``log_2pi``.
    Returns ``(means (B, K, n), covs (B, K, n, n) or None, mu (B, K, r), failed (B, K) (some mode filter failed),
    underflow (B, K) (every mode's likelihood underflowed), nis (B, K) or None, nees (B, K) or None)``: the fused
    estimates, the NIS of the mixture prior's innovation and the NEES of the fused estimate (:func:`sigma_run`)."""
    B, r, n = mu.shape[0], mu.shape[1], means.shape[-1]
    z, zoff, kind, A, idx, sensor, angular, R = packed
    K = zoff.shape[0] - 1
    if (keep_cov or truth is not None) and not with_cov:
        raise ValueError("with_cov: the fused covariance is needed to keep it or for the NEES")
    means, covs = _stack(means, 2, (B,)), _stack(covs, 3, (B,))
    _check_shapes("imm_sigma_run", B, (mu, transition, means, covs, xi, wm, wc, F, z, A, R, angular, Q))
    _check_offsets(zoff, R, z, B)
    nees = truth is not None
    means_out, covs_out, failed, nis_out, nees_out = _run_outputs(B, K, n, keep_cov, nis, nees)
    outputs = (means_out, covs_out, np.empty((B, K, r)), failed, np.zeros((B, K), dtype=np.bool_), nis_out, nees_out)
    out = _over_threads(_compiled_module().imm_sigma_run, (
        _contiguous(mu), _contiguous(transition), _contiguous(means), _contiguous(covs), _contiguous(xi),
        _contiguous(wm), _contiguous(wc), _contiguous(F), _periodic(Q, 2, (B, r)), z, zoff, kind, A, idx, sensor,
        angular, R, bool(with_cov), float(log_2pi), _truth_operand(truth, B, K, n), bool(nis), bool(keep_cov)),
        outputs, B)
    means_k, covs_k, mu_k, failed, underflow, nis_out, nees_out = out
    return (means_k, covs_k if keep_cov else None, mu_k, failed, underflow, nis_out if nis else None,
            nees_out if nees else None)


def _measure_args(measure: tuple, n: int, m: int) -> tuple:
    """``(kind, A, idx, sensor)`` of a fused step's measurement function as the compiled kernel takes them, checked
    against the state dimension ``n`` and the measurement dimension ``m`` (the kernel does not check bounds: a
    mismatch, or an index outside ``[-n, n)``, is a ValueError naming ``measure``, never a read out of bounds)."""
    kind, A, idx, sensor = measure
    A, idx, sensor = _contiguous(A), np.asarray(idx, dtype=np.int64), _contiguous(sensor)
    expected = {MEASURE_LINEAR: ((m, n), 0), MEASURE_RANGE_BEARING: (None, 2), MEASURE_PSEUDORANGES: ((m, 3), 4)}
    if kind not in expected or (expected[kind][0] is not None and A.shape != expected[kind][0]) \
            or idx.shape != (expected[kind][1],) or ((idx < -n) | (idx >= n)).any() or sensor.shape != (2,) \
            or (kind == MEASURE_RANGE_BEARING and m != 2):
        raise ValueError(f"measure: kind {kind!r} with A {A.shape}, idx {tuple(idx.tolist())}, sensor {sensor.shape} "
                         f"does not describe a measurement function of {m} components of an {n}-state")
    return int(kind), A, idx % n, sensor


# --------------------------------------------------------------------------- fused filter steps
def linear_transition(x: np.ndarray, F: np.ndarray) -> np.ndarray:
    """:math:`F x` for states or sigma points ``x`` (..., n): ``F`` (n, n) one matrix for all, or (r, n, n) one
    per mode, applied to the mode axis of ``x`` at -3 ((..., r, p, n), one :func:`matmul_rows` per mode), or
    broadcast (``x @ F^T``) when ``x`` has no such axis.  Returns (..., n); a run's numbers do not depend on
    the batch size (:func:`matmul_rows`).  The transition of the linear models of :mod:`mmlib.core.models`."""
    if F.ndim == 2:
        return matmul_rows(x, F.T)
    if x.ndim >= 3 and x.shape[-3] == F.shape[0]:
        return np.stack([matmul_rows(x[..., j, :, :], Fj.T) for j, Fj in enumerate(F)], axis=-3)
    return x @ np.swapaxes(F, -1, -2)


@_operation
def linear_predict(mean: np.ndarray, cov: np.ndarray, F: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""The Kalman time update through linear dynamics, :math:`(Fm, FPF^T + Q)`: ``mean`` (..., n), ``cov``
    (..., n, n), ``F`` (n, n) or (r, n, n) (one per mode, against a mode axis at -2 of ``mean``, as in
    :func:`linear_transition`) and ``Q`` broadcasting against (..., n, n).  The numpy body is the EKF's time
    update (:func:`congruence` of the Jacobian F, :func:`linear_transition` of the mean)."""
    cov_p, _ = congruence(np.broadcast_to(F, mean.shape[:-1] + F.shape[-2:]), cov, Q)
    return linear_transition(mean[..., None, :], F)[..., 0, :], cov_p


@linear_predict.compiled
def _linear_predict_compiled(mean, cov, F, Q):
    lead = mean.shape[:-1]
    n = mean.shape[-1]
    flat = _stack(mean, 1)
    m, c = _call("linear_predict", flat.shape[0], flat, _stack(cov, 2, lead), _periodic(F, 2, lead),
                 _periodic(Q, 2, lead))
    return m.reshape(lead + (n,)), c.reshape(lead + (n, n))


@_operation
def sigma_point_predict_linear(mean: np.ndarray, cov: np.ndarray, xi: np.ndarray, wm: np.ndarray, wc: np.ndarray,
                               F: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Sigma-point time update through linear dynamics: the unit points ``xi`` (M, n) about ``mean`` (..., n)
    with covariance ``cov`` (..., n, n) (:func:`sigma_points`), mapped by ``F`` (:func:`linear_transition`),
    :math:`\hat x^- = \sum_p w^m_p Y_p` and :math:`P^- = \sum_p w^c_p (Y_p - \hat x^-)(Y_p - \hat x^-)^T + Q`
    with the rule's weights ``wm``, ``wc`` (M,) and ``Q`` broadcasting against (..., n, n).  Returns
    ``(mean-, cov-)``; a run whose covariance is not positive definite gets NaN moments."""
    X, _ = sigma_points(mean, cov, xi)
    Y = linear_transition(X, F)
    mean_p = weighted_mean(Y, wm)
    cov_p, _ = weighted_covariances(Y - mean_p[..., None, :], wc, None, Q)
    return mean_p, cov_p


@sigma_point_predict_linear.compiled
def _sigma_point_predict_linear_compiled(mean, cov, xi, wm, wc, F, Q):
    lead = mean.shape[:-1]
    n = mean.shape[-1]
    flat = _stack(mean, 1)
    m, c, _ = _call("sigma_point_predict_linear", flat.shape[0], flat, _stack(cov, 2, lead), _contiguous(xi),
                    _contiguous(wm), _contiguous(wc), _periodic(F, 2, lead), _periodic(Q, 2, lead))
    return m.reshape(lead + (n,)), c.reshape(lead + (n, n))


@_operation
def measurement_moments(X: np.ndarray, mean: np.ndarray, Z: np.ndarray, wm: np.ndarray, wc: np.ndarray,
                        angular: ArrayLike, R: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Sigma-point measurement moments: points ``X`` (..., M, n) about ``mean`` (..., n), their images ``Z``
    (..., M, m), the rule's weights ``wm``, ``wc`` (M,), the measurement's ``angular`` components (m,) and
    noise ``R`` broadcasting against (..., m, m).  :math:`\hat z = \sum_p w^m_p Z_p`, taken about the first
    point when a component is an angle (:math:`Z_0 + \sum_p w^m_p\,\mathrm{res}(Z_p, Z_0)`, the angles
    wrapped to :math:`(-\pi, \pi]`, :func:`wrap_angle`), :math:`dz_p = \mathrm{res}(Z_p, \hat z)`,
    :math:`S = \sum_p w^c_p\,dz_p dz_p^T + R`, :math:`P_{xz} = \sum_p w^c_p (X_p - m)\,dz_p^T`: the
    ``average`` and ``residual`` of :mod:`mmlib.core.models`'s measurement models.  Returns
    ``(z_pred (..., m), S (..., m, m), Pxz (..., n, m))``."""
    angles = [c for c, flag in enumerate(angular) if flag]
    if angles:
        ref = Z[..., :1, :]
        z_pred = _wrapped(ref[..., 0, :] + wm @ _wrapped(np.subtract(Z, ref), angles), angles)
        dz = _wrapped(np.subtract(Z, z_pred[..., None, :]), angles)
    else:
        z_pred = wm @ Z
        dz = Z - z_pred[..., None, :]
    S, Pxz = weighted_covariances(dz, wc, X - mean[..., None, :], R)
    return z_pred, S, Pxz


def _wrapped(d: np.ndarray, angles) -> np.ndarray:
    """``d`` with its components ``angles`` (last axis) wrapped to (-pi, pi], in place."""
    for c in angles:
        d[..., c] = wrap_angle(d[..., c])
    return d


@measurement_moments.compiled
def _measurement_moments_compiled(X, mean, Z, wm, wc, angular, R):
    lead = mean.shape[:-1]
    n, m = mean.shape[-1], Z.shape[-1]
    flat = _stack(mean, 1)
    zp, S, Pxz = _call("measurement_moments", flat.shape[0], _stack(X, 2), flat, _stack(Z, 2, lead),
                       _contiguous(wm), _contiguous(wc), np.asarray(angular, dtype=np.bool_), _periodic(R, 2, lead))
    return zp.reshape(lead + (m,)), S.reshape(lead + (m, m)), Pxz.reshape(lead + (n, m))


def mixing_weights(mu: np.ndarray, transition: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""``c`` (B, r) and ``w[b, i, j] = mu_{i|j}`` (B, r, r) (Zhu et al. 2016, Eq. 54):
    :math:`c_j = \sum_i p_{ij}\mu_i`, :math:`\mu_{i|j} = p_{ij}\mu_i / c_j`, from mode probabilities ``mu``
    (B, r) and ``transition`` (r, r) (rows "from").  A mode with :math:`c_j = 0` (unreachable) gets
    :math:`\mu_{i|j} = \mu_i` (its estimate has zero weight later; no 0/0)."""
    c = matmul_rows(mu, transition)          # mu @ transition, the same bits for a run whatever the batch size
    impossible = c <= 0.0
    if impossible.any():
        # A mode no other mode can reach has c_j = 0: its mixed estimate gets zero weight in
        # every later step, so any valid distribution will do; use mu itself (no 0/0 NaN).
        w = transition[None, :, :] * mu[:, :, None] / np.where(impossible, 1.0, c)[:, None, :]
        return c, np.where(impossible[:, None, :], mu[:, :, None], w)
    return c, transition[None, :, :] * mu[:, :, None] / c[:, None, :]


def mix_moments(means: np.ndarray, covs: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""The standard IMM interaction (Zhu et al. 2016, Eqs. 55-56): :math:`x^{0j} = \sum_i \mu_{i|j} x^i` and
    :math:`P^{0j} = \sum_i \mu_{i|j}[P^i + (x^i - x^{0j})(x^i - x^{0j})^T]` (:func:`combine_covariances`) from
    ``means`` (B, r, n), ``covs`` (B, r, n, n) and ``w`` (B, r_from, r_to) (:func:`mixing_weights`) ->
    ``(mixed means (B, r, n), mixed covs (B, r, n, n))``."""
    wt = np.swapaxes(w, -1, -2)                                   # (B, j, i)
    mixed_mean = wt @ means                                       # (B, j, n)
    return mixed_mean, combine_covariances(wt, means, covs, mixed_mean)


@_operation
def cubature_mix(means: np.ndarray, covs: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Cubature-principle IMM interaction (CPIMM, Zhou et al. 2017, Eqs. 14-19; :class:`mmlib.core.mixing.
    CubatureMixing`, whose docstring has the mathematics), evaluated on the 2rn cubature points of the augmented
    mode variable: ``means`` (B, r, n), ``covs`` (B, r, n, n), mixing weights ``w`` (B, r_from, r_to)
    (:func:`mixing_weights`) -> ``(mixed means (B, r, n), mixed covs (B, r, n, n))``.  A mode covariance that is not
    positive definite gives NaN for that run.  The compiled twin (:func:`mmlib.core._kernels._cubature_points_core`)
    sums the two products in order with one fused multiply-add per term, as OpenBLAS's ``gemm`` and ``syrk`` do on
    AVX2 CPUs for most shapes (not ``gemm``'s kernel for a last odd row, where a product's inner dimension is 8 or
    more): the same bits there, round-off otherwise; for r = 1 or n = 1 (numpy's ``dot`` there) both run numpy's."""
    B, r, n = means.shape
    l = r * n
    chol, _ = cholesky(covs)                # (B, r, n, n) blocks of S; a non-PD block gives NaN (reported)
    wt = np.swapaxes(w, -1, -2)                                        # (B, j, i)
    centre = wt @ means                                                # f_j(chi_hat), (B, j, n)
    # point +-sqrt(l) S e_c in block i moves f_j by +-sqrt(l) mu_{i|j} S_i[:, c]
    cols = np.swapaxes(chol, -1, -2)                                   # (B, i, c, n): columns as rows
    shift = math.sqrt(l) * wt[:, :, :, None, None] * cols[:, None]      # (B, j, i, c, n)
    shift = shift.reshape(B, r, l, n)
    pts = np.concatenate([centre[:, :, None, :] + shift, centre[:, :, None, :] - shift], axis=2)
    mean = pts.mean(axis=2)                                            # Eq. 18, weights 1/(2l)
    d = pts - mean[:, :, None, :]
    cov = np.swapaxes(d, -1, -2) @ d / (2 * l)                         # Eq. 19
    return mean, 0.5 * (cov + np.swapaxes(cov, -1, -2))


@cubature_mix.compiled
def _cubature_mix_compiled(means, covs, w):
    means, covs, w = (np.asarray(a, dtype=np.float64) for a in (means, covs, w))
    B, r, n = means.shape
    if r < 2 or n < 2:
        return cubature_mix.implementations["numpy"](means, covs, w)
    # every operand with the runs' rows: the kernel reads w run by run (a shared w broadcast here, as numpy does)
    return _call("cubature_mix", B, _stack(means, 2), _stack(covs, 3, (B,)), _stack(w, 2, (B,)))


@_operation
def imm_mix(mu: np.ndarray, transition: np.ndarray, means: np.ndarray,
            covs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""IMM interaction: ``(c (B, r), mixed means (B, r, n), mixed covs (B, r, n, n))`` from mode probabilities
    ``mu`` (B, r), ``transition`` (r, r) (rows "from") and the mode estimates ``means`` (B, r, n), ``covs``
    (B, r, n, n): :func:`mixing_weights` then :func:`mix_moments`."""
    c, w = mixing_weights(mu, transition)
    return (c,) + mix_moments(means, covs, w)


@imm_mix.compiled
def _imm_mix_compiled(mu, transition, means, covs):
    return _call("imm_mix", mu.shape[0], _stack(mu, 1), _contiguous(transition), _stack(means, 2), _stack(covs, 3))


@_operation
def imm_output(loglik: np.ndarray, c: np.ndarray, means: np.ndarray, covs: np.ndarray, nu: np.ndarray,
               S: np.ndarray, with_cov: bool = True) -> tuple:
    r"""The end of an IMM cycle (Zhu et al. 2016, Eqs. 57-59): mode probabilities :math:`\mu_j \propto c_j L_j`
    (in logs, about the largest term), the log marginal likelihood :math:`\log p(z_k | z_{1:k-1}) =
    \log\sum_j c_j L_j`, the fused estimate :math:`\sum_j \mu_j x_j` with (if ``with_cov``, else None) its
    covariance :math:`\sum_j \mu_j[P_j + (x_j - \hat x)(x_j - \hat x)^T]`, and the innovation against the
    predicted measurement of the mixture prior, :math:`z - \sum_j c_j \hat z_j = \sum_j c_j \nu_j`, with its
    predicted covariance :math:`\sum_j c_j[S_j + (\nu_j - \nu)(\nu_j - \nu)^T]` (as
    :math:`\hat z_j - \hat z = \nu - \nu_j`).

    ``loglik``, ``c`` (B, r); ``means`` (B, r, n); ``covs`` (B, r, n, n); ``nu`` (B, r, m); ``S`` (B, r, m, m).
    Returns ``(mu, marginal, underflow, mean, cov, innovation, innovation_cov)``; ``underflow`` (B,): every
    mode's likelihood underflowed (:math:`\log L_j = -\infty` for all j), the run's ``mu`` is then NaN."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        logpost = loglik + np.log(c)                                  # (B, r)
        top = np.max(logpost, axis=1, keepdims=True)
        post = np.exp(logpost - top)
        total = post.sum(axis=1, keepdims=True)
        mu = post / total
        marginal = (top + np.log(total))[:, 0]                        # log p(z_k | z_1:k-1)
    underflow = (top[:, 0] == -np.inf)
    if underflow.any():
        mu = np.where(underflow[:, None], np.nan, mu)
    fused_mean = (mu[:, None, :] @ means)[:, 0]
    fused_cov = (combine_covariances(mu[:, None, :], means, covs, fused_mean[:, None, :])[:, 0]
                 if with_cov else None)
    innovation = (c[:, :, None] * nu).sum(axis=1)
    innovation_cov = combine_covariances(c[:, None, :], nu, S, innovation[:, None, :])[:, 0]
    return mu, marginal, underflow, fused_mean, fused_cov, innovation, innovation_cov


@imm_output.compiled
def _imm_output_compiled(loglik, c, means, covs, nu, S, with_cov=True):
    mu, marginal, underflow, mean, cov, innovation, innovation_cov = _call(
        "imm_output", loglik.shape[0], _stack(loglik, 1), _stack(c, 1), _stack(means, 2), _stack(covs, 3),
        _stack(nu, 2), _stack(S, 3), bool(with_cov))
    return mu, marginal, underflow, mean, (cov if with_cov else None), innovation, innovation_cov
