"""Tables and figures of a multiverse: factors, claim robustness, readings that reproduce the
published numbers, the one-factor-at-a-time view, the specification curve and the table match.

Markdown tables are returned as text; figures as matplotlib figures (the caller saves them).
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Iterable, Sequence

import numpy as np

from mmlib.core._validate import check_bool, check_positive_int
from mmlib.experiment import verdicts
from mmlib.experiment.multiverse import PRECISION, ROBUST_FRACTION, Multiverse
from mmlib.experiment.readings import ReadingSpace

if TYPE_CHECKING:
    import matplotlib.figure


def _cell(v) -> str:
    if v is None:
        return "--"
    if isinstance(v, float):
        return "nan" if not np.isfinite(v) else f"{v:.4g}"
    return str(v).replace("|", "\\|").replace("\n", " ")


def _cells(row, name: str) -> list:
    if isinstance(row, (str, bytes, dict)) or not hasattr(row, "__iter__"):
        raise ValueError(f"{name}: expected a sequence of cells, got {row!r}")
    return list(row)


def markdown_table(header: Sequence[Any], rows: Iterable[Sequence[Any]]) -> str:
    """A Markdown table; ``|`` in any cell (header included) is escaped, floats get 4 digits.  ``header`` and each
    row: sequences of cells of the header's length (a bare string is refused, never split into one letter a cell)."""
    header = _cells(header, "header")
    if not header:
        raise ValueError("header: expected at least one column")
    if isinstance(rows, (str, bytes)) or not hasattr(rows, "__iter__"):
        raise ValueError(f"rows: expected a sequence of rows (sequences of cells), got {rows!r}")
    rows = [_cells(r, f"rows[{i}]") for i, r in enumerate(rows)]
    for i, r in enumerate(rows):
        if len(r) != len(header):
            raise ValueError(f"rows[{i}]: {len(r)} cells for the {len(header)} columns of the header")
    lines = ["| " + " | ".join(_cell(h) for h in header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_cell(v) for v in r) + " |" for r in rows]
    return "\n".join(lines)


def value_pm(value: float | None, stderr: float | None, digits: int = 3) -> str:
    """``"value ± stderr"`` with ``digits`` decimals; the value alone when ``stderr`` is None or not finite, "--"
    when ``value`` is None.  ``digits`` an integer >= 0."""
    verdicts._real(value, "value")
    verdicts._real(stderr, "stderr")
    check_positive_int(digits, "digits", minimum=0)
    if value is None:
        return "--"
    if stderr is None or not np.isfinite(stderr):
        return f"{value:.{digits}f}"
    return f"{value:.{digits}f} ± {stderr:.{digits}f}"


def _positive(x, name: str) -> float:
    """A finite real number > 0, returned unchanged."""
    verdicts._real(x, name, none=False)
    if not (math.isfinite(x) and x > 0):
        raise ValueError(f"{name}: expected a finite number > 0, got {x!r}")
    return x


def _summary(mv, key: str):
    """A summary list from a :class:`Multiverse` (computed) or from its ``as_dict()`` form (stored)."""
    if isinstance(mv, dict):
        if key not in mv:
            raise ValueError(f"mv: expected a Multiverse or its as_dict() form, got a dict without {key!r}")
        return mv[key]
    return getattr(_multiverse(mv), key)()


def _multiverse(mv) -> Multiverse:
    if not isinstance(mv, Multiverse):
        raise ValueError(f"mv: expected a Multiverse (run_multiverse), got {type(mv).__name__}")
    return mv


def _factors(space) -> list:
    """The ``factors`` list of a ReadingSpace or of a stored multiverse."""
    if isinstance(space, ReadingSpace):
        return space.as_dict()
    if not isinstance(space, list) or not all(isinstance(f, dict) and "option_details" in f for f in space):
        raise ValueError(f"space: expected a ReadingSpace or the 'factors' list of a stored multiverse, got "
                         f"{type(space).__name__}")
    return space


def factors_table(space: ReadingSpace | list[dict]) -> str:
    """One row per factor: id, what is ambiguous, options (headline in bold), where the paper says it.
    ``space``: a ReadingSpace or the ``factors`` list of a stored multiverse."""
    rows = []
    factors = _factors(space)
    for f in factors:
        opts = "; ".join((f"**{o['name']}**: {o['label']}" if o["name"] == f["headline"]
                          else f"{o['name']}: {o['label']}") for o in f["option_details"])
        rows.append([f["id"], f["label"], opts, f["source"], "yes" if f["influential"] else "no"])
    return markdown_table(["factor", "ambiguity", "options (headline in bold)", "where in the paper",
                           "influential"], rows)


def options_table(space: ReadingSpace | list[dict]) -> str:
    """One row per option: the factor, the option, what it reads, and where the paper's text supports it."""
    factors = _factors(space)
    rows = [[f["id"], o["name"] + (" (headline)" if o["name"] == f["headline"] else ""), o["label"], o["source"]]
            for f in factors for o in f["option_details"]]
    return markdown_table(["factor", "option", "reading", "where the paper's text supports it"], rows)


def percent(x: float) -> str:
    """A fraction in [0, 1] as a whole percentage: ``0.483 -> "48"``."""
    verdicts._real(x, "x", none=False)
    return f"{100 * x:.0f}"


def share_text(entry: dict, verdict: str | None = None) -> str:
    """One verdict's share of the reading space with its interval, ``"holds 48 % [38, 58]"`` (``"holds 100 %"``
    when exact), from an entry of :meth:`Multiverse.claims_summary`; ``verdict`` defaults to the most frequent
    one.  For a design that is not a uniform sample, the entry's robustness text (no share)."""
    if not isinstance(entry, dict) or "share" not in entry or "verdict_counts" not in entry:
        raise ValueError(f"entry: expected an entry of Multiverse.claims_summary(), got {entry!r}")
    if entry["share"] is None:
        return entry["robustness"]
    if verdict is None:
        verdict = max(entry["share"], key=lambda k: (entry["share"][k], k == entry["headline_verdict"]))
    if verdict not in entry["share"]:
        raise ValueError(f"verdict: expected one of {list(entry['share'])}, got {verdict!r}")
    lo, hi = entry["interval"][verdict]
    f = entry["share"][verdict]
    band = "" if lo == hi == f else f" [{percent(lo)}, {percent(hi)}]"
    return f"{verdict} {percent(f)} %{band}"


def robustness_text(entry: dict) -> str:
    """A claim's robustness in one line from an entry of :meth:`Multiverse.claims_summary`: ``"robust — holds 96 %
    [92, 98] (uniform sample of 400 of 10752, seed S)"`` or ``"depends on the reading — holds 48 % [38, 58];
    contradicted 52 % [42, 62] (...)"``; for a design that is not a uniform sample, the counts over its universes
    and the note that they are no share."""
    if not isinstance(entry, dict) or "verdict_counts" not in entry or "robustness" not in entry:
        raise ValueError(f"entry: expected an entry of Multiverse.claims_summary(), got {entry!r}")
    if entry["share"] is None:
        return (f"{entry['robustness']} (counts over the design's universes: "
                + ", ".join(f"{k} {n}" for k, n in entry["verdict_counts"].items()) + ")")
    return (f"{entry['robustness']} — " + "; ".join(share_text(entry, k) for k in entry["verdict_counts"])
            + f" ({entry['weighting']})")


def claim_cell(claim: dict, across: dict | None) -> str:
    """A claim's verdict cell in a report: exactly one verdict word, the one decisive number and its share of the
    reading space with its interval, ``"holds — IMM5CKF − IMMCKF: position MSE +2.4e+03 % — holds 48 % [38, 58] of
    the space"``.  ``claim`` an entry of a results file's ``claims`` (``verdict``, ``decisive``); ``across`` the
    matching entry of the multiverse's ``claims_summary`` (None: the paper has no reading space)."""
    if not isinstance(claim, dict) or "verdict" not in claim:
        raise ValueError(f"claim: expected an entry of a results file's claims, got {claim!r}")
    word = str(verdicts.claim_category(claim["verdict"]))
    if across is not None and (not isinstance(across, dict) or "share" not in across or "robustness" not in across):
        raise ValueError(f"across: expected None or an entry of Multiverse.claims_summary(), got {across!r}")
    decisive = claim.get("decisive") or "--"
    if across is None:
        share = "no reading space"
    elif across["share"] is None:
        share = across["robustness"]
    else:
        share = share_text(across, word) + " of the space"
    return f"{word} — {decisive} — {share}"


def _weighting_note(summary: list) -> str:
    w = {c["weighting"] for c in summary}
    return "; ".join(sorted(w)) if w else "--"


def claims_table(mv: Multiverse | dict) -> str:
    """Per claim (:meth:`Multiverse.claims_summary`, computed or stored): the headline verdict, each verdict's share
    of the reading space with its 95 % interval (``"holds 48 % [38, 58]"``; exact, without interval, when the full
    factorial is run), robust or not, and the star universes' verdicts (reported apart).  The header states the
    weighting (e.g. "uniform sample of 200 of 10752, seed S")."""
    summary = _summary(mv, "claims_summary")
    rows = []
    for c in summary:
        if c["share"] is None:
            across = c["robustness"] + " (counts over the design: " + \
                ", ".join(f"{k} {n}" for k, n in c["verdict_counts"].items()) + ")"
        else:
            across = "; ".join(share_text(c, k) for k in c["verdict_counts"])
        star = ", ".join(f"{k} {n}" for k, n in c["star_counts"].items()) or "--"
        rows.append([c["claim"], c["headline_verdict"], across, c["robustness"], star])
    return markdown_table(["claim", "headline verdict", f"share of the reading space [95 % interval] "
                                                        f"({_weighting_note(summary)})",
                           f"robust (lower bound ≥ {100 * ROBUST_FRACTION:.0f} % for one verdict)",
                           "star: each option alone (not counted)"], rows)


def claim_option_table(mv: Multiverse | dict) -> str:
    """The claim x option view: one row per option of every factor, one column per claim (numbered C1, C2, ...:
    listed below the table), each cell the share of that claim's most frequent verdict among the counted universes
    with that option (and their number), so an option that drives a claim stands out.  Empty text with a note when
    the design is not a uniform sample."""
    summary = _summary(mv, "claims_summary")
    with_table = [c for c in summary if c.get("by_option")]
    if not with_table:
        return "No claim x option table: the design is not a uniform sample."
    modal = [max(c["verdict_counts"], key=c["verdict_counts"].get) for c in with_table]
    first = with_table[0]["by_option"]
    rows = []
    for fid, options in first.items():
        for opt in options:
            cells = [f"{fid}: {opt}", options[opt]["n"]]
            for c, v in zip(with_table, modal):
                cell = c["by_option"][fid][opt]
                cells.append("--" if not cell["n"] else f"{percent(cell['share'].get(v, 0.0))} %")
            rows.append(cells)
    header = ["option", "universes"] + [f"C{k + 1}: {v}" for k, v in enumerate(modal)]
    legend = "\n".join(f"- C{k + 1}: {c['claim']} (overall {share_text(c, v)})"
                        for k, (c, v) in enumerate(zip(with_table, modal)))
    return markdown_table(header, rows) + "\n\n" + legend


def _joint(t: dict | None) -> str:
    """A joint test as text: ``"Σz² 12.3 (2 cells, p 0.002): fails"``."""
    if t is None:
        return "--"
    return (f"Σz² {t['statistic']:.3g} ({t['dof']} cell{'s' if t['dof'] != 1 else ''}, p {t['p_value']:.2g}): "
            f"{'passes' if t['passes'] else 'fails'}")


def numbers_table(mv: Multiverse | dict) -> str:
    """Per published number: the headline verdict (a reproduced cell inside a row or table failing its joint test
    is *isolated*) with its row's joint test, the counted universes reproducing it (isolated ones apart), and the
    closest universe among those precise enough (s.e. ≤ ``PRECISION`` of the printed value), by relative
    distance."""
    rows = []
    summary = _summary(mv, "numbers_summary")
    for s in summary:
        c = s["closest"]
        iso = f" (+{s['n_isolated']} isolated)" if s["n_isolated"] else ""
        rows.append([s["item"], s["algorithm"], s["quantity"], s["paper"], s["headline_verdict"],
                     _joint(s["joint_test"]["row"]) if s["joint_test"] else "--",
                     f"{s['n_reproduced']} / {s['n_counted']}{iso}",
                     s["closest_status"] if c is None else value_pm(c["replicated"], c["stderr"]),
                     "--" if c is None else f"{100 * c['relative_distance']:.1f} %",
                     "--" if c is None else c["verdict"],
                     "--" if c is None else c["describe"]])
    prec = f"{100 * PRECISION:.0f} %"
    return markdown_table(["item", "algorithm", "quantity", "paper", "headline verdict", "headline row's joint test",
                           f"universes reproducing ({_weighting_note(summary)})",
                           f"closest precise universe (s.e. ≤ {prec} of the paper's)", "its relative distance",
                           "its verdict", "closest reading"], rows)


def most_reading(t: dict) -> str:
    """The reading that reproduces the most cells of a table, or 'none' when no reading reproduces any."""
    if not isinstance(t, dict) or "most_describe" not in t or "most_n_reproduced" not in t:
        raise ValueError(f"t: expected an entry of Multiverse.table_match(), got {t!r}")
    return t["most_describe"] if t["most_n_reproduced"] else "none (no reading reproduces a cell)"


def table_match_table(mv: Multiverse | dict) -> str:
    """Per published table (:meth:`Multiverse.table_match`, computed or stored): its cells; the headline's cells
    reproduced (isolated ones apart), Σz² and joint test; the counted universes whose table passes its joint test;
    the best-matching precise reading (smallest root-mean-square relative distance among the universes whose every
    cell has s.e. ≤ ``PRECISION`` of the printed value) with its Σz² and joint test; and the reading that reproduces
    the most cells."""
    rows = []
    for t in _summary(mv, "table_match"):
        iso = f" (+{t['isolated']} isolated)" if t["isolated"] else ""
        rows.append([t["table"], t["n_cells"], f"{t['headline_n_reproduced']} / {t['n_cells']}{iso}",
                     _joint(t["joint_test"]), f"{t['n_passing']} / {t['n_counted']}",
                     t["best_describe"],
                     "--" if t["best_rms_relative"] is None else f"{100 * t['best_rms_relative']:.1f} %",
                     _joint(t["best_joint_test"]), f"{t['best_n_reproduced']} / {t['n_cells']}",
                     f"{t['most_n_reproduced']} / {t['n_cells']}", most_reading(t)])
    return markdown_table(["table", "cells", "headline universe: cells reproduced", "headline joint test",
                           "universes passing the joint test",
                           f"best-matching precise reading (s.e. ≤ {100 * PRECISION:.0f} %)",
                           "its RMS relative distance", "its joint test", "its cells reproduced",
                           "most cells any reading reproduces", "that reading"], rows)


def one_factor_table(mv: Multiverse, columns: Sequence[tuple[str, tuple]]) -> str:
    """The one-factor-at-a-time view: ``columns`` is a list of (header, key) with key a value key
    (item, algorithm, quantity) or ``("effect", name)``."""
    _multiverse(mv)
    if isinstance(columns, (str, bytes, dict)) or not hasattr(columns, "__iter__"):
        raise ValueError(f"columns: expected a sequence of (header, key) pairs, got {columns!r}")
    columns = list(columns)
    for i, c in enumerate(columns):
        if not (isinstance(c, (tuple, list)) and len(c) == 2 and isinstance(c[0], str) and isinstance(c[1], tuple)
                and (len(c[1]) == 3 or (len(c[1]) == 2 and c[1][0] == "effect"))):
            raise ValueError(f"columns[{i}]: expected (header, (item, algorithm, quantity)) or (header, ('effect', "
                             f"name)), got {c!r}")
    rows = []
    for i, fid, reading in mv.one_factor_view():
        u = mv.universes[i]
        label = "headline" if fid is None else f"{fid}: {mv.space.factor(fid).option(reading[fid]).label}"
        cells = [label]
        for _, key in columns:
            if key[0] == "effect":
                e = mv.effect(u, key[1])
                cells.append(value_pm(e.value, e.stderr, 3 if abs(e.value or 0) < 100 else 0))
            else:
                v = mv.value(u, key)
                cells.append("--" if v is None else value_pm(v.replicated, v.stderr, 2))
        ndiv = sum(u.diverged.values())
        cells.append(str(ndiv) if ndiv else "")
        rows.append(cells)
    return markdown_table(["reading (one factor changed)"] + [h for h, _ in columns] + ["diverged runs"], rows)


def specification_curve(mv: Multiverse, effect: str, *, ylabel: str, title: str, published: float | None = None,
                        interval: float = verdicts.SIGMA_FACTOR, symlog: bool = False) -> matplotlib.figure.Figure:
    """Universes sorted by an effect (value ± ``interval`` standard errors; the verdict rule's band),
    the headline in red, the published value dashed, and below it which option each universe uses
    (Simonsohn, Simmons & Nelson 2020)."""
    import matplotlib
    import matplotlib.pyplot as plt
    _multiverse(mv)
    for value, arg in ((effect, "effect"), (ylabel, "ylabel"), (title, "title")):
        if not isinstance(value, str):
            raise ValueError(f"{arg}: expected a string, got {value!r}")
    if published is not None:
        verdicts._real(published, "published")
    interval = _positive(interval, "interval")
    check_bool(symlog, "symlog")
    vals = [mv.effect(u, effect) for u in mv.universes]
    y = np.array([np.nan if v.value is None else v.value for v in vals])
    se = np.array([0.0 if v.stderr is None else v.stderr for v in vals])
    order = np.argsort(np.where(np.isfinite(y), y, np.inf), kind="stable")
    n = len(order)
    factors = mv.space.factors
    n_rows = sum(len(f.options) for f in factors)
    fig, (ax, axp) = plt.subplots(2, 1, figsize=(max(7.5, min(16, 0.09 * n + 6)), 3.6 + 0.16 * n_rows),
                                  sharex=True, gridspec_kw={"height_ratios": [3.2, 0.16 * n_rows + 0.4]})
    x = np.arange(n)
    ys, ses = y[order], se[order]
    head_pos = int(np.where(order == 0)[0][0])
    has = np.isfinite(ys)
    no_se = has & np.array([vals[i].stderr is None for i in order])       # e.g. a single surviving run
    plain = has & ~no_se & (x != head_pos)
    ax.errorbar(x[has], ys[has], yerr=interval * ses[has], fmt="none", ecolor="0.6", elinewidth=0.8, zorder=1)
    ax.scatter(x[plain], ys[plain], c="C0", s=14, zorder=2, label="universe (± %g s.e.)" % interval)
    if no_se.any():
        ax.scatter(x[no_se], ys[no_se], facecolors="none", edgecolors="C0", s=30, zorder=2,
                   label=f"no standard error ({int(no_se.sum())}: a single run)")
    if has[head_pos]:
        ax.scatter([head_pos], [ys[head_pos]], c="C3", s=40, marker="D", zorder=3, label="headline reading")
    ax.axhline(0.0, color="k", lw=0.8)
    pub = published if published is not None else vals[0].published
    if pub is not None:
        ax.axhline(pub, color="C2", ls="--", lw=1.2, label=f"published ({pub:.3g})")
    if symlog:        # linear within the decade of the smallest |effect|, logarithmic beyond
        finite = np.abs(np.concatenate([y[np.isfinite(y) & (y != 0)], [pub] if pub else []]))
        linthresh = 10.0 ** np.floor(np.log10(np.min(finite))) if finite.size else 1.0
        ax.set_yscale("symlog", linthresh=linthresh, linscale=0.6)
        ax.yaxis.set_minor_locator(matplotlib.ticker.NullLocator())
        ax.yaxis.set_major_locator(matplotlib.ticker.SymmetricalLogLocator(base=10, linthresh=linthresh,
                                                                          subs=[1.0]))
    # the limits hold every value, its band and the published value, with room at both ends
    ends = [v for v in np.concatenate([ys[has] - interval * ses[has], ys[has] + interval * ses[has]])] + \
        ([pub] if pub is not None else []) + [0.0]
    lo, hi = min(ends), max(ends)
    if symlog:
        grow = (lambda v, f: v * f if abs(v) > linthresh else v + np.sign(v or 1) * linthresh)
        ax.set_ylim(grow(lo, 3.0) if lo < 0 else -linthresh, grow(hi, 3.0) if hi > 0 else linthresh)
    else:
        pad = 0.08 * (hi - lo or 1.0)
        ax.set_ylim(lo - pad, hi + pad)
    missing = np.where(~has)[0]
    if missing.size:              # no universe is dropped silently: marked along the bottom, apart from the data
        strip = matplotlib.transforms.blended_transform_factory(ax.transData, ax.transAxes)
        ax.scatter(missing, np.full(missing.size, 0.03), transform=strip, marker="x", c="k", s=30, zorder=3,
                   clip_on=False, label=f"no value ({missing.size} universes: every run diverged)")
        if not has[head_pos]:
            ax.scatter([head_pos], [0.03], transform=strip, marker="D", facecolors="none", edgecolors="C3", s=60,
                       zorder=4, clip_on=False, label="headline reading (no value)")
    ax.set(ylabel=ylabel, title=title)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    axp.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    row, yt, ylab = 0, [], []
    for f in factors:
        for o in f.options:
            used = [j for j, i in enumerate(order) if mv.readings[i][f.id] == o.name]
            axp.scatter(used, [row] * len(used), s=8, marker="s",
                        c="C3" if o.name == f.headline else "0.25")
            yt.append(row)
            ylab.append(f"{f.id}: {o.label}"[:64])
            row += 1
        axp.axhline(row - 0.5, color="0.8", lw=0.6)
    axp.set_yticks(yt)
    axp.set_yticklabels(ylab, fontsize=7)
    axp.set_ylim(row - 0.5, -0.5)
    axp.set_xlabel(f"universe, sorted by the effect ({n} universes; headline options in red)")
    axp.grid(False)
    fig.tight_layout()
    return fig


def table_match_figure(mv: Multiverse, *, title: str) -> matplotlib.figure.Figure:
    """Per published table, the sum of squared standardized distances of each universe (sorted),
    the headline and the best match (:meth:`Multiverse.table_match`: among the precise universes, the smallest
    root-mean-square relative distance) marked; the universes with a cell not precise enough are ringed."""
    import matplotlib.pyplot as plt
    _multiverse(mv)
    if not isinstance(title, str):
        raise ValueError(f"title: expected a string, got {title!r}")
    tables = [t for t in mv.tables if any(s is not None for s in mv.table_distances(t))]
    fig, axes = plt.subplots(1, len(tables), figsize=(4.2 * len(tables) + 1, 3.8), squeeze=False)
    for ax, table in zip(axes[0], tables):
        sums = np.array([np.nan if s is None else s for s in mv.table_distances(table)])
        order = np.argsort(np.where(np.isfinite(sums), sums, np.inf), kind="stable")
        ax.plot(np.arange(len(order)), sums[order], ".", color="C0", ms=4, label="universe")
        hp = int(np.where(order == 0)[0][0])
        ax.plot([hp], [sums[0]], "D", color="C3", ms=7, label="headline")
        pubs = [p for p in mv.published if p.table == table]
        precise = mv.table_precise(table)
        vague = [k for k, i in enumerate(order) if not precise[i]]
        if vague:
            ax.plot(vague, sums[order][vague], "o", mfc="none", mec="0.5", ms=6,
                    label=f"a cell's s.e. > {100 * PRECISION:.0f} % ({len(vague)}; not eligible)")
        best = {t["table"]: t for t in mv.table_match()}[table]["best_universe"]
        if best is not None:
            bp = int(np.where(order == best)[0][0])
            ax.plot([bp], [sums[best]], "*", color="C2", ms=11, label="best match (precise; RMS relative distance)")
        n_cells = len(pubs)
        ax.axhline(9.0 * n_cells, color="0.4", ls=":", lw=1, label="every cell at 3 s.e.")
        failed = np.where(np.isinf(sums[order]))[0]      # a cell whose algorithm failed (e.g. diverged)
        if failed.size:
            finite = sums[np.isfinite(sums)]
            top = 3.0 * max(float(finite.max()) if finite.size else 1.0, 9.0 * n_cells)
            ax.plot(failed, np.full(failed.size, top), "x", color="k", ms=5,
                    label=f"a cell failed ({failed.size}; drawn at the top)")
            if np.isinf(sums[0]):
                ax.plot([hp], [top], "D", color="C3", ms=7)
        ax.xaxis.set_major_locator(__import__("matplotlib").ticker.MaxNLocator(integer=True))
        ax.set(yscale="log", xlabel="universe, sorted", ylabel="Σ z² over the table's cells",
               title=f"{table} ({n_cells} cells)")
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def summary_line(mv: Multiverse | dict) -> str:
    """Per paper, in one line: the most cells of each published table that one reading reproduces (isolated
    coincidences not counted), and how many claim verdicts are robust across the reading space with its weighting
    (from a Multiverse or its stored form)."""
    parts = []
    for t in _summary(mv, "table_match"):
        by = f", by {t['most_describe']}" if t["most_n_reproduced"] else ""
        parts.append(f"{t['table']}: {'a' if t['most_n_reproduced'] == t['n_cells'] else 'no'} reading reproduces "
                     f"all {t['n_cells']} cells (at most {t['most_n_reproduced']}{by}; headline universe "
                     f"{t['headline_n_reproduced']})")
    claims = _summary(mv, "claims_summary")
    if claims and all(c["share"] is None for c in claims):
        return "; ".join(parts + [f"claim verdicts: {claims[0]['robustness']}"])
    robust = sum(bool(c["robust"]) for c in claims)
    return "; ".join(parts + [f"{robust} of {len(claims)} claim verdicts robust across the reading space "
                              f"({_weighting_note(claims)})"])
