"""Figures and tables of the arena: every algorithm on every scenario (:mod:`mmlib.arena.study`).

``cells`` is the list returned by :func:`mmlib.arena.study.run_arena` (or its stored form): one dict per
(algorithm, scenario), in scenario-major order, with either ``reason`` (the algorithm cannot apply) or the metrics
of :func:`mmlib.arena.study.cell_metrics` plus ``rank`` and ``versus_best``.  ``scenarios`` is the list of
:func:`mmlib.arena.study.scenario_table` (``scenario``, ``title``, ``nonlinearity_index``, ``properties``).  The
algorithms (columns) and scenarios (rows) are taken in the order in which they first appear in ``cells``.

* :func:`rmse_heatmap`: position RMSE of each cell relative to the best algorithm of its scenario;
* :func:`consistency_heatmap`: ANEES or ANIS divided by its degrees of freedom (1 = consistent);
* :func:`ladder_curves`: position RMSE along the nonlinearity and manoeuvre axes of the ladder;
* :func:`cell_table`: one scenario's cells as table rows (for :func:`mmlib.experiment.views.markdown_table`);
* :func:`claim_scenario_matrix`: the papers' claims across the arena (:func:`mmlib.arena.study.paper_claims`) as a
  pair x scenario matrix of part-verdict symbols.

Figures are returned (the caller saves them, e.g. with :func:`mmlib.experiment.report.save_figure`); matplotlib is
imported only inside the functions, so importing this module is cheap and needs no display.  Bad input is a
ValueError whose message starts with the argument's name.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Iterable, Sequence

import numpy as np

from mmlib.core._validate import check_names
from mmlib.experiment.verdicts import format_pm
from mmlib.experiment.views import value_pm

__all__ = [
    "rmse_heatmap", "consistency_heatmap", "ladder_curves", "cell_table", "claim_scenario_matrix", "LADDER_ALGORITHMS",
    "RMSE_RATIO_RANGE", "CONSISTENCY_RANGE", "BAND_SIGMAS", "NA_COLOUR", "NO_VALUE_COLOUR", "DIVERGED_COLOUR",
    "CONSISTENCY_NAMES", "CELL_TABLE_KEYS"
]

if TYPE_CHECKING:
    import matplotlib.axes
    import matplotlib.figure

    from mmlib.arena.study import ArenaResult

#: the algorithms :func:`ladder_curves` draws by default (those present in the cells)
LADDER_ALGORITHMS = ("EKF", "UKF", "CKF", "5CKF", "IMMEKF", "IMMUKF", "IMM5CKF", "STUKF")
RMSE_RATIO_RANGE = (1.0, 10.0)          #: colour range of :func:`rmse_heatmap` (ratios beyond are clipped)
CONSISTENCY_RANGE = (0.2, 5.0)          #: colour range of :func:`consistency_heatmap` (value / dof, log, centred at 1)
BAND_SIGMAS = 2.0                       #: error bars of :func:`ladder_curves`, in standard errors

NA_COLOUR = "0.86"                      # the algorithm does not apply
NO_VALUE_COLOUR = "0.97"                # no statistic recorded (e.g. no NIS)
DIVERGED_COLOUR = "#b2182b"             # every run diverged (fill) / some runs diverged (border)
CONSISTENCY_NAMES = {"anees": ("ANEES", "NEES"), "anis": ("ANIS", "NIS")}


# ----------------------------------------------------------------------------------------------------- input

def _layout(cells):
    """(algorithms, scenario names, {(scenario, algorithm): cell}) in order of first appearance; ValueError
    ``cells: ...`` for anything that is not a non-empty list of cell dicts (a :class:`study.ArenaResult` stands for
    its ``cells``)."""
    if not isinstance(cells, (list, dict)) and isinstance(getattr(cells, "cells", None), list):
        cells = cells.cells
    if isinstance(cells, (str, bytes, dict)) or not hasattr(cells, "__iter__"):
        raise ValueError(f"cells: expected a list of cell dicts (study.run_arena), got {type(cells).__name__}")
    cells = list(cells)
    if not cells:
        raise ValueError("cells: empty; expected at least one cell dict (study.run_arena)")
    algorithms, names, by = [], [], {}
    for i, c in enumerate(cells):
        if not isinstance(c, dict) or "algorithm" not in c or "scenario" not in c:
            raise ValueError(f"cells: item {i} is not a cell dict with 'algorithm' and 'scenario' keys: {c!r:.80}")
        key = (c["scenario"], c["algorithm"])
        if key in by:
            raise ValueError(f"cells: two cells for algorithm {key[1]!r} on scenario {key[0]!r}")
        if "reason" not in c and "rmse_position" not in c:
            raise ValueError(f"cells: cell {key[1]!r} on {key[0]!r} has neither a 'reason' nor metrics")
        by[key] = c
        if c["algorithm"] not in algorithms:
            algorithms.append(c["algorithm"])
        if c["scenario"] not in names:
            names.append(c["scenario"])
    return algorithms, names, by


def _scenario_rows(scenarios, name="scenarios") -> dict:
    """``{name: row}`` from a scenario table (list of dicts with a ``scenario`` key); {} for None."""
    if scenarios is None:
        return {}
    if isinstance(scenarios, (str, bytes, dict)) or not hasattr(scenarios, "__iter__"):
        raise ValueError(f"{name}: expected a list of scenario dicts (study.scenario_table), "
                         f"got {type(scenarios).__name__}")
    out = {}
    for i, s in enumerate(scenarios):
        if not isinstance(s, dict) or "scenario" not in s:
            raise ValueError(f"{name}: item {i} is not a scenario dict with a 'scenario' key: {s!r:.80}")
        out[s["scenario"]] = s
    return out


def _n_runs(cells) -> int:
    return max((int(c.get("n_runs") or 0) for c in cells), default=0)


def _eta(row):
    """The median nonlinearity index of a scenario-table row, or None."""
    ni = (row or {}).get("nonlinearity_index")
    v = ni.get("median") if isinstance(ni, dict) else ni
    return None if v is None or not np.isfinite(v) else float(v)


def _row_label(name, rows) -> str:
    eta = _eta(rows.get(name))
    if eta is None:
        return name
    return f"{name}  (η {'0' if eta < 1e-6 else _sig2(eta)})"


# ----------------------------------------------------------------------------------------------------- format

def _sig2(v: float) -> str:
    """``v`` to two significant digits, compact: 0.0042, 0.95, 1.7, 18, 180, 5.3e4."""
    if v is None or not np.isfinite(v):
        return "--"
    a = abs(v)
    if a == 0:
        return "0"
    if a >= 1e4:
        m, e = f"{v:.1e}".split("e")
        return f"{m}e{int(e)}"
    if a >= 10:
        return f"{round(v, 1 - int(math.floor(math.log10(a)))):.0f}"
    if a >= 1:
        return f"{v:.1f}"
    if a >= 0.1:
        return f"{v:.2f}"
    return f"{v:.2g}"


def _digits(v) -> int:
    """Decimals for a value printed with about three significant digits (at most 3, at least 0)."""
    if v is None or not np.isfinite(v) or v == 0:
        return 3
    return int(min(3, max(0, 2 - math.floor(math.log10(abs(v))))))


def _text_colour(rgba) -> str:
    r, g, b = rgba[:3]
    return "white" if 0.299 * r + 0.587 * g + 0.114 * b < 0.5 else "black"


# ----------------------------------------------------------------------------------------------------- heat maps

def _new_axes(ax, n_rows, n_cols):
    import matplotlib.axes
    import matplotlib.pyplot as plt
    if ax is not None:
        if not isinstance(ax, matplotlib.axes.Axes):
            raise ValueError(f"ax: expected None or a matplotlib Axes, got {type(ax).__name__}")
        return ax.figure, ax, False
    fig, ax = plt.subplots(figsize=(max(6.0, 0.52 * n_cols + 3.6), max(3.6, 0.36 * n_rows + 2.9)))
    return fig, ax, True


def _grid(ax, algorithms, names, rows):
    """Tick labels (algorithms on top, rotated; scenarios on the left), white lines between cells and a black line
    between the papers' scenarios and the ladder rungs."""
    n_r, n_c = len(names), len(algorithms)
    ax.set_xticks(np.arange(n_c))
    ax.set_xticklabels(algorithms, rotation=55, ha="left", rotation_mode="anchor", fontsize=8)
    ax.set_yticks(np.arange(n_r))
    ax.set_yticklabels([_row_label(n, rows) for n in names], fontsize=8)
    ax.xaxis.tick_top()
    ax.xaxis.set_label_position("top")
    ax.set_xticks(np.arange(n_c + 1) - 0.5, minor=True)
    ax.set_yticks(np.arange(n_r + 1) - 0.5, minor=True)
    ax.grid(False)
    ax.grid(which="minor", color="white", lw=1.2)
    ax.tick_params(which="minor", length=0)
    ax.tick_params(which="major", length=0)
    for side in ax.spines.values():
        side.set_visible(False)
    ladder = [n.startswith("ladder-") for n in names]
    for i in range(1, n_r):
        if ladder[i] != ladder[i - 1]:
            ax.axhline(i - 0.5, color="k", lw=1.4)
    ax.set_xlim(-0.5, n_c - 0.5)
    ax.set_ylim(n_r - 0.5, -0.5)
    ax.set_xlabel("algorithm")
    ax.set_ylabel("scenario" + ("  (η: computed nonlinearity index, median)" if rows else ""))


def _draw_cells(ax, data, kinds, labels, diverged, cmap, norm, bold=None, dots=None):
    """Draw the image of ``data`` (NaN where there is no value) and per cell its annotation: ``kinds`` is 'value',
    'na', 'div' or 'none'; partly diverged cells (``diverged`` > 0 with a value) get a red border and "† n"."""
    from matplotlib.patches import Rectangle
    masked = np.ma.masked_invalid(data)
    cmap = cmap.with_extremes(bad="none")
    im = ax.imshow(masked, cmap=cmap, norm=norm, aspect="auto", interpolation="nearest")
    n_r, n_c = data.shape
    for i in range(n_r):
        for j in range(n_c):
            kind = kinds[i][j]
            if kind == "na":
                ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, fc=NA_COLOUR, ec="none", zorder=0.5))
                ax.text(j, i, "n/a", ha="center", va="center", fontsize=6.5, color="0.35")
            elif kind == "div":
                ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, fc=DIVERGED_COLOUR, ec="none", zorder=0.5))
                ax.text(j, i, "div.", ha="center", va="center", fontsize=6.5, color="white", fontweight="bold")
            elif kind == "none":
                ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, fc=NO_VALUE_COLOUR, ec="0.8", zorder=0.5))
                ax.text(j, i, "--", ha="center", va="center", fontsize=6.5, color="0.4")
            else:
                colour = _text_colour(cmap(norm(np.clip(data[i, j], norm.vmin, norm.vmax))))
                part = diverged[i][j] > 0
                weight = "bold" if bold is not None and bold[i][j] else "normal"
                ax.text(j, i - (0.14 if part else 0.0), labels[i][j], ha="center", va="center", fontsize=6.5,
                        color=colour, fontweight=weight)
                if part:
                    ax.text(j, i + 0.24, f"† {diverged[i][j]}", ha="center", va="center", fontsize=5.5,
                            color=colour)
                    for ec, lw in (("white", 3.6), (DIVERGED_COLOUR, 1.8)):      # visible on dark and light
                        ax.add_patch(Rectangle((j - 0.42, i - 0.42), 0.84, 0.84, fill=False, ec=ec, lw=lw,
                                               zorder=3))
                if dots is not None and dots[i][j]:
                    ax.plot([j + 0.33], [i - 0.31], "o", ms=2.6, color=colour, zorder=4)
    return im


def _legend(ax, kinds, diverged, stat, extra=()):
    """The key below the axes: only the markings that occur."""
    from matplotlib.patches import Patch
    flat = [k for row in kinds for k in row]
    handles = list(extra)
    if any(d > 0 and k == "value" for rd, rk in zip(diverged, kinds) for d, k in zip(rd, rk)):
        handles.append(Patch(fc="white", ec=DIVERGED_COLOUR, lw=1.6,
                             label=f"† n: n runs diverged ({stat} over the others)"))
    if "div" in flat:
        handles.append(Patch(fc=DIVERGED_COLOUR, label="div.: diverged, fewer than 2 runs left (no value)"))
    if "na" in flat:
        handles.append(Patch(fc=NA_COLOUR, label="n/a: the algorithm does not apply (cell_table says why)"))
    if "none" in flat:
        handles.append(Patch(fc=NO_VALUE_COLOUR, ec="0.8", label="--: not recorded"))
    if handles:
        ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.01), ncol=2, fontsize=7.5,
                  frameon=False, handlelength=1.6, columnspacing=1.5)


def _value(stat) -> float | None:
    """The ``value`` of a metric dict, or None (no dict, or no value: too few valid runs)."""
    return None if stat is None or stat.get("value") is None else float(stat["value"])


def _cell_grid(cells, scenarios, value_of):
    """What a heat map draws, scenario rows by algorithm columns: ``(algorithms, names, by, rows, data, kinds,
    diverged)`` with ``data`` the cells' ``value_of(cell)`` (NaN where None), ``kinds`` "na" (does not apply), "value",
    "div" (no value, runs diverged) or "none" (no value otherwise), and ``diverged`` the diverged runs per cell."""
    algorithms, names, by = _layout(cells)
    rows = _scenario_rows(scenarios)
    n_r, n_c = len(names), len(algorithms)
    data = np.full((n_r, n_c), np.nan)
    kinds = [["na"] * n_c for _ in range(n_r)]
    diverged = [[0] * n_c for _ in range(n_r)]
    for i, s in enumerate(names):
        for j, a in enumerate(algorithms):
            c = by.get((s, a))
            if c is None or "reason" in c:
                continue
            diverged[i][j] = int(c.get("diverged") or 0)
            v = value_of(c)
            if v is None:
                kinds[i][j] = "div" if diverged[i][j] else "none"
            else:
                kinds[i][j] = "value"
                data[i, j] = v
    return algorithms, names, by, rows, data, kinds, diverged


def rmse_heatmap(cells: Iterable[dict] | ArenaResult, scenarios: Iterable[dict] | None = None,
                 ax: matplotlib.axes.Axes | None = None) -> matplotlib.figure.Figure:
    """Heat map of the position RMSE of every cell relative to the best algorithm of its scenario.

    ``cells``: the arena's cells (module docstring; ``rmse_position`` in m).  ``scenarios``: optional scenario
    table (:func:`mmlib.arena.study.scenario_table`); when given, each row label carries the scenario's computed
    nonlinearity index.  ``ax``: an Axes to draw into (default: a new figure).

    Drawn: rows = scenarios, columns = algorithms (order of ``cells``); the colour is RMSE / (smallest RMSE of the
    row) -- a dimensionless ratio, >= 1 but for cells with diverged runs -- on a log scale from 1 to 10 (ratios
    beyond clipped to the end colours);
    each cell is annotated with the ratio to two significant digits.  The best of a row is the smallest RMSE
    among its cells none of whose runs diverged (the cells :func:`mmlib.arena.study.rank_scenario` ranks, all on the
    same runs), so a ratio below 1 is possible only for a cell with diverged runs (its RMSE is over fewer runs); a
    cell some of whose runs diverged shows the RMSE of the others, with a red border and "† n".  Cells whose
    algorithm does not apply are grey with "n/a"; cells without an RMSE (every run, or all but one, diverged) are
    red with "div.".  Returns the Figure.
    """
    import matplotlib
    algorithms, names, by, rows, data, kinds, diverged = _cell_grid(
        cells, scenarios, lambda c: _value(c.get("rmse_position")))
    n_r, n_c = data.shape
    for i in range(n_r):
        row = data[i]
        clean = [j for j in range(n_c) if kinds[i][j] == "value" and not diverged[i][j]]
        if clean:                                 # the best among the cells without diverged runs (ranked ones)
            data[i] = row / np.min(row[clean])
        elif np.isfinite(row).any():
            data[i] = row / np.nanmin(row)
    labels = [[_sig2(data[i, j]) if kinds[i][j] == "value" else "" for j in range(n_c)] for i in range(n_r)]
    fig, ax, own = _new_axes(ax, n_r, n_c)
    norm = matplotlib.colors.LogNorm(*RMSE_RATIO_RANGE, clip=False)
    cmap = matplotlib.colormaps["YlGnBu"]
    im = _draw_cells(ax, data, kinds, labels, diverged, cmap, norm)
    _grid(ax, algorithms, names, rows)
    _colorbar(fig, im, ax, "position RMSE / best in scenario (log; > 10 clipped)", [1, 1.5, 2, 3, 5, 10])
    _legend(ax, kinds, diverged, "RMSE")
    n = _n_runs(by.values())
    ax.set_title(f"Position RMSE relative to the best algorithm of each scenario ({n} Monte Carlo runs)",
                 fontsize=10)
    if own:
        fig.tight_layout()
    return fig


def _colorbar(fig, im, ax, label: str, ticks: list[float]) -> None:
    """The heat maps' log colour bar: ``label``, ticks at ``ticks`` written plainly, no minor ticks."""
    cb = fig.colorbar(im, ax=ax, extend="both", fraction=0.035, pad=0.02)
    cb.set_label(label)
    cb.set_ticks(ticks, labels=[f"{t:g}" for t in ticks])
    cb.minorticks_off()


def consistency_heatmap(cells: Iterable[dict] | ArenaResult, which: str = "anees",
                        scenarios: Iterable[dict] | None = None,
                        ax: matplotlib.axes.Axes | None = None) -> matplotlib.figure.Figure:
    """Heat map of the filters' consistency: ANEES (``which="anees"``) or ANIS (``"anis"``) over its degrees of
    freedom.

    ``cells``: the arena's cells (module docstring; ``anees``/``anis`` dicts with ``value``, ``dof``, ``band``).
    ``scenarios``: optional scenario table (row labels get the nonlinearity index).  ``ax``: an Axes to draw into.

    Drawn: rows = scenarios, columns = algorithms; the colour is value / dof (dimensionless; 1 = a consistent
    filter, > 1 over-confident: errors larger than the filter's covariance says, < 1 pessimistic) on a log scale
    from 0.2 to 5 centred at 1 (clipped beyond); each cell is annotated with value / dof to two significant digits,
    in bold with a dot in its corner when the value lies inside its 95 % band (``band``: for the ANIS the exact
    chi-square interval of a consistent filter's average over runs and steps, for the ANEES the lenient one of a
    run-average at one step; :func:`mmlib.arena.study.consistency`).  n/a, "div." (fewer than two runs left) and
    partly diverged cells
    ("† n", red border; the value over the others) as in :func:`rmse_heatmap`; "--" where the statistic was not
    recorded.  Returns the Figure.
    """
    import matplotlib
    from matplotlib.lines import Line2D
    if which not in CONSISTENCY_NAMES:
        raise ValueError(f"which: expected 'anees' or 'anis', got {which!r}")
    algorithms, names, by, rows, data, kinds, diverged = _cell_grid(
        cells, scenarios, lambda c: None if _value(c.get(which)) is None else _value(c[which]) / float(c[which]["dof"]))
    n_r, n_c = data.shape
    inside = [[False] * n_c for _ in range(n_r)]
    for i, s in enumerate(names):
        for j, a in enumerate(algorithms):
            st = (by.get((s, a)) or {}).get(which)
            if kinds[i][j] == "value":
                band = st.get("band")
                inside[i][j] = bool(st["inside"]) if st.get("inside") is not None else (
                    band is not None and band[0] <= st["value"] <= band[1])
    labels = [[_sig2(data[i, j]) if kinds[i][j] == "value" else "" for j in range(n_c)] for i in range(n_r)]
    fig, ax, own = _new_axes(ax, n_r, n_c)
    norm = matplotlib.colors.LogNorm(*CONSISTENCY_RANGE, clip=False)
    cmap = matplotlib.colormaps["PuOr_r"]
    im = _draw_cells(ax, data, kinds, labels, diverged, cmap, norm, bold=inside, dots=inside)
    _grid(ax, algorithms, names, rows)
    name, stat = CONSISTENCY_NAMES[which]
    _colorbar(fig, im, ax, f"{name} / dof (log; 1 = consistent; > 1 over-confident)", [0.2, 0.5, 1, 2, 5])
    key = Line2D([], [], ls="none", marker="o", ms=3.5, color="k",
                 label=f"dot, bold: {name} inside its 95 % band")
    _legend(ax, kinds, diverged, name, extra=[key] if any(map(any, inside)) else [])
    n = _n_runs(by.values())
    ax.set_title(f"{name} / degrees of freedom (average {stat} over runs and steps; {n} Monte Carlo runs)",
                 fontsize=10)
    if own:
        fig.tight_layout()
    return fig


# ----------------------------------------------------------------------------------------------------- ladder

def _rmse(by, scenario, algorithm):
    """(value, stderr, diverged) of a cell's position RMSE, or None when it has none."""
    c = by.get((scenario, algorithm))
    if c is None or "reason" in c or c.get("rmse_position") is None or c["rmse_position"].get("value") is None:
        return None
    r = c["rmse_position"]
    return float(r["value"]), (np.nan if r.get("stderr") is None else float(r["stderr"])), int(c.get("diverged") or 0)


def _base_rule(algorithm: str) -> str:
    """The single-model filter an IMM runs in its modes: "IMMUKF" -> "UKF" (the algorithm itself otherwise)."""
    for prefix in ("IMM-", "IMM"):
        if algorithm.startswith(prefix) and len(algorithm) > len(prefix):
            return algorithm[len(prefix):]
    return algorithm


def _styles(algorithms):
    """One errorbar style per algorithm: a colour and marker per base rule, shared by the rule's single-model filter
    (solid, filled) and its IMM (dashed, open), so that the layer's effect reads as the gap between a pair."""
    markers = "osD^vP*Xh<>"
    bases = []
    for a in algorithms:
        if _base_rule(a) not in bases:
            bases.append(_base_rule(a))
    out = []
    for a in algorithms:
        k = bases.index(_base_rule(a))
        imm = _base_rule(a) != a
        out.append({"color": f"C{k % 10}", "marker": markers[k % len(markers)], "ms": 5.5, "lw": 1.4,
                    "ls": "--" if imm else "-", "mfc": "white" if imm else f"C{k % 10}", "mew": 1.2,
                    "capsize": 2.5, "elinewidth": 0.9})
    return out


def _plain_log_ticks(axis, lo, hi):
    """Log-axis ticks labelled as plain numbers: at 1, 2, 5 x 10^k (10, 20, 50, 100, ...), more within a decade."""
    import matplotlib.ticker as mt
    subs = (1.0, 2.0, 5.0) if hi > 30 * lo else (1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0)
    axis.set_major_locator(mt.LogLocator(base=10, subs=subs))
    axis.set_major_formatter(mt.FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(mt.NullFormatter())


def ladder_curves(cells: Iterable[dict] | ArenaResult, scenarios: Iterable[dict],
                  algorithms: Sequence[str] | None = None) -> matplotlib.figure.Figure:
    """Position RMSE along the ladder's two axes, one curve per algorithm.

    ``cells``: the arena's cells (``rmse_position`` in m).  ``scenarios``: the scenario table
    (:func:`mmlib.arena.study.scenario_table`): each rung's ``properties`` (``axis``, ``sigma_theta_mrad``,
    ``omega_deg_s``) and computed ``nonlinearity_index`` (median).  ``algorithms``: the algorithms to draw (default
    :data:`LADDER_ALGORITHMS`, those present in the cells).

    Drawn: left, position RMSE (m, log) with +-2 standard-error bars against the computed nonlinearity index
    (dimensionless, log) of the "nonlinearity" rungs, their bearing noise (mrad) on the top axis; right, position
    RMSE against the turn rate (deg/s) of the "manoeuvre" rungs plus the nonlinearity rung of the same bearing
    noise (where the two axes cross; dotted line in both panels).  A rung where an algorithm has no RMSE (not
    applicable, or every run diverged) is a gap in its curve; a point some of whose runs diverged is ringed in
    red.  Returns the Figure.
    """
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    all_algorithms, names, by = _layout(cells)
    if scenarios is None:
        raise ValueError("scenarios: required (study.scenario_table()): the rungs' axes and nonlinearity index")
    rows = _scenario_rows(scenarios)
    if algorithms is None:
        algorithms = [a for a in LADDER_ALGORITHMS if a in all_algorithms]
        if not algorithms:
            raise ValueError(f"cells: none of the default algorithms {', '.join(LADDER_ALGORITHMS)} is in the cells;"
                             f" pass algorithms=")
    else:
        algorithms = check_names(algorithms, "algorithms")
        unknown = [a for a in algorithms if a not in all_algorithms]
        if unknown or not algorithms:
            raise ValueError(f"algorithms: {'unknown ' + ', '.join(map(repr, unknown)) if unknown else 'empty'};"
                             f" in the cells: {', '.join(all_algorithms)}")

    def props(n):
        return rows[n].get("properties") or {}

    present = [n for n in names if n in rows]
    nl = [n for n in present if props(n).get("axis") == "nonlinearity"]
    turn = [n for n in present if props(n).get("axis") == "manoeuvre"]
    if not nl and not turn:
        raise ValueError("scenarios: no 'nonlinearity' or 'manoeuvre' ladder rung among the cells' scenarios")
    for n in nl:
        if _eta(rows[n]) is None or _eta(rows[n]) <= 0:
            raise ValueError(f"scenarios: rung {n!r} has no positive nonlinearity_index median")
    nl.sort(key=lambda n: _eta(rows[n]))
    turn_sigma = {props(n).get("sigma_theta_mrad") for n in turn}
    turn_omega = {props(n).get("omega_deg_s") for n in turn}
    cross = [n for n in nl if props(n).get("sigma_theta_mrad") in turn_sigma
             and props(n).get("omega_deg_s") not in turn_omega]
    turn_all = sorted(turn + cross, key=lambda n: props(n).get("omega_deg_s"))

    fig, (ax_nl, ax_w) = plt.subplots(1, 2, figsize=(12.0, 5.4))
    partly_any = False
    for a, style in zip(algorithms, _styles(algorithms)):
        for ax, rungs, x_of in ((ax_nl, nl, lambda n: _eta(rows[n])),
                                (ax_w, turn_all, lambda n: float(props(n).get("omega_deg_s")))):
            if not rungs:
                continue
            x = np.array([x_of(n) for n in rungs])
            vals = [_rmse(by, n, a) for n in rungs]
            y = np.array([np.nan if v is None else v[0] for v in vals])
            se = np.array([np.nan if v is None else v[1] for v in vals])
            yerr = np.nan_to_num(BAND_SIGMAS * se)
            ax.errorbar(x, y, yerr=np.vstack([np.minimum(yerr, 0.95 * np.nan_to_num(y)), yerr]), label=a, **style)
            part = np.array([v is not None and v[2] > 0 for v in vals])
            if part.any():
                partly_any = True
                ax.plot(x[part], y[part], "o", ms=11, mfc="none", mec=DIVERGED_COLOUR, mew=1.4, zorder=5)
    n = _n_runs(by.values())
    if nl:
        ax_nl.set_xscale("log")
        ax_nl.set_yscale("log")
        _plain_log_ticks(ax_nl.yaxis, *ax_nl.get_ylim())
        ax_nl.set(xlabel="computed nonlinearity index η (median over runs and steps; dimensionless)",
                  ylabel="position RMSE (m)",
                  title="Nonlinearity axis: bearing noise stepped, turns at "
                        + "/".join(sorted({f"{props(r).get('omega_deg_s'):g}" for r in nl})) + " °/s")
        top = ax_nl.secondary_xaxis("top")
        top.set_xticks([_eta(rows[r]) for r in nl],
                       labels=[f"{props(r).get('sigma_theta_mrad'):g}" for r in nl], fontsize=8)
        top.minorticks_off()
        top.set_xlabel("bearing noise σθ (mrad)", fontsize=9)
        for r in cross:
            ax_nl.axvline(_eta(rows[r]), color="0.5", ls=":", lw=1.0)
            ax_nl.annotate(f"{r}: the manoeuvre axis\ncrosses here (right panel)", xy=(_eta(rows[r]), 1.0),
                           xycoords=("data", "axes fraction"), xytext=(4, -4), textcoords="offset points",
                           ha="left", va="top", fontsize=7, color="0.35")
    else:
        ax_nl.text(0.5, 0.5, "no nonlinearity rungs in the cells", transform=ax_nl.transAxes, ha="center")
    if turn_all:
        ax_w.set_yscale("log")
        _plain_log_ticks(ax_w.yaxis, *ax_w.get_ylim())
        omegas = [float(props(r).get("omega_deg_s")) for r in turn_all]
        ax_w.set_xticks(omegas, labels=[f"{w:g}" for w in omegas])
        ax_w.set(xlabel="turn rate ω of the manoeuvres (°/s)", ylabel="position RMSE (m)",
                 title="Manoeuvre axis: turn rate stepped, bearing noise "
                       + "/".join(f"{s:g}" for s in sorted(x for x in turn_sigma if x is not None)) + " mrad")
        top = ax_w.secondary_xaxis("top")
        top.set_xticks(omegas, labels=turn_all, fontsize=7)
        top.minorticks_off()
        for r in cross:
            ax_w.axvline(float(props(r).get("omega_deg_s")), color="0.5", ls=":", lw=1.0)
    else:
        ax_w.text(0.5, 0.5, "no manoeuvre rungs in the cells", transform=ax_w.transAxes, ha="center")
    for ax in (ax_nl, ax_w):
        ax.grid(True, which="major", alpha=0.3)
        ax.grid(True, which="minor", alpha=0.12)
    handles, labels = ax_nl.get_legend_handles_labels() if nl else ax_w.get_legend_handles_labels()
    if partly_any:
        handles.append(Line2D([], [], ls="none", marker="o", ms=9, mfc="none", mec=DIVERGED_COLOUR, mew=1.4))
        labels.append("some runs diverged (RMSE of the others)")
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 5), fontsize=8, frameon=False)
    fig.suptitle(f"Position RMSE along the ladder ({n} Monte Carlo runs; bars ± {BAND_SIGMAS:g} standard errors; "
                 "gaps: no RMSE at that rung)", fontsize=10)
    rows_legend = math.ceil(len(labels) / min(len(labels), 5))
    fig.tight_layout(rect=(0, 0.045 * rows_legend + 0.01, 1, 1))
    return fig


# ----------------------------------------------------------------------------------------------------- table

CELL_TABLE_KEYS = ("algorithm", "RMSE position (m)", "RMSE velocity (m/s)", "ANEES (95 % band)", "ANIS (95 % band)",
                   "diverged", "cost (µs / run-step)", "rank", "versus best, or why it does not apply")


def _consistency_text(st) -> str:
    if st is None:
        return "--"
    if st.get("value") is None:
        return f"-- (dof {st['dof']:g}; fewer than two valid runs with finite statistics)"
    v = st["value"]
    d = _digits(v)
    text = f"{value_pm(v, st.get('stderr'), d)} (dof {st['dof']:g}"
    band = st.get("band")
    if band is not None:
        inside = st["inside"] if "inside" in st else band[0] <= v <= band[1]
        text += f"; [{band[0]:.{_digits(band[0])}f}, {band[1]:.{_digits(band[1])}f}]: " + \
            ("inside" if inside else "outside")
    return text + ")"


def _rmse_text(r) -> str:
    if r is None or r.get("value") is None:
        return "--"
    return value_pm(r["value"], r.get("stderr"), _digits(r["value"]))


def _versus_text(vb) -> str:
    if not vb:
        return "--"
    if vb.get("verdict") == "best":
        return "best"
    d, se = vb.get("difference_m2"), vb.get("stderr_m2")
    if d is None:
        diff = ""
    elif vb.get("verdict") == "identical (to round-off)":        # round-off: its size only, never a z-score
        diff = f" (vs {vb.get('algorithm')}: |Δ MSE| {abs(d):.0e} m²)"
    else:
        diff = f" (vs {vb.get('algorithm')}: Δ MSE {format_pm(d, se, signed=True)} m²)"
    return f"{vb.get('verdict')}{diff}"


def cell_table(cells: Iterable[dict] | ArenaResult, scenario: str) -> list[dict]:
    """One scenario's cells as table rows.

    ``cells``: the arena's cells; ``scenario``: a scenario name present in them.  Returns a list of dicts, one per
    algorithm (order of ``cells``), with the keys :data:`CELL_TABLE_KEYS`: position RMSE (m) and velocity RMSE (m/s)
    as "value ± standard error", ANEES and ANIS as "value ± se (dof; [95 % band]: inside/outside)", the diverged
    runs (with when and why), the cost (µs of CPU per run and step), the rank and the verdict against the
    scenario's best (paired difference of the per-run mean squared position errors, m²); for an algorithm that
    does not apply, "n/a" and the reason.  For Markdown::

        rows = cell_table(cells, "ladder-nl3")
        markdown_table(list(rows[0]), [list(r.values()) for r in rows])
    """
    algorithms, names, by = _layout(cells)
    if not isinstance(scenario, str) or scenario not in names:
        raise ValueError(f"scenario: unknown scenario {scenario!r}; in the cells: {', '.join(names)}")
    out = []
    for a in algorithms:
        c = by.get((scenario, a))
        if c is None:
            continue
        if "reason" in c:
            out.append(dict(zip(CELL_TABLE_KEYS, [a] + ["n/a"] * (len(CELL_TABLE_KEYS) - 2)
                                + [f"n/a: {c['reason']}"])))
            continue
        ndiv = int(c.get("diverged") or 0)
        cost = c.get("cost_us_per_run_step")
        out.append(dict(zip(CELL_TABLE_KEYS, [
            a, _rmse_text(c.get("rmse_position")), _rmse_text(c.get("rmse_velocity")),
            _consistency_text(c.get("anees")), _consistency_text(c.get("anis")),
            (c.get("divergence") or f"{ndiv} of {c.get('n_runs')} runs") if ndiv else "0",
            "--" if cost is None else f"{cost:.{_digits(cost)}f}",
            "--" if c.get("rank") is None else str(c["rank"]),
            _versus_text(c.get("versus_best"))])))
    return out


# ----------------------------------------------------------------------------------------------------- claims

def claim_scenario_matrix(paper_claims: Iterable[dict]) -> str:
    """The papers' claims across the arena as a Markdown matrix: one row per claimed pair "A − B" (with the paper and
    the claim's one verdict), one column per scenario (the pairs' scenario orders merged), and in each cell the symbol
    of the part verdict (:data:`mmlib.experiment.notebook.PART_SYMBOLS`: ✓ holds, ✗ contradicted, (✓)/(✗) negligible,
    · no detectable difference, ≡ identical to round-off, ? not comparable) with the relative position-MSE difference
    (none for an identity, "div." for a divergence part); empty where the pair does not apply.

    ``paper_claims``: the list of :func:`mmlib.arena.study.paper_claims` (``paper``, ``verdict``, ``parts``,
    ``pairs`` with ``part_verdicts``, optionally ``excluded``); a scenario kept out of the pooled verdicts (in some
    claim's ``excluded``) is marked † in the header: its cells are shown, its parts are not in the row's verdict."""
    from mmlib.experiment.notebook import PART_SYMBOLS
    from mmlib.experiment.report import PartVerdict
    from mmlib.experiment.views import markdown_table
    if isinstance(paper_claims, (str, bytes, dict)) or not hasattr(paper_claims, "__iter__"):
        raise ValueError(f"paper_claims: expected the list of study.paper_claims(...), got "
                         f"{type(paper_claims).__name__}")
    paper_claims = list(paper_claims)
    for i, pc in enumerate(paper_claims):
        if not isinstance(pc, dict) or any(k not in pc for k in ("paper", "verdict", "parts", "pairs")) or any(
                not isinstance(pair, dict) or "part_verdicts" not in pair for pair in pc["pairs"]):
            raise ValueError(f"paper_claims: item {i} is not an item of study.paper_claims(...) (paper, verdict, "
                             f"parts, pairs with part_verdicts)")
    scenarios: list = []          # every pair's scenarios merged in their order (each new one after its predecessor)
    for pc in paper_claims:
        for pair in pc["pairs"]:
            prev = None
            for s in pair["part_verdicts"]:
                if s not in scenarios:
                    scenarios.insert(0 if prev is None else scenarios.index(prev) + 1, s)
                prev = s
    rows = []
    for pc in paper_claims:
        numbers = {(p["comparison"], p["quantity"].rsplit(", ", 1)[-1]): p for p in pc["parts"]}
        for pair in pc["pairs"]:
            row = [pc["paper"], pc["verdict"], f"{pair['a']} − {pair['b']}"]
            for s in scenarios:
                v = pair["part_verdicts"].get(s)
                if v is None:
                    row.append("")
                    continue
                p = numbers.get((f"{pair['a']} − {pair['b']}", s))
                cell = PART_SYMBOLS[PartVerdict(v)]
                if p is not None and p["quantity"].startswith("diverged"):
                    cell += " div."
                elif p is not None and v != PartVerdict.IDENTICAL and p["reference"] and p["difference"] is not None:
                    cell += f" {100 * p['difference'] / abs(p['reference']):+.2g} %"
                row.append(cell)
            rows.append(row)
    legend = ("✓ holds · ✗ contradicted · (✓)/(✗) detected but negligible (< 1 %) · · no detectable difference · "
              "≡ identical to round-off · ? not comparable · div.: A diverged detectably more often")
    apart = {e["scenario"] for pc in paper_claims for e in pc.get("excluded", ())}
    if apart:
        legend += (" · †: kept out of the pooled verdict (a degenerate scenario or a reconstruction; judged apart: "
                   "study.paper_claims' excluded)")
    header = [f"{s} †" if s in apart else s for s in scenarios]
    return markdown_table(["paper", "verdict", "A − B", *header], rows) + "\n\n" + legend
