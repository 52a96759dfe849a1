r"""What the controls conclude: the ``controls`` section of ``data/results/controls.json`` (:func:`section`), the power
of the verdict rule against a perturbed printed value (:func:`rejection_power`) and the window of rule constants the
controls leave open (:func:`rule_window`).

The rule (:mod:`mmlib.experiment.verdicts`) reproduces a printed value ``p`` when :math:`|r - p| \le k\sigma`,
:math:`k` = ``SIGMA_FACTOR`` and :math:`\sigma = \sqrt{s^2 + s_p^2 + u^2}` (our standard error, the paper's estimated
Monte Carlo error, half a unit of the last printed digit).  With our estimate :math:`r \sim N(\mu, s^2)` around the
true value :math:`\mu`, the probability that the rule does *not* reproduce a printed value :math:`p'` is

.. math::
    \Pr(|r - p'| > k\sigma) = \Phi\!\left(\frac{m - k\sigma}{s}\right) + \Phi\!\left(\frac{-m - k\sigma}{s}\right),
    \qquad m = \mu - p',

the power of the rule against a printed error :math:`p' - \mu` (for :math:`p' = \mu` it is the false-rejection rate
:math:`2\Phi(-k)` when :math:`u = 0`).  The rule's constants are read when a function is called, so a changed rule
(tests/test_controls.py monkeypatches them) changes every number here.
"""
from __future__ import annotations

import math
from typing import Iterable, Mapping

from mmlib.experiment import verdicts
from mmlib.experiment.verdicts import Row
from mmlib.papers.controls import text

__all__ = [
    "rejection_power", "tightening_detection", "table_of", "rejected", "rule_window", "section"
]

_TABLE_OF = {p.key: p.table for p in text.PUBLISHED}
_NEGATIVE = {name: (fraction, expected) for name, fraction, expected in text.NEGATIVES}


def _phi(x: float) -> float:
    return 0.5 * math.erfc(-x / math.sqrt(2.0))


def rejection_power(true_value: float, printed: str, stderr: float, n_runs: int | None = None,
                    n_runs_paper: int | None = None) -> float:
    """The probability (module docstring) that the verdict rule does not reproduce the printed text ``printed`` when
    our estimate is normal around ``true_value`` with standard error ``stderr`` (same unit) over ``n_runs`` runs, the
    paper having ``n_runs_paper`` (None: no paper Monte Carlo error, as for a closed form)."""
    if not (isinstance(stderr, (int, float)) and stderr > 0 and math.isfinite(stderr)):
        raise ValueError(f"stderr: expected a positive finite standard error, got {stderr!r}")
    m, sigma = verdicts._difference_and_sigma(printed, float(true_value), float(stderr), n_runs, n_runs_paper)
    m = -m                                    # _difference_and_sigma gives replicated - paper = mu - p'
    k = verdicts.SIGMA_FACTOR
    return _phi((m - k * sigma) / stderr) + _phi((-m - k * sigma) / stderr)


def tightening_detection(factor: float, n_cells: int) -> float:
    """The probability that a positive control of ``n_cells`` independent cells (standardized distances standard
    normal) fails when the rule's factor is tightened to ``factor``: :math:`1 - (1 - 2\\Phi(-c))^n`; a tightening the
    control may miss is one within the largest distance it happens to draw."""
    return 1.0 - (1.0 - 2.0 * _phi(-float(factor))) ** int(n_cells)


def table_of(row: Row) -> str:
    """The control table a row belongs to (:data:`text.TABLES`); ValueError for a row of no control table."""
    key = (row.item, row.algorithm, row.quantity)
    if key not in _TABLE_OF:
        raise ValueError(f"row: {key} is no cell of the controls' tables")
    return _TABLE_OF[key]


def rejected(verdict: str) -> bool:
    """A decisive rejection: the cell is neither reproduced nor inconclusive (qualitatively or not reproduced)."""
    return verdicts.verdict_category(verdict) in (verdicts.QUALITATIVE, verdicts.NOT_REPRODUCED)


def rule_window(rows: Iterable[Row]) -> dict:
    """The rule constants under which the controls come out as they must, from the judged rows: ``sigma_factor``
    [max ``|z|`` of the positive cells, min ``|z|`` of the ±10 % cells) -- a factor below the first fails the positive
    control, one at or above the second the negative -- and ``relative_band`` [the least band that keeps every
    positive cell conclusive and every ±10 % cell qualitative, the least relative distance of a cell that must be
    "not reproduced") (fractions of the printed value)."""
    rows = list(rows)
    pos = [r for r in rows if table_of(r) == text.POSITIVE]
    near = [r for r in rows if table_of(r) != text.POSITIVE and _NEGATIVE[table_of(r)][1] == verdicts.QUALITATIVE]
    far = [r for r in rows if table_of(r) != text.POSITIVE and _NEGATIVE[table_of(r)][1] == verdicts.NOT_REPRODUCED]

    def rel(r):
        return abs(r.replicated - float(r.paper)) / abs(float(r.paper))

    k = verdicts.SIGMA_FACTOR
    conclusive = [k * abs(r.replicated - float(r.paper)) / abs(r.distance) / abs(float(r.paper)) if r.distance
                  else 0.0 for r in pos]
    return {"sigma_factor": [max(abs(r.distance) for r in pos), min(abs(r.distance) for r in near)],
            "relative_band": [max(conclusive + [rel(r) for r in near]), min(rel(r) for r in far) if far else None]}


def section(rows: Iterable[Row], *, n_runs: int, numbers_summary: Iterable[Mapping] = ()) -> dict:
    """The ``controls`` section of the results: ``positive`` (cells, reproduced, verdict counts, the largest
    ``|z|``, the table's joint test, and over the reading space whether every universe reproduces every cell),
    ``negative`` (per perturbed table: its perturbation, the verdict every cell must get, cells, not reproduced, as
    expected, the least ``|z|`` and the least power of the rule at ``n_runs`` runs; and the totals, the
    perturbations and the least power of the ±10 % tables), ``rule_window`` (:func:`rule_window`) and ``searched``
    (the third control's search). ``rows``: the judged rows (joint-tested,
    :func:`mmlib.experiment.verdicts.joint_tests`); ``numbers_summary``: the multiverse's
    (``Multiverse.numbers_summary``), empty when none was run."""
    rows, _ = verdicts.joint_tests(list(rows))
    by_table: dict = {}
    for r in rows:
        by_table.setdefault(table_of(r), []).append(r)
    across: dict = {}
    for n in numbers_summary:
        across.setdefault(n["table"], []).append(n)
    pos = by_table[text.POSITIVE]
    cats = [str(verdicts.verdict_category(r.verdict)) for r in pos]
    joint = verdicts.joint_test([r.distance for r in pos])
    positive = {"table": text.POSITIVE, "n_cells": len(pos), "n_reproduced": sum(verdicts.is_reproduced(r.verdict)
                                                                                  for r in pos),
                "verdicts": {c: cats.count(c) for c in dict.fromkeys(cats)},
                "max_abs_distance": max(abs(r.distance) for r in pos),
                "joint_test": {"statistic": joint.statistic, "dof": joint.dof, "p_value": joint.p_value,
                               "passes": joint.passes}}
    if text.POSITIVE in across:
        positive["every_universe_reproduces"] = all(n["n_reproduced"] == n["n_counted"] for n in across[text.POSITIVE])
        positive["n_counted"] = across[text.POSITIVE][0]["n_counted"]
    positive["all_reproduced"] = positive["n_reproduced"] == positive["n_cells"]
    tables, near_power = [], []
    for name, (fraction, expected) in _NEGATIVE.items():
        mine = by_table[name]
        truth = {(r.item.split(" (")[0], r.quantity): r for r in pos}
        powers = [rejection_power(truth[(r.item.split(" (")[0], r.quantity)].replicated, r.paper,
                                  truth[(r.item.split(" (")[0], r.quantity)].stderr, n_runs, None) for r in mine]
        if expected == verdicts.QUALITATIVE:
            near_power += powers
        entry = {"table": name, "perturbation": fraction, "expected": expected, "n_cells": len(mine),
                 "n_not_reproduced": sum(rejected(r.verdict) for r in mine),
                 "n_expected": sum(verdicts.verdict_category(r.verdict) == expected for r in mine),
                 "min_abs_distance": min(abs(r.distance) for r in mine), "power_min": min(powers)}
        if name in across:
            entry["every_universe_rejects"] = all(n["n_reproduced"] + n["n_isolated"] + n["n_inconclusive"] == 0
                                                  for n in across[name])
        tables.append(entry)
    negative = {"n_cells": sum(t["n_cells"] for t in tables),
                "n_not_reproduced": sum(t["n_not_reproduced"] for t in tables),
                "n_expected": sum(t["n_expected"] for t in tables),
                "perturbation": ", ".join(f"{100 * f:+.0f} %" for f, _ in _NEGATIVE.values()) + " of every cell",
                "power": min(near_power), "power_of": "the least, over the ±10 % cells, probability that the rule "
                                                      "does not reproduce the perturbed value, at the control's run "
                                                      "count, our estimate normal around the positive cell's value",
                "n_runs": int(n_runs), "tables": tables}
    negative["all_rejected"] = negative["n_not_reproduced"] == negative["n_cells"] == negative["n_expected"]
    return {"positive": positive, "negative": negative, "rule_window": rule_window(rows), "searched": text.SEARCHED}
