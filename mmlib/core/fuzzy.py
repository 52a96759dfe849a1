r"""Zero-order Takagi-Sugeno fuzzy inference, batched over Monte Carlo runs.

A rule base over d inputs, each with a few fuzzy sets (membership functions), and one rule
per combination of sets (a complete grid).  Rule r, "IF x_1 is A_{r1} AND ... AND x_d is A_{rd}
THEN y = c_r", fires with the product t-norm :math:`w_r = \prod_i \mu_{A_{ri}}(x_i)` and the
crisp output is the weighted average of the rule consequents (Takagi & Sugeno 1985; Tseng
et al. 2011, Sec. 3.1, "the output is the weighted average of the y_k"):

.. math:: y = \frac{\sum_r w_r c_r}{\sum_r w_r}.

Why not a package: scikit-fuzzy implements Mamdani inference (fuzzy output sets and centroid
defuzzification) and simpful evaluates one input vector per call, which would put a Python
loop over runs in the filter's inner loop.  The inference itself is the formula above; this
module evaluates it for all runs at once in ~20 lines.
"""
from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import numpy as np

from mmlib.core._validate import as_float_array, check_finite, check_scalar
from mmlib.core.linalg import compiled_rule_count, rule_output, rule_weights, trapezoid_rules
from mmlib.core.linalg import trapezoid_memberships as _trapezoid_memberships

__all__ = ["TakagiSugeno", "Trapezoid", "ramp_sets"]


@dataclass(frozen=True)
class Trapezoid:
    r"""Trapezoidal membership function: 0 below ``a``, rising to 1 at ``b``, 1 up to ``c``,
    falling to 0 at ``d``.  ``a = b = -inf`` gives a left shoulder, ``c = d = inf`` a right
    shoulder, ``b = c`` a triangle.

    ``name`` a string; ``a``-``d`` real numbers (in the input's units) with ``a <= b <= c <= d``;
    infinities only as shoulders (``a = -inf`` exactly when ``b = -inf``, ``d = inf`` exactly when
    ``c = inf``), so that every set is non-zero somewhere.  Call with ``x`` of any shape (finite, else a
    ValueError naming ``x``) to get the memberships in [0, 1], same shape."""

    name: str
    a: float
    b: float
    c: float
    d: float

    def __post_init__(self):
        if not isinstance(self.name, str):
            raise ValueError(f"name: expected a string, got {type(self.name).__name__}")
        a, b, c, d = (check_scalar(getattr(self, k), k, finite=False) for k in "abcd")
        if not a <= b <= c <= d:
            raise ValueError(f"a, b, c, d: expected a <= b <= c <= d for set {self.name!r}, got {(a, b, c, d)}")
        if (a == -math.inf) != (b == -math.inf):
            raise ValueError(f"b: a left shoulder (set {self.name!r}) needs a = b = -inf, got a={a}, b={b}")
        if (d == math.inf) != (c == math.inf):
            raise ValueError(f"c: a right shoulder (set {self.name!r}) needs c = d = inf, got c={c}, d={d}")
        if b == math.inf or c == -math.inf:
            raise ValueError(f"{'b' if b == math.inf else 'c'}: set {self.name!r} would be zero for every finite "
                             f"input, got {(a, b, c, d)}")
        for k, v in zip("abcd", (a, b, c, d)):
            object.__setattr__(self, k, v)

    def __call__(self, x: np.ndarray | float) -> np.ndarray:
        x = check_finite(as_float_array(x, "x"), "x")
        bounds = np.array([[self.a], [self.b], [self.c], [self.d]])
        return _trapezoid_memberships(bounds, x.reshape(-1))[:, 0].reshape(x.shape)[()]     # a scalar for a scalar


def ramp_sets(names: Iterable[str], breakpoints: np.ndarray) -> tuple:
    """Sets forming a partition of unity on the real line -- a left shoulder, triangles, a right
    shoulder -- with ``breakpoints[i]`` the point where set i reaches 1 (the end of the left
    shoulder, the triangles' peaks, the start of the right shoulder).  E.g. names (N, M, L) with
    breakpoints (1, 2, 4): N is 1 up to 1 and 0 from 2; M peaks at 2; L is 0 up to 2 and 1 from 4.

    ``names``: at least two strings; ``breakpoints``: one finite value per name (in the input's
    units), strictly increasing."""
    if not hasattr(names, "__iter__"):
        raise ValueError(f"names: expected a sequence of set names (strings), got {names!r}")
    names = tuple(names)
    if not all(isinstance(nm, str) for nm in names):
        raise ValueError(f"names: expected a sequence of set names (strings), got {names!r}")
    if len(names) < 2:
        raise ValueError(f"names: expected at least two set names, got {names!r}")
    bp = check_finite(as_float_array(breakpoints, "breakpoints"), "breakpoints")
    if bp.shape != (len(names),) or np.any(np.diff(bp) <= 0):
        raise ValueError(f"breakpoints: expected {len(names)} increasing values, got {breakpoints!r}")
    bp = [float(b) for b in bp]
    out = []
    for i, nm in enumerate(names):
        a = -math.inf if i == 0 else bp[i - 1]
        b = -math.inf if i == 0 else bp[i]
        c = math.inf if i == len(names) - 1 else bp[i]
        d = math.inf if i == len(names) - 1 else bp[i + 1]
        out.append(Trapezoid(nm, a, b, c, d))
    return tuple(out)


@dataclass(frozen=True, eq=False)
class TakagiSugeno:
    r"""Zero-order Takagi-Sugeno system with a complete rule grid.

    ``inputs``: one tuple of membership functions per input; ``consequents``: array of shape
    (n_sets_1, ..., n_sets_d, n_outputs), the crisp output of every rule.  Call with ``x`` (B, d)
    to get (B, n_outputs), :math:`y = \sum_r w_r c_r / \sum_r w_r` (ValueError naming ``x`` for a row that
    fires no rule).  ``input_names`` / ``output_names``: optional labels, one per input / output."""

    inputs: tuple
    consequents: np.ndarray
    input_names: tuple = ()
    output_names: tuple = ()

    def __post_init__(self):
        if isinstance(self.inputs, (str, bytes)) or not hasattr(self.inputs, "__iter__"):
            raise ValueError(f"inputs: expected one tuple of membership functions per input, got "
                             f"{type(self.inputs).__name__}")
        sets = tuple(self.inputs)
        if not sets:
            raise ValueError("inputs: expected at least one input, got none")
        for i, s in enumerate(sets):
            if isinstance(s, (str, bytes)) or not hasattr(s, "__iter__"):
                raise ValueError(f"inputs[{i}]: expected a non-empty tuple of membership functions, got {s!r}")
        sets = tuple(tuple(s) for s in sets)
        for i, s in enumerate(sets):
            if not s:
                raise ValueError(f"inputs[{i}]: expected a non-empty tuple of membership functions, got none")
            for j, mf in enumerate(s):
                if not callable(mf):
                    raise ValueError(f"inputs[{i}][{j}]: expected a membership function (callable), "
                                     f"got {type(mf).__name__}")
        cons = check_finite(as_float_array(self.consequents, "consequents"), "consequents")
        grid = tuple(len(s) for s in sets)
        if cons.ndim != len(grid) + 1 or cons.shape[:-1] != grid or cons.shape[-1] < 1:
            raise ValueError(f"consequents: expected shape {grid} + (n_outputs,), got {cons.shape}")
        if self.input_names and len(self.input_names) != len(sets):
            raise ValueError(f"input_names: expected {len(sets)} names, got {self.input_names!r}")
        if self.output_names and len(self.output_names) != cons.shape[-1]:
            raise ValueError(f"output_names: expected {cons.shape[-1]} names (one per output), "
                             f"got {self.output_names!r}")
        cons = np.array(cons, dtype=float)
        cons.setflags(write=False)
        object.__setattr__(self, "inputs", sets)
        object.__setattr__(self, "consequents", cons)
        # an input whose sets are all trapezoids is evaluated in one call (_trapezoid_memberships), same bits
        bounds = tuple(np.array([[t.a, t.b, t.c, t.d] for t in s]).T if all(type(t) is Trapezoid for t in s)
                       else None for s in sets)
        for b in bounds:
            if b is not None:
                b.setflags(write=False)
        object.__setattr__(self, "_bounds", bounds)
        # a system whose inputs are all trapezoids is evaluated whole by linalg.trapezoid_rules (compiled on the
        # compiled kernels, the same bits): every input's bounds padded to (d, 4, max k_i), and the set counts
        trapezoids = None
        if all(b is not None for b in bounds):
            padded = np.zeros((len(sets), 4, max(grid)))
            for i, b in enumerate(bounds):
                padded[i, :, :grid[i]] = b
            trapezoids = (padded, np.array(grid, dtype=np.int64))
            for a in trapezoids:
                a.setflags(write=False)
        object.__setattr__(self, "_trapezoids", trapezoids)
        rule_consequents = cons.reshape(int(np.prod(grid)), -1)
        rule_consequents.setflags(write=False)
        object.__setattr__(self, "_rule_consequents", rule_consequents)

    def trapezoid_form(self) -> tuple | None:
        """``(bounds (d, 4, k_max), sizes (d,), consequents (K, p))`` of :func:`mmlib.core.linalg.trapezoid_rules` when
        every input's sets are trapezoids and the K rules are few enough for a compiled call to sum them in numpy's
        order; None otherwise."""
        if self._trapezoids is None or not compiled_rule_count(self._rule_consequents.shape[0]):
            return None
        return self._trapezoids + (self._rule_consequents,)

    @property
    def n_inputs(self) -> int:
        """Number of inputs d."""
        return len(self.inputs)

    def firing_strengths(self, x: np.ndarray) -> np.ndarray:
        r"""Rule weights (B, n_sets_1, ..., n_sets_d): product of the memberships,
        :math:`w_r = \prod_i \mu_{A_{ri}}(x_i)`, in [0, 1], for inputs ``x`` (B, d) (each in its sets' units).
        A non-finite ``x`` or one of another shape is a ValueError naming ``x``."""
        x = self._checked(x)
        return rule_weights([np.stack([s(x[:, i]) for s in sets], axis=-1) if self._bounds[i] is None
                             else _trapezoid_memberships(self._bounds[i], x[:, i])        # (B, n_i)
                             for i, sets in enumerate(self.inputs)])

    def _checked(self, x) -> np.ndarray:
        x = check_finite(as_float_array(x, "x"), "x")
        if x.ndim != 2 or x.shape[1] != self.n_inputs or x.shape[0] == 0:
            raise ValueError(f"x: expected shape (B, {self.n_inputs}) with B >= 1, got {x.shape}")
        return x

    def __call__(self, x: np.ndarray) -> np.ndarray:
        checked = self._checked(x)
        if self._trapezoids is not None:         # every input's sets trapezoids: one call (compiled on that kernel)
            out, total = trapezoid_rules(checked, *self._trapezoids, self._rule_consequents)
        else:                                    # (rule_output: matmul_rows, the same bits whatever the runs)
            K = self._rule_consequents.shape[0]
            out, total = rule_output(self.firing_strengths(checked).reshape(checked.shape[0], K),
                                     self._rule_consequents)
        if np.any(total <= 0):
            b = int(np.argmax(total <= 0))
            raise ValueError(f"x: input {np.asarray(x)[b].tolist()} (row {b}) fires no rule; the fuzzy sets must "
                             "cover every input value")
        return out

    def rules(self) -> Iterator[tuple[tuple[str, ...], np.ndarray]]:
        """Readable rule list: (antecedent set names, consequent vector)."""
        for idx in itertools.product(*(range(len(s)) for s in self.inputs)):
            yield tuple(self.inputs[i][j].name for i, j in enumerate(idx)), self.consequents[idx]
