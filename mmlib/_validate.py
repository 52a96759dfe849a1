"""Argument validation shared by the whole library.

Every public entry point funnels its inputs through these helpers so that bad
input fails early with a ``ValueError`` that names the offending argument.
Nothing here ever *repairs* an input: a covariance that is not symmetric
positive definite is rejected, never projected.
"""
from __future__ import annotations

import numpy as np

#: Relative tolerance for symmetry and row-sum checks (floating-point scale:
#: a few hundred ulps of the largest entry).
RTOL = 1e-9


def as_float_array(value, name: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: cannot be converted to a float array ({exc})") from None
    return arr


def check_finite(arr: np.ndarray, name: str) -> np.ndarray:
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))
        raise ValueError(
            f"{name}: contains NaN or infinite values (first at index {tuple(int(i) for i in bad[0])})"
        )
    return arr


def check_matrix(value, name: str, shape: tuple[int, int] | None = None) -> np.ndarray:
    arr = check_finite(as_float_array(value, name), name)
    if arr.ndim != 2:
        raise ValueError(f"{name}: expected a 2-D matrix, got shape {arr.shape}")
    if shape is not None and arr.shape != shape:
        raise ValueError(f"{name}: expected shape {shape}, got {arr.shape}")
    return arr


def check_batch_vector(value, name: str, dim: int | None = None) -> np.ndarray:
    """A batch of vectors, shape (B, dim)."""
    arr = check_finite(as_float_array(value, name), name)
    if arr.ndim != 2:
        raise ValueError(f"{name}: expected shape (B, n) (batch of vectors), got {arr.shape}")
    if dim is not None and arr.shape[1] != dim:
        raise ValueError(f"{name}: expected vectors of length {dim}, got shape {arr.shape}")
    return arr


def check_covariance(value, name: str, dim: int | None = None, *, batch: bool = False,
                     semidefinite: bool = False) -> np.ndarray:
    """Symmetric positive-(semi)definite matrix (n, n), or a batch (B, n, n) if ``batch``."""
    arr = check_finite(as_float_array(value, name), name)
    want = 3 if batch else 2
    if arr.ndim != want or arr.shape[-1] != arr.shape[-2]:
        form = "(B, n, n)" if batch else "(n, n)"
        raise ValueError(f"{name}: expected a square covariance of shape {form}, got {arr.shape}")
    if dim is not None and arr.shape[-1] != dim:
        raise ValueError(f"{name}: expected {dim}x{dim} covariance, got shape {arr.shape}")
    scale = np.maximum(np.max(np.abs(arr), axis=(-2, -1), keepdims=True), np.finfo(float).tiny)
    if np.any(np.abs(arr - np.swapaxes(arr, -1, -2)) > RTOL * scale):
        raise ValueError(f"{name}: covariance is not symmetric")
    eig_min = np.linalg.eigvalsh(arr)[..., 0]
    floor = -RTOL * scale[..., 0, 0] if semidefinite else 0.0
    bad = eig_min < floor if semidefinite else eig_min <= 0.0
    if np.any(bad):
        where = f" (batch index {int(np.argmax(np.atleast_1d(bad)))})" if batch else ""
        kind = "positive semi-definite" if semidefinite else "positive definite"
        raise ValueError(f"{name}: covariance is not {kind}{where}; smallest eigenvalue {float(np.min(eig_min)):.3g}")
    return arr


def check_probabilities(value, name: str, *, axis: int = -1, total: bool = True) -> np.ndarray:
    """Entries in [0, 1]; if ``total``, each slice along ``axis`` sums to 1."""
    arr = check_finite(as_float_array(value, name), name)
    if np.any(arr < 0.0) or np.any(arr > 1.0):
        raise ValueError(f"{name}: probabilities must lie in [0, 1]")
    if total:
        sums = arr.sum(axis=axis)
        if np.any(np.abs(sums - 1.0) > 1e-9 * arr.shape[axis]):
            raise ValueError(f"{name}: rows must sum to 1 (got sums {np.round(sums, 12).tolist()})")
    return arr


def check_transition_matrix(value, name: str = "transition") -> np.ndarray:
    """Markov transition matrix, rows = 'from' mode, columns = 'to' mode."""
    arr = check_matrix(value, name)
    if arr.shape[0] != arr.shape[1]:
        raise ValueError(f"{name}: transition matrix must be square, got {arr.shape}")
    return check_probabilities(arr, name, axis=1)


def check_choice(value, name: str, choices) -> str:
    if value not in choices:
        raise ValueError(f"{name}: unknown value {value!r}; expected one of {sorted(choices)}")
    return value


def check_positive_int(value, name: str, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name}: expected an integer >= {minimum}, got {value!r}")
    return int(value)
