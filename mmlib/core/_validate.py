"""Argument validation shared by the whole library.

Every public entry point funnels its inputs through these helpers so that bad
input fails early with a ``ValueError`` that names the offending argument.
Nothing here ever *repairs* an input: a covariance that is not symmetric
positive definite is rejected, never projected.
"""
from __future__ import annotations

import math
import re
from collections.abc import Mapping

import numpy as np

#: Relative tolerance for symmetry and row-sum checks (floating-point scale:
#: a few hundred ulps of the largest entry).
RTOL = 1e-9


def _describe(value) -> str:
    return type(value).__name__ if not isinstance(value, np.ndarray) else f"array of dtype {value.dtype}"


def as_float_array(value, name: str) -> np.ndarray:
    """``value`` as a float64 array.  Real numbers only: complex numbers (numpy would drop the
    imaginary part with a warning), strings, booleans, None and other objects are rejected."""
    if value is None or isinstance(value, (str, bytes)):
        raise ValueError(f"{name}: expected real numbers, got {_describe(value)}")
    raw = value if isinstance(value, np.ndarray) else None
    if raw is None:
        try:
            raw = np.asarray(value)
        except (TypeError, ValueError) as exc:   # ragged nested sequences
            raise ValueError(f"{name}: cannot be converted to a float array ({exc})") from None
    kind = raw.dtype.kind
    if kind == "O":
        flat = raw.ravel()
        if any(isinstance(v, (str, bytes, bool, np.bool_, complex, np.complexfloating)) or v is None
               for v in flat):
            raise ValueError(f"{name}: expected real numbers, got {_describe(value)} holding non-real entries")
    elif kind not in "iuf":
        what = {"c": "complex numbers", "U": "strings", "S": "bytes", "b": "booleans"}.get(kind, f"dtype {raw.dtype}")
        raise ValueError(f"{name}: expected real numbers, got {what}")
    try:
        arr = np.asarray(raw, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: cannot be converted to a float array ({exc})") from None
    return arr


def check_scalar(value, name: str, *, positive: bool = False, nonnegative: bool = False,
                 finite: bool = True, low: float | None = None, high: float | None = None) -> float:
    """A real number (Python or numpy scalar, or a 0-d array) as a Python float.

    ``positive``: > 0; ``nonnegative``: >= 0; ``low``/``high``: inclusive bounds; ``finite`` rejects
    NaN and infinities (NaN is always rejected)."""
    arr = as_float_array(value, name)
    if arr.ndim != 0:
        raise ValueError(f"{name}: expected a real number, got an array of shape {arr.shape}")
    x = float(arr)
    if np.isnan(x) or (finite and not np.isfinite(x)):
        raise ValueError(f"{name}: expected a finite real number, got {x!r}")
    if positive and not x > 0:
        raise ValueError(f"{name}: expected a number > 0, got {x!r}")
    if nonnegative and not x >= 0:
        raise ValueError(f"{name}: expected a number >= 0, got {x!r}")
    if low is not None and x < low:
        raise ValueError(f"{name}: expected a number >= {low}, got {x!r}")
    if high is not None and x > high:
        raise ValueError(f"{name}: expected a number <= {high}, got {x!r}")
    return x


def check_index(value, name: str, size: int) -> int:
    """An integer index into an axis of length ``size`` (negative indices are rejected)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name}: expected an integer index, got {value!r}")
    if not 0 <= int(value) < size:
        raise ValueError(f"{name}: index {int(value)} outside 0..{size - 1}")
    return int(value)


def check_mask(value, name: str, n: int) -> np.ndarray:
    """A boolean mask of length ``n`` (an index list is not a mask: it is rejected, never cast)."""
    arr = np.asarray(value)
    if arr.dtype.kind != "b":
        raise ValueError(f"{name}: expected a boolean mask of length {n}, got {_describe(value)}"
                         f"{' of shape ' + str(arr.shape) if arr.ndim else ''}")
    if arr.shape != (n,):
        raise ValueError(f"{name}: expected a boolean mask of shape ({n},), got shape {arr.shape}")
    return arr


def check_has(obj, name: str, what: str, methods) -> object:
    """``obj`` provides every attribute in ``methods`` (duck-typed interface check), else a ValueError
    naming the argument, e.g. ``measurement: expected a measurement model (with h, R, ...), got str``."""
    missing = [m for m in methods if not hasattr(obj, m)]
    if missing or isinstance(obj, np.ndarray):
        lacking = f" lacking {', '.join(missing)}" if missing and not isinstance(obj, (str, np.ndarray)) else ""
        raise ValueError(f"{name}: expected {what} (providing {', '.join(methods)}), got {_describe(obj)}{lacking}")
    return obj


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
    if arr.ndim != 2 or (dim is not None and arr.shape[1] != dim):
        raise ValueError(f"{name}: expected shape (B, {'n' if dim is None else dim}) (a batch of vectors), "
                         f"got {arr.shape}")
    return arr


def check_covariance(value, name: str, dim: int | None = None, *, batch: bool = False, stack: bool = False,
                     semidefinite: bool = False) -> np.ndarray:
    r"""Symmetric positive-(semi)definite matrix (n, n); a batch (B, n, n) if ``batch``; any leading axes
    (..., n, n) (e.g. runs and steps, or runs and modes) if ``stack``.

    Symmetry to ``RTOL`` of each matrix's largest entry.  Definiteness by LAPACK's Cholesky, the test the
    filters apply (:func:`mmlib.core.linalg.cholesky`); ``semidefinite``: the Cholesky of
    :math:`A + \mathrm{RTOL}\,\max|A|\,I`, i.e. smallest eigenvalue >= -RTOL x the largest entry (a zero
    block, e.g. a zero noise level, is legitimate).  One batched call, cheap enough for every step;
    eigenvalues are computed only to decide a semi-definite failure and to report the first offending
    matrix (its index among the leading axes)."""
    arr = check_finite(as_float_array(value, name), name)
    if stack:
        ok_rank, form = arr.ndim >= 2, "(..., n, n)"
    else:
        ok_rank, form = arr.ndim == (3 if batch else 2), "(B, n, n)" if batch else "(n, n)"
    if not ok_rank or arr.shape[-1] != arr.shape[-2]:
        raise ValueError(f"{name}: expected a square covariance of shape {form}, got {arr.shape}")
    if dim is not None and arr.shape[-1] != dim:
        raise ValueError(f"{name}: expected {dim}x{dim} covariance, got shape {arr.shape}")
    lead, n = arr.shape[:-2], arr.shape[-1]
    flat = arr.reshape((-1, n, n))
    N = flat.shape[0]
    if N == 0:
        return arr
    where = (lambda i: f" at index {tuple(int(j) for j in np.unravel_index(i, lead))}" if lead else "")
    scale = np.maximum(np.abs(flat).reshape(N, -1).max(axis=1), np.finfo(float).tiny)
    asym = np.abs(flat - np.swapaxes(flat, -1, -2)).reshape(N, -1).max(axis=1) > RTOL * scale
    if np.any(asym):
        raise ValueError(f"{name}: covariance{where(int(np.argmax(asym)))} is not symmetric")
    test = flat
    if semidefinite:
        test = flat.copy()
        test.reshape(N, -1)[:, ::n + 1] += (RTOL * scale)[:, None]
    from mmlib.core.linalg import cholesky   # here, not at the top: the modules that need no covariance check (the
    _, failed = cholesky(test)               # Monte Carlo streams of a notebook kernel) do not import numba with it
    if not failed.any():
        return arr
    eig_min = np.linalg.eigvalsh(flat)[:, 0]
    bad = eig_min < -RTOL * scale if semidefinite else failed
    if np.any(bad):
        i = int(np.argmax(bad))
        kind = "positive semi-definite" if semidefinite else "positive definite"
        raise ValueError(f"{name}: covariance{where(i)} is not {kind}; smallest eigenvalue {float(eig_min[i]):.3g}")
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
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise ValueError(f"{name}: expected an integer >= {minimum}, got {value!r}")
    return int(value)


def check_finite_runs(arr: np.ndarray, name: str, valid: np.ndarray) -> np.ndarray:
    """``arr`` (run axis first) finite in every run where the boolean mask ``valid`` is True; the other
    runs (diverged, excluded by the caller) may hold anything.  The message gives the first bad index
    in the caller's own indexing."""
    bad = ~np.isfinite(arr)
    bad &= np.reshape(valid, (-1,) + (1,) * (arr.ndim - 1))
    if np.any(bad):
        at = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(f"{name}: contains NaN or infinite values in a run marked valid "
                         f"(first at index {at}); mark diverged runs invalid instead")
    return arr


def check_pattern(value, name: str, pattern: re.Pattern, description: str) -> str:
    """``value`` if it is a string that ``pattern`` matches whole; else a ValueError naming ``name``, saying it
    expected ``description`` (e.g. "a paper name of letters, digits, ...")."""
    if not isinstance(value, str) or not pattern.fullmatch(value):
        raise ValueError(f"{name}: expected {description}, got {value!r}")
    return value


def check_bool(value, name: str) -> bool:
    """A flag: True or False (numpy booleans accepted); ``"no"``, 0, 2 and the like are rejected, never read
    by their truth value."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name}: expected True or False, got {value!r}")
    return bool(value)


def check_name(value, name: str = "name") -> str:
    """A label: a string."""
    if not isinstance(value, str):
        raise ValueError(f"{name}: expected a string, got {value!r}")
    return value


def check_names(value, name: str, *, nonempty: bool = True, distinct: bool = True) -> list[str]:
    """A sequence of labels as a list of strings.  A bare string is refused, never split into its characters
    (``"IMM"`` is not ``["I", "M", "M"]``); ``nonempty``: at least one; ``distinct``: no label twice."""
    if isinstance(value, (str, bytes)) or isinstance(value, np.ndarray) and value.ndim == 0 \
            or not hasattr(value, "__iter__") or isinstance(value, dict):
        raise ValueError(f"{name}: expected a sequence of names (a list of strings), got {value!r}")
    out = list(value)
    for i, v in enumerate(out):
        if not isinstance(v, str):
            raise ValueError(f"{name}: expected a sequence of names (a list of strings), item {i} is {v!r}")
    if nonempty and not out:
        raise ValueError(f"{name}: expected at least one name, got an empty sequence")
    if distinct and len(set(out)) != len(out):
        raise ValueError(f"{name}: repeated names in {out}")
    return out


def check_indices(value, name: str, size: int) -> tuple[int, ...]:
    """A non-empty sequence of distinct integer indices into an axis of length ``size``, as a tuple of ints.
    Floats (``(0.9, 2.5)`` is not ``(0, 2)``), booleans, negative indices and a bare string or number are
    rejected, never truncated."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__") \
            or isinstance(value, np.ndarray) and value.ndim != 1:
        raise ValueError(f"{name}: expected a sequence of integer indices in 0..{size - 1}, got {value!r}")
    out = []
    for v in value:
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
            raise ValueError(f"{name}: expected integer indices in 0..{size - 1}, got {v!r} in {value!r}")
        if not 0 <= int(v) < size:
            raise ValueError(f"{name}: index {int(v)} outside 0..{size - 1} in {value!r}")
        out.append(int(v))
    if not out or len(set(out)) != len(out):
        raise ValueError(f"{name}: expected a non-empty sequence of distinct indices, got {value!r}")
    return tuple(out)


def check_count(value, name: str, total: int | None = None) -> int:
    """A count: an integer >= 0 (numpy integers accepted), at most ``total`` if given.  ``1.7`` is not ``1``
    and NaN is not a count: both are rejected, never truncated."""
    n = check_positive_int(value, name, minimum=0)
    if total is not None and n > total:
        raise ValueError(f"{name}: {n} of only {total}")
    return n


def check_applies(model, name: str, n: int) -> None:
    """``model.h`` accepts states of dimension ``n`` and returns ``model.dim`` values: probed once on a zero
    state, so that a measurement model built for another state vector (e.g. a 4-state position sensor on a
    6-state constant-acceleration model, or position indices beyond the state) is named at construction
    instead of failing inside a filter with a numpy shape or index error."""
    try:
        with np.errstate(all="ignore"):
            out = np.asarray(model.h(np.zeros((1, 1, n))))     # (runs, points, n), as the filters call it
    except Exception as exc:
        raise ValueError(f"{name}: cannot measure a state of dimension {n} ({type(exc).__name__}: {exc})") from None
    if out.shape != (1, 1, model.dim):
        raise ValueError(f"{name}: a state of dimension {n} gives measurements of shape {out.shape[2:]}, "
                         f"expected ({model.dim},)")


def as_plain_json(value, name: str):
    """``value`` as plain JSON data for a results file: numpy scalars become the Python equivalent (np.float64 ->
    float, np.int64 -> int, np.bool_ -> bool, np.str_ -> str), tuples and lists are converted item by item (a tuple
    stays a tuple), dicts need string keys; NaN, infinities and any other object (an array, a model) are a
    ValueError naming the item, e.g. ``changes['q'][1]`` (they would fail when the results are written)."""
    if isinstance(value, np.str_):
        return str(value)
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        x = float(value)
        if not math.isfinite(x):
            raise ValueError(f"{name}: expected a finite number, got {x!r} (a results file holds no NaN or infinity)")
        return x
    if isinstance(value, (tuple, list)):
        out = [as_plain_json(v, f"{name}[{i}]") for i, v in enumerate(value)]
        return tuple(out) if isinstance(value, tuple) else out
    if isinstance(value, Mapping):
        for k in value:
            if not isinstance(k, str):
                raise ValueError(f"{name}: expected string keys, got {k!r}")
        return {k: as_plain_json(v, f"{name}[{k!r}]") for k, v in value.items()}
    raise ValueError(f"{name}: expected a number, string, bool, None or a tuple, list or dict of them (JSON data), "
                     f"got {type(value).__name__}")
